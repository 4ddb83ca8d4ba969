"""Rules that send each tuple's product to one element, and what the rules over tuples of focal elements share.

A tuple picks one focal element of each source, and its product Π m_i(X_i) goes to one target: the
intersection, the union, or the element Dubois–Prade's rule or DSmH names.  Focal elements met for the first
time are combined directly, on integer codes of the elements (:func:`direct_path`): by a Python loop over the
tuples of one row, or by numpy over all of them.  When they come back, the compiled plan of :mod:`belief.plan`
serves them (:func:`target_kernel`).  Both add the same products in the same order: ``np.add.reduceat`` for a
few rows, a :class:`~belief.segments.RunProgram` (numpy's order of additions, replayed on blocks of rows) for
many.  The associative rules are folded pairwise (:func:`fold`), each step checked against the limits of
:mod:`belief.plan` first.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache, reduce
from operator import add

import numpy as np

import belief.plan as limits
from belief.batch import MassBatch, trusted_batch
from belief.errors import InvalidMassError, ModelError
from belief.frame import Element
from belief.model import Model
from belief.masks import to_words, tuple_codes, tuple_groups, word_count
from belief.plan import (Encoding, FoldBudget, Scatter, TuplePlan, canonical_codes, canonical_groups, check_joint,
                         coded_fast, decode, encode, gather_product, plan_lookup, row_chunks, sighted, tuple_plan)
from belief.segments import PROGRAM_MIN_ROWS, RunProgram, program_pays


# -- shared machinery ----------------------------------------------------------------------------
def broadcast_values(batches: Sequence[MassBatch]) -> tuple[int, list[np.ndarray]]:
    """The number of rows N and each source's (N, K_i) masses, a one-row source broadcast (no copy)."""
    n = max(len(b) for b in batches)
    return n, [b.values if len(b) == n else np.broadcast_to(b.values, (n, b.values.shape[1])) for b in batches]


def checked_plan(batches: Sequence[MassBatch], model: Model, rule: str = "") -> TuplePlan:
    """The compiled :class:`~belief.plan.TuplePlan` of these sources, refused first if it would be too large."""
    sizes = [len(b.focal) for b in batches]
    if math.prod(sizes) > limits.MAX_TUPLES:
        check_joint(rule or "the", sizes, max(len(b) for b in batches), "targets")
    return tuple_plan(batches[0].model, model, tuple(b.focal_key for b in batches))


def check_joint_sources(batches: Sequence[MassBatch], model: Model, rule: str, kind: str) -> None:
    """Refuse a joint combination of these sources that would exceed the limits of :mod:`belief.plan`."""
    check_joint(rule, [len(b.focal) for b in batches], max(len(b) for b in batches), kind,
                lambda: coded_fast(model, [b.focal for b in batches]), rule == "pcr5")


def _budget(batches: Sequence[MassBatch], model: Model, rule: str) -> FoldBudget:
    """The :class:`~belief.plan.FoldBudget` of an associative rule folded over these sources."""
    return FoldBudget(rule, len(batches), max(len(b) for b in batches),
                      lambda: coded_fast(model, [b.focal for b in batches]))


def require_normal(batches: Sequence[MassBatch], rule: str) -> None:
    """Refuse sources with mass on ∅, which the rule does not take."""
    for k, b in enumerate(batches, start=1):
        if b.empty_mass.any():
            raise InvalidMassError(f"{rule} needs normal sources, but source {k} has mass on ∅; normalise it first")


def require_kept(batch: MassBatch, model: Model, rule: str, number: int) -> None:
    """Refuse a focal element that vanishes under the fusion model: the rule has nowhere to send its mass."""
    for x in batch.focal:
        if x.terms and model.is_empty(x):
            raise ModelError(
                f"{rule} cannot give mass to {x} of source {number}, which is empty under the {model.kind} "
                "fusion model; use dsmh for such dynamic fusion"
            )


