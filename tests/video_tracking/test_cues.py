"""Image cues of the tracker: location, colour and foreground colour (SPEC B.2–B.4), and the background model."""

import doctest
import importlib
import inspect
import math
import pkgutil

import numpy as np
import pytest

from belief_tracking import background, cues
from belief_tracking.background import BackgroundConfig, BackgroundModel
from belief_tracking.cues import (
    CUES,
    AppearanceCue,
    ColourConfig,
    ColourCue,
    Cue,
    EdgeCue,
    ForegroundColourCue,
    LocationConfig,
    LocationCue,
    Observation,
    bhattacharyya,
    colour_bins,
    make_cue,
    score_cues,
    template_similarity,
)
from belief_tracking.cues.base import log_gaussian
from belief_tracking.cues.histograms import HISTOGRAM_BLOCK
from belief_tracking.errors import TrackingError, UnknownCueError
from belief_tracking.fusion import CueFusion

GREY = (128, 128, 128)
RED = (0, 0, 255)          # BGR
BLUE = (255, 0, 0)
GREEN = (0, 200, 0)


def scene_with_targets(height=100, width=140):
    """A grey frame with a red target at (30, 20, 20, 40) and a blue one at (90, 40, 20, 40) (x, y, w, h)."""
    image = np.full((height, width, 3), GREY, np.uint8)
    image[20:60, 30:50] = RED
    image[40:80, 90:110] = BLUE
    boxes = np.array([[30.0, 20.0, 20.0, 40.0], [90.0, 40.0, 20.0, 40.0]])
    return image, boxes


def red_target_mask(image):
    """A foreground mask of :func:`scene_with_targets` that holds the red target only."""
    mask = np.zeros(image.shape[:2], bool)
    mask[20:60, 30:50] = True
    return mask


#: Two targets, (x, y, w, h), for the frames of random pixels.
TWO_BOXES = np.array([[10.0, 10.0, 12.0, 24.0], [60.0, 30.0, 14.0, 28.0]])


def observation(image, boxes, foreground=None, previous=None, cues=()):
    """The frame with targets at ``boxes``, carrying the templates that the appearance ``cues`` build from them."""
    centres = boxes[:, :2] + boxes[:, 2:] / 2
    templates = {cue.name: cue.build_templates(image, boxes, foreground) for cue in cues
                 if isinstance(cue, AppearanceCue)}
    return Observation(image, foreground, centres, boxes[:, 2:], np.zeros((0, 2)) if previous is None else previous,
                       templates=templates)


def states_at(*points, log_scale=0.0):
    """Particle states (P, 5) at the given centres, zero velocity."""
    points = np.asarray(points, dtype=float)
    return np.column_stack([points, np.zeros((len(points), 2)), np.full(len(points), log_scale)])


