"""The one place that chooses MuJoCo's OpenGL backend (``MUJOCO_GL``).

MuJoCo reads ``MUJOCO_GL`` when it is imported, so this module must run first: ``sim/__init__``
imports it before anything imports ``mujoco``, and the CLI calls :func:`configure` with the user's
``--gl`` choice before it imports the simulator or the renderer.
"""

from __future__ import annotations

import ctypes.util
import os
import sys

BACKENDS = ("osmesa", "egl", "glfw")


def osmesa_available() -> bool:
    """Whether the OSMesa library (Debian's libosmesa6) can be found."""
    return ctypes.util.find_library("OSMesa") is not None


def default_backend() -> str:
    """glfw with a display, else osmesa where installed, else egl (Mesa's llvmpipe without a GPU)."""
    if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        return "osmesa" if osmesa_available() else "egl"
    return "glfw"


def mujoco_imported() -> bool:
    """Whether ``mujoco`` has been imported in this process already."""
    return "mujoco" in sys.modules


def configure(backend: str | None = None) -> str:
    """Set ``MUJOCO_GL`` (and PyOpenGL's platform) before MuJoCo is imported.

    Args:
        backend: "osmesa", "egl", "glfw", or None for the user's environment or the default.

    Returns:
        The backend in force.

    Raises:
        ValueError: Unknown backend name.
    """
    if backend is not None and backend not in BACKENDS:
        raise ValueError(f"unknown GL backend {backend!r}: choose one of {', '.join(BACKENDS)}")
    chosen = backend or os.environ.get("MUJOCO_GL") or default_backend()
    if backend is not None or "MUJOCO_GL" not in os.environ:
        if not mujoco_imported():
            os.environ["MUJOCO_GL"] = chosen
            if chosen in ("osmesa", "egl"):
                os.environ["PYOPENGL_PLATFORM"] = chosen
    return os.environ.get("MUJOCO_GL", chosen)
