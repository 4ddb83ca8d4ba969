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

The entries are read from the focal elements (:func:`incidence`, for batches) or from the
bit masks a :class:`~belief.mass.MassFunction` holds its unions of hypotheses as until its
elements are read (:func:`union_incidence`, put in canonical order first so that the sums
are the same; :func:`held_measure` measures a mass function so, without making elements).
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import chain
from operator import is_

import numpy as np

from belief.errors import TotalConflictError
from belief.frame import Element, Frame
from belief.masks import canonical_order, to_words, union_terms, word_count
from belief.model import Model
from belief.plan import RANK_TABLE_WIDTH, union_ranks

__all__ = ["Incidence", "incidence", "union_incidence", "query_columns", "canonical_masks", "held_measure",
           "without_empty", "SPARSE_TABLE_ENTRIES"]

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

    Parameters
    ----------
    focal : sequence of Element, length K
    queries : sequence of Element, length Q
    model : Model, optional
    """
    if model is not None and model.kind != "shafer":
        return None
    if not focal:
        return Incidence(np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0), len(queries))
    frame = focal[0].frame
    found = query_columns(frame, queries)
    if found is None:
        return None
    terms = [x.terms for x in focal]
    flat = list(chain.from_iterable(terms))
    lengths = list(map(int.bit_length, flat))
    own = list(map(is_, map(own_bits(frame).__getitem__, lengths), flat))
    if not all(own) and not all([t.bit_count() == 1 for t, o in zip(flat, own) if not o]):
        return None                             # an intersection: not a union of hypotheses
    counts = list(map(len, terms))
    position = np.fromiter(lengths, dtype=np.intp, count=len(lengths))
    position -= 1
    return _entries(position, None if len(flat) == len(terms) and 0 not in counts else counts, *found)


def union_incidence(frame: Frame, masks: Sequence[int], queries, *,
                    sort: bool = False) -> tuple[Incidence, np.ndarray | None] | None:
    """The :class:`Incidence` of unions of hypotheses given as bit masks, or None where it does not apply.

    The masks are those of :class:`~belief.mass.MassFunction` (``_unions_as_held``): bit i
    for hypothesis i, 0 for ∅; a single hypothesis parsed from its name is the very ``int``
    of :attr:`Frame.bits <belief.frame.Frame.bits>`, whose position is its bit length, read
    in constant time however wide the frame.

    Parameters
    ----------
    frame : Frame
    masks : sequence of int, length K
        Distinct masks.
    queries : str, Element or sequence of them
        Singleton queries, as :func:`query_columns` (which says when None is returned).
    sort : bool
        Put the masks in canonical order first (:func:`canonical_masks`); otherwise the
        entries follow the order given.

    Returns
    -------
    table : Incidence
        Its focal index counts in the order of the entries: canonical with ``sort``.
    order : ndarray of intp, shape (K,), or None
        With ``sort``, the position in ``masks`` of each focal element of ``table``.

    Examples
    --------
    >>> f = Frame(["a", "b", "c"])
    >>> table, order = union_incidence(f, [0b110, f.bits[0]], f.hypotheses, sort=True)    # b|c, a
    >>> order.tolist(), table.focal.tolist(), table.query.tolist(), table.size.tolist()
    ([1, 0], [0, 1, 1], [0, 1, 2], [1.0, 2.0, 2.0])
    """
    found = query_columns(frame, queries)
    return None if found is None else _union_table(frame, masks, sort, *found)


def _union_table(frame: Frame, masks: Sequence[int], sort: bool, columns: np.ndarray | None,
                 width: int) -> tuple[Incidence, np.ndarray | None]:
    """:func:`union_incidence` of queries found by :func:`query_columns`."""
    lengths = list(map(int.bit_length, masks))
    own = list(map(is_, map(own_bits(frame).__getitem__, lengths), masks))
    if all(own):
        # Single hypotheses only, each the frame's own bit (a Bayesian mass function read from names): one entry
        # each, and their canonical order is that of their bit lengths, all distinct.
        position = np.fromiter(lengths, dtype=np.intp, count=len(lengths))
        position -= 1
        order = position.argsort() if sort else None
        return _entries(position if order is None else position[order], None, columns, width), order
    order = None
    if sort:
        order = np.array(_canonical(frame, masks, lengths, own), dtype=np.intp)
        ranked = order.tolist()
        masks = [masks[i] for i in ranked]
        own = [own[i] for i in ranked]
    terms: list = [(m,) if o else () if not m else (m,) if m.bit_count() == 1 else None for m, o in zip(masks, own)]
    unions = [k for k, t in enumerate(terms) if t is None]
    for k, t in zip(unions, union_terms([masks[k] for k in unions], len(frame))):
        terms[k] = t
    position = np.array(list(map(int.bit_length, chain.from_iterable(terms))), dtype=np.intp)
    position -= 1
    return _entries(position, list(map(len, terms)), columns, width), order


def query_columns(frame: Frame, queries) -> tuple[np.ndarray | None, int] | None:
    """Where the singleton queries of an :class:`Incidence` find their hypotheses, or None if they are not such.

    Parameters
    ----------
    frame : Frame
        Of n hypotheses.
    queries : str, Element or sequence of them
        Distinct single hypotheses: names of the frame, or elements of it of one single-hypothesis term.  The
        frame's own :attr:`~belief.frame.Frame.hypotheses` or :attr:`~belief.frame.Frame.singletons` (the very
        tuples) are every hypothesis in frame order.  Anything else (a union, ∅, a name twice, another kind of
        iterable, which might be read only once) gives None: the caller's general path reads it or names what is
        wrong with it.

    Returns
    -------
    columns : ndarray of intp, shape (n,), or None
        The query of each hypothesis (-1 for none); None when query q is hypothesis q.
    width : int
        Q, the number of queries.

    Examples
    --------
    >>> f = Frame(["a", "b", "c"])
    >>> query_columns(f, ["c", f["a"]])
    (array([ 1, -1,  0]), 2)
    >>> query_columns(f, f.hypotheses), query_columns(f, "a|b")
    ((None, 3), None)
    """
    singletons = frame._singletons             # not made here: over thousands of hypotheses that takes milliseconds
    if queries is frame.hypotheses or queries is singletons and singletons is not None:
        return None, len(frame)
    if type(queries) is str or isinstance(queries, Element):
        queries = (queries,)
    elif type(queries) is not tuple and type(queries) is not list:
        return None
    index = frame._index
    try:
        # Names, the common case, are looked up without a Python loop; a None (an element, or a name that is not a
        # hypothesis) sends every query through the loop below.
        positions = list(map(index.get, queries))
    except TypeError:                           # an unhashable query
        return None
    if None not in positions:
        return _columns(len(frame), positions)
    bits = own_bits(frame)
    positions = []
    for q in queries:
        if type(q) is str:
            p = index.get(q)
            if p is None:
                return None
        elif isinstance(q, Element) and q.frame is frame and len(q.terms) == 1:
            t = q.terms[0]
            p = t.bit_length() - 1
            if bits[p + 1] is not t and t.bit_count() != 1:
                return None
        else:
            return None
        positions.append(p)
    return _columns(len(frame), positions)


def _columns(n: int, positions: list[int]) -> tuple[np.ndarray, int] | None:
    """:func:`query_columns` of queries at these positions of an n-hypothesis frame; None if one comes twice."""
    if len(set(positions)) != len(positions):
        return None
    columns = np.full(n, -1, dtype=np.intp)
    columns[positions] = np.arange(len(positions))
    return columns, len(positions)


def own_bits(frame: Frame) -> tuple:
    """``None`` and the frame's hypothesis bits: item i + 1 is the bit of hypothesis i, the ``int`` of length i + 1.

    A mask ``m`` is a hypothesis's own bit object when ``bits[m.bit_length()] is m``: over
    thousands of hypotheses each test of another integer (bit_count, a hash) reads thousands
    of bits, its length and identity none.
    """
    return (None, *frame.bits)


def _entries(position: np.ndarray, counts: list[int] | None, columns: np.ndarray | None, width: int) -> Incidence:
    """The :class:`Incidence` of K focal elements whose hypotheses are at these positions, in order.

    Parameters
    ----------
    position : ndarray of intp, shape (E,)
        The position of every hypothesis of every focal element, focal element after focal element.
    counts : list of int, length K, or None
        The number of hypotheses of each focal element; None when each has one (E = K).
    columns, width
        As returned by :func:`query_columns`.
    """
    if counts is None:
        focal = np.arange(len(position), dtype=np.intp)
        size = np.ones(len(position))
    else:
        count = np.array(counts, dtype=np.intp)
        focal = np.repeat(np.arange(len(counts), dtype=np.intp), count)
        size = count[focal].astype(np.float64)
    if columns is None:
        return Incidence(focal, position, size, width, complete=True)
    query = columns[position]
    keep = query >= 0
    if keep.all():
        return Incidence(focal, query, size, width, complete=True)
    return Incidence(focal[keep], query[keep], size[keep], width)


def canonical_masks(frame: Frame, masks: Sequence[int]) -> list[int]:
    """The positions that put distinct unions of hypotheses (bit masks) in canonical order.

    The order of :meth:`MassFunction.focal <belief.mass.MassFunction.focal>` (fewer
    hypotheses first, then by their positions; ∅ first), found without making elements.
    Single hypotheses, the frame's own bits most often, are ordered by their bit length;
    only unions of several hypotheses need their bits compared.

    Parameters
    ----------
    frame : Frame
    masks : sequence of int, length K

    Returns
    -------
    list of int, length K

    Examples
    --------
    >>> f = Frame(["a", "b", "c"])
    >>> canonical_masks(f, [0b011, f.bits[2], 0, f.bits[0]])    # a|b, c, ∅, a -> ∅, a, c, a|b
    [2, 3, 1, 0]
    """
    lengths = list(map(int.bit_length, masks))
    return _canonical(frame, masks, lengths, list(map(is_, map(own_bits(frame).__getitem__, lengths), masks)))


def _canonical(frame: Frame, masks: Sequence[int], lengths: list[int], own: list[bool]) -> list[int]:
    """:func:`canonical_masks`, given the bit length of each mask and whether it is the frame's own bit."""
    n = len(frame)
    if n <= RANK_TABLE_WIDTH:
        rank = union_ranks(n)[2]
        return sorted(range(len(masks)), key=lambda i: rank[masks[i]])
    empty: list[int] = []
    single: list[int] = []
    unions: list[int] = []
    for i, (m, o) in enumerate(zip(masks, own)):
        (single if o or m and m.bit_count() == 1 else unions if m else empty).append(i)
    # Among single hypotheses the canonical order is by position; unions of more come after them all.
    single.sort(key=lengths.__getitem__)
    if unions:
        order = canonical_order(to_words([masks[i] for i in unions], word_count(n))).tolist()
        unions = [unions[i] for i in order]
    return empty + single + unions


