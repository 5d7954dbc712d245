"""The Monte Carlo localiser: configuration, compiled kernels against the plain-Python reference,
the likelihood field against the world's distances, and tracking on LDS-01 scans."""

from __future__ import annotations

import math

import amcl_reference as ref
import mujoco
import numpy as np
import pytest

from control.estimation import amcl_kernels as K
from control.estimation.amcl import GRID_MARGIN, MAX_FIELD_CELLS, Amcl, AmclConfig, beam_subset, likelihood_field
from planning.core.arrays import kernel_input
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, World
from planning.errors import ConfigError
from sim.physics.lidar import LidarProfile, LidarScanner, beam_poses
from sim.physics.model import build_model

WORLD = World((-2.0, 2.0, -1.5, 1.5), (Box((1.0, 0.5), (0.4, 0.3), 0.3), Circle((-1.0, -0.5), 0.3)))
EXACT = LidarProfile(accuracy_near=0, accuracy_far=0, precision_near=0, precision_far=0)


def test_defaults_are_nav2s_and_bad_settings_are_refused() -> None:
    c = AmclConfig()
    nav2 = {
        "alpha1": 0.2,
        "alpha2": 0.2,
        "alpha3": 0.2,
        "alpha4": 0.2,
        "z_hit": 0.5,
        "z_rand": 0.5,
        "sigma_hit": 0.2,
        "laser_likelihood_max_dist": 2.0,
        "laser_max_range": 100.0,
        "laser_min_range": -1.0,
        "max_beams": 60,
        "min_particles": 500,
        "max_particles": 2000,
        "pf_err": 0.05,
        "pf_z": 0.99,
        "recovery_alpha_slow": 0.0,
        "recovery_alpha_fast": 0.0,
        "resample_interval": 1,
        "update_min_d": 0.25,
        "update_min_a": 0.2,
    }
    assert {k: getattr(c, k) for k in nav2} == nav2
    with pytest.raises(ConfigError, match="min_particles=5 is below 10"):
        c.parse("min_particles=5")
    with pytest.raises(ConfigError, match="unknown localiser key 'particles'"):
        c.parse("particles=100")
    with pytest.raises(ConfigError, match="max_particles=100 is below min_particles=500"):
        c.parse("max_particles=100")
    with pytest.raises(ConfigError, match=r"max_particles=1000000000000 is above 1,000,000.*at most 1000000"):
        c.parse("max_particles=1e12")  # not a 22 TB array
    with pytest.raises(ConfigError, match="sigma_hit must be > 0"):
        c.override({"sigma_hit": 0.0})
    with pytest.raises(
        ConfigError, match=r"refine must be a finite number, got 'yes', e\.g\. max_particles=1000"
    ) as err:
        c.parse("refine=yes")
    assert err.value.__cause__ is None  # no "NHSIM_TRACEBACK=1 prints the ValueError's traceback" from the command
    parsed = c.parse("max_particles=1000,refine=0")
    assert (parsed.max_particles, parsed.refine) == (1000, 0) and type(parsed.max_particles) is int
    for bad, match in [
        ("z_hit=2", r"z_hit must be a fraction in \[0, 1\], got 2"),
        ("z_hit=0", "z_hit must be > 0"),
        ("z_hit=0.8", r"z_hit \+ z_rand = 1.3 exceeds 1.*lower one of them"),
        ("pf_err=1.5", "pf_err must be a fraction"),
        ("laser_likelihood_max_dist=0", "laser_likelihood_max_dist must be > 0"),  # a flat field: 22 cm RMSE
        ("recovery_alpha_slow=0.1,recovery_alpha_fast=0.001", "recovery_alpha_slow=0.1 must be below"),
        ("recovery_alpha_fast=3", "recovery_alpha_fast must be a fraction"),
        (
            "alpha1=-1",
            r"^amcl alpha1 must be a finite number >= 0, got -1\.0; e\.g\. --amcl max_particles=1000,refine=0 ",
        ),
        ("sigma_hit=nan", r"^amcl sigma_hit must be a finite number >= 0, got nan; e\.g\. --amcl max_particles=1000,"),
        ("max_beams=60.5", r"^amcl max_beams must be an integer >= 0, got 60\.5; e\.g\. --amcl max_particles=1000,"),
    ]:
        with pytest.raises(ConfigError, match=match):
            c.parse(bad)
    assert c.parse("z_hit=0.95,z_rand=0.05,recovery_alpha_slow=0.001,recovery_alpha_fast=0.1").z_hit == 0.95
    assert beam_subset(360, 60).size == 60 and beam_subset(360, 60)[1] == 6  # Nav2's step (360 - 1) // 59


