"""The balancing EduMIP in the simulator: its balance loop under the tracker, pushes and falls."""

from __future__ import annotations

import math

import numpy as np
import pytest

from control.base import make_tracker
from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.errors import ConfigError
from planning.trajectory.references import make_reference
from sim.physics.metrics import compute_metrics
from sim.physics.model import body_pitch, rolling_radius
from sim.physics.perturb import Perturbation
from sim.physics.simulator import Simulator
from sim.pipeline.runs import RunKind
from sim.pipeline.simulate import simulate_plan, simulate_reference
from sim.viz.plots.run import pitch_figure

NAME = "edumip-balancing"


def test_tracks_a_circle_balancing() -> None:
    job = simulate_reference("open", robot=NAME, reference="circle", runs=[RunKind.CLOSED_LOOP])
    m = job.metrics["closed_loop"]
    assert m.fell is False and m.fall_time_s is None and m.status == "ok"
    assert m.final_position_error_m <= 0.02 and m.rms_position_error_m <= 0.03
    assert m.max_pitch_rad is not None and 0.0 < m.max_pitch_rad <= math.radians(20.0)
    assert m.warnings == 0 and m.collisions == 0
    record = m.as_dict()
    assert {"max_pitch_rad", "fell", "fall_time_s"} <= record.keys()
    log = job.logs["closed_loop"]
    bal = log.balance
    assert bal is not None and len(bal.t) > 0.9 * 200 * (log.t[-1] - log.t[0])
    # the complementary filter follows the true pitch: RMS error under 1 deg (gyro and accelerometer noise
    # and biases of the profile, the accelerometer's share of the driving accelerations)
    truth = np.interp(bal.t, log.t, body_pitch(log.qpos[:, 3:7]))
    assert float(np.sqrt(np.mean((bal.pitch_estimate - truth) ** 2))) < math.radians(1.0)
    fig = pitch_figure(job.logs)
    assert fig is not None and len(fig.axes[0].lines) == 3


def test_skid_records_have_no_balance_fields() -> None:
    job = simulate_reference("open", robot="edumip", reference="circle", runs=[RunKind.CLOSED_LOOP])
    assert "max_pitch_rad" not in job.metrics["closed_loop"].as_dict()
    assert pitch_figure(job.logs) is None


def test_a_push_too_large_is_a_reported_fall_that_ends_the_run() -> None:
    robot = load_robot(NAME)
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0))
    log = Simulator(robot).run(traj, make_tracker("fbl", robot), perturbation=Perturbation(push=(0.5, 2.0)))
    assert log.status.startswith("fell at t=2.0")
    assert log.balance is not None and log.balance.fell_at is not None and 2.0 <= log.balance.fell_at < 2.2
    assert log.t[-1] - log.t[0] < 2.3 < traj.duration  # the run ended at the fall
    m = compute_metrics(log, traj, max_speed=robot.max_speed, max_yaw_rate=robot.max_yaw_rate,
                        max_wheel_speed=robot.max_wheel_speed)  # fmt: skip
    assert m.fell is True and m.fall_time_s == log.balance.fell_at


def test_push_parses_and_is_refused_on_a_skid_robot() -> None:
    p = Perturbation.parse("push=0.05@10,latency=0.02")
    assert p.push == (0.05, 10.0) and p.latency == 0.02 and not p.is_nominal
    assert p.label() == "latency=0.02,push=0.05@10" and p.as_dict()["push"] == [0.05, 10.0]
    for bad, match in (("push=0.05", "IMPULSE@TIME"), ("push=2@1", r"push impulse .* in \[-1, 1\] \(N s\), got 2.0"),
                       ("push=0.1@-1", "push time")):  # fmt: skip
        with pytest.raises(ConfigError, match=match):
            Perturbation.parse(bad)
    robot = load_robot("edumip")
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0))
    with pytest.raises(ConfigError, match="does not balance"):
        Simulator(robot).run(traj, make_tracker("fbl", robot), perturbation=Perturbation(push=(0.05, 1.0)))


@pytest.mark.slow
def test_default_scenario_plan_within_the_targets() -> None:
    """The default scenario's C-RRT* plan, tracked balancing with sensor noise and an as-built draw:
    ends within 2 cm and 0.05 rad, RMS <= 3 cm, |pitch| <= 20 deg, no fall, contact or warning."""
    job = simulate_plan("edumip_map", planner="c-rrt-star", robot=NAME, runs=[RunKind.CLOSED_LOOP])
    m = job.metrics["closed_loop"]
    assert m.fell is False and m.status == "ok" and m.collisions == 0 and m.warnings == 0
    assert m.final_position_error_m <= 0.02 and m.final_heading_error_rad <= 0.05
    assert m.rms_position_error_m <= 0.03
    assert m.max_pitch_rad is not None and m.max_pitch_rad <= math.radians(20.0)


