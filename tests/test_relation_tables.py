"""The measure tables computed from integer codes equal the relations read element by element.

:mod:`belief.relation_tables` gives a :class:`~belief.batch.MeasurePlan` its (K, Q) tables from
the codes of :func:`belief.plan.encode`; the reference here is the literal definition on the
elements (∅ ≠ X ⊆ A, X ∩ A ≠ ∅ under the model, A ⊆ X, X = A, C_M(X ∩ A)).  The tables must be
equal entry for entry, on every kind of model, and a table over the limits is refused before it
is built.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import belief.batch
from belief import Frame, MassFunction, Model, ResourceLimitError
from belief.batch import MeasurePlan
from belief.relation_tables import coded_relations
from tests.strategies import elements, mass_cases


def literal(plan: MeasurePlan, name: str) -> np.ndarray:
    model = plan.model
    relation = {
        "subset": lambda x, a: bool(x.terms) and x <= a,
        "meets": lambda x, a: not model.is_empty(x & a),
        "superset": lambda x, a: a <= x,
        "equal": lambda x, a: x == a,
        "meet_cardinality": lambda x, a: float(model.cardinality(x & a)),
    }[name]
    return np.array([[relation(x, a) for a in plan.queries] for x in plan.focal],
                    dtype=np.float64).reshape(len(plan.focal), len(plan.queries))


RELATIONS = ("subset", "meets", "superset", "equal", "meet_cardinality")


@settings(max_examples=150, deadline=None)
@given(data=st.data(), case=mass_cases(min_n=1, max_n=5, max_focal=6, subnormal=None))
def test_coded_tables_equal_the_relations_read_element_by_element(data, case):
    m = case.build()
    model = m.model
    drawn = data.draw(st.lists(elements(m.frame), min_size=1, max_size=5))
    queries = tuple(model.reduce(q) for q in drawn) + tuple(m.focal)
    plan = MeasurePlan(model, tuple(m.focal), queries)
    coded = coded_relations(model, plan.focal, plan.queries)
    assert coded is not None                      # five hypotheses always have codes
    for name in RELATIONS:
        if name == "meet_cardinality" and coded.weights is None:
            continue
        np.testing.assert_array_equal(coded.table(name), literal(plan, name), err_msg=f"{name} under {case.case.label}")
        np.testing.assert_array_equal(getattr(plan, name), literal(plan, name), err_msg=name)


def test_a_wide_shafer_frame_codes_its_elements_in_several_words():
    names = [f"h{i}" for i in range(150)]
    frame = Frame(names)
    model = Model.shafer(frame)
    m = MassFunction({"h0|h149": 0.5, "h70|h80|h149": 0.25, "|".join(names[:100]): 0.25}, model=model)
    queries = tuple(model.reduce(frame.element(q)) for q in ("h149", "h0|h70", "|".join(names[60:]))) + tuple(m.focal)
    plan = MeasurePlan(model, tuple(m.focal), queries)
    assert coded_relations(model, plan.focal, plan.queries).focal.shape == (3, 3)
    for name in RELATIONS:
        np.testing.assert_array_equal(getattr(plan, name), literal(plan, name), err_msg=name)


def test_a_hybrid_model_with_exclusive_hypotheses_counts_their_own_regions():
    frame = Frame(["a", "b", "c"])
    model = Model.hybrid(frame, ["a&b"])          # a and b exclusive; each still meets c
    m = MassFunction({"a": 0.5, "a|b": 0.5}, model=model)
    plan = MeasurePlan(model, tuple(m.focal), (model.reduce(frame.element("b")), tuple(m.focal)[1]))
    assert coded_relations(model, plan.focal, plan.queries).weights is not None
    np.testing.assert_array_equal(plan.meet_cardinality, [[0.0, 2.0], [2.0, 4.0]])
    np.testing.assert_array_equal(plan.meet_cardinality, literal(plan, "meet_cardinality"))


def test_every_focal_element_as_a_query_is_fast_enough_to_need_no_more_than_the_codes():
    names = [f"h{i}" for i in range(20)]
    model = Model.shafer(Frame(names))
    masses = {"|".join(names[b] for b in range(20) if k >> b & 1): 1 / 1000 for k in range(1, 1001)}
    m = MassFunction(masses, model=model)
    batch = m.batch()
    queries = [str(e) for e in m.focal]
    bel, pls = batch.bel(queries)[0], batch.pls(queries)[0]
    for i in (0, 17, 999):
        assert bel[i] == m.bel(queries[i]) and pls[i] == m.pls(queries[i])
    assert np.all(bel <= pls)


def test_a_table_over_the_limit_is_refused_before_it_is_built(monkeypatch):
    frame = Frame(["x1", "x2", "x3"])              # names of this test only: no plan of another test is cached
    m = MassFunction({"x1": 0.5, "x1|x2": 0.25, "x2|x3": 0.25}, model=Model.shafer(frame))
    monkeypatch.setattr(belief.batch, "MAX_TABLE_ENTRIES", 8)
    with pytest.raises(ResourceLimitError) as caught:
        m.batch().bel(["x1", "x2", "x3"])
    assert caught.value.limit == "belief.batch.MAX_TABLE_ENTRIES"
    assert "3 focal elements by 3 queries holds 9 entries" in str(caught.value)


def test_element_by_element_tables_have_their_own_limit(monkeypatch):
    frame = Frame([f"t{i}" for i in range(13)])       # the free model of 13 hypotheses has no region codes
    m = MassFunction({"t0": 0.5, "t1|t2": 0.25, "t3&t4": 0.25}, frame=frame, model="free")
    assert coded_relations(m.model, tuple(m.focal), tuple(m.focal)) is None
    assert m.batch().bel(["t0", "t1"]).shape == (1, 2)
    monkeypatch.setattr(belief.batch, "MAX_ELEMENT_ENTRIES", 5)
    with pytest.raises(ResourceLimitError) as caught:
        m.batch().pls(["t0", "t1", "t2"])
    assert caught.value.limit == "belief.batch.MAX_ELEMENT_ENTRIES"


def sequential_sums(values: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Σ_k values[:, k] · table[k, q], term by term in the order of k, skipping weights of 0 (the literal definition)."""
    out = np.zeros((values.shape[0], table.shape[1]))
    for r in range(values.shape[0]):
        for q in range(table.shape[1]):
            total = 0.0
            for k in range(table.shape[0]):
                if table[k, q] != 0.0:
                    total += values[r, k] if table[k, q] == 1.0 else values[r, k] * table[k, q]
            out[r, q] = total
    return out


