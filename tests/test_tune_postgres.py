"""Many ``nhsim tune`` workers share one study in PostgreSQL (a real server, started here): no trial
is lost, none is evaluated twice."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import optuna
import pytest

from control.gains import load_gains_file
from tests.cli_helpers import nhsim_meanwhile
from tests.postgres_helpers import postgres_cluster, postgres_server

ROOT = Path(__file__).resolve().parents[1]
CASE = "open:line"


@pytest.mark.slow  # a PostgreSQL server and two tuning workers
def test_two_tune_workers_share_a_postgresql_study(tmp_path: Path) -> None:
    with postgres_server() as url:
        base = [sys.executable, "-m", "sim", "tune", "--scenarios", CASE, "--robot", "turtlebot3", "--trials", "6",
                "--storage", url, "--study", "shared", "--draws", "1", "--eval-runs", "0", "--quiet"]  # fmt: skip
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        procs = []
        for i in range(2):  # two workers, as on two machines: each its own command and output files
            argv = [*base, "--out", str(tmp_path / f"w{i}" / "gains.toml"), "--plots", str(tmp_path / f"w{i}")]
            pipe = subprocess.PIPE
            procs.append(subprocess.Popen(argv, cwd=tmp_path, env=env, stdout=pipe, stderr=pipe, text=True))
        outs = [p.communicate(timeout=900) for p in procs]
        for p, (_, err) in zip(procs, outs, strict=True):
            assert p.returncode in (0, 1), err  # 1: tuned gains that lose to the defaults are not recommended
        study = optuna.load_study(study_name="shared", storage=url)
        trials = study.get_trials(deepcopy=False)
    states = [t.state for t in trials]
    complete = [t for t in trials if t.state is optuna.trial.TrialState.COMPLETE]
    assert optuna.trial.TrialState.RUNNING not in states and optuna.trial.TrialState.WAITING not in states
    assert 6 <= len(complete) <= 7  # each worker stops once the study holds 6; one may finish its last trial
    params = [tuple(sorted(t.params.items())) for t in complete]
    assert len(set(params)) == len(params)  # no trial evaluated twice
    assert sum(t.params == {"kp": 9.0, "kd": 6.0, "xi_min": 0.02} for t in complete) == 1


def test_a_postgresql_url_that_cannot_be_opened_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("psycopg2")
    from sim.cli.main import main

    args = ["tune", "--scenarios", CASE, "--trials", "2", "--storage", "postgresql+psycopg2://nobody@127.0.0.1:9/x",
            "--study", "t", "--out", str(tmp_path / "g.toml"), "--plots", str(tmp_path), "--quiet"]  # fmt: skip
    assert main(args) == 2
    assert "cannot open storage" in capsys.readouterr().err
    assert not (tmp_path / "g.toml").exists()


def test_a_bare_postgresql_url_opens_with_the_installed_driver(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``postgresql://`` (the docs' form) is SQLAlchemy 2.1's psycopg 3, which nhsim does not install: it
    failed "Failed to import DB access module" with psycopg2 installed. Now the installed driver is named,
    and the failure is the connection's own (nothing listens on port 9)."""
    pytest.importorskip("psycopg2")
    from sim.cli.main import main
    from sim.tools.tune import with_driver

    bare = "postgresql://nobody:pw@127.0.0.1:9/x"
    named = with_driver(bare)
    assert named.startswith(("postgresql+psycopg2://", "postgresql://")) and named.endswith("nobody:pw@127.0.0.1:9/x")
    assert with_driver("postgresql+psycopg2://a@h/d") == "postgresql+psycopg2://a@h/d"
    assert with_driver("sqlite:///renders/t.db") == "sqlite:///renders/t.db"
    args = ["tune", "--scenarios", CASE, "--trials", "2", "--storage", bare,
            "--study", "t", "--out", str(tmp_path / "g.toml"), "--plots", str(tmp_path), "--quiet"]  # fmt: skip
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "cannot open storage 'postgresql://nobody:***@127.0.0.1:9/x'" in err and "DB access module" not in err
    assert ":pw@" not in err  # the password is used, never shown


