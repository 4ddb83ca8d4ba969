"""PCR5 and PCR6: the consensus, plus each conflicting tuple's product given back to the elements involved (SPEC A.3).

Both are evaluated jointly over all tuples of focal elements, as their s-source definitions require, by the
direct path or the compiled plan of :mod:`belief.rules_tuples` (the same products, added in the same order).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import numpy as np

from belief.batch import MassBatch, trusted_batch
from belief.frame import Element
from belief.model import Model
from belief.masks import tuple_codes
from belief.plan import Scatter, TuplePlan, row_chunks
from belief.rules_registry import register_rule
from belief.rules_tuples import (Direct, broadcast_values, check_joint_sources, checked_plan, column_tuples,
                                 direct_path, fold, require_nonempty, require_normal, segment_sum)


def _pcr(sources: Sequence[MassBatch], model: Model, rule: str) -> MassBatch:
    """Consensus (the conjunctive rule without ∅) plus the redistribution of every conflicting tuple."""
    require_normal(sources, rule)
    check_joint_sources(sources, model, rule, "pcr")
    direct = direct_path(sources, model, "pcr")
    if direct is not None:
        require_nonempty([b.focal for b in sources], direct.projected, model, rule)
        consensus = fold(sources, model, "meet")
        if direct.loop:
            elements, shares = _loop_pcr(sources, direct, rule)
        else:
            elements, shares = _pcr_shares(sources, _array_pcr_tables(direct, rule))
        return _add(model, consensus, elements, shares)
    plan = checked_plan(sources, model, rule)
    require_nonempty(plan.focal, plan.projected, model, rule)
    consensus = fold(sources, model, "meet")
    elements, shares = _pcr_shares(sources, _pcr_kernel(plan, rule))
    return _add(model, consensus, elements, shares)


def _pcr_shares(sources: Sequence[MassBatch], tables) -> tuple[tuple[Element, ...], np.ndarray]:
    """The conflict each element gets back, from the tables of :func:`pcr_tables`."""
    n, values = broadcast_values(sources)
    return pcr_share_values(n, values, tables)


def pcr_share_values(n: int, values: Sequence[np.ndarray], tables) -> tuple[tuple, np.ndarray]:
    """:func:`_pcr_shares` on the sources' (n, K_i) arrays."""
    scatter, columns, positions, representative = tables
    s = len(values)
    count = len(columns[0])
    shares = np.empty((n, len(scatter.elements)))
    for rows in row_chunks(n, count * (s + 2)):
        masses = [np.take(v[rows], c, axis=1) for v, c in zip(values, columns)]      # each (n, Tc)
        product = masses[0].copy()
        for m in masses[1:]:
            product *= m
        if representative is None:                      # PCR6: weight m_i(X_i)
            weights = masses
        else:                                           # PCR5: product of each group's masses, on its first slot
            weights = []
            for j in range(s):
                w = np.broadcast_to((representative[:, j] == j).astype(np.float64), product.shape).copy()
                for i in range(j, s):
                    member = representative[:, i] == j
                    if member.any():
                        w[:, member] *= masses[i][:, member]
                weights.append(w)
        total = weights[0].copy()
        for w in weights[1:]:
            total += w
        factor = np.divide(product, total, out=np.zeros_like(product), where=total > 0)
        entries = np.empty((product.shape[0], count * s))
        for i in range(s):
            entries[:, positions[i]] = factor * weights[i]
        shares[rows] = scatter.apply(entries)
    return scatter.elements, shares


def _loop_pcr(sources: Sequence[MassBatch], direct: Direct, rule: str) -> tuple[tuple[Element, ...], np.ndarray]:
    """:func:`_pcr_shares` for one row and a few tuples, in plain Python, with the same operations in the same order."""
    element_of: dict[int, Element] = {}
    for source_codes, projected in zip(direct.encoding.codes, direct.projected):
        for c, x in zip(source_codes, projected):
            element_of.setdefault(c, x)
    codes, shares = pcr_loop(direct.encoding.codes, [b.values[0].tolist() for b in sources], rule,
                             lambda c: element_of[c].sort_key)
    return tuple(element_of[c] for c in codes), shares


def pcr_loop(codes: Sequence[Sequence[int]], rows: Sequence[list[float]], rule: str,
             key) -> tuple[list[int], np.ndarray]:
    """The conflict shares of one row: the targets' codes in canonical order (``key``) and their (1, E) sums.

    ``codes`` identify the sources' focal elements (equal codes, equal elements; ∩ is ``&``).
    """
    s = len(codes)
    entries: list[list[tuple[int, float]]] = [[] for _ in range(s)]
    pcr5 = rule == "pcr5"
    for columns in column_tuples([len(c) for c in codes]):
        meet = -1
        for c, k in zip(codes, columns):
            meet &= c[k]
        if meet:
            continue
        masses = [row[k] for row, k in zip(rows, columns)]
        prod = masses[0]
        for m in masses[1:]:
            prod *= m
        targets = [c[k] for c, k in zip(codes, columns)]
        if pcr5:
            weights = []
            for j in range(s):
                w = 1.0 if targets.index(targets[j]) == j else 0.0
                if w:
                    for i in range(j, s):
                        if targets[i] == targets[j]:
                            w *= masses[i]
                weights.append(w)
        else:
            weights = masses
        total = weights[0]
        for w in weights[1:]:
            total += w
        factor = prod / total if total > 0 else 0.0
        for i in range(s):
            entries[i].append((targets[i], factor * weights[i]))
    groups: dict[int, list[float]] = {}
    for slot in entries:
        for target, value in slot:
            group = groups.get(target)
            if group is None:
                groups[target] = [value]
            else:
                group.append(value)
    present = sorted(groups, key=key)
    return present, np.array([[segment_sum(groups[c]) for c in present]])


