"""The kernel family of sources whose focal elements are single hypotheses, under Shafer's model.

A Bayesian source over n exclusive hypotheses is a probability vector: fusing two of them
is n products and a few sums, and every focal element of the result is again a single
hypothesis (plus ∅ for the conjunctive rules and Θ for Yager's).  The general plan would
intersect all n² pairs of focal elements to find that out, so :func:`~belief.rules.combine`
sends such sources here when there are many of them (:data:`SINGLETON_KERNEL_TUPLES`), and
the work follows the focal elements: O(n) for the rules of the ∩ kind, O(n²) arithmetic
and no n² structure for PCR5/PCR6, whose every conflicting pair has a share of its own.

With two sources a and b over the hypotheses in use (and a∅, b∅ their masses on ∅):

* conjunctive, DSmC (W (2)): m(θ_i) = a_i b_i and m(∅) = a∅ T_b + Σ_i a_i (b∅ + Σ_{j≠i} b_j),
  with T_b = b∅ + Σ_j b_j: sums of non-negative products only, so that near total
  conflict (m(∅) = 1 − 10⁻¹⁶) the small non-empty masses are not lost in a difference;
  Σ_{j≠i} b_j is the sum of the masses before i plus those after it (two cumulative sums);
* Dempster (SPEC A.3): the products a_i b_i rescaled by their sum;
* Yager: the conjunctive products, with the mass of ∅ moved to Θ;
* PCR5 = PCR6 for two sources (SPEC A.3): m(θ_i) = a_i b_i
  + Σ_{j≠i} [a_i² b_j / (a_i + b_j) + b_i² a_j / (b_i + a_j)].

More sources are folded pairwise for the associative rules (conjunctive, DSmC, Dempster;
Yager's rule folds the conjunctive part, then moves ∅ to Θ once).  PCR5 and PCR6 of more
sources are left to the other kernels.

Accuracy against the literal definition (every tuple visited, exact sums): the singleton
products are the plan's own products, bit for bit, and Dempster's scale is the same numpy
sum over the same non-zero products in canonical order; the other sums are in another
order, within a relative error of n·2⁻⁵³ of each mass (sums of non-negative terms).
"""

from __future__ import annotations

from collections.abc import Sequence
from operator import is_

import numpy as np

from belief.bayesian_blocks import sums_of_the_others
from belief.incidence import own_bits
from belief.mass import MassFunction, mass_from_masks
from belief.model import Model
from belief.rules_classic import WIDE_SCALE, conjunctive, dempster, dsmc, yager
from belief.rules_pcr import pcr5, pcr6

__all__ = ["SINGLETON_KERNEL_TUPLES", "SINGLETON_RULES", "singleton_sources", "combine_singletons"]

#: Sources with at least this many tuples of focal elements (n_1 · n_2 for two) come here; fewer are left to the
#: direct path, whose Python loops over a handful of floats cost less than this kernel's numpy calls.
SINGLETON_KERNEL_TUPLES = 4096
#: The built-in rules this family evaluates, by function (a rule registered anew under a name keeps its own), and
#: how: ∩ kind folded, or PCR of two sources.
SINGLETON_RULES = {conjunctive: "meet", dsmc: "meet", dempster: "dempster", yager: "yager", pcr5: "pcr", pcr6: "pcr"}
#: Entries of the pair table of PCR at a time: a block of (rows × n) shares (1 MB) stays in the processor's cache,
#: and below the size (460 800 entries) at which OpenBLAS splits a matrix-vector product over threads, which a
#: busy second core makes twenty times slower.  The sums a_i + b_j of a block are one product of a (rows × 2) and
#: a (2 × n) matrix, of rows · n · 2 ≤ 2¹⁸ multiply-adds: at most OpenBLAS's single-thread size for a matrix
#: product (65 536 × 4).
PCR_BLOCK_ENTRIES = 1 << 17


class SingletonSource:
    """One source read as a probability vector: hypothesis positions, their masses and the mass of ∅."""

    __slots__ = ("positions", "masses", "empty")

    def __init__(self, positions: np.ndarray, masses: np.ndarray, empty: float) -> None:
        self.positions = positions
        self.masses = masses
        self.empty = empty


def singleton_sources(sources: Sequence, model: Model | None) -> list[SingletonSource] | None:
    """The sources as probability vectors, or None where this family does not apply.

    It applies to two or more :class:`~belief.mass.MassFunction` under one Shafer model
    (the fusion model, if given, the same), every focal element a single hypothesis or ∅,
    with at least :data:`SINGLETON_KERNEL_TUPLES` tuples of focal elements.
    """
    if len(sources) < 2 or type(sources[0]) is not MassFunction:
        return None
    source_model = sources[0].model
    if source_model.kind != "shafer" or (model is not None and model != source_model):
        return None
    count = 1
    for m in sources:
        if type(m) is not MassFunction or (m.model is not source_model and m.model != source_model):
            return None
        count *= len(m)
    if count < SINGLETON_KERNEL_TUPLES:
        return None
    read = []
    for m in sources:
        source = _read(m)
        if source is None:
            return None
        read.append(source)
    return read


