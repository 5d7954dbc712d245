"""``nhsim tune``: no worse than the defaults, resumable after a kill, clear errors writing nothing."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import optuna
import pytest

from control.fbl import FBLGains
from control.gains import load_gains_file
from sim.cli.main import main
from sim.cli.tune import default_study_name
from sim.physics.perturb import PerturbationRange
from sim.pipeline.case import Case
from sim.pipeline.simulate import prepare_case
from sim.tools.tune import Evaluator, split_trials

CASE = "open:line"  # the cheapest reference: 12 s simulated, ~0.1 s a run


def _args(tmp_path: Path, trials: int, *extra: str) -> list[str]:
    return [
        "tune", "--scenarios", CASE, "--trials", str(trials), "--storage", f"sqlite:///{tmp_path}/study.db",
        "--study", "t", "--out", str(tmp_path / "gains.toml"), "--plots", str(tmp_path), "--quiet", *extra,
    ]  # fmt: skip


def _completed(tmp_path: Path) -> list[optuna.trial.FrozenTrial]:
    study = optuna.load_study(study_name="t", storage=f"sqlite:///{tmp_path}/study.db")
    return study.get_trials(states=(optuna.trial.TrialState.COMPLETE,))


def _completed_so_far(tmp_path: Path) -> int:
    """Completed trials, read without touching the schema: polling must never race the tuner creating it."""
    db = tmp_path / "study.db"
    if not db.exists():
        return 0
    try:
        with contextlib.closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=1.0)) as con:
            return int(con.execute("SELECT COUNT(*) FROM trials WHERE state = 'COMPLETE'").fetchone()[0])
    except sqlite3.OperationalError:
        return 0  # schema not created yet, or the database is locked for a moment


def test_tuning_is_no_worse_than_the_defaults(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(_args(tmp_path, 6, "--eval-runs", "1")) == 0
    out = capsys.readouterr().out
    assert "held-out perturbed runs" in out and "tuned / default" in out
    saved = load_gains_file(tmp_path / "gains.toml")
    prov = saved.provenance
    # Re-evaluate both gain sets the same way, independently of the study.
    ev = Evaluator([Case.parse(CASE)])
    tuned, default = ev.evaluate(saved.gains), ev.evaluate(FBLGains())
    assert tuned.objective == prov["objective"]  # deterministic, and the file holds what was found
    assert default.objective == prov["default_objective"]
    assert tuned.objective <= default.objective
    trials = _completed(tmp_path)
    assert len(trials) == 6 == prov["trials"]
    first = min(trials, key=lambda t: t.number)
    assert first.params == {"kp": 9.0, "kd": 6.0, "xi_min": 0.02} and first.value == default.objective
    assert prov["objective"] == min(t.value for t in trials)
    assert (tmp_path / "tune-t-history.png").stat().st_size > 1000
    assert (tmp_path / "tune-t-importance.png").stat().st_size > 1000
    # Same command again: nothing left to run, and the outputs are not overwritten without --overwrite.
    before = (tmp_path / "gains.toml").read_bytes()
    assert main(_args(tmp_path, 6)) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert (tmp_path / "gains.toml").read_bytes() == before


def test_killed_study_resumes_with_every_trial_once(tmp_path: Path) -> None:
    args = _args(tmp_path, 10, "--eval-runs", "0")
    proc = subprocess.Popen([sys.executable, "-m", "sim", *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    try:
        while True:
            assert proc.poll() is None, f"tune ended before it was killed: {proc.stderr.read().decode()}"  # type: ignore[union-attr]
            assert time.monotonic() < deadline, "no trial completed in 120 s"
            if _completed_so_far(tmp_path) >= 3:
                break
            time.sleep(0.05)
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    before = {t.number: (t.params, t.value) for t in _completed(tmp_path)}
    assert 3 <= len(before) < 10
    assert not (tmp_path / "gains.toml").exists()

    assert main(args) == 0  # the same command resumes
    after = _completed(tmp_path)
    assert len(after) == 10
    assert len({t.number for t in after}) == 10
    for number, record in before.items():  # every trial done before the kill is kept as it was
        assert {t.number: (t.params, t.value) for t in after}[number] == record
    params = [tuple(sorted(t.params.items())) for t in after]
    assert len(set(params)) == 10  # no trial evaluated twice
    assert params.count((("kd", 6.0), ("kp", 9.0), ("xi_min", 0.02))) == 1
    assert load_gains_file(tmp_path / "gains.toml").provenance["trials"] == 10


def test_parallel_workers_share_the_study(tmp_path: Path) -> None:
    assert main(_args(tmp_path, 4, "--jobs", "2", "--eval-runs", "0")) == 0
    trials = _completed(tmp_path)
    assert len(trials) == 4
    assert len({tuple(sorted(t.params.items())) for t in trials}) == 4


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"--scenarios": "nowhere:figure8"}, "nowhere"),
        ({"--scenarios": "open:spiral"}, "simulate_plan|spiral"),
        ({"--storage": "sqlite:////nonexistent-nhsim-dir/sub/study.db"}, "cannot open storage"),
        ({"--storage": "nosuchdb://user@host/db"}, "cannot open storage"),
        ({"--perturb-range": "grip=1:2"}, "expected comma-separated"),
        ({"--trials": "0"}, "--trials must be >= 1"),
    ],
)
def test_bad_input_is_a_clear_error_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: dict[str, str], match: str
) -> None:
    work = tmp_path / "out"
    work.mkdir()
    args = _args(work, 3)
    for key, value in change.items():
        if key in args:
            args[args.index(key) + 1] = value
        else:
            args += [key, value]
    assert main(args) == 2
    assert re.search(match, capsys.readouterr().err)
    assert list(work.iterdir()) == []


def test_malformed_gains_file_is_rejected_by_simulate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "g.toml"
    bad.write_text("[gains]\nkp = 9\nkd = -6\n")
    assert main(["simulate", "--gains", str(bad), "--json", str(tmp_path / "r.json")]) == 2
    assert "kd must be > 0" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.toml"]


def test_resuming_with_other_settings_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(_args(tmp_path, 1, "--eval-runs", "0")) == 0
    assert main([*_args(tmp_path, 2, "--eval-runs", "0", "--saturation-weight", "1"), "--overwrite"]) == 2
    assert "other settings" in capsys.readouterr().err
    assert len(_completed(tmp_path)) == 1


def test_helpers() -> None:
    assert split_trials(7, 3) == [3, 2, 2] and split_trials(2, 4) == [1, 1] and split_trials(0, 2) == []
    assert default_study_name(["open:figure8", "open:circle"], None, True) == "fbl-open-figure8_open-circle-robust"
    long = default_study_name([f"open:figure8-{i}" for i in range(20)], "edumip", False)
    assert len(long) <= 60 and long == default_study_name([f"open:figure8-{i}" for i in range(20)], "edumip", False)


def test_objective_is_the_stated_formula() -> None:
    case = Case.parse(CASE)
    gains = FBLGains(3.0, 2.0)
    m = prepare_case(case).run(gains).metrics
    ev = Evaluator([case], saturation_weight=0.5).evaluate(gains)
    assert ev.objective == m.rms_position_error_m + m.final_position_error_m + 0.5 * m.saturation_fraction
    assert (ev.runs, ev.failures, ev.rms_m) == (1, 0, m.rms_position_error_m)
    perts = PerturbationRange().sample(2, seed=1)
    robust = Evaluator([case, Case.parse("open:circle")], perts).evaluate(gains)
    assert robust.runs == 4  # every case meets every perturbation
    m2 = prepare_case(case).run(gains, perts[1]).metrics
    assert m2 != m  # the perturbation reached the physics
