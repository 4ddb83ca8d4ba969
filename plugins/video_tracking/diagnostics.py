"""What a run records per track and frame: collectors that read the stages' results and never steer.

:func:`diagnostic_columns` names the columns a tracker's settings record;
:class:`DiagnosticsCollector` reads one frame's stage results (the weighing, the weighted
sets, the appearance) into a :class:`FrameDiagnostics`.  With ``diagnostics="all"`` it also
computes what the running strategy does not need, the belief fusion's masses and C's feature
confidences, on its own parts: nothing it computes goes back into the tracker.
:data:`QUANTITIES` says in words what each column measures, for the pictures of a run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .appearance import Appearance
from .config import TrackerConfig
from .evidence import Evidence, Weighing
from .particles import ParticleSet
from .weighting import BELIEF_COLUMNS, BeliefWeighting, make_weighting

__all__ = ["FrameDiagnostics", "DiagnosticsCollector", "diagnostic_columns", "FILTER_COLUMNS",
           "APPEARANCE_COLUMNS", "Quantity", "QUANTITIES", "CONFIDENCE_PREFIX"]

#: Diagnostics of every particle filter, per target and frame: the particle count and the
#: effective sample size of the weights before resampling.
FILTER_COLUMNS = ("particles", "ess")

#: Diagnostics of the appearance follow-up: the total similarity ρ_t at the estimate (C (15))
#: and the occlusion flag ρ_t < T (1 or 0).
APPEARANCE_COLUMNS = ("similarity", "occluded")

#: The columns of C's feature confidences are ``confidence_<cue>``, one per cue.
CONFIDENCE_PREFIX = "confidence_"


@dataclass(frozen=True)
class Quantity:
    """What one diagnostic measures, in words: the title and the y axis of its panel in ``diagnostics.png``.

    Attributes
    ----------
    name : str
        The quantity in words, as a panel's title starts.
    label : str
        The equation of the papers that defines it ("W (33)"), or "" when none does; a title
        gives it after the name.
    axis : str
        The y axis: the symbol, what it is averaged over, and its unit or range.
    bounds : tuple of float or None
        The range of the quantity when it has one (masses, beliefs, similarities): the panel
        then shows all of it, so that panels compare at a glance.
    """

    name: str
    label: str
    axis: str
    bounds: tuple[float, float] | None = None

    @property
    def title(self) -> str:
        """The name, then the equation label in brackets when there is one.

        Examples
        --------
        >>> QUANTITIES["mean_bel"].title
        "Belief in the track's own target  (W (35))"
        >>> QUANTITIES["particles"].title
        'Particles per track'
        """
        return f"{self.name}  ({self.label})" if self.label else self.name


#: What each diagnostic column measures, in the order of the panels of ``diagnostics.png``.  The key
#: ``"confidence"`` stands for every ``confidence_<cue>`` column (one line per cue); ``occluded``
#: has no panel of its own: it marks the frames on the similarity panel.
QUANTITIES: dict[str, Quantity] = {
    "mean_m_target": Quantity("Mass on the track's own target", "W (33)",
                              "mean m(θj) over the particles (0 to 1)", (0.0, 1.0)),
    "mean_m_intersection": Quantity("Mass on overlaps with other targets", "W (34)",
                                    "mean m(θj ∩ …) over the particles (0 to 1)", (0.0, 1.0)),
    "mean_bel": Quantity("Belief in the track's own target", "W (35)",
                         "mean Bel(θj) over the particles (0 to 1)", (0.0, 1.0)),
    "mean_m_empty": Quantity("Conflict left on the empty set", "",
                             "mean m(∅) over the particles (0 to 1)", (0.0, 1.0)),
    "mean_r": Quantity("Disagreement between the first two cues", "W (10)",
                       "mean inconsistency R over the particles (0 to 1)", (0.0, 1.0)),
    "similarity": Quantity("Appearance similarity to the template", "C (15)",
                           "total similarity ρt (0 to 1)", (0.0, 1.0)),
    "confidence": Quantity("Weight of each cue in the adaptive fusion", "C (13)",
                           "feature confidence λ, mean over tracks (0 to 1)", (0.0, 1.0)),
    "particles": Quantity("Particles per track", "", "particles (count)"),
    "ess": Quantity("Effective sample size of the weights", "", "effective sample size (particles)"),
}


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
    if runs_belief(config):
        columns += BELIEF_COLUMNS
    columns += FILTER_COLUMNS
    if config.follows_appearance:
        columns += APPEARANCE_COLUMNS
    if config.fusion == "adaptive" or config.diagnostics == "all":
        columns += tuple(f"{CONFIDENCE_PREFIX}{name}" for name in config.cues)
    return columns


def runs_belief(config: TrackerConfig) -> bool:
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

    Examples
    --------
    >>> diagnostics = FrameDiagnostics(("ess",), (4, 9), np.array([[12.5], [30.0]]))
    >>> diagnostics.of(9), diagnostics.rows(3)[0]
    ({'ess': 30.0}, {'frame': 3, 'id': 4, 'ess': 12.5})
    """

    columns: tuple[str, ...]
    ids: tuple[int, ...]
    values: np.ndarray

    def of(self, target_id: int) -> dict[str, float]:
        """The diagnostics of one target, by column; KeyError if it has none this frame."""
        if target_id not in self.ids:
            raise KeyError(target_id)
        return {name: float(v) for name, v in zip(self.columns, self.values[self.ids.index(target_id)])}

    def rows(self, frame: int) -> list[dict[str, float]]:
        """One dict per target: ``frame``, ``id`` and every column (the lines of ``diagnostics.csv``)."""
        return [{"frame": frame, "id": target_id, **{c: float(v) for c, v in zip(self.columns, values)}}
                for target_id, values in zip(self.ids, self.values)]


