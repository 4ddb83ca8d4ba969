"""Griffe extension for the documentation site: Sphinx roles in docstrings become links.

The docstrings name other objects with Sphinx roles such as ``:class:`MassBatch``` or
``:func:`~belief.rules.combine```.  Markdown has no such syntax, so this extension rewrites
each role, once the packages are loaded, into an optional cross-reference: a link to the
object's entry in the API reference when the site documents it, and plain code otherwise.
A leading ``~`` keeps only the last component of the name as the link text, as in Sphinx.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:class|func|meth|data|mod|attr|exc|obj):`(?P<tilde>~?)(?P<target>[^`<>\s]+)`")
PACKAGES = ("belief", "belief_tracking")


def _resolve(obj: griffe.Object, target: str) -> str | None:
    """The full path of ``target`` as seen from ``obj``, or None when it is not ours."""
    if target.split(".")[0] in PACKAGES:
        return target
    head, _, rest = target.partition(".")
    try:
        path = obj.resolve(head)
    except (griffe.NameResolutionError, AttributeError, KeyError):
        return None
    return f"{path}.{rest}" if rest else path


def _rewrite(obj: griffe.Object) -> None:
    docstring = obj.docstring
    if docstring is None or ":" not in docstring.value:
        return

    def replace(match: re.Match) -> str:
        target = match["target"]
        title = target.rsplit(".", 1)[-1] if match["tilde"] else target
        path = _resolve(obj, target)
        if path is None:
            return f"`{title}`"
        return f'<autoref identifier="{path}" optional><code>{title}</code></autoref>'

    docstring.value = ROLE.sub(replace, docstring.value)


def _walk(obj: Any, seen: set[int]) -> None:
    if id(obj) in seen or obj.is_alias:
        return
    seen.add(id(obj))
    _rewrite(obj)
    for member in obj.members.values():
        if not member.is_alias:
            _walk(member, seen)


class SphinxRoles(griffe.Extension):
    """Rewrite the Sphinx roles of every docstring of a loaded package."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        _walk(pkg, set())
