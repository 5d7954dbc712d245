"""The FBL tracker's gains (:class:`FBLGains`, its parameters) and their files, with their provenance, as TOML.

A gains file holds one gain set and where it came from::

    # nhsim FBL tracker gains
    [gains]
    kp = 14.2        # position error gain Kp [1/s^2]
    kd = 7.9         # velocity error gain Kd [1/s]
    xi_min = 0.02    # singularity guard |xi| >= xi_min [m/s]

    [provenance]     # optional: how the gains were found
    study = "fbl-open-figure8"
    objective = 0.00123
    scenarios = ["open:figure8", "open:circle"]

``[gains]`` is required with ``kp`` and ``kd``; ``xi_min`` defaults to the tracker's default.
``[provenance]`` is free-form (strings, finite numbers, booleans, dates and times, lists and tables of
those) but its ``study`` must be a string, ``objective`` a finite number and ``scenarios`` a list of
strings. What :func:`dump_gains_toml` writes, :func:`parse_gains_toml` reads back equal (a tuple as a list).
"""

from __future__ import annotations

import datetime
import math
import numbers
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from control.base import check_positive_fields
from planning.core.checks import check_number
from planning.core.files import read_input_text
from planning.errors import ConfigError, option


@dataclass(frozen=True)
class FBLGains:
    """Gains of the dynamic feedback-linearisation tracker.

    Attributes:
        kp: Position error gain Kp [1/s^2].
        kd: Velocity error gain Kd [1/s].
        xi_min: Smallest |xi| used in the division [m/s] (singularity guard).
    """

    kp: float = 9.0
    kd: float = 6.0
    xi_min: float = 0.02

    def __post_init__(self) -> None:
        check_positive_fields(self, ("kp", "kd"), "the error dynamics need Kp, Kd > 0")
        check_positive_fields(self, ("xi_min",), "the law divides by the speed, kept at least xi_min (default 0.02)")

    @classmethod
    def parse(cls, text: str) -> FBLGains:
        """Parse ``"KP,KD"`` (as given to ``--gains``).

        Raises:
            ConfigError: Not two comma-separated positive numbers.
        """
        bad = ConfigError(f"gains must be 'KP,KD' (two positive finite numbers, e.g. 9,6), got {text!r}")
        if not isinstance(text, str):
            raise bad
        parts = [p.strip() for p in text.split(",")]
        if len(parts) != 2:
            raise bad
        try:
            kp, kd = float(parts[0]), float(parts[1])
        except ValueError as exc:
            raise bad from exc
        for name, gain in (("KP", kp), ("KD", kd)):
            if not (math.isfinite(gain) and gain > 0):
                raise ConfigError(f"{bad}: {name} = {gain:g} is not a positive finite number")
        return cls(kp=kp, kd=kd)


def check_sampled_stability(gains: FBLGains, control_rate: float, where: str, *, rate_given: bool = True) -> None:
    """Raise :class:`ConfigError` unless ``gains`` keep the FBL's error dynamics stable at ``control_rate`` [Hz].

    The linearised error of each axis is a double integrator driven by an acceleration held for a control period
    T (e'' = -Kp e - Kd e'); sampled, its characteristic polynomial is z^2 + (T Kd + T^2 Kp / 2 - 2) z + 1 - T Kd +
    T^2 Kp / 2, whose roots lie inside the unit circle (Jury's test) only when Kd < 2 / T and Kp < 2 Kd / T. Beyond,
    the tracker diverges whatever the robot (``--gains 1000,1`` at 50 Hz ended as "estimator diverged").

    Args:
        gains: The gains.
        control_rate: The rate the tracker runs at [Hz].
        where: What gave them, for the message (``"--gains 1000,1"``).
        rate_given: Whether the caller may choose the control rate (the message then suggests raising it; else
            only Kp and Kd).
    """
    most_kd = 2.0 * control_rate
    most_kp = 2.0 * gains.kd * control_rate
    if gains.kd < most_kd and gains.kp < most_kp:
        return
    fix = "lower Kp or raise Kd within its bound"
    if rate_given:
        fix = "lower Kp, raise Kd within its bound, or raise the control rate"
    raise UnstableGainsError(
        where,
        f"FBL gains Kp={gains.kp:g}, Kd={gains.kd:g} make the error dynamics unstable at the control rate "
        f"{control_rate:g} Hz (held for a period, they need Kd < 2 x rate = {most_kd:g} /s and Kp < 2 x Kd x rate = "
        f"{most_kp:g} /s^2); {fix} (the defaults are Kp={FBLGains().kp:g}, Kd={FBLGains().kd:g})",
    )


