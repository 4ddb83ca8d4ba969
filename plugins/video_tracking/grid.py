"""Running an experiment's grid, resumably, and writing its tables (``belief experiment CONFIG``).

:func:`run_experiment` runs every cell of an
:class:`~belief_tracking.experiment.Experiment` that is not finished yet
(:func:`~belief_tracking.runs.run_cell`, in parallel through
:mod:`~belief_tracking.executors`), saves each finished cell at once under
``OUT/cells/`` (so an interrupted grid resumes where it stopped, and a failed cell is retried
alone), and writes the tables of :mod:`~belief_tracking.tables`.

Before any of it, :func:`plan_experiment` counts the grid and estimates the time and peak memory
of every run from the sizes alone (frames, pixels, particles, targets): a run estimated beyond
:data:`MAX_RUN_SECONDS` or :data:`MAX_RUN_BYTES` is refused before anything is written, and
``belief experiment --dry-run`` prints the count and the estimate.  Every file is written to a
new hidden name in its own folder and renamed into place (:func:`os.replace` replaces a
symlink there rather than following it), so a file is whole or absent and nothing is written
outside the output folder.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import functools
import json
import math
import os
import stat
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import limits
from .errors import TrackingError
from .executors import executor, outcomes, runs_here
from .experiment import CELL_FORMAT, Cell, Experiment, ExperimentError, SequenceSpec
from .extras import require
from .runs import run_cell
from .tables import (
    RESULT_COLUMNS,
    RMS_COLUMNS,
    SUMMARY_METRICS,
    csv_text,
    rms_per_frame,
    summarise,
    summary_columns,
    write_text,
)
from .writers import ProgressBar

__all__ = ["ExperimentResult", "ExperimentPlan", "run_experiment", "plan_experiment", "check_output", "set_limits",
           "MAX_RUN_SECONDS", "MAX_RUN_BYTES", "MAX_CELL_FILE_BYTES", "OUTPUT_FILES"]

#: The longest estimated time of one run, in seconds (``belief experiment --max-run-seconds``).
#: A run over it (a million particles, say) would hold a worker for hours: refused before any work.
MAX_RUN_SECONDS = 600.0

#: The largest estimated peak memory of one run, in bytes (``belief experiment --max-run-bytes``).
#: Every worker holds one run at a time, so the grid's peak is this many times the workers.
MAX_RUN_BYTES = 1 << 30

#: A saved run larger than this is not one of ours (the largest records are a few megabytes):
#: it is run again rather than read.
MAX_CELL_FILE_BYTES = 256 << 20

#: The files an experiment writes at the top of its output folder (the runs go to ``cells/``).
OUTPUT_FILES = ("experiment.json", "results.csv", "rms.csv", "summary.csv")

# A run's time and memory are those of belief_tracking.limits (estimate_seconds, estimate_memory), with the
# frames a sequence holds in memory on top: a synthetic scene is rendered whole, a cut video is read whole.


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
        Every cell's full record by key (see :func:`~belief_tracking.runs.run_cell`),
        for figures.
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


@dataclass(frozen=True)
class ExperimentPlan:
    """The size of an experiment and the estimated cost of running it (:func:`plan_experiment`).

    Attributes
    ----------
    runs : int
        Cells of the grid (sequences x methods x seeds).
    run_seconds : float
        Estimated time of the longest run, in seconds.
    total_seconds : float
        Estimated time of all the runs on one core.
    wall_seconds : float
        Estimated time with ``workers`` processes.
    run_bytes : int
        Estimated peak memory of the largest run.
    peak_bytes : int
        Estimated peak memory with ``workers`` runs at once.
    workers : int
    """

    runs: int
    run_seconds: float
    total_seconds: float
    wall_seconds: float
    run_bytes: int
    peak_bytes: int
    workers: int

    def describe(self) -> str:
        """One line: the estimated time and memory of the grid.

        Examples
        --------
        >>> ExperimentPlan(8, 3.0, 20.0, 10.0, 200 << 20, 400 << 20, 2).describe()
        'estimated 20 s of computing (10 s on 2 workers), up to 3 s and 200 MB per run, 400 MB at once'
        """
        return (f"estimated {limits.duration(self.total_seconds)} of computing ({limits.duration(self.wall_seconds)} on "
                f"{self.workers} worker{'s' if self.workers != 1 else ''}), up to {limits.duration(self.run_seconds)} "
                f"and {_megabytes(self.run_bytes)} per run, {_megabytes(self.peak_bytes)} at once")


def plan_experiment(experiment: Experiment, *, workers: int | None = None) -> ExperimentPlan:
    """Count the grid and estimate its time and memory from the sizes alone, before any work.

    The cost of a run is estimated from its sequence's frames and frame size (a scene's preset,
    or a video's header), its targets (a scene's walkers, or the most ground-truth boxes of one
    frame) and its method's particles; the grid's from its runs and ``workers``.

    Parameters
    ----------
    experiment : Experiment
    workers : int, optional
        Local processes (default: one per core).

    Returns
    -------
    ExperimentPlan

    Raises
    ------
    ExperimentError
        A run is estimated to take more than :data:`MAX_RUN_SECONDS` or more memory than
        :data:`MAX_RUN_BYTES` (the message names the run, the estimate and how to raise the
        limit), or a recorded sequence's video or ground truth cannot be read.

    Examples
    --------
    >>> from belief_tracking.experiment import experiment_from_mapping
    >>> plan = plan_experiment(experiment_from_mapping({"seeds": 3, "tracker": {"particles": 20},
    ...     "sequences": [{"name": "crossing", "scene": "crossing", "frames": 10}]}), workers=1)
    >>> plan.runs, plan.workers, 1 < plan.run_seconds < 3
    (3, 1, True)
    """
    if not isinstance(experiment, Experiment):
        raise ExperimentError(f"experiment must be an Experiment, got {type(experiment).__name__}")
    _check_workers(workers)
    seeds = len(experiment.seeds)
    runs = len(experiment.sequences) * len(experiment.methods) * seeds
    longest, largest, total = 0.0, 0, 0.0
    for sequence in experiment.sequences:
        frames, width, height, held, targets = _sequence_size(sequence)
        pixels = width * height
        for method in experiment.methods:
            config = Cell(sequence, method, experiment.seeds[0], experiment.tracker).config()
            seconds = limits.estimate_seconds(config, width, height, frames, targets)
            memory = limits.estimate_memory(config, width, height, targets, frames).total + held * pixels * 3
            label = f"{sequence.name}/{method.name}"
            if seconds > MAX_RUN_SECONDS:
                raise ExperimentError(
                    f"a run of {label} is estimated at {limits.duration(seconds)} ({frames} frames of {pixels:,} pixels, "
                    f"{config.particles:,} particles x {targets} targets), more than "
                    f"belief_tracking.grid.MAX_RUN_SECONDS = {MAX_RUN_SECONDS:g}; use fewer particles or frames, "
                    f"or raise the limit with --max-run-seconds N")
            if memory > MAX_RUN_BYTES:
                raise ExperimentError(
                    f"a run of {label} is estimated at {_megabytes(memory)} of memory ({held} frames held of "
                    f"{pixels:,} pixels, {config.particles:,} particles x {targets} targets), more than "
                    f"belief_tracking.grid.MAX_RUN_BYTES = {MAX_RUN_BYTES:,}; use fewer particles or frames, "
                    f"or raise the limit with --max-run-bytes N")
            longest, largest = max(longest, seconds), max(largest, memory)
            total += seconds * seeds
    at_once = max(1, min(workers or os.cpu_count() or 1, runs))
    return ExperimentPlan(runs, longest, total, total / at_once, largest, largest * at_once, at_once)


def set_limits(*, max_runs: int | None = None, max_sequences: int | None = None, max_methods: int | None = None,
               max_run_seconds: float | None = None, max_run_bytes: int | None = None) -> None:
    """Raise (or lower) the limits of experiments for this process; None keeps a limit as it is.

    ``belief experiment --max-runs N`` and its siblings call it before the grid is read.

    Parameters
    ----------
    max_runs, max_sequences, max_methods : int, optional
        :data:`~belief_tracking.experiment.MAX_RUNS`, ``MAX_SEQUENCES``, ``MAX_METHODS``.
    max_run_seconds : float, optional
        :data:`MAX_RUN_SECONDS`.
    max_run_bytes : int, optional
        :data:`MAX_RUN_BYTES`.

    Raises
    ------
    ExperimentError
        A limit that is not a positive number.
    """
    from . import experiment as grid_module

    global MAX_RUN_SECONDS, MAX_RUN_BYTES
    for name, value in (("max_runs", max_runs), ("max_sequences", max_sequences), ("max_methods", max_methods),
                        ("max_run_seconds", max_run_seconds), ("max_run_bytes", max_run_bytes)):
        if value is None:
            continue
        integral = name != "max_run_seconds"
        if (isinstance(value, bool) or not isinstance(value, (int, np.integer) if integral else (int, float))
                or not value > 0 or (not integral and not math.isfinite(value))):
            raise ExperimentError(f"{name} must be a positive {'integer' if integral else 'number'}, got {value!r}")
    if max_runs is not None:
        grid_module.MAX_RUNS = int(max_runs)
    if max_sequences is not None:
        grid_module.MAX_SEQUENCES = int(max_sequences)
    if max_methods is not None:
        grid_module.MAX_METHODS = int(max_methods)
    if max_run_seconds is not None:
        MAX_RUN_SECONDS = float(max_run_seconds)
    if max_run_bytes is not None:
        MAX_RUN_BYTES = int(max_run_bytes)


@functools.lru_cache(maxsize=256)
def _sequence_size(sequence: SequenceSpec) -> tuple[int, int, int, int, int]:
    """Frames tracked, frame width and height, frames held in memory whole, and most targets in one frame."""
    if sequence.scene is not None:
        from . import scenes

        config = scenes.PRESETS[sequence.scene](sequence.scene_seed)
        frames = min(sequence.frames or config.n_frames, config.n_frames)
        # A scene is rendered whole before it is tracked.
        return frames, config.width, config.height, frames, max(1, len(config.walkers))
    from .motfiles import read_mot
    from .video import VideoReader

    where = f"sequence {sequence.name!r}"
    try:
        with contextlib.closing(VideoReader(sequence.video)) as reader:
            count, width, height = reader.frame_count, reader.width, reader.height
        gt = read_mot(sequence.gt)
    except TrackingError as exc:
        raise ExperimentError(f"{where}: {exc}") from None
    frames = int(count) if count else int(gt[:, 0].max()) if len(gt) else 1
    if sequence.frames is not None:
        frames = min(frames, sequence.frames)
        held = frames         # the first frames are read into memory (SequenceSpec.load)
    else:
        held = 0              # streamed: the frames of the run's own estimate only
    if len(gt):
        _, per_frame = np.unique(gt[:, 0], return_counts=True)
        targets = int(per_frame.max())
    else:
        targets = 1
    return max(frames, 1), width, height, held, targets




def _megabytes(count: int) -> str:
    return f"{count / 2**20:,.0f} MB" if count < 10 * 2**30 else f"{count / 2**30:,.0f} GB"


def _check_workers(workers: Any) -> None:
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer))
                                or workers < 1):
        raise ExperimentError(f"workers must be an integer >= 1, got {workers!r}")


def check_output(out_dir: str | os.PathLike[str]) -> Path:
    """The output folder of an experiment as a Path; an empty path or an existing file is refused.

    Examples
    --------
    >>> check_output("")
    Traceback (most recent call last):
    ...
    belief_tracking.experiment.ExperimentError: the output folder must be a non-empty path, got ''
    """
    if not isinstance(out_dir, (str, os.PathLike)) or not os.fspath(out_dir).strip():
        raise ExperimentError(f"the output folder must be a non-empty path, got {out_dir!r}")
    if "\0" in os.fspath(out_dir):
        raise ExperimentError(f"the output folder {os.fspath(out_dir)[:80]!r} holds a NUL character")
    out = Path(out_dir)
    try:
        exists = out.exists()
        if exists and not out.is_dir():
            raise ExperimentError(f"{out} exists and is not a folder")
    except OSError as exc:  # a name too long, a parent that is a file
        raise ExperimentError(f"the output folder {str(out)[:200]!r} is not usable ({exc.strerror or exc})") from None
    return out


def _check_output_contents(out: Path) -> None:
    """Refuse, before any work, an output folder whose files could not be replaced or would lead outside it."""
    if not out.exists():
        return
    if not os.access(out, os.W_OK | os.X_OK):
        raise ExperimentError(f"cannot write into the output folder {out} (permission denied)")
    cell_dir = out / "cells"
    if cell_dir.is_symlink() or (os.path.lexists(cell_dir) and not cell_dir.is_dir()):
        # A symlink there would put the saved runs (and their replacements) outside the folder.
        raise ExperimentError(f"{cell_dir} is a symlink or not a folder; the runs are saved only in a real "
                              f"folder of the output folder: move it away")
    for name in OUTPUT_FILES:
        path = out / name
        if not path.is_symlink() and path.is_dir():
            raise ExperimentError(f"{path} is a folder, where the experiment writes its file {name}: move it away")


def run_experiment(experiment: Experiment, out_dir: str | os.PathLike[str], *, workers: int | None = None,
                   scheduler: str | None = None, fresh: bool = False, progress: bool = True,
                   announce: Callable[[], None] | None = None) -> ExperimentResult:
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
        (``pip install "belief-dsmt[dask]"``).  Recorded videos must be readable at the same path
        on every worker.  The scheduler runs the cells as pickled Python tasks and sends
        back pickled results: connect only to a scheduler you trust (one that is not yours
        can run its own code here).
    fresh : bool
        Run every cell again, even those already finished.
    progress : bool
        Show a progress bar (when standard error is a terminal).
    announce : callable, optional
        Called with no argument once every argument is checked and the workers are ready
        (the Dask scheduler reached), before anything is written: ``belief experiment``
        prints its "N runs; outputs in OUT" line there, so that a bad argument is the only
        line printed.

    Returns
    -------
    ExperimentResult

    Raises
    ------
    ExperimentError
        Some cells failed: the message names them; the finished ones are kept, and running
        the experiment again retries the others only.  Also, before any work: a run estimated
        beyond :data:`MAX_RUN_SECONDS` or :data:`MAX_RUN_BYTES` (:func:`plan_experiment`), or an
        output folder that cannot take the files (a folder or symlink where a file or
        ``cells/`` goes, no permission).
    """
    require("tqdm")  # a missing extra is one line, before any argument is checked
    if not isinstance(experiment, Experiment):
        raise ExperimentError(f"experiment must be an Experiment, got {type(experiment).__name__}")
    _check_workers(workers)
    out = check_output(out_dir)
    _check_output_contents(out)
    plan_experiment(experiment, workers=workers)   # a run too long or too large is refused here
    cell_dir = out / "cells"
    cells = experiment.cells()
    records = {} if fresh else _finished_cells(cells, cell_dir)
    todo = [cell for cell in cells if cell.key not in records]
    reused = len(records)
    with contextlib.ExitStack() as stack:
        # The workers first (an unreachable scheduler fails here), then the announcement and the files.
        pool = None
        if todo and not runs_here(workers, scheduler, len(todo)):
            with _as_experiment_error():
                pool = stack.enter_context(executor(workers, scheduler, len(todo)))
        if announce is not None:
            announce()
        _start_output(out, cell_dir, experiment)
        with _as_experiment_error():
            failures = _run_pending(todo, cell_dir, records, workers=workers, scheduler=scheduler, pool=pool,
                                    progress=progress, desc=experiment.name)
    finished = [cell for cell in cells if cell.key in records]
    results, rms, summary, files = _write_tables(out, finished, records)
    if failures:
        first, message = failures[0]
        raise ExperimentError(f"{len(failures)} of {len(cells)} runs failed (first: {first.label}: {message}); "
                              f"the {len(finished)} finished runs are saved in {cell_dir}, and running the "
                              f"experiment again retries the others")
    return ExperimentResult(results, rms, summary, {c.key: records[c.key] for c in finished},
                            len(todo), reused, files)


