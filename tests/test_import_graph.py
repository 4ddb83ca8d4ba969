"""The import graph of each package, read from the source with ``ast`` (nothing is imported).

For ``belief`` (folder belief/) and ``belief_tracking`` (folder plugins/video_tracking/) the
graph has a node per module and an edge A -> B when A holds an import statement, anywhere (at
the top or inside a function), that names B.  The tests below assert that

* neither package has an import cycle;
* the plugin's modules import each other only relatively (``from .boxes import iou``), never
  as ``belief_tracking.x``;
* the plugin reaches no private name of ``belief``: no module path component and no imported
  name starting with ``_``, and no ``belief.<module>._name`` attribute through a module it
  imported.

tests/test_imports.py covers the rest and is not repeated here: that ``belief`` never imports
``cv2``, ``plugins`` or ``belief_tracking`` (test_no_belief_source_file_imports_cv2_or_plugins,
over the same source files, and by importing every module in a fresh interpreter), and that the
plugin imports only the documented modules of ``belief`` and names in their ``__all__``.

An edge goes to the modules an import names: ``from .x import y`` gives an edge to x, and to
x.y too when x.y is a module (so ``from . import y`` gives one to the package and one to y);
``import a.b`` one to a.b.  A module that names itself (``from . import y`` in a package's
``__init__``) is no edge, nor are the parent packages that Python initialises on the way to
a.b: with them every submodule would close a cycle with its package's ``__init__``.
"""

from __future__ import annotations

import ast
import functools
import itertools
from dataclasses import dataclass
from pathlib import Path

import networkx as nx
import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]

#: Each package: its import name and its folder in the repository.
PACKAGES = {"belief": REPO_ROOT / "belief", "belief_tracking": REPO_ROOT / "plugins" / "video_tracking"}

#: At most this many cycles of one strongly connected component are listed in a failure.
MAX_CYCLES_SHOWN = 10


@dataclass(frozen=True)
class Import:
    """One import statement of a module, resolved to absolute names."""

    module: str                 # the importing module
    path: Path                  # its source file
    line: int
    target: str                 # the module named: "belief.mass", "numpy", "belief_tracking.boxes"
    names: tuple[str, ...]      # the names of ``from target import ...`` (() for ``import target``)
    aliases: tuple[str, ...]    # the local names it binds, one per imported name
    relative: bool

    @property
    def where(self) -> str:
        return location(self.path, self.line)


def location(path: Path, line: int) -> str:
    """``file:line``, the file relative to the repository when it lies in it."""
    return f"{path.relative_to(REPO_ROOT) if path.is_relative_to(REPO_ROOT) else path}:{line}"


# -- building the graph -----------------------------------------------------------------------------
def module_files(folder: Path, package: str) -> dict[str, Path]:
    """Dotted module name -> source file, for every ``.py`` file below ``folder`` (the package ``package``).

    ``folder/__init__.py`` is ``package``, ``folder/a/b.py`` is ``package.a.b`` and
    ``folder/a/__init__.py`` is ``package.a``.
    """
    found = {}
    for path in sorted(folder.rglob("*.py")):
        parts = path.relative_to(folder).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join((package, *parts))] = path
    return found


