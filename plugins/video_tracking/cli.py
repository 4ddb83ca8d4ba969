"""The plugin's ``belief`` subcommands: ``track``, ``eval`` and ``experiment`` (entry points ``belief.commands``).

``belief track SOURCE --out DIR [options]`` tracks a video file, a folder of images, an
image pattern (``img1/%06d.jpg``) or a MOTChallenge sequence folder
(:func:`~belief_tracking.sources.open_source`); ``--detections DET.txt`` adds a
detector's boxes (a MOTChallenge detection file).  With no init file the tracks are
started, lost, found again and ended automatically from the detections, or from the
person blobs of the background model without them; ``--init BOXES``
gives the targets of the first frame (later entries are still found automatically);
``--init-from-gt GT.txt`` takes every birth and death from a ground truth (the tracks
still learn the background and follow the person blobs, or the detections, as automatic
ones do) and scores the tracks against it; a MOTChallenge sequence folder is scored against its own ground truth
(``gt/gt.txt``, :func:`~belief_tracking.sources.sequence_ground_truth`) when no ``--gt`` is
given.  ``belief track --demo --out DIR`` renders the synthetic demo scene,
tracks it automatically (the ground truth is not given to the tracker) and prints the
scores against its ground truth.  ``--set KEY=VALUE`` reaches every
setting of :class:`~belief_tracking.config.TrackerConfig`.

``belief eval TRACKS.txt GT.txt`` scores tracks (a run's output folder and a sequence folder
stand for their files); ``belief experiment GRID.toml`` runs a grid of seeded runs.  With
``--json`` each command prints its results as one JSON object; ``-q`` (``args.quiet``) leaves
out the progress bars, notes and announcements, ``-v`` (``args.verbose``) adds the settings
in effect (the ``belief`` command line gives every command both).  Every value is checked
here or in the settings dataclasses; bad input raises a
:class:`~belief_tracking.errors.TrackingError`, which the ``belief`` command line reports in
one line with exit status 1.  ``belief track`` also exits with
status 1, after writing the outputs of the frames it decoded, when a video decodes fewer
frames than its container announces; SIGTERM ends it as Ctrl-C does, deleting the files it
was writing (exit status 143).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import re
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from .defaults import AUTOMATIC_WARM_UP
from .extras import require
from .labels import LABELS_NOTE

__all__ = ["register", "register_eval", "register_experiment", "AUTOMATIC_WARM_UP", "parse_setting"]

#: The line printed under the scores of a run that has a ground truth.
SCORES_EXPLAINED = ("(MOTA: 1 minus the missed people, false boxes and identity switches per ground-truth box; "
                    "IDF1: the share of boxes on the right person with the right id; a box counts for both when it "
                    "overlaps its person by IoU >= 0.5; HOTA: the geometric mean of detection and association "
                    "accuracy, averaged over IoU thresholds 0.05 to 0.95; 1 is perfect for all three)")


def _quiet(args: argparse.Namespace) -> bool:
    """-q of the ``belief`` command line (a parser without it, as in the doctests, is not quiet)."""
    return bool(getattr(args, "quiet", False))


def _verbose(args: argparse.Namespace) -> bool:
    """-v of the ``belief`` command line."""
    return bool(getattr(args, "verbose", 0)) and not _quiet(args)


def _say(args: argparse.Namespace, line: str, *, detail: bool = False) -> None:
    """A line on standard error, ``belief COMMAND: line``: left out with -q, and a ``detail`` only printed with -v."""
    if _quiet(args) or (detail and not _verbose(args)):
        return
    text = " ".join(line.splitlines())
    print(f"belief {getattr(args, 'command', None) or 'track'}: {text}", file=sys.stderr, flush=True)


def _json_ready(value: Any) -> Any:
    """``value`` with NaN and infinities as None and numpy numbers as Python ones, for :func:`json.dumps`."""
    import math

    import numpy as np

    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Path):
        return str(value)
    return value


def _print_json(data: Any) -> None:
    print(json.dumps(_json_ready(data), indent=2, ensure_ascii=False))



def _cues(text: str) -> tuple[str, ...]:
    return tuple(name.strip() for name in text.split(",") if name.strip())


def _integer(minimum: int):
    """An argparse type: an integer of at least ``minimum`` (a bad value is a command-line error)."""
    def parse(text: str) -> int:
        from .limits import clipped

        # Strictly digits (int() also takes "1_0" and other scripts' digits), and below 2^63.
        if not _INTEGER.fullmatch(text.strip()):
            raise argparse.ArgumentTypeError(f"must be an integer, got {clipped(repr(text))}")
        if len(text.strip().lstrip("+-")) > 19 or abs(int(text)) >= 2 ** 63:
            raise argparse.ArgumentTypeError(f"must be an integer below 2**63, got {clipped(text.strip())}")
        value = int(text)
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, got {value}")
        return value
    return parse


_INTEGER = re.compile(r"[+-]?[0-9]+")


def parse_setting(text: str) -> tuple[list[str], Any]:
    """``KEY=VALUE`` of ``--set``: a dotted key path and a TOML value (bare words are text).

    Examples
    --------
    >>> parse_setting("belief.masses=normalised")
    (['belief', 'masses'], 'normalised')
    >>> parse_setting("location.sigma=8")
    (['location', 'sigma'], 8)
    >>> parse_setting("cues=['colour', 'edges']")
    (['cues'], ['colour', 'edges'])
    """
    from . import limits
    from .errors import TrackingError

    key, separator, value = text.partition("=")
    path = [part.strip() for part in key.split(".")]
    if not separator or not all(path):
        raise TrackingError(f"--set takes KEY=VALUE (e.g. belief.masses=normalised or location.sigma=8), "
                            f"got {limits.clipped(repr(text))}")
    return path, limits.toml_value(value, f"--set {limits.clipped(text)}")


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    """The TrackerConfig settings of the command line: ``--set`` values, then the dedicated flags."""
    from .errors import TrackingError

    options: dict[str, Any] = {}
    for text in args.set or ():
        path, value = parse_setting(text)
        table = options
        for part in path[:-1]:
            table = table.setdefault(part, {})
            if not isinstance(table, dict):
                raise TrackingError(f"--set {text}: {part} is not a table of settings")
        table[path[-1]] = value
    flags = {"particles": args.particles, "fusion": args.fusion, "warm_up": args.warm_up,
             "diagnostics": args.diagnostics}
    options.update({key: value for key, value in flags.items() if value is not None})
    belief = {key: value for key, value in (("rule", args.rule), ("weight", args.weight)) if value is not None}
    if belief:
        table = options.get("belief")
        options["belief"] = {**(table if isinstance(table, dict) else {}), **belief}
    if args.cues is not None:
        options["cues"] = _cues(args.cues)
    if args.adaptive_particles:
        options["adaptive_particles"] = True
    if args.template_update:
        options["template_update"] = True
    automatic = args.init_from_gt is None
    if automatic and options.get("initiation") is not False:
        # Without an init file every track starts from the background model, which must know
        # the background before the first frame; with one, only later entries are added.  (The
        # births and deaths of a ground truth are followed as run() does, runner.run_config.)
        table = options.get("initiation")
        table = dict(table) if isinstance(table, dict) else {}
        table.setdefault("first_frame", args.init is None)
        options["initiation"] = table
        options.setdefault("warm_up", AUTOMATIC_WARM_UP)
    return options


def _detections(args: argparse.Namespace, frame_count: int | None, width: int, height: int):
    from .detections import read_detections

    if args.detections is None:
        return None
    return read_detections(args.detections, frame_count=frame_count, image_size=(width, height))


#: The exit status of a run ended by SIGTERM (128 + the signal's number, as a shell reports it).
TERMINATED_STATUS = 128 + 15


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread as an interruption, so that a run deletes its staged files."""

    #: True when the signal came after the run had put all its files in place (only the report was left).
    files_complete = False


