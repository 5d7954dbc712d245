"""Calling a compiled kernel once per control period without numba's per-call type dispatch.

A numba dispatcher works out the numba type of every argument on every call to pick the compiled
overload. For float arrays and scalars that is quick; for a structured array (a tracker's or a
firmware's state record, a reference table) it goes through numba's general ``typeof`` and costs
several times the kernel's own arithmetic (measured: 4.5 us against 0.5 us for the FBL's period).
A loop that hands the same arrays to the same kernel every period resolves the overload once,
with :func:`bind`, and calls its compiled entry point directly: the same machine code, the same
results, without the type resolution. The resolution itself is remembered by the arguments'
fingerprints (numba's own key of its type cache), so binding a new run's arrays of the same types
costs microseconds, not the ~0.1 ms of typing a record array afresh.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from numba._dispatcher import compute_fingerprint
from numba.core.dispatcher import Dispatcher

#: Entry points by (kernel, the arguments' fingerprints), each with the dtypes its fingerprints name
#: (a record dtype's fingerprint holds its address: holding the dtype keeps the address its own).
_RESOLVED: dict[tuple[Any, ...], tuple[Callable[..., Any], tuple[Any, ...]]] = {}
#: Entries kept at most (a run binds a handful; tests build dtypes of their own).
_MAX_RESOLVED = 256


def bind(kernel: Callable[..., Any], *bound: Any, free: tuple[Any, ...] = ()) -> Callable[..., Any]:
    """``kernel`` with its leading arguments fixed, called without type dispatch.

    The overload is the one the dispatcher itself would choose for ``(*bound, *free)`` (compiled or
    loaded from numba's cache now if it is not yet); the returned callable takes the remaining
    arguments. Its arrays are bound for good, so the entry point, which does not check the types
    of the arrays it is given, only ever sees the arrays it was resolved for; the free arguments
    are converted as numba converts them (a scalar of another type is converted, a wrong count or
    a non-number raises TypeError).

    Args:
        kernel: A numba-compiled function (any other callable is bound with ``functools.partial``).
        *bound: Its leading arguments, the same objects at every call (e.g. a run's state arrays).
        free: Example values of the remaining arguments: their types select the overload (e.g.
            ``(0.0, 0.0)`` for two float64 arguments, ``(0,)`` for one int64).

    Returns:
        ``f(*rest)``, equal to ``kernel(*bound, *rest)``.
    """
    if not isinstance(kernel, Dispatcher):
        return functools.partial(kernel, *bound)
    call = _Bound(_entry(kernel, (*bound, *free)), *bound)
    call.rebind = (kernel, bound, free)
    return call


class _Bound(functools.partial):  # type: ignore[type-arg]
    """:func:`bind`'s callable: a partial of the overload's entry point (as fast to call), which pickles as the
    kernel bound again to its arguments: an entry point is a compiled closure, which pickle cannot take, so a
    tracker holding one could not be pickled or sent to another process."""

    rebind: tuple[Any, tuple[Any, ...], tuple[Any, ...]]

    def __reduce__(self) -> tuple[Any, ...]:
        kernel, bound, free = self.rebind
        return _rebound, (kernel, bound, free)


def _rebound(kernel: Callable[..., Any], bound: tuple[Any, ...], free: tuple[Any, ...]) -> Callable[..., Any]:
    """An unpickled :func:`bind`: ``kernel`` bound to the unpickled arguments."""
    return bind(kernel, *bound, free=free)


def _entry(kernel: Dispatcher, args: tuple[Any, ...]) -> Callable[..., Any]:
    """The entry point of the overload ``kernel`` chooses for ``args`` (compiled or loaded if new)."""
    try:
        key = (kernel, *(compute_fingerprint(a) for a in args))
    except (TypeError, ValueError, NotImplementedError):  # a value numba fingerprints not: type it afresh
        return kernel.compile(tuple(kernel.typeof_pyval(a) for a in args))
    hit = _RESOLVED.get(key)
    if hit is None:
        entry = kernel.compile(tuple(kernel.typeof_pyval(a) for a in args))
        if len(_RESOLVED) >= _MAX_RESOLVED:
            _RESOLVED.clear()
        hit = _RESOLVED[key] = (entry, tuple(getattr(a, "dtype", None) for a in args))
    return hit[0]
