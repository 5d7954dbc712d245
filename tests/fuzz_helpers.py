"""Shared pieces of the property-based (Hypothesis) tests: settings, a TOML writer and value strategies.

Every fuzz property runs twice: in the default run with :data:`FAST` (a few dozen examples, so the
fuzz files stay well under 30 s on a loaded machine) and in the ``slow`` suite with :data:`SLOW`
(1000 examples). Both are derandomised, so a run is reproducible; no example database is written.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Mapping
from datetime import date, datetime, time
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from planning.errors import NhsimError

_COMMON: dict[str, Any] = {
    "deadline": None,
    "derandomize": True,
    "database": None,
    "print_blob": True,
    "phases": [Phase.explicit, Phase.reuse, Phase.generate, Phase.target, Phase.shrink],
    "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large],
}
#: The default run's settings: few examples, reproducible.
FAST = settings(max_examples=40, **_COMMON)
#: The ``slow`` suite's settings: 1000 examples per property.
SLOW = settings(max_examples=1000, **_COMMON)


def fast_and_slow(
    strategy: st.SearchStrategy[Any], prop: Callable[[Any], None], fast: int | None = None
) -> tuple[Callable[[], None], Callable[[], None]]:
    """Two tests of one property: the default run's (``fast`` examples, default :data:`FAST`'s) and the
    ``slow``-marked one with :data:`SLOW`.

    Args:
        strategy: Draws one input of the property.
        prop: Checks the property for one input (raises AssertionError when it fails).
        fast: Examples of the default run's test.
    """
    fast_settings = FAST if fast is None else settings(FAST, max_examples=fast)
    return (
        fast_settings(given(strategy)(prop)),
        pytest.mark.slow(SLOW(given(strategy)(prop))),
    )


def expect_nhsim_errors(call: Callable[[], Any]) -> tuple[Any, NhsimError | None]:
    """``call()``'s result, or the NhsimError it raised; any other exception fails the test.

    Returns:
        (result, None) on a return, (None, error) on an NhsimError.
    """
    try:
        return call(), None
    except NhsimError as exc:
        assert str(exc), f"{type(exc).__name__} without a message"
        return None, exc
    except Exception as exc:
        raise AssertionError(f"raised {type(exc).__name__} (not an NhsimError): {exc!r}") from exc


def assert_finite(value: Any, where: str) -> None:
    """Every number in ``value`` (a number, an array, or nested lists, tuples and dicts of them) is finite."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            assert_finite(item, f"{where}[{key!r}]")
    elif isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            assert_finite(item, f"{where}[{i}]")
    elif isinstance(value, np.ndarray):
        if value.dtype.kind in "fc":
            assert np.all(np.isfinite(value)), f"{where} holds non-finite values"
    elif isinstance(value, float):
        assert math.isfinite(value), f"{where} = {value}"


# --------------------------------------------------------------------------------------------- TOML
def _toml_value(value: Any) -> str:
    """One TOML value (inline tables for mappings; NaN and infinities as TOML writes them)."""
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, (bool, int, float, str)):  # JSON's forms of these are TOML's too
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (datetime, date, time)):
        return value.isoformat()
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_toml_value(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"no TOML form for {type(value).__name__}")


def to_toml(document: Mapping[str, Any]) -> str:
    """A TOML document of top-level ``key = value`` lines (tables written inline).

    Strings are written as JSON strings, which are TOML basic strings for the printable text the
    strategies draw.
    """
    return "".join(f"{json.dumps(str(k))} = {_toml_value(v)}\n" for k, v in document.items())


# ------------------------------------------------------------------------------------------- values
#: Printable text that is valid inside a TOML basic string.
TEXT = st.text(st.characters(codec="utf-8", categories=("L", "N", "P", "Zs")), max_size=12)
#: Numbers that are not finite.
NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])
#: Any TOML scalar, finite or not.
SCALARS = st.one_of(
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(),
    TEXT,
    st.just(datetime(1979, 5, 27, 7, 32)),
)
#: Any TOML value: scalars, lists and tables of them, nested twice.
ANY_VALUE = st.recursive(
    SCALARS,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(TEXT, inner, max_size=3)),
    max_leaves=6,
)


