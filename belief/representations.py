"""Other representations of a belief function on 2^Θ, and two transformations.

On Shafer's model D^Θ is the power set 2^Θ, and a mass function is a vector of 2^n
numbers.  Here the entry at index ``i`` belongs to the subset whose hypotheses are the set
bits of ``i``: bit k stands for the k-th hypothesis of the frame, index 0 is ∅ and index
2^n - 1 is Θ (the binary order of Smets' fast Möbius transform).  A
:class:`~belief.mass.MassFunction` gives a vector of shape (2^n,), a
:class:`~belief.batch.MassBatch` of N rows an array of shape (N, 2^n).

Representations (Smets 1993, 1995; Denœux 2008), each of which determines m:

* the implicability b(A) = Σ_{B⊆A} m(B) = Bel(A) + m(∅) (:func:`implicability`);
* the commonality q(A) = Σ_{B⊇A} m(B) (:func:`commonality`);
* the conjunctive weights w of the canonical decomposition m = ∩_{A⊂Θ} A^{w(A)}, for
  non-dogmatic m (m(Θ) > 0) (:func:`conjunctive_weights`);
* the disjunctive weights v of m = ∪_{A≠∅} A_{v(A)}, for subnormal m (m(∅) > 0)
  (:func:`disjunctive_weights`).

The conjunctive rule multiplies commonalities and the disjunctive rule implicabilities
(Smets 1993), so b plays for ∪ the part that q plays for ∩.  The conversions are fast
Möbius transforms: O(n 2^n) operations per row, vectorised over the rows, for frames of up
to :data:`MAX_HYPOTHESES` hypotheses.  Each ``from_*`` function is the inverse of its
representation, ``from_commonality(commonality(m), model)`` gives back m.

Two transformations complete the module: the plausibility transform of Cobb & Shenoy
(2006), on any model, and the contextual discounting of Mercier, Quost & Denœux (2008).

Examples
--------
>>> from belief import Frame, MassFunction, Model
>>> shafer = Model.shafer(Frame(["a", "b"]))
>>> m = MassFunction({"a": 0.5, "a|b": 0.5}, model=shafer)
>>> mass_vector(m)                      # ∅, a, b, a|b
array([0. , 0.5, 0. , 0.5])
>>> commonality(m), implicability(m)
(array([1. , 1. , 0.5, 0.5]), array([0. , 0.5, 0. , 1. ]))
>>> conjunctive_weights(m)              # m = {a}^0.5: one simple mass function
array([1. , 0.5, 1. , 1. ])
>>> from_commonality(commonality(m), shafer) == m
True
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from typing import Union

import numpy as np

from belief.batch import MassBatch, resolve_model
from belief.errors import InvalidMassError, LatticeTooLargeError, ModelError, UndefinedTransformError
from belief.frame import Element, Frame
from belief.mass import MassFunction
from belief.model import Model

__all__ = [
    "MAX_HYPOTHESES",
    "subset_index",
    "subset_element",
    "mass_vector",
    "from_mass_vector",
    "implicability",
    "from_implicability",
    "commonality",
    "from_commonality",
    "conjunctive_weights",
    "from_conjunctive_weights",
    "disjunctive_weights",
    "from_disjunctive_weights",
    "plausibility_transform",
    "contextual_discount",
]

#: The largest frame the dense representations accept: 2^20 numbers per mass function.
MAX_HYPOTHESES = 20

Source = Union[MassFunction, MassBatch]

#: Masses of magnitude at most this are rounding noise of the transforms and become zeros.
_NOISE = 1e-13
#: A mass below -_NEGATIVE means the input was not the representation of a mass function.
_NEGATIVE = 1e-9


# -- checks and the dense layout ------------------------------------------------------------------
@lru_cache(maxsize=256)
def _shafer_of(frame: Frame) -> Model:
    return Model.shafer(frame)


def _require_shafer(model: Model, what: str) -> int:
    """The number of hypotheses, after checking that ``model`` is Shafer's model of a small enough frame."""
    if model != _shafer_of(model.frame):
        raise ModelError(
            f"{what} is defined on Shafer's model (the power set 2^Θ), not on the {model.kind} model; "
            "read the evidence under Shafer's model first (MassFunction.under(Model.shafer(frame)))"
        )
    n = len(model.frame)
    if n > MAX_HYPOTHESES:
        raise LatticeTooLargeError(
            f"{what} needs the 2^{n} subsets of the frame; at most {MAX_HYPOTHESES} hypotheses are supported"
        )
    return n


