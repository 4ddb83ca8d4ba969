"""The writers of a run: each frame's result handed to each writer, closed however the frames end, files last."""

from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from types import SimpleNamespace

import numpy as np
import pytest

from belief_tracking import scenes
from belief_tracking.config import TrackerConfig
from belief_tracking.errors import TrackingError
from belief_tracking.initiation import init_from_gt
from belief_tracking.runner import run
from belief_tracking.writers import (
    DiagnosticRows,
    FrameWriter,
    ProgressBar,
    Scoring,
    SummaryWriter,
    Timing,
    TrackRows,
    feed,
)


def result(frame: int, boxes=((10.0, 20.0, 5.0, 8.0),), seconds: float = 0.01):
    """A stand-in for a tracker's FrameResult: what the writers read of it, and no more."""
    estimates = tuple(SimpleNamespace(id=k + 1, box=box) for k, box in enumerate(boxes))
    rows = [[frame, e.id, e.box[0] + 1.0, e.box[1] + 1.0, e.box[2], e.box[3], -1, -1, -1, -1] for e in estimates]
    diagnostics = SimpleNamespace(rows=lambda f: [{"frame": f, "id": e.id, "particles": 10} for e in estimates])
    return SimpleNamespace(frame=frame, estimates=estimates, seconds=seconds, diagnostics=diagnostics,
                           mot_rows=lambda: [list(r) for r in rows])


def fake_track(frames):
    """Takes a frame, yields its result, then takes the next one, as the tracker does."""
    for k, image in enumerate(frames, start=1):
        yield result(k, boxes=((float(image[0, 0, 0]), 0.0, 4.0, 4.0),))


class Log(FrameWriter):
    def __init__(self, name, journal, fail_at=None):
        self.name, self.journal, self.fail_at = name, journal, fail_at

    def write(self, result, image):
        if result.frame == self.fail_at:
            raise TrackingError(f"{self.name} fails at frame {result.frame}")
        self.journal.append((self.name, result.frame, int(image[0, 0, 0])))

    def close(self):
        self.journal.append((self.name, "closed"))

    def finish(self):
        self.journal.append((self.name, "finished"))


def images(count):
    return [np.full((4, 4, 3), k, np.uint8) for k in range(count)]


def test_each_writer_gets_each_result_with_the_image_it_was_computed_on_and_is_closed_not_finished():
    journal = []
    feed(fake_track, images(3), [Log("a", journal), Log("b", journal)])
    assert journal == [("a", 1, 0), ("b", 1, 0), ("a", 2, 1), ("b", 2, 1), ("a", 3, 2), ("b", 3, 2),
                       ("b", "closed"), ("a", "closed")]


def test_every_writer_is_closed_when_one_fails():
    journal = []
    with pytest.raises(TrackingError, match="b fails at frame 2"):
        feed(fake_track, images(3), [Log("a", journal), Log("b", journal, fail_at=2), Log("c", journal)])
    assert journal[-3:] == [("c", "closed"), ("b", "closed"), ("a", "closed")]
    assert ("c", 2, 1) not in journal and not any("finished" in entry for entry in journal)


def test_the_collectors_keep_rows_diagnostics_and_the_tracker_seconds():
    timing, tracks, diagnostics = Timing(), TrackRows(), DiagnosticRows()
    feed(fake_track, images(4), [timing, tracks, diagnostics])
    assert timing.frames == 4 and timing.tracking_seconds == pytest.approx(0.04)
    assert timing.tracking_fps == pytest.approx(100.0) and timing.overall_fps == math.inf  # not stopped yet
    assert timing.stop() > 0 and timing.overall_fps == pytest.approx(4 / timing.overall_seconds)
    assert tracks.array().shape == (4, 10) and tracks.array()[:, 2].tolist() == [1.0, 2.0, 3.0, 4.0]
    assert [(r["frame"], r["id"]) for r in diagnostics.records] == [(1, 1), (2, 1), (3, 1), (4, 1)]


def test_a_run_of_frames_the_tracker_did_not_time_has_an_infinite_tracking_speed():
    timing = Timing()
    timing.write(result(1, seconds=0.0), None)
    assert timing.tracking_fps == math.inf


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_non_finite_estimate_is_refused_naming_its_frame_and_target(bad):
    tracks = TrackRows()
    tracks.write(result(1), None)
    with pytest.raises(TrackingError, match="frame 7: target 2 has a non-finite estimate"):
        tracks.write(result(7, boxes=((1.0, 1.0, 2.0, 2.0), (bad, 1.0, 2.0, 2.0))), None)
    assert len(tracks.rows) == 1  # the refused frame adds nothing


