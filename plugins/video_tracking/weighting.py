"""Weighting strategies: how the cues' scores of a frame become the particles' log-weights.

A strategy is a small part with one method, :meth:`~belief_tracking.evidence.Weighting.weigh`,
which takes the :class:`~belief_tracking.evidence.Evidence` of one frame (every cue's
log-likelihoods of every particle against θ_1 … θ_τ and FA, and each particle's own
target) and returns a :class:`~belief_tracking.evidence.Weighing`: the log-weights, and the
strategy's own diagnostics per target.  The strategies are registered in
:data:`WEIGHTINGS` by the names of :attr:`TrackerConfig.fusion
<belief_tracking.config.TrackerConfig.fusion>`:

* ``"belief"`` — :class:`BeliefWeighting`: the cues' mass functions combined by a rule of
  :mod:`belief`, weight Bel(θ_J) (or Pls, BetP) of the particle's own target (W (7), W (32));
* ``"adaptive"`` — :class:`~belief_tracking.adaptive.AdaptiveWeighting`: C's
  confidence-weighted mix of the product and sum rules (C (11)–(14));
* ``"sum"`` and ``"product"`` — :class:`~belief_tracking.adaptive.SumWeighting`,
  :class:`~belief_tracking.adaptive.ProductWeighting`: the cues' own-target likelihoods
  added with equal weights, or multiplied (the two terms of C (14)).

Only the active strategy runs each frame; the belief fusion also runs for the diagnostics
when they are asked for (``TrackerConfig.diagnostics = "all"``), and for the conflict level
of the adaptive particle count: :meth:`BeliefWeighting.fuse` fuses each frame's evidence
once, however many of them read it.

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

import numpy as np

from .adaptive import AdaptiveConfig, AdaptiveWeighting, ProductWeighting, SumWeighting
from .evidence import Evidence, Weighing, Weighting, target_means
from .fusion import CueFusion, FusionConfig, FusionResult

__all__ = ["Evidence", "Weighing", "Weighting", "BeliefWeighting", "SumWeighting", "ProductWeighting",
           "WEIGHTINGS", "make_weighting", "target_means", "BELIEF_COLUMNS"]

#: Diagnostics of the belief strategy, per target and frame: unweighted means over the target's
#: particles of m(θ_J) (W (33)), of the mass on intersections containing θ_J (W (34)), of
#: Bel(θ_J) (W (35)), of m(∅), and of the inconsistency R between the first two cues (W (10)).
BELIEF_COLUMNS = ("mean_m_target", "mean_m_intersection", "mean_bel", "mean_m_empty", "mean_r")


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
        self._fused: tuple[Evidence, FusionResult] | None = None

    def fuse(self, evidence: Evidence) -> FusionResult:
        """The :class:`~belief_tracking.fusion.FusionResult` of one frame, fused once per evidence."""
        if self._fused is not None and self._fused[0] is evidence:
            return self._fused[1]
        if self._fusion is None or self._fusion.n_targets != evidence.n_targets:
            self._fusion = CueFusion(evidence.n_targets, self.config)
        result = self._fusion.fuse(evidence.scores, evidence.owner)
        self._fused = (evidence, result)
        return result

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


#: The weighting strategies by name; each builds its part from the belief fusion's and C's
#: settings, the cue names and the random generator of C's feature confidences (C (11)).
WEIGHTINGS = {
    "belief": lambda fusion, adaptive, cues, rng: BeliefWeighting(fusion),
    "adaptive": lambda fusion, adaptive, cues, rng: AdaptiveWeighting(adaptive, cues, rng),
    "sum": lambda fusion, adaptive, cues, rng: SumWeighting(),
    "product": lambda fusion, adaptive, cues, rng: ProductWeighting(),
}


def make_weighting(name: str, fusion: FusionConfig, adaptive: AdaptiveConfig, cues: tuple[str, ...],
                   rng: np.random.Generator) -> Weighting:
    """The strategy ``name`` of :data:`WEIGHTINGS` (the name is checked by the tracker's settings).

    >>> make_weighting("sum", FusionConfig(), AdaptiveConfig(), ("colour",), np.random.default_rng(0))
    SumWeighting()
    """
    return WEIGHTINGS[name](fusion, adaptive, cues, rng)