def _as_batch(m: Source) -> tuple[MassBatch, bool]:
    if isinstance(m, MassFunction):
        return m.batch(), True
    if isinstance(m, MassBatch):
        return m, False
    raise TypeError(f"expected a MassFunction or a MassBatch, got {type(m).__name__}")


def _dense(batch: MassBatch, what: str) -> np.ndarray:
    """The rows of a batch on Shafer's model as an (N, 2^n) array indexed by subset masks."""
    n = _require_shafer(batch.model, what)
    out = np.zeros((len(batch), 1 << n))
    model = batch.model
    for k, element in enumerate(batch.focal):
        out[:, model.reduce(element).hypotheses] += batch.values[:, k]
    return out


def _model_of(model) -> Model:
    """A Model, or Shafer's model of a frame given as a Frame or a list of names."""
    if isinstance(model, Model):
        return model
    return resolve_model(model, "shafer")


def _as_array(values, n: int, what: str, name: str) -> tuple[np.ndarray, bool]:
    """An (N, 2^n) float copy of a 1-D or 2-D input, and whether it was 1-D."""
    array = np.array(values, dtype=np.float64, copy=True)
    single = array.ndim == 1
    if single:
        array = array.reshape(1, -1)
    if array.ndim != 2 or array.shape[1] != 1 << n:
        raise InvalidMassError(f"{name} must have shape (2^n,) or (N, 2^n) with 2^n = {1 << n} for a frame of "
                               f"{n} hypotheses, got {np.shape(values)}")
    if not np.isfinite(array).all():
        raise InvalidMassError(f"{what}: {name} holds a value that is not a finite number")
    return array, single


def subset_index(model, proposition: Union[str, Element]) -> int:
    """The index of a subset in the dense vectors of this module.

    Bit k of the index is set when the k-th hypothesis of the frame belongs to the subset.

    Parameters
    ----------
    model : Model, Frame or list of str
        Shafer's model (a frame stands for Shafer's model over it).
    proposition : str or Element
        A subset of Θ, e.g. ``"a|c"``; intersections are empty on Shafer's model.

    Returns
    -------
    int

    Examples
    --------
    >>> subset_index(["a", "b", "c"], "a|c"), subset_index(["a", "b", "c"], "empty")
    (5, 0)
    """
    model = _model_of(model)
    _require_shafer(model, "subset_index")
    return model.reduce(proposition).hypotheses


def subset_element(model, index: int) -> Element:
    """The subset at ``index`` in the dense vectors of this module (inverse of :func:`subset_index`).

    >>> subset_element(["a", "b", "c"], 6)
    Element('b|c')
    """
    model = _model_of(model)
    n = _require_shafer(model, "subset_element")
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < 1 << n:
        raise InvalidMassError(f"a subset index of a frame of {n} hypotheses is an integer in [0, {(1 << n) - 1}], "
                               f"got {index!r}")
    return _subset_elements(model.frame, (int(index),))[0]


def _result(values: np.ndarray, model: Model, single: bool, what: str) -> Source:
    """Masses over 2^Θ (N, 2^n) as a MassFunction or MassBatch, rounding noise of the transforms removed.

    A mass below -1e-9 means that the input was not a representation of a mass function.
    Masses within :data:`_NOISE` of zero are the transforms' rounding noise (about 1e-15 in
    practice) and become exact zeros, so that no spurious focal element appears; each row is
    then divided by its sum.
    """
    bad = values < -_NEGATIVE
    if bad.any():
        row, col = map(int, np.argwhere(bad)[0])
        where = f" (row {row})" if values.shape[0] > 1 else ""
        raise InvalidMassError(f"{what}: the input is not that of a mass function, it gives "
                               f"m({subset_element(model, col)}) = {values[row, col]!r} < 0{where}")
    values = np.where(values <= _NOISE, 0.0, values)
    totals = values.sum(axis=1)
    off = ~(np.abs(totals - 1.0) <= 1e-9)
    if off.any():
        row = int(np.flatnonzero(off)[0])
        where = f" (row {row})" if values.shape[0] > 1 else ""
        raise InvalidMassError(f"{what}: the input is not that of a mass function, its masses sum to "
                               f"{float(totals[row])!r}{where}")
    values = values / totals[:, None]
    columns = np.flatnonzero((values != 0).any(axis=0))
    columns = columns[np.argsort(_canonical_rank(len(model.frame))[columns], kind="stable")]
    focal = _subset_elements(model.frame, tuple(columns.tolist()))
    batch = MassBatch(focal, values[:, columns], model=model, subnormal=True, validate=False)
    return batch[0] if single else batch


