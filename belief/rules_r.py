"""The R-weighted rule of SPEC A.4, and :func:`inconsistency`, the R of W (10) that weighs its local conflicts.

The rule is folded in the given source order, as SPEC A.4 defines it; it is not associative.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from belief.batch import MassBatch
from belief.bayesian_split import bayesian_layout, dense_masses, exclusive_split
from belief.errors import InvalidMassError
from belief.frame import Element
from belief.model import Model
from belief.plan import FoldBudget, Scatter, TuplePlan, gather_product, row_chunks
from belief.r_inconsistency import aligned_inconsistency, bayesian_inconsistency
from belief.rules_classic import _ZERO_EXPONENT, _split
from belief.rules_common import prepare_sources
from belief.rules_registry import register_rule
from belief.rules_tuples import broadcast_values, checked_plan, prune, require_kept, require_normal


#: The values of the R-weighted rule's ``r_mode`` (how W (10) measures R) and ``empty_mode`` (SPEC A.4).
R_MODES = ("paper", "euclid", "jousselme")
EMPTY_MODES = ("union", "empty")


@register_rule("r_rule", summary="R-weighted local-conflict rule of the DSmT tracking paper, folded in source order",
               associative=False, keeps_conflict=True, aliases=("r", "rrule", "wang"),
               options=("r_mode", "empty_mode"))
def r_rule(sources: Sequence[MassBatch], model: Model, r_mode: str = "paper", empty_mode: str = "union") -> MassBatch:
    """The R-weighted conflict rule of SPEC A.4 (W (10)–(14) with the missing W (12′)).

    Two sources: the inconsistency R ∈ [0, 1] (W (10); ``r_mode`` "paper" as printed,
    "euclid", or "jousselme") splits each local conflict k of a pair {A, B} (W (11)):
    R·k stays on A ∩ B (W (14)), or, when A ∩ B is empty under the model, goes to A ∪ B
    (``empty_mode="union"``) or to ∅ (``"empty"``); (1 - R)·k goes to A, B and A ∪ B in
    proportion to m0, Dempster's combination of the sources' Shafer projections (W (12),
    (12′), (13)).  More sources are folded in the given order: the rule is not associative.
    """
    check_r_options(r_mode, empty_mode)
    require_normal(sources, "r_rule")
    for k, b in enumerate(sources, start=1):
        require_kept(b, model, "r_rule", k)
    # Read every source under the fusion model first, so that elements it identifies are merged.
    mapped = [b if b.model == model else b.under(model) for b in sources]
    budget = FoldBudget("r_rule", len(mapped), max(len(b) for b in mapped), False,
                        "the R-weighted rule sorts its pairs in Python")
    result = mapped[0]
    for number, b in enumerate(mapped[1:], start=2):
        budget.step(len(result.focal), len(b.focal), number)
        result = _r_pair(result, b, model, r_mode, empty_mode)
    return result


def check_r_options(r_mode: str = "paper", empty_mode: str = "union") -> None:
    """Refuse an ``r_mode`` not in :data:`R_MODES` or an ``empty_mode`` not in :data:`EMPTY_MODES`."""
    if r_mode not in R_MODES:
        raise InvalidMassError(f"r_mode must be one of {', '.join(R_MODES)}, got {r_mode!r}")
    if empty_mode not in EMPTY_MODES:
        raise InvalidMassError(f"empty_mode must be one of {', '.join(EMPTY_MODES)}, got {empty_mode!r}")


def _shafer_projection(element: Element) -> int:
    """π0(X) as a bit mask of hypotheses: the singleton regions of X (SPEC A.2)."""
    mask = 0
    for t in element.terms:
        if t.bit_count() == 1:
            mask |= t
    return mask


@dataclass(frozen=True, eq=False)
class _RPlan:
    """Index tables of the R-weighted rule for one pair of focal-element lists."""

    consensus: tuple[np.ndarray, np.ndarray]   # source columns of the consensus tuples
    scatter: Scatter                           # targets of [consensus tuples | kept, A, B, A∪B of every pair]
    consensus_positions: np.ndarray            # where the consensus entries sit in scatter order
    conflict: tuple[np.ndarray, np.ndarray]    # source columns of conflicting tuples, sorted by pair
    pair_starts: np.ndarray                    # where each pair's run starts, shape (C,)
    projection: tuple[np.ndarray, np.ndarray]  # tuples whose Shafer projections meet, sorted by that meet
    projection_starts: np.ndarray              # shape (P,)
    m0_index: np.ndarray                       # (C, 3): m0 column of π0(A), π0(B), π0(A∪B), or P if none
    support: tuple[np.ndarray, np.ndarray]     # (C, 3): columns of A, B, A∪B in each source, or K_i if absent
    pair_positions: tuple[np.ndarray, ...]     # four (C,) arrays: where each slot's entries sit in scatter order
    aligned: tuple[np.ndarray, np.ndarray]     # columns of the union of focal elements in each source, or K_i
    union_focal: tuple[Element, ...]


def _grouped(codes: list[int], columns: tuple[np.ndarray, ...]):
    """Columns sorted by code, and the start of each code's run."""
    codes_array = np.array(codes, dtype=np.int64)
    order = np.argsort(codes_array, kind="stable")
    sorted_codes = codes_array[order]
    starts = np.flatnonzero(np.r_[True, sorted_codes[1:] != sorted_codes[:-1]]) if len(codes) else np.zeros(0, np.int64)
    return tuple(c[order] for c in columns), starts


