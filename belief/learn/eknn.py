"""Denœux's evidential k-nearest-neighbour classifier, :class:`EKNN`, and the closed form of its fusion."""

from __future__ import annotations

import math

import numpy as np

from belief.batch import MassBatch
from belief.frame import Frame
import belief.learn.distances as distances
from belief.learn.inputs import (LearningDataError, LearningOptionError, NotFittedError, check_rows, hypothesis_names,
                                 is_integer, is_real)
from belief.model import Model

__all__ = ["EKNN", "NEIGHBOUR_SEARCHES", "QUERY_BLOCK_ROWS", "GAMMA_FLOOR", "LONGEST_LOG_STEP"]

#: The neighbour searches of :class:`EKNN`: ``"kdtree"`` needs scipy, ``"blocked"`` is numpy only.
NEIGHBOUR_SEARCHES = ("auto", "kdtree", "blocked")
#: Query rows handled at once by :meth:`EKNN.predict_mass` (the k-d tree answers them in one call).
QUERY_BLOCK_ROWS = 65_536
#: The smallest γ that ``optimize`` reaches (as in evtools-dst).
GAMMA_FLOOR = 1e-4
#: The largest change of ln γ in one step of ``optimize``.
LONGEST_LOG_STEP = 1.0


# -- the closed form of the fusion ------------------------------------------------------------------
def _evidence_weights(sq_dist: np.ndarray, neighbour_class: np.ndarray, gamma: np.ndarray, alpha: float,
                      n_classes: int) -> tuple[np.ndarray, np.ndarray]:
    """Supports s_i = α exp(−γ_c² d_i²) of the neighbours, shape (N, k), and the weight of evidence per class.

    The weight of class c is w_c = −Σ_{i of class c} ln(1 − s_i), shape (N, M): fusing simple support
    functions that all point at {c} multiplies their masses on Θ, so it adds these logarithms.
    """
    n_rows, k = sq_dist.shape
    support = alpha * np.exp(-(gamma[neighbour_class] ** 2) * sq_dist)
    weights = -np.log1p(-support)
    cells = (np.arange(n_rows)[:, None] * n_classes + neighbour_class).ravel()
    per_class = np.bincount(cells, weights=weights.ravel(), minlength=n_rows * n_classes)
    return support, per_class.reshape(n_rows, n_classes)


