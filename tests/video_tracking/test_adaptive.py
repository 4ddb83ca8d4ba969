"""C's adaptive fusion (SPEC B.5): spreads C (11), entropies C (12), confidences C (13), mixing C (14),
total similarity C (15), occlusion test and template update C (16).  Expected values are worked by hand
in the comments."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from belief_tracking.adaptive import (
    AdaptiveConfig,
    AdaptiveWeighting,
    feature_confidences,
    feature_entropies,
    feature_spreads,
    fuse_adaptive,
    fuse_product,
    fuse_sum,
    occluded,
    total_similarity,
    update_templates,
)
from belief_tracking.errors import TrackingError
from belief_tracking.particles import DegenerateWeightsWarning
from belief_tracking.weighting import Evidence

EPS = 1e-6
SQUARE = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [2.0, 2.0]])  # corners of a 2-px square

# Two particles of one target, two features: p = (0.5, 0.2) and (0.1, 0.4).
P_TWO = np.array([[0.5, 0.2], [0.1, 0.4]])
LOG_TWO = np.log(P_TWO)
OWNER_TWO = np.array([0, 0])
LAM_TWO = np.array([[0.25, 0.75]])


def _per_target_sums(log_weights, owner, n_targets):
    return np.bincount(owner, weights=np.exp(log_weights), minlength=n_targets)


def weigh(config, positions, log_p, owner, rng, similarity=None):
    """The adaptive strategy on own-target log-likelihoods ``log_p`` (P, c): log-weights and λ.

    The evidence's scores hold ``log_p`` in the owner's column; the other hypotheses do not
    enter C (14).
    """
    n_targets = int(np.max(owner)) + 1
    scores = []
    for column in np.asarray(log_p, dtype=float).T:
        table = np.full((len(column), n_targets + 1), -5.0)
        table[np.arange(len(column)), owner] = column
        scores.append(table)
    cues = tuple(f"cue{k}" for k in range(len(scores)))
    weighing = AdaptiveWeighting(config, cues, rng).weigh(
        Evidence(tuple(scores), np.asarray(owner), np.asarray(positions, dtype=float),
                 None if similarity is None else np.asarray(similarity, dtype=float), cues))
    assert tuple(weighing.diagnostics) == tuple(f"confidence_{c}" for c in cues)
    return weighing.log_weights, weighing.confidences


# -- C (12): entropies ----------------------------------------------------------------------------


def test_entropy_of_uniform_weights_over_four_particles_is_two_bits():
    # w̃ = 1/4 each: H = −4·¼·log₂ ¼ = 2.  The common value of the likelihoods does not matter.
    for level in (0.0, -700.0, 50.0):
        entropies = feature_entropies(np.full((4, 1), level), np.zeros(4, int), 1)
        assert entropies.shape == (1, 1)
        assert entropies[0, 0] == pytest.approx(2.0, abs=1e-12)


def test_entropy_of_one_hot_weights_is_zero():
    # w̃ = (1, 0, 0): H = −1·log₂ 1 − 0·log 0 − 0·log 0 = 0 with 0·log 0 = 0 (no NaN from −inf).
    log_p = np.array([[-3.0], [-np.inf], [-np.inf]])
    assert feature_entropies(log_p, np.zeros(3, int), 1).tolist() == [[0.0]]


def test_entropy_of_half_quarter_quarter_is_one_and_a_half_bits():
    # w̃ = (½, ¼, ¼): H = ½·1 + ¼·2 + ¼·2 = 1.5.  Likelihoods (0.2, 0.1, 0.1) normalise to these.
    log_p = np.log([[0.2], [0.1], [0.1]])
    assert feature_entropies(log_p, np.zeros(3, int), 1)[0, 0] == pytest.approx(1.5, abs=1e-12)


def test_entropy_is_per_target_and_per_feature_with_interleaved_owners():
    # Target 0 = particles 0, 2, 4; target 1 = particles 1, 3 (not contiguous).
    # Target 0: feature 0 weights (½, ¼, ¼) → 1.5; feature 1 equal → log₂ 3.
    # Target 1: feature 0 equal → 1; feature 1 one-hot → 0.
    log_p = np.array([
        [math.log(0.2), 0.0],
        [-5.0, -1.0],
        [math.log(0.1), 0.0],
        [-5.0, -np.inf],
        [math.log(0.1), 0.0],
    ])
    entropies = feature_entropies(log_p, np.array([0, 1, 0, 1, 0]), 2)
    np.testing.assert_allclose(entropies, [[1.5, math.log2(3)], [1.0, 0.0]], atol=1e-12)


def test_entropy_does_not_underflow_for_very_negative_log_likelihoods():
    # exp(−800) is 0 in float64, yet the normalised weights are (½, ¼, ¼) → 1.5 bits.
    log_p = np.array([[-800.0], [-800.0 - math.log(2)], [-800.0 - math.log(2)]])
    assert feature_entropies(log_p, np.zeros(3, int), 1)[0, 0] == pytest.approx(1.5, abs=1e-9)


# -- C (11): spreads ------------------------------------------------------------------------------


def test_spread_with_equal_likelihoods_and_keep_one_is_the_covariance_trace():
    # Equal weights over 4 particles: systematic resampling copies each once.  Mean (1, 1), each
    # squared distance 1 + 1 = 2, so tr Σ = (1/4)·4·2 = 2 and s = 2 + ε.
    spreads = feature_spreads(SQUARE, np.zeros((4, 1)), np.zeros(4, int), 1, np.random.default_rng(3), keep=1.0)
    assert spreads[0, 0] == pytest.approx(2.0 + EPS, abs=1e-12)


def test_spread_of_identical_positions_is_epsilon():
    positions = np.tile([5.0, 7.0], (6, 1))
    log_p = np.log(np.array([[0.1, 0.9], [0.2, 0.8], [0.3, 0.7], [0.4, 0.6], [0.5, 0.5], [0.6, 0.4]]))
    spreads = feature_spreads(positions, log_p, np.zeros(6, int), 1, np.random.default_rng(0), epsilon=1e-3)
    assert spreads.tolist() == [[1e-3, 1e-3]]


def test_spread_of_one_hot_likelihood_is_epsilon():
    # All weight on particle 2: N copies of (0, 2), zero covariance.
    log_p = np.array([[-np.inf], [-np.inf], [0.0], [-np.inf]])
    assert feature_spreads(SQUARE, log_p, np.zeros(4, int), 1, np.random.default_rng(1)).tolist() == [[EPS]]


def test_spread_keeps_the_particles_nearest_the_mean_and_drops_an_outlier():
    # Positions (0,0), (0,0), (2,0), (40,40), equal weights, keep = 0.75 → m = ⌈3⌉ = 3.
    # Mean of all four = (10.5, 10); the outlier (40, 40) is farthest and is dropped.
    # Kept mean = (2/3, 0); squared distances 4/9, 4/9, 16/9 → tr Σ = (24/9)/3 = 8/9.
    positions = np.array([[0.0, 0.0], [0.0, 0.0], [2.0, 0.0], [40.0, 40.0]])
    spreads = feature_spreads(positions, np.zeros((4, 1)), np.zeros(4, int), 1, np.random.default_rng(2), keep=0.75)
    assert spreads[0, 0] == pytest.approx(8 / 9 + EPS, abs=1e-12)
    # keep = 0.6: m = ⌈2.4⌉ = 3 as well (⌊2.4⌋ = 2 would keep (0,0) twice and give ε).
    spreads = feature_spreads(positions, np.zeros((4, 1)), np.zeros(4, int), 1, np.random.default_rng(2), keep=0.6)
    assert spreads[0, 0] == pytest.approx(8 / 9 + EPS, abs=1e-12)
    # keep = 1 keeps the outlier: mean (10.5, 10), tr Σ = var x + var y
    # = (10.5² + 10.5² + 8.5² + 29.5²)/4 + (3·10² + 30²)/4 = 1163/4 + 1200/4 = 590.75.
    spreads = feature_spreads(positions, np.zeros((4, 1)), np.zeros(4, int), 1, np.random.default_rng(2), keep=1.0)
    assert spreads[0, 0] == pytest.approx(590.75 + EPS, abs=1e-9)


def test_default_keep_of_sixty_percent_of_a_hundred_keeps_sixty():
    # 100 particles on a line at x = 0..99, equal weights: each resampled once, mean 49.5.
    # ⌈0.6·100⌉ = 60 nearest are x = 20..79 (distances ≤ 29.5); their variance is (60² − 1)/12
    # = 299.9166…  (61 particles would give (61² − 1)/12 = 310, i.e. not this value).
    positions = np.column_stack([np.arange(100.0), np.zeros(100)])
    spreads = feature_spreads(positions, np.zeros((100, 1)), np.zeros(100, int), 1, np.random.default_rng(4))
    assert spreads[0, 0] == pytest.approx((60**2 - 1) / 12 + EPS, abs=1e-9)


def test_spread_is_smaller_for_the_more_concentrated_feature():
    # Feature 0 flat over the square; feature 1 favours particle 0 strongly.
    log_p = np.array([[0.0, 0.0], [0.0, -5.0], [0.0, -5.0], [0.0, -5.0]])
    spreads = feature_spreads(SQUARE, log_p, np.zeros(4, int), 1, np.random.default_rng(5), keep=1.0)
    assert spreads[0, 1] < spreads[0, 0]


def test_spreads_are_reproducible_from_the_seed_and_use_the_generator():
    rng = np.random.default_rng(11)
    owner = np.repeat([0, 1, 2], 30)
    rng.shuffle(owner)
    positions = rng.normal(size=(90, 2)) * 10
    log_p = rng.normal(size=(90, 3)) * 3
    first = feature_spreads(positions, log_p, owner, 3, np.random.default_rng(99))
    second = feature_spreads(positions, log_p, owner, 3, np.random.default_rng(99))
    assert first.shape == (3, 3)
    np.testing.assert_array_equal(first, second)
    generator = np.random.default_rng(99)
    feature_spreads(positions, log_p, owner, 3, generator)
    # One systematic offset per target and feature: 9 draws consumed.
    reference = np.random.default_rng(99)
    reference.random(9)
    assert generator.random() == reference.random()


# -- C (13): confidences --------------------------------------------------------------------------


def test_confidences_from_spreads_and_entropies():
    # h = 1/(s·H + ε): s = (2, 1), H = (1, 1) → h ≈ (0.5, 1) → λ = (1/3, 2/3).
    lam = feature_confidences([[2.0, 1.0]], [[1.0, 1.0]])
    np.testing.assert_allclose(lam, [[1 / 3, 2 / 3]], atol=1e-6)
    # Exact with ε = 1e-6: λ₀ = (1/(2+ε)) / (1/(2+ε) + 1/(1+ε)) = (1+ε)/(3+2ε).
    assert lam[0, 0] == pytest.approx((1 + EPS) / (3 + 2 * EPS), rel=1e-12)


def test_confidences_use_the_product_of_spread_and_entropy():
    # Row 0: s·H = (1·3, 3·1) → equal.  Row 1: s·H = (1, 4) → h ≈ (1, 1/4) → λ = (0.8, 0.2).
    lam = feature_confidences([[1.0, 3.0], [1.0, 2.0]], [[3.0, 1.0], [1.0, 2.0]], epsilon=1e-12)
    np.testing.assert_allclose(lam, [[0.5, 0.5], [0.8, 0.2]], atol=1e-9)


def test_confidences_of_degenerate_features_stay_finite():
    # s·H = 0 for both features (one-particle target): h = 1/ε for both → λ = (½, ½).
    # s·H = 0 for one only: h = (1/ε, 1/(1+ε)) → λ₀ = 1/(1 + ε/(1+ε)) ≈ 1 − 1e-6.
    lam = feature_confidences([[EPS, EPS], [0.0, 1.0]], [[0.0, 0.0], [5.0, 1.0]])
    assert np.isfinite(lam).all()
    np.testing.assert_allclose(lam[0], [0.5, 0.5])
    assert lam[1, 0] == pytest.approx(1 - EPS, abs=1e-9)


# -- C (14): fusion -------------------------------------------------------------------------------


def test_product_and_sum_hand_values():
    # Product: 0.5·0.2 = 0.1, 0.1·0.4 = 0.04.  Equal sum: (0.5+0.2)/2 = 0.35, (0.1+0.4)/2 = 0.25.
    # λ = (¼, ¾): 0.125 + 0.15 = 0.275 and 0.025 + 0.3 = 0.325.
    np.testing.assert_allclose(np.exp(fuse_product(LOG_TWO, OWNER_TWO, 1)), [0.1, 0.04], rtol=1e-12)
    np.testing.assert_allclose(np.exp(fuse_sum(LOG_TWO, OWNER_TWO, 1)), [0.35, 0.25], rtol=1e-12)
    np.testing.assert_allclose(np.exp(fuse_sum(LOG_TWO, OWNER_TWO, 1, LAM_TWO)), [0.275, 0.325], rtol=1e-12)
    # λ rows are divided by their sum: (1, 3) is the same as (¼, ¾).
    np.testing.assert_allclose(np.exp(fuse_sum(LOG_TWO, OWNER_TWO, 1, [[1.0, 3.0]])), [0.275, 0.325], rtol=1e-12)


def test_sum_uses_each_targets_own_lambda_row():
    # Particle 0 of target 1 uses λ = (1, 0): 0.5; particle 1 of target 0 uses λ = (0, 1): 0.4.
    owner = np.array([1, 0])
    np.testing.assert_allclose(np.exp(fuse_sum(LOG_TWO, owner, 2, [[0.0, 1.0], [1.0, 0.0]])), [0.5, 0.4])


def test_adaptive_raw_hand_value():
    # ρ = ½: ½·0.1 + ½·0.275 = 0.1875; ½·0.04 + ½·0.325 = 0.1825.
    weights = np.exp(fuse_adaptive(LOG_TWO, OWNER_TWO, 1, LAM_TWO, 0.5, mix_norm="raw"))
    np.testing.assert_allclose(weights, [0.1875, 0.1825], rtol=1e-12)


def test_adaptive_per_term_hand_value():
    # Product (0.1, 0.04)/0.14 = (5/7, 2/7); sum (0.275, 0.325)/0.6 = (11/24, 13/24).
    # ρ = ½: (5/7 + 11/24)/2 = 197/336, (2/7 + 13/24)/2 = 139/336.
    weights = np.exp(fuse_adaptive(LOG_TWO, OWNER_TWO, 1, LAM_TWO, np.array([0.5])))
    np.testing.assert_allclose(weights, [197 / 336, 139 / 336], rtol=1e-12)
    # ρ = ¼ gives a different mix: ¼·5/7 + ¾·11/24 = 5/28 + 11/32 = 117/224.
    weights = np.exp(fuse_adaptive(LOG_TWO, OWNER_TWO, 1, LAM_TWO, 0.25))
    assert weights[0] == pytest.approx(117 / 224, rel=1e-12)


@pytest.mark.parametrize("mix_norm", ["per_term", "raw"])
def test_adaptive_reduces_to_product_at_rho_one_and_to_lambda_sum_at_rho_zero(mix_norm):
    rng = np.random.default_rng(6)
    owner = np.array([0, 1, 1, 0, 2, 1, 2, 0])
    log_p = rng.normal(-3.0, 2.0, size=(8, 3))
    lam = rng.dirichlet(np.ones(3), size=3)
    product = fuse_product(log_p, owner, 3)
    weighted_sum = fuse_sum(log_p, owner, 3, lam)
    at_one = fuse_adaptive(log_p, owner, 3, lam, np.ones(3), mix_norm=mix_norm)
    at_zero = fuse_adaptive(log_p, owner, 3, lam, np.zeros(3), mix_norm=mix_norm)
    if mix_norm == "raw":   # log(1·Π + 0·S) = log Π exactly, log(0·Π + 1·S) = log S
        np.testing.assert_allclose(at_one, product, rtol=1e-12)
        np.testing.assert_allclose(at_zero, weighted_sum, rtol=1e-12)
    else:                   # the same up to a per-target constant: compare normalised weights
        for fused, reference in ((at_one, product), (at_zero, weighted_sum)):
            expected = np.exp(reference) / np.bincount(owner, weights=np.exp(reference))[owner]
            np.testing.assert_allclose(np.exp(fused), expected, rtol=1e-12)
            np.testing.assert_allclose(_per_target_sums(fused, owner, 3), 1.0, rtol=1e-12)


def test_adaptive_rho_is_per_target():
    # Target 0 at ρ = 1 follows the product, target 1 at ρ = 0 the sum (independent targets).
    log_p = np.vstack([LOG_TWO, LOG_TWO])
    owner = np.array([0, 0, 1, 1])
    weights = np.exp(fuse_adaptive(log_p, owner, 2, np.vstack([LAM_TWO, LAM_TWO]), [1.0, 0.0]))
    np.testing.assert_allclose(weights, [5 / 7, 2 / 7, 11 / 24, 13 / 24], rtol=1e-12)


def test_per_term_mixing_does_not_underflow():
    # log p = −800 (exp underflows to 0).  Product: e^−1600·(1, ½) → (2/3, 1/3).
    # Equal sum: ½e^−800·(1 + 1) vs ½e^−800·(½ + 1) → 2 : 1.5 → (4/7, 3/7).
    log_p = np.array([[-800.0, -800.0], [-800.0 - math.log(2), -800.0]])
    lam = np.array([[0.5, 0.5]])
    at_one = np.exp(fuse_adaptive(log_p, OWNER_TWO, 1, lam, 1.0))
    at_zero = np.exp(fuse_adaptive(log_p, OWNER_TWO, 1, lam, 0.0))
    at_half = np.exp(fuse_adaptive(log_p, OWNER_TWO, 1, lam, 0.5))
    np.testing.assert_allclose(at_one, [2 / 3, 1 / 3], rtol=1e-12)
    np.testing.assert_allclose(at_zero, [4 / 7, 3 / 7], rtol=1e-12)
    np.testing.assert_allclose(at_half, [(2 / 3 + 4 / 7) / 2, (1 / 3 + 3 / 7) / 2], rtol=1e-12)
    # The raw form stays finite in the log domain too: log Π = −1600 and −1600 − log 2.
    raw = fuse_adaptive(log_p, OWNER_TWO, 1, lam, 1.0, mix_norm="raw")
    np.testing.assert_allclose(raw, [-1600.0, -1600.0 - math.log(2)], rtol=1e-15)


# -- robustness -----------------------------------------------------------------------------------


def test_minus_infinity_log_likelihoods_give_no_nan():
    # Particle 1 is impossible under feature 0, particle 2 under both features.
    log_p = np.array([[-1.0, -2.0], [-np.inf, -1.0], [-np.inf, -np.inf], [-3.0, -0.5]])
    owner = np.zeros(4, int)
    lam = np.array([[0.5, 0.5]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # no RuntimeWarning from log(0) or inf − inf
        assert np.isfinite(feature_entropies(log_p, owner, 1)).all()
        assert np.isfinite(feature_spreads(SQUARE, log_p, owner, 1, np.random.default_rng(0))).all()
        product = fuse_product(log_p, owner, 1)
        weighted_sum = fuse_sum(log_p, owner, 1, lam)
        fused = fuse_adaptive(log_p, owner, 1, lam, 0.3)
    assert not np.isnan(product).any() and not np.isnan(weighted_sum).any() and not np.isnan(fused).any()
    assert product[1] == -np.inf and product[2] == -np.inf   # Π has a zero factor
    assert np.isfinite(weighted_sum[1]) and weighted_sum[2] == -np.inf
    assert fused[2] == -np.inf and np.exp(fused).sum() == pytest.approx(1.0)


def test_product_term_that_is_zero_everywhere_is_dropped():
    # Every particle has one impossible feature: the product term is 0 on the whole target, so
    # the per-term mix is the normalised sum: ½·0.5 = 0.25 and ½·0.4 = 0.2 → (5/9, 4/9).
    log_p = np.array([[math.log(0.5), -np.inf], [-np.inf, math.log(0.4)]])
    fused = fuse_adaptive(log_p, OWNER_TWO, 1, [[0.5, 0.5]], 0.9)
    np.testing.assert_allclose(np.exp(fused), [5 / 9, 4 / 9], rtol=1e-12)


def test_target_with_no_possible_particle_falls_back_to_uniform_with_a_warning():
    log_p = np.array([[-np.inf, -np.inf], [-np.inf, -np.inf], [0.0, 0.0]])
    owner = np.array([0, 0, 1])
    with pytest.warns(DegenerateWeightsWarning):
        entropies = feature_entropies(log_p, owner, 2)
    np.testing.assert_allclose(entropies, [[1.0, 1.0], [0.0, 0.0]])   # uniform over 2 → 1 bit
    with pytest.warns(DegenerateWeightsWarning):
        fused = fuse_adaptive(log_p, owner, 2, np.full((2, 2), 0.5), [0.8, 0.8])
    np.testing.assert_allclose(np.exp(fused), [0.5, 0.5, 1.0])


def test_target_with_one_particle():
    # One particle: H = 0, s = ε (every copy is the same point), λ = (½, ½), its weight is 1.
    positions = np.vstack([SQUARE, [[50.0, 50.0]]])
    owner = np.array([0, 0, 0, 0, 1])
    log_p = np.array([[0.0, -1.0], [-1.0, 0.0], [-2.0, -1.0], [0.0, 0.0], [-9.0, -4.0]])
    log_weights, lam = weigh(AdaptiveConfig(), positions, log_p, owner, np.random.default_rng(0))
    assert np.isfinite(log_weights).all() and np.isfinite(lam).all()
    np.testing.assert_allclose(lam[1], [0.5, 0.5])
    assert log_weights[4] == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(_per_target_sums(log_weights, owner, 2), [1.0, 1.0], rtol=1e-12)


def test_all_equal_likelihoods():
    # Flat weights: H = log₂ 4 = 2 for both features, the spreads are equal (same resampled cloud
    # with keep = 1 → 2 + ε), so λ = (½, ½) and every particle gets ¼.
    log_p = np.full((4, 2), -12.0)
    owner = np.zeros(4, int)
    log_weights, lam = weigh(AdaptiveConfig(keep=1.0), SQUARE, log_p, owner, np.random.default_rng(0))
    np.testing.assert_allclose(lam, [[0.5, 0.5]])
    np.testing.assert_allclose(np.exp(log_weights), 0.25, rtol=1e-12)
    np.testing.assert_allclose(feature_entropies(log_p, owner, 1), [[2.0, 2.0]])


@pytest.mark.parametrize("seed", range(5))
def test_random_inputs_with_minus_infinity_never_give_nan(seed):
    rng = np.random.default_rng(seed)
    n_targets, n_features = 3, 2
    owner = rng.permutation(np.repeat(np.arange(n_targets), 7))
    log_p = rng.normal(-400.0, 300.0, size=(21, n_features))
    log_p[rng.random(log_p.shape) < 0.3] = -np.inf
    for target in range(n_targets):   # keep one possible particle per target and feature
        log_p[np.flatnonzero(owner == target)[0]] = -1.0
    positions = rng.uniform(0, 100, size=(21, 2))
    log_weights, lam = weigh(AdaptiveConfig(mix_norm="per_term"), positions, log_p, owner, rng)
    assert not np.isnan(log_weights).any() and np.isfinite(lam).all()
    np.testing.assert_allclose(lam.sum(axis=1), 1.0)
    np.testing.assert_allclose(_per_target_sums(log_weights, owner, n_targets), 1.0, rtol=1e-9)


# -- C (15) and occlusion -------------------------------------------------------------------------


def test_total_similarity_hand_values():
    # Row 0: ¼·0.8 + ¾·0.4 = 0.5.  Row 1: λ = (0.2, 0.6) renormalises to (¼, ¾): ¼·1 + ¾·0.6 = 0.7.
    rho_t = total_similarity([[0.25, 0.75], [0.2, 0.6]], [[0.8, 0.4], [1.0, 0.6]])
    np.testing.assert_allclose(rho_t, [0.5, 0.7], rtol=1e-12)


def test_occlusion_threshold_edge():
    # ρ_t < T only: exactly 0.6 is not occluded.
    assert occluded(np.array([0.5999999, 0.6, 0.6000001, 0.0, 1.0])).tolist() == [True, False, False, True, False]
    assert occluded([0.7], threshold=0.75).tolist() == [True]


# -- C (16): template update ----------------------------------------------------------------------

Q_INIT = np.array([[1.0, 0.0]])
Q_PREV = np.array([[0.5, 0.5]])
P_CUR = np.array([[0.64, 0.36]])   # β = √(1·0.64) + √(0·0.36) = 0.8


def test_template_update_hand_value():
    # p_c = 0.8·(½, ½) + 0.2·(0.64, 0.36) = (0.528, 0.472); q = 0.8·(1, 0) + 0.2·p_c = (0.9056, 0.0944).
    updated = update_templates(Q_INIT, Q_PREV, P_CUR, np.array([False]))
    np.testing.assert_allclose(updated, [[0.9056, 0.0944]], rtol=1e-12)


def test_template_update_normalises_a_masked_current_histogram():
    # p_cur = (0.32, 0.18) sums to F = ½; divided by F it is (0.64, 0.36), as above.
    updated = update_templates(Q_INIT, Q_PREV, P_CUR * 0.5, np.array([False]))
    np.testing.assert_allclose(updated, [[0.9056, 0.0944]], rtol=1e-12)


def test_template_update_is_frozen_under_occlusion_and_for_an_empty_current_histogram():
    rng = np.random.default_rng(8)
    q_init = rng.dirichlet(np.ones(16), size=3)
    q_prev = rng.dirichlet(np.ones(16), size=3)
    p_cur = rng.dirichlet(np.ones(16), size=3) * np.array([[0.7], [1.0], [0.0]])   # row 2 saw nothing
    updated = update_templates(q_init, q_prev, p_cur, np.array([True, False, False]))
    assert updated[0].tobytes() == q_prev[0].tobytes()     # occluded: bit-identical
    assert updated[2].tobytes() == q_prev[2].tobytes()     # p_cur sums to 0: kept
    assert not np.allclose(updated[1], q_prev[1])
    np.testing.assert_allclose(updated.sum(axis=1), 1.0, rtol=1e-12)
    assert (updated >= 0).all()


def test_template_update_with_identical_histograms_changes_nothing():
    # q_init = q_prev = p_cur = q: β = Σ q = 1, p_c = q, q_new = q.
    q = np.array([[0.1, 0.2, 0.3, 0.4]])
    np.testing.assert_allclose(update_templates(q, q, q, np.array([False])), q, rtol=1e-12)


# -- the weighting strategy ------------------------------------------------------------------------


def test_the_strategy_mixes_with_the_previous_similarity_of_the_evidence():
    positions = SQUARE[:2]
    log_weights, lam = weigh(AdaptiveConfig(keep=1.0), positions, LOG_TWO, OWNER_TWO, np.random.default_rng(0),
                             similarity=[1.0])
    np.testing.assert_allclose(np.exp(log_weights), [5 / 7, 2 / 7], rtol=1e-12)   # the product rule
    log_weights, lam = weigh(AdaptiveConfig(keep=1.0), positions, LOG_TWO, OWNER_TWO, np.random.default_rng(0),
                             similarity=[0.0])
    expected = (lam[0] * P_TWO).sum(axis=1)                                       # the λ-sum rule
    np.testing.assert_allclose(np.exp(log_weights), expected / expected.sum(), rtol=1e-12)


def test_a_new_target_starts_at_rho0():
    # Without a previous similarity (a target's first fused frame) C (14) mixes with ρ_0.
    config = AdaptiveConfig(keep=1.0, rho0=0.3)
    fresh, _ = weigh(config, SQUARE[:2], LOG_TWO, OWNER_TWO, np.random.default_rng(0))
    given, _ = weigh(config, SQUARE[:2], LOG_TWO, OWNER_TWO, np.random.default_rng(0), similarity=[0.3])
    np.testing.assert_array_equal(fresh, given)


def test_the_strategy_uses_the_configured_mix():
    log_weights, _ = weigh(AdaptiveConfig(mix_norm="raw"), SQUARE[:2], LOG_TWO, OWNER_TWO,
                           np.random.default_rng(0), similarity=[1.0])
    np.testing.assert_allclose(np.exp(log_weights), [0.1, 0.04], rtol=1e-12)     # raw product, unnormalised


def test_the_strategy_is_reproducible_from_the_seed():
    rng = np.random.default_rng(21)
    owner = rng.permutation(np.repeat([0, 1], 25))
    positions = rng.normal(size=(50, 2)) * 8
    log_p = rng.normal(-20.0, 5.0, size=(50, 2))
    results = [weigh(AdaptiveConfig(), positions, log_p, owner, np.random.default_rng(5)) for _ in range(2)]
    np.testing.assert_array_equal(results[0][0], results[1][0])
    np.testing.assert_array_equal(results[0][1], results[1][1])


# -- validation -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"keep": 0.0}, "keep"),
        ({"keep": 1.5}, "keep"),
        ({"keep": float("nan")}, "keep"),
        ({"threshold": -0.1}, "threshold"),
        ({"threshold": 1.2}, "threshold"),
        ({"rho0": 2.0}, "rho0"),
        ({"rho0": "high"}, "rho0"),
        ({"mix_norm": "log"}, "mix_norm"),
        ({"epsilon": 0.0}, "epsilon"),
        ({"epsilon": True}, "epsilon"),
    ],
)
def test_config_validation_names_the_field(kwargs, field):
    with pytest.raises(TrackingError, match=f"AdaptiveConfig.{field}"):
        AdaptiveConfig(**kwargs)


def test_config_defaults_and_accepted_edges():
    config = AdaptiveConfig()
    assert (config.keep, config.threshold, config.rho0, config.mix_norm, config.epsilon) == (
        0.6, 0.6, 0.8, "per_term", 1e-6)
    AdaptiveConfig(keep=1.0, threshold=0.0, rho0=1.0, mix_norm="raw")
    with pytest.raises(Exception):
        config.keep = 0.5   # frozen


def test_argument_errors_name_the_argument():
    log_p = np.zeros((4, 2))
    owner = np.zeros(4, int)
    rng = np.random.default_rng(0)
    with pytest.raises(TrackingError, match="owner"):
        fuse_product(log_p, np.array([0, 0, 0, 2]), 2)             # value out of range
    with pytest.raises(TrackingError, match="owner gives target 1 no particle"):
        feature_entropies(log_p, owner, 2)
    with pytest.raises(TrackingError, match="owner"):
        fuse_product(log_p, owner.astype(float), 1)
    with pytest.raises(TrackingError, match="log_p"):
        feature_entropies(np.array([[0.0], [np.nan]]), np.zeros(2, int), 1)
    with pytest.raises(TrackingError, match="log_p"):
        fuse_product(np.zeros(4), owner, 1)
    with pytest.raises(TrackingError, match="positions"):
        feature_spreads(np.zeros((4, 3)), log_p, owner, 1, rng)
    with pytest.raises(TrackingError, match="keep"):
        feature_spreads(SQUARE, log_p, owner, 1, rng, keep=0.0)
    with pytest.raises(TrackingError, match="rng"):
        feature_spreads(SQUARE, log_p, owner, 1, 42)
    with pytest.raises(TrackingError, match="lam"):
        fuse_sum(log_p, owner, 1, lam=[[0.0, 0.0]])
    with pytest.raises(TrackingError, match="lam"):
        fuse_adaptive(log_p, owner, 1, [[0.5, 0.5, 0.0]], 0.5)
    with pytest.raises(TrackingError, match="rho_prev"):
        fuse_adaptive(log_p, owner, 1, [[0.5, 0.5]], 1.5)
    with pytest.raises(TrackingError, match="mix_norm"):
        fuse_adaptive(log_p, owner, 1, [[0.5, 0.5]], 0.5, mix_norm="log")
    with pytest.raises(TrackingError, match="entropies"):
        feature_confidences([[1.0, 1.0]], [[1.0, -1.0]])
    with pytest.raises(TrackingError, match="epsilon"):
        feature_confidences([[1.0, 1.0]], [[1.0, 1.0]], epsilon=0.0)
    with pytest.raises(TrackingError, match="rho"):
        total_similarity([[0.5, 0.5]], [[0.5, 1.5]])
    with pytest.raises(TrackingError, match="threshold"):
        occluded([0.5], threshold=2.0)
    with pytest.raises(TrackingError, match="q_prev"):
        update_templates(Q_INIT, [[0.5, 0.6]], P_CUR, np.array([False]))
    with pytest.raises(TrackingError, match="p_cur"):
        update_templates(Q_INIT, Q_PREV, [[-0.1, 1.1]], np.array([False]))
    with pytest.raises(TrackingError, match="occluded"):
        update_templates(Q_INIT, Q_PREV, P_CUR, np.array([0]))
