"""Outputs never replace what they must not: a FIFO, a socket or a device; a file the command reads (its
scenario, the scenario's map image); a file that cannot be renamed over (refused before any work). A
command's outputs are one set: an interrupt or a failed move leaves every old file as it was."""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import socket
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from planning.errors import ConfigError, OutputExistsError
from planning.scenario import SCENARIOS_DIR
from sim.cli.job_outputs import input_paths
from sim.cli.main import main
from sim.io.bag import check_bag_target
from sim.outputs import (
    OutputsNotPlacedError,
    atomic_path,
    check_distinct,
    check_writable,
    staged_outputs,
    write_json,
)
from tests.render_helpers import require_gl
from tests.test_bag import OLD_META

#: A quick simulate job: one run, the pose fixes (no scan localiser), no video.
JOB = ["simulate", "--reference", "line", "--runs", "closed_loop", "--localiser", "fixes", "--quiet"]
#: Its outputs in ``out/``: the record, the plots beside it, a bag.
OUTPUTS = ["--no-video", "--json", "out/job.json", "--bag", "out/bag"]


def _no_physics(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("the physics ran before the outputs were checked")

    monkeypatch.setattr("sim.pipeline.simulate.simulate", refuse)


def _tree(folder: Path) -> dict[str, tuple[bytes, int] | str]:
    """Every entry under ``folder``: a file's bytes and modification time, a folder as "dir", a FIFO as "fifo"."""
    found: dict[str, tuple[bytes, int] | str] = {}
    for path in sorted(folder.rglob("*")):
        key = str(path.relative_to(folder))
        if path.is_fifo():
            found[key] = "fifo"
        elif path.is_dir():
            found[key] = "dir"
        else:
            found[key] = (path.read_bytes(), path.stat().st_mtime_ns)
    return found


def _temporaries(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.name.startswith(".nhsim-outputs-") or ".part" in p.name]


def _map_scenario(folder: Path) -> tuple[Path, Path]:
    """A copy of edumip_map (a scenario file and the map image it reads) in ``folder``/scen, ``folder``/maps."""
    (folder / "scen").mkdir(parents=True)
    (folder / "maps").mkdir()
    scenario = folder / "scen" / "edumip_map.toml"
    shutil.copy(SCENARIOS_DIR / "edumip_map.toml", scenario)
    shutil.copy(SCENARIOS_DIR.parent / "maps" / "edumip_map.png", folder / "maps" / "edumip_map.png")
    return scenario, folder / "maps" / "edumip_map.png"


# ---- what is not a regular file -----------------------------------------------------------------


def test_a_fifo_is_refused_even_with_overwrite(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    fifo = tmp_path / "f.json"
    os.mkfifo(fifo)
    for overwrite in (False, True):
        with pytest.raises(ConfigError, match=r"it is a FIFO \(named pipe\)"):
            check_writable(fifo, overwrite=overwrite)
    with pytest.raises(ConfigError, match="it is a FIFO"), atomic_path(fifo, overwrite=True) as tmp:
        tmp.write_text("{}")
    monkeypatch.chdir(tmp_path)
    _no_physics(monkeypatch)
    assert main([*JOB, "--no-video", "--no-plots", "--json", "f.json", "--overwrite"]) == 2
    assert "cannot write f.json: it is a FIFO" in capsys.readouterr().err
    assert fifo.is_fifo() and _tree(tmp_path) == {"f.json": "fifo"}


def test_a_socket_and_links_to_what_is_no_regular_file_are_refused(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "to-fifo.json").symlink_to(tmp_path / "fifo")
    with pytest.raises(ConfigError, match="it is a symbolic link to a FIFO"):
        check_writable(tmp_path / "to-fifo.json", overwrite=True)
    sock = tmp_path / "s.json"
    if len(os.fsencode(str(sock))) >= 100:
        pytest.skip("the temporary folder's path is too long for a socket's address")
    with contextlib.closing(socket.socket(socket.AF_UNIX)) as server:
        server.bind(str(sock))
        with pytest.raises(ConfigError, match="it is a socket"):
            check_writable(sock, overwrite=True)
        assert sock.is_socket()


def test_a_stream_of_the_process_is_no_output_even_where_it_links_to_a_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """With stdout redirected to a file, ``/dev/stdout`` (a link to ``/proc/self/fd/1``, which names the file) passed
    as a link to a regular file, and ``--json /dev/stdout --overwrite`` put the record where the link stood (its
    advice said to pass --overwrite); refused now, as a link of one's own into /proc is. ``/dev/shm`` holds files."""
    out = tmp_path / "stdout.txt"
    with open(out, "w") as f, contextlib.redirect_stdout(f):
        stdout = f"/proc/self/fd/{f.fileno()}"
        (tmp_path / "mine.json").symlink_to(stdout)
        for given in (Path(f"/dev/fd/{f.fileno()}"), Path(stdout)):  # as /dev/stdout is, stdout going to the file
            said = "a file of the kernel's /proc or /dev"
            with pytest.raises(ConfigError, match=f"cannot write {given}: it is {said}"):
                check_writable(given, overwrite=True)
        with pytest.raises(ConfigError, match=f"it is a link to {stdout}, not a file an output may replace"):
            check_writable(tmp_path / "mine.json", overwrite=True)
    assert (tmp_path / "mine.json").is_symlink()
    if os.path.isdir("/dev/shm"):
        check_writable(Path("/dev/shm/nhsim-never-written.json"), overwrite=True)  # absent: passes


@pytest.mark.parametrize(
    "argv",
    [
        ["plan", "--scenario", "farm", "--json", "loop"],
        ["simulate", "--reference", "line", "--no-video", "--json", "loop"],
        ["compare", "--reference", "line", "--trackers", "fbl", "--json", "loop"],
        ["montecarlo", "--reference", "line", "--runs", "1", "--results", "loop"],
        ["tune", "--scenarios", "open:line", "--out", "loop"],
    ],
    ids=["plan", "simulate", "compare", "montecarlo", "tune"],
)
def test_an_output_in_a_loop_of_links_is_bad_input_said_as_such(
    argv: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A link that names itself given as an output ended every command with Python's "RuntimeError: Symlink loop"
    traceback and status 1."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "loop").symlink_to("loop")
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "loop: a loop of symbolic links" in err and "choose another path" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["loop"]


def test_a_link_to_a_file_is_replaced_by_the_output_and_the_file_it_named_kept(tmp_path: Path) -> None:
    kept = tmp_path / "kept.json"
    kept.write_text("old")
    link = tmp_path / "out.json"
    link.symlink_to(kept)
    with pytest.raises(OutputExistsError):
        write_json(link, {"new": 1})
    write_json(link, {"new": 1}, overwrite=True)
    assert not link.is_symlink() and '"new": 1' in link.read_text() and kept.read_text() == "old"
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to(tmp_path / "nowhere")
    with pytest.raises(OutputExistsError):  # a link is an existing file, even one naming nothing
        write_json(dangling, {})
    assert dangling.is_symlink()


# ---- outputs over inputs ------------------------------------------------------------------------


def test_the_scenarios_file_and_its_map_image_are_inputs(tmp_path: Path) -> None:
    scenario, image = _map_scenario(tmp_path)
    found = {p.resolve() for _, p in input_paths(argparse.Namespace(scenario=str(scenario)))}
    assert found == {scenario.resolve(), image.resolve()}
    builtin = {p.resolve() for _, p in input_paths(argparse.Namespace(scenario="edumip_map"))}
    assert builtin == {
        (SCENARIOS_DIR / "edumip_map.toml").resolve(),
        (SCENARIOS_DIR / "../maps/edumip_map.png").resolve(),
    }
    cases = argparse.Namespace(scenarios=f"{scenario}:line, open:circle")
    assert {p.resolve() for _, p in input_paths(cases)} == {
        scenario.resolve(),
        image.resolve(),
        (SCENARIOS_DIR / "open.toml").resolve(),
    }
    assert input_paths(argparse.Namespace(scenario="random3")) == []  # a generated world reads no file


def _map_yaml_scenario(folder: Path) -> tuple[Path, Path, Path]:
    """A scenario in ``folder``/scen whose world is a ROS map YAML in ``folder``/maps naming an image beside
    it in ``folder``/maps/img: (scenario, YAML, image)."""
    from PIL import Image

    for sub in ("scen", "maps", "maps/img"):
        (folder / sub).mkdir()
    pixels = np.full((60, 60), 254, np.uint8)
    pixels[20:30, 25:35] = 0  # one obstacle
    Image.fromarray(pixels).save(folder / "maps" / "img" / "m.pgm")
    (folder / "maps" / "m.yaml").write_text(
        "image: img/m.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n",
        encoding="utf-8",
    )
    scenario = folder / "scen" / "s.toml"
    scenario.write_text(
        'name = "yaml_map"\nrobot = "turtlebot3"\nplanner = "hybrid-a-star"\n\n[world]\n\n[world.map]\n'
        'yaml = "../maps/m.yaml"\n\n[start]\npose = [0.4, 0.4, 0.0]\n\n[goal]\npose = [2.5, 2.5, 0.0]\n',
        encoding="utf-8",
    )
    return scenario, folder / "maps" / "m.yaml", folder / "maps" / "img" / "m.pgm"


@pytest.mark.parametrize("which", ["yaml", "image"])
@pytest.mark.parametrize("command", ["plan", "simulate"])
def test_no_output_writes_over_the_scenarios_map_yaml_or_the_image_it_names(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], which: str, command: str
) -> None:
    scenario, yaml_path, image = _map_yaml_scenario(tmp_path)
    found = {p.resolve() for _, p in input_paths(argparse.Namespace(scenario=str(scenario)))}
    assert found == {scenario.resolve(), yaml_path.resolve(), image.resolve()}
    _no_physics(monkeypatch)
    target = yaml_path if which == "yaml" else image
    before = _tree(tmp_path)
    argv = ["plan", "--scenario", str(scenario), "--quiet"]
    if command == "simulate":
        argv = [*JOB, "--scenario", str(scenario), "--no-video", "--no-plots"]
    assert main([*argv, "--json", str(target), "--overwrite"]) == 2
    err = capsys.readouterr().err
    assert f"the output {target} is the input --scenario {scenario}" in err
    assert ("map YAML" in err) and (("the image its map YAML" in err) == (which == "image"))
    assert _tree(tmp_path) == before


@pytest.mark.parametrize("option", ["--json", "--plot"])
@pytest.mark.parametrize("which", ["scenario", "map"])
def test_plan_refuses_to_write_over_its_scenario_or_its_map(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, which: str
) -> None:
    scenario, image = _map_scenario(tmp_path)
    target = scenario if which == "scenario" else image
    before = _tree(tmp_path)
    assert main(["plan", "--scenario", str(scenario), option, str(target), "--overwrite", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"the output {target} is the input --scenario {scenario}" in err
    assert ("its map image" in err) == (which == "map")
    assert _tree(tmp_path) == before


def test_simulate_refuses_to_write_over_the_scenarios_map(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario, image = _map_scenario(tmp_path)
    _no_physics(monkeypatch)
    before = _tree(tmp_path)
    argv = [*JOB, "--scenario", str(scenario), "--no-video", "--no-plots", "--json", str(image), "--overwrite"]
    assert main(argv) == 2
    assert f"the output {image} is the input --scenario {scenario} (its map image" in capsys.readouterr().err
    assert _tree(tmp_path) == before


@pytest.mark.parametrize("option", ["--out", "--json", "--storage"])
def test_tune_refuses_to_write_over_a_cases_scenario(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], option: str
) -> None:
    monkeypatch.chdir(tmp_path)
    shutil.copy(SCENARIOS_DIR / "open.toml", tmp_path / "t.toml")
    argv = ["tune", "--scenarios", "t.toml:line", "--robot", "edumip", "--localiser", "fixes", "--trials", "1"]
    argv += ["--draws", "1", "--eval-runs", "0", "--overwrite", "--plots", "plots"]
    given = {"--out": "t.toml", "--json": "t.toml", "--storage": "sqlite:///t.toml"}
    if option != "--storage":
        argv += ["--storage", "sqlite:///t.db"]
    before = _tree(tmp_path)
    assert main([*argv, option, given[option]]) == 2
    assert "the output t.toml is the input --scenarios t.toml" in capsys.readouterr().err
    assert _tree(tmp_path) == before


@pytest.mark.parametrize(
    ("argv", "target"),
    [  # each reads the models folder without naming a file of it: the default scenario, open for a reference
        (["simulate", "--no-video", "--no-plots", "--runs", "closed_loop", "--json"], "scenarios/edumip_map.toml"),
        (["simulate", "--reference", "line", "--no-video", "--json"], "sensors/turtlebot3.toml"),
        (["simulate", "--reference", "line", "--no-video", "--no-plots", "--bag"], "bags/run"),
        (["compare", "--reference", "circle", "--trackers", "fbl", "--json"], "scenarios/open.toml"),
        (["plan", "--scenario", "farm", "--json"], "maps/edumip_map.png"),
        (["montecarlo", "--reference", "line", "--runs", "2", "--jobs", "1", "--results"], "robots/edumip.xml"),
        (["tune", "--scenarios", "open:line", "--trials", "1", "--draws", "1", "--json"], "balance/x.toml"),
    ],
)
def test_no_output_goes_into_the_models_folder_the_runs_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], argv: list[str], target: str
) -> None:
    """Only a scenario named with --scenario was an input: ``--json models/scenarios/open.toml --overwrite`` with
    the open scenario implied (a reference), the default scenario, its map, a sensor table or a robot's model
    were written over, and every later run failed. The check sees the models folder (a copy here, so a failure
    of the check cannot reach the real one)."""
    import planning.core.robot as robot_module

    models = tmp_path / "models"
    shutil.copytree(robot_module.MODELS_DIR, models)
    monkeypatch.setattr(robot_module, "MODELS_DIR", models)
    monkeypatch.chdir(tmp_path)
    before = _tree(models)
    assert main([*argv, str(models / target), "--overwrite", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"it is inside nhsim's models folder {models.resolve()}, which the runs read" in err, err
    assert _tree(models) == before and sorted(p.name for p in tmp_path.iterdir()) == ["models"]


def test_a_registered_robots_files_are_no_output(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from planning.core.robot import ROBOTS, register_robot
    from tests.registry_helpers import isolated
    from tests.test_robot_plugins import _robot

    with isolated(monkeypatch, (ROBOTS,), "loaded"):
        model, sensors = _robot(tmp_path / "mine", "mybot")
        register_robot("mybot", model, sensors=sensors)
        for path in (model, model.with_name("mybot_scene.xml"), sensors):
            with pytest.raises(ConfigError, match="it is one of robot mybot's files, which the runs read"):
                check_writable(path, overwrite=True)
        check_writable(tmp_path / "mine" / "record.json", overwrite=True)  # beside them: fine


# ---- one check of a scenario's [sensors] --------------------------------------------------------


@pytest.mark.parametrize("table", ["fix_rate = -10", "fix_rat = 10"])
def test_plan_refuses_the_sensor_table_simulate_refuses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], table: str
) -> None:
    monkeypatch.chdir(tmp_path)
    text = (SCENARIOS_DIR / "open.toml").read_text(encoding="utf-8")
    Path("s.toml").write_text(f"{text}\n[sensors]\n{table}\n", encoding="utf-8")
    _no_physics(monkeypatch)
    assert main([*JOB, "--scenario", "s.toml", "--no-video", "--no-plots", "--json", "r.json"]) == 2
    simulated = capsys.readouterr().err.removeprefix("nhsim simulate: error: ")
    assert main(["plan", "--scenario", "s.toml", "--planner", "hybrid-astar", "--json", "p.json", "--quiet"]) == 2
    planned = capsys.readouterr().err.removeprefix("nhsim plan: error: ")
    assert "s.toml" in planned and "sensors" in planned and planned == simulated
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


# ---- two outputs at one path --------------------------------------------------------------------


def test_two_outputs_at_one_path_are_named_alone(tmp_path: Path) -> None:
    paths = [tmp_path / n for n in ("a.png", "b.png", "sub/../c.json", "d.png", "c.json", "e.png")]
    with pytest.raises(ConfigError) as err:
        check_distinct(paths)
    message = str(err.value)
    assert f"{tmp_path / 'sub/../c.json'} and {tmp_path / 'c.json'}" in message
    assert not any(str(tmp_path / n) in message for n in ("a.png", "b.png", "d.png", "e.png"))


# ---- files that cannot be renamed over ----------------------------------------------------------


@contextlib.contextmanager
def _immutable(path: Path) -> Iterator[None]:
    """``path`` made immutable (``chattr +i``) for the block; skips where that cannot be done."""
    chattr = shutil.which("chattr")
    if chattr is None or subprocess.run([chattr, "+i", str(path)], capture_output=True).returncode != 0:
        pytest.skip("chattr +i does not work here")
    try:
        yield
    finally:
        subprocess.run([chattr, "-i", str(path)], check=True)


def test_an_immutable_output_is_refused_before_any_work(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    old = tmp_path / "old.json"
    old.write_text("old")
    _no_physics(monkeypatch)
    with _immutable(old):
        assert main([*JOB, "--no-video", "--no-plots", "--json", "old.json", "--overwrite"]) == 2
        assert "cannot replace old.json: it is immutable" in capsys.readouterr().err
        assert old.read_text() == "old" and _temporaries(tmp_path) == []


def _failing_rename(monkeypatch: pytest.MonkeyPatch, path: Path) -> None:
    """``os.rename`` and ``os.replace`` fail (EPERM) as for an immutable file at ``path``: a move that would
    take it away or replace it; moving a file to ``path`` where none is succeeds."""
    for name in ("rename", "replace"):
        real: Callable[..., None] = getattr(os, name)

        def fake(src: object, dst: object, *, real: Callable[..., None] = real) -> None:
            away = Path(str(src)).resolve() == path.resolve()
            if away or (Path(str(dst)).resolve() == path.resolve() and os.path.lexists(path)):
                raise PermissionError(1, "Operation not permitted", str(dst))
            real(src, dst)

        monkeypatch.setattr(os, name, fake)


def test_a_failed_rename_is_an_error_that_keeps_the_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    old = tmp_path / "old.json"
    old.write_text("old")
    _failing_rename(monkeypatch, old)
    with pytest.raises(OutputsNotPlacedError, match=f"could not put {old} in place: Operation not permitted"):
        write_json(old, {"new": 1}, overwrite=True)
    assert old.read_text() == "old" and _temporaries(tmp_path) == []


def test_regress_update_that_cannot_replace_a_baseline_says_so_and_keeps_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    suite, bl = tmp_path / "suite.toml", tmp_path / "bl"
    fields = 'scenario = "open", robot = "turtlebot3", tracker = "fbl", seed = 0, fast = true'
    suite.write_text(f'cases = [\n  {{ name = "one", reference = "line", {fields} }},\n]\n')
    bl.mkdir()
    baseline = bl / "one.json"
    baseline.write_text('{"metrics": ')  # unreadable: --update rewrites it
    argv = ["regress", "--suite", str(suite), "--baselines", str(bl), "--update"]
    with _immutable(baseline):  # refused before the case runs
        monkeypatch.setattr("sim.tools.regress.check_task", lambda *a, **k: pytest.fail("the case ran"))
        assert main(argv) == 2
        assert f"cannot replace {baseline}: it is immutable" in capsys.readouterr().err
    monkeypatch.undo()
    _failing_rename(monkeypatch, baseline)  # a move that fails at the end: a clear error, the old baseline kept
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"could not put {baseline} in place" in err and "Traceback" not in err
    assert baseline.read_text() == '{"metrics": ' and _temporaries(tmp_path) == []


# ---- one set: all or nothing --------------------------------------------------------------------


def test_the_staged_set_is_moved_in_together_or_not_at_all(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    a, b, bag = tmp_path / "a.json", tmp_path / "deep" / "b.json", tmp_path / "bag"
    a.write_text("old a")
    bag.mkdir()
    (bag / "metadata.yaml").write_text(OLD_META)  # a bag nhsim wrote: --overwrite replaces only those
    before = _tree(tmp_path)

    def write_all(stage: object) -> None:
        for path in (a, b):
            write_json(stage.path(path), {"new": path.name})  # type: ignore[attr-defined]
        new_bag = stage.path(bag)  # type: ignore[attr-defined]
        new_bag.mkdir()
        (new_bag / "metadata.yaml").write_text("new bag")

    with pytest.raises(KeyboardInterrupt), staged_outputs(overwrite=True, folders={bag: check_bag_target}) as stage:
        write_all(stage)
        raise KeyboardInterrupt  # before the set is moved in
    assert _tree(tmp_path) == before  # deep/ made for b.json is gone again
    with monkeypatch.context() as m:
        _failing_rename(m, bag)  # the last move fails: the two before it are undone
        with pytest.raises(OutputsNotPlacedError, match="no output was replaced"):
            with staged_outputs(overwrite=True, folders={bag: check_bag_target}) as stage:
                write_all(stage)
    assert _tree(tmp_path) == before
    with staged_outputs(overwrite=True, folders={bag: check_bag_target}) as stage:
        write_all(stage)
    assert '"new": "a.json"' in a.read_text() and '"new": "b.json"' in b.read_text()
    assert (bag / "metadata.yaml").read_text() == "new bag" and _temporaries(tmp_path) == []
    b.unlink()
    with pytest.raises(OutputExistsError), staged_outputs(overwrite=False) as stage:  # checked again at the end
        write_json(stage.path(b), {})
        b.write_text("written meanwhile")
    assert b.read_text() == "written meanwhile" and _temporaries(tmp_path) == []


def _interrupt(*args: object, **kwargs: object) -> None:
    raise KeyboardInterrupt


@pytest.mark.parametrize("video", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_an_interrupted_job_keeps_every_old_output(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], video: bool
) -> None:
    """The record, the plots, the bag (and the video, written first) of seed 0 survive a run of seed 1
    interrupted as its outputs are written: none is replaced, no temporary file is left."""
    if video:
        require_gl()
    monkeypatch.chdir(tmp_path)
    outputs = ["--video", "out/job.mp4", "--fps", "5", "--size", "160x120", *OUTPUTS[1:]] if video else OUTPUTS
    assert main([*JOB, *outputs]) == 0
    before = _tree(tmp_path)
    assert ("out/job.mp4" in before) == video and "out/bag/metadata.yaml" in before
    # the plots are drawn after the video: the interrupt lands with the new video written
    monkeypatch.setattr("sim.viz.plots.draw.save_figure", _interrupt)
    assert main([*JOB, *outputs, "--seed", "1", "--overwrite"]) == 130
    assert _tree(tmp_path) == before and _temporaries(tmp_path) == []
    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    _failing_rename(monkeypatch, tmp_path / "out" / "job.json")  # the last move fails: every move undone
    assert main([*JOB, *outputs, "--seed", "1", "--overwrite"]) == 2
    err = capsys.readouterr().err
    assert "could not put out/job.json in place" in err and "no output was replaced" in err
    assert _tree(tmp_path) == before and _temporaries(tmp_path) == []


def test_an_interrupted_compare_keeps_every_old_output(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    argv = ["compare", "--reference", "line", "--trackers", "fbl", "--json", "c/c.json", "--plots", "c/c", "--quiet"]
    assert main(argv) == 0
    before = _tree(tmp_path)
    monkeypatch.setattr("sim.viz.plots.draw.save_figure", _interrupt)  # the record is written first
    assert main([*argv, "--seed", "1", "--overwrite"]) == 130
    assert _tree(tmp_path) == before and _temporaries(tmp_path) == []


def test_a_folder_removed_while_the_command_ran_is_said_and_nothing_is_replaced(tmp_path: Path) -> None:
    """The output staged in a folder that was removed meanwhile was skipped without a word: the others moved in
    and the command said it wrote a file that was not there."""
    from sim.outputs import OutputsNotPlacedError, StagedOutputs

    kept, gone = tmp_path / "kept" / "r.json", tmp_path / "gone" / "r.json"
    kept.parent.mkdir()
    kept.write_text("old")
    stage = StagedOutputs(overwrite=True)
    stage.path(kept).write_text("new")
    stage.path(gone).write_text("new")
    shutil.rmtree(gone.parent)  # the folder, with the output staged in it
    with pytest.raises(OutputsNotPlacedError, match=r"gone/r\.json: its folder was removed .* no output was replaced"):
        stage.commit()
    stage.discard()
    assert kept.read_text() == "old" and sorted(p.name for p in kept.parent.iterdir()) == ["r.json"]


def test_a_target_another_command_wrote_meanwhile_is_refused_saying_so(tmp_path: Path) -> None:
    """Two identical commands started together: the one that finished second ran to its end and was refused as
    if the file had been there before ("exists already"), which it had checked it was not."""
    from planning.errors import OutputExistsError
    from sim.outputs import StagedOutputs

    target = tmp_path / "r.json"
    stage = StagedOutputs(overwrite=False)
    stage.path(target).write_text("mine")
    target.write_text("theirs")  # the other command's, placed first
    with pytest.raises(OutputExistsError, match=r"r\.json exists already; .*written while this command ran"):
        stage.commit()
    stage.discard()
    assert target.read_text() == "theirs" and sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_a_killed_commands_staging_folders_are_swept_when_stale_unless_they_hold_an_old_output(
    tmp_path: Path,
) -> None:
    """SIGKILL or a lost terminal's SIGHUP left hidden ``.nhsim-outputs-*.part`` folders (up to 2 MB each) that no
    later run removed. A later command staging in that folder removes those untouched for a day whose ``old``
    folder is empty; one holding an old output (a commit killed midway: the only copy of a replaced file), a
    recent one (another command's, at work) and anything else are kept."""
    import os

    from sim.outputs import STALE_STAGE_S, StagedOutputs

    def stage(name: str, old: bool, age: float) -> Path:
        folder = tmp_path / f".nhsim-outputs-{name}.part"
        (folder / "new").mkdir(parents=True)
        (folder / "new" / "run.mp4").write_bytes(b"x" * 100)
        (folder / "old").mkdir()
        if old:
            (folder / "old" / "run.json").write_text("the only copy")
        for p in (folder / "new" / "run.mp4", folder / "new", folder / "old", folder):
            os.utime(p, (0, os.stat(p).st_mtime - age))
        return folder

    stale, holding, recent = (
        stage("stale0001", False, 2 * STALE_STAGE_S),
        stage("holds001", True, 2 * STALE_STAGE_S),
        stage("recent01", False, 60.0),
    )
    other = tmp_path / ".nhsim-outputs-notmine"  # not a staging folder's name
    other.mkdir()
    os.utime(other, (0, 0))
    outputs = StagedOutputs(overwrite=False)
    outputs.path(tmp_path / "r.json").write_text("{}")
    outputs.commit()
    outputs.discard()
    assert not stale.exists() and holding.exists() and recent.exists() and other.exists()
    assert (holding / "old" / "run.json").read_text() == "the only copy" and (tmp_path / "r.json").read_text() == "{}"


def test_a_staged_outputs_path_is_shown_as_its_target(tmp_path: Path) -> None:
    """A full disk during video encoding named the hidden staging path (``renders/.nhsim-outputs-XXXXXXXX.part/new/
    v.mp4``), a file the user never named."""
    from sim.outputs import StagedOutputs, shown

    stage = StagedOutputs(overwrite=False)
    try:
        staged = stage.path(tmp_path / "renders" / "v.mp4")
        assert ".nhsim-outputs-" in str(staged) and shown(staged) == str(tmp_path / "renders" / "v.mp4")
    finally:
        stage.discard()
    assert shown("/a/b/v.mp4") == "/a/b/v.mp4" and shown(".nhsim-outputs-x1.part/new/v.mp4") == "v.mp4"


def test_a_retired_output_goes_with_the_commit_and_comes_back_with_its_undo(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    record, plot, last = tmp_path / "a.json", tmp_path / "a-localiser.png", tmp_path / "z.json"
    record.write_text("old record")
    plot.write_text("old plot")
    last.write_text("old z")
    before = _tree(tmp_path)
    with pytest.raises(KeyboardInterrupt), staged_outputs(overwrite=True) as stage:
        write_json(stage.path(record), {"new": 1})
        stage.retire(plot)
        raise KeyboardInterrupt  # not committed: nothing retired
    assert _tree(tmp_path) == before
    with monkeypatch.context() as m:
        _failing_rename(m, plot)  # the retirement fails after the record moved in: the record's move is undone
        with pytest.raises(OutputsNotPlacedError, match="no output was replaced"), staged_outputs(overwrite=True) as st:
            write_json(st.path(record), {"new": 1})
            st.retire(plot)
    assert _tree(tmp_path) == before
    with staged_outputs(overwrite=True) as stage:
        write_json(stage.path(record), {"new": 1})
        stage.retire(plot)
        stage.retire(tmp_path / "never-there.png")  # nothing to remove: nothing done
    assert not plot.exists() and '"new": 1' in record.read_text() and _temporaries(tmp_path) == []
    with pytest.raises(ConfigError, match="both written and removed"), staged_outputs(overwrite=True) as stage:
        write_json(stage.path(last), {})
        stage.retire(last)


@pytest.mark.slow  # 3 s, three jobs; StagedOutputs.retire itself is tested above
def test_overwrite_replaces_a_records_whole_set_of_plots(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """--overwrite replaced the record and the plots the new job drew, and left the others of the old set beside
    them: an EduMIP's record with the TurtleBot3 run's localiser plot; with --no-plots, every old plot."""
    monkeypatch.chdir(tmp_path)
    job = ["simulate", "--reference", "line", "--no-video", "--json", "x/a.json", "--quiet"]
    assert main(job) == 0
    plots = {p.name for p in (tmp_path / "x").glob("*.png")}
    assert "a-localiser.png" in plots  # the TurtleBot3 localises with its scans
    keep = tmp_path / "x" / "a-notes.png"  # a file of the user's that the record does not list
    keep.write_text("mine")
    assert main([*job, "--robot", "edumip", "--overwrite"]) == 0
    assert {p.name for p in (tmp_path / "x").glob("*.png")} == plots - {"a-localiser.png"} | {"a-notes.png"}
    assert main([*job, "--robot", "edumip", "--overwrite", "--no-plots"]) == 0
    assert sorted(p.name for p in (tmp_path / "x").iterdir()) == ["a-notes.png", "a.json"]


def test_what_the_models_guard_lets_through_and_what_it_stops(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A link at the output's own path into the models folder is replaced, not written through (allowed); a folder
    beside the models folder with a like name is fine; a plugin's robot registered wrongly does not stop every
    output (it stopped them all); the tune study's SQLite file is an output too (it was written into models/,
    whose digest then refused to resume the study)."""
    import planning.core.robot as robot_module
    from planning.core.robot import ROBOTS
    from sim.outputs import check_not_read_by_runs
    from tests.registry_helpers import isolated

    models = tmp_path / "models"
    (models / "scenarios").mkdir(parents=True)
    (models / "scenarios" / "open.toml").write_text("x")
    monkeypatch.setattr(robot_module, "MODELS_DIR", models)
    link = tmp_path / "out" / "f.json"
    link.parent.mkdir()
    link.symlink_to(models / "scenarios" / "open.toml")
    check_not_read_by_runs(link)
    check_not_read_by_runs(tmp_path / "models2" / "x.json")
    check_not_read_by_runs(models / "..")
    (tmp_path / "in").symlink_to(models)
    with pytest.raises(ConfigError, match="inside nhsim's models folder"):
        check_not_read_by_runs(tmp_path / "in" / "x.json")  # a folder's link is followed
    with isolated(monkeypatch, (ROBOTS,), "loaded"):
        ROBOTS.add("register_robot", "weird", lambda: "nope", False)
        check_writable(tmp_path / "r.json", overwrite=False)
    monkeypatch.chdir(tmp_path)
    argv = ["tune", "--scenarios", "open:line", "--trials", "1", "--draws", "1", "--out", "g.toml", "--quiet"]
    assert main([*argv, "--storage", f"sqlite:///{models}/t.db"]) == 2
    assert not (models / "t.db").exists()


def test_a_study_storage_named_in_another_form_is_still_apart_from_the_outputs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``sqlite+pysqlite:////abs.db`` and ``sqlite:///file:abs.db?uri=true`` were read by their prefix and not
    seen as the study's file: the record given that path ran every trial, then replaced the study."""
    monkeypatch.chdir(tmp_path)
    argv = ["tune", "--scenarios", "open:line", "--trials", "1", "--draws", "1", "--quiet", "--overwrite"]
    for url in (f"sqlite+pysqlite:///{tmp_path}/s.db", f"sqlite:///file:{tmp_path}/s.db?uri=true"):
        assert main([*argv, "--storage", url, "--json", str(tmp_path / "s.db")]) == 2
        assert "is the study's own storage" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == []
