"""Mass functions learnt from data (belief.learn): EK-NN, consonant likelihoods and the imprecise Dirichlet model.

The EK-NN masses are checked against a case worked by hand, against Dempster's rule of
belief.combine on the neighbours' simple support functions, and against evtools-dst's EkNN on
the data sets of tests/fixtures/learn/eknn_fixtures.json (made by make_eknn_fixtures.py there,
which says how it was run; evtools-dst itself is not needed here).
"""

from __future__ import annotations

import json
import math
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import belief.learn as learn
import belief.learn.distances as learn_distances
import belief.learn.eknn as learn_eknn
from belief import BeliefError, MassBatch, MassFunction, combine
from belief.learn import (EKNN, LearningDataError, LearningOptionError, NotFittedError, consonant_from_likelihood,
                          default_gamma, idm_from_counts, mean_pairwise_distance)

FIXTURES = json.loads((Path(__file__).parent / "fixtures" / "learn" / "eknn_fixtures.json").read_text("utf-8"))
CASES = sorted(FIXTURES["cases"])
SEARCHES = ("kdtree", "blocked")


def simple_support(label: str, support: float, frame: list[str]) -> MassFunction:
    """m({label}) = support, m(Θ) = 1 − support."""
    masses = {label: support, "|".join(frame): 1.0 - support}
    return MassFunction({x: v for x, v in masses.items() if v > 0}, frame=frame)


# -- a case by hand --------------------------------------------------------------------------------
def test_two_classes_three_neighbours_by_hand():
    # Query 1.5; neighbours 1.0 (a, d = 0.5), 0.0 (a, d = 1.5), 3.0 (b, d = 1.5); γ_a = 1, γ_b = 2, α = 0.9.
    clf = EKNN(k=3, alpha=0.9, gamma=[1.0, 2.0]).fit([[0.0], [1.0], [3.0], [5.0]], ["a", "a", "b", "b"])
    near, far_a, far_b = 0.9 * math.exp(-0.25), 0.9 * math.exp(-2.25), 0.9 * math.exp(-4 * 2.25)
    theta_a = (1 - near) * (1 - far_a)                  # what the two a neighbours leave on Θ
    theta_b = 1 - far_b
    numerators = [(1 - theta_a) * theta_b, (1 - theta_b) * theta_a, theta_a * theta_b]
    expected = np.array(numerators) / sum(numerators)
    masses = clf.predict_mass([[1.5]])
    assert [str(x) for x in masses.focal] == ["a", "b", "a|b"]
    assert masses.model.kind == "shafer" and masses.frame.hypotheses == ("a", "b")
    np.testing.assert_allclose(masses.values[0], expected, rtol=0, atol=1e-15)
    # s = 0.700921, 0.094860 (a) and 0.000111 (b): Θ keeps 0.299079 × 0.905140 = 0.270708 of a and 0.999889 of b;
    # numerators 0.729292 × 0.999889, 0.000111 × 0.270708 and 0.270708 × 0.999889, of sum 0.999919.
    assert masses.values[0].round(6).tolist() == [0.729269, 0.00003, 0.270701]
    assert clf.predict([[1.5]]).tolist() == ["a"]


def test_the_closed_form_is_dempsters_rule_of_the_neighbours():
    rng = np.random.default_rng(3)
    X = rng.normal(size=(40, 3))
    y = rng.choice(["u", "v", "w"], size=40)
    clf = EKNN(k=6, alpha=0.9).fit(X, y)
    queries = rng.normal(size=(5, 3))
    masses = clf.predict_mass(queries)
    frame = list(clf.frame_.hypotheses)
    for row, query in enumerate(queries):
        distance = np.sqrt(((X - query) ** 2).sum(axis=1))
        nearest = np.argsort(distance)[:6]
        sources = []
        for i in nearest:
            c = frame.index(str(y[i]))
            sources.append(simple_support(frame[c], 0.9 * math.exp(-clf.gamma_[c] ** 2 * distance[i] ** 2), frame))
        fused = combine(*sources, rule="dempster")
        expected = [fused.mass(x) for x in (*frame, "|".join(frame))]
        np.testing.assert_allclose(masses.values[row], expected, rtol=0, atol=1e-13)


# -- against evtools-dst --------------------------------------------------------------------------------
def test_the_fixtures_say_how_they_were_made():
    assert "make_eknn_fixtures.py" in FIXTURES["made_by"] and FIXTURES["evtools_dst"] == "0.27.1"
    assert CASES == ["duplicates", "small_classes", "three_classes", "two_classes"]


