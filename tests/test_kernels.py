"""The kernels behind the combination paths: each against a literal or a slower evaluation of the same sums.

* :class:`belief.segments.RunProgram` sums runs of products for many rows in numpy's order of
  additions: its sums are those of ``np.add.reduceat``, to the last bit, and batches combined
  through it equal batches combined through ``reduceat``;
* :mod:`belief.masks` combines hypothesis masks of any width (rows of 64-bit words): its
  groups, canonical order and conjunctions match plain Python on the integers;
* frames wider than the rank tables (more than 16 hypotheses, more than 64) combine single
  mass functions on their masks, and agree with the batches' general path;
* :mod:`belief.joint_code` writes joint PCR5 / PCR6 out for focal elements that come back:
  its results are the loop's to the last bit, call after call.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import belief.masks as masks_module
import belief.plan as plan_module
import belief.rules_single as single
import belief.rules_tuples as tuples
from belief import Frame, MassBatch, MassFunction, Model, combine
from belief.frame import Element
from belief.joint_code import pcr_function
from belief.masks import canonical_order, from_words, to_words, tuple_groups, union_key, union_terms, word_count
from belief.segments import RunProgram

from tests.test_direct_path import clear_caches


# -- RunProgram: reduceat's sums for many rows ------------------------------------------------------------
def random_runs(rng, sizes):
    """Columns (in an order sorted by target) and run starts of random targets over the tuples of these sizes."""
    count = math.prod(sizes)
    targets = rng.integers(0, rng.integers(1, count + 1), size=count)
    order = np.argsort(targets, kind="stable")
    ordered = targets[order]
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    columns = [c[order] for c in np.unravel_index(np.arange(count), sizes)]
    return columns, starts


@pytest.mark.parametrize("seed", range(12))
def test_a_run_program_sums_as_reduceat_to_the_last_bit(seed):
    rng = np.random.default_rng(seed)
    sizes = [int(k) for k in rng.integers(1, 9, size=rng.integers(1, 4))]
    if seed % 4 == 0:
        sizes = [int(rng.integers(150, 400))]          # runs long enough for numpy's blocks of 128
    columns, starts = random_runs(rng, sizes)
    rows = int(rng.integers(1, 600))
    values = [rng.random((rows, k)) * 10.0 ** rng.uniform(-12, 0, size=(rows, k)) for k in sizes]
    products = values[0].take(columns[0], axis=1)
    for v, c in zip(values[1:], columns[1:]):
        products *= v.take(c, axis=1)
    expected = np.add.reduceat(products, starts, axis=1)
    assert np.array_equal(RunProgram(columns, starts).evaluate(values), expected)
    skipped = expected.copy()
    skipped[:, 0] = 0.0
    assert np.array_equal(RunProgram(columns, starts, (0,)).evaluate(values), skipped)


@pytest.fixture
def program_everywhere(monkeypatch):
    """Batches of any size summed by a RunProgram."""
    monkeypatch.setattr(tuples, "PROGRAM_MIN_ROWS", 0)
    monkeypatch.setattr(tuples, "program_pays", lambda *args: True)


@pytest.fixture
def reduceat_everywhere(monkeypatch):
    monkeypatch.setattr(tuples, "PROGRAM_MIN_ROWS", 10 ** 9)


def batch_case(seed: int, rows: int = 300):
    rng = np.random.default_rng(seed)
    frame = Frame(["a", "b", "c", "d"])
    model = [Model.shafer(frame), Model.free(frame), Model.for_targets(3)][seed % 3]
    frame = model.frame
    a, b, c, d = frame.hypotheses
    pool = [frame.element(t) for t in (a, b, f"{a}|{b}", f"{b}|{c}", f"{a}&{b}", f"{c}|{d}", f"{a}|{b}|{c}|{d}",
                                       f"{a}&{c}|{d}")]
    batches = []
    for _ in range(2 + seed % 2):
        focal = sorted({model.reduce(x) for x in rng.choice(pool, size=4, replace=False)} - {frame.empty},
                       key=lambda e: e.sort_key)
        values = rng.dirichlet(np.ones(len(focal)), size=rows)
        values[rng.random(values.shape) < 0.1] = 0.0
        values[values.sum(axis=1) == 0, 0] = 1.0
        batches.append(MassBatch(focal, values / values.sum(axis=1, keepdims=True), model=model))
    return batches


def outcome(batches, rule):
    try:
        result = combine(*batches, rule=rule, engine="general")
    except Exception as exc:                         # the same error either way
        return type(exc).__name__, str(exc)
    return result.focal, result.values.tolist()


def both_ways(monkeypatch, run) -> dict:
    """``run()`` with the runs of products summed by ``np.add.reduceat`` and by a :class:`RunProgram`, from cold caches."""
    got = {}
    for name, minimum in (("reduceat", 10 ** 9), ("program", 0)):
        with monkeypatch.context() as mp:
            mp.setattr(tuples, "PROGRAM_MIN_ROWS", minimum)
            mp.setattr(tuples, "program_pays", lambda *args: True)
            clear_caches()
            got[name] = run()
    return got


@pytest.mark.parametrize("rule", ["conjunctive", "dsmc", "dempster", "disjunctive", "yager", "dubois_prade", "dsmh",
                                  "pcr6"])
@pytest.mark.parametrize("seed", range(6))
def test_batches_summed_by_programs_equal_batches_summed_by_reduceat(rule, seed, monkeypatch):
    batches = batch_case(seed)
    got = both_ways(monkeypatch, lambda: [outcome(batches, rule) for _ in range(3)])    # direct path, then the plan
    assert got["program"] == got["reduceat"]
    assert got["program"][0] == got["program"][1] == got["program"][2]


# -- masks of any width --------------------------------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(width=st.sampled_from([3, 20, 64, 65, 130, 200]), data=st.data())
def test_tuple_groups_are_the_results_of_the_integer_operations(width, data):
    sources = data.draw(st.lists(st.lists(st.integers(1, (1 << width) - 1), min_size=1, max_size=6, unique=True),
                                 min_size=1, max_size=3))
    words = word_count(width)
    arrays = [to_words(s, words) for s in sources]
    assert [from_words(a) for a in arrays] == sources
    for ufunc, op in ((np.bitwise_and, lambda x, y: x & y), (np.bitwise_or, lambda x, y: x | y)):
        unique, first, inverse = tuple_groups(arrays, ufunc)
        results = from_words(unique)
        literal = []
        for combo in itertools.product(*sources):
            value = combo[0]
            for x in combo[1:]:
                value = op(value, x)
            literal.append(value)
        assert [results[i] for i in inverse.tolist()] == literal
        assert len(set(results)) == len(results)
        assert [literal[t] for t in first.tolist()] == results


def test_tuples_whose_hashes_collide_are_still_told_apart(monkeypatch):
    monkeypatch.setattr(masks_module, "_row_hashes",
                        lambda words: np.where(words.any(axis=1), np.uint64(7), np.uint64(0)))
    sources = [[3 << 64, 5 << 64, 1], [7 << 64 | 1, 1 << 65]]
    unique, _, inverse = tuple_groups([to_words(s, 2) for s in sources], np.bitwise_and)
    results = from_words(unique)
    assert [results[i] for i in inverse.tolist()] == [a & b for a in sources[0] for b in sources[1]]


@settings(max_examples=60, deadline=None)
@given(width=st.sampled_from([4, 16, 40, 64, 100]), data=st.data())
def test_the_canonical_order_of_masks_is_the_order_of_their_elements(width, data):
    found = data.draw(st.lists(st.integers(1, (1 << width) - 1), min_size=1, max_size=300, unique=True))
    frame = Frame([f"x{i}" for i in range(width)])
    elements = [Element._make(frame, terms) for terms in union_terms(found, width)]
    assert [e.terms for e in elements] == [tuple(1 << i for i in range(width) if m >> i & 1) for m in found]
    by_elements = [sum(e.terms) for e in sorted(elements, key=lambda e: e.sort_key)]
    assert sorted(found, key=union_key(width)) == by_elements
    assert [found[i] for i in canonical_order(to_words(found, word_count(width))).tolist()] == by_elements


@settings(max_examples=80, deadline=None)
@given(n=st.integers(2, 7), data=st.data())
def test_exclusive_hypotheses_are_told_from_the_constraints_alone(n, data):
    frame = Frame([f"h{i}" for i in range(n)])
    pairs = [(1 << i) | (1 << j) for i in range(n) for j in range(i + 1, n)]
    constraints = data.draw(st.lists(st.sampled_from(pairs + [1 << i for i in range(n)]), max_size=12, unique=True))
    model = Model(frame, constraints)
    used = data.draw(st.integers(0, (1 << n) - 1))
    bits = [1 << i for i in range(n) if used >> i & 1]
    literal = all(model.is_forbidden(a | b) for k, a in enumerate(bits) for b in bits[k + 1:])
    plan_module.exclusive_hypotheses.cache_clear()
    assert plan_module.exclusive_hypotheses(model, used) == literal


# -- frames beyond the rank tables ---------------------------------------------------------------------
def wide_sources(n: int, sizes, seed: int, model=None):
    rng = np.random.default_rng(seed)
    names = [f"h{i}" for i in range(n)]
    model = model or Model.shafer(Frame(names))
    out = []
    for k in sizes:
        masses = {}
        while len(masses) < k:
            subset = [h for h in names if rng.random() < 0.3] or [names[int(rng.integers(n))]]
            masses["|".join(subset)] = float(rng.uniform(0.1, 1.0))
        total = sum(masses.values())
        out.append(MassFunction({key: v / total for key, v in masses.items()}, model=model))
    return out


@pytest.mark.parametrize("n", [20, 64, 70, 130])
@pytest.mark.parametrize("rule", ["conjunctive", "dempster", "disjunctive", "yager", "pcr5", "pcr6", "dubois_prade",
                                  "dsmh"])
def test_wide_frames_combine_single_mass_functions_as_batches(n, rule):
    for sizes in ((3, 4), (12, 11), (3, 3, 3), (30, 40)):
        if rule in ("pcr5", "pcr6", "dubois_prade", "dsmh") and math.prod(sizes) > 400:
            continue
        sources = wide_sources(n, sizes, n + len(sizes))
        fused = combine(*sources, rule=rule)
        general = combine(*[m.batch() for m in sources], rule=rule, engine="general")[0]
        assert fused.focal == general.focal
        assert fused.isclose(general, rel_tol=0.0, abs_tol=1e-12)


def test_a_hybrid_model_whose_hypotheses_in_use_exclude_one_another_takes_the_mask_paths(monkeypatch):
    names = [f"h{i}" for i in range(80)]
    frame = Frame(names)
    # Only the first ten hypotheses exclude one another; the sources use no other.
    model = Model.hybrid(frame, [f"{a}&{b}" for i, a in enumerate(names[:10]) for b in names[i + 1:10]])
    rng = np.random.default_rng(3)
    sources = []
    for _ in range(2):
        masses = {}
        while len(masses) < 20:
            masses["|".join(h for h in names[:10] if rng.random() < 0.4) or "h0"] = float(rng.uniform(0.1, 1))
        total = sum(masses.values())
        sources.append(MassFunction({k: v / total for k, v in masses.items()}, model=model))
    calls = []
    original = Element.__and__
    monkeypatch.setattr(Element, "__and__", lambda self, other: calls.append(1) or original(self, other))
    fused = combine(*sources, rule="dempster")
    clear_caches()
    general = [combine(*[m.batch() for m in sources], rule="dempster", engine="general")[0] for _ in range(3)]
    assert not calls                                   # neither the direct path nor the plans meet elements
    for g in general:
        assert fused.focal == g.focal and fused.isclose(g, rel_tol=0.0, abs_tol=1e-12)


def test_a_thousand_focal_elements_on_sixty_four_hypotheses_are_combined_on_their_masks():
    a, b = wide_sources(64, (1000, 1000), 11)
    fused = combine(a, b, rule="dempster")
    assert fused._focal is None                       # no element made until read
    masks = fused._masks
    reference = {}
    for x, p in zip(a._union_masks(), a._union_floats()):
        for y, q in zip(b._union_masks(), b._union_floats()):
            if x & y:
                reference.setdefault(x & y, []).append(p * q)
    total = math.fsum(math.fsum(v) for v in reference.values())
    assert set(masks) == set(reference)
    got = dict(zip(masks, fused.values.tolist()))
    assert max(abs(got[m] - math.fsum(v) / total) for m, v in reference.items()) < 1e-15
    assert list(masks) == sorted(masks, key=union_key(64))


def test_batches_of_many_single_hypotheses_are_combined_without_meeting_elements(monkeypatch):
    n = 300
    names = [f"h{i}" for i in range(n)]
    model = Model.shafer(Frame(names))
    rng = np.random.default_rng(5)
    batches = [MassBatch(list(names), rng.dirichlet(np.ones(n), size=2), model=model) for _ in range(2)]
    calls = []
    original = Element.__and__
    monkeypatch.setattr(Element, "__and__", lambda self, other: calls.append(1) or original(self, other))
    fused = combine(*batches, rule="dempster", engine="general")
    assert not calls
    products = batches[0].values * batches[1].values
    assert np.allclose(fused.values, products / products.sum(axis=1, keepdims=True), rtol=1e-14, atol=0)


# -- joint PCR written out -----------------------------------------------------------------------------
@pytest.mark.parametrize("rule", ["pcr5", "pcr6"])
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_joint_pcr_written_out_gives_the_loops_sums(rule, data):
    n = data.draw(st.integers(2, 5))
    s = data.draw(st.integers(2, 4))
    sources = []
    for _ in range(s):
        focal = data.draw(st.lists(st.integers(1, (1 << n) - 1), min_size=1, max_size=4, unique=True))
        weights = data.draw(st.lists(st.integers(1, 9), min_size=len(focal), max_size=len(focal)))
        sources.append((focal, [w / sum(weights) for w in weights]))
    model = Model.shafer(Frame([f"h{i}" for i in range(n)]))
    masks = [f for f, _ in sources]
    values = [v for _, v in sources]
    loop = single._pcr_joint_loop(model, rule, masks, values)
    function, targets = pcr_function(masks, rule)
    sums = dict(zip(targets, function(*values)))
    assert dict(zip(loop._masks, loop._floats)) == {m: x for m, x in sums.items() if x > 0}


def test_joint_pcr_of_sources_that_come_back_is_the_same_call_after_call():
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    sources = [MassFunction({"a": 0.5, "b": 0.3, "a|c": 0.2}, model=shafer),
               MassFunction({"b": 0.6, "c": 0.1, "a|b": 0.3}, model=shafer),
               MassFunction({"a": 0.2, "c": 0.7, "b|c": 0.1}, model=shafer)]
    for rule in ("pcr5", "pcr6"):
        clear_caches()
        results = [combine(*sources, rule=rule) for _ in range(4)]         # loop, written out, then kept
        assert all(r == results[0] for r in results)
        assert type(sources[0]._memo).__name__ == "_JointTable" and sources[0]._memo.plan is not None
        general = combine(*[m.batch() for m in sources], rule=rule, engine="general")[0]
        assert results[0].isclose(general, rel_tol=0.0, abs_tol=1e-15)


# -- reading mass functions ------------------------------------------------------------------------------
def test_propositions_read_before_are_remembered_within_a_bound(monkeypatch):
    import belief.mass as mass_module

    monkeypatch.setattr(mass_module, "PARSE_CACHE_SIZE", 3)
    shafer = Model.shafer(Frame(["a", "b", "c", "d"]))
    texts = ["a", "b|c", "a|d", "c", "a|b|c|d", "b"]
    for _ in range(3):
        for first, second in zip(texts, texts[1:]):
            m = MassFunction({first: 0.25, second: 0.75}, model=shafer)
            assert m.to_mapping() == MassFunction({shafer.frame.element(first): 0.25,
                                                   shafer.frame.element(second): 0.75}, model=shafer).to_mapping()
            assert len(shafer._unions[3]) <= 3
    # A name twice is no union of distinct hypotheses: read by the general parser, never remembered.
    assert MassFunction({"a|a": 0.5, "b": 0.5}, model=shafer) == MassFunction({"a": 0.5, "b": 0.5}, model=shafer)
    assert "a|a" not in shafer._unions[3]


def test_dempsters_rows_normalised_block_by_block_are_those_normalised_afterwards(monkeypatch):
    from belief.rules_classic import WIDE_SCALE

    assert tuples.DEMPSTER_SMALLEST_SCALE == WIDE_SCALE
    frame = Frame(["a", "b", "c"])
    shafer = Model.shafer(frame)
    rng = np.random.default_rng(9)
    first = rng.dirichlet(np.ones(3), size=400)
    second = rng.dirichlet(np.ones(3), size=400)
    first[7] = [1.0 - 2e-13, 1e-13, 1e-13]                     # nearly total conflict: a non-empty mass of ~1e-26
    second[7] = [0.0, 0.5, 0.5]
    batches = [MassBatch(["a", "b", "c"], first, model=shafer), MassBatch(["a", "b", "c"], second, model=shafer)]
    got = both_ways(monkeypatch, lambda: [outcome(batches, "dempster"), outcome(batches[::-1], "dempster")])
    assert got["program"] == got["reduceat"]
    assert np.isclose(math.fsum(got["program"][0][1][7]), 1.0)
