"""Distances between mass functions and the conflict between sources (belief.distances).

The library is compared with a slow, literal reading of the definitions: every element is
the set of Venn regions it covers under the model (tests/strategies.py), the DSm
cardinality is the size of that set, and the arithmetic is exact (Fractions).
"""

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from belief import (
    Frame,
    FrameError,
    InvalidMassError,
    MassBatch,
    MassFunction,
    Model,
    ModelError,
    TotalConflictError,
    inconsistency,
)
from belief.distances import (
    DISTANCES,
    conflict,
    distance,
    euclidean_distance,
    jousselme_distance,
    jousselme_matrix,
    tessem_distance,
)
from belief.errors import BeliefError, UnknownMeasureError
from tests.strategies import (
    FusionCase,
    MassCase,
    any_model_cases,
    fusion_cases,
    hypothesis_regions,
    mass_case_lists,
    mass_cases_under,
    regions_of,
)

# -- the literal reference ----------------------------------------------------------------------------


def region_masses(mc: MassCase) -> dict[frozenset, Fraction]:
    """{region set under the model: exact mass}; the empty region set is ∅."""
    out: dict[frozenset, Fraction] = {}
    for regions, v in mc.region_masses():
        out[regions] = out.get(regions, Fraction(0)) + Fraction(v)
    return {k: v for k, v in out.items() if v}


def literal_jaccard(a: frozenset, b: frozenset) -> Fraction:
    if not a and not b:
        return Fraction(1)            # the convention D_∅∅ = 1
    if not a or not b:
        return Fraction(0)
    return Fraction(len(a & b), len(a | b))


def literal_jousselme(m1: dict, m2: dict) -> float:
    keys = set(m1) | set(m2)
    delta = {k: m1.get(k, Fraction(0)) - m2.get(k, Fraction(0)) for k in keys}
    total = sum(delta[a] * delta[b] * literal_jaccard(a, b) for a in keys for b in keys)
    return math.sqrt(total / 2)


def literal_euclidean(m1: dict, m2: dict) -> float:
    keys = set(m1) | set(m2)
    return math.sqrt(sum((m1.get(k, Fraction(0)) - m2.get(k, Fraction(0))) ** 2 for k in keys) / 2)


def singleton_regions(mc: MassCase, i: int) -> frozenset:
    return hypothesis_regions(mc.case.n, i) & mc.case.allowed


def literal_tessem(mc1: MassCase, mc2: MassCase) -> float:
    def betp(mc):
        m = region_masses(mc)
        normal = sum(v for k, v in m.items() if k)
        return [sum(v * Fraction(len(k & singleton_regions(mc, i)), len(k)) for k, v in m.items() if k) / normal
                for i in range(mc.case.n)]

    return float(max(abs(a - b) for a, b in zip(betp(mc1), betp(mc2))))


def literal_conflict(fc: FusionCase) -> Fraction:
    """Σ of the products of the tuples whose regions (under the fusion model) have no common region."""
    total = Fraction(0)
    for combo in itertools.product(*fc.sources):
        common = fc.fusion.allowed
        product = Fraction(1)
        for element, mass in combo:
            common = common & regions_of(element)
            product *= mass
        if not common:
            total += product
    return total


@st.composite
def mass_pairs(draw, count: int = 2, subnormal=None, kinds=("free", "shafer", "hybrid", "tracking")):
    """``count`` raw mass functions under one random model."""
    case = draw(any_model_cases(1, 4, kinds))
    assume(case.allowed)
    return [draw(mass_cases_under(case, subnormal=subnormal)) for _ in range(count)]


# -- literature values ----------------------------------------------------------------------------------------


def _jousselme_example(size_of_a: int):
    """Jousselme, Grenier & Bossé (2001), Section 5: |Θ| = 20, m2({1,...,5}) = 1 and
    m1({2,3,4}) = 0.05, m1({7}) = 0.05, m1(Θ) = 0.1, m1(A) = 0.8 with A = {1, ..., k}."""
    shafer = Model.shafer(Frame.numbered(20, prefix="h"))

    def union(*ids):
        return "|".join(f"h{i}" for i in ids)

    m1 = MassFunction({union(2, 3, 4): 0.05, union(7): 0.05, union(*range(1, 21)): 0.1,
                       union(*range(1, size_of_a + 1)): 0.8}, model=shafer)
    m2 = MassFunction({union(1, 2, 3, 4, 5): 1.0}, model=shafer)
    return m1, m2


