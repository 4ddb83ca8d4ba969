"""C's adaptive multi-feature fusion: spreads, entropies, confidences, mixing, occlusion, template update (SPEC B.5).

The maths of one frame of Algorithm C (SPEC B.5, steps 3–5), for τ targets at once:

1. per target and feature, the spatial spread s_i of the feature's resampled particle
   cloud (C (11)) and the entropy H_i of its normalised weights (C (12));
2. the performance index h_i = 1/(s_i·H_i + ε) and the confidences λ_i = h_i / Σ_k h_k (C (13));
3. the fused likelihood, a mix of the product rule and the λ-weighted sum rule whose
   product share is the previous frame's total similarity ρ_{t−1} (C (14));
4. the total similarity ρ_t = Σ_i λ_i ρ_i (C (15)), the occlusion test ρ_t < T, and the
   template update (C (16)), frozen under occlusion.

Conventions
-----------
The particles of all τ targets are stacked in one array of P rows; ``owner`` (P,) gives each
particle's target in 0..τ−1 (a target's particles need not be contiguous).  ``log_p`` (P, c)
holds log p(z_i | x^j), the log-likelihood of feature i for particle j under its own target's
template (C (10)).  Entries may be very negative or −inf; NaN and +inf are rejected.  Every
weight is handled in the log domain with log-sum-exp, so likelihoods of e^−800 do not underflow
to zero.  No NaN leaves this module: a feature whose weights are all zero within a target gets
uniform weights with a :class:`~belief_tracking.particles.DegenerateWeightsWarning`
(SPEC B.1, resampling).

Choices where SPEC B.5 reconstructs a garbled formula: the spread uses the default reading
of C (11) (resample N, keep the ⌈0.6·N⌉ resampled particles nearest their mean) and the scalar
s_i = tr Σ_i + ε; the performance index is the product form; ρ_{t−1} multiplies the product
term of C (14), and each term is normalised over the target's particles before mixing
(``mix_norm="per_term"``; ``"raw"`` is the formula as printed); C (16) is the reconstructed
form, with β = ρ[q_init, p_cur] weighing the initial template (SPEC B.5, variant A).

:class:`AdaptiveWeighting` is C's method as a weighting strategy of the tracker
(:mod:`belief_tracking.weighting`): each frame it computes the confidences λ from the
cues' scores and mixes the product and sum rules with each target's ρ_{t−1}, read from the
evidence.  :class:`SumWeighting` and :class:`ProductWeighting` are C (14)'s two terms on
their own, with equal weights.  The strategies trust the evidence the tracker built and call
the kernels below directly; the public functions check their inputs first.  The total
similarity itself, the occlusion test and the template update run after the estimate, in
:mod:`belief_tracking.appearance`, which writes ρ into each track's record.

Examples
--------
Two particles of one target, two features with likelihoods (0.5, 0.2) and (0.1, 0.4).  With
λ = (1/4, 3/4) and ρ_{t−1} = 1/2, C (14) as printed gives 0.5·0.1 + 0.5·(0.125 + 0.15) = 0.1875
for the first particle and 0.5·0.04 + 0.5·(0.025 + 0.3) = 0.1825 for the second:

>>> import numpy as np
>>> log_p = np.log([[0.5, 0.2], [0.1, 0.4]])
>>> owner = np.array([0, 0])
>>> lam = np.array([[0.25, 0.75]])
>>> np.exp(fuse_adaptive(log_p, owner, 1, lam, 0.5, mix_norm="raw")).round(6).tolist()
[0.1875, 0.1825]
"""

from __future__ import annotations

import math
import operator
import warnings
from dataclasses import dataclass
from typing import Optional, Union

import numpy as np

from . import checks
from .errors import TrackingError
from .particles import DegenerateWeightsWarning, systematic
from .evidence import Evidence, Weighing

__all__ = [
    "AdaptiveConfig",
    "AdaptiveWeighting",
    "SumWeighting",
    "ProductWeighting",
    "MIX_NORMS",
    "feature_spreads",
    "feature_entropies",
    "feature_confidences",
    "fuse_product",
    "fuse_sum",
    "fuse_adaptive",
    "total_similarity",
    "occluded",
    "update_templates",
]

MIX_NORMS = ("per_term", "raw")
"""Ways to mix the two terms of C (14): normalised over each target's particles first, or as printed."""

#: Slack on sums that should be 1, and on products like keep·N that should be integers.
_TOLERANCE = 1e-9

#: How far a template row's sum may stray from 1 before it is rejected.
_HISTOGRAM_TOLERANCE = 1e-6


# -- validation -----------------------------------------------------------------------------------


def _epsilon(name: str, value: object) -> float:
    return checks.number(name, value, positive=True)


def _keep(name: str, value: object) -> float:
    return checks.fraction(name, value, allow_zero=False)


def _unit(name: str, value: object) -> float:
    return checks.fraction(name, value)


def _n_targets(value: object) -> int:
    if isinstance(value, bool):
        raise TrackingError(f"n_targets must be a non-negative integer, got {value!r}")
    try:
        number = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise TrackingError(f"n_targets must be a non-negative integer, got {value!r}") from None
    if number < 0:
        raise TrackingError(f"n_targets must be a non-negative integer, got {number}")
    return number


def _float_array(name: str, value: object) -> np.ndarray:
    try:
        return np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TrackingError(f"{name} must be an array of real numbers") from None


