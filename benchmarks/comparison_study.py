"""The comparison study: every fusion rule and strategy on PETS 2009 and on synthetic scenes.

One command regenerates the whole results page of the documentation::

    python benchmarks/comparison_study.py                  # runs the grid, writes docs/results.md and its figures
    python benchmarks/comparison_study.py --workers 2      # local processes (default: one per core)
    python benchmarks/comparison_study.py --scheduler tcp://host:8786   # on a Dask cluster
    python benchmarks/comparison_study.py --data DIR       # another copy of the PETS sequence

The grid is ``benchmarks/comparison.toml`` (5 sequences x 9 methods x 5 seeds), run by
:func:`belief_tracking.grid.run_experiment`, so ``belief experiment
benchmarks/comparison.toml --data DIR`` gives the same ``results.csv``.  Finished runs are
kept in ``--runs`` (default ``comparison_runs/``), so an interrupted study resumes.  The page
(``docs/results.md``), its tables (``docs/results/*.csv``) and its figures
(``docs/results/*.png``) are rewritten from the runs.

The PETS sequence is looked for in ``shared/data/pets09_s2l1_f0001_0200`` next to the
repository (or under ``--data``); without it the script says so and exits 0 without
touching the page.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from belief_tracking import scenes  # noqa: E402
from belief_tracking.experiment import load_experiment  # noqa: E402
from belief_tracking.grid import run_experiment  # noqa: E402

CONFIG = ROOT / "benchmarks" / "comparison.toml"
DEFAULT_DATA = ROOT.parent / "shared" / "data"
PETS = "pets09_s2l1_f0001_0200"
#: The rules of belief-function theory in the study; the others are the strategies without masses.
DSMT_RULES = ("R-rule", "DSmC", "PCR6", "DSmH")
BELIEF_METHODS = DSMT_RULES + ("Dempster",)
#: Frames shown in the annotated strips (1-based, as in MOTChallenge files).
STRIP_FRAMES = {"crossing": (30, 45, 51, 70), "occlusion": (20, 40, 45, 80), "PETS09 S2.L1": (20, 70, 120, 170)}
#: Methods drawn in the annotated strips, one row each.
STRIP_METHODS = ("R-rule", "DSmC", "adaptive")
#: Occlusion of the crossing scene's far walker (1-based frames): partial, then full.
CROSSING_PARTIAL, CROSSING_FULL = (40, 62), (48, 54)
TABLES = (("mota", "MOTA", 3, True), ("idf1", "IDF1", 3, True), ("median_centre_error", "median centre error (px)",
                                                                     2, False),
          ("rms_error", "RMS position error (px)", 2, False), ("id_switches", "identity switches", 1, False),
          ("tracking_fps", "tracking speed (frames/s)", 0, None))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder holding " + PETS)
    parser.add_argument("--runs", type=Path, default=ROOT / "comparison_runs", help="folder of the finished runs")
    parser.add_argument("--docs", type=Path, default=ROOT / "docs", help="documentation folder to write into")
    parser.add_argument("--workers", type=int, help="local processes (default: one per core)")
    parser.add_argument("--scheduler", help="Dask scheduler address, or 'local'")
    args = parser.parse_args(argv)
    if not (args.data / PETS / "video.avi").is_file():
        print(f"PETS sequence not found in {args.data / PETS}: the study was not run")
        return 0
    experiment = load_experiment(CONFIG, data_dir=args.data)
    print(f"{len(experiment.cells())} runs; finished ones are kept in {args.runs}", flush=True)
    result = run_experiment(experiment, args.runs, workers=args.workers, scheduler=args.scheduler)
    print(f"ran {result.computed}, reused {result.reused}")

    figures = args.docs / "results"
    figures.mkdir(parents=True, exist_ok=True)
    for name in ("results.csv", "summary.csv", "rms.csv"):
        shutil.copyfile(result.files[name], figures / name)
    methods = [m.name for m in experiment.methods]
    sequences = [s.name for s in experiment.sequences]
    summary = {(r["sequence"], r["method"]): r for r in result.summary}
    plot_heatmap(figures / "mota.png", summary, sequences, methods)
    for sequence in sequences:
        plot_rms(figures / f"rms_{slug(sequence)}.png", result.rms, sequence, methods)
    crossing = experiment.sequences[sequences.index("crossing")]
    plot_confidence(figures / "confidence_crossing.png", result, experiment, crossing)
    for sequence, frames in STRIP_FRAMES.items():
        spec = experiment.sequences[sequences.index(sequence)]
        plot_strip(figures / f"frames_{slug(sequence)}.jpg", result, experiment, spec, frames)
    page = render_page(experiment, result, summary, sequences, methods)
    (args.docs / "results.md").write_text(page, encoding="utf-8")
    print(f"wrote {args.docs / 'results.md'} and {len(list(figures.iterdir()))} files in {figures}")
    return 0


def slug(text: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in text.lower()).strip("_")


# -- figures ---------------------------------------------------------------------------------------------
def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


STYLE = {"R-rule": ("tab:red", "-"), "DSmC": ("tab:orange", "-"), "PCR6": ("tab:purple", "-"),
         "DSmH": ("tab:brown", "-"), "Dempster": ("tab:gray", "--"), "adaptive": ("tab:blue", "-"),
         "sum": ("tab:cyan", ":"), "product": ("tab:green", "--"), "colour only": ("black", ":")}


def plot_heatmap(path: Path, summary: dict, sequences: list[str], methods: list[str]) -> None:
    plt = _pyplot()
    values = np.array([[summary[(s, m)]["mota_mean"] for s in sequences] for m in methods], dtype=float)
    fig, ax = plt.subplots(figsize=(1.6 * len(sequences) + 2.5, 0.45 * len(methods) + 1.5))
    image = ax.imshow(values, cmap="RdYlGn", vmin=-0.5, vmax=1.0, aspect="auto")
    ax.set_xticks(range(len(sequences)), sequences, rotation=20, ha="right")
    ax.set_yticks(range(len(methods)), methods)
    for i in range(len(methods)):
        for j in range(len(sequences)):
            ax.text(j, i, f"{values[i, j]:.2f}", ha="center", va="center", fontsize=8)
    fig.colorbar(image, ax=ax, label="MOTA (mean over the seeds)")
    ax.set_title("MOTA by method and sequence")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_rms(path: Path, rms: list[dict], sequence: str, methods: list[str], most: int = 6) -> None:
    """W (36) per target: one panel per target, one curve per method (as the tracking paper's Fig. 12)."""
    plt = _pyplot()
    curves: dict[int, dict[str, tuple[list[int], list[float]]]] = defaultdict(dict)
    for row in rms:
        if row["sequence"] != sequence:
            continue
        frames, values = curves[row["target"]].setdefault(row["method"], ([], []))
        frames.append(row["frame"])
        values.append(row["rms_error"])
    lengths = {t: max(len(f) for f, _ in by.values()) for t, by in curves.items()}
    targets = sorted(sorted(curves, key=lambda t: -lengths[t])[:most])
    cols = min(3, len(targets))
    rows = math.ceil(len(targets) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.6 * cols, 3.0 * rows), squeeze=False, sharey=True)
    for ax, target in zip(axes.flat, targets):
        for method in methods:
            if method in curves[target]:
                colour, line = STYLE.get(method, (None, "-"))
                ax.plot(*curves[target][method], line, color=colour, lw=1.2, label=method)
        ax.set_title(f"target {target}")
        ax.set_xlabel("frame")
        ax.set_yscale("log")
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(targets):]:
        ax.axis("off")
    for ax in axes[:, 0]:
        ax.set_ylabel("RMS error (px), W (36)")
    axes.flat[0].legend(fontsize=7, ncol=2)
    fig.suptitle(f"{sequence}: RMS position error over the seeds")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_confidence(path: Path, result, experiment, sequence) -> None:
    """W (33)-(35) on the crossing scene, seed 0, per belief rule (as the tracking paper's Fig. 10)."""
    plt = _pyplot()
    seed = experiment.seeds[0]
    records = {cell.method.name: result.cells[cell.key] for cell in experiment.cells()
               if cell.sequence == sequence and cell.seed == seed and cell.method.name in BELIEF_METHODS}
    quantities = ((2, "m_avg(θ_j), W (33)"), (3, "m_avg(θ_j ∩ θ_other), W (34)"), (4, "Bel_avg(θ_j), W (35)"))
    targets = sorted({row[1] for rec in records.values() for row in rec["curves"]})
    fig, axes = plt.subplots(len(quantities), len(targets), figsize=(5.0 * len(targets), 2.6 * len(quantities)),
                             squeeze=False, sharex=True)
    for j, target in enumerate(targets):
        for i, (column, label) in enumerate(quantities):
            ax = axes[i, j]
            ax.axvspan(*CROSSING_PARTIAL, color="0.9")
            ax.axvspan(*CROSSING_FULL, color="0.75")
            for method, record in records.items():
                rows = [r for r in record["curves"] if r[1] == target and r[column] is not None]
                colour, line = STYLE.get(method, (None, "-"))
                ax.plot([r[0] for r in rows], [r[column] for r in rows], line, color=colour, lw=1.2, label=method)
            ax.set_ylim(-0.02, 1.02)
            ax.grid(alpha=0.3)
            if j == 0:
                ax.set_ylabel(label, fontsize=8)
            if i == 0:
                ax.set_title(f"target {target}" + (" (hidden)" if target == 1 else " (in front)"))
        axes[-1, j].set_xlabel("frame")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"{sequence.name}, seed {seed}: mean masses and belief of each target's particles "
                 "(grey: partial, dark grey: full occlusion)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _frames(spec, wanted: tuple[int, ...]) -> dict[int, np.ndarray]:
    if spec.scene is not None:
        scene = scenes.render(scenes.PRESETS[spec.scene](spec.scene_seed))
        return {f: scene.frames[f - 1] for f in wanted}
    from belief_tracking.video import VideoReader

    found = {}
    reader = VideoReader(spec.video)
    try:
        for index, image in enumerate(reader, start=1):
            if index in wanted:
                found[index] = image
            if len(found) == len(wanted):
                break
    finally:
        reader.close()
    return found


