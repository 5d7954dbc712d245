"""Compose the MuJoCo model of a robot in a world: the robot's scene plus obstacles and walls.

Obstacles become static geoms of height ``obstacle_height``: circles are cylinders, boxes are
boxes, ellipses are prisms over a 96-gon that circumscribes the ellipse (MuJoCo's ellipsoid would
shrink with height), and polygons are prisms over the triangles of an ear-clipping triangulation
(MuJoCo collides with the convex hull of each mesh, so each piece must be convex).
"""

from __future__ import annotations

import functools
import math
import re
import warnings
from dataclasses import dataclass

import mujoco
import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.core.geometry import Pose2D
from planning.core.robot import NAMED_ELEMENTS, ROBOTS_DIR, RobotSpec, check_robot_spec, check_scene, load_robot
from planning.core.world import OBSTACLE_HEIGHT, Box, Circle, Ellipse, Polygon, World, check_world, polygon_area
from planning.errors import ModelError
from planning.signals import signals_held
from sim.physics.motors import apply_supply

OBSTACLE_RGBA = (0.72, 0.36, 0.28, 1.0)
#: Obstacles' and walls' contact affinity: bit 0 (every collision geom of the robots, MuJoCo's default) and
#: bit 1, the robots' full-width tyres (contype 2, conaffinity 0 in their MJCF): the tyres touch the
#: obstacles and the walls, never the floor, where the 1 mm collision tyre rolls alone.
OBSTACLE_AFFINITY = 3
WALL_RGBA = (0.55, 0.58, 0.62, 1.0)


@dataclass(frozen=True)
class BuiltModel:
    """A compiled model and the indices the simulator needs.

    Attributes:
        model: The compiled MjModel.
        obstacle_geoms: Geom ids of obstacles and walls.
        robot_geoms: Geom ids of the robot (base subtree).
        obstacle_names: Name per obstacle geom id (obstacle_<i> or wall_<side>).
    """

    model: mujoco.MjModel
    obstacle_geoms: NDArray[np.int64]
    robot_geoms: NDArray[np.int64]
    obstacle_names: dict[int, str]


#: Smallest triangle a polygon obstacle is built of, as a share of the polygon's area: a thinner one (three
#: vertices along a staircase's diagonal) is not a solid MuJoCo can hull ("qhull error", "coplanar vertices").
MIN_TRIANGLE_SHARE = 1e-9


def triangulate(vertices: NDArray[np.float64], name: str = "polygon") -> list[NDArray[np.float64]]:
    """Triangles covering a simple polygon exactly (earcut: collinear and touching vertices handled), each
    (3, 2), counter-clockwise; triangles of no area left out.

    Args:
        vertices: (K, 2) polygon.
        name: The obstacle, as messages name it.

    Raises:
        ModelError: The triangles do not cover the polygon's area (a part of the obstacle would be missing
            from physics while the planners and the map have it), naming the obstacle.
    """
    import mapbox_earcut  # compiled triangulation, loaded when a polygon obstacle is built

    v = np.ascontiguousarray(vertices, dtype=np.float64)
    idx = mapbox_earcut.triangulate_float64(v, np.array([len(v)], dtype=np.uint32)).reshape(-1, 3)
    tris = v[idx]  # (M, 3, 2)
    d1, d2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    area = 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    tris[area < 0] = tris[area < 0][:, ::-1]
    whole = abs(polygon_area(v))
    if not math.isclose(float(np.abs(area).sum()), whole, rel_tol=1e-9, abs_tol=1e-15):
        raise ModelError(
            f"{name}: its triangles cover {np.abs(area).sum():.6g} m^2 of its {whole:.6g} m^2: the polygon is not "
            'simple (it touches or crosses itself); give it as two polygons, or its map as shape = "box"'
        )
    return list(tris[np.abs(area) > MIN_TRIANGLE_SHARE * whole])


def _quat_yaw(theta: float) -> list[float]:
    return [float(np.cos(theta / 2)), 0.0, 0.0, float(np.sin(theta / 2))]


