"""The scaling chart of the bench section ``model`` (matplotlib, Agg)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

#: colour per implementation, marker per planar/spatial, line style per chain/tree
COLORS = {"ours": "tab:blue", "ours (unchecked)": "tab:cyan", "pinocchio": "black",
          "pinocchio aba": "tab:orange"}
MARKERS = {"planar": "o", "spatial": "s"}
STYLES = {"chain": "-", "tree": "--"}
TITLES = {"M": "mass matrix M (ours: CRBA; pinocchio.crba)",
          "f": "f of eq. 4 (ours: Newton-Euler; pinocchio.rnea)",
          "Jc": "contact Jacobian (pinocchio.computeFrameJacobian)",
          "simulation": "one simulated second with contacts\n(chains dropped, trees swinging; "
                        "pinocchio: PinocchioMechanism)",
          "free motion": "one simulated second without contacts\n(pinocchio aba: ABA + "
                         "DOP853, same tolerances)"}
PANELS = ("M", "f", "Jc", "simulation", "free motion", "per evaluation")
#: the last panel: one right-hand-side evaluation of the simulations (line style: quantity)
PER_EVALUATION = {"simulation": "-", "free motion": ":"}


def scaling_chart(records: list[dict[str, Any]], out: Path,
                  exponents: dict[str, dict[str, float]]) -> str:
    """Five log-log panels (M, f, Jc, simulation with and without contacts) of time against
    the number of bodies, and a sixth of one right-hand-side evaluation.

    Parameters
    ----------
    records : the section's records (one per quantity, kind, size and implementation).
    out : the folder the chart is written to.
    exponents : per quantity and implementation, the growth exponent (log-log slope) that
        the panel's legend quotes (:func:`convimpact.bench.model_section.exponent`).

    Returns
    -------
    str
        the chart's file name, ``model_scaling.png``.
    """
    from .charts import _plt, save_chart

    plt = _plt()
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter, ScalarFormatter

    fig, grid = plt.subplots(2, 3, figsize=(18, 9.5))
    axes = grid.ravel()
    ns = sorted({r["n_bodies"] for r in records})
    for ax, qty in zip(axes, PANELS):
        if qty == "per evaluation":
            _per_evaluation(ax, records, ns)
            continue
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
                scale = 1e6 if qty in ("M", "f", "Jc") else 1.0
                ax.plot([r["n_bodies"] for r in sub], [scale * r["median"] for r in sub],
                        color=color, marker=MARKERS[dim], ls=STYLES[shape], ms=4, lw=1.2,
                        alpha=0.85)
        ax.xaxis.set_major_locator(FixedLocator(ns))
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:g}"))
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_ylabel("us per call (median)" if qty in ("M", "f", "Jc") else "s per simulated s")
        slopes = [f"{impl}: n^{x:.2f}" for impl in COLORS
                  if (x := exponents.get(qty, {}).get(impl)) is not None]
        if slopes:
            ax.text(0.98, 0.02, "growth " + ", ".join(slopes), transform=ax.transAxes,
                    ha="right", va="bottom", fontsize=7,
                    bbox=dict(facecolor="white", alpha=0.8, lw=0))
    handles = ([Line2D([], [], color=c, lw=2, label=impl) for impl, c in COLORS.items()]
               + [Line2D([], [], color="gray", marker=m, ls="none", label=dim)
                  for dim, m in MARKERS.items()]
               + [Line2D([], [], color="gray", ls=ls, label=shape) for shape, ls in STYLES.items()])
    axes[0].legend(handles=handles, fontsize=7, loc="upper left")
    fig.suptitle("model evaluation cost against the number of bodies (same run; ours: "
                 "convimpact.model, validated and copied unless 'unchecked')", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    name = "model_scaling.png"
    return save_chart(fig, out, name)


def _per_evaluation(ax, records: list[dict[str, Any]], ns) -> None:
    """Wall time per right-hand-side evaluation of the simulated seconds (median over kinds)."""
    import numpy as np
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter, ScalarFormatter

    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.25)
    ax.set_title("one right-hand-side evaluation of the simulations\n(median over the kinds; "
                 "solid: with contacts, dotted: free motion)", fontsize=9.5)
    ax.set_xlabel("number of bodies n")
    ax.set_ylabel("us per evaluation (wall / nfev)")
    for qty, ls in PER_EVALUATION.items():
        for impl, color in COLORS.items():
            rows = [r for r in records if r["quantity"] == qty and r["implementation"] == impl
                    and r.get("wall_per_evaluation")]
            sizes = sorted({r["n_bodies"] for r in rows})
            if not sizes:
                continue
            med = [1e6 * float(np.median([r["wall_per_evaluation"] for r in rows
                                          if r["n_bodies"] == n])) for n in sizes]
            ax.plot(sizes, med, color=color, ls=ls, marker="o", ms=4, lw=1.4)
    ax.xaxis.set_major_locator(FixedLocator(ns))
    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())
