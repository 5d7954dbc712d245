"""`nhsim simulate` outputs: MP4 + plots + JSON by default, nothing clobbered, options honoured."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from planning.errors import ConfigError
from sim.cli.main import main
from sim.outputs import write_json
from tests.render_helpers import require_gl

#: Two runs (the fused closed loop and the open loop), so that no third robot stands where the pixel
#: checks look for the closed-loop one.
FAST = [
    "simulate",
    "--reference",
    "line",
    "--runs",
    "closed_loop,open_loop",
    "--fps",
    "5",
    "--size",
    "320x240",
    "--quiet",
]
#: FAST's stem: the scenario's own robot, and the one non-default run setting (the runs) as the first 6 hex
#: digits of the SHA-1 of {"runs": [...]} as JSON with sorted keys.
STEM = "open-line-" + hashlib.sha1(json.dumps({"runs": ["closed_loop", "open_loop"]}).encode()).hexdigest()[:6]


def snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in sorted(folder.iterdir())}


def decode(path: Path) -> tuple[dict, np.ndarray]:
    gen = imageio_ffmpeg.read_frames(str(path))
    meta = next(gen)
    w, h = meta["size"]
    return meta, np.stack([np.frombuffer(b, np.uint8).reshape(h, w, 3) for b in gen])


def robot_pixels() -> tuple[np.ndarray, np.ndarray]:
    """Image positions of the closed-loop robot at the first and the last frame in the world picture (overview)."""
    from planning.core.robot import load_robot
    from planning.scenario import load_scenario
    from sim.physics.simulator import Simulator
    from sim.pipeline.runs import RunKind
    from sim.pipeline.simulate import simulate_reference
    from sim.viz.renderer import SceneRenderer
    from sim.viz.replay import RenderSettings, Replay
    from sim.viz.scene import Projection

    job = simulate_reference("open", reference="line", runs=(RunKind.CLOSED_LOOP, RunKind.OPEN_LOOP))
    model = Simulator(load_robot("turtlebot3"), load_scenario("open").world).model
    replay = Replay(model, job.trajectory, job.logs, RenderSettings(width=320, height=240, fps=5.0))
    found = []
    with SceneRenderer(model, 320, 240, max_geom=replay.required_geoms) as r:
        for k in (0, replay.n_frames - 1):
            replay.render_frame(r, k)  # poses the runs and the camera of frame k
            r.renderer.update_scene(replay.datas[0], camera=replay.camera)
            tr = replay.tracks[0]
            px, _ = Projection.from_scene(r.scene, *replay.world_size).pixels(np.array([[*tr.xy[tr.idx[k]], 0.1]]))
            found.append(px[0])
    return found[0], found[1]


def test_default_outputs_then_no_clobber(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    require_gl()
    monkeypatch.chdir(tmp_path)
    assert main(FAST) == 0
    renders = tmp_path / "renders"
    names = sorted(p.name for p in renders.iterdir())
    stem = STEM
    assert names == sorted(
        [f"{stem}.mp4", f"{stem}.json"]
        + [f"{stem}-{n}.png" for n in ("world", "errors", "commands", "estimation", "localiser")]
    )
    record = json.loads((renders / f"{stem}.json").read_text())
    assert sorted(Path(p).name for p in record["files"].values()) == names  # names every file written
    # the video: decodes, H.264 yuv420p, one frame per 1/fps of simulated time and the end's, right size, not blank
    meta, frames = decode(renders / f"{stem}.mp4")
    assert meta["codec"] == "h264" and meta["pix_fmt"].startswith("yuv420p")
    duration = record["closed_loop"]["duration_s"]
    assert frames.shape == (round(duration * 5) + 1, 240, 320, 3)
    assert record["video"]["frames"] == frames.shape[0]
    assert record["video"]["inset_magnification"] > 1.0  # the close-up is larger than the overview
    assert frames.std() > 5.0
    # the closed-loop robot moved: its pixels at the start differ between first and last frame, and so
    # do those where it ends
    p0, p1 = robot_pixels()
    assert np.hypot(*(p1 - p0)) > 15.0
    for p in (p0, p1):
        x, y = round(float(p[0])), round(float(p[1]))
        a = frames[0, y - 3 : y + 4, x - 3 : x + 4].astype(float)
        b = frames[-1, y - 3 : y + 4, x - 3 : x + 4].astype(float)
        assert np.abs(a - b).mean() > 20.0
    # second run, same outputs, no --overwrite: an error, and nothing on disk changes
    before = snapshot(renders)
    assert main(FAST) == 2
    assert snapshot(renders) == before
    # with --overwrite it replaces them
    assert main([*FAST, "--overwrite"]) == 0


def test_custom_paths_and_switches(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    # no video, no plots: only the record, no OpenGL needed
    assert main([*FAST, "--no-video", "--no-plots"]) == 0
    assert sorted(p.name for p in (tmp_path / "renders").iterdir()) == [f"{STEM}.json"]
    record = json.loads((tmp_path / "renders" / f"{STEM}.json").read_text())
    assert record["files"] == {"json": f"renders/{STEM}.json"}
    # with no video, --json moves the record and the plots beside it (they went to ./renders/ whatever --json said)
    before = sorted(p.name for p in (tmp_path / "renders").iterdir())
    assert main([*FAST, "--no-video", "--json", str(tmp_path / "out" / "rec.json")]) == 0
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert "rec.json" in names and "rec-world.png" in names and all(n.startswith("rec") for n in names)
    assert sorted(p.name for p in (tmp_path / "renders").iterdir()) == before


def test_bad_options_fail_before_running(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main([*FAST, "--video", "out.avi"]) == 2
    assert main([*FAST, "--size", "161x120"]) == 2
    assert main([*FAST, "--size", "big"]) == 2
    assert main([*FAST, "--no-video", "--video", "x.mp4"]) == 2
    assert not (tmp_path / "renders").exists()


def test_video_path_moves_every_output(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    require_gl()
    monkeypatch.chdir(tmp_path)
    assert main([*FAST, "--video", "out/run.mp4", "--fps", "2"]) == 0
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    pngs = ["run-commands.png", "run-errors.png", "run-estimation.png", "run-localiser.png", "run-world.png"]
    assert names == [*pngs, "run.json", "run.mp4"]
    assert not (tmp_path / "renders").exists()


def test_the_estimation_plot_is_planned_beside_the_others(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Its name is decided and checked before running like every target; a job that gives no estimates
    does not write it (see test_default_outputs_then_no_clobber)."""
    from planning.errors import OutputExistsError
    from sim.cli.job_outputs import plan_outputs
    from sim.cli.main import build_parser

    monkeypatch.chdir(tmp_path)
    args = build_parser().parse_args([*FAST, "--no-video"])
    settings = {"runs": ["closed_loop", "open_loop"]}
    plan = plan_outputs(args, scenario="open", own_robot="turtlebot3", source="line", changed=settings)
    assert list(plan.plots) == ["world", "errors", "commands", "estimation", "localiser"]
    assert plan.plots["estimation"] == Path(f"renders/{STEM}-estimation.png")
    stale = tmp_path / "renders" / f"{STEM}-estimation.png"
    stale.parent.mkdir()
    stale.write_bytes(b"x")
    with pytest.raises(OutputExistsError, match=rf"{STEM}-estimation\.png"):
        plan_outputs(args, scenario="open", own_robot="turtlebot3", source="line", changed=settings)
    assert main([*FAST, "--no-video"]) == 2
    assert stale.read_bytes() == b"x"