def _completed(url: str, study: str) -> int:
    """Completed trials of ``study`` so far (0 while it is not there yet)."""
    import sqlalchemy

    try:
        with sqlalchemy.create_engine(url).connect() as con:
            sql = "SELECT count(*) FROM trials t JOIN studies s ON s.study_id = t.study_id WHERE s.study_name = :n AND "
            return int(con.execute(sqlalchemy.text(sql + "t.state = 'COMPLETE'"), {"n": study}).scalar_one())
    except sqlalchemy.exc.SQLAlchemyError:
        return 0


@pytest.mark.slow  # a server stopped and started again: 7 s
@pytest.mark.parametrize("jobs", [1, 2])
def test_a_database_lost_mid_study_is_one_line_and_a_rerun_resumes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, jobs: int
) -> None:
    """The PostgreSQL server stopped during a study: hundreds of lines of tracebacks (Optuna's UnboundLocalError
    'updated_state'; a worker's each with --jobs 2), exit status 1. Now one line names the lost connection (the
    storage, its password hidden) and says a rerun resumes; exit status 1, a failure that is not the input's.
    With the server back, the same command resumes the study."""
    with postgres_cluster() as server:
        url = server.url.replace("nhsim@", "nhsim:S3cretPW@")  # trust authentication takes any password
        args = ["tune", "--scenarios", CASE, "--draws", "1", "--storage", url, "--study", "lost", "--quiet"]
        args += ["--out", str(tmp_path / "g.toml"), "--plots", str(tmp_path), "--eval-runs", "0", "--jobs", str(jobs)]
        lost = nhsim_meanwhile(
            [*args, "--trials", "200"],
            lambda _: _completed(server.url, "lost") >= 2,
            lambda _: server.stop(),
            cwd=tmp_path,
        )
        err = lost.stderr
        assert lost.returncode == 1, err
        shown = server.url.replace("nhsim@", "nhsim:***@")
        assert err.startswith(f"nhsim tune: failed: lost the connection to the study's storage {shown} ("), err
        assert err.strip().endswith("rerun the same command to resume it") and len(err.strip().splitlines()) == 1
        assert not (tmp_path / "g.toml").exists()
        server.start()
        done = _completed(server.url, "lost")
        import sim.tools.tune as tune
        from sim.cli.main import main

        # the trial the lost connection left running is failed once silent: sooner here than the 10 s a user waits
        monkeypatch.setattr(tune, "HEARTBEAT_INTERVAL", 1)
        monkeypatch.setattr(tune, "GRACE_PERIOD", 2)
        monkeypatch.chdir(tmp_path)
        assert main([*args, "--trials", str(done + 1)]) in (0, 1)
        assert _completed(server.url, "lost") == done + 1


@pytest.mark.slow  # the default run checks it on SQLite (test_tune.py); here on a server, 4 s
def test_the_password_is_hidden_and_another_spelling_reaches_the_same_study(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The password of --storage was printed ("study pwr: 2 completed trials (postgresql://nhsim:S3cretPW@...)")
    and written to the gains file, the record and the plots; and the same study through another spelling of its
    URL (another driver, no password) was refused as "holds the outputs of study 'pwr' in ..., not of study 'pwr'
    in ...". The password is masked everywhere; the database, not the spelling, names the study's outputs."""
    from sim.cli.main import main

    with postgres_server() as url:
        secret = url.replace("postgresql+psycopg2://nhsim@", "postgresql://nhsim:S3cretPW@")
        base = ["tune", "--scenarios", CASE, "--draws", "1", "--eval-runs", "1", "--study", "pwr",
                "--out", str(tmp_path / "g.toml"), "--plots", str(tmp_path), "--quiet"]  # fmt: skip
        assert main([*base, "--trials", "2", "--storage", secret]) in (0, 1)
        said = capsys.readouterr()
        assert "S3cretPW" not in said.out + said.err and "nhsim:***@" in said.out
        for path in tmp_path.iterdir():
            assert b"S3cretPW" not in path.read_bytes(), path
        assert main([*base, "--trials", "3", "--storage", url]) in (0, 1)  # another driver, no password
        assert load_gains_file(tmp_path / "g.toml").provenance["trials"] == 3