def _fused_masses(class_weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Dempster's combination of the neighbours' simple support functions, from the weights of evidence.

    With P_c = exp(−w_c) the mass left on Θ by the neighbours of class c, the unnormalised result is
    m({c}) ∝ (1 − P_c) Π_{c' ≠ c} P_c' and m(Θ) ∝ Π_c P_c.  Dividing both by Π_c P_c and by
    exp(w_max) keeps every term in [0, 1], so that many close neighbours neither underflow nor
    overflow: m({c}) ∝ exp(w_c − w_max)(1 − exp(−w_c)), m(Θ) ∝ exp(−w_max).

    Returns
    -------
    masses : ndarray, shape (N, M + 1)
        m({c_1}), …, m({c_M}), m(Θ) per row.
    scaled_total : ndarray, shape (N,)
        The normaliser Z times exp(−w_max) / Π_c P_c, which the gradient of the training cost needs.
    """
    top = class_weight.max(axis=1, keepdims=True)
    singles = np.exp(class_weight - top) * -np.expm1(-class_weight)
    theta = np.exp(-top)
    total = singles.sum(axis=1, keepdims=True) + theta
    masses = np.empty((class_weight.shape[0], class_weight.shape[1] + 1))
    np.divide(singles, total, out=masses[:, :-1])
    np.divide(theta, total, out=masses[:, -1:])
    return masses, total[:, 0]


# -- the classifier --------------------------------------------------------------------------------------
class EKNN:
    """Denœux's evidential k-nearest-neighbour classifier.

    Neighbour i of a query, a training row of class c at Euclidean distance d_i, is a simple
    support function: m_i({c}) = α exp(−γ_c² d_i²) and m_i(Θ) = 1 − m_i({c}), where Θ is the frame
    of the class labels under Shafer's model.  The k nearest neighbours are fused by Dempster's
    rule (SPEC A.3), in closed form: with P_c = Π_{i of class c} (1 − m_i({c})) the mass that
    class c's neighbours leave on Θ,

        m({c}) = (1 − P_c) Π_{c' ≠ c} P_c' / Z,   m(Θ) = Π_c P_c / Z,

    and Z the sum of these numerators (one minus the conflict).  Each query row thus gets a
    mass function whose focal elements are the singletons and Θ.

    Parameters
    ----------
    k : int
        Number of neighbours, k ≥ 1.
    alpha : float
        The most mass a neighbour can give its class, 0 ≤ α < 1 (Denœux suggests 0.95).  With
        α < 1 no neighbour is certain, so the fusion never meets total conflict.
    gamma : None, float or array_like of shape (M,)
        The rate γ_c at which a neighbour's support fades with distance, per class in the order of
        :attr:`classes_`.  None takes the default of Denœux's evclass package (and of
        evtools-dst): γ_c² = 1 / (mean Euclidean distance between two training rows of class c),
        γ_c = 1 for a class of fewer than two distinct rows.  With ``optimize`` it is the start.
    optimize : bool
        Learn γ by minimising the leave-one-out cost of Zouhal and Denœux (1998) on the training set,
        (1 / 2n) Σ_rows Σ_c (m({c}) + λ m(Θ) − [y = c])², each training row classified by its k
        nearest other rows; λ is ``ignorance_weight``.  Quasi-Newton steps on ln γ (numpy only).
    ignorance_weight : float
        λ ∈ [0, 1], the share of m(Θ) that counts for each class in that cost: 1 compares the
        plausibilities with the labels (the default of evtools-dst), 1/M the pignistic
        probabilities (Zouhal and Denœux's choice), 0 the beliefs.
    max_iter : int
        The most quasi-Newton steps of ``optimize``.
    neighbours : {"auto", "kdtree", "blocked"}
        How the neighbours are found: a ``scipy.spatial.cKDTree`` (needs scipy), a numpy search
        over blocks of query rows, or the tree when scipy is installed.  Both give the same
        neighbours except for rows at equal distance.
    threads : int or None
        Threads for the distances of the default γ and for the k-d tree's queries; None for one
        per core.  The results do not depend on it.

    Attributes
    ----------
    classes_ : ndarray, shape (M,)
        The sorted class labels (``numpy.unique`` of ``y``).
    frame_ : Frame
        The frame of the masses: the labels written as strings, in the order of ``classes_``.
    model_ : Model
        Shafer's model of ``frame_``.
    gamma_ : ndarray, shape (M,)
        The γ_c used.
    loo_cost_ : float
        With ``optimize``, the leave-one-out cost at ``gamma_`` (NaN otherwise).
    n_features_in_ : int
        p, the number of features.

    Examples
    --------
    Two classes on a line, three neighbours, γ = 1 for both:

    >>> clf = EKNN(k=3, alpha=0.9, gamma=1.0).fit([[0.0], [1.0], [3.0], [4.0]], ["a", "a", "b", "b"])
    >>> masses = clf.predict_mass([[1.5]])
    >>> [str(x) for x in masses.focal]
    ['a', 'b', 'a|b']
    >>> masses.values.round(4)
    array([[0.7092, 0.0276, 0.2632]])
    >>> clf.predict([[1.5], [3.2]])
    array(['a', 'b'], dtype='<U1')

    By hand: the neighbours lie at 0.5 (a), 1.5 (a) and 1.5 (b), with supports
    s = 0.9 e^{−0.25} = 0.7009 and 0.9 e^{−2.25} = 0.0949.  Class a leaves
    P_a = 0.2991 × 0.9051 = 0.2707 on Θ, class b leaves P_b = 0.9051, so m({a}) ∝ 0.7293 × 0.9051 = 0.6601,
    m({b}) ∝ 0.0949 × 0.2707 = 0.0257 and m(Θ) ∝ 0.2707 × 0.9051 = 0.2450, which Z = 0.9308 divides.
    """

    def __init__(self, k: int = 5, alpha: float = 0.95, gamma=None, optimize: bool = False, *,
                 ignorance_weight: float = 1.0, max_iter: int = 100, neighbours: str = "auto",
                 threads: int | None = None) -> None:
        self.k = k
        self.alpha = alpha
        self.gamma = gamma
        self.optimize = optimize
        self.ignorance_weight = ignorance_weight
        self.max_iter = max_iter
        self.neighbours = neighbours
        self.threads = threads

    def __repr__(self) -> str:
        return (f"EKNN(k={self.k!r}, alpha={self.alpha!r}, gamma={self.gamma!r}, optimize={self.optimize!r})")

    # -- checks --------------------------------------------------------------------------------------
    def _check_options(self, n_rows: int, n_classes: int) -> None:
        if not is_integer(self.k) or self.k < 1:
            raise LearningOptionError(f"k must be a positive integer, got {self.k!r}")
        if self.k > n_rows:
            raise LearningOptionError(f"k = {self.k} neighbours, but there are only {n_rows} training rows")
        if self.optimize and self.k >= n_rows:
            raise LearningOptionError(f"optimize=True leaves each training row out, so k = {self.k} must be below "
                                      f"the {n_rows} training rows")
        alpha = self.alpha
        if not is_real(alpha) or not 0.0 <= alpha < 1.0:
            raise LearningOptionError(f"alpha must be a number with 0 <= alpha < 1, got {alpha!r}")
        weight = self.ignorance_weight
        if not is_real(weight) or not 0.0 <= weight <= 1.0:
            raise LearningOptionError(f"ignorance_weight (λ) must be a number in [0, 1], got {weight!r}")
        if not is_integer(self.max_iter) or self.max_iter < 0:
            raise LearningOptionError(f"max_iter must be a non-negative integer, got {self.max_iter!r}")
        if self.threads is not None and (not is_integer(self.threads) or self.threads < 1):
            raise LearningOptionError(f"threads must be None or a positive integer, got {self.threads!r}")
        if self.neighbours not in NEIGHBOUR_SEARCHES:
            raise LearningOptionError(f"neighbours must be one of {', '.join(NEIGHBOUR_SEARCHES)}; "
                                      f"got {self.neighbours!r}")
        if self.neighbours == "kdtree" and distances.scipy_spatial() is None:
            raise LearningOptionError("neighbours='kdtree' needs scipy; install it or use neighbours='blocked'")

    def _given_gamma(self, n_classes: int) -> np.ndarray | None:
        if self.gamma is None:
            return None
        try:
            gamma = np.array(self.gamma, dtype=np.float64)
        except (TypeError, ValueError):
            raise LearningOptionError(f"gamma must be None, a number or one number per class, got {self.gamma!r}") \
                from None
        if np.asarray(self.gamma).dtype == bool:
            raise LearningOptionError(f"gamma must hold numbers, not booleans: {self.gamma!r}")
        if gamma.ndim == 0:
            gamma = np.full(n_classes, float(gamma))
        if gamma.shape != (n_classes,):
            raise LearningOptionError(f"gamma must be a number or one number per class ({n_classes}), "
                                      f"got shape {gamma.shape}")
        if not (np.isfinite(gamma).all() and (gamma >= 0).all()):
            raise LearningOptionError(f"every γ must be a finite number >= 0, got {gamma.tolist()}")
        return gamma

    # -- fit / predict -------------------------------------------------------------------------------
    def fit(self, X, y) -> "EKNN":
        """Keep the training rows, index them for the neighbour search and set γ.

        Parameters
        ----------
        X : array_like, shape (n, p)
            Training rows, finite numbers.
        y : array_like, shape (n,)
            Their class labels; at least two distinct ones.  A label becomes a hypothesis name by
            ``str``, so it must be a valid one (no white space, none of ``( ) & | ∩ ∪ ∅ ,``).

        Returns
        -------
        EKNN
            The classifier itself.

        Raises
        ------
        LearningDataError
            Bad rows or labels.
        LearningOptionError
            An option out of range.
        """
        X = check_rows(X, "X")
        labels = np.asarray(y)
        if labels.ndim != 1 or labels.shape[0] != X.shape[0]:
            raise LearningDataError(f"y must hold one label per row of X, shape ({X.shape[0]},), got {labels.shape}")
        if labels.dtype.kind == "f" and np.isnan(labels).any():
            raise LearningDataError(f"y holds NaN in row {int(np.flatnonzero(np.isnan(labels))[0])}; every row "
                                    "needs a label")
        if labels.dtype == object and any(label is None for label in labels.tolist()):
            raise LearningDataError("y holds None; every row needs a label")
        try:
            classes, class_index = np.unique(labels, return_inverse=True)
        except TypeError as err:
            raise LearningDataError(f"the labels of y cannot be sorted: {err}") from None
        if classes.shape[0] < 2:
            raise LearningDataError(f"y must hold at least two classes, got {classes.tolist()!r}")
        names = hypothesis_names(classes.tolist())
        self._check_options(X.shape[0], classes.shape[0])
        search = self.neighbours
        if search == "auto":
            search = "kdtree" if distances.scipy_spatial() is not None else "blocked"

        self.classes_ = classes
        self.frame_ = Frame(list(names))
        self.model_ = Model.shafer(self.frame_)
        self.n_features_in_ = X.shape[1]
        self._train = X
        self._class_index = class_index.reshape(-1).astype(np.intp)
        self._search = search
        self._tree = distances.scipy_spatial().cKDTree(X) if search == "kdtree" else None
        gamma = self._given_gamma(classes.shape[0])
        if gamma is None:
            gamma = distances.default_gamma(X, self._class_index, classes.shape[0], use_scipy=search == "kdtree",
                                  threads=self.threads)
        self.loo_cost_ = math.nan
        if self.optimize:
            gamma, self.loo_cost_ = self._optimized_gamma(gamma)
        self.gamma_ = gamma
        return self

    def _nearest(self, queries: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Indices (N, k) of the k nearest training rows and their squared distances, nearest first."""
        if self._tree is None:
            return distances.nearest_blocked(self._train, queries, k)
        distance, index = self._tree.query(queries, k=k, workers=distances.thread_count(self.threads, queries.shape[0]))
        if k == 1:
            distance, index = distance[:, None], index[:, None]
        return index, distance ** 2

    def _check_fitted(self) -> None:
        if not hasattr(self, "gamma_"):
            raise NotFittedError("this EKNN is not fitted yet; call fit(X, y) first")

    def predict_mass(self, X) -> MassBatch:
        """The fused mass function of each query row.

        Parameters
        ----------
        X : array_like, shape (N, p)
            Query rows, with the p features of the training rows.

        Returns
        -------
        MassBatch
            N rows over the M + 1 focal elements {c_1}, …, {c_M}, Θ, under Shafer's model of
            :attr:`frame_`.  Rows are handled :data:`QUERY_BLOCK_ROWS` at a time, and the numpy
            search compares at most :data:`DISTANCE_BLOCK_ENTRIES` pairs at once.

        Raises
        ------
        NotFittedError
            Before :meth:`fit`.
        LearningDataError
            Rows that are not finite numbers, or a number of features other than the training rows'.
        """
        self._check_fitted()
        queries = check_rows(X, "X", self.n_features_in_)
        n_classes = self.classes_.shape[0]
        values = np.empty((queries.shape[0], n_classes + 1))
        for first in range(0, queries.shape[0], QUERY_BLOCK_ROWS):
            block = queries[first:first + QUERY_BLOCK_ROWS]
            index, sq_dist = self._nearest(block, self.k)
            _, weight = _evidence_weights(sq_dist, self._class_index[index], self.gamma_, float(self.alpha), n_classes)
            values[first:first + block.shape[0]] = _fused_masses(weight)[0]
        focal = (*self.frame_.singletons, self.model_.total)
        return MassBatch(focal, values, model=self.model_, validate=False)

    def predict(self, X) -> np.ndarray:
        """The label of largest pignistic probability BetP({c}) = m({c}) + m(Θ) / M for each query row.

        Parameters
        ----------
        X : array_like, shape (N, p)

        Returns
        -------
        ndarray, shape (N,)
            Labels taken from :attr:`classes_`; a tie goes to the first class in that order.
        """
        masses = self.predict_mass(X)
        betp = masses.betp(list(self.frame_.singletons))
        return self.classes_[np.argmax(betp, axis=1)]

    # -- learning γ --------------------------------------------------------------------------------------
    def _leave_one_out(self) -> tuple[np.ndarray, np.ndarray]:
        """The k nearest other rows of each training row: classes (n, k) and squared distances (n, k).

        The first of k + 1 neighbours is dropped: the row itself, or a duplicate of it at distance 0.
        """
        index, sq_dist = self._nearest(self._train, self.k + 1)
        return self._class_index[index[:, 1:]], sq_dist[:, 1:]

    def loo_cost(self, gamma) -> float:
        """The leave-one-out cost of ``optimize`` at the given γ, shape (M,), on the training rows.

        (1 / 2n) Σ_rows Σ_c (m({c}) + λ m(Θ) − [y = c])², each training row's masses fused from its
        k nearest other rows.
        """
        self._check_fitted()
        classes, sq_dist = self._leave_one_out()
        return self._cost_and_gradient(np.log(np.asarray(gamma, dtype=np.float64)), classes, sq_dist)[0]

    def _cost_and_gradient(self, log_gamma: np.ndarray, classes: np.ndarray,
                           sq_dist: np.ndarray) -> tuple[float, np.ndarray]:
        """The leave-one-out cost and its gradient with respect to ln γ, shape (M,).

        With w_c the weight of evidence of class c (:func:`_evidence_weights`) and T_c = m({c}) + λ m(Θ),
        ∂w_q/∂ln γ_q = −2 γ_q² Σ_{i of class q} d_i² s_i / (1 − s_i); the numerator u_q = e^{w_q} − 1 of
        m({q}) has ∂u_q/∂w_q = e^{w_q}; and ∂T_c/∂u_q = ([c = q] − T_c) / Z.
        """
        n_rows, n_classes = sq_dist.shape[0], self.classes_.shape[0]
        gamma = np.exp(np.clip(log_gamma, -50.0, 50.0))
        support, weight = _evidence_weights(sq_dist, classes, gamma, float(self.alpha), n_classes)
        masses, total = _fused_masses(weight)
        lam = float(self.ignorance_weight)
        transformed = masses[:, :-1] + lam * masses[:, -1:]
        target = np.zeros((n_rows, n_classes))
        target[np.arange(n_rows), self._class_index] = 1.0
        residual = transformed - target
        cost = 0.5 * float((residual ** 2).sum()) / n_rows
        # ∂cost/∂numerator_q, times the numerator's own derivative e^{w_q} (scaled by e^{−w_max} like Z).
        slope = (residual - (residual * transformed).sum(axis=1, keepdims=True)) / total[:, None]
        slope *= np.exp(weight - weight.max(axis=1, keepdims=True))
        share = sq_dist * support / (1.0 - support)
        cells = (np.arange(n_rows)[:, None] * n_classes + classes).ravel()
        fading = np.bincount(cells, weights=share.ravel(), minlength=n_rows * n_classes).reshape(n_rows, n_classes)
        gradient = (slope * fading).sum(axis=0) * (-2.0 * gamma ** 2) / n_rows
        return cost, gradient

    def _optimized_gamma(self, start: np.ndarray) -> tuple[np.ndarray, float]:
        """γ minimising the leave-one-out cost, by BFGS steps on ln γ with a backtracking line search.

        γ stays at or above :data:`GAMMA_FLOOR` (the bound of evtools-dst): below it a class's support
        hardly depends on distance any more, the cost is flat and the search would wander.  A step
        changes ln γ by at most :data:`LONGEST_LOG_STEP`, for the same reason.
        """
        classes, sq_dist = self._leave_one_out()
        floor = math.log(GAMMA_FLOOR)
        x = np.log(np.maximum(start, GAMMA_FLOOR))

        def evaluate(point):
            return self._cost_and_gradient(point, classes, sq_dist)

        cost, gradient = evaluate(x)
        inverse_hessian = np.eye(x.size)
        for _ in range(int(self.max_iter)):
            # A γ on the floor that would go lower is held there; the others move.
            free = ~((x <= floor) & (gradient > 0))
            if np.max(np.abs(gradient * free)) < 1e-10:
                break
            direction = -(inverse_hessian @ (gradient * free)) * free
            slope = float(gradient @ direction)
            if slope >= 0:                           # not a descent direction: restart from steepest descent
                inverse_hessian = np.eye(x.size)
                direction = -gradient * free
                slope = float(gradient @ direction)
            longest = np.max(np.abs(direction))
            if longest > LONGEST_LOG_STEP:
                direction *= LONGEST_LOG_STEP / longest
            step = 1.0
            while True:
                trial = np.maximum(x + step * direction, floor)
                trial_cost, trial_gradient = evaluate(trial)
                if trial_cost <= cost + 1e-4 * float(gradient @ (trial - x)):
                    break
                step *= 0.5
                if step < 1e-12:
                    return np.exp(x), cost
            moved, turned = trial - x, trial_gradient - gradient
            curvature = float(moved @ turned)
            if curvature > 1e-18:
                rho = 1.0 / curvature
                left = np.eye(x.size) - rho * np.outer(moved, turned)
                inverse_hessian = left @ inverse_hessian @ left.T + rho * np.outer(moved, moved)
            improvement = cost - trial_cost
            x, cost, gradient = trial, trial_cost, trial_gradient
            if improvement <= 1e-15 * max(1.0, abs(cost)):
                break
        return np.exp(x), cost
