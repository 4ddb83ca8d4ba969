"""The registry of combination rules: the table that :func:`register_rule` fills.

A rule is a plain function over batches (see :mod:`belief.rules`); registered under a name, it is what
:func:`~belief.rules.combine` and ``belief combine --rule`` call.  The built-in rules register themselves in
:mod:`belief.rules_classic`, :mod:`belief.rules_pcr` and :mod:`belief.rules_r`, further ones in
:mod:`belief.extra_rules`; :func:`~belief.rules.get_rule` looks them up.  The table depends on none of them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from belief.batch import MassBatch

__all__ = ["RULES", "ALIASES", "RuleInfo", "RuleFunction", "register_rule"]


RuleFunction = Callable[..., MassBatch]


@dataclass(frozen=True)
class RuleInfo:
    """A registered combination rule.

    Attributes
    ----------
    name : str
    function : callable
        ``function(sources: list[MassBatch], model: Model, **options) -> MassBatch``.
    summary : str
        One line for ``belief rules``.
    associative : bool
        Whether folding pairwise gives the joint result.
    keeps_conflict : bool
        Whether the result may hold mass on ∅.
    aliases : tuple of str
    options : tuple of str
        Keyword options the rule accepts.
    """

    name: str
    function: RuleFunction
    summary: str
    associative: bool
    keeps_conflict: bool = False
    aliases: tuple[str, ...] = ()
    options: tuple[str, ...] = field(default=())


#: The registered rules by name, in registration order.
RULES: dict[str, RuleInfo] = {}
#: Every name and alias of a rule, as :func:`~belief.rules.get_rule` spells them (lower case, "_" for "-"),
#: to the rule's name.
ALIASES: dict[str, str] = {}


def register_rule(name: str, *, summary: str, associative: bool, keeps_conflict: bool = False,
                  aliases: Sequence[str] = (), options: Sequence[str] = ()):
    """Decorator that adds a rule function to the registry under ``name`` and ``aliases``."""

    def decorate(function: RuleFunction) -> RuleFunction:
        info = RuleInfo(name, function, summary, associative, keeps_conflict, tuple(aliases), tuple(options))
        RULES[name] = info
        for key in (name, *aliases):
            # The spelling get_rule looks names up by: case and "-" / "_" do not matter.
            ALIASES[key.lower().replace("-", "_")] = name
        return function

    return decorate
