"""The ``belief`` command line: outputs, JSON formats and one-line errors."""

import json
import subprocess
import sys

import pytest

from belief import Frame, MassFunction, Model
from belief.cli import main


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def bba(tmp_path):
    def write(data, name="m.json"):
        path = tmp_path / name
        path.write_text(data if isinstance(data, str) else json.dumps(data), encoding="utf-8")
        return str(path)

    return write


HYBRID = {"frame": ["a", "b", "c"], "model": {"type": "hybrid", "empty": ["a&b"]},
          "mass": {"a": 0.5, "b|c": 0.3, "a|b|c": 0.2}}


# -- lattice ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("n, count", [(1, 2), (2, 5), (3, 19), (4, 167)])
def test_lattice_count(capsys, n, count):
    code, out, _ = run(capsys, "lattice", str(n), "--count")
    assert code == 0 and out.strip() == str(count)


def test_lattice_lists_named_hypotheses(capsys):
    code, out, _ = run(capsys, "lattice", "2")
    assert code == 0
    frame = Frame.numbered(2)
    listed = [frame.element(line) for line in out.split()]
    assert len(listed) == 5 == len(set(listed))
    assert frame.empty in listed and frame.total in listed and frame.element("t1&t2") in listed


def test_lattice_json_with_frame_and_model(capsys, tmp_path):
    model = tmp_path / "model.json"
    model.write_text(json.dumps({"type": "shafer"}))
    code, out, _ = run(capsys, "lattice", "--frame", "x,y,z", "--model", str(model), "--json")
    data = json.loads(out)
    assert code == 0
    assert data["frame"] == ["x", "y", "z"] and data["count"] == 8 == len(data["elements"])
    frame = Frame(["x", "y", "z"])
    assert {frame.element(e) for e in data["elements"]} == {
        frame.element(p) for p in ["empty", "x", "y", "z", "x|y", "x|z", "y|z", "x|y|z"]}


def test_lattice_json_count_has_no_elements(capsys):
    code, out, _ = run(capsys, "lattice", "3", "--count", "--json")
    assert json.loads(out) == {"frame": ["t1", "t2", "t3"], "count": 19}


# -- measures -----------------------------------------------------------------------------------------
def test_measures_json_matches_library(capsys, bba):
    path = bba(HYBRID)
    code, out, _ = run(capsys, "measures", path, "--query", "a", "b&c", "c|b", "--json")
    data = json.loads(out)
    m = MassFunction.from_dict(HYBRID)
    assert code == 0 and list(data) == ["a", "b&c", "c|b"]
    for query, row in data.items():
        assert row == {"bel": m.bel(query), "pls": m.pls(query), "q": m.q(query), "betp": m.betp(query)}


def test_measures_default_queries_are_focal_elements(capsys, bba):
    code, out, _ = run(capsys, "measures", bba(HYBRID), "--json")
    assert code == 0 and set(json.loads(out)) == {"a", "b|c", "a|b|c"}


def test_measures_table(capsys, bba):
    code, out, _ = run(capsys, "measures", bba(HYBRID))
    lines = out.splitlines()
    assert code == 0 and lines[0].split() == ["proposition", "bel", "pls", "q", "betp"]
    assert lines[2].split()[0] == "a" and float(lines[2].split()[1]) == pytest.approx(0.5)


# -- transform ---------------------------------------------------------------------------------------
def test_transform_pignistic_with_query(capsys, bba):
    code, out, _ = run(capsys, "transform", bba(HYBRID), "--pignistic", "--query", "a|b", "--json")
    m = MassFunction.from_dict(HYBRID)
    probability = json.loads(out)["probability"]
    assert code == 0 and list(probability) == ["a", "b", "c", "a|b"]
    assert probability == {q: m.betp(q) for q in probability}


def test_transform_dsmp(capsys, bba):
    data = {"frame": ["a", "b"], "model": {"type": "shafer"}, "mass": {"a": 0.4, "b": 0.2, "a|b": 0.4}}
    code, out, _ = run(capsys, "transform", bba(data), "--dsmp", "0", "--json")
    probability = json.loads(out)["probability"]
    # DSmP_0(a) = .4 + .4 * .4 / (.4 + .2) = 2/3, by hand from the definition.
    assert code == 0 and probability["a"] == pytest.approx(2 / 3) and probability["b"] == pytest.approx(1 / 3)


def test_transform_discount_round_trips_as_bba(capsys, bba):
    code, out, _ = run(capsys, "transform", bba(HYBRID), "--discount", "0.5", "--json")
    result = MassFunction.from_json(out)
    assert code == 0 and result == MassFunction.from_dict(HYBRID).discount(0.5)
    assert result.model == Model.hybrid(Frame(["a", "b", "c"]), ["a&b"])


def test_transform_condition_unnormalised_is_subnormal(capsys, bba):
    code, out, _ = run(capsys, "transform", bba(HYBRID), "--condition", "b", "--json")
    data = json.loads(out)
    assert code == 0 and data["subnormal"] is True
    assert data["mass"] == {"empty": 0.5, "b": 0.5}
    code, out, _ = run(capsys, "transform", bba(HYBRID), "--condition", "b", "--normalized", "--json")
    assert json.loads(out)["mass"] == {"b": 1.0} and "subnormal" not in json.loads(out)


