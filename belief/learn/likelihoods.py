"""Mass functions from a likelihood (Shafer's consonant mass function) and from counts (imprecise Dirichlet model)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from belief.frame import Frame
from belief.learn.inputs import LearningDataError, LearningOptionError, check_number, hypothesis_names, is_real
from belief.mass import MassFunction

__all__ = ["consonant_from_likelihood", "idm_from_counts"]


def _checked_values(values: Mapping, what: str, frame) -> tuple[tuple[str, ...], np.ndarray]:
    """Hypothesis names and finite non-negative numbers of a mapping ``{label: value}``, in frame order.

    Without a frame the labels are the frame, in the mapping's order; with one, a hypothesis the
    mapping leaves out has the value 0.
    """
    if not isinstance(values, Mapping):
        raise LearningDataError(f"{what} must be a mapping {{label: number}}, got {type(values).__name__}")
    if not values and frame is None:
        raise LearningDataError(f"{what} is empty: give at least one label")
    labels = list(values)
    names = hypothesis_names(labels)
    one = what[:-1] if what.endswith("s") else what
    given = {}
    for label, name in zip(labels, names):
        value = check_number(values[label], f"the {one} of {label!r}")
        if not math.isfinite(value):
            raise LearningDataError(f"the value {value!r} of {label!r} in {what} is not a finite number")
        if value < 0:
            raise LearningDataError(f"the value {value!r} of {label!r} in {what} is negative")
        given[name] = value
    if frame is None:
        return names, np.array([given[name] for name in names])
    hypotheses = (frame if isinstance(frame, Frame) else Frame(list(frame))).hypotheses
    unknown = [name for name in names if name not in hypotheses]
    if unknown:
        raise LearningDataError(f"{what} name {', '.join(map(repr, unknown))}, which the frame "
                                f"({', '.join(hypotheses)}) does not have")
    return hypotheses, np.array([given.get(name, 0.0) for name in hypotheses])


def consonant_from_likelihood(likelihood: Mapping[Any, float], frame=None) -> MassFunction:
    """Shafer's consonant mass function of a likelihood: pl({θ}) = L(θ) / max L.

    Sort the hypotheses by decreasing likelihood, θ_(1), …, θ_(n), and let π_j = L(θ_(j)) / L(θ_(1)).
    The focal elements are the nested sets A_j = {θ_(1), …, θ_(j)}, with m(A_j) = π_j − π_(j+1)
    (π_(n+1) = 0); equal likelihoods give no mass to the sets between them.  The plausibility of a
    set is the largest π of its members (Shafer 1976, ch. 10).

    Parameters
    ----------
    likelihood : mapping of label to float
        L(θ) ≥ 0 for each hypothesis, in any scale (only ratios matter); at least one positive.
        The labels are written as strings.
    frame : Frame or sequence of str, optional
        The frame of the result, to match another source's (e.g. :attr:`EKNN.frame_`); a hypothesis
        that ``likelihood`` leaves out has likelihood 0.  By default the labels, in the mapping's order.

    Returns
    -------
    MassFunction
        Under Shafer's model of the labels.  A hypothesis of likelihood 0 lies in no focal element.

    Raises
    ------
    LearningDataError
        No labels, a value that is not a number (or a boolean), NaN, infinite or negative, all
        values zero, or a label that ``frame`` does not have.

    Examples
    --------
    >>> m = consonant_from_likelihood({"a": 0.8, "b": 0.4, "c": 0.2})
    >>> m
    MassFunction({'a': 0.5, 'a|b': 0.25, 'a|b|c': 0.25}, frame=['a', 'b', 'c'])
    >>> m.pls(["a", "b", "c"])
    array([1.  , 0.5 , 0.25])
    >>> consonant_from_likelihood({"b": 1.0}, frame=["a", "b"]).to_mapping()
    {'b': 1.0}
    """
    names, values = _checked_values(likelihood, "likelihoods", frame)
    top = values.max()
    if top <= 0:
        raise LearningDataError("every likelihood is zero: a consonant mass function needs one positive value")
    plausibility = values / top
    # Decreasing plausibility, ties kept in the mapping's order, so that the result does not depend on sorting.
    order = np.argsort(-plausibility, kind="stable")
    ranked = plausibility[order]
    drops = ranked - np.append(ranked[1:], 0.0)
    masses: dict[str, float] = {}
    for j, drop in enumerate(drops.tolist()):
        if drop > 0:
            masses["|".join(names[i] for i in order[:j + 1])] = drop
    return MassFunction(masses, frame=list(names), model="shafer")


def idm_from_counts(counts: Mapping[Any, float], s: float = 2.0, frame=None) -> MassFunction:
    """The imprecise Dirichlet model of counts: m({θ_i}) = n_i / (N + s), m(Θ) = s / (N + s).

    Its belief and plausibility of θ_i are Walley's lower and upper probabilities n_i / (N + s) and
    (n_i + s) / (N + s), with N = Σ n_i; s sets how fast the interval shrinks as counts accrue
    (Walley suggests 1 or 2).

    Parameters
    ----------
    counts : mapping of label to float
        n_i ≥ 0 per hypothesis (fractional counts are allowed), the labels written as strings.
        All zero gives the vacuous mass function.
    s : float
        The prior strength, s > 0.
    frame : Frame or sequence of str, optional
        The frame of the result; a hypothesis that ``counts`` leaves out has count 0.  By default
        the labels, in the mapping's order.

    Returns
    -------
    MassFunction
        Under Shafer's model of the labels.

    Raises
    ------
    LearningDataError
        No labels, a count that is not a number, NaN, infinite or negative, or a label that
        ``frame`` does not have.
    LearningOptionError
        s not a finite number above 0.

    Examples
    --------
    >>> m = idm_from_counts({"red": 6, "blue": 2, "green": 0})
    >>> m
    MassFunction({'red': 0.6, 'blue': 0.2, 'red|blue|green': 0.2}, frame=['red', 'blue', 'green'])
    >>> m.bel("red"), m.pls("red")
    (0.6, 0.8)
    >>> idm_from_counts({"blue": 3}, s=1.0, frame=["red", "blue", "green"]).to_mapping()
    {'blue': 0.75, 'red|blue|green': 0.25}
    """
    if not is_real(s) or not (math.isfinite(s) and s > 0):
        raise LearningOptionError(f"s must be a finite number above 0, got {s!r}")
    names, values = _checked_values(counts, "counts", frame)
    scale = float(values.sum()) + float(s)
    masses = {name: value / scale for name, value in zip(names, values.tolist()) if value > 0}
    whole = "|".join(names)
    masses[whole] = masses.get(whole, 0.0) + float(s) / scale
    return MassFunction(masses, frame=list(names), model="shafer")
