"""What a frame's cues say about the particles, and what a weighting strategy makes of it.

:class:`Evidence` is one frame's scores (every cue's log-likelihoods of every particle
against θ_1 … θ_τ and FA, with each particle's own target); a weighting strategy
(:class:`Weighting`, in :mod:`~belief_tracking.weighting` and :mod:`~belief_tracking.adaptive`)
turns it into a :class:`Weighing`: the particles' log-weights and the strategy's own
quantities per target.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Evidence", "Weighing", "Weighting", "target_means"]


@dataclass(frozen=True, eq=False)
class Evidence:
    """What the cues say about the particles of one frame.

    Attributes
    ----------
    scores : tuple of ndarray, each shape (P, τ + 1)
        Per cue, in cue order: log p_1 … log p_τ, log p_FA of every particle (SPEC Part D).
    owner : ndarray of int, shape (P,)
        The target index of each particle, 0 … τ − 1; every target has a particle.
    positions : ndarray, shape (P, 2)
        The particles' centres (for the spreads of C (11)).
    similarity : ndarray, shape (τ,), optional
        Each target's total similarity ρ_{t−1} of the previous frame (C (15)), for C (14).
    cues : tuple of str
        The cue names, in the order of ``scores``.
    """

    scores: tuple[np.ndarray, ...]
    owner: np.ndarray
    positions: np.ndarray
    similarity: np.ndarray | None = None
    cues: tuple[str, ...] = ()

    @cached_property
    def n_targets(self) -> int:
        """τ."""
        return self.scores[0].shape[1] - 1

    @cached_property
    def counts(self) -> np.ndarray:
        """Particles per target, shape (τ,)."""
        return np.bincount(self.owner, minlength=self.n_targets)

    @cached_property
    def own(self) -> np.ndarray:
        """Each cue's log-likelihood of each particle for its own target, shape (P, c)."""
        rows = np.arange(self.owner.size)
        return np.stack([s[rows, self.owner] for s in self.scores], axis=1)


@dataclass(frozen=True, eq=False)
class Weighing:
    """What a strategy made of one frame's evidence.

    Attributes
    ----------
    log_weights : ndarray, shape (P,)
        Unnormalised log-weights (−inf for a weight of 0); the tracker normalises them
        within each target's set.
    diagnostics : dict of str to ndarray, each shape (τ,)
        The strategy's own quantities per target (its ``columns``).
    confidences : ndarray, shape (τ, c), or None
        Per target and cue, how much the strategy trusted the cue (C (13)); None when it
        weighs every cue alike.
    """

    log_weights: np.ndarray
    diagnostics: dict[str, np.ndarray] = field(default_factory=dict)
    confidences: np.ndarray | None = None


@runtime_checkable
class Weighting(Protocol):
    """A weighting strategy: one frame's evidence in, log-weights and diagnostics out."""

    #: The keys of :attr:`Weighing.diagnostics`.
    columns: tuple[str, ...]

    def weigh(self, evidence: Evidence) -> Weighing:
        """Log-weights of every particle and this strategy's diagnostics per target."""
        ...


def target_means(values: np.ndarray, owner: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Per-target unweighted means of per-particle ``values`` (as W (33)–(35)), shape (τ,).

    >>> target_means(np.array([1.0, 3.0, 5.0]), np.array([0, 0, 1]), np.array([2, 1])).tolist()
    [2.0, 5.0]
    """
    return np.bincount(owner, weights=np.asarray(values, dtype=np.float64), minlength=counts.size) / counts