@settings(max_examples=100, deadline=None)
@given(rows=st.integers(1, 6), k=st.integers(1, 12), q=st.integers(1, 12), data=st.data())
def test_weighted_sums_add_term_by_term_whichever_loop_runs(rows, k, q, data):
    from belief.plan import weighted_sum

    floats = st.floats(-1e3, 1e3, allow_nan=False, allow_subnormal=True)
    weight = st.sampled_from([0.0, 0.0, 1.0, 0.5, 1 / 3, 2.0, 1e-300])
    values = np.array(data.draw(st.lists(floats, min_size=rows * k, max_size=rows * k))).reshape(rows, k)
    table = np.array(data.draw(st.lists(weight, min_size=k * q, max_size=k * q))).reshape(k, q)
    import belief.plan

    expected = sequential_sums(values, table)
    # A step costing nothing picks the loop over entries; a costly one the loop over focal elements
    # (where the table has more entries than focal elements): both give the literal sums.
    for step_cost in (0, 10**12, belief.plan._STEP_COST):
        saved = belief.plan._STEP_COST
        belief.plan._STEP_COST = step_cost
        try:
            np.testing.assert_array_equal(weighted_sum(values, table), expected, err_msg=f"step cost {step_cost}")
        finally:
            belief.plan._STEP_COST = saved


