"""Parsing and checking of ``key=value,...`` option strings (``--perturb``, ``--sensors``).

The command-line options that change a run's physics or sensors take comma-separated
``key=value`` pairs; these helpers split such a string and read its numbers, raising
:class:`~planning.errors.ConfigError` with a message that names the option, the bad key or value and
what is expected. A number's range is checked by :func:`planning.core.checks.check_number`.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

from planning.errors import ConfigError


def parse_pairs(text: str, what: str, keys: Iterable[str], example: str, form: str = "key=value") -> dict[str, str]:
    """Split ``key=value,...`` into a dict of stripped strings (empty parts are skipped).

    Args:
        text: The option's text, e.g. ``"friction=0.6,mass=1.3"``.
        what: The option with its text as messages lead with it, e.g. ``option("perturb", text)``
            (:func:`planning.errors.option`).
        keys: The keys allowed.
        example: A valid text, quoted in the message when a part is malformed.
        form: How a part is written, as the message says it (e.g. ``key=lo:hi`` for ranges).

    Returns:
        Key -> value text, in the order given.

    Raises:
        ConfigError: A part without ``=``, an unknown key (named, with the allowed key it is closest to) or a
            key given twice.
    """
    allowed = list(keys)
    out: dict[str, str] = {}
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        key, sep, value = part.partition("=")
        key = key.strip()
        if not sep or key not in allowed:
            unknown = f"unknown key {key!r}{did_you_mean(key, allowed)}; " if sep else ""
            raise ConfigError(
                f"{what}: {unknown}expected comma-separated {form} with keys {', '.join(allowed)} "
                f"(e.g. {example}), got {part!r}"
            )
        if key in out:
            raise ConfigError(f"{what}: {key} given twice")
        out[key] = value.strip()
    return out


def parse_number(text: str, key: str, what: str) -> float:
    """``float(text)``, or a :class:`ConfigError` naming ``key`` and the option ``what``."""
    try:
        return float(text)
    except ValueError:
        raise ConfigError(f"{what}: {key} must be a number, got {text!r}") from None  # float()'s own error adds nothing


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """`` (did you mean 'CHOICE'?)`` naming the choice closest to a mistyped ``word``, or "" when none is close."""
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
