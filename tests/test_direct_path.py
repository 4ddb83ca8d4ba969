"""The direct path of the combination rules against the compiled plans.

A combination of focal elements met for the first time is evaluated directly, on integer
codes of the focal elements, with no plan compiled (:mod:`belief.rules`, :mod:`belief.plan`);
the plan is compiled when the same focal elements come back.  Mass functions whose focal
elements are unions of exclusive hypotheses take the leanest form of the direct path
(``rules_single.combine_single``).  The choice must not show:

* batches and the general direct path add the same products in the same order as the plan:
  their results are equal to the last bit;
* single mass functions of unions of hypotheses sum what reaches one element with
  ``math.fsum`` when a few tuples are looped over: those results agree with the plan's
  within 1e-12, and do not depend on the order in which the focal elements were given;
* every error is the same, with the same message.

Each test forces the paths with ``pytest.MonkeyPatch``: the plans alone (no direct path),
the direct path on every call (no plan is ever found or compiled), its Python loop or its
numpy evaluation, and the single-mass-function path with either of its evaluations.
"""

from __future__ import annotations

import math
import pickle
import re
from contextlib import contextmanager

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import belief.plan as plan_module
import belief.rules as rules
import belief.rules_pcr as pcr_module
import belief.rules_single as single
import belief.rules_tuples as tuples
from belief import (
    BeliefError,
    CombinationTooLargeError,
    Element,
    Frame,
    InvalidMassError,
    MassBatch,
    MassFunction,
    Model,
    ModelError,
    TotalConflictError,
    combine,
    sequential,
)
from tests.strategies import fusion_cases, subset_mass_lists, subset_text

RULES_UNDER_TEST = ("conjunctive", "dsmc", "dempster", "disjunctive", "yager", "dubois_prade", "dsmh", "pcr5", "pcr6",
                    "r_rule")
SINGLE_RULES = tuple(r for r in RULES_UNDER_TEST if r != "r_rule")
TOLERANCE = 1e-12


# -- forcing a path ---------------------------------------------------------------------------------------
@contextmanager
def path(name: str):
    """Force one way of evaluating every combination inside the block.

    ``plan``: compiled plans only; ``loop`` / ``arrays``: the general direct path on every
    call, by its Python loop or by numpy; ``single-loop`` / ``single-arrays``: the path of
    single mass functions, by its loops or by numpy (the general direct path elsewhere);
    ``auto``: the library's own choice, from empty caches.
    """
    with pytest.MonkeyPatch.context() as mp:
        if name == "plan":
            mp.setattr(rules, "SINGLE_FAMILIES", ())
            mp.setattr(tuples, "direct_path", lambda *args: None)
            mp.setattr(pcr_module, "direct_path", lambda *args: None)
        elif name in ("loop", "arrays", "single-loop", "single-arrays"):
            mp.setattr(tuples, "plan_lookup", lambda *args: None)
            mp.setattr(tuples, "sighted", lambda *args: False)
            mp.setattr(tuples, "LOOP_TUPLES", 10 ** 9 if name.endswith("loop") else 0)
            mp.setattr(tuples, "WIDE_LOOP_TUPLES", 10 ** 9 if name.endswith("loop") else 0)
            if name.startswith("single"):
                big = name == "single-loop"
                mp.setattr(single, "SINGLE_LOOP_TUPLES", 10 ** 9 if big else 0)
                mp.setattr(single, "PCR_LOOP_TUPLES", 10 ** 9 if big else 0)
                mp.setattr(single, "_single_seen", lambda key, table: None)      # never a cached table
            else:
                mp.setattr(rules, "SINGLE_FAMILIES", ())
        else:
            assert name == "auto", name
        clear_caches()
        yield
    clear_caches()


def clear_caches() -> None:
    plan_module._PLANS.clear()
    plan_module._SIGHTINGS.clear()
    single._SINGLE_TABLES.clear()
    single._SINGLE_SIGHTINGS.clear()


def outcome(sources, rule: str, **kwargs):
    """What a combination gives: (focal elements, masses) of every row, or (error type, message)."""
    try:
        result = combine(*sources, rule=rule, **kwargs)
    except BeliefError as exc:
        return type(exc).__name__, str(exc)
    if isinstance(result, MassFunction):
        return tuple(result.focal), tuple(result.values.tolist())
    return tuple(result.focal), tuple(map(tuple, result.values.tolist()))


