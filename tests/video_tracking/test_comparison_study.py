"""The results page of the comparison study agrees with its tables, and its tables with fresh runs."""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from plugins.video_tracking.experiment import (
    SCORE_COLUMNS,
    experiment_from_mapping,
    load_experiment,
    run_cell,
)

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "benchmarks" / "comparison.toml"
RESULTS = ROOT / "docs" / "results"
PAGE = ROOT / "docs" / "results.md"
DATA = ROOT.parent / "shared" / "data"
PETS = "PETS09 S2.L1"


def read_rows(path: Path) -> list[dict[str, str]]:
    with open(path, encoding="utf-8", newline="") as handle:
        return list(csv.DictReader(handle))


def synthetic_study():
    """The study's grid without its recorded sequence (which needs the data set)."""
    with open(CONFIG, "rb") as handle:
        mapping = tomllib.load(handle)
    mapping["sequences"] = [s for s in mapping["sequences"] if "scene" in s]
    return experiment_from_mapping(mapping)


def same_scores(fresh: dict, saved: dict[str, str]) -> None:
    for column in SCORE_COLUMNS:
        value, text = fresh[column], saved[column]
        if value is None:
            assert text == "", column
        elif isinstance(value, int):
            assert int(text) == value, column
        else:
            # the page is reproduced on any machine: allow the last bits of float arithmetic
            assert float(text) == pytest.approx(value, rel=1e-9, abs=1e-12), column


def test_the_study_covers_every_rule_and_strategy_of_the_issue():
    experiment = synthetic_study()
    configs = {m.name: experiment.cells()[0].__class__(experiment.sequences[0], m, 0, experiment.tracker).config()
               for m in experiment.methods}
    assert {c.rule for c in configs.values() if c.fusion == "belief"} >= {"r_rule", "dsmc", "pcr6", "dsmh",
                                                                          "dempster"}
    assert {c.fusion for c in configs.values()} == {"belief", "adaptive", "sum", "product"}
    assert configs["colour only"].cues == ("colour",)
    assert {s.scene for s in experiment.sequences} == {"crossing", "partial_occlusion", "illumination",
                                                       "scale_change"}


@pytest.mark.parametrize("sequence, method, seed", [("crossing", "R-rule", 0), ("occlusion", "DSmC", 1),
                                                    ("scale", "adaptive", 4)])
def test_a_fresh_run_reproduces_the_saved_row(sequence, method, seed):
    saved = {(r["sequence"], r["method"], r["seed"]): r for r in read_rows(RESULTS / "results.csv")}
    cell = next(c for c in synthetic_study().cells()
                if (c.sequence.name, c.method.name, c.seed) == (sequence, method, seed))
    same_scores(run_cell(cell)["row"], saved[(sequence, method, str(seed))])


@pytest.mark.data
def test_a_fresh_pets_run_reproduces_the_saved_row():
    if not (DATA / "pets09_s2l1_f0001_0200" / "video.avi").is_file():
        pytest.skip("the PETS sequence is not available")
    experiment = load_experiment(CONFIG, data_dir=DATA)
    cell = next(c for c in experiment.cells() if (c.sequence.name, c.method.name, c.seed) == (PETS, "R-rule", 0))
    saved = {(r["sequence"], r["method"], r["seed"]): r for r in read_rows(RESULTS / "results.csv")}
    same_scores(run_cell(cell)["row"], saved[(PETS, "R-rule", "0")])


def test_the_summary_is_the_mean_of_the_runs():
    results = read_rows(RESULTS / "results.csv")
    summary = read_rows(RESULTS / "summary.csv")
    assert len(results) == sum(int(r["runs"]) for r in summary)
    for row in summary:
        own = [float(r["mota"]) for r in results if (r["sequence"], r["method"]) == (row["sequence"], row["method"])]
        assert len(own) == int(row["runs"]) == 5
        assert float(row["mota_mean"]) == pytest.approx(math.fsum(own) / len(own), abs=1e-12)


def table(page: str, title: str) -> dict[tuple[str, str], str]:
    """The cells of the page's markdown table under ``## title``, by (method, sequence)."""
    section = page.split(f"## {title}\n", 1)[1].split("\n## ", 1)[0]
    lines = [line for line in section.splitlines() if line.startswith("|")]
    sequences = [c.strip() for c in lines[0].strip("|").split("|")][1:]
    cells = {}
    for line in lines[2:]:
        values = [c.strip() for c in line.strip("|").split("|")]
        for sequence, value in zip(sequences, values[1:]):
            cells[(values[0], sequence)] = value
    return cells


@pytest.mark.parametrize("title, metric, digits", [("MOTA", "mota", 3), ("IDF1", "idf1", 3),
                                                   ("Median centre error (px)", "median_centre_error", 2),
                                                   ("RMS position error (px)", "rms_error", 2)])
def test_the_page_tables_are_the_summary(title, metric, digits):
    page = PAGE.read_text(encoding="utf-8")
    cells = table(page, title)
    summary = read_rows(RESULTS / "summary.csv")
    assert len(cells) == len(summary)
    for row in summary:
        text = cells[(row["method"], row["sequence"])]
        mean, std = re.fullmatch(r"\**(-?[\d.]+) ± ([\d.]+)\**", text).groups()
        assert mean == f"{float(row[f'{metric}_mean']):.{digits}f}"
        assert std == f"{float(row[f'{metric}_std']):.{digits}f}"


def test_the_page_shows_its_figures_and_names_its_command():
    page = PAGE.read_text(encoding="utf-8")
    assert "python benchmarks/comparison_study.py" in page
    for image in re.findall(r"!\[[^\]]*\]\((results/[^)]+\.(?:png|jpg))\)", page):
        assert (ROOT / "docs" / image).is_file(), image
    assert len(re.findall(r"!\[", page)) >= 10
