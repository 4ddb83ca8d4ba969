"""Laws of the combination rules: mass conservation, symmetry, associativity, neutral elements."""

import math
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import (
    RULES,
    Frame,
    MassFunction,
    Model,
    ModelError,
    TotalConflictError,
    combine,
    sequential,
)
from tests.strategies import FusionCase, fusion_cases

ALL_RULES = ["conjunctive", "dsmc", "dempster", "disjunctive", "yager", "dubois_prade", "dsmh",
             "pcr5", "pcr6", "r_rule"]
ASSOCIATIVE = ["conjunctive", "dsmc", "dempster", "disjunctive"]
# Errors a valid input may legitimately raise: Dempster at total conflict; PCR5, PCR6 and the
# R-rule when a focal element vanishes under a stricter fusion model.
ALLOWED_ERRORS = {"dempster": TotalConflictError, "pcr5": ModelError, "pcr6": ModelError, "r_rule": ModelError}


def fusion_model(fc: FusionCase):
    return fc.fusion.model if fc.dynamic else None


def outcome(*sources, rule, **kwargs):
    """The result, or the exception class for an error the rule may raise on valid input."""
    try:
        return combine(*sources, rule=rule, **kwargs)
    except (TotalConflictError, ModelError) as exc:
        assert isinstance(exc, ALLOWED_ERRORS.get(rule, ())), (rule, exc)
        return type(exc)


def same(a, b, tol=1e-12) -> bool:
    if isinstance(a, type) or isinstance(b, type):
        return a is b
    return a.isclose(b, rel_tol=1e-9, abs_tol=tol)


def test_registry_flags_the_associative_rules():
    # The rules of belief.rules (defined in its modules belief.rules_*); those registered by other modules
    # have their laws tested with them (tests/test_extra_rules.py for belief.extra_rules).
    core = {n: info for n, info in RULES.items() if info.function.__module__.startswith("belief.rules")}
    assert set(ALL_RULES) <= set(core)
    assert sorted(n for n, info in core.items() if info.associative) == sorted(ASSOCIATIVE)


# -- mass conservation --------------------------------------------------------------------------------


@pytest.mark.parametrize("rule", ALL_RULES)
@settings(max_examples=40)
@given(fc=fusion_cases(dynamic=None))
def test_masses_sum_to_one(rule, fc):
    result = outcome(*fc.build(), rule=rule, model=fusion_model(fc))
    if isinstance(result, type):
        return
    # m(∅) counts where the rule keeps it (conjunctive, DSmC, R-rule "empty", Dubois–Prade and
    # disjunctive under dynamic fusion)
    assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-12)
    assert (result.values > 0).all()
    if rule in ("dempster", "yager", "dsmh", "pcr5", "pcr6") or rule == "r_rule":
        assert result.empty_mass == 0.0
    if rule in ("dubois_prade", "disjunctive") and not fc.dynamic:
        assert result.empty_mass == 0.0


@pytest.mark.parametrize("rule", ["r_rule"])
@pytest.mark.parametrize("r_mode", ["paper", "euclid", "jousselme"])
@settings(max_examples=30)
@given(fc=fusion_cases(dynamic=None))
def test_r_rule_masses_sum_to_one_in_every_mode(rule, r_mode, fc):
    # SPEC A.4 step 4: Σ m = 1, m(∅) included in "empty" mode.
    for empty_mode in ("union", "empty"):
        result = outcome(*fc.build(), rule=rule, model=fusion_model(fc), r_mode=r_mode, empty_mode=empty_mode)
        if isinstance(result, type):
            return
        assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-12)
        if empty_mode == "union":
            assert result.empty_mass == 0.0


# -- the order of the sources -----------------------------------------------------------------------------


@pytest.mark.parametrize("rule", [r for r in ALL_RULES if r != "r_rule"])
@settings(max_examples=30)
@given(data=st.data())
def test_commutativity(rule, data):
    fc = data.draw(fusion_cases(dynamic=None))
    masses = fc.build()
    shuffled = data.draw(st.permutations(masses))
    model = fusion_model(fc)
    assert same(outcome(*masses, rule=rule, model=model), outcome(*shuffled, rule=rule, model=model))


@settings(max_examples=60)
@given(fc=fusion_cases(max_sources=2, dynamic=None))
def test_two_source_r_rule_is_commutative(fc):
    # R, the local conflicts k_{A,B}, m0 and the fallback weights m1 + m2 are all symmetric in the
    # two sources (SPEC A.4), so for two sources the order does not matter.
    m1, m2 = fc.build()
    model = fusion_model(fc)
    for mode in ("paper", "euclid", "jousselme"):
        for empty_mode in ("union", "empty"):
            a = outcome(m1, m2, rule="r_rule", model=model, r_mode=mode, empty_mode=empty_mode)
            b = outcome(m2, m1, rule="r_rule", model=model, r_mode=mode, empty_mode=empty_mode)
            assert same(a, b)


