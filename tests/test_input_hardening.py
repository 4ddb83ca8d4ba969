"""Hostile or degenerate input ends with one specific error, never a traceback, a hang or a wrong answer."""

import json
import os
import math
import random

import pytest

from belief import (
    FormatError,
    Frame,
    FrameError,
    InvalidMassError,
    LatticeTooLargeError,
    MassFunction,
    Model,
    ModelError,
    ParseError,
    UndefinedTransformError,
    hyper_power_set,
)
from belief.batch import _largest_epsilon
from belief.cli import main
from belief.frame import MAX_PROPOSITION_TERMS, reduce_terms, term_key
from belief.model import MAX_LISTED_CONSTRAINTS
from belief import textfiles
from belief.textfiles import load_json


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def refused(capsys, *argv, says=()):
    code, out, err = run(capsys, *argv)
    assert code == 1, (out, err)
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    for fragment in says:
        assert fragment in err, err
    return err


@pytest.fixture
def write(tmp_path):
    def make(name, content):
        path = tmp_path / name
        path.write_text(content if isinstance(content, str) else json.dumps(content), encoding="utf-8")
        return path
    return make


def names(n):
    return [f"h{i}" for i in range(n)]


# -- JSON --------------------------------------------------------------------------------------------------
def test_a_model_type_that_is_not_a_string(capsys, write):
    bba = write("bba.json", {"frame": ["a", "b"], "model": {"type": ["x"]}, "mass": {"a": 1.0}})
    refused(capsys, "measures", bba, says=['"type" must be a string'])
    model = write("model.json", {"type": ["x"]})
    refused(capsys, "lattice", "3", "--model", model, says=["model.json", '"type" must be a string'])
    with pytest.raises(FormatError):
        Model.from_dict(Frame(["a", "b"]), {"type": ["x"]})


@pytest.mark.parametrize("digits", [400, 5000])
def test_integers_too_large_for_a_float(capsys, write, digits):
    bba = write("bba.json", '{"frame": ["a", "b"], "mass": {"a": 1%s}}' % ("0" * (digits - 1)))
    refused(capsys, "measures", bba, says=["bba.json", f"{digits:,} digits", "too large"])
    with pytest.raises(FormatError, match="too large"):
        MassFunction.from_json(bba.read_text())
    with pytest.raises(InvalidMassError, match="too large for a float"):
        MassFunction({"a": 10 ** (digits - 1)}, frame=["a", "b"])


def test_json_nested_fifty_thousand_deep(capsys, write):
    bba = write("bba.json", '{"frame": ["a", "b"], "mass": ' + "[" * 50_000 + "]" * 50_000 + "}")
    refused(capsys, "measures", bba, says=["nested too deeply"])
    with pytest.raises(FormatError, match="nested too deeply"):
        MassFunction.from_json(bba.read_text())


def test_nested_values_are_quoted_short_in_messages(capsys, write):
    bba = write("bba.json", {"frame": ["a", "b"], "mass": {"a": [[[[[[[1]]]]]]]}})
    err = refused(capsys, "measures", bba, says=["must be a number"])
    assert len(err) < 200


@pytest.mark.parametrize("command", ["measures", "transform", "combine"])
def test_duplicate_keys_are_refused(capsys, write, command):
    bba = write("bba.json", '{"frame": ["a", "b"], "mass": {"a": 0.5, "a": 1.0}}')
    argv = {"measures": ["measures", bba], "transform": ["transform", bba, "--pignistic"],
            "combine": ["combine", bba, bba, "--rule", "dempster"]}[command]
    refused(capsys, *argv, says=["bba.json", 'the key "a" appears twice'])


def test_duplicate_keys_in_every_json_input(capsys, write):
    good = write("good.json", {"frame": ["a", "b"], "mass": {"a": 0.5, "b": 0.5}})
    model = write("model.json", '{"type": "hybrid", "type": "free"}')
    refused(capsys, "combine", good, good, "--rule", "dempster", "--model", model, says=['"type" appears twice'])
    rates = write("rates.json", '{"a": 0.1, "a": 0.2, "b": 0.3}')
    refused(capsys, "transform", good, "--contextual-discount", rates, says=['"a" appears twice'])
    with pytest.raises(FormatError, match='"frame" appears twice'):
        MassFunction.from_json('{"frame": ["a"], "frame": ["a", "b"], "mass": {"a": 1}}')
    with pytest.raises(FormatError, match=r'"a\\u200b" appears twice'):
        load_json('{"a\\u200b": 1, "a\\u200b": 2}')


