"""MOTChallenge detection files: reading, writing, checking against a video, and handing them to the tracker."""

from __future__ import annotations

import doctest
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief_tracking import detections as detections_module
from belief_tracking import outputs
from belief_tracking.config import TrackerConfig
from belief_tracking.detections import Detections, check_detections, check_rows, read_detections, write_detections
from belief_tracking.errors import DetectionFileError, TrackFileError, TrackingError
from belief_tracking.initiation import read_init_boxes
from belief_tracking.runner import run


def test_docstring_examples():
    for module in (detections_module, outputs):
        result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
        assert result.attempted > 0 and result.failed == 0, module.__name__


# -- the container ------------------------------------------------------------------------------------
def test_detections_keep_the_frames_with_boxes_in_order_and_count_every_box():
    rows = [[1.0, 2.0, 3.0, 4.0, 0.5], [5.0, 6.0, 7.0, 8.0, 1.0]]
    dets = Detections({9: rows[:1], 2: rows, 5: []}, source="mine")
    assert dets.frames == (2, 9) and len(dets) == 3           # frame 5 has no box: not a frame of the detections
    assert dets.at(2).tolist() == rows and dets.at(9).tolist() == rows[:1]
    assert dets.at(5).shape == (0, 5) and dets.at(np.int64(2)).tolist() == rows
    assert repr(dets) == "Detections(3 boxes over 2 frames from 'mine')"
    assert len(Detections()) == 0 and Detections().frames == ()


def test_the_detections_of_a_frame_refuse_writes():
    dets = Detections({1: [[1.0, 2.0, 3.0, 4.0, 0.5]]})
    with pytest.raises(ValueError, match="read-only"):
        dets.at(1)[0, 0] = 5.0
    assert dets.at(1)[0, 0] == 1.0 and not dets.at(7).flags.writeable


def test_detections_do_not_change_with_the_array_they_were_made_from():
    given_rows = np.array([[1.0, 2.0, 3.0, 4.0, 0.5]])
    dets = Detections({1: given_rows})
    given_rows[0, 0] = 99.0                              # the caller's array stays the caller's, writable
    assert dets.at(1)[0, 0] == 1.0 and given_rows.flags.writeable


def test_rows_on_the_edges_of_the_ranges_are_accepted():
    # Negative corners (a box reaching past the top-left corner), the scores 0 and 1, tiny sizes.
    rows = [[-5.0, -5.0, 1e-3, 1e-3, 0.0], [0.0, 0.0, 10.0, 10.0, 1.0]]
    assert check_rows(rows, "frame 1").tolist() == rows
    assert check_rows(np.zeros((0, 5)), "frame 1").shape == (0, 5)


def test_detections_that_reach_into_the_video_fit_it():
    # The last frame of the video, and boxes that share only a sliver with the 64 x 48 image.
    dets = Detections({4: [[-9.5, 0.0, 10.0, 10.0, 0.9], [63.5, 47.5, 10.0, 10.0, 0.9]]}, source="mine")
    assert check_detections(dets, frame_count=4, image_size=(64, 48)) is None
    assert check_detections(Detections(), frame_count=1, image_size=(1, 1)) is None


# -- reading ------------------------------------------------------------------------------------------
def test_a_motchallenge_detection_file_is_read_0_based(tmp_path):
    path = tmp_path / "det.txt"
    path.write_text("1,-1,11,21,10,20,0.9,-1,-1,-1\n"
                    "\n"
                    "  1,-1,31.5,1,5,8,1  \n"
                    "4 -1 1 1 5 8 0 7 7\n")  # white space separates the fields of a line without commas
    dets = read_detections(path, frame_count=4, image_size=(64, 48))
    assert dets.frames == (1, 4) and len(dets) == 3 and dets.source == str(path)
    assert dets.at(1).tolist() == [[10.0, 20.0, 10.0, 20.0, 0.9], [30.5, 0.0, 5.0, 8.0, 1.0]]
    assert dets.at(4).tolist() == [[0.0, 0.0, 5.0, 8.0, 0.0]]
    assert dets.at(2).shape == (0, 5) and not dets.at(1).flags.writeable


def test_a_box_partly_outside_the_image_is_kept(tmp_path):
    path = tmp_path / "det.txt"
    path.write_text("1,-1,-4,-4,10,10,0.5\n1,-1,60,40,10,10,0.5\n")
    assert len(read_detections(path, image_size=(64, 48))) == 2


