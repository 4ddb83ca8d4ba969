"""Frames, elements of D^Θ, parsing and canonical printing."""

import pickle

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import (
    Element,
    Frame,
    FrameError,
    Model,
    ParseError,
    UnknownHypothesisError,
)
from tests.strategies import (
    elements,
    expression_element,
    expression_regions,
    expression_text,
    expressions,
    frames,
    hypothesis_regions,
    minimal_regions,
    regions_of,
    regions_of_terms,
    term_text,
)

ABC = Frame(["a", "b", "c"])


def regions(text: str, frame: Frame = ABC) -> frozenset:
    return regions_of(frame.element(text))


def hyp(name: str, frame: Frame = ABC) -> frozenset:
    return hypothesis_regions(len(frame), frame.hypotheses.index(name))


# -- frame validation ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("names", "fragments"),
    [
        ([], ["at least one"]),
        (["a", ""], ["must not be empty"]),
        (["a b"], ["'a b'", "reserved character"]),
        (["a\tb"], ["reserved character"]),
        (["x(y"], ["'x(y'", "reserved character", "'('"]),
        (["x)"], ["reserved character", "')'"]),
        (["a&b"], ["reserved character", "'&'"]),
        (["a|b"], ["reserved character", "'|'"]),
        (["a∩b"], ["reserved character", "'∩'"]),
        (["a∪b"], ["reserved character", "'∪'"]),
        (["∅x"], ["reserved character", "'∅'"]),
        (["a,b"], ["reserved character", "','"]),
        (["a", "b", "a"], ["'a' appears twice"]),
        (["empty"], ["'empty' is reserved"]),
        (["∅"], ["'∅' is reserved"]),
    ],
)
def test_bad_hypothesis_names_are_rejected_with_a_message_naming_the_problem(names, fragments):
    with pytest.raises(FrameError) as info:
        Frame(names)
    for fragment in fragments:
        assert fragment in str(info.value)


def test_frame_errors_are_value_errors_and_belief_errors():
    from belief import BeliefError

    with pytest.raises(ValueError):
        Frame(["a", "a"])
    with pytest.raises(BeliefError):
        Frame(["a", "a"])


def test_a_single_string_is_not_a_list_of_names():
    with pytest.raises(FrameError, match="parse"):
        Frame("abc")


def test_non_string_names_are_rejected():
    with pytest.raises(FrameError, match="strings"):
        Frame(["a", 3])


def test_frame_parse_and_numbered():
    assert Frame.parse("t1, t2 ,FA").hypotheses == ("t1", "t2", "FA")
    assert Frame.numbered(3) == Frame(["t1", "t2", "t3"])
    assert Frame.numbered(2, prefix="h").hypotheses == ("h1", "h2")
    for bad in (0, -1, True, 2.0):
        with pytest.raises(FrameError):
            Frame.numbered(bad)


def test_frame_protocol():
    assert len(ABC) == 3
    assert list(ABC) == ["a", "b", "c"]
    assert "b" in ABC and "d" not in ABC
    assert ABC.index("c") == 2
    assert ABC == Frame(["a", "b", "c"]) and hash(ABC) == hash(Frame(["a", "b", "c"]))
    assert ABC != Frame(["b", "a", "c"])
    assert regions_of(ABC.total) == regions_of_terms([1, 2, 4], 3) == frozenset(range(1, 8))
    assert ABC.empty.is_empty and not ABC.empty
    assert [regions_of(s) for s in ABC.singletons] == [hyp("a"), hyp("b"), hyp("c")]
    assert regions_of(ABC.conjunction(["c", "a"])) == hyp("a") & hyp("c")
    with pytest.raises(FrameError):
        ABC.conjunction([])


def test_unknown_hypothesis_lookups_name_the_hypothesis_and_the_frame():
    for call in (lambda: ABC["z"], lambda: ABC.index("z"), lambda: ABC.conjunction(["a", "z"])):
        with pytest.raises(UnknownHypothesisError) as info:
            call()
        message = str(info.value)
        assert "'z'" in message and "a, b, c" in message
    assert issubclass(UnknownHypothesisError, FrameError)