def check_period_stability(gains: FBLGains, dt: float, tracker: str) -> None:
    """:func:`check_sampled_stability` for a tracker of the FBL's gains reset with control period ``dt`` [s] (a
    finite number > 0): the one check of gains used in a loop of one's own, as the cases check theirs."""
    check_sampled_stability(gains, 1.0 / dt, f"tracker {tracker!r} reset with dt = {dt:g} s")


class UnstableGainsError(ConfigError):
    """FBL gains the control rate cannot keep stable (:func:`check_sampled_stability`).

    Args:
        where: What gave them.
        problem: What is wrong and the fix (the message is ``where: problem``).
    """

    def __init__(self, where: str, problem: str) -> None:
        super().__init__(f"{where}: {problem}")
        self.problem = problem


GAIN_KEYS = ("kp", "kd", "xi_min")

#: A key TOML takes bare (unquoted).
BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
#: What a provenance value may be besides text, numbers, lists and tables: TOML's dates and times.
TOML_TIMES = (datetime.datetime, datetime.date, datetime.time)


@dataclass(frozen=True)
class GainsFile:
    """A gain set and its provenance.

    Attributes:
        gains: The FBL gains.
        provenance: Study name, objective value, scenarios and whatever else the writer recorded: a dict with text
            keys whose values are what a TOML file holds (text, booleans, integers, finite floats, dates and times,
            lists and dicts of those), so that :func:`dump_gains_toml` can write it.

    Raises:
        ConfigError: ``gains`` is not an :class:`FBLGains`, or ``provenance`` is not such a dict (the message names
            the entry and what it holds).
    """

    gains: FBLGains
    provenance: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.gains, FBLGains):
            shown = "FBLGains(kp=9.0, kd=6.0)"
            if isinstance(self.gains, Mapping) and all(isinstance(k, str) and k.isidentifier() for k in self.gains):
                shown = f"FBLGains({', '.join(f'{k}={v!r}' for k, v in self.gains.items())})"
            raise ConfigError(
                f"GainsFile.gains must be an FBLGains: pass {shown}, got {type(self.gains).__name__} {self.gains!r:.80}"
            )
        if not isinstance(self.provenance, Mapping):
            raise ConfigError(
                "GainsFile.provenance must be a dict of what the gains came from, e.g. {'study': 'fbl-figure8'}, got "
                f"{type(self.provenance).__name__} {self.provenance!r:.80}"
            )
        check_provenance("GainsFile.provenance", self.provenance)
        object.__setattr__(self, "provenance", dict(self.provenance))


