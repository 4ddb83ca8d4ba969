"""What the tracker reads of the fused cues, through belief's public API (SPEC A.4, A.5, Part D; W (32)–(34)).

The tracker fuses c Bayesian cue mass functions per particle under the tracking model and
reads, for a particle of target J, Bel(θ_J), Pls(θ_J), BetP(θ_J), m(θ_J), the mass of the
target intersections inside θ_J (W (34), Bel(θ_J) − m(θ_J)) and m(∅).  ``combine`` takes the
closed forms of Bayesian sources for these; here they are compared, owner by owner
(``select=``), with the general combination (``engine="general"``).
"""

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import event, given, settings, target
from hypothesis import strategies as st

from belief import RULES, ClosedFormBatch, MassBatch, Model, TotalConflictError, combine, inconsistency

MEASURES = ("bel", "pls", "betp", "singleton_mass", "intersection_mass", "empty_mass")
#: (rule, r_mode, empty_mode) of every option the tracker may use.
OPTIONS = ([("r_rule", r_mode, empty_mode) for r_mode in ("paper", "euclid", "jousselme")
            for empty_mode in ("union", "empty")]
           + [("dsmc", "paper", "union"), ("conjunctive", "paper", "union"), ("dempster", "paper", "union"),
              ("pcr6", "paper", "union")])
#: How close to total conflict the strategy's conflict rows come: 1 − m(∅) is about 2ε.
EPSILONS = (0.0, 1e-16, 1e-15, 1e-14, 1e-13, 3e-13)


def options_of(rule, r_mode, empty_mode):
    return {"r_mode": r_mode, "empty_mode": empty_mode} if rule == "r_rule" else {}


def cue_batches(masses):
    model = Model.for_targets(masses[0].shape[1] - 1)
    return [MassBatch.bayesian(m, model=model) for m in masses]


def owner_reading(fused, owner, tau):
    """The tracker's measures of θ_owner, read through select= (any batch)."""
    targets = [f"t{j + 1}" for j in range(tau)]
    out = {"bel": fused.bel(targets, select=owner), "pls": fused.pls(targets, select=owner),
           "singleton_mass": fused.mass(targets, select=owner), "empty_mass": fused.empty_mass}
    try:
        out["betp"] = fused.betp(targets, select=owner)
    except TotalConflictError as exc:
        out["betp"] = exc
    out["intersection_mass"] = out["bel"] - out["singleton_mass"]
    return out


def reference(masses, owner, rule, r_mode="paper", empty_mode="union"):
    """The same measures read off the general combination's focal elements, one by one."""
    tau = masses[0].shape[1] - 1
    model = Model.for_targets(tau)
    names = [str(x) for x in model.frame.singletons]
    batches = [MassBatch(names, m, model=model) for m in masses]
    fused = (batches[0] if len(batches) == 1
             else combine(*batches, rule=rule, engine="general", **options_of(rule, r_mode, empty_mode)))
    rows = np.arange(owner.size)
    targets = [f"t{j + 1}" for j in range(tau)]
    out = {"bel": fused.bel(targets)[rows, owner], "pls": fused.pls(targets)[rows, owner],
           "empty_mass": fused.empty_mass}
    try:
        out["betp"] = fused.betp(targets)[rows, owner]
    except TotalConflictError as exc:
        out["betp"] = exc
    singleton = np.zeros(owner.size)
    intersection = np.zeros(owner.size)
    for column, element in enumerate(fused.focal):
        if len(element.terms) != 1 or element.terms[0] >> tau & 1:
            continue                                        # unions, and elements holding FA
        term = element.terms[0]
        inside = np.array([bool(term >> j & 1) for j in owner])
        if term.bit_count() == 1:
            singleton += np.where(inside, fused.values[:, column], 0.0)
        else:
            intersection += np.where(inside, fused.values[:, column], 0.0)
    out["singleton_mass"], out["intersection_mass"] = singleton, intersection
    return out


def fast(masses, owner, rule, r_mode="paper", empty_mode="union"):
    batches = cue_batches(masses)
    if len(batches) == 1:
        return batches[0], owner_reading(batches[0], owner, masses[0].shape[1] - 1)
    fused = combine(*batches, rule=rule, **options_of(rule, r_mode, empty_mode))
    # Closed forms for every option, except R by "euclid" or "jousselme" beyond three cues.
    assert isinstance(fused, ClosedFormBatch) == (r_mode == "paper" or len(batches) <= 3)
    return fused, owner_reading(fused, owner, masses[0].shape[1] - 1)


