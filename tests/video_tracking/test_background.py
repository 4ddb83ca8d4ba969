"""The background model without detections: median warm-up, protected pixels, gain and lighting changes."""

from __future__ import annotations

import doctest

import numpy as np
import pytest

from belief_tracking import background
from belief_tracking.background import BackgroundConfig, BackgroundModel
from belief_tracking.errors import TrackingError
from belief_tracking.scenes import crossing

#: Pixel-exact checks need the mixtures at full size (the default shrinks frames twice).
FULL = BackgroundConfig(downscale=1)

GREEN = (40, 200, 40)


def textured(rng, height=60, width=80):
    return rng.integers(60, 180, size=(height, width, 3)).astype(np.uint8)


def noisy(frame, rng, gain=1.0):
    return np.clip(frame * gain + rng.normal(0, 2, frame.shape), 0, 255).astype(np.uint8)


def square_mask(shape, x, y, side):
    mask = np.zeros(shape[:2], bool)
    mask[y:y + side, x:x + side] = True
    return mask


# -- warm-up ---------------------------------------------------------------------------------------
def test_people_in_view_in_every_warm_up_frame_are_foreground_in_the_first_frame(rendered_scene):
    scene = rendered_scene(crossing(0))
    spread = scene.frames[np.linspace(0, len(scene.frames) - 1, 50).round().astype(int)]
    first = scene.ground_truth[scene.ground_truth[:, 0] == 1]
    fractions = {}
    for median in (True, False):
        model = BackgroundModel(BackgroundConfig(median_warm_up=median, downscale=1))
        assert model.warm_up(spread) == 50
        mask = model.apply(scene.frames[0])
        fractions[median] = [mask[y - 1:y - 1 + h, x - 1:x - 1 + w].mean() for x, y, w, h in first[:, 2:6]]
    # Fed as they are, the frames teach MOG2 the people: they fade into the background.
    assert min(fractions[True]) > 0.8
    assert max(fractions[False]) < 0.5


def test_a_place_covered_in_most_warm_up_frames_by_people_in_two_colours_is_not_learnt():
    rng = np.random.default_rng(1)
    scene = textured(rng)
    frames = []
    for k in range(20):
        frame = noisy(scene, rng)
        if k % 20 < 6:
            frame[20:40, 30:50] = 20          # a dark person ...
        elif k % 20 < 11:
            frame[20:40, 30:50] = 45          # ... and another, in 11 of the 20 frames
        frames.append(frame)
    model = BackgroundModel(FULL)
    model.warm_up(frames)
    mask = model.apply(noisy(scene, rng))
    # The per-channel median is the second person's grey here; the colour most frames share is the background.
    assert mask[20:40, 30:50].mean() < 0.05


def test_a_short_warm_up_learns_the_frames_as_they_are():
    rng = np.random.default_rng(2)
    scene = textured(rng)
    model = BackgroundModel(FULL)
    assert model.warm_up(noisy(scene, rng) for _ in range(3)) == 3
    assert model.frames_seen == 3
    assert model.warm_up([]) == 0
    frame = noisy(scene, rng)
    frame[10:22, 10:22] = GREEN
    mask = model.apply(frame)
    assert mask[10:22, 10:22].mean() > 0.95 and mask.sum() < 200


def test_grey_frames_work_throughout():
    rng = np.random.default_rng(3)
    scene = textured(rng)[:, :, 0]
    model = BackgroundModel(FULL)
    model.warm_up(noisy(scene, rng) for _ in range(20))
    frame = noisy(scene, rng, gain=1.2)
    frame[10:22, 10:22] = 250
    protect = square_mask(scene.shape, 8, 8, 16)
    mask = model.apply(frame, protect=protect)
    assert mask.shape == scene.shape
    assert mask[10:22, 10:22].mean() > 0.95
    assert mask[~protect].mean() < 0.01
    assert model.gain == pytest.approx(1.2, abs=0.02)


# -- protected pixels ------------------------------------------------------------------------------
@pytest.mark.parametrize("protected", [True, False])
def test_a_person_who_stands_still_stays_foreground_only_when_protected(protected):
    rng = np.random.default_rng(4)
    scene = textured(rng)
    model = BackgroundModel(FULL)
    model.warm_up(noisy(scene, rng) for _ in range(30))
    square = square_mask(scene.shape, 30, 20, 14)
    protect = square_mask(scene.shape, 28, 18, 18) if protected else None
    for _ in range(200):
        frame = noisy(scene, rng)
        frame[square] = GREEN
        mask = model.apply(frame, protect=protect)
    if protected:
        assert mask[square].mean() > 0.95
        assert mask[~square].mean() < 0.01
    else:
        # MOG2 learns what stays: after 200 frames at α = 0.01 the square is background.
        assert mask[square].mean() < 0.05