def test_subnormal_file_is_accepted_only_when_declared(capsys, bba):
    data = {"frame": ["a", "b"], "mass": {"empty": 0.2, "a": 0.8}}
    code, _, err = run(capsys, "measures", bba(data))
    assert code == 1 and "subnormal" in err
    code, out, _ = run(capsys, "measures", bba(dict(data, subnormal=True)), "--query", "a", "--json")
    assert code == 0 and json.loads(out)["a"]["bel"] == pytest.approx(0.8)


# -- errors: one line, non-zero exit, no traceback --------------------------------------------------------
BAD_FILES = [
    ({"frame": ["a", "b"], "mass": {"c": 1.0}}, "unknown hypothesis 'c'"),
    ({"frame": ["a", "b"], "mass": {"a": 0.5, "b": 0.4}}, "sum to"),
    ({"frame": ["a", "b"], "mass": {"a": -0.5, "b": 1.5}}, "negative mass"),
    ('{"frame": ["a", "b"], "mass": {"a": NaN, "b": 1.0}}', "not a finite number"),
    ({"frame": ["a", "b"], "mass": {"a&": 1.0}}, "malformed proposition"),
    ({"frame": ["a", "b"], "mass": {"(a|b": 1.0}}, "missing ')'"),
    ('{"frame": ["a", "b"], "mass": ', "not valid JSON"),
    ({"frame": ["a", "b"]}, "no \"mass\""),
    ({"frame": ["a", "b"], "model": {"type": "weird"}, "mass": {"a": 1.0}}, "unknown model type"),
]


@pytest.mark.parametrize("content, message", BAD_FILES)
def test_bad_bba_files(capsys, bba, content, message):
    code, out, err = run(capsys, "measures", bba(content))
    assert code == 1 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert message in err and "Traceback" not in err


def test_unreadable_file(capsys, tmp_path):
    code, _, err = run(capsys, "measures", str(tmp_path / "missing.json"))
    assert code == 1 and "no such file" in err and len(err.strip().splitlines()) == 1


def test_lattice_too_large_says_why(capsys):
    code, _, err = run(capsys, "lattice", "7", "--count")
    assert code == 1 and "cannot be enumerated" in err and len(err.strip().splitlines()) == 1


def test_total_conflict_on_normalised_conditioning(capsys, bba):
    code, _, err = run(capsys, "transform", bba(HYBRID), "--condition", "a&b", "--normalized")
    assert code == 1 and "total conflict" in err


