"""Measures and decisions of mass functions measured from their bit masks (belief.incidence.held_measure).

A :class:`~belief.mass.MassFunction` built from a mapping of unions of hypotheses keeps them
as bit masks, in the order given, until its elements are read.  Under Shafer's model, for
singleton queries, ``decide``, ``m.bel``, ``m.pls``, ``m.q`` and ``m.betp`` weigh an incidence
built from those masks (put in canonical order first) instead of the elements.  The choice
must not show: every result is compared, to the last bit, with the dense tables of the
mass function's elements (:class:`~belief.batch.MeasurePlan` with its sparse tables turned
off), on

* fresh mass functions (masks in the order of the mapping's keys),
* settled ones (``m.focal`` read first: masks in canonical order, elements made),
* mass functions of masks as the kernels make them (with ∅, loose or in canonical order);

sums of three or more terms in another order than the canonical one would differ in their
last bits, which is what these tests would see.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import Frame, MassBatch, MassFunction, Model, TotalConflictError
from belief.batch import MeasurePlan
from belief.decisions import CRITERIA, decide
from belief.incidence import canonical_masks, held_measure, union_incidence
from belief.mass import mass_from_masks

MEASURES = ("bel", "pls", "q", "betp")
#: The criteria of decide that the masks serve (DSmP keeps the elements' path).
HELD_CRITERIA = tuple(c for c in CRITERIA if c != "dsmp")


# -- the reference: the dense tables of the elements ----------------------------------------------------------
def elements_only(m: MassFunction) -> MassFunction:
    """The same mass function held as elements and an array only (no masks: the batch path)."""
    return MassFunction._trusted(m.model, m.focal, m.values.copy())


def dense(call):
    """``call()`` with the sparse tables off: every measure of a batch takes the dense (K, Q) tables."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(MeasurePlan, "sparse", property(lambda self: None))
        return call()


def same_bits(a, b) -> bool:
    """Equal as floats, to the bit (``-0.0`` and ``0.0`` differ)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def names_of(frame: Frame, mask: int) -> str:
    return "|".join(frame.hypotheses[i] for i in range(len(frame)) if mask >> i & 1)


# -- random mass functions of unions of hypotheses ------------------------------------------------------------
@st.composite
def masks_of(draw, n: int):
    """A union of hypotheses of an n-hypothesis frame: often a single one, often a few of the first hypotheses (so
    that a hypothesis lies in three or more focal elements), sometimes any subset."""
    kind = draw(st.sampled_from(["single", "few", "any"]))
    if kind == "single":
        return 1 << draw(st.integers(0, n - 1))
    if kind == "few":
        top = draw(st.sampled_from([min(n, 5), n]))
        positions = draw(st.lists(st.integers(0, top - 1), min_size=1, max_size=4))
        return sum(1 << i for i in set(positions))
    return draw(st.integers(1, (1 << n) - 1))


@st.composite
def union_cases(draw):
    """(model, {proposition: mass}) over 3..70 hypotheses, keys in random order, masses summing to one."""
    n = draw(st.integers(3, 70))
    frame = Frame([f"x{i}" for i in range(n)])
    masks = draw(st.lists(masks_of(n), min_size=1, max_size=40, unique=True))
    weights = draw(st.lists(st.floats(1e-3, 1.0), min_size=len(masks), max_size=len(masks)))
    total = sum(weights)
    return Model.shafer(frame), {names_of(frame, m): w / total for m, w in zip(masks, weights)}


@st.composite
def query_lists(draw, frame: Frame):
    """Singleton queries: the frame's hypotheses, or distinct names, elements or both in any order, or one name."""
    kind = draw(st.sampled_from(["hypotheses", "names", "elements", "mixed", "one"]))
    if kind == "hypotheses":
        return frame.hypotheses
    chosen = draw(st.lists(st.sampled_from(frame.hypotheses), min_size=1, max_size=len(frame), unique=True))
    if kind == "names":
        return chosen
    if kind == "elements":
        return [frame[name] for name in chosen]
    if kind == "mixed":
        return tuple(frame.element(name) if i % 2 else name for i, name in enumerate(chosen))
    return chosen[0]


def check_measures(variants: list[MassFunction], make, queries) -> None:
    """Every measure of every variant (``make()`` for a fresh one) has the bits of the dense tables."""
    reference = elements_only(variants[0] if variants else make())
    for measure in MEASURES:
        expected = dense(lambda: getattr(reference, measure)(queries))
        for m in [make(), *variants]:
            got = getattr(m, measure)(queries)
            assert type(got) is type(expected)
            assert same_bits(got, expected), (measure, got, expected)


def check_decisions(variants: list[MassFunction], make) -> None:
    reference = elements_only(variants[0] if variants else make())
    for criterion in HELD_CRITERIA:
        expected = dense(lambda: decide(reference, criterion))
        for tol in (1e-9, 0.0):
            for m in [make(), *variants]:
                got = decide(m, criterion, tol=tol)
                if tol:
                    assert got == expected
                    assert same_bits(got.value, expected.value)
                else:
                    assert got == dense(lambda: decide(reference, criterion, tol=0.0))


