"""Segments of a trajectory from its inputs: drive forwards, drive backwards, turn in place.

A planned trajectory carries its segments (``Trajectory.segments``); a timed plan and an analytic
reference do not, and both the plan-to-trajectory step (:mod:`planning.trajectory.from_plan`) and the
segmented tracker (:class:`control.segmented.SegmentedTracker`) infer them the same way, here.

Each sample is labelled by the sign of v: "forward" where v > eps, "reverse" where v < -eps, "rotate"
where |v| <= eps and |omega| > eps. A stand-still (neither) joins the next moving segment, or the
previous one at the end; a trajectory that never moves is one "forward" segment. "hold" is never
inferred: stand-stills are part of the drives and turns around them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["InferredSegments", "infer_segments"]

#: Inferred kinds by code (code 0 is a stand-still before filling).
_KINDS = ("", "forward", "reverse", "rotate")


@dataclass(frozen=True)
class InferredSegments:
    """Segments inferred from a trajectory's inputs.

    Attributes:
        codes: (N,) kind of every sample by code (1 forward, 2 reverse, 3 rotate).
        index: (N,) segment of every sample: 0, 1, ... non-decreasing, as ``Trajectory.segments``.
        kinds: Kind of each segment, as ``Trajectory.segment_kinds``; consecutive kinds differ.
    """

    codes: NDArray[np.int64]
    index: NDArray[np.int64]
    kinds: tuple[str, ...]

    @property
    def labels(self) -> tuple[str, ...]:
        """(N,) kind of every sample ("forward", "reverse" or "rotate"); built when asked (a tracker
        that needs only the segments never pays for N strings)."""
        return tuple(np.array(_KINDS)[self.codes].tolist())


def infer_segments(v: ArrayLike, omega: ArrayLike, eps: float = 1e-4) -> InferredSegments:
    """Label the samples of a trajectory and group them into segments (see the module doc).

    Args:
        v: (N,) speed [m/s]; a non-finite speed counts as a stand-still.
        omega: (N,) yaw rate [rad/s].
        eps: Speeds [m/s] and yaw rates [rad/s] of at most this size count as zero.

    Returns:
        The per-sample labels, the segment index of each sample and the kind of each segment.

    Raises:
        ValueError: ``v`` and ``omega`` are not 1-D arrays of one length.
    """
    v = np.asarray(v, dtype=float)
    omega = np.asarray(omega, dtype=float)
    if v.ndim != 1 or v.shape != omega.shape:
        raise ValueError(f"infer_segments: v and omega must be 1-D of one length, got {v.shape} and {omega.shape}")
    n = v.size
    if n == 0:
        return InferredSegments(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), ())
    rotating = (np.abs(v) <= eps) & (np.abs(omega) > eps)
    codes = np.select([v > eps, v < -eps, rotating], [1, 2, 3], 0)
    moving = np.flatnonzero(codes)
    if moving.size == 0:
        codes[:] = 1
    else:
        # index of the next moving sample at or after each sample (n past the last one)
        nxt = np.minimum.accumulate(np.where(codes > 0, np.arange(n), n)[::-1])[::-1]
        codes = np.where(nxt < n, codes[np.minimum(nxt, n - 1)], codes[moving[-1]])
    new = np.concatenate([[True], codes[1:] != codes[:-1]])  # a segment starts here
    index = (np.cumsum(new) - 1).astype(np.int64)
    names = np.array(_KINDS)
    return InferredSegments(codes.astype(np.int64), index, tuple(names[codes[new]].tolist()))
