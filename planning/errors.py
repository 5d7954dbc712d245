"""The exception hierarchy shared by every layer of nhsim.

Every error a user can cause derives from :class:`NhsimError`; its message says what was wrong
and how to fix it (the bad field, the valid choices, the command that installs what is missing).
"""

from __future__ import annotations


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


class OutputExistsError(NhsimError, FileExistsError):
    """An output file exists already and overwriting was not requested."""


class DependencyError(NhsimError, ImportError):
    """An optional dependency or system library is missing."""