def agree(a, b, tolerance: float = 0.0) -> bool:
    """Two outcomes are the same error, or the same focal elements with masses within ``tolerance``."""
    if isinstance(a[0], str) or isinstance(b[0], str):
        return a == b
    if a[0] != b[0]:
        return False
    if tolerance == 0.0:
        return a[1] == b[1]
    flat_a = np.ravel(np.array(a[1], dtype=float))
    flat_b = np.ravel(np.array(b[1], dtype=float))
    return flat_a.shape == flat_b.shape and bool(np.all(np.abs(flat_a - flat_b) <= tolerance))


def across(paths, sources, rule: str, **kwargs) -> dict:
    out = {}
    for name in paths:
        with path(name):
            out[name] = outcome(sources, rule, **kwargs)
    return out


# -- the general direct path: the plan's results to the last bit --------------------------------------------
@pytest.mark.parametrize("rule", RULES_UNDER_TEST)
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(fc=fusion_cases(max_sources=4, max_n=4, dynamic=None))
def test_direct_path_equals_the_plan_to_the_last_bit(rule, fc):
    sources = fc.build()
    model = fc.fusion.model if fc.dynamic else None
    got = across(("plan", "loop", "arrays"), sources, rule, model=model)
    assert got["loop"] == got["plan"], got
    assert got["arrays"] == got["plan"], got


@st.composite
def batch_sources(draw):
    """Two or three batches under one model (some of one row, to broadcast), with zero masses in places."""
    fc = draw(fusion_cases(max_sources=3, max_n=4, dynamic=None))
    rows = draw(st.integers(2, 5))
    batches = []
    for source in fc.sources:
        focal = [e for e, _ in source]
        n = draw(st.sampled_from([1, rows]))
        weights = draw(st.lists(st.lists(st.integers(0, 9), min_size=len(focal), max_size=len(focal))
                                .filter(any), min_size=n, max_size=n))
        values = np.array(weights, dtype=float)
        values /= values.sum(axis=1, keepdims=True)
        batches.append(MassBatch(focal, values, model=fc.source.model))
    return fc, batches


@pytest.mark.parametrize("rule", RULES_UNDER_TEST)
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=batch_sources())
def test_batches_take_the_direct_path_with_the_plans_results(rule, data):
    fc, batches = data
    model = fc.fusion.model if fc.dynamic else None
    got = across(("plan", "loop", "arrays", "auto"), batches, rule, model=model)
    for name in ("loop", "arrays", "auto"):
        assert got[name] == got["plan"], (name, got)


# -- single mass functions of unions of hypotheses ------------------------------------------------------
@st.composite
def union_sources(draw):
    """Mass functions of unions of hypotheses on Shafer's model, given as text, two to four of them."""
    sources = draw(subset_mass_lists(min_sources=2, max_sources=4, max_n=5, max_focal=5, empty=None))
    return [s.build() for s in sources]


@pytest.mark.parametrize("rule", SINGLE_RULES)
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(sources=union_sources())
def test_single_mass_functions_agree_with_the_plan(rule, sources):
    got = across(("plan", "single-loop", "single-arrays", "auto"), sources, rule)
    for name in ("single-loop", "single-arrays", "auto"):
        assert agree(got[name], got["plan"], TOLERANCE), (name, got)
    # Repeated calls (the focal elements come back: tables are cached) give the same result.
    with path("auto"):
        first = outcome(sources, rule)
        for _ in range(3):
            assert outcome(sources, rule) == first


@pytest.mark.parametrize("rule", SINGLE_RULES)
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(sources=union_sources(), data=st.data())
def test_single_results_do_not_depend_on_the_order_of_the_focal_elements(rule, sources, data):
    shuffled = []
    for m in sources:
        items = list(m.to_mapping().items())
        order = data.draw(st.permutations(range(len(items))))
        shuffled.append(MassFunction(dict(items[i] for i in order), model=m.model, subnormal=True))
    assert shuffled == sources
    with path("auto"):
        assert outcome(shuffled, rule) == outcome(sources, rule)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(sources=union_sources())
