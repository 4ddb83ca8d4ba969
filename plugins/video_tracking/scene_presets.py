"""The library of synthetic scenes: the presets that stage the papers' difficulties, and the crowds.

Each function maps a seed to a :class:`~belief_tracking.scene_config.SceneConfig`;
:func:`~belief_tracking.scene_render.render` draws it.  :data:`PRESETS` holds the scenes of
the papers' experiments (SPEC Part C), and :data:`CROWDS` the crowd of twelve walkers dressed
alike, which scores identities (:func:`~belief_tracking.evaluation.identity_swaps`).  The
two registries are apart so that what iterates over the presets (the choice of defaults,
the experiments) sees the same eight scenes as before.  :mod:`belief_tracking.scenes`
re-exports every public name of this module.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np

from .scene_config import SKIN_BGR, BackgroundStyle, Colour, Lighting, SceneConfig, Shadow, StaticShape, Walker

__all__ = [
    "crossing",
    "similar_colours",
    "partial_occlusion",
    "illumination",
    "scale_change",
    "demo",
    "entering_leaving",
    "lost_and_found",
    "PRESETS",
    "crowd",
    "CROWDS",
    "CROWD_SHIRT",
    "CROWD_TROUSERS",
    "RED",
    "BLUE",
    "YELLOW",
    "GREEN",
    "NAVY",
    "CHARCOAL",
    "BROWN",
    "GREY",
]


# -- presets -------------------------------------------------------------------------------------------------
#
# The presets reproduce the difficulties of the papers' experiments (SPEC Part C) at
# 320 x 240.  Their layouts are fixed.  The seed changes only the background texture,
# the random background shapes and the sensor noise, so a property such as "walker 1 is
# fully hidden at frame 50" holds for every seed.

RED: Colour = (40, 40, 190)
BLUE: Colour = (180, 110, 40)
YELLOW: Colour = (40, 180, 200)
GREEN: Colour = (60, 160, 60)
NAVY: Colour = (90, 40, 30)
CHARCOAL: Colour = (45, 45, 50)
BROWN: Colour = (40, 70, 110)
GREY: Colour = (120, 120, 120)


def _crossing_pair(first: tuple[Colour, Colour], second: tuple[Colour, Colour], meet_frame: int = 50,
                   meet_x: float = 160.0) -> tuple[Walker, Walker]:
    """Two walkers crossing so that walker 1 passes fully behind walker 2 around ``meet_frame``.

    Walker 2 is nearer the camera, so it is larger (30 x 76 against 18 x 52) and lower in
    the image.  Walker 1's box (rows 128-179) lies inside walker 2's body below the head
    (rows 127-187).  Walker 1 is therefore hidden completely while the horizontal offset
    of their centres is at most 6 px.  At the relative speed of 2 px/frame this lasts
    about 7 frames, and the partial occlusion before and after it lasts about 8 frames
    each.
    """
    speed_1, speed_2 = 1.1, -0.9
    far = Walker(id=1, first_frame=0, start_centre=(meet_x - speed_1 * meet_frame, 154.0), velocity=(speed_1, 0.0),
                 size=(18, 52), shirt=first[0], trousers=first[1], depth=2.0)
    near = Walker(id=2, first_frame=0, start_centre=(meet_x - speed_2 * meet_frame, 150.0), velocity=(speed_2, 0.0),
                  size=(30, 76), shirt=second[0], trousers=second[1], depth=1.0)
    return far, near


def crossing(seed: int = 0) -> SceneConfig:
    """Two people in different colours cross; one is fully hidden by the other around frame 50 (W exp. 1).

    Walker 1 (red shirt, navy trousers, far) walks right and walker 2 (blue shirt,
    charcoal trousers, near) walks left.  Walker 1 is partly hidden from frame 39 to 61
    and fully hidden from frame 47 to 53.  The scene has 100 frames.
    """
    return SceneConfig(walkers=_crossing_pair((RED, NAVY), (BLUE, CHARCOAL)), n_frames=100, seed=seed, name="crossing")


def similar_colours(seed: int = 0) -> SceneConfig:
    """The crossing of :func:`crossing`, by two people dressed alike (W exp. 2, C exp. 2).

    The shirts are two close reds, (50, 50, 170) and (62, 46, 160), and the trousers two
    close dark blues.  They fall in the same bins of a coarse colour histogram.  A red
    sign of the same red hangs on the background (a distractor, as in C exp. 1).
    """
    sign = StaticShape(x=250, y=40, w=24, h=30, colour=(50, 50, 170))
    return SceneConfig(walkers=_crossing_pair(((50, 50, 170), (80, 45, 35)), ((62, 46, 160), (86, 50, 36))),
                       background=BackgroundStyle(shapes=(sign,)), n_frames=100, seed=seed,
                       name="similar_colours")


def partial_occlusion(seed: int = 0) -> SceneConfig:
    """People who are partly but never fully hidden, by another person or by a pillar.

    * Walker 2 (near, 30 x 76, rows 120-195) passes in front of walker 1 (far, 18 x 52,
      rows 92-143) around frame 40.  It covers walker 1's bottom 24 rows, which is
      about half of their pixels.
    * Walker 3 (20 x 50, rows 37-86) walks left behind a 10 px wide pillar (x 235-244,
      rows 20-94) around frame 20.  The pillar hides at most half of the body.

    The scene has 100 frames.
    """
    walkers = (
        Walker(id=1, first_frame=0, start_centre=(116.0, 118.0), velocity=(1.1, 0.0), size=(18, 52),
               shirt=YELLOW, trousers=BROWN, depth=2.0),
        Walker(id=2, first_frame=0, start_centre=(196.0, 158.0), velocity=(-0.9, 0.0), size=(30, 76),
               shirt=BLUE, trousers=CHARCOAL, depth=1.0),
        Walker(id=3, first_frame=0, start_centre=(275.0, 62.0), velocity=(-1.9, 0.0), size=(20, 50),
               shirt=GREEN, trousers=NAVY, depth=3.0),
    )
    pillar = StaticShape(x=235, y=20, w=10, h=75, colour=(150, 150, 160))
    return SceneConfig(walkers=walkers, occluders=(pillar,), n_frames=100, seed=seed, name="partial_occlusion")


def illumination(seed: int = 0) -> SceneConfig:
    """Strong light, then a shadow, with no occlusion (C exp. 1 and 2, W exp. 3).

    * The global gain rises from 1.0 at frame 15 to 1.5 at frame 25, stays there until
      frame 40, and falls back to 1.0 at frame 50.
    * Walker 2 walks right into a shadow (x >= 200, rows 100-239, darkening 0.5).  Their
      box starts to enter it at frame 52 and is fully inside from frame 61.
    * Walker 1 walks left along the top of the image, in the light.

    The scene has 100 frames.
    """
    walkers = (
        Walker(id=1, first_frame=0, start_centre=(260.0, 70.0), velocity=(-1.5, 0.0), size=(20, 54),
               shirt=RED, trousers=NAVY),
        Walker(id=2, first_frame=0, start_centre=(60.0, 165.0), velocity=(2.5, 0.0), size=(24, 64),
               shirt=GREEN, trousers=BROWN),
    )
    lighting = Lighting(gain_keyframes=((15, 1.0), (25, 1.5), (40, 1.5), (50, 1.0)),
                        shadows=(Shadow(x=200, y=100, w=120, h=140, darkening=0.5),))
    return SceneConfig(walkers=walkers, lighting=lighting, n_frames=100, seed=seed, name="illumination")


def scale_change(seed: int = 0) -> SceneConfig:
    """One person walks towards the camera and another walks away from it (W exp. 3).

    * Walker 1 starts at 14 x 36 near the top and walks down, growing by 1 % per frame.
      By frame 89 it is 2.4 times as large (34 x 87).
    * Walker 2 starts at 32 x 84 near the bottom and walks up, shrinking by 1 % per frame
      to 0.41 times its size (13 x 34).

    Their paths stay apart.  The scene has 90 frames.
    """
    walkers = (
        Walker(id=1, first_frame=0, start_centre=(90.0, 60.0), velocity=(0.3, 1.3), size=(14, 36),
               shirt=RED, trousers=NAVY, scale_rate=1.01),
        Walker(id=2, first_frame=0, start_centre=(240.0, 180.0), velocity=(-0.3, -1.1), size=(32, 84),
               shirt=BLUE, trousers=CHARCOAL, scale_rate=0.99),
    )
    return SceneConfig(walkers=walkers, n_frames=90, seed=seed, name="scale_change")


def demo(seed: int = 0) -> SceneConfig:
    """The scene of ``belief track --demo``: four people and most of the difficulties, in 100 frames.

    * Walkers 1 and 2 cross as in :func:`crossing`, with walker 1 fully hidden around
      frame 45.
    * Walker 3 walks down the right side towards the camera, growing by 0.6 % per frame.
    * Walker 4 walks left along the top behind a pillar (partial occlusion, around
      frame 25) and then into a shadow on the left (x < 90, rows 0-109, darkening 0.55).
    * The light brightens from gain 1.0 at frame 60 to 1.35 at frame 72 (the sun comes
      out) and stays bright.
    """
    crossing_far, crossing_near = _crossing_pair((RED, NAVY), (BLUE, CHARCOAL), meet_frame=45, meet_x=150.0)
    walkers = (
        crossing_far,
        crossing_near,
        Walker(id=3, first_frame=0, start_centre=(270.0, 70.0), velocity=(-0.2, 1.0), size=(16, 42),
               shirt=YELLOW, trousers=GREY, scale_rate=1.006, depth=0.5),
        Walker(id=4, first_frame=0, start_centre=(230.0, 60.0), velocity=(-1.8, 0.0), size=(18, 46),
               shirt=GREEN, trousers=BROWN, depth=3.0),
    )
    pillar = StaticShape(x=180, y=20, w=9, h=90, colour=(150, 150, 160))
    lighting = Lighting(gain_keyframes=((60, 1.0), (72, 1.35)),
                        shadows=(Shadow(x=0, y=0, w=90, h=110, darkening=0.55),))
    return SceneConfig(walkers=walkers, occluders=(pillar,), lighting=lighting, n_frames=100, seed=seed,
                       name="demo")


def entering_leaving(seed: int = 0) -> SceneConfig:
    """Three people walk in through a side border and out through the other, one after another.

    The scene starts empty, so a background model can learn the bare background from
    the first frames.  Each walker enters at a different time and crosses the image
    along their own band of rows, so that no two of them ever overlap.  The nearer the
    walker (lower in the image), the larger they are.

    ======  =============================  =============  =====  =======  =======
    walker  clothes                        direction      speed  size     rows
    ======  =============================  =============  =====  =======  =======
    1       red shirt, navy trousers       left to right  2.5    20 x 50  35-84
    2       blue shirt, charcoal trousers  right to left  2.3    22 x 56  100-155
    3       yellow shirt, brown trousers   left to right  2.5    26 x 62  161-222
    ======  =============================  =============  =====  =======  =======

    Speeds are in pixels per frame.  The frames (0-based indices) of each walker's first
    and last ground-truth rows are:

    * walker 1: first row at frame 5, last row at frame 139;
    * walker 2: first row at frame 20, last row at frame 167;
    * walker 3: first row at frame 40, last row at frame 177.

    Frames 0-4 and 178-199 have no ground-truth row.  A walker's first row is 2 px wide
    and starts at the shoulders, because the narrower head is not yet in view.  The
    scene has 200 frames: a crossing takes about 140 frames at these speeds, and the
    last walker leaves 22 frames before the end.

    Examples
    --------
    >>> [(w.id, w.first_frame, w.velocity[0]) for w in entering_leaving().walkers]
    [(1, 5, 2.5), (2, 20, -2.3), (3, 40, 2.5)]
    """
    width = 320
    # A start centre half a box width outside the border, plus 2 px, puts the first two
    # columns of the box in the image at the walker's first frame.
    walkers = (
        Walker(id=1, first_frame=5, start_centre=(2 - 20 / 2, 60.0), velocity=(2.5, 0.0), size=(20, 50),
               shirt=RED, trousers=NAVY, depth=3.0),
        Walker(id=2, first_frame=20, start_centre=(width - 2 + 22 / 2, 128.0), velocity=(-2.3, 0.0), size=(22, 56),
               shirt=BLUE, trousers=CHARCOAL, depth=2.0),
        Walker(id=3, first_frame=40, start_centre=(2 - 26 / 2, 192.0), velocity=(2.5, 0.0), size=(26, 62),
               shirt=YELLOW, trousers=BROWN, depth=1.0),
    )
    return SceneConfig(walkers=walkers, width=width, height=240, n_frames=200, seed=seed, name="entering_leaving")


def lost_and_found(seed: int = 0) -> SceneConfig:
    """A person walks behind a wall, out of sight for longer than a track coasts, and comes out again.

    * Walker 1 (red shirt, navy trousers, 18 x 52) walks right at 1.5 px per frame along
      rows 94-145 and passes behind a 50 px wide wall (x 150-199, rows 70-169): wholly
      hidden for about 21 frames, partly for about 12 frames on either side.
    * Walker 2 (blue shirt, charcoal trousers, 24 x 64) walks left at 1 px per frame below
      the wall (rows 173-236), in view all the time.

    A tracker that drops a person it has not seen for a while must recognise walker 1 when
    they come out and give them back their id.  The scene has 200 frames.

    Examples
    --------
    >>> [(w.id, w.velocity) for w in lost_and_found().walkers]
    [(1, (1.5, 0.0)), (2, (-1.0, 0.0))]
    """
    walkers = (
        Walker(id=1, first_frame=0, start_centre=(20.0, 120.0), velocity=(1.5, 0.0), size=(18, 52),
               shirt=RED, trousers=NAVY, depth=2.0),
        Walker(id=2, first_frame=0, start_centre=(290.0, 205.0), velocity=(-1.0, 0.0), size=(24, 64),
               shirt=BLUE, trousers=CHARCOAL, depth=1.0),
    )
    wall = StaticShape(x=150, y=70, w=50, h=100, colour=(150, 150, 160))
    return SceneConfig(walkers=walkers, occluders=(wall,), n_frames=200, seed=seed, name="lost_and_found")


#: The presets by name; each maps a seed to a :class:`SceneConfig`.
PRESETS: dict[str, Callable[[int], SceneConfig]] = {
    "crossing": crossing,
    "similar_colours": similar_colours,
    "partial_occlusion": partial_occlusion,
    "illumination": illumination,
    "scale_change": scale_change,
    "demo": demo,
    "entering_leaving": entering_leaving,
    "lost_and_found": lost_and_found,
}


# -- crowds --------------------------------------------------------------------------------------------------
#
# Unlike a preset's, a crowd's layout is drawn from its seed: each seed is another crowd.
# The layout has a random stream of its own, apart from the one that render() draws the
# background and the noise from, so the same seed gives the same crowd on any background.

# Each channel of the crowd's base colours sits in the middle of a bin of 32 grey levels, so
# that all the shirts, and all the trousers, fall in one bin of an 8 x 8 x 8 histogram.

#: The red (BGR) around which the shirts of a crowd vary, as in :func:`similar_colours`.
CROWD_SHIRT: Colour = (48, 48, 176)
#: The dark blue (BGR) around which the trousers of a crowd vary.
CROWD_TROUSERS: Colour = (80, 48, 44)

_CROWD_SIZE = 12
_CROWD_FRAMES = 150
# Seeds the layout's random stream with (seed, this key), which no render() stream uses
# (render() seeds with the seed alone); the key is "crow" in ASCII.
_CROWD_LAYOUT_KEY = 0x63726F77
# How far a crowd's colours stray from their base, in grey levels per channel.
_SHIRT_SPREAD, _TROUSERS_SPREAD, _SKIN_SPREAD = 14, 10, 6
# The feet lie in twelve bands of rows, one a walker, between these rows: every box shares
# rows with those of the nearest six or so bands on either side.
_FOOT_ROWS = (130.0, 210.0)
# A centre stays this far from the left and right borders: half the widest box (21 px) and
# a margin, so that everybody is whole in the image in every frame.
_CROWD_EDGE = 17.0
# People walking the same way start at least this far apart (centre to centre), more than
# the widest box, and nobody walks faster than the one ahead: they never overlap.
_CROWD_SPACING = 24.0
_START_SLACK = 10.0
_SLOWEST = 0.75
# Neighbours in a column have their feet at least this many bands apart.
_BAND_GAP = 4


def _jittered(base: Colour, spread: int, rng: np.random.Generator) -> Colour:
    """``base`` with every channel moved by an integer drawn uniformly from ``-spread..spread``."""
    return tuple(int(np.clip(c + rng.integers(-spread, spread + 1), 0, 255)) for c in base)


def _interleaved(bands: list[int], rng: np.random.Generator) -> tuple[int, ...]:
    """A random order of ``bands`` in which neighbours lie at least :data:`_BAND_GAP` bands apart."""
    orders = [order for order in itertools.permutations(sorted(bands))
              if all(abs(a - b) >= _BAND_GAP for a, b in zip(order, order[1:]))]
    return orders[int(rng.integers(len(orders)))]


def _column(bands: list[int], rng: np.random.Generator, width: int, n_frames: int) -> list[tuple[int, float, float]]:
    """``(band, start abscissa, speed)`` of people who walk right one behind the other, from the last to the first.

    The one ahead is the fastest, and reaches the right border's margin at the last frame
    at the latest, so the gaps between them only widen and everybody stays in view.  Next
    to each other in the column walk people whose feet are several bands apart.
    """
    count = len(bands)
    starts = _CROWD_EDGE + _CROWD_SPACING * np.arange(count) + np.sort(rng.uniform(0.0, _START_SLACK, count))
    fastest = (width - _CROWD_EDGE - starts[-1]) / (n_frames - 1)
    speeds = np.sort(rng.uniform(_SLOWEST, fastest, count))
    return [(band, float(start), float(speed)) for band, start, speed in zip(_interleaved(bands, rng), starts, speeds)]


def _crowd_walker(walker_id: int, band: int, start: float, speed: float, rng: np.random.Generator,
                  width: int) -> Walker:
    """The walker of a crowd whose feet lie in ``band``, from abscissa ``start`` (counted from their entry side).

    Walkers of even bands walk right, of odd bands left, so that neighbouring bands cross.
    The nearer the walker (the lower their feet), the larger they are and the more in
    front, as in a camera looking down on a square.
    """
    band_height = (_FOOT_ROWS[1] - _FOOT_ROWS[0]) / (_CROWD_SIZE - 1)
    foot = _FOOT_ROWS[0] + band_height * (band + rng.uniform(-0.4, 0.4))
    height = 0.07 * foot + 40.0 + rng.uniform(-2.0, 2.0)
    drift = rng.uniform(-0.12, 0.12)
    rightwards = band % 2 == 0
    centre_x = start if rightwards else width - start
    return Walker(id=walker_id, first_frame=0, start_centre=(round(centre_x, 2), round(foot - height / 2, 2)),
                  velocity=(round(speed if rightwards else -speed, 3), round(drift, 3)),
                  size=(round(0.37 * height, 1), round(height, 1)),
                  shirt=_jittered(CROWD_SHIRT, _SHIRT_SPREAD, rng),
                  trousers=_jittered(CROWD_TROUSERS, _TROUSERS_SPREAD, rng),
                  head=_jittered(SKIN_BGR, _SKIN_SPREAD, rng), depth=round((240.0 - foot) / 10.0, 3))


def crowd(seed: int = 0) -> SceneConfig:
    """Twelve people dressed alike criss-cross a square, each passing in front of and behind several others.

    The walkers' feet lie in twelve bands of rows between rows 130 and 210, one walker a
    band.  People of neighbouring bands walk opposite ways (even bands right, odd bands
    left), along straight, slightly slanted paths, at 0.75 to about 1.05 px per frame.  A
    box shares rows with the boxes of the nearest bands, so most people cross four to six
    people walking the other way (a few only one or two), partly hidden by the nearer of
    the two (whose feet are lower in the image, and who is larger) or hiding them; some are
    hidden almost wholly.  The six who walk one way start one behind the other, 24 px or
    more apart, none faster than the one ahead, so they never overlap; next to each other
    in that column walk people whose feet are four bands apart or more.  Everybody is in
    the image, whole, from the first frame to the last.  The ids are dealt at random.

    All shirts are close reds, within 14 grey levels of :data:`CROWD_SHIRT` in every
    channel, all trousers close dark blues, within 10 of :data:`CROWD_TROUSERS`, and the
    skins within 6 of :data:`~belief_tracking.scenes.SKIN_BGR`; no two walkers are
    dressed exactly alike.  The boxes are 17-21 px wide and 47-57 px high.  A colour
    histogram of 8 bins a channel puts every shirt in one bin and every pair of trousers in
    another, so keeping the identities through the crossings rests on motion and position.

    Unlike a preset's, the layout is drawn from the seed (from a random stream apart from
    the background's and the noise's), so every seed is another crowd.  The scene has 150
    frames of 320 x 240.

    Parameters
    ----------
    seed : int, default 0
        Seed of the layout, the clothes, the background and the sensor noise.

    Returns
    -------
    SceneConfig

    Examples
    --------
    >>> config = crowd(0)
    >>> len(config.walkers), config.n_frames, (config.width, config.height)
    (12, 150, (320, 240))
    >>> [w.velocity[0] > 0 for w in config.walkers].count(True)  # half walk right
    6
    >>> crowd(0) == crowd(0), crowd(0).walkers == crowd(1).walkers
    (True, False)
    """
    width, n_frames = 320, _CROWD_FRAMES
    rng = np.random.default_rng((seed, _CROWD_LAYOUT_KEY))
    # Even bands walk right, odd bands left; the ids are dealt at random over both.
    paths = _column(list(range(0, _CROWD_SIZE, 2)), rng, width, n_frames) + \
        _column(list(range(1, _CROWD_SIZE, 2)), rng, width, n_frames)
    ids = rng.permutation(_CROWD_SIZE) + 1
    walkers = sorted((_crowd_walker(int(walker_id), band, start, speed, rng, width)
                      for walker_id, (band, start, speed) in zip(ids, paths)), key=lambda walker: walker.id)
    return SceneConfig(walkers=tuple(walkers), width=width, height=240, n_frames=n_frames, seed=seed, name="crowd")


#: The crowd scenes by name, apart from :data:`PRESETS` (whose eight scenes the choice of
#: defaults and its acceptance check iterate over); each maps a seed to a :class:`SceneConfig`.
CROWDS: dict[str, Callable[[int], SceneConfig]] = {
    "crowd": crowd,
}
