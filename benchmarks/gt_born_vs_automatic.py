"""GT-born against automatic tracks: MOTA, IDF1 and HOTA on every built-in scene and on PETS09-S2L1 (issue 27).

Run from the repository root::

    python benchmarks/gt_born_vs_automatic.py                    # every preset and PETS, seed 0
    python benchmarks/gt_born_vs_automatic.py --seeds 0 1 2      # the mean over seeds
    python benchmarks/gt_born_vs_automatic.py --sequences demo crossing --no-pets
    python benchmarks/gt_born_vs_automatic.py --check            # exit 1 where GT-born scores below automatic

A *GT-born* run is ``belief track VIDEO --init-from-gt gt.txt``: every ground-truth id is
born at its first box and removed after its last.  An *automatic* run is ``belief track
VIDEO``: the tracks start and end on their own (SPEC B.4) after the background model has
learnt from 50 frames.  Both use the default settings (N = 100 particles, the R-weighted
rule, colour + location + foreground) and run as cells of ``belief experiment``
(:func:`belief_tracking.runs.run_cell`), scored by
``belief_tracking.evaluation.evaluate(gt, tracks)`` (IoU >= 0.5), so their figures are those of
the comparison study for the same settings and seeds.  Knowing the births and deaths is
more information than the automatic run has: the GT-born MOTA should be at least the
automatic one on every sequence (``--check`` says where it is not).

The scenes are the presets of ``belief_tracking.scenes.PRESETS`` rendered with scene seed 0;
the PETS sequence is looked for in ``shared/data/pets09_s2l1_f0001_0200`` next to the
repository (without it, it is skipped).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from belief_tracking.experiment import Cell, MethodSpec, SequenceSpec  # noqa: E402
from belief_tracking.runs import run_cell  # noqa: E402
from belief_tracking.scenes import PRESETS  # noqa: E402

DEFAULT_DATA = ROOT.parent / "shared" / "data" / "pets09_s2l1_f0001_0200"
PETS = "pets09_s2l1"
INITS = ("gt", "automatic")


def sequence(name: str, init: str, data: Path) -> SequenceSpec:
    """A scene preset, or the PETS clip, tracked from the ground truth's births (``gt``) or automatically."""
    if name == PETS:
        return SequenceSpec("PETS09 S2.L1", video=str(data / "video.avi"), gt=str(data / "gt.txt"), init=init)
    return SequenceSpec(name, scene=name, init=init)


def score(name: str, init: str, seed: int, particles: int, data: Path, rule: str | None) -> dict:
    options = {} if rule is None else ({"fusion": "adaptive"} if rule == "adaptive" else {"belief": {"rule": rule}})
    cell = Cell(sequence(name, init, data), MethodSpec.from_mapping(rule or "default", options), seed,
                (("particles", particles),))
    row = run_cell(cell)["row"]
    return {"name": name, "init": init, "seed": seed, "mota": row["mota"], "idf1": row["idf1"],
            "hota": row["hota"], "id_switches": row["id_switches"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sequences", nargs="+", default=[*PRESETS, PETS], choices=[*PRESETS, PETS], metavar="NAME",
                        help=f"sequences to run, of: {', '.join([*PRESETS, PETS])}")
    parser.add_argument("--no-pets", action="store_true", help="leave out the PETS sequence")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0])
    parser.add_argument("--particles", type=int, default=100)
    parser.add_argument("--rule", default=None,
                        help="a belief rule (pcr6, dempster, ...) or 'adaptive' instead of the default fusion")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--check", action="store_true", help="exit 1 if a GT-born MOTA is below the automatic one")
    args = parser.parse_args(argv)
    names = [n for n in dict.fromkeys(args.sequences) if not (n == PETS and args.no_pets)]
    if PETS in names and not ((args.data / "video.avi").is_file() and (args.data / "gt.txt").is_file()):
        print(f"PETS sequence not found in {args.data}: skipped")
        names.remove(PETS)
    jobs = [(name, init, seed, args.particles, args.data, args.rule)
            for name in names for init in INITS for seed in args.seeds]
    with ProcessPoolExecutor(max(1, args.jobs)) as pool:
        results = list(pool.map(score, *zip(*jobs)))
    print(f"N = {args.particles}, fusion {args.rule or 'default'}, seeds {args.seeds} (means over the seeds)")
    print(f"{'sequence':<18} {'GT-born MOTA':>12} {'automatic MOTA':>14} {'GT-born IDF1':>12} "
          f"{'automatic IDF1':>14} {'GT-born HOTA':>12} {'automatic HOTA':>14} {'GT-born ID sw':>13} "
          f"{'auto ID sw':>10}")
    below = []
    for name in names:
        mean = {(init, key): statistics.fmean(r[key] for r in results if r["name"] == name and r["init"] == init)
                for init in INITS for key in ("mota", "idf1", "hota", "id_switches")}
        print(f"{name:<18} {mean['gt', 'mota']:>12.3f} {mean['automatic', 'mota']:>14.3f} "
              f"{mean['gt', 'idf1']:>12.3f} {mean['automatic', 'idf1']:>14.3f} "
              f"{mean['gt', 'hota']:>12.3f} {mean['automatic', 'hota']:>14.3f} "
              f"{mean['gt', 'id_switches']:>13.1f} {mean['automatic', 'id_switches']:>10.1f}", flush=True)
        if mean["gt", "mota"] < mean["automatic", "mota"]:
            below.append(name)
    if below:
        print(f"GT-born MOTA below the automatic one on: {', '.join(below)}")
    return 1 if (args.check and below) else 0


if __name__ == "__main__":
    sys.exit(main())
