"""Uncertainty measures (belief.uncertainty): nonspecificity, Deng's entropy, ambiguity, discord,
dissonance and confusion.

The library is compared with a slow, literal reading of the definitions on Venn regions
(tests/strategies.py): an element is the set of regions it covers under the model and |A| (the
DSm cardinality) is the size of that set; masses and the sums inside the logarithms are exact
(Fractions).
"""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import Frame, MassBatch, MassFunction, Model
from belief.errors import BeliefError, UndefinedMeasureError, UndefinedTransformError, UnknownMeasureError
from belief.uncertainty import (
    MEASURES,
    ambiguity,
    confusion,
    deng_entropy,
    discord,
    dissonance,
    is_power_set_model,
    nonspecificity,
    uncertainty,
)
from tests.strategies import MassCase, hypothesis_regions, mass_case_lists, mass_cases

# -- the literal reference ----------------------------------------------------------------------------


def region_masses(mc: MassCase) -> dict[frozenset, Fraction]:
    out: dict[frozenset, Fraction] = {}
    for regions, v in mc.region_masses():
        out[regions] = out.get(regions, Fraction(0)) + Fraction(v)
    return {k: v for k, v in out.items() if v}


def log2(x: Fraction) -> float:
    return math.log2(x.numerator) - math.log2(x.denominator)


def literal(name: str, mc: MassCase) -> float:
    m = region_masses(mc)
    assert all(m)                     # normal mass functions only
    if name == "nonspecificity":
        return sum(float(v) * math.log2(len(a)) for a, v in m.items())
    if name == "deng":
        return -sum(float(v) * log2(v / (2 ** len(a) - 1)) for a, v in m.items())
    if name == "ambiguity":
        betp = [sum((v * Fraction(len(a & (hypothesis_regions(mc.case.n, i) & mc.case.allowed)), len(a))
                     for a, v in m.items()), Fraction(0)) for i in range(mc.case.n)]
        return -sum(float(p) * log2(p) for p in betp if p)
    if name == "discord":
        inner = {a: sum(w * Fraction(len(a & b), len(b)) for b, w in m.items()) for a in m}
    elif name == "dissonance":
        inner = {a: sum(w for b, w in m.items() if a & b) for a in m}
    elif name == "confusion":
        inner = {a: sum(w for b, w in m.items() if b <= a) for a in m}
    else:
        raise AssertionError(name)
    return -sum(float(v) * log2(inner[a]) for a, v in m.items())


def shannon(probabilities) -> float:
    return -sum(p * math.log2(p) for p in probabilities if p > 0)


ANY_MODEL = ["nonspecificity", "discord", "dissonance", "confusion"]
POWER_SET = ["deng", "ambiguity"]


# -- literature values ----------------------------------------------------------------------------------------


def test_deng_examples_on_three_hypotheses():
    # Deng (2016), Examples 3.1-3.3: m(a) = 1 gives 0 (as Shannon); m(a) = m(b) = m(c) = 1/3 gives
    # log2 3 (as Shannon); m(a ∪ b ∪ c) = 1 gives log2 7, where Shannon's entropy is not defined.
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    assert deng_entropy(MassFunction({"a": 1.0}, model=shafer)) == 0.0
    assert deng_entropy(MassFunction({"a": 1 / 3, "b": 1 / 3, "c": 1 / 3}, model=shafer)) == pytest.approx(
        math.log2(3), abs=1e-12)
    assert deng_entropy(MassFunction.vacuous(model=shafer)) == pytest.approx(math.log2(7), abs=1e-12)


def _fifteen(size_of_a: int) -> MassFunction:
    """Deng (2016), Example 3.5: Θ = {1, ..., 15}, m({3,4,5}) = 0.05, m({6}) = 0.05, m(A) = 0.8 with
    A = {1, ..., k}, m(Θ) = 0.1."""
    shafer = Model.shafer(Frame.numbered(15, prefix="h"))

    def union(*ids):
        return "|".join(f"h{i}" for i in ids)

    return MassFunction({union(3, 4, 5): 0.05, union(6): 0.05, union(*range(1, size_of_a + 1)): 0.8,
                         union(*range(1, 16)): 0.1}, model=shafer)