# -- parsing ---------------------------------------------------------------------------------------


def test_intersection_binds_tighter_than_union():
    a, b, c = hyp("a"), hyp("b"), hyp("c")
    assert regions("a | b & c") == a | (b & c)
    assert regions("a & b | c") == (a & b) | c
    assert regions("a | b & c") != regions("(a | b) & c")


def test_parentheses_override_precedence():
    a, b, c = hyp("a"), hyp("b"), hyp("c")
    assert regions("(a | b) & c") == (a | b) & c
    assert regions("a & (b | c)") == a & (b | c)
    assert regions("((a))") == a
    assert regions("(a | (b & (c | a)))") == a | (b & (c | a))


def test_unicode_operators_and_the_empty_element():
    assert ABC.element("a ∩ b ∪ c") == ABC.element("a&b|c")
    assert ABC.element("(a ∪ b) ∩ c") == ABC.element("(a|b)&c")
    assert ABC.element("∅") == ABC.empty == ABC.element("empty")
    assert ABC.element("a | empty") == ABC["a"]
    assert ABC.element("a ∪ ∅") == ABC["a"]
    assert ABC.element("a & empty").is_empty
    assert ABC.element("a∩∅").is_empty
    assert ABC.element("  a&b  ") == ABC.element("a & b")


def test_element_accepts_own_elements_and_rejects_other_frames_and_types():
    x = ABC.element("a&b")
    assert ABC.element(x) is x
    with pytest.raises(FrameError):
        Frame(["a", "b"]).element(x)
    with pytest.raises(TypeError):
        ABC.element(3)


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("", "empty proposition"),
        ("   ", "empty proposition"),
        ("a |", "unexpected end"),
        ("a &", "unexpected end"),
        ("(a | b", "missing ')'"),
        ("a)", "unexpected ')'"),
        ("a b", "unexpected 'b'"),
        ("& a", "unexpected '&'"),
        ("a && b", "unexpected '&'"),
        ("a | | b", "unexpected '|'"),
        ("()", "unexpected ')'"),
    ],
)
def test_malformed_propositions_raise_parse_errors_that_say_what_is_wrong(text, fragment):
    with pytest.raises(ParseError) as info:
        ABC.element(text)
    assert fragment in str(info.value)


def test_parse_errors_give_the_position():
    with pytest.raises(ParseError, match="position 4"):
        ABC.element("a & | b")


def test_unknown_hypothesis_in_a_proposition():
    with pytest.raises(UnknownHypothesisError) as info:
        ABC.element("a & zed | b")
    message = str(info.value)
    assert "'zed'" in message and "a, b, c" in message


def test_term_parses_a_single_conjunction_only():
    assert ABC.term("c & a") == 0b101
    with pytest.raises(ParseError):
        ABC.term("a | b")


# -- canonical printing -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("spellings", "ascii_text", "unicode_text"),
    [
        (["c | b & a", "a&b|c", "(b∩a) ∪ c", "c | a&b | a&b&c"], "a&b|c", "a∩b ∪ c"),
        (["(a | b) & c", "c&b | c&a", "a&c|b&c"], "a&c|b&c", "a∩c ∪ b∩c"),
        (["b | a", "a | b | a&b"], "a|b", "a ∪ b"),
        (["empty", "∅", "a & empty"], "empty", "∅"),
        (["c&b&a", "a & (b & c)"], "a&b&c", "a∩b∩c"),
        (["b&c | a", "a | c&b"], "a|b&c", "a ∪ b∩c"),
    ],
)
def test_equal_elements_print_canonically(spellings, ascii_text, unicode_text):
    # Canonical form (SPEC A.1): the union of the minimal conjunctions, hypotheses in frame
    # order inside a conjunction, conjunctions ordered by their hypothesis positions.
    parsed = [ABC.element(s) for s in spellings]
    assert all(p == parsed[0] for p in parsed)
    assert {str(p) for p in parsed} == {ascii_text}
    assert {p.format("unicode") for p in parsed} == {unicode_text}
    assert repr(parsed[0]) == f"Element({ascii_text!r})"


