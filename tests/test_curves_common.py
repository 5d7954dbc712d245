"""The machinery the curve solvers share: angle wrapping, the local frame, verification, the batch API."""

import numpy as np
import pytest

from planning.curves.common import (
    TOL,
    TWO_PI,
    CurveFamily,
    check_rho,
    fmod_2pi,
    lands_on,
    local_goal,
    mod2pi,
    pose_pairs,
)
from planning.curves.dubins import DUBINS, DUBINS_WORDS, dubins_batch
from planning.curves.reeds_shepp import REEDS_SHEPP, RS_WORDS, reeds_shepp_batch
from tests.curve_helpers import pose_pairs as random_pairs


def test_mod2pi_wraps_to_minus_pi_pi() -> None:
    a = np.linspace(-20.0, 20.0, 2001)
    w = np.array([mod2pi(float(x)) for x in a])
    assert np.all(np.abs(w) <= np.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)
    assert mod2pi(3 * np.pi / 2) == pytest.approx(-np.pi / 2, abs=1e-15)


def test_fmod_2pi_is_fmod_bit_for_bit() -> None:
    """The short cuts for |a| < 4 pi give fmod's own result, signed zeros and the edges included."""
    rng = np.random.default_rng(3)
    edges = [s * k * TWO_PI for s in (1.0, -1.0) for k in (1.0, 2.0)]
    near = [np.nextafter(e, t) for e in edges for t in (0.0, np.sign(e) * np.inf)]
    a = np.concatenate(
        [rng.uniform(-30.0, 30.0, 20000), rng.normal(0.0, 1e-300, 100), edges, near, [0.0, -0.0, 1e300, -1e300]]
    )
    got = np.array([fmod_2pi(float(x)) for x in a])
    assert np.array_equal(got.view(np.int64), np.fmod(a, TWO_PI).view(np.int64))  # -0.0 is not 0.0 here
    for x in (np.nan, np.inf, -np.inf):
        assert np.isnan(fmod_2pi(x))


def test_lands_on_takes_headings_modulo_two_pi() -> None:
    assert lands_on(1.0, 2.0, 0.5 + 2 * np.pi, 1.0, 2.0, 0.5)
    assert not lands_on(1.0 + 2 * TOL, 2.0, 0.5, 1.0, 2.0, 0.5)
    assert not lands_on(1.0, 2.0, 0.5 + 2 * TOL, 1.0, 2.0, 0.5)


def test_local_goal_is_the_goal_seen_from_the_start_in_turning_radii() -> None:
    start = np.array([[1.0, 2.0, np.pi / 2]])
    goals = np.array([[1.0, 4.0, np.pi / 2], [0.0, 2.0, 0.0]])
    # 2 m straight ahead; 1 m to the right, heading turned by -pi/2 (radius 0.5: twice the metres)
    np.testing.assert_allclose(local_goal(start, goals, 0, 0.5), (4.0, 0.0, 0.0), atol=1e-15)
    np.testing.assert_allclose(local_goal(start, goals, 1, 0.5), (0.0, 2.0, -np.pi / 2), atol=1e-15)
    np.testing.assert_allclose(local_goal(goals, start, 1, 1.0), (1.0, 0.0, np.pi / 2), atol=1e-15)  # 1 m ahead


def test_pose_pairs_broadcast_one_side_and_reject_bad_shapes() -> None:
    a, b = pose_pairs([0.0, 0.0, 0.0], np.zeros((4, 3)))
    assert a.shape == (1, 3) and b.shape == (4, 3) and a.flags.c_contiguous
    with pytest.raises(ValueError, match="shape"):
        pose_pairs([0.0, 0.0], [1.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="pose counts must match or one be 1, got 2 and 3"):
        pose_pairs(np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="turning radius must be > 0"):
        check_rho(-1.0)


@pytest.mark.parametrize(("family", "words", "batch"), [(DUBINS, DUBINS_WORDS, dubins_batch),
                                                         (REEDS_SHEPP, RS_WORDS, reeds_shepp_batch)])  # fmt: skip
def test_family_batch_lengths_and_paths_agree(family: CurveFamily, words: np.ndarray, batch) -> None:
    a, b = random_pairs(11, 50)
    lengths, types, segs = batch(a, b, 0.8)
    assert family.words is words and segs.shape == (50, words.shape[1])
    np.testing.assert_array_equal(lengths, family.lengths(a, b, 0.8))
    np.testing.assert_allclose(lengths, 0.8 * np.abs(segs).sum(axis=1), rtol=1e-15)
    for i in range(0, 50, 7):
        w = family.path(a[i], b[i], 0.8)
        assert w.length == pytest.approx(lengths[i], rel=1e-12)
        kappas = words[types[i]][segs[i] != 0.0]
        np.testing.assert_array_equal(w.kappas, kappas)
    # one pose on either side broadcasts
    np.testing.assert_array_equal(family.lengths(a[0], b[:5], 0.8), batch(np.repeat(a[:1], 5, 0), b[:5], 0.8)[0])


@pytest.mark.parametrize("family", [DUBINS, REEDS_SHEPP])
def test_non_finite_input_has_no_word(family: CurveFamily) -> None:
    lengths, types, _ = family.batch([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]], [[np.nan, 1.0, 0.0], [1.0, 0.0, 0.0]], 1.0)
    assert np.isinf(lengths[0]) and types[0] == -1 and lengths[1] == pytest.approx(1.0, abs=1e-12)
    with pytest.raises(ValueError, match=f"no {family.name} path"):
        family.path([0.0, 0.0, 0.0], [np.nan, 1.0, 0.0], 1.0)
