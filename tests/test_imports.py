"""The belief package stays independent of OpenCV and of the tracking plugins."""

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import belief

PACKAGE_DIR = Path(belief.__file__).resolve().parent
REPO_ROOT = PACKAGE_DIR.parent
FORBIDDEN = ("cv2", "plugins")


def belief_modules() -> list[str]:
    """Every module of the package that exists right now (found by walking the package)."""
    names = ["belief"]
    for info in pkgutil.walk_packages([str(PACKAGE_DIR)], prefix="belief."):
        names.append(info.name)
    return sorted(names)


def test_the_package_has_the_core_modules():
    modules = belief_modules()
    for name in ("belief.frame", "belief.model", "belief.lattice", "belief.batch", "belief.mass", "belief.errors"):
        assert name in modules


def test_importing_every_belief_module_loads_neither_cv2_nor_plugins():
    modules = belief_modules()
    script = "\n".join(
        [
            "import importlib, sys",
            f"for name in {modules!r}:",
            "    importlib.import_module(name)",
            "bad = sorted(m for m in sys.modules if m == 'cv2' or m.startswith('cv2.')",
            "             or m == 'plugins' or m.startswith('plugins.'))",
            "assert not bad, bad",
            "print('imported', len(" + repr(modules) + "))",
        ]
    )
    result = subprocess.run(
        [sys.executable, "-c", script], cwd=REPO_ROOT, capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "imported" in result.stdout


def imported_names(tree: ast.AST) -> list[tuple[str, int]]:
    """Top-level module names imported by a source tree, with line numbers.

    Covers ``import x``, ``from x import y`` and ``importlib.import_module("x")`` /
    ``__import__("x")`` with a literal name.
    """
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.module, node.lineno))
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
            if name in ("import_module", "__import__") and isinstance(node.args[0].value, str):
                found.append((node.args[0].value, node.lineno))
    return found


def test_no_belief_source_file_imports_cv2_or_plugins():
    offenders = []
    sources = sorted(PACKAGE_DIR.rglob("*.py"))
    assert sources
    for path in sources:
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for name, line in imported_names(tree):
            if name.split(".")[0] in FORBIDDEN:
                offenders.append(f"{path.relative_to(REPO_ROOT)}:{line} imports {name}")
    assert not offenders, "\n".join(offenders)


def test_the_static_scan_recognises_the_forbidden_imports():
    # guards the scanner itself
    samples = [
        "import cv2",
        "import numpy, cv2 as cv",
        "from cv2 import imread",
        "import plugins.video_tracking",
        "from plugins import video_tracking",
        "def f():\n    import cv2",
        "import importlib\nimportlib.import_module('plugins.video_tracking')",
        "__import__('cv2')",
    ]
    for source in samples:
        names = [name.split(".")[0] for name, _ in imported_names(ast.parse(source))]
        assert set(names) & set(FORBIDDEN), source
    harmless = "import numpy\nfrom belief import plugins_helper\ntext = 'import cv2'"
    assert not {n.split('.')[0] for n, _ in imported_names(ast.parse(harmless))} & set(FORBIDDEN)
