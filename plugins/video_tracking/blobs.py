"""People's boxes from a foreground mask, when there is no detector.

The blobs of a foreground mask are rough boxes of people: two people who walk side by
side make one blob, a shirt of the background's colour splits a person into a head and
torso above and legs below, and a blob can reach far above a person (a group one behind
the other) or be a shadow.  With a :class:`~belief_tracking.perspective.PersonSize`,
which says how large a person whose feet are on a given row is, :func:`person_boxes` turns
the blobs into boxes of single people:

1. **blobs**: the mask is cleaned by the opening of
   :func:`~belief_tracking.initiation.foreground_blobs` and split into 8-connected
   components;
2. **fragments**: two blobs whose union is no larger than one person at its foot row, and
   that each are only part of one, are merged (without a size model only a blob just
   above another of about its width, their union still a tall shape, is merged);
3. **small blobs** that are not cut by the image border and are far below a person's size
   are dropped (noise, shadows);
4. **tall blobs**, more than ``max_height`` times a person's height at their foot row, are
   cut to that height keeping the feet (the most reliable part of a blob, on the
   ground); what is left above is kept as a person further back when it is large enough;
5. **wide blobs**, at least ``split_width`` times a person's width, are split into
   k = round(width / person width) boxes at the emptiest columns near the even cuts, each
   box then shrunk to its pixels.

:func:`box_mask` gives the pixels under a set of boxes (the ``protect`` mask of
:meth:`BackgroundModel.apply <belief_tracking.background.BackgroundModel.apply>`),
and :func:`fit_person_size` fits the size model on the blobs of several masks.

Boxes are ``(x, y, w, h)`` in 0-based pixels, as in
:mod:`~belief_tracking.initiation`; OpenCV does the opening and the connected
components, the rest is NumPy.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from .boxes import check_boxes, pixel_ranges
from . import checks
from .errors import TrackingError
from .extras import require
from .perspective import PersonSize

__all__ = ["person_boxes", "box_mask", "fit_person_size"]

#: Blobs down to this fraction of ``min_area_pixels`` are kept as possible fragments of a person.
_FRAGMENT_AREA = 0.25

#: A merge of fragments may be up to this factor of a person's height and width at its foot row.
_MERGED_SIZE = 1.25

#: A blob is only part of a person when it is less than this fraction of a person's height
#: or width: two whole people are never merged.
_PARTIAL = 0.8

#: Fragments are merged only when at least this fraction of their union's box is foreground.
_MERGED_FILL = 0.3

#: With a size model, a blob inside the image below this fraction of a person's height, or
#: whose pixels fill less than this fraction of a person's box, is no person.
_MIN_HEIGHT, _MIN_FILL = 0.4, 0.12

#: What is left above a cut tall blob is a person further back when it is at least this
#: fraction of a person's height at its own foot row.
_REST_HEIGHT = 0.5

#: Dips of a blob's lowest-pixel profile narrower than this fraction of a person's width are
#: gaps between legs; a step of the profile by more than this fraction of a person's height
#: separates two people (one in front of the other); a run of columns narrower than this
#: fraction of a person's width is no person on its own.
_LEG_GAP, _FOOT_STEP, _NARROW_RUN = 0.3, 0.08, 0.4

#: A blob at most this many times a person's width, and not too tall, is one person as it is.
_ONE_WIDE = 1.25

#: A split may move from the even cut by this fraction of a part's width, to an emptier column.
_SPLIT_SLACK = 0.3

#: A blob within this many pixels of the image edge is cut by it.
_EDGE = 1


def person_boxes(mask: np.ndarray, size_model: PersonSize | None = None, *, min_area_pixels: float,
                 opening: int = 3, split_width: float = 1.7, max_height: float = 1.5) -> np.ndarray:
    """Boxes of single people from a foreground mask, using their expected size when it is known.

    Parameters
    ----------
    mask : ndarray of bool, shape (H, W)
        Foreground mask (True = foreground).
    size_model : PersonSize, optional
        A person's size by foot row.  Without it the boxes are the blobs, with fragments
        of one person stacked one above the other merged.
    min_area_pixels : float
        Without a size model, blobs (or merges) with fewer pixels are dropped, as by
        :func:`~belief_tracking.initiation.foreground_blobs`.  With one, only blobs
        cut by the image border are held to it; the others are held to the size model.
    opening : int
        Side of the square kernel of the opening (0 or 1: none).
    split_width : float
        A blob at least this many times a person's width at its foot row is split (> 1).
    max_height : float
        A blob more than this many times a person's height at its foot row is cut (> 1).

    Returns
    -------
    ndarray of float64, shape (n, 4)
        ``(x, y, w, h)`` boxes, sorted by x, then y, then w, then h.

    Raises
    ------
    TrackingError
        If the mask is not a 2-D bool array, or a setting is invalid.

    Examples
    --------
    Two people 10 × 30 px stand side by side with their feet on row 40, and a third one's
    legs are cut off from their torso by a band of background-coloured clothing:

    >>> mask = np.zeros((50, 80), bool)
    >>> mask[10:40, 5:25] = True                       # two people, one blob 20 px wide
    >>> mask[10:24, 50:60] = mask[29:40, 50:60] = True  # torso above, legs below
    >>> person_boxes(mask, min_area_pixels=20).tolist()
    [[5.0, 10.0, 20.0, 30.0], [50.0, 10.0, 10.0, 14.0], [50.0, 29.0, 10.0, 11.0]]
    >>> size = PersonSize(0.0, 30.0, 1 / 3)
    >>> person_boxes(mask, size, min_area_pixels=20).tolist()
    [[5.0, 10.0, 10.0, 30.0], [15.0, 10.0, 10.0, 30.0], [50.0, 10.0, 10.0, 30.0]]
    """
    mask = _checked_mask(mask)
    min_area_pixels = _number("min_area_pixels", min_area_pixels, minimum=0.0)
    if isinstance(opening, bool) or not isinstance(opening, (int, np.integer)) or opening < 0:
        raise TrackingError(f"opening must be an integer >= 0, got {opening!r}")
    split_width = _number("split_width", split_width, above=1.0)
    max_height = _number("max_height", max_height, above=1.0)
    if size_model is not None and not isinstance(size_model, PersonSize):
        raise TrackingError(f"size_model must be a PersonSize or None, got {type(size_model).__name__}")

    labels, stats = _components(mask, opening)
    blobs = [_Blob(stats[k, :4].copy(), [k + 1], int(stats[k, 4])) for k in range(len(stats))
             if stats[k, 4] >= _FRAGMENT_AREA * min_area_pixels]
    blobs = _merge_fragments(blobs, size_model)
    height, width = mask.shape
    boxes: list[np.ndarray] = []
    for blob in blobs:
        x, y, w, h = blob.box
        at_edge = x <= _EDGE or y <= _EDGE or x + w >= width - _EDGE or y + h >= height - _EDGE
        if size_model is None or at_edge:
            if blob.area >= min_area_pixels:
                boxes.extend(_shaped(blob, labels, size_model, split_width, max_height) if size_model else [blob.box])
            continue
        person_w, person_h = _size(size_model, y + h)
        if h < _MIN_HEIGHT * person_h or blob.area < _MIN_FILL * person_w * person_h:
            continue
        boxes.extend(_shaped(blob, labels, size_model, split_width, max_height))
    if not boxes:
        return np.zeros((0, 4))
    result = np.array(boxes, dtype=np.float64).reshape(-1, 4)
    return result[np.lexsort((result[:, 3], result[:, 2], result[:, 1], result[:, 0]))]


def box_mask(image_shape: tuple[int, ...], boxes) -> np.ndarray:
    """The pixels whose centres lie in any of the boxes ``(x, y, w, h)``, as a bool (H, W) mask.

    Boxes may reach past the image; only their in-image pixels are set.

    Examples
    --------
    >>> box_mask((4, 6), [[1, 1, 2, 2], [5, 3, 4, 4]]).astype(int)
    array([[0, 0, 0, 0, 0, 0],
           [0, 1, 1, 0, 0, 0],
           [0, 1, 1, 0, 0, 0],
           [0, 0, 0, 0, 0, 1]])
    """
    height, width = checks.image_shape(image_shape)
    boxes = check_boxes(boxes, "boxes", positive=False).reshape(-1, 4)
    mask = np.zeros((height, width), dtype=bool)
    x0, x1, y0, y1 = pixel_ranges(boxes, (height, width))
    for a, b, c, d in zip(y0, y1, x0, x1):
        mask[a:b, c:d] = True
    return mask


def fit_person_size(masks: Iterable[np.ndarray], *, min_area_pixels: float, opening: int = 3,
                    border: float = 2.0, min_boxes: int = 3) -> PersonSize | None:
    """A :class:`PersonSize` fitted to the blobs of several foreground masks (None when they cannot support one).

    The blobs are those of :func:`person_boxes` without a size model; blobs cut by the image
    border are left out, and :meth:`PersonSize.fit` sets aside groups and fragments.

    Examples
    --------
    One person, 10 × 30 px, walks across three masks; side by side with another at the end:

    >>> masks = [np.zeros((50, 80), bool) for _ in range(3)]
    >>> masks[0][10:40, 5:15] = masks[1][10:40, 30:40] = masks[2][10:40, 55:75] = True
    >>> fit_person_size(masks, min_area_pixels=20)
    PersonSize(a=0.0, b=30.0, aspect=0.3333333333333333)
    """
    found = []
    shape = None
    for mask in masks:
        mask = _checked_mask(mask)
        if shape is not None and mask.shape != shape:
            raise TrackingError(f"the masks differ in shape: {mask.shape} after {shape}")
        shape = mask.shape
        found.append(person_boxes(mask, None, min_area_pixels=min_area_pixels, opening=opening))
    if shape is None:
        return None
    return PersonSize.fit(np.concatenate(found), shape, border=border, min_boxes=min_boxes)


# -- blobs ------------------------------------------------------------------------------------------
class _Blob:
    """A box, the component labels it is made of, and its pixel count."""

    __slots__ = ("box", "labels", "area")

    def __init__(self, box: np.ndarray, labels: list[int], area: int) -> None:
        self.box, self.labels, self.area = box, labels, area


def _components(mask: np.ndarray, opening: int) -> tuple[np.ndarray, np.ndarray]:
    """The labels of the opened mask's 8-connected components and their stats (x, y, w, h, area)."""
    cv2 = require("cv2")  # OpenCV stays at the edges: out of the import path

    image = mask.view(np.uint8)
    if opening >= 2:
        kernel = np.ones((opening, opening), np.uint8)
        anchor = opening // 2
        # As in foreground_blobs: dilating with the reflected anchor makes a true opening for
        # even kernel sides, and the default border values leave blobs at the edge whole.
        image = cv2.erode(np.ascontiguousarray(image), kernel, anchor=(anchor, anchor))
        reflected = opening - 1 - anchor
        image = cv2.dilate(image, kernel, anchor=(reflected, reflected))
    # Grana's block-based labelling: with stats, three times faster here than OpenCV's default choice.
    count, labels, stats, _ = cv2.connectedComponentsWithStatsWithAlgorithm(
        np.ascontiguousarray(image), 8, cv2.CV_32S, cv2.CCL_BBDT)
    return labels, stats[1:count].astype(np.int64)