def test_the_command_line_names_the_option_that_raises_a_table_limit(tmp_path, capsys):
    import json

    from belief.cli import main

    names = [f"h{i}" for i in range(8)]
    masses = {"|".join(names[b] for b in range(8) if k >> b & 1): 1 / 40 for k in range(1, 41)}
    path = tmp_path / "forty.json"
    path.write_text(json.dumps({"model": {"type": "shafer"}, "frame": names, "mass": masses}), encoding="utf-8")
    assert main(["measures", str(path), "--max-table-entries", "1000"]) == 1
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "Traceback" not in error
    assert "40 focal elements by 40 queries holds 1,600 entries" in error
    assert "(--query PROP ...) or raise it with --max-table-entries N" in error
    assert main(["measures", str(path), "--max-table-entries", "1600", "--json"]) == 0
    table = json.loads(capsys.readouterr().out)
    assert len(table) == 40 and table["h0"]["bel"] == 1 / 40


def literal_jousselme(model, focal):
    size = len(focal)
    matrix = np.eye(size)
    for a in range(size):
        for b in range(a + 1, size):
            union = model.cardinality(focal[a] | focal[b])
            if union and model.cardinality(focal[a]) and model.cardinality(focal[b]):
                matrix[a, b] = matrix[b, a] = model.cardinality(focal[a] & focal[b]) / union
    return matrix


@settings(max_examples=100, deadline=None)
@given(case=mass_cases(min_n=1, max_n=5, max_focal=6, subnormal=None))
def test_jousselme_s_matrix_from_codes_equals_the_one_read_element_by_element(case):
    from belief.distances import jousselme_matrix

    m = case.build()
    focal = tuple(m.focal)
    np.testing.assert_array_equal(jousselme_matrix(m.model, focal), literal_jousselme(m.model, focal))


def test_jousselme_s_distance_of_many_focal_elements_is_refused_or_fast(monkeypatch):
    from belief.distances import jousselme_distance

    names = [f"y{i}" for i in range(12)]
    model = Model.shafer(Frame(names))
    masses = {"|".join(names[b] for b in range(12) if k >> b & 1): 1 / 2000 for k in range(1, 2001)}
    m = MassFunction(masses, model=model)
    vacuous = MassFunction({"|".join(names): 1.0}, model=model)
    with monkeypatch.context() as patch:
        patch.setattr(belief.batch, "MAX_TABLE_ENTRIES", 10**6)
        with pytest.raises(ResourceLimitError, match="Jousselme's matrix of 2,001 focal elements"):
            jousselme_distance(m, vacuous)
    assert 0 < jousselme_distance(m, vacuous) < 1


def test_each_measuring_command_says_what_avoids_a_table_refusal(tmp_path, capsys):
    import json

    from belief.cli import main

    names = [f"g{i}" for i in range(8)]              # a frame of this test only: no cached plan
    masses = {"|".join(names[b] for b in range(8) if k >> b & 1): 1 / 40 for k in range(1, 41)}
    path = tmp_path / "forty.json"
    path.write_text(json.dumps({"model": {"type": "shafer"}, "frame": names, "mass": masses}), encoding="utf-8")
    assert main(["uncertainty", str(path), "--max-table-entries", "1000"]) == 1
    error = capsys.readouterr().err
    assert "leave out discord, dissonance and confusion (--measure nonspecificity deng ambiguity) or raise it with " \
           "--max-table-entries N" in error
    assert main(["uncertainty", str(path), "--measure", "nonspecificity", "--max-table-entries", "1000"]) == 0
    capsys.readouterr()
    assert main(["distance", str(path), str(path), "--max-table-entries", "1000"]) == 1
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "use mass functions of fewer focal elements or raise it with " \
                                      "--max-table-entries N" in error