class DiagnosticsCollector:
    """Reads a frame's stage results into its :class:`FrameDiagnostics`.

    Parameters
    ----------
    config : TrackerConfig
    beliefs : BeliefWeighting or None
        The belief fusion of the frame's evidence, when it runs (:func:`runs_belief`).
    rng : numpy.random.Generator
        Draws the resampling of C's feature confidences when they are recorded but not used
        (``diagnostics="all"`` with another strategy): a generator of their own, so that
        recording them changes nothing of the run.
    """

    def __init__(self, config: TrackerConfig, beliefs: BeliefWeighting | None, rng: np.random.Generator) -> None:
        self.config = config
        self.columns = diagnostic_columns(config)
        self.beliefs = beliefs if config.fusion != "belief" else None
        self.confidences = make_weighting("adaptive", config.belief, config.adaptive_fusion, config.cues, rng) \
            if config.diagnostics == "all" and config.fusion != "adaptive" else None

    def empty(self) -> FrameDiagnostics:
        """The diagnostics of a frame without filtered tracks."""
        return FrameDiagnostics(self.columns, (), np.zeros((0, len(self.columns))))

    def collect(self, ids: Sequence[int], evidence: Evidence, weighing: Weighing, weighted: Sequence[ParticleSet],
                appearance: Appearance | None) -> FrameDiagnostics:
        """Every column of the frame for the filtered tracks ``ids`` (in evidence order)."""
        records = dict(weighing.diagnostics)
        if self.beliefs is not None:
            records.update(self.beliefs.weigh(evidence).diagnostics)
        if self.confidences is not None:
            records.update(self.confidences.weigh(evidence).diagnostics)
        records["particles"] = np.array([float(len(p)) for p in weighted])
        records["ess"] = np.array([p.ess() for p in weighted])
        if appearance is not None:
            records["similarity"] = appearance.similarity
            records["occluded"] = appearance.occluded.astype(np.float64)
        return FrameDiagnostics(self.columns, tuple(ids), np.column_stack([records[c] for c in self.columns]))

    @staticmethod
    def of_alive(diagnostics: FrameDiagnostics, alive: set[int]) -> FrameDiagnostics:
        """``diagnostics`` without the tracks that ended or were lost after filtering."""
        if all(i in alive for i in diagnostics.ids):
            return diagnostics
        keep = [k for k, i in enumerate(diagnostics.ids) if i in alive]
        return FrameDiagnostics(diagnostics.columns, tuple(diagnostics.ids[k] for k in keep), diagnostics.values[keep])
