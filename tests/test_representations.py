"""Representations on 2^Θ (b, q, w, v), the plausibility transform and contextual discounting.

A slow literal reference works on exact masses (Fractions) keyed by subset bit masks and loops over
every subset straight from the definitions:

    b(A) = Σ_{B⊆A} m(B)                      q(A) = Σ_{B⊇A} m(B)
    w(A) = Π_{B⊇A} q(B)^{(-1)^{|B|-|A|+1}}   (A ≠ Θ; Denœux 2008; w(Θ) = 1 by convention)
    v(A) = Π_{B⊆A} b(B)^{(-1)^{|A|-|B|+1}}   (A ≠ ∅; v(∅) = 1 by convention)

The exponents are ±1, so the weights are exact rationals too.  The decompositions are checked
the other way round as well, by combining the simple mass functions A^{w(A)} (1 - w on A, w on Θ)
with the conjunctive rule, and the negative ones A_{v(A)} (v on ∅, 1 - v on A) with the
disjunctive rule, literally.
"""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import (
    Frame,
    InvalidMassError,
    LatticeTooLargeError,
    MassBatch,
    MassFunction,
    Model,
    ModelError,
    UndefinedTransformError,
    UnknownHypothesisError,
    combine,
)
from belief.representations import (
    MAX_HYPOTHESES,
    commonality,
    conjunctive_weights,
    contextual_discount,
    disjunctive_weights,
    from_commonality,
    from_conjunctive_weights,
    from_disjunctive_weights,
    from_implicability,
    from_mass_vector,
    implicability,
    mass_vector,
    plausibility_transform,
    subset_element,
    subset_index,
)
from tests.strategies import SubsetMass, fusion_cases, subset_mass_lists, subset_masses, subset_text

# -- the literal reference ---------------------------------------------------------------------------------


def popcount(mask: int) -> int:
    return bin(mask).count("1")


def subsets(n: int) -> range:
    return range(1 << n)


def ref_b(m: dict, n: int) -> dict:
    return {a: sum((v for b, v in m.items() if b & ~a == 0), Fraction(0)) for a in subsets(n)}


def ref_q(m: dict, n: int) -> dict:
    return {a: sum((v for b, v in m.items() if a & ~b == 0), Fraction(0)) for a in subsets(n)}


def ref_w(m: dict, n: int) -> dict:
    q, full = ref_q(m, n), (1 << n) - 1
    w = {}
    for a in subsets(n):
        value = Fraction(1)
        if a != full:
            for b in subsets(n):
                if a & ~b == 0:
                    value *= q[b] ** (-1 if (popcount(b) - popcount(a)) % 2 == 0 else 1)
        w[a] = value
    return w


def ref_v(m: dict, n: int) -> dict:
    b = ref_b(m, n)
    v = {}
    for a in subsets(n):
        value = Fraction(1)
        if a:
            for c in subsets(n):
                if c & ~a == 0:
                    value *= b[c] ** (-1 if (popcount(a) - popcount(c)) % 2 == 0 else 1)
        v[a] = value
    return v


def ref_conjunctive(m1: dict, m2: dict) -> dict:
    out: dict = {}
    for a, x in m1.items():
        for b, y in m2.items():
            out[a & b] = out.get(a & b, Fraction(0)) + x * y
    return {k: v for k, v in out.items() if v}


def ref_disjunctive(m1: dict, m2: dict) -> dict:
    out: dict = {}
    for a, x in m1.items():
        for b, y in m2.items():
            out[a | b] = out.get(a | b, Fraction(0)) + x * y
    return {k: v for k, v in out.items() if v}


def ref_from_w(w: dict, n: int) -> dict:
    """∩_{A⊂Θ} A^{w(A)}, literally."""
    full = (1 << n) - 1
    m = {full: Fraction(1)}
    for a, weight in w.items():
        if a != full and weight != 1:
            m = ref_conjunctive(m, {a: 1 - weight, full: weight})
    return m


