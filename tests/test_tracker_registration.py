"""A new tracker costs one law: the proportional pose controller of docs/how-to/new-tracker.md (its
parameters, its compiled drive law, a short class, run from the page) is registered here and compared,
benchmarked, tuned, checked by the registry-wide tests and fuzzed, with no list anywhere else edited."""

from __future__ import annotations

import math
import sys
import types
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings

from control.base import (
    BASELINES,
    TRACKERS,
    check_ranges,
    feedback_trackers,
    make_tracker,
    option_value,
    ranged,
    register_tracker,
    search_space,
    tuned_option,
)
from control.switching import PerSegmentTracker, SegmentedParams
from planning.core.robot import RobotSpec, load_robot
from planning.errors import ConfigError
from tests.doc_blocks import block_of


# ---- the new tracker: the module docs/how-to/new-tracker.md shows, run from there ------------------------
def _tracker_module() -> types.ModuleType:
    """The page's block run as the module it says it is (``p_pose``, in ``sys.modules`` as an import puts it)."""
    block = block_of("docs/how-to/new-tracker.md")
    module = types.ModuleType("p_pose")
    sys.modules["p_pose"] = module
    exec(compile(block.code, block.name, "exec"), module.__dict__)
    return module


_MODULE = _tracker_module()
PoseGains, PoseP = _MODULE.PoseGains, _MODULE.PoseP


# ---- the proof ----------------------------------------------------------------------------------------
@pytest.fixture
def registered(monkeypatch: pytest.MonkeyPatch) -> str:
    """The new tracker registered for one test (the registry restored afterwards)."""
    monkeypatch.setitem(TRACKERS, "p-pose", "")  # undone after the test
    monkeypatch.setattr("control.base.BASELINES", set(BASELINES))
    register_tracker("p-pose", PoseP, replace=True)  # over the placeholder above
    return "p-pose"


def test_registering_puts_it_in_compare_and_its_runs_track(registered: str) -> None:
    from sim.pipeline.case import Case
    from sim.tools.compare import check_trackers, compare_trackers

    assert registered in feedback_trackers()  # compare's default set, bench track's too
    assert registered in check_trackers(feedback_trackers())
    case = Case("open", robot="turtlebot3", reference="circle", seed=2)
    result = compare_trackers(case, [registered, "kanayama"], runs=1)
    (run,) = result.of(registered)
    assert run.values["collisions"] == 0
    assert run.values["rms_m"] < 0.02 and run.values["final_m"] < 0.02  # a reference's closed-loop targets
    assert set(result.logs()) == {registered, "kanayama"}


def test_registering_runs_it_through_the_simulate_api(registered: str) -> None:
    """Its gains are not FBL gains: a case gives it its own defaults, or the params passed (the FBL gains
    were given to every tracker with a ``gains`` option, and this one refused them)."""
    from sim.pipeline.simulate import simulate_reference, tracker_for_run

    result = simulate_reference(
        "open", reference="circle", robot="turtlebot3", tracker=registered, runs=["closed_loop"]
    )
    (run,) = result.runs.values()
    assert run.tracker == registered and run.metrics.rms_position_error_m < 0.02
    case, kind, robot = result.prepared.case, run.kind, result.prepared.robot
    assert tracker_for_run(case, kind, robot).gains == PoseGains()  # type: ignore[attr-defined]
    tuned = PoseGains(k_along=3.0)
    assert tracker_for_run(replace(case, params=tuned), kind, robot).gains == tuned  # type: ignore[attr-defined]


def test_registering_puts_it_in_bench_track_and_tune(registered: str, monkeypatch: pytest.MonkeyPatch) -> None:
    from sim.tools.bench import track
    from sim.tools.tune import tuned_space

    timed: list[str] = []
    monkeypatch.setattr(track, "compare_trackers", lambda case, names, params: timed.extend(names) or _Empty())
    track.measure(trackers=None, mpc_solvers=())
    assert registered in timed and "open-loop" not in timed
    assert tuned_option(registered) == ("gains", PoseGains)
    assert tuned_space(registered) == (PoseGains, search_space(PoseGains)) and len(search_space(PoseGains)) == 3


class _Empty:
    runs: tuple[()] = ()


@pytest.mark.parametrize("robot_name", ["turtlebot3", "edumip"])
def test_the_registry_wide_tests_take_it(registered: str, robot_name: str) -> None:
    from tests import test_segmented, test_trackers

    assert registered in test_segmented.per_segment_trackers()
    test_segmented.test_the_compiled_switching_is_the_python_switching_for_every_registered_law(registered)
    for reference in ("circle", "figure8", "line"):
        test_trackers.test_every_tracker_tracks_every_reference(registered, robot_name, reference)
    test_trackers.test_an_unknown_option_is_named_with_the_valid_ones(registered)
    test_segmented.test_a_non_finite_pose_is_refused_by_every_tracker(registered, (math.nan, 0.0, 0.0))
    test_segmented.test_reset_refuses_a_bad_control_period(registered, 0.0)
    test_segmented.test_reset_refuses_a_period_too_small_for_the_trajectory(registered)