def test_write_json_writes_standard_json_with_null_for_non_finite(tmp_path: Path) -> None:
    data = {"a": float("nan"), "b": [1.5, float("inf"), -float("inf")], "c": np.array([0.25, np.nan]), "d": "x"}
    path = write_json(tmp_path / "r.json", data)
    text = path.read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {"a": None, "b": [1.5, None, None], "c": [0.25, None], "d": "x"}


def _tree(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--video", "/proc/nope/x.mp4"], "cannot write /proc/nope/x.mp4: its folder /proc/nope does not exist"),
        (["--video", "blocker/x.mp4"], "cannot write blocker/x.mp4: blocker is a file, not a folder"),
        (["--no-video", "--no-plots", "--json", "blocker/sub/r.json"], "cannot write blocker/sub/r.json: blocker is"),
        (["--no-video", "--json", "blocker/sub/r.json"], "cannot write blocker/sub/r-world.png: blocker is a file"),
        (["--no-video", "--json", "folder"], "cannot write folder: it is a folder"),
        (["--no-video", "--no-plots", "--json", "locked/r.json"], "its folder locked does not accept new files"),
        (["--no-video", "--no-plots", "--json", "n" * 300 + ".json"], "its name is 305 bytes long; at most 255"),
        # the name fits, its temporary name (".NAME.XXXXXXXX.part.json") does not
        (["--no-video", "--no-plots", "--json", "n" * 245 + ".json"], "would be 265 bytes long; at most 255 fit"),
        (["--no-video", "--no-plots", "--json", "/".join(["d" * 200] * 21) + "/r.json"], "path is 4227 bytes long"),
        # a folder's name too long raised OSError from is_dir, a traceback
        (["--no-video", "--no-plots", "--json", "d" * 260 + "/r.json"], "its folder name dddd"),
        # a bag folder is written as .NAME.XXXXXXXX.part/NAME/ and renamed: its name fit and the run failed at the end
        (["--no-video", "--no-plots", "--json", "r.json", "--bag", "b" * 250], "would be 265 bytes long; at most 255"),
        (["--no-video", "--no-plots", "--json", "r.json", "--bag", "b" * 260], "its name is 260 bytes long"),
    ],
)
def test_unwritable_outputs_fail_before_any_physics(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    options: list[str],
    message: str,
) -> None:
    if options[-1].startswith("/proc") and not Path("/proc").is_dir():
        pytest.skip("no /proc on this system")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "blocker").write_text("in the way")
    (tmp_path / "folder").mkdir()
    (tmp_path / "locked").mkdir()
    if "locked/r.json" in options:
        if os.geteuid() == 0:
            pytest.skip("the superuser may write into a read-only folder")
        (tmp_path / "locked").chmod(0o500)

    def no_physics(*args: object, **kwargs: object) -> None:
        raise AssertionError("the physics ran before the outputs were checked")

    monkeypatch.setattr("sim.pipeline.simulate.simulate", no_physics)
    before = _tree(tmp_path)
    assert main([*FAST, *options]) == 2
    assert message in capsys.readouterr().err
    assert _tree(tmp_path) == before


