"""Dempster, conjunctive, disjunctive and Yager against an exact reference in rational arithmetic.

The reference is the literal definition: every tuple of focal elements is visited, its
product taken in ``fractions.Fraction`` (every float is a rational, so the sources are
exact), and Dempster's rule divides by 1 - K (the sum of the non-empty masses) exactly.  Masses go down to 1e-300, where
products of two or more underflow double precision: the results must keep the ratios
(Dempster's rule divides tiny products by a tiny non-empty mass) and total conflict must
be reported only when the exact K is one.

Tolerance: 1e-12 relative, with an absolute floor of 1e-300.  A result below about 1e-300
is a product that double precision cannot hold with relative precision (it may even be
zero), so only its absolute error is bounded.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from belief import Frame, MassBatch, MassFunction, Model, TotalConflictError, combine

NAMES = ["h0", "h1", "h2", "h3", "h4"]
FRAME = Frame(NAMES)
MODELS = {"shafer": Model.shafer(FRAME), "free": Model.free(Frame(NAMES[:3]))}
RULES = ("dempster", "conjunctive", "disjunctive", "yager")
REL = 1e-12
ABS = 1e-300


class ExactTotalConflict(Exception):
    """The reference's Dempster normalisation divides by zero: K = 1 exactly."""


def reference(sources: list[MassFunction], rule: str, model: Model) -> dict:
    """The rule's result by its definition, over every tuple of focal elements, in exact arithmetic."""
    out: dict = {}
    items = [[(x, Fraction(v)) for x, v in zip(m.focal, m.values.tolist())] for m in sources]
    for combo in itertools.product(*items):
        element = combo[0][0]
        product = combo[0][1]
        for x, v in combo[1:]:
            element = element | x if rule == "disjunctive" else element & x
            product *= v
        element = model.reduce(element)
        out[element] = out.get(element, Fraction(0)) + product
    empty = model.frame.empty
    if rule == "dempster":
        # 1 - K, as the sum of the non-empty masses: the sources' floats need not sum to one exactly.
        out.pop(empty, None)
        kept = sum(out.values(), Fraction(0))
        if kept == 0:
            raise ExactTotalConflict
        return {x: v / kept for x, v in out.items()}
    if rule == "yager":
        conflict = out.pop(empty, Fraction(0))
        out[model.total] = out.get(model.total, Fraction(0)) + conflict
    return out


def assert_matches(got: dict, want: dict) -> None:
    for x in set(got) | set(want):
        g, w = got.get(x, 0.0), want.get(x, Fraction(0))
        assert abs(Fraction(g) - w) <= REL * w + Fraction(ABS), (str(x), g, float(w))


def check(sources: list[MassFunction], rule: str, model: Model) -> None:
    try:
        want = reference(sources, rule, model)
    except ExactTotalConflict:
        with pytest.raises(TotalConflictError):
            combine(*sources, rule=rule)
        with pytest.raises(TotalConflictError):
            combine(*[m.batch() for m in sources], rule=rule, engine="general")
        return
    single = combine(*sources, rule=rule)
    assert_matches(dict(zip(single.focal, single.values.tolist())), want)
    batch = combine(*[m.batch() for m in sources], rule=rule, engine="general")
    assert_matches(dict(zip(batch.focal, batch.values[0].tolist())), want)


# The strategies are built once: building one costs more than drawing from it.
SHAFER_MASKS = st.lists(st.integers(1, 2 ** len(NAMES) - 1), min_size=1, max_size=4, unique=True)
FREE_NAMES = st.lists(st.sampled_from(["h0", "h1", "h2", "h0|h1", "h1|h2", "h0&h1", "h0&h2", "h0|h1|h2", "h0&h1&h2",
                                       "h2|h0&h1"]), min_size=1, max_size=4, unique=True)
MANTISSAS = st.floats(0.5, 1.0)
EXPONENTS = st.sampled_from([0, 0, 1, 20, 150, 290, 300])


