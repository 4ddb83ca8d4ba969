"""Repeated, seeded tracking experiments over a grid (``belief experiment CONFIG``).

An experiment crosses *sequences* (synthetic scenes or recorded videos with ground truth),
*methods* (a combination rule, a fusion strategy, a cue set, or any other
:class:`~plugins.video_tracking.tracker.TrackerConfig` settings) and *seeds*.  Every
combination is a :class:`Cell`: one tracking run, scored against the ground truth.  The cells
run in parallel on local processes, or on a Dask cluster when a scheduler address is given
(the same code: Dask's client offers a :class:`concurrent.futures.Executor`).  Each finished
cell is saved at once under ``OUT/cells/``, so an interrupted grid resumes where it stopped.

The outputs, in ``OUT/``:

``results.csv``
    One row per cell (tidy): the sequence, the method and its rule, fusion and cues, the
    seed, the CLEAR MOT and identity scores, the centre errors, the RMS error of the run, the
    mean particle count, the share of target-frames flagged as occluded, and the timings
    (:data:`TIMING_COLUMNS`, the only columns that differ between two runs of the same grid).
``rms.csv``
    The RMS position error of every target at every frame over the seeds, W (36):
    ``RMS_t = sqrt(1/n_runs · Σ_k [(x_k(t) − x̂_k(t))² + (y_k(t) − ŷ_k(t))²])``, with box
    centres.  When the tracks start from the ground truth a target's estimate is the track
    with its id; with the automatic initiation it is the track paired with it in that frame
    (IoU ≥ 0.5).  ``runs`` counts the runs that had an estimate.
``summary.csv``
    Per sequence and method: the mean and standard deviation over the seeds of the main
    scores.
``experiment.json``
    The grid as it was resolved (absolute paths, every setting).

The configuration is a TOML file::

    name = "two rules"
    seeds = [0, 1]                      # or a count: seeds = 5 means 0..4

    [tracker]                           # settings of every cell (TrackerConfig keywords)
    particles = 40

    [[sequences]]
    name = "crossing"
    scene = "crossing"                  # a synthetic scene of plugins.video_tracking.scenes

    [[sequences]]
    name = "pets"
    video = "pets09/video.avi"          # relative to the file (or to --data)
    gt = "pets09/gt.txt"
    init = "gt"                         # tracks born and ended as in the ground truth; or "automatic"

    [[methods]]
    name = "R-rule"
    rule = "r_rule"

    [[methods]]
    name = "adaptive"
    fusion = "adaptive"

Instead of ``[[methods]]``, a ``[grid]`` table crosses lists: ``rules``, ``fusions`` (a
fusion other than ``"belief"`` is crossed with no rule) and ``cues`` (each a list of cue
names, or a comma-separated string).  A method's or ``[tracker]``'s nested tables fill the
nested settings, e.g. ``[tracker.motion]`` ``sigma_pos = 2.0``.

Examples
--------
>>> import tempfile
>>> experiment = experiment_from_mapping({
...     "seeds": [0, 1],
...     "tracker": {"particles": 20},
...     "sequences": [{"name": "crossing", "scene": "crossing", "frames": 12}],
...     "grid": {"rules": ["r_rule", "dsmc"]}})
>>> [cell.label for cell in experiment.cells()]
['crossing/r_rule/seed 0', 'crossing/r_rule/seed 1', 'crossing/dsmc/seed 0', 'crossing/dsmc/seed 1']
>>> out = tempfile.mkdtemp()
>>> result = run_experiment(experiment, out, workers=1, progress=False)
>>> result.computed, result.reused, len(result.results)
(4, 0, 4)
>>> run_experiment(experiment, out, workers=1, progress=False).reused    # nothing is redone
4
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import csv
import hashlib
import json
import math
import os
import re
import sys
import tempfile
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

from belief.errors import BeliefError
from plugins.video_tracking.errors import TrackingError

__all__ = [
    "ExperimentError",
    "SequenceSpec",
    "MethodSpec",
    "Cell",
    "Experiment",
    "ExperimentResult",
    "RESULT_COLUMNS",
    "SCORE_COLUMNS",
    "TIMING_COLUMNS",
    "RMS_COLUMNS",
    "SUMMARY_METRICS",
    "load_experiment",
    "experiment_from_mapping",
    "run_cell",
    "run_experiment",
    "rms_per_frame",
    "register",
]

#: Version of the cell files; a cell saved by another version is run again.
CELL_FORMAT = 1

#: Columns of ``results.csv`` that hold scores (identical for identical seeds).
SCORE_COLUMNS = ("mota", "motp", "idf1", "precision", "recall", "id_switches", "false_positives",
                 "false_negatives", "matched_pairs", "num_objects", "mean_centre_error", "median_centre_error",
                 "rms_error", "mean_particles", "occluded_share")

#: Columns of ``results.csv`` that hold timings (the only ones that vary from run to run).
TIMING_COLUMNS = ("seconds", "tracking_fps", "overall_fps")

#: The columns of ``results.csv``.
RESULT_COLUMNS = ("sequence", "method", "rule", "fusion", "cues", "seed", "particles", "frames") \
    + SCORE_COLUMNS + TIMING_COLUMNS

#: The columns of ``rms.csv`` (W (36)).
RMS_COLUMNS = ("sequence", "method", "target", "frame", "runs", "rms_error")

#: The scores averaged over the seeds in ``summary.csv``.
SUMMARY_METRICS = ("mota", "idf1", "id_switches", "median_centre_error", "rms_error", "mean_particles",
                   "tracking_fps")

#: Settings of a sequence, a method, and the top level of a configuration file.
_SEQUENCE_KEYS = ("name", "scene", "scene_seed", "frames", "video", "gt", "init")
_TOP_KEYS = ("name", "seeds", "tracker", "sequences", "methods", "grid")
_GRID_KEYS = ("rules", "fusions", "cues")
_INITS = ("gt", "automatic")
#: Frames the background model learns from before an automatic run (as ``belief track``).
_AUTOMATIC_WARM_UP = 50


class ExperimentError(TrackingError):
    """A bad experiment configuration, or cells that failed (the message names them)."""


# -- the grid ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SequenceSpec:
    """One sequence of an experiment: a synthetic scene or a recorded video with ground truth.

    Attributes
    ----------
    name : str
        The label in the tables.
    scene : str or None
        A preset of :data:`plugins.video_tracking.scenes.PRESETS` (rendered on the worker).
    scene_seed : int
        Seed of the scene's rendering (its noise), the same for every run.
    frames : int or None
        Track only the first ``frames`` frames (None: all).
    video, gt : str or None
        Paths of a recorded video and its MOTChallenge ground truth (absolute once loaded).
    init : {"gt", "automatic"}
        ``"gt"``: every target is born at its first ground-truth box and removed after its
        last (``belief track --init-from-gt``); ``"automatic"``: the tracks start and end on
        their own (SPEC B.4) after a background warm-up of 50 frames.
    """

    name: str
    scene: str | None = None
    scene_seed: int = 0
    frames: int | None = None
    video: str | None = None
    gt: str | None = None
    init: str = "gt"

    def __post_init__(self) -> None:
        from plugins.video_tracking import scenes

        if not isinstance(self.name, str) or not self.name.strip():
            raise ExperimentError(f"a sequence needs a non-empty name, got {self.name!r}")
        where = f"sequence {self.name!r}"
        if (self.scene is None) == (self.video is None):
            raise ExperimentError(f"{where}: give either a synthetic 'scene' or a recorded 'video' (with 'gt')")
        if self.scene is not None and self.scene not in scenes.PRESETS:
            raise ExperimentError(f"{where}: unknown scene {self.scene!r}; known scenes: "
                                  f"{', '.join(scenes.PRESETS)}")
        if self.video is not None and self.gt is None:
            raise ExperimentError(f"{where}: a recorded video needs its ground truth 'gt' to be scored")
        if self.scene is not None and self.gt is not None:
            raise ExperimentError(f"{where}: a synthetic scene carries its own ground truth; remove 'gt'")
        _check_count(self.scene_seed, f"{where}: scene_seed", minimum=0)
        if self.frames is not None:
            _check_count(self.frames, f"{where}: frames", minimum=1)
        if self.init not in _INITS:
            raise ExperimentError(f"{where}: init must be one of {', '.join(_INITS)}, got {self.init!r}")

    def load(self) -> tuple[Any, np.ndarray]:
        """The frames to track (a rendered scene or a video path) and the ground-truth rows."""
        from plugins.video_tracking import scenes
        from plugins.video_tracking.evaluation import read_mot

        if self.scene is not None:
            scene = scenes.render(scenes.PRESETS[self.scene](self.scene_seed))
            frames, gt = scene.frames, scene.ground_truth
        else:
            frames, gt = self.video, read_mot(self.gt)
        if self.frames is not None:
            if self.scene is None:
                from plugins.video_tracking.video import VideoReader

                with contextlib.closing(VideoReader(self.video)) as reader:
                    frames = np.stack([image for _, image in zip(range(self.frames), reader)])
            frames = frames[: self.frames]
            gt = gt[gt[:, 0] <= self.frames]
        return frames, gt


@dataclass(frozen=True)
class MethodSpec:
    """One tracking method: :class:`~plugins.video_tracking.tracker.TrackerConfig` settings.

    Attributes
    ----------
    name : str
        The label in the tables.
    options : tuple of (str, object)
        TrackerConfig keywords, sorted by name; nested settings are mappings.
    """

    name: str
    options: tuple[tuple[str, Any], ...] = ()

    @classmethod
    def from_mapping(cls, name: str, options: Mapping[str, Any]) -> MethodSpec:
        """A method from its settings (checked against :class:`TrackerConfig`'s fields)."""
        _check_tracker_keys(options, f"method {name!r}")
        return cls(name, _freeze(options))

    def settings(self) -> dict[str, Any]:
        """The options as a plain dict."""
        return _thaw(self.options)


@dataclass(frozen=True)
class Cell:
    """One run of an experiment: a sequence, a method and a seed.

    Attributes
    ----------
    sequence : SequenceSpec
    method : MethodSpec
    seed : int
        The tracker's seed (the only source of randomness of the run).
    tracker : tuple of (str, object)
        The experiment-wide settings, overridden by the method's.
    """

    sequence: SequenceSpec
    method: MethodSpec
    seed: int
    tracker: tuple[tuple[str, Any], ...] = ()

    @property
    def label(self) -> str:
        """``sequence/method/seed s``, for messages."""
        return f"{self.sequence.name}/{self.method.name}/seed {self.seed}"

    def settings(self) -> dict[str, Any]:
        """The TrackerConfig keywords of this cell (experiment settings, then the method's)."""
        settings = _thaw(self.tracker)
        for name, value in self.method.settings().items():
            if isinstance(value, dict) and isinstance(settings.get(name), dict):
                settings[name] = {**settings[name], **value}
            else:
                settings[name] = value
        if self.sequence.init == "automatic":
            settings.setdefault("initiation", {})
            settings.setdefault("warm_up", _AUTOMATIC_WARM_UP)
        return settings

    def config(self):
        """The :class:`~plugins.video_tracking.tracker.TrackerConfig` of this cell."""
        return _tracker_config(self.settings(), f"method {self.method.name!r}")

    @property
    def key(self) -> str:
        """A file-name-safe identifier: the labels and a digest of every setting."""
        record = {"format": CELL_FORMAT, "sequence": asdict(self.sequence), "settings": self.settings(),
                  "seed": self.seed}
        digest = hashlib.sha256(json.dumps(record, sort_keys=True, default=str).encode()).hexdigest()[:12]
        return f"{_slug(self.sequence.name)}__{_slug(self.method.name)}__seed{self.seed}__{digest}"


@dataclass(frozen=True)
class Experiment:
    """A grid of sequences × methods × seeds.

    Attributes
    ----------
    name : str
    sequences : tuple of SequenceSpec
    methods : tuple of MethodSpec
    seeds : tuple of int
    tracker : tuple of (str, object)
        Settings of every cell (TrackerConfig keywords), which a method's settings override.
    """

    name: str
    sequences: tuple[SequenceSpec, ...]
    methods: tuple[MethodSpec, ...]
    seeds: tuple[int, ...]
    tracker: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        for what, items in (("sequences", self.sequences), ("methods", self.methods)):
            if not items:
                raise ExperimentError(f"the experiment has no {what}")
            names = [item.name for item in items]
            repeated = sorted({n for n in names if names.count(n) > 1})
            if repeated:
                raise ExperimentError(f"{what} must have distinct names; repeated: {', '.join(repeated)}")
        if not self.seeds:
            raise ExperimentError("the experiment has no seeds")
        for seed in self.seeds:
            _check_count(seed, "a seed", minimum=0)
        if len(set(self.seeds)) != len(self.seeds):
            raise ExperimentError(f"the seeds repeat a value: {list(self.seeds)}")
        for cell in self.cells():
            if cell.seed == self.seeds[0]:
                cell.config()   # every method's settings are checked before any work starts

    def cells(self) -> list[Cell]:
        """The cells in grid order: sequence, then method, then seed."""
        return [Cell(sequence, method, seed, self.tracker)
                for sequence in self.sequences for method in self.methods for seed in self.seeds]

    def to_dict(self) -> dict[str, Any]:
        """The resolved grid, JSON-ready."""
        return {"name": self.name, "seeds": list(self.seeds), "tracker": _thaw(self.tracker),
                "sequences": [asdict(s) for s in self.sequences],
                "methods": [{"name": m.name, **m.settings()} for m in self.methods]}


# -- reading a configuration ------------------------------------------------------------------------
def load_experiment(path: str | os.PathLike[str], data_dir: str | os.PathLike[str] | None = None) -> Experiment:
    """Read an experiment from a TOML file.

    Parameters
    ----------
    path : path
        The configuration (see the module's documentation for its layout).
    data_dir : path, optional
        Where relative ``video`` and ``gt`` paths are looked for (default: the file's folder).

    Raises
    ------
    ExperimentError
        A missing or malformed file, an unknown key, scene, rule, cue or setting, or a
        missing video; the message names the problem.
    """
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib

    path = Path(path)
    try:
        with open(path, "rb") as handle:
            mapping = tomllib.load(handle)
    except FileNotFoundError:
        raise ExperimentError(f"{path}: no such experiment file") from None
    except OSError as exc:
        raise ExperimentError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ExperimentError(f"{path}: not valid TOML ({exc})") from None
    mapping.setdefault("name", path.stem)
    try:
        return experiment_from_mapping(mapping, base_dir=Path(data_dir) if data_dir is not None else path.parent)
    except ExperimentError as exc:
        raise ExperimentError(f"{path}: {exc}") from None


def experiment_from_mapping(mapping: Mapping[str, Any], base_dir: str | os.PathLike[str] | None = None) -> Experiment:
    """An experiment from a mapping laid out as the TOML file.

    Parameters
    ----------
    mapping : mapping
        Keys ``name``, ``seeds``, ``tracker``, ``sequences``, and ``methods`` or ``grid``.
    base_dir : path, optional
        Where relative video and ground-truth paths are looked for (default: the working
        directory).

    Raises
    ------
    ExperimentError
        An unknown or missing key, or a bad value; the message names it.
    """
    if not isinstance(mapping, Mapping):
        raise ExperimentError(f"an experiment is a table of settings, got {type(mapping).__name__}")
    _check_keys(mapping, _TOP_KEYS, "the experiment")
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    name = mapping.get("name", "experiment")
    if not isinstance(name, str):
        raise ExperimentError(f"the experiment's name must be text, got {name!r}")

    seeds = mapping.get("seeds", [0])
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        _check_count(seeds, "seeds (a count)", minimum=1)
        seeds = list(range(seeds))
    if not isinstance(seeds, list):
        raise ExperimentError(f"seeds must be a list of seeds or a count, got {seeds!r}")

    tracker = mapping.get("tracker", {})
    if not isinstance(tracker, Mapping):
        raise ExperimentError("[tracker] must be a table of TrackerConfig settings")
    _check_tracker_keys(tracker, "[tracker]")

    raw_sequences = mapping.get("sequences")
    if not isinstance(raw_sequences, list) or not raw_sequences:
        raise ExperimentError("the experiment needs at least one [[sequences]] entry")
    sequences = tuple(_sequence(entry, base) for entry in raw_sequences)

    if "methods" in mapping and "grid" in mapping:
        raise ExperimentError("give either [[methods]] or [grid], not both")
    if "methods" in mapping:
        raw_methods = mapping["methods"]
        if not isinstance(raw_methods, list) or not raw_methods:
            raise ExperimentError("[[methods]] needs at least one entry")
        methods = []
        for entry in raw_methods:
            if not isinstance(entry, Mapping) or not isinstance(entry.get("name"), str):
                raise ExperimentError(f"every [[methods]] entry needs a name, got {entry!r}")
            options = {k: v for k, v in entry.items() if k != "name"}
            methods.append(MethodSpec.from_mapping(entry["name"], options))
    else:
        methods = _grid_methods(mapping.get("grid", {}))
    return Experiment(name, sequences, tuple(methods), tuple(seeds), _freeze(tracker))


def _sequence(entry: Any, base: Path) -> SequenceSpec:
    if isinstance(entry, str):
        entry = {"name": entry, "scene": entry}
    if not isinstance(entry, Mapping):
        raise ExperimentError(f"a sequence is a scene name or a table, got {entry!r}")
    _check_keys(entry, _SEQUENCE_KEYS, f"sequence {entry.get('name', '?')!r}")
    values = dict(entry)
    if "name" not in values:
        values["name"] = values.get("scene") or Path(str(values.get("video", "?"))).parent.name or "video"
    for key in ("video", "gt"):
        if key in values:
            if not isinstance(values[key], str):
                raise ExperimentError(f"sequence {values['name']!r}: {key} must be a path, got {values[key]!r}")
            resolved = (base / Path(values[key]).expanduser()).resolve()
            if not resolved.is_file():
                raise ExperimentError(f"sequence {values['name']!r}: {key} file not found: {resolved}")
            values[key] = str(resolved)
    try:
        return SequenceSpec(**values)
    except TypeError as exc:  # pragma: no cover - keys are checked above
        raise ExperimentError(str(exc)) from None


def _grid_methods(grid: Any) -> list[MethodSpec]:
    if not isinstance(grid, Mapping):
        raise ExperimentError("[grid] must be a table of lists")
    _check_keys(grid, _GRID_KEYS, "[grid]")
    lists = {}
    for key in _GRID_KEYS:
        value = grid.get(key)
        if value is None:
            continue
        if not isinstance(value, list) or not value:
            raise ExperimentError(f"[grid] {key} must be a non-empty list, got {value!r}")
        lists[key] = value
    rules = lists.get("rules", [None])
    fusions = lists.get("fusions", ["belief"])
    cue_sets = [None] if "cues" not in lists else [_cue_tuple(c) for c in lists["cues"]]
    methods = []
    for cues in cue_sets:
        for fusion in fusions:
            for rule in (rules if fusion == "belief" else [None]):
                options: dict[str, Any] = {}
                parts = []
                if fusion != "belief":
                    options["fusion"] = fusion
                    parts.append(str(fusion))
                if rule is not None:
                    options["rule"] = rule
                    parts.append(str(rule))
                if cues is not None:
                    options["cues"] = list(cues)
                    if len(cue_sets) > 1:
                        parts.append("+".join(cues))
                methods.append(MethodSpec.from_mapping("/".join(parts) or "default", options))
    return methods


def _cue_tuple(value: Any) -> tuple[str, ...]:
    if isinstance(value, str):
        return tuple(name.strip() for name in value.split(",") if name.strip())
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return tuple(value)
    raise ExperimentError(f"a cue set is a list of cue names or a comma-separated string, got {value!r}")


def _check_keys(mapping: Mapping[str, Any], known: Sequence[str], where: str) -> None:
    unknown = [key for key in mapping if key not in known]
    if unknown:
        raise ExperimentError(f"{where}: unknown key {unknown[0]!r}; known keys: {', '.join(known)}")


def _check_tracker_keys(options: Mapping[str, Any], where: str) -> None:
    from plugins.video_tracking.tracker import TrackerConfig

    known = [f.name for f in fields(TrackerConfig)]
    _check_keys(options, known, f"{where} (TrackerConfig settings)")


def _check_count(value: Any, what: str, minimum: int) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ExperimentError(f"{what} must be an integer >= {minimum}, got {value!r}")


def _freeze(options: Mapping[str, Any]) -> tuple[tuple[str, Any], ...]:
    """Sorted, hashable settings (lists become tuples, tables become sorted pairs)."""
    def freeze(value: Any) -> Any:
        if isinstance(value, Mapping):
            return ("__table__",) + tuple((k, freeze(v)) for k, v in sorted(value.items()))
        if isinstance(value, (list, tuple)):
            return tuple(freeze(v) for v in value)
        return value
    return tuple((key, freeze(value)) for key, value in sorted(options.items()))


def _thaw(options: tuple[tuple[str, Any], ...]) -> dict[str, Any]:
    def thaw(value: Any) -> Any:
        if isinstance(value, tuple) and value[:1] == ("__table__",):
            return {k: thaw(v) for k, v in value[1:]}
        if isinstance(value, tuple):
            return [thaw(v) for v in value]
        return value
    return {key: thaw(value) for key, value in options}


def _tracker_config(settings: Mapping[str, Any], where: str):
    """Build a TrackerConfig; nested tables fill the nested settings dataclasses."""
    from plugins.video_tracking.initiation import InitiationConfig
    from plugins.video_tracking.tracker import TrackerConfig

    defaults = TrackerConfig()
    keywords = {}
    for name, value in settings.items():
        if name == "initiation":
            value = None if value is False else _dataclass(InitiationConfig, value, f"{where}: initiation")
        elif is_dataclass(getattr(defaults, name)):
            kind = type(getattr(defaults, name))
            value = _dataclass(kind, value, f"{where}: {name}")
        elif isinstance(value, list):
            value = tuple(value)
        keywords[name] = value
    try:
        return TrackerConfig(**keywords)
    except BeliefError as exc:
        raise ExperimentError(f"{where}: {exc}") from None


def _dataclass(kind: type, value: Any, where: str):
    if not isinstance(value, Mapping):
        raise ExperimentError(f"{where} must be a table of {kind.__name__} settings, got {value!r}")
    _check_keys(value, [f.name for f in fields(kind)], where)
    values = {k: tuple(v) if isinstance(v, list) else v for k, v in value.items()}
    try:
        return kind(**values)
    except (BeliefError, TypeError, ValueError) as exc:
        raise ExperimentError(f"{where}: {exc}") from None


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-") or "x"


# -- one cell ---------------------------------------------------------------------------------------
def run_cell(cell: Cell) -> dict[str, Any]:
    """Track one cell and score it.

    Runs on a worker (a local process or a Dask worker): a synthetic scene is rendered there;
    a recorded video must be readable at the same path.

    Parameters
    ----------
    cell : Cell

    Returns
    -------
    dict
        The row of ``results.csv`` (:data:`RESULT_COLUMNS`) and, for the per-frame tables and
        figures, ``errors`` (target id → list of ``[frame, centre error]``), ``curves``
        (rows ``frame, id, m_avg(θ_j), m_avg(θ_j ∩ others), Bel_avg(θ_j), ρ``: W (33)–(35)
        and C (15)) and ``tracks`` (the rows of ``tracks.txt``).
    """
    from plugins.video_tracking.evaluation import evaluate
    from plugins.video_tracking.tracker import init_from_gt, run

    started = time.perf_counter()
    config = cell.config()
    frames, gt = cell.sequence.load()
    plan = init_from_gt(gt, source=f"ground truth of {cell.sequence.name}") \
        if cell.sequence.init == "gt" else None
    with tempfile.TemporaryDirectory(prefix="belief-cell-") as folder:
        summary = run(frames, plan, config, out_dir=folder, seed=cell.seed, write_video=False, progress=False,
                      write_plot=False)
    diagnostics = summary.diagnostics
    tracks = summary.tracks
    scores = evaluate(gt, tracks)
    errors = _centre_errors(gt, tracks, by_id=cell.sequence.init == "gt")
    squared = [e * e for pairs in errors.values() for _, e in pairs]
    seconds = time.perf_counter() - started

    def mean_of(column: str) -> float:
        values = [float(row[column]) for row in diagnostics if _float(row.get(column)) is not None]
        return float(np.mean(values)) if values else math.nan

    row = {
        "sequence": cell.sequence.name,
        "method": cell.method.name,
        "rule": config.rule if config.fusion == "belief" else "",
        "fusion": config.fusion,
        "cues": "+".join(config.cues),
        "seed": cell.seed,
        "particles": config.particles,
        "frames": summary.frames,
        "mota": scores.mota, "motp": scores.motp, "idf1": scores.idf1,
        "precision": scores.precision, "recall": scores.recall,
        "id_switches": scores.id_switches, "false_positives": scores.false_positives,
        "false_negatives": scores.false_negatives, "matched_pairs": scores.matched_pairs,
        "num_objects": scores.num_objects,
        "mean_centre_error": scores.mean_centre_error, "median_centre_error": scores.median_centre_error,
        "rms_error": math.sqrt(math.fsum(squared) / len(squared)) if squared else math.nan,
        "mean_particles": mean_of("particles"),
        "occluded_share": mean_of("occluded"),
        "seconds": seconds, "tracking_fps": summary.tracking_fps, "overall_fps": summary.overall_fps,
    }
    # NaN (a ratio without a denominator, e.g. MOTP without any match) is saved as null
    row = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in row.items()}
    curve_columns = ("mean_m_target", "mean_m_intersection", "mean_bel", "similarity")
    curves = [[int(r["frame"]), int(r["id"])] + [_float(r.get(c)) for c in curve_columns] for r in diagnostics]
    return {"format": CELL_FORMAT, "key": cell.key, "row": row,
            "errors": {str(k): v for k, v in errors.items()}, "curves": curves,
            "tracks": [[float(v) for v in r] for r in tracks]}