@pytest.mark.parametrize("search", SEARCHES)
@pytest.mark.parametrize("name", CASES)
def test_masses_equal_evtools_dst(name, search):
    case = FIXTURES["cases"][name]
    clf = EKNN(k=case["k"], alpha=case["alpha"], neighbours=search).fit(case["X_train"], case["y_train"])
    assert list(clf.frame_.hypotheses) == case["classes"]
    np.testing.assert_allclose(clf.gamma_, case["gamma"], rtol=1e-13, atol=0)
    masses = clf.predict_mass(case["X_test"])
    assert [str(x) for x in masses.focal] == [*case["classes"], "|".join(case["classes"])]
    difference = np.abs(masses.values - np.array(case["masses"])).max()
    assert difference <= 1e-9, f"{name}: masses differ from evtools-dst's by {difference:.3g}"
    assert [str(label) for label in clf.predict(case["X_test"])] == case["predict"]


@pytest.mark.parametrize("name", [n for n in CASES if "optimized_gamma" in FIXTURES["cases"][n]])
def test_learnt_gamma_does_at_least_as_well_as_evtools_dst(name):
    case = FIXTURES["cases"][name]
    clf = EKNN(k=case["k"], alpha=case["alpha"], optimize=True).fit(case["X_train"], case["y_train"])
    assert clf.loo_cost_ == pytest.approx(clf.loo_cost(clf.gamma_), abs=1e-15)
    assert clf.loo_cost_ <= clf.loo_cost(case["optimized_gamma"]) + 1e-9
    assert clf.loo_cost_ < clf.loo_cost(case["gamma"])
    # Where the optimum is sharp (two classes) the two optimisers land on the same γ.
    if name == "two_classes":
        np.testing.assert_allclose(clf.gamma_, case["optimized_gamma"], rtol=1e-3)


# -- learning γ ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("weight", [0.0, 1 / 3, 1.0])
def test_the_gradient_of_the_leave_one_out_cost_matches_finite_differences(weight):
    case = FIXTURES["cases"]["three_classes"]
    clf = EKNN(k=5, alpha=0.95, ignorance_weight=weight).fit(case["X_train"], case["y_train"])
    classes, sq_dist = clf._leave_one_out()
    point = np.log([0.5, 0.8, 0.3])
    _, gradient = clf._cost_and_gradient(point, classes, sq_dist)
    step = 1e-6
    for q in range(3):
        up, down = point.copy(), point.copy()
        up[q] += step
        down[q] -= step
        numeric = (clf._cost_and_gradient(up, classes, sq_dist)[0] - clf._cost_and_gradient(down, classes, sq_dist)[0])
        assert gradient[q] == pytest.approx(numeric / (2 * step), rel=1e-5, abs=1e-10)


def test_optimize_starts_from_a_given_gamma_and_keeps_it_above_the_floor():
    case = FIXTURES["cases"]["three_classes"]
    clf = EKNN(k=5, optimize=True, gamma=[1.0, 1.0, 1.0], max_iter=0).fit(case["X_train"], case["y_train"])
    assert clf.gamma_.tolist() == [1.0, 1.0, 1.0]
    learnt = EKNN(k=5, optimize=True, gamma=0.0).fit(case["X_train"], case["y_train"])
    assert (learnt.gamma_ >= learnt_floor()).all() and learnt.loo_cost_ < learnt.loo_cost([1.0, 1.0, 1.0])
    assert math.isnan(EKNN(k=5).fit(case["X_train"], case["y_train"]).loo_cost_)


def learnt_floor() -> float:
    return learn_eknn.GAMMA_FLOOR * (1 - 1e-12)


# -- the default γ and the neighbour searches -----------------------------------------------------------------
@pytest.mark.parametrize("use_scipy", [True, False])
def test_mean_pairwise_distance_over_blocks(monkeypatch, use_scipy):
    rng = np.random.default_rng(5)
    rows = 1e6 + rng.normal(size=(23, 3))                  # an offset far larger than the spread
    brute = np.mean([np.linalg.norm(rows[i] - rows[j]) for i in range(23) for j in range(i + 1, 23)])
    assert mean_pairwise_distance(rows, use_scipy=use_scipy) == pytest.approx(brute, rel=1e-9)
    monkeypatch.setattr(learn_distances, "PAIR_BLOCK_ROWS", 5)    # diagonal, off-diagonal and ragged blocks
    assert mean_pairwise_distance(rows, use_scipy=use_scipy) == pytest.approx(brute, rel=1e-9)