def ref_from_v(v: dict, n: int) -> dict:
    """∪_{A≠∅} A_{v(A)}, literally."""
    m = {0: Fraction(1)}
    for a, weight in v.items():
        if a and weight != 1:
            m = ref_disjunctive(m, {0: weight, a: 1 - weight})
    return m


def ref_pls(m: dict, x: int) -> Fraction:
    return sum((v for b, v in m.items() if b >> x & 1), Fraction(0))


def as_vector(table: dict, n: int) -> np.ndarray:
    return np.array([float(table.get(a, 0)) for a in subsets(n)])


def vector_of(m: MassFunction) -> np.ndarray:
    """The masses of a library mass function over 2^Θ, read through its public mapping interface."""
    return np.array([m[subset_text(m.frame, a)] for a in subsets(len(m.frame))])


def close(a, b, tol=1e-12) -> bool:
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), rtol=1e-9, atol=tol)


SHAFER_ABC = Model.shafer(Frame(["a", "b", "c"]))
SHAFER_AB = Model.shafer(Frame(["a", "b"]))


# -- layout ----------------------------------------------------------------------------------------------------


def test_the_binary_order_of_the_subsets():
    # Smets' fast Möbius transform order: bit k of the index is the k-th hypothesis.
    texts = [str(subset_element(SHAFER_ABC, i)) for i in range(8)]
    assert texts == ["empty", "a", "b", "a|b", "c", "a|c", "b|c", "a|b|c"]
    assert [subset_index(SHAFER_ABC, t) for t in texts] == list(range(8))
    assert subset_index(["a", "b", "c"], "c|a") == 5
    m = MassFunction({"b": 0.25, "a|c": 0.75}, model=SHAFER_ABC)
    assert mass_vector(m).tolist() == [0, 0, 0.25, 0, 0, 0.75, 0, 0]
    with pytest.raises(InvalidMassError):
        subset_element(SHAFER_ABC, 8)


# -- literature values -----------------------------------------------------------------------------------------


def test_commonality_and_implicability_by_hand():
    # m = {∅: .1, a: .3, b∪c: .6} on {a, b, c} (Smets 1993 definitions): b(a) = .1 + .3, b(b∪c) = .1 + .6,
    # q(b) = q(c) = q(b∪c) = .6, q(a) = .3, q(∅) = 1.
    m = MassFunction({"empty": 0.1, "a": 0.3, "b|c": 0.6}, model=SHAFER_ABC, subnormal=True)
    assert close(implicability(m), [0.1, 0.4, 0.1, 0.4, 0.1, 0.4, 0.7, 1.0])
    assert close(commonality(m), [1.0, 0.3, 0.6, 0, 0.6, 0, 0.6, 0])
    exact = {0: Fraction(1, 10), 1: Fraction(3, 10), 6: Fraction(6, 10)}
    assert close(implicability(m), as_vector(ref_b(exact, 3), 3))
    assert close(commonality(m), as_vector(ref_q(exact, 3), 3))


def test_conjunctive_weights_of_a_normal_mass_function_by_hand():
    # Smets (1995): a non-dogmatic m is ∩ A^{w(A)} with w possibly above 1.  m = {a: .3, b: .3, Θ: .4} on
    # {a, b}: q = (1, .7, .7, .4), so w(a) = w(b) = .4/.7 = 4/7 and w(∅) = q(a) q(b) / (q(∅) q(Θ)) = .49/.4
    # = 1.225 > 1: a^{4/7} ∩ b^{4/7} puts (3/7)² = 9/49 on ∅, which ∅^{1.225} takes back.
    m = MassFunction({"a": 0.3, "b": 0.3, "a|b": 0.4}, model=SHAFER_AB)
    assert close(conjunctive_weights(m), [1.225, 4 / 7, 4 / 7, 1.0])
    exact = {1: Fraction(3, 10), 2: Fraction(3, 10), 3: Fraction(2, 5)}
    assert ref_w(exact, 2) == {0: Fraction(49, 40), 1: Fraction(4, 7), 2: Fraction(4, 7), 3: Fraction(1)}
    assert ref_from_w(ref_w(exact, 2), 2) == exact