def _float(text: Any) -> float | None:
    try:
        value = float(text)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def _centre_errors(gt: np.ndarray, tracks: np.ndarray, by_id: bool) -> dict[int, list[list[float]]]:
    """Per scored ground-truth target: ``[frame, centre error]`` of each frame it has an estimate.

    ``by_id``: the estimate is the track with the target's id, whatever its overlap; otherwise
    it is the track paired with the target in that frame by the scoring (IoU ≥ 0.5,
    :func:`~plugins.video_tracking.evaluation.matched_pairs`).
    """
    from plugins.video_tracking.evaluation import matched_pairs

    gt = np.asarray(gt, dtype=np.float64)
    tracks = np.asarray(tracks, dtype=np.float64).reshape(-1, 10)
    if by_id:
        if gt.shape[1] > 6:
            gt = gt[gt[:, 6] != 0]

        def centres(rows: np.ndarray) -> np.ndarray:
            return rows[:, 2:4] + rows[:, 4:6] / 2.0

        estimate = {(int(f), int(i)): c for (f, i), c in zip(tracks[:, :2], centres(tracks))}
        rows = [(int(f), int(i), float(np.hypot(*(estimate[int(f), int(i)] - c))))
                for (f, i), c in zip(gt[:, :2], centres(gt)) if (int(f), int(i)) in estimate]
    else:
        rows = [(int(f), int(i), float(e)) for f, i, _, e in matched_pairs(gt, tracks)]
    errors: dict[int, list[list[float]]] = {}
    for frame, target, error in sorted(rows):
        errors.setdefault(target, []).append([frame, error])
    return dict(sorted(errors.items()))


