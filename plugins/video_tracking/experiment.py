"""The grid of an experiment: sequences × methods × seeds, read from a TOML file.

An experiment crosses *sequences* (synthetic scenes or recorded videos with ground truth),
*methods* (a combination rule, a fusion strategy, a cue set, or any other
:class:`~belief_tracking.config.TrackerConfig` settings) and *seeds*.  Every
combination is a :class:`Cell`: one tracking run, scored against the ground truth
(:func:`belief_tracking.runs.run_cell`).  :func:`belief_tracking.grid.run_experiment`
runs the cells in parallel on local processes or a Dask cluster, resumably, and writes the
tables (``belief experiment CONFIG`` on the command line).

The outputs, in ``OUT/``, are ``results.csv`` (one row per cell), ``rms.csv`` (the RMS
position error of every target at every frame over the seeds, W (36)) and ``summary.csv``
(mean and standard deviation over the seeds), described column by column in
:mod:`belief_tracking.tables`, and ``experiment.json`` (the grid as it was resolved:
absolute paths, every setting).

The configuration is a TOML file::

    name = "two rules"
    seeds = [0, 1]                      # or a count: seeds = 5 means 0..4

    [tracker]                           # settings of every cell (TrackerConfig keywords)
    particles = 40

    [[sequences]]
    name = "crossing"
    scene = "crossing"                  # a synthetic scene of belief_tracking.scenes

    [[sequences]]
    name = "pets"
    video = "pets09/video.avi"          # relative to the file (or to --data)
    gt = "pets09/gt.txt"
    init = "gt"                         # tracks born and ended as in the ground truth; or "automatic"

    [[sequences]]
    name = "pets with detections"
    video = "pets09/video.avi"
    gt = "pets09/gt.txt"
    detections = "pets09/det.txt"       # a MOTChallenge detection file
    init = "automatic"

    [[methods]]
    name = "R-rule"
    belief.rule = "r_rule"              # the belief fusion's settings (FusionConfig)

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
>>> from belief_tracking.grid import run_experiment
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

import contextlib
import dataclasses
import functools
import hashlib
import json
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from .errors import TrackingError
from .extras import require

__all__ = [
    "ExperimentError",
    "SequenceSpec",
    "MethodSpec",
    "Cell",
    "Experiment",
    "CELL_FORMAT",
    "AUTOMATIC_WARM_UP",
    "MAX_RUNS",
    "load_experiment",
    "experiment_from_mapping",
]

#: Version of the cell files; a cell saved by another version is run again.
CELL_FORMAT = 3

#: Settings of a sequence, a method, and the top level of a configuration file.
_SEQUENCE_KEYS = ("name", "scene", "scene_seed", "frames", "video", "gt", "init", "detections")
#: The sequence's paths, resolved against the configuration's folder.
_PATH_KEYS = ("video", "gt", "detections")
_TOP_KEYS = ("name", "seeds", "tracker", "sequences", "methods", "grid")
_GRID_KEYS = ("rules", "fusions", "cues")
_INITS = ("gt", "automatic")
#: Frames the background model learns from before an automatic run (as ``belief track``).
AUTOMATIC_WARM_UP = 50

#: The most runs (sequences x methods x seeds) an experiment may have.  Each run tracks a whole
#: sequence, so a larger grid would take years; a count of seeds is refused before any list of
#: that length is made.  Split a larger study into several experiments.
MAX_RUNS = 100_000


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
        A preset of :data:`belief_tracking.scenes.PRESETS` (rendered on the worker).
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
    detections : str or None
        Path of a MOTChallenge detection file (``det.txt``, absolute once loaded), read with
        :func:`~belief_tracking.detections.read_detections` against the whole
        sequence's length and frame size (:meth:`load_detections`).  Every method that
        tracks the sequence is given the boxes, as ``belief track --detections`` does: they
        start, support and correct the tracks, and a method whose cues include
        ``"detections"`` also fuses them as a cue.  None: no detector.
    """

    name: str
    scene: str | None = None
    scene_seed: int = 0
    frames: int | None = None
    video: str | None = None
    gt: str | None = None
    init: str = "gt"
    detections: str | None = None

    def __post_init__(self) -> None:
        from . import scenes

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
        if self.detections is not None and (not isinstance(self.detections, str) or not self.detections.strip()):
            raise ExperimentError(f"{where}: detections must be the path of a detection file, got {self.detections!r}")

    def load(self) -> tuple[Any, np.ndarray]:
        """The frames to track (a rendered scene or a video path) and the ground-truth rows."""
        from .motfiles import read_mot

        if self.scene is not None:
            scene = _rendered(self.scene, self.scene_seed, self.frames)
            frames, gt = scene.frames, scene.ground_truth
        else:
            frames, gt = self.video, read_mot(self.gt)
        if self.frames is not None:
            if self.scene is None:
                from .video import VideoReader

                with contextlib.closing(VideoReader(self.video)) as reader:
                    frames = np.stack([image for _, image in zip(range(self.frames), reader)])
            frames = frames[: self.frames]
            gt = gt[gt[:, 0] <= self.frames]
        return frames, gt

    def load_detections(self):
        """The detections of the sequence, or None without a detection file.

        The file is checked against the whole sequence (the video's frame count and size, or
        the scene's), even when only its first ``frames`` are tracked.

        Returns
        -------
        Detections or None

        Raises
        ------
        TrackingError
            The file is missing or unreadable, or a line is malformed, after the last frame
            or wholly outside the image (:func:`~belief_tracking.detections.read_detections`;
            the message names the file).
        """
        from .detections import read_detections

        if self.detections is None:
            return None
        if self.scene is not None:
            from . import scenes

            config = scenes.PRESETS[self.scene](self.scene_seed)
            frame_count, size = config.n_frames, (config.width, config.height)
        else:
            from .video import VideoReader

            with contextlib.closing(VideoReader(self.video)) as reader:
                frame_count, size = reader.frame_count, (reader.width, reader.height)
        return read_detections(self.detections, frame_count=frame_count, image_size=size)

    def record(self) -> dict[str, Any]:
        """The fields as a dict; ``detections`` only when the sequence has a detection file.

        A sequence without detections keeps the record (and so the cell keys and the
        ``experiment.json``) it had before sequences could have detections.
        """
        record = asdict(self)
        if record["detections"] is None:
            del record["detections"]
        return record


