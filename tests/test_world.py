"""Signed distances checked against a slow reference: distance to a densely sampled boundary."""

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from planning.core.world import Box, Circle, Ellipse, Polygon, World, polygon_area
from planning.errors import ConfigError


def _boundary(obs: object, n: int = 20000) -> np.ndarray:
    s = np.linspace(0, 2 * np.pi, n, endpoint=False)
    if isinstance(obs, Circle):
        return np.asarray(obs.center) + obs.radius * np.column_stack([np.cos(s), np.sin(s)])
    if isinstance(obs, Ellipse):
        a, b = obs.radii
        c, sn = np.cos(obs.angle), np.sin(obs.angle)
        loc = np.column_stack([a * np.cos(s), b * np.sin(s)])
        return loc @ np.array([[c, sn], [-sn, c]]) + np.asarray(obs.center)
    verts = obs.corners() if isinstance(obs, Box) else obs.array
    pts = []
    for a, b in zip(verts, np.roll(verts, -1, axis=0), strict=True):
        u = np.linspace(0, 1, n // len(verts), endpoint=False)[:, None]
        pts.append(a + u * (b - a))
    return np.vstack(pts)


def _inside(obs: object, p: np.ndarray) -> np.ndarray:
    if isinstance(obs, Circle):
        return np.hypot(*(p - obs.center).T) < obs.radius
    if isinstance(obs, Ellipse):
        c, s = np.cos(obs.angle), np.sin(obs.angle)
        d = p - obs.center
        lx, ly = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
        return (lx / obs.radii[0]) ** 2 + (ly / obs.radii[1]) ** 2 < 1
    from matplotlib.path import Path

    verts = obs.corners() if isinstance(obs, Box) else obs.array
    return Path(verts).contains_points(p)


OBSTACLES = [
    Circle((0.3, -0.2), 0.7),
    Ellipse((0.1, 0.2), (1.2, 0.4), 0.7),
    Ellipse((0.0, 0.0), (0.3, 0.9), -0.4),
    Box((0.2, 0.1), (1.0, 0.4), 0.5),
    Polygon(((0, 0), (2, 0), (2, 2), (1, 0.6), (0, 2))),  # non-convex
]


@pytest.mark.parametrize("obs", OBSTACLES, ids=lambda o: o.kind)
def test_signed_distance_matches_dense_boundary_reference(obs: object) -> None:
    rng = np.random.default_rng(3)
    pts = rng.uniform(-2.5, 2.5, size=(400, 2))
    sd = obs.signed_distance(pts)  # type: ignore[attr-defined]
    bnd = _boundary(obs)
    ref = np.min(np.hypot(pts[:, None, 0] - bnd[None, :, 0], pts[:, None, 1] - bnd[None, :, 1]), axis=1)
    ref = np.where(_inside(obs, pts), -ref, ref)
    spacing = np.max(np.hypot(*np.diff(bnd, axis=0).T))
    np.testing.assert_allclose(sd, ref, atol=spacing)  # the reference is off by at most the sample spacing


def test_ellipse_distance_is_exact_against_a_1d_minimisation() -> None:
    e = Ellipse((0.5, -0.3), (1.5, 0.5), 0.3)
    rng = np.random.default_rng(4)
    pts = rng.uniform(-3, 3, size=(50, 2))
    sd = e.signed_distance(pts)
    for p, d in zip(pts, sd, strict=True):
        rot = np.array([[np.cos(e.angle), np.sin(e.angle)], [-np.sin(e.angle), np.cos(e.angle)]])

        def dist(u: float, p: np.ndarray = p, rot: np.ndarray = rot) -> float:
            q = np.array([1.5 * np.cos(u), 0.5 * np.sin(u)]) @ rot + e.center
            return float(np.hypot(*(q - p)))

        grid = np.linspace(0, 2 * np.pi, 721)
        u0 = grid[np.argmin([dist(u) for u in grid])]
        best = minimize_scalar(dist, bounds=(u0 - 0.01, u0 + 0.01), method="bounded", options={"xatol": 1e-12}).fun
        assert abs(abs(d) - best) < 1e-7


def _ellipse_reference(a: float, b: float, p: np.ndarray) -> float:
    """Unsigned distance from p to the axis-aligned ellipse of semi-axes a, b at the origin, by a dense
    angle grid refined with a bounded 1-D minimisation (the parametrisation's angle u)."""

    def dist(u: float) -> float:
        return float(np.hypot(a * np.cos(u) - p[0], b * np.sin(u) - p[1]))

    grid = np.linspace(-0.1, 2 * np.pi + 0.1, 4001)
    k = int(np.argmin([dist(u) for u in grid]))
    return float(
        minimize_scalar(dist, bounds=(grid[k - 1], grid[k + 1]), method="bounded", options={"xatol": 1e-14}).fun
    )


@pytest.mark.parametrize("offset", [1e-3, 1e-6, 1e-9, 1e-11, 1e-13, 1e-17, 1e-200])
def test_ellipse_distance_near_its_major_axis_inside_is_exact(offset: float) -> None:
    """A point just off the major axis inside: the closest-point root lies next to the pole t = -b^2,
    where bisecting t lost up to 4e-5 m (offset 1e-12) and, below 1e-16 m, made the distance -inf."""
    a, b = 0.9, 0.5
    for p in (np.array([0.2, offset]), np.array([offset, offset]), np.array([0.35, -offset])):
        d = float(Ellipse((0.0, 0.0), (a, b)).signed_distance(p)[0])
        assert d < 0 and abs(-d - _ellipse_reference(a, b, p)) < 1e-10, (p, d)


def test_ellipse_distance_at_its_centre_is_minus_its_minor_semi_axis() -> None:
    """Seen from the point at the origin, an ellipse centred a subnormal distance away is a -b deep."""
    e = Ellipse((5.4e-210, 2.1e-258), (0.9152360054504847, 0.5830635839399547))
    assert float(e.signed_distance([0.0, 0.0])[0]) == pytest.approx(-0.5830635839399547, abs=1e-12)
    turned = Ellipse((1e-300, -1e-300), (0.3, 0.9), 1.2)
    assert float(turned.signed_distance([0.0, 0.0])[0]) == pytest.approx(-0.3, abs=1e-12)


def _bisected_ellipse_distance(q0: float, q1: float, a: float, b: float) -> float:
    """Signed distance of a folded point (q0, q1) >= 0 to the ellipse of semi-axes (a, b) by 64 steps of
    Eberly's bisection of the closest-point root in log u: the plain-Python reference of
    :mod:`planning.core.ellipse`, which finds the same root by safeguarded Newton steps."""
    y0, y1, e0, e1 = (q0, q1, a, b) if a >= b else (q1, q0, b, a)
    if not e1 * y1 > 0:
        y1 = 0.0
    if y1 > 0 and y0 > 0:
        d = e0 * e0 - e1 * e1
        lo, hi = e1 * y1, math.hypot(e0 * y0, e1 * y1)
        for _ in range(64):
            mid = math.sqrt(lo) * math.sqrt(hi)
            if (e0 * y0 / (mid + d)) ** 2 + (e1 * y1 / mid) ** 2 - 1.0 > 0:
                lo = mid
            else:
                hi = mid
        u = math.sqrt(lo) * math.sqrt(hi)
        dist = math.hypot(e0 * e0 * y0 / (u + d) - y0, e1 * e1 * y1 / u - y1)
    elif y1 > 0:
        dist = abs(y1 - e1)
    else:
        x0, x1 = e0, 0.0
        if y0 < (e0 * e0 - e1 * e1) / e0:
            x0 = e0 * e0 * y0 / max(e0 * e0 - e1 * e1, 1e-300)
            x1 = e1 * math.sqrt(max(1.0 - (x0 / e0) ** 2, 0.0))
        dist = math.hypot(x0 - y0, x1)
    return -dist if (q0 / a) ** 2 + (q1 / b) ** 2 < 1.0 else dist


def test_ellipse_distance_equals_the_plain_bisection_on_random_and_near_axis_points() -> None:
    """The compiled Newton root against the plain 64-step bisection: random ellipses, points up to 3 m
    out, points a hair off either axis (inside and out) and on the boundary, to 1e-14 m."""
    rng = np.random.default_rng(11)
    worst = 0.0
    for _ in range(200):
        a, b = rng.uniform(0.05, 1.0, 2)
        q = rng.uniform(0.0, 3.0, (40, 2))
        near = rng.uniform(0.0, 1.2 * max(a, b), 10)
        hair = 10.0 ** rng.uniform(-300, -3, 10)
        t = rng.uniform(0, np.pi / 2, 10)
        on = np.column_stack([a * np.cos(t), b * np.sin(t)])
        q = np.vstack([q, np.column_stack([near, hair]), np.column_stack([hair, near]), on])
        got = Ellipse((0.0, 0.0), (float(a), float(b))).signed_distance(q)
        ref = np.array([_bisected_ellipse_distance(float(x), float(y), float(a), float(b)) for x, y in q])
        worst = max(worst, float(np.max(np.abs(got - ref))))
    assert worst <= 1e-14, worst


def test_world_walls_and_minimum() -> None:
    w = World((-1, 1, -2, 2), (Circle((0, 0), 0.5),))
    np.testing.assert_allclose(w.wall_distance([[0.9, 0.0], [0, -1.5]]), [0.1, 0.5])
    np.testing.assert_allclose(w.signed_distance([[0.9, 0.0]]), [0.1])
    np.testing.assert_allclose(w.signed_distance([[0.0, 0.0]]), [-0.5])
    assert w.is_free([[0.0, 1.0]], clearance=0.3).tolist() == [True]
    assert w.is_free([[0.0, 0.7]], clearance=0.3).tolist() == [False]
    assert w.min_feature() == pytest.approx(1.0)
    assert World((0, 1, 0, 1)).obstacle_distance([[0.5, 0.5]])[0] == np.inf
    # thinner than the exact checker resolves (it steps a quarter of the smallest obstacle): refused, named
    with pytest.raises(ConfigError, match=r"obstacle 1 \(box\) is 5e-05 m across, less than the 0.1 mm"):
        World((0, 1, 0, 1), (Circle((0.5, 0.5), 0.1), Box((0.2, 0.2), (0.3, 0.00005))))
    assert World((0, 1, 0, 1), (Circle((0.5, 0.5), 0.00005),)).min_feature() == pytest.approx(0.0001)


@pytest.mark.parametrize(
    ("ctor", "match"),
    [
        (lambda: Circle((0, 0), 0.0), "radius"),
        (lambda: Ellipse((0, 0), (1, -1)), "radii"),
        (lambda: Box((0, 0), (0, 1)), "size"),
        (lambda: Polygon(((0, 0), (1, 1))), "at least 3"),
        (lambda: Polygon(((0, 0), (1, 1), (2, 2))), "zero area"),
        (lambda: World((1, 0, 0, 1)), "xmin < xmax"),
        (lambda: World((0, 1e6, 0, 1e6)), r"1e\+06 x 1e\+06 m, more than 1000 m a side"),  # 65 GB of tree
    ],
)
def test_bad_shapes_are_rejected(ctor: object, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        ctor()  # type: ignore[operator]


@pytest.mark.parametrize(
    ("vertices", "match"),
    [
        (((0, 0), (1, 0), (1, 1), (1, 1), (0, 1)), r"^polygon vertex 3 repeats vertex 2"),
        (((0, 0), (1, 0), (1, 1), (0, 1), (0, 0)), r"^polygon vertex 4 repeats vertex 0"),
        (((0, 0), (2, 0), (2, 2), (0, 2), (3, 1)), r"^edges 1 and 3 cross"),  # signed area 1 m^2
        (((0, 0), (2, 0), (2, 2), (1, 2), (1, 0), (0, 2)), r"^edges 0 and 3 cross"),  # vertex 4 on edge 0
        (((0, 0), (2, 0), (2, 1), (3, 1), (1, 1), (0, 1)), r"^edges 2 and 3 fold back"),
        # a bow tie: 0.5 m^2 in two lobes whose signed areas cancel; it was refused as "polygon has zero area"
        (((1.0, 0.5), (2.0, 1.5), (2.0, 0.5), (1.0, 1.5)), r"^edges 0 and 2 cross .*must not intersect itself"),
        (((0, 0), (1, 1), (2, 2)), r"^polygon has zero area \(its vertices lie on one line\): give vertices that"),
        (((0, 0), (2, 0), (1, 0)), r"^polygon has zero area \(its vertices lie on one line\)"),  # folds back too
    ],
)
def test_degenerate_and_self_intersecting_polygons_are_rejected(
    vertices: tuple[tuple[float, float], ...], match: str
) -> None:
    with pytest.raises(ConfigError, match=match):
        Polygon(vertices)


def test_polygon_orientation_is_normalised() -> None:
    cw = Polygon(((0, 0), (0, 1), (1, 1), (1, 0)))
    assert polygon_area(cw.array) > 0
    assert cw.signed_distance([[0.5, 0.5]])[0] == pytest.approx(-0.5)


@pytest.mark.parametrize(
    "shape",
    [
        Circle(np.array([1, 1]), np.float64(0.2)),
        Box([2, 1.5], [0.4, 0.4], np.float32(0.3)),
        Ellipse([3, 2], np.array([0.3, 0.2])),
        Polygon([[1, 2], [2, 2], [1.5, 2.5]], height=1),
    ],
    ids=lambda s: s.kind,
)
def test_shapes_given_lists_or_arrays_store_tuples_of_floats_and_plan(shape: object) -> None:
    """A shape made of lists or numpy values keeps tuples of floats: it, its world and the collision checker
    built from it (which hashes the world) work as a shape made of tuples does (lists were kept as given, and
    every planner then raised 'unhashable type: list')."""
    from planning import PlanProblem, Pose2D, load_robot, make_planner

    def floats(value: object) -> bool:
        if isinstance(value, tuple):
            return all(floats(v) for v in value)
        return type(value) is float

    names = ("center", "size", "radii", "radius", "angle", "vertices", "height")
    fields = {name: getattr(shape, name) for name in names if hasattr(shape, name)}
    assert len(fields) >= 2 and all(floats(v) for v in fields.values()), fields
    world = World((0, 4, 0, 3), (shape,))  # type: ignore[arg-type]
    assert hash(world) == hash(World((0, 4, 0, 3), (shape,)))  # type: ignore[arg-type]
    problem = PlanProblem(world, load_robot("turtlebot3"), Pose2D(0.4, 0.4, 0), Pose2D(3.6, 0.4, 0), seed=0)
    assert make_planner("birrt").plan(problem).success