def _add_prism(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    name: str,
    poly: NDArray[np.float64],
    height: float,
    rgba: tuple[float, ...],
) -> None:
    verts = np.vstack(
        [np.column_stack([poly, np.zeros(len(poly))]), np.column_stack([poly, np.full(len(poly), height)])]
    )
    spec.add_mesh(name=f"{name}_mesh", uservert=verts.reshape(-1).tolist())
    mesh = mujoco.mjtGeom.mjGEOM_MESH
    body.add_geom(name=name, type=mesh, meshname=f"{name}_mesh", rgba=list(rgba), conaffinity=OBSTACLE_AFFINITY)


def check_scene_arguments(robot: object, world: object) -> None:
    """Refuse a ``robot`` that is not a :class:`RobotSpec` or a ``world`` that is neither a :class:`World` nor
    None, with a ConfigError naming the argument of :class:`sim.physics.simulator.Simulator` and how to make one
    (they were AttributeErrors from inside the model's compilation)."""
    check_robot_spec("Simulator", robot)
    check_world("Simulator: world", world, none="an empty floor")


def check_named_elements(robot: RobotSpec, model: mujoco.MjModel) -> None:
    """Raise :class:`ModelError` unless the compiled model has every element of :data:`NAMED_ELEMENTS`, naming
    the model file and every one it lacks (a model of one's own that misses one failed deep inside a run)."""
    kinds = {
        "joint": mujoco.mjtObj.mjOBJ_JOINT,
        "actuator": mujoco.mjtObj.mjOBJ_ACTUATOR,
        "sensor": mujoco.mjtObj.mjOBJ_SENSOR,
    }
    missing = [
        f"{kind} {name!r}"
        for kind, names in NAMED_ELEMENTS.items()
        for name in names
        if mujoco.mj_name2id(model, kinds[kind], name) < 0
    ]
    if missing:
        raise ModelError(
            f"{robot.mjcf}: robot {robot.name!r} lacks {', '.join(missing)}, which the simulator reads by name; give "
            f"them as {ROBOTS_DIR / 'turtlebot3_burger.xml'} does (docs/how-to/new-robot.md)"
        )


def _compile_scene(
    robot: RobotSpec, world: World | None, wall_height: float, wall_thickness: float
) -> tuple[mujoco.MjModel, list[str]]:
    """:func:`build_model`'s compiled scene and the names of the obstacles and walls it added, in order."""
    spec = mujoco.MjSpec.from_file(str(robot.scene))
    holder = spec.worldbody.add_body(name="obstacles")
    # One contact sensor counts robot-obstacle contacts in sensordata, so the physics loop needs no
    # Python scan of the contact list unless something is touching. intprm = [data, reduce, num]:
    # data bit 0 = "found", no reduction, one slot.
    spec.add_sensor(
        name="obstacle_contact",
        type=mujoco.mjtSensor.mjSENS_CONTACT,
        objtype=mujoco.mjtObj.mjOBJ_XBODY,
        objname="base",
        reftype=mujoco.mjtObj.mjOBJ_BODY,
        refname="obstacles",
        intprm=[1, 0, 1],
    )
    names: list[str] = []
    if world is not None:
        names += _add_obstacles(spec, holder, world)
        names += _add_walls(holder, world, wall_height, wall_thickness)
        xmin, xmax, ymin, ymax = world.bounds
        spec.stat.extent = float(max(xmax - xmin, ymax - ymin))
        spec.stat.center = [(xmin + xmax) / 2, (ymin + ymax) / 2, 0.0]
    return spec.compile(), names


class MujocoWarning(RuntimeWarning):
    """A warning MuJoCo gave (an unstable simulation, a buffer too small), as Python's ``warnings`` say it."""


def _warn(message: str) -> None:
    try:
        warnings.warn(f"MuJoCo: {message}", MujocoWarning, stacklevel=2)
    except MujocoWarning:  # warnings made errors (-W error): not raised through MuJoCo's C; the run counts it
        pass


