"""Every nhsim scenario as a dm_control environment, with nhsim's own stack as its reference policy.

::

    from sim import suite

    env = suite.load("edumip_map", "edumip", "c-rrt-star", seed=0)
    policy = suite.reference_policy(env)
    timestep = env.reset()
    while not timestep.last():
        timestep = env.step(policy(timestep))

:func:`load` returns a :class:`dm_control.rl.control.Environment` (see :mod:`sim.suite.env` for the
specs, the reward and when an episode ends); :data:`ALL` lists the (scenario, robot, source) cases
``nhsim simulate --all`` runs; :func:`reference_policy` is the estimator and tracker that
``nhsim simulate`` runs in closed loop, fed from the environment's observations.

dm_control chooses its OpenGL backend when it is first imported: unless ``MUJOCO_GL`` is set (or
MuJoCo was imported already), the first name loaded from here chooses the headless default as the
command line does (:func:`sim.viz.gl.configure`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from sim.suite.cases import NotApplicableError as NotApplicableError
    from sim.suite.cases import load as load
    from sim.suite.policy import EpisodeResult as EpisodeResult
    from sim.suite.policy import ReferencePolicy as ReferencePolicy
    from sim.suite.policy import reference_policy as reference_policy
    from sim.suite.policy import run_episode as run_episode

_EXPORTS = {
    "NotApplicableError": "sim.suite.cases",
    "load": "sim.suite.cases",
    "EpisodeResult": "sim.suite.policy",
    "ReferencePolicy": "sim.suite.policy",
    "reference_policy": "sim.suite.policy",
    "run_episode": "sim.suite.policy",
}


def __getattr__(name: str) -> Any:
    """Load a public name (and ``ALL``, the sweep's cases) on first use."""
    from sim.viz import gl

    if not gl.mujoco_imported():  # dm_control picks its rendering backend when first imported
        gl.configure(None)
    if name == "ALL":
        from sim.suite.cases import all_cases

        return all_cases()
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'sim.suite' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*_EXPORTS, "ALL"])
