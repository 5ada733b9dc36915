"""Drawing of one map of the failure atlas (:func:`plot_atlas`): a panel per path, each cell
coloured by its most severe failure mode."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np

from .atlas_modes import AtlasMap

#: drawing priority of the modes (most severe first) and their colours
_PRIORITY = ("unexpected_error", "singular_loop", "singular_delassus",
             "non_positive_effective_mass", "no_convergence", "not_supported", "energy_gain",
             "slip_reversal", "friction_pushes_slip", "missed_impact", "smeared_impact",
             "compliant_deep", "compliant_stiff", "zeno")
_COLORS = {"ok": "#f2f2f2", "separating": "#d0d0d0", "not_judged": "white",
           "unexpected_error": "black",
           "singular_loop": "#6a3d9a", "singular_delassus": "#1f78b4",
           "non_positive_effective_mass": "#e31a1c", "no_convergence": "#ff7f00",
           "not_supported": "#b15928", "energy_gain": "#fb9a99", "slip_reversal": "#33a02c",
           "friction_pushes_slip": "#b2df8a", "missed_impact": "#e31a1c",
           "smeared_impact": "#fdbf6f", "compliant_deep": "#1f78b4",
           "compliant_stiff": "#a6cee3", "zeno": "#6a3d9a"}


def plot_atlas(atlas_map: AtlasMap, out: str | Path | None = None,
               paths: Sequence[str] | None = None, ncols: int = 3):
    """Draw one map: a panel per path, each cell coloured by its most severe mode.

    Parameters
    ----------
    atlas_map : the map.
    out : file (PNG) to write, or None.
    paths : the panels (default every path of the map).
    ncols : panels per row.

    Returns
    -------
    matplotlib Figure
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    m = atlas_map
    paths = list(paths or m.paths)
    present = [mode for mode in _PRIORITY if mode in m.modes
               and any(np.any(m.flags[p][mode]) for p in paths)]
    empty = (np.asarray(m.samples) == 0) if m.samples is not None else None
    has_empty = empty is not None and bool(np.any(empty))
    cats = ["ok", "separating"] + present + (["not_judged"] if has_empty else [])
    cmap = ListedColormap([_COLORS[c] for c in cats])
    ncols = min(ncols, len(paths))
    nrows = int(math.ceil(len(paths) / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.3 * ncols, 3.6 * nrows + 1.0),
                             squeeze=False, sharex=True, sharey=True)
    x, y = np.asarray(m.x), np.asarray(m.y)

    def edges(v):
        if v.size == 1:
            return np.array([v[0] - 0.5, v[0] + 0.5])
        mid = 0.5 * (v[1:] + v[:-1])
        return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])

    for ax, p in zip(axes.ravel(), paths):
        img = np.zeros((y.size, x.size))
        img[m.all_separating] = 1
        for code, mode in reversed(list(enumerate(present, start=2))):
            img[m.flags[p][mode]] = code
        if has_empty:  # e.g. a start that penetrates the floor: nothing was run there
            img[empty] = len(cats) - 1
        ax.pcolormesh(edges(x), edges(y), img, cmap=cmap, vmin=-0.5,
                      vmax=len(cats) - 0.5, shading="flat")
        items = [f"{k.replace('_', ' ')}: {v}" for k, v in m.counts[p].items() if v]
        lines = [", ".join(items[i:i + 2]) for i in range(0, len(items), 2)]
        ax.set_title("\n".join([p] + (lines or ["no failure"])), fontsize=7)
    for ax in axes.ravel()[len(paths):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel(m.x_name, fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel(m.y_name, fontsize=8)
    handles = [Patch(facecolor=_COLORS[c], edgecolor="0.6", label=c.replace("_", " "))
               for c in cats]
    fig.legend(handles=handles, loc="lower center", ncol=min(6, len(handles)), fontsize=8,
               frameon=False)
    fig.suptitle(f"failure atlas: {m.title}\n(cell colour: most severe mode met over "
                 f"{_cell_note(m)}; counts over {m.n_samples} samples)", fontsize=9)
    fig.tight_layout(rect=(0, 0.07, 1, 0.93))
    if out is not None:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out, dpi=90)
    return fig


def _cell_note(m: AtlasMap) -> str:
    keys = [k for k in ("rates", "e", "mu", "slider_speeds") if k in m.fixed]
    return "the " + ", ".join(keys) + " of each cell" if keys else "each cell"
