"""Planar worlds: rectangular bounds (walls) and obstacles with an exact signed distance.

Every obstacle answers ``signed_distance(points)`` for many points at once: positive outside,
negative inside, zero on the boundary [m], exact to floating-point precision (the ellipse by
Eberly's closest-point equation, solved to about 1e-15 m: :mod:`planning.core.ellipse`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.checks import check_number, numbers_text, refuse_kind
from planning.errors import ConfigError

FloatArray = NDArray[np.float64]

#: Height of an obstacle that states none, and of the walls, as built in physics and drawn in a bag [m]: above
#: the TurtleBot3's LDS-01 scan plane (0.182 m), so the scanner sees it. A lower obstacle (its ``height``) is
#: one the scan passes over: physics has it, and the planners, but not the map a localiser matches scans to.
OBSTACLE_HEIGHT = 0.3
#: Tallest obstacle a world takes [m].
MAX_OBSTACLE_HEIGHT = 10.0


def _check_height(shape: Any) -> None:
    """Check a shape's height and store it as a float."""
    height = check_number(f"{shape.kind} height", shape.height, above=0.0, at_most=MAX_OBSTACLE_HEIGHT)
    object.__setattr__(shape, "height", height)


def _points(points: ArrayLike) -> FloatArray:
    p = np.asarray(points, dtype=float)
    if p.ndim == 1:
        p = p[None, :]
    if p.shape[-1] != 2:
        raise ValueError(f"points must have shape (M, 2), got {p.shape}")
    return p


def _finite_pair(where: str, value: object) -> tuple[float, float]:
    """``value`` as a tuple of two floats (a list or an array given is stored so: a shape is hashable and its
    world with it), else ConfigError naming the field ``where``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = np.full(1, np.nan)
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ConfigError(f"{where} must be two finite numbers, got {value!r}")
    return float(arr[0]), float(arr[1])


def _to_local(p: FloatArray, center: FloatArray, angle: float) -> FloatArray:
    c, s = np.cos(angle), np.sin(angle)
    d = p - center
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)


class _Folded:
    """An ellipse or a box: a shape symmetric about both axes of a frame at ``center`` turned by ``angle``,
    with two extents > 0 in the field named by ``extents_field``."""

    center: tuple[float, float]
    angle: float
    height: float
    kind: ClassVar[str]
    extents_field: ClassVar[str]

    def __post_init__(self) -> None:
        _check_height(self)
        object.__setattr__(self, "center", _finite_pair(f"{self.kind} center", self.center))
        extents = _finite_pair(f"{self.kind} {self.extents_field}", getattr(self, self.extents_field))
        if not (extents[0] > 0 and extents[1] > 0):
            raise ConfigError(f"{self.kind} {self.extents_field} must be > 0, got {extents}")
        object.__setattr__(self, self.extents_field, extents)
        object.__setattr__(self, "angle", check_number(f"{self.kind} angle", self.angle))

    def _folded(self, points: ArrayLike) -> FloatArray:
        """(M, 2) points in the shape's frame, folded into its first quadrant (absolute coordinates)."""
        return np.abs(_to_local(_points(points), np.asarray(self.center), self.angle))


@dataclass(frozen=True)
class Circle:
    """A disc obstacle. center (2,) [m], radius [m], height [m] (:data:`OBSTACLE_HEIGHT`)."""

    center: tuple[float, float]
    radius: float
    height: float = OBSTACLE_HEIGHT
    kind: ClassVar[str] = "circle"

    def __post_init__(self) -> None:
        _check_height(self)
        object.__setattr__(self, "center", _finite_pair("circle center", self.center))
        object.__setattr__(self, "radius", check_number("circle radius", self.radius, above=0.0))

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        """Signed distance of (M, 2) points [m]."""
        p = _points(points)
        return np.hypot(p[..., 0] - self.center[0], p[..., 1] - self.center[1]) - self.radius

    def bounding_box(self) -> tuple[float, float, float, float]:
        """Axis-aligned box (xmin, xmax, ymin, ymax) [m]."""
        cx, cy = self.center
        return (cx - self.radius, cx + self.radius, cy - self.radius, cy + self.radius)

    @property
    def min_feature(self) -> float:
        """Smallest extent of the obstacle [m]."""
        return 2.0 * self.radius