def _log_likelihoods(log_p: object) -> np.ndarray:
    array = _float_array("log_p", log_p)
    if array.ndim != 2 or array.shape[1] == 0:
        raise TrackingError(f"log_p must have shape (P, c) with c >= 1, got shape {array.shape}")
    if np.isnan(array).any() or np.isposinf(array).any():
        raise TrackingError("log_p must not contain NaN or +inf (−inf marks an impossible particle)")
    return array


def _owner(owner: object, n_particles: int, n_targets: object) -> tuple[np.ndarray, np.ndarray, int]:
    """Checked ``owner`` as intp, the particle count of every target (τ,), and τ."""
    n_targets = _n_targets(n_targets)
    array = np.asarray(owner)
    if array.dtype == np.bool_ or not (np.issubdtype(array.dtype, np.integer) or array.size == 0):
        raise TrackingError(f"owner must be an integer array, got dtype {array.dtype}")
    array = array.astype(np.intp)
    if array.shape != (n_particles,):
        raise TrackingError(f"owner must have shape ({n_particles},), one target per particle, got {array.shape}")
    if array.size and (array.min() < 0 or array.max() >= n_targets):
        raise TrackingError(
            f"owner values must lie in 0..n_targets-1 = 0..{n_targets - 1}, got {array.min()}..{array.max()}"
        )
    counts = np.bincount(array, minlength=n_targets)
    if n_targets and counts.min() == 0:
        empty = int(np.argmin(counts))
        raise TrackingError(f"owner gives target {empty} no particle; every target needs at least one")
    return array, counts, n_targets


def _per_target(name: str, value: object, n_targets: int, n_features: Optional[int] = None) -> np.ndarray:
    """A (τ, c) array of finite non-negative numbers."""
    array = _float_array(name, value)
    if array.ndim != 2 or array.shape[0] != n_targets or (n_features is not None and array.shape[1] != n_features):
        expected = f"({n_targets}, {'c' if n_features is None else n_features})"
        raise TrackingError(f"{name} must have shape {expected}, got {array.shape}")
    if not np.isfinite(array).all():
        raise TrackingError(f"{name} must be finite")
    if (array < 0).any():
        raise TrackingError(f"{name} must be non-negative, got minimum {array.min()!r}")
    return array


def _confidence_rows(name: str, lam: object, n_targets: int, n_features: Optional[int] = None) -> np.ndarray:
    """λ rows (τ, c), each divided by its sum."""
    array = _per_target(name, lam, n_targets, n_features)
    sums = array.sum(axis=1)
    if (sums <= 0).any():
        raise TrackingError(f"{name} has a row summing to 0 (target {int(np.argmin(sums))}); a row needs some weight")
    return array / sums[:, None]


def _similarities(name: str, value: object, n_targets: int) -> np.ndarray:
    """ρ per target, (τ,), from a number or an array, each in [0, 1]."""
    array = _float_array(name, value)
    if array.ndim == 0:
        array = np.full(n_targets, float(array))
    if array.shape != (n_targets,):
        raise TrackingError(f"{name} must be a number or have shape ({n_targets},), got {array.shape}")
    if not np.isfinite(array).all() or (array < 0).any() or (array > 1).any():
        raise TrackingError(f"{name} must lie in [0, 1], got {array.tolist()!r}")
    return array


# -- log-domain helpers ---------------------------------------------------------------------------


def _segment_logsumexp(values: np.ndarray, owner: np.ndarray, n_targets: int) -> np.ndarray:
    """log Σ_{j of target k} exp(values[j]) per target and column; (P, m) → (τ, m), −inf for a zero sum."""
    n_columns = values.shape[1]
    peak = np.full((n_targets, n_columns), -np.inf)
    np.maximum.at(peak, owner, values)
    shift = np.where(np.isfinite(peak), peak, 0.0)
    slots = (owner[:, None] * n_columns + np.arange(n_columns)).ravel()
    totals = np.bincount(slots, weights=np.exp(values - shift[owner]).ravel(), minlength=n_targets * n_columns)
    with np.errstate(divide="ignore"):
        return shift + np.log(totals.reshape(n_targets, n_columns))


