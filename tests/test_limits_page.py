"""docs/limits.md lists every limit of the library with the default the code has, and every error class."""

import importlib
import re
from pathlib import Path

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
