"""What writing the bag adds to a run without video (``nhsim bench bag``).

The same ``nhsim simulate ... --no-video`` command runs ``repeats`` times without ``--bag`` and
``repeats`` times with it, interleaved (without, with; then with, without; ...) so that load from
other processes hits both alike, each in a fresh process as a user runs it (imports, planning,
physics, plots and record included), after one untimed command with the bag (the kernels both use compiled and
cached there, not in the first timed one). Each command's wall time and CPU time (user + system, of the
child process) are measured; the cost is the ratio of the medians with and without the bag. The CPU
ratio is the judged one: on a machine shared with other work a command waits for the processor a
varying part of its wall time, which the CPU time does not count. The bag's own write time (wall and
CPU, from the record) is reported beside it. Targets: CPU ratio at most :data:`TARGET_RATIO`, bag at
most :data:`TARGET_MB` MB.
"""

from __future__ import annotations

import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from planning.errors import NhsimError

TARGET_RATIO = 1.2
TARGET_MB = 5.0


@dataclass(frozen=True)
class BagBench:
    """One measurement.

    Attributes:
        without_s: Wall time of each command without the bag [s].
        with_s: Wall time of each command with it [s].
        without_cpu_s: CPU time of each command without the bag [s].
        with_cpu_s: CPU time of each command with it [s].
        write_s: The bag's write time of each command with it, as its record states [s].
        write_cpu_s: The bag's write CPU time of each command with it [s].
        size_bytes: Bytes of the bag.
        messages: Messages in the bag.
        duration_s: Simulated time of the bag [s].
    """

    without_s: tuple[float, ...]
    with_s: tuple[float, ...]
    without_cpu_s: tuple[float, ...]
    with_cpu_s: tuple[float, ...]
    write_s: tuple[float, ...]
    write_cpu_s: tuple[float, ...]
    size_bytes: int
    messages: int
    duration_s: float

    @property
    def ratio(self) -> float:
        """Median wall time with the bag over median wall time without it."""
        return statistics.median(self.with_s) / statistics.median(self.without_s)

    @property
    def cpu_ratio(self) -> float:
        """Median CPU time with the bag over median CPU time without it (the judged ratio)."""
        return statistics.median(self.with_cpu_s) / statistics.median(self.without_cpu_s)

    @property
    def cpu_ratio_min(self) -> float:
        """Least CPU time with the bag over least CPU time without it: a busy machine only adds CPU time
        (shared caches, frequency), so the least of each is the closest to the command's own."""
        return min(self.with_cpu_s) / min(self.without_cpu_s)

    @property
    def write_share(self) -> float:
        """The bag's own write CPU time (measured inside the command) over the median CPU time without the
        bag: the part of the ratio that the bag's writing accounts for, free of the run-to-run spread."""
        return statistics.median(self.write_cpu_s) / statistics.median(self.without_cpu_s)

    @property
    def passed(self) -> bool:
        """Both targets met."""
        return self.cpu_ratio <= TARGET_RATIO and self.size_bytes <= TARGET_MB * 1e6


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _command(argv: list[str], folder: Path, bag: bool) -> tuple[float, float, dict[str, Any]]:
    """Run ``nhsim simulate ARGV --no-video`` (with ``--bag`` when asked) with its outputs in ``folder``, which must
    be new (so no record of an earlier command can be read for this one's): (wall [s], CPU [s], its record).

    Raises:
        NhsimError: The command failed (any exit status but 0: bad input, a failed run, a crash), naming the
            command, its exit status and the end of its own error output; or it wrote no record.
    """
    folder.mkdir()
    record = folder / "run.json"
    cmd = [sys.executable, "-m", "sim", "simulate", *argv, "--no-video", "--quiet", "--json", str(record)]
    if bag:
        cmd += ["--bag", str(folder / "bag")]
    cpu, t0 = _children_cpu(), time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall, cpu = time.perf_counter() - t0, _children_cpu() - cpu
    said = done.stderr.strip()[-1500:] or "no error output"
    if done.returncode != 0:
        raise NhsimError(
            f"the timed command failed (exit {done.returncode}), so nothing was measured: nhsim {' '.join(cmd[3:])}\n"
            f"{said}\nrun that command alone to see why, and fix it (or give bench bag another job)"
        )
    if not record.is_file() or (bag and not (folder / "bag").is_dir()):
        raise NhsimError(f"nhsim {' '.join(cmd[3:])} exited 0 but wrote no record or no bag in {folder}: {said}")
    return wall, cpu, json.loads(record.read_text(encoding="utf-8"))


def measure(argv: list[str], repeats: int) -> BagBench:
    """Run ``nhsim simulate ARGV`` ``repeats`` times without and with ``--bag``, interleaved."""
    runs: dict[bool, list[tuple[float, float]]] = {False: [], True: []}
    writes: list[tuple[float, float]] = []
    last: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="nhsim-bench-bag-") as tmp:
        # untimed, with the bag (its kernels a superset): a cold numba cache is compiled here, not charged to the
        # first timed command (always one without the bag: with a fresh cache the ratio read 0.20-0.34, "met")
        _command(argv, Path(tmp) / "warm-up", True)
        for r in range(repeats):
            for bag in (False, True) if r % 2 == 0 else (True, False):
                wall, cpu, record = _command(argv, Path(tmp) / f"{r}-{'bag' if bag else 'plain'}", bag)
                runs[bag].append((wall, cpu))
                if bag:
                    last = record["bag"]
                    writes.append((float(last["write_s"]), float(last["write_cpu_s"])))
    messages = sum(int(t["messages"]) for t in last["topics"].values())
    return BagBench(
        tuple(w for w, _ in runs[False]),
        tuple(w for w, _ in runs[True]),
        tuple(c for _, c in runs[False]),
        tuple(c for _, c in runs[True]),
        tuple(w for w, _ in writes),
        tuple(c for _, c in writes),
        int(last["size_bytes"]),
        messages,
        float(last["duration_s"]),
    )
