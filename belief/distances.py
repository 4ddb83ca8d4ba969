"""Distances between mass functions, and the conflict between sources.

Every function takes :class:`~belief.mass.MassFunction` objects or
:class:`~belief.batch.MassBatch` objects (or a mix) under one frame and one model.  Two
mass functions give a float; batches give one value per row, an ndarray of shape (N,)
(a single mass function or a one-row batch is broadcast against an N-row batch).

Before a distance is taken, the two sources are *aligned*: their mass vectors are read
over the union of their focal elements (an element that is focal on one side only has
mass 0 on the other).

* :func:`jousselme_distance`: Jousselme, Grenier and Bossé's distance, on D^Θ with the DSm
  cardinality;
* :func:`euclidean_distance`: the normalised Euclidean distance between mass vectors;
* :func:`tessem_distance`: Tessem's distance between betting commitments (pignistic
  probabilities);
* :func:`distance`: any of them by name (:data:`DISTANCES`);
* :func:`conflict`: the conflict K, the mass that the conjunctive combination puts on ∅.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import Union

import numpy as np

from belief.batch import MassBatch, check_table_entries
from belief.errors import InvalidMassError, UnknownMeasureError
from belief.frame import Element
from belief.mass import MassFunction
from belief.model import Model
from belief.relation_tables import coded_relations
from belief.rules_common import check_same_model

__all__ = ["jousselme_distance", "euclidean_distance", "tessem_distance", "distance", "conflict",
           "jousselme_matrix", "DISTANCES"]

Source = Union[MassFunction, MassBatch]


# -- shared machinery -------------------------------------------------------------------------------
def _as_batch(source: Source, what: str = "source") -> tuple[MassBatch, bool]:
    """The source as a batch, and whether it was a single mass function."""
    if isinstance(source, MassFunction):
        return source.batch(), True
    if isinstance(source, MassBatch):
        return source, False
    raise TypeError(f"{what} is a {type(source).__name__}, not a MassFunction or MassBatch")


def _rows(batches: Sequence[MassBatch]) -> int:
    counts = {len(b) for b in batches} - {1}
    if len(counts) > 1:
        raise InvalidMassError(f"batches have different numbers of rows: {sorted(counts)}")
    return max(len(b) for b in batches)


def _pair(m1: Source, m2: Source) -> tuple[MassBatch, MassBatch, Model, int, bool]:
    b1, single1 = _as_batch(m1, "the first source")
    b2, single2 = _as_batch(m2, "the second source")
    model = check_same_model([b1, b2])
    return b1, b2, model, _rows([b1, b2]), single1 and single2


def _aligned(b1: MassBatch, b2: MassBatch, n: int) -> tuple[np.ndarray, np.ndarray, tuple[Element, ...]]:
    """The two batches' masses over the union of their focal elements, each of shape (n, K)."""
    focal = tuple(sorted(set(b1.focal) | set(b2.focal), key=lambda e: e.sort_key))
    out = []
    for b in (b1, b2):
        index = {e: i for i, e in enumerate(b.focal)}
        padded = np.concatenate([b.values, np.zeros((len(b), 1))], axis=1)
        columns = [index.get(e, len(b.focal)) for e in focal]
        out.append(np.broadcast_to(np.take(padded, columns, axis=1), (n, len(focal))))
    return out[0], out[1], focal


def _result(values: np.ndarray, single: bool):
    return float(values[0]) if single else values


# -- Jousselme ------------------------------------------------------------------------------------------
_FEWER = "use mass functions of fewer focal elements"