def _read(m: MassFunction) -> SingletonSource | None:
    """A mass function's singletons (positions in frame order) and its mass on ∅, or None for any other element."""
    held = m._unions_as_held()
    if held is not None:
        # Bit masks, maybe not in canonical order: the kernels scatter by position, so no order is needed.
        masks, floats = held
        lengths = list(map(int.bit_length, masks))
        # A hypothesis read from its name is the frame's own bit object: known single without reading its bits.
        own = list(map(is_, map(own_bits(m.frame).__getitem__, lengths), masks))
        if not all(own) and any(mask & (mask - 1) for mask, known in zip(masks, own) if not known):
            return None
        # A single hypothesis is at the position its bit length gives; ∅ is the mask 0 (at most one).
        positions = np.array(lengths, dtype=np.intp)
        masses = np.array(floats, dtype=np.float64)
        positions -= 1
        empty = 0.0
        if len(positions) and positions.min() < 0:
            keep = positions >= 0
            empty = float(masses[~keep][0])
            positions, masses = positions[keep], masses[keep]
        return SingletonSource(positions, masses, empty)
    positions = []
    masses = []
    empty = 0.0
    for element, mass in m.items():
        terms = element.terms
        if not terms:
            empty = mass
            continue
        if len(terms) != 1:
            return None
        term = terms[0]
        if term & (term - 1):
            return None
        positions.append(term.bit_length() - 1)
        masses.append(mass)
    return SingletonSource(np.array(positions, dtype=np.intp), np.array(masses, dtype=np.float64), float(empty))


