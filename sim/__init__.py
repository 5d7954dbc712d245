"""Simulation layer of nhsim: MuJoCo models, the physics loop, metrics, rendering and the CLI.

Importing this package has no side effect. MuJoCo reads its OpenGL backend (``MUJOCO_GL``) when it is
first imported; choose it with :func:`sim.viz.gl.configure` before importing :mod:`sim.physics`
(the CLI does), or leave it to the renderer's headless default (see :mod:`sim.viz.gl`).
"""
