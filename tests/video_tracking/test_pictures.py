"""The pictures a run writes, as a person reads them: diagnostics.png and tracks.png (issue 27, point 3).

diagnostics.png keeps only the panels with something to show, titles each with the quantity's name before its
equation label, labels both axes and leaves a gap where a track was not output; tracks.png draws every track's
path with its births, deaths and re-identifications marked; the README lists every file a run writes; and the
help of ``belief track`` names each quantity before its label.
"""

from __future__ import annotations

import argparse
import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from belief_tracking import outputs, track_paths  # noqa: E402
from belief_tracking.cli import DEMO_OUTPUTS, register  # noqa: E402
from belief_tracking.config import TrackerConfig  # noqa: E402
from belief_tracking.diagnostics import diagnostic_columns  # noqa: E402
from belief_tracking.initiation import init_from_gt  # noqa: E402
from belief_tracking.runner import output_names, run  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

#: An equation label of the papers: "W (33)", "C (13)", "W (33)-(35)".
LABEL = re.compile(r"\b[WLC] \(\d+\)")


def synthetic_records(columns, frames=range(1, 21), ids=(1, 2), missing=()):
    """Diagnostics rows with ``columns``: m(∅) all zero, a fixed particle count, every other column varying.

    ``missing`` holds the (frame, id) pairs left out, as for a track that was not output then.
    """
    rows = []
    for frame in frames:
        for track_id in ids:
            if (frame, track_id) in missing:
                continue
            row = {"frame": float(frame), "id": float(track_id)}
            for k, column in enumerate(columns):
                if column == "mean_m_empty":
                    row[column] = 0.0
                elif column == "particles":
                    row[column] = 100.0
                elif column == "occluded":
                    row[column] = float(frame % 7 == 0)
                elif column == "ess":
                    row[column] = 30.0 + frame + 5 * track_id
                else:
                    row[column] = 0.5 + 0.4 * np.sin(frame / 3 + k + track_id)
            rows.append(row)
    return rows


def titles(figure):
    return [ax.get_title() for ax in figure.axes]


def named_before(text: str, match: re.Match) -> bool:
    """Whether at least two words come before the label in its clause (after the last , ; or :)."""
    clause = re.split(r"[,;:]", text[:match.start()])[-1]
    return len(re.findall(r"[A-Za-zρλθ']{3,}", clause)) >= 2


# -- diagnostics.png ---------------------------------------------------------------------------------------
def test_a_default_run_has_no_adaptive_fusion_panel_and_no_flat_panel():
    records = synthetic_records(diagnostic_columns(TrackerConfig()))
    shown = titles(outputs.diagnostics_figure(records))
    assert len(shown) == 5
    joined = " ".join(shown)
    for absent in ("C (13)", "C (15)", "empty set", "Particles per track"):
        assert absent not in joined
    assert not any("confidence" in t.lower() or "similarity" in t.lower() for t in shown)


def test_a_tracked_default_run_draws_only_the_panels_that_vary(rendered_scene):
    from belief_tracking import scenes
    from belief_tracking.tracker import Tracker

    scene = rendered_scene(dataclasses.replace(scenes.crossing(0), n_frames=8))
    tracker = Tracker(TrackerConfig(particles=30), init_from_gt(scene.ground_truth), np.random.default_rng(0))
    records = [row for result in tracker.track(scene.frames) for row in result.diagnostics.rows(result.frame)]
    assert {r["mean_m_empty"] for r in records} == {0.0} and {r["particles"] for r in records} == {30.0}
    keys = [panel.key for panel in outputs.diagnostic_panels(records)]
    assert "mean_m_empty" not in keys and "particles" not in keys
    assert not {"similarity", "confidence"} & set(keys)
    assert "mean_m_target" in keys and "ess" in keys


