"""Running ``nhsim`` in the test's own process: its exit status and what it printed, as a subprocess would
give them, without a new interpreter's start and imports (a second or more a call on two cores). For what a
subprocess alone shows (signals, the console's handling of stdout, the default outputs' folder), run
``python -m sim`` (``tests.test_cli.nhsim``)."""

from __future__ import annotations

import contextlib
import io
import subprocess


def nhsim_here(*args: str) -> subprocess.CompletedProcess[str]:
    """``nhsim ARGS`` run in this process (its exit status and what it printed)."""
    from sim.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:  # a usage error (argparse exits 2)
            code = int(exc.code or 0)
    return subprocess.CompletedProcess(["nhsim", *args], code, out.getvalue(), err.getvalue())
