"""Compiled combination plans: index tables for a fixed tuple of focal-element lists.

Combining s sources means visiting every tuple (X_1, …, X_s) of their focal elements.
The tuples, their intersections under the fusion model and where each rule sends their
product depend only on the focal elements, not on the masses, so they are compiled once
(and cached) into integer arrays.  A rule then evaluates all N rows of a batch with a few
numpy operations:

* ``products`` gathers the masses of each tuple and multiplies them, shape (N, T);
* a :class:`Scatter` adds contributions that go to the same result element with one
  ``np.add.reduceat`` over contributions sorted by target.

Compiling pays when the same focal elements come back (a tracker, a repeated fusion).  A
combination of focal elements seen for the first time is evaluated directly instead
(:mod:`belief.rules`), on integer codes of its focal elements (:func:`encode`): there ∩ and
∪ are ``&`` and ``|``, so the tuples' results cost a few numpy operations (or a loop over
a few dozen tuples) and no element is built per tuple; only the distinct results become
elements.  Hypothesis masks wider than 64 bits are rows of 64-bit words (:mod:`belief.masks`).
:func:`plan_lookup` and :func:`sighted` tell which way a call goes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import NamedTuple

import numpy as np

from belief.errors import CombinationTooLargeError
from belief.frame import Element, Frame, make_elements
from belief.masks import (canonical_order, from_words, single_terms, to_words, tuple_codes, tuple_groups, union_terms,
                          word_count)
from belief.model import Model

__all__ = ["TuplePlan", "Scatter", "FocalKey", "tuple_plan", "MAX_TUPLES", "MAX_WORK", "MAX_BYTES",
           "MAX_ELEMENT_TUPLES", "JobCost", "joint_cost", "check_joint", "FoldBudget", "coded_fast", "Encoding",
           "encode", "coded_table", "canonical_codes", "canonical_groups", "plan_lookup", "sighted", "mask_terms",
           "union_ranks", "union_elements", "RANK_TABLE_WIDTH", "weighted_sum", "exclusive_hypotheses"]

# The limits below are read when a combination starts, so a caller may raise them
# (``belief.plan.MAX_TUPLES = ...``).  The defaults keep an accepted job under about ten
# seconds and a gigabyte on a two-core machine; every refusal is a CombinationTooLargeError
# that names the limit.
#: A joint combination (a rule that is not associative) visits at most this many tuples of focal elements.
MAX_TUPLES = 4_000_000
#: A combination does at most this much work: rows × tuples × sources, weighted by the rule (:func:`joint_cost`).
MAX_WORK = 200_000_000
#: The index tables of a joint combination take at most about this many bytes.
MAX_BYTES = 768 * 2**20
#: Focal elements without codes that numpy combines (:func:`coded_fast`) go element by element, at most this many
#: tuples of them.
MAX_ELEMENT_TUPLES = 25_000
#: Rows are processed in chunks of about this many (row × tuple) entries, to bound memory.
CHUNK_ENTRIES = 1 << 18
#: Models that allow more Venn regions than this get no region codes (:func:`encode`).
REGION_LIMIT = 1 << 12
#: Frames of at most this many hypotheses get a table of the canonical order of their unions (:func:`union_ranks`).
RANK_TABLE_WIDTH = 16
#: How many compiled plans are kept, and how many lists of focal elements are remembered as seen.
PLAN_CACHE_SIZE = 512
SIGHTINGS_SIZE = 4096


class Scatter:
    """Sums contributions into result elements: ``out[:, r] = Σ_{e: target[e]=r} contrib[:, e]``.

    Parameters
    ----------
    targets : sequence of Element
        The result element of each contribution, shape (E,).

    Attributes
    ----------
    elements : tuple of Element
        The distinct targets in canonical order (the result's focal elements).
    order : ndarray of int, shape (E,)
        Contribution indices sorted by target.
    starts : ndarray of int, shape (R,)
        Where each target's run begins in ``order``.
    """

    def __init__(self, targets: Sequence[Element]) -> None:
        unique: dict[Element, int] = {}
        codes = np.fromiter((unique.setdefault(t, len(unique)) for t in targets), dtype=np.int64, count=len(targets))
        self._build(list(unique), codes)

    @classmethod
    def from_codes(cls, unique: Sequence[Element], codes: np.ndarray) -> "Scatter":
        """Build from distinct elements and, per contribution, the index of its target in ``unique``."""
        scatter = object.__new__(cls)
        scatter._build(list(unique), np.asarray(codes, dtype=np.int64))
        return scatter

    @classmethod
    def from_ranks(cls, ordered: Sequence[Element], ranks: np.ndarray) -> "Scatter":
        """Build from distinct elements already in canonical order and, per contribution, its target's position."""
        scatter = object.__new__(cls)
        scatter._finish(list(ordered), np.asarray(ranks, dtype=np.int64))
        return scatter

    def _build(self, unique: list[Element], codes: np.ndarray) -> None:
        keys = [e.sort_key for e in unique]
        rank_of = sorted(range(len(unique)), key=keys.__getitem__)
        rank = np.empty(len(unique), dtype=np.int64)
        rank[rank_of] = np.arange(len(unique))
        self._finish([unique[r] for r in rank_of], rank[codes] if len(codes) else codes)

    def _finish(self, ordered: list[Element], ranked: np.ndarray) -> None:
        unique = ordered
        if len(unique) < 1 << 16:
            # Small integer keys sort by radix in linear time.
            ranked = ranked.astype(np.uint16 if len(unique) >= 1 << 8 else np.uint8)
        order = np.argsort(ranked, kind="stable")
        sorted_codes = ranked[order]
        starts = (np.flatnonzero(np.r_[True, sorted_codes[1:] != sorted_codes[:-1]])
                  if len(ranked) else np.zeros(0, np.int64))
        present = sorted_codes[starts].tolist()
        self.elements = tuple(unique) if len(present) == len(unique) else tuple(unique[r] for r in present)
        self.order = order
        self.starts = starts

    def apply(self, sorted_contributions: np.ndarray) -> np.ndarray:
        """Sum contributions that are already in ``order``; (N, E) -> (N, R)."""
        if sorted_contributions.shape[1] == 0:
            return np.zeros((sorted_contributions.shape[0], 0))
        return np.add.reduceat(sorted_contributions, self.starts, axis=1)


@dataclass(frozen=True, eq=False)
class TuplePlan:
    """All tuples of focal elements of s sources, with their intersections under a model.

    Attributes
    ----------
    source_model, model : Model
        The model the sources were elicited under, and the fusion model.
    focal : tuple of tuple of Element
        The focal elements of each source (as elicited).
    """

    source_model: Model
    model: Model
    focal: tuple[tuple[Element, ...], ...]

    @property
    def sizes(self) -> tuple[int, ...]:
        return tuple(len(f) for f in self.focal)

    @cached_property
    def count(self) -> int:
        return math.prod(self.sizes)        # a Python int: an int64 product wraps past 2^63 tuples

    @cached_property
    def columns(self) -> tuple[np.ndarray, ...]:
        """For each source, its focal-element column in every tuple (row-major order), shape (T,)."""
        sizes = self.sizes
        columns = []
        for i, size in enumerate(sizes):
            inner = math.prod(sizes[i + 1:])
            outer = math.prod(sizes[:i])
            columns.append(np.tile(np.repeat(np.arange(size, dtype=np.int64), inner), outer))
        return tuple(columns)

    @cached_property
    def projected(self) -> tuple[tuple[Element, ...], ...]:
        """The focal elements reduced under the fusion model (∅ if they vanish there)."""
        model = self.model
        return tuple(tuple(model.reduce(x) for x in f) for f in self.focal)

    @cached_property
    def tuples(self) -> list[tuple[int, ...]]:
        return list(zip(*(c.tolist() for c in self.columns)))

    @cached_property
    def meet_table(self) -> tuple[list[Element], np.ndarray]:
        """X_1 ∩ … ∩ X_s under the fusion model: the distinct results and, per tuple, an index into them."""
        return self._fold(lambda a, b: a & b, np.bitwise_and)

    @cached_property
    def join_table(self) -> tuple[list[Element], np.ndarray]:
        """X_1 ∪ … ∪ X_s under the fusion model, as :attr:`meet_table`."""
        return self._fold(lambda a, b: a | b, np.bitwise_or)

    @cached_property
    def meets(self) -> list[Element]:
        """X_1 ∩ … ∩ X_s under the fusion model, for every tuple."""
        unique, codes = self.meet_table
        return [unique[c] for c in codes.tolist()]

    @cached_property
    def joins(self) -> list[Element]:
        """X_1 ∪ … ∪ X_s under the fusion model, for every tuple."""
        unique, codes = self.join_table
        return [unique[c] for c in codes.tolist()]

    def _fold(self, op, ufunc) -> tuple[list[Element], np.ndarray]:
        coded = coded_table(self.model, self.projected, ufunc)
        if coded is not None:
            return coded
        # Fold source by source, caching partial results per prefix of the tuple.
        model = self.model
        partial: dict[tuple[int, ...], Element] = {(i,): x for i, x in enumerate(self.projected[0])}
        for source in range(1, len(self.focal)):
            nxt: dict[tuple[int, ...], Element] = {}
            for prefix, value in partial.items():
                for i, x in enumerate(self.projected[source]):
                    nxt[prefix + (i,)] = model.reduce(op(value, x))
            partial = nxt
        unique: dict[Element, int] = {}
        codes = np.fromiter((unique.setdefault(partial[t], len(unique)) for t in self.tuples),
                            dtype=np.int64, count=self.count)
        return list(unique), codes

    @cached_property
    def conflicting(self) -> np.ndarray:
        """True where the tuple's intersection is empty under the fusion model, shape (T,)."""
        unique, codes = self.meet_table
        empty = np.array([not e.terms for e in unique], dtype=bool)
        return empty[codes]

    # -- evaluation ---------------------------------------------------------------------------
    def products(self, values: Sequence[np.ndarray], order: np.ndarray | None = None) -> np.ndarray:
        """Π_i m_i(X_i) for every tuple (optionally in ``order``); values[i] has shape (N, K_i)."""
        columns = self.columns if order is None else tuple(c[order] for c in self.columns)
        return gather_product(values, columns)


def weighted_sum(values: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Σ_k values[:, k] · table[k, q] for every q, shape (N, Q): the same bits on every machine and in every context.

    Each column q is summed over the k with a non-zero weight, in the order of k, each term
    rounded on its own (a weight of 1 adds the mass itself).  A column of the result thus
    depends neither on the other columns of ``table``, nor on the other rows, nor on columns
    of ``values`` whose weight is 0 (a focal element that another mass function of a batch
    holds), nor on the CPU.  A BLAS matrix product (``values @ table``) chooses its kernel,
    its fused multiply-adds and its order of summation by CPU and by shape, so that BetP of
    one query could differ in its last bit from BetP of the same query in a list, and from
    one machine to another.

    Parameters
    ----------
    values : ndarray, shape (N, K)
    table : ndarray, shape (K, Q)

    Examples
    --------
    >>> weighted_sum(np.array([[0.1, 0.2, 0.7]]), np.array([[1.0, 0.5], [0.0, 0.0], [1.0, 0.25]]))
    array([[0.8  , 0.225]])
    """
    n = values.shape[0]
    out = np.empty((n, table.shape[1]))
    # Blocks that stay in the CPU's cache, but never so short that the Python loop dominates.
    step = max(4096, _WEIGHTED_BLOCK // max(values.shape[1] + table.shape[1], 1))
    k, q = table.shape
    block_rows = min(n, step)
    entries = int(np.count_nonzero(table))
    if k * (_STEP_COST + block_rows * q) < entries * (_STEP_COST + block_rows):
        # Few rows and a full table: a step per focal element over every query beats a step per entry.  Adding
        # a term of weight 0 (a finite mass times 0) leaves each sum as it is, and a weight of 1 gives the mass
        # itself, so the sums are the same bits, term by term in the order of the focal elements.
        for start in range(0, n, step):
            rows = values[start:start + step]
            total = np.zeros((rows.shape[0], q))
            for x in range(k):
                total += rows[:, x:x + 1] * table[x]
            out[start:start + step] = total
        return out
    weights = _nonzero_columns(table)
    for start in range(0, n, step):
        columns = np.ascontiguousarray(values[start:start + step].T)     # each focal element's masses
        block = np.zeros((table.shape[1], columns.shape[1]))
        term = np.empty(columns.shape[1])
        for q, (rows, factors) in enumerate(weights):
            total = block[q]
            for k, w in zip(rows, factors):
                total += columns[k] if w == 1.0 else np.multiply(columns[k], w, out=term)
        out[start:start + step] = block.T
    return out


#: Floats per block of rows in :func:`weighted_sum` (about 1 MB).
_WEIGHTED_BLOCK = 1 << 17
#: The cost of one step of a Python loop, in floats added (about a microsecond).
_STEP_COST = 1000


def _nonzero_columns(table: np.ndarray) -> list[tuple[list[int], list[float]]]:
    """For each column of ``table``, the rows of its non-zero weights and those weights."""
    return [(np.flatnonzero(column).tolist(), column[column != 0].tolist()) for column in table.T]


def gather_product(values: Sequence[np.ndarray], columns: Sequence[np.ndarray]) -> np.ndarray:
    """Π_i values[i][:, columns[i]], shape (N, len(columns[0]))."""
    result = values[0].take(columns[0], axis=1)
    for v, c in zip(values[1:], columns[1:]):
        result *= v.take(c, axis=1)
    return result


class FocalKey:
    """A hashable stand-in for a tuple of focal elements, hashed once (plans are looked up by it)."""

    __slots__ = ("focal", "_hash")

    def __init__(self, focal: tuple[Element, ...]) -> None:
        self.focal = focal
        self._hash = hash(focal)

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, FocalKey):
            return NotImplemented
        return self.focal is other.focal or (self._hash == other._hash and self.focal == other.focal)


def tuple_plan(source_model: Model, model: Model, focal) -> TuplePlan:
    """The cached :class:`TuplePlan` of these focal-element lists (tuples of elements or :class:`FocalKey`)."""
    keys = tuple(f if isinstance(f, FocalKey) else FocalKey(tuple(f)) for f in focal)
    key = (source_model, model, keys)
    plan = _PLANS.pop(key, None)
    if plan is None:
        plan = TuplePlan(source_model, model, tuple(k.focal for k in keys))
        if len(_PLANS) >= PLAN_CACHE_SIZE:
            evict(_PLANS)
    _PLANS[key] = plan                       # most recently used last
    return plan


def plan_lookup(source_model: Model, model: Model, keys: tuple[FocalKey, ...]) -> TuplePlan | None:
    """The cached plan of these focal lists, or None: nothing is compiled or recorded."""
    return _PLANS.get((source_model, model, keys))


def sighted(source_model: Model, model: Model, keys: tuple[FocalKey, ...], purpose: str = "") -> bool:
    """Whether these focal lists were met before under these models for ``purpose``; the first call records them."""
    key = (source_model, model, keys, purpose)
    if _SIGHTINGS.pop(key, False):
        _SIGHTINGS[key] = True
        return True
    if len(_SIGHTINGS) >= SIGHTINGS_SIZE:
        evict(_SIGHTINGS)
    _SIGHTINGS[key] = True
    return False


def evict(cache: dict) -> None:
    """Drop the least recently used entry of a cache kept as a dict (the first in insertion order).

    Another thread may have changed the dict meanwhile; then there is nothing to do.
    """
    try:
        del cache[next(iter(cache))]
    except (KeyError, RuntimeError, StopIteration):
        pass


#: Compiled plans and seen focal lists, least recently used first (dicts keep insertion order).
_PLANS: dict[tuple, TuplePlan] = {}
_SIGHTINGS: dict[tuple, bool] = {}


# -- integer codes of focal elements -------------------------------------------------------------------
class Encoding(NamedTuple):
    """Integer codes of the focal elements of s sources under a fusion model.

    For any elements X and Y of the sources, X ∩ Y under the model has the code
    ``c(X) & c(Y)``, X ∪ Y has ``c(X) | c(Y)``, ∅ has 0, and two elements have equal codes
    exactly when they are equal under the model.

    Attributes
    ----------
    kind : {"exclusive", "regions"}
        ``exclusive``: every focal element is a union of hypotheses that exclude one
        another under the model (Shafer's model, say), and its code is the bit mask of
        those hypotheses.  ``regions``: the code has one bit per Venn region that the model
        allows, set for the regions inside the element.
    codes : tuple of tuple of int
        The code of every focal element, source by source.
    width : int
        The number of bits a code may use (hypotheses, or allowed regions).
    """

    kind: str
    codes: tuple[tuple[int, ...], ...]
    width: int


def encode(model: Model, projected: Sequence[Sequence[Element]]) -> Encoding | None:
    """The codes of focal elements already reduced under ``model``, or None if the model has too many regions.

    Parameters
    ----------
    model : Model
        The fusion model.
    projected : sequence of sequence of Element
        Each source's focal elements in their form under ``model``.

    Examples
    --------
    >>> from belief import Frame
    >>> f = Frame(["a", "b", "c"])
    >>> encode(Model.shafer(f), [[f["a"], f.element("a|c")], [f["c"]]])
    Encoding(kind='exclusive', codes=((1, 5), (4,)), width=3)
    >>> encode(Model.free(f), [[f["a"]], [f["b"]]]).kind
    'regions'
    """
    if model.kind == "shafer":
        # Under Shafer's model a reduced element has single-hypothesis conjunctions only.
        return Encoding("exclusive", tuple(tuple([sum(x.terms) for x in elements]) for elements in projected),
                        len(model.frame))
    used = 0
    single = True
    for elements in projected:
        for x in elements:
            for t in x.terms:
                used |= t
                if single and t & (t - 1):
                    single = False
    if single and exclusive_hypotheses(model, used):
        return Encoding("exclusive", tuple(tuple([sum(x.terms) for x in elements]) for elements in projected),
                        len(model.frame))
    table = _region_table(model)
    if table is None:
        return None
    hypotheses, width = table
    memo: dict[int, int] = {}
    codes = []
    for elements in projected:
        row = []
        for x in elements:
            code = 0
            for t in x.terms:
                region = memo.get(t)
                if region is None:
                    region = -1
                    m = t
                    while m:
                        low = m & -m
                        region &= hypotheses[low.bit_length() - 1]
                        m ^= low
                    memo[t] = region
                code |= region
            row.append(code)
        codes.append(tuple(row))
    return Encoding("regions", tuple(codes), width)


@lru_cache(maxsize=1024)
def exclusive_hypotheses(model: Model, used: int) -> bool:
    """Whether the model forbids every pair of the hypotheses in ``used``.

    A pair a|b is forbidden when a constraint lies inside it: a, b or a|b itself.  So the
    hypotheses forbidden on their own are set aside, and the others must have every one of
    their pairs listed: the count of listed pairs inside them tells, in one pass over the
    constraints (n² checks of the pairs themselves took seconds on a frame of a few hundred).
    """
    if model.kind == "shafer":
        return True
    alone = 0
    for f in model.forbidden:
        if not f & (f - 1):
            alone |= f
    rest = used & ~alone
    k = rest.bit_count()
    pairs = sum(1 for f in model.forbidden if f.bit_count() == 2 and not f & ~rest)
    return pairs == k * (k - 1) // 2


@lru_cache(maxsize=64)
def _region_table(model: Model) -> tuple[tuple[int, ...], int] | None:
    """For each hypothesis, the set of allowed regions that contain it (a bit per region), and their number.

    None when the model allows more than :data:`REGION_LIMIT` regions (or the frame is too
    large to list its regions).
    """
    n = len(model.frame)
    if n > 12 or model.cardinality(model.total) > REGION_LIMIT:
        return None
    hypotheses = [0] * n
    count = 0
    for region in range(1, 1 << n):
        if model.is_forbidden(region):
            continue
        bit = 1 << count
        count += 1
        m = region
        while m:
            low = m & -m
            hypotheses[low.bit_length() - 1] |= bit
            m ^= low
    return tuple(hypotheses), count


def mask_terms(mask: int) -> tuple[int, ...]:
    """The single-hypothesis conjunctions of a hypothesis mask, in frame order.

    >>> mask_terms(0b1011)
    (1, 2, 8)
    """
    return single_terms(mask)


@lru_cache(maxsize=None)
def union_ranks(n: int) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """The canonical order of the 2^n unions of hypotheses of an n-hypothesis frame (∅ first).

    Returns ``rank`` (the position of every mask), ``unrank`` (the mask at every position)
    and ``rank`` as a list.  Fewer hypotheses come first; among as many, the set whose
    smallest differing position is its own, i.e. the larger bit-reversed mask (the order of
    :attr:`Element.sort_key`).  The table depends on n only; n is at most
    :data:`RANK_TABLE_WIDTH`.

    >>> rank, unrank, _ = union_ranks(3)
    >>> unrank.tolist()      # ∅, a, b, c, a|b, a|c, b|c, a|b|c
    [0, 1, 2, 4, 3, 5, 6, 7]
    """
    if not 0 <= n <= RANK_TABLE_WIDTH:
        raise ValueError(f"rank tables go up to {RANK_TABLE_WIDTH} hypotheses, not {n}")
    masks = np.arange(1 << n, dtype=np.uint64)
    unrank = np.lexsort((~_reversed_bits(masks, n), np.bitwise_count(masks))).astype(np.int64)
    rank = np.empty(1 << n, dtype=np.int64)
    rank[unrank] = np.arange(1 << n)
    rank.flags.writeable = False
    unrank.flags.writeable = False
    return rank, unrank, rank.tolist()


def _reversed_bits(masks: np.ndarray, width: int) -> np.ndarray:
    """Each uint64 mask with its lowest ``width`` bits in reverse order."""
    reverse = np.zeros(len(masks), dtype=np.uint64)
    for i in range(width):
        reverse |= ((masks >> np.uint64(i)) & np.uint64(1)) << np.uint64(width - 1 - i)
    return reverse


def union_elements(frame: Frame, masks: Sequence[int]) -> list[Element]:
    """The unions of hypotheses given by bit masks (0 gives ∅).

    On frames of at most :data:`RANK_TABLE_WIDTH` hypotheses the elements made are kept (at
    most :data:`ELEMENT_CACHE_SIZE` a frame, for :data:`ELEMENT_CACHE_FRAMES` frames): the
    same few unions come back in every mass function read, and elements are immutable.
    """
    if len(frame) > RANK_TABLE_WIDTH:
        # Single hypotheses parsed from their names are the frame's own bits: found by identity, not made.
        singleton = frame.singleton_of_bit
        found = [singleton(m) for m in masks]
        if None not in found:
            return found
        missing = [m for m, e in zip(masks, found) if e is None]
        made = iter(make_elements(frame, union_terms(missing, len(frame))))
        return [e if e is not None else next(made) for e in found]
    known = _ELEMENTS.get(frame)
    if known is None:
        if len(_ELEMENTS) >= ELEMENT_CACHE_FRAMES:
            evict(_ELEMENTS)
        known = _ELEMENTS[frame] = {}
    found = list(map(known.get, masks))
    if None not in found:
        return found
    missing = list(dict.fromkeys(m for m, e in zip(masks, found) if e is None))
    made = dict(zip(missing, make_elements(frame, union_terms(missing, len(frame)))))
    if len(known) + len(made) > ELEMENT_CACHE_SIZE:
        known.clear()
    known.update(made)
    return [e if e is not None else made[m] for m, e in zip(masks, found)]


#: How many elements made from masks are kept per frame, and for how many frames (:func:`union_elements`).
ELEMENT_CACHE_SIZE = 4096
ELEMENT_CACHE_FRAMES = 16
_ELEMENTS: dict[Frame, dict[int, Element]] = {}


def decode(model: Model, encoding: Encoding, projected: Sequence[Sequence[Element]], codes: Sequence[int],
           tuples: Sequence[Sequence[int]], ops: Sequence[str]) -> list[Element]:
    """The elements of some tuple codes.

    ``tuples[k]`` is a tuple (one column per source) whose ∩ (``ops[k] == "meet"``) or ∪
    (``"join"``) has the code ``codes[k]``; region codes are turned into elements through it.
    """
    if encoding.kind == "exclusive":
        return union_elements(model.frame, codes)
    out = []
    for columns, op in zip(tuples, ops):
        value = projected[0][columns[0]]
        for source in range(1, len(projected)):
            x = projected[source][columns[source]]
            value = model.reduce(value & x if op == "meet" else value | x)
        out.append(value)
    return out


def canonical_codes(model: Model, encoding: Encoding, projected: Sequence[Sequence[Element]], codes: np.ndarray,
                    ops: np.ndarray | str) -> tuple[list[Element], np.ndarray]:
    """The distinct elements of some tuple codes in canonical order, and each code's position among them.

    ``codes`` (uint64, one per tuple in row-major order) are ∩ or ∪ of the tuples' focal
    elements, as ``ops`` says: "meet", "join", or per tuple True for ∩ (region codes are
    turned into elements through a tuple that has them).
    """
    if encoding.kind == "exclusive":
        n = len(model.frame)
        if n <= RANK_TABLE_WIDTH:
            # The canonical positions of all 2^n unions: a look-up and no sort of elements.
            rank, unrank, _ = union_ranks(n)
            ranked = rank[codes.astype(np.intp)]
            present = np.flatnonzero(np.bincount(ranked, minlength=1 << n))
            compact = np.zeros(1 << n, dtype=np.int64)
            compact[present] = np.arange(len(present))
            return union_elements(model.frame, unrank[present].tolist()), compact[ranked]
        present, inverse = np.unique(codes, return_inverse=True)
        return canonical_groups(model, encoding, projected, present.reshape(-1, 1), None, inverse.reshape(-1), ops)
    unique, first, inverse = np.unique(codes, return_index=True, return_inverse=True)
    return canonical_groups(model, encoding, projected, unique.reshape(-1, 1), first, inverse.reshape(-1), ops)


def canonical_groups(model: Model, encoding: Encoding, projected: Sequence[Sequence[Element]], unique: np.ndarray,
                     first: np.ndarray | None, inverse: np.ndarray,
                     ops: np.ndarray | str) -> tuple[list[Element], np.ndarray]:
    """:func:`canonical_codes` of tuples already grouped by their code (:func:`belief.masks.tuple_groups`).

    ``unique`` holds the distinct codes as rows of 64-bit words, ``first`` a tuple that has
    each (needed for region codes only), ``inverse`` each tuple's row of ``unique``.
    """
    if encoding.kind == "exclusive":
        # Unions of hypotheses: sorted by their masks, and made from the masks alone.
        order = canonical_order(unique)
        rank = np.empty(len(order), dtype=np.int64)
        rank[order] = np.arange(len(order))
        return union_elements(model.frame, from_words(unique[order])), rank[inverse]
    sizes = tuple(len(c) for c in encoding.codes)
    tuples = list(zip(*(c.tolist() for c in np.unravel_index(first, sizes))))
    if isinstance(ops, str):
        kinds = [ops] * len(tuples)
    else:
        kinds = ["meet" if m else "join" for m in ops[first].tolist()]
    elements = decode(model, encoding, projected, from_words(unique), tuples, kinds)
    keys = [e.sort_key for e in elements]
    order = sorted(range(len(elements)), key=keys.__getitem__)
    rank = np.empty(len(elements), dtype=np.int64)
    rank[order] = np.arange(len(elements))
    return [elements[k] for k in order], rank[inverse]


def coded_table(model: Model, projected: Sequence[Sequence[Element]], ufunc,
                encoding: Encoding | None = None) -> tuple[list[Element], np.ndarray] | None:
    """The ∩ (``np.bitwise_and``) or ∪ (``np.bitwise_or``) of every tuple from integer codes.

    Returns the distinct results and, per tuple in row-major order, an index into them
    (as :attr:`TuplePlan.meet_table`), or None where the codes are region codes wider than
    64 bits, or there are none.  Hypothesis masks wider than 64 bits are rows of words,
    combined a block of tuples at a time.
    """
    if encoding is None:
        encoding = encode(model, projected)
    if encoding is None:
        return None
    op = "meet" if ufunc is np.bitwise_and else "join"
    if encoding.width <= 64:
        combined = tuple_codes([np.array(c, dtype=np.uint64) for c in encoding.codes], ufunc)
        return canonical_codes(model, encoding, projected, combined, op)
    if encoding.kind != "exclusive":
        return None                     # region codes of more than 64 bits: element by element (coded_fast)
    words = word_count(encoding.width)
    unique, first, inverse = tuple_groups([to_words(c, words) for c in encoding.codes], ufunc)
    return canonical_groups(model, encoding, projected, unique, first, inverse, op)


def row_chunks(n_rows: int, width: int):
    """Slices of rows such that each chunk holds about ``CHUNK_ENTRIES`` (row × width) entries."""
    step = max(1, CHUNK_ENTRIES // max(1, width))
    for start in range(0, n_rows, step):
        yield slice(start, min(n_rows, start + step))


# -- the cost of a combination, estimated before it starts -----------------------------------------------
#: Relative time per row × tuple × source of each kind of evaluation, as (numerator, denominator).
_WORK_WEIGHTS = {"pcr": (1, 1), "targets": (1, 4), "fold": (1, 4)}
#: Bytes of index tables per tuple × source (measured: the PCR tables keep several int64 copies of the columns).
_ENTRY_BYTES = {"pcr": 64, "targets": 12, "fold": 12}
#: Building the tables of a combination costs about as much as evaluating this many rows on them.
TABLE_ROWS = 8


class JobCost(NamedTuple):
    """The estimated size of a combination (Python ints: they never wrap)."""

    tuples: int
    work: int
    bytes: int


def joint_cost(sizes: Sequence[int], rows: int = 1, kind: str = "pcr", pcr5: bool = False) -> JobCost:
    """The cost of visiting every tuple of focal elements of sources of these sizes.

    Parameters
    ----------
    sizes : sequence of int
        The number of focal elements of each source, shape (s,).
    rows : int
        The number of rows of the batch.
    kind : {"pcr", "targets", "fold"}
        ``"pcr"``: PCR5 / PCR6 shares; ``"targets"``: one target per tuple (DSmH,
        Dubois–Prade); ``"fold"``: one pairwise step of an associative rule.
    pcr5 : bool
        PCR5 groups the equal elements of a tuple, in time quadratic in the sources.

    Returns
    -------
    JobCost
        ``tuples`` = Π sizes; ``work`` = rows × tuples × s (the tables counted as
        :data:`TABLE_ROWS` rows), weighted by the kind; ``bytes`` = tuples × s × the bytes per
        entry of the kind's tables.

    Examples
    --------
    >>> joint_cost([2] * 64).tuples == 2 ** 64      # no int64 wrap-around
    True
    >>> joint_cost([3, 3, 3], rows=2)
    JobCost(tuples=27, work=810, bytes=5184)
    """
    tuples = math.prod(sizes)
    s = len(sizes)
    numerator, denominator = _WORK_WEIGHTS[kind]
    if pcr5:
        numerator, denominator = numerator * max(5, s), denominator * 5
    work = tuples * s * (rows + TABLE_ROWS) * numerator // denominator
    return JobCost(tuples, work, tuples * s * _ENTRY_BYTES[kind])


def count_text(count: int) -> str:
    """A count for a message: with thousands separators, or as a power of ten beyond 24 digits.

    >>> count_text(16_777_216), count_text(3 ** 300)
    ('16,777,216', 'about 1.4 x 10^143')
    """
    digits = len(str(count))
    if digits <= 24:
        return f"{count:,}"
    head = int(str(count)[:3]) / 100
    return f"about {head:.1f} x 10^{digits - 1}"


def _refuse(what: str, limit: str, value: int, unit: str = "") -> CombinationTooLargeError:
    return CombinationTooLargeError(f"{what}, more than belief.plan.{limit} = {value:,}{unit}; use fewer focal "
                                    f"elements, sources or rows, or raise belief.plan.{limit}",
                                    limit=f"belief.plan.{limit}")


def check_joint(rule: str, sizes: Sequence[int], rows: int = 1, kind: str = "pcr", fast=True,
                pcr5: bool = False) -> JobCost:
    """Refuse a joint combination that would exceed :data:`MAX_TUPLES`, :data:`MAX_WORK` or :data:`MAX_BYTES`.

    ``fast=False`` says that the focal elements have no 64-bit codes, so that every tuple
    is combined element by element, at most :data:`MAX_ELEMENT_TUPLES` of them; ``fast`` may
    be a callable, asked only when there are more tuples than that.

    Raises
    ------
    CombinationTooLargeError
        Naming the limit exceeded and the estimate.

    Examples
    --------
    >>> check_joint("pcr6", [2] * 64)
    Traceback (most recent call last):
    ...
    belief.errors.CombinationTooLargeError: joint pcr6 combination of 64 sources visits 18,446,744,073,709,551,616 \
tuples of focal elements, more than belief.plan.MAX_TUPLES = 4,000,000; use fewer focal elements, sources or rows, \
or raise belief.plan.MAX_TUPLES
    """
    cost = joint_cost(sizes, rows, kind, pcr5)
    what = f"joint {rule} combination of {len(sizes)} sources visits {count_text(cost.tuples)} tuples of focal elements"
    if cost.tuples > MAX_TUPLES:
        raise _refuse(what, "MAX_TUPLES", MAX_TUPLES)
    if cost.tuples > MAX_ELEMENT_TUPLES and not (fast() if callable(fast) else fast):
        raise _refuse(what + " element by element (the model gives them no 64-bit codes)", "MAX_ELEMENT_TUPLES",
                      MAX_ELEMENT_TUPLES)
    if cost.work > MAX_WORK:
        raise _refuse(f"{what} in {rows:,} row{'s' if rows != 1 else ''}, about {count_text(cost.work)} units of work",
                      "MAX_WORK", MAX_WORK)
    if cost.bytes > MAX_BYTES:
        raise _refuse(f"{what}, with index tables of about {count_text(cost.bytes)} bytes", "MAX_BYTES", MAX_BYTES, " bytes")
    return cost


class FoldBudget:
    """The running cost of an associative rule folded pairwise, checked before each step.

    The partial results of a fold may grow at every step (on a free model, up to the
    product of the sources' sizes), so the cost is not known in advance: each step is
    checked before it runs, against the limits of :func:`check_joint` applied to the
    whole fold so far.

    Examples
    --------
    >>> budget = FoldBudget("dempster", 3, rows=1)
    >>> budget.step(4, 5, 2)
    >>> budget.tuples
    20
    """

    __slots__ = ("rule", "sources", "rows", "fast", "slow_reason", "tuples", "work")

    def __init__(self, rule: str, sources: int, rows: int = 1, fast=True,
                 slow_reason: str = "the model gives them no 64-bit codes") -> None:
        self.rule = rule
        self.sources = sources
        self.rows = rows
        self.fast = fast                # a bool, or a callable that tells (asked only when it matters)
        self.slow_reason = slow_reason
        self.tuples = 0
        self.work = 0

    def step(self, left: int, right: int, source: int) -> None:
        """Account for a step that combines a partial result of ``left`` focal elements with ``source`` (``right``)."""
        cost = joint_cost((left, right), self.rows, "fold")
        self.tuples += cost.tuples
        self.work += cost.work
        what = (f"{self.rule} of {self.sources} sources, folded pairwise, would visit {count_text(self.tuples)} tuples of focal "
                f"elements by source {source} (its partial result has {left:,} focal elements)")
        if cost.tuples > MAX_TUPLES:
            raise _refuse(what, "MAX_TUPLES", MAX_TUPLES)
        if self.tuples > MAX_ELEMENT_TUPLES:
            if callable(self.fast):
                self.fast = bool(self.fast())
            if not self.fast:
                raise _refuse(f"{what} element by element ({self.slow_reason})", "MAX_ELEMENT_TUPLES",
                              MAX_ELEMENT_TUPLES)
        if self.work > MAX_WORK:
            raise _refuse(f"{what}, about {count_text(self.work)} units of work in {self.rows:,} row"
                          f"{'s' if self.rows != 1 else ''}", "MAX_WORK", MAX_WORK)
        if cost.bytes > MAX_BYTES:
            raise _refuse(f"{what}, with index tables of about {count_text(cost.bytes)} bytes", "MAX_BYTES", MAX_BYTES,
                          " bytes")


def coded_fast(model: Model, focal: Sequence[Sequence[Element]] = ()) -> bool:
    """Whether elements of ``model`` (or at least these focal elements) have codes that numpy combines (:func:`encode`).

    Those are region codes of at most 64 bits, or the hypothesis masks of unions of exclusive
    hypotheses (of any width, :func:`coded_table`).  Without codes, tuples are combined
    element by element, thousands of times slower.
    """
    if model.kind == "shafer":
        return True
    table = _region_table(model)
    if table is not None and table[1] <= 64:
        return True
    used = 0
    for elements in focal:
        for x in elements:
            for t in x.terms:
                if t & (t - 1):
                    return False
                used |= t
    return bool(focal) and exclusive_hypotheses(model, used)
