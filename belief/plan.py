"""Compiled combination plans: index tables for a fixed tuple of focal-element lists.

Combining s sources means visiting every tuple (X_1, …, X_s) of their focal elements.
The tuples, their intersections under the fusion model and where each rule sends their
product depend only on the focal elements, not on the masses, so they are compiled once
(and cached) into integer arrays.  A rule then evaluates all N rows of a batch with a few
numpy operations:

* ``products`` gathers the masses of each tuple and multiplies them, shape (N, T);
* a :class:`Scatter` adds contributions that go to the same result element with one
  ``np.add.reduceat`` over contributions sorted by target.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from belief.frame import Element
from belief.model import Model

__all__ = ["TuplePlan", "Scatter", "FocalKey", "tuple_plan", "MAX_TUPLES"]

#: Refuse joint combinations with more focal-element tuples than this.
MAX_TUPLES = 20_000_000
#: Rows are processed in chunks of about this many (row × tuple) entries, to bound memory.
CHUNK_ENTRIES = 1 << 18


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

    def _build(self, unique: list[Element], codes: np.ndarray) -> None:
        keys = [e.sort_key for e in unique]
        rank_of = sorted(range(len(unique)), key=keys.__getitem__)
        rank = np.empty(len(unique), dtype=np.int64)
        rank[rank_of] = np.arange(len(unique))
        ranked = rank[codes] if len(codes) else codes
        if len(unique) < 1 << 16:
            # Small integer keys sort by radix in linear time.
            ranked = ranked.astype(np.uint16 if len(unique) >= 1 << 8 else np.uint8)
        order = np.argsort(ranked, kind="stable")
        sorted_codes = ranked[order]
        starts = (np.flatnonzero(np.r_[True, sorted_codes[1:] != sorted_codes[:-1]])
                  if len(codes) else np.zeros(0, np.int64))
        self.elements = tuple(unique[rank_of[r]] for r in sorted_codes[starts].tolist())
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
        return int(np.prod(self.sizes, dtype=np.int64))

    @cached_property
    def columns(self) -> tuple[np.ndarray, ...]:
        """For each source, its focal-element column in every tuple (row-major order), shape (T,)."""
        sizes = self.sizes
        columns = []
        for i, size in enumerate(sizes):
            inner = int(np.prod(sizes[i + 1:], dtype=np.int64))
            outer = int(np.prod(sizes[:i], dtype=np.int64))
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
        fast = self._fold_exclusive(ufunc)
        if fast is not None:
            return fast
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

    def _fold_exclusive(self, ufunc) -> tuple[list[Element], np.ndarray] | None:
        """Vectorised fold when every element is a union of hypotheses that exclude one another.

        Under Shafer's model (or any model that forbids every pair of the hypotheses the
        focal elements use) an element is just the set of its hypotheses, so ∩ and ∪ are
        bitwise AND and OR of one 64-bit mask per element.
        """
        n = len(self.model.frame)
        if n > 63 or self.count < 64:
            return None
        used = 0
        for elements in self.projected:
            for x in elements:
                if any(t & (t - 1) for t in x.terms):
                    return None
                used |= x.hypotheses
        bits = [i for i in range(n) if used >> i & 1]
        if not all(self.model.is_forbidden((1 << i) | (1 << j)) for a, i in enumerate(bits) for j in bits[a + 1:]):
            return None
        masks = [np.array([x.hypotheses for x in elements], dtype=np.uint64) for elements in self.projected]
        combined = masks[0][self.columns[0]]
        for m, c in zip(masks[1:], self.columns[1:]):
            combined = ufunc(combined, m[c])
        unique, inverse = np.unique(combined, return_inverse=True)
        frame = self.model.frame
        elements = [_union_of(frame, u) for u in unique.tolist()]
        return elements, inverse.reshape(-1).astype(np.int64)

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


def gather_product(values: Sequence[np.ndarray], columns: Sequence[np.ndarray]) -> np.ndarray:
    """Π_i values[i][:, columns[i]], shape (N, len(columns[0]))."""
    result = values[0].take(columns[0], axis=1)
    for v, c in zip(values[1:], columns[1:]):
        result *= v.take(c, axis=1)
    return result


@lru_cache(maxsize=1 << 16)
def _union_of(frame, mask: int) -> Element:
    """The union of the hypotheses in ``mask`` (cached: exclusive models reuse few elements)."""
    return Element._make(frame, tuple(1 << i for i in range(mask.bit_length()) if mask >> i & 1))


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
    return _cached_plan(source_model, model, keys)


@lru_cache(maxsize=512)
def _cached_plan(source_model: Model, model: Model, keys: tuple[FocalKey, ...]) -> TuplePlan:
    return TuplePlan(source_model, model, tuple(k.focal for k in keys))


def row_chunks(n_rows: int, width: int):
    """Slices of rows such that each chunk holds about ``CHUNK_ENTRIES`` (row × width) entries."""
    step = max(1, CHUNK_ENTRIES // max(1, width))
    for start in range(0, n_rows, step):
        yield slice(start, min(n_rows, start + step))
