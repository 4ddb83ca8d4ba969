"""Combination rules against the slow literal reference (tests/reference_rules.py), batches, literature values,
errors and aliases."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import (
    BeliefError,
    CombinationTooLargeError,
    Frame,
    FrameError,
    InvalidMassError,
    MassBatch,
    MassFunction,
    Model,
    ModelError,
    RULES,
    TotalConflictError,
    UnknownRuleError,
    combine,
    sequential,
)
from belief.rules import get_rule, inconsistency, rule_names
from tests.reference_rules import (
    RefModelError,
    RefTotalConflict,
    add,
    ref_combine,
    ref_r_fold,
    ref_sources,
    regions_result,
)
from tests.strategies import (
    FusionCase,
    ModelCase,
    exact_weights,
    fusion_cases,
    mass_cases,
    mass_cases_under,
    tracking_allowed,
    weight_lists,
)

# The slow, literal reference of every rule, in exact arithmetic, is tests/reference_rules.py.


# -- comparison helpers -----------------------------------------------------------------------------------


def assert_matches(actual: dict, expected: dict, tol: float = 1e-12) -> None:
    for key in set(actual) | set(expected):
        got, want = actual.get(key, 0.0), float(expected.get(key, 0))
        assert math.isclose(got, want, rel_tol=1e-9, abs_tol=tol), (sorted(key), got, want)


ALL_RULES = ["conjunctive", "dsmc", "dempster", "disjunctive", "yager", "dubois_prade", "dsmh",
             "pcr5", "pcr6", "r_rule"]
EXPECTED_ERRORS = {RefModelError: ModelError, RefTotalConflict: TotalConflictError}


def check_against_reference(fc: FusionCase, rule: str, **options) -> None:
    masses = fc.build()
    model = fc.fusion.model if fc.dynamic else None
    try:
        expected = ref_combine(rule, ref_sources(fc), fc.fusion.allowed, **options)
    except (RefModelError, RefTotalConflict) as exc:
        with pytest.raises(EXPECTED_ERRORS[type(exc)]):
            combine(*masses, rule=rule, model=model, **options)
        return
    result = combine(*masses, rule=rule, model=model, **options)
    assert isinstance(result, MassFunction)
    assert result.model == fc.fusion.model
    assert_matches(regions_result(result, fc.fusion), expected)


# -- the rules against the reference ------------------------------------------------------------------------


def test_the_registry_holds_the_rules_under_test():
    assert set(ALL_RULES) <= set(RULES)


@pytest.mark.parametrize("rule", ALL_RULES)
@settings(max_examples=40)
@given(fc=fusion_cases(dynamic=False))
def test_static_fusion_matches_the_reference(rule, fc):
    check_against_reference(fc, rule)


@pytest.mark.parametrize("rule", ALL_RULES)
@settings(max_examples=40)
@given(fc=fusion_cases(dynamic=True))
def test_dynamic_fusion_matches_the_reference(rule, fc):
    # The fusion model is stricter than the sources' model: focal elements may shrink or vanish.
    # PCR5, PCR6 and the R-rule refuse vanishing elements with ModelError (the reference raises).
    check_against_reference(fc, rule)


@pytest.mark.parametrize("r_mode", ["paper", "euclid", "jousselme"])
@pytest.mark.parametrize("empty_mode", ["union", "empty"])
@settings(max_examples=25)
@given(fc=fusion_cases(dynamic=None, max_sources=3))
def test_r_rule_modes_match_the_reference(r_mode, empty_mode, fc):
    check_against_reference(fc, "r_rule", r_mode=r_mode, empty_mode=empty_mode)


@pytest.mark.parametrize("rule", ["conjunctive", "dsmc", "dempster", "disjunctive"])
@settings(max_examples=40)
@given(data=st.data())
def test_subnormal_sources_where_the_rule_accepts_them(rule, data):
    # The conjunctive rules keep ∅ absorbing (∅ ∩ X = ∅) and the disjunctive rule keeps it
    # neutral (∅ ∪ X = X), so open-world sources with m(∅) > 0 are fine for them.
    mcs = [data.draw(mass_cases(min_n=1, max_n=3, subnormal=None))]
    case = mcs[0].case
    for _ in range(data.draw(st.integers(1, 2))):
        mcs.append(data.draw(mass_cases_under(case, subnormal=None)))
    sources = []
    for mc in mcs:
        merged: dict[frozenset, Fraction] = {}
        for regions, v in mc.region_masses():
            add(merged, regions, Fraction(v))
        sources.append(list(merged.items()))
    masses = [mc.build() for mc in mcs]
    try:
        expected = ref_combine(rule, sources, case.allowed)
    except RefTotalConflict:
        with pytest.raises(TotalConflictError):
            combine(*masses, rule=rule)
        return
    # the masses are floats here (w / total), so compare with a slightly looser tolerance
    assert_matches(regions_result(combine(*masses, rule=rule), case), expected, tol=1e-9)


# -- batches equal row by row ---------------------------------------------------------------------------------


@st.composite
def batch_cases(draw, max_sources: int = 3, max_rows: int = 4):
    """Sources as batches over fixed focal lists with N rows (zeros allowed), and a fusion model."""
    fc = draw(fusion_cases(max_sources=max_sources, dynamic=None))
    rows = draw(st.integers(1, max_rows))
    batches = []
    for entries in fc.sources:
        focal = [e for e, _ in entries]
        table = []
        one_row = draw(st.integers(0, 4)) == 0   # now and then a one-row batch, broadcast
        for _ in range(1 if one_row else rows):
            weights = draw(weight_lists(0, 9, len(focal)))
            if not any(weights):
                weights[-1] = 1
            table.append([float(f) for f in exact_weights(weights)])
        batches.append(MassBatch(focal, table, model=fc.source.model))
    return fc, batches, rows


def try_combine(*sources, **kwargs):
    try:
        return combine(*sources, **kwargs)
    except BeliefError as exc:
        return exc


@pytest.mark.parametrize("rule", ALL_RULES)
@settings(max_examples=30)
@given(data=batch_cases())
def test_batches_equal_row_by_row_results(rule, data):
    fc, batches, rows = data
    model = fc.fusion.model if fc.dynamic else None
    n = max(len(b) for b in batches)
    assert n in (1, rows)
    singles = [try_combine(*(b[i if len(b) > 1 else 0] for b in batches), rule=rule, model=model)
               for i in range(n)]
    result = try_combine(*batches, rule=rule, model=model)
    failed = [s for s in singles if isinstance(s, Exception)]
    if failed:
        # a row that cannot be combined makes the whole batch fail, with the same error
        assert isinstance(result, type(failed[0])), (result, failed[0])
        return
    if isinstance(result, ModelError):
        # A focal element of a batch vanishes under the fusion model but carries no mass in any
        # row: the batch is refused from its focal list alone.  Only acceptable in that case.
        zero_columns = [e for b in batches for j, e in enumerate(b.focal)
                        if not b.values[:, j].any() and fc.fusion.model.is_empty(e)]
        assert zero_columns, result
        return
    assert isinstance(result, MassBatch), result
    assert len(result) == n and result.model == fc.fusion.model
    for i in range(n):
        assert result[i].isclose(singles[i], rel_tol=1e-9, abs_tol=1e-12), (i, result[i], singles[i])


@pytest.mark.parametrize("rule", ["conjunctive", "dempster", "dsmh", "pcr6", "r_rule"])
def test_mass_functions_and_batches_mix(rule):
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    batch = MassBatch(["a", "b", "a|b|c"], [[0.5, 0.2, 0.3], [0.1, 0.6, 0.3], [0.0, 0.0, 1.0]], model=shafer)
    m = MassFunction({"a": 0.3, "c": 0.3, "b|c": 0.4}, model=shafer)
    result = combine(batch, m, rule=rule)
    assert isinstance(result, MassBatch) and len(result) == 3
    for i in range(3):
        assert result[i].isclose(combine(batch[i], m, rule=rule))
    # a list of sources is accepted as well
    assert combine([batch[0], m], rule=rule) == combine(batch[0], m, rule=rule)


# -- literature values ------------------------------------------------------------------------------------------

ZADEH = Frame(["A", "B", "C"])


def zadeh_sources(model):
    # Zadeh's example (L. Zadeh, "A simple view of the Dempster-Shafer theory of evidence and its
    # implication for the rule of combination", AI Magazine 7(2), 1986), as discussed in Dezert &
    # Smarandache, "An introduction to DSmT" (arXiv:0903.0279), §2.6 and §3.3.
    return (MassFunction({"A": 0.9, "C": 0.1}, model=model), MassFunction({"B": 0.9, "C": 0.1}, model=model))


def assert_masses(result: MassFunction, expected: dict, tol: float = 1e-12) -> None:
    model = result.model
    want = {model.reduce(model.frame.element(k)) if k != "empty" else model.frame.empty: v
            for k, v in expected.items()}
    got = dict(result.items())
    assert set(got) == {e for e, v in want.items() if v}, (result, expected)
    for element, value in want.items():
        assert got.get(element, 0.0) == pytest.approx(value, abs=tol), (element, got.get(element), value)


@pytest.mark.parametrize(
    ("rule", "expected"),
    [
        # Dempster: the conflict 0.99 is normalised away and C, which both sources found almost
        # impossible, gets everything.
        ("dempster", {"C": 1.0}),
        # Yager: m(C) = 0.01 and the conflict 0.99 goes to total ignorance A∪B∪C.
        ("yager", {"C": 0.01, "A|B|C": 0.99}),
        # Dubois & Prade: each conflicting product goes to the union of its two elements.
        ("dubois_prade", {"C": 0.01, "A|B": 0.81, "A|C": 0.09, "B|C": 0.09}),
        # DSmH on Shafer's model: here S2 never applies and it coincides with Dubois & Prade.
        ("dsmh", {"C": 0.01, "A|B": 0.81, "A|C": 0.09, "B|C": 0.09}),
        # PCR5 (and PCR6, equal for two sources), "An introduction to DSmT" §3.3:
        # A = .81·.9/1.8 + .9²·.1/(.9+.1) = .405 + .081 = .486, B likewise,
        # C = .01 + 2·(.1²·.9/(.1+.9)) = .028.
        ("pcr5", {"A": 0.486, "B": 0.486, "C": 0.028}),
        ("pcr6", {"A": 0.486, "B": 0.486, "C": 0.028}),
        # The unnormalised conjunctive rule keeps the conflict 0.99 on ∅.
        ("conjunctive", {"empty": 0.99, "C": 0.01}),
    ],
)
def test_zadeh_example_on_shafer_model(rule, expected):
    # evidencelib 1.3 agrees on every line.
    m1, m2 = zadeh_sources(Model.shafer(ZADEH))
    assert_masses(combine(m1, m2, rule=rule), expected)


def test_zadeh_example_dsmc_on_the_free_model():
    # "An introduction to DSmT" §2.6.1: on the free model the classic DSm rule gives
    # m(A∩B) = .81, m(A∩C) = .09, m(B∩C) = .09, m(C) = .01 and no conflict (evidencelib agrees).
    m1, m2 = zadeh_sources(Model.free(ZADEH))
    result = combine(m1, m2, rule="dsmc")
    assert_masses(result, {"A&B": 0.81, "A&C": 0.09, "B&C": 0.09, "C": 0.01})
    assert result.empty_mass == 0.0


T3 = Frame(["t1", "t2", "t3"])


def dsmt_intro_sources():
    # Dezert & Smarandache, "An introduction to DSmT" (arXiv:0903.0279), pp. 15-16: two sources on
    # the free model of Θ = {θ1, θ2, θ3}.
    free = Model.free(T3)
    return (MassFunction({"t1": 0.1, "t2": 0.4, "t3": 0.2, "t1|t2": 0.3}, model=free),
            MassFunction({"t1": 0.5, "t2": 0.1, "t3": 0.3, "t1|t2": 0.1}, model=free))


def test_dsmc_example_of_the_introduction_to_dsmt():
    # ibid.: m(θ1) = .21, m(θ2) = .11, m(θ3) = .06, m(θ1∪θ2) = .03, m(θ1∩θ2) = .21,
    # m(θ1∩θ3) = .13, m(θ2∩θ3) = .14, m(θ3∩(θ1∪θ2)) = .11 (evidencelib agrees).
    m1, m2 = dsmt_intro_sources()
    assert_masses(combine(m1, m2, rule="dsmc"), {
        "t1": 0.21, "t2": 0.11, "t3": 0.06, "t1|t2": 0.03, "t1&t2": 0.21, "t1&t3": 0.13,
        "t2&t3": 0.14, "t3&(t1|t2)": 0.11})


def test_hybrid_dsm_rule_when_a_hypothesis_disappears():
    # ibid., pp. 15-16 (the hybrid DSm rule of Advances and Applications of DSmT vol. 1, ch. 4):
    # the sources above were elicited on the free model; then θ3 is found not to exist and the
    # hypotheses to be exclusive.  DSmH under that hybrid model gives
    # m(θ1) = .34, m(θ2) = .25, m(θ1∪θ2) = .41.  By hand: θ1 collects .05 + .03 + .01 + .10 + .15,
    # θ2 collects .04 + .12 + .04 + .02 + .03, and θ1∪θ2 collects .01 + .20 + .02 + .09 + .03 (S3)
    # plus m1(θ3)m2(θ3) = .06, for which u(θ3) = θ3 ≡ ∅ so S2 gives it to total ignorance.
    # evidencelib agrees.
    m1, m2 = dsmt_intro_sources()
    hybrid = Model.hybrid(T3, ["t3", "t1&t2"])
    assert_masses(combine(m1, m2, rule="dsmh", model=hybrid), {"t1": 0.34, "t2": 0.25, "t1|t2": 0.41})
    # The same example with the other rules (ibid., p. 16): Dempster gives .21/.35, .11/.35,
    # .03/.35; the conjunctive rule keeps the conflict .65 on ∅; Yager gives θ1∪θ2 .03 + .65;
    # Dubois & Prade loses the .06 of θ3 ∩ θ3, whose union is empty too (here it stays on ∅).
    assert_masses(combine(m1, m2, rule="dempster", model=hybrid),
                  {"t1": 0.21 / 0.35, "t2": 0.11 / 0.35, "t1|t2": 0.03 / 0.35})
    assert_masses(combine(m1, m2, rule="conjunctive", model=hybrid),
                  {"empty": 0.65, "t1": 0.21, "t2": 0.11, "t1|t2": 0.03})
    assert_masses(combine(m1, m2, rule="yager", model=hybrid), {"t1": 0.21, "t2": 0.11, "t1|t2": 0.68})
    assert_masses(combine(m1, m2, rule="dubois_prade", model=hybrid),
                  {"t1": 0.34, "t2": 0.25, "t1|t2": 0.35, "empty": 0.06})


def test_static_hybrid_dsm_rule_hand_computed():
    # Hand-computed (static DSmH, sources and fusion under one hybrid model in which θ1∩θ2 ≡ ∅,
    # Θ = {θ1, θ2, θ3}): m1 = {θ1: .6, θ3: .4}, m2 = {θ2: .7, θ1∩θ3: .3}.
    #   θ1 × θ2      = .42  θ1∩θ2 ≡ ∅ → S3: θ1∪θ2
    #   θ1 × θ1∩θ3   = .18  → θ1∩θ3 (S1)
    #   θ3 × θ2      = .28  → θ2∩θ3 (S1)
    #   θ3 × θ1∩θ3   = .12  → θ1∩θ3 (S1)
    # so m(θ1∪θ2) = .42, m(θ1∩θ3) = .30, m(θ2∩θ3) = .28 (evidencelib agrees).
    hybrid = Model.hybrid(T3, ["t1&t2"])
    m1 = MassFunction({"t1": 0.6, "t3": 0.4}, model=hybrid)
    m2 = MassFunction({"t2": 0.7, "t1&t3": 0.3}, model=hybrid)
    assert_masses(combine(m1, m2, rule="dsmh"), {"t1|t2": 0.42, "t1&t3": 0.30, "t2&t3": 0.28})


AB = Frame(["A", "B"])


@pytest.mark.parametrize(
    ("source_1", "source_2", "expected"),
    [
        ({"A": 0.6, "A|B": 0.4}, {"B": 0.3, "A|B": 0.7}, {"A": 0.54, "B": 0.18, "A|B": 0.28}),
        ({"A": 0.6, "A|B": 0.4}, {"A": 0.2, "B": 0.3, "A|B": 0.5}, {"A": 0.62, "B": 0.18, "A|B": 0.20}),
        ({"A": 0.6, "B": 0.3, "A|B": 0.1}, {"A": 0.2, "B": 0.3, "A|B": 0.5},
         {"A": 0.584, "B": 0.366, "A|B": 0.05}),
    ],
)
def test_pcr5_two_source_examples(source_1, source_2, expected):
    # "An introduction to DSmT" (arXiv:0903.0279), §3.2, examples 1-3 (Shafer's model on {A, B}).
    # E.g. example 1: m∩(A) = .42, m∩(B) = .18, m∩(A∪B) = .28 and the conflict m1(A)m2(B) = .18
    # goes back as .6²·.3/.9 = .12 to A and .6·.3²/.9 = .06 to B (evidencelib agrees).
    shafer = Model.shafer(AB)
    m1, m2 = MassFunction(source_1, model=shafer), MassFunction(source_2, model=shafer)
    assert_masses(combine(m1, m2, rule="pcr5"), expected)
    assert_masses(combine(m1, m2, rule="pcr6"), expected)


def jaif_example_2():
    # T. Dezert, J. Dezert, F. Smarandache, "Improvement of proportional conflict redistribution
    # rules of combination of basic belief assignments", J. Adv. Inf. Fusion 16(1), 2021,
    # Example 2: three sources on Shafer's model of Θ = {A, B}.
    shafer = Model.shafer(AB)
    return [MassFunction({"A": 0.6, "B": 0.1, "A|B": 0.3}, model=shafer),
            MassFunction({"A": 0.5, "B": 0.3, "A|B": 0.2}, model=shafer),
            MassFunction({"A": 0.4, "B": 0.1, "A|B": 0.5}, model=shafer)]


@pytest.mark.parametrize(
    ("rule", "expected"),
    [
        # JAIF 2021 Example 2, printed to six decimals:
        # PCR5 A .723281, B .182460, A∪B .094259; PCR6 A .743496, B .162245, A∪B .094259.
        # First conflicting product there: m1(A)m2(A)m3(B) = .03 goes .0225/.0075 to A/B under
        # PCR5 (weights .6·.5 = .30 vs .1) and .0275/.0025 under PCR6 (weights .6 + .5 vs .1).
        ("pcr5", {"A": 0.723281, "B": 0.182460, "A|B": 0.094259}),
        ("pcr6", {"A": 0.743496, "B": 0.162245, "A|B": 0.094259}),
    ],
)
def test_pcr5_and_pcr6_differ_for_three_sources(rule, expected):
    # evidencelib agrees with both columns.
    assert_masses(combine(*jaif_example_2(), rule=rule), expected, tol=1e-6)


def test_pcr5_and_pcr6_with_four_categorical_sources():
    # JAIF 2021 Example 3: m1(A∪B) = m2(B) = m3(A∪B) = m4(C) = 1 on Shafer's model of {A, B, C}.
    # The single conflicting product 1 goes, under PCR5, to the distinct elements A∪B, B, C in
    # proportion to 1·1, 1, 1 (one third each); under PCR6 in proportion to the summed masses
    # 2, 1, 1 (1/2, 1/4, 1/4).  evidencelib agrees.
    shafer = Model.shafer(ZADEH)
    sources = [MassFunction.categorical(x, model=shafer) for x in ("A|B", "B", "A|B", "C")]
    assert_masses(combine(*sources, rule="pcr5"), {"A|B": 1 / 3, "B": 1 / 3, "C": 1 / 3})
    assert_masses(combine(*sources, rule="pcr6"), {"A|B": 0.5, "B": 0.25, "C": 0.25})


TRACK2 = Model.for_targets(2)


def spec_a4_sources():
    # SPEC A.4 worked example: tracking model with τ = 2, m1 = m_loc, m2 = m_col.
    return (MassFunction({"t1": 0.6, "t2": 0.3, "FA": 0.1}, model=TRACK2),
            MassFunction({"t1": 0.2, "t2": 0.7, "FA": 0.1}, model=TRACK2))


def test_r_rule_worked_example_of_spec_a4():
    # SPEC A.4: R = .6325 (paper), m(θ1∩θ2) = .3036, m(θ1) = .2113, m(θ2) = .3574, m(FA) = .0139,
    # m(θ1∪FA) = .0506, m(θ2∪FA) = .0632, m(θ1∪θ2) = 0, Bel(θ1) = .5149, Bel(θ2) = .6609.
    m1, m2 = spec_a4_sources()
    result = combine(m1, m2, rule="r_rule")
    assert_masses(result, {"t1&t2": 0.3036, "t1": 0.2113, "t2": 0.3574, "FA": 0.0139,
                           "t1|FA": 0.0506, "t2|FA": 0.0632}, tol=5e-5)
    assert result["t1|t2"] == 0.0
    assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-15)
    assert result.bel("t1") == pytest.approx(0.5149, abs=5e-5)
    assert result.bel("t2") == pytest.approx(0.6609, abs=5e-5)
    # By hand: the total variation is (.4 + .4 + 0)/2 = .4, so R = √.4 = .6325 (paper), and
    # ½((.4)² + (.4)²) = .16 gives R = .400 (euclid).  The pair θ1/θ2 has k = .6·.7 + .3·.2 = .48,
    # R·k = .48·√.4 stays on θ1∩θ2 (W (14)).
    assert result["t1&t2"] == pytest.approx(0.48 * math.sqrt(0.4), abs=1e-12)
    euclid = combine(m1, m2, rule="r_rule", r_mode="euclid")
    assert euclid["t1&t2"] == pytest.approx(0.48 * 0.4, abs=1e-12)
    # Jousselme, by hand: on M_2, C(θ1) = C(θ2) = 2 (regions θ1 only and θ1∩θ2), C(θ1∩θ2) = 1,
    # so D(θ1, θ2) = 1/3, D(·, FA) = 0 and ½ ΔᵀDΔ = ½(.16 + .16 - 2·.16/3) = .32/3.
    jousselme = combine(m1, m2, rule="r_rule", r_mode="jousselme")
    assert jousselme["t1&t2"] == pytest.approx(0.48 * math.sqrt(0.32 / 3), abs=1e-12)
    # K0 = .66 and m0 = (.3529, .6176, .0294): Dempster's rule on the Shafer projections, which for
    # these Bayesian sources are the sources themselves read under Shafer's model.
    shafer = Model.shafer(TRACK2.frame)
    assert combine(m1, m2, rule="conjunctive", model=shafer).empty_mass == pytest.approx(0.66, abs=1e-12)
    m0 = combine(m1, m2, rule="dempster", model=shafer)
    assert [m0["t1"], m0["t2"], m0["FA"]] == pytest.approx([0.3529, 0.6176, 0.0294], abs=5e-5)
    # With empty_mode="empty" R·k of the target/FA pairs goes to ∅ instead of θj∪FA; Bel(θj)
    # does not change (SPEC A.4).
    empty = combine(m1, m2, rule="r_rule", empty_mode="empty")
    assert empty.empty_mass == pytest.approx((0.08 + 0.10) * math.sqrt(0.4), abs=1e-12)
    assert empty.bel("t1") == pytest.approx(result.bel("t1"), abs=1e-12)
    assert empty.bel("t2") == pytest.approx(result.bel("t2"), abs=1e-12)
    assert math.fsum(empty.values) == pytest.approx(1.0, abs=1e-15)


TRACK3 = Model.for_targets(3)


def spec_part_d_cues():
    # SPEC Part D, explicit example: τ = 3, m_loc = (.5, .2, .2; FA .1), m_col = (.3, .4, .1; FA .2),
    # and a third cue (.4, .3, .2; .1).
    names = ("t1", "t2", "t3", "FA")
    return [MassFunction(dict(zip(names, values)), model=TRACK3)
            for values in ((0.5, 0.2, 0.2, 0.1), (0.3, 0.4, 0.1, 0.2), (0.4, 0.3, 0.2, 0.1))]


def test_table_rule_example_of_spec_part_d():
    # SPEC Part D table: θ1∩θ2 .26, ∅ .26, θ1 .15, θ1∩θ3 .11, θ2∩θ3 .10, θ2 .08, θ3 .02, FA .02;
    # Bel = (.52, .44, .23) and Pls = .72 for every target.  The "table" rule is DSmC on M_τ.
    # evidencelib (conjunctive rule on the same hybrid model) agrees, for three cues too.
    loc, col, third = spec_part_d_cues()
    result = combine(loc, col, rule="dsmc")
    assert_masses(result, {"t1&t2": 0.26, "empty": 0.26, "t1": 0.15, "t1&t3": 0.11, "t2&t3": 0.10,
                           "t2": 0.08, "t3": 0.02, "FA": 0.02})
    assert [result.bel(t) for t in ("t1", "t2", "t3")] == pytest.approx([0.52, 0.44, 0.23], abs=1e-12)
    assert [result.pls(t) for t in ("t1", "t2", "t3")] == pytest.approx([0.72] * 3, abs=1e-12)
    # A third cue adds θ1∩θ2∩θ3 (.125) and m(∅) = .35; the masses still sum to one.
    three = combine(loc, col, third, rule="dsmc")
    assert three["t1&t2&t3"] == pytest.approx(0.125, abs=1e-12)
    assert three.empty_mass == pytest.approx(0.35, abs=1e-12)
    assert math.fsum(three.values) == pytest.approx(1.0, abs=1e-15)
    # Closed forms of SPEC Part D with P = Π_l (1 - m_l(FA)):
    # m(FA) = Π m_l(FA), m(∅) = 1 - P - Π m_l(FA), Bel(θJ) = P - Π_l (1 - m_l(FA) - m_l(θJ)).
    cues = (loc, col, third)
    p = math.prod(1 - c["FA"] for c in cues)
    assert three["FA"] == pytest.approx(math.prod(c["FA"] for c in cues), abs=1e-15)
    for target in ("t1", "t2", "t3"):
        assert three.bel(target) == pytest.approx(p - math.prod(1 - c["FA"] - c[target] for c in cues), abs=1e-12)


def test_r_rule_on_the_part_d_example():
    # SPEC Part D: the same two cues under the R-rule give R = .548, K0 = .73,
    # Bel = (.525, .383, .161), and the masses sum to one.  By hand: the total variation is
    # (.2 + .2 + .1 + .1)/2 = .3, R = √.3 = .5477; K0 = 1 - (.15 + .08 + .02 + .02) = .73.
    loc, col, _ = spec_part_d_cues()
    result = combine(loc, col, rule="r_rule")
    assert combine(loc, col, rule="conjunctive", model=Model.shafer(TRACK3.frame)).empty_mass == pytest.approx(
        0.73, abs=1e-12)
    assert [result.bel(t) for t in ("t1", "t2", "t3")] == pytest.approx([0.525, 0.383, 0.161], abs=5e-4)
    assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-15)
    # θ1/θ2 pair: k = .5·.4 + .2·.3 = .26, of which R·k stays on θ1∩θ2.
    assert result["t1&t2"] == pytest.approx(0.26 * math.sqrt(0.3), abs=1e-12)


def test_r_rule_cue_order_matters_from_three_cues():
    # SPEC Part D: "Cue order changes the result" when the R-rule is folded over ≥ 3 cues.
    loc, col, third = spec_part_d_cues()
    forward = combine(loc, col, third, rule="r_rule")
    backward = combine(third, col, loc, rule="r_rule")
    assert not forward.isclose(backward, abs_tol=1e-6)
    # while each fold step is the two-source rule, in the given order
    assert forward.isclose(combine(combine(loc, col, rule="r_rule"), third, rule="r_rule"))
    assert math.fsum(forward.values) == pytest.approx(1.0, abs=1e-15)


def test_r_rule_survives_a_subnormal_m0():
    # θ1/θ2 conflict k = .25 with m0(θ1) = m0(θ2) = 5e-321: (1 - R)·k is split by the ratio
    # m0(θj) / Σ m0 = ½, which must not go through k / Σ m0 (that overflows to inf).
    # R = √(½(.5 + .5)) = √½, so each target gets (1 - √½)·.25 / 2.
    m1 = MassFunction({"t1": 0.5, "t2": 1e-320, "FA": 0.5}, model=TRACK2)
    m2 = MassFunction({"t1": 1e-320, "t2": 0.5, "FA": 0.5}, model=TRACK2)
    result = combine(m1, m2, rule="r_rule")
    assert all(math.isfinite(v) for v in result.values)
    assert result["t1"] == pytest.approx((1 - math.sqrt(0.5)) * 0.125, abs=1e-15)
    assert result["t2"] == pytest.approx((1 - math.sqrt(0.5)) * 0.125, abs=1e-15)
    assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-15)


def test_r_rule_of_sources_equal_as_fractions_but_not_as_floats_matches_the_reference():
    # 1/3 + 1/3 and 1/9 + 5/9 both merge onto t4 (t1∩t2 is empty under Shafer's model) but
    # round to neighbouring floats: the paper R of the two is about 7e-9, not 0, and so is the
    # mass it moves to t1 ∪ t4.
    from tests.strategies import shafer_allowed

    frame = Frame(["t1", "t2", "t3", "t4"])
    case = ModelCase(Model.shafer(frame), shafer_allowed(4), "shafer")
    t1, t4, tail = frame.element("t1"), frame.element("t4"), frame.element("t1&t2|t4")
    third = Fraction(1, 3)
    fc = FusionCase(case, case, (((t1, third), (t4, third), (tail, third)),
                                 ((t4, Fraction(1, 9)), (tail, Fraction(5, 9)), (t1, third))))
    result = combine(*fc.build(), rule="r_rule")
    assert 1e-9 < result[frame.element("t1|t4")] < 1e-7
    check_against_reference(fc, "r_rule")


def test_r_rule_disjoint_sources_have_r_exactly_one():
    # SPEC A.4: R = 1 iff the focal sets are disjoint.  The float sum .6 + .3 + .1 + .7 + .2 + .1 is
    # 1.9999999999999998, which would leave (1 - R)·k ≈ 1e-17 on θ1 and θ2; a later fold would then
    # see m0 > 0 where it is 0 and split its conflicts differently.
    track5 = Model.for_targets(5)
    m1 = MassFunction({"t1": 0.6, "t2": 0.3, "t3": 0.1}, model=track5)
    m2 = MassFunction({"t4": 0.7, "t5": 0.2, "FA": 0.1}, model=track5)
    batches = [m1.batch(), m2.batch()]
    focal = sorted(set(m1.batch().focal) | set(m2.batch().focal), key=lambda e: e.sort_key)
    aligned = [np.array([[dict(zip(b.focal, b.values[0])).get(e, 0.0) for e in focal]]) for b in batches]
    assert inconsistency(aligned[0], aligned[1], focal, track5)[0] == 1.0
    result = combine(m1, m2, rule="r_rule")
    assert result["t1"] == result["t2"] == result["t3"] == 0.0
    assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-15)


NEARLY_DISJOINT = (   # t1, t2, t3, FA: each cue nearly certain where the one before is not
    (4.8044063940795295e-001, 3.8299827079933405e-270, 5.1955936059204699e-001, 3.3715779997564867e-304),
    (1.6734984019838230e-232, 6.3650048422790428e-001, 1.1584386602429696e-265, 3.6349951577209566e-001),
    (0.415501505372766, 0.378822042699179, 0.1647159244402119, 0.04096052748784315),
    (1.7193461102892705e-167, 1.1602698267435671e-002, 1.4222902966521806e-303, 9.8839730173256424e-001),
)


@pytest.mark.parametrize("engine", ["general", "auto"])
def test_r_rule_of_nearly_disjoint_cues_keeps_one_minus_r_to_its_last_digits(engine):
    # The first two cues overlap by about 2e-232, so 1 − R is about 1e-232.  Formed as
    # 1 − √(Σ|Δ|/2), it would be the rounding of a sum near 2 (1e-16), which puts 1e-17 on t2
    # after the second fold where the fold puts 1e-270; the fourth fold's m0 weights compare
    # such masses and would then move 6e-6 of mass from t2 to t1.  The reference takes the
    # cues normalised exactly, as fractions (SPEC A.4, W (10), (12)).
    model = Model.for_targets(3)
    case = ModelCase(model, tracking_allowed(4, 3), "tracking")
    singletons = list(model.frame.singletons)
    exact = []
    for row in NEARLY_DISJOINT:
        total = sum(Fraction(v) for v in row)
        exact.append([(case.regions(e), Fraction(v) / total) for e, v in zip(singletons, row)])
    expected = ref_r_fold(exact, case.allowed, "paper", "union")
    fused = combine(*(MassBatch.bayesian(np.array(row), model=model) for row in NEARLY_DISJOINT), rule="r_rule",
                    engine=engine)
    # Each singleton's mass and belief, which the closed forms compute on their own.
    for index, element in enumerate(singletons):
        regions = case.regions(element)
        mass = float(expected.get(regions, 0))
        bel = float(sum((v for k, v in expected.items() if k and k <= regions), Fraction(0)))
        assert fused.mass([element])[0, 0] == pytest.approx(mass, rel=1e-12, abs=1e-15), element
        assert fused.bel([element])[0, 0] == pytest.approx(bel, rel=1e-12, abs=1e-15), element
    # The case is one where the noise mattered: t1 holds far more than any rounding of 1 − R.
    assert expected[case.regions(singletons[0])] > 1e-6
    if engine == "general":
        assert_matches(regions_result(fused[0], case), expected)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 1), st.floats(-300, 0), st.floats(0, 1), st.floats(-300, 0)),
                min_size=2, max_size=6),
       st.booleans())
def test_paper_r_near_one_keeps_the_relative_precision_of_one_minus_r(columns, disjointish):
    # R of W (10) as printed and 1 − R, for two rows that sum to one, against exact arithmetic on
    # the same floats, √ taken to 800 digits.  Where the overlap Σ min(m1, m2) is below ½, 1 − R
    # is formed from it, 1 − √(1 − overlap), and must keep 1e-13 of its own size down to the
    # smallest normal float; elsewhere R is √(Σ|Δ|/2) of the floats as given, to 1e-13 of itself (SPEC A.4).
    from decimal import Decimal, localcontext

    from belief.bayesian import paper_inconsistency

    m1 = np.array([a * 10.0 ** e for a, e, _, _ in columns])
    m2 = np.array([b * 10.0 ** e for _, _, b, e in columns])
    if disjointish:                       # each mass large in at most one of the rows
        m1[1::2] *= 1e-200
        m2[0::2] *= 1e-200
    if not (m1.sum() > 0 and m2.sum() > 0):
        return
    m1, m2 = m1 / m1.sum(), m2 / m2.sum()
    overlap = np.minimum(m1, m2).sum()
    r, rho = paper_inconsistency(np.array([np.abs(m1 - m2).sum() / 2]), np.array([overlap]))
    exact_overlap = sum((min(Fraction(a), Fraction(b)) for a, b in zip(m1, m2)), Fraction(0))
    exact_half = sum((abs(Fraction(a) - Fraction(b)) for a, b in zip(m1, m2)), Fraction(0)) / 2

    def root(q: Fraction) -> Decimal:
        return (Decimal(q.numerator) / Decimal(q.denominator)).sqrt()

    assert 0.0 <= r[0] <= 1.0 and 0.0 <= rho[0] <= 1.0
    with localcontext() as context:
        context.prec = 800                # 1 − √(1 − x) for x down to 1e-330, to 1e-13 of itself
        if exact_overlap == 0:
            assert r[0] == 1.0 and rho[0] == 0.0
        elif overlap < 0.5:
            # Below the normal range (2^-1022) a float keeps fewer digits: one rounding of 2^-1075 there.
            assert rho[0] == pytest.approx(float(1 - root(1 - exact_overlap)), rel=1e-13, abs=2.0 ** -1073)
        else:
            # The half Σ|Δ|/2 handed to it is a float: below 2^-1022 its rounding errs by up to 2^-1075
            # absolutely, which moves √ by that over 2R (R ≈ 1e-156 for a half of 5e-312); a bound of
            # twice that leaves room for the rounding of √ itself.
            want = float(root(exact_half))
            assert r[0] == pytest.approx(want, rel=1e-13, abs=2.0 ** -1074 / (2 * want) if want else 0.0)
            assert r[0] + rho[0] == 1.0


# -- error paths ---------------------------------------------------------------------------------------------------


def shafer_ab():
    shafer = Model.shafer(Frame(["a", "b"]))
    return shafer, MassFunction({"a": 0.6, "b": 0.4}, model=shafer), MassFunction({"a": 0.3, "a|b": 0.7}, model=shafer)


def test_unknown_rule_lists_the_known_ones():
    _, m1, m2 = shafer_ab()
    with pytest.raises(UnknownRuleError) as info:
        combine(m1, m2, rule="no_such_rule")
    assert isinstance(info.value, BeliefError) and isinstance(info.value, KeyError)
    message = str(info.value)
    assert "no_such_rule" in message and not message.startswith('"')
    for name in ALL_RULES:
        assert name in message
    with pytest.raises(UnknownRuleError):
        get_rule("pcr7")
    with pytest.raises(UnknownRuleError):
        sequential(m1, m2, rule="pcr7")
    with pytest.raises(TypeError):
        get_rule(6)


def test_fewer_than_two_sources():
    _, m1, _ = shafer_ab()
    for call in (lambda: combine(m1), lambda: combine(), lambda: combine([m1]), lambda: sequential(m1),
                 lambda: combine(m1.batch(), rule="conjunctive")):
        with pytest.raises(InvalidMassError, match="at least two sources"):
            call()


def test_sources_under_different_models_or_frames():
    shafer, m1, _ = shafer_ab()
    free = MassFunction({"a": 0.5, "b": 0.5}, frame=["a", "b"], model="free")
    with pytest.raises(ModelError, match="model"):
        combine(m1, free)
    other = MassFunction({"a": 0.5, "c": 0.5}, frame=["a", "c"])
    with pytest.raises(FrameError):
        combine(m1, other)
    with pytest.raises(TypeError):
        combine(m1, {"a": 1.0})


def test_batches_with_different_row_counts():
    shafer = Model.shafer(Frame(["a", "b"]))
    two = MassBatch(["a", "b"], [[0.5, 0.5], [0.2, 0.8]], model=shafer)
    three = MassBatch(["a", "b"], [[0.5, 0.5], [0.2, 0.8], [1.0, 0.0]], model=shafer)
    with pytest.raises(InvalidMassError, match="rows"):
        combine(two, three, rule="conjunctive")
    # one row broadcasts against any number
    one = MassBatch(["a", "b"], [[0.5, 0.5]], model=shafer)
    assert len(combine(one, three, rule="conjunctive")) == 3


def test_unknown_and_bad_options():
    _, m1, m2 = shafer_ab()
    with pytest.raises(InvalidMassError, match="r_mode"):
        combine(m1, m2, rule="dempster", r_mode="paper")
    with pytest.raises(InvalidMassError, match="colour"):
        combine(m1, m2, rule="r_rule", colour="red")
    with pytest.raises(InvalidMassError, match="r_mode"):
        combine(m1, m2, rule="r_rule", r_mode="manhattan")
    with pytest.raises(InvalidMassError, match="empty_mode"):
        combine(m1, m2, rule="r_rule", empty_mode="nowhere")


def test_dempster_total_conflict():
    shafer, _, _ = shafer_ab()
    a = MassFunction({"a": 1.0}, model=shafer)
    b = MassFunction({"b": 1.0}, model=shafer)
    with pytest.raises(TotalConflictError, match="total conflict"):
        combine(a, b, rule="dempster")
    batch = MassBatch(["a", "b"], [[0.5, 0.5], [0.0, 1.0]], model=shafer)
    with pytest.raises(TotalConflictError, match="total conflict.*row 1"):
        combine(a, batch, rule="dempster")


def test_dempster_near_total_conflict_still_sums_to_one():
    # Two Bayesian sources on {a, b} that agree with weight x(1 - y) + (1 - x)y ≈ 1e-12: the
    # conflict is 1 - 1e-12, yet Dempster's rule is defined and, computed exactly from the floats
    # handed to the library, m(a) = x(1 - y)/(x(1 - y) + (1 - x)y) ≈ 1/4.
    shafer, _, _ = shafer_ab()
    x, y = 2.5e-13, 7.5e-13
    m1 = MassFunction({"a": x, "b": 1 - x}, model=shafer)
    m2 = MassFunction({"a": 1 - y, "b": y}, model=shafer)
    fx, fy = Fraction(m1["a"]), Fraction(m2["b"])
    f1b, f2a = Fraction(m1["b"]), Fraction(m2["a"])
    agree_a, agree_b = fx * f2a, f1b * fy
    conflict = 1 - agree_a - agree_b
    assert 1 - float(conflict) < 2e-12
    result = combine(m1, m2, rule="dempster")
    assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-12)
    assert result["a"] == pytest.approx(float(agree_a / (agree_a + agree_b)), rel=1e-9)
    assert result["b"] == pytest.approx(float(agree_b / (agree_a + agree_b)), rel=1e-9)


@pytest.mark.parametrize("rule", ["yager", "dubois_prade", "dsmh", "pcr5", "pcr6", "r_rule"])
@pytest.mark.parametrize("position", [0, 1, 2])
def test_subnormal_sources_are_rejected_where_the_rule_needs_normal_ones(rule, position):
    shafer = Model.shafer(Frame(["a", "b"]))
    sources = [MassFunction({"a": 0.6, "b": 0.4}, model=shafer) for _ in range(3)]
    sources[position] = MassFunction({"empty": 0.2, "a": 0.8}, model=shafer, subnormal=True)
    with pytest.raises(InvalidMassError, match="normal"):
        combine(*sources, rule=rule)


@pytest.mark.parametrize("rule", ALL_RULES)
def test_dynamic_fusion_needs_a_stricter_model(rule):
    frame = Frame(["a", "b", "c"])
    hybrid = Model.hybrid(frame, ["a&b"])
    m1 = MassFunction({"a": 0.5, "c": 0.5}, model=hybrid)
    m2 = MassFunction({"b": 0.5, "a|c": 0.5}, model=hybrid)
    for looser in (Model.free(frame), Model.hybrid(frame, ["b&c"])):
        with pytest.raises(ModelError, match="not stricter"):
            combine(m1, m2, rule=rule, model=looser)
    with pytest.raises(FrameError):
        combine(m1, m2, rule=rule, model=Model.free(Frame(["a", "b"])))
    # the same model, or a stricter one, is fine
    assert combine(m1, m2, rule=rule, model=hybrid).model == hybrid
    assert combine(m1, m2, rule=rule, model=Model.shafer(frame)).model == Model.shafer(frame)


@pytest.mark.parametrize("rule", ["pcr5", "pcr6", "r_rule"])
def test_pcr_and_r_rule_refuse_elements_that_vanish_under_the_fusion_model(rule):
    free = Model.free(T3)
    m1 = MassFunction({"t1&t2": 0.4, "t3": 0.6}, model=free)
    m2 = MassFunction({"t1": 0.5, "t2": 0.5}, model=free)
    with pytest.raises(ModelError, match="t1&t2"):
        combine(m1, m2, rule=rule, model=Model.shafer(T3))
    # DSmH is made for it: t1∩t2 (empty) against t1 goes to the union t1 (S3)
    result = combine(m1, m2, rule="dsmh", model=Model.shafer(T3))
    assert_masses(result, {"t1": 0.2, "t2": 0.2, "t1|t3": 0.3, "t2|t3": 0.3})


def test_r_rule_refuses_a_vanishing_element_in_any_source():
    # Under the fusion model θ2 ≡ ∅, so m2(θ2) = .5 has nowhere to go, whichever source holds it:
    # PCR5, PCR6 and the R-rule refuse it rather than drop it on ∅ silently.
    frame = Frame(["t1", "t2"])
    free = Model.free(frame)
    m1 = MassFunction({"t1": 1.0}, model=free)
    m2 = MassFunction({"t1": 0.5, "t2": 0.5}, model=free)
    gone = Model.hybrid(frame, ["t2"])
    for rule in ("pcr5", "pcr6"):
        for order in ((m1, m2), (m2, m1)):
            with pytest.raises(ModelError):
                combine(*order, rule=rule, model=gone)
    with pytest.raises(ModelError):
        combine(m2, m1, rule="r_rule", model=gone)
    with pytest.raises(ModelError):
        combine(m1, m2, rule="r_rule", model=gone)


def test_r_rule_reads_the_first_source_under_the_fusion_model():
    # Hand-computed.  m1 = {θ1: .5, θ1 ∪ (θ2∩θ3): .5} and m2 = {θ2: 1} on the free model, fused
    # under Shafer's model, where θ2∩θ3 ≡ ∅: m1 reads {θ1: 1} there.  Then R = √((1 + 1)/2) = 1
    # (paper), and the only conflict, k(θ1, θ2) = 1, goes with weight R to θ1∩θ2 ≡ ∅, i.e. to θ1∪θ2
    # (empty_mode "union"): m(θ1∪θ2) = 1.  That is what the rule gives with the sources swapped
    # (two-source R-rule is symmetric) or read under Shafer's model first.
    f = Frame(["t1", "t2", "t3"])
    free, shafer = Model.free(f), Model.shafer(f)
    m1 = MassFunction({"t1": 0.5, "t1|t2&t3": 0.5}, model=free)
    m2 = MassFunction({"t2": 1.0}, model=free)
    assert_masses(combine(m2, m1, rule="r_rule", model=shafer), {"t1|t2": 1.0})
    assert_masses(combine(m1.under(shafer), m2.under(shafer), rule="r_rule"), {"t1|t2": 1.0})
    assert_masses(combine(m1, m2, rule="r_rule", model=shafer), {"t1|t2": 1.0})


# -- names and aliases ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("alias", "name"),
    [("smets", "conjunctive"), ("tbm", "conjunctive"), ("unnormalized", "conjunctive"),
     ("dsm_classic", "dsmc"), ("ds", "dempster"), ("dempster_shafer", "dempster"),
     ("union", "disjunctive"), ("dp", "dubois_prade"), ("duboisprade", "dubois_prade"),
     ("Dubois-Prade", "dubois_prade"), ("hybrid", "dsmh"), ("dsm_hybrid", "dsmh"), ("DSm-Hybrid", "dsmh"),
     ("r", "r_rule"), ("rrule", "r_rule"), ("wang", "r_rule"), ("R-Rule", "r_rule"),
     ("DEMPSTER", "dempster"), ("Pcr6", "pcr6"), ("PCR5", "pcr5"), ("YAGER", "yager")],
)
def test_aliases_and_case_insensitive_names(alias, name):
    assert get_rule(alias) is RULES[name]
    assert get_rule(alias).name == name
    _, m1, m2 = shafer_ab()
    assert combine(m1, m2, rule=alias) == combine(m1, m2, rule=name)


def test_rule_names_and_rule_info():
    assert rule_names() == list(RULES)
    for name, info in RULES.items():
        assert info.name == name and get_rule(info) is info and get_rule(name.upper()) is info
        assert info.summary
    _, m1, m2 = shafer_ab()
    assert combine(m1, m2, rule=RULES["pcr6"]) == combine(m1, m2, rule="pcr6")
    assert RULES["r_rule"].options == ("r_mode", "empty_mode")


def results_with_empty_mass():
    """For each rule, a combination that leaves mass on ∅, if the rule can do that."""
    m1, m2 = dsmt_intro_sources()
    hybrid = Model.hybrid(T3, ["t3", "t1&t2"])       # θ3 ≡ ∅: θ3 ∩ θ3 and θ3 ∪ θ3 are both empty
    shafer = Model.shafer(T3)
    a = MassFunction({"empty": 0.5, "t1": 0.5}, model=shafer, subnormal=True)
    b = MassFunction({"empty": 0.5, "t2": 0.5}, model=shafer, subnormal=True)
    loc, col = spec_a4_sources()
    return {
        "conjunctive": combine(m1, m2, rule="conjunctive", model=hybrid),
        "dsmc": combine(m1, m2, rule="dsmc", model=hybrid),
        "r_rule": combine(loc, col, rule="r_rule", empty_mode="empty"),
        # the .06 of θ3 ∩ θ3 (union empty too) stays on ∅ under dynamic fusion
        "dubois_prade": combine(m1, m2, rule="dubois_prade", model=hybrid),
        # ∅ ∪ ∅ = ∅ for open-world sources: m(∅) = .5 · .5; and under dynamic fusion θ3 ∪ θ3 ≡ ∅
        "disjunctive": combine(a, b, rule="disjunctive"),
    }


@pytest.mark.parametrize("rule", ["conjunctive", "dsmc", "r_rule", "dubois_prade", "disjunctive"])
def test_keeps_conflict_flags_the_rules_whose_results_hold_mass_on_empty(rule):
    # RuleInfo.keeps_conflict: "Whether the result may hold mass on ∅."
    result = results_with_empty_mass()[rule]
    assert result.empty_mass > 0
    assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-12)
    assert RULES[rule].keeps_conflict


def test_rules_without_the_keeps_conflict_flag_leave_nothing_on_empty():
    # Yager, Dempster, DSmH, PCR5 and PCR6 never do, even on the examples above.
    m1, m2 = dsmt_intro_sources()
    hybrid = Model.hybrid(T3, ["t3", "t1&t2"])
    for rule in ("dempster", "yager", "dsmh"):
        assert not RULES[rule].keeps_conflict
        assert combine(m1, m2, rule=rule, model=hybrid).empty_mass == 0.0
    for rule in ("pcr5", "pcr6"):
        assert not RULES[rule].keeps_conflict
        assert combine(m1, m2, rule=rule, model=Model.shafer(T3)).empty_mass == 0.0


def test_a_joint_combination_with_too_many_tuples_is_refused(monkeypatch):
    import belief.plan as plan_module

    monkeypatch.setattr(plan_module, "MAX_TUPLES", 9)
    frame = Frame(["a", "b", "c"])
    shafer = Model.shafer(frame)
    m = MassFunction({"a": 0.5, "b": 0.3, "c": 0.2}, model=shafer)
    with pytest.raises(CombinationTooLargeError, match="27 tuples.*belief.plan.MAX_TUPLES = 9"):
        combine(m, m, m, rule="pcr6")
    assert combine(m, m, rule="pcr6").isclose(combine(m, m, rule="pcr5"))     # 9 tuples: at the limit
