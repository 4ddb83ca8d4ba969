"""Kernel-weighted histograms of many boxes at once: the image features the appearance cues share.

The colour, foreground and edge cues (:mod:`~belief_tracking.cues.colour`,
:mod:`~belief_tracking.cues.foreground`, :mod:`~belief_tracking.cues.edges`) all count,
for every particle's window, the bins of its pixels weighted by the Epanechnikov kernel
(L (9)–(11)): joint RGB bins (:func:`colour_bins`) or gradient orientations weighted by
their magnitude (:func:`orientation_bins`, the HOE of SPEC B.5).  A window is sampled at a
fixed grid of points (:func:`kernel_grid`), so P windows cost P · S look-ups whatever their
size; :func:`sample_boxes`, :func:`sample_slots` and :func:`sample_counts` do it for a block
of windows, and :func:`sparse_rho` reads the Bhattacharyya coefficients (L (12)) off the
few filled bins of each histogram.  :func:`false_alarm_histogram` is q_FA of W (18).

Pixel geometry: pixel (column i, row j) covers [i, i+1) × [j, j+1); a box ``(x, y, w, h)``
has centre ``(x + w/2, y + h/2)``, and a point ``(px, py)`` falls in pixel ``(⌊px⌋, ⌊py⌋)``.
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np

from ..errors import TrackingError

__all__ = ["colour_bins", "orientation_bins", "kernel_grid", "kernel_histograms", "bhattacharyya",
           "false_alarm_histogram", "Sampling", "sample_boxes", "sample_slots", "sample_counts", "FilledBins",
           "filled_bins", "sparse_rho", "MAX_BINS_PER_CHANNEL", "MAX_ORIENTATION_BINS", "HISTOGRAM_BLOCK"]

#: Joint RGB histograms have bins³ bins; 16³ = 4096 (the largest of the papers, C) keeps a
#: (P, B) float array of 800 particles near 26 MB.
MAX_BINS_PER_CHANNEL = 16

#: Residuals of W (18) at most this fraction of the scene are rounding, not colours.
RESIDUAL_TOLERANCE = 1e-12

#: At most this many orientation bins (one per degree); a (P, B) array stays small.
MAX_ORIENTATION_BINS = 360

#: Windows whose histograms are built at once: every temporary of a block (its samples, its
#: dense counts) stays small enough for the allocator to serve from memory it already holds.
HISTOGRAM_BLOCK = 128


def colour_bins(image: np.ndarray, bins: int) -> np.ndarray:
    """The joint-RGB bin of every pixel: r·bins² + g·bins + b, each channel cut into ``bins``.

    A channel value v falls in bin ⌊v · bins / 256⌋, so the bins are equally wide.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W, 3)
        BGR, as OpenCV reads it.
    bins : int
        Bins per channel.

    Returns
    -------
    ndarray of uint16, shape (H, W)
        Values in 0 … bins³ − 1; intp for more than 40 bins per channel, whose bins³ does
        not fit in 16 bits.

    Examples
    --------
    >>> pixel = np.array([[[0, 0, 255], [255, 255, 255]]], np.uint8)     # red, white (BGR)
    >>> colour_bins(pixel, 8).tolist()
    [[448, 511]]
    """
    if bins > 40:
        channels = image.astype(np.intp) * bins >> 8                  # ⌊v·bins/256⌋, exact in integers
        blue, green, red = channels[..., 0], channels[..., 1], channels[..., 2]
        return (red * bins + green) * bins + blue
    # 16 bits hold v·bins and bins³ exactly.  The bin image is read at every sample point of
    # every particle, and a quarter of intp's size keeps it in cache and out of the
    # allocator's mapped blocks.
    if bins & (bins - 1) == 0:                                        # a power of two: ⌊v·bins/256⌋ = v >> shift
        shift = 8 - (bins.bit_length() - 1)
        channels = image >> shift                                     # uint8, a third of the passes' memory
        joint = channels[..., 2].astype(np.uint16)
        joint <<= 8 - shift
        joint |= channels[..., 1]
        joint <<= 8 - shift
        joint |= channels[..., 0]
        return joint
    channels = image.astype(np.uint16)
    channels *= bins
    channels >>= 8                                                    # ⌊v·bins/256⌋
    joint = channels[..., 2] * np.uint16(bins)
    joint += channels[..., 1]
    joint *= bins
    joint += channels[..., 0]
    return joint


def orientation_bins(image: np.ndarray, bins: int = 16, unsigned: bool = False,
                     min_gradient: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """The gradient-orientation bin and the edge weight of every pixel (the HOE of SPEC B.5).

    The grey image 0.299 R + 0.587 G + 0.114 B is differentiated with the 3×3 Sobel kernels
    (borders replicated), x to the right and y *down*; the orientation θ = atan2(g_y, g_x),
    taken in [0, 2π) (in [0, π) when ``unsigned``, so that opposite gradients share a bin),
    is cut into ``bins`` equal bins starting at 0, and the weight is the magnitude
    g = √(g_x² + g_y²) where g ≥ ``min_gradient`` and 0 elsewhere.  The Sobel sums are
    divided by 4, the sum of a kernel's positive taps, so that g is in grey levels: a step of
    s grey levels gives g = s on each side of it, and the default threshold of 10 keeps the
    steps of 10 levels or more while the sensor noise of a few levels stays out.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W, 3)
        BGR, as OpenCV reads it.
    bins : int
        Orientation bins over the full circle (over a half circle when ``unsigned``).
    unsigned : bool
        Fold θ and θ + π together.
    min_gradient : float
        Pixels with a weaker gradient get weight 0 (SPEC: 10).

    Returns
    -------
    bin_image : ndarray of intp, shape (H, W)
        Values in 0 … bins − 1.
    weights : ndarray of float64, shape (H, W)
        g, or 0 below ``min_gradient``.

    Examples
    --------
    A dark left half and a bright right half (grey 200): the gradient points right,
    θ = 0, bin 0, and the two columns beside the step get g = 200:

    >>> image = np.zeros((3, 4, 3), np.uint8)
    >>> image[:, 2:] = 200
    >>> bin_image, weights = orientation_bins(image)
    >>> weights
    array([[  0., 200., 200.,   0.],
           [  0., 200., 200.,   0.],
           [  0., 200., 200.,   0.]])
    >>> bin_image[weights > 0]
    array([0, 0, 0, 0, 0, 0])

    Mirrored, the gradient points left (θ = π, bin 8 of 16), which ``unsigned`` folds back
    onto θ = 0; turned on its side, it points down (θ = π/2, bin 4):

    >>> orientation_bins(image[:, ::-1])[0][weights > 0]
    array([8, 8, 8, 8, 8, 8])
    >>> orientation_bins(image[:, ::-1], unsigned=True)[0][weights > 0]
    array([0, 0, 0, 0, 0, 0])
    >>> orientation_bins(image.transpose(1, 0, 2))[0][weights.T > 0]
    array([4, 4, 4, 4, 4, 4])
    """
    channels = image.astype(np.int64)
    # Integer weights in thousandths: a grey pixel (B = G = R) keeps its exact value.
    grey = (114 * channels[..., 0] + 587 * channels[..., 1] + 299 * channels[..., 2]) / 1000.0
    padded = np.pad(grey, 1, mode="edge")
    left, right = padded[:, :-2], padded[:, 2:]                                  # (H + 2, W)
    across = right - left
    gx = across[:-2] + 2.0 * across[1:-1] + across[2:]
    smooth = left + 2.0 * padded[:, 1:-1] + right
    gy = smooth[2:] - smooth[:-2]
    magnitude = 0.25 * np.sqrt(gx * gx + gy * gy)         # np.hypot and np.mod are several times slower
    period = np.pi if unsigned else 2.0 * np.pi
    # In turns, the axis directions (±π/2, π, …) are exact multiples of 1/4, so they do not
    # fall on the wrong side of a bin boundary by rounding.
    turns = np.arctan2(gy, gx) / period                   # [−1/2, 1/2], or [−1, 1] when unsigned
    turns += turns < 0                                    # [0, 1]
    bin_image = (turns * bins).astype(np.intp)
    bin_image[bin_image >= bins] = 0                      # one turn (θ = π unsigned, or −0 rounded) is 0
    weights = np.where(magnitude >= min_gradient, magnitude, 0.0)
    return bin_image, weights



@lru_cache(maxsize=32)
def kernel_grid(samples: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The sample points of a box and their Epanechnikov weights (L (11), per-axis form).

    A ``w_samples × h_samples`` grid of cell centres u_i = (2i + 1)/n − 1 ∈ (−1, 1) along each
    axis, in units of the half-sizes; the weight is k(r) = 1 − r² with
    r² = u_x² + u_y² (SPEC B.2), and points with k = 0 (the box corners outside the inscribed
    ellipse) are dropped since they add nothing to any histogram.

    Parameters
    ----------
    samples : (int, int)
        Points across and down the box.

    Returns
    -------
    offsets : ndarray, shape (S, 2)
        (u_x, u_y) of the kept points; read-only (shared between calls).
    weights : ndarray, shape (S,)
        Their kernel weights, all > 0.

    Examples
    --------
    >>> offsets, weights = kernel_grid((2, 2))
    >>> offsets
    array([[-0.5, -0.5],
           [ 0.5, -0.5],
           [-0.5,  0.5],
           [ 0.5,  0.5]])
    >>> weights
    array([0.5, 0.5, 0.5, 0.5])
    """
    across, down = samples
    u = (2.0 * np.arange(across) + 1.0) / across - 1.0
    v = (2.0 * np.arange(down) + 1.0) / down - 1.0
    grid_u, grid_v = np.meshgrid(u, v)                                 # row-major: down, then across
    weights = 1.0 - grid_u ** 2 - grid_v ** 2
    keep = weights > 0
    offsets = np.stack([grid_u[keep], grid_v[keep]], axis=1)
    weights = weights[keep]
    offsets.flags.writeable = False
    weights.flags.writeable = False
    return offsets, weights


