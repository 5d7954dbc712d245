"""The control suite (``sim.suite``), tested in the manner of dm_control's ``suite/suite_test.py``.

One parametrised set of checks runs over every entry of ``suite.ALL`` (slow: each entry plans), and
over a fast subset in the default run: valid specs, finite observations, reset determinism, random
actions within the spec raising no MuJoCo warning. Then: the reference policy reproduces
``nhsim simulate``'s closed-loop run bit for bit and beats a zero policy; bad input is refused with
the valid choices or the spec.
"""

from __future__ import annotations

import copy
import pickle
from collections.abc import Iterator

import dm_env
import numpy as np
import pytest
from dm_control.rl import control
from dm_env import specs

from planning.errors import ConfigError, ScenarioError
from sim import suite
from sim.physics.runlog import RunLog
from sim.pipeline.runs import RunKind
from sim.pipeline.simulate import simulate_plan, simulate_reference
from tests.doc_blocks import block_of

#: Entries checked in the default run: both robots, references and several planners.
FAST = (
    ("edumip_map", "edumip", "c-rrt-star"),
    ("parallel_park", "turtlebot3", "birrt"),
    ("three_point_turn", "turtlebot3", "rrt"),
    ("turn_in_place", "edumip", "sinusoidal"),
    ("open", "turtlebot3", "figure8"),
    ("open", "edumip", "circle"),
)


def _load(entry: tuple[str, str, str], seed: int = 0) -> control.Environment:
    try:
        return suite.load(*entry, seed=seed)
    except suite.NotApplicableError as exc:
        pytest.skip(f"n/a, as in nhsim simulate --all: {exc}")


def _random_actions(env: control.Environment, n: int, seed: int) -> Iterator[np.ndarray]:
    spec = env.action_spec()
    rng = np.random.default_rng(seed)
    for _ in range(n):
        yield rng.uniform(spec.minimum, spec.maximum, size=spec.shape)


def _check_entry(entry: tuple[str, str, str]) -> None:
    env = _load(entry)
    # specs valid
    aspec = env.action_spec()
    assert isinstance(aspec, specs.BoundedArray) and aspec.shape == aspec.minimum.shape == aspec.maximum.shape == (2,)
    assert np.all(np.isfinite(aspec.minimum)) and np.all(aspec.minimum < aspec.maximum)
    ospec = env.observation_spec()
    first = env.reset()
    assert first.first() and list(first.observation) == list(ospec)
    for name, spec in ospec.items():
        spec.validate(first.observation[name])
        assert np.all(np.isfinite(first.observation[name])), name
    # reset determinism: the same seed gives the same first observation and the same 100 steps
    env, twin = _load(entry), _load(entry)
    steps = [(env.reset(), twin.reset())]
    for action in _random_actions(env, 100, seed=7):
        a, b = env.step(action), twin.step(action)
        steps.append((a, b))
        if a.last():
            break
    for a, b in steps:
        assert a.step_type == b.step_type and a.reward == b.reward
        for name in ospec:
            np.testing.assert_array_equal(a.observation[name], b.observation[name], err_msg=name)
    # random actions within the spec for 200 steps: no MuJoCo warning, finite observations, rewards in [0, 1]
    ts = env.reset()
    rspec = env.reward_spec()  # bounded as the reward is (dm_env's default said an unbounded float)
    assert (rspec.minimum, rspec.maximum, rspec.shape) == (0.0, 1.0, ())
    for action in _random_actions(env, 200, seed=11):
        ts = env.step(action)
        assert 0.0 <= ts.reward <= 1.0
        rspec.validate(np.asarray(ts.reward, dtype=np.float64))
        assert all(np.all(np.isfinite(v)) for v in ts.observation.values())
        if ts.last():
            ts = env.reset()
    assert not np.any(env.physics.data.warning.number), env.physics.data.warning.number


@pytest.mark.parametrize("entry", FAST, ids="-".join)
def test_fast_entries(entry: tuple[str, str, str]) -> None:
    _check_entry(entry)


@pytest.mark.slow
@pytest.mark.parametrize("entry", suite.ALL, ids="-".join)
def test_every_entry(entry: tuple[str, str, str]) -> None:
    _check_entry(entry)