@lru_cache(maxsize=512)
def _r_plan(plan: TuplePlan, empty_mode: str) -> _RPlan:
    model = plan.model
    first, second = plan.projected
    c1, c2 = plan.columns
    pairs: dict[frozenset, int] = {}
    pair_elements: list[tuple[Element, Element]] = []
    consensus, consensus_targets = [], []
    conflict, conflict_pair = [], []
    projected, projected_key = [], []
    keys: dict[int, int] = {}
    for t, (i, j) in enumerate(plan.tuples):
        x, y, z = first[i], second[j], plan.meets[t]
        px, py = _shafer_projection(x), _shafer_projection(y)
        if px & py:
            projected.append(t)
            projected_key.append(keys.setdefault(px & py, len(keys)))
        if not x.terms or not y.terms:
            is_conflict = False                      # ∅ carried by a running result stays on ∅
        elif not z.terms:
            is_conflict = True
        elif x <= y or y <= x:
            is_conflict = False
        else:
            is_conflict = bool(px and py and not px & py)   # paradox: distinct singletons that may overlap
        if is_conflict:
            key = frozenset((x, y))
            if key not in pairs:
                pairs[key] = len(pairs)
                pair_elements.append((x, y))
            conflict.append(t)
            conflict_pair.append(pairs[key])
        else:
            consensus.append(t)
            consensus_targets.append(z)
    cons = np.array(consensus, dtype=np.int64)
    conflict_columns, pair_starts = _grouped(conflict_pair, (c1[conflict], c2[conflict]))
    projection_columns, projection_starts = _grouped(projected_key, (c1[projected], c2[projected]))
    n_pairs = len(pairs)
    m0_index = np.full((n_pairs, 3), len(keys), dtype=np.int64)
    columns1 = {e: c for c, e in enumerate(first)}
    columns2 = {e: c for c, e in enumerate(second)}
    support1 = np.full((n_pairs, 3), len(first), dtype=np.int64)
    support2 = np.full((n_pairs, 3), len(second), dtype=np.int64)
    slot_targets: list[list[Element]] = [[], [], [], []]
    for c, (a, b) in enumerate(pair_elements):
        union = model.reduce(a | b)
        meet = model.reduce(a & b)
        kept = meet if meet.terms else (union if empty_mode == "union" else model.frame.empty)
        for slot, e in enumerate((kept, a, b, union)):
            slot_targets[slot].append(e)
        for slot, e in enumerate((a, b, union)):
            p = _shafer_projection(e)
            if p in keys:
                m0_index[c, slot] = keys[p]
            support1[c, slot] = columns1.get(e, len(first))
            support2[c, slot] = columns2.get(e, len(second))
    n_cons = len(consensus)
    scatter = Scatter(consensus_targets + [e for slot in slot_targets for e in slot])
    rank = np.empty(n_cons + 4 * n_pairs, dtype=np.int64)
    rank[scatter.order] = np.arange(rank.size)
    consensus_positions = rank[:n_cons]
    positions = tuple(rank[n_cons + slot * n_pairs:n_cons + (slot + 1) * n_pairs] for slot in range(4))
    union_focal = tuple(sorted(set(first) | set(second), key=lambda e: e.sort_key))
    aligned = (np.array([columns1.get(e, len(first)) for e in union_focal], dtype=np.int64),
               np.array([columns2.get(e, len(second)) for e in union_focal], dtype=np.int64))
    return _RPlan((c1[cons], c2[cons]), scatter, consensus_positions, conflict_columns, pair_starts,
                  projection_columns, projection_starts, m0_index, (support1, support2), positions, aligned,
                  union_focal)


