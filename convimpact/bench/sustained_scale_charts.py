"""Charts of the ``sustained-scale`` bench section (:mod:`.sustained_scale_section`).

* ``sustained_scale_stop.png`` (:func:`stop_chart`): one stop's force problem, median time
  against the number of contacts (tables at rest and sliding), ours and the mode enumerator.
* ``sustained_scale_simulation.png`` (:func:`simulation_chart`): wall time per simulated
  second against the number of contacts, event-driven (ours) and MuJoCo, tables at rest and
  sliding (lines) and the box stack (single points), with the fitted growth exponents; and
  beside it the tables' stop-distance errors against the closed form v0^2 / (2 mu g).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .charts import _plt, save_chart
from .contact_scale_charts import power_law_fit

STYLE = {"rest": "--", "slide": "-"}
COLORS = {"event-driven": "tab:blue", "mujoco": "tab:orange", "enumerator": "tab:red"}


def stop_chart(records: list[dict[str, Any]], out: Path) -> str:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for kind in ("rest", "slide"):
        rs = sorted((r for r in records if r["part"] == "stop"
                     and r["scene"] == f"table-{kind}"), key=lambda r: r["contacts"])
        n = [r["contacts"] for r in rs]
        t = [r["ours_time"] for r in rs]
        p, _ = power_law_fit(n, t)
        ax.loglog(n, t, STYLE[kind], marker="o", color=COLORS["event-driven"],
                  label=f"ours, table {kind} (n^{p:.2f})")
        en = [(r["contacts"], r["enumerator_time"]) for r in rs if r["enumerator_time"]]
        if en:
            ax.loglog(*zip(*en), STYLE[kind], marker="s", color=COLORS["enumerator"],
                      label=f"mode enumerator, table {kind}")
    ax.set_xlabel("closed contacts (table legs)")
    ax.set_ylabel("seconds per stop (median)")
    ax.set_title("one stop's contact force problem: engine-based solver vs enumeration")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return save_chart(fig, out, "sustained_scale_stop.png")


def simulation_chart(records: list[dict[str, Any]], out: Path) -> str:
    plt = _plt()
    fig, (ax, rx, bx) = plt.subplots(1, 3, figsize=(19, 5.8))
    sims = [r for r in records if r["part"] == "simulation"]
    _ratio_panel(rx, sims)
    for scheme in ("event-driven", "mujoco"):
        for kind in ("rest", "slide"):
            rs = sorted((r for r in sims if r["scheme"] == scheme
                         and r["scene"] == f"table-{kind}"), key=lambda r: r["contacts"])
            if not rs:
                continue
            n = [r["contacts"] for r in rs]
            t = [r["wall_per_second"] for r in rs]
            p, _ = power_law_fit(n, t)
            name = "ours (event-driven)" if scheme == "event-driven" else "MuJoCo (2 ms)"
            ax.loglog(n, t, STYLE[kind], marker="o", color=COLORS[scheme],
                      label=f"{name}, table {kind} (n^{p:.2f})")
            if kind == "slide":
                bx.loglog(n, [max(r["distance_error"], 1e-16) for r in rs], marker="o",
                          color=COLORS[scheme], label=name)
        who = "ours" if scheme == "event-driven" else "MuJoCo"
        for r in sims:
            if r["scene"] == "box_stack" and r["scheme"] == scheme:
                ax.loglog([r["contacts"]], [r["wall_per_second"]], marker="*", ms=13, ls="",
                          color=COLORS[scheme], label=f"{who}, box stack (tip time error "
                          f"{r['tip_time_error']:.1e})")
            if r["scene"] == "humanoid_push" and r["scheme"] == scheme:
                ax.loglog([r["contacts"]], [r["wall_per_second"]], marker="P", ms=11, ls="",
                          color=COLORS[scheme], label=f"{who}, humanoid pushed "
                          f"(penetration {r['penetration']:.1e} m)")
    ax.set_xlabel("contacts")
    ax.set_ylabel("wall seconds per simulated second")
    ax.set_title("simulation cost against the number of contacts (dashed: at rest)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    bx.set_xlabel("table legs (sliding)")
    bx.set_ylabel("|distance - v0^2/(2 mu g)| / (v0^2/(2 mu g))")
    bx.set_title("sliding table: stop distance against the closed form")
    bx.grid(True, which="both", alpha=0.3)
    bx.legend(fontsize=8)
    fig.tight_layout()
    return save_chart(fig, out, "sustained_scale_simulation.png")


def _ratio_panel(ax, sims: list[dict[str, Any]]) -> None:
    """Ours / MuJoCo per simulated second against the contacts, wall and CPU time, with
    the 10x target."""
    for kind, marker in (("rest", "o"), ("slide", "s"), ("box_stack", "*"),
                         ("humanoid_push", "P")):
        scene = f"table-{kind}" if kind in ("rest", "slide") else kind
        ours = {r["contacts"]: r for r in sims if r["scene"] == scene
                and r["scheme"] == "event-driven"}
        mj = {r["contacts"]: r for r in sims if r["scene"] == scene and r["scheme"] == "mujoco"}
        n = sorted(c for c in ours if c in mj)
        if not n:
            continue
        for key, style, what in (("wall_per_second", "-", "wall"), ("cpu_per_second", ":",
                                                                     "CPU")):
            if not all(ours[c].get(key) and mj[c].get(key) for c in n):
                continue
            ax.loglog(n, [ours[c][key] / mj[c][key] for c in n], style, marker=marker,
                      ms=6 if marker in "os" else 10, color=COLORS["event-driven"]
                      if what == "wall" else "tab:green",
                      label=f"{scene}, {what} time")
    ax.axhline(10.0, color="tab:red", lw=1, ls="--", label="10x (target)")
    ax.set_xlabel("contacts")
    ax.set_ylabel("ours / MuJoCo per simulated second")
    ax.set_title("ratio to MuJoCo (same run; CPU time: the process's)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
