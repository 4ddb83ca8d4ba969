"""The rules of belief.extra_rules: cautious, bold, average, murphy, pcr5_plus and pcr6_plus.

The slow literal references work on exact masses (Fractions):

    cautious   w_12(A) = min(w_1(A), w_2(A)), then ∩_{A⊂Θ} A^{w_12(A)} combined literally (Denœux 2008)
    bold       v_12(A) = min(v_1(A), v_2(A)), then ∪_{A≠∅} A_{v_12(A)} combined literally (Denœux 2008)
    average    (1/s) Σ_i m_i, on Venn-region sets under the fusion model
    murphy     the average combined s - 1 times with itself by Dempster's rule (Murphy 2000)
    PCR5+/6+   every tuple of focal elements (itertools.product): a non-empty intersection takes the
               product; a conflicting product goes to the distinct elements whose binary keeping index is
               1, in proportion to the product (PCR5+) or the sum (PCR6+) of the masses committed to each
               (Dezert, Dezert & Smarandache, JAIF 16(1), 2021, eqs. (23)-(26))

The keeping index is written here from its definition on region sets (cardinality = number of regions).
"""

import math
from fractions import Fraction
from itertools import product

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import (
    RULES,
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
from belief.cli import main
from belief.extra_rules import keeping_index
from belief.rules import get_rule
from tests.strategies import FusionCase, fusion_cases, subset_mass_lists, subset_text
from tests.test_representations import ref_from_v, ref_from_w, ref_v, ref_w

NEW_RULES = ["cautious", "bold", "average", "murphy", "pcr5_plus", "pcr6_plus"]
ANY_MODEL_RULES = ["average", "murphy", "pcr5_plus", "pcr6_plus"]

# -- references ----------------------------------------------------------------------------------------------


def ref_cautious(sources: list[dict], n: int) -> dict:
    weights = [ref_w(m, n) for m in sources]
    return ref_from_w({a: min(w[a] for w in weights) for a in range(1 << n)}, n)


def ref_bold(sources: list[dict], n: int) -> dict:
    weights = [ref_v(m, n) for m in sources]
    return ref_from_v({a: min(v[a] for v in weights) for a in range(1 << n)}, n)


def region_sources(fc: FusionCase) -> list[list[tuple[frozenset, Fraction]]]:
    """Each source as (regions under the fusion model, exact mass).

    Entries that denote one element under the sources' model are one focal element (a mass function adds
    their masses); elements that only the stricter fusion model identifies stay apart, as for PCR5.
    """
    out = []
    for source in fc.sources:
        merged: dict = {}
        for e, v in source:
            add(merged, fc.source.regions(e), v)
        out.append([(x & fc.fusion.allowed, v) for x, v in merged.items()])
    return out


def add(table: dict, key, value) -> None:
    table[key] = table.get(key, Fraction(0)) + value


def ref_average(sources) -> dict:
    out: dict = {}
    for source in sources:
        for x, v in source:
            add(out, x, v / len(sources))
    return {k: v for k, v in out.items() if v}


class RefTotalConflict(Exception):
    pass


def ref_murphy(sources) -> dict:
    mean = ref_average(sources)
    result = mean
    for _ in range(len(sources) - 1):
        out: dict = {}
        for x, v in result.items():
            for y, w in mean.items():
                add(out, x & y, v * w)
        result = out
    result.pop(frozenset(), None)
    kept = sum(result.values(), Fraction(0))
    if not kept:
        raise RefTotalConflict
    return {k: v / kept for k, v in result.items() if v}


def ref_keeping(elements: set) -> set:
    """Binary keeping index on region sets: by decreasing cardinality, X is kept if a strictly larger element
    was kept, or if some other element of no greater cardinality is not included in X."""
    kept: set = set()
    for size in sorted({len(x) for x in elements}, reverse=True):
        larger_kept = any(len(y) > size for y in kept)
        for x in (x for x in elements if len(x) == size):
            if larger_kept or any(y != x and len(y) <= size and not y <= x for y in elements):
                kept.add(x)
    return kept


def ref_pcr_plus(sources, products: bool) -> dict:
    out: dict = {}
    for combo in product(*sources):
        elements = [x for x, _ in combo]
        masses = [v for _, v in combo]
        p = math.prod(masses, start=Fraction(1))
        meet = frozenset.intersection(*elements)
        if meet:
            add(out, meet, p)
            continue
        weights = {}
        for x in ref_keeping(set(elements)):
            committed = [v for y, v in zip(elements, masses) if y == x]
            weights[x] = math.prod(committed, start=Fraction(1)) if products else sum(committed)
        total = sum(weights.values())
        for x, w in weights.items():
            add(out, x, p * w / total)
    return {k: v for k, v in out.items() if v}


def regions_result(result: MassFunction, fc: FusionCase) -> dict:
    out: dict = {}
    for e, v in result.items():
        key = fc.fusion.regions(e)
        out[key] = out.get(key, 0.0) + v
    return out


def assert_matches(actual: dict, expected: dict, tol: float = 1e-12) -> None:
    for key in set(actual) | set(expected):
        got, want = actual.get(key, 0.0), float(expected.get(key, 0))
        assert math.isclose(got, want, rel_tol=1e-9, abs_tol=tol), (sorted(key) if key else key, got, want)


def subset_result(result: MassFunction) -> dict:
    frame = result.frame
    return {sum(1 << frame.index(h) for h in str(e).split("|")) if e.terms else 0: v for e, v in result.items()}


def fusion_model(fc: FusionCase):
    return fc.fusion.model if fc.dynamic else None


SHAFER_AB = Model.shafer(Frame(["A", "B"]))
SHAFER_ABC = Model.shafer(Frame(["a", "b", "c"]))


def jaif_example_2():
    # T. Dezert, J. Dezert, F. Smarandache, "Improvement of proportional conflict redistribution rules of
    # combination of basic belief assignments", J. Adv. Inf. Fusion 16(1), 2021, Example 2.
    return [MassFunction({"A": 0.6, "B": 0.1, "A|B": 0.3}, model=SHAFER_AB),
            MassFunction({"A": 0.5, "B": 0.3, "A|B": 0.2}, model=SHAFER_AB),
            MassFunction({"A": 0.4, "B": 0.1, "A|B": 0.5}, model=SHAFER_AB)]


# -- the registry -------------------------------------------------------------------------------------------------


def test_the_rules_are_registered_with_their_properties():
    assert set(NEW_RULES) <= set(RULES)
    for name in NEW_RULES:
        assert RULES[name].function.__module__ == "belief.extra_rules" and RULES[name].summary
    # Denœux (2008): cautious and bold are commutative, associative and idempotent; the others are not associative.
    assert {n for n in NEW_RULES if RULES[n].associative} == {"cautious", "bold"}
    assert {n for n in NEW_RULES if RULES[n].keeps_conflict} == {"cautious", "bold", "average"}
    for alias, name in (("pcr5+", "pcr5_plus"), ("PCR6+", "pcr6_plus"), ("mean", "average"),
                        ("Cautious-Conjunctive", "cautious"), ("bold_disjunctive", "bold")):
        assert get_rule(alias) is RULES[name]


def test_the_command_line_lists_and_uses_the_rules(capsys, tmp_path):
    assert main(["rules"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert set(NEW_RULES) <= set(listed)
    m = MassFunction({"a": 0.6, "a|b": 0.4}, model=Model.shafer(Frame(["a", "b"])))
    path = tmp_path / "m.json"
    path.write_text(m.to_json(), encoding="utf-8")
    assert main(["combine", "--rule", "cautious", "--json", str(path), str(path)]) == 0
    assert MassFunction.from_json(capsys.readouterr().out).isclose(m)


# -- literature values --------------------------------------------------------------------------------------------


def test_cautious_rule_of_separable_mass_functions():
    # Denœux (2008): for m1 = ∩ A^{w1(A)} and m2 = ∩ A^{w2(A)}, the cautious combination is
    # ∩ A^{min(w1(A), w2(A))}.  m1 = {a}^.4 ∩ {a,b}^.5 = {a: .6, a∪b: .2, Θ: .2};
    # m2 = {a}^.6 ∩ {b,c}^.3 = {∅: .28, a: .12, b∪c: .42, Θ: .18};
    # result {a}^.4 ∩ {a,b}^.5 ∩ {b,c}^.3 = m1 ∩ {b,c}^.3 = {∅: .42, a: .18, b: .14, a∪b: .06, b∪c: .14, Θ: .06}.
    m1 = MassFunction({"a": 0.6, "a|b": 0.2, "a|b|c": 0.2}, model=SHAFER_ABC)
    m2 = MassFunction({"empty": 0.28, "a": 0.12, "b|c": 0.42, "a|b|c": 0.18}, model=SHAFER_ABC, subnormal=True)
    expected = {"empty": 0.42, "a": 0.18, "b": 0.14, "a|b": 0.06, "b|c": 0.14, "a|b|c": 0.06}
    result = combine(m1, m2, rule="cautious")
    assert result.isclose(MassFunction(expected, model=SHAFER_ABC, subnormal=True))
    exact = [{1: Fraction(3, 5), 3: Fraction(1, 5), 7: Fraction(1, 5)},
             {0: Fraction(7, 25), 1: Fraction(3, 25), 6: Fraction(21, 50), 7: Fraction(9, 50)}]
    assert_matches(subset_result(result), ref_cautious(exact, 3))
    # the unnormalised conjunctive rule counts the common {a} evidence twice: m(a) .6·.4 + ... differs
    assert not combine(m1, m2, rule="conjunctive").isclose(result)


def test_cautious_rule_is_not_the_conjunctive_rule_on_one_piece_of_evidence_seen_twice():
    # Denœux (2008), introduction: two experts who saw the same evidence {a}^.3 should not add up to {a}^.09.
    m = MassFunction({"a": 0.7, "a|b": 0.3}, model=Model.shafer(Frame(["a", "b"])))
    assert combine(m, m, rule="cautious") == m
    assert combine(m, m, rule="conjunctive")["a"] == pytest.approx(0.91)


def test_bold_rule_by_hand():
    # Denœux (2008), the dual rule: {a}_.6 ∪ {b}_.5 and {a}_.8 ∪ {b}_.2 (A_v: v on ∅, 1 - v on A) give
    # {a}_.6 ∪ {b}_.2 = {∅: .12, a: .4·.2, b: .6·.8, a∪b: .4·.8}.
    m1 = MassFunction({"empty": 0.3, "a": 0.2, "b": 0.3, "a|b": 0.2}, model=Model.shafer(Frame(["a", "b"])),
                      subnormal=True)
    m2 = MassFunction({"empty": 0.16, "a": 0.04, "b": 0.64, "a|b": 0.16}, model=m1.model, subnormal=True)
    result = combine(m1, m2, rule="bold")
    assert result.isclose(MassFunction({"empty": 0.12, "a": 0.08, "b": 0.48, "a|b": 0.32}, model=m1.model,
                                       subnormal=True))
    assert not result.isclose(combine(m1, m2, rule="disjunctive"))


def test_murphy_by_hand():
    # Murphy (2000) as tabulated by Deng et al. (Decision Support Systems 38, 2004): m1 = {A: .5, B: .2, C: .3},
    # m2 = {B: .9, C: .1}: A .1543, B .7469, C .0988.  By hand: the mean {A: .25, B: .55, C: .2} with itself
    # gives .0625, .3025, .04 over 1 - K = .405.
    shafer = Model.shafer(Frame(["A", "B", "C"]))
    m1 = MassFunction({"A": 0.5, "B": 0.2, "C": 0.3}, model=shafer)
    m2 = MassFunction({"B": 0.9, "C": 0.1}, model=shafer)
    result = combine(m1, m2, rule="murphy")
    assert result["A"] == pytest.approx(0.0625 / 0.405, abs=1e-12)
    assert result["B"] == pytest.approx(0.3025 / 0.405, abs=1e-12)
    assert result["C"] == pytest.approx(0.04 / 0.405, abs=1e-12)
    assert [round(result[h], 4) for h in "ABC"] == [0.1543, 0.7469, 0.0988]
    assert combine(m1, m2, rule="average").to_mapping() == {"A": 0.25, "B": 0.55, "C": 0.2}


def test_pcr5_plus_and_pcr6_plus_on_jaif_example_2():
    # JAIF 2021 Example 2.  PCR5/PCR6 give A∪B .094259 (rules.py, test_rules_laws); PCR5+/PCR6+ give A∪B only its
    # consensus .3·.2·.5 = .03, because in every conflicting tuple that holds A∪B, A∪B contains the other elements
    # (A and B) and takes no part in the conflict.  The rest, exactly (evidencelib agrees to 1e-6):
    # PCR5+ A .768631, B .201369; PCR6+ A .788847, B .181153.
    ms = jaif_example_2()
    a, b, ab = frozenset({1}), frozenset({2}), frozenset({1, 2})          # regions of A, B, A∪B
    exact = [[(a, Fraction(6, 10)), (b, Fraction(1, 10)), (ab, Fraction(3, 10))],
             [(a, Fraction(5, 10)), (b, Fraction(3, 10)), (ab, Fraction(2, 10))],
             [(a, Fraction(4, 10)), (b, Fraction(1, 10)), (ab, Fraction(5, 10))]]
    for rule, products, printed in (("pcr5_plus", True, (0.768631, 0.201369)),
                                    ("pcr6_plus", False, (0.788847, 0.181153))):
        result = combine(*ms, rule=rule)
        expected = ref_pcr_plus(exact, products)
        assert expected[ab] == Fraction(3, 100)
        assert result["A|B"] == pytest.approx(0.03, abs=1e-15)
        assert result["A"] == pytest.approx(float(expected[a]), abs=1e-12)
        assert result["B"] == pytest.approx(float(expected[b]), abs=1e-12)
        assert (round(result["A"], 6), round(result["B"], 6)) == printed
        assert combine(*ms, rule=rule.replace("_plus", ""))["A|B"] == pytest.approx(0.094259, abs=1e-6)


def test_the_vacuous_mass_is_neutral_for_pcr5_plus_and_pcr6_plus():
    # JAIF 2021, Example 4 and the abstract: unlike PCR5 and PCR6, PCR5+ and PCR6+ keep the vacuous mass function
    # neutral (PCR5 with the vacuous fourth source moves A∪B from .094259 to .200571).
    ms = jaif_example_2()
    vacuous = MassFunction.vacuous(model=SHAFER_AB)
    for rule in ("pcr5_plus", "pcr6_plus"):
        assert combine(*ms, vacuous, rule=rule).isclose(combine(*ms, rule=rule), abs_tol=1e-15)
    assert combine(*ms, vacuous, rule="pcr5")["A|B"] == pytest.approx(0.200571, abs=1e-6)


def test_keeping_index_by_hand():
    # JAIF 2021 eq. (24).  {A, B, A∪B}: A∪B contains A and B, index 0.  {A, C, A∪B}: A∪B meets C in nothing,
    # index 1.  {A∪B∪C, A∪B, A, B}: the two largest contain everything smaller, index 0.  {C∪D, A∪B, A}:
    # C∪D is kept (A∪B is not in it), so everything smaller is kept.
    frame = Frame(["A", "B", "C", "D"])
    shafer = Model.shafer(frame)

    def kept(*texts):
        return sorted(str(e) for e in keeping_index([shafer.element(t) for t in texts], shafer))

    assert kept("A", "B", "A|B") == ["A", "B"]
    assert kept("A", "C", "A|B") == ["A", "A|B", "C"]
    assert kept("A|B|C", "A|B", "A", "B") == ["A", "B"]
    assert kept("C|D", "A|B", "A") == ["A", "A|B", "C|D"]
    assert kept("A", "B", "A", "A|B") == ["A", "B"]          # repeats are one element


# -- laws: cautious and bold ------------------------------------------------------------------------------------


def same(a, b, tol=1e-12) -> bool:
    return a.isclose(b, rel_tol=1e-9, abs_tol=tol)


@settings(max_examples=30)
@given(sources=subset_mass_lists(min_sources=2, max_sources=3, max_n=3, total=True))
def test_cautious_matches_the_reference(sources):
    result = combine(*(sm.build() for sm in sources), rule="cautious")
    assert_matches(subset_result(result), ref_cautious([sm.exact() for sm in sources], sources[0].n))


@settings(max_examples=30)
@given(sources=subset_mass_lists(min_sources=2, max_sources=3, max_n=3, empty=True))
def test_bold_matches_the_reference(sources):
    result = combine(*(sm.build() for sm in sources), rule="bold")
    assert_matches(subset_result(result), ref_bold([sm.exact() for sm in sources], sources[0].n))


@pytest.mark.parametrize(("rule", "option"), [("cautious", "total"), ("bold", "empty")])
@settings(max_examples=25)
@given(data=st.data())
def test_cautious_and_bold_are_idempotent_commutative_and_associative(rule, option, data):
    a, b, c = (sm.build() for sm in data.draw(subset_mass_lists(3, 3, max_n=4, **{option: True})))
    assert same(combine(a, a, rule=rule), a)
    assert same(combine(a, b, rule=rule), combine(b, a, rule=rule))
    joint = combine(a, b, c, rule=rule)
    assert same(joint, combine(combine(a, b, rule=rule), c, rule=rule))
    assert same(joint, combine(a, combine(b, c, rule=rule), rule=rule))
    assert same(joint, sequential(a, b, c, rule=rule))
    for result in (joint, combine(a, b, rule=rule)):
        assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-12) and (result.values > 0).all()


@settings(max_examples=25)
@given(sources=subset_mass_lists(min_sources=2, max_sources=2, max_n=3, total=True, empty=True))
def test_cautious_is_more_committed_than_each_source(sources):
    # Denœux (2008): m1 ∧ m2 is w-more committed than m1 and m2, so its commonality is at most
    # theirs (q-ordering follows from the w-ordering).
    from belief.representations import commonality, conjunctive_weights

    masses = [sm.build() for sm in sources]
    result = combine(*masses, rule="cautious")
    for m in masses:
        assert (conjunctive_weights(result) <= conjunctive_weights(m) + 1e-12).all()
        assert (commonality(result) <= commonality(m) + 1e-12).all()


# -- laws: every new rule ----------------------------------------------------------------------------------------------


def outcome(*sources, rule, **kwargs):
    try:
        return combine(*sources, rule=rule, **kwargs)
    except (TotalConflictError, ModelError) as exc:
        return type(exc)


@pytest.mark.parametrize("rule", ANY_MODEL_RULES)
@settings(max_examples=25)
@given(fc=fusion_cases(dynamic=None))
def test_rules_for_every_model_match_the_reference(rule, fc):
    masses = fc.build()
    sources = region_sources(fc)
    vanishing = any(not x for s in sources for x, _ in s)
    if rule in ("pcr5_plus", "pcr6_plus") and vanishing:
        with pytest.raises(ModelError, match="empty under"):
            combine(*masses, rule=rule, model=fusion_model(fc))
        return
    try:
        expected = {"average": ref_average, "murphy": ref_murphy, "pcr5_plus": lambda s: ref_pcr_plus(s, True),
                    "pcr6_plus": lambda s: ref_pcr_plus(s, False)}[rule](sources)
    except RefTotalConflict:
        with pytest.raises(TotalConflictError):
            combine(*masses, rule=rule, model=fusion_model(fc))
        return
    result = combine(*masses, rule=rule, model=fusion_model(fc))
    assert isinstance(result, MassFunction) and result.model == fc.fusion.model
    assert_matches(regions_result(result, fc), expected)


@pytest.mark.parametrize("rule", ANY_MODEL_RULES)
@settings(max_examples=20)
@given(fc=fusion_cases(dynamic=None))
def test_masses_sum_to_one_and_none_is_negative(rule, fc):
    result = outcome(*fc.build(), rule=rule, model=fusion_model(fc))
    if isinstance(result, type):
        return
    assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-12)
    assert (result.values > 0).all()
    if not RULES[rule].keeps_conflict:
        assert result.empty_mass == 0.0


@pytest.mark.parametrize("rule", ["cautious", "bold"])
@settings(max_examples=20)
@given(data=st.data())
def test_cautious_and_bold_conserve_mass(rule, data):
    option = {"cautious": {"total": True}, "bold": {"empty": True}}[rule]
    sources = data.draw(subset_mass_lists(2, 4, max_n=4, **option))
    result = combine(*(sm.build() for sm in sources), rule=rule)
    assert math.fsum(result.values) == pytest.approx(1.0, abs=1e-12)
    assert (result.values > 0).all()


@pytest.mark.parametrize("rule", ANY_MODEL_RULES)
@settings(max_examples=15)
@given(data=st.data())
def test_the_order_of_the_sources_does_not_matter(rule, data):
    fc = data.draw(fusion_cases(dynamic=None))
    masses = fc.build()
    shuffled = data.draw(st.permutations(masses))
    a, b = outcome(*masses, rule=rule, model=fusion_model(fc)), outcome(*shuffled, rule=rule, model=fusion_model(fc))
    assert a is b if isinstance(a, type) else same(a, b)


@settings(max_examples=30)
@given(fc=fusion_cases(min_sources=2, max_sources=2, dynamic=None))
def test_pcr5_plus_and_pcr6_plus_are_pcr5_for_two_sources(fc):
    # JAIF 2021: for two sources no element of a conflicting pair contains the other, so nothing is dropped.
    model = fusion_model(fc)
    reference = outcome(*fc.build(), rule="pcr5", model=model)
    for rule in ("pcr5_plus", "pcr6_plus"):
        result = outcome(*fc.build(), rule=rule, model=model)
        assert result is reference if isinstance(reference, type) else same(result, reference)


@pytest.mark.parametrize("rule", ["pcr5_plus", "pcr6_plus"])
@settings(max_examples=20)
@given(fc=fusion_cases(max_sources=3, dynamic=False))
def test_the_vacuous_mass_is_neutral(rule, fc):
    masses = fc.build()
    vacuous = MassFunction.vacuous(model=fc.source.model)
    assert same(combine(*masses, vacuous, rule=rule), combine(*masses, rule=rule))
    assert same(combine(masses[0], vacuous, rule=rule), masses[0])


@pytest.mark.parametrize("rule", NEW_RULES)
@settings(max_examples=12)
@given(data=st.data())
def test_a_batch_is_combined_row_by_row(rule, data):
    option = {"cautious": {"total": True}, "bold": {"empty": True}}.get(rule, {"empty": False})
    rows = [data.draw(subset_mass_lists(2, 2, min_n=3, max_n=3, **option)) for _ in range(3)]
    frame = rows[0][0].frame
    rows = [[sm.__class__(frame, sm.masses) for sm in pair] for pair in rows]
    first = MassBatch.from_mass_functions([pair[0].build() for pair in rows])
    second = MassBatch.from_mass_functions([pair[1].build() for pair in rows])
    try:
        fused = combine(first, second, rule=rule)
    except TotalConflictError:
        return
    assert isinstance(fused, MassBatch) and len(fused) == 3
    for k, pair in enumerate(rows):
        assert same(fused[k], combine(pair[0].build(), pair[1].build(), rule=rule))
    # a one-row source is broadcast
    broadcast = combine(first, second[0], rule=rule)
    for k in range(3):
        assert same(broadcast[k], combine(first[k], second[0], rule=rule))


@pytest.mark.parametrize("rule", ["average", "murphy", "pcr5_plus", "pcr6_plus"])
def test_non_associative_rules_are_combined_jointly(rule):
    # For these rules folding pairwise is another rule; combine() must evaluate the s-source definition.
    ms = jaif_example_2()
    joint = combine(*ms, rule=rule)
    folded = combine(combine(ms[0], ms[1], rule=rule), ms[2], rule=rule)
    assert not joint.isclose(folded, abs_tol=1e-6)
    assert sequential(*ms, rule=rule).isclose(folded)
    exact = [[(frozenset({1 << SHAFER_AB.frame.index(h) for h in str(e).split("|")}),
               Fraction(v).limit_denominator(100)) for e, v in m.items()] for m in ms]
    expected = {"average": ref_average, "murphy": ref_murphy, "pcr5_plus": lambda s: ref_pcr_plus(s, True),
                "pcr6_plus": lambda s: ref_pcr_plus(s, False)}[rule](exact)
    got = {frozenset({1 << SHAFER_AB.frame.index(h) for h in str(e).split("|")}): v for e, v in joint.items()}
    assert_matches(got, expected)


# -- bad input ------------------------------------------------------------------------------------------------------


def test_cautious_refuses_dogmatic_sources():
    m1 = MassFunction({"a": 0.6, "a|b|c": 0.4}, model=SHAFER_ABC)
    dogmatic = MassFunction({"a": 0.6, "b": 0.4}, model=SHAFER_ABC)
    with pytest.raises(InvalidMassError, match=r"non-dogmatic .*source 2 has m\(Θ\) = 0"):
        combine(m1, dogmatic, rule="cautious")
    batch = MassBatch.from_mass_functions([m1, dogmatic])
    with pytest.raises(InvalidMassError, match=r"source 1 .*\(row 1\)"):
        combine(batch, m1, rule="cautious")


def test_bold_refuses_normal_sources():
    m1 = MassFunction({"empty": 0.2, "a": 0.8}, model=SHAFER_ABC, subnormal=True)
    normal = MassFunction({"a": 0.6, "b": 0.4}, model=SHAFER_ABC)
    with pytest.raises(InvalidMassError, match=r"subnormal .*source 2 has m\(∅\) = 0"):
        combine(m1, normal, rule="bold")


@pytest.mark.parametrize("rule", ["cautious", "bold"])
def test_cautious_and_bold_need_shafers_model(rule):
    free = Model.free(Frame(["a", "b"]))
    m = MassFunction({"empty": 0.5, "a|b": 0.5}, model=free, subnormal=True)
    with pytest.raises(ModelError, match="Shafer's model"):
        combine(m, m, rule=rule)
    # dynamic fusion under Shafer's model is fine: the sources are read under it first
    m = MassFunction({"a&b": 0.2, "empty": 0.3, "a|b": 0.5}, model=free, subnormal=True)
    shafer = Model.shafer(free.frame)
    assert same(combine(m, m, rule=rule, model=shafer), m.under(shafer))


@pytest.mark.parametrize("rule", ["pcr5_plus", "pcr6_plus"])
def test_pcr_plus_refuses_subnormal_sources_and_vanishing_elements(rule):
    m = MassFunction({"a": 0.5, "b": 0.5}, model=SHAFER_ABC)
    subnormal = MassFunction({"empty": 0.2, "a": 0.8}, model=SHAFER_ABC, subnormal=True)
    with pytest.raises(InvalidMassError, match="normal"):
        combine(m, subnormal, rule=rule)
    free = Model.free(SHAFER_ABC.frame)
    with pytest.raises(ModelError, match="a&b"):
        combine(MassFunction({"a&b": 0.4, "c": 0.6}, model=free), MassFunction({"a": 1.0}, model=free), rule=rule,
                model=SHAFER_ABC)


def test_pcr_plus_refuses_too_many_tuples(monkeypatch):
    import belief.extra_rules as extra

    monkeypatch.setattr(extra, "MAX_PLUS_TUPLES", 9)
    m = MassFunction({"a": 0.5, "b": 0.3, "c": 0.2}, model=SHAFER_ABC)
    with pytest.raises(InvalidMassError, match="27 tuples"):
        combine(m, m, m, rule="pcr6_plus")
    assert combine(m, m, rule="pcr6_plus").isclose(combine(m, m, rule="pcr6"))      # 9 tuples: at the limit


def test_murphy_at_total_conflict():
    shafer = Model.shafer(Frame(["a", "b"]))
    empty = MassFunction({"empty": 1.0}, model=shafer, subnormal=True)
    with pytest.raises(TotalConflictError):
        combine(empty, empty, rule="murphy")
    assert combine(empty, empty, rule="average").empty_mass == 1.0


def test_subset_text_round_trip():
    frame = Frame(["a", "b", "c"])
    assert [subset_text(frame, k) for k in (0, 5, 7)] == ["empty", "a|c", "a|b|c"]