@pytest.mark.parametrize("use_scipy", [True, False])
def test_threads_do_not_change_the_mean(monkeypatch, use_scipy):
    monkeypatch.setattr(learn_distances, "PAIR_BLOCK_ROWS", 16)
    rows = np.random.default_rng(4).normal(size=(100, 4))
    one = mean_pairwise_distance(rows, use_scipy=use_scipy, threads=1)
    assert mean_pairwise_distance(rows, use_scipy=use_scipy, threads=2) == one
    assert mean_pairwise_distance(rows, use_scipy=use_scipy, threads=None) == one
    X, y = rows, np.array(["a", "b"] * 50)
    assert EKNN(threads=2).fit(X, y).predict_mass(rows).values.tolist() == \
        EKNN(threads=1).fit(X, y).predict_mass(rows).values.tolist()


def test_default_gamma_falls_back_to_one():
    X = np.array([[0.0, 0.0], [3.0, 4.0], [7.0, 7.0], [7.0, 7.0], [9.0, 9.0]])
    gamma = default_gamma(X, np.array([0, 0, 1, 1, 2]), 3)
    assert gamma.tolist() == [1 / math.sqrt(5.0), 1.0, 1.0]    # distance 5; identical rows; a single row


def test_the_default_gamma_holds_no_class_by_class_matrix():
    rows = np.random.default_rng(0).normal(size=(4000, 2))   # a 4000 × 4000 matrix would take 128 MB
    tracemalloc.start()
    try:
        mean_pairwise_distance(rows)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 40e6


def test_predict_mass_holds_no_query_by_training_matrix(monkeypatch):
    rng = np.random.default_rng(1)
    X, y = rng.normal(size=(20_000, 2)), rng.integers(0, 3, size=20_000)
    queries = rng.normal(size=(1_000, 2))                  # 1000 × 20000 distances would take 160 MB
    clf = EKNN(k=5, gamma=1.0, neighbours="blocked").fit(X, y)
    tracemalloc.start()
    try:
        clf.predict_mass(queries)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 60e6


def test_the_searches_agree_in_blocks(monkeypatch):
    rng = np.random.default_rng(2)
    X, y = rng.normal(size=(300, 4)), rng.choice(["x", "y", "z"], size=300)
    queries = rng.normal(size=(97, 4))
    tree = EKNN(k=7).fit(X, y)
    assert tree._search == "kdtree"
    whole = tree.predict_mass(queries).values
    monkeypatch.setattr(learn_eknn, "QUERY_BLOCK_ROWS", 10)
    monkeypatch.setattr(learn_distances, "DISTANCE_BLOCK_ENTRIES", 1000)      # 3 query rows at a time
    blocked = EKNN(k=7, neighbours="blocked").fit(X, y)
    np.testing.assert_allclose(blocked.gamma_, tree.gamma_, rtol=1e-13)
    np.testing.assert_allclose(blocked.predict_mass(queries).values, whole, rtol=0, atol=1e-15)
    np.testing.assert_allclose(tree.predict_mass(queries).values, whole, rtol=0, atol=0)
    assert EKNN(k=300, neighbours="blocked").fit(X, y).predict_mass(queries).values == pytest.approx(
        EKNN(k=300).fit(X, y).predict_mass(queries).values, abs=1e-13)


def test_without_scipy_the_numpy_search_and_distances_serve(monkeypatch):
    case = FIXTURES["cases"]["three_classes"]
    monkeypatch.setattr(learn_distances, "scipy_spatial", lambda: None)
    clf = EKNN(k=case["k"]).fit(case["X_train"], case["y_train"])
    assert clf._search == "blocked" and clf._tree is None
    np.testing.assert_allclose(clf.gamma_, case["gamma"], rtol=1e-13, atol=0)
    np.testing.assert_allclose(clf.predict_mass(case["X_test"]).values, case["masses"], rtol=0, atol=1e-9)
    with pytest.raises(LearningOptionError, match="neighbours='kdtree' needs scipy"):
        EKNN(k=2, neighbours="kdtree").fit(GOOD_X, GOOD_Y)


