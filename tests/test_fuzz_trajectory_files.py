"""Property-based tests of trajectory file import on files shaped like published ones
(:func:`tests.fuzz_helpers.timed_files`: irregular stamps, repeated stamps where drives meet, given
derivatives that agree or not, stand-stills, reversals, pixel units).

Properties: every file either becomes a valid trajectory in an arena around it (strictly increasing
stamps, finite values, starting and ending where the file does) or is refused with a
TrajectoryFileError naming its row; a drawn fault is refused naming the row it was put in, never run.
Two files (50 in the slow suite) are run through ``nhsim simulate`` too: exit 0 or 1 with a record, or 2 naming the row.
"""

from __future__ import annotations

import atexit
import io
import re
import shutil
import tempfile
from contextlib import chdir, redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from hypothesis import event, given, settings

from planning.core.robot import load_robot
from planning.trajectory.file_formats import TrajectoryFileError
from planning.trajectory.file_trajectory import arena_scenario, file_trajectory
from planning.trajectory.importer import TrajectoryFile, read_trajectory_file
from sim.cli.main import main
from tests.fuzz_helpers import FAST, SLOW, TimedFile, assert_finite, expect_nhsim_errors, fast_and_slow, timed_files

ROBOTS = {name: load_robot(name) for name in ("edumip", "turtlebot3")}
_WORKDIR = Path(tempfile.mkdtemp(prefix="nhsim-fuzz-files-"))
atexit.register(shutil.rmtree, _WORKDIR, ignore_errors=True)
_ROW = re.compile(r"\bline \d+\b")


def _write(f: TimedFile) -> Path:
    path = Path(tempfile.mkdtemp(dir=_WORKDIR)) / "drawn.csv"
    path.write_text(f.text)
    return path


def _source(f: TimedFile, path: Path) -> TrajectoryFile:
    return TrajectoryFile(path, columns=f.columns, scale=f.scale)


def import_property(f: TimedFile) -> None:
    path = _write(f)
    robot = ROBOTS["edumip" if len(f.text) % 2 else "turtlebot3"]

    def build() -> tuple[object, object]:
        imported = read_trajectory_file(_source(f, path))
        arena = arena_scenario(imported, robot)
        return imported, file_trajectory(imported, robot, arena.world)

    result, err = expect_nhsim_errors(build)
    if f.refused_at is not None:
        assert isinstance(err, TrajectoryFileError), f"{f.why}: a fault at {f.refused_at} ran ({err!r})"
        assert f.refused_at in str(err), f"{f.why}: {err}"
        event("refused: the drawn fault")
        return
    if err is not None:
        assert isinstance(err, TrajectoryFileError) and _ROW.search(str(err)), f"{f.why}: {type(err).__name__}: {err}"
        event("refused naming a row")
        return
    imported, res = result  # type: ignore[misc]
    traj = res.trajectory  # type: ignore[attr-defined]
    assert traj is not None and res.success, f"{f.why}: {res.reason}"  # type: ignore[attr-defined]
    assert np.all(np.diff(traj.t) > 0.0), f.why
    assert_finite([traj.t, traj.pose, traj.vel, traj.acc], "trajectory")
    xy = imported.xy  # type: ignore[attr-defined]
    assert np.hypot(*(traj.pose[0, :2] - xy[0])) < 1e-6 and np.hypot(*(traj.pose[-1, :2] - xy[-1])) < 1e-6, f.why
    event("re-timed" if imported.report.retimed else "timing kept")  # type: ignore[attr-defined]


test_import_fast, test_import_slow = fast_and_slow(timed_files(), import_property, fast=20)


def _run_cli(argv: list[str], where: Path) -> tuple[int, str]:
    """Exit status and stderr of ``nhsim ARGV`` run in the folder ``where`` (its renders/ are its own)."""
    err = io.StringIO()
    with chdir(where), redirect_stdout(io.StringIO()), redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
    return code, err.getvalue()


def simulate_property(f: TimedFile) -> None:
    path = _write(f)
    out = path.parent / "run.json"
    argv = ["simulate", "--trajectory", str(path), "--robot", "edumip", "--no-video", "--json", str(out)]
    if f.columns:
        argv += ["--columns", ",".join(f.columns)]
    if f.scale:
        argv += ["--scale", str(f.scale)]
    code, err = _run_cli(argv, path.parent)
    if f.refused_at is not None:
        assert code == 2 and f.refused_at in err and not out.exists(), (f.why, code, err)
    elif code == 2:
        assert _ROW.search(err) and not out.exists(), (f.why, err)
    else:
        assert code in (0, 1) and out.exists(), (f.why, code, err)


test_simulate_fast = settings(FAST, max_examples=2)(given(timed_files())(simulate_property))
# a simulate run costs seconds: the slow suite runs 50 of them, not SLOW's 1000
test_simulate_slow = pytest.mark.slow(settings(SLOW, max_examples=50)(given(timed_files())(simulate_property)))
