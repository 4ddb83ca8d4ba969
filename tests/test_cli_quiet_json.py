"""A command line that composes: -q and -v on every command, --json wherever results are printed, and the note of
``belief combine`` under a model with no empty intersection (issue 27)."""

from __future__ import annotations

import argparse
import json

import pytest

from belief.cli import CONJUNCTIVE_WITHOUT_CONFLICT, build_parser, main
from belief.mass import MassFunction

FREE = {"type": "free"}
SHAFER = {"type": "shafer"}
#: Two sources whose focal elements intersect in a&b, a&c and b&c: empty under Shafer's model, not under the free one.
SOURCES = ({"frame": ["a", "b", "c"], "mass": {"a": 0.6, "b|c": 0.3, "a|b|c": 0.1}},
           {"frame": ["a", "b", "c"], "mass": {"b": 0.5, "c": 0.2, "a|c": 0.3}})
#: The commands that print no result to put in JSON: a demonstration in words.
WITHOUT_RESULTS = {"demo"}


def write_sources(folder, model=FREE, sources=SOURCES) -> list[str]:
    paths = []
    for k, data in enumerate(sources):
        path = folder / f"s{k}.json"
        path.write_text(json.dumps({**data, **({"model": model} if model is not None else {})}), encoding="utf-8")
        paths.append(str(path))
    return paths


