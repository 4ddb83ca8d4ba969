"""What the fused cues say about each particle's own target, without the fused mass functions.

The tracker fuses c Bayesian cue mass functions per particle (W (7), W (20)–(21)) under the
tracking model M_τ of SPEC Part D (targets may overlap, θ_j ∩ FA ≡ ∅), and then reads, for a
particle of target J, only Bel(θ_J) (W (32)), Pls(θ_J), BetP(θ_J), m(θ_J), the mass of the
target intersections inside θ_J (W (34)) and m(∅).  The general combination materialises
every focal element; with the R-weighted rule (SPEC A.4) folded over three cues there are
O(τ³) of them per particle.  This module computes the same numbers from a few sums over the
targets, for all particles at once.

Elements by their relation to J and FA
--------------------------------------
With Bayesian cues, every focal element of a fold of the R-weighted rule is one of

* θ_i (mass s_i), FA (f), ∅ (e);
* θ_S = ∩_{i∈S} θ_i with |S| ≥ 2 (kept conflict of target pairs, W (14), and consensus);
  only the totals Q = Σ_S m(θ_S) and Q_J = Σ_{S∋J} m(θ_S) are needed;
* θ_i ∪ FA (u_i) and θ_S ∪ FA, |S| ≥ 2 (the conflict R·k of a target element against FA in
  ``empty_mode="union"``), kept as the vector u and the totals V, V_J;
* unions θ_i ∪ θ_l and θ_i ∪ θ_l ∪ FA, which never receive mass: m0 (Dempster's rule on the
  Shafer projections) only has singleton keys, θ_i and FA.

A fold with a Bayesian cue p (targets p_i, false alarm p_F, T = Σ_i p_i) has
m0(θ_i) ∝ w_i = (s_i + u_i) p_i and m0(FA) ∝ w_F = (f + U + V) p_F, and only these pairs conflict:

=======================  ===================  =====================  =============================
pair                     k (W (11))           R·k goes to (W (14))   (1 − R)·k goes to (W (12)–(13))
=======================  ===================  =====================  =============================
θ_i, θ_l                 s_i p_l + s_l p_i    θ_i ∩ θ_l              θ_i : θ_l as w_i : w_l
θ_i, FA                  s_i p_F + f p_i      θ_i ∪ FA, or ∅         θ_i : FA as w_i : w_F
θ_S, FA                  m(θ_S) p_F           θ_S ∪ FA, or ∅         FA and θ_S ∪ FA, ½ each
θ_i ∪ FA, θ_l            u_i p_l              θ_i ∩ θ_l              all to θ_l
θ_S ∪ FA, θ_l            m(θ_S ∪ FA) p_l      θ_S ∩ θ_l              θ_S ∪ FA : θ_l as w_F : w_l
=======================  ===================  =====================  =============================

Everything else is consensus: θ_S with θ_l goes to θ_{S∪{l}}, θ_i ∪ FA with θ_i to θ_i, and
every FA-containing element with FA to FA.  Summed over the targets, e.g. the kept conflict
inside θ_J is R·(s_J (T − p_J) + p_J (S − s_J)) with S = Σ_i s_i, and the new
intersection mass is Q·T + R·(S T − Σ_i s_i p_i + U T − Σ_i u_i p_i + V T).  A fold's
inconsistency R (W (10)) needs Σ_A |m(A) − p(A)| = Σ_i |s_i − p_i| + |f − p_F| + Q + U + V + e,
hence every s_i of the running result; each s_i gets the share w_i / (w_i + w_l) of every pair
θ_i, θ_l, a sum over l that does not factorise.  So the folds before the last cost one O(τ²)
pass per particle (a (τ, τ) matrix times two vectors), the last fold O(τ) per particle.

When m0 gives a pair no weight, SPEC A.4 weighs it by the sources' own support.  The
fallbacks of the pairs above are exact here, except for the pairs θ_S/FA and θ_S ∪ FA/θ_l,
whose fallback shares depend on each m(θ_S); the rows that need them (no mass at all on FA
and the elements containing it, yet an FA or target share to place) are flagged in
:attr:`OwnerMeasures.general`, for the general combination to fill in.

Coverage: the R-weighted rule with ``r_mode="paper"`` for any number of cues;
``"euclid"`` and ``"jousselme"`` (which need Σ_S m(θ_S)², and D(A, B) between all the
elements) and BetP up to three cues; the conjunctive rules ``dsmc``/``conjunctive`` and
Dempster's rule for any number of cues through the closed forms of SPEC Part D; one cue for
every rule.  :func:`supports` tells which.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from belief.errors import InvalidMassError, TotalConflictError

__all__ = ["OwnerMeasures", "owner_measures", "supports", "first_inconsistency", "MAX_CUES_BY_MODE"]

#: Rows × τ × τ entries of one block of the O(τ²) pass (bounds memory; any size gives the same result).
BLOCK_ENTRIES = 1 << 17

#: The most cues the closed forms of the R-weighted rule handle per inconsistency mode (None: any).
MAX_CUES_BY_MODE = {"paper": None, "euclid": 3, "jousselme": 3}
#: The most cues for which BetP of the R-weighted rule is computed in closed form.
MAX_BETP_CUES = 3

_CONJUNCTIVE = ("dsmc", "conjunctive", "dempster")


@dataclass(frozen=True, eq=False)
class OwnerMeasures:
    """Measures of θ_J for every particle, J being the particle's own target.

    Attributes
    ----------
    bel, pls : ndarray, shape (P,)
        Bel(θ_J) and Pls(θ_J) (W (8), W (9), W (32)).
    betp : ndarray, shape (P,), or None
        BetP(θ_J), when asked for.
    singleton : ndarray, shape (P,)
        m(θ_J) (W (33)).
    intersection : ndarray, shape (P,)
        Σ m(θ_J ∩ θ_k ∩ …) over the pure target intersections containing θ_J (W (34)).
    empty : ndarray, shape (P,)
        m(∅).
    general : ndarray of bool, shape (P,)
        Rows whose values above are placeholders: a fallback of SPEC A.4 that does not
        reduce to sums over the targets; the general combination must give them.
    """

    bel: np.ndarray
    pls: np.ndarray
    betp: np.ndarray | None
    singleton: np.ndarray
    intersection: np.ndarray
    empty: np.ndarray
    general: np.ndarray


def supports(rule: str, n_cues: int, r_mode: str = "paper", betp: bool = False) -> bool:
    """Whether :func:`owner_measures` handles this combination.

    Parameters
    ----------
    rule : str
        A canonical rule name of :data:`belief.RULES`.
    n_cues : int
    r_mode : str
        Inconsistency mode of the R-weighted rule (SPEC A.4).
    betp : bool
        Whether BetP(θ_J) is needed.

    Examples
    --------
    >>> supports("r_rule", 3), supports("r_rule", 4, "euclid"), supports("pcr6", 2), supports("pcr6", 1)
    (True, False, False, True)
    """
    if n_cues == 1 or rule in _CONJUNCTIVE:
        return n_cues >= 1
    if rule != "r_rule":
        return False
    limit = MAX_CUES_BY_MODE.get(r_mode, 0)
    if limit is not None and n_cues > limit:
        return False
    return not (betp and n_cues > MAX_BETP_CUES)


def owner_measures(masses: Sequence[np.ndarray], owner: np.ndarray, rule: str, *, r_mode: str = "paper",
                   empty_mode: str = "union", betp: bool = False) -> OwnerMeasures:
    """Bel, Pls, BetP, m(θ_J), intersection mass and m(∅) of the fused cues, per particle.

    Equals reading these measures off ``combine(*cues, rule=rule)`` under
    ``Model.for_targets(τ)`` (W (7), W (32); SPEC A.4, A.5, Part D) for the rows not flagged
    in :attr:`OwnerMeasures.general`, at O(c·τ) cost per particle (O(τ²) per particle for each
    R-weighted fold but the last, see the module notes).

    Parameters
    ----------
    masses : sequence of ndarray, each shape (P, τ + 1)
        Bayesian cue masses m(θ_1) … m(θ_τ), m(FA), rows summing to one, in cue order.
    owner : ndarray of int, shape (P,)
        The target J of each particle.
    rule : str
        Canonical rule name; see :func:`supports`.
    r_mode, empty_mode : str
        Options of the R-weighted rule.
    betp : bool
        Compute BetP(θ_J) as well.

    Returns
    -------
    OwnerMeasures

    Raises
    ------
    InvalidMassError
        For a combination that :func:`supports` refuses.
    TotalConflictError
        Dempster's rule on a totally conflicting row, or BetP of a row with m(∅) = 1 (as the
        general path).

    Examples
    --------
    SPEC A.4, worked example (τ = 2, location then colour): Bel(θ1) = .5149, Bel(θ2) = .6609,
    and m(θ1 ∩ θ2) = .3036.

    >>> cues = [np.array([[0.6, 0.3, 0.1]] * 2), np.array([[0.2, 0.7, 0.1]] * 2)]
    >>> m = owner_measures(cues, np.array([0, 1]), "r_rule")
    >>> m.bel.round(4), m.intersection.round(4), m.pls.round(4)
    (array([0.5149, 0.6609]), array([0.3036, 0.3036]), array([0.9861, 0.9861]))
    """
    masses = [np.asarray(m, dtype=np.float64) for m in masses]
    owner = np.asarray(owner, dtype=np.int64)
    if not masses:
        raise InvalidMassError("fusion needs at least one cue")
    if not supports(rule, len(masses), r_mode, betp):
        raise InvalidMassError(f"no closed form for rule {rule!r} with {len(masses)} cues "
                               f"(r_mode={r_mode!r}, betp={betp}); use the general combination")
    if len(masses) == 1:
        return _one_cue(masses[0], owner)
    if rule in _CONJUNCTIVE:
        return _conjunctive(masses, owner, normalise=rule == "dempster", betp=betp)
    return _r_rule(masses, owner, r_mode, empty_mode == "union", betp)


def first_inconsistency(m1: np.ndarray, m2: np.ndarray, r_mode: str = "paper") -> np.ndarray:
    """R of W (10) between two batches of Bayesian cue masses on the tracking frame, shape (P,).

    Equals :func:`belief.rules.inconsistency` over the singletons of ``Model.for_targets(τ)``,
    in O(τ) per row also for ``"jousselme"``: there D(θ_i, θ_l) = C(θ_i∩θ_l)/C(θ_i∪θ_l) = 1/3
    for two targets, 0 between a target and FA.

    >>> first_inconsistency(np.array([[0.6, 0.3, 0.1]]), np.array([[0.2, 0.7, 0.1]])).round(4)
    array([0.6325])
    """
    m1, m2 = np.asarray(m1, dtype=np.float64), np.asarray(m2, dtype=np.float64)
    tau = m1.shape[1] - 1
    state = _RState.bayesian(m1, np.zeros(m1.shape[0], dtype=np.int64))
    return _inconsistency(state, m2[:, :tau], m2[:, tau], r_mode, tau)


# -- one cue, conjunctive rules ------------------------------------------------------------------------
def _one_cue(m: np.ndarray, owner: np.ndarray) -> OwnerMeasures:
    rows = np.arange(owner.size)
    own = m[rows, owner]
    targets = m[:, :-1].sum(axis=1)
    zeros = np.zeros(owner.size)
    # BetP: another target θ_i shares the region θ_i ∩ θ_J, C(θ_i ∩ θ_J) / C(θ_i) = ½.
    return OwnerMeasures(bel=own.copy(), pls=targets, betp=own + 0.5 * np.maximum(targets - own, 0.0),
                         singleton=own.copy(), intersection=zeros, empty=zeros.copy(),
                         general=np.zeros(owner.size, dtype=bool))


def _conjunctive(masses: list[np.ndarray], owner: np.ndarray, normalise: bool, betp: bool) -> OwnerMeasures:
    """SPEC Part D: P = Π_l T_l, Bel(θ_J) = P − Π_l (T_l − m_l(θ_J)), m(FA) = Π_l m_l(FA)."""
    rows = np.arange(owner.size)
    targets = np.prod([m[:, :-1].sum(axis=1) for m in masses], axis=0)               # P: all cues on targets
    fa = np.prod([m[:, -1] for m in masses], axis=0)
    without = np.prod([m[:, :-1].sum(axis=1) - m[rows, owner] for m in masses], axis=0)
    singleton = np.prod([m[rows, owner] for m in masses], axis=0)
    bel = np.maximum(targets - without, 0.0)
    empty = np.maximum(1.0 - targets - fa, 0.0)
    kept = targets + fa                                                               # Σ of the non-empty masses
    # BetP: θ_S with J ∈ S counts fully, other target intersections by C(θ_{S∪J}) / C(θ_S) = ½.
    pignistic = 0.5 * (targets + bel) if betp else None
    if normalise:
        dead = ~(kept > 0)
        if dead.any():
            row = int(np.flatnonzero(dead)[0])
            where = f" (row {row})" if owner.size > 1 else ""
            raise TotalConflictError(f"dempster: total conflict between the sources{where}, m(∅) = 1; "
                                     "Dempster's rule is undefined (try yager, dubois_prade, dsmh or pcr6)")
        return OwnerMeasures(bel=bel / kept, pls=targets / kept, betp=None if pignistic is None else pignistic / kept,
                             singleton=singleton / kept, intersection=(bel - singleton) / kept,
                             empty=np.zeros(owner.size), general=np.zeros(owner.size, dtype=bool))
    if pignistic is not None:
        pignistic = _normalised_betp(pignistic, empty, kept)
    return OwnerMeasures(bel=bel, pls=targets, betp=pignistic, singleton=singleton,
                         intersection=np.maximum(bel - singleton, 0.0), empty=empty,
                         general=np.zeros(owner.size, dtype=bool))


def _normalised_betp(numerator: np.ndarray, empty: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """BetP with ∅ removed and the rest rescaled, as :meth:`belief.MassBatch.betp` does."""
    if not empty.any():
        return numerator
    dead = ~(kept > 0)
    if dead.any():
        row = int(np.flatnonzero(dead)[0])
        where = f" (row {row})" if kept.size > 1 else ""
        raise TotalConflictError(f"BetP is undefined: total conflict, m(∅) = 1{where}")
    return numerator / kept


# -- the R-weighted rule -------------------------------------------------------------------------------
@dataclass
class _RState:
    """A running R-weighted result, by element class (module notes); arrays over the rows."""

    owner: np.ndarray
    s: np.ndarray                      # (n, τ) m(θ_i)
    u: np.ndarray                      # (n, τ) m(θ_i ∪ FA)
    f: np.ndarray                      # m(FA)
    e: np.ndarray                      # m(∅)
    q: np.ndarray                      # Σ m(θ_S), |S| ≥ 2
    q_own: np.ndarray                  # the same over S ∋ J
    v: np.ndarray                      # Σ m(θ_S ∪ FA), |S| ≥ 2
    v_own: np.ndarray                  # the same over S ∋ J
    q_each: np.ndarray | None = None   # (n, τ) Σ_{S∋i} m(θ_S), while every θ_S is a pair of the first fold
    q_squares: np.ndarray | None = None  # Σ_S m(θ_S)², likewise
    u_total: np.ndarray | None = None  # Σ_i u_i when only u_J is kept (last fold)

    @classmethod
    def bayesian(cls, m: np.ndarray, owner: np.ndarray) -> "_RState":
        tau = m.shape[1] - 1
        n = m.shape[0]
        zero = np.zeros(n)
        return cls(owner, m[:, :tau], np.zeros((n, tau)), m[:, tau], zero, zero, zero, zero, zero,
                   np.zeros((n, tau)), zero)

    @property
    def u_sum(self) -> np.ndarray:
        return self.u.sum(axis=1) if self.u_total is None else self.u_total


def _r_rule(masses: list[np.ndarray], owner: np.ndarray, r_mode: str, union: bool, betp: bool) -> OwnerMeasures:
    tau = masses[0].shape[1] - 1
    state = _RState.bayesian(masses[0], owner)
    general = np.zeros(owner.size, dtype=bool)
    for index, cue in enumerate(masses[1:], start=2):
        p, p_fa = cue[:, :tau], cue[:, tau]
        r = _inconsistency(state, p, p_fa, r_mode, tau)                                   # W (10)
        state, flagged = _fold(state, p, p_fa, r, union, last=index == len(masses), betp=betp)
        general |= flagged
    s_own = state.s[:, 0]                                                             # the last fold keeps s_J
    bel = s_own + state.q_own                                                         # W (32), SPEC A.5
    pls = np.maximum(1.0 - state.f - state.e, 0.0)                                    # every element but FA, ∅
    pignistic = None
    if betp:
        pignistic = _r_betp(state, s_own, tau)
    return OwnerMeasures(bel=bel, pls=pls, betp=pignistic, singleton=s_own, intersection=state.q_own,
                         empty=state.e, general=general)


def _r_betp(state: _RState, s_own: np.ndarray, tau: int) -> np.ndarray:
    """BetP(θ_J) = Σ_X m(X) C(X ∩ θ_J) / C(X) by element class, up to three cues.

    C(θ_S) = N_|S| = 2^(τ−|S|) regions, C(θ_S ∪ FA) = N_|S| + 1.  Up to three cues every θ_S ∪ FA
    with |S| ≥ 2 is a pair (it comes from a pair θ_i ∩ θ_l of the first fold).  The ratios are
    written with 1/N_k, which cannot overflow for large τ.
    """
    i1, i2 = 2.0 ** (1 - tau), 2.0 ** (2 - tau)            # 1/N_1, 1/N_2
    u_own = state.u[:, 0]                                  # the last fold keeps u_J only
    u_all = state.u_sum
    singles = np.maximum(1.0 - state.f - state.e - state.q - u_all - state.v, 0.0)   # Σ_i m(θ_i)
    numerator = (s_own + 0.5 * np.maximum(singles - s_own, 0.0)
                 + state.q_own + 0.5 * np.maximum(state.q - state.q_own, 0.0)
                 + (u_own + 0.5 * np.maximum(u_all - u_own, 0.0)) / (1.0 + i1)
                 + (state.v_own + 0.5 * np.maximum(state.v - state.v_own, 0.0)) / (1.0 + i2))
    return _normalised_betp(numerator, state.e, 1.0 - state.e)


def _inconsistency(state: _RState, p: np.ndarray, p_fa: np.ndarray, r_mode: str, tau: int) -> np.ndarray:
    """R (W (10)) between the running result and a Bayesian cue, from the element classes."""
    d = state.s - p
    d_fa = state.f - p_fa
    if r_mode == "paper":
        # Σ_A |Δ(A)| over t_1..t_τ, FA and the non-singletons (where the cue has no mass).
        value = (np.abs(np.concatenate([d, d_fa[:, None]], axis=1)).sum(axis=1)
                 + state.q + state.u_sum + state.v + state.e) / 2.0
        # Disjoint focal sets: exactly 1, as belief.rules.inconsistency (the cue only has θ_i and FA).
        value[~((np.minimum(state.s, p) > 0).any(axis=1) | (np.minimum(state.f, p_fa) > 0))] = 1.0
    elif r_mode == "euclid":
        value = 0.5 * ((np.concatenate([d, d_fa[:, None]], axis=1) ** 2).sum(axis=1)
                       + (state.u * state.u).sum(axis=1) + state.q_squares + state.e ** 2)
    elif r_mode == "jousselme":
        value = 0.5 * _jousselme_form(state, d, d_fa, tau)
    else:
        raise InvalidMassError(f"r_mode must be one of paper, euclid, jousselme, got {r_mode!r}")
    return np.sqrt(np.clip(value, 0.0, 1.0))


def _jousselme_form(state: _RState, d: np.ndarray, d_fa: np.ndarray, tau: int) -> np.ndarray:
    """ΔᵀDΔ with D(A, B) = C(A∩B)/C(A∪B) over θ_i, FA, θ_i∩θ_l (pairs), θ_i ∪ FA and ∅.

    With N_k = 2^(τ−k) = C(θ_S) for |S| = k: D(θ_i, θ_l) = 1/3; D(θ_i, θ_i∩θ_l) = ½ and 1/5
    off the pair; between pairs 1 (same), 1/3 (one target shared), 1/7 (disjoint);
    D(θ_i∪FA, θ_i) = N_1/(N_1+1), D(θ_i∪FA, θ_l) = N_2/(2N_1−N_2+1), D(θ_i∪FA, FA) = 1/(N_1+1),
    D(θ_i∪FA, θ_S) = N_2/(N_1+1) if i ∈ S else N_3/(N_1+N_2−N_3+1),
    D(θ_i∪FA, θ_l∪FA) = (N_2+1)/(2N_1−N_2+1); 0 with ∅ and between a target element and FA.
    They are evaluated with 1/N_k (N_1 = 2 N_2 = 4 N_3), which cannot overflow for large τ.
    """
    i1, i2, i3 = 2.0 ** (1 - tau), 2.0 ** (2 - tau), 2.0 ** (3 - tau)     # 1/N_1, 1/N_2, 1/N_3
    q_each, q, q2 = state.q_each, state.q, state.q_squares
    u = state.u
    u_sum = u.sum(axis=1)
    d_sum = d.sum(axis=1)
    d2 = (d * d).sum(axis=1)
    value = d2 + (d_sum ** 2 - d2) / 3.0 + d_fa ** 2
    value += 2.0 * (d * (0.5 * q_each + 0.2 * (q[:, None] - q_each))).sum(axis=1)
    q_each2 = (q_each * q_each).sum(axis=1)
    value += q2 + (q_each2 - 2.0 * q2) / 3.0 + (q * q + q2 - q_each2) / 7.0
    value += 2.0 * (u * (d / (1.0 + i1) + (d_sum[:, None] - d) / (3.0 + i2))).sum(axis=1)
    value += 2.0 * u_sum * d_fa * i1 / (1.0 + i1)
    value += 2.0 * (u * (q_each * 0.5 / (1.0 + i1) + (q[:, None] - q_each) / (5.0 + i3))).sum(axis=1)
    u2 = (u * u).sum(axis=1)
    value += u2 + (u_sum ** 2 - u2) * (1.0 + i2) / (3.0 + i2)
    return value


def _ratio(numerator: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """numerator / denominator where the denominator is positive, else 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = numerator / denominator
    return np.where(denominator > 0, out, 0.0)