def test_single_path_results_behave_as_the_plans(sources):
    normal = [m for m in sources if m.empty_mass == 0.0]
    if len(normal) < 2:
        return
    with path("plan"):
        try:
            reference = combine(*normal, rule="dempster")
        except TotalConflictError as exc:
            with path("single-loop"), pytest.raises(TotalConflictError, match=re.escape(str(exc))):
                combine(*normal, rule="dempster")
            return
    with path("single-loop"):
        result = combine(*normal, rule="dempster")
    assert result.model == reference.model and result.focal == reference.focal
    assert result.isclose(reference, rel_tol=0.0, abs_tol=TOLERANCE)
    assert len(result) == len(reference) and list(result) == list(reference)
    assert pickle.loads(pickle.dumps(result)) == result
    assert result.bel(result.frame.total) == pytest.approx(1.0, abs=1e-12)



@pytest.mark.parametrize("rule", ["conjunctive", "disjunctive", "dempster"])
@pytest.mark.parametrize("off", [0.0, 3e-14, 8e-10, -8e-10])
def test_a_pair_of_sources_that_sum_to_one_only_nearly_gives_a_result_that_does(rule, off):
    # Sources may be off one by SUM_TOLERANCE; a product of two that is off by more than
    # RESULT_TOLERANCE is rescaled, on the pair's own loop as on the plans.
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m1 = MassFunction({"a": 0.5, "b|c": 0.5 + off}, model=shafer)
    m2 = MassFunction({"a|b": 0.25, "c": 0.75 + off}, model=shafer)
    got = across(("plan", "single-loop", "auto"), [m1, m2], rule)
    assert agree(got["single-loop"], got["plan"], TOLERANCE) and got["auto"] == got["single-loop"], got
    total = math.fsum(got["auto"][1])
    assert abs(total - 1.0) <= rules.RESULT_TOLERANCE

def test_hybrid_model_of_exclusive_pairs_takes_the_single_path():
    frame = Frame(["a", "b", "c", "d"])
    pairs = [f"{x}&{y}" for i, x in enumerate(frame.hypotheses) for y in frame.hypotheses[i + 1:]]
    hybrid = Model.hybrid(frame, pairs)
    m1 = MassFunction({"a|b": 0.6, "c": 0.3, "a|b|c|d": 0.1}, model=hybrid)
    m2 = MassFunction({"a": 0.5, "b|c": 0.5}, model=hybrid)
    for rule in SINGLE_RULES:
        got = across(("plan", "single-loop", "single-arrays"), [m1, m2], rule)
        assert agree(got["single-loop"], got["plan"], TOLERANCE), (rule, got)
        assert agree(got["single-arrays"], got["plan"], TOLERANCE), (rule, got)


def test_free_and_tracking_models_leave_single_mass_functions_to_the_general_paths():
    free = Model.free(Frame(["a", "b", "c"]))
    m1 = MassFunction({"a|b": 0.6, "c": 0.4}, model=free)
    m2 = MassFunction({"a": 0.5, "b|c": 0.5}, model=free)
    info = rules.get_rule("dsmc")
    assert single.combine_single(info, (m1, m2), None) is None          # a and b overlap: no hypothesis masks
    tracking = Model.for_targets(2)
    t1 = MassFunction({"t1": 0.6, "t2|FA": 0.4}, model=tracking)
    t2 = MassFunction({"t2": 0.5, "t1|t2": 0.5}, model=tracking)
    assert single.combine_single(info, (t1, t2), None) is None
    for sources in ([m1, m2], [t1, t2]):
        for rule in RULES_UNDER_TEST:
            got = across(("plan", "loop", "arrays", "auto"), sources, rule)
            assert got["loop"] == got["arrays"] == got["auto"] == got["plan"], (rule, got)


# -- where the choice switches ----------------------------------------------------------------------------
def shafer_sources(k1: int, k2: int, n: int = 6):
    frame = Frame([f"h{i}" for i in range(n)])
    model = Model.shafer(frame)
    rng = np.random.default_rng(k1 * 100 + k2)

    def source(k):
        masks = rng.choice(np.arange(1, 1 << n), size=k, replace=False)
        weights = rng.uniform(0.1, 1.0, size=k)
        weights /= weights.sum()
        return MassFunction({subset_text(frame, int(m)): float(w) for m, w in zip(masks, weights)}, model=model)

    return source(k1), source(k2)


