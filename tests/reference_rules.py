"""The slow, literal reference of the combination rules, in exact rational arithmetic.

An element is its set of Venn regions (tests/strategies.py); under the fusion model it keeps the
regions that model allows, and the empty set of regions is ∅.  A source is a list of
(regions under the source model, exact mass) pairs.  Every rule visits every tuple of focal
elements (itertools.product) and adds Fractions, straight from the definitions:

  conjunctive / DSmC   Π m_i(X_i) → X_1 ∩ … ∩ X_s (∅ kept)              SPEC A.3, W (2)
  Dempster             conjunctive, ∅ removed, rescaled by 1 - m(∅)        SPEC A.3
  disjunctive          Π m_i(X_i) → X_1 ∪ … ∪ X_s
  Yager                conjunctive, m(∅) added to total ignorance
  Dubois–Prade         → ∩ if non-empty, else → ∪ (which may be ∅ under dynamic fusion)
  DSmH                 → ∩ if non-empty (S1), else → ∪ if non-empty (S3), else → u(X_1) ∪ … ∪ u(X_s)
                       or total ignorance if that is empty too (S2); u(X) = the union of the
                       hypotheses that appear in X as elicited
  PCR5                 a conflicting product goes to the distinct elements Y of the tuple in
                       proportion to P_Y = Π_{i: X_i = Y} m_i(Y)
  PCR6                 a conflicting product goes to each X_i in proportion to m_i(X_i)
  R-rule               SPEC A.4, normative algorithm combine_r, folded over the sources in order

Every quantity is exact except the R of W (10), a square root: the smaller of R and 1 − R is
taken to 300 significant bits (:func:`root`; 1 − R as (1 − R²)/(1 + R), which keeps those bits
where R is near one) and the other is its complement, so that each pair of the fold conserves
mass exactly.  R² takes the form of W (10) that is exact for the floats as given
(:func:`radicand`).  Nothing here uses the library's own ∩, ∪, ⊆ or rules, so tests can compare
the library with it.  Bel, Pls, BetP and the mass of an element of a result (SPEC A.5) are here
as well.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from itertools import product

from belief import MassFunction
from tests.strategies import FusionCase, ModelCase, minimal_regions

__all__ = ["RefModelError", "RefTotalConflict", "RStep", "add", "ref_sources", "ref_combine", "ref_r_fold",
           "ref_r_pair", "ref_inconsistency", "radicand", "root", "regions_result", "ref_bel", "ref_pls", "ref_betp",
           "ref_mass"]


def popcount(mask: int) -> int:
    return bin(mask).count("1")


def ref_sources(fc: FusionCase) -> list[list[tuple[frozenset, Fraction]]]:
    """Each source as (regions under the source model, mass), entries of one element merged.

    The masses are the floats that the sources hold (entries of one element added by
    ``math.fsum``, as a mass function merges them), taken exactly: the R-rule's paper R is
    the square root of a distance, so two sources that are equal as fractions but differ by
    one rounding in a merged mass have an R of about 1e-8, not 0.
    """
    out = []
    for entries in fc.sources:
        merged: dict[frozenset, list[float]] = {}
        for element, mass in entries:
            merged.setdefault(fc.source.regions(element), []).append(float(mass))
        out.append([(key, Fraction(math.fsum(values))) for key, values in merged.items()])
    return out


def u_regions(source_regions: frozenset, allowed: frozenset) -> frozenset:
    """u(X) under the fusion model: X's minimal regions name the hypotheses that appear in X."""
    mask = 0
    for region in minimal_regions(source_regions):
        mask |= region
    return frozenset(s for s in allowed if s & mask)


def add(table: dict, key: frozenset, value) -> None:
    table[key] = table.get(key, Fraction(0)) + value


def ref_tuples(sources):
    for combo in product(*sources):
        elements = [x for x, _ in combo]
        mass = Fraction(1)
        for _, v in combo:
            mass *= v
        yield elements, [v for _, v in combo], mass


class RefModelError(Exception):
    """The reference's counterpart of ModelError (an element vanishes under the fusion model)."""