@pytest.mark.parametrize("size_of_a, published", [(1, 2.6623), (2, 3.9303), (3, 4.9082), (14, 13.8622)])
def test_deng_entropy_of_deng_table(size_of_a, published):
    # Deng (2016), Table 1 (four decimals): the entropy grows with |A|.
    assert deng_entropy(_fifteen(size_of_a)) == pytest.approx(published, abs=5e-5)


@pytest.mark.parametrize("size_of_a", [1, 2, 7, 14])
def test_nonspecificity_of_deng_example_by_hand(size_of_a):
    # Dubois & Prade (1985) on the same mass function: N = 0.05 log2 3 + 0.05 log2 1 + 0.8 log2 k + 0.1 log2 15.
    expected = 0.05 * math.log2(3) + 0.8 * math.log2(size_of_a) + 0.1 * math.log2(15)
    assert nonspecificity(_fifteen(size_of_a)) == pytest.approx(expected, abs=1e-12)


def test_nonspecificity_examples():
    # Dubois & Prade (1985): N is the Hartley measure log2 |A| for a categorical m(A) = 1, and 0 for
    # Bayesian mass functions.
    shafer = Model.shafer(Frame(["a", "b", "c", "d"]))
    assert nonspecificity(MassFunction({"a|b": 0.5, "a|b|c|d": 0.5}, model=shafer)) == pytest.approx(1.5, abs=1e-15)
    assert nonspecificity(MassFunction.vacuous(model=shafer)) == pytest.approx(2.0, abs=1e-15)
    assert nonspecificity(MassFunction({"a": 0.2, "d": 0.8}, model=shafer)) == 0.0
    # On the free model |a ∪ b| counts three Venn regions (a only, b only, a∩b), |a| two.
    free = MassFunction({"a|b": 0.5, "a": 0.5}, frame=["a", "b"], model="free")
    assert nonspecificity(free) == pytest.approx(0.5 * math.log2(3) + 0.5, abs=1e-15)


def test_ambiguity_examples():
    # Jousselme et al. (2006): AM is the Shannon entropy of BetP; log2 |Θ| for total ignorance.
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    assert ambiguity(MassFunction.vacuous(model=shafer)) == pytest.approx(math.log2(3), abs=1e-12)
    # Zadeh's first expert: BetP = (0.9, 0, 0.1)
    assert ambiguity(MassFunction({"a": 0.9, "c": 0.1}, model=shafer)) == pytest.approx(
        -0.9 * math.log2(0.9) - 0.1 * math.log2(0.1), abs=1e-12)
    # m(a) = 0.5, m(b ∪ c) = 0.5: BetP = (0.5, 0.25, 0.25), AM = 1.5
    assert ambiguity(MassFunction({"a": 0.5, "b|c": 0.5}, model=shafer)) == pytest.approx(1.5, abs=1e-12)


def test_conflict_measures_on_dezert_smarandache_example():
    # m(A) = 0.3, m(B) = 0.1, m(A∪B) = 0.6 (Dezert & Smarandache 2008), by hand:
    # Bel = (0.3, 0.1, 1), BetP = (0.6, 0.4, 1), Pls = (0.9, 0.7, 1) on A, B, A∪B.
    m = MassFunction({"A": 0.3, "B": 0.1, "A|B": 0.6}, model=Model.shafer(Frame(["A", "B"])))
    assert confusion(m) == pytest.approx(-0.3 * math.log2(0.3) - 0.1 * math.log2(0.1), abs=1e-12)      # Höhle 1982
    assert discord(m) == pytest.approx(-0.3 * math.log2(0.6) - 0.1 * math.log2(0.4), abs=1e-12)        # Klir-Ramer
    assert dissonance(m) == pytest.approx(-0.3 * math.log2(0.9) - 0.1 * math.log2(0.7), abs=1e-12)     # Yager 1983
    assert deng_entropy(m) == pytest.approx(-0.3 * math.log2(0.3) - 0.1 * math.log2(0.1)
                                            - 0.6 * math.log2(0.6 / 3), abs=1e-12)


