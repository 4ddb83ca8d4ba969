"""Cue fusion for the tracker: cue masses, rules on particle batches, weights."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief_tracking.errors import TrackingError
from belief_tracking.fusion import CueFusion, FusionConfig, cue_masses


def bayesian_rows(rng, rows, size):
    return rng.dirichlet(np.ones(size), size=rows)


def test_cue_masses_are_normalised_likelihoods():
    rng = np.random.default_rng(1)
    p = rng.uniform(0.01, 5.0, size=(20, 4))
    np.testing.assert_allclose(cue_masses(np.log(p)), p / p.sum(axis=1, keepdims=True), rtol=1e-12)


def test_cue_masses_survive_underflow_and_zero_rows():
    # exp(-800) underflows to 0, yet the proportions are kept: this is why the softmax form is used (W (20)-(21)).
    rows = cue_masses(np.array([[-800.0, -800.0 - np.log(3.0), -np.inf], [-np.inf, -np.inf, -np.inf]]))
    np.testing.assert_allclose(rows[0], [0.75, 0.25, 0.0])
    np.testing.assert_allclose(rows[1], [1 / 3, 1 / 3, 1 / 3])
    assert np.isfinite(rows).all()


@pytest.mark.parametrize("bad", [np.array([[np.nan, 0.0]]), np.array([[np.inf, 0.0]]), np.zeros((3,))])
def test_cue_masses_reject_bad_input(bad):
    with pytest.raises(TrackingError):
        cue_masses(bad)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), targets=st.integers(1, 5), cues=st.integers(2, 4))
def test_table_rule_weights_match_the_closed_forms(seed, targets, cues):
    # SPEC Part D: for Bayesian cues under the tracking model, DSmC gives
    # Bel(θ_J) = P - Π_l (1 - m_l(FA) - m_l(θ_J)) and Pls(θ_J) = P for every J, with P = Π_l (1 - m_l(FA)).
    rng = np.random.default_rng(seed)
    rows = 7
    masses = [bayesian_rows(rng, rows, targets + 1) for _ in range(cues)]
    owner = rng.integers(0, targets, size=rows)
    scores = [np.log(m) for m in masses]
    fa = np.stack([m[:, -1] for m in masses])                          # (c, P)
    own = np.stack([m[np.arange(rows), owner] for m in masses])        # (c, P)
    p = np.prod(1 - fa, axis=0)
    bel = CueFusion(targets, FusionConfig(rule="dsmc", weight="bel", masses="normalised")).fuse(scores, owner)
    np.testing.assert_allclose(bel.weights, p - np.prod(1 - fa - own, axis=0), atol=1e-12)
    pls = CueFusion(targets, FusionConfig(rule="dsmc", weight="pls", masses="normalised")).fuse(scores, owner)
    np.testing.assert_allclose(pls.weights, p, atol=1e-12)
    np.testing.assert_allclose(bel.empty_mass, 1 - p - np.prod(fa, axis=0), atol=1e-12)


def test_two_targets_two_cues_give_w27_to_w32():
    # W (27)-(32) with location (.6, .3, .1) and colour (.2, .7, .1): Bel(θ1) = .12 + .48, Bel(θ2) = .21 + .48.
    fusion = CueFusion(2, FusionConfig(rule="dsmc", masses="normalised"))
    location = np.log([[0.6, 0.3, 0.1], [0.6, 0.3, 0.1]])
    colour = np.log([[0.2, 0.7, 0.1], [0.2, 0.7, 0.1]])
    result = fusion.fuse([location, colour], owner=np.array([0, 1]))
    np.testing.assert_allclose(result.weights, [0.60, 0.69])
    np.testing.assert_allclose(result.singleton_mass, [0.12, 0.21])
    np.testing.assert_allclose(result.intersection_mass, [0.48, 0.48])
    np.testing.assert_allclose(result.empty_mass, [0.18, 0.18])


def test_r_rule_matches_the_worked_example_of_spec_a4():
    # SPEC A.4: Bel(θ1) = .5149, Bel(θ2) = .6609, m(θ1∩θ2) = .3036.
    fusion = CueFusion(2, FusionConfig(masses="normalised"))
    location = np.log([[0.6, 0.3, 0.1]] * 2)
    colour = np.log([[0.2, 0.7, 0.1]] * 2)
    result = fusion.fuse([location, colour], owner=np.array([0, 1]))
    np.testing.assert_allclose(result.weights, [0.5149, 0.6609], atol=5e-5)
    np.testing.assert_allclose(result.intersection_mass, [0.3036, 0.3036], atol=5e-5)


def test_rules_agree_with_combining_rows_one_by_one():
    from belief import MassFunction, combine

    rng = np.random.default_rng(3)
    fusion = CueFusion(3, FusionConfig(rule="pcr6", weight="betp", masses="normalised"))
    masses = [bayesian_rows(rng, 5, 4) for _ in range(3)]
    owner = np.array([0, 1, 2, 0, 1])
    result = fusion.fuse([np.log(m) for m in masses], owner)
    names = list(fusion.model.frame.hypotheses)
    for row in range(5):
        singles = [MassFunction(dict(zip(names, m[row])), model=fusion.model) for m in masses]
        fused = combine(*singles, rule="pcr6")
        assert result.weights[row] == pytest.approx(fused.betp(fusion.targets[owner[row]]), abs=1e-12)


def test_a_single_cue_is_its_own_evidence():
    fusion = CueFusion(2, FusionConfig(masses="normalised"))
    result = fusion.fuse([np.log([[0.5, 0.3, 0.2]])], owner=np.array([1]))
    assert result.weights[0] == pytest.approx(0.3)


def test_configuration_errors_are_specific():
    with pytest.raises(TrackingError, match="known rules"):
        FusionConfig(rule="nope")
    with pytest.raises(TrackingError, match="FusionConfig.weight"):
        FusionConfig(weight="mean")
    with pytest.raises(TrackingError, match="FusionConfig.r_mode must be one of paper, euclid, jousselme"):
        FusionConfig(r_mode="manhattan")
    with pytest.raises(TrackingError, match="number of targets"):
        CueFusion(0)
    fusion = CueFusion(2, FusionConfig(masses="normalised"))
    with pytest.raises(TrackingError, match="shape"):
        fusion.fuse([np.zeros((3, 4))], owner=np.zeros(3, dtype=int))
    with pytest.raises(TrackingError, match="owners"):
        fusion.fuse([np.zeros((2, 3))], owner=np.array([0, 2]))