@pytest.mark.parametrize("rule", SINGLE_RULES)
def test_the_loop_and_numpy_agree_on_either_side_of_the_threshold(rule, monkeypatch):
    limit = 12
    monkeypatch.setattr(single, "SINGLE_LOOP_TUPLES", limit)
    monkeypatch.setattr(single, "PCR_LOOP_TUPLES", limit)
    for k1, k2 in ((3, 4), (2, 6), (13, 1), (3, 5), (4, 4)):      # 12 tuples and fewer, then more
        sources = shafer_sources(k1, k2)
        with path("plan"):
            reference = outcome(sources, rule)
        with path("auto"):
            got = [outcome(sources, rule) for _ in range(3)]     # first sight, then seen again (cached)
        for g in got:
            assert agree(g, reference, TOLERANCE), (k1 * k2, g, reference)
        assert got[0] == got[1] == got[2]


def test_each_forced_path_is_the_one_taken():
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    free = Model.free(shafer.frame)
    mfs = [MassFunction({"a": 0.6, "b|c": 0.4}, model=shafer), MassFunction({"b": 0.5, "a|c": 0.5}, model=shafer)]
    frees = [MassFunction({"a&b": 0.6, "c": 0.4}, model=free), MassFunction({"b": 0.5, "a|c": 0.5}, model=free)]
    expected = {"plan": "tuple_plan", "loop": "_loop_targets", "arrays": "_array_targets",
                "single-loop": "_pair_loop", "single-arrays": "_single_table"}
    for name, function in expected.items():
        sources = frees if name in ("loop", "arrays") else mfs
        calls = []
        with path(name):
            module = plan_module if function == "tuple_plan" else single if name.startswith("single") else tuples
            original = getattr(module, function)
            with pytest.MonkeyPatch.context() as mp:
                mp.setattr(module, function, lambda *args, **kw: calls.append(1) or original(*args, **kw))
                if function == "tuple_plan":
                    mp.setattr(tuples, "tuple_plan", getattr(module, function))
                combine(*sources, rule="conjunctive")
        assert calls, name


def test_a_plan_is_compiled_only_when_the_focal_elements_come_back():
    a = MassBatch(["a", "b", "a|b"], [[0.5, 0.3, 0.2], [0.1, 0.6, 0.3]], frame=["a", "b", "c"], model="shafer")
    b = MassBatch(["b", "c", "a|b|c"], [[0.4, 0.4, 0.2], [0.3, 0.3, 0.4]], frame=["a", "b", "c"], model="shafer")
    with path("auto"):
        first = outcome([a, b], "dempster")
        assert not plan_module._PLANS                          # first sight: evaluated directly
        second = outcome([a, b], "dempster")
        assert len(plan_module._PLANS) == 1                    # seen again: compiled
        third = outcome([a, b], "dempster")
        assert len(plan_module._PLANS) == 1                    # found in the cache
    assert first == second == third


def test_single_tables_are_kept_only_for_focal_elements_that_come_back():
    m1, m2 = shafer_sources(12, 12)
    with path("auto"):
        results = []
        for _ in range(3):
            results.append(outcome([m1, m2], "conjunctive"))
            if len(results) == 1:
                assert not single._SINGLE_TABLES
        assert len(single._SINGLE_TABLES) == 1
    assert results[0] == results[1] == results[2]


def test_many_rows_and_many_focal_elements_still_agree_with_the_plan():
    rng = np.random.default_rng(7)
    frame = Frame([f"t{i}" for i in range(1, 7)])
    model = Model.hybrid(frame, ["t1&t2", "t3&t4&t5"])                  # 41 regions: codes of one word
    focal = [frame.element(t) for t in ("t1", "t2|t3", "t3&t4", "t1|t5", "t6&t2", "t4", "t2&t6|t5", "t4|t5|t6")]
    batches = [MassBatch(focal, rng.dirichlet(np.ones(len(focal)), size=50), model=model) for _ in range(3)]
    for rule in ("dsmc", "dempster", "pcr6", "dsmh"):
        got = across(("plan", "loop", "arrays", "auto"), batches, rule)
        assert got["loop"] == got["arrays"] == got["auto"] == got["plan"], rule


