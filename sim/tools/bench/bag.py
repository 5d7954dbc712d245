"""What writing the bag adds to a run without video (``nhsim bench bag``).

The same ``nhsim simulate ... --no-video`` command runs ``repeats`` times without ``--bag`` and
``repeats`` times with it, interleaved (without, with; then with, without; ...) so that load from
other processes hits both alike, each in a fresh process as a user runs it (imports, planning,
physics, plots and record included). The ratio of the median wall times is the cost; the bag's
own write time (from the record) is reported beside it. Targets: ratio at most :data:`TARGET_RATIO`,
bag at most :data:`TARGET_MB` MB.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from planning.errors import NhsimError

TARGET_RATIO = 1.2
TARGET_MB = 5.0


@dataclass(frozen=True)
class BagBench:
    """One measurement.

    Attributes:
        without_s: Wall time of each command without the bag [s].
        with_s: Wall time of each command with it [s].
        write_s: The bag's write time of each command with it, as its record states [s].
        size_bytes: Bytes of the bag.
        messages: Messages in the bag.
        duration_s: Simulated time of the bag [s].
    """

    without_s: tuple[float, ...]
    with_s: tuple[float, ...]
    write_s: tuple[float, ...]
    size_bytes: int
    messages: int
    duration_s: float

    @property
    def ratio(self) -> float:
        """Median command with the bag over median command without it."""
        return statistics.median(self.with_s) / statistics.median(self.without_s)

    @property
    def share(self) -> float:
        """1 + the bag's median write time over the median command without it."""
        return 1.0 + statistics.median(self.write_s) / statistics.median(self.without_s)

    @property
    def passed(self) -> bool:
        """Both targets met."""
        return self.ratio <= TARGET_RATIO and self.size_bytes <= TARGET_MB * 1e6


def _command(argv: list[str], folder: Path, bag: bool) -> tuple[float, dict]:
    """Run ``nhsim simulate ARGV --no-video`` (with ``--bag`` when asked): (wall time [s], its record)."""
    record = folder / "run.json"
    cmd = [
        sys.executable,
        "-m",
        "sim",
        "simulate",
        *argv,
        "--no-video",
        "--quiet",
        "--overwrite",
        "--json",
        str(record),
    ]
    if bag:
        cmd += ["--bag", str(folder / "bag")]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if done.returncode == 2 or not record.is_file():
        raise NhsimError(f"{' '.join(cmd[3:])} failed (exit {done.returncode}): {done.stderr.strip()[-500:]}")
    return wall, json.loads(record.read_text(encoding="utf-8"))


def measure(argv: list[str], repeats: int) -> BagBench:
    """Run ``nhsim simulate ARGV`` ``repeats`` times without and with ``--bag``, interleaved."""
    without: list[float] = []
    with_: list[float] = []
    write: list[float] = []
    last: dict = {}
    with tempfile.TemporaryDirectory(prefix="nhsim-bench-bag-") as tmp:
        for r in range(repeats):
            for bag in (False, True) if r % 2 == 0 else (True, False):
                wall, record = _command(argv, Path(tmp), bag)
                if bag:
                    with_.append(wall)
                    write.append(float(record["bag"]["write_s"]))
                    last = record["bag"]
                else:
                    without.append(wall)
    messages = sum(int(t["messages"]) for t in last["topics"].values())
    return BagBench(tuple(without), tuple(with_), tuple(write), int(last["size_bytes"]), messages, last["duration_s"])