def test_separable_mass_functions_give_back_their_weights():
    # Denœux 2008: A^{w} gives 1 - w to A and w to Θ; {a}^.4 ∩ {a,b}^.5 = {a: .6, a∪b: .2, Θ: .2},
    # whose weights are .4 on {a}, .5 on {a, b} and 1 elsewhere (∅ included).
    m = MassFunction({"a": 0.6, "a|b": 0.2, "a|b|c": 0.2}, model=SHAFER_ABC)
    expected = np.ones(8)
    expected[[1, 3]] = [0.4, 0.5]
    assert close(conjunctive_weights(m), expected)
    # Dually (Denœux 2008), {a}_.6 ∪ {b}_.5 = {∅: .3, a: .2, b: .3, a∪b: .2} has v(a) = .6, v(b) = .5.
    m = MassFunction({"empty": 0.3, "a": 0.2, "b": 0.3, "a|b": 0.2}, model=SHAFER_AB, subnormal=True)
    assert close(disjunctive_weights(m), [1.0, 0.6, 0.5, 1.0])
    exact = {0: Fraction(3, 10), 1: Fraction(1, 5), 2: Fraction(3, 10), 3: Fraction(1, 5)}
    assert ref_v(exact, 2) == {0: 1, 1: Fraction(3, 5), 2: Fraction(1, 2), 3: 1}


def test_the_disjunctive_weights_are_the_conjunctive_weights_of_the_negation():
    # Denœux 2008: v(A) = w̄(Θ \ A), where m̄(A) = m(Θ \ A) (hand-picked m, and the reference).
    m = MassFunction({"empty": 0.2, "a": 0.1, "b|c": 0.3, "a|c": 0.4}, model=SHAFER_ABC, subnormal=True)
    negation = MassFunction({"a|b|c": 0.2, "b|c": 0.1, "a": 0.3, "b": 0.4}, model=SHAFER_ABC)
    v, w_bar = disjunctive_weights(m), conjunctive_weights(negation)
    assert close(v[1:], w_bar[::-1][1:])
    exact = {0: Fraction(1, 5), 1: Fraction(1, 10), 6: Fraction(3, 10), 5: Fraction(2, 5)}
    assert close(v, as_vector(ref_v(exact, 3), 3))


def test_plausibility_transform_by_hand():
    # Cobb & Shenoy (2006): P(x) ∝ Pls({x}).  m = {a: .5, b: .2, Θ: .3}: Pls = (.8, .5, .3), sum 1.6.
    m = MassFunction({"a": 0.5, "b": 0.2, "a|b|c": 0.3}, model=SHAFER_ABC)
    assert close(plausibility_transform(m), [0.5, 0.3125, 0.1875])
    # m(∅) does not count: the subnormal {∅: .5, a: .25, a∪b: .25} has Pls = (.5, .25).
    m = MassFunction({"empty": 0.5, "a": 0.25, "a|b": 0.25}, model=SHAFER_AB, subnormal=True)
    assert close(plausibility_transform(m), [2 / 3, 1 / 3])