def test_frames_beyond_the_rank_tables_still_agree():
    frame = Frame([f"h{i}" for i in range(20)])
    model = Model.shafer(frame)
    m1 = MassFunction({"h0|h19": 0.5, "h3|h7|h11": 0.3, "h0|h1|h2|h3": 0.2}, model=model)
    m2 = MassFunction({"h0": 0.4, "h3|h19": 0.4, "h7|h11|h1": 0.2}, model=model)
    # No rank table: the masks are held as given, and put in canonical order by their key when read.
    assert m1._loose and m1.focal == tuple(frame.element(x) for x in ("h0|h19", "h3|h7|h11", "h0|h1|h2|h3"))
    for rule in SINGLE_RULES:
        got = across(("plan", "loop", "arrays", "auto"), [m1, m2], rule)
        assert got["loop"] == got["arrays"] == got["auto"] == got["plan"], rule


@pytest.mark.parametrize("singletons", [False, True])
@pytest.mark.parametrize("width", [300, 20, 64, 65, 130])
def test_many_unions_of_a_wide_frame_come_out_in_canonical_order(width, singletons):
    # Past a few dozen masks numpy sorts their words: the order must be Element.sort_key's.
    rng = np.random.default_rng(width)
    frame = Frame([f"h{i}" for i in range(width)])
    names = set()
    while len(names) < (min(width, 300) if singletons else 300):
        size = 1 if singletons else int(rng.integers(1, 5))
        names.add("|".join(f"h{i}" for i in sorted(rng.choice(width, size=size, replace=False).tolist())))
    masses = dict(zip(sorted(names), rng.dirichlet(np.ones(len(names))).tolist()))
    m = MassFunction(masses, model=Model.shafer(frame))
    assert m.to_mapping() == masses                 # read before the elements are made
    assert list(m.to_mapping().values()) == m.values.tolist()
    assert list(m.focal) == sorted(m.focal, key=lambda e: e.sort_key)
    assert list(m.to_mapping()) == [str(e) for e in m.focal]
    assert {str(e): v for e, v in m.items()} == masses


# -- the same errors ------------------------------------------------------------------------------------------
ALL_PATHS = ("plan", "loop", "arrays", "single-loop", "single-arrays", "auto")


def assert_same_error(sources, rule, error, match, **kwargs):
    got = across(ALL_PATHS, sources, rule, **kwargs)
    assert got["plan"][0] == error.__name__, got["plan"]
    assert match in got["plan"][1], got["plan"]
    for name, value in got.items():
        assert value == got["plan"], (name, value, got["plan"])


def test_total_conflict_is_the_same_error_on_every_path():
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m1 = MassFunction({"a": 0.7, "b": 0.3}, model=shafer)
    m2 = MassFunction({"c": 1.0}, model=shafer)
    assert_same_error([m1, m2], "dempster", TotalConflictError, "total conflict")
    assert_same_error([m1, m2, MassFunction({"a|b|c": 1.0}, model=shafer)], "dempster", TotalConflictError,
                      "total conflict")
    batch = MassBatch(["a", "c"], [[0.5, 0.5], [1.0, 0.0]], model=shafer)
    other = MassBatch(["b"], [[1.0]], model=shafer)
    assert_same_error([batch, other], "dempster", TotalConflictError, "(row 0)")


@pytest.mark.parametrize("rule", ["yager", "dubois_prade", "dsmh", "pcr5", "pcr6"])
def test_mass_on_the_empty_set_is_refused_on_every_path(rule):
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m1 = MassFunction({"empty": 0.2, "a": 0.8}, model=shafer, subnormal=True)
    m2 = MassFunction({"b": 0.5, "a|c": 0.5}, model=shafer)
    assert_same_error([m1, m2], rule, InvalidMassError, "needs normal sources")


@pytest.mark.parametrize("rule", ["pcr5", "pcr6"])
def test_an_element_that_vanishes_under_the_fusion_model_is_refused_on_every_path(rule):
    free = Model.free(Frame(["a", "b", "c"]))
    m1 = MassFunction({"a&b": 0.4, "c": 0.6}, model=free)
    m2 = MassFunction({"a": 0.5, "b|c": 0.5}, model=free)
    assert_same_error([m1, m2], rule, ModelError, "empty under the shafer fusion model", model=Model.shafer(free.frame))