def test_integer_labels_and_an_empty_query():
    clf = EKNN(k=2).fit([[0.0], [1.0], [5.0], [6.0]], np.array([10, 10, 20, 20]))
    assert clf.frame_.hypotheses == ("10", "20") and clf.predict([[0.2], [5.5]]).tolist() == [10, 20]
    empty = clf.predict_mass(np.zeros((0, 1)))
    assert isinstance(empty, MassBatch) and empty.shape == (0, 3) and clf.predict(np.zeros((0, 1))).shape == (0,)


def test_the_masses_fuse_with_another_source():
    clf = EKNN(k=3).fit([[0.0], [1.0], [3.0], [4.0]], ["a", "a", "b", "b"])
    masses = clf.predict_mass([[2.0]])
    other = MassBatch.bayesian([[0.2, 0.8]], model=clf.model_)
    fused = combine(masses, other, rule="dempster")
    assert fused.betp("b")[0] > masses.betp("b")[0]


def test_many_close_neighbours_neither_overflow_nor_underflow():
    X = np.zeros((2000, 1))
    y = np.array(["a"] * 1000 + ["b"] * 1000)
    masses = EKNN(k=2000, alpha=0.99, gamma=1.0).fit(X, y).predict_mass([[0.0]]).values
    assert np.isfinite(masses).all() and masses[0].tolist() == [0.5, 0.5, 0.0]
    one_sided = EKNN(k=1000, alpha=0.99, gamma=1.0).fit(X[:1001], y[:1001]).predict_mass([[0.0]]).values
    assert one_sided[0].tolist() == [1.0, 0.0, 0.0]


# -- properties ---------------------------------------------------------------------------------------------------
training_sets = st.integers(min_value=0, max_value=2**32 - 1).map(np.random.default_rng)


@settings(max_examples=40)
@given(rng=training_sets, k=st.integers(1, 8), alpha=st.floats(0.0, 0.999), search=st.sampled_from(SEARCHES))
def test_masses_are_mass_functions(rng, k, alpha, search):
    X = rng.normal(size=(12, 2)) * rng.uniform(0.01, 100.0)
    y = rng.choice(["a", "b", "c"], size=12)
    y[:2] = ["a", "b"]
    masses = EKNN(k=k, alpha=alpha, neighbours=search).fit(X, y).predict_mass(rng.normal(size=(6, 2)) * 3).values
    assert (masses >= 0).all()
    np.testing.assert_allclose(masses.sum(axis=1), 1.0, rtol=0, atol=1e-12)


@settings(max_examples=40)
@given(rng=training_sets, alpha=st.floats(0.0, 0.999))
def test_one_neighbour_gives_its_simple_support_function(rng, alpha):
    X = rng.normal(size=(10, 3))
    y = np.array(["p", "q"] * 5)
    clf = EKNN(k=1, alpha=alpha).fit(X, y)
    query = rng.normal(size=(1, 3))
    distance = np.sqrt(((X - query) ** 2).sum(axis=1))
    nearest = int(np.argmin(distance))
    c = clf.frame_.hypotheses.index(y[nearest])
    support = alpha * math.exp(-clf.gamma_[c] ** 2 * distance[nearest] ** 2)
    expected = np.zeros(3)
    expected[c], expected[2] = support, 1 - support
    np.testing.assert_allclose(clf.predict_mass(query).values[0], expected, rtol=0, atol=1e-15)


@settings(max_examples=30)
@given(rng=training_sets, k=st.integers(1, 6), alpha=st.sampled_from([0.0, 1e-300, 1e-12]))
def test_alpha_towards_zero_gives_the_vacuous_mass_function(rng, k, alpha):
    X = rng.normal(size=(9, 2))
    y = np.array(["a", "b", "c"] * 3)
    masses = EKNN(k=k, alpha=alpha).fit(X, y).predict_mass(rng.normal(size=(4, 2))).values
    np.testing.assert_allclose(masses, np.tile([0.0, 0.0, 0.0, 1.0], (4, 1)), rtol=0, atol=10 * k * alpha)
    if alpha == 0.0:
        assert masses.tolist() == [[0.0, 0.0, 0.0, 1.0]] * 4


# -- bad input ------------------------------------------------------------------------------------------------------
GOOD_X, GOOD_Y = [[0.0], [1.0], [2.0], [3.0]], ["a", "a", "b", "b"]


