"""The closed forms of the conjunctive rule, DSmC, Dempster's and Yager's rule for Bayesian sources."""

from __future__ import annotations

import numpy as np

from belief.bayesian_blocks import Blocks, Fusion, block_sources, first_pick, product_of, sums_of_the_others
from belief.bayesian_split import ExclusiveSplit

#: Rows per block of a fusion that reads the sources column by column (a column of a block stays
#: below the size where the allocator maps fresh pages for every temporary).
COLUMN_BLOCK_ROWS = 1 << 13


#: Dempster's rule below this non-empty mass goes the general way, which rescales its products
#: (belief.rules.WIDE_SCALE).  Above it, what underflowed is below 2^-474 of every result.
_WIDE_SCALE = 2.0 ** -600


class Underflow(Exception):
    """The closed form of Dempster's rule would divide by a non-empty mass that may have underflowed."""


class ConjunctiveFusion(Fusion):
    """The conjunctive rule, DSmC, Dempster's and Yager's rule of Bayesian sources (W (2), SPEC A.3, Part D).

    Parameters
    ----------
    values : sequence of ndarray, each shape (N, n)
        The sources' masses of θ_1 … θ_n, in frame order (see ``maps`` for other orders).
    empties : sequence of (ndarray of shape (N,) or None)
        m(∅) of each source, for the subnormal sources the conjunctive rules accept.
    split : ExclusiveSplit
    rule : {"conjunctive", "dsmc", "dempster", "yager"}
    maps : optional
        Where the columns of each source sit in the frame (:class:`Blocks`).

    Examples
    --------
    SPEC Part D, two cues on three targets: Bel = (.52, .44, .23), Pls = .72 and m(∅) = .26.

    >>> from belief import Model, exclusive_split
    >>> loc, col = np.array([[.5, .2, .2, .1]]), np.array([[.3, .4, .1, .2]])
    >>> fusion = ConjunctiveFusion([loc, col], [None, None], exclusive_split(Model.for_targets(3)), "dsmc")
    >>> fusion.o_measure("bel").round(12), fusion.o_measure("pls").round(12), fusion.empty().round(12)
    (array([[0.52, 0.44, 0.23]]), array([0.72]), array([0.26]))
    """

    def __init__(self, values, empties, split: ExclusiveSplit, rule: str, maps=None) -> None:
        self.split = split
        self.rule = rule
        self.sources = Blocks(values, split.size, maps=maps, step=COLUMN_BLOCK_ROWS)
        n = self.rows = self.sources.rows
        s = len(values)
        self.totals = np.empty((s, n))                             # O_i per source
        self.exclusive = np.empty((len(split.exclusive), n))       # Π_i m_i(θ_e)
        self.conflict = np.empty(n)                                # m∩(∅), summed over conflicting tuples
        sources = self.sources
        for rows in sources:
            totals = [sources.total(k, split.free, rows, self.totals[k, rows]) for k in range(s)]
            excl = [sources.part(k, split.exclusive, rows) for k in range(s)]
            if s > 1:
                np.multiply(excl[0], excl[1], out=self.exclusive[:, rows])
                for e in excl[2:]:
                    self.exclusive[:, rows] *= e
            else:
                self.exclusive[:, rows] = excl[0]
            self.conflict[rows] = _conflict(excl, totals, [None if z is None else z[rows] for z in empties])
        self.all_free = product_of(list(self.totals))                # P_O = Π_i O_i
        self.scale = np.add.reduce(self.exclusive, axis=0)         # Σ of the non-empty masses
        self.scale += self.all_free
        if rule == "dempster" and not (self.scale > _WIDE_SCALE).all():
            raise Underflow       # total conflict, or products that underflowed: the general path tells which
        self._cache: dict = {}
        self._bel: tuple[bytes, np.ndarray] | None = None

    def empty(self) -> np.ndarray:
        return self.conflict if self.rule in ("conjunctive", "dsmc") else np.zeros(self.rows)

    def kept(self) -> np.ndarray:
        return self.scale

    def _norm(self, values: np.ndarray) -> np.ndarray:
        if self.rule != "dempster":
            return values
        return np.divide(values, self.scale, out=values if values.ndim == 1 else None)

    def _yager_shares(self) -> tuple[float, float]:
        """C(θ_j)/C(Θ) for j in O and in E: Θ holds the conflict under Yager's rule."""
        inverse = self.split.inverse_cardinality(1)                    # 1 / 2^(|O|-1)
        total = 2.0 - inverse + len(self.split.exclusive) * inverse    # C(Θ) / 2^(|O|-1)
        return 1.0 / total, inverse / total

    def _measure(self, kind: str, free: list[np.ndarray], totals, all_free, conflict, bel=None) -> np.ndarray:
        """The raw (before Dempster's normalisation) measure; fresh arrays, free to reuse."""
        if kind == "mass":
            return product_of(free)
        if bel is None:
            bel = first_pick(free, totals)
            if kind == "bel":
                return bel
        elif kind == "bel":
            return bel.copy()
        out = np.add(all_free, bel)
        out *= 0.5                                                     # θ_S with j ∉ S counts for ½
        if self.rule == "yager":
            out += conflict * self._yager_shares()[0]
        return out

    def o_measure(self, kind: str, positions: np.ndarray | None = None) -> np.ndarray:
        key = (kind, None if positions is None else positions.tobytes())
        if key in self._cache:
            return self._cache[key]
        if kind == "pls":
            out = self.all_free + self.conflict if self.rule == "yager" else self.all_free.copy()
            out = self._norm(out)
        elif positions is not None:
            free = self.picked(positions)
            bel = None
            if kind != "mass":
                # Bel and BetP of one selection share the sum over the first source that picks θ_j.
                if self._bel is None or self._bel[0] != key[1]:
                    self._bel = (key[1], first_pick(free, list(self.totals)))
                bel = self._bel[1]
            out = self._norm(self._measure(kind, free, list(self.totals), self.all_free, self.conflict, bel))
        else:
            out = np.empty((len(self.split.free), self.rows))
            for rows in self.sources:
                free, _, _ = block_sources(self.sources.block(rows), self.split)
                out[:, rows] = self._measure(kind, free, list(self.totals[:, rows]), self.all_free[rows],
                                             self.conflict[rows])
            out = self._norm(out).T
        self._cache[key] = out
        return out

    def e_measure(self, kind: str) -> np.ndarray:
        out = self.exclusive
        if kind == "pls" and self.rule == "yager":
            out = out + self.conflict
        elif kind == "betp" and self.rule == "yager":
            out = out + self.conflict * self._yager_shares()[1]
        return self._norm(out).T


def _conflict(excl, totals, empties) -> np.ndarray:
    """m∩(∅) of Bayesian sources by a pass over them, as a sum of products (never 1 − Σ).

    After source k a tuple is all-free (mass P_k), all on one exclusive θ_e (B_k(e)), or
    already conflicting (C_k); the next source keeps or breaks each state:
    C_{k+1} = C_k · T + P_k · (E + z) + Σ_e B_k(e) · (O + z + Σ_{e′≠e} m(θ_e′)), where T, O,
    E and z are the next source's total, free, exclusive and ∅ masses.
    """
    free_so_far = totals[0]
    same = excl[0]
    conflict = empties[0].copy() if empties[0] is not None else np.zeros(totals[0].shape)
    for e, total, z in zip(excl[1:], totals[1:], empties[1:]):
        e_total = e.sum(axis=0)
        outside = e_total if z is None else e_total + z          # what breaks an all-free tuple
        free_or_empty = total if z is None else total + z
        others = sums_of_the_others(e)                                      # the other exclusive hypotheses
        conflict = (conflict * (free_or_empty + e_total) + free_so_far * outside
                    + (same * (free_or_empty + others)).sum(axis=0))
        free_so_far = free_so_far * total
        same = same * e
    return conflict