def require_nonempty(focal, projected, model: Model, rule: str) -> None:
    """:func:`require_kept` of every source, from its focal elements and their forms under the fusion model."""
    for k, (orig, proj) in enumerate(zip(focal, projected), start=1):
        for x, y in zip(orig, proj):
            if x.terms and not y.terms:
                raise ModelError(
                    f"{rule} cannot give mass to {x} of source {k}, which is empty under the {model.kind} "
                    "fusion model; use dsmh for such dynamic fusion"
                )


# -- the direct path: focal elements seen for the first time -------------------------------------------
#: A single row with at most this many tuples is combined by a Python loop over the tuples.
LOOP_TUPLES = 256
#: A single row whose codes do not fit 64 bits is looped over up to this many tuples.
WIDE_LOOP_TUPLES = 4096


@dataclass(frozen=True, eq=False)
class Direct:
    """What the direct path needs of one combination: the focal elements under the fusion model and their codes."""

    projected: tuple[tuple[Element, ...], ...]
    encoding: Encoding
    loop: bool                          # a Python loop over the tuples of one row, else numpy over all tuples

    @property
    def sizes(self) -> tuple[int, ...]:
        return tuple(len(c) for c in self.encoding.codes)


def direct_path(batches: Sequence[MassBatch], model: Model, purpose: str) -> Direct | None:
    """How to combine these sources without a plan, or None where the plan serves the call.

    A compiled plan costs more than one direct evaluation and pays only when its focal
    elements come back, so the plan serves a call when it is cached already or when these
    focal lists were met before (it is compiled then); so does a combination whose codes
    are too wide for numpy and too many to loop over.  The choice never changes a result:
    the direct path adds the same products in the same order.
    """
    count = 1
    for b in batches:
        count *= len(b.focal)
    if count > limits.MAX_TUPLES:
        return None                     # the plan path refuses it, with its message
    source_model = batches[0].model
    keys = tuple(b.focal_key for b in batches)
    if plan_lookup(source_model, model, keys) is not None or sighted(source_model, model, keys, purpose):
        return None
    if source_model == model:
        projected = tuple(b.focal for b in batches)      # already in their form under the model
    else:
        projected = tuple(tuple(model.reduce(x) for x in b.focal) for b in batches)
    encoding = encode(model, projected)
    if encoding is None:
        return None
    single = all(len(b) == 1 for b in batches)
    if single and count <= LOOP_TUPLES:
        return Direct(projected, encoding, True)
    if encoding.width <= 64 or (purpose == "targets" and encoding.kind == "exclusive"):
        # Wide hypothesis masks are rows of words (belief.masks); PCR's tables take 64-bit codes only.
        return Direct(projected, encoding, False)
    if single and count <= WIDE_LOOP_TUPLES:
        return Direct(projected, encoding, True)
    return None


def segment_sum(values: list[float]) -> float:
    """The sum ``np.add.reduceat`` gives for one segment: the first value plus numpy's pairwise sum of the rest.

    The loops of the direct path add with it, so that their results equal the plan's to the last bit.
    """
    n = len(values)
    if n == 1:
        return values[0]
    if n <= 8:
        # Fewer than eight after the first: numpy adds them one by one (``sum`` may compensate).
        return values[0] + reduce(add, values[1:])
    return values[0] + pairwise_sum(values, 1, n - 1)


def pairwise_sum(values: list[float], start: int, n: int) -> float:
    """numpy's pairwise summation of ``values[start:start + n]`` (eight partial sums, blocks of 128)."""
    if n < 8:
        total = 0.0
        for i in range(start, start + n):
            total += values[i]
        return total
    if n <= 128:
        r0, r1, r2, r3, r4, r5, r6, r7 = values[start:start + 8]
        i = start + 8
        stop = start + n - n % 8
        while i < stop:
            r0 += values[i]
            r1 += values[i + 1]
            r2 += values[i + 2]
            r3 += values[i + 3]
            r4 += values[i + 4]
            r5 += values[i + 5]
            r6 += values[i + 6]
            r7 += values[i + 7]
            i += 8
        total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        for k in range(i, start + n):
            total += values[k]
        return total
    half = n // 2
    half -= half % 8
    return pairwise_sum(values, start, half) + pairwise_sum(values, start + half, n - half)


