"""Particle-filter machinery: particle sets, constant-velocity motion and resampling (SPEC B.1).

A target's posterior is a weighted sample set S_t = {(s^(n), π^(n))}, n = 1..N (W (5)).  The
samples are the rows of an ``(N, 5)`` array whose columns are :data:`STATE`; the weights are
kept as log-weights so that products of many small likelihoods neither underflow nor turn
into 0/0.  One frame of the bootstrap filter is

1. propagate every particle through the motion model (W-S2, L (7), C (7)),
2. add the per-particle log-likelihood and renormalise (C (5)),
3. estimate the state as the weighted mean (W (6)),
4. resample when the effective sample size is low (W-S5); the particle count may change
   here (SPEC B.3, adaptive particle number).

Every random draw takes an explicit :class:`numpy.random.Generator`, so a run is
reproducible from its seed.  Nothing loops over particles in Python.

Degenerate weights (all zero, all ``-inf`` in the log domain, or a non-finite sum) are
replaced by uniform weights with a :class:`DegenerateWeightsWarning`, so that no NaN ever
leaves this module (SPEC B.1, resampling).

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(7)
>>> particles = ParticleSet(initialise((120.0, 80.0), 200, rng, velocity=(2.0, 0.0)))
>>> motion = ConstantVelocity(MotionConfig(), bounds=(320, 240))
>>> particles = particles.propagate(motion, rng)
>>> distance = np.hypot(particles.states[:, CX] - 122.0, particles.states[:, CY] - 80.0)
>>> particles = particles.reweight(-0.5 * (distance / 10.0) ** 2)
>>> cx, cy = particles.estimate()[[CX, CY]]
>>> bool(abs(cx - 122.0) < 2.0 and abs(cy - 80.0) < 2.0)
True
>>> particles = particles.resample(rng, method="systematic", threshold=1.0)
>>> len(particles), particles.ess()
(200, 200.0)
"""

from __future__ import annotations

import math
import operator
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Optional, Protocol

import numpy as np

from .errors import TrackingError
from . import limits
from .limits import shown as _shown

__all__ = [
    "STATE",
    "STATE_DIM",
    "CX",
    "CY",
    "VX",
    "VY",
    "LOG_SCALE",
    "DegenerateWeightsWarning",
    "MotionConfig",
    "MotionModel",
    "ConstantVelocity",
    "initialise",
    "normalise_log_weights",
    "effective_sample_size",
    "Resampler",
    "multinomial",
    "systematic",
    "stratified",
    "residual",
    "RESAMPLERS",
    "get_resampler",
    "adaptive_count",
    "ParticleSet",
]

STATE = ("cx", "cy", "vx", "vy", "log_scale")
"""Column names of a particle state: centre (px), velocity (px per frame) and log of the window scale."""

STATE_DIM = len(STATE)
"""d, the number of state columns."""

CX, CY, VX, VY, LOG_SCALE = range(STATE_DIM)


class DegenerateWeightsWarning(UserWarning):
    """Weights summed to zero or to a non-finite value and were replaced by uniform weights."""


# -- validation helpers ---------------------------------------------------------------------------


def _real(name: str, value: object) -> float:
    """``value`` as a finite float; a bool, a non-number or ±inf/NaN raises :class:`TrackingError`."""
    if isinstance(value, bool):
        raise TrackingError(f"{name} must be a real number, got {value!r}")
    if isinstance(value, (str, bytes)):
        raise TrackingError(f"{name} must be a real number, got {_shown(value)}")
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        raise TrackingError(f"{name} must be a real number, got {_shown(value)}") from None
    if not math.isfinite(number):
        raise TrackingError(f"{name} must be finite, got {value!r}")
    return number


def _non_negative(name: str, value: object) -> float:
    number = _real(name, value)
    if number < 0:
        raise TrackingError(f"{name} must be non-negative, got {value!r}")
    return number


def _count(name: str, value: object, minimum: int = 1) -> int:
    try:
        number = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise TrackingError(f"{name} must be an integer, got {_shown(value)}") from None
    if number < minimum:
        raise TrackingError(f"{name} must be at least {minimum}, got {number}")
    return number


