"""The contact-mode figure of a simulation: per contact, its mode timeline and its forces.

:func:`plot_contacts` draws, per contact, the mode timeline and the contact force series
(normal force, tangential force magnitude, and the friction bound mu lambda_n); used by
``convimpact simulate`` (``contacts.png``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Union

import numpy as np

from .animation_frames import MODE_COLORS, contact_columns
from .result import MODE_NAMES, SimulationResult


def _mode_runs(result: SimulationResult, contact: str,
               column: int | None) -> list[tuple[str, float, float]]:
    """(mode, t_start, t_end) runs of one contact over the run."""
    t0, t1 = float(result.t[0]), float(result.t[-1])
    ivs = result.modes_of(contact)
    if ivs:
        return [(iv.mode, float(iv.t_start), float(iv.t_end)) for iv in ivs]
    cm = result.contact_mode
    if column is None or cm.ndim != 2 or cm.shape[0] != len(result.t) or cm.shape[0] == 0:
        return [("open", t0, t1)]
    codes = cm[:, column]
    runs = []
    start = 0
    for j in range(1, len(codes) + 1):
        if j == len(codes) or codes[j] != codes[start]:
            end_t = float(result.t[j]) if j < len(codes) else t1
            runs.append((MODE_NAMES[int(codes[start])], float(result.t[start]), end_t))
            start = j
    return runs


def plot_contacts(result: SimulationResult, path: Union[str, Path], mechanism: Any = None,
                  title: str | None = None) -> Path | None:
    """Per contact: the mode timeline and, under it, the contact force series.

    For each contact a band shows its modes over time (open grey, stick green, slip red)
    and a plot under it the normal force lambda_n, the tangential force magnitude
    |lambda_t| and the friction bound mu lambda_n (dashed; needs ``mechanism`` for mu).
    Impacts are vertical lines (dark for the contact's own impacts, light for the others),
    a Painleve stop a magenta dotted line.

    Parameters
    ----------
    result : the simulation.
    path : the PNG file to write.
    mechanism : optional, the simulated mechanism: supplies mu (``contact_parameters``) and
        the contact names when the result did not record them.
    title : figure title.

    Returns
    -------
    Path of the written PNG, or None when there are no contacts (nothing is written).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    names = list(result.contact_names) or list(getattr(mechanism, "contact_names", None) or [])
    if not names or len(result.t) == 0:
        return None
    cols = contact_columns(result, names)
    n = len(names)
    per = 2.4 if n <= 4 else 1.9
    fig = Figure(figsize=(9.0, 1.0 + per * n), dpi=100)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2 * n, 1, sharex=True,
                        gridspec_kw={"height_ratios": [0.45, 2.0] * n, "hspace": 0.12})
    t = result.t
    f = result.contact_force
    have_forces = f.ndim == 3 and f.shape[0] == len(t) and f.shape[0] > 0
    t_pl = [ev.time for ev in result.painleve]
    for c, (name, col) in enumerate(zip(names, cols)):
        ax_mode, ax_force = axes[2 * c], axes[2 * c + 1]
        for mode in MODE_NAMES:
            bars = [(a, b - a) for m, a, b in _mode_runs(result, name, col) if m == mode]
            if bars:
                ax_mode.broken_barh(bars, (0.0, 1.0), facecolors=MODE_COLORS[mode],
                                    edgecolor="none")
        ax_mode.set_ylim(0, 1)
        ax_mode.set_yticks([])
        mu = None
        if mechanism is not None and hasattr(mechanism, "contact_parameters"):
            try:
                mu = float(mechanism.contact_parameters(name)[1])
            except Exception:  # noqa: BLE001 - a user mechanism without parameters
                mu = None
        label = name if mu is None else f"{name}\n(mu = {mu:g})"
        ax_mode.set_ylabel(label, rotation=0, ha="right", va="center", fontsize="small")
        if have_forces and col is not None and col < f.shape[1]:
            lam_n = f[:, col, 0]
            lam_t = np.linalg.norm(f[:, col, 1:], axis=1)
            ax_force.plot(t, lam_n, color="C0", lw=1.2)
            ax_force.plot(t, lam_t, color="C4", lw=1.2)
            if mu is not None and mu > 0:
                ax_force.plot(t, mu * lam_n, color="C4", lw=1.0, ls="--", alpha=0.7)
        else:
            ax_force.text(0.5, 0.5, "no contact forces recorded", transform=ax_force.transAxes,
                          ha="center", va="center", color="0.4", fontsize="small")
        ax_force.set_ylabel("force [N]", fontsize="small")
        ax_force.tick_params(labelsize="x-small")
        for ax in (ax_mode, ax_force):
            for ev in result.impacts:
                own = name in ev.contacts
                ax.axvline(ev.time, color="0.25" if own else "0.8", lw=0.9 if own else 0.5,
                           ls="-" if own else ":", zorder=3 if ax is ax_mode else 0)
            for tp in t_pl:
                ax.axvline(tp, color="m", lw=1.2, ls=":", zorder=4)
    axes[-1].set_xlabel("t [s]")
    axes[-1].set_xlim(float(t[0]), float(t[-1]) if t[-1] > t[0] else float(t[0]) + 1.0)
    handles = [Patch(facecolor=MODE_COLORS[m], label=m) for m in MODE_NAMES]
    handles += [Line2D([], [], color="C0", lw=1.2, label=r"$\lambda_n$"),
                Line2D([], [], color="C4", lw=1.2, label=r"$|\lambda_t|$"),
                Line2D([], [], color="C4", lw=1.0, ls="--", alpha=0.7, label=r"$\mu\lambda_n$"),
                Line2D([], [], color="0.25", lw=0.9, label="impact")]
    if t_pl:
        handles.append(Line2D([], [], color="m", lw=1.2, ls=":", label="Painleve"))
    fig.legend(handles=handles, loc="upper right", ncol=len(handles), frameon=False,
               fontsize="small", bbox_to_anchor=(0.98, 1.0))
    fig.suptitle(title or "contact modes and forces", x=0.02, ha="left", fontsize="medium")
    fig.subplots_adjust(left=0.12, right=0.98, top=1.0 - 0.55 / fig.get_size_inches()[1],
                        bottom=0.45 / fig.get_size_inches()[1] + 0.02)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    fig.clear()
    return path
