"""BlobCandidates: a frame's candidate boxes from its foreground mask, with a size model learnt on the way."""

from __future__ import annotations

import numpy as np
import pytest

from belief_tracking.candidates import BLOB_SCORE, BlobCandidates
from belief_tracking.initiation import InitiationConfig
from belief_tracking.perspective import PersonSize

H, W = 80, 120          # 9600 pixels: min_area 0.02 is 192 px, below a 10 x 30 person (300 px)
CONFIG = InitiationConfig(min_area=0.02)


def mask_with(*boxes) -> np.ndarray:
    """A foreground mask with the rectangles ``(x, y, w, h)`` set, well inside the image."""
    mask = np.zeros((H, W), bool)
    for x, y, w, h in boxes:
        mask[y:y + h, x:x + w] = True
    return mask


def person(x: int, foot: int = 60, width: int = 10, height: int = 30) -> tuple[int, int, int, int]:
    """A person's rectangle with the feet on row ``foot``."""
    return x, foot - height, width, height


def test_each_blob_is_a_box_with_the_blob_score():
    finder = BlobCandidates(CONFIG, (H, W), fit_every=5)
    found = finder(mask_with(person(20), person(70, width=12)))
    # Before any size model the boxes are the blobs: 10 x 30 and 12 x 30, feet on row 60.
    assert found.tolist() == [[20.0, 30.0, 10.0, 30.0, BLOB_SCORE], [70.0, 30.0, 12.0, 30.0, BLOB_SCORE]]
    assert found.dtype == np.float64 and BLOB_SCORE == 0.5
    assert finder.size is None


def test_an_empty_mask_gives_an_empty_five_column_array():
    finder = BlobCandidates(CONFIG, (H, W), fit_every=1)
    found = finder(np.zeros((H, W), bool))
    assert found.shape == (0, 5) and found.dtype == np.float64
    assert finder.size is None                              # no blob: nothing to fit


def test_a_blob_below_the_minimum_area_gives_nothing():
    finder = BlobCandidates(CONFIG, (H, W), fit_every=5)
    assert finder.min_area_pixels == pytest.approx(0.02 * H * W)            # 192 px
    # 12 x 16 = 192 px is kept, 12 x 15 = 180 px is not (after the 3 x 3 opening, which keeps rectangles).
    assert finder(mask_with((30, 40, 12, 16))).tolist() == [[30.0, 40.0, 12.0, 16.0, BLOB_SCORE]]
    assert finder(mask_with((30, 40, 12, 15))).shape == (0, 5)


def test_the_size_model_is_fitted_every_fit_every_frames():
    finder = BlobCandidates(CONFIG, (H, W), fit_every=3)
    sizes = []
    for x in (10, 30, 50, 70):
        finder(mask_with(person(x)))
        sizes.append(finder.size)
    # Three 10 x 30 boxes, all with their feet on row 60: too little spread for a slope, so the
    # model is the constant height 30 and the aspect 10 / 30 — fitted on the third frame, not before.
    assert sizes[:2] == [None, None]
    assert sizes[2] == sizes[3] == PersonSize(0.0, 30.0, 1 / 3)


def test_the_size_model_is_kept_after_fit_until_frames():
    def sizes(fit_until):
        finder = BlobCandidates(CONFIG, (H, W), fit_every=3, fit_until=fit_until)
        for k in range(6):                        # three people 10 x 30, then three 14 x 42, feet on row 60
            finder(mask_with(person(10 + 15 * k, width=10 if k < 3 else 14, height=30 if k < 3 else 42)))
        return finder.size

    assert sizes(3) == PersonSize(0.0, 30.0, 1 / 3)             # fitted on the first three, then kept
    # Refitted on all six: the median height of 30, 30, 30, 42, 42, 42 is 36; the aspect is still 1/3.
    assert sizes(6) == PersonSize(0.0, 36.0, 1 / 3)


def test_blobs_that_cannot_support_a_model_leave_it_unknown():
    finder = BlobCandidates(CONFIG, (H, W), fit_every=2)
    for _ in range(4):
        finder(mask_with((40, 40, 30, 20)))       # wider than tall: a group or a shadow, never a person's size
    assert finder.size is None


def test_two_people_in_one_blob_are_split_once_the_size_model_is_known():
    finder = BlobCandidates(CONFIG, (H, W), fit_every=3)
    pair = (60, 30, 24, 30)                       # two 12 x 30 people side by side: one blob 24 px wide
    found = [finder(mask_with(person(15 + 5 * k, width=12), pair)) for k in range(4)]
    # Frames 1 and 2: no size model, the pair is one box.  On frame 3 the model is fitted first
    # on the walker's three boxes (the pair, wider than 1 / 1.4 of its height, is no person's
    # shape and stays out of the fit), and the pair is 24 px wide where a person is 0.4 · 30 = 12:
    # at least 1.7 people wide, it is split into round(24 / 12) = 2 boxes at the middle column.
    for frame in found[:2]:
        assert frame.tolist()[1:] == [[60.0, 30.0, 24.0, 30.0, BLOB_SCORE]]
    assert finder.size == PersonSize(0.0, 30.0, 0.4)
    for frame in found[2:]:
        assert frame.tolist()[1:] == [[60.0, 30.0, 12.0, 30.0, BLOB_SCORE], [72.0, 30.0, 12.0, 30.0, BLOB_SCORE]]