def _dense(sources: Sequence[SingletonSource], n: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """The hypotheses any source uses (sorted positions) and each source's masses over them."""
    # An occupancy table of the frame rather than np.unique, whose first call imports numpy.ma (~15 ms).
    column = np.zeros(n, dtype=np.intp)
    for s in sources:
        column[s.positions] = 1
    used = np.flatnonzero(column)
    column[used] = np.arange(len(used))
    out = []
    for s in sources:
        dense = np.zeros(len(used))
        dense[column[s.positions]] = s.masses
        out.append(dense)
    return used, out


def _meet(a: np.ndarray, a_empty: float, b: np.ndarray, b_empty: float) -> tuple[np.ndarray, float]:
    """Conjunctive step (W (2)): the products on each hypothesis and the mass on ∅."""
    total_b = b_empty + float(b.sum())
    conflict = a_empty * total_b + float(np.dot(a, sums_of_the_others(b) + b_empty))
    return a * b, conflict


def _pcr_pair(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """PCR5/PCR6 of two Bayesian sources (SPEC A.3): consensus plus the proportional shares of every conflicting pair.

    The pair (i, j), i ≠ j, gives a_i² b_j / (a_i + b_j) to θ_i and a_i b_j² / (a_i + b_j) to θ_j;
    pairs with a zero mass give nothing.  θ_i's shares are a_i (a_i Σ_j b_j / (a_i + b_j)): the
    quotients lie in [0, 1], so subnormal masses neither overflow (as 1 / (a_i + b_j) would) nor
    lose their share.  The (i, j) table is built a block of rows at a time.
    """
    out = a * b
    live_a = np.flatnonzero(a > 0)
    live_b = np.flatnonzero(b > 0)
    if not len(live_a) or not len(live_b):
        return out
    x = a[live_a]
    y = b[live_b]
    column_b = np.full(len(b), -1, dtype=np.intp)
    column_b[live_b] = np.arange(len(live_b))
    # 1 / (a_i + b_j) stays below the largest float when every sum is above 2^-1020: one reciprocal and two
    # products per pair then.  Smaller (subnormal) masses take two quotients per pair, which cannot overflow.
    reciprocal = float(x.min()) + float(y.min()) > 2.0 ** -1020
    to_a = np.empty(len(x))
    to_b = _pcr_rows(x, y, live_a, column_b, reciprocal, to_a)
    out[live_a] += x * (x * to_a)
    out[live_b] += y * (y * to_b)
    return out


def _pcr_rows(x: np.ndarray, y: np.ndarray, live_a: np.ndarray, column_b: np.ndarray, reciprocal: bool,
              to_a: np.ndarray) -> np.ndarray:
    """The pair table of :func:`_pcr_pair`: writes Σ_j b_j / (a_i + b_j) to ``to_a`` and returns Σ_i a_i / (a_i + b_j).

    Shapes: ``x``, ``to_a`` (len(x),); ``y`` and the result (len(y),).  The table is made a
    block of :data:`PCR_BLOCK_ENTRIES` at a time, which stays in the processor's cache.
    """
    to_b = np.zeros(len(y))
    step = max(1, PCR_BLOCK_ENTRIES // len(y))
    table = np.empty((min(step, len(x)), len(y)))           # one buffer for every block: no page faults
    # a_i + b_j as the product [a_i, 1] · [1, b_j]ᵀ: each entry is x_i·1 + 1·y_j, exact products and one
    # rounded sum, so the bits of a_i + b_j, in a third of the time numpy's broadcast addition takes.
    left = np.ones((len(table), 2))
    right = np.ones((2, len(y)))
    right[1] = y
    for start in range(0, len(x), step):
        rows = slice(start, start + step)
        total = table[:len(x[rows])]
        pairs = left[:len(total)]
        pairs[:, 0] = x[rows]
        np.matmul(pairs, right, out=total)                  # a_i + b_j
        if reciprocal:
            np.divide(1.0, total, out=total)                # as np.reciprocal, which numpy does not vectorise
            part_b = part_a = total
        else:
            part_b = np.divide(y, total)                    # b_j / (a_i + b_j)
            part_a = np.divide(x[rows, None], total, out=total)   # a_i / (a_i + b_j)
        # The pair (i, i) is no conflict: its shares are taken out where a row meets its own column.
        same = np.flatnonzero(column_b[live_a[rows]] >= 0)
        if len(same):
            own = column_b[live_a[rows][same]]
            part_b[same, own] = 0.0
            part_a[same, own] = 0.0
        if reciprocal:
            to_a[rows] = total @ y
            to_b += x[rows] @ total
        else:
            to_a[rows] = part_b.sum(axis=1)
            to_b += part_a.sum(axis=0)
    return to_b


def combine_singletons(kind: str, sources: Sequence[SingletonSource], model: Model) -> MassFunction | None:
    """Combine singleton sources with a rule of :data:`SINGLETON_RULES`; None where another kernel must decide.

    Returns None for PCR of more than two sources or with mass on ∅, for Yager's rule and PCR
    with mass on ∅ (the general path refuses them with its own message), and for Dempster's
    rule when the non-empty products sum below 2⁻⁴⁰ (underflow or total conflict: the
    general path combines again with wide exponents or raises).

    Examples
    --------
    Zadeh's example, with the rules of this family (sources as few as these are below
    :data:`SINGLETON_KERNEL_TUPLES`, so :func:`~belief.rules.combine` would send them elsewhere).

    >>> from belief import Frame, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> m1 = _read(MassFunction({"a": 0.9, "c": 0.1}, model=shafer))
    >>> m2 = _read(MassFunction({"b": 0.9, "c": 0.1}, model=shafer))
    >>> combine_singletons("dempster", [m1, m2], shafer)
    MassFunction({'c': 1.0}, frame=['a', 'b', 'c'])
    >>> {e: round(v, 12) for e, v in combine_singletons("pcr", [m1, m2], shafer).to_mapping().items()}
    {'a': 0.486, 'b': 0.486, 'c': 0.028}
    >>> combine_singletons("meet", [m1, m2], shafer).to_mapping()
    {'empty': 0.99, 'c': 0.010000000000000002}
    """
    used, dense = _dense(sources, len(model.frame))
    if kind == "pcr":
        if len(sources) != 2 or any(s.empty for s in sources):
            return None
        values = _pcr_pair(dense[0], dense[1])
        return _singleton_result(model, used, values, None)
    if kind == "yager" and any(s.empty for s in sources):
        return None
    products = dense[0]
    conflict = sources[0].empty
    for s, b in zip(sources[1:], dense[1:]):
        products, conflict = _meet(products, conflict, b, s.empty)
    if kind == "dempster":
        kept = products[products > 0]
        scale = kept.sum()
        if not scale > WIDE_SCALE:          # underflow or total conflict: the general path decides
            return None
        return _singleton_result(model, used, products / scale, None)
    if kind == "yager":
        return _singleton_result(model, used, products, None, on_total=conflict)
    return _singleton_result(model, used, products, conflict)


def _singleton_result(model: Model, used: np.ndarray, values: np.ndarray, empty: float | None,
                      on_total: float = 0.0) -> MassFunction:
    """The mass function of the non-zero singleton masses, ∅ first and Θ last where they hold mass."""
    live = values > 0
    positions = used[live].tolist()
    bits = model.frame.bits
    masks = [bits[p] for p in positions]            # the frame's own bits: read by identity (Frame.singleton_of_bit)
    masses = values[live]
    n = len(model.frame)
    if on_total > 0.0:
        everything = (1 << n) - 1
        if len(masks) == 1 and masks[0] == everything:    # a frame of one hypothesis: Θ is that hypothesis
            masses = masses + on_total
        else:
            masks.append(everything)
            masses = np.append(masses, on_total)
    if empty:
        masks.insert(0, 0)
        masses = np.insert(masses, 0, empty)
    return mass_from_masks(model, tuple(masks), np.ascontiguousarray(masses, dtype=np.float64))