def test_two_even_bets_disagree_by_one_bit():
    # Klir & Ramer (1990): two disjoint focal elements with mass 1/2 each give a discord of one bit.
    m = MassFunction({"a": 0.5, "b|c": 0.5}, model=Model.shafer(Frame(["a", "b", "c"])))
    assert discord(m) == pytest.approx(1.0, abs=1e-15)
    assert dissonance(m) == pytest.approx(1.0, abs=1e-15)
    assert confusion(m) == pytest.approx(1.0, abs=1e-15)


# -- the library against the literal reference -------------------------------------------------------------


@settings(max_examples=50)
@given(mc=mass_cases(subnormal=False))
def test_measures_on_every_model_against_the_literal_definition(mc):
    m = mc.build()
    for name in ANY_MODEL:
        assert MEASURES[name](m) == pytest.approx(literal(name, mc), abs=1e-9), name


@settings(max_examples=40)
@given(mc=mass_cases(kinds=("shafer",), subnormal=False))
def test_measures_on_shafer_model_against_the_literal_definition(mc):
    m = mc.build()
    for name in POWER_SET + ANY_MODEL:
        assert MEASURES[name](m) == pytest.approx(literal(name, mc), abs=1e-9), name


# -- laws ------------------------------------------------------------------------------------------------------------


@settings(max_examples=30)
@given(mc=mass_cases(subnormal=False))
def test_measures_are_non_negative_and_ordered(mc):
    m = mc.build()
    values = uncertainty(m)
    assert all(v >= 0.0 for v in values.values())
    # Bel(A) ≤ BetP(A) ≤ Pls(A) for every focal A, so dissonance ≤ discord ≤ confusion
    assert values["dissonance"] <= values["discord"] + 1e-12
    assert values["discord"] <= values["confusion"] + 1e-12
    if is_power_set_model(m.model):
        # 2^|A| - 1 ≥ |A|: Deng's entropy is at least the nonspecificity plus the Shannon entropy of m
        assert values["deng"] >= values["nonspecificity"] + shannon(m.values) - 1e-12
    else:
        assert set(values) == set(ANY_MODEL)


@st.composite
def bayesian_masses(draw):
    n = draw(st.integers(1, 5))
    weights = draw(st.lists(st.integers(0, 20), min_size=n, max_size=n).filter(any))
    total = sum(weights)
    model = Model.shafer(Frame.numbered(n))
    return MassFunction({name: w / total for name, w in zip(model.frame.hypotheses, weights)}, model=model)


@settings(max_examples=30)
@given(m=bayesian_masses())
def test_bayesian_mass_functions_reduce_every_entropy_to_shannon(m):
    h = shannon(m.values)
    values = uncertainty(m)
    assert values.pop("nonspecificity") == 0.0
    for name, value in values.items():
        assert value == pytest.approx(h, abs=1e-12), name


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_total_ignorance(n):
    m = MassFunction.vacuous(model=Model.shafer(Frame.numbered(n)))
    assert nonspecificity(m) == pytest.approx(math.log2(n), abs=1e-12)
    assert ambiguity(m) == pytest.approx(math.log2(n), abs=1e-12)
    assert deng_entropy(m) == pytest.approx(math.log2(2 ** n - 1), abs=1e-12)
    assert discord(m) == dissonance(m) == confusion(m) == 0.0


@settings(max_examples=30)
@given(mc=mass_cases(kinds=("free",), subnormal=False))
def test_no_dissonance_on_the_free_model(mc):
    # every non-empty element of the free model holds the region "all hypotheses", so Pls(A) = 1
    assert dissonance(mc.build()) == pytest.approx(0.0, abs=1e-12)     # Pls(A) = Σ m rounds to 1 - 1e-16


