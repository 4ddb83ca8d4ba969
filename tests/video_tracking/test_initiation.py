"""Automatic track initiation and termination from the foreground mask (SPEC B.4, L modules 2, 3, 5)."""

from __future__ import annotations


import numpy as np
import pytest

from belief_tracking.errors import InitError, TrackingError
from belief_tracking.initiation import (
    InitiationConfig,
    InitPlan,
    TargetInit,
    foreground_blobs,
    foreground_fraction,
    init_from_boxes,
    init_from_gt,
    read_init_boxes,
)

H, W = 60, 80  # the small image of most tests: 4800 pixels, so the default min area is 9.6 px


def empty_mask() -> np.ndarray:
    return np.zeros((H, W), bool)


def mask_with(*boxes) -> np.ndarray:
    """A mask with the (x, y, w, h) rectangles set to foreground (clipped to the image)."""
    mask = empty_mask()
    for x, y, w, h in boxes:
        mask[max(y, 0):max(y + h, 0), max(x, 0):max(x + w, 0)] = True
    return mask


# -- init plans ----------------------------------------------------------------------------------------

def target(id, first, last=None, box=(0, 0, 2, 2)):
    return TargetInit(id, first, last, box)


def test_a_plan_orders_its_targets_by_birth_then_id_and_lists_each_frame_s_births():
    plan = InitPlan((target(9, 3), target(4, 1, 5), target(2, 3, 3), target(7, 1)), source="mine")
    assert [(t.id, t.first_frame) for t in plan.targets] == [(4, 1), (7, 1), (2, 3), (9, 3)]
    assert [t.id for t in plan.births(1)] == [4, 7]
    assert [t.id for t in plan.births(3)] == [2, 9]
    assert plan.births(2) == [] and plan.births(99) == []
    plan.births(1).clear()                                   # a copy: the plan keeps its births
    assert len(plan.births(1)) == 2


def test_a_target_s_fields_are_made_plain_ints_and_floats():
    born = TargetInit(np.int64(3), np.int32(2), 2, [np.float32(1.5), 2, 3, 4])
    assert born == TargetInit(3, 2, 2, (1.5, 2.0, 3.0, 4.0))
    assert type(born.id) is int and type(born.first_frame) is int and all(type(v) is float for v in born.box)


@pytest.mark.parametrize("targets, peak", [
    ([target(1, 1, 3), target(2, 2), target(3, 4, 5)], (2, 2)),           # the docstring's plan
    ([target(1, 1, 1), target(2, 2), target(3, 2), target(4, 3)], (3, 3)),  # 1 leaves as 2 and 3 come
    ([target(1, 1, 2), target(2, 3, 4), target(3, 5)], (1, 1)),            # one at a time: never two
    ([target(1, 4), target(2, 4, 4), target(3, 5)], (2, 4)),               # 2 ends after frame 4, 3 comes at 5
])
def test_the_peak_is_the_most_targets_alive_at_once_and_when_that_first_happens(targets, peak):
    # A target is alive from its first frame to its last, both included.
    assert InitPlan(tuple(targets)).peak() == peak


def test_a_birth_box_must_share_some_area_with_the_image():
    def plan(x, y, w=10.0, h=10.0):
        return InitPlan((TargetInit(1, 1, None, (x, y, w, h)),), source="plan")

    for inside in [(0, 0), (-9.5, -9.5), (319.5, 239.5), (-5, 100)]:
        plan(*inside).check_image(320, 240)                  # reaches into the image: accepted
    for outside in [(320, 0), (0, 240), (-10, 0), (0, -10)]:
        with pytest.raises(InitError, match="lies outside the 320x240 image"):
            plan(*outside).check_image(320, 240)


def test_the_ground_truth_gives_each_id_its_first_box_0_based_and_its_last_frame():
    rows = np.array([
        [3, 5, 13, 21, 10, 20, 1],
        [1, 5, 11, 21, 10, 20, 0],      # id 5's first box, though on the second row; the flag is not used
        [2, 5, 12, 21, 10, 20, 1],
        [6, 8, 101, 51, 20, 40, 1],
        [2, 8, 100.5, 50, 20, 40, 1],   # id 8: frames 2 and 6, absent in between
    ], dtype=float)
    plan = init_from_gt(rows)
    assert [(t.id, t.first_frame, t.last_frame, t.box) for t in plan.targets] == [
        (5, 1, 3, (10.0, 20.0, 10.0, 20.0)), (8, 2, 6, (99.5, 49.0, 20.0, 40.0))]
    assert plan.source == "ground truth" and init_from_gt(rows, source="gt.txt").source == "gt.txt"


