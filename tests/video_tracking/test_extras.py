"""Without the ``tracking`` extra, the library works and a tracking command says which extra to install."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from belief_tracking.errors import MissingExtraError
from belief_tracking.extras import INSTALL, require

ROOT = Path(__file__).resolve().parents[2]

# sys.modules[name] = None makes ``import name`` fail as if the package were not installed.
WITHOUT = "import sys\nfor name in {names!r}:\n    sys.modules[name] = None\n"


def run(code: str, names: tuple[str, ...]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", WITHOUT.format(names=names) + code], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("argv", [["track", "--demo", "--no-progress"], ["eval", "gt.txt", "tracks.txt"]])
def test_a_tracking_command_without_opencv_or_motmetrics_is_one_line_naming_the_extra(tmp_path, argv):
    argv = [str(tmp_path / a) if a.endswith(".txt") else a for a in argv]
    if argv[0] == "eval":
        for name in argv[1:]:
            Path(name).write_text("1,1,10,10,20,40,1,1,1\n")
    result = run(f"from belief.cli import main\nsys.exit(main({argv!r} + (['--out', {str(tmp_path / 'o')!r}] "
                 f"if {argv[0]!r} == 'track' else [])))", ("cv2", "motmetrics"))
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and INSTALL in lines[0] and "Traceback" not in result.stderr, result.stderr
    assert not (tmp_path / "o").exists()


def test_the_library_imports_and_combines_without_the_extra():
    result = run("import belief\nm = belief.MassFunction({'a': 0.6, 'a|b': 0.4}, frame=['a', 'b'])\n"
                 "print(belief.combine(m, m, rule='pcr6'))", ("cv2", "motmetrics", "matplotlib", "tqdm"))
    assert result.returncode == 0, result.stderr
    assert "a" in result.stdout


def test_require_names_the_extra_and_is_both_a_belief_error_and_an_import_error():
    with pytest.raises(MissingExtraError, match=r"pip install 'belief-dsmt\[tracking\]'") as caught:
        require("a_package_that_is_not_installed")
    assert isinstance(caught.value, ModuleNotFoundError)
    assert caught.value.name == "a_package_that_is_not_installed"
