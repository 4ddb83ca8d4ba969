"""Particle-filter machinery: motion, initialisation, weights, resampling and particle sets."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from belief_tracking.errors import TrackingError
from belief_tracking.particles import (
    CX,
    CY,
    LOG_SCALE,
    RESAMPLERS,
    STATE,
    STATE_DIM,
    VX,
    VY,
    ConstantVelocity,
    DegenerateWeightsWarning,
    MotionConfig,
    ParticleSet,
    adaptive_count,
    effective_sample_size,
    get_resampler,
    initialise,
    multinomial,
    normalise_log_weights,
    residual,
    stratified,
    systematic,
)

METHODS = sorted(RESAMPLERS)
TOLERANCE = 1e-6  # slack for rounding in n·w when n·w is (nearly) an integer


def random_states(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.normal(loc=[100, 80, 1, -1, 0], scale=[30, 20, 2, 2, 0.1], size=(n, STATE_DIM))


# Non-negative weight vectors with a positive sum, zeros included on purpose.
weight_vectors = st.lists(
    st.one_of(st.just(0.0), st.floats(min_value=1e-6, max_value=1e3)),
    min_size=1,
    max_size=40,
).filter(lambda values: sum(values) > 0)
sizes = st.integers(min_value=1, max_value=200)
seeds = st.integers(min_value=0, max_value=2**32 - 1)


def counts(indices: np.ndarray, n_particles: int) -> np.ndarray:
    return np.bincount(indices, minlength=n_particles)


# -- state layout ---------------------------------------------------------------------------------


def test_state_columns():
    assert STATE == ("cx", "cy", "vx", "vy", "log_scale")
    assert STATE_DIM == 5
    assert [STATE[i] for i in (CX, CY, VX, VY, LOG_SCALE)] == list(STATE)


# -- configuration --------------------------------------------------------------------------------


def test_motion_config_defaults_are_the_trackers():
    config = MotionConfig()
    assert (config.sigma_pos, config.sigma_vel, config.dt) == (3.0, 0.5, 1.0)
    assert config.noise_std().tolist() == [3.0, 3.0, 0.5, 0.5, 0.0]          # no noise on the log-scale


@pytest.mark.parametrize("field", ["sigma_pos", "sigma_vel", "dt"])
@pytest.mark.parametrize("value", [-1.0, math.nan, math.inf, -math.inf, "four", None])
def test_bad_motion_config_names_the_field(field, value):
    with pytest.raises(TrackingError, match=f"MotionConfig.{field}"):
        MotionConfig(**{field: value})


def test_dt_must_be_positive_but_noise_may_be_zero():
    with pytest.raises(TrackingError, match="dt"):
        MotionConfig(dt=0)
    assert MotionConfig(sigma_pos=0, sigma_vel=0).sigma_pos == 0.0


def test_motion_config_is_frozen():
    with pytest.raises(AttributeError):
        MotionConfig().sigma_pos = 1.0  # type: ignore[misc]


@pytest.mark.parametrize("bounds", [(0, 10), (10, -1), (math.nan, 10), (10,), "wide", (10, 10, 10)])
def test_bad_bounds_raise(bounds):
    with pytest.raises(ValueError, match="bounds"):
        ConstantVelocity(MotionConfig(), bounds=bounds)


# -- motion ---------------------------------------------------------------------------------------


@given(
    cx=st.floats(-1e4, 1e4),
    cy=st.floats(-1e4, 1e4),
    vx=st.floats(-100, 100),
    vy=st.floats(-100, 100),
    log_scale=st.floats(-3, 3),
    dt=st.floats(0.1, 5),
)
def test_zero_noise_is_exact_constant_velocity(cx, cy, vx, vy, log_scale, dt):
    model = ConstantVelocity(MotionConfig(sigma_pos=0, sigma_vel=0, dt=dt))
    states = np.array([[cx, cy, vx, vy, log_scale]] * 3)
    moved = model.propagate(states, np.random.default_rng(0))
    expected = np.array([cx + vx * dt, cy + vy * dt, vx, vy, log_scale])
    assert np.array_equal(moved, np.tile(expected, (3, 1)))


def test_propagate_returns_a_new_array_and_leaves_the_input_alone():
    states = random_states(10)
    before = states.copy()
    moved = ConstantVelocity().propagate(states, np.random.default_rng(1))
    assert moved is not states
    assert np.array_equal(states, before)
    assert not np.array_equal(moved, states)


def test_noise_standard_deviations_match_the_config():
    config = MotionConfig(sigma_pos=3.0, sigma_vel=0.5, dt=2.0)
    states = np.zeros((200_000, STATE_DIM))
    states[:, VX] = 1.5  # the drift must shift the mean, not widen the spread
    moved = ConstantVelocity(config).propagate(states, np.random.default_rng(2024))
    noise = moved - states
    noise[:, CX] -= 1.5 * config.dt
    expected_std = [3.0, 3.0, 0.5, 0.5]
    np.testing.assert_allclose(noise[:, :4].std(axis=0), expected_std, rtol=0.02)
    assert np.all(np.abs(noise[:, :4].mean(axis=0)) < 0.05 * np.array(expected_std))
    assert np.array_equal(noise[:, 4], np.zeros(len(states)))                       # the log-scale stays
    correlations = np.corrcoef(noise[:, :4], rowvar=False)
    np.testing.assert_allclose(correlations, np.eye(4), atol=0.02)


def test_propagation_is_reproducible_from_the_seed():
    model = ConstantVelocity()
    states = random_states(50)
    first = model.propagate(states, np.random.default_rng(5))
    again = model.propagate(states, np.random.default_rng(5))
    other = model.propagate(states, np.random.default_rng(6))
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other)


def test_centres_are_clipped_to_the_image_and_velocities_kept():
    model = ConstantVelocity(MotionConfig(sigma_pos=50.0), bounds=(64, 48))
    states = random_states(5_000)
    states[:, [VX, VY]] = [[300.0, -300.0]]
    moved = model.propagate(states, np.random.default_rng(3))
    assert moved[:, CX].min() >= 0 and moved[:, CX].max() <= 63
    assert moved[:, CY].min() >= 0 and moved[:, CY].max() <= 47
    assert (moved[:, CX] == 63).any() and (moved[:, CY] == 0).any()
    assert np.isfinite(moved).all()


@pytest.mark.parametrize("shape", [(0, 5), (4, 4), (5,), (2, 5, 1)])
def test_propagate_rejects_bad_shapes(shape):
    with pytest.raises(ValueError, match="shape"):
        ConstantVelocity().propagate(np.zeros(shape), np.random.default_rng(0))


# -- initialisation -------------------------------------------------------------------------------


def test_initialise_spreads_centres_and_sets_the_rest_exactly():
    states = initialise((120.0, 45.0), 100_000, np.random.default_rng(8), sigma_pos=5.0,
                        velocity=(2.0, -1.0), log_scale=0.3)
    assert states.shape == (100_000, STATE_DIM)
    np.testing.assert_allclose(states[:, [CX, CY]].mean(axis=0), [120.0, 45.0], atol=0.1)
    np.testing.assert_allclose(states[:, [CX, CY]].std(axis=0), [5.0, 5.0], rtol=0.02)
    assert (states[:, VX] == 2.0).all() and (states[:, VY] == -1.0).all()
    assert (states[:, LOG_SCALE] == 0.3).all()


def test_initialise_defaults_and_zero_spread():
    states = initialise((10.0, 20.0), 3, np.random.default_rng(0), sigma_pos=0.0)
    assert states.tolist() == [[10.0, 20.0, 0.0, 0.0, 0.0]] * 3


def test_initialise_is_reproducible_from_the_seed():
    first = initialise((0.0, 0.0), 20, np.random.default_rng(1))
    assert np.array_equal(first, initialise((0.0, 0.0), 20, np.random.default_rng(1)))
    assert not np.array_equal(first, initialise((0.0, 0.0), 20, np.random.default_rng(2)))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"n": 0}, "n"),
        ({"n": 2.5}, "n"),
        ({"sigma_pos": -1.0}, "sigma_pos"),
        ({"box_centre": (math.nan, 0.0)}, "box_centre"),
        ({"box_centre": (1.0,)}, "box_centre"),
        ({"velocity": (0.0, math.inf)}, "velocity"),
        ({"log_scale": math.nan}, "log_scale"),
    ],
)
def test_initialise_rejects_bad_arguments(kwargs, field):
    arguments = {"box_centre": (0.0, 0.0), "n": 5, "rng": np.random.default_rng(0), **kwargs}
    with pytest.raises(ValueError, match=field):
        initialise(**arguments)


# -- log-weights and effective sample size --------------------------------------------------------


@given(st.lists(st.one_of(st.floats(-1e3, 1e3), st.just(-math.inf)), min_size=1, max_size=50)
       .filter(lambda values: max(values) > -math.inf))
def test_normalised_log_weights_sum_to_one_and_keep_ratios(values):
    normalised = normalise_log_weights(values)
    assert np.isclose(np.exp(normalised).sum(), 1.0)
    finite = np.isfinite(values)
    assert np.array_equal(np.isneginf(normalised), ~finite)
    shifts = normalised[finite] - np.asarray(values)[finite]
    assert np.allclose(shifts, shifts[0])


def test_normalising_huge_log_weights_does_not_overflow():
    normalised = normalise_log_weights([1e4, 1e4 + math.log(3.0)])
    np.testing.assert_allclose(np.exp(normalised), [0.25, 0.75])


@pytest.mark.parametrize(
    "values",
    [[-math.inf] * 4, [0.0, math.nan, 0.0, 0.0], [0.0, math.inf, 1.0, 2.0]],
    ids=["all -inf", "nan", "+inf"],
)
def test_degenerate_log_weights_become_uniform_with_a_warning(values):
    with pytest.warns(DegenerateWeightsWarning):
        normalised = normalise_log_weights(values)
    np.testing.assert_allclose(np.exp(normalised), 0.25)
    assert np.isfinite(normalised).all()


def test_normalising_does_not_modify_its_input():
    values = np.array([0.0, 1.0, -math.inf])
    normalise_log_weights(values)
    assert values.tolist() == [0.0, 1.0, -math.inf]


@pytest.mark.parametrize("shape", [(0,), (2, 2)])
def test_log_weights_must_be_a_non_empty_vector(shape):
    with pytest.raises(ValueError, match="log_weights"):
        normalise_log_weights(np.zeros(shape))


@pytest.mark.parametrize("n", [1, 2, 7, 100, 1000])
def test_ess_of_uniform_weights_is_n(n):
    assert effective_sample_size(np.full(n, -3.7)) == n


@pytest.mark.parametrize("n", [1, 2, 7, 100])
def test_ess_of_a_one_hot_weight_is_one(n):
    log_weights = np.full(n, -math.inf)
    log_weights[n // 2] = 0.0
    assert effective_sample_size(log_weights) == 1.0


@given(st.lists(st.floats(-20, 20), min_size=1, max_size=50))
def test_ess_is_the_inverse_sum_of_squared_weights(values):
    weights = np.exp(np.asarray(values) - max(values))
    weights /= weights.sum()
    ess = effective_sample_size(values)
    assert math.isclose(ess, 1.0 / np.sum(weights**2), rel_tol=1e-9)
    assert 1.0 - 1e-9 <= ess <= len(values) * (1 + 1e-9)


# -- resamplers -----------------------------------------------------------------------------------


def test_registry_and_lookup():
    assert RESAMPLERS == {"multinomial": multinomial, "systematic": systematic,
                          "stratified": stratified, "residual": residual}
    for name, function in RESAMPLERS.items():
        assert get_resampler(name) is function


def test_unknown_resampler_lists_the_known_names():
    with pytest.raises(ValueError, match="unknown resampler 'mcmc'") as error:
        get_resampler("mcmc")
    for name in RESAMPLERS:
        assert name in str(error.value)


@pytest.mark.parametrize("method", METHODS)
@given(weights=weight_vectors, n=st.one_of(st.none(), sizes), seed=seeds)
def test_resamplers_return_valid_indices(method, weights, n, seed):
    indices = RESAMPLERS[method](np.array(weights), np.random.default_rng(seed), n)
    expected_size = len(weights) if n is None else n
    assert indices.shape == (expected_size,)
    assert np.issubdtype(indices.dtype, np.integer)
    assert indices.min() >= 0 and indices.max() < len(weights)
    zero = np.flatnonzero(np.array(weights) == 0)
    assert not np.isin(indices, zero).any(), "a particle of weight zero was selected"


class ZeroUniforms:
    """A generator stand-in whose uniforms are all exactly 0, the edge of every cumulative interval."""

    def random(self, size=None):
        return 0.0 if size is None else np.zeros(size)


@pytest.mark.parametrize("method", METHODS)
def test_a_uniform_on_an_interval_edge_never_selects_a_zero_weight_particle(method):
    indices = RESAMPLERS[method](np.array([0.0, 0.0, 0.5, 0.0, 0.5]), ZeroUniforms(), 3)
    assert set(indices.tolist()) <= {2, 4}
    assert indices[0] == 2


@given(weights=weight_vectors, n=sizes, seed=seeds)
def test_systematic_copies_each_particle_floor_or_ceil_of_n_w(weights, n, seed):
    w = np.array(weights) / sum(weights)
    copies = counts(systematic(np.array(weights), np.random.default_rng(seed), n), len(w))
    assert (copies >= np.floor(n * w - TOLERANCE)).all()
    assert (copies <= np.ceil(n * w + TOLERANCE)).all()


@pytest.mark.parametrize("method", ["systematic", "stratified"])
@given(weights=weight_vectors, n=sizes, seed=seeds)
def test_cumulative_copies_are_within_one_of_n_times_the_cdf(method, weights, n, seed):
    w = np.array(weights) / sum(weights)
    copies = counts(RESAMPLERS[method](np.array(weights), np.random.default_rng(seed), n), len(w))
    assert np.all(np.abs(np.cumsum(copies) - n * np.cumsum(w)) < 1 + TOLERANCE)


@given(weights=weight_vectors, n=sizes, seed=seeds)
def test_stratified_copies_are_within_two_of_n_w(weights, n, seed):
    # A particle's interval can touch two strata it does not fill, so ±1 would be too strict here.
    w = np.array(weights) / sum(weights)
    copies = counts(stratified(np.array(weights), np.random.default_rng(seed), n), len(w))
    assert np.all(np.abs(copies - n * w) < 2 + TOLERANCE)


@given(weights=weight_vectors, n=sizes, seed=seeds)
def test_residual_keeps_at_least_floor_of_n_w_copies(weights, n, seed):
    w = np.array(weights) / sum(weights)
    copies = counts(residual(np.array(weights), np.random.default_rng(seed), n), len(w))
    floors = np.floor(n * w + TOLERANCE)
    remainder = n - int(np.floor(n * w).sum())
    assert (copies >= floors - 1).all()  # −1 only where n·w is an integer up to rounding
    assert (copies >= np.floor(n * w - TOLERANCE)).all()
    assert (copies <= floors + remainder).all()


def test_residual_is_deterministic_when_every_n_w_is_an_integer():
    weights = np.array([0.5, 0.25, 0.125, 0.125])
    for seed in range(5):
        indices = residual(weights, np.random.default_rng(seed), 8)
        assert indices.tolist() == [0, 0, 0, 0, 1, 1, 2, 3]


def test_multinomial_counts_match_the_weights_statistically():
    weights = np.array([0.05, 0.1, 0.15, 0.3, 0.4])
    n = 100_000
    copies = counts(multinomial(weights, np.random.default_rng(11), n), weights.size)
    # Standard deviation of each count is √(n·w·(1−w)) ≤ 160; allow six of them.
    assert np.all(np.abs(copies - n * weights) < 6 * np.sqrt(n * weights * (1 - weights)))


@pytest.mark.parametrize("method", METHODS)
def test_every_resampler_is_unbiased(method):
    weights = np.array([0.03, 0.17, 0.2, 0.0, 0.35, 0.25])
    n, repeats = 7, 4000
    total = np.zeros(weights.size)
    resampler = RESAMPLERS[method]
    for seed in range(repeats):
        total += counts(resampler(weights, np.random.default_rng(seed), n), weights.size)
    mean = total / repeats
    # Per-draw count variance is at most n·w(1−w) (multinomial); the mean over the repeats is far tighter.
    np.testing.assert_allclose(mean, n * weights, atol=6 * np.sqrt(n * 0.25 / repeats))


@pytest.mark.parametrize("method", METHODS)
def test_resampling_is_reproducible_from_the_seed(method):
    weights = np.random.default_rng(0).random(1000)
    resampler = RESAMPLERS[method]
    first = resampler(weights, np.random.default_rng(42))
    assert np.array_equal(first, resampler(weights, np.random.default_rng(42)))
    assert not np.array_equal(first, resampler(weights, np.random.default_rng(43)))


@pytest.mark.parametrize("method", METHODS)
def test_unnormalised_weights_are_divided_by_their_sum(method):
    weights = np.array([1.0, 3.0, 0.0, 4.0])
    indices = RESAMPLERS[method](weights * 1e300, np.random.default_rng(9), 16)
    again = RESAMPLERS[method](weights / 8, np.random.default_rng(9), 16)
    assert np.array_equal(indices, again)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    "weights",
    [[0.0, 0.0, 0.0, 0.0], [0.2, math.nan, 0.3, 0.5], [0.2, math.inf, 0.3, 0.5]],
    ids=["zero sum", "nan", "inf"],
)
def test_degenerate_weights_resample_uniformly_with_a_warning(method, weights):
    with pytest.warns(DegenerateWeightsWarning):
        indices = RESAMPLERS[method](np.array(weights), np.random.default_rng(4), 4000)
    copies = counts(indices, 4)
    np.testing.assert_allclose(copies, 1000, atol=6 * np.sqrt(4000 * 0.25 * 0.75))


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    ("weights", "n", "message"),
    [
        ([0.5, -0.1, 0.6], None, "non-negative"),
        ([0.5, -math.inf], None, "non-negative"),
        ([], None, "weights"),
        ([[0.5, 0.5]], None, "weights"),
        ([0.5, 0.5], 0, "n"),
        ([0.5, 0.5], 1.5, "n"),
    ],
)
def test_resamplers_reject_bad_input(method, weights, n, message):
    with pytest.raises(ValueError, match=message):
        RESAMPLERS[method](np.array(weights), np.random.default_rng(0), n)


# -- adaptive particle number ---------------------------------------------------------------------


@given(kappa=st.floats(0, 1), n_min=st.integers(1, 200), extra=st.integers(0, 200))
def test_adaptive_count_follows_the_formula(kappa, n_min, extra):
    n_max = n_min + extra
    count = adaptive_count(kappa, n_min, n_max)
    assert n_min <= count <= n_max
    assert count - n_min >= (n_max - n_min) * kappa - 1e-6
    assert count - n_min < (n_max - n_min) * kappa + 1


def test_adaptive_count_examples():
    assert adaptive_count(0.0, 20, 40) == 20
    assert adaptive_count(0.01, 20, 40) == 21
    assert adaptive_count(0.5, 20, 40) == 30
    assert adaptive_count(1.0, 20, 40) == 40
    assert adaptive_count(1.0 + 1e-12, 20, 40) == 40
    assert adaptive_count(0.07, 1, 101) == 8  # 100 × 0.07 rounds up to 7.000000000000001


@pytest.mark.parametrize(
    ("kappa", "n_min", "n_max", "field"),
    [(1.5, 20, 40, "kappa"), (-0.1, 20, 40, "kappa"), (math.nan, 20, 40, "kappa"),
     (0.5, 0, 40, "n_min"), (0.5, 30, 20, "n_max"), (0.5, 20, 40.0, "n_max")],
)
def test_adaptive_count_rejects_bad_arguments(kappa, n_min, n_max, field):
    with pytest.raises(ValueError, match=field):
        adaptive_count(kappa, n_min, n_max)


# -- particle sets --------------------------------------------------------------------------------


def test_a_new_set_has_uniform_weights():
    particles = ParticleSet(random_states(8))
    assert len(particles) == 8
    np.testing.assert_allclose(particles.weights(), 1 / 8)
    assert particles.ess() == 8.0


@given(st.lists(st.floats(-30, 30), min_size=1, max_size=30), seeds)
def test_estimate_is_the_weighted_mean(log_weights, seed):
    states = random_states(len(log_weights), seed % 1000)
    particles = ParticleSet(states, log_weights)
    weights = np.exp(np.asarray(log_weights) - max(log_weights))
    by_hand = np.array([sum(w * s[d] for w, s in zip(weights, states)) / sum(weights) for d in range(STATE_DIM)])
    np.testing.assert_allclose(particles.estimate(), by_hand, rtol=1e-9, atol=1e-9)


def test_estimate_by_hand_on_a_small_example():
    states = np.array([[0.0, 10.0, 1.0, 0.0, 0.0], [4.0, 2.0, -1.0, 2.0, math.log(2.0)]])
    particles = ParticleSet(states, np.log([3.0, 1.0]))
    np.testing.assert_allclose(particles.estimate(), [1.0, 8.0, 0.5, 0.5, math.log(2.0) / 4])


def test_the_arrays_are_private_read_only_copies():
    states = random_states(4)
    log_weights = np.zeros(4)
    particles = ParticleSet(states, log_weights)
    states[0, 0] = 1e6
    log_weights[0] = 50.0
    assert particles.states[0, 0] != 1e6
    np.testing.assert_allclose(particles.weights(), 0.25)
    with pytest.raises(ValueError):
        particles.states[0, 0] = 1.0
    with pytest.raises(ValueError):
        particles.log_weights[0] = 1.0


@pytest.mark.parametrize(
    ("states", "log_weights", "message"),
    [
        (np.zeros((3, 4)), None, "shape"),
        (np.zeros((0, 5)), None, "shape"),
        (np.zeros((3, 5)), np.zeros(2), "log_weights"),
        (np.full((3, 5), math.nan), None, "finite"),
    ],
)
def test_bad_particle_sets_raise(states, log_weights, message):
    with pytest.raises(ValueError, match=message):
        ParticleSet(states, log_weights)


def test_reweight_adds_log_likelihoods_and_renormalises():
    particles = ParticleSet(random_states(3), np.log([0.5, 0.25, 0.25]))
    reweighted = particles.reweight([0.0, math.log(2.0), -math.inf])
    np.testing.assert_allclose(reweighted.weights(), [0.5, 0.5, 0.0])
    assert reweighted.states is particles.states or np.array_equal(reweighted.states, particles.states)
    np.testing.assert_allclose(particles.weights(), [0.5, 0.25, 0.25])  # the original is unchanged


def test_reweight_checks_the_shape():
    with pytest.raises(ValueError, match="log_likelihood"):
        ParticleSet(random_states(3)).reweight(np.zeros(4))


def test_all_impossible_particles_give_a_finite_uniform_set():
    model = ConstantVelocity(MotionConfig(), bounds=(32, 32))
    states = random_states(50)
    states[:, [CX, CY]] += 1e4  # every particle far outside the image
    particles = ParticleSet(states).propagate(model, np.random.default_rng(0))
    with pytest.warns(DegenerateWeightsWarning):
        particles = particles.reweight(np.full(len(particles), -math.inf))
    np.testing.assert_allclose(particles.weights(), 1 / 50)
    assert np.isfinite(particles.estimate()).all()
    assert particles.ess() == 50.0
    resampled = particles.resample(np.random.default_rng(1), threshold=1.0)
    assert np.isfinite(resampled.states).all() and np.isfinite(resampled.log_weights).all()


def test_repeated_zero_likelihoods_never_produce_nan():
    rng = np.random.default_rng(12)
    particles = ParticleSet(initialise((16.0, 16.0), 30, rng))
    model = ConstantVelocity(bounds=(32, 32))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateWeightsWarning)
        for _ in range(20):
            particles = particles.propagate(model, rng)
            particles = particles.reweight(np.where(rng.random(len(particles)) < 0.5, -math.inf, -1e308))
            particles = particles.reweight(np.full(len(particles), -math.inf))
            particles = particles.resample(rng, threshold=1.0)
    assert np.isfinite(particles.states).all()
    assert np.isfinite(particles.estimate()).all()


def test_propagate_keeps_the_weights():
    particles = ParticleSet(random_states(4), np.log([0.1, 0.2, 0.3, 0.4]))
    moved = particles.propagate(ConstantVelocity(), np.random.default_rng(0))
    np.testing.assert_allclose(moved.weights(), [0.1, 0.2, 0.3, 0.4])
    assert not np.array_equal(moved.states, particles.states)


def test_take_copies_the_chosen_particles_with_uniform_weights():
    states = random_states(4)
    taken = ParticleSet(states, np.log([0.1, 0.2, 0.3, 0.4])).take(np.array([3, 3, 0]))
    assert np.array_equal(taken.states, states[[3, 3, 0]])
    np.testing.assert_allclose(taken.weights(), 1 / 3)
    with pytest.raises(ValueError, match="indices"):
        ParticleSet(states).take(np.array([True, False, True, False]))


def test_resampling_is_skipped_while_the_ess_is_high():
    particles = ParticleSet(random_states(10), np.log(np.arange(1.0, 11.0)))  # N_eff = 55² / 385 ≈ 7.86
    rng = np.random.default_rng(0)
    state_before = rng.bit_generator.state
    assert particles.resample(rng, threshold=0.5) is particles
    assert particles.resample(rng, threshold=0.78) is particles
    assert rng.bit_generator.state == state_before  # no random number was consumed
    resampled = particles.resample(rng, threshold=0.79)
    assert resampled is not particles and resampled.ess() == 10.0


def test_threshold_one_resamples_every_frame_even_with_uniform_weights():
    particles = ParticleSet(random_states(10))
    resampled = particles.resample(np.random.default_rng(0), threshold=1.0)
    assert resampled is not particles
    # Systematic resampling of equal weights keeps every particle once.
    assert sorted(map(tuple, resampled.states)) == sorted(map(tuple, particles.states))


@pytest.mark.parametrize("method", METHODS)
def test_resample_draws_from_the_weights(method):
    states = random_states(4)
    particles = ParticleSet(states, [-math.inf, 0.0, -math.inf, 0.0])
    resampled = particles.resample(np.random.default_rng(7), method=method, threshold=1.0)
    assert len(resampled) == 4
    rows = {tuple(row) for row in resampled.states}
    assert rows <= {tuple(states[1]), tuple(states[3])}
    np.testing.assert_allclose(resampled.weights(), 0.25)


@pytest.mark.parametrize("new_size", [3, 40])
def test_resampling_to_a_new_particle_count(new_size):
    particles = ParticleSet(random_states(10))
    rng = np.random.default_rng(0)
    # A new size forces resampling even when the ESS is perfect and the threshold is zero.
    resized = particles.resample(rng, threshold=0.0, n=new_size)
    assert len(resized) == new_size
    assert resized.ess() == new_size
    assert {tuple(row) for row in resized.states} <= {tuple(row) for row in particles.states}


def test_adaptive_particle_number_round_trip():
    rng = np.random.default_rng(21)
    particles = ParticleSet(initialise((50.0, 50.0), 40, rng))
    for kappa in (0.0, 0.6, 1.0, 0.25):
        size = adaptive_count(kappa, 20, 40)
        particles = particles.resample(rng, threshold=1.0, n=size)
        assert len(particles) == size


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"method": "bootstrap"}, "unknown resampler"), ({"threshold": 1.5}, "threshold"),
     ({"threshold": math.nan}, "threshold"), ({"n": 0}, "n")],
)
def test_resample_rejects_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        ParticleSet(random_states(5)).resample(np.random.default_rng(0), **kwargs)


def test_a_whole_filter_run_is_reproducible_from_its_seed():
    def run(seed: int) -> np.ndarray:
        rng = np.random.default_rng(seed)
        model = ConstantVelocity(bounds=(200, 100))
        particles = ParticleSet(initialise((40.0, 50.0), 60, rng, velocity=(3.0, 0.0)))
        estimates = []
        for frame in range(1, 11):
            particles = particles.propagate(model, rng)
            truth = np.array([40.0 + 3.0 * frame, 50.0])
            distance = np.linalg.norm(particles.states[:, [CX, CY]] - truth, axis=1)
            particles = particles.reweight(-0.5 * (distance / 8.0) ** 2)
            estimates.append(particles.estimate())
            particles = particles.resample(rng, threshold=1.0)
        return np.array(estimates)

    first = run(99)
    assert np.array_equal(first, run(99))
    assert not np.array_equal(first, run(100))
    # The filter follows the target it was given.
    np.testing.assert_allclose(first[-1, [CX, CY]], [70.0, 50.0], atol=5.0)


@pytest.mark.parametrize("value", [True, "fast", float("nan")])
def test_motion_settings_refuse_bools_text_and_nan(value):
    from belief_tracking.errors import TrackingError

    with pytest.raises(TrackingError, match="sigma_pos must be"):
        MotionConfig(sigma_pos=value)


def test_sets_made_by_the_operations_are_read_only_and_equal_to_checked_ones():
    rng = np.random.default_rng(21)
    particles = ParticleSet(random_states(6), rng.normal(size=6))
    likelihood = rng.normal(size=6)
    made = {
        "reweight": (particles.reweight(likelihood), ParticleSet(particles.states, particles.log_weights + likelihood)),
        "take": (particles.take(np.array([5, 0, 0, 2])), ParticleSet(particles.states[[5, 0, 0, 2]])),
    }
    for name, (fast, checked) in made.items():
        assert np.array_equal(fast.states, checked.states), name
        assert np.array_equal(fast.log_weights, checked.log_weights), name
        for array in (fast.states, fast.log_weights):
            with pytest.raises(ValueError):
                array[0] = 0.0
    # A reweighted set shares the read-only states of its source instead of copying them.
    assert made["reweight"][0].states is particles.states
    assert not np.shares_memory(made["take"][0].states, particles.states)


def test_reweight_with_nan_or_infinite_likelihoods_falls_back_to_uniform():
    particles = ParticleSet(random_states(3), np.log([0.2, 0.3, 0.5]))
    for bad in ([0.0, math.nan, 0.0], [0.0, math.inf, 0.0]):
        with pytest.warns(DegenerateWeightsWarning, match="NaN or \\+inf"):
            reweighted = particles.reweight(bad)
        np.testing.assert_allclose(reweighted.weights(), 1 / 3)
