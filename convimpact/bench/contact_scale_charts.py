"""Measures and charts of the ``contact-scale`` bench section (:mod:`.contact_scale_section`).

Measures: :func:`power_law_fit` (``t = c n^p`` in log-log), :func:`performance_profile`
(Dolan–Moré) and :func:`certified_times` (each solver's time where certified, ADMM's 1e-10
rerun folded in). Charts:

* ``contact_scale_times.png`` (:func:`times_chart`): median time per solve against the number
  of contacts, log-log, one panel per law; filled markers: answers certified at 1e-8 by the
  natural-map residual, hollow: answers that are not (or a peer's time to its failure), crosses
  at the time limit: timeouts. Lines: the power laws fitted over the certified problems of at
  least ``FIT_MIN_CONTACTS`` contacts, their exponents in the legend. ADMM's point is its 1e-8
  run, or its 1e-10 rerun when only that one is certified.
* ``contact_scale_profile.png`` (:func:`profile_chart`): the Dolan–Moré performance profile
  per law, the fraction of problems certified within a factor tau of the fastest certified
  solver.
"""

from __future__ import annotations

import math
import textwrap
from typing import Any, Sequence

import numpy as np

from .charts import _plt, save_chart

#: the power laws are fitted over problems of at least this many contacts
FIT_MIN_CONTACTS = 10
#: and over at least this many problems
FIT_MIN_POINTS = 3
#: the solvers compared (ADMM with its 1e-10 rerun folded in) and their names
SOLVERS = ("ours", "admm", "pgs")
NAMES = {"ours": "ours (solve_contact_problem)", "admm": "Pinocchio ADMM",
         "admm-1e-10": "Pinocchio ADMM tol 1e-10", "pgs": "Pinocchio PGS"}
STYLE = {"ours": ("tab:blue", "o"), "admm": ("tab:orange", "D"), "pgs": ("tab:pink", "v")}


# -- the measures (the section's aggregates and the charts) ------------------------------------

def power_law_fit(n, t) -> tuple[float, float]:
    """Least-squares fit of ``t = c n^p`` in log-log: returns ``(p, c)`` (nan with fewer than
    two distinct n)."""
    n = np.asarray(n, dtype=float)
    t = np.asarray(t, dtype=float)
    if n.size < 2 or np.unique(n).size < 2:
        return math.nan, math.nan
    p, logc = np.polyfit(np.log(n), np.log(t), 1)
    return float(p), float(math.exp(logc))


