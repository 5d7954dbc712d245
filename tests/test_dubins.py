"""Dubins curves: forward only, endpoints, integration, known optima, asymmetry, OMPL."""

import numpy as np
import pytest

from planning.core.kinematics import rollout, unicycle_rhs
from planning.curves.dubins import dubins_length, dubins_path

RNG = np.random.default_rng(3)
N = 400
A = np.column_stack([RNG.uniform(-4, 4, (N, 2)), RNG.uniform(-np.pi, np.pi, N)])
B = np.column_stack([RNG.uniform(-4, 4, (N, 2)), RNG.uniform(-np.pi, np.pi, N)])


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize("i", range(0, N, 25))
def test_controls_integrate_to_goal_forward_only(i):
    w = dubins_path(A[i], B[i], 0.5)
    assert np.all(w.lengths > 0)
    dur, u = w.controls(speed=0.2)
    x = A[i].copy()
    for d, uk in zip(dur, u, strict=True):
        n = max(1, int(np.ceil(d / 5e-3)))
        x = rollout(unicycle_rhs, x, np.repeat(uk[None, :], n, axis=0), d / n)[-1]
    assert np.allclose(x[:2], B[i, :2], atol=1e-9) and abs(_wrap(x[2] - B[i, 2])) < 1e-9
    assert 0.2 * dur.sum() == pytest.approx(dubins_length(A[i], B[i], 0.5)[0], abs=1e-12)
    _, dirs = w.sample(0.01)
    assert np.all(dirs == 1.0)


def test_heading_flip_symmetry_and_asymmetry():
    d = dubins_length(A, B, 0.7)
    flip = np.array([0.0, 0.0, np.pi])
    assert np.allclose(d, dubins_length(B + flip, A + flip, 0.7), atol=1e-9)
    assert np.max(np.abs(d - dubins_length(B, A, 0.7))) > 0.5  # not symmetric


def test_known_values():
    assert dubins_length([0, 0, 0], [0, 0, np.pi], 1.0)[0] == pytest.approx(7 * np.pi / 3, abs=1e-9)
    assert dubins_length([0, 0, 0], [0, 2, np.pi], 1.0)[0] == pytest.approx(np.pi, abs=1e-9)
    assert dubins_length([0, 0, 0], [5, 0, 0], 1.0)[0] == pytest.approx(5.0, abs=1e-12)
    assert dubins_length([0, 0, 0], [0, 0, 0], 1.0)[0] == pytest.approx(0.0, abs=1e-12)


def test_matches_ompl():
    ob = pytest.importorskip("ompl.base")
    sp = ob.DubinsStateSpace(0.7)
    s0, s1 = sp.allocState(), sp.allocState()
    ref = []
    for a, b in zip(A, B, strict=True):
        s0.setX(a[0]), s0.setY(a[1]), s0.setYaw(a[2])
        s1.setX(b[0]), s1.setY(b[1]), s1.setYaw(b[2])
        ref.append(sp.distance(s0, s1))
    assert np.allclose(dubins_length(A, B, 0.7), ref, atol=1e-9)