def test_the_fuzz_suite_draws_it(registered: str) -> None:
    from tests.test_fuzz_trackers import tracker_cases, tracker_property

    seen: list[str] = []

    @settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck), database=None)
    @given(tracker_cases().filter(lambda c: c.tracker == registered))
    def fuzz(case: Any) -> None:
        seen.append(case.tracker)
        tracker_property(case)

    fuzz()
    assert seen and set(seen) == {registered}


# ---- what register_tracker and make_tracker check of the tracker's parameters -----------------------------
class TunesGain(PoseP):
    """``TUNED`` names "gain", an option it does not take (its option is ``gains``)."""

    TUNED = ("gain", PoseGains)


def test_a_tuned_option_the_tracker_does_not_take_is_refused_at_registration(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It was accepted, and ``nhsim tune`` failed inside the study's first Optuna trial (a traceback, then the
    error) and left the study's database behind, although exit status 2 says nothing was written."""
    from sim.cli.main import main

    said = (
        r"TUNED = \('gain', PoseGains\) names option 'gain', which TunesGain does not take \(its keyword options: "
        r"gains, turns\); name the option it is given as, e.g. TUNED = \('gains', PoseGains\)$"
    )
    with pytest.raises(ConfigError, match=rf"^register_tracker\('tunes-gain'\): {said}"):
        register_tracker("tunes-gain", TunesGain)
    assert "tunes-gain" not in TRACKERS
    module = types.ModuleType("nhsim_test_tunes_gain")
    module.TunesGain = TunesGain  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, module.__name__, module)
    monkeypatch.setitem(TRACKERS, "tunes-gain", "")  # undone after the test
    register_tracker("tunes-gain", "nhsim_test_tunes_gain:TunesGain", replace=True)  # imported when first used
    with pytest.raises(ConfigError, match=rf"^tracker 'tunes-gain' \(.*\): {said}"):
        tuned_option("tunes-gain")
    argv = ["tune", "--tracker", "tunes-gain", "--scenarios", "open:line", "--robot", "turtlebot3", "--trials", "2"]
    argv += [
        "--storage",
        f"sqlite:///{tmp_path}/study.db",
        "--json",
        str(tmp_path / "t.json"),
        "--plots",
        str(tmp_path),
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "names option 'gain'" in err and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []  # no study database


@dataclass(frozen=True)
class LooseGains:
    """PoseGains whose check is never called: ``__post_inti__`` is a typo of ``__post_init__``."""

    k_along: float = ranged(2.0, 0.01, 50.0, "1/s", tune=(0.2, 20.0))
    k_lateral: float = ranged(20.0, 0.01, 1000.0, "1/m^2", tune=(1.0, 200.0))
    k_heading: float = ranged(3.0, 0.01, 50.0, "1/s", tune=(0.2, 20.0))

    def __post_inti__(self) -> None:
        check_ranges(self)


class Loose(PoseP):
    """The pose controller on :class:`LooseGains`, taken with ``option_value``."""

    TUNED = ("gains", LooseGains)

    def __init__(self, robot: RobotSpec, *, gains: LooseGains | None = None, turns: SegmentedParams | None = None):
        self.gains = option_value(self.name, "gains", gains, LooseGains())  # type: ignore[arg-type]
        PerSegmentTracker.__init__(self, robot, option_value(self.name, "turns", turns, SegmentedParams()))


class Raw(Loose):
    """The same, keeping its gains as given (no ``option_value``)."""

    def __init__(self, robot: RobotSpec, *, gains: LooseGains | None = None, turns: SegmentedParams | None = None):
        self.gains = gains or LooseGains()  # type: ignore[assignment]
        PerSegmentTracker.__init__(self, robot, SegmentedParams())


@pytest.mark.parametrize("field", ["k_along", "k_heading"])
@pytest.mark.parametrize("bad", [-5.0, math.nan, 1e6])
def test_gains_out_of_their_ranges_are_refused_though_the_dataclass_checks_nothing(
    monkeypatch: pytest.MonkeyPatch, field: str, bad: float
) -> None:
    """nhsim knows the ranges from ``ranged()``: a gains dataclass whose ``__post_init__`` is misspelt made a
    tracker with k_along = -5 or NaN."""
    gains = LooseGains(**{field: bad})  # the dataclass takes it
    robot = load_robot("turtlebot3")
    said = rf"^tracker '(loose|raw)': option gains: LooseGains\.{field} must be a finite number in \[0\.01, 50\]"
    for name, factory in (("loose", Loose), ("raw", Raw)):
        monkeypatch.setitem(TRACKERS, name, "")  # undone after the test
        register_tracker(name, factory, replace=True)
        with pytest.raises(ConfigError, match=said):
            make_tracker(name, robot, gains=gains)
    with pytest.raises(ConfigError, match=said.replace("(loose|raw)", "p-pose")):  # made directly: option_value
        Loose(robot, gains=gains)
    assert getattr(gains, field) is bad or math.isnan(getattr(gains, field))  # the value itself left as it was
    assert make_tracker("loose", robot, gains=LooseGains(k_along=3.0)).gains == LooseGains(k_along=3.0)  # type: ignore[attr-defined]