def check_provenance(where: str, value: object) -> None:
    """Refuse a provenance entry a TOML file cannot hold (:func:`dump_gains_toml` writes every other): a key that is
    not text, text that is not Unicode (a lone surrogate), a non-finite number, None or any other object.

    Args:
        where: The entry, as the message names it (``GainsFile.provenance['note']``).
        value: What it holds (a table is checked entry by entry, a list item by item).

    Raises:
        ConfigError: Naming the first entry that cannot be written, what it holds and what it may hold.
    """
    if isinstance(value, Mapping):
        for key, item in value.items():
            if not isinstance(key, str):
                raise ConfigError(f"{where}: the key {key!r:.80} must be text (a TOML key), got {type(key).__name__}")
            check_provenance(f"{where}[{key!r}]", item)
        return
    if isinstance(value, list | tuple):
        for i, item in enumerate(value):
            check_provenance(f"{where}[{i}]", item)
        return
    wrong = ""
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            wrong = "text that is not Unicode (a lone surrogate), which no TOML file holds"
    elif isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral):
        if not math.isfinite(value):
            wrong = f"the non-finite number {value!r}"
    elif isinstance(value, datetime.time) and value.tzinfo is not None:
        wrong = f"the time {value.isoformat()} with an offset, which TOML's times (local ones) have not"
    elif not isinstance(value, (bool, numbers.Integral, *TOML_TIMES)):
        wrong = f"{type(value).__name__} {value!r:.80}"
    if wrong:
        raise ConfigError(
            f"{where} holds {wrong}; a gains file's provenance holds text, booleans, integers, finite numbers, dates "
            "and times, and lists and tables of those"
        )


