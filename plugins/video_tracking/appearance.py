"""How well each track still looks like its templates: total similarity, occlusion and template update.

After the estimate of a frame (C's algorithm, step 5; SPEC B.5), :class:`AppearanceFollower`
computes, for every track of the store:

* the total similarity ρ_t = Σ_i λ_i ρ[p_i(x̂_t), q̂_{i,t−1}] of its appearance cues at its
  estimate (C (9), C (15)), with the confidences λ of the weighting strategy renormalised
  over the appearance cues, or equal weights when the strategy has none;
* the occlusion flag ρ_t < T;
* when the templates follow their tracks, the update of C (16), frozen while a track is
  occluded.

ρ_t goes into the track's record (:attr:`~belief_tracking.store.Track.similarity`): it is
the ρ_{t−1} that C's adaptive fusion (C (14)) reads the next frame.  The templates, current
and initial, are the track's too (:attr:`~belief_tracking.store.Track.templates`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from .adaptive import AdaptiveConfig, occluded, total_similarity, update_templates
from .cues import AppearanceCue, Observation
from .store import Track

__all__ = ["AppearanceFollower", "Appearance", "row_similarity", "stacked_templates"]


def row_similarity(histograms: np.ndarray, templates: np.ndarray) -> np.ndarray:
    """ρ[h_j, q_j] row by row (C (9)), shape (τ,).

    >>> row_similarity(np.array([[0.5, 0.5], [1.0, 0.0]]), np.array([[0.5, 0.5], [0.0, 1.0]])).tolist()
    [1.0, 0.0]
    """
    return np.clip(np.sqrt(np.maximum(histograms, 0.0) * templates).sum(axis=1), 0.0, 1.0)


def stacked_templates(tracks: Sequence[Track], cues: Sequence[AppearanceCue],
                      initial: bool = False) -> dict[str, np.ndarray]:
    """The tracks' current (or ``initial``) templates of each cue, stacked, shape (τ, B) by cue name.

    >>> track = Track.born(1, (0, 0, 4, 8), np.zeros((2, 5)), {"colour": np.array([0.5, 0.5])})
    >>> from belief_tracking.cues import ColourCue
    >>> stacked_templates([track, track], [ColourCue()])["colour"].tolist()
    [[0.5, 0.5], [0.5, 0.5]]
    """
    return {cue.name: np.stack([(t.initial_templates if initial else t.templates)[cue.name] for t in tracks])
            for cue in cues}


class Appearance(NamedTuple):
    """The appearance of every track at its new estimate.

    Attributes
    ----------
    similarity : ndarray, shape (τ,)
        ρ_t (C (15)); 1 without appearance cues.
    occluded : ndarray of bool, shape (τ,)
        ρ_t < T.
    """

    similarity: np.ndarray
    occluded: np.ndarray


class AppearanceFollower:
    """Total similarity at the estimates (C (15)), occlusion flags and the template update (C (16)).

    Parameters
    ----------
    config : AdaptiveConfig
        The threshold T of the occlusion test.
    cues : sequence
        The tracker's cues, in fusion order; the appearance cues among them are followed.
    update : bool
        Update the templates by C (16) (frozen under occlusion).

    Examples
    --------
    A track whose window shows exactly its template has ρ_t = 1 and is not occluded:

    >>> from belief_tracking.cues import ColourCue, ColourConfig
    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> cue = ColourCue(ColourConfig(samples=(6, 12)))
    >>> box = (30, 20, 10, 20)
    >>> track = Track.born(7, box, np.zeros((3, 5)), {"colour": cue.build_templates(image, [box])[0]})
    >>> follower = AppearanceFollower(AdaptiveConfig(), [cue], update=False)
    >>> obs = Observation(image, None, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)),
    ...                   templates=stacked_templates([track], [cue]))
    >>> appearance = follower.follow(obs, [track])
    >>> appearance.similarity.round(12).tolist(), appearance.occluded.tolist(), round(track.similarity, 12)
    ([1.0], [False], 1.0)
    """

    def __init__(self, config: AdaptiveConfig, cues: Sequence, update: bool) -> None:
        self.config = config
        self.update = bool(update)
        self.cues = list(cues)
        self._columns = [k for k, cue in enumerate(self.cues) if isinstance(cue, AppearanceCue)]

    def follow(self, obs: Observation, tracks: Sequence[Track], confidences: np.ndarray | None = None) -> Appearance:
        """ρ_t and the occlusion flags of every track at its new estimate; C (16) when updating.

        Parameters
        ----------
        obs : Observation
            The frame the estimates belong to, with the tracks' templates before the update.
        tracks : sequence of Track
            The tracks, in the observation's order; their estimates are this frame's (W (6)).
            Each track's ``similarity`` becomes its ρ_t, and its templates are updated.
        confidences : ndarray, shape (τ, c), optional
            The weighting strategy's confidences λ (C (13)), one column per cue.

        Returns
        -------
        Appearance
        """
        tau = len(tracks)
        if not self._columns:
            similarity, flags = np.ones(tau), np.zeros(tau, dtype=bool)
        else:
            states, index = np.array([t.estimate for t in tracks]), np.arange(tau)
            cues = [self.cues[k] for k in self._columns]
            current = [cue.histograms(obs, states, index) for cue in cues]                      # each (τ, B)
            rho = np.stack([row_similarity(p, obs.templates_of(cue.name)) for p, cue in zip(current, cues)], axis=1)
            weights = np.ones((tau, len(cues))) if confidences is None else confidences[:, self._columns]
            similarity = total_similarity(weights, rho)
            flags = occluded(similarity, self.config.threshold)
            if self.update:
                self._update(obs, tracks, cues, current, flags)
        for track, value in zip(tracks, similarity):
            track.similarity = float(value)
        return Appearance(similarity, flags)

    @staticmethod
    def _update(obs: Observation, tracks: Sequence[Track], cues: list, current: list[np.ndarray],
                frozen: np.ndarray) -> None:
        """Let every template follow its track's current appearance, frozen under occlusion (C (16))."""
        initial = stacked_templates(tracks, cues, initial=True)
        for cue, observed in zip(cues, current):
            updated = update_templates(initial[cue.name], obs.templates_of(cue.name), observed, frozen)
            totals = updated.sum(axis=1, keepdims=True)
            # Rows summing to 1 up to rounding are normalised once more, as every template is.
            updated = np.divide(updated, totals, out=updated, where=totals > 0)
            for track, row in zip(tracks, updated):
                track.templates[cue.name] = row