@functools.lru_cache(maxsize=4)
def _rendered(name: str, seed: int, frames: int | None):
    """A preset scene, rendered once per process for all the methods and seeds that track it.

    A scene cut to its first frames is rendered to that length only: a shorter scene begins
    with exactly the frames of a longer one.
    """
    from . import scenes

    config = scenes.PRESETS[name](seed)
    if frames is not None and frames < config.n_frames:
        config = dataclasses.replace(config, n_frames=frames)
    scene = scenes.render(config)
    scene.frames.flags.writeable = False
    return scene


@dataclass(frozen=True)
class MethodSpec:
    """One tracking method: :class:`~belief_tracking.config.TrackerConfig` settings.

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
            settings.setdefault("warm_up", AUTOMATIC_WARM_UP)
        return settings

    def config(self):
        """The :class:`~belief_tracking.config.TrackerConfig` of this cell."""
        return _tracker_config(self.settings(), f"method {self.method.name!r}")

    @functools.cached_property
    def key(self) -> str:
        """A file-name-safe identifier: the labels and a digest of every setting.

        The digest covers the complete configuration, defaults included, and the library's
        version, so that a saved run is not reused once a default it ran with has changed.
        """
        from belief import __version__

        record = {"format": CELL_FORMAT, "sequence": self.sequence.record(), "settings": self.settings(),
                  "config": asdict(self.config()), "version": __version__, "seed": self.seed}
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
        runs = len(self.sequences) * len(self.methods) * len(self.seeds)
        if runs > MAX_RUNS:
            raise ExperimentError(f"{len(self.sequences)} sequences x {len(self.methods)} methods x "
                                  f"{len(self.seeds)} seeds = {runs} runs, more than an experiment may have "
                                  f"(MAX_RUNS = {MAX_RUNS}); split it into several experiments")
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
                "sequences": [s.record() for s in self.sequences],
                "methods": [{"name": m.name, **m.settings()} for m in self.methods]}


# -- reading a configuration ------------------------------------------------------------------------
def load_experiment(path: str | os.PathLike[str], data_dir: str | os.PathLike[str] | None = None) -> Experiment:
    """Read an experiment from a TOML file.

    Parameters
    ----------
    path : path
        The configuration (see the module's documentation for its layout).
    data_dir : path, optional
        Where relative ``video``, ``gt`` and ``detections`` paths are looked for (default: the
        file's folder).

    Raises
    ------
    ExperimentError
        A missing, binary or malformed file, an unknown key, scene, rule, cue or setting, a
        missing video, ground truth or detection file, or more than :data:`MAX_RUNS` runs;
        the message names the problem.
    """
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        tomllib = require("tomli")

    path = Path(path)
    try:
        with open(path, "rb") as handle:
            mapping = tomllib.load(handle)
    except FileNotFoundError:
        raise ExperimentError(f"{path}: no such experiment file") from None
    except OSError as exc:
        raise ExperimentError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise ExperimentError(f"{path}: not a TOML file (it is not UTF-8 text)") from None
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
        Where relative video, ground-truth and detection paths are looked for (default: the working
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
        if seeds > MAX_RUNS:
            raise ExperimentError(f"seeds = {seeds} is more runs than an experiment may have "
                                  f"(MAX_RUNS = {MAX_RUNS})")
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
    for key in _PATH_KEYS:
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
                    options["belief"] = {"rule": rule}
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
    from .config import TrackerConfig

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
    from .config import TrackerConfig

    try:
        return TrackerConfig.from_settings(settings, where)
    except TrackingError as exc:
        raise ExperimentError(str(exc)) from None


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-") or "x"