@contextlib.contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """Turn SIGTERM into :class:`_Terminated` while the block runs (only in the main thread)."""
    def handler(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_IGN)   # a second SIGTERM must not cut the clean-up short
        raise _Terminated()

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: signals are not ours to handle
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _output_dir(text: str | None, option: str = "--out") -> None:
    from .errors import TrackingError

    if text is not None and not text.strip():
        raise TrackingError(f"{option} must name a folder, got an empty path (use {option} . for the working "
                            "folder)")


def _cmd_track(args: argparse.Namespace) -> int:
    """``belief track``: SIGTERM ends it as Ctrl-C does, with no staged file left behind."""
    from . import limits

    try:
        with _sigterm_interrupts(), limits.applied(limits.given(args)):
            return _track(args)
    except _Terminated as stop:
        if stop.files_complete:
            print(f"belief: terminated (SIGTERM) after the run had written all its files to {args.out}",
                  file=sys.stderr)
        else:
            print(f"belief: terminated (SIGTERM); nothing of this run was left in {args.out}", file=sys.stderr)
        return TERMINATED_STATUS


def _track(args: argparse.Namespace) -> int:
    from .config import TrackerConfig

    _output_dir(args.out)
    config = TrackerConfig.from_settings(_settings(args), "the tracker's settings")
    if args.demo:
        _demo_arguments(args)
    found = None if args.demo else _sequence_gt(args)
    out = _track_output(args, found)
    try:
        if args.demo:
            summary, args.scored_against = _track_demo(args, config, out)
        else:
            summary, args.scored_against = _track_source(args, config, out, found)
        _report(args, summary)
    except BaseException as exc:
        out.abort()
        if isinstance(exc, _Terminated):
            exc.files_complete = out.committed
        raise
    return 0


