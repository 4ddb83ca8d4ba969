"""Synthetic video scenes with exact ground truth, for tests and for the embedded demo.

A scene is a textured static background with people walking across it, each drawn
as a head, a shirt and trousers (three flat-coloured blocks).  The people walk in
straight lines at constant velocity and may grow or shrink at a constant rate.  The
difficulties of the experiments the trackers are compared on (SPEC Part C) are staged
on purpose: people crossing each other with partial and then full occlusion, static
objects in front of people, people with similar clothing, a change of brightness, a
shadow, and people walking towards or away from the camera (scale change).

Because the scene is drawn here, the ground truth is exact.  Every box is the extent of
the pixels that the person covers in the image, and every visibility is counted from
the drawing.  A scene is fully determined by its :class:`SceneConfig`.  The
configuration includes a seed, so the same configuration always gives byte-identical
frames and ground truth.

Conventions
-----------
* Frame indices ``t`` are 0-based in the Python API (``scene.frame(0)`` is the first
  frame).  Pixel boxes ``(x, y, w, h)`` are 0-based as well, so that
  ``frame[y:y + h, x:x + w]`` is the box.
* The ground-truth table follows MOTChallenge: ``frame, id, x, y, w, h, flag, -1, -1, -1``,
  with 1-based frame numbers and a 1-based top-left corner (``x_mot = x + 1``).
  ``motmetrics.io.loadtxt`` subtracts the 1 again.  The flag is always 1 ("consider
  this box").
* A box is the person's extent, clipped to the image.  A person who is hidden behind
  somebody else keeps their full box and gets a visibility of 0, as in MOTChallenge.
  A person who is entirely outside the image gets no row.
* The visibility of a box is the fraction of the person's in-image pixels that are not
  hidden by a nearer person or by a static occluder.  Being cut off by the image
  border does not count as being hidden.

Invalid settings raise :class:`~belief_tracking.errors.TrackingError`, which is
a ``ValueError``, as soon as a configuration object is made.  OpenCV is used only by
:func:`write_video`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import TrackingError
from .extras import require

__all__ = [
    "Walker",
    "StaticShape",
    "Shadow",
    "Lighting",
    "BackgroundStyle",
    "SceneConfig",
    "Scene",
    "render",
    "write_gt",
    "write_video",
    "crossing",
    "similar_colours",
    "partial_occlusion",
    "illumination",
    "scale_change",
    "demo",
    "entering_leaving",
    "lost_and_found",
    "PRESETS",
]

Colour = tuple[int, int, int]
Box = tuple[int, int, int, int]

#: Skin tone (BGR) of the heads unless a walker says otherwise.
SKIN_BGR: Colour = (110, 140, 190)

# Body layout as fractions of the box height: the head is the top fifth and the shirt
# runs down to 60 % of the height.  The head is narrower than the body, so the head rows
# of a box also contain background, as they would for a real person.
_HEAD_HEIGHT_FRACTION = 0.2
_SHIRT_BOTTOM_FRACTION = 0.6
_HEAD_WIDTH_FRACTION = 0.45

# Owner value of the pixels covered by a static occluder.  Walker ids are positive and 0
# means background, so a negative value can belong to no walker.
_OCCLUDER_OWNER = -1


def _round_half_up(value: float) -> int:
    # One rounding rule for every box coordinate.  Python's round() rounds halves to
    # even, which would make a box jitter by one pixel as the walker moves.
    return int(math.floor(value + 0.5))


def _check_colour(name: str, colour: Colour) -> None:
    if len(colour) != 3 or not all(isinstance(c, (int, np.integer)) and 0 <= c <= 255 for c in colour):
        raise TrackingError(f"{name} must be three integers in 0..255 (B, G, R), got {colour!r}")


def _check_rectangle(name: str, x: int, y: int, w: int, h: int) -> None:
    if w <= 0 or h <= 0:
        raise TrackingError(f"{name} must have a positive width and height, got {w}x{h}")


@dataclass(frozen=True)
class Walker:
    """A person walking in a straight line at constant velocity.

    Attributes
    ----------
    id : int
        Identity in the ground truth (positive, unique within a scene).
    first_frame, last_frame : int
        0-based frame indices between which the walker is in the scene, both inclusive.
        ``last_frame=None`` means until the end of the scene.
    start_centre : (float, float)
        Centre ``(x, y)`` of the walker's box at ``first_frame``, in pixels.  It may lie
        outside the image, for a person who walks in.
    velocity : (float, float)
        Displacement ``(dx, dy)`` of the centre per frame, in pixels.
    size : (float, float)
        Box width and height ``(w, h)`` at ``first_frame``, in pixels.
    shirt, trousers, head : (int, int, int)
        Colours (BGR, like OpenCV) of the upper body, the legs and the head.
    scale_rate : float
        Multiplicative growth of the size per frame.  Use a value above 1 for someone
        walking towards the camera and below 1 for someone walking away from it.
    depth : float
        Distance from the camera in arbitrary units.  A walker with a smaller depth is
        drawn in front of one with a larger depth.  On a tie, the walker with the smaller
        id is in front.

    Examples
    --------
    >>> w = Walker(id=1, first_frame=0, start_centre=(100.0, 120.0), velocity=(2.0, 0.0),
    ...            size=(20, 50), shirt=(40, 40, 190), trousers=(90, 40, 30))
    >>> w.box_at(10)  # (x, y, w, h): the centre has moved 20 px to the right
    (110, 95, 20, 50)
    """

    id: int
    first_frame: int
    start_centre: tuple[float, float]
    size: tuple[float, float]
    shirt: Colour
    trousers: Colour
    velocity: tuple[float, float] = (0.0, 0.0)
    head: Colour = SKIN_BGR
    last_frame: int | None = None
    scale_rate: float = 1.0
    depth: float = 0.0

    def __post_init__(self) -> None:
        if int(self.id) != self.id or self.id < 1:
            raise TrackingError(f"walker id must be a positive integer, got {self.id!r}")
        if self.first_frame < 0:
            raise TrackingError(f"walker {self.id}: first_frame must be >= 0, got {self.first_frame}")
        if self.last_frame is not None and self.last_frame < self.first_frame:
            raise TrackingError(f"walker {self.id}: last_frame {self.last_frame} is before first_frame {self.first_frame}")
        if len(self.size) != 2 or min(self.size) <= 0:
            raise TrackingError(f"walker {self.id}: size must be a positive (w, h), got {self.size!r}")
        if not (self.scale_rate > 0 and math.isfinite(self.scale_rate)):
            raise TrackingError(f"walker {self.id}: scale_rate must be a positive number, got {self.scale_rate!r}")
        for name in ("shirt", "trousers", "head"):
            _check_colour(f"walker {self.id}: {name}", getattr(self, name))

    def is_present(self, t: int) -> bool:
        """Whether the walker is in the scene at frame index ``t`` (it may still be off-image)."""
        return t >= self.first_frame and (self.last_frame is None or t <= self.last_frame)

    def box_at(self, t: int) -> Box:
        """The walker's full box ``(x, y, w, h)`` at frame index ``t``, before clipping to the image.

        Width and height are rounded to whole pixels and are at least 1.  The top-left
        corner is the rounded centre minus half the size.
        """
        elapsed = t - self.first_frame
        growth = self.scale_rate ** elapsed
        width = max(1, _round_half_up(self.size[0] * growth))
        height = max(1, _round_half_up(self.size[1] * growth))
        centre_x = self.start_centre[0] + elapsed * self.velocity[0]
        centre_y = self.start_centre[1] + elapsed * self.velocity[1]
        return (_round_half_up(centre_x - width / 2), _round_half_up(centre_y - height / 2), width, height)


@dataclass(frozen=True)
class StaticShape:
    """A flat-coloured rectangle that does not move: scenery, or an occluder in front of people.

    Attributes
    ----------
    x, y, w, h : int
        The rectangle in 0-based pixels.  It may extend past the image.
    colour : (int, int, int)
        BGR colour.
    """

    x: int
    y: int
    w: int
    h: int
    colour: Colour

    def __post_init__(self) -> None:
        _check_rectangle("a static shape", self.x, self.y, self.w, self.h)
        _check_colour("static shape colour", self.colour)


@dataclass(frozen=True)
class Shadow:
    """A rectangle of the image that is darker than the rest (a building's shadow, say).

    Attributes
    ----------
    x, y, w, h : int
        The shadowed rectangle in 0-based pixels.
    darkening : float
        Factor applied to every pixel in the rectangle, people included.  It must be in
        (0, 1]; 0.5 halves the brightness.
    """

    x: int
    y: int
    w: int
    h: int
    darkening: float = 0.5

    def __post_init__(self) -> None:
        _check_rectangle("a shadow", self.x, self.y, self.w, self.h)
        if not 0 < self.darkening <= 1:
            raise TrackingError(f"shadow darkening must be in (0, 1], got {self.darkening!r}")


@dataclass(frozen=True)
class Lighting:
    """How the light changes over time and across the image.

    Attributes
    ----------
    gain_keyframes : tuple of (int, float)
        ``(frame index, gain)`` pairs in increasing frame order.  The whole image is
        multiplied by the gain, which is interpolated linearly between keyframes and held
        constant before the first and after the last.  With no keyframes the gain is 1.
        For example, ``((20, 1.0), (30, 1.5))`` makes the sun come out between frames 20
        and 30.  Values that exceed 255 saturate, as they do in a camera.
    shadows : tuple of Shadow
        Static darker regions.

    Examples
    --------
    >>> light = Lighting(gain_keyframes=((20, 1.0), (30, 1.5)))
    >>> light.gain(0), light.gain(25), light.gain(99)
    (1.0, 1.25, 1.5)
    """

    gain_keyframes: tuple[tuple[int, float], ...] = ()
    shadows: tuple[Shadow, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "gain_keyframes", tuple(tuple(k) for k in self.gain_keyframes))
        object.__setattr__(self, "shadows", tuple(self.shadows))
        frames = [k[0] for k in self.gain_keyframes]
        if any(b <= a for a, b in zip(frames, frames[1:])):
            raise TrackingError(f"gain keyframes must have strictly increasing frames, got {frames}")
        if any(not (k[1] > 0 and math.isfinite(k[1])) for k in self.gain_keyframes):
            raise TrackingError(f"gains must be positive numbers, got {self.gain_keyframes!r}")

    def gain(self, t: int) -> float:
        """The global brightness gain at frame index ``t``."""
        if not self.gain_keyframes:
            return 1.0
        frames, gains = zip(*self.gain_keyframes)
        return float(np.interp(t, frames, gains))


@dataclass(frozen=True)
class BackgroundStyle:
    """The static background: a base colour with smooth and fine texture, and some rectangles.

    Attributes
    ----------
    base_colour : (int, int, int)
        BGR colour around which the background varies.
    smooth_variation : float
        Standard deviation (grey levels) of a slowly varying colour field.  The field is
        bilinear noise on a grid of ``smooth_cell`` pixels.
    smooth_cell : int
        Grid spacing of the slowly varying field, in pixels.
    grain : float
        Standard deviation (grey levels) of the static per-pixel texture.  It is drawn
        once, unlike the sensor noise that :class:`SceneConfig` draws anew for every frame.
    n_random_shapes : int
        Number of random grey-ish rectangles (benches, doors, signs) placed from the seed.
        They are kept desaturated so that they look unlike the people.
    shapes : tuple of StaticShape
        Rectangles at fixed places, drawn after the random ones.  Use them, for example,
        for a background object with the colour of a person's shirt (a distractor).
    """

    base_colour: Colour = (105, 115, 110)
    smooth_variation: float = 12.0
    smooth_cell: int = 48
    grain: float = 5.0
    n_random_shapes: int = 6
    shapes: tuple[StaticShape, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "shapes", tuple(self.shapes))
        _check_colour("background base_colour", self.base_colour)
        if self.smooth_variation < 0 or self.grain < 0 or self.n_random_shapes < 0:
            raise TrackingError("smooth_variation, grain and n_random_shapes must be >= 0")
        if self.smooth_cell < 1:
            raise TrackingError(f"smooth_cell must be >= 1, got {self.smooth_cell}")

    @classmethod
    def flat(cls, colour: Colour = (105, 115, 110)) -> BackgroundStyle:
        """A uniform background of one colour (no texture, no shapes), handy in tests."""
        return cls(base_colour=colour, smooth_variation=0.0, grain=0.0, n_random_shapes=0)


@dataclass(frozen=True)
class SceneConfig:
    """Everything that defines a synthetic scene.  :func:`render` turns it into frames.

    Attributes
    ----------
    walkers : tuple of Walker
        The people, with distinct ids.
    width, height : int
        Image size in pixels (320 x 240 by default, as in L's experiments).
    n_frames : int
        Number of frames.
    background : BackgroundStyle
        The static background.
    occluders : tuple of StaticShape
        Static objects in front of every walker (a pillar, a hedge).
    lighting : Lighting
        Brightness changes over time and shadows.
    noise_std : float
        Standard deviation (grey levels) of the Gaussian sensor noise.  It is drawn
        independently for every pixel, channel and frame.
    seed : int
        Seed of the background texture, the random shapes and the sensor noise.
    name : str
        A label for reports.
    """

    walkers: tuple[Walker, ...] = ()
    width: int = 320
    height: int = 240
    n_frames: int = 100
    background: BackgroundStyle = field(default_factory=BackgroundStyle)
    occluders: tuple[StaticShape, ...] = ()
    lighting: Lighting = field(default_factory=Lighting)
    noise_std: float = 4.0
    seed: int = 0
    name: str = "custom"

    def __post_init__(self) -> None:
        object.__setattr__(self, "walkers", tuple(self.walkers))
        object.__setattr__(self, "occluders", tuple(self.occluders))
        if self.width < 1 or self.height < 1 or self.n_frames < 1:
            raise TrackingError(f"width, height and n_frames must be >= 1, got {self.width}, {self.height}, {self.n_frames}")
        ids = [w.id for w in self.walkers]
        if len(set(ids)) != len(ids):
            raise TrackingError(f"walker ids must be distinct, got {ids}")
        if not (self.noise_std >= 0 and math.isfinite(self.noise_std)):
            raise TrackingError(f"noise_std must be a finite number >= 0, got {self.noise_std!r}")


@dataclass(frozen=True, eq=False)
class Scene:
    """A rendered scene: frames, exact ground truth and visibilities.

    Attributes
    ----------
    config : SceneConfig
        What was rendered.
    frames : ndarray of uint8, shape (T, H, W, 3)
        BGR frames (read-only).
    ground_truth : ndarray of int64, shape (M, 10)
        MOTChallenge rows ``frame, id, x, y, w, h, 1, -1, -1, -1`` with 1-based frame
        numbers and a 1-based top-left corner, sorted by frame and then by id.
    visibility : ndarray of float64, shape (M,)
        Fraction of each row's person that is visible (see the module notes).

    A scene iterates over its frames, and ``len(scene)`` is the number of frames.
    """

    config: SceneConfig
    frames: np.ndarray
    ground_truth: np.ndarray
    visibility: np.ndarray

    def __len__(self) -> int:
        return self.frames.shape[0]

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter(self.frames)

    def frame(self, t: int) -> np.ndarray:
        """The BGR frame of shape (H, W, 3) at 0-based frame index ``t``."""
        if not 0 <= t < len(self):
            raise IndexError(f"frame index {t} is outside 0..{len(self) - 1}")
        return self.frames[t]

    @property
    def ids(self) -> tuple[int, ...]:
        """Ids of the walkers that appear in the image at least once, in increasing order."""
        return tuple(int(i) for i in np.unique(self.ground_truth[:, 1]))

    def _rows_at(self, t: int) -> np.ndarray:
        return np.flatnonzero(self.ground_truth[:, 0] == t + 1)

    def boxes_at(self, t: int) -> dict[int, Box]:
        """Ground-truth boxes at frame index ``t`` as ``{id: (x, y, w, h)}`` in 0-based pixels."""
        return {int(r[1]): (int(r[2]) - 1, int(r[3]) - 1, int(r[4]), int(r[5]))
                for r in self.ground_truth[self._rows_at(t)]}

    def visibility_at(self, t: int) -> dict[int, float]:
        """Visibility of every walker in the image at frame index ``t``, as ``{id: fraction}``."""
        rows = self._rows_at(t)
        return {int(i): float(v) for i, v in zip(self.ground_truth[rows, 1], self.visibility[rows])}

    def initial_boxes(self) -> dict[int, tuple[int, Box]]:
        """Where to start tracking each walker: ``{id: (frame index, (x, y, w, h))}``.

        This is the walker's first ground-truth row, i.e. the first frame in which any
        of their pixels is in the image.  It is the box that the papers draw by hand.
        """
        first: dict[int, tuple[int, Box]] = {}
        for row in self.ground_truth:
            walker_id = int(row[1])
            if walker_id not in first:
                first[walker_id] = (int(row[0]) - 1, (int(row[2]) - 1, int(row[3]) - 1, int(row[4]), int(row[5])))
        return dict(sorted(first.items()))


# -- rendering ----------------------------------------------------------------------------------------------

def _bilinear_noise(height: int, width: int, cell: int, rng: np.random.Generator) -> np.ndarray:
    """Smooth colour noise of shape (height, width, 3) with unit standard deviation at the grid nodes."""
    rows, cols = height // cell + 2, width // cell + 2
    grid = rng.standard_normal((rows, cols, 3))
    ys = np.arange(height) / cell
    xs = np.arange(width) / cell
    y0, x0 = ys.astype(int), xs.astype(int)
    fy, fx = (ys - y0)[:, None, None], (xs - x0)[None, :, None]
    top = grid[y0][:, x0] * (1 - fx) + grid[y0][:, x0 + 1] * fx
    bottom = grid[y0 + 1][:, x0] * (1 - fx) + grid[y0 + 1][:, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def _clip_rectangle(x: int, y: int, w: int, h: int, width: int, height: int) -> tuple[slice, slice] | None:
    """Row and column slices of the part of a rectangle inside the image, or None if it is outside."""
    x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, width), min(y + h, height)
    if x1 <= x0 or y1 <= y0:
        return None
    return slice(y0, y1), slice(x0, x1)


def _paint_rectangle(image: np.ndarray, shape: StaticShape) -> None:
    region = _clip_rectangle(shape.x, shape.y, shape.w, shape.h, image.shape[1], image.shape[0])
    if region is not None:
        image[region] = shape.colour


def _render_background(config: SceneConfig, rng: np.random.Generator) -> np.ndarray:
    """The static background, float32 of shape (H, W, 3)."""
    style = config.background
    height, width = config.height, config.width
    image = np.empty((height, width, 3), dtype=np.float64)
    image[:] = style.base_colour
    # Every texture is drawn even when its strength is 0.  This keeps the random stream,
    # and so the random shapes, the same whatever the strengths.
    image += style.smooth_variation * _bilinear_noise(height, width, style.smooth_cell, rng)
    grain = rng.standard_normal((height, width, 1))
    for _ in range(style.n_random_shapes):
        w = int(rng.integers(12, max(13, width // 4)))
        h = int(rng.integers(12, max(13, height // 3)))
        x = int(rng.integers(-w // 2, width - w // 2))
        y = int(rng.integers(-h // 2, height - h // 2))
        grey = rng.uniform(50, 160)
        tint = rng.normal(0, 12, size=3)
        colour = tuple(int(c) for c in np.clip(np.rint(grey + tint), 0, 255))
        _paint_rectangle(image, StaticShape(x, y, w, h, colour))
    for shape in style.shapes:
        _paint_rectangle(image, shape)
    # The grain is added after the shapes so that the shapes are textured too.
    image += style.grain * grain
    return image.astype(np.float32)


def _body_template(w: int, h: int, walker: Walker) -> tuple[np.ndarray, np.ndarray]:
    """The walker drawn in a box of size (h, w): a colour patch (h, w, 3) and a mask (h, w) of covered pixels."""
    patch = np.zeros((h, w, 3), dtype=np.float32)
    mask = np.zeros((h, w), dtype=bool)
    head_rows = _round_half_up(_HEAD_HEIGHT_FRACTION * h)
    shirt_end = max(head_rows, _round_half_up(_SHIRT_BOTTOM_FRACTION * h))
    head_width = max(1, _round_half_up(_HEAD_WIDTH_FRACTION * w))
    head_left = (w - head_width) // 2
    patch[:head_rows, head_left:head_left + head_width] = walker.head
    mask[:head_rows, head_left:head_left + head_width] = True
    patch[head_rows:shirt_end] = walker.shirt
    patch[shirt_end:] = walker.trousers
    mask[head_rows:] = True
    return patch, mask


def _shadow_map(config: SceneConfig) -> np.ndarray:
    """Static per-pixel light factor (H, W, 1) of the shadows; 1 outside every shadow."""
    factor = np.ones((config.height, config.width, 1), dtype=np.float32)
    for shadow in config.lighting.shadows:
        region = _clip_rectangle(shadow.x, shadow.y, shadow.w, shadow.h, config.width, config.height)
        if region is not None:
            factor[region] *= shadow.darkening
    return factor


def render(config: SceneConfig, rng: np.random.Generator | None = None) -> Scene:
    """Draw every frame of a scene and its ground truth.

    Parameters
    ----------
    config : SceneConfig
        The scene.
    rng : numpy.random.Generator, optional
        Source of the background texture, the random shapes and the sensor noise.  By
        default it is ``numpy.random.default_rng(config.seed)``, so a configuration alone
        fixes the scene byte for byte.

    Returns
    -------
    Scene
        Frames of shape (T, H, W, 3), uint8 BGR, with ground-truth rows of shape (M, 10)
        and visibilities of shape (M,).

    Notes
    -----
    For each frame, the renderer copies the background and draws the walkers from the
    farthest to the nearest, then the occluders.  It keeps a map of which walker owns
    each pixel.  Next it multiplies the image by the global gain and the shadow factors,
    adds the sensor noise, and rounds and clips to 0..255.  The background and the noise
    come from two independent child streams of ``rng``, so a longer scene begins with
    the same frames as a shorter one.

    Examples
    --------
    >>> scene = render(crossing(seed=0))
    >>> scene.frames.shape, scene.frames.dtype
    ((100, 240, 320, 3), dtype('uint8'))
    >>> scene.initial_boxes()
    {1: (0, (96, 128, 18, 52)), 2: (0, (190, 112, 30, 76))}
    >>> scene.ground_truth[:2].tolist()  # frame, id, x, y, w, h (1-based corner), flag, -1, -1, -1
    [[1, 1, 97, 129, 18, 52, 1, -1, -1, -1], [1, 2, 191, 113, 30, 76, 1, -1, -1, -1]]
    >>> min(scene.visibility_at(50).values())  # walker 1 is fully behind walker 2
    0.0
    """
    if rng is None:
        rng = np.random.default_rng(config.seed)
    background_rng, noise_rng = rng.spawn(2)
    height, width = config.height, config.width
    background = _render_background(config, background_rng)

    occluder_layer = np.zeros((height, width, 3), dtype=np.float32)
    occluder_mask = np.zeros((height, width), dtype=bool)
    for shape in config.occluders:
        region = _clip_rectangle(shape.x, shape.y, shape.w, shape.h, width, height)
        if region is not None:
            occluder_layer[region] = shape.colour
            occluder_mask[region] = True
    has_occluders = bool(occluder_mask.any())
    shadow_factor = _shadow_map(config)

    # Farthest first, so that nearer walkers overwrite them; on equal depth the lower id
    # is drawn last and so ends up in front.
    drawing_order = sorted(config.walkers, key=lambda w: (-w.depth, -w.id))
    frames = np.empty((config.n_frames, height, width, 3), dtype=np.uint8)
    truth_rows: list[list[int]] = []
    visibility: list[float] = []
    owner = np.empty((height, width), dtype=np.int32)  # id of the walker seen at each pixel, 0 for none

    for t in range(config.n_frames):
        image = background.copy()
        owner.fill(0)
        drawn: list[tuple[int, int, int, int, int, int]] = []  # id, x0, y0, x1, y1, pixels in image
        for walker in drawing_order:
            if not walker.is_present(t):
                continue
            x, y, w, h = walker.box_at(t)
            region = _clip_rectangle(x, y, w, h, width, height)
            if region is None:
                continue
            patch, mask = _body_template(w, h, walker)
            rows, cols = region
            local = (slice(rows.start - y, rows.stop - y), slice(cols.start - x, cols.stop - x))
            mask = mask[local]
            if not mask.any():
                continue  # only background columns of the head rows are in the image
            np.copyto(image[region], patch[local], where=mask[:, :, None])
            owner[region][mask] = walker.id
            # The box is the extent of the pixels actually drawn inside the image.  That is
            # the clipped box, except at a side border that cuts the narrow head out of view
            # (the box then starts at the shoulders) or leaves only the head in view.
            covered_rows = np.flatnonzero(mask.any(axis=1))
            covered_cols = np.flatnonzero(mask.any(axis=0))
            drawn.append((walker.id,
                          cols.start + int(covered_cols[0]), rows.start + int(covered_rows[0]),
                          cols.start + int(covered_cols[-1]) + 1, rows.start + int(covered_rows[-1]) + 1,
                          int(mask.sum())))
        if has_occluders:
            np.copyto(image, occluder_layer, where=occluder_mask[:, :, None])
            owner[occluder_mask] = _OCCLUDER_OWNER

        for walker_id, x0, y0, x1, y1, pixels in sorted(drawn):
            visible = int(np.count_nonzero(owner[y0:y1, x0:x1] == walker_id))
            truth_rows.append([t + 1, walker_id, x0 + 1, y0 + 1, x1 - x0, y1 - y0, 1, -1, -1, -1])
            visibility.append(visible / pixels)

        image *= shadow_factor
        gain = config.lighting.gain(t)
        if gain != 1.0:
            image *= np.float32(gain)
        if config.noise_std > 0:
            image += np.float32(config.noise_std) * noise_rng.standard_normal(image.shape, dtype=np.float32)
        np.clip(np.rint(image), 0, 255, out=image)
        frames[t] = image

    frames.flags.writeable = False
    ground_truth = np.array(truth_rows, dtype=np.int64).reshape(-1, 10)
    ground_truth.flags.writeable = False
    visibility_array = np.array(visibility, dtype=np.float64)
    visibility_array.flags.writeable = False
    return Scene(config=config, frames=frames, ground_truth=ground_truth, visibility=visibility_array)


# -- output --------------------------------------------------------------------------------------------------

def write_gt(path: str | Path, rows: np.ndarray, visibility: np.ndarray | None = None) -> None:
    """Write ground-truth (or tracker) rows as a MOTChallenge CSV file.

    Parameters
    ----------
    path : str or Path
        File to write (usually ``gt/gt.txt``).
    rows : array_like, shape (M, K), K >= 6
        ``frame, id, x, y, w, h, ...`` with 1-based frames and corners.  Integer arrays
        are written as integers; float arrays use ``%.6f`` with trailing zeros removed.
    visibility : array_like, shape (M,), optional
        Each row's visible fraction in [0, 1] (:attr:`Scene.visibility`).  With it, the
        file has the 9 columns of a MOTChallenge 17 ground truth,
        ``frame, id, x, y, w, h, flag, class, visibility``: the flag is the 7th column of
        ``rows`` (1 when ``rows`` has 6), the class is 1 (pedestrian), as evaluation tools
        that read MOT17 files expect.  Without it, ``rows`` are written as they are.

    Raises
    ------
    TrackingError
        If ``rows`` is not a table with at least 6 columns, or ``visibility`` does not give
        one value in [0, 1] per row.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "gt.txt")
    >>> write_gt(path, [[1, 1, 10, 20, 5, 8, 1, -1, -1, -1]])
    >>> open(path).read()
    '1,1,10,20,5,8,1,-1,-1,-1\\n'
    >>> scene = render(crossing(0))
    >>> write_gt(path, scene.ground_truth, visibility=scene.visibility)
    >>> open(path).read().splitlines()[0]
    '1,1,97,129,18,52,1,1,1'
    """
    table = np.asarray(rows)
    if table.ndim != 2 or (table.size and table.shape[1] < 6):
        raise TrackingError(f"rows must be a table of shape (M, K) with K >= 6, got shape {table.shape}")
    if visibility is not None:
        seen = np.asarray(visibility, dtype=np.float64).reshape(-1)
        if seen.shape != (len(table),) or not np.all((seen >= 0) & (seen <= 1)):
            raise TrackingError(f"visibility must give one value in [0, 1] per row ({len(table)}), "
                                f"got shape {np.shape(visibility)}")
        flags = table[:, 6] if table.shape[1] > 6 else np.ones(len(table), dtype=table.dtype)
        lines = [",".join([*(_format_number(float(v)) for v in row[:6]), _format_number(float(flag)), "1",
                           _format_number(float(v))])
                 for row, flag, v in zip(table, flags, seen)]
    elif np.issubdtype(table.dtype, np.integer):
        lines = [",".join(str(int(v)) for v in row) for row in table]
    else:
        lines = [",".join(_format_number(float(v)) for v in row) for row in table]
    with open(path, "w", encoding="ascii", newline="\n") as handle:
        handle.write("".join(line + "\n" for line in lines))


def _format_number(value: float) -> str:
    if value == int(value):
        return str(int(value))
    return f"{value:.6f}".rstrip("0")


def write_video(path: str | Path, scene: Scene | Iterable[np.ndarray], fps: float = 25.0) -> int:
    """Write frames to a Motion-JPEG ``.avi`` file with OpenCV.

    Parameters
    ----------
    path : str or Path
        Output file; ``.avi`` is the container that goes with Motion-JPEG.
    scene : Scene or iterable of ndarray of uint8, shape (H, W, 3)
        BGR frames, all of one size.
    fps : float
        Frame rate stored in the file.

    Returns
    -------
    int
        Number of frames written.

    Raises
    ------
    OSError
        If OpenCV cannot open the file for writing.
    TrackingError
        If a frame is not (H, W, 3) uint8 or differs in size from the first.
    """
    cv2 = require("cv2")  # OpenCV stays at the edges: out of the import path

    writer = None
    size = None
    count = 0
    try:
        for frame in scene:
            frame = np.asarray(frame)
            if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
                raise TrackingError(f"frames must be (H, W, 3) uint8 arrays, got {frame.shape} {frame.dtype}")
            if writer is None:
                size = frame.shape[:2]
                writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), float(fps),
                                         (frame.shape[1], frame.shape[0]))
                if not writer.isOpened():
                    raise OSError(f"OpenCV could not open {str(path)!r} for writing")
            elif frame.shape[:2] != size:
                raise TrackingError(f"frame {count} has size {frame.shape[:2]}, the first had {size}")
            writer.write(np.ascontiguousarray(frame))
            count += 1
    finally:
        if writer is not None:
            writer.release()
    return count


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