@pytest.mark.parametrize("X, y, message", [
    ([[0.0], [np.nan], [2.0], [3.0]], GOOD_Y, "holds nan in row 1, feature 0"),
    ([0.0, 1.0, 2.0, 3.0], GOOD_Y, "must have shape (N, p)"),
    ([["a"], ["b"], ["c"], ["d"]], GOOD_Y, "must be an array of numbers"),
    ([[True], [False], [True], [False]], GOOD_Y, "not booleans"),
    (np.zeros((4, 0)), GOOD_Y, "has no features"),
    (GOOD_X, ["a", "a", "b"], "one label per row of X"),
    (GOOD_X, ["a"] * 4, "at least two classes"),
    (GOOD_X, [0.0, np.nan, 1.0, 1.0], "holds NaN in row 1"),
    (GOOD_X, ["a", "a", "b c", "b c"], "the label 'b c' cannot name a hypothesis"),
    (GOOD_X, ["a", "a", "x|y", "x|y"], "cannot name a hypothesis"),
])
def test_bad_training_data_is_refused(X, y, message):
    with pytest.raises(LearningDataError) as caught:
        EKNN(k=2).fit(X, y)
    assert message in str(caught.value)
    assert isinstance(caught.value, BeliefError) and isinstance(caught.value, ValueError)


@pytest.mark.parametrize("options, message", [
    (dict(k=0), "k must be a positive integer"),
    (dict(k=2.0), "k must be a positive integer"),
    (dict(k=True), "k must be a positive integer"),
    (dict(k=5), "only 4 training rows"),
    (dict(k=4, optimize=True), "must be below the 4 training rows"),
    (dict(alpha=1.0), "0 <= alpha < 1"),
    (dict(alpha=-0.1), "0 <= alpha < 1"),
    (dict(alpha=float("nan")), "0 <= alpha < 1"),
    (dict(alpha="0.9"), "0 <= alpha < 1"),
    (dict(gamma=-1.0), "finite number >= 0"),
    (dict(gamma=[1.0, 2.0, 3.0]), "one number per class (2)"),
    (dict(gamma="fast"), "gamma must be None, a number"),
    (dict(gamma=[1.0, float("inf")]), "finite number >= 0"),
    (dict(ignorance_weight=2.0), "in [0, 1]"),
    (dict(max_iter=-1), "max_iter"),
    (dict(neighbours="brute"), "neighbours must be one of auto, kdtree, blocked"),
    (dict(threads=0), "threads must be None or a positive integer"),
    (dict(threads=1.5), "threads must be None or a positive integer"),
])
def test_bad_options_are_refused(options, message):
    with pytest.raises(LearningOptionError) as caught:
        EKNN(**{"k": 2, **options}).fit(GOOD_X, GOOD_Y)
    assert message in str(caught.value)


def test_predictions_need_a_fitted_classifier_with_the_same_features():
    with pytest.raises(NotFittedError, match="not fitted yet"):
        EKNN().predict_mass([[0.0]])
    assert issubclass(NotFittedError, AttributeError) and issubclass(NotFittedError, BeliefError)
    clf = EKNN(k=2).fit(GOOD_X, GOOD_Y)
    with pytest.raises(LearningDataError, match="has 2 features, but the classifier was fitted on 1"):
        clf.predict([[0.0, 1.0]])
    with pytest.raises(LearningDataError, match="holds inf"):
        clf.predict_mass([[np.inf]])
    assert repr(clf) == "EKNN(k=2, alpha=0.95, gamma=None, optimize=False)"


# -- consonant mass functions ----------------------------------------------------------------------------------------
def test_consonant_from_likelihood_by_hand():
    m = consonant_from_likelihood({"a": 2.0, "b": 6.0, "c": 3.0, "d": 0.0})
    assert m.frame.hypotheses == ("a", "b", "c", "d") and m.model.kind == "shafer"
    assert m.to_mapping() == pytest.approx({"b": 0.5, "b|c": 1 / 6, "a|b|c": 1 / 3})
    np.testing.assert_allclose(m.pls(["a", "b", "c", "d"]), [1 / 3, 1.0, 0.5, 0.0], atol=1e-15)


def test_the_frame_of_another_source():
    frame = ["bent", "cracked", "good"]
    m = consonant_from_likelihood({"good": 0.5, "bent": 1.0}, frame=frame)
    assert m.frame.hypotheses == tuple(frame) and m.to_mapping() == {"bent": 0.5, "bent|good": 0.5}
    counts = idm_from_counts({}, frame=frame)
    assert counts.frame.hypotheses == tuple(frame) and counts.to_mapping() == {"bent|cracked|good": 1.0}
    with pytest.raises(LearningDataError, match="likelihoods name 'rusty', which the frame"):
        consonant_from_likelihood({"rusty": 1.0}, frame=frame)
    with pytest.raises(LearningDataError, match="every likelihood is zero"):
        consonant_from_likelihood({}, frame=frame)