def _add(model: Model, base: MassBatch, elements: Sequence[Element], values: np.ndarray) -> MassBatch:
    """``base`` without its ∅ column, plus ``values`` over ``elements``, as one batch."""
    keep = [i for i, e in enumerate(base.focal) if e.terms]
    focal = sorted({base.focal[i] for i in keep} | set(elements), key=lambda e: e.sort_key)
    index = {e: k for k, e in enumerate(focal)}
    out = np.zeros((max(len(base), len(values)), len(focal)))
    out[:, [index[base.focal[i]] for i in keep]] += base.values[:, keep]
    out[:, [index[e] for e in elements]] += values
    return trusted_batch(model, tuple(focal), out, canonical=True)


@lru_cache(maxsize=512)
def _pcr_kernel(plan: TuplePlan, rule: str):
    """:func:`pcr_tables` of a plan (cached with it)."""
    conflict = np.flatnonzero(plan.conflicting)
    unique, per_source = _element_codes(plan)
    return pcr_tables(tuple(c[conflict] for c in plan.columns), unique, per_source, rule)


def _array_pcr_tables(direct: Direct, rule: str):
    """:func:`pcr_tables` from the codes of the direct path (no plan)."""
    arrays = [np.array(c, dtype=np.uint64) for c in direct.encoding.codes]
    conflict = np.flatnonzero(tuple_codes(arrays, np.bitwise_and) == 0)
    columns = tuple(c.astype(np.int64, copy=False) for c in np.unravel_index(conflict, direct.sizes))
    index: dict[int, int] = {}
    unique: list[Element] = []
    per_source = []
    for source_codes, projected in zip(direct.encoding.codes, direct.projected):
        row = []
        for c, x in zip(source_codes, projected):
            k = index.get(c)
            if k is None:
                k = index[c] = len(unique)
                unique.append(x)
            row.append(k)
        per_source.append(np.array(row, dtype=np.int64))
    return pcr_tables(columns, unique, per_source, rule)


def pcr_tables(columns: tuple[np.ndarray, ...], unique: list, per_source: list[np.ndarray], rule: str,
               ranked: bool = False):
    """Tables for redistributing the conflicting tuples.

    ``columns`` holds each source's column at every conflicting tuple, ``unique`` the
    distinct focal elements under the fusion model and ``per_source`` the index of each
    source's focal elements into it.  Returns the scatter over (conflicting tuple, slot)
    entries, the columns, the positions of each slot's entries in scatter order, and
    (PCR5) the group representative of every slot.  With ``ranked``, ``unique`` is in
    canonical order already (its items need not be elements).
    """
    s = len(columns)
    size = len(columns[0])
    slot_codes = [per_source[i][columns[i]] for i in range(s)]          # each (Tc,)
    codes = np.concatenate(slot_codes) if s else np.zeros(0, np.int64)
    scatter = Scatter.from_ranks(unique, codes) if ranked else Scatter.from_codes(unique, codes)
    total = size * s
    rank = np.empty(total, dtype=np.int64)
    rank[scatter.order] = np.arange(total)
    positions = tuple(rank[i * size:(i + 1) * size] for i in range(s))
    representative = None
    if rule == "pcr5":
        # rep[t, i]: the first slot of tuple t whose element equals slot i's element.
        representative = np.empty((size, s), dtype=np.int64)
        for i in range(s):
            rep = np.full(size, i, dtype=np.int64)
            for j in range(i - 1, -1, -1):
                rep = np.where(slot_codes[j] == slot_codes[i], j, rep)
            representative[:, i] = rep
    return scatter, columns, positions, representative


def _element_codes(plan: TuplePlan) -> tuple[list[Element], list[np.ndarray]]:
    """The distinct projected focal elements of all sources, and per source the code of each column."""
    index: dict[Element, int] = {}
    per_source = [np.array([index.setdefault(x, len(index)) for x in elements], dtype=np.int64)
                  for elements in plan.projected]
    return list(index), per_source


@register_rule("pcr5", summary="PCR5: conflicting products go back to the elements involved, by mass products",
               associative=False)
def pcr5(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """Proportional conflict redistribution rule no. 5, joint s-source form.

    Each conflicting product Π m_i(X_i) is shared among the distinct elements of the
    tuple in proportion to the product of the masses that the sources committed to each:
    element Y gets Π m_i(X_i) · P_Y / Σ_Z P_Z with P_Y = Π_{i: X_i = Y} m_i(Y).  This is
    the general PCR5 formula of Smarandache & Dezert (Advances and Applications of DSmT,
    vol. 2, ch. 1, 2006), in the focal-element form of Dezert, Dezert & Smarandache
    (JAIF 2021, eq. 14); for two sources it reduces to SPEC A.3.
    """
    return _pcr(sources, model, "pcr5")


@register_rule("pcr6", summary="PCR6: each source's element gets back a share proportional to its mass",
               associative=False)
def pcr6(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """Proportional conflict redistribution rule no. 6 (Martin & Osswald, 2006), joint s-source form.

    Each conflicting product Π m_i(X_i) goes back to every X_i in proportion to m_i(X_i):
    X_i gets Π_j m_j(X_j) · m_i(X_i) / Σ_j m_j(X_j); shares reaching the same element add
    up (Dezert & Smarandache, An introduction to DSmT, 2009, eqs. 16–17).  Equals PCR5
    for two sources.
    """
    return _pcr(sources, model, "pcr6")