def _fold(state: _RState, p: np.ndarray, p_fa: np.ndarray, r: np.ndarray, union: bool, last: bool,
          betp: bool) -> tuple[_RState, np.ndarray]:
    """One fold of the R-weighted rule (SPEC A.4) with a Bayesian cue, by element class.

    ``last``: keep only the owner's θ_J and θ_J ∪ FA (O(τ) per row); otherwise every s_i and
    u_i, with the O(τ²) pass.  Returns the new state and the rows left to the general path.
    """
    owner = state.owner
    n, tau = p.shape
    rows = np.arange(n)
    s, u, f, e, q, v = state.s, state.u, state.f, state.e, state.q, state.v
    rho = 1.0 - r
    kept = r if union else np.zeros(n)                       # R·k of an element against FA stays (union)
    total_p = p.sum(axis=1)
    s_sum = s.sum(axis=1)
    u_sum = u.sum(axis=1)
    w = s * p + u * p                                        # m0(θ_i), unnormalised; = consensus on θ_i
    w_fa = (f + u_sum + v) * p_fa                            # m0(FA)
    support = s + p                                          # fallback weight of θ_i (SPEC A.4)
    # Rows whose fallback is not a sum over the targets (θ_S/FA or θ_S ∪ FA/θ_l without m0 weight).
    flagged = ((q > 0) & (p_fa > 0) & ~(w_fa > 0)) | ((v > 0) & ((p > 0) & ~(w + w_fa[:, None] > 0)).any(axis=1))
    half = np.where(w_fa > 0, 0.5, 0.0)                      # θ_S/FA: m0(FA) = m0(π0(θ_S ∪ FA)), m0(θ_S) = 0

    # θ_i against FA: k_i = s_i p_F + f p_i, to θ_i : FA (: θ_i ∪ FA on fallback).
    k_fa = s * p_fa[:, None] + f[:, None] * p
    weight_total = w + w_fa[:, None]
    plain = weight_total > 0
    fallback_total = support + (f + p_fa)[:, None] + u
    to_target = np.where(plain, _ratio(w, weight_total), _ratio(support, fallback_total))
    to_fa = np.where(plain, _ratio(np.broadcast_to(w_fa[:, None], w.shape), weight_total),
                     _ratio(np.broadcast_to((f + p_fa)[:, None], w.shape), fallback_total))
    to_union = np.where(plain, 0.0, np.where(fallback_total > 0, _ratio(u, fallback_total), 1.0))

    # θ_S ∪ FA against θ_l: k = m(θ_S ∪ FA) p_l, to θ_S ∪ FA : θ_l as m0(FA) : m0(θ_l).
    to_fa_union = rho * (p * _ratio(np.broadcast_to(w_fa[:, None], w.shape), w + w_fa[:, None])).sum(axis=1)

    # The pure target intersections: consensus θ_S × θ_l, and R·k of θ_i/θ_l, θ_i∪FA/θ_l, θ_S∪FA/θ_l.
    p_own = p[rows, owner]
    s_own = s[rows, owner]
    u_own = u[rows, owner]
    others_p = np.maximum(total_p - p_own, 0.0)
    new_q = q * total_p + r * (s_sum * total_p - (s * p).sum(axis=1) + u_sum * total_p - (u * p).sum(axis=1)
                               + v * total_p)
    new_q_own = (state.q_own * total_p + np.maximum(q - state.q_own, 0.0) * p_own
                 + r * (s_own * others_p + p_own * np.maximum(s_sum - s_own, 0.0)
                        + u_own * others_p + p_own * np.maximum(u_sum - u_own, 0.0)
                        + state.v_own * total_p + np.maximum(v - state.v_own, 0.0) * p_own))
    # θ_S ∪ FA: R·k of θ_S/FA (union), half of (1 − R)·k of θ_S/FA, and what θ_S ∪ FA keeps against θ_l.
    from_pairs = kept + rho * half
    new_v = v * to_fa_union + from_pairs * q * p_fa
    new_v_own = state.v_own * to_fa_union + from_pairs * state.q_own * p_fa
    new_f = (f + u_sum + v) * p_fa + rho * (k_fa * to_fa).sum(axis=1) + rho * half * q * p_fa
    new_e = e + (0.0 if union else r * (k_fa.sum(axis=1) + q * p_fa))

    # θ_i ∪ FA: R·k of θ_i/FA (union) and the fallback shares.
    new_u = kept[:, None] * k_fa + rho[:, None] * k_fa * to_union
    # θ_j ∪ FA against θ_i: all of (1 − R)·k to θ_i when m0(θ_i) > 0; else σ_i : u_j (pairwise).
    zero_w = ~(w > 0) & (p > 0)
    needs_pairs = zero_w.any(axis=1) & (u_sum > 0)
    if last:
        # Only J's singleton (and θ_J ∪ FA for BetP).
        share = _owner_pair_shares(s, p, w, support, owner)
        s8 = np.where(w[rows, owner] > 0, p_own * np.maximum(u_sum - u_own, 0.0),
                      p_own * support[rows, owner] * _others_sum(_ratio(u, u + support[rows, owner][:, None]), owner))
        new_s_own = (w[rows, owner] + rho * (share + k_fa[rows, owner] * to_target[rows, owner]) + rho * s8
                     + rho * v * p_own * _ratio(w[rows, owner], w_fa + w[rows, owner]))
        u_extra_own = np.zeros(n)
        u_extra_all = np.zeros(n)
        if betp and needs_pairs.any():
            sub = np.flatnonzero(needs_pairs)
            extra = _union_fallback(u[sub], p[sub], support[sub], zero_w[sub])
            u_extra_all[sub] = extra.sum(axis=1)
            u_extra_own[sub] = extra[np.arange(sub.size), owner[sub]]
        new_u_own = new_u[rows, owner] + rho * u_extra_own
        result = _RState(owner, new_s_own[:, None], new_u_own[:, None], new_f, new_e, new_q, new_q_own, new_v,
                         new_v_own, u_total=new_u.sum(axis=1) + rho * u_extra_all)
        return result, flagged
    share = _pair_shares(s, p, w, support)
    s8 = np.where(w > 0, p * np.maximum(u_sum[:, None] - u, 0.0), 0.0)
    if needs_pairs.any():
        sub = np.flatnonzero(needs_pairs)
        s8[sub] += _target_fallback(u[sub], p[sub], support[sub], zero_w[sub])
        new_u[sub] += rho[sub, None] * _union_fallback(u[sub], p[sub], support[sub], zero_w[sub])
    new_s = (w + rho[:, None] * (share + k_fa * to_target + s8)
             + (rho * v)[:, None] * p * _ratio(w, w + w_fa[:, None]))
    result = _RState(owner, new_s, new_u, new_f, new_e, new_q, new_q_own, new_v, new_v_own)
    if not q.any() and not u.any() and not v.any():
        # First fold: every θ_S is a pair θ_i ∩ θ_l with mass R·k_il, k_il = s_i p_l + s_l p_i.
        result.q_each = r[:, None] * (s * np.maximum(total_p[:, None] - p, 0.0)
                                      + p * np.maximum(s_sum[:, None] - s, 0.0))
        sp = s * p
        squares = ((s * s).sum(axis=1) * (p * p).sum(axis=1) - (sp * sp).sum(axis=1)
                   + sp.sum(axis=1) ** 2 - (sp * sp).sum(axis=1))                    # Σ_{i<l} k_il²
        result.q_squares = r * r * np.maximum(squares, 0.0)
    return result, flagged