def test_too_many_tuples_are_refused_on_every_path(monkeypatch):
    monkeypatch.setattr(plan_module, "MAX_TUPLES", 9)
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m = MassFunction({"a": 0.5, "b": 0.3, "c": 0.2}, model=shafer)
    assert_same_error([m, m, m], "pcr6", CombinationTooLargeError, "27 tuples")
    for name in ALL_PATHS:
        with path(name):
            assert combine(m, m, rule="pcr6").isclose(combine(m, m, rule="pcr5"))   # 9 tuples: at the limit


def test_dsmh_where_every_element_vanishes_gives_the_plans_result():
    frame = Frame(["a", "b", "c"])
    free = Model.free(frame)
    strict = Model.hybrid(frame, ["a&b", "c"])
    m1 = MassFunction({"a&b": 0.5, "c": 0.5}, model=free)
    m2 = MassFunction({"c": 0.7, "a&b&c": 0.3}, model=free)
    got = across(("plan", "loop", "arrays", "auto"), [m1, m2], "dsmh", model=strict)
    assert got["loop"] == got["arrays"] == got["auto"] == got["plan"]
    assert not isinstance(got["plan"][0], str)


def test_sequential_and_lists_of_sources_take_the_same_paths():
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    ms = [MassFunction({"a": 0.6, "b|c": 0.4}, model=shafer), MassFunction({"b": 0.5, "a|c": 0.5}, model=shafer),
          MassFunction({"c": 0.3, "a|b": 0.7}, model=shafer)]
    for rule in ("pcr5", "dempster"):
        with path("plan"):
            reference = sequential(*ms, rule=rule)
        with path("auto"):
            assert sequential(*ms, rule=rule).isclose(reference, rel_tol=0.0, abs_tol=TOLERANCE)
            assert combine(ms, rule=rule) == combine(*ms, rule=rule)


# -- building mass functions from a mapping ---------------------------------------------------------------
def general_constructor(masses, model):
    """The same mass function through the element-keyed constructor (no masks kept)."""
    return MassFunction({model.frame.element(k) if k != "empty" else model.frame.empty: v
                         for k, v in masses.items()}, model=model, subnormal=True)


@settings(max_examples=60, deadline=None)
@given(sources=union_sources())
def test_masks_and_floats_build_the_same_mass_function(sources):
    for m in sources:
        text = m.to_mapping()
        again = MassFunction(text, model=m.model, subnormal=True)
        reference = general_constructor(text, m.model)
        assert again == reference and hash(again) == hash(reference)
        assert again.focal == reference.focal and again.values.tolist() == reference.values.tolist()
        assert repr(again) == repr(reference) and again.to_dict() == reference.to_dict()
        assert len(again) == len(reference) and list(again.items()) == list(reference.items())
        assert not again.values.flags.writeable
        assert pickle.loads(pickle.dumps(again)) == reference


@pytest.mark.parametrize(
    ("masses", "error", "match"),
    [
        ({}, InvalidMassError, "at least one focal element"),
        ({"a": 0.0}, InvalidMassError, "sum to 0.0"),
        ({"a": True}, InvalidMassError, "must be a number"),
        ({"a": "0.5", "b": 0.5}, InvalidMassError, "must be a number"),
        ({"a": float("nan"), "b": 1.0}, InvalidMassError, "not a finite number"),
        ({"a": float("inf"), "b": 1.0}, InvalidMassError, "not a finite number"),
        ({"a": -0.1, "b": 1.1}, InvalidMassError, "negative mass"),
        ({"a": 0.5, "b": 0.4}, InvalidMassError, "sum to 0.9"),
        ({"a": 0.5, "d": 0.5}, BeliefError, "unknown hypothesis 'd'"),
        ({"a|": 1.0}, BeliefError, "malformed proposition"),
        ({"a&b": 1.0}, InvalidMassError, "empty under the shafer model"),
    ],
)
def test_bad_mappings_raise_the_errors_of_the_general_constructor(masses, error, match):
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    with pytest.raises(error, match=match):
        MassFunction(masses, model=shafer)