def test_the_summary_lists_its_fields_in_order(tmp_path):
    timing, tracks = Timing(), TrackRows()
    for frame in (1, 2):
        for writer in (timing, tracks):
            writer.write(result(frame), None)
    source = SimpleNamespace(name="frames", count=3, missing=lambda decoded: 3 - decoded, decode_seconds=0.5)
    settings = {"seed": 0, "init": "automatic initiation", "detections": None, "parameters": {}, "version": "v"}
    SummaryWriter(tmp_path / "summary.json", source, timing, tracks, None, settings).finish()
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    assert list(summary) == ["source", "frames", "expected_frames", "complete", "targets", "track_rows", "fps",
                             "seed", "init", "detections", "parameters", "version", "scores"]
    assert list(summary["fps"]) == ["tracking", "overall", "decoding_seconds", "tracking_seconds", "overall_seconds"]
    assert (summary["frames"], summary["expected_frames"], summary["complete"]) == (2, 3, False)
    assert (summary["targets"], summary["track_rows"], summary["scores"]) == (1, 2, None)
    assert summary["fps"]["decoding_seconds"] == 0.5 and summary["fps"]["overall_seconds"] > 0


def test_the_scores_read_the_tracks_kept_before_them():
    tracks = TrackRows()
    for frame in (1, 2):
        tracks.write(result(frame), None)
    scoring = Scoring(tracks.array(), tracks)
    assert scoring.scores is None
    scoring.finish()
    assert scoring.scores.mota == 1.0 and scoring.scores.id_switches == 0


@pytest.mark.parametrize("terminal", [True, False])
def test_the_progress_bar_is_shown_on_a_terminal_only(monkeypatch, terminal):
    monkeypatch.setattr(sys, "stderr", SimpleNamespace(isatty=lambda: terminal, write=lambda text: len(text),
                                                       flush=lambda: None))
    assert ProgressBar(3).shown is terminal
    assert ProgressBar(3, show=False).shown is False


def test_the_writers_add_little_to_each_frame():
    # The tracker takes about 6 ms a frame on the PETS video: what the run adds must not show.
    results = [result(k, boxes=[(1.0, 2.0, 3.0, 4.0)] * 8) for k in range(1, 2001)]
    frames = images(1) * len(results)

    def replay(frames):
        for item, _ in zip(results, frames):
            yield item

    best = math.inf
    for _ in range(3):
        started = time.perf_counter()
        feed(replay, frames, [Timing(), TrackRows(), DiagnosticRows(), ProgressBar(len(results), show=False)])
        best = min(best, (time.perf_counter() - started) / len(results))
    assert best < 300e-6


@pytest.fixture
def short_scene(rendered_scene):
    return rendered_scene(dataclasses.replace(scenes.crossing(0), n_frames=4))


def test_a_failing_output_deletes_the_staged_files_and_leaves_the_others(tmp_path, short_scene, quick_plot):
    out = tmp_path / "run"
    out.mkdir()
    (out / "tracks.txt").write_text("of an earlier run\n")
    (out / "notes.txt").write_text("the user's own\n")

    def broken(path):
        raise TrackingError("the extra output cannot be written")

    with pytest.raises(TrackingError, match="extra output"):
        run(short_scene, init_from_gt(short_scene.ground_truth), TrackerConfig(particles=10), out,
            write_video=False, progress=False, extra_outputs={"extra.txt": broken}, force=True)
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "tracks.txt"]
    assert (out / "tracks.txt").read_text() == "of an earlier run\n"


def test_a_run_returns_what_its_writers_kept(tmp_path, short_scene, quick_plot):
    summary = run(short_scene, init_from_gt(short_scene.ground_truth), TrackerConfig(particles=10), tmp_path / "run",
                  write_video=False, progress=False, gt=short_scene.ground_truth)
    written = json.loads(summary.files["summary.json"].read_text(encoding="utf-8"))
    assert summary.frames == written["frames"] == 4 and summary.complete
    assert summary.tracks.shape == (written["track_rows"], 10)
    assert summary.tracking_fps == pytest.approx(written["fps"]["tracking"])
    assert summary.overall_fps == pytest.approx(written["fps"]["overall"])
    assert summary.scores.to_dict() == written["scores"]
    with open(summary.files["diagnostics.csv"], encoding="ascii") as handle:
        assert len(summary.diagnostics) == len(handle.readlines()) - 1 > 0
    assert list(summary.files) == ["tracks.txt", "diagnostics.csv", "diagnostics.png", "tracks.png", "summary.json"]
