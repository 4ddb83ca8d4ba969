"""The command line says why a number may surprise: overlapping hypotheses, an empty query, the default rule."""

from __future__ import annotations

import json

import pytest

from belief.cli import main

HYBRID = {"frame": ["a", "b", "c"], "model": {"type": "hybrid", "empty": ["a&b"]},
          "mass": {"a": 0.5, "b|c": 0.3, "a|b|c": 0.2}}
SHAFER = {"frame": ["A", "B"], "mass": {"A": 0.6, "A|B": 0.4}}


@pytest.fixture
def files(tmp_path):
    paths = {}
    for name, data in (("hybrid", HYBRID), ("shafer", SHAFER)):
        paths[name] = tmp_path / f"{name}.json"
        paths[name].write_text(json.dumps(data))
    return paths


def run(capsys, *argv):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_betp_of_overlapping_hypotheses_says_why_it_sums_past_one(capsys, files):
    status, out, err = run(capsys, "transform", files["hybrid"], "--pignistic")
    assert status == 0 and "0.655000" in out
    assert err.count("\n") == 1 and "need not sum to 1" in err and "a∩c, b∩c" in err and "a∩b" not in err
    status, out, err = run(capsys, "transform", files["shafer"], "--pignistic")
    assert status == 0 and err == ""          # exclusive hypotheses: their BetP sums to one, nothing to say
    status, _, err = run(capsys, "-q", "transform", files["hybrid"], "--pignistic")
    assert status == 0 and err == ""


def test_a_query_that_is_empty_under_the_model_is_marked_and_named(capsys, files):
    status, out, err = run(capsys, "measures", files["shafer"], "--query", "A&B", "A")
    assert status == 0
    assert out.splitlines()[2].startswith("A&B (= ∅)") and "1.000000" in out.splitlines()[2]
    assert "A&B is empty under the shafer model" in err and "q(∅) is 1" in err
    status, out, _ = run(capsys, "measures", files["shafer"], "--query", "A&B", "--json")
    assert json.loads(out) == {"A&B": {"bel": 0.0, "pls": 0.0, "q": 1.0, "betp": 0.0}}   # keys as given


def test_combine_uses_dempsters_rule_by_default_as_python_does(capsys, files):
    from belief import MassFunction, combine

    status, out, _ = run(capsys, "combine", files["shafer"], files["shafer"], "--json")
    source = MassFunction.from_dict(SHAFER)
    assert status == 0
    assert json.loads(out)["mass"] == combine(source, source).to_mapping() == \
        combine(source, source, rule="dempster").to_mapping()