def inconsistency(first, second, *aligned, r_mode: str = "paper") -> np.ndarray:
    """The inconsistency R of W (10) between two batches, row by row, shape (N,).

    ``paper``: R = sqrt(Σ_A |m1(A) - m2(A)| / 2) as printed; ``euclid``:
    sqrt(½ Σ_A (m1(A) - m2(A))²); ``jousselme``: sqrt(½ Δᵀ D Δ) with D_AB = C(A∩B)/C(A∪B)
    (SPEC A.4).  The sums run over the focal elements of either batch.

    For Bayesian batches on the models of :func:`~belief.bayesian.exclusive_split` this costs
    O(n) per row whatever the mode: between singletons D is 1/3 for two free hypotheses and
    0 otherwise off the diagonal.

    ``paper`` gives exactly R = 1 when no element has mass in both rows (disjoint focal
    sets, SPEC A.4), whatever the rounding of the sum: the rule is discontinuous where m0
    vanishes, so a spurious (1 - R)·k of 1e-17 would change later folds.

    Parameters
    ----------
    first, second : MassBatch or MassFunction
        Under one model; a one-row batch (or a mass function) is broadcast.  For rows
        already aligned on a common focal list, pass two ndarrays of shape (N, K) followed
        by the focal elements and the model: ``inconsistency(m1, m2, focal, model)``.
    r_mode : {"paper", "euclid", "jousselme"}
        May also be given as the third positional argument.

    Returns
    -------
    ndarray, shape (N,)

    Raises
    ------
    InvalidMassError
        For an unknown ``r_mode``, or batches of different numbers of rows.
    FrameError, ModelError
        For batches of different frames or models.

    Examples
    --------
    SPEC A.4: paper R = 0.632 and euclid R = 0.400.

    >>> from belief import MassBatch, Model
    >>> model = Model.for_targets(2)
    >>> a = MassBatch.bayesian([0.6, 0.3, 0.1], model=model)
    >>> b = MassBatch.bayesian([0.2, 0.7, 0.1], model=model)
    >>> inconsistency(a, b).round(4), inconsistency(a, b, r_mode="euclid").round(4)
    (array([0.6325]), array([0.4]))
    """
    if isinstance(first, np.ndarray) or isinstance(second, np.ndarray):
        if len(aligned) not in (2, 3):
            raise InvalidMassError("aligned arrays need the focal elements and the model: "
                                   "inconsistency(m1, m2, focal, model[, r_mode])")
        if len(aligned) == 3:
            r_mode = aligned[2]
        check_r_options(r_mode)
        return _aligned_inconsistency(np.asarray(first, dtype=np.float64), np.asarray(second, dtype=np.float64),
                                      aligned[0], aligned[1], r_mode)[0]
    if len(aligned) > 1:
        raise TypeError("inconsistency(first, second, r_mode) takes at most three positional arguments for batches")
    if aligned:
        r_mode = aligned[0]
    check_r_options(r_mode)
    (b1, b2), model, _ = prepare_sources([first, second], None)
    n = max(len(b1), len(b2))
    split = exclusive_split(model)
    layouts = [bayesian_layout(b.focal_key) for b in (b1, b2)]
    if split is not None and all(layout is not None and layout.empty is None for layout in layouts):
        m1, m2 = (np.broadcast_to(dense_masses(b, layout, split.size)[0], (n, split.size))
                  for b, layout in zip((b1, b2), layouts))
        return bayesian_inconsistency(m1, m2, split, r_mode)
    focal = tuple(sorted(set(b1.focal) | set(b2.focal), key=lambda e: e.sort_key))
    index1 = {e: i for i, e in enumerate(b1.focal)}
    index2 = {e: i for i, e in enumerate(b2.focal)}
    p1, p2 = _padded(b1.values), _padded(b2.values)
    v1 = np.take(p1, [index1.get(e, len(b1.focal)) for e in focal], axis=1)
    v2 = np.take(p2, [index2.get(e, len(b2.focal)) for e in focal], axis=1)
    return _aligned_inconsistency(np.broadcast_to(v1, (n, len(focal))), np.broadcast_to(v2, (n, len(focal))),
                                  focal, model, r_mode)[0]