def column_tuples(sizes: Sequence[int]):
    """Every tuple of columns, in row-major order (the order of :attr:`TuplePlan.columns`)."""
    return itertools.product(*(range(k) for k in sizes))


def _canonical(direct: Direct, elements: list[Element]) -> list[int]:
    """The positions of ``elements`` in canonical order."""
    if direct.encoding.kind == "exclusive":
        # Unions of hypotheses: fewer hypotheses first, then by their positions (Element.sort_key).
        keys = [(len(e.terms), e.terms) for e in elements]
    else:
        keys = [e.sort_key for e in elements]
    return sorted(range(len(elements)), key=keys.__getitem__)


def _loop_targets(batches: Sequence[MassBatch], model: Model, key: str, direct: Direct) -> MassBatch | None:
    """One row, a few tuples: each tuple's product goes to one element, summed per element in plain Python."""
    codes = direct.encoding.codes
    rows = [b.values[0].tolist() for b in batches]
    groups: dict[int, list[float]] = {}
    first: dict[int, tuple[tuple[int, ...], str]] = {}
    if len(batches) == 2 and key in ("meet", "join"):
        c1, c2 = codes
        v1, v2 = rows
        meet = key == "meet"
        for i, a in enumerate(c1):
            p = v1[i]
            for j, b in enumerate(c2):
                c = a & b if meet else a | b
                group = groups.get(c)
                if group is None:
                    groups[c] = [p * v2[j]]
                    first[c] = ((i, j), key)
                else:
                    group.append(p * v2[j])
    else:
        for columns in column_tuples(direct.sizes):
            meet = join = None
            if key != "join":
                meet = -1
                for c, k in zip(codes, columns):
                    meet &= c[k]
            if key != "meet":
                join = 0
                for c, k in zip(codes, columns):
                    join |= c[k]
            if key == "meet" or (key != "join" and meet):
                code, op = meet, "meet"
            elif key == "join" or join or key == "dubois_prade":
                code, op = join, "join"
            else:
                return None                 # DSmH's S2: every element vanished (the plan path places it)
            p = rows[0][columns[0]]
            for row, k in zip(rows[1:], columns[1:]):
                p *= row[k]
            group = groups.get(code)
            if group is None:
                groups[code] = [p]
                first[code] = (columns, op)
            else:
                group.append(p)
    unique = list(groups)
    elements = decode(model, direct.encoding, direct.projected, unique,
                      [first[c][0] for c in unique], [first[c][1] for c in unique])
    order = _canonical(direct, elements)
    values = np.array([[segment_sum(groups[unique[k]]) for k in order]])
    return trusted_batch(model, tuple(elements[k] for k in order), values, canonical=True)