def performance_profile(table: dict[str, list[float | None]], taus) -> dict[str, np.ndarray]:
    """Dolan-Moré profile: ``table[solver][j]`` is the solver's time on problem j (None or a
    non-finite value: not solved). Returns per solver the fraction of all problems solved
    within ``tau`` times the fastest solver's time on that problem, for each ``tau``."""
    solvers = list(table)
    T = np.array([[np.inf if v is None or not math.isfinite(v) else float(v)
                   for v in table[s]] for s in solvers], dtype=float).reshape(len(solvers), -1)
    best = T.min(axis=0) if T.size else np.zeros(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(np.isfinite(T), T / best, np.inf)
    taus = np.asarray(taus, dtype=float)
    n_prob = T.shape[1]
    return {s: (np.array([np.sum(ratio[i] <= tau) / n_prob for tau in taus]) if n_prob
                else np.zeros(taus.shape))
            for i, s in enumerate(solvers)}


def certified_times(records: list[dict[str, Any]], law: str) -> tuple[list[str],
                                                                       dict[str, list]]:
    """Per problem of ``law`` (in record order) each solver's time when certified, else None;
    ADMM's is its 1e-8 time when certified, else its 1e-10 time when that run is."""
    problems = list(dict.fromkeys(r["problem"] for r in records if r["law"] == law))
    by = {(r["problem"], r["solver"]): r for r in records if r["law"] == law}
    table: dict[str, list] = {s: [] for s in SOLVERS}
    for p in problems:
        for s in SOLVERS:
            r = by.get((p, s))
            if s == "admm" and not (r and r["certified"]):
                r = by.get((p, "admm-1e-10"))
            table[s].append(r["time_median"] if r and r["certified"] else None)
    return problems, table


# -- the charts ---------------------------------------------------------------------------------


def _points(records: list[dict[str, Any]], law: str, solver: str) -> list[dict[str, Any]]:
    """The record drawn for ``solver`` on each problem of ``law`` (ADMM: the 1e-10 rerun when
    it is certified and the 1e-8 run is not)."""
    by = {(r["problem"], r["solver"]): r for r in records if r["law"] == law}
    out = []
    for p in dict.fromkeys(r["problem"] for r in records if r["law"] == law):
        r = by.get((p, solver))
        if solver == "admm" and r is not None and not r["certified"]:
            rerun = by.get((p, "admm-1e-10"))
            if rerun is not None and rerun["certified"]:
                r = rerun
        if r is not None and r["status"] != "skipped":
            out.append(r)
    return out


def _title(fig, text: str) -> None:
    """A title wrapped to the figure's width, the panels laid out below it."""
    width = fig.get_size_inches()[0]
    lines = textwrap.wrap(text, width=int(15.5 * width))
    fig.suptitle("\n".join(lines), fontsize=9)
    fig.tight_layout()  # leaves the suptitle its room


def times_chart(records: list[dict[str, Any]], laws: Sequence[str], out,
                time_limit: float) -> str:
    plt = _plt()
    fig, axes = plt.subplots(1, len(laws), figsize=(6.4 * len(laws), 5.2), squeeze=False,
                             sharey=True)
    for ax, law in zip(axes[0], laws):
        problems, table = certified_times(records, law)
        n_of = {r["problem"]: r["n"] for r in records if r["law"] == law}
        for s in SOLVERS:
            color, marker = STYLE[s]
            pts = _points(records, law, s)
            ok = [r for r in pts if r["certified"]]
            bad = [r for r in pts if not r["certified"] and r["status"] != "timeout"
                   and r["time_median"]]
            hung = [r for r in pts if r["status"] == "timeout"]
            fit = [(n_of[p], t) for p, t in zip(problems, table[s])
                   if t is not None and n_of[p] >= FIT_MIN_CONTACTS]
            p_, c_ = (power_law_fit(*zip(*fit)) if len(fit) >= FIT_MIN_POINTS
                      else (math.nan, math.nan))
            label = NAMES[s] + (f": {len(ok)} certified, fit n^{p_:.2f}" if math.isfinite(p_)
                                else f": {len(ok)} certified")
            ax.scatter([r["n"] for r in ok], [r["time_median"] for r in ok], color=color,
                       marker=marker, s=26, alpha=0.85, label=label)
            if bad:
                ax.scatter([r["n"] for r in bad], [r["time_median"] for r in bad],
                           facecolors="none", edgecolors=color, marker=marker, s=26,
                           alpha=0.85)
            if hung:
                ax.scatter([r["n"] for r in hung], [time_limit] * len(hung), color=color,
                           marker="x", s=40)
            if math.isfinite(p_):
                ns = np.array([min(n for n, _ in fit), max(n for n, _ in fit)], dtype=float)
                ax.plot(ns, c_ * ns ** p_, color=color, lw=1.0, alpha=0.7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("number of contacts n")
        ax.set_title(f"law {law}", fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    axes[0][0].set_ylabel("median wall time per solve (s)")
    _title(fig, "contact problems (W, b, mu) from 2 to 1,000 contacts at tol 1e-8; filled: "
                "certified by the natural-map residual, hollow: not certified (or a peer's "
                f"time to its failure), x: killed at {time_limit:g} s; lines: power laws "
                f"fitted over certified problems of >= {FIT_MIN_CONTACTS} contacts (ADMM: its "
                "tol 1e-8 run, or its 1e-10 rerun when only that one is certified)")
    return save_chart(fig, out, "contact_scale_times.png")


def profile_chart(records: list[dict[str, Any]], laws: Sequence[str], out) -> str:
    plt = _plt()
    fig, axes = plt.subplots(1, len(laws), figsize=(6.0 * len(laws), 4.6), squeeze=False,
                             sharey=True)
    for ax, law in zip(axes[0], laws):
        problems, table = certified_times(records, law)
        finite = [t for s in SOLVERS for t in table[s] if t is not None]
        ratios = []
        for j in range(len(problems)):
            ts = [table[s][j] for s in SOLVERS if table[s][j] is not None]
            ratios += [t / min(ts) for t in ts]
        top = max(ratios + [10.0]) * 2.0 if finite else 10.0
        taus = np.geomspace(1.0, top, 400)
        prof = performance_profile(table, taus)
        for s in SOLVERS:
            color, _ = STYLE[s]
            ax.step(taus, prof[s], where="post", color=color, lw=1.6,
                    label=f"{NAMES[s]} ({sum(t is not None for t in table[s])}/"
                          f"{len(problems)} certified)")
        ax.set_xscale("log")
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlim(1.0, top)
        ax.set_xlabel("tau (time / fastest certified solver's time on the problem)")
        ax.set_title(f"law {law}: {len(problems)} problems", fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=8, loc="lower right")
    axes[0][0].set_ylabel("fraction of problems certified within tau")
    _title(fig, "performance profile (Dolan-Moré): solved = certified at 1e-8 by the "
                "natural-map residual (ADMM: at tol 1e-8, or at 1e-10 when only that run "
                "reaches it)")
    return save_chart(fig, out, "contact_scale_profile.png")
