"""Fusing the cues of every particle with :mod:`belief` (SPEC Part D, W (7), W (20)–(21), W (32)).

Each cue scores every particle against every hypothesis of the frame
{θ_1, …, θ_τ, FA}.  The scores of one cue become a Bayesian mass function per particle
(:func:`cue_masses`); the c cue mass functions of all particles are combined at once with a
rule of the :mod:`belief` registry, as batches under the tracking model
(``Model.for_targets``), and the weight of a particle of target J is Bel(θ_J) (W (32)), or
Pls(θ_J) or BetP(θ_J), read with ``select=`` the particle's own target.

Everything goes through :mod:`belief`'s public API: for Bayesian sources
:func:`belief.combine` uses its closed forms by itself (O(c·τ) per particle, plus one O(τ²)
pass for each R-weighted fold but the last) instead of the O(τ³) focal elements that a
general combination of three cues builds, and builds those only if someone asks.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from belief import EMPTY_MODES, R_MODES, BeliefError, MassBatch, Model, combine, get_rule, inconsistency
from . import checks
from .errors import TrackingError

__all__ = ["FusionConfig", "CueFusion", "FusionResult", "cue_masses", "relative_likelihoods", "WEIGHTS", "MASSES"]

#: How a fused mass function becomes a particle weight.
WEIGHTS = ("bel", "pls", "betp")

#: How a cue's likelihoods become its mass function (:func:`cue_masses`).
MASSES = ("relative", "normalised")

#: The two ways :func:`cue_masses` reads likelihoods.
_LIKELIHOOD_READINGS = ("normalised", "absolute")


@dataclass(frozen=True)
class FusionConfig:
    """How cue evidence is fused.

    Attributes
    ----------
    rule : str
        A rule of :data:`belief.RULES` (default: the R-weighted rule of SPEC A.4).
    weight : {"bel", "pls", "betp"}
        The measure of θ_J that weights a particle of target J (W (32): Bel).
    r_mode, empty_mode : str
        Options of the R-weighted rule (ignored by the other rules).
    masses : {"relative", "normalised"}
        How each cue's likelihoods become its mass function: ``"relative"`` (default)
        divides each likelihood by the best own-target likelihood in the particle's set
        (:func:`relative_likelihoods`), keeps it as the mass and puts the unexplained rest
        on FA (:func:`cue_masses` ``"absolute"``); ``"normalised"`` is W (20)–(21) as printed.
    """

    rule: str = "r_rule"
    weight: str = "bel"
    r_mode: str = "paper"
    empty_mode: str = "union"
    masses: str = "relative"

    def __post_init__(self) -> None:
        try:
            get_rule(self.rule)
        except (BeliefError, TypeError) as exc:
            raise TrackingError(f"FusionConfig.rule: {exc}") from None
        checks.choice("FusionConfig.weight", self.weight, WEIGHTS)
        checks.choice("FusionConfig.masses", self.masses, MASSES)
        if get_rule(self.rule).name == "r_rule":
            checks.choice("FusionConfig.r_mode", self.r_mode, R_MODES)
            checks.choice("FusionConfig.empty_mode", self.empty_mode, EMPTY_MODES)

    @property
    def options(self) -> dict[str, str]:
        if get_rule(self.rule).name == "r_rule":
            return {"r_mode": self.r_mode, "empty_mode": self.empty_mode}
        return {}


def cue_masses(log_likelihoods: np.ndarray, mode: str = "normalised") -> np.ndarray:
    """Bayesian cue masses over θ_1 … θ_τ, FA from log-likelihoods, row by row.

    ``"normalised"`` is W (20)–(21): m(θ_j) = p_j / (Σ_k p_k + p_FA), computed as a softmax
    (the largest log-likelihood is subtracted first, so rows of tiny likelihoods keep their
    proportions).

    ``"absolute"`` keeps the likelihoods themselves.  The cue likelihoods are Gaussian
    similarities p = G(d; σ) ∈ (0, 1] (W (16), (19), (22), (23)): p_j is the degree to which
    the particle's window fits target j.  Where they sum to at most one,

        m(θ_j) = p_j,        m(FA) = 1 − Σ_k p_k,

    so FA, the complement of the targets in the exhaustive frame (SPEC Part D), receives its
    own likelihood p_FA plus whatever support no target claims.  Where they sum to more than
    one the row is normalised as in W (20)–(21), so both modes agree there.  A window that fits
    no model well is thus evidence of a false alarm; with normalised masses a poor fit to
    θ_J still gives m(θ_J) ≈ 1 as long as FA fits even worse, so every particle near its
    target gets Bel(θ_J) ≈ 1 and the weights W (32) stop telling good particles from poor ones.

    Parameters
    ----------
    log_likelihoods : ndarray, shape (P, τ + 1)
        log p_1 … log p_τ, log p_FA for P particles; -inf is a likelihood of zero.
    mode : {"normalised", "absolute"}

    Returns
    -------
    ndarray, shape (P, τ + 1)
        Rows that sum to one.  A row of all -inf gets the uniform mass (normalised) or all
        mass on FA (absolute), never NaN.

    Examples
    --------
    >>> cue_masses(np.array([[np.log(0.6), np.log(0.3), np.log(0.1)], [-700.0, -700.0, -np.inf]]))
    array([[0.6, 0.3, 0.1],
           [0.5, 0.5, 0. ]])
    >>> cue_masses(np.log([[0.2, 0.05, 0.1], [0.9, 0.4, 0.1]]), "absolute").round(4)
    array([[0.2   , 0.05  , 0.75  ],
           [0.6429, 0.2857, 0.0714]])
    """
    values = np.asarray(log_likelihoods, dtype=np.float64)
    if values.ndim != 2 or values.shape[1] < 2:
        raise TrackingError(f"log-likelihoods must have shape (P, τ + 1), got {values.shape}")
    if mode not in _LIKELIHOOD_READINGS:
        raise TrackingError(f"mode must be one of {', '.join(_LIKELIHOOD_READINGS)}, got {mode!r}")
    peak = float(values.max()) if values.size else 0.0           # NaN if any entry is
    if math.isnan(peak) or peak == math.inf:
        raise TrackingError("log-likelihoods must not be NaN or +inf")
    if mode == "normalised":
        return _softmax(values)
    if peak > 0:
        raise TrackingError("absolute cue masses need likelihoods in [0, 1] (log-likelihoods ≤ 0)")
    likelihoods = np.exp(values)
    targets = likelihoods[:, :-1].sum(axis=1)
    total = targets + likelihoods[:, -1]
    fits = total <= 1.0
    # Rows whose likelihoods sum past one are normalised as W (20)–(21).  Their largest
    # likelihood is then above 1 / (τ + 1), so dividing by the sum loses nothing to the
    # shift by the maximum that a softmax of arbitrary log-likelihoods needs.
    likelihoods /= np.where(fits, 1.0, total)[:, None]
    likelihoods[:, -1] = np.where(fits, 1.0 - targets, likelihoods[:, -1])
    return likelihoods


def _softmax(values: np.ndarray) -> np.ndarray:
    """W (20)–(21) row by row from log-likelihoods: exp(v − max) normalised; a row of −inf is uniform."""
    top = values.max(axis=1, keepdims=True)
    dead = ~np.isfinite(top[:, 0])
    shifted = np.exp(values - np.where(dead[:, None], 0.0, top))
    shifted[dead] = 1.0
    return shifted / shifted.sum(axis=1, keepdims=True)


def relative_likelihoods(log_likelihoods: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """Likelihoods relative to the best particle of each set: log p − max_{n ∈ set J} log p_J⁽ⁿ⁾.

    The cue likelihoods G(d; σ) measure similarity on a scale that depends on the scene: a
    walking person never matches the template of their first frame exactly, so even the best
    window of a target may have p_J ≪ 1, and with :func:`cue_masses` ``"absolute"`` every
    particle would then hand most of its mass to FA.  Dividing by the best own-target
    likelihood in the set gives Shafer's relative likelihood L(x) / max L: the best particle
    of target J fits θ_J with p = 1, the others in proportion, and a window that fits a
    hypothesis better than that best particle is capped at 1.  A set whose every own-target
    likelihood is zero is left as it is.

    Parameters
    ----------
    log_likelihoods : ndarray, shape (P, τ + 1)
        One cue's log p_1 … log p_τ, log p_FA.
    owner : ndarray of int, shape (P,)
        The target of each particle.

    Returns
    -------
    ndarray, shape (P, τ + 1)
        Relative log-likelihoods, all ≤ 0.

    Examples
    --------
    >>> scores = np.log([[0.02, 0.01, 0.001], [0.01, 0.001, 0.001], [0.5, 0.2, 0.1]])
    >>> np.exp(relative_likelihoods(scores, np.array([0, 0, 1]))).round(3)
    array([[1.  , 0.5 , 0.05],
           [0.5 , 0.05, 0.05],
           [1.  , 1.  , 0.5 ]])
    """
    values = np.asarray(log_likelihoods, dtype=np.float64)
    owner = np.asarray(owner, dtype=np.int64)
    if values.shape[0] == 0:
        return values.copy()
    own = values[np.arange(owner.size), owner]
    best = np.full(int(owner.max()) + 1, -np.inf)
    np.maximum.at(best, owner, own)
    shift = best[owner]
    shift = np.where(np.isfinite(shift), shift, 0.0)
    return np.minimum(values - shift[:, None], 0.0)


class FusionResult:
    """The fused evidence of P particles, read for each particle's own target.

    Every measure is computed on first access (and kept), from the fused batch of
    :func:`belief.combine`, whose closed forms share their work between the measures.

    Parameters
    ----------
    fused : MassBatch
        One fused mass function per particle (P rows).
    cues : sequence of MassBatch
        The cue batches that were combined (R needs the first two).
    owner : ndarray of int, shape (P,)
        The target of each particle.
    targets : list of str
        θ_1 … θ_τ.
    config : FusionConfig

    Attributes
    ----------
    fused, owner : as given.
    """

    def __init__(self, fused: MassBatch, cues: Sequence[MassBatch], owner: np.ndarray, targets: list[str],
                 config: "FusionConfig") -> None:
        self.fused = fused
        self.cues = tuple(cues)
        self.owner = owner
        self._targets = targets
        self._config = config

    @cached_property
    def weights(self) -> np.ndarray:
        """The measure of θ_J that weighs each particle (``config.weight``: Bel, Pls or BetP), shape (P,) (W (32))."""
        if self._config.weight == "bel":
            return self.bel
        return getattr(self.fused, self._config.weight)(self._targets, select=self.owner)

    @cached_property
    def bel(self) -> np.ndarray:
        """Bel(θ_J) of every particle for its own target J, shape (P,) (W (8), W (35))."""
        return self.fused.bel(self._targets, select=self.owner)

    @cached_property
    def singleton_mass(self) -> np.ndarray:
        """m(θ_J) of every particle for its own target J, shape (P,) (W (33))."""
        return self.fused.mass(self._targets, select=self.owner)

    @cached_property
    def intersection_mass(self) -> np.ndarray:
        """Mass on the elements inside θ_J other than θ_J itself (θ_J ∩ θ_k …), shape (P,) (W (34)).

        Under the tracking model the non-empty elements inside θ_J are θ_J and the target
        intersections that contain it, so this is Bel(θ_J) − m(θ_J).
        """
        return np.maximum(self.bel - self.singleton_mass, 0.0)

    @cached_property
    def empty_mass(self) -> np.ndarray:
        """m(∅) of every particle (the conflict the rule keeps), shape (P,)."""
        return self.fused.empty_mass

    @cached_property
    def inconsistency(self) -> np.ndarray:
        """R of W (10) between the first two cues, per particle, shape (P,); zeros with one cue."""
        if len(self.cues) < 2:
            return np.zeros(len(self.owner))
        return inconsistency(self.cues[0], self.cues[1], r_mode=self._config.r_mode)


class CueFusion:
    """Combines the cue evidence of all particles of all targets at once.

    Parameters
    ----------
    n_targets : int
        τ; the frame is ``t1 … tτ, FA`` under the tracking model.
    config : FusionConfig

    Examples
    --------
    The worked example of SPEC A.4 (two targets; location, then colour):

    >>> fusion = CueFusion(2, FusionConfig(rule="r_rule", masses="normalised"))
    >>> location = np.log([[0.6, 0.3, 0.1]])
    >>> colour = np.log([[0.2, 0.7, 0.1]])
    >>> result = fusion.fuse([location, colour], owner=np.array([0]))
    >>> round(float(result.weights[0]), 4), round(float(result.inconsistency[0]), 4)      # Bel(θ1), R
    (0.5149, 0.6325)
    """

    def __init__(self, n_targets: int, config: "FusionConfig" = None) -> None:
        self.n_targets = checks.integer("the number of targets", n_targets, minimum=1)
        self.config = config if config is not None else FusionConfig()
        self.model = Model.for_targets(self.n_targets)
        self.targets = [str(x) for x in self.model.frame.singletons[:self.n_targets]]

    def cue_masses(self, log_likelihoods: Sequence[np.ndarray], owner: np.ndarray) -> list[np.ndarray]:
        """The cue mass functions of P particles, one (P, τ + 1) array per cue (``config.masses``)."""
        shape = (owner.size, self.n_targets + 1)
        masses = []
        for k, scores in enumerate(log_likelihoods):
            scores = np.asarray(scores, dtype=np.float64)
            if scores.shape != shape:
                raise TrackingError(f"cue {k + 1} gives shape {scores.shape}, expected {shape}")
            if self.config.masses == "relative":
                masses.append(cue_masses(relative_likelihoods(scores, owner), "absolute"))
            else:
                masses.append(cue_masses(scores, self.config.masses))
        return masses

    def fuse(self, log_likelihoods: Sequence[np.ndarray], owner: np.ndarray) -> FusionResult:
        """Fuse c cues for P particles (W (7)); the result reads each particle's own target (W (32)).

        Parameters
        ----------
        log_likelihoods : sequence of ndarray, each shape (P, τ + 1)
            One array per cue, in cue order (the R-weighted rule is folded in that order).
        owner : ndarray of int, shape (P,)
            The target index of each particle.
        """
        if not log_likelihoods:
            raise TrackingError("fusion needs at least one cue")
        owner = np.asarray(owner, dtype=np.int64)
        if owner.size and (owner.min() < 0 or owner.max() >= self.n_targets):
            raise TrackingError(f"particle owners must be target indices 0..{self.n_targets - 1}")
        cues = [MassBatch.bayesian(m, model=self.model, validate=False)
                for m in self.cue_masses(log_likelihoods, owner)]
        fused = cues[0] if len(cues) == 1 else combine(*cues, rule=self.config.rule, **self.config.options)
        return FusionResult(fused, cues, owner, self.targets, self.config)
