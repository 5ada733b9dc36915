"""Charts of the derivative sections (``derivatives`` and ``sensitivities``): times on log axes
(they span decades), the finite differences' deviation from the exact derivatives below."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .charts import _plt, save_chart

PATHS = ("solve", "solve + derivatives", "central FD")
SIM_PATHS = ("simulate", "simulate, sensitivities=True", "central FD of whole runs")


def _time_bars(ax, rows: list[dict[str, Any]], keys, names, unit: float, ylabel: str,
               title: str, fontsize: int | None = None) -> None:
    """Three bars per row (log axis): the median times ``rows[i][key]`` times ``unit``."""
    x = np.arange(len(rows))
    width = 0.27
    for j, (key, name) in enumerate(zip(keys, names)):
        ax.bar(x + (j - 1) * width, [unit * r[key] for r in rows], width, label=name)
    ax.set_yscale("log")
    ax.set_ylabel(ylabel)
    ax.set_title(title, **({} if fontsize is None else {"fontsize": fontsize}))
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(axis="y", which="both", alpha=0.3)


def single_contact_chart(records: list[dict[str, Any]], out: Path) -> str:
    """Two panels: the three calls' median times per law/d/mode (log), and the finite
    differences' deviation from the analytic jacobians."""
    plt = _plt()
    labels = [f"{r['law']}, {'planar' if r['d'] == 2 else 'spatial'} {r['regime']}, "
              f"k = {r['k']}" for r in records]
    x = np.arange(len(records))
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(max(8.0, 0.55 * len(records) + 2), 8.5),
                                 sharex=True)
    _time_bars(ax, records, ("time_solve", "time_derivatives", "time_fd"), PATHS, 1e6,
               "median CPU time per call (µs)",
               "impact derivatives, one contact: time per call (central FD: every argument)")
    bx.bar(x, [max(r["fd_deviation"], 1e-17) for r in records], 0.5, color="tab:gray")
    bx.set_yscale("log")
    bx.set_ylabel("max |FD - analytic| / scale")
    bx.set_title("central differences (step 1e-6 of each argument) vs the analytic jacobians "
                 "(scale: the key's largest entry, at least max |dq+| / max(1, |argument|))",
                 fontsize=9)
    bx.grid(axis="y", which="both", alpha=0.3)
    bx.set_xticks(x)
    bx.set_xticklabels(labels, rotation=55, ha="right", rotation_mode="anchor", fontsize=8)
    fig.tight_layout()
    return save_chart(fig, out, "derivatives.png")


def several_contacts_chart(rows: list[dict[str, Any]], out: Path) -> str:
    """One panel per law: time per call against the number of contacts (log-log) for the
    solve, the solve with derivatives, the differences in (dq, e, mu) and the estimate with
    M and Jc; a last panel: the differences' deviation."""
    plt = _plt()
    done = [r for r in rows if "skipped" not in r]
    laws = list(dict.fromkeys(r["law"] for r in done))
    n_panels = len(laws) + 1
    cols = 3
    nrows = int(np.ceil(n_panels / cols))
    fig, axes = plt.subplots(nrows, cols, figsize=(12.5, 3.9 * nrows), squeeze=False)
    series = (("time_solve", "solve", "o:", "tab:blue"),
              ("time_derivatives", "solve + derivatives", "s-", "tab:orange"),
              ("time_fd", "central FD (dq, e, mu)", "^--", "tab:green"),
              ("fd_estimate_all", "FD with M, Jc (estimate)", "v-.", "tab:red"))
    for ax, law in zip(axes.flat, laws):
        at = sorted((r for r in done if r["law"] == law), key=lambda r: r["n_contacts"])
        n = [r["n_contacts"] for r in at]
        for key, label, style, color in series:
            ax.plot(n, [1e3 * r[key] for r in at], style, color=color, label=label,
                    alpha=0.6 if key == "fd_estimate_all" else 1.0)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xticks(n)
        ax.set_xticklabels([str(v) for v in n])
        ax.set_title(f"{law}", fontsize=10)
        ax.set_xlabel("spatial contacts (k = 3 n + 2)")
        ax.set_ylabel("median CPU time (ms)")
        ax.grid(which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=7, loc="upper left")
    bx = axes.flat[len(laws)]
    for law in laws:
        at = sorted((r for r in done if r["law"] == law), key=lambda r: r["n_contacts"])
        bx.plot([r["n_contacts"] for r in at],
                [max(r["fd_deviation"] or 1e-17, 1e-17) for r in at], "o-", label=law)
    bx.set_xscale("log", base=2)
    bx.set_yscale("log")
    bx.set_xticks(sorted({r["n_contacts"] for r in done}))
    bx.set_xticklabels([str(v) for v in sorted({r["n_contacts"] for r in done})])
    bx.set_xlabel("spatial contacts")
    bx.set_ylabel("max |FD - analytic| / max |analytic|")
    bx.set_title("central FD (step 1e-6, tol 1e-12) vs analytic", fontsize=10)
    bx.grid(which="both", alpha=0.3)
    bx.legend(fontsize=7)
    for ax in list(axes.flat)[n_panels:]:
        ax.set_visible(False)
    fig.suptitle("impact derivatives at several contacts: time and accuracy", fontsize=11)
    fig.tight_layout()
    return save_chart(fig, out, "derivatives_several.png")


def sensitivities_chart(rows: list[dict[str, Any]], out: Path) -> str:
    """Two panels per scene row: the three runs' median times (log), and the deviations of
    the finite differences of whole runs from the exact sensitivities."""
    plt = _plt()
    labels = [f"{r['scene']}\n({r['events_label']})" for r in rows]
    x = np.arange(len(rows))
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(max(8.0, 1.5 * len(rows) + 2.5), 8.0),
                                 sharex=True)
    _time_bars(ax, rows, ("time_plain", "time_sensitivities", "time_fd"), SIM_PATHS, 1e3,
               "median CPU time per run (ms)",
               "trajectory sensitivities at the default tolerances (rtol 1e-8, atol 1e-10); "
               "FD: 2 runs per state direction", fontsize=9)
    width = 0.27
    names = (("deviation_state", "state_transition"), ("deviation_e", "d/de"),
             ("deviation_mu", "d/dmu"))
    for j, (key, name) in enumerate(names):
        vals = [r.get(key) for r in rows]
        bx.bar([xi + (j - 1) * width for xi, v in zip(x, vals) if v],
               [v for v in vals if v], width, label=name, color=f"C{j}")
        for xi, v in zip(x, vals):  # not differenced, or exactly zero both ways: say so
            if not v:
                bx.annotate("n/a" if v is None else "0", (xi + (j - 1) * width, 0.02),
                            xycoords=("data", "axes fraction"), ha="center", fontsize=8,
                            color=f"C{j}")
    bx.set_yscale("log")
    bx.set_ylabel("max |FD - exact| / max(1, max |exact|)")
    bx.set_title("central FD of whole runs (step 1e-6, rtol 1e-11, atol 1e-12) vs exact",
                 fontsize=9)
    bx.legend(loc="upper left", fontsize=8)
    bx.grid(axis="y", which="both", alpha=0.3)
    bx.set_xticks(x)
    bx.set_xticklabels(labels, fontsize=8)
    fig.tight_layout()
    return save_chart(fig, out, "sensitivities.png")
