"""The ``nhsim`` command line.

Each subcommand lives in its own module under ``sim/cli/`` with two functions:
``add_parser(subparsers) -> argparse.ArgumentParser`` and ``run(args) -> int``. The table below is
the whole registry; the CLI, the help text and the tests enumerate it.

A command's module is imported only when that command is named (to build its parser and run it):
``nhsim --version`` and ``nhsim --help`` import none of them (the overview lists each command with
the first line of its module's docstring, read from the file) and no numerics at all, and a command
loads only what it uses. Building a parser must not import mujoco: :func:`main` chooses MuJoCo's GL
backend first (:func:`sim.viz.gl.configure` with the command's ``--gl``, else ``MUJOCO_GL`` or the
default).
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import gc
import importlib
import importlib.util
import io
import os
import re
import signal
import sys
import warnings
from collections.abc import Collection, Sequence
from typing import Any, NoReturn, TextIO

from planning.errors import NhsimError, PlannerError, SimulationError, without_python
from sim.outputs import UNNAMED_WRITE_ERRNOS

#: Subcommand name -> module path.
COMMANDS: dict[str, str] = {
    "simulate": "sim.cli.simulate",
    "compare": "sim.cli.compare",
    "bench": "sim.cli.bench",
    "scenarios": "sim.cli.scenarios",
    "plan": "sim.cli.plan",
    "tune": "sim.cli.tune",
    "regress": "sim.cli.regress",
    "montecarlo": "sim.cli.montecarlo",
}


def package_version() -> str:
    """The installed ``nhsim`` distribution's version, or "unknown (not installed)" when run from a
    source tree that was never installed."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("nhsim")
    except PackageNotFoundError:
        return "unknown (not installed)"


#: One number or several, comma-separated, the first negative: what a value of nhsim's options looks like.
_NEGATIVE_NUMBERS = re.compile(r"^-\d*\.?\d+(?:[eE][-+]?\d+)?(?:,\s*[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?)*$")


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose usage errors are one line, as nhsim's own (argparse printed the whole usage, up to
    21 lines, before it; ``--help`` shows it); numbers that start with a minus are a value (``--initial-pose
    -1.4,-2.4,1.2``, ``--gains -1,7``), and its "expected one argument" says how to give any other value that starts
    with '-' (``--scenario=-odd.toml``). Options are not
    abbreviated (argparse took ``--over`` for ``--overwrite``, the one switch that lets a file be replaced): every
    command's parser is this class, made without abbreviations."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)
        # a value of numbers that starts with a minus is a value, not an option: --initial-pose -1.4,-2.4,1.2 and
        # --offset -1,0,0 as argparse reads -1.4 (nhsim has no option that looks like a number)
        self._negative_number_matcher = _NEGATIVE_NUMBERS

    def error(self, message: str) -> NoReturn:
        found = re.match(r"argument (--[\w-]+)(?:/\S+)?: expected one argument$", message)
        if found:
            message += f" (a value that starts with '-' goes after '=': {found.group(1)}=VALUE)"
        kind = re.search(r"^argument (--[\w-]+)(?:/\S+)?: invalid (int|float) value: '.*'$", message)
        if kind:  # argparse names the type alone: the option's default is an example it takes (--fps refuses 0.5)
            example = getattr(self._option_string_actions.get(kind.group(1)), "default", None)
            whole = kind.group(2) == "int"
            if isinstance(example, bool) or not isinstance(example, int if whole else int | float):
                example = 3 if whole else 0.5  # no number as default (None)
            message += f"; give {'a whole number' if whole else 'a number'}, e.g. {example:g}"
        self.exit(2, f"{self.prog}: error: {message}\n")


class _Version(argparse.Action):
    """``--version``: print ``nhsim VERSION`` and exit (the version is looked up only then)."""

    def __init__(self, option_strings: Sequence[str], dest: str, **kwargs: object) -> None:
        super().__init__(option_strings, dest, nargs=0, help=str(kwargs.get("help", "")))

    def __call__(self, parser: argparse.ArgumentParser, *_: object) -> None:
        print(f"{parser.prog} {package_version()}")  # on stdout, as argparse's own version action
        parser.exit()


def summary(module: str) -> str:
    """The first line of a command module's docstring without its ``nhsim NAME``: prefix, read from
    its file (the module is not imported)."""
    spec = importlib.util.find_spec(module)
    origin = spec.origin if spec is not None else None
    if origin is None:
        return ""
    with open(origin, encoding="utf-8") as f:
        head = f.read(2000)
    found = re.match(r'\s*[rRuU]?"""(.*?)(?:\n|""")', head, re.S)
    line = found.group(1).strip() if found else ""
    return re.sub(r"^``nhsim [\w-]+``:\s*", "", line)


