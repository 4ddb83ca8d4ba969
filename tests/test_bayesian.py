"""Closed forms for Bayesian sources (belief.bayesian) against the general combination.

Every test compares ``combine(..., engine="auto")``, which takes the closed forms where they
apply, with ``engine="general"``, which builds every focal element from the compiled plan:
the measures of singletons (with and without ``select=``), m(∅), the lazily materialised
values and the exceptions must agree (SPEC A.3, A.4, A.5, Part D).
"""

import math
import pickle
from dataclasses import replace
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import event, given, settings, target
from hypothesis import strategies as st

import belief.bayesian_fold as fold_module
import belief.rules as rules_module
from belief import (
    ENGINES,
    ClosedFormBatch,
    Frame,
    InvalidMassError,
    MassBatch,
    MassFunction,
    Model,
    ModelError,
    TotalConflictError,
    combine,
    exclusive_split,
    inconsistency,
)

MEASURES = ("bel", "pls", "mass", "betp")
R_OPTIONS = [{"r_mode": r, "empty_mode": e} for r in ("paper", "euclid", "jousselme") for e in ("union", "empty")]
RULE_OPTIONS = ([(rule, {}) for rule in ("conjunctive", "dsmc", "dempster", "yager", "pcr5", "pcr6")]
                + [("r_rule", options) for options in R_OPTIONS])

HYBRID = Model.hybrid(Frame(["a", "x", "b", "c", "y"]),
                      empty=["a&x", "b&x", "c&x", "x&y", "a&y", "b&y", "c&y"])      # E = {x, y}, O = {a, b, c}
HYBRID_ONE = Model.hybrid(Frame(["a", "x", "b", "c"]), empty=["a&x", "b&x", "c&x"])  # E = {x}, not last
MODELS = ([(f"tracking {tau}", Model.for_targets(tau)) for tau in range(1, 6)]
          + [(f"shafer {n}", Model.shafer(Frame.numbered(n))) for n in range(2, 6)]
          + [(f"free {n}", Model.free(Frame.numbered(n))) for n in range(2, 5)]
          + [("hybrid E={x,y}", HYBRID), ("hybrid E={x}", HYBRID_ONE)])


def covered(rule: str, options: dict, model: Model, sources: int) -> bool:
    """Where the closed forms must be taken (belief.bayesian's module notes)."""
    split = exclusive_split(model)
    if split is None:
        return False
    exclusive = len(split.exclusive)
    if rule in ("pcr5", "pcr6"):
        return sources == 2 or exclusive <= 1
    if rule == "r_rule":
        return exclusive <= 1 and (options.get("r_mode", "paper") == "paper" or sources <= 3)
    return True


# -- inputs --------------------------------------------------------------------------------------------
def dense(rng, rows, n):
    return rng.dirichlet(np.ones(n), size=rows)


def sparse(rng, rows, n):
    """Exact zeros, rows all on one hypothesis, rows all on the exclusive ones."""
    m = rng.dirichlet(np.full(n, 0.6), size=rows)
    m[rng.random(m.shape) < 0.4] = 0.0
    kind = rng.integers(0, 4, size=rows)
    m[kind == 0] = np.eye(n)[rng.integers(0, n, size=rows)][kind == 0]
    m[m.sum(axis=1) == 0, -1] = 1.0
    return m / m.sum(axis=1, keepdims=True)


def tiny(rng, rows, n):
    """Masses down to 1e-320 beside ordinary ones: products of two or three underflow or turn subnormal.

    Such masses come from likelihoods that underflow (a particle far from every target), and
    no closed form may divide by them or by a sum of them.
    """
    m = rng.dirichlet(np.ones(n), size=rows)
    small = rng.random(m.shape) < 0.5
    m[small] = 10.0 ** rng.uniform(-320, -150, size=int(small.sum()))
    return m / m.sum(axis=1, keepdims=True)


def peaked(rng, rows, n):
    """What a particle's cue gives many targets: a few ordinary masses, the rest 1e-320 to 1e-20 or exactly 0.

    The last column (FA in the tracking models) always keeps an ordinary mass.
    """
    m = 10.0 ** rng.uniform(-320, -20, size=(rows, n))
    m[rng.random(m.shape) < 0.3] = 0.0
    for row in m:
        row[rng.choice(n, size=int(rng.integers(1, 3)), replace=False)] = rng.random(1) + 0.1
    m[:, -1] = rng.uniform(0.05, 0.5, size=rows)
    return m / m.sum(axis=1, keepdims=True)