@contextlib.contextmanager
def _as_experiment_error() -> Iterator[None]:
    """Raise a :class:`TrackingError` of the block (a worker pool that cannot start, say) as an ExperimentError."""
    try:
        yield
    except TrackingError as exc:
        if isinstance(exc, ExperimentError):
            raise
        raise ExperimentError(str(exc)) from None


def _finished_cells(cells: Sequence[Cell], cell_dir: Path) -> dict[str, dict[str, Any]]:
    """The records of the cells already saved under ``cell_dir``, by key.

    The folder is listed once; only regular files (no symlink, FIFO or device) of at most
    :data:`MAX_CELL_FILE_BYTES` bytes are read, and anything else is run again.
    """
    try:
        with os.scandir(cell_dir) as listing:
            saved = {entry.name: entry for entry in listing if entry.name.endswith(".json")}
    except OSError:   # no folder yet (or not a readable one): nothing is finished
        return {}
    records = {}
    for cell in cells:
        entry = saved.get(f"{cell.key}.json")
        if entry is None:
            continue
        record = _read_cell(Path(entry.path), cell)
        if record is not None:
            records[cell.key] = record
    return records


def _start_output(out: Path, cell_dir: Path, experiment: Experiment) -> None:
    """Create ``OUT/cells/`` and write ``experiment.json``."""
    try:
        cell_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExperimentError(f"cannot create the output folder {str(cell_dir)!r}: "
                              f"{exc.strerror or exc}") from None
    _write_atomic(out, "experiment.json", json.dumps(experiment.to_dict(), indent=2, sort_keys=True) + "\n")


