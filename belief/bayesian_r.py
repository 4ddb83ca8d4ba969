"""The closed form of the R-weighted rule (SPEC A.4) for Bayesian sources, folded in source order."""

from __future__ import annotations

import numpy as np

from belief.batch import MassBatch, measure_plan
from belief.bayesian_blocks import Blocks, Fusion, NoClosedForm, pick_per_row
from belief.bayesian_fold import RECIPROCAL_FLOOR, Fold, RState, all_above
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
