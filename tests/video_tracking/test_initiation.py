"""Automatic track initiation and termination from the foreground mask (SPEC B.4, L modules 2, 3, 5)."""

from __future__ import annotations

import doctest
from dataclasses import replace

import numpy as np
import pytest

from plugins.video_tracking import initiation
from plugins.video_tracking.errors import TrackingError
from plugins.video_tracking.initiation import (
    InitiationConfig,
    Initiator,
    foreground_blobs,
    foreground_fraction,
)
from plugins.video_tracking.scenes import BackgroundStyle, Lighting, entering_leaving, render

H, W = 60, 80  # the small image of most tests: 4800 pixels, so the default min area is 9.6 px


def empty_mask() -> np.ndarray:
    return np.zeros((H, W), bool)


def mask_with(*boxes) -> np.ndarray:
    """A mask with the (x, y, w, h) rectangles set to foreground (clipped to the image)."""
    mask = empty_mask()
    for x, y, w, h in boxes:
        mask[max(y, 0):max(y + h, 0), max(x, 0):max(x + w, 0)] = True
    return mask


# -- the module's own examples (plugins/ is outside pytest's doctest paths) ------------------------------

def test_the_docstring_examples_run():
    result = doctest.testmod(initiation, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 10
    assert result.failed == 0


# -- blobs ---------------------------------------------------------------------------------------------

def test_the_opening_removes_a_two_by_two_speck_and_keeps_a_three_by_three_square():
    mask = mask_with((10, 10, 3, 3), (40, 30, 2, 2))
    assert foreground_blobs(mask, 1, opening=3).tolist() == [[10, 10, 3, 3]]
    assert foreground_blobs(mask, 1, opening=0).tolist() == [[10, 10, 3, 3], [40, 30, 2, 2]]
    assert foreground_blobs(mask, 1, opening=1).tolist() == [[10, 10, 3, 3], [40, 30, 2, 2]]


def test_the_opening_cuts_a_thin_bridge_and_keeps_blobs_at_the_image_edge_whole():
    # two 5 x 5 squares joined by a 1 px line, and a 3 px wide strip along the left edge
    mask = mask_with((20, 20, 5, 5), (25, 22, 6, 1), (31, 20, 5, 5), (0, 40, 3, 10))
    assert foreground_blobs(mask, 1, opening=0).tolist() == [[0, 40, 3, 10], [20, 20, 16, 5]]
    assert foreground_blobs(mask, 1, opening=3).tolist() == [[0, 40, 3, 10], [20, 20, 5, 5], [31, 20, 5, 5]]
    # the border counts as foreground for the erosion: a 2 px strip along an edge survives whole,
    # while the same strip away from the edge, or a 1 px strip along it, is removed
    assert foreground_blobs(mask_with((0, 40, 2, 10)), 1, opening=3).tolist() == [[0, 40, 2, 10]]
    assert foreground_blobs(mask_with((78, 0, 2, 10)), 1, opening=3).tolist() == [[78, 0, 2, 10]]
    assert len(foreground_blobs(mask_with((30, 40, 2, 10)), 1, opening=3)) == 0
    assert len(foreground_blobs(mask_with((0, 40, 1, 10)), 1, opening=3)) == 0


def test_an_even_opening_kernel_neither_shifts_nor_grows_a_blob():
    mask = mask_with((30, 30, 2, 2), (10, 10, 4, 3))
    mask[50, 50] = True  # a single pixel: smaller than the 2 x 2 kernel
    assert foreground_blobs(mask, 1, opening=2).tolist() == [[10, 10, 4, 3], [30, 30, 2, 2]]


def test_eight_connectivity_joins_diagonal_pixels():
    mask = empty_mask()
    mask[5, 5] = mask[6, 6] = mask[7, 7] = True  # a diagonal: three blobs under 4-connectivity
    mask[5, 20] = mask[5, 22] = True  # a gap of one pixel: two blobs
    assert foreground_blobs(mask, 1, opening=0).tolist() == [[5, 5, 3, 3], [20, 5, 1, 1], [22, 5, 1, 1]]


def test_the_minimum_area_counts_blob_pixels_not_box_pixels():
    mask = mask_with((10, 10, 3, 3))
    assert len(foreground_blobs(mask, 9, opening=0)) == 1
    assert len(foreground_blobs(mask, 9.5, opening=0)) == 0
    ell = mask_with((40, 10, 1, 3), (40, 12, 3, 1))  # an L of 5 pixels in a 3 x 3 box
    assert foreground_blobs(ell, 5, opening=0).tolist() == [[40, 10, 3, 3]]
    assert len(foreground_blobs(ell, 6, opening=0)) == 0


def test_blobs_are_sorted_by_x_then_y_and_an_empty_mask_has_none():
    mask = mask_with((50, 5, 4, 4), (10, 40, 4, 4), (10, 5, 4, 4))
    assert foreground_blobs(mask, 1).tolist() == [[10, 5, 4, 4], [10, 40, 4, 4], [50, 5, 4, 4]]
    blobs = foreground_blobs(empty_mask(), 1)
    assert blobs.shape == (0, 4) and blobs.dtype == np.float64


@pytest.mark.parametrize("call", [
    lambda: foreground_blobs(np.zeros((5, 5), np.uint8), 1),
    lambda: foreground_blobs(np.zeros((5, 5, 1), bool), 1),
    lambda: foreground_blobs(np.zeros((5, 5), bool), -1),
    lambda: foreground_blobs(np.zeros((5, 5), bool), float("nan")),
    lambda: foreground_blobs(np.zeros((5, 5), bool), 1, opening=-1),
    lambda: foreground_blobs(np.zeros((5, 5), bool), 1, opening=2.5),
])
def test_bad_blob_inputs_are_rejected(call):
    with pytest.raises(TrackingError):
        call()


# -- foreground fraction -------------------------------------------------------------------------------

def test_foreground_fraction_by_hand():
    mask = np.zeros((10, 10), bool)
    mask[2:6, 2:6] = True  # 16 pixels
    boxes = [
        [0, 0, 10, 10],    # 16 / 100
        [2, 2, 4, 4],      # the square itself
        [2, 2, 8, 2],      # 8 of its 16 pixels
        [-5, -5, 9, 9],    # clipped to the 4 x 4 corner, of which rows and columns 2-3 are set
        [20, 0, 5, 5],     # entirely outside
        [1.6, 2, 2, 1],    # pixel centres 2.5 and 3.5 are in [1.6, 3.6): two set pixels
        [3, 3, 0, 4],      # no width, no pixel
    ]
    assert foreground_fraction(mask, boxes).tolist() == [0.16, 1.0, 0.5, 0.25, 0.0, 1.0, 0.0]


def test_foreground_fraction_agrees_with_counting_pixel_centres():
    rng = np.random.default_rng(3)
    mask = rng.random((23, 31)) < 0.4
    boxes = np.column_stack([rng.uniform(-10, 35, 200), rng.uniform(-10, 28, 200),
                             rng.uniform(0.5, 20, 200), rng.uniform(0.5, 20, 200)])
    rows, cols = np.mgrid[0:23, 0:31]
    expected = []
    for x, y, w, h in boxes:
        inside = (cols + 0.5 >= x) & (cols + 0.5 < x + w) & (rows + 0.5 >= y) & (rows + 0.5 < y + h)
        expected.append(mask[inside].mean() if inside.any() else 0.0)
    assert np.allclose(foreground_fraction(mask, boxes), expected, rtol=0, atol=1e-12)


def test_foreground_fraction_of_no_boxes_and_bad_inputs():
    assert foreground_fraction(empty_mask(), np.zeros((0, 4))).shape == (0,)
    with pytest.raises(TrackingError):
        foreground_fraction(empty_mask(), [[0, 0, 1, float("inf")]])
    with pytest.raises(TrackingError):
        foreground_fraction(empty_mask(), [[0, 0, 1]])
    with pytest.raises(TrackingError):
        foreground_fraction(empty_mask().astype(np.uint8), [[0, 0, 1, 1]])


# -- births --------------------------------------------------------------------------------------------

def test_a_blob_entering_at_the_left_border_is_born_at_its_third_consecutive_frame():
    init = Initiator(InitiationConfig(), (H, W))
    assert init.update(empty_mask(), {}) == ([], [])  # the empty first frame
    results = [init.update(mask_with((0, 20, right, 20)), {}) for right in (4, 6, 8)]
    assert results[0] == ([], []) and results[1] == ([], [])
    assert results[2] == ([(0.0, 20.0, 8.0, 20.0)], [])
    assert init.candidates == []  # the born blob is no longer a candidate
    assert init.frames_seen == 4
    # if no track takes the blob over, it must be seen for three more frames to be born again
    again = [init.update(mask_with((0, 20, 8, 20)), {})[0] for _ in range(3)]
    assert again == [[], [], [(0.0, 20.0, 8.0, 20.0)]]


def test_candidate_counts_grow_while_the_blob_is_seen_and_restart_after_a_gap():
    init = Initiator(InitiationConfig(), (H, W))
    init.update(empty_mask(), {})
    init.update(mask_with((0, 20, 4, 20)), {})
    init.update(mask_with((0, 20, 6, 20)), {})
    assert init.candidates == [((0.0, 20.0, 6.0, 20.0), 2)]
    assert init.update(empty_mask(), {}) == ([], [])  # not seen: the candidate is dropped
    assert init.candidates == []
    births = [init.update(mask_with((0, 20, 8, 20)), {})[0] for _ in range(3)]
    assert births == [[], [], [(0.0, 20.0, 8.0, 20.0)]]


def test_a_candidate_is_followed_while_it_moves_inside_the_border_zone():
    init = Initiator(InitiationConfig(), (H, W))
    init.update(empty_mask(), {})
    # a blob at the right edge moving left by 4 px a frame: IoU 24 / 120 < 0.3, but the centres are
    # 4 px apart, within half the blob's diagonal (6.7 px)
    births = [init.update(mask_with((x, 30, 6, 12)), {})[0] for x in (74, 70, 66)]
    assert births == [[], [], [(66.0, 30.0, 6.0, 12.0)]]
    # a blob that jumps farther than half its diagonal starts a new candidate
    init = Initiator(InitiationConfig(), (H, W))
    init.update(empty_mask(), {})
    births = [init.update(mask_with(box), {})[0] for box in [(0, 5, 4, 4), (0, 40, 4, 4), (0, 40, 4, 4)]]
    assert births == [[], [], []]
    assert init.candidates == [((0.0, 40.0, 4.0, 4.0), 2)]


def test_a_blob_that_leaves_the_border_zone_before_its_third_frame_is_not_born():
    init = Initiator(InitiationConfig(border=10), (H, W))
    init.update(empty_mask(), {})
    init.update(mask_with((6, 20, 6, 20)), {})   # columns 6-11 meet the zone (columns 0-9)
    init.update(mask_with((9, 20, 6, 20)), {})   # column 9 still does
    assert init.update(mask_with((10, 20, 6, 20)), {}) == ([], [])  # column 10 does not
    assert init.candidates == []


def test_a_blob_in_the_middle_is_born_only_on_the_first_frame():
    middle = mask_with((35, 25, 8, 10))
    later = Initiator(InitiationConfig(), (H, W))
    later.update(empty_mask(), {})
    assert all(later.update(middle, {}) == ([], []) for _ in range(10))
    at_once = Initiator(InitiationConfig(), (H, W))
    assert at_once.update(middle, {}) == ([(35.0, 25.0, 8.0, 10.0)], [])
    assert at_once.update(middle, {1: (35.0, 25.0, 8.0, 10.0)}) == ([], [])
    not_first = Initiator(InitiationConfig(first_frame=False), (H, W))
    assert all(not_first.update(middle, {}) == ([], []) for _ in range(10))


def test_first_frame_births_skip_blobs_covered_by_a_track_and_border_blobs_wait_without_it():
    mask = mask_with((35, 25, 8, 10), (5, 5, 6, 6), (0, 40, 5, 10))
    init = Initiator(InitiationConfig(), (H, W))
    assert init.update(mask, {4: (4.0, 4.0, 8.0, 8.0)}) == ([(0.0, 40.0, 5.0, 10.0), (35.0, 25.0, 8.0, 10.0)], [])
    waiting = Initiator(InitiationConfig(first_frame=False), (H, W))
    assert [waiting.update(mask, {})[0] for _ in range(3)] == [[], [], [(0.0, 40.0, 5.0, 10.0), (5.0, 5.0, 6.0, 6.0)]]


@pytest.mark.parametrize("track, born", [
    ((0.0, 20.0, 8.0, 20.0), False),    # the blob's own box
    ((0.0, 18.0, 30.0, 30.0), False),   # a large box: IoU 160 / 900 >= 0.1
    ((-20.0, 0.0, 60.0, 60.0), False),  # a huge box: IoU 160 / 3600 < 0.1, but the blob lies inside it
    ((1.0, 22.0, 5.0, 10.0), False),    # a smaller box inside the blob: IoU 50 / 160 >= 0.1
    ((2.0, 25.0, 3.0, 5.0), True),      # a tiny box inside the blob: IoU 15 / 160 < 0.1, 15 / 160 of the blob
    ((7.0, 20.0, 10.0, 20.0), True),    # a neighbour sharing one column: IoU 20 / 340, 20 / 160 of the blob
])
def test_a_blob_covered_by_a_track_is_not_born(track, born):
    init = Initiator(InitiationConfig(), (H, W))
    init.update(empty_mask(), {})
    mask = mask_with((0, 20, 8, 20))
    results = [init.update(mask, {1: track}) for _ in range(3)]
    assert results[2][0] == ([(0.0, 20.0, 8.0, 20.0)] if born else [])


def test_appear_frames_of_one_gives_an_immediate_birth():
    init = Initiator(InitiationConfig(appear_frames=1), (H, W))
    init.update(empty_mask(), {})
    assert init.update(mask_with((70, 50, 10, 10)), {}) == ([(70.0, 50.0, 10.0, 10.0)], [])


# -- deaths --------------------------------------------------------------------------------------------

def test_a_track_moving_out_of_the_image_dies_after_exit_frames():
    init = Initiator(InitiationConfig(), (H, W))
    init.update(empty_mask(), {})
    # the person has left; the estimate moves left from centre x = 6 (in the zone) to outside
    deaths = [init.update(empty_mask(), {3: (x, 20.0, 8.0, 20.0)})[1] for x in (2.0, -1.0, -4.0)]
    assert deaths == [[], [], [3]]


def test_a_track_at_the_border_with_foreground_lives_and_an_empty_streak_must_be_unbroken():
    init = Initiator(InitiationConfig(), (H, W))
    init.update(empty_mask(), {})
    box = (74.0, 20.0, 8.0, 20.0)  # centre x = 78, in the right zone
    seen = mask_with((74, 20, 6, 20))
    assert all(init.update(seen, {5: box})[1] == [] for _ in range(10))
    sequence = [empty_mask(), empty_mask(), seen, empty_mask(), empty_mask(), empty_mask()]
    assert [init.update(m, {5: box})[1] for m in sequence] == [[], [], [], [], [], [5]]


def test_a_track_with_little_foreground_lives_and_below_the_threshold_dies():
    box = (0.0, 20.0, 10.0, 10.0)  # 100 pixels, centre in the zone
    just_enough = mask_with((0, 20, 10, 1))  # 10 %: not below 0.1
    too_little = mask_with((0, 20, 9, 1))  # 9 %
    init = Initiator(InitiationConfig(), (H, W))
    assert all(init.update(just_enough, {1: box})[1] == [] for _ in range(10))
    assert [init.update(too_little, {1: box})[1] for _ in range(3)] == [[], [], [1]]


def test_a_track_that_loses_its_foreground_in_the_middle_dies_after_lost_frames_and_not_before():
    init = Initiator(InitiationConfig(), (H, W))
    box = (35.0, 20.0, 10.0, 20.0)
    init.update(mask_with((35, 20, 10, 20)), {2: box})
    deaths = [init.update(empty_mask(), {2: box})[1] for _ in range(25)]
    assert deaths[:24] == [[]] * 24  # far from the border the exit rule does not apply
    assert deaths[24] == [2]


def test_lost_frames_none_keeps_a_track_without_foreground_away_from_the_border():
    init = Initiator(InitiationConfig(lost_frames=None), (H, W))
    box = (35.0, 20.0, 10.0, 20.0)
    assert all(init.update(empty_mask(), {2: box})[1] == [] for _ in range(100))
    assert init.update(empty_mask(), {2: (-8.0, 20.0, 10.0, 20.0)})[1] == []  # the exit rule still works
    assert init.update(empty_mask(), {2: (-8.0, 20.0, 10.0, 20.0)})[1] == []
    assert init.update(empty_mask(), {2: (-8.0, 20.0, 10.0, 20.0)})[1] == [2]


def test_counters_are_per_track_and_forgotten_when_a_track_is_no_longer_given():
    init = Initiator(InitiationConfig(), (H, W))
    out = (-10.0, 20.0, 8.0, 20.0)
    assert init.update(empty_mask(), {1: out, 9: out})[1] == []
    assert init.update(empty_mask(), {1: out, 9: out})[1] == []
    assert init.update(empty_mask(), {9: out})[1] == [9]  # track 1 is not given: its streak is forgotten
    assert [init.update(empty_mask(), {1: out, 7: out})[1] for _ in range(3)] == [[], [], [1, 7]]


def test_deaths_are_sorted_and_dead_tracks_start_afresh_if_given_again():
    init = Initiator(InitiationConfig(exit_frames=1), (H, W))
    out = (90.0, 20.0, 8.0, 20.0)
    assert init.update(empty_mask(), {12: out, 3: out, 7: (35.0, 20.0, 8.0, 8.0)})[1] == [3, 12]
    assert init.update(empty_mask(), {3: out})[1] == [3]


def test_reset_forgets_candidates_counters_and_the_first_frame():
    init = Initiator(InitiationConfig(), (H, W))
    init.update(empty_mask(), {})
    init.update(mask_with((0, 20, 4, 20)), {1: (-10.0, 0.0, 5.0, 5.0)})
    init.reset()
    assert init.frames_seen == 0 and init.candidates == []
    assert init.update(mask_with((35, 25, 8, 10)), {}) == ([(35.0, 25.0, 8.0, 10.0)], [])


# -- a whole scene -------------------------------------------------------------------------------------

def test_every_walker_of_the_entering_leaving_scene_is_born_at_the_border_and_ends_after_leaving():
    config = replace(entering_leaving(0), background=BackgroundStyle.flat((0, 0, 0)), noise_std=0.0,
                     lighting=Lighting())
    scene = render(config)
    walkers = {w.id: w for w in config.walkers}
    init = Initiator(InitiationConfig(), scene.frames.shape[1:])
    tracks: dict[int, int] = {}  # track id -> walker id, followed by a perfect tracker
    born_at, died_at = {}, {}
    for t, frame in enumerate(scene.frames):
        mask = frame.any(axis=2)
        boxes = {track: tuple(float(v) for v in walkers[walker].box_at(t)) for track, walker in tracks.items()}
        births, deaths = init.update(mask, boxes)
        for track in deaths:
            died_at[tracks.pop(track)] = t
        truth = scene.boxes_at(t)
        for box in births:
            walker = next(i for i, b in truth.items() if tuple(float(v) for v in b) == box)  # the exact GT box
            assert walker not in born_at
            born_at[walker] = t
            tracks[len(born_at)] = walker
    for walker in walkers:
        frames = scene.ground_truth[scene.ground_truth[:, 1] == walker, 0] - 1
        first, last = int(frames[0]), int(frames[-1])
        # the first frame shows a 2 px sliver (80-100 pixels), smaller than the minimum area of
        # 153.6 pixels; from the next frame on the blob is large enough, and the third is the birth
        assert born_at[walker] == first + 3
        assert died_at[walker] == last + 3  # the box holds no foreground from the frame after the last
    assert tracks == {}  # no track is left on a departed walker


# -- configuration and input errors --------------------------------------------------------------------

@pytest.mark.parametrize("field, value", [
    ("border", -1), ("border", 2.5), ("border", True),
    ("min_area", -0.1), ("min_area", 1.5), ("min_area", float("nan")), ("min_area", "0.1"),
    ("opening", -1), ("opening", 3.0),
    ("max_iou", 0.0), ("max_iou", 1.2),
    ("appear_frames", 0), ("appear_frames", 1.5),
    ("exit_frames", 0),
    ("exit_foreground", 0.0), ("exit_foreground", 2.0),
    ("lost_frames", 0), ("lost_frames", 2.5),
    ("first_frame", "yes"), ("first_frame", 1),
])
def test_bad_configurations_name_the_field(field, value):
    with pytest.raises(TrackingError, match=f"InitiationConfig.{field} "):
        InitiationConfig(**{field: value})


def test_good_edge_settings_are_accepted():
    config = InitiationConfig(border=0, min_area=0, opening=0, max_iou=1, appear_frames=1, exit_frames=1,
                              exit_foreground=1, lost_frames=None, first_frame=False)
    assert config.lost_frames is None and config.min_area == 0.0
    assert InitiationConfig(min_area=np.float32(0.01), border=np.int64(4)).border == 4


@pytest.mark.parametrize("shape", [(0, 5), (5,), (5, 5, 3, 1), "abc", (5.0, 5), None])
def test_bad_image_shapes_are_rejected(shape):
    with pytest.raises(TrackingError, match="image_shape"):
        Initiator(InitiationConfig(), shape)


def test_an_image_shape_with_channels_is_accepted_and_a_bad_config_is_not():
    assert Initiator(None, (H, W, 3)).image_shape == (H, W)
    with pytest.raises(TrackingError, match="InitiationConfig"):
        Initiator({"border": 3}, (H, W))


@pytest.mark.parametrize("mask, tracks, message", [
    (np.zeros((H, W), np.uint8), {}, "bool array of shape"),
    (np.zeros((W, H), bool), {}, "bool array of shape"),
    (np.zeros((H, W), bool), [(0, 0, 1, 1)], "dict"),
    (np.zeros((H, W), bool), {"a": (0, 0, 1, 1)}, "a track id must be an integer"),
    (np.zeros((H, W), bool), {True: (0, 0, 1, 1)}, "a track id must be an integer"),
    (np.zeros((H, W), bool), {1: (0, 0, 1)}, r"track boxes: boxes must have shape \(n, 4\)"),
    (np.zeros((H, W), bool), {1: "box"}, "track boxes: boxes must be numbers"),
    (np.zeros((H, W), bool), {1: (0, float("nan"), 1, 1)}, "not finite"),
    (np.zeros((H, W), bool), {1: (0, 0, 0, 1)}, "both must be positive"),
])
def test_bad_update_inputs_are_rejected(mask, tracks, message):
    init = Initiator(InitiationConfig(), (H, W))
    with pytest.raises(TrackingError, match=message):
        init.update(mask, tracks)
    assert init.frames_seen == 0  # a rejected frame does not count
