"""Boxes: the one check of the plugin and the one IoU."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from belief_tracking.boxes import box_centres, check_boxes, iou
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
