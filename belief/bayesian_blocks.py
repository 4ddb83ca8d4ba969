"""What the closed-form fusions share: the sources read in blocks of rows, and the base class of the fusions.

A fusion (:class:`Fusion`) gives the measures of a fused batch by element class; it reads the sources through
:class:`Blocks`, a block of rows at a time, each turned to (hypotheses, rows) in frame order.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache

import numpy as np

from belief.batch import MassBatch
from belief.bayesian_split import ExclusiveSplit

#: Rows × |O| × |O| entries per block of the pairwise pass of the R-weighted rule.
PAIR_BLOCK_ENTRIES = 1 << 19
#: Rows × n entries per block of rows of the R-weighted rule's folds and of PCR: each array of a
#: block stays a few hundred kB at most, long enough to spread numpy's per-call overhead, short
#: enough that the fold's temporaries are recycled by the allocator rather than mapped afresh.
ROW_BLOCK_ENTRIES = 22_000


class NoClosedForm(Exception):
    """A measure that the closed forms of this fusion do not give (the general path answers)."""


#: The smallest subnormal float, which a zero denominator is raised to (:func:`share_of`).
TINY = np.finfo(np.float64).smallest_subnormal


def share_of(numerator: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """numerator / denominator for 0 ≤ numerator ≤ denominator, and 0 where both are 0.

    Only a zero denominator is raised (to the smallest subnormal), so every positive one
    divides exactly as on the general path.
    """
    return numerator / np.maximum(denominator, TINY)


def product_of(arrays: Sequence[np.ndarray]) -> np.ndarray:
    """The elementwise product of the arrays, left to right (a copy of a lone array)."""
    out = arrays[0]
    for a in arrays[1:]:
        out = out * a
    return out if len(arrays) > 1 else out.copy()


class Fusion:
    """Measures of a fused batch by element class.

    ``o_measure(kind)`` gives, for kind ``"bel"``, ``"pls"``, ``"mass"`` or ``"betp"`` (the
    pignistic numerator, before the division by the non-empty mass), the values for every
    free hypothesis, shape (N, |O|) (or (N,) when they are the same for all);
    ``o_measure(kind, positions)`` the value for one free hypothesis per row, shape (N,).
    ``e_measure(kind)`` gives shape (N, |E|).
    """

    rows: int
    split: ExclusiveSplit
    sources: "Blocks"
    general: Callable[[np.ndarray], MassBatch] | None = None
    _picks: tuple[bytes, list[np.ndarray]] | None = None
    #: BetP's divisor, once checked for total conflict (False: no row has m(∅) > 0).
    _betp_scale: np.ndarray | bool | None = None

    def empty(self) -> np.ndarray:
        raise NotImplementedError

    def kept(self) -> np.ndarray:
        """Σ of the non-empty masses per row, shape (N,) (the BetP normalisation)."""
        raise NotImplementedError

    def o_measure(self, kind: str, positions: np.ndarray | None = None) -> np.ndarray:
        raise NotImplementedError

    def e_measure(self, kind: str) -> np.ndarray:
        raise NotImplementedError

    def picked(self, positions: np.ndarray) -> list[np.ndarray]:
        """Each source's mass of θ_j, j the free hypothesis ``positions[n]``, in row n; shape (N,) each.

        Bel, BetP and the mass of one reading select the same hypotheses, so the gathers of
        the last ``positions`` are kept.
        """
        key = positions.tobytes()
        if self._picks is None or self._picks[0] != key:
            sources, free = self.sources, self.split.o_index
            self._picks = (key, [sources.gather_source(k, lookup[free].take(positions))
                                 for k, lookup in enumerate(sources.lookup)])
        return self._picks[1]


def block_sources(values: Sequence[np.ndarray], split: ExclusiveSplit):
    """Each source's free rows (|O|, B), exclusive rows (|E|, B) and free total O_i (B,), of one block."""
    free = [v[split.o_index] for v in values]
    excl = [v[split.e_index] for v in values]
    return free, excl, [f.sum(axis=0) for f in free]


@lru_cache(maxsize=4)
def row_offsets(rows: int, stride: int) -> np.ndarray:
    """n · stride for n < rows: where each row starts in a flattened (rows, stride) array (read-only, shared)."""
    out = np.arange(0, rows * stride, stride, dtype=np.int64)
    out.flags.writeable = False
    return out


