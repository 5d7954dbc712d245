"""Perturbations: the physics is not the model the tracker was tuned on.

A :class:`Perturbation` changes one run:

- ``friction``: scale of the sliding friction of every geom (the tyres govern the rolling
  contact, having priority over the floor), e.g. 0.6 for a slippery floor.
- ``mass``: scale of the base body's mass and inertia (payload), e.g. 1.3.
- ``radius``: physics wheel radius over the nominal one. The tracker and its drive mapping
  (:class:`control.diffdrive.DiffDrive`) keep believing the nominal radius, so a wheel speed meant
  for speed v gives ``radius * v``.
- ``noise`` / ``heading_noise``: standard deviation of zero-mean Gaussian noise added to the pose
  the tracker sees [m] / [rad]; the log keeps the true pose. Drawn from
  ``np.random.default_rng(seed)`` before the run, so the same seed gives the same run, bit for bit.
- ``latency``: delay [s] between the pose measurement and the wheels receiving the command it
  produced, rounded to whole physics steps (2 ms); commands not yet arrived leave the previous
  one in force (zero wheel speed at the start).
- ``push=J@t`` (balancing robots): a horizontal impulse of J [N s] on the top of the body at t [s]
  from the start of the run, forward along the heading (negative: backward), e.g. ``push=0.05@10``;
  |J| <= 1 N s. Not drawn by ranges.

Command-line syntax (``nhsim simulate --perturb``): comma-separated ``key=value`` with keys
friction, mass, radius, noise, heading_noise, latency, push, e.g.
``friction=0.6,mass=1.3,radius=1.02,noise=0.005,latency=0.02``. Ranges (``nhsim tune
--perturb-range``) use ``key=lo:hi``, e.g. ``friction=0.5:1.5,latency=0:0.04``.
"""

from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass, fields
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from planning.core.checks import check_number
from planning.errors import ConfigError, option
from sim.physics.keyvalue import parse_number, parse_pairs
from sim.physics.model import scale_wheels

#: Field -> (lowest allowed, highest allowed, nominal, unit) for validation and help.
LIMITS: dict[str, tuple[float, float, float, str]] = {
    "friction": (0.05, 10.0, 1.0, "x"),
    "mass": (0.1, 10.0, 1.0, "x"),
    "radius": (0.5, 1.5, 1.0, "x"),
    "noise": (0.0, 0.5, 0.0, "m"),
    "heading_noise": (0.0, 1.0, 0.0, "rad"),
    "latency": (0.0, 1.0, 0.0, "s"),
}
#: A valid ``--perturb`` text, quoted when a part is malformed.
EXAMPLE = "friction=0.6,mass=1.3,radius=1.02,noise=0.005,latency=0.02"
#: A valid ``--perturb-range`` text, quoted when a part is malformed.
RANGE_EXAMPLE = "friction=0.5:1.5,latency=0:0.04"
#: Largest |push| impulse [N s] (five times what topples the balancing EduMIP).
MAX_PUSH = 1.0


def _option(text: str) -> str:
    """``--perturb TEXT`` as messages lead with it (:func:`planning.errors.option`)."""
    return option("perturb", text, python="perturbation=Perturbation.parse({})")


def parse_push(value: str, text: str) -> tuple[float, float]:
    """``J@t`` -> (impulse [N s], time [s]).

    Raises:
        ConfigError: Malformed, non-numeric, |J| > :data:`MAX_PUSH` or t < 0.
    """
    what = _option(text)
    impulse_s, sep, time_s = value.partition("@")
    if not sep:
        raise ConfigError(f"{what}: push must be IMPULSE@TIME in N s and s (e.g. push=0.05@10), got {value!r}")
    impulse = parse_number(impulse_s, "push impulse", what)
    impulse = check_number("perturbation push impulse", impulse, at_least=-MAX_PUSH, at_most=MAX_PUSH, unit="N s")
    time = parse_number(time_s, "push time", what)
    return impulse, check_number("perturbation push time", time, at_least=0.0, at_most=1e6, unit="s")