def route_mujoco_warnings() -> None:
    """Have MuJoCo's warnings said through Python's ``warnings`` (:class:`MujocoWarning`, on stderr, filterable),
    unless a handler of one's own is set: MuJoCo's default prints them to stdout and appends them to
    ``MUJOCO_LOG.TXT`` in the working folder, which a refused command then left behind. A run still counts
    them in its ``warnings`` metric (``data.warning``)."""
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_warn)


def build_model(
    robot: RobotSpec,
    world: World | None = None,
    *,
    wall_height: float = OBSTACLE_HEIGHT,
    wall_thickness: float = 0.05,
) -> BuiltModel:
    """Compile the robot's scene with the world's obstacles and walls.

    Args:
        robot: The robot (its scene file is loaded).
        world: Bounds and obstacles; None for the bare scene.
        wall_height: Height of the boundary walls [m] (above a laser scanner's plane: the
            TurtleBot3's LDS-01 scans 0.182 m above the floor).
        wall_thickness: Thickness of the walls, placed outside the bounds [m].

    Returns:
        The compiled model and its geom indices.

    Raises:
        ConfigError: ``robot`` is not a RobotSpec (a robot's name is not), or ``world`` not a World or None
            (named as :class:`sim.physics.simulator.Simulator`'s arguments, the public way here).
    """
    check_scene_arguments(robot, world)
    check_scene(robot)
    route_mujoco_warnings()
    with signals_held():  # an interrupt inside a binding's argument conversion became its TypeError: it waits
        try:
            model, names = _compile_scene(robot, world, wall_height, wall_thickness)
        except ValueError as exc:  # MuJoCo's XML or compile error: the robot's own files, or a world's obstacle
            if (hit := re.search(r"obstacle_(\d+)", str(exc))) is not None and world is not None:
                k = int(hit.group(1))
                raise ModelError(
                    f"MuJoCo cannot build world obstacle {k} ({world.obstacles[k].kind}) in physics: {exc}"
                ) from None
            raise ModelError(f"robot {robot.name!r}: MuJoCo cannot load its scene {robot.scene}: {exc}") from None
    check_named_elements(robot, model)
    if robot.battery_voltage > 0:
        apply_supply(model, robot.battery_voltage)  # the run's battery (nothing at the model's own)
    obstacle_ids = np.array([model.geom(n).id for n in names], dtype=np.int64)
    base = model.body("base").id
    robot_bodies = {b for b in range(model.nbody) if b == base or _has_ancestor(model, b, base)}
    robot_ids = np.array([g for g in range(model.ngeom) if model.geom_bodyid[g] in robot_bodies], dtype=np.int64)
    return BuiltModel(model, obstacle_ids, robot_ids, {int(i): n for i, n in zip(obstacle_ids, names, strict=True)})


def _add_obstacles(spec: mujoco.MjSpec, holder: mujoco.MjsBody, world: World) -> list[str]:
    """Add the world's obstacles as static geoms, each of its own height [m]; returns their geom names in order."""
    names: list[str] = []
    for i, obs in enumerate(world.obstacles):
        name = f"obstacle_{i}"
        h = obs.height
        if isinstance(obs, Circle):
            holder.add_geom(
                name=name,
                type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                size=[obs.radius, h / 2, 0],
                pos=[obs.center[0], obs.center[1], h / 2],
                rgba=list(OBSTACLE_RGBA),
                conaffinity=OBSTACLE_AFFINITY,
            )
            names.append(name)
        elif isinstance(obs, Box):
            holder.add_geom(
                name=name,
                type=mujoco.mjtGeom.mjGEOM_BOX,
                size=[obs.size[0] / 2, obs.size[1] / 2, h / 2],
                pos=[obs.center[0], obs.center[1], h / 2],
                quat=_quat_yaw(obs.angle),
                rgba=list(OBSTACLE_RGBA),
                conaffinity=OBSTACLE_AFFINITY,
            )
            names.append(name)
        elif isinstance(obs, Ellipse):
            n = 96
            ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
            scale = 1.0 / np.cos(np.pi / n)  # circumscribe: the prism contains the ellipse
            a, b = obs.radii
            local = np.column_stack([a * scale * np.cos(ang), b * scale * np.sin(ang)])
            c, s = np.cos(obs.angle), np.sin(obs.angle)
            poly = local @ np.array([[c, s], [-s, c]]) + np.asarray(obs.center)
            _add_prism(spec, holder, name, poly, h, OBSTACLE_RGBA)
            names.append(name)
        elif isinstance(obs, Polygon):
            for k, tri in enumerate(triangulate(obs.array, f"world obstacle {i} (a polygon)")):
                piece = f"{name}_{k}"
                _add_prism(spec, holder, piece, tri, h, OBSTACLE_RGBA)
                names.append(piece)
    return names


