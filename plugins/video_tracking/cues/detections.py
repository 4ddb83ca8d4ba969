"""The detections cue: how well a particle agrees with the frame's detector boxes, each discounted by its score."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .. import checks
from .base import ConfiguredCue, positive_setting
from .observation import Observation, checked_particles

__all__ = ["DetectionConfig", "DetectionCue"]


@dataclass(frozen=True)
class DetectionConfig:
    """Settings of the detections cue.

    Attributes
    ----------
    sigma : float
        σ_det of the Gaussian of a particle's distance to a detection, in units of the
        detection's own width (horizontally) and height (vertically): 0.25 means a particle
        a quarter of the box width beside the box centre is one σ away.
    reliability : float in [0, 1]
        Trust in the detector on top of its scores: a detection of score s discounts its
        evidence by the reliability r·s (1: the scores as they are).
    """

    sigma: float = 0.25
    reliability: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", positive_setting("DetectionConfig", "sigma", self.sigma))
        object.__setattr__(self, "reliability", checks.fraction("DetectionConfig.reliability", self.reliability))


class DetectionCue(ConfiguredCue):
    """How well a particle agrees with the frame's detections, each discounted by its score.

    Each detection i with box centre (x_i, y_i), size (w_i, h_i) and score s_i is a source of
    reliability r_i = r·s_i (r of :class:`DetectionConfig`); its support for a window centred
    on (x, y) is the Gaussian

        G_i(x, y) = exp(−½ [((x − x_i) / (σ w_i))² + ((y − y_i) / (σ h_i))²]).

    Discounting a source by its reliability keeps 1 − r_i of its mass on the whole frame
    (Shafer's discounting), which reads as a likelihood of at least 1 − r_i for every
    hypothesis:

    * target j with detection d_j (:attr:`Observation.assigned`): p_j = r_d·G_d + (1 − r_d);
    * target j with no detection this frame: p_j = 1, so the cue says nothing about it and
      the other cues carry the target (a missed detection, an occlusion);
    * FA: p_FA = 1 − max_i r_i·G_i, small on any detection and 1 far from all of them.

    A frame without detections gives every particle p = 1 for every hypothesis.

    Examples
    --------
    One detection of score 0.8, taken by target 0; target 1 has none.  A particle on the
    detection supports target 0 fully and FA little; one far away supports target 0 only
    by the 1 − 0.8 that the detector's doubt leaves:

    >>> obs = Observation(np.zeros((100, 100, 3), np.uint8), None, centres=[[50, 50], [10, 10]],
    ...                   sizes=[[20, 40], [20, 40]], previous_particles=np.zeros((0, 2)),
    ...                   detections=[[40, 30, 20, 40, 0.8]], assigned=[0, -1])
    >>> states = np.array([[50.0, 50.0, 0, 0, 0], [90.0, 90.0, 0, 0, 0]])
    >>> np.exp(DetectionCue().log_likelihoods(obs, states, np.array([0, 0]))).round(3)
    array([[1. , 1. , 0.2],
           [0.2, 1. , 1. ]])
    """

    name: ClassVar[str] = "detections"
    config_type: ClassVar[type] = DetectionConfig

    def log_likelihoods(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """log p_1 … log p_τ, log p_FA of every particle, shape (P, τ + 1)."""
        states, owner = checked_particles(obs, states, owner)
        tau = obs.n_targets
        scores = np.zeros((states.shape[0], tau + 1))
        detections = obs.detections
        if detections is None or detections.shape[0] == 0 or states.shape[0] == 0:
            return scores
        centres = detections[:, :2] + detections[:, 2:4] / 2.0
        spread = self.config.sigma * detections[:, 2:4]
        dx = (states[:, 0:1] - centres[:, 0]) / spread[:, 0]
        dy = (states[:, 1:2] - centres[:, 1]) / spread[:, 1]
        reliability = self.config.reliability * detections[:, 4]
        support = reliability * np.exp(-0.5 * (dx * dx + dy * dy))                   # (P, n): r_i·G_i
        # log1p(−x) keeps 1 − r·G accurate when r·G is tiny; a certain detection (r·G = 1)
        # gives −inf, a likelihood of zero, which the mass functions accept.
        with np.errstate(divide="ignore"):
            scores[:, tau] = np.log1p(-support.max(axis=1))
            taken = np.flatnonzero(obs.assigned >= 0)
            chosen = obs.assigned[taken]
            scores[:, taken] = np.log1p(support[:, chosen] - reliability[chosen])
        return scores
