"""A new tracker costs one law: a proportional pose controller written and registered here (its
parameters, its compiled drive law, a short class) is compared, benchmarked, tuned, checked by the
registry-wide tests and fuzzed, with no list anywhere else edited (docs: "add a tracker")."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba as nb
import pytest
from hypothesis import HealthCheck, given, settings

from control.base import (
    BASELINES,
    TRACKERS,
    check_ranges,
    feedback_trackers,
    option_value,
    ranged,
    register_tracker,
    search_space,
    tuned_option,
)
from control.estimation.kernels import wrap
from control.switching import PerSegmentTracker, SegmentedParams, dataclass_values, period, state_dtype
from planning.core.robot import RobotSpec


# ---- the new tracker: one module's worth ------------------------------------------------------------
@dataclass(frozen=True)
class PoseGains:
    """Gains of the proportional pose controller (ranges checked)."""

    k_along: float = ranged(2.0, 0.01, 50.0, "1/s", tune=(0.2, 20.0))
    k_lateral: float = ranged(20.0, 0.01, 1000.0, "1/m^2", tune=(1.0, 200.0))
    k_heading: float = ranged(3.0, 0.01, 50.0, "1/s", tune=(0.2, 20.0))

    def __post_init__(self) -> None:
        check_ranges(self)


STATE = state_dtype([("k_along", "f8"), ("k_lateral", "f8"), ("k_heading", "f8")])


@nb.njit
def drive(s: Any, ref: Any, k: int, x: float, y: float, theta: float, enter: bool, rested: bool) -> tuple[float, float]:
    """The reference's inputs plus proportional feedback on the pose error in the robot's frame."""
    r = ref[k]
    c, sn = math.cos(theta), math.sin(theta)
    ex, ey = c * (r.x - x) + sn * (r.y - y), -sn * (r.x - x) + c * (r.y - y)
    return r.v + s.k_along * ex, r.omega + s.k_lateral * r.v * ey + s.k_heading * wrap(r.theta - theta)


@nb.njit
def _period(state: Any, ref: Any, t: float, x: float, y: float, theta: float) -> tuple[int, float, float]:
    return period(state, ref, t, x, y, theta, drive)


class PoseP(PerSegmentTracker):
    """Proportional pose control on the drives; turns in place and stand-stills by segment."""

    name = "p-pose"
    TUNED = ("gains", PoseGains)
    STATE = STATE
    DRIVE = staticmethod(drive)
    PERIOD = staticmethod(_period)

    def __init__(self, robot: RobotSpec, *, gains: PoseGains | None = None, turns: SegmentedParams | None = None):
        self.gains = option_value(self.name, "gains", gains, PoseGains())
        super().__init__(robot, option_value(self.name, "turns", turns, SegmentedParams()))

    def law_values(self) -> dict[str, float]:
        return dataclass_values(self.gains)


# ---- the proof ----------------------------------------------------------------------------------------
@pytest.fixture
def registered(monkeypatch: pytest.MonkeyPatch) -> str:
    """The new tracker registered for one test (the registry restored afterwards)."""
    monkeypatch.setitem(TRACKERS, "p-pose", "")  # undone after the test
    monkeypatch.setattr("control.base.BASELINES", set(BASELINES))
    register_tracker("p-pose", PoseP)
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