@lru_cache(maxsize=256)
def jousselme_matrix(model: Model, focal: tuple[Element, ...]) -> np.ndarray:
    """The similarity matrix D of Jousselme's distance over a list of elements.

    D_AB = C_M(A ∩ B) / C_M(A ∪ B), with C_M the DSm cardinality under the model (the number
    of Venn regions the model allows); on Shafer's model this is the Jaccard index
    |A ∩ B| / |A ∪ B|.  By convention D_∅∅ = 1 (and D_∅B = 0 for B ≠ ∅), which keeps D
    positive definite, so that the distance stays a metric on subnormal mass functions.

    Parameters
    ----------
    model : Model
    focal : tuple of Element
        K distinct elements, reduced under the model.

    Returns
    -------
    ndarray, shape (K, K)
        Read-only.

    Examples
    --------
    >>> from belief import Frame, Model
    >>> f = Frame(["a", "b"])
    >>> jousselme_matrix(Model.free(f), (f["a"], f["b"], f.total))   # a, b, a|b hold 2, 2, 3 regions
    array([[1.        , 0.33333333, 0.66666667],
           [0.33333333, 1.        , 0.66666667],
           [0.66666667, 0.66666667, 1.        ]])
    """
    size = len(focal)
    check_table_entries(size * size, f"Jousselme's matrix of {size:,} focal elements", advice=_FEWER)
    cards = [model.cardinality(x) for x in focal]
    coded = coded_relations(model, focal, focal) if size else None
    if coded is not None and coded.weights is not None:
        inter = coded.table("meet_cardinality")
        card = np.array(cards, dtype=np.float64)
        union = card[:, None] + card[None, :] - inter      # exact: integers below 2^53
        with np.errstate(invalid="ignore", divide="ignore"):
            matrix = np.where((card[:, None] > 0) & (card[None, :] > 0), inter / union, 0.0)
        np.fill_diagonal(matrix, 1.0)
        matrix.flags.writeable = False
        return matrix
    check_table_entries(size * size, f"Jousselme's matrix of {size:,} focal elements compared element by element "
                        "(the model has too many Venn regions to code them)", one_by_one=True, advice=_FEWER)
    matrix = np.zeros((size, size))
    for a in range(size):
        matrix[a, a] = 1.0
        for b in range(a + 1, size):
            union = model.cardinality(focal[a] | focal[b])
            if union and cards[a] and cards[b]:
                matrix[a, b] = matrix[b, a] = model.cardinality(focal[a] & focal[b]) / union
    matrix.flags.writeable = False
    return matrix


def jousselme_distance(m1: Source, m2: Source):
    """Jousselme's distance between two mass functions, row by row.

    d_J(m1, m2) = sqrt(½ (m1 - m2)ᵀ D (m1 - m2)), with D_AB = C_M(A ∩ B) / C_M(A ∪ B)
    (:func:`jousselme_matrix`), the mass vectors aligned on the union of the focal elements.
    On Shafer's model C_M(X) = |X| and this is the distance of Jousselme, Grenier and Bossé;
    on a DSm model the DSm cardinality counts the Venn regions that the model allows (SPEC
    A.4 offers the same formula as ``r_mode="jousselme"`` of W (10)).  The distance lies in
    [0, 1] and is a metric: D is positive definite (the Jaccard index matrix, Bouchard,
    Jousselme and Doré 2013).

    Parameters
    ----------
    m1, m2 : MassFunction or MassBatch
        Under one frame and model.  Batches have N rows each (or one row, broadcast).

    Returns
    -------
    float or ndarray of shape (N,)
        A float if both arguments are mass functions.

    Raises
    ------
    FrameError, ModelError
        If the two sources have different frames or models.
    InvalidMassError
        For batches of different numbers of rows.

    References
    ----------
    A.-L. Jousselme, D. Grenier, É. Bossé, "A new distance between two bodies of evidence",
    Information Fusion 2(2), 2001, pp. 91–101.

    Examples
    --------
    >>> from belief import Frame, MassFunction, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> m1 = MassFunction({"a": 0.5, "b|c": 0.5}, model=shafer)
    >>> m2 = MassFunction({"a|b": 1.0}, model=shafer)
    >>> round(jousselme_distance(m1, m2), 6)   # sqrt(½ (0.25 + 0.25 + 1 - 2 (0.5 · 1/2 + 0.5 · 1/3)))
    0.57735
    >>> jousselme_distance(m1, m1)
    0.0
    """
    b1, b2, model, n, single = _pair(m1, m2)
    v1, v2, focal = _aligned(b1, b2, n)
    delta = v1 - v2
    squared = 0.5 * np.einsum("na,ab,nb->n", delta, jousselme_matrix(model, focal), delta)
    return _result(np.sqrt(np.clip(squared, 0.0, None)), single)


