"""Single mass functions whose focal elements are unions of exclusive hypotheses: the leanest path of combine.

The focal elements are hypothesis bit masks, their intersections and unions ``&`` and ``|``, and no element
is made (the result's are made when it is read).  :func:`combine_single` tells whether the path applies to a
combination of :func:`~belief.rules.combine`, and gives its final result.

A few tuples are looped over in Python; more go through numpy, on frames of up to 16 hypotheses by the rank
tables of :func:`~belief.plan.union_ranks`, on wider ones by the masks as rows of 64-bit words
(:mod:`belief.masks`).  What comes back is kept: the grouping of a pair's tuples (on the first mass function, or
in a bounded table), and joint PCR written out as a function (:mod:`belief.joint_code`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache
from itertools import product
from math import fsum
from typing import NamedTuple

import numpy as np

import belief.plan as limits
from belief.batch import SUM_TOLERANCE
from belief.joint_code import pcr_function
from belief.mass import MassFunction, _set, _union_context, mass_from_masks
from belief.model import Model
from belief.masks import canonical_order, from_words, to_words, tuple_codes, tuple_groups, union_key, word_count
from belief.plan import (RANK_TABLE_WIDTH, FoldBudget, check_joint, evict, exclusive_hypotheses, union_ranks)
from belief.rules_classic import WIDE_SCALE, conjunctive, dempster, disjunctive, dsmc, dsmh, dubois_prade, yager
from belief.rules_common import RESULT_TOLERANCE, Source, renormalised
from belief.rules_pcr import pcr5, pcr6, pcr_loop, pcr_share_values, pcr_tables
from belief.rules_registry import RuleInfo
from belief.rules_tuples import column_tuples, pairwise_sum, segment_sum

#: A single combination of at most this many tuples is summed by a Python loop (numpy's calls cost more).
SINGLE_LOOP_TUPLES = 96
#: The same for joint PCR5 and PCR6, whose tuples are written out as a function when they come back
#: (:mod:`belief.joint_code`): a call on them then costs less than numpy's.
PCR_LOOP_TUPLES = 256
#: Joint rules of more tuples than this are checked against the limits of :mod:`belief.plan` first.
JOINT_UNCHECKED_TUPLES = 128
#: How many single-row tables (:func:`_single_table`) are kept for focal elements that come back.
SINGLE_CACHE_SIZE = 1024
#: The single-row tables kept hold at most this many tuples in all (about 16 bytes each).
SINGLE_CACHE_TUPLES = 1 << 22
#: Two mass functions of at most this many tuples are combined by :func:`_pair_arrays` before anything else is tried.
PAIR_ARRAY_TUPLES = 1 << 16

_PAIR_KINDS = frozenset(("meet", "dempster", "join"))
_JOINT_KINDS = frozenset(("pcr5", "pcr6", "dubois_prade", "dsmh"))
_SINGLE_TABLES: dict[tuple, tuple] = {}
_SINGLE_SIGHTINGS: dict[tuple, bool] = {}
#: The built-in rules that :func:`combine_single` evaluates, by function (a rule registered anew under a name
#: keeps its own).
_SINGLE_RULES: dict[Callable, str] = {conjunctive: "meet", dsmc: "meet", dempster: "dempster", disjunctive: "join",
                                      yager: "yager", dubois_prade: "dubois_prade", dsmh: "dsmh", pcr5: "pcr5",
                                      pcr6: "pcr6"}


def combine_single(info: RuleInfo, sources: Sequence[Source], model: Model | None) -> MassFunction | None:
    """Combine mass functions whose focal elements are unions of exclusive hypotheses, or None.

    This is the direct path at its leanest: the focal elements are hypothesis bit masks
    (:meth:`MassFunction._union_masks`), their intersections and unions ``&`` and ``|``, the
    canonical order a look-up in :func:`~belief.plan.union_ranks` (or a sort of the masks on
    frames wider than :data:`~belief.plan.RANK_TABLE_WIDTH`), and no element is made (the
    result's are made when it is read).  It takes Shafer's model, or any model that forbids
    every pair of the hypotheses in use (and, on wide frames, no hypothesis on its own), the
    sources' own model for the fusion, and the built-in rules of :data:`_SINGLE_RULES`
    (Dubois–Prade's and DSmH only up to the rank tables); anything else, every error, and
    Dempster's rule with a non-empty mass below :data:`WIDE_SCALE` (total conflict, or
    products that may have underflowed) go the general way (None).  Each step adds the same
    products in the same order as the plan of :mod:`belief.plan`, so the results are the
    same to the last bit.  The result is final: rescaled as :func:`renormalised` says.
    """
    kind = _SINGLE_RULES.get(info.function)
    if kind is None:
        return None
    if len(sources) == 2 and kind in _PAIR_KINDS:
        # The commonest call, two mass functions just built from unions of hypotheses, checked first.
        a, b = sources
        if type(a) is MassFunction and type(b) is MassFunction:
            source_model = a.model
            masks1 = a._masks
            masks2 = b._masks
            if (b.model is source_model and (model is None or model is source_model) and masks1 is not None
                    and masks2 is not None and source_model._unions and source_model.kind == "shafer"):
                count = len(masks1) * len(masks2)
                if count <= SINGLE_LOOP_TUPLES:
                    return _pair_loop(source_model, kind, masks1, a._floats or a._union_floats(), masks2,
                                      b._floats or b._union_floats(), a)
                if (count <= PAIR_ARRAY_TUPLES and a._floats is not None and b._floats is not None
                        and len(source_model.frame) <= RANK_TABLE_WIDTH):
                    if count > limits.MAX_TUPLES or 5 * count > limits.MAX_WORK or 24 * count > limits.MAX_BYTES:
                        FoldBudget(info.name, 2).step(len(masks1), len(masks2), 2)      # it says which limit
                    return _pair_arrays(source_model, kind, masks1, a._floats, masks2, b._floats)
    fused = _single_any(kind, info, sources, model)
    if fused is None:
        return None
    # A pair of a few tuples there is final already; renormalising it again leaves it as it is.
    return renormalised(fused, len(sources[0]) if len(sources) == 1 else len(sources))


def combine_again(info: RuleInfo, sources: Sequence[Source], model: Model | None) -> MassFunction | None:
    """Joint PCR5 / PCR6 of mass functions met before, by the code written for their focal lists; else None.

    The first source remembers its partners' focal lists (:class:`_JointTable`) when they
    are combined; the same sources again (a tracker, a repeated fusion) then skip the grouping
    of the tuples, and the result is the loop's to the last bit.
    """
    first = sources[0] if sources else None
    if type(first) is not MassFunction:
        return None
    memo = first._memo
    if type(memo) is not _JointTable or memo.plan is None or memo.rule != _SINGLE_RULES.get(info.function):
        return None
    source_model = first.model
    if (len(memo.masks) != len(sources) or not (model is None or model is source_model)
            or memo.count > limits.MAX_TUPLES):
        return None
    values = []
    for m, mk in zip(sources, memo.masks):
        if type(m) is not MassFunction or m._masks is not mk or m.model is not source_model:
            return None
        values.append(m._floats or m._union_floats())
    return memo.combine(source_model, values)


def _single_any(kind: str, info: RuleInfo, sources: Sequence[Source], model: Model | None) -> MassFunction | None:
    """:func:`combine_single` past its commonest call: a result to renormalise, or None."""
    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):
        sources = sources[0]
    if len(sources) < 2 or type(sources[0]) is not MassFunction:
        return None
    source_model = sources[0].model
    for m in sources:
        if type(m) is not MassFunction or (m.model is not source_model and m.model != source_model):
            return None
    if model is not None and model is not source_model and model != source_model:
        return None
    context = source_model._unions
    if context is None:
        context = _union_context(source_model)
    n = len(source_model.frame)
    if not context and not (n > RANK_TABLE_WIDTH and _wide_unions(source_model)):
        return None
    if n > RANK_TABLE_WIDTH and kind in ("dubois_prade", "dsmh"):
        return None                             # left to the plans, which have their elements
    masks = []
    count = 1
    for m in sources:
        mk = m._masks                           # possibly not in canonical order yet (see _MassSlots)
        if mk is None:
            mk = m._union_masks()
            if mk is None:
                return None
        masks.append(mk)
        count *= len(mk)
    if kind in _JOINT_KINDS and (count > min(PCR_LOOP_TUPLES, JOINT_UNCHECKED_TUPLES) or count > limits.MAX_TUPLES):
        check_joint(info.name, [len(mk) for mk in masks], 1, "pcr" if kind in ("pcr5", "pcr6") else "targets",
                    True, kind == "pcr5")
    if source_model.kind != "shafer":
        used = 0
        for mk in masks:
            for x in mk:
                used |= x
        if not exclusive_hypotheses(source_model, used):
            return None
    if count <= SINGLE_LOOP_TUPLES and len(masks) == 2 and kind in ("meet", "dempster", "join"):
        a, b = sources
        return _pair_loop(source_model, kind, masks[0], a._floats or a._union_floats(), masks[1],
                          b._floats or b._union_floats(), a)
    if count <= PCR_LOOP_TUPLES and kind in ("pcr5", "pcr6"):
        if any(0 in mk for mk in masks):
            return None                         # mass on ∅: the general path refuses it
        return _pcr_joint_loop(source_model, kind, masks, [m._floats or m._union_floats() for m in sources],
                               sources[0])
    # The other evaluations follow the canonical order, as the plan does.
    masks = [m._union_masks() for m in sources]
    # Few tuples go through a Python loop on the floats, more through numpy on the arrays.
    if kind in ("pcr5", "pcr6"):
        loop = count <= PCR_LOOP_TUPLES
    elif kind in ("dubois_prade", "dsmh"):
        loop = count <= SINGLE_LOOP_TUPLES
    else:
        loop = len(masks[0]) * len(masks[1]) <= SINGLE_LOOP_TUPLES     # the first step of the fold
    if loop:
        values = [m._union_floats() for m in sources]
    else:
        values = [m.values for m in sources]
    if kind in ("pcr5", "pcr6", "yager", "dubois_prade", "dsmh"):
        for mk in masks:
            if mk[0] == 0:                      # mass on ∅ (it sorts first): the general path refuses it
                return None
        if kind in ("pcr5", "pcr6"):
            return _single_pcr(source_model, n, masks, values, kind)
    if kind in ("dubois_prade", "dsmh"):
        out = _single_targets(n, masks, values, kind)
    else:
        out = _single_fold(n, masks, values, "join" if kind == "join" else "meet", FoldBudget(info.name, len(masks)))
    if out is None:
        return None
    focal, row = out
    if focal[0] == 0:
        if kind == "dempster":
            # As Dempster's rule does: the rest rescaled by its sum (numpy's pairwise sum, also in the loop's lists).
            if type(row) is list:
                kept = row[1:]
                scale = pairwise_sum(kept, 0, len(kept))
                if not scale > WIDE_SCALE:
                    return None                 # underflow or total conflict: the general path tells which
                focal, row = focal[1:], [x / scale for x in kept]
            else:
                kept = row[1:]
                scale = kept.sum()
                if not scale > WIDE_SCALE:
                    return None
                focal, row = focal[1:], kept / scale
        elif kind == "yager":
            focal, row = _single_to_total(source_model, n, focal, np.asarray(row))
    if type(row) is np.ndarray and kind in ("meet", "dempster", "join"):
        # Every mass of a mass function is positive: if the product of the smallest ones is,
        # so is every product and every sum of them (rounding is monotone), and there is no
        # zero to drop.
        least = 1.0
        for m in sources:
            least *= min(m._union_floats())
        if least > 0:
            return mass_from_masks(source_model, focal if type(focal) is tuple else tuple(focal),
                                            row if row.base is None else row.copy())
    return _single_result(source_model, focal, row)


def _pair_loop(model: Model, kind: str, masks1: tuple[int, ...], values1: tuple[float, ...], masks2: tuple[int, ...],
               values2: tuple[float, ...], owner: MassFunction | None = None) -> MassFunction | None:
    """Two mass functions, a few tuples, a rule of the ∩ or ∪ kind: :func:`combine_single` in one Python function.

    The products that reach one element are added by ``math.fsum``, and Dempster's
    normalisation divides by the ``fsum`` of the non-empty masses: correctly rounded sums,
    which do not depend on the order of the focal elements, so that the sources need not
    be sorted first and the result is left to sort itself when read.  They agree with the
    plan's sums within a few units in the last place.

    ``owner`` (the first mass function) remembers its partner's focal elements: when the
    same two meet again, the grouping of the tuples is made once and kept on it
    (:func:`_pair_table`), and later calls only multiply and add.

    The result is final: normalised for Dempster's rule, else rescaled where
    :func:`renormalised` would rescale it, zeros dropped.
    """
    key = "join" if kind == "join" else "meet"
    if owner is not None:
        memo = owner._memo
        if type(memo) is tuple and memo[0] is masks1 and memo[1] is masks2 and memo[2] == key:
            table = memo[3]
            if table is None:
                table = _pair_table(masks1, masks2, key)
                _set(owner, "_memo", (masks1, masks2, key, table))
            return _pair_from_table(model, kind, table, values1, values2)
        _set(owner, "_memo", (masks1, masks2, key, None))
    groups: dict = {}
    get = groups.get
    normalise = False
    join = kind == "join"
    dempster = kind == "dempster"
    for a, p in zip(masks1, values1):
        for b, q in zip(masks2, values2):
            c = a | b if join else a & b
            if not c and dempster:
                # Dempster's rule reads nothing of ∅ but whether it was reached: its tuples are skipped.
                normalise = True
                continue
            group = get(c)
            if group is None:
                groups[c] = p * q               # one product: no list
            elif type(group) is float:
                groups[c] = [group, p * q]
            else:
                group.append(p * q)
    sums = [group if type(group) is float else group[0] + group[1] if len(group) == 2 else fsum(group)
            for group in groups.values()]
    # _pair_result, inline: a call on new inputs pays for every function it enters.
    scale = fsum(sums)
    if normalise:
        if not scale > WIDE_SCALE:
            return None                         # underflow or total conflict: the general path tells which
        sums = [x / scale for x in sums]
    elif RESULT_TOLERANCE < abs(scale - 1.0) <= _PAIR_REACH:
        sums = [x / scale for x in sums]
    if not min(values1) * min(values2) > 0 and not all(x > 0 for x in sums):
        pairs = [(f, x) for f, x in zip(groups, sums) if x > 0]
        return mass_from_masks(model, [f for f, _ in pairs], [x for _, x in pairs], True)
    return mass_from_masks(model, list(groups), sums, True)


#: What :func:`renormalised` rescales in the result of two sources.
_PAIR_REACH = 4 * SUM_TOLERANCE


def _pair_result(model: Model, focal: list, sums: list, normalise: bool, positive: bool) -> MassFunction | None:
    """The mass function of a pair's sums per target, final (see :func:`_pair_loop`).

    None where Dempster's normalisation would divide by a non-empty mass below
    :data:`WIDE_SCALE` (underflow or total conflict: the general path tells which).
    ``positive``: the product of the smallest masses of the two sources is positive.
    """
    scale = fsum(sums)
    if normalise:
        if not scale > WIDE_SCALE:
            return None
        sums = [x / scale for x in sums]
    elif RESULT_TOLERANCE < abs(scale - 1.0) <= _PAIR_REACH:
        sums = [x / scale for x in sums]
    # Masses are positive: if the product of the smallest two is, so is every product, every sum
    # and every quotient by a scale of at most 1 + _PAIR_REACH (rounding is monotone), and no
    # zero is dropped.
    if not positive and not all(x > 0 for x in sums):
        pairs = [(f, x) for f, x in zip(focal, sums) if x > 0]
        return mass_from_masks(model, [f for f, _ in pairs], [x for _, x in pairs], True)
    return mass_from_masks(model, focal, sums, True)


def _pair_table(masks1, masks2, key: str) -> tuple:
    """How the tuples of two focal lists group by target: the targets, the columns of each group's tuples, the sizes."""
    groups: dict[int, list[tuple[int, int]]] = {}
    for i, a in enumerate(masks1):
        for j, b in enumerate(masks2):
            groups.setdefault(a | b if key == "join" else a & b, []).append((i, j))
    focal = list(groups)
    rows = [i for group in groups.values() for i, _ in group]
    columns = [j for group in groups.values() for _, j in group]
    sizes = [len(group) for group in groups.values()]
    empty = focal.index(0) if 0 in groups else None
    return focal, rows, columns, sizes, empty


def _pair_from_table(model: Model, kind: str, table: tuple, values1, values2) -> MassFunction | None:
    """:func:`_pair_loop` on the grouping of :func:`_pair_table`: the same sums."""
    focal, rows, columns, sizes, empty = table
    products = [values1[i] * values2[j] for i, j in zip(rows, columns)]
    sums = []
    start = 0
    for size in sizes:
        if size == 1:
            sums.append(products[start])
        elif size == 2:
            sums.append(products[start] + products[start + 1])
        else:
            sums.append(fsum(products[start:start + size]))
        start += size
    focal = list(focal)
    normalise = kind == "dempster" and empty is not None
    if normalise:
        del focal[empty], sums[empty]
    return _pair_result(model, focal, sums, normalise, min(values1) * min(values2) > 0)


def _pair_arrays(model: Model, kind: str, masks1: Sequence[int], values1: Sequence[float], masks2: Sequence[int],
                 values2: Sequence[float]) -> MassFunction | None:
    """Two mass functions of many tuples, a rule of the ∩ or ∪ kind: numpy over the outer products, final.

    The sources' masks are not sorted themselves: the tuples are put in the order in which the
    plan adds them (:func:`_pair_order`: by target, then by the canonical positions of their
    focal elements), so that the sums are the plan's to the last bit.  The order is kept
    (:func:`_single_seen`) for when the same two meet again.  None where
    Dempster's normalisation would divide by a non-empty mass below :data:`WIDE_SCALE`.
    """
    key = "join" if kind == "join" else "meet"
    n = len(model.frame)
    memo = (n, key, (tuple(masks1), tuple(masks2)))
    table = _SINGLE_TABLES.get(memo)
    if table is None:
        table = _single_table(n, [masks1, masks2], key)
        _single_seen(memo, table)
    products = np.multiply.outer(np.array(values1), np.array(values2)).ravel()
    sums = np.add.reduceat(products[table.order], table.starts)
    focal = table.focal
    normalised = kind == "dempster" and focal[0] == 0
    if normalised:
        kept = sums[1:]
        scale = kept.sum()
        if not scale > WIDE_SCALE:
            return None                         # underflow or total conflict: the general path tells which
        focal, sums = focal[1:], kept / scale
    if min(values1) * min(values2) > 0:
        # Every product is positive, and so is every sum: no zero to drop (see _single_any).
        fused = mass_from_masks(model, focal, sums)
    else:
        fused = _single_result(model, focal, sums)
    # Quotients by their own sum add up to one within a few units in the last place, far inside
    # RESULT_TOLERANCE: renormalised would return them as they are.
    return fused if normalised else renormalised(fused, 2)


class _PairOrder(NamedTuple):
    """How the tuples of two focal lists group by target (:func:`_pair_order`)."""

    order: np.ndarray                   # the tuples (row-major) sorted by target, then canonically
    starts: np.ndarray                  # where each target's run begins
    focal: tuple[int, ...]              # the targets, in canonical order


def _pair_order(n: int, key: str, masks1: Sequence[int], masks2: Sequence[int]) -> _PairOrder:
    """The :class:`_PairOrder` of two lists of hypothesis masks under ∩ (``key="meet"``) or ∪.

    Each list is put in canonical order (its ranks, distinct, sorted by radix), the tuples of
    the sorted lists are sorted by the rank of their target (stably, by radix), and the
    result is mapped back to the tuples of the lists as given.
    """
    rank = _narrow_ranks(n)
    a = np.array(masks1)
    b = np.array(masks2)
    first = rank[a].argsort(kind="stable")
    second = rank[b].argsort(kind="stable")
    ufunc = np.bitwise_and if key == "meet" else np.bitwise_or
    ranked = rank[ufunc.outer(a[first], b[second])].ravel()
    by_target = ranked.argsort(kind="stable")
    rows, columns = np.divmod(by_target, len(b))
    targets = ranked[by_target]
    change = np.empty(len(targets), dtype=bool)
    change[0] = True
    np.not_equal(targets[1:], targets[:-1], out=change[1:])
    starts = change.nonzero()[0]
    order = first[rows] * len(b) + second[columns]
    return _PairOrder(order, starts, tuple(union_ranks(n)[1][targets[starts]].tolist()))


def _pcr_joint_loop(model: Model, rule: str, masks: list, values: list,
                    owner: MassFunction | None = None) -> MassFunction:
    """PCR5 / PCR6 of a few tuples of unions of hypotheses, in one Python loop over the tuples.

    A tuple whose focal elements meet gives its product to the intersection (the
    consensus); a conflicting one shares it among its elements, by the masses (PCR6) or
    by the product of the masses of each distinct element (PCR5).  What reaches one
    element is added by ``math.fsum``, so the result does not depend on the order of the
    focal elements and agrees with the plan's (consensus folded pairwise, then the
    shares) within a few units in the last place.

    ``owner`` (the first source) remembers the focal elements of the sources: when the same
    ones meet again, the tuples are grouped once into a :class:`_JointTable` kept on it, and
    later calls only multiply, divide and add (:meth:`_JointTable.combine`), to the same bits.
    """
    if owner is not None:
        memo = owner._memo
        if type(memo) is _JointTable and memo.rule == rule and memo.holds(masks):
            return memo.combine(model, values)
        _set(owner, "_memo", _JointTable(tuple(masks), rule))
    groups: dict = {}
    get = groups.get
    pcr5 = rule == "pcr5" and len(masks) > 2            # two distinct elements: PCR5 and PCR6 coincide
    for combo in product(*[tuple(zip(mk, v)) for mk, v in zip(masks, values)]):
        meet = -1
        mass = 1.0
        total = 0.0
        for x, m in combo:
            meet &= x
            mass *= m
            total += m
        if meet:
            shares = ((meet, mass),)
        elif pcr5:
            weights: dict = {}
            for x, m in combo:
                weights[x] = weights[x] * m if x in weights else m
            total = 0.0
            for w in weights.values():
                total += w
            # Every group weight underflowed, and the product with them: the tuple shares nothing.
            factor = mass / total if total > 0.0 else 0.0
            shares = [(x, factor * w) for x, w in weights.items()]
        else:
            factor = mass / total
            shares = [(x, factor * m) for x, m in combo]
        for c, v in shares:
            group = get(c)
            if group is None:
                groups[c] = v
            elif type(group) is float:
                groups[c] = [group, v]
            else:
                group.append(v)
    focal = []
    sums = []
    for c, group in groups.items():
        x = group if type(group) is float else (group[0] + group[1] if len(group) == 2 else fsum(group))
        if x > 0:
            focal.append(c)
            sums.append(x)
    return mass_from_masks(model, tuple(focal), tuple(sums), True)


class _JointTable:
    """What the first source of a joint PCR combination remembers of its partners (see :func:`_pcr_joint_loop`).

    ``masks`` are the sources' focal lists (the objects themselves: a mass function never
    changes them, and one sorted anew holds new ones); ``plan`` the combination written
    out for them (:func:`~belief.joint_code.pcr_function`), made when they come back.
    """

    __slots__ = ("masks", "rule", "plan", "count")

    def __init__(self, masks: tuple, rule: str) -> None:
        self.masks = masks
        self.rule = rule
        self.plan = None
        self.count = 1
        for mk in masks:
            self.count *= len(mk)

    def holds(self, masks: Sequence) -> bool:
        """Whether these are the focal lists remembered (the same objects)."""
        mine = self.masks
        if len(mine) != len(masks):
            return False
        for a, b in zip(mine, masks):
            if a is not b:
                return False
        return True

    def combine(self, model: Model, values: Sequence[Sequence[float]]) -> MassFunction:
        """The rule on the remembered focal lists with these masses, final: the loop's sums to the last bit.

        Rescaled as :func:`~belief.rules_common.renormalised` rescales a result of these
        sources, and without its zero masses.
        """
        if self.plan is None:
            self.plan = pcr_function(self.masks, self.rule)
        function, focal = self.plan
        sums = function(*values)
        if not min(sums) > 0:
            kept = [k for k, x in enumerate(sums) if x > 0]
            focal, sums = [focal[k] for k in kept], [sums[k] for k in kept]
        total = fsum(sums)
        if RESULT_TOLERANCE < abs(total - 1.0) <= 2 * len(values) * SUM_TOLERANCE:
            sums = [x / total for x in sums]                        # as renormalised does
        return mass_from_masks(model, focal, sums, True)


def _single_result(model: Model, focal: list[int], row: list | np.ndarray) -> MassFunction:
    """The mass function of a result row, without its zero masses (as ``MassBatch.__getitem__``)."""
    if type(row) is list:
        if all(x > 0 for x in row):
            return mass_from_masks(model, tuple(focal), tuple(row))
        pairs = [(f, x) for f, x in zip(focal, row) if x > 0]
        return mass_from_masks(model, tuple([f for f, _ in pairs]), tuple([x for _, x in pairs]))
    if row.min() > 0:
        return mass_from_masks(model, focal if type(focal) is tuple else tuple(focal),
                                        row if row.base is None else row.copy())
    kept = np.flatnonzero(row > 0)
    return mass_from_masks(model, tuple([focal[i] for i in kept.tolist()]), row[kept])


def _single_to_total(model: Model, n: int, focal: list[int], row: np.ndarray) -> tuple[list[int], np.ndarray]:
    """Yager: the ∅ mass (first) added to total ignorance, as :func:`~belief.rules_classic.yager` does."""
    total = sum(model.total.terms)
    new_focal = list(focal[1:])
    new_values = row[1:].copy()
    if total in new_focal:
        new_values[new_focal.index(total)] += row[0]
        return new_focal, new_values
    key = _mask_key(n)
    new_focal.append(total)
    new_values = np.append(new_values, row[0])
    order = sorted(range(len(new_focal)), key=lambda i: key(new_focal[i]))
    return [new_focal[i] for i in order], new_values[order]


def _single_fold(n: int, masks: list, values: list, key: str,
                 budget: FoldBudget | None = None) -> tuple[list[int], list | np.ndarray] | None:
    """:func:`fold` on masks: pairwise, the zero masses of each partial result dropped."""
    if budget is not None:
        budget.step(len(masks[0]), len(masks[1]), 2)
    out = _single_targets(n, masks[:2], values[:2], key)
    for number, (mk, v) in enumerate(zip(masks[2:], values[2:]), start=3):
        focal, row = _single_prune(*out)
        if budget is not None:
            budget.step(len(focal), len(mk), number)
        out = _single_targets(n, [tuple(focal), mk], [row, v], key)
    return _single_prune(*out) if len(masks) > 2 else out


def _single_prune(focal: list[int], row: list | np.ndarray) -> tuple[list[int], list | np.ndarray]:
    """:func:`prune` of one row."""
    if type(row) is not np.ndarray:
        if all(x != 0 for x in row):
            return focal, row
        pairs = [(f, x) for f, x in zip(focal, row) if x != 0]
        return [f for f, _ in pairs], [x for _, x in pairs]
    live = np.flatnonzero(row)
    if live.size == len(focal):
        return focal, row
    return [focal[i] for i in live.tolist()], row[live]


def _single_seen(key: tuple, table) -> None:
    """Keep ``table`` if ``key`` was met before (its focal elements came back); else remember ``key``.

    The tables kept hold at most :data:`SINGLE_CACHE_TUPLES` tuples in all (``key[2]`` holds
    the focal lists), the least recently kept going first.
    """
    if _SINGLE_SIGHTINGS.pop(key, False):
        size = _tuple_count(key)
        if size > SINGLE_CACHE_TUPLES:
            return
        kept = sum(map(_tuple_count, list(_SINGLE_TABLES)))
        while _SINGLE_TABLES and (len(_SINGLE_TABLES) >= SINGLE_CACHE_SIZE or kept + size > SINGLE_CACHE_TUPLES):
            oldest = next(iter(_SINGLE_TABLES))
            kept -= _tuple_count(oldest)
            _SINGLE_TABLES.pop(oldest, None)
        _SINGLE_TABLES[key] = table
        return
    if len(_SINGLE_SIGHTINGS) >= SINGLE_CACHE_SIZE:
        evict(_SINGLE_SIGHTINGS)
    _SINGLE_SIGHTINGS[key] = True


def _tuple_count(key: tuple) -> int:
    count = 1
    for masks in key[2]:
        count *= len(masks)
    return count


def _outer(values: Sequence[np.ndarray]) -> np.ndarray:
    """Π_i values[i][X_i] for every tuple, row-major, multiplied left to right as :func:`gather_product`."""
    if len(values) == 2:
        return np.multiply.outer(values[0], values[1]).ravel()
    s = len(values)
    out = values[0].reshape((-1,) + (1,) * (s - 1))
    for i, v in enumerate(values[1:], start=1):
        out = out * v.reshape((1,) * i + (-1,) + (1,) * (s - 1 - i))
    return out.ravel()


def _single_targets(n: int, masks: list, values: list, key: str) -> tuple[list[int], list | np.ndarray] | None:
    """Each tuple's product to one union of hypotheses: the targets in canonical order and their sums."""
    count = 1
    for mk in masks:
        count *= len(mk)
    if count <= SINGLE_LOOP_TUPLES:
        return _single_loop(n, masks, values, key)
    memo = (n, key, tuple(masks))
    table = _SINGLE_TABLES.get(memo)
    if table is None:
        table = _single_table(n, masks, key)
        if table is None:
            return None
        _single_seen(memo, table)
    order, starts, focal = table
    values = [v if type(v) is np.ndarray else np.array(v) for v in values]
    return focal, np.add.reduceat(_outer(values)[order], starts)


def _single_table(n: int, masks: list, key: str) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]] | None:
    """The order that sorts the tuples by target (stable), where each target's run starts, and the targets."""
    if n > RANK_TABLE_WIDTH:
        return _wide_table(n, masks, key)
    if len(masks) == 2 and key in ("meet", "join"):
        return _pair_order(n, key, masks[0], masks[1])          # also for masks in any order
    else:
        arrays = [np.array(mk, dtype=np.int64) for mk in masks]
        if key == "meet":
            codes = tuple_codes(arrays, np.bitwise_and)
        elif key == "join":
            codes = tuple_codes(arrays, np.bitwise_or)
        else:
            meet = tuple_codes(arrays, np.bitwise_and)
            join = tuple_codes(arrays, np.bitwise_or)
            if key == "dsmh" and not ((meet != 0) | (join != 0)).all():
                return None
            codes = np.where(meet != 0, meet, join)
    ranked = _narrow_ranks(n)[codes].ravel()
    order = ranked.argsort(kind="stable")
    sorted_ranks = ranked[order]
    step = np.empty(len(sorted_ranks), dtype=bool)
    step[0] = True
    np.not_equal(sorted_ranks[1:], sorted_ranks[:-1], out=step[1:])
    starts = step.nonzero()[0]
    return order, starts, tuple(union_ranks(n)[1][sorted_ranks[starts]].tolist())


