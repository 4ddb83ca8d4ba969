"""``belief experiment``: grids of seeded runs, locally and on Dask, resumable, with W (36) tables."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from belief.cli import main
from belief_tracking import grid
from belief_tracking.errors import TrackingError
from belief_tracking.experiment import (
    Cell,
    ExperimentError,
    MethodSpec,
    SequenceSpec,
    experiment_from_mapping,
    load_experiment,
)
from belief_tracking.grid import run_experiment
from belief_tracking.runs import _centre_errors, run_cell
from belief_tracking.tables import RESULT_COLUMNS, RMS_COLUMNS, TIMING_COLUMNS, rms_per_frame

#: 2 rules x 2 seeds x 1 synthetic scene, kept short.
SMALL = {
    "name": "small",
    "seeds": [0, 1],
    "tracker": {"particles": 12},
    "sequences": [{"name": "crossing", "scene": "crossing", "frames": 20}],
    "grid": {"rules": ["r_rule", "dsmc"]},
}

SMALL_TOML = """\
name = "small"
seeds = [0, 1]

[tracker]
particles = 12

[[sequences]]
name = "crossing"
scene = "crossing"
frames = 20

[grid]
rules = ["r_rule", "dsmc"]
"""


def read_rows(path: Path) -> list[dict[str, str]]:
    with open(path, encoding="utf-8", newline="") as handle:
        return list(csv.DictReader(handle))


def scores_only(path: Path) -> list[dict[str, str]]:
    """``results.csv`` without its timing columns (the only ones that vary between runs)."""
    return [{k: v for k, v in row.items() if k not in TIMING_COLUMNS} for row in read_rows(path)]


@pytest.fixture(scope="module")
def local_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("local")
    result = run_experiment(experiment_from_mapping(SMALL), out, workers=2, progress=False)
    return out, result


def test_the_small_grid_writes_one_row_per_run(local_run):
    out, result = local_run
    rows = read_rows(out / "results.csv")
    assert list(rows[0]) == list(RESULT_COLUMNS)
    assert [(r["method"], r["seed"]) for r in rows] == [("r_rule", "0"), ("r_rule", "1"), ("dsmc", "0"),
                                                        ("dsmc", "1")]
    assert {r["rule"] for r in rows} == {"r_rule", "dsmc"}
    assert {r["frames"] for r in rows} == {"20"}
    for row in rows:
        assert -1e9 < float(row["mota"]) <= 1.0
        assert 0.0 <= float(row["idf1"]) <= 1.0
        assert float(row["seconds"]) > 0 and float(row["tracking_fps"]) > 0
    # the two seeds are different runs, not copies
    assert rows[0]["mean_centre_error"] != rows[1]["mean_centre_error"]
    assert result.computed == 4 and result.reused == 0
    assert len(list((out / "cells").glob("*.json"))) == 4


def test_identical_seeds_give_identical_tables(local_run, tmp_path):
    out, _ = local_run
    again = tmp_path / "again"
    run_experiment(experiment_from_mapping(SMALL), again, workers=1, progress=False)
    assert scores_only(again / "results.csv") == scores_only(out / "results.csv")
    assert (again / "rms.csv").read_bytes() == (out / "rms.csv").read_bytes()


def test_a_dask_cluster_gives_the_same_tables(local_run, tmp_path):
    # A scheduler reached by its address: the runs go through the Dask client's executor.  The
    # cluster's workers are threads of this process, which keeps the test quick.
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    out, _ = local_run
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        result = run_experiment(experiment_from_mapping(SMALL), tmp_path / "dask", scheduler=cluster.scheduler_address,
                                progress=False)
    assert result.computed == 4
    assert scores_only(tmp_path / "dask" / "results.csv") == scores_only(out / "results.csv")
    assert (tmp_path / "dask" / "rms.csv").read_bytes() == (out / "rms.csv").read_bytes()


def test_the_cli_runs_a_grid_and_prints_its_summary(local_run, tmp_path, capsys):
    out, _ = local_run
    config = tmp_path / "small.toml"
    config.write_text(SMALL_TOML, encoding="utf-8")
    assert main(["experiment", str(config), "--out", str(tmp_path / "cli"), "--workers", "1", "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "1 sequences x 2 methods x 2 seeds = 4 runs" in printed
    assert "ran 4 runs, reused 0" in printed and "crossing" in printed and "MOTA" in printed
    assert scores_only(tmp_path / "cli" / "results.csv") == scores_only(out / "results.csv")


def test_an_interrupted_grid_resumes_without_redoing_finished_runs(local_run, tmp_path, monkeypatch):
    out, _ = local_run
    experiment = experiment_from_mapping(SMALL)
    calls = []
    real = grid.run_cell

    def interrupted(cell):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(cell.label)
        return real(cell)

    monkeypatch.setattr(grid, "run_cell", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_experiment(experiment, tmp_path, workers=1, progress=False)
    assert len(list((tmp_path / "cells").glob("*.json"))) == 2
    assert not list((tmp_path / "cells").glob(".*partial"))

    monkeypatch.setattr(grid, "run_cell", lambda cell: calls.append(cell.label) or real(cell))
    result = run_experiment(experiment, tmp_path, workers=1, progress=False)
    assert result.computed == 2 and result.reused == 2
    assert len(calls) == 4 and len(set(calls)) == 4       # every run ran exactly once in all
    assert scores_only(tmp_path / "results.csv") == scores_only(out / "results.csv")


def test_a_damaged_or_foreign_cell_file_is_run_again(local_run, tmp_path):
    out, _ = local_run
    experiment = experiment_from_mapping(SMALL)
    first = run_experiment(experiment, tmp_path, workers=1, progress=False)
    assert first.computed == 4
    files = sorted((tmp_path / "cells").glob("*.json"))
    files[0].write_text('{"format": 1, "key": "trunc', encoding="utf-8")
    record = json.loads(files[1].read_text(encoding="utf-8"))
    record["key"] = "another grid"
    files[1].write_text(json.dumps(record), encoding="utf-8")
    second = run_experiment(experiment, tmp_path, workers=1, progress=False)
    assert (second.computed, second.reused) == (2, 2)
    assert scores_only(tmp_path / "results.csv") == scores_only(out / "results.csv")
    assert run_experiment(experiment, tmp_path, workers=1, progress=False, fresh=True).computed == 4


def test_a_changed_setting_is_a_new_run(tmp_path):
    run_experiment(experiment_from_mapping(SMALL), tmp_path, workers=1, progress=False)
    changed = {**SMALL, "tracker": {"particles": 20}}
    result = run_experiment(experiment_from_mapping(changed), tmp_path, workers=1, progress=False)
    assert result.computed == 4 and result.reused == 0
    assert {row["particles"] for row in read_rows(tmp_path / "results.csv")} == {"20"}


def test_failed_runs_are_named_and_the_others_kept(tmp_path, monkeypatch):
    real = grid.run_cell

    def fails_for_dsmc(cell):
        if cell.method.name == "dsmc" and cell.seed == 1:
            raise ValueError("synthetic failure")
        return real(cell)

    monkeypatch.setattr(grid, "run_cell", fails_for_dsmc)
    with pytest.raises(ExperimentError, match=r"1 of 4 runs failed \(first: crossing/dsmc/seed 1: "
                                              r"ValueError: synthetic failure\)"):
        run_experiment(experiment_from_mapping(SMALL), tmp_path, workers=1, progress=False)
    assert len(list((tmp_path / "cells").glob("*.json"))) == 3
    assert len(read_rows(tmp_path / "results.csv")) == 3
    monkeypatch.setattr(grid, "run_cell", real)
    assert run_experiment(experiment_from_mapping(SMALL), tmp_path, workers=1, progress=False).computed == 1


def test_rms_table_is_w36_over_the_seeds(local_run):
    """W (36): RMS_t = sqrt(mean over the runs of the squared centre error at t)."""
    out, result = local_run
    rows = read_rows(out / "rms.csv")
    assert list(rows[0]) == list(RMS_COLUMNS)
    experiment = experiment_from_mapping(SMALL)
    # recompute target 1, frame 20, method dsmc from the per-run centre errors
    errors = []
    for cell in experiment.cells():
        if cell.method.name == "dsmc":
            pairs = dict((int(f), e) for f, e in result.cells[cell.key]["errors"]["1"])
            errors.append(pairs[20])
    row = next(r for r in rows if r["method"] == "dsmc" and r["target"] == "1" and r["frame"] == "20")
    assert int(row["runs"]) == 2
    assert float(row["rms_error"]) == pytest.approx(math.sqrt((errors[0] ** 2 + errors[1] ** 2) / 2), rel=1e-12)
    # one row per method, target and frame where a run has an estimate (of 2 targets x 20 frames: a
    # GT-born track that nothing supports for a few frames is not output there)
    estimated = {(cell.method.name, target, int(frame)) for cell in experiment.cells()
                 for target, pairs in result.cells[cell.key]["errors"].items() for frame, _ in pairs}
    assert len(rows) == len(estimated) and 0.9 * 2 * 2 * 20 <= len(rows) <= 2 * 2 * 20
    assert all(int(row["runs"]) >= 1 for row in rows)


def test_summary_is_the_mean_over_the_seeds(local_run):
    out, _ = local_run
    results = read_rows(out / "results.csv")
    summary = read_rows(out / "summary.csv")
    assert [(r["sequence"], r["method"], r["runs"]) for r in summary] == [("crossing", "r_rule", "2"),
                                                                          ("crossing", "dsmc", "2")]
    for row in summary:
        own = [float(r["mota"]) for r in results if r["method"] == row["method"]]
        assert float(row["mota_mean"]) == pytest.approx(np.mean(own), abs=1e-12)
        assert float(row["mota_std"]) == pytest.approx(np.std(own, ddof=1), abs=1e-12)


def test_centre_errors_by_id_are_hand_checkable():
    gt = np.array([[1, 1, 0, 0, 10, 20, 1, -1, -1, -1],
                   [2, 1, 2, 0, 10, 20, 1, -1, -1, -1],
                   [2, 2, 50, 50, 10, 20, 0, -1, -1, -1]])       # flag 0: not scored
    tracks = np.array([[1, 1, 3, 4, 10, 20, 1, -1, -1, -1],   # centre off by (3, 4): 5 px
                       [2, 1, 2, 0, 10, 20, 1, -1, -1, -1],
                       [2, 2, 50, 50, 10, 20, 1, -1, -1, -1]])
    assert _centre_errors(gt, tracks, by_id=True) == {1: [[1, 5.0], [2, 0.0]]}
    # automatic ids: pairs by IoU >= 0.5.  The (3, 4) shift leaves IoU = 7·16 / (2·200 − 112) = 0.39:
    # no pair in frame 1; a (0, 3) shift leaves 10·17 / (400 − 170) = 0.74: paired, 3 px.
    renamed = tracks.copy()
    renamed[:, 1] += 10
    assert _centre_errors(gt, renamed, by_id=False) == {1: [[2, 0.0]]}
    renamed[0, 2:4] = [0, 3]
    assert _centre_errors(gt, renamed, by_id=False) == {1: [[1, 3.0], [2, 0.0]]}


def test_grid_crosses_rules_only_with_the_belief_fusion():
    experiment = experiment_from_mapping({
        "sequences": ["crossing"],
        "grid": {"rules": ["r_rule", "pcr6"], "fusions": ["belief", "sum"], "cues": ["colour", "colour,location"]}})
    assert [m.name for m in experiment.methods] == [
        "r_rule/colour", "pcr6/colour", "sum/colour",
        "r_rule/colour+location", "pcr6/colour+location", "sum/colour+location"]
    assert experiment.cells()[2].config().fusion == "sum"
    assert experiment.cells()[2].config().cues == ("colour",)


def test_methods_take_any_tracker_setting_and_nested_tables():
    experiment = experiment_from_mapping({
        "seeds": 3,
        "tracker": {"particles": 30, "motion": {"sigma_pos": 2.0}},
        "sequences": [{"name": "walk", "scene": "scale_change"}],
        "methods": [{"name": "colour only", "cues": ["colour"]},
                    {"name": "stiff", "motion": {"sigma_vel": 0.1}, "adaptive_particles": True}]})
    assert experiment.seeds == (0, 1, 2)
    colour, stiff = experiment.cells()[0].config(), experiment.cells()[3].config()
    assert colour.cues == ("colour",) and colour.particles == 30 and colour.motion.sigma_pos == 2.0
    assert stiff.motion.sigma_pos == 2.0 and stiff.motion.sigma_vel == 0.1 and stiff.adaptive_particles


def test_a_cell_runs_without_writing_files(tmp_path, monkeypatch):
    # The cell consumes the tracker's frame results directly: no run() and no output folder.
    from belief_tracking import runner

    monkeypatch.setattr(runner, "run", lambda *a, **k: pytest.fail("run_cell must not go through run()"))
    monkeypatch.chdir(tmp_path)
    cell = experiment_from_mapping({**SMALL, "seeds": [0]}).cells()[0]
    record = run_cell(cell)
    assert list(tmp_path.iterdir()) == []
    # at most one row per target and frame (2 x 20), as many as the matched and the false tracks
    assert record["row"]["frames"] == 20 and 36 <= len(record["tracks"]) <= 40
    assert len(record["tracks"]) == record["row"]["matched_pairs"] + record["row"]["false_positives"]
    assert {len(curve) for curve in record["curves"]} == {6}
    assert all(curve[5] is None for curve in record["curves"])          # no similarity without its follow-up


def test_an_automatic_sequence_is_scored_by_iou_pairing():
    spec = SequenceSpec("enter", scene="entering_leaving", frames=40, init="automatic")
    cell = Cell(spec, MethodSpec("default"), 0, (("particles", 15),))
    assert cell.config().initiation is not None and cell.config().warm_up == 50
    record = run_cell(cell)
    assert record["row"]["frames"] == 40
    assert record["errors"], "the walkers that entered are paired with tracks"
    assert record["row"]["mota"] > 0


@pytest.mark.parametrize("mapping, message", [
    ({"sequences": ["crossing"], "colour": 1}, "unknown key 'colour'; known keys: name, seeds, tracker"),
    ({"sequences": ["nowhere"]}, "unknown scene 'nowhere'; known scenes: crossing"),
    ({"sequences": ["crossing"], "grid": {"rules": ["pcr7"]}}, "unknown rule 'pcr7'"),
    ({"sequences": ["crossing"], "grid": {"cues": [["colour", "sound"]]}}, "unknown cue 'sound'"),
    ({"sequences": ["crossing"], "tracker": {"particels": 3}}, "unknown key 'particels'"),
    ({"sequences": ["crossing"], "tracker": {"particles": 0}}, "particles must be an integer >= 1"),
    ({"sequences": ["crossing"], "tracker": {"motion": {"sigma": 1}}}, "motion: unknown key 'sigma'"),
    ({"sequences": ["crossing"], "seeds": [0, 0]}, "the seeds repeat a value"),
    ({"sequences": ["crossing"], "seeds": [-1]}, "a seed must be an integer >= 0"),
    ({"sequences": ["crossing"], "seeds": 0}, "seeds (a count) must be an integer >= 1"),
    ({"sequences": []}, "at least one [[sequences]]"),
    ({"sequences": ["crossing", "crossing"]}, "sequences must have distinct names; repeated: crossing"),
    ({"sequences": ["crossing"], "methods": [{"name": "a"}], "grid": {}}, "either [[methods]] or [grid]"),
    ({"sequences": ["crossing"], "methods": [{"rule": "dsmc"}]}, "every [[methods]] entry needs a name"),
    ({"sequences": [{"name": "v", "video": "missing.avi", "gt": "gt.txt"}]}, "cannot read video file"),
    ({"sequences": [{"name": "v", "scene": "crossing", "init": "magic"}]}, "init must be one of gt, automatic"),
])
def test_bad_configurations_name_the_problem(mapping, message, tmp_path):
    with pytest.raises(ExperimentError) as info:
        experiment_from_mapping(mapping, base_dir=tmp_path)
    assert message in str(info.value)


def test_a_recorded_video_is_resolved_against_the_data_folder(tmp_path, rendered_scene):
    from belief_tracking import scenes

    scene = rendered_scene(scenes.crossing())
    data = tmp_path / "data"
    data.mkdir()
    scenes.write_video(data / "crossing.avi", scene.frames[:20])
    scenes.write_gt(data / "gt.txt", scene.ground_truth[scene.ground_truth[:, 0] <= 20])
    config = tmp_path / "grid.toml"
    config.write_text('seeds = [0]\ntracker = { particles = 10 }\n'
                      '[[sequences]]\nname = "recorded"\nvideo = "crossing.avi"\ngt = "gt.txt"\n', encoding="utf-8")
    with pytest.raises(ExperimentError, match="grid.toml: sequence 'recorded': cannot read video file .*: no such file"):
        load_experiment(config)
    experiment = load_experiment(config, data_dir=data)
    assert experiment.name == "grid"
    assert Path(experiment.sequences[0].video) == (data / "crossing.avi").resolve()
    result = run_experiment(experiment, tmp_path / "out", workers=1, progress=False)
    assert result.results[0]["frames"] == 20 and result.results[0]["num_objects"] == 40


def write_gt_as_detections(path: Path, gt: np.ndarray) -> Path:
    """Every ground-truth box as a detection of score 1 (MOTChallenge det rows, 1-based corners)."""
    lines = [f"{int(r[0])},-1,{r[2]},{r[3]},{r[4]},{r[5]},1,-1,-1,-1" for r in gt]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def recorded_with_detections(tmp_path_factory, rendered_scene):
    """A 20-frame crossing written as a video, its ground truth and detections made from it."""
    from belief_tracking import scenes

    scene = rendered_scene(scenes.crossing())
    data = tmp_path_factory.mktemp("detections")
    gt = scene.ground_truth[scene.ground_truth[:, 0] <= 20]
    scenes.write_video(data / "crossing.avi", scene.frames[:20])
    scenes.write_gt(data / "gt.txt", gt)
    write_gt_as_detections(data / "det.txt", gt)
    return data


def test_a_sequence_with_detections_is_tracked_automatically_from_them(recorded_with_detections, tmp_path):
    data = recorded_with_detections
    config = tmp_path / "grid.toml"
    config.write_text('seeds = [0]\ntracker = { particles = 15 }\n'
                      '[[sequences]]\nname = "recorded"\nvideo = "crossing.avi"\ngt = "gt.txt"\n'
                      'detections = "det.txt"\ninit = "automatic"\n'
                      '[[methods]]\nname = "default"\n', encoding="utf-8")
    experiment = load_experiment(config, data_dir=data)
    sequence = experiment.sequences[0]
    assert Path(sequence.detections) == (data / "det.txt").resolve()
    assert len(sequence.load_detections()) == 40
    cell = experiment.cells()[0]
    assert cell.config().cues == ("colour", "location", "foreground")
    assert cell.config().initiation is not None and cell.config().warm_up == 50
    result = run_experiment(experiment, tmp_path / "out", workers=1, progress=False)
    row = result.results[0]
    assert row["frames"] == 20 and row["num_objects"] == 40
    assert row["cues"] == "colour+location+foreground"
    assert row["mota"] >= 0.9
    assert json.loads((tmp_path / "out" / "experiment.json").read_text())["sequences"][0]["detections"] \
        == sequence.detections


def test_detections_leave_the_cues_and_other_sequences_keys_alone(tmp_path):
    det = write_gt_as_detections(tmp_path / "det.txt", np.array([[1, 1, 10, 10, 10, 20, 1, -1, -1, -1]]))
    experiment = experiment_from_mapping({
        "seeds": [0],
        "sequences": [{"name": "crossing", "scene": "crossing"},
                      {"name": "with boxes", "scene": "crossing", "detections": "det.txt", "init": "automatic"}],
        "methods": [{"name": "colour", "cues": ["colour"]}, {"name": "both", "cues": ["detections", "colour"]},
                    {"name": "default"}]}, base_dir=tmp_path)
    plain, with_boxes = experiment.cells()[:3], experiment.cells()[3:]
    assert [c.config().cues for c in plain] == [("colour",), ("detections", "colour"),
                                                ("colour", "location", "foreground")]
    assert [c.config().cues for c in with_boxes] == [c.config().cues for c in plain]
    assert with_boxes[0].sequence.detections == str(det.resolve())
    # The key of a cell without detections is the one it had before sequences could have them.
    assert "detections" not in plain[0].sequence.record()
    assert experiment_from_mapping(SMALL).cells()[0].key == experiment_from_mapping(SMALL).cells()[0].key
    assert len({c.key for c in experiment.cells()}) == 6


def test_a_bad_detection_file_is_named(tmp_path):
    with pytest.raises(ExperimentError, match=r"sequence 'v': cannot read detections file .*nothing\.txt.*: no such file"):
        experiment_from_mapping({"sequences": [{"name": "v", "scene": "crossing", "detections": "nothing.txt"}]},
                                base_dir=tmp_path)
    missing = SequenceSpec("v", scene="crossing", frames=5, detections=str(tmp_path / "gone.txt"))
    with pytest.raises(TrackingError, match=r"gone\.txt") as info:
        run_cell(Cell(missing, MethodSpec("default"), 0, (("particles", 5),)))
    assert "\n" not in str(info.value)
    # a box after the scene's last frame (100) or wholly outside its 320 x 240 frames
    late = tmp_path / "late.txt"
    late.write_text("1,-1,10,10,10,20,0.9\n101,-1,10,10,10,20,0.9\n", encoding="utf-8")
    with pytest.raises(TrackingError, match=r"late\.txt, line 2"):
        SequenceSpec("v", scene="crossing", frames=5, detections=str(late)).load_detections()
    outside = tmp_path / "outside.txt"
    outside.write_text("1,-1,400,10,10,20,0.9\n", encoding="utf-8")
    with pytest.raises(TrackingError, match=r"outside\.txt, line 1"):
        SequenceSpec("v", scene="crossing", detections=str(outside)).load_detections()
    with pytest.raises(ExperimentError, match="detections must be the path of a detection file"):
        SequenceSpec("v", scene="crossing", detections=3)


def test_the_cli_reports_a_bad_file_in_one_line(tmp_path, capsys):
    config = tmp_path / "bad.toml"
    config.write_text('seeds = [0]\n[[sequences]]\nscene = "crossing"\n[grid]\nrules = ["pcr7"]\n', encoding="utf-8")
    assert main(["experiment", str(config), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("belief: error: ") and "unknown rule 'pcr7'" in err
    assert main(["experiment", str(tmp_path / "missing.toml")]) == 1
    err = capsys.readouterr().err
    assert "cannot read experiment file" in err and "no such file" in err
    (tmp_path / "broken.toml").write_text("seeds = [0\n", encoding="utf-8")
    assert main(["experiment", str(tmp_path / "broken.toml")]) == 1
    assert "not valid TOML" in capsys.readouterr().err


def test_dry_run_lists_the_runs(tmp_path, capsys):
    config = tmp_path / "small.toml"
    config.write_text(SMALL_TOML, encoding="utf-8")
    assert main(["experiment", str(config), "--dry-run"]) == 0
    printed = capsys.readouterr().out
    assert "crossing/dsmc/seed 1" in printed and not (tmp_path / "small").exists()


def test_rms_per_frame_counts_only_runs_with_an_estimate():
    runs = [("s", "m", {"errors": {"1": [[1, 3.0], [2, 6.0]]}}), ("s", "m", {"errors": {"1": [[1, 4.0]]}})]
    rows = rms_per_frame(runs)
    assert [(r["frame"], r["runs"]) for r in rows] == [(1, 2), (2, 1)]
    assert rows[0]["rms_error"] == pytest.approx(math.sqrt(12.5))
    assert rows[1]["rms_error"] == 6.0


def test_an_output_path_that_is_a_file_is_refused(tmp_path):
    target = tmp_path / "taken"
    target.write_text("not a folder", encoding="utf-8")
    with pytest.raises(ExperimentError, match="exists and is not a folder"):
        run_experiment(experiment_from_mapping(SMALL), target, workers=1, progress=False)
    assert target.read_text(encoding="utf-8") == "not a folder"


def test_a_scheduler_without_dask_names_the_extra(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "distributed", None)     # import distributed -> ImportError
    with pytest.raises(ExperimentError, match=r"needs the dask extra: pip install 'belief-dsmt\[dask\]'"):
        run_experiment(experiment_from_mapping(SMALL), tmp_path, scheduler="tcp://127.0.0.1:8786", progress=False)
    assert not list((tmp_path / "cells").glob("*.json"))


def test_a_changed_default_or_version_gives_a_new_key(monkeypatch):
    # A saved run is reused only if it ran with the same complete configuration: the digest
    # must see defaults that the configuration file does not name, and the library's version.
    import dataclasses

    import belief

    cell = experiment_from_mapping(SMALL).cells()[0]
    config = cell.config()
    before = Cell(cell.sequence, cell.method, cell.seed, cell.tracker).key
    assert before == cell.key and before.startswith("crossing__r_rule__seed0__")
    monkeypatch.setattr(Cell, "config", lambda self: dataclasses.replace(config, particles=config.particles + 1))
    assert Cell(cell.sequence, cell.method, cell.seed, cell.tracker).key != before
    monkeypatch.undo()
    monkeypatch.setattr(belief, "__version__", belief.__version__ + ".post1")
    assert Cell(cell.sequence, cell.method, cell.seed, cell.tracker).key != before
