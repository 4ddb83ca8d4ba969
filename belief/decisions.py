"""Decisions: the hypothesis (or candidate element) that a mass function supports most.

:func:`decide` picks, among the hypotheses θ_1, …, θ_n (or a given list of candidate
elements), the one(s) with the largest belief, plausibility, pignistic probability or
DSmP.  Candidates whose value is within an absolute tolerance of the maximum are *tied*
and are all returned, in candidate order.

A :class:`~belief.mass.MassFunction` gives a :class:`Decision`; a
:class:`~belief.batch.MassBatch` of N rows gives a :class:`DecisionBatch`, whose arrays
hold the N decisions at once and whose rows are :class:`Decision` objects.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Union

import numpy as np

from belief.batch import MassBatch
from belief.dask_batches import DaskMassBatch, lazy_decisions
from belief.distances import _as_batch
from belief.errors import MeasureOptionError, UnknownMeasureError
from belief.frame import Element
from belief.incidence import held_measure
from belief.mass import MassFunction
from belief.model import Model

__all__ = ["decide", "Decision", "DecisionBatch", "CRITERIA", "DEFAULT_TOLERANCE"]

#: The decision criteria of :func:`decide`.
CRITERIA = ("betp", "bel", "pls", "dsmp")

#: Candidates within this absolute distance of the maximal value are tied.
DEFAULT_TOLERANCE = 1e-9

Query = Union[Element, str]


@dataclass(frozen=True)
class Decision:
    """The decision of one mass function.

    Attributes
    ----------
    elements : list of str
        The maximising candidates (several when tied), in candidate order, each written
        in canonical form (a hypothesis name for a singleton).
    value : float
        The maximal value of the criterion.

    Examples
    --------
    >>> Decision(["a"], 0.6)
    Decision(elements=['a'], value=0.6)
    """

    elements: list[str]
    value: float


@dataclass(frozen=True, eq=False)
class DecisionBatch:
    """The decisions of the N rows of a batch, as arrays.

    Attributes
    ----------
    candidates : tuple of str
        The Q candidates, in canonical form.
    scores : ndarray, shape (N, Q)
        The criterion's value for every row and candidate.
    value : ndarray, shape (N,)
        The maximal value of each row.
    tied : ndarray of bool, shape (N, Q)
        True where a candidate is within the tolerance of its row's maximum: the chosen ones.
    index : ndarray of int, shape (N,)
        The position of the first chosen candidate of each row.

    Indexing (``decisions[n]``) and iteration give :class:`Decision` objects; ``len`` is N.

    Examples
    --------
    >>> from belief import MassBatch, Model
    >>> batch = MassBatch.bayesian([[0.5, 0.3, 0.2], [0.4, 0.4, 0.2]], model=Model.for_targets(2))
    >>> decisions = decide(batch, "bel")
    >>> decisions.index, decisions.value
    (array([0, 0]), array([0.5, 0.4]))
    >>> decisions[1]
    Decision(elements=['t1', 't2'], value=0.4)
    >>> decisions.elements
    [['t1'], ['t1', 't2']]
    """

    candidates: tuple[str, ...]
    scores: np.ndarray
    value: np.ndarray
    tied: np.ndarray
    index: np.ndarray

    def __len__(self) -> int:
        return self.scores.shape[0]

    def __getitem__(self, row: int) -> Decision:
        chosen = np.flatnonzero(self.tied[row]).tolist()
        return Decision([self.candidates[q] for q in chosen], float(self.value[row]))

    def __iter__(self) -> Iterator[Decision]:
        for row in range(len(self)):
            yield self[row]

    @property
    def elements(self) -> list[list[str]]:
        """The chosen candidates of every row (a list of N lists)."""
        return [decision.elements for decision in self]

    def __repr__(self) -> str:
        return f"<DecisionBatch of {len(self)} decisions among {len(self.candidates)} candidates>"


def _candidates(batch: MassBatch, candidates) -> tuple[Element, ...]:
    model = batch.model
    if candidates is None:
        return _hypotheses(model)
    if isinstance(candidates, (str, Element)):
        candidates = [candidates]
    resolved: list[Element] = []
    for c in candidates:
        element = model.reduce(model.frame.element(c))
        if not element.terms:
            raise MeasureOptionError(f"candidate {c!s} is empty under the {model.kind} model and cannot be chosen")
        if element not in resolved:
            resolved.append(element)
    if not resolved:
        raise MeasureOptionError("decide needs at least one candidate")
    return tuple(resolved)


@lru_cache(maxsize=64)
def _hypotheses(model: Model) -> tuple[Element, ...]:
    """The default candidates: the hypotheses that are not empty under the model, in frame order."""
    if model.kind == "shafer":
        return tuple(model.frame.singletons)
    chosen = [model.reduce(x) for x in model.frame.singletons]
    return tuple(x for x in chosen if x.terms)


def _check_tolerance(tol: float) -> float:
    try:
        value = float(tol)
    except (TypeError, ValueError):
        raise MeasureOptionError(f"the tolerance must be a number, got {tol!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise MeasureOptionError(f"the tolerance must be finite and non-negative, got {tol!r}")
    return value


def decide(m: Union[MassFunction, MassBatch], criterion: str = "betp", candidates: Sequence[Query] | None = None,
           *, tol: float = DEFAULT_TOLERANCE, epsilon: float = 0.001):
    """The candidate(s) that maximise a criterion: Bel, Pls, BetP or DSmP.

    The criteria, for a candidate A of D^Θ:

    * ``"bel"``: the belief Bel(A) = Σ_{∅≠B⊆A} m(B) (W (8)), the pessimistic choice;
    * ``"pls"``: the plausibility Pls(A) = Σ_{B∩A≢∅} m(B) (W (9)), the optimistic choice;
    * ``"betp"``: the generalised pignistic probability BetP(A) = Σ_X m(X) C_M(X∩A)/C_M(X),
      Smets' pignistic decision, with the DSm cardinality C_M on D^Θ (Dezert & Smarandache);
    * ``"dsmp"``: DSmP_ε(A), the proportional transformation of Dezert & Smarandache (2008).

    BetP and DSmP remove the mass of ∅ and rescale the rest; Bel and Pls leave it out.

    Parameters
    ----------
    m : MassFunction or MassBatch
        One mass function, or a batch of N.
    criterion : {"betp", "bel", "pls", "dsmp"}
        Case-insensitive.
    candidates : sequence of str or Element, optional
        The elements (propositions) to choose from, e.g. ``["a", "b|c"]``; by default the
        hypotheses θ_1, …, θ_n that are not empty under the model, in frame order.
        Candidates that denote the same element under the model are kept once.
    tol : float
        Absolute tolerance of ties: every candidate whose value is at least
        ``max - tol`` is chosen.  The default 1e-9 absorbs rounding; 0 keeps exact ties only.
    epsilon : float
        The ε of DSmP (ignored by the other criteria).

    Returns
    -------
    Decision or DecisionBatch
        For a mass function, ``Decision(elements, value)``: the chosen candidates in
        canonical form and the maximal value.  For a batch, a :class:`DecisionBatch` of N
        rows (arrays ``scores`` (N, Q), ``value`` (N,), ``tied`` (N, Q) and ``index`` (N,)).

    Raises
    ------
    UnknownMeasureError
        For a criterion not in :data:`CRITERIA` (the message lists them).
    MeasureOptionError
        For a negative or non-finite ``tol``, no candidates, or a candidate that is empty
        under the model.
    TotalConflictError
        ``"betp"`` or ``"dsmp"`` on a row with m(∅) = 1.
    UndefinedTransformError
        ``"dsmp"`` with ε = 0 where it is undefined, or a negative ε.

    References
    ----------
    P. Smets, R. Kennes, "The transferable belief model", Artificial Intelligence 66(2), 1994,
    pp. 191–234 (pignistic decisions).  J. Dezert, F. Smarandache, "A new probabilistic
    transformation of belief mass assignment", Fusion 2008 (DSmP).

    Examples
    --------
    Dezert and Smarandache's (2008) first example: m(A) = 0.3, m(B) = 0.1, m(A∪B) = 0.6 under
    Shafer's model gives BetP(A) = 0.6 and DSmP_0.001(A) = 0.3 + 0.6 · 0.301/0.402 ≈ 0.74925.

    >>> from belief import Frame, MassFunction, Model
    >>> m = MassFunction({"A": 0.3, "B": 0.1, "A|B": 0.6}, model=Model.shafer(Frame(["A", "B"])))
    >>> decide(m)
    Decision(elements=['A'], value=0.6)
    >>> d = decide(m, "dsmp")
    >>> d.elements, round(d.value, 5)
    (['A'], 0.74925)
    >>> decide(m, "pls", candidates=["B", "A|B"])
    Decision(elements=['A|B'], value=1.0)
    >>> decide(MassFunction.vacuous(model=m.model), "bel")    # every hypothesis ties
    Decision(elements=['A', 'B'], value=0.0)
    """
    key = criterion.lower() if isinstance(criterion, str) else criterion
    if key not in CRITERIA:
        raise UnknownMeasureError(f"unknown decision criterion {criterion!r}; known criteria: {', '.join(CRITERIA)}")
    tol = _check_tolerance(tol)
    if candidates is None and isinstance(m, MassFunction):
        # The hypotheses (the default candidates under Shafer's model) of a mass function that holds its focal
        # elements as bit masks: measured from the masks, as m.betp & co. do, without making its elements or the
        # frame's singletons (None where that does not apply).
        names = m.model.frame.hypotheses
        scores = held_measure(m, key, names)
        if scores is not None:
            return _decisions(names, scores, tol)[0]
    batch, single = _as_batch(m, "the mass function")
    queries = _candidates(batch, candidates)
    if isinstance(batch, DaskMassBatch):
        frame = batch.model.frame
        names = frame.hypotheses if queries is frame.singletons else tuple([str(q) for q in queries])
        return lazy_decisions(_decisions, batch, key, queries, names, tol, epsilon)
    if key == "dsmp":
        scores = batch.dsmp(queries, epsilon=epsilon)
    else:
        scores = getattr(batch, key)(queries)
    scores = np.asarray(scores, dtype=np.float64).reshape(len(batch), len(queries))
    frame = batch.model.frame
    names = frame.hypotheses if queries is frame.singletons else tuple([str(q) for q in queries])
    result = _decisions(names, scores, tol)
    return result[0] if single else result


def _decisions(names: tuple[str, ...], scores: np.ndarray, tol: float) -> DecisionBatch:
    """The decisions of N rows of scores, shape (N, Q), among the Q candidates ``names``."""
    value = scores.max(axis=1)
    tied = scores >= (value - tol)[:, None]
    return DecisionBatch(names, scores, value, tied, np.argmax(tied, axis=1))
