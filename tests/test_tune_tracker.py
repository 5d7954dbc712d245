"""``nhsim tune --tracker T``: any registered tracker's parameters tuned with the FBL's objective and
draws, on a tiny study; its record is what ``nhsim compare --params`` reads."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import optuna
import pytest

from control.base import TRACKERS, search_space
from control.kanayama import KanayamaParams
from control.mpc import MPCParams
from planning.errors import ConfigError
from sim.cli.main import main
from sim.pipeline.case import Case
from sim.tools.compare import load_params
from sim.tools.tune import Evaluator, default_params, make_draws, make_params, tuned_space


def _args(tmp_path: Path, tracker: str, trials: int) -> list[str]:
    return [
        "tune", "--tracker", tracker, "--scenarios", "open:line", "--robot", "turtlebot3", "--trials", str(trials),
        "--storage", f"sqlite:///{tmp_path}/study.db", "--study", "t", "--json", str(tmp_path / "t.json"),
        "--plots", str(tmp_path), "--draws", "1", "--eval-runs", "1", "--quiet",
    ]  # fmt: skip


def test_tune_a_peer_tracker_on_a_tiny_study(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(_args(tmp_path, "kanayama", 3))
    assert code in (0, 1)  # 1: the tuned parameters lost to the defaults on the held-out draw
    out = capsys.readouterr().out
    assert "best trial #" in out and "kx=" in out and "ktheta=" in out
    record = json.loads((tmp_path / "t.json").read_text())
    assert record["tracker"] == "kanayama" and set(record["params"]) == {"kx", "ky", "ktheta"}
    assert record["settings"]["tracker"] == "kanayama"
    assert record["settings"]["search_space"] == {k: list(v) for k, v in search_space(KanayamaParams).items()}
    assert not (tmp_path / "t.toml").exists()  # a gains file is for the FBL's gains only
    study = optuna.load_study(study_name="t", storage=f"sqlite:///{tmp_path}/study.db")
    trials = study.get_trials(states=(optuna.trial.TrialState.COMPLETE,))
    assert len(trials) == 3 and trials[0].params == default_params("kanayama")  # the defaults first
    assert load_params([tmp_path / "t.json"])["kanayama"] == KanayamaParams(**record["params"])


@pytest.mark.parametrize(
    ("tracker", "message"),
    [("open-loop", "'open-loop' has no parameters to tune"), ("pid", "unknown tracker 'pid': choose from fbl")],
)
def test_tune_refuses_a_tracker_without_parameters(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tracker: str, message: str
) -> None:
    assert main(_args(tmp_path, tracker, 1)) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_the_same_objective_and_draws_score_any_tracker() -> None:
    cases = [Case("open", robot="turtlebot3", reference="line", tracker="mpc")]
    draws = make_draws(1, 0)
    evaluator = Evaluator(cases, draws, tracker="mpc")
    cls, space = tuned_space("mpc")
    assert cls is MPCParams and "q_position" in space
    default = evaluator.evaluate(MPCParams())
    other = evaluator.evaluate(MPCParams(q_position=1.0, q_heading=0.01))
    assert default.failures == 0 and other.rms_m != default.rms_m  # the parameters reach the tracker
    assert evaluator.evaluate(MPCParams()) == default  # common random numbers: the same draw, the same run
    assert default.objective == pytest.approx(default.rms_m + default.final_m + 0.05 * default.saturation)


@pytest.mark.parametrize("tracker", sorted(TRACKERS))
def test_every_corner_of_a_search_space_is_a_valid_parameter_set(tracker: str) -> None:
    """A trial may sample any point of the ranges: each corner, the other fields at their defaults,
    makes valid parameters (RPP's min_lookahead range once reached past the default max_lookahead,
    and its trials failed with a ConfigError)."""
    try:
        cls, space = tuned_space(tracker)
    except ConfigError:  # nothing to tune (open-loop)
        return
    for corner in itertools.product(*space.values()):
        make_params(tracker, dict(zip(space, corner, strict=True)))
    assert cls is not None and space
