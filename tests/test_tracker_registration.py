"""A new tracker costs one law: the proportional pose controller of docs/how-to/new-tracker.md (its
parameters, its compiled drive law, a short class, run from the page) is registered here and compared,
benchmarked, tuned, checked by the registry-wide tests and fuzzed, with no list anywhere else edited."""

from __future__ import annotations

import math
import sys
import types
from dataclasses import replace
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings

from control.base import (
    BASELINES,
    TRACKERS,
    feedback_trackers,
    register_tracker,
    search_space,
    tuned_option,
)
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
