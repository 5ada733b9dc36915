"""The ``per-impact`` section's law-against-law view of the exact single-contact kernels.

One chart, ``per_impact_laws_fast.png``: per one-contact problem class, the median wall time
of ``method="fast"`` under every law (the full ``solve_problem`` call and the bare kernel
:func:`convimpact.impact.exact.dispatch.solve_contact`), measured in the same run; and one summary
sentence per class comparing each of :data:`FEATURED` -- ``stronge`` (Stronge's energetic
law: an exact piecewise-linear path in the plane, an integrated curved slip in space) and
``chatterjee-ruina`` (Chatterjee & Ruina's algebraic law: one 2 x 2 or 3 x 3 solve and a
projection onto the cone, at its default e_t = 0) -- with the median of the other laws.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

FIGURE = "per_impact_laws_fast.png"
#: the laws the summary compares with the median of the others
FEATURED = ("stronge", "chatterjee-ruina")
SINGLE = ("planar, 1 contact, open", "planar, 1 contact, closed", "spatial, 1 contact, open",
          "spatial, 1 contact, closed")


def _times(aggs: list[dict[str, Any]], laws, key: str) -> np.ndarray:
    """(class, law) medians of ``key`` for the ``fast`` label (NaN where not measured)."""
    out = np.full((len(SINGLE), len(laws)), np.nan)
    for a in aggs:
        if a["label"] == "fast" and a["class"] in SINGLE and a["law"] in laws:
            t = a.get(key)
            if t is not None:
                out[SINGLE.index(a["class"]), list(laws).index(a["law"])] = t
    return out


def law_speed_chart(aggs: list[dict[str, Any]], out: str, laws) -> list[str]:
    """Grouped bars of the fast path's median time per law and one-contact class (log scale);
    returns the written file names (none when nothing was measured)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    laws = [law for law in laws if law != "frictionless"]
    full = _times(aggs, laws, "time_full_median")
    kern = _times(aggs, laws, "time_kernel_median")
    if not np.isfinite(full).any():
        return []
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.8), sharey=True, layout="constrained")
    width = 0.8 / len(laws)
    x = np.arange(len(SINGLE))
    colours = plt.get_cmap("tab10").colors
    for ax, data, what in ((axes[0], full, "solve_problem(..., method='fast')"),
                           (axes[1], kern, "bare kernel solve_contact")):
        for j, law in enumerate(laws):
            ax.bar(x + (j - (len(laws) - 1) / 2) * width, data[:, j] * 1e6, width,
                   label=law, color=colours[j % len(colours)],
                   edgecolor="black" if law == "stronge" else "none")
        ax.set_yscale("log")
        ax.set_xticks(x, [c.replace(", ", "\n", 1) for c in SINGLE], fontsize=8)
        ax.set_title(what, fontsize=10)
        ax.grid(axis="y", which="both", alpha=0.3)
    axes[0].set_ylabel("median wall time per impact [us]")
    axes[1].legend(fontsize=8, loc="upper left")
    fig.suptitle("one contact, exact kernels: every law's median wall time in the same run "
                 "(stronge outlined)", fontsize=11)
    os.makedirs(out, exist_ok=True)
    fig.savefig(os.path.join(out, FIGURE), dpi=110)
    plt.close(fig)
    return [FIGURE]


def law_speed_summary(aggs: list[dict[str, Any]], laws) -> list[str]:
    """Per one-contact class and law of :data:`FEATURED`: its fast path against the median of
    the other laws."""
    laws = [law for law in laws if law != "frictionless"]
    full = _times(aggs, laws, "time_full_median")
    lines = []
    for law in FEATURED:
        if law not in laws:
            continue
        j = laws.index(law)
        others = [i for i in range(len(laws)) if i != j]
        for c, cls in enumerate(SINGLE):
            mine, rest = full[c, j], full[c, others]
            rest = rest[np.isfinite(rest)]
            if not (np.isfinite(mine) and rest.size):
                continue
            med = float(np.median(rest))
            lines.append(f"{law}, {cls}: fast {mine * 1e6:.3g} us per impact vs the other "
                         f"laws' median {med * 1e6:.3g} us ({mine / med:.3g}x; range "
                         f"{rest.min() * 1e6:.3g}..{rest.max() * 1e6:.3g} us)")
    return lines
