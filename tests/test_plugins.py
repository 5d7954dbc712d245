"""Registering trackers and planners: what ``register_tracker`` accepts, the plugin hook that brings a user's
tracker or planner to the ``nhsim`` command (entry points of groups ``nhsim.trackers`` and ``nhsim.planners``,
``NHSIM_PLUGINS``) and to ``tune --jobs`` workers, and ``tune``'s outputs for a tracker without a gains file."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import optuna
import pytest

from control import base
from control.base import (
    BASELINES,
    BY_CODE,
    PLUGIN_GROUP,
    PLUGIN_VARIABLE,
    TRACKERS,
    feedback_trackers,
    in_every_process,
    make_tracker,
    option_takes,
    register_tracker,
    tracker_origin,
)
from control.fbl import DynamicFBL
from control.gains import FBLGains
from control.kanayama import KanayamaParams
from control.open_loop import OpenLoop
from planning.core.robot import load_robot
from planning.errors import ConfigError
from planning.planners.registry import PLANNERS, make_planner
from planning.planners.registry import PLUGIN_GROUP as PLANNER_GROUP
from sim.cli.main import main
from tests.registry_helpers import isolated

ROOT = Path(__file__).resolve().parents[1]


class MyFBL(DynamicFBL):
    """A tracker of the test's own (the FBL under another name), registered by the test's code."""


@pytest.fixture
def registry(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """The registries as they are now, restored after the test, with their plugins unloaded (the next lookup
    loads them); the plugin modules the test imported are forgotten again."""
    monkeypatch.setattr(base, "BASELINES", set(BASELINES))
    with isolated(monkeypatch, (TRACKERS, PLANNERS), "unloaded"):
        yield


def _package(site: Path, entry_points: dict[str, str], modules: dict[str, str], group: str = PLUGIN_GROUP) -> Path:
    """An installed package in folder ``site``: its modules and a ``.dist-info`` declaring the entry
    points of ``group`` (``nhsim.trackers`` by default; as ``pip install`` leaves them)."""
    site.mkdir(exist_ok=True)
    for name, code in modules.items():
        (site / f"{name}.py").write_text(code)
    info = site / "nhsim_test_plugins-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: nhsim-test-plugins\nVersion: 1.0\n")
    lines = "".join(f"{name} = {value}\n" for name, value in entry_points.items())
    (info / "entry_points.txt").write_text(f"[{group}]\n{lines}")
    return site


FBL2 = "from control.fbl import DynamicFBL\n\n\nclass FBL2(DynamicFBL):\n    name = 'fbl2'\n"
REGISTERS = "from control.base import register_tracker\nfrom control.fbl import DynamicFBL\n\n"


# ---- register_tracker checks what it is given ------------------------------------------------------------
@pytest.mark.parametrize("name", ["", "a,b", "a b", "p-pose\n", 123, None])
def test_a_name_that_cannot_be_given_on_the_command_line_is_refused(registry: None, name: object) -> None:
    with pytest.raises(ConfigError, match="name must be non-empty text without commas or whitespace"):
        register_tracker(name, MyFBL)  # type: ignore[arg-type]
    assert name not in TRACKERS


@pytest.mark.parametrize("target", ["mypackage.pose_p", "a:b:c", ":PoseP", "mypackage:", "my package:P", 42, None])
def test_a_target_that_is_neither_a_factory_nor_module_attr_is_refused(registry: None, target: object) -> None:
    with pytest.raises(ConfigError, match=r"register_tracker\('x1'\): target") as err:
        register_tracker("x1", target)  # type: ignore[arg-type]
    assert "mypackage.pose_p:PoseP" in str(err.value) or "module:attr" in str(err.value)
    assert "x1" not in TRACKERS


def test_a_registered_name_is_replaced_only_when_asked(registry: None) -> None:
    with pytest.raises(ConfigError, match=r"tracker 'fbl' is already registered \(built in\) as control.fbl:Dyn"):
        register_tracker("fbl", MyFBL)
    assert TRACKERS["fbl"] == "control.fbl:DynamicFBL"
    register_tracker("mine", MyFBL)
    register_tracker("mine", MyFBL)  # the same again (a plugin module imported twice): nothing replaced
    with pytest.raises(ConfigError, match=rf"'mine' is already registered \({BY_CODE}\) as .*MyFBL; .*replace=True"):
        register_tracker("mine", OpenLoop)
    register_tracker("mine", OpenLoop, baseline=True, replace=True)
    register_tracker("fbl", MyFBL, replace=True)
    assert TRACKERS["mine"] is OpenLoop and TRACKERS["fbl"] is MyFBL and "mine" not in feedback_trackers()


@pytest.mark.parametrize(
    ("target", "error"),
    [
        ("nhsim_test_no_such_module:Tracker", "ModuleNotFoundError: No module named 'nhsim_test_no_such_module'"),
        ("control.fbl:NoSuchTracker", "AttributeError: module 'control.fbl' has no attribute 'NoSuchTracker'"),
        ("control.base:PLUGIN_GROUP", "is not callable"),
    ],
)
def test_a_target_that_fails_to_load_names_the_tracker_and_the_target(registry: None, target: str, error: str) -> None:
    register_tracker("x1", target)  # imported when first used
    with pytest.raises(ConfigError) as err:
        make_tracker("x1", load_robot("turtlebot3"))
    assert f"tracker 'x1' ({BY_CODE})" in str(err.value) and repr(target) in str(err.value) and error in str(err.value)


def test_the_fbl_gains_option_is_known_by_its_declared_type(registry: None) -> None:
    takes = {name: option_takes(name, "gains", FBLGains) for name in ("fbl", "segmented", "kanayama", "mpc", "rpp")}
    assert takes == {"fbl": True, "segmented": True, "kanayama": False, "mpc": False, "rpp": False}
    assert not option_takes("open-loop", "gains", FBLGains)  # no such option

    class Unresolved(DynamicFBL):
        def __init__(self, robot: object, *, gains: FBLGains | NotDefined | None = None) -> None:  # type: ignore[name-defined] # noqa: F821
            super().__init__(robot, gains=gains)  # type: ignore[arg-type]

    register_tracker("unresolved", Unresolved)
    assert option_takes("unresolved", "gains", FBLGains)  # read from the annotation's text
    assert not option_takes("unresolved", "params", FBLGains)


# ---- plugins, in this process ----------------------------------------------------------------------------
def _env_plugin(folder: Path, monkeypatch: pytest.MonkeyPatch, variable: str) -> None:
    """A plugin module ``nhsim_test_env_plugin`` in ``folder`` (on the path) registering the tracker 'env-fbl', and
    NHSIM_PLUGINS set to ``variable``."""
    (folder / "nhsim_test_env_plugin.py").write_text(REGISTERS + "register_tracker('env-fbl', DynamicFBL)\n")
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setenv(PLUGIN_VARIABLE, variable)


def test_a_module_named_by_the_variable_is_imported_at_the_first_lookup(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _env_plugin(tmp_path, monkeypatch, " nhsim_test_env_plugin, ")
    assert "nhsim_test_env_plugin" not in sys.modules
    assert "env-fbl" in feedback_trackers()
    origin = f"from module 'nhsim_test_env_plugin' named by {PLUGIN_VARIABLE}= nhsim_test_env_plugin, "
    assert tracker_origin("env-fbl") == origin and in_every_process("env-fbl")
    assert make_tracker("env-fbl", load_robot("turtlebot3")).name == "fbl"


def test_entry_points_register_a_tracker_lazily_or_import_a_module(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    modules = {"nhsim_test_ep_fbl2": FBL2, "nhsim_test_ep_mod": REGISTERS + "register_tracker('mod-fbl', DynamicFBL)\n"}
    entry_points = {"fbl2": "nhsim_test_ep_fbl2:FBL2", "mine": "nhsim_test_ep_mod"}
    monkeypatch.syspath_prepend(str(_package(tmp_path / "site", entry_points, modules)))
    assert {"fbl2", "mod-fbl"} <= set(feedback_trackers())
    assert "nhsim_test_ep_fbl2" not in sys.modules  # imported when first used
    package = f"of group {PLUGIN_GROUP} in nhsim-test-plugins 1.0"
    assert tracker_origin("fbl2") == f"from entry point 'fbl2 = nhsim_test_ep_fbl2:FBL2' {package}"
    assert tracker_origin("mod-fbl") == f"from entry point 'mine = nhsim_test_ep_mod' {package}"
    assert make_tracker("fbl2", load_robot("turtlebot3")).name == "fbl2"
    assert in_every_process("fbl2") and in_every_process("fbl") and not in_every_process("nobody")


@pytest.mark.parametrize(
    ("plugin", "label", "error"),
    [
        ("nhsim_test_missing", "plugin", "ModuleNotFoundError: No module named 'nhsim_test_missing'"),
        ("nhsim_test_raises", "plugin", "RuntimeError: no licence"),
        (
            "nhsim_test_clashes",
            "tracker plugin",
            "ConfigError: register_tracker: tracker 'fbl' is already registered (built in)",
        ),
    ],
)
def test_a_plugin_that_fails_is_a_clear_error_of_any_command_that_looks_up_a_tracker(
    registry: None,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    plugin: str,
    label: str,
    error: str,
) -> None:
    """A module named by the variable serves every registry: its failure is a plugin's, and a registry's only when
    that registry refused what it registered."""
    (tmp_path / "nhsim_test_raises.py").write_text("raise RuntimeError('no licence')\n")
    (tmp_path / "nhsim_test_clashes.py").write_text(
        REGISTERS + "register_tracker('fbl', type('Other', (DynamicFBL,), {}))\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(PLUGIN_VARIABLE, plugin)
    assert main(["compare", "--trackers", "fbl", "--reference", "line", "--quiet"]) == 2
    err = capsys.readouterr().err
    want = f"nhsim compare: error: {label} failed to load: module {plugin!r} named by {PLUGIN_VARIABLE}={plugin}"
    assert err.startswith(f"{want}: {error}") and "Traceback" not in err
    with pytest.raises(ConfigError, match=f"^{label} failed to load"):  # every lookup, not the first only
        "fbl" in TRACKERS  # noqa: B015


def test_a_plugin_python_cannot_find_names_pythonpath(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The how-to pages' ``NHSIM_PLUGINS=mypackage.tdt nhsim plan ...``, run beside ``mypackage/``, failed with "No
    module named 'mypackage'" alone: the nhsim command (unlike ``python -m sim``) does not import from the working
    directory. The error says so and gives the fix; a module missing inside a package Python found gets no such
    hint."""
    (tmp_path / "nhsim_test_pkg").mkdir()
    (tmp_path / "nhsim_test_pkg" / "__init__.py").write_text("")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_pkg.tdt")
    argv = ["compare", "--trackers", "fbl", "--reference", "line", "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert (
        "No module named 'nhsim_test_pkg'; Python looks for it in the folders of sys.path (the nhsim command: not in "
        "the working directory): run it with PYTHONPATH=. (the working directory holds it)" in err
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "No module named 'nhsim_test_pkg.tdt' (NHSIM_TRACEBACK=1" in err and "PYTHONPATH" not in err
    # an installed package's entry point whose module is gone: a broken install, not a path to give
    monkeypatch.delenv(PLUGIN_VARIABLE)
    monkeypatch.syspath_prepend(str(_package(tmp_path / "site", {"ghost": "nhsim_test_ghost"}, {})))
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "No module named 'nhsim_test_ghost'" in err and "PYTHONPATH" not in err


def test_regress_names_a_failing_plugin_as_such_not_as_its_first_case(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "nhsim_test_raises.py").write_text("raise RuntimeError('no licence')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_raises")
    suite = tmp_path / "suite.toml"
    suite.write_text(
        'cases = [{ scenario = "open", robot = "edumip", reference = "line", tracker = "fbl", seed = 0, '
        "control_rate = 50 }]\n"
    )
    assert main(["regress", "--suite", str(suite), "--baselines", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "error: plugin failed to load: module 'nhsim_test_raises'" in err and "case 1" not in err, err


def test_the_documented_error_is_the_one_given(registry: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(PLUGIN_VARIABLE, "mypackage.trackers")
    with pytest.raises(ConfigError) as err:
        feedback_trackers()
    page = " ".join((ROOT / "docs" / "how-to" / "new-tracker.md").read_text().split())
    assert f"`nhsim compare: error: {err.value}`" in page


def test_the_documented_planner_plugin_error_is_the_one_given(registry: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(PLUGIN_VARIABLE, "mypackage.tdt")
    with pytest.raises(ConfigError) as err:
        make_planner("birrt")
    page = " ".join((ROOT / "docs" / "how-to" / "new-planner.md").read_text().split())
    assert f"`nhsim plan: error: {err.value}`" in page


# ---- plugins, in the nhsim command -----------------------------------------------------------------------
def _nhsim(site: Path, *argv: str, cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """``nhsim ARGV`` in a fresh process that sees the packages installed in ``site`` (``env`` added to this
    process's environment, less NHSIM_PLUGINS and NHSIM_TRACEBACK)."""
    inherited = {k: v for k, v in os.environ.items() if k not in (PLUGIN_VARIABLE, "NHSIM_TRACEBACK")}
    path = os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])
    environment = inherited | {"PYTHONPATH": path} | (env or {})
    return subprocess.run(
        [sys.executable, "-m", "sim", *argv], capture_output=True, text=True, env=environment, cwd=cwd
    )


def test_the_command_runs_a_tracker_of_an_installed_entry_point(tmp_path: Path) -> None:
    site = _package(tmp_path / "site", {"fbl2": "nhsim_test_fbl2:FBL2"}, {"nhsim_test_fbl2": FBL2})
    argv = ["compare", "--trackers", "fbl2,kanayama", "--scenario", "open", "--reference", "line", "--quiet"]
    done = _nhsim(site, *argv, "--robot", "turtlebot3", "--json", "c.json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert [line.split()[0] for line in done.stdout.splitlines()[3:5]] == ["fbl2", "kanayama"]
    assert list(json.loads((tmp_path / "c.json").read_text())["trackers"]) == ["fbl2", "kanayama"]


@pytest.mark.slow  # 4 s; compare and simulate run a registered tracker in test_tracker_registration.py
def test_simulate_runs_its_closed_loops_with_any_registered_tracker(tmp_path: Path) -> None:
    """simulate's --tracker picks the runs (fbl, open-loop, both); a plugin's tracker could not drive its closed
    loops: --feedback T now does (an FBL of a plugin takes the FBL's gains, as its declared option says)."""
    site = _package(tmp_path / "site", {"fbl2": "nhsim_test_fbl2:FBL2"}, {"nhsim_test_fbl2": FBL2})
    argv = ["simulate", "--scenario", "open", "--reference", "line", "--robot", "turtlebot3", "--runs", "closed_loop"]
    done = _nhsim(site, *argv, "--feedback", "fbl2", "--no-video", "--json", "s.json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "s.json").read_text())["tracker"] == "fbl2"
    assert "gains Kp=9 Kd=6" in done.stdout.splitlines()[0]
    done = _nhsim(site, *argv, "--feedback", "fbl3", "--no-video", cwd=tmp_path)
    from control.base import TRACKERS

    choose = ", ".join([*TRACKERS.built_in(), "fbl2"])  # the built-in ones sorted, then the plugin's
    assert done.returncode == 2 and f"unknown tracker 'fbl3'; choose {choose}" in done.stderr


def test_simulate_feedback_says_what_it_does_not_use(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """--gains is said to be ignored by a law that does not take them (and the record's gains are null); a
    tracker without feedback is refused; --feedback is said to be ignored when no run feeds back."""
    monkeypatch.chdir(tmp_path)
    argv = ["simulate", "--scenario", "open", "--reference", "line", "--robot", "turtlebot3", "--no-video"]
    assert main([*argv, "--runs", "closed_loop", "--feedback", "kanayama", "--gains", "5,3", "--json", "k.json"]) == 0
    out, err = capsys.readouterr()
    assert "--gains ignored: tracker kanayama does not use the FBL's gains" in err
    assert "tracker kanayama (its own parameters)" in out.splitlines()[0]
    assert json.loads((tmp_path / "k.json").read_text())["gains"] is None  # not its law's
    assert main([*argv, "--feedback", "open-loop"]) == 2
    assert "'open-loop' feeds nothing back" in capsys.readouterr().err
    assert main([*argv, "--runs", "open_loop", "--feedback", "mpc", "--no-plots", "--json", "o.json"]) == 0
    assert "--feedback ignored: no run of open_loop feeds back" in capsys.readouterr().err


def test_version_and_help_load_no_plugin_and_a_broken_one_fails_a_lookup_clearly(tmp_path: Path) -> None:
    marker = tmp_path / "imported"
    modules = {"nhsim_test_marks": f"open({str(marker)!r}, 'w').close()\n", "nhsim_test_broken": "import nowhere\n"}
    site = _package(tmp_path / "site", {"marks": "nhsim_test_marks", "broken": "nhsim_test_broken"}, modules)
    for argv in (["--version"], ["--help"], ["compare", "--help"]):
        done = _nhsim(site, *argv, cwd=tmp_path)
        assert done.returncode == 0 and not marker.exists(), (argv, done.stderr)
    done = _nhsim(site, "compare", "--trackers", "fbl", "--reference", "line", cwd=tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.strip() == (
        "nhsim compare: error: tracker plugin failed to load: entry point 'broken = nhsim_test_broken' of group "
        "nhsim.trackers in nhsim-test-plugins 1.0: ModuleNotFoundError: No module named 'nowhere' (NHSIM_TRACEBACK=1 "
        "prints the ModuleNotFoundError's traceback)"
    )


# ---- planner plugins: the same hook, group nhsim.planners ------------------------------------------------
MINE = "from planning.planners.sampling.rrt import BiRRT\n\n\nclass Mine(BiRRT):\n    name = 'mine'\n"
REGISTERS_MINE = "from planning import register_planner\n\nregister_planner('mod-mine', 'nhsim_test_mine:Mine')\n"
BOTH = (
    REGISTERS
    + "from planning import register_planner\nfrom planning.planners.sampling.rrt import BiRRT\n\n"
    + "register_planner('env-birrt', BiRRT)\nregister_tracker('env-fbl', DynamicFBL)\n"
)


def test_planner_entry_points_register_a_planner_lazily_or_import_a_module(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    modules = {"nhsim_test_mine": MINE, "nhsim_test_pmod": REGISTERS_MINE}
    entry_points = {"mine": "nhsim_test_mine:Mine", "mod": "nhsim_test_pmod"}
    monkeypatch.syspath_prepend(str(_package(tmp_path / "site", entry_points, modules, PLANNER_GROUP)))
    assert {"mine", "mod-mine"} <= set(PLANNERS)
    assert "nhsim_test_mine" not in sys.modules  # imported when first made
    package = f"of group {PLANNER_GROUP} in nhsim-test-plugins 1.0"
    assert PLANNERS.origin("mine") == f"from entry point 'mine = nhsim_test_mine:Mine' {package}"
    assert PLANNERS.origin("mod-mine") == f"from entry point 'mod = nhsim_test_pmod' {package}"
    assert PLANNERS.in_every_process("mine") and not PLANNERS.in_every_process("nobody")
    assert make_planner("mine").name == "mine"
    assert "mine" not in TRACKERS  # the planners' group registers no tracker


def test_one_module_named_by_the_variable_registers_a_planner_and_a_tracker(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "nhsim_test_both.py").write_text(BOTH)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_both")
    assert "env-birrt" in PLANNERS  # the planners' lookup imports it; its tracker is registered then too
    origin = f"from module 'nhsim_test_both' named by {PLUGIN_VARIABLE}=nhsim_test_both"
    assert PLANNERS.origin("env-birrt") == origin and tracker_origin("env-fbl") == origin
    assert "env-fbl" in feedback_trackers() and TRACKERS.plugins == PLANNERS.plugins == "loaded"


def test_simulate_all_runs_a_plugins_planner_only_on_a_scenario_naming_it(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--all --planner P`` for a plugin's P that no swept scenario names ran no case and passed (exit 0); it is
    refused, saying why and what to do. A scenario file naming P sweeps it."""
    (tmp_path / "nhsim_test_both.py").write_text(BOTH)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_both")
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--all", "--scenario", "simple_motion", "--planner", "env-birrt", "--no-video"]) == 2
    err = capsys.readouterr().err
    origin = f"from module 'nhsim_test_both' named by {PLUGIN_VARIABLE}=nhsim_test_both"
    assert f"no case to run: env-birrt ({origin}) is a plugin's planner, which --all runs only on a scenario" in err
    assert "(nhsim simulate --scenario simple_motion --planner env-birrt)" in err and "Traceback" not in err
    scenario = (ROOT / "models" / "scenarios" / "simple_motion.toml").read_text()
    named = re.sub(
        r"(?m)^planner = .*$", 'planner = "env-birrt"', re.sub(r"(?m)^name = .*$", 'name = "env_motion"', scenario)
    )
    (tmp_path / "env.toml").write_text(named)
    argv = ["simulate", "--all", "--scenario", "env.toml", "--robot", "turtlebot3", "--planner", "env-birrt"]
    assert main([*argv, "--quiet", "--no-video", "--json", "all.json"]) == 0, capsys.readouterr()
    rows = json.loads((tmp_path / "all.json").read_text())["rows"]
    assert [(r["scenario"], r["planner"], r["outcome"]) for r in rows] == [("env_motion", "env-birrt", "ok")]


def test_scenarios_stops_at_a_failing_planner_plugin_with_one_line(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``nhsim scenarios`` printed the plugin's error on every row naming a planner (the plugin imported again
    for each), exit 1; a broken scenario file among those listed keeps its own row."""
    import planning.scenario

    (tmp_path / "nhsim_test_raises.py").write_text("raise RuntimeError('no licence')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_raises")
    assert main(["scenarios"]) == 2
    out, err = capsys.readouterr()
    plugin = f"module 'nhsim_test_raises' named by {PLUGIN_VARIABLE}=nhsim_test_raises: RuntimeError: no licence"
    hint = "(NHSIM_TRACEBACK=1 prints the RuntimeError's traceback)"
    assert out == "" and err.splitlines() == [f"nhsim scenarios: error: plugin failed to load: {plugin} {hint}"]
    monkeypatch.delenv(PLUGIN_VARIABLE)
    broken = tmp_path / "broken.toml"
    broken.write_text("name = \n")
    monkeypatch.setattr(planning.scenario, "builtin_scenarios", lambda: ["parking_lot", str(broken)])
    assert main(["scenarios"]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[2].startswith("parking_lot ") and "rrt-star" in lines[2]
    assert lines[3].startswith(f"{broken} error: ") and len(lines) == 4


@pytest.mark.slow  # 4 s: installs a package; an installed tracker's entry point stays in the default run
def test_the_command_plans_and_simulates_with_a_planner_of_an_installed_entry_point(tmp_path: Path) -> None:
    """``nhsim plan --planner P``, ``simulate --planner P`` and a scenario file naming P: the command answered
    "unknown planner" for any planner it did not ship."""
    site = _package(tmp_path / "site", {"mine": "nhsim_test_mine:Mine"}, {"nhsim_test_mine": MINE}, PLANNER_GROUP)
    done = _nhsim(site, "plan", "--scenario", "simple_motion", "--planner", "mine", "--json", "p.json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "p.json").read_text())["planner"] == "mine"
    scenario = (ROOT / "models" / "scenarios" / "simple_motion.toml").read_text()
    (tmp_path / "mine.toml").write_text('planner = "mine"\n' + re.sub(r"(?m)^planner = .*$", "", scenario))
    argv = ["simulate", "--scenario", "mine.toml", "--runs", "closed_loop", "--no-video", "--json", "s.json"]
    done = _nhsim(site, *argv, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "s.json").read_text())["source"] == "planner:mine"


def test_plan_help_loads_no_planner_plugin_and_a_broken_one_fails_a_plan_clearly(tmp_path: Path) -> None:
    marker = tmp_path / "imported"
    modules = {"nhsim_test_marks": f"open({str(marker)!r}, 'w').close()\n", "nhsim_test_broken": "import nowhere\n"}
    entry_points = {"marks": "nhsim_test_marks", "broken": "nhsim_test_broken"}
    site = _package(tmp_path / "site", entry_points, modules, PLANNER_GROUP)
    for argv in (["--version"], ["plan", "--help"], ["simulate", "--help"]):
        done = _nhsim(site, *argv, cwd=tmp_path)
        assert done.returncode == 0 and not marker.exists(), (argv, done.stderr)
    assert "or one a plugin registers" in done.stdout
    done = _nhsim(site, "plan", "--scenario", "simple_motion", "--planner", "birrt", cwd=tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.strip() == (
        "nhsim plan: error: planner plugin failed to load: entry point 'broken = nhsim_test_broken' of group "
        "nhsim.planners in nhsim-test-plugins 1.0: ModuleNotFoundError: No module named 'nowhere' (NHSIM_TRACEBACK=1 "
        "prints the ModuleNotFoundError's traceback)"
    )
    argv = ["plan", "--scenario", "simple_motion", "--planner", "birrt"]
    traced = _nhsim(site, *argv, cwd=tmp_path, env={"NHSIM_TRACEBACK": "1"})
    lines = traced.stderr.splitlines()
    assert traced.returncode == 2 and lines[0] == done.stderr.strip().split(" (NHSIM_TRACEBACK")[0]
    assert lines[1] == "Traceback (most recent call last):" and 'nhsim_test_broken.py", line 1' in traced.stderr
    assert lines[-1] == "ModuleNotFoundError: No module named 'nowhere'"


# ---- tune --jobs: workers know the tracker, or the trials stay in this process -----------------------------
def _tune(tmp_path: Path, tracker: str, *extra: str) -> list[str]:
    return [
        "tune", "--tracker", tracker, "--scenarios", "open:line", "--robot", "turtlebot3", "--trials", "2",
        "--storage", f"sqlite:///{tmp_path}/study.db", "--study", "t", "--json", str(tmp_path / "t.json"),
        "--plots", str(tmp_path), "--draws", "1", "--quiet", *extra,
    ]  # fmt: skip


def test_tune_jobs_runs_a_tracker_registered_by_code_in_this_process(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Worker processes run none of the caller's code: they failed on the unknown name, and the command
    said to rerun, which could not help."""

    def no_workers(*args: object) -> None:
        raise AssertionError("workers started for a tracker they do not know")

    monkeypatch.setattr("sim.cli.tune._run_parallel", no_workers)
    register_tracker("my-fbl", MyFBL)
    argv = _tune(tmp_path, "my-fbl", "--jobs", "2", "--eval-runs", "0", "--out", str(tmp_path / "t.toml"))
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert f"tracker 'my-fbl' is {BY_CODE}, which --jobs worker processes do not run: running the 2 trials" in err
    assert PLUGIN_GROUP in err and PLUGIN_VARIABLE in err
    study = optuna.load_study(study_name="t", storage=f"sqlite:///{tmp_path}/study.db")
    assert len(study.get_trials(states=(optuna.trial.TrialState.COMPLETE,))) == 2


@pytest.mark.slow  # two tuning worker processes
def test_tune_workers_load_the_plugins(tmp_path: Path) -> None:
    site = _package(tmp_path / "site", {"fbl2": "nhsim_test_fbl2:FBL2"}, {"nhsim_test_fbl2": FBL2})
    done = _nhsim(site, *_tune(tmp_path, "fbl2", "--jobs", "2", "--eval-runs", "0"), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "in this process" not in done.stderr
    study = optuna.load_study(study_name="t", storage=f"sqlite:///{tmp_path}/study.db")
    assert len(study.get_trials(states=(optuna.trial.TrialState.COMPLETE,))) == 2


# ---- tune's outputs for a tracker without a gains file ------------------------------------------------------
def test_tune_refuses_out_for_a_tracker_without_a_gains_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(_tune(tmp_path, "kanayama", "--out", str(tmp_path / "t1.toml"))) == 2
    err = capsys.readouterr().err
    assert "--out names the gains file, which holds FBL gains" in err and "give --json FILE" in err
    assert list(tmp_path.iterdir()) == []


def test_tune_says_where_it_wrote_the_default_parameters(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Tuned parameters that lose to the defaults: the defaults go to the record, and the message names it
    (it named a gains file that was never written)."""
    import sim.tools.tune as tune
    from sim.tools.tune import Comparison, Evaluation

    def runs(costs: list[float]) -> Evaluation:
        return Evaluation(sum(costs) / len(costs), 0.01, 0.02, 0.0, 0, len(costs), tuple(costs))

    monkeypatch.setattr(tune, "compare", lambda ev, tuned, draws: Comparison(runs([1.0]), runs([2.0]), draws, ("a",)))
    assert main(_tune(tmp_path, "kanayama", "--eval-runs", "1")) == 1
    err = capsys.readouterr().err
    note = "worse than the defaults on held-out robots: objective 2.000000 m against 1.000000 m (2.00x)"
    assert f"{note}: wrote the default KanayamaParams to {tmp_path / 't.json'}" in err
    assert json.loads((tmp_path / "t.json").read_text())["params"] == json.loads(json.dumps(KanayamaParams().__dict__))
    assert not list(tmp_path.glob("*.toml"))


# ---- a plugin's planner is checked as the commands run it ----------------------------------------------------
class _Raises:
    name = "raises"

    def plan(self, problem: object) -> object:
        raise RuntimeError("boom")


class _Returns:
    """Returns what its ``kind`` says: None, a one-pose "success" (a path to nowhere) or a straight line."""

    name = "returns"

    def __init__(self, *, kind: str = "none") -> None:
        self.kind = kind

    def plan(self, problem: Any) -> object:
        from planning import PlanResult, PlanStatus

        s, g = problem.start, problem.goal
        poses = {"one": [[s.x, s.y, s.theta]], "line": [[s.x, s.y, s.theta], [g.x, g.y, g.theta]]}
        if self.kind not in poses:
            return None
        return PlanResult(PlanStatus.SUCCESS, self.name, path=np.array(poses[self.kind]), stats={})


@pytest.mark.parametrize(
    ("planner", "argv", "code", "said"),
    [
        ("raises", [], 1, f"nhsim plan: failed: planner 'raises' ({BY_CODE}) raised RuntimeError: boom"),
        ("returns", [], 1, f"nhsim plan: failed: planner 'returns' ({BY_CODE}) returned None (NoneType), not a Plan"),
    ],
)
def test_a_planner_that_raises_or_returns_no_result_is_a_failed_plan_naming_it(
    registry: None, capsys: pytest.CaptureFixture[str], planner: str, argv: list[str], code: int, said: str
) -> None:
    """They were tracebacks (RuntimeError, or AttributeError: 'NoneType' object has no attribute 'path')."""
    from planning import register_planner

    register_planner("raises", _Raises)
    register_planner("returns", _Returns)
    for command in (["plan"], ["simulate", "--no-video", "--runs", "closed_loop"]):
        assert main([*command, "--scenario", "simple_motion", "--planner", planner, "--quiet", *argv]) == code
        err = capsys.readouterr().err
        assert said.replace("nhsim plan", f"nhsim {command[0]}") in err and "Traceback" not in err, err


def test_a_planners_success_is_checked_against_the_goal_and_the_obstacles(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A one-pose "success" was reported as one (exit 0) and tracked as a run that never moved; a straight line
    through the obstacles was a failure "whose collision check cannot be trusted", and ``simulate`` went on to
    smooth it and failed as "could not be smoothed ... plan with more clearance", naming neither the planner nor
    the collision."""
    from planning import register_planner

    monkeypatch.chdir(tmp_path)
    register_planner("returns", _Returns)
    argv = ["plan", "--planner", "returns", "--quiet"]
    assert main([*argv, "--scenario", "simple_motion", "--planner-option", "kind=one", "--json", "one.json"]) == 1
    record = json.loads((tmp_path / "one.json").read_text())
    assert (
        record["status"] == "failed"
        and "reported success, but its path ends 1.04 m and 0 rad from the goal" in (record["reason"])
    )
    assert main([*argv, "--scenario", "edumip_map", "--planner-option", "kind=line"]) == 1
    said = r"planner 'returns' \(.*\) reported success, but its path collides "
    said += r"at \(\d\.\d{3}, \d\.\d{3}, -?\d\.\d{3}\), "
    said += r"(between )?plan\.path\[\d+\].* of its 2 poses, the edumip's footprint overlaps the \w+ at x"
    assert re.search(said, capsys.readouterr().out)
    simulate = ["simulate", "--scenario", "simple_motion", "--planner", "returns", "--no-video"]
    line = ["--scenario", "edumip_map", "--runs", "closed_loop", "--no-plots", "--planner-option", "kind=line"]
    assert main(["simulate", "--planner", "returns", "--no-video", *line]) == 1
    out = capsys.readouterr()
    assert re.search(said, out.out + out.err) and "smoothed" not in out.out + out.err
    assert main([*simulate, "--runs", "closed_loop", "--planner-option", "kind=one"]) == 1


def test_origin_loads_the_plugins_it_answers_for(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Asked first, before any lookup, it said "registered by this program's own code" for a plugin's planner."""
    site = _package(tmp_path / "site", {"mine": "nhsim_test_mine:Mine"}, {"nhsim_test_mine": MINE}, PLANNER_GROUP)
    monkeypatch.syspath_prepend(str(site))
    assert PLANNERS.plugins == "unloaded"
    assert PLANNERS.origin("mine").startswith("from entry point 'mine = nhsim_test_mine:Mine'")


def test_an_entry_points_taken_name_says_to_rename_the_entry_point(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    site = _package(tmp_path / "site", {"rrt": "nhsim_test_mine:Mine"}, {"nhsim_test_mine": MINE}, PLANNER_GROUP)
    monkeypatch.syspath_prepend(str(site))
    with pytest.raises(ConfigError, match=r"'rrt' is already registered \(built in\).*give the entry point another n"):
        make_planner("birrt")


def test_a_module_that_registers_its_own_class_under_its_import_path_name_is_the_same_entry(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A planner registered by its import path (an entry point, ``register_planner(name, "pkg.mod:Class")``) whose
    module also registers the class on import (as docs/how-to/new-planner.md's module does, for NHSIM_PLUGINS)
    was refused when first made: "planner 'tdt' is already registered ... as nhsim_test_tdt:TDT"."""
    from planning import make_planner, register_planner

    (tmp_path / "nhsim_test_tdt.py").write_text(
        "from planning import register_planner\n\n\n"
        "class TDT:\n"
        "    name = 'tdt'\n\n"
        "    def plan(self, problem):\n"
        "        raise NotImplementedError\n\n\n"
        "register_planner('tdt', TDT)\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    register_planner("tdt", "nhsim_test_tdt:TDT")
    assert make_planner("tdt").name == "tdt" and PLANNERS.origin("tdt") == BY_CODE
    (tmp_path / "nhsim_test_other.py").write_text("class TDT:\n    name = 'tdt'\n")
    with pytest.raises(ConfigError, match=r"planner 'tdt' is already registered .* as nhsim_test_tdt:TDT"):
        register_planner("tdt", "nhsim_test_other:TDT")


def test_a_failing_plugin_is_named_first_when_another_registrys_plugin_loads_it(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A planner lookup imported a good plugin module whose tracker registration loaded the tracker plugins, of
    which a bad one failed: the message led with "planner plugin failed to load: module 'nhsim_test_good' ...",
    an innocent module, and named the culprit only at the end of the line."""
    from planning.planners.registry import make_planner

    (tmp_path / "nhsim_test_good.py").write_text(
        "from control import register_tracker\nfrom control.fbl import DynamicFBL\n\n\n"
        "class Mine(DynamicFBL):\n    name = 'mine'\n\n\nregister_tracker('mine', Mine)\n"
    )
    (tmp_path / "nhsim_test_bad.py").write_text("raise RuntimeError('case 7')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_good,nhsim_test_bad")
    with pytest.raises(ConfigError) as info:
        make_planner("rrt")
    said = str(info.value)
    assert said.startswith("plugin failed to load: module 'nhsim_test_bad' named by"), said
    assert "RuntimeError: case 7" in said and "nhsim_test_good" not in said.split("named by")[0], said


# ---- which plugin failed, and by which registry ---------------------------------------------------------------
PLANS_RRT = "from planning import register_planner\nfrom planning.planners.sampling.rrt import BiRRT\n\n"
PLANS_RRT += "register_planner('rrt', type('Other', (BiRRT,), {}))\n"
FIRST = (
    "from control import register_tracker\nfrom control.fbl import DynamicFBL\nfrom planning import register_planner\n"
    "from planning.planners.sampling.rrt import BiRRT\n\n\nclass First(DynamicFBL):\n    pass\n\n\n"
    "register_planner('first-birrt', BiRRT)\nregister_tracker('shared', First)\n"
)
SECOND = REGISTERS + "\n\nclass Second(DynamicFBL):\n    pass\n\n\nregister_tracker('shared', Second)\n"


def test_a_plugins_refused_registration_is_named_by_the_registry_that_refused_it(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A plugin whose register_planner("rrt", ...) collided made ``compare`` (a tracker lookup) say "tracker plugin
    failed to load": the label was that of whichever registry loaded the plugins first."""
    (tmp_path / "nhsim_test_plans_rrt.py").write_text(PLANS_RRT)
    (tmp_path / "nhsim_test_clashes.py").write_text(
        REGISTERS + "register_tracker('fbl', type('Other', (DynamicFBL,), {}))\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_plans_rrt")
    assert main(["compare", "--trackers", "fbl", "--reference", "line", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nhsim compare: error: planner plugin failed to load: module 'nhsim_test_plans_rrt'"), err
    assert "ConfigError: register_planner: planner 'rrt' is already registered (built in)" in err
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_clashes")
    with pytest.raises(ConfigError, match=r"^tracker plugin failed to load: module 'nhsim_test_clashes'"):
        make_planner("birrt")  # a planner lookup, a tracker's refusal


@pytest.mark.parametrize("lookup", ["planner", "tracker"])
def test_of_two_plugins_registering_one_name_the_later_one_named_is_refused(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, lookup: str
) -> None:
    """The first module's registration of a planner loaded the tracker plugins in the middle of its import: the
    second module registered "shared" before the first did, and the first was blamed (as by a planner plugin)."""
    (tmp_path / "nhsim_test_first.py").write_text(FIRST)
    (tmp_path / "nhsim_test_second.py").write_text(SECOND)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_first,nhsim_test_second")
    with pytest.raises(ConfigError) as info:
        make_planner("birrt") if lookup == "planner" else make_tracker("fbl", load_robot("turtlebot3"))
    said = str(info.value)
    assert said.startswith("tracker plugin failed to load: module 'nhsim_test_second' named by"), said
    first = f"module 'nhsim_test_first' named by {PLUGIN_VARIABLE}=nhsim_test_first,nhsim_test_second"
    assert f"tracker 'shared' is already registered (from {first}) as nhsim_test_first:First" in said, said


# ---- the registries are edited through register_*, not directly -------------------------------------------------
def test_a_built_in_or_a_plugins_entry_is_not_replaced_or_removed_directly(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``PLANNERS["rrt"] = X``, ``del`` and ``clear()`` went around the duplicate-name check register_* makes."""
    _env_plugin(tmp_path, monkeypatch, "nhsim_test_env_plugin")
    for registered, name, kind in ((PLANNERS, "rrt", "planner"), (TRACKERS, "fbl", "tracker")):
        before = registered[name]
        fix = rf"register_{kind}\('{name}', target, replace=True\) replaces it"
        with pytest.raises(ConfigError, match=rf"^{kind} '{name}' is registered \(built in\) as .*replaced.*; {fix}$"):
            registered[name] = "mypackage.mine:Mine"
        with pytest.raises(ConfigError, match=rf"cannot be removed directly in the registry; {fix}"):
            del registered[name]
        with pytest.raises(ConfigError, match="cannot be removed directly"):
            registered.clear()
        with pytest.raises(ConfigError, match="cannot be removed directly"):
            registered.pop(name)
        assert registered[name] == before and registered.origin(name) == "built in"
    with pytest.raises(ConfigError, match=r"^tracker 'env-fbl' is registered \(from module 'nhsim_test_env_plugin'"):
        TRACKERS["env-fbl"] = MyFBL
    TRACKERS["mine"] = MyFBL  # a new name, and one this program's own code set: as register_tracker would
    TRACKERS["mine"] = OpenLoop
    assert TRACKERS.origin("mine") == BY_CODE
    del TRACKERS["mine"]
    assert "mine" not in TRACKERS and TRACKERS["env-fbl"] is DynamicFBL


# ---- montecarlo's code digest covers the plugins --------------------------------------------------------------
def test_the_code_digest_covers_the_plugins_source(
    registry: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """montecarlo hashed nhsim's own code only: a plugin's planner edited, the same command read the old runs back
    as this code's (the same table, nothing rerun). The digest is taken with the plugins loaded."""
    from sim.tools import digests

    package = tmp_path / "nhsim_test_pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "plugin.py").write_text("from nhsim_test_pkg import planners  # noqa: F401\n")
    planner = "from planning import register_planner\nfrom planning.planners.sampling.rrt import BiRRT\n\n\n"
    planner += "class Mine(BiRRT):\n    name = 'mine'\n\n\nregister_planner('mine', Mine)\n"
    (package / "planners.py").write_text(planner)
    own = digests.code_digest()  # no plugin named: nhsim's own code
    for registered in (PLANNERS, TRACKERS):
        registered.plugins = "unloaded"  # a fresh process (the fixture restores it)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(PLUGIN_VARIABLE, "nhsim_test_pkg.plugin")
    with_plugin = digests.code_digest()  # loads the plugins first
    assert PLANNERS.plugins == "loaded" and PLANNERS.origin("mine").startswith("from module 'nhsim_test_pkg.plugin'")
    assert with_plugin != own
    files = {"nhsim_test_pkg/__init__.py", "nhsim_test_pkg/planners.py", "nhsim_test_pkg/plugin.py"}
    assert files <= {name for _, name in digests.plugin_files()}  # the plugin's whole package
    (package / "planners.py").write_text(planner.replace("name = 'mine'", "name = 'mine'  # edited"))
    digests._digest.cache_clear()  # a new process: the files read again
    assert digests.code_digest() not in (own, with_plugin)
    for name in [m for m in sys.modules if m.startswith("nhsim_test_pkg")]:
        del sys.modules[name]


def test_an_unknown_name_says_how_a_plugins_is_registered(registry: None) -> None:
    """A planner of a plugin not loaded was "unknown planner 'line-turn': choose one of birrt, ...", not saying
    that a plugin's is named in NHSIM_PLUGINS or installed with an entry point."""
    with pytest.raises(ConfigError) as planner:
        make_planner("line-turn")
    with pytest.raises(ConfigError) as tracker:
        make_tracker("line-turn", load_robot("turtlebot3"))
    for info, kind, group in ((planner, "planner", PLANNER_GROUP), (tracker, "tracker", PLUGIN_GROUP)):
        said = str(info.value)
        assert said.startswith(f"unknown {kind} 'line-turn': choose one of "), said
        assert f"name its module in {PLUGIN_VARIABLE} (e.g. {PLUGIN_VARIABLE}=mypackage.{kind}s)" in said, said
        assert f"an entry point of group {group}" in said and "\n" not in said, said


def test_montecarlos_replay_commands_carry_the_plugins_it_was_given(monkeypatch: pytest.MonkeyPatch) -> None:
    """A study of a plugin's tracker printed replay commands without NHSIM_PLUGINS: run as printed, they failed
    ("unknown tracker") or, for a plugin overriding nothing, replayed without it."""
    import shlex

    from sim.cli.montecarlo import _replay_line

    worst = {"index": 3, "plan_seed": 7, "build_seed": 11, "noise_seed": 13}
    monkeypatch.delenv(PLUGIN_VARIABLE, raising=False)
    plain = _replay_line(["--scenario", "open", "--feedback", "p-pose"], worst)
    assert shlex.split(plain)[:2] == ["nhsim", "simulate"]
    monkeypatch.setenv(PLUGIN_VARIABLE, "my pkg.trackers")
    line = _replay_line(["--scenario", "open", "--feedback", "p-pose"], worst)
    assert shlex.split(line) == [f"{PLUGIN_VARIABLE}=my pkg.trackers", *shlex.split(plain)]
