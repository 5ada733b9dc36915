"""Charts of the ``moreau-scale`` bench section (:mod:`.moreau_scale_section`).

* ``moreau_scale_growth.png`` (:func:`growth_chart`): wall time per simulated second against
  the number of contacts (log-log), one panel per motion (sliding, at rest): ours per law and
  MuJoCo, each with its fitted power law (exponent in the legend) and the 10x MuJoCo line;
  every law of the section (ccp, coulomb, dissipative on the engine, the others island by
  island);
* ``moreau_pile.png`` (:func:`pile_chart`): the disc pile, E(t) - E(0) of both simulators
  and the final piles side by side.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .charts import _plt, save_chart

STYLE = {"ccp": ("tab:blue", "o"), "coulomb": ("tab:red", "s"),
         "dissipative": ("tab:green", "D"), "pereira-nikravesh": ("tab:purple", "v"),
         "stronge": ("tab:orange", "P"), "mujoco": ("black", "^")}


def growth_chart(records: list[dict[str, Any]], exps: dict[str, Any], out, step: float) -> str:
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(13, 7), sharey=True)
    for ax, motion in zip(axes, ("sliding", "rest")):
        mj = None
        for law in STYLE:
            pts = sorted((r["contacts"], r["wall_per_simulated_second"]) for r in records
                         if r["law"] == law and r.get("motion") == motion
                         and not r.get("ablation"))
            if not pts:
                continue
            n, t = map(np.array, zip(*pts))
            color, marker = STYLE[law]
            fit = exps.get(f"{law}/{motion}")
            name = "MuJoCo" if law == "mujoco" else f"Moreau–Jean, law {law}"
            label = name + (f" (fit n^{fit['exponent']:.2f})" if fit else "")
            ax.plot(n, t, marker=marker, color=color, lw=0, ms=7, label=label)
            if fit:
                ax.plot(n, fit["coefficient"] * n ** fit["exponent"], color=color, lw=1,
                        alpha=0.7)
            if law == "mujoco":
                mj = (n, t)
        if mj is not None:
            ax.plot(mj[0], 10 * mj[1], color="gray", ls="--", lw=1, label="10x MuJoCo")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ns = sorted({r["contacts"] for r in records if r.get("motion") == motion})
        ax.set_xticks(ns)
        ax.set_xticklabels([str(n) for n in ns])
        ax.minorticks_off()
        ax.set_xlabel("number of contacts (4 per box)")
        ax.set_title("boxes sliding at 2 m/s" if motion == "sliding" else "boxes at rest",
                     fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    axes[0].set_ylabel("wall time per simulated second (s)")
    fig.suptitle(f"Moreau–Jean vs MuJoCo, same step h = {step:g} s: ccp, coulomb and "
                 "dissipative on the contact engine (certified at 1e-8),\npereira-nikravesh and "
                 "stronge island by island (the law's impulse, resolve_impact at impacts; "
                 "pereira-nikravesh's resting\nislands by the certificate of its answer, its "
                 "sliding ones by its compiled search without the dominated active sets\nand "
                 "those certified to have no admissible impulse, after the first step, all in "
                 "one compiled call per step;\nstronge's islands in one "
                 "compiled call on steps without an impact; medians)", fontsize=10)
    fig.tight_layout()
    return save_chart(fig, out, "moreau_scale_growth.png")


def pile_chart(series: dict[str, Any], records: list[dict[str, Any]], out) -> str:
    plt = _plt()
    from matplotlib.patches import Circle

    by = {r["law"]: r for r in records}
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8))
    ax = axes[0]
    colors = {"ccp": "tab:blue", "coulomb": "tab:red"}
    for law, (t, e, _) in series["ours"].items():
        ax.plot(t, e, color=colors.get(law, "tab:green"),
                label=f"Moreau–Jean, {law}: {by[law]['wall_per_simulated_second']:.3g} s per "
                      "simulated s")
    t, e, _ = series["mujoco"]
    ax.plot(t, e, color="black",
            label=f"MuJoCo: {by['mujoco']['wall_per_simulated_second']:.3g} s per simulated s")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("E(t) - E(0) (J)")
    ax.set_title("total energy (e = 0)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    width = series["width"]
    law = list(series["ours"])[-1]
    panels = ((axes[1], series["ours"][law][2],
               f"Moreau–Jean ({law}) at t end: {by[law]['contacts']} contacts at most, "
               f"penetration {by[law]['max_penetration']:.1e} m"),
              (axes[2], series["mujoco"][2],
               f"MuJoCo at t end: {by['mujoco']['contacts']} contacts at most, "
               f"penetration {by['mujoco']['max_penetration']:.1e} m"))
    for ax, xy, title in panels:
        for (x, y), r in zip(xy, series["radii"]):
            ax.add_patch(Circle((x, y), r, fill=False, lw=0.8))
        top = float(np.max(xy[:, 1])) + 0.1
        ax.plot([0, 0, width, width], [top, 0, 0, top], color="k", lw=1.5)
        ax.set_xlim(-0.05, width + 0.05)
        ax.set_ylim(-0.05, top)
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=9)
    fig.suptitle(f"disc pile: {len(series['radii'])} discs settling in a box, same step "
                 f"h = {series['h']:g} s", fontsize=10)
    fig.tight_layout()
    return save_chart(fig, out, "moreau_pile.png")