#: The files ``belief track --demo`` writes besides a run's own.
DEMO_OUTPUTS = ("gt.txt", "scene.avi")


def _track_output(args: argparse.Namespace, found: Path | None = None):
    """The output folder of ``belief track``, checked against every input (``found``: the sequence's ground truth)
    before any work."""
    from .outdir import OutputFolder, input_paths
    from .runner import output_names

    names = output_names(write_video=not args.no_video, extra=DEMO_OUTPUTS if args.demo else ())
    inputs = input_paths(args.source, args.init, args.init_from_gt, args.gt, args.detections,
                         getattr(args, "settings", None), found)
    return OutputFolder(args.out, names, inputs=inputs, force=args.force)


def _sequence_gt(args: argparse.Namespace) -> Path | None:
    """The ground truth of a MOTChallenge sequence folder given as SOURCE, when no other is given (None else)."""
    from .sources import sequence_ground_truth

    if args.source is None or args.gt is not None or args.init_from_gt is not None:
        return None
    return sequence_ground_truth(args.source)


def _demo_arguments(args: argparse.Namespace) -> None:
    from .errors import TrackingError

    if args.source is not None or args.init_from_gt is not None or args.init is not None or args.gt is not None:
        raise TrackingError("--demo takes no SOURCE, --init, --init-from-gt or --gt")


def _announce(line: str) -> None:
    print(f"belief track: {line}", file=sys.stderr, flush=True)


def _announcer(args: argparse.Namespace):
    """Where a run's announcements go: standard error, or nowhere with -q."""
    return None if _quiet(args) else _announce


def _progress(args: argparse.Namespace) -> bool:
    return not args.no_progress and not _quiet(args)


def _track_details(args: argparse.Namespace, config, frames, init: str, detections, gt) -> None:
    """What ``belief track -v`` says before the run: the source, the tracker's settings, the inputs in effect."""
    from .limits import clipped
    from .sources import sequence_detections

    if not _verbose(args):
        return
    count = f"{frames.count:,} frames" if frames.count else "frames (count unknown)"
    _say(args, f"source {clipped(frames.name)}: {frames.kind}, {count} of {frames.width}x{frames.height} at "
               f"{frames.fps:g} fps", detail=True)
    fusion = f"belief fusion ({config.describe()})" if config.fusion == "belief" else config.describe()
    _say(args, f"tracker: {fusion}, {config.particles} particles, cues "
               f"{', '.join(config.cues)}, warm-up {config.warm_up} frames, seed {args.seed}"
               f"{', adaptive particles' if config.adaptive_particles else ''}"
               f"{', template update' if config.template_update else ''}", detail=True)
    given = _settings(args)
    if given:
        _say(args, f"settings that differ from TrackerConfig's defaults: "
                   f"{json.dumps(_json_ready(given), ensure_ascii=False)}", detail=True)
    _say(args, f"initiation: {init}", detail=True)
    if detections is not None:
        boxes = sum(len(detections.at(f)) for f in detections.frames)
        _say(args, f"detections: {clipped(detections.source)}, {boxes:,} boxes on {len(detections):,} frames",
             detail=True)
    else:
        public = sequence_detections(args.source) if args.source is not None else None
        hint = f" (the sequence's {clipped(public)} is used only with --detections {clipped(public)})" \
            if public is not None else ""
        _say(args, f"detections: none{hint}", detail=True)
    _say(args, f"ground truth: {clipped(gt)}" if gt is not None else "ground truth: none (the tracks are not scored)",
         detail=True)


