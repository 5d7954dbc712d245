"""Checks of the options several commands share: each names the flag and the fix (exit 2)."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Sequence
from pathlib import Path, PurePath
from typing import Any

from planning.core.checks import check_number
from planning.errors import ConfigError


def comma_list(text: str, file_of: Callable[[str], str] = str) -> list[str]:
    """The items of a comma-separated list of names or files, stripped, empty ones dropped; a run of items that,
    joined by their commas, names an existing file is that one file (``--scenario a,b.toml`` with a file named
    ``a,b.toml``: split at every comma, it was ``a`` and ``b.toml``), the longest such run first.

    Args:
        text: The option's value.
        file_of: The file part of an item (``Case.split``'s scenario of ``SCENARIO:PLANNER``); the item whole
            by default.
    """
    parts = text.split(",")
    items: list[str] = []
    i = 0
    while i < len(parts):
        end = next((j for j in range(len(parts), i + 1, -1) if _names_a_file(",".join(parts[i:j]), file_of)), i + 1)
        items.append(",".join(parts[i:end]).strip())
        i = end
    return [item for item in items if item]


def case_list(text: str) -> list[str]:
    """The ``SCENARIO[:REFERENCE|:PLANNER]`` cases of a comma list (``tune --scenarios``): :func:`comma_list` with
    each case's scenario as its file part."""
    from sim.pipeline.case import Case

    return comma_list(text, lambda token: Case.split(token)[0])


def _names_a_file(run: str, file_of: Callable[[str], str]) -> bool:
    """Whether items joined by their commas, ``run``, are one item naming an existing file: its file part exists
    and holds every comma (``b.toml:line,open`` is two items though ``b.toml`` exists)."""
    run = run.strip()
    file = file_of(run)
    return run.startswith(file) and "," not in run[len(file) :] and os.path.isfile(file)


def check_time_limit(seconds: float) -> None:
    """Raise :class:`ConfigError` unless the ``--time-limit`` planning budget [s] is a finite number > 0."""
    check_number("--time-limit", seconds, above=0.0, unit="s, the planning budget", fix="pass e.g. --time-limit 30")


def check_seeds(**flags: int | None) -> None:
    """Raise :class:`ConfigError` unless every seed given (``flag_name=value``, ``None`` for one not given)
    is >= 0, naming the flag: ``check_seeds(seed=args.seed)`` checks ``--seed``."""
    for name, value in flags.items():
        if value is not None:
            flag = "--" + name.replace("_", "-")
            check_number(flag, value, integer=True, at_least=0, fix=f"pass e.g. {flag} 0")


def check_at_least(counts: dict[str, tuple[int, int]]) -> None:
    """Raise :class:`ConfigError` naming the first flag whose count is below its least value:
    ``counts`` maps a flag (``"--repeats"``) to ``(value, least)``."""
    for flag, (value, least) in counts.items():
        check_number(flag, value, integer=True, at_least=least)


#: Most seeded random worlds a bench takes (each one is planned, by every planner it races, before any row is
#: printed: 10^8 of them grew the process by hundreds of MB without a line).
MOST_WORLDS = 1000


def check_worlds(flag: str, count: int) -> None:
    """Raise :class:`ConfigError` unless a bench's count of random worlds is in [0, :data:`MOST_WORLDS`]."""
    check_number(flag, count, integer=True, at_least=0, at_most=MOST_WORLDS, fix="each one is planned before the table")


def check_once(flag: str, names: Sequence[str] | None) -> None:
    """Raise :class:`ConfigError` when a list option names one item twice: a bench's problem or planner given twice
    is raced twice and weighs twice in its medians (``--scenarios farm farm``)."""
    seen: set[str] = set()
    for name in names or ():
        if name in seen:
            raise ConfigError(f"{flag} names {name!r} twice; give each once (a repeated one would weigh twice)")
        seen.add(name)


def check_something_to_plan(flag: str, scenarios: Sequence[Any]) -> None:
    """Raise :class:`ConfigError` for a bench's scenario (or planning problem: its ``start``, ``goal`` and ``name``)
    whose goal is its start (:func:`sim.pipeline.case.nothing_to_plan`): its plan is the start alone, and a ratio
    of lengths divides by zero there."""
    from sim.pipeline.case import nothing_to_plan

    for scenario in scenarios:
        if nothing_to_plan(scenario):
            raise ConfigError(
                f"{flag}: scenario {scenario.name!r} has nothing to plan (its goal is its start); drop it, or choose "
                "a scenario whose goal lies elsewhere"
            )


def check_control_rate(hz: float) -> None:
    """Raise :class:`ConfigError` unless ``--control-rate`` [Hz] is a finite number > 0 (whether it divides
    the physics rate is the simulator's check)."""
    check_number("--control-rate", hz, above=0.0, unit="Hz", fix="pass e.g. --control-rate 50")


def refuse_blank_values(parser: argparse.ArgumentParser) -> None:
    """Make every option of ``parser`` (and of its subcommands) that takes text refuse an empty or blank
    value, naming the option and what to give: ``--gains ''`` was read as "not given" (the defaults ran),
    ``--json ''`` as the folder ``.``. Options of numbers or choices refuse it already."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in dict.fromkeys(action.choices.values()):
                refuse_blank_values(sub)
        elif action.option_strings and action.nargs != 0 and action.choices is None and _takes_text(action.type):
            action.type = _not_blank(action)


def _takes_text(kind: object) -> bool:
    return kind is None or kind is str or (isinstance(kind, type) and issubclass(kind, PurePath))


def _not_blank(action: argparse.Action) -> Callable[[str], Any]:
    """``action``'s type, refusing a blank value first, and for an output file (metavar ``PATH``) a value
    ending in a separator, which ``Path`` would read as a file named like the folder, one ending in ``.`` or
    ``..`` (a folder: ``sub/.`` was read as a file ``sub``, and ``.`` has no name to put a sibling's suffix on),
    and ``-``, which commonly means the standard output (it wrote a file named '-'; argparse reports the message
    as ``argument --X: ...``)."""
    convert = action.type if callable(action.type) else str
    metavar = action.metavar if isinstance(action.metavar, str) else action.dest.upper()
    leave = "" if action.required else f", or leave {action.option_strings[0]} out"

    def read(text: str) -> Any:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"the value is empty; give {metavar}{leave}")
        if metavar == "PATH" and text.endswith(("/", os.sep)):  # an output file: Path() drops the separator
            raise argparse.ArgumentTypeError(f"{text} ends in a separator, a folder; give a file name in it")
        if metavar == "PATH" and text.replace(os.sep, "/").rsplit("/", 1)[-1] in (".", ".."):  # Path() drops a "."
            raise argparse.ArgumentTypeError(f"{text} names a folder; give a file name in it")
        if metavar == "PATH" and text == "-":  # an output file: not the standard output, which has the report
            raise argparse.ArgumentTypeError(
                "'-' is no file: the outputs are written to files (the standard output has the report); give a "
                "file name, or ./- for a file named '-'"
            )
        return convert(text)

    return read


def check_file_stem(stem: str, flag: str, example: str, suffixes: tuple[str, ...]) -> None:
    """Raise :class:`ConfigError` when ``flag``'s file stem (``STEM`` of ``STEM-paths.png``) names a folder: an
    existing one, or a path ending in a separator, which would write files named ``-paths.png`` inside it.

    Args:
        stem: The value given.
        flag: The option, e.g. ``"--plots"``.
        example: A stem to suggest, e.g. ``"renders/cmp"``.
        suffixes: What the command adds to the stem, e.g. ``("-paths.png", "-errors.png")``.
    """
    if stem.endswith(("/", os.sep)) or Path(stem).is_dir():
        made = " and ".join(f"{example}{s}" for s in suffixes)
        raise ConfigError(f"{flag} {stem} names a folder; {flag} takes a file stem, e.g. {example} (writes {made})")
    from sim.outputs import IMAGE_FORMATS

    suffix = Path(stem).suffix
    if suffix[1:].lower() in IMAGE_FORMATS:
        bare = stem[: -len(suffix)]
        made = " and ".join(f"{bare}{s}" for s in suffixes)
        raise ConfigError(
            f"{flag} {stem} ends in a file type; {flag} takes a file stem, the names are made from it: {flag} {bare} "
            f"writes {made} (it would have written {stem}{suffixes[0]})"
        )


#: ``--planner-option``'s form, quoted in its help and messages.
PLANNER_OPTION_EXAMPLE = "max_iter=500"


def add_planner_option_argument(p: argparse.ArgumentParser) -> None:
    """``--planner-option KEY=VALUE`` (repeatable): a planner's option, over a scenario's ``[planners.<name>]``."""
    p.add_argument(
        "--planner-option",
        action="append",
        default=None,
        metavar="KEY=VALUE",
        help="an option of the planner, over the scenario's [planners.<name>] table; repeatable; the value is read "
        f'as in TOML (500, 0.25, true, "text"; bare text is text), e.g. --planner-option {PLANNER_OPTION_EXAMPLE} '
        "for optim (each planner's options: docs/explanation/planners.md) (default: the scenario's own options only)",
    )


def planner_option_values(texts: list[str] | None) -> dict[str, Any]:
    """The ``--planner-option`` texts as keyword options, each value read as a TOML value (a bare word that is
    no TOML value is text); the planner checks the names and values when it is made.

    Raises:
        ConfigError: A text without ``=``, with no key, or a key given twice.
    """
    import tomllib

    out: dict[str, Any] = {}
    for text in texts or []:
        key, sep, value = (part.strip() for part in text.partition("="))
        if not sep or not key:
            raise ConfigError(
                f"--planner-option {text!r}: expected KEY=VALUE, e.g. --planner-option {PLANNER_OPTION_EXAMPLE}"
            )
        if key in out:
            raise ConfigError(f"--planner-option: {key!r} is given twice; give each option once")
        if key == "time_limit":  # the command's own budget, said in its header and record
            raise ConfigError(f"--planner-option {text!r}: the planning budget is --time-limit; give --time-limit S")
        if key == "config":  # a planner's whole configuration object: the Python API's, no text gives one
            raise ConfigError(
                f"--planner-option {text!r}: config is a configuration object of the Python API; give its fields "
                f"one by one, e.g. --planner-option {PLANNER_OPTION_EXAMPLE}"
            )
        try:
            out[key] = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError:
            out[key] = value  # a bare word: text (e.g. init=hybrid-a-star)
    return out


def robot_name(text: str) -> str:
    """``--robot``'s value when it names a registered robot (the plugins' too: they load when a ``--robot`` is
    given, not for ``--help``).

    Raises:
        argparse.ArgumentTypeError: Any other (exit 2), listing the robots and how a plugin's is registered.
    """
    from planning.core.robot import check_robot_name

    if not text.strip():
        raise argparse.ArgumentTypeError("the value is empty; give R, or leave --robot out")
    try:  # loads the plugins: one that fails is said as itself (argparse says "invalid robot_name value" of others)
        return check_robot_name("", text)
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from exc


def add_robot_argument(p: argparse.ArgumentParser, help: str, default: str | None = None) -> None:
    """``--robot NAME`` (checked by :func:`robot_name`); its help lists the built-in robots without loading a
    plugin, and says a plugin's is accepted too."""
    from planning.core.robot import ROBOTS

    p.add_argument(
        "--robot",
        type=robot_name,
        default=default,
        metavar="R",
        help=f"{help}; R: {', '.join(ROBOTS.built_in())} or a plugin's robot (docs/how-to/new-robot.md)",
    )
