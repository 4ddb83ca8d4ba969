"""Running an experiment's grid, resumably, and writing its tables (``belief experiment CONFIG``).

:func:`run_experiment` runs every cell of an
:class:`~belief_tracking.experiment.Experiment` that is not finished yet
(:func:`~belief_tracking.runs.run_cell`, in parallel through
:mod:`~belief_tracking.executors`), saves each finished cell at once under
``OUT/cells/`` (so an interrupted grid resumes where it stopped, and a failed cell is retried
alone), and writes the tables of :mod:`~belief_tracking.tables`.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import TrackingError
from .executors import executor, outcomes, runs_here
from .experiment import CELL_FORMAT, Experiment, ExperimentError
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
    tqdm = require("tqdm").tqdm

    if not isinstance(experiment, Experiment):
        raise ExperimentError(f"experiment must be an Experiment, got {type(experiment).__name__}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer))
                                or workers < 1):
        raise ExperimentError(f"workers must be an integer >= 1, got {workers!r}")
    out = check_output(out_dir)
    cell_dir = out / "cells"

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
    failures = []
    with contextlib.ExitStack() as stack:
        # The workers first (an unreachable scheduler fails here), then the announcement and the files.
        pool = None
        if todo and not runs_here(workers, scheduler, len(todo)):
            try:
                pool = stack.enter_context(executor(workers, scheduler, len(todo)))
            except TrackingError as exc:
                raise exc if isinstance(exc, ExperimentError) else ExperimentError(str(exc)) from None
        if announce is not None:
            announce()
        try:
            cell_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ExperimentError(f"cannot create the output folder {str(cell_dir)!r}: "
                                  f"{exc.strerror or exc}") from None
        write_text(out / "experiment.json", json.dumps(experiment.to_dict(), indent=2, sort_keys=True) + "\n")
        if todo:
            bar = tqdm(total=len(todo), unit="run", desc=experiment.name, file=sys.stderr, leave=False,
                       disable=not progress or not sys.stderr.isatty())
            try:
                for cell, record, error in outcomes(run_cell, todo, workers=workers, scheduler=scheduler,
                                                    pool=pool):
                    bar.update(1)
                    if error is not None:
                        failures.append((cell, error))
                        continue
                    text = json.dumps(record, allow_nan=False, default=_json_default)
                    write_text(cell_dir / f"{cell.key}.json", text + "\n")
                    records[cell.key] = json.loads(text)    # as a reused cell reads: lists, not tuples
            except TrackingError as exc:
                if isinstance(exc, ExperimentError):
                    raise
                raise ExperimentError(str(exc)) from None
            finally:
                bar.close()

    finished = [cell for cell in cells if cell.key in records]
    results = [records[cell.key]["row"] for cell in finished]
    rms = rms_per_frame([(cell.sequence.name, cell.method.name, records[cell.key]) for cell in finished])
    summary = summarise(results)
    files = {"results.csv": out / "results.csv", "rms.csv": out / "rms.csv", "summary.csv": out / "summary.csv",
             "experiment.json": out / "experiment.json"}
    write_csv(files["results.csv"], RESULT_COLUMNS, results)
    write_csv(files["rms.csv"], RMS_COLUMNS, rms)
    write_csv(files["summary.csv"], summary_columns(), summary)
    if failures:
        first, message = failures[0]
        raise ExperimentError(f"{len(failures)} of {len(cells)} runs failed (first: {first.label}: {message}); "
                              f"the {len(finished)} finished runs are saved in {cell_dir}, and running the "
                              f"experiment again retries the others")
    return ExperimentResult(results, rms, summary, {c.key: records[c.key] for c in finished},
                            len(todo), reused, files)


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
