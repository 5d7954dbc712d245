"""Bad input gets one clear error naming the problem and the fix (exit 2 from the command line, no traceback), and
nothing is lost silently: a Monte Carlo results file, the kernel cache, MUJOCO_GL, ``bench plan --quick``, YAML
paths and bag metadata, gains files, map images and regression baselines."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from planning.errors import ConfigError, ScenarioError
from planning.trajectory.file_formats import TrajectoryFileError, read_table
from sim.cli.main import main
from sim.tools.montecarlo import ResultsFile

ROOT = Path(__file__).resolve().parents[1]
KEY = {"scenario": "open", "seed": 0}


# ------------------------------------------------------------------------------------- montecarlo results
def _record(index: int, seeds: list[dict[str, Any]] | None = None) -> str:
    """A failed plan's record of run ``index`` (with ``seeds``, a study's :meth:`record_seeds`, its seeds)."""
    rec = {"plan_seed": 0, "noise_seed": index, "build_seed": None, "perturbation": None}
    return json.dumps({"index": index, **(rec if seeds is None else seeds[index]), "failed": "PlanError: none"})


def _results(tmp_path: Path, lines: list[str], end: str = "\n") -> Path:
    path = tmp_path / "mc.jsonl"
    header = json.dumps({"nhsim_montecarlo": 1, "key": KEY, "code": "c0de"})
    path.write_text("\n".join([header, *lines]) + end)
    return path


@pytest.mark.parametrize(
    ("bad", "problem"),
    [
        ('{"broken": 1,', "line 3: not a JSON record"),
        ('{"foo": 1}', "line 3: a record without 'index', 'plan_seed', 'noise_seed', 'build_seed', 'perturbation'"),
        ("[1, 2]", "line 3: a JSON list, not a run record"),
        (_record(1).replace('"index": 1', '"index": "1"'), "line 3: its index '1' is not a run number"),
        (_record(1).replace(', "failed": "PlanError: none"', ""), "line 3: run 1 has neither 'failed' nor"),
    ],
)
def test_a_results_line_that_is_no_record_is_refused_and_nothing_is_cut(tmp_path: Path, bad: str, problem: str) -> None:
    # a corrupt line 2 of 3 cut the file back to its header, deleting the valid runs after it (rc 0, no word);
    # {"foo": 1} crashed with KeyError 'index'
    path = _results(tmp_path, [_record(0), bad, _record(2)])
    before = path.read_bytes()
    with pytest.raises(ConfigError) as err:
        ResultsFile(path, KEY, code="c0de")
    said = str(err.value)
    assert said.startswith(f"{path}, {problem}"), said
    assert "repair or delete that line" in said and "--overwrite" in said
    assert path.read_bytes() == before


def test_only_a_last_line_cut_short_is_dropped_and_said(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _results(tmp_path, [_record(0), _record(1), _record(2)[:20]], end="")
    results = ResultsFile(path, KEY, code="c0de")
    assert sorted(results.records) == [0, 1]
    assert path.read_text().splitlines()[1:] == [_record(0), _record(1)]
    [note] = results.notes  # the command says it (test_montecarlo_refuses_a_damaged_results_file_with_status_2)
    assert note.startswith(f"{path}: dropped its last line (line 4, 20 bytes cut short") and "done again" in note
    # a whole last record without its newline is kept, ended, so that the next one starts a line
    whole = _results(tmp_path, [_record(0), _record(1)], end="")
    kept = ResultsFile(whole, KEY, code="c0de")
    assert sorted(kept.records) == [0, 1] and kept.notes == []
    assert whole.read_text().endswith(_record(1) + "\n")
    # a last line that is cut short but has its newline was not cut by an interrupted append: refused
    ended = _results(tmp_path, [_record(0), _record(1)[:20]])
    with pytest.raises(ConfigError, match=r"line 3: not a JSON record"):
        ResultsFile(ended, KEY, code="c0de")


def test_montecarlo_refuses_a_damaged_results_file_with_status_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from sim.cli.main import build_parser
    from sim.cli.montecarlo import _spec
    from sim.tools.digests import code_digest

    monkeypatch.chdir(tmp_path)
    argv = ["montecarlo", "--reference", "line", "--localiser", "fixes", "--jobs", "1", "--runs", "3"]
    argv += ["--results", "d.jsonl", "--json", "d.json", "--quiet", "--no-plots"]
    spec = _spec(build_parser().parse_args(argv))
    header = json.dumps({"nhsim_montecarlo": 1, "key": spec.key(), "code": code_digest()})
    seeds = spec.record_seeds()
    for lines, problem in (
        ([_record(0, seeds), '{"broken": 1,', _record(2, seeds)], "line 3: not a JSON record;"),
        # a failed plan's record names its seeds as a measured one does: one edited is not this study's run
        ([_record(0, seeds), _record(1)], "line 3: run 1 is not this study's run 1: its noise_seed 1 (this study's"),
    ):
        (tmp_path / "d.jsonl").write_text("\n".join([header, *lines]) + "\n")
        before = (tmp_path / "d.jsonl").read_bytes()
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"nhsim montecarlo: error: d.jsonl, {problem}") and "Traceback" not in err, err
        assert (tmp_path / "d.jsonl").read_bytes() == before and not (tmp_path / "d.json").exists()
    # a last line cut short (an interrupted append) is dropped, said, and its run done again
    (tmp_path / "d.jsonl").write_text("\n".join([header, _record(0, seeds), _record(1, seeds), _record(2)[:20]]))
    assert main(argv) == 0
    assert "note: d.jsonl: dropped its last line (line 4, 20 bytes cut short" in capsys.readouterr().err


# ------------------------------------------------------------------------------------------- kernel cache
def _python(code: str, tmp_path: Path, **env: str) -> subprocess.CompletedProcess[str]:
    clean = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "NUMBA_CACHE_LOCATOR_CLASSES")}
    clean.update(PYTHONPATH=os.pathsep.join([str(ROOT), str(tmp_path)]), **env)
    return subprocess.run(
        [sys.executable, "-c", code], env=clean, cwd=tmp_path, capture_output=True, text=True, check=False, timeout=300
    )


def test_version_never_touches_the_kernel_cache(tmp_path: Path) -> None:
    # a cache folder that cannot even be looked at (another user's home: PermissionError; here a name too long
    # for the file system) crashed every command at import, --version included
    unusable = tmp_path / ("a" * 300)
    done = _python(
        "from sim.cli.main import main; raise SystemExit(main(['--version']))", tmp_path, XDG_CACHE_HOME=str(unusable)
    )
    assert done.returncode == 0 and done.stdout.startswith("nhsim ") and done.stderr == "", done.stderr
    fresh = tmp_path / "xdg"
    done = _python(
        "from sim.cli.main import main; raise SystemExit(main(['--version']))", tmp_path, XDG_CACHE_HOME=str(fresh)
    )
    assert done.returncode == 0 and not fresh.exists()


def test_an_unusable_kernel_cache_is_said_once_and_kernels_compile_anyway(tmp_path: Path) -> None:
    # XDG_CACHE_HOME naming a file: every kernel compiled on every run (55 s) and not a word
    (tmp_path / "kern.py").write_text("import numba\n\n\n@numba.njit(cache=True)\ndef inc(x):\n    return x + 1\n")
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    code = (
        "import control.estimation.kernels, numba, os, kern\n"
        "print(kern.inc(41), numba.config.CACHE_DIR, os.path.isdir(numba.config.CACHE_DIR))"
    )
    done = _python(code, tmp_path, XDG_CACHE_HOME=str(not_a_folder))
    assert done.returncode == 0, done.stderr
    answer, used, isdir = done.stdout.split()
    assert answer == "42" and isdir == "True" and not used.startswith(str(not_a_folder))
    assert not Path(used).exists()  # the temporary folder is removed at exit
    assert done.stderr.count("cannot keep compiled kernels") == 1, done.stderr
    assert f"cannot keep compiled kernels in {not_a_folder}/nhsim/numba/" in done.stderr
    assert "set XDG_CACHE_HOME to a folder you can write" in done.stderr


# --------------------------------------------------------------------------------------------- MUJOCO_GL
def test_an_unknown_mujoco_gl_is_refused_naming_the_valid_values(tmp_path: Path) -> None:
    # a traceback from mujoco's import (RuntimeError: invalid value for environment variable MUJOCO_GL)
    code = "from sim.cli.main import main; raise SystemExit(main(['compare', '--reference', 'line']))"
    done = _python(code, tmp_path, MUJOCO_GL="bogus")
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr and "RuntimeError" not in done.stderr
    assert "nhsim compare: error: environment variable MUJOCO_GL='bogus' is not a GL backend" in done.stderr
    assert "set it to one of osmesa, egl, glfw" in done.stderr and "--gl osmesa" in done.stderr


@pytest.mark.parametrize("value", ["egl", "OSMesa", " glfw", "", "disable", "0", "true"])
def test_the_mujoco_gl_values_mujoco_takes_are_left_to_it(value: str, monkeypatch: pytest.MonkeyPatch) -> None:
    from sim.viz import gl

    monkeypatch.setenv("MUJOCO_GL", value)
    gl.check_environment()
    monkeypatch.setenv("MUJOCO_GL", "bogus")
    with pytest.raises(ConfigError, match="MUJOCO_GL='bogus'"):
        gl.check_environment()


# ------------------------------------------------------------------------------------ bench plan --quick
@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--seeds", "0"], "--seeds must be an integer >= 1, got 0"),
        (["--budget", "-1"], "--budget must be a finite number in (0, 3600] (s), got -1.0"),
        (["--optimal", "RRT"], "unknown OMPL planner(s) RRT for --optimal"),
    ],
)
def test_bench_plan_quick_checks_the_values_given_with_it(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # --quick ran 5 seeds at 0.5 s whatever --seeds and --budget said, even invalid ones
    assert main(["bench", "plan", "--quick", *argv]) == 2
    captured = capsys.readouterr()
    assert message in captured.err and captured.out == ""


def test_bench_plan_quick_sets_defaults_that_the_options_given_override() -> None:
    from sim.cli.bench.plan import settings
    from sim.cli.main import build_parser
    from sim.tools.bench.plan import OPTIMAL

    def resolved(*argv: str) -> tuple[Any, ...]:
        return settings(build_parser().parse_args(["bench", "plan", *argv]))

    assert resolved("--quick") == (5, ["disc10"], 0.5, ("RRTstar",))
    assert resolved("--quick", "--seeds", "7", "--budget", "0.2") == (7, ["disc10"], 0.2, ("RRTstar",))
    assert resolved("--quick", "--scenarios", "maze", "--optimal", "BITstar") == (5, ["maze"], 0.5, ("BITstar",))
    assert resolved() == (20, None, 1.0, tuple(OPTIMAL))


# -------------------------------------------------------------------------------- YAML paths, bag metadata
def _yaml_path(quaternions: list[tuple[float, float, float, float]]) -> str:
    lines = ["header:", "  frame_id: map", "poses:"]
    for i, (qx, qy, qz, qw) in enumerate(quaternions):
        lines += [
            "- header:",
            "    frame_id: map",
            "  pose:",
            f"    position: {{x: {0.5 * i}, y: 0.0, z: 0.0}}",
            f"    orientation: {{x: {qx}, y: {qy}, z: {qz}, w: {qw}}}",
        ]
    return "\n".join(lines) + "\n"


def test_a_yaml_path_gets_the_bags_unit_quaternion_check(tmp_path: Path) -> None:
    # a norm-2 quaternion was taken without a word, where a bag refuses a norm more than 0.001 off 1
    path = tmp_path / "q.yaml"
    path.write_text(_yaml_path([(0, 0, 0, 1), (0, 0, 0, 2), (0, 0, 0, 1)]))
    with pytest.raises(TrajectoryFileError) as err:
        read_table(path)
    assert str(err.value) == (
        f"{path}: poses[1] has an unnormalised (norm 2) orientation quaternion (x, y, z, w) = (0, 0, 0, 2) (1 of 3 "
        "poses); an orientation is a unit quaternion, norm 1 within 0.001 (tf2 refuses others): normalise it (x, y, "
        "z and w divided by their norm)"
    )
    s, c = math.sin(0.25), math.cos(0.25)
    path.write_text(_yaml_path([(0, 0, 0, 1.0005), (0, 0, s, c), (0, 0, 0, 1)]))  # within the tolerance: normalised
    assert read_table(path).columns["theta"] == pytest.approx([0.0, 0.5, 0.0])


def test_a_yaml_path_without_poses_is_said_to_have_none(tmp_path: Path) -> None:
    # "unknown column name(s) 'header'"
    path = tmp_path / "p.yaml"
    path.write_text("header:\n  frame_id: map\n  stamp: {sec: 0, nanosec: 0}\n")
    with pytest.raises(
        TrajectoryFileError, match=r"p\.yaml: has a header but no poses list; a nav_msgs/Path needs one"
    ):
        read_table(path)


def test_broken_yaml_is_one_line_with_the_line_and_column(tmp_path: Path) -> None:
    # PyYAML's several lines, with a quoted excerpt and a caret
    path = tmp_path / "b.yaml"
    path.write_text("poses: [\n")
    with pytest.raises(TrajectoryFileError) as err:
        read_table(path)
    said = str(err.value)
    assert "\n" not in said and said.startswith(f"{path}: not valid YAML (line 2, column 1: expected the node content")
    assert "fix the file there" in said


def test_a_bag_whose_metadata_is_broken_yaml_is_named_in_one_line(tmp_path: Path) -> None:
    from planning.trajectory.bag_file import read_bag_table

    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: [5\n")
    with pytest.raises(TrajectoryFileError) as err:
        read_bag_table(bag, "/plan", timed=False)
    said = str(err.value)
    assert "\n" not in said and said.startswith(
        f"cannot read bag {bag}: {bag / 'metadata.yaml'} is not valid YAML (line 3"
    )
    assert "ros2 bag reindex" in said


# ----------------------------------------------------------------------------------- map image, baselines
def test_a_map_image_that_is_a_folder_is_said_to_be_one(tmp_path: Path) -> None:
    from planning.scenario import load_scenario

    text = (ROOT / "models" / "scenarios" / "edumip_map.toml").read_text()
    scenario = tmp_path / "sc.toml"
    scenario.write_text(text.replace('image = "../maps/edumip_map.png"', 'image = "."'))
    with pytest.raises(ScenarioError, match=r"map image \S+ is a folder, not an image file; give the PNG or JPEG"):
        load_scenario(scenario)


def _baseline(tmp_path: Path, metrics: dict[str, Any]) -> Any:
    from sim.tools.regress import Baseline

    path = tmp_path / "c.json"
    path.write_text(json.dumps({"case": {}, "environment": {}, "metrics": metrics}))
    return Baseline.read(path)


def test_a_baseline_without_values_for_the_runs_metrics_is_unreadable_not_changed(tmp_path: Path) -> None:
    # reported as "final_position_error_m changed (nan -> 0.0025)" for every metric
    from sim.pipeline.case import Case
    from sim.tools.regress import Status, judge

    case = Case("open", reference="line", name="c")
    run = {"final_position_error_m": 0.0025, "collisions": 0, "duration_s": 7.06, "fell": False}
    for junk in ({}, {"final_position_error_m": None, "collisions": 0, "duration_s": 7.06, "fell": False}):
        result = judge(case, run, _baseline(tmp_path, junk), {})
        assert result.status is Status.UNREADABLE, result
        assert "(no value for metric(s) final_position_error_m" in result.message
        assert "rewrite it with nhsim regress --update --case c" in result.message and "nan ->" not in result.message
    base = _baseline(tmp_path, {**run, "rms_position_error_m": None})
    same = judge(case, {**run, "rms_position_error_m": math.nan}, base, {})
    assert same.status is not Status.UNREADABLE
    assert not [c for c in same.changes if c.metric == "rms_position_error_m"]  # NaN, written null: not a change


def test_a_benchmark_verdict_reads_apart_from_its_target() -> None:
    """A median just above its target printed to the target's digits read '0.990 (target <= 0.99) MISSED'."""
    from sim.cli.bench.plan import against

    assert against(0.9903, 0.99, 3) == "0.9903" and against(0.99, 0.99, 3) == "0.990"
    assert against(0.981, 0.99, 3) == "0.981" and against(1.0049, 1.0, 2) == "1.005"
    assert against(float("inf"), 1.0, 2) == "inf" and against(float("nan"), 1.0, 2) == "-"


def test_a_full_disk_while_appending_a_run_names_the_results_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A full disk under the results file said "could not write: No space left on device", naming no file."""
    from sim.cli.main import could_not_write

    results = ResultsFile(tmp_path / "mc.jsonl", KEY, code="c0de")

    def full(fd: int) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(OSError) as err:
        results.add(json.loads(_record(0)))
    assert err.value.filename == str(tmp_path / "mc.jsonl")
    assert could_not_write(err.value, "montecarlo").startswith(
        f"could not write {tmp_path / 'mc.jsonl'}: No space left"
    )
