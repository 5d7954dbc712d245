"""Reeds–Shepp curves: endpoints, integration of the controls, symmetry, known optima, OMPL."""

import numpy as np
import pytest

from planning.curves.dubins import dubins_length
from planning.curves.reeds_shepp import (
    CSC_FAMILIES,
    FAMILIES,
    reeds_shepp_batch,
    reeds_shepp_length,
    reeds_shepp_path,
    shortest_radii,
)
from tests.curve_helpers import drive, ompl_distances, pose_pairs, wrap

N = 400
A, B = pose_pairs(7, N)


@pytest.mark.parametrize("i", range(0, N, 50))
def test_controls_integrate_to_goal_and_length(i):
    rho = 0.6
    w = reeds_shepp_path(A[i], B[i], rho)
    x, travelled = drive(A[i], w, speed=1.0, dt=1e-3)
    assert np.allclose(x[:2], B[i, :2], atol=1e-9)
    assert abs(wrap(x[2] - B[i, 2])) < 1e-9
    assert travelled == pytest.approx(reeds_shepp_length(A[i], B[i], rho)[0], abs=1e-12)


def test_samples_start_end_and_spacing():
    w = reeds_shepp_path(A[0], B[0], 0.5)
    poses, dirs = w.sample(0.01)
    assert np.allclose(poses[0], A[0])
    assert np.allclose(poses[-1, :2], B[0, :2], atol=1e-9) and abs(wrap(poses[-1, 2] - B[0, 2])) < 1e-9
    assert np.all(np.hypot(*np.diff(poses[:, :2], axis=0).T) <= 0.01 + 1e-12)
    assert set(np.unique(dirs)) <= {-1.0, 1.0}


def test_never_longer_than_dubins_and_symmetric():
    rs = reeds_shepp_length(A, B, 0.7)
    assert np.all(rs <= dubins_length(A, B, 0.7) + 1e-9)
    # reversing a path in time joins b to a with the same length
    assert np.allclose(rs, reeds_shepp_length(B, A, 0.7), atol=1e-9)
    # invariance under a rigid motion of both poses
    c, s = np.cos(0.8), np.sin(0.8)
    R = np.array([[c, -s], [s, c]])
    A2 = np.column_stack([A[:, :2] @ R.T + [1.0, -2.0], A[:, 2] + 0.8])
    B2 = np.column_stack([B[:, :2] @ R.T + [1.0, -2.0], B[:, 2] + 0.8])
    assert np.allclose(rs, reeds_shepp_length(A2, B2, 0.7), atol=1e-9)
    # scaling: length scales with the radius when the poses scale too
    assert np.allclose(2 * rs, reeds_shepp_length(A * [2, 2, 1], B * [2, 2, 1], 1.4), atol=1e-9)


@pytest.mark.parametrize(
    ("goal", "expected"),
    [
        ((3.0, 0.0, 0.0), 3.0),  # straight ahead
        ((-2.0, 0.0, 0.0), 2.0),  # straight back
        ((0.0, 2.0, np.pi), np.pi),  # half circle left
        ((0.0, 0.0, 0.0), 0.0),
    ],
)
def test_known_values(goal, expected):
    assert reeds_shepp_length([0.0, 0.0, 0.0], goal, 1.0)[0] == pytest.approx(expected, abs=1e-9)


def test_matches_ompl():
    ref = ompl_distances("ReedsSheppStateSpace", 0.7, A, B)
    assert np.allclose(reeds_shepp_length(A, B, 0.7), ref, atol=1e-9)


def test_bad_input():
    with pytest.raises(ValueError, match="turning radius"):
        reeds_shepp_length([0, 0, 0], [1, 1, 0], 0.0)
    with pytest.raises(ValueError, match="shape"):
        reeds_shepp_length([0, 0], [1, 1, 0], 1.0)


def test_single_lengths_and_the_csc_bound():
    """shortest_radii gives the batch solver's length, word and segments bit for bit; the CSC words
    alone bound the length from above, and solving the other families from that bound gives the length
    again, bit for bit."""
    q0, q1 = pose_pairs(11, 3000)
    q1[:50] = q0[:50]  # no motion at all
    rho = 0.3
    exact, words, segments = reeds_shepp_batch(q0, q1, rho)
    scratch = np.zeros((2, 5))
    for a, b, want, word, segs in zip(q0, q1, exact, words, segments, strict=True):
        length, index = shortest_radii(a, b, rho, scratch, 0, FAMILIES, np.inf)
        assert length * rho == want and index == word and (word < 0 or np.array_equal(scratch[1], segs))
        upper = shortest_radii(a, b, rho, scratch, 0, CSC_FAMILIES, np.inf)[0]
        assert upper * rho >= want
        assert shortest_radii(a, b, rho, scratch, CSC_FAMILIES, FAMILIES, upper)[0] * rho == want


def test_the_compiled_sine_is_odd_and_cosine_even_exactly():
    """The solver computes phi's sine and cosine once and flips the sine's sign for the reflected and
    time-flipped candidates: the same values as computing them at -phi only if these hold bit for bit."""
    import numba as nb

    @nb.njit
    def first_asymmetric(a):  # one value at a time, as the solver calls them (no vectorised loop)
        for i in range(a.size):
            if np.sin(-a[i]) != -np.sin(a[i]) or np.cos(-a[i]) != np.cos(a[i]):
                return i
        return -1

    a = np.concatenate([np.random.default_rng(2).uniform(-50.0, 50.0, 20000), [0.0, np.pi, 1e-300, 1e5]])
    assert first_asymmetric(a) == -1