def test_sweep_judges_a_balancing_run_by_its_own_targets() -> None:
    """RMS 3 cm and |pitch| <= 20 deg for a balancing run (2 cm for the others); a fall fails."""
    from dataclasses import replace

    from sim.physics.metrics import TrackingMetrics
    from sim.pipeline.sweep import met_targets, sweep_misses

    base = TrackingMetrics(0.01, 0.01, 0.025, 0.05, 0.01, 0, 0, 0.0, 10.0)
    assert not met_targets(base)  # 2.5 cm RMS misses the 2 cm of a skid robot
    up = replace(base, max_pitch_rad=0.3, fell=False)
    assert met_targets(up)
    assert not met_targets(replace(up, max_pitch_rad=0.36))  # beyond 20 deg
    assert not met_targets(replace(up, rms_position_error_m=0.031))
    assert not met_targets(replace(up, fell=True, fall_time_s=3.0))
    # the sweep's table names what was missed (it said only "missed a target (see the errors)")
    assert sweep_misses(replace(up, rms_position_error_m=0.0317)) == ["rms_position_error_m 0.0317 > 0.03"]
    assert sweep_misses(replace(base, collisions=2)) == ["rms_position_error_m 0.025 > 0.02", "2 contact(s)"]
    assert sweep_misses(up) == []


def test_the_firmware_reads_with_the_runs_sensor_profile_and_seed() -> None:
    """A run's sensor overrides (``--sensors``) and seed reach the balance firmware's IMU and
    encoders, not only the base's sensors."""
    from dataclasses import replace

    import mujoco

    from sim.robot.sensing import SensingSetup

    sim = Simulator(load_robot(NAME))
    setup = SensingSetup.for_robot(NAME, seed=3, text="gyro_noise_density=0,accel_bias_std=0.1")
    firmware = sim.balance_for_run(sim.model, mujoco.MjData(sim.model), None, setup, 0.02)
    assert firmware is not None
    noise = firmware.sensors.noise
    assert noise.profile == replace(setup.profile, fix_rate=0.0) and (noise.seed, noise.part) == (3, 1)
    assert np.all(noise.gyro_white == 0.0) and not np.all(noise.accel_bias == 0.0)


def test_the_estimator_counts_the_body_pitch_into_the_wheels_turns() -> None:
    """A body that leans forward by d_theta over wheels that stay put turns the encoders back by d_theta
    (they measure the wheel against the body): given the pitch, the loop sees no travel; without it,
    r d_theta backwards."""
    from control.estimation import EstimatorConfig
    from sim.robot.sensing import EstimatorLoop

    robot, q = load_robot(NAME), 2 * math.pi / 4096
    loops = [EstimatorLoop(robot, EstimatorConfig(), n_periods=4, dt=0.02, rad_per_count=q) for _ in range(2)]
    counts = -round(0.08 / q)  # the lean in counts
    with_pitch, without = loops
    with_pitch.start(0.0, (0.0, 0.0, 0.0), (0, 0), pitch=0.0)
    without.start(0.0, (0.0, 0.0, 0.0), (0, 0))
    x_with = with_pitch.step(1, counts, counts, 0.0, pitch=-counts * q)[0]
    x_without = without.step(1, counts, counts, 0.0)[0]
    assert abs(x_with) < 1e-12
    assert x_without == pytest.approx(rolling_radius(robot) * counts * q, rel=1e-9)


def test_the_balancing_robot_estimate_is_consistent_through_a_turn_in_place() -> None:
    """The lean it takes to stand and the pitching of a turn in place would read as travel without the
    pitch in the odometry (NEES inside its bounds at 3 % of the fixes, 2.8 mm of position error)."""
    job = simulate_plan("turn_in_place", planner="c-rrt-star", seed=0, robot=NAME)
    est = job.metrics[RunKind.CLOSED_LOOP].estimation
    assert est is not None and est.fixes_used > 50
    assert est.nees_in_bound_fraction >= 0.85
    assert est.position_rmse_m < 1e-3