# -- the whole grid ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class ExperimentResult:
    """What :func:`run_experiment` produced.

    Attributes
    ----------
    results : list of dict
        The rows of ``results.csv``, in grid order.
    rms : list of dict
        The rows of ``rms.csv`` (W (36)).
    summary : list of dict
        The rows of ``summary.csv``.
    cells : dict of str to dict
        Every cell's full record by key (see :func:`run_cell`), for figures.
    computed, reused : int
        Cells run now, and cells found finished in the output folder.
    files : dict of str to Path
    """

    results: list[dict[str, Any]]
    rms: list[dict[str, Any]]
    summary: list[dict[str, Any]]
    cells: dict[str, dict[str, Any]] = field(repr=False)
    computed: int
    reused: int
    files: dict[str, Path]


def run_experiment(experiment: Experiment, out_dir: str | os.PathLike[str], *, workers: int | None = None,
                   scheduler: str | None = None, fresh: bool = False, progress: bool = True) -> ExperimentResult:
    """Run every cell that is not finished yet, then write the tables.

    Parameters
    ----------
    experiment : Experiment
    out_dir : path
        Receives ``cells/`` (one JSON file per finished cell), ``results.csv``, ``rms.csv``,
        ``summary.csv`` and ``experiment.json``.
    workers : int, optional
        Local processes (default: one per core); 1 runs the cells in this process.  With
        ``scheduler="local"``, the number of workers of the local Dask cluster.
    scheduler : str, optional
        The address of a Dask scheduler (``tcp://host:8786``), or ``"local"`` to start a
        Dask cluster on this machine; needs the ``dask`` extra
        (``pip install "belief[dask]"``).  Recorded videos must be readable at the same path
        on every worker.
    fresh : bool
        Run every cell again, even those already finished.
    progress : bool
        Show a progress bar (when standard error is a terminal).

    Returns
    -------
    ExperimentResult

    Raises
    ------
    ExperimentError
        Some cells failed: the message names them; the finished ones are kept, and running
        the experiment again retries the others only.
    """
    if not isinstance(experiment, Experiment):
        raise ExperimentError(f"experiment must be an Experiment, got {type(experiment).__name__}")
    if workers is not None:
        _check_count(workers, "workers", minimum=1)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ExperimentError(f"{out} exists and is not a folder")
    cell_dir = out / "cells"
    cell_dir.mkdir(parents=True, exist_ok=True)
    _write_text(out / "experiment.json", json.dumps(experiment.to_dict(), indent=2, sort_keys=True) + "\n")

    cells = experiment.cells()
    records: dict[str, dict[str, Any]] = {}
    todo = []
    for cell in cells:
        record = None if fresh else _read_cell(cell_dir / f"{cell.key}.json", cell.key)
        if record is None:
            todo.append(cell)
        else:
            records[cell.key] = record
    reused = len(records)
    failures: list[tuple[Cell, str]] = []
    if todo:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), unit="run", desc=experiment.name, file=sys.stderr, leave=False,
                   disable=not progress or not sys.stderr.isatty())
        try:
            for cell, record, error in _outcomes(workers, scheduler, todo):
                bar.update(1)
                if error is not None:
                    failures.append((cell, error))
                    continue
                text = json.dumps(record, allow_nan=False, default=_json_default)
                _write_text(cell_dir / f"{cell.key}.json", text + "\n")
                records[cell.key] = json.loads(text)    # as a reused cell reads: lists, not tuples
        finally:
            bar.close()

    finished = [cell for cell in cells if cell.key in records]
    results = [records[cell.key]["row"] for cell in finished]
    rms = rms_per_frame(finished, records)
    summary = _summarise(finished, records)
    files = {"results.csv": out / "results.csv", "rms.csv": out / "rms.csv", "summary.csv": out / "summary.csv",
             "experiment.json": out / "experiment.json"}
    _write_csv(files["results.csv"], RESULT_COLUMNS, results)
    _write_csv(files["rms.csv"], RMS_COLUMNS, rms)
    _write_csv(files["summary.csv"], _summary_columns(), summary)
    if failures:
        first, message = failures[0]
        raise ExperimentError(f"{len(failures)} of {len(cells)} runs failed (first: {first.label}: {message}); "
                              f"the {len(finished)} finished runs are saved in {cell_dir}, and running the "
                              f"experiment again retries the others")
    return ExperimentResult(results, rms, summary, {c.key: records[c.key] for c in finished},
                            len(todo), reused, files)