def test_a_nav2_block_is_taken_key_by_key_or_refused_with_the_reason() -> None:
    """A Nav2 ``amcl:`` block carries over: laser_min_range (which was refused as unknown) leaves out the beams
    at or below it (-1.0, Nav2's default, the scan's own range_min); a Nav2 key of another model or of ROS's
    plumbing is refused naming why, not listed as a typo."""
    c = AmclConfig()
    amcl = Amcl(World((0.0, 4.0, 0.0, 4.0)), c.parse("laser_min_range=0.5"), (0.0, 0.0, 0.0), seed=0)
    ranges = np.array([0.11, 0.3, 0.5, 0.51, 2.0, 3.6, np.inf])
    r, _ = amcl.beams(ranges, 0.12, 3.5, 0.0, 0.1, every=True)
    assert r.tolist() == [0.51, 2.0]
    plain = Amcl(World((0.0, 4.0, 0.0, 4.0)), c.parse("laser_min_range=-1"), (0.0, 0.0, 0.0), seed=0)
    assert plain.beams(ranges, 0.12, 3.5, 0.0, 0.1, every=True)[0].tolist() == [0.3, 0.5, 0.51, 2.0]
    assert c.range_limits(0.12, 3.5) == (0.12, 3.5)
    with pytest.raises(ConfigError, match="laser_min_range=200 is not below laser_max_range=100"):
        c.parse("laser_min_range=200")
    for key, says in [
        ("z_max", "Nav2's beam model"),
        ("lambda_short", "Nav2's beam model"),
        ("do_beamskip", "beam skipping"),
        ("alpha5", "differential drive"),
        ("initial_pose", "--initial-pose X,Y,THETA"),
        ("transform_tolerance", "ROS plumbing"),
    ]:
        with pytest.raises(ConfigError, match=rf"'{key}' is not taken: .*{says}"):
            c.parse(f"{key}=1")


def test_motion_model_matches_reference() -> None:
    rng = np.random.default_rng(0)
    alphas = np.array([0.2, 0.1, 0.3, 0.05])
    for old, new in [
        ((0, 0, 0), (0.3, 0.1, 0.4)),
        ((1, 2, 3.0), (0.8, 2.1, -3.0)),
        ((0, 0, 1), (0.005, 0, 1.3)),
        ((0, 0, 0), (-0.25, 0.0, 0.0)),
    ]:
        parts = rng.normal(size=(200, 3))
        z = rng.normal(size=(200, 3))
        got = parts.copy()
        K.motion_update(got, np.array(old, float), np.array(new, float), alphas, z)
        np.testing.assert_allclose(got, ref.motion_update(parts, old, new, alphas, z), atol=1e-12)
    # noiseless: a particle at the odometry's start ends at its end
    p = np.array([[0.0, 0.0, 0.3]])
    K.motion_update(p, np.array([0.0, 0.0, 0.3]), np.array([0.2, 0.1, -0.2]), np.zeros(4), np.ones((1, 3)))
    np.testing.assert_allclose(p[0], [0.2, 0.1, -0.2], atol=1e-12)