def check_push(push: object) -> tuple[float, float] | None:
    """``push`` (None, or a pair (impulse [N s], time [s]): |impulse| <= :data:`MAX_PUSH`, time >= 0) as a
    tuple of floats.

    Raises:
        ConfigError: Not None nor a pair (text such as ``"0.05@10"`` is the command line's form), or a part
            that is not a finite number in its range (named).
    """
    if push is None:
        return None
    if (isinstance(push, tuple | list) or (isinstance(push, np.ndarray) and push.ndim == 1)) and len(push) == 2:
        impulse = check_number("perturbation push impulse", push[0], at_least=-MAX_PUSH, at_most=MAX_PUSH, unit="N s")
        return impulse, check_number("perturbation push time", push[1], at_least=0.0, at_most=1e6, unit="s")
    raise ConfigError(
        f"perturbation push must be a pair (impulse [N s], time [s]) or None, got {push!r:.80}; e.g. "
        "Perturbation(push=(0.05, 10.0)) (Perturbation.parse('push=0.05@10') reads the command line's form)"
    )


def _check(name: str, value: object) -> float:
    lo, hi, _, unit = LIMITS[name]
    return check_number(f"perturbation {name}", value, at_least=lo, at_most=hi, unit=unit)


@dataclass(frozen=True)
class Perturbation:
    """A change of the physics and of the loop for one run (see the module docstring).

    Attributes:
        friction: Sliding friction scale [-].
        mass: Base mass and inertia scale [-].
        radius: Physics wheel radius over nominal [-].
        noise: Pose-sensor position noise standard deviation [m].
        heading_noise: Pose-sensor heading noise standard deviation [rad].
        latency: Control latency [s].
        seed: Seed of the sensor noise.
        push: (impulse [N s], time [s]) of a push on a balancing robot's body top, or None.
    """

    friction: float = 1.0
    mass: float = 1.0
    radius: float = 1.0
    noise: float = 0.0
    heading_noise: float = 0.0
    latency: float = 0.0
    seed: int = 0
    push: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for name in LIMITS:
            object.__setattr__(self, name, _check(name, getattr(self, name)))
        object.__setattr__(self, "seed", check_number("perturbation seed", self.seed, integer=True, at_least=0))
        object.__setattr__(self, "push", check_push(self.push))

    @classmethod
    def parse(cls, text: str, *, seed: int = 0) -> Perturbation:
        """Parse ``key=value,...`` (see the module docstring); keys left out stay nominal.

        Raises:
            ConfigError: Unknown key, repeated key, non-numeric or out-of-range value.
        """
        pairs = parse_pairs(text, _option(text), [*LIMITS, "push"], EXAMPLE)
        push = parse_push(pairs.pop("push"), text) if "push" in pairs else None
        return cls(**{k: parse_number(v, k, _option(text)) for k, v in pairs.items()}, seed=seed, push=push)

    @property
    def is_nominal(self) -> bool:
        """True when nothing is changed (the run is the unperturbed one)."""
        return self.push is None and all(getattr(self, n) == LIMITS[n][2] for n in LIMITS)

    @property
    def changes_model(self) -> bool:
        """True when the compiled model must be modified (friction, mass or radius)."""
        return (self.friction, self.mass, self.radius) != (1.0, 1.0, 1.0)

    def as_dict(self) -> dict[str, Any]:
        """Plain-dict view for records (``push`` only when there is one)."""
        out = asdict(self)
        if self.push is None:
            del out["push"]
        else:
            out["push"] = list(self.push)
        return out

    def label(self) -> str:
        """The ``key=value`` text of the non-nominal fields ("nominal" if none)."""
        parts = [f"{n}={getattr(self, n):g}" for n in LIMITS if getattr(self, n) != LIMITS[n][2]]
        if self.push is not None:
            parts.append(f"push={self.push[0]:g}@{self.push[1]:g}")
        return ",".join(parts) or "nominal"

    def check_within(self, horizon: float) -> None:
        """Check that every timed key acts inside a run of ``horizon`` seconds [s]: a push after the
        run's end, or a latency as long as the run (no command would reach the wheels), would be
        claimed and never happen.

        Raises:
            ConfigError: Naming the key, its time and the run's length.
        """
        late = []
        if self.push is not None and self.push[1] >= horizon:
            late.append(f"push={self.push[0]:g}@{self.push[1]:g} comes at {self.push[1]:g} s")
        if self.latency >= horizon:
            late.append(f"latency={self.latency:g} delays every command by {self.latency:g} s")
        if late:
            raise ConfigError(
                f"{option('perturb', python='perturbation')}: {'; '.join(late)}, but the run lasts {horizon:.4g} s: "
                f"it would never act; give a time below {horizon:.4g} s (or a longer run: a slower reference or a "
                "longer trajectory)"
            )

    def apply_to_model(self, model: mujoco.MjModel) -> mujoco.MjModel:
        """A perturbed copy of a compiled model (friction, base mass, wheel radius); the input is
        not touched."""
        m = copy.deepcopy(model)
        if self.friction != 1.0:
            m.geom_friction[:, 0] *= self.friction
        if self.mass != 1.0:
            base = m.body("base").id
            m.body_mass[base] *= self.mass
            m.body_inertia[base] *= self.mass
        if self.radius != 1.0:
            scale_wheels(m, self.radius)
        d = mujoco.MjData(m)
        mujoco.mj_setConst(m, d)
        return m

    def latency_steps(self, timestep: float) -> int:
        """Latency in whole physics steps of ``timestep`` [s], rounded to the nearest, a half up (Python's ``round``
        took 0.005 s at 2 ms steps to 4 ms, as 0.003 s; the run's ``latency_applied_s`` says what was applied)."""
        return math.floor(self.latency / timestep + 0.5)

    def sensor_noise(self, n: int) -> NDArray[np.float64] | None:
        """(n, 3) noise [dx, dy, dtheta] for ``n`` control periods, or None without noise."""
        if self.noise == 0.0 and self.heading_noise == 0.0:
            return None
        rng = np.random.default_rng(self.seed)
        z = rng.standard_normal((n, 3))
        return z * np.array([self.noise, self.noise, self.heading_noise])


