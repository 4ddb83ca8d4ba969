"""docs/limits.md lists every limit of the library with the default the code has, and every error class."""

import importlib
import re
from pathlib import Path

import pytest

import belief
import belief.errors

PAGE = Path(__file__).resolve().parent.parent / "docs" / "limits.md"
ROW = re.compile(r"^\| `(belief(?:\.\w+)+)\.([A-Z_]+)` \| (\d+) \|", re.MULTILINE)
#: Module constants named MAX_* that are not limits on a user's job.
NOT_LIMITS = {("belief.strategies", "MAX_WEIGHT")}


def documented() -> dict:
    return {(module, name): int(value) for module, name, value in ROW.findall(PAGE.read_text(encoding="utf-8"))}


def test_every_documented_default_is_the_code_s():
    rows = documented()
    assert len(rows) >= 13
    for (module, name), value in rows.items():
        assert getattr(importlib.import_module(module), name) == value, f"{module}.{name}"


def test_every_limit_of_the_library_is_documented():
    rows = documented()
    for path in sorted((Path(belief.__file__).parent).glob("*.py")):
        module = f"belief.{path.stem}"
        for name in re.findall(r"^(MAX_[A-Z_]+) = ", path.read_text(encoding="utf-8"), re.MULTILINE):
            if (module, name) not in NOT_LIMITS:
                assert (module, name) in rows, f"{module}.{name} is not on docs/limits.md"


def test_every_error_class_is_documented():
    text = PAGE.read_text(encoding="utf-8")
    classes = [name for name in dir(belief.errors) if name.endswith("Error") and name != "BeliefError"]
    assert classes
    for name in classes + ["UnknownRuleError", "MissingPlotExtraError"]:
        assert f"`{name}`" in text or f".{name}`" in text, name


TRACKING_ROW = re.compile(r"^\| `(belief_tracking(?:\.\w+)+)\.([A-Z_]+)` \| (\d+) \|", re.MULTILINE)
#: Constants named MAX_* / MIN_* of the plugin that are parts of its model, not limits on a user's job.
TRACKING_NOT_LIMITS = {("belief_tracking.perspective", "MAX_SCALE_CHANGE")}


def test_every_documented_default_of_the_tracking_plugin_is_the_code_s():
    pytest.importorskip("cv2")
    rows = TRACKING_ROW.findall(PAGE.read_text(encoding="utf-8"))
    assert len(rows) >= 20
    for module, name, value in rows:
        assert getattr(importlib.import_module(module), name) == int(value), f"{module}.{name}"


def test_every_limit_of_the_tracking_plugin_is_documented():
    pytest.importorskip("cv2")
    import belief_tracking

    text = PAGE.read_text(encoding="utf-8")
    for path in sorted(Path(belief_tracking.__file__).parent.glob("*.py")):
        module = f"belief_tracking.{path.stem}"
        for name in re.findall(r"^((?:MAX|MIN)_[A-Z_]+) = ", path.read_text(encoding="utf-8"), re.MULTILINE):
            if (module, name) in TRACKING_NOT_LIMITS:
                continue
            assert f"`{module}.{name}`" in text or f"`{name}`" in text, f"{module}.{name} is not on docs/limits.md"