def test_likelihood_field_is_the_worlds_distance_and_the_sensor_model_matches_reference() -> None:
    f = likelihood_field(WORLD, 0.05, 2.0)
    x0, y0, h, cap = f.grid[:4]
    i, j = np.meshgrid(np.arange(f.signed.shape[0]), np.arange(f.signed.shape[1]), indexing="ij")
    pts = np.column_stack([x0 + h * i.ravel(), y0 + h * j.ravel()])
    sd = WORLD.signed_distance(pts).reshape(f.signed.shape)
    np.testing.assert_allclose(f.signed, np.clip(sd, -cap, cap), atol=1e-12)
    np.testing.assert_allclose(f.capped, np.clip(sd, 0, cap), atol=1e-12)
    assert np.all(WORLD.signed_distance(f.free) >= 0.1)
    rng = np.random.default_rng(1)
    parts = np.column_stack([rng.uniform(-1.5, 1.5, 50), rng.uniform(-1, 1, 50), rng.uniform(-3, 3, 50)])
    r, b = rng.uniform(0.2, 3.0, 60), np.linspace(0, 2 * np.pi, 60, endpoint=False)
    laser, model = np.array([-0.032, 0.0, 0.0]), np.array([0.5, 0.5, 0.2, 3.5])
    w = np.full(50, 2.0)
    far = float(K.pz_cubed(np.array([f.grid[3]]), model)[0])
    total = K.likelihood_update(parts, w, r, b, laser, K.pz_cubed(f.capped, model), f.grid, far)
    want = 2.0 * ref.likelihood(parts, r, b, laser, f.capped, f.grid, model)
    np.testing.assert_allclose(w, want, rtol=1e-12)
    assert total == pytest.approx(want.sum(), rel=1e-12)


def test_resampling_and_kld_match_reference() -> None:
    rng = np.random.default_rng(2)
    bins = np.array([-3.0, -3.0, 0.5, math.radians(10)])
    shape = np.array([12, 12, 36], dtype=np.int64)
    assert K.kld_limit(1, 0.05, 0.99, 10, 2000) == 2000
    b = 2 / (9 * 49)
    assert K.kld_limit(50, 0.05, 0.99, 10, 2000) == math.ceil(49 / 0.1 * (1 - b + math.sqrt(b) * 0.99) ** 3)
    for n, spread, w_diff in [(300, 0.2, 0.0), (500, 2.0, 0.0), (400, 1.0, 0.3)]:
        parts = rng.normal(0, spread, (n, 3))
        w = rng.random(n) ** 4
        w /= w.sum()
        m = 600
        order = rng.permutation(m).astype(np.int64)
        coins, randoms = rng.random(m), rng.uniform(-2, 2, (m, 3))
        kld = np.array([0.05, 0.99, 20.0])
        out = np.empty((m, 3))
        count = K.resample(parts, w, 0.37, order, w_diff, coins, randoms, bins, shape, kld, out)
        want = ref.resample(parts, w, 0.37, order, w_diff, coins, randoms, bins, shape, kld)
        assert count == len(want)
        np.testing.assert_array_equal(out[:count], want)
    # a tight cloud needs few particles, a wide one many
    tight = K.resample(
        rng.normal(0, 0.05, (500, 3)),
        np.full(500, 1 / 500),
        0.5,
        rng.permutation(2000),
        0.0,
        np.zeros(0),
        np.zeros((0, 3)),
        bins,
        shape,
        np.array([0.05, 0.99, 100.0]),
        np.empty((2000, 3)),
    )
    wide = K.resample(
        rng.uniform(-2.5, 2.5, (500, 3)),
        np.full(500, 1 / 500),
        0.5,
        rng.permutation(2000),
        0.0,
        np.zeros(0),
        np.zeros((0, 3)),
        bins,
        shape,
        np.array([0.05, 0.99, 100.0]),
        np.empty((2000, 3)),
    )
    assert 100 < tight < 150 and wide == 2000  # 8 bins at most (the cloud straddles 0) against hundreds


@pytest.fixture(scope="module")
def scanner() -> tuple[mujoco.MjData, LidarScanner]:
    model = build_model(load_robot("turtlebot3"), WORLD).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return data, LidarScanner(model, EXACT, seed=3)


