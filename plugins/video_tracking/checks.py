"""Checks of setting values at the plugin's boundary, with messages that name the field.

Every settings dataclass of the plugin (``TrackerConfig``, ``ColourConfig``, ``MotionConfig``
…) checks its fields once, in ``__post_init__``, with these helpers; the code behind trusts
them.  A bad value raises :class:`~belief_tracking.errors.TrackingError` (a
:class:`belief.errors.BeliefError`), never a bare ``ValueError``, so the command line turns
it into one line.

Examples
--------
>>> number("MotionConfig.sigma_pos", 3, minimum=0.0)
3.0
>>> integer("TrackerConfig.particles", 0, minimum=1)
Traceback (most recent call last):
...
belief_tracking.errors.TrackingError: TrackerConfig.particles must be an integer >= 1, got 0
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence

import numpy as np

from .errors import TrackingError
from .limits import shown

__all__ = ["number", "integer", "choice", "flag", "fraction", "instance", "image_shape"]


def number(name: str, value: object, *, minimum: float | None = None, positive: bool = False,
           maximum: float | None = None) -> float:
    """``value`` as a finite float within the bounds (``positive``: strictly above 0)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TrackingError(f"{name} must be a number, got {shown(value)}")
    result = float(value)
    if not math.isfinite(result):
        raise TrackingError(f"{name} must be finite, got {shown(value)}")
    if positive and result <= 0:
        raise TrackingError(f"{name} must be positive, got {shown(value)}")
    if minimum is not None and result < minimum:
        raise TrackingError(f"{name} must be at least {minimum:g}, got {shown(value)}")
    if maximum is not None and result > maximum:
        raise TrackingError(f"{name} must be at most {maximum:g}, got {shown(value)}")
    return result


def integer(name: str, value: object, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """``value`` as an int (a bool is refused) within the bounds."""
    if isinstance(value, (bool, np.bool_)):
        raise TrackingError(f"{name} must be an integer, got {shown(value)}")
    try:
        result = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise TrackingError(f"{name} must be an integer, got {shown(value)}") from None
    if minimum is not None and result < minimum:
        raise TrackingError(f"{name} must be an integer >= {minimum}, got {shown(value)}")
    if maximum is not None and result > maximum:
        raise TrackingError(f"{name} must be an integer <= {maximum}, got {shown(value)}")
    return int(result)


def fraction(name: str, value: object, *, allow_zero: bool = True) -> float:
    """A number in [0, 1] (in (0, 1] without ``allow_zero``)."""
    interval = "[0, 1]" if allow_zero else "(0, 1]"
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or not 0 <= value <= 1 or (value == 0 and not allow_zero):
        raise TrackingError(f"{name} must be a number in {interval}, got {shown(value)}")
    return float(value)


def choice(name: str, value: object, choices: Sequence[str]) -> str:
    """One of ``choices``; the message lists them."""
    if not isinstance(value, str) or value not in choices:
        raise TrackingError(f"{name} must be one of {', '.join(choices)}, got {shown(value)}")
    return value


def flag(name: str, value: object) -> bool:
    """True or False (numpy booleans too; not 0 or 1)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TrackingError(f"{name} must be True or False, got {shown(value)}")
    return bool(value)


def instance(name: str, value: object, kind: type) -> object:
    """``value`` if it is a ``kind`` (a settings dataclass), else an error naming both."""
    if not isinstance(value, kind):
        article = "an" if kind.__name__[0] in "AEIOU" else "a"
        raise TrackingError(f"{name} must be {article} {kind.__name__}, got {type(value).__name__}")
    return value


def image_shape(shape) -> tuple[int, int]:
    """(H, W) of an image shape (H, W) or (H, W, C) with positive H and W."""
    try:
        dims = tuple(shape)
    except TypeError:
        dims = ()
    if len(dims) not in (2, 3) or any(isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 1
                                       for d in dims[:2]):
        raise TrackingError(f"image_shape must be (H, W) or (H, W, C) with positive H and W, got {shown(shape)}")
    return int(dims[0]), int(dims[1])
