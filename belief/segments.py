"""Sums of the tuples' products by target for many rows at once, bit for bit as ``np.add.reduceat``.

A rule of the ∩ or ∪ kind sends the product Π m_i(X_i) of every tuple of focal elements to
one target, and the plan sums the products of each target with ``np.add.reduceat`` over the
products sorted by target (:class:`~belief.plan.Scatter`).  numpy adds a run as its first
value plus the pairwise sum of the rest (eight partial sums, blocks of 128), and it calls
its inner loop once per row and target: for a batch of many rows and a few dozen tuples
those calls cost more than the arithmetic.

:class:`RunProgram` computes the same sums the other way round: the products are laid out
with one row per tuple (rows of the batch along the columns), the runs of equal length are
stacked so that the k-th product of every such run is one contiguous block, and numpy's
pairwise order is replayed on whole blocks.  Every addition adds the same two numbers as
numpy's does for every row, so the results are equal to the last bit; the choice between
the two (:func:`program_pays`) never shows in a result.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

import numpy as np

__all__ = ["RunProgram", "program_pays", "PROGRAM_MIN_ROWS"]

#: Batches of fewer rows are summed by ``np.add.reduceat``: its calls are few, and a program costs Python per run.
PROGRAM_MIN_ROWS = 256
#: Rows of a batch taken at a time: the products of a block stay in the processor's cache.
BLOCK_ENTRIES = 1 << 17
#: Estimated cost of one numpy call of the program over a block, and of one run of one row in ``reduceat``, in ns.
_CALL_NS = 1500
_REDUCEAT_RUN_NS = 9


def program_pays(rows: int, runs: int, operations: int, contributions: int) -> bool:
    """Whether a :class:`RunProgram` of ``operations`` block operations beats ``reduceat`` on ``rows`` rows."""
    if rows < PROGRAM_MIN_ROWS:
        return False
    blocks = -(-rows * contributions // BLOCK_ENTRIES)
    return blocks * operations * _CALL_NS < rows * runs * _REDUCEAT_RUN_NS


class RunProgram:
    """The sums of runs of products, replaying numpy's order of additions block by block.

    Parameters
    ----------
    columns : sequence of ndarray of int
        Each source's focal-element column for every contribution, in the order that sorts
        the contributions by target (:attr:`Scatter.order <belief.plan.Scatter>`), shape (E,).
    starts : ndarray of int
        Where each target's run begins among the sorted contributions, shape (R,).
    skip : sequence of int
        Runs whose sums nobody reads (the conflict of Dempster's rule): they are left at 0.

    Attributes
    ----------
    operations : int
        The number of numpy calls per block of rows (the program's cost beside the arithmetic).
    """

    __slots__ = ("columns", "groups", "operations", "runs", "count", "skipped")

    def __init__(self, columns: Sequence[np.ndarray], starts: np.ndarray, skip: Sequence[int] = ()) -> None:
        count = len(columns[0])
        starts_list = np.asarray(starts).tolist()
        ends = starts_list[1:] + [count]
        skipped = set(skip)
        by_length: dict[int, list[int]] = {}
        for run, (start, end) in enumerate(zip(starts_list, ends)):
            if run not in skipped:
                by_length.setdefault(end - start, []).append(run)
        layout: list[int] = []
        groups = []
        operations = len(columns) * 2 + 1
        for length, runs in sorted(by_length.items()):
            # Block k of the group holds the k-th product of each of its runs.
            base = len(layout)
            for k in range(length):
                layout.extend(starts_list[run] + k for run in runs)
            groups.append((length, np.array(runs, dtype=np.intp), base, len(runs)))
            operations += _operation_count(length - 1) + 2
        order = np.array(layout, dtype=np.intp)
        self.columns = tuple(np.asarray(c)[order] for c in columns)
        self.groups = tuple(groups)
        self.operations = operations
        self.runs = len(starts_list)
        self.count = len(layout)
        self.skipped = tuple(sorted(skipped))

    def evaluate(self, values: Sequence[np.ndarray]) -> np.ndarray:
        """The (N, R) sums for the sources' (N, K_i) masses (rows broadcast alike)."""
        n = values[0].shape[0]
        out = np.empty((n, self.runs))
        if self.skipped:
            out[:, list(self.skipped)] = 0.0
        live = [r for r in range(self.runs) if r not in self.skipped] if self.skipped else None
        for start, stop, block_sums in self._blocks(values):
            if live is None:
                out[start:stop] = block_sums.T
            else:
                out[start:stop, live] = block_sums[live].T
        return out

    def evaluate_normalised(self, values: Sequence[np.ndarray], smallest: float) -> np.ndarray | None:
        """Dempster's rows: the sums of every run but the first (∅, skipped), each row divided by its total.

        The total of a row is added as ``sums[:, 1:].sum(axis=1)`` adds it, and each sum divided
        by it, so that the rows are bit for bit those of the plan's sums normalised afterwards.
        None where a row's total is not above ``smallest`` (the caller normalises then).
        """
        n = values[0].shape[0]
        out = np.empty((n, self.runs - 1))
        for start, stop, block_sums in self._blocks(values):
            kept = block_sums[1:]
            total = _pairwise(kept, 0, 1, 0, len(kept))
            if not (total > smallest).all():
                return None
            kept /= total
            out[start:stop] = kept.T
        return out

    def _blocks(self, values: Sequence[np.ndarray]):
        """(start, stop, sums) for each block of rows; ``sums`` is (R, stop - start), a work array reused."""
        n = values[0].shape[0]
        step = max(1, BLOCK_ENTRIES // max(1, self.count))
        width = min(step, n)
        products, factor, sums = _scratch(self.count * width, self.runs * width)
        for start in range(0, n, step):
            stop = min(n, start + step)
            blocks = self._products([v[start:stop] for v in values], products, factor, stop - start)
            block_sums = sums[:self.runs * (stop - start)].reshape(self.runs, stop - start)
            for length, runs, base, size in self.groups:
                if length == 1:
                    block_sums[runs] = blocks[base:base + size]
                    continue
                total = _pairwise(blocks, base, size, 1, length - 1)
                total += blocks[base:base + size]          # the first product plus the rest, as numpy adds them
                block_sums[runs] = total
            yield start, stop, block_sums

    def _products(self, values: Sequence[np.ndarray], products: np.ndarray, factor: np.ndarray,
                  width: int) -> np.ndarray:
        """Π_i m_i(X_i) of every laid-out contribution, one row per contribution, multiplied left to right.

        ``products`` and ``factor`` are flat work arrays of at least count × width entries.
        """
        shape = (self.count, width)
        products = products[:self.count * width].reshape(shape)
        factor = factor[:self.count * width].reshape(shape)
        # mode="clip" (the columns are valid): with ``out``, the default mode copies through a buffer.
        np.take(np.ascontiguousarray(values[0].T), self.columns[0], axis=0, out=products, mode="clip")
        for v, c in zip(values[1:], self.columns[1:]):
            np.take(np.ascontiguousarray(v.T), c, axis=0, out=factor, mode="clip")
            products *= factor
        return products


_SCRATCH = threading.local()


def _scratch(entries: int, sums: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """This thread's work arrays of at least these sizes, kept from call to call.

    A fresh array of a megabyte is mapped anew by the allocator, and its first use costs a
    page fault per page, more than the arithmetic on it.  Arrays of more than twice
    :data:`BLOCK_ENTRIES` (one row of a huge plan) are not kept.
    """
    if entries > 2 * BLOCK_ENTRIES or sums > 2 * BLOCK_ENTRIES:
        return np.empty(entries), np.empty(entries), np.empty(sums)          # a block of a single huge row
    kept = getattr(_SCRATCH, "arrays", None)
    if kept is None or len(kept[0]) < entries or len(kept[2]) < sums:
        size = max(entries, len(kept[0]) if kept else 0)
        kept = (np.empty(size), np.empty(size), np.empty(max(sums, len(kept[2]) if kept else 0)))
        _SCRATCH.arrays = kept
    return kept


def _operation_count(n: int) -> int:
    """The numpy calls of :func:`_pairwise` over ``n`` values."""
    if n < 8:
        return n
    if n <= 128:
        return n + 8
    half = n // 2
    half -= half % 8
    return _operation_count(half) + _operation_count(n - half) + 1


def _pairwise(blocks: np.ndarray, base: int, size: int, first: int, n: int) -> np.ndarray:
    """numpy's pairwise sum of the products ``first .. first + n - 1`` of each run of a group, as a new array.

    Block k of the group is ``blocks[base + k * size : base + (k + 1) * size]``; the order of
    the additions is that of numpy's ``pairwise_sum`` (see :func:`belief.rules_tuples.pairwise_sum`).
    """
    def block(k: int) -> np.ndarray:
        row = base + k * size
        return blocks[row:row + size]

    if n < 8:
        total = block(first).copy()
        for k in range(first + 1, first + n):
            total += block(k)
        return total
    if n <= 128:
        partial = [block(first + j).copy() for j in range(8)]
        i = 8
        stop = n - n % 8
        while i < stop:
            for j in range(8):
                partial[j] += block(first + i + j)
            i += 8
        total = partial[0] + partial[1]
        total += partial[2] + partial[3]
        rest = partial[4] + partial[5]
        rest += partial[6] + partial[7]
        total += rest
        for k in range(i, n):
            total += block(first + k)
        return total
    half = n // 2
    half -= half % 8
    total = _pairwise(blocks, base, size, first, half)
    total += _pairwise(blocks, base, size, first + half, n - half)
    return total
