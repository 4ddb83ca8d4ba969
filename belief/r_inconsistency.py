"""The inconsistency R of W (10) between rows of two arrays aligned on the same focal elements.

:func:`aligned_inconsistency` gives R in any of its three modes for arrays aligned on a focal list,
:func:`paper_inconsistency` the printed R from its two sums, and :func:`bayesian_inconsistency` R between two
Bayesian batches in O(n) per row.  :func:`belief.rules.inconsistency` takes batches and mass functions.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from belief.bayesian_split import ExclusiveSplit

__all__ = ["aligned_inconsistency", "bayesian_inconsistency", "paper_inconsistency"]


def bayesian_inconsistency(m1: np.ndarray, m2: np.ndarray, split: ExclusiveSplit, r_mode: str) -> np.ndarray:
    """R of W (10) between two Bayesian batches in frame order, shape (N,): O(n) per row.

    ``paper`` and ``euclid`` are computed as :func:`belief.rules.inconsistency` does on the
    same columns; ``jousselme`` uses D(θ_i, θ_l) = C(θ_i∩θ_l)/C(θ_i∪θ_l) = 1/3 for two free
    hypotheses and 0 otherwise off the diagonal, so ΔᵀDΔ = Σ Δ² + ((Σ_O Δ)² − Σ_O Δ²) / 3.

    Parameters
    ----------
    m1, m2 : ndarray, shape (N, n)
    split : ExclusiveSplit
    r_mode : {"paper", "euclid", "jousselme"}

    Examples
    --------
    SPEC A.4: paper R = .632 and euclid R = .400 for (.6, .3, .1) against (.2, .7, .1).

    >>> from belief import Model, exclusive_split
    >>> split = exclusive_split(Model.for_targets(2))
    >>> a, b = np.array([[.6, .3, .1]]), np.array([[.2, .7, .1]])
    >>> [float(bayesian_inconsistency(a, b, split, mode)[0].round(4)) for mode in ("paper", "euclid")]
    [0.6325, 0.4]
    """
    def jousselme(delta: np.ndarray) -> np.ndarray:
        free = delta[:, split.o_index]
        squares = (free * free).sum(axis=1)
        free_sum = free.sum(axis=1)
        excl = delta[:, split.e_index]
        # (Σ Δ)² − Σ Δ² is exactly 0 when a single free hypothesis differs, so sources on two
        # disjoint singletons give exactly R = 1, as the general path does.
        return 0.5 * ((excl * excl).sum(axis=1) + squares + (free_sum * free_sum - squares) / 3.0)

    return aligned_inconsistency(m1, m2, r_mode, jousselme)[0]


def aligned_inconsistency(m1: np.ndarray, m2: np.ndarray, r_mode: str,
                          jousselme: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """R of W (10) between rows of two arrays aligned on the same focal elements, and 1 − R; shapes (N,).

    ``jousselme(delta)`` returns ½ ΔᵀDΔ for the rows of ``delta = m1 − m2``; it is called only
    when ``r_mode == "jousselme"``, so each caller supplies the form its columns allow.  For
    ``paper``, 1 − R keeps its relative precision when R is near 1 (:func:`paper_inconsistency`).
    """
    delta = m1 - m2
    if r_mode == "paper":
        return paper_inconsistency(np.abs(delta).sum(axis=1) / 2.0, np.minimum(m1, m2).sum(axis=1))
    if r_mode == "euclid":
        value = 0.5 * (delta * delta).sum(axis=1)
    else:
        value = jousselme(delta)
    r = np.sqrt(np.clip(value, 0.0, 1.0))
    return r, 1.0 - r


def paper_inconsistency(half_distance: np.ndarray, overlap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R of W (10) as printed, and 1 − R, from Σ_A |Δ(A)| / 2 and the overlap Σ_A min(m1(A), m2(A)).

    For two mass functions that sum to 1, Σ |Δ| / 2 = 1 − Σ min(m1, m2).  Where the overlap is
    below ½ (R above 0.71), R = sqrt(1 − overlap) and 1 − R = overlap / (1 + R): a sum of
    non-negative terms, so 1 − R keeps its relative precision when the sources barely overlap.
    Taken as 1 − sqrt(Σ|Δ|/2), it would be rounding noise of 1e-16 where the exact value is,
    say, 1e-200, and the shares (1 − R)·k it sends to A, B and A ∪ B would be noise that the
    next fold's m0 weights magnify.  Sources with no common focal element have overlap 0, so
    R = 1 and 1 − R = 0 exactly (SPEC A.4).

    Parameters
    ----------
    half_distance, overlap : ndarray, shape (N,)

    Returns
    -------
    r, rho : ndarray, shape (N,)
        R and 1 − R.

    Examples
    --------
    >>> r, rho = paper_inconsistency(np.array([0.4, 1.0 - 1e-200]), np.array([0.6, 1e-200]))
    >>> r.round(4), rho[1]
    (array([0.6325, 1.    ]), np.float64(5e-201))
    """
    far = overlap < 0.5
    r = np.sqrt(np.where(far, 1.0 - overlap, np.clip(half_distance, 0.0, 1.0)))
    return r, np.where(far, overlap / (1.0 + r), 1.0 - r)
