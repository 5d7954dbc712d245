"""Simulation layer of nhsim: MuJoCo models, the physics loop, the pipeline, drawing and the CLI.

The public names are re-exported here (rooms: ``physics``, ``pipeline``, ``viz``, ``tools``, ``cli``)::

    from sim import simulate_plan, write_video

    job = simulate_plan("edumip_map", planner="c-rrt-star", seed=0)
    print(job.metrics["closed_loop"].final_position_error_m)
    write_video(job, "renders/edumip_map.mp4")

Importing this package configures and loads nothing (each name loads on first use). MuJoCo reads
its OpenGL backend (``MUJOCO_GL``) when it is first imported; the renderer draws headless (OSMesa,
else EGL) whatever was chosen then, unless a backend was named that cannot draw here (see
:mod:`sim.viz.gl`; the CLI calls
:func:`sim.viz.gl.configure` with ``--gl``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from planning.kernel_cache import configure as _configure_kernel_cache
from planning.lazy import lazy_exports

_configure_kernel_cache()  # numba's cache directory, before any kernel is defined (planning.kernel_cache)

if TYPE_CHECKING:
    from sim.physics.metrics import TrackingMetrics as TrackingMetrics
    from sim.physics.metrics import compute_metrics as compute_metrics
    from sim.physics.perturb import Perturbation as Perturbation
    from sim.physics.runlog import RunLog as RunLog
    from sim.physics.simulator import SimConfig as SimConfig
    from sim.physics.simulator import Simulator as Simulator
    from sim.pipeline.case import Case as Case
    from sim.pipeline.case import PlanOptions as PlanOptions
    from sim.pipeline.case import prepare_trajectory as prepare_trajectory
    from sim.pipeline.runs import RunKind as RunKind
    from sim.pipeline.simulate import JobResult as JobResult
    from sim.pipeline.simulate import simulate as simulate
    from sim.pipeline.simulate import simulate_file as simulate_file
    from sim.pipeline.simulate import simulate_plan as simulate_plan
    from sim.pipeline.simulate import simulate_reference as simulate_reference
    from sim.pipeline.simulate import track as track
    from sim.viz.job_video import write_video as write_video
    from sim.viz.replay import RenderSettings as RenderSettings

#: Public name -> the module that defines it. Loaded on first use, so that ``import sim`` (and the
#: command line, which must choose MuJoCo's GL backend before MuJoCo loads) imports no MuJoCo.
_EXPORTS = {
    "TrackingMetrics": "sim.physics.metrics",
    "compute_metrics": "sim.physics.metrics",
    "Perturbation": "sim.physics.perturb",
    "RunLog": "sim.physics.runlog",
    "SimConfig": "sim.physics.simulator",
    "Simulator": "sim.physics.simulator",
    "Case": "sim.pipeline.case",
    "PlanOptions": "sim.pipeline.case",
    "prepare_trajectory": "sim.pipeline.case",
    "RunKind": "sim.pipeline.runs",
    "JobResult": "sim.pipeline.simulate",
    "simulate": "sim.pipeline.simulate",
    "simulate_file": "sim.pipeline.simulate",
    "simulate_plan": "sim.pipeline.simulate",
    "simulate_reference": "sim.pipeline.simulate",
    "track": "sim.pipeline.simulate",
    "write_video": "sim.viz.job_video",
    "RenderSettings": "sim.viz.replay",
}

__all__ = sorted(_EXPORTS)


def _choose_gl() -> None:
    """Choose MuJoCo's GL backend as the command line does (the headless default unless ``MUJOCO_GL`` says
    otherwise) before a public name imports MuJoCo: dm_control reads the choice when first imported, so a suite
    environment made after ``from sim import simulate_plan`` could not render headless (:mod:`sim.suite`)."""
    from sim.viz import gl

    if not gl.mujoco_imported():
        gl.configure(None)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals(), before=_choose_gl)
