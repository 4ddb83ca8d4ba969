"""Fuzzing of the ``belief`` command line, and the hardening reproducers as tests.

Every command, on any input, keeps one contract: exit status 0 with a valid result, or a
non-zero exit status with exactly one line on standard error; never a traceback, never NaN or
inf in the output.  The BBA files that ``combine`` and ``transform`` print are read again by
``measures`` and ``combine``.

The commands run in-process through ``belief.cli.main`` (see :mod:`tests.fuzz_strategies`).  The
reproducers that could run away (huge joint combinations, huge frames, the hyper-power set of
six hypotheses) run as processes of their own, killed after a generous time and limited in
memory, so that a regression fails the test instead of holding up the suite.  No test asserts
how long a command takes, nor the wording of a message.
"""

from __future__ import annotations

import json
import math
import os
import re
import resource
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.fuzz_strategies import (
    NOT_FINITE,
    RULES,
    SIMPLE_NAMES,
    Outcome,
    assert_contract,
    bba_documents,
    call,
    check_bba,
    check_finite_values,
    check_lattice,
    check_measures,
    check_number,
    check_probability,
    documents,
    encoded,
    frames,
    json_values,
    load_json,
    model_objects,
    propositions,
    write,
)

FUZZ = settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                        HealthCheck.data_too_large])
FEW = settings(FUZZ, max_examples=12)
TIMEOUT = 60
MEMORY = 2 << 30


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


class Files:
    """Numbered files in one folder, for the examples of one test."""

    def __init__(self, root: Path, prefix: str) -> None:
        self.root, self.prefix, self.count = root, prefix, 0

    def __call__(self, text: str, suffix: str = ".json") -> str:
        self.count += 1
        return write(self.root / f"{self.prefix}{self.count}{suffix}", text)


def read_back(files: Files, text: str, partner: str | None = None) -> None:
    """A printed BBA is read again: ``measures`` accepts it, ``combine`` keeps the contract with it."""
    path = files(text)
    # BetP is undefined when all the mass is on the empty set: there, measures may refuse in one line
    conflict = load_json(text)["mass"].get("empty", 0.0) >= 1 - 1e-9
    assert_contract(call("measures", path, "--json"), "either" if conflict else "ok", check_measures)
    assert_contract(call("combine", path, partner or path, "--rule", "conjunctive", "--json"), "either", check_bba)


def _exclusive(data: dict) -> bool:
    model = data.get("model")
    return isinstance(model, dict) and model.get("type") == "shafer"


# -- fuzzing ---------------------------------------------------------------------------------------------------
@FUZZ
@given(text=documents(), command=st.sampled_from(["measures", "transform", "combine", "decide", "distance",
                                                   "uncertainty"]), as_json=st.booleans())
def test_fuzz_any_file_where_a_bba_is_expected(folder, text, command, as_json):
    files = Files(folder, "any")
    path = files(text)
    flag = ["--json"] if as_json else []
    argv = {"measures": ["measures", path],
            "transform": ["transform", path, "--pignistic"],
            "combine": ["combine", path, path, "--rule", "pcr6"],
            "decide": ["decide", path],
            "distance": ["distance", path, path],
            "uncertainty": ["uncertainty", path]}[command]
    if command == "combine" and as_json:
        assert_contract(call(*argv, *flag), "either", lambda out: read_back(files, out, path))
    else:
        assert_contract(call(*argv, *flag))


@FEW
@given(text=st.one_of(propositions(["a", "b", "c"], max_leaves=10), st.text(max_size=12),
                      st.text(alphabet="abc()&|∩∪∅ empty\t\n", max_size=20)),
       model=st.sampled_from([None, {"type": "shafer"}, {"type": "hybrid", "empty": ["a&b"]}]))
def test_fuzz_proposition_strings(folder, text, model):
    files = Files(folder, "proposition")
    data = {"frame": ["a", "b", "c"], "mass": {text: 1.0}}
    if model is not None:
        data["model"] = model
    path = files(json.dumps(data))
    assert_contract(call("measures", path, "--json"), "either", check_measures)
    plain = files(json.dumps({"frame": ["a", "b", "c"], "mass": {"a": 0.5, "b|c": 0.5}}))
    assert_contract(call("measures", plain, "--query", text, "--json"), "either", check_measures)
    assert_contract(call("transform", plain, "--condition", text, "--json"), "either",
                    lambda out: read_back(files, out, plain))
    assert_contract(call("decide", plain, "--candidates", text, "--json"), "either", check_number("value"))