def coordinate(lo: float = -20.0, hi: float = 20.0) -> st.SearchStrategy[float]:
    """A finite coordinate in [lo, hi] [m]."""
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


def maybe_bad(good: st.SearchStrategy[Any], bad: st.SearchStrategy[Any], p_bad: int = 8) -> st.SearchStrategy[Any]:
    """``good`` most of the time, ``bad`` about one draw in ``p_bad``.

    The choice is an integer in [0, p_bad) that picks ``bad`` at its middle value: Hypothesis draws the
    ends of a range (and 0 above all) far more often than 1 / p_bad, and shrinks towards 0, the good side.
    """
    return st.integers(0, p_bad - 1).flatmap(lambda k: bad if k == p_bad // 2 else good)


#: A number that an option or a field may wrongly hold: non-finite, zero, negative, or not a number at all.
BAD_NUMBER = st.one_of(
    NON_FINITE,
    st.sampled_from([0, 0.0, -1.0, -1e-9, 1e300, -1e300, True, False]),
    TEXT,
    st.lists(st.floats(-1, 1), max_size=2),
)


# ------------------------------------------------------------------------------------- timed files
@dataclasses.dataclass(frozen=True)
class TimedFile:
    """A drawn trajectory file shaped like published ones (see :func:`timed_files`).

    Attributes:
        text: The file's text (CSV with a header, or without one when ``columns`` names them).
        columns: ``--columns`` for a file without a header, else None.
        scale: ``--scale`` (0.01 for a file in pixels of 1 cm), or None for metres.
        refused_at: The row the file must be refused at ("line 7"), for a drawn fault; None when it
            must run.
        why: What was drawn, for the failure report.
    """

    text: str
    columns: tuple[str, ...] | None
    scale: float | None
    refused_at: str | None
    why: str


def _piece(t: np.ndarray, p0: np.ndarray, p1: np.ndarray, bend: float, ramp: bool) -> tuple[np.ndarray, ...]:
    """Positions, velocities and accelerations at times t (from 0) of a drive from p0 to p1 bent sideways
    by ``bend``: rest to rest (quintic) when ``ramp``, else at constant pace."""
    T = float(t[-1])
    s = t / T
    if ramp:
        u, du, ddu = (
            10 * s**3 - 15 * s**4 + 6 * s**5,
            (30 * s**2 - 60 * s**3 + 30 * s**4) / T,
            (60 * s - 180 * s**2 + 120 * s**3) / T**2,
        )
    else:
        u, du, ddu = s, np.full_like(s, 1.0 / T), np.zeros_like(s)
    d = p1 - p0
    nrm = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
    w, dw = np.sin(np.pi * u), np.pi * np.cos(np.pi * u)
    xy = p0 + np.outer(u, d) + bend * np.outer(w, nrm)
    vel = np.outer(du, d) + bend * np.outer(dw * du, nrm)
    acc = np.outer(ddu, d) + bend * np.outer(dw * ddu - np.pi**2 * w * du**2, nrm)
    return xy, vel, acc


#: The column sets a drawn file gives (t, x, y and some derivatives and headings).
TIMED_COLUMNS = (
    ("t", "x", "y"),
    ("t", "x", "y", "theta"),
    ("t", "x", "y", "vx", "vy"),
    ("t", "x", "y", "vx", "vy", "ax", "ay"),
    ("t", "x", "y", "vx", "vy", "ax", "ay", "theta"),
)
_ORDER = {"t": 0, "x": 1, "y": 2, "vx": 3, "vy": 4, "ax": 5, "ay": 6, "theta": 7}


def _stand(rng: np.random.Generator, last: np.ndarray, t0: float) -> np.ndarray:
    """Rows standing at the pose of row ``last`` (8,) while time passes after t0."""
    ts = t0 + np.cumsum(rng.uniform(0.05, 1.8, int(rng.integers(2, 6))))
    block = np.tile(last, (ts.size, 1))
    block[:, 0], block[:, 3:7] = ts, 0.0
    return block


def _drive(
    rng: np.random.Generator, start: np.ndarray, target: np.ndarray, t0: float, ramp: bool, back: bool
) -> np.ndarray:
    """Rows (t, x, y, vx, vy, ax, ay, theta) of one drive from ``start`` to ``target`` after t0, stamps
    0.05-1.8 s apart; the heading points backwards on a drive ``back``."""
    dur = float(rng.uniform(3.0, 40.0))
    ts = np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 1.8, max(int(dur / 0.9), 2)))])
    ts *= dur / ts[-1]
    xy, vel, acc = _piece(ts, start, target, float(rng.uniform(-0.3, 0.3)), ramp)
    sgn = -1.0 if back else 1.0
    theta = np.arctan2(sgn * vel[:, 1], sgn * vel[:, 0])
    theta[0], theta[-1] = theta[1], theta[-2]  # at rest: the heading of the motion next to it
    return np.column_stack([ts + t0, xy, vel, acc, theta])


