"""Dense tables of how K focal elements relate to Q queries, computed from integer codes.

A measure of a batch (:class:`~belief.batch.MeasurePlan`) weighs its masses with a (K, Q)
table: 1 where the focal element lies in the query (belief, W (8)), meets it (plausibility,
W (9)), contains it (commonality) or equals it, and C_M(X ∩ A), the DSm cardinality of their
meet, for the pignistic probability.  With the codes of :func:`belief.plan.encode`, under
which ∩ is a bitwise AND and two elements are equal exactly when their codes are, every entry
is a few word operations, so a table of 10^6 entries takes milliseconds where comparing
elements one pair at a time takes seconds.  Codes are rows of 64-bit words
(:func:`belief.masks.to_words`), so a frame of any width goes the same way.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from belief.frame import Element
from belief.masks import to_words, word_count
from belief.model import Model
from belief.plan import encode

__all__ = ["CodedRelations", "coded_relations"]

#: Entries (focal element × query × word) of one block of the broadcast comparisons.
_BLOCK_ENTRIES = 1 << 21
#: Cardinalities are counted exactly while their sum stays below this bound (2^53: floats hold such integers).
_EXACT_INTEGERS = float(1 << 53)


class CodedRelations:
    """The relation tables of focal elements and queries, from their codes.

    Parameters
    ----------
    focal : ndarray of uint64, shape (K, W)
        The codes of the focal elements as rows of W words.
    queries : ndarray of uint64, shape (Q, W)
        The codes of the queries.
    weights : ndarray of float, shape (W * 64,), or None
        The DSm cardinality carried by each bit of a code (1 for a Venn region, C_M(θ) for
        a hypothesis of an exclusive code); None when a meet's cardinality cannot be counted
        from its bits exactly.

    Examples
    --------
    >>> from belief import Frame, Model
    >>> f = Frame(["a", "b", "c"])
    >>> tables = coded_relations(Model.shafer(f), [f["a"], f.element("a|b")], [f["a"], f.element("b|c")])
    >>> tables.table("subset").tolist(), tables.table("meets").tolist()
    ([[1.0, 0.0], [0.0, 0.0]], [[1.0, 0.0], [1.0, 1.0]])
    >>> tables.table("meet_cardinality").tolist()
    [[1.0, 0.0], [1.0, 1.0]]
    """

    def __init__(self, focal: np.ndarray, queries: np.ndarray, weights: np.ndarray | None) -> None:
        self.focal = focal
        self.queries = queries
        self.weights = weights

    def table(self, relation: str) -> np.ndarray:
        """The (K, Q) float table of ``relation``: ``subset``, ``meets``, ``superset``, ``equal`` or ``meet_cardinality``."""
        if relation == "meet_cardinality" and self.weights is None:
            raise ValueError("the cardinality of a meet is not countable from these codes")
        focal, queries = self.focal, self.queries
        k, words = focal.shape
        q = queries.shape[0]
        out = np.empty((k, q), dtype=np.float64)
        step = max(1, _BLOCK_ENTRIES // max(1, k * words))
        nonempty = focal.any(axis=1)[:, None]
        for start in range(0, q, step):
            block = queries[start:start + step][None, :, :]
            x = focal[:, None, :]
            if relation == "subset":
                value = ~(x & ~block).any(axis=2) & nonempty
            elif relation == "meets":
                value = (x & block).any(axis=2)
            elif relation == "superset":
                value = ~(block & ~x).any(axis=2)
            elif relation == "equal":
                value = (x == block).all(axis=2)
            elif relation == "meet_cardinality":
                value = _weighted_bits(x & block, self.weights)
            else:
                raise ValueError(f"no coded table for the relation {relation!r}")
            out[:, start:start + step] = value
        return out


def _weighted_bits(codes: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Σ over the set bits of each code of the bit's weight; ``codes`` has shape (..., W)."""
    if weights is _UNIT:
        return np.bitwise_count(codes).sum(axis=-1, dtype=np.int64)
    total = np.zeros(codes.shape[:-1], dtype=np.float64)
    for word in range(codes.shape[-1]):
        column = codes[..., word]
        for bit in range(64):
            weight = weights[word * 64 + bit]
            if weight:
                total += ((column >> np.uint64(bit)) & np.uint64(1)) * weight
    return total


#: The weights of codes whose bits each count one (Venn regions, or the hypotheses of Shafer's model).
_UNIT = np.ones(0)


def coded_relations(model: Model, focal: Sequence[Element], queries: Sequence[Element]) -> CodedRelations | None:
    """The :class:`CodedRelations` of elements already in their form under ``model``, or None.

    None where the model has too many Venn regions to code (:func:`belief.plan.encode`).
    """
    encoding = encode(model, [focal, queries])
    if encoding is None:
        return None
    words = word_count(encoding.width)
    focal_codes, query_codes = (to_words(codes, words) for codes in encoding.codes)
    weights: np.ndarray | None = _UNIT
    if encoding.kind == "exclusive" and model.kind != "shafer":
        # Exclusive hypotheses share no region, so a union's regions are the sum of its hypotheses' own.
        counts = [model.cardinality(h) for h in model.frame.hypotheses]
        if sum(counts) < _EXACT_INTEGERS:
            weights = np.zeros(words * 64)
            weights[:len(counts)] = counts
        else:
            weights = None
    return CodedRelations(focal_codes, query_codes, weights)
