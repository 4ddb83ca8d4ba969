"""The classic rules: conjunctive, DSmC, Dempster's, disjunctive, Yager's, Dubois–Prade's and DSmH.

Each registers itself in :data:`~belief.rules_registry.RULES` on import.  The associative ones are folded
pairwise (:func:`~belief.rules_tuples.fold`); Dubois–Prade's rule and DSmH are evaluated jointly over all tuples
of focal elements, as their s-source definitions require.  Dempster's rule whose non-empty mass may have
underflowed is combined again with the exponents of the products kept apart (:func:`_wide_dempster`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from belief.batch import MassBatch, trusted_batch
from belief.errors import TotalConflictError
from belief.frame import Element
from belief.model import Model
from belief.plan import tuple_plan
from belief.rules_registry import register_rule
from belief.rules_tuples import (broadcast_values, check_joint_sources, fold, prune, require_normal, target_kernel,
                                 tuple_targets_rule)


@register_rule("conjunctive", summary="unnormalised conjunctive rule (Smets' TBM); conflict stays on ∅",
               associative=True, keeps_conflict=True, aliases=("smets", "tbm", "unnormalized"))
def conjunctive(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = Σ_{X_1∩…∩X_s=A} Π m_i(X_i), with the products of empty intersections on ∅ (W (2))."""
    return fold(sources, model, "meet", "conjunctive")


@register_rule("dsmc", summary="classic DSm rule: conjunctive on D^Θ (no conflict on the free model)",
               associative=True, keeps_conflict=True, aliases=("dsm_classic",))