def test_all_is_the_sweep_matrix() -> None:
    from sim.pipeline.sweep import sweep_cases

    cases = sweep_cases()
    assert len(suite.ALL) == len(cases) == len(set(suite.ALL))
    assert {(c.scenario, c.robot, c.planner) for c in cases} == set(suite.ALL)
    assert ("edumip_map", "edumip", "c-rrt-star") in suite.ALL
    # the balancing EduMIP has every case the skid EduMIP has: 58 + 2 x 51 entries
    per_robot = {r: {(s, p) for s, rr, p in suite.ALL if rr == r} for r in ("turtlebot3", "edumip", "edumip-balancing")}
    assert per_robot["edumip-balancing"] == per_robot["edumip"]
    assert [len(v) for v in per_robot.values()] == [58, 51, 51] and len(suite.ALL) == 160
    assert ("turn_in_place", "edumip-balancing", "sinusoidal") in suite.ALL


def _assert_same_run(episode: suite.EpisodeResult, log: RunLog) -> None:
    assert episode.log.pose.shape == log.pose.shape
    np.testing.assert_array_equal(episode.log.t, log.t)
    np.testing.assert_array_equal(episode.log.pose, log.pose)
    np.testing.assert_array_equal(episode.log.wheel_command, log.wheel_command)


def test_reference_policy_reproduces_simulate_bit_for_bit_on_the_default_job() -> None:
    env = suite.load("edumip_map", "edumip", "c-rrt-star", seed=3, build_seed=5)
    episode = suite.run_episode(env, suite.reference_policy(env))
    job = simulate_plan("edumip_map", planner="c-rrt-star", robot="edumip", seed=3, build_seed=5,
                        runs=(RunKind.CLOSED_LOOP,))  # fmt: skip
    _assert_same_run(episode, job.logs[RunKind.CLOSED_LOOP])
    ours, theirs = episode.metrics, job.metrics[RunKind.CLOSED_LOOP]
    for name in ("final_position_error_m", "final_heading_error_rad", "rms_position_error_m", "max_position_error_m"):
        assert getattr(ours, name) == getattr(theirs, name), name
    assert ours.final_position_error_m < 0.02 and episode.steps == len(job.logs[RunKind.CLOSED_LOOP].t) - 1


def test_reference_policy_reproduces_a_reference_run_with_odometry() -> None:
    env = suite.load("open", "turtlebot3", "figure8", seed=1)
    episode = suite.run_episode(env, suite.reference_policy(env, "odometry"))
    job = simulate_reference("open", reference="figure8", robot="turtlebot3", seed=1,
                             runs=(RunKind.CLOSED_LOOP_ODOMETRY,))  # fmt: skip
    _assert_same_run(episode, job.logs[RunKind.CLOSED_LOOP_ODOMETRY])


def test_the_turtlebot3s_environment_is_its_run_on_pose_fixes() -> None:
    """The TurtleBot3's observations carry pose fixes, not its laser scans, but its case kept the robot's default
    localiser (amcl): the reference policy's estimator was set up for scan matching (its range-bias terms) and fed
    fixes, reproducing no command. It is ``simulate --localiser fixes``, bit for bit."""
    env = suite.load("open", "turtlebot3", "circle", seed=2)
    assert env.task.sensing.localiser.kind == "fixes"
    episode = suite.run_episode(env, suite.reference_policy(env))
    job = simulate_reference("open", reference="circle", robot="turtlebot3", seed=2, localiser="fixes",
                             runs=(RunKind.CLOSED_LOOP,))  # fmt: skip
    _assert_same_run(episode, job.logs[RunKind.CLOSED_LOOP])


def test_reference_policy_beats_a_zero_policy() -> None:
    env = suite.load("open", "edumip", "circle", seed=0)
    ours = suite.run_episode(env, suite.reference_policy(env))
    zero = suite.run_episode(env, lambda ts: np.zeros(2))
    assert ours.ret > 0.95 * ours.steps
    assert zero.ret < 0.5 * ours.ret


def test_episodes_after_the_first_draw_new_noise() -> None:
    env = suite.load("open", "turtlebot3", "circle", seed=0)
    a = env.reset().observation["gyro_z"]
    b = env.reset().observation["gyro_z"]
    assert a[0] != b[0]


def test_unknown_names_list_the_valid_ones() -> None:
    with pytest.raises(ConfigError, match="unknown robot 'roomba': choose one of edumip, edumip-balancing, turtlebot3"):
        suite.load("open", "roomba", "figure8")
    with pytest.raises(ConfigError, match=r"c-rrt-star.*figure8"):
        suite.load("open", "edumip", "astar")
    with pytest.raises(ScenarioError, match="edumip_map"):
        suite.load("moon", "edumip", "figure8")