@dataclass(frozen=True)
class Ellipse(_Folded):
    """An ellipse. center (2,) [m], radii (a, b) semi-axes [m], angle of the a-axis [rad], height [m]."""

    center: tuple[float, float]
    radii: tuple[float, float]
    angle: float = 0.0
    height: float = OBSTACLE_HEIGHT
    kind: ClassVar[str] = "ellipse"
    extents_field: ClassVar[str] = "radii"

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        """Signed distance of (M, 2) points [m] (exact; Eberly's closest-point equation, solved by
        :mod:`planning.core.ellipse`)."""
        from planning.core.ellipse import ellipse_distances  # compiled: loaded when an ellipse is measured

        q = self._folded(points)
        flat = q.reshape(-1, 2)
        a, b = self.radii
        out = ellipse_distances(np.ascontiguousarray(flat[:, 0]), np.ascontiguousarray(flat[:, 1]), float(a), float(b))
        return np.asarray(out).reshape(q.shape[:-1])

    def bounding_box(self) -> tuple[float, float, float, float]:
        """Axis-aligned box (xmin, xmax, ymin, ymax) [m]."""
        a, b = self.radii
        c, s = np.cos(self.angle), np.sin(self.angle)
        hx = float(np.hypot(a * c, b * s))
        hy = float(np.hypot(a * s, b * c))
        cx, cy = self.center
        return (cx - hx, cx + hx, cy - hy, cy + hy)

    @property
    def min_feature(self) -> float:
        """Smallest extent of the obstacle [m]."""
        return 2.0 * min(self.radii)


@dataclass(frozen=True)
class Box(_Folded):
    """An oriented rectangle. center (2,) [m], size (full extents) [m], angle [rad], height [m]."""

    center: tuple[float, float]
    size: tuple[float, float]
    angle: float = 0.0
    height: float = OBSTACLE_HEIGHT
    kind: ClassVar[str] = "box"
    extents_field: ClassVar[str] = "size"

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        """Signed distance of (M, 2) points [m]."""
        q = self._folded(points)
        d = q - 0.5 * np.asarray(self.size)
        outside = np.hypot(np.maximum(d[..., 0], 0.0), np.maximum(d[..., 1], 0.0))
        inside = np.minimum(np.maximum(d[..., 0], d[..., 1]), 0.0)
        return outside + inside

    def corners(self) -> FloatArray:
        """(4, 2) corners, counter-clockwise [m]."""
        hx, hy = 0.5 * self.size[0], 0.5 * self.size[1]
        local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        c, s = np.cos(self.angle), np.sin(self.angle)
        return local @ np.array([[c, s], [-s, c]]) + np.asarray(self.center)

    def bounding_box(self) -> tuple[float, float, float, float]:
        """Axis-aligned box (xmin, xmax, ymin, ymax) [m]."""
        c = self.corners()
        return (float(c[:, 0].min()), float(c[:, 0].max()), float(c[:, 1].min()), float(c[:, 1].max()))

    @property
    def min_feature(self) -> float:
        """Smallest extent of the obstacle [m]."""
        return float(min(self.size))


