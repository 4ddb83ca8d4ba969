"""Pictures of one mass function: its masses, the Bel/BetP/Pls interval of every hypothesis, its focal elements.

:func:`plot_mass` draws, side by side:

* the mass m(A) of every focal element (W (1));
* for every hypothesis θ, the interval [Bel(θ), Pls(θ)] (W (8), W (9)) with the pignistic
  probability BetP(θ) (SPEC A.5) marked inside it;
* for frames of at most four hypotheses, the Hasse diagram of the focal elements: each
  focal element is a node labelled with its mass, placed by its DSm cardinality, with an
  edge from A to B when A ⊂ B and no focal element lies strictly between them.

matplotlib (the ``plot`` extra) draws on its own canvas, so no global backend is touched.
"""

from __future__ import annotations

from pathlib import Path
from typing import Union

import numpy as np

from belief.errors import BeliefError, FormatError
from belief.install import install_command
from belief.frame import Element
from belief.mass import MassFunction

__all__ = ["plot_mass", "focal_hasse_edges", "MAX_HASSE_HYPOTHESES", "MAX_PLOTTED_FOCAL", "MAX_PLOTTED_HYPOTHESES",
           "MissingPlotExtraError"]

#: Frames up to this many hypotheses get the Hasse diagram of their focal elements.
MAX_HASSE_HYPOTHESES = 4
#: Focal elements drawn as bars: beyond it, the largest masses and one bar for the rest.
MAX_PLOTTED_FOCAL = 30
#: Hypotheses drawn with their Bel, BetP and Pls: beyond it, those of the largest BetP.
MAX_PLOTTED_HYPOTHESES = 40


class MissingPlotExtraError(BeliefError, ModuleNotFoundError):
    """matplotlib, needed to draw, is not installed; the message says how to install it."""


def _matplotlib():
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ModuleNotFoundError as exc:
        if exc.name is None or exc.name.split(".")[0] != "matplotlib":
            raise
        raise MissingPlotExtraError(f"drawing needs matplotlib, which is not installed: {install_command('plot')}",
                                    name="matplotlib") from None
    return Figure, FigureCanvasAgg


def focal_hasse_edges(m: MassFunction) -> list[tuple[Element, Element]]:
    """The covering pairs (A, B) of the focal elements ordered by inclusion under m's model.

    A ⊂ B strictly, and no focal element C has A ⊂ C ⊂ B.

    Examples
    --------
    >>> m = MassFunction({"a": 0.5, "a|b": 0.3, "a|b|c": 0.2}, frame=["a", "b", "c"])
    >>> [(str(a), str(b)) for a, b in focal_hasse_edges(m)]
    [('a', 'a|b'), ('a|b', 'a|b|c')]
    """
    model = m.model
    focal = list(m.focal)
    below = {(a, b) for a in focal for b in focal if a != b and model.includes(a, b)}
    return [(a, b) for a, b in sorted(below, key=lambda pair: (focal.index(pair[0]), focal.index(pair[1])))
            if not any((a, c) in below and (c, b) in below for c in focal)]