def _pair(name: str, value: object) -> tuple[float, float]:
    try:
        first, second = value  # type: ignore[misc]
    except (TypeError, ValueError):
        raise TrackingError(f"{name} must be a pair of numbers, got {value!r}") from None
    return _real(name, first), _real(name, second)


def _states(states: object) -> np.ndarray:
    array = np.asarray(states, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != STATE_DIM or array.shape[0] == 0:
        raise TrackingError(f"states must have shape (N, {STATE_DIM}) with N >= 1, got shape {array.shape}")
    return array


def _uniform_log_weights(n: int) -> np.ndarray:
    return np.full(n, -math.log(n))


def _warn_degenerate(what: str) -> None:
    warnings.warn(
        f"{what}; using uniform weights instead",
        DegenerateWeightsWarning,
        stacklevel=3,
    )


# -- motion ---------------------------------------------------------------------------------------

#: The largest time step of the motion model, in frames.
MAX_DT = 1000.0


@dataclass(frozen=True)
class MotionConfig:
    """Noise levels and time step of the constant-velocity model (W-S2).

    The defaults are the tracker's, chosen on PETS 2009 S2.L1 (SPEC B.1 suggests 4 px and
    1 px/frame): people there walk at about 1 px per frame.  The log-scale column gets no
    noise: a window's size comes from the perspective model, not from the state.

    Parameters
    ----------
    sigma_pos : float
        Standard deviation of the per-step noise on cx and cy, in pixels.
    sigma_vel : float
        Standard deviation of the per-step noise on vx and vy, in pixels per frame.
    dt : float
        Time step in frames (must be positive).

    Raises
    ------
    TrackingError
        A field is not a finite number, a standard deviation is negative, or ``dt`` is
        not positive; the message names the field.

    Examples
    --------
    >>> MotionConfig()
    MotionConfig(sigma_pos=3.0, sigma_vel=0.5, dt=1.0)
    >>> MotionConfig(sigma_pos=-1)
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: MotionConfig.sigma_pos must be non-negative, got -1
    """

    sigma_pos: float = 3.0
    sigma_vel: float = 0.5
    dt: float = 1.0

    def __post_init__(self) -> None:
        for name in ("sigma_pos", "sigma_vel"):
            value = _non_negative(f"MotionConfig.{name}", getattr(self, name))
            # A spread beyond any frame puts every particle on the image's border (run checks: the diagonal).
            if value > limits.MAX_SPREAD:
                raise TrackingError(f"MotionConfig.{name} must be at most {limits.MAX_SPREAD:g} px, got {value!r}")
            object.__setattr__(self, name, value)
        dt = _real("MotionConfig.dt", self.dt)
        if not 0 < dt <= MAX_DT:
            raise TrackingError(f"MotionConfig.dt must be positive and at most {MAX_DT:g} frames, got {self.dt!r}")
        object.__setattr__(self, "dt", dt)

    def noise_std(self) -> np.ndarray:
        """Per-column noise standard deviations, shape ``(5,)``, in :data:`STATE` order (0 for the log-scale)."""
        return np.array([self.sigma_pos, self.sigma_pos, self.sigma_vel, self.sigma_vel, 0.0])


class MotionModel(Protocol):
    """Anything that moves a particle array one step forward."""

    def propagate(self, states: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Return the propagated states, shape ``(N, 5)``, as a new array."""
        ...


@dataclass(frozen=True)
class ConstantVelocity:
    """Constant-velocity dynamics s_t = A s_{t-1} + w, w ~ N(0, Σ_w) (W-S2, L (7), C (7)).

    With A = [[I₂, dt·I₂, 0], [0, I₂, 0], [0, 0, 1]] over (centre, velocity, log-scale) and
    Σ_w = diag(σ_pos², σ_pos², σ_vel², σ_vel², σ_log_scale²)::

        cx ← cx + vx·dt + ε_x    vx ← vx + ε_vx    log_scale ← log_scale + ε_s
        cy ← cy + vy·dt + ε_y    vy ← vy + ε_vy

    The noise is drawn once per step and independently per column, so the position noise
    has standard deviation exactly σ_pos whatever the velocity noise.  C's random walk
    (A = I on the centre, σ = 5 px) is ``MotionConfig(sigma_pos=5, sigma_vel=0)`` with
    particles initialised at zero velocity.

    Parameters
    ----------
    config : MotionConfig
        Noise levels and time step.
    bounds : (width, height) or None
        Image size in pixels.  When given, centres are clipped to [0, width − 1] ×
        [0, height − 1] so that they always round to a pixel of the image; velocities are
        left as they are.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> still = ConstantVelocity(MotionConfig(sigma_pos=0, sigma_vel=0))
    >>> still.propagate(np.array([[10.0, 20.0, 3.0, -1.0, 0.0]]), rng).tolist()
    [[13.0, 19.0, 3.0, -1.0, 0.0]]
    >>> clipped = ConstantVelocity(MotionConfig(0, 0), bounds=(64, 48))
    >>> clipped.propagate(np.array([[60.0, 2.0, 10.0, -5.0, 0.0]]), rng).tolist()
    [[63.0, 0.0, 10.0, -5.0, 0.0]]
    """

    config: MotionConfig = field(default_factory=MotionConfig)
    bounds: Optional[tuple[float, float]] = None

    def __post_init__(self) -> None:
        if not isinstance(self.config, MotionConfig):
            raise TrackingError(f"config must be a MotionConfig, got {type(self.config).__name__}")
        if self.bounds is not None:
            width, height = _pair("bounds", self.bounds)
            if width < 1 or height < 1:
                raise TrackingError(f"bounds (width, height) must both be at least 1 pixel, got {self.bounds!r}")
            object.__setattr__(self, "bounds", (width, height))

    def propagate(self, states: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Move every particle one time step.

        Parameters
        ----------
        states : ndarray, shape (N, 5)
            Particle states in :data:`STATE` column order; not modified.
        rng : numpy.random.Generator
            Source of the process noise; one ``(N, 5)`` standard-normal draw per call,
            whatever the configuration, so runs with different noise levels stay in step.

        Returns
        -------
        ndarray, shape (N, 5)
            The propagated states, a new array.
        """
        states = _states(states)
        config = self.config
        moved = states + rng.standard_normal(states.shape) * config.noise_std()
        # The deterministic drift uses the velocity *before* this step's velocity noise.
        moved[:, CX:CY + 1] += states[:, VX:VY + 1] * config.dt
        if self.bounds is not None:
            width, height = self.bounds
            for column, top in ((CX, width - 1.0), (CY, height - 1.0)):
                values = moved[:, column]
                np.minimum(np.maximum(values, 0.0, out=values), top, out=values)
        return moved


def initialise(
    box_centre: tuple[float, float],
    n: int,
    rng: np.random.Generator,
    sigma_pos: float = 5.0,
    velocity: tuple[float, float] = (0.0, 0.0),
    log_scale: float = 0.0,
) -> np.ndarray:
    """Draw N particles around an initial target position (W-S1, L (8)).

    The centres are Gaussian around ``box_centre`` with standard deviation ``sigma_pos`` in
    each axis; velocity and log-scale are set exactly.  Pair the result with uniform
    weights π = 1/N (W (5)), which is what :class:`ParticleSet` does by default.

    Parameters
    ----------
    box_centre : (cx, cy)
        Initial centre in pixels.
    n : int
        Number of particles, N ≥ 1.
    rng : numpy.random.Generator
    sigma_pos : float
        Spread of the centres in pixels (SPEC B.1 default 5).
    velocity : (vx, vy)
        Initial velocity of every particle, pixels per frame.
    log_scale : float
        Initial log-scale of every particle (0 is the size of the initial box).

    Returns
    -------
    ndarray, shape (n, 5)

    Examples
    --------
    >>> states = initialise((50.0, 40.0), 4, np.random.default_rng(1), sigma_pos=0.0, velocity=(1.0, -2.0))
    >>> states.tolist()[0]
    [50.0, 40.0, 1.0, -2.0, 0.0]
    >>> states.shape
    (4, 5)
    """
    centre = np.array(_pair("box_centre", box_centre))
    n = _count("n", n)
    sigma_pos = _non_negative("sigma_pos", sigma_pos)
    velocity = _pair("velocity", velocity)
    log_scale = _real("log_scale", log_scale)
    states = np.empty((n, STATE_DIM))
    states[:, [CX, CY]] = centre + sigma_pos * rng.standard_normal((n, 2))
    states[:, [VX, VY]] = velocity
    states[:, LOG_SCALE] = log_scale
    return states


# -- weights --------------------------------------------------------------------------------------


def normalise_log_weights(log_weights: np.ndarray) -> np.ndarray:
    """Shift log-weights so that their exponentials sum to one (log-sum-exp).

    log π̃⁽ⁿ⁾ = log π⁽ⁿ⁾ − log Σ_i π⁽ⁱ⁾, computed as ``l − m − log Σ exp(l − m)`` with
    m = max l, so that neither very large nor very small log-weights overflow.

    Entries of ``-inf`` (impossible particles) stay ``-inf``.  If every entry is ``-inf``,
    or any entry is NaN or ``+inf``, the sum of weights is zero or not finite: the result is
    uniform, log(1/N), with a :class:`DegenerateWeightsWarning`.

    Parameters
    ----------
    log_weights : array_like, shape (N,)

    Returns
    -------
    ndarray, shape (N,)
        Normalised log-weights, a new array.

    Examples
    --------
    >>> np.exp(normalise_log_weights(np.log([1.0, 3.0]))).round(12).tolist()   # exp(log 3) is 3 to rounding
    [0.25, 0.75]
    >>> normalise_log_weights([1000.0, 1000.0, -np.inf]).tolist()
    [-0.6931471805599453, -0.6931471805599453, -inf]
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     uniform = normalise_log_weights([-np.inf, -np.inf])
    >>> np.exp(uniform).tolist(), caught[0].category.__name__
    ([0.5, 0.5], 'DegenerateWeightsWarning')
    """
    log_weights = np.array(log_weights, dtype=np.float64)
    if log_weights.ndim != 1 or log_weights.size == 0:
        raise TrackingError(f"log_weights must be a non-empty 1-D array, got shape {log_weights.shape}")
    # The maximum is NaN if any entry is, so one pass finds NaN and +inf.
    peak = float(log_weights.max())
    if math.isnan(peak) or peak == math.inf:
        _warn_degenerate("log-weights contain NaN or +inf, so the weight sum is not finite")
        return _uniform_log_weights(log_weights.size)
    if peak == -math.inf:
        _warn_degenerate("every log-weight is -inf, so the weights sum to zero")
        return _uniform_log_weights(log_weights.size)
    log_weights -= peak                                            # a private copy: shifted in place
    log_weights -= math.log(float(np.exp(log_weights).sum()))
    return log_weights


def effective_sample_size(log_weights: np.ndarray) -> float:
    """Effective sample size N_eff = 1 / Σ_n (π̃⁽ⁿ⁾)² of the normalised weights.

    It is N for uniform weights and 1 when one particle holds all the weight.

    Parameters
    ----------
    log_weights : array_like, shape (N,)
        Log-weights, normalised or not (degenerate ones count as uniform, see
        :func:`normalise_log_weights`).

    Returns
    -------
    float in [1, N]

    Examples
    --------
    >>> effective_sample_size(np.zeros(8))
    8.0
    >>> effective_sample_size([0.0, -np.inf, -np.inf])
    1.0
    """
    return _ess(normalise_log_weights(log_weights))


def _ess(normalised_log_weights: np.ndarray) -> float:
    # (Σw)² / Σw² on weights scaled so the largest is 1: equal to 1/Σπ̃², and exactly N for equal weights.
    relative = np.exp(normalised_log_weights - normalised_log_weights.max())
    return float(relative.sum() ** 2 / np.square(relative).sum())


def _checked_weights(weights: np.ndarray) -> np.ndarray:
    """Validated weights divided by their sum; uniform (with a warning) if that sum is 0 or not finite."""
    weights = np.asarray(weights, dtype=np.float64)
    if weights.ndim != 1 or weights.size == 0:
        raise TrackingError(f"weights must be a non-empty 1-D array, got shape {weights.shape}")
    if (weights < 0).any():
        raise TrackingError(f"weights must be non-negative, got minimum {weights.min()!r}")
    # Without negative entries the maximum is finite exactly when every entry is (NaN propagates).
    peak = weights.max()
    if not math.isfinite(peak):
        _warn_degenerate("weights contain NaN or +inf, so their sum is not finite")
        return np.full(weights.size, 1.0 / weights.size)
    if peak == 0:
        _warn_degenerate("weights sum to zero")
        return np.full(weights.size, 1.0 / weights.size)
    # Dividing by the largest weight first keeps the sum finite even for weights near the float maximum.
    scaled = weights / peak
    return scaled / scaled.sum()


def _resample_size(n: Optional[int], default: int) -> int:
    return default if n is None else _count("n", n)


def _cumulative(weights: np.ndarray) -> np.ndarray:
    cumulative = np.cumsum(weights)
    # Pin the last edge to exactly 1 so that every uniform in [0, 1) falls inside some particle.
    cumulative /= cumulative[-1]
    return cumulative


def _invert(cumulative: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Index of the particle whose cumulative interval [C_{i-1}, C_i) holds each position in [0, 1)."""
    indices = np.searchsorted(cumulative, positions, side="right")
    # Rounding in (k + u)/n can reach 1.0 for the last position; it belongs to the last particle.
    return np.minimum(indices, cumulative.size - 1)


# -- resamplers -----------------------------------------------------------------------------------


class Resampler(Protocol):
    """Draw particle indices in proportion to their weights."""

    def __call__(self, weights: np.ndarray, rng: np.random.Generator, n: Optional[int] = None) -> np.ndarray:
        ...


def multinomial(weights: np.ndarray, rng: np.random.Generator, n: Optional[int] = None) -> np.ndarray:
    """Multinomial resampling: n independent draws with P(index = i) = w_i (W-S5, literally).

    Parameters
    ----------
    weights : array_like, shape (N,)
        Non-negative weights; they are divided by their sum.  A zero or non-finite sum
        gives uniform weights and a :class:`DegenerateWeightsWarning`.
    rng : numpy.random.Generator
    n : int, optional
        Number of indices to draw; N by default.

    Returns
    -------
    ndarray of intp, shape (n,)
        Indices into the particle array, each in [0, N).

    Raises
    ------
    TrackingError
        ``weights`` is not a non-empty 1-D array, has a negative entry, or ``n < 1``.

    Examples
    --------
    >>> multinomial([0.0, 1.0, 0.0], np.random.default_rng(0), n=4).tolist()
    [1, 1, 1, 1]
    """
    weights = _checked_weights(weights)
    n = _resample_size(n, weights.size)
    return _invert(_cumulative(weights), rng.random(n))


def systematic(weights: np.ndarray, rng: np.random.Generator, n: Optional[int] = None) -> np.ndarray:
    """Systematic resampling: positions (k + u)/n, k = 0..n−1, with one shared u ~ U[0, 1).

    The SPEC B.1 default.  Particle i is copied ⌊n·w_i⌋ or ⌈n·w_i⌉ times, which gives the
    lowest resampling noise of the four schemes.  Parameters, return value and errors
    are those of :func:`multinomial`.

    Examples
    --------
    >>> systematic([0.5, 0.25, 0.25], np.random.default_rng(0), n=4).tolist()
    [0, 0, 1, 2]
    """
    weights = _checked_weights(weights)
    n = _resample_size(n, weights.size)
    return _invert(_cumulative(weights), (np.arange(n) + rng.random()) / n)


def stratified(weights: np.ndarray, rng: np.random.Generator, n: Optional[int] = None) -> np.ndarray:
    """Stratified resampling: positions (k + u_k)/n, k = 0..n−1, with independent u_k ~ U[0, 1).

    One draw per stratum [k/n, (k+1)/n).  The number of copies of the first i particles
    together is within one of n·(w_1 + … + w_i).  Parameters, return value and errors are
    those of :func:`multinomial`.

    Examples
    --------
    >>> stratified([0.5, 0.25, 0.25], np.random.default_rng(0), n=4).tolist()
    [0, 0, 1, 2]
    """
    weights = _checked_weights(weights)
    n = _resample_size(n, weights.size)
    return _invert(_cumulative(weights), (np.arange(n) + rng.random(n)) / n)


def residual(weights: np.ndarray, rng: np.random.Generator, n: Optional[int] = None) -> np.ndarray:
    """Residual resampling: ⌊n·w_i⌋ copies of particle i, the rest drawn multinomially.

    The R = n − Σ_i ⌊n·w_i⌋ remaining indices are drawn with probabilities proportional to
    the residuals n·w_i − ⌊n·w_i⌋.  Indices come out grouped by particle.  Parameters,
    return value and errors are those of :func:`multinomial`.

    Examples
    --------
    >>> residual([0.5, 0.25, 0.25], np.random.default_rng(0), n=4).tolist()
    [0, 0, 1, 2]
    """
    weights = _checked_weights(weights)
    n = _resample_size(n, weights.size)
    expected = n * weights
    copies = np.floor(expected).astype(np.intp)
    # Rounding in n·w can push Σ⌊n·w⌋ one past n; drop the excess from the largest counts.
    while copies.sum() > n:
        copies[np.argmax(copies)] -= 1
    guaranteed = np.repeat(np.arange(weights.size), copies)
    remaining = n - guaranteed.size
    if remaining == 0:
        return guaranteed
    leftovers = np.clip(expected - copies, 0.0, None)
    if leftovers.sum() <= 0:
        leftovers = weights  # only possible through rounding; fall back to the weights themselves
    drawn = _invert(_cumulative(leftovers / leftovers.sum()), rng.random(remaining))
    return np.concatenate([guaranteed, drawn])


RESAMPLERS: dict[str, Callable[..., np.ndarray]] = {
    "multinomial": multinomial,
    "systematic": systematic,
    "stratified": stratified,
    "residual": residual,
}
"""Resampling schemes by name; each maps ``(weights, rng, n=None)`` to an index array."""


def get_resampler(name: str) -> Callable[..., np.ndarray]:
    """The resampler registered under ``name`` in :data:`RESAMPLERS`.

    Raises
    ------
    TrackingError
        For an unknown name; the message lists the known ones.

    Examples
    --------
    >>> get_resampler("residual") is residual
    True
    >>> get_resampler("bootstrap")
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: unknown resampler 'bootstrap'; known: multinomial, residual, stratified, systematic
    """
    try:
        return RESAMPLERS[name]
    except (KeyError, TypeError):
        known = ", ".join(sorted(RESAMPLERS))
        raise TrackingError(f"unknown resampler {name!r}; known: {known}") from None


def adaptive_count(kappa: float, n_min: int, n_max: int) -> int:
    """Particle count for the next frame from the conflict level (SPEC B.3, adaptive particle number).

    N_{t+1} = N_min + ⌈(N_max − N_min)·κ_t⌉, so no conflict keeps N_min particles and total
    conflict uses N_max.  W gives no formula; this is the SPEC default, where κ_t is the mean
    per-particle conflict weight R (W (10)) and N_min = ⌈N_max / 2⌉.

    Parameters
    ----------
    kappa : float
        Conflict level κ_t in [0, 1]; values within 1e-9 outside are clipped.
    n_min, n_max : int
        Bounds of the particle count, 1 ≤ n_min ≤ n_max.

    Returns
    -------
    int in [n_min, n_max]

    Examples
    --------
    >>> adaptive_count(0.0, 20, 40), adaptive_count(0.3, 20, 40), adaptive_count(1.0, 20, 40)
    (20, 26, 40)
    >>> adaptive_count(0.07, 1, 101)  # 100 × 0.07 is 7.000000000000001 in floating point, still 7 more
    8
    """
    kappa = _real("kappa", kappa)
    n_min = _count("n_min", n_min)
    n_max = _count("n_max", n_max)
    if n_max < n_min:
        raise TrackingError(f"n_max must be at least n_min, got n_min={n_min}, n_max={n_max}")
    tolerance = 1e-9
    if not -tolerance <= kappa <= 1 + tolerance:
        raise TrackingError(f"kappa must lie in [0, 1], got {kappa!r}")
    kappa = min(max(kappa, 0.0), 1.0)
    # A product within rounding of an integer counts as that integer, so κ's last bit cannot add a particle.
    extra = math.ceil((n_max - n_min) * kappa - tolerance)
    return n_min + min(max(extra, 0), n_max - n_min)


# -- particle sets --------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ParticleSet:
    """One target's weighted sample set S_t = {(s⁽ⁿ⁾, π⁽ⁿ⁾)} (W (5)), with log-weights.

    Immutable: every operation returns a new set and the arrays are read-only.  A tracker
    can therefore keep the previous frame's set (W (23) needs every particle at t − 1)
    without defensive copies, and no step can change a set that another step still reads.

    Parameters
    ----------
    states : array_like, shape (N, 5)
        Finite particle states in :data:`STATE` column order, N ≥ 1.  Copied.
    log_weights : array_like, shape (N,), optional
        Log-weights, normalised on construction (:func:`normalise_log_weights`); uniform
        (π = 1/N) when omitted.

    Raises
    ------
    TrackingError
        Wrong shapes, or a non-finite state.

    Examples
    --------
    >>> states = np.array([[0.0, 0.0, 1.0, 0.0, 0.0], [10.0, 4.0, 1.0, 0.0, 0.0]])
    >>> particles = ParticleSet(states, np.log([1.0, 3.0]))
    >>> particles.weights().round(12).tolist()
    [0.25, 0.75]
    >>> particles.estimate().round(12).tolist()
    [7.5, 3.0, 1.0, 0.0, 0.0]
    >>> round(particles.ess(), 12)  # 1 / (0.25² + 0.75²)
    1.6
    """

    states: np.ndarray
    log_weights: Optional[np.ndarray] = None

    def __post_init__(self) -> None:
        states = np.array(_states(self.states), dtype=np.float64)  # always a private copy
        if not np.isfinite(states).all():
            raise TrackingError("states must be finite")
        if self.log_weights is None:
            log_weights = _uniform_log_weights(states.shape[0])
        else:
            log_weights = np.asarray(self.log_weights, dtype=np.float64)
            if log_weights.shape != (states.shape[0],):
                raise TrackingError(
                    f"log_weights must have shape ({states.shape[0]},) to match states, got {log_weights.shape}"
                )
            log_weights = normalise_log_weights(log_weights)
        states.flags.writeable = False
        log_weights.flags.writeable = False
        object.__setattr__(self, "states", states)
        object.__setattr__(self, "log_weights", log_weights)

    @classmethod
    def _from_checked(cls, states: np.ndarray, log_weights: np.ndarray) -> ParticleSet:
        """A set of arrays that already are what ``__post_init__`` makes: private, finite, normalised.

        The operations of a set make these themselves, so they skip the copies and checks,
        which cost more than the arithmetic on a set of a hundred particles.
        """
        states.flags.writeable = False
        log_weights.flags.writeable = False
        particles = object.__new__(cls)
        object.__setattr__(particles, "states", states)
        object.__setattr__(particles, "log_weights", log_weights)
        return particles

    def __len__(self) -> int:
        return self.states.shape[0]

    def __repr__(self) -> str:
        return f"ParticleSet(N={len(self)}, ess={self.ess():.3g}, estimate={np.round(self.estimate(), 3).tolist()})"

    def weights(self) -> np.ndarray:
        """Normalised weights π̃⁽ⁿ⁾ = exp(log-weight), shape ``(N,)``, summing to one."""
        return np.exp(self.log_weights)

    def estimate(self) -> np.ndarray:
        """State estimate x̂_t = Σ_n π̃⁽ⁿ⁾ s⁽ⁿ⁾, the posterior mean (W (6), L (18), C (6)).

        Returns
        -------
        ndarray, shape (5,)
            The log-scale column is averaged in the log domain, so ``exp`` of it is the
            geometric mean of the particles' scales.
        """
        return self.weights() @ self.states

    def ess(self) -> float:
        """Effective sample size of the weights, see :func:`effective_sample_size`."""
        return _ess(self.log_weights)

    def propagate(self, motion: MotionModel, rng: np.random.Generator) -> ParticleSet:
        """The set moved one step by ``motion`` (W-S2), weights unchanged."""
        states = np.asarray(motion.propagate(self.states, rng), dtype=np.float64)
        if states.shape != self.states.shape or not np.isfinite(states).all():
            raise TrackingError(f"the motion model must return finite states of shape {self.states.shape}")
        # The weights are this set's own normalised array, so the new set can share them.
        return ParticleSet._from_checked(states, self.log_weights)

    def with_column(self, column: int, values) -> ParticleSet:
        """The set with one state column replaced, weights unchanged.

        Parameters
        ----------
        column : int
            A column of :data:`STATE`, e.g. :data:`LOG_SCALE`.
        values : float or array_like, shape (N,)
            Finite new values.

        Examples
        --------
        >>> particles = ParticleSet(np.zeros((2, 5))).with_column(LOG_SCALE, [0.5, -0.5])
        >>> particles.states[:, LOG_SCALE].tolist(), particles.ess()
        ([0.5, -0.5], 2.0)
        """
        states = self.states.copy()
        states[:, column] = values
        if not np.isfinite(states[:, column]).all():
            raise TrackingError(f"the new values of state column {column} must be finite")
        return ParticleSet._from_checked(states, self.log_weights)

    def reweight(self, log_likelihood: np.ndarray) -> ParticleSet:
        """The set with log π⁽ⁿ⁾ + log p(z_t | s⁽ⁿ⁾), renormalised (C (5)).

        Parameters
        ----------
        log_likelihood : array_like, shape (N,)
            Per-particle log-likelihood; ``-inf`` marks an impossible particle.  If every
            particle becomes impossible the weights fall back to uniform with a
            :class:`DegenerateWeightsWarning`.
        """
        log_likelihood = np.asarray(log_likelihood, dtype=np.float64)
        if log_likelihood.shape != self.log_weights.shape:
            raise TrackingError(f"log_likelihood must have shape {self.log_weights.shape}, got {log_likelihood.shape}")
        # The states are this set's own read-only array, so the new set can share them.
        return ParticleSet._from_checked(self.states, normalise_log_weights(self.log_weights + log_likelihood))

    def take(self, indices: np.ndarray) -> ParticleSet:
        """The particles at ``indices`` (repeats allowed), with uniform weights.

        This is the second half of resampling, for callers that choose the indices
        themselves and need them to carry other per-particle data along.
        """
        indices = np.asarray(indices)
        if indices.ndim != 1 or indices.size == 0 or not np.issubdtype(indices.dtype, np.integer):
            raise TrackingError(f"indices must be a non-empty 1-D integer array, got {indices.dtype} {indices.shape}")
        # Indexing copies the (finite) states; the weights of a resampled set are uniform.
        return ParticleSet._from_checked(self.states[indices], _uniform_log_weights(indices.size))

    def resample(
        self,
        rng: np.random.Generator,
        method: str = "systematic",
        threshold: float = 0.5,
        n: Optional[int] = None,
    ) -> ParticleSet:
        """Resample when the effective sample size is low (W-S5), optionally to a new size.

        Resampling happens when N_eff < threshold·N, always when ``threshold`` is 1 (every
        frame, as all three papers do), and always when ``n`` differs from N (the adaptive
        particle number of SPEC B.3; see :func:`adaptive_count`).  Otherwise the set is
        returned unchanged and ``rng`` is not used.

        Parameters
        ----------
        rng : numpy.random.Generator
        method : str
            A name in :data:`RESAMPLERS`; systematic by default (SPEC B.1).
        threshold : float in [0, 1]
            Fraction of N below which N_eff triggers resampling; 0 never resamples a set
            of unchanged size.
        n : int, optional
            Size of the resampled set; N by default.

        Returns
        -------
        ParticleSet
            After resampling, n particles with uniform weights.

        Examples
        --------
        >>> rng = np.random.default_rng(3)
        >>> particles = ParticleSet(initialise((0.0, 0.0), 10, rng), np.log(np.arange(1.0, 11.0)))
        >>> particles.resample(rng, threshold=0.5) is particles  # N_eff = 55² / 385 ≈ 7.9 ≥ 5
        True
        >>> bigger = particles.resample(rng, method="residual", n=25)
        >>> len(bigger), bigger.ess()
        (25, 25.0)
        """
        resampler = get_resampler(method)
        threshold = _real("threshold", threshold)
        if not 0.0 <= threshold <= 1.0:
            raise TrackingError(f"threshold must lie in [0, 1], got {threshold!r}")
        size = _resample_size(n, len(self))
        if size == len(self) and threshold < 1.0 and not self.ess() < threshold * len(self):
            return self
        return self.take(resampler(self.weights(), rng, size))