def slow_histogram(image, centre, size, bins, samples, mask=None):
    """One particle's histogram, pixel by pixel, written straight from L (9)-(11) and L (16)-(17)."""
    height, width = image.shape[:2]
    across, down = samples
    histogram = np.zeros(bins ** 3)
    total = 0.0
    for row in range(down):
        for col in range(across):
            u = (2 * col + 1) / across - 1
            v = (2 * row + 1) / down - 1
            k = 1 - u * u - v * v                          # Epanechnikov, per-axis r²
            if k <= 0:
                continue
            total += k                                     # f of L (10): every sample point
            px = math.floor(centre[0] + u * (size[0] / 2))
            py = math.floor(centre[1] + v * (size[1] / 2))
            inside = 0 <= px < width and 0 <= py < height
            px, py = min(max(px, 0), width - 1), min(max(py, 0), height - 1)
            if mask is not None and not (inside and mask[py, px]):
                continue
            blue, green, red = (int(c) * bins // 256 for c in image[py, px])
            histogram[(red * bins + green) * bins + blue] += k
    return histogram / total


# -- location cue ----------------------------------------------------------------------------------
def location_obs(previous):
    return Observation(np.zeros((120, 200, 3), np.uint8), None, np.array([[100.0, 50.0], [140.0, 70.0]]),
                       np.array([[20.0, 40.0], [20.0, 40.0]]), np.asarray(previous, dtype=float))


def test_location_matches_the_formulas_by_hand():
    obs = location_obs([[90, 45], [150, 75], [120, 60]])
    states = states_at([110, 60], [100, 50], [300, 10])
    scores = LocationCue(LocationConfig(sigma=10.0, literal=True)).log_likelihoods(obs, states, np.array([0, 0, 1]))
    d_max = math.hypot(30, 15)                                 # the particle (90, 45) is farthest from (120, 60)
    expected = [
        [-(10 ** 2 + 10 ** 2) / 200, -(30 ** 2 + 10 ** 2) / 200, -(d_max - 10) ** 2 / 200],
        [0.0, -(40 ** 2 + 20 ** 2) / 200, -(d_max - math.hypot(20, 10)) ** 2 / 200],
        [-(200 ** 2 + 40 ** 2) / 200, -(160 ** 2 + 60 ** 2) / 200, 0.0],       # beyond d_max: clamped
    ]
    np.testing.assert_allclose(scores, expected, rtol=1e-12)


def test_the_gated_location_measures_from_the_nearest_target_up_to_the_gate():
    # The previous particles do not matter: d_max = gate · σ = 30 px.
    obs = location_obs([[90, 45], [150, 75], [120, 60]])
    scores = LocationCue(LocationConfig(sigma=10.0)).log_likelihoods(
        obs, states_at([110, 60], [100, 50], [100, 95]), np.array([1, 0, 0]))
    assert scores[0, 2] == pytest.approx(-(30 - math.hypot(10, 10)) ** 2 / 200, rel=1e-12)
    assert scores[1, 2] == pytest.approx(-30 ** 2 / 200)      # on target 1: as far from FA as can be
    assert scores[2, 2] == 0.0                                 # 45 px from target 1, beyond the gate
    assert scores[0, 0] == pytest.approx(-1.0) and scores[0, 1] == pytest.approx(-5.0)


def test_location_fa_grows_away_from_the_centroid_and_is_clamped_outside_d_max():
    obs = location_obs([[90, 45], [150, 75]])
    d_max = math.hypot(30, 15)
    radii = np.linspace(0, d_max + 60, 200)
    direction = np.array([0.6, -0.8])
    states = states_at(*(np.array([120.0, 60.0]) + radii[:, None] * direction))
    fa = LocationCue(LocationConfig(literal=True)).log_likelihoods(obs, states, np.zeros(len(radii), dtype=int))[:, 2]
    inside = radii < d_max
    assert np.all(np.diff(fa[inside]) > 0)                    # strictly more FA-like going out
    assert np.all(fa[~inside] == 0.0)                          # max(d_max − d, 0) = 0: no fall-back
    assert fa[0] == pytest.approx(-d_max ** 2 / 200)


def test_location_d_max_is_floored_at_sigma():
    obs = location_obs([[120, 60]])                            # every old particle at the centroid: d_max = 0
    fa = LocationCue(LocationConfig(sigma=10.0, literal=True)).log_likelihoods(obs, states_at([120, 60], [124, 63]),
                                                                             np.array([0, 0]))
    np.testing.assert_allclose(fa[:, 2], [-100 / 200, -25 / 200])


# -- colour cue ------------------------------------------------------------------------------------
def test_particle_on_a_target_box_matches_its_template():
    image, boxes = scene_with_targets()
    cue = ColourCue()
    obs = observation(image, boxes, cues=[cue])
    slow = [slow_histogram(image, box[:2] + box[2:] / 2, box[2:], 8, (12, 24)) for box in boxes]
    np.testing.assert_allclose(cue.templates(obs), slow, rtol=1e-12, atol=1e-15)
    states = states_at(*obs.centres)
    histograms = cue.histograms(obs, states, np.array([0, 1]))
    np.testing.assert_allclose(histograms, cue.templates(obs), atol=1e-15)
    scores = cue.log_likelihoods(obs, states, np.array([0, 1]))
    np.testing.assert_allclose(np.diag(scores[:, :2]), [0.0, 0.0], atol=1e-12)          # ρ = 1 → log p = 0
    np.testing.assert_allclose(scores[0, 1], -1 / (2 * 0.15 ** 2))                        # red vs blue: ρ = 0


def test_templates_of_a_textured_target_are_matched_exactly():
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, size=(80, 90, 3), dtype=np.uint8)
    boxes = np.array([[10.5, 7.25, 23.0, 41.0]])
    cue = ColourCue(ColourConfig(bins=4, samples=(9, 17)))
    scores = cue.log_likelihoods(observation(image, boxes, cues=[cue]), states_at([22.0, 27.75]), np.array([0]))
    assert scores[0, 0] == pytest.approx(0.0, abs=1e-12)
    assert scores[0, 1] < -1.0


def test_a_box_on_another_colour_has_lower_similarity():
    image, boxes = scene_with_targets()
    cue = ColourCue()
    obs = observation(image, boxes[:1], cues=[cue])
    # on the red target; half over it; on grey background
    states = states_at([40, 40], [50, 40], [80, 15])
    histograms = cue.histograms(obs, states, np.zeros(3, dtype=int))
    rho = bhattacharyya(histograms, cue.templates(obs))[:, 0]
    assert rho[0] == pytest.approx(1.0) and 0.3 < rho[1] < 0.9 and rho[2] == 0.0
    scores = cue.log_likelihoods(obs, states, np.zeros(3, dtype=int))
    np.testing.assert_allclose(scores[:, 0], -(1 - rho) / (2 * 0.15 ** 2), atol=1e-12)   # W (16)-(17)
    assert scores[0, 0] > scores[1, 0] > scores[2, 0]


