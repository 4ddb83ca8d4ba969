"""Axis-aligned boxes ``(x, y, w, h)``: the one check, overlaps and centres of the plugin.

A box is the continuous rectangle [x, x + w) × [y, y + h) in pixel coordinates, with
``(x, y)`` the top-left corner.  Inside the plugin boxes are 0-based (pixel (column i,
row j) covers [i, i + 1) × [j, j + 1)); MOTChallenge files are 1-based, and the readers
and writers convert at the file boundary.

Every module that takes boxes from a caller checks them here (:func:`check_boxes`), and
every overlap is :func:`iou`, or :func:`checked_iou` on arrays checked already (the CLEAR MOT
evaluation turns it into the distance 1 − IoU, HOTA takes it as the similarity).
"""

from __future__ import annotations

import numpy as np

from .errors import TrackingError

__all__ = ["check_boxes", "iou", "checked_iou", "intersections", "box_centres", "pixel_ranges"]


def check_boxes(boxes, what: str = "boxes", *, positive: bool = True, image_shape: tuple[int, int] | None = None,
                error: type[TrackingError] = TrackingError) -> np.ndarray:
    """``boxes`` as a float (n, 4) array, or an error that names ``what`` and the problem.

    Parameters
    ----------
    boxes : array_like, shape (n, 4)
        ``x, y, w, h`` per box.  An empty list is (0, 4).
    what : str
        How the message names the boxes ("ground-truth boxes", "the birth box of target 3").
    positive : bool
        Require positive widths and heights (else non-negative ones are accepted).
    image_shape : (int, int), optional
        (H, W): every box must overlap the image.
    error : type
        The :class:`~belief_tracking.errors.TrackingError` subclass to raise.

    Returns
    -------
    ndarray of float64, shape (n, 4)
        A new array.

    Raises
    ------
    TrackingError
        (or ``error``) for a wrong shape, a value that is not finite, a bad size, or a box
        outside the image.

    Examples
    --------
    >>> check_boxes([[10, 20, 8, 16]])
    array([[10., 20.,  8., 16.]])
    >>> check_boxes([[0, 0, 0, 5]], "track boxes")
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: track boxes: box 0 has width 0 and height 5; both must be positive
    >>> check_boxes([[500, 10, 10, 10]], image_shape=(240, 320))
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: boxes: box 0 (x=500, y=10, w=10, h=10) lies outside the 320x240 image
    """
    try:
        array = np.array(boxes, dtype=np.float64)
    except (TypeError, ValueError):
        raise error(f"{what}: boxes must be numbers x, y, w, h, got {boxes!r}") from None
    if array.size == 0:
        return array.reshape(0, 4)
    if array.ndim != 2 or array.shape[1] != 4:
        raise error(f"{what}: boxes must have shape (n, 4) (x, y, w, h), got {array.shape}")
    finite = np.isfinite(array).all(axis=1)
    if not finite.all():
        index = int(np.argmin(finite))
        raise error(f"{what}: box {index} has a value that is not finite: {array[index].tolist()}")
    sizes = array[:, 2:]
    bad = (sizes <= 0).any(axis=1) if positive else (sizes < 0).any(axis=1)
    if bad.any():
        index = int(np.argmax(bad))
        w, h = sizes[index]
        wanted = "positive" if positive else "non-negative"
        raise error(f"{what}: box {index} has width {w:g} and height {h:g}; both must be {wanted}")
    if image_shape is not None:
        height, width = image_shape
        outside = (array[:, 0] >= width) | (array[:, 1] >= height) | (array[:, 0] + array[:, 2] <= 0) \
            | (array[:, 1] + array[:, 3] <= 0)
        if outside.any():
            index = int(np.argmax(outside))
            x, y, w, h = array[index]
            raise error(f"{what}: box {index} (x={x:g}, y={y:g}, w={w:g}, h={h:g}) lies outside the "
                        f"{width}x{height} image")
    return array


