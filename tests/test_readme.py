"""The examples of the README and of every documentation page run and print what they say."""

import doctest
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

#: Pages that must hold ``>>>`` examples: a page listed here whose examples vanish fails.
PAGES_WITH_EXAMPLES = {
    "README.md",
    "docs/index.md",
    "docs/theory.md",
    "docs/concepts.md",
    "docs/rules.md",
    "docs/tutorials/fusion.md",
    "docs/tutorials/tracking.md",
    "docs/tutorials/learning.md",
    "docs/experiments.md",
}

PAGES = sorted({"README.md"} | {path.relative_to(ROOT).as_posix() for path in DOCS.rglob("*.md")})


def test_the_listed_pages_exist():
    missing = sorted(name for name in PAGES_WITH_EXAMPLES if not (ROOT / name).is_file())
    assert not missing, f"pages listed in PAGES_WITH_EXAMPLES do not exist: {missing}"


@pytest.mark.parametrize("name", PAGES)
def test_markdown_examples(name):
    # No option flags: a page runs under plain `python -m doctest PAGE` as it does here.
    result = doctest.testfile(str(ROOT / name), module_relative=False, optionflags=0)
    if name in PAGES_WITH_EXAMPLES:
        assert result.attempted > 0, f"{name} is listed as having examples, but none ran"
    assert result.failed == 0