@pytest.mark.parametrize("argv", [
    ["lattice", "x"],
    ["lattice"],
    ["lattice", "3", "--frame", "a,b"],
    ["transform", "m.json"],
    ["transform", "m.json", "--pignistic", "--discount", "0.5"],
    ["nosuchcommand"],
])
def test_usage_errors_exit_2_with_one_line(capsys, argv):
    code, _, err = run(capsys, *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "error" in err


def test_console_script_error_has_no_traceback(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"frame": ["a"], "mass": {"a": 2.0}}))
    proc = subprocess.run([sys.executable, "-m", "belief.cli", "measures", str(bad)],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 1 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr


def test_demo_runs(capsys):
    code, out, _ = run(capsys, "demo")
    assert code == 0 and "Paul" in out and "pignistic" in out
    # Propositions are written one way throughout: the tables as the mass lines.
    assert "Peter ∪ Paul" in out and "Peter|Paul" not in out and "a&b" not in out and "a∩b" in out


class HelloPlugin:
    """An entry point of the group ``belief.commands`` that adds ``belief hello``."""

    name = "hello"
    value = "hello_plugin:register"

    @staticmethod
    def load():
        def register(sub):
            p = sub.add_parser("hello")
            p.set_defaults(func=lambda args: print("hello from a plugin") or 0)
        return register


def listing(*plugins):
    import belief.cli as cli

    return lambda group: list(plugins) if group == cli.ENTRY_POINT_GROUP else []


def test_plugin_entry_points_are_registered(monkeypatch, capsys):
    import belief.cli as cli

    class Broken:
        name = "broken"
        value = "broken_plugin:register"

        @staticmethod
        def load():
            raise ImportError("missing dependency")

    monkeypatch.setattr(cli, "entry_points", listing(HelloPlugin, Broken))
    code, out, err = run(capsys, "hello")
    assert code == 0 and out.strip() == "hello from a plugin"
    assert "plugin 'broken' could not be loaded" in err


def test_a_plugin_listed_by_two_distributions_is_registered_once(monkeypatch, capsys):
    # An environment that still holds the project under an earlier distribution name lists each entry point twice.
    import belief.cli as cli

    class SameUnderTheNewName(HelloPlugin):
        pass

    monkeypatch.setattr(cli, "entry_points", listing(HelloPlugin, SameUnderTheNewName))
    code, out, err = run(capsys, "hello")
    assert code == 0 and out.strip() == "hello from a plugin"
    assert err == ""


# -- combine and rules ------------------------------------------------------------------------------
ZADEH_1 = {"frame": ["A", "B", "C"], "model": {"type": "shafer"}, "mass": {"A": 0.9, "C": 0.1}}
ZADEH_2 = {"frame": ["A", "B", "C"], "model": {"type": "shafer"}, "mass": {"B": 0.9, "C": 0.1}}


def test_rules_lists_every_registered_rule(capsys):
    from belief.rules import RULES

    code, out, _ = run(capsys, "rules")
    listed = [line.split()[0] for line in out.splitlines()]
    assert code == 0 and listed == list(RULES)


def test_combine_zadeh_dempster_table(capsys, bba):
    # Zadeh's example: Dempster's rule puts all the mass on C.
    code, out, _ = run(capsys, "combine", "--rule", "dempster", bba(ZADEH_1, "1.json"), bba(ZADEH_2, "2.json"))
    lines = out.splitlines()
    assert code == 0 and lines[2].split() == ["C", "1.000000"] and len(lines) == 3


def test_combine_json_keeps_conflict_and_can_be_combined_again(capsys, bba):
    one, two = bba(ZADEH_1, "1.json"), bba(ZADEH_2, "2.json")
    code, out, _ = run(capsys, "combine", "--rule", "conjunctive", one, two, "--json")
    data = json.loads(out)
    assert code == 0 and data["subnormal"] is True
    assert data["mass"]["empty"] == pytest.approx(0.99) and data["mass"]["C"] == pytest.approx(0.01)
    again = bba(data, "again.json")
    code, out, _ = run(capsys, "combine", "--rule", "conjunctive", again, one, "--json")
    assert code == 0 and json.loads(out)["mass"]["empty"] == pytest.approx(1 - 0.001)


def test_combine_dynamic_fusion_with_model_file(capsys, bba, tmp_path):
    free1 = dict(ZADEH_1, model={"type": "free"})
    free2 = dict(ZADEH_2, model={"type": "free"})
    model = tmp_path / "shafer.json"
    model.write_text(json.dumps({"type": "shafer"}))
    code, out, _ = run(capsys, "combine", "--rule", "dsmh", "--model", str(model),
                       bba(free1, "1.json"), bba(free2, "2.json"), "--json")
    data = json.loads(out)
    # DSmH on Zadeh's example (DSmT book vol. 1, ch. 5): A∪B .81, A∪C .09, B∪C .09, C .01.
    frame = Frame(["A", "B", "C"])
    got = {frame.element(k): v for k, v in data["mass"].items()}
    expected = {"A|B": 0.81, "A|C": 0.09, "B|C": 0.09, "C": 0.01}
    assert code == 0 and data["model"] == {"type": "shafer"}
    assert got.keys() == {frame.element(k) for k in expected}
    for key, value in expected.items():
        assert got[frame.element(key)] == pytest.approx(value)


def test_combine_r_rule_options(capsys, bba):
    one, two = bba(ZADEH_1, "1.json"), bba(ZADEH_2, "2.json")
    _, paper, _ = run(capsys, "combine", "--rule", "r_rule", one, two, "--json")
    _, euclid, _ = run(capsys, "combine", "--rule", "r_rule", "--r-mode", "euclid", one, two, "--json")
    assert json.loads(paper)["mass"] != json.loads(euclid)["mass"]
    code, _, err = run(capsys, "combine", "--rule", "dempster", "--r-mode", "euclid", one, two)
    assert code == 1 and "r_mode" in err


@pytest.mark.parametrize("argv, message", [
    (["--rule", "nosuchrule"], "known rules: conjunctive"),
])
def test_combine_unknown_rule_lists_known(capsys, bba, argv, message):
    code, _, err = run(capsys, "combine", *argv, bba(ZADEH_1, "1.json"), bba(ZADEH_2, "2.json"))
    assert code == 1 and message in err and len(err.strip().splitlines()) == 1


def test_combine_total_conflict_message(capsys, bba):
    a = {"frame": ["A", "B"], "model": {"type": "shafer"}, "mass": {"A": 1.0}}
    b = {"frame": ["A", "B"], "model": {"type": "shafer"}, "mass": {"B": 1.0}}
    code, out, err = run(capsys, "combine", "--rule", "dempster", bba(a, "a.json"), bba(b, "b.json"))
    assert code == 1 and out == "" and "total conflict" in err and len(err.strip().splitlines()) == 1


def test_combine_needs_two_sources_of_one_model(capsys, bba):
    code, _, err = run(capsys, "combine", "--rule", "pcr6", bba(ZADEH_1, "1.json"))
    assert code == 2 and "at least two" in err
    other = dict(ZADEH_2, model={"type": "free"})
    code, _, err = run(capsys, "combine", "--rule", "pcr6", bba(ZADEH_1, "1.json"), bba(other, "2.json"))
    assert code == 1 and "model" in err
