"""Bhattacharyya coefficients of many windows against each colour cue's references, the windows sampled once.

The colour cues (:class:`~belief_tracking.cues.colour.ColourCue` and the subclasses that
keep its scoring) compare every particle's window with the targets' templates and q_FA.
Sampling a window's points is most of the cost, so cues that read the same bin image with
the same grid share it: :func:`window_similarities` samples every window once for all of them.
"""

from __future__ import annotations

import numpy as np

from .histograms import HISTOGRAM_BLOCK, filled_bins, sample_boxes, sample_slots, sparse_rho
from .observation import Observation, particle_sizes

__all__ = ["window_similarities"]


def window_similarities(cues: list, obs: Observation, states: np.ndarray, owner: np.ndarray) -> list[np.ndarray]:
    """ρ of every window with every reference (τ templates, then q_FA) of colour cues that share their features and grid.

    One (P, τ + 1) array per cue, in [0, 1]; each box is sampled once for all the cues.

    The bins that no pixel of the frame fills (with a positive weight) cannot be in any box,
    so the histograms are counted over the frame's own bins only, in their order (plus one
    slot, read against zero, for weightless points), which keeps the dense counts of a block
    a few times smaller and gives the same sums.
    """
    first = cues[0]
    features = first.frame_features(obs)
    bin_image, weights = features
    n_bins = first.config.n_bins
    present = np.flatnonzero(obs.scene_counts(bin_image, weights, n_bins) > 0)
    compact = np.full(n_bins, present.size, np.intp)
    compact[present] = np.arange(present.size)
    width = present.size + 1
    roots, rhos = [], []
    for cue in cues:
        cue.check_observation(obs)
        references = cue.references(obs, features)                          # (τ + 1, B)
        root = np.zeros((width, references.shape[0]))                       # (width, τ + 1), rows gathered
        root[:-1] = np.sqrt(references[:, present]).T
        roots.append(root)
        rhos.append(np.empty((states.shape[0], references.shape[0])))
    centres, sizes = states[:, :2], particle_sizes(obs, states, owner)
    masked = any(cue.masked for cue in cues)
    # Blocks keep every temporary of a block (its samples, its dense counts) small enough
    # for the allocator to serve from memory it already holds, whatever P.
    for start in range(0, states.shape[0], HISTOGRAM_BLOCK):
        block = slice(start, start + HISTOGRAM_BLOCK)
        sampling = sample_boxes(centres[block], sizes[block], first.config.samples, bin_image.shape, masked)
        slots = sample_slots(bin_image, sampling, width, compact)
        counted = [cue.block_counts(obs, features, sampling, slots, width) for cue in cues]
        # A mask only removes points, so the filled bins of an unmasked cue cover those of all.
        shared = next((filled_bins(counts.reshape(-1, width)) for cue, (counts, _) in zip(cues, counted)
                       if not cue.masked), None) if len(cues) > 1 else None
        for (counts, norms), root, rho in zip(counted, roots, rhos):
            rho[block] = sparse_rho(counts.reshape(-1, width), norms, root, shared)
    for rho in rhos:
        np.clip(rho, 0.0, 1.0, out=rho)
    return rhos
