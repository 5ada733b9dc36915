"""The compass gait's period-doubling cascade: continuation in slope with the multipliers.

:func:`compass_gait_bifurcation` follows the period-one gait of the compass-gait walker
(scene ``compass_gait``, Goswami, Thuilot & Espiau 1998) in slope from 3 degrees, down and
up, by Newton shooting (:func:`convimpact.simulation.find_periodic_orbit`) with a secant
predictor in the gait's variables (stance angle, its rate, interleg angle, its rate just
after heel strike). The multipliers are tracked; where a real one crosses -1 (a flip,
period-doubling bifurcation) the period-two orbit is sought by shooting on the doubled map
(``strides=2``) from the period-one orbit displaced along the critical multiplier's
eigenvector, and continued in turn (its own crossing of -1 starts a period-four branch, and
so on up to ``max_period``). The period-one branch is continued past the bifurcation too
(unstable). :func:`plot_gait_bifurcation` charts the interleg angle at heel strike against
the slope (every point of each orbit) above the multipliers' moduli.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import ConvImpactError, ParameterError
from ..simulation.periodic import PeriodicOrbitError

__all__ = ["GaitBranch", "GaitBifurcation", "compass_gait_bifurcation",
           "plot_gait_bifurcation"]


@dataclass(frozen=True)
class GaitBranch:
    """One branch of gaits of one period, point by point.

    Attributes
    ----------
    period : strides per period (1, 2, 4, ...).
    slopes_deg : (n,) slope of each point, degrees.
    interleg : (n, period) the interleg angle at each heel strike of the orbit, rad.
    multipliers : (n, 3) the multipliers of the period map (P applied ``period`` times),
        complex, by decreasing modulus.
    stable : (n,) all |multipliers| < 1.
    periods_s : (n,) the orbit's duration (``period`` strides), s.
    """

    period: int
    slopes_deg: np.ndarray
    interleg: np.ndarray
    multipliers: np.ndarray
    stable: np.ndarray
    periods_s: np.ndarray


@dataclass(frozen=True)
class GaitBifurcation:
    """The branches and where the period doublings were found.

    Attributes
    ----------
    branches : the branches, period one first.
    doublings_deg : ((period, slope_low, slope_high), ...): a multiplier of the period-n
        branch crosses -1 between these two slopes (degrees).
    failures : ((period, slope_deg, message), ...): points where Newton failed (the branch
        stops there).
    parameters : the scene parameters (besides the slope) used.
    wall_time : seconds.
    """

    branches: tuple[GaitBranch, ...]
    doublings_deg: tuple[tuple[int, float, float], ...]
    failures: tuple[tuple[int, float, str], ...]
    parameters: dict
    wall_time: float


def _gait_of_state(z, slope):
    return np.array([z[2] + slope, z[6], z[3], z[7]])


def _ordered(orbit, slope):
    """The orbit's points as gait vectors, the one with the widest interleg angle first."""
    pts = [_gait_of_state(p, slope) for p in orbit.points]
    first = int(np.argmax([abs(p[2]) for p in pts]))
    return pts[first:] + pts[:first]