def test_format_rejects_unknown_styles():
    with pytest.raises(ValueError):
        ABC["a"].format("latex")


# -- large frames -----------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [64, 65, 100])
def test_elements_of_large_frames_stay_a_few_integers(n):
    frame = Frame.numbered(n)
    names = frame.hypotheses
    x = frame.conjunction([names[0], names[63], names[-1]]) | frame[names[49]]
    y = frame.element(f"{names[63]} & ({names[0]} | {names[1]})")
    assert len(x.terms) == 2 and all(type(t) is int for t in x.terms)
    expected_terms = {(1 << 0) | (1 << 63) | (1 << (n - 1)), 1 << 49}
    assert set(x.terms) == expected_terms
    meet = x & y
    # the literal rule: pairwise unions of conjunctions, keeping the minimal ones
    y_terms = {(1 << 0) | (1 << 63), (1 << 1) | (1 << 63)}
    assert set(y.terms) == y_terms
    assert set(meet.terms) == set(minimal_regions({a | b for a in expected_terms for b in y_terms}))
    assert set((x | y).terms) == set(minimal_regions(expected_terms | y_terms))
    assert len(meet.terms) <= 3 and len((x | y).terms) <= 3
    assert meet <= x and meet <= y and x <= x | y and not x <= y
    assert frame.element(str(x)) == x and frame.element(x.format("unicode")) == x
    assert frame.total.terms == tuple(1 << i for i in range(n))
    assert x & frame.total == x and x | frame.empty == x and (x & frame.empty).is_empty
    # DSm cardinality on the free model counts regions: 2^(n-1) contain one hypothesis,
    # 2^(n-k) contain k given ones, so by inclusion-exclusion
    # |θ_50 ∪ (θ_1∩θ_64∩θ_n)| = 2^(n-1) + 2^(n-k) - 2^(n-k-1), k = |{1, 64, n}|.
    k = len({0, 63, n - 1})
    free = Model.free(frame)
    assert free.cardinality(frame[names[49]]) == 2 ** (n - 1)
    assert free.cardinality(x) == 2 ** (n - 1) + 2 ** (n - k) - 2 ** (n - k - 1)
    exclusive = Model.hybrid(frame, [f"{names[0]}&{names[63]}"])
    assert exclusive.cardinality(frame[names[0]]) == 2 ** (n - 1) - 2 ** (n - 2)
    assert exclusive.reduce(x) == frame[names[49]]


# -- element protocol ------------------------------------------------------------------------------


def test_elements_are_immutable_hashable_and_picklable():
    x = ABC.element("a&b|c")
    with pytest.raises(AttributeError):
        x.terms = ()
    with pytest.raises(AttributeError):
        x.frame = Frame(["q"])
    assert hash(x) == hash(ABC.element("c|b&a"))
    assert pickle.loads(pickle.dumps(x)) == x
    assert {x, ABC.element("c | a&b")} == {x}


def test_elements_of_different_frames_do_not_combine():
    other = Frame(["a", "b", "c", "d"])
    with pytest.raises(FrameError):
        ABC["a"] & other["a"]
    with pytest.raises(FrameError):
        ABC["a"] <= other["a"]
    assert ABC["a"] != other["a"]
    with pytest.raises(TypeError):
        ABC["a"] & 1


def test_string_operands_are_parsed_in_the_elements_frame():
    assert ABC["a"] & "b" == ABC.element("a&b")
    assert "b" | ABC["a"] == ABC.element("a|b")
    assert ABC["a"] >= "a&c" and ABC.element("a&c") < "a" and ABC["a"] > "a&b"


def test_element_constructor_validates_masks():
    for bad in (0, -1, 8, True, "1"):
        with pytest.raises(FrameError):
            Element(ABC, [bad])
    with pytest.raises(TypeError):
        Element("abc", [1])
    assert Element(ABC, [0b011, 0b001, 0b111]) == ABC["a"]


def test_hypotheses_mask():
    assert ABC.element("a&c | c").hypotheses == 0b100
    assert ABC.element("a&b | c").hypotheses == 0b111
    assert ABC.empty.hypotheses == 0


# -- lattice laws on the free model (property tests) ----------------------------------------------


