"""``belief track``: the demo writes every output; bad input gives one line and a non-zero exit."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from belief.cli import main
from belief_tracking import scenes
from belief_tracking.cli import AUTOMATIC_WARM_UP, SCORES_EXPLAINED, register
from belief_tracking.errors import TrackingError

OUTPUTS = {"tracks.txt", "diagnostics.csv", "diagnostics.png", "tracks.png", "summary.json", "annotated.avi", "gt.txt",
           "scene.avi", ".belief-outputs.json"}
DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "pets09_s2l1_f0001_0200"


def track(argv: list[str]) -> int:
    """Run ``belief track`` through the plugin's own parser (works without the package installed)."""
    parser = argparse.ArgumentParser(prog="belief")
    register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["track", *argv])
    return args.func(args)


def write_video(path: Path, n_frames: int = 4) -> Path:
    frames = np.full((n_frames, 48, 64, 3), 100, np.uint8)
    frames[:, 10:30, 20:30] = (40, 40, 190)
    scenes.write_video(path, frames)
    return path


@pytest.mark.parametrize("case", ["missing video", "not a video", "box outside", "empty init", "unknown cue",
                                  "unknown rule"])
def test_bad_input_is_one_line_and_leaves_no_output(tmp_path, capsys, case):
    video = write_video(tmp_path / "v.avi")
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1,21,11,10,20\n")
    argv = [str(video), "--init", str(boxes)]
    if case == "missing video":
        argv[0] = str(tmp_path / "nope.avi")
    elif case == "not a video":
        junk = tmp_path / "junk.avi"
        junk.write_text("this is not a video\n")
        argv[0] = str(junk)
    elif case == "box outside":
        boxes.write_text("1,500,11,10,20\n")
    elif case == "empty init":
        boxes.write_text("")
    elif case == "unknown cue":
        argv += ["--cues", "colour,sound"]
    else:
        argv += ["--rule", "no_such_rule"]
    out = tmp_path / "out"
    status = main(["track", *argv, "--out", str(out), "--no-progress"])
    err = capsys.readouterr().err
    assert status == 1
    assert err.startswith("belief: error:") and err.count("\n") == 1
    assert not out.exists()
    with pytest.raises(TrackingError):
        track([*argv, "--out", str(out), "--no-progress"])


def test_track_with_boxes_file(tmp_path):
    video = write_video(tmp_path / "v.avi", n_frames=5)
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("id,x,y,w,h\n3,21,11,10,20\n")
    out = tmp_path / "out"
    assert track([str(video), "--init", str(boxes), "--out", str(out), "--particles", "20", "--no-video",
                  "--no-progress"]) == 0
    assert {p.name for p in out.iterdir()} == {"tracks.txt", "diagnostics.csv", "diagnostics.png", "tracks.png",
                                               "summary.json", ".belief-outputs.json"}
    tracks = np.loadtxt(out / "tracks.txt", delimiter=",")
    assert tracks.shape == (5, 10) and set(tracks[:, 1]) == {3}


@pytest.mark.data
def test_pets_first_frames(tmp_path):
    if not (DATA / "video.avi").exists():
        pytest.skip("the PETS 2009 S2L1 data set is absent")
    from belief_tracking.motfiles import read_mot
    from belief_tracking.scenes import write_gt

    gt = read_mot(DATA / "gt.txt")
    short = tmp_path / "gt20.txt"
    write_gt(short, gt[gt[:, 0] <= 20])
    out = tmp_path / "pets"
    # The tracker stops at the end of the video; births after frame 20 do not happen as the gt is cut.
    from belief_tracking.config import TrackerConfig
    from belief_tracking.initiation import init_from_gt
    from belief_tracking.runner import run
    from belief_tracking.video import VideoReader

    with VideoReader(DATA / "video.avi") as reader:
        frames = np.stack([f for _, f in zip(range(20), reader)])
    summary = run(frames, init_from_gt(short), TrackerConfig(particles=50), out, seed=0, write_video=False,
                  progress=False, gt=short)
    assert summary.frames == 20
    tracks = np.loadtxt(out / "tracks.txt", delimiter=",")
    assert len(tracks) > 0 and np.isfinite(tracks).all()
    diagnostics = np.genfromtxt(out / "diagnostics.csv", delimiter=",", names=True)
    assert all(np.isfinite(diagnostics[name]).all() for name in diagnostics.dtype.names)