def _normalise_within(values: np.ndarray, owner: np.ndarray, n_targets: int,
                      counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Log-weights (P, m) normalised within every target and column, and the (τ, m) mask of zero sums.

    A target whose column is −inf everywhere gets uniform weights log(1/N) there.
    """
    total = _segment_logsumexp(values, owner, n_targets)
    degenerate = np.isneginf(total)
    normalised = values - np.where(degenerate, 0.0, total)[owner]
    uniform = -np.log(np.maximum(counts, 1))[owner][:, None]
    return np.where(degenerate[owner], uniform, normalised), degenerate


def _feature_log_weights(log_p: np.ndarray, owner: np.ndarray, n_targets: int, counts: np.ndarray) -> np.ndarray:
    """log w̃_i^j of C (12): feature i's likelihoods normalised over target's particles, (P, c)."""
    log_w, degenerate = _normalise_within(log_p, owner, n_targets, counts)
    if degenerate.any():
        target, feature = map(int, np.argwhere(degenerate)[0])
        warnings.warn(
            f"feature {feature} gives every particle of target {target} likelihood 0; using uniform weights instead",
            DegenerateWeightsWarning,
            stacklevel=3,
        )
    return log_w


def _groups(owner: np.ndarray, counts: np.ndarray) -> list[np.ndarray]:
    """The particle indices of every target, in particle order."""
    order = np.argsort(owner, kind="stable")
    return np.split(order, np.cumsum(counts)[:-1]) if counts.size else []


# -- configuration --------------------------------------------------------------------------------


@dataclass(frozen=True)
class AdaptiveConfig:
    """Settings of C's adaptive fusion (SPEC B.5 and C Table 2).

    Attributes
    ----------
    keep : float
        Fraction in (0, 1] of the resampled particles kept for the spread of C (11)
        (C's "Resampling 60%N"); m = ⌈keep·N⌉.
    threshold : float
        T in [0, 1]: a target is occluded when its total similarity ρ_t < T (C Table 2: 0.6).
    rho0 : float
        ρ_0 in [0, 1], the total similarity a new target starts with (C step 1: 0.8).
    mix_norm : {"per_term", "raw"}
        How C (14) mixes its product and sum terms: each normalised over the target's
        particles first (default), or ``"raw"``, the formula as printed; see
        :func:`fuse_adaptive`.
    epsilon : float
        ε > 0 added to the spread (s_i = tr Σ_i + ε) and in h_i = 1/(s_i·H_i + ε).

    Raises
    ------
    TrackingError
        A field out of its range or of the wrong kind; the message names the field.

    Examples
    --------
    >>> AdaptiveConfig()
    AdaptiveConfig(keep=0.6, threshold=0.6, rho0=0.8, mix_norm='per_term', epsilon=1e-06)
    >>> AdaptiveConfig(keep=0)
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: AdaptiveConfig.keep must be a number in (0, 1], got 0
    """

    keep: float = 0.6
    threshold: float = 0.6
    rho0: float = 0.8
    mix_norm: str = "per_term"
    epsilon: float = 1e-6

    def __post_init__(self) -> None:
        object.__setattr__(self, "keep", _keep("AdaptiveConfig.keep", self.keep))
        object.__setattr__(self, "threshold", _unit("AdaptiveConfig.threshold", self.threshold))
        object.__setattr__(self, "rho0", _unit("AdaptiveConfig.rho0", self.rho0))
        object.__setattr__(self, "epsilon", _epsilon("AdaptiveConfig.epsilon", self.epsilon))
        checks.choice("AdaptiveConfig.mix_norm", self.mix_norm, MIX_NORMS)


# -- C (11)–(13): how much to trust each feature --------------------------------------------------


def feature_spreads(
    positions: np.ndarray,
    log_p: np.ndarray,
    owner: np.ndarray,
    n_targets: int,
    rng: np.random.Generator,
    keep: float = 0.6,
    epsilon: float = 1e-6,
) -> np.ndarray:
    """Spatial spread of every feature's particle cloud, s_i = tr Σ_i + ε (C (11), SPEC default reading).

    For target k with N particles and feature i:

    1. resample N positions of the target's particles by feature i's normalised likelihoods
       w̃_i^j = p(z_i | x^j) / Σ_l p(z_i | x^l), systematically;
    2. keep the m = ⌈keep·N⌉ resampled positions nearest to the mean of all N (ties go to the
       earlier draw), so that a few migrating particles do not inflate the spread;
    3. C (11): Σ_i = (1/m) Σ_{j=1}^{m} (x_i^j − x̄_i)(x_i^j − x̄_i)ᵀ with x̄_i the mean of the m
       kept positions, and s_i = tr Σ_i + ε (the determinant would vanish for duplicated particles).

    Parameters
    ----------
    positions : array_like, shape (P, 2)
        Particle centres (x, y) in pixels.
    log_p : array_like, shape (P, c)
        log p(z_i | x^j) of every particle under its own target; −inf allowed.
    owner : array_like of int, shape (P,)
        Target of every particle, in 0..τ−1; every target needs a particle.
    n_targets : int
        τ.
    rng : numpy.random.Generator
        Source of the resampling offsets: one :func:`~belief_tracking.particles.systematic`
        draw per target and feature, targets outer, features inner.
    keep : float
        Fraction in (0, 1] of the resampled particles kept (C Table 2: 60 %).
    epsilon : float
        ε > 0 added to the trace.

    Returns
    -------
    ndarray, shape (τ, c)
        s_i per target and feature, at least ε, in squared pixels.

    Raises
    ------
    TrackingError
        Malformed shapes, an ``owner`` value out of range or a target with no particle,
        NaN or +inf in ``log_p``, non-finite positions, or ``keep``/``epsilon`` out of range.

    Examples
    --------
    Four particles at the corners of a 2-pixel square, equally likely under feature 0
    (each resampled once: the mean is (1, 1), every squared distance 2, so s = 2 + ε);
    feature 1 gives all its weight to the first particle (N copies of it: s = ε):

    >>> positions = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [2.0, 2.0]])
    >>> log_p = np.array([[0.0, 0.0], [0.0, -np.inf], [0.0, -np.inf], [0.0, -np.inf]])
    >>> feature_spreads(positions, log_p, np.zeros(4, int), 1, np.random.default_rng(0), keep=1.0).tolist()
    [[2.000001, 1e-06]]
    """
    log_p = _log_likelihoods(log_p)
    owner, counts, n_targets = _owner(owner, log_p.shape[0], n_targets)
    positions = _float_array("positions", positions)
    if positions.shape != (log_p.shape[0], 2):
        raise TrackingError(f"positions must have shape ({log_p.shape[0]}, 2), got {positions.shape}")
    if not np.isfinite(positions).all():
        raise TrackingError("positions must be finite")
    keep = _keep("keep", keep)
    epsilon = _epsilon("epsilon", epsilon)
    if not isinstance(rng, np.random.Generator):
        raise TrackingError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")

    return _spreads(positions, log_p, owner, n_targets, counts, rng, keep, epsilon)


def _spreads(positions: np.ndarray, log_p: np.ndarray, owner: np.ndarray, n_targets: int, counts: np.ndarray,
             rng: np.random.Generator, keep: float, epsilon: float) -> np.ndarray:
    """:func:`feature_spreads` of checked inputs, with each target's particle count."""
    weights = np.exp(_feature_log_weights(log_p, owner, n_targets, counts))
    spreads = np.empty((n_targets, log_p.shape[1]))
    for target, members in enumerate(_groups(owner, counts)):
        n = members.size
        # A product within rounding of an integer counts as that integer (0.6·100 → 60, not 61).
        m = min(max(math.ceil(keep * n - _TOLERANCE), 1), n)
        own_positions = positions[members]
        for feature in range(log_p.shape[1]):
            drawn = own_positions[systematic(weights[members, feature], rng, n)]          # (N, 2)
            distance = ((drawn - drawn.mean(axis=0)) ** 2).sum(axis=1)
            kept = drawn[np.argsort(distance, kind="stable")[:m]]                          # (m, 2)
            spreads[target, feature] = ((kept - kept.mean(axis=0)) ** 2).sum(axis=1).mean() + epsilon
    return spreads


