"""``nhsim bench cold``'s worlds and table (the fresh processes themselves are timed by the benchmark)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from planning.scenario import load_scenario
from sim.tools.bench.cold import ColdRow, format_rows, world_toml


def _row(**kw: object) -> ColdRow:
    base = dict(world="cold0", obstacles=8, size_m=6.0, status="success", time_limit_s=10.0, process_wall_s=1.2,
                process_cpu_s=1.4, reported_s=0.15, reported_cpu_s=0.15, grid_s=0.02, code_s=0.09, new_world_s=0.06,
                warm_s=0.05, simplify_s=0.03)  # fmt: skip
    return ColdRow(**{**base, **kw})  # type: ignore[arg-type]


def test_the_worlds_are_seeded_valid_and_hold_every_kind(tmp_path: Path) -> None:
    text = world_toml(2000, 8.0, 20, 0.6)
    assert text == world_toml(2000, 8.0, 20, 0.6) and text != world_toml(2001, 8.0, 20, 0.6)
    (tmp_path / "w.toml").write_text(text)
    scenario = load_scenario(tmp_path / "w.toml")
    kinds = [o.kind for o in scenario.world.obstacles]
    assert len(kinds) == 20 and set(kinds) == {"circle", "ellipse", "box", "polygon"}
    assert scenario.world.bounds == (-4.0, 4.0, -4.0, 4.0)
    (tmp_path / "w.toml").write_text(world_toml(2000, 8.0, 20, 0.6, ("circle", "box", "polygon")))
    kinds = [o.kind for o in load_scenario(tmp_path / "w.toml").world.obstacles]
    assert len(kinds) == 20 and set(kinds) == {"circle", "box", "polygon"}


def test_the_table_shows_the_simplification_beside_the_reported_time_and_judges_the_targets() -> None:
    quick, slow = _row(), _row(world="cold2000", reported_s=0.25, process_wall_s=1.6, simplify_s=math.nan)
    header, *lines = format_rows([quick, slow])
    assert header.split()[:4] == ["world", "obst", "size", "status"] and "simplify" in header.split()
    cells = lines[0].split()  # world, obst, size, status, then the times: ..., grid, simplify, new warm, warm
    assert cells[10:14] == ["0.020", "0.030", "0.060", "0.050"]
    assert "reported <= 0.2 s met; process <= 1.5 s met" in lines[0]
    assert "nan" in lines[1] and "reported <= 0.2 s MISSED; process <= 1.5 s MISSED" in lines[1]
    crowded = _row(obstacles=2000, size_m=20.0, status="timeout", time_limit_s=2.0, reported_s=2.2, code_s=0.15)
    assert (
        crowded.working_s == 2.2 - 0.15
        and "within the 2 s limit (+5%: the last step's check) met" in format_rows([crowded])[1]
    )


def test_a_world_without_a_plan_misses_whatever_its_times() -> None:
    """An infeasible plan (a world of obstacles scaled up four times) was judged on its time alone and "met"
    both targets; a world of at most 20 obstacles is there to be planned, so no plan is a miss."""
    from sim.tools.bench.cold import passed

    for status in ("infeasible", "bounds_violated", "timeout"):
        row = _row(status=status)
        assert row.targets[0] == f"a plan ({status}) MISSED" and not passed([row])
    assert passed([_row()]) and not any("a plan" in t for t in _row().targets)
    assert not any("a plan" in t for t in _row(obstacles=2000, size_m=20.0, status="timeout").targets)


def test_a_fresh_process_keeps_the_users_path_and_a_failure_says_why(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The cold process ran with PYTHONPATH replaced by the repository's, so a plugin set up as the how-tos teach
    could not load; its error output was thrown away and the bench died reading a record never written
    (FileNotFoundError)."""
    from planning.errors import NhsimError
    from sim.tools.bench.cold import _fresh_process

    (tmp_path / "straight_plugin.py").write_text(
        "import numpy as np\n"
        "from planning import PlanResult, PlanStatus, register_planner\n\n\n"
        "class Straight:\n"
        "    name = 'straight'\n\n"
        "    def plan(self, problem):\n"
        "        s, g = problem.start, problem.goal\n"
        "        path = np.array([[s.x, s.y, s.theta], [g.x, g.y, g.theta]])\n"
        "        return PlanResult(PlanStatus.SUCCESS, self.name, path=path, stats={})\n\n\n"
        "register_planner('straight', Straight)\n"
    )
    (tmp_path / "w.toml").write_text(world_toml(2000, 8.0, 0, 0.6))
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))
    monkeypatch.setenv("NHSIM_PLUGINS", "straight_plugin")
    wall, cpu, record = _fresh_process(tmp_path / "w.toml", "straight", 1.0, tmp_path / "plan.json")
    assert record["planner"] == "straight" and record["status"] == "success" and wall > 0 and cpu > 0
    monkeypatch.setenv("NHSIM_PLUGINS", "no_such_plugin")
    with pytest.raises(NhsimError, match=r"(?s)failed \(exit 2\) and wrote no record.*no_such_plugin"):
        _fresh_process(tmp_path / "w.toml", "straight", 1.0, tmp_path / "other.json")
