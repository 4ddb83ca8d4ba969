"""The closed form of the R-weighted rule (SPEC A.4) for Bayesian sources, folded in source order."""

from __future__ import annotations

import numpy as np

from belief.batch import MassBatch, measure_plan
from belief.bayesian_blocks import Blocks, Fusion, NoClosedForm, pick_per_row, row_offsets
from belief.bayesian_fold import RECIPROCAL_FLOOR, Fold, RState, all_above, low_pairs, pair_sums
from belief.bayesian_split import ExclusiveSplit
from belief.frame import Element
from belief.plan import weighted_sum
from belief.r_inconsistency import paper_inconsistency


def _below(values: np.ndarray, rows: np.ndarray) -> None:
    """Mark in ``rows`` the columns of (K, B) ``values`` with an entry at or below the floor (or NaN)."""
    if not all_above(values, RECIPROCAL_FLOOR):
        rows |= ~(values.min(axis=0) > RECIPROCAL_FLOOR)


def _state_inconsistency(state: RState, p: np.ndarray, p_f: np.ndarray, r_mode: str,
                         split: ExclusiveSplit) -> tuple[np.ndarray, np.ndarray]:
    """R (W (10)) between a running result and a Bayesian cue, and 1 − R, from the element classes; shape (N,)."""
    if r_mode == "paper":
        # The cue has mass on singletons only, so they alone overlap the running result.
        overlap = np.add.reduce(np.minimum(state.s, p), 0)
        overlap += np.minimum(state.f, p_f)
    d = state.s - p
    d_f = state.f - p_f
    if r_mode == "paper":
        # Σ_A |Δ(A)|: the other elements count fully.
        value = np.add.reduce(np.abs(d, out=d), 0)
        value += np.abs(d_f, out=d_f)
        if not state.fresh:
            u_total = state.u_total if state.u_total is not None else np.add.reduce(state.u, 0)
            value += state.q
            value += u_total
            value += state.v
            value += state.e
        value *= 0.5
        return paper_inconsistency(value, overlap)
    if r_mode == "euclid":
        value = (d * d).sum(axis=0) + d_f * d_f
        if not state.fresh:
            value += state.q_squares + (state.u * state.u).sum(axis=0) + state.v * state.v + state.e * state.e
        value *= 0.5
    else:
        value = 0.5 * _jousselme_form(state, d, d_f, split)
    np.maximum(value, 0.0, out=value)
    np.minimum(value, 1.0, out=value)
    r = np.sqrt(value, out=value)
    return r, 1.0 - r


def _jousselme_form(state: RState, d: np.ndarray, d_f: np.ndarray, split: ExclusiveSplit) -> np.ndarray:
    """ΔᵀDΔ over θ_i, F, the pairs θ_i ∩ θ_l, θ_i ∪ F and ∅, D(A, B) = C(A∩B)/C(A∪B) (SPEC A.4).

    With N_k = C(θ_S) for |S| = k (N_1 = 2 N_2 = 4 N_3): D(θ_i, θ_l) = 1/3; D(θ_i, θ_i∩θ_l) = ½
    and 1/5 off the pair; between pairs 1, 1/3 (one target shared), 1/7 (none);
    D(θ_i∪F, θ_i) = N_1/(N_1+1), D(θ_i∪F, θ_l) = N_2/(2N_1−N_2+1), D(θ_i∪F, F) = 1/(N_1+1),
    D(θ_i∪F, θ_S) = N_2/(N_1+1) if i ∈ S, else N_3/(N_1+N_2−N_3+1),
    D(θ_i∪F, θ_l∪F) = (N_2+1)/(2N_1−N_2+1); 0 with ∅ and between F and the targets.
    Valid while every θ_S is a pair and no θ_S ∪ F exists: for the R of the first two folds.
    """
    d_sum = d.sum(axis=0)
    d2 = (d * d).sum(axis=0)
    # The pair terms as (Σ d)² − Σ d², which is exactly 0 when one target differs: a degenerate R
    # of exactly 1 (sources on disjoint singletons) then stays exactly 1, as on the general path.
    value = d2 + (d_sum * d_sum - d2) / 3.0 + d_f * d_f
    if state.fresh:
        return value
    i1, i2, i3 = (split.inverse_cardinality(k) for k in (1, 2, 3))
    q_each, q, q2, u = state.qj, state.q, state.q_squares, state.u
    u_sum = u.sum(axis=0)
    value += 2.0 * (d * (0.5 * q_each + 0.2 * (q - q_each))).sum(axis=0)
    q_each2 = (q_each * q_each).sum(axis=0)
    value += q2 + (q_each2 - 2.0 * q2) / 3.0 + (q * q + q2 - q_each2) / 7.0
    value += 2.0 * (u * (d / (1.0 + i1) + (d_sum - d) / (3.0 + i2))).sum(axis=0)
    value += 2.0 * u_sum * d_f * i1 / (1.0 + i1)
    value += 2.0 * (u * (q_each * 0.5 / (1.0 + i1) + (q - q_each) / (5.0 + i3))).sum(axis=0)
    u2 = (u * u).sum(axis=0)
    value += u2 + (u_sum * u_sum - u2) * (1.0 + i2) / (3.0 + i2)
    return value


