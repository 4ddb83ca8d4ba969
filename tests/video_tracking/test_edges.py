"""The edge cue: orientation bins, magnitude-weighted kernel histograms and the HOE (SPEC B.2, B.5)."""

import math

import cv2
import numpy as np
import pytest

from belief_tracking.cues import (
    CUES,
    AppearanceCue,
    ColourConfig,
    ColourCue,
    EdgeConfig,
    EdgeCue,
    ForegroundColourCue,
    Observation,
    bhattacharyya,
    false_alarm_histogram,
    kernel_histograms,
    make_cue,
    orientation_bins,
    template_similarity,
)
from belief_tracking.cues import observation as observation_module
from belief_tracking.cues.histograms import HISTOGRAM_BLOCK
from belief_tracking.errors import TrackingError

SIGMA = 0.15
FLAT = -1.0 / (2 * SIGMA ** 2)          # log p of ρ = 0


def grey_image(values):
    """A BGR image whose three channels all hold ``values`` (so the grey level is exactly ``values``)."""
    values = np.asarray(values, dtype=np.uint8)
    return np.repeat(values[:, :, None], 3, axis=2)


def step_image(height=6, width=8, column=4, left=0, right=200):
    """Grey ``left`` before ``column`` and ``right`` from it on: a vertical step edge."""
    values = np.full((height, width), left)
    values[:, column:] = right
    return grey_image(values)


def target_scene():
    """A dark 120×90 frame with a bright, striped 20×30 target at (40, 30) and nothing else."""
    values = np.full((90, 120), 20)
    values[30:60, 40:60] = 220
    values[38:42, 40:60] = 90                     # a dark band across the target
    values[30:60, 49:51] = 120                    # and a mid-grey stripe down it
    return grey_image(values), np.array([[40.0, 30.0, 20.0, 30.0]])


def observe(image, boxes, foreground=None, cues=()):
    """The frame with targets at ``boxes``, carrying the templates that ``cues`` build from them."""
    boxes = np.asarray(boxes, dtype=np.float64)
    templates = {cue.name: cue.build_templates(image, boxes, foreground) for cue in cues}
    return Observation(image, foreground, boxes[:, :2] + boxes[:, 2:] / 2, boxes[:, 2:], np.zeros((0, 2)),
                       templates=templates)


def particles(*centres, log_scale=0.0):
    return np.array([[cx, cy, 0.0, 0.0, log_scale] for cx, cy in centres])


# -- orientation bins ----------------------------------------------------------------------------
def test_a_vertical_step_puts_all_weight_in_the_bin_of_its_gradient_direction():
    bins, weights = orientation_bins(step_image(right=200))
    assert bins.dtype == np.intp and weights.dtype == np.float64 and bins.shape == weights.shape == (6, 8)
    # Sobel: (right − left) · (1 + 2 + 1) / 4 = 200 on the two columns that touch the step, 0 elsewhere.
    expected = np.zeros((6, 8))
    expected[:, 3:5] = 200.0
    assert np.array_equal(weights, expected)
    assert (bins[weights > 0] == 0).all()                                   # θ = 0
    mirrored_bins, mirrored = orientation_bins(step_image(left=200, right=0))
    assert np.array_equal(mirrored, expected)
    assert (mirrored_bins[mirrored > 0] == 8).all()                          # θ = π, bin 8 of 16


def test_a_horizontal_step_points_down_or_up_with_y_growing_downwards():
    down = grey_image(np.where(np.arange(6)[:, None] >= 3, 150, 10) * np.ones((1, 5), int))
    bins, weights = orientation_bins(down)
    assert np.array_equal(weights[2:4], np.full((2, 5), 140.0)) and not weights[[0, 1, 4, 5]].any()
    assert (bins[weights > 0] == 4).all()                                    # θ = π/2
    up_bins, up = orientation_bins(down[::-1])
    assert (up_bins[up > 0] == 12).all()                                     # θ = 3π/2
    assert (orientation_bins(down, bins=8)[0][weights > 0] == 2).all()


