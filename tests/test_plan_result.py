"""PlanResult checks itself: statuses are PlanStatus values, arrays have one row per path pose."""

import numpy as np
import pytest

from planning.planners.base import PlanResult, PlanStatus

PATH = np.column_stack([np.linspace(0.0, 1.0, 5), np.zeros(5), np.zeros(5)])


def test_a_valid_result_keeps_its_arrays() -> None:
    t = np.linspace(0.0, 2.0, 5)
    res = PlanResult(
        PlanStatus.SUCCESS, "p", path=PATH, times=t, controls=np.ones((5, 2)), directions=-np.ones(5),
        states=np.zeros((5, 4)),
    )  # fmt: skip
    # the result's own read-only copies: it is frozen, and an edit of its path (or of the caller's array, re-used
    # for the next plan) would reach every record holding it (the job's trajectory, its JSON, its bag)
    assert not np.shares_memory(res.path, PATH) and res.times is not None and not np.shares_memory(res.times, t)
    assert not res.path.flags.writeable and not res.times.flags.writeable and PATH.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        res.path[0, 0] = 5.0
    assert res.success and res.length() == pytest.approx(1.0, abs=1e-15)


def test_a_failure_needs_no_path() -> None:
    res = PlanResult(PlanStatus.TIMEOUT, "p", reason="budget spent")
    assert res.path.shape == (0, 3) and not res.success and res.length() == 0.0


def test_lists_become_float_arrays() -> None:
    res = PlanResult(PlanStatus.SUCCESS, "p", path=[[0, 0, 0], [1, 0, 0]], directions=[1, 1])
    assert res.path.dtype == np.float64 and res.path.shape == (2, 3)
    assert res.directions is not None and res.directions.dtype == np.float64


@pytest.mark.parametrize("status", ["success", "timeout", None, 0])
def test_status_must_be_a_plan_status(status: object) -> None:
    with pytest.raises(ValueError, match=r"PlanResult\.status must be a PlanStatus"):
        PlanResult(status, "p", path=PATH)  # type: ignore[arg-type]


def test_success_without_a_path_is_rejected() -> None:
    with pytest.raises(ValueError, match="empty but the status is success"):
        PlanResult(PlanStatus.SUCCESS, "p")


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("path", np.zeros((4, 2)), r"path must have shape \(any, 3\)"),
        ("path", np.zeros(3), r"path must have shape \(any, 3\)"),
        ("path", np.array([[0.0, 0.0, np.nan]]), "path holds non-finite"),
        ("directions", np.ones(4), r"directions must have shape \(5\)"),
        ("directions", np.array([1.0, 1.0, 0.0, 1.0, -1.0]), r"\+1 \(forwards\) or -1"),
        ("states", np.zeros((4, 4)), r"states must have shape \(5, any\)"),
        ("states", np.full((5, 4), np.inf), "states holds non-finite"),
    ],
)
def test_bad_arrays_name_the_field(field: str, value: np.ndarray, match: str) -> None:
    kwargs = {"path": PATH, field: value}
    with pytest.raises(ValueError, match=match):
        PlanResult(PlanStatus.SUCCESS, "p", **kwargs)  # type: ignore[arg-type]


def test_times_and_controls_come_together_with_one_row_per_pose() -> None:
    t = np.linspace(0.0, 1.0, 5)
    with pytest.raises(ValueError, match="give both or neither"):
        PlanResult(PlanStatus.SUCCESS, "p", path=PATH, times=t)
    with pytest.raises(ValueError, match=r"times must have shape \(5\)"):
        PlanResult(PlanStatus.SUCCESS, "p", path=PATH, times=t[:4], controls=np.zeros((5, 2)))
    with pytest.raises(ValueError, match=r"controls must have shape \(5, 2\)"):
        PlanResult(PlanStatus.SUCCESS, "p", path=PATH, times=t, controls=np.zeros((5, 3)))


def test_frozen() -> None:
    res = PlanResult(PlanStatus.SUCCESS, "p", path=PATH)
    with pytest.raises(AttributeError):
        res.status = PlanStatus.FAILED  # type: ignore[misc]
