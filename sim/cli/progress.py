"""Progress bars of the CLI (tqdm, on stderr): shown on a terminal, never with ``--quiet``.

The library only reports progress through callbacks (:data:`sim.pipeline.runs.Progress`,
``Simulator.run(progress=...)``, ``render_frames(progress=...)``); this module turns those reports
into bars. A bar appears only once its stage has run for :data:`DELAY_S` seconds, so short stages
leave the terminal as it was, and every bar is removed when its stage ends.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from sim.pipeline.runs import RunKind

#: Seconds a stage runs before its bar appears.
DELAY_S = 1.0

#: Stage label -> bar title.
TITLES = {"plan": "planning", **{str(kind): f"physics, {kind.caption}" for kind in RunKind}}


def _tqdm(**kwargs: Any) -> Any:
    from tqdm import tqdm

    return tqdm(leave=False, dynamic_ncols=True, delay=DELAY_S, **kwargs)


class TimedBar:
    """A bar over a time budget, advanced by a timer thread while an uninterruptible call runs.

    Use as a context manager around the call (e.g. a planner's ``plan``); the bar fills with the
    elapsed time, caps at the budget, and is removed when the block ends.

    Args:
        desc: Title.
        budget: The time budget [s] (> 0).
        enabled: False makes this a no-op (no thread, no output).
        interval: Seconds between updates.
    """

    def __init__(self, desc: str, budget: float, *, enabled: bool = True, interval: float = 0.1) -> None:
        self.desc, self.budget, self.enabled, self.interval = desc, float(budget), enabled, interval
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._bar: Any = None

    def start(self) -> TimedBar:
        """Show the bar (after :data:`DELAY_S`) and start the timer thread."""
        if not self.enabled or self._thread is not None:
            return self
        bar_format = "{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} s budget"
        self._bar = _tqdm(total=round(self.budget, 1), desc=self.desc, unit="s", bar_format=bar_format)
        t0 = time.perf_counter()

        def tick() -> None:
            while not self._stop.wait(self.interval):
                elapsed = round(min(time.perf_counter() - t0, self.budget), 1)
                self._bar.update(elapsed - self._bar.n)

        self._thread = threading.Thread(target=tick, name="progress-timer", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the thread and remove the bar (idempotent)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> TimedBar:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


class JobBars:
    """A :data:`sim.pipeline.runs.Progress` callback that draws one bar per stage of a job.

    ``"plan"`` gets a :class:`TimedBar` over the planning budget (started by the report of 0 s,
    stopped by the report of the whole budget); each run label gets a bar over its control
    periods. Use as a context manager so bars left open by an error are removed.

    Args:
        enabled: False makes every report a no-op.
    """

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self._bars: dict[str, Any] = {}

    def __call__(self, stage: str, done: float, total: float) -> None:
        """Take one report (see :data:`sim.pipeline.runs.Progress`)."""
        if not self.enabled:
            return
        title = TITLES.get(stage, stage)
        bar = self._bars.get(stage)
        if stage == "plan":
            if bar is None and done < total:
                self._bars[stage] = TimedBar(title, total).start()
            elif bar is not None and done >= total:
                self._bars.pop(stage).stop()
            return
        if bar is None:
            if done >= total:
                return
            bar = self._bars[stage] = _tqdm(total=int(total), desc=title, unit="period")
        bar.update(int(done) - bar.n)
        if done >= total:
            self._bars.pop(stage).close()

    def close(self) -> None:
        """Remove every bar still open."""
        for bar in self._bars.values():
            (bar.stop if isinstance(bar, TimedBar) else bar.close)()
        self._bars.clear()

    def __enter__(self) -> JobBars:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