def test_consonant_ties_and_a_single_label():
    m = consonant_from_likelihood({"x": 1, "y": 1, "z": 0.5})
    assert m.to_mapping() == pytest.approx({"x|y": 0.5, "x|y|z": 0.5})
    assert consonant_from_likelihood({"only": 0.3}).to_mapping() == {"only": 1.0}
    assert consonant_from_likelihood({3: 1.0, 4: 0.5}).frame.hypotheses == ("3", "4")


@settings(max_examples=60)
@given(st.lists(st.floats(0.0, 1e6), min_size=1, max_size=6).filter(lambda v: max(v) > 0))
def test_consonant_plausibility_of_a_hypothesis_is_its_normalised_likelihood(values):
    likelihood = {f"h{i}": v for i, v in enumerate(values)}
    m = consonant_from_likelihood(likelihood)
    np.testing.assert_allclose(m.pls(list(likelihood)), np.array(values) / max(values), rtol=0, atol=1e-12)
    focal = sorted(m.focal, key=lambda x: len(str(x)))
    assert all(a <= b for a, b in zip(focal, focal[1:]))        # nested


@pytest.mark.parametrize("likelihood, message", [
    ({}, "is empty"),
    ({"a": -0.1, "b": 1.0}, "-0.1 of 'a' in likelihoods is negative"),
    ({"a": float("nan")}, "is not a finite number"),
    ({"a": float("inf")}, "is not a finite number"),
    ({"a": "high"}, "the likelihood of 'a' must be a number"),
    ({"a": True}, "must be a number"),
    ({"a": 0.0, "b": 0}, "every likelihood is zero"),
    ({"a b": 1.0}, "cannot name a hypothesis"),
    ({1: 1.0, "1": 0.5}, "are both written '1'"),
    ([("a", 1.0)], "must be a mapping"),
])
def test_bad_likelihoods_are_refused(likelihood, message):
    with pytest.raises(LearningDataError) as caught:
        consonant_from_likelihood(likelihood)
    assert message in str(caught.value)


# -- the imprecise Dirichlet model ---------------------------------------------------------------------------------
def test_idm_by_hand():
    m = idm_from_counts({"red": 3, "blue": 1, "green": 0}, s=1.0)
    assert m.to_mapping() == pytest.approx({"red": 0.6, "blue": 0.2, "red|blue|green": 0.2})
    np.testing.assert_allclose(m.bel(["red", "blue", "green"]), [0.6, 0.2, 0.0])
    np.testing.assert_allclose(m.pls(["red", "blue", "green"]), [0.8, 0.4, 0.2])


def test_idm_without_observations_is_vacuous_and_one_label_is_certain():
    assert idm_from_counts({"a": 0, "b": 0}).to_mapping() == {"a|b": 1.0}
    assert idm_from_counts({"a": 4}).to_mapping() == {"a": 1.0}
    assert idm_from_counts({"a": 2.5, "b": 0.5}, s=np.float64(3.0)).to_mapping() == pytest.approx(
        {"a": 2.5 / 6, "b": 0.5 / 6, "a|b": 0.5})


@settings(max_examples=60)
@given(st.lists(st.integers(0, 10**6), min_size=1, max_size=6), st.floats(1e-3, 100.0))
def test_idm_bounds_are_walleys(counts, s):
    m = idm_from_counts({f"h{i}": n for i, n in enumerate(counts)}, s=s)
    total = sum(counts) + s
    names = [f"h{i}" for i in range(len(counts))]
    if len(counts) > 1:                                # one label is the whole frame, certain whatever the counts
        np.testing.assert_allclose(m.bel(names), np.array(counts) / total, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(m.pls(names), (np.array(counts) + s) / total, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("s", [0.0, -1.0, float("nan"), float("inf"), "2", True])
def test_idm_refuses_a_bad_prior_strength(s):
    with pytest.raises(LearningOptionError, match="s must be a finite number above 0"):
        idm_from_counts({"a": 1}, s=s)


@pytest.mark.parametrize("counts, message", [
    ({}, "is empty"),
    ({"a": -1}, "negative"),
    ({"a": float("nan")}, "not a finite number"),
    ({"a": None}, "the count of 'a' must be a number"),
])
def test_idm_refuses_bad_counts(counts, message):
    with pytest.raises(LearningDataError, match=message):
        idm_from_counts(counts)
