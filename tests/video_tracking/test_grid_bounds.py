"""``belief experiment``: a grid is counted, typed and bounded before any work, and writes only whole files in --out."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from belief.cli import main
from belief_tracking import experiment as experiment_module
from belief_tracking import grid
from belief_tracking.errors import TrackingError
from belief_tracking.executors import MAX_ERROR_CHARS, describe_error
from belief_tracking.experiment import (
    Cell,
    ExperimentError,
    MethodSpec,
    SequenceSpec,
    experiment_from_mapping,
    load_experiment,
)
from belief_tracking.grid import plan_experiment, run_experiment

#: One run of three frames: about a second.
TINY = {"seeds": [0], "tracker": {"particles": 5},
        "sequences": [{"name": "crossing", "scene": "crossing", "frames": 3}]}
TINY_TOML = '[tracker]\nparticles = 5\n[[sequences]]\nname = "crossing"\nscene = "crossing"\nframes = 3\n'


def tiny(**changes):
    mapping = json.loads(json.dumps(TINY))
    mapping.update(changes)
    return mapping


def one_line_error(capsys, argv) -> str:
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert status == 1
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    return lines[0]


# -- counted before expanded -----------------------------------------------------------------------
def test_a_million_run_grid_is_refused_before_any_method_or_sequence_is_made(monkeypatch):
    made = []
    monkeypatch.setattr(experiment_module.MethodSpec, "from_mapping",
                        classmethod(lambda cls, *a: made.append(a) or cls(a[0], ())))
    monkeypatch.setattr(experiment_module, "_sequence", lambda *a: made.append(a))
    mapping = {"seeds": 10_000, "sequences": ["crossing"] * 10,
               "grid": {"rules": ["r_rule", "dsmc", "pcr5", "pcr6", "dempster"], "fusions": ["belief", "sum"],
                        "cues": [["colour"], ["colour", "location"]]}}
    with pytest.raises(ExperimentError, match=r"10 sequences x 12 methods x 10000 seeds = 1200000 runs.*MAX_RUNS"
                                              r".*--max-runs N"):
        experiment_from_mapping(mapping)
    assert made == []


def test_repeated_names_in_a_grid_list_are_refused_before_the_crossing():
    with pytest.raises(ExperimentError, match=r"\[grid\] rules must have distinct names; repeated: r_rule"):
        experiment_from_mapping(tiny(grid={"rules": ["r_rule"] * 1000, "cues": ["colour"] * 1000}))


def test_more_methods_than_the_limit_are_refused_and_the_limit_can_be_raised(monkeypatch):
    methods = [{"name": f"m{i}"} for i in range(4)]
    monkeypatch.setattr(experiment_module, "MAX_METHODS", 3)
    with pytest.raises(ExperimentError, match=r"4 methods, more than belief_tracking.experiment.MAX_METHODS = 3.*"
                                              r"--max-methods N"):
        experiment_from_mapping(tiny(methods=methods))
    grid.set_limits(max_methods=4)
    assert len(experiment_from_mapping(tiny(methods=methods)).methods) == 4


def test_set_limits_refuses_a_limit_that_is_not_a_positive_number():
    for bad in (0, -1, True, 1.5, "3"):
        with pytest.raises(ExperimentError, match="max_runs must be a positive integer"):
            grid.set_limits(max_runs=bad)
    with pytest.raises(ExperimentError, match="max_run_seconds must be a positive number"):
        grid.set_limits(max_run_seconds=float("nan"))


def test_the_keys_of_a_large_grid_are_those_of_the_whole_record():
    # The key is assembled from pieces computed once per method and sequence; it must stay the
    # digest of the complete record, so that runs saved before are still found.
    import hashlib
    from dataclasses import asdict

    from belief import __version__

    experiment = experiment_from_mapping({
        "seeds": 2, "tracker": {"particles": 7, "motion": {"sigma_pos": 2.0}},
        "sequences": [{"name": "a b", "scene": "crossing", "frames": 3},
                      {"name": "enter", "scene": "entering_leaving", "init": "automatic"}],
        "grid": {"rules": ["r_rule", "dsmc"], "fusions": ["belief", "sum"]}})
    for cell in experiment.cells():
        record = {"format": experiment_module.CELL_FORMAT, "sequence": cell.sequence.record(),
                  "settings": cell.settings(), "config": asdict(cell.config()), "version": __version__,
                  "seed": cell.seed}
        digest = hashlib.sha256(json.dumps(record, sort_keys=True, default=str).encode()).hexdigest()[:12]
        assert cell.key.endswith(f"__{digest}")
    assert len({cell.key for cell in experiment.cells()}) == 12


# -- names -------------------------------------------------------------------------------------------
def test_a_400_character_sequence_name_is_one_line_before_any_work(tmp_path, capsys):
    config = tmp_path / "grid.toml"
    config.write_text(TINY_TOML.replace('name = "crossing"', f'name = "{"a" * 400}"'))
    out = tmp_path / "out"
    error = one_line_error(capsys, ["experiment", config, "--out", out, "--workers", "1", "--no-progress"])
    assert "name has 400 characters" in error and "MAX_NAME_CHARS = 200" in error
    assert not out.exists()


@pytest.mark.parametrize("name, message", [
    ("a\0b", "control character '\\x00'"),
    ("two\nlines", "control character '\\n'"),
    ("   ", "must be non-empty text"),
])
def test_a_name_with_a_control_character_or_no_text_is_refused(name, message):
    with pytest.raises(ExperimentError, match="name") as info:
        experiment_from_mapping(tiny(sequences=[{"name": name, "scene": "crossing", "frames": 3}]))
    assert message in str(info.value)
    with pytest.raises(ExperimentError) as info:
        experiment_from_mapping(tiny(methods=[{"name": name}]))
    assert message in str(info.value)
    with pytest.raises(ExperimentError) as info:
        experiment_from_mapping(tiny(name=name))
    assert message in str(info.value)


@pytest.mark.parametrize("name", ["..", "../../x", ".hidden", "/", "a/../../b", "é" * 200])
def test_a_saved_run_s_file_name_stays_a_plain_visible_name(name):
    cell = Cell(SequenceSpec(name, scene="crossing", frames=3), MethodSpec(name), 0)
    assert "/" not in cell.key and not cell.key.startswith(".") and len(cell.key) + len(".json") < 255


# -- types and ranges --------------------------------------------------------------------------------
@pytest.mark.parametrize("entry, message", [
    ({"scene": 5}, "[[sequences]] entry 1: scene must be text, got int 5"),
    ({"scene": ["crossing"]}, "[[sequences]] entry 1: scene must be text, got list"),
    ({"scene": "crossing", "frames": True}, "[[sequences]] entry 1: frames must be an integer, got bool True"),
    ({"scene": "crossing", "frames": 2.0}, "frames must be an integer, got float 2.0"),
    ({"scene": "crossing", "frames": "3"}, "frames must be an integer, got str '3'"),
    ({"scene": "crossing", "frames": 10**12}, "frames = 1000000000000 is more than the 100 frames of scene"),
    ({"scene": "crossing", "scene_seed": 2**64}, "scene_seed = 18446744073709551616 is more than the largest"),
    ({"scene": "crossing", "init": 1}, "init must be text, got int 1"),
    ({"scene": "crossing", "bogus": 1}, "[[sequences]] entry 1: unknown key 'bogus'"),
    ({"video": "a\0b", "gt": "gt.txt"}, "video must be the path of a file"),
    ({"video": "v" * 5000, "gt": "gt.txt"}, "File name too long"),
    ({"video": "/dev/null", "gt": "/dev/null"}, "it is a device, not a regular file"),
])
def test_every_sequence_key_is_typed_and_named_with_its_table(entry, message, tmp_path):
    with pytest.raises(ExperimentError) as info:
        experiment_from_mapping(tiny(sequences=[entry]), base_dir=tmp_path)
    assert message in str(info.value)
    assert "\n" not in str(info.value) and len(str(info.value)) < 600


@pytest.mark.parametrize("changes, message", [
    ({"seeds": [2**64]}, "a seed = 18446744073709551616 is more than the largest allowed"),
    ({"seeds": []}, "seeds is an empty list"),
    ({"seeds": [0, "1"]}, "a seed must be an integer >= 0, got str '1'"),
    ({"tracker": {"motion": {"bogus": 1}}}, "[tracker]: motion: unknown key 'bogus'"),
    ({"tracker": "x"}, "[tracker] must be a table of TrackerConfig settings, got str 'x'"),
    ({"grid": {"rules": [5]}}, "[grid] rules must be a list of names, got int 5"),
    ({"grid": {"fusions": [["sum"]]}}, "[grid] fusions must be a list of names, got list"),
    ({"methods": [5]}, "[[methods]] entry 1 must be a table, got int 5"),
    ({"name": ""}, "the experiment's name must be non-empty text"),
])
def test_every_top_level_value_is_typed_and_named_with_its_table(changes, message):
    with pytest.raises(ExperimentError) as info:
        experiment_from_mapping(tiny(**changes))
    assert message in str(info.value)


def test_a_deeply_nested_experiment_is_one_line(tmp_path, capsys):
    config = tmp_path / "deep.toml"
    config.write_text("seeds = " + "[" * 50_000 + "]" * 50_000 + "\n" + TINY_TOML)
    error = one_line_error(capsys, ["experiment", config, "--dry-run"])
    assert "nest deeper than the parser can follow" in error
    config.write_text("tracker = " + "{a = " * 300 + "1" + "}" * 300 + "\n" + TINY_TOML.replace("[tracker]\n", ""))
    assert "nest" in one_line_error(capsys, ["experiment", config, "--dry-run"])
    nested: dict = {}
    deep = nested
    for _ in range(5000):
        deep["a"] = {}
        deep = deep["a"]
    with pytest.raises(ExperimentError, match="MAX_DEPTH = 8"):
        experiment_from_mapping(tiny(tracker=nested))


def test_an_experiment_file_must_be_a_regular_file_of_bounded_size(tmp_path, monkeypatch):
    with pytest.raises(ExperimentError, match="not a regular file"):
        load_experiment(os.devnull)
    with pytest.raises(ExperimentError, match="it is a directory"):
        load_experiment(tmp_path)
    config = tmp_path / "grid.toml"
    config.write_text(TINY_TOML)
    monkeypatch.setattr(experiment_module, "MAX_CONFIG_BYTES", 20)
    with pytest.raises(ExperimentError, match=r"bytes, more than .*MAX_CONFIG_BYTES = 20"):
        load_experiment(config)
    with pytest.raises(ExperimentError, match="File name too long"):
        load_experiment(tmp_path / ("x" * 5000))


# -- the estimate ------------------------------------------------------------------------------------
def test_the_plan_counts_the_runs_and_estimates_them():
    plan = plan_experiment(experiment_from_mapping(tiny(seeds=4)), workers=2)
    assert (plan.runs, plan.workers) == (4, 2)
    assert 0 < plan.run_seconds < plan.total_seconds and plan.wall_seconds == pytest.approx(plan.total_seconds / 2)
    assert 100 << 20 < plan.run_bytes < 1 << 30 and plan.peak_bytes == 2 * plan.run_bytes
    assert plan.describe().startswith("estimated ") and "on 2 workers" in plan.describe()


def test_a_run_estimated_beyond_the_limits_is_refused_before_anything_is_written(tmp_path, monkeypatch):
    out = tmp_path / "out"
    monkeypatch.setattr(grid, "MAX_RUN_SECONDS", 0.5)
    with pytest.raises(ExperimentError, match=r"a run of crossing/default is estimated at .*MAX_RUN_SECONDS = 0.5.*"
                                              r"--max-run-seconds N"):
        run_experiment(experiment_from_mapping(TINY), out, workers=1, progress=False)
    monkeypatch.setattr(grid, "MAX_RUN_SECONDS", 600.0)
    monkeypatch.setattr(grid, "MAX_RUN_BYTES", 1 << 20)
    with pytest.raises(ExperimentError, match=r"MB of memory .*MAX_RUN_BYTES = 1,048,576.*--max-run-bytes N"):
        run_experiment(experiment_from_mapping(TINY), out, workers=1, progress=False)
    assert not out.exists()


# -- outputs -----------------------------------------------------------------------------------------
def test_files_are_never_written_through_a_symlink_or_outside_out(tmp_path):
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (elsewhere / "mine.csv").write_text("my own\n")
    # A staged name that an older writer used, and a final name, both pointing outside --out.
    (out / ".results.csv.partial").symlink_to(elsewhere / "planted.csv")
    (out / "summary.csv").symlink_to(elsewhere / "mine.csv")
    run_experiment(experiment_from_mapping(TINY), out, workers=1, progress=False)
    assert sorted(p.name for p in elsewhere.iterdir()) == ["mine.csv"]
    assert (elsewhere / "mine.csv").read_text() == "my own\n"
    assert not (out / "summary.csv").is_symlink() and (out / "summary.csv").read_text().startswith("sequence,")
    assert [p.name for p in out.iterdir() if p.name.endswith(".partial") and not p.is_symlink()] == []


def test_a_symlinked_cells_folder_or_a_folder_where_a_table_goes_is_refused_before_any_run(tmp_path):
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / "cells").symlink_to(elsewhere, target_is_directory=True)
    with pytest.raises(ExperimentError, match="cells is a symlink or not a folder"):
        run_experiment(experiment_from_mapping(TINY), out, workers=1, progress=False)
    assert list(elsewhere.iterdir()) == []
    (out / "cells").unlink()
    (out / "results.csv").mkdir()
    with pytest.raises(ExperimentError, match="results.csv is a folder, where the experiment writes its file"):
        run_experiment(experiment_from_mapping(TINY), out, workers=1, progress=False)
    assert not (out / "cells").exists() and not (out / "experiment.json").exists()


def test_an_out_that_is_a_file_or_holds_nul_is_one_line(tmp_path, capsys):
    config = tmp_path / "grid.toml"
    config.write_text(TINY_TOML)
    mine = tmp_path / "mine"
    mine.write_text("mine")
    assert "exists and is not a folder" in one_line_error(capsys, ["experiment", config, "--out", mine])
    assert mine.read_text() == "mine"
    with pytest.raises(ExperimentError, match="NUL"):
        grid.check_output("a\0b")
    with pytest.raises(ExperimentError):
        run_experiment(experiment_from_mapping(TINY), mine / "sub", workers=1, progress=False)


# -- resuming ----------------------------------------------------------------------------------------
def test_damaged_saved_runs_are_run_again_never_read_as_results(tmp_path):
    out = tmp_path / "out"
    experiment = experiment_from_mapping(TINY)
    first = run_experiment(experiment, out, workers=1, progress=False)
    key = experiment.cells()[0].key
    path = out / "cells" / f"{key}.json"
    good = json.loads(path.read_text())
    damaged = [
        {"format": good["format"], "key": key},                                    # no row: KeyError once
        {**good, "errors": {"1": [[1, "far"]]}},                                   # a text error
        {**good, "row": {**good["row"], "sequence": "another"}},                   # another sequence's row
        {**good, "row": {**good["row"], "mota": "high"}},
    ]
    for record in damaged:
        path.write_text(json.dumps(record))
        again = run_experiment(experiment, out, workers=1, progress=False)
        assert (again.computed, again.reused) == (1, 0)
        assert again.results[0]["mota"] == first.results[0]["mota"]
    path.write_text("[" * 100_000 + "]" * 100_000)                                 # RecursionError once
    assert run_experiment(experiment, out, workers=1, progress=False).computed == 1
    path.unlink()
    path.symlink_to(tmp_path / "elsewhere.json")
    (tmp_path / "elsewhere.json").write_text(json.dumps(good))
    assert run_experiment(experiment, out, workers=1, progress=False).computed == 1
    assert not path.is_symlink() and (tmp_path / "elsewhere.json").read_text() == json.dumps(good)
    assert run_experiment(experiment, out, workers=1, progress=False).reused == 1


def test_a_failed_run_s_error_is_one_bounded_line():
    text = describe_error(TrackingError("first\nsecond " + "x" * 10_000))
    assert "\n" not in text and len(text) == MAX_ERROR_CHARS and text.startswith("TrackingError: first second")
