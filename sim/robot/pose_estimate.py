"""How the scan localiser starts (``--initial-pose``): at the start pose, by global localisation, or at a pose
estimate ``X,Y,THETA`` (a ROS user's "2D Pose Estimate"). Plain parsing and checks, no MuJoCo: the CLI converts
the option while it parses its arguments, before the GL back end is chosen."""

from __future__ import annotations

import math

import numpy as np

from planning.core.world import World
from planning.errors import ConfigError, option

#: How the localiser starts (``--initial-pose``): at the start pose, or globally; or (any other value) at a pose
#: estimate ``X,Y,THETA`` (:func:`parse_initial_pose`).
INITIAL_POSES = ("known", "unknown")
#: An ``--initial-pose`` given as a pose estimate, quoted in messages.
POSE_EXAMPLE = "1.2,0.5,0.3"


def parse_initial_pose(text: str) -> tuple[float, float, float]:
    """A pose estimate ``X,Y,THETA`` [m, m, rad] (``--initial-pose``).

    Raises:
        ConfigError: Not three finite numbers, or a heading beyond +-4 pi as a scenario's pose refuses it
            (:func:`planning.core.checks.heading_beyond`: a typo or degrees), naming the option and an example.
    """
    from planning.core.checks import heading_beyond

    parts = [p.strip() for p in text.split(",")]
    fix = f"give X,Y,THETA in metres and radians, e.g. {option('initial-pose', POSE_EXAMPLE)}, or known or unknown"
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ConfigError(f"{option('initial-pose', text)}: not three numbers; {fix}") from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{option('initial-pose', text)}: expected three finite numbers; {fix}")
    beyond = heading_beyond(values[2])
    if beyond:
        raise ConfigError(f"{option('initial-pose', text)}: THETA is {beyond}; {fix}")
    return values[0], values[1], values[2]


def check_initial_pose(pose: tuple[float, float, float], world: World, text: str) -> None:
    """A pose estimate must lie inside the world's walls and outside its obstacles (a belief no robot could hold).

    Raises:
        ConfigError: Outside the walls or inside an obstacle, naming where and the fix.
    """
    xmin, xmax, ymin, ymax = world.bounds
    where = option("initial-pose", text)
    if not (xmin < pose[0] < xmax and ymin < pose[1] < ymax):
        raise ConfigError(
            f"{where}: ({pose[0]:g}, {pose[1]:g}) is outside the world's walls (x {xmin:g} to {xmax:g}, y {ymin:g} "
            f"to {ymax:g} m); give a position inside them"
        )
    if world.obstacles and float(world.obstacle_distance(np.array([pose[:2]]))[0]) <= 0.0:
        raise ConfigError(
            f"{where}: ({pose[0]:g}, {pose[1]:g}) is inside an obstacle of the map; give a position in free space"
        )