def commands() -> dict[str, argparse.ArgumentParser]:
    """Every command of ``belief`` (the plugins' included) and its parser."""
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def run(capsys, *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def lines(text: str) -> list[str]:
    return text.splitlines()


# -- -q and -v ------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(commands()))
def test_every_command_takes_quiet_and_verbose(name):
    options = commands()[name]._option_string_actions
    assert {"-q", "--quiet", "-v", "--verbose"} <= set(options)


def test_quiet_and_verbose_go_before_or_after_the_command(tmp_path):
    a, b = write_sources(tmp_path)
    parser = build_parser()
    plain = parser.parse_args(["combine", "--rule", "pcr6", a, b])
    assert (plain.quiet, plain.verbose) == (False, 0)
    assert parser.parse_args(["-q", "combine", "--rule", "pcr6", a, b]).quiet is True
    assert parser.parse_args(["combine", "--rule", "pcr6", a, b, "--quiet"]).quiet is True
    assert parser.parse_args(["-v", "combine", "--rule", "pcr6", a, b]).verbose == 1
    assert parser.parse_args(["combine", "-vv", "--rule", "pcr6", a, b]).verbose == 2


def test_quiet_and_verbose_together_is_a_command_line_error(tmp_path, capsys):
    a, b = write_sources(tmp_path)
    status, out, err = run(capsys, "-q", "combine", "--rule", "pcr6", a, b, "-v")
    assert status == 2 and out == ""
    assert len(lines(err)) == 1 and "not both" in err and "Traceback" not in err


def test_an_error_is_still_one_line_when_quiet(tmp_path, capsys):
    status, out, err = run(capsys, "-q", "measures", str(tmp_path / "missing.json"))
    assert status == 1 and out == ""
    assert len(lines(err)) == 1 and err.startswith("belief: error:")
    status, _, err = run(capsys, "combine", "--rule", "pcr6", str(tmp_path / "missing.json"),
                         str(tmp_path / "missing.json"), "-v")
    assert status == 1 and len(lines(err)) == 1 and err.startswith("belief: error:")


def test_verbose_adds_details_on_standard_error_and_leaves_the_results_alone(tmp_path, capsys):
    a, b = write_sources(tmp_path, SHAFER)
    _, plain, plain_err = run(capsys, "combine", "--rule", "pcr6", a, b, "--json")
    status, out, err = run(capsys, "combine", "--rule", "pcr6", a, b, "--json", "-v")
    assert status == 0 and out == plain and plain_err == ""
    assert json.loads(out)["mass"]
    said = lines(err)
    assert all(line.startswith("belief combine: ") for line in said)
    assert any(a in line and "3 focal elements" in line and "Shafer's model" in line for line in said)
    assert any(line.startswith("belief combine: rule pcr6:") for line in said)
    assert any("fusion model: Shafer's model" in line for line in said)
    assert any("representation:" in line for line in said)
    assert any("limits in effect:" in line and "MAX_TUPLES = 4,000,000" in line for line in said)
    assert said[-1].startswith("belief combine: finished in ") and said[-1].endswith(" s")
    status, out, err = run(capsys, "measures", a, "--json", "-v", "--max-table-entries", "1e6")
    assert status == 0 and json.loads(out)
    assert any("MAX_TABLE_ENTRIES = 1,000,000" in line for line in lines(err))


# -- --json ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(set(commands()) - WITHOUT_RESULTS))
def test_every_command_that_prints_results_has_json(name):
    assert "--json" in commands()[name]._option_string_actions


def test_plot_json_names_the_picture(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    a, _ = write_sources(tmp_path, SHAFER)
    target = tmp_path / "fig.svg"
    status, out, err = run(capsys, "plot", a, "--out", str(target), "--json")
    assert status == 0 and err == ""
    assert json.loads(out) == {"file": str(target), "format": "svg"} and target.stat().st_size > 0


# -- combine under a model with no empty intersection ------------------------------------------------------------
def conjunctive(paths) -> dict:
    from belief.rules import combine

    sources = [MassFunction.from_dict(json.loads(open(p, encoding="utf-8").read())) for p in paths]
    return combine(*sources, rule="conjunctive").to_mapping()


@pytest.mark.parametrize("rule", sorted(CONJUNCTIVE_WITHOUT_CONFLICT))
def test_a_rule_under_the_free_model_says_it_gives_the_conjunctive_result(tmp_path, capsys, rule):
    paths = write_sources(tmp_path, FREE)
    status, out, err = run(capsys, "combine", "--rule", rule, *paths, "--json")
    assert status == 0
    result = MassFunction.from_dict(json.loads(out)).to_mapping()
    expected = conjunctive(paths)
    assert set(result) == set(expected) and all(result[k] == pytest.approx(expected[k], abs=1e-12) for k in result)
    [note] = lines(err)
    assert note.startswith("belief combine: ") and "no empty intersection" in note
    assert f"{rule} has no conflict" in note and "conjunctive" in note
    assert "--model shafer" in note and '"model"' in note
    status, quiet_out, err = run(capsys, "combine", "--rule", rule, *paths, "--json", "-q")
    assert status == 0 and err == "" and quiet_out == out


def test_the_note_follows_the_model_used_not_its_name(tmp_path, capsys):
    paths = write_sources(tmp_path, FREE)
    # A hybrid model without constraints is the free model; one constraint makes a&b empty.
    for model, noted in (({"type": "hybrid", "empty": []}, True), ({"type": "hybrid", "empty": ["a&b"]}, False),
                         (SHAFER, False)):
        (tmp_path / "model.json").write_text(json.dumps(model), encoding="utf-8")
        status, _, err = run(capsys, "combine", "--rule", "pcr6", *paths, "--model", str(tmp_path / "model.json"))
        assert status == 0 and ("no empty intersection" in err) is noted, model
    status, _, err = run(capsys, "combine", "--rule", "pcr6", *write_sources(tmp_path, SHAFER))
    assert status == 0 and err == ""
    # Whatever the default model of a BBA file without one, the note says what that model is.
    bare = write_sources(tmp_path, None)
    free = not MassFunction.from_dict(SOURCES[0]).model.constrained
    status, _, err = run(capsys, "combine", "--rule", "dempster", *bare)
    assert status == 0 and ("no empty intersection" in err) is free


@pytest.mark.parametrize("rule", ["conjunctive", "r_rule", "disjunctive", "average", "murphy"])
def test_rules_that_are_not_the_conjunctive_one_by_lack_of_conflict_get_no_note(tmp_path, capsys, rule):
    status, _, err = run(capsys, "combine", "--rule", rule, *write_sources(tmp_path, FREE))
    assert status == 0 and err == ""


def test_the_list_of_rules_that_need_conflict_is_of_registered_rules():
    from belief.rules import RULES

    assert CONJUNCTIVE_WITHOUT_CONFLICT <= set(RULES)
    assert not {"conjunctive", "r_rule", "disjunctive", "average", "murphy"} & CONJUNCTIVE_WITHOUT_CONFLICT


def test_model_names_shafer_and_free(tmp_path, capsys):
    paths = write_sources(tmp_path, FREE)
    status, out, err = run(capsys, "combine", "--rule", "pcr6", *paths, "--model", "shafer", "--json")
    assert status == 0 and err == ""
    data = json.loads(out)
    assert data["model"] == SHAFER and "a&b" not in data["mass"]
    status, out, _ = run(capsys, "combine", "--rule", "conjunctive", *paths, "--model", "free", "--json")
    assert status == 0 and json.loads(out)["mass"] == pytest.approx(conjunctive(paths))
    status, out, _ = run(capsys, "lattice", "--frame", "a,b", "--model", "shafer", "--count")
    assert (status, out) == (0, "4\n")
    status, out, _ = run(capsys, "lattice", "--frame", "a,b", "--model", "free", "--count")
    assert (status, out) == (0, "5\n")
