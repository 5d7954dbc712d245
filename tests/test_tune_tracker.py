"""``nhsim tune --tracker T``: any registered tracker's parameters tuned with the FBL's objective and
draws, on a tiny study; its record is what ``nhsim compare --params`` reads."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import re
import sys
from pathlib import Path
from typing import Any

import optuna
import pytest

from control.base import TRACKERS, ranged, search_space
from control.kanayama import KanayamaParams, KanayamaTracker
from control.mpc import MPCParams
from planning.errors import ConfigError
from sim.cli.main import main
from sim.pipeline.case import Case
from sim.tools.compare import load_params
from sim.tools.tune import (
    Evaluator,
    TuneSpec,
    default_params,
    load_study,
    make_draws,
    make_params,
    tuned_space,
)


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


def assert_searchable(tracker: str) -> None:
    """What ``nhsim tune --tracker`` needs of a tracker's search space: something to tune, every range
    log-uniform (0 < low < high: Optuna refuses a low end of 0, "low > 0 must hold for log=True"), every
    default inside its range (the defaults are the first trial: Optuna refused a default of 0, "'0.0' is
    invalid value for the case log=True"), and each corner, the other fields at their defaults, valid
    parameters (RPP's min_lookahead range once reached past the default max_lookahead, and its trials
    failed with a ConfigError)."""
    space = tuned_space(tracker)[1]  # a ConfigError here is the refusal nhsim tune would give
    assert space, f"{tracker}: nothing to tune"
    defaults = default_params(tracker)
    for name, (low, high) in space.items():
        assert 0 < low < high, f"{tracker}: {name} searched log-uniformly over ({low}, {high})"
        assert low <= defaults[name] <= high, f"{tracker}: default {name}={defaults[name]} outside ({low}, {high})"
    for corner in itertools.product(*space.values()):
        make_params(tracker, dict(zip(space, corner, strict=True)))


@pytest.mark.parametrize("tracker", sorted(TRACKERS))
def test_every_corner_of_a_search_space_is_a_valid_parameter_set(tracker: str) -> None:
    """Every tracker that declares something to tune (``TUNED``) can be tuned (:func:`assert_searchable`);
    one without ``TUNED`` (open-loop) is refused by name. Only that refusal is let pass: a ConfigError from a
    bad search range once passed as "nothing to tune"."""
    if getattr(TRACKERS.factory(tracker), "TUNED", None) is None:
        with pytest.raises(ConfigError, match="has no parameters to tune"):
            tuned_space(tracker)
        return
    assert_searchable(tracker)


# ---- search ranges Optuna cannot search, refused where they are declared and by nhsim tune ------------------
def _field(default: float, tune: tuple[float, float] | None, valid: tuple[float, float] = (0.0, 50.0)) -> Any:
    """A field as ranged() makes it, without its checks: how a range it now refuses reached the study."""
    return dataclasses.field(default=default, metadata={"range": valid, "unit": "rows", "tune": tune})


@dataclasses.dataclass(frozen=True)
class ZeroLow:
    rows: float = _field(3.0, (0.0, 10.0))


@dataclasses.dataclass(frozen=True)
class ZeroDefault:
    rows: float = _field(0.0, (0.5, 10.0))


@dataclasses.dataclass(frozen=True)
class Untuned:
    rows: float = ranged(3.0, 0.0, 50.0, "rows")


@dataclasses.dataclass(frozen=True)
class Plain:
    rows: float = 3.0


def _tracker_tuning(params: type) -> type:
    return type(f"Tunes{params.__name__}", (KanayamaTracker,), {"TUNED": ("params", params)})


@pytest.mark.parametrize(
    ("params", "fbl_kp", "optuna_said"),
    [
        (ZeroLow, (0.0, 100.0), "`low > 0` must hold for `log=True`"),
        (ZeroDefault, (10.0, 100.0), "`0.0` is invalid value for the case log=True"),
    ],
)
def test_the_registry_wide_check_catches_what_optuna_refuses(
    monkeypatch: pytest.MonkeyPatch, params: type, fbl_kp: tuple[float, float], optuna_said: str
) -> None:
    """Both search spaces a study's first trial crashed on (Optuna's own words) fail the registry-wide check:
    declared on a dataclass's field, and in a space no ranged() declares (the FBL's ``SEARCH_SPACE``, whose
    kp default is 9)."""
    low, high = params.__dataclass_fields__["rows"].metadata["tune"]
    with pytest.raises(ValueError, match=re.escape(optuna_said)):  # what the study's first trial met
        optuna.distributions.FloatDistribution(low, high, log=True).to_internal_repr(params().rows)
    monkeypatch.setitem(TRACKERS, "small", _tracker_tuning(params))
    with pytest.raises(ConfigError, match=rf"^tracker 'small': {params.__name__}\.rows: .*log-uniform"):
        assert_searchable("small")
    monkeypatch.setattr("sim.tools.tune.SEARCH_SPACE", {"kp": fbl_kp, "kd": (0.5, 40.0), "xi_min": (0.002, 0.2)})
    with pytest.raises(AssertionError, match="kp"):
        assert_searchable("fbl")


@pytest.mark.parametrize(
    ("default", "valid", "tune", "said"),
    [
        (3.0, (0.0, 50.0), (0.0, 10.0), r"cannot search tune=\(0, 10\); the search is log-uniform: give tune=\(a, b\) "
         r"with 0 < a < b, e.g. tune=\(0.1, 10\)"),
        (3.0, (0.0, 50.0), (10.0, 0.5), r"cannot search tune=\(10, 0.5\); the search is log-uniform"),
        (0.0, (0.0, 50.0), (0.5, 10.0), r"the default 0.0 lies outside every search range and nhsim tune runs the "
         r"defaults as its first trial; the search is log-uniform \(tune=\(a, b\) with 0 < a < b\), so give a default "
         r"> 0 inside tune=\(a, b\), or leave tune= out"),
        (20.0, (0.0, 50.0), (0.5, 10.0), r"the default 20.0 lies outside tune=\(0.5, 10\) .* e.g. tune=\(0.5, 20\)"),
        (3.0, (0.01, 50.0), (0.001, 10.0), r"tune=\(0.001, 10\) reaches outside the valid range \[0.01, 50\]; "
         r".* e.g. tune=\(0.01, 10\)"),
        (3.0, (0.0, 5.0), (0.5, 10.0), r"tune=\(0.5, 10\) reaches outside the valid range \[0, 5\]; "
         r".* e.g. tune=\(0.5, 5\)"),
        (3, (1, 50), (1, 10), r"an integer parameter cannot be tuned"),
        (3.0, (0.0, 50.0), (1.0,), r"tune must be two finite numbers \(a, b\), got \(1.0,\)"),
        (3.0, (0.0, 50.0), (0.5, math.inf), r"tune must be two finite numbers"),
    ],
)  # fmt: skip
def test_ranged_refuses_a_search_range_where_it_is_declared(
    default: float, valid: tuple[float, float], tune: tuple[float, float], said: str
) -> None:
    call = re.escape(f"ranged({default!r}, {valid[0]!r}, {valid[1]!r}, 'rows', tune={tune!r}): ")
    with pytest.raises(ConfigError, match=f"^{call}{said}"):
        ranged(default, *valid, "rows", tune=tune)
    field = _field(default, tune, valid)  # the same range reached a dataclass by another way: named by its field
    cls = dataclasses.make_dataclass("Declared", [("rows", float, field)], frozen=True)
    with pytest.raises(ConfigError, match=f"^Declared\\.rows: {said}"):
        search_space(cls)


def test_ranged_takes_a_search_range_that_holds_its_default() -> None:
    field = ranged(3.0, 0.0, 50.0, "rows", tune=(0.5, 10))
    assert field.metadata["tune"] == (0.5, 10.0) and isinstance(field.metadata["tune"][1], float)
    assert ranged(0.5, 0.0, 50.0, "rows", tune=(0.5, 10.0)).metadata["tune"] == (0.5, 10.0)  # ends included
    assert ranged(0.0, 0.0, 50.0, "rows").metadata["tune"] is None  # untuned: a default of 0 is fine


_DECLARED = """
import dataclasses
from control.base import ranged
from control.kanayama import KanayamaTracker

