"""Perturbations: model edits, pose noise and latency, each against an exact or analytic answer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from control.base import make_tracker
from planning.core.robot import load_robot
from planning.errors import ConfigError
from planning.scenario import load_scenario
from planning.trajectory.references import make_reference
from sim.physics.perturb import Perturbation, PerturbationRange
from sim.physics.simulator import SimConfig, Simulator


@pytest.fixture(scope="module")
def setup() -> tuple[Simulator, object, object]:
    robot = load_robot("turtlebot3")
    sc = load_scenario("open")
    traj = make_reference("line", robot, sc.start, length=1.0)
    return Simulator(robot, sc.world), traj, robot


def _run(setup, tracker: str = "open-loop", pert: Perturbation | None = None, rate: float = 50.0):  # type: ignore[no-untyped-def]
    sim, traj, robot = setup
    return sim.run(traj, make_tracker(tracker, robot), SimConfig(control_rate=rate), perturbation=pert)


def test_nominal_perturbation_is_the_unperturbed_run(setup) -> None:  # type: ignore[no-untyped-def]
    base = _run(setup, "fbl")
    assert _run(setup, "fbl", Perturbation()).identical_to(base)
    assert _run(setup, "fbl", Perturbation(seed=9)).identical_to(base)  # a seed alone changes nothing


def test_model_edits_are_exact_and_leave_the_nominal_model_alone(setup) -> None:  # type: ignore[no-untyped-def]
    sim = setup[0]
    m0 = sim.model
    base, wheel = m0.body("base").id, m0.geom("wheel_left_geom").id
    friction0, mass0, size0 = m0.geom_friction.copy(), m0.body_mass.copy(), m0.geom_size.copy()
    m = Perturbation(friction=0.6, mass=1.3, radius=1.02).apply_to_model(m0)
    np.testing.assert_array_equal(m.geom_friction[:, 0], friction0[:, 0] * 0.6)
    np.testing.assert_array_equal(m.geom_friction[:, 1:], friction0[:, 1:])
    assert m.body_mass[base] == mass0[base] * 1.3
    assert m.body_subtreemass[base] == pytest.approx(m0.body_subtreemass[base] + 0.3 * mass0[base], rel=1e-12)
    assert m.geom_size[wheel, 0] == size0[wheel, 0] * 1.02
    assert m.body_pos[base, 2] == pytest.approx(m0.body_pos[base, 2] + 0.02 * size0[wheel, 0], abs=1e-15)
    caster = m0.geom("caster").id  # the caster keeps its height above the floor
    assert m.body_pos[base, 2] + m.geom_pos[caster, 2] == pytest.approx(m0.body_pos[base, 2] + m0.geom_pos[caster, 2])
    np.testing.assert_array_equal(m0.geom_friction, friction0)  # the simulator's model is untouched
    np.testing.assert_array_equal(m0.body_mass, mass0)
    np.testing.assert_array_equal(m0.geom_size, size0)


def test_wheel_radius_error_scales_open_loop_distance(setup) -> None:  # type: ignore[no-untyped-def]
    # The drive still believes the nominal radius, so each wheel turn covers f times the distance.
    start = setup[1].pose[0, :2]
    d0 = np.linalg.norm(_run(setup).pose[-1, :2] - start)
    for f in (0.97, 1.03):
        d = np.linalg.norm(_run(setup, pert=Perturbation(radius=f)).pose[-1, :2] - start)
        assert d / d0 == pytest.approx(f, rel=2e-3)


def _shifted(base, late, shift: float, field: str, atol: float | None) -> int:  # type: ignore[no-untyped-def]
    """Check ``late.<field>`` against ``base.<field>`` delayed by ``shift`` [s] wherever the late log has
    that time (exactly, or within ``atol``); returns how many samples were compared."""
    t_late = late.t - late.t[0]
    checked = 0
    for i in range(1, len(base)):
        t = base.t[i] - base.t[0] + shift
        j = int(np.argmin(np.abs(t_late - t)))
        if abs(t_late[j] - t) > 1e-9:
            continue
        a, b = getattr(late, field)[j], getattr(base, field)[i]
        if atol is None:
            np.testing.assert_array_equal(a, b)
        else:
            np.testing.assert_allclose(a[:2], b[:2], atol=atol)
        checked += 1
    assert checked == sum(base.t[i] - base.t[0] + shift <= t_late[-1] + 1e-9 for i in range(1, len(base)))
    return checked


@pytest.mark.parametrize(("latency", "rate"), [(0.02, 50.0), (0.01, 50.0), (0.01, 100.0), (0.006, 100.0)])
def test_latency_delays_the_open_loop_run(setup, latency: float, rate: float) -> None:  # type: ignore[no-untyped-def]
    # Open loop ignores the pose, so a latency L only delays the wheel commands: the command in force
    # is the nominal one shifted by L (the robot rests on zero commands meanwhile). The motors' firmware
    # takes a command up at its next update (every 10 ms from the start), so the run is the nominal
    # one shifted by L rounded up to the firmware's period.
    base = _run(setup, rate=rate)
    late = _run(setup, pert=Perturbation(latency=latency), rate=rate)
    period = setup[0].motors.period
    shift = math.ceil(latency / period - 1e-9) * period
    _shifted(base, late, latency, "wheel_command", None)  # in force up to t
    assert _shifted(base, late, shift, "pose", 2e-5) > 0.9 * len(base)
    n_rest = round(latency / (late.t[1] - late.t[0]))
    np.testing.assert_array_equal(late.wheel_command[: n_rest + 1], 0.0)
    assert late.meta["perturbation"]["latency"] == latency


def test_noise_is_seeded_and_has_the_stated_spread(setup) -> None:  # type: ignore[no-untyped-def]
    p = Perturbation(noise=0.004, heading_noise=0.02, seed=11)
    z = p.sensor_noise(40000)
    assert z is not None
    # standard error of a sample std is sigma / sqrt(2n) ~ 0.35 %; allow 5 of them
    np.testing.assert_allclose(z.std(axis=0), [0.004, 0.004, 0.02], rtol=0.02)
    np.testing.assert_allclose(z.mean(axis=0), 0.0, atol=5 * 0.02 / np.sqrt(40000))
    a = _run(setup, "fbl", p)
    assert _run(setup, "fbl", p).identical_to(a)
    assert not _run(setup, "fbl", Perturbation(noise=0.004, heading_noise=0.02, seed=12)).identical_to(a)
    assert not a.identical_to(_run(setup, "fbl"))
    assert Perturbation().sensor_noise(5) is None


def test_parse_and_validation() -> None:
    p = Perturbation.parse("friction=0.6,mass=1.3,radius=1.02,noise=0.005,latency=0.02", seed=4)
    assert p == Perturbation(0.6, 1.3, 1.02, 0.005, 0.0, 0.02, seed=4)
    assert p.label() == "friction=0.6,mass=1.3,radius=1.02,noise=0.005,latency=0.02"
    for bad, match in [("grip=2", "expected comma-separated"), ("mass=heavy", "must be a number"),
                       ("mass=1,mass=2", "given twice"), ("radius=2", r"in \[0.5, 1.5\] \(x\), got 2.0"),
                       ("noise=-1", r"in \[0, 0.5\] \(m\), got -1.0"),
                       ("latency", "expected comma-separated")]:  # fmt: skip
        with pytest.raises(ConfigError, match=match):
            Perturbation.parse(bad)
    with pytest.raises(ConfigError, match="seed"):
        Perturbation(seed=-1)


def test_range_sampling_is_seeded_and_within_bounds() -> None:
    r = PerturbationRange.parse("friction=0.5:0.7,latency=0.01")
    assert r.friction == (0.5, 0.7) and r.latency == (0.01, 0.01) and r.mass == PerturbationRange().mass
    a, b = r.sample(50, seed=3), r.sample(50, seed=3)
    assert a == b and a != r.sample(50, seed=4)
    assert all(0.5 <= p.friction <= 0.7 and p.latency == 0.01 for p in a)
    assert len({p.seed for p in a}) == 50
    with pytest.raises(ConfigError, match=r"lo 0.7 > hi 0.5"):
        PerturbationRange.parse("friction=0.7:0.5")


def test_a_timed_perturbation_outside_the_run_is_refused(
    tmp_path: object, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A push after the run's end (or a latency as long as the run) would be claimed and never act:
    refused before any physics, naming the key, its time and the run's length."""
    from pathlib import Path

    from sim.cli.main import main

    Perturbation.parse("push=0.9@17.9").check_within(18.0)
    with pytest.raises(ConfigError, match=r"push=0\.9@25 comes at 25 s, but the run lasts 18 s"):
        Perturbation.parse("push=0.9@25").check_within(18.0)
    with pytest.raises(ConfigError, match=r"latency=0.6 delays every command by 0.6 s, but the run lasts 0.5 s"):
        Perturbation.parse("latency=0.6").check_within(0.5)
    monkeypatch.chdir(tmp_path)  # type: ignore[arg-type]

    def no_physics(*args: object, **kwargs: object) -> None:
        raise AssertionError("the physics ran")

    monkeypatch.setattr("sim.physics.simulator.Recorder", no_physics)  # the run's log, made as it starts
    argv = ["simulate", "--robot", "edumip-balancing", "--reference", "circle", "--perturb", "push=0.9@250"]
    assert main([*argv, "--no-video", "--no-plots", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "push=0.9@250 comes at 250 s, but the run lasts" in err and "Traceback" not in err
    assert not list(Path(".").rglob("*.json"))


def test_an_unknown_range_key_is_named_with_the_closest_key_and_a_range_example() -> None:
    """``--perturb-range fricton=0.5:1.5`` said only "expected comma-separated key=value ..." with the single
    values of a --perturb example."""
    with pytest.raises(ConfigError) as caught:
        PerturbationRange.parse("fricton=0.5:1.5")
    message = str(caught.value)
    assert "unknown key 'fricton' (did you mean 'friction'?)" in message
    assert "key=lo:hi" in message and "(e.g. friction=0.5:1.5,latency=0:0.04)" in message
    with pytest.raises(ConfigError, match=r"unknown key 'zzz'; expected comma-separated key=value with keys friction"):
        Perturbation.parse("zzz=1")  # nothing close: no guess


def test_a_push_in_the_runs_last_control_period_is_taken() -> None:
    """A run lasts its whole control periods (27.18 s where the trajectory and hold give 27.16 s), but a push between
    the two was refused as coming after the run's end."""
    from control.base import make_tracker
    from planning.core.geometry import Pose2D
    from planning.core.robot import load_robot
    from planning.trajectory.references import make_reference
    from sim.physics.simulator import Schedule, SimConfig, Simulator

    assert Schedule.make(10, 0.002, 1.005).duration == pytest.approx(1.02)
    robot = load_robot("edumip-balancing")
    sim = Simulator(robot)
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0), length=0.1)
    config = SimConfig(control_rate=50.0, hold=0.0101)  # the horizon ends inside a control period
    horizon = traj.duration + config.hold
    lasts = Schedule.make(sim.steps_per_control(50.0), float(sim.model.opt.timestep), horizon).duration
    assert lasts > horizon + 1e-3
    late = Perturbation.parse(f"push=0.01@{0.5 * (horizon + lasts):.6f}")
    log = sim.run(traj, make_tracker("fbl", robot), config, perturbation=late)
    assert log.t[-1] == pytest.approx(lasts)


def test_a_latency_is_a_whole_number_of_physics_steps_rounded_half_up_and_the_applied_one_recorded() -> None:
    """``round`` rounded halves to even: 0.005 s at 2 ms steps ran as 4 ms, as 0.003 s did, and 0.001 s as none,
    while the record kept the latency asked for; halves go up now, and the record says what was applied."""
    from sim.physics.perturb import Perturbation

    step = 0.002
    steps = [Perturbation(latency=x).latency_steps(step) for x in (0.001, 0.003, 0.005, 0.0049, 0.02)]
    assert steps == [1, 2, 3, 2, 10]
    import sim

    case = sim.Case("open", robot="edumip", reference="line", perturbation=Perturbation(latency=0.005))
    result = sim.simulate(case, "open_loop")
    assert result.record()["perturbation"]["latency"] == 0.005
    assert result.record()["perturbation"]["latency_applied_s"] == pytest.approx(0.006, abs=1e-12)