def _aligned_inconsistency(m1: np.ndarray, m2: np.ndarray, focal: Sequence[Element], model: Model,
                           r_mode: str = "paper") -> tuple[np.ndarray, np.ndarray]:
    """R of W (10) between rows of two arrays aligned on ``focal``, and 1 − R; shapes (N,)."""
    def jousselme(delta: np.ndarray) -> np.ndarray:
        matrix = _jousselme_matrix(model, tuple(focal))
        return 0.5 * np.einsum("na,ab,nb->n", delta, matrix, delta)

    return aligned_inconsistency(m1, m2, r_mode, jousselme)


@lru_cache(maxsize=256)
def _jousselme_matrix(model: Model, focal: tuple[Element, ...]) -> np.ndarray:
    size = len(focal)
    matrix = np.zeros((size, size))
    for a in range(size):
        for b in range(size):
            union = model.cardinality(focal[a] | focal[b])
            matrix[a, b] = model.cardinality(focal[a] & focal[b]) / union if union else 0.0
    return matrix


def _padded(values: np.ndarray) -> np.ndarray:
    """values with a column of zeros appended (index K stands for "absent")."""
    return np.concatenate([values, np.zeros((values.shape[0], 1))], axis=1)


def _r_pair(b1: MassBatch, b2: MassBatch, model: Model, r_mode: str, empty_mode: str) -> MassBatch:
    plan = checked_plan([b1, b2], model)
    rp = _r_plan(plan, empty_mode)
    n, (v1, v2) = broadcast_values([b1, b2])
    out = np.empty((n, len(rp.scatter.elements)))
    width = len(rp.consensus_positions) + 4 * len(rp.pair_starts)
    for rows in row_chunks(n, plan.count + width):
        out[rows] = rp.scatter.apply(_r_pair_entries(rp, v1[rows], v2[rows], model, r_mode, width))
    return prune(MassBatch._trusted(model, rp.scatter.elements, out, canonical=True))


