"""Decisions: the candidates that maximise Bel, Pls, BetP or DSmP (belief.decisions).

The library is compared with a slow, literal reading of the definitions on Venn regions
(tests/strategies.py): an element is the set of regions it covers under the model and the
DSm cardinality is the size of that set; the arithmetic is exact (Fractions).
"""

import dataclasses
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from belief import (
    Element,
    Frame,
    MassBatch,
    MassFunction,
    Model,
    TotalConflictError,
    UnknownHypothesisError,
)
from belief.decisions import CRITERIA, Decision, DecisionBatch, decide
from belief.errors import BeliefError, MeasureOptionError, UnknownMeasureError
from tests.strategies import (
    MassCase,
    elements,
    hypothesis_regions,
    mass_case_lists,
    mass_cases,
)

EPSILON = Fraction(1, 1000)
TOL = 1e-9

# -- the literal reference ----------------------------------------------------------------------------


def region_masses(mc: MassCase) -> dict[frozenset, Fraction]:
    out: dict[frozenset, Fraction] = {}
    for regions, v in mc.region_masses():
        out[regions] = out.get(regions, Fraction(0)) + Fraction(v)
    return {k: v for k, v in out.items() if v}


def literal_value(criterion: str, m: dict, a: frozenset) -> Fraction:
    """Bel, Pls, BetP or DSmP_ε of the region set ``a`` (W (8), W (9), generalised BetP, DSmP)."""
    if criterion == "bel":
        return sum((v for b, v in m.items() if b and b <= a), Fraction(0))
    if criterion == "pls":
        return sum((v for b, v in m.items() if b & a), Fraction(0))
    normal = sum(v for b, v in m.items() if b)
    mn = {b: v / normal for b, v in m.items() if b}
    if criterion == "betp":
        return sum(v * Fraction(len(a & b), len(b)) for b, v in mn.items())
    units = {z: v for z, v in mn.items() if len(z) == 1}
    total = Fraction(0)
    for x, v in mn.items():
        top = sum((w for z, w in units.items() if z <= (x & a)), Fraction(0)) + EPSILON * len(x & a)
        bottom = sum((w for z, w in units.items() if z <= x), Fraction(0)) + EPSILON * len(x)
        total += v * top / bottom
    return total


def literal_decision(criterion: str, mc: MassCase, candidates: list[frozenset]) -> tuple[list[frozenset], Fraction]:
    m = region_masses(mc)
    values = [literal_value(criterion, m, a) for a in candidates]
    best = max(values)
    # no value sits on the edge of the tolerance band, where float rounding could decide
    assume(all(abs(float(best - v) - TOL) > 1e-12 for v in values))
    return [a for a, v in zip(candidates, values) if best - v <= Fraction(TOL)], best


def default_candidates(mc: MassCase) -> list[frozenset]:
    regions = [hypothesis_regions(mc.case.n, i) & mc.case.allowed for i in range(mc.case.n)]
    return [r for r in regions if r]


def decided_regions(decision: Decision, mc: MassCase) -> list[frozenset]:
    """The chosen names read back as region sets (the names are the library's canonical forms)."""
    return [mc.case.regions(mc.case.frame.element(name)) for name in decision.elements]


def has_mass_outside_the_empty_set(mc: MassCase) -> bool:
    return any(k and v for k, v in region_masses(mc).items())


# -- literature and hand-computed values ---------------------------------------------------------------------


def test_dezert_smarandache_first_example():
    # Dezert & Smarandache, "A new probabilistic transformation of belief mass assignment" (Fusion 2008):
    # Θ = {A, B}, Shafer's model, m(A) = 0.3, m(B) = 0.1, m(A∪B) = 0.6.  BetP(A) = 0.6, BetP(B) = 0.4,
    # DSmP_0(A) = 0.3 + 0.6 · 0.3/0.4 = 0.75 and DSmP_ε(A) = 0.3 + 0.6 (0.3 + ε)/(0.4 + 2ε).
    m = MassFunction({"A": 0.3, "B": 0.1, "A|B": 0.6}, model=Model.shafer(Frame(["A", "B"])))
    betp = decide(m, "betp")
    assert betp.elements == ["A"] and betp.value == pytest.approx(0.6, abs=1e-15)
    assert decide(m, "dsmp", epsilon=0).value == pytest.approx(0.75, abs=1e-15)
    assert decide(m, "dsmp").value == pytest.approx(0.3 + 0.6 * 0.301 / 0.402, abs=1e-15)
    assert decide(m, "bel") == Decision(["A"], 0.3)
    assert decide(m, "pls").value == pytest.approx(0.9, abs=1e-15)


