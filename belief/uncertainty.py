"""Uncertainty measures of a mass function, in bits.

Each measure takes a :class:`~belief.mass.MassFunction` (and gives a float) or a
:class:`~belief.batch.MassBatch` of N rows (and gives an ndarray of shape (N,)).

* how imprecise the evidence is: :func:`nonspecificity` (Dubois–Prade);
* how much it disagrees with itself: :func:`discord` (Klir–Ramer), :func:`dissonance`
  (Yager), :func:`confusion` (Höhle);
* both at once: :func:`deng_entropy` (Deng) and :func:`ambiguity` (Jousselme et al.);
* :func:`uncertainty`: all of them by name (:data:`MEASURES`).

Where the literature reads a measure on D^Θ through the DSm cardinality C_M(A) (the number
of Venn regions of A that the model allows, :meth:`~belief.model.Model.cardinality`), so
does this module: nonspecificity, discord, dissonance and confusion are defined under every
model, and equal the classical measures on Shafer's model, where C_M(A) = |A|.  Deng's
entropy (which counts the 2^|A| - 1 subsets of A) and the ambiguity measure (the Shannon
entropy of the pignistic probabilities of the hypotheses, which must be exclusive) are
defined on power-set models only: Shafer's model, or a hybrid model whose hypotheses are
pairwise exclusive.  All of them need a normal mass function (m(∅) = 0).  Where a measure
is undefined, :class:`~belief.errors.UndefinedMeasureError` says why.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import Union

import numpy as np

from belief.batch import MassBatch, measure_plan
from belief.distances import _as_batch
from belief.errors import UndefinedMeasureError, UnknownMeasureError
from belief.mass import MassFunction
from belief.model import Model
from belief.plan import weighted_sum

__all__ = ["nonspecificity", "deng_entropy", "ambiguity", "discord", "dissonance", "confusion", "uncertainty",
           "MEASURES", "is_power_set_model"]

Source = Union[MassFunction, MassBatch]


@lru_cache(maxsize=256)
def is_power_set_model(model: Model) -> bool:
    """True if the hypotheses are pairwise exclusive under the model, so that D^Θ is a power set.

    That is Shafer's model, or a hybrid model that declares every θ_i ∩ θ_j empty (and
    possibly some hypotheses too).  There C_M(A) = |A|, the number of (non-empty)
    hypotheses in A.

    >>> from belief import Frame, Model
    >>> f = Frame(["a", "b", "c"])
    >>> is_power_set_model(Model.shafer(f)), is_power_set_model(Model.hybrid(f, ["a&b"]))
    (True, False)
    >>> is_power_set_model(Model.hybrid(f, ["a&b", "a&c", "b&c"]))
    True
    """
    n = len(model.frame)
    return all(model.is_forbidden((1 << i) | (1 << j)) for i in range(n) for j in range(i + 1, n))


def _prepare(m: Source, name: str, power_set: bool = False) -> tuple[MassBatch, bool, np.ndarray]:
    """The batch, whether it was one mass function, and the cardinalities C_M of its focal elements (K,)."""
    batch, single = _as_batch(m, "the mass function")
    model = batch.model
    if power_set and not is_power_set_model(model):
        raise UndefinedMeasureError(
            f"{name} is defined on power sets only (pairwise exclusive hypotheses, as in Shafer's model), "
            f"not on the {model.kind} model; read the evidence under Shafer's model first (MassFunction.under)"
        )
    cards = measure_plan(model, batch.focal, ()).focal_cardinality
    empty = cards == 0
    if empty.any():
        held = batch.values[:, empty].sum(axis=1) > 0
        if held.any():
            where = f" (row {int(np.flatnonzero(held)[0])})" if len(batch) > 1 else ""
            raise UndefinedMeasureError(
                f"{name} is undefined for a mass function with m(∅) > 0{where}; normalise it first "
                "(MassFunction.normalized)"
            )
    return batch, single, cards


def _result(values: np.ndarray, single: bool):
    values = np.maximum(values, 0.0)          # rounding may leave -1e-17 where the value is 0
    return float(values[0]) if single else values


def _weighted_log(masses: np.ndarray, of: np.ndarray) -> np.ndarray:
    """Σ_k m_k log2 q_k over the entries with m_k > 0, per row; q is clipped to (0, 1]."""
    live = masses > 0
    q = np.where(live, np.minimum(of, 1.0), 1.0)
    return np.where(live, masses * np.log2(q), 0.0).sum(axis=1)


def nonspecificity(m: Source):
    """Dubois and Prade's nonspecificity: how imprecise the focal elements are, in bits.

    N(m) = Σ_A m(A) log2 |A|, the mass-weighted Hartley measure of the focal elements, with
    |A| read as the DSm cardinality C_M(A) on D^Θ.  It is 0 exactly for Bayesian mass
    functions on Shafer's model (every focal element a single hypothesis) and log2 n for
    total ignorance over n exclusive hypotheses.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Normal (m(∅) = 0), under any model.

    Returns
    -------
    float or ndarray of shape (N,)

    Raises
    ------
    UndefinedMeasureError
        If m(∅) > 0.

    References
    ----------
    D. Dubois, H. Prade, "A note on measures of specificity for fuzzy sets", International
    Journal of General Systems 10(4), 1985, pp. 279–283.

    Examples
    --------
    >>> from belief import Frame, MassFunction, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c", "d"]))
    >>> nonspecificity(MassFunction({"a|b": 0.5, "a|b|c|d": 0.5}, model=shafer))   # 0.5 · 1 + 0.5 · 2
    1.5
    >>> round(nonspecificity(MassFunction({"a|b": 1.0}, frame=["a", "b"], model="free")), 6)   # 3 regions
    1.584963
    """
    batch, single, cards = _prepare(m, "the nonspecificity")
    return _result(weighted_sum(batch.values, np.log2(np.maximum(cards, 1.0))[:, None])[:, 0], single)


def deng_entropy(m: Source):
    """Deng's entropy: nonspecificity and discord in one Shannon-like sum, in bits.

    E_d(m) = -Σ_A m(A) log2( m(A) / (2^|A| - 1) ), where 2^|A| - 1 counts the non-empty
    subsets of A.  It equals the Shannon entropy of m for Bayesian mass functions, is 0 for a
    categorical mass on one hypothesis and log2(2^n - 1) for total ignorance over n.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Normal, under a power-set model (see :func:`is_power_set_model`).

    Returns
    -------
    float or ndarray of shape (N,)

    Raises
    ------
    UndefinedMeasureError
        If m(∅) > 0, or the hypotheses are not exclusive under the model (2^|A| - 1 counts
        subsets of a set, which an element of D^Θ is not).

    References
    ----------
    Y. Deng, "Deng entropy", Chaos, Solitons & Fractals 91, 2016, pp. 549–553.

    Examples
    --------
    Deng's (2016) first examples: m(a) = 1, then m(a) = m(b) = m(c) = 1/3, then m(a ∪ b ∪ c) = 1.

    >>> from belief import Frame, MassFunction, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> deng_entropy(MassFunction({"a": 1.0}, model=shafer))
    0.0
    >>> round(deng_entropy(MassFunction({"a": 1 / 3, "b": 1 / 3, "c": 1 / 3}, model=shafer)), 4)   # log2 3
    1.585
    >>> round(deng_entropy(MassFunction.vacuous(model=shafer)), 4)   # log2 7
    2.8074
    """
    batch, single, cards = _prepare(m, "Deng's entropy", power_set=True)
    c = np.maximum(cards, 1.0)
    log_subsets = c + np.log2(-np.expm1(-c * math.log(2.0)))     # log2(2^C - 1), exact for large C
    values = batch.values
    return _result(weighted_sum(values, log_subsets[:, None])[:, 0] - _weighted_log(values, values), single)


def ambiguity(m: Source):
    """Jousselme et al.'s ambiguity measure: the Shannon entropy of the pignistic probabilities, in bits.

    AM(m) = -Σ_i BetP(θ_i) log2 BetP(θ_i), with BetP(θ_i) = Σ_{A ∋ θ_i} m(A) / |A|.  It is
    log2 n for total ignorance over n hypotheses and the Shannon entropy of m for Bayesian
    mass functions.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Normal, under a power-set model (BetP of the hypotheses must be a probability
        distribution, so the hypotheses must be exclusive).

    Returns
    -------
    float or ndarray of shape (N,)

    Raises
    ------
    UndefinedMeasureError
        If m(∅) > 0, or the hypotheses are not exclusive under the model.

    References
    ----------
    A.-L. Jousselme, C. Liu, D. Grenier, É. Bossé, "Measuring ambiguity in the evidence theory",
    IEEE Transactions on Systems, Man, and Cybernetics, Part A 36(5), 2006, pp. 890–903.

    Examples
    --------
    Zadeh's first expert, m(a) = 0.9 and m(c) = 0.1, and total ignorance over three hypotheses:

    >>> from belief import Frame, MassFunction, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> round(ambiguity(MassFunction({"a": 0.9, "c": 0.1}, model=shafer)), 6)   # H(0.9, 0.1)
    0.468996
    >>> round(ambiguity(MassFunction.vacuous(model=shafer)), 6)                  # log2 3
    1.584963
    """
    batch, single, _ = _prepare(m, "the ambiguity measure", power_set=True)
    p = batch.pignistic()
    return _result(-_weighted_log(p, p), single)


def discord(m: Source):
    """Klir and Ramer's discord: how much the focal elements disagree, in bits.

    D(m) = -Σ_A m(A) log2 Σ_B m(B) |A ∩ B| / |B| = -Σ_A m(A) log2 BetP(A), with |·| read as
    the DSm cardinality C_M on D^Θ (so that the inner sum is the generalised pignistic
    probability BetP(A) of Dezert and Smarandache).  It is 0 for a categorical or a vacuous
    mass function and the Shannon entropy of m for Bayesian ones on Shafer's model.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Normal, under any model.

    Returns
    -------
    float or ndarray of shape (N,)

    Raises
    ------
    UndefinedMeasureError
        If m(∅) > 0.

    References
    ----------
    G. J. Klir, A. Ramer, "Uncertainty in the Dempster–Shafer theory: a critical
    re-examination", International Journal of General Systems 18(2), 1990, pp. 155–166.

    Examples
    --------
    m(A) = 0.3, m(B) = 0.1, m(A∪B) = 0.6: BetP(A) = 0.6, BetP(B) = 0.4, BetP(A∪B) = 1.

    >>> from belief import Frame, MassFunction, Model
    >>> m = MassFunction({"A": 0.3, "B": 0.1, "A|B": 0.6}, model=Model.shafer(Frame(["A", "B"])))
    >>> round(discord(m), 6)        # -(0.3 log2 0.6 + 0.1 log2 0.4)
    0.353282
    """
    batch, single, _ = _prepare(m, "the discord")
    return _result(-_weighted_log(batch.values, batch.betp(list(batch.focal))), single)


def dissonance(m: Source):
    """Yager's dissonance: the evidence against each focal element, in bits.

    E(m) = -Σ_A m(A) log2 Pls(A), with the plausibility of W (9) (on D^Θ under the model).
    It is 0 when every pair of focal elements intersects (consonant evidence, and every
    mass function on the free DSm model) and the Shannon entropy of m for Bayesian ones on
    Shafer's model.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Normal, under any model.

    Returns
    -------
    float or ndarray of shape (N,)

    Raises
    ------
    UndefinedMeasureError
        If m(∅) > 0.

    References
    ----------
    R. R. Yager, "Entropy and specificity in a mathematical theory of evidence",
    International Journal of General Systems 9(4), 1983, pp. 249–260.

    Examples
    --------
    m(A) = 0.3, m(B) = 0.1, m(A∪B) = 0.6: Pls(A) = 0.9, Pls(B) = 0.7, Pls(A∪B) = 1.

    >>> from belief import Frame, MassFunction, Model
    >>> m = MassFunction({"A": 0.3, "B": 0.1, "A|B": 0.6}, model=Model.shafer(Frame(["A", "B"])))
    >>> round(dissonance(m), 6)     # -(0.3 log2 0.9 + 0.1 log2 0.7)
    0.097058
    """
    batch, single, _ = _prepare(m, "the dissonance")
    return _result(-_weighted_log(batch.values, batch.pls(list(batch.focal))), single)


def confusion(m: Source):
    """Höhle's confusion: how little each focal element's own support adds up, in bits.

    C(m) = -Σ_A m(A) log2 Bel(A), with the belief of W (8) (on D^Θ under the model).  It is
    0 for a categorical mass function and the Shannon entropy of m for Bayesian ones on
    Shafer's model.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Normal, under any model.

    Returns
    -------
    float or ndarray of shape (N,)

    Raises
    ------
    UndefinedMeasureError
        If m(∅) > 0.

    References
    ----------
    U. Höhle, "Entropy with respect to plausibility measures", Proceedings of the 12th IEEE
    International Symposium on Multiple-Valued Logic, 1982, pp. 167–169.

    Examples
    --------
    m(A) = 0.3, m(B) = 0.1, m(A∪B) = 0.6: Bel(A) = 0.3, Bel(B) = 0.1, Bel(A∪B) = 1.

    >>> from belief import Frame, MassFunction, Model
    >>> m = MassFunction({"A": 0.3, "B": 0.1, "A|B": 0.6}, model=Model.shafer(Frame(["A", "B"])))
    >>> round(confusion(m), 6)      # -(0.3 log2 0.3 + 0.1 log2 0.1)
    0.853282
    """
    batch, single, _ = _prepare(m, "the confusion")
    return _result(-_weighted_log(batch.values, batch.bel(list(batch.focal))), single)


#: The measures of :func:`uncertainty`, by name, in the order it lists them.
MEASURES: dict[str, Callable] = {
    "nonspecificity": nonspecificity,
    "deng": deng_entropy,
    "ambiguity": ambiguity,
    "discord": discord,
    "dissonance": dissonance,
    "confusion": confusion,
}

#: The measures defined on power-set models only.
POWER_SET_ONLY = ("deng", "ambiguity")


def uncertainty(m: Source, measures: Sequence[str] | None = None) -> dict:
    """Several uncertainty measures at once, ``{name: value}``, in bits.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Normal (m(∅) = 0).
    measures : sequence of str, optional
        Names of :data:`MEASURES`.  By default every measure that is defined under the
        model of ``m``: all six on a power-set model (see :func:`is_power_set_model`), and
        all but ``deng_entropy`` and ``ambiguity`` on the others.

    Returns
    -------
    dict of str to float, or to ndarray of shape (N,) for a batch

    Raises
    ------
    UnknownMeasureError
        For a name that is not in :data:`MEASURES` (the message lists the known ones).
    UndefinedMeasureError
        If m(∅) > 0, or a measure asked for by name is not defined under the model.

    Examples
    --------
    >>> from belief import Frame, MassFunction, Model
    >>> m = MassFunction({"A": 0.3, "B": 0.1, "A|B": 0.6}, model=Model.shafer(Frame(["A", "B"])))
    >>> for name, value in uncertainty(m).items():
    ...     print(f"{name:14} {value:.4f}")
    nonspecificity 0.6000
    deng           2.2464
    ambiguity      0.9710
    discord        0.3533
    dissonance     0.0971
    confusion      0.8533
    >>> free = MassFunction({"A|B": 1.0}, frame=["A", "B"], model="free")   # D^Θ is no power set
    >>> list(uncertainty(free))
    ['nonspecificity', 'discord', 'dissonance', 'confusion']
    >>> uncertainty(free, ["deng"])   # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    belief.errors.UndefinedMeasureError: Deng's entropy is defined on power sets only (...), not on the free model; ...
    """
    if measures is None:
        batch, _ = _as_batch(m, "the mass function")
        names = [n for n in MEASURES if n not in POWER_SET_ONLY or is_power_set_model(batch.model)]
    else:
        if isinstance(measures, str):
            measures = [measures]
        names = list(measures)
        for name in names:
            if name not in MEASURES:
                raise UnknownMeasureError(f"unknown uncertainty measure {name!r}; known measures: "
                                          f"{', '.join(MEASURES)}")
    return {name: MEASURES[name](m) for name in names}