def _wide_table(n: int, masks: list, key: str) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """:func:`_single_table` beyond the rank tables: the tuples grouped by their result's words, then sorted."""
    words = word_count(n)
    unique, _, inverse = tuple_groups([to_words(mk, words) for mk in masks],
                                      np.bitwise_and if key == "meet" else np.bitwise_or)
    canonical = canonical_order(unique)
    rank = np.empty(len(canonical), dtype=np.int64 if len(canonical) >= 1 << 31 else np.int32)
    rank[canonical] = np.arange(len(canonical))
    order = rank[inverse].argsort(kind="stable")
    # Every distinct result is present: its run starts after the runs of those before it.
    sizes = np.bincount(rank[inverse], minlength=len(canonical))
    starts = np.zeros(len(canonical), dtype=np.int64)
    np.cumsum(sizes[:-1], out=starts[1:])
    return order, starts, tuple(from_words(unique[canonical]))


@lru_cache(maxsize=None)
def _narrow_ranks(n: int) -> np.ndarray:
    """:func:`~belief.plan.union_ranks` in the narrowest unsigned type (small keys sort by radix)."""
    return union_ranks(n)[0].astype(np.uint8 if n <= 8 else np.uint16)


@lru_cache(maxsize=64)
def _wide_unions(model: Model) -> bool:
    """Whether unions of hypotheses are their own form under a model of a frame too wide for the rank tables."""
    return model.kind == "shafer" or all(f & (f - 1) for f in model.forbidden)


