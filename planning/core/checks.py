"""One check for the numbers a user gives (options, problem fields): type, finiteness and range, and one
for the flags (True or False), each with a ConfigError naming the field, what it must be and what it was."""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np

from planning.errors import ConfigError


def given(value: object, integer: bool = False) -> str:
    """``value`` as a message quotes what was given: its repr, and for a 0-d numpy array (``np.array(0.5)``,
    ``np.squeeze`` of one value) that it is one and how to pass it (``float(x)``, or ``int(x)`` for an
    ``integer`` field; no advice for one of bools or text, or a float for an integer field). Numbers are not
    read out of arrays: numpy scalars (what indexing, ``np.mean`` or ``np.linalg.norm`` give) are numbers, a
    0-d array is not."""
    if not (isinstance(value, np.ndarray) and value.ndim == 0):
        return repr(value)
    cast = "int" if integer else "float"
    fits = value.dtype.kind in ("iu" if integer else "iuf")
    return f"a 0-d numpy array ({value!r})" + (f"; pass {cast}(x)" if fits else "")


def check_number(
    where: str,
    value: object,
    *,
    above: float | None = None,
    at_least: float | None = None,
    at_most: float | None = None,
    integer: bool = False,
    optional: bool = False,
) -> float | int | None:
    """``value`` as a float (an int with ``integer``) when it is a finite number in range.

    Args:
        where: The field, as the message names it (e.g. ``"rrt: goal_bias"``).
        value: What was given. A bool is not a number, nor a 0-d numpy array (the message says to pass
            ``float(x)``: see :func:`given`); with ``integer`` a float is not accepted.
        above: Exclusive lower bound.
        at_least: Inclusive lower bound.
        at_most: Inclusive upper bound.
        integer: Require an integer.
        optional: Accept None (returned as None).

    Returns:
        The value (None only with ``optional``).

    Raises:
        ConfigError: Not a finite number (an integer with ``integer``), or out of range; the message
            names ``where``, the range and the value.
    """
    if value is None and optional:
        return None
    kind = numbers.Integral if integer else numbers.Real
    wanted = "an integer" if integer else "a finite number"
    if isinstance(value, bool) or not isinstance(value, kind) or not math.isfinite(value):
        raise ConfigError(f"{where} must be {wanted}{' (or omitted)' if optional else ''}, got {given(value, integer)}")
    number = int(value) if isinstance(value, numbers.Integral) else float(value)  # type: ignore[arg-type]
    bounds = [(above, ">", number > above if above is not None else True)]
    bounds += [(at_least, ">=", number >= at_least if at_least is not None else True)]
    bounds += [(at_most, "<=", number <= at_most if at_most is not None else True)]
    if not all(ok for _, _, ok in bounds):
        wanted_range = " and ".join(f"{op} {limit:g}" for limit, op, _ in bounds if limit is not None)
        raise ConfigError(f"{where} must be {wanted_range}, got {value!r}")
    return number if integer else float(number)


def check_flag(where: str, value: object) -> bool:
    """``value`` when it is True or False (a numpy bool too), as a bool.

    A flag is not read for its truth: the string ``"no"``, a number or None would pass ``if value``
    either way, silently.

    Raises:
        ConfigError: Anything else; the message names ``where`` and the value.
    """
    if isinstance(value, bool | np.bool_):
        return bool(value)
    raise ConfigError(f"{where} must be True or False, got {value!r}")


def check_fields(obj: object, limits: Mapping[str, Mapping[str, Any]], prefix: str = "") -> None:
    """Check the named fields of a frozen dataclass with :func:`check_number`; store the checked values.

    Args:
        obj: The dataclass instance (from its ``__post_init__``).
        limits: Field name -> keyword arguments of :func:`check_number` (``above``, ``integer``, ...).
        prefix: Put before the field's name in messages (e.g. ``"C-RRT*: "``).

    Raises:
        ConfigError: A field is not a finite number in its range (the message names it).
    """
    for name, kwargs in limits.items():
        object.__setattr__(obj, name, check_number(f"{prefix}{name}", getattr(obj, name), **kwargs))
