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


def nice_levels(lo: float, hi: float, n: int = 21) -> np.ndarray:
    """About ``n`` contour levels at round values (steps 1, 2, 2.5, 5 x 10^k) covering [lo, hi]."""
    from matplotlib.ticker import MaxNLocator

    lo, hi = float(lo), float(hi)
    if not hi > lo:
        hi = lo + 1.0
    levels = MaxNLocator(nbins=max(n - 1, 2), steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
    # MaxNLocator may pad by one step on each side; keep only what covers [lo, hi]
    first = np.searchsorted(levels, lo, side="right") - 1
    last = np.searchsorted(levels, hi, side="left")
    return np.round(levels[max(first, 0):last + 1], 12)


def nice_ticks(lo: float, hi: float, n: int = 7) -> np.ndarray:
    """At most about ``n`` round tick values inside [lo, hi]."""
    from matplotlib.ticker import MaxNLocator

    t = MaxNLocator(nbins=n, steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
    span = 1e-9 * (hi - lo)
    return np.round(t[(t >= lo - span) & (t <= hi + span)], 12)


def _extend(zmin: float, zmax: float, lo: float, hi: float) -> str:
    below, above = zmin < lo, zmax > hi
    return {(True, True): "both", (True, False): "min", (False, True): "max"}.get(
        (below, above), "neither")


def clip_note(zmin: float, zmax: float, lo: float, hi: float) -> str:
    """The caption of a colour bar whose scale clips the data (empty when it does not)."""
    def fmt(x: float) -> str:
        return f"{x:.0f}" if abs(x) >= 1000 else f"{x:.3g}"

    parts = []
    if zmin < lo:
        parts.append(f"down to {fmt(zmin)}")
    if zmax > hi:
        parts.append(f"up to {fmt(zmax)}")
    if not parts:
        return ""
    return "pointed ends: values beyond the scale (" + ", ".join(parts) + ")"


def landscape_colorbar(mappable, ax, label: str, note: str = ""):
    """A colour bar with round ticks for one or several axes (``ax`` may be a list)."""
    import matplotlib.pyplot as plt

    lv = np.asarray(mappable.levels, float)
    cb = plt.colorbar(mappable, ax=ax, label=label + (f"\n{note}" if note else ""))
    cb.set_ticks(nice_ticks(lv[0], lv[-1]))
    return cb


def plot_landscape(L: Landscape, quantity: str = "tangential_velocity", ax=None,
                   title: str | None = None, levels: int = 21,
                   stiction: tuple[float, float] | None = None, zero_contour: bool = False,
                   values: np.ndarray | None = None, label: str | None = None,
                   robust: bool = False, legend: str = "inside",
                   limits: tuple[float, float] | None = None, colorbar: bool = True,
                   extend: str | None = None):
    """Filled contours of ``quantity`` over (mu, e) with the failure regions marked.

    Marked: the boundary of the stick region (solid crimson; drawn exactly, see
    :class:`~convimpact.studies.landscape.StickBoundary`, for planar landscapes, else from
    the grid), where energy is gained (hatched ``//``), where friction pushes the pre-impact slip
    (dotted outline), slip reversal (hatched ``\\\\``) and where the law jams or fails (grey).

    Optional:

    * ``stiction = (e_lower, e_upper)`` draws the bounds on e of the necessary stiction
      conditions (eq. 62, e.g. from :func:`convimpact.stiction_interval`) as dashed lines (an
      empty interval, NaN bounds, is stated in the legend);
    * ``zero_contour`` draws the level ``quantity = 0`` in light blue where it is a curve
      (a velocity vanishes on the whole stick region, which is marked instead);
    * ``values`` (shape (len(e), len(mu))) replaces ``getattr(L, quantity)``, ``label`` the
      colour-bar label;
    * ``robust`` limits the colour scale to the 2nd-98th percentiles, so that a blow-up near a
      jam does not wash out the map; ``limits = (low, high)`` fixes it. Levels and ticks fall
      on round values; values beyond the scale take the end colours and the colour bar gets
      pointed ends, explained in its label;
    * ``colorbar=False`` draws no colour bar: the filled contours are left in
      ``ax.convimpact_mappable`` and ``ax.convimpact_range`` = (data min, data max) for
      :func:`landscape_colorbar` over several axes (pass the same ``limits`` and ``extend``);
    * ``legend``: ``"inside"`` (upper left), ``"below"`` (under the axes) or ``"none"``.
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    from .landscape import landscape_stick_boundary

    ax = _axes(ax)
    Z = np.asarray(getattr(L, quantity) if values is None else values, float)
    if Z.ndim == 3:
        Z = np.linalg.norm(Z, axis=-1)
    MU, E = np.meshgrid(L.mu, L.e)
    finite = np.isfinite(Z)
    label = label or _LABELS.get(quantity, quantity)
    if finite.any():
        zmin, zmax = float(np.min(Z[finite])), float(np.max(Z[finite]))
        if limits is not None:
            lo, hi = (float(x) for x in limits)
        elif robust:
            lo, hi = np.percentile(Z[finite], [2.0, 98.0])
        else:
            lo, hi = zmin, zmax
        span = nice_levels(lo, hi, levels)
        if limits is not None:  # exactly the requested scale, not padded to round values
            tol = 1e-12 * (hi - lo)
            span = span[(span >= lo - tol) & (span <= hi + tol)]
            if span.size < 2:
                span = np.linspace(lo, hi, levels)
        Zf = np.where(finite, Z, np.nan)
        step = float(np.min(np.diff(span))) if span.size > 1 else 1.0
        # a plateau on a level (a slip that is zero on the whole stick region, up to
        # round-off) would flicker between two bands: snap it, and centre a band on it
        near = np.abs(Zf[..., None] - span) <= 1e-9 * max(abs(zmin), abs(zmax), 1e-300)
        if near.any(axis=-1).sum() > 0.01 * finite.sum():
            Zf = np.where(near.any(axis=-1), span[np.argmax(near, axis=-1)], Zf)
            span = np.concatenate([span - 0.5 * step, [span[-1] + 0.5 * step]])
        lo, hi = float(span[0]), float(span[-1])
        ext = extend or _extend(zmin, zmax, lo, hi)
        cs = ax.contourf(MU, E, Zf, levels=span, cmap="viridis", extend=ext)
        ax.convimpact_mappable = cs
        ax.convimpact_range = (zmin, zmax)
        if colorbar:
            landscape_colorbar(cs, ax, label, clip_note(zmin, zmax, lo, hi))
    handles = []
    bad = L.jammed | L.failed
    if bad.any():
        ax.contourf(MU, E, bad.astype(float), levels=[0.5, 1.5], colors=["0.6"])
        handles.append(Patch(color="0.6", label="jam / solver failure"))
    for mask, hatch, text in ((L.energy_gained, "//", "energy gained"),
                              (L.slip_reversal, "\\\\", "slip reversal")):
        if mask.any():
            ax.contourf(MU, E, mask.astype(float), levels=[0.5, 1.5], colors="none",
                        hatches=[hatch])
            ax.contour(MU, E, mask.astype(float), levels=[0.5], colors="k", linewidths=0.6)
            handles.append(Patch(facecolor="none", edgecolor="k", hatch=hatch, label=text))
    sb = landscape_stick_boundary(L)
    stick_style = dict(color="crimson", ls="-", lw=2.0)
    if sb is not None:
        mu_edge = float(np.max(np.abs(L.mu)))
        e_c, m_c = sb.curve(mu_edge)
        e_c, m_c = e_c[(e_c >= L.e.min()) & (e_c <= L.e.max())], m_c[(e_c >= L.e.min())
                                                                       & (e_c <= L.e.max())]
        drawn = False
        for sign in (1.0, -1.0):
            x = sign * m_c
            ok = (x >= L.mu.min()) & (x <= L.mu.max())
            if ok.sum() >= 2:
                ax.plot(np.where(ok, x, np.nan), e_c, **stick_style)
                drawn = True
        rule = {"stronge": r"$\mu \geq \max(|W_{tn}|/W_{tt}, -s\,\pi_t/\pi_n)$",
                "chatterjee-ruina": r"$\mu \geq |\hat J_t|/\hat J_n$, "
                                    r"$\hat J = (1+e) J_I + (1+e_t)(J_{II} - J_I)$",
                }.get(L.law, r"$|\mu| \geq |\pi_t|/\pi_n$ of eq. (42)")
        if drawn:
            handles.append(plt.Line2D([], [], **stick_style,
                                      label=f"stick boundary: sticks where {rule}"))
        else:
            handles.append(Patch(facecolor="none", edgecolor="none",
                                 label=rf"never sticks for $|\mu| \leq$ {mu_edge:g} ({rule})"))
    elif L.stick_possible.any() and not L.stick_possible.all():
        ax.contour(MU, E, L.stick_possible.astype(float), levels=[0.5], colors="crimson",
                   linewidths=2.0)
        handles.append(plt.Line2D([], [], **stick_style, label="stick boundary (grid)"))
    mask = L.friction_pushes_slip
    if mask.any() and not mask.all():
        ax.contour(MU, E, mask.astype(float), levels=[0.5], colors="darkorange",
                   linestyles=":", linewidths=2.0)
        handles.append(plt.Line2D([], [], color="darkorange", ls=":", lw=2.0,
                                  label="friction pushes slip"))
    if zero_contour and finite.any() and np.nanmin(Z) < 0.0 < np.nanmax(Z):
        Z0 = np.where(finite, Z, np.nan)
        if quantity in ("tangential_velocity", "v_plus") or values is not None:
            Z0 = np.where(L.regime == 2, np.nan, Z0)  # identically zero where stuck
        zc = ax.contour(MU, E, Z0, levels=[0.0], colors="deepskyblue", linewidths=1.8)
        # label it only where it is a curve (a few cells of round-off are not)
        scale = np.array([np.ptp(L.mu) or 1.0, np.ptp(L.e) or 1.0])
        length = sum(float(np.sum(np.hypot(*(np.diff(seg, axis=0) / scale).T)))
                     for seg in zc.allsegs[0] if len(seg) > 1)
        if length > 0.05:
            handles.append(plt.Line2D([], [], color="deepskyblue", lw=1.8,
                                      label=f"{label.split(' [')[0]} = 0"))
        else:
            zc.remove()
    if stiction is not None:
        lo, hi = stiction
        if np.isfinite(lo) and np.isfinite(hi):
            for y in {float(lo), float(hi)}:
                ax.axhline(y, color="crimson", ls="--", lw=1.2)
            text = f"eq. (62) (stiction necessary): {lo:.3g} <= e <= {hi:.3g}"
            handles.append(plt.Line2D([], [], color="crimson", ls="--", lw=1.2, label=text))
        else:
            handles.append(plt.Line2D([], [], color="crimson", ls="--", lw=1.2,
                                      label="eq. (62): no e in [0, 1] allows stiction"))
    ax.set_xlim(float(L.mu.min()), float(L.mu.max()))
    ax.set_ylim(float(L.e.min()), float(L.e.max()))
    ax.set_xlabel(r"friction coefficient $\mu$")
    ax.set_ylabel("coefficient of restitution $e$")
    ax.set_title(title or f"{L.law} / {L.method}: {quantity.replace('_', ' ')}")
    if handles and legend == "inside":
        ax.legend(handles=handles, loc="upper left", fontsize=8, framealpha=0.85)
    elif handles and legend == "below":
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13),
                  ncol=2, fontsize=8, frameon=False)
    return ax


def plot_angle_sweep(alpha: np.ndarray, energy_loss: np.ndarray, normal_impulse: np.ndarray,
                     alpha_m: float | None = None, gain_sector: Sequence[float] | None = None,
                     ax=None, title: str | None = None,
                     gain_sectors: Sequence[Sequence[float]] | None = None,
                     alpha_max_normal_impulse: float | None = None):
    """The paper's Fig. 9: T_L and pi_n versus the angle alpha of the tangential impulse.

    ``alpha`` in radians, measured counter-clockwise from v_t-; shown in degrees. Non-finite
    values (excluded directions) are left blank. ``gain_sector`` is one sector (alpha_0,
    alpha_1); ``gain_sectors`` several, each counter-clockwise from alpha_0 to alpha_1 (a sector
    through 0 is drawn in two pieces). ``alpha_max_normal_impulse`` marks where pi_n peaks.
    """
    ax = _axes(ax)
    deg = np.degrees(alpha)
    energy_loss = np.where(np.isfinite(energy_loss), energy_loss, np.nan)
    normal_impulse = np.where(np.isfinite(normal_impulse), normal_impulse, np.nan)
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
    first = True
    for sector in gain_sectors or ():
        a0, a1 = np.degrees(np.asarray(sector, float)) % 360.0
        pieces = [(a0, a1)] if a0 <= a1 else [(a0, 360.0), (0.0, a1)]
        for lo, hi in pieces:
            ax.axvspan(lo, hi, color="C3", alpha=0.15,
                       label=(rf"energy gain: $\alpha_0$ = {a0:.1f}$^\circ$ to "
                              rf"$\alpha_1$ = {a1:.1f}$^\circ$") if first else None)
            first = False
    if alpha_m is not None:
        ax.axvline(np.degrees(alpha_m), color="k", ls=":",
                   label=rf"$\alpha_m$ = {np.degrees(alpha_m):.2f}$^\circ$ (max. dissipation)")
    if alpha_max_normal_impulse is not None:
        ax.axvline(np.degrees(alpha_max_normal_impulse), color="C1", ls="-.", lw=0.8,
                   label=rf"max $\pi_n$ at {np.degrees(alpha_max_normal_impulse):.2f}$^\circ$")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    # below the axes: inside, any corner covers a curve somewhere on [0, 360] degrees
    ax.legend(h1 + h2, l1 + l2, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2,
              fontsize=8, frameon=False)
    ax.set_xlim(float(np.min(deg)), float(np.max(deg)))
    ax.set_title(title or "energy loss and normal impulse versus impulse direction")
    return ax


def plot_tangent_vectors(vectors: dict[str, np.ndarray], ax=None, title: str | None = None,
                         legend: bool = False, unit: str | None = None,
                         dashed: Sequence[str] = (), colors: dict | None = None):
    """The paper's Fig. 10: vectors in the tangent plane (t1 right, t2 up), from the origin.

    Each vector is labelled at its tip, or (``legend=True``) in a legend with its components,
    which stays readable when vectors are nearly collinear. ``unit`` names the unit of every
    vector of the axes (``"m/s"``, ``"N s"``) on the axis labels: draw quantities of different
    units on different axes. Vectors named in ``dashed`` are drawn dashed; ``colors`` maps a
    name to its colour.
    """
    ax = _axes(ax)
    lim = 0.0
    handles = []
    import matplotlib.pyplot as plt

    for i, (name, vec) in enumerate(vectors.items()):
        vec = np.asarray(vec, float)[-2:]
        col = (colors or {}).get(name, f"C{i}")
        ls = "--" if name in dashed else "-"
        ax.annotate("", xy=vec, xytext=(0, 0),
                    arrowprops=dict(arrowstyle="-|>", color=col, lw=2, ls=ls))
        if legend:
            handles.append(plt.Line2D([], [], color=col, lw=2, ls=ls,
                                      label=f"{name} = ({vec[0]:.3f}, {vec[1]:.3f})"))
        else:
            ax.text(*(1.05 * vec), name, color=col, fontsize=10)
        lim = max(lim, float(np.abs(vec).max()))
    lim = 1.15 * lim or 1.0
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    ax.axhline(0, color="0.7", lw=0.5)
    ax.axvline(0, color="0.7", lw=0.5)
    suffix = f" [{unit}]" if unit else ""
    ax.set_xlabel(f"component along $t_1${suffix}")
    ax.set_ylabel(f"component along $t_2${suffix}")
    if handles:
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=1,
                  fontsize=8, frameon=False)
    ax.set_title(title or "tangent plane")
    return ax


def plot_energy_fraction(e: np.ndarray, curves: dict, ax=None, title: str | None = None):
    """The paper's Fig. 3: energy loss fraction T_L / T- versus e, with closed forms overlaid.

    ``curves`` maps a label to a dict with ``law`` (the computed fractions, drawn as markers)
    and optional ``eq59`` (drawn as a line) and ``two_mass`` (drawn dashed) arrays over ``e``.
    """
    ax = _axes(ax)
    e = np.asarray(e, float)
    step = max(1, e.size // 20)
    for i, (label, c) in enumerate(curves.items()):
        col = f"C{i}"
        ax.plot(e[::step], np.asarray(c["law"])[::step], "o", color=col, ms=4,
                label=f"{label}: resolve_impact")
        if c.get("eq59") is not None:
            ax.plot(e, c["eq59"], "-", color=col, lw=1.2, label=f"{label}: eq. (59)")
        if c.get("two_mass") is not None:
            ax.plot(e, c["two_mass"], "--", color="k", lw=0.8,
                    label="two-particle closed form" if i == 0 else None)
    ax.set_xlabel("coefficient of restitution $e$")
    ax.set_ylabel(r"energy loss fraction $T_L / T^{(-)}$")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.05)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    ax.set_title(title or "energy loss versus the coefficient of restitution")
    return ax


#: properties of :meth:`convimpact.impact.results.ImpactDiagnostics.held`, in display order
PROPERTIES = ("restitution", "friction_cone", "friction_opposes_post_slip", "energy_not_gained",
              "loop_closed", "momentum_balance")


def plot_law_properties(table: dict, ax=None, title: str | None = None):
    """Which physical properties each law kept on each example, as a coloured matrix.

    ``table[example][law]`` is a dict with ``held`` (property -> bool, see
    :meth:`~convimpact.impact.results.ImpactDiagnostics.held`), ``energy_loss_fraction`` and
    ``regime``; or ``{"error": message}`` when the law failed. A cell is green when every
    property held, red with the broken properties listed otherwise.
    """
    ax = _axes(ax)
    examples = list(table)
    laws = list(dict.fromkeys(law for ex in examples for law in table[ex]))
    short = {"restitution": "restitution", "friction_cone": "cone",
             "friction_opposes_post_slip": "opposes post-slip",
             "energy_not_gained": "ENERGY GAINED", "loop_closed": "loop",
             "momentum_balance": "momentum"}
    img = np.zeros((len(examples), len(laws)))
    for i, ex in enumerate(examples):
        for j, law in enumerate(laws):
            cell = table[ex].get(law, {"error": "not run"})
            if "error" in cell:
                img[i, j] = 2
                text = "failed:\n" + cell["error"][:40]
            else:
                broken = [short[p] for p in PROPERTIES if not cell["held"].get(p, True)]
                img[i, j] = 1 if broken else 0
                text = (f"{cell['regime']}, $T_L/T^-$ = {cell['energy_loss_fraction']:.3f}\n"
                        + ("broken: " + ",\n".join(broken) if broken else "all kept"))
            ax.text(j, i, text, ha="center", va="center", fontsize=8)
    from matplotlib.colors import ListedColormap

    ax.imshow(img, cmap=ListedColormap(["#c7e9c0", "#fcbba1", "#d9d9d9"]), vmin=0, vmax=2,
              aspect="auto")
    ax.set_xticks(range(len(laws)), laws)
    ax.set_yticks(range(len(examples)), examples)
    ax.set_xticks(np.arange(len(laws) + 1) - 0.5, minor=True)
    ax.set_yticks(np.arange(len(examples) + 1) - 0.5, minor=True)
    ax.grid(which="minor", color="w", lw=2)
    ax.tick_params(which="minor", length=0)
    ax.set_title(title or "properties each law kept (green: all; red: some broken)")
    return ax


def plot_velocity_comparison(v_plus: dict, reference: np.ndarray | None = None,
                             reference_label: str = "paper", ax=None,
                             title: str | None = None, labels: Sequence[str] | None = None):
    """Grouped bars of post-impact contact velocities (n, t1, t2 ...) per law.

    ``v_plus`` maps a law to its (d,) contact velocity; ``reference`` is drawn as a black line
    across each group, its value written under the group's axis label. Each bar's value is
    written inside the bar (or just past its end when the bar is short), never on a reference
    line.
    """
    ax = _axes(ax)
    names = list(v_plus)
    d = len(next(iter(v_plus.values())))
    labels = list(labels or (["$n$", "$t$"] if d == 2 else ["$n$", "$t_1$", "$t_2$"]))
    width = 0.8 / max(len(names), 1)
    x = np.arange(d)
    allv = np.concatenate([np.asarray(v, float) for v in v_plus.values()]
                          + ([np.asarray(reference, float)] if reference is not None else []))
    span = max(float(np.max(allv)) - min(float(np.min(allv)), 0.0), 1e-12)
    for i, name in enumerate(names):
        vals = np.asarray(v_plus[name], float)
        pos = x - 0.4 + width * (i + 0.5)
        ax.bar(pos, vals, width, color=f"C{i}", label=name)
        for px, val in zip(pos, vals):
            if abs(val) > 0.22 * span:  # inside, along the bar
                ax.text(px, 0.5 * val, f"{val:.3f}", ha="center", va="center", rotation=90,
                        fontsize=7, color="w")
            else:
                ax.text(px, val, f"{val:.3f}", ha="center", va="bottom" if val >= 0 else "top",
                        fontsize=6)
    if reference is not None:
        ref = np.asarray(reference, float)
        ax.hlines(ref, x - 0.45, x + 0.45, colors="k", lw=2, label=reference_label)
        labels = [f"{lab}\n{reference_label.split(':')[0]}: {r:g}" for lab, r in zip(labels, ref)]
    ax.axhline(0, color="0.5", lw=0.5)
    ax.set_xticks(x, labels)
    ax.set_ylabel("post-impact relative velocity $v_r^+$ [m/s]")
    ax.legend(fontsize=7)
    ax.set_title(title or "post-impact contact velocity under each law")
    return ax