def test_the_adaptive_fusion_brings_its_panels_and_the_layout_grows_and_shrinks_with_them():
    everything = synthetic_records(diagnostic_columns(TrackerConfig(fusion="adaptive", adaptive_particles=True,
                                                                    diagnostics="all")))
    for row in everything:  # a particle count that adapts
        row["particles"] = 50.0 + row["frame"]
    full = outputs.diagnostics_figure(everything)
    few = outputs.diagnostics_figure(synthetic_records(("particles", "ess", "mean_bel")))
    assert len(titles(full)) == 8                            # all but the zero m(∅)
    assert any("C (13)" in t for t in titles(full)) and any("C (15)" in t for t in titles(full))
    assert len(titles(few)) == 2                             # the fixed particle count is left out
    assert few.get_figheight() < full.get_figheight()


def test_panels_of_absent_constant_or_zero_columns_are_left_out():
    records = [{"frame": f, "id": 1, "mean_m_empty": 0.0, "particles": 80.0, "mean_bel": 0.4, "ess": 10.0 + f % 3}
               for f in range(1, 10)]
    assert [panel.key for panel in outputs.diagnostic_panels(records)] == ["ess"]
    assert outputs.diagnostic_panels([]) == []
    empty = outputs.diagnostics_figure([])
    assert len(empty.axes) == 1 and "Nothing to draw" in empty.axes[0].texts[0].get_text()


def test_titles_start_with_words_and_give_the_label_after_them():
    records = synthetic_records(diagnostic_columns(TrackerConfig(fusion="adaptive", diagnostics="all")))
    figure = outputs.diagnostics_figure(records)
    for title in titles(figure):
        assert re.match(r"[A-Z][a-z]+ [a-z]", title), title           # words first
        assert not title.startswith(("[", "(", "mean ")), title
        for match in LABEL.finditer(title):
            assert named_before(title, match) and title.endswith(")"), title
    assert "Mass on the track's own target  (W (33))" in titles(figure)


def test_every_panel_has_labelled_axes_with_units():
    records = synthetic_records(diagnostic_columns(TrackerConfig(fusion="adaptive", diagnostics="all")))
    for ax in outputs.diagnostics_figure(records).axes:
        assert ax.get_xlabel() == "frame number"
        ylabel = ax.get_ylabel()
        assert re.search(r"\((0 to 1|count|particles)\)$", ylabel), ylabel


def test_a_track_missing_from_some_frames_is_drawn_with_nan_breaks():
    gap = {(frame, 1) for frame in range(8, 13)}
    figure = outputs.diagnostics_figure(synthetic_records(("mean_bel", "ess"), missing=gap))
    line = next(line for line in figure.axes[0].lines if line.get_label() == "track 1")
    x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
    assert list(x) == list(range(1, 21))                   # every frame, the missing ones included
    assert np.isnan(y[7:12]).all() and np.isfinite(y[:7]).all() and np.isfinite(y[12:]).all()


def test_with_gaps_fills_the_missing_frames_with_nan():
    frames, values = outputs.with_gaps(np.array([2, 3, 6]), np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]))
    assert list(frames) == [2, 3, 4, 5, 6]
    assert np.isnan(values[2:4]).all() and values[4].tolist() == [5.0, 6.0]
    frames, values = outputs.with_gaps(np.array([], dtype=int), np.array([]))
    assert frames.size == 0 and values.size == 0


def test_the_figure_touches_no_global_backend():
    import matplotlib

    before = matplotlib.get_backend()
    outputs.diagnostics_figure(synthetic_records(("ess",)))
    assert matplotlib.get_backend() == before


# -- tracks.png ----------------------------------------------------------------------------------------------
#: Track 1 is seen on frames 1-3, not output on 4-6 and found again on 7-10; track 2 is born on frame 3 and
#: dies after frame 5; track 3 lives from frame 6 to the last frame, 10.
TABLE = np.array([[f, 1, 10 + 2 * f, 20, 10, 30, -1, -1, -1, -1] for f in (1, 2, 3, 7, 8, 9, 10)]
                 + [[f, 2, 60, 10 + 3 * f, 8, 24, -1, -1, -1, -1] for f in (3, 4, 5)]
                 + [[f, 3, 100 - f, 50, 12, 36, -1, -1, -1, -1] for f in range(6, 11)], dtype=float)