def test_sensor_overrides_reach_the_environment_and_bad_arguments_are_named() -> None:
    """A message about the sensors' rates says to give ``fix_rate=...``, which suite.load could not take;
    lists as arguments ended in @cache's TypeError."""
    env = suite.load("open", "edumip", "line", control_rate=25, sensors="fix_rate=5")
    assert env.task.sensing.profile.fix_rate == 5.0 and env.control_timestep() == pytest.approx(0.04)
    typo = (
        r'--sensors fix_rat=5 \(sensors="fix_rat=5" from Python\): unknown key .fix_rat. \(did you mean .fix_rate.\?\)'
    )
    with pytest.raises(ConfigError, match=typo + "; expected"):
        suite.load("open", "edumip", "line", sensors="fix_rat=5")
    with pytest.raises(ConfigError, match=r"control_rate must be a finite number > 0 \(Hz\), got \[50\]; e\.g\. 50"):
        suite.load("open", "edumip", "line", control_rate=[50])  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"--build-seed \(build_seed=\.\.\. from Python\) must be an integer"):
        suite.load("open", "edumip", "line", build_seed=[1])  # type: ignore[arg-type]


def test_bad_actions_raise_with_the_spec() -> None:
    env = suite.load("open", "edumip", "circle", seed=0)
    env.reset()
    with pytest.raises(ValueError, match=r"shape.*BoundedArray"):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match=r"bounds.*BoundedArray"):
        env.step(np.array([1e6, 0.0]))
    with pytest.raises(ValueError, match="BoundedArray"):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(ValueError, match=r"complex.*BoundedArray"):  # not cast to its real part
        env.step(np.array([1.0 + 2.0j, 0.0]))
    with pytest.raises(ValueError, match=r"complex.*BoundedArray"):
        env.step([1.0, 0.5j])


def test_seeds_are_taken_as_dm_controls_suite_takes_them() -> None:
    """An int, None (a random seed) or a RandomState, checked at load; anything else refused there."""
    for bad in ("7", 7.0, True, -1):
        with pytest.raises(ConfigError, match=r"seed must be an integer >= 0, None .* or a numpy.random.RandomState"):
            suite.load("open", "turtlebot3", "circle", seed=bad)  # type: ignore[arg-type]
    from sim.suite.cases import suite_seed

    assert suite_seed(7) == 7 and suite_seed(np.int64(7)) == 7
    assert suite_seed(np.random.RandomState(3)) == suite_seed(np.random.RandomState(3))  # drawn from it
    assert suite_seed(None) != suite_seed(None)  # a fresh random seed (equal once in 2**31)
    env = suite.load("open", "turtlebot3", "circle", seed=None)
    assert env.reset().observation["gyro_z"].shape == (1,)
    rs = suite.load("open", "turtlebot3", "circle", seed=np.random.RandomState(3))
    again = suite.load("open", "turtlebot3", "circle", seed=np.random.RandomState(3))
    assert rs.reset().observation["gyro_z"][0] == again.reset().observation["gyro_z"][0]


def test_the_docs_snippet_runs() -> None:
    block = block_of("docs/how-to/dm-control-suite.md")
    scope: dict[str, object] = {}
    exec(compile(block.code, block.name, "exec"), scope)
    final = scope["timestep"]
    assert final.last() and final.discount == 1.0  # type: ignore[attr-defined]


def test_reference_policy_reproduces_simulate_bit_for_bit_on_the_balancing_robot() -> None:
    """The balancing EduMIP's estimator counts its body's pitch into the wheels' turns: the policy reads
    the balance loop's estimate from the ``pitch_estimate`` observation, as the simulator's sensing does."""
    env = suite.load("turn_in_place", "edumip-balancing", "c-rrt-star", seed=0)
    episode = suite.run_episode(env, suite.reference_policy(env))
    job = simulate_plan("turn_in_place", planner="c-rrt-star", robot="edumip-balancing", seed=0,
                        runs=(RunKind.CLOSED_LOOP,))  # fmt: skip
    _assert_same_run(episode, job.logs[RunKind.CLOSED_LOOP])


def _assert_valid_observation(env: control.Environment, ts: dm_env.TimeStep) -> None:
    for name, spec in env.observation_spec().items():
        spec.validate(ts.observation[name])
        assert np.all(np.isfinite(ts.observation[name])), name


def test_a_fall_of_the_balancing_robot_ends_the_episode_with_discount_0() -> None:
    """Alternating full wheel speeds topple the balancing EduMIP: its balance firmware finds the fall
    (the test that ends an ``nhsim simulate`` run) at its first update of period 22 and the episode ends
    with that step, discount 0, instead of running its 928 periods lying on the floor with discount 1."""
    env = suite.load("open", "edumip-balancing", "circle", seed=0)
    limit = float(env.action_spec().maximum[0])
    ts = env.reset()
    firmware = env.task.episode.recorder.balance
    steps = 0
    while not ts.last():
        assert firmware.fell_at is None  # the episode did not end before the fall
        ts = env.step(np.full(2, limit if steps % 2 == 0 else -limit))
        steps += 1
    assert firmware.fell_at is not None and ts.discount == 0.0
    assert steps == 22 < env.task.schedule.n_ctrl == 928 and not env.task.episode.recorder.contacts
    _assert_valid_observation(env, ts)
    assert env.task.log().status.startswith("fell at t=0.420 s")