def test_protected_background_pixels_stay_background_and_shadows_too():
    rng = np.random.default_rng(5)
    scene = textured(rng)
    model = BackgroundModel(FULL)
    model.warm_up(noisy(scene, rng) for _ in range(30))
    protect = np.zeros(scene.shape[:2], bool)
    protect[:, :40] = True
    for _ in range(5):
        frame = noisy(scene, rng)
        frame[10:25, 5:20] = GREEN                                          # a protected person
        frame[35:50, 5:20] = (frame[35:50, 5:20] * 0.7).astype(np.uint8)  # a protected shadow
        frame[10:25, 50:65] = GREEN                                         # a person elsewhere
        mask = model.apply(frame, protect=protect)
    assert mask[10:25, 5:20].mean() > 0.95 and mask[10:25, 50:65].mean() > 0.95
    assert mask[35:50, 5:20].mean() < 0.05
    person_pixels = square_mask(scene.shape, 5, 10, 15) | square_mask(scene.shape, 50, 10, 15)
    assert mask[~person_pixels].mean() < 0.01


def test_protect_must_be_a_bool_mask_of_the_frame_shape():
    model = BackgroundModel(FULL)
    frame = np.zeros((20, 30, 3), np.uint8)
    with pytest.raises(TrackingError, match=r"protect must be a bool array of shape \(20, 30\)"):
        model.apply(frame, protect=np.zeros((20, 30), np.uint8))
    with pytest.raises(TrackingError, match="protect must be a bool array"):
        model.apply(frame, protect=np.zeros((30, 20), bool))


def test_a_shadow_is_background_only_when_shadows_are_detected():
    rng = np.random.default_rng(10)
    scene = textured(rng)
    shadow = square_mask(scene.shape, 20, 20, 20)
    fractions = {}
    for detect in (True, False):
        model = BackgroundModel(BackgroundConfig(detect_shadows=detect, downscale=1))
        model.warm_up(noisy(scene, rng) for _ in range(30))
        frame = noisy(scene, rng)
        frame[shadow] = (frame[shadow] * 0.7).astype(np.uint8)   # darker, same chromaticity
        fractions[detect] = model.apply(frame)[shadow].mean()
    assert fractions[True] < 0.05 and fractions[False] > 0.95


def test_grey_frames_are_modelled_as_well_as_colour_ones():
    rng = np.random.default_rng(11)
    scene = textured(rng)[:, :, 0]
    model = BackgroundModel(FULL)
    assert model.warm_up(noisy(scene, rng) for _ in range(10)) == 10
    frame = noisy(scene, rng)
    frame[10:25, 30:45] = 250
    mask = model.apply(frame)
    assert mask.shape == scene.shape and mask[10:25, 30:45].all()
    assert mask[square_mask(scene.shape, 30, 10, 15) == 0].mean() < 0.01


def test_the_model_counts_its_frames_and_the_foreground_of_its_last_mask():
    rng = np.random.default_rng(12)
    scene = textured(rng)
    model = BackgroundModel(FULL)
    assert model.warm_up([]) == 0 and model.frames_seen == 0
    assert model.warm_up(noisy(scene, rng) for _ in range(6)) == 6 and model.frames_seen == 6
    frame = noisy(scene, rng)
    frame[0:30, 0:40] = GREEN                                    # a quarter of the 60 x 80 frame
    mask = model.apply(frame)
    assert model.frames_seen == 7
    assert model.foreground_fraction == mask.mean() and 0.24 < model.foreground_fraction < 0.27
    assert repr(model).endswith("frames_seen=7)")


def test_without_gain_compensation_the_gain_stays_one():
    rng = np.random.default_rng(13)
    scene = textured(rng)
    model = BackgroundModel(BackgroundConfig(compensate_gain=False, downscale=1))
    model.warm_up(noisy(scene, rng) for _ in range(10))
    model.apply(noisy(scene, rng, gain=1.2))
    assert model.gain == 1.0


# -- light -----------------------------------------------------------------------------------------
def gain_ramp(model: BackgroundModel, scene, rng, gains):
    fractions, flags = [], []
    for gain in gains:
        mask = model.apply(noisy(scene, rng, gain))
        fractions.append(mask.mean())
        flags.append(model.lighting_change)
    return np.array(fractions), np.array(flags)


