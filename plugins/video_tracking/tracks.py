"""Managing the tracks of the store: births, corrections, losses, re-identification and deaths.

:class:`TrackManager` decides, each frame, what happens to the tracks of the
:class:`~belief_tracking.store.TrackStore` and carries it out as operations on the store.
Births come from the :class:`~belief_tracking.initiation.InitPlan` (by hand or from a
ground truth) and, without a plan or for the people who enter later, from the frame's
candidate boxes, by the rules of :class:`~belief_tracking.lifecycle.Lifecycle`: a track
that took a candidate moves its box towards it (:meth:`TrackManager.follow_candidates`);
one that nothing supports is hidden, then lost, and the store remembers what it looked
like, so that a newborn track that looks like it, near where it should be, takes back its
id.  The boxes of planned births fit the perspective model of the window sizes
(:class:`~belief_tracking.perspective.PerspectiveScale`).

Every random draw (the particles of a newborn track, W-S1) comes from the generator given
to the manager.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .association import UNASSIGNED
from .boxes import check_boxes
from .config import TrackerConfig
from .cues.histograms import bhattacharyya
from .errors import InitError
from .initiation import InitPlan, TargetInit
from .lifecycle import Lifecycle
from .observe import FrameView
from .particles import CX, CY, ParticleSet, initialise
from .perspective import PerspectiveScale
from .store import Track, TrackStore

__all__ = ["Estimate", "TrackManager"]


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
    """

    frame: int
    id: int
    state: np.ndarray
    box: tuple[float, float, float, float]

    def mot_row(self) -> list[float]:
        """``frame, id, x, y, w, h, -1, -1, -1, -1`` with a 1-based top-left corner (MOTChallenge)."""
        x, y, w, h = self.box
        return [self.frame, self.id, x + 1.0, y + 1.0, w, h, -1, -1, -1, -1]

    @classmethod
    def of(cls, track: Track, frame: int) -> Estimate:
        """The estimate of ``track`` at ``frame``: its state and window now."""
        return cls(frame, track.id, track.estimate.copy(), track.box())