def _subset_elements(frame: Frame, masks: tuple[int, ...]) -> list[Element]:
    """The elements of the given subset masks (from a cached table of all subsets on small frames)."""
    n = len(frame)
    if n <= 12:
        table = _all_subsets(frame)
        return [table[c] for c in masks]
    return [Element(frame, [1 << i for i in range(n) if c >> i & 1]) for c in masks]


@lru_cache(maxsize=64)
def _all_subsets(frame: Frame) -> tuple[Element, ...]:
    n = len(frame)
    return tuple(Element(frame, [1 << i for i in range(n) if c >> i & 1]) for c in range(1 << n))


@lru_cache(maxsize=32)
def _canonical_rank(n: int) -> np.ndarray:
    """The position of every subset mask in the canonical order of elements (``Element.sort_key``).

    On Shafer's model that order is: fewer hypotheses first, then the tuples of hypothesis
    positions in lexicographic order, which is the bit-reversed mask in decreasing order.
    """
    masks = np.arange(1 << n, dtype=np.int64)
    reversed_masks = np.zeros_like(masks)
    for i in range(n):
        reversed_masks |= ((masks >> i) & 1) << (n - 1 - i)
    order = np.lexsort((-reversed_masks, np.bitwise_count(masks)))
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return rank


def _out(array: np.ndarray, single: bool) -> np.ndarray:
    return array[0] if single else array


# -- fast zeta and Möbius transforms over the subset lattice -----------------------------------------
# Each works in place on a C-contiguous (N, 2^n) array: one pass per hypothesis i, on the view
# (N, 2^(n-1-i), 2, 2^i) whose third axis is "hypothesis i absent / present".
def _passes(a: np.ndarray):
    rows, size = a.shape
    for i in range(size.bit_length() - 1):
        yield a.reshape(rows, -1, 2, 1 << i)


def _sum_subsets(a: np.ndarray) -> np.ndarray:
    """a(A) ← Σ_{B⊆A} a(B)."""
    for view in _passes(a):
        view[:, :, 1, :] += view[:, :, 0, :]
    return a


def _unsum_subsets(a: np.ndarray) -> np.ndarray:
    """Inverse of :func:`_sum_subsets`: a(A) ← Σ_{B⊆A} (-1)^{|A|-|B|} a(B)."""
    for view in _passes(a):
        view[:, :, 1, :] -= view[:, :, 0, :]
    return a


def _sum_supersets(a: np.ndarray) -> np.ndarray:
    """a(A) ← Σ_{B⊇A} a(B)."""
    for view in _passes(a):
        view[:, :, 0, :] += view[:, :, 1, :]
    return a


def _unsum_supersets(a: np.ndarray) -> np.ndarray:
    """Inverse of :func:`_sum_supersets`: a(A) ← Σ_{B⊇A} (-1)^{|B|-|A|} a(B)."""
    for view in _passes(a):
        view[:, :, 0, :] -= view[:, :, 1, :]
    return a


# -- mass vectors ------------------------------------------------------------------------------------
def mass_vector(m: Source) -> np.ndarray:
    """The masses of every subset of Θ, in the binary order of this module.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Under Shafer's model, on at most :data:`MAX_HYPOTHESES` hypotheses; m(∅) may be positive.

    Returns
    -------
    ndarray
        Shape (2^n,) for a mass function, (N, 2^n) for a batch of N rows.

    Raises
    ------
    ModelError
        Under any other model than Shafer's.
    LatticeTooLargeError
        For more than :data:`MAX_HYPOTHESES` hypotheses.

    Examples
    --------
    >>> from belief import MassFunction
    >>> mass_vector(MassFunction({"b": 0.25, "a|b": 0.75}, frame=["a", "b"], model="shafer"))
    array([0.  , 0.  , 0.25, 0.75])
    """
    batch, single = _as_batch(m)
    return _out(_dense(batch, "mass_vector"), single)