def test_strict_json_keeps_ordinary_input():
    assert load_json('{"a": 1, "b": [1, 2.5, {"c": null}]}') == {"a": 1, "b": [1, 2.5, {"c": None}]}
    assert load_json("1" * 308) == int("1" * 308)


# -- hypothesis names --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, code", [
    ("\ud800", "\\ud800"),          # lone surrogate
    ("a\u200b", "\\u200b"),         # zero-width space
    ("b\x00", "\\u0000"),           # NUL
    ("c\u202e", "\\u202e"),         # right-to-left override
    ("d\ue000", "\\ue000"),         # private use
])
def test_invisible_or_unprintable_characters_in_names(capsys, write, name, code):
    with pytest.raises(FrameError) as info:
        Frame(["a", name] if name != "a\u200b" else ["a", name])
    assert code in str(info.value) and "printable" in str(info.value)
    bba = write("bba.json", json.dumps({"frame": ["x", name], "mass": {"x": 1.0}}))
    refused(capsys, "measures", bba, says=[code])


def test_a_surrogate_name_cannot_reach_the_output(capsys, write):
    bba = write("bba.json", '{"frame": ["\\ud800", "b"], "mass": {"\\ud800": 1.0}}')
    refused(capsys, "measures", bba, says=["lone surrogate"])


def test_names_that_differ_only_in_normalisation():
    with pytest.raises(FrameError, match="normalisation"):
        Frame(["\u00e9", "e\u0301"])
    assert Frame(["é", "ü", "θ1"]).hypotheses == ("é", "ü", "θ1")


def test_a_large_frame_is_listed_short_in_messages():
    frame = Frame.numbered(5000)
    with pytest.raises(FrameError) as info:
        frame.element("t1|nope")
    assert "5,000 hypotheses" in str(info.value) and len(str(info.value)) < 500


# -- parsing -----------------------------------------------------------------------------------------------
def test_four_hundred_nested_parentheses(capsys, write):
    text = "(" * 400 + "a" + ")" * 400
    bba = write("bba.json", {"frame": ["a", "b"], "mass": {text: 1.0}})
    code, out, _ = run(capsys, "measures", bba)
    assert code == 0 and out.splitlines()[2].split()[0] == "a"
    frame = Frame(["a", "b"])
    assert frame.element("(" * 100_000 + "a|b" + ")" * 100_000) == frame.element("a|b")
    with pytest.raises(ParseError, match="missing"):
        frame.element("(" * 1000 + "a")


@pytest.mark.parametrize("form", ["{}", "({})", "{} | empty", "{} ∪ a0"])
def test_a_union_of_eight_thousand_hypotheses(form):
    frame = Frame([f"a{i}" for i in range(8000)])
    joiner = " ∪ " if "∪" in form else "|"
    element = frame.element(form.format(joiner.join(frame.hypotheses)))
    assert element == frame.total


def test_large_mixed_unions_reduce_like_small_ones():
    frame = Frame.numbered(3000)
    text = "|".join(f"t{i}|t{i}&t{i + 1}" for i in range(1, 3000)) + "|t3000"
    assert frame.element(text) == frame.total
    text = "|".join(f"t{i}&t{i + 1}|t{i}&t{i + 1}&t{i + 2}" for i in range(1, 2999))
    assert frame.element(text).terms == tuple((1 << i) | (1 << (i + 1)) for i in range(2998))
    rng = random.Random(7)
    for _ in range(100):
        width = rng.randint(3, 10)
        terms = [rng.randint(1, (1 << width) - 1) for _ in range(rng.randint(65, 200))]
        kept = []
        for t in sorted(set(terms), key=int.bit_count):
            if not any(k & ~t == 0 for k in kept):
                kept.append(t)
        assert reduce_terms(terms) == tuple(sorted(kept, key=term_key))


def test_an_intersection_whose_normal_form_explodes_is_refused():
    frame = Frame.numbered(80)
    text = "&".join(f"(t{2 * i + 1}|t{2 * i + 2})" for i in range(40))
    with pytest.raises(ParseError, match=f"limit {MAX_PROPOSITION_TERMS:,}"):
        frame.element(text)


