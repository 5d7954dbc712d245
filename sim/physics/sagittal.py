"""The sagittal plant of a balancing robot: its linearisation upright and its period map.

Linearisation. :func:`linearise_upright` settles the robot upright on the floor with no voltage
(upright is an equilibrium: the body's centre of mass is above the axle) and asks MuJoCo for the
one-step transition Jacobians ``A = d x_{k+1} / d x_k`` and ``B = d x_{k+1} / d u_k`` by centred
finite differences (``mujoco.mjd_transitionFD``; x = (tangent-space positions, velocities), 2 nv
states). The free joint's tangent coordinates at a level, heading-0 base are the world x, y, z and
the small rotations about x, y, z; the wheel joints' are their angles relative to the body.

Reduction. The balance loop sees the sagittal plane only: pitch theta (rotation about y, positive
tipping the top forward), the wheel position phi (the mean wheel angle in the world, mean joint
angle + theta) and their rates. A sagittal state s lifts to the full state by ``L`` (base x = r phi
as the tyres roll without slipping, pitch = theta, each joint angle = phi - theta; the same for the
rates) and comes back by ``P`` (theta = the pitch coordinate, phi = mean joint angle + pitch). The
period-T map of the full model with the voltage held (n = T / timestep steps) is ``A^n`` and
``sum_i A^i B``; its sagittal part is ``P A^n L`` and ``P sum_i A^i B (1, 1)`` (one common voltage).
The integral of the wheel-position error adds a fifth state, ``z_{k+1} = z_k + T phi_k``.

The sagittal model's closed-form numbers (:class:`SagittalParams`) give the steady lean and voltage
a forward acceleration needs (:func:`balance_accel_limit`).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from planning.core.geometry import Pose2D
from planning.errors import ConfigError
from sim.physics.model import set_pose
from sim.physics.motors import MotorModel, whole_steps

FloatArray = NDArray[np.float64]

#: Free-joint tangent indices: base x, pitch; wheel joints follow the free joint's 6.
DOF_X, DOF_PITCH, DOF_WHEELS = 0, 4, (6, 7)


@dataclass(frozen=True)
class SagittalParams:
    """The sagittal model's numbers of a balancing robot, read from its compiled model.

    Attributes:
        body_mass: M, the body's mass [kg].
        com_height: l, its centre of mass above the axle [m].
        wheel_mass: m, both wheels' mass [kg].
        axle_inertia: J, both wheels' inertia about the axle [kg m^2].
        rotor_inertia: J_a, both motors' rotor inertia on the joints (armature) [kg m^2].
        wheel_radius: r [m].
        gravity: g [m/s^2].
        torque_per_volt: The motor's torque per volt at the wheel, g_m = tau_stall / V_batt [N m/V].
    """

    body_mass: float
    com_height: float
    wheel_mass: float
    axle_inertia: float
    rotor_inertia: float
    wheel_radius: float
    gravity: float
    torque_per_volt: float

    @classmethod
    def from_model(cls, model: mujoco.MjModel, gravity: float | None = None) -> SagittalParams:
        """Read them from a compiled model (``base`` and ``wheel_left`` bodies, ``wheel_left_geom`` tyre,
        ``wheel_left_joint``, the motor constants); ``gravity`` [m/s^2] overrides the model's."""
        base, wheel = model.body("base").id, model.body("wheel_left").id
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, model.body_iquat[wheel])
        rot3 = rot.reshape(3, 3)
        motor = MotorModel.from_model(model)
        return cls(
            body_mass=float(model.body_mass[base]),
            com_height=float(model.body_ipos[base][2]),
            wheel_mass=2.0 * float(model.body_mass[wheel]),
            axle_inertia=2.0 * float((rot3 @ np.diag(model.body_inertia[wheel]) @ rot3.T)[1, 1]),
            rotor_inertia=2.0 * float(model.dof_armature[model.joint("wheel_left_joint").dofadr[0]]),
            wheel_radius=float(model.geom_size[model.geom("wheel_left_geom").id][0]),
            gravity=-float(model.opt.gravity[2]) if gravity is None else gravity,
            torque_per_volt=motor.stall_torque / motor.battery_voltage,
        )

    @property
    def lean_per_accel(self) -> float:
        """The steady lean a steady forward acceleration needs [rad per m/s^2] (see :func:`balance_accel_limit`)::

        theta / a = (M l + r (m + M) + J / r) / (M g l)
        """
        m_l, r = self.body_mass * self.com_height, self.wheel_radius
        return (m_l + r * (self.wheel_mass + self.body_mass) + self.axle_inertia / r) / (m_l * self.gravity)

    @property
    def voltage_per_accel(self) -> float:
        """The common motor voltage a steady forward acceleration needs beyond the back-EMF of the
        wheel speed [V per m/s^2] (see :func:`balance_accel_limit`)::

            u / a = r (m + M + (J + J_a) / r^2) / (2 g_m)
        """
        r = self.wheel_radius
        inertia = self.wheel_mass + self.body_mass + (self.axle_inertia + self.rotor_inertia) / r**2
        return r * inertia / (2.0 * self.torque_per_volt)