@pytest.mark.parametrize("ramp, signed_bin, unsigned_bin", [
    (lambda x, y: x + y, 0, 0),            # gradient (1, 1): θ = π/4
    (lambda x, y: y - x, 1, 1),            # (−1, 1): 3π/4
    (lambda x, y: -x - y, 2, 0),           # (−1, −1): 5π/4, folded onto π/4
    (lambda x, y: x - y, 3, 1),            # (1, −1): 7π/4, folded onto 3π/4
])
def test_diagonal_gradients_and_the_unsigned_folding(ramp, signed_bin, unsigned_bin):
    y, x = np.mgrid[0:7, 0:7]
    image = grey_image(128 + 8 * ramp(x, y))                                # 32 … 224
    bins, weights = orientation_bins(image, bins=4)                         # bins of π/2: diagonals mid-bin
    inner = (slice(1, -1), slice(1, -1))
    # A ramp of 8 per pixel: g_x = g_y = ±2 · 8 · 4 / 4 = ±16 inside; g = 16√2.
    assert np.allclose(weights[inner], 16 * math.sqrt(2), rtol=0, atol=1e-12)
    assert (bins[inner] == signed_bin).all()
    folded, _ = orientation_bins(image, bins=2, unsigned=True)               # bins of π/2 over [0, π)
    assert (folded[inner] == unsigned_bin).all()


def test_unsigned_orientations_fold_opposite_steps_together():
    rising, falling = step_image(left=0, right=90), step_image(left=90, right=0)
    for image in (rising, falling):
        bins, weights = orientation_bins(image, unsigned=True)
        assert (bins[weights > 0] == 0).all() and weights.sum() == 6 * 2 * 90.0
    down = rising.transpose(1, 0, 2)
    assert (orientation_bins(down, unsigned=True)[0][orientation_bins(down)[1] > 0] == 8).all()   # π/2 of [0, π)
    assert (orientation_bins(down[::-1], unsigned=True)[0][orientation_bins(down)[1][::-1] > 0] == 8).all()


def test_weak_gradients_are_cut_at_min_gradient():
    faint = step_image(left=100, right=108)                                  # g = 8 grey levels
    assert not orientation_bins(faint)[1].any()
    assert orientation_bins(faint, min_gradient=8.0)[1].max() == 8.0        # kept at exactly the threshold
    assert orientation_bins(faint, min_gradient=0.0)[1].sum() == 6 * 2 * 8.0
    assert orientation_bins(step_image(left=100, right=112))[1].max() == 12.0


def test_grey_level_weights_the_channels_in_bgr_order():
    blue = np.zeros((3, 4, 3), np.uint8)
    blue[:, 2:, 0] = 100                                                     # BGR: channel 0 is blue
    red = np.zeros((3, 4, 3), np.uint8)
    red[:, 2:, 2] = 100
    assert np.allclose(orientation_bins(blue)[1][:, 1:3], 11.4)
    assert np.allclose(orientation_bins(red)[1][:, 1:3], 29.9)


def test_gradients_match_opencv_sobel_with_replicated_borders():
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, size=(17, 23, 3), dtype=np.uint8)
    b, g, r = (image[..., k].astype(np.float64) for k in range(3))
    grey = 0.299 * r + 0.587 * g + 0.114 * b
    gx = cv2.Sobel(grey, cv2.CV_64F, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE)
    gy = cv2.Sobel(grey, cv2.CV_64F, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE)
    magnitude = np.hypot(gx, gy) / 4.0                                      # in grey levels
    bins, weights = orientation_bins(image, bins=16, min_gradient=0.0)
    assert np.allclose(weights, magnitude, rtol=0, atol=1e-9)
    turns = np.mod(np.arctan2(gy, gx), 2 * np.pi) / (2 * np.pi) * 16
    clear = np.abs(turns - np.round(turns)) > 1e-6                          # away from a bin boundary
    assert clear.mean() > 0.9
    assert np.array_equal(bins[clear], np.floor(turns[clear]).astype(np.intp) % 16)