def _merge_fragments(blobs: list[_Blob], size_model: PersonSize | None) -> list[_Blob]:
    """Merge pairs of fragments of one person, smallest union first, until no pair qualifies."""
    while len(blobs) >= 2:
        boxes = np.array([b.box for b in blobs], dtype=np.float64)
        areas = np.array([b.area for b in blobs], dtype=np.float64)
        first, second = np.triu_indices(len(blobs), 1)
        a, b = boxes[first], boxes[second]
        left, top = np.minimum(a[:, 0], b[:, 0]), np.minimum(a[:, 1], b[:, 1])
        right = np.maximum(a[:, 0] + a[:, 2], b[:, 0] + b[:, 2])
        bottom = np.maximum(a[:, 1] + a[:, 3], b[:, 1] + b[:, 3])
        union_w, union_h = right - left, bottom - top
        fill = (areas[first] + areas[second]) / (union_w * union_h)
        if size_model is None:
            ok = _stacked(a, b, union_w, union_h)
        else:
            person_w, person_h = _size(size_model, bottom)
            partial = lambda box: (box[:, 3] < _PARTIAL * person_h) | (box[:, 2] < _PARTIAL * person_w)  # noqa: E731
            ok = (union_h <= _MERGED_SIZE * person_h) & (union_w <= _MERGED_SIZE * person_w) \
                & partial(a) & partial(b)
        ok &= fill >= _MERGED_FILL
        if not ok.any():
            break
        pick = np.flatnonzero(ok)[np.argmin((union_w * union_h)[ok])]
        i, j = int(first[pick]), int(second[pick])
        box = np.array([left[pick], top[pick], union_w[pick], union_h[pick]], dtype=np.int64)
        merged = _Blob(box, blobs[i].labels + blobs[j].labels, blobs[i].area + blobs[j].area)
        blobs = [blob for k, blob in enumerate(blobs) if k not in (i, j)] + [merged]
    return blobs