class RefTotalConflict(Exception):
    """The reference's counterpart of TotalConflictError."""


def ref_combine(rule: str, sources, allowed: frozenset, r_mode="paper", empty_mode="union",
                steps: list | None = None) -> dict:
    """Reference result of a rule as {regions under the fusion model: Fraction} (``steps``: see :func:`ref_r_pair`)."""
    total = frozenset(allowed)
    fused = [[(x & allowed, v) for x, v in s] for s in sources]
    out: dict[frozenset, Fraction] = {}
    if rule in ("pcr5", "pcr6", "r_rule") and any(not x for s in fused for x, _ in s):
        raise RefModelError
    if rule == "r_rule":
        return ref_r_fold(fused, allowed, r_mode, empty_mode, steps)
    for (elements, masses, p), (originals, _, _) in zip(ref_tuples(fused), ref_tuples(sources)):
        meet = frozenset.intersection(*elements)
        join = frozenset.union(*elements)
        if rule in ("conjunctive", "dsmc", "dempster", "yager"):
            add(out, meet, p)
        elif rule == "disjunctive":
            add(out, join, p)
        elif rule == "dubois_prade":
            add(out, meet if meet else join, p)
        elif rule == "dsmh":
            if meet:
                add(out, meet, p)
            elif join:
                add(out, join, p)
            else:
                u = frozenset().union(*(u_regions(x, allowed) for x in originals))
                add(out, u if u else total, p)
        elif rule in ("pcr5", "pcr6"):
            if meet:
                add(out, meet, p)
                continue
            if not p:
                continue                          # nothing to redistribute (and no weights to divide by)
            weights: dict[frozenset, Fraction] = {}
            if rule == "pcr6":
                for x, v in zip(elements, masses):
                    add(weights, x, v)
                denominator = sum(masses)
                for x, w in weights.items():
                    add(out, x, p * w / denominator)
            else:
                for x in set(elements):
                    weight = Fraction(1)
                    for y, v in zip(elements, masses):
                        if y == x:
                            weight *= v
                    weights[x] = weight
                denominator = sum(weights.values())
                for x, w in weights.items():
                    add(out, x, p * w / denominator)
        else:  # pragma: no cover
            raise AssertionError(rule)
    if rule == "dempster":
        out.pop(frozenset(), None)
        kept = sum(out.values(), Fraction(0))     # 1 - m(∅), when the sources sum to one exactly
        if not kept:
            raise RefTotalConflict
        out = {x: v / kept for x, v in out.items()}
    if rule == "yager":
        conflict = out.pop(frozenset(), Fraction(0))
        add(out, total, conflict)
    return {x: v for x, v in out.items() if v}


# -- the R-weighted rule (SPEC A.4) -----------------------------------------------------------------------
#: Significant bits of the reference's square roots: far beyond double precision, yet small numbers.
ROOT_BITS = 300