def plot_mass(m: MassFunction, out: Union[str, Path, None] = None, *, title: str | None = None):
    """Draw ``m``: masses, Bel/BetP/Pls per hypothesis and, for n ≤ 4, the Hasse diagram of its focal elements.

    Parameters
    ----------
    m : MassFunction
    out : path, optional
        Where to save the picture (the format follows the suffix: .png, .pdf, .svg …).
    title : str, optional
        A title over the panels.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    MissingPlotExtraError
        If matplotlib is not installed.
    FormatError
        If ``out`` has a suffix matplotlib cannot write.

    Examples
    --------
    >>> m = MassFunction({"a": 0.5, "a|b": 0.3, "c": 0.2}, frame=["a", "b", "c"], model="shafer")
    >>> figure = plot_mass(m)
    >>> for axes in figure.axes:
    ...     print(axes.get_title())
    Mass of each focal element: m(A), W (1)
    Belief, pignistic probability and plausibility: Bel ≤ BetP ≤ Pls
    Focal elements by inclusion (Hasse diagram), with their masses
    """
    Figure, FigureCanvasAgg = _matplotlib()
    if not isinstance(m, MassFunction):
        raise FormatError(f"plot_mass draws a MassFunction, got {type(m).__name__}")
    hypotheses = list(m.frame.hypotheses)
    hasse = len(hypotheses) <= MAX_HASSE_HYPOTHESES
    panels = 3 if hasse else 2
    figure = Figure(figsize=(5.0 * panels, 4.2), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.subplots(1, panels)
    if title:
        figure.suptitle(title)

    labels, masses, rest = _largest_masses(m)
    colours = ["tab:blue"] * len(masses)
    if rest is not None:
        labels, masses, colours = labels + [rest[0]], masses + [rest[1]], colours + ["tab:gray"]
    bars = axes[0].bar(range(len(labels)), masses, color=colours)
    if len(masses) <= 12:                   # more labels than that overlap
        axes[0].bar_label(bars, labels=[f"{v:.3g}" for v in masses], fontsize=8)
    axes[0].set_xticks(range(len(labels)), labels, rotation=45 if len(labels) > 6 else 0, ha="right"
                       if len(labels) > 6 else "center")
    axes[0].set_ylim(0, 1.08)
    axes[0].set_ylabel("mass m(A)")
    shown = "" if rest is None else f" (the {len(masses) - 1} largest of {len(m.focal):,})"
    axes[0].set_title(f"Mass of each focal element{shown}: m(A), W (1)", fontsize=10)

    batch = m.batch()
    bel = batch.bel(hypotheses)[0]
    pls = batch.pls(hypotheses)[0]
    betp = batch.betp(hypotheses)[0]
    total = len(hypotheses)
    if total > MAX_PLOTTED_HYPOTHESES:
        keep = np.sort(np.argsort(-betp, kind="stable")[:MAX_PLOTTED_HYPOTHESES])
        hypotheses = [hypotheses[i] for i in keep]
        bel, pls, betp = bel[keep], pls[keep], betp[keep]
    rows = range(len(hypotheses))
    axes[1].hlines(rows, bel, pls, color="tab:gray", linewidth=6, alpha=0.6, label="[Bel, Pls]")
    axes[1].plot(bel, rows, "|", color="tab:blue", markersize=14, label="Bel, W (8)")
    axes[1].plot(pls, rows, "|", color="tab:red", markersize=14, label="Pls, W (9)")
    axes[1].plot(betp, rows, "o", color="black", label="BetP")
    axes[1].set_yticks(list(rows), hypotheses)
    axes[1].set_xlim(-0.02, 1.02)
    axes[1].set_xlabel("value")
    axes[1].set_ylim(len(hypotheses) - 0.5, -1.6)
    axes[1].legend(fontsize=8, loc="upper center", ncols=4, handlelength=1.2)
    shown = "" if total <= MAX_PLOTTED_HYPOTHESES else f" (the {len(hypotheses)} of largest BetP of {total:,})"
    axes[1].set_title(f"Belief, pignistic probability and plausibility{shown}: Bel ≤ BetP ≤ Pls", fontsize=10)

    if hasse:
        _draw_hasse(axes[2], m)
    if out is not None:
        try:
            figure.savefig(out)
        except ValueError as exc:                          # an unknown image format
            raise FormatError(f"cannot write the picture {str(out)!r}: {exc}") from None
    return figure


def _largest_masses(m: MassFunction) -> tuple[list[str], list[float], tuple[str, float] | None]:
    """Labels and masses of the focal elements drawn (canonical order), and the label and mass of the rest, if any."""
    values = m.values
    if len(values) <= MAX_PLOTTED_FOCAL:
        return [str(e) for e in m.focal], values.tolist(), None
    keep = np.sort(np.argsort(-values, kind="stable")[:MAX_PLOTTED_FOCAL])
    focal = m.focal
    others = len(values) - len(keep)
    rest = float(values.sum() - values[keep].sum())
    return [str(focal[i]) for i in keep], values[keep].tolist(), (f"the other {others:,}", max(rest, 0.0))


def _draw_hasse(axes, m: MassFunction) -> None:
    model = m.model
    focal = list(m.focal)
    levels: dict[int, list[Element]] = {}
    for element in focal:
        levels.setdefault(model.cardinality(element), []).append(element)
    ordered = sorted(levels)
    position = {}
    for row, level in enumerate(ordered):
        members = levels[level]
        for k, element in enumerate(members):
            position[element] = ((k + 1) / (len(members) + 1), row)
    labels = {}
    for element, value in zip(focal, m.values.tolist()):
        x, y = position[element]
        axes.scatter([x], [y], s=300 + 1500 * value, color="tab:blue", alpha=0.35, zorder=2)
        labels[element] = axes.text(x, y, f"{element}\n{value:.3g}", ha="center", va="center", fontsize=8, zorder=3,
                                    bbox={"boxstyle": "round,pad=0.2", "facecolor": "white", "edgecolor": "none",
                                          "alpha": 0.85})
    for a, b in focal_hasse_edges(m):
        # Each edge stops at the boxes of its two labels, so that no line is drawn through a name.
        axes.annotate("", xy=position[b], xytext=position[a], zorder=1,
                      arrowprops={"arrowstyle": "-", "color": "tab:gray", "patchA": labels[a].get_bbox_patch(),
                                  "patchB": labels[b].get_bbox_patch(), "shrinkA": 2, "shrinkB": 2})
    axes.set_xlim(0, 1)
    axes.set_ylim(-0.6, len(ordered) - 0.4)
    axes.set_yticks(range(len(ordered)), [str(level) for level in ordered])
    axes.set_ylabel("DSm cardinality C(A)")
    axes.set_xticks([])
    axes.set_title("Focal elements by inclusion (Hasse diagram), with their masses", fontsize=10)
