"""The exception hierarchy shared by every layer of nhsim.

Every error a user can cause derives from :class:`NhsimError`; its message says what was wrong
and how to fix it (the bad field, the valid choices, the command that installs what is missing).
A message that names an option names it both ways, with :func:`option`: as the command line gives it
and as a Python caller sets it (``--localiser fixes (localiser="fixes" from Python)``).
"""

from __future__ import annotations

import re
import shlex
from typing import Any


class NhsimError(Exception):
    """Root of every error nhsim raises on purpose."""


class ConfigError(NhsimError, ValueError):
    """A parameter, gain set or option has an invalid value."""


class ScenarioError(ConfigError):
    """A scenario file is malformed or describes an impossible problem."""


class ModelError(NhsimError):
    """A robot model (MJCF) is missing, malformed, or lacks a required element."""


class SimulationError(NhsimError):
    """The physics engine reported a problem (a MuJoCo warning, a non-finite state)."""


class PlannerError(NhsimError):
    """A planner failed as code: it raised, or returned something that is not a plan result (a plugin's bug;
    the commands report it as a failed run, naming the planner)."""


class OutputExistsError(NhsimError, FileExistsError):
    """An output file exists already and overwriting was not requested."""


class DependencyError(NhsimError, ImportError):
    """An optional dependency or system library is missing."""


def option(flag: str, value: object = None, *, python: str | None = None) -> str:
    """An option as a message names it: as the command line gives it, then as a Python caller does.

    ``option("localiser", "fixes")`` -> ``--localiser fixes (localiser="fixes" from Python)``;
    ``option("overwrite", True)`` -> ``--overwrite (overwrite=True from Python)``;
    ``option("topic")`` -> ``--topic (topic=... from Python)``;
    ``option("path", python="timed=False")`` -> ``--path (timed=False from Python)``;
    ``option("gains", "9", python="resolve_gains({})")`` -> ``--gains 9 (resolve_gains("9") from Python)``.

    Args:
        flag: The command-line option without its dashes, e.g. ``"time-scale"``.
        value: Its value (True: a switch, which takes none); None: the option alone.
        python: What a Python caller sets instead, when it is not the flag's own keyword (its dashes as
            underscores): a keyword, a text where ``{}`` stands for the value, or a whole text.
    """
    return f"{_command_line(flag, value)} ({_python_form(flag, value, python)} from Python)"


def options(*given: str | tuple[Any, ...], conjunction: str = "and") -> str:
    """Several options in one phrase, each as :func:`option` takes it (a flag, or a tuple of its arguments):
    ``options("lidar", ("initial-pose", "unknown"))`` -> ``--lidar and --initial-pose unknown (lidar=...,
    initial_pose="unknown" from Python)``."""
    specs = [(g, None, None) if isinstance(g, str) else (*g, None, None)[:3] for g in given]
    flags = [_command_line(flag, value) for flag, value, _ in specs]
    said = ", ".join(flags[:-1]) + f" {conjunction} " + flags[-1] if len(flags) > 1 else flags[0]
    return f"{said} ({', '.join(_python_form(*spec) for spec in specs)} from Python)"


#: The Python form :func:`option` adds, with the space before it (one level of parentheses inside).
_PYTHON_FORM = re.compile(r" \((?:[^()]|\([^()]*\))* from Python\)")


def without_python(message: str) -> str:
    """``message`` without the Python forms :func:`option` adds: for a reader who sets the options under
    their command-line names (a regression suite's case table)."""
    return _PYTHON_FORM.sub("", message)


def _shown(value: object) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _command_line(flag: str, value: object) -> str:
    return f"--{flag}" if value is None or value is True else f"--{flag} {shlex.quote(_shown(value))}"


def _python_form(flag: str, value: object = None, python: str | None = None) -> str:
    form = python or flag.replace("-", "_")
    if value is None:
        literal = "..."
    elif isinstance(value, str):
        literal = f'"{value}"' if '"' not in value and "\\" not in value else repr(value)
    else:
        literal = _shown(value)
    if "{}" in form:
        return form.replace("{}", literal)
    return f"{form}={literal}" if form.isidentifier() else form