@FUZZ
@given(data=bba_documents(), queries=st.data(), as_json=st.booleans())
def test_fuzz_measures(folder, data, queries, as_json):
    names = data["frame"] if isinstance(data["frame"], list) else []
    names = [n for n in names if isinstance(n, str)]
    asked = queries.draw(st.lists(propositions(names), max_size=3))
    path = Files(folder, "measures")(json.dumps(data))
    argv = ["measures", path] + (["--query", *asked] if asked else [])
    assert_contract(call(*argv, *(["--json"] if as_json else [])), "either", check_measures if as_json else None)


@st.composite
def transform_options(draw, names):
    how = draw(st.sampled_from(["--pignistic", "--dsmp", "--discount", "--condition", "--plausibility",
                                "--contextual-discount"]))
    number = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0, 1, 1e-3, 1e308, -1, 2]))
    options = {"--dsmp": [str(draw(number))], "--discount": [str(draw(number))],
               "--condition": [draw(propositions(names))]}.get(how, [])
    extra = []
    if draw(st.integers(0, 4)) == 0:
        extra.append("--normalized")
    if draw(st.integers(0, 3)) == 0:
        extra += ["--query", *draw(st.lists(propositions(names), min_size=1, max_size=2))]
    return how, options, extra


@FUZZ
@given(data=bba_documents(), choice=st.data())
def test_fuzz_transform(folder, data, choice):
    files = Files(folder, "transform")
    names = [n for n in data["frame"] if isinstance(n, str)] if isinstance(data["frame"], list) else []
    how, options, extra = choice.draw(transform_options(names))
    path = files(json.dumps(data))
    if how == "--contextual-discount":
        rates = choice.draw(st.one_of(
            st.dictionaries(st.sampled_from(names or ["a"]),
                            st.one_of(st.floats(0, 1), st.floats(allow_nan=True, allow_infinity=True)), max_size=3),
            json_values(3)))
        options = [files(json.dumps(rates))]
    result = call("transform", path, how, *options, *extra, "--json")
    if how in ("--discount", "--condition", "--contextual-discount"):
        check = lambda out: read_back(files, out, path)  # noqa: E731
    elif how == "--plausibility":
        check = lambda out: check_probability(out, True, names)  # noqa: E731
    else:
        check = lambda out: check_probability(out, _exclusive(data), names)  # noqa: E731
    assert_contract(result, "either", check)


@FUZZ
@given(first=bba_documents(), choice=st.data())
def test_fuzz_combine(folder, first, choice):
    files = Files(folder, "combine")
    documents_ = [first] + choice.draw(st.lists(st.one_of(bba_documents(), st.just(first)), min_size=1, max_size=2))
    paths = [files(json.dumps(d)) for d in documents_]
    rule = choice.draw(st.one_of(st.sampled_from(RULES), st.sampled_from(["DS", "pcr5+", "nope", ""])))
    extra = []
    if choice.draw(st.integers(0, 3)) == 0:
        names = [n for n in first["frame"] if isinstance(n, str)] if isinstance(first["frame"], list) else []
        extra += ["--model", files(json.dumps(choice.draw(model_objects(names))))]
    if rule == "r_rule" or choice.draw(st.integers(0, 5)) == 0:
        extra += ["--r-mode", choice.draw(st.sampled_from(["paper", "euclid", "jousselme"]))]
        extra += ["--empty-mode", choice.draw(st.sampled_from(["union", "empty"]))]
    as_json = choice.draw(st.booleans())
    result = call("combine", *paths, "--rule", rule, *extra, *(["--json"] if as_json else []))
    assert_contract(result, "either", (lambda out: read_back(files, out, paths[0])) if as_json else None)