def near_conflict(rng, rows, model, sources):
    """Sources that (almost) never agree: 1 − ε on an exclusive hypothesis against 1 − ε on the others.

    ε is log-uniform down to 1e-16, and sometimes exactly 0, so that the conjunctive m(∅)
    lands anywhere in [1 − 1e-9, 1], 1 included.
    """
    split = exclusive_split(model)
    n = len(model.frame)
    free, excl = list(split.free), list(split.exclusive)
    out = []
    for k in range(sources):
        m = np.empty((rows, n))
        for r in range(rows):
            eps = 0.0 if rng.random() < 0.15 else 10.0 ** rng.uniform(-16, -9)
            side = np.zeros(n)
            on_exclusive = (k + r) % 2 == 0 and excl
            if on_exclusive:
                side[excl[(k // 2 + r) % len(excl)]] = 1.0
            else:
                side[free] = rng.dirichlet(np.ones(len(free)))
            m[r] = (1.0 - eps) * side + eps * rng.dirichlet(np.ones(n))
        out.append(m / m.sum(axis=1, keepdims=True))
    return out


def build(model, arrays, broadcast, rng=None):
    """Bayesian batches; with ``rng`` some take their columns in another order or drop a hypothesis."""
    batches = [MassBatch.bayesian(a, model=model) for a in arrays]
    if broadcast and len(arrays[0]) > 1:
        batches[0] = MassBatch.bayesian(arrays[0][0], model=model)       # one row, broadcast
    if rng is not None:
        names = [str(x) for x in model.frame.singletons]
        for k in range(len(batches)):
            kind = rng.integers(0, 4)
            values = batches[k].values
            if kind == 3:                                                 # column-major memory, trusted
                batches[k] = MassBatch.bayesian(np.asfortranarray(values), model=model, validate=False)
            elif kind == 1:                                                 # the same masses, columns shuffled
                order = rng.permutation(len(names))
                batches[k] = MassBatch([names[j] for j in order], values[:, order], model=model)
            elif kind == 2 and (values[:, -1] == 0).all():                # a hypothesis without mass left out
                batches[k] = MassBatch(names[:-1], values[:, :-1], model=model)
    return batches


# -- the comparison ------------------------------------------------------------------------------------
def outcome(call):
    try:
        return call(), None
    except (TotalConflictError, InvalidMassError, ModelError) as exc:
        return None, (type(exc), str(exc))


def assert_measures_agree(fast, general, queries, select, fresh=None):
    """Every measure of the queries, with and without select, to 1e-12 (BetP: relative to 1 − m(∅)).

    ``fresh`` is a second fused batch of the same sources that is read with ``select`` first,
    before any full table (the closed forms then compute the selected column only).
    """
    n = len(general)
    empty = general.empty_mass
    fresh = fast if fresh is None else fresh
    for kind in MEASURES:
        want, error = outcome(lambda: getattr(general, kind)(queries))
        chosen, chosen_error = outcome(lambda: getattr(fresh, kind)(queries, select=select))
        got, got_error = outcome(lambda: getattr(fast, kind)(queries))
        assert got_error == error and chosen_error == error, (kind, got_error, chosen_error, error)
        if error:
            assert outcome(lambda: getattr(fast, kind)(queries, select=select))[1] == error
            continue
        again, _ = outcome(lambda: getattr(fast, kind)(queries, select=select))
        np.testing.assert_allclose(again, chosen, rtol=1e-13, atol=1e-15, err_msg=kind)
        if kind == "betp":
            # BetP divides by Σ of the non-empty masses, 1 − m(∅).  Every mass is a sum of
            # products on both paths, so the quotient keeps 1e-12, except for the shares
            # (1 − R)·k of the R-weighted rule: the two paths round R differently (1e-16),
            # which the division magnifies by 1 / (1 − m(∅)) near total conflict.
            tol = 1e-12 + 1e-15 / np.maximum(1.0 - empty, 1e-300)
            assert np.all(np.abs(got - want) <= tol[:, None]), kind
            assert np.all(np.abs(chosen - want[np.arange(n), select]) <= tol), kind
        else:
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12, err_msg=kind)
            np.testing.assert_allclose(chosen, want[np.arange(n), select], rtol=0, atol=1e-12, err_msg=kind)
        assert got.shape == (n, len(queries)) and chosen.shape == (n,)
    np.testing.assert_allclose(fast.empty_mass, empty, rtol=0, atol=1e-12, err_msg="m(∅)")
    np.testing.assert_allclose(fresh.empty_mass, empty, rtol=0, atol=1e-12, err_msg="m(∅)")


def _non_empty_mass(batches) -> np.ndarray:
    conjunctive = combine(*batches, rule="conjunctive", engine="general")
    kept = [k for k, element in enumerate(conjunctive.focal) if not conjunctive.model.is_empty(element)]
    return conjunctive.values[:, kept].sum(axis=1)


def check(model, rule, options, arrays, broadcast, rng, shuffle=False):
    """Compare the two engines on these sources; return the conjunctive conflict of the inputs."""
    batches = build(model, arrays, broadcast, rng if shuffle else None)
    general, error = outcome(lambda: combine(*batches, rule=rule, engine="general", **options))
    fast, fast_error = outcome(lambda: combine(*batches, rule=rule, **options))
    assert fast_error == error
    # Dempster's rule on a non-empty mass below 2^-600 goes the general way, which rescales
    # the products that underflow; engine="bayesian" then declines.
    # The non-empty mass is summed from its own columns: 1 − m(∅) would round a tiny one to
    # 0 or to 1e-16.  A margin over 2^-600 keeps the rounding of either path out of the way.
    weak = rule == "dempster" and error is None and not (_non_empty_mass(batches) > 2.0 ** -590).all()
    if covered(rule, options, model, len(arrays)):
        if error is None:
            assert isinstance(fast, ClosedFormBatch) or weak
        bayesian_error = outcome(lambda: combine(*batches, rule=rule, engine="bayesian", **options))[1]
        assert bayesian_error == error or (weak and bayesian_error[0] is ModelError
                                           and "underflowing" in bayesian_error[1])
    else:
        assert error is not None or type(fast) is MassBatch
    if error is None:
        singletons = list(model.frame.singletons)
        queries = [singletons[i] for i in rng.permutation(len(singletons))]
        queries += [singletons[int(rng.integers(len(singletons)))]]            # a query twice
        select = rng.integers(0, len(queries), size=len(general))
        fresh = combine(*batches, rule=rule, **options)
        assert_measures_agree(fast, general, queries, select, fresh)
        assert len(fast) == len(general)
        # The lazily materialised batch is the general combination itself.
        assert fast.focal == general.focal
        np.testing.assert_array_equal(fast.values, general.values)
    return combine(*batches, rule="conjunctive").empty_mass


@st.composite
def cases(draw, kinds=("dense", "sparse", "conflict", "tiny", "peaked")):
    name, model = draw(st.sampled_from(MODELS))
    rule, options = draw(st.sampled_from(RULE_OPTIONS))
    sources = draw(st.integers(2, 4))
    rows = draw(st.integers(1, 7))
    kind = draw(st.sampled_from(kinds))
    seed = draw(st.integers(0, 2**32 - 1))
    broadcast = draw(st.booleans())
    return name, model, rule, options, sources, rows, kind, seed, broadcast


@settings(max_examples=150, deadline=None)
@given(case=cases(kinds=("dense", "sparse")))
def test_any_order_of_the_singleton_columns(case):
    # Batches whose focal elements are singletons in another order, or not all of them: the
    # closed forms read them in frame order block by block.
    name, model, rule, options, sources, rows, kind, seed, broadcast = case
    rng = np.random.default_rng(seed)
    check(model, rule, options, arrays_of(rng, model, sources, rows, kind), broadcast, rng, shuffle=True)


def arrays_of(rng, model, sources, rows, kind):
    n = len(model.frame)
    if kind == "conflict" and exclusive_split(model).exclusive:
        return near_conflict(rng, rows, model, sources)
    maker = {"dense": dense, "tiny": tiny, "peaked": peaked}.get(kind, sparse)
    return [maker(rng, rows, n) for _ in range(sources)]


@pytest.mark.filterwarnings("error::RuntimeWarning")
@settings(max_examples=300, deadline=None)
@given(case=cases())
def test_closed_forms_equal_the_general_combination(case):
    name, model, rule, options, sources, rows, kind, seed, broadcast = case
    rng = np.random.default_rng(seed)
    conflict = check(model, rule, options, arrays_of(rng, model, sources, rows, kind), broadcast, rng)
    target(float(conflict.max()), label="conjunctive m(∅)")
    if conflict.max() >= 1 - 1e-12:
        event("some row has m(∅) ≥ 1 − 1e-12")


@settings(max_examples=150, deadline=None)
@given(case=cases(kinds=("conflict",)))
def test_near_total_conflict(case):
    # One source 1 − ε on an exclusive hypothesis, another 1 − ε on the free ones, ε down to
    # 1e-16: the non-empty masses are tiny, and both paths must find the same ones (and the
    # same totally conflicting rows).
    name, model, rule, options, sources, rows, kind, seed, broadcast = case
    if not exclusive_split(model).exclusive:
        model = Model.for_targets(len(model.frame))
    rng = np.random.default_rng(seed)
    conflict = check(model, rule, options, near_conflict(rng, max(rows, 2), model, sources), False, rng)
    target(float(conflict.max()), label="conjunctive m(∅)")
    assert conflict.max() >= 1 - 1e-9                 # the strategy does what it says
    if conflict.max() >= 1 - 1e-12:
        event("some row has m(∅) ≥ 1 − 1e-12")


@pytest.mark.parametrize("name, model", MODELS, ids=[m[0] for m in MODELS])
@pytest.mark.parametrize("rule, options", RULE_OPTIONS,
                         ids=[f"{r}-{o.get('r_mode', '')}-{o.get('empty_mode', '')}" for r, o in RULE_OPTIONS])
def test_every_rule_on_every_model(name, model, rule, options):
    rng = np.random.default_rng(len(name) * 1000 + RULE_OPTIONS.index((rule, options)))
    for sources in (2, 3, 4):
        for maker in (dense, sparse):
            check(model, rule, options, [maker(rng, 6, len(model.frame)) for _ in range(sources)], sources == 3, rng)


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("rule, options", RULE_OPTIONS,
                         ids=[f"{r}-{o.get('r_mode', '')}-{o.get('empty_mode', '')}" for r, o in RULE_OPTIONS])
def test_masses_that_underflow_in_products(rule, options):
    # Cue masses of 1e-160 and below (likelihoods that underflow): pair weights of 1e-320 must
    # neither overflow a reciprocal nor turn into NaN, and both paths agree.
    rng = np.random.default_rng(RULE_OPTIONS.index((rule, options)))
    for tau in (2, 5, 9):
        model = Model.for_targets(tau)
        for sources in (2, 3):
            arrays = [tiny(rng, 40, tau + 1) for _ in range(sources)]
            check(model, rule, options, arrays, False, rng)


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("rule, options", [(r, o) for r, o in RULE_OPTIONS if r == "r_rule"],
                         ids=[f"{o['r_mode']}-{o['empty_mode']}" for r, o in RULE_OPTIONS if r == "r_rule"])
def test_many_targets_with_peaked_cues(rule, options):
    # The tracker's case: one cue spread over every target, the others peaked on one or two,
    # with exact zeros and masses down to 1e-320 elsewhere, for up to 24 targets.
    rng = np.random.default_rng(R_OPTIONS.index(options))
    sizes = ((6, 4), (13, 3), (24, 3)) if options["r_mode"] != "jousselme" else ((6, 3), (13, 2), (24, 2))
    for tau, most in sizes:            # Jousselme's R on the general path costs |focal|² per row
        model = Model.for_targets(tau)
        for sources in range(2, most + 1):
            arrays = [dense(rng, 12, tau + 1)] + [peaked(rng, 12, tau + 1) for _ in range(sources - 1)]
            check(model, rule, options, arrays, False, rng)


def _exact_pair_shares(s, p, w):
    """Σ_{l≠i} k_il w_i / (w_i + w_l), or σ_i / (σ_i + σ_l) where w_i + w_l = 0, in exact rationals."""
    o, n = s.shape
    out = np.zeros((o, n))
    for col in range(n):
        fs, fp, fw = ([Fraction(float(v)) for v in a[:, col]] for a in (s, p, w))
        for i in range(o):
            total = Fraction(0)
            for j in range(o):
                if j == i:
                    continue
                k = fs[i] * fp[j] + fs[j] * fp[i]
                if fw[i] + fw[j] > 0:
                    total += k * fw[i] / (fw[i] + fw[j])
                elif fs[i] + fp[i] + fs[j] + fp[j] > 0:
                    total += k * (fs[i] + fp[i]) / (fs[i] + fp[i] + fs[j] + fp[j])
            out[i, col] = float(total)
    return out


@st.composite
def pair_inputs(draw):
    """(s, p, w) of up to 10 targets and 5 rows: ordinary, tiny (to 1e-320) and zero masses and weights."""
    o, n = draw(st.integers(2, 10)), draw(st.integers(1, 5))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))

    def masses():
        scale = 10.0 ** rng.choice([0.0, -100.0, -200.0, -290.0, -305.0, -320.0], size=(o, n))
        values = rng.random((o, n)) * scale
        values[rng.random((o, n)) < draw(st.sampled_from([0.0, 0.3, 0.7]))] = 0.0
        return values

    s, p = masses(), masses()
    w = s * p if draw(st.booleans()) else (s + masses()) * p          # a fresh state, or one with unions
    return s, p, w


