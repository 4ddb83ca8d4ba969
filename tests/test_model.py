"""Constraint models: free, Shafer, hybrid and tracking (SPEC A.2)."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import FormatError, Frame, MassFunction, Model, ModelError, UnknownHypothesisError
from tests.strategies import (
    ModelCase,
    any_model_cases,
    elements,
    frames,
    hybrid_allowed,
    minimal_regions,
    model_cases,
    regions_of,
    tracking_allowed,
)

ABC = Frame(["a", "b", "c"])


def cases_with_elements(min_n=1, max_n=5, count=2):
    return any_model_cases(min_n, max_n).flatmap(
        lambda case: st.tuples(st.just(case), st.lists(elements(case.frame), min_size=count, max_size=count))
    )


# -- reduction, emptiness, cardinality against brute force --------------------------------------


@settings(max_examples=200)
@given(cases_with_elements())
def test_reduce_keeps_exactly_the_allowed_regions(data):
    case, (x, y) = data
    model = case.model
    reduced = model.reduce(x)
    assert regions_of(reduced) & case.allowed == case.regions(x)
    # canonical: the terms of the reduced element are the minimal surviving regions
    assert sorted(reduced.terms) == sorted(minimal_regions(case.regions(x)))
    assert model.reduce(reduced) == reduced
    assert model.element(str(x)) == reduced
    assert model.is_empty(x) == (not case.regions(x))
    assert model.is_empty(x) == model.reduce(x).is_empty
    # two elements are identified under the model iff they keep the same regions
    assert (model.reduce(x) == model.reduce(y)) == (case.regions(x) == case.regions(y))
    assert model.includes(x, y) == (case.regions(x) <= case.regions(y))
    assert case.regions(model.intersection(x, y)) == case.regions(x) & case.regions(y)
    assert case.regions(model.union(x, y)) == case.regions(x) | case.regions(y)
    assert regions_of(model.total) & case.allowed == case.allowed
    assert model.empty.is_empty


@settings(max_examples=150)
@given(cases_with_elements(1, 6, count=1))
def test_cardinality_counts_the_allowed_regions(data):
    case, (x,) = data
    assert case.model.cardinality(x) == len(case.regions(x))
    assert case.model.cardinality(str(x)) == len(case.regions(x))


@settings(max_examples=100)
@given(frames(1, 6).flatmap(lambda f: st.tuples(st.lists(st.integers(1, (1 << len(f)) - 1), max_size=4),
                                                 elements(f, max_terms=5))))
def test_cardinality_with_random_forbidden_conjunctions(data):
    forbidden, x = data
    frame = x.frame
    model = Model(frame, forbidden)
    assert model.cardinality(x) == len(regions_of(x) & hybrid_allowed(len(frame), forbidden))


def test_is_forbidden_on_the_classic_models():
    assert not Model.free(ABC).is_forbidden(0b111)
    shafer = Model.shafer(ABC)
    assert [shafer.is_forbidden(t) for t in range(1, 8)] == [(t.bit_count() > 1) for t in range(1, 8)]


def test_hybrid_constraints_exclusivity_and_non_existence():
    exclusive = Model.hybrid(ABC, empty=["a&b"])
    assert exclusive.is_empty("a&b") and exclusive.is_empty("a&b&c")
    assert not exclusive.is_empty("a&c") and not exclusive.is_empty("a")
    assert exclusive.reduce(ABC.element("a&b | c")) == ABC["c"]
    gone = Model.hybrid(ABC, empty=["c"])
    assert gone.is_empty("c") and gone.is_empty("a&c") and not gone.is_empty("a&b")
    assert gone.reduce(ABC.element("a | c")) == ABC["a"]
    assert gone.total == ABC.element("a|b")
    both = Model.hybrid(ABC, empty=["a&b|c"])
    assert both == Model.hybrid(ABC, empty=["a&b", "c"])
    assert Model.hybrid(ABC, empty="a&b") == exclusive
    assert Model.hybrid(ABC, empty=ABC.element("a&b")) == exclusive
    assert Model.hybrid(ABC, empty=["empty"]) == Model.free(ABC)


def test_paper_hybrid_model_dsm_cardinalities():
    # Dezert & Smarandache, "An introduction to DSmT" (2009, arXiv:0903.0279), §2.2 (Fig. 3:
    # every conjunction empty except θ1∩θ2) and the table of DSm cardinals C_M(A) in the
    # section on the generalized pignistic transformation ("Notion of DSm cardinality").
    frame = Frame(["t1", "t2", "t3"])
    model = Model.hybrid(frame, empty=["t1&t3", "t2&t3"])
    table = {
        "empty": 0,
        "t1&t2": 1,
        "t3": 1,
        "t1": 2,
        "t2": 2,
        "t1|t2": 3,
        "t1|t3": 3,
        "t2|t3": 3,
        "t1|t2|t3": 4,
    }
    assert {text: model.cardinality(text) for text in table} == table


# -- the tracking model (SPEC A.2, W (15)) -----------------------------------------------------


@pytest.mark.parametrize("targets", [1, 2, 3, 5, 40])
def test_tracking_model_occlusion_allowed_false_alarm_exclusive(targets):
    model = Model.for_targets(targets)
    frame = model.frame
    assert frame.hypotheses == tuple(f"t{i}" for i in range(1, targets + 1)) + ("FA",)
    assert model.kind == "tracking" and model.false_alarm == "FA"
    fa = frame["FA"]
    for i in range(1, targets + 1):
        ti = frame[f"t{i}"]
        assert not model.is_empty(ti)
        assert model.is_empty(ti & fa)
        for j in range(i + 1, targets + 1):
            assert not model.is_empty(ti & frame[f"t{j}"])
    assert not model.is_empty(fa)
    assert model.cardinality(fa) == 1
    # θ_1 meets 2^(τ-1) sets of targets; the total is every set of targets plus FA
    assert model.cardinality("t1") == 2 ** (targets - 1)
    assert model.cardinality(frame.total) == 2 ** targets


def test_tracking_model_on_any_frame_and_false_alarm_name():
    frame = Frame(["bg", "car", "person"])
    model = Model.tracking(frame, false_alarm="bg")
    assert model.is_empty("bg & car") and model.is_empty("bg & person")
    assert not model.is_empty("car & person")
    assert model == Model.hybrid(frame, ["bg&car", "bg&person"])
    with pytest.raises(UnknownHypothesisError):
        Model.tracking(Frame(["t1", "t2"]))
    with pytest.raises(ModelError):
        Model.tracking(Frame(["FA"]))
    for bad in (0, -2, True, "2"):
        with pytest.raises(ModelError):
            Model.for_targets(bad)


@given(frames(2, 5).flatmap(lambda f: st.tuples(st.just(f), st.integers(0, len(f) - 1), elements(f))))
def test_tracking_model_matches_its_region_definition(data):
    frame, fa, x = data
    model = Model.tracking(frame, frame.hypotheses[fa])
    allowed = tracking_allowed(len(frame), fa)
    assert model.cardinality(x) == len(regions_of(x) & allowed)
    assert model.is_empty(x) == (not regions_of(x) & allowed)


# -- identity -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6])
def test_hybrid_with_every_pair_exclusive_is_shafers_model(n):
    frame = Frame.numbered(n)
    names = frame.hypotheses
    pairs = [f"{names[i]}&{names[j]}" for i in range(n) for j in range(i + 1, n)]
    hybrid = Model.hybrid(frame, pairs)
    assert hybrid == Model.shafer(frame)
    assert hash(hybrid) == hash(Model.shafer(frame))
    assert hybrid.kind == "hybrid" and Model.shafer(frame).kind == "shafer"
    x = frame.total
    assert hybrid.cardinality(x) == Model.shafer(frame).cardinality(x) == n


def test_model_equality_ignores_how_constraints_are_spelled():
    assert Model.hybrid(ABC, ["a&b|a&c"]) == Model.hybrid(ABC, ["a&c", "b&a"])
    assert Model.hybrid(ABC, ["a&b", "a&b&c"]) == Model.hybrid(ABC, ["a&b"])
    assert Model.hybrid(ABC, ["a & (b | c)"]) == Model.hybrid(ABC, ["a&b", "a&c"])
    assert Model.hybrid(ABC, []) == Model.free(ABC)
    assert Model(ABC, [0b011]) == Model.hybrid(ABC, ["a&b"])
    assert Model.free(ABC) != Model.free(Frame(["a", "b", "d"]))
    assert Model.free(ABC) != Model.shafer(ABC)
    assert Model.hybrid(ABC, ["a&b"]) != Model.hybrid(ABC, ["a&c"])
    assert Model.free(ABC) != "free"


@given(frames(1, 4).flatmap(lambda f: st.tuples(model_cases(f), model_cases(f))))
def test_models_are_equal_iff_they_allow_the_same_regions(pair):
    first, second = pair
    assert (first.model == second.model) == (first.allowed == second.allowed)
    if first.model == second.model:
        assert hash(first.model) == hash(second.model)


@given(frames(1, 4).flatmap(lambda f: st.tuples(model_cases(f), model_cases(f))))
def test_is_refined_by_means_forbidding_at_least_as_much(pair):
    first, second = pair
    assert first.model.is_refined_by(second.model) == (second.allowed <= first.allowed)


def test_refinement_examples_and_other_frames():
    free, shafer = Model.free(ABC), Model.shafer(ABC)
    assert free.is_refined_by(shafer) and not shafer.is_refined_by(free)
    assert free.is_refined_by(free) and shafer.is_refined_by(shafer)
    assert Model.hybrid(ABC, ["a&b"]).is_refined_by(shafer)
    assert not Model.hybrid(ABC, ["c"]).is_refined_by(shafer)
    assert not free.is_refined_by(Model.free(Frame(["a", "b"])))


def test_constructor_validation():
    with pytest.raises(ModelError, match="unknown model type"):
        Model(ABC, [], kind="open")
    for bad in (0, -1, 8, True):
        with pytest.raises(ModelError):
            Model(ABC, [bad])
    with pytest.raises(TypeError):
        Model(["a", "b"])


def test_repr_names_the_kind():
    assert repr(Model.free(ABC)).startswith("Model.free(")
    assert repr(Model.shafer(ABC)).startswith("Model.shafer(")
    assert "a&b" in repr(Model.hybrid(ABC, ["b&a"]))
    assert "false_alarm='c'" in repr(Model.tracking(ABC, "c"))


# -- serialisation ------------------------------------------------------------------------------------


@given(any_model_cases(1, 5))
def test_to_dict_from_dict_round_trip(case: ModelCase):
    model = case.model
    data = model.to_dict()
    if not model.total.terms:
        # A model file under which every element is empty is refused when read.
        with pytest.raises(ModelError, match="every hypothesis empty"):
            Model.from_dict(model.frame, data)
        return
    back = Model.from_dict(model.frame, data)
    assert back == model
    assert back.kind == model.kind
    assert back.false_alarm == model.false_alarm


def test_to_dict_shapes():
    assert Model.free(ABC).to_dict() == {"type": "free"}
    assert Model.shafer(ABC).to_dict() == {"type": "shafer"}
    assert Model.tracking(ABC, "c").to_dict() == {"type": "tracking", "false_alarm": "c"}
    data = Model.hybrid(ABC, ["c&b", "a"]).to_dict()
    assert data["type"] == "hybrid"
    assert Model.hybrid(ABC, data["empty"]) == Model.hybrid(ABC, ["a", "b&c"])


def test_from_dict_defaults():
    # Shafer's model unless another is named: a BBA file without "model" is read as DST users write it.
    assert Model.from_dict(ABC, None) == Model.shafer(ABC)
    assert Model.from_dict(ABC, {}) == Model.shafer(ABC)
    assert Model.from_dict(ABC, {"type": "free"}) == Model.free(ABC)
    assert Model.from_dict(ABC, {"empty": ["a&b"]}) == Model.hybrid(ABC, ["a&b"])
    assert Model.from_dict(Frame(["t1", "FA"]), {"type": "tracking"}) == Model.for_targets(1)


@pytest.mark.parametrize(
    ("data", "fragment"),
    [
        ("free", "JSON object"),
        (["free"], "JSON object"),
        ({"type": "free", "colour": 1}, "colour"),
        ({"type": "open"}, "'open'"),
        ({"type": "hybrid", "empty": "a&b"}, "list of proposition strings"),
        ({"type": "hybrid", "empty": [1]}, "list of proposition strings"),
        ({"type": "tracking", "false_alarm": 3}, "false_alarm"),
    ],
)
def test_from_dict_errors_are_format_errors_naming_the_problem(data, fragment):
    with pytest.raises(FormatError) as info:
        Model.from_dict(ABC, data)
    assert fragment in str(info.value)


@pytest.mark.parametrize("data", [
    {"type": "free", "false_alarm": "a"},
    {"type": "shafer", "false_alarm": "a"},
    {"type": "hybrid", "empty": ["a&b"], "false_alarm": "a"},
    {"type": "tracking", "false_alarm": "c", "colour": "red"},
])
def test_model_keys_that_do_not_belong_to_the_type_are_refused(data):
    with pytest.raises(FormatError, match="do not belong"):
        Model.from_dict(Frame(["a", "b", "c"]), data)


# -- "empty" with every model type ------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["free", "shafer", "hybrid", "tracking"])
def test_an_empty_list_of_empty_propositions_changes_nothing(kind):
    extra = {"false_alarm": "c"} if kind == "tracking" else {}
    base = Model.from_dict(ABC, {"type": kind, **extra})
    assert Model.from_dict(ABC, {"type": kind, "empty": [], **extra}) == base


def test_free_with_empty_propositions_is_the_hybrid_model():
    model = Model.from_dict(ABC, {"type": "free", "empty": ["a&b", "c"]})
    assert model == Model.hybrid(ABC, ["a&b", "c"])


def test_shafer_with_an_impossible_hypothesis_keeps_the_exclusions_and_drops_the_hypothesis():
    # Dynamic fusion: Shafer's model on {a, b, c} in which c turns out impossible.
    model = Model.from_dict(ABC, {"type": "shafer", "empty": ["c"]})
    for proposition in ("a&b", "a&c", "b&c", "c"):
        assert model.is_empty(proposition), proposition
    for proposition in ("a", "b", "a|b", "a|c"):
        assert not model.is_empty(proposition), proposition
    assert model.is_refined_by(model) and Model.shafer(ABC).is_refined_by(model)
    assert not model.is_refined_by(Model.shafer(ABC))
    # It is written as the hybrid model it is, and read back equal.
    assert Model.from_dict(ABC, model.to_dict()) == model
    m = MassFunction({"a": 0.5, "a|c": 0.5}, frame=ABC, model=model)
    assert m.bel("a") == pytest.approx(1.0)


def test_shafer_with_empty_propositions_it_already_has_is_shafers_model():
    assert Model.from_dict(ABC, {"type": "shafer", "empty": ["a&b", "b&c"]}) == Model.shafer(ABC)


def test_tracking_with_empty_propositions_adds_them_to_the_false_alarm_exclusions():
    model = Model.from_dict(ABC, {"type": "tracking", "false_alarm": "c", "empty": ["a&b"]})
    assert model.is_empty("a&b") and model.is_empty("a&c") and model.is_empty("b&c")
    assert not model.is_empty("a")


def test_a_type_that_is_not_a_string_is_a_format_error():
    with pytest.raises(FormatError, match="must be a string"):
        Model.from_dict(ABC, {"type": ["x"]})