def kernel_histograms(bin_image: np.ndarray, centres: np.ndarray, box_sizes: np.ndarray, n_bins: int,
                      samples: tuple[int, int], foreground: np.ndarray | None = None, *,
                      pixel_weights: np.ndarray | None = None) -> np.ndarray:
    """Kernel-weighted histograms of P boxes at once (L (9)–(11); L (16)–(17) with a mask; C (8)).

    q(u) = f Σ_i k(r_i) g(x_i) δ[h(x_i) − u] ξ(x_i) with f = 1 / Σ_i k(r_i) g(x_i) (L (10)),
    over the sample points x_i of :func:`kernel_grid` placed in each box; ξ ≡ 1 without a
    mask and g ≡ 1 without pixel weights, which gives the plain f = 1 / Σ_i k(r_i).

    Sample points outside the image are moved to the nearest border pixel, so a box leaving
    the frame keeps a full histogram of the border colours (and of the border pixel weights).
    With a mask they count as background instead (ξ = 0): nothing outside the frame is
    foreground, and keeping them in f is what lowers the score of a box that leaves the
    frame.  The mask never enters f: Σ_u q(u) = F, the kernel-weighted foreground fraction of
    the box, ≤ 1 (SPEC B.4).

    Pixel weights (the gradient magnitudes of a histogram of oriented edges, SPEC B.5) do
    enter f, box by box: every histogram sums to 1 (to F with a mask), except that of a box
    whose sample points all have weight 0, which is all zero — its Bhattacharyya coefficient
    with any reference is then 0, never NaN.

    Parameters
    ----------
    bin_image : ndarray of int, shape (H, W)
        The bin of every pixel (:func:`colour_bins`).
    centres : ndarray, shape (P, 2)
        Box centres (cx, cy).
    box_sizes : ndarray, shape (P, 2)
        Box sizes (w, h), positive.
    n_bins : int
        B, the number of bins (values of ``bin_image`` lie in 0 … B − 1).
    samples : (int, int)
        The grid of :func:`kernel_grid`.
    foreground : ndarray of bool, shape (H, W), optional
        ξ of L (16).
    pixel_weights : ndarray of float, shape (H, W), optional
        g, a non-negative weight per pixel that multiplies the kernel weight of every sample
        point falling in that pixel.

    Returns
    -------
    ndarray, shape (P, B)
        One histogram per box; rows sum to 1 without a mask and to F with one (to 0 for a
        box without any weight).

    Examples
    --------
    The left half of a 4×4 image is in bin 0, the right half in bin 1; a box over the whole
    image splits evenly, and with the right half as foreground only that half is counted:

    >>> bins = np.repeat([[0, 0, 1, 1]], 4, axis=0)
    >>> kernel_histograms(bins, np.array([[2.0, 2.0]]), np.array([[4.0, 4.0]]), 2, (4, 4))
    array([[0.5, 0.5]])
    >>> kernel_histograms(bins, np.array([[2.0, 2.0]]), np.array([[4.0, 4.0]]), 2, (4, 4), foreground=bins == 1)
    array([[0. , 0.5]])

    Weighting the right half 3 times as much as the left moves the split to 1 : 3:

    >>> kernel_histograms(bins, np.array([[2.0, 2.0]]), np.array([[4.0, 4.0]]), 2, (4, 4),
    ...                   pixel_weights=np.where(bins == 1, 3.0, 1.0))
    array([[0.25, 0.75]])
    """
    counts, norms = _kernel_counts(bin_image, centres, box_sizes, n_bins, samples, foreground, pixel_weights)
    return counts.reshape(-1, n_bins) / norms