def test_the_orientation_images_of_a_frame_are_computed_once_per_setting(monkeypatch):
    calls = []
    real = observation_module.orientation_bins
    monkeypatch.setattr(observation_module, "orientation_bins",
                        lambda image, *args, **kwargs: calls.append(args + tuple(kwargs.values()))
                        or real(image, *args, **kwargs))
    image, boxes = target_scene()
    cue = EdgeCue(EdgeConfig(samples=(6, 12)))
    obs = observe(image, boxes, cues=[cue])                                  # templates: no observation
    assert calls == []
    first = obs.orientation_bins(16, False, 10.0)
    assert obs.orientation_bins(16, False, 10.0) is first and len(calls) == 1
    obs.orientation_bins(16, True, 10.0)
    obs.orientation_bins(16, False, 5.0)
    assert len(calls) == 3
    calls.clear()
    cue.log_likelihoods(obs, particles((50, 45)), np.array([0]))
    cue.histograms(obs, particles((50, 45)), np.array([0]))
    cue.false_alarm_histogram(obs)
    assert obs.with_templates(dict(obs.templates)).orientation_bins(16, False, 10.0) is first
    assert calls == []                                                        # the default setting is memoised


# -- magnitude-weighted kernel histograms --------------------------------------------------------
def test_pixel_weights_multiply_the_kernel_weights_and_renormalise():
    # One row of 4 pixels, 4 sample points at u = ±1/4, ±3/4: k = 15/16 inside, 7/16 outside.
    bin_image = np.array([[0, 0, 1, 1]])
    weights = np.array([[2.0, 1.0, 1.0, 0.0]])
    centre, size = np.array([[2.0, 0.5]]), np.array([[4.0, 1.0]])
    hist = kernel_histograms(bin_image, centre, size, 2, (4, 1), pixel_weights=weights)
    # bin 0: 7/16 · 2 + 15/16 · 1 = 29/16; bin 1: 15/16 · 1 + 7/16 · 0 = 15/16; sum 44/16.
    assert np.allclose(hist, [[29 / 44, 15 / 44]], rtol=0, atol=1e-15)
    assert np.allclose(kernel_histograms(bin_image, centre, size, 2, (4, 1)), [[0.5, 0.5]])


def test_unit_pixel_weights_change_nothing_and_boxes_are_normalised_one_by_one():
    rng = np.random.default_rng(8)
    bin_image = rng.integers(0, 5, size=(30, 40))
    centres = rng.uniform(0, 40, size=(9, 2))
    sizes = rng.uniform(3, 15, size=(9, 2))
    plain = kernel_histograms(bin_image, centres, sizes, 5, (6, 8))
    assert np.allclose(kernel_histograms(bin_image, centres, sizes, 5, (6, 8), pixel_weights=np.ones((30, 40))),
                       plain, rtol=0, atol=1e-14)
    weights = rng.uniform(0, 3, size=(30, 40))
    together = kernel_histograms(bin_image, centres, sizes, 5, (6, 8), pixel_weights=weights)
    alone = np.concatenate([kernel_histograms(bin_image, centres[i:i + 1], sizes[i:i + 1], 5, (6, 8),
                                              pixel_weights=weights) for i in range(9)])
    assert np.allclose(together, alone, rtol=0, atol=1e-14)
    assert np.allclose(together.sum(axis=1), 1.0) and not np.allclose(together, plain, atol=1e-3)


