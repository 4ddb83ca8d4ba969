"""The live targets: births, corrections, losses, re-identification and deaths.

:class:`TrackManager` holds the targets in birth order, which is also the order of the
appearance cues' templates: a birth appends a template to every appearance cue and a death
removes it.  Births come from the :class:`~belief_tracking.initiation.InitPlan`
(by hand or from a ground truth) and, without a plan or for the people who enter later,
from the frame's candidate boxes, by the rules of
:class:`~belief_tracking.lifecycle.Lifecycle`: a target that took a candidate moves
its box towards it (:meth:`TrackManager.follow_candidates`); one that nothing supports is
hidden, then lost, and its templates are remembered so that a newborn target that looks
like it, near where it should be, takes back its id.  The boxes of planned births fit the
perspective model of the window sizes
(:class:`~belief_tracking.perspective.PerspectiveScale`).

Every random draw (the particles of a newborn target, W-S1) comes from the generator given
to the manager.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .boxes import check_boxes
from .config import TrackerConfig
from .association import UNASSIGNED
from .cues import AppearanceCue, bhattacharyya
from .errors import InitError, TrackingError
from .initiation import InitPlan, TargetInit
from .lifecycle import Lifecycle
from .particles import CX, CY, LOG_SCALE, VX, VY, ParticleSet, initialise
from .perspective import PerspectiveScale

__all__ = ["Estimate", "Target", "TrackManager"]


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


@dataclass
class Target:
    """A live target: its particle set and what its window and templates were built from.

    Attributes
    ----------
    id : int
    last_frame : int or None
        The plan's last frame of the target (None: until the initiation ends it).
    size : ndarray, shape (2,)
        Base window size ``w, h``; a particle's window is size × exp(log_scale).
    particles : ParticleSet
    estimate : ndarray, shape (5,)
        The estimated state of the last frame (W (6)).
    birth_cy : float
        Centre row of the birth box, the reference row of the perspective scale.
    """

    id: int
    last_frame: int | None
    size: np.ndarray
    particles: ParticleSet
    estimate: np.ndarray
    birth_cy: float = 0.0

    def box(self, state: np.ndarray | None = None) -> tuple[float, float, float, float]:
        """The window ``x, y, w, h`` of ``state`` (default: the estimate), in 0-based pixels."""
        state = self.estimate if state is None else state
        w, h = self.size * math.exp(min(max(float(state[LOG_SCALE]), -30.0), 30.0))
        return (float(state[CX] - w / 2.0), float(state[CY] - h / 2.0), float(w), float(h))


class TrackManager:
    """Births and deaths of the targets, kept in step with the appearance cues' templates.

    Parameters
    ----------
    config : TrackerConfig
    plan : InitPlan or None
        Planned births and deaths; None leaves them all to the automatic initiation.
    cues : list
        The tracker's cues (the appearance cues get a template per target).
    rng : numpy.random.Generator
        Draws the particles of newborn targets (W-S1).

    Attributes
    ----------
    targets : list of Target
        The live targets, in birth order.
    perspective : PerspectiveScale or None
        The window-size model fitted to the planned birth boxes (None until two boxes on
        different rows allow a fit).
    lifecycle : Lifecycle or None
        The automatic tracks' births, losses and deaths, made at the first frame (it needs
        the image size).
    lost : dict of int to lost target
        The lost targets remembered for re-identification, by id.
    """

    def __init__(self, config: TrackerConfig, plan: InitPlan | None, cues: list, rng: np.random.Generator) -> None:
        self.config = config
        self.plan = plan
        self.cues = cues
        self.rng = rng
        self.targets: list[Target] = []
        self.perspective: PerspectiveScale | None = None
        self.lifecycle: Lifecycle | None = None
        self.lost: dict[int, _LostTarget] = {}
        self._last_seen: dict[int, tuple[int, np.ndarray]] = {}
        self._image_shape: tuple[int, int] | None = None
        self._birth_boxes: list[tuple[float, float, float, float]] = []
        planned = [t.id for t in plan.targets] if plan is not None else []
        self._planned = set(planned)
        self._next_id = max(planned, default=0) + 1
        self._appearance = [cue for cue in cues if isinstance(cue, AppearanceCue)]

    @property
    def ids(self) -> list[int]:
        """The live targets' ids, in target order."""
        return [t.id for t in self.targets]

    def start(self, image_shape: tuple[int, int]) -> None:
        """Get ready for frames of ``image_shape`` (H, W): the automatic initiation needs it."""
        self._image_shape = image_shape
        if self.config.initiation is not None:
            self.lifecycle = Lifecycle(self.config.initiation, image_shape)

    # -- births and deaths --------------------------------------------------------------------
    def add(self, birth: TargetInit, frame: int, image: np.ndarray, foreground: np.ndarray | None = None,
            planned: bool = True) -> Estimate:
        """Start tracking ``birth`` at its box in ``image`` (W-S1); returns its first estimate.

        A target that is not ``planned``
        (found by the initiation) does not enter the fit of the perspective model: blob
        boxes are too rough (merged groups, shadows, missing legs) to fit the ground plane on.
        """
        if any(t.id == birth.id for t in self.targets):
            raise InitError(f"target {birth.id} is already being tracked")
        source = self.plan.source if self.plan is not None and self.plan.source else "init"
        check_boxes([birth.box], f"{source}: the box of target {birth.id}", image_shape=image.shape[:2],
                    error=InitError)
        x, y, w, h = birth.box
        centre = (x + w / 2.0, y + h / 2.0)
        for cue in self._appearance:
            cue.add_target(image, birth.box, foreground)
        states = initialise(centre, self.config.particles, self.rng, sigma_pos=self.config.init_sigma)
        estimate = np.array([centre[0], centre[1], 0.0, 0.0, 0.0])
        self.targets.append(Target(birth.id, birth.last_frame, np.array([w, h]), ParticleSet(states), estimate,
                                   birth_cy=centre[1]))
        if planned:
            self._birth_boxes.append(birth.box)
            self.perspective = PerspectiveScale.fit(self._birth_boxes)
        self._next_id = max(self._next_id, birth.id + 1)
        return Estimate(frame, birth.id, estimate.copy(), birth.box)

    def remove(self, target_id: int) -> None:
        """Stop tracking ``target_id``; the appearance cues forget its template."""
        index = next((k for k, t in enumerate(self.targets) if t.id == target_id), None)
        if index is None:
            raise TrackingError(f"no live target {target_id!r} to remove")
        for cue in self._appearance:
            cue.remove_target(index)
        del self.targets[index]

    def end_planned(self, frame: int) -> None:
        """Remove the planned targets whose last frame is before ``frame``."""
        for target in [t for t in self.targets if t.last_frame is not None and t.last_frame < frame]:
            self.remove(target.id)

    def predicted_boxes(self, dt: float = 1.0) -> np.ndarray:
        """Each live target's box moved on by its estimated velocity for ``dt`` frames, shape (τ, 4)."""
        if not self.targets:
            return np.zeros((0, 4))
        boxes = np.array([t.box() for t in self.targets])
        boxes[:, :2] += dt * np.array([t.estimate[[VX, VY]] for t in self.targets])
        return boxes

    def births_and_deaths(self, frame: int, image: np.ndarray, foreground: np.ndarray | None,
                          estimates: list[Estimate], candidates: np.ndarray | None = None,
                          assigned: np.ndarray | None = None, detector: bool = False,
                          births_allowed: bool = True, likeness: np.ndarray | None = None) -> list[Estimate]:
        """Planned births, then the automatic tracks' losses, deaths and births; returns the frame's estimates.

        Parameters
        ----------
        frame : int
        image : ndarray of uint8, shape (H, W, 3)
        foreground : ndarray of bool, shape (H, W), or None
        estimates : list of Estimate
            The live targets' estimates of this frame, in target order.
        candidates : ndarray, shape (n, 5), optional
            The frame's candidate boxes ``x, y, w, h, score`` (detections, or person blobs).
        assigned : ndarray of int, shape (τ,), optional
            The candidate each live target took (−1: none).
        detector : bool
            Whether the candidates come from a detector.
        births_allowed : bool
            False when this frame's candidates must not start tracks (a lighting change).
        likeness : ndarray, shape (τ,), optional
            How much each target's window still looks like its templates (Bhattacharyya
            coefficient): at least ``appearance_support`` supports the target; NaN for a
            target that took a candidate.

        Returns
        -------
        list of Estimate
            The frame's output: the estimates of the tracks that end, are lost or coast
            unseen for longer than ``coast_frames`` are left out; those of newborn targets
            are appended (their birth boxes).
        """
        # The lifecycle reads the targets that went through this frame's filter; planned
        # births join it from the next frame.
        tracked = len(estimates)
        estimates = list(estimates)
        for birth in self.plan.births(frame) if self.plan is not None else []:
            estimates.append(self.add(birth, frame, image, foreground))
        if self.lifecycle is None:
            return estimates
        candidates = np.zeros((0, 5)) if candidates is None else np.asarray(candidates, dtype=np.float64)
        assigned = np.full(tracked, UNASSIGNED, dtype=np.intp) if assigned is None \
            else np.asarray(assigned, dtype=np.intp)
        ids = [e.id for e in estimates[:tracked]]
        boxes = np.array([e.box for e in estimates[:tracked]]).reshape(-1, 4)
        outcome = self.lifecycle.update(ids, boxes, assigned, candidates,
                                        None if detector else foreground, births_allowed, likeness)
        for target_id in outcome.lost:
            self._remember(target_id, frame)
        for target_id in outcome.lost + outcome.ended:
            self.remove(target_id)
            self._last_seen.pop(target_id, None)
        gone = set(outcome.lost) | set(outcome.ended)
        coast = self.config.initiation.coast_frames
        # A track unsupported for longer than it may coast is still followed, but not output;
        # the targets the user gave are always output.
        estimates = [e for e in estimates if e.id not in gone and (e.id in self._planned
                                                                   or self.lifecycle.unsupported(e.id) <= coast)]
        self._forget(frame)
        # No automatic track starts while max_targets are live: the cost of a frame grows as
        # the cube of the number of targets (TrackerConfig.max_targets).
        room = max(self.config.max_targets - len(self.targets), 0)
        for box in outcome.births[:room]:
            born = TargetInit(self._next_id, frame, None, tuple(float(v) for v in box))
            estimate = self.add(born, frame, image, foreground, planned=False)
            estimates.append(self._reidentify(estimate, frame))
        return estimates

    def follow_candidates(self, frame: int, assigned: np.ndarray, candidates: np.ndarray,
                          detector: bool = False) -> None:
        """Targets that took a candidate move towards it: size by ``size_smoothing``, centre by ``centre_gain``.

        A detection moves the size by ``detection_size_smoothing`` instead: a detector's boxes
        jitter from frame to frame more than a silhouette's, so they are averaged over more
        frames.

        The centre moves by the gain times the candidate's score, particles and estimate
        alike, so that the next frame starts from the corrected position.  A ``detector``'s
        box keeps a margin of background beside the person (detectors often give one
        aspect ratio to everybody): it gives at most ``max_aspect`` times its height as the
        width.  A foreground blob is the silhouette itself and gives its width as it is.
        """
        initiation = self.config.initiation
        if initiation is None:
            return
        rate, gain = initiation.size_smoothing, initiation.centre_gain
        for target, k in zip(self.targets, assigned):
            if k < 0:
                continue
            x, y, w, h, score = candidates[k]
            self._last_seen[target.id] = (frame, np.array([x, y, w, h]))
            width = min(w, initiation.max_aspect * h) if detector else w
            step = initiation.detection_size_smoothing if detector else rate
            target.size = (1.0 - step) * target.size + step * np.array([width, h])
            if gain > 0:
                shift = np.zeros(target.particles.states.shape[1])
                shift[[CX, CY]] = gain * score * (np.array([x + w / 2.0, y + h / 2.0]) - target.estimate[[CX, CY]])
                target.particles = ParticleSet(target.particles.states + shift, target.particles.log_weights)
                target.estimate = target.estimate + shift

    def _remember(self, target_id: int, frame: int) -> None:
        """Keep what a lost target looked like, so that a newborn target like it takes back its id."""
        index = next(k for k, t in enumerate(self.targets) if t.id == target_id)
        target = self.targets[index]
        templates = [np.array(cue.templates[index]) for cue in self._appearance]
        # Where a candidate last supported the target: after that the particles only guessed.
        seen, box = self._last_seen.pop(target_id, (frame, np.array(target.box())))
        self.lost[target_id] = _LostTarget(target_id, seen, box, target.estimate[[VX, VY]].copy(), templates)

    def _forget(self, frame: int) -> None:
        memory = self.config.initiation.memory
        for target_id in [i for i, lost in self.lost.items() if frame - lost.frame > memory]:
            del self.lost[target_id]

    def _reidentify(self, estimate: Estimate, frame: int) -> Estimate:
        """A newborn target that looks like a remembered lost one, near where it was lost, takes its id."""
        if not self.lost or not self._appearance:
            return estimate
        target = self.targets[-1]
        config = self.config.initiation
        best, best_similarity = None, config.reid_similarity
        centre = np.array(estimate.state[[CX, CY]])
        for lost in self.lost.values():
            gap = frame - lost.frame
            x, y, w, h = lost.box
            expected = np.array([x + w / 2.0, y + h / 2.0]) + gap * lost.velocity
            # Someone out of sight may have turned or stopped: the reach grows with the time
            # gone, from one box height.
            reach = h * (1.0 + gap / 10.0)
            if np.hypot(*(centre - expected)) > reach:
                continue
            similarity = min(float(bhattacharyya(cue.templates[-1], lost.templates[k]))
                             for k, cue in enumerate(self._appearance))
            if similarity >= best_similarity:
                best, best_similarity = lost.id, similarity
        if best is None:
            return estimate
        del self.lost[best]
        target.id = best
        return Estimate(estimate.frame, best, estimate.state, estimate.box)


@dataclass(frozen=True)
class _LostTarget:
    """What a lost target looked like, and where and when it was last seen."""

    id: int
    frame: int
    box: np.ndarray
    velocity: np.ndarray
    templates: list