BAD_LINES = [
    ("1,-1,11,21,10,20", "line 2: expected at least 7 fields (frame,-1,x,y,w,h,score,...), got 6"),
    ("1,-1,11,abc,10,20,0.5", "line 2: field 4 is not a number: 'abc'"),
    ("1,-1,11,21,-10,20,0.5", "line 2: the box size -10 x 20 is not positive and finite"),
    ("1,-1,11,21,10,0,0.5", "line 2: the box size 10 x 0 is not positive and finite"),
    ("1,-1,11,21,nan,20,0.5", "line 2: the box size nan x 20 is not positive and finite"),
    ("1,-1,11,21,10,inf,0.5", "line 2: the box size 10 x inf is not positive and finite"),
    ("1,-1,inf,21,10,20,0.5", "line 2: the corner inf,21 is not finite"),
    ("1,-1,11,21,10,20,1.5", "line 2: the score 1.5 is outside [0, 1]"),
    ("1,-1,11,21,10,20,-0.1", "line 2: the score -0.1 is outside [0, 1]"),
    ("1,-1,11,21,10,20,nan", "line 2: the score nan is outside [0, 1]"),
    ("0,-1,11,21,10,20,0.5", "line 2: the frame must be an integer of at least 1, got 0"),
    ("2.5,-1,11,21,10,20,0.5", "line 2: the frame must be an integer of at least 1, got 2.5"),
    ("6,-1,11,21,10,20,0.5", "line 2: frame 6 is after the end of the video (5 frames)"),
    ("1,-1,65,21,10,20,0.5", "line 2: the box 65,21,10,20 is wholly outside the 64x48 image"),
    ("1,-1,-9,21,10,20,0.5", "line 2: the box -9,21,10,20 is wholly outside the 64x48 image"),
]


@pytest.mark.parametrize("line, message", BAD_LINES, ids=[m.split(": ", 1)[1][:30] for _, m in BAD_LINES])
def test_a_bad_line_is_named_with_its_number(tmp_path, line, message):
    path = tmp_path / "det.txt"
    path.write_text(f"1,-1,11,21,10,20,0.5\n{line}\n")
    with pytest.raises(DetectionFileError) as info:
        read_detections(path, frame_count=5, image_size=(64, 48))
    assert str(info.value) == f"{path}, {message}" or str(info.value).startswith(f"{path}, {message}")
    assert "\n" not in str(info.value) and isinstance(info.value, TrackFileError)


def test_frames_and_image_are_checked_only_when_known(tmp_path):
    path = tmp_path / "det.txt"
    path.write_text("9,-1,500,500,10,20,0.5\n")
    assert read_detections(path).frames == (9,)


@pytest.mark.parametrize("text, message", [("", "no detections in the file"), ("\n  \n", "no detections"),
                                           (None, "no such file")])
def test_an_empty_or_missing_file_is_refused(tmp_path, text, message):
    path = tmp_path / "det.txt"
    if text is not None:
        path.write_text(text)
    with pytest.raises(DetectionFileError, match=message):
        read_detections(path)


# -- writing: the round trip ----------------------------------------------------------------------------
coordinate = st.floats(-50, 500, allow_nan=False).map(lambda v: round(v, 3))
size = st.floats(0.001, 300, allow_nan=False).map(lambda v: round(v, 3))
score = st.floats(0, 1).map(lambda v: round(v, 6))
row = st.tuples(coordinate, coordinate, size, size, score)
by_frame = st.dictionaries(st.integers(1, 2000), st.lists(row, min_size=1, max_size=4), min_size=1, max_size=6)


@settings(max_examples=40, deadline=None)
@given(by_frame=by_frame, unrounded=st.floats(0, 1e-4))
def test_written_detections_read_back_to_the_written_precision(tmp_path_factory, by_frame, unrounded):
    folder = tmp_path_factory.mktemp("det")
    original = Detections({f: [(x + unrounded, y, w, h, s) for x, y, w, h, s in rows] for f, rows in by_frame.items()})
    write_detections(folder / "det.txt", original)
    again = read_detections(folder / "det.txt")
    assert again.frames == original.frames == tuple(sorted(by_frame)) and len(again) == len(original)
    for frame, rows in by_frame.items():
        assert np.allclose(again.at(frame), np.array(rows, dtype=float), rtol=0, atol=1e-9)
    write_detections(folder / "again.txt", again)
    assert (folder / "again.txt").read_text() == (folder / "det.txt").read_text()


def test_write_detections_refuses_what_it_cannot_write(tmp_path):
    with pytest.raises(TrackingError, match="needs Detections"):
        write_detections(tmp_path / "det.txt", {1: [[0, 0, 1, 1, 1]]})
    with pytest.raises(TrackingError, match="narrower or lower than 0.0005 px"):
        write_detections(tmp_path / "det.txt", Detections({1: [[0, 0, 0.0001, 1, 1]]}))