def test_sigterm_during_the_render_exits_130_and_leaves_no_file(tmp_path: Path) -> None:
    import signal
    import subprocess
    import sys
    import time

    require_gl()
    root = Path(__file__).resolve().parents[1]
    video = tmp_path / "run.mp4"
    cmd = [sys.executable, "-m", "sim", *FAST[:-5], "--fps", "30", "--size", "640x480", "--quiet"]
    proc = subprocess.Popen(
        [*cmd, "--video", str(video)],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(root)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 300
        rendering = ".nhsim-outputs-*.part/new/.run.*part.mp4"  # the video's temporary file, in the staging folder
        while not list(tmp_path.glob(rendering)) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert proc.poll() is None, (
            f"the render ended before it could be stopped: {proc.stderr.read() if proc.stderr else ''}"
        )
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "interrupted" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no partial video, nothing else either


def test_sigterm_is_an_interrupt_only_inside_the_block() -> None:
    import signal

    from sim.cli.interrupt import sigterm_as_interrupt

    def mine(signum: int, frame: object) -> None:
        raise AssertionError("the block's handler should have run")

    previous = signal.signal(signal.SIGTERM, mine)
    try:
        with pytest.raises(KeyboardInterrupt, match="SIGTERM"), sigterm_as_interrupt():
            signal.raise_signal(signal.SIGTERM)
        assert signal.getsignal(signal.SIGTERM) is mine
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_outputs_are_named_by_the_robot_and_the_run_settings(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    job = ["simulate", "--reference", "figure8", "--runs", "closed_loop", "--no-video", "--no-plots", "--quiet"]
    tag = hashlib.sha1(b'{"runs": ["closed_loop"]}').hexdigest()[:6]
    assert main([*job, "--robot", "turtlebot3"]) == 0  # the open arena's own robot: no robot in the name
    assert main([*job, "--robot", "edumip"]) == 0  # another robot: its own files, nothing refused
    assert main([*job, "--robot", "edumip"]) == 2  # the same job again is still never overwritten
    names = sorted(p.name for p in (tmp_path / "renders").iterdir())
    assert names == [f"open-figure8-{tag}.json", f"open-figure8-edumip-{tag}.json"]
    records = [json.loads((tmp_path / "renders" / n).read_text()) for n in names]
    assert [r["robot"] for r in records] == ["turtlebot3", "edumip"]


def test_a_scenario_file_with_another_robot_is_named_without_looking_it_up_by_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The robot part of an output name compares with the scenario file's own robot: the name inside a
    file is not a built-in scenario (``--robot`` used to fail with "unknown scenario 'myworld'")."""
    scenario = tmp_path / "s.toml"
    scenario.write_text(
        'name = "myworld"\nrobot = "turtlebot3"\nrobots = ["turtlebot3", "edumip"]\n[world]\n'
        "bounds = [-2.0, 2.0, -2.0, 2.0]\n[start]\npose = [0.0, 0.0, 0.0]\n[goal]\npose = [1.0, 0.0, 0.0]\n"
    )
    record = tmp_path / "run.json"
    record.write_text("{}")  # in the way: the job stops at its output check, before any physics
    job = ["simulate", "--scenario", str(scenario), "--reference", "line", "--no-video", "--no-plots"]
    assert main([*job, "--robot", "edumip", "--json", str(record), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "unknown scenario" not in err and str(record) in err and "exists" in err
    assert record.read_text() == "{}"


def _job_stem(*extra: str) -> str:
    """The stem ``simulate`` gives a job on open along figure8 (as :func:`sim.cli.simulate._track_job` does)."""
    from sim.cli.job_outputs import changed_settings, output_stem
    from sim.cli.main import build_parser
    from sim.cli.simulate import job_case, parse_runs, run_choices
    from sim.pipeline.case import load_case_scenario

    args = build_parser().parse_args(["simulate", "--scenario", "open", "--reference", "figure8", *extra])
    case, source = job_case(args)
    runs = parse_runs(args.runs) if args.runs is not None else run_choices()[args.tracker]
    settings = changed_settings(args, case, load_case_scenario(case), runs)
    return output_stem(args, scenario="open", own_robot="turtlebot3", source=source, changed=settings)


def test_the_settings_tag_names_non_default_settings_and_gains_files_by_content(tmp_path: Path) -> None:
    stem = _job_stem
    assert stem() == stem("--robot", "turtlebot3", "--seed", "0", "--control-rate", "50") == "open-figure8"
    tags = {
        stem(*o)
        for o in (["--gains", "4,3"], ["--gains", "4,4"], ["--build", "nominal"], ["--tracker", "fbl"], ["--seed", "3"])
    }
    assert len(tags) == 5 and all(t.startswith("open-figure8-") and len(t) == len("open-figure8-") + 6 for t in tags)
    assert stem("--robot", "edumip", "--gains", "4,3").startswith("open-figure8-edumip-")
    page = " ".join((Path(__file__).parents[1] / "docs" / "explanation" / "rendering.md").read_text().split())
    assert f"e.g. `{stem('--seed', '3')}.mp4` for `--seed 3`" in page  # the page's example is the name written
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text("[gains]\nkp = 4.0\nkd = 6.0\n")
    b.write_text("[gains]\nkd = 6.0\nkp = 4.0  # the same gains, another file\n")
    assert stem("--gains", str(a)) == stem("--gains", str(b)) == stem("--gains", "4,6")  # kd's default is 6
    b.write_text("[gains]\nkp = 5.0\nkd = 6.0\n")
    assert stem("--gains", str(a)) != stem("--gains", str(b))


@pytest.mark.parametrize(
    "restated",
    [
        ["--seed", "0", "--noise-seed", "0", "--control-rate", "50.0"],
        ["--gains", "9,6"],
        ["--runs", "open_loop,closed_loop_odometry,closed_loop"],
        ["--tracker", "both"],
        ["--build", "as-built", "--build-seed", "1"],
        ["--localiser", "amcl", "--initial-pose", "known"],
        ["--amcl", "max_particles=2000,min_particles=500", "--lidar", "beams=360"],
        ["--motors", "battery_voltage=11.1"],
        ["--perturb", "friction=1.0"],
        ["--time-limit", "5"],  # a reference plans nothing
    ],
)
def test_a_default_said_again_leaves_the_name_alone(restated: list[str]) -> None:
    """The tag names what the runs use, not how it was asked for: the defaults given again write the
    default job's files (and are refused as existing, not written beside them under a new name)."""
    assert _job_stem(*restated) == "open-figure8"


def test_the_tag_names_what_the_runs_use() -> None:
    from sim.cli.job_outputs import settings_tag

    assert _job_stem("--seed", "3") == _job_stem("--seed", "3", "--noise-seed", "3")
    assert _job_stem("--amcl", "max_particles=1000") != "open-figure8"
    assert _job_stem("--localiser", "fixes") != "open-figure8"
    pert = {"friction": 0.6, "mass": 1.0, "radius": 1.0, "noise": 0.0, "heading_noise": 0.0, "latency": 0.0, "seed": 0}
    assert _job_stem("--perturb", "friction=0.6") == "open-figure8-" + settings_tag({"perturbation": pert})


def test_a_scenario_name_cannot_lead_the_outputs_out_of_their_folder(tmp_path: Path) -> None:
    from sim.cli.job_outputs import DEFAULT_DIR, file_safe, plan_outputs
    from sim.cli.main import build_parser

    assert file_safe("../../escaped") == "_.._escaped" and file_safe("ümlaut name") == "ümlaut_name"
    assert file_safe("edumip_map") == "edumip_map" and file_safe("c-rrt-star") == "c-rrt-star"
    args = build_parser().parse_args(["simulate", "--no-video"])
    plan = plan_outputs(args, scenario="../../escaped", source="rrt", own_robot="turtlebot3", changed={})
    assert plan.json == DEFAULT_DIR / "_.._escaped-rrt.json"
    assert all(p.parent == DEFAULT_DIR for p in plan.targets())


def test_the_pitch_plot_is_planned_for_a_balancing_robot(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from sim.cli.job_outputs import plan_outputs
    from sim.cli.main import build_parser

    monkeypatch.chdir(tmp_path)
    args = build_parser().parse_args([*FAST, "--no-video", "--robot", "edumip-balancing"])
    plan = plan_outputs(args, scenario="open", source="line", changed={})
    assert list(plan.plots) == ["world", "errors", "commands", "estimation", "pitch"]
    assert plan.plots["pitch"].name.startswith("open-line-edumip-balancing") and plan.plots["pitch"].name.endswith(
        "-pitch.png"
    )


def test_video_options_given_with_no_video_are_named_as_ignored(capsys: pytest.CaptureFixture[str]) -> None:
    from sim.cli.job_outputs import plan_outputs
    from sim.cli.main import build_parser

    def note(*extra: str) -> str:
        args = build_parser().parse_args(["simulate", "--no-video", *extra])
        plan_outputs(args, scenario="open", source="line", own_robot="turtlebot3", changed={})
        return capsys.readouterr().err

    assert note() == "" and note("--fps", "30", "--camera", "overview") == ""  # the defaults, said again
    assert note("--size", "640X480") == note("--size", "640\u00d7480") == ""  # the default size, spelt otherwise
    assert note("--fps", "10", "--quality", "high") == (
        "nhsim simulate: --fps, --quality ignored: they set the video, and --no-video writes none\n"
    )
    said = "nhsim simulate: --size ignored: it sets the video, and --no-video writes none\n"
    assert note("--size", "320x240") == said


@pytest.mark.parametrize(
    ("extra", "said"),
    [
        (["--size", "big"], "--size must look like WIDTHxHEIGHT"),
        (["--size", "640_0x480"], "--size must look like WIDTHxHEIGHT"),  # int() read 6400
        (["--size", "+640x480"], "--size must look like WIDTHxHEIGHT"),
        (["--size", "\uff16\uff14\uff10x480"], "--size must look like WIDTHxHEIGHT"),  # full-width digits
        (["--size", "641x480"], "must be even"),
        (["--size", "8192x8192"], "4096"),
        (["--fps", "-5"], "fps"),
        (["--size", "4096x2304", "--fps", "60"], "a second"),
    ],
)
def test_bad_video_options_are_refused_with_no_video_too(extra: list[str], said: str) -> None:
    """A bad value is an error whether or not a video is written: passed over as "ignored", it would be refused
    the day the same command line drops --no-video."""
    from sim.cli.job_outputs import plan_outputs
    from sim.cli.main import build_parser

    for video in (["--no-video"], []):
        args = build_parser().parse_args(["simulate", *video, *extra])
        with pytest.raises(ConfigError, match=said):
            plan_outputs(args, scenario="open", source="line", own_robot="turtlebot3", changed={})


def test_write_json_writes_arrays_compactly_and_exactly(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    path = rng.normal(size=(400, 3))
    path[7, 1] = np.inf
    data = {
        "path": path,
        "directions": np.array([1, -1, 1], dtype=np.int8),
        "flags": np.array([True, False]),
        "deep": {"m": np.eye(2), "row": np.ones((1, 2)), "none": np.zeros((0, 3)), "x": np.float64(2.5)},
    }
    text = write_json(tmp_path / "r.json", data).read_text()
    back = json.loads(text)
    expect = path.copy().tolist()
    expect[7][1] = None
    assert back["path"] == expect  # every float as written by repr: exact
    assert back["directions"] == [1, -1, 1] and back["flags"] == [True, False]
    assert back["deep"] == {"m": [[1.0, 0.0], [0.0, 1.0]], "row": [[1.0, 1.0]], "none": [], "x": 2.5}
    lines = text.splitlines()
    assert '  "directions": [1, -1, 1],' in lines  # a vector on one line
    assert sum(line.startswith("    [") for line in lines) == 400  # a matrix one row per line, indented
    assert "      [1.0, 0.0]," in lines and '    "row": [[1.0, 1.0]],' in lines


@pytest.mark.parametrize(
    ("options", "said"),
    [
        (["--no-plots"], "is the default of --video (the video): give another with --video)"),
        (["--no-video"], "is the default of the world plot (beside the record): give another with --json)"),
        (["--no-video", "--no-plots"], "is the default of --json (the record): give another with --json)"),
    ],
)
def test_an_unwritable_default_output_names_the_option_that_moves_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], options: list[str], said: str
) -> None:
    """A working folder where renders/ cannot be made (read-only, or a file of that name) said "cannot write
    renders/open-line-world.png: ...; choose another path" of a path the user never gave."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "renders").write_text("in the way")
    assert main([*FAST, *options]) == 2
    err = capsys.readouterr().err
    assert "cannot write renders/" in err and said in err, err
    if "--no-video" in options:  # the record given there: its own message, no default said
        assert main([*FAST, *options, "--json", "renders/r.json"]) == 2
        assert "is the default of" not in capsys.readouterr().err


def test_a_plot_beside_the_video_names_video_as_what_moves_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """With a video the plots go beside it: the message told to give --json, which moved the record alone."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "renders" / f"{STEM}-world.png").mkdir(parents=True)  # a folder in the plot's way
    assert main(FAST) == 2
    err = capsys.readouterr().err
    assert "is the default of the world plot (beside the video): give another with --video)" in err, err


def test_a_no_video_overwrite_removes_the_video_of_the_set_it_replaces(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """--overwrite replaces a set: the plots it does not write again were removed, the old video stayed beside the
    new record and plots (another seed's); the removal is said beside the files written (it was said nowhere)."""
    monkeypatch.chdir(tmp_path)
    assert main([*FAST, "--video", "out/a.mp4"]) == 0
    assert (tmp_path / "out" / "a.mp4").is_file()
    capsys.readouterr()
    said = [a for a in FAST if a != "--quiet"]
    assert main([*said, "--no-video", "--json", "out/a.json", "--seed", "4", "--overwrite"]) == 0
    assert not (tmp_path / "out" / "a.mp4").exists()
    lines = capsys.readouterr().out.splitlines()
    assert "wrote out/a.json" in lines and "wrote out/a-world.png" in lines
    removed = [line for line in lines if line.startswith("removed")]
    assert removed == ["removed out/a.mp4 (of the set --overwrite replaced: this run writes no such file)"]
    record = json.loads((tmp_path / "out" / "a.json").read_text())
    assert "video" not in record["files"] and (tmp_path / "out" / "a-world.png").is_file()
    # a video elsewhere that the old record did not name beside it is left alone
    assert main([*FAST, "--video", "out/b.mp4", "--no-plots"]) == 0
    (tmp_path / "keep").mkdir()
    assert main([*FAST, "--no-video", "--no-plots", "--json", "keep/b.json", "--overwrite"]) == 0
    assert (tmp_path / "out" / "b.mp4").is_file()
