"""RunLog: the time series of what the engine did in one run."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Contact:
    """A robot-obstacle contact seen in the log: time [s] and obstacle geom name."""

    t: float
    obstacle: str


@dataclass(frozen=True)
class RunLog:
    """What one run did, sampled at the log rate (at least the control rate).

    Attributes:
        t: (N,) times [s].
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

    def __len__(self) -> int:
        return int(self.t.size)

    def arrays(self) -> dict[str, FloatArray]:
        """The numeric series by name (for comparisons and saving)."""
        return {
            "t": self.t, "pose": self.pose, "qpos": self.qpos, "ref_pose": self.ref_pose,
            "command": self.command, "wheel_command": self.wheel_command, "wheel_speed": self.wheel_speed,
        }  # fmt: skip

    def identical_to(self, other: RunLog) -> bool:
        """Bitwise equality of every series, the contacts and the warnings."""
        a, b = self.arrays(), other.arrays()
        return (
            all(a[k].shape == b[k].shape and a[k].tobytes() == b[k].tobytes() for k in a)
            and self.contacts == other.contacts
            and self.warnings == other.warnings
        )