def test_a_box_without_weight_gets_an_all_zero_histogram_not_nan():
    bin_image = np.zeros((10, 10), np.intp)
    weights = np.zeros((10, 10))
    weights[:, 8:] = 5.0
    hist = kernel_histograms(bin_image, np.array([[3.0, 5.0], [9.0, 5.0]]), np.array([[4.0, 4.0], [2.0, 2.0]]),
                             3, (4, 4), pixel_weights=weights)
    assert np.array_equal(hist, [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    assert np.array_equal(bhattacharyya(hist, np.array([[1.0, 0.0, 0.0], [1 / 3, 1 / 3, 1 / 3]])),
                          [[0.0, 0.0], [1.0, math.sqrt(1 / 3)]])


def test_pixel_weights_with_a_mask_keep_the_mask_out_of_the_normalisation():
    bin_image = np.array([[0, 0, 1, 1]])
    weights = np.array([[2.0, 1.0, 1.0, 0.0]])
    mask = np.array([[False, True, True, True]])
    hist = kernel_histograms(bin_image, np.array([[2.0, 0.5]]), np.array([[4.0, 1.0]]), 2, (4, 1), mask,
                             pixel_weights=weights)
    assert np.allclose(hist, [[15 / 44, 15 / 44]], rtol=0, atol=1e-15)      # pixel 0 masked, f = 16/44


def test_pixel_weights_of_the_wrong_shape_are_refused():
    with pytest.raises(TrackingError, match="pixel_weights must have the shape"):
        kernel_histograms(np.zeros((4, 4), np.intp), np.array([[2.0, 2.0]]), np.array([[2.0, 2.0]]), 2, (2, 2),
                          pixel_weights=np.ones((4, 5)))


# -- the edge cue --------------------------------------------------------------------------------
def test_a_particle_on_the_template_box_scores_rho_one_and_a_flat_box_rho_zero():
    image, boxes = target_scene()
    cue = EdgeCue(EdgeConfig(samples=(10, 15)))
    obs = observe(image, boxes, cues=[cue])
    assert np.isclose(cue.templates(obs).sum(), 1.0)
    states = particles((50, 45), (100, 15))                                 # on the target; on the flat dark area
    hist = cue.histograms(obs, states, np.array([0, 0]))
    assert np.isclose(hist[0].sum(), 1.0) and np.array_equal(hist[1], np.zeros(16))
    logs = cue.log_likelihoods(obs, states, np.array([0, 0]))
    assert np.isfinite(logs).all()
    assert abs(logs[0, 0]) < 1e-12
    assert np.allclose(logs[1], [FLAT, FLAT], rtol=0, atol=1e-12)


def test_a_shifted_box_scores_lower_the_further_it_moves():
    image, boxes = target_scene()
    cue = EdgeCue(EdgeConfig(samples=(20, 30)))                             # one sample per pixel
    obs = observe(image, boxes, cues=[cue])
    shifts = [0, 1, 3, 6]
    logs = cue.log_likelihoods(obs, particles(*[(50 + s, 45) for s in shifts]), np.zeros(4, int))[:, 0]
    assert abs(logs[0]) < 1e-12
    assert (np.diff(logs) < 0).all()


def test_the_false_alarm_histogram_is_the_magnitude_weighted_scene_without_the_targets():
    image, boxes = target_scene()
    values = image[..., 0].astype(int)
    y, x = np.mgrid[0:20, 0:30]
    values[65:85, 5:35] = 20 + 3 * (2 * x + y)                             # a ramp: θ = atan2(1, 2), bin 1
    image = grey_image(values)
    cue = EdgeCue(EdgeConfig(samples=(10, 15)))
    obs = observe(image, boxes, cues=[cue])
    bins, weights = orientation_bins(image)
    scene = np.bincount(bins.ravel(), weights.ravel(), minlength=16)
    expected = false_alarm_histogram(scene, cue.templates(obs))
    q_fa = cue.false_alarm_histogram(obs)
    assert np.allclose(q_fa, expected, rtol=0, atol=1e-15) and np.isclose(q_fa.sum(), 1.0)
    assert cue.templates(obs)[0, 1] == 0 and q_fa[1] > 0.2                  # the ramp is where FA lies
    logs = cue.log_likelihoods(obs, particles((50, 45), (20, 75)), np.array([0, 0]))
    assert logs[0, 0] > logs[0, 1]                                           # the target is θ1
    assert logs[1, 1] > logs[1, 0]                                           # the ramp is FA
    rho = 1 + 2 * SIGMA ** 2 * logs
    assert np.allclose(rho[:, 1], bhattacharyya(cue.histograms(obs, particles((50, 45), (20, 75)),
                                                                np.array([0, 0])), q_fa[None, :])[:, 0])


def test_a_frame_without_edges_gives_a_uniform_false_alarm_and_finite_scores():
    image = grey_image(np.full((40, 50), 77))
    cue = EdgeCue(EdgeConfig(samples=(6, 12)))
    obs = observe(image, [[10, 10, 10, 20]], cues=[cue])
    assert np.array_equal(cue.templates(obs), np.zeros((1, 16)))            # no edge in the box
    assert np.array_equal(cue.false_alarm_histogram(obs), np.full(16, 1 / 16))
    assert np.allclose(cue.log_likelihoods(obs, particles((15, 20), (30, 20)), np.array([0, 0])), FLAT)


def test_histograms_built_block_by_block_equal_the_whole_batch():
    rng = np.random.default_rng(11)
    image = rng.integers(0, 256, size=(80, 120, 3), dtype=np.uint8)
    image[:, :30] = 60                                                       # some boxes see no edge at all
    boxes = np.array([[40, 10, 12, 24], [80, 30, 14, 28]])
    cue = EdgeCue(EdgeConfig(samples=(6, 12)))
    obs = observe(image, boxes, cues=[cue])
    n = 2 * HISTOGRAM_BLOCK + 7
    states = np.column_stack([rng.uniform(0, 120, n), rng.uniform(0, 80, n), np.zeros((n, 2)),
                              rng.normal(0, 0.3, n)])
    states[:5, :2] = [5, 40]                                                 # inside the flat band
    states[:5, 4] = -1.0
    owner = rng.integers(0, 2, n)
    hist = cue.histograms(obs, states, owner)
    assert np.array_equal(hist[:5], np.zeros((5, 16)))
    sums = hist.sum(axis=1)
    edged = sums > 0
    assert np.allclose(sums[edged], 1.0) and 0.5 < edged.mean() < 0.95
    references = np.concatenate([cue.templates(obs), cue.false_alarm_histogram(obs)[None, :]])
    whole = (0.0 - (1.0 - bhattacharyya(hist, references))) / (2 * SIGMA ** 2)
    logs = cue.log_likelihoods(obs, states, owner)
    assert logs.shape == (n, 3) and np.isfinite(logs).all()
    assert np.allclose(logs, whole, rtol=0, atol=1e-12)


# -- registry and settings -----------------------------------------------------------------------
def test_the_registry_builds_the_edge_cue():
    assert CUES["edges"] is EdgeCue
    cue = make_cue("edges", bins=8, min_gradient=4)
    assert isinstance(cue, EdgeCue) and isinstance(cue, AppearanceCue) and cue.name == "edges"
    assert cue.config == EdgeConfig(bins=8, min_gradient=4.0)
    image, boxes = target_scene()
    assert cue.build_templates(image, boxes).shape == (1, 8)
    assert make_cue("edges").config == EdgeConfig(16, 0.15, (12, 24), 10.0)
    with pytest.raises(TrackingError, match="no option fa_mode; its options are bins, sigma, samples, min_gradient"):
        make_cue("edges", fa_mode="gate")


@pytest.mark.parametrize("build, message", [
    (lambda: EdgeConfig(bins=0), "EdgeConfig.bins must be a positive integer"),
    (lambda: EdgeConfig(bins=2.5), "EdgeConfig.bins must be a positive integer"),
    (lambda: EdgeConfig(bins=361), "EdgeConfig.bins must be at most 360"),
    (lambda: EdgeConfig(sigma=0), "EdgeConfig.sigma must be a positive"),
    (lambda: EdgeConfig(sigma=float("inf")), "EdgeConfig.sigma must be a positive"),
    (lambda: EdgeConfig(samples=(12,)), "EdgeConfig.samples must be a pair"),
    (lambda: EdgeConfig(samples=(12, 0)), "EdgeConfig.samples must be a positive integer"),
    (lambda: EdgeConfig(min_gradient=-1), "EdgeConfig.min_gradient must be a non-negative"),
    (lambda: EdgeConfig(min_gradient=float("nan")), "EdgeConfig.min_gradient must be a non-negative"),
    (lambda: EdgeConfig(min_gradient="10"), "EdgeConfig.min_gradient must be a non-negative"),
    (lambda: EdgeCue(ColourConfig()), "EdgeCue needs an EdgeConfig, got ColourConfig"),
    (lambda: ColourCue(EdgeConfig()), "ColourCue needs a ColourConfig, got EdgeConfig"),
])
def test_bad_edge_settings_are_refused_naming_the_field(build, message):
    with pytest.raises(TrackingError, match=message):
        build()


# -- templates: built by the cue, kept by the tracks, read from the observation -------------------
def two_target_scene(cue_type):
    """A cue of ``cue_type`` and a frame with two targets (a foreground mask over all of it)."""
    image = np.full((60, 90, 3), 30, np.uint8)
    image[10:40, 10:25] = (0, 0, 230)
    image[10:40, 16:19] = 90                      # a stripe down the first target, a band across the second
    image[15:45, 50:65] = (200, 180, 0)
    image[25:28, 50:65] = 90
    boxes = np.array([[10, 10, 15, 30], [50, 15, 15, 30]])
    config = EdgeConfig(samples=(6, 12)) if cue_type is EdgeCue else ColourConfig(bins=4, samples=(6, 12))
    return cue_type(config), image, boxes, np.ones((60, 90), bool)


@pytest.mark.parametrize("cue_type", [ColourCue, ForegroundColourCue, EdgeCue])
def test_the_templates_of_several_boxes_equal_those_built_one_at_a_time(cue_type):
    cue, image, boxes, mask = two_target_scene(cue_type)
    together = cue.build_templates(image, boxes, foreground=mask)
    assert together.shape == (2, cue.config.n_bins) and np.allclose(together.sum(axis=1), 1.0)
    alone = np.concatenate([cue.build_templates(image, box[None, :], foreground=mask) for box in boxes])
    if cue_type is EdgeCue:         # Σ K · g of a box is summed in another order beside other boxes
        np.testing.assert_allclose(together, alone, rtol=0, atol=1e-15)
    else:                           # Σ K is the grid's, whatever the boxes
        np.testing.assert_array_equal(together, alone)
    assert np.array_equal(cue.build_templates(image, boxes[::-1], foreground=mask), together[::-1])  # in box order
    assert not np.allclose(together[0], together[1])


@pytest.mark.parametrize("cue_type", [ColourCue, ForegroundColourCue, EdgeCue])
def test_scoring_reads_the_templates_of_the_observation_and_never_changes_them(cue_type):
    cue, image, boxes, mask = two_target_scene(cue_type)
    obs = observe(image, boxes, mask, cues=[cue])
    built = obs.templates[cue.name].copy()
    states, owner = particles((17.5, 25), (57.5, 30), (40, 50)), np.array([0, 1, 1])
    cue.log_likelihoods(obs, states, owner)
    cue.false_alarm_histogram(obs)
    template_similarity([cue], obs, states, owner)
    assert np.array_equal(obs.templates[cue.name], built) and np.array_equal(cue.templates(obs), built)
    # Templates built again are new arrays: the ones handed out before stay put.
    assert not np.shares_memory(cue.build_templates(image, boxes, foreground=mask), obs.templates[cue.name])
    # Other templates make another observation; this one still reads its own.
    swapped = obs.with_templates({cue.name: built[::-1]})
    assert np.array_equal(cue.templates(swapped), built[::-1]) and np.array_equal(cue.templates(obs), built)
    assert swapped._features is obs._features
    on_own = cue.log_likelihoods(obs, states[:2], owner[:2])
    on_swapped = cue.log_likelihoods(swapped, states[:2], owner[:2])
    assert np.allclose(np.diag(on_own[:, :2]), 0.0, atol=1e-12) and (np.diag(on_swapped[:, :2]) < -1).all()
    # The cue holds its settings and nothing of the targets.
    assert vars(cue) == {"config": cue.config} and repr(cue) == f"{cue_type.__name__}({cue.config!r})"


def test_a_new_template_is_what_particles_are_scored_against():
    image, boxes = target_scene()
    cue = EdgeCue(EdgeConfig(samples=(10, 15)))
    obs = observe(image, boxes, cues=[cue])
    moved = particles((55, 49))
    assert cue.log_likelihoods(obs, moved, np.array([0]))[0, 0] < -1
    followed = obs.with_templates({"edges": cue.histograms(obs, moved, np.array([0]))})
    assert abs(cue.log_likelihoods(followed, moved, np.array([0]))[0, 0]) < 1e-12
    assert cue.log_likelihoods(followed, particles((50, 45)), np.array([0]))[0, 0] < -1


def test_no_box_gives_no_histogram_with_pixel_weights_too():
    image = np.zeros((20, 30, 3), np.uint8)
    image[5:15, 10:20] = 200
    cue = EdgeCue(EdgeConfig(bins=8))
    assert cue.build_templates(image, np.zeros((0, 4))).shape == (0, 8)
    obs = Observation(image, None, [[15.0, 10.0]], [[10.0, 10.0]], np.zeros((0, 2)),
                      templates={"edges": cue.build_templates(image, [[10, 5, 10, 10]])})
    assert cue.histograms(obs, np.zeros((0, 5)), np.zeros(0, np.intp)).shape == (0, 8)