def _array_targets(batches: Sequence[MassBatch], model: Model, key: str, direct: Direct,
                   normalise: bool = False) -> MassBatch | None:
    """Each tuple's product to one element, on all tuples at once; the arithmetic of the plan path."""
    if direct.encoding.width > 64:
        if key not in ("meet", "join"):
            return None                     # wide masks of Dubois–Prade and DSmH: the plan path
        words = word_count(direct.encoding.width)
        unique, first, inverse = tuple_groups([to_words(c, words) for c in direct.encoding.codes],
                                              np.bitwise_and if key == "meet" else np.bitwise_or)
        elements, ranks = canonical_groups(model, direct.encoding, direct.projected, unique, first, inverse, key)
        scatter = Scatter.from_ranks(elements, ranks)
        columns = tuple(c.astype(np.int64, copy=False) for c in np.unravel_index(scatter.order, direct.sizes))
        return _scatter_products(batches, model, scatter, columns, len(inverse), None, normalise)
    arrays = [np.array(c, dtype=np.uint64) for c in direct.encoding.codes]
    meet = tuple_codes(arrays, np.bitwise_and) if key != "join" else None
    join = tuple_codes(arrays, np.bitwise_or) if key != "meet" else None
    if key == "meet":
        targets, use_meet = meet, None
    elif key == "join":
        targets, use_meet = join, None
    else:
        use_meet = meet != 0
        if key == "dsmh" and not (use_meet | (join != 0)).all():
            return None                     # DSmH's S2: every element vanished (the plan path places it)
        targets = np.where(use_meet, meet, join)
    elements, ranks = canonical_codes(model, direct.encoding, direct.projected, targets,
                                      key if use_meet is None else use_meet)
    scatter = Scatter.from_ranks(elements, ranks)
    columns = tuple(c.astype(np.int64, copy=False) for c in np.unravel_index(scatter.order, direct.sizes))
    return _scatter_products(batches, model, scatter, columns, len(targets), None, normalise)


def _scatter_products(batches: Sequence[MassBatch], model: Model, scatter: Scatter,
                      columns: tuple[np.ndarray, ...], count: int, program=None,
                      normalise: bool = False) -> MassBatch:
    """Sum the tuples' products by target: ``reduceat`` on a few rows, a :class:`RunProgram` on many.

    ``program`` is a callable that gives the program (cached with a plan) or None; the two
    evaluations add the same numbers in the same order.  With ``normalise`` (Dempster's rule,
    see :func:`fold`) a program may return the rows normalised, without ∅.
    """
    n, values = broadcast_values(batches)
    skip = (0,) if normalise and scatter.elements and not scatter.elements[0].terms else ()
    if n >= PROGRAM_MIN_ROWS:
        kernel = program(skip) if program is not None else RunProgram(columns, scatter.starts, skip)
        if program_pays(n, len(scatter.starts), kernel.operations, count):
            if skip:
                rows = kernel.evaluate_normalised(values, DEMPSTER_SMALLEST_SCALE)
                if rows is not None:
                    return trusted_batch(model, scatter.elements[1:], rows, canonical=True)
            return trusted_batch(model, scatter.elements, kernel.evaluate(values), canonical=True)
    out = np.empty((n, len(scatter.elements)))
    for rows in row_chunks(n, count):
        out[rows] = scatter.apply(gather_product([v[rows] for v in values], columns))
    return trusted_batch(model, scatter.elements, out, canonical=True)


@lru_cache(maxsize=512)
def target_program(plan: TuplePlan, key: str, skip: tuple[int, ...]) -> RunProgram:
    """The :class:`~belief.segments.RunProgram` of a plan's :func:`target_kernel` (cached with it)."""
    scatter, columns = target_kernel(plan, key)
    return RunProgram(columns, scatter.starts, skip)


@lru_cache(maxsize=512)
def target_kernel(plan: TuplePlan, key: str) -> tuple[Scatter, tuple[np.ndarray, ...]]:
    """The scatter of a one-target-per-tuple rule, and each source's columns in scatter order."""
    if key == "meet":
        scatter = Scatter.from_codes(*plan.meet_table)
    elif key == "join":
        scatter = Scatter.from_codes(*plan.join_table)
    else:
        scatter = Scatter(_TARGETS[key](plan))
    return scatter, tuple(c[scatter.order] for c in plan.columns)


