"""Every module of the tracking plugin runs its own docstring examples.

The plugin is installed as ``belief_tracking`` from the folder ``plugins/video_tracking``,
so its examples run here on the imported modules (under the name users import), rather
than through pytest's collection of files.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil
from pathlib import Path

import pytest

import belief_tracking

MODULES = sorted(info.name for info in pkgutil.walk_packages(belief_tracking.__path__, "belief_tracking."))


def test_the_plugin_has_its_modules():
    assert {"belief_tracking.tracker", "belief_tracking.cues", "belief_tracking.cli"} <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    if ">>>" in Path(module.__file__).read_text(encoding="utf-8"):
        assert result.attempted > 0, f"{name} has examples, but none ran"
    assert result.failed == 0
