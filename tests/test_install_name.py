"""The distribution has a name of its own, and every install hint uses it with an extra that exists."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from belief.install import DISTRIBUTION, EXTRAS, install_command

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
#: Files where an install command may be written.
TEXT_FILES = [p for pattern in ("belief/**/*.py", "plugins/**/*.py", "docs/**/*.md", "*.md", "benchmarks/*.py",
                                "tests/**/*.py")
              for p in ROOT.glob(pattern)]


def test_the_distribution_is_not_the_unrelated_belief_on_the_package_index():
    assert PROJECT["name"] == DISTRIBUTION and DISTRIBUTION != "belief"


def test_the_extras_named_here_are_those_of_pyproject():
    assert set(EXTRAS) == set(PROJECT["optional-dependencies"])
    for extra in PROJECT["optional-dependencies"].values():
        for requirement in extra:
            name = re.match(r"[A-Za-z0-9_.-]+", requirement).group(0)
            assert name != "belief", f"{requirement} names the unrelated 'belief' distribution"


def test_every_install_hint_names_this_distribution_and_an_extra_it_has():
    hint = re.compile(r"pip install ['\"]?([A-Za-z0-9_.-]+)\[([a-z,]+)\]")
    found = 0
    for path in TEXT_FILES:
        for name, extras in hint.findall(path.read_text(encoding="utf-8")):
            if name == ".":
                continue
            found += 1
            assert name == DISTRIBUTION, f"{path.relative_to(ROOT)}: pip install {name}[{extras}]"
            assert set(extras.split(",")) <= set(EXTRAS), f"{path.relative_to(ROOT)}: no extra {extras}"
    assert found >= 4


def test_an_unknown_extra_is_refused_with_the_known_ones():
    assert install_command("tracking") == "pip install 'belief-dsmt[tracking]'"
    with pytest.raises(ValueError, match="no extra 'video'; its extras: tracking, plot"):
        install_command("video")
