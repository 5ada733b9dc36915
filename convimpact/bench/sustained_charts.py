"""Charts of the ``sustained`` bench section (:mod:`convimpact.bench.sustained_section`).

``sustained_work_precision.png`` (:func:`work_precision_chart`: one log-log panel per scene,
final-state error, solid, and closed-form error, dashed hollow, against wall time; event-driven
and Moreau–Jean in their own markers, labels rtol and h) and ``sustained_convergence.png``
(:func:`convergence_chart`: Moreau–Jean's final-state and closed-form errors against h for all
scenes, with slope-1 and slope-2 guides).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .sustained_references import ROUNDOFF

#: floor of the charts' error axes
ERROR_FLOOR = 1e-16
SCHEME_STYLE = {"event-driven": ("o", "tab:blue"), "moreau-jean": ("s", "tab:red")}


def _sparse_log_formatter(every: int):
    """Labels 10^k only for k divisible by ``every`` (the ticks stay at every decade)."""
    from matplotlib.ticker import FuncFormatter

    def fmt(v, _pos):
        k = round(math.log10(v)) if v > 0 else 0
        return f"$10^{{{k}}}$" if v > 0 and k % every == 0 else ""

    return FuncFormatter(fmt)


def work_precision_chart(records: list[dict[str, Any]], labels: Mapping[str, str],
                         out: Path) -> str:
    """One log-log panel per scene: error against wall time, both schemes."""
    from .charts import _plt, save_chart

    plt = _plt()
    keys = list(labels)
    ncol = min(4, len(keys))
    nrow = math.ceil(len(keys) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.6 * nrow), squeeze=False)
    from matplotlib.ticker import LogLocator, NullFormatter

    for ax in axes.flat[len(keys):]:
        ax.set_visible(False)
    walls = [r["wall_time"] for r in records if r["scene"] in labels and r.get("wall_time")]
    xlim = (min(walls) / 1.5, max(walls) * 1.5) if walls else (1e-2, 10.0)
    for ax, key in zip(axes.flat, keys):
        rows = [r for r in records if r["scene"] == key and r.get("wall_time")]
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(*xlim)
        ax.set_ylim(ERROR_FLOOR / 3, 3.0)
        ax.yaxis.set_major_locator(LogLocator(numticks=20))
        ax.yaxis.set_major_formatter(_sparse_log_formatter(4))
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.grid(True, which="major", alpha=0.3)
        ax.set_title(labels[key], fontsize=9)
        for scheme, (marker, color) in SCHEME_STYLE.items():
            sub = sorted((r for r in rows if r["scheme"] == scheme), key=lambda r: r["wall_time"])
            for field, ls, fill in (("final_state_error", "-", color),
                                    ("observable_error", "--", "none")):
                pts = [r for r in sub if r.get(field) is not None]
                if not pts:
                    continue
                xs = [r["wall_time"] for r in pts]
                ys = [max(r[field], ERROR_FLOOR) for r in pts]
                ax.plot(xs, ys, marker=marker, color=color, ls=ls, mfc=fill, ms=5, alpha=0.85)
                if field == "final_state_error":
                    for r, x, yv in zip(pts, xs, ys):
                        ax.annotate(r["setting"].split("=")[1], (x, yv), fontsize=6,
                                    color=color, xytext=(3, 3), textcoords="offset points")
        ax.tick_params(labelsize=7)
    for ax in axes[:, 0]:
        ax.set_ylabel("relative error", fontsize=8)
    for ax in axes[-1, :]:
        ax.set_xlabel("wall time of the run [s]", fontsize=8)
    from matplotlib.lines import Line2D
    handles = [Line2D([], [], marker=m, color=c, ls="-", label=f"{s}, final state vs reference")
               for s, (m, c) in SCHEME_STYLE.items()]
    handles += [Line2D([], [], marker=m, color=c, mfc="none", ls="--",
                       label=f"{s}, closed-form observable")
                for s, (m, c) in SCHEME_STYLE.items()]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle("sustained contact: error against wall time (labels: event-driven rtol, "
                 "Moreau–Jean h; errors below 1e-16 drawn at 1e-16)", fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 0.95))
    name = "sustained_work_precision.png"
    return save_chart(fig, out, name)


def _minor_h_formatter():
    """Plain labels (4e-3) on the minor ticks 2..5 of a step axis, none on the others."""
    from matplotlib.ticker import FuncFormatter

    def fmt(v, _pos):
        k = math.floor(math.log10(v) + 1e-9)
        m = v / 10 ** k
        return f"{m:.0f}e{k}" if round(m) in (2, 4) or abs(m - 5) < 1e-6 else ""

    return FuncFormatter(fmt)


def convergence_chart(records: list[dict[str, Any]], labels: Mapping[str, str],
                      out: Path) -> str:
    """Moreau–Jean's errors against h, all scenes, with slope-1 and slope-2 guides."""
    from .charts import _plt, save_chart

    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(15, 5.2))
    cmap = plt.get_cmap("tab10")
    for ax, (field, title) in zip(axes, (("final_state_error",
                                          "final state against the event-driven reference"),
                                         ("observable_error", "closed-form observable"))):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="major", alpha=0.3)
        ax.set_title(f"Moreau–Jean: {title}", fontsize=10)
        ax.set_xlabel("step h [s]")
        ax.set_ylabel("error" + (" (relative; incline holds: absolute, m)"
                                 if field == "observable_error" else " (relative)"))
        hs_all, top = [], []
        for i, key in enumerate(labels):
            sub = sorted((r for r in records if r["scene"] == key and r["scheme"] == "moreau-jean"
                          and r.get(field) is not None), key=lambda r: r["options"]["h"])
            if not sub:
                continue
            hs = [r["options"]["h"] for r in sub]
            es = [max(r[field], ERROR_FLOOR) for r in sub]
            ax.plot(hs, es, marker="so^vD<>p"[i % 8], color=cmap(i % 10), ms=7 - 0.4 * i,
                    label=labels[key], alpha=0.85)
            hs_all += hs
            top.append(es[-1])
        if hs_all:
            h = np.array([min(hs_all), max(hs_all)])
            top = [e for e in top if e > ROUNDOFF] or [1e-3]
            anchor = 3.0 * float(np.exp(np.median(np.log(top))))
            for slope, ls in ((1, "k-"), (2, "k:")):
                ax.plot(h, anchor * (h / h[1]) ** slope, ls, lw=1, alpha=0.6,
                        label=f"slope {slope}")
        ax.xaxis.set_minor_formatter(_minor_h_formatter())
    handles, names = axes[0].get_legend_handles_labels()
    axes[1].legend(handles, names, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                   frameon=False)
    fig.suptitle("sustained contact: Moreau–Jean (theta = 1/2, law coulomb) converging as h -> 0 "
                 "(round-off floor 1e-16)", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    name = "sustained_convergence.png"
    return save_chart(fig, out, name)