def test_a_global_brightening_never_reaches_the_mask_and_is_flagged_while_it_lasts():
    rng = np.random.default_rng(6)
    scene = textured(rng)
    gains = [1.0] * 5 + list(np.linspace(1.0, 1.35, 11)[1:]) + [1.35] * 15
    model = BackgroundModel(FULL)
    model.warm_up(noisy(scene, rng) for _ in range(30))
    fractions, flags = gain_ramp(model, scene, rng, gains)
    assert fractions.max() < 0.01
    assert not flags[:5].any() and flags[7:15].all() and not flags[-3:].any()
    assert model.gain == pytest.approx(1.35, abs=0.01)

    uncompensated = BackgroundModel(BackgroundConfig(compensate_gain=False, downscale=1))
    uncompensated.warm_up(noisy(scene, rng) for _ in range(30))
    fractions, flags = gain_ramp(uncompensated, scene, rng, gains)
    # Without the gain the brightening floods the mask; the flood itself is flagged.
    assert fractions.max() > 0.5 and flags[10:16].any()


def test_a_change_the_gain_cannot_explain_is_flagged_and_relearnt():
    rng = np.random.default_rng(7)
    before, after = textured(rng), textured(rng)
    model = BackgroundModel(FULL)
    model.warm_up(noisy(before, rng) for _ in range(30))
    fractions, flags = [], []
    for _ in range(20):
        fractions.append(model.apply(noisy(after, rng)).mean())
        flags.append(model.lighting_change)
    assert fractions[0] > 0.9 and flags[0]
    # Re-learnt within a few frames, then trusted again.
    assert max(fractions[8:]) < 0.01
    assert not any(flags[10:])


def test_a_large_person_does_not_bias_the_gain():
    rng = np.random.default_rng(8)
    scene = textured(rng)
    model = BackgroundModel(FULL)
    model.warm_up(noisy(scene, rng) for _ in range(30))
    frame = noisy(scene, rng)
    frame[5:55, 10:40] = 250                 # a third of the frame, far brighter
    mask = model.apply(frame)
    assert model.gain == pytest.approx(1.0, abs=0.01)
    assert mask[5:55, 10:40].mean() > 0.95 and not model.lighting_change


# -- downscale -------------------------------------------------------------------------------------
def test_a_downscaled_model_gives_a_full_size_mask_and_protects_too():
    rng = np.random.default_rng(9)
    scene = textured(rng, 61, 81)                           # odd sizes: the last row and column are dropped
    model = BackgroundModel(BackgroundConfig(downscale=2))
    model.warm_up(noisy(scene, rng) for _ in range(30))
    square = square_mask(scene.shape, 30, 20, 14)
    protect = square_mask(scene.shape, 28, 18, 18)
    for _ in range(200):
        frame = noisy(scene, rng, gain=1.1)
        frame[square] = GREEN
        mask = model.apply(frame, protect=protect)
    assert mask.shape == scene.shape[:2] and mask.dtype == np.bool_
    # Block edges may shift the outline by a pixel.
    assert mask[square].mean() > 0.95 and mask[~protect].mean() < 0.01


def test_frames_smaller_than_the_downscale_are_refused():
    model = BackgroundModel(BackgroundConfig(downscale=4))
    with pytest.raises(TrackingError, match="cannot be shrunk 4 times"):
        model.apply(np.zeros((3, 30, 3), np.uint8))


# -- settings and docs -----------------------------------------------------------------------------
@pytest.mark.parametrize("settings, message", [
    ({"max_foreground": 0}, r"max_foreground must lie in \(0, 1\]"),
    ({"max_foreground": 1.5}, r"max_foreground must lie in \(0, 1\]"),
    ({"relearn_frames": 0}, "relearn_frames must be a positive integer"),
    ({"gain_change": 0.0}, "gain_change must be a positive number"),
    ({"gain_change": float("nan")}, "gain_change must be a positive number"),
    ({"compensate_gain": "yes"}, "compensate_gain must be True or False"),
    ({"median_warm_up": 1}, "median_warm_up must be True or False"),
    ({"downscale": 0}, "downscale must be a positive integer"),
])
def test_bad_settings_are_refused(settings, message):
    with pytest.raises(TrackingError, match=message):
        BackgroundConfig(**settings)


def test_warm_up_frames_are_checked():
    model = BackgroundModel(FULL)
    with pytest.raises(TrackingError, match="uint8"):
        model.warm_up([np.zeros((20, 30, 3))] * 6)
    with pytest.raises(TrackingError, match="differs from the model's"):
        model.warm_up([np.zeros((20, 30, 3), np.uint8)] * 5 + [np.zeros((30, 20, 3), np.uint8)])


def test_docstring_examples():
    result = doctest.testmod(background, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