def _genuine(orbit, period):
    """The orbit's period is ``period``, not a divisor (its points half a period apart
    differ)."""
    return period == 1 or bool(
        np.max(np.abs(orbit.points[0] - orbit.points[period // 2])) > 1e-4)


def _continue(period, slopes, guess, make, find_gait, progress, failures, parent=None,
              switch=None):
    """Follow the period-``period`` branch over ``slopes``; a point that falls back onto the
    parent branch (period / 2, ``parent``: slope -> orbit) is sought again by a branch
    switch from the parent's orbit there."""
    out = []
    prev = None
    for s in slopes:
        t0 = time.perf_counter()
        try:
            orbit = find_gait(make(float(s)), guess, strides=period)
            if not _genuine(orbit, period) and parent is not None and float(s) in parent:
                orbit = switch(parent[float(s)], float(s), period // 2)
            if orbit is None or not _genuine(orbit, period):
                raise PeriodicOrbitError(
                    f"only the period-{period // 2} orbit found (no period-{period} orbit)")
        except ConvImpactError as exc:
            failures.append((period, float(np.degrees(s)), f"{type(exc).__name__}: {exc}"))
            if progress:
                print(f"  period {period}, slope {np.degrees(s):6.3f} deg: Newton failed "
                      f"({type(exc).__name__}); the branch stops", flush=True)
            break
        current = _ordered(orbit, float(s))[0]
        out.append((float(s), orbit))
        if progress:
            print(f"  period {period}, slope {np.degrees(s):6.3f} deg: max |multiplier| = "
                  f"{np.max(np.abs(orbit.multipliers)):.4f} ({time.perf_counter() - t0:.1f} s)",
                  flush=True)
        guess = current if prev is None else 2.0 * current - prev
        prev = current
    return out


def _flip(points):
    """Index i such that a real multiplier crosses -1 between points i and i + 1, or None."""
    def below(orbit):
        m = orbit.multipliers
        real = np.abs(m.imag) < 1e-9
        return bool(np.any(real & (m.real < -1.0)))
    for i in range(len(points) - 1):
        if not below(points[i][1]) and below(points[i + 1][1]):
            return i
    return None


def _switch(orbit, slope, period, make, find_periodic, progress):
    """The period-2n orbit next to a period-n orbit just past its flip."""
    from convimpact.simulation import project_to_section

    m = orbit.multipliers
    w, v = np.linalg.eig(orbit.jacobian)
    j = int(np.argmin(np.abs(w - (-1.0))))
    direction = np.real(orbit.basis @ v[:, j])
    direction /= np.linalg.norm(direction)
    scene = make(float(slope))
    for eps in (0.02, 0.05, 0.1, 0.01):
        for sign in (1.0, -1.0):
            try:
                start = project_to_section(scene, orbit.state + sign * eps * direction, orbit)
                cand = find_periodic(scene, start, strides=2 * period)
            except ConvImpactError:
                continue
            a, b = cand.points[0], cand.points[period]
            if np.max(np.abs(a - b)) > 1e-4:
                if progress:
                    print(f"  branch switch at {np.degrees(slope):.3f} deg: period {2 * period}"
                          f" (offset {eps:g}, |multiplier + 1| was {np.min(np.abs(m + 1)):.3f})",
                          flush=True)
                return cand
    return None


def compass_gait_bifurcation(min_deg: float = 1.0, max_deg: float = 5.4,
                             step_deg: float = 0.1, *, start_deg: float = 3.0,
                             max_period: int = 4, progress: bool = True,
                             **scene_parameters) -> GaitBifurcation:
    """Continue the compass gait's gaits in slope and switch branches at period doublings.

    Parameters
    ----------
    min_deg, max_deg, step_deg : the slopes charted (degrees): from ``start_deg`` down to
        ``min_deg`` and up to ``max_deg`` in steps of ``step_deg``.
    start_deg : where the period-one gait is first found (from the scene's reference gait).
    max_period : the longest period followed (1, 2, 4, 8...).
    progress : print a line per point (a run takes minutes).
    **scene_parameters : the compass_gait scene's other parameters (hip_mass, leg_mass...).

    Returns
    -------
    GaitBifurcation
    """
    from convimpact.problems import compass_gait as cg
    from convimpact.problems._walker import find_gait
    from convimpact.scenes import load_scene
    from convimpact.simulation import find_periodic_orbit
    from convimpact.validation import integer, positive, real

    min_deg, max_deg = real("min_deg", min_deg), real("max_deg", max_deg)
    step_deg, start_deg = positive("step_deg", step_deg), real("start_deg", start_deg)
    max_period = integer("max_period", max_period, minimum=1)
    if not 0.0 < min_deg <= start_deg <= max_deg:
        raise ParameterError(
            f"need 0 < min_deg <= start_deg <= max_deg, got {min_deg}, {start_deg}, {max_deg}")
    wall = time.perf_counter()

    def make(slope):
        return load_scene("compass_gait", slope=slope, **scene_parameters)

    def find_periodic(scene, state, strides):
        L = float(scene.parameters["leg_length"])
        k = scene.mechanism.n_coordinates
        return find_periodic_orbit(scene, (state[:k], state[k:]), strides=strides,
                                   reduce=lambda th, dth: cg.reduce(th, dth, L),
                                   t_max=4.0 * float(scene.t_end), max_iterations=12)

    failures: list = []
    up = np.radians(np.arange(start_deg, max_deg + 1e-9, step_deg))
    down = np.radians(np.arange(start_deg, min_deg - 1e-9, -step_deg))
    guess = np.array(cg.REFERENCE_GAIT) * (np.radians(start_deg) / cg.REFERENCE_SLOPE) ** (1 / 3)
    if progress:
        print(f"compass gait: period one from {start_deg} deg down to {min_deg} and up to "
              f"{max_deg} deg, step {step_deg} deg", flush=True)
    upper = _continue(1, up, guess, make, find_gait, progress, failures)
    lower = []
    if upper and len(down) > 1:
        first = _ordered(upper[0][1], float(up[0]))[0]
        lower = _continue(1, down[1:], first, make, find_gait, progress, failures)
    branches = [(1, lower[::-1] + upper)]
    doublings = []
    period, points = 1, upper
    while 2 * period <= max_period:
        i = _flip(points)
        if i is None:
            break
        lo, hi = points[i][0], points[i + 1][0]
        doublings.append((period, float(np.degrees(lo)), float(np.degrees(hi))))
        new = _switch(points[i + 1][1], hi, period, make, find_periodic, progress)
        if new is None:
            failures.append((2 * period, float(np.degrees(hi)), "no period-doubled orbit found"))
            break
        rest = [s for s, _ in points[i + 1:]]
        parent = {s: o for s, o in points}
        guess = _ordered(new, hi)[0]
        period *= 2

        def switch(orbit, slope, p):
            return _switch(orbit, slope, p, make, find_periodic, progress)

        points = _continue(period, np.array(rest), guess, make, find_gait, progress, failures,
                           parent=parent, switch=switch)
        branches.append((period, points))
    if progress:
        print(f"done in {time.perf_counter() - wall:.0f} s; period doublings (deg): "
              f"{[(p, round(a, 3), round(b, 3)) for p, a, b in doublings]}", flush=True)
    return GaitBifurcation(
        branches=tuple(_branch(p, pts) for p, pts in branches if pts),
        doublings_deg=tuple(doublings), failures=tuple(failures),
        parameters=dict(scene_parameters), wall_time=time.perf_counter() - wall)


def _branch(period, points) -> GaitBranch:
    slopes = np.array([s for s, _ in points])
    inter = np.array([[abs(p[3]) for p in o.points] for _, o in points])
    mults = np.array([np.pad(o.multipliers, (0, max(0, 3 - o.multipliers.size)))[:3]
                      for _, o in points])
    return GaitBranch(period=period, slopes_deg=np.degrees(slopes), interleg=inter,
                      multipliers=mults,
                      stable=np.array([o.stable for _, o in points]),
                      periods_s=np.array([o.period for _, o in points]))


def plot_gait_bifurcation(result: GaitBifurcation, path=None):
    """The bifurcation diagram (interleg angle at heel strike vs slope; filled: stable,
    hollow: unstable) above the multipliers' moduli; saved as ``path`` (PNG) if given.
    Returns the figure."""
    import matplotlib

    if path is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 7.0), sharex=True,
                                      gridspec_kw={"height_ratios": [3, 2]})
    colors = {1: "tab:blue", 2: "tab:orange", 4: "tab:green", 8: "tab:red"}
    for br in result.branches:
        c = colors.get(br.period, "k")
        for j in range(br.interleg.shape[1]):
            y = np.degrees(br.interleg[:, j])
            top.plot(br.slopes_deg[br.stable], y[br.stable], "o", ms=3.5, color=c,
                     label=f"period {br.period}" if j == 0 else None)
            top.plot(br.slopes_deg[~br.stable], y[~br.stable], "o", ms=3.5, mfc="none",
                     color=c, alpha=0.6,
                     label=f"period {br.period}, unstable" if j == 0 and (~br.stable).any()
                     else None)
        mod = np.abs(br.multipliers)
        for j in range(mod.shape[1]):
            bottom.plot(br.slopes_deg, mod[:, j], ".-", ms=3, lw=0.8, color=c,
                        alpha=1.0 if j == 0 else 0.45,
                        label=f"period {br.period}" if j == 0 else None)
    for p, lo, hi in result.doublings_deg:
        for ax in (top, bottom):
            ax.axvspan(lo, hi, color="0.85", zorder=0)
    bottom.axhline(1.0, color="k", lw=0.8, ls="--")
    bottom.set_yscale("log")
    top.set_ylabel("interleg angle at heel strike (deg)")
    top.set_title("Compass gait (m_H/m = 2, a = b = 0.5 m): period doubling with slope")
    top.legend(fontsize=8, loc="upper left")
    bottom.set_ylabel("|multipliers| of the period map")
    bottom.set_xlabel("slope (deg)")
    bottom.legend(fontsize=8, loc="upper left")
    bottom.set_ylim(1e-2, 30.0)
    fig.tight_layout()
    if path is not None:
        from pathlib import Path

        Path(path).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=110)
        plt.close(fig)  # written: off pyplot's list of open figures (the object stays usable)
    return fig