@st.composite
def mass_functions(draw, model: Model):
    """A mass function with 1 to 4 focal elements whose masses span 1 to 1e-300."""
    n = len(model.frame)
    if model.kind == "shafer":
        assert n == len(NAMES)
        masks = draw(SHAFER_MASKS)
        names = ["|".join(NAMES[i] for i in range(n) if mask >> i & 1) for mask in masks]
    else:
        names = draw(FREE_NAMES)
    weights = [draw(MANTISSAS) * 10.0 ** -draw(EXPONENTS) for _ in names]
    total = math.fsum(weights)
    return MassFunction({name: w / total for name, w in zip(names, weights)}, model=model)


MASS_FUNCTIONS = {kind: mass_functions(model) for kind, model in MODELS.items()}


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("kind", sorted(MODELS))
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_rules_agree_with_the_exact_reference(rule, kind, data):
    model = MODELS[kind]
    count = data.draw(st.integers(2, 4), label="sources")
    sources = [data.draw(MASS_FUNCTIONS[kind], label=f"source {k}") for k in range(count)]
    check(sources, rule, model)


SHAFER = MODELS["shafer"]


def test_products_that_underflow_keep_their_ratios():
    # Every product that reaches a non-empty element underflows; K < 1 all the same.
    m1 = MassFunction({"h4": 1.0, "h0|h1": 5e-324, "h2|h3": 1e-300}, model=SHAFER)
    m2 = MassFunction({"h0": 2 / 3, "h1": 1 / 3}, model=SHAFER)
    for sources in ([m1, m2], [m1.batch(), m2.batch()]):
        for engine in ("auto", "general"):
            fused = combine(*sources, rule="dempster", engine=engine)
            got = dict(zip(fused.focal, fused.values.reshape(-1).tolist()))
            assert got == pytest.approx({SHAFER.element("h0"): 2 / 3, SHAFER.element("h1"): 1 / 3}, rel=1e-15)
    check([m1, m2], "dempster", SHAFER)


def test_no_total_conflict_while_the_exact_conflict_is_below_one():
    m1 = MassFunction({"h4": 1.0, "h0": 1e-300}, model=SHAFER)
    m2 = MassFunction({"h3": 1.0, "h0": 1e-300}, model=SHAFER)
    m3 = MassFunction({"h2": 1.0, "h0|h1": 1e-300}, model=SHAFER)
    assert combine(m1, m2, rule="dempster").to_mapping() == {"h0": 1.0}
    assert combine(m1, m2, m3, rule="dempster").to_mapping() == {"h0": 1.0}
    batch = combine(MassBatch.from_mass_functions([m1, m1]), m2.batch(), rule="dempster")
    assert batch.values.tolist() == [[1.0], [1.0]]
    check([m1, m2, m3], "dempster", SHAFER)


def test_total_conflict_is_reported_where_the_exact_conflict_is_one():
    m1 = MassFunction({"h4": 1.0 - 1e-300, "h0": 1e-300}, model=SHAFER)
    m2 = MassFunction({"h3": 1.0}, model=SHAFER)
    with pytest.raises(TotalConflictError, match="total conflict"):
        combine(m1, m2, rule="dempster")
    check([m1, m2], "dempster", SHAFER)


def test_bayesian_batches_whose_agreement_underflows_go_the_general_way():
    # The closed forms cannot keep products below 2^-1074; the general path rescales them.
    model = Model.shafer(Frame(["a", "b", "c"]))
    a = MassBatch.bayesian([[1e-200, 1e-200, 1.0 - 2e-200], [0.5, 0.5, 0.0]], model=model)
    b = MassBatch.bayesian([[0.5, 0.5, 0.0], [0.5, 0.5, 0.0]], model=model)
    c = MassBatch.bayesian([[1e-200, 3e-200, 1.0 - 4e-200], [0.5, 0.5, 0.0]], model=model)
    fused = combine(a, b, c, rule="dempster")
    assert fused.focal == (model.element("a"), model.element("b"))
    np.testing.assert_allclose(fused.values, [[0.25, 0.75], [0.5, 0.5]], rtol=1e-15)