@pytest.mark.parametrize("masked", [False, True])
def test_vectorised_histograms_equal_a_particle_by_particle_loop(masked):
    rng = np.random.default_rng(7)
    height, width = 50, 70
    image = rng.integers(0, 256, size=(height, width, 3), dtype=np.uint8)
    mask = rng.random((height, width)) < 0.4
    config = ColourConfig(bins=4, samples=(7, 10))
    sizes = np.array([[12.0, 20.0], [9.0, 15.0]])
    centres = np.array([[30.0, 20.0], [50.0, 30.0]])
    n = 40
    # partly and fully outside the image too, and with scale changes
    states = np.column_stack([rng.uniform(-20, width + 20, n), rng.uniform(-20, height + 20, n),
                              rng.normal(size=(n, 2)), rng.normal(0, 0.5, n)])
    owner = rng.integers(0, 2, n)
    obs = Observation(image, mask if masked else None, centres, sizes, np.zeros((0, 2)))
    cue = ForegroundColourCue(config) if masked else ColourCue(config)
    fast = cue.histograms(obs, states, owner)
    slow = np.array([slow_histogram(image, states[p, :2], sizes[owner[p]] * np.exp(states[p, 4]), 4, (7, 10),
                                    mask if masked else None) for p in range(n)])
    np.testing.assert_allclose(fast, slow, rtol=1e-12, atol=1e-15)
    # The templates are the same histograms of their boxes (a foreground one normalised to 1).
    boxes = np.column_stack([rng.uniform(0, width - 5, 8), rng.uniform(0, height - 5, 8), rng.uniform(3, 25, (8, 2))])
    slow = np.array([slow_histogram(image, box[:2] + box[2:] / 2, box[2:], 4, (7, 10), mask if masked else None)
                     for box in boxes])
    if masked:
        slow /= slow.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(cue.build_templates(image, boxes, mask), slow, rtol=1e-12, atol=1e-15)


def test_colour_bins_cut_each_channel_evenly():
    levels = np.arange(256, dtype=np.uint8)
    image = np.stack([levels, np.zeros(256, np.uint8), np.zeros(256, np.uint8)], axis=-1)[None]     # blue ramp
    np.testing.assert_array_equal(colour_bins(image, 8)[0], np.repeat(np.arange(8), 32))
    image = image[..., ::-1]                                                                          # red ramp
    np.testing.assert_array_equal(colour_bins(np.ascontiguousarray(image), 8)[0], np.repeat(np.arange(8), 32) * 64)


def test_false_alarm_histogram_excludes_the_target_colours():
    image, boxes = scene_with_targets()
    cue = ColourCue(ColourConfig())
    obs = observation(image, boxes, cues=[cue])
    q_fa = cue.false_alarm_histogram(obs)
    red, blue, grey = (colour_bins(np.array([[c]], np.uint8), 8)[0, 0] for c in (RED, BLUE, GREY))
    assert q_fa.sum() == pytest.approx(1.0)
    assert q_fa[red] == 0.0 and q_fa[blue] == 0.0
    assert q_fa[grey] == pytest.approx(1.0)
    # a particle on the background is FA-like, one on a target is not
    scores = cue.log_likelihoods(obs, states_at([10, 85], [40, 40]), np.array([0, 0]))
    assert scores[0, 2] == pytest.approx(0.0, abs=1e-12) and scores[0, 2] > scores[0, :2].max()
    assert scores[1, 2] == pytest.approx(-1 / (2 * 0.15 ** 2))


def test_false_alarm_histogram_removes_a_target_colour_everywhere():
    # A red patch elsewhere in the scene: W (18) subtracts the red template, so red leaves FA entirely.
    image, boxes = scene_with_targets()
    image[85:95, 5:25] = RED
    red = colour_bins(np.array([[RED]], np.uint8), 8)[0, 0]
    cue = ColourCue(ColourConfig())
    assert cue.false_alarm_histogram(observation(image, boxes, cues=[cue]))[red] == 0.0


def test_false_alarm_histogram_is_uniform_when_the_targets_fill_the_scene():
    image = np.full((20, 20, 3), RED, np.uint8)
    boxes = np.array([[0.0, 0.0, 20.0, 20.0]])
    cue = ColourCue(ColourConfig(bins=2))
    np.testing.assert_allclose(cue.false_alarm_histogram(observation(image, boxes, cues=[cue])), np.full(8, 1 / 8))


def test_false_alarm_histogram_ignores_rounding_residue():
    # A target template equal to the scene up to rounding leaves nothing: uniform, not amplified noise.
    rng = np.random.default_rng(10)                  # a template whose subtraction leaves ~1e-16 > 0 in every bin
    template = rng.random(6)
    template /= template.sum()
    scene = template * 997.0 * (1 + 1e-15)
    assert (scene / scene.sum() - template > 0).any()
    q_fa = cues.false_alarm_histogram(scene, template[None, :])
    np.testing.assert_allclose(q_fa, np.full(6, 1 / 6))