def parse_gains_toml(text: str, *, where: str = "gains file") -> GainsFile:
    """Parse the TOML text of a gains file.

    Args:
        text: The file's content.
        where: Name used in error messages (the path).

    Raises:
        ConfigError: Not TOML, no ``[gains]`` table, a missing, unknown, non-numeric, negative or
            zero gain, or a malformed provenance field.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{where}: not valid TOML ({exc}); a gains file has a [gains] table with kp, kd") from exc
    unknown = set(data) - {"gains", "provenance"}
    loose = sorted(k for k in unknown if not isinstance(data[k], dict))  # keys above any table, not tables
    if loose:
        one = len(loose) == 1
        said = f"{', '.join(loose)} {'is a key' if one else 'are keys'} at the top of the file, outside any table"
        them = "it" if one else "them"
        if set(loose) <= set(GAIN_KEYS):
            raise ConfigError(f"{where}: {said}; put {them} under [gains]: write a line '[gains]' above {them}")
        raise ConfigError(
            f"{where}: {said}; a gains file holds only the tables [gains] ({', '.join(GAIN_KEYS)}) and [provenance]: "
            f"move {them} into one, or delete {them}"
        )
    if unknown:
        raise ConfigError(f"{where}: unknown table(s) {', '.join(sorted(unknown))}; allowed: [gains], [provenance]")
    table = data.get("gains")
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: missing [gains] table; write e.g. '[gains]' then 'kp = 9.0' and 'kd = 6.0'")
    bad_keys = set(table) - set(GAIN_KEYS)
    if bad_keys:
        raise ConfigError(f"{where}: unknown gain(s) {', '.join(sorted(bad_keys))}; allowed: {', '.join(GAIN_KEYS)}")
    values: dict[str, float] = {}
    for key in GAIN_KEYS:
        if key not in table:
            if key == "xi_min":
                continue
            raise ConfigError(f"{where}: [gains] has no {key}; add '{key} = <positive number>'")
        values[key] = check_number(f"{where}: [gains] {key}", table[key], above=0.0, fix="the error dynamics need it")
    prov = data.get("provenance", {})
    if not isinstance(prov, dict):
        raise ConfigError(f"{where}: provenance must be a table ([provenance]), got {type(prov).__name__}")
    if "study" in prov and not isinstance(prov["study"], str):
        raise ConfigError(f"{where}: [provenance] study must be a string, got {prov['study']!r}")
    if "objective" in prov:
        check_number(f"{where}: [provenance] objective", prov["objective"])
    if "scenarios" in prov:
        sc = prov["scenarios"]
        if not (isinstance(sc, list) and all(isinstance(s, str) for s in sc)):
            raise ConfigError(f"{where}: [provenance] scenarios must be a list of strings, got {sc!r}")
    check_provenance(f"{where}: provenance", prov)
    return GainsFile(FBLGains(**values), dict(prov))


def load_gains_file(path: str | Path) -> GainsFile:
    """Read a gains file.

    Raises:
        ConfigError: The file cannot be read or is malformed (see :func:`parse_gains_toml`).
    """
    p = Path(path)
    try:
        text = read_input_text(p)  # once (a pipe cannot be read again); a byte-order mark is dropped
    except OSError as exc:
        raise ConfigError(f"cannot read gains file {p}: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"gains file {p} is not UTF-8 text (a TOML file with a [gains] table)") from exc
    return parse_gains_toml(text, where=str(p))


def resolve_gains(text: str, folder: Path | None = None) -> FBLGains:
    """Gains from a ``--gains`` argument: ``"KP,KD"`` or the path of a gains file (relative to ``folder`` when
    given, e.g. a regression suite file's; else to the working directory).

    Raises:
        ConfigError: Neither two positive numbers nor a readable, valid gains file (nor text at all).
    """
    if not isinstance(text, str):
        raise ConfigError(
            f"resolve_gains takes text, 'KP,KD' (e.g. '9,6') or a gains file's path, got {text!r:.80}; "
            "FBLGains(kp=9, kd=6) makes gains without text"
        )
    p = Path(text) if folder is None else folder / text
    if p.suffix == ".toml" or p.exists():
        return load_gains_file(p).gains
    if "," not in text:
        raise ConfigError(
            f"{option('gains', text, python='resolve_gains({})')}: neither 'KP,KD' (e.g. 9,6) nor an existing gains "
            "file (.toml)"
        )
    return FBLGains.parse(text)


#: The escapes of a TOML basic string besides ``\\uXXXX``, which writes every other control character.
TOML_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string: quoted, with the quote, the backslash and every control character
    (U+0000 to U+001F, U+007F) escaped, as TOML requires (a raw one is an invalid file)."""
    out = []
    for ch in text:
        if ch in TOML_ESCAPES:
            out.append(TOML_ESCAPES[ch])
        elif ch < " " or ch == "\x7f":
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml_value(value: Any) -> str:
    """A provenance value (checked: :func:`check_provenance`) as TOML."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        number = float(value)
        if not math.isfinite(number):
            raise ConfigError(f"cannot write a non-finite number {value!r} to a gains file")
        return repr(number)
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, TOML_TIMES):
        return value.isoformat()
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items()) + " }"
    raise ConfigError(f"cannot write a {type(value).__name__} to a gains file")


def _toml_key(key: str) -> str:
    """A key as TOML writes it: bare when it is only ASCII letters, digits, ``_`` and ``-``, else quoted."""
    return key if BARE_KEY.fullmatch(key) else toml_string(key)


def dump_gains_toml(gains_file: GainsFile) -> str:
    """TOML text of a gains file; :func:`parse_gains_toml` reads it back exactly (floats by repr, text with TOML's
    escapes: a quote, a backslash or a control character in a provenance string or key reads back as written).

    Raises:
        ConfigError: ``gains_file`` is not a :class:`GainsFile`.
    """
    if not isinstance(gains_file, GainsFile):
        raise ConfigError(
            f"dump_gains_toml: gains_file must be a GainsFile: pass GainsFile(FBLGains(...), provenance), got "
            f"{type(gains_file).__name__} {gains_file!r:.80}"
        )
    g = gains_file.gains
    lines = [
        "# nhsim FBL tracker gains (read by: nhsim simulate --gains FILE)",
        "[gains]",
        f"kp = {g.kp!r}  # position error gain [1/s^2]",
        f"kd = {g.kd!r}  # velocity error gain [1/s]",
        f"xi_min = {g.xi_min!r}  # singularity guard [m/s]",
    ]
    if gains_file.provenance:
        lines += ["", "[provenance]"]
        lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in gains_file.provenance.items()]
    return "\n".join(lines) + "\n"
