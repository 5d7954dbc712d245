"""As-built variation: the robot on the floor is not quite the robot in the drawing.

No two assembled robots are alike: tyres differ in diameter, the wheels' contact lines are not
exactly the nominal track apart, tyre rubber grips differently, batteries and cables change the
base's mass and move its centre of mass. Borenstein and Feng (UMBmark: "Measurement and
correction of systematic odometry errors in mobile robots", IEEE Trans. Robotics and Automation
12(6), 1996) single out two of these as the dominant systematic odometry errors of a differential
drive, constant over long periods: the wheel-diameter ratio ``E_d = D_R / D_L`` and the wheelbase
error ``E_b = b_actual / b_nominal``. The planner and the tracker keep the nominal numbers (read
from the MJCF by :func:`planning.core.robot.load_robot`); only the physics gets the as-built robot.

An :class:`AsBuilt` holds one build; :meth:`AsBuilt.draw` draws it for a robot from a build seed
(an integer, ``--build-seed``, default :data:`DEFAULT_BUILD_SEED`), each quantity from a normal
distribution with the robot's standard deviation (:data:`TOLERANCES`) clipped at
:data:`CLIP_SIGMAS` standard deviations, so no build leaves the tolerance band.
:meth:`AsBuilt.apply_to_model` edits a copy of a compiled model exactly, as
:meth:`sim.physics.perturb.Perturbation.apply_to_model` does.
"""

from __future__ import annotations

import copy
import math
import zlib
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from planning.core.checks import check_number
from planning.errors import ConfigError, ModelError, option
from sim.physics.model import BuiltModel, build_model

if TYPE_CHECKING:
    from planning.core.robot import RobotSpec
    from planning.core.world import World

#: The build seed used when none is given.
DEFAULT_BUILD_SEED = 1
#: Draws are clipped at this many standard deviations.
CLIP_SIGMAS = 3.0


@dataclass(frozen=True)
class BuildTolerance:
    """Standard deviations of one robot's as-built draw.

    Attributes:
        radius: Each wheel's radius scale [-] (independent per wheel, so ``E_d`` has ~sqrt(2) x).
        track: Track width change [m].
        friction: Tyre friction scale [-].
        mass: Base mass scale [-].
        com_x: Centre-of-mass offset forward [m].
        com_y: Centre-of-mass offset to the left [m].
        com_x_forward_max: Largest forward offset a build may have [m]: a robot whose centre of
            mass sits too near the front of its support tips onto its chassis at rest or when it
            brakes, and no such robot leaves assembly; draws beyond it are cut to it.
    """

    radius: float
    track: float
    friction: float
    mass: float
    com_x: float
    com_y: float
    com_x_forward_max: float = math.inf


#: Robot -> tolerances. The magnitudes are estimates: neither robot's maker publishes them, and
#: UMBmark defines E_d and E_b without giving typical values for these robots.
TOLERANCES: dict[str, BuildTolerance] = {
    # TurtleBot3 Burger: 66 mm moulded rubber tyres 18 mm wide, 160 mm track, ~1 kg (ROBOTIS
    # e-Manual specifications; turtlebot3_description URDF).
    "turtlebot3": BuildTolerance(
        radius=0.002,  # estimate: 0.07 mm on r = 33 mm (moulding, wear, load); E_d sigma ~0.28 %
        track=0.001,  # estimate: where the contact line sits across an 18 mm tyre; E_b sigma ~0.6 %
        friction=0.10,  # estimate: rubber compound, wear and dust change grip by ~10 %
        mass=0.02,  # estimate: screws, cables and battery variants of a kit, ~20 g in 1 kg
        com_x=0.003,  # estimate: battery slack in its holder along x
        com_y=0.002,  # estimate: cable runs and battery slack across
        # the URDF's centre of mass is 4 mm behind the axle, the ball caster behind it: a build
        # 5.7 mm further forward tipped onto its chassis at rest; half the margin is kept
        com_x_forward_max=0.0025,
    ),
    # EduMIP: 68 mm wheels, ~12 mm tyres, 0.10 m track (the MJCF's sources [B] and [E]).
    "edumip": BuildTolerance(
        radius=0.003,  # estimate: smaller, harder tyres pressed onto the gearbox shafts; E_d ~0.42 %
        track=0.001,  # estimate: contact line across a 12 mm tyre and wheel seating; E_b ~1 %
        friction=0.10,  # estimate: as the TurtleBot3
        mass=0.03,  # estimate: battery pack and board variants, ~5 g in 0.18 kg
        com_x=0.002,  # estimate: board and battery placement
        com_y=0.002,  # estimate: as com_x
    ),
}

