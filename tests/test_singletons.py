"""The kernel of many single hypotheses (belief.singletons) and the sparse measure tables (belief.incidence)."""

from __future__ import annotations

import itertools
import pickle
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import belief.rules as rules
import belief.singletons as singletons
from belief import Frame, MassBatch, MassFunction, Model, TotalConflictError, UndefinedTransformError, combine
from belief.batch import measure_plan
from belief.decisions import decide
from belief.incidence import incidence
from belief.plan import weighted_sum

KERNEL_RULES = ("dempster", "conjunctive", "dsmc", "yager", "pcr5", "pcr6")


def literal(sources: list[MassFunction], rule: str) -> dict[int, Fraction]:
    """The rule by its definition over every tuple of focal elements, in exact arithmetic: {hypothesis mask: mass}.

    Shafer's model: a tuple of single hypotheses reaches θ_i when all are θ_i, and conflicts otherwise (SPEC A.3).
    """
    n = len(sources[0].frame)
    items = [[(x.terms[0] if x.terms else 0, Fraction(v)) for x, v in m.items()] for m in sources]
    out: dict[int, Fraction] = {}
    conflict = Fraction(0)
    for combo in itertools.product(*items):
        masks = {mask for mask, _ in combo}
        product = Fraction(1)
        for _, v in combo:
            product *= v
        if len(masks) == 1 and 0 not in masks:
            out[combo[0][0]] = out.get(combo[0][0], Fraction(0)) + product
            continue
        conflict += product
        if rule in ("pcr5", "pcr6"):                         # two sources: proportional to the two masses
            (x, a), (y, b) = combo
            out[x] = out.get(x, Fraction(0)) + a * product / (a + b)
            out[y] = out.get(y, Fraction(0)) + b * product / (a + b)
    if rule == "dempster":
        kept = sum(out.values(), Fraction(0))
        if kept == 0:
            raise ZeroDivisionError("total conflict")
        return {x: v / kept for x, v in out.items()}
    if rule == "yager":
        out[(1 << n) - 1] = out.get((1 << n) - 1, Fraction(0)) + conflict
    elif rule in ("conjunctive", "dsmc") and conflict:
        out[0] = conflict
    return out


def as_masks(m: MassFunction) -> dict[int, float]:
    out = {}
    for x, v in m.items():
        mask = 0
        for t in x.terms:
            mask |= t
        out[mask] = v
    return out


@pytest.fixture
def kernel_always(monkeypatch):
    """Send every pair of singleton sources to the kernel, however few their focal elements, and count the calls."""
    calls = []
    original = singletons.combine_singletons
    monkeypatch.setattr(singletons, "SINGLETON_KERNEL_TUPLES", 0)
    monkeypatch.setattr(rules, "combine_singletons", lambda *a: calls.append(a[0]) or original(*a))
    return calls


@st.composite
def bayesian_pairs(draw):
    n = draw(st.integers(1, 7))
    model = Model.shafer(Frame([f"h{i}" for i in range(n)]))
    tiny = st.sampled_from([1e-300, 1e-310, 5e-324, 1e-17, 1e-8])
    sources = []
    for _ in range(2):
        used = draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=n, unique=True))
        weights = [draw(st.one_of(st.integers(1, 20).map(float), tiny)) for _ in used]
        total = sum(weights)
        masses = {f"h{i}": w / total for i, w in zip(used, weights)}
        masses = {k: v for k, v in masses.items() if v > 0}
        if abs(sum(masses.values()) - 1) > 1e-9:
            masses[next(iter(masses))] += 1 - sum(masses.values())
        sources.append(MassFunction(masses, model=model))
    return sources


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(bayesian_pairs(), st.sampled_from(KERNEL_RULES))
def test_the_kernel_equals_the_literal_definition(kernel_always, sources, rule):
    try:
        want = literal(sources, rule)
    except ZeroDivisionError:                                  # exact total conflict
        with pytest.raises(TotalConflictError):
            combine(*sources, rule=rule)
        return
    got = as_masks(combine(*sources, rule=rule))
    assert kernel_always, "the kernel was not taken"       # the fixture only adds calls: any one is this case's
    for mask, value in want.items():
        exact = float(value)
        assert got.get(mask, 0.0) == pytest.approx(exact, rel=64 * 2.0 ** -53, abs=1e-300), (mask, rule)
    assert set(got) <= set(want)


