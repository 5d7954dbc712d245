"""control/dispatch.py: a kernel bound once is the dispatcher's own overload, without its per-call typing."""

from __future__ import annotations

import functools

import numba as nb
import numpy as np
import pytest

from control.dispatch import bind


@nb.njit
def _advance(state, table, k, x):  # type: ignore[no-untyped-def]  # pragma: no cover - compiled
    """Adds x times row k of the table's ``gain`` to the state's ``total``; returns (total, k)."""
    s = state[0]
    s.total += x * table[k].gain
    return s.total, k


def _record(fields: list[str]) -> np.dtype:
    return np.dtype([(f, "f8") for f in fields], align=True)


def test_a_bound_kernel_is_the_dispatched_kernel_on_the_same_arrays() -> None:
    state_type, table_type = _record(["total", "pad"]), _record(["gain", "other"])
    a, b = np.zeros(1, state_type), np.zeros(1, state_type)
    table = np.zeros(4, table_type)
    table["gain"], table["other"] = [0.5, 1.5, -2.0, 3.25], 99.0
    step = bind(_advance, a, table, free=(0, 0.0))
    for k, x in [(0, 1.0), (3, -0.7), (2, 1e-3), (1, 7)]:  # an int x is converted as the dispatcher would
        assert step(k, x) == _advance(b, table, k, x)
        assert a.tobytes() == b.tobytes()  # the state changed in place, alike
    assert a[0]["total"] != 0.0


def test_records_of_other_layouts_get_their_own_overloads() -> None:
    """The same field names at other offsets, and dtypes made and dropped one after another (whose
    addresses could be reused), each bind to an overload that reads their own layout."""
    table = np.zeros(1, _record(["gain"]))
    table["gain"] = 2.0
    for n in range(12):
        before, after = [f"b{i}" for i in range(n % 4)], [f"a{i}" for i in range(n % 3)]
        fields = before + after
        state = np.zeros(1, _record([*before, "total", *after]))
        state[0]["total"] = n
        assert bind(_advance, state, table, free=(0, 0.0))(0, 1.0) == (n + 2.0, 0)
        assert state[0]["total"] == n + 2.0 and all(state[0][f] == 0.0 for f in fields)


def test_a_bound_kernel_refuses_a_wrong_call_and_plain_functions_are_partials() -> None:
    state, table = np.zeros(1, _record(["total"])), np.zeros(2, _record(["gain"]))
    step = bind(_advance, state, table, free=(0, 0.0))
    with pytest.raises(TypeError):
        step(0)  # one argument short
    with pytest.raises(TypeError):
        step(0, "fast")  # not a number

    def plain(a: int, b: int) -> int:
        return a - b

    bound = bind(plain, 5)
    assert isinstance(bound, functools.partial) and bound(3) == 2