def _drives(draw: st.DrawFn, rng: np.random.Generator, why: list[str]) -> np.ndarray:
    """The rows of one to four drives, stand-stills and reversals, in metres and seconds."""
    rows = [_drive(rng, rng.uniform(0.3, 2.7, 2), rng.uniform(0.3, 2.7, 2), 0.0, True, False)]
    for _ in range(draw(st.integers(0, 3))):
        kind = draw(st.sampled_from(["drive", "reverse", "stand"]))
        last = rows[-1][-1]
        if kind == "stand":
            rows.append(_stand(rng, last, float(last[0])))
            why.append("stand")
            continue
        back = rows[-1][0, 1:3] if kind == "reverse" else rng.uniform(0.3, 2.7, 2)  # reverse: the way it came
        ramp = draw(st.booleans())
        block = _drive(rng, last[1:3], back, float(last[0]), ramp, kind == "reverse")
        if draw(st.booleans()):  # the join's stamp repeated: the same place, velocities a little apart
            block[0, 3:5] += rng.normal(0.0, 0.005, 2)
            why.append("repeated stamp")
        else:
            block = block[1:]
        rows.append(block)
        why.append(kind if ramp else f"{kind} (moving at its ends)")
    return np.vstack(rows)


@st.composite
def timed_files(draw: st.DrawFn, faults: bool = True) -> TimedFile:
    """Trajectory files like one published for an EduMIP: ``t,x,y,vx,vy,ax,ay,theta`` (some of them) in
    pixels of 1 cm or in metres, sampled irregularly 0.05-1.8 s apart, made of one to four drives
    that meet at repeated stamps (same place, velocities a little apart), with stand-stills (rows at
    one place while time passes), reversals (a drive back the way it came: a cusp), drives that start
    or end moving, and given derivatives that agree with the positions or not (vy of the wrong sign,
    wrong units, noise). With ``faults``, about one file in three gets a fault that must be refused
    naming its row: a stamp repeated at another place, or a stamp going back.

    Bulk numbers come from a numpy generator seeded by the draw (a failure replays exactly); the shape
    of the file is drawn by Hypothesis.
    """
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = draw(st.sampled_from([0.01, None]))
    names = draw(st.sampled_from(TIMED_COLUMNS))
    why = ["pixels" if scale else "metres", ",".join(names)]
    data = _drives(draw, rng, why)
    derivs = draw(st.sampled_from(["agree", "agree", "vy sign", "units", "noise"]))
    if derivs == "vy sign":
        data[:, 4] *= -1.0
    elif derivs == "units":
        data[:, 3:7] *= 100.0
    elif derivs == "noise":
        data[:, 3:7] += rng.normal(0.0, 0.02, (data.shape[0], 4))
    why.append(f"derivatives {derivs}")
    fault = None
    kind = draw(st.sampled_from([None, None, None, None, "repeat", "back"])) if faults else None
    if kind is not None:
        k = int(rng.integers(1, data.shape[0] - 1))
        if kind == "repeat":  # a stamp repeated 5 cm away
            data = np.insert(data, k + 1, data[k], axis=0)
            data[k + 1, 1] += 0.05
            why.append(f"stamp repeated at another place, data row {k + 1}")
        else:
            data[k + 1, 0] = data[k, 0] - 0.5
            why.append(f"stamp going back, data row {k + 1}")
        fault = k + 1
    data[:, 1:7] /= scale or 1.0
    header = draw(st.booleans())
    body = [",".join(f"{v:.4f}" for v in row[[_ORDER[c] for c in names]]) for row in data]
    text = "\n".join([",".join(names), *body] if header else body) + "\n"
    refused_at = None if fault is None else f"line {fault + 1 + int(header)}"
    return TimedFile(text, None if header else names, scale, refused_at, "; ".join(why))