@settings(max_examples=200, deadline=None)
@given(inputs=pair_inputs())
def test_pair_shares_are_exact(inputs):
    # The one sum of the R-weighted fold that does not factorise, against exact rationals: the
    # pairs whose weights sum below the floor, or to 0 (SPEC A.4's fallback), included.
    s, p, w = inputs
    with np.errstate(divide="raise", over="raise", invalid="raise"):
        got = fold_module._pair_shares(s, p, w)
    want = _exact_pair_shares(s, p, w)
    # Relative to the value: products below 1e-300 lose digits to subnormal rounding on any path.
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-300)


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("r_mode, want_f", [("paper", 0.04027836789673436), ("euclid", 0.08600311862586871)])
def test_a_fallback_share_whose_product_underflows(r_mode, want_f):
    # SPEC A.4 fallback in the first fold: θ2 against FA has k = 1e-134 · 1e-83 and no m0
    # weight, so FA gets k · 1e-134 / 1e-83 = 1e-268, whose product k · 1e-134 underflows.
    # That m(FA) is the whole m0(FA) of the next fold, where m0(θ1) = 0.5 · 1e-268 is of the
    # same size: losing it hands θ1 a share of the conflict θ1 / FA that belongs to FA.
    # Exact values from the literal rule in rational arithmetic.
    model = Model.for_targets(4)
    arrays = [np.array([[0.5, 0.0, 0.0, 0.5, 1e-134]]),
              np.array([[0.45, 1e-83, 0.1, 0.45, 0.0]]),
              np.array([[1e-268, 0.0, 0.0, 0.5, 0.5]])]
    options = {"r_mode": r_mode, "empty_mode": "empty"}
    check(model, "r_rule", options, arrays, False, np.random.default_rng(0))
    fused = combine(*(MassBatch.bayesian(a, model=model) for a in arrays), rule="r_rule", **options)
    assert fused.mass(["FA"])[0, 0] == pytest.approx(want_f, rel=1e-12)