def _run_pending(todo: Sequence[Cell], cell_dir: Path, records: dict[str, dict[str, Any]], *,
                 workers: int | None, scheduler: str | None, pool: concurrent.futures.Executor | None,
                 progress: bool, desc: str) -> list[tuple[Cell, str]]:
    """Run the cells of ``todo``, saving each finished one at once; returns the failed cells and their errors.

    ``records`` gains the record of every finished cell, as a reused cell reads it back.
    """
    failures: list[tuple[Cell, str]] = []
    if not todo:
        return failures
    bar = ProgressBar(len(todo), show=progress, unit="run", desc=desc)
    try:
        for cell, record, error in outcomes(run_cell, todo, workers=workers, scheduler=scheduler, pool=pool):
            bar.advance()
            if error is not None:
                failures.append((cell, error))
                continue
            text = json.dumps(record, allow_nan=False, default=_json_default)
            _write_atomic(cell_dir, f"{cell.key}.json", text + "\n")
            records[cell.key] = json.loads(text)    # as a reused cell reads: lists, not tuples
    finally:
        bar.close()
    return failures


def _write_tables(out: Path, finished: Sequence[Cell], records: Mapping[str, dict[str, Any]]):
    """Write ``results.csv``, ``rms.csv`` and ``summary.csv`` of the finished cells; returns their rows and files."""
    results = [records[cell.key]["row"] for cell in finished]
    rms = rms_per_frame([(cell.sequence.name, cell.method.name, records[cell.key]) for cell in finished])
    summary = summarise(results)
    files = {"results.csv": out / "results.csv", "rms.csv": out / "rms.csv", "summary.csv": out / "summary.csv",
             "experiment.json": out / "experiment.json"}
    _write_atomic(out, "results.csv", csv_text(RESULT_COLUMNS, results))
    _write_atomic(out, "rms.csv", csv_text(RMS_COLUMNS, rms))
    _write_atomic(out, "summary.csv", csv_text(summary_columns(), summary))
    return results, rms, summary, files