@FEW
@given(data=bba_documents(), other=bba_documents(), choice=st.data())
def test_fuzz_decide_distance_uncertainty(folder, data, other, choice):
    files = Files(folder, "ddu")
    path, second = files(json.dumps(data)), files(json.dumps(choice.draw(st.one_of(st.just(data), st.just(other)))))
    names = [n for n in data["frame"] if isinstance(n, str)] if isinstance(data["frame"], list) else []
    criterion = choice.draw(st.sampled_from(["betp", "bel", "pls", "dsmp"]))
    argv = ["decide", path, "--criterion", criterion, "--json"]
    if choice.draw(st.booleans()):
        argv += ["--candidates", *choice.draw(st.lists(propositions(names), min_size=1, max_size=3))]
    if choice.draw(st.integers(0, 2)) == 0:
        argv += ["--epsilon", str(choice.draw(st.floats(allow_nan=True, allow_infinity=True)))]
    if choice.draw(st.integers(0, 2)) == 0:
        argv += ["--tolerance", str(choice.draw(st.floats(allow_nan=True, allow_infinity=True)))]
    assert_contract(call(*argv), "either", check_number("value"))
    kind = choice.draw(st.sampled_from(["jousselme", "euclidean", "tessem", "nope"]))
    assert_contract(call("distance", path, second, "--kind", kind, "--json"), "either", check_number("distance"))
    measures = choice.draw(st.lists(st.sampled_from(["nonspecificity", "deng", "discord", "x"]),
                                    max_size=2))
    argv = ["uncertainty", path, "--json"] + (["--measure", *measures] if measures else [])
    assert_contract(call(*argv), "either", check_finite_values)


@FUZZ
@given(choice=st.data())
def test_fuzz_lattice(folder, choice):
    files = Files(folder, "lattice")
    argv = ["lattice"]
    if choice.draw(st.booleans()):
        argv.append(str(choice.draw(st.one_of(st.integers(-3, 4), st.sampled_from(["x", "2.5", "", "1e3"])))))
    names = []
    if choice.draw(st.integers(0, 2)) == 0:
        names = choice.draw(frames(SIMPLE_NAMES, min_size=0, max_size=4, unique=False))
        text = st.text(max_size=6).filter(lambda t: not any(NOT_FINITE.fullmatch(p.strip()) for p in t.split(",")))
        argv += ["--frame", choice.draw(st.one_of(st.just(",".join(names)), text))]
    if choice.draw(st.integers(0, 2)) == 0:
        argv += ["--model", files(choice.draw(encoded(model_objects(names or ["t1", "t2"]))))]
    argv += choice.draw(st.lists(st.sampled_from(["--count", "--json"]), unique=True))
    assert_contract(call(*argv), "either", check_lattice if "--json" in argv else None)


@settings(FUZZ, max_examples=3)
@given(data=bba_documents())
def test_fuzz_plot(folder, data):
    pytest.importorskip("matplotlib")
    files = Files(folder, "plot")
    path = files(json.dumps(data))
    assert_contract(call("plot", path, "--out", str(folder / "figure.png")))


@pytest.mark.parametrize("argv", [["rules"], ["demo"], ["nope"], ["combine"], ["measures"],
                                  ["transform", "x.json"], ["lattice", "--count", "--json"]])
def test_plain_commands_and_wrong_command_lines(argv):
    assert_contract(call(*argv))


# -- found by the fuzzing: user text with line breaks echoed raw in a message ---------------------------------------
@pytest.mark.parametrize("text, argv", [
    ('{"frame": ["a"], "mass": {"a": 1}, "\\n": null}', ["measures"]),
    ('{"frame": ["a"], "mass": {"a": 1}, "x\\u0085y": null}', ["measures"]),
    ('{"frame": ["a"], "model": {"\\r": null}, "mass": {"a": 1}}', ["measures"]),
    ('{"frame": ["a"], "model": {"type": "shafer", "x\\fy": 1}, "mass": {"a": 1}}', ["measures"]),
    ('{"frame": ["a", "b"], "mass": {"a": 0.5, "b": 0.5}}', ["decide", "--candidates", "\n∅"]),
    ('{"frame": ["a", "b"], "model": {"type": "shafer"}, "mass": {"a": 0.5, "b": 0.5}}',
     ["decide", "--candidates", "a&b\n"]),
], ids=["unknown key \\n", "unknown key \\x85", "model key \\r", "model key \\f", "candidate \\n∅",
        "candidate a&b\\n"])
def test_refusals_quote_line_breaks_of_user_text(tmp_path, text, argv):
    path = write(tmp_path / "m.json", text)
    command, *options = argv
    assert_contract(call(command, path, *options), "error")


# -- processes with a time and memory cap -----------------------------------------------------------------------
def _cap() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))


