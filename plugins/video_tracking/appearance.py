"""How well each target still looks like its templates: total similarity, occlusion and template update.

After the estimate of a frame (C's algorithm, step 5; SPEC B.5):

* the total similarity ρ_t = Σ_i λ_i ρ[p_i(x̂_t), q̂_{i,t−1}] of every target's appearance
  cues at its estimate (C (9), C (15)), with the confidences λ of the weighting strategy
  renormalised over the appearance cues, or equal weights when the strategy has none;
* the occlusion flag ρ_t < T;
* when the templates follow their targets, the update of C (16), frozen while a target is
  occluded.

:class:`AppearanceFollower` keeps ρ_t per target id: it is the ρ_{t−1} that C's adaptive
fusion (C (14)) reads the next frame, and the only place where that state lives.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .adaptive import AdaptiveConfig, occluded, total_similarity
from .cues import AppearanceCue, Observation

__all__ = ["AppearanceFollower", "row_similarity"]


def row_similarity(histograms: np.ndarray, templates: np.ndarray) -> np.ndarray:
    """ρ[h_j, q_j] row by row (C (9)), shape (τ,).

    >>> row_similarity(np.array([[0.5, 0.5], [1.0, 0.0]]), np.array([[0.5, 0.5], [0.0, 1.0]])).tolist()
    [1.0, 0.0]
    """
    return np.clip(np.sqrt(np.maximum(histograms, 0.0) * templates).sum(axis=1), 0.0, 1.0)


class AppearanceFollower:
    """Total similarity at the estimates (C (15)), occlusion flags and the template update (C (16)).

    Parameters
    ----------
    config : AdaptiveConfig
        ρ_0 of a new target, the threshold T and the update's settings.
    cues : sequence
        The tracker's cues; the appearance cues among them are followed.
    update : bool
        Update the templates by C (16) (frozen under occlusion).

    Examples
    --------
    A target whose window shows exactly its template has ρ_t = 1 and is not occluded:

    >>> from belief_tracking.cues import ColourCue, ColourConfig, Observation
    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> cue = ColourCue(ColourConfig(samples=(6, 12)))
    >>> cue.set_templates(image, np.array([[30, 20, 10, 20]]))
    >>> follower = AppearanceFollower(AdaptiveConfig(), [cue], update=False)
    >>> obs = Observation(image, None, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)))
    >>> similarity, flags = follower.follow(obs, np.array([[35.0, 30.0, 0, 0, 0]]), [7])
    >>> similarity.round(12).tolist(), flags.tolist(), follower.similarity([7, 8]).round(12).tolist()
    ([1.0], [False], [1.0, 0.8])
    """

    def __init__(self, config: AdaptiveConfig, cues: Sequence, update: bool) -> None:
        self.config = config
        self.cues = list(cues)
        self.update = bool(update)
        self._columns = [k for k, cue in enumerate(self.cues) if isinstance(cue, AppearanceCue)]
        self._similarity: dict[int, float] = {}

    def similarity(self, ids: Sequence[int]) -> np.ndarray:
        """ρ_{t−1} of the targets ``ids`` (ρ_0 for a target not followed yet), shape (τ,)."""
        return np.array([self._similarity.get(int(i), self.config.rho0) for i in ids], dtype=np.float64)

    def follow(self, obs: Observation, estimates: np.ndarray, ids: Sequence[int],
               confidences: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """ρ_t and the occlusion flags of every target at its new estimate; C (16) when updating.

        Parameters
        ----------
        obs : Observation
            The frame the estimates belong to.
        estimates : ndarray, shape (τ, 5)
            The estimated states (W (6)), in the cues' target order.
        ids : sequence of int
            The targets' ids, in the same order.
        confidences : ndarray, shape (τ, c), optional
            The weighting strategy's confidences λ (C (13)), one column per cue.

        Returns
        -------
        similarity : ndarray, shape (τ,)
            ρ_t (C (15)); 1 without appearance cues.
        occluded : ndarray of bool, shape (τ,)
            ρ_t < T.
        """
        tau = len(ids)
        if not self._columns:
            similarity, flags = np.ones(tau), np.zeros(tau, dtype=bool)
        else:
            index = np.arange(tau)
            current = [self.cues[k].histograms(obs, estimates, index) for k in self._columns]     # each (τ, B)
            rho = np.stack([row_similarity(p, self.cues[k].templates) for p, k in zip(current, self._columns)],
                           axis=1)
            weights = np.ones((tau, len(self._columns))) if confidences is None else confidences[:, self._columns]
            similarity = total_similarity(weights, rho)
            flags = occluded(similarity, self.config.threshold)
            if self.update:
                for p, k in zip(current, self._columns):
                    self.cues[k].follow_appearance(p, flags)
        self._similarity = {int(i): float(s) for i, s in zip(ids, similarity)}
        return similarity, flags