def test_plausibility_transform_on_dsm_models():
    # Free model: every hypothesis meets every non-empty element, so the transform is uniform.
    free = Model.free(Frame(["a", "b", "c"]))
    assert close(plausibility_transform(MassFunction({"a": 0.6, "b&c": 0.4}, model=free)), [1 / 3] * 3)
    # θ_a ∩ θ_b ≡ ∅ only: {a: .6, b∩c: .4} has Pls(a) = .6 (a ∩ b ∩ c is empty), Pls(b) = .4 and
    # Pls(c) = .6 + .4 (a ∩ c is not empty), so P = (.6, .4, 1) / 2.
    hybrid = Model.hybrid(Frame(["a", "b", "c"]), ["a&b"])
    assert close(plausibility_transform(MassFunction({"a": 0.6, "b&c": 0.4}, model=hybrid)), [0.3, 0.2, 0.5])
    # Tracking model: every target is as plausible as any other (SPEC A.5), FA differs.
    tracking = Model.for_targets(2)
    m = MassFunction({"t1": 0.5, "t2": 0.2, "FA": 0.3}, model=tracking)
    p = plausibility_transform(m)
    assert p[0] == p[1] and close(p, [0.7 / 1.7, 0.7 / 1.7, 0.3 / 1.7])


def test_contextual_discounting_by_hand():
    # Mercier, Quost & Denœux (2008): m^α = m ∪ ∪_θ m_θ, m_θ(∅) = 1 - α_θ, m_θ({θ}) = α_θ.
    # m = {a: .7, b∪c: .3}, α = (a: .2, b: .5, c: 0).  m_a ∪ m_b = {∅: .4, a: .1, b: .4, a∪b: .1};
    # then a ∪ (that) = {a: .5, a∪b: .5} · .7 and b∪c ∪ (that) = {b∪c: .8, a∪b∪c: .2} · .3:
    # m^α = {a: .35, a∪b: .35, b∪c: .24, Θ: .06}.
    m = MassFunction({"a": 0.7, "b|c": 0.3}, model=SHAFER_ABC)
    result = contextual_discount(m, {"a": 0.2, "b": 0.5, "c": 0.0})
    expected = {"a": 0.35, "a|b": 0.35, "b|c": 0.24, "a|b|c": 0.06}
    assert result.isclose(MassFunction(expected, model=SHAFER_ABC))
    assert contextual_discount(m, [0.2, 0.5, 0.0]) == result
    # Mercier et al. 2008: Pls^α({θ}) = 1 - (1 - α_θ)(1 - Pls({θ})): Pls(a) = .7 → .76, Pls(b) = .3 → .65.
    assert result.pls("a") == pytest.approx(0.76, abs=1e-12) and result.pls("b") == pytest.approx(0.65, abs=1e-12)


def test_contextual_discounting_extremes():
    m = MassFunction({"a": 0.7, "b|c": 0.3}, model=SHAFER_ABC)
    assert contextual_discount(m, {"a": 0, "b": 0, "c": 0}) == m
    assert contextual_discount(m, [1.0, 1.0, 1.0]) == MassFunction.vacuous(model=SHAFER_ABC)
    # equal rates are not Shafer's discounting (that would put .5 on Θ; here Θ gets .3 · .5 + .7 · .25)
    half = contextual_discount(m, [0.5, 0.5, 0.5])
    assert half["a|b|c"] == pytest.approx(0.7 * 0.25 + 0.3 * 0.5, abs=1e-12)
    assert not half.isclose(m.discount(0.5))


# -- laws against the reference ------------------------------------------------------------------------------------


@settings(max_examples=60)
@given(sm=subset_masses(max_n=4))
def test_b_and_q_match_the_reference(sm: SubsetMass):
    m, exact, n = sm.build(), sm.exact(), sm.n
    assert close(implicability(m), as_vector(ref_b(exact, n), n))
    assert close(commonality(m), as_vector(ref_q(exact, n), n))
    assert close(mass_vector(m), as_vector(exact, n))


@settings(max_examples=40)
@given(sm=subset_masses(max_n=3, total=True))
def test_conjunctive_weights_match_the_reference(sm: SubsetMass):
    exact, n = sm.exact(), sm.n
    w = ref_w(exact, n)
    assert close(conjunctive_weights(sm.build()), as_vector(w, n), tol=1e-10)
    assert ref_from_w(w, n) == {k: v for k, v in exact.items() if v}     # the decomposition, literally