# -- foreground-masked colour (L (16)-(17)) --------------------------------------------------------
def foreground_scene():
    image = np.full((100, 100, 3), GREY, np.uint8)
    image[30:70, 40:60] = RED
    mask = np.zeros((100, 100), bool)
    mask[30:70, 40:60] = True
    boxes = np.array([[40.0, 30.0, 20.0, 40.0]])
    return image, mask, boxes


def test_foreground_histogram_sums_to_the_kernel_weighted_foreground_fraction():
    image, mask, boxes = foreground_scene()
    cue = ForegroundColourCue(ColourConfig(samples=(10, 20)))
    obs = observation(image, boxes, foreground=mask, cues=[cue])
    states = states_at([50, 50], [58, 60], [66, 82], [10, 10])
    histograms = cue.histograms(obs, states, np.zeros(4, dtype=int))
    # F by hand: the kernel weights of the sample points that land on the mask, over all weights
    offsets, weights = cues.kernel_grid((10, 20))
    for p, (cx, cy) in enumerate(states[:, :2]):
        px = np.floor(cx + offsets[:, 0] * 10).astype(int)
        py = np.floor(cy + offsets[:, 1] * 20).astype(int)
        on = (px >= 40) & (px < 60) & (py >= 30) & (py < 70)
        assert histograms[p].sum() == pytest.approx(weights[on].sum() / weights.sum(), abs=1e-12)
    assert histograms[0].sum() == pytest.approx(1.0) and histograms[3].sum() == 0.0
    assert 0 < histograms[2].sum() < 0.1


def test_foreground_normalisation_crushes_particles_that_cover_little_foreground():
    image, mask, boxes = foreground_scene()
    cue = ForegroundColourCue()
    obs = observation(image, boxes, foreground=mask, cues=[cue])
    states = states_at([50, 50], [66, 82])                # on the target; over one corner of it
    histograms = cue.histograms(obs, states, np.zeros(2, dtype=int))
    coverage = histograms.sum(axis=1)
    rho = bhattacharyya(histograms, cue.templates(obs))[:, 0]
    # all the foreground it sees is the target's red, yet ρ = √F (Cauchy–Schwarz bound reached) …
    np.testing.assert_allclose(rho, np.sqrt(coverage))
    # … whereas renormalising over the foreground pixels alone would call it a perfect match
    assert bhattacharyya(histograms[1:] / coverage[1], cue.templates(obs))[0, 0] == pytest.approx(1.0)
    scores = cue.log_likelihoods(obs, states, np.zeros(2, dtype=int))
    assert scores[0, 0] == pytest.approx(0.0, abs=1e-12)
    assert scores[0, 0] - scores[1, 0] > 10.0             # likelihood ratio above e^10


def test_foreground_template_is_normalised_and_falls_back_without_foreground():
    image, mask, boxes = foreground_scene()
    half = mask.copy()
    half[:, 50:] = False                                   # only the left half of the target is foreground
    wide = np.array([[30.0, 20.0, 40.0, 60.0]])                # the target with grey around it
    background = [5.0, 5.0, 10.0, 10.0]                        # no foreground in that box
    templates = ForegroundColourCue().build_templates(image, np.array([wide[0], background]), foreground=half)
    plain = ColourCue().build_templates(image, np.array([wide[0], background]))
    red = colour_bins(np.array([[RED]], np.uint8), 8)[0, 0]
    assert templates.shape == (2, 512)
    assert templates[0].sum() == pytest.approx(1.0)
    assert templates[0, red] == pytest.approx(1.0)              # no grey: it is not foreground
    assert plain[0, red] < 0.9
    np.testing.assert_array_equal(templates[1], plain[1])       # the unmasked histogram


def test_foreground_cue_needs_a_mask():
    image, mask, boxes = foreground_scene()
    cue = ForegroundColourCue()
    with pytest.raises(TrackingError, match="foreground mask"):
        cue.build_templates(image, boxes)
    obs = observation(image, boxes)
    obs = obs.with_templates({"foreground": cue.build_templates(image, boxes, foreground=mask)})
    with pytest.raises(TrackingError, match="Observation.foreground"):
        cue.log_likelihoods(obs, states_at([50, 50]), np.array([0]))
    with pytest.raises(TrackingError, match="Observation.foreground"):
        cue.histograms(obs, states_at([50, 50]), np.array([0]))


# -- all cues --------------------------------------------------------------------------------------
def all_cues():
    return [LocationCue(), ColourCue(), ForegroundColourCue()]


