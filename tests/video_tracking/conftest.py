"""Fixtures shared by the tracking tests."""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import pytest


@functools.lru_cache(maxsize=None)
def _render_once(config):
    from belief_tracking import scenes

    return scenes.render(config)


@pytest.fixture(scope="session")
def rendered_scene():
    """``scenes.render`` drawing each configuration once in a test process, for the tests that use a scene.

    A scene's arrays refuse writes, so the tests can share one; the tests of the renderer itself
    (tests/video_tracking/test_scenes.py) still compare it with a fresh rendering.
    """
    return _render_once


@pytest.fixture(scope="module")
def scene_files(tmp_path_factory):
    """A short crossing scene (12 frames of 320 x 240) as scene.avi and gt.txt."""
    from belief_tracking import scenes

    folder = tmp_path_factory.mktemp("scene")
    scene = scenes.render(dataclasses.replace(scenes.crossing(0), n_frames=12))
    scenes.write_video(folder / "scene.avi", scene)
    scenes.write_gt(folder / "gt.txt", scene.ground_truth, visibility=scene.visibility)
    return folder / "scene.avi", folder / "gt.txt"


@pytest.fixture
def quick_plot(monkeypatch):
    """diagnostics.png and tracks.png as stubs: drawing the real ones costs seconds and is tested with the demo
    and in tests/video_tracking/test_pictures.py."""
    from belief_tracking import outputs, track_paths

    def stub(path, *args, **kwargs):
        Path(path).write_bytes(b"png")

    monkeypatch.setattr(outputs, "plot_diagnostics", stub)
    monkeypatch.setattr(track_paths, "plot_track_paths", stub)
