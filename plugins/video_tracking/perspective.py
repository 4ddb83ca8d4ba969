"""Box size from the image row: a ground-plane perspective model fitted to the targets' boxes.

With a static camera looking down on a flat ground, a person's height in the image grows
linearly with the row of their feet, h = a·foot + b (the row where h would vanish is the
horizon).  Fitted to the boxes the targets are born with, this model gives every particle
its window size from its own position, so the window shrinks as a target walks away from
the camera without a scale state that the cues would have to estimate.  (An appearance cue
cannot estimate scale well: the foreground-masked colour of SPEC B.4 scores ρ ≤ √F, and a
window inside the silhouette has F = 1, so it rewards shrinking windows.)

The scale of a particle of target J at centre row ``cy`` is h(cy) / h(cy_J), where cy_J is
the centre row of J's birth box: J keeps its own size and aspect ratio at birth, and follows
the model's relative change.

:class:`PersonSize` is the same ground-plane model with a width, w = aspect·h, fitted robustly
(Theil–Sen, then a refit on the boxes that agree with it) to rough boxes: the foreground
blobs of the frames when there is no detector, of which some are merged groups, fragments
or people cut by the image border.  It says how large a person whose feet are on a given
row should be, so that a blob as wide as two people can be split, and a box that no person
could fill can be cut.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .boxes import check_boxes
from . import checks
from .errors import TrackingError

__all__ = ["PerspectiveScale", "PersonSize", "MAX_SCALE_CHANGE"]

#: The model may change a box's size by at most this factor either way.
MAX_SCALE_CHANGE = 4.0


@dataclass(frozen=True)
class PerspectiveScale:
    """Box height h = a·foot + b as a function of the foot row (0-based pixels).

    Attributes
    ----------
    a, b : float
        Slope and intercept; ``0 ≤ a < 2`` (a box whose centre moves down one row has its
        foot move down 1 + a/2 rows).

    Examples
    --------
    Three people: 40 px tall with feet at row 100, 60 px at 200, 80 px at 300:

    >>> model = PerspectiveScale.fit([[0, 60, 15, 40], [50, 140, 20, 60], [90, 220, 30, 80]])
    >>> round(model.a, 3), round(model.b, 3)
    (0.2, 20.0)
    >>> float(model.height(np.array([170.0]))[0])            # centre row 170: feet at 200
    60.0
    >>> round(float(model.log_scale(np.array([260.0]), 170.0)[0]), 4) == round(math.log(80 / 60), 4)
    True
    >>> PerspectiveScale.fit([[0, 60, 15, 40]]) is None       # one box: no model
    True
    """

    a: float
    b: float

    @classmethod
    def fit(cls, boxes, min_spread: float = 2.0) -> PerspectiveScale | None:
        """Least-squares fit to boxes ``(x, y, w, h)``; None when the boxes cannot support one.

        Parameters
        ----------
        boxes : array_like, shape (n, 4)
            Top-left corner and size of each box, in pixels.
        min_spread : float
            The foot rows must have a standard deviation of at least this many pixels.

        Returns
        -------
        PerspectiveScale or None
            None for fewer than two boxes, feet on (nearly) one row, or a fit that is not a
            camera looking down on a ground plane (a < 0 or a ≥ 2, or a height ≤ 0 at a
            box's own row).
        """
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        if boxes.shape[0] < 2:
            return None
        foot = boxes[:, 1] + boxes[:, 3]
        if foot.std() < min_spread:
            return None
        a, b = np.polyfit(foot, boxes[:, 3], 1)
        if not (math.isfinite(a) and math.isfinite(b)) or not 0.0 <= a < 2.0:
            return None
        if ((a * foot + b) <= 0).any():
            return None
        return cls(float(a), float(b))

    def height(self, cy: np.ndarray) -> np.ndarray:
        """Box height of a box centred on row(s) ``cy``: h = (a·cy + b) / (1 − a/2), at least 1 px."""
        return np.maximum((self.a * np.asarray(cy, dtype=np.float64) + self.b) / (1.0 - self.a / 2.0), 1.0)

    def log_scale(self, cy: np.ndarray, reference_cy: float) -> np.ndarray:
        """log(h(cy) / h(reference_cy)), clipped to ±log :data:`MAX_SCALE_CHANGE`; shape of ``cy``."""
        ratio = np.log(self.height(cy)) - math.log(float(self.height(np.array([reference_cy]))[0]))
        limit = math.log(MAX_SCALE_CHANGE)
        return np.clip(ratio, -limit, limit)


#: A person's box is at least this much taller than wide; wider boxes are groups side by side
#: (or shadows) and do not enter the fit.
_MIN_ELONGATION = 1.4

#: After the first fit, boxes whose height is within this factor of the fitted one are refitted.
_INLIER_FACTOR = 1.25

#: Theil–Sen looks at every pair of boxes: beyond this many boxes, an even subset of them.
_MAX_FIT_BOXES = 300


@dataclass(frozen=True)
class PersonSize:
    """A person's expected box size from their foot row: h = a·foot + b and w = aspect·h.

    Attributes
    ----------
    a, b : float
        Height model in pixels of a person whose feet are on 0-based row ``foot``;
        ``0 <= a < 2``.  ``a = 0`` is a constant size (every person at about one row).
    aspect : float
        Width over height of a person's box, positive.

    Examples
    --------
    People 2.5 times as tall as wide, 40 px tall with feet at row 100 and 80 px at row 300:

    >>> size = PersonSize(0.2, 20.0, 0.4)
    >>> w, h = size.expected([100, 300])
    >>> w.tolist(), h.tolist()
    ([16.0, 32.0], [40.0, 80.0])
    >>> size.plausible([[0, 60, 16, 40], [0, 160, 50, 40], [0, 200, 28, 100]]).tolist()
    [True, False, True]
    """

    a: float
    b: float
    aspect: float

    def __post_init__(self) -> None:
        for name in ("a", "b", "aspect"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                    or not math.isfinite(value):
                raise TrackingError(f"PersonSize.{name} must be a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))
        if not 0.0 <= self.a < 2.0:
            raise TrackingError(f"PersonSize.a must lie in [0, 2), got {self.a!r}")
        if self.aspect <= 0:
            raise TrackingError(f"PersonSize.aspect must be positive, got {self.aspect!r}")

    @classmethod
    def fit(cls, boxes, image_shape: tuple[int, ...] | None = None, *, border: float = 2.0, min_boxes: int = 3,
            min_spread: float = 10.0) -> PersonSize | None:
        """The model of candidate boxes ``(x, y, w, h)``, robust to merged groups and fragments.

        Parameters
        ----------
        boxes : array_like, shape (n, 4)
            0-based candidate boxes: detections, or the foreground blobs of several frames.
        image_shape : (int, int) or (int, int, int), optional
            (H, W) of the image: boxes within ``border`` px of an edge are left out (the
            edge cuts the person).
        border : float
            See ``image_shape``.
        min_boxes : int
            Fewer usable boxes than this give None.
        min_spread : float
            When the foot rows of the usable boxes span fewer pixels than this (10th to
            90th percentile), no slope can be told and the size is constant (``a = 0``).

        Returns
        -------
        PersonSize or None

        Notes
        -----
        Boxes wider than 1 / 1.4 of their height are left out (groups side by side,
        shadows).  The slope is the median of the slopes between pairs of boxes and the
        intercept the median of the rest (Theil–Sen, which ignores up to 29 % of wild boxes);
        it is then fitted again on the boxes whose height is within a factor 1.25 of the
        first fit.  The aspect is the median width over height of those boxes.  A slope
        outside [0, 2), or a height that would vanish at a box's own row, gives the
        constant model.

        Raises
        ------
        TrackingError
            If the boxes are not finite (n, 4) with positive sizes, or a setting is invalid.

        Examples
        --------
        Ten people on the model h = 0.25·foot + 10, w = 0.4·h, a group of two side by side
        and a 10 px fragment:

        >>> feet = np.arange(80, 240, 16.0)
        >>> heights = 0.25 * feet + 10
        >>> people = np.column_stack([20 * np.arange(10), feet - heights, 0.4 * heights, heights])
        >>> extra = [[50, 100, 40, 30], [90, 200, 12, 10]]
        >>> size = PersonSize.fit(np.vstack([people, extra]))
        >>> round(size.a, 3), round(size.b, 3), round(size.aspect, 3)
        (0.25, 10.0, 0.4)
        >>> size = PersonSize.fit([[0, 50, 10, 25], [40, 50, 14, 27], [80, 51, 12, 26]])   # one row
        >>> size.a, size.b, round(size.aspect, 3)
        (0.0, 26.0, 0.462)
        """
        boxes = check_boxes(boxes, "person boxes").reshape(-1, 4)
        if isinstance(min_boxes, bool) or not isinstance(min_boxes, (int, np.integer)) or min_boxes < 2:
            raise TrackingError(f"min_boxes must be an integer >= 2, got {min_boxes!r}")
        for name, value in (("border", border), ("min_spread", min_spread)):
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                    or not math.isfinite(value) or value < 0:
                raise TrackingError(f"{name} must be a finite number >= 0, got {value!r}")
        keep = boxes[:, 3] >= _MIN_ELONGATION * boxes[:, 2]
        if image_shape is not None:
            height, width = checks.image_shape(image_shape)
            keep &= (boxes[:, 0] >= border) & (boxes[:, 1] >= border) \
                & (boxes[:, 0] + boxes[:, 2] <= width - border) & (boxes[:, 1] + boxes[:, 3] <= height - border)
        boxes = boxes[keep]
        if len(boxes) < min_boxes:
            return None
        if len(boxes) > _MAX_FIT_BOXES:
            boxes = boxes[np.linspace(0, len(boxes) - 1, _MAX_FIT_BOXES).round().astype(np.intp)]
        foot, heights = boxes[:, 1] + boxes[:, 3], boxes[:, 3]
        sloped = np.subtract(*np.percentile(foot, [90, 10])) >= min_spread
        a, b = _theil_sen(foot, heights) if sloped else (0.0, float(np.median(heights)))
        if not _is_ground_plane(a, b, foot):
            a, b = 0.0, float(np.median(heights))
        inliers = np.abs(np.log(heights / np.maximum(a * foot + b, 1e-9))) <= math.log(_INLIER_FACTOR)
        if np.count_nonzero(inliers) >= min_boxes:
            if sloped and a > 0:
                refit = _theil_sen(foot[inliers], heights[inliers])
                if _is_ground_plane(*refit, foot[inliers]):
                    a, b = refit
            else:
                b = float(np.median(heights[inliers]))
        else:
            inliers = np.ones(len(boxes), dtype=bool)
        aspect = float(np.median(boxes[inliers, 2] / heights[inliers]))
        return cls(a, b, aspect)

    def expected(self, foot_rows) -> tuple[np.ndarray, np.ndarray]:
        """Expected width and height of a person whose feet are on ``foot_rows`` (at least 1 px each).

        Raises
        ------
        TrackingError
            If a foot row is not a finite number.
        """
        foot = np.asarray(foot_rows, dtype=np.float64) if _numeric(foot_rows) else None
        if foot is None or not np.isfinite(foot).all():
            raise TrackingError(f"foot rows must be finite numbers, got {foot_rows!r}")
        heights = np.maximum(self.a * foot + self.b, 1.0)
        return np.maximum(self.aspect * heights, 1.0), heights

    def plausible(self, boxes, factor: float = 1.5) -> np.ndarray:
        """Whether each box ``(x, y, w, h)`` is within ``factor`` of the expected size at its foot row, both ways.

        Raises
        ------
        TrackingError
            If the boxes are not finite (n, 4) with positive sizes, or ``factor`` < 1.
        """
        boxes = check_boxes(boxes, "boxes").reshape(-1, 4)
        if isinstance(factor, bool) or not isinstance(factor, (int, float, np.integer, np.floating)) \
                or not math.isfinite(factor) or factor < 1:
            raise TrackingError(f"factor must be a finite number >= 1, got {factor!r}")
        widths, heights = self.expected(boxes[:, 1] + boxes[:, 3])
        ratio_w, ratio_h = boxes[:, 2] / widths, boxes[:, 3] / heights
        return (ratio_w <= factor) & (ratio_w >= 1 / factor) & (ratio_h <= factor) & (ratio_h >= 1 / factor)

    @property
    def scale(self) -> PerspectiveScale:
        """The height model as a :class:`PerspectiveScale`, for the particles' window sizes."""
        return PerspectiveScale(self.a, self.b)


def _numeric(values) -> bool:
    try:
        array = np.asarray(values)
    except (TypeError, ValueError):
        return False
    return array.dtype.kind in "iuf"



def _theil_sen(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Median of the pairwise slopes, then the median intercept (pairs less than a pixel apart in x skipped)."""
    first, second = np.triu_indices(len(x), 1)
    dx = x[second] - x[first]
    apart = np.abs(dx) >= 1.0
    if not apart.any():
        return 0.0, float(np.median(y))
    a = float(np.median((y[second] - y[first])[apart] / dx[apart]))
    return a, float(np.median(y - a * x))


def _is_ground_plane(a: float, b: float, foot: np.ndarray) -> bool:
    """A camera looking down on a flat ground: 0 <= a < 2 and a positive height at every given foot row."""
    return math.isfinite(a) and math.isfinite(b) and 0.0 <= a < 2.0 and bool(((a * foot + b) > 0).all())
