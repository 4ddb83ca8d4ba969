"""Boxes: the one check of the plugin and the one IoU."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from belief_tracking.boxes import box_centres, check_boxes, intersections, iou, pixel_ranges
from belief_tracking.errors import InitError, TrackingError

boxes = st.lists(st.tuples(st.integers(-20, 20), st.integers(-20, 20), st.integers(0, 15), st.integers(0, 15)),
                 max_size=5)


def test_iou_by_hand():
    a = [[0, 0, 2, 2], [0, 0, 4, 4]]
    b = [[1, 0, 2, 2], [1, 1, 2, 2], [2, 0, 2, 2], [10, 10, 3, 3]]
    # 2 / (4 + 4 - 2); 1 / 7; touching edges; disjoint.  Then each of the first three lies inside
    # the 4 x 4 box: 4 / 16.
    assert np.allclose(iou(a, b), [[1 / 3, 1 / 7, 0, 0], [1 / 4, 1 / 4, 1 / 4, 0]], rtol=0, atol=1e-15)
    assert iou([[3, 3, 0, 0]], [[3, 3, 0, 0]]).tolist() == [[0.0]]  # empty union
    assert iou(np.zeros((0, 4)), b).shape == (0, 4)
    with pytest.raises(TrackingError):
        iou([[0, 0, -1, 1]], b)


@given(boxes, boxes)
def test_iou_is_symmetric_bounded_and_one_only_for_equal_boxes(first, second):
    a = np.array(first, dtype=float).reshape(-1, 4)
    b = np.array(second, dtype=float).reshape(-1, 4)
    overlap = iou(a, b)
    assert overlap.shape == (len(a), len(b))
    np.testing.assert_array_equal(overlap, iou(b, a).T)
    assert ((overlap >= 0) & (overlap <= 1)).all()
    for i, j in zip(*np.nonzero(overlap == 1.0)):
        np.testing.assert_array_equal(a[i], b[j])


@pytest.mark.parametrize("value, message", [
    ([[1, 2, 3]], r"shape \(n, 4\)"),
    ([1, 2, 3, 4], r"shape \(n, 4\)"),
    ([[0, 0, np.nan, 1]], "box 0 has a value that is not finite"),
    ([[0, 0, 1, 1], [0, 0, 0, 1]], "box 1 has width 0 and height 1; both must be positive"),
    ([["a", 0, 1, 1]], "boxes must be numbers"),
])
def test_a_bad_box_is_named(value, message):
    with pytest.raises(TrackingError, match=message):
        check_boxes(value, "test boxes")


def test_the_check_names_the_boxes_raises_the_asked_error_and_returns_a_new_array():
    given_boxes = np.array([[1.0, 2.0, 3.0, 4.0]])
    checked = check_boxes(given_boxes)
    assert checked is not given_boxes and checked.tolist() == given_boxes.tolist()
    assert check_boxes([[0, 0, 0, 0]], positive=False).shape == (1, 4)
    assert check_boxes([]).shape == (0, 4)
    with pytest.raises(InitError, match="^my boxes: box 0 .* lies outside the 320x240 image$"):
        check_boxes([[-10, 0, 10, 10]], "my boxes", image_shape=(240, 320), error=InitError)


def test_centres():
    assert box_centres([[10, 20, 6, 8], [0, 0, 1, 1]]).tolist() == [[13.0, 24.0], [0.5, 0.5]]


def test_intersections_by_hand():
    a = np.array([[0.0, 0.0, 4.0, 2.0], [1.0, 1.0, 2.0, 2.0]])
    b = np.array([[2.0, 1.0, 4.0, 4.0], [0.5, 0.5, 1.0, 1.0], [4.0, 0.0, 1.0, 1.0]])
    # [0, 4) x [0, 2) and [2, 6) x [1, 5): 2 x 1; the 1 x 1 square at 0.5 lies inside; touching edges: 0.
    # [1, 3) x [1, 3) and [2, 6) x [1, 5): 1 x 2; and [0.5, 1.5) x [0.5, 1.5): 0.5 x 0.5.
    assert intersections(a, b).tolist() == [[2.0, 1.0, 0.0], [2.0, 0.25, 0.0]]
    assert intersections(a, np.zeros((0, 4))).shape == (2, 0)


def test_pixel_ranges_by_hand():
    # A pixel is in a box when its centre is: x = 0.4 takes pixel 0 (centre 0.5), x = 0.6 does not.
    boxes = np.array([[0.4, 0.6, 1.2, 1.0],        # columns 0 and 1 (centres 0.5, 1.5 < 1.6); row 1 only
                      [-3.0, 8.0, 5.0, 9.0],       # clipped: columns 0 and 1, rows 8 and 9 of a 10-row image
                      [2.0, 2.0, 0.0, 3.0],        # no width: no column
                      [12.0, 0.0, 2.0, 2.0]])      # right of a 10-column image: nothing
    x0, x1, y0, y1 = pixel_ranges(boxes, (10, 10))
    assert list(zip(x0.tolist(), x1.tolist())) == [(0, 2), (0, 2), (2, 2), (10, 10)]
    assert list(zip(y0.tolist(), y1.tolist())) == [(1, 2), (8, 10), (2, 5), (0, 2)]


@given(st.lists(st.tuples(st.floats(-5, 15), st.floats(-5, 15), st.floats(0, 12), st.floats(0, 12)),
                min_size=1, max_size=4))
def test_pixel_ranges_hold_exactly_the_pixels_whose_centre_is_in_the_box(given_boxes):
    shape = (7, 9)
    x0, x1, y0, y1 = pixel_ranges(np.array(given_boxes), shape)
    for (x, y, w, h), a, b, c, d in zip(given_boxes, x0, x1, y0, y1):
        columns = [i for i in range(shape[1]) if x <= i + 0.5 < x + w]
        rows = [j for j in range(shape[0]) if y <= j + 0.5 < y + h]
        assert list(range(a, b)) == columns and list(range(c, d)) == rows


def test_boxes_reaching_partly_outside_the_image_pass_the_image_check():
    inside = [[-5.0, -5.0, 6.0, 6.0], [319.0, 239.0, 30.0, 30.0]]
    assert check_boxes(inside, image_shape=(240, 320)).tolist() == inside
