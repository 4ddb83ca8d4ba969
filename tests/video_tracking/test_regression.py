"""Tracking quality does not regress: fresh runs of the comparison study's crossing scene against its saved scores.

The comparison study (``python benchmarks/comparison_study.py``, docs/results.md) saves every
run's scores in docs/results/results.csv.  A particle filter is chaotic: the last bits of a
sum may move one resampled particle and, from there, a seed's MOTA by a few hundredths.  So
the check is on means over seeds and with tolerances that such rounding cannot exceed, while
a real change of the tracker's behaviour (weights that stop following the targets, a lost
identity) does.
"""

from __future__ import annotations

import csv
import statistics
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from belief_tracking.experiment import experiment_from_mapping
from belief_tracking.runs import run_cell

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "benchmarks" / "comparison.toml"
RESULTS = ROOT / "docs" / "results" / "results.csv"
SEEDS = (0, 1)

#: Largest change of a mean over SEEDS that rounding alone may cause.
TOLERANCE = {"mota": 0.1, "idf1": 0.06, "median_centre_error": 1.0}


def crossing_cells(method: str):
    with open(CONFIG, "rb") as handle:
        mapping = tomllib.load(handle)
    mapping["sequences"] = [s for s in mapping["sequences"] if s.get("name") == "crossing"]
    mapping["methods"] = [m for m in mapping["methods"] if m["name"] == method]
    mapping["seeds"] = list(SEEDS)
    return experiment_from_mapping(mapping).cells()


def saved(method: str, column: str) -> float:
    with open(RESULTS, encoding="utf-8", newline="") as handle:
        rows = [r for r in csv.DictReader(handle)
                if r["sequence"] == "crossing" and r["method"] == method and int(r["seed"]) in SEEDS]
    assert len(rows) == len(SEEDS)
    return statistics.fmean(float(r[column]) for r in rows)


@pytest.mark.parametrize("method", ["R-rule", "PCR6", "adaptive"])
def test_fresh_runs_score_as_the_saved_study(method):
    rows = [run_cell(cell)["row"] for cell in crossing_cells(method)]
    for column, tolerance in TOLERANCE.items():
        fresh = statistics.fmean(row[column] for row in rows)
        assert fresh == pytest.approx(saved(method, column), abs=tolerance), column
