"""Simulation layer of nhsim: MuJoCo models, the physics loop, metrics, rendering and the CLI.

Importing this package chooses MuJoCo's GL backend first (see :mod:`sim.viz.gl`).
"""

from sim.viz import gl as _gl

_gl.configure()