def from_mass_vector(values, model) -> Source:
    """The mass function (1-D input) or batch (2-D input) with these masses over 2^Θ.

    Parameters
    ----------
    values : array_like, shape (2^n,) or (N, 2^n)
        Masses in the order of :func:`mass_vector`; each row sums to one.
    model : Model, Frame or list of str
        Shafer's model (a frame stands for Shafer's model over it).

    Returns
    -------
    MassFunction or MassBatch
        Subnormal when m(∅) > 0.

    Examples
    --------
    >>> from_mass_vector([0.0, 0.2, 0.0, 0.8], ["a", "b"])
    MassFunction({'a': 0.2, 'a|b': 0.8}, frame=['a', 'b'])
    """
    model = _model_of(model)
    n = _require_shafer(model, "from_mass_vector")
    array, single = _as_array(values, n, "from_mass_vector", "the mass vector")
    return _result(array, model, single, "from_mass_vector")


# -- implicability and commonality ----------------------------------------------------------------
def implicability(m: Source) -> np.ndarray:
    """The implicability function b(A) = Σ_{B⊆A} m(B) = Bel(A) + m(∅) of every subset A of Θ.

    Smets (1993) calls b the implicability; the disjunctive rule multiplies it, b_{1∪2} = b_1 b_2.
    Pls(A) = 1 - b(Θ \\ A).

    Parameters
    ----------
    m : MassFunction or MassBatch
        Under Shafer's model (see :func:`mass_vector`).

    Returns
    -------
    ndarray
        Shape (2^n,) or (N, 2^n), in the order of :func:`mass_vector`.

    Examples
    --------
    >>> from belief import MassFunction
    >>> m = MassFunction({"empty": 0.1, "a": 0.3, "b|c": 0.6}, frame=["a", "b", "c"], model="shafer",
    ...                  subnormal=True)
    >>> implicability(m).round(12)     # ∅, a, b, a|b, c, a|c, b|c, Θ
    array([0.1, 0.4, 0.1, 0.4, 0.1, 0.4, 0.7, 1. ])
    """
    batch, single = _as_batch(m)
    return _out(_sum_subsets(_dense(batch, "implicability")), single)


def from_implicability(b, model) -> Source:
    """The mass function whose implicability is ``b`` (inverse of :func:`implicability`).

    m(A) = Σ_{B⊆A} (-1)^{|A|-|B|} b(B), the Möbius inverse (Smets 1993).

    Parameters
    ----------
    b : array_like, shape (2^n,) or (N, 2^n)
        In the order of :func:`mass_vector`, with b(Θ) = 1.
    model : Model, Frame or list of str
        Shafer's model.

    Returns
    -------
    MassFunction or MassBatch
        For a 1-D or a 2-D ``b``.

    Raises
    ------
    InvalidMassError
        If ``b`` is not the implicability of a mass function (a negative mass, b(Θ) ≠ 1).

    Examples
    --------
    >>> from_implicability([0.0, 0.3, 0.0, 1.0], ["a", "b"])
    MassFunction({'a': 0.3, 'a|b': 0.7}, frame=['a', 'b'])
    """
    model = _model_of(model)
    n = _require_shafer(model, "from_implicability")
    array, single = _as_array(b, n, "from_implicability", "b")
    return _result(_unsum_subsets(array), model, single, "from_implicability")


def commonality(m: Source) -> np.ndarray:
    """The commonality function q(A) = Σ_{B⊇A} m(B) of every subset A of Θ.

    The conjunctive rule multiplies commonalities, q_{1∩2} = q_1 q_2 (Smets 1993); q(∅) = 1.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Under Shafer's model (see :func:`mass_vector`).

    Returns
    -------
    ndarray
        Shape (2^n,) or (N, 2^n), in the order of :func:`mass_vector`.

    Examples
    --------
    >>> from belief import MassFunction
    >>> m = MassFunction({"a": 0.3, "b|c": 0.6, "a|b|c": 0.1}, frame=["a", "b", "c"], model="shafer")
    >>> commonality(m).round(12)       # ∅, a, b, a|b, c, a|c, b|c, Θ
    array([1. , 0.4, 0.7, 0.1, 0.7, 0.1, 0.7, 0.1])
    """
    batch, single = _as_batch(m)
    return _out(_sum_supersets(_dense(batch, "commonality")), single)