#: The relation of the table of each measure of :func:`held_measure`.
_RELATIONS = {"bel": "subset", "pls": "meets", "q": "superset", "betp": "ratio"}


def held_measure(mass, method: str, queries) -> np.ndarray | None:
    """Bel, Pls, q or BetP of singleton queries from a mass function's bit masks, or None where that does not apply.

    :class:`~belief.mass.MassFunction` holds the unions of hypotheses it was given as bit masks
    and floats until its elements are read; under Shafer's model, for singleton queries
    (:func:`query_columns`) and tables of more than :data:`SPARSE_TABLE_ENTRIES` entries, its
    measures are weighed on the :class:`Incidence` of those masks (:func:`union_incidence`),
    in canonical order (:func:`canonical_masks`): the sums, the order of their terms and the
    normalisation of BetP are those of :meth:`MassBatch.bel <belief.batch.MassBatch.bel>` & co.
    on the mass function's batch, so the bits are too, and no element is made.

    Parameters
    ----------
    mass : MassFunction
    method : str
        ``"bel"``, ``"pls"``, ``"q"`` or ``"betp"`` (anything else gives None).
    queries : str, Element or sequence of them

    Returns
    -------
    ndarray, shape (1,) for one query (a str or an Element), (1, Q) for a sequence of Q; or None

    Raises
    ------
    TotalConflictError
        BetP of a mass function with m(∅) = 1.

    Examples
    --------
    >>> from belief import MassFunction
    >>> f = Frame([f"h{i}" for i in range(300)])
    >>> m = MassFunction({"h0": 0.5, "h1|h2": 0.5}, model=Model.shafer(f))
    >>> held_measure(m, "betp", f.hypotheses)[0, :4].tolist()
    [0.5, 0.25, 0.25, 0.0]
    """
    relation = _RELATIONS.get(method)
    model = mass.model
    if relation is None or model.kind != "shafer":
        return None
    held = mass._unions_as_held()
    if held is None:
        return None
    masks, floats = held
    frame = model.frame
    found = query_columns(frame, queries)
    if found is None or len(masks) * found[1] <= SPARSE_TABLE_ENTRIES:
        return None                             # small tables stay dense, as MeasurePlan.sparse has them
    # Loose masks are in the order given: sums in it could differ in their last bits from the canonical one.
    table, order = _union_table(frame, masks, mass._loose, *found)
    if order is None:
        values = mass.values.reshape(1, -1)
    else:
        values = np.array(floats, dtype=np.float64)[order].reshape(1, -1)
    if relation == "ratio" and values[0, 0] and not masks[0 if order is None else order[0]]:
        keep = np.ones(len(masks))
        keep[0] = 0.0                           # ∅, first in canonical order
        values = without_empty(values, keep, "BetP")
    result = table.weigh(values, relation)
    return result[:, 0] if type(queries) is str or isinstance(queries, Element) else result


def without_empty(values: np.ndarray, keep: np.ndarray, what: str) -> np.ndarray:
    """Rows with the mass of ∅ removed and rescaled by 1 - m(∅) (Dempster normalisation).

    Parameters
    ----------
    values : ndarray, shape (N, K)
    keep : ndarray of float, shape (K,)
        1 for the focal elements that are not ∅, 0 for ∅.
    what : str
        The measure, named by the error.

    Returns
    -------
    ndarray, shape (N, K)

    Raises
    ------
    TotalConflictError
        Where a row has m(∅) = 1.

    Examples
    --------
    >>> without_empty(np.array([[0.5, 0.25, 0.25]]), np.array([0.0, 1.0, 1.0]), "BetP")
    array([[0. , 0.5, 0.5]])
    """
    scale = (values * keep).sum(axis=1)
    dead = scale <= 0
    if dead.any():
        where = f" (row {int(np.flatnonzero(dead)[0])})" if values.shape[0] > 1 else ""
        raise TotalConflictError(f"{what} is undefined: total conflict, m(∅) = 1{where}")
    return values * keep / scale[:, None]
