"""Arrays as nhsim's compiled kernels take the inputs they only read.

numba compiles a kernel once per combination of argument types, and an array's writability is part of
its type. nhsim's value types (plans, trajectories, robot specs, run logs) hold read-only arrays, while
the arrays a kernel builds and hands to the kernels it calls are writable: a kernel met with both
compiles twice, and one of two array inputs up to four times (the largest take seconds each, and every
process on a new machine or after an update pays for them). Python code passes each array input
through :func:`kernel_input`, so a kernel sees the one type its compiled callers give it.

The frozen value types hold their arrays read-only; :func:`freeze_arrays` and :class:`ReadOnlyArrays`
keep them so in their copies (a pickled value, a worker process's, and a deep copy come back with
writeable arrays).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray


def freeze_arrays(value: object) -> None:
    """Hold the numpy arrays among a frozen dataclass's fields as read-only views, as the value itself is
    frozen: an edit through a run's log, a plan or a trajectory would reach every record, plot and video
    made of it. Views, not copies (a long run's log is large), and the arrays given stay as they were."""
    for f in dataclasses.fields(value):  # type: ignore[arg-type]
        item = getattr(value, f.name)
        if isinstance(item, np.ndarray) and item.flags.writeable:
            view = item.view()
            view.flags.writeable = False
            object.__setattr__(value, f.name, view)


class ComparedByValue:
    """A dataclass that holds arrays (or values that do) and compares by value, so that a copy equals its original:
    equal when every compared field is (:func:`same_fields`: arrays element by element, NaN equal to NaN). A class
    declares ``eq=False`` to its ``@dataclass`` to keep this (a generated ``__eq__`` compares arrays with ``==``,
    which raises). Not hashable: it holds arrays."""

    def __eq__(self, other: object) -> bool:
        return same_fields(self, other)

    __hash__ = None  # type: ignore[assignment]


class ReadOnlyArrays(ComparedByValue):
    """A frozen dataclass whose arrays stay read-only in its copies too: a pickled one (a worker process's) and
    a deep copy come back with writeable arrays, which :meth:`__setstate__` makes read-only again; compared by
    value (:class:`ComparedByValue`)."""

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        freeze_arrays(self)


def same_value(a: Any, b: Any) -> bool:
    """Whether two field values are equal: arrays element by element (NaN equal to NaN, shapes too), tuples,
    lists and mappings item by item, anything else by ``==`` (a value whose ``==`` is not a truth is not equal)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        try:
            return bool(np.array_equal(a, b, equal_nan=True))
        except TypeError:  # NaN has no meaning for text or objects
            return bool(np.array_equal(a, b))
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return type(a) is type(b) and len(a) == len(b) and all(same_value(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        return a.keys() == b.keys() and all(same_value(a[k], b[k]) for k in a)
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    try:
        return bool(a == b)
    except (TypeError, ValueError):
        return False


def same_fields(a: Any, b: Any) -> bool:
    """``a == b`` for two dataclasses of one class, field by field with :func:`same_value` (the fields that
    compare); ``NotImplemented`` when ``b`` is of another class."""
    if b.__class__ is not a.__class__:
        return NotImplemented
    return all(same_value(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a) if f.compare)


def kernel_input(values: ArrayLike) -> NDArray[np.float64]:
    """``values`` as a C-contiguous, writable float64 array: the array itself when it already is one (the
    kernels given it only read it), else a copy."""
    out = np.ascontiguousarray(values, dtype=np.float64)
    return out if out.flags.writeable else out.copy()