def test_the_conflict_strategy_reaches_total_conflict():
    # A counting check of the near-conflict inputs above: many rows reach m(∅) ≥ 1 − 1e-12.
    rng = np.random.default_rng(3)
    model = Model.for_targets(3)
    conflict = combine(*build(model, near_conflict(rng, 200, model, 2), False), rule="conjunctive").empty_mass
    assert (conflict >= 1 - 1e-12).sum() >= 60
    assert (conflict == 1.0).any() and ((conflict < 1.0) & (conflict >= 1 - 1e-15)).any()


# -- exact conflict: identical exceptions --------------------------------------------------------------
def test_dempster_total_conflict_raises_at_combine_time_on_both_paths():
    model = Model.for_targets(2)
    a = MassBatch.bayesian([[0.5, 0.5, 0.0], [0.0, 0.0, 1.0]], model=model)
    b = MassBatch.bayesian([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]], model=model)
    messages = set()
    for engine in ("auto", "general", "bayesian"):
        with pytest.raises(TotalConflictError) as info:
            combine(a, b, rule="dempster", engine=engine)
        messages.add(str(info.value))
    assert len(messages) == 1 and "(row 0)" in messages.pop()


@pytest.mark.parametrize("rule, options", [("dsmc", {}), ("conjunctive", {}), ("r_rule", {"empty_mode": "empty"})])
def test_betp_of_a_totally_conflicting_row_raises_on_both_paths(rule, options):
    model = Model.for_targets(2)
    eps = 1e-16
    a = MassBatch.bayesian([[0.5, 0.5, 0.0], [1 - eps, 0.0, eps], [0.2, 0.3, 0.5]], model=model)
    b = MassBatch.bayesian([[0.0, 0.0, 1.0], [0.0, eps, 1 - eps], [0.3, 0.3, 0.4]], model=model)
    fast = combine(a, b, rule=rule, **options)
    general = combine(a, b, rule=rule, engine="general", **options)
    assert isinstance(fast, ClosedFormBatch)
    np.testing.assert_array_equal(fast.empty_mass[:1], [1.0])
    assert 0 < 1 - fast.empty_mass[1] < 1e-15                   # row 1 keeps a sliver of non-empty mass
    errors = []
    for fused in (fast, general):
        with pytest.raises(TotalConflictError) as info:
            fused.betp(["t1", "t2", "FA"])
        errors.append(str(info.value))
        with pytest.raises(TotalConflictError):
            fused.betp(["t1", "t2"], select=[0, 1, 0])
    assert errors[0] == errors[1] == "BetP is undefined: total conflict, m(∅) = 1 (row 0)"
    # Without the totally conflicting row both find BetP, the sliver row included.
    rest_fast = combine(a, b, rule=rule, **options)
    np.testing.assert_allclose(fast.bel(["t1", "t2"]), general.bel(["t1", "t2"]), rtol=0, atol=1e-12)
    keep = [1, 2]
    a2, b2 = (MassBatch.bayesian(x.values[keep], model=model) for x in (a, b))
    got = combine(a2, b2, rule=rule, **options).betp(["t1", "t2", "FA"])
    want = combine(a2, b2, rule=rule, engine="general", **options).betp(["t1", "t2", "FA"])
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    assert rest_fast is not fast


def test_option_errors_are_the_same_on_both_paths():
    model = Model.for_targets(2)
    a = MassBatch.bayesian([0.6, 0.3, 0.1], model=model)
    b = MassBatch.bayesian([0.2, 0.7, 0.1], model=model)
    for options in ({"r_mode": "cosine"}, {"empty_mode": "void"}):
        errors = {outcome(lambda: combine(a, b, rule="r_rule", engine=e, **options))[1]
                  for e in ("auto", "general", "bayesian")}
        assert len(errors) == 1 and errors.pop()[0] is InvalidMassError
    with pytest.raises(InvalidMassError, match="takes no option"):
        combine(a, b, rule="dsmc", r_mode="paper")


