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
import unicodedata
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from .defaults import AUTOMATIC_WARM_UP
from .errors import TrackingError
from .extras import require
from .limits import regular_file

__all__ = [
    "ExperimentError",
    "SequenceSpec",
    "MethodSpec",
    "Cell",
    "Experiment",
    "CELL_FORMAT",
    "AUTOMATIC_WARM_UP",
    "MAX_RUNS",
    "MAX_SEQUENCES",
    "MAX_METHODS",
    "MAX_NAME_CHARS",
    "MAX_SEED",
    "MAX_CONFIG_BYTES",
    "MAX_DEPTH",
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

#: The most runs (sequences x methods x seeds) an experiment may have.  Each run tracks a whole
#: sequence, so a larger grid would take years; the product is counted from the lengths of the
#: lists (and of ``[grid]``'s crossing) before any sequence, method or cell is made.  Split a
#: larger study into several experiments (``belief experiment --max-runs N`` raises it).
MAX_RUNS = 100_000

#: The most sequences, and methods, of one experiment.  Every method's settings are checked
#: before any work (about a millisecond each), so these keep the check of a grid within a
#: second or two.
MAX_SEQUENCES = 1_000
MAX_METHODS = 2_000

#: The longest name of an experiment, a sequence or a method, in characters.  Names go into the
#: file names of the saved runs (cut to a bounded slug there) and into every line of the tables.
MAX_NAME_CHARS = 200

#: The largest seed (of the tracker or of a scene's rendering): the largest integer of TOML.
MAX_SEED = 2**63 - 1

#: The largest experiment file, in bytes (a grid of a thousand sequences takes about 60 kB).
MAX_CONFIG_BYTES = 1 << 20

#: The deepest nesting of tables and arrays in an experiment (``[tracker.motion]`` is 2 deep).
MAX_DEPTH = 8


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
        last (``belief track --init-from-gt``), its track supported and corrected by the
        frames' candidates after a background warm-up of 50 frames
        where the cues read the foreground (:data:`~belief_tracking.initiation.FOLLOW_PLAN`;
        a method's ``initiation = false`` leaves the particle filters alone); ``"automatic"``: the tracks start and end on
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

        _check_name(self.name, "a sequence's name")
        where = f"sequence {self.name!r}"
        for key in ("scene", "video", "gt", "init"):
            value = getattr(self, key)
            if value is not None and not isinstance(value, str):
                raise ExperimentError(f"{where}: {key} must be text, got {type(value).__name__} {value!r:.80}")
        if (self.scene is None) == (self.video is None):
            raise ExperimentError(f"{where}: give either a synthetic 'scene' or a recorded 'video' (with 'gt')")
        if self.scene is not None and self.scene not in scenes.PRESETS:
            raise ExperimentError(f"{where}: unknown scene {self.scene!r}; known scenes: "
                                  f"{', '.join(scenes.PRESETS)}")
        if self.video is not None and self.gt is None:
            raise ExperimentError(f"{where}: a recorded video needs its ground truth 'gt' to be scored")
        if self.scene is not None and self.gt is not None:
            raise ExperimentError(f"{where}: a synthetic scene carries its own ground truth; remove 'gt'")
        _check_count(self.scene_seed, f"{where}: scene_seed", minimum=0, maximum=MAX_SEED)
        if self.frames is not None:
            _check_count(self.frames, f"{where}: frames", minimum=1)
            if self.scene is not None:
                length = scenes.PRESETS[self.scene](self.scene_seed).n_frames
                if self.frames > length:
                    # A scene is never longer than its preset: a larger count would be cut silently.
                    raise ExperimentError(f"{where}: frames = {self.frames} is more than the {length} frames of "
                                          f"scene {self.scene!r}")
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

    def __post_init__(self) -> None:
        _check_name(self.name, "a method's name")

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
        return _cell_settings(self.tracker, self.method, self.sequence.init == "automatic")

    def config(self):
        """The :class:`~belief_tracking.config.TrackerConfig` of this cell (one frozen object per method)."""
        return _method_config(self.tracker, self.method, self.sequence.init == "automatic")

    @functools.cached_property
    def key(self) -> str:
        """A file-name-safe identifier: the labels and a digest of every setting.

        The digest covers the complete configuration, defaults included, and the library's
        version, so that a saved run is not reused once a default it ran with has changed.
        The name is at most about 180 characters, whatever the names of the sequence and the
        method (each is cut to a slug of 64 characters; the digest tells them apart).
        """
        from belief import __version__

        # The JSON of the record {format, sequence, settings, config, version, seed} with sorted
        # keys, assembled from pieces computed once per sequence and per method: the same text
        # (and so the same key) as json.dumps of the whole record, without building a
        # TrackerConfig per cell, which made the keys of a large grid take minutes.
        settings = _settings_json(self.tracker, self.method, self.sequence.init == "automatic")
        text = (f'{{"config": {_config_json(self.config())}, "format": {CELL_FORMAT}, '
                f'"seed": {json.dumps(self.seed)}, '
                f'"sequence": {_sequence_json(self.sequence)}, "settings": {settings}, '
                f'"version": {json.dumps(__version__)}}}')
        digest = hashlib.sha256(text.encode()).hexdigest()[:12]
        return f"{_slug(self.sequence.name)}__{_slug(self.method.name)}__seed{self.seed}__{digest}"


def _cell_settings(tracker: tuple[tuple[str, Any], ...], method: MethodSpec, automatic: bool) -> dict[str, Any]:
    """The TrackerConfig keywords of a method's cells: the experiment's settings, then the method's."""
    settings = _thaw(tracker)
    for name, value in method.settings().items():
        if isinstance(value, dict) and isinstance(settings.get(name), dict):
            settings[name] = {**settings[name], **value}
        else:
            settings[name] = value
    if automatic:
        settings.setdefault("initiation", {})
        settings.setdefault("warm_up", AUTOMATIC_WARM_UP)
    elif "initiation" not in settings and "foreground" in settings.get("cues", _default_cues()):
        # As ``belief track --init-from-gt`` (runner.run_config): the ground truth's births and
        # deaths, with tracks that learn the background and follow the candidates as automatic
        # ones do (FOLLOW_PLAN).  A method's own ``initiation`` is used as it is: ``false`` keeps
        # the particle filters alone.
        from .initiation import FOLLOW_PLAN, settings_of

        settings["initiation"] = settings_of(FOLLOW_PLAN)
        settings.setdefault("warm_up", AUTOMATIC_WARM_UP)
    return settings


@functools.cache
def _default_cues() -> tuple[str, ...]:
    from .config import TrackerConfig

    return TrackerConfig().cues


@functools.lru_cache(maxsize=8192)
def _method_config(tracker: tuple[tuple[str, Any], ...], method: MethodSpec, automatic: bool):
    """The TrackerConfig of a method's cells, built once for all its sequences and seeds."""
    return _tracker_config(_cell_settings(tracker, method, automatic), f"method {method.name!r}")


@functools.lru_cache(maxsize=8192)
def _settings_json(tracker: tuple[tuple[str, Any], ...], method: MethodSpec, automatic: bool) -> str:
    return json.dumps(_cell_settings(tracker, method, automatic), sort_keys=True, default=str)


@functools.lru_cache(maxsize=8192)
def _config_json(config: Any) -> str:
    return json.dumps(asdict(config), sort_keys=True, default=str)


@functools.lru_cache(maxsize=8192)
def _sequence_json(sequence: SequenceSpec) -> str:
    return json.dumps(sequence.record(), sort_keys=True, default=str)


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
            _check_length(len(items), what, f"MAX_{what.upper()}", f"--max-{what}")
            _check_distinct([item.name for item in items], what)
        _check_name(self.name, "the experiment's name")
        if not self.seeds:
            raise ExperimentError("the experiment has no seeds")
        _check_runs(len(self.sequences), len(self.methods), len(self.seeds))
        for seed in self.seeds:
            _check_count(seed, "a seed", minimum=0, maximum=MAX_SEED)
        if len(set(self.seeds)) != len(self.seeds):
            repeated = sorted({s for s in self.seeds if self.seeds.count(s) > 1}) if len(self.seeds) < 1000 else []
            raise ExperimentError(f"the seeds repeat a value{': ' + str(repeated[:5]) if repeated else ''}")
        # Every method's settings are checked before any work starts: once per method and kind of
        # initiation (a cell's settings depend on nothing else), not once per cell.
        for automatic in sorted({sequence.init == "automatic" for sequence in self.sequences}):
            for method in self.methods:
                _method_config(self.tracker, method, automatic)

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

    if not isinstance(path, (str, os.PathLike)) or not os.fspath(path):
        raise ExperimentError(f"the experiment file must be a non-empty path, got {path!r}")
    path = Path(path)
    text = _read_config(path)
    try:
        mapping = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ExperimentError(f"{_shown_path(str(path))}: not valid TOML ({exc})") from None
    except RecursionError:
        raise ExperimentError(f"{_shown_path(str(path))}: not a usable TOML file: its arrays or tables nest deeper than "
                              f"the parser can follow (an experiment nests at most {MAX_DEPTH} deep)") from None
    if "name" not in mapping:
        # The file's stem names the experiment, within the bounds of any name.
        mapping["name"] = path.stem[:MAX_NAME_CHARS].strip() or "experiment"
    try:
        return experiment_from_mapping(mapping, base_dir=Path(data_dir) if data_dir is not None else path.parent)
    except ExperimentError as exc:
        raise ExperimentError(f"{_shown_path(str(path))}: {exc}") from None


def _read_config(path: Path) -> str:
    """The text of an experiment file: a regular file of at most :data:`MAX_CONFIG_BYTES` bytes of UTF-8."""
    shown = _shown_path(str(path))
    info = regular_file(path, "experiment file", ExperimentError)  # never a FIFO (it blocks) or a device
    if info.st_size > MAX_CONFIG_BYTES:
        raise ExperimentError(f"{shown}: {info.st_size:,} bytes, more than an experiment file may have "
                              f"(belief_tracking.experiment.MAX_CONFIG_BYTES = {MAX_CONFIG_BYTES:,}); "
                              f"split the study into several experiments")
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_CONFIG_BYTES + 1)
    except OSError as exc:
        raise ExperimentError(f"{shown}: cannot read ({exc.strerror or exc})") from None
    if len(data) > MAX_CONFIG_BYTES:  # pragma: no cover - the file grew since its stat
        raise ExperimentError(f"{shown}: more than MAX_CONFIG_BYTES = {MAX_CONFIG_BYTES:,} bytes")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ExperimentError(f"{shown}: not a TOML file (it is not UTF-8 text)") from None
    if "\0" in text:
        raise ExperimentError(f"{shown}: not a TOML file (it holds NUL bytes)")
    return text


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
    _check_depth(mapping)
    _check_keys(mapping, _TOP_KEYS, "the experiment")
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    name = mapping.get("name", "experiment")
    _check_name(name, "the experiment's name")

    # Counted first, from the lengths alone: a grid too large is refused before any sequence,
    # method or cell is made, in a time that does not grow with its size.
    seeds = mapping.get("seeds", [0])
    if isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
        _check_count(seeds, "seeds (a count)", minimum=1)
        if seeds > MAX_RUNS:
            raise ExperimentError(f"seeds = {seeds} is more runs than an experiment may have (MAX_RUNS = {MAX_RUNS}); "
                                  f"split the study into several experiments, or raise the limit with --max-runs N")
        n_seeds = int(seeds)
    elif isinstance(seeds, list):
        if not seeds:
            raise ExperimentError("seeds is an empty list; give a list of seeds or a count (seeds = 5: 0..4)")
        n_seeds = len(seeds)
    else:
        raise ExperimentError(f"seeds must be a list of seeds or a count, got {type(seeds).__name__} {seeds!r:.80}")

    tracker = mapping.get("tracker", {})
    if not isinstance(tracker, Mapping):
        raise ExperimentError(f"[tracker] must be a table of TrackerConfig settings, got "
                              f"{type(tracker).__name__} {tracker!r:.80}")
    _check_tracker_keys(tracker, "[tracker]")

    raw_sequences = mapping.get("sequences")
    if not isinstance(raw_sequences, list) or not raw_sequences:
        got = "" if raw_sequences is None else f", got {type(raw_sequences).__name__} {raw_sequences!r:.80}"
        raise ExperimentError(f"the experiment needs at least one [[sequences]] entry{got}")
    if "methods" in mapping and "grid" in mapping:
        raise ExperimentError("give either [[methods]] or [grid], not both")
    if "methods" in mapping:
        raw_methods = mapping["methods"]
        if not isinstance(raw_methods, list) or not raw_methods:
            raise ExperimentError("[[methods]] needs at least one entry")
        n_methods = len(raw_methods)
    else:
        grid = mapping.get("grid", {})
        n_methods = _grid_size(grid)
    _check_runs(len(raw_sequences), n_methods, n_seeds)
    _check_length(len(raw_sequences), "sequences", "MAX_SEQUENCES", "--max-sequences")
    _check_length(n_methods, "methods", "MAX_METHODS", "--max-methods")

    if isinstance(seeds, list):
        for seed in seeds:
            _check_count(seed, "a seed", minimum=0, maximum=MAX_SEED)
    else:
        seeds = list(range(n_seeds))
    sequences = tuple(_sequence(entry, base, number) for number, entry in enumerate(raw_sequences, 1))
    _check_distinct([sequence.name for sequence in sequences], "sequences")
    if "methods" in mapping:
        methods = []
        for number, entry in enumerate(raw_methods, 1):
            if not isinstance(entry, Mapping):
                raise ExperimentError(f"[[methods]] entry {number} must be a table, got "
                                      f"{type(entry).__name__} {entry!r:.80}")
            if "name" not in entry:
                raise ExperimentError(f"every [[methods]] entry needs a name; entry {number} has none")
            _check_name(entry["name"], f"[[methods]] entry {number}: name")
            options = {k: v for k, v in entry.items() if k != "name"}
            methods.append(MethodSpec.from_mapping(entry["name"], options))
        _check_distinct([method.name for method in methods], "methods")
    else:
        methods = _grid_methods(grid)
    _check_tracker_alone(tracker)
    return Experiment(name, sequences, tuple(methods), tuple(seeds), _freeze(tracker))


#: The type of every key of a ``[[sequences]]`` entry.
_SEQUENCE_TYPES = {"name": str, "scene": str, "scene_seed": int, "frames": int, "video": str, "gt": str,
                   "init": str, "detections": str}


def _sequence(entry: Any, base: Path, number: int = 1) -> SequenceSpec:
    where = f"[[sequences]] entry {number}"
    if isinstance(entry, str):
        _check_name(entry, where)
        entry = {"name": entry, "scene": entry}
    if not isinstance(entry, Mapping):
        raise ExperimentError(f"{where}: a sequence is a scene name or a table, got "
                              f"{type(entry).__name__} {entry!r:.80}")
    _check_keys(entry, _SEQUENCE_KEYS, where)
    for key, kind in _SEQUENCE_TYPES.items():
        value = entry.get(key)
        if value is not None and (not isinstance(value, kind) or isinstance(value, bool)):
            raise ExperimentError(f"{where}: {key} must be {'an integer' if kind is int else 'text'}, got "
                                  f"{type(value).__name__} {value!r:.80}")
    values = dict(entry)
    if "name" not in values:
        values["name"] = values.get("scene") or Path(str(values.get("video", "?"))).parent.name or "video"
    _check_name(values["name"], f"{where}: name")
    where = f"sequence {values['name']!r}"
    for key in _PATH_KEYS:
        if key in values:
            values[key] = _resolve_file(base, values[key], where, key)
    return SequenceSpec(**values)


def _resolve_file(base: Path, text: str, where: str, key: str) -> str:
    """The absolute path of an existing regular file named by ``text`` (relative to ``base``), the ``key`` of
    ``where`` (a sequence)."""
    what = f"{where}: {key}"
    if not text.strip() or "\0" in text:
        raise ExperimentError(f"{what} must be the path of a file, got {_shown(text)!r}")
    try:
        resolved = (base / Path(text).expanduser()).resolve()
    except (OSError, RuntimeError, ValueError) as exc:  # a name too long, a symlink loop
        raise ExperimentError(f"{what}: not a usable path {_shown(text)!r} "
                              f"({getattr(exc, 'strerror', None) or exc})") from None
    try:
        regular_file(resolved, f"{key} file", ExperimentError)
    except ExperimentError as exc:
        raise ExperimentError(f"{where}: {exc}") from None
    return str(resolved)


def _grid_lists(grid: Any) -> dict[str, list]:
    """The lists of ``[grid]``, checked: non-empty lists of text (cue sets: lists of text) without repeats."""
    if not isinstance(grid, Mapping):
        raise ExperimentError(f"[grid] must be a table of lists, got {type(grid).__name__} {grid!r:.80}")
    _check_keys(grid, _GRID_KEYS, "[grid]")
    lists = {}
    for key in _GRID_KEYS:
        value = grid.get(key)
        if value is None:
            continue
        if not isinstance(value, list) or not value:
            raise ExperimentError(f"[grid] {key} must be a non-empty list, got {type(value).__name__} {value!r:.80}")
        if key == "cues":
            value = [_cue_tuple(item) for item in value]
        else:
            for item in value:
                if not isinstance(item, str):
                    raise ExperimentError(f"[grid] {key} must be a list of names, got {type(item).__name__} "
                                          f"{item!r:.80} in it")
        _check_distinct(value, f"[grid] {key}")
        lists[key] = value
    return lists


def _grid_size(grid: Any) -> int:
    """How many methods ``[grid]`` crosses, counted without making them."""
    lists = _grid_lists(grid)
    fusions = lists.get("fusions", ["belief"])
    beliefs = fusions.count("belief")
    return len(lists.get("cues", [None])) * (len(lists.get("rules", [None])) * beliefs + len(fusions) - beliefs)


def _grid_methods(grid: Any) -> list[MethodSpec]:
    lists = _grid_lists(grid)
    rules = lists.get("rules", [None])
    fusions = lists.get("fusions", ["belief"])
    cue_sets = lists.get("cues", [None])
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
    raise ExperimentError(f"a cue set is a list of cue names or a comma-separated string, got {value!r:.80}")


def _check_keys(mapping: Mapping[str, Any], known: Sequence[str], where: str) -> None:
    unknown = [key for key in mapping if key not in known]
    if unknown:
        raise ExperimentError(f"{where}: unknown key {_shown(str(unknown[0]))!r}; known keys: {', '.join(known)}")


def _check_tracker_alone(tracker: Mapping[str, Any]) -> None:
    """Refuse a bad ``[tracker]`` setting under its own table's name rather than under a method's."""
    if tracker:
        _tracker_config(_thaw(_freeze(tracker)), "[tracker]")


def _check_depth(mapping: Mapping[str, Any]) -> None:
    """Refuse tables and arrays nested deeper than :data:`MAX_DEPTH` (walked without recursion)."""
    stack: list[tuple[Any, int]] = [(mapping, 1)]
    while stack:
        value, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise ExperimentError(f"the experiment nests tables or arrays more than "
                                  f"belief_tracking.experiment.MAX_DEPTH = {MAX_DEPTH} deep (no setting nests "
                                  f"deeper than 3)")
        if isinstance(value, Mapping):
            stack.extend((item, depth + 1) for item in value.values())
        elif isinstance(value, (list, tuple)):
            stack.extend((item, depth + 1) for item in value)


def _check_runs(sequences: int, methods: int, seeds: int) -> None:
    runs = sequences * methods * seeds
    if runs > MAX_RUNS:
        raise ExperimentError(f"{sequences} sequences x {methods} methods x {seeds} seeds = {runs} runs, more than an "
                              f"experiment may have (MAX_RUNS = {MAX_RUNS}); split the study into "
                              f"several experiments, or raise the limit with --max-runs N")


def _check_length(count: int, what: str, limit: str, option: str) -> None:
    maximum = globals()[limit]
    if count > maximum:
        raise ExperimentError(f"{count:,} {what}, more than belief_tracking.experiment.{limit} = {maximum:,}; "
                              f"split the study into several experiments, or raise the limit with {option} N")


def _check_distinct(names: Sequence[Any], what: str) -> None:
    seen: set[Any] = set()
    repeated = []
    for name in names:
        if name in seen and name not in repeated:
            repeated.append(name)
        seen.add(name)
    if repeated:
        shown = ", ".join(_shown(n if isinstance(n, str) else "+".join(n)) for n in repeated[:5])
        raise ExperimentError(f"{what} must have distinct names; repeated: {shown}")


def _check_name(value: Any, what: str) -> None:
    """A name of the tables: non-empty text of at most :data:`MAX_NAME_CHARS` characters, no control character."""
    if not isinstance(value, str) or not value.strip():
        raise ExperimentError(f"{what} must be non-empty text, got {type(value).__name__} {value!r:.80}")
    if len(value) > MAX_NAME_CHARS:
        raise ExperimentError(f"{what} has {len(value):,} characters ({_shown(value, 40)!r}), more than "
                              f"belief_tracking.experiment.MAX_NAME_CHARS = {MAX_NAME_CHARS}; use a shorter name")
    bad = next((c for c in value if unicodedata.category(c) in ("Cc", "Cs")), None)
    if bad is not None:
        # A NUL, a newline or a lone surrogate breaks the tables' lines and the files' names.
        raise ExperimentError(f"{what} {_shown(value)!r} holds the control character {bad!r}; "
                              f"use printable characters only")


def _shown(text: str, limit: int = 80) -> str:
    """``text`` cut for a one-line message."""
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text):,} characters)"


