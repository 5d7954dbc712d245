"""CasADi for nhsim's optimisers ('optim' planner, 'mpc' tracker): imported on first use, with the
OpenBLAS its wheels bundle on one thread, so a solve gives the same bits on every machine.

CasADi's wheels carry their own OpenBLAS (``libcasadi-tp-openblas``), which IPOPT's linear solver
(MUMPS) calls. By default it runs one thread per core, and the last bits of a solve depend on that
count: the 'optim' plan of ``parking_lot`` for the balancing EduMIP came out 4.432270348152941 m long
in a two-core process and 4.432270348152942 m on a Dask worker (whose nanny sets
``OPENBLAS_NUM_THREADS=1``), so ``nhsim simulate --all --jobs 1`` and ``--jobs 2`` disagreed, and a
machine with another core count would too. On nhsim's problem sizes one thread costs nothing (that
plan takes 2.8 s either way).
"""

from __future__ import annotations

import ctypes
import functools
import re
import threading
from pathlib import Path
from typing import Any

from planning.errors import DependencyError

#: Held by every CasADi solve and set-up (the 'optim' planner's, the 'mpc' tracker's): both keep their solvers for
#: the process (one NLP a shape, one solver a horizon), and a solver, or IPOPT's MUMPS under two solvers, run from two
#: threads at once crashed the interpreter ("Solver ipopt is already in use", then a heap corruption). One solve at a
#: time in a process; processes (nhsim's executors, Dask's workers) solve at once.
SOLVER_LOCK = threading.RLock()
#: The OpenBLAS of CasADi's wheels, in the package's folder.
OPENBLAS_GLOB = "libcasadi-tp-openblas.so*"


def casadi_module(user: str) -> Any:
    """The ``casadi`` module, its bundled OpenBLAS set to one thread (once per process).

    Args:
        user: What needs it, for the error ("the 'optim' planner").

    Raises:
        DependencyError: CasADi is not installed.
    """
    try:
        import casadi
    except ImportError as exc:  # pragma: no cover - casadi is a hard dependency
        raise DependencyError(f"{user} needs CasADi: pip install 'casadi>=3.6'") from exc
    _one_thread()
    return casadi


@functools.cache
def _bundled_openblas() -> Any:
    """CasADi's bundled OpenBLAS (a ``ctypes.CDLL``), None for a build without one (e.g. one linked
    against the system's BLAS).

    The wheels carry the library three times as separate files (``.so``, ``.so.0``, ``.so.0.3``, not links).
    IPOPT's plugin loads the one its soname names (``.so.0``); loading another by its path maps a second copy,
    whose thread count is not the solver's: a process that solved with IPOPT before setting the count (a test
    calling CasADi directly first) kept a thread per core, and its plans their last bits. So the copy named
    like a soname (one version number) is the one taken."""
    import casadi

    paths = sorted(Path(casadi.__file__).parent.glob(OPENBLAS_GLOB))
    sonames = [p for p in paths if re.fullmatch(r".*\.so\.\d+", p.name)]
    for path in sonames or paths:
        return ctypes.CDLL(str(path))
    return None


@functools.cache
def _one_thread() -> None:
    lib = _bundled_openblas()
    if lib is not None:
        lib.openblas_set_num_threads(1)


def blas_threads() -> int | None:
    """Threads of CasADi's bundled OpenBLAS in this process (None without it)."""
    lib = _bundled_openblas()
    return None if lib is None else int(lib.openblas_get_num_threads())