# -- against a video and in a run -----------------------------------------------------------------------
def test_check_detections_names_the_frame_and_the_box():
    dets = Detections({3: [[10.0, 20.0, 8.0, 16.0, 0.9]], 5: [[70.0, 0.0, 8.0, 16.0, 0.9]]}, source="mine")
    check_detections(dets)
    with pytest.raises(DetectionFileError, match="mine: frame 5 is after the end of the video \\(4 frames\\)"):
        check_detections(dets, frame_count=4)
    with pytest.raises(DetectionFileError, match="mine: frame 5 has the box 70,0,8,16 .* outside the 64x48 image"):
        check_detections(dets, image_size=(64, 48))
    with pytest.raises(TrackingError, match="must be Detections or None"):
        check_detections([[1, 2]])


def frames_with_a_red_block(n_frames: int = 4) -> np.ndarray:
    frames = np.full((n_frames, 48, 64, 3), 100, np.uint8)
    frames[:, 10:30, 20:30] = (40, 40, 190)
    return frames


@pytest.fixture
def plan(tmp_path):
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1,21,11,10,20\n")
    return read_init_boxes(boxes)


def test_the_run_hands_the_detections_to_the_tracker_frame_by_frame(tmp_path, plan, monkeypatch):
    from belief_tracking import runner

    given_to_tracker = []
    real_step = runner.Tracker.step

    def step(self, frame, image, detections=None):
        given_to_tracker.append((frame, None if detections is None else detections.tolist()))
        return real_step(self, frame, image, detections)

    monkeypatch.setattr(runner.Tracker, "step", step)
    dets = Detections({2: [[20.0, 10.0, 10.0, 20.0, 0.8]]}, source="det.txt")
    summary = run(frames_with_a_red_block(), plan, TrackerConfig(particles=10), tmp_path / "out", write_video=False,
                  progress=False, write_plot=False, detections=dets)
    assert summary.frames == 4
    assert given_to_tracker == [(1, []), (2, [[20.0, 10.0, 10.0, 20.0, 0.8]]), (3, []), (4, [])]
    import json
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["detections"] == "det.txt"


@pytest.mark.parametrize("dets, message", [
    (Detections({5: [[20.0, 10.0, 10.0, 20.0, 0.8]]}, source="det.txt"), "det.txt: frame 5 is after the end"),
    (Detections({1: [[99.0, 10.0, 10.0, 20.0, 0.8]]}, source="det.txt"), "wholly outside the 64x48 image"),
    ({1: [[20.0, 10.0, 10.0, 20.0, 0.8]]}, "detections must be Detections or None, got dict"),
])
def test_detections_that_do_not_fit_are_refused_before_any_output(tmp_path, plan, dets, message):
    out = tmp_path / "deep" / "out"
    with pytest.raises(TrackingError, match=message):
        run(frames_with_a_red_block(), plan, TrackerConfig(particles=10), out, write_video=False, progress=False,
            detections=dets)
    assert not (tmp_path / "deep").exists()


def test_detections_past_a_length_announced_wrongly_are_refused_after_the_run(tmp_path, plan):
    from belief_tracking.sources import FrameSource

    frames = frames_with_a_red_block()
    unknown_length = FrameSource(frames, name="stream", width=64, height=48, fps=25.0, count=None)
    dets = Detections({9: [[20.0, 10.0, 10.0, 20.0, 0.8]]}, source="det.txt")
    out = tmp_path / "out"
    with pytest.raises(DetectionFileError, match="det.txt: frame 9 is after the end of the video \\(4 frames\\)"):
        run(unknown_length, plan, TrackerConfig(particles=10), out, write_video=False, progress=False,
            detections=dets)
    assert not out.exists()


def test_an_output_folder_holds_the_files_of_its_latest_run_only(tmp_path, plan, quick_plot):
    out = tmp_path / "out"
    out.mkdir()
    mine = Path(out / "notes.txt")
    mine.write_text("kept")
    (out / "annotated").mkdir()
    config = TrackerConfig(particles=10)
    run(frames_with_a_red_block(), plan, config, out, progress=False, force=True)
    assert {p.name for p in out.iterdir()} == {"tracks.txt", "diagnostics.csv", "diagnostics.png", "tracks.png",
                                               "annotated.avi", "summary.json", "notes.txt", "annotated",
                                               ".belief-outputs.json"}
    run(frames_with_a_red_block(), plan, config, out, progress=False, write_video=False, write_plot=False,
        force=True)
    assert {p.name for p in out.iterdir()} == {"tracks.txt", "diagnostics.csv", "summary.json", "notes.txt",
                                               "annotated", ".belief-outputs.json"}
    assert mine.read_text() == "kept"
