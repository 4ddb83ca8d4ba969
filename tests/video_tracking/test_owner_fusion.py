"""Closed-form owner measures against the general combination (SPEC A.4, A.5, Part D; W (32)–(34))."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import plugins.video_tracking.fusion as fusion_module
from belief import MassBatch, Model, TotalConflictError, combine
from belief.rules import inconsistency
from plugins.video_tracking.fusion import CueFusion, FusionConfig
from plugins.video_tracking.owner_fusion import first_inconsistency, owner_measures, supports

MEASURES = ("bel", "pls", "betp", "singleton_mass", "intersection_mass", "empty_mass")
#: (rule, r_mode, empty_mode) of every supported option.
OPTIONS = ([("r_rule", r_mode, empty_mode) for r_mode in ("paper", "euclid", "jousselme")
            for empty_mode in ("union", "empty")]
           + [("dsmc", "paper", "union"), ("conjunctive", "paper", "union"), ("dempster", "paper", "union")])


def reference(masses, owner, rule, r_mode="paper", empty_mode="union"):
    """The measures of θ_owner read off the general combination of the cue batches."""
    tau = masses[0].shape[1] - 1
    model = Model.for_targets(tau)
    focal = model.frame.singletons
    batches = [MassBatch._trusted(model, focal, m, canonical=True) for m in masses]
    options = {"r_mode": r_mode, "empty_mode": empty_mode} if rule == "r_rule" else {}
    fused = batches[0] if len(batches) == 1 else combine(*batches, rule=rule, **options)
    rows, targets = np.arange(owner.size), list(focal[:tau])
    out = {"bel": fused.bel(targets)[rows, owner], "pls": fused.pls(targets)[rows, owner],
           "empty_mass": fused.empty_mass}
    try:
        out["betp"] = fused.betp(targets)[rows, owner]
    except TotalConflictError:
        out["betp"] = None
    singleton = np.zeros(owner.size)
    intersection = np.zeros(owner.size)
    for column, element in enumerate(fused.focal):
        if len(element.terms) != 1 or element.terms[0] >> tau & 1:
            continue
        term = element.terms[0]
        inside = np.array([bool(term >> j & 1) for j in owner])
        if term.bit_count() == 1:
            singleton += np.where(inside, fused.values[:, column], 0.0)
        else:
            intersection += np.where(inside, fused.values[:, column], 0.0)
    out["singleton_mass"], out["intersection_mass"] = singleton, intersection
    return out


def fused_measures(masses, owner, rule, r_mode="paper", empty_mode="union", weight="bel"):
    """CueFusion on these cue masses (as log-likelihoods read literally), weight and measures."""
    tau = masses[0].shape[1] - 1
    config = FusionConfig(rule=rule, weight=weight, r_mode=r_mode, empty_mode=empty_mode, masses="normalised")
    fusion = CueFusion(tau, config)
    with np.errstate(divide="ignore"):
        scores = [np.log(m) for m in masses]
    exact = fusion.cue_masses(scores, owner)          # the masses the fusion actually combines
    return fusion.fuse(scores, owner), exact


def assert_close(got, want, name):
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12, err_msg=name)


def sparse_masses(rng, rows, tau, zeros):
    """Bayesian rows with exact zeros, some rows all on FA and some all on one target."""
    m = rng.dirichlet(np.full(tau + 1, 0.7), size=rows)
    m[rng.random(m.shape) < zeros] = 0.0
    kind = rng.integers(0, 6, size=rows)
    m[kind == 0] = np.eye(tau + 1)[tau]
    m[kind == 1] = np.eye(tau + 1)[rng.integers(0, tau, size=rows)][kind == 1]
    m[m.sum(axis=1) == 0, tau] = 1.0
    return m / m.sum(axis=1, keepdims=True)


def check_case(masses, owner, rule, r_mode, empty_mode):
    _, exact = fused_measures(masses, owner, rule, r_mode, empty_mode)
    for m, e in zip(masses, exact):
        np.testing.assert_allclose(e, m, atol=1e-15)
    want = reference(exact, owner, rule, r_mode, empty_mode)
    for weight in ("bel", "pls", "betp"):
        if weight == "betp" and want["betp"] is None:
            with pytest.raises(TotalConflictError):
                fused_measures(masses, owner, rule, r_mode, empty_mode, weight)
            continue
        result, _ = fused_measures(masses, owner, rule, r_mode, empty_mode, weight)
        if weight == "betp":
            # BetP divides by 1 − m(∅): near total conflict that division magnifies the
            # rounding of either path by 1 / (1 − m(∅)), so the tolerance scales with it.
            scale = 1.0 / np.maximum(1.0 - np.asarray(want["empty_mass"]), 1e-300)
            assert np.all(np.abs(result.weights - want[weight]) <= 1e-12 * scale), weight
        else:
            assert_close(result.weights, want[weight], weight)
        assert_close(result.bel, want["bel"], "bel")
        for name in ("singleton_mass", "intersection_mass", "empty_mass"):
            assert_close(getattr(result, name), want[name], name)


# -- the property: closed forms = general combination ----------------------------------------------------------
@settings(max_examples=120, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), tau=st.integers(1, 5), cues=st.integers(1, 4),
       option=st.sampled_from(OPTIONS), zeros=st.sampled_from([0.0, 0.0, 0.3, 0.7]))
def test_fast_path_equals_the_general_combination(seed, tau, cues, option, zeros):
    rule, r_mode, empty_mode = option
    rng = np.random.default_rng(seed)
    rows = 9
    masses = [sparse_masses(rng, rows, tau, zeros) if zeros else rng.dirichlet(np.ones(tau + 1), size=rows)
              for _ in range(cues)]
    owner = rng.integers(0, tau, size=rows)
    try:
        reference(masses, owner, rule, r_mode, empty_mode)
    except TotalConflictError:
        with pytest.raises(TotalConflictError):
            fused_measures(masses, owner, rule, r_mode, empty_mode)
        return
    check_case(masses, owner, rule, r_mode, empty_mode)


@pytest.mark.parametrize("rule, r_mode, empty_mode", OPTIONS)
@pytest.mark.parametrize("tau", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("cues", [1, 2, 3, 4])
def test_every_option_on_dense_cues(rule, r_mode, empty_mode, tau, cues):
    rng = np.random.default_rng(1000 * tau + 10 * cues + OPTIONS.index((rule, r_mode, empty_mode)))
    masses = [rng.dirichlet(np.ones(tau + 1), size=12) for _ in range(cues)]
    owner = rng.integers(0, tau, size=12)
    check_case(masses, owner, rule, r_mode, empty_mode)


# -- edge cases -------------------------------------------------------------------------------------------------
def edge_cues(tau):
    rows = []
    eye = np.eye(tau + 1)
    rows.append([eye[tau], eye[0], np.full(tau + 1, 1.0 / (tau + 1))])                  # a cue all on FA first
    rows.append([eye[0], np.r_[np.zeros(tau), 1.0], eye[0]])                             # FA between two agreeing cues
    rows.append([np.full(tau + 1, 1.0 / (tau + 1))] * 3)                                  # identical cues, R = 0
    m = np.r_[np.arange(1.0, tau + 1), 0.0]
    rows.append([m / m.sum(), m[::-1] / m.sum(), eye[tau]])                                # no FA, then all FA
    half = np.r_[np.zeros(tau), 1.0] * 0.5 + np.r_[1.0, np.zeros(tau)] * 0.5
    rows.append([half, eye[-1], eye[0]])
    return [np.array([r[k] for r in rows]) for k in range(3)]


@pytest.mark.parametrize("rule, r_mode, empty_mode", OPTIONS)
@pytest.mark.parametrize("tau", [1, 2, 3, 4])
def test_edge_cases(rule, r_mode, empty_mode, tau):
    # Zero masses, a cue all on FA, identical cues, one target: totally conflicting rows raise as
    # the general path does (Dempster's rule; BetP with m(∅) = 1).
    masses = edge_cues(tau)
    rows = masses[0].shape[0]
    for owner in (np.zeros(rows, dtype=np.int64), np.full(rows, tau - 1)):
        for cues in (2, 3):
            try:
                reference(masses[:cues], owner, rule, r_mode, empty_mode)
            except TotalConflictError:
                with pytest.raises(TotalConflictError):
                    fused_measures(masses[:cues], owner, rule, r_mode, empty_mode)
                continue
            check_case(masses[:cues], owner, rule, r_mode, empty_mode)


def test_blocks_of_the_pairwise_pass_do_not_matter(monkeypatch):
    # The O(τ²) pass runs over blocks of rows; a block of one or two rows gives the same result.
    import plugins.video_tracking.owner_fusion as owner_fusion

    rng = np.random.default_rng(21)
    tau = 4
    masses = [sparse_masses(rng, 25, tau, 0.4) for _ in range(3)]
    owner = rng.integers(0, tau, size=25)
    before = owner_measures(masses, owner, "r_rule", betp=True)
    monkeypatch.setattr(owner_fusion, "BLOCK_ENTRIES", 2 * tau * tau)
    after = owner_measures(masses, owner, "r_rule", betp=True)
    for name in ("bel", "pls", "betp", "singleton", "intersection", "empty"):
        np.testing.assert_array_equal(getattr(before, name), getattr(after, name))
    check_case(masses, owner, "r_rule", "paper", "union")


def test_rows_without_a_closed_form_are_combined_in_general():
    # No FA mass in the first two cues, so the third cue's FA meets θ1∩θ2 with m0(FA) = 0: SPEC A.4's
    # support fallback splits each θ_S/FA conflict by m(θ_S), which does not sum over the targets.
    first = np.array([[0.5, 0.3, 0.2, 0.0], [0.2, 0.3, 0.4, 0.1]])
    second = np.array([[0.1, 0.6, 0.3, 0.0], [0.3, 0.3, 0.3, 0.1]])
    third = np.array([[0.2, 0.2, 0.2, 0.4], [0.2, 0.2, 0.2, 0.4]])
    owner = np.array([0, 1])
    fast = owner_measures([first, second, third], owner, "r_rule")
    assert fast.general.tolist() == [True, False]
    check_case([first, second, third], owner, "r_rule", "paper", "union")


# -- examples from SPEC ------------------------------------------------------------------------------------------
def test_spec_a4_worked_example():
    # Bel(θ1) = .5149, Bel(θ2) = .6609, m(θ1∩θ2) = .3036, m(θ1) = .2113, m(θ2) = .3574, m(FA) = .0139.
    cues = [np.array([[0.6, 0.3, 0.1]] * 2), np.array([[0.2, 0.7, 0.1]] * 2)]
    m = owner_measures(cues, np.array([0, 1]), "r_rule", betp=True)
    np.testing.assert_allclose(m.bel, [0.5149, 0.6609], atol=5e-5)
    np.testing.assert_allclose(m.singleton, [0.2113, 0.3574], atol=5e-5)
    np.testing.assert_allclose(m.intersection, [0.48 * math.sqrt(0.4)] * 2, atol=1e-12)
    np.testing.assert_allclose(m.pls, [1 - 0.0139] * 2, atol=5e-5)


def test_spec_part_d_table_rule():
    # Bel = (.52, .44, .23) and Pls = .72 for two cues; with the third cue m(∅) = .35.
    loc = np.array([[0.5, 0.2, 0.2, 0.1]] * 3)
    col = np.array([[0.3, 0.4, 0.1, 0.2]] * 3)
    third = np.array([[0.4, 0.3, 0.2, 0.1]] * 3)
    owner = np.array([0, 1, 2])
    two = owner_measures([loc, col], owner, "dsmc")
    np.testing.assert_allclose(two.bel, [0.52, 0.44, 0.23], atol=1e-12)
    np.testing.assert_allclose(two.pls, [0.72] * 3, atol=1e-12)
    np.testing.assert_allclose(two.empty, [0.26] * 3, atol=1e-12)
    np.testing.assert_allclose(owner_measures([loc, col, third], owner, "dsmc").empty, [0.35] * 3, atol=1e-12)


# -- the first fold's R -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("r_mode", ["paper", "euclid", "jousselme"])
@pytest.mark.parametrize("tau", [1, 2, 5])
def test_first_inconsistency_equals_the_library(r_mode, tau):
    rng = np.random.default_rng(tau)
    m1, m2 = (rng.dirichlet(np.ones(tau + 1), size=20) for _ in range(2))
    m1[:3] = np.eye(tau + 1)[tau]
    m2[:2] = m1[:2]
    model = Model.for_targets(tau)
    want = inconsistency(m1, m2, model.frame.singletons, model, r_mode)
    np.testing.assert_allclose(first_inconsistency(m1, m2, r_mode), want, rtol=0, atol=1e-12)
    result = CueFusion(tau, FusionConfig(r_mode=r_mode, masses="normalised")).fuse(
        [np.log(m1 + 1e-300), np.log(m2 + 1e-300)], np.zeros(20, dtype=np.int64))
    assert result.inconsistency.shape == (20,)


# -- laziness and the general path ---------------------------------------------------------------------------------
def test_fused_is_combined_only_when_read(monkeypatch):
    rng = np.random.default_rng(7)
    tau, rows = 5, 30
    scores = [np.log(rng.dirichlet(np.ones(tau + 1), size=rows)) for _ in range(3)]
    owner = rng.integers(0, tau, size=rows)
    calls = []
    real = fusion_module.combine
    monkeypatch.setattr(fusion_module, "combine", lambda *a, **k: calls.append(1) or real(*a, **k))
    result = CueFusion(tau, FusionConfig(masses="normalised")).fuse(scores, owner)
    for name in ("weights", "bel", "singleton_mass", "intersection_mass", "empty_mass", "inconsistency"):
        assert getattr(result, name).shape == (rows,)
    assert calls == []
    fused = result.fused
    assert calls == [1] and len(fused) == rows
    np.testing.assert_allclose(fused.bel(list(fused.frame.singletons[:tau]))[np.arange(rows), owner],
                               result.weights, atol=1e-12)


@pytest.mark.parametrize("rule, r_mode", [("pcr6", "paper"), ("dsmh", "paper"), ("yager", "paper"),
                                          ("r_rule", "euclid")])
def test_other_rules_use_the_general_combination(rule, r_mode):
    # No closed form: PCR6, DSmH, Yager; the Euclidean R beyond three cues.
    rng = np.random.default_rng(11)
    tau, cues = 3, 4
    assert not supports(rule, cues, r_mode)
    masses = [rng.dirichlet(np.ones(tau + 1), size=6) for _ in range(cues)]
    owner = rng.integers(0, tau, size=6)
    result, _ = fused_measures(masses, owner, rule, r_mode)
    want = reference(masses, owner, rule, r_mode)
    for name in ("bel", "singleton_mass", "intersection_mass", "empty_mass"):
        assert_close(getattr(result, name), want[name], name)


def test_many_targets_stay_cheap():
    # τ = 40 has 2^40 target regions; the closed forms never enumerate them.
    rng = np.random.default_rng(5)
    tau, rows = 40, 200
    masses = [rng.dirichlet(np.ones(tau + 1), size=rows) for _ in range(3)]
    owner = rng.integers(0, tau, size=rows)
    m = owner_measures(masses, owner, "r_rule", betp=True)
    assert not m.general.any()
    assert np.all((m.bel >= 0) & (m.bel <= m.pls + 1e-12) & (m.pls <= 1 + 1e-12))
    assert np.all(m.betp >= m.bel - 1e-12) and np.all(m.betp <= m.pls + 1e-12)