def test_refinement_recovers_the_pose_from_an_exact_scan(scanner: tuple) -> None:
    data, lidar = scanner
    pose = np.array([0.1, -0.3, 0.4])
    scan = lidar.scan(data, 0.0, np.tile(pose, (360, 1)))
    amcl = Amcl(WORLD, AmclConfig(), [*lidar.offset[:2], 0.0], seed=1)
    f = amcl.field
    r, b = amcl.beams(scan.ranges, 0.12, 3.5, 0.0, scan.angle_increment, every=True)
    got, _, _, used, _, _ = K.refine(
        pose + np.array([0.06, -0.04, 0.04]),
        r,
        b,
        amcl.laser,
        f.signed,
        f.grid,
        0.3,
        20,
        kernel_input(K.NO_NOISE_MODEL),
    )
    assert used > 300
    np.testing.assert_allclose(got, pose, atol=2e-4)  # the grid's bilinear error


def test_resume_is_refine_from_the_fits_pose(scanner: tuple) -> None:
    """``resume`` skips the pass a fit already holds: the same state as refining from its pose again, bit for bit,
    whether the first fit converged or ran out of steps (and the objective is ``fit_cost``'s at the pose)."""
    data, lidar = scanner
    rng = np.random.default_rng(4)
    amcl = Amcl(WORLD, AmclConfig(), [*lidar.offset[:2], 0.0], seed=1)
    f = amcl.field
    for k in range(12):
        pose = np.array([0.1, -0.3, 0.4]) + rng.normal(0.0, [0.1, 0.1, 0.05])
        scan = lidar.scan(data, 0.0, np.tile(pose, (360, 1)))
        r, b = amcl.beams(scan.ranges, 0.12, 3.5, 0.0, scan.angle_increment, every=True)
        args = (r, b, amcl.laser, f.signed, f.grid, 0.3)
        start = pose + rng.normal(0.0, [0.08, 0.08, 0.05])
        fit = K.refine(start, *args, 1 + k % 4, kernel_input(K.NO_NOISE_MODEL))  # 1-4 steps: some stop short
        kept = [np.copy(a) if isinstance(a, np.ndarray) else a for a in fit]
        again = K.refine(fit[0], *args, 10, kernel_input(K.NO_NOISE_MODEL))
        got = K.resume(fit, *args, 10, kernel_input(K.NO_NOISE_MODEL), K.WHOLE)
        for a, b_ in zip(got, again, strict=True):
            np.testing.assert_array_equal(a, b_)
        for a, b_ in zip(fit, kept, strict=True):
            np.testing.assert_array_equal(a, b_)  # the fit given is left as it was
        assert fit[5] == K.fit_cost(fit[0], *args, kernel_input(K.NO_NOISE_MODEL))


def test_tracks_a_driving_robot_on_exact_scans(scanner: tuple) -> None:
    data, lidar = scanner
    t = np.arange(0.0, 20.0, 0.02)
    th = 0.25 * t
    truth = np.column_stack([0.6 * np.sin(th), -0.5 - 0.6 * (np.cos(th) - 1.0) - 0.6, th])
    truth[:, 1] += 0.1
    odom = truth + np.cumsum(np.random.default_rng(4).normal(0, 5e-4, truth.shape), axis=0)
    amcl = Amcl(WORLD, AmclConfig(), [*lidar.offset[:2], 0.0], seed=1)
    amcl.reset(truth[0] + [0.1, -0.1, 0.05])
    errs = []
    for k0 in range(0, len(t) - 11, 10):
        times = t[k0] + lidar.profile.time_increment * np.arange(360)
        scan = lidar.scan(data, t[k0], beam_poses(t[k0 : k0 + 11], truth[k0 : k0 + 11], times))
        if amcl.update(odom[k0 + 5], scan.ranges, 0.12, 3.5, 0.0, scan.angle_increment, force=k0 == 0):
            e = amcl.estimate
            assert e is not None and e.refined
            errs.append([math.hypot(*(e.pose[:2] - truth[k0 + 5, :2])), abs(K.angle_diff(e.pose[2], truth[k0 + 5, 2]))])
    errs_a = np.array(errs)
    assert len(errs) >= 15  # an update every 0.25 m or 0.2 rad
    assert np.sqrt(np.mean(errs_a[:, 0] ** 2)) < 0.01  # the scan's skew over a revolution is what is left
    assert np.sqrt(np.mean(errs_a[:, 1] ** 2)) < math.radians(0.5)
    assert 500 <= amcl.particles.shape[0] <= 2000


