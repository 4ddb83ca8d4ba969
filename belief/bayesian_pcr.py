"""The closed forms of PCR5 and PCR6 for Bayesian sources: the consensus plus the proportional redistribution."""

from __future__ import annotations

from itertools import combinations

import numpy as np

from belief.bayesian_blocks import Blocks, Fusion, block_sources, first_pick, pick_per_row, product_of, share_of
from belief.bayesian_split import ExclusiveSplit

#: Rows × grid entries per block of the enumerations (a block's temporaries stay in cache).
BLOCK_ENTRIES = 1 << 18


class PCRFusion(Fusion):
    """PCR5 and PCR6 of Bayesian sources (SPEC A.3): consensus plus proportional redistribution.

    Only tuples that hold an exclusive hypothesis conflict.  Two sources: the pairs
    (θ_e, θ_y), (θ_x, θ_e) and (θ_e, θ_e′), O(|E|·n) per row.  More sources (|E| ≤ 1): for
    each set A of sources that pick the exclusive θ_F, the others pick free hypotheses, a
    grid of |O|^(s−|A|) tuples per row.

    Examples
    --------
    Zadeh's example on Shafer's model: PCR6 gives (.486, .486, .028).

    >>> from belief import Frame, Model, exclusive_split
    >>> split = exclusive_split(Model.shafer(Frame(["a", "b", "c"])))
    >>> fusion = PCRFusion([np.array([[.9, 0, .1]]), np.array([[0, .9, .1]])], split, "pcr6")
    >>> np.hstack([fusion.o_measure("mass"), fusion.e_measure("mass")]).round(12)
    array([[0.486, 0.486, 0.028]])
    """

    def __init__(self, values, split: ExclusiveSplit, rule: str, maps=None) -> None:
        self.split = split
        self.rule = rule
        # With three sources or more a block holds one (|O|, |O|) grid per row.
        self.sources = Blocks(values, split.size, len(split.free) if len(values) > 2 else 0, maps)
        self.rows = self.sources.rows
        self.s = len(values)
        self._parts: dict | None = None
        self._cache: dict = {}
        self._share: tuple[bytes, np.ndarray, np.ndarray | None] | None = None

    def parts(self) -> dict:
        """Per row: O_i, P_O, Π_i m_i(θ_e), and what the conflicting tuples give back to each hypothesis."""
        if self._parts is None:
            n, o, e = self.rows, len(self.split.free), len(self.split.exclusive)
            parts = {"totals": np.empty((self.s, n)), "exclusive": np.empty((e, n)),
                     "to_free": np.empty((o, n)), "to_excl": np.empty((e, n))}
            for rows in self.sources:
                free, excl, totals = block_sources(self.sources.block(rows), self.split)
                parts["totals"][:, rows] = totals
                parts["exclusive"][:, rows] = product_of(excl)
                if not e:
                    parts["to_free"][:, rows] = 0.0
                elif self.s == 2:
                    parts["to_free"][:, rows], parts["to_excl"][:, rows] = _two_sources(free, excl)
                else:
                    parts["to_free"][:, rows], parts["to_excl"][:, rows] = _enumerated(free, excl, self.rule)
            parts["all_free"] = product_of(list(parts["totals"]))
            parts["spread"] = parts["all_free"] + parts["to_free"].sum(axis=0)      # every free-side mass
            self._parts = parts
        return self._parts

    def empty(self) -> np.ndarray:
        return np.zeros(self.rows)

    def kept(self) -> np.ndarray:
        return np.ones(self.rows)

    def o_measure(self, kind: str, positions: np.ndarray | None = None) -> np.ndarray:
        key = (kind, None if positions is None else positions.tobytes())
        if key in self._cache:
            return self._cache[key]
        parts = self.parts()
        if kind == "pls":
            out = parts["spread"]
        elif positions is not None:
            free = self.picked(positions)
            if self._share is None or self._share[0] != key[1]:
                self._share = (key[1], pick_per_row(parts["to_free"], positions), None)
            share = self._share[1]
            if kind == "mass":
                out = product_of(free) + share
            else:
                # Bel and BetP of one selection share the sum over the first source that picks θ_j.
                if self._share[2] is None:
                    bel = first_pick(free, list(parts["totals"]))
                    bel += share
                    self._share = (key[1], share, bel)
                bel = self._share[2]
                out = bel.copy() if kind == "bel" else 0.5 * (parts["spread"] + bel)
        else:
            out = np.empty((len(self.split.free), self.rows))
            for rows in self.sources:
                free, _, _ = block_sources(self.sources.block(rows), self.split)
                out[:, rows] = self._measure(kind, free, list(parts["totals"][:, rows]), parts["to_free"][:, rows],
                                             parts["spread"][rows])
            out = out.T
        self._cache[key] = out
        return out

    @staticmethod
    def _measure(kind, free, totals, share, spread) -> np.ndarray:
        if kind == "mass":
            return product_of(free) + share
        bel = first_pick(free, totals) + share
        return bel if kind == "bel" else 0.5 * (spread + bel)

    def e_measure(self, kind: str) -> np.ndarray:
        parts = self.parts()
        return (parts["exclusive"] + parts["to_excl"]).T


