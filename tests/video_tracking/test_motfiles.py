"""MOTChallenge text files: splitting lines, the frame and box ranges, and writing tracks.

Reading track and ground-truth files (read_mot) is tested with the evaluation, in
tests/video_tracking/test_evaluation.py, and the docstring examples in
tests/video_tracking/test_docstring_examples.py.
"""

from __future__ import annotations

import pytest

from belief_tracking.errors import InitError, TrackFileError
from belief_tracking.motfiles import MAX_COORDINATE, MAX_FRAME, check_box, check_frame, read_mot, text_lines, write_tracks


def test_lines_split_on_commas_or_else_on_blanks_and_keep_their_numbers():
    text = "1, 2 ,3\n\n   \n4 5\t6\n7,8 9\n"
    assert list(text_lines(text, "f.txt")) == [
        (1, "f.txt, line 1", ["1", "2", "3"]),
        (4, "f.txt, line 4", ["4", "5", "6"]),
        (5, "f.txt, line 5", ["7", "8 9"]),           # a line with a comma splits on commas only
    ]
    assert list(text_lines("", "f.txt")) == []


def test_written_tracks_are_one_line_per_row_with_integer_frames_and_ids(tmp_path):
    path = tmp_path / "tracks.txt"
    write_tracks(path, [[1, 7, 10.0, 20.5, 30.0, 40.0], [2.0, 12.0, -1.23456, 0.0004, 5.5, 6.0, 0.9, 1, 2, 3]])
    assert path.read_bytes() == (b"1,7,10.000,20.500,30.000,40.000,-1,-1,-1,-1\n"
                                 b"2,12,-1.235,0.000,5.500,6.000,-1,-1,-1,-1\n")    # columns past the 6th dropped
    write_tracks(path, [])
    assert path.read_text() == ""


def test_written_tracks_read_back_as_written(tmp_path):
    path = tmp_path / "tracks.txt"
    rows = [[1, 7, 10.0, 20.5, 30.0, 40.0], [1, 8, 0.125, 1.0, 2.0, 3.0], [3, 7, 12.0, 20.0, 30.0, 40.0]]
    write_tracks(path, rows)
    # read_mot keeps the 7th column, the flag, which a written track sets to -1.
    assert read_mot(path).tolist() == [row + [-1.0] for row in rows]


def test_frames_are_integers_from_one_to_the_largest_frame():
    assert check_frame(1.0, "here") == 1 and check_frame(float(MAX_FRAME), "here") == MAX_FRAME
    assert type(check_frame(3.0, "here")) is int
    for bad, bound in [(0.0, "frames count from 1"), (2.5, "frames count from 1"),
                       (MAX_FRAME + 1.0, f"at most {MAX_FRAME}"), (float("nan"), "frames count from 1")]:
        with pytest.raises(InitError, match=f"^here: the frame must be an integer of at least 1, got .* \\({bound}\\)$"):
            check_frame(bad, "here", InitError)


def test_box_values_may_reach_the_largest_coordinate_in_either_direction():
    check_box(-MAX_COORDINATE, MAX_COORDINATE, 0.0, MAX_COORDINATE, "here")
    check_box(0.0, 0.0, MAX_COORDINATE, MAX_COORDINATE, "here")
    with pytest.raises(TrackFileError, match="^here: the box width 2e\\+06 is beyond 1e\\+06 pixels$"):
        check_box(0.0, 0.0, 2 * MAX_COORDINATE, 1.0, "here")