def test_shapes_are_particles_by_targets_plus_false_alarm():
    image, boxes = scene_with_targets()
    boxes = np.vstack([boxes, [[5.0, 70.0, 10.0, 20.0]]])
    mask = red_target_mask(image)
    every_cue = all_cues()
    obs = observation(image, boxes, foreground=mask, previous=np.array([[40.0, 40.0], [100.0, 60.0]]), cues=every_cue)
    rng = np.random.default_rng(0)
    states = np.column_stack([rng.uniform(0, 140, (30, 2)), np.zeros((30, 2)), rng.normal(0, 0.1, 30)])
    owner = rng.integers(0, 3, 30)
    for cue in every_cue:
        assert isinstance(cue, Cue)
        scores = cue.log_likelihoods(obs, states, owner)
        assert scores.shape == (30, 4) and np.isfinite(scores).all() and (scores <= 0).all()
        assert cue.log_likelihoods(obs, np.zeros((0, 5)), np.zeros(0, dtype=int)).shape == (0, 4)


def test_particles_outside_the_image_give_finite_values():
    image, boxes = scene_with_targets()
    mask = red_target_mask(image)
    every_cue = all_cues()
    obs = observation(image, boxes, foreground=mask, previous=np.array([[40.0, 40.0]]), cues=every_cue)
    states = states_at([-5, 40], [145, 90], [-1e6, -1e6], [1e6, 50], [70, -500])
    states = np.vstack([states, states_at([40, 40], log_scale=200.0), states_at([40, 40], log_scale=-200.0)])
    owner = np.zeros(len(states), dtype=int)
    for cue in every_cue:
        scores = cue.log_likelihoods(obs, states, owner)
        assert not np.isnan(scores).any() and not np.isposinf(scores).any(), cue.name
        if cue.name != "location":
            assert np.isfinite(scores).all(), cue.name


def test_cue_outputs_feed_the_fusion():
    image, boxes = scene_with_targets()
    location, colour = LocationCue(), ColourCue()
    obs = observation(image, boxes, previous=np.array([[0.0, 0.0], [140.0, 100.0]]), cues=[colour])
    states = states_at([40, 40], [130, 10])                # on target 1; on the background, far from both
    owner = np.array([0, 0])
    result = CueFusion(2).fuse([location.log_likelihoods(obs, states, owner),
                                colour.log_likelihoods(obs, states, owner)], owner)
    assert result.weights[0] > 0.9 > 0.1 > result.weights[1]


def test_registry_builds_every_cue():
    assert set(CUES) == {"colour", "location", "foreground", "edges", "detections"}
    assert make_cue("colour", bins=4, sigma=0.2).config == ColourConfig(bins=4, sigma=0.2)
    assert isinstance(make_cue("foreground"), ForegroundColourCue)
    assert isinstance(make_cue("colour"), AppearanceCue) and not isinstance(make_cue("location"), AppearanceCue)
    with pytest.raises(UnknownCueError, match="known cues: colour, location, foreground, edges"):
        make_cue("sound")
    with pytest.raises(TrackingError, match="no option bins; its options are sigma, gate, literal"):
        make_cue("location", bins=3)


@pytest.mark.parametrize("build, message", [
    (lambda: LocationConfig(sigma=0), "sigma must be a positive"),
    (lambda: LocationConfig(sigma=float("nan")), "sigma must be a positive"),
    (lambda: LocationConfig(literal="yes"), "LocationConfig.literal must be True or False"),
    (lambda: ColourConfig(bins=0), "bins must be a positive integer"),
    (lambda: ColourConfig(bins=32), "bins must be at most 16"),
    (lambda: ColourConfig(bins=8.0), "bins must be a positive integer"),
    (lambda: ColourConfig(sigma=-0.1), "sigma must be a positive"),
    (lambda: ColourConfig(samples=(12,)), "samples must be a pair"),
    (lambda: ColourConfig(samples=(0, 5)), "samples must be a positive integer"),
    (lambda: LocationCue(ColourConfig()), "needs a LocationConfig"),
    (lambda: BackgroundConfig(history=0), "history must be a positive integer"),
    (lambda: BackgroundConfig(var_threshold=-1), "var_threshold must be a positive"),
    (lambda: BackgroundConfig(background_ratio=1.5), r"background_ratio must lie in \(0, 1\]"),
    (lambda: BackgroundConfig(learning_rate=2.0), "learning_rate must be None or lie in"),
    (lambda: BackgroundConfig(detect_shadows="yes"), "detect_shadows must be True or False"),
])
def test_bad_configurations_raise_clear_errors(build, message):
    with pytest.raises(TrackingError, match=message):
        build()