def from_commonality(q, model) -> Source:
    """The mass function whose commonality is ``q`` (inverse of :func:`commonality`).

    m(A) = Σ_{B⊇A} (-1)^{|B|-|A|} q(B) (Smets 1993).

    Parameters
    ----------
    q : array_like, shape (2^n,) or (N, 2^n)
        In the order of :func:`mass_vector`, with q(∅) = 1.
    model : Model, Frame or list of str
        Shafer's model.

    Returns
    -------
    MassFunction or MassBatch

    Raises
    ------
    InvalidMassError
        If ``q`` is not the commonality of a mass function.

    Examples
    --------
    >>> from_commonality([1.0, 1.0, 0.4, 0.4], ["a", "b"])
    MassFunction({'a': 0.6, 'a|b': 0.4}, frame=['a', 'b'])
    """
    model = _model_of(model)
    n = _require_shafer(model, "from_commonality")
    array, single = _as_array(q, n, "from_commonality", "q")
    return _result(_unsum_supersets(array), model, single, "from_commonality")


# -- canonical decompositions ---------------------------------------------------------------------------
def _require_positive(values: np.ndarray, what: str, kind: str, quantity: str) -> None:
    """Refuse rows where ``quantity`` (m(Θ) or m(∅), one value per row) is not positive."""
    bad = ~(values > 0)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        where = f" (row {row})" if values.size > 1 else ""
        raise UndefinedTransformError(f"{what} is defined for {kind} mass functions ({quantity} > 0) only; "
                                      f"this one has {quantity} = 0{where}")


def _log_conjunctive_weights(dense: np.ndarray, what: str) -> np.ndarray:
    """ln w over 2^Θ from masses (N, 2^n): ln w(A) = -Σ_{B⊇A} (-1)^{|B|-|A|} ln q(B), ln w(Θ) = 0."""
    _require_positive(dense[:, -1], what, "non-dogmatic", "m(Θ)")
    log_w = _unsum_supersets(np.log(_sum_supersets(dense)))
    np.negative(log_w, out=log_w)
    log_w[:, -1] = 0.0
    return log_w


def _masses_from_log_conjunctive_weights(log_w: np.ndarray) -> np.ndarray:
    """Masses (N, 2^n) from ln w: ln q(A) = Σ_{B⊉A} ln w(B), then the Möbius inverse of q."""
    log_w = log_w.copy()
    log_w[:, -1] = 0.0
    above = _sum_supersets(log_w)                        # Σ_{B⊇A} ln w(B)
    log_q = above[:, :1] - above                         # Σ_B ln w(B) - Σ_{B⊇A} ln w(B)
    return _unsum_supersets(np.exp(log_q))


def _log_disjunctive_weights(dense: np.ndarray, what: str) -> np.ndarray:
    """ln v over 2^Θ from masses (N, 2^n): ln v(A) = -Σ_{B⊆A} (-1)^{|A|-|B|} ln b(B), ln v(∅) = 0."""
    _require_positive(dense[:, 0], what, "subnormal", "m(∅)")
    log_v = _unsum_subsets(np.log(_sum_subsets(dense)))
    np.negative(log_v, out=log_v)
    log_v[:, 0] = 0.0
    return log_v


def _masses_from_log_disjunctive_weights(log_v: np.ndarray) -> np.ndarray:
    """Masses (N, 2^n) from ln v: ln b(B) = Σ_{A⊄B} ln v(A), then the Möbius inverse of b."""
    log_v = log_v.copy()
    log_v[:, 0] = 0.0
    below = _sum_subsets(log_v)                          # Σ_{A⊆B} ln v(A)
    log_b = below[:, -1:] - below
    return _unsum_subsets(np.exp(log_b))


def _weights_array(weights, n: int, what: str, name: str, skip: int) -> tuple[np.ndarray, bool]:
    array, single = _as_array(weights, n, what, name)
    array[:, skip] = 1.0
    bad = ~(array > 0)
    if bad.any():
        row, col = map(int, np.argwhere(bad)[0])
        raise InvalidMassError(f"{what}: the weights must be positive, got {array[row, col]!r} at index {col}")
    return array, single


