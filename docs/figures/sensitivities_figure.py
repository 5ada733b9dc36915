"""Draws ``docs/figures/sensitivities.png`` for the user guide's "Trajectory sensitivities".

Run from the repository root: ``python docs/figures/sensitivities_figure.py``. Left: a ball
(e = 0.5) bouncing four times, dy(t)/dh and dv(t)/dh from ``sensitivity_series`` (lines) and from
central differences of whole simulations (dots). Right: the sliding box, dx(t)/dmu and
dv(t)/dmu through the slip -> stick stop (the corners' columns summed).
"""

from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import convimpact as ci  # noqa: E402
from convimpact.simulation import simulate  # noqa: E402

TIGHT = dict(rtol=1e-11, atol=1e-12, event_tol=1e-13)
H = 1e-6


def ball_panel(ax) -> None:
    scene = ci.load_scene("bouncing_ball", e=0.5)
    span = (0.0, 1.15)  # four impacts, before the bounces accumulate (t = 1.285 s)
    dense = np.linspace(*span, 561)
    res = simulate(scene, span, t_eval=dense, sensitivities=True, **TIGHT)
    s = res.sensitivity_series
    ax.plot(s["t"], s["state"][:, 1, 1], color="C0", label="dy/dh (variational)")
    ax.plot(s["t"], s["state"][:, 3, 1], color="C1", label="dv/dh (variational)")
    coarse = np.linspace(0.05, 1.1, 15)
    runs = []
    for sign in (1.0, -1.0):
        th = scene.theta0 + sign * H * np.array([0.0, 1.0])
        runs.append(simulate(scene, span, (th, scene.dtheta0), t_eval=coarse, **TIGHT))
    ax.plot(coarse, (runs[0].theta[:, 1] - runs[1].theta[:, 1]) / (2 * H), "o", color="C0",
            label="dy/dh (finite differences of runs)")
    ax.plot(coarse, (runs[0].dtheta[:, 1] - runs[1].dtheta[:, 1]) / (2 * H), "s", color="C1",
            label="dv/dh (finite differences of runs)")
    for ev in res.impacts:
        ax.axvline(ev.time, color="0.6", ls="--", lw=0.8)
    ax.set_title("ball, e = 0.5: derivatives w.r.t. the drop height h\n(dashed: impacts, "
                 "where the saltation matrix acts)", fontsize=9)
    ax.set_xlabel("t (s)")
    ax.legend(fontsize=7, loc="upper left")


def box_panel(ax) -> None:
    span = (0.0, 1.4)
    dense = np.linspace(*span, 561)
    box = ci.load_scene("sliding_box", v0=3.0, mu=0.3)
    res = simulate(box, span, t_eval=dense, sensitivities=True, **TIGHT)
    s = res.sensitivity_series
    ax.plot(s["t"], s["mu"][:, 0].sum(axis=1), color="C2", label="dx/dmu (variational)")
    ax.plot(s["t"], s["mu"][:, 3].sum(axis=1), color="C3", label="dv/dmu (variational)")
    coarse = np.linspace(0.05, 1.35, 14)
    runs = [simulate(ci.load_scene("sliding_box", v0=3.0, mu=0.3 + sign * H), span,
                     t_eval=coarse, **TIGHT) for sign in (1.0, -1.0)]
    ax.plot(coarse, (runs[0].theta[:, 0] - runs[1].theta[:, 0]) / (2 * H), "o", color="C2",
            label="dx/dmu (finite differences of runs)")
    ax.plot(coarse, (runs[0].dtheta[:, 0] - runs[1].dtheta[:, 0]) / (2 * H), "s", color="C3",
            label="dv/dmu (finite differences of runs)")
    stop = [ev for ev in res.event_sensitivities if ev.kind == "slip-stick"][0]
    ax.axvline(stop.time, color="0.6", ls="--", lw=0.8)
    ax.axhline(-3.0 ** 2 / (2 * 0.3 ** 2 * 9.81), color="C2", ls=":", lw=0.8,
               label="-v0^2/(2 mu^2 g) (closed form)")
    ax.set_title("box sliding to rest, mu = 0.3: derivatives w.r.t. mu\n(dashed: the "
                 "slip -> stick stop)", fontsize=9)
    ax.set_xlabel("t (s)")
    ax.legend(fontsize=7, loc="lower left")


def main(out: str = "docs/figures/sensitivities.png") -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    ball_panel(axes[0])
    box_panel(axes[1])
    fig.savefig(out, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main(*sys.argv[1:])
