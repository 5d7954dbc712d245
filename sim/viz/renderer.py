"""The process's one OpenGL renderer: a :class:`mujoco.Renderer` made with the GL backend in force.

:mod:`sim.viz.gl` decides the backend; :class:`SceneRenderer` asks it which backend can draw now
(:func:`sim.viz.gl.render_backend`), so a MuJoCo imported without a usable one (GLFW without a
display by default, or disabled) either gets the headless default or raises one
:class:`DependencyError` saying what to install or call. The renderer is closed explicitly.
"""

from __future__ import annotations

import copy
import warnings
from typing import ClassVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from planning.errors import ConfigError, DependencyError
from sim.viz import gl
from sim.viz.scene import Frame

QUALITIES = ("fast", "high")

#: Stacks of a sphere, capsule or ellipsoid in the fast look (MuJoCo's default 16).
FAST_STACKS = 8


class SceneRenderer:
    """The process's one OpenGL renderer (a :class:`mujoco.Renderer`), closed explicitly.

    Args:
        model: The model to draw (its off-screen buffer is enlarged on a copy if too small).
        width: Image width [px].
        height: Image height [px].
        quality: "fast" (no shadows, reflections or multisampling, spheres in
            :data:`FAST_STACKS` stacks) or "high" (shadows, reflections and the model's
            multisampling and tessellation).
        max_geom: Capacity of the scene (model geoms plus decorations).

    Attributes:
        backend: The GL backend of its context ("osmesa", "egl", "glfw", ...).

    Raises:
        DependencyError: No OpenGL context can be created (no library, or mujoco was imported with
            a backend that cannot draw here); the message says what to install or to call.
        RuntimeError: Another renderer is open in this process.
    """

    _open: ClassVar[int] = 0

    def __init__(
        self, model: mujoco.MjModel, width: int, height: int, *, quality: str = "fast", max_geom: int = 10000
    ) -> None:
        if SceneRenderer._open:
            raise RuntimeError("one renderer per process: close the open SceneRenderer before opening another")
        if quality not in QUALITIES:
            raise ConfigError(f"unknown quality {quality!r}: choose one of {', '.join(QUALITIES)}")
        backend = gl.render_backend()
        high = quality == "high"
        model = copy.deepcopy(model)  # the caller's model is left as it is
        model.vis.global_.offwidth = max(width, model.vis.global_.offwidth)
        model.vis.global_.offheight = max(height, model.vis.global_.offheight)
        if high:
            # with shadows MuJoCo adds each light in its own pass: the scenes' headlight + sun,
            # balanced for the plain look, saturate the floor to white; dim them
            model.vis.headlight.diffuse[:] = 0.35 * model.vis.headlight.diffuse
            model.light_diffuse[:] = 0.6 * model.light_diffuse
        else:
            # multisampling doubles the cost of a frame under OSMesa; the fast look goes without
            model.vis.quality.offsamples = 0
            # spheres (the robots' casters, a few pixels wide) in fewer stacks: the ghosts' passes draw
            # each one up to four times a frame (translucent: back and front, in colour and white)
            model.vis.quality.numstacks = min(model.vis.quality.numstacks, FAST_STACKS)
        self.model = model
        try:
            with gl.contexts_for(backend), warnings.catch_warnings():
                # GLFW warns of a display it cannot open, with Python's file and line, before the error says so
                warnings.filterwarnings("ignore", module="glfw")
                self.renderer = mujoco.Renderer(model, height=height, width=width, max_geom=max_geom)
        except Exception as exc:  # the GL libraries raise many types: ImportError, OSError, FatalError ...
            raise DependencyError(gl.unavailable_message(backend, exc)) from exc
        SceneRenderer._open += 1
        self._closed = False
        flags = self.renderer.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = high
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = high
        self.width = width
        self.height = height
        self.backend = backend

    @property
    def scene(self) -> mujoco.MjvScene:
        """The scene drawn by :meth:`render`."""
        return self.renderer.scene

    def render(self, out: Frame | None = None) -> Frame:
        """Draw the scene into ``out`` ((height, width, 3) uint8) or a new array."""
        return self.renderer.render(out=out)

    def draw(
        self, scene: mujoco.MjvScene, size: tuple[int, int] | None = None, origin: tuple[int, int] = (0, 0)
    ) -> None:
        """Draw ``scene`` (any scene of this model) into the off-screen buffer; read it with :meth:`read`.

        Args:
            scene: The scene.
            size: (width, height) [px] of the viewport (the frustum fills it; MuJoCo clears only it);
                None for the whole image.
            origin: (x, y) [px] of the viewport's bottom-left corner in the buffer (OpenGL: y up).
        """
        r = self.renderer
        if r._gl_context:
            r._gl_context.make_current()
        viewport = r._rect if size is None else mujoco.MjrRect(origin[0], origin[1], size[0], size[1])
        mujoco.mjr_render(viewport, scene, r._mjr_context)

    def read(self, rect: tuple[int, int, int, int], rgb: Frame | None, depth: NDArray[np.float32] | None) -> None:
        """Read a rectangle of the last :meth:`draw` into contiguous arrays, row 0 at the top.

        Args:
            rect: (x0, y0, x1, y1) [px] in image coordinates (y down), end exclusive.
            rgb: (y1 - y0, x1 - x0, 3) uint8 colour, or None.
            depth: (y1 - y0, x1 - x0) float32 depth (0 far, 1 near), or None.
        """
        x0, y0, x1, y1 = rect
        viewport = mujoco.MjrRect(x0, self.height - y1, x1 - x0, y1 - y0)  # OpenGL: origin bottom left
        mujoco.mjr_readPixels(rgb, depth, viewport, self.renderer._mjr_context)
        for a in (rgb, depth):
            if a is not None:
                a[:] = a[::-1].copy()

    def close(self) -> None:
        """Free the OpenGL context (idempotent)."""
        if not self._closed:
            self.renderer.close()
            self._closed = True
            SceneRenderer._open -= 1

    def __enter__(self) -> SceneRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def probe_renderer() -> str | None:
    """None when an OpenGL context can be created here, else the reason (with what to install)."""
    m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom type="plane" size="1 1 .1"/></worldbody></mujoco>')
    try:
        with SceneRenderer(m, 16, 16):
            return None
    except DependencyError as exc:
        return str(exc)
