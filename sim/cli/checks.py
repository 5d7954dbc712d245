"""Checks of the options several commands share: each names the flag and the fix (exit 2)."""

from __future__ import annotations

import math

from planning.errors import ConfigError


def check_time_limit(seconds: float) -> None:
    """Raise :class:`ConfigError` unless the ``--time-limit`` planning budget [s] is a finite number > 0."""
    if not (seconds > 0 and math.isfinite(seconds)):
        raise ConfigError(
            f"--time-limit must be a finite planning budget > 0 s, got {seconds:g}; pass e.g. --time-limit 30"
        )


def check_seeds(**flags: int | None) -> None:
    """Raise :class:`ConfigError` unless every seed given (``flag_name=value``, ``None`` for one not given)
    is >= 0, naming the flag: ``check_seeds(seed=args.seed)`` checks ``--seed``."""
    for name, value in flags.items():
        if value is not None and value < 0:
            flag = "--" + name.replace("_", "-")
            raise ConfigError(f"{flag} must be a whole number >= 0, got {value}; pass e.g. {flag} 0")


def check_at_least(counts: dict[str, tuple[int, int]]) -> None:
    """Raise :class:`ConfigError` naming the first flag whose count is below its least value:
    ``counts`` maps a flag (``"--repeats"``) to ``(value, least)``."""
    for flag, (value, least) in counts.items():
        if value < least:
            raise ConfigError(f"{flag} must be >= {least}, got {value}")


def check_control_rate(hz: float) -> None:
    """Raise :class:`ConfigError` unless ``--control-rate`` [Hz] is a finite number > 0 (whether it divides
    the physics rate is the simulator's check)."""
    if not (hz > 0 and math.isfinite(hz)):
        raise ConfigError(f"--control-rate must be a finite number of Hz > 0, got {hz:g}; pass e.g. --control-rate 50")
