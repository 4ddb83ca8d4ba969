"""Synthetic scenes: determinism, exact ground truth and the difficulties each preset stages."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief_tracking import scene_config, scene_presets, scene_render, scenes
from belief_tracking.errors import TrackingError
from belief_tracking.scenes import (
    CROWDS,
    PRESETS,
    BackgroundStyle,
    Lighting,
    SceneConfig,
    Shadow,
    StaticShape,
    Walker,
    crossing,
    crowd,
    demo,
    entering_leaving,
    illumination,
    partial_occlusion,
    render,
    scale_change,
    similar_colours,
    write_gt,
    write_video,
)

BLACK = (0, 0, 0)


@pytest.fixture(scope="module")
def rendered(rendered_scene):
    """Every preset rendered once with seed 0 (rendering is the slow part of these tests)."""
    return {name: rendered_scene(make(0)) for name, make in PRESETS.items()}


def quiet(config: SceneConfig, colour=BLACK) -> SceneConfig:
    """The same scene on a flat background, with no sensor noise and no lighting effects."""
    return replace(config, background=BackgroundStyle.flat(colour), noise_std=0.0, lighting=Lighting())


def changed_pixels_box(frame: np.ndarray, background_colour=BLACK):
    """Bounding box (x, y, w, h) of the pixels that differ from a flat background, or None."""
    changed = np.any(frame != np.array(background_colour, dtype=np.uint8), axis=2)
    rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
    if rows.size == 0:
        return None
    return (int(cols[0]), int(rows[0]), int(cols[-1] - cols[0] + 1), int(rows[-1] - rows[0] + 1))


def track_of(scene, walker_id: int):
    """Frame indices, boxes (0-based x, y, w, h) and visibilities of one walker, in frame order."""
    rows = scene.ground_truth[:, 1] == walker_id
    table = scene.ground_truth[rows]
    boxes = table[:, 2:6] - np.array([1, 1, 0, 0])
    return table[:, 0] - 1, boxes, scene.visibility[rows]


# -- determinism ---------------------------------------------------------------------------------------

def test_the_same_seed_gives_byte_identical_frames_and_ground_truth(rendered):
    again = render(crossing(0))
    first = rendered["crossing"]
    assert again.frames.tobytes() == first.frames.tobytes()
    assert np.array_equal(again.ground_truth, first.ground_truth)
    assert np.array_equal(again.visibility, first.visibility)


def test_another_seed_changes_background_and_noise_but_not_the_layout(rendered, rendered_scene):
    first = rendered["crossing"]
    other = rendered_scene(crossing(1))
    assert not np.array_equal(other.frames[0], first.frames[0])
    # averaged over 100 frames the sensor noise nearly cancels: what is left is the background
    assert np.abs(other.frames.mean(axis=0) - first.frames.mean(axis=0)).mean() > 2
    assert np.array_equal(other.ground_truth, first.ground_truth)


def test_the_background_changes_with_the_seed_without_sensor_noise():
    config = replace(crossing(0), noise_std=0.0, n_frames=1)
    assert not np.array_equal(render(config).frames, render(replace(config, seed=1)).frames)


def test_an_explicit_generator_replaces_the_configured_seed():
    config = replace(crossing(0), n_frames=3)
    explicit = render(config, np.random.default_rng(7))
    assert explicit.frames.tobytes() == render(replace(config, seed=7)).frames.tobytes()


def test_consecutive_frames_get_fresh_noise():
    config = replace(crossing(0), walkers=(), n_frames=2)
    scene = render(config)
    assert not np.array_equal(scene.frame(0), scene.frame(1))
    quiet_scene = render(replace(config, noise_std=0.0))
    assert np.array_equal(quiet_scene.frame(0), quiet_scene.frame(1))


def test_a_longer_scene_begins_with_the_frames_of_a_shorter_one():
    short = render(replace(demo(3), n_frames=5))
    long = render(replace(demo(3), n_frames=8))
    assert np.array_equal(long.frames[:5], short.frames)
    assert np.array_equal(long.ground_truth[: len(short.ground_truth)], short.ground_truth)


# -- exact ground truth --------------------------------------------------------------------------------

colours = st.tuples(*[st.integers(1, 255)] * 3)


@settings(max_examples=60, deadline=None)
@given(
    centre=st.tuples(st.floats(-40, 104), st.floats(-60, 108)),
    velocity=st.tuples(st.floats(-6, 6), st.floats(-6, 6)),
    size=st.tuples(st.floats(1, 40), st.floats(1, 70)),
    scale_rate=st.floats(0.9, 1.1),
    shirt=colours, trousers=colours, head=colours,
)
def test_every_box_is_the_extent_of_the_drawn_walker(centre, velocity, size, scale_rate, shirt, trousers, head):
    # On a black background every drawn pixel differs from the background, so the bounding
    # box of the changed pixels is the walker's extent in the image, border clipping included.
    walker = Walker(id=4, first_frame=0, start_centre=centre, velocity=velocity, size=size,
                    shirt=shirt, trousers=trousers, head=head, scale_rate=scale_rate)
    scene = render(SceneConfig(walkers=(walker,), width=64, height=48, n_frames=4,
                               background=BackgroundStyle.flat(BLACK), noise_std=0.0))
    for t in range(4):
        expected = changed_pixels_box(scene.frame(t))
        boxes = scene.boxes_at(t)
        if expected is None:
            assert boxes == {}
        else:
            assert boxes == {4: expected}
            assert scene.visibility_at(t) == {4: 1.0}


def test_a_box_partly_outside_the_image_is_clipped_and_one_fully_outside_has_no_row():
    walker = Walker(id=1, first_frame=0, start_centre=(-5.0, 24.0), velocity=(-10.0, 0.0), size=(20, 40),
                    shirt=(0, 0, 200), trousers=(200, 0, 0))
    scene = render(SceneConfig(walkers=(walker,), width=64, height=48, n_frames=3,
                               background=BackgroundStyle.flat(BLACK), noise_std=0.0))
    assert walker.box_at(0) == (-15, 4, 20, 40)
    # Only columns 0..4 of the image hold part of the walker.  The narrow head (rows 4..11)
    # lies further left, so the box starts at the shoulders.
    assert scene.boxes_at(0) == {1: (0, 12, 5, 32)}
    assert scene.boxes_at(1) == {}  # x from -25 to -6: gone
    assert scene.ground_truth[:, 0].tolist() == [1]


def test_visibility_counts_the_pixels_left_uncovered_by_nearer_walkers_and_occluders():
    far = Walker(id=1, first_frame=0, start_centre=(30.0, 24.0), size=(16, 30), velocity=(1.5, 0.0),
                 shirt=(0, 0, 200), trousers=(0, 200, 0), head=(200, 0, 0), depth=5.0)
    near = Walker(id=2, first_frame=0, start_centre=(44.0, 30.0), size=(14, 26), velocity=(-1.0, 0.0),
                  shirt=(0, 90, 90), trousers=(90, 90, 0), head=(90, 0, 90), depth=1.0)
    post = StaticShape(x=26, y=0, w=3, h=48, colour=(255, 255, 255))
    config = SceneConfig(walkers=(far, near), occluders=(post,), width=64, height=48, n_frames=12,
                         background=BackgroundStyle.flat(BLACK), noise_std=0.0)
    together = render(config)
    seen_partial = {1: False, 2: False}
    for walker in (far, near):
        alone = render(replace(config, walkers=(walker,), occluders=()))
        for t in range(12):
            drawn_alone = np.any(alone.frame(t) != 0, axis=2)
            # each walker's colours are used by nothing else, so an unchanged pixel is a visible one
            still_visible = drawn_alone & np.all(together.frame(t) == alone.frame(t), axis=2)
            expected = still_visible.sum() / drawn_alone.sum()
            assert together.visibility_at(t)[walker.id] == pytest.approx(expected, abs=1e-12)
            assert together.boxes_at(t)[walker.id] == alone.boxes_at(t)[walker.id]  # occlusion never shrinks a box
            seen_partial[walker.id] |= 0 < expected < 0.9
    assert seen_partial == {1: True, 2: True}


def test_on_equal_depth_the_lower_id_is_in_front():
    a = Walker(id=1, first_frame=0, start_centre=(32.0, 24.0), size=(10, 20), shirt=(0, 0, 200), trousers=(0, 0, 200))
    b = Walker(id=2, first_frame=0, start_centre=(32.0, 24.0), size=(10, 20), shirt=(200, 0, 0), trousers=(200, 0, 0))
    scene = render(SceneConfig(walkers=(b, a), width=64, height=48, n_frames=1,
                               background=BackgroundStyle.flat(BLACK), noise_std=0.0))
    assert scene.visibility_at(0) == {1: 1.0, 2: 0.0}


def test_a_walker_at_half_a_pixel_per_frame_steps_one_pixel_every_other_frame():
    # halves round up, so the box moves steadily (rounding halves to even would stall it)
    walker = Walker(id=1, first_frame=0, start_centre=(10.0, 10.0), velocity=(0.5, 0.0), size=(20, 20),
                    shirt=BLACK, trousers=BLACK)
    assert [walker.box_at(t)[0] for t in range(9)] == [0, 1, 1, 2, 2, 3, 3, 4, 4]


def test_walkers_appear_only_between_their_first_and_last_frames():
    walker = Walker(id=3, first_frame=2, last_frame=4, start_centre=(32.0, 24.0), size=(10, 20),
                    shirt=(0, 0, 200), trousers=(200, 0, 0))
    scene = render(SceneConfig(walkers=(walker,), width=64, height=48, n_frames=8, noise_std=0.0))
    assert scene.ground_truth[:, 0].tolist() == [3, 4, 5]
    assert scene.initial_boxes() == {3: (2, walker.box_at(2))}
    assert walker.box_at(2) == (27, 14, 10, 20)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_preset_boxes_lie_inside_the_image_and_match_the_walkers(rendered, name):
    scene = rendered[name]
    config = scene.config
    gt = scene.ground_truth
    assert gt.shape[1] == 10 and gt.dtype.kind == "i"
    assert np.all(gt[:, 2:4] >= 1) and np.all(gt[:, 4:6] >= 1)
    assert np.all(gt[:, 2] - 1 + gt[:, 4] <= config.width) and np.all(gt[:, 3] - 1 + gt[:, 5] <= config.height)
    assert np.all(gt[:, 6] == 1) and np.all(gt[:, 7:] == -1)
    assert np.all((scene.visibility >= 0) & (scene.visibility <= 1))
    order = np.lexsort((gt[:, 1], gt[:, 0]))
    assert np.array_equal(order, np.arange(len(gt)))  # sorted by frame, then id
    walkers = {w.id: w for w in config.walkers}
    for row in gt:
        x, y, w, h = walkers[int(row[1])].box_at(int(row[0]) - 1)
        if x >= 0 and y >= 0 and x + w <= config.width and y + h <= config.height:
            assert tuple(int(v) for v in row[2:6]) == (x + 1, y + 1, w, h)


def test_scene_accessors_agree_with_the_ground_truth_table(rendered):
    scene = rendered["demo"]
    assert len(scene) == 100 and len(list(scene)) == 100
    assert scene.ids == (1, 2, 3, 4)
    assert scene.frame(7) is not None and np.array_equal(scene.frame(7), scene.frames[7])
    rows = scene.ground_truth[scene.ground_truth[:, 0] == 8]
    assert scene.boxes_at(7) == {int(r[1]): (int(r[2]) - 1, int(r[3]) - 1, int(r[4]), int(r[5])) for r in rows}
    initial = scene.initial_boxes()
    assert set(initial) == {1, 2, 3, 4}
    for walker_id, (t, box) in initial.items():
        assert scene.boxes_at(t)[walker_id] == box
    with pytest.raises(IndexError):
        scene.frame(100)
    with pytest.raises(ValueError):
        scene.frames[0, 0, 0] = 1  # frames are read-only


# -- the difficulties of the presets -------------------------------------------------------------------

@pytest.mark.parametrize("name, meet_frame", [("crossing", 50), ("similar_colours", 50), ("demo", 45)])
@pytest.mark.parametrize("seed", [0, 1])
def test_the_crossing_hides_walker_one_completely_and_only_near_the_meeting(rendered, rendered_scene, name, meet_frame,
                                                                          seed):
    scene = rendered[name] if seed == 0 else rendered_scene(PRESETS[name](seed))
    frames, _, visibility = track_of(scene, 1)
    assert visibility[frames == meet_frame][0] == 0.0
    hidden = frames[visibility == 0.0]
    assert hidden.min() >= meet_frame - 6 and hidden.max() <= meet_frame + 6 and len(hidden) >= 5
    far_from_meeting = np.abs(frames - meet_frame) >= 20
    assert np.all(visibility[far_from_meeting] == 1.0)
    assert np.all(track_of(scene, 2)[2] == 1.0)  # the nearer walker is never hidden


def test_the_crossing_walkers_wear_different_colours_and_the_similar_ones_alike():
    def shirts(config):
        return [np.array(w.shirt, dtype=float) for w in config.walkers[:2]]

    different, alike = shirts(crossing(0)), shirts(similar_colours(0))
    assert np.abs(different[0] - different[1]).max() > 100
    assert np.abs(alike[0] - alike[1]).max() <= 16
    # same bins of an 8 x 8 x 8 colour histogram (32 grey levels a bin)
    assert np.array_equal(alike[0] // 32, alike[1] // 32)


def test_partial_occlusion_hides_part_of_a_walker_but_never_all_of_it(rendered):
    scene = rendered["partial_occlusion"]
    minimum = {walker_id: track_of(scene, walker_id)[2].min() for walker_id in scene.ids}
    assert 0.3 < minimum[1] < 0.7  # behind walker 2's body
    assert 0.3 < minimum[3] < 0.7  # behind the pillar
    assert minimum[2] == 1.0


def test_the_illumination_preset_changes_brightness_as_configured(rendered):
    scene = rendered["illumination"]
    light = scene.config.lighting
    before = scene.frame(10).astype(float).mean()
    for t in (20, 30, 45, 60):
        measured = scene.frame(t).astype(float).mean() / before
        assert measured == pytest.approx(light.gain(t) / light.gain(10), rel=0.03)
    assert light.gain(30) == 1.5 and light.gain(20) == 1.25


def test_the_shadow_darkens_a_walker_who_enters_it(rendered):
    scene = rendered["illumination"]
    shadow = scene.config.lighting.shadows[0]

    def shirt_level(t):
        x, y, w, h = scene.boxes_at(t)[2]
        centre = scene.frame(t)[y + int(0.4 * h) - 2: y + int(0.4 * h) + 2, x + w // 2 - 2: x + w // 2 + 2]
        return centre.astype(float).mean()

    outside, inside = shirt_level(5), shirt_level(80)
    assert scene.boxes_at(80)[2][0] >= shadow.x and scene.boxes_at(5)[2][0] + scene.boxes_at(5)[2][2] < shadow.x
    assert inside / outside == pytest.approx(shadow.darkening, rel=0.1)


def test_shadows_and_gain_multiply_exactly_on_a_flat_scene():
    lighting = Lighting(gain_keyframes=((0, 1.0), (2, 2.0)), shadows=(Shadow(x=0, y=0, w=10, h=48, darkening=0.5),))
    scene = render(SceneConfig(width=64, height=48, n_frames=3, background=BackgroundStyle.flat((40, 80, 100)),
                               lighting=lighting, noise_std=0.0))
    assert scene.frame(0)[0, 20].tolist() == [40, 80, 100]
    assert scene.frame(0)[0, 5].tolist() == [20, 40, 50]
    assert scene.frame(1)[0, 20].tolist() == [60, 120, 150]
    assert scene.frame(2)[0, 5].tolist() == [40, 80, 100]


def test_the_scale_preset_grows_one_walker_and_shrinks_the_other(rendered):
    scene = rendered["scale_change"]
    _, growing, _ = track_of(scene, 1)
    _, shrinking, _ = track_of(scene, 2)
    assert np.all(np.diff(growing[:, 3]) >= 0) and np.all(np.diff(shrinking[:, 3]) <= 0)
    assert growing[-1, 3] / growing[0, 3] == pytest.approx(1.01 ** 89, rel=0.03)
    assert shrinking[-1, 2] / shrinking[0, 2] == pytest.approx(0.99 ** 89, rel=0.05)
    assert growing[-1, 2] > 2 * growing[0, 2]


def test_the_demo_scene_is_small_and_has_a_full_occlusion_and_a_light_change(rendered):
    scene = rendered["demo"]
    config = scene.config
    assert (config.width, config.height) == (320, 240)
    assert 3 <= len(config.walkers) <= 4 and 80 <= config.n_frames <= 120
    assert scene.visibility.min() == 0.0
    gains = [config.lighting.gain(t) for t in range(config.n_frames)]
    assert max(gains) / min(gains) > 1.2
    assert config.lighting.shadows and config.occluders


@pytest.mark.parametrize("seed", [0, 1])
def test_the_entering_leaving_walkers_come_in_and_go_out_at_the_documented_frames(rendered, seed):
    scene = rendered["entering_leaving"] if seed == 0 else render(entering_leaving(seed))
    config = scene.config
    assert (config.width, config.height, len(scene)) == (320, 240, 200)
    assert scene.boxes_at(0) == {} and not np.any(scene.ground_truth[:, 0] <= 5)  # frames 0-4 are empty
    documented = {1: (5, 139, "left"), 2: (20, 167, "right"), 3: (40, 177, "left")}
    for walker_id, (first, last, entry_side) in documented.items():
        frames, boxes, visibility = track_of(scene, walker_id)
        assert (frames[0], frames[-1]) == (first, last)
        assert np.array_equal(frames, np.arange(first, last + 1))  # in view without a gap
        assert np.all(visibility == 1.0)  # nobody ever overlaps anybody
        right_edges = boxes[:, 0] + boxes[:, 2]
        enters_left = boxes[0, 0] == 0 and right_edges[-1] == config.width
        enters_right = right_edges[0] == config.width and boxes[-1, 0] == 0
        assert enters_left if entry_side == "left" else enters_right
        assert 1.5 <= abs(next(w for w in config.walkers if w.id == walker_id).velocity[0]) <= 2.5
    assert len(scene.ground_truth) == sum(last - first + 1 for first, last, _ in documented.values())
    last_frame = len(scene) - 1
    assert sum(last <= last_frame - 20 for _, last, _ in documented.values()) == 3
    # bands of rows that do not meet, and clothes of clearly different colours
    bands = sorted((w.box_at(w.first_frame)[1], w.box_at(w.first_frame)[1] + w.box_at(w.first_frame)[3])
                   for w in config.walkers)
    assert all(top_of_next >= bottom for (_, bottom), (top_of_next, _) in zip(bands, bands[1:]))
    shirts = np.array([w.shirt for w in config.walkers], dtype=float)
    assert min(np.abs(a - b).max() for i, a in enumerate(shirts) for b in shirts[i + 1:]) > 100
    assert len({tuple(c // 32) for c in shirts.astype(int)}) == 3  # three bins of an 8 x 8 x 8 histogram


# -- the crowds ----------------------------------------------------------------------------------------

def boxes_over_time(walker: Walker, n_frames: int) -> np.ndarray:
    return np.array([walker.box_at(t) for t in range(n_frames)])


def overlapping(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per frame, whether boxes ``a[t]`` and ``b[t]`` (x, y, w, h) share pixels."""
    return ((a[:, 0] < b[:, 0] + b[:, 2]) & (b[:, 0] < a[:, 0] + a[:, 2])
            & (a[:, 1] < b[:, 1] + b[:, 3]) & (b[:, 1] < a[:, 1] + a[:, 3]))


