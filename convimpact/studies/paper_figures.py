"""The PNG figures of ``convimpact paper``: :func:`write_figures` draws :data:`FIGURES` from a
:class:`~convimpact.studies.paper.PaperReport`."""

from __future__ import annotations

import os
from typing import Callable

import numpy as np

from .paper import PAPER, PENDULUM_3D_E, PENDULUM_3D_MU, PaperReport


def _property_table(report: PaperReport) -> dict:
    table = {}
    for key, per in report.results.items():
        ex = report.examples[key]
        T = 0.5 * float(ex.dq @ ex.M @ ex.dq)
        row = {}
        for law, r in per.items():
            if isinstance(r, str):
                row[law] = {"error": r}
            else:
                row[law] = {"held": r.diagnostics.held(), "regime": r.regime,
                            "energy_loss_fraction": r.energy_loss / T}
        table[f"{key}\ne = {ex.e:g}, mu = {ex.mu:g}"] = row
    return table


FIGURES = ("fig3_energy_loss.png", "fig5_tangential_velocity_a.png", "fig6_energy_loss_a.png",
           "fig7_tangential_velocity_b.png", "fig9_angle_sweep.png", "fig10_tangent_plane.png",
           "laws_properties.png", "laws_pendulum_a.png", "laws_pendulum_b.png",
           "laws_pendulum_3d.png")