@pytest.mark.parametrize("rule", KERNEL_RULES)
def test_the_kernel_is_taken_and_gives_the_plans_masses(rule):
    rng = np.random.default_rng(7)
    names = [f"k{i}" for i in range(120)]
    model = Model.shafer(Frame(names))
    ps = [rng.random(120) for _ in range(2)]
    ps[0][:10] = 0.0                                           # hypotheses only one source holds
    sources = [MassFunction(dict(zip(names, (p / p.sum()).tolist())), model=model) for p in ps]
    calls = []
    original = rules.combine_singletons
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(rules, "combine_singletons", lambda *a: calls.append(a[0]) or original(*a))
        fast = combine(*sources, rule=rule)
    assert calls == [singletons.SINGLETON_RULES[rules.get_rule(rule).function]]
    general = combine(*(m.batch() for m in sources), rule=rule, engine="general")[0]
    assert fast.focal == general.focal
    np.testing.assert_allclose(fast.values, general.values, rtol=1e-13, atol=0)
    if rule == "dempster":
        assert fast == general                               # the same products and the same scale


def test_three_sources_fold_and_pcr_of_three_goes_elsewhere(kernel_always):
    model = Model.shafer(Frame(["a", "b", "c"]))
    ms = [MassFunction({"a": 0.5, "b": 0.3, "c": 0.2}, model=model), MassFunction({"a": 0.2, "b": 0.6, "c": 0.2},
                                                                                      model=model),
          MassFunction({"a": 0.4, "c": 0.6}, model=model)]
    got = combine(*ms, rule="dempster")
    want = {x: float(v) for x, v in literal_three(ms).items()}
    assert as_masks(got) == pytest.approx(want, rel=1e-15)
    assert kernel_always[-1] == "dempster"
    combine(*ms, rule="pcr6")                                 # the joint PCR6 of three sources: another kernel
    assert kernel_always[-1] == "pcr"


def literal_three(ms):
    out: dict[int, Fraction] = {}
    for combo in itertools.product(*[m.items() for m in ms]):
        if len({x for x, _ in combo}) == 1:
            mask = combo[0][0].terms[0]
            out[mask] = out.get(mask, Fraction(0)) + Fraction(combo[0][1]) * Fraction(combo[1][1]) * Fraction(
                combo[2][1])
    kept = sum(out.values(), Fraction(0))
    return {x: v / kept for x, v in out.items()}


def test_mass_on_the_empty_set_is_kept_by_the_conjunctive_rule_and_refused_by_pcr6(kernel_always):
    model = Model.shafer(Frame(["a", "b"]))
    m1 = MassFunction({"a": 0.7, "empty": 0.3}, model=model, subnormal=True)
    m2 = MassFunction({"a": 0.4, "b": 0.6}, model=model)
    got = combine(m1, m2, rule="conjunctive")
    assert got.to_mapping() == pytest.approx({"empty": 0.3 + 0.7 * 0.6, "a": 0.7 * 0.4})
    with pytest.raises(Exception, match="∅|empty"):
        combine(m1, m2, rule="pcr6")


def test_total_conflict_is_the_general_paths_error(kernel_always):
    model = Model.shafer(Frame(["a", "b"]))
    with pytest.raises(TotalConflictError, match="total conflict"):
        combine(MassFunction({"a": 1.0}, model=model), MassFunction({"b": 1.0}, model=model), rule="dempster")


def test_a_frame_of_one_hypothesis_puts_yagers_conflict_on_it(kernel_always):
    model = Model.shafer(Frame(["only"]))
    m = MassFunction({"only": 1.0}, model=model)
    assert combine(m, m, rule="yager").to_mapping() == {"only": 1.0}


def test_large_bayesian_sources_cost_no_n_squared_structure():
    names = [f"big{i}" for i in range(3000)]
    model = Model.shafer(Frame(names))
    rng = np.random.default_rng(3)
    ms = []
    for _ in range(2):
        p = rng.random(3000)
        ms.append(MassFunction(dict(zip(names, (p / p.sum()).tolist())), model=model))
    fused = combine(*ms, rule="dempster")
    products = ms[0].values * ms[1].values
    np.testing.assert_allclose(fused.values, products / products.sum(), rtol=1e-14)
    assert decide(fused).elements == [names[int(np.argmax(products))]]