def feature_entropies(log_p: np.ndarray, owner: np.ndarray, n_targets: int) -> np.ndarray:
    """Observation entropy of every feature, H_i = −Σ_j w̃_i^j log₂ w̃_i^j (C (12)).

    The weights w̃_i^j = p(z_i | x^j) / Σ_k p(z_i | x^k) are normalised over the target's own
    N particles (SPEC B.5: C prints the raw likelihoods, which are no distribution), with
    0·log 0 = 0.  H_i lies in [0, log₂ N]: 0 when one particle takes all the weight, log₂ N
    for equal weights.

    Parameters
    ----------
    log_p : array_like, shape (P, c)
        log p(z_i | x^j); −inf allowed.  Adding a constant to a target's column does not
        change its entropy.
    owner : array_like of int, shape (P,)
    n_targets : int

    Returns
    -------
    ndarray, shape (τ, c)
        Entropies in bits.

    Raises
    ------
    TrackingError
        Malformed shapes or ``owner``, NaN or +inf in ``log_p``.

    Examples
    --------
    Target 0 (particles 0, 2, 4) has weights (1/2, 1/4, 1/4): H = ½·1 + 2·¼·2 = 1.5 bits;
    target 1 (particles 1, 3) has equal weights: H = log₂ 2 = 1 bit.

    >>> log_p = np.log([[0.2], [0.7], [0.1], [0.7], [0.1]])
    >>> feature_entropies(log_p, np.array([0, 1, 0, 1, 0]), 2).round(12).tolist()
    [[1.5], [1.0]]
    """
    log_p = _log_likelihoods(log_p)
    owner, counts, n_targets = _owner(owner, log_p.shape[0], n_targets)
    return _entropies(log_p, owner, n_targets, counts)


def _entropies(log_p: np.ndarray, owner: np.ndarray, n_targets: int, counts: np.ndarray) -> np.ndarray:
    """:func:`feature_entropies` of checked inputs, with each target's particle count."""
    log_w = _feature_log_weights(log_p, owner, n_targets, counts)
    # 0·log 0 = 0: w̃ = 0 exactly where log w̃ = −inf, or where it underflows.
    terms = np.exp(log_w) * np.where(np.isfinite(log_w), log_w, 0.0) / math.log(2.0)
    slots = (owner[:, None] * log_p.shape[1] + np.arange(log_p.shape[1])).ravel()
    sums = np.bincount(slots, weights=terms.ravel(), minlength=n_targets * log_p.shape[1])
    return np.maximum(-sums.reshape(n_targets, log_p.shape[1]), 0.0)  # rounding can give −0.0 or −1e-17


def feature_confidences(spreads: np.ndarray, entropies: np.ndarray, epsilon: float = 1e-6) -> np.ndarray:
    """Feature confidences λ_i = h_i / Σ_k h_k with h_i = 1/(s_i·H_i + ε) (C "Define 3", C (13)).

    A feature whose particles are concentrated (small s_i) *and* whose weights are
    discriminative (small H_i) gets a large weight (SPEC B.5: product form of the garbled
    performance index).  Each row sums to 1.

    Parameters
    ----------
    spreads : array_like, shape (τ, c)
        s_i of :func:`feature_spreads`, finite and non-negative.
    entropies : array_like, shape (τ, c)
        H_i of :func:`feature_entropies`, finite and non-negative.
    epsilon : float
        ε > 0, which bounds h_i by 1/ε when s_i·H_i = 0 (e.g. a one-particle target).

    Returns
    -------
    ndarray, shape (τ, c)
        λ, rows summing to 1.

    Raises
    ------
    TrackingError
        Shapes that differ or are not 2-D, negative or non-finite entries, ``epsilon`` ≤ 0.

    Examples
    --------
    s = (2, 1), H = (1, 1): h ≈ (1/2, 1), so λ ≈ (1/3, 2/3).

    >>> feature_confidences([[2.0, 1.0]], [[1.0, 1.0]], epsilon=1e-12).round(9).tolist()
    [[0.333333333, 0.666666667]]
    """
    spreads = _float_array("spreads", spreads)
    if spreads.ndim != 2:
        raise TrackingError(f"spreads must have shape (τ, c), got {spreads.shape}")
    spreads = _per_target("spreads", spreads, spreads.shape[0])
    entropies = _per_target("entropies", entropies, spreads.shape[0], spreads.shape[1])
    return _confidences(spreads, entropies, _epsilon("epsilon", epsilon))


