"""The parts of a synthetic scene: walkers, static shapes, lighting, the background, and the rendered scene.

:class:`SceneConfig` gathers the parts that :func:`~belief_tracking.scene_render.render`
draws; :class:`Scene` holds what it drew.  Every part checks its settings when it is made
and raises :class:`~belief_tracking.errors.TrackingError`.  The conventions (0-based frame
indices and pixels, MOTChallenge ground-truth rows, visibilities) are those of
:mod:`belief_tracking.scenes`, which re-exports every public name of this module.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from .errors import TrackingError

__all__ = [
    "Walker",
    "StaticShape",
    "Shadow",
    "Lighting",
    "BackgroundStyle",
    "SceneConfig",
    "Scene",
    "SKIN_BGR",
    "round_half_up",
]

Colour = tuple[int, int, int]
Box = tuple[int, int, int, int]

#: Skin tone (BGR) of the heads unless a walker says otherwise.
SKIN_BGR: Colour = (110, 140, 190)


def round_half_up(value: float) -> int:
    """The integer nearest to ``value``, halves rounded up: the one rounding rule of every box coordinate.

    Python's :func:`round` rounds halves to even, which would make a box jitter by one
    pixel as a walker moves half a pixel per frame.

    Parameters
    ----------
    value : float

    Returns
    -------
    int

    Examples
    --------
    >>> [round_half_up(v) for v in (0.5, 1.5, 2.5, -0.5, 2.49)]
    [1, 2, 3, 0, 2]
    """
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
        width = max(1, round_half_up(self.size[0] * growth))
        height = max(1, round_half_up(self.size[1] * growth))
        centre_x = self.start_centre[0] + elapsed * self.velocity[0]
        centre_y = self.start_centre[1] + elapsed * self.velocity[1]
        return (round_half_up(centre_x - width / 2), round_half_up(centre_y - height / 2), width, height)


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
