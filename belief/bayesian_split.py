"""The models of the closed forms for Bayesian sources, and where a batch's singletons sit in the frame.

:func:`exclusive_split` tells whether a model is in the class of :mod:`belief.bayesian` (hypotheses free among
themselves, plus exclusive ones) and how its hypotheses split; :func:`bayesian_layout` whether a focal list is
Bayesian, and :func:`dense_masses` reads such a batch in frame order.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from belief.batch import MassBatch
from belief.model import Model

__all__ = ["ExclusiveSplit", "exclusive_split", "BayesianLayout", "bayesian_layout", "dense_masses"]


@dataclass(frozen=True)
class ExclusiveSplit:
    """The hypotheses of a model split into free ones (O) and exclusive ones (E).

    Attributes
    ----------
    free : tuple of int
        Frame positions of O, in frame order; never empty (a lone hypothesis counts as free).
    exclusive : tuple of int
        Frame positions of E, in frame order.
    """

    free: tuple[int, ...]
    exclusive: tuple[int, ...]

    @property
    def size(self) -> int:
        return len(self.free) + len(self.exclusive)

    @cached_property
    def o_index(self):
        """Rows (or columns) of O in a frame-ordered array: a slice when they are contiguous (no copy)."""
        return _index(self.free)

    @cached_property
    def e_index(self):
        """Rows (or columns) of E in a frame-ordered array."""
        return _index(self.exclusive)

    @cached_property
    def position(self) -> np.ndarray:
        """For each frame position, its column in [O columns, E columns], shape (n,)."""
        out = np.empty(self.size, dtype=np.int64)
        out[list(self.free)] = np.arange(len(self.free))
        out[list(self.exclusive)] = len(self.free) + np.arange(len(self.exclusive))
        return out

    def inverse_cardinality(self, k: int) -> float:
        """1 / N_k = 2^(k − |O|), the inverse DSm cardinality of θ_S for |S| = k (no overflow for large |O|)."""
        return 2.0 ** (k - len(self.free))


def _index(positions: tuple[int, ...]):
    if positions and positions == tuple(range(positions[0], positions[-1] + 1)):
        return slice(positions[0], positions[-1] + 1)
    return np.array(positions, dtype=np.int64)


@lru_cache(maxsize=256)
def exclusive_split(model: Model) -> ExclusiveSplit | None:
    """Whether the closed forms apply to ``model``, and how its hypotheses split.

    The model must forbid exactly the pairs θ_e ∩ θ_j with e ∈ E and j ≠ e, for some set E
    of hypotheses: every other intersection is then non-empty.  When no hypothesis is
    free, one exclusive hypothesis is counted as free (alone in O, it is exclusive
    anyway), which keeps E as small as possible.

    Parameters
    ----------
    model : Model

    Returns
    -------
    ExclusiveSplit or None
        None for a frame of one hypothesis and for models outside the class.

    Examples
    --------
    >>> from belief import Frame, Model
    >>> exclusive_split(Model.for_targets(3))
    ExclusiveSplit(free=(0, 1, 2), exclusive=(3,))
    >>> exclusive_split(Model.shafer(Frame(["a", "b", "c"])))
    ExclusiveSplit(free=(0,), exclusive=(1, 2))
    >>> exclusive_split(Model.hybrid(Frame(["a", "b", "c"]), empty=["a&b"])) is None
    True
    """
    n = len(model.frame)
    if n < 2:
        return None
    forbidden = set(model.forbidden)
    if any(term.bit_count() != 2 for term in forbidden):
        return None
    exclusive = [i for i in range(n) if all((1 << i) | (1 << j) in forbidden for j in range(n) if j != i)]
    members = set(exclusive)
    expected = {(1 << i) | (1 << j) for i in exclusive for j in range(n) if j != i}
    if forbidden != expected:
        return None
    free = [i for i in range(n) if i not in members]
    if not free:
        free, exclusive = [exclusive[0]], exclusive[1:]
    return ExclusiveSplit(tuple(free), tuple(exclusive))


@dataclass(frozen=True)
class BayesianLayout:
    """Where a batch's columns sit in the frame: a Bayesian focal list."""

    columns: tuple[int, ...]     # frame position of each non-empty column
    kept: tuple[int, ...]        # which columns those are
    empty: int | None            # the ∅ column, if any
    identity: bool               # the focal list is θ_1 … θ_n in frame order


@lru_cache(maxsize=1024)
def bayesian_layout(key) -> BayesianLayout | None:
    """The layout of a focal list (a :class:`~belief.plan.FocalKey`), or None if it is not Bayesian."""
    columns, kept, empty = [], [], None
    for k, x in enumerate(key.focal):
        if not x.terms:
            empty = k
        elif len(x.terms) == 1 and x.terms[0].bit_count() == 1:
            columns.append(x.terms[0].bit_length() - 1)
            kept.append(k)
        else:
            return None
    if len(set(columns)) != len(columns):
        return None
    n = len(key.focal[0].frame) if key.focal else 0
    identity = empty is None and columns == list(range(n))
    return BayesianLayout(tuple(columns), tuple(kept), empty, identity)


def dense_masses(batch: MassBatch, layout: BayesianLayout, n: int) -> tuple[np.ndarray, np.ndarray | None]:
    """Masses of θ_1 … θ_n in frame order, shape (rows, n), and m(∅) if the batch has that column."""
    values = batch.values
    if layout.identity:
        return values, None
    out = np.zeros((values.shape[0], n))
    if layout.columns:
        out[:, list(layout.columns)] = values[:, list(layout.kept)]
    return out, (values[:, layout.empty] if layout.empty is not None else None)
