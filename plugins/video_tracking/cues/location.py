"""The location cue: where a particle lies with respect to the previous estimates (W (22)–(24))."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .. import checks
from .base import ConfiguredCue, log_gaussian, positive_setting
from .observation import Observation, checked_particles

__all__ = ["LocationConfig", "LocationCue", "squared_distances"]


@dataclass(frozen=True)
class LocationConfig:
    """Settings of the location cue.

    Attributes
    ----------
    sigma : float
        σ_loc in pixels of the Gaussians of W (22) and W (23) (SPEC default 10 px).
    gate : float
        The tracker's FA: certain beyond ``gate`` · σ from the nearest target (not read
        when ``literal``).
    literal : bool
        False (default): each target's Gaussian is centred on its estimate moved on by its
        estimated velocity (x̂ + v̂·dt), so that the cue does not pull a moving target back,
        and FA grows with the distance to the *nearest* target up to a fixed d_max = ``gate``
        · σ, so that FA is unlikely near every target and certain beyond the gate, however
        the targets spread over the image.  True: W (22)–(24) as printed, centred on the
        estimates at t − 1, FA from the centroid of the targets with d_max from the particles
        of t − 1.  The tracker supplies the centres.
    """

    sigma: float = 10.0
    gate: float = 3.0
    literal: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", positive_setting("LocationConfig", "sigma", self.sigma))
        object.__setattr__(self, "gate", positive_setting("LocationConfig", "gate", self.gate))
        object.__setattr__(self, "literal", checks.flag("LocationConfig.literal", self.literal))


class LocationCue(ConfiguredCue):
    """Where a particle lies with respect to the previous estimates (W (22)–(24)).

    Target j: log p_j = −‖x − ĉ_j‖² / (2σ²), the log of G(‖x − ĉ_j‖; σ) (W (22)), with x the
    particle's propagated centre and ĉ_j target j's estimate at t − 1.

    FA: log p_FA = −max(d_max − d, 0)² / (2σ²) (W (23)).  FA grows as a particle moves
    away from the targets; the clamp keeps it at its maximum, log p_FA = 0, outside the
    circle of radius d_max instead of letting it fall again (SPEC B.3).  By default d is the
    distance of x to the nearest centre and d_max = ``gate`` · σ; with ``literal`` d is the
    distance to the centroid c̄ of the τ centres (W (24)) and d_max the largest such distance
    among all particles of t − 1, floored at σ.

    Examples
    --------
    W (22)–(24): targets at (100, 50) and (140, 70), so c̄ = (120, 60); the particles of
    t − 1 reach (90, 45), so d_max = √1125 ≈ 33.5.  A particle on target 1 is at d = √500
    from c̄:

    >>> obs = Observation(np.zeros((120, 200, 3), np.uint8), None,
    ...                   centres=[[100, 50], [140, 70]], sizes=[[20, 40], [20, 40]],
    ...                   previous_particles=[[90, 45], [150, 75]])
    >>> cue = LocationCue(LocationConfig(sigma=10.0, literal=True))
    >>> states = np.array([[100.0, 50.0, 0, 0, 0], [300.0, 60.0, 0, 0, 0]])
    >>> cue.log_likelihoods(obs, states, owner=np.array([0, 1])).round(3)
    array([[   0.   ,  -10.   ,   -0.625],
           [-200.5  , -128.5  ,    0.   ]])

    The gate (3σ = 30 px): on its target the particle is 30 px from the gate, log p_FA = −4.5;
    the far one is beyond it:

    >>> LocationCue(LocationConfig(sigma=10.0)).log_likelihoods(obs, states, np.array([0, 1]))[:, 2].tolist()
    [-4.5, 0.0]
    """

    name: ClassVar[str] = "location"
    config_type: ClassVar[type] = LocationConfig

    def log_likelihoods(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """log p_1 … log p_τ, log p_FA of every particle, shape (P, τ + 1) (W (22)–(24)).

        ``owner`` is only checked: location scores do not depend on a particle's own target.
        """
        states, owner = checked_particles(obs, states, owner)
        tau = obs.n_targets
        scores = np.empty((states.shape[0], tau + 1))
        if states.shape[0] == 0:
            return scores
        positions = states[:, :2]
        target_sq = squared_distances(positions, obs.centres)                      # (P, τ)
        scores[:, :tau] = log_gaussian(target_sq, self.config.sigma)
        if not self.config.literal:
            distance = np.sqrt(target_sq.min(axis=1, initial=np.inf))                # to the nearest target
            d_max = self.config.gate * self.config.sigma
        else:
            centroid = obs.centres.mean(axis=0)                                      # W (24)
            distance = np.linalg.norm(positions - centroid, axis=1)
            previous = np.linalg.norm(obs.previous_particles - centroid, axis=1)     # (Q,)
            # A circle thinner than σ would make FA jump from 0 to its maximum within a few
            # pixels of the targets; the floor keeps it as smooth as the target Gaussians.
            d_max = max(float(previous.max(initial=0.0)), self.config.sigma)
        gap = np.maximum(d_max - distance, 0.0)                                    # W (23) clamp
        scores[:, tau] = log_gaussian(gap ** 2, self.config.sigma)
        return scores


def squared_distances(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """‖points_p − centres_j‖², shape (len(points), len(centres))."""
    # Per axis, (P, τ) arrays with long inner loops: several times faster than an einsum over
    # a (P, τ, 2) array, and the same sum dx² + dy².
    squared = points[:, 0:1] - centres[:, 0]
    squared *= squared
    dy = points[:, 1:2] - centres[:, 1]
    dy *= dy
    squared += dy
    return squared
