"""One check for the numbers a user gives (options, problem fields): type, finiteness and range, and one
for the flags (True or False), each with a ConfigError naming the field, what it must be and what it was."""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any, Literal, TypedDict, TypeGuard, Unpack, overload

from planning.errors import ConfigError

#: Integers beyond this size are quoted by their number of digits (:func:`given`), not digit by digit.
HUGE_INTEGER = 10**30


def given(value: object, integer: bool = False) -> str:
    """``value`` as a message quotes what was given: its repr, and for a 0-d numpy array (``np.array(0.5)``,
    ``np.squeeze`` of one value) that it is one and how to pass it (``float(x)``, or ``int(x)`` for an
    ``integer`` field; no advice for one of bools or text, or a float for an integer field). Numbers are not
    read out of arrays: numpy scalars (what indexing, ``np.mean`` or ``np.linalg.norm`` give) are numbers, a
    0-d array is not."""
    import numpy as np  # here, not at the top: the command line checks its flags before it loads numerics

    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > HUGE_INTEGER:
        return f"an integer of {len(str(abs(value)))} digits"  # not its every digit
    if not (isinstance(value, np.ndarray) and value.ndim == 0):
        return repr(value)
    cast = "int" if integer else "float"
    fits = value.dtype.kind in ("iu" if integer else "iuf")
    return f"a 0-d numpy array ({value!r})" + (f"; pass {cast}(x)" if fits else "")


def is_number(value: object, integer: bool = False) -> TypeGuard[float]:
    """Whether ``value`` is a finite number (an integer with ``integer``): not a bool, nor a 0-d array."""
    kind = numbers.Integral if integer else numbers.Real
    if isinstance(value, bool) or not isinstance(value, kind):
        return False
    try:
        return math.isfinite(value)  # type: ignore[arg-type]
    except OverflowError:  # an integer too large for a float: TOML, JSON and Python's int take any size
        return False


def degrees_hint(value: object, largest: float = 720.0) -> str:
    """``"; 90 degrees would be 1.571 rad"`` for a number of radians that looks like degrees (a finite number at
    most ``largest`` in size), else "": the hint of a refused angle."""
    if not is_number(value) or abs(value) > largest:
        return ""
    return f"; {value:g} degrees would be {math.radians(value):.4g} rad"


#: Largest heading a pose (a scenario's, a map's origin, an option's) may give [rad]: a larger one is a typo or
#: degrees, not a direction.
MAX_HEADING = 4.0 * math.pi


def heading_beyond(theta: float) -> str:
    """Why a pose's heading ``theta`` [rad] is refused, "" when it is within :data:`MAX_HEADING`: "in radians within
    +-4 pi; 90 degrees would be 1.571 rad" (the degrees only for a heading that could be some). A scenario's poses,
    ``--offset``, ``--initial-pose`` and a ROS map's origin judge their headings by it."""
    if abs(theta) <= MAX_HEADING:
        return ""
    return f"in radians within +-4 pi{degrees_hint(theta)}"


def refuse_kind(where: str, kind: str, value: object, fix: str) -> ConfigError:
    """The error for an argument of the wrong type: ``<where> must be <kind>: pass <fix>, got <type> <value>``
    (what :func:`planning.core.geometry.check_pose` and :func:`planning.core.world.check_world` raise)."""
    return ConfigError(f"{where} must be {kind}: pass {fix}, got {type(value).__name__} {value!r:.80}")


def numbers_text(value: object, count: int) -> str:
    """``"1, 1, 0"`` for a tuple or list of ``count`` numbers (a pose or bounds spelled as numbers), else "":
    what a refused argument's advice quotes back."""
    if not isinstance(value, tuple | list) or len(value) != count or not all(is_number(v) for v in value):
        return ""
    return ", ".join(repr(v) for v in value)


class Limits(TypedDict, total=False):
    """The keyword arguments of :func:`check_number` besides ``integer`` and ``optional``."""

    above: float | None
    at_least: float | None
    at_most: float | None
    below: float | None
    unit: str
    fix: str


