"""Scoring every particle with every cue, and the likeness of windows to their targets' templates."""

from __future__ import annotations

import numpy as np

from ..errors import TrackingError
from .base import log_gaussian
from .colour import ColourCue
from .histograms import bhattacharyya
from .observation import Observation, checked_particles
from .similarity import window_similarities

__all__ = ["score_cues", "template_similarity", "sampling_groups"]


def score_cues(cues, obs: Observation, states: np.ndarray, owner: np.ndarray) -> tuple[np.ndarray, ...]:
    """Every cue's ``log_likelihoods(obs, states, owner)``, in the order of ``cues``.

    Colour cues (:class:`ColourCue` and the subclasses that keep its scoring) that read the
    same bin image with the same bins and sample grid place the sample points of every box
    once between them, which is most of their cost: the colour and foreground cues of the
    default tracker share it.  The scores are those of each cue on its own.

    Parameters
    ----------
    cues : sequence of Cue
    obs : Observation
    states : ndarray, shape (P, 5)
    owner : ndarray of int, shape (P,)

    Returns
    -------
    tuple of ndarray, each of shape (P, τ + 1) (or what the cue returns)

    Examples
    --------
    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> image[20:40, 30:40] = (0, 0, 255)
    >>> mask = image[..., 2] == 255
    >>> from belief_tracking.cues import ColourConfig, ForegroundColourCue
    >>> config = ColourConfig(samples=(6, 12))
    >>> colour, foreground = ColourCue(config), ForegroundColourCue(config)
    >>> templates = {cue.name: cue.build_templates(image, np.array([[30, 20, 10, 20]]), foreground=mask)
    ...              for cue in (colour, foreground)}
    >>> obs = Observation(image, mask, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)), templates=templates)
    >>> states, owner = np.array([[35.0, 30.0, 0, 0, 0], [60.0, 30.0, 0, 0, 0]]), np.array([0, 0])
    >>> together = score_cues([colour, foreground], obs, states, owner)
    >>> alone = [cue.log_likelihoods(obs, states, owner) for cue in (colour, foreground)]
    >>> all(np.array_equal(t, a) for t, a in zip(together, alone))
    True
    """
    states, owner = checked_particles(obs, states, owner)
    scores: list = [None] * len(cues)
    groups, others = sampling_groups(cues, obs)
    for index in others:
        scores[index] = cues[index].log_likelihoods(obs, states, owner)
    for members in groups:
        rhos = window_similarities([cues[i] for i in members], obs, states, owner)
        for index, rho in zip(members, rhos):
            scores[index] = log_gaussian(1.0 - rho, cues[index].config.sigma)       # d² = 1 − ρ (W (17))
    return tuple(scores)


def template_similarity(cues, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """ρ (L (12)) of every box with its owner's current template, the smallest over the appearance ``cues``.

    How much a target's window still looks like the target; the colour cues share their
    sampling as in :func:`score_cues`.

    Parameters
    ----------
    cues : sequence of AppearanceCue
        At least one.
    obs : Observation
    states : ndarray, shape (P, 5)
    owner : ndarray of int, shape (P,)

    Returns
    -------
    ndarray, shape (P,)

    Examples
    --------
    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> image[20:40, 30:40] = (0, 0, 255)
    >>> from belief_tracking.cues import ColourConfig
    >>> cue = ColourCue(ColourConfig(samples=(6, 12)))
    >>> obs = Observation(image, None, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)),
    ...                   templates={"colour": cue.build_templates(image, np.array([[30, 20, 10, 20]]))})
    >>> template_similarity([cue], obs, np.array([[35.0, 30.0, 0, 0, 0], [60.0, 30.0, 0, 0, 0]]), np.array([0, 0]))
    array([1., 0.])
    """
    if not cues:
        raise TrackingError("template_similarity needs at least one appearance cue")
    states, owner = checked_particles(obs, states, owner)
    rows = np.arange(owner.size)
    found = []
    groups, others = sampling_groups(cues, obs)
    for index in others:
        cue = cues[index]
        found.append(bhattacharyya(cue.histograms(obs, states, owner), cue.templates(obs))[rows, owner])
    for members in groups:
        found.extend(rho[rows, owner] for rho in window_similarities([cues[i] for i in members], obs, states, owner))
    return np.min(found, axis=0)


def sampling_groups(cues, obs: Observation) -> tuple[list[list[int]], list[int]]:
    """The indices of the colour cues that can share their sampling, by group, and those of the other cues."""
    groups: dict[tuple, list[int]] = {}
    others = []
    for index, cue in enumerate(cues):
        if isinstance(cue, ColourCue) and type(cue).log_likelihoods is ColourCue.log_likelihoods \
                and type(cue).histograms is ColourCue.histograms:
            bin_image, weights = cue.frame_features(obs)           # kept by obs: the ids stay valid
            groups.setdefault((id(bin_image), id(weights), cue.config.n_bins, cue.config.samples), []).append(index)
        else:
            others.append(index)
    return list(groups.values()), others