@pytest.mark.parametrize("size_of_a, published", [(1, 0.7858), (3, 0.5705), (4, 0.4237), (5, 0.1323),
                                                  (6, 0.3884), (10, 0.6554)])
def test_jousselme_distance_of_the_jousselme_grenier_bosse_example(size_of_a, published):
    # The distance values of Jousselme et al. (2001), four decimals; smallest when A = {1..5}.
    m1, m2 = _jousselme_example(size_of_a)
    assert jousselme_distance(m1, m2) == pytest.approx(published, abs=5e-5)


def test_jousselme_distance_by_hand_for_a_equal_to_the_second_focal_element():
    # The same example with A = {1..5}: Δ = (0.05, 0.05, 0.1, -0.2) on {2,3,4}, {7}, Θ, A, and the
    # Jaccard weights 3/20, 3/5, 1/20, 1/4 between them give Δᵀ D Δ = 0.055 - 0.02 = 0.035.
    m1, m2 = _jousselme_example(5)
    assert jousselme_distance(m1, m2) == pytest.approx(math.sqrt(0.035 / 2), abs=1e-12)


def test_zadeh_example_conflict_and_betting_commitments():
    # Zadeh's example (Zadeh 1986): K = 0.99; BetP1 = (0.9, 0, 0.1), BetP2 = (0, 0.9, 0.1), so Tessem's
    # (and Liu's 2006) distance between betting commitments is 0.9.
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m1 = MassFunction({"a": 0.9, "c": 0.1}, model=shafer)
    m2 = MassFunction({"b": 0.9, "c": 0.1}, model=shafer)
    assert conflict(m1, m2) == pytest.approx(0.99, abs=1e-15)
    assert tessem_distance(m1, m2) == pytest.approx(0.9, abs=1e-15)
    assert euclidean_distance(m1, m2) == pytest.approx(0.9, abs=1e-15)          # sqrt(½ (0.81 + 0.81))
    assert jousselme_distance(m1, m2) == pytest.approx(0.9, abs=1e-15)          # disjoint singletons: D = I


def test_three_source_conflict_by_hand():
    # Three sources on {a, b} (Shafer): the only conflict-free tuples are those whose intersection is a or b.
    shafer = Model.shafer(Frame(["a", "b"]))
    m1 = MassFunction({"a": 0.6, "a|b": 0.4}, model=shafer)
    m2 = MassFunction({"b": 0.5, "a|b": 0.5}, model=shafer)
    m3 = MassFunction({"a": 0.2, "b": 0.8}, model=shafer)
    # a∩b: 0.6·0.5 (any m3) = 0.3; a∩(a|b)∩b: 0.6·0.5·0.8 = 0.24; (a|b)∩b∩a: 0.4·0.5·0.2 = 0.04
    assert conflict(m1, m2, m3) == pytest.approx(0.3 + 0.24 + 0.04, abs=1e-15)
    assert conflict([m1, m2, m3]) == conflict(m1, m2, m3)


def test_the_free_model_has_no_conflict_but_the_tracking_model_has():
    frame = Frame(["t1", "t2", "FA"])
    m1 = MassFunction({"t1": 0.7, "FA": 0.3}, frame=frame, model="free")
    m2 = MassFunction({"t2": 0.6, "FA": 0.4}, frame=frame, model="free")
    assert conflict(m1, m2) == 0.0
    tracking = Model.tracking(frame)
    # Dynamic fusion under the tracking model: t1∩FA, FA∩t2 are empty, t1∩t2 is not.
    assert conflict(m1, m2, model=tracking) == pytest.approx(0.7 * 0.4 + 0.3 * 0.6, abs=1e-15)


def test_jousselme_matrix_on_the_free_model():
    # Free model on {a, b}: a and b hold two regions each, one of them shared; a|b holds three.
    f = Frame(["a", "b"])
    d = jousselme_matrix(Model.free(f), (f.empty, f["a"], f["b"], f["a"] & f["b"], f.total))
    expected = np.array([[1, 0, 0, 0, 0],
                         [0, 1, 1 / 3, 1 / 2, 2 / 3],
                         [0, 1 / 3, 1, 1 / 2, 2 / 3],
                         [0, 1 / 2, 1 / 2, 1, 1 / 3],
                         [0, 2 / 3, 2 / 3, 1 / 3, 1]])
    np.testing.assert_allclose(d, expected, atol=1e-15)


