"""Dubins curves: forward only, endpoints, integration, known optima, asymmetry, OMPL."""

import numpy as np
import pytest

from planning.curves.dubins import dubins_length, dubins_path
from tests.curve_helpers import drive, ompl_distances, pose_pairs, wrap

N = 400
A, B = pose_pairs(3, N)


@pytest.mark.parametrize("i", range(0, N, 25))
def test_controls_integrate_to_goal_forward_only(i):
    w = dubins_path(A[i], B[i], 0.5)
    assert np.all(w.lengths > 0)
    x, travelled = drive(A[i], w, speed=0.2, dt=5e-3)
    assert np.allclose(x[:2], B[i, :2], atol=1e-9) and abs(wrap(x[2] - B[i, 2])) < 1e-9
    assert travelled == pytest.approx(dubins_length(A[i], B[i], 0.5)[0], abs=1e-12)
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
    assert np.allclose(dubins_length(A, B, 0.7), ompl_distances("DubinsStateSpace", 0.7, A, B), atol=1e-9)
