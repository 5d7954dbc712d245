"""The one place that chooses MuJoCo's OpenGL backend (``MUJOCO_GL``).

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, and takes from it the class of
every OpenGL context it makes (``mujoco/rendering/classic/gl_context.py``: ``osmesa``, ``egl``, else
GLFW, which needs a display). Importing nhsim changes nothing; the choice is made explicitly:

- the CLI calls :func:`configure` with the user's ``--gl`` (or None) before it imports anything that
  imports mujoco; the tests call it once, in ``tests/conftest.py``;
- a library user may call :func:`configure` (or set ``MUJOCO_GL``) before importing
  :mod:`sim.physics` or :mod:`sim.viz.replay`;
- one who does neither still gets renders: mujoco then picks GLFW, which cannot open a context
  without a display, so the renderer (:class:`sim.viz.renderer.SceneRenderer`) makes its context
  with the headless default instead (:func:`render_backend`, :func:`contexts_for`: mujoco's own
  OSMesa or EGL context class, lent to ``mujoco.Renderer`` for its construction only).

Without a display the default is OSMesa (Debian's ``libosmesa6``), else EGL (Mesa's llvmpipe runs
without a GPU), else rendering is disabled: physics still runs and the renderer raises one
:class:`DependencyError` that says what to install. A backend asked for by name (``--gl``,
``MUJOCO_GL``) that cannot draw here is the same one error, never silently replaced.
"""

from __future__ import annotations

import contextlib
import ctypes.util
import importlib
import os
import sys
from collections.abc import Iterator
from types import ModuleType

from planning.errors import ConfigError, DependencyError, option, options

BACKENDS = ("osmesa", "egl", "glfw")

#: How a Python caller chooses a backend (the command line's ``--gl``), in messages.
_CONFIGURE = "sim.viz.gl.configure({})"
#: Backend -> what makes it loadable, for error messages.
INSTALL_HINTS = {
    "osmesa": "install Mesa's off-screen library: apt-get install libosmesa6",
    "egl": "install EGL with Mesa's drivers: apt-get install libegl1 libgl1-mesa-dri",
    "glfw": "run under a display (set DISPLAY) or choose a headless backend with "
    + options(("gl", "osmesa", _CONFIGURE), ("gl", "egl", _CONFIGURE), conjunction="or"),
}

#: How a Python caller skips the video (the command line's ``--no-video``), in messages.
_NO_VIDEO = "no write_video call"
#: MUJOCO_GL value used when no backend can load: MuJoCo imports without GL, physics runs.
DISABLED = "disable"

#: What to do when mujoco was imported with a backend that cannot draw (library users).
CONFIGURE_HINT = (
    "set MUJOCO_GL=osmesa (or call sim.viz.gl.configure('osmesa')) before anything imports mujoco, e.g. sim.physics"
)


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


#: The MUJOCO_GL values mujoco accepts (``mujoco/rendering/classic/gl_context.py``, as it reads them: lower case,
#: stripped): its backends, and the words that enable (GLFW) or disable rendering.
MUJOCO_GL_VALUES = (
    *BACKENDS,
    "glx",
    "",
    "enable",
    "enabled",
    "on",
    "true",
    "1",
    DISABLED,
    "disabled",
    "off",
    "false",
    "0",
)


def check_environment() -> None:
    """Refuse a ``MUJOCO_GL`` that mujoco's import would fail on (with a RuntimeError and no fix), before
    anything imports it.

    Raises:
        ConfigError: ``MUJOCO_GL`` is set to a value mujoco does not know; the message names the valid ones.
    """
    value = os.environ.get("MUJOCO_GL")
    if value is None or value.strip().lower() in MUJOCO_GL_VALUES or not sys.platform.startswith("linux"):
        return
    choose = options(("gl", "osmesa", _CONFIGURE), ("gl", "egl", _CONFIGURE), conjunction="or")
    raise ConfigError(
        f"environment variable MUJOCO_GL={value!r} is not a GL backend mujoco knows: set it to one of "
        f"{', '.join(BACKENDS)} ({DISABLED} for no rendering), or unset it for nhsim's default, or choose with {choose}"
    )


def mujoco_imported() -> bool:
    """Whether ``mujoco`` has been imported in this process already."""
    return "mujoco" in sys.modules


def configure(backend: str | None = None) -> str:
    """Set ``MUJOCO_GL`` (and PyOpenGL's platform) before MuJoCo is imported.

    Args:
        backend: "osmesa", "egl", "glfw", or None for the user's environment or the default.

    Returns:
        The backend in force (see :func:`current_backend`).

    Raises:
        ConfigError: Unknown backend name, a ``MUJOCO_GL`` mujoco would refuse (:func:`check_environment`;
            a backend named here replaces it), or a different backend was asked for after MuJoCo was
            imported (MuJoCo reads the choice once).
        DependencyError: The requested backend's library (or display) is missing; the message
            names what to install.
    """
    if backend is not None and backend not in BACKENDS:
        raise ConfigError(f"unknown GL backend {backend!r}: choose one of {', '.join(BACKENDS)}")
    if backend is None and not mujoco_imported():
        check_environment()
    if backend is not None:
        reason = backend_missing(backend)
        if reason is not None:
            raise DependencyError(reason)
        if mujoco_imported() and os.environ.get("MUJOCO_GL") != backend:
            raise ConfigError(
                f"GL backend {backend!r} requested after mujoco was imported with MUJOCO_GL="
                f"{os.environ.get('MUJOCO_GL')!r}; choose the backend before importing mujoco (or set MUJOCO_GL)"
            )
    if mujoco_imported():
        return current_backend()
    chosen = backend or os.environ.get("MUJOCO_GL") or default_backend()
    if backend is not None or "MUJOCO_GL" not in os.environ:
        os.environ["MUJOCO_GL"] = chosen
        if chosen in ("osmesa", "egl"):
            os.environ["PYOPENGL_PLATFORM"] = chosen
    return chosen


