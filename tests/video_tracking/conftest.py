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
    """diagnostics.png as a stub: drawing the real one costs seconds and is tested with the demo."""
    from belief_tracking import outputs

    monkeypatch.setattr(outputs, "plot_diagnostics", lambda path, *args, **kwargs: Path(path).write_bytes(b"png"))