def test_a_field_larger_than_it_builds_is_refused_before_any_memory_with_the_resolution_that_fits() -> None:
    # a 1000 x 1000 m world at 0.025 m: 1.6e9 cells (it took all of the machine's memory); refused at once
    huge = World((-500.0, 500.0, -500.0, 500.0), (Circle((0.0, 0.0), 0.3),))
    said = r'1.6e\+09 cells.*--amcl map_resolution=0.264 \(amcl="map_resolution=0.264" from Python\), or with the'
    with pytest.raises(ConfigError, match=said) as err:
        likelihood_field(huge, 0.025, 2.0)
    assert str(err.value).endswith('synthetic fixes, --localiser fixes (localiser="fixes" from Python)')
    fits = float(str(err.value).split("map_resolution=")[1].split()[0])
    nx = math.ceil((1000.0 + 2 * GRID_MARGIN) / fits) + 1
    assert nx * nx <= MAX_FIELD_CELLS  # the resolution it names builds


def test_a_scan_without_returns_still_moves_the_particles_by_the_odometry() -> None:
    """Nav2's AMCL applies its motion model on every scan once the robot has moved enough. A revolution with
    no beam to weigh (every wall beyond 3.5 m, in a 12 x 12 m arena) was skipped whole: the filter stood still
    while the robot drove 12 m on, and was 16 m off when the walls came back into range."""
    amcl = Amcl(World((0.0, 12.0, 0.0, 12.0)), AmclConfig(), (-0.032, 0.0, 0.0), seed=0)
    amcl.reset([4.0, 4.0, math.pi / 4])
    assert amcl.predict(np.array([0.0, 0.0, 0.0]))  # the first notes the odometry
    step = 0.1 * np.array([1.0, 0.0, 0.0])
    assert not amcl.predict(step)  # 0.1 m: less than update_min_d (0.25 m), as Nav2
    for k in range(1, 14):  # 3.9 m straight ahead in 0.3 m steps (the odometry's frame), one scan each
        assert amcl.predict(np.array([0.3 * k, 0.0, 0.0]))
    est = amcl.estimate
    assert est is not None and not est.refined
    heading = np.array([1.0, 1.0]) / math.sqrt(2)
    moved = amcl.particles[:, :2].mean(axis=0) - 4.0
    along, aside = float(moved @ heading), float(moved @ [-heading[1], heading[0]])
    # the cloud went along (its mean a little short of 3.9 m: Nav2's heading noise spreads it over an arc)
    assert 3.0 < along < 4.0 and abs(aside) < 0.3, (along, aside)
    assert np.hypot(*(est.pose[:2] - (4.0 + 3.9 * heading))) < 1.5  # its heaviest cluster
    assert est.cov[0, 0] + est.cov[1, 1] > 0.01 and amcl.updates == 0  # nothing weighed, nothing resampled