def write_figures(report: PaperReport, out: str,
                  progress: Callable[[str], None] | None = None) -> list[str]:
    """Draw the PNG figures of the report into ``out``; returns their paths. ``progress``,
    when given, is told each figure as it is drawn (and the fine law landscapes as they are
    computed)."""
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .paper import _law_landscapes, _pendulum_landscapes
    from .plotting import (clip_note, landscape_colorbar, plot_angle_sweep, plot_energy_fraction,
                           plot_landscape, plot_law_properties, plot_tangent_vectors,
                           plot_velocity_comparison)

    os.makedirs(out, exist_ok=True)
    paths = []

    def save(fig, name):
        path = os.path.join(out, name)
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        paths.append(path)
        if progress:
            progress(f"figure {len(paths)}/{len(FIGURES)} written: {name}")

    d = report.data
    grid = d["settings"]
    # Fig. 3
    f3 = d["fig3"]
    fig, ax = plt.subplots(figsize=(7, 5))
    plot_energy_fraction(np.array(f3["e"]), {k: v for k, v in f3["cases"].items()}, ax=ax,
                         title="Fig. 3: slider-crank striking the free slider (central impact)")
    ax.text(0.02, 0.03, "paper at e = 0: 100 %, 54 %, 32 % (cases 1-3)\n"
            "our geometry: m4 = 1, 5, 10 x the crank-slider's generalized mass",
            transform=ax.transAxes, fontsize=7, va="bottom")
    save(fig, FIGURES[0])
    # Figs. 5-7: drawn on a finer grid than paper.json's (the closed form is vectorized), so
    # that the hatched regions' edges are finer than a pixel; the stick boundary is exact
    fine = _pendulum_landscapes(report.examples, grid["figure_landscape_grid"])
    slip_label = "outgoing slip along the pre-impact slip [m/s]"
    for name, key, q, title in (
            (FIGURES[1], "pendulum_a", "tangential_velocity",
             "Fig. 5: pendulum (a), outgoing tangential velocity (Section 8)"),
            (FIGURES[2], "pendulum_a", "energy_loss",
             "Fig. 6: pendulum (a), energy loss $T_L$ (eq. 60)"),
            (FIGURES[3], "pendulum_b", "tangential_velocity",
             "Fig. 7: pendulum (b), outgoing tangential velocity (Section 8)")):
        L, iv = fine[key]
        fig, ax = plt.subplots(figsize=(7.5, 6.8))
        # positive: the contact still slides the way it came (the paper's "positive v_t+");
        # it is zero on the whole stick region (no zero contour: the region is outlined)
        values = -L.tangential_velocity if q == "tangential_velocity" else None
        # symmetric colour scale of the velocity maps: the 98th percentile of |v|, at most
        # 1.5 |v_r-| (the slip blows up near a jam)
        vlim = None
        if values is not None:
            speed = float(np.linalg.norm(L.meta["v_minus"]))
            fin = np.abs(values[np.isfinite(values)])
            top = min(1.5 * speed, float(np.percentile(fin, 98.0))) if fin.size else speed
            vlim = (-top, top)
        plot_landscape(L, q, ax=ax, title=title, stiction=(iv.lower, iv.upper),
                       zero_contour=values is None, values=values,
                       label=slip_label if values is not None else None, robust=True,
                       legend="below", limits=vlim)
        vm = L.meta["v_minus"]
        ax.text(0.99, 0.01, f"$v_r^-$ = {vm[0]:.3f} n {vm[1]:+.3f} t\n"
                r"$\mu$ > 0: friction opposes the slip (eq. 55); $\mu$ < 0: along it",
                transform=ax.transAxes, ha="right", va="bottom", fontsize=7,
                bbox=dict(fc="w", alpha=0.8, lw=0))
        save(fig, name)
    # Fig. 9
    f9 = d["fig9"]
    fig, ax = plt.subplots(figsize=(7.5, 5.6))
    nanify = lambda a: np.array([np.nan if x is None else x for x in a])  # noqa: E731
    plot_angle_sweep(np.array(f9["alpha"]), nanify(f9["energy_loss"]),
                     nanify(f9["normal_impulse"]), alpha_m=f9["alpha_m"], ax=ax,
                     gain_sectors=f9["energy_gain_sectors"],
                     alpha_max_normal_impulse=f9["alpha_max_normal_impulse"],
                     title=f"Fig. 9: 3D pendulum, e = {f9['e']}, $\\mu$ = {f9['mu']} "
                           f"(sliding along t($\\alpha$), eq. 38/60)")
    save(fig, FIGURES[4])
    # Fig. 10: velocities [m/s] and impulses [N s] on separate axes
    f10 = d["fig10"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 6.4), layout="constrained")
    plot_tangent_vectors({r"$v_t^-$ (before)": f10["v_t_minus"],
                          r"$\Delta v_t$ (jump)": f10["delta_v_t"],
                          r"$v_t^+$ (after)": f10["v_t_plus"]}, ax=ax1, legend=True,
                         unit="m/s", title="tangential velocities [m/s]")
    pit = np.asarray(f10["pi_t"], float)
    t_avg = np.linalg.norm(pit) * np.asarray(f10["t_average"], float)
    plot_tangent_vectors({r"$\pi_t$ (maximal dissipation)": pit,
                          r"$-(v_t^- + v_t^+)$ direction, scaled to $|\pi_t|$": t_avg},
                         ax=ax2, legend=True, unit="N s", dashed=(
                             r"$-(v_t^- + v_t^+)$ direction, scaled to $|\pi_t|$",),
                         colors={r"$\pi_t$ (maximal dissipation)": "C3",
                                 r"$-(v_t^- + v_t^+)$ direction, scaled to $|\pi_t|$": "C4"},
                         title="tangential impulse [N s]")
    ax2.text(0.5, -0.34, "dashed: the direction of the averaging rule the paper compares with\n"
             "(its ref. [17]): opposite to the mean of the approach and separation slips;\n"
             f"{abs(f10['angle_pi_t_to_t_average_deg']):.1f} deg from $\\pi_t$",
             transform=ax2.transAxes, ha="center", va="top", fontsize=8)
    fig.suptitle("Fig. 10: 3D pendulum, the tangent plane at maximal dissipation "
                 f"(e = {PENDULUM_3D_E}, $\\mu$ = {PENDULUM_3D_MU})", fontsize=12)
    save(fig, FIGURES[5])
    # laws side by side
    fig, ax = plt.subplots(figsize=(13, 7))
    plot_law_properties(_property_table(report), ax=ax,
                        title="the examples under each law: properties kept "
                              "(green: all; red: broken ones listed)")
    save(fig, FIGURES[6])
    fine_laws = _law_landscapes(report.examples, grid["figure_law_landscape_grid"], progress)
    for name, key in ((FIGURES[7], "pendulum_a"), (FIGURES[8], "pendulum_b")):
        per = fine_laws[key]
        low = min(float(np.nanmin(L.energy_loss_fraction)) for L in per.values())
        fig, axes = plt.subplots(1, len(per), figsize=(5.0 * len(per) + 1.2, 5.9),
                                 layout="constrained")
        for ax, (law, L) in zip(axes, per.items()):
            plot_landscape(L, "energy_loss_fraction", ax=ax, title=f"{law}", levels=21,
                           limits=(-1.0, 1.0), legend="below", colorbar=False,
                           extend="min" if low < -1.0 else "neither")
        note = clip_note(low, 1.0, -1.0, 1.0)
        landscape_colorbar(axes[0].convimpact_mappable, list(axes),
                           "energy loss fraction $T_L/T^-$ (negative: energy gained)", note)
        vm = report.examples[key].v_minus
        fig.suptitle(f"{key} ($v_r^-$ = {vm[0]:.3f} n {vm[1]:+.3f} t): energy loss fraction "
                     "$T_L/T^-$ under each law, failure regions marked", fontsize=12)
        save(fig, name)
    comp = {law: r.v_plus for law, r in report.results["pendulum_3d"].items()
            if not isinstance(r, str)}
    fig, ax = plt.subplots(figsize=(8, 5.2))
    pv = PAPER["pendulum_3d"]["v_plus"]
    plot_velocity_comparison(comp, reference=np.array(pv), ax=ax,
                             reference_label=f"paper: {pv[0]} n + {pv[1]} t1 + {pv[2]} t2",
                             title=f"3D pendulum (e = {PENDULUM_3D_E}, mu = {PENDULUM_3D_MU}): "
                                   "$v_r^+$ under each law")
    save(fig, FIGURES[9])
    return paths


__all__ = ["FIGURES", "write_figures"]