def _write_atomic(folder: Path, name: str, text: str) -> Path:
    """Write ``folder/name`` whole, never through a symbolic link (:func:`~belief_tracking.tables.write_text`)."""
    target = folder / name
    try:
        write_text(target, text)
    except OSError as exc:
        raise ExperimentError(f"cannot write {target} ({exc.strerror or exc})") from None
    return target


def _read_cell(path: Path, cell: Cell | str) -> dict[str, Any] | None:
    """A finished cell's record, or None when it is missing, unreadable, malformed or of another grid."""
    key = cell if isinstance(cell, str) else cell.key
    try:
        info = os.lstat(path)
        if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_CELL_FILE_BYTES:
            return None
        flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
        with open(os.open(path, flags), "rb") as handle:
            data = handle.read(MAX_CELL_FILE_BYTES + 1)
        record = json.loads(data.decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(record, dict) or record.get("format") != CELL_FORMAT or record.get("key") != key:
        return None
    if not _valid_record(record, None if isinstance(cell, str) else cell):
        return None
    return record


def _valid_record(record: Mapping[str, Any], cell: Cell | None) -> bool:
    """Whether a saved record has what the tables read, of the right types (else its cell runs again)."""
    row, errors = record.get("row"), record.get("errors")
    if not isinstance(row, dict) or not isinstance(errors, dict):
        return False
    if any(column not in row for column in RESULT_COLUMNS):
        return False
    if cell is not None and (row["sequence"] != cell.sequence.name or row["method"] != cell.method.name):
        return False
    for metric in SUMMARY_METRICS:
        value = row.get(metric)
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))):
            return False
    if not all(isinstance(record.get(name), list) for name in ("curves", "tracks")):
        return False
    for target, pairs in errors.items():
        if not target.lstrip("-").isdigit() or not isinstance(pairs, list):
            return False
        for pair in pairs:
            if (not isinstance(pair, list) or len(pair) != 2
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in pair)
                    or not all(math.isfinite(v) for v in pair)):
                return False
    return True


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON-ready: {type(value).__name__}")
