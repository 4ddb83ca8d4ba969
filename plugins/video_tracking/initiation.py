"""When tracks start and end: init plans, the settings of automatic tracks, and foreground blobs (SPEC B.4).

An :class:`InitPlan` says when each target is born and removed: from a MOTChallenge ground
truth (:func:`init_from_gt`, as ``belief track --init-from-gt``), from a file of first-frame
boxes (:func:`read_init_boxes`) or from boxes in code (:func:`init_from_boxes`).

Without a plan, or for the people who enter later, the tracks start, are lost, are found
again and end on their own (L §1.2 modules 2, 3 and 5), by the rules of
:class:`InitiationConfig` that :class:`~belief_tracking.lifecycle.Lifecycle` applies
to each frame's candidate boxes: a detector's, or the person blobs of the foreground mask.
L starts a target for every foreground blob of the first frame (module 2) and watches the
image border for people who come in or go out (modules 3 and 5); people also appear from
behind things and stop being seen in the middle of the image, so by default new tracks
may start anywhere (``anywhere``), and a track that nothing supports is hidden, then lost
and remembered.

The blobs of a mask are its 8-connected components after a morphological opening with a
square kernel (3 × 3 by default), dropping those smaller than ``min_area · W · H`` pixels
(:func:`foreground_blobs`); :func:`foreground_fraction` measures how much of a box is
foreground.

Boxes are ``(x, y, w, h)`` in 0-based pixels, with ``(x, y)`` the top-left corner, as in
:mod:`belief_tracking.cues`: pixel (column i, row j) covers [i, i+1) × [j, j+1), and
a pixel belongs to a box when its centre (i + ½, j + ½) does.  OpenCV does the opening and
the connected components; everything else is NumPy.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from os import PathLike

import numpy as np

from belief.textfiles import read_text
from . import checks
from .boxes import check_boxes, pixel_ranges
from .errors import InitError, TrackingError
from .extras import require
from .motfiles import MAX_COORDINATE, MAX_FRAME, MAX_ID, check_box, check_frame, read_mot

__all__ = [
    "TargetInit",
    "InitPlan",
    "init_from_gt",
    "init_from_boxes",
    "read_init_boxes",
    "InitiationConfig",
    "foreground_blobs",
    "foreground_fraction",
    "COVERED_FRACTION",
    "FOLLOW_PLAN",
    "settings_of",
]

Box = tuple[float, float, float, float]

#: A candidate is a track's when at least this fraction of its area lies inside the track
#: box, whatever their IoU (a track box may be much larger or smaller than the candidate).
COVERED_FRACTION = 0.5


# -- init plans ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TargetInit:
    """One target of an :class:`InitPlan`.

    Attributes
    ----------
    id : int
        The track id written to ``tracks.txt``.
    first_frame : int
        1-based frame at which the target is born, at ``box``.
    last_frame : int or None
        1-based frame after which it is removed; None keeps it to the end.
    box : (float, float, float, float)
        ``x, y, w, h`` in 0-based pixels: the initial centre and the base size.
    """

    id: int
    first_frame: int
    last_frame: int | None
    box: tuple[float, float, float, float]

    def __post_init__(self) -> None:
        object.__setattr__(self, "id", checks.integer("a target id", self.id))
        (box,) = check_boxes([self.box], f"the box of target {self.id}", error=InitError)
        first = checks.integer(f"the first frame of target {self.id}", self.first_frame)
        last = None if self.last_frame is None else \
            checks.integer(f"the last frame of target {self.id}", self.last_frame)
        if first < 1 or (last is not None and last < first):
            raise InitError(f"target {self.id}: bad frame range {first}..{last}")
        object.__setattr__(self, "first_frame", first)
        object.__setattr__(self, "last_frame", last)
        object.__setattr__(self, "box", tuple(float(v) for v in box))


@dataclass(frozen=True)
class InitPlan:
    """When each target is born and removed.

    Attributes
    ----------
    targets : tuple of TargetInit
        Distinct ids, in birth order (then id order).
    source : str
        Where the plan came from, for messages and the run's summary.
    """

    targets: tuple[TargetInit, ...]
    source: str = ""

    def __post_init__(self) -> None:
        targets = tuple(sorted(self.targets, key=lambda t: (t.first_frame, t.id)))
        if not targets:
            raise InitError(f"{self.source or 'the init'}: no target to track")
        ids = [t.id for t in targets]
        if len(set(ids)) != len(ids):
            raise InitError(f"{self.source or 'the init'}: a target id appears twice")
        object.__setattr__(self, "targets", targets)
        births: dict[int, list[TargetInit]] = {}
        for target in targets:
            births.setdefault(target.first_frame, []).append(target)
        object.__setattr__(self, "_births", births)

    def check_image(self, width: int, height: int) -> None:
        """Raise :class:`InitError` if a birth box does not overlap a ``width`` × ``height`` image."""
        for target in self.targets:
            x, y, w, h = target.box
            if x >= width or y >= height or x + w <= 0 or y + h <= 0:
                raise InitError(f"{self.source or 'init'}: the box of target {target.id} "
                                f"(x={x + 1:g}, y={y + 1:g}, w={w:g}, h={h:g}, 1-based) lies outside the "
                                f"{width}x{height} image")

    def peak(self) -> tuple[int, int]:
        """The most targets alive at once, and the first 1-based frame where that many are.

        Examples
        --------
        >>> plan = InitPlan((TargetInit(1, 1, 3, (0, 0, 2, 2)), TargetInit(2, 2, None, (0, 0, 2, 2)),
        ...                  TargetInit(3, 4, 5, (0, 0, 2, 2))))
        >>> plan.peak()
        (2, 2)
        """
        changes: dict[int, int] = {}
        for target in self.targets:
            changes[target.first_frame] = changes.get(target.first_frame, 0) + 1
            if target.last_frame is not None:
                changes[target.last_frame + 1] = changes.get(target.last_frame + 1, 0) - 1
        alive = best = 0
        at = 1
        for frame in sorted(changes):
            alive += changes[frame]
            if alive > best:
                best, at = alive, frame
        return best, at

    def births(self, frame: int) -> list[TargetInit]:
        """Targets born at 1-based ``frame``."""
        return list(self._births.get(frame, ()))  # type: ignore[attr-defined]


def init_from_gt(gt: str | PathLike[str] | np.ndarray, source: str | None = None) -> InitPlan:
    """Targets from a MOTChallenge ground truth: each id is born at its first box, removed after its last.

    Parameters
    ----------
    gt : path or ndarray, shape (M, ≥6)
        A file for :func:`~belief_tracking.motfiles.read_mot`, or its rows
        ``frame, id, x, y, w, h, ...`` (1-based frames and corners).
    source : str, optional
        How messages name the plan (default: the path, or "ground truth").

    Examples
    --------
    >>> rows = np.array([[1, 7, 11, 21, 10, 20], [2, 7, 12, 21, 10, 20], [2, 3, 1, 1, 5, 5]])
    >>> [(t.id, t.first_frame, t.last_frame, t.box) for t in init_from_gt(rows).targets]
    [(7, 1, 2, (10.0, 20.0, 10.0, 20.0)), (3, 2, 2, (0.0, 0.0, 5.0, 5.0))]
    """
    if isinstance(gt, np.ndarray):
        rows, name = np.asarray(gt, dtype=np.float64), source or "ground truth"
    else:
        rows, name = read_mot(gt), source or str(gt)
    if rows.ndim != 2 or rows.shape[0] == 0 or rows.shape[1] < 6:
        raise InitError(f"{name}: no boxes to initialise the targets from")
    if not np.isfinite(rows[:, :6]).all():
        raise InitError(f"{name}: a frame, id or box is not finite")
    frames, ids = rows[:, 0], rows[:, 1]
    bad = ((frames != np.round(frames)) | (frames < 1) | (frames > MAX_FRAME) | (ids != np.round(ids))
           | (np.abs(ids) > MAX_ID) | (np.abs(rows[:, 2:6]) > MAX_COORDINATE).any(axis=1))
    for row in rows[bad][:1]:
        check_frame(row[0], f"{name}, row {int(np.flatnonzero(bad)[0]) + 1}", InitError)
        where = f"{name}, frame {int(row[0])}"
        if row[1] != int(row[1]) or abs(row[1]) > MAX_ID:
            raise InitError(f"{where}: the id must be an integer from {-MAX_ID} to {MAX_ID}, got {row[1]:g}")
        check_box(*row[2:6], f"{where}, id {int(row[1])}", InitError)
    targets = []
    for track_id in np.unique(rows[:, 1]):
        own = rows[rows[:, 1] == track_id]
        own = own[np.argsort(own[:, 0], kind="stable")]
        first = own[0]
        if first[4] <= 0 or first[5] <= 0:
            raise InitError(f"{name}: the first box of id {int(track_id)} has no area")
        box = (first[2] - 1.0, first[3] - 1.0, first[4], first[5])
        targets.append(TargetInit(int(track_id), int(own[0, 0]), int(own[-1, 0]), box))
    return InitPlan(tuple(targets), source=name)


def read_init_boxes(path: str | PathLike[str]) -> InitPlan:
    """Targets from a CSV of ``id,x,y,w,h`` lines, all born at frame 1 and never removed.

    ``x, y`` is the top-left corner in the MOTChallenge convention (1-based, as in
    ``tracks.txt`` and ground-truth files).  Blank lines and lines starting with ``#`` are
    skipped, and so is a first line ``id,x,y,w,h``.

    Raises
    ------
    InitError
        Missing, unreadable or empty file, a malformed line (named with its number), a
        non-positive size or a repeated id.
    """
    name = str(path)
    text = read_text(path, "init file", InitError, encoding="utf-8-sig")
    targets = []
    seen: set[int] = set()
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        fields_ = [f.strip() for f in stripped.split(",")]
        if not targets and [f.lower() for f in fields_] == ["id", "x", "y", "w", "h"]:
            continue
        if len(fields_) != 5:
            raise InitError(f"{name}, line {number}: expected 5 fields id,x,y,w,h, got {len(fields_)}")
        try:
            values = [float(f) for f in fields_]
        except ValueError:
            raise InitError(f"{name}, line {number}: a field is not a number: {stripped!r}") from None
        if not all(math.isfinite(v) for v in values):
            raise InitError(f"{name}, line {number}: a field is not finite")
        track_id, x, y, w, h = values
        if track_id != int(track_id) or abs(track_id) > MAX_ID:
            raise InitError(f"{name}, line {number}: the id must be an integer from {-MAX_ID} to {MAX_ID}, "
                            f"got {fields_[0]}")
        check_box(x, y, w, h, f"{name}, line {number}", InitError)
        if w <= 0 or h <= 0:
            raise InitError(f"{name}, line {number}: the box needs a positive width and height, got {w:g} x {h:g}")
        if int(track_id) in seen:
            raise InitError(f"{name}, line {number}: id {int(track_id)} appears twice")
        seen.add(int(track_id))
        targets.append(TargetInit(int(track_id), 1, None, (x - 1.0, y - 1.0, w, h)))
    if not targets:
        raise InitError(f"init file {name!r} holds no boxes (it is empty)")
    return InitPlan(tuple(targets), source=name)


def init_from_boxes(boxes: Iterable[Sequence[float]], ids: Sequence[int] | None = None) -> InitPlan:
    """Targets at 0-based boxes ``(x, y, w, h)``, born at frame 1 and never removed.

    Examples
    --------
    >>> init_from_boxes([(10, 20, 8, 16)]).targets[0]
    TargetInit(id=1, first_frame=1, last_frame=None, box=(10.0, 20.0, 8.0, 16.0))
    """
    boxes = [tuple(b) for b in boxes]
    ids = list(range(1, len(boxes) + 1)) if ids is None else list(ids)
    if len(ids) != len(boxes):
        raise InitError(f"{len(ids)} ids for {len(boxes)} boxes")
    return InitPlan(tuple(TargetInit(int(i), 1, None, b) for i, b in zip(ids, boxes)), source="boxes")


# -- configuration --------------------------------------------------------------------------------
def _integer(name: str, value, minimum: int) -> int:
    return checks.integer(f"InitiationConfig.{name}", value, minimum=minimum)


def _fraction(name: str, value, *, allow_zero: bool) -> float:
    return checks.fraction(f"InitiationConfig.{name}", value, allow_zero=allow_zero)


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
        Without a detector, a track box with at least this foreground fraction F still
        counts as supported (default 0.1).
    lost_frames : int or None
        A track unsupported (no candidate, and without a detector too little foreground)
        for this many consecutive frames is lost: no longer output, and remembered for
        ``memory`` frames so that it can take back its id (default 25); None never loses
        a track.
    appearance_support : float or None
        A track whose window at its estimate has a Bhattacharyya coefficient ρ of at least
        this with its appearance templates (the smallest over the appearance cues) counts as
        supported, detected or not (default 0.8); None: only candidates (and foreground)
        support a track.
    coast_frames : int
        A track is output while it has been unsupported for at most this many frames
        (default 2); after that it is still followed, and output again once a candidate
        supports it, until ``lost_frames``.
    first_frame : bool
        Whether every free candidate of the first frame starts a track at once, anywhere
        in the image (L's module 2; default True).
    duplicate_iou : float
        Two tracks whose boxes overlap with at least this IoU follow the same person ...
    duplicate_frames : int or None
        ... and when they do so for this many consecutive frames, the younger one (the
        larger id) ends (default 0.5 and 5 frames); a box at least 70 % inside an older
        track's box counts as overlapping it (a fragment of a person already followed);
        None disables the rule.
    anywhere : bool
        Chains of candidates may start anywhere in the image (default True: people appear
        from doors and behind obstacles, and detections are seen everywhere); False keeps
        SPEC B.4's rule that a new target enters at the image border.
    match_iou : float
        The gate of the one-to-one assignment of candidates to tracks, and of a chain to
        the next frame's candidate: pairs overlapping less never match (default 0.3).
    memory : int
        Frames a lost track is remembered (default 50).
    reid_similarity : float
        A newborn track whose colour template has at least this Bhattacharyya coefficient
        with a remembered lost track's (and that is near enough to where it was lost) takes
        back that track's id (default 0.85).
    size_smoothing : float
        Weight in (0, 1] of a supporting candidate's size in a track's box size (an
        exponential moving average; default 0.3).
    detection_size_smoothing : float
        The same weight for a detection (default 0.15): a detector's boxes jitter from frame
        to frame (on PETS, MOT15's public boxes are 1.07 to 1.69 times as wide as the
        person, 10th to 90th percentile), so they are averaged over more frames.
    max_aspect : float
        A detection gives a track at most this times its height as the width (default 0.5):
        detectors often give one aspect ratio to everybody, with a margin of background
        beside the person.
    centre_gain : float
        A track that takes a candidate moves its centre, particles and estimate alike, by
        this times the candidate's score towards the candidate's centre (default 0.5).
    appearance_weight : float
        w, the weight of appearance in the assignment of *detections* to tracks (default
        0.75; 0: overlap alone): a pair scores IoU + w·ρ, where ρ is the Bhattacharyya
        coefficient between the track's templates and the window of the track's size at
        the detection's centre (the smallest over the appearance cues, as for
        ``appearance_support``).  Where two people stand close together, both of their
        tracks overlap the one detection, and ρ gives it to the person it shows.  The gate
        stays the overlap alone (``match_iou``).  Foreground blobs are assigned on overlap
        alone: a blob may hold several people.  The default was chosen with
        ``benchmarks/choose_defaults.py``.
    births : bool
        Whether tracks start and end on their own (default True).  False: every birth and
        death comes from the init plan.  The candidates still support and correct the
        planned tracks (their boxes follow the candidates they take, and the background
        model does not learn the pixels under them); a planned track that nothing supports
        is hidden after ``coast_frames`` frames and lost after ``lost_frames`` (no longer
        output, and remembered), as an automatic one is, and a chain of candidates only
        brings a lost track back (re-identification), never a new one.  A run given a plan
        and no initiation works so where its cues read the foreground (:data:`FOLLOW_PLAN`,
        :func:`~belief_tracking.runner.run_config`): the births and deaths of a ground truth
        are all known, and its tracks still use everything the foreground tells.
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
    belief_tracking.errors.TrackingError: InitiationConfig.appear_frames must be an integer >= 1, got 0
    """

    border: int = 10
    min_area: float = 0.002
    opening: int = 3
    max_iou: float = 0.1
    appear_frames: int = 3
    exit_frames: int = 3
    exit_foreground: float = 0.1
    lost_frames: int | None = 25
    coast_frames: int = 2
    appearance_support: float | None = 0.8
    first_frame: bool = True
    duplicate_iou: float = 0.5
    duplicate_frames: int | None = 5
    anywhere: bool = True
    match_iou: float = 0.3
    memory: int = 50
    reid_similarity: float = 0.85
    size_smoothing: float = 0.3
    detection_size_smoothing: float = 0.15
    max_aspect: float = 0.5
    centre_gain: float = 0.5
    appearance_weight: float = 0.75
    births: bool = True

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
        object.__setattr__(self, "first_frame", checks.flag("InitiationConfig.first_frame", self.first_frame))
        object.__setattr__(self, "coast_frames", _integer("coast_frames", self.coast_frames, 0))
        if self.appearance_support is not None:
            object.__setattr__(self, "appearance_support",
                               _fraction("appearance_support", self.appearance_support, allow_zero=True))
        object.__setattr__(self, "anywhere", checks.flag("InitiationConfig.anywhere", self.anywhere))
        object.__setattr__(self, "match_iou", _fraction("match_iou", self.match_iou, allow_zero=False))
        object.__setattr__(self, "memory", _integer("memory", self.memory, 0))
        object.__setattr__(self, "reid_similarity",
                           _fraction("reid_similarity", self.reid_similarity, allow_zero=False))
        object.__setattr__(self, "size_smoothing", _fraction("size_smoothing", self.size_smoothing, allow_zero=False))
        object.__setattr__(self, "detection_size_smoothing",
                           _fraction("detection_size_smoothing", self.detection_size_smoothing, allow_zero=False))
        object.__setattr__(self, "max_aspect", checks.number("InitiationConfig.max_aspect", self.max_aspect,
                                                             positive=True))
        object.__setattr__(self, "centre_gain", _fraction("centre_gain", self.centre_gain, allow_zero=True))
        object.__setattr__(self, "appearance_weight", checks.number("InitiationConfig.appearance_weight",
                                                                    self.appearance_weight, minimum=0.0))
        object.__setattr__(self, "births", checks.flag("InitiationConfig.births", self.births))

    def min_area_pixels(self, image_shape: tuple[int, int]) -> float:
        """The smallest blob area in pixels, ``min_area · W · H``, for an image of shape (H, W)."""
        height, width = checks.image_shape(image_shape)
        return self.min_area * height * width