def _confidences(spreads: np.ndarray, entropies: np.ndarray, epsilon: float) -> np.ndarray:
    """:func:`feature_confidences` of checked inputs."""
    index = 1.0 / (spreads * entropies + epsilon)   # h_i ∈ (0, 1/ε]
    return index / index.sum(axis=1, keepdims=True)


# -- C (14): fusion -------------------------------------------------------------------------------


def fuse_product(log_p: np.ndarray, owner: np.ndarray, n_targets: int) -> np.ndarray:
    """Product rule: log Π_i p(z_i | x^j) = Σ_i log p(z_i | x^j) (the first term of C (14); ablation ``"product"``).

    Parameters
    ----------
    log_p : array_like, shape (P, c)
    owner : array_like of int, shape (P,)
        Only checked: the product needs no per-target quantity.
    n_targets : int

    Returns
    -------
    ndarray, shape (P,)
        Unnormalised log-weights; −inf where any feature is −inf.

    Examples
    --------
    >>> np.exp(fuse_product(np.log([[0.5, 0.2], [0.1, 0.4]]), np.array([0, 0]), 1)).round(12).tolist()
    [0.1, 0.04]
    """
    log_p = _log_likelihoods(log_p)
    _owner(owner, log_p.shape[0], n_targets)
    return log_p.sum(axis=1)