#: The balancing EduMIP is the same kit assembled the same way (its wheels, board and battery).
TOLERANCES["edumip-balancing"] = TOLERANCES["edumip"]

#: Field -> (lowest allowed, highest allowed, nominal, unit).
LIMITS: dict[str, tuple[float, float, float, str]] = {
    "left_radius_scale": (0.8, 1.2, 1.0, "x"),
    "right_radius_scale": (0.8, 1.2, 1.0, "x"),
    "track_change": (-0.02, 0.02, 0.0, "m"),
    "tyre_friction_scale": (0.2, 5.0, 1.0, "x"),
    "base_mass_scale": (0.5, 2.0, 1.0, "x"),
    "com_offset_x": (-0.02, 0.02, 0.0, "m"),
    "com_offset_y": (-0.02, 0.02, 0.0, "m"),
}

SIDES = ("left", "right")


def check_build_seed(value: object) -> int:
    """The build seed as an int.

    Raises:
        ConfigError: Not an integer >= 0 (the message names ``--build-seed``, ``build_seed`` and the fix).
    """
    fix = f"pass a whole number, e.g. {DEFAULT_BUILD_SEED}"
    return check_number(option("build-seed"), value, integer=True, at_least=0, fix=fix)


def _set_radius(model: mujoco.MjModel, geom: int, radius: float) -> None:
    half = float(model.geom_size[geom, 1])
    model.geom_size[geom, 0] = radius
    model.geom_rbound[geom] = math.sqrt(radius * radius + half * half)  # as mj_setConst computes it
    model.geom_aabb[geom, 3:6] = (radius, radius, half)


def _ids(model: mujoco.MjModel, kind: str, names: list[str]) -> list[int]:
    try:
        return [getattr(model, kind)(n).id for n in names]
    except KeyError as exc:
        raise ModelError(f"as-built edit: the model has no {kind} named in {names} ({exc})") from exc