# -- engine= and the detection -------------------------------------------------------------------------
def test_engine_names():
    assert ENGINES == ("auto", "general", "bayesian")
    model = Model.for_targets(2)
    a = MassBatch.bayesian([0.6, 0.3, 0.1], model=model)
    with pytest.raises(InvalidMassError, match="unknown engine 'closed'; known engines: auto, general, bayesian"):
        combine(a, a, engine="closed")
    assert type(combine(a, a, rule="dsmc", engine="general")) is MassBatch
    assert isinstance(combine(a, a, rule="dsmc"), ClosedFormBatch)
    assert isinstance(combine(a, a, rule="dsmc", engine="bayesian"), ClosedFormBatch)


def test_exclusive_split_recognises_the_class():
    assert exclusive_split(Model.for_targets(3)).free == (0, 1, 2)
    assert exclusive_split(Model.for_targets(3)).exclusive == (3,)
    assert exclusive_split(Model.free(Frame.numbered(3))).exclusive == ()
    assert exclusive_split(Model.shafer(Frame.numbered(3))).exclusive == (1, 2)
    assert exclusive_split(Model.for_targets(1)) == exclusive_split(Model.shafer(Frame(["t1", "FA"])))
    assert exclusive_split(HYBRID).free == (0, 2, 3) and exclusive_split(HYBRID).exclusive == (1, 4)
    assert exclusive_split(HYBRID_ONE).exclusive == (1,)
    frame = Frame(["a", "b", "c"])
    assert exclusive_split(Model.hybrid(frame, empty=["a&b"])) is None          # a excludes b but not c
    assert exclusive_split(Model.hybrid(frame, empty=["c"])) is None            # a hypothesis that cannot exist
    assert exclusive_split(Model.hybrid(frame, empty=["a&b&c"])) is None
    assert exclusive_split(Model.free(Frame(["a"]))) is None


@pytest.mark.parametrize("rule", ["dsmc", "pcr6", "r_rule"])
def test_what_the_closed_forms_do_not_take_goes_the_general_way(rule):
    frame = Frame(["a", "b", "c"])
    outside = Model.hybrid(frame, empty=["a&b"])
    cases = {
        "model outside the class": [MassBatch.bayesian([[0.2, 0.3, 0.5]] * 2, model=outside)] * 2,
        "non-Bayesian source": [MassBatch(["a", "a|b"], [[0.5, 0.5]] * 2, frame=frame),
                                MassBatch.bayesian([[0.2, 0.3, 0.5]] * 2, frame=frame)],
    }
    free = Model.free(frame)
    shafer = Model.shafer(frame)
    for reason, batches in cases.items():
        general = combine(*batches, rule=rule, engine="general")
        fast = combine(*batches, rule=rule)
        assert type(fast) is MassBatch, reason
        np.testing.assert_array_equal(fast.values, general.values)
        kind = InvalidMassError if reason == "non-Bayesian source" else ModelError
        with pytest.raises(kind, match="engine='bayesian' cannot fuse these sources"):
            combine(*batches, rule=rule, engine="bayesian")
    # Dynamic fusion: free sources fused under Shafer's model.
    sources = [MassBatch.bayesian([[0.2, 0.3, 0.5]], model=free)] * 2
    assert type(combine(*sources, rule=rule, model=shafer)) is MassBatch
    with pytest.raises(ModelError, match="dynamic fusion"):
        combine(*sources, rule=rule, model=shafer, engine="bayesian")


def test_rules_and_sizes_without_closed_forms():
    shafer = Model.shafer(Frame.numbered(3))
    tracking = Model.for_targets(3)
    three = [MassBatch.bayesian([[0.2, 0.3, 0.5]], model=shafer)] * 3
    assert type(combine(*three, rule="pcr6")) is MassBatch              # |E| = 2, three sources
    with pytest.raises(ModelError, match="at most one exclusive hypothesis"):
        combine(*three, rule="pcr6", engine="bayesian")
    assert isinstance(combine(*three[:2], rule="pcr6"), ClosedFormBatch)
    with pytest.raises(ModelError, match="at most one exclusive hypothesis"):
        combine(*three[:2], rule="r_rule", engine="bayesian")
    four = [MassBatch.bayesian([[0.2, 0.3, 0.1, 0.4]], model=tracking)] * 4
    assert type(combine(*four, rule="r_rule", r_mode="euclid")) is MassBatch
    assert isinstance(combine(*four, rule="r_rule"), ClosedFormBatch)
    with pytest.raises(ModelError, match="up to three sources"):
        combine(*four, rule="r_rule", r_mode="jousselme", engine="bayesian")
    for rule in ("dsmh", "dubois_prade", "disjunctive"):
        assert type(combine(*four[:2], rule=rule)) is MassBatch
        with pytest.raises(ModelError, match="has no closed form"):
            combine(*four[:2], rule=rule, engine="bayesian")


def test_subnormal_sources():
    # A source with an ∅ column: the conjunctive rules take it, the others refuse it as before.
    model = Model.for_targets(2)
    a = MassBatch(["empty", "t1", "t2", "FA"], [[0.1, 0.5, 0.3, 0.1], [0.0, 0.2, 0.2, 0.6]], model=model,
                  subnormal=True)
    b = MassBatch.bayesian([[0.3, 0.3, 0.4], [0.5, 0.4, 0.1]], model=model)
    rng = np.random.default_rng(0)
    for rule in ("conjunctive", "dsmc", "dempster"):
        fast, general = combine(a, b, rule=rule), combine(a, b, rule=rule, engine="general")
        assert isinstance(fast, ClosedFormBatch)
        assert_measures_agree(fast, general, ["t2", "FA", "t1"], rng.integers(0, 3, size=2))
    for rule in ("pcr6", "r_rule", "yager"):
        errors = {outcome(lambda: combine(a, b, rule=rule, engine=e))[1] for e in ("auto", "general")}
        assert len(errors) == 1 and errors.pop()[0] is InvalidMassError