def test_bad_inputs_raise_clear_errors():
    image, boxes = scene_with_targets()
    obs = observation(image, boxes)
    cue = ColourCue()
    one = cue.build_templates(image, boxes[:1])
    rows = r"the colour templates must have one row per target \(2\), got shape "
    with pytest.raises(TrackingError, match=rows + r"\(1, 512\)"):
        Observation(image, None, obs.centres, obs.sizes, np.zeros((0, 2)), templates={"colour": one})
    with pytest.raises(TrackingError, match=rows + r"\(512,\)"):
        obs.with_templates({"colour": one[0]})
    for read in (lambda: cue.log_likelihoods(obs, states_at([40, 40]), np.array([0])),
                 lambda: cue.false_alarm_histogram(obs), lambda: cue.templates(obs)):
        with pytest.raises(TrackingError, match=r"the colour cue needs the targets' templates: Observation\(templates"):
            read()
    coarse = obs.with_templates({"colour": ColourCue(ColourConfig(bins=4)).build_templates(image, boxes)})
    with pytest.raises(TrackingError, match="the colour templates have 64 bins, the cue 512"):
        cue.log_likelihoods(coarse, states_at([40, 40]), np.array([0]))
    with pytest.raises(TrackingError, match=r"states must have shape \(P, 5\)"):
        LocationCue().log_likelihoods(obs, np.zeros((3, 4)), np.zeros(3, dtype=int))
    with pytest.raises(TrackingError, match="owners must be target indices 0..1"):
        LocationCue().log_likelihoods(obs, states_at([1, 1]), np.array([2]))
    with pytest.raises(TrackingError, match="must be finite"):
        LocationCue().log_likelihoods(obs, states_at([np.nan, 1]), np.array([0]))
    with pytest.raises(TrackingError, match=r"\(H, W, 3\) uint8"):
        Observation(image.astype(float), None, obs.centres, obs.sizes, np.zeros((0, 2)))
    with pytest.raises(TrackingError, match="mask > 0"):
        Observation(image, np.zeros(image.shape[:2], np.uint8), obs.centres, obs.sizes, np.zeros((0, 2)))
    with pytest.raises(TrackingError, match="lies outside the 140x100 image"):
        cue.build_templates(image, [[30, 20, 20, 40], [150, 10, 5, 5]])
    with pytest.raises(TrackingError, match="both must be positive"):
        cue.build_templates(image, [[10, 10, 0, 5]])
    with pytest.raises(TrackingError, match=r"\(H, W, 3\) uint8"):
        cue.build_templates(image.astype(float), boxes)
    with pytest.raises(TrackingError, match="mask > 0"):
        ForegroundColourCue().build_templates(image, boxes, foreground=np.ones(image.shape[:2], np.uint8))


# -- background model ------------------------------------------------------------------------------
def textured_background(rng, height=60, width=80):
    return rng.integers(40, 200, size=(height, width, 3)).astype(np.uint8)


def noisy(frame, rng):
    return np.clip(frame + rng.normal(0, 2, frame.shape), 0, 255).astype(np.uint8)


def test_background_model_flags_a_moving_square():
    rng = np.random.default_rng(5)
    scene = textured_background(rng)
    model = BackgroundModel()
    assert model.warm_up(noisy(scene, rng) for _ in range(30)) == 30
    for step in range(6):
        frame = noisy(scene, rng)
        x, y = 10 + 8 * step, 15 + 3 * step
        frame[y:y + 12, x:x + 12] = GREEN
        mask = model.apply(frame)
        square = np.zeros(mask.shape, bool)
        square[y:y + 12, x:x + 12] = True
        assert mask.dtype == np.bool_ and mask.shape == scene.shape[:2]
        assert mask[square].mean() > 0.95
        assert mask[~square].mean() < 0.01
    assert model.frames_seen == 36


def test_background_model_counts_shadows_as_background_when_asked():
    rng = np.random.default_rng(6)
    scene = textured_background(rng)
    frame = scene.copy()
    frame[10:30, 10:30] = (scene[10:30, 10:30] * 0.7).astype(np.uint8)     # darker, same chromaticity
    shadow = np.zeros(scene.shape[:2], bool)
    shadow[10:30, 10:30] = True
    fractions = {}
    for detect in (True, False):
        model = BackgroundModel(BackgroundConfig(detect_shadows=detect))
        model.warm_up(noisy(scene, rng) for _ in range(30))
        fractions[detect] = model.apply(frame)[shadow].mean()
    assert fractions[True] < 0.05 and fractions[False] > 0.95


def test_background_model_rejects_frames_of_another_shape():
    model = BackgroundModel()
    model.apply(np.zeros((20, 30, 3), np.uint8))
    with pytest.raises(TrackingError, match="differs from the model's"):
        model.apply(np.zeros((30, 20, 3), np.uint8))
    with pytest.raises(TrackingError, match="uint8"):
        model.apply(np.zeros((20, 30, 3)))


# -- docstring examples ----------------------------------------------------------------------------
#: The modules of the cues package that hold examples (similarity.py has none).
CUE_MODULES = [module for module in (importlib.import_module(f"{cues.__name__}.{info.name}")
                                     for info in pkgutil.iter_modules(cues.__path__))
               if ">>>" in inspect.getsource(module)]


