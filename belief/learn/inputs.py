"""The checks of :mod:`belief.learn`: its errors, and the inputs turned into arrays and hypothesis names."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from belief.errors import BeliefError, FrameError
from belief.frame import Frame

__all__ = ["LearningDataError", "LearningOptionError", "NotFittedError", "check_rows", "hypothesis_names",
           "is_integer", "is_real", "check_number"]


class LearningDataError(BeliefError, ValueError):
    """Data given to :mod:`belief.learn` are malformed: training or query rows, labels, likelihoods or counts."""

    __module__ = "belief.learn"             # raised and documented as belief.learn.<name>, where it is exported


class LearningOptionError(BeliefError, ValueError):
    """A parameter of :mod:`belief.learn` is out of its range (k, α, γ, λ, s, the neighbour search)."""

    __module__ = "belief.learn"             # raised and documented as belief.learn.<name>, where it is exported


class NotFittedError(BeliefError, ValueError, AttributeError):
    """A classifier is asked for predictions before :meth:`EKNN.fit` has run."""

    __module__ = "belief.learn"             # raised and documented as belief.learn.<name>, where it is exported


def check_rows(X, what: str, n_features: int | None = None) -> np.ndarray:
    """``X`` as a finite float array of shape (N, p), or a :class:`LearningDataError` that says what is wrong."""
    try:
        array = np.asarray(X, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise LearningDataError(f"{what} must be an array of numbers of shape (N, p): {err}") from None
    if np.asarray(X).dtype == bool:
        raise LearningDataError(f"{what} must hold numbers, not booleans")
    if array.ndim != 2:
        raise LearningDataError(f"{what} must have shape (N, p), one row per sample, got shape {array.shape}")
    if n_features is not None and array.shape[1] != n_features:
        raise LearningDataError(f"{what} has {array.shape[1]} features, but the classifier was fitted on {n_features}")
    if array.shape[1] == 0:
        raise LearningDataError(f"{what} has no features (shape {array.shape})")
    bad = ~np.isfinite(array)
    if bad.any():
        row, col = map(int, np.argwhere(bad)[0])
        raise LearningDataError(f"{what} holds {float(array[row, col])!r} in row {row}, feature {col}; "
                                "every value must be a finite number")
    return array


def hypothesis_names(labels) -> tuple[str, ...]:
    """The labels written as hypothesis names, refused when two coincide or one cannot name a hypothesis."""
    names = tuple(str(label) for label in labels)
    if len(set(names)) != len(names):
        seen: dict[str, Any] = {}
        for label, name in zip(labels, names):
            if name in seen:
                raise LearningDataError(f"the labels {seen[name]!r} and {label!r} are both written {name!r}; "
                                        "each label must have a name of its own")
            seen[name] = label
    for label, name in zip(labels, names):
        try:
            Frame([name])
        except FrameError as err:
            raise LearningDataError(f"the label {label!r} cannot name a hypothesis: {err}") from None
    return names


def is_integer(value) -> bool:
    """An int or numpy integer, not a boolean."""
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def is_real(value) -> bool:
    """A real number (int, float, numpy number), not a boolean and not a string."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def check_number(value, what: str) -> float:
    """A real number (not a boolean, not a string) as a float."""
    if not is_real(value):
        raise LearningDataError(f"{what} must be a number, got {value!r}")
    return float(value)
