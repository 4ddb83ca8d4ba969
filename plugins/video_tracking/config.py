"""The tracker's settings, :class:`TrackerConfig`, checked once when they are made.

Each part of the tracker has its own frozen settings dataclass, defined and given its
defaults next to the part (``ColourConfig`` in :mod:`~belief_tracking.cues`,
``MotionConfig`` in :mod:`~belief_tracking.particles`, …); :class:`TrackerConfig`
gathers them with the choices that assemble the parts (which cues, which weighting
strategy, which rule).  Every field is checked in ``__post_init__`` and raises
:class:`~belief_tracking.errors.TrackingError` naming the field; the tracker trusts
the settings after that.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, is_dataclass
from typing import Any

from belief.errors import BeliefError
from . import checks, limits
from .adaptive import AdaptiveConfig
from .background import BackgroundConfig
from .cues import CUES, ColourConfig, DetectionConfig, EdgeConfig, LocationConfig
from .errors import TrackingError, UnknownCueError
from .limits import shown
from .fusion import FusionConfig
from .initiation import InitiationConfig
from .particles import RESAMPLERS, MotionConfig
from .weighting import WEIGHTINGS

__all__ = ["TrackerConfig", "KAPPAS", "DIAGNOSTICS", "MAX_TARGETS"]

#: The conflict level that drives the adaptive particle count (:attr:`TrackerConfig.kappa`).
KAPPAS = ("mass", "r")

#: Which diagnostics a run records (:attr:`TrackerConfig.diagnostics`).
DIAGNOSTICS = ("strategy", "all")

#: The default of :attr:`TrackerConfig.max_targets`, the most targets tracked at once.  With
#: 100 particles a frame of 320 x 240 takes about 1.5 s at 100 targets, 5 s at 200 and
#: (cubically) minutes at 500.
MAX_TARGETS = 100
#: Other spellings of cue names, read as the cue's own name.
CUE_SPELLINGS = {"color": "colour"}

#: The largest :attr:`TrackerConfig.max_targets` accepted at all (the memory estimate bounds it further).
MAX_TARGETS_BOUND = 100_000

#: Sample points of a box, across times down, in a colour or edge cue (default 12 x 24 = 288).
#: The cost of a particle grows with them: 4096 samples make a frame 14 times slower.
MAX_SAMPLES = 4096


@dataclass(frozen=True)
class TrackerConfig:
    """Settings of the tracker (SPEC B.3 defaults unless noted).

    Attributes
    ----------
    particles : int
        N, particles per target (the maximum when ``adaptive_particles`` is on).
    cues : tuple of str
        Cue names of :data:`belief_tracking.cues.CUES`, in fusion order: the
        R-weighted rule folds the cues in this order (SPEC Part D), so it is recorded.
    fusion : {"belief", "adaptive", "sum", "product"}
        The weighting strategy of :data:`belief_tracking.weighting.WEIGHTINGS`:
        ``"belief"`` fuses the cues' mass functions with ``rule`` and weighs a particle of
        target J by ``weight`` of θ_J (W (7), W (32)); ``"adaptive"`` is C's
        confidence-weighted mix of the product and sum rules (C (11)–(14)), with the
        occlusion test and the template update of C (15)–(16); ``"sum"`` and ``"product"``
        combine the cues' own-target likelihoods with equal weights or by their product.
    belief : FusionConfig
        How the belief strategy fuses the cues and weighs a particle
        (:class:`~belief_tracking.fusion.FusionConfig`): the combination rule (default the
        R-weighted rule of SPEC A.4), the measure of θ_J that weighs a particle of target J
        (W (32): Bel), the options of the R-weighted rule and how a cue's likelihoods become
        its mass function.  The adaptive particle count fuses with it whatever the strategy.
    motion : MotionConfig
        Noise of the constant-velocity model (W-S2).
    resampling : str
        A resampler of :data:`belief_tracking.particles.RESAMPLERS`.
    ess_threshold : float in [0, 1]
        Resample when N_eff < threshold·N; 1 resamples every frame (the papers' choice).
    adaptive_fusion : AdaptiveConfig
        Settings of C's adaptive fusion, its occlusion test (threshold T) and its template
        update.
    template_update : bool
        Let the appearance templates follow their targets by C (16), frozen while a target
        is occluded (total similarity C (15) below T), with the strategies that keep fixed
        templates in their papers (belief, sum, product).  The adaptive strategy always
        updates its templates: C's method includes it.
    adaptive_particles : bool
        Adapt each target's N to its conflict (SPEC B.3): N_{t+1} = N_min + ⌈(N − N_min)·κ⌉
        with N_min = ⌈N / 2⌉.
    kappa : {"mass", "r"}
        The conflict κ of ``adaptive_particles``, per target, as a mean over its particles of
        the fused cues (with ``rule``, whatever the strategy): ``"mass"`` the mass on target
        intersections and on ∅ (the non-consensus mass of SPEC B.3); ``"r"`` the
        inconsistency R of W (10) between the first two cues.
    location, colour, foreground, edges, detections : settings dataclasses
        Settings of the location (``LocationConfig``), colour and foreground-masked colour
        (``ColourConfig``), edge (``EdgeConfig``) and detections (``DetectionConfig``) cues;
        the detections cue reads a detector's boxes, given to the tracker frame by frame.
    background : BackgroundConfig
        The background model of the foreground cue and of the automatic initiation.
    warm_up : int
        Frames, spread evenly over the whole video, that the background model learns from
        before tracking starts (0: it learns from the tracked frames only).  Without it the
        people in view at the first frame are part of the first background.
    initiation : InitiationConfig or None
        Start tracks on foreground blobs entering at the image border and end tracks that
        leave or lose their foreground (SPEC B.4, :mod:`belief_tracking.initiation`);
        None tracks exactly the targets of the init plan.
    init_sigma : float
        Spread in pixels of a newborn target's particles around its box centre (W-S1).
    max_targets : int
        The most targets tracked at once (default :data:`MAX_TARGETS`).  A frame costs
        particles × targets² in the cues (each particle is scored against every target) and
        particles × targets³ in the R-weighted fusion (a pair share per two targets, for each
        particle), so hundreds of targets take minutes a frame and gigabytes: an init plan
        with more targets at once is refused before any work, and automatic tracks are not
        started while this many are live.  Raise it (``--set max_targets=N``) to track more.
    diagnostics : {"strategy", "all"}
        ``"strategy"`` records what the running parts compute anyway (the active
        strategy's own quantities, the particle count and ESS, and the total similarity
        when the templates follow their targets); ``"all"`` also computes, every frame, the
        belief fusion's masses (W (33)–(35), m(∅), R) and C's feature confidences (C (13))
        and total similarity (C (15)), so that runs of every strategy report the same
        columns.

    Raises
    ------
    TrackingError
        A bad value of any field (an unknown cue raises :class:`UnknownCueError`, an
        unknown rule lists the known ones); the message names the field.

    Examples
    --------
    >>> TrackerConfig().cues
    ('colour', 'location', 'foreground')
    >>> TrackerConfig(cues=("colour", "sound"))
    Traceback (most recent call last):
    ...
    belief_tracking.errors.UnknownCueError: unknown cue 'sound'; known cues: colour, location, foreground, edges, detections
    """

    particles: int = 100
    cues: tuple[str, ...] = ("colour", "location", "foreground")
    fusion: str = "belief"
    belief: FusionConfig = field(default_factory=FusionConfig)
    motion: MotionConfig = field(default_factory=MotionConfig)
    resampling: str = "systematic"
    ess_threshold: float = 1.0
    adaptive_fusion: AdaptiveConfig = field(default_factory=AdaptiveConfig)
    template_update: bool = False
    adaptive_particles: bool = False
    kappa: str = "mass"
    location: LocationConfig = field(default_factory=LocationConfig)
    colour: ColourConfig = field(default_factory=ColourConfig)
    foreground: ColourConfig = field(default_factory=ColourConfig)
    edges: EdgeConfig = field(default_factory=EdgeConfig)
    detections: DetectionConfig = field(default_factory=DetectionConfig)
    background: BackgroundConfig = field(default_factory=BackgroundConfig)
    warm_up: int = 0
    initiation: InitiationConfig | None = None
    init_sigma: float = 5.0
    max_targets: int = MAX_TARGETS
    diagnostics: str = "strategy"

    def __post_init__(self) -> None:
        object.__setattr__(self, "particles", checks.integer("TrackerConfig.particles", self.particles, minimum=1))
        cues = (self.cues,) if isinstance(self.cues, str) else self.cues
        if not isinstance(cues, (tuple, list)):
            raise TrackingError(f"TrackerConfig.cues must be a list of cue names, got {shown(cues)}")
        cues = tuple(cues)
        if not cues:
            raise TrackingError("TrackerConfig.cues must name at least one cue")
        for name in cues:
            if not isinstance(name, str):
                raise TrackingError(f"TrackerConfig.cues must be a list of cue names, got {shown(name)} in it")
        cues = tuple(CUE_SPELLINGS.get(name, name) for name in cues)
        for name in cues:
            if name not in CUES:
                raise UnknownCueError(f"unknown cue {shown(name)}; known cues: {', '.join(CUES)}")
        if len(set(cues)) != len(cues):
            raise TrackingError(f"TrackerConfig.cues names a cue twice: {', '.join(cues)}")
        object.__setattr__(self, "cues", cues)
        if not isinstance(self.fusion, str) or self.fusion not in WEIGHTINGS:
            raise TrackingError(f"unknown fusion {shown(self.fusion)}; known fusions: {', '.join(WEIGHTINGS)}")
        if not isinstance(self.resampling, str) or self.resampling not in RESAMPLERS:
            raise TrackingError(f"unknown resampler {shown(self.resampling)}; known: {', '.join(sorted(RESAMPLERS))}")
        object.__setattr__(self, "ess_threshold", checks.fraction("TrackerConfig.ess_threshold", self.ess_threshold))
        object.__setattr__(self, "init_sigma", checks.number("TrackerConfig.init_sigma", self.init_sigma,
                                                             minimum=0.0, maximum=limits.MAX_SPREAD))
        for name, kind in (("belief", FusionConfig), ("motion", MotionConfig), ("location", LocationConfig),
                           ("colour", ColourConfig), ("foreground", ColourConfig), ("edges", EdgeConfig),
                           ("detections", DetectionConfig), ("background", BackgroundConfig),
                           ("adaptive_fusion", AdaptiveConfig)):
            checks.instance(f"TrackerConfig.{name}", getattr(self, name), kind)
        checks.choice("TrackerConfig.kappa", self.kappa, KAPPAS)
        checks.choice("TrackerConfig.diagnostics", self.diagnostics, DIAGNOSTICS)
        for name in ("adaptive_particles", "template_update"):
            object.__setattr__(self, name, checks.flag(f"TrackerConfig.{name}", getattr(self, name)))
        object.__setattr__(self, "warm_up", checks.integer("TrackerConfig.warm_up", self.warm_up, minimum=0,
                                                           maximum=limits.MAX_FRAMES))
        object.__setattr__(self, "max_targets", checks.integer("TrackerConfig.max_targets", self.max_targets,
                                                               minimum=1, maximum=MAX_TARGETS_BOUND))
        if self.initiation is not None:
            checks.instance("TrackerConfig.initiation", self.initiation, InitiationConfig)
        _check_cue_ranges(self)
        # The particles of every target live at once: their memory is bounded before any frame is read.
        limits.check_config(self)

    @classmethod
    def from_settings(cls, settings: Mapping[str, Any], where: str = "settings") -> "TrackerConfig":
        """Settings from a mapping, as a TOML table or ``--set`` options give them.

        Nested mappings fill the nested settings dataclasses (``{"location": {"sigma": 8}}``),
        lists become tuples, and ``initiation`` may be a table, ``True`` (the defaults) or
        ``False`` (off).

        Raises
        ------
        TrackingError
            An unknown key (the message lists the known ones) or a bad value; the message
            starts with ``where``.

        Examples
        --------
        >>> TrackerConfig.from_settings({"particles": 40, "colour": {"bins": 4}}).colour.bins
        4
        >>> TrackerConfig.from_settings({"particle": 40})  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        belief_tracking.errors.TrackingError: settings: unknown key 'particle'; known keys: particles, cues, ...
        """
        if not isinstance(settings, Mapping):
            raise TrackingError(f"{where} must be a table of TrackerConfig settings, got {shown(settings)}")
        # Nesting, texts, lists and integers are bounded before any value is looked at, so that no
        # check behind recurses, loops or quotes without end.
        limits.check_settings_tree(settings, where)
        _check_keys(settings, [f.name for f in fields(cls)], where, {"belief": FusionConfig})
        defaults = cls()
        keywords = {}
        for name, value in settings.items():
            if name == "initiation":
                if value is True:
                    value = {}
                value = None if value is False or value is None else \
                    _dataclass(InitiationConfig, value, f"{where}: initiation")
            elif is_dataclass(getattr(defaults, name)):
                value = _dataclass(type(getattr(defaults, name)), value, f"{where}: {name}")
            elif isinstance(value, list):
                value = tuple(value)
            keywords[name] = value
        try:
            return cls(**keywords)
        except limits.TrackingLimitError as exc:
            raise limits.TrackingLimitError(f"{where}: {exc}", exc.limit) from None
        except (BeliefError, TypeError, ValueError, OverflowError) as exc:
            raise TrackingError(f"{where}: {limits.clipped(str(exc))}") from None

    def cue_config(self, name: str):
        """The settings object of cue ``name``."""
        return {"location": self.location, "colour": self.colour, "foreground": self.foreground,
                "edges": self.edges, "detections": self.detections}[name]

    @property
    def uses_background(self) -> bool:
        """Whether a background model is needed (the foreground cue or the automatic initiation is on)."""
        return "foreground" in self.cues or self.initiation is not None

    @property
    def updates_templates(self) -> bool:
        """Whether the appearance templates follow their targets (C (16)): always for the adaptive strategy."""
        return self.fusion == "adaptive" or self.template_update

    @property
    def follows_appearance(self) -> bool:
        """Whether the total similarity of C (15) is computed every frame (templates, adaptive fusion or all diagnostics)."""
        return self.updates_templates or self.diagnostics == "all"

    def describe(self) -> str:
        """How the particles are weighed, in a few words (for titles and messages).

        >>> TrackerConfig().describe(), TrackerConfig(fusion="sum").describe()
        ('rule r_rule, weight bel', 'sum fusion')
        """
        if self.fusion == "belief":
            return f"rule {self.belief.rule}, weight {self.belief.weight}"
        return f"{self.fusion} fusion"


#: The smallest standard deviation of a cue (its square must not underflow, nor d²/σ² overflow).
MIN_SIGMA = 1e-100

#: The largest standard deviation of an appearance cue: its distances lie in [0, 1], so σ beyond makes it flat.
MAX_CUE_SIGMA = 1e3

#: The largest size in pixels of a morphological opening or of the image border of the initiation.
MAX_MASK_PIXELS = 1000


def _check_cue_ranges(config: TrackerConfig) -> None:
    """Bounds of the nested settings that their own dataclasses leave open: sample grids, spreads and counts.

    Each part checks the type and sign of its fields; the ranges beyond which a value means
    nothing (a σ that flattens its cue, a frame count no video reaches) are checked here, with
    the settings they combine with.
    """
    for name in ("colour", "foreground", "edges"):
        cue = getattr(config, name)
        across, down = cue.samples
        if across * down > MAX_SAMPLES:
            raise TrackingError(f"TrackerConfig.{name}.samples = ({across}, {down}) makes {across * down:,} "
                                f"sample points a box, more than {MAX_SAMPLES:,}")
        checks.number(f"TrackerConfig.{name}.sigma", cue.sigma, minimum=MIN_SIGMA, maximum=MAX_CUE_SIGMA)
    checks.number("TrackerConfig.edges.min_gradient", config.edges.min_gradient, maximum=limits.MAX_SPREAD)
    for name, value in (("location.sigma", config.location.sigma), ("location.gate", config.location.gate)):
        checks.number(f"TrackerConfig.{name}", value, maximum=limits.MAX_SPREAD)
    checks.number("TrackerConfig.location.sigma", config.location.sigma, minimum=MIN_SIGMA)
    checks.number("TrackerConfig.detections.sigma", config.detections.sigma, minimum=MIN_SIGMA,
                  maximum=MAX_CUE_SIGMA)
    checks.number("TrackerConfig.adaptive_fusion.epsilon", config.adaptive_fusion.epsilon, maximum=1.0)
    initiation = config.initiation
    if initiation is not None:
        for name in ("appear_frames", "exit_frames", "lost_frames", "coast_frames", "duplicate_frames", "memory"):
            value = getattr(initiation, name, None)
            if value is not None:
                checks.integer(f"TrackerConfig.initiation.{name}", value, maximum=limits.MAX_FRAMES)
        for name in ("border", "opening"):
            checks.integer(f"TrackerConfig.initiation.{name}", getattr(initiation, name), maximum=MAX_MASK_PIXELS)
        for name in ("max_aspect", "appearance_weight", "centre_gain"):
            value = getattr(initiation, name, None)
            if value is not None:
                checks.number(f"TrackerConfig.initiation.{name}", value, maximum=limits.MAX_SPREAD)


def _check_keys(mapping: Mapping[str, Any], known: list[str], where: str, nested: Mapping[str, type] = {}) -> None:
    """Refuse a key of ``mapping`` not in ``known``; a key of a ``nested`` table is named with its table."""
    unknown = [key for key in mapping if key not in known]
    if unknown:
        home = next((table for table, kind in nested.items() if unknown[0] in {f.name for f in fields(kind)}), None)
        hint = f"; {unknown[0]} is a setting of the {home} table: {home}.{unknown[0]}" if home else ""
        raise TrackingError(f"{where}: unknown key {shown(unknown[0])}{hint}; known keys: {', '.join(known)}")


def _dataclass(kind: type, value: Any, where: str):
    if not isinstance(value, Mapping):
        raise TrackingError(f"{where} must be a table of {kind.__name__} settings, got {shown(value)}")
    _check_keys(value, [f.name for f in fields(kind)], where)
    values = {k: tuple(v) if isinstance(v, list) else v for k, v in value.items()}
    try:
        return kind(**values)
    except (BeliefError, TypeError, ValueError, OverflowError) as exc:
        raise TrackingError(f"{where}: {limits.clipped(str(exc))}") from None