def tuple_targets_rule(batches: Sequence[MassBatch], model: Model, key: str, normalise: bool = False) -> MassBatch:
    """Rules that send each tuple's whole product to one element.

    With ``normalise``, batches of many rows may come back normalised as Dempster's rule does (see :func:`fold`).
    """
    direct = direct_path(batches, model, "targets")
    if direct is not None:
        if direct.loop:
            result = _loop_targets(batches, model, key, direct)
        else:
            result = _array_targets(batches, model, key, direct, normalise)
        if result is not None:
            return result
    plan = checked_plan(batches, model)
    scatter, columns = target_kernel(plan, key)
    return _scatter_products(batches, model, scatter, columns, plan.count,
                             lambda skip: target_program(plan, key, skip), normalise)


#: Two sources whose tuples × rows are at most this many are combined without a cost estimate.
SMALL_PAIR = 4096


def prune(batch: MassBatch) -> MassBatch:
    """Drop the columns that are zero in every row (they would only widen the next fold)."""
    live = np.flatnonzero((batch.values != 0).any(axis=0))
    if live.size == len(batch.focal):
        return batch
    return trusted_batch(batch.model, tuple(batch.focal[i] for i in live.tolist()), batch.values[:, live],
                              canonical=batch._canonical)


#: A fold of two sources under these rules may come back normalised, without ∅: Dempster's rule drops ∅ and
#: divides each row by the rest (rules_classic._move_empty, to the same bits), which a RunProgram does block by
#: block while the sums are in the processor's cache.
NORMALISED_FOLDS = frozenset(("dempster",))
#: rules_classic.WIDE_SCALE: below it, the rows are left unnormalised for Dempster's rule to decide.
DEMPSTER_SMALLEST_SCALE = 2.0 ** -40


def fold(batches: Sequence[MassBatch], model: Model, key: str, rule: str = "conjunctive") -> MassBatch:
    """Combine pairwise, left to right, each step checked against the limits of :mod:`belief.plan` first.

    Two sources of many rows under a rule of :data:`NORMALISED_FOLDS` may come back
    normalised, without ∅.  More sources never do: a partial result is pruned of its zero
    columns between the steps, and a ∅ column must then mean what it meant before.
    """
    if len(batches) == 2 and len(batches[0].focal) * len(batches[1].focal) * len(batches[0]) * len(batches[1]) \
            <= SMALL_PAIR:
        return tuple_targets_rule(batches, model, key)        # far below every limit: not worth the check
    budget = _budget(batches, model, rule)
    budget.step(len(batches[0].focal), len(batches[1].focal), 2)
    if len(batches) == 2:
        return tuple_targets_rule(batches, model, key, rule in NORMALISED_FOLDS)
    result = prune(tuple_targets_rule(batches[:2], model, key))
    for number, b in enumerate(batches[2:], start=3):
        budget.step(len(result.focal), len(b.focal), number)
        result = prune(tuple_targets_rule([result, b.under(model) if b.model != model else b], model, key))
    return result


def _dubois_prade_targets(plan: TuplePlan) -> list[Element]:
    return [m if m.terms else j for m, j in zip(plan.meets, plan.joins)]


def _hyper_union(element: Element) -> Element:
    """u(X): the union of the hypotheses that appear in X (u(a∩b) = a ∪ b)."""
    frame = element.frame
    mask = element.hypotheses
    return Element._make(frame, tuple(1 << i for i in range(len(frame)) if mask >> i & 1))


def _dsmh_targets(plan: TuplePlan) -> list[Element]:
    model = plan.model
    targets = []
    for t, meet, join in zip(plan.tuples, plan.meets, plan.joins):
        if meet.terms:
            targets.append(meet)                         # S1
        elif join.terms:
            targets.append(join)                         # S3
        else:                                            # S2: every focal element vanished
            u = model.frame.empty
            for source, i in enumerate(t):
                u = u | _hyper_union(plan.focal[source][i])
            u = model.reduce(u)
            targets.append(u if u.terms else model.total)
    return targets


_TARGETS: dict[str, Callable[[TuplePlan], list[Element]]] = {
    "dubois_prade": _dubois_prade_targets,
    "dsmh": _dsmh_targets,
}