@overload
def check_number(
    where: str, value: object, *, integer: Literal[True], optional: Literal[False] = False, **limits: Unpack[Limits]
) -> int: ...
@overload
def check_number(
    where: str,
    value: object,
    *,
    integer: Literal[False] = False,
    optional: Literal[False] = False,
    **limits: Unpack[Limits],
) -> float: ...
@overload
def check_number(
    where: str, value: object, *, integer: bool = False, optional: bool = False, **limits: Unpack[Limits]
) -> float | int | None: ...
def check_number(
    where: str,
    value: object,
    *,
    above: float | None = None,
    at_least: float | None = None,
    at_most: float | None = None,
    below: float | None = None,
    integer: bool = False,
    optional: bool = False,
    unit: str = "",
    fix: str = "",
) -> float | int | None:
    """``value`` as a float (an int with ``integer``) when it is a finite number in range.

    The one check of a number a user gives: its message names the field, what it must be (the kind, the
    range and the unit), what was given (:func:`given`) and, with ``fix``, how to put it right, e.g.
    ``perturbation friction must be a finite number in [0.05, 10] (x), got 50.0; give ...``.

    Args:
        where: The field, as the message names it (e.g. ``"rrt: goal_bias"``).
        value: What was given. A bool is not a number, nor a 0-d numpy array (the message says to pass
            ``float(x)``: see :func:`given`); with ``integer`` a float is not accepted.
        above: Exclusive lower bound.
        at_least: Inclusive lower bound.
        at_most: Inclusive upper bound.
        below: Exclusive upper bound.
        integer: Require an integer.
        optional: Accept None (returned as None).
        unit: The field's unit, quoted in parentheses after the range; it may say what a value means
            (``"Hz, 0 for no pose source"``).
        fix: How to put it right (or why the bound holds), appended after ``"; "``.

    Returns:
        The value (None only with ``optional``).

    Raises:
        ConfigError: Not a finite number (an integer with ``integer``), or out of range.
    """
    if value is None and optional:
        return None
    if is_number(value, integer):
        number = int(value) if isinstance(value, numbers.Integral) else float(value)
        low_ok = (above is None or number > above) and (at_least is None or number >= at_least)
        if low_ok and (at_most is None or number <= at_most) and (below is None or number < below):
            return number if integer else float(number)
    wanted = ["an integer" if integer else "a finite number", _range(above, at_least, at_most, below, integer)]
    wanted += [f"({unit})" if unit else "", "(or omitted)" if optional else ""]
    tail = f"; {fix}" if fix else ""
    raise ConfigError(f"{where} must be {' '.join(w for w in wanted if w)}, got {given(value, integer)}{tail}")


def _range(
    above: float | None,
    at_least: float | None,
    at_most: float | None,
    below: float | None = None,
    integer: bool = False,
) -> str:
    """The bounds as a message says them: ``"> 0"``, ``"< 1"``, ``"in [0, 1]"``, ``"in (0, 60]"``, ``"in (0, 1)"``
    (one lower and one upper bound), ``">= 0 and < 1 and <= 2"`` (more) or ``""`` for none."""
    low = [f"({_bound(above, integer)}"] if above is not None else []
    low += [f"[{_bound(at_least, integer)}"] if at_least is not None else []
    high = [f"{_bound(at_most, integer)}]"] if at_most is not None else []
    high += [f"{_bound(below, integer)})"] if below is not None else []
    if len(low) == 1 and len(high) == 1:
        return f"in {low[0]}, {high[0]}"
    said = ((">", above), (">=", at_least), ("<", below), ("<=", at_most))
    return " and ".join(f"{op} {_bound(limit, integer)}" for op, limit in said if limit is not None)


def _bound(limit: float, integer: bool) -> str:
    """A bound as a message writes it: an integer's in full (268435456, not 2.68435e+08), else as ``:g``."""
    if integer and float(limit).is_integer() and abs(limit) < 1e15:
        return str(int(limit))
    return f"{limit:g}"


def check_flag(where: str, value: object) -> bool:
    """``value`` when it is True or False (a numpy bool too), as a bool.

    A flag is not read for its truth: the string ``"no"``, a number or None would pass ``if value``
    either way, silently.

    Raises:
        ConfigError: Anything else; the message names ``where`` and the value.
    """
    if isinstance(value, bool):
        return value
    import numpy as np  # as in given

    if isinstance(value, np.bool_):
        return bool(value)
    said = " (true or false, unquoted, in a TOML or JSON file or a KEY=VALUE option)" if isinstance(value, str) else ""
    raise ConfigError(f"{where} must be True or False, got {value!r}{said}")


#: :func:`check_fields`'s limits of a field that must be True or False.
FLAG: Mapping[str, Any] = {"flag": True}


def check_fields(obj: object, limits: Mapping[str, Mapping[str, Any]], prefix: str = "") -> None:
    """Check the named fields of a frozen dataclass with :func:`check_number` (a field whose limits are
    :data:`FLAG` with :func:`check_flag`); store the checked values.

    Args:
        obj: The dataclass instance (from its ``__post_init__``).
        limits: Field name -> keyword arguments of :func:`check_number` (``above``, ``integer``, ...), or
            :data:`FLAG` for True or False.
        prefix: Put before the field's name in messages (e.g. ``"C-RRT*: "``).

    Raises:
        ConfigError: A field is not a finite number in its range, or a flag not True or False (the message
            names it).
    """
    for name, kwargs in limits.items():
        where, value = f"{prefix}{name}", getattr(obj, name)
        checked = check_flag(where, value) if kwargs is FLAG else check_number(where, value, **kwargs)
        object.__setattr__(obj, name, checked)
