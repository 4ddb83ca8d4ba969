"""People's boxes from a foreground mask: fragments merged, groups split, tall blobs cut."""

from __future__ import annotations

import doctest

import numpy as np
import pytest

from belief_tracking import blobs
from belief_tracking.blobs import box_mask, fit_person_size, person_boxes
from belief_tracking.boxes import iou
from belief_tracking.errors import TrackingError
from belief_tracking.initiation import foreground_blobs
from belief_tracking.perspective import PersonSize

H, W = 240, 320
SIZE = PersonSize(0.25, 10.0, 0.4)          # feet on row 200: 60 x 24 px
MIN_AREA = 0.002 * H * W


def person(mask, centre_x, foot, scale=1.0, legs_apart=False):
    """Draw a person of the model's size at their foot row: a narrower head, a body, maybe two legs."""
    width, height = (float(v) * scale for v in SIZE.expected(foot))
    w, h = int(round(width)), int(round(height))
    x, y = int(round(centre_x - w / 2)), foot - h
    head = int(round(0.45 * w))
    mask[y:y + h // 5, x + (w - head) // 2:x + (w - head) // 2 + head] = True
    mask[y + h // 5:foot, x:x + w] = True
    if legs_apart:
        mask[foot - int(0.4 * h):foot, x + w // 2 - 2:x + w // 2 + 2] = False
    return np.array([x, y, w, h], dtype=np.float64)


def empty():
    return np.zeros((H, W), bool)


def matched(found, truth, threshold=0.8):
    """Whether every true box has a found box with an IoU of at least ``threshold``."""
    return len(found) > 0 and bool((iou(np.asarray(truth), found).max(axis=1) >= threshold).all())


# -- splits and cuts -------------------------------------------------------------------------------
@pytest.mark.parametrize("count", [2, 3])
def test_people_side_by_side_are_split(count):
    mask = empty()
    truth = [person(mask, 100 + 24 * k, 200) for k in range(count)]
    plain = person_boxes(mask, min_area_pixels=MIN_AREA)
    assert len(plain) == 1                                  # one blob for the whole group
    found = person_boxes(mask, SIZE, min_area_pixels=MIN_AREA)
    assert len(found) == count and matched(found, truth)


def test_split_width_says_how_many_people_wide_a_blob_must_be_to_be_split():
    mask = empty()
    mask[140:200, 100:136] = True                            # 36 px wide where a person is 24: 1.5 people
    assert person_boxes(mask, SIZE, min_area_pixels=MIN_AREA).tolist() == [[100.0, 140.0, 36.0, 60.0]]
    # At split_width 1.4 (33.6 px) it is split into round(36 / 24) = 2 halves at the even cut, 18 px.
    assert person_boxes(mask, SIZE, min_area_pixels=MIN_AREA, split_width=1.4).tolist() == [
        [100.0, 140.0, 18.0, 60.0], [118.0, 140.0, 18.0, 60.0]]


def test_a_person_a_little_wider_than_expected_is_not_split():
    mask = empty()
    truth = person(mask, 150, 200, scale=1.3)
    found = person_boxes(mask, SIZE, min_area_pixels=MIN_AREA)
    assert len(found) == 1 and matched(found, [truth], 0.95)


def test_the_gap_between_the_legs_does_not_split_a_person():
    mask = empty()
    truth = person(mask, 150, 200, legs_apart=True)
    found = person_boxes(mask, SIZE, min_area_pixels=MIN_AREA)
    assert len(found) == 1 and matched(found, [truth], 0.95)


def test_a_person_in_front_of_another_is_told_apart_by_their_feet():
    mask = empty()
    behind = person(mask, 140, 150)                         # 47 x 19
    front = person(mask, 155, 200)                          # 60 x 24, overlaps the first
    assert len(person_boxes(mask, min_area_pixels=MIN_AREA)) == 1
    found = person_boxes(mask, SIZE, min_area_pixels=MIN_AREA)
    assert len(found) == 2 and matched(found, [behind, front])


def test_a_blob_taller_than_a_person_is_cut_keeping_the_feet():
    mask = empty()
    mask[100:200, 140:164] = True                           # 100 rows where a person has 60
    found = person_boxes(mask, SIZE, min_area_pixels=MIN_AREA)
    # The feet stay; the 40 rows left above are a person further back (at least half their height).
    assert found.tolist() == [[140.0, 100.0, 24.0, 40.0], [140.0, 140.0, 24.0, 60.0]]
    mask[:] = False
    mask[125:200, 140:164] = True                           # 75 rows: 15 rows above are dropped
    assert person_boxes(mask, SIZE, min_area_pixels=MIN_AREA, max_height=1.2).tolist() == [
        [140.0, 140.0, 24.0, 60.0]]
    assert person_boxes(mask, SIZE, min_area_pixels=MIN_AREA).tolist() == [[140.0, 125.0, 24.0, 75.0]]


def test_no_box_grows_beyond_a_plausible_size_for_its_row():
    rng = np.random.default_rng(21)
    mask = empty()
    for _ in range(12):
        person(mask, rng.uniform(30, 290), int(rng.uniform(80, 235)))
    found = person_boxes(mask, SIZE, min_area_pixels=MIN_AREA)
    inside = (found[:, 0] > 1) & (found[:, 1] > 1) & (found[:, 0] + found[:, 2] < W - 1) \
        & (found[:, 1] + found[:, 3] < H - 1)
    widths, heights = SIZE.expected(found[:, 1] + found[:, 3])
    assert (found[inside, 3] <= 1.5 * heights[inside]).all()
    assert (found[inside, 2] < 1.7 * widths[inside] + 1).all()


# -- fragments -------------------------------------------------------------------------------------
def test_a_person_cut_in_two_by_background_coloured_clothes_is_merged():
    mask = empty()
    truth = person(mask, 150, 200)
    mask[155:170] = False                                    # a band across the middle of the body
    assert len(person_boxes(mask, min_area_pixels=MIN_AREA)) == 2   # the band is too wide to merge blindly
    found = person_boxes(mask, SIZE, min_area_pixels=MIN_AREA)
    assert len(found) == 1 and matched(found, [truth], 0.95)


def test_without_a_size_model_only_a_thin_band_is_merged():
    mask = empty()
    truth = person(mask, 150, 200)
    mask[160:162] = False
    found = person_boxes(mask, min_area_pixels=MIN_AREA, opening=0)
    assert len(found) == 1 and matched(found, [truth], 0.95)


def test_two_whole_people_one_above_the_other_are_not_merged():
    mask = empty()
    truth = [person(mask, 150, 120), person(mask, 150, 190)]
    found = person_boxes(mask, SIZE, min_area_pixels=MIN_AREA)
    assert len(found) == 2 and matched(found, truth, 0.95)
    assert len(person_boxes(mask, min_area_pixels=MIN_AREA)) == 2


def test_small_blobs_inside_the_image_are_dropped_with_a_size_model():
    mask = empty()
    mask[180:200, 100:130] = True                           # a shadow on the ground: 20 rows of 60
    mask[150:160, 200:206] = True                           # a speck
    mask[150:200, 0:6] = True                               # a person walking in at the left edge
    found = person_boxes(mask, SIZE, min_area_pixels=MIN_AREA)
    assert found.tolist() == [[0.0, 150.0, 6.0, 50.0]]


def test_without_a_size_model_the_boxes_are_the_blobs():
    rng = np.random.default_rng(22)
    mask = rng.random((H, W)) < 0.02                        # noise, removed by the opening
    for x in range(10, 300, 40):
        top = int(rng.integers(10, 150))
        mask[top:top + int(rng.integers(8, 80)), x:x + int(rng.integers(4, 30))] = True
    expected = foreground_blobs(mask, MIN_AREA, 3)
    assert np.array_equal(person_boxes(mask, min_area_pixels=MIN_AREA), expected)
    assert person_boxes(empty(), SIZE, min_area_pixels=MIN_AREA).shape == (0, 4)


# -- helpers ---------------------------------------------------------------------------------------
def test_box_mask_marks_the_pixels_under_the_boxes():
    mask = box_mask((H, W, 3), [[10.0, 20.0, 5.0, 4.0], [-10.0, -10.0, 12.0, 12.0]])
    assert mask.shape == (H, W) and mask.sum() == 20 + 4
    assert mask[20:24, 10:15].all() and mask[:2, :2].all()
    assert not box_mask((H, W), np.zeros((0, 4))).any()


def test_the_size_model_is_fitted_from_the_blobs_of_several_masks():
    rng = np.random.default_rng(23)
    masks = []
    for _ in range(8):
        mask = empty()
        for k in range(4):
            person(mask, 40 + 75 * k + rng.uniform(-10, 10), int(rng.uniform(80, 230)))
        person(mask, 5, 180)                                  # cut by the image border
        masks.append(mask)
    size = fit_person_size(masks, min_area_pixels=MIN_AREA)
    assert size.a == pytest.approx(SIZE.a, abs=0.03)
    assert size.aspect == pytest.approx(SIZE.aspect, abs=0.04)
    assert fit_person_size([], min_area_pixels=MIN_AREA) is None
    with pytest.raises(TrackingError, match="the masks differ in shape"):
        fit_person_size([empty(), np.zeros((10, 10), bool)], min_area_pixels=MIN_AREA)


@pytest.mark.parametrize("call, message", [
    (lambda: person_boxes(np.zeros((H, W), np.uint8), min_area_pixels=1), "must be a non-empty 2-D bool array"),
    (lambda: person_boxes(np.zeros((0, 5), bool), min_area_pixels=1), "must be a non-empty 2-D bool array"),
    (lambda: person_boxes(empty(), min_area_pixels=-1), "min_area_pixels must be a finite number >= 0"),
    (lambda: person_boxes(empty(), min_area_pixels=1, opening=-1), "opening must be an integer >= 0"),
    (lambda: person_boxes(empty(), min_area_pixels=1, split_width=1.0), "split_width must be a finite number > 1"),
    (lambda: person_boxes(empty(), min_area_pixels=1, max_height=np.inf), "max_height must be a finite number"),
    (lambda: person_boxes(empty(), (0.2, 10, 0.4), min_area_pixels=1), "size_model must be a PersonSize"),
    (lambda: box_mask((H,), [[0, 0, 1, 1]]), "image_shape must be"),
    (lambda: box_mask((H, W), [[0, 0, 1, np.nan]]), "not finite"),
])
def test_bad_input_is_refused(call, message):
    with pytest.raises(TrackingError, match=message):
        call()


def test_docstring_examples():
    result = doctest.testmod(blobs, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
