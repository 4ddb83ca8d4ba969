"""``belief track`` and ``belief eval`` on MOTChallenge folders, with --json, -q and -v (issue 27).

A sequence folder given as the SOURCE is scored against its own ground truth when no --gt is
given (one line on standard error says so, unless -q); ``belief eval`` takes a sequence folder
for its ground truth and a run's output folder for its tracks.  Each test builds its own tiny
folder: a short rendered crossing scene, its frames in img1/, its ground truth in gt/gt.txt and
detections made from it in det/det.txt.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from belief.cli import main
from belief_tracking import limits, scenes
from belief_tracking.cli import SCORES_EXPLAINED
from belief_tracking.sources import open_source, sequence_ground_truth

FRAMES = 8
#: Few particles and no video: each run takes a second or so.
QUICK = ["--particles", "10", "--no-video", "--no-progress"]


def write_mot_folder(folder: Path, *, seqinfo: bool = True, video: bool = False, gt_name: str = "gt/gt.txt") -> Path:
    """A MOTChallenge sequence of a short crossing scene: img1/ (or a video), seqinfo.ini, the gt and det files."""
    import cv2

    scene = scenes.render(dataclasses.replace(scenes.crossing(0), n_frames=FRAMES))
    height, width = scene.frames.shape[1:3]
    folder.mkdir(parents=True)
    if video:
        scenes.write_video(folder / "video.avi", scene)
        im_dir = "video.avi"
    else:
        (folder / "img1").mkdir()
        for k, image in enumerate(scene.frames, start=1):
            assert cv2.imwrite(str(folder / "img1" / f"{k:06d}.png"), image)
        im_dir = "img1"
    if seqinfo:
        (folder / "seqinfo.ini").write_text(f"[Sequence]\nname=crossing\nimDir={im_dir}\nframeRate=10\n"
                                            f"seqLength={FRAMES}\nimWidth={width}\nimHeight={height}\nimExt=.png\n")
    (folder / gt_name).parent.mkdir(parents=True, exist_ok=True)
    scenes.write_gt(folder / gt_name, scene.ground_truth, visibility=scene.visibility)
    (folder / "det").mkdir()
    (folder / "det" / "det.txt").write_text("".join(f"{int(f)},-1,{x:.1f},{y:.1f},{w:.1f},{h:.1f},0.9,-1,-1,-1\n"
                                                    for f, _, x, y, w, h, *_ in scene.ground_truth))
    return folder


@pytest.fixture(scope="module")
def mot_folder(tmp_path_factory) -> Path:
    return write_mot_folder(tmp_path_factory.mktemp("mot") / "SEQ-01")


def snapshot(folder: Path) -> dict[str, tuple[str, int]]:
    """Every file under ``folder``: its content's digest and modification time."""
    return {str(p.relative_to(folder)): (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if p.is_file()}


def run(capsys, *argv: str) -> tuple[int, str, str]:
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def test_a_sequence_folder_is_scored_against_its_own_ground_truth(mot_folder, tmp_path, capsys, quick_plot):
    before = snapshot(mot_folder)
    status, out, err = run(capsys, "track", mot_folder, "--out", tmp_path / "run", *QUICK)
    assert status == 0, err
    gt = mot_folder / "gt" / "gt.txt"
    [note] = err.splitlines()
    assert note.startswith("belief track: ") and "MOTChallenge sequence" in note and str(gt) in note
    assert "MOTA" in out and "IDF1" in out and SCORES_EXPLAINED in out.splitlines()
    summary = json.loads((tmp_path / "run" / "summary.json").read_text(encoding="utf-8"))
    assert summary["scores"] is not None
    # A run never changes the files it did not write.
    assert snapshot(mot_folder) == before


def test_track_json_prints_the_summary_as_one_object(mot_folder, tmp_path, capsys, quick_plot):
    out_dir = tmp_path / "run"
    status, out, err = run(capsys, "track", mot_folder, "--out", out_dir, *QUICK, "--json")
    assert status == 0, err
    data = json.loads(out)                   # the whole of standard output is the object
    assert list(data) == ["source", "out", "frames", "expected_frames", "complete", "tracks", "boxes",
                          "tracking_fps", "overall_fps", "gt", "scores", "files"]
    tracks = np.loadtxt(out_dir / "tracks.txt", delimiter=",", ndmin=2)
    assert data["source"] == str(mot_folder) and data["out"] == str(out_dir)
    assert data["frames"] == data["expected_frames"] == FRAMES and data["complete"] is True
    assert data["boxes"] == len(tracks) and data["tracks"] == len(set(tracks[:, 1].tolist()))
    assert data["gt"] == str(mot_folder / "gt" / "gt.txt")
    assert set(data["scores"]) >= {"mota", "idf1", "id_switches", "false_positives", "false_negatives"}
    assert data["scores"]["num_objects"] == len(np.loadtxt(mot_folder / "gt" / "gt.txt", delimiter=",", ndmin=2))
    assert data["files"]["tracks.txt"] == str(out_dir / "tracks.txt")
    assert "MOTChallenge sequence" in err and len(err.splitlines()) == 1
    # The eval of the files gives the same scores as the run.
    status, evaluated, _ = run(capsys, "eval", out_dir / "tracks.txt", mot_folder / "gt" / "gt.txt", "--json")
    assert status == 0 and json.loads(evaluated)["mota"] == pytest.approx(data["scores"]["mota"])


def test_quiet_leaves_only_the_results(mot_folder, tmp_path, capsys, quick_plot, monkeypatch):
    monkeypatch.setattr(limits, "LONG_RUN_SECONDS", 0.0)     # every run announces its estimate
    status, out, err = run(capsys, "track", mot_folder, "--out", tmp_path / "loud", *QUICK)
    assert status == 0 and "MOTChallenge sequence" in err and "particles a target" in err
    status, out, err = run(capsys, "-q", "track", mot_folder, "--out", tmp_path / "quiet", *QUICK)
    assert status == 0 and err == ""
    assert "MOTA" in out and SCORES_EXPLAINED not in out
    status, out, err = run(capsys, "track", mot_folder, "--out", tmp_path / "json", *QUICK, "--json", "-q")
    assert status == 0 and err == "" and json.loads(out)["scores"] is not None


def test_quiet_hides_the_progress_bar(mot_folder, tmp_path, capsys, quick_plot, monkeypatch):
    argv = ["track", mot_folder, "--particles", "10", "--no-video"]
    # The bar is drawn only on a terminal: standard error pretends to be one.
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    status, _, err = run(capsys, *argv, "--out", tmp_path / "bar")
    assert status == 0 and "tracking" in err and "frame" in err
    status, _, err = run(capsys, *argv, "--out", tmp_path / "nobar", "-q")
    assert status == 0 and err == ""


def test_verbose_gives_the_settings_in_effect(mot_folder, tmp_path, capsys, quick_plot):
    status, out, err = run(capsys, "track", mot_folder, "--out", tmp_path / "run", *QUICK, "-v", "--json")
    assert status == 0 and json.loads(out)
    said = err.splitlines()
    assert all(line.startswith("belief track: ") for line in said)
    expected = ["MOTChallenge sequence", f"source {mot_folder}: sequence, {FRAMES} frames of 320x240 at 10 fps",
                "tracker: belief fusion (rule r_rule, weight bel), 10 particles", "initiation: automatic",
                f"the sequence's {mot_folder / 'det' / 'det.txt'} is used only with --detections",
                f"ground truth: {mot_folder / 'gt' / 'gt.txt'}", "finished in"]
    for text in expected:
        assert any(text in line for line in said), text


def test_an_explicit_ground_truth_wins_and_nothing_is_said(mot_folder, tmp_path, capsys, quick_plot):
    rows = np.loadtxt(mot_folder / "gt" / "gt.txt", delimiter=",", ndmin=2)
    early = tmp_path / "early.txt"
    scenes.write_gt(early, rows[rows[:, 0] <= 3])
    status, out, err = run(capsys, "track", mot_folder, "--out", tmp_path / "run", *QUICK, "--gt", early, "--json")
    assert status == 0 and err == ""
    data = json.loads(out)
    assert data["gt"] == str(early) and data["scores"]["num_objects"] == int((rows[:, 0] <= 3).sum())


def test_a_folder_without_a_ground_truth_is_tracked_unscored(tmp_path, capsys, quick_plot):
    folder = write_mot_folder(tmp_path / "SEQ")
    shutil.rmtree(folder / "gt")
    status, out, err = run(capsys, "track", folder, "--out", tmp_path / "run", *QUICK, "--json")
    assert status == 0 and err == ""
    data = json.loads(out)
    assert data["gt"] is None and data["scores"] is None


@pytest.mark.parametrize("layout", ["img1 without seqinfo.ini", "imDir naming a video, gt.txt beside it"])
def test_other_sequence_layouts_are_read_and_scored(tmp_path, capsys, quick_plot, layout):
    if layout.startswith("img1"):
        folder = write_mot_folder(tmp_path / "SEQ", seqinfo=False)
        gt = folder / "gt" / "gt.txt"
    else:
        folder = write_mot_folder(tmp_path / "SEQ", video=True, gt_name="gt.txt")
        gt = folder / "gt.txt"
    with open_source(folder) as frames:
        assert (frames.kind, frames.count, frames.width, frames.height) == ("sequence", FRAMES, 320, 240)
        assert frames.fps == (25.0 if layout.startswith("img1") else 10.0)
    assert sequence_ground_truth(folder) == gt
    status, out, err = run(capsys, "track", folder, "--out", tmp_path / "run", *QUICK, "--json")
    assert status == 0, err
    assert json.loads(out)["gt"] == str(gt) and str(gt) in err


def test_a_bad_ground_truth_of_the_folder_is_one_line_and_leaves_no_output(tmp_path, capsys, quick_plot):
    folder = write_mot_folder(tmp_path / "SEQ")
    (folder / "gt" / "gt.txt").write_text("1,1,10,10,5,10,1\nthis is not a box\n")
    status, out, err = run(capsys, "track", folder, "--out", tmp_path / "runs" / "run", *QUICK)
    assert status == 1 and out == ""
    assert err.startswith("belief: error:") and err.count("\n") == 1 and "Traceback" not in err
    assert "gt.txt" in err
    assert not (tmp_path / "runs").exists()
    (folder / "gt" / "gt.txt").write_text(f"{FRAMES + 5},1,10,10,5,10,1\n")     # after the last frame
    status, _, err = run(capsys, "track", folder, "--out", tmp_path / "runs" / "run", *QUICK)
    assert status == 1 and err.count("\n") == 1 and "after the end" in err


def test_eval_takes_a_run_folder_and_a_sequence_folder(mot_folder, tmp_path, capsys, quick_plot):
    out_dir = tmp_path / "run"
    assert run(capsys, "track", mot_folder, "--out", out_dir, *QUICK, "-q")[0] == 0
    status, files, _ = run(capsys, "eval", out_dir / "tracks.txt", mot_folder / "gt" / "gt.txt", "--json")
    assert status == 0
    status, folders, err = run(capsys, "eval", out_dir, mot_folder, "--json")
    assert status == 0 and json.loads(folders) == json.loads(files)
    said = err.splitlines()
    assert len(said) == 2 and all(line.startswith("belief eval: ") for line in said)
    assert str(out_dir / "tracks.txt") in said[0] and str(mot_folder / "gt" / "gt.txt") in said[1]
    status, quiet, err = run(capsys, "eval", out_dir, mot_folder, "-q")
    assert status == 0 and err == "" and "MOTA" in quiet


def test_eval_of_folders_without_the_files_is_one_line(mot_folder, tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    tracks = tmp_path / "tracks.txt"
    tracks.write_text("1,1,10,10,5,10,-1,-1,-1,-1\n")
    for argv, named in (([tracks, tmp_path / "empty"], "without a ground truth"),
                        ([tmp_path / "empty", mot_folder], "without tracks.txt")):
        status, out, err = run(capsys, "eval", *argv)
        assert status == 1 and out == ""
        assert err.startswith("belief: error:") and err.count("\n") == 1 and named in err


EXPERIMENT = """\
name = "tiny"
seeds = [0]

[tracker]
particles = 8

[[sequences]]
name = "crossing"
scene = "crossing"
frames = 5

[grid]
rules = ["dsmc"]
"""


def test_experiment_json(tmp_path, capsys):
    config = tmp_path / "tiny.toml"
    config.write_text(EXPERIMENT, encoding="utf-8")
    status, out, err = run(capsys, "experiment", config, "--dry-run", "--json")
    assert status == 0 and err == ""
    plan = json.loads(out)
    assert (plan["experiment"], plan["runs"], plan["cells"]) == ("tiny", 1, ["crossing/dsmc/seed 0"])
    assert plan["estimate"]["workers"] >= 1 and not (tmp_path / "tiny").exists()
    status, out, err = run(capsys, "experiment", config, "--workers", "1", "--json", "--no-progress")
    assert status == 0, err
    data = json.loads(out)
    assert (data["computed"], data["reused"], data["runs"]) == (1, 0, 1)
    [row] = data["summary"]
    assert row["sequence"] == "crossing" and row["runs"] == 1
    assert "1 sequences x 1 methods x 1 seeds = 1 runs" in err      # the announcement, off standard output
    status, out, err = run(capsys, "-q", "experiment", config, "--workers", "1")
    assert status == 0 and err == "" and "reused 1" in out and "= 1 runs" not in out
