"""One fold of the R-weighted rule (SPEC A.4) with a Bayesian cue, by element class.

:class:`RState` is a running result by element class, :class:`Fold` what one fold with a cue shares out;
:func:`pair_sums` and :func:`low_pairs` give the shares of the pairs of targets, which do not factorise, and
:func:`wide_pair_shares` those of the rows whose m0 weights lie below the normal doubles.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from belief.bayesian_blocks import TINY, share_of
from belief.rules_classic import _split

#: Pair weights above this (a normal number) have a finite, exact 1 / (x_i + x_l) whose products
#: with masses (≤ 1), and sums of fewer than 10¹⁷ of those, stay finite.
RECIPROCAL_FLOOR = 2.0 ** -960
#: The smallest normal double: an m0 weight below it has lost bits or underflowed (:meth:`Fold._widen`).
NORMAL_FLOOR = float(np.finfo(np.float64).tiny)


def all_above(values: np.ndarray, floor: float) -> bool:
    """Whether every value exceeds ``floor`` (NaN does not): one pass, no mask."""
    return not values.size or bool(values.min() > floor)


@dataclass
class RState:
    """A running R-weighted result by element class: (N,) per class, (|O|, N) per free hypothesis."""

    s: np.ndarray                          # m(θ_i)
    u: np.ndarray                          # m(θ_i ∪ F)
    f: np.ndarray                          # m(F)
    e: np.ndarray                          # m(∅)
    q: np.ndarray                          # Σ m(θ_S), |S| ≥ 2
    qj: np.ndarray                         # Σ_{S∋j} m(θ_S), per j
    v: np.ndarray                          # Σ m(θ_S ∪ F), |S| ≥ 2
    vj: np.ndarray                         # Σ_{S∋j} m(θ_S ∪ F), per j
    q_squares: np.ndarray | None = None    # Σ_S m(θ_S)², known while every θ_S is a pair (after one fold)
    fresh: bool = False                    # a Bayesian source: every class but θ_i and F is empty
    no_v: bool = True                      # no θ_S ∪ F yet
    u_total: np.ndarray | None = None      # Σ_i m(θ_i ∪ F), when known

    @classmethod
    def bayesian(cls, s: np.ndarray, f: np.ndarray) -> "RState":
        # Read-only zeros without memory: a fresh state's other classes are never read per element.
        zero = np.broadcast_to(0.0, (s.shape[1],))
        zeros = np.broadcast_to(0.0, s.shape)
        return cls(s, zeros, f, zero, zero, zeros, zero, zeros, zero, fresh=True)


class Fold:
    """The quantities that one fold of the R-weighted rule with a Bayesian cue shares out (SPEC A.4).

    With the running result m (element classes of :class:`RState`) and the cue p (p_i on
    the free hypotheses, p_F on the exclusive one F), m0 (Dempster's rule on the Shafer
    projections) only has singleton keys: m0(θ_i) ∝ w_i = (s_i + u_i) p_i and
    m0(F) ∝ w_F = (f + U + V) p_F.  The conflicting pairs (W (11)), where R·k goes (W (14))
    and how (1 − R)·k is split (W (12), (12′), (13)):

    ===================  ===================  ===================  ==================================
    pair                 k                    R·k                  (1 − R)·k
    ===================  ===================  ===================  ==================================
    θ_i, θ_l             s_i p_l + s_l p_i    θ_i ∩ θ_l            θ_i : θ_l as w_i : w_l
    θ_i, F               s_i p_F + f p_i      θ_i ∪ F, or ∅        θ_i : F as w_i : w_F
    θ_S, F               m(θ_S) p_F           θ_S ∪ F, or ∅        F and θ_S ∪ F, ½ each
    θ_i ∪ F, θ_l         u_i p_l              θ_i ∩ θ_l            all to θ_l
    θ_S ∪ F, θ_l         m(θ_S ∪ F) p_l       θ_{S∪{l}}            θ_S ∪ F : θ_l as w_F : w_l
    ===================  ===================  ===================  ==================================

    Every other product is consensus: θ_S with θ_l goes to θ_{S∪{l}}, θ_i ∪ F with θ_i to θ_i,
    every element holding F with F to F, and ∅ stays on ∅.  When m0 gives a pair no
    weight, SPEC A.4 weighs it by the sources' own support: exact sums for the first, second
    and fourth pair; the third and fifth depend on each m(θ_S), and their rows are
    ``flagged`` for the general path.  Terms of classes that are still empty (the first
    fold starts from a Bayesian source) are skipped.

    Only ratios of the weights of one pair matter (SPEC A.4), so the rows with a weight
    below the normal doubles, whose product w has lost bits or underflowed to 0, are
    listed in :attr:`wide` and their weights kept as mantissa × 2^exponent
    (:meth:`_widen`); each pair's weights are scaled to the larger before their ratio is
    taken (:func:`scaled`), and SPEC A.4's fallback applies only where a weight has a zero
    factor.
    """

    def __init__(self, state: RState, p: np.ndarray, p_f: np.ndarray, r_rho: tuple[np.ndarray, np.ndarray],
                 union: bool) -> None:
        s, f = state.s, state.f
        self.r, self.rho = r_rho                               # R and 1 − R (of W (10), from bayesian_r)
        self.state, self.p, self.p_f, self.union = state, p, p_f, union
        self._totals: dict | None = None
        self.t = np.add.reduce(p, 0)
        self.s_total = np.add.reduce(s, 0)
        fresh = state.fresh
        if fresh:
            self.w = s * p
            self.w_f = f * p_f
        else:
            self.u_total = state.u_total if state.u_total is not None else np.add.reduce(state.u, 0)
            self.w = s + state.u
            self.w *= p
            self.w_f = (f + self.u_total + state.v) * p_f
        self.k_f = s * p_f                                     # k of θ_i against F
        self.k_f += f * p
        self.wide = np.zeros(0, dtype=np.intp)                 # rows whose weights need exponents
        if not (all_above(self.w, NORMAL_FLOOR) and all_above(self.w_f, NORMAL_FLOOR)):
            self._widen(p, p_f)
        wide = self.wide
        both = self.w + self.w_f
        if wide.size:
            # The pairs θ_i, F of those rows: both weights scaled to the larger of the two.
            m, e, m_f, e_f = self._exponents
            top = np.maximum(e, e_f)
            x, x_f = scaled(m, e, top), scaled(m_f, e_f, top)
            both[:, wide] = x + x_f
        floor = not wide.size and all_above(both, RECIPROCAL_FLOOR)
        self.complete = complete = floor or bool(both.all())   # m0 weighs every pair θ_i, F
        if not complete:
            lost = ~(both > 0)
            both[lost] = 1.0                                # w = w_F = 0 there: their shares are 0
            floor = not wide.size and all_above(both, RECIPROCAL_FLOOR)
        self._both, self._inverse = both, floor
        if floor:
            inverse = np.divide(1.0, both, out=both)        # 1 / (w_i + w_F), one division for both shares
            self.to_target = self.w * inverse
        else:
            # Weights of 1e-300 and below (masses whose products underflow): the shares, at most
            # 1, are formed directly, where 1 / (w_i + w_F) would overflow.
            self.to_target = self.w / both
        if wide.size:
            self.to_target[:, wide] = x / both[:, wide]
            self._wide_to_f = x_f / both[:, wide]
        if not state.no_v:
            # θ_S ∪ F against θ_l: θ_l gets p_l w_l/(w_F + w_l), θ_S ∪ F keeps Σ_l p_l w_F/(w_F + w_l).
            self.to_l = p * self.to_target
            self.stays = _dot(p, self.to_f)
        self.to_union = None
        self.fallback = None
        if not complete:
            fallback = lost & (self.k_f > 0)
            if fallback.any():
                # θ_i against F without m0 weight: split by support σ_i : f + p_F : u_i (SPEC A.4).
                hyp, rows = np.nonzero(fallback)
                sigma = s[hyp, rows] + p[hyp, rows]
                own_f = f[rows] + p_f[rows]
                u = np.zeros(rows.size) if fresh else state.u[hyp, rows]
                total = sigma + own_f + u
                self.to_target[hyp, rows] = sigma / total
                # What F gets there, the ratio first (≤ 1): k_iF · (f + p_F) underflows for masses
                # near 1e-150 while the share itself is representable, and F's m0 weight in the
                # next fold may be that share alone.
                self.fallback = (rows, self.k_f[hyp, rows] * (own_f / total))
                self.to_union = np.zeros(s.shape)
                self.to_union[hyp, rows] = u / total
        self.flagged = np.zeros(s.shape[1], dtype=bool)
        self.pair_rows = np.zeros(0, dtype=np.int64)
        self.w_floor = False                                    # every w_i above the reciprocal floor
        if not fresh:
            f_weighed = self.w_f > 0
            if wide.size:
                f_weighed[wide] = self._exponents[2] > 0
            self.half = 0.5 * f_weighed
            self.flagged = (state.q > 0) & (p_f > 0) & ~f_weighed
            if not state.no_v and not complete:
                self.flagged |= (state.v > 0) & (lost & (p > 0)).any(axis=0)
            least = self.w.min() if self.w.size else 1.0
            self.w_floor = bool(least > RECIPROCAL_FLOOR)
            if least > 0:
                self.zero_w = None                              # m0 weighs every target
                self.some_zero_w = np.zeros(s.shape[1], dtype=bool)
            else:
                self.zero_w = p > 0
                self.zero_w &= ~(self.w > 0)
                if wide.size:
                    self.zero_w[:, wide] &= ~(self._exponents[0] > 0)
                self.some_zero_w = self.zero_w.any(axis=0)
                self.pair_rows = np.flatnonzero(self.some_zero_w & (self.u_total > 0))

    def _widen(self, p: np.ndarray, p_f: np.ndarray) -> None:
        """List in :attr:`wide` the rows with an m0 weight (W (12)) below the normal doubles; keep theirs exactly.

        Such a weight w_i = (s_i + u_i) p_i or w_F = (f + U + V) p_F, both factors positive, has
        lost bits or underflowed to 0 as a double; as the mantissa × 2^exponent of its factors'
        product (``_exponents``: mantissas and exponents of w_i, (|O|, R), and of w_F, (R,)) it
        keeps every bit, and only a zero factor makes it 0.
        """
        state = self.state
        low = self.w < NORMAL_FLOOR
        low &= p > 0
        low_f = (self.w_f < NORMAL_FLOOR) & (p_f > 0)
        rows = np.flatnonzero(low.any(axis=0) | low_f)
        if not rows.size:
            return
        a, a_f = state.s[:, rows], state.f[rows]
        if not state.fresh:
            a = a + state.u[:, rows]
            a_f = a_f + self.u_total[rows] + state.v[rows]
        keep = (low[:, rows] & (a > 0)).any(axis=0) | (low_f[rows] & (a_f > 0))
        if not keep.all():
            rows, a, a_f = rows[keep], a[:, keep], a_f[keep]
        self.wide = rows
        self._exponents = (*_product_split(a, p[:, rows]), *_product_split(a_f, p_f[rows]))

    @cached_property
    def to_f(self) -> np.ndarray:
        """w_F / (w_i + w_F): F's part of the pairs θ_i, F (formed only where a fold needs it whole)."""
        out = self.w_f * self._both if self._inverse else self.w_f / self._both
        if self.wide.size:
            out[:, self.wide] = self._wide_to_f
        return out

    @property
    def except_p(self) -> np.ndarray:
        """Σ_{l≠i} p_l: a float sum of non-negative terms is at least each of them, so t − p ≥ 0."""
        return self.t - self.p

    @property
    def except_u(self) -> np.ndarray:
        """Σ_{l≠i} u_l (≥ 0, as t − p)."""
        return self.u_total - self.state.u

    @property
    def sigma(self) -> np.ndarray:
        """Support m(θ_i) + p(θ_i), the weight of SPEC A.4's fallback."""
        return self.state.s + self.p

    def totals(self, names: tuple[str, ...] = ("s", "f", "u", "q", "v", "e")) -> dict[str, np.ndarray]:
        """The totals after the fold, O(|O|) per row, cached.

        Keys: ``s`` Σ_i m′(θ_i), ``f`` m′(F), ``u`` Σ_i m′(θ_i ∪ F), ``q`` Σ_S m′(θ_S),
        ``v`` Σ_S m′(θ_S ∪ F), ``e`` m′(∅).
        """
        if self._totals is None:
            self._totals = {}
        missing = tuple(k for k in names if k not in self._totals)
        if missing:
            self._totals.update(self._compute_totals(missing))
        return self._totals

    def _unions_to_targets(self) -> np.ndarray:
        """p_i Σ_{l≠i} u_l where m0 weighs θ_i: the pairs θ_l ∪ F / θ_i give θ_i all of (1 − R)·k."""
        out = self.p * self.except_u
        if self.zero_w is not None:
            out[self.zero_w] = 0.0
        return out

    def _f_share(self) -> np.ndarray:
        """Σ_i k_iF w_F / (w_i + w_F): F's part of the conflicts θ_i / F (with SPEC A.4's fallback)."""
        if self._inverse and "to_f" not in self.__dict__:
            out = _dot(self.k_f, self._both)                # Σ_i k_iF / (w_i + w_F), then times w_F
            out *= self.w_f
        else:
            out = _dot(self.k_f, self.to_f)
        if self.fallback is not None:
            np.add.at(out, *self.fallback)
        return out

    def _compute_totals(self, names: tuple[str, ...]) -> dict[str, np.ndarray]:
        st, rho, r, k_f = self.state, self.rho, self.r, self.k_f
        fresh = st.fresh
        out = {}
        # Σ_i s_i p_i and Σ_i u_i p_i: their sum is Σ_i w_i, the consensus on the singletons.
        sp = self.w.sum(axis=0) if fresh else _dot(st.s, self.p)
        up = None if fresh else _dot(st.u, self.p)
        # The conflicts of θ_i and of θ_i ∪ F with θ_l,
        # Σ_{i≠l} (s_i + u_i) p_l = Σ_{i<l} k_il + Σ_{i≠l} u_i p_l:
        # R·k goes to θ_i ∩ θ_l and (1 − R)·k to the singletons, whatever R.  Not (S + U) t − Σ_i w_i
        # alone (cross_sum): where one target holds nearly all of both masses that cancels, and its
        # error, roundings of (S + U) t, reaches masses far smaller (m′(F) gets a share of q p_F).
        weighed_all = fresh or self.zero_w is None
        if "q" in names or ("s" in names and weighed_all):
            if fresh:
                pairs = cross_sum((st.s,), self.p, self.s_total, self.t, sp)
            else:
                pairs = cross_sum((st.s, st.u), self.p, self.s_total + self.u_total, self.t, sp + up)
        if "s" in names:
            if weighed_all:
                to_singles = pairs + _dot(k_f, self.to_target)
            else:
                # θ_i ∪ F against θ_l gives θ_l all of (1 − R)·k only where m0 weighs θ_l, and the
                # rest goes by SPEC A.4's fallback (pair_rows): the other p_l are left out of the
                # sum, as subtracting their terms would cancel as well.
                to_singles = cross_sum((st.s,), self.p, self.s_total, self.t, sp)
                to_singles += cross_terms(st.u, np.where(self.zero_w, 0.0, self.p))
                to_singles += _dot(k_f, self.to_target)
            if not fresh:
                if self.pair_rows.size:
                    to_singles[self.pair_rows] += self._target_fallback(self.pair_rows).sum(axis=0)
                if not st.no_v:
                    to_singles += st.v * self.to_l.sum(axis=0)
            out["s"] = (sp if fresh else sp + up) + rho * to_singles
        q_p_f = None if fresh else st.q * self.p_f
        if "f" in names:
            to_f = self._f_share()
            if not fresh:
                to_f += self.half * q_p_f
            out["f"] = self.w_f + rho * to_f
        if "u" in names:
            to_unions = np.zeros(r.shape) if self.to_union is None else _dot(k_f, self.to_union)
            if not fresh and self.pair_rows.size:
                to_unions[self.pair_rows] += self._union_fallback(self.pair_rows).sum(axis=0)
            out["u"] = (r * k_f.sum(axis=0) if self.union else 0.0) + rho * to_unions
        if "q" in names:
            q_new = r * pairs
            if not fresh:
                q_new += st.q * self.t
                if not st.no_v:
                    q_new += r * st.v * self.t
            out["q"] = q_new
        if "v" in names:
            v_new = np.zeros(r.shape)
            if not fresh:
                v_new += ((r if self.union else 0.0) + rho * self.half) * q_p_f
                if not st.no_v:
                    v_new += rho * st.v * self.stays
            out["v"] = v_new
        if "e" in names:
            e_new = np.zeros(r.shape) if self.union else r * k_f.sum(axis=0)
            if not fresh:
                e_new += st.e * (self.t + self.p_f) + (0.0 if self.union else r * q_p_f)
            out["e"] = e_new
        return out

    def full(self, positions: np.ndarray | None = None) -> RState:
        """The state after the fold, every free hypothesis: O(|O|²) per row.

        With ``positions`` (the fold before a last one that is read for one target per row)
        Σ_{S∋j} m′(θ_S) and Σ_{S∋j} m′(θ_S ∪ F) are kept for j = positions[n] only, shape (B,).
        """
        st, p, k_f, rho, r = self.state, self.p, self.k_f, self.rho, self.r
        s = st.s
        to_singles = _pair_shares(s, p, self.w, (self.wide, *self._exponents[:2]) if self.wide.size else None)
        to_singles += k_f * self.to_target
        to_unions = None if self.to_union is None else k_f * self.to_union
        if positions is None:
            def pick(a):
                return a
            sj, pj, t, s_total = s, p, self.t, self.s_total
        else:
            flat = positions * s.shape[1] + np.arange(s.shape[1])

            def pick(a):
                return a.reshape(-1).take(flat)
            sj, pj = pick(s), pick(p)
            t, s_total = self.t, self.s_total
        qj = s_total - sj                                               # ≥ 0, as t − p
        qj *= pj
        qj += sj * (t - pj)
        qj *= r
        vj = np.zeros(qj.shape)
        if not st.fresh:
            to_singles += self._unions_to_targets()
            if self.pair_rows.size:
                rows = self.pair_rows
                to_singles[:, rows] += self._target_fallback(rows)
                if to_unions is None:
                    to_unions = np.zeros_like(s)
                to_unions[:, rows] += self._union_fallback(rows)
            qj_before, uj = pick(st.qj), pick(st.u)
            qj += (qj_before * t + np.maximum(st.q - qj_before, 0.0) * pj
                   + r * (uj * (t - pj) + pj * (self.u_total - uj)))
            vj += ((r if self.union else 0.0) + rho * self.half) * self.p_f * qj_before
            if not st.no_v:
                to_singles += st.v * self.to_l
                vj_before = pick(st.vj)
                qj += r * (vj_before * t + np.maximum(st.v - vj_before, 0.0) * pj)
                vj += rho * self.stays * vj_before
        if to_unions is not None:
            u = rho * to_unions
            if self.union:
                u += r * k_f
        else:
            u = r * k_f if self.union else np.zeros_like(s)
        totals = self.totals(("f", "e", "q", "v"))
        to_singles *= rho
        to_singles += self.w
        return RState(to_singles, u, totals["f"], totals["e"], totals["q"], qj, totals["v"], vj,
                       fresh=False, no_v=st.fresh, u_total=np.add.reduce(u, 0))

    def selected(self, j: np.ndarray) -> dict[str, np.ndarray]:
        """m′(θ_J), m′(θ_J ∪ F), Σ_{S∋J} m′(θ_S), Σ_{S∋J} m′(θ_S ∪ F) for one J = j[n] per row.

        O(|O|) per row: the pairs of θ_J with the other targets only.
        """
        st, p, rho, r = self.state, self.p, self.rho, self.r
        s = st.s
        o, n = s.shape
        flat = j * n + np.arange(n)

        def pick(a):
            return a.reshape(-1).take(flat)

        s_j, p_j, w_j = pick(s), pick(p), pick(self.w)
        # θ_J against every other θ_l: k_Jl = s_J p_l + p_J s_l split by m0, w_J : w_l, that is
        # w_J (s_J Σ_l p_l h_l + p_J Σ_l s_l h_l) with h_l = 1 / (w_J + w_l), l ≠ J; by support
        # where m0 gives neither any weight.
        both = w_j + self.w
        if self.w_floor or all_above(both, RECIPROCAL_FLOOR):    # w_J + w_l ≥ w_l
            h = np.divide(1.0, both, out=both)
            h.reshape(-1)[flat] = 0.0
            to_single = w_j * (s_j * _dot(p, h) + p_j * _dot(s, h))
        else:
            to_single = _own_pair_shares(s_j, p_j, w_j, both, s, p, j)
        plain = w_j > 0
        wide = self.wide
        if wide.size:
            # Those rows' pairs θ_J, θ_l again, each pair's weights scaled to the larger.
            m, e = self._exponents[:2]
            own, cols = j[wide], np.arange(wide.size)
            m_j, e_j = m[own, cols], e[own, cols]
            top = np.maximum(e, e_j)
            x_j = scaled(m_j, e_j, top)
            to_single[wide] = _own_pair_shares(s_j[wide], p_j[wide], x_j, x_j + scaled(m, e, top),
                                               s[:, wide], p[:, wide], own)
            plain[wide] = m_j > 0
        k_f = pick(self.k_f)
        to_single += k_f * pick(self.to_target)
        to_union = np.zeros(n) if self.to_union is None else k_f * pick(self.to_union)
        except_p = self.t - p_j
        qj = self.s_total - s_j
        qj *= p_j
        qj += s_j * except_p
        qj *= r
        vj = np.zeros(n)
        if not st.fresh:
            u = st.u
            u_j = pick(u)
            except_u = self.u_total - u_j
            to_single += p_j * except_u * plain
            bare = ~plain & (p_j > 0) & (except_u > 0)
            if bare.any():
                # θ_l ∪ F against θ_J without m0 weight on θ_J: θ_J gets σ_J / (u_l + σ_J).
                b = np.flatnonzero(bare)
                g_b = s_j[b] + p_j[b]
                ratio = share_of(np.broadcast_to(g_b, (o, b.size)), u[:, b] + g_b)
                ratio[j[b], np.arange(b.size)] = 0.0
                to_single[b] += p_j[b] * (u[:, b] * ratio).sum(axis=0)
            lonely = u_j > 0
            lonely &= self.some_zero_w
            if lonely.any():
                # θ_J ∪ F against θ_l without m0 weight on θ_l: θ_J ∪ F keeps u_J / (u_J + σ_l).
                b = np.flatnonzero(lonely)
                terms = np.where(self.zero_w[:, b], share_of(p[:, b], u_j[b] + s[:, b] + p[:, b]), 0.0)
                terms[j[b], np.arange(b.size)] = 0.0
                to_union[b] += u_j[b] * u_j[b] * terms.sum(axis=0)
            qj_j = st.qj if st.qj.ndim == 1 else pick(st.qj)        # kept for J only by the fold before
            qj += qj_j * self.t + np.maximum(st.q - qj_j, 0.0) * p_j + r * (u_j * except_p + p_j * except_u)
            vj += ((r if self.union else 0.0) + rho * self.half) * self.p_f * qj_j
            if not st.no_v:
                vj_j = st.vj if st.vj.ndim == 1 else pick(st.vj)
                to_single += st.v * pick(self.to_l)
                qj += r * (vj_j * self.t + np.maximum(st.v - vj_j, 0.0) * p_j)
                vj += rho * self.stays * vj_j
        u_new = rho * to_union
        if self.union:
            u_new += r * k_f
        to_single *= rho
        to_single += w_j
        return {"s": to_single, "u": u_new, "qj": qj, "vj": vj}

    def _union_pairs(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """D_ij = σ_i + u_j and the mask of the pairs it counts (targets i without m0 weight, j ≠ i); (|O|, |O|, R)."""
        u, sigma, zero_w = self.state.u[:, rows], self.sigma[:, rows], self.zero_w[:, rows]
        denominator = sigma[:, None] + u[None]
        counted = np.broadcast_to(zero_w[:, None], denominator.shape).copy()
        diagonal = np.arange(u.shape[0])
        counted[diagonal, diagonal] = False
        return denominator, counted

    def _target_fallback(self, rows: np.ndarray) -> np.ndarray:
        """θ_i's share of the pairs θ_j ∪ F / θ_i without m0 weight: p_i Σ_j u_j σ_i / (u_j + σ_i).

        The ratio σ_i / (u_j + σ_i) ≤ 1 is formed first, so tiny supports cannot overflow it.
        """
        denominator, counted = self._union_pairs(rows)
        shares = share_of(np.broadcast_to(self.sigma[:, rows][:, None], denominator.shape), denominator)
        shares *= counted
        return self.p[:, rows] * np.einsum("ijn,jn->in", shares, self.state.u[:, rows])

    def _union_fallback(self, rows: np.ndarray) -> np.ndarray:
        """θ_j ∪ F's share of the same pairs: u_j Σ_i p_i u_j / (u_j + σ_i), the ratio formed first."""
        denominator, counted = self._union_pairs(rows)
        u = self.state.u[:, rows]
        shares = share_of(np.broadcast_to(u[None], denominator.shape), denominator)
        shares *= counted
        return u * np.einsum("ijn,in->jn", shares, self.p[:, rows])


def _product_split(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """a·b as mantissas in [¼, 1) (0 where a factor is 0) and int64 exponents: no bit lost to underflow."""
    m_a, e_a = _split(a)
    m_b, e_b = _split(b)
    m_a *= m_b
    e_a += e_b
    return m_a, e_a


def scaled(mantissas: np.ndarray, exponents: np.ndarray, top: np.ndarray) -> np.ndarray:
    """mantissa × 2^(exponent − top): a pair's weights over a common power of two (``top``, the larger).

    The larger becomes at least ¼; a weight 2^-1100 or more below it, whose share of the
    pair is below every double's rounding, becomes 0 (as does a zero weight, whose
    exponent :func:`~belief.rules_classic._split` sets far below any real one).
    """
    return np.ldexp(mantissas, np.maximum(exponents - top, -1100).astype(np.int32))


def wide_pair_shares(s: np.ndarray, p: np.ndarray, mantissas: np.ndarray, exponents: np.ndarray) -> np.ndarray:
    """:func:`_pair_shares` of weights given as mantissa × 2^exponent (:meth:`Fold._widen`); shape (|O|, R).

    Σ_{l≠i} k_il w_i / (w_i + w_l) (W (12), (12′)), each pair's two weights scaled to the
    larger (:func:`scaled`) before the ratio, so that weights below the normal doubles keep
    their ratio; a pair whose weights are both exactly 0 is split by support σ = s + p
    (SPEC A.4).  The pairs (i, i + d) of one offset d are formed together.
    """
    o, n = s.shape
    out = np.zeros((o, n))
    for d in range(1, o):
        m = o - d
        top = np.maximum(exponents[:m], exponents[d:])
        x_a, x_b = scaled(mantissas[:m], exponents[:m], top), scaled(mantissas[d:], exponents[d:], top)
        k = s[:m] * p[d:]
        k += s[d:] * p[:m]
        total = x_a + x_b
        none = ~(total > 0)
        if none.any():
            sigma_a, sigma_b = s[:m] + p[:m], s[d:] + p[d:]
            x_a, x_b = np.where(none, sigma_a, x_a), np.where(none, sigma_b, x_b)
            total = np.maximum(x_a + x_b, TINY)             # 0 / 0 where k = 0 too
        out[:m] += k * (x_a / total)                        # the ratio first: σ may be subnormal
        out[d:] += k * (x_b / total)
    return out


def _own_pair_shares(s_j: np.ndarray, p_j: np.ndarray, x_j: np.ndarray, both: np.ndarray, s: np.ndarray,
                     p: np.ndarray, own: np.ndarray) -> np.ndarray:
    """Σ_{l≠J} k_Jl x_J / (x_J + x_l), k_Jl = s_J p_l + p_J s_l, for J = own[n] (W (12), (12′)); shape (B,).

    One J per row; ``both`` holds x_J + x_l, (|O|, B).  Where both weights are exactly 0 the pair is split by
    support σ_J : σ_l, σ = s + p (SPEC A.4).
    """
    k = s_j * p
    k += p_j * s
    lost = ~(both > 0) & (k > 0)
    share = share_of(np.broadcast_to(x_j, both.shape), both)
    if lost.any():
        hyp, cols = np.nonzero(lost)
        g_b = s_j[cols] + p_j[cols]
        share[hyp, cols] = g_b / (g_b + s[hyp, cols] + p[hyp, cols])
    share[own, np.arange(own.size)] = 0.0              # no pair of θ_J with itself
    return _dot(k, share)


def cross_sum(parts: tuple[np.ndarray, ...], b: np.ndarray, a_total: np.ndarray, b_total: np.ndarray,
              ab: np.ndarray) -> np.ndarray:
    """Σ_{i≠l} a_i b_l over the hypotheses, a = Σ parts, to a few roundings of itself; shape (B,).

    A·B − Σ_i a_i b_i costs nothing more once the sums are known, but its error is a few
    roundings of A·B, not of the result: where one hypothesis holds nearly all of both a and
    b the result is far smaller (a = b = (1, 10⁻⁸) gives 2·10⁻⁸ and kept half its digits).
    The rows where the difference is below A·B / 2 are summed term by term instead
    (:func:`cross_terms`); elsewhere it magnifies its operands' roundings at most twice.

    Parameters
    ----------
    parts : tuple of numpy.ndarray
        Non-negative (K, B) arrays whose sum is a (m(θ_i) and m(θ_i ∪ F), say), added only
        for the rows summed term by term.
    b : numpy.ndarray
        Non-negative (K, B).
    a_total, b_total, ab : numpy.ndarray
        (B,): A = Σ_i a_i, B = Σ_i b_i and Σ_i a_i b_i, each a sum of non-negative terms.

    Returns
    -------
    numpy.ndarray
        (B,).  A and B err by at most K − 1 roundings and Σ a b by K, so A·B − Σ a b errs by
        at most about 3K roundings of A·B, which is then at most twice the result: 6K
        roundings of the result at most, and 2K where summed term by term.
    """
    product = a_total * b_total
    out = product - ab
    doubtful = np.flatnonzero(~(2.0 * out > product))      # with the rows where it is 0, or rounded below
    if doubtful.size:
        if 4 * doubtful.size > out.size:
            a = parts[0] if len(parts) == 1 else sum(parts[1:], parts[0])
            return cross_terms(a, b)
        a = sum((x[:, doubtful] for x in parts[1:]), parts[0][:, doubtful])
        out[doubtful] = cross_terms(a, b[:, doubtful])
    return out


def cross_terms(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Σ_{i≠l} a_i b_l over the hypotheses of (K, B) arrays, as a sum of non-negative terms; shape (B,).

    Written as Σ_{l<i} (a_i b_l + a_l b_i) = Σ_i (a_i B_{<i} + b_i A_{<i}) with the prefix sums
    A_{<i} = Σ_{l<i} a_l: O(K) per row, and every operation adds or multiplies non-negative
    numbers, so the result errs by at most 2K roundings of itself.
    """
    k, n = a.shape
    if k < 2:
        return np.zeros(n)
    # The prefix sums one hypothesis at a time: np.cumsum along the short first axis runs
    # its inner loop down the hypotheses, several times slower than K − 2 additions of rows.
    before_a, before_b = np.empty((k - 1, n)), np.empty((k - 1, n))
    before_a[0], before_b[0] = a[0], b[0]
    for i in range(1, k - 1):
        np.add(before_a[i - 1], a[i], out=before_a[i])
        np.add(before_b[i - 1], b[i], out=before_b[i])
    out = _dot(a[1:], before_b)
    out += _dot(b[1:], before_a)
    return out


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Σ_i a_i b_i over the hypotheses of (K, B) arrays (one pass, no BLAS)."""
    if a.ndim == 2 and a.shape == b.shape:
        return np.einsum("ij,ij->j", a, b)
    return np.add.reduce(a * b, 0)


def _pair_shares(s: np.ndarray, p: np.ndarray, w: np.ndarray,
                 wide: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Σ_{l≠i} k_il m0(θ_i) / (m0(θ_i) + m0(θ_l)) for every i, k_il = s_i p_l + s_l p_i (support fallback).

    The sum does not factorise: one (|O|, |O|) matrix per row, built by :func:`pair_sums`
    and multiplied by w_i once; the pairs whose weights sum below the floor are then
    corrected by :func:`low_pairs`, where a pair without m0 weight is split by support
    σ_i : σ_l, σ = s + p (SPEC A.4).  Shape (|O|, B).

    ``wide``: the rows of :meth:`Fold._widen` with their weights' mantissas and exponents,
    whose shares :func:`wide_pair_shares` gives instead.
    """
    out = pair_sums(w, s, p, np.zeros(s.shape))
    out *= w
    if wide is None:
        return low_pairs(w, s, p, out)
    rows, mantissas, exponents = wide
    # low_pairs costs most where weights underflow, mostly in the wide rows, which are redone anyway.
    narrow = np.ones(s.shape[1], dtype=bool)
    narrow[rows] = False
    if narrow.any():
        cols = np.flatnonzero(narrow)
        out[:, cols] = low_pairs(w[:, cols], s[:, cols], p[:, cols], out[:, cols])
    out[:, rows] = wide_pair_shares(s[:, rows], p[:, rows], mantissas, exponents)
    return out


def pair_sums(weights: np.ndarray, s: np.ndarray, p: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``out`` plus Σ_{l≠i} k_il / max(x_i + x_l, floor) for every i, k_il = s_i p_l + s_l p_i, in place.

    Shape (|O|, B).  Both k and D = x_i + x_l are symmetric, so each unordered pair is formed
    once, the pairs (i, i + d) of one offset d together, and G_il = k_il / D_il goes to both
    ends; a caller multiplies by x_i last.  The floor (:data:`RECIPROCAL_FLOOR`, a normal
    number) keeps every G finite and exact for the pairs above it (k ≤ 2, so G ≤ 2 / floor
    and a sum of fewer than 10¹⁷ of them stays finite); the pairs below it, both of whose
    weights lie below the floor, get x_i G ≤ k x_i / floor, which :func:`low_pairs` tops up
    to their exact share.
    """
    o, n = s.shape
    clamp = not all_above(weights, 0.5 * RECIPROCAL_FLOOR)     # x_i + x_l ≥ 2 min x
    pair, share, term = np.empty((o - 1, n)), np.empty((o - 1, n)), np.empty((o - 1, n))
    for d in range(1, o):
        m = o - d
        d_il, k_il, t = pair[:m], share[:m], term[:m]
        np.add(weights[:m], weights[d:], out=d_il)
        if clamp:
            np.maximum(d_il, RECIPROCAL_FLOOR, out=d_il)
        np.multiply(s[:m], p[d:], out=k_il)
        k_il += np.multiply(s[d:], p[:m], out=t)
        k_il /= d_il
        out[:m] += k_il
        out[d:] += k_il
    return out


def low_pairs(weights: np.ndarray, s: np.ndarray, p: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``out`` (x_i Σ_l G_il of :func:`pair_sums`) topped up to the exact shares of the pairs below the floor.

    A pair with D = x_i + x_l below :data:`RECIPROCAL_FLOOR` got k x_i / floor; its exact
    share is k x_i / D, formed ratio first (x_i / D ≤ 1, so weights of 1e-300 and below
    cannot overflow it), and with D = 0 (no m0 weight) k σ_i / (σ_i + σ_l), σ = s + p
    (SPEC A.4).  The missing part, k (x_i / D)(1 − D / floor) or the whole fallback share,
    is non-negative and is added.  Both weights of such a pair lie below the floor, and
    k_il = s_i p_l + s_l p_i is a sum of two products s_a p_b, so each row's low targets
    with running mass (a) and those with cue mass (b) are gathered into two compact lists
    first, and the product s_a p_b is shared out on their (a, b) grid; shape (|O|, B).
    """
    if all_above(weights, RECIPROCAL_FLOOR):
        return out
    low = weights < RECIPROCAL_FLOOR
    with_s, with_p = low & (s > 0), low & (p > 0)
    if not (with_s.any() and with_p.any()):
        return out
    n = weights.shape[1]

    def compact(mask):
        # Each row's members, in order, down the first axis of a (size, B) table of flat
        # indices; the padding reads entry 0, which ``kept`` zeroes.
        column, hyp = np.nonzero(mask.T)
        counts = np.bincount(column, minlength=n)
        place = np.arange(column.size) - (np.cumsum(counts) - counts)[column]
        flat = np.zeros((int(counts.max()), n), dtype=np.intp)
        flat[place, column] = hyp * n + column
        kept = np.zeros(flat.shape, dtype=bool)
        kept[place, column] = True
        return flat, kept, (hyp, column, place)

    def gather(values, flat, kept):
        return np.ascontiguousarray(values).reshape(-1).take(flat) * kept

    flat_a, kept_a, where_a = compact(with_s)
    flat_b, kept_b, where_b = compact(with_p)
    x_a, x_b = gather(weights, flat_a, kept_a)[:, None], gather(weights, flat_b, kept_b)[None]
    s_a, p_b = gather(s, flat_a, kept_a), gather(p, flat_b, kept_b)
    term = s_a[:, None] * p_b[None]                                  # s_a p_b on the (a, b, row) grid
    term *= flat_a[:, None] != flat_b[None]                          # pairs of two targets
    total = x_a + x_b
    if (((x_a[:, 0] == 0) & kept_a).any(axis=0) & ((x_b[0] == 0) & kept_b).any(axis=0)).any():
        # Some pair may have no m0 weight (D = 0): the fallback share σ_a : σ_b there.
        sigma_a = (s_a + gather(p, flat_a, kept_a))[:, None]
        sigma_b = (p_b + gather(s, flat_b, kept_b))[None]
        weighed = total > 0
        term *= np.where(weighed, np.maximum(1.0 - total / RECIPROCAL_FLOOR, 0.0), 1.0)
        np.maximum(np.where(weighed, total, sigma_a + sigma_b), TINY, out=total)
        x_a, x_b = np.where(weighed, x_a, sigma_a), np.where(weighed, x_b, sigma_b)
    else:
        # 1 − D / floor: 0 for D ≥ floor, where pair_sums was exact.
        missing = total * (-1.0 / RECIPROCAL_FLOOR)
        missing += 1.0
        term *= np.maximum(missing, 0.0, out=missing)
        np.maximum(total, TINY, out=total)                          # the padding's 0 / 0
    to_a = np.divide(x_a, total)
    to_a *= term
    to_b = np.divide(x_b, total, out=total)
    to_b *= term
    for (hyp, column, place), extra in ((where_a, to_a.sum(axis=1)), (where_b, to_b.sum(axis=0))):
        out[hyp, column] += extra[place, column]
    return out