def balance_accel_limit(model: mujoco.MjModel, lean: float, gravity: float | None = None) -> float:
    """The forward acceleration [m/s^2] a balancing robot holds with its body leaning by ``lean`` [rad].

    Derivation. Take the sagittal model of the robot (axle position x, pitch theta): body mass M,
    centre of mass l above the axle, pitch inertia I; both wheels' mass m and axle inertia J; the
    motors' rotor inertia J_a on the joints; motor torque tau on the wheels (and -tau on the body).
    Linearised about upright, Lagrange's equations read::

        (m + M + (J + J_a) / r^2) x'' + (M l - J_a / r) theta'' = tau / r
        (M l - J_a / r) x'' + (I + M l^2 + J_a) theta''      = M g l theta - tau

    A steady acceleration x'' = a at a steady lean (theta'' = 0) needs tau = r a (m + M + (J + J_a)
    / r^2) from the first line and then, from the second, a lean of::

        theta = a (M l + r (m + M) + J / r) / (M g l)

    (the rotor terms cancel): a forward acceleration needs a forward lean first, the body's weight
    supplying the torque that tips it along. So ``a_max = lean M g l / (M l + r (m + M) + J / r)``.
    For the EduMIP's numbers [B] theta / a = 0.207 rad per m/s^2: 1 m/s^2 leans it 11.9 deg. The
    torque is the motors' ``g_m (u - kff omega)`` (:mod:`sim.physics.motors`), both motors at the
    common voltage u: beyond the back-EMF ``kff omega`` of the wheel speed omega, the acceleration
    needs ``u = tau / (2 g_m)`` (:attr:`SagittalParams.voltage_per_accel`).

    Args:
        model: The compiled model (base body, ``wheel_left`` body and ``wheel_left_geom`` tyre).
        lean: The lean allowed for acceleration [rad].
        gravity: g [m/s^2]; the model's if None.
    """
    return lean / SagittalParams.from_model(model, gravity).lean_per_accel


def linearise_upright(model: mujoco.MjModel, eps: float = 1e-6) -> tuple[FloatArray, FloatArray]:
    """One-step Jacobians of the model at rest upright on the floor, no voltage.

    Args:
        model: The compiled robot model (its scene).
        eps: Finite-difference step.

    Returns:
        A (2 nv, 2 nv) and B (2 nv, nu) of ``mujoco.mjd_transitionFD`` (centred differences).
    """
    d = mujoco.MjData(model)
    set_pose(model, d, Pose2D(0.0, 0.0, 0.0), settle=0.5)
    n = 2 * model.nv + model.na
    a, b = np.zeros((n, n)), np.zeros((n, model.nu))
    mujoco.mjd_transitionFD(model, d, eps, True, a, b, None, None)
    return a, b


def sagittal_maps(model: mujoco.MjModel, wheel_radius: float) -> tuple[FloatArray, FloatArray]:
    """``L`` (2 nv, 4) lifting (theta, phi, theta_dot, phi_dot) to the full tangent state and ``P`` (4, 2 nv)
    bringing it back (see the module docstring)."""
    nv = model.nv
    lift, proj = np.zeros((2 * nv, 4)), np.zeros((4, 2 * nv))
    for off, (i_th, i_phi) in ((0, (0, 1)), (nv, (2, 3))):
        lift[off + DOF_X, i_phi] = wheel_radius
        lift[off + DOF_PITCH, i_th] = 1.0
        proj[i_th, off + DOF_PITCH] = 1.0
        proj[i_phi, off + DOF_PITCH] = 1.0
        for w in DOF_WHEELS:
            lift[off + w, i_phi], lift[off + w, i_th] = 1.0, -1.0
            proj[i_phi, off + w] = 0.5
    return lift, proj


def sagittal_model(
    model: mujoco.MjModel, wheel_radius: float, period: float, jacobians: tuple[FloatArray, FloatArray] | None = None
) -> tuple[FloatArray, FloatArray]:
    """The balance loop's plant over one period, with the wheel-position integral.

    Args:
        model: The compiled robot model.
        wheel_radius: r [m].
        period: Loop period T [s], a whole number of physics steps.
        jacobians: (A, B) of :func:`linearise_upright`, computed if None.

    Returns:
        A (5, 5) and B (5, 1) over the state :data:`control.balance.STATE_NAMES`, input the common
        voltage [V].
    """
    steps = whole_steps(period, float(model.opt.timestep))
    if not steps:
        raise ConfigError(
            f"balance period {period:g} s is not a whole number of {model.opt.timestep:g} s physics steps"
        )
    a, b = jacobians if jacobians is not None else linearise_upright(model)
    an, bn = np.eye(a.shape[0]), np.zeros_like(b)
    for _ in range(steps):
        bn = a @ bn + b
        an = a @ an
    lift, proj = sagittal_maps(model, wheel_radius)
    a4, b4 = proj @ an @ lift, proj @ bn @ np.ones(b.shape[1])
    order = [0, 2, 1, 3]  # (theta, phi, theta_dot, phi_dot) -> (theta, theta_dot, phi, phi_dot)
    a4, b4 = a4[np.ix_(order, order)], b4[order]
    a5 = np.zeros((5, 5))
    a5[:4, :4] = a4
    a5[4, 2], a5[4, 4] = period, 1.0
    b5 = np.zeros((5, 1))
    b5[:4, 0] = b4
    return a5, b5