def _two_sources(free, excl) -> tuple[np.ndarray, np.ndarray]:
    """The redistribution of two sources' conflicting pairs (θ_e, θ_y), (θ_x, θ_e), (θ_e, θ_e′), one block."""
    (x1, x2), (e1, e2) = free, excl
    # For two sources the PCR5 and PCR6 weights are the same, m_1(X) and m_2(Y).
    g12 = share_of(e1[:, None] * x2[None], e1[:, None] + x2[None])          # (E, O, B)
    g21 = share_of(x1[:, None] * e2[None], x1[:, None] + e2[None])          # (O, E, B)
    to_free = x2 * g12.sum(axis=0) + x1 * g21.sum(axis=1)
    to_excl = e1 * g12.sum(axis=1) + e2 * g21.sum(axis=0)
    if e1.shape[0] > 1:
        gee = share_of(e1[:, None] * e2[None], e1[:, None] + e2[None])       # (E, E, B)
        diagonal = np.arange(e1.shape[0])
        gee[diagonal, diagonal] = 0.0
        to_excl = to_excl + e1 * gee.sum(axis=1) + e2 * gee.sum(axis=0)
    return to_free, to_excl


def _enumerated(free, excl, rule) -> tuple[np.ndarray, np.ndarray]:
    """s ≥ 3 sources, one exclusive hypothesis F: every split of the sources into A (on F) and B, one block."""
    s = len(free)
    f = [e[0] for e in excl]
    to_free = np.zeros(free[0].shape)
    to_f = np.zeros(free[0].shape[1])
    pcr5 = rule == "pcr5"
    for size in range(1, s):
        for on_f in combinations(range(s), size):
            product = product_of([f[k] for k in on_f])
            total = f[on_f[0]].copy()
            for k in on_f[1:]:
                total += f[k]
            weight_f = product if pcr5 else total      # PCR5: one group, Π m_i(F); PCR6: Σ m_i(F)
            xs = [free[k] for k in range(s) if k not in on_f]
            _grid_shares(xs, product, weight_f, pcr5, to_free, to_f)
    return to_free, to_f[None]