def _add_walls(holder: mujoco.MjsBody, world: World, height: float, thickness: float) -> list[str]:
    """Add four boundary walls of ``height`` and ``thickness`` [m] just outside the world's bounds;
    returns their geom names."""
    xmin, xmax, ymin, ymax = world.bounds
    t = thickness
    cx, cy = (xmin + xmax) / 2, (ymin + ymax) / 2
    walls = {
        "wall_west": ([xmin - t / 2, cy], [t / 2, (ymax - ymin) / 2 + t]),
        "wall_east": ([xmax + t / 2, cy], [t / 2, (ymax - ymin) / 2 + t]),
        "wall_south": ([cx, ymin - t / 2], [(xmax - xmin) / 2 + t, t / 2]),
        "wall_north": ([cx, ymax + t / 2], [(xmax - xmin) / 2 + t, t / 2]),
    }
    for name, (pos, half) in walls.items():
        holder.add_geom(
            name=name,
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[half[0], half[1], height / 2],
            pos=[pos[0], pos[1], height / 2],
            rgba=list(WALL_RGBA),
            conaffinity=OBSTACLE_AFFINITY,
        )
    return list(walls)


def _has_ancestor(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    while body > 0:
        body = int(model.body_parentid[body])
        if body == ancestor:
            return True
    return False


@nb.njit(cache=True)
def yaw_from_quat(w: float, x: float, y: float, z: float) -> float:
    """Heading [rad] of a unit quaternion (rotation about z of the body x-axis)."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def set_pose(model: mujoco.MjModel, data: mujoco.MjData, pose: Pose2D, *, settle: float = 0.5) -> None:
    """Place the robot's free joint at a planar pose, at rest on the floor.

    The robot is put at its model height, level, then left alone (no motor voltage) for ``settle``
    seconds so the soft contacts take up its weight (the tyres sink about 0.2 mm and the base tilts
    by a few mrad onto its caster or skid), and moved back to the pose's x, y and heading with zero
    velocity and time 0. A run then starts from rest, not with the robot dropping onto the floor.

    Args:
        model: The compiled model.
        data: Its data (modified).
        pose: Planar pose of the base (the axle's midpoint) [m, m, rad].
        settle: Seconds of physics to come to rest; 0 leaves the robot level at its model height.
    """
    adr = model.jnt_qposadr[model.joint("root").id]
    data.qpos[adr : adr + 2] = [pose.x, pose.y]
    data.qpos[adr + 2] = model.body_pos[model.body("base").id][2]
    data.qpos[adr + 3 : adr + 7] = _quat_yaw(pose.theta)
    data.qvel[:] = 0.0
    if settle > 0:
        data.ctrl[:] = 0.0
        mujoco.mj_step(model, data, nstep=max(1, round(settle / model.opt.timestep)))
        w, x, y, z = data.qpos[adr + 3 : adr + 7]
        drift = yaw_from_quat(w, x, y, z) - pose.theta
        turn = np.empty(4)
        mujoco.mju_mulQuat(turn, np.array(_quat_yaw(-drift)), data.qpos[adr + 3 : adr + 7].copy())
        data.qpos[adr + 3 : adr + 7] = turn
        data.qpos[adr : adr + 2] = [pose.x, pose.y]
        data.qvel[:] = 0.0
        data.time = 0.0
    mujoco.mj_forward(model, data)


@functools.cache
def robot_timestep(name: str) -> float:
    """The physics timestep [s] of a registered robot's model (compiled once per process)."""
    return float(build_model(load_robot(name)).model.opt.timestep)


#: Seconds the body is held level on the floor before :func:`rolling_radius` reads the contacts.
ROLLING_SETTLE = 0.5
_ROLLING: dict[tuple[str, float], float] = {}


def rolling_radius(robot: RobotSpec) -> float:
    """The wheels' rolling radius under the robot's weight [m]: what the robot's odometry should
    multiply its wheel angles by, as calibrated on the drawing's build (computed once per process).

    MuJoCo's soft contact lets a loaded tyre sink into the floor (0.2 mm for the TurtleBot3) and
    puts the contact point, where the no-slip constraint acts, midway through that penetration, so
    the wheel rolls on the distance from its axle to that point: the drawn radius less half the
    sink (TurtleBot3 -0.31 %, EduMIP -0.35 %, the balancing EduMIP -0.38 %, all of its weight on
    the wheels). It is read with the body held level at rest on an empty floor for
    :data:`ROLLING_SETTLE` seconds (a balancing robot stands on its wheels as its firmware holds it;
    the others on their wheels and skid or caster): the mean over both tyres' contacts of the height
    of the tyre's axis above the contact point. A steady straight drive travels this far per radian
    within 0.02 %, at any speed (tests/test_models.py).

    Raises:
        ModelError: A tyre (``wheel_<side>_geom``) does not touch the floor at rest.
    """
    key = (str(robot.mjcf), robot.wheel_radius)
    if key not in _ROLLING:
        _ROLLING[key] = _held_level_contact_radius(build_model(robot).model)
    return _ROLLING[key]


def _held_level_contact_radius(model: mujoco.MjModel) -> float:
    data = mujoco.MjData(model)
    set_pose(model, data, Pose2D(0.0, 0.0, 0.0), settle=0.0)
    root = model.joint("root")
    q, v = int(root.qposadr[0]), int(root.dofadr[0])
    level = data.qpos[q + 3 : q + 7].copy()
    for _ in range(max(1, round(ROLLING_SETTLE / model.opt.timestep))):
        mujoco.mj_step(model, data)
        data.qpos[q + 3 : q + 7] = level  # the body level, free to sink onto its wheels
        data.qvel[v : v + 2] = 0.0
        data.qvel[v + 3 : v + 6] = 0.0
    mujoco.mj_forward(model, data)
    heights: list[float] = []
    for side in ("left", "right"):
        tyre = model.geom(f"wheel_{side}_geom").id
        touching = [c for c in data.contact[: data.ncon] if tyre in (c.geom1, c.geom2)]
        if not touching:
            raise ModelError(f"rolling_radius: the tyre wheel_{side}_geom does not touch the floor at rest")
        heights += [float(data.geom_xpos[tyre, 2] - c.pos[2]) for c in touching]
    return float(np.mean(heights))


def scale_wheels(model: mujoco.MjModel, factor: float) -> None:
    """Scale the radius of the wheel geoms of a compiled model in place (a wheel-radius error).

    The collision tyres (``wheel_*_geom``) and the visual tyres (``wheel_*_tyre``) get radius
    ``factor * r``; their bounding radii and boxes follow. The axle rises by the change in radius
    (the base body's rest height, so :func:`set_pose` still puts the tyres on the floor), and the
    base body's own geoms (chassis, caster or skids) and the parts welded to it move down by as much
    in the body frame, so they keep their height above the floor: only the rolling radius changes,
    not how the weight is shared between wheels and caster. The wheels' touch-sensor zones
    (``wheel_*_contact`` sites) grow with the tyre. Call ``mujoco.mj_setConst`` afterwards.

    Args:
        model: The compiled model (modified).
        factor: New radius over the model's radius (> 0).
    """
    old = None
    for side in ("left", "right"):
        for suffix in ("geom", "tyre"):
            try:
                g = model.geom(f"wheel_{side}_{suffix}").id
            except KeyError:
                continue
            r = float(model.geom_size[g, 0])
            if suffix == "geom":
                old = r
            model.geom_size[g, 0] = r * factor
            half = float(model.geom_size[g, 1])
            model.geom_rbound[g] = float(np.hypot(r * factor, half))
            model.geom_aabb[g, 3:6] = [r * factor, r * factor, half]
    if old is None:
        raise ValueError("the model has no wheel_left_geom / wheel_right_geom to scale")
    base = model.body("base").id
    rise = old * (factor - 1.0)
    model.body_pos[base, 2] += rise
    model.geom_pos[model.geom_bodyid == base, 2] -= rise
    welded = (model.body_parentid == base) & (model.body_jntnum == 0)  # parts fixed to the base (LDS, caster)
    model.body_pos[welded, 2] -= rise
    for side in ("left", "right"):  # the touch sensors' zones keep their margin round the tyre
        try:
            site = model.site(f"wheel_{side}_contact").id
        except KeyError:
            continue
        model.site_size[site, 0] += rise


def body_pitch(quat: NDArray[np.float64]) -> NDArray[np.float64]:
    """Pitch [rad] of the body's axis in its heading's vertical plane, positive tipping forward.

    Args:
        quat: (..., 4) unit quaternions (w, x, y, z) of the base.
    """
    w, x, y, z = np.moveaxis(np.asarray(quat, dtype=float), -1, 0)
    ax, ay, az = 2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)  # body z axis in the world
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.arctan2(np.cos(yaw) * ax + np.sin(yaw) * ay, az)  # type: ignore[no-any-return]


def touches(d: mujoco.MjData, geom: int, other: int) -> bool:
    """Whether geoms ``geom`` and ``other`` are in contact now (the chassis and the floor: the robot has fallen;
    its wheels, skids or caster are all that touch the floor while it stands, and the chassis brushing an
    obstacle while upright is a collision, counted as one, not a fall)."""
    n = d.ncon
    if n == 0:
        return False
    pair = {geom, other}  # a handful of contacts, read once per control period: plain Python beats numpy's
    return any({a, b} == pair for a, b in d.contact.geom[:n].tolist())  # per-call costs (1.5 against 5.7 us)


#: The tilt [rad] past which a robot that does not balance has fallen over (its body's z axis from the vertical,
#: the balancing EduMIP's tip angle): driving, the skid EduMIP tilts up to 0.19 rad on its skids, the TurtleBot3
#: 0.01 rad; tipped on its side (a TurtleBot3 rests on a wheel and its chassis stays off the floor) it is 1.6.
TIP_ANGLE = 0.85


#: The tilt [rad] past which a robot that does not balance, its chassis on the floor, has fallen: below it the
#: chassis drags on the floor of a robot standing on its wheels, pitched up against an obstacle it pushes (a
#: TurtleBot3's tail touches the floor from 0.14 rad of pitch: it collided, and drives on).
FLOOR_TILT = 0.5


def tipped_over(d: mujoco.MjData, body: int, chassis: int, floor: int) -> bool:
    """Whether a robot that does not balance has fallen over: its body ``body`` tilted past :data:`TIP_ANGLE`, or its
    chassis on the floor with the body tilted past :data:`FLOOR_TILT` (the balancing robot's firmware makes the
    same test with its own tip angle)."""
    up = d.xmat[body][8]  # the cosine of the body's tilt
    return bool(up < math.cos(TIP_ANGLE)) or (up < math.cos(FLOOR_TILT) and touches(d, chassis, floor))