# -- associativity ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("rule", ASSOCIATIVE)
@settings(max_examples=40)
@given(fc=fusion_cases(min_sources=3, max_sources=3, dynamic=None))
def test_associativity(rule, fc):
    a, b, c = fc.build()
    model = fusion_model(fc)
    fusion = fc.fusion.model
    joint = outcome(a, b, c, rule=rule, model=model)
    left = outcome(a, b, rule=rule, model=model)
    if not isinstance(left, type):
        left = outcome(left, c.under(fusion), rule=rule)
    right = outcome(b, c, rule=rule, model=model)
    if not isinstance(right, type):
        right = outcome(a.under(fusion), right, rule=rule)
    assert same(joint, left) and same(joint, right)
    # sequential() folds pairwise; for an associative rule that is the joint combination
    assert same(joint, outcome_sequential(a, b, c, rule=rule, model=model))


def outcome_sequential(*sources, rule, model):
    try:
        return sequential(*sources, rule=rule, model=model)
    except TotalConflictError:
        return TotalConflictError


@pytest.mark.parametrize("rule", ["dubois_prade", "dsmh", "pcr5", "pcr6", "r_rule", "yager"])
@settings(max_examples=30)
@given(fc=fusion_cases(min_sources=3, max_sources=3, dynamic=False))
def test_sequential_folds_pairwise(rule, fc):
    a, b, c = fc.build()
    assert same(sequential(a, b, c, rule=rule), combine(combine(a, b, rule=rule), c, rule=rule))
    assert same(sequential(a, b, rule=rule), combine(a, b, rule=rule))


AB = Frame(["A", "B"])


def jaif_example_2():
    # T. Dezert, J. Dezert, F. Smarandache, "Improvement of proportional conflict redistribution
    # rules of combination of basic belief assignments", J. Adv. Inf. Fusion 16(1), 2021, Example 2.
    shafer = Model.shafer(AB)
    return [MassFunction({"A": 0.6, "B": 0.1, "A|B": 0.3}, model=shafer),
            MassFunction({"A": 0.5, "B": 0.3, "A|B": 0.2}, model=shafer),
            MassFunction({"A": 0.4, "B": 0.1, "A|B": 0.5}, model=shafer)]


def pcr5_two_sources_on_ab(m1: dict, m2: dict) -> dict:
    """Two-source PCR5 of SPEC A.3 on Shafer's model of {A, B}, exactly (keys 'A', 'B', 'A|B')."""
    meet = {("A", "A"): "A", ("A", "A|B"): "A", ("A|B", "A"): "A", ("B", "B"): "B", ("B", "A|B"): "B",
            ("A|B", "B"): "B", ("A|B", "A|B"): "A|B"}
    out = {"A": Fraction(0), "B": Fraction(0), "A|B": Fraction(0)}
    for x, vx in m1.items():
        for y, vy in m2.items():
            if (x, y) in meet:
                out[meet[(x, y)]] += vx * vy
            else:   # A against B
                out[x] += vx * vx * vy / (vx + vy)
                out[y] += vy * vy * vx / (vx + vy)
    return out


def test_pcr5_is_not_associative():
    # JAIF 2021 Example 2: the joint three-source PCR5 gives A .723281, B .182460, A∪B .094259,
    # while folding the two-source rule gives another result.  Hand-computed fold: PCR5(m1, m2) =
    # {A: .57 + .12 + .25/6, B: .14 + .06 + .05/6, A∪B: .06} (the conflicts .6·.3 and .1·.5 shared
    # as .6²·.3/.9, .6·.3²/.9 and .1·.5²/.6, .1²·.5/.6), then PCR5 with m3 the same way, which
    # leaves A∪B = .06·.5 = .03 (evidencelib agrees: A .801664, B .168336, A∪B .03).
    m1, m2, m3 = jaif_example_2()
    f = {k: Fraction(v).limit_denominator(1000) for k, v in (("A", 0.6), ("B", 0.1), ("A|B", 0.3))}
    g = {k: Fraction(v).limit_denominator(1000) for k, v in (("A", 0.5), ("B", 0.3), ("A|B", 0.2))}
    h = {k: Fraction(v).limit_denominator(1000) for k, v in (("A", 0.4), ("B", 0.1), ("A|B", 0.5))}
    first = pcr5_two_sources_on_ab(f, g)
    assert first == {"A": Fraction(57, 100) + Fraction(12, 100) + Fraction(25, 600),
                     "B": Fraction(14, 100) + Fraction(6, 100) + Fraction(5, 600), "A|B": Fraction(6, 100)}
    folded = pcr5_two_sources_on_ab(first, h)
    assert folded["A|B"] == Fraction(3, 100)
    left = combine(combine(m1, m2, rule="pcr5"), m3, rule="pcr5")
    for key, value in folded.items():
        assert left[key] == pytest.approx(float(value), abs=1e-12)
    assert sequential(m1, m2, m3, rule="pcr5").isclose(left)
    joint = combine(m1, m2, m3, rule="pcr5")
    assert joint["A"] == pytest.approx(0.723281, abs=1e-6)
    assert abs(joint["A"] - left["A"]) > 0.07 and abs(joint["A|B"] - left["A|B"]) > 0.06
    right = combine(m1, combine(m2, m3, rule="pcr5"), rule="pcr5")
    assert not right.isclose(left, abs_tol=1e-6) and not right.isclose(joint, abs_tol=1e-6)


