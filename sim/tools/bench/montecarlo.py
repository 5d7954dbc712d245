"""Monte Carlo throughput: the same runs serially in this process and on Dask workers (``nhsim bench montecarlo``).

Three timings of the same ``N`` runs of one study (:func:`sim.tools.montecarlo.run_one`, every run
kind of each run), in one command:

- ``direct``: a plain loop in this process (the baseline);
- ``one worker``: the distributed path with a single worker process (scatter, submit, results back):
  its time over the direct loop's, less one, is the distributed path's per-run overhead
  (target <= 10 %);
- ``J workers``: the throughput ratio, the direct loop's time over this one (target >= 1.7 for two
  workers on two cores).

Starting the local cluster (and importing nhsim on its workers) is timed apart (it is paid once per
command, not per run). The results of the three are compared too: the same records, bit for bit.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

#: Targets: throughput ratio on the workers, per-run overhead of the distributed path.
TARGET_SPEEDUP = 1.7
TARGET_OVERHEAD = 0.10


@dataclass(frozen=True)
class MonteCarloBench:
    """One measurement (times in seconds)."""

    runs: int
    workers: int
    direct_s: float
    one_worker_s: float
    workers_s: float
    startup_s: float
    same_records: bool

    @property
    def overhead(self) -> float:
        """Per-run overhead of the distributed path (one worker) over the direct loop."""
        return self.one_worker_s / self.direct_s - 1.0

    @property
    def speedup(self) -> float:
        """Throughput on the workers over the direct loop's."""
        return self.direct_s / self.workers_s

    @property
    def passed(self) -> bool:
        """Both targets met and the records equal."""
        return self.speedup >= TARGET_SPEEDUP and self.overhead <= TARGET_OVERHEAD and self.same_records


def measure(spec: Any, workers: int = 2) -> MonteCarloBench:
    """Time the study's runs directly, on one worker and on ``workers`` workers."""
    from sim.pipeline.case import prepare_trajectory
    from sim.tools.executor import DaskExecutor
    from sim.tools.montecarlo import WORKER_MODULES, run_one

    prepared = prepare_trajectory(spec.case)
    shared = (spec, None if spec.replan else prepared)
    items = list(enumerate(spec.draws()))
    t0 = time.perf_counter()
    direct = {i: run_one(shared, item) for i, item in enumerate(items)}
    direct_s = time.perf_counter() - t0
    times, same = [], True
    startup = 0.0
    for n in (1, workers):
        t0 = time.perf_counter()
        with DaskExecutor(jobs=n) as ex:
            ex.preload(*WORKER_MODULES)  # part of the start-up, as in nhsim montecarlo
            startup = max(startup, time.perf_counter() - t0)
            t1 = time.perf_counter()
            got = {item[0]: rec for item, rec in ex.map_unordered(run_one, items, shared=shared)}
            times.append(time.perf_counter() - t1)
        same = same and got == direct
    return MonteCarloBench(spec.runs, workers, direct_s, times[0], times[1], startup, same)
