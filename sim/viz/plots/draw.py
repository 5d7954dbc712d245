"""Pieces every report plot shares: the arena with its obstacles, and the one PNG writer.

Figures are built with matplotlib's object API on the Agg canvas (no display, no pyplot state).
"""

from __future__ import annotations

import contextlib
import logging
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Ellipse as EllipsePatch
from matplotlib.patches import Patch, Rectangle
from matplotlib.patches import Polygon as PolygonPatch
from numpy.typing import NDArray

from planning.core.world import Box, Circle, Ellipse, Obstacle, Polygon, World
from sim.outputs import atomic_path, image_format


@dataclass(frozen=True)
class WorldStyle:
    """How :func:`draw_world` draws an arena.

    Attributes:
        obstacle: Keyword arguments of every obstacle's patch (colours, line width, zorder).
        frame: Keyword arguments of the unfilled rectangle of the bounds (the walls).
        frame_on_top: Add the frame after the obstacles (drawn over them where they cross it).
    """

    obstacle: Mapping[str, Any]
    frame: Mapping[str, Any]
    frame_on_top: bool = True


#: Plan figures: grey obstacles, the walls as a black frame over them.
PLAN_WORLD = WorldStyle(
    obstacle={"facecolor": "0.55", "edgecolor": "0.25", "linewidth": 0.8, "zorder": 1},
    frame={"edgecolor": "black", "linewidth": 2.0, "zorder": 1},
)

#: A job's world figure: brick-red obstacles over a grey frame.
RUN_WORLD = WorldStyle(
    obstacle={"facecolor": "#b85c47", "edgecolor": "#6b2f22", "alpha": 0.85},
    frame={"edgecolor": "0.35", "linewidth": 1.5},
    frame_on_top=False,
)


def obstacle_patch(obstacle: Obstacle, **style: Any) -> Patch:
    """A matplotlib patch of an obstacle's exact outline (in metres), with patch keyword ``style``."""
    if isinstance(obstacle, Circle):
        return CirclePatch(obstacle.center, obstacle.radius, **style)
    if isinstance(obstacle, Ellipse):
        a, b = obstacle.radii
        return EllipsePatch(obstacle.center, 2 * a, 2 * b, angle=np.degrees(obstacle.angle), **style)
    if isinstance(obstacle, Box):
        return PolygonPatch(obstacle.corners(), closed=True, **style)
    if isinstance(obstacle, Polygon):
        return PolygonPatch(obstacle.array, closed=True, **style)
    raise TypeError(f"cannot draw obstacle {obstacle!r}")  # pragma: no cover - every kind is drawn above


def draw_world(ax: Axes, world: World, style: WorldStyle = PLAN_WORLD) -> None:
    """Draw an arena's walls (its bounds) and obstacles on ``ax`` (top view, metres)."""
    xmin, xmax, ymin, ymax = world.bounds
    frame = Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False, **style.frame)
    if not style.frame_on_top:
        ax.add_patch(frame)
    for obstacle in world.obstacles:
        ax.add_patch(obstacle_patch(obstacle, **style.obstacle))
    if style.frame_on_top:
        ax.add_patch(frame)


def world_extent(world: World, paths: Sequence[NDArray[np.float64]] = ()) -> tuple[tuple[float, float], ...]:
    """The smallest axis-aligned rectangle holding an arena's bounds, every obstacle and ``paths``.

    Args:
        world: Bounds and obstacles (an obstacle may reach past the bounds).
        paths: (N, 2) points [m] each (runs may leave the arena).

    Returns:
        ((xmin, xmax), (ymin, ymax)) [m].
    """
    xmin, xmax, ymin, ymax = world.bounds
    boxes = [(xmin, xmax, ymin, ymax)] + [o.bounding_box() for o in world.obstacles]
    boxes += [(float(p[:, 0].min()), float(p[:, 0].max()), float(p[:, 1].min()), float(p[:, 1].max())) for p in paths]
    b = np.asarray(boxes, dtype=float)
    return (float(b[:, 0].min()), float(b[:, 1].max())), (float(b[:, 2].min()), float(b[:, 3].max()))


def frame_world(ax: Axes, world: World, paths: Sequence[NDArray[np.float64]] = ()) -> None:
    """Set ``ax`` to frame :func:`world_extent` of ``world`` and ``paths`` with a 3 % margin, equal
    axes in metres."""
    (xmin, xmax), (ymin, ymax) = world_extent(world, paths)
    pad = 0.03 * max(xmax - xmin, ymax - ymin)
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


@contextlib.contextmanager
def any_glyphs() -> Iterator[None]:
    """Lay out or draw text whose characters the font may lack (a scenario named in CJK, say: DejaVu Sans has
    none) without matplotlib's warning per missing glyph on stderr: the figure shows a box for each."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"Glyph \d+ .* missing from font", category=UserWarning)
        yield


def tight(fig: Figure) -> None:
    """``fig.tight_layout()`` (:func:`any_glyphs`)."""
    with any_glyphs():
        fig.tight_layout()


def save_figure(fig: Figure, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write a figure atomically (never replacing a file unless ``overwrite``), in the format its suffix
    names (:func:`sim.outputs.image_format`: PNG for ``.png``; :func:`any_glyphs`)."""
    fmt = image_format(Path(path), "the figure")
    # PostScript has no transparency: matplotlib draws the translucent bands opaque and logs a warning on stderr
    ps_log = logging.getLogger("matplotlib.backends.backend_ps")
    level = ps_log.level
    ps_log.setLevel(logging.ERROR)
    try:
        with atomic_path(path, overwrite=overwrite) as tmp, any_glyphs():
            fig.savefig(tmp, format=fmt, bbox_inches="tight", pad_inches=0.1)  # nothing cut at the edges
    finally:
        ps_log.setLevel(level)
    return Path(path)
