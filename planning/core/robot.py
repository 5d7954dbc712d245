"""Kinematic robot specifications, read from the robots' MJCF files.

The planner and the physics must never disagree, so every number the planners and trackers use
(wheel radius, track width, footprint, speed and rate limits) is read from the same MJCF file
MuJoCo loads: geometry from the geoms and bodies, and the wheel-speed and planning limits from
``<custom><numeric name="nhsim_..."/>`` entries (the wheels are driven by DC motors whose
``ctrlrange`` is a voltage, so the wheel-speed limit the motors sustain is a numeric too).
"""

from __future__ import annotations

import functools
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from planning.core.checks import check_number
from planning.core.plugins import Registry, check_registration
from planning.errors import ConfigError, ModelError

FloatArray = NDArray[np.float64]

MODELS_DIR = Path(__file__).resolve().parents[2] / "models"
ROBOTS_DIR = MODELS_DIR / "robots"
SENSORS_DIR = MODELS_DIR / "sensors"


@dataclass(frozen=True)
class RobotFiles:
    """The files a robot is made of: what :func:`register_robot` registers under the robot's name.

    Attributes:
        mjcf: Its MJCF model (the bodies, geoms and ``nhsim_*`` numerics :func:`load_robot` reads;
            docs/how-to/new-robot.md). Its scene, ``<stem>_scene.xml`` beside it, includes it with a floor and a
            light.
        sensors: Its sensor settings file: a ``[sensors]`` table (:mod:`sim.physics.sensors`: encoders, IMU, pose
            fixes) and, for a laser scanner, a ``[lidar]`` one (``models/sensors/turtlebot3.toml`` is one).

    A value is its own factory (the registries hold factories): calling it returns it.
    """

    mjcf: Path
    sensors: Path

    def __call__(self) -> RobotFiles:
        return self

    @property
    def scene(self) -> Path:
        """Its scene file (:func:`scene_path`)."""
        return scene_path(self.mjcf)

    @property
    def registry_text(self) -> str:
        """How a message shows the registration: the model's path."""
        return f"{self.mjcf} (sensors {self.sensors})"


def scene_path(mjcf: Path) -> Path:
    """The scene file of a robot's model: ``<stem>_scene.xml`` beside it (the floor and light, including it)."""
    return mjcf.with_name(f"{mjcf.stem}_scene.xml")


#: The entry-point group of robot plugins: ``mypkg = "mypkg.robots"`` names a module whose import registers
#: robots (:func:`register_robot`); ``kobuki = "mypkg.robots:KOBUKI"`` registers a :class:`RobotFiles`
#: under the entry point's name.
PLUGIN_GROUP = "nhsim.robots"

#: Robot name -> its files (:class:`RobotFiles`), the names accepted everywhere (``--robot``, a scenario's
#: ``robot``, the run records). Its plugins (:mod:`planning.core.plugins`) load at its first lookup of a name,
#: listing or count.
ROBOTS: Registry[RobotFiles] = Registry(
    "robot",
    PLUGIN_GROUP,
    {
        "turtlebot3": RobotFiles(ROBOTS_DIR / "turtlebot3_burger.xml", SENSORS_DIR / "turtlebot3.toml"),
        "edumip": RobotFiles(ROBOTS_DIR / "edumip.xml", SENSORS_DIR / "edumip.toml"),
        # the balancing EduMIP carries the EduMIP's sensors
        "edumip-balancing": RobotFiles(ROBOTS_DIR / "edumip_balancing.xml", SENSORS_DIR / "edumip.toml"),
    },
)