def conjunctive_weights(m: Source) -> np.ndarray:
    """The conjunctive weights w(A), A ⊂ Θ, of the canonical decomposition of a non-dogmatic m.

    w(A) = Π_{B⊇A} q(B)^{(-1)^{|B|-|A|+1}} for A ≠ Θ, so that m is the conjunctive combination
    of the (generalised) simple mass functions A^{w(A)}, which give 1 - w(A) to A and w(A) to Θ:
    m = ∩_{A⊂Θ} A^{w(A)} (Smets 1995; Denœux 2008).  w(∅) is included (it is not 1
    in general, even for a normal m).  Weights above 1 are allowed: A^w is then not a mass
    function, but the combination is.  By convention w(Θ) = 1 (Θ^w is vacuous for every w).

    Parameters
    ----------
    m : MassFunction or MassBatch
        Under Shafer's model (see :func:`mass_vector`), with m(Θ) > 0 in every row.

    Returns
    -------
    ndarray
        Shape (2^n,) or (N, 2^n), in the order of :func:`mass_vector`; every weight is positive.

    Raises
    ------
    UndefinedTransformError
        For a dogmatic mass function (m(Θ) = 0).
    ModelError, LatticeTooLargeError
        As :func:`mass_vector`.

    Examples
    --------
    {a}^0.6 ∩ {b}^0.5 on Θ = {a, b}: m = {a: .2, b: .3, a∪b: .3} and m(∅) = .4 · .5 = .2;
    the decomposition gives back the two weights (and 1 elsewhere).

    >>> from belief import MassFunction
    >>> m = MassFunction({"empty": 0.2, "a": 0.2, "b": 0.3, "a|b": 0.3}, frame=["a", "b"], model="shafer",
    ...                  subnormal=True)
    >>> conjunctive_weights(m).round(12)
    array([1. , 0.6, 0.5, 1. ])
    """
    batch, single = _as_batch(m)
    dense = _dense(batch, "conjunctive_weights")
    return _out(np.exp(_log_conjunctive_weights(dense, "conjunctive_weights")), single)


def from_conjunctive_weights(w, model) -> Source:
    """The mass function ∩_{A⊂Θ} A^{w(A)} (inverse of :func:`conjunctive_weights`).

    q(A) = Π_{B⊂Θ, A⊄B} w(B), then m is the Möbius inverse of q.

    Parameters
    ----------
    w : array_like, shape (2^n,) or (N, 2^n)
        Positive weights in the order of :func:`mass_vector`; the entry of Θ is not used.
    model : Model, Frame or list of str
        Shafer's model.

    Returns
    -------
    MassFunction or MassBatch

    Raises
    ------
    InvalidMassError
        For a weight that is not positive, or weights that give a negative mass.

    Examples
    --------
    >>> m = from_conjunctive_weights([1.0, 0.6, 0.5, 1.0], ["a", "b"])
    >>> {e: round(v, 12) for e, v in m.to_mapping().items()}
    {'empty': 0.2, 'a': 0.2, 'b': 0.3, 'a|b': 0.3}
    """
    model = _model_of(model)
    n = _require_shafer(model, "from_conjunctive_weights")
    array, single = _weights_array(w, n, "from_conjunctive_weights", "w", -1)
    return _result(_masses_from_log_conjunctive_weights(np.log(array)), model, single, "from_conjunctive_weights")


def disjunctive_weights(m: Source) -> np.ndarray:
    """The disjunctive weights v(A), A ≠ ∅, of a subnormal m (Denœux 2008).

    v(A) = Π_{B⊆A} b(B)^{(-1)^{|A|-|B|+1}} for A ≠ ∅, so that m is the disjunctive combination
    of the negative simple mass functions A_{v(A)}, which give v(A) to ∅ and 1 - v(A) to A:
    m = ∪_{A≠∅} A_{v(A)}.  This is the conjunctive decomposition of the negation m̄(A) = m(Θ \\ A)
    read back: v(A) = w̄(Θ \\ A).  By convention v(∅) = 1.

    Parameters
    ----------
    m : MassFunction or MassBatch
        Under Shafer's model (see :func:`mass_vector`), with m(∅) > 0 in every row.

    Returns
    -------
    ndarray
        Shape (2^n,) or (N, 2^n), in the order of :func:`mass_vector`; every weight is positive.

    Raises
    ------
    UndefinedTransformError
        For a mass function with m(∅) = 0.
    ModelError, LatticeTooLargeError
        As :func:`mass_vector`.

    Examples
    --------
    {a}_0.6 ∪ {b}_0.5 on Θ = {a, b}: m(∅) = .6 · .5 = .3, m(a) = .4 · .5 = .2,
    m(b) = .6 · .5 = .3 and m(a ∪ b) = .4 · .5 = .2.

    >>> from belief import MassFunction
    >>> m = MassFunction({"empty": 0.3, "a": 0.2, "b": 0.3, "a|b": 0.2}, frame=["a", "b"], model="shafer",
    ...                  subnormal=True)
    >>> disjunctive_weights(m).round(12)
    array([1. , 0.6, 0.5, 1. ])
    """
    batch, single = _as_batch(m)
    dense = _dense(batch, "disjunctive_weights")
    return _out(np.exp(_log_disjunctive_weights(dense, "disjunctive_weights")), single)


