"""PNG charts of the bench sections (matplotlib, Agg backend, imported lazily)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

#: errors below this are drawn on it (the reference itself, or agreement to round-off)
ERROR_FLOOR = 1e-16

_MARKERS = {"closed-form": "D", "fast": "*", "sweep": "v", "clarabel": "o", "cvxpy": "s",
            "pinocchio impulseDynamics": "P", "pinocchio ADMM ccp": "X",
            "pinocchio ADMM ncp": "X", "pinocchio PGS": "h"}
_COLORS = {"closed-form": "tab:purple", "fast": "tab:red", "sweep": "tab:brown",
           "clarabel": "tab:blue", "cvxpy": "tab:green", "pinocchio impulseDynamics": "black",
           "pinocchio ADMM ccp": "tab:orange", "pinocchio ADMM ncp": "tab:orange",
           "pinocchio PGS": "tab:pink"}


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def per_impact_charts(aggs: list[dict[str, Any]], out: Path, laws: Sequence[str],
                      classes: Sequence[str]) -> list[str]:
    """One work-precision figure per law: error against time, one panel per problem class.

    Filled markers: the full ``solve_problem`` call; hollow markers of the same kind: the bare
    kernel (same error). Marker size grows with the tolerance setting's tightness.
    """
    plt = _plt()
    from matplotlib.lines import Line2D

    figures = []
    for law in laws:
        every = [a for a in aggs if a["law"] == law]
        rows = [a for a in every if a["time_full_median"] is not None]
        if not rows:
            continue
        fig, axes = plt.subplots(2, 4, figsize=(17, 8.2), sharex=True, sharey=True)
        handles: dict[str, Any] = {}
        for ax, cls in zip(axes.ravel(), classes):
            sub = [a for a in rows if a["class"] == cls]
            ax.set_title(cls, fontsize=10)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.axhline(ERROR_FLOOR, color="0.7", lw=0.8, ls="--")
            ax.grid(True, which="major", alpha=0.3)
            if not sub:
                failed = [a for a in every if a["class"] == cls]
                kinds = ", ".join(sorted({f for a in failed for f in a["failures"]}))
                text = ("no path serves\nthis class" if not failed else
                        f"every path failed here\n({kinds};\nsee bench.json)")
                ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes,
                        color="0.4", fontsize=9)
                continue
            for a in sub:
                m = a["method"]
                err = a["impulse_error_median"]
                y = max(err if err is not None else np.nan, ERROR_FLOOR)
                if err is None:
                    continue
                tight = _tightness(a["setting"])
                style = dict(marker=_MARKERS.get(m, "o"), color=_COLORS.get(m, "gray"),
                             ms=5 + tight, ls="none")
                h, = ax.plot(a["time_full_median"], y, **style, alpha=0.9)
                handles.setdefault(m, h)
                if a["time_kernel_median"]:
                    ax.plot(a["time_kernel_median"], y, **{**style, "mfc": "none"}, alpha=0.9)
                    ax.plot([a["time_kernel_median"], a["time_full_median"]], [y, y],
                            color=style["color"], lw=0.6, alpha=0.5)
                note = _short_setting(a["setting"])
                if a["is_reference"]:
                    note = (note + " ref").strip()
                if a["n_failed"]:
                    note += f" ({a['n_failed']}/{a['n_problems']} failed)"
                if note:
                    ax.annotate(note, (a["time_full_median"], y), fontsize=6,
                                color=style["color"], xytext=(4, 3),
                                textcoords="offset points")
        for ax in axes[-1]:
            ax.set_xlabel("median wall time per solve [s]")
        for ax in axes[:, 0]:
            ax.set_ylabel(r"median $|\pi - \pi_{ref}| / |\pi_{ref}|$")
        extra = [Line2D([], [], marker="o", mfc="none", color="0.3", ls="none",
                        label="hollow: bare kernel"),
                 Line2D([], [], color="0.7", ls="--", label=f"floor {ERROR_FLOOR:g} "
                                                           "(reference / round-off)")]
        fig.legend(handles=list(handles.values()) + extra,
                   labels=list(handles) + [h.get_label() for h in extra],
                   loc="lower center", ncol=min(6, len(handles) + 2), fontsize=9,
                   frameon=False)
        fig.suptitle(f"law '{law}': median impulse error against median wall time per solve "
                     "(labels: tolerance setting; 'ref': the reference path)", fontsize=12)
        fig.tight_layout(rect=(0, 0.06, 1, 0.96))
        name = f"per_impact_{law}.png"
        fig.savefig(Path(out) / name, dpi=90)
        plt.close(fig)
        figures.append(name)
    return figures


def _short_setting(setting: str) -> str:
    """``"tol=1e-06"`` -> ``"1e-06"``, ``"xtol=1e-02 grid=36"`` -> ``"x1e-02/36"``."""
    if setting == "default":
        return ""
    parts = dict(p.split("=", 1) for p in setting.split() if "=" in p)
    if "xtol" in parts:
        return f"x{parts['xtol']}/{parts.get('grid', '')}"
    return parts.get("tol", setting)


def _tightness(setting: str) -> float:
    """Marker growth with the tolerance: 0 for default or loose, up to ~6 for 1e-12."""
    for part in setting.split():
        if part.startswith(("tol=", "xtol=")):
            t = float(part.split("=", 1)[1])
            return max(0.0, -np.log10(t) / 2.0)
    return 3.0


def throughput_chart(rows: list[dict[str, Any]], out: Path, title: str) -> str:
    """Horizontal bars of points per second (log scale), one per law/method."""
    plt = _plt()
    rows = [r for r in rows if r.get("points_per_second")]
    fig, ax = plt.subplots(figsize=(8.5, 0.42 * len(rows) + 1.6))
    labels = [r["label"] for r in rows]
    vals = [r["points_per_second"] for r in rows]
    colors = [_COLORS.get(r["method"], "gray") for r in rows]
    ax.barh(range(len(rows)), vals, color=colors)
    ax.set_yticks(range(len(rows)), labels, fontsize=8)
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("landscape points per second")
    for i, v in enumerate(vals):
        ax.text(v, i, f" {v:.3g}", va="center", fontsize=7)
    ax.set_title(title, fontsize=10)
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    name = "landscape_throughput.png"
    fig.savefig(Path(out) / name, dpi=90)
    plt.close(fig)
    return name