@settings(max_examples=40)
@given(sm=subset_masses(max_n=3, empty=True))
def test_disjunctive_weights_match_the_reference(sm: SubsetMass):
    exact, n = sm.exact(), sm.n
    v = ref_v(exact, n)
    assert close(disjunctive_weights(sm.build()), as_vector(v, n), tol=1e-10)
    assert ref_from_v(v, n) == {k: x for k, x in exact.items() if x}


@settings(max_examples=60)
@given(sm=subset_masses(max_n=5, total=True, empty=True, max_focal=8))
def test_round_trips_are_exact_to_1e_12(sm: SubsetMass):
    m = sm.build()
    model = m.model
    for forward, back in ((implicability, from_implicability), (commonality, from_commonality),
                          (conjunctive_weights, from_conjunctive_weights),
                          (disjunctive_weights, from_disjunctive_weights), (mass_vector, from_mass_vector)):
        again = back(forward(m), model)
        assert isinstance(again, MassFunction)
        assert np.abs(vector_of(again) - vector_of(m)).max() <= 1e-12, forward.__name__
        assert set(again.focal) == set(m.focal), forward.__name__       # no spurious focal element


@settings(max_examples=30)
@given(pair=subset_mass_lists(min_sources=2, max_sources=2, max_n=4))
def test_the_conjunctive_rule_multiplies_q_and_the_disjunctive_rule_multiplies_b(pair):
    # Smets (1993): q_{1∩2} = q_1 q_2 and b_{1∪2} = b_1 b_2 (here with the library's own rules).
    m1, m2 = (sm.build() for sm in pair)
    assert close(commonality(combine(m1, m2, rule="conjunctive")), commonality(m1) * commonality(m2))
    assert close(implicability(combine(m1, m2, rule="disjunctive")), implicability(m1) * implicability(m2))


@settings(max_examples=30)
@given(sources=subset_mass_lists(min_sources=2, max_sources=4, max_n=4, total=True, empty=True))
def test_a_batch_is_transformed_row_by_row(sources):
    masses = [sm.build() for sm in sources]
    batch = MassBatch.from_mass_functions(masses)
    model = batch.model
    for transform, back in ((implicability, from_implicability), (commonality, from_commonality),
                            (conjunctive_weights, from_conjunctive_weights),
                            (disjunctive_weights, from_disjunctive_weights)):
        rows = transform(batch)
        assert rows.shape == (len(masses), 1 << len(model.frame))
        for k, m in enumerate(masses):
            assert np.array_equal(rows[k], transform(m))
        again = back(rows, model)
        assert isinstance(again, MassBatch) and len(again) == len(masses)
        for k, m in enumerate(masses):
            assert again[k].isclose(m, abs_tol=1e-12)
    assert close(plausibility_transform(batch), np.array([plausibility_transform(m) for m in masses]))
    rates = np.linspace(0.1, 0.9, len(model.frame))
    discounted = contextual_discount(batch, rates)
    for k, m in enumerate(masses):
        assert discounted[k].isclose(contextual_discount(m, rates), abs_tol=1e-12)


@settings(max_examples=40)
@given(sm=subset_masses(max_n=4), data=st.data())
def test_contextual_discounting_is_the_disjunctive_combination_with_the_contexts(sm: SubsetMass, data):
    n, exact = sm.n, sm.exact()
    steps = data.draw(st.lists(st.integers(0, 4), min_size=n, max_size=n))
    alpha = [Fraction(k, 4) for k in steps]
    expected = exact
    for x, a in enumerate(alpha):
        expected = ref_disjunctive(expected, {0: 1 - a, 1 << x: a})
    rates = {name: float(a) for name, a in zip(sm.frame.hypotheses, alpha)}
    result = contextual_discount(sm.build(), rates)
    assert close(vector_of(result), as_vector(expected, n))
    # the same through the library's disjunctive rule, and the contour function of Mercier et al. (2008)
    contexts = [MassFunction({"empty": 1 - float(a), subset_text(sm.frame, 1 << x): float(a)}, model=sm.model,
                             subnormal=True) for x, a in enumerate(alpha) if a]
    if contexts:
        assert result.isclose(combine(sm.build(), *contexts, rule="disjunctive"), abs_tol=1e-12)
    for x, a in enumerate(alpha):
        pls = ref_pls(exact, x)
        assert result.pls(sm.frame.hypotheses[x]) == pytest.approx(float(1 - (1 - a) * (1 - pls)), abs=1e-12)