@pytest.mark.parametrize(
    "masses",
    [{"a|a": 1.0}, {" a | b ": 0.5, "c": 0.5}, {"a": 1}, {"a": np.float32(0.5), "b|c": 0.5}, {"a": 0.5, "a|a": 0.5},
     {"a|b": 0.25, "b|a": 0.75}, {"a": 0.5, "b": 0.5, "c": 0.0}, {"c|b|a": 1.0}],
)
def test_unusual_mappings_give_the_general_constructors_result(masses):
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m = MassFunction(masses, model=shafer)
    merged: dict = {}
    for key, value in masses.items():
        element = shafer.frame.element(key)
        merged[element] = merged.get(element, 0.0) + float(value)
    reference = MassFunction({e: v for e, v in merged.items() if v}, model=shafer)
    assert m.isclose(reference, rel_tol=0.0, abs_tol=1e-15) and m.focal == reference.focal


def test_a_model_that_empties_a_hypothesis_keeps_the_general_constructor():
    frame = Frame(["a", "b", "c"])
    model = Model.hybrid(frame, ["c"])
    m = MassFunction({"a|c": 0.4, "b": 0.6}, model=model)
    assert m._masks is None and [str(e) for e in m.focal] == ["a", "b"]
    assert m.values.tolist() == [0.4, 0.6]


def test_elements_and_masses_are_made_when_first_read():
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m = MassFunction({"b|c": 0.25, "a": 0.75}, model=shafer)
    assert m._focal is None and m._values is None
    assert [str(e) for e in m.focal] == ["a", "b|c"] and m._values is None
    assert m.values.tolist() == [0.75, 0.25]
    assert m.focal is m.focal and m.values is m.values
    with pytest.raises(AttributeError):
        m.values = np.array([0.5, 0.5])
    with pytest.raises(AttributeError):
        m.focal = ()
    fused = combine(m, MassFunction({"a|b": 0.5, "c": 0.5}, model=shafer), rule="conjunctive")
    assert fused._focal is None
    assert math.fsum(fused.values) == pytest.approx(1.0, abs=1e-15)
    assert [str(e) for e in fused.focal] == ["empty", "a", "b", "c"]


def test_elements_made_by_the_factory_are_ordinary_elements():
    frame = Frame(["a", "b", "c"])
    made = frame.element("c|a&b")
    parsed = frame.element("(c | b & a)")
    built = Element(frame, [4, 3])
    assert type(made) is Element and made == parsed == built
    assert hash(made) == hash(parsed) == hash(built)
    assert made.sort_key == built.sort_key
    with pytest.raises(AttributeError):
        made.terms = ()
    with pytest.raises(AttributeError):
        made.__class__ = Element
    assert pickle.loads(pickle.dumps(made)) == made


def test_single_hypotheses_of_a_wide_frame_are_the_frames_own_elements():
    # Found by identity (an integer of n bits hashes in O(n)); a mask equal to a bit but made otherwise is made.
    frame = Frame([f"h{i}" for i in range(100)])
    m = MassFunction({"h70": 0.25, "h7": 0.5, "h3|h99": 0.25}, model=Model.shafer(frame))
    focal = m.focal
    assert focal[0] is frame.singletons[7] and focal[1] is frame.singletons[70]
    assert str(focal[2]) == "h3|h99"
    assert frame.singleton_of_bit(frame.bits[70]) is frame.singletons[70]
    assert frame.singleton_of_bit(1 << 70) is None                     # equal, not the same object
    made = MassFunction({"h70": 0.5, "h7": 0.5}, model=Model.shafer(frame))
    assert combine(made, made, rule="dempster").focal == (frame.singletons[7], frame.singletons[70])


@pytest.mark.parametrize("width", [3, 40])
def test_to_mapping_from_masks_prints_as_the_elements_do(width):
    frame = Frame([f"h{i}" for i in range(width)])
    shafer = Model.shafer(frame)
    a = MassFunction({"h0|h2": 0.5, "h1": 0.3, "h0|h1|h2": 0.2}, model=shafer)
    b = MassFunction({"h2": 0.6, "h0|h1": 0.4}, model=shafer)
    fused = combine(a, b, rule="conjunctive")                  # ∅, single hypotheses and unions
    printed = fused.to_mapping()                               # before any element is made
    assert "empty" in printed and "h0|h1" in printed
    assert printed == {str(e): v for e, v in zip(fused.focal, fused.values.tolist())}
    assert list(printed) == [str(e) for e in fused.focal]
