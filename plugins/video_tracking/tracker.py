"""The multi-target tracker: one particle filter per target, a frame loop of named stages (SPEC B.3, Part D).

:class:`Tracker` assembles small parts and runs them, frame after frame:

1. **predict** — every target's particles move by the constant-velocity model (W-S2), and
   their windows take the size the perspective model gives their row;
2. **score** — every cue scores every particle of every target against θ_1 … θ_τ and FA
   (W-S3, :mod:`~belief_tracking.cues`);
3. **weigh** — the weighting strategy turns the scores into log-weights
   (:mod:`~belief_tracking.weighting`: the belief rules, C's adaptive fusion, sum,
   product);
4. **estimate** — each target's weights are normalised within its set and its state is
   their weighted mean (W-S4, W (6)); then, when the appearance is followed, the total
   similarity, the occlusion flag and the template update of C (15)–(16)
   (:mod:`~belief_tracking.appearance`);
5. **resample** — each set is resampled (W-S5), to an adaptive size on request (SPEC B.3);
6. **manage tracks** — planned and automatic births and deaths
   (:mod:`~belief_tracking.tracks`).

The tracker is an iterator over frames: :meth:`Tracker.track` (or iterating a tracker made
with ``frames=``) yields one :class:`FrameResult` per frame, with the estimates and one
diagnostics record; writing files, progress and scoring belong to
:mod:`~belief_tracking.runner`.  Nothing costs 2^τ: the cues are linear in τ·N and
the fusion's closed forms are polynomial in τ.  Every random draw comes from the one
``numpy.random.Generator`` given to the tracker, so a run is reproducible from its seed.

Frame numbers are 1-based (as in MOTChallenge files); boxes ``(x, y, w, h)`` inside the
tracker are 0-based pixels with the top-left corner at ``(x, y)``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from .appearance import AppearanceFollower
from .association import UNASSIGNED, assign, contested_pairs
from .background import BackgroundModel
from .blobs import box_mask
from .candidates import BlobCandidates
from .config import TrackerConfig
from .cues import CUES, AppearanceCue, Observation, score_cues, template_similarity
from .detections import Detections, check_rows
from .errors import InitError, TrackingError
from .initiation import InitPlan
from .particles import CX, CY, LOG_SCALE, VX, VY, ConstantVelocity, ParticleSet, adaptive_count
from .tracks import Estimate, TrackManager
from .weighting import BELIEF_COLUMNS, Evidence, Weighing, make_weighting

__all__ = ["Tracker", "FrameResult", "FrameDiagnostics", "Estimate", "diagnostic_columns"]

#: Diagnostics of every particle filter, per target and frame: the particle count and the
#: effective sample size of the weights before resampling.
FILTER_COLUMNS = ("particles", "ess")

#: Diagnostics of the appearance follow-up: the total similarity ρ_t at the estimate (C (15))
#: and the occlusion flag ρ_t < T (1 or 0).
APPEARANCE_COLUMNS = ("similarity", "occluded")


def diagnostic_columns(config: TrackerConfig) -> tuple[str, ...]:
    """The diagnostics a tracker with ``config`` records per target and frame, in order.

    The belief fusion's means of W (33)–(35), m(∅) and R when it runs (the belief strategy,
    ``diagnostics="all"`` or the adaptive particle count), the particle count and ESS, the
    total similarity and occlusion flag when the appearance is followed, and one feature
    confidence per cue (C (13)) with the adaptive strategy or ``diagnostics="all"``.

    Examples
    --------
    >>> diagnostic_columns(TrackerConfig())
    ('mean_m_target', 'mean_m_intersection', 'mean_bel', 'mean_m_empty', 'mean_r', 'particles', 'ess')
    >>> diagnostic_columns(TrackerConfig(fusion="sum"))
    ('particles', 'ess')
    >>> diagnostic_columns(TrackerConfig(cues=("colour", "edges"), diagnostics="all"))[-4:]
    ('similarity', 'occluded', 'confidence_colour', 'confidence_edges')
    """
    columns: tuple[str, ...] = ()
    if _runs_belief(config):
        columns += BELIEF_COLUMNS
    columns += FILTER_COLUMNS
    if config.follows_appearance:
        columns += APPEARANCE_COLUMNS
    if config.fusion == "adaptive" or config.diagnostics == "all":
        columns += tuple(f"confidence_{name}" for name in config.cues)
    return columns


def _runs_belief(config: TrackerConfig) -> bool:
    """Whether the belief fusion runs every frame (as the strategy, for the diagnostics or for κ)."""
    return config.fusion == "belief" or config.diagnostics == "all" or config.adaptive_particles


@dataclass(frozen=True, eq=False)
class FrameDiagnostics:
    """One frame's diagnostics: a value per target and column.

    Attributes
    ----------
    columns : tuple of str
        :func:`diagnostic_columns` of the tracker.
    ids : tuple of int
        The targets that were filtered this frame and are still tracked (a target born
        this frame has no diagnostics yet).
    values : ndarray, shape (len(ids), len(columns))
    """

    columns: tuple[str, ...]
    ids: tuple[int, ...]
    values: np.ndarray

    def of(self, target_id: int) -> dict[str, float]:
        """The diagnostics of one target, by column; KeyError if it has none this frame."""
        row = self.ids.index(target_id) if target_id in self.ids else None
        if row is None:
            raise KeyError(target_id)
        return {name: float(v) for name, v in zip(self.columns, self.values[row])}

    def rows(self, frame: int) -> list[dict[str, float]]:
        """One dict per target: ``frame``, ``id`` and every column (the lines of ``diagnostics.csv``)."""
        return [{"frame": frame, "id": target_id, **{c: float(v) for c, v in zip(self.columns, values)}}
                for target_id, values in zip(self.ids, self.values)]


@dataclass(frozen=True, eq=False)
class FrameResult:
    """What the tracker made of one frame.

    Attributes
    ----------
    frame : int
        1-based frame number.
    estimates : tuple of Estimate
        One per target alive after the frame, in target order (newborn targets last).
    diagnostics : FrameDiagnostics
    seconds : float
        Time the tracker spent on the frame (decoding and output excluded).
    """

    frame: int
    estimates: tuple[Estimate, ...]
    diagnostics: FrameDiagnostics
    seconds: float = 0.0

    def mot_rows(self) -> list[list[float]]:
        """The estimates as MOTChallenge rows (:meth:`Estimate.mot_row`)."""
        return [e.mot_row() for e in self.estimates]


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
        The only source of randomness: initialisation, motion noise and resampling, and,
        through a child generator spawned from it, the resampling inside C's feature
        confidences (C (11)).
    frames : iterable of ndarray, optional
        The frames to iterate over with ``for result in tracker``.

    Attributes
    ----------
    config : TrackerConfig
    cues : list
        The cues, in fusion order.
    weighting : Weighting
        The active weighting strategy.
    tracks : TrackManager
        The live targets, their births and deaths.
    diagnostic_columns : tuple of str
        The columns of every :class:`FrameDiagnostics` (:func:`diagnostic_columns`).

    Examples
    --------
    >>> from belief_tracking import scenes
    >>> from belief_tracking.initiation import init_from_gt
    >>> scene = scenes.render(scenes.crossing(0))
    >>> tracker = Tracker(TrackerConfig(particles=20), init_from_gt(scene.ground_truth), np.random.default_rng(0))
    >>> results = list(tracker.track(scene.frames[:3]))
    >>> [e.id for e in results[-1].estimates], all(np.isfinite(e.box).all() for e in results[-1].estimates)
    ([1, 2], True)
    >>> sorted(results[-1].diagnostics.of(1))[:3]
    ['ess', 'mean_bel', 'mean_m_empty']
    """

    def __init__(self, config: TrackerConfig, init: InitPlan | None, rng: np.random.Generator, *,
                 frames: Iterable[np.ndarray] | None = None) -> None:
        if not isinstance(config, TrackerConfig):
            raise TrackingError(f"Tracker needs a TrackerConfig, got {type(config).__name__}")
        if init is not None and not isinstance(init, InitPlan):
            raise TrackingError(f"Tracker needs an InitPlan or None, got {type(init).__name__}")
        if init is None and config.initiation is None:
            raise InitError("nothing to track: give an InitPlan or turn on the automatic initiation "
                            "(TrackerConfig.initiation)")
        if not isinstance(rng, np.random.Generator):
            raise TrackingError(f"Tracker needs a numpy.random.Generator, got {type(rng).__name__}")
        if init is not None:
            peak, frame = init.peak()
            if peak > config.max_targets:
                raise InitError(f"{init.source or 'the init plan'}: {peak} targets at once (at frame {frame}), "
                                f"more than TrackerConfig.max_targets = {config.max_targets}; a frame costs "
                                f"particles x targets^3 in the fusion, so this many would take hours: raise the "
                                f"limit (--set max_targets={peak}) to track them anyway")
        self.config = config
        self.init = init
        self.rng = rng
        self.frames = frames
        # A child stream for the confidences' resampling (C (11)) leaves the filter's own draws
        # as they are whether or not the confidences are computed.
        feature_rng = rng.spawn(1)[0]
        self.cues = [CUES[name](config.cue_config(name)) for name in config.cues]
        # Found once: isinstance against a runtime-checkable protocol inspects the class each call.
        self._appearance_cues = [cue for cue in self.cues if isinstance(cue, AppearanceCue)]
        self.background = BackgroundModel(config.background) if config.uses_background else None
        self.weighting = make_weighting(config.fusion, config, feature_rng)
        self._belief = make_weighting("belief", config, feature_rng) \
            if _runs_belief(config) and config.fusion != "belief" else None
        self._confidences = make_weighting("adaptive", config, feature_rng) \
            if config.diagnostics == "all" and config.fusion != "adaptive" else None
        self.appearance = AppearanceFollower(config.adaptive_fusion, self.cues, config.updates_templates) \
            if config.follows_appearance else None
        self.tracks = TrackManager(config, init, self.cues, rng)
        self.diagnostic_columns = diagnostic_columns(config)
        self._reads_candidates = "detections" in config.cues
        self._blobs: BlobCandidates | None = None
        self._gate = config.initiation.match_iou if config.initiation is not None else 0.3
        self._motion: ConstantVelocity | None = None
        self._image_shape: tuple[int, int] | None = None

    @property
    def targets(self):
        """The live targets, in birth order (the order of the cues' templates)."""
        return self.tracks.targets

    def warm_up(self, frames: Iterable[np.ndarray]) -> int:
        """Let the background model learn from ``frames`` before tracking; returns how many (0 without a model)."""
        if self.background is None:
            return 0
        return self.background.warm_up(frames)

    # -- iteration ----------------------------------------------------------------------------
    def __iter__(self) -> Iterator[FrameResult]:
        if self.frames is None:
            raise TrackingError("this tracker was made without frames=; use tracker.track(frames)")
        return self.track(self.frames)

    def track(self, frames: Iterable[np.ndarray], first_frame: int = 1,
              detections: Detections | None = None) -> Iterator[FrameResult]:
        """Track ``frames`` one by one, numbered from ``first_frame``; yields a :class:`FrameResult` each.

        Frames are read as they are needed, so a video never has to fit in memory.
        ``detections`` (optional) gives each frame's detector boxes (:meth:`Detections.at`).
        """
        for offset, image in enumerate(frames):
            frame = first_frame + offset
            yield self.step(frame, image, None if detections is None else detections.at(frame))

    # -- one frame ----------------------------------------------------------------------------
    def step(self, frame: int, image: np.ndarray, detections: np.ndarray | None = None) -> FrameResult:
        """Process 1-based ``frame``: the six stages of the module's description.

        Parameters
        ----------
        frame : int
            1-based frame number, increasing by one per call.
        image : ndarray of uint8, shape (H, W, 3)
            The BGR frame.
        detections : ndarray, shape (n, 5), optional
            The frame's detector boxes ``x, y, w, h, score`` in 0-based pixels
            (:meth:`Detections.at <belief_tracking.detections.Detections.at>`); None
            when the run has no detector.

        Returns
        -------
        FrameResult
        """
        started = time.perf_counter()
        image = self._begin(frame, image)
        detector = detections is not None
        if detector:
            detections = check_rows(detections, f"frame {frame}")
        # With a detector the candidates come from it: the mask is needed only by a cue.
        needs_mask = self.background is not None and ("foreground" in self.config.cues or not detector)
        foreground = None
        if needs_mask:
            # Automatic tracks keep their people in the foreground: a person who stands still
            # must not be learnt into the background under their own track.
            protect = box_mask(image.shape, [t.box() for t in self.targets]) \
                if self.tracks.lifecycle is not None and self.targets else None
            foreground = self.background.apply(image, protect)
        births_allowed = not getattr(self.background, "lighting_change", False)
        self.tracks.end_planned(frame)
        candidates = self._candidates(detections, foreground)
        assigned = likeness = None
        estimates: list[Estimate] = []
        diagnostics = FrameDiagnostics(self.diagnostic_columns, (), np.zeros((0, len(self.diagnostic_columns))))
        if self.targets:
            predicted = self.tracks.predicted_boxes(self.config.motion.dt) if candidates is not None else None
            previous = np.concatenate([t.particles.states[:, [CX, CY]] for t in self.targets])
            moved = self._predict()
            obs = Observation(image, foreground, centres=self._location_centres(),
                              sizes=np.array([t.size for t in self.targets]), previous_particles=previous,
                              detections=candidates if self._reads_candidates else None)
            if candidates is not None:
                assigned = self._assign(obs, predicted, candidates, detector)
                if self._reads_candidates:
                    obs = obs.with_assignment(assigned)
            evidence = self._score(obs, moved)
            weighing = self.weighting.weigh(evidence)
            weighted = self._estimate(moved, weighing, evidence)
            records = self._diagnose(obs, evidence, weighing, weighted)
            self._resample(weighted, records)
            if assigned is not None:
                self.tracks.follow_candidates(frame, assigned, candidates, detector)
            if self.tracks.lifecycle is not None and self.config.initiation.appearance_support is not None:
                likeness = self._likeness(obs, assigned)
            estimates = [Estimate(frame, t.id, t.estimate.copy(), t.box()) for t in self.targets]
            diagnostics = FrameDiagnostics(self.diagnostic_columns, tuple(t.id for t in self.targets),
                                           np.column_stack([records[c] for c in self.diagnostic_columns]))
        estimates = self.tracks.births_and_deaths(frame, image, foreground, estimates, candidates, assigned,
                                                  detector=detector, births_allowed=births_allowed,
                                                  likeness=likeness)
        alive = {e.id for e in estimates}
        if any(i not in alive for i in diagnostics.ids):
            keep = [k for k, i in enumerate(diagnostics.ids) if i in alive]
            diagnostics = FrameDiagnostics(diagnostics.columns, tuple(diagnostics.ids[k] for k in keep),
                                           diagnostics.values[keep])
        return FrameResult(frame, tuple(estimates), diagnostics, time.perf_counter() - started)

    def _assign(self, obs: Observation, predicted: np.ndarray, candidates: np.ndarray, detector: bool) -> np.ndarray:
        """The candidate each target takes (:func:`~belief_tracking.association.assign`), −1 for none.

        Detections are weighed by appearance too (``InitiationConfig.appearance_weight``):
        ρ of the window of each target's size at each detection's centre with the target's
        templates, formed only for :func:`~belief_tracking.association.contested_pairs`.
        Foreground blobs go by overlap alone.
        """
        initiation = self.config.initiation
        weight = initiation.appearance_weight if initiation is not None else 0.0
        if not (detector and weight > 0 and self._appearance_cues and len(candidates)):
            return assign(predicted, candidates, self._gate)
        rows, cols = contested_pairs(predicted, candidates, self._gate)
        if not rows.size:
            return assign(predicted, candidates, self._gate)
        states = np.zeros((rows.size, len(self.targets[0].estimate)))
        states[:, CX] = candidates[cols, 0] + candidates[cols, 2] / 2.0
        states[:, CY] = candidates[cols, 1] + candidates[cols, 3] / 2.0
        likeness = np.zeros((len(predicted), len(candidates)))
        likeness[rows, cols] = np.clip(template_similarity(self._appearance_cues, obs, states, rows), 0.0, 1.0)
        return assign(predicted, candidates, self._gate, likeness, weight)

    def _likeness(self, obs: Observation, assigned: np.ndarray | None) -> np.ndarray | None:
        """How much each target's window at its estimate still looks like its templates, shape (τ,).

        The smallest Bhattacharyya coefficient ρ (L (12)) over the appearance cues; None
        without an appearance cue.  Only a target that took no candidate needs it (a
        candidate supports the others): the others get NaN.
        """
        if not self._appearance_cues:
            return None
        needed = np.arange(len(self.targets)) if assigned is None else np.flatnonzero(assigned == UNASSIGNED)
        likeness = np.full(len(self.targets), np.nan)
        if needed.size:
            states = np.array([self.targets[k].estimate for k in needed])
            likeness[needed] = template_similarity(self._appearance_cues, obs, states, needed)
        return likeness

    def _candidates(self, detections: np.ndarray | None, foreground: np.ndarray | None) -> np.ndarray | None:
        """The frame's candidate boxes ``x, y, w, h, score``: the detections, else the foreground's person blobs."""
        if detections is not None:
            return detections
        if self.tracks.lifecycle is None or foreground is None:
            return None
        if self._blobs is None:
            self._blobs = BlobCandidates(self.config.initiation, foreground.shape)
        return self._blobs(foreground)

    def _begin(self, frame: int, image: np.ndarray) -> np.ndarray:
        """Check a frame at the boundary; the first one fixes the image size of the run."""
        image = np.asarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8 or 0 in image.shape:
            raise TrackingError(f"frame {frame}: frames must be (H, W, 3) uint8 arrays, got shape {image.shape} "
                                f"dtype {image.dtype}")
        if self._image_shape is None:
            self._image_shape = image.shape[:2]
            height, width = self._image_shape
            self._motion = ConstantVelocity(self.config.motion, bounds=(width, height))
            self.tracks.start(self._image_shape)
        elif image.shape[:2] != self._image_shape:
            raise TrackingError(f"frame {frame} has size {image.shape[:2]}, the first had {self._image_shape}")
        return image

    def _predict(self) -> list[ParticleSet]:
        """W-S2: every set propagated, each window sized by the perspective model (or its birth size)."""
        perspective = self.tracks.perspective
        moved = []
        for target in self.targets:
            particles = target.particles.propagate(self._motion, self.rng)
            # Without a fitted model every target keeps its birth size: a random walk on the
            # scale would drift, since the foreground-masked colour rewards shrinking windows.
            scale = 0.0 if perspective is None else \
                perspective.log_scale(particles.states[:, CY], target.birth_cy)
            moved.append(particles.with_column(LOG_SCALE, scale))
        return moved

    def _location_centres(self) -> np.ndarray:
        """The t − 1 centres, moved on by their velocities if the location cue asks so, shape (τ, 2)."""
        centres = np.array([t.estimate[[CX, CY]] for t in self.targets])
        if not self.config.location.literal:
            centres = centres + self.config.motion.dt * np.array([t.estimate[[VX, VY]] for t in self.targets])
        return centres

    def _score(self, obs: Observation, moved: list[ParticleSet]) -> Evidence:
        """W-S3: every cue scores every particle against θ_1 … θ_τ, FA."""
        counts = np.array([len(p) for p in moved])
        states = np.concatenate([p.states for p in moved])                            # (P, 5)
        owner = np.repeat(np.arange(len(moved)), counts)                               # (P,)
        scores = score_cues(self.cues, obs, states, owner)
        similarity = self.appearance.similarity(self.tracks.ids) if self.appearance is not None else None
        return Evidence(scores, owner, states[:, [CX, CY]], similarity, self.config.cues)

    def _estimate(self, moved: list[ParticleSet], weighing: Weighing, evidence: Evidence) -> list[ParticleSet]:
        """W-S4: weights normalised within each set, the estimate their weighted mean (W (6))."""
        starts = np.concatenate([[0], np.cumsum(evidence.counts)])
        weighted = []
        for j, (target, particles) in enumerate(zip(self.targets, moved)):
            reweighted = particles.reweight(weighing.log_weights[starts[j]:starts[j + 1]])
            target.estimate = reweighted.estimate()
            weighted.append(reweighted)
        return weighted

    def _diagnose(self, obs: Observation, evidence: Evidence, weighing: Weighing,
                  weighted: list[ParticleSet]) -> dict[str, np.ndarray]:
        """Every diagnostics column of the frame, per target; runs the appearance follow-up."""
        records = dict(weighing.diagnostics)
        if self._belief is not None:
            records.update(self._belief.weigh(evidence).diagnostics)
        if self._confidences is not None:
            records.update(self._confidences.weigh(evidence).diagnostics)
        records["particles"] = np.array([float(len(p)) for p in weighted])
        records["ess"] = np.array([p.ess() for p in weighted])
        if self.appearance is not None:
            states = np.array([t.estimate for t in self.targets])
            similarity, occluded = self.appearance.follow(obs, states, self.tracks.ids, weighing.confidences)
            records["similarity"] = similarity
            records["occluded"] = occluded.astype(np.float64)
        return records

    def _resample(self, weighted: list[ParticleSet], records: dict[str, np.ndarray]) -> None:
        """W-S5: every set resampled, to N_min + ⌈(N − N_min)·κ⌉ particles with the adaptive count."""
        config = self.config
        kappa = None
        if config.adaptive_particles:
            kappa = records["mean_r"] if config.kappa == "r" else \
                records["mean_m_intersection"] + records["mean_m_empty"]
        for j, (target, particles) in enumerate(zip(self.targets, weighted)):
            n_next = None
            if kappa is not None:
                n_next = adaptive_count(float(np.clip(kappa[j], 0.0, 1.0)), math.ceil(config.particles / 2),
                                        config.particles)
            target.particles = particles.resample(self.rng, method=config.resampling,
                                                  threshold=config.ess_threshold, n=n_next)
