"""Distances for :mod:`belief.learn`: the mean distance within a class (the default γ) and the k nearest rows.

Neither builds a matrix of all the distances at once: the mean distance works on blocks of
:data:`PAIR_BLOCK_ROWS` rows, the numpy neighbour search on blocks of query rows of at most
:data:`DISTANCE_BLOCK_ENTRIES` distances.  scipy, where installed, computes the blocks faster; it is
imported on first use and never required.
"""

from __future__ import annotations

import math
import os

import numpy as np

__all__ = ["mean_pairwise_distance", "default_gamma", "nearest_blocked", "block_distances", "scipy_spatial",
           "thread_count", "PAIR_BLOCK_ROWS", "DISTANCE_BLOCK_ENTRIES"]

#: Distances held at once by the numpy neighbour search: a block of queries times the training rows.
DISTANCE_BLOCK_ENTRIES = 1_000_000
#: Rows of one class compared at once for the default γ: blocks of PAIR_BLOCK_ROWS² distances (8 MB).
PAIR_BLOCK_ROWS = 1024


def scipy_spatial():
    """scipy.spatial if scipy is installed, else None: scipy only makes things faster."""
    try:
        import scipy.spatial
        import scipy.spatial.distance
    except ImportError:  # pragma: no cover - the test venv has scipy; the numpy paths are tested by name
        return None
    return scipy.spatial


def block_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distances between the rows of a (n_a, p) and b (n_b, p), shape (n_a, n_b), from differences.

    Differences, not the expansion |a|² + |b|² − 2a·b, which loses the distances of close rows.
    """
    squares = np.zeros((a.shape[0], b.shape[0]))
    step = np.empty_like(squares)
    for feature in range(a.shape[1]):
        np.subtract(a[:, feature, None], b[None, :, feature], out=step)
        step *= step
        squares += step
    return np.sqrt(squares, out=squares)


def mean_pairwise_distance(rows: np.ndarray, use_scipy: bool = True, threads: int | None = 1) -> float:
    """The mean Euclidean distance over the n(n − 1)/2 pairs of rows, without an (n, n) matrix.

    Parameters
    ----------
    rows : ndarray, shape (n, p)
        n ≥ 2 rows.
    use_scipy : bool
        Use ``scipy.spatial.distance.cdist`` on each block when scipy is installed (faster);
        otherwise numpy.  Both compute each distance from the differences of the rows.
    threads : int or None
        Threads that compute blocks side by side (both kernels release the GIL); None for one per
        core.  The blocks' sums are added in one fixed order, so the result does not depend on it.

    Returns
    -------
    float
        (2 / (n (n − 1))) Σ_{i<j} ‖x_i − x_j‖, summed block by block over blocks of
        :data:`PAIR_BLOCK_ROWS` rows: a diagonal block holds each pair twice, a block above it once.

    Examples
    --------
    >>> mean_pairwise_distance(np.array([[0.0, 0.0], [3.0, 4.0], [6.0, 8.0]]))  # (5 + 10 + 5) / 3
    6.666666666666667
    """
    spatial = scipy_spatial() if use_scipy else None
    distances = spatial.distance.cdist if spatial is not None else block_distances
    n = rows.shape[0]
    # Centred rows keep the block sums in the scale of the spread, whatever the offset of the data.
    rows = rows - rows.mean(axis=0)
    size = PAIR_BLOCK_ROWS
    pairs = [(first, second) for first in range(0, n, size) for second in range(first, n, size)]

    def block_sum(pair: tuple[int, int]) -> float:
        first, second = pair
        total = float(distances(rows[first:first + size], rows[second:second + size]).sum())
        return 0.5 * total if first == second else total

    workers = thread_count(threads, len(pairs))
    if workers == 1:
        sums = [block_sum(pair) for pair in pairs]
    else:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(workers) as pool:
            sums = list(pool.map(block_sum, pairs))
    return math.fsum(sums) / (n * (n - 1) / 2)


def thread_count(threads: int | None, tasks: int) -> int:
    """The threads to use for ``tasks`` pieces of work: ``threads``, or one per core for None."""
    if threads is None:
        try:
            threads = len(os.sched_getaffinity(0))
        except AttributeError:  # pragma: no cover - not on Linux
            threads = os.cpu_count() or 1
    return max(1, min(int(threads), tasks))


def default_gamma(X: np.ndarray, class_index: np.ndarray, n_classes: int, use_scipy: bool = True,
                  threads: int | None = 1) -> np.ndarray:
    """The per-class γ of Denœux's evclass package and of evtools-dst: γ_c = 1 / √(mean distance in class c).

    Parameters
    ----------
    X : ndarray, shape (n, p)
        Training rows.
    class_index : ndarray of int, shape (n,)
        The class of each row, 0 to M − 1.
    n_classes : int
        M.
    use_scipy, threads :
        As for :func:`mean_pairwise_distance`.

    Returns
    -------
    ndarray, shape (M,)
        γ_c² = 1 / (mean Euclidean distance, not squared, between two rows of class c); γ_c = 1
        for a class of fewer than two rows or of identical rows.

    Examples
    --------
    >>> default_gamma(np.array([[0.0], [4.0], [1.0]]), np.array([0, 0, 1]), 2)  # class 0: mean distance 4
    array([0.5, 1. ])
    """
    gamma = np.ones(n_classes)
    for c in range(n_classes):
        members = X[class_index == c]
        if members.shape[0] < 2:
            continue
        mean = mean_pairwise_distance(members, use_scipy=use_scipy, threads=threads)
        if mean > 0:
            gamma[c] = 1.0 / math.sqrt(mean)
    return gamma


def nearest_blocked(train: np.ndarray, queries: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The k nearest training rows of each query by numpy alone, in blocks of queries.

    Returns indices (N, k) and squared distances (N, k), nearest first; ties go to the lower index.
    """
    n_train = train.shape[0]
    rows_at_once = max(1, DISTANCE_BLOCK_ENTRIES // max(n_train, 1))
    index = np.empty((queries.shape[0], k), dtype=np.intp)
    sq_dist = np.empty((queries.shape[0], k))
    for first in range(0, queries.shape[0], rows_at_once):
        block = queries[first:first + rows_at_once]
        distance = block_distances(block, train)
        if k < n_train:
            chosen = np.argpartition(distance, k - 1, axis=1)[:, :k]
            chosen.sort(axis=1)
        else:
            chosen = np.broadcast_to(np.arange(n_train), (block.shape[0], n_train))
        picked = np.take_along_axis(distance, chosen, axis=1)
        order = np.argsort(picked, axis=1, kind="stable")
        index[first:first + block.shape[0]] = np.take_along_axis(chosen, order, axis=1)
        sq_dist[first:first + block.shape[0]] = np.take_along_axis(picked, order, axis=1) ** 2
    return index, sq_dist