# -- neutral elements ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("rule", ["conjunctive", "dempster", "dsmc"])
@settings(max_examples=40)
@given(fc=fusion_cases(dynamic=False))
def test_the_vacuous_mass_is_neutral(rule, fc):
    masses = fc.build()
    vacuous = MassFunction.vacuous(model=fc.source.model)
    assert same(combine(masses[0], vacuous, rule=rule), masses[0])
    assert same(combine(vacuous, masses[0], rule=rule), masses[0])
    assert same(outcome(*masses, vacuous, rule=rule), outcome(*masses, rule=rule))


@settings(max_examples=40)
@given(fc=fusion_cases(dynamic=False))
def test_the_vacuous_mass_absorbs_under_the_disjunctive_rule(fc):
    vacuous = MassFunction.vacuous(model=fc.source.model)
    assert same(combine(*fc.build(), vacuous, rule="disjunctive"), vacuous)


@pytest.mark.parametrize(
    ("rule", "expected"),
    [
        # JAIF 2021 Example 4: Example 2's three sources and a fourth, vacuous one; printed results
        # PCR5 A .654604, B .144825, A∪B .200571 and PCR6 A .647113, B .128342, A∪B .224545.
        ("pcr5", {"A": 0.654604, "B": 0.144825, "A|B": 0.200571}),
        ("pcr6", {"A": 0.647113, "B": 0.128342, "A|B": 0.224545}),
    ],
)
def test_the_vacuous_mass_is_not_neutral_for_pcr5_and_pcr6(rule, expected):
    # evidencelib agrees.
    sources = jaif_example_2()
    vacuous = MassFunction.vacuous(model=sources[0].model)
    with_vacuous = combine(*sources, vacuous, rule=rule)
    for key, value in expected.items():
        assert with_vacuous[key] == pytest.approx(value, abs=1e-6)
    assert with_vacuous["A|B"] > combine(*sources, rule=rule)["A|B"] + 0.1


# -- relations between rules -------------------------------------------------------------------------------------


@settings(max_examples=60)
@given(fc=fusion_cases(min_sources=2, max_sources=2, dynamic=None))
def test_pcr5_equals_pcr6_for_two_sources(fc):
    # SPEC A.3: for s = 2 PCR6 is PCR5.
    model = fusion_model(fc)
    assert same(outcome(*fc.build(), rule="pcr5", model=model), outcome(*fc.build(), rule="pcr6", model=model))


@settings(max_examples=60)
@given(fc=fusion_cases(kinds=("free",), dynamic=False))
def test_dsmc_has_no_conflict_on_the_free_model(fc):
    # On the free model no intersection is empty: DSmC leaves nothing on ∅, and the rules that
    # only differ in how they treat conflict all coincide with it.
    masses = fc.build()
    dsmc = combine(*masses, rule="dsmc")
    assert dsmc.empty_mass == 0.0
    for rule in ("conjunctive", "dempster", "dsmh", "dubois_prade", "yager", "pcr5", "pcr6"):
        assert same(combine(*masses, rule=rule), dsmc)


@settings(max_examples=60)
@given(fc=fusion_cases(dynamic=None))
def test_dempster_is_the_normalised_conjunctive_rule(fc):
    model = fusion_model(fc)
    conjunctive = combine(*fc.build(), rule="conjunctive", model=model)
    dempster = outcome(*fc.build(), rule="dempster", model=model)
    if all(not e.terms for e in conjunctive.focal):   # every product on ∅: total conflict
        assert dempster is TotalConflictError
        return
    assert same(dempster, conjunctive.normalized())
    # and Yager's rule is the conjunctive rule with m(∅) moved to total ignorance
    yager = combine(*fc.build(), rule="yager", model=model)
    assert yager[fc.fusion.model.total] == pytest.approx(
        conjunctive[fc.fusion.model.total] + conjunctive.empty_mass, abs=1e-12)