def _track_demo(args: argparse.Namespace, config, out):
    """``belief track --demo``: the demo scene, tracked automatically and scored against its ground truth."""
    from . import scenes
    from .runner import run

    scene = scenes.render(scenes.demo(args.seed))
    gt = scene.ground_truth
    height, width = scene.frames.shape[1:3]
    detections = _detections(args, len(scene), width, height)
    extra = {"gt.txt": lambda path: scenes.write_gt(path, gt, visibility=scene.visibility),
             "scene.avi": lambda path: scenes.write_video(path, scene)}
    if _verbose(args):
        from .sources import open_source

        how = "detections" if detections is not None else "foreground blobs"
        _track_details(args, config, open_source(scene), f"automatic, from {how}; the demo's ground truth only "
                       "scores the tracks", detections, "the demo scene's own (written as gt.txt)")
    # The tracker finds the people itself, as on a user's video; the ground truth only scores it.
    summary = run(scene, None, config, out, args.seed, write_video=not args.no_video, progress=_progress(args),
                  gt=gt, extra_outputs=extra, detections=detections, announce=_announcer(args))
    return summary, str(Path(args.out) / "gt.txt")


def _track_source(args: argparse.Namespace, config, out, found: Path | None = None):
    """``belief track SOURCE``: with an init file, a ground truth's births and deaths, or neither; ``found`` is the
    ground truth of a sequence folder, which scores the tracks when no other is given."""
    from .errors import TrackingError
    from .initiation import init_from_gt, read_init_boxes
    from .limits import clipped
    from .runner import run, run_config
    from .sources import open_source

    if args.source is None:
        raise TrackingError("give a SOURCE to track (a video, a folder of images, an image pattern or a "
                            "MOTChallenge sequence folder), or --demo")
    plan, gt = None, args.gt
    if args.init_from_gt is not None:
        plan = init_from_gt(args.init_from_gt)
        gt = gt if gt is not None else args.init_from_gt
    elif args.init is not None:
        plan = read_init_boxes(args.init)
    frames = open_source(args.source)
    try:
        # The detection file is checked against the source's length and size, naming its lines.
        detections = _detections(args, frames.count, frames.width, frames.height)
        if gt is None and found is not None:
            from .motfiles import check_ground_truth, read_mot

            gt = str(found)
            # Read before it is named, so that a bad file is the only line printed.
            check_ground_truth(read_mot(gt, what="ground-truth file"), frames.count, gt)
            _say(args, f"{clipped(args.source)} is a MOTChallenge sequence: the tracks are scored against its ground "
                       f"truth {clipped(gt)} (--gt FILE scores them against another)")
        if args.init_from_gt is not None:
            init = f"the births and deaths of {clipped(args.init_from_gt)}"
        elif args.init is not None:
            init = f"the boxes of {clipped(args.init)} on the first frame, later entries automatic"
        else:
            init = f"automatic, from {'the detections' if detections is not None else 'foreground blobs'}"
        _track_details(args, config if plan is None else run_config(config, plan), frames, init, detections, gt)
    except BaseException:
        frames.close()
        raise
    summary = run(frames, plan, config, out, args.seed, write_video=not args.no_video, progress=_progress(args),
                  gt=gt, detections=detections, announce=_announcer(args))
    return summary, gt


def _report(args: argparse.Namespace, summary) -> None:
    """Print the run's speed and scores (as one JSON object with --json; ``args.scored_against`` names the ground
    truth that scored it); a video that decoded fewer frames than announced is then an error."""
    from .errors import VideoError

    if getattr(args, "json", False):
        _print_json(track_summary(summary, source=args.source if not args.demo else "demo", out=args.out,
                                  gt=getattr(args, "scored_against", None)))
    else:
        written = ", ".join(path.name for path in summary.files.values())
        print(f"tracked {summary.frames} frames: {summary.tracking_fps:.1f} fps tracking, "
              f"{summary.overall_fps:.1f} fps overall; outputs in {args.out}: {written}")
        if summary.scores is not None:
            s = summary.scores
            print(f"MOTA {s.mota:.4f}  IDF1 {s.idf1:.4f}  HOTA {s.hota:.4f}  ID switches {s.id_switches}  "
                  f"centre error mean {s.mean_centre_error:.2f} px, median {s.median_centre_error:.2f} px")
            if not _quiet(args):
                print(SCORES_EXPLAINED)
    if not summary.complete:
        # The outputs of the decoded frames are kept, but the run did not track the whole video.
        raise VideoError(f"{args.source}: decoded {summary.frames} of the {summary.expected_frames} frames the "
                         f"file announces (truncated or corrupt after frame {summary.frames}); the outputs of "
                         f"those {summary.frames} frames are in {args.out}")