@lru_cache(maxsize=64)
def _mask_key(n: int):
    """The sort key of hypothesis masks of n hypotheses in canonical order (:func:`~belief.masks.union_key`)."""
    return union_key(n, union_ranks(n)[2] if n <= RANK_TABLE_WIDTH else None)


def _single_loop(n: int, masks: list, values: list, key: str) -> tuple[list[int], list[float]] | None:
    """:func:`_single_targets` for a few tuples, in Python, with numpy's order of additions (sums as a list)."""
    rows = [v if type(v) is not np.ndarray else v.tolist() for v in values]
    groups: dict[int, list[float]] = {}
    get = groups.get
    if len(masks) == 2 and key in ("meet", "join"):
        c1, c2 = masks
        v1, v2 = rows
        meet = key == "meet"
        for a, p in zip(c1, v1):
            for b, q in zip(c2, v2):
                c = a & b if meet else a | b
                group = get(c)
                if group is None:
                    groups[c] = [p * q]
                else:
                    group.append(p * q)
    else:
        for columns in column_tuples([len(mk) for mk in masks]):
            meet = -1
            join = 0
            for mk, k in zip(masks, columns):
                meet &= mk[k]
                join |= mk[k]
            if key == "meet":
                c = meet
            elif key == "join":
                c = join
            else:
                c = meet or join
                if key == "dsmh" and not c:
                    return None
            p = rows[0][columns[0]]
            for row, k in zip(rows[1:], columns[1:]):
                p *= row[k]
            group = get(c)
            if group is None:
                groups[c] = [p]
            else:
                group.append(p)
    focal = sorted(groups, key=_mask_key(n))
    sums = []
    for c in focal:
        group = groups[c]
        sums.append(group[0] if len(group) == 1 else segment_sum(group))
    return focal, sums


