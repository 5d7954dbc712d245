"""The bag's many-message topics are serialised at once (:func:`sim.io.rosmsgs.serialize_rows`): each
row equals ``rosbags``' own serialisation of the message filled field by field (the reference here)."""

from __future__ import annotations

import copy
import math
import pickle
from typing import Any

import numpy as np
import pytest

from planning.errors import NhsimError
from sim.io import bag_topics as bt
from sim.io import rosmsgs as m


def reference_rows(template: Any, columns: dict[str, np.ndarray], ks: list[int]) -> list[bytes]:
    """Message k of each of ``ks`` built by setting each field on a copy of the template, serialised by rosbags."""
    out = []
    for k in ks:
        msg = copy.deepcopy(template)
        for path, values in columns.items():
            *head, last = path.split(".")
            obj = msg
            for key in head:
                obj = obj[int(key)] if key.isdigit() else getattr(obj, key)
            old = obj[int(last)] if last.isdigit() else getattr(obj, last)
            if hasattr(old, "nanosec"):
                value: Any = m.stamp(float(values[k]))
            else:
                value = float(values[k])
            if last.isdigit():
                obj[int(last)] = value
            else:
                setattr(obj, last, value)
        out.append(m.serialize(msg))
    return out


@pytest.fixture(scope="module")
def topics() -> list[bt.Topic]:
    from sim.io.bag import job_topics
    from sim.pipeline.runs import RunKind
    from sim.pipeline.simulate import simulate_reference

    runs = (RunKind.CLOSED_LOOP, RunKind.OPEN_LOOP)  # frame names of two lengths on /tf
    job = simulate_reference("open", reference="circle", robot="turtlebot3", runs=runs)
    return job_topics(job.prepared, job.logs)


def test_every_row_topic_matches_rosbags_message_by_message(topics: list[bt.Topic]) -> None:
    batched = [tp for tp in topics if tp.rows is not None]
    kinds = {tp.msgtype for tp in batched}
    assert {m.TYPES[k] for k in ("tf", "odometry", "joints", "imu", "twist", "vector", "clock")} <= kinds
    tf = next(tp for tp in batched if tp.name == "/tf")
    assert isinstance(tf.rows, list) and len(tf.rows) == 2  # each run's transforms, one part each
    for tp in batched:
        parts = tp.rows if isinstance(tp.rows, list) else [tp.rows]
        got = tp.serialized()
        assert len(got) == tp.times.size, tp.name
        some = np.flatnonzero(np.random.default_rng(3).random(tp.times.size) < 0.3)  # across the parts too
        assert [bytes(b) for b in tp.serialized(some)] == [bytes(got[k]) for k in some], tp.name
        first = 0
        for template, columns in parts:  # type: ignore[misc]
            n = len(next(iter(columns.values())))
            ks = sorted({0, 1, n // 3, n // 2, n - 2, n - 1})
            want = reference_rows(pickle.loads(pickle.dumps(template)), columns, ks)
            for k, w in zip(ks, want, strict=True):
                assert bytes(got[first + k]) == w, f"{tp.name} message {first + k}"
            first += n
        assert first == tp.times.size, tp.name


def test_a_time_before_zero_and_times_past_an_int32_of_nanoseconds() -> None:
    template = m.vector_stamped(0.0, "base_link", 0.0, 0.0, 0.0)
    t = np.array([0.0, 1.5, 2.999999999, 4.3, 3600.25])
    cols = {"header.stamp": t, "vector.x": -t, "vector.y": np.full(t.size, math.pi)}
    rows = m.serialize_rows(pickle.loads(pickle.dumps(template)), cols)
    assert [bytes(r) for r in rows] == reference_rows(template, cols, list(range(t.size)))


def test_a_field_of_no_fixed_place_is_refused() -> None:
    template = m.joint_state(0.0, ["a", "b"], np.zeros(2), np.zeros(2))
    with pytest.raises(NhsimError, match=r"header\.frame_id"):
        m.serialize_rows(template, {"header.frame_id": np.zeros(3)})