def register_robot(
    name: str, mjcf: str | os.PathLike[str], *, sensors: str | os.PathLike[str], replace: bool = False
) -> None:
    """Register a robot of your own by name: its MJCF model and its sensor settings file.

    A call registers it in the running process (:func:`load_robot`, a :class:`~planning.scenario.Scenario`'s
    ``robot``, ``sim.cli.main.main([...])`` called from it). For the ``nhsim`` command and fresh worker
    processes to know it, make the registration a plugin: a module named by ``NHSIM_PLUGINS`` or an entry point
    of group ``nhsim.robots`` (:data:`PLUGIN_GROUP`) in an installed package (docs/how-to/new-robot.md). Its
    build tolerances (``--build as-built``, the default) are ``sim.physics.asbuilt.TOLERANCES[name]``, set by the
    same module; without them it runs as drawn only (``--build nominal``).

    Args:
        name: The robot's name: non-empty text without commas or whitespace.
        mjcf: Its MJCF file, read now: a model :func:`load_robot` refuses is refused here, naming what is
            wrong; its scene, ``<stem>_scene.xml`` (a floor and a light, including the model), must be beside it.
        sensors: Its sensor settings file: ``[sensors]`` and, with a laser scanner, ``[lidar]`` (the layout of
            ``models/sensors/turtlebot3.toml``; its numbers are checked when a run reads them).
        replace: Replace a robot registered under ``name`` already (a built-in one too).

    Raises:
        ConfigError: A bad name, a missing file, or a name taken by other files without ``replace``.
        ModelError: The model is not one :func:`load_robot` reads, or has no scene file beside it.
    """
    # the name as the other registries check theirs (the target checked is the files' type, callable as a factory)
    check_registration("register_robot", name, RobotFiles, kind="robot", flag="--robot NAME", examples=("kobuki", ""))
    files = RobotFiles(_existing(name, "mjcf", mjcf, ".xml"), _existing(name, "sensors", sensors, ".toml"))
    spec = _parse_robot(name, files.mjcf, files.mjcf.read_bytes())
    check_scene(spec)
    ROBOTS.add("register_robot", name, files, replace)


def check_scene(robot: RobotSpec) -> None:
    """Raise :class:`ModelError` unless the robot's scene file (:attr:`RobotSpec.scene`) exists and includes the
    robot's model, naming the file to copy or the ``<include>`` to write (a scene left including the Burger
    simulated the Burger, or failed to open a file that was not there)."""
    copy = f"copy {ROBOTS_DIR / 'turtlebot3_burger_scene.xml'} beside it and make its <include> name {robot.mjcf.name}"
    if not robot.scene.is_file():
        raise ModelError(
            f"robot {robot.name!r} has no scene file {robot.scene} (the floor and light, which include "
            f"{robot.mjcf.name}): {copy}"
        )
    try:
        included = [e.get("file", "") for e in ET.parse(robot.scene).getroot().iter("include")]
    except (OSError, ET.ParseError) as exc:
        raise ModelError(f"cannot read the scene file of robot {robot.name!r}, {robot.scene}: {exc}") from exc
    here = robot.scene.parent
    if not any((here / name).resolve() == robot.mjcf.resolve() for name in included if name):
        said = ", ".join(included) if any(included) else "no file"
        raise ModelError(
            f"the scene file of robot {robot.name!r}, {robot.scene}, includes {said}, not its model "
            f'{robot.mjcf.name}: make its <include file="{robot.mjcf.name}"/>'
        )


def _existing(name: str, what: str, path: object, suffix: str) -> Path:
    """``path`` as an absolute Path when it names an existing ``suffix`` file (for :func:`register_robot`)."""
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise ConfigError(f"register_robot({name!r}): {what} must be the path of a {suffix} file, got {path!r:.80}")
    found = Path(path).expanduser().resolve()
    if not found.is_file() or found.suffix != suffix:
        what_is = (
            "is a folder" if found.is_dir() else "does not exist" if not found.exists() else f"is not a {suffix} file"
        )
        raise ConfigError(
            f"register_robot({name!r}): {what} {str(path)!r} {what_is}; give the path of its {suffix} file"
        )
    return found


def robot_files(name: str) -> RobotFiles:
    """The files of the robot registered as ``name``.

    Raises:
        ConfigError: Unknown name (listing the robots, and how a plugin's is registered).
    """
    files = ROBOTS.factory(name)()
    if not isinstance(files, RobotFiles):
        raise ConfigError(
            f"robot {name!r} ({ROBOTS.origin(name)}) is registered as {files!r:.80}, not RobotFiles(mjcf, sensors); "
            "register it with register_robot(name, 'path/robot.xml', sensors=...)"
        )
    return files


def robot_names() -> str:
    """The robots' names, sorted and comma-separated, for the messages that list them (the plugins loaded)."""
    return ", ".join(sorted(ROBOTS))