def held_path_taken(m: MassFunction, width: int) -> bool:
    """Whether measuring a fresh ``m`` for ``width`` queries leaves its elements unmade (the masks served)."""
    return m._focal is None and m._batch is None if len(m) * width > 256 else True


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_fresh_and_settled_mass_functions_measure_as_the_dense_tables(data):
    model, mapping = data.draw(union_cases())
    frame = model.frame

    def make():
        return MassFunction(mapping, model=model)

    fresh = make()
    assert fresh._loose                                       # held as masks, in the order of the keys
    settled = make()
    settled.focal
    queries = data.draw(query_lists(frame))
    check_measures([settled], make, queries)
    check_decisions([settled], make)
    width = 1 if isinstance(queries, str) else len(queries)
    probe = make()
    probe.betp(queries)
    assert held_path_taken(probe, width)
    probe = make()
    decide(probe, "pls")
    assert held_path_taken(probe, len(frame))


@settings(max_examples=100, deadline=None)
@given(union_cases(), st.integers(0, 40), st.floats(1e-3, 0.9), st.booleans(), st.data())
def test_masks_with_the_empty_set_as_the_kernels_make_them(case, where, empty, loose, data):
    model, mapping = case
    frame = model.frame
    settled = MassFunction(mapping, model=model)
    masks, floats = list(settled._union_masks()), [v * (1.0 - empty) for v in settled._union_floats()]
    if loose:                                                 # ∅ anywhere among masks in any order
        order = data.draw(st.permutations(range(len(masks))))
        masks, floats = [masks[i] for i in order], [floats[i] for i in order]
        masks.insert(where % (len(masks) + 1), 0)
        floats.insert(where % (len(floats) + 1), empty)
    else:                                                     # canonical order, ∅ first, values as an array
        masks, floats = [0, *masks], np.array([empty, *floats])

    def make():
        return mass_from_masks(model, masks, floats if loose else floats.copy(), loose=loose)

    queries = data.draw(query_lists(frame))
    check_measures([], make, queries)
    check_decisions([], make)


@settings(max_examples=50, deadline=None)
@given(union_cases())
def test_subnormal_mappings_with_empty_measure_as_the_dense_tables(case):
    model, mapping = case
    mapping = {"empty": 0.25, **{key: 0.75 * v for key, v in mapping.items()}}

    def make():
        return MassFunction(mapping, model=model, subnormal=True)

    check_measures([], make, model.frame.hypotheses)
    check_decisions([], make)


@settings(max_examples=100, deadline=None)
@given(union_cases(), st.data())
def test_canonical_masks_is_the_order_of_the_settled_mass_function(case, data):
    model, mapping = case
    frame = model.frame
    m = MassFunction(mapping, model=model)
    masks = list(m._masks)
    if data.draw(st.booleans()):
        masks.append(0)
    masks = [masks[i] for i in data.draw(st.permutations(range(len(masks))))]
    order = canonical_masks(frame, masks)
    expected = sorted(masks, key=lambda mask: frame.element(names_of(frame, mask) or "empty").sort_key)
    assert [masks[i] for i in order] == expected
    table, sort_order = union_incidence(frame, masks, frame.hypotheses, sort=True)
    assert sort_order.tolist() == order


# -- a wide frame ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def wide():
    """A Bayesian mass function over 2 000 hypotheses (Dirichlet masses), as a mapping of names to masses."""
    frame = Frame([f"h{i}" for i in range(2000)])
    masses = np.random.default_rng(7).dirichlet(np.ones(2000)).tolist()
    order = np.random.default_rng(8).permutation(2000).tolist()       # keys not in frame order
    return Model.shafer(frame), {frame.hypotheses[i]: masses[i] for i in order}


def test_a_wide_bayesian_mass_function_is_measured_from_its_masks(wide):
    model, mapping = wide
    frame = model.frame
    names = frame.hypotheses

    def make():
        return MassFunction(mapping, model=model)

    exact = np.array([mapping[name] for name in names])
    settled = make()
    settled.focal
    reference = elements_only(settled)
    for measure in MEASURES:
        expected = getattr(reference, measure)(names)           # the sparse tables of the elements
        assert same_bits(expected, exact)                     # one term per hypothesis, kept exactly
        for m in (make(), settled):
            assert same_bits(getattr(m, measure)(names), expected)
            assert same_bits(getattr(m, measure)(list(names)), expected)
        assert getattr(make(), measure)("h17") == mapping["h17"]
        chosen = ["h5", "h1999", "h0"]
        assert same_bits(getattr(make(), measure)(chosen), exact[[5, 1999, 0]])
    best = names[int(np.argmax(exact))]
    for criterion in HELD_CRITERIA:
        fresh = make()
        decision = decide(fresh, criterion)
        assert fresh._focal is None and fresh._batch is None            # no element was made
        assert decision.elements == [best] and decision.value == float(exact.max())
        assert decision == decide(settled, criterion) == decide(reference, criterion)