def test_readme_main_command_runs_the_tracking_demo_and_writes_every_output(tmp_path, capsys):
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text(encoding="utf-8")
    command = next(line for line in readme.splitlines() if line.startswith("pip install \".[tracking]\" && belief "))
    argv = command.split("&& belief ", 1)[1].split()
    assert argv[:2] == ["track", "--demo"]
    out = tmp_path / "readme_run"
    argv[argv.index("--out") + 1] = str(out)
    assert track([*argv[1:], "--particles", "30", "--seed", "2", "--no-progress"]) == 0
    assert {p.name for p in out.iterdir()} == OUTPUTS
    printed = capsys.readouterr().out
    assert "MOTA" in printed and "IDF1" in printed and "ID switches" in printed
    assert SCORES_EXPLAINED in printed.splitlines()
    summary = json.loads((out / "summary.json").read_text())
    # The demo is tracked as a user's video is: the ground truth only scores it.
    assert summary["init"] == "automatic initiation" and summary["parameters"]["warm_up"] == AUTOMATIC_WARM_UP
    assert summary["frames"] == 100 and summary["seed"] == 2 and summary["parameters"]["particles"] == 30
    assert summary["detections"] is None
    # gt.txt has the 9 columns of a MOT17 ground truth: flag 1, class 1 (pedestrian), visibility in [0, 1]
    gt = np.loadtxt(out / "gt.txt", delimiter=",")
    assert gt.shape[1] == 9 and (gt[:, 6] == 1).all() and (gt[:, 7] == 1).all()
    assert gt[:, 8].min() == 0.0 and gt[:, 8].max() == 1.0
    assert summary["parameters"]["cues"] == ["colour", "location", "foreground"]
    assert summary["scores"]["mota"] is not None and summary["version"]
    tracks = np.loadtxt(out / "tracks.txt", delimiter=",")
    assert tracks.shape[1] == 10 and len(tracks) > 100 and np.isfinite(tracks).all()
    assert set(tracks[:, 0]) <= set(range(1, 101))
    diagnostics = np.genfromtxt(out / "diagnostics.csv", delimiter=",", names=True)
    assert len(diagnostics) > 100 and np.isfinite(diagnostics["mean_bel"]).all()