@dataclass(frozen=True, eq=False)
class RobotSpec:
    """What planners and trackers know about a differential-drive robot.

    Two specs are equal when every field is (the footprint's vertices compared exactly,
    ``np.array_equal``): ``load_robot(name)`` twice gives equal specs. A spec hashes by its scalar fields,
    so equal specs hash alike and it can key a dict or a cache.

    Attributes:
        name: Registry name ("turtlebot3", "edumip").
        mjcf: Path of the robot's MJCF file.
        scene: Path of the scene file (floor and light) that includes it.
        wheel_radius: r [m].
        track_width: Distance between the wheels' contact lines [m].
        max_speed: |v| limit [m/s].
        max_yaw_rate: |omega| limit [rad/s].
        max_accel: |dv/dt| limit [m/s^2].
        max_yaw_accel: |domega/dt| limit [rad/s^2].
        max_wheel_speed: Wheel-speed limit the motors sustain (``nhsim_max_wheel_speed``) [rad/s].
        wheelbase: Virtual wheelbase l of the bicycle model [m].
        max_steering: Virtual steering-angle bound |phi| [rad].
        footprint: (K, 2) convex footprint in the base frame, counter-clockwise [m]: the x-y projection
            of the base's and the wheels' geoms, the base's swept through every pitch within
            ``footprint_pitch`` about the wheel axle.
        mass: Total mass [kg].
        footprint_pitch: |pitch| the footprint covers the body at (``nhsim_footprint_pitch``; 0 for a
            body held level by skids or casters) [rad].
        battery_voltage: The supply the wheel motors run on (``nhsim_motor_battery_voltage``; the speed
            limits above are those of this voltage, :mod:`sim.physics.motors`) [V]; 0 when not given.
    """

    name: str
    mjcf: Path
    scene: Path
    wheel_radius: float
    track_width: float
    max_speed: float
    max_yaw_rate: float
    max_accel: float
    max_yaw_accel: float
    max_wheel_speed: float
    wheelbase: float
    max_steering: float
    footprint: FloatArray = field(repr=False)
    mass: float = 0.0
    footprint_pitch: float = 0.0
    battery_voltage: float = 0.0

    def __post_init__(self) -> None:
        """Check the name and every number (:func:`check_spec`): a spec is the planners' and trackers' word on the
        robot; the footprint is held as a read-only float array (a list was taken, and ``radius`` then failed)."""
        if not isinstance(self.name, str) or not self.name.strip():
            raise ConfigError(f"RobotSpec: name must be the robot's name (text), got {self.name!r:.60}")
        try:
            footprint = np.array(self.footprint, dtype=float)  # a copy: the caller's array stays theirs
        except (TypeError, ValueError):
            got = f"{self.footprint!r:.60}"
            raise ConfigError(
                f"robot {self.name!r}: the footprint must be (K >= 3, 2) finite vertices [m], got {got}"
            ) from None
        footprint.flags.writeable = False
        object.__setattr__(self, "footprint", footprint)
        check_spec(self)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RobotSpec) or other.__class__ is not self.__class__:
            return NotImplemented
        return self._scalars() == other._scalars() and np.array_equal(self.footprint, other.footprint)

    def __hash__(self) -> int:
        return hash(self._scalars())

    def _scalars(self) -> tuple[object, ...]:
        """Every field but the footprint (an array: compared apart, and left out of the hash)."""
        return tuple(getattr(self, f.name) for f in fields(self) if f.name != "footprint")

    @functools.cached_property
    def radius(self) -> float:
        """Radius of the smallest disc about the base origin that holds the footprint [m] (computed once)."""
        return float(np.max(np.hypot(self.footprint[:, 0], self.footprint[:, 1])))

    def footprint_at(self, poses: FloatArray) -> FloatArray:
        """Footprint polygons placed at poses.

        Args:
            poses: (M, 3) poses [x, y, theta].

        Returns:
            (M, K, 2) world-frame vertices [m].
        """
        p = np.atleast_2d(np.asarray(poses, dtype=float))
        c, s = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
        fx, fy = self.footprint[None, :, 0], self.footprint[None, :, 1]
        return np.stack([p[:, :1] + c * fx - s * fy, p[:, 1:2] + s * fx + c * fy], axis=-1)