def test_the_markers_are_births_deaths_and_reidentifications():
    events = track_paths.track_events(TABLE, last_frame=10)
    assert [(e.kind, e.track_id, e.frame) for e in events] == [
        ("birth", 1, 1), ("reidentified", 1, 7), ("birth", 2, 3), ("death", 2, 5), ("birth", 3, 6)]
    reidentified = next(e for e in events if e.kind == "reidentified")
    assert (reidentified.x, reidentified.y) == (10 + 14 - 1 + 5, 20 - 1 + 30)   # the box's bottom centre


def test_a_track_alive_at_the_run_s_end_has_not_died_but_one_ending_earlier_has():
    assert not any(e.kind == "death" for e in track_paths.track_events(TABLE[TABLE[:, 1] == 3], last_frame=10))
    late = track_paths.track_events(TABLE[TABLE[:, 1] == 3], last_frame=12)
    assert [(e.kind, e.frame) for e in late] == [("birth", 6), ("death", 10)]
    assert track_paths.track_events(np.zeros((0, 10))) == []


def test_a_path_has_nan_in_its_gaps():
    path = next(p for p in track_paths.track_paths(TABLE) if p.track_id == 1)
    assert list(path.frames) == list(range(1, 11)) and path.points.shape == (10, 2)
    assert np.isnan(path.points[3:6]).all() and np.isfinite(path.points[[0, 1, 2, 6, 7, 8, 9]]).all()
    assert path.gaps == [(3, 7)]


def test_the_tracks_figure_marks_every_event_and_explains_the_marks_in_words():
    image = np.full((120, 160, 3), 90, np.uint8)
    figure = track_paths.tracks_figure(TABLE, image, last_frame=10, image_frame=5, title="synthetic")
    ax = figure.axes[0]
    marked = sorted(len(collection.get_offsets()) for collection in ax.collections)
    assert marked == [1, 1, 3]                                      # 1 death, 1 re-identification, 3 births
    legend = " ".join(text.get_text() for text in figure.legends[0].get_texts())
    for words in ("birth", "death", "re-identification", "gap", "bottom centre"):
        assert words in legend
    assert "track starts (birth), its id beside it: 3" in legend
    assert [t.get_text() for t in ax.texts] == ["1", "2", "3"]     # each id written at its birth
    assert ax.get_xlabel() == "x (pixels)" and ax.get_ylabel() == "y (pixels)"
    assert "frame 5" in figure.get_suptitle() and figure.get_suptitle().startswith("synthetic")


def test_the_picture_keeps_the_middle_frame_or_the_last_one():
    picture = track_paths.TrackPathsPicture("unused.png", None, (4, 3), expected_frames=None)
    for frame in (1, 2, 3):
        picture.write(type("Result", (), {"frame": frame})(), np.full((3, 4, 3), frame, np.uint8))
    assert picture.image_frame == 3 and int(picture.image[0, 0, 0]) == 3