class Blocks:
    """The sources read in blocks of rows, each block turned to (hypotheses, rows) in frame order.

    A fusion computes its per-row results block by block: every temporary then stays in
    cache (a temporary of the whole batch would be allocated, and the pages of its memory
    touched, at every call), while a block is long enough that numpy's per-call overhead
    is spread over thousands of rows.

    Parameters
    ----------
    values : sequence of ndarray, each shape (N, K_i)
        The sources' masses (a broadcast one-row source has stride 0 along the rows).
    width : int
        n, the hypotheses of the frame.
    pairs : int
        A pairwise pass over this many hypotheses runs per block: its (pairs, pairs) matrix
        per row must fit too.
    maps : sequence of (None or (ndarray, ndarray)), optional
        For a source whose columns are not θ_1 … θ_n in frame order: the frame position of
        each of its singleton columns, and those columns.
    step : int, optional
        Rows per block, for a fusion that reads the sources column by column
        (:meth:`total`, :meth:`part`) and never holds a whole block.
    """

    def __init__(self, values: Sequence[np.ndarray], width: int, pairs: int = 0, maps=None,
                 step: int | None = None) -> None:
        self.values = [np.asarray(v) for v in values]
        self.width = width
        self.rows = max(v.shape[0] for v in self.values)
        if step is None:
            step = max(64, min(ROW_BLOCK_ENTRIES // max(1, width), PAIR_BLOCK_ENTRIES // max(1, pairs * pairs)))
        self.step = step
        # For each source: the column of each frame position, −1 where it has none (mass 0).
        self.lookup = []
        for v, mapping in zip(self.values, maps if maps is not None else [None] * len(self.values)):
            lookup = np.arange(width, dtype=np.int64)
            if mapping is not None:
                lookup[:] = -1
                lookup[mapping[0]] = mapping[1]
            self.lookup.append(lookup)
        self.complete = [bool((lookup >= 0).all()) for lookup in self.lookup]
        in_order = np.arange(width)
        self.in_order = [np.array_equal(lookup, in_order) for lookup in self.lookup]

    def __iter__(self):
        for start in range(0, self.rows, self.step):
            yield slice(start, min(self.rows, start + self.step))

    def _columns(self, k: int) -> np.ndarray:
        """Source k as (K_k, N); rows of it are contiguous when the source is stored column-major."""
        v = self.values[k]
        if not (v.flags.c_contiguous or v.flags.f_contiguous):
            v = self.values[k] = np.ascontiguousarray(v)
        return v.T

    def block(self, rows: slice) -> list[np.ndarray]:
        """Each source's rows ``rows`` as (n, B), θ_1 … θ_n in frame order (views where the memory allows)."""
        out = []
        size = rows.stop - rows.start
        for k, v in enumerate(self.values):
            lookup = self.lookup[k]
            columns = self._columns(k)
            if v.shape[0] != self.rows:                          # one row, broadcast
                row = np.where(lookup >= 0, columns[:, 0].take(np.maximum(lookup, 0)), 0.0)
                out.append(np.repeat(row[:, None], size, axis=1))
            elif not self.complete[k]:
                block = np.zeros((self.width, size))
                present = lookup >= 0
                block[present] = columns[:, rows].take(lookup[present], axis=0)
                out.append(block)
            elif v.flags.f_contiguous and self.in_order[k]:
                out.append(columns[:, rows])                     # already (n, B), rows contiguous
            else:
                out.append(columns[lookup, rows])
        return out

    def column(self, k: int, j: int, rows: slice) -> np.ndarray | None:
        """Source k's masses of θ_j (frame position j) in ``rows``, a view: shape (B,), or (1,) if broadcast."""
        c = int(self.lookup[k][j])
        if c < 0:
            return None
        columns = self._columns(k)
        return columns[c, :1] if self.values[k].shape[0] != self.rows else columns[c, rows]

    def total(self, k: int, positions: Sequence[int], rows: slice, out: np.ndarray) -> np.ndarray:
        """Σ_j of source k's masses of θ_j, j in ``positions`` (frame order), in ``rows``, written to ``out``.

        Read where the masses lie: one reduction when the columns are adjacent, else one
        addition per column, so that no block of the source is copied.
        """
        columns = self._columns(k)
        cols = [int(self.lookup[k][j]) for j in positions]
        cols = [c for c in cols if c >= 0]
        part = columns[:, :1] if self.values[k].shape[0] != self.rows else columns[:, rows]
        if not cols:
            out[...] = 0.0
        elif len(cols) > 2 and cols == list(range(cols[0], cols[0] + len(cols))):
            adjacent = part[cols[0]:cols[-1] + 1]
            if adjacent.shape[1] == out.shape[0]:
                np.add.reduce(adjacent, axis=0, out=out)
            else:
                out[...] = np.add.reduce(adjacent, axis=0)
        elif len(cols) == 1:
            np.copyto(out, part[cols[0]])
        else:
            np.add(part[cols[0]], part[cols[1]], out=out)
            for c in cols[2:]:
                out += part[c]
        return out

    def part(self, k: int, positions: Sequence[int], rows: slice) -> np.ndarray:
        """Source k's masses of θ_j, j in ``positions``, in ``rows``: a (len(positions), B) copy."""
        out = np.zeros((len(positions), rows.stop - rows.start))
        for i, j in enumerate(positions):
            column = self.column(k, j, rows)
            if column is not None:
                out[i] = column
        return out

    def gather_source(self, k: int, columns: np.ndarray) -> np.ndarray:
        """The mass in column ``columns[n]`` of source k (−1: none, mass 0) in row n, shape (N,)."""
        v = self._columns(k).T
        absent = None if self.complete[k] else columns < 0
        if absent is not None:
            columns = np.where(absent, 0, columns)
        if v.shape[0] != self.rows:                              # a one-row source, broadcast
            out = v[0].take(columns)
        elif v.flags.c_contiguous:
            out = v.reshape(-1).take(np.add(columns, row_offsets(self.rows, v.shape[1])))
        else:
            # Column-major: the masses of a hypothesis lie together.
            flat = np.multiply(columns, self.rows)
            flat += row_offsets(self.rows, 1)
            out = v.T.reshape(-1).take(flat)
        if absent is not None:
            out[absent] = 0.0
        return out


def first_pick(free: Sequence[np.ndarray], totals: Sequence[np.ndarray]) -> np.ndarray:
    """Σ m(θ_S) over the all-free tuples whose S holds j (SPEC Part D, Bel(θ_J)), for each row j of ``free``.

    Summed over the first source k that picks θ_j: Π_{i<k} (O_i − m_i(θ_j)) · m_k(θ_j) ·
    Π_{i>k} O_i, a sum of non-negative products.  The difference O_i − m_i(θ_j) is the
    mass of the other free hypotheses, never more than O_i, so its rounding stays below
    that of P_O = Π_i O_i.  Works on (|O|, N) arrays and on one (N,) value per row alike.
    """
    bel = np.array(free[0], dtype=np.float64, copy=True)
    if len(free) == 1:
        return bel
    without = np.subtract(totals[0], free[0])              # the tuples so far that avoid θ_j
    np.maximum(without, 0.0, out=without)
    term = np.empty_like(without)
    last = len(free) - 1
    for k in range(1, len(free)):
        m, total = free[k], totals[k]
        bel *= total
        bel += np.multiply(without, m, out=term)
        if k < last:
            np.subtract(total, m, out=term)
            np.maximum(term, 0.0, out=term)
            without *= term
    return bel


def pick_per_row(values: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """values[positions[n], n] for every row n of a (K, N) array."""
    n = positions.size
    if values.flags.c_contiguous and values.shape[1] == n:
        flat = np.multiply(positions, n)
        flat += row_offsets(n, 1)
        return values.reshape(-1).take(flat)
    return values[positions, np.arange(n)]


def sums_of_the_others(values: np.ndarray) -> np.ndarray:
    """Σ_{j ≠ i} values[j] for every i along the first axis: the values before i plus those after it.

    Two cumulative sums of non-negative masses, never Σ_E − m(θ_e): next to an values
    hypothesis of mass 1 the difference would be 1 − 1 = 0 and lose the others' 1e-160
    (their conflict with a source on θ_e), which Yager's rule then leaves off Θ.
    """
    out = np.zeros_like(values)
    if values.shape[0] > 1:
        np.cumsum(values[:-1], axis=0, out=out[1:])
        out[:-1] += np.cumsum(values[:0:-1], axis=0)[::-1]
    return out