# -- the library against the literal reference -------------------------------------------------------------


@settings(max_examples=30)
@given(pair=mass_pairs())
def test_jousselme_and_euclidean_against_the_literal_definition(pair):
    mc1, mc2 = pair
    m1, m2 = mc1.build(), mc2.build()
    r1, r2 = region_masses(mc1), region_masses(mc2)
    assert jousselme_distance(m1, m2) == pytest.approx(literal_jousselme(r1, r2), abs=1e-9)
    assert euclidean_distance(m1, m2) == pytest.approx(literal_euclidean(r1, r2), abs=1e-12)


@settings(max_examples=20)
@given(pair=mass_pairs(subnormal=False))
def test_tessem_against_the_literal_definition(pair):
    mc1, mc2 = pair
    assert tessem_distance(mc1.build(), mc2.build()) == pytest.approx(literal_tessem(mc1, mc2), abs=1e-12)


@settings(max_examples=20)
@given(pair=mass_pairs(subnormal=False))
def test_normal_distances_match_the_inconsistency_modes_of_the_rules(pair):
    # SPEC A.4 defines the "euclid" and "jousselme" readings of W (10) with the same formulas.
    m1, m2 = (mc.build() for mc in pair)
    assert euclidean_distance(m1, m2) == pytest.approx(float(inconsistency(m1, m2, r_mode="euclid")[0]), abs=1e-12)
    assert jousselme_distance(m1, m2) == pytest.approx(float(inconsistency(m1, m2, r_mode="jousselme")[0]),
                                                       abs=1e-9)


@settings(max_examples=25)
@given(fc=fusion_cases(max_sources=3, dynamic=None))
def test_conflict_against_the_literal_definition(fc):
    model = fc.fusion.model if fc.dynamic else None
    assert conflict(*fc.build(), model=model) == pytest.approx(float(literal_conflict(fc)), abs=1e-12)


# -- metric laws ------------------------------------------------------------------------------------------------


METRICS = ["jousselme", "euclidean"]


@settings(max_examples=40)
@given(triple=mass_pairs(count=3, subnormal=False))
def test_every_distance_is_symmetric_bounded_and_satisfies_the_triangle_inequality(triple):
    a, b, c = (mc.build() for mc in triple)
    for kind in DISTANCES:
        ab, ba, bc, ac = distance(a, b, kind), distance(b, a, kind), distance(b, c, kind), distance(a, c, kind)
        assert ab == pytest.approx(ba, abs=1e-12), kind
        assert 0.0 <= ab <= 1.0 + 1e-12, kind
        assert ac <= ab + bc + 1e-9, kind
        assert distance(a, a, kind) == pytest.approx(0.0, abs=1e-7), kind


@settings(max_examples=30)
@given(pair=mass_pairs(subnormal=None), kind=st.sampled_from(METRICS))
def test_metrics_are_zero_exactly_between_equal_mass_functions(pair, kind):
    mc1, mc2 = pair
    m1, m2 = mc1.build(), mc2.build()
    d = distance(m1, m2, kind)
    if m1.isclose(m2, rel_tol=0, abs_tol=1e-12):
        assert d == pytest.approx(0.0, abs=1e-7)
    else:
        # the masses are ratios of small integers: different mass functions differ far beyond rounding
        assert d > 1e-6, (m1, m2)


@settings(max_examples=20)
@given(pair=mass_pairs(subnormal=False))
def test_tessem_is_zero_exactly_between_equal_pignistic_probabilities(pair):
    m1, m2 = (mc.build() for mc in pair)
    p1, p2 = m1.batch().pignistic()[0], m2.batch().pignistic()[0]
    d = tessem_distance(m1, m2)
    assert (d <= 1e-12) == bool(np.allclose(p1, p2, rtol=0, atol=1e-12))


def test_tessem_is_only_a_pseudo_metric():
    # Two different mass functions with the same bets are at distance 0.
    shafer = Model.shafer(Frame(["a", "b"]))
    vacuous = MassFunction.vacuous(model=shafer)
    uniform = MassFunction({"a": 0.5, "b": 0.5}, model=shafer)
    assert tessem_distance(vacuous, uniform) == 0.0
    assert jousselme_distance(vacuous, uniform) > 0.0


# -- batches ------------------------------------------------------------------------------------------------------