#: A spec's numbers and the model numeric each is read from (:func:`load_robot`), as a message names them.
NUMERICS: dict[str, str] = {
    "max_speed": "nhsim_max_linear_speed",
    "max_yaw_rate": "nhsim_max_angular_speed",
    "max_accel": "nhsim_max_linear_accel",
    "max_yaw_accel": "nhsim_max_angular_accel",
    "max_wheel_speed": "nhsim_max_wheel_speed",
    "wheelbase": "nhsim_wheelbase",
    "max_steering": "nhsim_max_steering_angle",
    "footprint_pitch": "nhsim_footprint_pitch",
    "battery_voltage": "nhsim_motor_battery_voltage",
    "wheel_radius": "the size of geom 'wheel_left_geom'",
    "track_width": "the y distance between bodies 'wheel_left' and 'wheel_right'",
}
#: Bounds of a spec's numbers beyond any wheeled robot's (0.165 m/s and 5 rad/s for the TurtleBot3): a speed of
#: 1e9 m/s made a turning radius whose curves asked for 745 GiB.
_CEILINGS: dict[str, tuple[float, str]] = {
    "wheel_radius": (2.0, "m"),
    "track_width": (10.0, "m"),
    "max_speed": (50.0, "m/s"),
    "max_yaw_rate": (100.0, "rad/s"),
    "max_accel": (1000.0, "m/s^2"),
    "max_yaw_accel": (10000.0, "rad/s^2"),
    "max_wheel_speed": (1000.0, "rad/s"),
    "wheelbase": (10.0, "m"),
}


def inscribed_radius(robot: RobotSpec, shape: str) -> float:
    """Radius [m] of the largest disc about the base origin inside the robot (its footprint, or the disc): what
    every pose of any collision-free path keeps off everything, which a 2-D search can prove impossible."""
    if shape == "disc":
        return float(robot.radius)
    a = robot.footprint
    b = np.roll(a, -1, axis=0)
    edge = b - a
    cross = edge[:, 0] * a[:, 1] - edge[:, 1] * a[:, 0]  # one sign on every edge: the origin is inside (convex)
    if not (np.all(cross > 0.0) or np.all(cross < 0.0)):
        return 0.0  # the origin on or outside the outline (a plugin's robot): no disc about it is inside
    return float(np.min(np.abs(cross) / np.hypot(edge[:, 0], edge[:, 1])))


def check_spec(spec: RobotSpec) -> None:
    """Raise unless every number of ``spec`` is one a differential-drive robot has.

    Each of :data:`_CEILINGS` is a finite number above 0 and at most its ceiling; the steering bound in (0, pi/2)
    [rad]; the footprint's pitch in [0, pi/2), the battery's voltage at least 0, the mass at least 0; the footprint
    (K >= 3, 2) finite; and the speed limits within the wheels' reach: ``max_speed <= r max_wheel_speed`` and
    ``max_yaw_rate <= 2 r max_wheel_speed / track`` (1e-9 of slack for a decimal rounded down).

    Raises:
        ConfigError: The first number that is not (named, with the model numeric it is read from).
    """

    def where(name: str) -> str:
        return f"robot {spec.name!r}: {name} ({NUMERICS[name]})" if name in NUMERICS else f"robot {spec.name!r}: {name}"

    for name, (ceiling, unit) in _CEILINGS.items():
        check_number(where(name), getattr(spec, name), above=0.0, at_most=ceiling, unit=unit)
    check_number(where("max_steering"), spec.max_steering, above=0.0, below=math.pi / 2, unit="rad")
    check_number(where("footprint_pitch"), spec.footprint_pitch, at_least=0.0, below=math.pi / 2, unit="rad")
    check_number(where("battery_voltage"), spec.battery_voltage, at_least=0.0, unit="V, 0 when not given")
    check_number(where("mass"), spec.mass, at_least=0.0, unit="kg")
    hull = np.asarray(spec.footprint)
    if hull.ndim != 2 or hull.shape[0] < 3 or hull.shape[1] != 2 or not np.all(np.isfinite(hull)):
        raise ConfigError(
            f"robot {spec.name!r}: the footprint must be (K >= 3, 2) finite vertices [m], got an array of shape "
            f"{hull.shape}; give the base's and the wheels' geoms in the model"
        )
    reach = spec.wheel_radius * spec.max_wheel_speed
    for name, most in (("max_speed", reach), ("max_yaw_rate", 2.0 * reach / spec.track_width)):
        if getattr(spec, name) > most * (1.0 + 1e-9):
            raise ConfigError(
                f"{where(name)} = {getattr(spec, name):g} is beyond what the wheels reach at max_wheel_speed "
                f"({spec.max_wheel_speed:g} rad/s on a radius of {spec.wheel_radius:g} m, a track of "
                f"{spec.track_width:g} m: {most:.6g}); lower it, or raise nhsim_max_wheel_speed if the motors "
                "sustain more"
            )