def test_the_criteria_can_disagree_and_tie():
    # m(a) = 0.4, m(b ∪ c) = 0.6 under Shafer's model: Bel = (0.4, 0, 0) picks a; Pls = (0.4, 0.6, 0.6)
    # ties b and c; BetP = (0.4, 0.3, 0.3) picks a.
    m = MassFunction({"a": 0.4, "b|c": 0.6}, model=Model.shafer(Frame(["a", "b", "c"])))
    assert decide(m, "bel") == Decision(["a"], 0.4)
    assert decide(m, "pls") == Decision(["b", "c"], 0.6)
    assert decide(m, "betp").elements == ["a"]
    # among compound candidates: Bel(b|c) = 0.6 beats Bel(a) = 0.4
    assert decide(m, "bel", candidates=["a", "c|b"]) == Decision(["b|c"], 0.6)


def test_free_model_decisions_count_the_shared_region():
    # Free model on {a, b}: m(a∩b) = 1 gives Bel(a) = Bel(b) = 1, BetP(a) = BetP(b) = 1 (a∩b ⊆ a and ⊆ b).
    m = MassFunction({"a&b": 1.0}, frame=["a", "b"], model="free")
    for criterion in CRITERIA:
        assert decide(m, criterion) == Decision(["a", "b"], 1.0)
    assert decide(m, "bel", candidates=["a&b", "a|b"]).elements == ["a&b", "a|b"]


def test_tolerance_decides_what_a_tie_is():
    m = MassFunction({"a": 0.5 + 1e-12, "b": 0.5 - 1e-12}, frame=["a", "b"], model="shafer")
    assert decide(m, "bel").elements == ["a", "b"]
    assert decide(m, "bel", tol=0).elements == ["a"]
    assert decide(m, "bel", tol=0.0).value == 0.5 + 1e-12
    wide = MassFunction({"a": 0.6, "b": 0.3, "c": 0.1}, frame=["a", "b", "c"], model="shafer")
    assert decide(wide, "betp", tol=0.31).elements == ["a", "b"]
    assert decide(wide, "betp", tol=1).elements == ["a", "b", "c"]


def test_hypotheses_that_the_model_removes_are_no_candidates():
    frame = Frame(["a", "b", "c"])
    model = Model.hybrid(frame, ["c", "a&b"])
    m = MassFunction({"a|b|c": 1.0}, model=model)
    assert decide(m, "betp") == Decision(["a", "b"], 0.5)
    assert decide(m, "bel") == Decision(["a", "b"], 0.0)      # c would tie at 0 if it were a candidate


# -- the library against the literal reference -------------------------------------------------------------


@settings(max_examples=40)
@given(mc=mass_cases(subnormal=None))
def test_decisions_against_the_literal_definition(mc):
    assume(has_mass_outside_the_empty_set(mc))
    m = mc.build()
    for criterion in CRITERIA:
        expected, best = literal_decision(criterion, mc, default_candidates(mc))
        got = decide(m, criterion)
        assert decided_regions(got, mc) == expected, criterion
        assert got.value == pytest.approx(float(best), abs=1e-12), criterion


@settings(max_examples=30)
@given(data=st.data())
def test_decisions_among_given_candidates_against_the_literal_definition(data):
    mc = data.draw(mass_cases(subnormal=False))
    frame = mc.case.frame
    raw = data.draw(st.lists(elements(frame), min_size=1, max_size=4))
    raw = [e for e in raw if mc.case.regions(e)]
    assume(raw)
    candidates: list[frozenset] = []
    for e in raw:
        if mc.case.regions(e) not in candidates:
            candidates.append(mc.case.regions(e))
    m = mc.build()
    for criterion in CRITERIA:
        expected, best = literal_decision(criterion, mc, candidates)
        got = decide(m, criterion, candidates=raw)
        assert decided_regions(got, mc) == expected, criterion
        assert got.value == pytest.approx(float(best), abs=1e-12), criterion


# -- ties ---------------------------------------------------------------------------------------------------------


def swap01(element: Element) -> Element:
    """The element with hypotheses 0 and 1 exchanged."""
    def swap(mask: int) -> int:
        low, high = mask & 1, mask >> 1 & 1
        return (mask & ~3) | (low << 1) | high

    return Element(element.frame, [swap(t) for t in element.terms])


