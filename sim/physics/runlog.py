"""RunLog: the time series of what the engine did in one run."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planning.errors import SimulationError

FloatArray = NDArray[np.float64]

#: Series -> columns (None: a (N,) series; 0: any number, e.g. nq).
WIDTHS: dict[str, int | None] = {
    "t": None,
    "pose": 3,
    "qpos": 0,
    "ref_pose": 3,
    "command": 2,
    "wheel_command": 2,
    "wheel_speed": 2,
}


@dataclass(frozen=True)
class Contact:
    """A robot-obstacle contact seen in the log: time [s] and obstacle geom name."""

    t: float
    obstacle: str


@dataclass(frozen=True)
class RunLog:
    """What one run did, sampled at the log rate (at least the control rate).

    Checks itself on construction: every series has N rows (``t`` is (N,), N >= 1) and the stated
    columns (ValueError naming the series otherwise), and every value is finite (SimulationError:
    the run diverged).

    Attributes:
        t: (N,) times [s] (increasing, except where MuJoCo reset an unstable run and its clock).
        pose: (N, 3) true pose [x, y, theta] of the base at each time (theta unwrapped); the tracker
            itself sees the pose sensors.
        qpos: (N, nq) full generalised positions, for replay and rendering.
        ref_pose: (N, 3) reference pose at the same times.
        command: (N, 2) body command [v, omega] in force [m/s, rad/s].
        wheel_command: (N, 2) wheel speed command [left, right] [rad/s].
        wheel_speed: (N, 2) measured wheel speeds [rad/s].
        contacts: Robot-obstacle contacts (first sample of each touching spell).
        warnings: MuJoCo warnings raised during the run (empty on a clean run).
        meta: Robot, tracker, gains, rates, seed, trajectory name.
    """

    t: FloatArray
    pose: FloatArray
    qpos: FloatArray
    ref_pose: FloatArray
    command: FloatArray
    wheel_command: FloatArray
    wheel_speed: FloatArray
    contacts: tuple[Contact, ...] = ()
    warnings: tuple[str, ...] = ()
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.t.ndim != 1 or self.t.size < 1:
            raise ValueError(f"RunLog.t must be (N,) with N >= 1 samples, got shape {self.t.shape}")
        n = self.t.size
        for name, a in self.arrays().items():
            width = WIDTHS[name]
            want = (n,) if width is None else (n, width or (a.shape[1] if a.ndim == 2 else -1))
            if a.shape != want:
                expected = "(N,)" if width is None else f"(N, {width or 'nq'})"
                raise ValueError(f"RunLog.{name} must be {expected} with N = {n} (the length of t), got {a.shape}")
            finite = np.isfinite(a).reshape(n, -1).all(axis=1)
            if not finite.all():
                k = int(np.argmin(finite))
                raise SimulationError(
                    f"RunLog.{name} is not finite at sample {k} (t = {self.t[k]:g} s): the run diverged"
                )

    def __len__(self) -> int:
        return int(self.t.size)

    def arrays(self) -> dict[str, FloatArray]:
        """The numeric series by name (for comparisons and saving)."""
        return {name: getattr(self, name) for name in WIDTHS}

    def identical_to(self, other: RunLog) -> bool:
        """Bitwise equality of every series, the contacts and the warnings."""
        a, b = self.arrays(), other.arrays()
        return (
            all(a[k].shape == b[k].shape and a[k].tobytes() == b[k].tobytes() for k in a)
            and self.contacts == other.contacts
            and self.warnings == other.warnings
        )
