"""The scaling chart of the bench section ``model`` (matplotlib, Agg)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

#: colour per implementation, marker per planar/spatial, line style per chain/tree
COLORS = {"ours": "tab:blue", "ours (unchecked)": "tab:cyan", "pinocchio": "black"}
MARKERS = {"planar": "o", "spatial": "s"}
STYLES = {"chain": "-", "tree": "--"}
TITLES = {"M": "mass matrix M (ours: CRBA; pinocchio.crba)",
          "f": "f of eq. 4 (ours: Newton-Euler; pinocchio.rnea)",
          "Jc": "contact Jacobian (pinocchio.computeFrameJacobian)",
          "simulation": "one simulated second of the dropped chain"}


def scaling_chart(records: list[dict[str, Any]], out: Path) -> str:
    """Four log-log panels (M, f, Jc, simulation): time against the number of bodies."""
    from .charts import _plt, save_chart

    plt = _plt()
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FixedLocator, NullFormatter, ScalarFormatter

    fig, axes = plt.subplots(1, 4, figsize=(19, 4.8))
    ns = sorted({r["n_bodies"] for r in records})
    for ax, qty in zip(axes, ("M", "f", "Jc", "simulation")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.25)
        ax.set_title(TITLES[qty], fontsize=9.5)
        ax.set_xlabel("number of bodies n")
        rows = [r for r in records if r["quantity"] == qty and r.get("median")]
        for kind in sorted({r["kind"] for r in rows}):
            dim, shape = kind.split()
            for impl, color in COLORS.items():
                sub = sorted((r for r in rows if r["kind"] == kind and r["implementation"] == impl),
                             key=lambda r: r["n_bodies"])
                if not sub:
                    continue
                scale = 1.0 if qty == "simulation" else 1e6
                ax.plot([r["n_bodies"] for r in sub], [scale * r["median"] for r in sub],
                        color=color, marker=MARKERS[dim], ls=STYLES[shape], ms=4, lw=1.2,
                        alpha=0.85)
        ax.xaxis.set_major_locator(FixedLocator(ns))
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_major_formatter(ScalarFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_ylabel("s per simulated s" if qty == "simulation" else "us per call (median)")
    handles = ([Line2D([], [], color=c, lw=2, label=impl) for impl, c in COLORS.items()]
               + [Line2D([], [], color="gray", marker=m, ls="none", label=dim)
                  for dim, m in MARKERS.items()]
               + [Line2D([], [], color="gray", ls=ls, label=shape) for shape, ls in STYLES.items()])
    axes[0].legend(handles=handles, fontsize=7, loc="upper left")
    fig.suptitle("model evaluation cost against the number of bodies (same run; ours: "
                 "convimpact.model, validated and copied unless 'unchecked')", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    name = "model_scaling.png"
    return save_chart(fig, out, name)