def euclidean_distance(m1: Source, m2: Source):
    """The normalised Euclidean distance between the mass vectors, row by row.

    d_E(m1, m2) = sqrt(½ Σ_A (m1(A) - m2(A))²), the sum over the focal elements of either
    source.  It is Jousselme's distance with D the identity (every pair of distinct
    elements counted as unrelated), lies in [0, 1] and is a metric; it is the ``euclid``
    reading of the inconsistency W (10) (SPEC A.4).

    Parameters
    ----------
    m1, m2 : MassFunction or MassBatch
        As for :func:`jousselme_distance`.

    Returns
    -------
    float or ndarray of shape (N,)

    Raises
    ------
    FrameError, ModelError, InvalidMassError
        As for :func:`jousselme_distance`.

    References
    ----------
    A.-L. Jousselme, P. Maupin, "Distances in evidence theory: comprehensive survey and
    generalizations", International Journal of Approximate Reasoning 53(2), 2012, pp. 118–145
    (the L2 family).

    Examples
    --------
    >>> from belief import Frame, MassFunction, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> m1 = MassFunction({"a": 0.5, "b|c": 0.5}, model=shafer)
    >>> m2 = MassFunction({"a|b": 1.0}, model=shafer)
    >>> round(euclidean_distance(m1, m2), 6)        # sqrt(½ (0.25 + 0.25 + 1))
    0.866025
    """
    b1, b2, _, n, single = _pair(m1, m2)
    v1, v2, _ = _aligned(b1, b2, n)
    return _result(np.sqrt(0.5 * np.sum((v1 - v2) ** 2, axis=1)), single)


def tessem_distance(m1: Source, m2: Source):
    """Tessem's distance between betting commitments, row by row.

    d_T(m1, m2) = max_i |BetP1(θ_i) - BetP2(θ_i)|, the largest difference between the
    pignistic probabilities of a hypothesis, with the generalised BetP(A) = Σ_X m(X)
    C_M(X ∩ A) / C_M(X) (mass on ∅ is removed first and the rest rescaled).  It compares the
    bets rather than the evidence: two different mass functions with the same pignistic
    probabilities are at distance 0, so it is a pseudo-metric on mass functions (a metric on
    their BetP vectors).  It lies in [0, 1].

    Parameters
    ----------
    m1, m2 : MassFunction or MassBatch
        As for :func:`jousselme_distance`.

    Returns
    -------
    float or ndarray of shape (N,)

    Raises
    ------
    FrameError, ModelError, InvalidMassError
        As for :func:`jousselme_distance`.
    TotalConflictError
        If a row has m(∅) = 1 (BetP is undefined).

    References
    ----------
    B. Tessem, "Approximations for efficient computation in the theory of evidence",
    Artificial Intelligence 61(2), 1993, pp. 315–329; used as the "distance between betting
    commitments" by W. Liu, "Analyzing the degree of conflict among belief functions",
    Artificial Intelligence 170(11), 2006, pp. 909–924.

    Examples
    --------
    Zadeh's example: BetP1 = (0.9, 0, 0.1) and BetP2 = (0, 0.9, 0.1).

    >>> from belief import Frame, MassFunction, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> m1 = MassFunction({"a": 0.9, "c": 0.1}, model=shafer)
    >>> m2 = MassFunction({"b": 0.9, "c": 0.1}, model=shafer)
    >>> round(tessem_distance(m1, m2), 12)
    0.9
    """
    b1, b2, _, n, single = _pair(m1, m2)
    p1, p2 = (np.broadcast_to(b.pignistic(), (n, len(b.frame))) for b in (b1, b2))
    return _result(np.max(np.abs(p1 - p2), axis=1), single)