def test_the_chassis_brushing_an_obstacle_is_a_collision_not_a_fall() -> None:
    """On random8002 the dead-reckoning run drifts into obstacle_5 at 9.67 s. The firmware took the chassis
    touching it (upright, 0.57 rad of pitch) for a fall at 9.885 s and the status named only the fall. The fall
    is a tilt past the tip angle or the chassis on the floor; the collision is said first, as what caused it.
    The touch began at 9.665 s, between two log samples (9.670 s was the first sample after it: the time said
    before contacts were looked for after every step near an obstacle)."""
    job = simulate_plan("random8002", robot=NAME, runs=[RunKind.CLOSED_LOOP_ODOMETRY])
    m = job.runs[RunKind.CLOSED_LOOP_ODOMETRY].metrics
    assert m.collisions > 0 and m.status.startswith("collided with 'obstacle_5' at t=9.665 s, then fell at t=")
    fell = float(m.status.split("then fell at t=")[1].split(" s")[0])
    assert fell > 10.0  # after the robot toppled over the obstacle, not when its chassis first brushed it


@pytest.mark.parametrize("robot", ["edumip", "turtlebot3"])
def test_a_robot_that_does_not_balance_ends_its_run_when_it_lies_on_the_floor(
    robot: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The balancing robot's firmware ends a run at a fall; a skid robot tipped over ran on to the end of its
    trajectory, on its back (the dm_control suite ended its episode there). Started tipped on its side, its
    chassis lands on the floor and the run ends there, said as a fall."""
    import mujoco

    import sim.physics.simulator as simulator_module
    from sim.physics.model import set_pose
    from sim.pipeline.simulate import simulate_reference

    def tipped(model: mujoco.MjModel, data: mujoco.MjData, pose: object, **kw: object) -> None:
        set_pose(model, data, pose, **kw)  # type: ignore[arg-type]
        data.qpos[2] += 0.05
        data.qpos[3:7] = [np.cos(0.8), np.sin(0.8), 0.0, 0.0]  # rolled 1.6 rad about its heading
        mujoco.mj_forward(model, data)

    monkeypatch.setattr(simulator_module, "set_pose", tipped)
    job = simulate_reference("open", reference="line", robot=robot, runs=[RunKind.CLOSED_LOOP_TRUTH])
    m = job.runs[RunKind.CLOSED_LOOP_TRUTH].metrics
    assert m.status.startswith("fell at t=") and "with the chassis on the floor); the run ended there" in m.status
    assert m.duration_s < 2.0 < job.prepared.trajectory.duration


def test_a_turtlebot3_dragging_its_tail_against_an_obstacle_has_not_fallen() -> None:
    """Pitched up against an obstacle it pushes, a TurtleBot3's chassis touches the floor from 0.14 rad: that
    ended its run as a fall (and its metrics there). Its chassis on the floor is a fall past FLOOR_TILT."""
    import mujoco

    from planning import World, load_robot
    from sim.physics.model import FLOOR_TILT, build_model, tipped_over, touches

    m = build_model(load_robot("turtlebot3"), World((-3, 3, -3, 3))).model
    d = mujoco.MjData(m)
    geoms = (m.body("base").id, m.geom("chassis").id, m.geom("floor").id)

    def resting(tilt: float) -> bool:
        """Pitched by ``tilt`` and lowered until its chassis touches the floor: whether it is tipped over."""
        d.qpos[3:7] = [np.cos(tilt / 2), 0.0, np.sin(tilt / 2), 0.0]
        for z in np.linspace(0.3, -0.2, 5001):
            d.qpos[2] = z
            mujoco.mj_forward(m, d)
            if touches(d, geoms[1], geoms[2]):
                return tipped_over(d, *geoms)
        raise AssertionError(f"the chassis never reached the floor at {tilt} rad")

    assert not resting(0.3) and not resting(FLOOR_TILT - 0.02)
    assert resting(FLOOR_TILT + 0.02) and resting(0.8)


def test_the_as_built_line_of_a_balancing_robot_says_its_centre_of_mass() -> None:
    """What a balancing body leans by (its centre of mass off the axle), its mass and its tyres' grip were in the
    record but not in the header: the skid robot's line stays as it was."""
    from sim.cli.simulate import _build_line

    built = {"left_radius_scale": 1.0014, "right_radius_scale": 1.0013, "track_change": -0.0016}
    built |= {"com_offset_x": -0.0048, "base_mass_scale": 1.040, "tyre_friction_scale": 0.952}
    balancing = {"build_seed": 1, "as_built": built, "closed_loop": {"max_pitch_rad": 0.2}}
    assert _build_line(balancing).endswith(
        "centre of mass -4.8 mm ahead of the axle, body mass x1.040, tyre friction x0.952"
    )
    skid = {"build_seed": 1, "as_built": built, "closed_loop": {"rms_position_error_m": 0.01}}
    assert _build_line(skid) == "as built (seed 1): wheels 1.0014/1.0013 x r, track -1.6 mm"