def test_a_wide_mass_function_of_unions_and_the_empty_set(wide):
    model, mapping = wide
    frame = model.frame
    names = frame.hypotheses
    shared = {"h0|h1|h2": 0.25, "h1|h2": 0.125, "h0|h1999": 0.0625, "h2|h5|h1999": 0.0625}
    rest = 1.0 - sum(shared.values())
    mixed = {**{key: v * rest for key, v in mapping.items()}, **shared}
    fresh = MassFunction(mixed, model=model)
    reference = elements_only(MassFunction(mixed, model=model))
    for measure in MEASURES:
        assert same_bits(getattr(fresh, measure)(names), getattr(reference, measure)(names))
    assert fresh._focal is None
    for criterion in HELD_CRITERIA:
        assert decide(MassFunction(mixed, model=model), criterion) == decide(reference, criterion)
    masks, floats = list(fresh._masks), [0.5 * v for v in fresh._floats]
    with_empty = mass_from_masks(model, [*masks[:100], 0, *masks[100:]], [*floats[:100], 0.5, *floats[100:]],
                                 loose=True)
    reference = elements_only(mass_from_masks(model, [*masks[:100], 0, *masks[100:]],
                                              [*floats[:100], 0.5, *floats[100:]], loose=True))
    for measure in MEASURES:
        assert same_bits(getattr(with_empty, measure)(names), getattr(reference, measure)(names))
    assert with_empty._focal is None
    assert decide(with_empty, "betp") == decide(reference, "betp")


# -- what the masks leave to the elements' path, and the errors -----------------------------------------------
def test_other_queries_and_criteria_take_the_elements_path(wide):
    model, mapping = wide
    frame = model.frame

    def make():
        return MassFunction(mapping, model=model)

    reference = elements_only(make())
    for queries in ("h1|h2", ["h3", "h3"], ["h1", "h1|h2"], ("h1", "empty"), [frame.element("h4")]):
        for measure in MEASURES:
            assert same_bits(getattr(make(), measure)(queries), getattr(reference, measure)(queries))
    assert same_bits(make().pls(iter(["h1", "h2"])), reference.pls(["h1", "h2"]))     # read once, by the batch
    assert decide(make(), "dsmp") == decide(reference, "dsmp")
    assert decide(make(), "betp", candidates=["h1", "h2|h3"]) == decide(reference, "betp", candidates=["h1", "h2|h3"])
    assert held_measure(make(), "dsmp", frame.hypotheses) is None
    assert held_measure(make(), "bel", None) is None
    assert held_measure(MassFunction(mapping, model=Model.free(frame)), "bel", frame.hypotheses) is None


def test_total_conflict_and_bad_queries_raise_as_on_the_elements_path():
    frame = Frame([f"c{i}" for i in range(300)])
    model = Model.shafer(frame)
    conflict = mass_from_masks(model, [0], (1.0,), loose=True)
    assert held_measure(mass_from_masks(model, [0], (1.0,), loose=True), "bel", frame.hypotheses) is not None
    with pytest.raises(TotalConflictError, match=r"^BetP is undefined: total conflict, m\(∅\) = 1$"):
        decide(conflict, "betp")
    with pytest.raises(TotalConflictError, match=r"^BetP is undefined: total conflict, m\(∅\) = 1$"):
        mass_from_masks(model, [0], (1.0,), loose=True).betp(frame.hypotheses)
    with pytest.raises(TotalConflictError, match=r"^BetP is undefined: total conflict, m\(∅\) = 1$"):
        elements_only(conflict).betp(frame.hypotheses)
    assert decide(mass_from_masks(model, [0], (1.0,), loose=True), "pls") == decide(elements_only(conflict), "pls")
    assert decide(elements_only(conflict), "pls").elements == list(frame.hypotheses)
    m = MassFunction({"c0": 0.5, "c1|c2": 0.5}, model=model)
    for bad in (["c0", "nope"], [3], [["c0"]], ["c0", "c1|"]):
        with pytest.raises(Exception) as held:
            m.bel(bad)
        with pytest.raises(type(held.value)) as reference:
            elements_only(m).bel(bad)
        assert str(held.value) == str(reference.value)


def test_batches_of_rows_keep_their_path():
    frame = Frame([f"b{i}" for i in range(100)])
    model = Model.shafer(frame)
    values = np.random.default_rng(3).dirichlet(np.ones(100), size=4)
    batch = MassBatch(list(frame.hypotheses), values, model=model)
    decisions = decide(batch, "betp")
    assert [d.elements for d in decisions] == [[frame.hypotheses[int(np.argmax(row))]] for row in values]
    assert same_bits(batch.betp(frame.singletons), values)
