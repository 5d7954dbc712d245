"""The Python API type-checks from a user's program: ``mypy --strict`` on the documented tracker module and its
registration (docs/how-to/new-tracker.md), the documented planner (docs/how-to/new-planner.md) and a short script
using the API finds nothing. It found the packages untyped (no ``py.typed``: "module is installed, but missing
library stubs or py.typed marker"), ``register_tracker("p-pose", PoseP)`` an incompatible type (the Tracker
protocol's ``name`` an instance variable, the trackers' a class variable) and ``from planning import Scenario``
not explicitly exported."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

from tests.doc_blocks import ROOT, block_of

PACKAGES = ("planning", "control", "sim")

#: A user's script: plans, makes and drives a tracker, simulates; the built-in trackers are Trackers.
SCRIPT = """\
from __future__ import annotations

from control import DynamicFBL, FBLGains, SegmentedTracker, Tracker, make_tracker
from planning import (
    Planner, PlanProblem, PlanStatus, Pose2D, Scenario, densify_path, load_robot, load_scenario, make_planner,
    make_reference, path_length,
)
from planning.scenario import Scenario as ScenarioType  # where nhsim's own modules import it from
from planning.scenario import random_scenario
from sim import RunKind, simulate_reference

from mypackage.pose_p import PoseP


def main() -> float:
    scenario: Scenario = load_scenario("open")
    drawn: ScenarioType = random_scenario("edumip", 3)
    planner: Planner = make_planner("rrt")
    result = planner.plan(PlanProblem.from_scenario(scenario, seed=0))
    ok: bool = result.status is PlanStatus.SUCCESS
    robot = load_robot("turtlebot3")
    trackers: list[Tracker] = [PoseP(robot), SegmentedTracker(robot), DynamicFBL(robot)]
    tracker = make_tracker("fbl", robot, gains=FBLGains(kp=9.0, kd=6.0))
    tracker.reset(make_reference("circle", robot, Pose2D(0.0, 0.0, 0.0), radius=1.0), dt=0.02)
    v, omega = tracker.command(0.0, 0.0, 0.0, 0.0)
    job = simulate_reference("open", reference="circle", runs=[RunKind.CLOSED_LOOP])
    err: float = job.metrics[RunKind.CLOSED_LOOP].final_position_error_m
    dense = densify_path(result.path, 0.02)
    return err + v + omega + path_length(dense) + float(ok) + len(trackers) + len(drawn.world.obstacles)
"""


def _registration() -> str:
    """The registration block of new-tracker.md's step 5 (indented in the list), as written: a module of its own
    (it imports PoseP itself)."""
    text = (ROOT / "docs/how-to/new-tracker.md").read_text()
    found = re.findall(r"\n( *)```python\n(.*?)\n\1```", text, flags=re.S)
    blocks = [textwrap.dedent(code) for _, code in found if 'register_tracker("p-pose", PoseP)' in code]
    assert len(blocks) == 1, 'new-tracker.md should show register_tracker("p-pose", PoseP) in one block'
    return blocks[0] + "\n"


def test_the_packages_ship_py_typed_and_the_build_includes_it() -> None:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    for package in PACKAGES:
        assert (ROOT / package / "py.typed").is_file(), f"{package}/py.typed is missing"
        assert "py.typed" in data.get(package, []), f"pyproject's package-data does not ship {package}/py.typed"


@pytest.mark.slow  # mypy --strict over the documented examples: 7 s, kept out of the default run
def test_mypy_strict_accepts_the_documented_tracker_planner_and_an_api_script(tmp_path: Path) -> None:
    """Run as a user would: the packages found on the path (PYTHONPATH, which mypy treats as installed
    packages, so it reads them only with their ``py.typed``), no nhsim configuration, mypy's cache in tmp."""
    pytest.importorskip("mypy")
    (tmp_path / "mypackage").mkdir()
    (tmp_path / "mypackage" / "__init__.py").write_text("")
    (tmp_path / "mypackage" / "pose_p.py").write_text(block_of("docs/how-to/new-tracker.md").code)
    (tmp_path / "mypackage" / "trackers.py").write_text(_registration())
    (tmp_path / "mypackage" / "tdt.py").write_text(block_of("docs/how-to/new-planner.md").code)
    (tmp_path / "use_api.py").write_text(SCRIPT)
    (tmp_path / "mypy.ini").write_text("[mypy]\n")  # none of the user's or the repository's settings
    env = {k: v for k, v in os.environ.items() if k not in ("MYPYPATH", "MYPY_CACHE_DIR")}
    env["PYTHONPATH"] = str(ROOT)
    files = ["use_api.py", "mypackage/pose_p.py", "mypackage/trackers.py", "mypackage/tdt.py"]
    proc = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--config-file", "mypy.ini", "--cache-dir", ".cache", *files],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert f"Success: no issues found in {len(files)} source files" in proc.stdout