def plot_strip(path: Path, result, experiment, spec, wanted: tuple[int, ...]) -> None:
    """Frames with the ground truth (white, dashed) and the tracks of seed 0 (coloured, with ids)."""
    plt = _pyplot()
    from matplotlib.patches import Rectangle

    images = _frames(spec, wanted)
    gt = spec.load()[1]
    seed = experiment.seeds[0]
    tracks = {cell.method.name: np.array(result.cells[cell.key]["tracks"]).reshape(-1, 10)
              for cell in experiment.cells() if cell.sequence == spec and cell.seed == seed}
    height, width = next(iter(images.values())).shape[:2]
    fig, axes = plt.subplots(len(STRIP_METHODS), len(wanted), squeeze=False,
                             figsize=(2.6 * len(wanted) * width / height, 2.6 * len(STRIP_METHODS)))
    palette = plt.get_cmap("tab10")
    for i, method in enumerate(STRIP_METHODS):
        for j, frame in enumerate(wanted):
            ax = axes[i, j]
            ax.imshow(images[frame][:, :, ::-1])
            for row in gt[gt[:, 0] == frame]:
                ax.add_patch(Rectangle((row[2] - 1, row[3] - 1), row[4], row[5], fill=False, ec="white", lw=0.9,
                                       ls="--"))
            for row in tracks[method][tracks[method][:, 0] == frame]:
                colour = palette(int(row[1]) % 10)
                ax.add_patch(Rectangle((row[2] - 1, row[3] - 1), row[4], row[5], fill=False, ec=colour, lw=1.4))
                ax.text(row[2] - 1, row[3] - 3, str(int(row[1])), color=colour, fontsize=7, weight="bold")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(f"frame {frame}", fontsize=9)
            if j == 0:
                ax.set_ylabel(method, fontsize=9)
    fig.suptitle(f"{spec.name}: tracks of seed {seed} (coloured) and ground truth (white, dashed)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100, pil_kwargs={"quality": 85})
    plt.close(fig)


# -- the page --------------------------------------------------------------------------------------------
def _number(value, digits: int) -> str:
    return "–" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def metric_table(summary: dict, sequences: list[str], methods: list[str], metric: str, digits: int,
                 higher_better: bool | None) -> str:
    lines = ["| method | " + " | ".join(sequences) + " |", "|---|" + "---:|" * len(sequences)]
    best = {}
    if higher_better is not None:
        for s in sequences:
            values = [summary[(s, m)][f"{metric}_mean"] for m in methods]
            finite = [v for v in values if v is not None and math.isfinite(v)]
            best[s] = (max if higher_better else min)(finite) if finite else None
    for m in methods:
        cells = []
        for s in sequences:
            row = summary[(s, m)]
            mean, std = row[f"{metric}_mean"], row[f"{metric}_std"]
            text = _number(mean, digits)
            if std is not None and math.isfinite(std) and metric != "tracking_fps":
                text += f" ± {_number(std, digits)}"
            if best.get(s) is not None and mean is not None and round(mean, digits) == round(best[s], digits):
                text = f"**{text}**"
            cells.append(text)
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def findings(summary: dict, sequences: list[str], methods: list[str]) -> list[str]:
    """Plain statements read off the summary: the best method per sequence, and DSmT rules against the rest."""
    out = []
    wins = ties = 0
    for s in sequences:
        mota = {m: round(summary[(s, m)]["mota_mean"], 3) for m in methods}
        ranked = sorted(methods, key=lambda m: -mota[m])
        best_rule = max(DSMT_RULES, key=lambda m: mota[m])
        best_other = max((m for m in methods if m not in DSMT_RULES), key=lambda m: mota[m])
        if mota[best_rule] > mota[best_other]:
            verdict, wins = "a DSmT rule is best", wins + 1
        elif mota[best_rule] == mota[best_other]:
            verdict, ties = "a tie", ties + 1
        else:
            verdict = "the DSmT rules are not best"
        tied = [m for m in methods if mota[m] == mota[ranked[0]]]
        head = (f"best MOTA {ranked[0]} ({mota[ranked[0]]:.3f}), then {ranked[1]} ({mota[ranked[1]]:.3f}) and "
                f"{ranked[2]} ({mota[ranked[2]]:.3f})") if len(tied) < 3 else \
            f"MOTA {mota[ranked[0]]:.3f} for {len(tied)} methods ({', '.join(tied)})"
        out.append(f"**{s}**: {head}; worst {ranked[-1]} ({mota[ranked[-1]]:.3f}). Best DSmT rule: {best_rule} "
                   f"({mota[best_rule]:.3f}); best of the other methods: {best_other} ({mota[best_other]:.3f}): "
                   f"{verdict}.")
    out.append(f"Over the {len(sequences)} sequences, the best DSmT rule has a higher MOTA than every other method "
               f"on {wins}, ties on {ties} and is beaten on {len(sequences) - wins - ties}.")
    beats = [s for s in sequences if round(summary[(s, "R-rule")]["mota_mean"], 3)
             > round(summary[(s, "Dempster")]["mota_mean"], 3)]
    out.append(f"The R-weighted rule has a higher MOTA than Dempster's rule on {len(beats)} of {len(sequences)} "
               "sequences" + (f" ({', '.join(beats)})." if beats else "."))
    colour = [s for s in sequences if round(summary[(s, "R-rule")]["mota_mean"], 3)
              > round(summary[(s, "colour only")]["mota_mean"], 3)]
    out.append(f"Fusing the three cues by the R-weighted rule has a higher MOTA than the colour cue alone on "
               f"{len(colour)} of {len(sequences)} sequences" + (f" ({', '.join(colour)})." if colour else "."))
    return out


def same_runs(result, first: str, second: str) -> bool:
    """Whether two methods gave the same scores on every sequence and seed (floats to 1e-9)."""
    from belief_tracking.tables import SCORE_COLUMNS

    rows = defaultdict(dict)
    for row in result.results:
        rows[(row["sequence"], row["seed"])][row["method"]] = row

    def same(x, y) -> bool:
        if x is None or y is None:
            return x is y
        return math.isclose(x, y, rel_tol=1e-9, abs_tol=1e-12)

    return all(same(both[first][c], both[second][c]) for both in rows.values() for c in SCORE_COLUMNS)


def discussion(result, summary: dict, sequences: list[str], methods: list[str]) -> list[str]:
    """What the numbers mean: statements checked against the summary, and the mechanisms behind them."""
    pets = sequences[0]
    synthetic = sequences[1:]

    def mota(s: str, m: str) -> float:
        return summary[(s, m)]["mota_mean"]

    lines = []
    pets_ranked = sorted(methods, key=lambda m: -mota(pets, m))
    if pets_ranked[0] in DSMT_RULES:
        negative = [m for m in methods if mota(pets, m) < 0]
        lines.append(
            f"**Where the DSmT rules win.** On the real video, with 8 people who meet and part, the best MOTA goes "
            f"to {pets_ranked[0]} ({mota(pets, pets_ranked[0]):.3f}), the next to {pets_ranked[1]} "
            f"({mota(pets, pets_ranked[1]):.3f}). " + (
                "The R-weighted rule splits each local conflict between the two hypotheses, their intersection and "
                "their union (W (11)-(14)); what lands on θ_j or on an intersection θ_j ∩ θ_k still counts in "
                "Bel(θ_j), so a particle of target j keeps more of its weight when one cue contradicts the others. "
                if pets_ranked[0] == "R-rule" else "")
            + (f"{len(negative)} methods have a negative MOTA there ({', '.join(negative)}): more misses, false "
               "boxes and identity switches than there are ground-truth boxes." if negative else ""))
    best = {s: max(methods, key=lambda m: mota(s, m)) for s in sequences}
    not_rules = [s for s in sequences if round(mota(s, best[s]), 3) > max(round(mota(s, m), 3) for m in DSMT_RULES)]
    colour_better = [s for s in synthetic if round(mota(s, "colour only"), 3) > round(mota(s, "R-rule"), 3)]
    hardest = min(sequences, key=lambda s: mota(s, best[s]))
    text = "**Where they do not.** "
    if not_rules:
        text += (f"On {', '.join(not_rules)} a method without masses is best "
                 f"({', '.join(f'{best[s]}, {mota(s, best[s]):.3f}' for s in not_rules)}). ")
    if colour_better:
        text += (f"The colour cue alone does better than the three cues fused by the R-weighted rule on "
                 f"{' and '.join(colour_better)}, probably because the synthetic people wear flat, distinct colours that "
                 "separate them on their own, while two overlapping people make one foreground blob. ")
    text += (f"The hardest sequence is {hardest}: its best MOTA is {mota(hardest, best[hardest]):.3f}. ")
    pcr6_rank = sorted(DSMT_RULES + ("Dempster",), key=lambda m: -mota(pets, m)).index("PCR6") + 1
    occlusion_best = [s for s in ("crossing", "occlusion") if best[s] == "PCR6"]
    if occlusion_best and pcr6_rank == len(DSMT_RULES) + 1:
        text += (f"PCR6 is best on {' and '.join(occlusion_best)} but the worst belief rule on PETS; this "
                 "study does not show why.")
    lines.append(text.strip())
    if same_runs(result, "DSmC", "DSmH"):
        lines.append(
            "**DSmC and DSmH give the same runs.** This is not a coincidence of the seeds. Each cue's mass function "
            "is Bayesian over {θ_1..θ_τ, FA}, so the only empty conjunctions are those of a target with the false "
            "alarm; DSmH moves their mass to θ_j ∪ FA, which is not a subset of θ_j, and Bel(θ_j), the particle "
            "weight (W (32)), is the same under both rules. (Their curves overlap in the figure of the masses.)")
    if round(mota(pets, "Dempster"), 3) < round(mota(pets, "DSmC"), 3):
        lines.append(
            "**Dempster's rule against DSmC.** Dempster's rule is the conjunctive combination divided by 1 − K, "
            "where K is the conflict of that particle's cues. The divisor differs from particle to particle, so it "
            "raises the weight of the particles whose cues disagree most; on PETS it has a lower MOTA than DSmC "
            f"({mota(pets, 'Dempster'):.3f} against {mota(pets, 'DSmC'):.3f}).")
    return lines


def render_page(experiment, result, summary: dict, sequences: list[str], methods: list[str]) -> str:
    seeds = experiment.seeds
    tracker = dict(experiment.tracker)
    parts = [
        "# Comparison study",
        "",
        "Every fusion rule and strategy of the tracker on the same sequences, with the same settings and the same "
        f"seeds: {len(sequences)} sequences × {len(methods)} methods × {len(seeds)} seeds "
        f"({len(result.results)} runs). This page, its tables and its figures are written by one command:",
        "",
        "```bash",
        "python benchmarks/comparison_study.py",
        "```",
        "",
        "It runs the grid `benchmarks/comparison.toml` with `belief experiment`'s runner (the finished runs are "
        "kept, so an interrupted study resumes), then draws the figures. The raw tables are "
        "[results.csv](results/results.csv) (one row per run), [summary.csv](results/summary.csv) (means and "
        "standard deviations over the seeds) and [rms.csv](results/rms.csv) (RMS position error per target and "
        "frame, W (36)).",
        "",
        "Equation labels such as W (33) follow the quantity they name and point to the papers listed under "
        "[References](theory.md#references).",
        "",
        "## Set-up",
        "",
        "- **Sequences.** PETS 2009 S2.L1, frames 1–200 (real video, up to 8 people), and four synthetic scenes "
        "of `belief_tracking.scenes`: `crossing` (two people cross, one fully hidden for 7 frames), "
        "`occlusion` (the `partial_occlusion` scene: a person half hidden by another, one behind a pillar), "
        "`illumination` (a global brightening, then a shadow) and `scale` (`scale_change`: people walking "
        "towards and away from the camera).",
        "- **Initialisation.** Every target is born at its first ground-truth box and removed after its last "
        "(`belief track --init-from-gt`), so the scores measure the following of targets, not their detection; "
        "the background model first learns from 50 frames, and the person blobs support and correct the tracks as "
        "they do automatic ones (with the foreground cue: `colour only` is the particle filters alone).",
        f"- **Tracker.** N = {tracker.get('particles', 100)} particles per target; every other setting is the "
        "default of `TrackerConfig` (colour, location and foreground cues; Bel(θ_j) as the particle weight, "
        "W (32); systematic resampling every frame).",
        f"- **Seeds.** {', '.join(map(str, seeds))}: the tracker's only source of randomness. A synthetic scene is "
        "rendered once, with its own fixed seed.",
        "- **Methods.** The belief rules fuse the three cues' mass functions over {θ_1..θ_τ, FA}: the R-weighted "
        "rule of the tracking paper (`r_rule`, W (7)–(10), the default), DSmC (the conjunctive rule on D^Θ, which "
        "keeps the mass of two overlapping targets on their intersection), PCR6, DSmH and Dempster's rule. The other strategies do not use masses: `adaptive` mixes the "
        "product and the sum of the cues' likelihoods with weights from each cue's confidence, tests for "
        "occlusion and updates the templates (C (11)–(16)); `sum` and `product` combine the likelihoods with "
        "equal weights or by their product. `colour only` is the R-weighted rule with the colour cue alone.",
        "- **Scores.** CLEAR MOT accuracy (MOTA) and IDF1 with IoU ≥ 0.5, the median distance between matched "
        "box centres, and the RMS of the centre error of the run over all target-frames (each target's "
        "estimate is the track with its id). Mean ± standard deviation over the seeds; the best value of each "
        "sequence is in bold. The same numbers come out of `benchmarks/accuracy_pets.py` for PETS (its "
        "`default`, `dempster`, `dsmc`, `adaptive`, `product` and `sum` configurations are the R-rule, "
        "Dempster, DSmC, adaptive, product and sum rows), and a test recomputes runs of this table.",
        "",
        "## What the numbers say",
        "",
    ]
    parts += [f"- {line}" for line in findings(summary, sequences, methods)]
    parts += ["", "![MOTA by method and sequence](results/mota.png)", "", "## Reading the results", ""]
    for line in discussion(result, summary, sequences, methods):
        parts += [line, ""]
    for metric, title, digits, higher in TABLES:
        parts += [f"## {title[0].upper() + title[1:]}", "", metric_table(summary, sequences, methods, metric, digits,
                                                                           higher), ""]
    parts += [
        "The tracking speed is of the tracker alone (decoding excluded), on whatever machine ran the study, and "
        "varies from run to run; it is the only column of `results.csv` that does.",
        "",
        "## RMS position error per target",
        "",
        "The RMS error of W (36) at each frame, over the seeds, for each target (log scale). A curve that leaves "
        "the bottom of a panel and stays high is a target lost for good; a bump that comes back is a target lost "
        "during an occlusion and found again.",
        "",
    ]
    for sequence in sequences:
        parts += [f"### {sequence}", "", f"![RMS error per target, {sequence}](results/rms_{slug(sequence)}.png)", ""]
    parts += [
        "## Mean masses and belief during an occlusion",
        "",
        "The crossing scene, seed 0: for each target, the mean over its particles of the mass on its own "
        "hypothesis θ_j (W (33)), on the intersection with the other target (W (34)), and of the belief "
        "Bel(θ_j) (W (35)), under each belief rule. Grey: the far walker (target 1) is partly hidden; dark grey: "
        "fully hidden. Under the tracking model two targets may overlap (θ_1 ∩ θ_2 is a state of its own) "
        "while the false alarm excludes every target; the rules differ in where the conflicting mass goes.",
        "",
        "![Mean masses and belief on the crossing scene](results/confidence_crossing.png)",
        "",
        "## Annotated frames",
        "",
        "The tracks of seed 0 (coloured boxes with their ids) and the ground truth (white, dashed), for the "
        f"{', '.join(STRIP_METHODS[:-1])} and {STRIP_METHODS[-1]} methods.",
        "",
    ]
    for sequence in STRIP_FRAMES:
        parts += [f"![Annotated frames, {sequence}](results/frames_{slug(sequence)}.jpg)", ""]
    return "\n".join(parts)


if __name__ == "__main__":
    sys.exit(main())