# -- the sparse tables ----------------------------------------------------------------------------------
@st.composite
def union_batches(draw):
    n = draw(st.integers(1, 8))
    frame = Frame([f"u{i}" for i in range(n)])
    model = Model.shafer(frame)
    masks = draw(st.lists(st.integers(0, (1 << n) - 1), min_size=1, max_size=12, unique=True))
    focal = tuple(sorted((model.reduce(frame.element("|".join(f"u{i}" for i in range(n) if m >> i & 1)))
                          if m else frame.empty for m in masks), key=lambda e: e.sort_key))
    rows = draw(st.integers(1, 5))
    values = np.array(draw(st.lists(st.lists(st.floats(0, 1), min_size=len(focal), max_size=len(focal)),
                                    min_size=rows, max_size=rows)))
    queries = tuple(draw(st.permutations(frame.singletons)))[:draw(st.integers(1, n))]
    return model, focal, queries, values


@settings(max_examples=200, deadline=None)
@given(union_batches(), st.sampled_from(["subset", "equal", "meets", "superset", "ratio"]))
def test_the_sparse_tables_give_the_dense_tables_bits(case, relation):
    model, focal, queries, values = case
    table = incidence(focal, queries, model)
    assert table is not None
    dense = weighted_sum(values, getattr(measure_plan(model, focal, queries), relation))
    np.testing.assert_array_equal(table.weigh(values, relation), dense)


def test_sparse_tables_do_not_apply_to_intersections_repeated_queries_or_other_models():
    frame = Frame(["a", "b", "c"])
    shafer = Model.shafer(frame)
    assert incidence((frame.element("a|b"),), (frame["a"], frame["a"]), shafer) is None
    assert incidence((frame.element("a|b"),), (frame.element("a|b"),), shafer) is None
    assert incidence((frame.element("a&b"),), (frame["a"],), None) is None
    assert incidence((frame["a"],), (frame["a"],), Model.free(frame)) is None


def bayesian_and_one_union(prefix: str, n: int, union: int, seed: int) -> tuple[Model, list[str], np.ndarray,
                                                                                 MassFunction]:
    """n single hypotheses and the union of the first ``union`` of them, random masses (the last one the union's)."""
    names = [f"{prefix}{i}" for i in range(n)]
    model = Model.shafer(Frame(names))
    masses = np.random.default_rng(seed).random(n + 1)
    masses /= masses.sum()
    mapping = dict(zip(names, masses[:n].tolist()))
    mapping["|".join(names[:union])] = float(masses[n])
    return model, names, masses, MassFunction(mapping, model=model)


def test_measures_of_many_hypotheses_take_the_sparse_tables_and_agree_with_the_definition():
    model, names, masses, m = bayesian_and_one_union("s", 400, 4, seed=5)
    batch = m.batch()
    plan = measure_plan(model, batch.focal, model.frame.singletons)
    assert plan.sparse is not None
    pls = batch.pls(model.frame.singletons)[0]
    betp = batch.betp(model.frame.singletons)[0]
    bel = batch.bel(model.frame.singletons)[0]
    single = {x.terms[0]: v for x, v in batch[0].items() if len(x.terms) == 1}
    for i, x in enumerate(model.frame.singletons):
        own = single.get(x.terms[0], 0.0)
        share = float(masses[400]) if i < 4 else 0.0
        assert bel[i] == own
        assert pls[i] == pytest.approx(own + share, rel=1e-15)
        assert betp[i] == pytest.approx(own + share / 4, rel=1e-15)


def test_frames_of_the_same_names_are_one_object():
    a = Frame(["p", "q"])
    assert Frame(("p", "q")) is a
    assert pickle.loads(pickle.dumps(a)) is a
    assert Frame(["q", "p"]) is not a
    assert MassFunction({"p": 1.0}, frame=["p", "q"]).frame is a