# -- large frames ------------------------------------------------------------------------------------------
def test_measures_on_a_free_frame_beyond_floating_point(capsys, write):
    data = {"frame": names(1100), "model": {"type": "free"}, "mass": {"h0": 1.0}}
    bba = write("bba.json", data)
    refused(capsys, "measures", bba, says=["BetP", "2^1099"])
    m = MassFunction.from_dict(data)
    with pytest.raises(UndefinedTransformError, match="floating-point range"):
        m.betp("h0")
    with pytest.raises(UndefinedTransformError, match="floating-point range"):
        m.pignistic()
    assert m.bel("h0") == 1.0 and m.pls("h1") == 1.0


def test_measures_on_a_free_frame_of_a_thousand_hypotheses_still_work(capsys, write):
    bba = write("bba.json", {"frame": names(1000), "model": {"type": "free"}, "mass": {"|".join(names(1000)): 1.0}})
    code, out, _ = run(capsys, "measures", bba, "--json")
    assert code == 0
    (row,) = json.loads(out).values()
    assert row == {"bel": 1.0, "pls": 1.0, "q": 1.0, "betp": 1.0}


@pytest.mark.parametrize("n", [1000, 10_000])
def test_shafer_model_on_many_hypotheses(capsys, write, n):
    bba = write("bba.json", {"frame": names(n), "model": {"type": "shafer"}, "mass": {"h0": 0.5, "h1|h2": 0.5}})
    code, out, _ = run(capsys, "measures", bba, "--json", "--query", "h1")
    assert code == 0
    assert json.loads(out)["h1"] == {"bel": 0.0, "pls": 0.5, "q": 0.5, "betp": 0.25}
    model = Model.shafer(Frame(names(n)))
    assert model.cardinality("|".join(names(n))) == n
    assert model.is_empty("h0&h1") and not model.is_empty("h0")


def test_a_union_of_eight_thousand_hypotheses_under_shafer(capsys, write):
    bba = write("bba.json", {"frame": names(8000), "model": {"type": "shafer"},
                             "mass": {"|".join(names(8000)): 1.0}})
    code, out, _ = run(capsys, "measures", bba, "--json", "--query", "h5")
    assert code == 0 and json.loads(out)["h5"]["betp"] == pytest.approx(1 / 8000)


def test_shafer_model_equals_its_listed_form():
    frame = Frame.numbered(5)
    listed = Model.hybrid(frame, [f"t{i}&t{j}" for i in range(1, 6) for j in range(i + 1, 6)])
    shafer = Model.shafer(frame)
    assert listed == shafer and shafer == listed and hash(listed) == hash(shafer)
    assert shafer.forbidden == listed.forbidden
    assert Model.free(frame) != shafer and Model.hybrid(frame, ["t1&t2"]) != shafer
    assert shafer.is_refined_by(listed) and listed.is_refined_by(shafer)
    assert Model.hybrid(frame, ["t1&t2"]).is_refined_by(shafer) and not shafer.is_refined_by(Model.free(frame))


def test_shafer_model_is_not_listed_beyond_the_limit():
    n = 2000
    assert n * (n - 1) // 2 > MAX_LISTED_CONSTRAINTS
    model = Model.shafer(Frame.numbered(n))
    with pytest.raises(LatticeTooLargeError, match="MAX_LISTED_CONSTRAINTS"):
        model.forbidden
    with pytest.raises(LatticeTooLargeError, match="MAX_LISTED_CONSTRAINTS"):
        Model.from_dict(model.frame, {"type": "shafer", "empty": ["t1"]})


def test_shafer_model_with_an_empty_hypothesis_on_a_large_frame():
    frame = Frame.numbered(300)
    model = Model.from_dict(frame, {"type": "shafer", "empty": ["t2"]})
    assert model.kind == "hybrid" and model.is_empty("t2") and model.is_empty("t1&t3") and not model.is_empty("t1")
    small = Frame.numbered(4)
    assert Model.from_dict(small, {"type": "shafer", "empty": ["t2"]}).forbidden == \
        Model(small, [0b11, 0b101, 0b1001, 0b10, 0b110, 0b1010, 0b1100]).forbidden


