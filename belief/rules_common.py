"""What every combination does before and after its rule: the sources read as batches, the result rescaled.

:func:`prepare_sources` checks the sources of :func:`~belief.rules.combine` (mass functions or batches under one
frame and model, whose rows broadcast) and reads them as batches under the fusion model; :func:`renormalised`
rescales a result whose masses sum to one only within what the sources' tolerance explains.
"""

from __future__ import annotations

from collections.abc import Sequence
from math import fsum
from typing import Union

import numpy as np

from belief.batch import SUM_TOLERANCE, MassBatch, check_refines, trusted_batch
from belief.errors import FrameError, InvalidMassError, ModelError
from belief.mass import MassFunction, mass_from_masks
from belief.model import Model

__all__ = ["Source", "prepare_sources", "check_same_model", "RESULT_TOLERANCE", "renormalised"]

#: What :func:`~belief.rules.combine` takes and gives.
Source = Union[MassFunction, MassBatch]


def prepare_sources(sources: Sequence[Source], model: Model | None) -> tuple[list[MassBatch], Model, bool]:
    """The sources as batches, the fusion model, and whether every source is a mass function.

    ``sources`` may also be one list or tuple of them.  Raises as :func:`~belief.rules.combine` says: fewer
    than two sources, another type, another frame or model, batches of different numbers of rows, a fusion
    model that is not stricter than the sources'.
    """
    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):
        sources = list(sources[0])
    if len(sources) < 2:
        raise InvalidMassError(f"combination needs at least two sources, got {len(sources)}")
    single = all(isinstance(s, MassFunction) for s in sources)
    batches: list[MassBatch] = []
    for k, s in enumerate(sources):
        if isinstance(s, MassFunction):
            batches.append(s.batch())
        elif isinstance(s, MassBatch):
            batches.append(s)
        else:
            raise TypeError(f"source {k + 1} is a {type(s).__name__}, not a MassFunction or MassBatch")
    source_model = check_same_model(batches)
    rows = {len(b) for b in batches} - {1}
    if len(rows) > 1:
        raise InvalidMassError(f"batches have different numbers of rows: {sorted(rows)}")
    if model is None:
        model = source_model
    else:
        check_refines(source_model, model)
    return batches, model, single


def check_same_model(batches: Sequence[MassBatch]) -> Model:
    """The shared model of the batches; FrameError or ModelError if they differ."""
    model = batches[0].model
    for k, b in enumerate(batches[1:], start=2):
        if b.model != model:
            if b.frame != model.frame:
                raise FrameError(f"source {k} has the frame {list(b.frame.hypotheses)}, "
                                 f"source 1 has {list(model.frame.hypotheses)}")
            raise ModelError(f"source {k} was elicited under the {b.model.kind} model and source 1 under the "
                             f"{model.kind} model; read them under one model first (MassFunction.under)")
    return model


#: A result whose masses sum to one within this is left as it is; others are rescaled to sum to one.
RESULT_TOLERANCE = 1e-13


def renormalised(result: Source, sources: int) -> Source:
    """The result with every row rescaled to sum to one where it is off by more than :data:`RESULT_TOLERANCE`.

    Sources are accepted when they sum to one within
    :data:`~belief.batch.SUM_TOLERANCE`, and the masses of a combination sum to the
    product of the sources' sums: left alone, the error would compound over repeated
    combinations until a result is no longer a valid input.  Rows within the tolerance
    are returned bit for bit, and so are rows off by more than the ``sources`` sums can
    explain: that is a fault of the rule, which :func:`belief.testing.check_rule` must see.
    """
    reach = 2 * sources * SUM_TOLERANCE
    if type(result) is MassFunction:
        floats = result._floats
        if floats is not None:
            total = fsum(floats)
            if not RESULT_TOLERANCE < abs(total - 1.0) <= reach:
                return result
            if result._masks is not None:
                return mass_from_masks(result.model, result._masks, tuple([x / total for x in floats]),
                                                result._loose)
        else:
            total = fsum(result.values.tolist())
            if not RESULT_TOLERANCE < abs(total - 1.0) <= reach:
                return result
            if result._masks is not None:
                return mass_from_masks(result.model, result._masks, result.values / total)
        return renormalised(result.batch(), sources)[0]
    values = result.values
    if values.shape[0] == 1 and values.shape[1] <= 64:
        if not RESULT_TOLERANCE < abs(fsum(values[0].tolist()) - 1.0) <= reach:
            return result
    totals = values.sum(axis=1)
    error = np.abs(totals - 1.0)
    off = (error > RESULT_TOLERANCE) & (error <= reach)
    if not off.any():
        return result
    scale = np.where(off, totals, 1.0)
    return trusted_batch(result.model, result.focal, values / scale[:, None], canonical=result._canonical)
