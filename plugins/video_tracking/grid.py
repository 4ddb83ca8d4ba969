"""Running an experiment's grid, resumably, and writing its tables (``belief experiment CONFIG``).

:func:`run_experiment` runs every cell of an
:class:`~belief_tracking.experiment.Experiment` that is not finished yet
(:func:`~belief_tracking.runs.run_cell`, in parallel through
:mod:`~belief_tracking.executors`), saves each finished cell at once under
``OUT/cells/`` (so an interrupted grid resumes where it stopped, and a failed cell is retried
alone), and writes the tables of :mod:`~belief_tracking.tables`.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import json
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import TrackingError
from .executors import executor, outcomes, runs_here
from .experiment import CELL_FORMAT, Cell, Experiment, ExperimentError
from .extras import require
from .runs import run_cell
from .tables import (
    RESULT_COLUMNS,
    RMS_COLUMNS,
    rms_per_frame,
    summarise,
    summary_columns,
    write_csv,
    write_text,
)
from .writers import ProgressBar

__all__ = ["ExperimentResult", "run_experiment", "check_output"]


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
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ExperimentError(f"{out} exists and is not a folder")
    return out


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
        (``pip install "belief[dask]"``).  Recorded videos must be readable at the same path
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
        the experiment again retries the others only.
    """
    require("tqdm")  # a missing extra is one line, before any argument is checked
    if not isinstance(experiment, Experiment):
        raise ExperimentError(f"experiment must be an Experiment, got {type(experiment).__name__}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer))
                                or workers < 1):
        raise ExperimentError(f"workers must be an integer >= 1, got {workers!r}")
    out = check_output(out_dir)
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
    """The records of the cells already saved under ``cell_dir``, by key."""
    records = {}
    for cell in cells:
        record = _read_cell(cell_dir / f"{cell.key}.json", cell.key)
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
    write_text(out / "experiment.json", json.dumps(experiment.to_dict(), indent=2, sort_keys=True) + "\n")


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
            write_text(cell_dir / f"{cell.key}.json", text + "\n")
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
    write_csv(files["results.csv"], RESULT_COLUMNS, results)
    write_csv(files["rms.csv"], RMS_COLUMNS, rms)
    write_csv(files["summary.csv"], summary_columns(), summary)
    return results, rms, summary, files


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