def triples(max_n=5):
    return frames(1, max_n).flatmap(lambda f: st.tuples(elements(f), elements(f), elements(f)))


@given(triples())
def test_meet_and_join_are_commutative_associative_and_idempotent(xyz):
    x, y, z = xyz
    assert x & y == y & x and x | y == y | x
    assert (x & y) & z == x & (y & z)
    assert (x | y) | z == x | (y | z)
    assert x & x == x and x | x == x


@given(triples())
def test_absorption_and_distributivity(xyz):
    x, y, z = xyz
    assert x & (x | y) == x
    assert x | (x & y) == x
    assert x & (y | z) == (x & y) | (x & z)
    assert x | (y & z) == (x | y) & (x | z)


@given(triples())
def test_order_is_the_lattice_order(xyz):
    x, y, _ = xyz
    assert (x <= y) == (x & y == x) == (x | y == y)
    assert (x < y) == (x <= y and x != y)
    assert x & y <= x <= x | y
    assert (x <= y and y <= x) == (x == y)


@given(triples())
def test_empty_and_total_are_bottom_and_top(xyz):
    x = xyz[0]
    frame = x.frame
    assert frame.empty <= x <= frame.total
    assert x | frame.empty == x and x & frame.total == x
    assert (x & frame.empty).is_empty and x | frame.total == frame.total


@given(frames(1, 6).flatmap(elements))
def test_printing_then_parsing_gives_the_element_back(x):
    frame = x.frame
    assert frame.element(str(x)) == x
    assert frame.element(x.format("unicode")) == x
    assert frame.element(repr(x)[len("Element('"):-len("')")]) == x


@given(frames(1, 5).flatmap(lambda f: st.tuples(elements(f), elements(f))))
def test_elements_are_equal_exactly_when_they_print_equally(xy):
    x, y = xy
    assert (x == y) == (str(x) == str(y)) == (x.format("unicode") == y.format("unicode"))
    if x == y:
        assert hash(x) == hash(y)


@given(frames(1, 5).flatmap(elements))
def test_printed_conjunctions_are_the_minimal_regions(x):
    # Each printed conjunction is one minimal Venn region, hypotheses in frame order.
    frame = x.frame
    if x.is_empty:
        assert str(x) == "empty"
        return
    printed = str(x).split("|")
    expected = sorted(minimal_regions(regions_of(x)))
    assert sorted(printed) == sorted(term_text(frame, r) for r in expected)


# -- the encoding against a literal region-set implementation -----------------------------------


@settings(max_examples=200)
@given(frames(1, 5).flatmap(lambda f: st.tuples(elements(f), elements(f))))
def test_meet_join_and_inclusion_agree_with_region_sets(xy):
    x, y = xy
    rx, ry = regions_of(x), regions_of(y)
    assert regions_of(x & y) == rx & ry
    assert regions_of(x | y) == rx | ry
    assert (x <= y) == (rx <= ry)
    assert (x == y) == (rx == ry)
    assert x.is_empty == (not rx)
    # the stored conjunctions are exactly the minimal regions (canonical form)
    assert sorted(x.terms) == sorted(minimal_regions(rx))


@settings(max_examples=200)
@given(frames(1, 5).flatmap(lambda f: st.tuples(st.just(f), expressions(len(f)))))
def test_expressions_evaluate_and_parse_like_region_sets(case):
    frame, expr = case
    expected = expression_regions(expr, len(frame))
    assert regions_of(expression_element(expr, frame)) == expected
    for unicode in (False, True):
        for minimal in (False, True):
            text = expression_text(expr, frame, unicode=unicode, minimal_parentheses=minimal)
            assert regions_of(frame.element(text)) == expected, text


def test_shafer_model_on_a_hundred_hypotheses():
    frame = Frame.numbered(100)
    shafer = Model.shafer(frame)
    x = frame.element("t1&t64&t100 | t50")
    assert shafer.cardinality(frame.total) == 100
    assert shafer.reduce(x) == frame["t50"]
    assert shafer.is_empty(frame.element("t1&t2")) and not shafer.is_empty(frame["t99"])