def test_the_ground_truth_may_come_from_a_file(tmp_path):
    path = tmp_path / "gt.txt"
    path.write_text("2,4,31,41,8,16,1,-1,-1,-1\n1,3,1,1,5,5,1,-1,-1,-1\n3,4,32,41,8,16,1,-1,-1,-1\n")
    plan = init_from_gt(path)
    assert [(t.id, t.first_frame, t.last_frame, t.box) for t in plan.targets] == [
        (3, 1, 1, (0.0, 0.0, 5.0, 5.0)), (4, 2, 3, (30.0, 40.0, 8.0, 16.0))]
    assert plan.source == str(path)


def test_an_init_file_gives_targets_born_at_frame_one_and_never_removed(tmp_path):
    path = tmp_path / "boxes.csv"
    # A byte-order mark, a header, a comment, a blank line and blanks around the fields.
    path.write_text("\ufeffID, X, Y, W, H\n# the two people at the door\n\n 7 , 11, 21.5 ,8,16\n2,1,1,4.5,9\n",
                    encoding="utf-8")
    plan = read_init_boxes(path)
    assert plan.targets == (TargetInit(2, 1, None, (0.0, 0.0, 4.5, 9.0)), TargetInit(7, 1, None, (10.0, 20.5, 8.0, 16.0)))
    assert plan.source == str(path)


def test_a_header_after_the_first_box_is_no_header(tmp_path):
    path = tmp_path / "boxes.csv"
    path.write_text("1,11,21,8,16\nid,x,y,w,h\n")
    with pytest.raises(InitError, match="line 2: a field is not a number"):
        read_init_boxes(path)


def test_boxes_in_code_are_numbered_from_one_unless_ids_are_given():
    plan = init_from_boxes([(10, 20, 8, 16), (0, 0, 4, 4)])
    assert [(t.id, t.first_frame, t.last_frame, t.box) for t in plan.targets] == [
        (1, 1, None, (10.0, 20.0, 8.0, 16.0)), (2, 1, None, (0.0, 0.0, 4.0, 4.0))]
    assert [t.id for t in init_from_boxes([(0, 0, 1, 1), (5, 5, 1, 1)], ids=[9, 3]).targets] == [3, 9]
    assert plan.source == "boxes"
    with pytest.raises(InitError, match="1 ids for 2 boxes"):
        init_from_boxes([(0, 0, 1, 1), (5, 5, 1, 1)], ids=[9])


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


# -- deaths --------------------------------------------------------------------------------------------


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
    ("coast_frames", -1), ("appearance_support", 1.5), ("anywhere", "no"), ("match_iou", 0.0),
    ("memory", -1), ("reid_similarity", 0.0), ("size_smoothing", 0.0), ("detection_size_smoothing", 1.5),
    ("max_aspect", 0.0), ("centre_gain", -0.1), ("duplicate_iou", 0.0), ("duplicate_frames", 0),
])
def test_bad_configurations_name_the_field(field, value):
    with pytest.raises(TrackingError, match=f"InitiationConfig.{field} "):
        InitiationConfig(**{field: value})


def test_good_edge_settings_are_accepted():
    config = InitiationConfig(border=0, min_area=0, opening=0, max_iou=1, appear_frames=1, exit_frames=1,
                              exit_foreground=1, lost_frames=None, first_frame=False)
    assert config.lost_frames is None and config.min_area == 0.0
    assert InitiationConfig(min_area=np.float32(0.01), border=np.int64(4)).border == 4




def test_foreground_fraction_of_a_few_small_boxes_counts_the_same_pixels_as_many():
    rng = np.random.default_rng(5)
    mask = rng.random((120, 160)) < 0.3
    boxes = np.column_stack([rng.uniform(-10, 165, 60), rng.uniform(-10, 125, 60),
                             rng.uniform(0.5, 12, 60), rng.uniform(0.5, 12, 60)])
    small = np.concatenate([foreground_fraction(mask, boxes[i:i + 3]) for i in range(0, 60, 3)])  # by the boxes
    whole = foreground_fraction(mask, np.vstack([boxes, [[0, 0, 160, 120]]]))[:-1]             # integral image
    assert small.tolist() == whole.tolist()
    rows, cols = np.mgrid[0:120, 0:160]
    x, y, w, h = boxes[7]
    inside = (cols + 0.5 >= x) & (cols + 0.5 < x + w) & (rows + 0.5 >= y) & (rows + 0.5 < y + h)
    assert small[7] == (mask[inside].mean() if inside.any() else 0.0)
