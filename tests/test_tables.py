"""TableReader: every error names the document, the field, what was expected and what was found."""

import pytest

from planning.core.tables import TableReader
from planning.errors import ScenarioError

R = TableReader("s.toml")


def test_keys() -> None:
    R.keys({"a": 1, "b": 2}, "t.", {"a"}, {"b", "c"})
    with pytest.raises(ScenarioError, match=r"^s\.toml: field 't': expected a table \(\[t\]\), got 3$"):
        R.keys(3, "t.", {"a"}, set())
    with pytest.raises(ScenarioError, match=r"^s\.toml: field '': expected a table, got \[\]$"):
        R.keys([], "", set(), set())
    with pytest.raises(ScenarioError, match=r"unknown key\(s\) 'd', 'e' in \[t\]; allowed: a, b"):
        R.keys({"a": 1, "d": 1, "e": 1}, "t.", {"a"}, {"b"})
    with pytest.raises(ScenarioError, match=r"unknown key\(s\) 'd' in \[top level\]"):
        R.keys({"d": 1}, "", set(), set())
    with pytest.raises(ScenarioError, match=r"missing field\(s\) 't.a', 't.b'"):
        R.keys({}, "t.", {"a", "b"}, set())


def test_number() -> None:
    assert R.number({"x": 2}, "x", "t.") == 2.0 and isinstance(R.number({"x": 2}, "x", "t."), float)
    assert R.number({}, "x", "t.", default=0.5) == 0.5
    assert R.number({"x": -1.0}, "x", "t.") == -1.0
    for bad in (True, "1", float("nan"), float("inf"), [1]):
        with pytest.raises(ScenarioError, match=r"field 't\.x': expected a finite number"):
            R.number({"x": bad}, "x", "t.")
    with pytest.raises(ScenarioError, match=r"field 't.x': expected a number > 0, got 0"):
        R.number({"x": 0}, "x", "t.", positive=True)
    with pytest.raises(ScenarioError, match=r"field 't.x': expected a size > 0 \[m\], got -2"):
        R.number({"x": -2}, "x", "t.", positive=True, expected="a size > 0 [m]")
    with pytest.raises(KeyError):
        R.number({}, "x", "t.")


def test_vector() -> None:
    assert R.vector({"v": [1, 2.5]}, "v", "t.", 2) == (1.0, 2.5)
    for bad in ([1.0], [1.0, "2"], [1.0, False], [1.0, float("nan")], (1.0, 2.0)):
        with pytest.raises(ScenarioError, match=r"field 't\.v': expected a list of 2 finite numbers"):
            R.vector({"v": bad}, "v", "t.", 2)
    with pytest.raises(ScenarioError, match=r"expected \[x, y\]"):
        R.vector({"v": [1.0]}, "v", "t.", 2, expected="[x, y]")