@settings(max_examples=40)
@given(pair=subset_mass_lists(min_sources=2, max_sources=2, max_n=4, empty=False))
def test_the_plausibility_transform_commutes_with_dempsters_rule(pair):
    # Cobb & Shenoy (2006): Pl_P(m1 ⊕ m2) = Pl_P(m1) ⊗ Pl_P(m2) (normalised product).
    m1, m2 = (sm.build() for sm in pair)
    exact1, exact2 = (sm.exact() for sm in pair)
    n = pair[0].n
    product = [ref_pls(exact1, x) * ref_pls(exact2, x) for x in range(n)]
    conflict = ref_conjunctive(exact1, exact2).get(0, Fraction(0))
    if conflict == 1:
        return
    fused = combine(m1, m2, rule="dempster")
    p = plausibility_transform(fused)
    if sum(product):
        assert close(p, [float(x / sum(product)) for x in product])
    assert close(plausibility_transform(m1) * plausibility_transform(m2) / np.dot(
        plausibility_transform(m1), plausibility_transform(m2)), p)


@settings(max_examples=40)
@given(fc=fusion_cases(min_sources=2, max_sources=2, kinds=("free", "hybrid", "tracking", "shafer")))
def test_the_plausibility_transform_follows_pls_on_every_model(fc):
    m = fc.build()[0]
    pls = np.array([m.pls(h) for h in m.frame.hypotheses])
    if pls.sum() == 0:
        with pytest.raises(UndefinedTransformError):
            plausibility_transform(m)
        return
    p = plausibility_transform(m)
    assert close(p, pls / pls.sum()) and p.sum() == pytest.approx(1.0, abs=1e-12) and (p >= 0).all()


def test_the_plausibility_transform_of_a_total_conflict_is_undefined():
    with pytest.raises(UndefinedTransformError, match="plausibility 0"):
        plausibility_transform(MassFunction({"empty": 1.0}, model=SHAFER_AB, subnormal=True))
    # θ_c declared empty: a mass function on c alone reads m(∅) = 1 under that model
    gone = Model.hybrid(Frame(["a", "b", "c"]), ["c"])
    with pytest.raises(UndefinedTransformError):
        plausibility_transform(MassFunction({"c": 1.0}, model=gone, subnormal=True))


# -- bad input ---------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", [Model.free(Frame(["a", "b"])), Model.for_targets(2),
                                   Model.hybrid(Frame(["a", "b", "c"]), ["a&b"])])
def test_other_models_are_refused(model):
    m = MassFunction.vacuous(model=model)
    for transform in (mass_vector, implicability, commonality, conjunctive_weights, disjunctive_weights):
        with pytest.raises(ModelError, match="Shafer's model"):
            transform(m)
    with pytest.raises(ModelError, match="Shafer's model"):
        contextual_discount(m, [0.1] * len(model.frame))
    with pytest.raises(ModelError, match="Shafer's model"):
        from_commonality([1.0, 1.0, 1.0, 1.0], model)


def test_a_hybrid_model_equal_to_shafers_is_accepted():
    # Model equality is by forbidden regions: declaring a∩b empty on {a, b} is Shafer's model.
    same = Model.hybrid(Frame(["a", "b"]), ["a&b"])
    m = MassFunction({"a": 0.5, "a|b": 0.5}, model=same)
    assert close(commonality(m), [1.0, 1.0, 0.5, 0.5])