def _floats(text: str | None, n: int | None = None, what: str = "") -> FloatArray:
    if text is None:
        raise ModelError(f"missing attribute {what}")
    try:
        vals = np.array([float(x) for x in text.split()])
    except ValueError:
        raise ModelError(f"{what} must be numbers separated by spaces, got {text!r:.80}") from None
    if n is not None and vals.size != n:
        raise ModelError(f"{what} needs {n} numbers, got {text!r}")
    return vals


def _euler_matrix(euler: FloatArray) -> FloatArray:
    """Rotation matrix for MuJoCo's default 'xyz' intrinsic Euler sequence."""
    a, b, c = euler
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return rx @ ry @ rz


def _geom_attrs(geom: ET.Element, defaults: dict[str, dict[str, str]]) -> dict[str, str]:
    """A geom's attributes over those of its default class."""
    attrs = dict(defaults.get(geom.get("class", ""), {}))
    attrs.update(geom.attrib)
    return attrs


#: The single pitch of a body that does not pitch [rad].
UPRIGHT: FloatArray = np.zeros(1)


def _pitched_xy(points: FloatArray, pitches: FloatArray) -> FloatArray:
    """(P * N, 2) x-y projections of (N, 3) points turned about the y axis by each of (P,) pitches [rad];
    a positive pitch tips +z towards +x: x -> x cos a + z sin a, y stays."""
    x = np.outer(np.cos(pitches), points[:, 0]) + np.outer(np.sin(pitches), points[:, 2])
    return np.column_stack([x.ravel(), np.tile(points[:, 1], pitches.size)])


def _geom_outline(
    geom: ET.Element, defaults: dict[str, dict[str, str]], offset: FloatArray, pitches: FloatArray = UPRIGHT
) -> FloatArray:
    """Points whose planar convex hull covers the geom's x-y projection, the geom turned about the frame's
    y axis by each of ``pitches`` [rad]."""
    attrs = _geom_attrs(geom, defaults)
    gtype = attrs.get("type", "sphere")
    size = _floats(attrs.get("size", "0"), what="geom size")
    pos = _floats(attrs.get("pos", "0 0 0"), 3, "geom pos") + offset
    rot = _euler_matrix(_floats(attrs["euler"], 3, "euler")) if "euler" in attrs else np.eye(3)
    if gtype == "sphere":
        ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
        ring = size[0] * np.column_stack([np.cos(ang), np.sin(ang)])
        return (_pitched_xy(pos[None, :], pitches)[:, None, :] + ring[None, :, :]).reshape(-1, 2)
    if gtype == "box":
        local = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * size[:3]
    elif gtype == "cylinder":
        ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
        ring = np.column_stack([size[0] * np.cos(ang), size[0] * np.sin(ang)])
        local = np.vstack([np.column_stack([ring, np.full(24, h)]) for h in (-size[1], size[1])])
    else:
        raise ModelError(f"footprint: geom type {gtype!r} is not supported (use box, cylinder or sphere)")
    return _pitched_xy(local @ rot.T + pos, pitches)