@pytest.mark.parametrize("module", [cues, *CUE_MODULES, background], ids=lambda m: m.__name__)
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_the_bin_image_of_a_frame_is_computed_once_for_every_cue(monkeypatch):
    from belief_tracking.cues import observation as observation_module

    calls = []
    real = observation_module.colour_bins
    monkeypatch.setattr(observation_module, "colour_bins", lambda image, bins: calls.append(bins) or real(image, bins))
    image, boxes = scene_with_targets()
    mask = red_target_mask(image)
    colour, foreground = ColourCue(), ForegroundColourCue()
    obs = observation(image, boxes, foreground=mask, cues=[colour, foreground])  # templates: no observation
    assert calls == []
    first = obs.colour_bins(8)
    assert obs.colour_bins(8) is first and calls == [8]
    states, owner = states_at((40, 40), (100, 60)), np.array([0, 1])
    for cue in (colour, foreground):
        cue.log_likelihoods(obs, states, owner)
        cue.histograms(obs, states, owner)
        cue.false_alarm_histogram(obs)
    score_cues([colour, foreground], obs, states, owner)
    # A copy with other templates or with the frame's assignment shares the frame's features.
    assert obs.with_templates(dict(obs.templates)).colour_bins(8) is first
    assert obs.with_assignment(None).colour_bins(8) is first
    assert calls == [8]
    obs.colour_bins(4)
    assert calls == [8, 4]


@pytest.mark.parametrize("cue_type", [ColourCue, ForegroundColourCue])
def test_scores_of_many_particles_are_built_block_by_block_without_changing_them(cue_type):
    rng = np.random.default_rng(5)
    image = rng.integers(0, 256, size=(80, 120, 3), dtype=np.uint8)
    mask = rng.random((80, 120)) < 0.5
    cue = cue_type(ColourConfig(samples=(6, 12)))
    obs = observation(image, TWO_BOXES, foreground=mask, cues=[cue])
    n = 2 * HISTOGRAM_BLOCK + 7
    states = np.column_stack([rng.uniform(0, 120, n), rng.uniform(0, 80, n), np.zeros((n, 2)), rng.normal(0, 0.1, n)])
    owner = rng.integers(0, 2, n)
    references = np.concatenate([cue.templates(obs), cue.false_alarm_histogram(obs)[None, :]])
    np.testing.assert_array_equal(cue.references(obs, cue.frame_features(obs)), references)
    whole = log_gaussian(1.0 - bhattacharyya(cue.histograms(obs, states, owner), references), cue.config.sigma)
    assert np.allclose(cue.log_likelihoods(obs, states, owner), whole, rtol=0, atol=1e-12)


def test_cues_scored_together_score_as_each_alone_and_their_template_similarity_is_the_smallest_rho():
    class CoarseForegroundCue(ForegroundColourCue):
        """A second foreground cue, of other bins: its templates need a name of their own."""

        name = "coarse foreground"

    rng = np.random.default_rng(8)
    image = rng.integers(0, 256, size=(80, 120, 3), dtype=np.uint8)
    image[:, :30] = 40                                  # a flat stripe: bins and edges the frame lacks elsewhere
    mask = rng.random((80, 120)) < 0.5
    cues = [ColourCue(ColourConfig(samples=(6, 12))), LocationCue(),
            ForegroundColourCue(ColourConfig(samples=(6, 12))), EdgeCue(),
            CoarseForegroundCue(ColourConfig(bins=4, samples=(6, 12)))]
    templates = observation(image, TWO_BOXES, foreground=mask, cues=cues).templates
    assert len(templates) == 4
    n = HISTOGRAM_BLOCK + 9
    states = np.column_stack([rng.uniform(-5, 125, n), rng.uniform(-5, 85, n), np.zeros((n, 2)),
                              rng.normal(0, 0.1, n)])
    owner = rng.integers(0, 2, n)
    fresh = lambda: Observation(image, mask, [[16.0, 22.0], [67.0, 44.0]], [[12.0, 24.0], [14.0, 28.0]],  # noqa: E731
                                np.zeros((0, 2)), templates=templates)
    together = score_cues(cues, fresh(), states, owner)
    for cue, scores in zip(cues, together):
        np.testing.assert_allclose(scores, cue.log_likelihoods(fresh(), states, owner), rtol=0, atol=1e-12)
    appearance = [cue for cue in cues if isinstance(cue, AppearanceCue)]
    obs = fresh()
    rho = [bhattacharyya(cue.histograms(obs, states, owner), cue.templates(obs))[np.arange(n), owner]
           for cue in appearance]
    np.testing.assert_allclose(template_similarity(appearance, fresh(), states, owner), np.min(rho, axis=0),
                               rtol=0, atol=1e-12)
    with pytest.raises(TrackingError, match="at least one"):
        template_similarity([], fresh(), states, owner)


