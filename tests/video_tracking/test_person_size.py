"""The person-size model: expected box size from the foot row, fitted robustly to rough boxes."""

from __future__ import annotations

import doctest

import numpy as np
import pytest

from belief_tracking import perspective
from belief_tracking.errors import TrackingError
from belief_tracking.perspective import PerspectiveScale, PersonSize

A, B, ASPECT = 0.25, 12.0, 0.4


def people(rng, count, feet=(60.0, 230.0), x_range=(20.0, 280.0)):
    """Boxes of people on the true model, with 4 % noise on the height and 8 % on the width."""
    foot = rng.uniform(*feet, count)
    height = (A * foot + B) * rng.normal(1.0, 0.04, count)
    width = ASPECT * height * rng.normal(1.0, 0.08, count)
    return np.column_stack([rng.uniform(*x_range, count), foot - height, width, height])


def test_the_fit_recovers_the_model_from_noisy_boxes_with_merges_fragments_and_tall_blobs():
    rng = np.random.default_rng(11)
    boxes = people(rng, 160)
    wild = people(rng, 45)
    wild[:15, 2] *= 2.2                              # two people side by side: one wide blob
    wild[15:30, 1] += 0.6 * wild[15:30, 3]            # legs alone: a fragment on the right row
    wild[15:30, 3] *= 0.4
    wild[30:, 1] -= 0.7 * wild[30:, 3]               # a person further back on top: a tall blob
    wild[30:, 3] *= 1.7
    candidates = np.vstack([boxes, wild])[rng.permutation(205)]
    size = PersonSize.fit(candidates)
    assert size.a == pytest.approx(A, abs=0.02)
    assert size.b == pytest.approx(B, abs=3.0)
    assert size.aspect == pytest.approx(ASPECT, abs=0.02)
    width, height = size.expected([100.0, 200.0])
    assert height == pytest.approx([A * 100 + B, A * 200 + B], rel=0.04)


def test_groups_one_behind_the_other_near_the_camera_do_not_tilt_the_slope():
    rng = np.random.default_rng(14)
    groups = people(rng, 50, feet=(190.0, 230.0))   # near the camera, each with a head above it
    groups[:, 1] -= 0.7 * groups[:, 3]
    groups[:, 3] *= 1.7
    size = PersonSize.fit(np.vstack([people(rng, 120), groups]))
    # Least squares, even refitted on the boxes near it, would give a = 0.6 here.
    assert size.a == pytest.approx(A, abs=0.02) and size.b == pytest.approx(B, abs=3.0)


def test_people_all_on_one_row_give_a_constant_size():
    rng = np.random.default_rng(12)
    boxes = people(rng, 30, feet=(150.0, 154.0))
    size = PersonSize.fit(boxes)
    assert size.a == 0.0
    assert size.b == pytest.approx(A * 152 + B, rel=0.03)
    width, height = size.expected([0.0, 239.0])
    assert height[0] == height[1] and width[0] == pytest.approx(ASPECT * height[0], rel=0.05)


def test_a_slope_that_is_no_ground_plane_gives_a_constant_size():
    # Heights that shrink towards the camera: no camera looking down on a flat ground.
    foot = np.array([80.0, 120.0, 160.0, 200.0, 240.0])
    height = 90.0 - 0.2 * foot
    boxes = np.column_stack([10 * np.arange(5), foot - height, 0.4 * height, height])
    size = PersonSize.fit(boxes)
    assert size.a == 0.0 and size.b == pytest.approx(np.median(height))


def test_boxes_cut_by_the_image_border_are_left_out():
    rng = np.random.default_rng(13)
    boxes = people(rng, 20, x_range=(40.0, 200.0))
    cut = people(rng, 20, x_range=(0.0, 0.0))       # at the left edge, half in view: half as wide
    cut[:, 2] *= 0.5
    size = PersonSize.fit(np.vstack([boxes, cut]), (240, 320))
    assert size.aspect == pytest.approx(ASPECT, abs=0.03)
    without_shape = PersonSize.fit(np.vstack([boxes, cut]))
    assert without_shape.aspect < ASPECT - 0.03


def test_too_few_usable_boxes_give_no_model():
    assert PersonSize.fit(np.zeros((0, 4))) is None
    assert PersonSize.fit([[10, 10, 10, 30], [30, 40, 10, 30]]) is None
    # Wider than tall: groups or shadows, never used.
    assert PersonSize.fit([[10, 10, 40, 30], [60, 40, 40, 30], [110, 80, 40, 30]]) is None
    assert PersonSize.fit([[10, 10, 10, 30], [30, 40, 10, 30]], min_boxes=2) is not None


def test_plausible_boxes_are_within_the_factor_both_ways():
    size = PersonSize(0.2, 20.0, 0.4)                  # feet at row 200: 60 x 24
    boxes = [[0, 140, 24, 60], [0, 100, 24, 100], [0, 170, 24, 30], [0, 140, 50, 60], [0, 140, 14, 60]]
    assert size.plausible(boxes).tolist() == [True, False, False, False, False]
    assert size.plausible(boxes, factor=2.5).tolist() == [True, True, True, True, True]
    assert size.plausible(np.zeros((0, 4))).shape == (0,)


def test_the_height_model_is_a_perspective_scale():
    size = PersonSize(0.2, 20.0, 0.4)
    scale = size.scale
    assert isinstance(scale, PerspectiveScale) and (scale.a, scale.b) == (0.2, 20.0)


def test_expected_heights_are_at_least_one_pixel():
    width, height = PersonSize(0.5, -50.0, 0.4).expected(np.array([0.0, 200.0]))
    assert height.tolist() == [1.0, 50.0] and width.tolist() == [1.0, 20.0]


@pytest.mark.parametrize("call, message", [
    (lambda: PersonSize(2.5, 0.0, 0.4), r"PersonSize.a must lie in \[0, 2\)"),
    (lambda: PersonSize(0.1, float("inf"), 0.4), "PersonSize.b must be a finite number"),
    (lambda: PersonSize(0.1, 10.0, 0.0), "PersonSize.aspect must be positive"),
    (lambda: PersonSize(True, 10.0, 0.4), "PersonSize.a must be a finite number"),
    (lambda: PersonSize.fit([[0, 0, 10, np.nan]]), "not finite"),
    (lambda: PersonSize.fit([[0, 0, -1, 10]]), "both must be positive"),
    (lambda: PersonSize.fit([[0, 0, 10]]), "person boxes"),
    (lambda: PersonSize.fit([[0, 0, 10, 30]], min_boxes=1), "min_boxes must be an integer >= 2"),
    (lambda: PersonSize.fit([[0, 0, 10, 30]], border=-1), "border must be a finite number >= 0"),
    (lambda: PersonSize.fit([[0, 0, 10, 30]], (240,)), "image_shape must be"),
    (lambda: PersonSize(0.1, 10.0, 0.4).expected([1.0, np.nan]), "foot rows must be finite numbers"),
    (lambda: PersonSize(0.1, 10.0, 0.4).expected("row 3"), "foot rows must be finite numbers"),
    (lambda: PersonSize(0.1, 10.0, 0.4).plausible([[0, 0, 10, 30]], factor=0.5), "factor must be"),
])
def test_bad_input_is_refused(call, message):
    with pytest.raises(TrackingError, match=message):
        call()


def test_docstring_examples():
    result = doctest.testmod(perspective, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