def test_counting_regions_of_many_disjoint_conjunctions():
    frame = Frame.numbered(1000)
    text = "|".join(f"t{2 * i + 1}&t{2 * i + 2}" for i in range(500))
    assert Model.free(frame).cardinality(text) == 2 ** 1000 - 3 ** 500


# -- DSmP ----------------------------------------------------------------------------------------------------
SHAFER_ABC = {"frame": ["a", "b", "c"], "model": {"type": "shafer"}, "mass": {"a": 0.5, "b|c": 0.5}}


def test_dsmp_with_an_epsilon_that_overflows(capsys, write):
    bba = write("bba.json", SHAFER_ABC)
    refused(capsys, "transform", bba, "--dsmp", "1e308", says=["ε = 1e+308", "b|c", "use ε ≤"])
    refused(capsys, "decide", bba, "--criterion", "dsmp", "--epsilon", "1e308", says=["ε = 1e+308"])
    m = MassFunction.from_dict(SHAFER_ABC)
    with pytest.raises(UndefinedTransformError, match="floating-point range"):
        m.dsmp("b", epsilon=1e308)
    with pytest.raises(UndefinedTransformError, match="floating-point range"):
        m.dsmp_probabilities(epsilon=1e308)


@pytest.mark.parametrize("epsilon", ["inf", "nan", "-1"])
def test_dsmp_with_an_epsilon_that_is_not_finite_or_negative(capsys, write, epsilon):
    bba = write("bba.json", SHAFER_ABC)
    refused(capsys, "transform", bba, "--dsmp", epsilon, says=["ε"])


def test_dsmp_with_a_large_epsilon_tends_to_betp(capsys, write):
    bba = write("bba.json", SHAFER_ABC)
    code, out, _ = run(capsys, "transform", bba, "--dsmp", "1e300", "--json")
    assert code == 0
    assert json.loads(out)["probability"] == {"a": 0.5, "b": 0.25, "c": 0.25}
    m = MassFunction.from_dict(SHAFER_ABC)
    bound = _largest_epsilon(2)
    assert m.dsmp("b", epsilon=bound) == pytest.approx(0.25)
    with pytest.raises(UndefinedTransformError, match="floating-point range"):
        m.dsmp("b", epsilon=math.nextafter(bound, math.inf))


# -- models --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("rule", ["yager", "dsmh"])
def test_a_fusion_model_that_empties_the_frame(capsys, write, rule):
    one = write("one.json", {"frame": ["A", "B", "C"], "mass": {"A": 0.5, "B|C": 0.5}})
    two = write("two.json", {"frame": ["A", "B", "C"], "mass": {"B": 0.5, "A|C": 0.5}})
    model = write("model.json", {"type": "hybrid", "empty": ["A|B|C"]})
    refused(capsys, "combine", one, two, "--rule", rule, "--model", model,
            says=["model.json", "every hypothesis empty"])


@pytest.mark.parametrize("data", [
    {"type": "hybrid", "empty": ["A|B|C"]},
    {"type": "hybrid", "empty": ["A", "B|C"]},
    {"empty": ["A|B", "C&A|C"]},
    {"type": "shafer", "empty": ["A|B|C"]},
    {"type": "free", "empty": ["C|B|A"]},
])
def test_models_without_a_non_empty_element_are_refused(data):
    with pytest.raises(ModelError, match="every hypothesis empty"):
        Model.from_dict(Frame(["A", "B", "C"]), data)


def test_a_bba_under_a_model_that_empties_the_frame(capsys, write):
    bba = write("bba.json", {"frame": ["a"], "model": {"type": "hybrid", "empty": ["a"]},
                             "mass": {"empty": 1.0}, "subnormal": True})
    refused(capsys, "measures", bba, says=["every hypothesis empty"])


# -- lattice -------------------------------------------------------------------------------------------------
def test_lattice_of_a_hundred_million_hypotheses(capsys, write):
    refused(capsys, "lattice", "100000000", says=["100,000,000 hypotheses", "cannot be enumerated"])
    refused(capsys, "lattice", "100000000", "--json", says=["cannot be enumerated"])
    shafer = write("shafer.json", {"type": "shafer"})
    refused(capsys, "lattice", "100000000", "--model", shafer, says=["shafer model", "cannot be enumerated"])
    with pytest.raises(LatticeTooLargeError):
        hyper_power_set(100_000_000)