def _shown_path(path: str, limit: int = 240) -> str:
    """A path cut for a one-line message, keeping its end (the file's name)."""
    return path if len(path) <= limit else f"{path[:limit // 2]}...{path[-limit // 2:]} ({len(path):,} characters)"


def _check_tracker_keys(options: Mapping[str, Any], where: str) -> None:
    from .config import TrackerConfig

    known = [f.name for f in fields(TrackerConfig)]
    _check_keys(options, known, f"{where} (TrackerConfig settings)")


def _check_count(value: Any, what: str, minimum: int, maximum: int | None = None) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ExperimentError(f"{what} must be an integer >= {minimum}, got {type(value).__name__} {value!r:.80}")
    if maximum is not None and value > maximum:
        raise ExperimentError(f"{what} = {value} is more than the largest allowed, {maximum} (2^63 - 1)")


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


#: The characters of a name that a cell's file name keeps (the key's digest covers the whole name): a file
#: name has at most 255 bytes.
_SLUG_LENGTH = 64


def _slug(text: str) -> str:
    """A file-name piece of ``text``: ASCII letters, digits, ``.``, ``_`` and ``-``, at most 64 characters.

    A piece never starts with a dot, so that no name hides its file or reads as ``..``.
    """
    slug = re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-")[:_SLUG_LENGTH].strip("-")
    return slug if slug and not slug.startswith(".") else f"x{slug}"