class RRuleFusion(Fusion):
    """The R-weighted rule (SPEC A.4) of Bayesian sources, folded in source order, at most one exclusive F.

    Every fold but the last keeps each m(θ_i) and m(θ_i ∪ F), because the next fold's R and
    its m0 weights need them: one O(|O|²) pass per row (the pair shares do not factorise).
    The last fold gives Σ-type totals in O(|O|) per row, and the per-hypothesis values
    either for all free hypotheses (O(|O|²)) or for one selected per row (O(|O|)).  The rows
    are processed in blocks that fit in cache.  Rows whose SPEC A.4 fallback does not reduce
    to sums (:class:`Fold`) are listed in :attr:`general_rows`; their measures are read off
    the general combination of those rows alone.

    Coverage: ``r_mode="paper"`` for any number of sources, ``"euclid"`` and
    ``"jousselme"`` (which need Σ_S m(θ_S)² and D between all the elements) up to three;
    BetP up to three sources (its weight of θ_S ∪ F depends on |S|, and from four
    sources on |S| varies).

    Examples
    --------
    SPEC A.4, worked example: Bel(θ1) = .5149, Bel(θ2) = .6609 and m(θ1 ∩ θ2) = .3036.

    >>> from belief import Model, exclusive_split
    >>> fusion = RRuleFusion([np.array([[.6, .3, .1]]), np.array([[.2, .7, .1]])],
    ...                      exclusive_split(Model.for_targets(2)), "paper", union=True)
    >>> fusion.o_measure("bel").round(4), (fusion.o_measure("bel") - fusion.o_measure("mass")).round(4)
    (array([[0.5149, 0.6609]]), array([[0.3036, 0.3036]]))
    """

    def __init__(self, values, split: ExclusiveSplit, r_mode: str, union: bool, maps=None) -> None:
        self.split = split
        self.sources = Blocks(values, split.size, len(split.free) if len(values) > 2 else 0, maps)
        self._maps = maps
        self._three = len(values) == 3 and r_mode == "paper"     # :meth:`_run_three` applies
        self.rows = self.sources.rows
        self.s = len(values)
        self.r_mode = r_mode
        self.union = union
        self._totals: dict | None = None
        self._full: dict | None = None
        self._selected: tuple[bytes, dict] | None = None
        self._flagged = np.zeros(self.rows, dtype=bool)
        self._sub: MassBatch | None = None
        self._cache: dict = {}

    # -- the folds, in blocks of rows -------------------------------------------------------------
    def _cues(self, rows: slice) -> list[tuple[np.ndarray, np.ndarray]]:
        """The sources of these rows: (|O|, B) masses of the free hypotheses, and (B,) of F (0 without F)."""
        split = self.split
        f_row = split.exclusive[0] if split.exclusive else None
        zero = np.zeros(rows.stop - rows.start)
        return [(b[split.o_index], b[f_row] if f_row is not None else zero) for b in self.sources.block(rows)]

    def _last_fold(self, rows: slice, positions: np.ndarray | None = None) -> Fold:
        """Every fold but the last for these rows, then the last fold.

        ``positions``: the last fold is read for one free hypothesis per row only, so the fold
        before it keeps the per-hypothesis sums of intersections for that one (not with the
        Jousselme R, whose form needs them all).

        A second pass over the rows (another ``select``, say) folds the first sources again
        rather than keeping their (|O|, N) state: a pass serves all the measures of one reading.
        """
        cues = self._cues(rows)
        state = RState.bayesian(*cues[0])
        r_rho = _state_inconsistency(state, *cues[1], self.r_mode, self.split)             # W (10)
        for index in range(1, len(cues) - 1):
            p, p_f = cues[index]
            fold = Fold(state, p, p_f, r_rho, self.union)
            self._flagged[rows] |= fold.flagged
            only = positions if index == len(cues) - 2 and self.r_mode != "jousselme" else None
            before, state = state, fold.full(only)
            if index == 1 and self.r_mode != "paper":
                # After one fold every θ_S is a pair θ_i ∩ θ_l of mass R·k_il, and
                # Σ_{i<l} k_il² = Σs² Σp² − Σ(s p)² + (Σ s p)² − Σ(s p)².
                sp = before.s * p
                sp2 = (sp * sp).sum(axis=0)
                squares = ((before.s * before.s).sum(axis=0) * (p * p).sum(axis=0) - sp2 + sp.sum(axis=0) ** 2 - sp2)
                state.q_squares = r_rho[0] * r_rho[0] * np.maximum(squares, 0.0)
            r_rho = _state_inconsistency(state, *cues[index + 1], self.r_mode, self.split)
        fold = Fold(state, *cues[-1], r_rho, self.union)
        self._flagged[rows] |= fold.flagged
        return fold

    def _run(self, positions: np.ndarray | None = None, full: bool = False) -> None:
        """One pass over the row blocks for the totals, and the selected or every free hypothesis."""
        if not full and self._three:
            self._run_three(positions)
            return
        n, o = self.rows, len(self.split.free)
        totals = None if self._totals is not None else {k: np.empty(n) for k in ("s", "f", "u", "q", "v", "e")}
        selected = None if positions is None else {k: np.empty(n) for k in ("s", "u", "qj", "vj")}
        every = {k: np.empty((o, n)) for k in ("s", "u", "qj", "vj")} if full else None
        for rows in self.sources:
            fold = self._last_fold(rows, None if positions is None or full else positions[rows])
            if totals is not None:
                for k, v in fold.totals().items():
                    totals[k][rows] = v
            if selected is not None:
                for k, v in fold.selected(positions[rows]).items():
                    selected[k][rows] = v
            if every is not None:
                state = fold.full()
                for k in every:
                    every[k][:, rows] = getattr(state, k)
        if totals is not None:
            self._totals = totals
        if selected is not None:
            self._selected = (positions.tobytes(), selected)
        if every is not None:
            self._full = every

    def _run_three(self, positions: np.ndarray | None) -> None:
        """:meth:`_run` for three cues and the R of W (10) as printed.

        The two folds of :class:`Fold` in the case that nearly every row of a tracker meets:
        m0 weighs every pair of a target with F in both folds (w_i + w_F above
        :data:`RECIPROCAL_FLOOR`), and the selected target with every other one, so no
        flagged class arises in the first fold, and the second one has no θ_S ∪ F to start
        from.  The pairs of targets in the first fold may be as small as they come (particles
        far from a target give it likelihoods of 1e-300, or 0): :func:`low_pairs` gives them
        their exact shares.  Blocks of rows give only the sums over the targets that the
        second fold needs; its per-row formulas (R of W (10), the totals and the selected
        target) then run once on whole columns.  The other rows are folded again by the
        general fold on their own, so that every row gets the arithmetic of :class:`Fold`.
        """
        n, union = self.rows, self.union
        sums = {k: np.empty(n) for k in ("r1", "s0", "t1", "w1", "f1", "k1", "a2", "o2", "s1", "w2", "f2", "g2",
                                         "t2", "f", "pf", "cf")}
        if positions is not None:
            sums.update({k: np.empty(n) for k in ("sj", "pj", "cj", "s1j", "w2j", "ch", "sh")})
        slow = np.zeros(n, dtype=bool)
        with np.errstate(all="ignore"):              # rows below the floor are redone by Fold
            for rows in self.sources:
                self._three_block(rows, None if positions is None else positions[rows], sums, slow)
            totals, selected, flagged = self._three_rows(sums, positions)
        self._flagged |= flagged
        if slow.any():
            redo = np.flatnonzero(slow)
            sub = RRuleFusion([v if v.shape[0] != n else v[redo] for v in self.sources.values], self.split,
                              self.r_mode, union, self._maps)
            sub._three = False
            sub._run(None if positions is None else positions[redo])
            self._flagged[redo] = sub._flagged
            for k, v in sub._totals.items():
                totals[k][redo] = v
            if selected is not None:
                for k, v in sub._selected[1].items():
                    selected[k][redo] = v
        if self._totals is None:
            self._totals = totals
        if selected is not None:
            self._selected = (positions.tobytes(), selected)

    def _three_block(self, rows: slice, j: np.ndarray | None, sums: dict, slow: np.ndarray) -> None:
        """The sums over the targets of one block of rows (:meth:`_run_three`), written to ``sums[k][rows]``."""
        (s, f), (p, p_f), (c, c_f) = self._cues(rows)
        put = {k: v[rows] for k, v in sums.items()}
        reduce = np.add.reduce
        put["f"][...], put["pf"][...], put["cf"][...] = f, p_f, c_f
        # R of W (10) between the first two cues, and 1 − R.
        r1, rho1 = _state_inconsistency(RState.bayesian(s, f), p, p_f, "paper", self.split)
        put["r1"][...] = r1
        near = np.zeros(r1.shape, dtype=bool)                # rows for the general fold
        # First fold (its state is fresh): k_il of every pair to θ_i and θ_l as w_i : w_l, k_iF to
        # θ_i and F as w_i : w_F, R·k_iF to θ_i ∪ F (or ∅).
        d = w1 = s * p
        w_f = f * p_f
        inverse = w1 + w_f
        _below(inverse, near)
        np.divide(1.0, inverse, out=inverse)                 # 1 / (w_i + w_F)
        k1 = s * p_f
        k1 += f * p
        ki = np.multiply(k1, inverse, out=inverse)          # k_iF / (w_i + w_F)
        f1 = reduce(ki, 0, out=put["f1"])
        to_singles = pair_sums(w1, s, p, ki)                # + Σ_{l≠i} k_il / (w_i + w_l)
        f1 *= w_f
        f1 *= rho1
        f1 += w_f                                            # m′(F)
        to_singles *= w1
        low_pairs(w1, s, p, to_singles)                     # the pairs whose weights sum below the floor
        to_singles *= rho1
        s1 = np.add(to_singles, w1, out=to_singles)          # m′(θ_i)
        s_total, t = reduce(s, 0, out=put["s0"]), reduce(p, 0, out=put["t1"])
        reduce(w1, 0, out=put["w1"])
        reduce(s1, 0, out=put["s1"])
        reduce(c, 0, out=put["t2"])
        k_total = np.multiply(s_total, p_f, out=put["k1"])  # Σ_i k_iF, a sum of non-negative terms
        k_total += f * t
        # Second fold: R needs Σ|m′(θ_i) − c_i|, m0 weighs w_i = (m′(θ_i) + m′(θ_i ∪ F)) c_i.
        reduce(np.minimum(s1, c, out=d), 0, out=put["o2"])
        np.subtract(s1, c, out=d)
        reduce(np.abs(d, out=d), 0, out=put["a2"])
        if self.union:
            k1 *= r1                                         # m′(θ_i ∪ F)
            w2 = np.add(k1, s1, out=k1)
            u_total = r1 * k_total
        else:
            w2 = s1.copy()
            u_total = 0.0
        w2 *= c
        if self.union and not w2.all():
            # θ_l ∪ F against a target θ_i that m0 does not weigh takes SPEC A.4's fallback: the general fold.
            near |= ((w2 == 0) & (c > 0)).any(axis=0) & (u_total > 0)
        reduce(w2, 0, out=put["w2"])
        w2_f = (f1 + u_total) * c_f
        k2 = s1 * c_f
        k2 += np.multiply(f1, c, out=d)
        inverse = np.add(w2, w2_f, out=d)
        _below(inverse, near)
        np.divide(1.0, inverse, out=inverse)
        np.einsum("ij,ij->j", k2, inverse, out=put["f2"])                 # Σ k_iF / (w_i + w_F)
        np.einsum("ij,ij,ij->j", k2, w2, inverse, out=put["g2"])          # Σ k_iF w_i / (w_i + w_F)
        if j is not None:
            # θ_J against every other θ_l: Σ_l c_l h_l and Σ_l m′(θ_l) h_l, h_l = 1 / (w_J + w_l).
            flat = j * j.size
            flat += row_offsets(j.size, 1)
            for key, values in (("sj", s), ("pj", p), ("cj", c), ("s1j", s1), ("w2j", w2)):
                values.reshape(-1).take(flat, out=put[key], mode="clip")      # unbuffered: flat is valid
            h = np.add(w2, put["w2j"], out=inverse)
            _below(h, near)
            np.divide(1.0, h, out=h)
            h.reshape(-1)[flat] = 0.0
            np.einsum("ij,ij->j", c, h, out=put["ch"])
            np.einsum("ij,ij->j", s1, h, out=put["sh"])
        slow[rows] = near

    def _three_rows(self, sums: dict, positions: np.ndarray | None):
        """The per-row formulas of the second fold (:meth:`Fold.totals`, :meth:`Fold.selected`) on whole columns.

        Returns the totals, the selected parts (or None) and the flagged rows.
        """
        union = self.union
        f0, p_f, c_f = sums["f"], sums["pf"], sums["cf"]
        r1, k1, f1, t2 = sums["r1"], sums["k1"], sums["f1"], sums["t2"]
        q1 = np.maximum(sums["s0"] * sums["t1"] - sums["w1"], 0.0)
        q1 *= r1                                             # Σ m′(θ_S), every θ_S a pair
        u1 = r1 * k1 if union else np.zeros(self.rows)       # Σ m′(θ_i ∪ F)
        e1 = np.zeros(self.rows) if union else r1 * k1       # m′(∅)
        # R of W (10) between m′ and the third cue: the cue has mass on singletons only.
        value = sums["a2"] + np.abs(f1 - c_f)
        value += q1
        value += u1
        value += e1
        value *= 0.5
        r, rho = paper_inconsistency(value, sums["o2"] + np.minimum(f1, c_f))
        w_f = (f1 + u1) * c_f
        half = 0.5 * (w_f > 0)
        flagged = (q1 > 0) & (c_f > 0) & ~(w_f > 0)
        # Σ_{i≠l} (m′(θ_i) + m′(θ_i ∪ F)) c_l: the consensus of targets and of θ_i ∪ F with other targets.
        s1, w2 = sums["s1"], sums["w2"]
        spread = np.maximum((s1 + u1) * t2 - w2, 0.0)
        q_p_f = q1 * c_f
        r_k = s1 * c_f                                       # Σ_i k_iF of the second fold
        r_k += f1 * t2
        r_k *= r
        totals = {"s": w2 + rho * (spread + sums["g2"]),
                  "f": w_f + rho * (sums["f2"] * w_f + half * q_p_f),
                  "u": r_k if union else np.zeros(self.rows),
                  "q": r * spread + q1 * t2,
                  "v": ((r if union else 0.0) + rho * half) * q_p_f,
                  "e": e1 * (t2 + c_f) if union else r_k + e1 * (t2 + c_f) + r * q_p_f}
        if positions is None:
            return totals, None, flagged
        s_j, p_j, c_j = sums["sj"], sums["pj"], sums["cj"]
        s1j, w_j = sums["s1j"], sums["w2j"]
        q1j = sums["s0"] - s_j                              # Σ_{S∋J} m′(θ_S): the pairs θ_J ∩ θ_l
        q1j *= p_j
        q1j += s_j * (sums["t1"] - p_j)
        q1j *= r1
        if union:
            u1j = s_j * p_f
            u1j += f0 * p_j
            u1j *= r1                                        # m′(θ_J ∪ F)
        else:
            u1j = np.zeros(self.rows)
        k_f = s1j * c_f
        k_f += f1 * c_j
        except_p = t2 - c_j
        except_u = u1 - u1j
        to_single = s1j * sums["ch"]
        to_single += c_j * sums["sh"]
        to_single *= w_j
        to_single += k_f * (w_j * (1.0 / (w_j + w_f)))
        to_single += c_j * except_u                         # θ_l ∪ F against θ_J: all to θ_J
        qj = s1 - s1j
        qj *= c_j
        qj += s1j * except_p
        qj *= r
        qj += q1j * t2 + np.maximum(q1 - q1j, 0.0) * c_j + r * (u1j * except_p + c_j * except_u)
        to_single *= rho
        to_single += w_j
        selected = {"s": to_single, "u": r * k_f if union else np.zeros(self.rows), "qj": qj,
                    "vj": ((r if union else 0.0) + rho * half) * c_f * q1j}
        return totals, selected, flagged

    @property
    def general_rows(self) -> np.ndarray:
        self.totals()
        return np.flatnonzero(self._flagged)

    def totals(self) -> dict:
        if self._totals is None:
            self._run()
        return self._totals

    def _parts(self, positions: np.ndarray | None) -> dict:
        if positions is None:
            if self._full is None:
                self._run(full=True)
            return self._full
        if self._full is not None:
            return {k: pick_per_row(v, positions) for k, v in self._full.items()}
        key = positions.tobytes()
        if self._selected is None or self._selected[0] != key:
            self._run(positions=positions)
        return self._selected[1]

    # -- measures ---------------------------------------------------------------------------------
    def _sub_batch(self) -> MassBatch | None:
        rows = self.general_rows
        if not rows.size:
            return None
        if self._sub is None:
            self._sub = self.general(rows)
        return self._sub

    def _patch(self, out: np.ndarray, kind: str, exclusive: bool, positions: np.ndarray | None) -> np.ndarray:
        """Rows left to the general path: their values come from the general combination of those rows."""
        sub = self._sub_batch()
        if sub is None:
            return out
        rows = self.general_rows
        frame = sub.model.frame
        members = self.split.exclusive if exclusive else self.split.free
        values = _raw(sub, kind, tuple(frame.singletons[i] for i in members))
        out = np.array(out, dtype=np.float64, copy=True)
        if positions is not None:
            values = values[np.arange(rows.size), positions[rows]]
        elif out.ndim == 1:
            values = values[:, 0]          # Pls(θ_j) is the same for every free j
        out[rows] = values
        return out

    def _betp_ready(self) -> None:
        if self.s > 3:
            raise NoClosedForm("BetP of the R-weighted rule of more than three sources")

    def o_measure(self, kind: str, positions: np.ndarray | None = None) -> np.ndarray:
        key = (kind, None if positions is None else positions.tobytes())
        if key in self._cache:
            return self._cache[key]
        if kind == "pls":
            totals = self.totals()
            out = totals["s"] + totals["q"] + totals["u"] + totals["v"]          # every element but F and ∅
        else:
            if kind == "betp":
                self._betp_ready()
            parts = self._parts(positions)          # one pass over the rows gives the totals as well
            totals = self.totals()
            if kind == "mass":
                out = parts["s"]
            elif kind == "bel":
                out = parts["s"] + parts["qj"]                                  # W (8): θ_j and θ_S ∋ j
            else:
                i1, i2 = self.split.inverse_cardinality(1), self.split.inverse_cardinality(2)
                own1, other1 = 1.0 / (1.0 + i1), 0.5 / (1.0 + i1)               # θ_j∪F, θ_i∪F against θ_j
                own2, other2 = 1.0 / (1.0 + i2), 0.5 / (1.0 + i2)               # θ_S∪F with j ∈ S, j ∉ S
                out = (0.5 * (totals["s"] + totals["q"] + parts["s"] + parts["qj"])
                       + other1 * totals["u"] + other2 * totals["v"]
                       + (own1 - other1) * parts["u"] + (own2 - other2) * parts["vj"])
            if positions is None:
                out = out.T
        out = self._patch(out, kind, False, positions)
        self._cache[key] = out
        return out

    def e_measure(self, kind: str) -> np.ndarray:
        if not self.split.exclusive:
            return np.zeros((self.rows, 0))
        key = (kind, "exclusive")
        if key in self._cache:
            return self._cache[key]
        totals = self.totals()
        f = totals["f"]
        if kind == "pls":
            out = f + totals["u"] + totals["v"]
        elif kind == "betp":
            self._betp_ready()
            i1, i2 = self.split.inverse_cardinality(1), self.split.inverse_cardinality(2)
            out = f + totals["u"] * (i1 / (1.0 + i1)) + totals["v"] * (i2 / (1.0 + i2))   # C(F)/C(θ_S ∪ F)
        else:
            out = f
        out = self._patch(out[:, None], kind, True, None)
        self._cache[key] = out
        return out

    def empty(self) -> np.ndarray:
        out = self.totals()["e"]
        sub = self._sub_batch()
        if sub is not None:
            out = out.copy()
            out[self.general_rows] = sub.empty_mass
        return out

    def kept(self) -> np.ndarray:
        t = self.totals()
        out = t["s"] + t["f"] + t["q"] + t["u"] + t["v"]
        sub = self._sub_batch()
        if sub is not None:
            out = out.copy()
            keep = np.array([bool(x.terms) for x in sub.focal], dtype=np.float64)
            out[self.general_rows] = (sub.values * keep).sum(axis=1)
        return out


def _raw(batch: MassBatch, kind: str, queries: tuple[Element, ...]) -> np.ndarray:
    """A measure of a general batch before any normalisation, shape (N, Q) (BetP: its numerator)."""
    plan = measure_plan(batch.model, batch.focal, queries)
    table = {"bel": plan.subset, "pls": plan.meets, "mass": plan.equal, "betp": plan.ratio}[kind]
    return weighted_sum(batch.values, table)
