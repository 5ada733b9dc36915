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
           "pinocchio PGS": "tab:pink", "batch": "tab:olive"}


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save_chart(fig, out, name: str, dpi: int = 90) -> str:
    """Write ``fig`` as ``out/name`` (the folder made if missing), close it, return ``name``."""
    import matplotlib.pyplot as plt

    Path(out).mkdir(parents=True, exist_ok=True)
    fig.savefig(Path(out) / name, dpi=dpi)
    plt.close(fig)
    return name


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
        notes: dict[Any, list[dict[str, Any]]] = {}
        for ax, cls in zip(axes.ravel(), classes):
            sub = [a for a in rows if a["class"] == cls]
            ax.set_title(cls, fontsize=10)
            ax.set_xscale("log")
            ax.set_yscale("log")
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
                notes.setdefault(ax, []).append(
                    {"x": a["time_full_median"], "y": y, "color": style["color"],
                     "setting": _short_setting(a["setting"]), "ref": a["is_reference"],
                     "failed": (f"{a['n_failed']}/{a['n_problems']} failed"
                                if a["n_failed"] else "")})
        for ax in axes.ravel():  # after the data: a log axis without data has no range yet
            if ax.lines:
                ax.axhline(ERROR_FLOOR, color="0.7", lw=0.8, ls="--")
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
        for ax, items in notes.items():
            _place_labels(fig, ax, _merge_notes(items))
        name = f"per_impact_{law}.png"
        fig.savefig(Path(out) / name, dpi=90)
        plt.close(fig)
        figures.append(name)
    return figures


def _merge_notes(items: list[dict[str, Any]], dx: float = 0.3,
                 dy: float = 0.8) -> list[dict[str, Any]]:
    """One label per cluster of points of one colour (within ``dx``, ``dy`` decades).

    Several tolerance settings often land on the same time and error; their labels would be
    drawn on top of each other. A cluster is labelled once, its tolerances as a range
    (``1e-06..1e-12``), "ref" and failure counts once each.
    """
    out: list[dict[str, Any]] = []
    for it in sorted(items, key=lambda i: (i["color"], i["y"], i["x"])):
        lx, ly = np.log10(it["x"]), np.log10(it["y"])
        for c in out:
            if (c["color"] == it["color"] and abs(np.log10(c["x"]) - lx) < dx
                    and abs(np.log10(c["y"]) - ly) < dy):
                c["members"].append(it)
                break
        else:
            out.append({"x": it["x"], "y": it["y"], "color": it["color"], "members": [it]})
    for c in out:
        ms = c["members"]
        tols = [m["setting"] for m in ms if m["setting"]]
        text = ""
        if tols:
            uniq = sorted(set(tols), key=lambda t: (_tol_value(t), t))
            text = uniq[0] if len(uniq) == 1 else (
                f"{uniq[-1]}..{uniq[0]}" if all(_tol_value(t) < np.inf for t in uniq)
                else ", ".join(uniq))
        if any(m["ref"] for m in ms):
            text = (text + " ref").strip()
        failed = sorted({m["failed"] for m in ms if m["failed"]})
        if failed:
            text += f" ({', '.join(failed)})"
        c["text"] = text
        # anchor at the cluster's upper-right point
        top = max(ms, key=lambda m: (m["y"], m["x"]))
        c["x"], c["y"] = top["x"], top["y"]
    return [c for c in out if c["text"]]


def _tol_value(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return np.inf


#: label offsets tried in turn (points; horizontal alignment)
_OFFSETS = ((4, 3, "left"), (4, -9, "left"), (-4, 3, "right"), (-4, -9, "right"),
            (4, 11, "left"), (4, -17, "left"), (-4, 11, "right"), (-4, -17, "right"),
            (0, 19, "center"), (0, -25, "center"), (14, 3, "left"), (-14, 3, "right"))


def _place_labels(fig, ax, clusters: list[dict[str, Any]]) -> None:
    """Annotate each cluster where its label overlaps no other label, nor leaves the axes.

    Offsets are tried in the order of ``_OFFSETS``; when none is free, the least overlapping
    one is kept.
    """
    from matplotlib.transforms import Bbox

    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    placed = []
    markers = []  # the plotted points, which a label should not cover either
    for line in ax.lines:
        if line.get_marker() in (None, "None", "", " "):
            continue
        r = 0.5 * line.get_markersize() * fig.dpi / 72.0
        for px, py in ax.transData.transform(np.column_stack(line.get_data())):
            if np.isfinite(px) and np.isfinite(py):
                markers.append(Bbox([[px - r, py - r], [px + r, py + r]]))
    for c in sorted(clusters, key=lambda c: (-c["y"], c["x"])):
        best = None
        for ox, oy, ha in _OFFSETS:
            t = ax.annotate(c["text"], (c["x"], c["y"]), fontsize=6, color=c["color"],
                            xytext=(ox, oy), textcoords="offset points", ha=ha)
            bb = t.get_window_extent(renderer).expanded(1.04, 1.1)
            overlap = (sum(_overlap(bb, o) for o in placed)
                       + 0.5 * sum(_overlap(bb, o) for o in markers))
            outside = bb.width * bb.height - _overlap(bb, frame)
            cost = overlap + 2.0 * outside
            if best is None or cost < best[0]:
                if best is not None:
                    best[1].remove()
                best = (cost, t, bb)
            else:
                t.remove()
            if cost == 0.0:
                break
        placed.append(best[2])


def _overlap(a, b) -> float:
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return max(w, 0.0) * max(h, 0.0)


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
        ax.text(v, i, " " + f"{v:.3g}".replace("e+0", "e").replace("e+", "e"), va="center",
                fontsize=7)
    if vals:  # room for the value labels right of the longest bar (log scale)
        ax.set_xlim(right=max(vals) * 10.0)
    ax.set_title(title, fontsize=10)
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    name = "landscape_throughput.png"
    fig.savefig(Path(out) / name, dpi=90)
    plt.close(fig)
    return name