def test_mass_functions_keep_the_general_path():
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m1 = MassFunction({"a": 0.9, "c": 0.1}, model=shafer)
    m2 = MassFunction({"b": 0.9, "c": 0.1}, model=shafer)
    for engine in ENGINES:
        fused = combine(m1, m2, rule="pcr6", engine=engine)
        assert isinstance(fused, MassFunction)
        assert fused.isclose(MassFunction({"a": 0.486, "b": 0.486, "c": 0.028}, model=shafer))
    with pytest.raises(ModelError, match="has no closed form"):
        combine(m1, m2, rule="dsmh", engine="bayesian")
    # A mass function broadcast against a batch: its focal elements are a subset of the singletons.
    batch = MassBatch.bayesian([[0.1, 0.2, 0.7], [0.6, 0.3, 0.1]], model=shafer)
    fast, general = combine(m1, batch, rule="pcr6"), combine(m1, batch, rule="pcr6", engine="general")
    assert isinstance(fast, ClosedFormBatch)
    assert_measures_agree(fast, general, ["a", "b", "c"], np.array([2, 0]))


# -- the lazy batch ------------------------------------------------------------------------------------
@pytest.fixture
def counted(monkeypatch):
    """Count the calls of the general rule functions."""
    calls = []
    for name, info in list(rules_module.RULES.items()):
        def function(*args, _f=info.function, _name=name, **kwargs):
            calls.append(_name)
            return _f(*args, **kwargs)
        monkeypatch.setitem(rules_module.RULES, name, replace(info, function=function))
    return calls


def test_values_are_combined_on_first_access_only(counted):
    model = Model.for_targets(3)
    rng = np.random.default_rng(4)
    cues = [MassBatch.bayesian(dense(rng, 20, 4), model=model) for _ in range(3)]
    owner = rng.integers(0, 3, size=20)
    targets = list(model.frame.singletons[:3])
    fused = combine(*cues, rule="r_rule")
    assert isinstance(fused, MassBatch) and isinstance(fused, ClosedFormBatch)
    for kind in MEASURES:
        getattr(fused, kind)(targets)
        getattr(fused, kind)(targets[::-1], select=owner)
        getattr(fused, kind)("t2")
    fused.empty_mass, fused.pignistic(), len(fused)
    assert counted == []
    general = combine(*cues, rule="r_rule", engine="general")
    assert counted == ["r_rule"]
    assert "9 focal elements" not in repr(fused)                # the repr combines, once
    assert repr(fused) == repr(general) and counted == ["r_rule", "r_rule"]
    np.testing.assert_array_equal(fused.values, general.values)
    assert fused[3] == general[3] and list(fused)[7] == general[7]
    fused.q(targets), fused.dsmp(targets), fused.bel("t1|t2"), fused.mass("t1&t2")
    assert counted == ["r_rule", "r_rule"]
    restored = pickle.loads(pickle.dumps(fused))
    assert type(restored) is MassBatch
    np.testing.assert_array_equal(restored.values, general.values)


def test_other_queries_read_the_materialised_batch(counted):
    model = Model.for_targets(3)
    rng = np.random.default_rng(8)
    cues = [MassBatch.bayesian(dense(rng, 6, 4), model=model) for _ in range(2)]
    fused = combine(*cues, rule="dsmc")
    general = combine(*cues, rule="dsmc", engine="general")
    assert counted == ["dsmc"]
    for query in (["t1&t2", "t1|FA"], "t1&t2&t3", ["t1", "t1|t2"]):
        np.testing.assert_allclose(fused.mass(query), general.mass(query), atol=1e-15)
        np.testing.assert_allclose(fused.bel(query), general.bel(query), atol=1e-15)
    np.testing.assert_allclose(fused.q(["t1"]), general.q(["t1"]), atol=1e-15)
    assert counted == ["dsmc", "dsmc"]


def test_one_fold_per_fused_batch(monkeypatch):
    # A tracker reads Bel, m(θ_J), Pls and m(∅) of one fused batch: the rule is folded once, in
    # one pass over the sources' rows (30 rows: one block).
    from belief.bayesian_blocks import Blocks

    made = []
    real = Blocks.block
    monkeypatch.setattr(Blocks, "block", lambda self, rows: made.append(1) or real(self, rows))
    model = Model.for_targets(4)
    rng = np.random.default_rng(2)
    cues = [MassBatch.bayesian(dense(rng, 30, 5), model=model) for _ in range(3)]
    owner = rng.integers(0, 4, size=30)
    targets = list(model.frame.singletons[:4])
    fused = combine(*cues, rule="r_rule")
    fused.bel(targets, select=owner)
    folds = len(made)
    assert folds == 1
    fused.mass(targets, select=owner.copy()), fused.pls(targets, select=owner), fused.empty_mass
    fused.betp(targets, select=owner)
    assert len(made) == folds


# -- select= --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("engine", ["auto", "general"])
def test_select_picks_one_query_per_row(engine):
    model = Model.for_targets(3)
    rng = np.random.default_rng(5)
    cues = [MassBatch.bayesian(dense(rng, 5, 4), model=model) for _ in range(2)]
    fused = combine(*cues, rule="pcr6", engine=engine)
    queries = ["FA", "t3", "t1"]
    select = np.array([0, 1, 2, 2, 1])
    for kind in MEASURES:
        full = getattr(fused, kind)(queries)
        np.testing.assert_array_equal(getattr(fused, kind)(queries, select=select), full[np.arange(5), select])
        np.testing.assert_array_equal(getattr(fused, kind)("t2", select=np.zeros(5, dtype=np.int32)),
                                      getattr(fused, kind)("t2"))
    for bad, message in ((select[:4], "shape"), (select + 0.0, "integer"), (select.astype(bool), "integer"),
                         (select + 1, "picks query 3 in row 2"), (-select, "picks query -1")):
        with pytest.raises(InvalidMassError, match=message):
            fused.bel(queries, select=bad)