@dataclasses.dataclass(frozen=True)
class Params:
    rows: float = ranged({default}, 0.0, 50.0, "rows", tune={tune})

class Tracker(KanayamaTracker):
    TUNED = ("params", Params)
"""


@pytest.mark.parametrize(
    ("params", "said"),
    [
        (ZeroLow, "tracker 'small': ZeroLow.rows: cannot search tune=(0, 10); the search is log-uniform: give "
         "tune=(a, b) with 0 < a < b, e.g. tune=(0.1, 10)"),
        (ZeroDefault, "tracker 'small': ZeroDefault.rows: the default 0.0 lies outside every search range"),
        (Untuned, "tracker 'small' has nothing to tune: no field of its Untuned declares a search range; declare one "
         "on each field to tune, ranged(default, low, high, unit, tune=(a, b)) with 0 < a < b"),
        (Plain, "tracker 'small' has nothing to tune: no field of its Plain declares a search range"),
        ("3.0, (0.0, 10.0)", "cannot load its factory 'declared_0:Tracker': ConfigError: "
         "ranged(3.0, 0.0, 50.0, 'rows', tune=(0.0, 10.0)): cannot search tune=(0, 10); the search is log-uniform"),
        ("0.0, (0.5, 10)", "cannot load its factory 'declared_1:Tracker': ConfigError: "
         "ranged(0.0, 0.0, 50.0, 'rows', tune=(0.5, 10)): the default 0.0 lies outside every search range"),
    ],
)  # fmt: skip
def test_tune_refuses_a_tracker_it_cannot_search_before_any_study(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, params: Any, said: str
) -> None:
    """Refused at once, in one line, with nothing written: a study was made and left behind (its first trial
    crashed in Optuna), or trials ran a tracker with nothing to tune and "the defaults were best" (exit 0)."""
    out = tmp_path / "out"
    out.mkdir()
    if isinstance(params, str):  # a plugin module declaring it with ranged(), as the how-to's tracker does
        module = f"declared_{int('0.5' in params)}"
        default, tune = params.split(", ", 1)
        (tmp_path / f"{module}.py").write_text(_DECLARED.format(default=default, tune=tune))
        monkeypatch.syspath_prepend(str(tmp_path))
        monkeypatch.delitem(sys.modules, module, raising=False)
        monkeypatch.setitem(TRACKERS, "small", f"{module}:Tracker")
    else:
        monkeypatch.setitem(TRACKERS, "small", _tracker_tuning(params))
    assert main(_args(out, "small", 2)) == 2
    err = capsys.readouterr().err
    assert said in err and err.count("\n") == 1 and err.startswith("nhsim tune: error: ")
    assert list(out.iterdir()) == []  # no study database


def _spec(tmp_path: Path) -> TuneSpec:
    case = Case("open", robot="turtlebot3", reference="line", tracker="kanayama")
    return TuneSpec((case,), make_draws(1, 0), f"sqlite:///{tmp_path}/s.db", "t", 2, tracker="kanayama")


def _left_study(spec: TuneSpec, search: dict[str, list[float]], state: optuna.trial.TrialState) -> None:
    """The study as a crashed run left it: its settings, with ``search`` as its search space, and its first
    trial (the defaults) in ``state``."""
    study = optuna.create_study(storage=spec.storage, study_name=spec.study, direction="minimize")
    study.enqueue_trial(default_params(spec.tracker))
    if state != optuna.trial.TrialState.WAITING:
        trial = study.ask()
        study.tell(trial, 1.0 if state == optuna.trial.TrialState.COMPLETE else None, state=state)
    study.set_user_attr("settings", json.loads(json.dumps(spec.settings() | {"search_space": search})))


def test_a_study_whose_every_trial_failed_is_made_anew_with_the_fixed_range(tmp_path: Path) -> None:
    """An earlier nhsim made the study, then its first trial crashed on the search range; rerun with the range
    fixed, it was refused ("created with other settings"): the study was never usable. It holds nothing to
    resume, so it is made anew."""
    spec = _spec(tmp_path)
    _left_study(spec, {"kx": [0.0, 40.0]}, optuna.trial.TrialState.FAIL)
    study = load_study(spec, create=True)
    assert study.user_attrs["settings"] == json.loads(json.dumps(spec.settings()))
    (trial,) = study.get_trials()
    assert trial.state == optuna.trial.TrialState.WAITING and trial.system_attrs["fixed_params"] == default_params(
        "kanayama"
    )


@pytest.mark.parametrize("state", [optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.WAITING])
def test_a_study_with_other_settings_and_a_trial_to_keep_is_still_refused(
    tmp_path: Path, state: optuna.trial.TrialState
) -> None:
    """A completed trial is worth resuming; a waiting one is another worker's new study: neither is replaced."""
    spec = _spec(tmp_path)
    _left_study(spec, {"kx": [0.5, 40.0]}, state)
    with pytest.raises(ConfigError, match="was created with other settings: search_space"):
        load_study(spec, create=True)
    assert len(optuna.load_study(study_name="t", storage=spec.storage).trials) == 1