@dataclass(frozen=True)
class PerturbationRange:
    """Ranges ``(lo, hi)`` to draw perturbations from, uniformly and independently per field.

    The defaults describe a plausible lab robot: floors from slippery to grippy, a payload of up
    to half the base mass, a 3 % tyre wear or inflation error, a few mm of pose noise and up to
    two control periods (at 50 Hz) of latency.
    """

    friction: tuple[float, float] = (0.5, 1.5)
    mass: tuple[float, float] = (0.8, 1.5)
    radius: tuple[float, float] = (0.97, 1.03)
    noise: tuple[float, float] = (0.0, 0.005)
    heading_noise: tuple[float, float] = (0.0, 0.02)
    latency: tuple[float, float] = (0.0, 0.04)

    def __post_init__(self) -> None:
        for name in LIMITS:
            pair = getattr(self, name)
            if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
                raise ConfigError(f"perturbation range {name} must be (lo, hi), got {pair!r}")
            lo, hi = _check(name, pair[0]), _check(name, pair[1])
            if lo > hi:
                raise ConfigError(f"perturbation range {name}: lo {lo:g} > hi {hi:g}; write {name}={hi:g}:{lo:g}")
            object.__setattr__(self, name, (lo, hi))

    @classmethod
    def parse(cls, text: str, *, others: str = "default") -> PerturbationRange:
        """Parse ``key=lo:hi,...`` (or ``key=value`` for a fixed value).

        Args:
            text: The ranges.
            others: What the keys left out get: ``"default"`` their default range (a robust
                study), ``"nominal"`` their nominal value (a Monte Carlo study of just those keys).

        Raises:
            ConfigError: Unknown key, malformed or out-of-range bounds.
        """
        what = option("perturb-range", text, python="PerturbationRange.parse({})")
        out: dict[str, tuple[float, float]] = {}
        if others == "nominal":
            out = {name: (LIMITS[name][2], LIMITS[name][2]) for name in LIMITS}
        for key, value in parse_pairs(text, what, LIMITS, RANGE_EXAMPLE, form="key=lo:hi (or key=value)").items():
            lo_s, sep, hi_s = value.partition(":")
            lo = parse_number(lo_s, key, what)
            out[key] = (lo, parse_number(hi_s, key, what) if sep else lo)
        return cls(**out)

    def sample(self, n: int, seed: int) -> list[Perturbation]:
        """``n`` perturbations drawn from ``np.random.default_rng(seed)``; each gets its own noise
        seed from the same generator. Same seed, same list."""
        check_number("number of perturbations", n, integer=True, at_least=0)
        rng = np.random.default_rng(seed)
        out = []
        for _ in range(n):
            values: dict[str, Any] = {f.name: float(rng.uniform(*getattr(self, f.name))) for f in fields(self)}
            out.append(Perturbation(**values, seed=int(rng.integers(2**31))))
        return out