@settings(max_examples=30)
@given(mc=mass_cases(min_n=2, kinds=("free", "shafer"), subnormal=False), criterion=st.sampled_from(CRITERIA))
def test_every_tied_maximiser_is_chosen(mc, criterion):
    # Averaging a mass function with its image under θ_0 <-> θ_1 makes θ_0 and θ_1 exactly
    # symmetric (the free and Shafer models are symmetric too): either both are chosen or neither.
    m = mc.build()
    masses: dict[Element, float] = {}
    for e, v in m.items():
        for x in (e, swap01(e)):
            masses[x] = masses.get(x, 0.0) + v / 2
    symmetric = MassFunction(masses, model=m.model)
    decision = decide(symmetric, criterion)
    names = m.frame.hypotheses
    assert (names[0] in decision.elements) == (names[1] in decision.elements)
    # and every chosen candidate is within the tolerance of the maximum, every other one below it
    batch = symmetric.batch()
    queries = list(m.frame.hypotheses)
    values = batch.dsmp(queries)[0] if criterion == "dsmp" else getattr(batch, criterion)(queries)[0]
    assert decision.elements == [q for q, v in zip(queries, values) if v >= decision.value - TOL]
    assert decision.value == max(values)


# -- batches ----------------------------------------------------------------------------------------------------


@settings(max_examples=20)
@given(cases=mass_case_lists(size=5), criterion=st.sampled_from(CRITERIA))
def test_batches_decide_row_by_row(cases, criterion):
    masses = [mc.build() for mc in cases]
    batch = MassBatch.from_mass_functions(masses)
    decisions = decide(batch, criterion)
    assert isinstance(decisions, DecisionBatch) and len(decisions) == len(masses)
    assert decisions.scores.shape == (len(masses), len(decisions.candidates))
    for row, m in enumerate(masses):
        one = decide(m, criterion)
        assert decisions[row].elements == one.elements
        assert decisions[row].value == pytest.approx(one.value, abs=1e-12)
        assert decisions.candidates[decisions.index[row]] == one.elements[0]
    assert decisions.elements == [decide(m, criterion).elements for m in masses]
    np.testing.assert_array_equal(decisions.tied.any(axis=1), True)


def test_a_bayesian_batch_decides_from_the_closed_forms():
    cues = MassBatch.bayesian([[0.6, 0.3, 0.1], [0.2, 0.7, 0.1], [0.45, 0.45, 0.1]], model=Model.for_targets(2))
    decisions = decide(cues, "betp")
    assert decisions.elements == [["t1"], ["t2"], ["t1", "t2"]]
    # t1 ∩ t2 is not empty under the tracking model: BetP(t1) = m(t1) + m(t2) C(t1∩t2)/C(t2) = m(t1) + m(t2)/2
    np.testing.assert_allclose(decisions.value, [0.6 + 0.15, 0.7 + 0.1, 0.45 + 0.225], atol=1e-15)
    assert list(decisions) == [decisions[0], decisions[1], decisions[2]]


# -- bad input --------------------------------------------------------------------------------------------------


def test_unknown_criterion_lists_the_known_ones():
    m = MassFunction({"a": 1.0}, frame=["a", "b"])
    with pytest.raises(UnknownMeasureError, match="known criteria: betp, bel, pls, dsmp"):
        decide(m, "maxent")
    assert decide(m, "BetP") == decide(m, "betp")
    assert issubclass(UnknownMeasureError, MeasureOptionError) and issubclass(MeasureOptionError, BeliefError)


@pytest.mark.parametrize("tol", [-1e-9, float("nan"), float("inf"), "small"])
def test_bad_tolerances_are_refused(tol):
    with pytest.raises(MeasureOptionError):
        decide(MassFunction({"a": 1.0}, frame=["a", "b"]), tol=tol)


def test_bad_candidates_are_refused():
    m = MassFunction({"a": 1.0}, frame=["a", "b"], model="shafer")
    with pytest.raises(MeasureOptionError, match="empty under the shafer model"):
        decide(m, candidates=["a", "a&b"])
    with pytest.raises(MeasureOptionError, match="at least one candidate"):
        decide(m, candidates=[])
    with pytest.raises(UnknownHypothesisError):
        decide(m, candidates=["c"])
    with pytest.raises(TypeError):
        decide({"a": 1.0})
    assert decide(m, candidates="a") == Decision(["a"], 1.0)


def test_pignistic_decisions_need_mass_outside_the_empty_set():
    dead = MassFunction({"empty": 1.0}, frame=["a", "b"], subnormal=True)
    with pytest.raises(TotalConflictError):
        decide(dead, "betp")
    with pytest.raises(TotalConflictError):
        decide(dead, "dsmp")
    assert decide(dead, "pls") == Decision(["a", "b"], 0.0)


def test_a_decision_is_a_frozen_value():
    d = decide(MassFunction({"a": 1.0}, frame=["a", "b"]))
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.value = 0.0  # type: ignore[misc]
    assert d == Decision(["a"], 1.0)