class TrackManager:
    """Births, deaths, losses and re-identification of the tracks of a store.

    Parameters
    ----------
    config : TrackerConfig
    plan : InitPlan or None
        Planned births and deaths; None leaves them all to the automatic initiation.
    appearance_cues : sequence of AppearanceCue
        The cues whose templates a newborn track gets.
    rng : numpy.random.Generator
        Draws the particles of newborn tracks (W-S1).
    store : TrackStore
        Where the tracks live.

    Attributes
    ----------
    perspective : PerspectiveScale or None
        The window-size model fitted to the planned birth boxes (None until two boxes on
        different rows allow a fit).
    lifecycle : Lifecycle or None
        The automatic tracks' births, losses and deaths, made at the first frame (it needs
        the image size).

    Examples
    --------
    A planned target is born at its box and ends after its last frame:

    >>> from belief_tracking.initiation import init_from_boxes
    >>> store = TrackStore()
    >>> plan = init_from_boxes([(10, 20, 8, 16)], ids=[4])
    >>> manager = TrackManager(TrackerConfig(particles=5), plan, [], np.random.default_rng(0), store)
    >>> manager.start((60, 80))
    >>> image = np.zeros((60, 80, 3), np.uint8)
    >>> view = FrameView(1, image, None, None, detector=False, births_allowed=True)
    >>> [e.id for e in manager.births_and_deaths(view, [])], store.ids
    ([4], [4])
    """

    def __init__(self, config: TrackerConfig, plan: InitPlan | None, appearance_cues: Sequence,
                 rng: np.random.Generator, store: TrackStore) -> None:
        self.config = config
        self.plan = plan
        self.appearance_cues = list(appearance_cues)
        self.rng = rng
        self.store = store
        self.perspective: PerspectiveScale | None = None
        self.lifecycle: Lifecycle | None = None
        self._birth_boxes: list[tuple[float, float, float, float]] = []
        self._next_id = max((t.id for t in plan.targets), default=0) + 1 if plan is not None else 1
        self._planned = {target.id: target for target in plan.targets} if plan is not None else {}

    def start(self, image_shape: tuple[int, int]) -> None:
        """Get ready for frames of ``image_shape`` (H, W): the automatic initiation needs it."""
        if self.config.initiation is not None:
            self.lifecycle = Lifecycle(self.config.initiation, image_shape)

    # -- births and deaths --------------------------------------------------------------------
    def add(self, birth: TargetInit, frame: int, image: np.ndarray, foreground: np.ndarray | None = None,
            planned: bool = True) -> Estimate:
        """Start tracking ``birth`` at its box in ``image`` (W-S1); returns its first estimate.

        A target that is not ``planned`` (found by the initiation) does not enter the fit of
        the perspective model: blob boxes are too rough (merged groups, shadows, missing
        legs) to fit the ground plane on.
        """
        if birth.id in self.store:
            raise InitError(f"target {birth.id} is already being tracked")
        source = self.plan.source if self.plan is not None and self.plan.source else "init"
        check_boxes([birth.box], f"{source}: the box of target {birth.id}", image_shape=image.shape[:2],
                    error=InitError)
        x, y, w, h = birth.box
        templates = {cue.name: cue.build_templates(image, np.reshape(np.asarray(birth.box, dtype=np.float64),
                                                                     (1, -1)), foreground)[0]
                     for cue in self.appearance_cues}
        states = initialise((x + w / 2.0, y + h / 2.0), self.config.particles, self.rng,
                            sigma_pos=self.config.init_sigma)
        track = self.store.add(Track.born(birth.id, birth.box, states, templates,
                                          similarity=self.config.adaptive_fusion.rho0,
                                          last_frame=birth.last_frame, planned=planned))
        if planned:
            self._birth_boxes.append(birth.box)
            self.perspective = PerspectiveScale.fit(self._birth_boxes)
        self._next_id = max(self._next_id, birth.id + 1)
        return Estimate(frame, birth.id, track.estimate.copy(), birth.box)

    def end_planned(self, frame: int) -> None:
        """Remove the planned tracks whose last frame is before ``frame``."""
        for track in self.store:
            if track.last_frame is not None and track.last_frame < frame:
                self.store.remove(track.id)

    def births_and_deaths(self, view: FrameView, estimates: list[Estimate], assigned: np.ndarray | None = None,
                          likeness: np.ndarray | None = None) -> list[Estimate]:
        """Planned births, then the automatic tracks' losses, deaths and births; returns the frame's estimates.

        Parameters
        ----------
        view : FrameView
            The frame: its number, image, foreground and candidates.
        estimates : list of Estimate
            The live tracks' estimates of this frame, oldest track first.
        assigned : ndarray of int, shape (τ,), optional
            The candidate each live track took (−1: none).
        likeness : ndarray, shape (τ,), optional
            How much each track's window still looks like its templates (Bhattacharyya
            coefficient): at least ``appearance_support`` supports the track; NaN for a
            track that took a candidate.

        Returns
        -------
        list of Estimate
            The frame's output: the estimates of the tracks that end, are lost or coast
            unseen for longer than ``coast_frames`` are left out; those of newborn tracks
            are appended (their birth boxes).
        """
        # The lifecycle reads the tracks that went through this frame's filter; planned
        # births join it from the next frame.
        tracked = [self.store[e.id] for e in estimates]
        estimates = list(estimates) + [self.add(birth, view.number, view.image, view.foreground)
                                       for birth in (self.plan.births(view.number) if self.plan is not None else [])]
        if self.lifecycle is None:
            return estimates
        gone, births = self._losses_and_deaths(view, tracked, estimates[:len(tracked)], assigned, likeness)
        initiation = self.config.initiation
        # A track unsupported for longer than it may coast is still followed, but not output.
        # The targets the user gave beside automatic ones are always output; where the plan
        # gives every birth (births=False), the candidates are what tells whether a planned
        # track is still on its person, as for an automatic track.
        always, coast = initiation.births, initiation.coast_frames
        estimates = [e for e in estimates if e.id not in gone
                     and ((always and self.store[e.id].planned) or self.store[e.id].life.unsupported <= coast)]
        self.store.forget(view.number, initiation.memory)
        born = self._automatic_births(view, births)
        return estimates + (born if initiation.births else self._found_again(view.number, born))

    def _losses_and_deaths(self, view: FrameView, tracked: list[Track], estimates: list[Estimate],
                           assigned: np.ndarray | None, likeness: np.ndarray | None) -> tuple[set[int], np.ndarray]:
        """The lifecycle's verdict on the filtered tracks, carried out: the ids that are gone, the boxes born."""
        candidates = np.zeros((0, 5)) if view.candidates is None else np.asarray(view.candidates, dtype=np.float64)
        assigned = np.full(len(tracked), UNASSIGNED, dtype=np.intp) if assigned is None \
            else np.asarray(assigned, dtype=np.intp)
        boxes = np.array([e.box for e in estimates]).reshape(-1, 4)
        outcome = self.lifecycle.update([t.life for t in tracked], boxes, assigned, candidates,
                                        None if view.detector else view.foreground, view.births_allowed, likeness)
        for k in outcome.lost:
            self.store.lose(tracked[k].id, view.number)
        for k in outcome.ended:
            self.store.remove(tracked[k].id)
        return {tracked[k].id for k in outcome.lost + outcome.ended}, outcome.births

    def _automatic_births(self, view: FrameView, boxes: np.ndarray) -> list[Estimate]:
        """Tracks born on the chains' boxes, each re-identified if it looks like a lost one."""
        # No automatic track starts while max_targets are live: the cost of a frame grows as
        # the cube of the number of targets (TrackerConfig.max_targets).
        room = max(self.config.max_targets - len(self.store), 0)
        born = []
        for box in boxes[:room]:
            birth = TargetInit(self._next_id, view.number, None, tuple(float(v) for v in box))
            estimate = self.add(birth, view.number, view.image, view.foreground, planned=False)
            born.append(self._reidentify(estimate, view.number))
        return born

    def _found_again(self, frame: int, born: list[Estimate]) -> list[Estimate]:
        """Without births of the initiation's own: of this frame's newborn tracks, those that took back a planned id.

        A chain that looks like no lost target is nobody the plan knows of: its track ends at
        once.  One that took back a lost target's id is that target again, until the plan's
        last frame for it.
        """
        kept = []
        for estimate in born:
            target = self._planned.get(estimate.id)
            if target is not None and (target.last_frame is None or target.last_frame >= frame):
                self.store[estimate.id].last_frame = target.last_frame
                kept.append(estimate)
            else:
                self.store.remove(estimate.id)
        return kept

    def follow_candidates(self, frame: int, tracks: Sequence[Track], assigned: np.ndarray, candidates: np.ndarray,
                          detector: bool = False) -> None:
        """Tracks that took a candidate move towards it: size by ``size_smoothing``, centre by ``centre_gain``.

        A detection moves the size by ``detection_size_smoothing`` instead: a detector's boxes
        jitter from frame to frame more than a silhouette's, so they are averaged over more
        frames.

        The centre moves by the gain times the candidate's score, particles and estimate
        alike, so that the next frame starts from the corrected position.  A ``detector``'s
        box keeps a margin of background beside the person (detectors often give one
        aspect ratio to everybody): it gives at most ``max_aspect`` times its height as the
        width.  A foreground blob is the silhouette itself and gives its width as it is.

        A track's window is its base size times exp(log_scale), the scale the perspective
        model gives its row: the candidate is the whole window, so the base size moves
        towards the candidate's size divided by that scale, or the scale would count twice.
        """
        initiation = self.config.initiation
        if initiation is None:
            return
        rate, gain = initiation.size_smoothing, initiation.centre_gain
        for track, k in zip(tracks, assigned):
            if k < 0:
                continue
            x, y, w, h, score = candidates[k]
            track.last_seen = (frame, np.array([x, y, w, h]))
            width = min(w, initiation.max_aspect * h) if detector else w
            step = initiation.detection_size_smoothing if detector else rate
            track.size = (1.0 - step) * track.size + step * np.array([width, h]) / track.scale()
            if gain > 0:
                shift = np.zeros(track.particles.states.shape[1])
                shift[[CX, CY]] = gain * score * (np.array([x + w / 2.0, y + h / 2.0]) - track.estimate[[CX, CY]])
                track.particles = ParticleSet(track.particles.states + shift, track.particles.log_weights)
                track.estimate = track.estimate + shift

    def _reidentify(self, estimate: Estimate, frame: int) -> Estimate:
        """A newborn track that looks like a remembered lost one, near where it was lost, takes its id."""
        if not self.store.lost or not self.appearance_cues:
            return estimate
        track = self.store[estimate.id]
        config = self.config.initiation
        best, best_similarity = None, config.reid_similarity
        centre = np.array(estimate.state[[CX, CY]])
        for lost in self.store.lost.values():
            gap = frame - lost.frame
            x, y, w, h = lost.box
            expected = np.array([x + w / 2.0, y + h / 2.0]) + gap * lost.velocity
            # Someone out of sight may have turned or stopped: the reach grows with the time
            # gone, from one box height.
            reach = h * (1.0 + gap / 10.0)
            if np.hypot(*(centre - expected)) > reach:
                continue
            similarity = min(float(bhattacharyya(track.templates[cue.name], lost.templates[cue.name]))
                             for cue in self.appearance_cues)
            if similarity >= best_similarity:
                best, best_similarity = lost.id, similarity
        if best is None:
            return estimate
        self.store.reidentify(track.id, best)
        return Estimate(estimate.frame, best, estimate.state, estimate.box)
