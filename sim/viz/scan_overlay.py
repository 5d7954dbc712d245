"""The scan localiser in the video's close-up: the current scan's points, placed by the localiser's own
pose (so a bad fix shows as a scan that does not sit on the walls), and its particle cloud."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw

from sim.physics.runlog import LocaliserLog, RunLog
from sim.viz.scene import Projection

FloatArray = NDArray[np.float64]

#: Colour of the scan's points and of the particles (RGB).
SCAN_RGB = (230, 40, 40)
PARTICLE_RGB = (40, 90, 230)
#: Height the scan's points are drawn at [m] (the LDS-01's plane) and the particles at.
SCAN_Z = 0.182
PARTICLE_Z = 0.005


@dataclass(frozen=True)
class ScanOverlay:
    """Per localiser update: the scan's end points in the world by the localiser's pose, and its particles.

    Attributes:
        t: (L,) update times [s].
        scans: (L, B, 2) end points (NaN where a beam returned nothing) [m].
        clouds: (L, P, 2) particle positions (NaN rows where fewer) [m].
    """

    t: FloatArray
    scans: FloatArray
    clouds: FloatArray

    @classmethod
    def of(cls, log: RunLog) -> ScanOverlay | None:
        """The overlay of a run fed by a scan localiser (None otherwise, or before its first update)."""
        loc = log.estimation.localiser if log.estimation is not None else None
        if loc is None or loc.t.size == 0 or loc.scan_t.size == 0:
            return None
        return cls(loc.t, _end_points(loc), loc.cloud[:, :, :2])

    def draw(self, out: NDArray[np.uint8], proj: Projection, shift: FloatArray, t: float, dot: int) -> None:
        """Draw the latest update at or before ``t`` [s] into ``out`` (the view ``proj`` projects onto,
        offset by ``shift`` [px]); dots of ``dot`` px."""
        i = int(np.searchsorted(self.t, t, side="right")) - 1
        if i < 0:
            return
        pil = Image.fromarray(out)
        draw = ImageDraw.Draw(pil)
        for xy, z, rgb, r in (
            (self.clouds[i], PARTICLE_Z, PARTICLE_RGB, dot / 2),
            (self.scans[i], SCAN_Z, SCAN_RGB, dot),
        ):
            keep = np.all(np.isfinite(xy), axis=1)
            px, ok = proj.pixels(np.column_stack([xy[keep], np.full(int(keep.sum()), z)]))
            for x, y in px[ok] - shift:
                draw.ellipse((x - r, y - r, x + r, y + r), fill=rgb)
        out[:] = np.asarray(pil)


def _end_points(loc: LocaliserLog) -> FloatArray:
    """(L, B, 2) each update's scan end points in the world, placed by the localiser's pose then."""
    # an update at t used the revolution centred on t: its stamp is half a revolution earlier
    half = 0.5 * loc.scan_time_increment * loc.scan_ranges.shape[1]
    s = np.clip(np.searchsorted(loc.scan_t, loc.t - half - 1e-9), 0, loc.scan_t.size - 1)
    ranges = loc.scan_ranges[s]
    bearings = loc.scan_angle_increment * np.arange(ranges.shape[1])
    x, y, th = (loc.pose[:, i : i + 1] for i in range(3))
    lx = x + np.cos(th) * loc.laser[0] - np.sin(th) * loc.laser[1]
    ly = y + np.sin(th) * loc.laser[0] + np.cos(th) * loc.laser[1]
    a = th + loc.laser[2] + bearings
    r = np.where(np.isfinite(ranges), ranges, np.nan)
    return np.stack([lx + r * np.cos(a), ly + r * np.sin(a)], axis=-1)