def track_summary(summary, *, source: str | None, out: str, gt: str | None) -> dict[str, Any]:
    """What ``belief track --json`` prints: the run's counts, speed, scores and files, ready for :func:`json.dumps`.

    Keys: ``source``, ``out``, ``frames``, ``expected_frames``, ``complete``, ``tracks`` (distinct ids), ``boxes``
    (rows of tracks.txt), ``tracking_fps``, ``overall_fps``, ``gt`` (the ground truth that scored the tracks, or
    None), ``scores`` (those of ``belief eval --json``, or None) and ``files`` (name to path).
    """
    tracks = summary.tracks
    data = {"source": source, "out": str(out), **summary.to_dict(), "gt": gt}
    data["tracks"] = int(len(set(tracks[:, 1].tolist()))) if len(tracks) else 0
    data["boxes"] = int(len(tracks))
    order = ("source", "out", "frames", "expected_frames", "complete", "tracks", "boxes", "tracking_fps",
             "overall_fps", "gt", "scores", "files")
    return _json_ready({key: data[key] for key in order})


#: The description of ``belief track --help``.
TRACK_DESCRIPTION = ("Track targets in a video (a video file, a folder of images, an image pattern such as "
                     "img1/%06d.jpg, or a MOTChallenge sequence folder with its seqinfo.ini): one particle filter "
                     "per target, each particle weighted by "
                     "fusing colour, location, foreground and edge cues over {t1..tN, FA} with a belief-function "
                     "rule (or the adaptive, sum or product fusion). Without an init file, tracks start on "
                     "detections (--detections) or foreground blobs that persist, are hidden while nothing supports "
                     "them, take back their id when they are seen again, and end when they leave. Writes tracks.txt "
                     "(MOTChallenge), diagnostics.csv, diagnostics.png (the diagnostics over the frames), "
                     "tracks.png (every track's path over a frame of the video), annotated.avi and summary.json "
                     "into --out (each written under a temporary name and renamed), and removes the files of an earlier "
                     "run there that this run does not write. It refuses to start when --out is, lies inside or "
                     "holds one of its inputs, or holds files that no run wrote there (a hidden list, "
                     ".belief-outputs.json, names the files runs wrote) unless --force. With --demo, "
                     "renders a synthetic scene, tracks it automatically and prints its scores against the scene's "
                     "ground truth. Exit status: 0 when the whole source was tracked; 1 on bad input (one line "
                     "on standard error, no output left), or when a video decodes fewer frames than its container "
                     "announces (truncated or corrupt: the outputs of the decoded frames are kept, and the line "
                     "says how many frames of how many); 143 when ended by SIGTERM and 130 by Ctrl-C, with no "
                     "output of the run left.")


def register(subparsers: Any) -> None:
    """Add the ``track`` subcommand to a ``belief`` sub-parser collection.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="belief")
    >>> register(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["track", "v.avi", "--init", "boxes.csv", "--out", "o", "--particles", "30"])
    >>> args.source, args.init, args.particles, args.seed, args.detections
    ('v.avi', 'boxes.csv', 30, 0, None)
    """
    p = subparsers.add_parser("track", help="track people in a video with the DSmT multi-cue particle filter",
                              description=TRACK_DESCRIPTION, epilog=LABELS_NOTE + ".")
    _add_track_inputs(p)
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--seed", type=_integer(0), default=0, metavar="S", help="random seed (default 0)")
    _add_tracker_settings(p)
    p.add_argument("--no-video", action="store_true", help="do not write annotated.avi")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true",
                   help="print the run's summary (counts, speed, scores, files) as one JSON object")
    p.add_argument("--force", action="store_true",
                   help="write into --out even if it holds files that no run wrote there: those of the run's file "
                        "names are replaced, the others left (never when --out holds an input)")
    from . import limits

    limits.add_options(p)
    p.set_defaults(func=_cmd_track)