def _grid_shares(xs: list[np.ndarray], product: np.ndarray, weight_f: np.ndarray, pcr5: bool,
                 to_free: np.ndarray, to_f: np.ndarray) -> None:
    """Add the shares of the tuples where the sources of ``xs`` pick free hypotheses and the others F.

    The tuple (a_1, …, a_b) has the product P = product · Π_k x_k(a_k).  PCR6 sends
    P · x_k(a_k) / D to θ_{a_k} for each k and P · weight_f / D to F, with
    D = weight_f + Σ_k x_k(a_k); PCR5 weighs each distinct element once, by the product of
    the masses put on it.  One or two free positions: a matrix H_ab = 1/D per row and two
    products with it; more: the whole grid, in blocks of rows.
    """
    b = len(xs)
    if b == 1:
        (x,) = xs
        g = product * share_of(x, weight_f + x)              # P / D per free hypothesis
        to_free += x * g
        to_f += weight_f * g.sum(axis=0)
        return
    o, rows = xs[0].shape
    block = max(64, BLOCK_ENTRIES // max(1, o ** b))
    if b == 2:
        _pair_grid_shares(xs[0], xs[1], product, weight_f, pcr5, block, to_free, to_f)
        return
    shape = [o] * b
    if pcr5:
        axes = np.indices(shape)
        equal = {(k, j): (axes[k] == axes[j])[..., None] for k in range(b) for j in range(b) if k != j}
        first = [np.logical_and.reduce([~equal[(j, k)] for j in range(k)]) if k else np.ones(shape + [1], bool)
                 for k in range(b)]
    for start in range(0, rows, block):
        r = slice(start, min(rows, start + block))
        n = r.stop - r.start
        grid = [x[:, r].reshape(tuple(o if j == k else 1 for j in range(b)) + (n,)) for k, x in enumerate(xs)]
        p = product[r] * product_of(grid)
        wf = weight_f[r]
        if pcr5:
            weights = []
            for k in range(b):
                w = grid[k]
                for j in range(b):
                    if j != k:
                        w = w * np.where(equal[(k, j)], grid[j], 1.0)
                weights.append(w * first[k])
        else:
            weights = grid
        denominator = wf + weights[0]
        for w in weights[1:]:
            denominator = denominator + w
        g = p / np.maximum(denominator, 1e-300)            # D = 0 only where P = 0
        for k in range(b):
            others = tuple(j for j in range(b) if j != k)
            to_free[:, r] += (weights[k] * g).sum(axis=others).reshape(o, n)
        to_f[r] += wf * g.reshape(-1, n).sum(axis=0)


def _pair_grid_shares(x: np.ndarray, y: np.ndarray, product: np.ndarray, weight_f: np.ndarray, pcr5: bool,
                      block: int, to_free: np.ndarray, to_f: np.ndarray) -> None:
    """:func:`_grid_shares` of two free positions: H_ab = 1 / (w_F + x_a + y_b) per row, two contractions.

    θ_a gets c x_a² Σ_b H_ab y_b and θ_b gets c y_b² Σ_a H_ab x_a, F gets c w_F Σ_ab x_a H_ab y_b.
    The grid and the per-block results are allocated once and reused from block to block.
    """
    o, rows = x.shape
    diagonal = np.arange(o)
    # D = 0 only where x_a = y_b = w_F = 0, and then every share of the tuple vanishes; raising
    # w_F + x_a to 1e-300 changes no share by more than its tuple's product, below 1e-300.
    alpha = np.add(x, weight_f)
    np.maximum(alpha, 1e-300, out=alpha)
    step = min(block, rows)
    grid, hy, hx, term = np.empty((o, o, step)), np.empty((o, step)), np.empty((o, step)), np.empty((o, step))
    for start in range(0, rows, step):
        r = slice(start, min(rows, start + step))
        if r.stop - r.start != step:                     # the last, shorter block
            step = r.stop - r.start
            grid, hy, hx, term = np.empty((o, o, step)), np.empty((o, step)), np.empty((o, step)), np.empty((o, step))
        xr, yr, c, wf = x[:, r], y[:, r], product[r], weight_f[r]
        np.add(alpha[:, None, r], yr[None], out=grid)    # (a, b, rows): D = w_F + x_a + y_b
        np.divide(1.0, grid, out=grid)
        if pcr5:
            grid[diagonal, diagonal] = 0.0               # a = b is one group: below
        np.einsum("abn,bn->an", grid, yr, out=hy)
        np.einsum("abn,an->bn", grid, xr, out=hx)
        np.multiply(xr, hy, out=term)                    # x_a Σ_b H_ab y_b
        to_f[r] += wf * c * np.add.reduce(term, axis=0)
        term *= xr
        hx *= yr
        hx *= yr
        term += hx
        term *= c
        to_free[:, r] += term
        if pcr5:
            group = xr * yr                              # both sources on θ_a: weight m_1(θ_a) m_2(θ_a)
            g = c * share_of(group, c + group)
            to_free[:, r] += group * g
            to_f[r] += c * g.sum(axis=0)
