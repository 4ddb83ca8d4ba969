"""The particle filter's own stages, run on every track of the store: predict, estimate, resample (W-S2, S4, S5).

* :class:`Prediction` moves every track's particles by the constant-velocity model (W-S2)
  and sizes their windows by the perspective model of the row they reach;
* :func:`estimate` normalises each track's weights within its set and takes their weighted
  mean as its state (W-S4, W (6));
* :class:`ParticleCount` chooses each track's next particle count from its conflict level
  (SPEC B.3, the adaptive particle number), an explicit quantity of its own;
* :func:`resample` draws each track's next set (W-S5).

Every random draw comes from the generator given to the stage.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .evidence import Evidence, Weighing, target_means
from .particles import CX, CY, LOG_SCALE, VX, VY, ConstantVelocity, MotionConfig, ParticleSet, adaptive_count
from .perspective import PerspectiveScale
from .store import Track
from .weighting import BeliefWeighting

__all__ = ["Prediction", "estimate", "ParticleCount", "resample", "location_centres"]


class Prediction:
    """W-S2: every track's particles propagated, each window sized by the perspective model (or its birth size).

    Parameters
    ----------
    config : MotionConfig
    image_shape : (int, int)
        (H, W) of the frames: the motion model keeps the centres inside.

    Examples
    --------
    >>> prediction = Prediction(MotionConfig(sigma_pos=0.0, sigma_vel=0.0), (50, 80))
    >>> track = Track.born(1, (10, 10, 4, 8), np.array([[12.0, 14.0, 1.0, 0.5, 0.2]]), {})
    >>> prediction([track], None, np.random.default_rng(0))[0].states.tolist()
    [[13.0, 14.5, 1.0, 0.5, 0.0]]
    """

    def __init__(self, config: MotionConfig, image_shape: tuple[int, int]) -> None:
        height, width = image_shape
        self.motion = ConstantVelocity(config, bounds=(width, height))

    def __call__(self, tracks: Sequence[Track], perspective: PerspectiveScale | None,
                 rng: np.random.Generator) -> list[ParticleSet]:
        """The moved particle set of every track, in order; the tracks themselves are unchanged."""
        moved = []
        for track in tracks:
            particles = track.particles.propagate(self.motion, rng)
            # Without a fitted model every track keeps its birth size: a random walk on the
            # scale would drift, since the foreground-masked colour rewards shrinking windows.
            scale = 0.0 if perspective is None else \
                perspective.log_scale(particles.states[:, CY], track.birth_cy)
            moved.append(particles.with_column(LOG_SCALE, scale))
        return moved


def location_centres(tracks: Sequence[Track], dt: float, literal: bool) -> np.ndarray:
    """The t − 1 centres of the tracks, moved on by their velocities unless ``literal``, shape (τ, 2).

    >>> track = Track.born(1, (10, 10, 4, 8), np.zeros((1, 5)), {})
    >>> track.estimate[2:4] = (2.0, -1.0)
    >>> location_centres([track], 1.0, literal=False).tolist(), location_centres([track], 1.0, True).tolist()
    ([[14.0, 13.0]], [[12.0, 14.0]])
    """
    centres = np.array([t.estimate[[CX, CY]] for t in tracks]).reshape(-1, 2)
    if not literal:
        centres = centres + dt * np.array([t.estimate[[VX, VY]] for t in tracks]).reshape(-1, 2)
    return centres


def estimate(tracks: Sequence[Track], moved: Sequence[ParticleSet], weighing: Weighing,
             counts: np.ndarray) -> list[ParticleSet]:
    """W-S4: weights normalised within each set, each track's estimate their weighted mean (W (6)).

    Parameters
    ----------
    tracks : sequence of Track
        Their ``estimate`` becomes this frame's.
    moved : sequence of ParticleSet
        The predicted sets, in track order.
    weighing : Weighing
        The log-weights of every particle, the sets one after another.
    counts : ndarray of int, shape (τ,)
        The particles of each set.

    Returns
    -------
    list of ParticleSet
        The weighted sets, in track order.

    Examples
    --------
    >>> track = Track.born(1, (0, 0, 2, 2), np.zeros((2, 5)), {})
    >>> moved = [ParticleSet(np.array([[0.0, 0, 0, 0, 0], [4.0, 0, 0, 0, 0]]))]
    >>> _ = estimate([track], moved, Weighing(np.log([1.0, 3.0])), np.array([2]))
    >>> track.estimate.tolist()
    [3.0, 0.0, 0.0, 0.0, 0.0]
    """
    starts = np.concatenate([[0], np.cumsum(counts)])
    weighted = []
    for j, (track, particles) in enumerate(zip(tracks, moved)):
        reweighted = particles.reweight(weighing.log_weights[starts[j]:starts[j + 1]])
        track.estimate = reweighted.estimate()
        weighted.append(reweighted)
    return weighted


class ParticleCount:
    """The adaptive particle number (SPEC B.3): each track's next N from its conflict level κ.

    N_{t+1} = N_min + ⌈(N − N_min)·κ⌉ with N_min = ⌈N / 2⌉ (:func:`~belief_tracking.particles.adaptive_count`).
    κ is a mean over the track's particles of the cues fused by the belief rule, whatever the
    weighting strategy: ``"mass"`` the mass on target intersections and on ∅ (the
    non-consensus mass), ``"r"`` the inconsistency R of W (10) between the first two cues.

    Parameters
    ----------
    particles : int
        N, the most particles a track has.
    kappa : {"mass", "r"}
    beliefs : BeliefWeighting
        The belief fusion of the frame's evidence (shared with the strategy and the
        diagnostics, so each frame is fused once).

    Examples
    --------
    >>> from belief_tracking.fusion import FusionConfig
    >>> count = ParticleCount(10, "mass", BeliefWeighting(FusionConfig(masses="normalised")))
    >>> scores = (np.log([[0.6, 0.3, 0.1]] * 2), np.log([[0.2, 0.7, 0.1]] * 2))
    >>> evidence = Evidence(scores, np.array([0, 1]), np.zeros((2, 2)))
    >>> count.kappa(evidence).round(4).tolist()                  # m(θ1 ∩ θ2) + m(∅), the same for both
    [0.3036, 0.3036]
    >>> count(evidence)                                          # 5 + ⌈5 · 0.3036⌉
    [7, 7]
    """

    def __init__(self, particles: int, kappa: str, beliefs: BeliefWeighting) -> None:
        self.particles = particles
        self.kind = kappa
        self.beliefs = beliefs

    def kappa(self, evidence: Evidence) -> np.ndarray:
        """κ of every track, shape (τ,)."""
        fused = self.beliefs.fuse(evidence)
        owner, counts = evidence.owner, evidence.counts
        if self.kind == "r":
            return target_means(fused.inconsistency, owner, counts)
        return target_means(fused.intersection_mass, owner, counts) + target_means(fused.empty_mass, owner, counts)

    def __call__(self, evidence: Evidence) -> list[int]:
        """Every track's particle count for the next frame."""
        return [adaptive_count(float(np.clip(k, 0.0, 1.0)), math.ceil(self.particles / 2), self.particles)
                for k in self.kappa(evidence)]


def resample(tracks: Sequence[Track], weighted: Sequence[ParticleSet], rng: np.random.Generator, method: str,
             threshold: float, counts: Sequence[int] | None = None) -> None:
    """W-S5: every track's weighted set resampled (to ``counts`` particles with the adaptive number).

    >>> track = Track.born(1, (0, 0, 2, 2), np.zeros((2, 5)), {})
    >>> weighted = [ParticleSet(np.array([[0.0, 0, 0, 0, 0], [4.0, 0, 0, 0, 0]]), np.array([-np.inf, 0.0]))]
    >>> resample([track], weighted, np.random.default_rng(0), "systematic", 1.0, [3])
    >>> track.particles.states[:, 0].tolist()
    [4.0, 4.0, 4.0]
    """
    for j, (track, particles) in enumerate(zip(tracks, weighted)):
        track.particles = particles.resample(rng, method=method, threshold=threshold,
                                             n=None if counts is None else counts[j])