def _collect_defaults(root: ET.Element) -> dict[str, dict[str, str]]:
    out: dict[str, dict[str, str]] = {}

    def walk(node: ET.Element, inherited: dict[str, str]) -> None:
        for child in node.findall("default"):
            attrs = dict(inherited)
            g = child.find("geom")
            if g is not None:
                attrs.update(g.attrib)
            cls = child.get("class")
            if cls:
                out[cls] = attrs
            walk(child, attrs)

    for d in root.findall("default"):
        walk(d, {})
    return out


def robot_path(name: str) -> Path:
    """The MJCF path of a robot given its registered name (:data:`ROBOTS`), or a path to an MJCF file.

    Raises:
        ConfigError: ``name`` is neither a robot name nor the path of an existing .xml file (a name
            that is no text, such as None, too; the message lists the robot names): bad input, a ValueError as
            every such mistake (:class:`ModelError` is a model file's own fault).
    """
    if not isinstance(name, (str, os.PathLike)):
        raise ConfigError(
            f"a robot is named by text: one of {robot_names()} or the path of an MJCF file, got {name!r:.80}"
        )
    if isinstance(name, str) and name in ROBOTS:
        return robot_files(name).mjcf
    path = Path(name)
    if path.suffix == ".xml" and path.is_file():
        return path
    if path.suffix == ".xml" or os.sep in str(name):
        what = "is a folder" if path.is_dir() else "does not exist" if not path.exists() else "is not an .xml file"
        raise ConfigError(
            f"robot model {str(name)!r} {what}: give the path of a robot's MJCF file, or one of {robot_names()}"
        )
    raise ConfigError(
        f"unknown robot {name!r}: choose one of {robot_names()} or give an MJCF path; {ROBOTS.unknown_hint()}"
    )


def check_robot_name(where: str, name: object) -> str:
    """``name`` when it is a registered robot's name (:data:`ROBOTS`).

    Raises:
        ConfigError: Anything else; the message names ``where`` (when given), lists the robot names and says how a
            plugin's robot is registered.
    """
    if isinstance(name, RobotSpec):
        said = f"a robot is named here, not given as a RobotSpec: robot={name.name!r}"
        raise ConfigError(f"{where}: {said}" if where else said)
    if not isinstance(name, str) or name not in ROBOTS:
        said = f"unknown robot {name!r:.80}: choose one of {robot_names()}; {ROBOTS.unknown_hint()}"
        raise ConfigError(f"{where}: {said}" if where else said)
    return name


def check_robot_spec(where: str, robot: object) -> RobotSpec:
    """``robot`` when it is a :class:`RobotSpec` (what :func:`load_robot` returns).

    Raises:
        ConfigError: Anything else, a robot's name too; the message names ``where`` and how to load one.
    """
    if not isinstance(robot, RobotSpec):
        name = robot if isinstance(robot, str) else "turtlebot3"
        raise ConfigError(f"{where}: robot must be a RobotSpec (load_robot({name!r})), got {robot!r:.80}")
    return robot


def load_robot(name: str) -> RobotSpec:
    """Read a robot's kinematic specification from its MJCF file.

    Args:
        name: A registered robot's name ("turtlebot3", "edumip", "edumip-balancing", or one registered by
            :func:`register_robot`), or the path of an MJCF file with the same element names (the spec is named
            by the registered robot whose model it is, else by the file's stem).

    Returns:
        The spec.

    Raises:
        ConfigError: An unknown name (the message lists the robot names).
        ModelError: The file cannot be read or lacks a required element (named in the message).

    The file is read each time, and parsed once per text: loading the same text again gives the same spec
    (a frozen value with a read-only footprint, shared).
    """
    path = robot_path(name)
    try:
        text = path.read_bytes()
    except OSError as exc:
        raise ModelError(f"cannot read robot model {path}: {exc}") from exc
    return _parse_robot(_registered_name(name, path), path, text)


def _registered_name(name: str, path: Path) -> str:
    """The name a spec read from ``path`` goes by: ``name`` when registered, else that of the registered robot
    whose model ``path`` is (a built-in model's path names the built-in robot), else the file's stem."""
    if isinstance(name, str) and name in ROBOTS:
        return name
    resolved = path.resolve()
    return next((n for n in ROBOTS if robot_files(n).mjcf.resolve() == resolved), path.stem)


