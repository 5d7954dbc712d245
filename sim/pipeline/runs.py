"""Run kinds and the constants every stage of the pipeline shares.

A job tracks one trajectory in several runs; :class:`RunKind` names them. Its value labels the run
in records, logs, plots and progress reports (``"closed_loop"``, ``"open_loop"``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from enum import StrEnum
from typing import Any

from planning.errors import ConfigError
from sim.robot.sources import PoseSource

#: Feedback tracker of a case that names none: analytic references are smooth (dynamic feedback
#: linearisation), plans have cusps and turns in place (the segmented tracker).
REFERENCE_TRACKER = "fbl"
PLAN_TRACKER = "segmented"

#: Time simulated after a planned trajectory ends, for the final pose regulation [s].
PLAN_HOLD_S = 2.0

#: A job's progress: (stage, done, total). Stages: ``"plan"`` with seconds of the planning budget
#: (0 when planning starts, total when it returns), and each run kind with control periods of
#: physics (see :meth:`sim.physics.simulator.Simulator.run`).
Progress = Callable[[str, float, float], Any]


class RunKind(StrEnum):
    """How a run drives the robot along the trajectory.

    Each member is one line: its label, the tracker it always uses ("" for the case's feedback
    tracker, see :meth:`sim.pipeline.case.Case.tracker_for`), where that tracker's pose comes from
    (:class:`sim.robot.sensing.PoseSource`) and the caption of its progress bar. Adding a kind is
    adding a line.

    Attributes:
        tracker: Tracker the kind always uses, or "" for the case's feedback tracker.
        source: The pose the tracker is fed: the fused estimate (encoders, gyro and localisation
            fixes), dead reckoning (encoders and gyro), or the true pose.
        caption: Progress bar title.
    """

    tracker: str
    source: PoseSource
    caption: str

    def __new__(cls, label: str, tracker: str, source: PoseSource, caption: str) -> RunKind:
        member = str.__new__(cls, label)
        member._value_ = label
        member.tracker = tracker
        member.source = source
        member.caption = caption
        return member

    @property
    def localises(self) -> bool:
        """Whether the run is corrected by the localiser: only one fed the fused estimate takes its scans and fixes
        (dead reckoning and the true pose take none)."""
        return self.source is PoseSource.FUSED

    #                      label                   tracker      pose source          bar caption
    CLOSED_LOOP          = "closed_loop",          "",          PoseSource.FUSED,    "closed loop"  # fmt: skip
    CLOSED_LOOP_ODOMETRY = "closed_loop_odometry", "",          PoseSource.ODOMETRY, "odometry loop"  # fmt: skip
    OPEN_LOOP            = "open_loop",            "open-loop", PoseSource.TRUTH,    "open loop"  # fmt: skip
    CLOSED_LOOP_TRUTH    = "closed_loop_truth",    "",          PoseSource.TRUTH,    "truth loop"  # fmt: skip

    @classmethod
    def of_tracker(cls, tracker: str) -> RunKind:
        """The kind a tracker's single run belongs to: the kind that always uses it, else closed loop."""
        return next((kind for kind in cls if kind.tracker == tracker), cls.CLOSED_LOOP)


#: Every kind of run there is.
ALL_RUNS: tuple[RunKind, ...] = tuple(RunKind)

#: The runs of a job unless told otherwise: the real robot's loop (fused estimate), dead reckoning
#: and open loop; feedback on the true pose only on request.
DEFAULT_RUNS: tuple[RunKind, ...] = (RunKind.CLOSED_LOOP, RunKind.CLOSED_LOOP_ODOMETRY, RunKind.OPEN_LOOP)


def run_kinds(runs: Iterable[RunKind | str] | str) -> tuple[RunKind, ...]:
    """Run kinds given as members or their labels (``"closed_loop"``, or one label alone), in order.

    Raises:
        ConfigError: None given, an unknown or a repeated one (the message lists the valid labels).
    """
    given = [runs] if isinstance(runs, str) else list(runs)
    by_label = {str(k): k for k in RunKind}
    kinds: list[RunKind] = []
    for run in given:
        if not isinstance(run, str) or run not in by_label:
            raise ConfigError(f"unknown run {run!r}; choose from {', '.join(by_label)}")
        if by_label[run] in kinds:
            raise ConfigError(f"run {run} given twice")
        kinds.append(by_label[run])
    if not kinds:
        raise ConfigError(f"no run given; choose from {', '.join(by_label)}")
    return tuple(kinds)