def _add_track_inputs(p: argparse.ArgumentParser) -> None:
    """``belief track``'s inputs: the source, its init, detections and ground truth."""
    p.add_argument("source", nargs="?", metavar="SOURCE",
                   help="what to track: a video file; a folder of images (.jpg, .png, .bmp, .tif, ..., taken in "
                        "the order of their names); an image pattern such as img1/%%06d.jpg (from number 0 or 1 "
                        "to the first missing file); or a MOTChallenge sequence folder (with seqinfo.ini)")
    init = p.add_mutually_exclusive_group()
    init.add_argument("--init-from-gt", metavar="GT.txt",
                      help="MOTChallenge ground truth: each id is born at its first box and removed after its last, "
                           "and no other track starts or ends (its tracks still follow the person blobs or "
                           "detections, and are lost and found again as automatic ones are); the tracks are also "
                           "scored against it")
    init.add_argument("--init", metavar="BOXES",
                      help="CSV of id,x,y,w,h lines (1-based corner, as in MOT files): targets of the first frame; "
                           "people entering later are found automatically")
    p.add_argument("--demo", action="store_true", help="track the embedded synthetic demo scene")
    p.add_argument("--detections", metavar="DET.txt",
                   help="a detector's boxes, MOTChallenge detection file: frame,-1,x,y,w,h,score,... per line "
                        "(1-based corner, score in [0, 1]); a MOTChallenge sequence has its public detections at "
                        "SEQ/det/det.txt, which are used only when given here. The boxes start, support and "
                        "correct the tracks; add 'detections' to --cues to fuse them as a cue as well")
    p.add_argument("--gt", metavar="GT.txt", help="MOTChallenge ground truth to score the tracks against "
                                                  "(implied by --init-from-gt; without either, a MOTChallenge "
                                                  "sequence SOURCE is scored against its own gt/gt.txt)")


def _add_tracker_settings(p: argparse.ArgumentParser) -> None:
    """``belief track``'s tracker settings: the dedicated flags, then ``--set`` for any other."""
    p.add_argument("--particles", type=_integer(1), metavar="N", help="particles per target (default 100)")
    p.add_argument("--cues", metavar="LIST", help="comma-separated cues in fusion order, of colour, location, "
                                                  "foreground, edges (default colour,location,foreground)")
    p.add_argument("--fusion", choices=["belief", "adaptive", "sum", "product"],
                   help="how the cues weigh a particle: belief (the rule of --rule, default), adaptive "
                        "(confidence-weighted product/sum mix with occlusion detection and template update), "
                        "sum or product")
    p.add_argument("--rule", metavar="RULE", help="combination rule of --fusion belief (default r_rule; "
                                                  "see 'belief rules')")
    p.add_argument("--weight", choices=["bel", "pls", "betp"], help="particle weight (default bel)")
    p.add_argument("--template-update", action="store_true",
                   help="let the appearance templates follow their targets (the template update of C (16)), frozen "
                        "under occlusion; the adaptive fusion always does")
    p.add_argument("--adaptive-particles", action="store_true",
                   help="adapt each target's particle count to the conflict between its cues (at most --particles)")
    p.add_argument("--warm-up", type=_integer(0), metavar="N",
                   help=f"frames spread over the video that the background model learns from first "
                        f"(default {AUTOMATIC_WARM_UP} where the foreground is read: automatic tracks, "
                        f"or the foreground cue)")
    p.add_argument("--diagnostics", choices=["strategy", "all"],
                   help="diagnostics.csv columns: those of the running parts (default), or all of them, whatever "
                        "the fusion (the mean masses and belief of W (33)-(35), the feature confidences of C (13), the "
                        "total similarity of C (15))")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="any tracker setting, e.g. --set belief.masses=normalised, --set location.literal=true, "
                        "--set adaptive_fusion.mix_norm=raw (repeatable; values in TOML syntax)")


# -- belief eval -----------------------------------------------------------------------------------
def _cmd_eval(args: argparse.Namespace) -> int:
    from .evaluation import evaluate
    from .motfiles import read_mot

    tracks_file, gt_file, notes = _eval_files(args)
    # A run that found nobody writes an empty tracks.txt: it scores as missing every box.
    tracks = read_mot(tracks_file, allow_empty=True, what="tracks file")
    gt = read_mot(gt_file, what="ground-truth file")
    for line in notes:      # once both files are read: a bad one is the only line printed
        _say(args, line)
    _say(args, f"{len(tracks):,} boxes of {len(set(tracks[:, 1].tolist())) if len(tracks) else 0:,} tracks against "
               f"{len(gt):,} ground-truth boxes of {len(set(gt[:, 1].tolist())):,} ids", detail=True)
    scores = evaluate(gt, tracks)
    if args.json:
        print(json.dumps(scores.to_dict(), indent=2))
    else:
        print(scores.format_table())
    return 0