def test_mass_of_every_batch():
    batch = MassBatch(["a", "a|b", "empty"], [[0.5, 0.3, 0.2], [0.1, 0.9, 0.0]], frame=["a", "b"], subnormal=True)
    np.testing.assert_array_equal(batch.mass(["a", "b", "a|b", "empty"]), [[0.5, 0, 0.3, 0.2], [0.1, 0, 0.9, 0]])
    np.testing.assert_array_equal(batch.mass("a|b"), [0.3, 0.9])
    shafer = MassBatch(["a", "b"], [[0.5, 0.5]], frame=["a", "b"], model="shafer")
    np.testing.assert_array_equal(shafer.mass(["a&b", "a"]), [[0.0, 0.5]])      # a∩b is ∅ under Shafer


# -- constructors and broadcasting ----------------------------------------------------------------------
def test_bayesian_constructor():
    model = Model.for_targets(2)
    batch = MassBatch.bayesian([0.6, 0.3, 0.1], model=model)
    assert batch.shape == (1, 3) and batch.focal == model.frame.singletons
    assert MassBatch.bayesian([[0.6, 0.3, 0.1]], model=model).focal is batch.focal          # cached
    default = MassBatch.bayesian([[0.5, 0.5]], frame=["a", "b"])
    assert default.model == Model.shafer(Frame(["a", "b"]))
    assert MassBatch.bayesian([[0.5, 0.5]], frame=["a", "b"], model="free").model == Model.free(Frame(["a", "b"]))
    with pytest.raises(InvalidMassError, match="shape"):
        MassBatch.bayesian([[0.5, 0.5]], model=model)
    with pytest.raises(InvalidMassError, match="sum to"):
        MassBatch.bayesian([[0.5, 0.4, 0.2]], model=model)
    with pytest.raises(InvalidMassError, match="negative"):
        MassBatch.bayesian([[1.1, -0.1, 0.0]], model=model)
    with pytest.raises(InvalidMassError, match="finite"):
        MassBatch.bayesian([[np.nan, 0.5, 0.5]], model=model)
    source = np.array([[0.6, 0.3, 0.1]])
    copied = MassBatch.bayesian(source, model=model)
    trusted = MassBatch.bayesian(source, model=model, validate=False)
    source[0, 0] = 0.0
    assert copied.values[0, 0] == 0.6 and trusted.values[0, 0] == 0.0      # no copy without validation
    assert source.flags.writeable and not trusted.values.flags.writeable
    gone = Model.hybrid(Frame(["a", "b", "c"]), empty=["c"])
    odd = MassBatch.bayesian([[0.5, 0.5, 0.0]], model=gone)
    assert odd.bel("a")[0] == 0.5


def test_one_row_batches_broadcast():
    model = Model.for_targets(3)
    rng = np.random.default_rng(6)
    single = MassBatch.bayesian(dense(rng, 1, 4), model=model)
    many = MassBatch.bayesian(dense(rng, 9, 4), model=model)
    for rule, options in RULE_OPTIONS:
        for sources in ([single, many, many], [many, single], [single, single]):
            fast = combine(*sources, rule=rule, **options)
            general = combine(*sources, rule=rule, engine="general", **options)
            assert isinstance(fast, ClosedFormBatch) and len(fast) == len(general)
            assert_measures_agree(fast, general, ["t1", "t2", "t3", "FA"], rng.integers(0, 4, size=len(general)))


