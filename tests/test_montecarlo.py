"""Monte Carlo studies (``sim.tools.montecarlo``, ``nhsim montecarlo``) and the executor they run on.

The distributed tests start a real Dask scheduler and two worker processes (a ``LocalCluster``),
never a mock, and compare with the serial loop: equal statistics, bit for bit.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import socket
import threading
import time
from pathlib import Path
from typing import Any, cast

import pytest

from planning.errors import ConfigError, SimulationError
from sim.cli.main import main
from sim.physics.perturb import PerturbationRange
from sim.pipeline.case import Case
from sim.tools.executor import DaskExecutor, Executor, make_executor
from sim.tools.montecarlo import MonteCarloSpec, ResultsFile, partial_path, run_montecarlo, statistics

CASE = Case("open", robot="turtlebot3", reference="line", seed=3)


def _spec(runs: int = 3, **kw: object) -> MonteCarloSpec:
    return MonteCarloSpec(CASE, runs, **kw)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """A 3-run study run serially, uninterrupted: the reference for the other tests."""
    path = tmp_path_factory.mktemp("mc") / "serial.jsonl"
    spec = _spec()
    result = run_montecarlo(spec, Executor(), ResultsFile(path, spec.key()))
    return {"stats": result.stats, "records": result.records, "path": path, "spec": spec}


def test_statistics_summarise_every_run_kind(serial: dict[str, object]) -> None:
    stats = serial["stats"]
    assert isinstance(stats, dict)
    records = serial["records"]
    assert isinstance(records, list) and [r["index"] for r in records] == [0, 1, 2]
    assert len({r["build_seed"] for r in records}) == 3 and len({r["noise_seed"] for r in records}) == 3
    for kind in ("closed_loop", "closed_loop_odometry", "open_loop"):
        s = stats[kind]
        finals = sorted(r["runs"][kind]["final_position_error_m"] for r in records)
        assert s["final_position_error_m"]["p50"] == finals[1]  # the median of three
        assert finals[1] <= s["final_position_error_m"]["p90"] <= s["final_position_error_m"]["p99"] <= finals[2]
        assert s["worst"][0]["final_position_error_m"] == finals[2]
    # the real robot's closed loop keeps to the path; open loop drifts further
    assert stats["closed_loop"]["success_rate"] == 1.0
    assert stats["open_loop"]["final_position_error_m"]["p50"] > stats["closed_loop"]["final_position_error_m"]["p50"]


@pytest.mark.slow  # a Dask cluster of two worker processes
def test_two_dask_workers_give_the_serial_statistics(serial: dict[str, object], tmp_path: Path) -> None:
    spec = _spec()
    with DaskExecutor(jobs=2) as ex:
        assert ex.workers == 2
        result = run_montecarlo(spec, ex, ResultsFile(tmp_path / "dask.jsonl", spec.key()))
    assert result.stats == serial["stats"]
    assert result.records == serial["records"]


def test_a_killed_study_resumed_ends_with_the_same_statistics(serial: dict[str, object], tmp_path: Path) -> None:
    spec = _spec()
    path = tmp_path / "resumed.jsonl"
    lines = Path(str(serial["path"])).read_text().splitlines(keepends=True)
    # killed after two runs, while writing the third (half a line on disk)
    path.write_text("".join(lines[:3]) + lines[3][: len(lines[3]) // 2])
    results = ResultsFile(path, spec.key())
    assert sorted(results.records) == [0, 1]
    result = run_montecarlo(spec, Executor(), results)
    assert result.ran == 1
    assert result.stats == serial["stats"]
    assert [json.loads(x)["index"] for x in path.read_text().splitlines()[1:]] == [0, 1, 2]


def test_an_edited_scenario_file_is_another_study(tmp_path: Path) -> None:
    """A study's key holds a digest of its scenario as read: the world edited under the same name and path is
    another study (its runs would have been mixed with the old world's on resume, as an edited trajectory file's
    are not); the digest is of the scenario, not of where it was read (a copy of a built-in has the built-in's)."""
    from planning.scenario import SCENARIOS_DIR

    def key(path: Path | str) -> dict[str, object]:
        return MonteCarloSpec(Case(str(path), robot="turtlebot3", reference="line", seed=3), 3).key()

    mine = tmp_path / "parking_lot.toml"
    shutil.copy(SCENARIOS_DIR / "parking_lot.toml", mine)
    before = key(mine)
    assert before["world"] == key("parking_lot")["world"]
    text = mine.read_text(encoding="utf-8")
    assert "center = [1.2, 0.3]" in text
    mine.write_text(text.replace("center = [1.2, 0.3]", "center = [1.21, 0.3]"), encoding="utf-8")
    after = key(mine)
    assert {k for k in before if before[k] != after[k]} == {"world"}
    (tmp_path / "runs.jsonl").write_text(json.dumps({"key": before, "code": "x"}) + "\n")
    with pytest.raises(ConfigError, match=r"another study .*world: "):
        ResultsFile(tmp_path / "runs.jsonl", after)


def test_a_results_file_of_another_study_is_refused(serial: dict[str, object], tmp_path: Path) -> None:
    other = MonteCarloSpec(Case("open", robot="turtlebot3", reference="line", seed=4), 3)
    with pytest.raises(ConfigError, match=r"another study \(seed: 3 there, 4 here\)"):
        ResultsFile(Path(str(serial["path"])), other.key())
    ranged = _spec(ranges=PerturbationRange.parse("radius=0.97:1.03", others="nominal"))
    with pytest.raises(ConfigError, match="ranges: None there"):
        ResultsFile(Path(str(serial["path"])), ranged.key())
    (tmp_path / "odd.jsonl").write_text(json.dumps({"key": "open", "code": "x"}) + "\n")  # no object: AttributeError
    with pytest.raises(ConfigError, match=r"odd\.jsonl is not an nhsim montecarlo results file; choose another"):
        ResultsFile(tmp_path / "odd.jsonl", other.key())


def test_a_study_never_runs_a_robot_or_noise_that_tune_trains_on() -> None:
    """montecarlo's run i was tune's training draw i of the same seed (both 0 by default): a study of tuned gains ran
    on the very robots and noise they were tuned on. Its runs are now the held-out draws compare takes."""
    from sim.tools.tune import make_draws

    for seed in (0, 7):
        study = MonteCarloSpec(Case("open", reference="line", seed=seed), 50).draws()
        training = make_draws(200, seed)
        assert study == make_draws(50, seed, held_out=True)
        assert not {d.build_seed for d in study} & {d.build_seed for d in training}
        assert not {d.seed for d in study} & {d.seed for d in training}
    assert _spec().key()["draws"] == "held-out"  # results made by an nhsim that drew the training set: another study


def test_a_hand_edited_run_record_is_refused_naming_the_file_and_line(
    serial: dict[str, object], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Valid JSON is not enough: a record with a run kind deleted was read as a run whose kind was not measured (its
    success counted as a failure: 50 % for 75 %), and a record whose noise seed was changed was kept, its edited
    seed printed in the worst runs' replay commands. A line must be the run of this study its index names. Its
    fields must be of their types: a metric "abc" or null ended the command in a traceback, NaN gave null
    percentiles without a word, and "yes" was a success."""
    monkeypatch.chdir(tmp_path)
    spec = _spec()
    header, *lines = Path(str(serial["path"])).read_text().splitlines(keepends=True)
    argv = ["montecarlo", "--scenario", "open", "--robot", "turtlebot3", "--reference", "line", "--seed", "3"]
    argv += ["--runs", "3", "--jobs", "1", "--quiet", "--no-plots", "--results", "r.jsonl", "--json", "r.json"]
    from sim.cli.montecarlo import _spec as cli_spec

    header = json.dumps({**json.loads(header), "key": cli_spec(build_argv(argv)).key()}) + "\n"  # the command's key
    path = tmp_path / "r.jsonl"
    second = json.loads(lines[1])
    index, kinds = second["index"], ", ".join(second["runs"])
    no_open_loop = {**second, "runs": {k: v for k, v in second["runs"].items() if k != "open_loop"}}
    other_seed = {**second, "noise_seed": second["noise_seed"] + 2}

    def closed(**fields: object) -> dict[str, Any]:
        return {**second, "runs": {**second["runs"], "closed_loop": {**second["runs"]["closed_loop"], **fields}}}

    final, build = f"run {index}: closed_loop final_position_error_m must be a finite number >= 0", second["build_seed"]
    for edited, problem in (
        (no_open_loop, f"run {index} has no 'open_loop' run, while every run of a study drives {kinds}"),
        (other_seed, f"run {index} is not this study's run {index}: its noise_seed {other_seed['noise_seed']} "),
        (closed(final_position_error_m="abc"), f"{final}, got 'abc';"),
        (closed(final_position_error_m=None), f"{final}, got None;"),
        (closed(final_position_error_m=math.nan), f"{final}, got nan;"),
        (closed(final_position_error_m=True), f"{final}, got True;"),
        (closed(collisions="x"), f"run {index}: closed_loop collisions must be an integer >= 0, got 'x';"),
        (closed(success="yes"), f"run {index}: closed_loop success must be True or False, got 'yes' (true or false"),
        (closed(path=[[0.0, "x"]]), f"run {index}: closed_loop path must be a list of [x, y] points"),
        ({**second, "build_seed": float(build)}, f"run {index}: build_seed must be an integer >= 0, got {build}.0;"),
    ):
        path.write_text(header + lines[0] + json.dumps(edited) + "\n" + lines[2])
        before = path.read_bytes()
        with pytest.raises(ConfigError) as err:
            ResultsFile(path, json.loads(header)["key"], seeds=spec.record_seeds)
        assert str(err.value).startswith(f"{path}, line 3: {problem}"), str(err.value)
        assert main(argv) == 2
        said = capsys.readouterr().err
        assert said.startswith(f"nhsim montecarlo: error: r.jsonl, line 3: {problem}") and said.count("\n") == 1
        assert path.read_bytes() == before and not (tmp_path / "r.json").exists()
    path.write_text(header + "".join(lines))  # the runs as nhsim wrote them: resumed, nothing to run
    assert main(argv) == 0
    assert json.loads((tmp_path / "r.json").read_text())["ran_now"] == 0


def test_a_run_on_two_lines_is_read_once_or_refused_when_they_differ(serial: dict[str, object], tmp_path: Path) -> None:
    """Two commands of one study run at once each append every run; a run's line copied and edited was read too:
    the later line won, without a word. The same record twice is read once (said); two that differ are refused."""
    spec = _spec()
    header, *lines = Path(str(serial["path"])).read_text().splitlines(keepends=True)
    path = tmp_path / "r.jsonl"
    path.write_text(header + "".join(lines) + "".join(lines))
    results = ResultsFile(path, spec.key(), seeds=spec.record_seeds)
    assert [results.records[i] for i in range(3)] == serial["records"]
    assert results.notes == [
        f"{path}: 3 lines (5, 6, 7) repeat runs of earlier lines, the same records (as two commands of this study "
        "run at once write them); each run is read once"
    ]
    second = json.loads(lines[1])
    flipped = not second["runs"]["open_loop"]["success"]
    other = {**second, "runs": {**second["runs"], "open_loop": {**second["runs"]["open_loop"], "success": flipped}}}
    path.write_text(header + "".join(lines) + json.dumps(other) + "\n")
    before = path.read_bytes()
    with pytest.raises(ConfigError) as err:
        ResultsFile(path, spec.key(), seeds=spec.record_seeds)
    assert str(err.value).startswith(f"{path}, line 5: run 1 is on line 3 already, with other values; ")
    assert path.read_bytes() == before


def test_the_seeds_of_a_study_with_perturbations_are_read_back_as_its_own(tmp_path: Path) -> None:
    spec = _spec(runs=1, ranges=PerturbationRange.parse("radius=0.97:1.03,latency=0:0.02", others="nominal"))
    result = run_montecarlo(spec, Executor(), ResultsFile(tmp_path / "p.jsonl", spec.key()))
    reread = ResultsFile(tmp_path / "p.jsonl", spec.key(), seeds=spec.record_seeds)
    assert reread.records[0] == result.records[0] and reread.records[0]["perturbation"]["radius"] != 1.0


def test_a_replaced_results_file_stays_until_the_study_is_written(serial: dict[str, object], tmp_path: Path) -> None:
    """``montecarlo --overwrite`` deleted the other study's results file at its start; later it replaced it, and the
    other study's summary and plots, with its first run: an interrupt then lost them, where the outputs are
    promised to be written as one set, or not at all. Now the runs go to ``NAME.partial`` beside it, and are resumed
    from there; the file is replaced when the study is written (sim.cli.montecarlo)."""
    theirs = tmp_path / "r.jsonl"
    theirs.write_bytes(Path(str(serial["path"])).read_bytes())
    before = theirs.read_bytes()
    other = MonteCarloSpec(Case("open", robot="turtlebot3", reference="line", seed=4), 3)
    results = ResultsFile(theirs, other.key(), replacing=True)  # not read: another study's
    assert results.records == {} and results.file == partial_path(theirs) == tmp_path / "r.jsonl.partial"
    first = json.loads(before.splitlines()[1])  # a run record, stored as this study's first
    results.add(first)
    assert theirs.read_bytes() == before  # the other study's runs stay
    header, *lines = results.file.read_text().splitlines()
    assert json.loads(header)["key"] == other.key() and [json.loads(x) for x in lines] == [first]
    again = ResultsFile(theirs, other.key(), replacing=True)  # the same command after an interrupt: resumed
    assert sorted(again.records) == [first["index"]] and again.file == results.file and again.notes == []
    own = ResultsFile(theirs, cast(MonteCarloSpec, serial["spec"]).key())  # the file's study rerun: the runs waiting
    waiting = f"{results.file} holds 1 run(s) of an interrupted study that was replacing {theirs}: rerun that study"
    assert any(n.startswith(waiting) for n in own.notes), own.notes
    third = MonteCarloSpec(Case("open", robot="turtlebot3", reference="line", seed=5), 3)
    replaced = ResultsFile(theirs, third.key(), replacing=True)
    assert replaced.records == {}  # another study's partial runs: replaced, and said (they were dropped unsaid)
    assert replaced.notes == [f"replaced {results.file}: its 1 run(s), of another interrupted study, are dropped"]
    assert not results.file.exists() and theirs.read_bytes() == before


def test_an_interrupted_overwrite_leaves_the_old_study_whole_and_resumes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import sim.tools.montecarlo as mc

    monkeypatch.chdir(tmp_path)
    argv = ["montecarlo", "--scenario", "open", "--reference", "line", "--robot", "edumip", "--jobs", "1", "--quiet"]
    argv += ["--results", "r.jsonl", "--json", "s.json", "--runs", "2"]
    assert main([*argv, "--seed", "3"]) == 0
    old = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert sorted(old) == ["r.jsonl", "s-cdf.png", "s-fan.png", "s.json"]
    real, ran = mc.run_one, []

    def interrupted(shared: Any, item: Any) -> Any:
        if ran:
            raise KeyboardInterrupt  # Ctrl-C during the new study's second run
        ran.append(item)
        return real(shared, item)

    monkeypatch.setattr(mc, "run_one", interrupted)
    assert main([*argv, "--seed", "4", "--overwrite"]) == 130
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.name in old} == old  # all of the old study
    assert len((tmp_path / "r.jsonl.partial").read_text().splitlines()) == 2  # the header and the run finished
    capsys.readouterr()
    waiting = "(runs of a study that replaces it wait in r.jsonl.partial)"
    assert main([*argv, "--seed", "4"]) == 2  # without --overwrite: refused, what differs said before the summary
    said = "another study (seed: 3 there, 4 here); give another --results, the same settings, or --overwrite to "
    assert f"{said}replace it {waiting}\n" in capsys.readouterr().err
    assert main([*argv[:-4], "--json", "t.json", "--runs", "2", "--seed", "4"]) == 2  # the runs waiting are named
    assert waiting in capsys.readouterr().err
    monkeypatch.setattr(mc, "run_one", real)
    assert main([*argv, "--seed", "4", "--overwrite"]) == 0  # resumed: one run left
    assert json.loads((tmp_path / "s.json").read_text())["ran_now"] == 1
    assert json.loads((tmp_path / "r.jsonl").read_text().splitlines()[0])["key"]["seed"] == 4
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(old)  # the partial file in place, no other left


def test_perturbations_are_drawn_from_the_ranges_only() -> None:
    spec = _spec(runs=20, ranges=PerturbationRange.parse("radius=0.97:1.03,latency=0:0.02", others="nominal"))
    draws = spec.draws()
    radii = [d.perturbation.radius for d in draws if d.perturbation is not None]
    assert len(radii) == 20 and all(0.97 <= r <= 1.03 for r in radii) and len(set(radii)) == 20
    assert all(d.perturbation is not None and d.perturbation.friction == 1.0 for d in draws)
    # a larger study starts with the smaller one's runs
    assert _spec(runs=5).draws() == _spec(runs=8).draws()[:5]


@pytest.mark.slow  # a local cluster with a worker killed; 4 s
def test_a_worker_that_dies_has_its_run_retried_elsewhere(tmp_path: Path) -> None:
    marker = tmp_path / "died"
    with DaskExecutor(jobs=2) as ex:
        got = dict(ex.map_unordered(_die_once, [0, 1, 2, 3], shared=str(marker)))
        assert got == {0: 0, 1: 10, 2: 20, 3: 30}
        assert marker.exists() and ex.retries >= 1


@pytest.mark.slow  # a Dask cluster of two worker processes
def test_an_interrupt_stops_busy_workers_at_once() -> None:
    """Dask's close lets a busy worker finish its run for up to 4 s before killing it; an interrupted
    study abandons its runs, so its workers are killed as soon as the close reaches them."""
    with pytest.raises(KeyboardInterrupt), DaskExecutor(jobs=2) as ex:
        pids = [n.pid for n in ex._cluster.workers.values()]  # type: ignore[union-attr]
        busy = [ex._client.submit(time.sleep, 60.0, pure=False) for _ in range(2)]
        give_up = time.monotonic() + 30.0
        while sum(map(len, ex._client.processing().values())) < len(busy) and time.monotonic() < give_up:
            time.sleep(0.05)
        time.sleep(0.5)  # both runs under way
        start = time.monotonic()
        raise KeyboardInterrupt
    assert time.monotonic() - start < 2.5  # 4-5 s before
    for pid in pids:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


@pytest.mark.slow  # a Dask cluster of one worker process
def test_an_interrupt_during_the_close_of_idle_workers_waits_for_it(monkeypatch: pytest.MonkeyPatch) -> None:
    """A Ctrl-C just as a study's last run finished cut Dask's close of its idle workers short, and the command took
    10.3 s to exit (Dask's finalisers waiting for the close). The close is held through now (under a second), then
    the interrupt acts."""
    import signal

    from distributed.core import Status

    ex = DaskExecutor(jobs=1)
    cluster = ex._cluster
    assert cluster is not None
    real = cluster.close

    def close(*args: object, **kwargs: object) -> object:
        os.kill(os.getpid(), signal.SIGINT)  # the interrupt arrives as the close begins
        return real(*args, **kwargs)

    monkeypatch.setattr(cluster, "close", close)
    with pytest.raises(KeyboardInterrupt):
        ex.close()
    assert cluster.status == Status.closed and not cluster.workers


def test_only_the_report_of_an_interrupted_dask_wait_is_dropped() -> None:
    """Interrupted inside ``distributed.utils.sync``, Dask's cancel callback fails on the event loop's thread
    (``NameError: cannot access free variable 'future'``) and Tornado logged it beside "interrupted": that
    report alone is dropped; any other error, a NameError elsewhere too, is still logged."""
    import logging
    import os.path
    import sys

    from sim.tools.executor import _CANCEL_REPORTS

    def record(filename: str, name: str, error: type[Exception] = NameError) -> logging.LogRecord:
        code = compile(f"def {name}():\n    raise {error.__name__}('x')\n", filename, "exec")
        scope: dict[str, object] = {}
        exec(code, scope)
        try:
            scope[name]()  # type: ignore[operator]
        except Exception:
            info = sys.exc_info()
        return logging.LogRecord("tornado.application", logging.ERROR, filename, 1, "Exception in callback", (), info)

    utils = os.path.join("site-packages", "distributed", "utils.py")
    assert not _CANCEL_REPORTS.filter(record(utils, "cancel"))
    assert _CANCEL_REPORTS.filter(record(utils, "cancel", RuntimeError))
    assert _CANCEL_REPORTS.filter(record(utils, "wait"))
    assert _CANCEL_REPORTS.filter(record(os.path.join("sim", "tools", "montecarlo.py"), "cancel"))
    assert _CANCEL_REPORTS.filter(logging.LogRecord("tornado.application", logging.ERROR, "", 1, "plain", (), None))


def _die_once(marker: str, item: int) -> int:
    if item == 1 and not os.path.exists(marker):
        Path(marker).write_text("x")
        os._exit(1)  # the worker process dies mid-run
    time.sleep(0.2)
    return item * 10


def test_bad_input_is_refused_clearly(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import sim.tools.executor as executor

    with pytest.raises(ConfigError, match=r"--runs \(runs=\.\.\. from Python\) must be an integer >= 1, got 0"):
        _spec(runs=0)
    assert main(["montecarlo", "--scenario", "open", "--reference", "line", "--runs", "0", "--jobs", "1"]) == 2
    assert "--runs" in capsys.readouterr().err
    with pytest.raises(ConfigError, match=r"--jobs \(jobs=\.\.\. from Python\) must be an integer >= 1"):
        make_executor(0)
    monkeypatch.setattr(executor, "CONNECT_TIMEOUT_S", 1)  # its 10 s, shortened: nothing listens there
    start = time.monotonic()
    with pytest.raises(ConfigError, match=r"tcp://127\.0\.0\.1:9 within 1 s"):
        make_executor(scheduler="tcp://127.0.0.1:9")
    assert time.monotonic() - start < 3
    assert not list(tmp_path.iterdir())


def test_a_bad_sensors_value_is_refused_before_any_worker_starts(
    tmp_path: Path, capfd: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--sensors fix_rate=abc`` was read first in the workers: the cluster started, the study line was printed and
    each worker logged the error's traceback before the command's own line. A sensors file and --lidar were
    refused up front already; the values of --sensors KEY=VALUE now are too."""
    import sim.tools.executor as executor

    def started(*args: object, **kwargs: object) -> Executor:
        raise AssertionError("an executor was started for a study refused as bad input")

    monkeypatch.setattr(executor, "make_executor", started)
    monkeypatch.chdir(tmp_path)
    argv = ["montecarlo", "--scenario", "open", "--reference", "line", "--runs", "3", "--jobs", "2", "--no-plots"]
    for sensors, said in (
        ("fix_rate=abc", "--sensors fix_rate=abc: fix_rate must be a number, got 'abc'"),
        ("fix_rate=-1", "sensor fix_rate must be a finite number in [0, 1000]"),
        ("fix_rate=7", "sensor fix_rate=7 Hz: its period is 7.143 control periods at 50 Hz, not a whole number"),
    ):
        assert main([*argv, "--sensors", sensors]) == 2
        out, err = capfd.readouterr()
        assert out == "" and err.startswith(f"nhsim montecarlo: error: {said}") and err.count("\n") == 1, err
    assert list(tmp_path.iterdir()) == []


def test_the_cli_runs_resumes_and_replays_a_run_bit_for_bit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    argv = ["montecarlo", "--scenario", "open", "--reference", "line", "--robot", "turtlebot3", "--runs", "2"]
    argv += ["--seed", "3", "--jobs", "1", "--quiet", "--no-plots", "--json", "mc.json", "--results", "mc.jsonl"]
    assert main(argv) == 0
    first = json.loads((tmp_path / "mc.json").read_text())
    assert main(argv) == 0  # the same command again: nothing to run, its own summary rewritten
    again = json.loads((tmp_path / "mc.json").read_text())
    assert again["ran_now"] == 0 and again["statistics"] == first["statistics"]
    worst = first["statistics"]["closed_loop"]["worst"][0]
    from sim.tools.montecarlo import replay_options

    replay = ["simulate", *first["replay_base"], *replay_options(worst), "--no-video", "--no-plots", "--quiet"]
    assert main([*replay, "--json", "replay.json"]) in (0, 1)
    rec = json.loads((tmp_path / "replay.json").read_text())
    assert rec["closed_loop"]["final_position_error_m"] == worst["final_position_error_m"]


def test_a_replay_names_the_studys_gains_not_the_file_they_came_from(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The replay commands named ``--gains FILE``: a gains file rewritten after the study (a resumed tune rewrites
    its --out) made the "bit for bit" replay run other gains. They now name the gains themselves."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "g.toml").write_text("[gains]\nkp = 7.123456789\nkd = 4.5\n")
    argv = ["montecarlo", "--scenario", "open", "--reference", "line", "--robot", "turtlebot3", "--runs", "1"]
    argv += ["--localiser", "fixes", "--jobs", "1", "--quiet", "--no-plots", "--json", "mc.json"]
    assert main([*argv, "--results", "mc.jsonl", "--gains", "g.toml"]) == 0
    rec = json.loads((tmp_path / "mc.json").read_text())
    base = rec["replay_base"]
    assert base[base.index("--gains") + 1] == "7.123456789,4.5"
    (tmp_path / "g.toml").write_text("[gains]\nkp = 1.0\nkd = 1.0\n")  # the file changes after the study
    from sim.tools.montecarlo import replay_options

    worst = rec["statistics"]["closed_loop"]["worst"][0]
    replay = ["simulate", *base, *replay_options(worst), "--no-video", "--no-plots", "--quiet", "--json", "r.json"]
    assert main(replay) == 0
    again = json.loads((tmp_path / "r.json").read_text())
    assert again["closed_loop"]["final_position_error_m"] == worst["final_position_error_m"]


def test_the_localiser_is_part_of_the_study_and_of_its_replays(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The TurtleBot3's runs on its scan localiser (its default) or on Gaussian fixes: two studies, each
    replayed on the source it ran on."""
    monkeypatch.chdir(tmp_path)
    base = ["montecarlo", "--scenario", "open", "--reference", "line", "--robot", "turtlebot3", "--runs", "1"]
    base += ["--jobs", "1", "--quiet", "--no-plots"]
    records = {}
    for name, extra in (("amcl", []), ("fixes", ["--localiser", "fixes"])):
        assert main([*base, *extra, "--json", f"{name}.json", "--results", f"{name}.jsonl"]) in (0, 1)
        records[name] = json.loads((tmp_path / f"{name}.json").read_text())
    assert "--localiser" not in records["amcl"]["replay_base"]
    fixes = records["fixes"]["replay_base"]
    assert fixes[fixes.index("--localiser") + 1] == "fixes"
    assert records["amcl"]["key"] != records["fixes"]["key"] and records["fixes"]["key"]["localiser"] == "fixes"


def test_a_study_of_another_tracker_is_its_own_and_replays_on_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """montecarlo had no --feedback: only the FBL could be studied from the command line (no mpc, rpp, kanayama, nor a
    plugin's tracker), though simulate and compare run them all."""
    monkeypatch.chdir(tmp_path)
    base = ["montecarlo", "--scenario", "open", "--reference", "line", "--robot", "turtlebot3", "--runs", "1"]
    base += ["--localiser", "fixes", "--jobs", "1", "--no-plots"]
    records = {}
    for name, extra in (("fbl", []), ("kanayama", ["--feedback", "kanayama", "--quiet"])):
        assert main([*base, *extra, "--json", f"{name}.json", "--results", f"{name}.jsonl"]) == 0
        records[name] = json.loads((tmp_path / f"{name}.json").read_text())
        if name == "fbl":  # the study's every output, its results file too
            said = capsys.readouterr().out.splitlines()
            assert said[-2:] == ["wrote fbl.jsonl (1 run appended)", "wrote fbl.json"], said[-3:]
    assert records["fbl"]["key"]["tracker"] == "fbl" and records["kanayama"]["key"]["tracker"] == "kanayama"
    assert records["fbl"]["statistics"] != records["kanayama"]["statistics"]  # another law drove the closed loops
    from sim.tools.montecarlo import replay_options

    worst = records["kanayama"]["statistics"]["closed_loop"]["worst"][0]
    replay = ["simulate", *records["kanayama"]["replay_base"], *replay_options(worst), "--no-video", "--no-plots"]
    feedback = records["kanayama"]["replay_base"].index("--feedback")
    assert (
        records["kanayama"]["replay_base"][feedback + 1] == "kanayama"
        and "--feedback" not in records["fbl"]["replay_base"]
    )
    replay = [arg for arg in replay if arg != "--quiet"]
    assert main([*replay, "--quiet", "--json", "replay.json"]) == 0
    rec = json.loads((tmp_path / "replay.json").read_text())
    assert rec["closed_loop"]["final_position_error_m"] == worst["final_position_error_m"]  # bit for bit
    capsys.readouterr()
    for extra, said in (
        (["--feedback", "mpc", "--gains", "3,2"], "--gains: tracker mpc does not use the FBL's gains; drop --gains"),
        (["--feedback", "open-loop"], "the open loop is a run of every study already (open_loop)"),
    ):
        assert main([*base, *extra, "--quiet", "--json", "bad.json", "--results", "bad.jsonl"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("nhsim montecarlo: error: ") and said in err and err.count("\n") == 1, err
    assert not (tmp_path / "bad.jsonl").exists()


def test_statistics_of_no_measured_run_are_nan_not_errors() -> None:
    stats = statistics([{"index": 0, "plan_seed": 1, "noise_seed": 1, "build_seed": 1, "failed": "plan"}])
    assert stats["plan_failures"] == 1 and stats["closed_loop"]["success_rate"] == 0.0


def test_runs_that_ended_early_are_counted_by_why_and_said_under_the_table() -> None:
    """A study whose closed loops all stopped at t = 1.5 s of 9 s (the estimator diverged, 2.58 m from the goal)
    printed their final errors (0.11 m) as if they had run to the end, with no word of it: they are counted by
    why now, in the statistics and under the table."""
    from sim.cli.montecarlo import format_table

    def entry(status: str) -> dict[str, object]:
        metrics = dict.fromkeys(("final_position_error_m", "final_heading_error_rad", "rms_position_error_m"), 0.1)
        return {
            **metrics,
            "max_position_error_m": 0.2,
            "collisions": 0,
            "warnings": 0,
            "status": status,
            "success": status == "ok",
            "path": [],
        }

    statuses = ["estimator diverged at t=1.500 s (innovation): ...", "ok", "fell at t=2.1 s (|tilt| beyond 0.85 rad)"]
    records = [
        {
            "index": k,
            "plan_seed": 1,
            "noise_seed": k,
            "build_seed": k,
            "perturbation": None,
            "runs": {kind: entry(status) for kind in ("closed_loop", "closed_loop_odometry", "open_loop")},
        }
        for k, status in enumerate(statuses)
    ]
    stats = statistics(records)
    assert stats["closed_loop"]["ended_early"] == {"estimator diverged": 1, "fell": 1}
    table = format_table(stats)
    assert (
        "closed_loop: 2 of 3 runs ended early (estimator diverged: 1, fell: 1); their errors above are where" in table
    )
    assert statistics(records[1:2])["closed_loop"]["ended_early"] == {}
    assert "ended early" not in format_table(statistics(records[1:2]))


@pytest.mark.slow  # a Dask cluster of two worker processes
def test_regress_on_two_workers_reports_what_the_serial_run_reports(capsys: pytest.CaptureFixture[str]) -> None:
    cases = ["--case", "open-turtlebot3-line-fbl-s0,open-turtlebot3-line-open-loop-s0"]
    assert main(["regress", *cases]) == 0
    serial = capsys.readouterr().out
    assert main(["regress", *cases, "--jobs", "2"]) == 0
    assert capsys.readouterr().out == serial
    assert "2 passed, 0 failed of 2 case(s)" in serial


@pytest.mark.slow  # a Dask cluster of two worker processes
def test_sweep_cases_on_two_workers_give_the_serial_rows() -> None:
    from sim.pipeline.sweep import sweep_case, sweep_task

    cases = [Case("parallel_park", robot="turtlebot3", planner="birrt"), Case("turn_in_place", planner="sinusoidal")]
    with DaskExecutor(jobs=2) as ex:
        rows = {case.name: row for case, row in ex.map_unordered(sweep_task, cases)}
    for case in cases:
        ours, theirs = rows[case.name], sweep_case(case)
        assert ours.outcome == theirs.outcome and ours.runs == theirs.runs  # every metric of every run, exactly


def test_a_path_file_runs_as_a_study_resumes_and_replays(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--path`` (published trajectory files) as simulate reads it: an arena around the file, every run judged
    as a plan; the replay command reads the file again and gives the same run."""
    import numpy as np

    monkeypatch.chdir(tmp_path)
    f = tmp_path / "nav.csv"
    f.write_text("x,y\n" + "\n".join(f"{x!r},0.5" for x in np.linspace(-1.0, 0.0, 11).tolist()) + "\n")
    argv = ["montecarlo", "--path", str(f), "--runs", "2", "--jobs", "1", "--quiet", "--no-plots"]
    argv += ["--json", "mc.json", "--results", "mc.jsonl"]
    assert main(argv) == 0
    rec = json.loads((tmp_path / "mc.json").read_text())
    assert rec["key"]["source"] == f"file:{f}" and rec["key"]["file"]["kind"] == "path"
    assert rec["statistics"]["closed_loop"]["success_rate"] == 1.0
    f.write_text(f.read_text().replace("0.0,0.5", "0.0,0.6"))  # another file: another study
    with pytest.raises(ConfigError, match="another study"):
        from sim.cli.montecarlo import _spec

        ResultsFile(tmp_path / "mc.jsonl", _spec(build_argv(argv)).key())
    f.write_text(f.read_text().replace("0.0,0.6", "0.0,0.5"))
    worst = rec["statistics"]["closed_loop"]["worst"][0]
    from sim.tools.montecarlo import replay_options

    replay = ["simulate", *rec["replay_base"], *replay_options(worst), "--no-video", "--no-plots", "--quiet"]
    assert main([*replay, "--runs", "closed_loop", "--json", "replay.json"]) == 0
    again = json.loads((tmp_path / "replay.json").read_text())
    assert again["closed_loop"]["final_position_error_m"] == worst["final_position_error_m"]


def build_argv(argv: list[str]) -> object:
    from sim.cli.main import build_parser

    return build_parser().parse_args(argv)


def test_replan_plans_each_run_with_its_own_seed(tmp_path: Path) -> None:
    spec = MonteCarloSpec(Case("parallel_park", robot="turtlebot3", planner="birrt", seed=2), 2, replan=True)
    result = run_montecarlo(spec, Executor(), ResultsFile(tmp_path / "r.jsonl", spec.key()))
    for rec, draw in zip(result.records, spec.draws(), strict=True):
        assert rec["plan_seed"] == rec["noise_seed"] == draw.seed != spec.case.seed
        assert rec["runs"]["closed_loop"]["success"]
    reread = ResultsFile(tmp_path / "r.jsonl", spec.key(), seeds=spec.record_seeds)  # its seeds: the study's
    assert [reread.records[i] for i in range(2)] == result.records
    once = MonteCarloSpec(spec.case, 2)
    assert once.key() != spec.key()  # replanned runs are another study
    assert all(
        r["plan_seed"] == 2
        for r in run_montecarlo(once, Executor(), ResultsFile(tmp_path / "o.jsonl", once.key())).records
    )


@pytest.fixture
def short_connect(monkeypatch: pytest.MonkeyPatch) -> float:
    """The scheduler's connection deadline cut to 2 s so the failures below are quick to test."""
    import sim.tools.executor as executor

    monkeypatch.setattr(executor, "CONNECT_TIMEOUT_S", 2)
    return 2.0


def _scheduler_refused(argv_scheduler: str, capsys: pytest.CaptureFixture[str], limit: float) -> str:
    start = time.monotonic()
    argv = ["montecarlo", "--reference", "line", "--runs", "2", "--quiet", "--no-plots"]
    assert main([*argv, "--scheduler", argv_scheduler]) == 2
    assert time.monotonic() - start < limit + 3  # the promised time, and a margin for a loaded machine
    err = capsys.readouterr().err
    assert "Traceback" not in err and argv_scheduler in err
    return err


def test_a_scheduler_address_that_is_no_address_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    err = _scheduler_refused("notanaddress", capsys, 0)
    assert "missing port number" in err and "tcp://HOST:PORT" in err


def test_an_http_server_at_the_scheduler_address_is_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], short_connect: float
) -> None:
    import threading
    from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

    class Quiet(BaseHTTPRequestHandler):
        def log_message(self, *args: object) -> None:
            pass

    monkeypatch.chdir(tmp_path)
    server = ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        err = _scheduler_refused(f"tcp://127.0.0.1:{server.server_address[1]}", capsys, short_connect)
    finally:
        server.shutdown()
        server.server_close()
    assert "an HTTP server answered" in err and "not a Dask scheduler" in err


def test_a_silent_server_at_the_scheduler_address_fails_in_the_promised_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], short_connect: float
) -> None:
    import socket
    import threading

    monkeypatch.chdir(tmp_path)
    listener = socket.create_server(("127.0.0.1", 0))
    accepted: list[socket.socket] = []
    stop = threading.Event()

    def accept() -> None:
        listener.settimeout(0.1)
        while not stop.is_set():
            try:
                accepted.append(listener.accept()[0])  # and say nothing
            except TimeoutError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        err = _scheduler_refused(f"tcp://127.0.0.1:{listener.getsockname()[1]}", capsys, short_connect)
    finally:
        stop.set()
        thread.join()
        for s in [*accepted, listener]:
            s.close()
    assert "accepted the connection but sent nothing within 2 s" in err


def test_a_refused_scheduler_is_waited_for_saying_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], short_connect: float
) -> None:
    """Refused connections are retried to the deadline (a scheduler still starting refuses them), 10 s by default,
    without a word; a wait past a second says so."""
    import socket

    monkeypatch.chdir(tmp_path)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # closed again: nothing listens there
    err = _scheduler_refused(f"tcp://127.0.0.1:{port}", capsys, short_connect)
    assert f"waiting for the Dask scheduler at tcp://127.0.0.1:{port} (Connection refused), up to 2 s" in err
    assert err.count("waiting for") == 1 and f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}" in err


@pytest.mark.slow  # a Dask cluster of worker processes
def test_simulate_all_and_regress_run_on_a_scheduler_without_jobs(capsys: pytest.CaptureFixture[str]) -> None:
    """``--scheduler`` alone: the commands' own default of one process is not a given ``--jobs``."""
    cases = ["--case", "open-turtlebot3-line-fbl-s0,open-turtlebot3-line-open-loop-s0"]
    assert main(["regress", *cases]) == 0
    serial = capsys.readouterr().out
    sweep = ["simulate", "--all", "--robot", "turtlebot3", "--planner", "sinusoidal", "--quiet"]
    assert main(sweep) == 0
    serial_sweep = capsys.readouterr().out
    with _scheduler(workers=1) as cluster:  # type: ignore[attr-defined]
        assert main(["regress", *cases, "--scheduler", cluster.scheduler_address]) == 0
        assert capsys.readouterr().out == serial
        assert main([*sweep, "--scheduler", cluster.scheduler_address]) == 0
        rows = capsys.readouterr().out
    untimed = lambda text: sorted(" ".join(line.split()[:4] + line.split()[5:]) for line in text.splitlines())
    assert untimed(rows) == untimed(serial_sweep)  # every column but the planning time [s]
    assert "sinusoidal      ok" in rows


def test_more_runs_than_a_study_holds_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    """The seeds' own bound (268,435,456 runs) was taken: its draws took 18.5 GB and it had not started after three
    minutes. A study takes at most MAX_RUNS, fewer than the distinct draws."""
    from sim.tools.montecarlo import MAX_RUNS
    from sim.tools.tune import MAX_DRAWS

    assert MAX_RUNS <= MAX_DRAWS
    for runs in (MAX_RUNS + 1, MAX_DRAWS):
        assert main(["montecarlo", "--reference", "line", "--runs", str(runs), "--jobs", "1"]) == 2
        err = capsys.readouterr().err
        assert f"--runs must be an integer <= {MAX_RUNS}, got {runs}; a study makes each run's draws up front" in err


def test_refused_input_leaves_no_results_file_and_outputs_are_checked_before_any_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    base = ["montecarlo", "--scenario", "open", "--reference", "line", "--robot", "edumip", "--jobs", "1", "--quiet"]
    base += ["--no-plots", "--runs", "1"]
    # a localiser the robot cannot carry: refused, and no header-only results file left to block the next try
    assert main([*base, "--results", "q.jsonl", "--json", "q.json", "--localiser", "amcl"]) == 2
    assert "has no laser scanner" in capsys.readouterr().err and list(tmp_path.iterdir()) == []
    # two outputs at one path: refused before any run (the summary replaced the runs)
    assert main([*base, "--results", "same.json", "--json", "same.json"]) == 2
    said = "two outputs share a path: --results and --json (the summary) both name same.json"
    assert said in capsys.readouterr().err and list(tmp_path.iterdir()) == []
    # a --bags folder whose name is too long: refused (it was a traceback)
    assert main([*base, "--results", "l.jsonl", "--json", "l.json", "--bags", "b" * 260]) == 2
    assert "its folder name bbbb" in capsys.readouterr().err and list(tmp_path.iterdir()) == []
    # another study's runs: kept without --overwrite, replaced with it
    assert main([*base, "--results", "r.jsonl", "--json", "a.json", "--seed", "3"]) == 0
    assert main([*base, "--results", "r.jsonl", "--json", "b.json", "--seed", "4"]) == 2
    assert "holds the runs of another study (seed: 3 there, 4 here)" in capsys.readouterr().err
    assert main([*base, "--results", "r.jsonl", "--json", "b.json", "--seed", "4", "--overwrite"]) == 0
    assert json.loads((tmp_path / "r.jsonl").read_text().splitlines()[0])["key"]["seed"] == 4
    # a bags folder that holds bags: refused before the study without --overwrite, replaced with it
    assert main([*base, "--json", "c.json", "--results", "c.jsonl", "--bags", "bags"]) == 0
    assert (tmp_path / "bags" / "worst-0" / "metadata.yaml").is_file()
    shutil.copytree(tmp_path / "bags" / "worst-0", tmp_path / "bags" / "worst-7")  # a larger study's worst run
    (tmp_path / "bags" / "worst-0.check").write_text("a user's notes")  # a file, not a bag
    assert main([*base, "--json", "d.json", "--results", "d.jsonl", "--bags", "bags"]) == 2
    err = capsys.readouterr().err
    assert "--bags bags holds bags already (worst-0, worst-7)" in err and not (tmp_path / "d.json").exists()
    assert main([*base, "--json", "d.json", "--results", "d.jsonl", "--bags", "bags", "--overwrite"]) == 0
    # the earlier study's bags the new one did not replace are gone with it (they were not its worst runs)
    assert sorted(p.name for p in (tmp_path / "bags").iterdir()) == ["worst-0", "worst-0.check"]


def test_another_studys_results_file_is_refused_naming_what_differs_before_its_summary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The same command with one setting changed and ``--results`` alone (its summary and plots beside it, the
    other study's too) was refused for the summary: "r.json exists already; pass --overwrite ... (it is not this
    study's output)"; what differs was said only with --json elsewhere. It is said first now."""
    monkeypatch.chdir(tmp_path)
    base = ["montecarlo", "--scenario", "open", "--reference", "line", "--robot", "edumip", "--jobs", "1", "--quiet"]
    base += ["--runs", "1", "--results", "r.jsonl"]
    assert main([*base, "--seed", "3"]) == 0
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert sorted(before) == ["r-cdf.png", "r-fan.png", "r.json", "r.jsonl"]
    capsys.readouterr()
    assert main([*base, "--seed", "4"]) == 2
    assert capsys.readouterr().err == (
        "nhsim montecarlo: error: r.jsonl holds the runs of another study (seed: 3 there, 4 here); give another "
        "--results, the same settings, or --overwrite to replace it\n"
    )
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_a_results_file_of_ones_own_keeps_the_default_studys_summary_and_plots(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--results`` elsewhere named its summary and plots after the study's key, in renders/: a second run of the
    same study into another results file replaced the first one's summary (its statistics of 2 runs said 1) and
    plots, without --overwrite. They now go beside the results file given, and a summary of the same study's
    other results file is not this run's to replace."""
    monkeypatch.chdir(tmp_path)
    base = ["montecarlo", "--scenario", "open", "--reference", "line", "--robot", "edumip", "--jobs", "1", "--quiet"]
    base += ["--no-plots", "--seed", "5"]
    assert main([*base, "--runs", "2"]) == 0
    (default,) = (tmp_path / "renders").glob("*-mc-*.json")
    before = default.read_bytes()
    assert main([*base, "--runs", "1", "--results", "mine/r.jsonl"]) == 0
    assert default.read_bytes() == before and json.loads(before)["statistics"]["closed_loop"]["runs"] == 2
    mine = json.loads((tmp_path / "mine" / "r.json").read_text())
    assert mine["results"] == "mine/r.jsonl" and mine["statistics"]["closed_loop"]["runs"] == 1
    # the default summary given as --json for another results file: another run's statistics, refused
    assert main([*base, "--runs", "1", "--results", "mine/r.jsonl", "--json", str(default)]) == 2
    assert "it is not this study's output" in capsys.readouterr().err and default.read_bytes() == before


def test_plan_options_for_a_study_that_plans_nothing_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    # they changed the study's key (another results file) and nothing else
    argv = ["montecarlo", "--scenario", "open", "--reference", "line", "--runs", "1", "--jobs", "1"]
    assert main([*argv, "--time-limit", "5", "--replan"]) == 2
    assert "--time-limit, --replan are for a planned study, and this one plans nothing" in capsys.readouterr().err


def test_the_robot_and_localiser_left_to_the_scenario_are_the_study_that_names_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """open's own robot is the TurtleBot3, whose own localiser is amcl: the study that leaves them unsaid is
    the one that names them (resuming it without --robot was refused: "robot: 'turtlebot3' there, None
    here"), by its default outputs too; and the results an earlier nhsim keyed so (robot None, no
    localiser) are this study's."""
    import hashlib

    monkeypatch.chdir(tmp_path)
    base = ["montecarlo", "--scenario", "open", "--reference", "line", "--runs", "1", "--jobs", "1", "--quiet"]
    base += ["--no-plots"]
    assert main([*base, "--robot", "turtlebot3", "--localiser", "amcl"]) == 0
    (results,) = Path("renders").glob("*.jsonl")
    assert main(base) == 0  # resumed: nothing to run
    summary = results.with_suffix(".json")
    record = json.loads(summary.read_text())
    assert list(Path("renders").glob("*.jsonl")) == [results] and record["ran_now"] == 0
    assert record["key"]["robot"] == "turtlebot3" and record["key"]["localiser"] == "amcl"
    lines = results.read_text().splitlines(keepends=True)
    header = json.loads(lines[0])
    earlier = {k: v for k, v in header["key"].items() if k != "localiser"} | {"robot": None}
    tag = hashlib.sha1(json.dumps(earlier, sort_keys=True).encode()).hexdigest()[:6]
    old = results.with_name(f"{results.name.rsplit('-', 1)[0]}-{tag}.jsonl")
    old.write_text(json.dumps({**header, "key": earlier}) + "\n" + "".join(lines[1:]))
    old.with_suffix(".json").write_text(json.dumps({**record, "key": earlier, "results": str(old)}))
    results.unlink()
    summary.unlink()
    assert main(base) == 0  # found where the earlier nhsim put it, and resumed
    assert json.loads(old.with_suffix(".json").read_text())["ran_now"] == 0 and not results.exists()
    assert main([*base, "--results", str(old), "--json", "again.json", "--robot", "turtlebot3"]) == 0
    assert json.loads(Path("again.json").read_text())["ran_now"] == 0


def test_runs_made_by_other_code_are_not_resumed_into_this_codes_study(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The study's key is its settings; runs made by other code (a changed planner, speed profile or robot
    model) under the same settings were resumed as this code's and mixed into its statistics."""
    monkeypatch.chdir(tmp_path)
    base = ["montecarlo", "--scenario", "open", "--reference", "line", "--runs", "1", "--jobs", "1", "--quiet"]
    base += ["--no-plots", "--results", "r.jsonl", "--json", "r.json"]
    assert main(base) == 0
    lines = Path("r.jsonl").read_text().splitlines(keepends=True)
    header = json.loads(lines[0])
    assert len(header["code"]) == 12
    Path("r.jsonl").write_text(json.dumps({**header, "code": "0" * 12}) + "\n" + "".join(lines[1:]))
    capsys.readouterr()
    assert main([*base[:-1], "r3.json"]) == 2
    err = capsys.readouterr().err
    assert "made by other code (digest 000000000000)" in err and "--overwrite" in err
    assert main([*base[:-1], "r4.json", "--overwrite"]) == 0
    assert json.loads(Path("r4.json").read_text())["ran_now"] == 1


@pytest.mark.slow  # 3 s; the staged set itself: tests/test_output_safety.py
def test_the_record_and_plots_are_written_as_one_set(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The plots were replaced one by one before the record: a record that failed to write left the new plots
    beside the old record. They are one set now: all moved in, or none."""
    import sim.outputs

    monkeypatch.chdir(tmp_path)
    argv = ["montecarlo", "--scenario", "open", "--reference", "line", "--robot", "turtlebot3", "--runs", "2"]
    argv += ["--seed", "3", "--jobs", "1", "--quiet", "--json", "mc.json", "--results", "mc.jsonl"]
    assert main(argv) == 0
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.suffix in (".png", ".json")}
    assert len(before) >= 3  # the record and its plots

    def failing(path: Path, data: object, **kw: object) -> Path:
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(sim.outputs, "write_json", failing)
    assert main([*argv, "--overwrite", "--runs", "3"]) == 1  # another study: other plots; one line, a full disk
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.suffix in (".png", ".json")} == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".nhsim-outputs-")]


# ------------------------------------------------------------------------------- a cluster of the user's, set up badly
#: A ``dask worker`` whose environment lacks nhsim: importing ``sim`` fails as it does where nhsim is not installed.
_WORKER_WITHOUT_NHSIM = """
import sys

class NoNhsim:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "sim":
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)

sys.meta_path.insert(0, NoNhsim())
from distributed.cli.dask_worker import main
main()
"""


def _scheduler(workers: int = 0, processes: bool = True) -> object:
    """A scheduler in this process (and ``workers`` in-process workers), as ``dask scheduler`` serves one."""
    import logging

    from dask.distributed import LocalCluster

    from sim.tools.executor import LOCAL_SCHEDULER

    return LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=processes,
        protocol="tcp://",
        silence_logs=logging.ERROR,
        **LOCAL_SCHEDULER,  # type: ignore[arg-type]
    )


def test_workers_that_cannot_import_nhsim_are_refused_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """They ended the command with Dask's 51-line traceback of ``ModuleNotFoundError: No module named 'sim'``, exit
    status 1 (a failed run): a cluster set up badly is bad input, said in one line with the fix."""
    import subprocess
    import sys

    from dask.distributed import Client

    monkeypatch.chdir(tmp_path)
    with _scheduler() as cluster:  # type: ignore[attr-defined]
        address = cluster.scheduler_address
        worker = subprocess.Popen(
            [sys.executable, "-c", _WORKER_WITHOUT_NHSIM, address, "--nthreads", "1", "--no-nanny", "--no-dashboard"],
            stderr=subprocess.DEVNULL,
        )
        try:
            with Client(address) as client:
                client.wait_for_workers(1, timeout=30)
            argv = ["montecarlo", "--reference", "line", "--runs", "2", "--quiet", "--no-plots", "--scheduler", address]
            assert main(argv) == 2
        finally:
            worker.kill()
            worker.wait()
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"nhsim montecarlo: error: the workers at {address} cannot import nhsim's sim.")
    assert "(No module named 'sim')" in err and "in each worker's environment" in err and "--jobs J" in err
    assert not list(tmp_path.iterdir())  # nothing written


def test_a_scheduler_that_cannot_import_nhsim_is_refused_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The scheduler reads every run's task: one started where nhsim is not installed ended the command with Dask's
    traceback of "Error during deserialization of the task graph", exit status 1, its workers having nhsim."""
    import subprocess
    import sys

    from dask.distributed import Client

    monkeypatch.chdir(tmp_path)
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler_cli = _WORKER_WITHOUT_NHSIM.replace("dask_worker", "dask_scheduler")
    scheduler = subprocess.Popen(
        [sys.executable, "-c", scheduler_cli, "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
        stderr=subprocess.DEVNULL,
    )
    worker = None
    try:
        for _ in range(300):  # until it listens
            with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), timeout=1):
                break
            time.sleep(0.1)
        worker = subprocess.Popen(  # a worker where nhsim is installed
            [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1", "--no-nanny"],
            stderr=subprocess.DEVNULL,
        )
        with Client(address) as client:
            client.wait_for_workers(1, timeout=60)
        argv = ["montecarlo", "--reference", "line", "--runs", "2", "--quiet", "--no-plots", "--scheduler", address]
        assert main(argv) == 2
    finally:
        for proc in (worker, scheduler):
            if proc is not None:
                proc.kill()
                proc.wait()
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"nhsim montecarlo: error: the scheduler at {address} cannot import nhsim's sim."), err
    assert "(No module named 'sim')" in err and "in the scheduler's environment and start it there" in err
    assert not list(tmp_path.iterdir())  # nothing written


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def test_runs_on_which_workers_keep_dying_end_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    """A batch whose workers died as often as the scheduler allows (a worker out of memory, or one that joined late
    where nhsim is not installed, dying on its first run) ended the command with Dask's KilledWorker traceback."""
    import operator

    import dask
    import distributed  # noqa: F401  (its defaults in dask's config first: set() of a key not there yet removes
    # the whole "distributed" table on leaving, and the next LocalCluster of this process failed with KeyError)

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), _scheduler(workers=1) as cluster:  # type: ignore[attr-defined]
        address = cluster.scheduler_address
        with DaskExecutor(address=address, kept="finished runs are kept") as ex:
            with pytest.raises(SimulationError) as err:
                list(ex.map_unordered(operator.call, [3], shared=os._exit))  # the worker's process ends: os._exit(3)
    said = str(err.value)
    assert said.startswith(f"1 worker at {address} died running the same runs (Dask's KilledWorker; the last"), said
    assert "where nhsim is not installed" in said and said.endswith("see the workers' logs; finished runs are kept")


def _times_ten(shared: object, item: int) -> int:
    time.sleep(0.2)  # long enough for the executor to see the worker at work
    return item * 10


def test_a_cluster_without_workers_says_so_once_and_waits_for_one(monkeypatch: pytest.MonkeyPatch) -> None:
    """A scheduler without a worker (none started yet, or its last one killed) made the runs wait forever in
    silence. The wait is said once, and the runs go on when a worker connects: no deadline ends them."""
    import sim.tools.executor as executor

    monkeypatch.setattr(executor, "NO_WORKER_S", 0.3)
    monkeypatch.setattr(executor, "WORKER_CHECK_S", 0.05)
    said: list[str] = []
    with _scheduler(processes=False) as cluster:  # type: ignore[attr-defined]
        address = cluster.scheduler_address

        def notify(message: str) -> None:
            said.append(message)
            if message.startswith("no worker"):
                time.sleep(0.5)  # the wait is said once, not on every look
                cluster.scale(1)  # the user starts a worker

        late = threading.Timer(15.0, cluster.scale, args=(1,))  # a worker anyway: a silent wait fails, not hangs
        late.start()
        try:
            with DaskExecutor(address=address, notify=notify, kept="finished runs are kept") as ex:
                assert dict(ex.map_unordered(_times_ten, [1, 2, 3])) == {1: 10, 2: 20, 3: 30}
        finally:
            late.cancel()
    assert said == [
        f"no worker is connected to {address}; the runs wait for one: start one with 'dask worker {address}' where "
        "nhsim is installed, or press Ctrl-C to stop: finished runs are kept",
        f"1 worker connected to {address}: the runs go on",
    ]


def test_montecarlo_on_a_cluster_without_workers_says_it_waits_on_stderr(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import sys

    import sim.tools.executor as executor

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(executor, "NO_WORKER_S", 0.2)
    monkeypatch.setattr(executor, "WORKER_CHECK_S", 0.05)
    with _scheduler(processes=False) as cluster:  # type: ignore[attr-defined]
        captured = sys.stderr

        class Stderr:  # starts a worker once the command has said it waits for one
            def write(self, text: str) -> int:
                if "no worker is connected" in text:
                    cluster.scale(1)
                return captured.write(text)

            def flush(self) -> None:
                captured.flush()

        monkeypatch.setattr(sys, "stderr", Stderr())
        argv = ["montecarlo", "--scenario", "open", "--reference", "line", "--runs", "1", "--quiet", "--no-plots"]
        argv += ["--results", "r.jsonl", "--json", "r.json", "--scheduler", cluster.scheduler_address]
        late = threading.Timer(30.0, cluster.scale, args=(1,))  # a worker anyway: a silent wait fails, not hangs
        late.start()
        try:
            assert main(argv) == 0
        finally:
            late.cancel()
    err = capsys.readouterr().err
    assert err.startswith(f"nhsim montecarlo: no worker is connected to {cluster.scheduler_address}; the runs wait")
    assert err.splitlines()[0].endswith("the finished runs are kept in r.jsonl, and the same command resumes")
    assert json.loads(Path("r.json").read_text())["ran_now"] == 1


def test_the_local_cluster_serves_no_dashboard_and_leaves_port_8787_alone(capfd: pytest.CaptureFixture[str]) -> None:
    """``dashboard_address=None`` is Dask's default port, not "none": the local cluster's scheduler served its
    dashboard on 127.0.0.1:8787, and when that port was taken warned (even with --quiet) "Port 8787 is already
    in use" in four lines."""
    import socket
    import warnings

    holder = socket.socket()
    try:
        holder.bind(("127.0.0.1", 8787))  # taken here, unless something else holds it already
        holder.listen()
    except OSError:
        pass
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with DaskExecutor(jobs=1) as ex:
                http = ex._cluster.scheduler.http_server  # type: ignore[union-attr]
                status = _http_status(f"http://127.0.0.1:{http.port}/status")
    finally:
        holder.close()
    assert http.port != 8787 and http.address == "127.0.0.1"  # a free port of the loopback interface
    assert status == 404  # no dashboard page (nor Dask's page asking for bokeh, which serves it)
    assert not [w for w in caught if "8787" in str(w.message)]
    assert "8787" not in capfd.readouterr().err


def _http_status(url: str) -> int:
    import urllib.error
    import urllib.request

    try:
        with urllib.request.urlopen(url, timeout=10) as reply:
            return int(reply.status)
    except urllib.error.HTTPError as exc:
        return exc.code