def _eval_files(args: argparse.Namespace) -> tuple[str, str, list[str]]:
    """The files ``belief eval`` reads, and the notes that name them: a run's output folder stands for its tracks.txt,
    and a MOTChallenge sequence folder for its ground truth (gt/gt.txt)."""
    import os

    from .errors import TrackFileError
    from .limits import clipped
    from .sources import SEQUENCE_GROUND_TRUTH

    tracks, gt, notes = args.tracks, args.gt, []
    if os.path.isdir(tracks):
        if not os.path.isfile(os.path.join(tracks, "tracks.txt")):
            raise TrackFileError(f"{clipped(tracks)} is a folder without tracks.txt: give a tracks file, or the "
                                 "output folder of a belief track run")
        tracks = os.path.join(tracks, "tracks.txt")
        notes.append(f"reading the tracks of the run in {clipped(args.tracks)}: {clipped(tracks)}")
    if os.path.isdir(gt):
        # Any folder that keeps a ground truth where a sequence does: its frames are not needed to score.
        found = next((os.path.join(gt, name) for name in SEQUENCE_GROUND_TRUTH
                      if os.path.isfile(os.path.join(gt, name))), None)
        if found is None:
            raise TrackFileError(f"{clipped(gt)} is a folder without a ground truth: give a ground-truth file, or a "
                                 f"MOTChallenge sequence folder with {' or '.join(SEQUENCE_GROUND_TRUTH)}")
        gt = str(found)
        notes.append(f"{clipped(args.gt)} is a MOTChallenge sequence: scoring against its ground truth {clipped(gt)}")
    return tracks, gt, notes