def _context_module() -> ModuleType | None:
    """The module whose ``GLContext`` :class:`mujoco.Renderer` instantiates; None before mujoco is imported."""
    renderer = getattr(sys.modules.get("mujoco"), "Renderer", None)
    if renderer is None:
        return None
    module = getattr(sys.modules.get(renderer.__module__), "gl_context", None)
    return module if isinstance(module, ModuleType) else None


def loaded_backend() -> str | None:
    """The backend of the OpenGL contexts the imported mujoco makes ("osmesa", "egl", "glfw", ...),
    :data:`DISABLED` when it makes none, None before mujoco is imported."""
    module = _context_module()
    if module is None:
        return None
    context_class = getattr(module, "GLContext", None)
    return DISABLED if context_class is None else str(context_class.__module__).rsplit(".", 1)[-1]


def _resolve() -> tuple[str, str | None]:
    """(backend a renderer made now uses, why it cannot draw or None)."""
    requested = os.environ.get("MUJOCO_GL", "").strip().lower()
    loaded = loaded_backend()
    if loaded is None:  # mujoco is not imported yet: the choice configure() makes
        chosen = requested or default_backend()
        return chosen, unavailable_message(DISABLED) if chosen == DISABLED else None
    if loaded == "glfw" and not display_available():
        if requested == "glfw":  # asked for by name: not replaced
            return loaded, f"{backend_missing('glfw')}; or {CONFIGURE_HINT}"
        fallback = default_backend()  # mujoco's default without a display: draw headless instead
        return fallback, unavailable_message(DISABLED) if fallback == DISABLED else None
    if loaded == DISABLED:
        if default_backend() == DISABLED:
            return DISABLED, unavailable_message(DISABLED)
        why = "rendering disabled" if requested in ("", DISABLED) else "its OpenGL context could not load"
        return DISABLED, f"mujoco was imported with MUJOCO_GL={requested or 'unset'} ({why}); {CONFIGURE_HINT}"
    return loaded, None


def current_backend() -> str:
    """The backend a renderer made now uses (``MUJOCO_GL`` or the default before mujoco is imported;
    after, mujoco's choice or, for GLFW without a display by default, the headless default)."""
    return _resolve()[0]


def render_backend() -> str:
    """The backend a renderer made now uses (see :func:`current_backend`).

    Raises:
        DependencyError: None can draw here: no library, or mujoco was imported with a backend that
            cannot (disabled, asked-for GLFW without a display); the message says what to install
            or to call.
    """
    backend, problem = _resolve()
    if problem is not None:
        raise DependencyError(problem)
    return backend


@contextlib.contextmanager
def contexts_for(backend: str) -> Iterator[None]:
    """Within: :class:`mujoco.Renderer` makes its OpenGL context with ``backend``.

    When ``backend`` differs from what mujoco chose at import (GLFW by default, without a display),
    mujoco's own context class for ``backend`` (``mujoco.osmesa`` or ``mujoco.egl``) is lent to the
    renderer for its construction; mujoco's choice is restored on exit. The context lives with the
    renderer that made it.

    Raises:
        ImportError: The backend's context class cannot load (callers report it as a
            :class:`DependencyError`).
    """
    module = _context_module()
    if module is None or loaded_backend() == backend:
        yield
        return
    context_class = importlib.import_module(f"mujoco.{backend}").GLContext
    missing = object()
    saved = module.__dict__.get("GLContext", missing)
    module.GLContext = context_class  # type: ignore[attr-defined]
    try:
        yield
    finally:
        if saved is missing:
            del module.GLContext
        else:
            module.GLContext = saved  # type: ignore[attr-defined]


def unavailable_message(backend: str, error: BaseException | None = None) -> str:
    """The one message shown when no OpenGL context can be created.

    Args:
        backend: The backend in force (:func:`current_backend`).
        error: What creating the context raised, if anything.
    """
    cause = f" ({type(error).__name__}: {error})" if error is not None else ""
    if backend == DISABLED:
        head = "no OpenGL backend can load on this machine (neither libOSMesa nor libEGL was found, no display)"
    else:
        head = f"cannot create an OpenGL context with the {backend} backend{cause}"
    headless = [b for b in ("osmesa", "egl") if backend_missing(b) is None]
    if backend in ("glfw", "glx") and headless:  # a display that cannot be opened (a stale DISPLAY over ssh)
        choose = options(*(("gl", b, _CONFIGURE) for b in headless), conjunction="or")
        return (
            f"{head}: the display ({os.environ.get('DISPLAY') or os.environ.get('WAYLAND_DISPLAY') or 'none'}) "
            f"cannot be used; render without it: {choose}, or skip the video: "
            f"{option('no-video', True, python=_NO_VIDEO)}"
        )
    return (
        f"{head}; {INSTALL_HINTS['osmesa']} (or, for {option('gl', 'egl', python=_CONFIGURE)}, "
        f"{INSTALL_HINTS['egl'].split(': ')[1]}), or skip the video: {option('no-video', True, python=_NO_VIDEO)}"
    )
