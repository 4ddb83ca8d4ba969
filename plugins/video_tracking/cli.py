"""The ``belief track`` subcommand (entry point ``belief.commands``: ``track``).

``belief track VIDEO --out DIR [options]`` tracks a video: with no init file the tracks are
started and ended automatically from the background model (SPEC B.4); ``--init BOXES``
gives the targets of the first frame (later entries are still found automatically);
``--init-from-gt GT.txt`` takes every birth and death from a ground truth and scores the
tracks against it.  ``belief track --demo --out DIR`` renders the synthetic demo scene,
tracks it from its ground truth and prints the scores.  Bad input raises a
:class:`~plugins.video_tracking.errors.TrackingError`, which the ``belief`` command line
reports in one line with exit status 1.
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["register", "AUTOMATIC_WARM_UP"]

#: Frames the background model learns from before an automatic run (``--warm-up``).
AUTOMATIC_WARM_UP = 50


def _cues(text: str) -> tuple[str, ...]:
    return tuple(name.strip() for name in text.split(",") if name.strip())


def _cmd_track(args: argparse.Namespace) -> int:
    from plugins.video_tracking import scenes
    from plugins.video_tracking.errors import TrackingError
    from plugins.video_tracking.initiation import InitiationConfig
    from plugins.video_tracking.tracker import TrackerConfig, init_from_gt, read_init_boxes, run

    if args.particles is not None and args.particles < 1:
        raise TrackingError(f"--particles must be a positive integer, got {args.particles}")
    if args.seed < 0:
        raise TrackingError(f"--seed must be a non-negative integer, got {args.seed}")
    options: dict[str, Any] = {}
    if args.particles is not None:
        options["particles"] = args.particles
    if args.cues is not None:
        options["cues"] = _cues(args.cues)
    if args.rule is not None:
        options["rule"] = args.rule
    if args.weight is not None:
        options["weight"] = args.weight
    if args.fusion is not None:
        options["fusion"] = args.fusion
    if args.adaptive_particles:
        options["adaptive_particles"] = True
    if args.warm_up is not None:
        if args.warm_up < 0:
            raise TrackingError(f"--warm-up must be a non-negative integer, got {args.warm_up}")
        options["warm_up"] = args.warm_up
    automatic = not args.demo and args.init_from_gt is None
    if automatic:
        # Without an init file every track starts from the background model, which must know
        # the background before the first frame; with one, only later entries are added.
        options["initiation"] = InitiationConfig(first_frame=args.init is None)
        options.setdefault("warm_up", AUTOMATIC_WARM_UP)
    config = TrackerConfig(**options)
    progress = not args.no_progress

    if args.demo:
        if args.video is not None or args.init_from_gt is not None or args.init is not None or args.gt is not None:
            raise TrackingError("--demo takes no VIDEO, --init, --init-from-gt or --gt")
        scene = scenes.render(scenes.demo(args.seed))
        gt = scene.ground_truth
        extra = {"gt.txt": lambda path: scenes.write_gt(path, gt),
                 "scene.avi": lambda path: scenes.write_video(path, scene)}
        summary = run(scene, init_from_gt(gt, source="demo scene ground truth"), config, args.out, args.seed,
                      write_video=not args.no_video, progress=progress, gt=gt, extra_outputs=extra)
    else:
        if args.video is None:
            raise TrackingError("give a VIDEO to track, or --demo")
        plan, gt = None, args.gt
        if args.init_from_gt is not None:
            plan = init_from_gt(args.init_from_gt)
            gt = gt if gt is not None else args.init_from_gt
        elif args.init is not None:
            plan = read_init_boxes(args.init)
        summary = run(args.video, plan, config, args.out, args.seed, write_video=not args.no_video,
                      progress=progress, gt=gt)
    print(f"tracked {summary.frames} frames: {summary.tracking_fps:.1f} fps tracking, "
          f"{summary.overall_fps:.1f} fps overall; outputs in {args.out}")
    if summary.scores is not None:
        s = summary.scores
        print(f"MOTA {s.mota:.4f}  IDF1 {s.idf1:.4f}  ID switches {s.id_switches}  "
              f"centre error mean {s.mean_centre_error:.2f} px, median {s.median_centre_error:.2f} px")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``track`` subcommand to a ``belief`` sub-parser collection.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="belief")
    >>> register(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["track", "v.avi", "--init", "boxes.csv", "--out", "o", "--particles", "30"])
    >>> args.video, args.init, args.particles, args.seed
    ('v.avi', 'boxes.csv', 30, 0)
    """
    p = subparsers.add_parser(
        "track", help="track people in a video with the DSmT multi-cue particle filter",
        description="Track targets in a video: one particle filter per target, each particle weighted by "
                    "fusing colour, location, foreground and edge cues over {t1..tN, FA} with a belief-function "
                    "rule (or the adaptive, sum or product fusion). Without an init file, tracks start on "
                    "foreground blobs entering the image and end when they leave. Writes tracks.txt "
                    "(MOTChallenge), diagnostics.csv, diagnostics.png, annotated.avi and summary.json into "
                    "--out. With --demo, renders a synthetic scene, tracks it from its ground truth and prints "
                    "the scores.")
    p.add_argument("video", nargs="?", metavar="VIDEO", help="the video file to track")
    init = p.add_mutually_exclusive_group()
    init.add_argument("--init-from-gt", metavar="GT.txt",
                      help="MOTChallenge ground truth: each id is born at its first box and removed after its last "
                           "(the tracks are also scored against it)")
    init.add_argument("--init", metavar="BOXES",
                      help="CSV of id,x,y,w,h lines (1-based corner, as in MOT files): targets of the first frame; "
                           "people entering later are found automatically")
    p.add_argument("--demo", action="store_true", help="track the embedded synthetic demo scene")
    p.add_argument("--gt", metavar="GT.txt", help="MOTChallenge ground truth to score the tracks against "
                                                  "(implied by --init-from-gt)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument("--particles", type=int, metavar="N", help="particles per target (default 100)")
    p.add_argument("--cues", metavar="LIST", help="comma-separated cues in fusion order, of colour, location, "
                                                  "foreground, edges (default colour,location,foreground)")
    p.add_argument("--fusion", choices=["belief", "adaptive", "sum", "product"],
                   help="how the cues weigh a particle: belief (the rule of --rule, default), adaptive "
                        "(confidence-weighted product/sum mix with occlusion detection and template update), "
                        "sum or product")
    p.add_argument("--rule", metavar="RULE", help="combination rule of --fusion belief (default r_rule; "
                                                  "see 'belief rules')")
    p.add_argument("--weight", choices=["bel", "pls", "betp"], help="particle weight (default bel)")
    p.add_argument("--adaptive-particles", action="store_true",
                   help="adapt each target's particle count to the conflict between its cues (at most --particles)")
    p.add_argument("--warm-up", type=int, metavar="N",
                   help=f"frames spread over the video that the background model learns from first "
                        f"(default {AUTOMATIC_WARM_UP} without an init file, else 0)")
    p.add_argument("--no-video", action="store_true", help="do not write annotated.avi")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_track)
