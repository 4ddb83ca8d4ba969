"""The belief package stays independent of OpenCV and of the tracking plugins."""

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import belief

PACKAGE_DIR = Path(belief.__file__).resolve().parent
REPO_ROOT = PACKAGE_DIR.parent
FORBIDDEN = ("cv2", "plugins", "belief_tracking")


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
            "             or m.split('.')[0] in ('plugins', 'belief_tracking'))",
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


def documented_belief_modules() -> set[str]:
    """``belief`` and the submodules that the API reference documents (``::: belief.x`` lines)."""
    page = (REPO_ROOT / "docs" / "reference" / "belief.md").read_text(encoding="utf-8")
    return {"belief"} | {line.split()[1] for line in page.splitlines() if line.startswith("::: belief.")}


def private_belief_names() -> set[str]:
    """Names with one leading underscore defined anywhere in ``belief`` (functions, classes, attributes, slots)."""
    names = set()
    for path in PACKAGE_DIR.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                names.add(node.name)
            elif isinstance(node, ast.Attribute):
                names.add(node.attr)
            elif isinstance(node, ast.Name):
                names.add(node.id)
            elif isinstance(node, ast.Constant) and isinstance(node.value, str):
                names.add(node.value)                                    # __slots__ entries
    return {n for n in names if n.startswith("_") and not n.startswith("__") and n.isidentifier()}


def test_the_plugins_use_only_the_public_api_of_belief():
    # A plugin imports public names of belief or of its documented submodules, and reaches no
    # private attribute of belief's objects: if a plugin needs more, belief grows it for everyone.
    import importlib

    documented = documented_belief_modules()
    private = private_belief_names()
    offenders = []
    sources = sorted((REPO_ROOT / "plugins").rglob("*.py"))
    assert sources
    for path in sources:
        where = path.relative_to(REPO_ROOT)
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        plugin_names = {node.name for node in ast.walk(tree) if isinstance(node, (ast.FunctionDef, ast.ClassDef))}
        plugin_names |= {t.attr for node in ast.walk(tree) if isinstance(node, (ast.Assign, ast.AnnAssign))
                         for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
                         if isinstance(t, ast.Attribute)}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "belief":
                if node.module not in documented:
                    offenders.append(f"{where}:{node.lineno} imports from {node.module}, which is not documented")
                    continue
                public = set(getattr(importlib.import_module(node.module), "__all__", ()))
                for alias in node.names:
                    if alias.name not in public:
                        offenders.append(f"{where}:{node.lineno} imports {alias.name} from {node.module}, "
                                         f"which is not in its __all__")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == "belief" and alias.name not in documented:
                        offenders.append(f"{where}:{node.lineno} imports {alias.name}, which is not documented")
            elif isinstance(node, ast.Attribute) and node.attr in private and node.attr not in plugin_names:
                offenders.append(f"{where}:{node.lineno} uses {node.attr}, a private name of belief")
    assert not offenders, "\n".join(offenders)