def test_the_crowds_have_a_registry_of_their_own():
    assert CROWDS == {"crowd": crowd}
    assert not set(CROWDS) & set(PRESETS)
    config = crowd(5)
    assert config.seed == 5 and config.name == "crowd"


@pytest.mark.parametrize("seed", range(5))
def test_a_crowd_is_twelve_walkers_dressed_alike_but_not_identically(seed):
    config = crowd(seed)
    assert len(config.walkers) == 12 and 100 <= config.n_frames <= 200
    assert sorted(w.id for w in config.walkers) == list(range(1, 13))
    shirts = np.array([w.shirt for w in config.walkers])
    trousers = np.array([w.trousers for w in config.walkers])
    assert np.abs(shirts - scenes.CROWD_SHIRT).max() <= 14 and np.abs(trousers - scenes.CROWD_TROUSERS).max() <= 10
    assert len({(w.shirt, w.trousers, w.head) for w in config.walkers}) == 12
    # one bin of an 8 x 8 x 8 colour histogram for all the shirts, one for all the trousers
    assert len({tuple(c) for c in shirts // 32}) == 1 and len({tuple(c) for c in trousers // 32}) == 1
    sizes = np.array([w.size for w in config.walkers])
    assert np.all(sizes.max(axis=0) / sizes.min(axis=0) < 1.3)
    assert sum(w.velocity[0] > 0 for w in config.walkers) == 6


@pytest.mark.parametrize("seed", range(5))
def test_every_crowd_walker_stays_in_view_and_crosses_several_others(seed):
    config = crowd(seed)
    boxes = {w.id: boxes_over_time(w, config.n_frames) for w in config.walkers}
    for walker_boxes in boxes.values():
        assert np.all(walker_boxes[:, :2] >= 0)
        assert np.all(walker_boxes[:, 0] + walker_boxes[:, 2] <= config.width)
        assert np.all(walker_boxes[:, 1] + walker_boxes[:, 3] <= config.height)
    crossed = []
    for walker in config.walkers:
        crossed.append(0)
        for other in config.walkers:
            if other.id == walker.id:
                continue
            shared = overlapping(boxes[walker.id], boxes[other.id])
            if (other.velocity[0] > 0) != (walker.velocity[0] > 0):
                crossed[-1] += bool(shared.any())
            else:
                assert not shared.any()           # walking the same way, one behind the other
    assert min(crossed) >= 2 and np.mean(crossed) >= 4


def test_the_crowd_hides_everybody_but_the_nearest_walker_at_some_point():
    scene = render(replace(crowd(0), noise_std=0.0))    # the sensor noise, the slow part, changes no visibility
    gt = scene.ground_truth
    assert np.array_equal(np.bincount(gt[:, 0])[1:], np.full(scene.config.n_frames, 12))  # all in view
    lowest = {walker_id: scene.visibility[gt[:, 1] == walker_id].min() for walker_id in scene.ids}
    nearest = min(scene.config.walkers, key=lambda w: w.depth).id
    assert lowest.pop(nearest) == 1.0
    assert all(v < 1.0 for v in lowest.values())
    assert sum(v < 0.2 for v in lowest.values()) >= 4           # some nearly wholly


def test_a_crowd_is_drawn_from_its_seed_alone():
    assert crowd(2) == crowd(2)
    assert crowd(2).walkers != crowd(3).walkers
    short = replace(crowd(2), n_frames=6)
    first, again = render(short), render(short)
    assert first.frames.tobytes() == again.frames.tobytes()
    assert np.array_equal(first.ground_truth, again.ground_truth)
    # the layout's random stream is not the background's: the same crowd on another background
    elsewhere = render(replace(short, seed=9))
    assert np.array_equal(elsewhere.ground_truth, first.ground_truth)
    assert not np.array_equal(elsewhere.frames[0], first.frames[0])


def test_the_scenes_module_re_exports_every_public_name_of_its_parts():
    parts = (scene_config, scene_presets, scene_render)
    assert sorted(scenes.__all__) == sorted(name for part in parts for name in part.__all__)
    for part in parts:
        for name in part.__all__:
            assert getattr(scenes, name) is getattr(part, name)


# -- files ---------------------------------------------------------------------------------------------

def test_ground_truth_file_round_trip(rendered, tmp_path):
    scene = rendered["crossing"]
    path = tmp_path / "gt.txt"
    write_gt(path, scene.ground_truth)
    loaded = np.loadtxt(path, delimiter=",", dtype=np.int64, ndmin=2)
    assert np.array_equal(loaded, scene.ground_truth)
    assert path.read_text().splitlines()[0] == "1,1,97,129,18,52,1,-1,-1,-1"


def test_float_rows_are_written_without_spurious_decimals(tmp_path):
    path = tmp_path / "tracks.txt"
    write_gt(path, np.array([[1.0, 2.0, 10.5, 20.25, 5.0, 8.0, 0.875, -1.0, -1.0, -1.0]]))
    assert path.read_text() == "1,2,10.5,20.25,5,8,0.875,-1,-1,-1\n"
    with pytest.raises(TrackingError):
        write_gt(path, np.zeros((3, 4)))


@pytest.mark.filterwarnings("ignore:Operation with tuple is deprecated")  # inside motmetrics, with pandas 3
def test_ground_truth_reads_back_with_motmetrics(rendered, tmp_path):
    mm = pytest.importorskip("motmetrics")
    scene = rendered["crossing"]
    path = tmp_path / "gt.txt"
    write_gt(path, scene.ground_truth)
    table = mm.io.loadtxt(str(path), fmt="mot15-2D")
    assert len(table) == len(scene.ground_truth)
    first = table.loc[(1, 1)]
    assert (first["X"], first["Y"], first["Width"], first["Height"]) == (96, 128, 18, 52)  # back to 0-based


def test_write_video_writes_a_readable_file_with_every_frame(tmp_path):
    cv2 = pytest.importorskip("cv2")
    scene = render(replace(demo(0), n_frames=12))
    path = tmp_path / "demo.avi"
    assert write_video(path, scene, fps=10) == 12
    capture = cv2.VideoCapture(str(path))
    read = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        read.append(frame)
    capture.release()
    assert len(read) == 12
    assert read[0].shape == (240, 320, 3)
    # Motion-JPEG is lossy but close
    assert np.abs(read[5].astype(int) - scene.frame(5).astype(int)).mean() < 8


def test_write_video_rejects_frames_of_the_wrong_kind(tmp_path):
    pytest.importorskip("cv2")
    with pytest.raises(TrackingError):
        write_video(tmp_path / "bad.avi", [np.zeros((8, 8), dtype=np.uint8)])
    with pytest.raises(TrackingError):
        write_video(tmp_path / "bad.avi", [np.zeros((8, 8, 3), np.uint8), np.zeros((16, 8, 3), np.uint8)])


# -- configuration errors ------------------------------------------------------------------------------

@pytest.mark.parametrize("make", [
    lambda: SceneConfig(walkers=(crossing(0).walkers[0], crossing(0).walkers[0])),
    lambda: SceneConfig(n_frames=0),
    lambda: SceneConfig(noise_std=-1.0),
    lambda: Walker(id=0, first_frame=0, start_centre=(0, 0), size=(5, 5), shirt=BLACK, trousers=BLACK),
    lambda: Walker(id=1, first_frame=0, start_centre=(0, 0), size=(0, 5), shirt=BLACK, trousers=BLACK),
    lambda: Walker(id=1, first_frame=3, last_frame=2, start_centre=(0, 0), size=(5, 5), shirt=BLACK, trousers=BLACK),
    lambda: Walker(id=1, first_frame=0, start_centre=(0, 0), size=(5, 5), shirt=(0, 0, 256), trousers=BLACK),
    lambda: Walker(id=1, first_frame=0, start_centre=(0, 0), size=(5, 5), shirt=BLACK, trousers=BLACK,
                   scale_rate=0.0),
    lambda: Lighting(gain_keyframes=((5, 1.0), (5, 2.0))),
    lambda: Lighting(gain_keyframes=((5, -1.0),)),
    lambda: Shadow(x=0, y=0, w=10, h=10, darkening=0.0),
    lambda: StaticShape(x=0, y=0, w=0, h=10, colour=BLACK),
])
def test_bad_configurations_are_rejected(make):
    with pytest.raises(TrackingError):
        make()


def test_presets_are_registered_and_carry_their_seed():
    assert set(PRESETS) == {"crossing", "similar_colours", "partial_occlusion", "illumination", "scale_change", "demo",
                            "entering_leaving", "lost_and_found"}
    for name, make in PRESETS.items():
        config = make(5)
        assert config.seed == 5 and config.name == name
    assert partial_occlusion(0).occluders and illumination(0).lighting.shadows
    assert any(w.scale_rate != 1 for w in scale_change(0).walkers)
