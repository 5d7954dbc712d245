"""Python code hands each compiled kernel one array type (:func:`planning.core.arrays.kernel_input`).

numba compiles a kernel once per combination of argument types, an array's writability among them. Plans,
trajectories and robot specs hold read-only arrays, the arrays a kernel builds for the kernels it calls are
writable, and a kernel reached both ways compiled twice: 26 of the 127 s of CPU the test run spent compiling
on a new machine.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np

from control.estimation.amcl import Amcl, AmclConfig
from planning.core.arrays import kernel_input
from planning.core.robot import load_robot
from planning.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]

_CALLS = """
from numba.core.dispatcher import Dispatcher

from planning import PlanProblem, load_robot, load_scenario, make_planner
from planning.collision import compiled
from planning.collision.exact import CollisionChecker
from planning.curves import reeds_shepp
from planning.planners.sampling import connect_kernel
from planning.trajectory import smoothing

sc = load_scenario("nav_map1")
robot = load_robot(sc.robot)
problem = PlanProblem(sc.world, robot, sc.start, sc.goal, seed=0, time_limit=10.0)
paths = [make_planner(name, **options).plan(problem).path for name, options in
         (("birrt", {}), ("rrt-star", {"max_iterations": 300}))]
checker = CollisionChecker(sc.world, robot)
for path in paths:  # a plan's arrays are read-only, copies of them writable
    for poses in (path, path.copy(), path.tolist()):
        checker.clearance_of(poses)
        reeds_shepp.REEDS_SHEPP.batch(poses[:-1], poses[1:], 0.3)
        smoothing.remove_loops(poses)
kernels = (connect_kernel.steer_free, reeds_shepp._solve, compiled.clearances_kernel, smoothing._loop_cut)
for kernel in kernels:
    assert isinstance(kernel, Dispatcher)
    print(kernel.py_func.__name__, len(kernel.signatures))
"""


def test_planning_kernels_compile_once_for_read_only_and_writable_inputs() -> None:
    """A fresh process (a kernel's compiled types are per process) plans, measures clearances, solves
    Reeds–Shepp words and cuts loops on a plan's read-only arrays, on copies and on lists: each kernel the
    Python side calls has one type, as it had before its input came from a value type."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", _CALLS], env=env, cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    counts = dict(line.split() for line in done.stdout.splitlines())
    assert counts == {"steer_free": "1", "_solve": "1", "clearances_kernel": "1", "_loop_cut": "1"}, counts


def test_the_localisers_noise_model_reaches_its_kernels_as_one_type_given_or_not() -> None:
    world = load_scenario("nav_map1").world
    robot = load_robot("turtlebot3")
    laser = np.zeros(3)
    plain = Amcl(world, AmclConfig(), laser, 0, clearance=robot.radius)
    noisy = Amcl(world, AmclConfig(), laser, 0, clearance=robot.radius, range_noise=(1.5, 0.01, 0.035, 0.05, 0.02))
    assert numba.typeof(plain._noise) == numba.typeof(noisy._noise) == numba.typeof(kernel_input([0.0]))


def test_kernel_input_copies_only_what_is_not_already_a_writable_contiguous_array() -> None:
    mine = np.arange(6.0).reshape(2, 3)
    assert kernel_input(mine) is mine
    frozen = mine.copy()
    frozen.flags.writeable = False
    for given in (frozen, mine[:, :2], mine.astype(np.float32), mine.tolist()):
        out = kernel_input(given)
        assert out.flags.writeable and out.flags.c_contiguous and out.dtype == np.float64
        assert np.array_equal(out, np.asarray(given, dtype=float)) and not np.shares_memory(out, mine)


_LOCALISER_CALLS = """
import mujoco
import numpy as np
from numba.core.dispatcher import Dispatcher

from control.estimation import amcl_kernels as K
from control.estimation.amcl import Amcl, AmclConfig
from planning.core.robot import load_robot
from planning.core.world import World
from sim.physics.model import build_model
from sim.physics.lidar import LidarProfile, LidarScanner

corridor, room = World((0.0, 12.0, 0.0, 1.2), ()), World((0.0, 3.0, 0.0, 2.5), ())
for world, truth in ((corridor, (6.0, 0.6, 0.02)), (room, (1.2, 1.0, 0.3))):
    model = build_model(load_robot("turtlebot3"), world).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lidar = LidarScanner(model, LidarProfile(), seed=0)
    scan = lidar.scan(data, 0.0, np.tile(truth, (360, 1)))
    amcl = Amcl(world, AmclConfig(), [*lidar.offset[:2], 0.0], seed=0)
    amcl.reset(np.add(truth, (0.1, 0.03, 0.02)), std_xy=0.1, std_theta=0.03)
    r, b = amcl.beams(scan.ranges, 0.12, 3.5, 0.0, scan.angle_increment, every=True)
    est = amcl._estimate(r, b, scan=(scan.ranges, scan.bearings, 0.12, 3.5))
    print("refined", int(est.refined))
for kernel in (K.refine, K.refine_within, K.resume, K.rays_through):
    assert isinstance(kernel, Dispatcher)
    print(kernel.py_func.__name__, len(kernel.signatures))
"""


def test_the_localisers_fits_compile_once_whole_or_within_a_corridors_directions() -> None:
    """A fresh process localises in a corridor (the fit within the directions the scan fixes) and in a room (the whole
    fit): each fitting kernel the Python side calls has one type. The whole fit's basis (a constant, read-only) and a
    corridor's (computed, writable) gave ``resume`` two."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-c", _LOCALISER_CALLS], env=env, cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.split("\n")
    assert lines.count("refined 1") == 2, done.stdout  # both fits ran: the corridor's within, the room's whole
    counts = dict(line.split() for line in lines if line and not line.startswith("refined"))
    assert counts == {"refine": "1", "refine_within": "1", "resume": "1", "rays_through": "1"}, counts
