"""A job's video draws the model its runs stepped, taken from the job (no simulator is rebuilt for it)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.scenario import load_scenario
from planning.trajectory.references import make_reference
from sim.physics.asbuilt import AsBuilt
from sim.physics.perturb import Perturbation
from sim.pipeline.case import Case, PreparedTrajectory
from sim.pipeline.runs import RunKind
from sim.pipeline.simulate import JobResult, track
from tests.render_helpers import require_gl

BUILD_SEED = 7


def _job(build_seed: int | None, perturbation: Perturbation | None = None) -> JobResult:
    sc = load_scenario("open")
    robot = load_robot(sc.robot)
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0), length=0.2)
    case = Case("open", reference="line", build_seed=build_seed, perturbation=perturbation)
    return track(PreparedTrajectory(case, sc, robot, traj, "reference:line"), (RunKind.CLOSED_LOOP,))


def _tyre_radius(model) -> float:  # type: ignore[no-untyped-def]
    return float(model.geom_size[model.geom("wheel_left_geom").id][0])


def test_a_job_carries_the_as_built_model_its_runs_stepped() -> None:
    job = _job(BUILD_SEED)
    drawn = AsBuilt.nominal().compile(job.robot, job.scenario.world).model
    built = AsBuilt.draw(job.robot.name, BUILD_SEED).compile(job.robot, job.scenario.world).model
    assert _tyre_radius(job.model) == _tyre_radius(built) != _tyre_radius(drawn)
    assert np.array_equal(job.model.body_mass, built.body_mass)


def test_a_job_model_carries_the_case_perturbation() -> None:
    job = _job(None, Perturbation(radius=1.05))
    drawn = AsBuilt.nominal().compile(job.robot, job.scenario.world).model
    assert _tyre_radius(job.model) == pytest.approx(1.05 * _tyre_radius(drawn), rel=1e-12)


def test_writing_a_video_builds_no_simulator(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    require_gl()
    from sim.physics import simulator
    from sim.viz.job_video import write_video
    from sim.viz.replay import RenderSettings

    job = _job(BUILD_SEED)

    def refuse(*_a: object, **_k: object) -> None:
        raise AssertionError("write_video built a Simulator")

    monkeypatch.setattr(simulator.Simulator, "__init__", refuse)
    seen = []
    from sim.viz import job_video

    replay = job_video.Replay

    def spy(model, *a, **k):  # type: ignore[no-untyped-def]
        seen.append(model)
        return replay(model, *a, **k)

    monkeypatch.setattr(job_video, "Replay", spy)
    facts = write_video(job, tmp_path / "job.mp4", RenderSettings(width=160, height=120, fps=10))
    assert facts["frames"] > 0 and (tmp_path / "job.mp4").stat().st_size > 0
    assert seen == [job.model]


def test_write_video_refuses_a_name_that_is_not_mp4_before_drawing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """It wrote MP4 data into "x.avi" (ffmpeg is told ``-f mp4``); now it refuses before drawing anything."""
    from planning.errors import ConfigError
    from sim.viz import job_video

    def refuse(*_a: object, **_k: object) -> None:
        raise AssertionError("write_video drew before checking the name")

    monkeypatch.setattr(job_video, "Replay", refuse)
    with pytest.raises(ConfigError, match=r"must name an \.mp4 file .*got .*x\.avi; end the name in \.mp4"):
        job_video.write_video(_job(BUILD_SEED), tmp_path / "out" / "x.avi")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("flag", ["no", "False", 0, 1, None])
def test_write_video_refuses_an_overwrite_that_is_not_true_or_false(tmp_path: Path, flag: object) -> None:
    """``overwrite="no"`` is truthy: read for its truth it replaced the video; a flag must be True or False."""
    require_gl()
    from planning.errors import ConfigError
    from sim.viz.job_video import write_video
    from sim.viz.replay import RenderSettings

    out = tmp_path / "job.mp4"
    out.write_bytes(b"keep me")
    with pytest.raises(ConfigError, match=re.escape(f"overwrite must be True or False, got {flag!r}")):
        write_video(_job(BUILD_SEED), out, RenderSettings(width=160, height=120, fps=10), overwrite=flag)  # type: ignore[arg-type]
    assert out.read_bytes() == b"keep me" and sorted(p.name for p in tmp_path.iterdir()) == ["job.mp4"]