def resolve_relative(module: str, is_package: bool, level: int, name: str | None) -> str:
    """The absolute module of ``from <level dots><name> import ...`` written in ``module``.

    One dot is the package that holds the module, or the package itself in its ``__init__``;
    each further dot goes one package up.
    """
    base = module.split(".") if is_package else module.split(".")[:-1]
    if level - 1 >= len(base):
        raise ValueError(f"{module}: a relative import with {level} dots goes above the top-level package")
    base = base[:len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def syntax_tree(path: Path) -> ast.Module:
    """The parsed source file (each text parsed once per test process: the tests read the same files)."""
    return _parsed(path.read_text(encoding="utf-8"), str(path))


@functools.lru_cache(maxsize=None)
def _parsed(source: str, filename: str) -> ast.Module:
    return ast.parse(source, filename=filename)


def imports_in(path: Path, module: str) -> list[Import]:
    """Every import statement of a source file, at any depth, with relative names resolved."""
    tree = syntax_tree(path)
    is_package = path.name == "__init__.py"
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                bound = alias.asname or alias.name.split(".")[0]
                found.append(Import(module, path, node.lineno, alias.name, (), (bound,), False))
        elif isinstance(node, ast.ImportFrom):
            target = resolve_relative(module, is_package, node.level, node.module) if node.level else node.module
            names = tuple(alias.name for alias in node.names)
            aliases = tuple(alias.asname or alias.name for alias in node.names)
            found.append(Import(module, path, node.lineno, target, names, aliases, node.level > 0))
    return found


def internal_targets(record: Import, modules: set[str]) -> set[str]:
    """The modules of ``modules`` that an import names, other than the importing module itself.

    ``import a.b.c`` names a.b.c (the longest prefix that is a module); ``from x import y``
    names x, and x.y too when that is a module.
    """
    if not record.names:
        parts = record.target.split(".")
        named = next((p for p in (".".join(parts[:k]) for k in range(len(parts), 0, -1)) if p in modules), None)
        targets = {named} - {None}
    else:
        targets = {f"{record.target}.{name}" for name in record.names} & modules
        targets |= {record.target} & modules
    return targets - {record.module}


def package_imports(folder: Path, package: str) -> list[Import]:
    """The imports of every module of a package."""
    return [record for module, path in module_files(folder, package).items() for record in imports_in(path, module)]


def import_graph(folder: Path, package: str) -> nx.DiGraph:
    """The directed graph of imports between the modules of a package; each edge keeps the lines that make it."""
    modules = module_files(folder, package)
    graph = nx.DiGraph()
    graph.add_nodes_from(modules)
    for record in package_imports(folder, package):
        for target in internal_targets(record, set(modules)):
            if graph.has_edge(record.module, target):
                graph.edges[record.module, target]["where"].append(record.where)
            else:
                graph.add_edge(record.module, target, where=[record.where])
    return graph


def import_cycles(graph: nx.DiGraph) -> list[list[str]]:
    """The strongly connected components of more than one module, each sorted: the modules on a cycle."""
    return sorted(sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1)


def describe_cycles(graph: nx.DiGraph, components: list[list[str]]) -> str:
    """A failure message: each component, and some of its cycles with the file and line of each import."""
    lines = []
    for component in components:
        lines.append(f"import cycle among {', '.join(component)}:")
        cycles = itertools.islice(nx.simple_cycles(graph.subgraph(component)), MAX_CYCLES_SHOWN)
        for cycle in sorted(cycles, key=lambda c: (len(c), c)):
            steps = [f"{a} -> {b} ({graph.edges[a, b]['where'][0]})" for a, b in zip(cycle, cycle[1:] + cycle[:1])]
            lines.append("    " + ", ".join(steps))
    return "\n".join(lines)


# -- the packages -----------------------------------------------------------------------------------
@pytest.mark.parametrize("package", sorted(PACKAGES))
def test_a_package_has_no_import_cycle(package):
    graph = import_graph(PACKAGES[package], package)
    assert len(graph) > 5 and graph.number_of_edges() > 5      # the graph was built from real modules
    components = import_cycles(graph)
    assert not components, f"{package} has import cycles; break each by moving what both sides need into " \
        f"a module of their own (an import inside a function still counts):\n" + describe_cycles(graph, components)


def absolute_imports_of_itself(folder: Path, package: str) -> list[str]:
    """Where a module of a package imports a module of the same package by its absolute name."""
    return [f"{record.where}: " + (f"from {record.target} import {', '.join(record.names)}" if record.names
                                   else f"import {record.target}")
            for record in package_imports(folder, package)
            if not record.relative and record.target.split(".")[0] == package]


def test_the_plugin_modules_import_each_other_only_relatively():
    absolute = absolute_imports_of_itself(PACKAGES["belief_tracking"], "belief_tracking")
    assert not absolute, "the plugin's modules must import each other relatively (from .boxes import iou), " \
        "so that the plugin does not depend on its installed name:\n" + "\n".join(absolute)


def is_private(name: str) -> bool:
    """A name with a leading underscore that is not a dunder (``__version__``, ``__name__`` are public)."""
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_uses_of_belief(folder: Path, package: str) -> list[str]:
    """Where a package names a private part of ``belief``.

    That is an import of a module with a path component, or of a name, that is private
    (:func:`is_private`), or a private attribute reached through a name bound by an import of
    ``belief``: ``mass._x`` after ``from belief import mass``, ``belief.mass._x`` after
    ``import belief.mass``.
    """
    found = []
    for module, path in module_files(folder, package).items():
        records = [r for r in imports_in(path, module) if r.target.split(".")[0] == "belief"]
        for record in records:
            if any(is_private(part) for part in record.target.split(".")):
                found.append(f"{record.where}: imports {record.target}")
            private = [name for name in record.names if is_private(name)]
            if private:
                found.append(f"{record.where}: imports {', '.join(private)} from {record.target}")
        bound_to_belief = {alias for record in records for alias in record.aliases}
        for node in ast.walk(syntax_tree(path)):
            if isinstance(node, ast.Attribute) and is_private(node.attr):
                root = node.value
                while isinstance(root, ast.Attribute):
                    root = root.value
                if isinstance(root, ast.Name) and root.id in bound_to_belief:
                    found.append(f"{location(path, node.lineno)}: uses {ast.unparse(node)}")
    return found


def test_the_plugin_reaches_no_private_name_of_belief():
    offenders = private_uses_of_belief(PACKAGES["belief_tracking"], "belief_tracking")
    assert not offenders, "the plugin may use only belief's public API; make what it needs public in " \
        "belief instead:\n" + "\n".join(offenders)


# -- the builder on small packages ------------------------------------------------------------------
def write_package(root: Path, files: dict[str, str]) -> Path:
    """A package folder ``root/pkg`` with the given files (relative path -> source)."""
    folder = root / "pkg"
    for name, source in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(source, encoding="utf-8")
    return folder


def test_a_two_module_cycle_is_found_and_named_with_its_lines(tmp_path):
    folder = write_package(tmp_path, {"__init__.py": "", "a.py": "import os\nfrom .b import f\n",
                                      "b.py": "def f():\n    from .a import g\n", "c.py": "from . import a\n"})
    graph = import_graph(folder, "pkg")
    assert set(graph.edges) == {("pkg.a", "pkg.b"), ("pkg.b", "pkg.a"), ("pkg.c", "pkg"), ("pkg.c", "pkg.a")}
    assert import_cycles(graph) == [["pkg.a", "pkg.b"]]
    message = describe_cycles(graph, import_cycles(graph))
    assert message.startswith("import cycle among pkg.a, pkg.b:\n")
    assert "pkg.a -> pkg.b (" in message and "a.py:2)" in message and "pkg.b -> pkg.a (" in message \
        and "b.py:2)" in message
    (tmp_path / "pkg" / "b.py").write_text("def f():\n    pass\n")       # the lazy import gone: no cycle
    assert import_cycles(import_graph(folder, "pkg")) == []


def test_relative_imports_resolve_against_the_package_of_the_module(tmp_path):
    folder = write_package(tmp_path, {
        "__init__.py": "from . import top\nfrom .sub import leaf\n",
        "top.py": "from .sub.leaf import x\nfrom . import sub\nfrom .errors import E\n",
        "errors.py": "",
        "sub/__init__.py": "from .. import errors\nfrom . import leaf\n",
        "sub/leaf.py": "from ..errors import E\nfrom ..top import y\nfrom .. import helper\nimport pkg.sub\n",
    })
    graph = import_graph(folder, "pkg")
    assert set(graph) == {"pkg", "pkg.top", "pkg.errors", "pkg.sub", "pkg.sub.leaf"}
    assert set(graph["pkg"]) == {"pkg.top", "pkg.sub", "pkg.sub.leaf"}
    assert set(graph["pkg.top"]) == {"pkg.sub.leaf", "pkg", "pkg.sub", "pkg.errors"}
    # In a package's __init__, "." is the package itself: `from . import leaf` is pkg.sub.leaf.
    assert set(graph["pkg.sub"]) == {"pkg", "pkg.errors", "pkg.sub.leaf"}
    # `from .. import helper`: pkg has no module helper, so it is a name of the package pkg.
    assert set(graph["pkg.sub.leaf"]) == {"pkg.errors", "pkg.top", "pkg", "pkg.sub"}
    assert resolve_relative("pkg.sub.leaf", False, 2, "errors") == "pkg.errors"
    assert resolve_relative("pkg.sub", True, 1, None) == "pkg.sub"
    assert resolve_relative("pkg.sub", False, 1, "x") == "pkg.x"
    with pytest.raises(ValueError, match="above the top-level package"):
        resolve_relative("pkg.a", False, 2, "x")


def test_an_import_inside_a_function_counts_and_one_inside_a_docstring_does_not(tmp_path):
    folder = write_package(tmp_path, {
        "__init__.py": "",
        "lazy.py": '"""A module.\n\n>>> from pkg import eager\n"""\n\n\ndef load():\n'
                   '    """from .eager import nothing"""\n    if True:\n        from .eager import thing\n'
                   '    return thing\n',
        "eager.py": "thing = 1\n",
    })
    graph = import_graph(folder, "pkg")
    assert set(graph.edges) == {("pkg.lazy", "pkg.eager")}
    assert graph.edges["pkg.lazy", "pkg.eager"]["where"] == [f"{folder / 'lazy.py'}:10"]
    (record,) = package_imports(folder, "pkg")
    assert record.relative and record.target == "pkg.eager" and record.names == ("thing",)


def test_private_names_of_belief_are_found_through_imports_and_module_aliases(tmp_path):
    folder = write_package(tmp_path, {
        "__init__.py": "",
        "ok.py": "from belief import MassFunction, __version__\nimport belief.mass as mass\nmass.MassFunction.__name__\n"
                 "_local = 1\nother._private\n",
        "bad.py": "import belief.mass\nfrom belief import _hidden\nfrom belief._internal import thing\n"
                  "from belief import rules as r\n\n\ndef f():\n    return belief.mass._secret, r._table\n",
    })
    offenders = private_uses_of_belief(folder, "pkg")
    assert sorted(offenders) == sorted(f"{folder / 'bad.py'}:{line}: {what}" for line, what in [
        (2, "imports _hidden from belief"), (3, "imports belief._internal"), (8, "uses belief.mass._secret"),
        (8, "uses r._table")])


def test_an_absolute_import_of_the_package_inside_it_is_found(tmp_path):
    folder = write_package(tmp_path, {"__init__.py": "", "a.py": "from pkg.b import x\nfrom .b import y\n",
                                      "b.py": '"""\n>>> import pkg.a\n"""\nimport pkg\nimport pkgother\n'})
    assert sorted(absolute_imports_of_itself(folder, "pkg")) == [f"{folder / 'a.py'}:1: from pkg.b import x",
                                                                 f"{folder / 'b.py'}:4: import pkg"]