# -- the sparse Bhattacharyya sums and the compact bin image --------------------------------------
def test_bhattacharyya_over_the_filled_bins_equals_the_dense_product_to_rounding():
    rng = np.random.default_rng(11)
    histograms = rng.random((60, 512)) * (rng.random((60, 512)) < 0.05)
    histograms[[3, 17]] = 0.0                                     # boxes without any weight
    histograms /= np.maximum(histograms.sum(axis=1, keepdims=True), 1e-300)
    references = rng.random((9, 512)) * (rng.random((9, 512)) < 0.3)
    references /= references.sum(axis=1, keepdims=True)
    dense = np.clip(np.sqrt(histograms) @ np.sqrt(references).T, 0.0, 1.0)
    rho = bhattacharyya(histograms, references)
    assert rho.shape == (60, 9)
    np.testing.assert_allclose(rho, dense, rtol=0, atol=1e-15)
    assert (rho[[3, 17]] == 0.0).all()
    # One histogram or one reference drops its axis, as in a matrix product.
    np.testing.assert_allclose(bhattacharyya(histograms[5], references), dense[5], rtol=0, atol=1e-15)
    np.testing.assert_allclose(bhattacharyya(histograms, references[2]), dense[:, 2], rtol=0, atol=1e-15)
    with pytest.raises(TrackingError, match="same B"):
        bhattacharyya(histograms, references[:, :8])


@pytest.mark.parametrize("bins", [1, 7, 8, 16, 40, 41])
def test_colour_bins_are_compact_and_exact(bins):
    rng = np.random.default_rng(bins)
    image = rng.integers(0, 256, size=(30, 20, 3), dtype=np.uint8)
    image[0, :3] = [(0, 0, 0), (255, 255, 255), (255, 0, 128)]
    channels = image.astype(np.int64) * bins // 256
    expected = (channels[..., 2] * bins + channels[..., 1]) * bins + channels[..., 0]
    found = colour_bins(image, bins)
    assert found.dtype == (np.uint16 if bins <= 40 else np.intp)
    np.testing.assert_array_equal(found, expected)


def test_histograms_of_a_compact_bin_image_equal_those_of_an_intp_one():
    rng = np.random.default_rng(4)
    image = rng.integers(0, 256, size=(40, 50, 3), dtype=np.uint8)
    mask = rng.random((40, 50)) < 0.5
    compact = colour_bins(image, 8)
    centres = np.column_stack([rng.uniform(-10, 60, 30), rng.uniform(-10, 50, 30)])
    sizes = rng.uniform(4, 30, (30, 2))
    for foreground in (None, mask):
        np.testing.assert_array_equal(
            cues.kernel_histograms(compact, centres, sizes, 512, (6, 12), foreground),
            cues.kernel_histograms(compact.astype(np.intp), centres, sizes, 512, (6, 12), foreground))


def test_both_colour_cues_count_the_scene_once_per_frame(monkeypatch):
    image, boxes = scene_with_targets()
    mask = red_target_mask(image)
    colour, foreground = ColourCue(), ForegroundColourCue()
    obs = observation(image, boxes, foreground=mask, cues=[colour, foreground])
    pixels = image.shape[0] * image.shape[1]
    scene_counts = []
    real = np.bincount

    def counting(x, *args, **kwargs):
        if np.size(x) == pixels:
            scene_counts.append(1)
        return real(x, *args, **kwargs)

    monkeypatch.setattr(np, "bincount", counting)
    states = states_at((40, 40), (100, 60))
    colour.log_likelihoods(obs, states, np.array([0, 1]))
    foreground.log_likelihoods(obs, states, np.array([0, 1]))
    monkeypatch.undo()
    assert len(scene_counts) == 1
    np.testing.assert_array_equal(colour.false_alarm_histogram(obs),
                                  colour.false_alarm_histogram(observation(image, boxes, foreground=mask,
                                                                           cues=[colour])))
    # The counts are the frame's, kept once: the same read-only array however often they are asked for.
    counts = obs.scene_counts(obs.colour_bins(8), None, 512)
    np.testing.assert_array_equal(counts, np.bincount(colour_bins(image, 8).ravel(), minlength=512))
    assert obs.scene_counts(obs.colour_bins(8), None, 512) is counts and not counts.flags.writeable


def test_background_masks_of_successive_frames_are_separate_arrays():
    rng = np.random.default_rng(8)
    scene = textured_background(rng)
    model = BackgroundModel()
    model.warm_up(noisy(scene, rng) for _ in range(20))
    frame = noisy(scene, rng)
    frame[10:20, 10:20] = GREEN
    first = model.apply(frame)
    kept = first.copy()
    second = model.apply(noisy(scene, rng))
    assert not np.shares_memory(first, second)
    np.testing.assert_array_equal(first, kept)
    assert first[10:20, 10:20].all() and not second[10:20, 10:20].any()


@pytest.mark.parametrize("bins", range(1, 17))
def test_colour_bins_of_every_bin_count_follow_the_formula(bins):
    rng = np.random.default_rng(bins)
    image = rng.integers(0, 256, size=(7, 9, 3), dtype=np.uint8)
    image[0, :3] = [[0, 0, 0], [255, 255, 255], [31, 32, 224]]
    channel = image.astype(np.int64) * bins // 256
    expected = (channel[..., 2] * bins + channel[..., 1]) * bins + channel[..., 0]
    found = colour_bins(image, bins)
    assert found.dtype == np.uint16
    np.testing.assert_array_equal(found, expected)
