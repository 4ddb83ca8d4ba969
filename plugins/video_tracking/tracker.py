"""The multi-target tracker: one particle filter per track, a frame as a list of named stages (SPEC B.3, Part D).

Every target has one home, a :class:`~belief_tracking.store.Track` of the tracker's
:class:`~belief_tracking.store.TrackStore`, and :meth:`Tracker.step` runs a frame through
small parts, each a function or a one-method object that a test can drive alone:

1. **observe** — the frame gate, the background model's foreground and the frame's candidate
   boxes (:class:`~belief_tracking.observe.FrameObserver`);
2. **predict** — every track's particles move by the constant-velocity model (W-S2), their
   windows sized by the perspective model (:class:`~belief_tracking.filtering.Prediction`);
3. **associate** — every track takes at most one candidate
   (:class:`~belief_tracking.association.Association`);
4. **score** — every cue scores every particle against θ_1 … θ_τ and FA (W-S3,
   :mod:`~belief_tracking.cues`);
5. **weigh** — the weighting strategy turns the scores into log-weights
   (:mod:`~belief_tracking.weighting`: the belief rules, C's adaptive fusion, sum, product);
6. **estimate** — each track's weights are normalised within its set and its state is
   their weighted mean (W-S4, W (6), :func:`~belief_tracking.filtering.estimate`);
7. **update appearance** — total similarity, occlusion flag and template update of C
   (15)–(16) (:class:`~belief_tracking.appearance.AppearanceFollower`);
8. **adapt N and resample** — each set is resampled (W-S5), to the adaptive size of its
   conflict on request (SPEC B.3, :class:`~belief_tracking.filtering.ParticleCount`);
9. **manage tracks** — the tracks that took a candidate move towards it; planned and
   automatic births, losses, deaths and re-identification
   (:class:`~belief_tracking.tracks.TrackManager`).

The diagnostics are read off the stages' results by a collector that never steers
(:mod:`~belief_tracking.diagnostics`).  The tracker is an iterator over frames:
:meth:`Tracker.track` (or iterating a tracker made with ``frames=``) yields one
:class:`FrameResult` per frame; writing files, progress and scoring belong to
:mod:`~belief_tracking.runner`.  Nothing costs 2^τ: the cues are linear in τ·N and the
fusion's closed forms are polynomial in τ.  Every random draw comes from the one
``numpy.random.Generator`` given to the tracker, so a run is reproducible from its seed.

Frame numbers are 1-based (as in MOTChallenge files); boxes ``(x, y, w, h)`` inside the
tracker are 0-based pixels with the top-left corner at ``(x, y)``.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from .appearance import Appearance, AppearanceFollower, stacked_templates
from .association import UNASSIGNED, Association
from .background import BackgroundModel
from .config import TrackerConfig
from .cues import CUES, AppearanceCue, Observation, score_cues, template_similarity
from .detections import Detections
from .diagnostics import DiagnosticsCollector, FrameDiagnostics, diagnostic_columns, runs_belief
from .errors import InitError, TrackingError
from .evidence import Evidence
from .filtering import ParticleCount, Prediction, estimate, location_centres, resample
from .initiation import InitPlan
from .observe import FrameObserver, FrameView
from .particles import CX, CY, ParticleSet
from .store import Track, TrackStore
from .tracks import Estimate, TrackManager
from .weighting import BeliefWeighting, make_weighting

__all__ = ["Tracker", "FrameResult", "FrameDiagnostics", "Estimate", "diagnostic_columns"]


@dataclass(frozen=True, eq=False)
class FrameResult:
    """What the tracker made of one frame.

    Attributes
    ----------
    frame : int
        1-based frame number.
    estimates : tuple of Estimate
        One per target alive after the frame, oldest first (newborn targets last).
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
    store : TrackStore
        The live tracks and the memory of the lost ones.
    weighting : Weighting
        The active weighting strategy.
    manager : TrackManager
        Births, deaths, losses and re-identification of the store's tracks.
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
    >>> tracker.store.ids, len(tracker.store[1].particles)
    ([1, 2], 20)
    """

    def __init__(self, config: TrackerConfig, init: InitPlan | None, rng: np.random.Generator, *,
                 frames: Iterable[np.ndarray] | None = None) -> None:
        _check_arguments(config, init, rng)
        self.config, self.init, self.rng, self.frames = config, init, rng, frames
        # A child stream for the confidences' resampling (C (11)) leaves the filter's own draws
        # as they are whether or not the confidences are computed.
        feature_rng = rng.spawn(1)[0]
        self.cues = [CUES[name](config.cue_config(name)) for name in config.cues]
        self.appearance_cues = [cue for cue in self.cues if isinstance(cue, AppearanceCue)]
        self.background = BackgroundModel(config.background) if config.uses_background else None
        self.store = TrackStore()
        self.manager = TrackManager(config, init, self.appearance_cues, rng, self.store)
        self.observe = FrameObserver(config, self.background)
        self.associate = Association(config.initiation, self.appearance_cues)
        self.weighting = make_weighting(config.fusion, config.belief, config.adaptive_fusion, config.cues, feature_rng)
        beliefs = self.weighting if isinstance(self.weighting, BeliefWeighting) else \
            BeliefWeighting(config.belief) if runs_belief(config) else None
        self.particle_count = ParticleCount(config.particles, config.kappa, beliefs) \
            if config.adaptive_particles else None
        self.appearance = AppearanceFollower(config.adaptive_fusion, self.cues, config.updates_templates) \
            if config.follows_appearance else None
        self.diagnostics = DiagnosticsCollector(config, beliefs, feature_rng)
        self.diagnostic_columns = self.diagnostics.columns
        self.predict: Prediction | None = None

    @property
    def targets(self) -> list[Track]:
        """The live tracks, oldest first."""
        return self.store.tracks

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
        """Process 1-based ``frame``: the stages of the module's description, in order.

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
        view = self._observe(frame, image, detections)                         # 1. the frame
        tracks = self.store.tracks
        if not tracks:                                                         # nothing to filter: births only
            return self._result(view, self.manager.births_and_deaths(view, []), self.diagnostics.empty(), started)
        moved = self.predict(tracks, self.manager.perspective, self.rng)        # 2. W-S2
        obs = self._observation(view, tracks)
        assigned = self._associate(obs, view, tracks)                          # 3. candidates to tracks
        evidence = self._score(obs, moved, tracks, assigned)                   # 4. W-S3
        weighing = self.weighting.weigh(evidence)                              # 5. W (7), W (32); C (14)
        weighted = estimate(tracks, moved, weighing, evidence.counts)          # 6. W-S4, W (6)
        appearance = self._follow_appearance(obs, tracks, weighing)            # 7. C (15)–(16)
        counts = self.particle_count(evidence) if self.particle_count is not None else None     # 8. SPEC B.3
        resample(tracks, weighted, self.rng, self.config.resampling, self.config.ess_threshold, counts)  # W-S5
        estimates = self._manage(view, obs, tracks, assigned)                  # 9. births, deaths, re-id
        diagnostics = self.diagnostics.collect([t.id for t in tracks], evidence, weighing, weighted, appearance)
        return self._result(view, estimates, diagnostics, started)

    def _result(self, view: FrameView, estimates: list[Estimate], diagnostics: FrameDiagnostics,
                started: float) -> FrameResult:
        """The frame's result; the diagnostics of the tracks that are gone are left out."""
        diagnostics = self.diagnostics.of_alive(diagnostics, {e.id for e in estimates})
        return FrameResult(view.number, tuple(estimates), diagnostics, time.perf_counter() - started)

    def _observe(self, frame: int, image: np.ndarray, detections: np.ndarray | None) -> FrameView:
        """Stage 1: the frame's view; the first frame fixes the image size, and the planned ends are made."""
        view = self.observe(frame, image, detections, [t.box() for t in self.store])
        if self.predict is None:
            self.predict = Prediction(self.config.motion, self.observe.image_shape)
            self.manager.start(self.observe.image_shape)
        self.manager.end_planned(frame)
        return view

    def _observation(self, view: FrameView, tracks: Sequence[Track]) -> Observation:
        """What the cues see of the frame and of the tracks (their t − 1 state and templates)."""
        previous = np.concatenate([t.particles.states[:, [CX, CY]] for t in tracks])
        return Observation(view.image, view.foreground,
                           centres=location_centres(tracks, self.config.motion.dt, self.config.location.literal),
                           sizes=np.array([t.size for t in tracks]), previous_particles=previous,
                           detections=view.candidates if "detections" in self.config.cues else None,
                           templates=stacked_templates(tracks, self.appearance_cues))

    def _associate(self, obs: Observation, view: FrameView, tracks: Sequence[Track]) -> np.ndarray | None:
        """Stage 3: the candidate each track takes (−1: none); None without candidates."""
        predicted = np.array([t.predicted_box(self.config.motion.dt) for t in tracks])
        return self.associate(obs, predicted, view.candidates, view.detector)

    def _score(self, obs: Observation, moved: Sequence[ParticleSet], tracks: Sequence[Track],
               assigned: np.ndarray | None) -> Evidence:
        """Stage 4 (W-S3): every cue scores every particle against θ_1 … θ_τ, FA."""
        if assigned is not None and obs.detections is not None:
            obs = obs.with_assignment(assigned)
        counts = np.array([len(p) for p in moved])
        states = np.concatenate([p.states for p in moved])                            # (P, 5)
        owner = np.repeat(np.arange(len(moved)), counts)                               # (P,)
        similarity = np.array([t.similarity for t in tracks], dtype=np.float64) \
            if self.appearance is not None else None
        return Evidence(score_cues(self.cues, obs, states, owner), owner, states[:, [CX, CY]], similarity,
                        self.config.cues)

    def _follow_appearance(self, obs: Observation, tracks: Sequence[Track], weighing) -> Appearance | None:
        """Stage 7: ρ_t, occlusion and the template update of every track (C (15)–(16))."""
        if self.appearance is None:
            return None
        return self.appearance.follow(obs, tracks, weighing.confidences)

    def _manage(self, view: FrameView, obs: Observation, tracks: Sequence[Track],
                assigned: np.ndarray | None) -> list[Estimate]:
        """Stage 9: the tracks that took a candidate follow it; then births, losses, deaths and re-identification."""
        if assigned is not None:
            self.manager.follow_candidates(view.number, tracks, assigned, view.candidates, view.detector)
        likeness = self._likeness(obs, tracks, assigned)
        return self.manager.births_and_deaths(view, [Estimate.of(t, view.number) for t in tracks], assigned, likeness)

    def _likeness(self, obs: Observation, tracks: Sequence[Track], assigned: np.ndarray | None) -> np.ndarray | None:
        """How much each track's window at its estimate still looks like its templates, shape (τ,).

        The smallest Bhattacharyya coefficient ρ (L (12)) over the appearance cues, with the
        templates as the appearance stage left them; None without an appearance cue or an
        appearance support to read it.  Only a track that took no candidate needs it (a
        candidate supports the others): the others get NaN.
        """
        initiation = self.config.initiation
        if not self.appearance_cues or initiation is None or initiation.appearance_support is None:
            return None
        needed = np.arange(len(tracks)) if assigned is None else np.flatnonzero(assigned == UNASSIGNED)
        likeness = np.full(len(tracks), np.nan)
        if needed.size:
            states = np.array([tracks[k].estimate for k in needed])
            updated = self.appearance is not None and self.appearance.update
            current = obs.with_templates(stacked_templates(tracks, self.appearance_cues)) if updated else obs
            likeness[needed] = template_similarity(self.appearance_cues, current, states, needed)
        return likeness


def _check_arguments(config: TrackerConfig, init: InitPlan | None, rng: np.random.Generator) -> None:
    """The tracker's arguments at its gate: types, something to track, no more targets than allowed."""
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