def _single_pcr(model: Model, n: int, masks: list, values: list, rule: str) -> MassFunction:
    """PCR5 / PCR6 of mass functions of unions of hypotheses: :func:`~belief.rules_pcr.pcr6` (or pcr5) on masks."""
    focal, consensus = _single_fold(n, masks, values, "meet")
    key = _mask_key(n)
    count = 1
    for mk in masks:
        count *= len(mk)
    memo = (n, rule, tuple(masks))
    tables = _SINGLE_TABLES.get(memo)
    if tables is None and count <= PCR_LOOP_TUPLES:
        targets, shares = pcr_loop(masks, [v if type(v) is not np.ndarray else v.tolist() for v in values], rule, key)
    else:
        if tables is None:
            tables = _single_pcr_tables(n, masks, rule)
            _single_seen(memo, tables)
        targets, shares = pcr_share_values(1, [np.asarray(v).reshape(1, -1) for v in values], tables)
    # As PCR5 and PCR6 add them: the consensus without ∅, plus the shares.
    keep = [i for i, x in enumerate(focal) if x]
    union = sorted({focal[i] for i in keep} | set(targets), key=key)
    index = {x: k for k, x in enumerate(union)}
    out = np.zeros((1, len(union)))
    out[:, [index[focal[i]] for i in keep]] += np.asarray(consensus)[keep]
    out[:, [index[x] for x in targets]] += shares
    return _single_result(model, union, out[0])


def _single_pcr_tables(n: int, masks: list, rule: str):
    """:func:`pcr_tables` of mass functions of unions of hypotheses."""
    if n < 64:
        arrays = [np.array(mk, dtype=np.int64) for mk in masks]
        conflict = np.flatnonzero(tuple_codes(arrays, np.bitwise_and) == 0)
    else:
        unique, _, inverse = tuple_groups([to_words(mk, word_count(n)) for mk in masks], np.bitwise_and)
        conflict = np.flatnonzero(~unique.any(axis=1)[inverse])
    columns = tuple(c.astype(np.int64, copy=False) for c in np.unravel_index(conflict, [len(mk) for mk in masks]))
    unique = sorted({x for mk in masks for x in mk}, key=_mask_key(n))
    index = {x: k for k, x in enumerate(unique)}
    per_source = [np.array([index[x] for x in mk], dtype=np.int64) for mk in masks]
    return pcr_tables(columns, unique, per_source, rule, ranked=True)