def test_the_fit_asks_half_of_the_beams_the_particles_weigh_not_more_than_the_scan_has() -> None:
    """With max_beams above the scan's beams (720 of 360) the fit asked for 360 beams within its gate, every
    one of the scan's, and did not hold where some beams see nothing (7.0 cm against 0.4 cm at max_beams 60-400
    in a 3 x 2 m room)."""
    world = World((-6.0, 6.0, -1.5, 1.5), (Box((1.0, 0.5), (0.4, 0.3), 0.3), Circle((-1.0, -0.5), 0.3)))
    model = build_model(load_robot("turtlebot3"), world).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lidar = LidarScanner(model, EXACT, seed=3)
    pose = np.array([0.1, -0.3, 0.4])
    scan = lidar.scan(data, 0.0, np.tile(pose, (360, 1)))
    valid = np.isfinite(scan.ranges) & (scan.ranges > 0.12) & (scan.ranges < 3.5)
    assert 180 < valid.sum() < 360  # some beams see nothing within range
    for max_beams in (60, 720):
        amcl = Amcl(world, AmclConfig(max_beams=max_beams), [*lidar.offset[:2], 0.0], seed=1)
        amcl.reset(pose + np.array([0.03, -0.02, 0.01]))
        amcl.update(pose, scan.ranges, 0.12, 3.5, 0.0, scan.angle_increment, force=True)
        assert amcl.estimate is not None and amcl.estimate.refined, max_beams
        assert math.hypot(*(amcl.estimate.pose[:2] - pose[:2])) < 0.005