@settings(max_examples=20)
@given(cases=mass_case_lists(size=4), kind=st.sampled_from(sorted(DISTANCES)))
def test_batches_give_the_row_by_row_distances(cases, kind):
    masses = [mc.build() for mc in cases]
    batch = MassBatch.from_mass_functions(masses)
    reversed_batch = MassBatch.from_mass_functions(masses[::-1])
    got = distance(batch, reversed_batch, kind)
    assert isinstance(got, np.ndarray) and got.shape == (len(masses),)
    expected = [distance(a, b, kind) for a, b in zip(masses, masses[::-1])]
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    # a single mass function is broadcast against every row
    np.testing.assert_allclose(distance(masses[0], batch, kind), [distance(masses[0], m, kind) for m in masses],
                               rtol=0, atol=1e-12)


@settings(max_examples=15)
@given(cases=mass_case_lists(size=4))
def test_batch_conflict_is_the_row_by_row_conflict(cases):
    masses = [mc.build() for mc in cases]
    batch = MassBatch.from_mass_functions(masses)
    other = MassBatch.from_mass_functions(masses[::-1])
    got = conflict(batch, other, masses[0])
    assert isinstance(got, np.ndarray) and got.shape == (len(masses),)
    np.testing.assert_allclose(got, [conflict(a, b, masses[0]) for a, b in zip(masses, masses[::-1])],
                               rtol=0, atol=1e-12)


def test_bayesian_batches_use_the_closed_forms_and_agree():
    model = Model.for_targets(2)
    a = MassBatch.bayesian([[0.6, 0.3, 0.1], [0.2, 0.7, 0.1]], model=model)
    b = MassBatch.bayesian([[0.2, 0.7, 0.1], [0.2, 0.7, 0.1]], model=model)
    # tracking model: t1∩FA and t2∩FA are empty, t1∩t2 is not
    np.testing.assert_allclose(conflict(a, b), [0.6 * 0.1 + 0.3 * 0.1 + 0.1 * 0.9, 0.2 * 0.1 + 0.7 * 0.1 + 0.1 * 0.9],
                               atol=1e-15)
    assert euclidean_distance(a, b)[0] == pytest.approx(0.4, abs=1e-12)     # SPEC A.4: euclid R = 0.400


# -- bad input -----------------------------------------------------------------------------------------------------


def test_unknown_kind_lists_the_known_ones():
    m = MassFunction({"a": 1.0}, frame=["a", "b"])
    with pytest.raises(UnknownMeasureError, match="known distances: jousselme, euclidean, tessem"):
        distance(m, m, kind="hamming")
    with pytest.raises(UnknownMeasureError):
        distance(m, m, kind=None)
    assert distance(m, m, kind="JOUSSELME") == 0.0
    assert issubclass(UnknownMeasureError, BeliefError) and issubclass(UnknownMeasureError, ValueError)


@pytest.mark.parametrize("function", [jousselme_distance, euclidean_distance, tessem_distance, conflict])
def test_different_frames_or_models_are_refused(function):
    m1 = MassFunction({"a": 1.0}, frame=["a", "b"])
    with pytest.raises(FrameError):
        function(m1, MassFunction({"a": 1.0}, frame=["a", "c"]))
    with pytest.raises(ModelError):
        function(m1, MassFunction({"a": 1.0}, frame=["a", "b"], model="free"))
    with pytest.raises(TypeError):
        function(m1, {"a": 1.0})


def test_batches_of_different_lengths_and_too_few_sources_are_refused():
    model = Model.shafer(Frame(["a", "b"]))
    two = MassBatch.bayesian([[0.5, 0.5], [1.0, 0.0]], model=model)
    three = MassBatch.bayesian([[0.5, 0.5], [1.0, 0.0], [0.0, 1.0]], model=model)
    with pytest.raises(InvalidMassError):
        jousselme_distance(two, three)
    with pytest.raises(InvalidMassError):
        conflict(two, three)
    with pytest.raises(InvalidMassError):
        conflict(two)


def test_tessem_needs_some_mass_outside_the_empty_set():
    shafer = Model.shafer(Frame(["a", "b"]))
    dead = MassFunction({"empty": 1.0}, model=shafer, subnormal=True)
    with pytest.raises(TotalConflictError):
        tessem_distance(dead, MassFunction({"a": 1.0}, model=shafer))
    # Jousselme's distance is defined there: ∅ is an element like the others (D_∅∅ = 1).
    assert jousselme_distance(dead, MassFunction({"a": 1.0}, model=shafer)) == pytest.approx(1.0)
