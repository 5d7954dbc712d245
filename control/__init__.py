"""Control layer of nhsim: trackers, drive mappings and gain sets.

Pure numerics; knows trajectories and kinematics (``planning``), never MuJoCo. The public names are
re-exported here, so ``from control import make_tracker, FBLGains`` is all a user needs::

    tracker = make_tracker("fbl", robot, gains=FBLGains(kp=9.0, kd=6.0))
    tracker.reset(trajectory, dt=0.02)
    v, omega = tracker.command(t, x, y, theta)

Importing this package imports none of its modules: each public name loads its module on first use,
so that a command loads only what it runs (``nhsim --version`` loads no numerics).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from planning.kernel_cache import configure as _configure_kernel_cache
from planning.lazy import lazy_exports

_configure_kernel_cache()  # numba's cache directory, before any kernel is defined (planning.kernel_cache)

if TYPE_CHECKING:
    from control.base import TRACKERS as TRACKERS
    from control.base import Tracker as Tracker
    from control.base import feedback_trackers as feedback_trackers
    from control.base import make_tracker as make_tracker
    from control.base import register_tracker as register_tracker
    from control.base import tracker_options as tracker_options
    from control.diffdrive import DiffDrive as DiffDrive
    from control.fbl import DynamicFBL as DynamicFBL
    from control.gains import FBLGains as FBLGains
    from control.gains import GainsFile as GainsFile
    from control.gains import load_gains_file as load_gains_file
    from control.gains import resolve_gains as resolve_gains
    from control.open_loop import OpenLoop as OpenLoop
    from control.segmented import SegmentedParams as SegmentedParams
    from control.segmented import SegmentedTracker as SegmentedTracker
    from control.switching import PerSegmentTracker as PerSegmentTracker

#: Public name -> the module that defines it (loaded on first use).
_EXPORTS = {
    "TRACKERS": "control.base",
    "Tracker": "control.base",
    "feedback_trackers": "control.base",
    "make_tracker": "control.base",
    "register_tracker": "control.base",
    "tracker_options": "control.base",
    "DiffDrive": "control.diffdrive",
    "DynamicFBL": "control.fbl",
    "FBLGains": "control.gains",
    "GainsFile": "control.gains",
    "load_gains_file": "control.gains",
    "resolve_gains": "control.gains",
    "OpenLoop": "control.open_loop",
    "SegmentedParams": "control.segmented",
    "SegmentedTracker": "control.segmented",
    "PerSegmentTracker": "control.switching",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