def check_case(masses, owner, rule, r_mode="paper", empty_mode="union"):
    """Fast reading = general reading: errors alike, 1e-12 (BetP: relative to 1 − m(∅))."""
    try:
        want = reference(masses, owner, rule, r_mode, empty_mode)
    except TotalConflictError as exc:
        with pytest.raises(TotalConflictError) as info:
            fast(masses, owner, rule, r_mode, empty_mode)
        assert str(info.value) == str(exc)
        return None
    fused, got = fast(masses, owner, rule, r_mode, empty_mode)
    for name in MEASURES:
        if isinstance(want[name], Exception):
            assert isinstance(got[name], TotalConflictError) and str(got[name]) == str(want[name]), name
            continue
        assert not isinstance(got[name], Exception), (name, got[name])
        if name == "betp":
            # BetP divides by 1 − m(∅), which magnifies the rounding of R in (1 − R)·k near total conflict.
            tol = 1e-12 + 1e-15 / np.maximum(1.0 - want["empty_mass"], 1e-300)
            assert np.all(np.abs(got[name] - want[name]) <= tol), name
        else:
            np.testing.assert_allclose(got[name], want[name], rtol=0, atol=1e-12, err_msg=name)
    return fused


def sparse_masses(rng, rows, tau, zeros):
    """Bayesian rows with exact zeros, some rows all on FA and some all on one target."""
    m = rng.dirichlet(np.full(tau + 1, 0.7), size=rows)
    m[rng.random(m.shape) < zeros] = 0.0
    kind = rng.integers(0, 6, size=rows)
    m[kind == 0] = np.eye(tau + 1)[tau]
    m[kind == 1] = np.eye(tau + 1)[rng.integers(0, tau, size=rows)][kind == 1]
    m[m.sum(axis=1) == 0, tau] = 1.0
    return m / m.sum(axis=1, keepdims=True)


def conflict_rows(rng, tau, cues, epsilons):
    """One row per ε where the cues take turns: 1 − ε on FA, then 1 − ε on the targets.

    The conjunctive m(∅) of such a row is at least (1 − ε)², 1 − 6e-13 or closer, and exactly 1 for ε = 0.
    """
    out = []
    for k in range(cues):
        rows = []
        for r, eps in enumerate(epsilons):
            side = np.zeros(tau + 1)
            if (k + r) % 2 == 0:
                side[tau] = 1.0
            else:
                side[:tau] = rng.dirichlet(np.full(tau, 0.5))
            rows.append((1.0 - eps) * side + eps * rng.dirichlet(np.ones(tau + 1)))
        m = np.array(rows)
        out.append(m / m.sum(axis=1, keepdims=True))
    return out


def conjunctive_conflict(masses):
    return combine(*cue_batches(masses), rule="conjunctive").empty_mass if len(masses) > 1 else np.zeros(1)


# -- the property: closed forms = general combination ----------------------------------------------------------
@settings(max_examples=120, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), tau=st.integers(1, 5), cues=st.integers(1, 4),
       option=st.sampled_from(OPTIONS), zeros=st.sampled_from([0.0, 0.0, 0.3, 0.7]),
       epsilons=st.lists(st.sampled_from(EPSILONS), min_size=1, max_size=3))
def test_fast_path_equals_the_general_combination(seed, tau, cues, option, zeros, epsilons):
    rule, r_mode, empty_mode = option
    rng = np.random.default_rng(seed)
    rows = 9
    masses = [sparse_masses(rng, rows, tau, zeros) if zeros else rng.dirichlet(np.ones(tau + 1), size=rows)
              for _ in range(cues)]
    # Every example also carries rows at (or a hair from) total conflict.
    masses = [np.vstack([m, c]) for m, c in zip(masses, conflict_rows(rng, tau, cues, epsilons))]
    owner = rng.integers(0, tau, size=rows + len(epsilons))
    fused = check_case(masses, owner, rule, r_mode, empty_mode)
    if cues > 1:
        conflict = conjunctive_conflict(masses)
        assert conflict[rows:].min() >= 1 - 1e-12            # the conflict rows are what they say
        kept = np.zeros(1) if fused is None else fused.empty_mass
        target(float(conflict.max()), label="conjunctive m(∅) of the cues")
        event("the cues reach m(∅) ≥ 1 − 1e-12")
        if kept.max() >= 1 - 1e-12:
            event("the fused batch keeps m(∅) ≥ 1 − 1e-12")


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
    # the general path does (Dempster's rule at combine time; BetP with m(∅) = 1 when read).
    masses = edge_cues(tau)
    rows = masses[0].shape[0]
    for owner in (np.zeros(rows, dtype=np.int64), np.full(rows, tau - 1)):
        for cues in (2, 3):
            check_case(masses[:cues], owner, rule, r_mode, empty_mode)


