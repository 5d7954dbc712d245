"""CasADi's solvers from two threads: the 'optim' planner and the 'mpc' tracker keep theirs for the process, and
two threads using them at once crashed the interpreter ("Solver ipopt is already in use", then a heap corruption,
or NaNs in the solve). They run in a fresh interpreter, so that a crash fails the test, not the test run."""

from __future__ import annotations

import subprocess
import sys

SCRIPT = """
import threading
import numpy as np
from control import make_tracker
from planning import PlanProblem, load_robot, load_scenario, make_planner
from planning.core.geometry import Pose2D
from planning.trajectory.references import make_reference

problem = PlanProblem.from_scenario(load_scenario("simple_motion"), seed=0, time_limit=30)
robot = load_robot("turtlebot3")
reference = make_reference("circle", robot, Pose2D(0.0, 0.0, 0.0))

def track():
    tracker = make_tracker("mpc", robot)
    tracker.reset(reference, 0.02)
    pose = reference.pose[0] + np.array([0.05, -0.03, 0.1])
    return [tracker.command(float(t), *map(float, pose)) for t in reference.t[:40:2]]

serial = (make_planner("optim").plan(problem), track())
out = [None] * 4
def run(i):
    out[i] = make_planner("optim").plan(problem) if i % 2 == 0 else track()
threads = [threading.Thread(target=run, args=(i,)) for i in range(4)]
for t in threads:
    t.start()
for t in threads:
    t.join()
same_plans = all(np.array_equal(out[i].path, serial[0].path) for i in (0, 2))
same_commands = all(np.array_equal(np.array(out[i]), np.array(serial[1])) for i in (1, 3))
print("SAME", str(serial[0].status), same_plans, same_commands)
"""


def test_optim_and_mpc_in_two_threads_give_the_serial_answers() -> None:
    run = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.splitlines()[-1] == "SAME success True True", run.stdout + run.stderr[-2000:]