def _stacked(a: np.ndarray, b: np.ndarray, union_w: np.ndarray, union_h: np.ndarray) -> np.ndarray:
    """Without a size model: one blob just above the other, of about its width, their union a tall shape."""
    overlap = np.minimum(a[:, 0] + a[:, 2], b[:, 0] + b[:, 2]) - np.maximum(a[:, 0], b[:, 0])
    gap = np.maximum(a[:, 1], b[:, 1]) - np.minimum(a[:, 1] + a[:, 3], b[:, 1] + b[:, 3])
    narrower = np.minimum(a[:, 2], b[:, 2])
    return (overlap >= 0.5 * narrower) & (gap >= 0) & (gap <= np.maximum(2.0, 0.1 * union_h)) \
        & (union_w <= 1.25 * np.maximum(a[:, 2], b[:, 2])) & (union_h >= 1.5 * union_w)


def _shaped(blob: _Blob, labels: np.ndarray, size_model: PersonSize, split_width: float,
            max_height: float) -> list[np.ndarray]:
    """The boxes of one blob: one per run of feet, each after the tall cut and the width split."""
    x, y, w, h = (int(v) for v in blob.box)
    person_w, person_h = _size(size_model, y + h)
    if w <= _ONE_WIDE * person_w and h <= max_height * person_h:
        return [blob.box]                                  # one person: no room for another beside them
    crop = labels[y:y + h, x:x + w]
    pixels = crop == blob.labels[0] if len(blob.labels) == 1 else np.isin(crop, blob.labels)
    pieces: list[tuple[int, int, int, int]] = []           # in the blob's box, disjoint
    for left, right, foot in _foot_runs(pixels, y, size_model):
        run = _tight(pixels, 0, foot, left, right)
        if run is None:
            continue
        top = run[1]
        person_h = _size(size_model, y + foot)[1]
        parts = [(top, foot)]                              # row ranges of the run
        if foot - top > max_height * person_h:
            cut = foot - int(round(person_h))
            parts = [(cut, foot)]
            rest = _tight(pixels, top, cut, left, right)
            if rest is not None:
                rest_h = _size(size_model, y + rest[1] + rest[3])[1]
                if rest[3] >= _REST_HEIGHT * rest_h:
                    parts.append((top, cut))
        for upper, lower in parts:
            part = _tight(pixels, upper, lower, left, right)
            if part is None:
                continue
            px, py, pw, ph = part
            part_w = _size(size_model, y + py + ph)[0]
            pieces_wide = int(round(pw / part_w))
            if pw < split_width * part_w or pieces_wide < 2:
                pieces.append(part)
                continue
            columns = pixels[py:py + ph, px:px + pw].sum(axis=0).astype(np.float64)
            cuts = [0] + _split_columns(columns, pieces_wide) + [pw]
            for start, stop in zip(cuts[:-1], cuts[1:]):
                piece = _tight(pixels, py, py + ph, px + start, px + stop)
                if piece is not None:
                    pieces.append(piece)
    # A run's head above a nearer person's (cut off as the rest of a tall run) and the rest of
    # that person beside it are two pieces of one person: the fragment merge joins them.
    found = [_Blob(np.array([x + px, y + py, pw, ph], dtype=np.int64), [], int(pixels[py:py + ph, px:px + pw].sum()))
             for px, py, pw, ph in pieces]
    return [piece.box for piece in _merge_fragments(found, size_model)]


