"""Matplotlib helpers for landscapes, angle sweeps and tangent-plane vectors (the paper's figures).

matplotlib is imported lazily; every function takes an optional ``ax`` and returns it.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .landscape import Landscape

_LABELS = {
    "energy_loss": "energy loss $T_L$ [J]",
    "energy_loss_fraction": "energy loss fraction $T_L/T^-$",
    "tangential_velocity": "outgoing slip $v_t^+$ along $t$ [m/s]",
    "normal_impulse": r"normal impulse $\pi_n$ [N s]",
}


def _axes(ax):
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(6.4, 4.8))
    return ax


def plot_landscape(L: Landscape, quantity: str = "tangential_velocity", ax=None,
                   title: str | None = None, levels: int = 21):
    """Filled contours of ``quantity`` over (mu, e) with the failure regions marked.

    Marked: where sticking is possible (solid outline), where energy is gained (hatched ``//``),
    where friction pushes the pre-impact slip (dotted outline), slip reversal (hatched ``\\\\``)
    and where the law jams or fails (grey).
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    ax = _axes(ax)
    Z = np.asarray(getattr(L, quantity), float)
    if Z.ndim == 3:
        Z = np.linalg.norm(Z, axis=-1)
    MU, E = np.meshgrid(L.mu, L.e)
    finite = np.isfinite(Z)
    if finite.any():
        lo, hi = np.nanmin(Z[finite]), np.nanmax(Z[finite])
        if hi <= lo:
            hi = lo + 1.0
        span = np.linspace(lo - 1e-9 * abs(hi - lo), hi + 1e-9 * abs(hi - lo), levels)
        cs = ax.contourf(MU, E, np.where(finite, Z, np.nan), levels=span, cmap="viridis")
        plt.colorbar(cs, ax=ax, label=_LABELS.get(quantity, quantity))
    handles = []
    bad = L.jammed | L.failed
    if bad.any():
        ax.contourf(MU, E, bad.astype(float), levels=[0.5, 1.5], colors=["0.6"])
        handles.append(Patch(color="0.6", label="jam / solver failure"))
    for mask, hatch, label in ((L.energy_gained, "//", "energy gained"),
                               (L.slip_reversal, "\\\\", "slip reversal")):
        if mask.any():
            ax.contourf(MU, E, mask.astype(float), levels=[0.5, 1.5], colors="none",
                        hatches=[hatch])
            ax.contour(MU, E, mask.astype(float), levels=[0.5], colors="k", linewidths=0.6)
            handles.append(Patch(facecolor="none", edgecolor="k", hatch=hatch, label=label))
    for mask, style, color, label in ((L.stick_possible, "-", "crimson", "stick boundary"),
                                      (L.friction_pushes_slip, ":", "darkorange",
                                       "friction pushes slip")):
        if mask.any() and not mask.all():
            ax.contour(MU, E, mask.astype(float), levels=[0.5], colors=color,
                       linestyles=style, linewidths=2.0)
            handles.append(plt.Line2D([], [], color=color, ls=style, lw=2.0, label=label))
    ax.set_xlabel(r"friction coefficient $\mu$")
    ax.set_ylabel("coefficient of restitution $e$")
    ax.set_title(title or f"{L.law} / {L.method}: {quantity.replace('_', ' ')}")
    if handles:
        ax.legend(handles=handles, loc="upper left", fontsize=8, framealpha=0.85)
    return ax


def plot_angle_sweep(alpha: np.ndarray, energy_loss: np.ndarray, normal_impulse: np.ndarray,
                     alpha_m: float | None = None, gain_sector: Sequence[float] | None = None,
                     ax=None, title: str | None = None):
    """The paper's Fig. 9: T_L and pi_n versus the angle alpha of the tangential impulse.

    ``alpha`` in radians, measured counter-clockwise from v_t-; shown in degrees.
    """
    ax = _axes(ax)
    deg = np.degrees(alpha)
    ax.plot(deg, energy_loss, color="C0", label="energy loss $T_L$ [J]")
    ax.set_xlabel(r"angle $\alpha$ of the tangential impulse from $v_t^-$ [deg]")
    ax.set_ylabel("energy loss [J]", color="C0")
    ax.axhline(0.0, color="0.5", lw=0.5)
    ax2 = ax.twinx()
    ax2.plot(deg, normal_impulse, color="C1", ls="--", label=r"normal impulse $\pi_n$")
    ax2.set_ylabel(r"normal impulse $\pi_n$ [N s]", color="C1")
    if gain_sector is not None and np.all(np.isfinite(gain_sector)):
        a0, a1 = np.degrees(gain_sector)
        ax.axvspan(a0, a1, color="C3", alpha=0.15, label="energy gain sector")
    if alpha_m is not None:
        ax.axvline(np.degrees(alpha_m), color="k", ls=":",
                   label=rf"$\alpha_m$ = {np.degrees(alpha_m):.2f}$^\circ$")
    ax.legend(loc="lower left", fontsize=8)
    ax.set_title(title or "energy loss and normal impulse versus impulse direction")
    return ax


def plot_tangent_vectors(vectors: dict[str, np.ndarray], ax=None, title: str | None = None):
    """The paper's Fig. 10: vectors in the tangent plane (t1 right, t2 up), from the origin."""
    ax = _axes(ax)
    lim = 0.0
    for i, (name, vec) in enumerate(vectors.items()):
        vec = np.asarray(vec, float)[-2:]
        ax.annotate("", xy=vec, xytext=(0, 0),
                    arrowprops=dict(arrowstyle="->", color=f"C{i}", lw=2))
        ax.text(*(1.05 * vec), name, color=f"C{i}", fontsize=10)
        lim = max(lim, float(np.abs(vec).max()))
    lim = 1.25 * lim or 1.0
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    ax.axhline(0, color="0.7", lw=0.5)
    ax.axvline(0, color="0.7", lw=0.5)
    ax.set_xlabel("$t_1$")
    ax.set_ylabel("$t_2$")
    ax.set_title(title or "tangent plane")
    return ax