def from_disjunctive_weights(v, model) -> Source:
    """The mass function ∪_{A≠∅} A_{v(A)} (inverse of :func:`disjunctive_weights`).

    b(B) = Π_{A≠∅, A⊄B} v(A), then m is the Möbius inverse of b.

    Parameters
    ----------
    v : array_like, shape (2^n,) or (N, 2^n)
        Positive weights in the order of :func:`mass_vector`; the entry of ∅ is not used.
    model : Model, Frame or list of str
        Shafer's model.

    Returns
    -------
    MassFunction or MassBatch

    Raises
    ------
    InvalidMassError
        For a weight that is not positive, or weights that give a negative mass.

    Examples
    --------
    >>> m = from_disjunctive_weights([1.0, 0.6, 0.5, 1.0], ["a", "b"])
    >>> {e: round(v, 12) for e, v in m.to_mapping().items()}
    {'empty': 0.3, 'a': 0.2, 'b': 0.3, 'a|b': 0.2}
    """
    model = _model_of(model)
    n = _require_shafer(model, "from_disjunctive_weights")
    array, single = _weights_array(v, n, "from_disjunctive_weights", "v", 0)
    return _result(_masses_from_log_disjunctive_weights(np.log(array)), model, single, "from_disjunctive_weights")


# -- transformations -----------------------------------------------------------------------------------
def plausibility_transform(m: Source) -> np.ndarray:
    """The plausibility transform P(θ) = Pls(θ) / Σ_φ Pls(φ) (Cobb & Shenoy 2006).

    Pls is W (9) under the mass function's own model, so the transform exists on every model
    (under the free model every hypothesis meets every non-empty element).  m(∅) does not
    count in Pls, so a subnormal m has the transform of its normalisation.  On Shafer's
    model the transform commutes with Dempster's rule: the transform of m1 ⊕ m2 is the
    normalised product of the transforms (Cobb & Shenoy 2006).

    Parameters
    ----------
    m : MassFunction or MassBatch
        Under any model.

    Returns
    -------
    ndarray
        Shape (n,) for a mass function, (N, n) for a batch, in frame order; each row sums to one.

    Raises
    ------
    UndefinedTransformError
        If every hypothesis has plausibility 0 (all the mass on ∅ or on empty hypotheses).

    Examples
    --------
    Pls(a) = .5 + .3 = .8, Pls(b) = .2 + .3 = .5, Pls(c) = .3, so P = (.8, .5, .3) / 1.6.

    >>> from belief import MassFunction
    >>> m = MassFunction({"a": 0.5, "b": 0.2, "a|b|c": 0.3}, frame=["a", "b", "c"], model="shafer")
    >>> plausibility_transform(m).round(12)
    array([0.5   , 0.3125, 0.1875])
    """
    batch, single = _as_batch(m)
    pls = batch.pls(list(batch.frame.singletons))
    totals = pls.sum(axis=1)
    dead = ~(totals > 0)
    if dead.any():
        where = f" (row {int(np.flatnonzero(dead)[0])})" if len(batch) > 1 else ""
        raise UndefinedTransformError("the plausibility transform is undefined: every hypothesis has "
                                      f"plausibility 0{where}")
    return _out(pls / totals[:, None], single)


