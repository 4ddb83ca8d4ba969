"""Automatic track initiation and termination from a foreground mask (SPEC B.4, L §1.2 modules 2, 3 and 5).

L's multi-target tracker starts a target for every foreground blob of the first frame
(module 2), watches the image border for people who come in or go out (module 3) and
adds or removes targets accordingly (module 5).  L gives no rules for modules 3 and 5,
so the SPEC defaults are used:

* **blobs**: the foreground mask is cleaned by a morphological opening with a square
  kernel (3 × 3 by default) and split into 8-connected components; components smaller
  than ``min_area · W · H`` pixels are dropped (:func:`foreground_blobs`);
* **appear**: a blob that meets the border zone (``border`` px wide along the four image
  edges) and belongs to no track for ``appear_frames`` consecutive frames becomes a new
  track, whose box is the blob's bounding box at that frame;
* **disappear**: a track whose box centre lies in the border zone or outside the image,
  and whose box holds a foreground fraction below ``exit_foreground``, for ``exit_frames``
  consecutive frames is ended.  A track whose box holds too little foreground for
  ``lost_frames`` consecutive frames is ended wherever it is (the target has stopped
  being seen, for example because the filter drifted onto the background).

:class:`Initiator` holds the counters from frame to frame; the tracker calls
:meth:`Initiator.update` once per frame with the mask and its current track boxes.

Boxes are ``(x, y, w, h)`` in 0-based pixels, with ``(x, y)`` the top-left corner, as in
:mod:`plugins.video_tracking.cues`: pixel (column i, row j) covers [i, i+1) × [j, j+1), and
a pixel belongs to a box when its centre (i + ½, j + ½) does.  OpenCV does the opening and
the connected components; everything else is NumPy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plugins.video_tracking.errors import TrackingError

__all__ = [
    "InitiationConfig",
    "Initiator",
    "foreground_blobs",
    "foreground_fraction",
    "iou",
    "COVERED_FRACTION",
    "CANDIDATE_IOU",
]

Box = tuple[float, float, float, float]

#: A blob is a track's when at least this fraction of the blob's area lies inside the
#: track box, whatever their IoU (a track box may be much larger or smaller than the blob).
COVERED_FRACTION = 0.5

#: A blob continues an appearance candidate of the previous frame when their IoU is at
#: least this (or when their centres are at most half the blob's diagonal apart).
CANDIDATE_IOU = 0.3


# -- configuration --------------------------------------------------------------------------------
def _integer(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise TrackingError(f"InitiationConfig.{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _fraction(name: str, value, *, allow_zero: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or value > 1 or value < 0 or (value == 0 and not allow_zero):
        interval = "[0, 1]" if allow_zero else "(0, 1]"
        raise TrackingError(f"InitiationConfig.{name} must be a number in {interval}, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class InitiationConfig:
    """Settings of automatic track initiation and termination (SPEC B.4 defaults).

    Attributes
    ----------
    border : int
        Width b in pixels of the border zone along each image edge (default 10).  A blob
        meets the zone when any of its pixels is within ``border`` px of an edge.
    min_area : float
        Smallest blob area as a fraction of the image area W·H (default 0.002, i.e. 154
        pixels at 320 × 240).
    opening : int
        Side of the square kernel of the morphological opening applied to the mask before
        the blobs are taken (default 3); 0 or 1 disables the opening.
    max_iou : float
        A blob whose IoU with a track box is at least this belongs to that track and cannot
        start a new one (default 0.1).
    appear_frames : int
        n_app, the number of consecutive frames a free blob must meet the border zone
        before it becomes a track (default 3).
    exit_frames : int
        n_dis, the number of consecutive frames a track must lie in the border zone (or
        outside the image) with too little foreground before it ends (default 3).
    exit_foreground : float
        F below which a track box counts as having lost its target (default 0.1).
    lost_frames : int or None
        A track whose foreground fraction stays below ``exit_foreground`` for this many
        consecutive frames ends even away from the border (default 25); None disables
        the rule.
    first_frame : bool
        Whether every blob of the first frame given to :meth:`Initiator.update` starts a
        track at once, anywhere in the image (L's module 2; default True).
    duplicate_iou : float
        Two tracks whose boxes overlap with at least this IoU follow the same person ...
    duplicate_frames : int or None
        ... and when they do so for this many consecutive frames, the younger one (the
        larger id) ends (default 0.5 and 15 frames, longer than two people take to cross);
        None disables the rule.

    Raises
    ------
    TrackingError
        If a setting is out of range; the message names the field.

    Examples
    --------
    >>> InitiationConfig().min_area_pixels((240, 320))
    153.6
    >>> InitiationConfig(appear_frames=0)
    Traceback (most recent call last):
    ...
    plugins.video_tracking.errors.TrackingError: InitiationConfig.appear_frames must be an integer >= 1, got 0
    """

    border: int = 10
    min_area: float = 0.002
    opening: int = 3
    max_iou: float = 0.1
    appear_frames: int = 3
    exit_frames: int = 3
    exit_foreground: float = 0.1
    lost_frames: int | None = 25
    first_frame: bool = True
    duplicate_iou: float = 0.5
    duplicate_frames: int | None = 15

    def __post_init__(self) -> None:
        object.__setattr__(self, "border", _integer("border", self.border, 0))
        object.__setattr__(self, "min_area", _fraction("min_area", self.min_area, allow_zero=True))
        object.__setattr__(self, "opening", _integer("opening", self.opening, 0))
        object.__setattr__(self, "max_iou", _fraction("max_iou", self.max_iou, allow_zero=False))
        object.__setattr__(self, "appear_frames", _integer("appear_frames", self.appear_frames, 1))
        object.__setattr__(self, "exit_frames", _integer("exit_frames", self.exit_frames, 1))
        object.__setattr__(self, "exit_foreground",
                           _fraction("exit_foreground", self.exit_foreground, allow_zero=False))
        if self.lost_frames is not None:
            object.__setattr__(self, "lost_frames", _integer("lost_frames", self.lost_frames, 1))
        object.__setattr__(self, "duplicate_iou", _fraction("duplicate_iou", self.duplicate_iou, allow_zero=False))
        if self.duplicate_frames is not None:
            object.__setattr__(self, "duplicate_frames", _integer("duplicate_frames", self.duplicate_frames, 1))
        if not isinstance(self.first_frame, (bool, np.bool_)):
            raise TrackingError(f"InitiationConfig.first_frame must be True or False, got {self.first_frame!r}")
        object.__setattr__(self, "first_frame", bool(self.first_frame))

    def min_area_pixels(self, image_shape: tuple[int, int]) -> float:
        """The smallest blob area in pixels, ``min_area · W · H``, for an image of shape (H, W)."""
        height, width = _image_shape(image_shape)
        return self.min_area * height * width


# -- input checks ---------------------------------------------------------------------------------
def _image_shape(shape) -> tuple[int, int]:
    try:
        dims = tuple(shape)
    except TypeError:
        dims = ()
    if len(dims) not in (2, 3) or any(isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 1
                                       for d in dims[:2]):
        raise TrackingError(f"image_shape must be (H, W) or (H, W, C) with positive H and W, got {shape!r}")
    return int(dims[0]), int(dims[1])


def _checked_mask(mask, shape: tuple[int, int] | None = None) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.ndim != 2 or mask.dtype != np.bool_ or (shape is not None and mask.shape != shape):
        expected = f"shape {shape}" if shape is not None else "2 dimensions"
        raise TrackingError(f"the foreground mask must be a bool array of {expected}, got shape {mask.shape} "
                            f"dtype {mask.dtype} (use mask > 0 for a 0/255 image)")
    if mask.size == 0:
        raise TrackingError(f"the foreground mask is empty (shape {mask.shape})")
    return mask


def _checked_boxes(name: str, boxes) -> np.ndarray:
    boxes = np.asarray(boxes, dtype=np.float64)
    if boxes.ndim == 1 and boxes.size == 0:
        boxes = boxes.reshape(0, 4)
    if boxes.ndim != 2 or boxes.shape[1] != 4:
        raise TrackingError(f"{name} must have shape (n, 4) (x, y, w, h), got {boxes.shape}")
    if not np.isfinite(boxes).all():
        raise TrackingError(f"{name} must be finite")
    if (boxes[:, 2:] < 0).any():
        raise TrackingError(f"{name} must have non-negative widths and heights")
    return boxes


# -- blobs, foreground fractions and overlaps -----------------------------------------------------
def foreground_blobs(mask: np.ndarray, min_area_pixels: float, opening: int = 3) -> np.ndarray:
    """Bounding boxes of the 8-connected foreground blobs of a mask, after an opening.

    Parameters
    ----------
    mask : ndarray of bool, shape (H, W)
        Foreground mask (True = foreground).
    min_area_pixels : float
        Blobs with fewer pixels than this (counted after the opening) are dropped.
    opening : int
        Side of the square kernel of the morphological opening (erosion then dilation);
        0 or 1 leaves the mask as it is.  The image border does not erode blobs that
        touch it.

    Returns
    -------
    ndarray of float64, shape (n, 4)
        One ``(x, y, w, h)`` box per blob, sorted by x, then y, then w, then h.

    Raises
    ------
    TrackingError
        If the mask is not a 2-D bool array, or ``min_area_pixels`` or ``opening`` is invalid.

    Examples
    --------
    >>> mask = np.zeros((8, 10), bool)
    >>> mask[1:4, 1:4] = True          # a 3 x 3 square
    >>> mask[5, 6] = mask[6, 7] = True  # two diagonal pixels: one 8-connected blob
    >>> foreground_blobs(mask, min_area_pixels=1, opening=0).tolist()
    [[1.0, 1.0, 3.0, 3.0], [6.0, 5.0, 2.0, 2.0]]
    >>> foreground_blobs(mask, min_area_pixels=1, opening=3).tolist()  # the opening removes the pair
    [[1.0, 1.0, 3.0, 3.0]]
    """
    import cv2  # the image-processing edge of the plugin: keep OpenCV out of the import path

    mask = _checked_mask(mask)
    if isinstance(min_area_pixels, bool) or not isinstance(min_area_pixels, (int, float, np.integer, np.floating)) \
            or not math.isfinite(min_area_pixels) or min_area_pixels < 0:
        raise TrackingError(f"min_area_pixels must be a finite number >= 0, got {min_area_pixels!r}")
    if isinstance(opening, bool) or not isinstance(opening, (int, np.integer)) or opening < 0:
        raise TrackingError(f"opening must be an integer >= 0, got {opening!r}")
    image = mask.astype(np.uint8)
    if opening >= 2:
        kernel = np.ones((opening, opening), np.uint8)
        anchor = opening // 2
        # OpenCV's dilation does not reflect the kernel; dilating with the reflected anchor
        # makes erode + dilate a true opening for even kernel sides too.  The default border
        # values (max for erosion, min for dilation) leave blobs at the image edge whole.
        image = cv2.erode(image, kernel, anchor=(anchor, anchor))
        reflected = opening - 1 - anchor
        image = cv2.dilate(image, kernel, anchor=(reflected, reflected))
    count, _, stats, _ = cv2.connectedComponentsWithStats(image, connectivity=8)
    stats = stats[1:count]  # label 0 is the background
    keep = stats[:, cv2.CC_STAT_AREA] >= min_area_pixels
    boxes = stats[keep][:, [cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH, cv2.CC_STAT_HEIGHT]]
    boxes = boxes.astype(np.float64).reshape(-1, 4)
    order = np.lexsort((boxes[:, 3], boxes[:, 2], boxes[:, 1], boxes[:, 0]))
    return boxes[order]


def _pixel_ranges(boxes: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """First and one-past-last pixel columns and rows of each box, clipped to the image."""
    height, width = shape
    # Pixel i is in [x, x + w) when its centre i + 1/2 is: i from ceil(x - 1/2) to ceil(x + w - 1/2) - 1.
    x0 = np.clip(np.ceil(boxes[:, 0] - 0.5), 0, width).astype(np.intp)
    x1 = np.clip(np.ceil(boxes[:, 0] + boxes[:, 2] - 0.5), 0, width).astype(np.intp)
    y0 = np.clip(np.ceil(boxes[:, 1] - 0.5), 0, height).astype(np.intp)
    y1 = np.clip(np.ceil(boxes[:, 1] + boxes[:, 3] - 0.5), 0, height).astype(np.intp)
    return x0, np.maximum(x1, x0), y0, np.maximum(y1, y0)


def foreground_fraction(mask: np.ndarray, boxes) -> np.ndarray:
    """Fraction of the pixels of each box that are foreground, counting only pixels inside the image.

    Parameters
    ----------
    mask : ndarray of bool, shape (H, W)
        Foreground mask.
    boxes : array_like, shape (n, 4)
        ``(x, y, w, h)`` boxes; a pixel is in a box when its centre is.  Boxes may extend
        past the image: the fraction is over their in-image pixels.

    Returns
    -------
    ndarray of float64, shape (n,)
        Foreground pixels / in-image pixels of each box; 0 for a box with no pixel in the
        image.  An integral image makes each box O(1).

    Raises
    ------
    TrackingError
        If the mask is not a 2-D bool array or the boxes are not finite (n, 4) with
        non-negative sizes.

    Examples
    --------
    >>> mask = np.zeros((4, 6), bool)
    >>> mask[0:2, 0:3] = True
    >>> foreground_fraction(mask, [[0, 0, 3, 2], [0, 0, 6, 4], [-3, -2, 6, 4], [10, 0, 2, 2]]).tolist()
    [1.0, 0.25, 1.0, 0.0]
    """
    mask = _checked_mask(mask)
    boxes = _checked_boxes("boxes", boxes)
    integral = np.zeros((mask.shape[0] + 1, mask.shape[1] + 1), dtype=np.int64)
    np.cumsum(np.cumsum(mask, axis=0, dtype=np.int64), axis=1, out=integral[1:, 1:])
    x0, x1, y0, y1 = _pixel_ranges(boxes, mask.shape)
    foreground = integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]
    pixels = (x1 - x0) * (y1 - y0)
    return np.divide(foreground, pixels, out=np.zeros(len(boxes)), where=pixels > 0)


def _intersections(boxes_a: np.ndarray, boxes_b: np.ndarray) -> np.ndarray:
    left = np.maximum(boxes_a[:, None, 0], boxes_b[None, :, 0])
    top = np.maximum(boxes_a[:, None, 1], boxes_b[None, :, 1])
    right = np.minimum(boxes_a[:, None, 0] + boxes_a[:, None, 2], boxes_b[None, :, 0] + boxes_b[None, :, 2])
    bottom = np.minimum(boxes_a[:, None, 1] + boxes_a[:, None, 3], boxes_b[None, :, 1] + boxes_b[None, :, 3])
    return np.clip(right - left, 0, None) * np.clip(bottom - top, 0, None)


def iou(boxes_a, boxes_b) -> np.ndarray:
    """Intersection over union of every pair of boxes.

    Parameters
    ----------
    boxes_a : array_like, shape (n, 4)
    boxes_b : array_like, shape (m, 4)
        ``(x, y, w, h)`` boxes, as continuous rectangles [x, x + w) × [y, y + h).

    Returns
    -------
    ndarray of float64, shape (n, m)
        Area of the intersection over area of the union; 0 where the union is empty.

    Raises
    ------
    TrackingError
        If the boxes are not finite (n, 4) arrays with non-negative sizes.

    Examples
    --------
    >>> iou([[0, 0, 2, 2]], [[1, 0, 2, 2], [0, 0, 2, 2], [5, 5, 1, 1], [0, 0, 4, 4]]).tolist()
    [[0.3333333333333333, 1.0, 0.0, 0.25]]
    """
    boxes_a = _checked_boxes("boxes_a", boxes_a)
    boxes_b = _checked_boxes("boxes_b", boxes_b)
    inter = _intersections(boxes_a, boxes_b)
    union = (boxes_a[:, None, 2] * boxes_a[:, None, 3] + boxes_b[None, :, 2] * boxes_b[None, :, 3]) - inter
    return np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)


# -- the stateful initiator -----------------------------------------------------------------------
class Initiator:
    """Births and deaths of tracks, frame after frame, from the foreground mask (SPEC B.4).

    Parameters
    ----------
    config : InitiationConfig or None
        The rules; None means the defaults.
    image_shape : (int, int) or (int, int, int)
        (H, W) of the frames, or a frame's full shape (H, W, C).

    Notes
    -----
    Each call to :meth:`update` takes the mask of one frame and the current track boxes:

    1. The blobs of the mask are taken (:func:`foreground_blobs`).  A blob is *covered*
       when its IoU with a track box is at least ``max_iou``, or when at least
       :data:`COVERED_FRACTION` of its area lies in a track box.
    2. On the first call with ``first_frame=True``, every uncovered blob is born at once.
    3. Otherwise the uncovered blobs that meet the border zone are the candidates of this
       frame.  Each one continues the best-matching candidate of the previous frame (IoU
       at least :data:`CANDIDATE_IOU`, or centres at most half the blob's diagonal apart;
       pairs are taken greedily by decreasing IoU, then increasing distance) and takes its
       count plus one, or starts at 1.  A candidate whose count reaches ``appear_frames``
       is born with the blob's current box; the previous candidates that no blob continues
       are dropped.
    4. Each track keeps two counters, reset when its condition fails: frames with its box
       centre in the border zone (or outside the image) *and* foreground fraction below
       ``exit_foreground``, and frames with the fraction below ``exit_foreground``
       anywhere.  A track dies when the first reaches ``exit_frames`` or the second
       reaches ``lost_frames``.  The counters of ids that are no longer given are dropped.

    The border zone is the ``border`` outermost pixel columns and rows: a point (px, py)
    is in it when ``px < b``, ``px >= W - b``, ``py < b`` or ``py >= H - b``.

    Examples
    --------
    A person walks in at the left edge of an empty 40 × 60 image and is born at the third
    consecutive frame in which they are seen:

    >>> init = Initiator(InitiationConfig(border=5, min_area=0.01), (40, 60))
    >>> mask = np.zeros((40, 60), bool)
    >>> init.update(mask, {})  # nothing on the first frame
    ([], [])
    >>> for right in (3, 5, 7):
    ...     mask[10:30, :right] = True
    ...     print(init.update(mask, {}))
    ([], [])
    ([], [])
    ([(0.0, 10.0, 7.0, 20.0)], [])

    The tracker now follows the person as track 1.  They walk out again, and the track
    ends once its box, in the border zone, has held no foreground for three frames:

    >>> mask[:] = False
    >>> [init.update(mask, {1: (-2.0, 10.0, 6.0, 20.0)}) for _ in range(3)]
    [([], []), ([], []), ([], [1])]
    """

    def __init__(self, config: InitiationConfig | None, image_shape: tuple[int, ...]) -> None:
        if config is None:
            config = InitiationConfig()
        if not isinstance(config, InitiationConfig):
            raise TrackingError(f"config must be an InitiationConfig, got {type(config).__name__}")
        self.config = config
        self.image_shape = _image_shape(image_shape)
        self.min_area_pixels = config.min_area_pixels(self.image_shape)
        self._frames_seen = 0
        self._candidates = np.zeros((0, 4))
        self._candidate_counts = np.zeros(0, dtype=np.intp)
        self._blobs = np.zeros((0, 4))
        self._exit_counts: dict[int, int] = {}
        self._lost_counts: dict[int, int] = {}
        self._twin_counts: dict[int, int] = {}

    @property
    def frames_seen(self) -> int:
        """How many frames :meth:`update` has been given."""
        return self._frames_seen

    @property
    def candidates(self) -> list[tuple[Box, int]]:
        """The appearance candidates after the last frame: ``(blob box, consecutive frames seen)``."""
        return [(tuple(float(v) for v in box), int(n)) for box, n in zip(self._candidates, self._candidate_counts)]

    @property
    def blobs(self) -> np.ndarray:
        """The foreground blobs of the last frame given to :meth:`update`, shape (n, 4) (a copy)."""
        return self._blobs.copy()

    def touches_border(self, boxes) -> np.ndarray:
        """Whether each box ``(x, y, w, h)`` reaches into the border zone, shape (n,)."""
        return self._in_border_zone(np.asarray(boxes, dtype=np.float64).reshape(-1, 4))

    def reset(self) -> None:
        """Forget every candidate and counter, as if no frame had been given."""
        self._frames_seen = 0
        self._candidates = np.zeros((0, 4))
        self._candidate_counts = np.zeros(0, dtype=np.intp)
        self._blobs = np.zeros((0, 4))
        self._exit_counts.clear()
        self._twin_counts.clear()
        self._lost_counts.clear()

    def update(self, mask: np.ndarray, tracks: dict[int, Box]) -> tuple[list[Box], list[int]]:
        """Process one frame.

        Parameters
        ----------
        mask : ndarray of bool, shape (H, W)
            The frame's foreground mask.
        tracks : dict of int to (x, y, w, h)
            The current box of every live track, by track id.

        Returns
        -------
        births : list of (float, float, float, float)
            Boxes of the new tracks (the blobs' bounding boxes), sorted by x then y.
        deaths : list of int
            Ids of the tracks to end, in increasing order.

        Raises
        ------
        TrackingError
            If the mask is not a bool array of the image shape, or a track box is not four
            finite numbers with a positive width and height.
        """
        mask = _checked_mask(mask, self.image_shape)
        ids, boxes = self._checked_tracks(tracks)
        first = self._frames_seen == 0
        self._frames_seen += 1

        blobs = foreground_blobs(mask, self.min_area_pixels, self.config.opening)
        self._blobs = blobs
        free = ~self._covered(blobs, boxes)
        if first and self.config.first_frame:
            births = blobs[free]
            self._candidates = np.zeros((0, 4))
            self._candidate_counts = np.zeros(0, dtype=np.intp)
        else:
            births = self._advance_candidates(blobs[free & self._in_border_zone(blobs)])
        deaths = self._deaths(mask, ids, boxes)
        return [tuple(float(v) for v in box) for box in births], deaths

    # -- steps of update --------------------------------------------------------------------------
    @staticmethod
    def _checked_tracks(tracks) -> tuple[list[int], np.ndarray]:
        if not isinstance(tracks, dict):
            raise TrackingError(f"tracks must be a dict {{id: (x, y, w, h)}}, got {type(tracks).__name__}")
        ids = []
        for track_id in tracks:
            if isinstance(track_id, bool) or not isinstance(track_id, (int, np.integer)):
                raise TrackingError(f"track ids must be integers, got {track_id!r}")
            ids.append(int(track_id))
        ids.sort()
        boxes = np.zeros((len(ids), 4))
        for k, track_id in enumerate(ids):
            try:
                box = np.asarray(tracks[track_id], dtype=np.float64)
            except (TypeError, ValueError):
                box = np.zeros(0)
            if box.shape != (4,):
                raise TrackingError(f"track {track_id} has box {tracks[track_id]!r}: a box must be four numbers "
                                    f"(x, y, w, h)")
            boxes[k] = box
        bad = ~np.isfinite(boxes).all(axis=1) | (boxes[:, 2] <= 0) | (boxes[:, 3] <= 0)
        if bad.any():
            index = int(np.argmax(bad))
            raise TrackingError(f"track {ids[index]} has box {tracks[ids[index]]!r}: a box must be finite "
                                f"with a positive width and height")
        return ids, boxes

    def _covered(self, blobs: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """Whether each blob belongs to a track (IoU >= max_iou, or mostly inside a track box)."""
        if len(boxes) == 0 or len(blobs) == 0:
            return np.zeros(len(blobs), dtype=bool)
        overlap = iou(blobs, boxes) >= self.config.max_iou
        inside = _intersections(blobs, boxes) >= COVERED_FRACTION * (blobs[:, 2] * blobs[:, 3])[:, None]
        return (overlap | inside).any(axis=1)

    def _in_border_zone(self, blobs: np.ndarray) -> np.ndarray:
        """Whether any pixel of each blob lies within ``border`` px of an image edge."""
        height, width = self.image_shape
        b = self.config.border
        return ((blobs[:, 0] < b) | (blobs[:, 1] < b)
                | (blobs[:, 0] + blobs[:, 2] > width - b) | (blobs[:, 1] + blobs[:, 3] > height - b))

    def _advance_candidates(self, blobs: np.ndarray) -> np.ndarray:
        """Match this frame's candidate blobs to the previous ones; return those that are born."""
        counts = np.ones(len(blobs), dtype=np.intp)
        previous, previous_counts = self._candidates, self._candidate_counts
        if len(blobs) and len(previous):
            overlaps = iou(blobs, previous)
            centres = blobs[:, :2] + blobs[:, 2:] / 2
            previous_centres = previous[:, :2] + previous[:, 2:] / 2
            distances = np.linalg.norm(centres[:, None, :] - previous_centres[None, :, :], axis=2)
            reach = np.hypot(blobs[:, 2], blobs[:, 3])[:, None] / 2
            rows, cols = np.nonzero((overlaps >= CANDIDATE_IOU) | (distances <= reach))
            order = np.lexsort((cols, rows, distances[rows, cols], -overlaps[rows, cols]))
            blob_taken = np.zeros(len(blobs), dtype=bool)
            previous_taken = np.zeros(len(previous), dtype=bool)
            for k in order:
                i, j = rows[k], cols[k]
                if not blob_taken[i] and not previous_taken[j]:
                    blob_taken[i] = previous_taken[j] = True
                    counts[i] = previous_counts[j] + 1
        born = counts >= self.config.appear_frames
        self._candidates = blobs[~born]
        self._candidate_counts = counts[~born]
        return blobs[born]

    def _deaths(self, mask: np.ndarray, ids: list[int], boxes: np.ndarray) -> list[int]:
        """Update the per-track counters; return the ids of the tracks that end."""
        config = self.config
        height, width = self.image_shape
        b = config.border
        empty = foreground_fraction(mask, boxes) < config.exit_foreground
        centre_x = boxes[:, 0] + boxes[:, 2] / 2
        centre_y = boxes[:, 1] + boxes[:, 3] / 2
        at_border = (centre_x < b) | (centre_x >= width - b) | (centre_y < b) | (centre_y >= height - b)
        # ids are sorted, so an older track (smaller id) comes first: a duplicate is a track
        # that overlaps an older one.
        overlaps = iou(boxes, boxes) if len(ids) else np.zeros((0, 0))
        duplicate = np.array([(overlaps[k, :k] >= config.duplicate_iou).any() for k in range(len(ids))], dtype=bool)
        exit_counts, lost_counts, twin_counts, deaths = {}, {}, {}, []
        for k, track_id in enumerate(ids):
            leaving = self._exit_counts.get(track_id, 0) + 1 if empty[k] and at_border[k] else 0
            lost = self._lost_counts.get(track_id, 0) + 1 if empty[k] else 0
            twin = self._twin_counts.get(track_id, 0) + 1 if duplicate[k] else 0
            if leaving >= config.exit_frames or (config.lost_frames is not None and lost >= config.lost_frames) \
                    or (config.duplicate_frames is not None and twin >= config.duplicate_frames):
                deaths.append(track_id)
            else:
                exit_counts[track_id], lost_counts[track_id], twin_counts[track_id] = leaving, lost, twin
        self._exit_counts, self._lost_counts, self._twin_counts = exit_counts, lost_counts, twin_counts
        return deaths
