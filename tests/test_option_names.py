"""A message that names a command-line option names the Python keyword beside it (:func:`planning.errors.option`):
a caller of the Python API is not left to guess which keyword ``--localiser fixes`` is."""

from __future__ import annotations

from pathlib import Path

import pytest

from planning.errors import ConfigError, OutputExistsError, option, options, without_python


def test_an_option_is_named_as_the_command_line_and_as_python_give_it() -> None:
    assert option("localiser", "fixes") == '--localiser fixes (localiser="fixes" from Python)'
    assert option("overwrite", True) == "--overwrite (overwrite=True from Python)"
    assert option("topic") == "--topic (topic=... from Python)"
    assert option("time-scale", 1e-9) == "--time-scale 1e-09 (time_scale=1e-09 from Python)"
    assert option("path", python="timed=False") == "--path (timed=False from Python)"
    assert option("gains", "9", python="resolve_gains({})") == '--gains 9 (resolve_gains("9") from Python)'
    assert option("perturb", "mass=1, x") == "--perturb 'mass=1, x' (perturb=\"mass=1, x\" from Python)"  # as typed
    both = options("lidar", ("initial-pose", "unknown"), conjunction="or")
    assert both == '--lidar or --initial-pose unknown (lidar=..., initial_pose="unknown" from Python)'
    said = f"e.g. {option('perturb', 'mass=1', python='perturbation=Perturbation.parse({})')}; or {both}"
    assert without_python(said) == "e.g. --perturb mass=1; or --lidar or --initial-pose unknown"


def test_planning_names_the_keyword_of_a_scenario_and_a_file(tmp_path: Path) -> None:
    from planning.scenario import load_scenario, scenario_with_robot
    from planning.trajectory.importer import TrajectoryFile, read_trajectory_file

    with pytest.raises(ConfigError, match=r"choose one of them with --robot \(robot=\.\.\. from Python\)"):
        scenario_with_robot(load_scenario("three_point_turn"), "edumip")
    p = tmp_path / "xy.csv"
    p.write_text("x,y\n0,0\n1,1\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"a path: use --path \(timed=False from Python\)"):
        read_trajectory_file(TrajectoryFile(p))


def test_control_names_the_call_and_the_case_field() -> None:
    from control.estimation.amcl import AmclConfig
    from control.gains import resolve_gains

    with pytest.raises(ConfigError, match=r'^--gains 9 \(resolve_gains\("9"\) from Python\): neither'):
        resolve_gains("9")
    with pytest.raises(ConfigError, match=r'^--amcl refine \(amcl="refine" from Python\): expected key=value'):
        AmclConfig().parse("refine")


def test_sim_names_the_case_fields_and_the_function_keywords(tmp_path: Path) -> None:
    from planning.scenario import load_scenario
    from sim.outputs import check_writable
    from sim.physics.perturb import Perturbation
    from sim.pipeline.case import Case
    from sim.tools.compare import check_trackers
    from sim.tools.montecarlo import MonteCarloSpec

    edumip = load_scenario("open").with_robot("edumip")
    with pytest.raises(ConfigError) as err:
        Case(
            "open", reference="line", localiser="amcl", amcl="max_particles=100", initial_pose="unknown"
        ).localiser_setup(edumip)
    assert 'localiser="amcl", amcl=..., initial_pose="unknown" from Python) need one' in str(err.value)
    with pytest.raises(ConfigError) as err:  # only what was given is named
        Case("open", reference="line", localiser="amcl").localiser_setup(edumip)
    assert '--localiser amcl (localiser="amcl" from Python) needs one' in str(err.value)
    assert str(err.value).endswith("drop it: the edumip localises from fixes")  # not another refused option
    with pytest.raises(ConfigError, match=r'^--perturb mas=1 \(perturbation=Perturbation\.parse\("mas=1"\) from'):
        Perturbation.parse("mas=1")
    with pytest.raises(ConfigError, match=r"^--trackers \(trackers=\.\.\. from Python\) needs at least one"):
        check_trackers([])
    with pytest.raises(ConfigError, match=r"^--runs \(runs=\.\.\. from Python\) must be an integer >= 1"):
        MonteCarloSpec(Case("open", reference="line"), 0)
    (tmp_path / "a.json").write_text("{}", encoding="utf-8")
    with pytest.raises(OutputExistsError, match=r"pass --overwrite \(overwrite=True from Python\) to replace it"):
        check_writable(tmp_path / "a.json", overwrite=False)
