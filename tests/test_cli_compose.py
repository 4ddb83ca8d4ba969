"""The command line composes: '-' reads standard input, ``python -m belief`` runs it, ``rules --json`` lists rules."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from belief.cli import main

SOURCES = ({"model": {"type": "shafer"}, "frame": ["a", "b", "c"], "mass": {"a": 0.6, "a|b": 0.4}},
           {"model": {"type": "shafer"}, "frame": ["a", "b", "c"], "mass": {"b": 0.5, "a|b|c": 0.5}})


@pytest.fixture
def sources(tmp_path):
    paths = []
    for k, data in enumerate(SOURCES):
        path = tmp_path / f"s{k}.json"
        path.write_text(json.dumps(data), encoding="utf-8")
        paths.append(str(path))
    return paths


def belief(*arguments: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "belief", *arguments], input=stdin, capture_output=True,
                          text=True, timeout=120)


def test_json_output_of_combine_feeds_transform_through_a_pipe(sources):
    combined = belief("combine", "--rule", "dempster", *sources, "--json")
    assert combined.returncode == 0, combined.stderr
    piped = belief("transform", "-", "--pignistic", "--json", stdin=combined.stdout)
    assert piped.returncode == 0, piped.stderr
    probability = json.loads(piped.stdout)["probability"]
    assert sum(probability.values()) == pytest.approx(1.0) and probability["a"] > probability["c"]
    direct = belief("transform", sources[0], "--pignistic", "--json")
    again = belief("transform", "-", "--pignistic", "--json", stdin=open(sources[0], encoding="utf-8").read())
    assert json.loads(direct.stdout) == json.loads(again.stdout)


def test_standard_input_is_read_once_a_command(sources, monkeypatch, capsys):
    monkeypatch.setattr(sys, "stdin", open(sources[0], encoding="utf-8"))
    assert main(["combine", "--rule", "dempster", "-", "-"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "standard input ('-') can be read only once" in err


def test_bad_json_on_standard_input_is_one_line_naming_it(capsys, monkeypatch, tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text("{not json", encoding="utf-8")
    monkeypatch.setattr(sys, "stdin", open(bad, encoding="utf-8"))
    assert main(["measures", "-"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "BBA file on standard input is not valid JSON" in err


def test_python_dash_m_belief_is_the_command_line():
    done = belief("--version")
    assert done.returncode == 0 and done.stdout.startswith("belief ")


def test_rules_list_as_json_with_their_properties(capsys):
    from belief.rules import RULES

    assert main(["rules", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert [rule["name"] for rule in listed] == list(RULES)
    dempster = next(rule for rule in listed if rule["name"] == "dempster")
    assert dempster["associative"] is True and dempster["keeps_conflict"] is False
    assert next(rule for rule in listed if rule["name"] == "pcr6")["associative"] is False


def test_the_everyday_functions_are_at_the_top_level_and_betp_gives_the_distribution():
    import belief
    import belief.uncertainty
    from belief import Frame, MassFunction, Model, conflict, decide, distance
    from belief.decisions import decide as decide_itself

    assert decide is decide_itself and {"decide", "distance", "conflict"} <= set(belief.__all__)
    assert {"decide", "distance"} <= set(dir(belief))
    m = MassFunction({"a": 0.5, "a|b": 0.5}, model=Model.shafer(Frame(["a", "b"])))
    assert decide(m, "betp").elements == ["a"] and distance(m, m) == 0.0
    assert m.betp() == m.pignistic() == {"a": 0.75, "b": 0.25}
    assert set(belief.uncertainty.uncertainty(m)) >= {"nonspecificity"} and conflict(m, m) >= 0.0
    with pytest.raises(AttributeError, match="no attribute 'decidee'"):
        belief.decidee