def test_a_tipped_skid_edumip_ends_the_episode_with_discount_0() -> None:
    """Full speed forward from rest tips the skid EduMIP over: the episode ends with discount 0 at period 20,
    the first whose end finds its body tilted past ``TIP_ANGLE`` (0.85 rad; its chassis lands on the floor
    three periods later), instead of running its 1265 periods on its back with discount 1. It touched no
    obstacle."""
    from sim.physics.model import TIP_ANGLE

    env = suite.load("edumip_map", "edumip", "c-rrt-star", seed=0)
    m, d = env.physics.model.ptr, env.physics.data.ptr
    base = m.body("base").id

    ts = env.reset()
    steps = 0
    while not ts.last():
        assert d.xmat[base][8] >= np.cos(TIP_ANGLE)  # the episode did not end before the fall
        ts = env.step(env.action_spec().maximum * np.ones(2))
        steps += 1
    assert d.xmat[base][8] < np.cos(TIP_ANGLE) and ts.discount == 0.0 and not env.task.episode.recorder.contacts
    assert steps == 20 < env.task.schedule.n_ctrl == 1265
    _assert_valid_observation(env, ts)
    # the run log says so, as a simulate run's does (its status said "ok" of a robot on its back)
    assert env.task.log().status.startswith("fell at t=0.400 s (|tilt| beyond 0.85 rad")  # 20 periods of 20 ms


@pytest.mark.parametrize(
    ("entry", "steps", "ret"),
    [
        (("edumip_map", "edumip", "c-rrt-star"), 1265, 1264.9644007705647),
        (("open", "edumip-balancing", "circle"), 928, 926.1965358479506),
    ],
    ids=["skid", "balancing"],
)
def test_a_reference_policy_episode_runs_to_its_time_limit_with_discount_1(
    entry: tuple[str, str, str], steps: int, ret: float
) -> None:
    """The fall test does not fire while the robot tracks: the episode runs every period of the
    trajectory and its hold with discount 1, its return as measured before episodes ended at a fall."""
    env = suite.load(*entry, seed=0)
    policy = suite.reference_policy(env)
    ts = env.reset()
    discounts, total = [], 0.0
    while not ts.last():
        ts = env.step(policy(ts))
        discounts.append(ts.discount)
        total += ts.reward
    assert len(discounts) == env.task.schedule.n_ctrl == steps and set(discounts) == {1.0}
    assert total == pytest.approx(ret, rel=1e-12)


def test_before_the_first_episode_the_physics_copies_and_restores() -> None:
    env = suite.load("open", "turtlebot3", "figure8", seed=3)
    state = env.physics.get_state()
    env.physics.set_state(state)
    twin = env.physics.copy()
    np.testing.assert_array_equal(twin.get_state(), state)


def test_an_episode_is_not_rewound_through_mujocos_state_alone() -> None:
    """``physics.set_state`` rewound MuJoCo but not the episode (its firmware, sensors, log and reference clock):
    the reward went on scoring a later point and a replay drifted by millimetres; ``physics.copy()`` stepped into
    "reset the environment". Both are refused during an episode, naming the replay that works: the same seed and
    the same actions give the same episode, bit for bit."""
    actions = [np.array([2.0, 2.5]), np.array([1.0, -1.0]), np.array([3.0, 3.0])] * 10
    poses = []
    for _ in range(2):
        env = suite.load("open", "turtlebot3", "figure8", seed=3)
        env.reset()
        for a in actions:
            ts = env.step(a)
        poses.append((np.array(ts.observation["privileged_true_pose"]), ts.reward))
        with pytest.raises(RuntimeError, match=r"cannot be rewound or copied .*the same seed, reset it and step the"):
            env.physics.set_state(env.physics.get_state())
        with pytest.raises(RuntimeError, match="cannot be rewound or copied"):
            env.physics.copy()
        for copier in (copy.copy, copy.deepcopy, pickle.dumps):  # dm_control's __getstate__: no way around it
            with pytest.raises(RuntimeError, match="cannot be rewound or copied"):
                copier(env.physics)
        assert repr(env.task.log()).startswith("RunLog('agent on ")  # whose actions ran ("?" before)
    np.testing.assert_array_equal(poses[0][0], poses[1][0])
    assert poses[0][1] == poses[1][1]