def test_a_run_writes_tracks_png_with_its_births_and_deaths_marked(tmp_path, rendered_scene, monkeypatch):
    from belief_tracking import scenes

    scene = rendered_scene(dataclasses.replace(scenes.crossing(0), n_frames=8))
    gt = scene.ground_truth
    # Target 2 leaves the plan after frame 5: its track dies there, before the run ends.
    plan = init_from_gt(gt[(gt[:, 1] != 2) | (gt[:, 0] <= 5)])
    drawn = {}
    real = track_paths.tracks_figure

    def spy(rows, image=None, **options):
        drawn["rows"], drawn["image"], drawn["figure"] = rows, image, real(rows, image, **options)
        return drawn["figure"]

    monkeypatch.setattr(track_paths, "tracks_figure", spy)
    monkeypatch.setattr(outputs, "plot_diagnostics", lambda path, *a, **k: Path(path).write_bytes(b"png"))
    summary = run(scene, plan, TrackerConfig(particles=20), tmp_path / "run", write_video=False, progress=False)
    written = summary.files["tracks.png"]
    assert written.name == "tracks.png" and written.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert list(summary.files) == list(output_names(write_video=False))
    assert drawn["image"].shape == scene.frames.shape[1:]            # a frame of the video under the paths
    kinds = [(e.kind, e.track_id) for e in track_paths.track_events(drawn["rows"], last_frame=8)]
    assert ("birth", 1) in kinds and ("birth", 2) in kinds and ("death", 2) in kinds
    legend = " ".join(text.get_text() for text in drawn["figure"].legends[0].get_texts())
    assert "(death); a path without one was followed to the end: 1" in legend


def test_a_run_without_plots_writes_neither_picture(tmp_path, rendered_scene):
    from belief_tracking import scenes

    scene = rendered_scene(dataclasses.replace(scenes.crossing(0), n_frames=3))
    summary = run(scene, init_from_gt(scene.ground_truth), TrackerConfig(particles=10), tmp_path / "run",
                  write_video=False, write_plot=False, progress=False)
    assert not {"diagnostics.png", "tracks.png"} & set(summary.files)
    assert not {"diagnostics.png", "tracks.png"} & {p.name for p in (tmp_path / "run").iterdir()}
    assert "tracks.png" not in output_names(write_plot=False)


# -- what a person reads besides ------------------------------------------------------------------------------
def readme_outputs_section() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    match = re.search(r"^(#+) What a run writes\s*$(?P<body>.*?)(?=^#{1,3} |\Z)", text, re.M | re.S)
    assert match, "README.md has no section 'What a run writes'"
    return match["body"]


def test_the_readme_lists_every_file_a_run_writes():
    section = readme_outputs_section()
    names = set(output_names(extra=DEMO_OUTPUTS))
    assert {"annotated.avi", "tracks.txt", "diagnostics.csv", "diagnostics.png", "tracks.png",
            "summary.json"} <= names
    for name in names:
        assert re.search(rf"^- `{re.escape(name)}`.*?:", section, re.M) or re.search(
            rf"^- .*`{re.escape(name)}`", section, re.M), f"README's outputs section does not list {name}"


def test_the_help_of_belief_track_names_each_quantity_before_its_label():
    parser = argparse.ArgumentParser(prog="belief")
    register(parser.add_subparsers(dest="command"))
    track = parser._subparsers._group_actions[0].choices["track"]
    text = " ".join(track.format_help().split())
    labels = list(LABEL.finditer(text))
    assert labels, "the help cites no equation label any more: this test has nothing to check"
    for match in labels:
        context = text[max(0, match.start() - 60):match.end()]
        assert named_before(text, match), f"no name before {match[0]}: ...{context}"
    assert "tracks.png" in text


def test_the_docs_link_the_labels_to_their_list():
    for page in ("docs/tracking.md", "docs/plots.md"):
        assert "theory.md#references" in (ROOT / page).read_text(encoding="utf-8"), page


@pytest.mark.parametrize("command", ["track", "experiment", "eval", "combine", "decide", "transform", "measures"])
def test_help_names_each_quantity_before_its_equation_label_and_says_where_labels_are_explained(command, capsys):
    # A label such as "W (33)" is read only after the quantity's name, and the help says what W and C stand for.
    import re

    from belief.cli import main

    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    labels = list(re.finditer(r"\b[WC] \(\d+\)", text))
    for label in labels:
        before = text[:label.start()].rstrip(" (")
        assert re.search(r"[a-z]{4,}( of| such as)?$", before), f"{label.group()} follows no quantity's name: ...{before[-40:]}"
    if labels:
        assert "docs/theory.md" in text and "Wang" in text