def build_parser(commands: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The top-level parser. The commands named in ``commands`` (None: every one) get their full
    parser, built by their module; the others are listed with their :func:`summary` only."""
    parser = _Parser(
        prog="nhsim",
        description="Plan, track and simulate nonholonomic wheeled robots (TurtleBot3, EduMIP) in MuJoCo.",
    )
    parser.add_argument("--version", action=_Version, help="show the installed version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module in COMMANDS.items():
        if commands is not None and name not in commands:
            sub.add_parser(name, help=summary(module)).set_defaults(_module=module)
            continue
        p = importlib.import_module(module).add_parser(sub)
        p.set_defaults(_module=module)
        assert p.prog.endswith(name)
    from sim.cli.checks import refuse_blank_values

    refuse_blank_values(parser)  # one rule for every command's text options: empty is no value
    return parser


def named_command(argv: Sequence[str]) -> str | None:
    """The command ``argv`` names (its first word that is not an option), or None."""
    first = next((a for a in argv if not a.startswith("-")), None)
    return first if first in COMMANDS else None


class _ReaderGone(io.TextIOBase):
    """The command's standard output: when its reader goes away (``nhsim simulate ... | head -3``), what it
    prints after goes nowhere, and the command goes on to write its outputs (it stopped at the next print,
    and the run's record, plots and video were lost or kept by chance). Each write is flushed, so a closed
    pipe is found at the print that meets it, not at exit. A standard output that cannot be written for
    another reason (a full disk, ``>/dev/full``; none at all, ``>&-``) is the same for the command, which
    then ends with status 1 once its outputs are written (:attr:`failed` says why); text the output's
    encoding cannot hold (``PYTHONIOENCODING=ascii``) is written with backslash escapes."""

    def __init__(self, stream: TextIO | None) -> None:
        self.stream = stream
        #: Whether the reader went away (or there is no standard output).
        self.gone = stream is None
        #: Why the standard output could not be written, other than a reader gone ("" when it could).
        self.failed = "" if stream is not None else "there is no standard output (it was closed)"

    def write(self, text: str) -> int:
        if not self.gone and self.stream is not None:
            try:
                try:
                    self.stream.write(text)
                except UnicodeEncodeError:
                    encoding = self.stream.encoding or "ascii"
                    self.stream.write(text.encode(encoding, "backslashreplace").decode(encoding))
                self.stream.flush()
            except BrokenPipeError:
                self._away()
            except OSError as exc:  # a full disk, an I/O error: nothing more can be printed
                self.failed = f"its standard output could not be written ({exc.strerror or exc})"
                self._away()
            except ValueError:  # the stream closed (a library that kept this object past the command)
                self.gone = True
        return len(text)

    def flush(self) -> None:
        if not self.gone and self.stream is not None:
            try:
                self.stream.flush()
            except BrokenPipeError:
                self._away()
            except OSError as exc:
                self.failed = f"its standard output could not be written ({exc.strerror or exc})"
                self._away()
            except ValueError:
                self.gone = True

    def _away(self) -> None:
        self.gone = True
        with contextlib.suppress(OSError, ValueError, AttributeError):  # what is still buffered goes nowhere
            os.dup2(os.open(os.devnull, os.O_WRONLY), self.stream.fileno())  # type: ignore[union-attr]

    def isatty(self) -> bool:
        try:
            return not self.gone and self.stream is not None and self.stream.isatty()
        except ValueError:  # closed
            return False

    def fileno(self) -> int:
        if self.stream is None:
            raise io.UnsupportedOperation("there is no standard output")
        return self.stream.fileno()

    @property
    def encoding(self) -> str:  # type: ignore[override]
        return self.stream.encoding if self.stream is not None else "utf-8"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``nhsim`` console script; returns the process exit code.

    Exit codes: 0 success, 1 a run or check failed (a run failed its checks, a benchmark missed its
    target, a planner ended without a path or its plan could not be made into a trajectory),
    2 bad input (usage or a clear error message), 130 interrupted (Ctrl-C, SIGTERM or SIGHUP, handled alike
    for the whole command: :mod:`sim.cli.interrupt`), 141 its standard output closed before it was
    done (``nhsim plan ... | head -3``: the command prints nothing more but does the rest of its work, its
    outputs written, and then exits as one killed by SIGPIPE would; a failure's own code stands).
    """
    from sim.cli.interrupt import sigterm_as_interrupt

    out = _ReaderGone(sys.stdout)
    # stderr alike: with ``2>&1 | head -1`` a note printed there after the reader left raised BrokenPipeError,
    # whose traceback went to the same closed pipe, and the command ended with status 1 and no word
    err = _ReaderGone(sys.stderr)
    with sigterm_as_interrupt(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = _main(argv)
        except KeyboardInterrupt:  # before a command was chosen (building the parser, parsing)
            say_interrupted("nhsim: interrupted")
            return 130
        except SystemExit as exc:  # argparse's --help, --version or usage error: printed, or not
            if out.failed and exc.code in (0, None):
                print(f"nhsim: {out.failed}", file=sys.stderr)
                raise SystemExit(1) from None
            raise
    if out.failed and code == 0:
        print(f"nhsim: {out.failed}; its files were written, its printed report was lost", file=sys.stderr)
        return 1
    return 141 if out.gone and code == 0 else code


def console() -> int:
    """The ``nhsim`` console script and ``python -m sim``: :func:`main`, then a quick exit.

    When the command has finished (its outputs written and closed), the objects still alive are
    frozen out of the garbage collector: the interpreter's collections at exit would otherwise walk
    every object numba and the libraries made (about 0.15 s after a plan, more than the plan of a
    small world) only to free memory the process is about to return anyway. An interrupted command
    (130) exits the slow way: what it left half done may still hold a temporary file that only its
    collection removes, and a further Ctrl-C, SIGTERM or SIGHUP meanwhile is ignored (the status stays 130). Tests
    call :func:`main`, which leaves the collector and the signals alone.
    """
    warnings.showwarning = _one_line_own(warnings.showwarning)
    code = main()
    if code != 130:
        gc.freeze()
    else:  # interrupted: another Ctrl-C, SIGTERM or SIGHUP while it exits the slow way (removing what it left)
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):  # changes nothing: ignored, as Python's
            signal.signal(sig, signal.SIG_IGN)  # finalisation keeps it, the status stays 130 (SIGTERM's default
            # ended it with 143, SIGHUP's with 129)
    return code


#: The packages whose warnings the command says as its own lines (``nhsim: ...``).
OWN_PACKAGES = ("sim", "planning", "control", "models")


def _one_line_own(show: Any) -> Any:
    """``warnings.showwarning`` saying a warning of nhsim's own (a class defined in :data:`OWN_PACKAGES`: a MuJoCo
    warning, ``sim.physics.model.MujocoWarning``, a reference beyond the robot's limits, ...) as one line of the
    command's, ``nhsim: ...``, without Python's file and code line; a library's as Python says it."""

    def showwarning(message: Any, category: type[Warning], *args: Any, **kwargs: Any) -> None:
        if category.__module__.split(".")[0] in OWN_PACKAGES:
            print(f"nhsim: {message}", file=sys.stderr)
        else:
            show(message, category, *args, **kwargs)

    return showwarning


def _after_writing() -> str:
    """What an interrupt's line adds when outputs were already placed (:data:`sim.outputs.PLACED`): ", after writing
    A, B and N more"; "" when none was (outputs are placed in one step the interrupt waits for)."""
    placed = sys.modules["sim.outputs"].PLACED if "sim.outputs" in sys.modules else []
    if not placed:
        return ""
    names = ", ".join(str(p) for p in placed[:3]) + (f" and {len(placed) - 3} more" if len(placed) > 3 else "")
    return f", after writing {names}"


def say_interrupted(text: str) -> None:
    """Print ``text`` on stderr, where it may fail: a terminal that hung up (its SIGHUP is an interrupt) takes
    no more writes (EIO). Then the text is lost, and stderr is pointed at /dev/null, so that neither this
    print nor Python's flush at exit turns the status 130 into 1 or 120."""
    try:
        print(text, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, sys.stderr.fileno())
            os.close(null)


def _command_parser(parser: argparse.ArgumentParser, args: argparse.Namespace) -> argparse.ArgumentParser:
    """The parser of the command ``args`` ran (a benchmark's for ``bench NAME``), else ``parser`` itself."""
    for name in (getattr(args, "command", None), getattr(args, "benchmark", None)):
        sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
        if not name or sub is None or name not in sub.choices:
            break
        parser = sub.choices[name]
    return parser


def _main(argv: Sequence[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    command = named_command(argv)
    parser = build_parser([command] if command is not None else [])
    args, extra = parser.parse_known_args(argv)
    if extra:  # said by the command's own parser: "nhsim scenarios: error" (not "nhsim: error")
        _command_parser(parser, args).error(f"unrecognized arguments: {' '.join(extra)}")
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    name = " ".join(filter(None, (args.command, getattr(args, "benchmark", None))))  # ``bench render``
    if "sim.outputs" in sys.modules:  # a program running several commands: this one's outputs only
        sys.modules["sim.outputs"].PLACED.clear()
    try:
        from sim.viz import gl

        gl.configure(getattr(args, "gl", None))  # before the command imports mujoco
        mod = importlib.import_module(args._module)
        return int(mod.run(args))
    except SimulationError as exc:
        _say_failure(f"nhsim {name}: simulation failed: {without_python(str(exc))}", exc)
        return 1
    except NhsimError as exc:
        if _failed_plan(exc):  # a failed plan is a failed run, not bad input (as in ``nhsim plan``)
            _say_failure(f"nhsim {name}: failed: {without_python(str(exc))}", exc)
            return 1
        _say_failure(f"nhsim {name}: error: {without_python(str(exc))}", exc)
        return 2
    except KeyboardInterrupt as exc:  # a command may say what it kept and how to go on (``nhsim_note``)
        say_interrupted(f"nhsim {name}: interrupted{getattr(exc, 'nhsim_note', '')}{_after_writing()}")
        return 130
    except OSError as exc:
        if exc.errno not in WRITE_FAILURES:
            raise
        print(f"nhsim {name}: failed: {could_not_write(exc, args.command)}", file=sys.stderr)
        return 1


#: Set to 1, a command that fails because code it ran raised an exception of its own (a plugin's planner or tracker,
#: a library nhsim calls) prints that exception's traceback after its one-line error.
TRACEBACK_ENV = "NHSIM_TRACEBACK"


def _say_failure(line: str, exc: NhsimError) -> None:
    """Print a command's one-line error ``line`` for ``exc`` on stderr. When ``exc`` was raised from another
    exception than nhsim's own (``raise ... from``: a plugin's planner raised, say), the line says how to see where,
    and with :data:`TRACEBACK_ENV` set that exception's traceback follows it."""
    cause = exc.__cause__
    quiet = os.environ.get(TRACEBACK_ENV, "") in ("", "0")
    if cause is None or isinstance(cause, NhsimError) or (quiet and _input_failure(cause)):
        print(line, file=sys.stderr)
    elif quiet:
        print(f"{line} ({TRACEBACK_ENV}=1 prints the {type(cause).__name__}'s traceback)", file=sys.stderr)
    else:
        import traceback

        print(line, file=sys.stderr)
        traceback.print_exception(cause, file=sys.stderr)


def _input_failure(cause: BaseException) -> bool:
    """Whether ``cause`` is reading a user's file failing (missing, unreadable, not UTF-8, not valid TOML, JSON
    or YAML): the line says what and where, and a traceback of the reader would tell the user nothing more."""
    import json
    import tomllib

    readers: tuple[type[BaseException], ...] = (OSError, UnicodeError, tomllib.TOMLDecodeError, json.JSONDecodeError)
    yaml = sys.modules.get("yaml")  # loaded only where a YAML file was read
    if yaml is not None:
        readers += (yaml.YAMLError,)
    return isinstance(cause, readers)


def could_not_write(exc: OSError, command: str = "") -> str:
    """What a full disk (or quota, a file too large, an I/O error: :data:`WRITE_FAILURES`) met while writing
    says: the file (as the user named it: a staged output's path is shown as its target's,
    :func:`sim.outputs.shown`), why, what is left, and the fix. Outputs are written under temporary names and
    placed only once complete, so none was written or replaced; ``command``'s incremental record (:data:`KEPT`)
    keeps what it held."""
    from sim.outputs import shown

    what = f" {shown(os.fsdecode(exc.filename))}" if exc.filename else ""
    kept = f" ({KEPT[command]})" if command in KEPT else ""
    return (
        f"could not write{what}: {exc.strerror or exc}; no output was written or replaced{kept}: free space (or "
        "give a path on another disk) and run it again"
    )


#: What a command that records as it goes keeps when a write fails (:func:`could_not_write`).
KEPT = {
    "montecarlo": "the runs already in its results file are kept, and the same command resumes",
    "tune": "the trials already in its study are kept, and the same command resumes",
}


#: Why a file could not be written that is the machine's, not the command's input: a full disk or quota, a file too
#: large (the write errors the outputs name, :data:`sim.outputs.UNNAMED_WRITE_ERRNOS`), an I/O error (one line, exit
#: status 1, as a failed run; a path that cannot be written at all is bad input, refused before the run).
WRITE_FAILURES = frozenset({errno.EIO}) | UNNAMED_WRITE_ERRNOS


def _failed_plan(exc: BaseException) -> bool:
    """Whether ``exc`` is a failed plan, not bad input: a :class:`planning.errors.PlannerError` (a planner's
    code failed) or a :class:`planning.trajectory.from_plan.TrajectoryError` (its module is looked up, not
    imported: an error of that class means it is loaded)."""
    module = sys.modules.get("planning.trajectory.from_plan")
    return isinstance(exc, PlannerError) or (module is not None and isinstance(exc, module.TrajectoryError))


if __name__ == "__main__":
    raise SystemExit(main())