def test_too_large_frames_are_refused():
    frame = Frame.numbered(MAX_HYPOTHESES + 1)
    m = MassFunction.vacuous(model=Model.shafer(frame))
    for transform in (mass_vector, commonality, conjunctive_weights):
        with pytest.raises(LatticeTooLargeError, match=str(MAX_HYPOTHESES)):
            transform(m)
    assert plausibility_transform(m).shape == (MAX_HYPOTHESES + 1,)     # needs no subset lattice


def test_weights_need_non_dogmatic_or_subnormal_mass_functions():
    dogmatic = MassFunction({"a": 0.5, "b": 0.5}, model=SHAFER_AB)
    with pytest.raises(UndefinedTransformError, match=r"non-dogmatic .*m\(Θ\) = 0"):
        conjunctive_weights(dogmatic)
    with pytest.raises(UndefinedTransformError, match=r"subnormal .*m\(∅\) = 0"):
        disjunctive_weights(dogmatic)
    batch = MassBatch.from_mass_functions([MassFunction.vacuous(model=SHAFER_AB), dogmatic])
    with pytest.raises(UndefinedTransformError, match="row 1"):
        conjunctive_weights(batch)


@pytest.mark.parametrize(
    ("rates", "error", "match"),
    [
        ({"a": -0.1, "b": 0.2, "c": 0.3}, InvalidMassError, r"rate of a must be in \[0, 1\]"),
        ({"a": 0.1, "b": 1.5, "c": 0.3}, InvalidMassError, r"rate of b must be in \[0, 1\]"),
        ({"a": 0.1, "b": float("nan"), "c": 0.3}, InvalidMassError, "rate of b"),
        ({"a": 0.1, "b": True, "c": 0.3}, InvalidMassError, "must be a number"),
        ({"a": 0.1, "b": 0.2, "c": 0.3, "d": 0.4}, UnknownHypothesisError, "unknown hypothesis 'd'"),
        ({"a": 0.1, "c": 0.3}, InvalidMassError, "missing: b"),
        ([0.1, 0.2], InvalidMassError, "shape"),
        ([0.1, -0.2, 0.3], InvalidMassError, r"rate of b must be in \[0, 1\]"),
        ([[0.1, 0.2, 0.3], [0.1, 0.2, 0.3]], InvalidMassError, "shape"),
        ("abc", InvalidMassError, "mapping"),
    ],
)
def test_bad_discount_rates(rates, error, match):
    m = MassFunction({"a": 0.7, "b|c": 0.3}, model=SHAFER_ABC)
    with pytest.raises(error, match=match):
        contextual_discount(m, rates)


def test_inverse_transforms_refuse_what_is_not_a_representation():
    with pytest.raises(InvalidMassError, match="shape"):
        from_commonality([1.0, 0.5, 0.5], SHAFER_AB)
    with pytest.raises(InvalidMassError, match="< 0"):
        from_commonality([1.0, 0.2, 0.2, 0.5], SHAFER_AB)          # m(Θ) = .5 but m(a) = .2 - .5 < 0
    with pytest.raises(InvalidMassError, match="sum to"):
        from_implicability([0.0, 0.1, 0.1, 0.9], SHAFER_AB)         # b(Θ) = .9
    with pytest.raises(InvalidMassError, match="positive"):
        from_conjunctive_weights([1.0, 0.0, 0.5, 1.0], SHAFER_AB)
    with pytest.raises(InvalidMassError, match="< 0"):
        from_conjunctive_weights([1.0, 2.0, 1.0, 1.0], SHAFER_AB)   # {a}^2 alone gives m(a) = -1
    with pytest.raises(InvalidMassError, match="finite"):
        from_disjunctive_weights([1.0, float("inf"), 0.5, 1.0], SHAFER_AB)
    with pytest.raises(InvalidMassError, match="< 0"):
        from_mass_vector([0.0, 1.5, -0.5, 0.0], SHAFER_AB)
    with pytest.raises(TypeError):
        commonality({"a": 1.0})