#: The initiation of a run given an init plan and no initiation (``belief track --init-from-gt``,
#: :func:`~belief_tracking.runner.run_config`): every birth and death is the plan's, and the
#: frame's candidates (the person blobs of the foreground, or a detector's boxes) support, correct,
#: lose and find again the planned tracks as they do automatic ones, with the pixels under the
#: tracks kept out of the background model.  A planned track's first box is the ground truth's
#: (or the user's), so the centre goes all the way to the candidate it takes (``centre_gain`` 1):
#: the plan says that person is there, and the candidate says where.
FOLLOW_PLAN = InitiationConfig(first_frame=False, births=False, centre_gain=1.0)


def settings_of(config: InitiationConfig) -> dict:
    """The fields of ``config`` that differ from the defaults, as a table of settings (``--set initiation.…``).

    Examples
    --------
    >>> settings_of(FOLLOW_PLAN)
    {'first_frame': False, 'centre_gain': 1.0, 'births': False}
    >>> InitiationConfig(**settings_of(FOLLOW_PLAN)) == FOLLOW_PLAN
    True
    """
    return {f.name: getattr(config, f.name) for f in dataclasses.fields(config)
            if getattr(config, f.name) != f.default}


# -- input checks ---------------------------------------------------------------------------------
def _checked_mask(mask, shape: tuple[int, int] | None = None) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.ndim != 2 or mask.dtype != np.bool_ or (shape is not None and mask.shape != shape):
        expected = f"shape {shape}" if shape is not None else "2 dimensions"
        raise TrackingError(f"the foreground mask must be a bool array of {expected}, got shape {mask.shape} "
                            f"dtype {mask.dtype} (use mask > 0 for a 0/255 image)")
    if mask.size == 0:
        raise TrackingError(f"the foreground mask is empty (shape {mask.shape})")
    return mask


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
    cv2 = require("cv2")  # OpenCV stays at the edges: out of the import path

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
        image.  Boxes that cover much of the frame between them are counted on an integral
        image, which makes each box O(1).

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
    boxes = check_boxes(boxes, "boxes", positive=False)
    x0, x1, y0, y1 = pixel_ranges(boxes, mask.shape)
    pixels = (x1 - x0) * (y1 - y0)
    if 4 * int(pixels.sum()) < mask.size:
        # A few boxes (a frame's tracks): counting their own pixels costs less than the
        # integral image of the whole frame.
        foreground = np.array([np.count_nonzero(mask[top:bottom, left:right])
                               for left, right, top, bottom in zip(x0.tolist(), x1.tolist(), y0.tolist(), y1.tolist())],
                              dtype=np.int64)
    else:
        integral = np.zeros((mask.shape[0] + 1, mask.shape[1] + 1), dtype=np.int64)
        np.cumsum(np.cumsum(mask, axis=0, dtype=np.int64), axis=1, out=integral[1:, 1:])
        foreground = integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]
    return np.divide(foreground, pixels, out=np.zeros(len(boxes)), where=pixels > 0)