@dataclass(frozen=True)
class Polygon:
    """A simple polygon (convex or not). vertices (K, 2) [m], K >= 3, no self-intersection; height [m]."""

    vertices: tuple[tuple[float, float], ...]
    height: float = OBSTACLE_HEIGHT
    kind: ClassVar[str] = "polygon"
    _v: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        _check_height(self)
        try:
            v = np.asarray(self.vertices, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"polygon vertices must be [x, y] numbers, got {self.vertices!r:.80} ({exc})") from None
        if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
            raise ConfigError(f"polygon needs at least 3 vertices of [x, y], got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ConfigError(f"polygon vertices must be finite numbers, got {v.tolist()}")
        repeat = _repeated_vertex(v)
        if repeat is not None:
            raise ConfigError(f"{repeat}; remove the duplicate vertex")
        crossing = _crossing_edges(v)
        if abs(polygon_area(v)) < 1e-12 and (crossing is None or _collinear(v)):
            line = "its vertices lie on one line" if _collinear(v) else "it is too thin"
            raise ConfigError(f"polygon has zero area ({line}): give vertices that enclose an area")
        if crossing is not None:  # before the area: a bow tie's two lobes have signed areas that cancel
            raise ConfigError(
                f"{crossing} (edge i runs from vertex i to vertex i+1); a polygon must not intersect itself: "
                "reorder its vertices or split it into simple polygons"
            )
        object.__setattr__(self, "vertices", tuple((float(x), float(y)) for x, y in v))  # hashable, as given
        if polygon_area(v) < 0:
            v = v[::-1].copy()
        object.__setattr__(self, "_v", v)

    @property
    def array(self) -> FloatArray:
        """(K, 2) vertices in counter-clockwise order [m]."""
        return self._v

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        """Signed distance of (M, 2) points [m]."""
        p = _points(points)[..., None, :]  # (M, 1, 2)
        a = self._v[None, :, :]
        b = np.roll(self._v, -1, axis=0)[None, :, :]
        ab = b - a
        ap = p - a
        t = np.clip(np.sum(ap * ab, axis=-1) / np.sum(ab * ab, axis=-1), 0.0, 1.0)
        closest = a + t[..., None] * ab
        dist = np.min(np.hypot(*(p - closest).transpose(2, 0, 1)), axis=-1)
        # even-odd rule
        py = p[..., 1]
        ay, by = a[..., 1], b[..., 1]
        crosses = (ay > py) != (by > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = a[..., 0] + (py - ay) * ab[..., 0] / (by - ay)
        inside = np.sum(crosses & (p[..., 0] < xint), axis=-1) % 2 == 1
        return np.where(inside, -dist, dist)

    def bounding_box(self) -> tuple[float, float, float, float]:
        """Axis-aligned box (xmin, xmax, ymin, ymax) [m]."""
        v = self._v
        return (float(v[:, 0].min()), float(v[:, 0].max()), float(v[:, 1].min()), float(v[:, 1].max()))

    @property
    def min_feature(self) -> float:
        """Smallest extent of the obstacle (twice the largest inscribed-disc radius bound) [m]."""
        xmin, xmax, ymin, ymax = self.bounding_box()
        return float(min(xmax - xmin, ymax - ymin, 2.0 * abs(polygon_area(self._v)) / _perimeter(self._v) * 2.0))


def polygon_area(v: FloatArray) -> float:
    """Signed area of a polygon (K, 2) [m^2], positive when counter-clockwise."""
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _tolerance(v: FloatArray) -> float:
    """Length below which two vertices of ``v`` count as one [m] (1e-12 of the polygon's scale)."""
    return 1e-12 * max(1.0, float(np.max(np.abs(v))))


def _collinear(v: FloatArray) -> bool:
    """Whether all vertices of ``v`` lie on one line (to 1e-12 of the polygon's extent)."""
    spread = np.linalg.svd(v - v.mean(axis=0), compute_uv=False)
    return bool(spread[1] <= 1e-12 * max(1.0, float(spread[0])))


def _repeated_vertex(v: FloatArray) -> str | None:
    """``"polygon vertex j repeats vertex i"`` for the first vertex that repeats an earlier one, else None."""
    gap = np.hypot(*(v[:, None, :] - v[None, :, :]).transpose(2, 0, 1))  # (K, K)
    earlier, later = np.nonzero(np.triu(gap <= _tolerance(v), 1))
    if later.size == 0:
        return None
    first = int(np.argmin(later))
    return f"polygon vertex {later[first]} repeats vertex {earlier[first]}"


def _cross2(u: FloatArray, w: FloatArray) -> FloatArray:
    """z-component of the cross product of (..., 2) vectors."""
    return np.asarray(u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0], dtype=float)


def _crossing_edges(v: FloatArray) -> str | None:
    """``"edges i and j cross"`` for the first pair of edges that meet other than at their shared vertex.

    Edge i runs from vertex i to vertex i+1 (the last edge closes the loop). Edges that share a vertex
    meet wrongly when they fold back onto each other (collinear, opposite directions).
    """
    k = v.shape[0]
    a, b = v, np.roll(v, -1, axis=0)
    ab = b - a
    tol = _tolerance(v) * max(1.0, float(np.max(np.hypot(*ab.T))))  # cross products scale as length^2
    for e in range(k):
        nxt = (e + 1) % k
        if abs(_cross2(ab[e], ab[nxt])) <= tol and float(ab[e] @ ab[nxt]) < 0:
            return f"edges {min(e, nxt)} and {max(e, nxt)} fold back onto each other"
    i, j = np.triu_indices(k, 2)
    keep = ~((i == 0) & (j == k - 1))  # the first and last edges share vertex 0
    i, j = i[keep], j[keep]
    d1 = _cross2(ab[i], a[j] - a[i])
    d2 = _cross2(ab[i], b[j] - a[i])
    d3 = _cross2(ab[j], a[i] - a[j])
    d4 = _cross2(ab[j], b[i] - a[j])
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    touch = (_on_segment(d1, a[j], a[i], b[i], tol) | _on_segment(d2, b[j], a[i], b[i], tol)) | (
        _on_segment(d3, a[i], a[j], b[j], tol) | _on_segment(d4, b[i], a[j], b[j], tol)
    )
    hits = np.nonzero(proper | touch)[0]
    if hits.size == 0:
        return None
    return f"edges {i[hits[0]]} and {j[hits[0]]} cross"


def _on_segment(cross: FloatArray, p: FloatArray, a: FloatArray, b: FloatArray, tol: float) -> NDArray[np.bool_]:
    """Whether points p (M, 2), collinear with segments a-b by ``cross`` (M,), lie on those segments."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    within = np.all((p >= lo - 1e-12) & (p <= hi + 1e-12), axis=-1)
    return np.asarray((np.abs(cross) <= tol) & within)


def _perimeter(v: FloatArray) -> float:
    return float(np.sum(np.hypot(*(np.roll(v, -1, axis=0) - v).T)))


Obstacle = Circle | Ellipse | Box | Polygon


#: Smallest obstacle extent a world takes [m]: the exact collision checker samples motions at a quarter
#: of the smallest one (:attr:`planning.collision.exact.CollisionChecker.resolution`), and a thinner one
#: would have it sample a path finer than memory holds (1e-9 m: 4 x 10^9 samples a metre; at this floor
#: 40,000, a 10 m path's 400,000 poses in 10 MB). Small fruit of a few millimetres is well above it.
MIN_FEATURE = 1e-4


def too_thin(ob: Obstacle) -> str:
    """Why ``ob`` is thinner than a world takes (:data:`MIN_FEATURE`), as "is ... across, ...; make it
    larger, or remove it"; "" when it is not."""
    if ob.min_feature >= MIN_FEATURE:
        return ""
    return (
        f"is {ob.min_feature:.3g} m across, less than the {MIN_FEATURE * 1e3:g} mm the collision checker resolves "
        "(it samples motions at a quarter of the smallest obstacle); make it larger, or remove it"
    )


def span(xmin: float, xmax: float, ymin: float, ymax: float) -> str:
    """A box [m] as a message says it: "x 0..2, y 0..1.2"."""
    return f"x {xmin:g}..{xmax:g}, y {ymin:g}..{ymax:g}"


def lies_outside(ob: Obstacle, bounds: tuple[float, float, float, float]) -> str:
    """Why ``ob`` cannot be in a world of ``bounds`` (xmin, xmax, ymin, ymax) [m], as "lies wholly outside the
    world bounds ...; move it inside, or remove it" (it could never be met: a typo, centimetres for metres?); ""
    when some of it lies inside (its bounding box overlaps the bounds)."""
    bx0, bx1, by0, by1 = ob.bounding_box()
    if not (bx1 <= bounds[0] or bx0 >= bounds[1] or by1 <= bounds[2] or by0 >= bounds[3]):
        return ""
    return (
        f"lies wholly outside the world bounds {list(bounds)} (its box spans {span(bx0, bx1, by0, by1)}); "
        "move it inside, or remove it"
    )


#: Longest side of a world [m]: the sampling planners' reach and every grid grow with it.
MAX_WORLD_SIDE = 1000.0


@dataclass(frozen=True)
class World:
    """A rectangular arena with walls on its edges and obstacles inside.

    Attributes:
        bounds: (xmin, xmax, ymin, ymax) [m].
        obstacles: The obstacles, each at least partly inside the bounds.

    Raises:
        ConfigError: Bounds that are not 4 finite numbers with xmin < xmax and ymin < ymax (at most
            :data:`MAX_WORLD_SIDE` a side), or an obstacle that is not one, lies wholly outside the bounds
            (:func:`lies_outside`) or is too thin (:func:`too_thin`); the message names the obstacle's index.
    """

    bounds: tuple[float, float, float, float]
    obstacles: tuple[Obstacle, ...] = ()

    def __post_init__(self) -> None:
        try:
            b = tuple(float(x) for x in self.bounds)
        except (TypeError, ValueError):
            b = ()
        if len(b) != 4 or not all(np.isfinite(b)):
            raise ConfigError(f"bounds must be 4 finite numbers [xmin, xmax, ymin, ymax], got {self.bounds}")
        if not (b[0] < b[1] and b[2] < b[3]):
            raise ConfigError(f"bounds need xmin < xmax and ymin < ymax, got {b}")
        if max(b[1] - b[0], b[3] - b[2]) > MAX_WORLD_SIDE:
            raise ConfigError(
                f"bounds span {b[1] - b[0]:g} x {b[3] - b[2]:g} m, more than {MAX_WORLD_SIDE:g} m a side (a "
                "TurtleBot3 takes 75 minutes to cross that): give bounds in metres around the area the robot drives"
            )
        object.__setattr__(self, "bounds", b)
        try:
            if isinstance(self.obstacles, Obstacle | str):
                raise TypeError
            object.__setattr__(self, "obstacles", tuple(self.obstacles))
        except TypeError:
            raise ConfigError(
                f"obstacles must be a sequence of obstacles (Circle, Ellipse, Box, Polygon), got {self.obstacles!r}"
            ) from None
        for i, ob in enumerate(self.obstacles):
            if not isinstance(ob, Obstacle):
                raise ConfigError(f"obstacle {i} must be a Circle, Ellipse, Box or Polygon, got {ob!r}")
        for i, ob in enumerate(self.obstacles):
            if why := lies_outside(ob, b) or too_thin(ob):
                raise ConfigError(f"obstacle {i} ({ob.kind}) {why}")

    @property
    def width(self) -> float:
        """Extent along x [m]."""
        return self.bounds[1] - self.bounds[0]

    @property
    def height(self) -> float:
        """Extent along y [m]."""
        return self.bounds[3] - self.bounds[2]

    def seen_at(self, plane: float) -> World:
        """The world a planar laser scanner ``plane`` metres above the floor sees, and a map made from its scans
        holds: the walls and the obstacles that reach above the plane (this world, when every one does). A
        lower obstacle is passed over by the scan, and is in physics and the planners' world only."""
        seen = tuple(ob for ob in self.obstacles if ob.height > plane)
        return self if len(seen) == len(self.obstacles) else World(self.bounds, seen)

    def grid_spacing(self, finest: float, max_cells: int) -> float:
        """Spacing [m] of a square grid over the bounds: ``finest``, or coarser where that would need more
        than ``max_cells`` cells (the collision grid, the 2-D routes)."""
        return max(finest, float(np.sqrt(self.width * self.height / max_cells)))

    def wall_distance(self, points: ArrayLike) -> FloatArray:
        """Distance to the nearest wall, positive inside the bounds [m]. (M,)"""
        p = _points(points)
        xmin, xmax, ymin, ymax = self.bounds
        return np.minimum.reduce([p[..., 0] - xmin, xmax - p[..., 0], p[..., 1] - ymin, ymax - p[..., 1]])

    def obstacle_distance(self, points: ArrayLike) -> FloatArray:
        """Signed distance to the nearest obstacle (walls excluded) [m]; +inf without obstacles. (M,)"""
        p = _points(points)
        out = np.full(p.shape[:-1], np.inf)
        for obs in self.obstacles:
            out = np.minimum(out, obs.signed_distance(p))
        return out

    def signed_distance(self, points: ArrayLike, *, walls: bool = True) -> FloatArray:
        """Signed distance to the nearest obstacle or wall [m], negative inside one. (M,)"""
        d = self.obstacle_distance(points)
        return np.minimum(d, self.wall_distance(points)) if walls else d

    def is_free(self, points: ArrayLike, clearance: float = 0.0) -> NDArray[np.bool_]:
        """Whether discs of radius ``clearance`` [m] (a finite number >= 0) at the points touch nothing. (M,) bool

        Raises:
            ConfigError: ``clearance`` is not a finite number >= 0 (-1 called points inside obstacles free)."""
        clearance = check_number("World.is_free: clearance", clearance, at_least=0.0, unit="m")
        return self.signed_distance(points) > clearance

    def min_feature(self) -> float:
        """Smallest extent among the obstacles [m] (inf without obstacles)."""
        return min((o.min_feature for o in self.obstacles), default=float("inf"))


@overload
def check_world(where: str, value: object, *, none: Literal[""] = "") -> World: ...
@overload
def check_world(where: str, value: object, *, none: str) -> World | None: ...
def check_world(where: str, value: object, *, none: str = "") -> World | None:
    """``value`` when it is a :class:`World` (or None, where ``none`` says what None stands for, as "an empty
    floor" does for a simulator).

    Raises:
        ConfigError: Anything else, naming ``where``, what was given and how to make a world of it
            (``World((0, 3, 0, 3))`` for four numbers, ``load_scenario('open').world`` for a scenario's name).
    """
    if isinstance(value, World) or (none and value is None):
        return value
    if text := numbers_text(value, 4):
        fix = f"World(({text})) for bounds alone"
    elif isinstance(value, str):
        fix = f"load_scenario({value!r}).world"
    else:
        fix = "World((xmin, xmax, ymin, ymax), obstacles), or load_scenario(name).world"
    raise refuse_kind(where, f"a World or None ({none})" if none else "a World", value, fix)
