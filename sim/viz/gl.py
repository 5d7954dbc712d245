"""The one place that chooses MuJoCo's OpenGL backend (``MUJOCO_GL``).

MuJoCo reads ``MUJOCO_GL`` when it is imported, so this module must run first: ``sim/__init__``
imports it before anything imports ``mujoco``, and the CLI calls :func:`configure` with the user's
``--gl`` choice before it imports the simulator or the renderer.

Without a display the default is OSMesa (Debian's ``libosmesa6``), else EGL (Mesa's llvmpipe runs
without a GPU), else rendering is disabled: physics still runs and the renderer raises one
:class:`DependencyError` that says what to install.
"""

from __future__ import annotations

import ctypes.util
import os
import sys

from planning.errors import ConfigError, DependencyError

BACKENDS = ("osmesa", "egl", "glfw")

#: Backend -> what makes it loadable, for error messages.
INSTALL_HINTS = {
    "osmesa": "install Mesa's off-screen library: apt-get install libosmesa6",
    "egl": "install EGL with Mesa's drivers: apt-get install libegl1 libgl1-mesa-dri",
    "glfw": "run under a display (set DISPLAY) or choose a headless backend with --gl osmesa or --gl egl",
}

#: MUJOCO_GL value used when no backend can load: MuJoCo imports without GL, physics runs.
DISABLED = "disable"


def osmesa_available() -> bool:
    """Whether the OSMesa library (Debian's libosmesa6) can be found."""
    return ctypes.util.find_library("OSMesa") is not None


def egl_available() -> bool:
    """Whether an EGL library (libEGL) can be found."""
    return ctypes.util.find_library("EGL") is not None


def display_available() -> bool:
    """Whether a window system is there for GLFW (always assumed off Linux)."""
    return not sys.platform.startswith("linux") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def backend_missing(backend: str) -> str | None:
    """Why ``backend`` cannot load on this machine (with the fix), or None when it may."""
    present = {"osmesa": osmesa_available, "egl": egl_available, "glfw": display_available}[backend]()
    if present:
        return None
    what = {"osmesa": "libOSMesa was not found", "egl": "libEGL was not found", "glfw": "there is no display"}
    return f"GL backend {backend!r} cannot load: {what[backend]}; {INSTALL_HINTS[backend]}"


def default_backend() -> str:
    """glfw with a display, else osmesa where installed, else egl, else "disable" (no rendering)."""
    if sys.platform.startswith("linux") and not display_available():
        if osmesa_available():
            return "osmesa"
        return "egl" if egl_available() else DISABLED
    return "glfw"


def mujoco_imported() -> bool:
    """Whether ``mujoco`` has been imported in this process already."""
    return "mujoco" in sys.modules


def current_backend() -> str:
    """The ``MUJOCO_GL`` value in force (after :func:`configure`)."""
    return os.environ.get("MUJOCO_GL", "") or default_backend()


def configure(backend: str | None = None) -> str:
    """Set ``MUJOCO_GL`` (and PyOpenGL's platform) before MuJoCo is imported.

    Args:
        backend: "osmesa", "egl", "glfw", or None for the user's environment or the default.

    Returns:
        The backend in force.

    Raises:
        ConfigError: Unknown backend name, or a different backend was asked for after MuJoCo was
            imported (MuJoCo reads the choice once).
        DependencyError: The requested backend's library (or display) is missing; the message
            names what to install.
    """
    if backend is not None and backend not in BACKENDS:
        raise ConfigError(f"unknown GL backend {backend!r}: choose one of {', '.join(BACKENDS)}")
    if backend is not None:
        reason = backend_missing(backend)
        if reason is not None:
            raise DependencyError(reason)
        if mujoco_imported() and os.environ.get("MUJOCO_GL") != backend:
            raise ConfigError(
                f"GL backend {backend!r} requested after mujoco was imported with MUJOCO_GL="
                f"{os.environ.get('MUJOCO_GL')!r}; choose the backend before importing mujoco (or set MUJOCO_GL)"
            )
    chosen = backend or os.environ.get("MUJOCO_GL") or default_backend()
    if backend is not None or "MUJOCO_GL" not in os.environ:
        if not mujoco_imported():
            os.environ["MUJOCO_GL"] = chosen
            if chosen in ("osmesa", "egl"):
                os.environ["PYOPENGL_PLATFORM"] = chosen
    return os.environ.get("MUJOCO_GL", chosen)


def unavailable_message(backend: str, error: BaseException | None = None) -> str:
    """The one message shown when no OpenGL context can be created.

    Args:
        backend: The ``MUJOCO_GL`` value in force.
        error: What creating the context raised, if anything.
    """
    cause = f" ({type(error).__name__}: {error})" if error is not None else ""
    if backend == DISABLED:
        head = "no OpenGL backend can load on this machine (neither libOSMesa nor libEGL was found, no display)"
    else:
        head = f"cannot create an OpenGL context with MUJOCO_GL={backend}{cause}"
    return (
        f"{head}; {INSTALL_HINTS['osmesa']} (or, for --gl egl, {INSTALL_HINTS['egl'].split(': ')[1]}), "
        "or pass --no-video to skip the video"
    )