def test_a_row_does_not_depend_on_the_others():
    # The closed forms work in blocks of rows; a row gives the same values alone, in a small
    # batch and in a large one.
    rng = np.random.default_rng(21)
    tau = 4
    masses = [sparse_masses(rng, 300, tau, 0.4) for _ in range(3)]
    owner = rng.integers(0, tau, size=300)
    whole = fast(masses, owner, "r_rule", "paper", "empty")[1]
    for rows in (slice(0, 1), slice(7, 9), slice(100, 300)):
        part = fast([m[rows] for m in masses], owner[rows], "r_rule", "paper", "empty")[1]
        for name in ("bel", "pls", "singleton_mass", "intersection_mass", "empty_mass"):
            np.testing.assert_allclose(part[name], whole[name][rows], rtol=1e-13, atol=1e-16, err_msg=name)
    check_case(masses, owner, "r_rule", "paper", "empty")


def test_rows_without_a_closed_form_are_combined_in_general():
    # No FA mass in the first two cues, so the third cue's FA meets θ1∩θ2 with m0(FA) = 0: SPEC A.4's
    # support fallback splits each θ_S/FA conflict by m(θ_S), which does not sum over the targets;
    # belief combines that row in general, and the other one in closed form.
    first = np.array([[0.5, 0.3, 0.2, 0.0], [0.2, 0.3, 0.4, 0.1]])
    second = np.array([[0.1, 0.6, 0.3, 0.0], [0.3, 0.3, 0.3, 0.1]])
    third = np.array([[0.2, 0.2, 0.2, 0.4], [0.2, 0.2, 0.2, 0.4]])
    owner = np.array([0, 1])
    for empty_mode in ("union", "empty"):
        check_case([first, second, third], owner, "r_rule", "paper", empty_mode)


# -- examples from SPEC ------------------------------------------------------------------------------------------
def test_spec_a4_worked_example():
    # Bel(θ1) = .5149, Bel(θ2) = .6609, m(θ1∩θ2) = .3036, m(θ1) = .2113, m(θ2) = .3574, m(FA) = .0139.
    cues = [np.array([[0.6, 0.3, 0.1]] * 2), np.array([[0.2, 0.7, 0.1]] * 2)]
    fused, m = fast(cues, np.array([0, 1]), "r_rule")
    np.testing.assert_allclose(m["bel"], [0.5149, 0.6609], atol=5e-5)
    np.testing.assert_allclose(m["singleton_mass"], [0.2113, 0.3574], atol=5e-5)
    np.testing.assert_allclose(m["intersection_mass"], [0.48 * math.sqrt(0.4)] * 2, atol=1e-12)
    np.testing.assert_allclose(m["pls"], [1 - 0.0139] * 2, atol=5e-5)
    np.testing.assert_allclose(fused.mass("FA"), [0.0139] * 2, atol=5e-5)


def test_spec_part_d_table_rule():
    # Bel = (.52, .44, .23) and Pls = .72 for two cues; with the third cue m(∅) = .35.
    loc = np.array([[0.5, 0.2, 0.2, 0.1]] * 3)
    col = np.array([[0.3, 0.4, 0.1, 0.2]] * 3)
    third = np.array([[0.4, 0.3, 0.2, 0.1]] * 3)
    owner = np.array([0, 1, 2])
    two = fast([loc, col], owner, "dsmc")[1]
    np.testing.assert_allclose(two["bel"], [0.52, 0.44, 0.23], atol=1e-12)
    np.testing.assert_allclose(two["pls"], [0.72] * 3, atol=1e-12)
    np.testing.assert_allclose(two["empty_mass"], [0.26] * 3, atol=1e-12)
    np.testing.assert_allclose(fast([loc, col, third], owner, "dsmc")[1]["empty_mass"], [0.35] * 3, atol=1e-12)


