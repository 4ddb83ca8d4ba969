"""The live targets: births and deaths from the init plan and the automatic initiation.

:class:`TrackManager` holds the targets in birth order, which is also the order of the
appearance cues' templates: a birth appends a template to every appearance cue and a death
removes it.  Births come from the :class:`~plugins.video_tracking.initiation.InitPlan`
(by hand or from a ground truth) and, with the automatic initiation, from foreground blobs
entering the image (SPEC B.4); deaths from the plan's last frames and from the
initiation's exit, lost and duplicate rules.  A target born in part at the image border
(*growing*) takes the size and centre of its blob until the blob is all in view, and then
its templates are taken anew.  The boxes of planned births fit the perspective model of
the window sizes (:class:`~plugins.video_tracking.perspective.PerspectiveScale`).

Every random draw (the particles of a newborn target, W-S1) comes from the generator given
to the manager.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plugins.video_tracking.boxes import check_boxes, iou
from plugins.video_tracking.config import TrackerConfig
from plugins.video_tracking.cues import AppearanceCue
from plugins.video_tracking.errors import InitError, TrackingError
from plugins.video_tracking.initiation import InitPlan, Initiator, TargetInit
from plugins.video_tracking.particles import CX, CY, LOG_SCALE, ParticleSet, initialise
from plugins.video_tracking.perspective import PerspectiveScale

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
    growing : bool
        Born in part at the image border: its size follows its blob until all of it is in view.
    """

    id: int
    last_frame: int | None
    size: np.ndarray
    particles: ParticleSet
    estimate: np.ndarray
    birth_cy: float = 0.0
    growing: bool = False

    def box(self, state: np.ndarray | None = None) -> tuple[float, float, float, float]:
        """The window ``x, y, w, h`` of ``state`` (default: the estimate), in 0-based pixels."""
        state = self.estimate if state is None else state
        w, h = self.size * math.exp(float(np.clip(state[LOG_SCALE], -30.0, 30.0)))
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
    initiator : Initiator or None
        The automatic initiation, made at the first frame (it needs the image size).
    """

    def __init__(self, config: TrackerConfig, plan: InitPlan | None, cues: list, rng: np.random.Generator) -> None:
        self.config = config
        self.plan = plan
        self.cues = cues
        self.rng = rng
        self.targets: list[Target] = []
        self.perspective: PerspectiveScale | None = None
        self.initiator: Initiator | None = None
        self._image_shape: tuple[int, int] | None = None
        self._birth_boxes: list[tuple[float, float, float, float]] = []
        planned = [t.id for t in plan.targets] if plan is not None else []
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
            self.initiator = Initiator(self.config.initiation, image_shape)

    # -- births and deaths --------------------------------------------------------------------
    def add(self, birth: TargetInit, frame: int, image: np.ndarray, foreground: np.ndarray | None = None,
            growing: bool = False, planned: bool = True) -> Estimate:
        """Start tracking ``birth`` at its box in ``image`` (W-S1); returns its first estimate.

        ``growing`` marks a target seen only in part, entering at the image border (needs
        the automatic initiation, which finds the blobs).  A target that is not ``planned``
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
                                   birth_cy=centre[1], growing=bool(growing) and self.config.initiation is not None))
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

    def births_and_deaths(self, frame: int, image: np.ndarray, foreground: np.ndarray | None,
                          estimates: list[Estimate]) -> list[Estimate]:
        """Planned births, then the automatic initiation's deaths and births; returns the frame's estimates.

        The estimates of tracks that end here are dropped; those of newborn targets are
        appended (their birth boxes).
        """
        estimates = list(estimates)
        for birth in self.plan.births(frame) if self.plan is not None else []:
            estimates.append(self.add(birth, frame, image, foreground))
        if self.initiator is None:
            return estimates
        births, deaths = self.initiator.update(foreground, {e.id: e.box for e in estimates})
        for target_id in deaths:
            self.remove(target_id)
        ended = set(deaths)
        estimates = [e for e in estimates if e.id not in ended]
        self._grow(image, foreground)
        partial = self.initiator.touches_border(births) if births else []
        for box, growing in zip(births, partial):
            born = TargetInit(self._next_id, frame, None, tuple(float(v) for v in box))
            estimates.append(self.add(born, frame, image, foreground, growing=growing, planned=False))
        return estimates

    def _grow(self, image: np.ndarray, foreground: np.ndarray) -> None:
        """Targets entering the image take the size and centre of their blob until all of it is in view."""
        blobs = self.initiator.blobs
        if not len(blobs):
            return
        for index, target in enumerate(self.targets):
            if not target.growing:
                continue
            overlap = iou(np.array([target.box()]), blobs)[0]
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
            for cue in self._appearance:
                cue.rebuild_template(index, image, (x, y, w, h), foreground)