def intersections(boxes_a: np.ndarray, boxes_b: np.ndarray) -> np.ndarray:
    """Areas of the pairwise intersections of two checked box arrays, shape (n, m)."""
    left = np.maximum(boxes_a[:, None, 0], boxes_b[None, :, 0])
    top = np.maximum(boxes_a[:, None, 1], boxes_b[None, :, 1])
    right = np.minimum(boxes_a[:, None, 0] + boxes_a[:, None, 2], boxes_b[None, :, 0] + boxes_b[None, :, 2])
    bottom = np.minimum(boxes_a[:, None, 1] + boxes_a[:, None, 3], boxes_b[None, :, 1] + boxes_b[None, :, 3])
    return np.maximum(right - left, 0.0) * np.maximum(bottom - top, 0.0)


def iou(boxes_a, boxes_b) -> np.ndarray:
    """Intersection over union of every pair of boxes.

    Parameters
    ----------
    boxes_a : array_like, shape (n, 4)
    boxes_b : array_like, shape (m, 4)
        ``(x, y, w, h)`` boxes with non-negative sizes.

    Returns
    -------
    ndarray of float64, shape (n, m)
        Area of the intersection over area of the union; 0 where the union has no area
        (two empty boxes), so never NaN.  The full (n, m) shape also when n or m is 0.

    Examples
    --------
    >>> iou([[0, 0, 2, 2]], [[1, 0, 2, 2], [0, 0, 2, 2], [5, 5, 1, 1], [0, 0, 4, 4]]).tolist()
    [[0.3333333333333333, 1.0, 0.0, 0.25]]
    >>> iou(np.zeros((0, 4)), [[0, 0, 1, 1]]).shape
    (0, 1)
    """
    return checked_iou(check_boxes(boxes_a, "boxes", positive=False), check_boxes(boxes_b, "boxes", positive=False))


def checked_iou(boxes_a: np.ndarray, boxes_b: np.ndarray) -> np.ndarray:
    """:func:`iou` of two arrays that :func:`check_boxes` has checked already: the same floats, without the checks.

    The scoring calls it once per frame, so that a file of many frames is checked once
    rather than frame by frame.

    Parameters
    ----------
    boxes_a : ndarray of float64, shape (n, 4)
    boxes_b : ndarray of float64, shape (m, 4)
        ``(x, y, w, h)`` boxes with non-negative sizes.

    Returns
    -------
    ndarray of float64, shape (n, m)

    Examples
    --------
    >>> checked_iou(np.array([[0.0, 0.0, 2.0, 2.0]]), np.array([[1.0, 0.0, 2.0, 2.0]])).tolist()
    [[0.3333333333333333]]
    """
    inter = intersections(boxes_a, boxes_b)
    union = (boxes_a[:, None, 2] * boxes_a[:, None, 3] + boxes_b[None, :, 2] * boxes_b[None, :, 3]) - inter
    return np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)


def box_centres(boxes) -> np.ndarray:
    """Centres ``(x + w/2, y + h/2)`` of boxes ``(x, y, w, h)``, shape (n, 2).

    Examples
    --------
    >>> box_centres([[10, 20, 6, 8]])
    array([[13., 24.]])
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return boxes[:, :2] + boxes[:, 2:] / 2.0


def pixel_ranges(boxes: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """First and one-past-last pixel columns and rows of each box, clipped to the image of ``shape`` (H, W).

    Pixel (i, j) is in a box when its centre (i + 1/2, j + 1/2) is.

    Examples
    --------
    >>> [r.tolist() for r in pixel_ranges(np.array([[1.0, 1.0, 2.0, 2.0], [5.0, 3.0, 4.0, 4.0]]), (4, 6))]
    [[1, 5], [3, 6], [1, 3], [3, 4]]
    """
    height, width = shape
    # Pixel i is in [x, x + w) when its centre i + 1/2 is: i from ceil(x - 1/2) to ceil(x + w - 1/2) - 1.
    x0 = np.clip(np.ceil(boxes[:, 0] - 0.5), 0, width).astype(np.intp)
    x1 = np.clip(np.ceil(boxes[:, 0] + boxes[:, 2] - 0.5), 0, width).astype(np.intp)
    y0 = np.clip(np.ceil(boxes[:, 1] - 0.5), 0, height).astype(np.intp)
    y1 = np.clip(np.ceil(boxes[:, 1] + boxes[:, 3] - 0.5), 0, height).astype(np.intp)
    return x0, np.maximum(x1, x0), y0, np.maximum(y1, y0)