@functools.lru_cache(maxsize=64)
def _parse_robot(name: str, path: Path, text: bytes) -> RobotSpec:
    """:func:`load_robot` of ``text``, the file at ``path``, for the robot ``name`` (the spec depends on nothing
    else)."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ModelError(f"cannot read robot model {path}: {exc}") from exc
    numerics = {n.get("name"): n.get("data") for n in root.iter("numeric")}
    _check_required(path, root, numerics)

    def numeric(key: str) -> float:
        full = f"nhsim_{key}"
        if full not in numerics:
            raise ModelError(f"{path}: <custom><numeric name={full!r}> is missing")
        try:
            return float(_floats(numerics[full], 1, full)[0])
        except ModelError as exc:
            raise ModelError(f"{path}: <numeric name={full!r}>: {exc}") from None

    bodies = {b.get("name"): b for b in root.iter("body")}
    defaults = _collect_defaults(root)
    wheel_radius, track = _wheels(path, root, bodies, defaults)
    pitch = numeric("footprint_pitch") if "nhsim_footprint_pitch" in numerics else 0.0
    if not 0.0 <= pitch < np.pi / 2:
        raise ModelError(f"{path}: nhsim_footprint_pitch must be in [0, pi/2) [rad], got {pitch!r}")
    hull = _footprint(bodies, defaults, pitch)
    mass = 0.0
    for body in root.iter("body"):
        inertial = body.find("inertial")
        if inertial is not None:  # an explicit inertial replaces the geoms' masses, as in MuJoCo
            mass += float(inertial.get("mass", 0))
            continue
        for g in body.findall("geom"):
            mass += float(_geom_attrs(g, defaults).get("mass", 0) or 0)
    try:
        spec = RobotSpec(
            name=name,
            mjcf=path,
            scene=scene_path(path),
            wheel_radius=wheel_radius,
            track_width=track,
            max_speed=numeric("max_linear_speed"),
            max_yaw_rate=numeric("max_angular_speed"),
            max_accel=numeric("max_linear_accel"),
            max_yaw_accel=numeric("max_angular_accel"),
            max_wheel_speed=numeric("max_wheel_speed"),
            wheelbase=numeric("wheelbase"),
            max_steering=numeric("max_steering_angle"),
            footprint=hull,
            mass=mass,
            footprint_pitch=pitch,
            battery_voltage=numeric("motor_battery_voltage") if "nhsim_motor_battery_voltage" in numerics else 0.0,
        )
    except ConfigError as exc:  # a number no robot has (check_spec)
        raise ModelError(f"{path}: {exc}") from None
    return spec


#: The numerics a model must give (``nhsim_`` before each); the others have defaults.
REQUIRED_NUMERICS = (
    "max_linear_speed",
    "max_angular_speed",
    "max_linear_accel",
    "max_angular_accel",
    "max_wheel_speed",
    "wheelbase",
    "max_steering_angle",
)
#: What the simulator reads from a robot's model by name (a model of one's own needs them too), by kind.
NAMED_ELEMENTS: dict[str, tuple[str, ...]] = {
    "joint": ("root", "wheel_left_joint", "wheel_right_joint"),
    "actuator": ("wheel_left_motor", "wheel_right_motor"),
    "sensor": (
        "base_pos",
        "base_quat",
        "wheel_left_vel",
        "wheel_right_vel",
        "wheel_left_pos",
        "wheel_right_pos",
        "wheel_left_touch",  # each tyre's floor contact: without them a wheel off the floor read as never
        "wheel_right_touch",
    ),
}


def _check_required(path: Path, root: ET.Element, numerics: dict[str | None, str | None]) -> None:
    """Raise :class:`ModelError` naming every body, geom, numeric, joint, actuator and sensor the model lacks, at
    once (one at a time, a model of one's own took a run per missing name). A model that includes other files has
    its joints, actuators and sensors checked when it is compiled (``sim.physics.model.check_named_elements``)."""
    bodies = {e.get("name") for e in root.iter("body")}
    missing = [f"body {b!r}" for b in ("base", "wheel_left", "wheel_right") if b not in bodies]
    missing += [] if any(g.get("name") == "wheel_left_geom" for g in root.iter("geom")) else ["geom 'wheel_left_geom'"]
    missing += [f"<custom><numeric name='nhsim_{k}'>" for k in REQUIRED_NUMERICS if f"nhsim_{k}" not in numerics]
    if root.find(".//include") is None:
        by_kind = {
            "joint": {e.get("name") for e in root.iter() if e.tag in ("joint", "freejoint")},
            "actuator": {e.get("name") for a in root.iter("actuator") for e in a},
            "sensor": {e.get("name") for t in root.iter("sensor") for e in t},
        }
        missing += [f"{kind} {n!r}" for kind, want in NAMED_ELEMENTS.items() for n in want if n not in by_kind[kind]]
    if missing:
        raise ModelError(
            f"{path}: the model lacks {', '.join(missing)}; give them as {ROBOTS_DIR / 'turtlebot3_burger.xml'} does "
            "(docs/how-to/new-robot.md)"
        )


def _wheels(
    path: Path, root: ET.Element, bodies: dict[str | None, ET.Element], defaults: dict[str, dict[str, str]]
) -> tuple[float, float]:
    """Wheel radius [m] and track width [m] of a robot model."""
    left_geom = next((g for g in root.iter("geom") if g.get("name") == "wheel_left_geom"), None)
    if left_geom is None:
        raise ModelError(f"{path}: geom 'wheel_left_geom' is missing")
    wheel_radius = float(_floats(_geom_attrs(left_geom, defaults).get("size"), what="wheel size")[0])
    yl = _floats(bodies["wheel_left"].get("pos"), 3, "wheel_left pos")[1]
    yr = _floats(bodies["wheel_right"].get("pos"), 3, "wheel_right pos")[1]
    return wheel_radius, float(abs(yl - yr))


#: Pitch angles a swept footprint samples per radian on each side of upright, at most 1/60 rad (0.95 deg)
#: apart: the hull of the samples holds a point r from the axle to within r (1 - cos(step / 2)), 4 um at
#: 0.11 m.
PITCH_SAMPLES_PER_RAD = 60


def _footprint(bodies: dict[str | None, ET.Element], defaults: dict[str, dict[str, str]], pitch: float) -> FloatArray:
    """(K, 2) convex hull of the x-y projections of the base's and the wheels' geoms, counter-clockwise [m];
    the base's rotated about the wheel axle (the base frame's y axis) through every pitch in
    [-pitch, pitch] [rad] (the wheels turn about that axis and stay where they are)."""
    angles = np.linspace(-pitch, pitch, 1 + 2 * math.ceil(pitch * PITCH_SAMPLES_PER_RAD))
    points = [_geom_outline(g, defaults, np.zeros(3), angles) for g in bodies["base"].findall("geom")]
    for wheel in ("wheel_left", "wheel_right"):
        off = _floats(bodies[wheel].get("pos"), 3, f"{wheel} pos")
        points.extend(_geom_outline(g, defaults, off) for g in bodies[wheel].findall("geom"))
    hull = convex_hull(np.vstack(points))
    hull.setflags(write=False)  # a spec is a shared value (load_robot's cache)
    return hull


def convex_hull(points: FloatArray) -> FloatArray:
    """(K, 2) vertices of the convex hull of (N, 2) points [m], counter-clockwise without collinear
    vertices, starting at the leftmost vertex (the upper one of two): the order qhull's
    ``ConvexHull(points).vertices`` gives these footprints (Andrew's monotone chain; a footprint
    needs no scipy, whose import costs every command that loads a robot a few tenths of a second).
    """
    pts = np.unique(np.asarray(points, dtype=float), axis=0)  # sorted by x, then y

    def half(order: FloatArray) -> list[FloatArray]:
        chain: list[FloatArray] = []
        for p in order:
            while len(chain) >= 2:
                (ax, ay), (bx, by) = chain[-2], chain[-1]
                if (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax) > 0:
                    break
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(pts), half(pts[::-1])
    hull = np.array(lower[:-1] + upper[:-1])  # counter-clockwise from the lowest leftmost point
    left = np.flatnonzero(hull[:, 0] == hull[:, 0].min())
    start = int(left[np.argmax(hull[left, 1])])
    return np.roll(hull, -start, axis=0)
