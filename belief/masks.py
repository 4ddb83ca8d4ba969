"""Integer codes of focal elements on frames of any width: 64-bit words, their ∩ and ∪ over tuples, their order.

A union of exclusive hypotheses is the bit mask of its hypotheses (and a Venn-region code the
mask of its regions, :func:`belief.plan.encode`), so ∩ and ∪ of focal elements are ``&`` and
``|`` of their codes.  Codes of up to 64 bits are one ``uint64`` each; wider ones are rows of
64-bit words, least significant first (:func:`to_words`), and the tuples of focal elements of
s sources are combined a block of tuples at a time (:func:`tuple_groups`), so that no array
of tuples × words is ever made.  The tuples are grouped by their result with a 64-bit hash of
the words, checked against the words themselves: a collision is told, never merged.

:func:`canonical_order` and :func:`union_key` give the canonical order of unions of
hypotheses (:attr:`belief.frame.Element.sort_key`: fewer hypotheses first, then the set whose
smallest differing hypothesis is its own), and :func:`union_terms` their conjunctions, from
which elements are made.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache
from itertools import islice

import numpy as np

__all__ = ["WORD_BITS", "word_count", "to_words", "from_words", "canonical_order", "union_key", "union_terms",
           "single_terms", "tuple_codes", "tuple_groups", "TUPLE_BLOCK_WORDS"]

WORD_BITS = 64
#: Tuples are combined in blocks of about this many words (8 bytes each).
TUPLE_BLOCK_WORDS = 1 << 20
#: Below this many masks, :func:`union_terms` loops in Python; above, numpy lists the bits of all at once.
_VECTOR_TERMS = 256
#: What listing one set bit in Python costs, in units of numpy's cost of reading one bit of a mask.
_PYTHON_BIT_COST = 64
_LITTLE_WORDS = np.dtype("<u8")
# Odd multipliers of the hash of a row of words (splitmix64's constants).
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def word_count(width: int) -> int:
    """The 64-bit words a code of ``width`` bits takes (at least one)."""
    return max(1, -(-width // WORD_BITS))


def to_words(masks: Sequence[int], words: int) -> np.ndarray:
    """Non-negative integer codes as a (K, words) array of uint64, least significant word first.

    >>> to_words([1, 1 << 64 | 2], 2).tolist()
    [[1, 0], [2, 1]]
    """
    if words == 1:
        return np.array(masks, dtype=np.uint64).reshape(-1, 1)
    size = 8 * words
    data = b"".join([m.to_bytes(size, "little") for m in masks])
    return np.frombuffer(data, dtype=_LITTLE_WORDS).astype(np.uint64).reshape(-1, words)


def from_words(words: np.ndarray) -> list[int]:
    """The inverse of :func:`to_words`: one Python int per row.

    >>> from_words(to_words([5, 1 << 70], 2))
    [5, 1180591620717411303424]
    """
    if words.shape[1] == 1:
        return words[:, 0].tolist()
    size = 8 * words.shape[1]
    data = np.ascontiguousarray(words, dtype=_LITTLE_WORDS).tobytes()
    return [int.from_bytes(data[i:i + size], "little") for i in range(0, len(data), size)]


@lru_cache(maxsize=1)
def _reversed_bytes() -> np.ndarray:
    values = np.arange(256, dtype=np.uint8)
    out = np.zeros(256, dtype=np.uint8)
    for i in range(8):
        out |= ((values >> i) & 1) << (7 - i)
    return out


def _reversed_words(words: np.ndarray) -> np.ndarray:
    """Each uint64 word with its 64 bits in reverse order."""
    data = np.ascontiguousarray(words, dtype=_LITTLE_WORDS)
    flipped = _reversed_bytes()[data.view(np.uint8).reshape(data.shape + (8,))][..., ::-1]
    return np.ascontiguousarray(flipped).view(_LITTLE_WORDS).reshape(data.shape).astype(np.uint64)


def canonical_order(words: np.ndarray) -> np.ndarray:
    """The positions that sort distinct rows of words (unions of hypotheses) in canonical order.

    Fewer hypotheses first; among as many, the set whose smallest differing hypothesis is
    its own, which is the larger mask read with its bits reversed.

    >>> canonical_order(to_words([3, 4, 1, 2], 1)).tolist()      # a|b, c, a, b -> a, b, c, a|b
    [2, 3, 1, 0]
    """
    count = np.bitwise_count(words).sum(axis=1, dtype=np.int64)
    reverse = ~_reversed_words(words)
    if words.shape[1] == 1:
        # Distinct rows have distinct reversed words, so any sort of them is the order; then a stable sort
        # by the counts (small integers, sorted by radix) puts it within each count.
        by_bits = reverse[:, 0].argsort()
        return by_bits[count.astype(np.uint8 if words.shape[1] * WORD_BITS < 256 else np.uint16)[by_bits]
                       .argsort(kind="stable")]
    # np.lexsort: the last key is the primary one; word 0 holds the first hypotheses.
    keys = [reverse[:, w] for w in range(words.shape[1] - 1, -1, -1)] + [count]
    return np.lexsort(keys)


def union_key(width: int, rank: Sequence[int] | None = None) -> Callable[[int], object]:
    """A sort key of hypothesis masks in canonical order (``rank`` a table of it, as :func:`~belief.plan.union_ranks`).

    >>> sorted([3, 4, 1, 2], key=union_key(70))
    [1, 2, 4, 3]
    """
    if rank is not None:
        return rank.__getitem__
    pattern = f"0{width}b"

    def key(mask: int) -> tuple[int, int]:
        return mask.bit_count(), -int(format(mask, pattern)[::-1], 2)

    return key


def single_terms(mask: int) -> tuple[int, ...]:
    """The single-hypothesis conjunctions of a hypothesis mask, in frame order.

    >>> single_terms(0b1011)
    (1, 2, 8)
    """
    terms = []
    while mask:
        low = mask & -mask
        terms.append(low)
        mask ^= low
    return tuple(terms)


@lru_cache(maxsize=8)
def _powers(bits: int) -> np.ndarray:
    """The single-hypothesis masks 1 << i, i < bits, as Python ints in an object array (shared, not rebuilt)."""
    return np.array([1 << i for i in range(bits)], dtype=object)


def union_terms(masks: Sequence[int], width: int) -> list[tuple[int, ...]]:
    """The single-hypothesis conjunctions of each hypothesis mask, in frame order.

    Many masks have their bits listed by numpy in blocks (the Python loop over the bits
    costs a few hundred nanoseconds a hypothesis).

    >>> union_terms([0b1011, 0], 4)
    [(1, 2, 8), ()]
    """
    if len(masks) < _VECTOR_TERMS:
        return [single_terms(m) for m in masks]
    words = word_count(width)
    # numpy reads every bit of every mask, Python only the set ones: few set bits (singletons) go by Python.
    if _PYTHON_BIT_COST * sum([m.bit_count() for m in masks]) < len(masks) * words * WORD_BITS:
        return [single_terms(m) for m in masks]
    powers = _powers(words * WORD_BITS)
    out: list[tuple[int, ...]] = []
    step = max(1, (1 << 22) // (words * WORD_BITS))
    for start in range(0, len(masks), step):
        block = to_words(masks[start:start + step], words).astype(_LITTLE_WORDS, copy=False)
        bits = np.unpackbits(block.view(np.uint8).reshape(len(block), -1), axis=1, bitorder="little")
        rows, columns = np.nonzero(bits)
        flat = iter(powers[columns].tolist())
        out.extend([tuple(islice(flat, c)) for c in np.bincount(rows, minlength=len(block)).tolist()])
    return out


def _mix(h: np.ndarray) -> np.ndarray:
    h ^= h >> np.uint64(30)
    h *= _MIX1
    h ^= h >> np.uint64(27)
    h *= _MIX2
    h ^= h >> np.uint64(31)
    return h


def _row_hashes(words: np.ndarray) -> np.ndarray:
    """A 64-bit hash of every row of words; 0 for rows of zeros only, never 0 for the others."""
    h = np.zeros(len(words), dtype=np.uint64)
    with np.errstate(over="ignore"):
        for w in range(words.shape[1]):
            h += _GOLDEN * np.uint64(w + 1)
            h ^= words[:, w]
            h = _mix(h)
    h |= np.uint64(1)
    h[~words.any(axis=1)] = 0
    return h


def _codes_at(arrays: Sequence[np.ndarray], ufunc, sizes: Sequence[int], tuples: np.ndarray) -> np.ndarray:
    """``ufunc`` folded over the codes of the tuples of these row-major indices, shape (len(tuples), W)."""
    columns = np.unravel_index(tuples, sizes)
    out = arrays[0][columns[0]]
    for a, c in zip(arrays[1:], columns[1:]):
        ufunc(out, a[c], out=out)
    return out


def tuple_codes(codes: Sequence[np.ndarray], ufunc) -> np.ndarray:
    """``ufunc`` folded over one code per source for every tuple, in row-major tuple order, shape (T,)."""
    s = len(codes)
    out = codes[0].reshape((-1,) + (1,) * (s - 1))
    for i, a in enumerate(codes[1:], start=1):
        out = ufunc(out, a.reshape((1,) * i + (-1,) + (1,) * (s - 1 - i)))
    return out.reshape(-1)


def tuple_groups(arrays: Sequence[np.ndarray], ufunc) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distinct results of ``ufunc`` (``np.bitwise_and`` or ``np.bitwise_or``) over every tuple of codes.

    Parameters
    ----------
    arrays : sequence of ndarray of uint64, shape (K_i, W)
        Each source's codes as rows of words (:func:`to_words`).

    Returns
    -------
    unique : ndarray of uint64, shape (R, W)
        The distinct results, in no particular order.
    first : ndarray of int, shape (R,)
        A tuple (row-major index) that has each result.
    inverse : ndarray of int, shape (T,)
        The result of every tuple, as a row of ``unique``.
    """
    sizes = [len(a) for a in arrays]
    count = 1
    for k in sizes:
        count *= k
    width = arrays[0].shape[1]
    if width == 1:
        codes = tuple_codes([a[:, 0] for a in arrays], ufunc)
        unique, first, inverse = np.unique(codes, return_index=True, return_inverse=True)
        return unique.reshape(-1, 1), first, inverse.reshape(-1)
    step = max(1, TUPLE_BLOCK_WORDS // width)
    hashes = np.empty(count, dtype=np.uint64)
    for start in range(0, count, step):
        stop = min(count, start + step)
        hashes[start:stop] = _row_hashes(_codes_at(arrays, ufunc, sizes, np.arange(start, stop)))
    _, first, inverse = np.unique(hashes, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    unique = _codes_at(arrays, ufunc, sizes, first)
    # Equal hashes of different results would be merged: every tuple is checked against its group's result.
    for start in range(0, count, step):
        stop = min(count, start + step)
        if not np.array_equal(_codes_at(arrays, ufunc, sizes, np.arange(start, stop)), unique[inverse[start:stop]]):
            return _exact_groups(arrays, ufunc, sizes, count)
    return unique, first, inverse


def _exact_groups(arrays, ufunc, sizes, count) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`tuple_groups` by sorting the rows themselves (after a hash collision, which is rare)."""
    codes = _codes_at(arrays, ufunc, sizes, np.arange(count))
    unique, first, inverse = np.unique(codes, axis=0, return_index=True, return_inverse=True)
    return unique, first, inverse.reshape(-1)