def run_capped(argv: list, cwd: Path, timeout: float = TIMEOUT, stdout_file: Path | None = None) -> Outcome:
    """The command line in a process of its own, limited to ``MEMORY`` bytes and killed after ``timeout`` s."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    command = [sys.executable, "-c", "import sys; from belief.cli import main; sys.exit(main())", *map(str, argv)]
    out = open(stdout_file, "wb") if stdout_file else subprocess.PIPE
    try:
        process = subprocess.run(command, cwd=cwd, stdout=out, stderr=subprocess.PIPE, env=env,
                                 preexec_fn=_cap, timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail(f"belief {' '.join(map(str, argv))[:200]} still running after {timeout} s (killed)")
    finally:
        if stdout_file:
            out.close()
    stdout = "" if stdout_file else process.stdout.decode("utf-8", "replace")
    err = process.stderr.decode("utf-8", "replace")
    crash = err if "Traceback" in err or "MemoryError" in err else None
    code = process.returncode if process.returncode >= 0 else 128 - process.returncode
    return Outcome(list(argv), code, stdout, err, crash)


def _bba(frame, mass, model=None) -> str:
    data = {"frame": frame, "mass": mass}
    if model is not None:
        data["model"] = model
    return json.dumps(data)


SHAFER = {"type": "shafer"}


# -- point 1: the size guard -------------------------------------------------------------------------------
@pytest.mark.parametrize("rule", ["dsmh", "pcr5", "pcr6", "dubois_prade"])
def test_point1_size_guard_64_sources(tmp_path, rule):
    for i in range(64):
        (tmp_path / f"s{i}.json").write_text(_bba(["a", "b"], {"a": 0.5, "b": 0.5}, SHAFER))
    result = run_capped(["combine", "--rule", rule, *[f"s{i}.json" for i in range(64)], "--json"], tmp_path)
    assert_contract(result, "either", check_bba)


# -- point 2: limits, and joint tuples that associative rules do not need ------------------------------------------
@pytest.mark.parametrize("rule", ["pcr6", "dsmh"])
def test_point2_limits_24_sources_of_2(tmp_path, rule):
    for k in range(24):
        a = 0.2 + 0.6 * ((k * 37) % 64) / 64
        (tmp_path / f"p{k}.json").write_text(_bba(["a", "b"], {"a": a, "b": 1 - a}, SHAFER))
    result = run_capped(["combine", "--rule", rule, *[f"p{k}.json" for k in range(24)], "--json"], tmp_path)
    assert_contract(result, "either", check_bba)


@pytest.mark.parametrize("rule", ["dempster", "conjunctive", "disjunctive"])
def test_point2_limits_25_sources_of_5_free_10(tmp_path, rule):
    h = [f"h{i}" for i in range(10)]
    for k in range(25):
        mass = {h[k % 10]: 0.3, f"{h[(k + 1) % 10]}|{h[(k + 3) % 10]}": 0.25,
                f"{h[(k + 2) % 10]}&{h[(k + 5) % 10]}": 0.15,
                f"{h[(k + 4) % 10]}|{h[(k + 6) % 10]}|{h[(k + 7) % 10]}": 0.2, "|".join(h): 0.1}
        (tmp_path / f"f{k}.json").write_text(_bba(h, mass))
    result = run_capped(["combine", "--rule", rule, *[f"f{k}.json" for k in range(25)], "--json"], tmp_path)
    assert_contract(result, "either", check_bba)


# -- point 3: bad BBA input ----------------------------------------------------------------------------------------
AB = _bba(["a", "b"], {"a": 0.5, "b": 0.5})
BAD_INPUT = {
    "model type list": ('{"frame": ["a", "b"], "model": {"type": ["x"]}, "mass": {"a": 1}}', "error"),
    "mass of 400 digits": ('{"frame": ["a", "b"], "mass": {"a": 1' + "0" * 399 + "}}", "error"),
    "mass of 5000 digits": ('{"frame": ["a", "b"], "mass": {"a": 1' + "0" * 4999 + "}}", "error"),
    "JSON nested 50000 deep": ("[" * 50000 + "]" * 50000, "error"),
    "mass nested 50000 deep": ('{"frame": ["a", "b"], "mass": ' + '{"a": ' * 50000 + "1" + "}" * 50001, "error"),
    "400 nested parentheses": (_bba(["a", "b"], {"(" * 400 + "a" + ")" * 400: 0.5, "b": 0.5}), "either"),
    "hypothesis \\ud800": ('{"frame": ["\\ud800", "b"], "mass": {"\\ud800": 0.5, "b": 0.5}}', "either"),
    "free frame of 1030": (_bba([f"h{i}" for i in range(1030)], {"h0": 0.5, "h1|h2": 0.5}), "either"),
}


@pytest.mark.parametrize("case", list(BAD_INPUT))
@pytest.mark.parametrize("command", ["measures", "transform", "combine"])
def test_point3_bad_bba_input(tmp_path, case, command):
    text, expected = BAD_INPUT[case]
    path = write(tmp_path / "bad.json", text)
    argv = {"measures": ["measures", path, "--json"],
            "transform": ["transform", path, "--pignistic", "--json"],
            "combine": ["combine", "--rule", "dempster", path, path, "--json"]}[command]
    check = {"measures": check_measures, "transform": lambda out: check_probability(out, False),
             "combine": check_bba}[command]
    assert_contract(call(*argv), expected, check)


def test_point3_model_file_with_type_list(tmp_path):
    model, path = write(tmp_path / "model.json", '{"type": ["x"]}'), write(tmp_path / "m.json", AB)
    assert_contract(call("combine", "--rule", "dempster", path, path, "--model", model), "error")
    assert_contract(call("lattice", "2", "--model", model), "error")


@pytest.mark.parametrize("n", [1000, 10000])
def test_point3_shafer_model_on_many_hypotheses(tmp_path, n):
    write(tmp_path / "m.json", _bba([f"h{i}" for i in range(n)], {"h0": 0.5, "h1|h2": 0.5}, SHAFER))
    assert_contract(run_capped(["measures", "m.json", "--json"], tmp_path), "either", check_measures)


# -- point 4: parsing a union of n hypotheses ---------------------------------------------------------------------
@pytest.mark.parametrize("n", [1000, 2000, 4000, 8000])
def test_point4_union_of_n_hypotheses(tmp_path, n):
    names = [f"h{i}" for i in range(n)]
    write(tmp_path / "m.json", _bba(names, {"(" + "|".join(names[:-1]) + ")": 1.0}))
    result = run_capped(["transform", "m.json", "--discount", "0.9", "--json"], tmp_path)
    assert_contract(result, "ok", check_bba)


# -- point 5: results read back ----------------------------------------------------------------------------------------
DRIFT = _bba(["a", "b", "c"], {"a": 0.3, "b": 0.3, "a|b|c": 0.4000000009})


@pytest.mark.parametrize("rule", ["pcr6", "pcr5", "dempster", "conjunctive", "disjunctive", "yager", "dsmh",
                                  "dubois_prade", "average", "murphy"])
def test_point5_three_sources_summing_to_one_plus_9e_10_read_back(tmp_path, rule):
    path = write(tmp_path / "m.json", DRIFT)
    result = call("combine", "--rule", rule, path, path, path, "--json")
    assert_contract(result, "ok", check_bba)
    again = write(tmp_path / "r.json", result.out)
    assert_contract(call("measures", again), "ok")
    assert_contract(call("combine", "--rule", rule, again, path, "--json"), "ok", check_bba)


def test_point5_pcr6_chain_read_back(tmp_path):
    path = current = write(tmp_path / "m.json", DRIFT)
    for k in range(3):
        result = call("combine", "--rule", "pcr6", current, path, "--json")
        assert_contract(result, "ok", check_bba)
        current = write(tmp_path / f"r{k}.json", result.out)
    assert_contract(call("measures", current, "--json"), "ok", check_measures)


# -- point 6: silent numerical failures -------------------------------------------------------------------------------
def test_point6_dsmp_with_huge_epsilon(tmp_path):
    path = write(tmp_path / "m.json", _bba(["a", "b", "c"], {"a": 0.5, "b|c": 0.5}, SHAFER))

    def check(out):
        probability = check_probability(out, True)
        assert math.isclose(probability["a"], 0.5, rel_tol=1e-6), probability
        assert math.isclose(probability["b"], probability["c"], rel_tol=1e-6), probability

    assert_contract(call("transform", path, "--dsmp", "1e308", "--json"), "either", check)


H5 = [f"h{i}" for i in range(5)]


@pytest.mark.parametrize("first, second, exact", [
    ({"h4": 1, "h0|h1": 5e-324, "h2|h3": 1e-300}, {"h0": 2 / 3, "h1": 1 / 3}, {"h0": 2 / 3, "h1": 1 / 3}),
    ({"h4": 1, "h0|h1": 5e-324}, {"h0": 0.4, "h1": 0.6}, {"h0": 0.4, "h1": 0.6}),
    ({"h4": 1, "h0|h1": 5e-324}, {"h0": 0.4, "h1": 0.4, "h2": 0.2}, {"h0": 0.5, "h1": 0.5}),
], ids=["2/3 1/3", "0.4 0.6", "called total conflict"])
def test_point6_dempster_with_conflict_next_to_one(tmp_path, first, second, exact):
    one, two = write(tmp_path / "1.json", _bba(H5, first, SHAFER)), write(tmp_path / "2.json", _bba(H5, second, SHAFER))

    def check(out):
        mass = check_bba(out)["mass"]
        assert set(mass) == set(exact) and all(math.isclose(mass[k], v, rel_tol=1e-9) for k, v in exact.items()), mass

    assert_contract(call("combine", "--rule", "dempster", one, two, "--json"), "either", check)


@pytest.mark.parametrize("rule", ["yager", "dsmh"])
def test_point6_fusion_model_that_empties_the_frame(tmp_path, rule):
    one = write(tmp_path / "1.json", _bba(["A", "B", "C"], {"A": 0.5, "B|C": 0.5}))
    two = write(tmp_path / "2.json", _bba(["A", "B", "C"], {"B": 0.5, "A|C": 0.5}))
    model = write(tmp_path / "model.json", json.dumps({"type": "hybrid", "empty": ["A|B|C"]}))
    assert_contract(call("combine", "--rule", rule, one, two, "--model", model, "--json"), "error")


# -- point 7: ambiguous input ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("text", [
    '{"frame": ["a", "b"], "mass": {"a": 0.5, "b": 0.2, "b": 0.5}}',
    '{"frame": ["a", "b"], "frame": ["a", "b", "c"], "mass": {"a": 0.5, "b": 0.5}}',
], ids=["mass", "frame"])
def test_point7_duplicate_keys(tmp_path, text):
    assert_contract(call("measures", write(tmp_path / "m.json", text)), "error")


@pytest.mark.parametrize("invisible", ["\\u200b", "\\u200d", "\\ufeff", "\\u2060"])
def test_point7_names_differing_by_invisible_characters(tmp_path, invisible):
    text = f'{{"frame": ["a", "a{invisible}"], "mass": {{"a": 0.5, "a{invisible}": 0.5}}}}'
    assert_contract(call("measures", write(tmp_path / "m.json", text)), "error")


def test_point7_nul_in_a_name(tmp_path):
    text = '{"frame": ["a\\u0000b", "c"], "mass": {"a\\u0000b": 0.5, "c": 0.5}}'
    assert_contract(call("measures", write(tmp_path / "m.json", text)), "error")
    assert_contract(call("lattice", "--frame", "a\x00b,c"), "error")


# -- point 8: lattice ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("n", ["100000000", str(2 ** 63), "64"])
def test_point8_lattice_too_large(tmp_path, n):
    assert_contract(run_capped(["lattice", n], tmp_path), "error")


def test_point8_lattice_6_json_starts_streaming_in_little_memory(tmp_path):
    """The first 32 MB of ``lattice 6 --json`` arrive from a process limited to 1 GB: the list is streamed."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    command = [sys.executable, "-c", "import sys; from belief.cli import main; sys.exit(main())", "lattice", "6",
               "--json"]

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))

    process = subprocess.Popen(command, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                               preexec_fn=cap)
    received, size = [], 0
    try:
        while size < 32 << 20:
            chunk = process.stdout.read1(1 << 20)
            if not chunk:
                break
            received.append(chunk)
            size += len(chunk)
    finally:
        if process.poll() is None:
            process.kill()
        _, err = process.communicate(timeout=TIMEOUT)
    text = b"".join(received).decode("utf-8", "ignore")
    assert size >= 32 << 20, f"{size} bytes, then exit {process.returncode}: {err.decode('utf-8', 'replace')[-800:]}"
    assert text.lstrip().startswith("{") and '"elements"' in text, text[:200]
    listed = text[text.index("[", text.index('"elements"')) + 1:].rsplit(",", 1)[0]
    elements = json.loads("[" + listed + "]")
    assert len(elements) > 1000 and all(isinstance(e, str) and e for e in elements)
    found = re.search(r'"count"\s*:\s*(\d+)', text[:text.index('"elements"')])
    assert found is None or int(found.group(1)) == 7828353