# -- the first fold's R -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("r_mode", ["paper", "euclid", "jousselme"])
@pytest.mark.parametrize("tau", [1, 2, 5])
def test_first_inconsistency_equals_the_general_one(r_mode, tau):
    # Between Bayesian batches R costs O(τ) per row; written over a focal list that is not
    # Bayesian (one more element, with no mass), the same batches take the general computation.
    rng = np.random.default_rng(tau)
    m1, m2 = (rng.dirichlet(np.ones(tau + 1), size=20) for _ in range(2))
    m1[:3] = np.eye(tau + 1)[tau]
    m2[:2] = m1[:2]
    model = Model.for_targets(tau)
    names = [str(x) for x in model.frame.singletons] + ["t1|FA"]
    padded = [MassBatch(names, np.hstack([m, np.zeros((20, 1))]), model=model) for m in (m1, m2)]
    want = inconsistency(*padded, r_mode=r_mode)
    got = inconsistency(*cue_batches([m1, m2]), r_mode=r_mode)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert got[:2].tolist() == [0.0, 0.0] and got.shape == (20,)


# -- laziness and the general path ---------------------------------------------------------------------------------
def test_fused_is_combined_only_when_read(monkeypatch):
    calls = []
    info = RULES["r_rule"]
    counted = replace(info, function=lambda *a, **k: calls.append(1) or info.function(*a, **k))
    monkeypatch.setitem(RULES, "r_rule", counted)
    rng = np.random.default_rng(7)
    tau, rows = 5, 30
    masses = [rng.dirichlet(np.ones(tau + 1), size=rows) for _ in range(3)]
    owner = rng.integers(0, tau, size=rows)
    fused, reading = fast(masses, owner, "r_rule")
    for name in MEASURES:
        assert reading[name].shape == (rows,)
    assert calls == []
    general = combine(*cue_batches(masses), rule="r_rule", engine="general")
    assert calls == [1]
    np.testing.assert_array_equal(fused.values, general.values)
    assert len(fused) == rows and fused.focal == general.focal
    assert calls == [1, 1]
    np.testing.assert_allclose(fused.bel([f"t{j + 1}" for j in range(tau)])[np.arange(rows), owner],
                               reading["bel"], atol=1e-12)


@pytest.mark.parametrize("rule, r_mode", [("dsmh", "paper"), ("yager", "paper"), ("pcr5", "paper"),
                                          ("r_rule", "euclid")])
def test_other_rules_and_sizes(rule, r_mode):
    # DSmH has no closed form, the Euclidean R none beyond three cues: they combine in general;
    # Yager's rule and PCR5 have closed forms.  The readings are the same either way.
    rng = np.random.default_rng(11)
    tau, cues = 3, 4
    masses = [rng.dirichlet(np.ones(tau + 1), size=6) for _ in range(cues)]
    owner = rng.integers(0, tau, size=6)
    fused = combine(*cue_batches(masses), rule=rule, **options_of(rule, r_mode, "union"))
    assert isinstance(fused, ClosedFormBatch) == (rule in ("yager", "pcr5"))
    got = owner_reading(fused, owner, tau)
    want = reference(masses, owner, rule, r_mode)
    for name in ("bel", "pls", "betp", "singleton_mass", "intersection_mass", "empty_mass"):
        np.testing.assert_allclose(got[name], want[name], rtol=0, atol=1e-12, err_msg=name)


def test_many_targets_stay_cheap():
    # τ = 40 has 2^40 target regions; the closed forms never enumerate them.
    rng = np.random.default_rng(5)
    tau, rows = 40, 200
    masses = [rng.dirichlet(np.ones(tau + 1), size=rows) for _ in range(3)]
    owner = rng.integers(0, tau, size=rows)
    fused, m = fast(masses, owner, "r_rule")
    assert np.all((m["bel"] >= 0) & (m["bel"] <= m["pls"] + 1e-12) & (m["pls"] <= 1 + 1e-12))
    assert np.all(m["betp"] >= m["bel"] - 1e-12) and np.all(m["betp"] <= m["pls"] + 1e-12)
    assert np.all(m["intersection_mass"] >= -1e-15)