# ---------------------------------------------------------------------------------------- crowded worlds
@st.composite
def crowded_worlds(draw: st.DrawFn, min_obstacles: int = 20, max_obstacles: int = 300) -> Any:
    """A world of many obstacles of every kind (circles, ellipses, oriented boxes, convex and
    star-shaped polygons), small and large, overlapping each other and the walls, in bounds of
    random size and place (a few metres to about 15 m a side).

    The obstacles are drawn from a seeded generator (one drawn seed and count: Hypothesis shrinks
    those, not hundreds of coordinates).
    """
    from planning.core.world import MIN_FEATURE, Box, Circle, Ellipse, Polygon, World, lies_outside

    n = draw(st.integers(min_obstacles, max_obstacles), label="obstacles")
    seed = draw(st.integers(0, 2**32 - 1), label="seed")
    rng = np.random.default_rng(seed)
    w, h = rng.uniform(2.0, 15.0, 2)
    x0, y0 = rng.uniform(-10.0, 10.0, 2)
    scale = float(rng.choice([0.02, 0.1, 0.4]))  # typical obstacle size [m]: fruits, poles, tables
    obstacles: list[Any] = []
    for _ in range(n):
        c = (float(x0 + rng.uniform(-0.1, 1.1) * w), float(y0 + rng.uniform(-0.1, 1.1) * h))
        a, b = (float(v) for v in scale * rng.uniform(0.2, 2.0, 2))
        angle = float(rng.uniform(-4.0, 4.0))
        kind = int(rng.integers(4))
        if kind == 0:
            obstacles.append(Circle(c, a))
        elif kind == 1:
            obstacles.append(Ellipse(c, (a, b), angle))
        elif kind == 2:
            obstacles.append(Box(c, (2 * a, 2 * b), angle))
        else:  # a star-shaped polygon: vertices at increasing angles about the centre
            k = int(rng.integers(3, 9))
            phi = 2 * np.pi * (np.arange(k) + rng.uniform(0.0, 0.8, k)) / k
            r = a * rng.uniform(0.3, 1.0, k)
            vertices = tuple((c[0] + r[i] * np.cos(phi[i]), c[1] + r[i] * np.sin(phi[i])) for i in range(k))
            try:
                poly = Polygon(vertices)
                # a sliver thinner than a world takes (MIN_FEATURE) is refused as a degenerate draw is
                obstacles.append(poly if poly.min_feature >= MIN_FEATURE else Circle(c, a))
            except NhsimError:  # a degenerate draw (three nearly collinear vertices): a circle instead
                obstacles.append(Circle(c, a))
    bounds = (float(x0), float(x0 + w), float(y0), float(y0 + h))
    return World(bounds, tuple(ob for ob in obstacles if not lies_outside(ob, bounds)))  # a world takes none beyond