@lru_cache(maxsize=32)
def _grid_axes(samples: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """The grid of :func:`kernel_grid` by axis: u (across,), v (down,), then each kept point's u and v index.

    The kept points are in the order of :func:`kernel_grid`; all four arrays are read-only.
    """
    across, down = samples
    u = (2.0 * np.arange(across) + 1.0) / across - 1.0
    v = (2.0 * np.arange(down) + 1.0) / down - 1.0
    grid_u, grid_v = np.meshgrid(u, v)
    keep = np.flatnonzero(1.0 - grid_u ** 2 - grid_v ** 2 > 0)
    down_index, across_index = np.divmod(keep, across)
    for array in (u, v, across_index, down_index):
        array.flags.writeable = False
    return u, v, across_index, down_index


def _tiled_weights(samples: tuple[int, int], n_boxes: int) -> np.ndarray:
    """The kernel weights of :func:`kernel_grid` for ``n_boxes`` boxes, sample-major and flat (S · n_boxes,).

    Read-only; point s of box b is entry s · n_boxes + b, the order of :class:`Sampling`.
    """
    if n_boxes > HISTOGRAM_BLOCK:                        # not worth keeping
        return np.repeat(kernel_grid(samples)[1], n_boxes)
    return _kept_tiled_weights(samples, n_boxes)


@lru_cache(maxsize=8)
def _kept_tiled_weights(samples: tuple[int, int], n_boxes: int) -> np.ndarray:
    """:func:`_tiled_weights` for a block of boxes, built once per block size."""
    tiled = np.repeat(kernel_grid(samples)[1], n_boxes)
    tiled.flags.writeable = False
    return tiled


class Sampling(NamedTuple):
    """Where the sample points of a block of n boxes fall, sample-major: point s of box b is at [s, b].

    Sample-major rows are as long as the block, and a histogram count still adds the weights
    of one box's points in the order of :func:`kernel_grid`, so nothing is transposed.
    """

    pixels: np.ndarray                  # (S, n) flat pixel index of every point
    inside: np.ndarray | None           # (S, n) which points lie in the image; None: all, or not asked
    weights: np.ndarray                 # (S · n,) kernel weight of every point, read-only
    n_boxes: int
    kernel_total: float                 # Σ_i k(r_i) over one box's points, the 1 / f of L (10)


def sample_boxes(centres: np.ndarray, box_sizes: np.ndarray, samples: tuple[int, int], shape: tuple[int, int],
            inside: bool = False) -> Sampling:
    """The :class:`Sampling` of the boxes at ``centres`` (n, 2) of sizes ``box_sizes`` (n, 2) in an image of ``shape``.

    A box's sample points form a grid, so the coordinates are computed per axis (across +
    down values per box rather than 2 S), each by the same floating-point expression as
    point by point, and only the pixel indices are spread over the grid.  Which points lie
    in the image is found only when ``inside`` is asked (a mask counts the others out).
    """
    u, v, across_index, down_index = _grid_axes(samples)
    height, width = shape
    half = 0.5 * box_sizes
    xs = centres[:, 0] + u[:, None] * half[:, 0]                                   # (across, n)
    ys = centres[:, 1] + v[:, None] * half[:, 1]                                   # (down, n)
    # Truncating a coordinate clipped to [0, W − 1] gives the same pixel as clipping ⌊x⌋,
    # without a floor pass.
    clipped = np.maximum(xs, 0.0)
    columns = np.minimum(clipped, width - 1.0, out=clipped).astype(np.intp)
    clipped = np.maximum(ys, 0.0)
    rows = np.minimum(clipped, height - 1.0, out=clipped).astype(np.intp)
    rows *= width
    pixels = np.take(rows, down_index, axis=0)                                     # (S, n)
    pixels += np.take(columns, across_index, axis=0)
    weights = _tiled_weights(samples, centres.shape[0])
    within = None
    if inside:
        within_x = (xs >= 0) & (xs < width)
        within_y = (ys >= 0) & (ys < height)
        if not (within_x.all() and within_y.all()):
            within = np.take(within_y, down_index, axis=0) & np.take(within_x, across_index, axis=0)
    return Sampling(pixels, within, weights, centres.shape[0], _kernel_total(samples))


@lru_cache(maxsize=32)
def _kernel_total(samples: tuple[int, int]) -> float:
    """Σ_i k(r_i) over the points of :func:`kernel_grid`."""
    return float(kernel_grid(samples)[1].sum())


def sample_slots(bin_image: np.ndarray, sampling: Sampling, width: int, compact: np.ndarray | None = None) -> np.ndarray:
    """The histogram slot b · width + bin of every sample point, flat (S · n,).

    ``compact`` (optional, shape (B,)) renumbers the bins into 0 … width − 1 first.
    """
    bins = np.take(np.ravel(bin_image), sampling.pixels)
    if compact is not None:
        bins = np.take(compact, bins)
    return np.add(bins, np.arange(sampling.n_boxes, dtype=np.intp) * width, dtype=np.intp).ravel()


def sample_counts(slots: np.ndarray, sampling: Sampling, width: int, foreground: np.ndarray | None = None,
            pixel_weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | float]:
    """The unnormalised histograms of the sampled boxes, flat (n · width,), and their 1 / f.

    1 / f is a number without pixel weights, and one per box, shape (n, 1), with them (1 for
    a box without weight, whose counts are all 0).  Each count adds its sample weights in
    the order of :func:`kernel_grid`, so the counts are those of a point-by-point sum.
    """
    n_boxes = sampling.n_boxes
    sample_weights = sampling.weights
    if pixel_weights is not None:
        sample_weights = sample_weights * np.take(np.ravel(pixel_weights), sampling.pixels).ravel()
        totals = sample_weights.reshape(sampling.pixels.shape).sum(axis=0)         # 1 / f, box by box
    if foreground is not None:
        counted = np.take(np.ravel(foreground), sampling.pixels)
        if sampling.inside is not None:
            counted &= sampling.inside
        sample_weights = sample_weights * counted.ravel()
    counts = np.bincount(slots, weights=sample_weights, minlength=n_boxes * width)
    if pixel_weights is None:
        return counts, sampling.kernel_total                                       # f of L (10)
    # A box without any weight keeps its all-zero row rather than 0 / 0.
    return counts, np.where(totals > 0, totals, 1.0)[:, None]


def _kernel_counts(bin_image: np.ndarray, centres: np.ndarray, box_sizes: np.ndarray, n_bins: int,
                   samples: tuple[int, int], foreground: np.ndarray | None = None,
                   pixel_weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | float]:
    """The unnormalised histograms of :func:`kernel_histograms`, flat (n · B,), and their 1 / f (:func:`sample_counts`)."""
    if pixel_weights is not None:
        if np.shape(pixel_weights) != np.shape(bin_image):
            raise TrackingError(f"pixel_weights must have the shape {np.shape(bin_image)} of the bin image, "
                                f"got {np.shape(pixel_weights)}")
        pixel_weights = np.asarray(pixel_weights, dtype=np.float64)
    sampling = sample_boxes(centres, box_sizes, tuple(samples), np.shape(bin_image), foreground is not None)
    return sample_counts(sample_slots(bin_image, sampling, n_bins), sampling, n_bins, foreground, pixel_weights)


def bhattacharyya(histograms: np.ndarray, references: np.ndarray) -> np.ndarray:
    """Bhattacharyya coefficients ρ[h_p, q_k] = Σ_u √(h_p(u) q_k(u)) of all pairs (L (12)–(13)).

    The sum runs over the non-zero bins of each h_p only: a box's histogram is built from a
    few hundred sample points, so it fills a few dozen of its B bins (B = 512 for 8 bins per
    channel).  No BLAS call is made, so the cost never depends on a BLAS thread pool, which
    a small product only slows down when the machine is busy.  Rounding is clipped into
    [0, 1] so that 1 − ρ = d² (W (17)) is never negative.

    Parameters
    ----------
    histograms : ndarray, shape (P, B)
    references : ndarray, shape (K, B)

    Returns
    -------
    ndarray, shape (P, K)

    Examples
    --------
    >>> bhattacharyya(np.array([[0.5, 0.5], [1.0, 0.0]]), np.array([[0.5, 0.5], [0.0, 1.0]]))
    array([[1.        , 0.70710678],
           [0.70710678, 0.        ]])
    """
    histograms = np.asarray(histograms, dtype=np.float64)
    references = np.asarray(references, dtype=np.float64)
    if histograms.ndim not in (1, 2) or references.ndim not in (1, 2) \
            or histograms.shape[-1] != references.shape[-1]:
        raise TrackingError(f"histograms (P, B) and references (K, B) need the same B, "
                            f"got shapes {histograms.shape} and {references.shape}")
    rows = np.ascontiguousarray(np.atleast_2d(histograms))
    rho = sparse_rho(rows, 1.0, np.sqrt(np.atleast_2d(references)).T.copy())
    np.clip(rho, 0.0, 1.0, out=rho)
    # The shapes of a matrix product: a 1-D argument loses its axis.
    if references.ndim == 1:
        rho = rho[:, 0]
    return rho[0] if histograms.ndim == 1 else rho


class FilledBins(NamedTuple):
    """Where the non-zero counts of n histograms of B bins are, box by box."""

    positions: np.ndarray               # (F,) flat positions in the (n, B) counts, increasing
    boxes: np.ndarray                   # (F,) the box of each
    bins: np.ndarray                    # (F,) the bin of each
    starts: np.ndarray                  # (n + 1,) the first entry of each box, then F
    nonempty: np.ndarray | None         # the boxes with an entry; None when every box has one


def filled_bins(counts: np.ndarray) -> FilledBins:
    """The :class:`FilledBins` of ``counts``, shape (n, B)."""
    n_boxes, n_bins = counts.shape
    positions = np.flatnonzero(counts != 0)            # a boolean pass: nonzero() on floats is slower
    boxes = positions // n_bins
    starts = np.searchsorted(boxes, np.arange(n_boxes + 1))
    has_entries = starts[1:] > starts[:-1]
    return FilledBins(positions, boxes, positions - boxes * n_bins, starts,
                   None if has_entries.all() else np.flatnonzero(has_entries))


def sparse_rho(counts: np.ndarray, norms, root_references: np.ndarray, filled: FilledBins | None = None) -> np.ndarray:
    """Σ_u √(h_p(u)) r_k(u) for n histograms h_p = counts_p / norm_p, shape (n, K).

    ``counts`` has shape (n, B), C-contiguous; ``norms`` is one number for all, or one per box
    (shape (n, 1)); ``root_references`` is √q, shape (B, K).  Each h_p(u) is the quotient of
    the dense histogram, and each box's terms are added in the order of its bins, so only
    the order of the additions differs from a dense product.  ``filled`` (optional) may
    name more positions than the non-zero counts, such as those of histograms of the same
    points without a mask: a zero count adds a zero term (the sums agree to rounding).
    """
    n_boxes = counts.shape[0]
    if filled is None:
        filled = filled_bins(counts)
    if filled.positions.size == 0:
        return np.zeros((n_boxes, root_references.shape[1]))
    roots = counts.ravel()[filled.positions]
    roots /= norms if np.ndim(norms) == 0 else np.ravel(norms)[filled.boxes]
    np.sqrt(roots, out=roots)
    terms = np.take(root_references, filled.bins, axis=0)                          # (filled, K)
    terms *= roots[:, None]
    if filled.nonempty is None:                                                    # the usual case
        return np.add.reduceat(terms, filled.starts[:-1], axis=0)
    rho = np.zeros((n_boxes, root_references.shape[1]))
    rho[filled.nonempty] = np.add.reduceat(terms, filled.starts[filled.nonempty], axis=0)
    return rho


def false_alarm_histogram(scene_counts: np.ndarray, templates: np.ndarray) -> np.ndarray:
    """The colours of the scene that are not the targets', q_FA (W (18)).

    q_FA ∝ max(q_scene − Σ_j q_j, 0) with q_scene the normalised scene histogram, as W (18)
    prints it: a target's colour is removed from FA entirely.  The result is renormalised to
    sum 1, and is uniform if nothing is left (SPEC B.3) — as when the scene itself is empty,
    an edge histogram of a frame without edges.

    Parameters
    ----------
    scene_counts : ndarray, shape (B,)
        Pixel counts of every bin over the whole frame (no kernel); for weighted pixels, the
        sums of their weights.
    templates : ndarray, shape (τ, B)
        The target templates q_j, rows summing to 1.

    Returns
    -------
    ndarray, shape (B,)
        Sums to 1.

    Examples
    --------
    A scene of 90 background pixels (bin 0) and 10 target pixels (bin 1):

    >>> scene, target = np.array([90.0, 10.0, 0.0]), np.array([[0.0, 1.0, 0.0]])
    >>> false_alarm_histogram(scene, target)
    array([1., 0., 0.])
    """
    scene_counts = np.asarray(scene_counts, dtype=np.float64)
    if not scene_counts.sum() > 0:
        return np.full(scene_counts.shape, 1.0 / scene_counts.size)
    scene = scene_counts / scene_counts.sum()
    residual = scene - templates.sum(axis=0)
    # What survives the subtraction by rounding alone (~1e-17 of the scene) is not a colour of
    # the scene; renormalised, it would become a spurious FA histogram.  This also clamps at 0.
    residual[residual <= RESIDUAL_TOLERANCE * scene.sum()] = 0.0
    total = residual.sum()
    if total <= 0:
        return np.full(scene_counts.shape, 1.0 / scene_counts.size)
    return residual / total