def _dyadic(q: Fraction, bits: int = ROOT_BITS) -> Fraction:
    """q ≥ 0 rounded down to ``bits`` significant bits (a small denominator for the folds that follow)."""
    if q <= 0:
        return Fraction(0)
    shift = bits - (q.numerator.bit_length() - q.denominator.bit_length())
    scaled = q * (Fraction(2) ** shift)
    return Fraction(scaled.numerator // scaled.denominator) / Fraction(2) ** shift


def root(q: Fraction) -> Fraction:
    """√q for a rational q ≥ 0, to :data:`ROOT_BITS` significant bits (exact where q is a square)."""
    if q <= 0:
        return Fraction(0)
    p, d = q.numerator, q.denominator
    exact_p, exact_d = math.isqrt(p), math.isqrt(d)
    if exact_p * exact_p == p and exact_d * exact_d == d:
        return Fraction(exact_p, exact_d)
    shift = max(0, ROOT_BITS - (p.bit_length() - d.bit_length()) // 2 + 2)
    return Fraction(math.isqrt(p * 4 ** shift // d), 2 ** shift)


def shafer_projection(x: frozenset) -> frozenset:
    """π0(X): the singleton regions of X (SPEC A.2)."""
    return frozenset(r for r in x if popcount(r) == 1)


def radicand(m1: dict, m2: dict, r_mode: str) -> tuple[Fraction, bool]:
    """R² of W (10) over the focal elements of either source (SPEC A.4), and whether it is 1 − Σ min(m1, m2).

    The printed radicand Σ|Δ|/2 equals 1 − Σ min(m1, m2) for sources that sum to one.  The
    floats of a source sum to one only to their last bits, and the two forms differ by that
    much; R = √· magnifies the difference where R is near 0 in the second form, and 1 − R does
    where R is near 1 in the first.  In paper mode the radicand is therefore Σ|Δ|/2 where the
    sources overlap by ½ or more and 1 − Σ min(m1, m2) elsewhere, each form where it is exact
    to the last bits of the masses (as :func:`belief.r_inconsistency.paper_inconsistency` does).
    """
    keys = list(set(m1) | set(m2))
    delta = [m1.get(k, Fraction(0)) - m2.get(k, Fraction(0)) for k in keys]
    far = False
    if r_mode == "paper":
        overlap = sum((min(m1.get(k, Fraction(0)), m2.get(k, Fraction(0))) for k in keys), Fraction(0))
        far = overlap < Fraction(1, 2)
        value = 1 - overlap if far else sum(abs(d) for d in delta) / 2
    elif r_mode == "euclid":
        value = sum(d * d for d in delta) / 2
    else:
        value = Fraction(0)
        for a, da in zip(keys, delta):
            for b, db in zip(keys, delta):
                union = len(a | b)
                value += da * db * (Fraction(len(a & b), union) if union else 0)
        value /= 2
    return min(max(value, Fraction(0)), Fraction(1)), far


def ref_inconsistency(m1: dict, m2: dict, r_mode: str) -> tuple[Fraction, Fraction]:
    """R of W (10) (:func:`radicand`) and 1 − R.

    R + (1 − R) is one exactly, or a fold's result would not sum to one and the next step's
    R would be off by that: the smaller of the two is rounded (:func:`root`), the other is
    its complement.  Near one, 1 − R is (1 − R²)/(1 + R), which keeps its relative precision
    where the sources barely overlap.
    """
    value, _ = radicand(m1, m2, r_mode)
    if value < Fraction(1, 4):
        r = root(value)
        return r, 1 - r
    rho = _dyadic((1 - value) / (1 + root(value)))
    return 1 - rho, rho


@dataclass
class RStep:
    """One pair of the R-weighted rule's fold: its R (and R², from :func:`radicand`), local conflicts and m0 weights.

    ``conflicts`` holds the local conflict k of every conflicting pair, ``m0_weights`` the m0
    weights of its A, B and A ∪ B (W (12)); ``far`` says that R² is 1 − Σ min(m1, m2).
    """

    r: Fraction
    squared: Fraction
    far: bool
    conflicts: list
    m0_weights: list


def ref_r_pair(m1: dict, m2: dict, allowed: frozenset, r_mode: str, empty_mode: str,
               steps: list | None = None, r: Fraction | None = None) -> dict:
    """combine_r(m1, m2) of SPEC A.4, steps 1-4, on region sets.

    ``steps``, if given, receives the :class:`RStep` of the pair, for tests that need to
    know how sensitive the result is to its R and m0; ``r`` replaces R (and 1 − R) by another
    value, to see that.
    """
    squared, far = radicand(m1, m2, r_mode)
    if r is None:
        r, rho = ref_inconsistency(m1, m2, r_mode)
    else:
        rho = 1 - r
    step = RStep(r, squared, far, [], [])
    m0: dict[frozenset, Fraction] = {}          # Dempster on the Shafer projections, unnormalised
    for (x, v), (y, w) in product(m1.items(), m2.items()):
        c = shafer_projection(x) & shafer_projection(y)
        if c:
            add(m0, c, v * w)
    out: dict[frozenset, Fraction] = {}
    conflicts: dict[frozenset, Fraction] = {}   # k_{X,Y}, W (11)
    pairs: dict[frozenset, tuple] = {}
    for (x, v), (y, w) in product(m1.items(), m2.items()):
        p, z = v * w, x & y
        px, py = shafer_projection(x), shafer_projection(y)
        if not x or not y:
            add(out, frozenset(), p)              # ∅ carried by a running result stays on ∅
        elif not z or (not (x <= y or y <= x) and px and py and not px & py):
            key = frozenset((x, y))
            add(conflicts, key, p)
            pairs[key] = (x, y)
        else:
            add(out, z, p)                        # consensus
    for key, k in conflicts.items():
        a, b = pairs[key]
        union, meet = a | b, a & b
        kept = meet if meet else (union if empty_mode == "union" else frozenset())
        add(out, kept, r * k)                                             # W (14)
        targets = (a, b, union)
        weights = [m0.get(shafer_projection(t), Fraction(0)) if shafer_projection(t) else Fraction(0)
                   for t in targets]
        step.conflicts.append(k)
        step.m0_weights.append(tuple(weights))
        if not sum(weights):
            weights = [m1.get(t, Fraction(0)) + m2.get(t, Fraction(0)) for t in targets]
        if not sum(weights):
            weights = [Fraction(0), Fraction(0), Fraction(1)]
        for t, wt in zip(targets, weights):
            add(out, t, rho * k * wt / sum(weights))                      # W (12), (12'), (13)
    if steps is not None:
        steps.append(step)
    return {x: v for x, v in out.items() if v}


def ref_r_fold(fused, allowed, r_mode, empty_mode, steps: list | None = None,
               overrides: dict | None = None) -> dict:
    """The R-weighted rule folded over the sources in the given order (SPEC A.4).

    ``steps`` as :func:`ref_r_pair`; ``overrides`` maps the number of a pair (0 for the
    first two sources) to the R that replaces its own.
    """
    def as_dict(source):
        d: dict[frozenset, Fraction] = {}
        for x, v in source:
            add(d, x, v)
        return d

    result = as_dict(fused[0])
    for number, source in enumerate(fused[1:]):
        r = None if overrides is None else overrides.get(number)
        result = ref_r_pair(result, as_dict(source), allowed, r_mode, empty_mode, steps, r)
    return result


# -- reading results, and their measures (SPEC A.5) ----------------------------------------------------------
def regions_result(m: MassFunction, case: ModelCase) -> dict:
    """A library mass function as {regions under the case's model: mass}; two elements of one region set fail."""
    out: dict[frozenset, float] = {}
    for e, v in m.items():
        key = case.regions(e)
        assert key not in out, f"two result elements denote the regions {sorted(key)}"
        out[key] = v
    return out


def ref_bel(result: dict, query: frozenset) -> Fraction:
    """Bel(A) = Σ_{∅ ≠ B ⊆ A} m(B) (W (8))."""
    return sum((v for x, v in result.items() if x and x <= query), Fraction(0))


def ref_pls(result: dict, query: frozenset) -> Fraction:
    """Pls(A) = Σ_{B ∩ A ≠ ∅} m(B) (W (9))."""
    return sum((v for x, v in result.items() if x & query), Fraction(0))


def ref_mass(result: dict, query: frozenset) -> Fraction:
    """m(A), 0 where A is not focal (m(∅) for a query empty under the model)."""
    return result.get(query, Fraction(0))


def ref_betp(result: dict, query: frozenset) -> Fraction:
    """BetP(A) = Σ_X m(X) C(X ∩ A)/C(X) over the non-empty X, rescaled by their total mass.

    C counts the allowed regions (the DSm cardinality).  Raises :class:`RefTotalConflict`
    where every mass is on ∅.
    """
    kept = sum((v for x, v in result.items() if x), Fraction(0))
    if not kept:
        raise RefTotalConflict
    return sum((v * Fraction(len(x & query), len(x)) for x, v in result.items() if x), Fraction(0)) / kept
