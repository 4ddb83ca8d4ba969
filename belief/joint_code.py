"""Straight-line Python for the joint PCR5 / PCR6 of a few mass functions whose focal elements come back.

Joint PCR over s sources visits every tuple of their focal elements.  For a few dozen tuples
the visit itself costs more than the arithmetic: a loop looks up, tests and groups every
tuple anew on every call, and a table of positions (``itemgetter``, ``map``) touches an
object per group.  Once the same focal lists come back, :func:`pcr_function` writes the
whole combination out as one Python function of the sources' masses: one statement per
product, quotient and share, and one sum per result element, with the grouping of the
tuples fixed in the text.  It performs the same multiplications, additions and divisions as
the loop of :func:`belief.rules_single._pcr_joint_loop`, in the same order, and adds what
reaches one element with ``math.fsum`` (two terms with ``+``, which rounds alike), so the
results are the loop's to the last bit.

The text holds nothing but generated names and the operators; the functions are kept in a
bounded cache by focal lists and rule.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache
from itertools import product
from math import fsum

__all__ = ["pcr_function", "CODE_CACHE_SIZE"]

#: How many generated functions are kept (each is a few kilobytes of bytecode).
CODE_CACHE_SIZE = 256


def pcr_function(masks: Sequence[Sequence[int]], rule: str) -> tuple[Callable[..., list[float]], list[int]]:
    """The combination of sources of these focal lists as a function of their masses, and the targets it sums.

    Parameters
    ----------
    masks : sequence of sequence of int
        Each source's focal elements as hypothesis bit masks (unions of exclusive
        hypotheses), none empty.
    rule : {"pcr5", "pcr6"}

    Returns
    -------
    function, list of int
        ``function(masses_1, …, masses_s)`` takes each source's masses in the order of its
        masks and returns the sum that reaches each target, in the order of the targets.

    Examples
    --------
    >>> combine, targets = pcr_function([(1, 2), (1, 3)], "pcr6")
    >>> targets, [round(x, 12) for x in combine([0.6, 0.4], [0.5, 0.5])]
    ([1, 2], [0.711111111111, 0.288888888889])
    """
    return _generated(tuple(tuple(mk) for mk in masks), rule)


@lru_cache(maxsize=CODE_CACHE_SIZE)
def _generated(masks: tuple[tuple[int, ...], ...], rule: str) -> tuple[Callable[..., list[float]], list[int]]:
    writer = _Writer(len(masks))
    groups: dict[int, list[str]] = {}
    pcr5 = rule == "pcr5" and len(masks) > 2       # two distinct elements: PCR5 and PCR6 coincide
    for columns in product(*[range(len(mk)) for mk in masks]):
        elements = [mk[k] for mk, k in zip(masks, columns)]
        meet = -1
        for x in elements:
            meet &= x
        mass = writer.product(columns)
        if meet:
            groups.setdefault(meet, []).append(mass)
            continue
        if pcr5:
            # Each distinct element weighs the product of its sources' masses, in source order.
            weights: dict[int, list[int]] = {}
            for source, (x, k) in enumerate(zip(elements, columns)):
                weights.setdefault(x, []).append(source)
            parts = {x: " * ".join(writer.mass(i, columns[i]) for i in sources) for x, sources in weights.items()}
            named = {x: writer.assign(text) if " " in text else text for x, text in parts.items()}
            # Every group weight may have underflowed, and the product with them: the tuple then shares nothing.
            total = writer.assign(" + ".join(named.values()))
            factor = writer.assign(f"{mass} / {total} if {total} > 0.0 else 0.0")
            for x, weight in named.items():
                groups.setdefault(x, []).append(f"{factor} * {weight}")
        else:
            factor = writer.assign(f"{mass} / {writer.total(columns)}")
            for source, (x, k) in enumerate(zip(elements, columns)):
                groups.setdefault(x, []).append(f"{factor} * {writer.mass(source, k)}")
    sums = []
    for terms in groups.values():
        if len(terms) == 1:
            sums.append(terms[0])
        elif len(terms) == 2:
            sums.append(f"{terms[0]} + {terms[1]}")          # correctly rounded, as fsum of two is
        else:
            sums.append(f"fsum(({', '.join(terms)}))")
    function = writer.function(masks, sums)
    return function, list(groups)


class _Writer:
    """The statements of a generated function: masses unpacked, products and partial sums named once."""

    def __init__(self, sources: int) -> None:
        self.sources = sources
        self.lines: list[str] = []
        self.names: dict[str, str] = {}

    def mass(self, source: int, column: int) -> str:
        return f"m{source}_{column}"

    def assign(self, expression: str) -> str:
        """A name for the expression, computed once."""
        name = self.names.get(expression)
        if name is None:
            name = self.names[expression] = f"t{len(self.names)}"
            self.lines.append(f"    {name} = {expression}")
        return name

    def product(self, columns: Sequence[int]) -> str:
        """Π m_i(X_i), multiplied left to right, its prefixes shared between tuples."""
        value = self.mass(0, columns[0])
        for source in range(1, len(columns)):
            value = self.assign(f"{value} * {self.mass(source, columns[source])}")
        return value

    def total(self, columns: Sequence[int]) -> str:
        """Σ m_i(X_i), added left to right, its prefixes shared between tuples."""
        value = self.mass(0, columns[0])
        for source in range(1, len(columns)):
            value = self.assign(f"{value} + {self.mass(source, columns[source])}")
        return value

    def function(self, masks: Sequence[Sequence[int]], sums: Sequence[str]) -> Callable[..., list[float]]:
        arguments = [f"v{i}" for i in range(self.sources)]
        unpack = []
        for i, mk in enumerate(masks):
            names = ", ".join(self.mass(i, k) for k in range(len(mk)))
            unpack.append(f"    {names}, = v{i}")
        body = unpack + self.lines + [f"    return [{', '.join(sums)}]"]
        text = f"def combine({', '.join(arguments)}):\n" + "\n".join(body) + "\n"
        namespace = {"fsum": fsum}
        exec(compile(text, "<belief.joint_code>", "exec"), namespace)   # only generated names and operators
        return namespace["combine"]