def register_eval(subparsers: Any) -> None:
    """Add the ``eval`` subcommand to a ``belief`` sub-parser collection.

    ``belief eval TRACKS.txt GT.txt [--json]`` prints the
    :class:`~belief_tracking.evaluation.Scores` of the tracks against the ground
    truth, as a table or as JSON.  Bad files raise
    :class:`~belief_tracking.errors.TrackFileError`, which the ``belief`` command
    line reports in one line.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="belief")
    >>> register_eval(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["eval", "tracks.txt", "gt.txt", "--json"])
    >>> args.tracks, args.gt, args.json
    ('tracks.txt', 'gt.txt', True)
    """
    p = subparsers.add_parser(
        "eval", help="score tracks against ground truth (MOTA, MOTP, IDF1, centre error)",
        description="Score MOTChallenge tracks against ground truth: CLEAR MOT (IoU >= 0.5), IDF1, "
                    "ID switches, false positives, misses and box-centre errors. Ground-truth rows "
                    "with flag 0 are not scored, and hypotheses matched to them are dropped. "
                    "MOTP is the mean IoU of the matched pairs. An empty tracks file (a run that found "
                    "nobody) misses every box: MOTA 0, IDF1 0.")
    p.add_argument("tracks", metavar="TRACKS.txt",
                   help="tracker output, MOTChallenge CSV, or the output folder of a belief track run (its tracks.txt)")
    p.add_argument("gt", metavar="GT.txt",
                   help="ground truth, MOTChallenge CSV, or a MOTChallenge sequence folder (its gt/gt.txt)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_eval)


# -- belief experiment -----------------------------------------------------------------------------
#: Runs that ``belief experiment --dry-run`` lists by name (it counts the others).
DRY_RUN_LISTED = 20


def _cmd_experiment(args: argparse.Namespace) -> int:
    from .experiment import load_experiment
    from .grid import check_output, plan_experiment, run_experiment, set_limits
    from .outdir import check_folder, input_paths
    from .tables import format_summary

    _output_dir(args.out)
    set_limits(max_runs=args.max_runs, max_sequences=args.max_sequences, max_methods=args.max_methods,
               max_run_seconds=args.max_run_seconds, max_run_bytes=args.max_run_bytes)
    experiment = load_experiment(args.config, data_dir=args.data)
    out = check_output(args.out if args.out is not None else Path(args.config).with_suffix(""))
    inputs = [args.config, *(path for sequence in experiment.sequences
                             for path in (sequence.video, sequence.gt, sequence.detections))]
    check_folder(out, input_paths(*inputs), create=False)
    cells = experiment.cells()
    plan = plan_experiment(experiment, workers=args.workers)
    line = (f"{experiment.name}: {len(experiment.sequences)} sequences x {len(experiment.methods)} methods x "
            f"{len(experiment.seeds)} seeds = {len(cells)} runs; outputs in {out}")
    as_json = getattr(args, "json", False)
    grid = {"experiment": experiment.name, "sequences": len(experiment.sequences),
            "methods": len(experiment.methods), "seeds": len(experiment.seeds), "runs": len(cells), "out": str(out),
            "estimate": {"total_seconds": plan.total_seconds, "wall_seconds": plan.wall_seconds,
                         "run_seconds": plan.run_seconds, "run_bytes": plan.run_bytes,
                         "peak_bytes": plan.peak_bytes, "workers": plan.workers}}
    if args.dry_run:
        if as_json:
            _print_json({**grid, "cells": [cell.label for cell in cells]})
            return 0
        print(line)
        print(plan.describe())
        for cell in cells[:DRY_RUN_LISTED]:
            print(f"  {cell.label}")
        if len(cells) > DRY_RUN_LISTED:
            print(f"  ... and {len(cells) - DRY_RUN_LISTED:,} more")
        return 0

    def announce() -> None:
        # Printed once every argument is checked and the workers are ready: an error is then the only line.
        if _quiet(args):
            return
        if as_json:     # standard output holds the JSON object alone
            _say(args, f"{line}; {plan.describe()}")
        else:
            print(f"{line}\n{plan.describe()}", flush=True)

    result = run_experiment(experiment, out, workers=args.workers, scheduler=args.scheduler, fresh=args.fresh,
                            progress=_progress(args), announce=announce)
    if as_json:
        _print_json({**grid, "computed": result.computed, "reused": result.reused, "summary": result.summary,
                     "files": {name: str(path) for name, path in result.files.items()}})
        return 0
    print(f"ran {result.computed} runs, reused {result.reused} finished ones")
    print(format_summary(result.summary))
    return 0


def register_experiment(subparsers: Any) -> None:
    """Add the ``experiment`` subcommand to a ``belief`` sub-parser collection.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="belief")
    >>> register_experiment(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["experiment", "grid.toml", "--workers", "2", "--scheduler", "local"])
    >>> args.config, args.workers, args.scheduler, args.fresh
    ('grid.toml', 2, 'local', False)
    """
    p = subparsers.add_parser(
        "experiment", help="run a grid of seeded tracking runs and tabulate their scores",
        description="Run every cell of a grid (sequences x methods x seeds) described by a TOML file, in parallel "
                    "on local processes or on a Dask cluster, and write results.csv (one row per run: scores and "
                    "timings), rms.csv (the RMS position error of W (36), per target and frame over the seeds) and "
                    "summary.csv into --out. Finished runs are kept in --out/cells, so an interrupted experiment "
                    "resumes where it stopped.", epilog=LABELS_NOTE + ".")
    p.add_argument("config", metavar="CONFIG", help="the experiment's TOML file")
    p.add_argument("--out", metavar="DIR", help="output folder (default: CONFIG without its suffix)")
    p.add_argument("--data", metavar="DIR", help="folder of the relative video and gt paths (default: CONFIG's "
                                                  "folder)")
    p.add_argument("--workers", type=_integer(1), metavar="N", help="local processes, or local Dask workers "
                                                             "(default: one per core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the Dask scheduler at ADDRESS (tcp://host:8786), or 'local' for a Dask cluster on "
                        "this machine (needs belief-dsmt[dask]). The scheduler runs the runs as pickled Python tasks "
                        "and sends back pickled results: a scheduler that is not yours can run its own code "
                        "here, so connect only to one you trust")
    p.add_argument("--fresh", action="store_true", help="run every cell again, even the finished ones")
    p.add_argument("--dry-run", action="store_true",
                   help="print the number of runs, their estimated time and memory and the first runs, and stop")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: the grid, its estimate, and the runs' summary (with --dry-run, the "
                        "runs' labels)")
    p.add_argument("--max-runs", type=_integer(1), metavar="N", help="most runs of one experiment (default 100000)")
    p.add_argument("--max-sequences", type=_integer(1), metavar="N", help="most sequences (default 1000)")
    p.add_argument("--max-methods", type=_integer(1), metavar="N", help="most methods (default 2000)")
    p.add_argument("--max-run-seconds", type=_integer(1), metavar="N",
                   help="the longest estimated time of one run, in seconds (default 600)")
    p.add_argument("--max-run-bytes", type=_integer(1), metavar="N",
                   help="the largest estimated memory of one run, in bytes (default 1073741824)")
    p.set_defaults(func=_cmd_experiment)