def _r_pair_entries(rp: _RPlan, v1: np.ndarray, v2: np.ndarray, model: Model, r_mode: str,
                    width: int) -> np.ndarray:
    """Every contribution of some rows, in scatter order: consensus products and shared local conflicts."""
    n = v1.shape[0]
    entries = np.empty((n, width))
    entries[:, rp.consensus_positions] = gather_product([v1, v2], rp.consensus)
    n_pairs = len(rp.pair_starts)
    if not n_pairs:
        return entries
    p1, p2 = _padded(v1), _padded(v2)
    r, rho = _aligned_inconsistency(np.take(p1, rp.aligned[0], axis=1), np.take(p2, rp.aligned[1], axis=1),
                                    rp.union_focal, model, r_mode)                       # W (10)
    k = np.add.reduceat(gather_product([v1, v2], rp.conflict), rp.pair_starts, axis=1)   # W (11)
    weights = _m0_weights(rp, v1, v2)
    total = weights[0] + weights[1] + weights[2]
    missing = ~(total > 0)
    if missing.any():
        # SPEC A.4: weight by the sources' own support of A, B and A ∪ B; failing that, all to A ∪ B.
        cols = np.flatnonzero(missing.any(axis=0))
        sub = missing[:, cols]
        support = [np.take(p1, rp.support[0][cols, slot], axis=1) + np.take(p2, rp.support[1][cols, slot], axis=1)
                   for slot in range(3)]
        for slot in range(3):
            weights[slot][:, cols] = np.where(sub, support[slot], weights[slot][:, cols])
        sub_total = weights[0][:, cols] + weights[1][:, cols] + weights[2][:, cols]
        none = ~(sub_total > 0)
        if none.any():
            weights[2][:, cols] = np.where(none, 1.0, weights[2][:, cols])
            sub_total = np.where(none, 1.0, sub_total)
        total[:, cols] = sub_total
    # (1 - R)·k·w/Σw, with the ratio taken first: w ≤ Σw, so a subnormal Σw cannot overflow k/Σw.
    share = k * rho[:, None]
    entries[:, rp.pair_positions[0]] = r[:, None] * k                                    # W (14)
    for slot in range(3):
        entries[:, rp.pair_positions[slot + 1]] = share * (weights[slot] / total)        # W (12), (12′), (13)
    return entries


def _m0_weights(rp: _RPlan, v1: np.ndarray, v2: np.ndarray) -> list[np.ndarray]:
    """Each pair's m0 weights of A, B and A ∪ B (W (12)), scaled per pair so that none has underflowed.

    Only the ratios w / Σw of one pair are used (SPEC A.4), so its three weights may share
    any factor.  The products of masses are kept as mantissa × 2^exponent (as Dempster's rule
    does where its non-empty mass is tiny), summed by m0 element, and each pair's weights are
    scaled to the largest of them: a weight of 1e-330, which doubles would round to zero (and
    the rule then weigh the pair by support), keeps its ratio to the others to the last bits.
    """
    n, pairs = v1.shape[0], len(rp.pair_starts)
    if not len(rp.projection_starts):
        return [np.zeros((n, pairs)) for _ in range(3)]
    (c1, c2), starts = rp.projection, rp.projection_starts
    m1, e1 = _split(np.take(v1, c1, axis=1))
    m2, e2 = _split(np.take(v2, c2, axis=1))
    exponent = e1 + e2
    top = np.maximum.reduceat(exponent, starts, axis=1)
    runs = np.diff(np.append(starts, exponent.shape[1]))
    shift = np.maximum(exponent - np.repeat(top, runs, axis=1), -1100).astype(np.int32)
    mantissas, exponents = _split(np.add.reduceat(np.ldexp(m1 * m2, shift), starts, axis=1))
    exponents = np.where(mantissas == 0, _ZERO_EXPONENT, exponents + top)
    # Index P (no m0 element) reads a zero weight.
    mantissas = np.concatenate([mantissas, np.zeros((n, 1))], axis=1)
    exponents = np.concatenate([exponents, np.full((n, 1), _ZERO_EXPONENT)], axis=1)
    slots = [(np.take(mantissas, rp.m0_index[:, slot], axis=1), np.take(exponents, rp.m0_index[:, slot], axis=1))
             for slot in range(3)]
    pair_top = np.maximum(np.maximum(slots[0][1], slots[1][1]), slots[2][1])
    return [np.ldexp(m, np.maximum(e - pair_top, -1100).astype(np.int32)) for m, e in slots]