def _foot_runs(pixels: np.ndarray, top: int, size_model: PersonSize) -> list[tuple[int, int, int]]:
    """Runs of columns whose lowest pixel is on about one row: ``(first, past-last column, foot row)``.

    A person in front of another has their feet lower in the image: where the lowest pixel
    of the columns steps by more than 8 % of a person's height, one person ends and the
    next begins.  The gaps between a walker's legs (dips of the profile narrower than 30 %
    of a person's width) are filled first, and a run narrower than 40 % of a person's width
    joins the neighbour whose feet are nearer its own (an arm, a bag, a sliver of someone
    hidden).  Rows are in the blob's box.
    """
    height, width = pixels.shape
    filled = pixels.any(axis=0)
    bottom = np.where(filled, height - np.argmax(pixels[::-1], axis=0), 0)
    person_w = _size(size_model, top + height)[0]
    window = max(1, int(_LEG_GAP * person_w)) | 1
    bottom = _closing(bottom, window)
    tolerance = np.maximum(2.0, _FOOT_STEP * _size(size_model, top + bottom)[1])
    steps = np.flatnonzero(np.abs(np.diff(bottom)) > tolerance[1:]) + 1
    edges = [0, *steps.tolist(), width]
    runs = [[a, b, int(bottom[a:b].max())] for a, b in zip(edges[:-1], edges[1:])]
    while len(runs) > 1:
        narrow = [k for k, (a, b, foot) in enumerate(runs)
                  if b - a < _NARROW_RUN * _size(size_model, top + foot)[0]]
        if not narrow:
            break
        k = min(narrow, key=lambda k: runs[k][1] - runs[k][0])
        neighbours = [n for n in (k - 1, k + 1) if 0 <= n < len(runs)]
        n = min(neighbours, key=lambda n: abs(runs[n][2] - runs[k][2]))
        first, second = sorted((k, n))
        runs[first] = [runs[first][0], runs[second][1], max(runs[first][2], runs[second][2])]
        del runs[second]
    return [(a, b, foot) for a, b, foot in runs if foot > 0]