def _discount_rates(rates, frame: Frame, rows: int) -> np.ndarray:
    """The discount rates as an (R, n) array, R = 1 or the number of rows."""
    n = len(frame)
    if isinstance(rates, Mapping):
        array = np.empty(n)
        seen = set()
        for key, value in rates.items():
            if not isinstance(key, str):
                raise InvalidMassError(f"discount rates are keyed by hypothesis names, got {key!r}")
            index = frame.index(key)              # UnknownHypothesisError for a name not in the frame
            array[index] = _rate(value, key)
            seen.add(index)
        missing = [frame.hypotheses[i] for i in range(n) if i not in seen]
        if missing:
            raise InvalidMassError(f"contextual discounting needs a rate for every hypothesis; missing: "
                                   f"{', '.join(missing)} (give 0 to keep the source as it is in that context)")
        return array.reshape(1, n)
    if isinstance(rates, (str, bytes)):
        raise InvalidMassError(f"discount rates must be a mapping of hypothesis names to rates or an array, "
                               f"got {rates!r}")
    try:
        array = np.array(rates, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidMassError(f"discount rates must be numbers in [0, 1], got {rates!r}") from None
    if array.ndim == 1:
        array = array.reshape(1, -1)
    if array.ndim != 2 or array.shape[1] != n or array.shape[0] not in (1, rows):
        raise InvalidMassError(f"discount rates must have shape ({n},) or ({rows}, {n}) (one rate per hypothesis "
                               f"of the frame, in frame order), got {np.shape(rates)}")
    bad = ~((array >= 0) & (array <= 1))
    if bad.any():
        row, col = map(int, np.argwhere(bad)[0])
        raise InvalidMassError(f"the discount rate of {frame.hypotheses[col]} must be in [0, 1], "
                               f"got {array[row, col]!r}")
    return array


def _rate(value, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InvalidMassError(f"the discount rate of {name} must be a number in [0, 1], got {value!r}")
    value = float(value)
    if not (0.0 <= value <= 1.0):
        raise InvalidMassError(f"the discount rate of {name} must be in [0, 1], got {value!r}")
    return value


def contextual_discount(m: Source, rates) -> Source:
    """Contextual discounting with one discount rate α_θ per hypothesis (Mercier, Quost & Denœux 2008).

    The source is reliable with probability β_θ = 1 - α_θ when the truth is θ.  The discounted
    mass function is the disjunctive combination of m with one mass function per hypothesis,
    m_θ(∅) = 1 - α_θ and m_θ({θ}) = α_θ:

        m^α = m ∪ m_{θ_1} ∪ … ∪ m_{θ_n},   that is   b^α(A) = b(A) Π_{θ∉A} (1 - α_θ)

    (Mercier et al. 2008, the finest partition of Θ into contexts).  All rates 0 keep m, all
    rates 1 give the vacuous mass function, and Pls^α(θ) = 1 - (1 - α_θ)(1 - Pls(θ)) for a
    normal m.  Equal rates α_θ = α are *not* Shafer's discounting by α (that is the coarsest
    partition, one context Θ: :meth:`MassFunction.discount` with reliability 1 - α).

    Parameters
    ----------
    m : MassFunction or MassBatch
        Under Shafer's model (see :func:`mass_vector`).
    rates : mapping of str to float, or array_like of shape (n,) or (N, n)
        α_θ ∈ [0, 1] for every hypothesis of the frame: a mapping from hypothesis names, or
        an array in frame order (one row per row of the batch, or one row for all).

    Returns
    -------
    MassFunction or MassBatch
        Like ``m``.

    Raises
    ------
    InvalidMassError
        A rate outside [0, 1] or not a number, a hypothesis without a rate, an array of the
        wrong shape.
    UnknownHypothesisError
        A rate for a name that is not a hypothesis of the frame.
    ModelError, LatticeTooLargeError
        As :func:`mass_vector`.

    Examples
    --------
    A sensor that says "a" (m(a) = 1) but is unreliable (α = 0.4) when the truth is b:
    m^α = m ∪ m_b gives .6 to a and .4 to a ∪ b; its rate for c does not matter here.

    >>> from belief import MassFunction
    >>> m = MassFunction({"a": 1.0}, frame=["a", "b", "c"], model="shafer")
    >>> discounted = contextual_discount(m, {"a": 0.0, "b": 0.4, "c": 0.0})
    >>> {e: round(v, 12) for e, v in discounted.to_mapping().items()}
    {'a': 0.6, 'a|b': 0.4}
    """
    batch, single = _as_batch(m)
    dense = _dense(batch, "contextual_discount")
    n = len(batch.frame)
    alpha = _discount_rates(rates, batch.frame, len(batch))
    factor = np.ones((alpha.shape[0], 1 << n))
    for i, view in enumerate(_passes(factor)):
        view[:, :, 0, :] *= (1.0 - alpha[:, i])[:, None, None]      # θ_i ∉ A: times β_i
    b = _sum_subsets(dense) * factor
    return _result(_unsum_subsets(b), batch.model, single, "contextual_discount")