@settings(max_examples=150, deadline=None)
@given(union_batches(), st.sampled_from([0.0, 0.001, 0.5]))
def test_dsmp_on_the_sparse_tables_equals_the_dense_definition(case, epsilon):
    model, focal, _, values = case
    assume(any(x.terms for x in focal))                         # only ∅: total conflict on both paths
    queries = model.frame.singletons
    values = values + 1e-3                                      # rows of positive masses summing to one
    values /= values.sum(axis=1, keepdims=True)
    batch = MassBatch(list(focal), values, model=model, subnormal=True)
    table = incidence(focal, queries, model)
    plan = measure_plan(model, focal, queries)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(type(plan), "sparse", property(lambda self: None))
        try:
            dense = batch.dsmp(queries, epsilon=epsilon)
        except Exception as exc:                                # ε = 0 where DSmP is undefined
            with pytest.raises(type(exc), match="undefined"):
                table_dsmp(batch, table, epsilon)
            return
    np.testing.assert_allclose(table_dsmp(batch, table, epsilon), dense, rtol=1e-13, atol=1e-300)


def table_dsmp(batch, table, epsilon):
    keep = np.array([bool(x.terms) for x in batch.focal], dtype=float)
    kept = batch.values * keep
    result, undefined = table.dsmp(kept / kept.sum(axis=1, keepdims=True), epsilon)
    if undefined is not None:
        raise UndefinedTransformError("DSmP undefined")
    return result


def test_decide_by_dsmp_over_many_hypotheses_takes_the_sparse_tables():
    model, names, p, m = bayesian_and_one_union("d", 3000, 2, seed=11)
    batch = m.batch()
    assert measure_plan(model, batch.focal, model.frame.singletons).sparse.complete
    scores = batch.dsmp(model.frame.singletons, epsilon=0.0)[0]
    d0 = p[0] + p[3000] * p[0] / (p[0] + p[1])
    assert scores[0] == pytest.approx(d0, rel=1e-12)
    assert scores[5] == pytest.approx(p[5], rel=1e-12)
    assert decide(m, "dsmp", epsilon=0.0).elements == [names[int(np.argmax(scores))]]


def test_a_relation_without_a_sparse_table_is_refused_by_name():
    frame = Frame(["a", "b"])
    table = incidence((frame["a"],), (frame["a"],), Model.shafer(frame))
    with pytest.raises(ValueError, match="no sparse table for the relation 'unit_in_meet'"):
        table.weigh(np.array([[1.0]]), "unit_in_meet")


def test_dsmp_names_the_focal_element_where_it_is_undefined():
    model, names, _, _ = bayesian_and_one_union("e", 300, 2, seed=1)
    m = MassFunction({"e0|e1": 0.5, **{name: 0.5 / 298 for name in names[2:]}}, model=model)
    with pytest.raises(UndefinedTransformError, match=r"focal element e0\|e1 holds no mass of DSm cardinality one"):
        m.batch().dsmp(model.frame.singletons, epsilon=0.0)


@pytest.mark.parametrize("n", [1, 2, 65, 66, 2049, 4099])
def test_the_pcr_pair_table_gives_the_bits_of_sums_and_quotients_written_out(n):
    # The block kernel forms a_i + b_j as a small matrix product: it must give the bits of the sums written out,
    # on block edges too (n above PCR_BLOCK_ENTRIES // rows), with zero masses and the pairs (i, i) left out.
    rng = np.random.default_rng(n)
    a, b = rng.random(n) ** 4, rng.random(n) ** 4
    a[rng.random(n) < 0.2] = 0.0
    b[rng.random(n) < 0.2] = 0.0
    a[0] = b[-1] = 1.0                              # something live in each
    a, b = a / a.sum(), b / b.sum()
    live_a, live_b = np.flatnonzero(a), np.flatnonzero(b)
    x, y = a[live_a], b[live_b]
    reciprocal = 1.0 / np.add.outer(x, y)
    reciprocal[live_a[:, None] == live_b[None, :]] = 0.0
    step = max(1, singletons.PCR_BLOCK_ENTRIES // len(y))     # the kernel's blocks: its order of additions
    to_a, to_b = np.empty(len(x)), np.zeros(len(y))
    for start in range(0, len(x), step):
        rows = slice(start, start + step)
        to_a[rows] = reciprocal[rows] @ y
        to_b += x[rows] @ reciprocal[rows]
    expected = a * b
    expected[live_a] += x * (x * to_a)
    expected[live_b] += y * (y * to_b)
    assert np.array_equal(singletons._pcr_pair(a, b), expected)