def test_a_video_without_init_file_is_tracked_automatically(tmp_path, capsys, rendered_scene):
    scene = rendered_scene(scenes.entering_leaving(0))
    video = tmp_path / "entering.avi"
    scenes.write_video(video, scene)
    gt = tmp_path / "gt.txt"
    scenes.write_gt(gt, scene.ground_truth)
    out = tmp_path / "auto"
    assert track([str(video), "--out", str(out), "--gt", str(gt), "--particles", "20", "--no-video",
                  "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["init"] == "automatic initiation" and summary["parameters"]["warm_up"] == 50
    assert summary["parameters"]["initiation"]["first_frame"] is True
    assert summary["targets"] == 3 and summary["scores"]["mota"] >= 0.8
    assert "MOTA" in capsys.readouterr().out


def test_fusion_strategy_edges_and_adaptive_particles_from_the_command_line(tmp_path, rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    video = tmp_path / "crossing.avi"
    scenes.write_video(video, scene.frames[:20])
    gt = tmp_path / "gt.txt"
    scenes.write_gt(gt, scene.ground_truth[scene.ground_truth[:, 0] <= 20])
    out = tmp_path / "adaptive"
    assert track([str(video), "--init-from-gt", str(gt), "--out", str(out), "--particles", "20", "--fusion",
                  "adaptive", "--adaptive-particles", "--cues", "colour,location,edges", "--no-video",
                  "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    parameters = summary["parameters"]
    assert parameters["fusion"] == "adaptive" and parameters["adaptive_particles"] is True
    assert parameters["cues"] == ["colour", "location", "edges"] and parameters["initiation"] is None
    header = (out / "diagnostics.csv").read_text().splitlines()[0].split(",")
    # the adaptive count's conflict comes from the belief fusion, so its masses are recorded too
    assert header[:7] == ["frame", "id", "mean_m_target", "mean_m_intersection", "mean_bel", "mean_m_empty", "mean_r"]
    assert header[-5:] == ["similarity", "occluded", "confidence_colour", "confidence_location", "confidence_edges"]
    counts = np.genfromtxt(out / "diagnostics.csv", delimiter=",", names=True)["particles"]
    assert counts.min() >= 10 and counts.max() <= 20


@pytest.mark.parametrize("flag, value, message", [("--warm-up", "-1", "must be an integer >= 0, got -1"),
                                                   ("--particles", "0", "must be an integer >= 1, got 0"),
                                                   ("--seed", "x", "must be an integer, got 'x'")])
def test_a_bad_flag_value_is_a_one_line_command_line_error(tmp_path, capsys, flag, value, message):
    video = write_video(tmp_path / "v.avi")
    assert main(["track", str(video), "--out", str(tmp_path / "o"), flag, value]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and f"argument {flag}: {message}" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("setting, message", [("belief.masses=absolute", "FusionConfig.masses must be one of"),
                                              ("masses=normalised", "masses is a setting of the belief table: belief.masses"),
                                              ("location.sigmaa=3", "unknown key 'sigmaa'"),
                                              ("novalue", "--set takes KEY=VALUE")])
def test_a_bad_setting_is_a_one_line_error(tmp_path, capsys, setting, message):
    video = write_video(tmp_path / "v.avi")
    assert main(["track", str(video), "--out", str(tmp_path / "o"), "--set", setting]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("belief: error:") and message in err and err.count("\n") == 0
    assert not (tmp_path / "o").exists()


def test_every_setting_is_reachable_from_the_command_line(tmp_path):
    video = write_video(tmp_path / "v.avi", n_frames=3)
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1,21,11,10,20\n")
    out = tmp_path / "out"
    assert track([str(video), "--init", str(boxes), "--out", str(out), "--no-video", "--no-progress",
                  "--set", "belief.masses=normalised", "--set", "adaptive_fusion.mix_norm='raw'", "--set", "particles=12",
                  "--set", "colour.bins=4", "--template-update", "--diagnostics", "all"]) == 0
    parameters = json.loads((out / "summary.json").read_text())["parameters"]
    assert parameters["belief"]["masses"] == "normalised" and parameters["adaptive_fusion"]["mix_norm"] == "raw"
    assert parameters["particles"] == 12 and parameters["colour"]["bins"] == 4
    assert parameters["template_update"] is True and parameters["diagnostics"] == "all"


# -- sources other than a video file, and detection files ----------------------------------------------
def write_images(folder: Path, n_frames: int = 4, name: str = "{:06d}.png") -> Path:
    """Frames of :func:`write_video` as lossless images, one file a frame."""
    import cv2

    folder.mkdir(parents=True, exist_ok=True)
    frames = np.full((n_frames, 48, 64, 3), 100, np.uint8)
    frames[:, 10:30, 20:30] = (40, 40, 190)
    for k, image in enumerate(frames, start=1):
        assert cv2.imwrite(str(folder / name.format(k)), image)
    return folder


def write_sequence(folder: Path, n_frames: int = 4, info: str | None = None) -> Path:
    write_images(folder / "img1", n_frames, "{:06d}.jpg")
    if info is None:
        info = f"[Sequence]\nname=walk\nimDir=img1\nframeRate=10\nseqLength={n_frames}\nimWidth=64\nimHeight=48\n" \
               "imExt=.jpg\n"
    (folder / "seqinfo.ini").write_text(info)
    return folder


DETECTIONS = "1,-1,21,11,10,20,0.9,-1,-1,-1\n3,-1,22,11,10,20,0.8,-1,-1,-1\n"


BAD_SOURCES = {
    "detections: malformed line": ("det", "1,-1,21,11,10,20,0.9\n2,-1,21,11,10,20\n",
                                   "det.txt, line 2: expected at least 7 fields"),
    "detections: not a number": ("det", "1,-1,21,11,10,twenty,0.9\n", "det.txt, line 1: field 6 is not a number"),
    "detections: negative size": ("det", "\n1,-1,21,11,-10,20,0.9\n", "det.txt, line 2: the box size -10 x 20"),
    "detections: NaN size": ("det", "1,-1,21,11,10,NaN,0.9\n", "det.txt, line 1: the box size 10 x NaN"),
    "detections: score above 1": ("det", "1,-1,21,11,10,20,2.5\n", "det.txt, line 1: the score 2.5 is outside [0, 1]"),
    "detections: NaN score": ("det", "1,-1,21,11,10,20,nan\n", "det.txt, line 1: the score nan is outside [0, 1]"),
    "detections: past the end": ("det", DETECTIONS + "5,-1,21,11,10,20,0.9\n",
                                 "det.txt, line 3: frame 5 is after the end of the video (4 frames)"),
    "detections: outside the image": ("det", "1,-1,100,11,10,20,0.9\n", "wholly outside the 64x48 image"),
    "unreadable first image": ("first", None, "000001.png': OpenCV cannot decode it"),
    "unreadable later image": ("later", None, "000003.png': OpenCV cannot decode it"),
    "images of two sizes": ("size", None, "000004.png' has size 32x24, the earlier images"),
    "empty folder": ("empty", None, "holds no image file"),
    "seqinfo.ini without imDir": ("seqinfo", "[Sequence]\nname=walk\nframeRate=10\nseqLength=4\n",
                                  "seqinfo.ini: no imDir"),
}


@pytest.mark.parametrize("case", list(BAD_SOURCES))
def test_a_bad_source_or_detection_file_is_one_line_and_leaves_no_output(tmp_path, capsys, case):
    import cv2

    what, text, message = BAD_SOURCES[case]
    source = write_images(tmp_path / "frames")
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1,21,11,10,20\n")
    argv = [str(source), "--init", str(boxes)]
    if what == "det":
        (tmp_path / "det.txt").write_text(text)
        argv += ["--detections", str(tmp_path / "det.txt")]
    elif what == "first":
        (source / "000001.png").write_bytes(b"not an image at all" * 10)
    elif what == "later":
        (source / "000003.png").write_bytes(b"\x89PNG\r\n\x1a\n but then garbage" * 10)
    elif what == "size":
        cv2.imwrite(str(source / "000004.png"), np.zeros((24, 32, 3), np.uint8))
    elif what == "empty":
        for file in source.iterdir():
            file.unlink()
    elif what == "seqinfo":
        argv[0] = str(write_sequence(tmp_path / "SEQ", info=text))
    out = tmp_path / "runs" / "out"
    status = main(["track", *argv, "--out", str(out), "--particles", "10", "--no-progress"])
    out_text, err = capsys.readouterr()
    assert status == 1, err
    assert err.startswith("belief: error:") and err.count("\n") == 1 and "Traceback" not in err
    assert message in err
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("kind", ["folder", "pattern", "sequence"])
def test_a_folder_a_pattern_or_a_sequence_is_tracked_with_detections(tmp_path, quick_plot, kind):
    if kind == "sequence":
        folder = write_sequence(tmp_path / "SEQ")
        source = str(folder)
        (folder / "det").mkdir()
        (folder / "det" / "det.txt").write_text(DETECTIONS)
        detections = folder / "det" / "det.txt"
    else:
        folder = write_images(tmp_path / "frames")
        source = str(folder if kind == "folder" else folder / "%06d.png")
        detections = tmp_path / "det.txt"
        detections.write_text(DETECTIONS)
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1,21,11,10,20\n")
    out = tmp_path / "out"
    assert track([source, "--init", str(boxes), "--detections", str(detections), "--out", str(out),
                  "--particles", "10", "--cues", "colour,location", "--no-progress", "--no-video"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frames"] == 4 and summary["source"] == source and summary["detections"] == str(detections)
    assert summary["parameters"]["cues"] == ["colour", "location"]
    assert np.loadtxt(out / "tracks.txt", delimiter=",").shape == (4, 10)


def test_the_public_detections_of_a_sequence_are_used_only_when_given(tmp_path, quick_plot, capsys):
    folder = write_sequence(tmp_path / "SEQ")
    (folder / "det").mkdir()
    (folder / "det" / "det.txt").write_text("this line would be refused\n")
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1,21,11,10,20\n")
    out = tmp_path / "out"
    assert track([str(folder), "--init", str(boxes), "--out", str(out), "--particles", "10", "--no-progress",
                  "--no-video"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["detections"] is None and "detections" not in summary["parameters"]["cues"]
    with pytest.raises(SystemExit):
        track(["--help"])
    assert "SEQ/det/det.txt" in " ".join(capsys.readouterr().out.split())


def test_a_run_without_video_removes_the_video_of_the_run_before(tmp_path, quick_plot):
    source = write_images(tmp_path / "frames")
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1,21,11,10,20\n")
    out = tmp_path / "out"
    argv = [str(source), "--init", str(boxes), "--out", str(out), "--particles", "10", "--no-progress"]
    assert track(argv) == 0
    assert (out / "annotated.avi").is_file()
    (out / "my_notes.txt").write_text("mine")
    assert track([*argv, "--no-video", "--force"]) == 0
    assert {p.name for p in out.iterdir()} == {"tracks.txt", "diagnostics.csv", "diagnostics.png", "tracks.png",
                                               "summary.json", "my_notes.txt", ".belief-outputs.json"}
