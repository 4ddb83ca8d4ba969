"""The multi-target DSmT particle-filter tracker (SPEC B.3 W-S1..S6, generalised in Part D).

One :class:`~plugins.video_tracking.particles.ParticleSet` per live target.  Every frame

1. the background model gives the foreground mask (SPEC B.4), when the foreground cue is used;
2. every target's particles are propagated by the constant-velocity model (W-S2);
3. an :class:`~plugins.video_tracking.cues.Observation` is built from the t − 1 estimates and
   the t − 1 particles of *all* live targets (so the centroid, d_max and q_FA are recomputed
   every frame, Part D);
4. the particles of all targets are stacked into one ``(P, 5)`` array with an owner array,
   every cue scores them against {θ_1..θ_τ, FA}, and
   :class:`~plugins.video_tracking.fusion.CueFusion` fuses the cues and weighs each particle
   by Bel(θ_J) (or Pls / BetP) of its own target J (W (7), W (32), W-S3);
5. per target: the weights are normalised within the set, the state is estimated (W (6),
   W-S4), the diagnostics W (33)–(35) are recorded, and the set is resampled (W-S5).

Nothing costs 2^τ: the cues are linear in τ·P, and the fusion stores only focal elements.
Targets are born and removed by an :class:`InitPlan` (a MOTChallenge ground truth, or boxes
for the first frame).  Every random draw comes from the one ``numpy.random.Generator`` given to
the tracker, so a run is reproducible from its seed.

Frame numbers are 1-based (as in MOTChallenge files); boxes ``(x, y, w, h)`` inside the
tracker are 0-based pixels with the top-left corner at ``(x, y)``, as in :mod:`cues`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from os import PathLike

import numpy as np

from belief.errors import BeliefError
from belief.rules import get_rule
from plugins.video_tracking.adaptive import (
    AdaptiveConfig,
    feature_confidences,
    feature_entropies,
    feature_spreads,
    fuse_adaptive,
    fuse_product,
    fuse_sum,
    occluded,
    total_similarity,
    update_templates,
)
from plugins.video_tracking.background import BackgroundConfig, BackgroundModel
from plugins.video_tracking.cues import (
    CUES,
    AppearanceCue,
    ColourConfig,
    EdgeConfig,
    LocationConfig,
    Observation,
)
from plugins.video_tracking.errors import InitError, TrackingError, UnknownCueError
from plugins.video_tracking.evaluation import read_mot
from plugins.video_tracking.fusion import WEIGHTS, CueFusion, FusionConfig
from plugins.video_tracking.initiation import InitiationConfig, Initiator, iou
from plugins.video_tracking.particles import (
    CX,
    CY,
    LOG_SCALE,
    VX,
    VY,
    RESAMPLERS,
    ConstantVelocity,
    MotionConfig,
    ParticleSet,
    adaptive_count,
    initialise,
)
from plugins.video_tracking.perspective import PerspectiveScale

__all__ = [
    "TrackerConfig",
    "TargetInit",
    "InitPlan",
    "Estimate",
    "Tracker",
    "init_from_gt",
    "init_from_boxes",
    "read_init_boxes",
    "DIAGNOSTIC_COLUMNS",
    "diagnostic_columns",
    "FUSIONS",
    "Summary",
    "run",
]

#: Columns of a target's diagnostics, per frame, whatever the cues (W (33)–(35), SPEC B.3 and
#: B.5): unweighted means over the target's particles of m(θ_J), of the mass on intersections
#: containing θ_J, of Bel(θ_J), of m(∅), of the inconsistency R of the first fold (W (10)); the
#: particle count and the effective sample size of the weights before resampling; the total
#: similarity ρ_t of the appearance cues at the estimate (C (15)) and the occlusion flag
#: ρ_t < T (1 or 0).  :func:`diagnostic_columns` adds one feature confidence per cue (C (13)).
DIAGNOSTIC_COLUMNS = ("mean_m_target", "mean_m_intersection", "mean_bel", "mean_m_empty", "mean_r",
                      "particles", "ess", "similarity", "occluded")


def diagnostic_columns(cues: Sequence[str]) -> tuple[str, ...]:
    """The diagnostics of a tracker with ``cues``: :data:`DIAGNOSTIC_COLUMNS`, then ``confidence_<cue>`` per cue.

    Examples
    --------
    >>> diagnostic_columns(("colour", "edges"))[-2:]
    ('confidence_colour', 'confidence_edges')
    """
    return DIAGNOSTIC_COLUMNS + tuple(f"confidence_{name}" for name in cues)


#: Where window sizes come from (:attr:`TrackerConfig.scale`).
SCALES = ("perspective", "state")

#: How the cues weigh a particle (:attr:`TrackerConfig.fusion`).
FUSIONS = ("belief", "adaptive", "sum", "product")

#: The conflict level that drives the adaptive particle count (:attr:`TrackerConfig.kappa`).
KAPPAS = ("mass", "r")


# -- configuration --------------------------------------------------------------------------------
@dataclass(frozen=True)
class TrackerConfig:
    """Settings of the tracker (SPEC B.3 defaults unless noted).

    Attributes
    ----------
    particles : int
        N, particles per target (the maximum when ``adaptive_particles`` is on).
    cues : tuple of str
        Cue names of :data:`plugins.video_tracking.cues.CUES`, in fusion order: the
        R-weighted rule folds the cues in this order (SPEC Part D), so it is recorded.
    rule : str
        A combination rule of :data:`belief.RULES` (default: the R-weighted rule).
    weight : {"bel", "pls", "betp"}
        The measure of θ_J that weighs a particle of target J (W (32)).
    r_mode, empty_mode : str
        Options of the R-weighted rule.
    masses : {"relative", "absolute", "normalised"}
        How a cue's likelihoods become its mass function (:class:`FusionConfig`);
        ``"normalised"`` is W (20)–(21).
    scale : {"perspective", "state"}
        Where a window's size comes from: a ground-plane model of box height against the foot
        row, fitted to the birth boxes seen so far
        (:class:`~plugins.video_tracking.perspective.PerspectiveScale`; fixed size until two
        boxes on different rows allow a fit), or the particles' own log-scale random walk.
    motion : MotionConfig
        Noise of the constant-velocity model (default σ_pos = 3 px, σ_vel = 0.5 px/frame).
    resampling : str
        A resampler of :data:`plugins.video_tracking.particles.RESAMPLERS`.
    ess_threshold : float in [0, 1]
        Resample when N_eff < threshold·N; 1 resamples every frame (the papers' choice).
    fusion : {"belief", "adaptive", "sum", "product"}
        How the cues weigh a particle: ``"belief"`` fuses them with ``rule`` and weighs by
        ``weight`` (W (7), W (32)); ``"adaptive"`` is C's confidence-weighted mix of the
        product and sum rules (C (11)–(14), :mod:`plugins.video_tracking.adaptive`);
        ``"sum"`` and ``"product"`` combine the cues' own-target likelihoods with equal
        weights or by their product.  The belief fusion is run for the diagnostics whatever
        the strategy, so every run reports the same curves.
    adaptive_fusion : AdaptiveConfig
        Settings of the adaptive fusion, of the occlusion test (threshold T of C) and of the
        template update (C (16)).
    template_update : bool or None
        Update the appearance templates every frame by C (16), frozen while the target is
        occluded (total similarity C (15) below T).  None (default) updates them for the
        adaptive fusion only, as C does; the belief rules of W keep fixed templates.
    adaptive_particles : bool
        Adapt each target's N to its conflict (SPEC B.3): N_{t+1} = N_min + ⌈(N − N_min)·κ⌉
        with N_min = ⌈N / 2⌉.
    kappa : {"mass", "r"}
        The conflict κ of ``adaptive_particles``, per target, as a mean over its particles:
        ``"mass"`` the mass the fused cues put on target intersections and on ∅ (the
        non-consensus mass of SPEC B.3); ``"r"`` the inconsistency R of the first fold (W (10)).
    location, colour, foreground, edges : LocationConfig, ColourConfig, ColourConfig, EdgeConfig
        Settings of the location, colour, foreground-masked colour and edge cues (location
        default: ``fa_mode="gate"``, ``reference="predicted"``).
    background : BackgroundConfig
        The background model of the foreground cue and of the automatic initiation.
    warm_up : int
        Frames, spread evenly over the whole video, that the background model learns from
        before tracking starts (0: it learns from the tracked frames only).  Without it the
        people in view at the first frame are part of the first background.
    initiation : InitiationConfig or None
        Start tracks on foreground blobs entering at the image border and end tracks that
        leave or lose their foreground (SPEC B.4, :mod:`plugins.video_tracking.initiation`);
        None tracks exactly the targets of the :class:`InitPlan`.
    init_sigma : float
        Spread in pixels of a newborn target's particles around its box centre (W-S1).

    Raises
    ------
    TrackingError
        An unknown cue (:class:`UnknownCueError`), rule, weight or resampler, a repeated cue,
        or a bad count; the message names the field.

    Examples
    --------
    >>> TrackerConfig().cues
    ('colour', 'location', 'foreground')
    >>> TrackerConfig(cues=("colour", "sound"))
    Traceback (most recent call last):
    ...
    plugins.video_tracking.errors.UnknownCueError: unknown cue 'sound'; known cues: colour, location, foreground, edges
    """

    particles: int = 100
    cues: tuple[str, ...] = ("colour", "location", "foreground")
    rule: str = "r_rule"
    weight: str = "bel"
    r_mode: str = "paper"
    empty_mode: str = "union"
    masses: str = "relative"
    scale: str = "perspective"
    motion: MotionConfig = field(default_factory=lambda: MotionConfig(sigma_pos=3.0, sigma_vel=0.5))
    resampling: str = "systematic"
    ess_threshold: float = 1.0
    fusion: str = "belief"
    adaptive_fusion: AdaptiveConfig = field(default_factory=AdaptiveConfig)
    template_update: bool | None = None
    adaptive_particles: bool = False
    kappa: str = "mass"
    location: LocationConfig = field(default_factory=lambda: LocationConfig(fa_mode="gate", reference="predicted"))
    colour: ColourConfig = field(default_factory=ColourConfig)
    foreground: ColourConfig = field(default_factory=ColourConfig)
    edges: EdgeConfig = field(default_factory=EdgeConfig)
    background: BackgroundConfig = field(default_factory=BackgroundConfig)
    warm_up: int = 0
    initiation: InitiationConfig | None = None
    init_sigma: float = 5.0

    def __post_init__(self) -> None:
        if isinstance(self.particles, bool) or not isinstance(self.particles, (int, np.integer)) \
                or self.particles < 1:
            raise TrackingError(f"TrackerConfig.particles must be a positive integer, got {self.particles!r}")
        object.__setattr__(self, "particles", int(self.particles))
        cues = (self.cues,) if isinstance(self.cues, str) else tuple(self.cues)
        if not cues:
            raise TrackingError("TrackerConfig.cues must name at least one cue")
        for name in cues:
            if name not in CUES:
                raise UnknownCueError(f"unknown cue {name!r}; known cues: {', '.join(CUES)}")
        if len(set(cues)) != len(cues):
            raise TrackingError(f"TrackerConfig.cues names a cue twice: {', '.join(cues)}")
        object.__setattr__(self, "cues", cues)
        try:
            self.fusion_config()
        except BeliefError as exc:
            if isinstance(exc, TrackingError):
                raise
            raise TrackingError(str(exc)) from None
        if self.weight not in WEIGHTS:
            raise TrackingError(f"TrackerConfig.weight must be one of {', '.join(WEIGHTS)}, got {self.weight!r}")
        if self.scale not in SCALES:
            raise TrackingError(f"TrackerConfig.scale must be one of {', '.join(SCALES)}, got {self.scale!r}")
        if self.resampling not in RESAMPLERS:
            raise TrackingError(f"unknown resampler {self.resampling!r}; known: {', '.join(sorted(RESAMPLERS))}")
        if not isinstance(self.ess_threshold, (int, float)) or not 0.0 <= self.ess_threshold <= 1.0:
            raise TrackingError(f"TrackerConfig.ess_threshold must lie in [0, 1], got {self.ess_threshold!r}")
        if not isinstance(self.init_sigma, (int, float)) or not math.isfinite(self.init_sigma) \
                or self.init_sigma < 0:
            raise TrackingError(f"TrackerConfig.init_sigma must be a non-negative number, got {self.init_sigma!r}")
        for name, kind in (("motion", MotionConfig), ("location", LocationConfig), ("colour", ColourConfig),
                           ("foreground", ColourConfig), ("edges", EdgeConfig), ("background", BackgroundConfig),
                           ("adaptive_fusion", AdaptiveConfig)):
            if not isinstance(getattr(self, name), kind):
                raise TrackingError(f"TrackerConfig.{name} must be a {kind.__name__}")
        if self.fusion not in FUSIONS:
            raise TrackingError(f"unknown fusion {self.fusion!r}; known fusions: {', '.join(FUSIONS)}")
        if self.kappa not in KAPPAS:
            raise TrackingError(f"TrackerConfig.kappa must be one of {', '.join(KAPPAS)}, got {self.kappa!r}")
        for name in ("adaptive_particles",):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise TrackingError(f"TrackerConfig.{name} must be True or False, got {getattr(self, name)!r}")
        if self.template_update is not None and not isinstance(self.template_update, (bool, np.bool_)):
            raise TrackingError(f"TrackerConfig.template_update must be None, True or False, "
                                f"got {self.template_update!r}")
        if isinstance(self.warm_up, bool) or not isinstance(self.warm_up, (int, np.integer)) or self.warm_up < 0:
            raise TrackingError(f"TrackerConfig.warm_up must be a non-negative integer, got {self.warm_up!r}")
        if self.initiation is not None and not isinstance(self.initiation, InitiationConfig):
            raise TrackingError("TrackerConfig.initiation must be None or an InitiationConfig")

    def fusion_config(self) -> FusionConfig:
        """The :class:`FusionConfig` of these settings (raises ``UnknownRuleError`` for a bad rule)."""
        get_rule(self.rule)
        return FusionConfig(rule=self.rule, weight=self.weight, r_mode=self.r_mode, empty_mode=self.empty_mode,
                            masses=self.masses)

    def cue_config(self, name: str):
        """The settings object of cue ``name``."""
        return {"location": self.location, "colour": self.colour, "foreground": self.foreground,
                "edges": self.edges}[name]

    @property
    def uses_background(self) -> bool:
        """Whether a background model is needed (the foreground cue or the automatic initiation is on)."""
        return "foreground" in self.cues or self.initiation is not None

    @property
    def updates_templates(self) -> bool:
        """Whether the appearance templates follow the target (C (16)); see ``template_update``."""
        return self.fusion == "adaptive" if self.template_update is None else bool(self.template_update)


# -- target births and deaths ---------------------------------------------------------------------
@dataclass(frozen=True)
class TargetInit:
    """One target of an :class:`InitPlan`.

    Attributes
    ----------
    id : int
        The track id written to ``tracks.txt``.
    first_frame : int
        1-based frame at which the target is born, at ``box``.
    last_frame : int or None
        1-based frame after which it is removed; None keeps it to the end.
    box : (float, float, float, float)
        ``x, y, w, h`` in 0-based pixels: the initial centre and the base size.
    """

    id: int
    first_frame: int
    last_frame: int | None
    box: tuple[float, float, float, float]

    def __post_init__(self) -> None:
        box = tuple(float(v) for v in self.box)
        if len(box) != 4 or not all(math.isfinite(v) for v in box) or box[2] <= 0 or box[3] <= 0:
            raise InitError(f"target {self.id}: the box must be finite with a positive size, got {self.box!r}")
        if self.first_frame < 1 or (self.last_frame is not None and self.last_frame < self.first_frame):
            raise InitError(f"target {self.id}: bad frame range {self.first_frame}..{self.last_frame}")
        object.__setattr__(self, "box", box)


@dataclass(frozen=True)
class InitPlan:
    """When each target is born and removed.

    Attributes
    ----------
    targets : tuple of TargetInit
        Distinct ids, in birth order (then id order).
    source : str
        Where the plan came from, for the summary.
    """

    targets: tuple[TargetInit, ...]
    source: str = ""

    def __post_init__(self) -> None:
        targets = tuple(sorted(self.targets, key=lambda t: (t.first_frame, t.id)))
        if not targets:
            raise InitError(f"{self.source or 'the init'}: no target to track")
        ids = [t.id for t in targets]
        if len(set(ids)) != len(ids):
            raise InitError(f"{self.source or 'the init'}: a target id appears twice")
        object.__setattr__(self, "targets", targets)

    def check_image(self, width: int, height: int) -> None:
        """Raise :class:`InitError` if a birth box does not overlap a ``width`` × ``height`` image."""
        for target in self.targets:
            x, y, w, h = target.box
            if x >= width or y >= height or x + w <= 0 or y + h <= 0:
                raise InitError(f"{self.source or 'init'}: the box of target {target.id} "
                                f"(x={x + 1:g}, y={y + 1:g}, w={w:g}, h={h:g}, 1-based) lies outside the "
                                f"{width}x{height} image")

    def births(self, frame: int) -> list[TargetInit]:
        """Targets born at 1-based ``frame``."""
        return [t for t in self.targets if t.first_frame == frame]


def init_from_gt(gt: str | PathLike[str] | np.ndarray, source: str | None = None) -> InitPlan:
    """Targets from a MOTChallenge ground truth: each id is born at its first box, removed after its last.

    Parameters
    ----------
    gt : path or ndarray, shape (M, ≥6)
        A file for :func:`~plugins.video_tracking.evaluation.read_mot`, or its rows
        ``frame, id, x, y, w, h, ...`` (1-based frames and corners).

    Examples
    --------
    >>> rows = np.array([[1, 7, 11, 21, 10, 20], [2, 7, 12, 21, 10, 20], [2, 3, 1, 1, 5, 5]])
    >>> [(t.id, t.first_frame, t.last_frame, t.box) for t in init_from_gt(rows).targets]
    [(7, 1, 2, (10.0, 20.0, 10.0, 20.0)), (3, 2, 2, (0.0, 0.0, 5.0, 5.0))]
    """
    if isinstance(gt, np.ndarray):
        rows, name = np.asarray(gt, dtype=np.float64), source or "ground truth"
    else:
        rows, name = read_mot(gt), source or str(gt)
    if rows.ndim != 2 or rows.shape[0] == 0 or rows.shape[1] < 6:
        raise InitError(f"{name}: no boxes to initialise the targets from")
    targets = []
    for track_id in np.unique(rows[:, 1]):
        own = rows[rows[:, 1] == track_id]
        own = own[np.argsort(own[:, 0], kind="stable")]
        first = own[0]
        box = (first[2] - 1.0, first[3] - 1.0, first[4], first[5])
        if first[4] <= 0 or first[5] <= 0:
            raise InitError(f"{name}: the first box of id {int(track_id)} has no area")
        targets.append(TargetInit(int(track_id), int(own[0, 0]), int(own[-1, 0]), box))
    return InitPlan(tuple(targets), source=name)


def read_init_boxes(path: str | PathLike[str]) -> InitPlan:
    """Targets from a CSV of ``id,x,y,w,h`` lines, all born at frame 1 and never removed.

    ``x, y`` is the top-left corner in the MOTChallenge convention (1-based, as in
    ``tracks.txt`` and ground-truth files).  Blank lines and lines starting with ``#`` are
    skipped, and so is a first line ``id,x,y,w,h``.

    Raises
    ------
    InitError
        Missing, unreadable or empty file, a malformed line (named with its number), a
        non-positive size or a repeated id.
    """
    name = str(path)
    try:
        with open(path, encoding="utf-8-sig") as handle:
            text = handle.read()
    except FileNotFoundError:
        raise InitError(f"cannot read init file {name!r}: no such file") from None
    except IsADirectoryError:
        raise InitError(f"cannot read init file {name!r}: it is a directory") from None
    except (UnicodeDecodeError, OSError) as exc:
        raise InitError(f"cannot read init file {name!r}: {getattr(exc, 'strerror', None) or exc}") from None
    targets = []
    seen: set[int] = set()
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        fields_ = [f.strip() for f in stripped.split(",")]
        if not targets and [f.lower() for f in fields_] == ["id", "x", "y", "w", "h"]:
            continue
        if len(fields_) != 5:
            raise InitError(f"{name}, line {number}: expected 5 fields id,x,y,w,h, got {len(fields_)}")
        try:
            values = [float(f) for f in fields_]
        except ValueError:
            raise InitError(f"{name}, line {number}: a field is not a number: {stripped!r}") from None
        if not all(math.isfinite(v) for v in values):
            raise InitError(f"{name}, line {number}: a field is not finite")
        track_id, x, y, w, h = values
        if track_id != int(track_id):
            raise InitError(f"{name}, line {number}: the id must be an integer, got {track_id:g}")
        if w <= 0 or h <= 0:
            raise InitError(f"{name}, line {number}: the box needs a positive width and height, got {w:g} x {h:g}")
        if int(track_id) in seen:
            raise InitError(f"{name}, line {number}: id {int(track_id)} appears twice")
        seen.add(int(track_id))
        targets.append(TargetInit(int(track_id), 1, None, (x - 1.0, y - 1.0, w, h)))
    if not targets:
        raise InitError(f"init file {name!r} holds no boxes (it is empty)")
    return InitPlan(tuple(targets), source=name)


def init_from_boxes(boxes: Iterable[Sequence[float]], ids: Sequence[int] | None = None) -> InitPlan:
    """Targets at 0-based boxes ``(x, y, w, h)``, born at frame 1 and never removed.

    Examples
    --------
    >>> init_from_boxes([(10, 20, 8, 16)]).targets[0]
    TargetInit(id=1, first_frame=1, last_frame=None, box=(10.0, 20.0, 8.0, 16.0))
    """
    boxes = [tuple(b) for b in boxes]
    ids = list(range(1, len(boxes) + 1)) if ids is None else list(ids)
    if len(ids) != len(boxes):
        raise InitError(f"{len(ids)} ids for {len(boxes)} boxes")
    return InitPlan(tuple(TargetInit(int(i), 1, None, b) for i, b in zip(ids, boxes)), source="boxes")


# -- the tracker ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Estimate:
    """One target's output at one frame.

    Attributes
    ----------
    frame : int
        1-based frame number.
    id : int
        Track id.
    state : ndarray, shape (5,)
        The weighted-mean state (W (6)); a newborn target's is its box centre.
    box : (float, float, float, float)
        ``x, y, w, h`` in 0-based pixels: centre of the estimate, base size × exp(log_scale).
    diagnostics : dict of str to float, or None
        :data:`DIAGNOSTIC_COLUMNS` of this frame; None at the birth frame (nothing was fused).
    """

    frame: int
    id: int
    state: np.ndarray
    box: tuple[float, float, float, float]
    diagnostics: dict[str, float] | None = None

    def mot_row(self) -> list[float]:
        """``frame, id, x, y, w, h, -1, -1, -1, -1`` with a 1-based top-left corner (MOTChallenge)."""
        x, y, w, h = self.box
        return [self.frame, self.id, x + 1.0, y + 1.0, w, h, -1, -1, -1, -1]


@dataclass
class _Target:
    id: int
    last_frame: int | None
    size: np.ndarray          # (2,) base w, h
    particles: ParticleSet
    estimate: np.ndarray      # (5,) at t − 1
    birth_cy: float = 0.0     # centre row of the birth box, the reference of the perspective scale
    similarity: float = 0.8   # total similarity ρ_{t−1} of C (15), ρ_0 at birth
    occluded: bool = False
    growing: bool = False     # born in part at the image border: its size follows its blob until all is in


class Tracker:
    """Tracks targets through a sequence of frames.

    Parameters
    ----------
    config : TrackerConfig
    init : InitPlan or None
        Births and deaths of planned targets.  None, or targets not in the plan, need
        ``config.initiation``: the tracker then starts and ends tracks itself (SPEC B.4), with
        ids after the plan's largest.
    rng : numpy.random.Generator
        The only source of randomness (initialisation, motion noise, resampling, and the
        resampling inside the feature confidences through a child generator spawned from it).

    Attributes
    ----------
    targets : list
        The live targets in the order of the cues' templates (birth order).
    diagnostic_columns : tuple of str
        The keys of every :attr:`Estimate.diagnostics` (:func:`diagnostic_columns`).

    Examples
    --------
    >>> from plugins.video_tracking import scenes
    >>> scene = scenes.render(scenes.crossing(0))
    >>> plan = init_from_gt(scene.ground_truth)
    >>> tracker = Tracker(TrackerConfig(particles=20), plan, np.random.default_rng(0))
    >>> estimates = [tracker.step(t + 1, scene.frame(t)) for t in range(3)]
    >>> [e.id for e in estimates[-1]], all(np.isfinite(e.box).all() for e in estimates[-1])
    ([1, 2], True)
    >>> sorted(estimates[-1][0].diagnostics)[:4]
    ['confidence_colour', 'confidence_foreground', 'confidence_location', 'ess']
    """

    def __init__(self, config: TrackerConfig, init: InitPlan | None, rng: np.random.Generator) -> None:
        if not isinstance(config, TrackerConfig):
            raise TrackingError(f"Tracker needs a TrackerConfig, got {type(config).__name__}")
        if init is not None and not isinstance(init, InitPlan):
            raise TrackingError(f"Tracker needs an InitPlan or None, got {type(init).__name__}")
        if init is None and config.initiation is None:
            raise InitError("nothing to track: give an InitPlan or turn on the automatic initiation "
                            "(TrackerConfig.initiation)")
        if not isinstance(rng, np.random.Generator):
            raise TrackingError(f"Tracker needs a numpy.random.Generator, got {type(rng).__name__}")
        self.config = config
        self.init = init
        self.rng = rng
        # A child stream for the confidences' resampling (C (11)) leaves the draws of the
        # filter itself as they are without it.
        self._feature_rng = rng.spawn(1)[0]
        self.cues = [CUES[name](config.cue_config(name)) for name in config.cues]
        self.background = BackgroundModel(config.background) if config.uses_background else None
        self.targets: list[_Target] = []
        self._fusion: CueFusion | None = None
        self._fusion_config = config.fusion_config()
        self._motion: ConstantVelocity | None = None
        self._image_shape: tuple[int, int] | None = None
        self._last_frame = 0
        self._birth_boxes: list[tuple[float, float, float, float]] = []
        self.perspective: PerspectiveScale | None = None
        self.initiator: Initiator | None = None
        planned = [t.id for t in init.targets] if init is not None else []
        self._next_id = max(planned, default=0) + 1
        self.diagnostic_columns = diagnostic_columns(config.cues)

    # -- births and deaths --------------------------------------------------------------------
    def add_target(self, target: TargetInit, image: np.ndarray, foreground: np.ndarray | None = None,
                   growing: bool = False, planned: bool = True) -> Estimate:
        """Start tracking ``target`` at its box in ``image`` (W-S1); returns its first estimate.

        ``growing`` marks a target seen only in part, entering at the image border: until its
        foreground blob leaves the border zone the blob gives its size, and then its templates
        are taken anew (needs the automatic initiation, which finds the blobs).  A target
        that is not ``planned`` (found by the initiation) does not enter the fit of the
        perspective model.
        """
        if any(t.id == target.id for t in self.targets):
            raise InitError(f"target {target.id} is already being tracked")
        height, width = image.shape[:2]
        InitPlan((target,), source=self.init.source if self.init is not None else "").check_image(width, height)
        x, y, w, h = target.box
        centre = (x + w / 2.0, y + h / 2.0)
        for cue in self.cues:
            if isinstance(cue, AppearanceCue):
                cue.add_target(image, target.box, foreground)
        states = initialise(centre, self.config.particles, self.rng, sigma_pos=self.config.init_sigma)
        estimate = np.array([centre[0], centre[1], 0.0, 0.0, 0.0])
        self.targets.append(_Target(target.id, target.last_frame, np.array([w, h]), ParticleSet(states), estimate,
                                    birth_cy=centre[1], similarity=self.config.adaptive_fusion.rho0,
                                    growing=bool(growing) and self.config.initiation is not None))
        # Blob boxes are too rough (merged groups, shadows, missing legs) to fit the ground
        # plane on: only the boxes of planned births (by hand or from a ground truth) are used.
        if self.config.scale == "perspective" and planned:
            self._birth_boxes.append(target.box)
            self.perspective = PerspectiveScale.fit(self._birth_boxes)
        self._next_id = max(self._next_id, target.id + 1)
        self._fusion = None
        return Estimate(self._last_frame, target.id, estimate.copy(), target.box)

    def remove_target(self, target_id: int) -> None:
        """Stop tracking ``target_id``; the cues forget its template."""
        index = next((k for k, t in enumerate(self.targets) if t.id == target_id), None)
        if index is None:
            raise TrackingError(f"no live target {target_id!r} to remove")
        for cue in self.cues:
            if isinstance(cue, AppearanceCue):
                cue.remove_target(index)
        del self.targets[index]
        self._fusion = None

    def warm_up(self, frames: Iterable[np.ndarray]) -> int:
        """Let the background model learn from ``frames`` before tracking; returns how many (0 without a model)."""
        if self.background is None:
            return 0
        return self.background.warm_up(frames)

    # -- one frame ----------------------------------------------------------------------------
    def step(self, frame: int, image: np.ndarray) -> list[Estimate]:
        """Process 1-based ``frame``: deaths, W-S2..S5 for the live targets, then births.

        With the automatic initiation, tracks that left or lost their foreground end here
        (their estimate of this frame is dropped) and blobs entering the image start tracks.

        Parameters
        ----------
        frame : int
            1-based frame number, increasing by one per call.
        image : ndarray of uint8, shape (H, W, 3)
            The BGR frame.

        Returns
        -------
        list of Estimate
            One per target alive at this frame, in the tracker's target order.
        """
        image = np.asarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8 or 0 in image.shape:
            raise TrackingError(f"frames must be (H, W, 3) uint8 arrays, got shape {image.shape} dtype {image.dtype}")
        if self._image_shape is None:
            self._image_shape = image.shape[:2]
            height, width = self._image_shape
            self._motion = ConstantVelocity(self.config.motion, bounds=(width, height))
            if self.config.initiation is not None:
                self.initiator = Initiator(self.config.initiation, self._image_shape)
        elif image.shape[:2] != self._image_shape:
            raise TrackingError(f"frame {frame} has size {image.shape[:2]}, the first had {self._image_shape}")
        self._last_frame = frame
        for target in [t for t in self.targets if t.last_frame is not None and t.last_frame < frame]:
            self.remove_target(target.id)
        foreground = self.background.apply(image) if self.background is not None else None
        estimates = self._filter(frame, image, foreground) if self.targets else []
        for target in self.init.births(frame) if self.init is not None else []:
            estimates.append(self.add_target(target, image, foreground))
        if self.initiator is not None:
            boxes = {e.id: e.box for e in estimates}
            births, deaths = self.initiator.update(foreground, boxes)
            for target_id in deaths:
                self.remove_target(target_id)
            ended = set(deaths)
            estimates = [e for e in estimates if e.id not in ended]
            self._grow(image, foreground)
            partial = self.initiator.touches_border(births) if births else []
            for box, growing in zip(births, partial):
                born = TargetInit(self._next_id, frame, None, tuple(float(v) for v in box))
                estimates.append(self.add_target(born, image, foreground, growing=growing, planned=False))
        return estimates

    def _grow(self, image: np.ndarray, foreground: np.ndarray) -> None:
        """Targets entering the image take the size and centre of their blob until all of it is in view."""
        blobs = self.initiator.blobs
        if not len(blobs):
            return
        for index, target in enumerate(self.targets):
            if not target.growing:
                continue
            overlap = iou(np.array([self._box(target, target.estimate)]), blobs)[0]
            best = int(np.argmax(overlap))
            if overlap[best] <= 0:
                continue
            x, y, w, h = blobs[best]
            centre = np.array([x + w / 2.0, y + h / 2.0])
            shift = np.zeros(target.particles.states.shape[1])
            shift[[CX, CY]] = centre - target.estimate[[CX, CY]]
            target.particles = ParticleSet(target.particles.states + shift, target.particles.log_weights)
            target.estimate = target.estimate + shift
            target.size = np.array([w, h])
            target.birth_cy = float(centre[1])
            if self.initiator.touches_border(blobs[best])[0]:
                continue
            target.growing = False
            for cue in self.cues:
                if isinstance(cue, AppearanceCue):
                    cue.rebuild_template(index, image, (x, y, w, h), foreground)

    def _filter(self, frame: int, image: np.ndarray, foreground: np.ndarray | None) -> list[Estimate]:
        config = self.config
        tau = len(self.targets)
        # W-S2: propagate.  The t − 1 particles (after resampling) give d_max (W (23)).
        previous = np.concatenate([t.particles.states[:, [CX, CY]] for t in self.targets])
        moved = [t.particles.propagate(self._motion, self.rng) for t in self.targets]
        if config.scale == "perspective":
            # Without a fitted model every target keeps its birth size: a random walk on the
            # scale would drift, since the foreground-masked colour rewards shrinking windows.
            for k, (target, particles) in enumerate(zip(self.targets, moved)):
                rescaled = particles.states.copy()
                rescaled[:, LOG_SCALE] = 0.0 if target.growing or self.perspective is None else \
                    self.perspective.log_scale(rescaled[:, CY], target.birth_cy)
                moved[k] = ParticleSet(rescaled, particles.log_weights)
        counts = np.array([len(p) for p in moved])
        states = np.concatenate([p.states for p in moved])                              # (P, 5)
        owner = np.repeat(np.arange(tau), counts)                                       # (P,)
        obs = Observation(image, foreground,
                          centres=self._location_centres(),
                          sizes=np.array([t.size for t in self.targets]),
                          previous_particles=previous)
        # W-S3: every cue scores every particle against θ_1..θ_τ, FA.
        scores = [cue.log_likelihoods(obs, states, owner) for cue in self.cues]
        if self._fusion is None or self._fusion.n_targets != tau:
            self._fusion = CueFusion(tau, self._fusion_config)
        result = self._fusion.fuse(scores, owner)
        own = np.stack([s[np.arange(owner.size), owner] for s in scores], axis=1)       # (P, c)
        adaptive = config.adaptive_fusion
        spreads = feature_spreads(states[:, [CX, CY]], own, owner, tau, self._feature_rng, keep=adaptive.keep,
                                  epsilon=adaptive.epsilon)                              # C (11)
        confidences = feature_confidences(spreads, feature_entropies(own, owner, tau),
                                          epsilon=adaptive.epsilon)                      # C (12)–(13)
        log_weights = self._log_weights(result, own, owner, confidences)
        per_target = {
            "mean_m_target": _means(result.singleton_mass, owner, counts),
            "mean_m_intersection": _means(result.intersection_mass, owner, counts),
            "mean_bel": _means(result.bel, owner, counts),
            "mean_m_empty": _means(result.empty_mass, owner, counts),
            "mean_r": _means(result.inconsistency, owner, counts),
        }
        kappa = per_target["mean_r"] if config.kappa == "r" else \
            per_target["mean_m_intersection"] + per_target["mean_m_empty"]
        estimates = []
        weighted_sets = []
        starts = np.concatenate([[0], np.cumsum(counts)])
        for j, (target, particles) in enumerate(zip(self.targets, moved)):
            weighted = particles.reweight(log_weights[starts[j]:starts[j + 1]])          # normalised in the set
            target.estimate = weighted.estimate()                                        # W-S4, W (6)
            weighted_sets.append(weighted)
        similarity, occluded = self._follow_appearance(obs, confidences)                # C (15), C (16)
        for j, (target, weighted) in enumerate(zip(self.targets, weighted_sets)):
            diagnostics = {name: float(values[j]) for name, values in per_target.items()}
            diagnostics["particles"] = float(len(weighted))
            diagnostics["ess"] = weighted.ess()
            diagnostics["similarity"] = float(similarity[j])
            diagnostics["occluded"] = float(occluded[j])
            for k, name in enumerate(config.cues):
                diagnostics[f"confidence_{name}"] = float(confidences[j, k])
            n_next = None
            if config.adaptive_particles:
                n_next = adaptive_count(float(np.clip(kappa[j], 0.0, 1.0)), math.ceil(config.particles / 2),
                                        config.particles)
            target.particles = weighted.resample(self.rng, method=config.resampling,     # W-S5
                                                 threshold=config.ess_threshold, n=n_next)
            target.similarity, target.occluded = float(similarity[j]), bool(occluded[j])
            state = target.estimate
            estimates.append(Estimate(frame, target.id, state.copy(), self._box(target, state), diagnostics))
        return estimates

    def _log_weights(self, result, own: np.ndarray, owner: np.ndarray, confidences: np.ndarray) -> np.ndarray:
        """Log-weights of the particles under the configured fusion strategy, shape (P,)."""
        fusion, tau = self.config.fusion, len(self.targets)
        if fusion == "sum":
            return fuse_sum(own, owner, tau)
        if fusion == "product":
            return fuse_product(own, owner, tau)
        if fusion == "adaptive":
            previous = np.array([t.similarity for t in self.targets])
            return fuse_adaptive(own, owner, tau, confidences, previous,
                                 mix_norm=self.config.adaptive_fusion.mix_norm)             # C (14)
        weights = np.nan_to_num(np.asarray(result.weights, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
        with np.errstate(divide="ignore"):
            return np.log(np.maximum(weights, 0.0))                                       # 0 → -inf

    def _follow_appearance(self, obs: Observation, confidences: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Total similarity ρ_t at the new estimates (C (15)), the occlusion flags, and C (16).

        ρ_{i,t} = ρ[p_i(x̂_t), q̂_{i,t−1}] for every appearance cue i, weighted by the cues'
        confidences renormalised over the appearance cues; without one ρ_t = 1.  The templates
        are updated when ``config.updates_templates``, and kept while a target is occluded.
        """
        tau = len(self.targets)
        columns = [k for k, cue in enumerate(self.cues) if isinstance(cue, AppearanceCue)]
        if not columns:
            return np.ones(tau), np.zeros(tau, dtype=bool)
        hat = np.array([t.estimate for t in self.targets])      # their log-scales follow the perspective model
        index = np.arange(tau)
        current = [self.cues[k].histograms(obs, hat, index) for k in columns]                # each (τ, B)
        rho = np.stack([_row_similarity(p, self.cues[k].templates) for p, k in zip(current, columns)], axis=1)
        similarity = total_similarity(confidences[:, columns], rho)
        flags = occluded(similarity, self.config.adaptive_fusion.threshold)
        if self.config.updates_templates:
            for p, k in zip(current, columns):
                cue = self.cues[k]
                updated = update_templates(cue.initial_templates, cue.templates, p, flags,
                                           variant=self.config.adaptive_fusion.update)
                for j in range(tau):
                    cue.replace_template(j, updated[j])
        return similarity, flags

    def _location_centres(self) -> np.ndarray:
        """The t − 1 centres, moved on by their velocities if the location cue asks so, shape (τ, 2)."""
        centres = np.array([t.estimate[[CX, CY]] for t in self.targets])
        if self.config.location.reference == "predicted":
            centres = centres + self.config.motion.dt * np.array([t.estimate[[VX, VY]] for t in self.targets])
        return centres

    @staticmethod
    def _box(target: _Target, state: np.ndarray) -> tuple[float, float, float, float]:
        w, h = target.size * math.exp(float(np.clip(state[LOG_SCALE], -30.0, 30.0)))
        return (float(state[CX] - w / 2.0), float(state[CY] - h / 2.0), float(w), float(h))


def _row_similarity(histograms: np.ndarray, templates: np.ndarray) -> np.ndarray:
    """ρ[h_j, q_j] row by row (C (9)), shape (τ,)."""
    return np.clip(np.sqrt(np.maximum(histograms, 0.0) * templates).sum(axis=1), 0.0, 1.0)


def _means(values: np.ndarray, owner: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Per-target unweighted means of per-particle ``values`` (W (33)–(35)), shape (τ,)."""
    return np.bincount(owner, weights=np.asarray(values, dtype=np.float64), minlength=counts.size) / counts


# -- a whole run ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Summary:
    """What a :func:`run` did.

    Attributes
    ----------
    frames : int
        Frames processed.
    tracking_fps : float
        Frames per second of the tracker alone (decoding and output excluded).
    overall_fps : float
        Frames per second of the whole run (decoding and writing included).
    tracks : ndarray, shape (M, 10)
        The rows of ``tracks.txt``.
    scores : Scores or None
        The evaluation against the ground truth, when it is known.
    files : dict of str to Path
        The output files by name.
    diagnostics : list of dict
        The rows of ``diagnostics.csv`` (frame, id and the diagnostic columns), unrounded.
    """

    frames: int
    tracking_fps: float
    overall_fps: float
    tracks: np.ndarray
    scores: object | None
    files: dict
    diagnostics: list = field(default_factory=list, repr=False)

    def to_dict(self) -> dict:
        """The JSON-ready part (no arrays)."""
        return {"frames": self.frames, "tracking_fps": self.tracking_fps, "overall_fps": self.overall_fps,
                "scores": None if self.scores is None else self.scores.to_dict(),
                "files": {k: str(v) for k, v in self.files.items()}}


def run(source, init: InitPlan | None, config: TrackerConfig = TrackerConfig(), out_dir: str | PathLike[str] = "track",
        seed: int = 0, write_video: bool = True, progress: bool = True, gt: np.ndarray | str | None = None,
        extra_outputs: dict | None = None, write_plot: bool = True) -> Summary:
    """Track ``source`` and write the outputs into ``out_dir``.

    Parameters
    ----------
    source : path, Scene or ndarray of uint8, shape (T, H, W, 3)
        A video file (decoded with OpenCV), a rendered synthetic scene, or frames.
    init : InitPlan or None
        Births and deaths of the targets (:func:`init_from_gt`, :func:`read_init_boxes`);
        None leaves them all to the automatic initiation (``config.initiation``).
    config : TrackerConfig
        With ``config.warm_up`` > 0 the background model first learns from that many frames
        spread over the whole source (a video file is then decoded twice).
    out_dir : path
        Receives ``tracks.txt``, ``diagnostics.csv``, ``diagnostics.png`` (unless
        ``write_plot`` is false), ``annotated.avi`` (unless ``write_video`` is false) and
        ``summary.json``, written last.
    seed : int
        Seed of the run's only random generator.
    progress : bool
        Show a progress bar on standard error (only when it is a terminal).
    gt : ndarray or path, optional
        Ground truth to score the tracks against (:func:`~plugins.video_tracking.evaluation.evaluate`).
    extra_outputs : dict of str to callable, optional
        Further files ``name -> write(path)``, committed with the others.
    write_plot : bool
        Draw ``diagnostics.png`` (repeated runs of an experiment skip it).

    Returns
    -------
    Summary

    Raises
    ------
    TrackingError
        Unreadable video (:class:`VideoError`), boxes outside the image (:class:`InitError`), …
        On any error the staged files are deleted: nothing that looks complete is left.
    """
    import sys
    import time

    from belief import __version__
    from plugins.video_tracking import outputs
    from plugins.video_tracking.evaluation import evaluate
    from plugins.video_tracking.video import AnnotatedVideoWriter, VideoReader

    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise TrackingError(f"the seed must be a non-negative integer, got {seed!r}")
    if init is not None and not isinstance(init, InitPlan):
        raise TrackingError(f"init must be an InitPlan or None, got {type(init).__name__}")
    if not isinstance(config, TrackerConfig):
        raise TrackingError(f"config must be a TrackerConfig, got {type(config).__name__}")
    if init is None and config.initiation is None:
        raise InitError("nothing to track: give an init plan or turn on the automatic initiation")
    started = time.perf_counter()
    reader = None
    if isinstance(source, (str, PathLike)):
        reader = VideoReader(source)
        frames, fps, total = reader, reader.fps, reader.frame_count
        width, height, source_name = reader.width, reader.height, str(source)
    else:
        frames = getattr(source, "frames", source)
        frames = np.asarray(frames)
        if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8 or 0 in frames.shape:
            raise TrackingError(f"frames must be a (T, H, W, 3) uint8 array, got shape {frames.shape}")
        height, width = frames.shape[1:3]
        fps, total = 25.0, frames.shape[0]
        config_of_scene = getattr(source, "config", None)
        source_name = f"scene {config_of_scene.name!r}" if config_of_scene is not None else "frames"
    gt_rows = None
    if gt is not None:
        gt_rows = read_mot(gt) if isinstance(gt, (str, PathLike)) else np.asarray(gt, dtype=np.float64)
    try:
        if init is not None:
            init.check_image(width, height)
        staged = outputs.StagedOutputs(out_dir)
    except BaseException:
        if reader is not None:
            reader.close()
        raise
    try:
        rng = np.random.default_rng(int(seed))
        tracker = Tracker(config, init, rng)
        if config.warm_up > 0 and tracker.background is not None:
            tracker.warm_up(_spread_frames(source, frames, total, config.warm_up))
        writer = AnnotatedVideoWriter(staged.path("annotated.avi"), fps) if write_video else None
        rows: list[list[float]] = []
        records: list[dict[str, float]] = []
        tracking_seconds = 0.0
        count = 0
        from tqdm import tqdm

        bar = tqdm(total=total, unit="frame", desc="tracking", file=sys.stderr, leave=False,
                   disable=not progress or not sys.stderr.isatty())
        try:
            for index, image in enumerate(frames):
                frame = index + 1
                tick = time.perf_counter()
                estimates = tracker.step(frame, image)
                tracking_seconds += time.perf_counter() - tick
                for estimate in estimates:
                    row = estimate.mot_row()
                    if not np.isfinite(row).all():
                        raise TrackingError(f"frame {frame}: target {estimate.id} has a non-finite estimate")
                    rows.append(row)
                    if estimate.diagnostics is not None:
                        records.append({"frame": frame, "id": estimate.id, **estimate.diagnostics})
                if writer is not None:
                    writer.write(image, frame, [(e.id, e.box) for e in estimates])
                count += 1
                bar.update(1)
        finally:
            bar.close()
            if writer is not None:
                writer.close()
        if count == 0:
            raise TrackingError(f"{source_name}: no frame to track")
        tracks = np.array(rows, dtype=np.float64).reshape(-1, 10)
        outputs.write_tracks(staged.path("tracks.txt"), rows)
        outputs.write_diagnostics(staged.path("diagnostics.csv"), records,
                                  ("frame", "id") + tracker.diagnostic_columns)
        if write_plot:
            outputs.plot_diagnostics(staged.path("diagnostics.png"), records,
                                     title=f"{source_name}: {_strategy(config)}",
                                     threshold=config.adaptive_fusion.threshold)
        for name, write in (extra_outputs or {}).items():
            write(staged.path(name))
        scores = evaluate(gt_rows, tracks) if gt_rows is not None else None
        overall = time.perf_counter() - started
        tracking_fps = count / tracking_seconds if tracking_seconds > 0 else float("inf")
        overall_fps = count / overall if overall > 0 else float("inf")
        from dataclasses import asdict

        summary = {
            "source": source_name,
            "frames": count,
            "targets": len({int(row[1]) for row in rows}),
            "track_rows": len(rows),
            "fps": {"tracking": tracking_fps, "overall": overall_fps,
                    "decoding_seconds": reader.decode_seconds if reader is not None else 0.0,
                    "tracking_seconds": tracking_seconds, "overall_seconds": overall},
            "seed": int(seed),
            "init": init.source if init is not None else "automatic initiation",
            "parameters": asdict(config),
            "version": __version__,
            "scores": scores.to_dict() if scores is not None else None,
        }
        outputs.write_summary(staged.path("summary.json"), summary)
        files = staged.commit()
    except BaseException:
        staged.abort()
        raise
    finally:
        if reader is not None:
            reader.close()
    return Summary(count, tracking_fps, overall_fps, tracks, scores, files, records)


def _strategy(config: TrackerConfig) -> str:
    """How the particles are weighed, for titles."""
    if config.fusion == "belief":
        return f"rule {config.rule}, weight {config.weight}"
    return f"{config.fusion} fusion"


def _spread_frames(source, frames, total: int | None, count: int):
    """Up to ``count`` frames spread evenly over a video file or an array of frames (the first ones if
    the length is unknown)."""
    if total:
        picks = set(np.linspace(0, total - 1, num=min(count, total)).round().astype(int).tolist())
    else:
        picks = set(range(count))
    if not isinstance(source, (str, PathLike)):
        return (frames[k] for k in sorted(picks))
    from plugins.video_tracking.video import VideoReader

    def read():
        with VideoReader(source) as reader:
            for k, image in enumerate(reader):
                if k in picks:
                    yield image
                if k >= max(picks):
                    break
    return read()
