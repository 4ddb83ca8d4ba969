"""Measures of single hypotheses over many focal elements: which hypothesis lies in which focal element.

Under Shafer's model a focal element that is a union of hypotheses X = θ_a ∪ θ_b ∪ … meets
the singleton θ_i exactly when θ_i is one of its hypotheses, and then

* Bel(θ_i) and m(θ_i) take m(X) only for X = θ_i (W (8));
* Pls(θ_i) and the commonality q(θ_i) take m(X) for every X that holds θ_i (W (9));
* BetP(θ_i) takes m(X) / |X| for every X that holds θ_i (the DSm cardinality of a union of
  exclusive hypotheses is their number).

So the table of a measure, (K focal elements × Q singleton queries), has one entry per
hypothesis of each focal element: Σ_X |X| entries where the dense table has K·Q, which for a
Bayesian mass function over 20 000 hypotheses is 20 000 against 4·10⁸.  :class:`Incidence`
keeps those entries; :meth:`Incidence.weigh` sums them in the order of the focal elements,
each term rounded on its own, exactly as :func:`~belief.plan.weighted_sum` sums the dense
table: the two give the same bits.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from belief.frame import Element
from belief.model import Model

__all__ = ["Incidence", "incidence", "SPARSE_TABLE_ENTRIES"]

#: Tables of more entries than this (K · Q) are kept as an :class:`Incidence` where one applies: building a dense
#: table meets every focal element with every query, some microseconds each, where the incidence reads each
#: focal element's hypotheses once.  Smaller tables stay dense (a matrix the tracker's many rows reuse).
SPARSE_TABLE_ENTRIES = 256
#: Floats of (rows × entries) gathered at a time by :meth:`Incidence.weigh` (about 8 MB).
_WEIGH_BLOCK = 1 << 20


class Incidence:
    """The hypotheses of K focal elements (unions of exclusive hypotheses) that Q singleton queries name.

    Attributes
    ----------
    focal, query : ndarray of intp, shape (E,)
        The focal element and the query of each entry, sorted by focal element.
    size : ndarray of float, shape (E,)
        The number of hypotheses of the entry's focal element.
    queries : int
        Q.
    complete : bool
        Whether the queries name every hypothesis of every focal element (DSmP needs them all).
    """

    def __init__(self, focal: np.ndarray, query: np.ndarray, size: np.ndarray, queries: int,
                 complete: bool = False) -> None:
        self.focal = focal
        self.query = query
        self.size = size
        self.queries = queries
        self.complete = complete

    def dsmp(self, values: np.ndarray, epsilon: float) -> tuple[np.ndarray, tuple[int, int] | None]:
        """DSmP_ε of every query (Dezert & Smarandache 2008) from normalised masses, shape (N, Q); needs :attr:`complete`.

        Under Shafer's model the focal elements of DSm cardinality one are the single hypotheses,
        so for a query θ_i and a focal element X that holds it the share of m(X) is
        (m(θ_i) + ε) / (Σ_{θ_j ∈ X} m(θ_j) + ε |X|), and nothing otherwise.  Returns the values and,
        where a focal element with mass has a zero denominator (ε = 0 and none of its
        hypotheses has mass of its own), its (row, focal element) instead of the values.
        """
        rows, width = values.shape[0], self.queries
        singleton = self.size == 1.0
        own = np.zeros((rows, width))
        own[:, self.query[singleton]] = values[:, self.focal[singleton]]
        count = values.shape[1]
        sizes = _sizes(self, count)
        out = np.zeros((rows, width))
        step = max(1, _WEIGH_BLOCK // max(len(self.focal), 1))
        for start in range(0, rows, step):
            block = values[start:start + step]
            b = block.shape[0]
            held = own[start:start + step][:, self.query]                     # m(θ_i) of each entry, (b, E)
            by_focal = (np.arange(b)[:, None] * count + self.focal[None, :]).ravel()
            denominator = np.bincount(by_focal, weights=held.ravel(), minlength=b * count).reshape(b, count).astype(float)
            denominator += epsilon * sizes[None, :]
            live = block > 0
            bad = live & (denominator <= 0)
            if bad.any():
                n, x = map(int, np.argwhere(bad)[0])
                return out, (start + n, x)
            safe = np.where(live, denominator, 1.0)
            terms = block[:, self.focal] * (held + epsilon) / safe[:, self.focal]
            target = (np.arange(b)[:, None] * width + self.query[None, :]).ravel()
            out[start:start + step] = np.bincount(target, weights=terms.ravel(), minlength=b * width).reshape(b, width)
        return out, None

    def weigh(self, values: np.ndarray, relation: str) -> np.ndarray:
        """Σ_X values[:, X] · table[X, q] of one relation's table, shape (N, Q).

        Parameters
        ----------
        values : ndarray, shape (N, K)
        relation : {"subset", "equal", "meets", "superset", "ratio"}
            As the tables of :class:`~belief.batch.MeasurePlan`: subset and equal keep the
            entries of single-hypothesis focal elements with weight 1, meets and superset
            every entry with weight 1, ratio every entry with weight 1/|X|.

        Examples
        --------
        >>> from belief import Frame
        >>> f = Frame(["a", "b", "c"])
        >>> table = incidence([f["a"], f.element("a|b")], [f["a"], f["b"]])
        >>> table.weigh(np.array([[0.6, 0.4]]), "ratio")
        array([[0.8, 0.2]])
        """
        focal, query = self.focal, self.query
        weights = None
        if relation in ("subset", "equal"):
            keep = self.size == 1.0
            focal, query = focal[keep], query[keep]
        elif relation == "ratio":
            weights = 1.0 / self.size
        elif relation not in ("meets", "superset"):
            raise ValueError(f"no sparse table for the relation {relation!r}")
        rows, width = values.shape[0], self.queries
        out = np.empty((rows, width))
        step = max(1, _WEIGH_BLOCK // max(len(focal), 1))
        for start in range(0, rows, step):
            block = values[start:start + step]
            terms = block[:, focal]
            if weights is not None:
                terms *= weights
            # np.bincount adds in input order: per (row, query) in the order of the focal elements.
            target = (np.arange(block.shape[0])[:, None] * width + query[None, :]).ravel()
            out[start:start + step] = np.bincount(target, weights=terms.ravel(),
                                                  minlength=block.shape[0] * width).reshape(block.shape[0], width)
        return out


def _sizes(table: Incidence, count: int) -> np.ndarray:
    """|X| of each of the ``count`` focal elements (0 for ∅), from a complete incidence."""
    sizes = np.zeros(count)
    sizes[table.focal] = table.size
    return sizes


def incidence(focal: Sequence[Element], queries: Sequence[Element], model: Model | None = None) -> Incidence | None:
    """The :class:`Incidence` of focal elements and singleton queries, or None where it does not apply.

    It applies when every query is a distinct single hypothesis and every focal element a
    union of hypotheses (or ∅), under Shafer's model (``model`` None means the caller has
    checked the model).
    """
    if model is not None and model.kind != "shafer":
        return None
    if not focal:
        return Incidence(np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0), len(queries))
    singletons = focal[0].frame.singletons
    # A frame's hypotheses as integers of up to n bits, by position: a term that *is* one of them needs no
    # test.  Over thousands of hypotheses each test of another integer (bit_count, a hash) reads thousands of
    # bits, and a dictionary keyed by masks would hash them: positions (bit_length) are read in constant time.
    masks = [x.terms[0] for x in singletons]
    if queries is singletons:
        column: dict[int, int] | None = None
    else:
        column = {}
        for q, x in enumerate(queries):
            terms = x.terms
            if len(terms) != 1:
                return None
            position = terms[0].bit_length() - 1
            if masks[position] is not terms[0] and terms[0].bit_count() != 1:
                return None
            column[position] = q
        if len(column) != len(queries):
            return None                         # a query twice
    get = column.get if column is not None else None
    focal_of: list[int] = []
    query_of: list[int] = []
    size_of: list[int] = []
    terms_seen = 0
    for k, x in enumerate(focal):
        terms = x.terms
        size = len(terms)
        terms_seen += size
        for t in terms:
            position = t.bit_length() - 1
            if masks[position] is not t and t.bit_count() != 1:
                return None                     # an intersection: not a union of hypotheses
            q = position if get is None else get(position)
            if q is not None:
                focal_of.append(k)
                query_of.append(q)
                size_of.append(size)
    return Incidence(np.array(focal_of, dtype=np.intp), np.array(query_of, dtype=np.intp),
                     np.array(size_of, dtype=np.float64), len(queries), complete=len(focal_of) == terms_seen)