def _log_sum_term(log_p: np.ndarray, owner: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """log Σ_i λ_i p(z_i | x^j) per particle, by log-sum-exp over the features."""
    with np.errstate(divide="ignore"):
        terms = np.log(lam)[owner] + log_p                          # (P, c); λ_i = 0 gives −inf
    peak = terms.max(axis=1)
    shift = np.where(np.isfinite(peak), peak, 0.0)
    with np.errstate(divide="ignore"):
        return shift + np.log(np.exp(terms - shift[:, None]).sum(axis=1))


def fuse_sum(log_p: np.ndarray, owner: np.ndarray, n_targets: int, lam: Optional[np.ndarray] = None) -> np.ndarray:
    """Sum rule: log Σ_i λ_i p(z_i | x^j) (the second term of C (14); ablations ``"sum"`` and ``"fixed"``).

    Parameters
    ----------
    log_p : array_like, shape (P, c)
    owner : array_like of int, shape (P,)
    n_targets : int
    lam : array_like, shape (τ, c), optional
        Weights per target, each row divided by its sum (C (13) rows already sum to 1);
        equal weights 1/c when omitted.

    Returns
    -------
    ndarray, shape (P,)
        Unnormalised log-weights; −inf only where every feature with weight is −inf.

    Raises
    ------
    TrackingError
        Malformed inputs, a negative or non-finite λ, or a λ row summing to 0.

    Examples
    --------
    Likelihoods (0.5, 0.2) and (0.1, 0.4): equal weights give 0.35 and 0.25; λ = (1/4, 3/4)
    gives 0.125 + 0.15 = 0.275 and 0.025 + 0.3 = 0.325.

    >>> log_p, owner = np.log([[0.5, 0.2], [0.1, 0.4]]), np.array([0, 0])
    >>> np.exp(fuse_sum(log_p, owner, 1)).round(12).tolist()
    [0.35, 0.25]
    >>> np.exp(fuse_sum(log_p, owner, 1, lam=[[0.25, 0.75]])).round(12).tolist()
    [0.275, 0.325]
    """
    log_p = _log_likelihoods(log_p)
    owner, _, n_targets = _owner(owner, log_p.shape[0], n_targets)
    n_features = log_p.shape[1]
    if lam is None:
        lam = np.full((n_targets, n_features), 1.0 / n_features)
    else:
        lam = _confidence_rows("lam", lam, n_targets, n_features)
    return _log_sum_term(log_p, owner, lam)


def fuse_adaptive(
    log_p: np.ndarray,
    owner: np.ndarray,
    n_targets: int,
    lam: np.ndarray,
    rho_prev: Union[float, np.ndarray],
    mix_norm: str = "per_term",
) -> np.ndarray:
    """Adaptive fusion of the product and the confidence-weighted sum rules (C (14)).

    p(z_t | x^j) = ρ_{t−1} Π_i p(z_{i,t} | x^j) + (1 − ρ_{t−1}) Σ_i λ_{i,t} p(z_{i,t} | x^j),

    with ρ_{t−1} multiplying the product term (SPEC B.5: when an occlusion starts the
    similarity drops and the multiplicative weight falls).  The two terms live on different
    scales, a product of c densities against a convex sum, so by default
    (``mix_norm="per_term"``, SPEC B.5) each term is first normalised over the target's
    particles, P̃^j = Π^j / Σ_l Π^l and S̃^j = S^j / Σ_l S^l, and the result
    ρ_{t−1} P̃^j + (1 − ρ_{t−1}) S̃^j sums to 1 over the target.  Everything stays in the log
    domain (log-sum-exp), so log-likelihoods of −800 mix correctly.  A term that is 0 for every
    particle of a target carries no information there and is dropped (the other term gets
    weight 1); if both are, the target's weights are uniform, with a
    :class:`~belief_tracking.particles.DegenerateWeightsWarning`.

    ``mix_norm="raw"`` is the formula as printed, on the likelihoods as given: SPEC B.5 pairs
    it with likelihoods without their 1/(√(2π)σ) factor, i.e. log_p = −d²/(2σ²).

    Parameters
    ----------
    log_p : array_like, shape (P, c)
    owner : array_like of int, shape (P,)
    n_targets : int
    lam : array_like, shape (τ, c)
        Confidences λ_{i,t} (C (13)); each row is divided by its sum.
    rho_prev : float or array_like, shape (τ,)
        ρ_{t−1} in [0, 1] per target (C (15) of the previous frame; ρ_0 = 0.8).
    mix_norm : {"per_term", "raw"}

    Returns
    -------
    ndarray, shape (P,)
        Log-weights: normalised within every target for ``"per_term"``, the log of the printed
        C (14) for ``"raw"``.  ρ_{t−1} = 1 gives the product rule, ρ_{t−1} = 0 the λ-sum rule.

    Raises
    ------
    TrackingError
        Malformed inputs, ``rho_prev`` outside [0, 1], an unknown ``mix_norm``.

    Examples
    --------
    Likelihoods (0.5, 0.2) and (0.1, 0.4), λ = (1/4, 3/4), ρ_{t−1} = 1/2: the product term
    (0.1, 0.04) normalises to (5/7, 2/7), the sum term (0.275, 0.325) to (11/24, 13/24), and
    ½·(5/7 + 11/24) = 197/336, ½·(2/7 + 13/24) = 139/336.

    >>> log_p, owner, lam = np.log([[0.5, 0.2], [0.1, 0.4]]), np.array([0, 0]), [[0.25, 0.75]]
    >>> weights = np.exp(fuse_adaptive(log_p, owner, 1, lam, 0.5))
    >>> bool(np.allclose(weights, [197 / 336, 139 / 336]))
    True
    """
    log_p = _log_likelihoods(log_p)
    owner, counts, n_targets = _owner(owner, log_p.shape[0], n_targets)
    _confidence_rows("lam", lam, n_targets, log_p.shape[1])
    rho = _similarities("rho_prev", rho_prev, n_targets)
    if mix_norm not in MIX_NORMS:
        raise TrackingError(f"mix_norm must be one of {', '.join(MIX_NORMS)}, got {mix_norm!r}")
    return _mix(log_p, owner, n_targets, counts, _float_array("lam", lam), rho, mix_norm)


def _mix(log_p: np.ndarray, owner: np.ndarray, n_targets: int, counts: np.ndarray, lam: np.ndarray,
         rho: np.ndarray, mix_norm: str) -> np.ndarray:
    """:func:`fuse_adaptive` of checked inputs; ``lam`` non-negative, rows with some weight."""
    lam = lam / lam.sum(axis=1)[:, None]                                               # each row sums to 1
    terms = np.stack([log_p.sum(axis=1), _log_sum_term(log_p, owner, lam)], axis=1)   # (P, 2): product, sum
    if mix_norm == "per_term":
        terms, empty = _normalise_within(terms, owner, n_targets, counts)
        # A term with no mass on a target is dropped there; if both are, both are uniform and ρ is irrelevant.
        rho = np.where(empty[:, 0], 0.0, np.where(empty[:, 1], 1.0, rho))
        if (empty[:, 0] & empty[:, 1]).any():
            target = int(np.argmax(empty[:, 0] & empty[:, 1]))
            warnings.warn(
                f"every particle of target {target} has likelihood 0 under both terms of C (14); "
                "using uniform weights instead",
                DegenerateWeightsWarning,
                stacklevel=2,
            )
    with np.errstate(divide="ignore"):
        log_rho, log_rest = np.log(rho)[owner], np.log1p(-rho)[owner]
    return np.logaddexp(log_rho + terms[:, 0], log_rest + terms[:, 1])


# -- C (15), occlusion, C (16) --------------------------------------------------------------------


def total_similarity(lam: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """Total similarity of every target's template, ρ_t = Σ_i λ_{i,t} ρ_{i,t} (C (15)).

    λ is renormalised over the features given, so a caller may pass only some columns (e.g.
    the appearance features of a larger cue set).  ρ_{i,t} is the Bhattacharyya coefficient
    of feature i (C (9)), by default at the estimate, ρ[p_i(x̂_t), q̂_{i,t−1}] (SPEC B.5).

    Parameters
    ----------
    lam : array_like, shape (τ, k)
        Confidences λ (C (13)), non-negative, no row all zero.
    rho : array_like, shape (τ, k)
        Per-feature similarities ρ_{i,t} in [0, 1].

    Returns
    -------
    ndarray, shape (τ,)
        ρ_t in [0, 1].

    Raises
    ------
    TrackingError
        Shapes that differ or are not 2-D, a λ row summing to 0, a ρ outside [0, 1].

    Examples
    --------
    λ = (0.2, 0.6) renormalises to (1/4, 3/4); with ρ = (0.8, 0.4): 0.2 + 0.3 = 0.5.

    >>> total_similarity([[0.2, 0.6]], [[0.8, 0.4]]).round(12).tolist()
    [0.5]
    """
    lam = _float_array("lam", lam)
    if lam.ndim != 2 or lam.shape[1] == 0:
        raise TrackingError(f"lam must have shape (τ, k) with k >= 1, got {lam.shape}")
    lam = _confidence_rows("lam", lam, lam.shape[0])
    rho = _per_target("rho", rho, lam.shape[0], lam.shape[1])
    if (rho > 1).any():
        raise TrackingError(f"rho must lie in [0, 1], got maximum {rho.max()!r}")
    return np.clip((lam * rho).sum(axis=1), 0.0, 1.0)


def occluded(rho_t: np.ndarray, threshold: float = 0.6) -> np.ndarray:
    """Occlusion test ρ_t < T (SPEC B.5, occlusion detection; C Table 2: T = 0.6).

    Parameters
    ----------
    rho_t : array_like, shape (τ,)
        Total similarities (C (15)), finite.
    threshold : float
        T in [0, 1].

    Returns
    -------
    ndarray of bool, shape (τ,)
        True where the target counts as occluded; ρ_t = T exactly is not.

    Examples
    --------
    >>> occluded([0.59, 0.6, 0.61]).tolist()
    [True, False, False]
    """
    rho_t = _float_array("rho_t", rho_t)
    if rho_t.ndim != 1:
        raise TrackingError(f"rho_t must have shape (τ,), got {rho_t.shape}")
    if not np.isfinite(rho_t).all():
        raise TrackingError("rho_t must be finite")
    return rho_t < _unit("threshold", threshold)


def _histograms(name: str, value: object, shape: Optional[tuple[int, ...]] = None) -> np.ndarray:
    array = _float_array(name, value)
    if array.ndim != 2 or array.shape[1] == 0 or (shape is not None and array.shape != shape):
        expected = "(τ, B)" if shape is None else str(shape)
        raise TrackingError(f"{name} must have shape {expected}, got {array.shape}")
    if not np.isfinite(array).all() or (array < 0).any():
        raise TrackingError(f"{name} must be finite and non-negative")
    return array


def update_templates(
    q_init: np.ndarray,
    q_prev: np.ndarray,
    p_cur: np.ndarray,
    occluded: np.ndarray,
) -> np.ndarray:
    """Template update of one feature for every target, frozen under occlusion (C (16), reconstructed).

    With β = ρ[q_init, p̂_cur] = Σ_u √(q_init(u) p̂_cur(u)) (C (9); SPEC B.5, variant A):

        p_c = β q̂_{t−1} + (1 − β) p̂_cur,
        q̂_t = β q_init + (1 − β) p_c        if ρ_t ≥ T,     q̂_t = q̂_{t−1}   if ρ_t < T.

    An initial template that still fits is kept; one that fits badly hands over to the
    recent appearance.  p̂_cur is p_cur divided by its row sum: a foreground-masked
    histogram sums to its foreground fraction F ≤ 1.  A p_cur row summing to 0 (nothing seen)
    keeps q̂_{t−1}, as does occlusion; those rows are returned bit for bit.

    Parameters
    ----------
    q_init : array_like, shape (τ, B)
        Initial templates q_{i,init}, rows summing to 1.
    q_prev : array_like, shape (τ, B)
        Previous templates q̂_{i,t−1}, rows summing to 1.
    p_cur : array_like, shape (τ, B)
        Current appearance p_i(x̂_t), non-negative; rows need not sum to 1.
    occluded : array_like of bool, shape (τ,)
        ρ_t < T per target, e.g. from :func:`occluded`.

    Returns
    -------
    ndarray, shape (τ, B)
        q̂_{i,t}, rows summing to 1.

    Raises
    ------
    TrackingError
        Shapes that differ, negative or non-finite bins, a template row whose sum is not 1,
        a non-boolean ``occluded``.

    Examples
    --------
    q_init = (1, 0), q̂_{t−1} = (½, ½), p_cur = (0.32, 0.18), which sums to F = ½ and
    normalises to (0.64, 0.36), so β = √0.64 = 0.8: p_c = 0.8·(½, ½) + 0.2·(0.64, 0.36)
    = (0.528, 0.472), q̂ = 0.8·(1, 0) + 0.2·(0.528, 0.472) = (0.9056, 0.0944).  Under occlusion
    q̂_{t−1} stays.

    >>> q_init, q_prev, p_cur = [[1.0, 0.0]], [[0.5, 0.5]], [[0.32, 0.18]]
    >>> update_templates(q_init, q_prev, p_cur, [False]).round(12).tolist()
    [[0.9056, 0.0944]]
    >>> update_templates(q_init, q_prev, p_cur, [True]).tolist()
    [[0.5, 0.5]]
    """
    q_init = _histograms("q_init", q_init)
    q_prev = _histograms("q_prev", q_prev, q_init.shape)
    p_cur = _histograms("p_cur", p_cur, q_init.shape)
    for name, templates in (("q_init", q_init), ("q_prev", q_prev)):
        if (np.abs(templates.sum(axis=1) - 1.0) > _HISTOGRAM_TOLERANCE).any():
            raise TrackingError(f"{name} rows must sum to 1, got sums {templates.sum(axis=1).tolist()!r}")
    frozen = np.asarray(occluded)
    if frozen.dtype != np.bool_ or frozen.shape != (q_init.shape[0],):
        raise TrackingError(
            f"occluded must be a boolean array of shape ({q_init.shape[0]},), got {frozen.dtype} {frozen.shape}"
        )

    mass = p_cur.sum(axis=1)
    seen = mass > 0
    current = p_cur / np.where(seen, mass, 1.0)[:, None]
    beta = np.clip(np.sqrt(q_init * current).sum(axis=1), 0.0, 1.0)[:, None]      # C (9), (τ, 1)
    blend = beta * q_prev + (1.0 - beta) * current                                   # p_c
    updated = beta * q_init + (1.0 - beta) * blend
    totals = updated.sum(axis=1, keepdims=True)                                      # 1 ± rounding where seen
    updated /= np.where(seen[:, None], totals, 1.0)
    return np.where((seen & ~frozen)[:, None], updated, q_prev)


# -- the weighting strategy ----------------------------------------------------------------------


class AdaptiveWeighting:
    """C's adaptive fusion as a weighting strategy (Algorithm C, steps 3–4; C (11)–(14)).

    Every frame: the spread s_i (C (11)) and the entropy H_i (C (12)) of every cue's scores
    within each target's particles give the confidences λ (C (13)), and the log-weights mix
    the product and the λ-weighted sum of the cues' own-target likelihoods, the product's
    share being the target's total similarity ρ_{t−1} of the previous frame (C (14)), read
    from the evidence.

    Parameters
    ----------
    config : AdaptiveConfig
    cues : sequence of str
        The cue names, in score order (for the diagnostics' column names).
    rng : numpy.random.Generator
        Draws the systematic resampling of the spreads (C (11)).

    Attributes
    ----------
    columns : tuple of str
        ``confidence_<cue>`` per cue: λ of every target (C (13)).

    Examples
    --------
    >>> from belief_tracking.weighting import Evidence
    >>> scores = (np.log([[0.5, 0.1], [0.1, 0.1]]), np.log([[0.2, 0.1], [0.4, 0.1]]))
    >>> evidence = Evidence(scores, np.array([0, 0]), np.array([[0.0, 0.0], [2.0, 0.0]]))
    >>> weighing = AdaptiveWeighting(AdaptiveConfig(), ("colour", "edges"), np.random.default_rng(0)).weigh(evidence)
    >>> weighing.confidences.shape, bool(np.isclose(np.exp(weighing.log_weights).sum(), 1.0))
    ((1, 2), True)
    """

    def __init__(self, config: AdaptiveConfig, cues, rng: np.random.Generator) -> None:
        self.config = config
        self.columns = tuple(f"confidence_{name}" for name in cues)
        self.rng = rng

    def weigh(self, evidence: Evidence) -> Weighing:
        config, tau = self.config, evidence.n_targets
        own, owner, counts = evidence.own, evidence.owner, evidence.counts
        # The evidence comes checked from the tracker: the kernels, not the checked functions.
        spreads = _spreads(evidence.positions, own, owner, tau, counts, self.rng, config.keep, config.epsilon)  # C (11)
        confidences = _confidences(spreads, _entropies(own, owner, tau, counts), config.epsilon)   # C (12)–(13)
        previous = evidence.similarity if evidence.similarity is not None else np.full(tau, config.rho0)
        log_weights = _mix(own, owner, tau, counts, confidences, np.asarray(previous, dtype=np.float64),
                           config.mix_norm)                                                       # C (14)
        diagnostics = {column: confidences[:, k] for k, column in enumerate(self.columns)}
        return Weighing(log_weights, diagnostics, confidences)


class SumWeighting:
    """Equal-weight sum of the cues' own-target likelihoods: log Σ_i p_i / c (the sum term of C (14)).

    >>> scores = (np.log([[0.5, 0.1]]), np.log([[0.1, 0.1]]))
    >>> np.exp(SumWeighting().weigh(Evidence(scores, np.array([0]), np.zeros((1, 2)))).log_weights).round(12)
    array([0.3])
    """

    columns: tuple[str, ...] = ()

    def __repr__(self) -> str:
        return "SumWeighting()"

    def weigh(self, evidence: Evidence) -> Weighing:
        own = evidence.own
        return Weighing(_log_sum_term(own, evidence.owner, np.full((evidence.n_targets, own.shape[1]),
                                                                   1.0 / own.shape[1])))


class ProductWeighting:
    """Product of the cues' own-target likelihoods: Σ_i log p_i (the product term of C (14)).

    >>> scores = (np.log([[0.5, 0.1]]), np.log([[0.2, 0.1]]))
    >>> np.exp(ProductWeighting().weigh(Evidence(scores, np.array([0]), np.zeros((1, 2)))).log_weights).round(12)
    array([0.1])
    """

    columns: tuple[str, ...] = ()

    def __repr__(self) -> str:
        return "ProductWeighting()"

    def weigh(self, evidence: Evidence) -> Weighing:
        return Weighing(evidence.own.sum(axis=1))
