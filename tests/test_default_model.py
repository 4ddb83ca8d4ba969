"""Shafer's model is what a frame without a model means, in Python and in BBA files."""

from __future__ import annotations

import json

import pytest

from belief import Frame, MassBatch, MassFunction, Model, combine
from belief.cli import main
from belief.errors import InvalidMassError

FRAME = ["a", "b", "c"]


def test_zadehs_example_without_a_model_is_dempsters_answer():
    first = MassFunction({"a": 0.9, "c": 0.1}, frame=FRAME)
    second = MassFunction({"b": 0.9, "c": 0.1}, frame=FRAME)
    assert first.model == Model.shafer(Frame(FRAME))
    assert combine(first, second, rule="dempster").to_mapping() == {"c": 1.0}


def test_the_free_model_is_asked_for_by_name():
    first = MassFunction({"a": 0.9, "c": 0.1}, frame=FRAME, model="free")
    second = MassFunction({"b": 0.9, "c": 0.1}, frame=FRAME, model="free")
    fused = combine(first, second, rule="dempster").to_mapping()
    assert fused == pytest.approx({"a&b": 0.81, "a&c": 0.09, "b&c": 0.09, "c": 0.01}, abs=1e-12)
    assert repr(first) == "MassFunction({'a': 0.9, 'c': 0.1}, frame=['a', 'b', 'c'], model='free')"
    assert repr(MassFunction({"a": 1.0}, frame=FRAME)) == "MassFunction({'a': 1.0}, frame=['a', 'b', 'c'])"


def test_every_constructor_without_a_model_uses_shafers_model():
    shafer = Model.shafer(Frame(FRAME))
    assert MassFunction.vacuous(frame=FRAME).model == shafer
    assert MassFunction.categorical("a|b", frame=FRAME).model == shafer
    assert MassBatch(["a", "b"], [[0.5, 0.5]], frame=FRAME).model == shafer
    assert MassBatch.bayesian([[0.2, 0.3, 0.5]], frame=FRAME).model == shafer
    with pytest.raises(InvalidMassError, match="empty under the shafer model"):
        MassFunction({"a&b": 1.0}, frame=FRAME)


def test_a_bba_file_without_a_model_is_read_under_shafers_model(tmp_path, capsys):
    paths = []
    for k, masses in enumerate(({"a": 0.9, "c": 0.1}, {"b": 0.9, "c": 0.1})):
        path = tmp_path / f"s{k}.json"
        path.write_text(json.dumps({"frame": FRAME, "mass": masses}))
        paths.append(str(path))
    assert main(["combine", "--rule", "dempster", *paths, "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["model"] == {"type": "shafer"} and result["mass"] == {"c": 1.0}
    assert MassFunction.from_dict({"frame": FRAME, "mass": {"a": 1.0}}).model == Model.shafer(Frame(FRAME))
    free = MassFunction.from_dict({"frame": FRAME, "model": {"type": "free"}, "mass": {"a&b": 1.0}})
    assert free.model == Model.free(Frame(FRAME))