def rms_per_frame(cells: Sequence[Cell], records: Mapping[str, Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The RMS position error of each target at each frame over the seeds (W (36)).

    Parameters
    ----------
    cells : sequence of Cell
        Finished cells; those of one sequence and method are the runs k = 1..n_runs.
    records : mapping of str to dict
        The cells' records by key (:func:`run_cell`).

    Returns
    -------
    list of dict
        Rows ``sequence, method, target, frame, runs, rms_error`` with
        ``rms_error = sqrt(Σ_k e_k(t)² / runs)`` over the runs that had an estimate.

    Examples
    --------
    >>> spec, method = SequenceSpec("s", scene="crossing"), MethodSpec("m")
    >>> cells = [Cell(spec, method, 0), Cell(spec, method, 1)]
    >>> records = {cells[0].key: {"errors": {"1": [[1, 3.0]]}}, cells[1].key: {"errors": {"1": [[1, 4.0]]}}}
    >>> rms_per_frame(cells, records)     # sqrt((9 + 16) / 2)
    [{'sequence': 's', 'method': 'm', 'target': 1, 'frame': 1, 'runs': 2, 'rms_error': 3.5355339059327378}]
    """
    groups: dict[tuple[str, str], dict[tuple[int, int], list[float]]] = {}
    for cell in cells:
        squares = groups.setdefault((cell.sequence.name, cell.method.name), {})
        for target, pairs in records[cell.key]["errors"].items():
            for frame, error in pairs:
                squares.setdefault((int(target), int(frame)), []).append(float(error) ** 2)
    rows = []
    for (sequence, method), squares in groups.items():
        for (target, frame), values in sorted(squares.items()):
            rows.append({"sequence": sequence, "method": method, "target": target, "frame": frame,
                         "runs": len(values), "rms_error": math.sqrt(math.fsum(values) / len(values))})
    return rows


def _summary_columns() -> tuple[str, ...]:
    return ("sequence", "method", "rule", "fusion", "cues", "runs") + tuple(
        f"{metric}_{stat}" for metric in SUMMARY_METRICS for stat in ("mean", "std"))


def _summarise(cells: Sequence[Cell], records: Mapping[str, Mapping[str, Any]]) -> list[dict[str, Any]]:
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for cell in cells:
        groups.setdefault((cell.sequence.name, cell.method.name), []).append(records[cell.key]["row"])
    rows = []
    for (sequence, method), own in groups.items():
        row: dict[str, Any] = {"sequence": sequence, "method": method, "rule": own[0]["rule"],
                               "fusion": own[0]["fusion"], "cues": own[0]["cues"], "runs": len(own)}
        for metric in SUMMARY_METRICS:
            values = np.array([np.nan if r[metric] is None else r[metric] for r in own], dtype=np.float64)
            finite = values[np.isfinite(values)]
            row[f"{metric}_mean"] = float(finite.mean()) if len(finite) else math.nan
            row[f"{metric}_std"] = float(finite.std(ddof=1)) if len(finite) > 1 else math.nan
        rows.append(row)
    return rows


def _outcomes(workers: int | None, scheduler: str | None,
              cells: Sequence[Cell]) -> Iterator[tuple[Cell, dict[str, Any] | None, str | None]]:
    """Run the cells and yield ``(cell, record, None)`` or ``(cell, None, error)`` as each ends."""
    if scheduler is None and min(workers or os.cpu_count() or 1, len(cells)) == 1:
        for cell in cells:     # in this process, one after the other
            try:
                yield cell, run_cell(cell), None
            except Exception as exc:  # noqa: BLE001 - reported with the cell it came from
                yield cell, None, f"{type(exc).__name__}: {exc}"
        return
    with _executor(workers, scheduler, len(cells)) as executor:
        futures = {executor.submit(run_cell, cell): cell for cell in cells}
        try:
            for future in concurrent.futures.as_completed(futures):
                try:
                    record = future.result()
                except Exception as exc:  # noqa: BLE001 - reported with the cell it came from
                    yield futures[future], None, f"{type(exc).__name__}: {exc}"
                else:
                    yield futures[future], record, None
        except BaseException:
            for future in futures:
                future.cancel()
            raise


@contextlib.contextmanager
def _executor(workers: int | None, scheduler: str | None, cells: int) -> Iterator[concurrent.futures.Executor]:
    if scheduler is None:
        import multiprocessing

        # spawn: no copy of this process's OpenCV threads or open files in the workers
        with concurrent.futures.ProcessPoolExecutor(min(workers or os.cpu_count() or 1, cells),
                                                    mp_context=multiprocessing.get_context("spawn")) as pool:
            yield pool
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ExperimentError('a Dask scheduler needs the dask extra: pip install "belief[dask]"') from None
    with contextlib.ExitStack() as stack:
        if scheduler == "local":
            cluster = stack.enter_context(LocalCluster(n_workers=workers or os.cpu_count() or 1,
                                                       threads_per_worker=1, dashboard_address=None))
            client = stack.enter_context(Client(cluster))
        else:
            try:
                client = stack.enter_context(Client(scheduler, timeout=30))
            except (OSError, TimeoutError, ValueError) as exc:
                raise ExperimentError(f"cannot reach the Dask scheduler at {scheduler!r} ({exc})") from None
        # pure=False: two cells are never merged into one task, whatever their arguments
        yield client.get_executor(pure=False)


def _read_cell(path: Path, key: str) -> dict[str, Any] | None:
    """A finished cell's record, or None when it is missing, unreadable or of another grid."""
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("format") != CELL_FORMAT or record.get("key") != key:
        return None
    return record


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON-ready: {type(value).__name__}")


def _write_text(path: Path, text: str) -> None:
    """Write through a temporary file, so that an interruption never leaves half a file."""
    partial = path.with_name(f".{path.name}.partial")
    partial.write_text(text, encoding="utf-8")
    os.replace(partial, path)


def _cell_text(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return "" if not math.isfinite(value) else repr(value)
    return str(value)


def _write_csv(path: Path, columns: Sequence[str], rows: Sequence[Mapping[str, Any]]) -> None:
    partial = path.with_name(f".{path.name}.partial")
    with open(partial, "w", encoding="utf-8", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(columns)
        for row in rows:
            writer.writerow([_cell_text(row.get(c)) for c in columns])
    os.replace(partial, path)


# -- command line -----------------------------------------------------------------------------------
def _format_summary(rows: Sequence[Mapping[str, Any]]) -> str:
    lines = [f"{'sequence':<18} {'method':<20} {'runs':>4} {'MOTA':>7} {'IDF1':>7} {'median px':>9} "
             f"{'RMS px':>8} {'fps':>7}"]
    for r in rows:
        def num(name: str, digits: int) -> str:
            value = r[f"{name}_mean"]
            return "-" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"
        lines.append(f"{r['sequence']:<18} {r['method']:<20} {r['runs']:>4} {num('mota', 3):>7} "
                     f"{num('idf1', 3):>7} {num('median_centre_error', 2):>9} {num('rms_error', 2):>8} "
                     f"{num('tracking_fps', 1):>7}")
    return "\n".join(lines)


def _cmd_experiment(args: Any) -> int:
    experiment = load_experiment(args.config, data_dir=args.data)
    out = Path(args.out) if args.out is not None else Path(args.config).with_suffix("")
    cells = experiment.cells()
    print(f"{experiment.name}: {len(experiment.sequences)} sequences x {len(experiment.methods)} methods x "
          f"{len(experiment.seeds)} seeds = {len(cells)} runs; outputs in {out}", flush=True)
    if args.dry_run:
        for cell in cells:
            print(f"  {cell.label}")
        return 0
    result = run_experiment(experiment, out, workers=args.workers, scheduler=args.scheduler, fresh=args.fresh,
                            progress=not args.no_progress)
    print(f"ran {result.computed} runs, reused {result.reused} finished ones")
    print(_format_summary(result.summary))
    return 0


def register(subparsers: Any) -> None:
    """Add the ``experiment`` subcommand to a ``belief`` sub-parser collection.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="belief")
    >>> register(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["experiment", "grid.toml", "--workers", "2", "--scheduler", "local"])
    >>> args.config, args.workers, args.scheduler, args.fresh
    ('grid.toml', 2, 'local', False)
    """
    p = subparsers.add_parser(
        "experiment", help="run a grid of seeded tracking runs and tabulate their scores",
        description="Run every cell of a grid (sequences x methods x seeds) described by a TOML file, in parallel "
                    "on local processes or on a Dask cluster, and write results.csv (one row per run: scores and "
                    "timings), rms.csv (RMS position error per target and frame over the seeds, W (36)) and "
                    "summary.csv into --out. Finished runs are kept in --out/cells, so an interrupted experiment "
                    "resumes where it stopped.")
    p.add_argument("config", metavar="CONFIG", help="the experiment's TOML file")
    p.add_argument("--out", metavar="DIR", help="output folder (default: CONFIG without its suffix)")
    p.add_argument("--data", metavar="DIR", help="folder of the relative video and gt paths (default: CONFIG's "
                                                  "folder)")
    p.add_argument("--workers", type=int, metavar="N", help="local processes, or local Dask workers "
                                                             "(default: one per core)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on the Dask scheduler at ADDRESS "
                                                           "(tcp://host:8786), or 'local' for a Dask cluster on "
                                                           "this machine (needs belief[dask])")
    p.add_argument("--fresh", action="store_true", help="run every cell again, even the finished ones")
    p.add_argument("--dry-run", action="store_true", help="list the runs and stop")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_experiment)