def dsmc(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """The classic DSm rule W (2): the conjunctive consensus on the hyper-power set.

    On the free model no intersection is empty, so the result carries no conflict.  Under
    a hybrid model (such as the tracking model of SPEC Part D, where it is the ``table``
    rule) the products that land on an empty intersection stay on ∅.
    """
    return fold(sources, model, "meet", "dsmc")


@register_rule("dempster", summary="Dempster's rule: conjunctive, renormalised by 1 - conflict",
               associative=True, aliases=("ds", "dempster_shafer"))
def dempster(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = m∩(A) / Σ_{B≠∅} m∩(B) for A ≠ ∅ (SPEC A.3).

    The denominator is the sum of the non-empty masses rather than 1 - K, so that a
    conflict K close to one still yields masses that sum to one.
    """
    result = _move_empty(fold(sources, model, "meet", "dempster"), None, model, "dempster")
    return result if result is not None else _wide_dempster(sources, model)


#: Dempster's rule normalises by the non-empty mass; below this, products that underflowed may matter,
#: and the combination is made again with exponents kept apart (:func:`_wide_dempster`).
WIDE_SCALE = 2.0 ** -40
#: The exponent of a zero mass in :func:`_wide_dempster`: below any sum of real exponents.
_ZERO_EXPONENT = -(1 << 40)


def _split(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Masses as mantissas in [½, 1) and int64 exponents (zeros get :data:`_ZERO_EXPONENT`)."""
    mantissas, exponents = np.frexp(values)
    exponents = exponents.astype(np.int64)
    exponents[mantissas == 0] = _ZERO_EXPONENT
    return mantissas, exponents


def _wide_dempster(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """Dempster's rule where the non-empty mass is tiny: products kept as mantissa × 2^exponent, never underflowing.

    Each pairwise step multiplies mantissas and adds exponents, drops the products that
    reach ∅, and sums each target's products scaled to the largest of them, so that a sum
    loses only what is below 2^-1074 of itself.  The final rows are scaled to their
    largest mass and normalised.  Total conflict is reported only when every product
    that reaches a non-empty element has a zero factor, that is when K = 1 exactly.
    """
    n, values = broadcast_values(sources)
    parts = [_split(v) for v in values]
    mantissas, exponents = parts[0]
    focal = sources[0].focal
    source_model = sources[0].model
    for b, (m2, e2) in zip(sources[1:], parts[1:]):
        if b.model != model:
            b = b.under(model)
            m2, e2 = _split(b.values if len(b) == n else np.broadcast_to(b.values, (n, len(b.focal))))
        plan = tuple_plan(source_model, model, (tuple(focal), b.focal))
        scatter, (c1, c2) = target_kernel(plan, "meet")
        product = mantissas.take(c1, axis=1) * m2.take(c2, axis=1)        # in [¼, 1): no underflow
        exponent = exponents.take(c1, axis=1) + e2.take(c2, axis=1)
        top = np.maximum.reduceat(exponent, scatter.starts, axis=1)
        runs = np.diff(np.append(scatter.starts, exponent.shape[1]))
        shift = np.maximum(exponent - np.repeat(top, runs, axis=1), -1100)
        sums = np.add.reduceat(np.ldexp(product, shift.astype(np.int32)), scatter.starts, axis=1)
        mantissas, exponents = _split(sums)
        exponents = np.where(mantissas == 0, _ZERO_EXPONENT, exponents + top)
        keep = [i for i, e in enumerate(scatter.elements) if e.terms]
        focal = tuple(scatter.elements[i] for i in keep)
        mantissas, exponents = mantissas[:, keep], exponents[:, keep]
        source_model = model
    top = exponents.max(axis=1, initial=_ZERO_EXPONENT)
    dead = top <= _ZERO_EXPONENT // 2
    if dead.any():
        row = int(np.flatnonzero(dead)[0])
        where = f" (row {row})" if n > 1 else ""
        raise TotalConflictError(f"dempster: total conflict between the sources{where}, m(∅) = 1; "
                                 "Dempster's rule is undefined (try yager, dubois_prade, dsmh or pcr6)")
    scaled = np.ldexp(mantissas, np.maximum(exponents - top[:, None], -1100).astype(np.int32))
    out = scaled / scaled.sum(axis=1)[:, None]
    return prune(trusted_batch(model, focal, out, canonical=True))


@register_rule("disjunctive", summary="disjunctive rule: products go to the union of the focal elements",
               associative=True, keeps_conflict=True, aliases=("union",))
def disjunctive(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = Σ_{X_1∪…∪X_s=A} Π m_i(X_i) (Dubois & Prade 1986; Smets 1993)."""
    return fold(sources, model, "join", "disjunctive")


@register_rule("yager", summary="Yager's rule: the conflict goes to total ignorance",
               associative=False)
def yager(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = m∩(A) for ∅ ≠ A ≠ Θ and m(Θ) = m∩(Θ) + m∩(∅) (Yager 1987)."""
    require_normal(sources, "yager")
    return _move_empty(fold(sources, model, "meet", "yager"), model.total, model, "yager")


@register_rule("dubois_prade", summary="Dubois–Prade: each conflicting product goes to the union of its elements",
               associative=False, keeps_conflict=True, aliases=("dp", "duboisprade"))
def dubois_prade(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = Σ_{∩X_i=A} Π m_i(X_i) + Σ_{∩X_i=∅, ∪X_i=A} Π m_i(X_i), jointly over s sources.

    Under dynamic fusion a product whose union is empty in the fusion model has no
    element to go to; as the formula says, it stays on ∅ (DSmH places it instead).
    """
    require_normal(sources, "dubois_prade")
    check_joint_sources(sources, model, "dubois_prade", "targets")
    return tuple_targets_rule(sources, model, "dubois_prade")


@register_rule("dsmh", summary="hybrid DSm rule (S1 + S2 + S3), static or dynamic",
               associative=False, aliases=("hybrid", "dsm_hybrid"))
def dsmh(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """The hybrid DSm rule, m(A) = φ(A)[S1(A) + S2(A) + S3(A)], jointly over s sources.

    Each tuple's product goes to its intersection if that is non-empty under the fusion
    model (S1); else to the union of its elements (S3); and if every element of the tuple
    is empty under the fusion model, to u(X_1) ∪ … ∪ u(X_s), where u(X) is the union of
    the hypotheses that make up X, or to total ignorance if that is empty too (S2)
    (Smarandache & Dezert, Advances and Applications of DSmT, vol. 1, ch. 4).
    """
    require_normal(sources, "dsmh")
    check_joint_sources(sources, model, "dsmh", "targets")
    return tuple_targets_rule(sources, model, "dsmh")


# -- the conflict of a fold: normalised away (Dempster) or moved to total ignorance (Yager) --------------
def _move_empty(result: MassBatch, to: Element | None, model: Model, rule: str) -> MassBatch:
    """Remove the ∅ column: renormalise (``to=None``, Dempster) or add it to ``to`` (Yager)."""
    focal = result.focal
    if result._canonical:                      # ∅ sorts first
        if not focal or focal[0].terms:
            return result
        k = 0
    else:
        if all(e.terms for e in focal):
            return result
        k = next(i for i, e in enumerate(focal) if not e.terms)
    values = result.values
    if to is None:
        kept = values[:, 1:] if k == 0 else np.delete(values, k, axis=1)
        scale = kept.sum(axis=1)
        if not (scale > WIDE_SCALE).all():
            return None                         # the non-empty mass may have underflowed: see _wide_dempster
        return trusted_batch(model, focal[:k] + focal[k + 1:], kept / scale[:, None], canonical=result._canonical)
    new_focal = list(focal[:k] + focal[k + 1:])
    new_values = np.delete(values, k, axis=1)
    if to in new_focal:
        new_values[:, new_focal.index(to)] += values[:, k]
    else:
        new_focal.append(to)
        new_values = np.hstack([new_values, values[:, k:k + 1]])
    order = sorted(range(len(new_focal)), key=lambda i: new_focal[i].sort_key)
    return trusted_batch(model, tuple(new_focal[i] for i in order), new_values[:, order], canonical=True)
