"""Weighting strategies: how the cues' scores of a frame become the particles' log-weights.

A strategy is a small part with one method, :meth:`Weighting.weigh`, which takes the
:class:`Evidence` of one frame (every cue's log-likelihoods of every particle against
θ_1 … θ_τ and FA, and each particle's own target) and returns a :class:`Weighing`: the
log-weights, and the strategy's own diagnostics per target.  The strategies are registered
in :data:`WEIGHTINGS` by the names of :attr:`TrackerConfig.fusion
<belief_tracking.config.TrackerConfig.fusion>`:

* ``"belief"`` — :class:`BeliefWeighting`: the cues' mass functions combined by a rule of
  :mod:`belief`, weight Bel(θ_J) (or Pls, BetP) of the particle's own target (W (7), W (32));
* ``"adaptive"`` — :class:`~belief_tracking.adaptive.AdaptiveWeighting`: C's
  confidence-weighted mix of the product and sum rules (C (11)–(14));
* ``"sum"`` and ``"product"`` — :class:`SumWeighting`, :class:`ProductWeighting`: the
  cues' own-target likelihoods added with equal weights, or multiplied.

Only the active strategy runs each frame; the tracker runs another one only for its
diagnostics, when they are asked for (``TrackerConfig.diagnostics = "all"``), or for the
conflict level of the adaptive particle count.

Examples
--------
Two particles of one target, two cues; the product rule weighs by the product of the
own-target likelihoods:

>>> scores = (np.log([[0.5, 0.1], [0.1, 0.1]]), np.log([[0.2, 0.1], [0.4, 0.1]]))
>>> evidence = Evidence(scores, owner=np.array([0, 0]), positions=np.zeros((2, 2)))
>>> np.exp(ProductWeighting().weigh(evidence).log_weights).round(6).tolist()
[0.1, 0.04]
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from .fusion import CueFusion, FusionConfig

if TYPE_CHECKING:
    from .config import TrackerConfig

__all__ = ["Evidence", "Weighing", "Weighting", "BeliefWeighting", "SumWeighting", "ProductWeighting",
           "WEIGHTINGS", "make_weighting", "target_means", "BELIEF_COLUMNS"]

#: Diagnostics of the belief strategy, per target and frame: unweighted means over the target's
#: particles of m(θ_J) (W (33)), of the mass on intersections containing θ_J (W (34)), of
#: Bel(θ_J) (W (35)), of m(∅), and of the inconsistency R between the first two cues (W (10)).
BELIEF_COLUMNS = ("mean_m_target", "mean_m_intersection", "mean_bel", "mean_m_empty", "mean_r")


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


class BeliefWeighting:
    """The belief strategy: cue mass functions fused by a :mod:`belief` rule (W (7), W (20)–(21), W (32)).

    Each cue's scores become one Bayesian mass function per particle over
    {θ_1, …, θ_τ, FA} (:func:`~belief_tracking.fusion.cue_masses`); the c mass
    functions of every particle are combined at once under the tracking model, and a
    particle of target J gets the log of Bel(θ_J) (or Pls, BetP: ``config.weight``).

    Parameters
    ----------
    config : FusionConfig

    Examples
    --------
    SPEC A.4's worked example (τ = 2, location then colour, literal masses W (20)–(21)):
    Bel(θ1) = .5149.

    >>> weighting = BeliefWeighting(FusionConfig(masses="normalised"))
    >>> scores = (np.log([[0.6, 0.3, 0.1]] * 2), np.log([[0.2, 0.7, 0.1]] * 2))
    >>> weighing = weighting.weigh(Evidence(scores, np.array([0, 1]), np.zeros((2, 2))))
    >>> np.exp(weighing.log_weights).round(4), weighing.diagnostics["mean_bel"].round(4)
    (array([0.5149, 0.6609]), array([0.5149, 0.6609]))
    """

    columns = BELIEF_COLUMNS

    def __init__(self, config: FusionConfig = FusionConfig()) -> None:
        self.config = config
        self._fusion: CueFusion | None = None

    def fuse(self, evidence: Evidence):
        """The :class:`~belief_tracking.fusion.FusionResult` of one frame."""
        if self._fusion is None or self._fusion.n_targets != evidence.n_targets:
            self._fusion = CueFusion(evidence.n_targets, self.config)
        return self._fusion.fuse(evidence.scores, evidence.owner)

    def weigh(self, evidence: Evidence) -> Weighing:
        result = self.fuse(evidence)
        with np.errstate(divide="ignore"):
            log_weights = np.log(np.maximum(result.weights, 0.0))                       # 0 → −inf
        owner, counts = evidence.owner, evidence.counts
        diagnostics = {
            "mean_m_target": target_means(result.singleton_mass, owner, counts),
            "mean_m_intersection": target_means(result.intersection_mass, owner, counts),
            "mean_bel": target_means(result.bel, owner, counts),
            "mean_m_empty": target_means(result.empty_mass, owner, counts),
            "mean_r": target_means(result.inconsistency, owner, counts),
        }
        return Weighing(log_weights, diagnostics)


class SumWeighting:
    """Equal-weight sum of the cues' own-target likelihoods: log Σ_i p_i / c (the sum term of C (14))."""

    columns: tuple[str, ...] = ()

    def weigh(self, evidence: Evidence) -> Weighing:
        own = evidence.own
        terms = own + np.log(1.0 / own.shape[1])
        peak = terms.max(axis=1)
        shift = np.where(np.isfinite(peak), peak, 0.0)           # a particle with every p_i = 0 stays at −inf
        with np.errstate(divide="ignore"):
            return Weighing(shift + np.log(np.exp(terms - shift[:, None]).sum(axis=1)))


class ProductWeighting:
    """Product of the cues' own-target likelihoods: Σ_i log p_i (the product term of C (14))."""

    columns: tuple[str, ...] = ()

    def weigh(self, evidence: Evidence) -> Weighing:
        return Weighing(evidence.own.sum(axis=1))


def _belief(config: "TrackerConfig", rng: np.random.Generator) -> BeliefWeighting:
    return BeliefWeighting(config.belief)


def _adaptive(config: "TrackerConfig", rng: np.random.Generator):
    from .adaptive import AdaptiveWeighting

    return AdaptiveWeighting(config.adaptive_fusion, config.cues, rng)


#: The weighting strategies by name; each builds its part from the tracker's settings and the
#: random generator of the feature confidences (C (11)).
WEIGHTINGS = {
    "belief": _belief,
    "adaptive": _adaptive,
    "sum": lambda config, rng: SumWeighting(),
    "product": lambda config, rng: ProductWeighting(),
}


def make_weighting(name: str, config: "TrackerConfig", rng: np.random.Generator) -> Weighting:
    """The strategy ``name`` of :data:`WEIGHTINGS` for these settings (the name is checked by ``config``)."""
    return WEIGHTINGS[name](config, rng)
