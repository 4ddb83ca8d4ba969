"""Fusing the cues of every particle into a weight (SPEC Part D, W (7), W (20)–(21), W (32)).

Each cue scores every particle against every hypothesis of the frame
{θ_1, …, θ_τ, FA}.  The scores of one cue become a Bayesian mass function per particle
(W (20)–(21), computed as a softmax of log-likelihoods so that tiny likelihoods never give
0/0); the c cue mass functions of all particles are combined at once with a rule of the
:mod:`belief` registry, as batches under the tracking model; the weight of a particle of
target J is then Bel(θ_J) (W (32)), or Pls(θ_J) or BetP(θ_J) on request.

For the rules and cue counts of :func:`plugins.video_tracking.owner_fusion.supports` (the
R-weighted rule, DSmC, the conjunctive rule and Dempster's rule) those measures come from
closed forms over the targets, at O(c·τ) per particle (plus one O(τ²) pass per particle for
each R-weighted fold but the last) instead of the O(τ³) focal elements that a general
combination of three cues builds; the fused mass functions are then combined only if
:attr:`FusionResult.fused` is read.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property, partial

import numpy as np

from belief import MassBatch, Model, combine
from belief.errors import BeliefError, InvalidMassError
from belief.rules import EMPTY_MODES, R_MODES, get_rule
from plugins.video_tracking import checks
from plugins.video_tracking.errors import TrackingError
from plugins.video_tracking.owner_fusion import first_inconsistency, owner_measures, supports

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
        raise InvalidMassError(f"log-likelihoods must have shape (P, τ + 1), got {values.shape}")
    if np.isnan(values).any() or np.isposinf(values).any():
        raise InvalidMassError("log-likelihoods must not be NaN or +inf")
    if mode not in _LIKELIHOOD_READINGS:
        raise InvalidMassError(f"mode must be one of {', '.join(_LIKELIHOOD_READINGS)}, got {mode!r}")
    top = values.max(axis=1, keepdims=True)
    dead = ~np.isfinite(top[:, 0])
    shifted = np.exp(values - np.where(dead[:, None], 0.0, top))
    shifted[dead] = 1.0
    normalised = shifted / shifted.sum(axis=1, keepdims=True)
    if mode == "normalised":
        return normalised
    if (values > 0).any():
        raise InvalidMassError("absolute cue masses need likelihoods in [0, 1] (log-likelihoods ≤ 0)")
    likelihoods = np.exp(values)
    fits = likelihoods.sum(axis=1) <= 1.0
    likelihoods[:, -1] = 1.0 - likelihoods[:, :-1].sum(axis=1)
    return np.where(fits[:, None], likelihoods, normalised)


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
    """The fused evidence of P particles.

    Parameters
    ----------
    fused : MassBatch or callable
        The fused mass functions, or a function without arguments that combines them (then
        :attr:`fused` is computed on first access only).
    owner : ndarray of int, shape (P,)
    weights : ndarray, shape (P,)
    n_targets : int
    measures : dict of str to ndarray, optional
        Measures of θ_owner already known (keys ``bel``, ``pls``, ``betp``,
        ``singleton_mass``, ``intersection_mass``, ``empty_mass``); the others are read off
        :attr:`fused`.
    inconsistency : callable, optional
        Gives :attr:`inconsistency`; zeros by default.

    Attributes
    ----------
    owner : ndarray of int, shape (P,)
        The target of each particle.
    weights : ndarray, shape (P,)
        The measure of θ_owner of each particle (not normalised).
    n_targets : int
        τ.
    """

    def __init__(self, fused: MassBatch | Callable[[], MassBatch], owner: np.ndarray, weights: np.ndarray,
                 n_targets: int = 0, *, measures: dict[str, np.ndarray] | None = None,
                 inconsistency: Callable[[], np.ndarray] | None = None) -> None:
        self._fused = fused
        self.owner = owner
        self.weights = weights
        self.n_targets = n_targets
        self._measures = {k: v for k, v in (measures or {}).items() if v is not None}
        self._inconsistency = inconsistency

    @cached_property
    def fused(self) -> MassBatch:
        """One fused mass function per particle (P rows), combined on first access if needed."""
        return self._fused if isinstance(self._fused, MassBatch) else self._fused()

    def _known(self, name: str):
        return self._measures.get(name)

    @cached_property
    def bel(self) -> np.ndarray:
        """Bel(θ_J) of every particle for its own target J, shape (P,) (W (32))."""
        known = self._known("bel")
        if known is not None:
            return known
        targets = list(self.fused.frame.singletons[:self.n_targets])
        return self.fused.bel(targets)[np.arange(len(self.owner)), self.owner] if len(self.owner) else np.zeros(0)

    @cached_property
    def singleton_mass(self) -> np.ndarray:
        """m(θ_J) of every particle for its own target J, shape (P,) (W (33))."""
        known = self._known("singleton_mass")
        return known if known is not None else _singleton_mass(self.fused, self.owner, self.n_targets)

    @cached_property
    def intersection_mass(self) -> np.ndarray:
        """Mass on intersections of θ_J with other targets (θ_J ∩ θ_k …), per particle, shape (P,) (W (34))."""
        known = self._known("intersection_mass")
        return known if known is not None else _intersection_mass(self.fused, self.owner, self.n_targets)

    @cached_property
    def empty_mass(self) -> np.ndarray:
        """m(∅) of every particle (conflict kept by the rule), shape (P,)."""
        known = self._known("empty_mass")
        return known if known is not None else self.fused.empty_mass

    @cached_property
    def inconsistency(self) -> np.ndarray:
        """R (W (10)) of the first fold, between cues 1 and 2, per particle; zeros with one cue."""
        return self._inconsistency() if self._inconsistency is not None else np.zeros(len(self.owner))


def _singleton_mass(fused: MassBatch, owner: np.ndarray, n_targets: int) -> np.ndarray:
    columns = _columns(fused, [fused.frame.singletons[j] for j in range(n_targets)])
    return _pick(fused.values, columns, owner)


def _intersection_mass(fused: MassBatch, owner: np.ndarray, n_targets: int) -> np.ndarray:
    fa = len(fused.frame) - 1
    totals = np.zeros((len(owner), n_targets))
    for col, element in enumerate(fused.focal):
        if len(element.terms) != 1:
            continue
        term = element.terms[0]
        if term >> fa & 1 or term.bit_count() < 2:
            continue
        for j in range(n_targets):
            if term >> j & 1:
                totals[:, j] += fused.values[:, col]
    return totals[np.arange(len(owner)), owner]


def _columns(batch: MassBatch, elements) -> np.ndarray:
    index = {e: i for i, e in enumerate(batch.focal)}
    return np.array([index.get(e, -1) for e in elements], dtype=np.int64)


def _pick(values: np.ndarray, columns: np.ndarray, owner: np.ndarray) -> np.ndarray:
    padded = np.concatenate([values, np.zeros((values.shape[0], 1))], axis=1)
    chosen = np.where(columns < 0, values.shape[1], columns)[owner]
    return padded[np.arange(values.shape[0]), chosen]


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
    >>> round(float(result.weights[0]), 4)            # Bel(θ1)
    0.5149
    """

    def __init__(self, n_targets: int, config: FusionConfig = FusionConfig()) -> None:
        if isinstance(n_targets, bool) or not isinstance(n_targets, int) or n_targets < 1:
            raise InvalidMassError(f"the number of targets must be a positive integer, got {n_targets!r}")
        self.n_targets = n_targets
        self.config = config
        self.model = Model.for_targets(n_targets)
        self.focal = self.model.frame.singletons
        self.targets = self.focal[:n_targets]

    def cue_masses(self, log_likelihoods: Sequence[np.ndarray], owner: np.ndarray) -> list[np.ndarray]:
        """The cue mass functions of P particles, one (P, τ + 1) array per cue (``config.masses``)."""
        owner = np.asarray(owner, dtype=np.int64)
        shape = (owner.size, self.n_targets + 1)
        masses = []
        for k, scores in enumerate(log_likelihoods):
            scores = np.asarray(scores, dtype=np.float64)
            if scores.shape != shape:
                raise InvalidMassError(f"cue {k + 1} gives shape {scores.shape}, expected {shape}")
            if self.config.masses == "relative":
                masses.append(cue_masses(relative_likelihoods(scores, owner), "absolute"))
            else:
                masses.append(cue_masses(scores, self.config.masses))
        return masses

    def fuse(self, log_likelihoods: Sequence[np.ndarray], owner: np.ndarray) -> FusionResult:
        """Fuse c cues for P particles (W (7)) and weigh each particle (W (32)).

        Parameters
        ----------
        log_likelihoods : sequence of ndarray, each shape (P, τ + 1)
            One array per cue, in cue order (the R-weighted rule is folded in that order).
        owner : ndarray of int, shape (P,)
            The target index of each particle.
        """
        if not log_likelihoods:
            raise InvalidMassError("fusion needs at least one cue")
        owner = np.asarray(owner, dtype=np.int64)
        if owner.size and (owner.min() < 0 or owner.max() >= self.n_targets):
            raise InvalidMassError(f"particle owners must be target indices 0..{self.n_targets - 1}")
        batches = [MassBatch._trusted(self.model, self.focal, values, canonical=True)
                   for values in self.cue_masses(log_likelihoods, owner)]
        masses = [b.values for b in batches]
        config = self.config
        weight = config.weight
        rule = get_rule(config.rule).name
        if len(masses) > 1:
            def inconsistency() -> np.ndarray:
                return first_inconsistency(masses[0], masses[1], config.r_mode)
        else:
            inconsistency = None
        if not supports(rule, len(masses), config.r_mode, betp=weight == "betp"):
            fused = self._combine(batches)
            measure = getattr(fused, weight)(list(self.targets))                    # (P, τ)
            weights = measure[np.arange(owner.size), owner] if owner.size else np.zeros(0)
            return FusionResult(fused, owner, weights, self.n_targets, inconsistency=inconsistency)
        # Closed forms per particle; rows they leave open are combined in general.
        fast = owner_measures(masses, owner, rule, r_mode=config.r_mode, empty_mode=config.empty_mode,
                              betp=weight == "betp")
        measures = {"bel": fast.bel, "pls": fast.pls, "betp": fast.betp, "singleton_mass": fast.singleton,
                    "intersection_mass": fast.intersection, "empty_mass": fast.empty}
        if fast.general.any():
            rows = np.flatnonzero(fast.general)
            part = FusionResult(self._combine([MassBatch._trusted(self.model, self.focal, m[rows], canonical=True)
                                               for m in masses]), owner[rows], None, self.n_targets)
            targets = list(self.targets)
            for name in list(measures):
                if measures[name] is None:
                    continue
                if name in WEIGHTS:
                    values = getattr(part.fused, name)(targets)[np.arange(rows.size), owner[rows]]
                else:
                    values = getattr(part, name)
                measures[name] = measures[name].copy()
                measures[name][rows] = values
        return FusionResult(partial(self._combine, batches), owner, measures[weight], self.n_targets,
                            measures=measures, inconsistency=inconsistency)

    def _combine(self, batches: list[MassBatch]) -> MassBatch:
        """The general combination of the cue batches with the configured rule (W (7))."""
        if len(batches) == 1:
            return batches[0]
        return combine(*batches, rule=self.config.rule, **self.config.options)