def test_lattice_with_a_model_that_removes_hypotheses_still_works(capsys, write):
    removed = "|".join(f"t{i}" for i in range(4, 101))
    model = write("model.json", {"type": "shafer", "empty": [removed]})
    code, out, _ = run(capsys, "lattice", "100", "--model", model, "--count")
    assert code == 0 and out.strip() == "8"


@pytest.mark.parametrize("argv", [["4"], ["--frame", 'a"b,c\\d,e']])
def test_lattice_json_is_written_as_json_dumps_would(capsys, argv):
    code, out, _ = run(capsys, "lattice", *argv, "--json")
    assert code == 0
    frame = Frame.parse(argv[1]) if argv[0] == "--frame" else Frame.numbered(4)
    lattice = hyper_power_set(frame)
    expected = {"frame": list(frame.hypotheses), "count": len(lattice), "elements": [str(e) for e in lattice]}
    assert out == json.dumps(expected, indent=2, ensure_ascii=False) + "\n"
    code, out, _ = run(capsys, "lattice", *argv, "--json", "--count")
    del expected["elements"]
    assert out == json.dumps(expected, indent=2, ensure_ascii=False) + "\n"


def test_lattice_strings_match_the_elements():
    for model in (Model.free(Frame.numbered(4)), Model.tracking(Frame(["t1", "t2", "t3", "FA"])),
                  Model.from_dict(Frame.numbered(5), {"empty": ["t1&t2", "t3"]})):
        lattice = hyper_power_set(model)
        assert list(lattice.strings()) == [str(e) for e in lattice]
        assert list(lattice.strings("unicode", chunk=7)) == [e.format("unicode") for e in lattice]


def test_batch_betp_and_dsmp_refuse_cardinalities_beyond_floats():
    # The same refusal as MassFunction's, on the batch API that the tracker and the engine use.
    import numpy as np

    from belief import MassBatch, UndefinedTransformError

    huge = MassBatch(["h1|h2", "h3"], np.array([[0.5, 0.5]]), model=Model.free(Frame([f"h{i}" for i in range(1030)])))
    for call in (huge.pignistic, lambda: huge.betp(["h1"]), lambda: huge.dsmp(["h1"])):
        with pytest.raises(UndefinedTransformError, match="out of floating-point range"):
            call()
    small = MassBatch(["a|b", "c"], np.array([[0.5, 0.5]]), model=Model.shafer(Frame(["a", "b", "c"])))
    with pytest.raises(UndefinedTransformError, match=r"use ε ≤ 8\.98\d*e\+307"):
        small.dsmp(["a"], 1e308)
    assert small.dsmp(["a"], 1e300)[0, 0] == pytest.approx(0.25)


# -- files that are not regular, or too large (a FIFO blocked the reader; /dev/zero filled the memory) ----------
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs")
def test_a_fifo_as_a_bba_file_is_refused_without_blocking(capsys, tmp_path):
    fifo = tmp_path / "m.json"
    os.mkfifo(fifo)
    refused(capsys, "combine", "--rule", "dempster", str(fifo), str(fifo), says=("it is a FIFO, not a regular file",))


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_a_device_as_a_bba_file_is_refused_before_it_is_read(capsys):
    refused(capsys, "decide", "/dev/zero", says=("'/dev/zero': it is a device, not a regular file",))


def test_a_bba_file_over_the_size_limit_is_refused_before_it_is_read(capsys, write, monkeypatch):
    path = write("m.json", {"frame": ["a", "b"], "mass": {"a": 0.5, "b": 0.5}})
    monkeypatch.setattr(textfiles, "MAX_TEXT_BYTES", 10)
    refused(capsys, "decide", path, says=("more than belief.textfiles.MAX_TEXT_BYTES = 10",))


@pytest.mark.parametrize("width", range(1, 9))
def test_row_sums_of_short_rows_are_numpys_bits(width):
    # Short rows are summed column by column (ten times faster), which must give the bits of numpy's row sums;
    # a batch is refused exactly where it was before.
    import numpy as np

    from belief.batch import _row_sums

    rng = np.random.default_rng(width)
    values = rng.random((5000, width)) ** rng.uniform(0.1, 10.0)
    values[rng.random(values.shape) < 0.1] = 0.0
    values[0] = 1e308                               # past the float range: inf, as numpy gives
    assert np.array_equal(_row_sums(values), values.sum(axis=1))