def _closing(profile: np.ndarray, window: int) -> np.ndarray:
    """Grey closing of a 1-D profile (a running max, then a running min): fills dips narrower than ``window``."""
    half = window // 2
    if half == 0 or profile.size < 2:
        return profile
    return _running(_running(profile, half, np.maximum), half, np.minimum)


def _running(profile: np.ndarray, half: int, pick) -> np.ndarray:
    """Running max or min over ``2·half + 1`` neighbours, the ends repeated (windows are a few pixels)."""
    padded = np.concatenate([np.full(half, profile[0]), profile, np.full(half, profile[-1])])
    result = profile.copy()
    for shift in range(2 * half + 1):
        pick(result, padded[shift:shift + profile.size], out=result)
    return result


def _size(size_model: PersonSize, foot):
    """:meth:`PersonSize.expected` without its checks (the rows here are the mask's own): floats for a float."""
    if not isinstance(foot, np.ndarray):
        height = max(size_model.a * float(foot) + size_model.b, 1.0)
        return max(size_model.aspect * height, 1.0), height
    height = np.maximum(size_model.a * foot + size_model.b, 1.0)
    return np.maximum(size_model.aspect * height, 1.0), height


def _split_columns(columns: np.ndarray, pieces: int) -> list[int]:
    """Cut positions that split the columns into ``pieces``: the emptiest column near each even cut."""
    smooth = np.convolve(columns, np.ones(3) / 3, mode="same")
    width = len(columns)
    slack = _SPLIT_SLACK * width / pieces
    cuts = []
    for k in range(1, pieces):
        even = k * width / pieces
        lo, hi = max(1, int(math.floor(even - slack))), min(width - 1, int(math.ceil(even + slack)))
        if hi <= lo:
            cuts.append(int(round(even)))
            continue
        candidates = np.arange(lo, hi + 1)
        # The emptiest column; among equals the one nearest the even cut, so a flat blob splits evenly.
        best = np.lexsort((np.abs(candidates - even), smooth[np.minimum(candidates, width - 1)]))[0]
        cuts.append(int(candidates[best]))
    cuts = sorted(set(min(max(c, 1), width - 1) for c in cuts))
    return cuts


def _tight(pixels: np.ndarray, top: int, bottom: int, left: int, right: int) -> tuple[int, int, int, int] | None:
    """The bounding box (x, y, w, h), in the blob's box, of the pixels in the given rows and columns."""
    region = pixels[top:bottom, left:right]
    rows = np.flatnonzero(region.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(region.any(axis=0))
    return left + int(cols[0]), top + int(rows[0]), int(cols[-1] - cols[0] + 1), int(rows[-1] - rows[0] + 1)


# -- checks -----------------------------------------------------------------------------------------
def _checked_mask(mask) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.ndim != 2 or mask.dtype != np.bool_ or mask.size == 0:
        raise TrackingError(f"the foreground mask must be a non-empty 2-D bool array, got shape {mask.shape} "
                            f"dtype {mask.dtype} (use mask > 0 for a 0/255 image)")
    return mask


def _number(name: str, value, *, minimum: float | None = None, above: float | None = None) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or (minimum is not None and value < minimum) \
            or (above is not None and value <= above):
        bound = f">= {minimum:g}" if minimum is not None else f"> {above:g}"
        raise TrackingError(f"{name} must be a finite number {bound}, got {value!r}")
    return float(value)