def test_the_refinements_3x3_solve_is_numpys() -> None:
    """``refine``'s Gauss-Newton step solves its 3 x 3 normal equations itself (numba's ``np.linalg.solve``
    took 4 s to compile in a new process): the same solution to rounding, pivoting where a column starts
    with zero, on the information matrices of 10-360 beams."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        jac = rng.normal(size=(int(rng.integers(10, 361)), 3)) * np.array([1.0, 1.0, rng.uniform(0.1, 3.0)])
        info, g = jac.T @ jac, rng.normal(size=3)
        want = np.linalg.solve(info + 1e-9 * np.eye(3), g)
        np.testing.assert_allclose(K._solve3(info, 1e-9, g), want, rtol=1e-12, atol=1e-14 * np.abs(want).max())
    swap = np.array([[0.0, 2.0, 1.0], [3.0, 1.0, 0.0], [1.0, 0.0, 4.0]])  # no pivot at [0, 0]
    np.testing.assert_allclose(K._solve3(swap, 0.0, np.array([1.0, 2.0, 3.0])), np.linalg.solve(swap, [1.0, 2.0, 3.0]))


def test_of_the_two_fits_the_one_the_scan_explains_better_is_taken() -> None:
    """A 9.5 x 9.3 m room split by a wall with a 0.27 m gap, the robot 1.1 m past it: the particles' cloud, spread
    along the wall (nothing else within the scanner's 3.5 m), had its mean 0.3 m off, and the fit from it slid
    along the wall to a pose with one beam more within the gate and a residual three times the right one's, which
    the fit from the last estimate had. Ranked by beams within the gate first, the wrong fit was taken (a seeded
    run lost the robot, 0.51 m off); ranked by the fit's own objective (every weighed beam, those beyond the gate at
    the gate), the right one is, for every noise draw."""
    from sim.physics.lidar import load_lidar_profile
    from sim.robot.scan_localiser import range_bias, range_noise

    world = World((-1.34, 8.2, -0.75, 8.51), (Box((3.026, 1.221), (0.279, 3.962)), Box((3.026, 5.993), (0.279, 5.054))))
    model = build_model(load_robot("turtlebot3"), world).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    profile = load_lidar_profile("turtlebot3")
    assert profile is not None
    truth, cloud = np.array([4.111, 3.821, -0.756]), np.array([3.977, 3.508, -0.766])
    more_beams_wrong = 0
    for seed in range(30):
        lidar = LidarScanner(model, profile, seed=seed)
        scan = lidar.scan(data, 0.0, np.tile(truth, (360, 1)))
        amcl = Amcl(world, AmclConfig(), [*lidar.offset[:2], 0.0], seed=1, range_bias=range_bias(profile),
                    range_noise=range_noise(profile))  # fmt: skip
        r, b = amcl.beams(scan.ranges, 0.12, 3.5, 0.0, scan.angle_increment, every=True)
        f = amcl.field
        fits = [K.refine(s, r, b, amcl.laser, f.signed, f.grid, 0.3, 10, amcl._noise) for s in (cloud, truth)]
        wrong, right = fits
        assert abs(wrong[0][1] - truth[1]) > 0.3 and abs(right[0][1] - truth[1]) < 0.1  # two fits, far apart
        costs = [K.fit_cost(fit[0], r, b, amcl.laser, f.signed, f.grid, 0.3, amcl._noise) for fit in fits]
        assert costs[1] < costs[0], seed
        assert [fit[5] for fit in fits] == costs  # refine's objective at its pose, bit for bit
        more_beams_wrong += (wrong[3], -wrong[4]) > (right[3], -right[4])
        amcl.reset(cloud, std_xy=0.05, std_theta=0.02)  # the cloud about the wrong mean, the last estimate right
        est = amcl._estimate(
            r, b, prior=truth + np.array([0.002, 0.005, 0.0]), scan=(scan.ranges, scan.bearings, 0.12, 3.5)
        )
        assert est.refined and math.hypot(*(est.pose[:2] - truth[:2])) < 0.1, (seed, est.pose)  # the scanner's bias
    assert more_beams_wrong >= 1  # the draws include one the old ranking got wrong


def test_a_corridor_fixes_the_position_across_it_and_the_heading_not_along_it() -> None:
    """Between two long walls, with both ends out of the scanner's reach, a scan fixes the position across the
    corridor and the heading, nothing along it: the fit's information is singular there, and the whole fit was
    dropped for the cloud's estimate (16 cm across, 7.7 deg). The fit within the directions the scan fixes
    (``observed_directions``) gives those to the scan's precision, holds the cloud's mean along the corridor, and
    reports the cloud's spread there and the fit's across: a covariance as long and thin as the corridor."""
    from control.estimation.amcl import observed_directions
    from sim.robot.scan_localiser import range_bias, range_noise

    corridor = World((0.0, 12.0, 0.0, 1.2), ())
    model = build_model(load_robot("turtlebot3"), corridor).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    profile = LidarProfile()
    rng = np.random.default_rng(5)
    for seed in range(6):
        truth = np.array([rng.uniform(4.5, 7.5), rng.uniform(0.45, 0.75), rng.normal(0.0, 0.05)])
        lidar = LidarScanner(model, profile, seed=seed)
        scan = lidar.scan(data, 0.0, np.tile(truth, (360, 1)))
        amcl = Amcl(corridor, AmclConfig(), [*lidar.offset[:2], 0.0], seed=seed, range_bias=range_bias(profile),
                    range_noise=range_noise(profile))  # fmt: skip
        cloud = truth + np.array([0.3, 0.08, 0.06])  # the cloud 30 cm along, 8 cm across and 3.4 deg off
        amcl.reset(cloud, std_xy=0.15, std_theta=0.05)
        r, b = amcl.beams(scan.ranges, 0.12, 3.5, 0.0, scan.angle_increment, every=True)
        f = amcl.field
        info = K.refine(truth, r, b, amcl.laser, f.signed, f.grid, 0.3, 0, amcl._noise)[1]
        basis = observed_directions(info)
        assert basis is not None and np.count_nonzero(np.any(basis != 0.0, axis=0)) == 2
        assert np.allclose(np.abs(basis[0]), 0.0, atol=1e-6)  # nothing along x is observed
        est = amcl._estimate(r, b, scan=(scan.ranges, scan.bearings, 0.12, 3.5))
        assert est.refined, seed
        assert abs(est.pose[1] - truth[1]) < 0.01 and abs(est.pose[2] - truth[2]) < 0.005, (seed, est.pose, truth)
        mean = K.cluster_estimate(amcl.particles, amcl.weights, amcl.bins, amcl.shape)[0]
        assert est.pose[0] == pytest.approx(mean[0], abs=1e-9)  # held along the corridor, where the cloud put it
        sd = np.sqrt(np.diag(est.cov))
        assert sd[0] > 0.05 and sd[1] < 0.01 and sd[2] < 0.01, sd
    # a scan that fixes every direction keeps the whole fit
    assert observed_directions(np.diag([4.0, 3.0, 2.0])) is None