#: The distances of :func:`distance`, by name.
DISTANCES: dict[str, Callable] = {
    "jousselme": jousselme_distance,
    "euclidean": euclidean_distance,
    "tessem": tessem_distance,
}


def distance(m1: Source, m2: Source, kind: str = "jousselme"):
    """The distance of the given kind between two mass functions (or batches), row by row.

    Parameters
    ----------
    m1, m2 : MassFunction or MassBatch
        Under one frame and model.
    kind : {"jousselme", "euclidean", "tessem"}
        A name of :data:`DISTANCES` (case-insensitive): :func:`jousselme_distance`,
        :func:`euclidean_distance` or :func:`tessem_distance`.

    Returns
    -------
    float or ndarray of shape (N,)

    Raises
    ------
    UnknownMeasureError
        For a name that is not in :data:`DISTANCES` (the message lists the known ones).

    Examples
    --------
    >>> from belief import Frame, MassFunction
    >>> m1 = MassFunction({"a": 1.0}, frame=["a", "b"])
    >>> m2 = MassFunction({"b": 1.0}, frame=["a", "b"])
    >>> distance(m1, m2), distance(m1, m2, kind="euclidean")   # Shafer's model: a and b disjoint
    (1.0, 1.0)
    >>> free = [MassFunction(m, frame=["a", "b"], model="free") for m in ({"a": 1.0}, {"b": 1.0})]
    >>> round(distance(*free), 6)   # the free model: a and b share a∩b, D_ab = 1/3
    0.816497
    >>> distance(m1, m2, kind="hamming")
    Traceback (most recent call last):
    ...
    belief.errors.UnknownMeasureError: unknown distance 'hamming'; known distances: jousselme, euclidean, tessem
    """
    key = kind.lower() if isinstance(kind, str) else kind
    if key not in DISTANCES:
        raise UnknownMeasureError(f"unknown distance {kind!r}; known distances: {', '.join(DISTANCES)}")
    return DISTANCES[key](m1, m2)


# -- conflict ------------------------------------------------------------------------------------------------
def conflict(*sources: Source, model: Model | None = None):
    """The conflict K between two or more sources, row by row.

    K = m∩(∅) = Σ_{X_1 ∩ … ∩ X_s ≡ ∅} Π_i m_i(X_i): the mass that the conjunctive
    combination (W (2) under the model, SPEC A.3) puts on ∅, the K of Dempster's
    normalisation 1 - K.  On the free DSm model no intersection is empty, so K is the mass
    the sources already put on ∅ (0 for normal sources).

    Parameters
    ----------
    *sources : MassFunction or MassBatch
        At least two (or one list of them), under one frame and model; batches of N rows
        (one-row batches and mass functions are broadcast).
    model : Model, optional
        A stricter model to read the intersections under (dynamic fusion); by default the
        sources' model.

    Returns
    -------
    float or ndarray of shape (N,)
        A float if every source is a mass function.

    Raises
    ------
    FrameError, ModelError
        For sources of different frames or models, or a ``model`` that is not stricter.
    InvalidMassError
        For fewer than two sources, or batches of different numbers of rows.

    Examples
    --------
    Zadeh's example (Zadeh 1986): the two experts agree only on c, so K = 1 - 0.1 · 0.1.

    >>> from belief import Frame, MassFunction, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> m1 = MassFunction({"a": 0.9, "c": 0.1}, model=shafer)
    >>> m2 = MassFunction({"b": 0.9, "c": 0.1}, model=shafer)
    >>> round(conflict(m1, m2), 12)
    0.99
    >>> round(conflict(m1, m1), 12)     # a source conflicts with itself unless it is categorical
    0.18
    """
    from belief.rules import combine

    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):
        sources = tuple(sources[0])
    if len(sources) < 2:
        raise InvalidMassError(f"the conflict needs at least two sources, got {len(sources)}")
    for k, s in enumerate(sources, start=1):
        _as_batch(s, f"source {k}")
    fused = combine(*sources, rule="conjunctive", model=model)
    if isinstance(fused, MassFunction):
        return fused.empty_mass
    return np.asarray(fused.empty_mass, dtype=np.float64)
