"""Start-up: the command line imports no numerics before a command needs them (sys.modules, not timing)."""

import subprocess
import sys

import pytest

HEAVY = ("mujoco", "numba", "scipy", "casadi", "matplotlib", "numpy", "optuna", "dask")


def _imported(code: str) -> list[str]:
    """The HEAVY packages a fresh interpreter has imported after running ``code``."""
    probe = f"{code}\nimport sys\nprint('LOADED', *(m for m in {HEAVY!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return out.stdout.splitlines()[-1].split()[1:]


def test_importing_the_command_line_imports_no_numerics():
    assert _imported("import sim.cli.main") == []
    assert _imported("import planning, control, sim") == []


@pytest.mark.parametrize("argv", [["--version"], ["--help"], []])
def test_version_and_help_import_no_numerics(argv):
    code = f"from sim.cli.main import main\ntry:\n    main({argv!r})\nexcept SystemExit:\n    pass"
    assert _imported(code) == []


def test_no_commands_help_imports_numba_or_what_runs_the_work():
    """``nhsim plan --help`` (every command's and benchmark's) took 0.33-0.37 s of which numba's import, with
    SciPy's, was 0.15-0.25 s: the planners' base imported the plan clock, and the value types' module the array
    copy kernels. 0.11-0.14 s now; numpy, which the parsers' planner and robot names come with, stays."""
    from sim.cli.bench import BENCHMARKS
    from sim.cli.main import COMMANDS

    helps = [[name, "--help"] for name in COMMANDS] + [["bench", name, "--help"] for name in BENCHMARKS]
    code = (
        "import contextlib, io\nfrom sim.cli.main import main\n"
        f"for argv in {helps!r}:\n"
        "    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
        "        main(argv)"
    )
    assert set(_imported(code)) <= {"numpy"}


def test_plan_imports_neither_mujoco_nor_plotting():
    code = (
        "from sim.cli.main import main\n"
        "main(['plan', '--scenario', 'nav_map1', '--planner', 'hybrid-a-star', '--quiet', '--time-limit', '20'])"
    )
    loaded = _imported(code)
    assert "numba" in loaded  # it did plan
    assert not {"mujoco", "matplotlib", "casadi", "optuna", "dask"} & set(loaded)


def test_the_overview_lists_every_command_with_its_summary():
    from sim.cli.main import COMMANDS, build_parser, summary

    text = build_parser([]).format_help()
    for name, module in COMMANDS.items():
        assert name in text
        assert summary(module) and summary(module).split()[0] in text
    assert summary("sim.cli.plan").startswith("plan a scenario with a registered planner")
