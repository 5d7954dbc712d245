"""RunLog checks its own shapes and values."""

from __future__ import annotations

import numpy as np
import pytest

from planning.errors import SimulationError
from sim.physics.runlog import RunLog


def _series(n: int = 4, nq: int = 9) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    return {
        "t": np.arange(n) * 0.02,
        "pose": rng.standard_normal((n, 3)),
        "qpos": rng.standard_normal((n, nq)),
        "ref_pose": rng.standard_normal((n, 3)),
        "command": rng.standard_normal((n, 2)),
        "wheel_command": rng.standard_normal((n, 2)),
        "wheel_speed": rng.standard_normal((n, 2)),
    }


def test_a_well_formed_log_is_kept_as_given() -> None:
    series = _series()
    log = RunLog(**series)
    assert len(log) == 4
    assert all(np.shares_memory(log.arrays()[k], v) for k, v in series.items())  # read-only views, not copies
    assert all(v.flags.writeable and not log.arrays()[k].flags.writeable for k, v in series.items())
    assert log.identical_to(RunLog(**{k: v.copy() for k, v in series.items()}))


@pytest.mark.parametrize(
    ("name", "shape", "expected"),
    [
        ("pose", (4, 2), r"pose must be \(N, 3\)"),
        ("qpos", (3, 9), r"qpos must be \(N, nq\) with N = 4"),
        ("qpos", (4,), r"qpos must be \(N, nq\)"),
        ("command", (4, 2, 1), r"command must be \(N, 2\)"),
        ("wheel_speed", (5, 2), r"wheel_speed must be \(N, 2\) with N = 4"),
    ],
)
def test_a_series_of_the_wrong_shape_is_named(name: str, shape: tuple[int, ...], expected: str) -> None:
    series = _series()
    series[name] = np.zeros(shape)
    with pytest.raises(ValueError, match=expected):
        RunLog(**series)


def test_times_must_be_a_non_empty_vector() -> None:
    with pytest.raises(ValueError, match=r"t must be \(N,\) with N >= 1"):
        RunLog(**_series(0))
    series = _series()
    series["t"] = series["t"][:, None]
    with pytest.raises(ValueError, match=r"t must be \(N,\)"):
        RunLog(**series)


@pytest.mark.parametrize("name", ["t", "pose", "qpos", "ref_pose", "command", "wheel_command", "wheel_speed"])
def test_a_non_finite_value_is_a_diverged_run(name: str) -> None:
    series = _series()
    series[name] = series[name].copy()
    series[name].reshape(4, -1)[2, 0] = np.nan if name != "qpos" else np.inf
    with pytest.raises(SimulationError, match=rf"{name} is not finite at sample 2"):
        RunLog(**series)
