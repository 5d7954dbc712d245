"""What a robot's footprint at a pose overlaps: the planners' own test of a start or goal (:func:`end_clearance`)
and, for messages, which wall or obstacle it overlaps and how far the pose must move (:func:`footprint_overlap`)."""

from __future__ import annotations

import numpy as np

from planning.core.geometry import Pose2D
from planning.core.robot import RobotSpec
from planning.core.world import World


def end_clearance(world: World, robot: RobotSpec, pose: Pose2D, *, walls: bool = True) -> float:
    """The clearance [m] of ``robot``'s footprint at ``pose`` from the obstacles and (with ``walls``) the walls
    of ``world``: the planners' own test of a start or goal (the footprint model of
    :class:`planning.collision.exact.CollisionChecker`, no margin). 0 or less is an overlap; -inf an obstacle
    with a point inside the footprint."""
    from planning.collision.exact import CollisionChecker  # imported here: compiled code, loaded on first use

    checker = CollisionChecker(world, robot, shape="footprint", walls=walls)
    return float(checker.clearance_of(pose.as_array()[None, :])[0])


def footprint_overlap(world: World, robot: RobotSpec, pose: Pose2D) -> tuple[float, str, float] | None:
    """What ``robot``'s footprint at ``pose`` overlaps the most: (the footprint's clearance from it [m], the wall
    or obstacle named, e.g. ``"the wall x = 3"`` or ``"the circle at x 2.7..3.3, y 1.2..1.8"``, how far the pose must
    move away from it [m]); None when the footprint is clear (by the planners' check, :func:`end_clearance`)."""
    return min(footprint_overlaps(world, robot, pose), key=lambda f: (f[0], -f[2]), default=None)


def footprint_overlaps(world: World, robot: RobotSpec, pose: Pose2D) -> list[tuple[float, str, float]]:
    """Everything ``robot``'s footprint at ``pose`` overlaps, each as :func:`footprint_overlap` gives the worst:
    the walls as one, then each obstacle; empty when the footprint is clear."""
    if float(world.signed_distance(pose.xy)[0]) > robot.radius or end_clearance(world, robot, pose) > 0:
        return []  # (the footprint lies within the robot's radius of its centre: clear when nothing is nearer)
    found: list[tuple[float, str, float]] = []
    walls = end_clearance(World(world.bounds), robot, pose)
    if walls <= 0:
        xs, ys = robot.footprint_at(pose.as_array()[None, :])[0].T
        xmin, xmax, ymin, ymax = world.bounds
        depth = {f"x = {xmin:g}": xmin - xs.min(), f"x = {xmax:g}": xs.max() - xmax}
        depth |= {f"y = {ymin:g}": ymin - ys.min(), f"y = {ymax:g}": ys.max() - ymax}
        order = sorted(depth, key=lambda k: -depth[k])
        hit = [k for k in order if depth[k] > 0] or order[:1]  # (touching, within the checker's tolerance)
        move = -walls if np.isfinite(walls) else max(depth.values())  # -inf: the whole footprint beyond a wall
        found.append((walls, f"the wall{'s' if len(hit) > 1 else ''} {' and '.join(hit)}", move))
    for ob in world.obstacles:
        centre = float(ob.signed_distance(pose.xy)[0])
        if centre > robot.radius:
            continue  # the footprint lies within the robot's radius of its centre
        clr = end_clearance(World(world.bounds, (ob,)), robot, pose, walls=False)
        if clr <= 0:
            bx0, bx1, by0, by1 = ob.bounding_box()
            what = f"the {ob.kind} at x {bx0:.3g}..{bx1:.3g}, y {by0:.3g}..{by1:.3g}"
            found.append((clr, what, -clr if np.isfinite(clr) else robot.radius - centre))
    return found