@dataclass(frozen=True)
class AsBuilt:
    """One assembled robot's deviations from its drawing (see the module docstring).

    Attributes:
        left_radius_scale: Left wheel radius over nominal [-].
        right_radius_scale: Right wheel radius over nominal [-].
        track_change: Track width minus nominal [m] (each wheel moves out by half).
        tyre_friction_scale: Sliding friction of both tyres over nominal [-].
        base_mass_scale: Base body mass and inertia over nominal [-].
        com_offset_x: Base centre of mass moved forward [m].
        com_offset_y: Base centre of mass moved to the left [m].
        robot: The robot it was drawn for ("" if not drawn).
        build_seed: The seed it was drawn from (None if not drawn).
    """

    left_radius_scale: float = 1.0
    right_radius_scale: float = 1.0
    track_change: float = 0.0
    tyre_friction_scale: float = 1.0
    base_mass_scale: float = 1.0
    com_offset_x: float = 0.0
    com_offset_y: float = 0.0
    robot: str = ""
    build_seed: int | None = None

    def __post_init__(self) -> None:
        for name, (lo, hi, _, unit) in LIMITS.items():
            value = check_number(f"as-built {name}", getattr(self, name), at_least=lo, at_most=hi, unit=unit)
            object.__setattr__(self, name, value)
        if self.build_seed is not None:
            object.__setattr__(self, "build_seed", check_build_seed(self.build_seed))

    @classmethod
    def nominal(cls) -> AsBuilt:
        """The robot as drawn: every scale 1, every offset 0."""
        return cls()

    @classmethod
    def draw(cls, robot_name: str, build_seed: int) -> AsBuilt:
        """Draw a build of a robot from its tolerances; the same robot and seed, the same build.

        Args:
            robot_name: "turtlebot3" or "edumip" (a key of :data:`TOLERANCES`).
            build_seed: An integer >= 0; the draw uses ``np.random.default_rng([build_seed,
                crc32(robot_name)])``, so two robots with one seed differ.

        Raises:
            ConfigError: Unknown robot or bad seed.
        """
        seed = check_build_seed(build_seed)
        if robot_name not in TOLERANCES:
            raise ConfigError(
                f"no build tolerances for robot {robot_name!r} (robots with them: {', '.join(TOLERANCES)}): run it as "
                f"drawn, {option('build', 'nominal', python='build_seed=None')}, or give its tolerances where it is "
                f"registered, sim.physics.asbuilt.TOLERANCES[{robot_name!r}] = BuildTolerance(radius=..., ...) "
                "(docs/how-to/new-robot.md)"
            )
        tol = TOLERANCES[robot_name]
        rng = np.random.default_rng([seed, zlib.crc32(robot_name.encode())])
        z = np.clip(rng.standard_normal(7), -CLIP_SIGMAS, CLIP_SIGMAS).tolist()
        return cls(
            left_radius_scale=1.0 + tol.radius * z[0],
            right_radius_scale=1.0 + tol.radius * z[1],
            track_change=tol.track * z[2],
            tyre_friction_scale=1.0 + tol.friction * z[3],
            base_mass_scale=1.0 + tol.mass * z[4],
            com_offset_x=min(tol.com_x * z[5], tol.com_x_forward_max),
            com_offset_y=tol.com_y * z[6],
            robot=robot_name,
            build_seed=seed,
        )

    @property
    def is_nominal(self) -> bool:
        """True when nothing differs from the drawing."""
        return all(getattr(self, name) == LIMITS[name][2] for name in LIMITS)

    @property
    def wheel_ratio(self) -> float:
        """UMBmark's ``E_d = D_R / D_L`` [-]."""
        return self.right_radius_scale / self.left_radius_scale

    def wheelbase_ratio(self, track_width: float) -> float:
        """UMBmark's ``E_b = b_actual / b_nominal`` for a nominal track width [m]."""
        return (track_width + self.track_change) / track_width

    def as_dict(self) -> dict[str, float | int | str | None]:
        """Plain-dict view for records."""
        return {**asdict(self), "wheel_ratio": self.wheel_ratio}

    def compile(self, robot: RobotSpec, world: World | None = None) -> BuiltModel:
        """The robot as built in ``world`` (None: an empty floor), compiled: the drawing's model
        (:func:`sim.physics.model.build_model`) with this build applied (:meth:`apply_to_model`), the
        drawing's own when nominal. The model a run of this build steps and its video draws."""
        built = build_model(robot, world)
        return built if self.is_nominal else replace(built, model=self.apply_to_model(built.model))

    def apply_to_model(self, model: mujoco.MjModel) -> mujoco.MjModel:
        """An as-built copy of a compiled model; the input is not touched.

        Each wheel's collision tyre (``wheel_<side>_geom``) and visual tyre (``wheel_<side>_tyre``,
        if present) get their own radius, with bounding radius and box to match; the base rises
        by the mean change in radius and each wheel body moves up or down by its own difference
        from that mean, so both tyres touch the floor with the base level, and the base's own
        geoms move down by the mean in the body frame, keeping their height above the floor (as
        :func:`sim.physics.model.scale_wheels` does). The wheel bodies move out (or in) by half the
        track change each. The collision tyres' sliding friction is scaled; the base body's mass
        and inertia are scaled and its centre of mass (``body_ipos``) moved in x and y. Derived
        constants are recomputed with ``mj_setConst``. The nominal build returns an exact copy.

        Raises:
            ModelError: The model lacks the base or a wheel body or collision tyre.
        """
        m = copy.deepcopy(model)
        if self.is_nominal:
            return m
        (base,) = _ids(m, "body", ["base"])
        wheels = _ids(m, "body", [f"wheel_{s}" for s in SIDES])
        tyres = _ids(m, "geom", [f"wheel_{s}_geom" for s in SIDES])
        rises = []
        for side, wheel, tyre, scale in zip(SIDES, wheels, tyres, self._radius_scales(), strict=True):
            radius = float(m.geom_size[tyre, 0])
            rises.append(radius * (scale - 1.0))
            for geom in (tyre, *self._visual_tyre(m, side)):
                _set_radius(m, geom, float(m.geom_size[geom, 0]) * scale)
            m.body_pos[wheel, 1] += math.copysign(self.track_change / 2.0, float(m.body_pos[wheel, 1]))
        mean_rise = (rises[0] + rises[1]) / 2.0
        for wheel, rise in zip(wheels, rises, strict=True):
            m.body_pos[wheel, 2] += rise - mean_rise
        m.body_pos[base, 2] += mean_rise
        m.geom_pos[m.geom_bodyid == base, 2] -= mean_rise
        m.geom_friction[tyres, 0] *= self.tyre_friction_scale
        m.body_mass[base] *= self.base_mass_scale
        m.body_inertia[base] *= self.base_mass_scale
        m.body_ipos[base, :2] += (self.com_offset_x, self.com_offset_y)
        mujoco.mj_setConst(m, mujoco.MjData(m))
        return m

    def _radius_scales(self) -> tuple[float, float]:
        return self.left_radius_scale, self.right_radius_scale

    @staticmethod
    def _visual_tyre(model: mujoco.MjModel, side: str) -> list[int]:
        try:
            return [model.geom(f"wheel_{side}_tyre").id]
        except KeyError:
            return []