# -- inconsistency -------------------------------------------------------------------------------------
@settings(max_examples=100, deadline=None)
@given(case=cases(kinds=("dense", "sparse")), r_mode=st.sampled_from(["paper", "euclid", "jousselme"]))
def test_inconsistency_closed_form(case, r_mode):
    name, model, _, _, _, rows, kind, seed, broadcast = case
    rng = np.random.default_rng(seed)
    a, b = build(model, arrays_of(rng, model, 2, rows, kind), broadcast)
    focal = model.frame.singletons
    want = inconsistency(np.broadcast_to(a.values, b.shape), b.values, focal, model, r_mode)
    np.testing.assert_allclose(inconsistency(a, b, r_mode=r_mode), want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(inconsistency(a, b, r_mode), want, rtol=0, atol=1e-12)


def test_inconsistency_of_general_batches():
    model = Model.for_targets(2)
    a = MassBatch.bayesian([0.6, 0.3, 0.1], model=model)
    b = MassBatch.bayesian([0.2, 0.7, 0.1], model=model)
    assert inconsistency(a, b).round(4).tolist() == [0.6325]                 # SPEC A.4
    assert inconsistency(a, b, r_mode="euclid").round(4).tolist() == [0.4]
    c = MassBatch(["t1", "t1|FA", "t1&t2"], [[0.5, 0.3, 0.2], [0.1, 0.1, 0.8]], model=model)
    focal = (model.frame.element("t1"), model.frame.element("t2"), model.frame.element("FA"),
             model.frame.element("t1&t2"), model.frame.element("t1|FA"))
    aligned_a = np.array([[0.6, 0.3, 0.1, 0.0, 0.0]] * 2)
    aligned_c = np.array([[0.5, 0.0, 0.0, 0.2, 0.3], [0.1, 0.0, 0.0, 0.8, 0.1]])
    for r_mode in ("paper", "euclid", "jousselme"):
        np.testing.assert_allclose(inconsistency(a, c, r_mode=r_mode),
                                   inconsistency(aligned_a, aligned_c, focal, model, r_mode), atol=1e-15)
    disjoint = MassBatch.bayesian([0.0, 0.0, 1.0], model=model)
    assert inconsistency(MassBatch.bayesian([0.6, 0.4, 0.0], model=model), disjoint).tolist() == [1.0]
    with pytest.raises(InvalidMassError, match="r_mode"):
        inconsistency(a, b, r_mode="cosine")
    with pytest.raises(InvalidMassError, match="focal elements and the model"):
        inconsistency(a.values, b.values)


# -- literature values -----------------------------------------------------------------------------------
def test_spec_a4_worked_example():
    model = Model.for_targets(2)
    location = MassBatch.bayesian([0.6, 0.3, 0.1], model=model)
    colour = MassBatch.bayesian([0.2, 0.7, 0.1], model=model)
    fused = combine(location, colour, rule="r_rule", engine="bayesian")
    bel, mass = fused.bel(["t1", "t2"])[0], fused.mass(["t1", "t2", "FA"])[0]
    np.testing.assert_allclose(bel, [0.5149, 0.6609], atol=5e-5)
    np.testing.assert_allclose(mass, [0.2113, 0.3574, 0.0139], atol=5e-5)
    np.testing.assert_allclose(bel - mass[:2], [0.48 * math.sqrt(0.4)] * 2, atol=1e-15)    # m(θ1∩θ2) = R·k
    assert round(fused.mass("t1&t2")[0], 4) == 0.3036


def test_spec_part_d_table_rule():
    model = Model.for_targets(3)
    loc = MassBatch.bayesian([0.5, 0.2, 0.2, 0.1], model=model)
    col = MassBatch.bayesian([0.3, 0.4, 0.1, 0.2], model=model)
    third = MassBatch.bayesian([0.4, 0.3, 0.2, 0.1], model=model)
    two = combine(loc, col, rule="dsmc", engine="bayesian")
    targets = ["t1", "t2", "t3"]
    np.testing.assert_allclose(two.bel(targets), [[0.52, 0.44, 0.23]], atol=1e-12)
    np.testing.assert_allclose(two.pls(targets), [[0.72] * 3], atol=1e-12)
    np.testing.assert_allclose(two.empty_mass, [0.26], atol=1e-12)
    three = combine(loc, col, third, rule="dsmc", engine="bayesian")
    np.testing.assert_allclose(three.empty_mass, [0.35], atol=1e-12)
    np.testing.assert_allclose(three.mass("t1&t2&t3"), [0.125], atol=1e-12)


@pytest.mark.parametrize("rule, expected", [("dempster", (0.0, 0.0, 1.0)), ("pcr6", (0.486, 0.486, 0.028)),
                                            ("pcr5", (0.486, 0.486, 0.028))])
def test_zadeh_example(rule, expected):
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m1 = MassBatch.bayesian([0.9, 0.0, 0.1], model=shafer)
    m2 = MassBatch.bayesian([0.0, 0.9, 0.1], model=shafer)
    fused = combine(m1, m2, rule=rule, engine="bayesian")
    for kind in MEASURES:                       # a Bayesian result: every measure is the mass
        np.testing.assert_allclose(getattr(fused, kind)(["a", "b", "c"]), [expected], atol=1e-12)


# -- laws -------------------------------------------------------------------------------------------------
@settings(max_examples=100, deadline=None)
@given(case=cases(kinds=("dense", "sparse")))
def test_pcr5_equals_pcr6_for_two_sources(case):
    name, model, _, _, _, rows, kind, seed, broadcast = case
    rng = np.random.default_rng(seed)
    batches = build(model, arrays_of(rng, model, 2, rows, kind), broadcast)
    queries = list(model.frame.singletons)
    for kind in MEASURES:
        np.testing.assert_allclose(getattr(combine(*batches, rule="pcr5"), kind)(queries),
                                   getattr(combine(*batches, rule="pcr6"), kind)(queries), rtol=0, atol=1e-15)


@settings(max_examples=150, deadline=None)
@given(case=cases())
def test_bel_betp_pls_are_ordered(case):
    # Bel(θ_j) ≤ BetP(θ_j) (1 − m(∅)) ≤ Pls(θ_j); on Shafer's model BetP is a probability over
    # the singletons (on the others θ_i ∩ θ_j counts for both, and the sum exceeds one).
    name, model, rule, options, sources, rows, kind, seed, broadcast = case
    rng = np.random.default_rng(seed)
    batches = build(model, arrays_of(rng, model, sources, rows, kind), broadcast)
    try:
        fused = combine(*batches, rule=rule, **options)
        queries = list(model.frame.singletons)
        betp = fused.betp(queries)
    except TotalConflictError:
        return
    kept = 1.0 - fused.empty_mass[:, None]
    bel, pls = fused.bel(queries), fused.pls(queries)
    assert np.all(bel <= betp * kept + 1e-12) and np.all(betp * kept <= pls + 1e-12)
    if len(exclusive_split(model).free) == 1:
        np.testing.assert_allclose(betp.sum(axis=1), 1.0, atol=1e-9)
        if rule in ("conjunctive", "dsmc", "dempster", "pcr5", "pcr6"):
            # On Shafer's model these rules give a Bayesian result: the closed-form masses sum to one.
            np.testing.assert_allclose(fused.mass(queries).sum(axis=1) + fused.empty_mass, 1.0, atol=1e-9)
    assert np.all(bel >= 0) and np.all(pls <= 1 + 1e-12)
    np.testing.assert_allclose(fused.values.sum(axis=1), 1.0, atol=1e-9)          # the materialised masses


def test_many_targets_stay_cheap(counted):
    # τ = 40: 2^40 regions and, for three R-weighted cues, O(τ³) focal elements; the closed
    # forms touch neither, and nothing is combined in general.
    tau, rows = 40, 50
    model = Model.for_targets(tau)
    rng = np.random.default_rng(9)
    cues = [MassBatch.bayesian(dense(rng, rows, tau + 1), model=model) for _ in range(3)]
    owner = rng.integers(0, tau, size=rows)
    targets = list(model.frame.singletons[:tau])
    for rule, options in [("r_rule", {}), ("r_rule", {"r_mode": "jousselme", "empty_mode": "empty"}),
                          ("dsmc", {}), ("pcr6", {}), ("pcr5", {}), ("dempster", {})]:
        fused = combine(*cues, rule=rule, **options)
        bel, pls = fused.bel(targets, select=owner), fused.pls(targets, select=owner)
        betp = fused.betp(targets, select=owner)
        kept = 1.0 - fused.empty_mass
        assert np.all(bel <= betp * kept + 1e-12) and np.all(betp * kept <= pls + 1e-12)
        every = fused.betp(list(model.frame.singletons))
        np.testing.assert_allclose(every[np.arange(rows), owner], betp, rtol=1e-12)
        assert fused.mass(targets, select=owner).shape == (rows,)
    assert counted == []
    assert inconsistency(cues[0], cues[1], r_mode="jousselme").shape == (rows,)