@settings(max_examples=30)
@given(data=st.data())
def test_consonant_evidence_has_no_dissonance(data):
    # nested focal elements a ⊂ a|b ⊂ a|b|c ... under any of the library's models
    n = data.draw(st.integers(1, 4))
    frame = Frame.numbered(n)
    model = data.draw(st.sampled_from([Model.free(frame), Model.shafer(frame)]))
    weights = data.draw(st.lists(st.integers(0, 9), min_size=n, max_size=n).filter(any))
    names = frame.hypotheses
    m = MassFunction({"|".join(names[:k + 1]): w / sum(weights) for k, w in enumerate(weights)}, model=model)
    assert dissonance(m) == pytest.approx(0.0, abs=1e-12)


def test_hybrid_power_set_models_count_only_the_hypotheses_that_exist():
    frame = Frame(["a", "b", "c"])
    model = Model.hybrid(frame, ["a&b", "a&c", "b&c", "c"])       # c does not exist: D^Θ is 2^{a, b}
    assert is_power_set_model(model)
    m = MassFunction({"a|b|c": 1.0}, model=model)
    assert nonspecificity(m) == pytest.approx(1.0, abs=1e-15)
    assert deng_entropy(m) == pytest.approx(math.log2(3), abs=1e-12)
    assert ambiguity(m) == pytest.approx(1.0, abs=1e-12)


# -- batches ----------------------------------------------------------------------------------------------------


@settings(max_examples=15)
@given(cases=mass_case_lists(size=5))
def test_batches_give_the_row_by_row_measures(cases):
    masses = [mc.build() for mc in cases]
    batch = MassBatch.from_mass_functions(masses)
    got = uncertainty(batch)
    assert list(got) == list(uncertainty(masses[0]))
    for name, values in got.items():
        assert isinstance(values, np.ndarray) and values.shape == (len(masses),)
        np.testing.assert_allclose(values, [MEASURES[name](m) for m in masses], rtol=0, atol=1e-12)


# -- bad input --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(MEASURES))
def test_mass_on_the_empty_set_is_refused(name):
    m = MassFunction({"empty": 0.2, "a": 0.8}, model=Model.shafer(Frame(["a", "b"])), subnormal=True)
    with pytest.raises(UndefinedMeasureError, match=r"m\(∅\) > 0"):
        MEASURES[name](m)
    batch = MassBatch.from_mass_functions([MassFunction({"a": 1.0}, model=m.model), m])
    with pytest.raises(UndefinedMeasureError, match=r"row 1"):
        MEASURES[name](batch)


@pytest.mark.parametrize("name", POWER_SET)
@pytest.mark.parametrize("model", [Model.free(Frame(["a", "b"])), Model.tracking(Frame(["a", "b", "FA"])),
                                   Model.hybrid(Frame(["a", "b", "c"]), ["a&b"])])
def test_power_set_measures_are_refused_on_other_models(name, model):
    m = MassFunction({"a": 1.0}, model=model)
    with pytest.raises(UndefinedMeasureError, match="power sets only"):
        MEASURES[name](m)
    with pytest.raises(UndefinedMeasureError):
        uncertainty(m, [name])
    assert name not in uncertainty(m)
    assert issubclass(UndefinedMeasureError, UndefinedTransformError) and issubclass(UndefinedMeasureError,
                                                                                      BeliefError)


def test_unknown_measures_are_refused_with_the_known_names():
    m = MassFunction({"a": 1.0}, frame=["a", "b"], model="shafer")
    with pytest.raises(UnknownMeasureError, match="known measures: nonspecificity, deng, ambiguity"):
        uncertainty(m, ["shannon"])
    assert uncertainty(m, "discord") == {"discord": 0.0}
    with pytest.raises(TypeError):
        nonspecificity({"a": 1.0})