def _others_sum(values: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """Σ_{j≠J} values[:, j] per row."""
    return values.sum(axis=1) - values[np.arange(owner.size), owner]


def _owner_pair_shares(s: np.ndarray, p: np.ndarray, w: np.ndarray, support: np.ndarray,
                       owner: np.ndarray) -> np.ndarray:
    """Σ_{l≠J} k_Jl · m0(θ_J) / (m0(θ_J) + m0(θ_l)), with the support fallback; O(τ) per row."""
    rows = np.arange(owner.size)
    s_own, p_own, w_own, g_own = s[rows, owner], p[rows, owner], w[rows, owner], support[rows, owner]
    k = s_own[:, None] * p + p_own[:, None] * s
    total = w_own[:, None] + w
    share = np.where(total > 0, _ratio(np.broadcast_to(w_own[:, None], w.shape), total),
                     _ratio(np.broadcast_to(g_own[:, None], w.shape), g_own[:, None] + support))
    share[rows, owner] = 0.0
    return (k * share).sum(axis=1)


def _pair_shares(s: np.ndarray, p: np.ndarray, w: np.ndarray, support: np.ndarray) -> np.ndarray:
    """Σ_{l≠i} k_il · m0(θ_i) / (m0(θ_i) + m0(θ_l)) for every i, with the support fallback.

    k_il = s_i p_l + s_l p_i, so the sum is s_i (M p)_i + p_i (M s)_i with
    M_il = w_i / (w_i + w_l): one (τ, τ) matrix per row, built block by block.  A pair without
    m0 weight (w_i = w_l = 0) is split as σ_i : σ_l instead (SPEC A.4); its k_il is positive
    only if one of the two targets has running mass and the other cue mass (then neither has
    both), which picks the few rows that need that second pass.
    """
    out = _share_products(w, s, p, None)
    absent = ~(w > 0)
    pending = (absent & (s > 0)).any(axis=1) & (absent & (p > 0)).any(axis=1)
    if pending.any():
        rows = np.flatnonzero(pending)
        out[rows] += _share_products(support[rows], s[rows], p[rows], absent[rows])
    return out


def _share_products(weights: np.ndarray, s: np.ndarray, p: np.ndarray, members: np.ndarray | None) -> np.ndarray:
    """s_i Σ_l p_l M_il + p_i Σ_l s_l M_il, M_il = x_i / (x_i + x_l) over members i ≠ l (0 if x_i + x_l = 0).

    The ratio is formed before it multiplies k (it is at most 1), so subnormal weights cannot overflow.
    """
    n, tau = s.shape
    out = np.empty((n, tau))
    block = max(1, BLOCK_ENTRIES // max(tau * tau, 1))
    diagonal = np.arange(tau)
    for start in range(0, n, block):
        rows = slice(start, start + block)
        x = weights[rows] if members is None else np.where(members[rows], weights[rows], 0.0)
        total = x[:, :, None] + x[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            matrix = x[:, :, None] / total
        matrix[~(total > 0)] = 0.0
        if members is not None:
            matrix *= members[rows][:, :, None]
            matrix *= members[rows][:, None, :]
        matrix[:, diagonal, diagonal] = 0.0
        product = np.matmul(matrix, np.stack([p[rows], s[rows]], axis=2))              # (b, τ, 2)
        out[rows] = s[rows] * product[:, :, 0] + p[rows] * product[:, :, 1]
    return out


def _union_pairs(u: np.ndarray, support: np.ndarray, zero_w: np.ndarray) -> np.ndarray:
    """G_ij = 1 / (u_j + σ_i) for targets i without m0 weight and j ≠ i, else 0; shape (n, τ, τ)."""
    tau = u.shape[1]
    total = support[:, :, None] + u[:, None, :]
    g = _ratio(np.ones_like(total), total)
    g *= zero_w[:, :, None]
    g[:, np.arange(tau), np.arange(tau)] = 0.0
    return g


def _target_fallback(u: np.ndarray, p: np.ndarray, support: np.ndarray, zero_w: np.ndarray) -> np.ndarray:
    """θ_i's fallback share of the pairs θ_j ∪ FA/θ_i: p_i σ_i Σ_j u_j / (u_j + σ_i), per (1 − R)."""
    g = _union_pairs(u, support, zero_w)
    return p * support * np.einsum("nij,nj->ni", g, u)


def _union_fallback(u: np.ndarray, p: np.ndarray, support: np.ndarray, zero_w: np.ndarray) -> np.ndarray:
    """θ_j ∪ FA's fallback share of the pairs θ_j ∪ FA/θ_i: u_j² Σ_i p_i / (u_j + σ_i), per (1 − R)."""
    g = _union_pairs(u, support, zero_w)
    return u * u * np.einsum("nij,ni->nj", g, p)
