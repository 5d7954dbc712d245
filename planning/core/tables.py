"""Typed reading of parsed TOML tables (scenario files and their ``[world.map]``), naming the file and
the field in every error, with what was expected and what was found."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from planning.core.checks import given, is_number
from planning.errors import ScenarioError

#: Longest quote of a value a message makes [characters] (a longer one is cut, its length said).
LONGEST_VALUE = 120


def toml_value(value: Any) -> str:
    """``value`` as the document spells it: ``true``/``false``, a table as ``a table``, else its repr."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, Mapping):
        return "a table" if value else "an empty table"
    if isinstance(value, int):
        return given(value)  # an integer of hundreds of digits by its number of digits
    text = repr(value)
    return text if len(text) <= LONGEST_VALUE else f"{text[: LONGEST_VALUE - 20]}... ({len(text)} characters)"


class TableReader:
    """Reads fields of the tables of one document.

    Args:
        where: How errors name the document (usually its path).

    Fields are named ``ctx + key``: ``ctx`` is the dotted path of the table with a trailing dot
    (``"world."``, ``"world.obstacles[2]."``; ``""`` at the top level).
    """

    def __init__(self, where: str) -> None:
        self.where = where

    def fail(self, field_name: str, expected: str, got: Any = None) -> ScenarioError:
        """The error for field ``field_name``: what was expected and (unless None) what was found."""
        got_txt = "" if got is None else f", got {toml_value(got)}"
        return ScenarioError(f"{self.where}: field '{field_name}': expected {expected}{got_txt}")

    def keys(self, table: Any, ctx: str, required: set[str], optional: set[str]) -> None:
        """Check that ``table`` is a table with every required key and no key outside both sets."""
        name = ctx.rstrip(".")
        if not isinstance(table, Mapping):
            raise self.fail(name, f"a table ([{name}])" if name else "a table", table)
        unknown = set(table) - required - optional
        if unknown:
            raise ScenarioError(
                f"{self.where}: unknown key(s) {', '.join(sorted(repr(k) for k in unknown))} in "
                f"[{name or 'top level'}]; allowed: {', '.join(sorted(required | optional))}"
            )
        missing = required - set(table)
        if missing:
            raise ScenarioError(f"{self.where}: missing field(s) {', '.join(sorted(repr(ctx + k) for k in missing))}")

    def number(
        self,
        table: Mapping[str, Any],
        key: str,
        ctx: str,
        *,
        positive: bool = False,
        default: float | None = None,
        expected: str | None = None,
    ) -> float:
        """A finite number (> 0 with ``positive``); ``default`` when the key is absent and a default is given.

        ``expected`` replaces "a number > 0" in the error for a number that is not positive.
        """
        if key not in table and default is not None:
            return default
        val = table[key]
        if not is_number(val):
            raise self.fail(f"{ctx}{key}", "a finite number", val)
        if positive and val <= 0:
            raise self.fail(f"{ctx}{key}", expected or "a number > 0", val)
        return float(val)

    def vector(
        self, table: Mapping[str, Any], key: str, ctx: str, n: int, *, expected: str | None = None
    ) -> tuple[float, ...]:
        """A list of ``n`` finite numbers (``expected`` describes it in the error)."""
        val = table[key]
        if not isinstance(val, list) or len(val) != n or not all(is_number(v) for v in val):
            raise self.fail(f"{ctx}{key}", expected or f"a list of {n} finite numbers", val)
        return tuple(float(v) for v in val)
