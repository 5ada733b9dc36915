"""The seed's own sliding procedure (Section 9.3): a 1-D search over the tangent angle alpha.

In space the Pereira-Nikravesh law slides along the tangent ``t`` that maximizes the energy
loss T_L (eq. 60), with the normal impulse of eq. (38)/(51). Here ``t`` rotates by ``alpha``
counter-clockwise from the direction of the pre-impact slip ``v_t-`` in the (t1, t2) plane
(from the t1 axis when ``v_t- = 0``), exactly as in the paper's Fig. 9, and

    pi_n(alpha) = -(1 + e) v_n / D(alpha),   D(alpha) = W_n . (1, mu t(alpha))   (eq. 38/51)
    T_L(alpha) = -pi . v - 1/2 pi . W . pi,  pi = pi_n(alpha) (n + mu t(alpha))     (eq. 60)

in contact space (``W`` includes the loops, Section 6). Directions with ``D <= 0`` are excluded
(no finite compressive normal impulse slides there).

:func:`energy_loss_versus_angle` evaluates the curve on an array of angles (vectorized, for
Fig. 9); :func:`sweep_direction` finds its maximum: a coarse grid brackets every local
maximum, which is then refined by Brent's bounded method to ``xtol`` in alpha. Note that
``T_L`` is flat at its maximum, so the achievable accuracy in alpha is about
``sqrt(eps |T_L| / |T_L''|)`` (~1e-8) however small ``xtol`` is; T_L itself is accurate to
round-off. The exact answer is :func:`convimpact.impact.laws.max_dissipation.max_dissipation_direction`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from ..laws.pereira_nikravesh import frictionless_impulse, stick_admissible, sticking_impulse
from ..diagnostics import assemble_result
from ...errors import (contact_inputs, NonPositiveEffectiveMassError, ParameterError,
                       ShapeError, SingularSystemError)
from ..options import check_single_contact
from ..laws.max_dissipation import max_dissipation_direction  # the exact answer, re-exported
from ..problem.build import ImpactProblem
from ..results import ImpactResult

#: default refinement tolerance in alpha (radians)
DEFAULT_XTOL = 1e-10
#: default number of grid angles over [0, 2 pi) used to bracket maxima and sectors
DEFAULT_GRID = 360

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class EnergyLossCurve:
    """T_L and pi_n along tangent angles alpha (the paper's Fig. 9).

    Attributes
    ----------
    alpha : angles in radians, counter-clockwise from v_t- (from t1 if v_t- = 0).
    energy_loss : T_L(alpha) (eq. 60); ``-inf`` where the direction is excluded (D <= 0).
    normal_impulse : pi_n(alpha) (eq. 38/51); ``+inf`` where excluded.
    denominator : D(alpha) = W_n . (1, mu t(alpha)), the denominator of eq. (38)/(51).
    admissible : D(alpha) > 0.
    """

    alpha: np.ndarray
    energy_loss: np.ndarray
    normal_impulse: np.ndarray
    denominator: np.ndarray
    admissible: np.ndarray


@dataclass(frozen=True)
class SweepResult:
    """Maximum of T_L over the tangent angle (Section 9.3).

    Attributes
    ----------
    alpha_m : angle of maximal energy loss, radians in [0, 2 pi), counter-clockwise from v_t-.
    energy_loss_max : T_L(alpha_m).
    normal_impulse : pi_n(alpha_m) (eq. 38/51).
    direction : unit tangent t(alpha_m) in the frame's (t1, t2) axes.
    energy_gain_sectors : sectors (alpha_0, alpha_1), counter-clockwise from alpha_0 to
        alpha_1, of admissible directions with T_L < 0 (the paper's alpha_0, alpha_1).
    excluded_sector : (start, end) of the directions with D <= 0 (closed form), or None.
    max_normal_impulse : sup of pi_n over admissible directions (inf if a sector is excluded).
    alpha_max_normal_impulse : the angle where it is reached (None if unbounded).
    n_evaluations : number of T_L evaluations (grid + refinements).
    xtol : requested tolerance in alpha.
    """

    alpha_m: float
    energy_loss_max: float
    normal_impulse: float
    direction: np.ndarray
    energy_gain_sectors: tuple[tuple[float, float], ...]
    excluded_sector: tuple[float, float] | None
    max_normal_impulse: float
    alpha_max_normal_impulse: float | None
    n_evaluations: int
    xtol: float


def _spatial_data(W, v, e, mu) -> tuple:
    """(W, v, e, mu) converted, of a spatial contact, and the unit reference tangent."""
    W, v, e, mu = contact_inputs(W, v, e, mu)
    if W.shape != (3, 3) or v.shape != (3,):
        raise ShapeError(
            f"the angle sweep needs a spatial contact: W of shape (3, 3) and v of length 3 "
            f"(n, t1, t2); got W {W.shape} and v {v.shape} (a planar contact has only the two "
            "tangents alpha = 0 and pi: use the sweep solver, which compares them)")
    vt = v[1:]
    nv = float(np.hypot(vt[0], vt[1]))
    ref = vt / nv if nv > 0.0 else np.array([1.0, 0.0])
    return W, v, e, mu, ref


def _tangent(ref: np.ndarray, alpha) -> tuple[np.ndarray, np.ndarray]:
    ca, sa = np.cos(alpha), np.sin(alpha)
    return ca * ref[0] - sa * ref[1], ca * ref[1] + sa * ref[0]


def energy_loss_versus_angle(W, v, e: float, mu: float, alpha) -> EnergyLossCurve:
    """T_L(alpha) and pi_n(alpha) of a spatial sliding contact (eq. 60, Fig. 9), vectorized.

    Parameters
    ----------
    W : (3, 3) Delassus block of the contact (loops included).
    v : (3,) pre-impact contact velocity (v_n, v_t1, v_t2), v_n < 0.
    e, mu : restitution and friction.
    alpha : array_like of angles (radians), counter-clockwise from v_t- in the (t1, t2) plane.

    Returns
    -------
    EnergyLossCurve
    """
    W, v, e, mu, ref = _spatial_data(W, v, e, mu)
    alpha = np.asarray(alpha, dtype=float)
    t1, t2 = _tangent(ref, alpha)
    D = W[0, 0] + mu * (W[0, 1] * t1 + W[0, 2] * t2)  # eq. (38) denominator
    pWp = (W[0, 0] + 2.0 * mu * (W[0, 1] * t1 + W[0, 2] * t2)
           + mu * mu * (W[1, 1] * t1 * t1 + 2.0 * W[1, 2] * t1 * t2 + W[2, 2] * t2 * t2))
    ok = D > 1e-12 * float(np.max(np.abs(W)))
    Dsafe = np.where(ok, D, 1.0)
    pn = -(1.0 + e) * v[0] / Dsafe
    tl = -pn * (v[0] + mu * (v[1] * t1 + v[2] * t2)) - 0.5 * pn * pn * pWp  # eq. (60)
    return EnergyLossCurve(alpha=alpha, energy_loss=np.where(ok, tl, -np.inf),
                           normal_impulse=np.where(ok, pn, np.inf), denominator=D,
                           admissible=ok)


def _coupling(W: np.ndarray) -> tuple[np.ndarray, float]:
    """w = W[0, 1:] (the normal-tangent coupling) and |w|."""
    w = W[0, 1:]
    return w, float(np.hypot(w[0], w[1]))


def _angle_against(w: np.ndarray, ref: np.ndarray) -> float:
    """The angle of -w, counter-clockwise from ``ref``."""
    return math.atan2(-(ref[0] * w[1] - ref[1] * w[0]), -(ref[0] * w[0] + ref[1] * w[1]))


def _excluded_sector(W: np.ndarray, mu: float, ref: np.ndarray) -> tuple[float, float] | None:
    """Angles with D(alpha) <= 0, in closed form: w.t <= -W_nn / mu, w = W[0, 1:]."""
    w, nw = _coupling(W)
    if mu == 0.0 or mu * nw <= W[0, 0]:
        return None
    centre = _angle_against(w, ref)
    half = math.acos(W[0, 0] / (mu * nw))
    return ((centre - half) % _TWO_PI, (centre + half) % _TWO_PI)


def sweep_options(xtol, n_grid) -> tuple[float, int]:
    """The sweep's options checked (every planar and spatial impact, before any work): xtol a
    positive finite angle tolerance, n_grid an integer >= 8 (ParameterError or
    NonFiniteError naming the option)."""
    from ...validation import integer, positive

    return positive("xtol", xtol), integer("n_grid", n_grid, minimum=8)


def sweep_direction(W, v, e: float, mu: float, xtol: float = DEFAULT_XTOL,
                    n_grid: int = DEFAULT_GRID) -> SweepResult:
    """The seed's search for the sliding direction: maximize T_L(alpha) (eq. 60, Fig. 9).

    A grid of ``n_grid`` angles brackets every local maximum of T_L over the admissible
    directions (D > 0); each is refined by Brent's bounded method to ``xtol`` in alpha and the
    best is returned. The energy-gain sectors (T_L < 0) are located on the same grid and their
    ends refined by Brent's root finder to ``xtol``; sectors narrower than the grid spacing
    can be missed.

    Parameters
    ----------
    W : (3, 3) Delassus block; v : (3,) pre-impact velocity with v_n < 0.
    e, mu : restitution and friction (mu > 0).
    xtol : tolerance in alpha (radians).
    n_grid : number of bracketing grid angles (>= 8).

    Returns
    -------
    SweepResult
    """
    W, v, e, mu, ref = _spatial_data(W, v, e, mu)
    xtol, n_grid = sweep_options(xtol, n_grid)
    if not v[0] < 0.0:
        raise ParameterError(f"the sweep needs an approaching contact (v_n < 0), got {v[0]:g}")
    if not W[0, 0] > 0.0:
        raise SingularSystemError(
            f"W_nn = {W[0, 0]:.3e}: the contact normal moves no mass; no impulse can act")
    n_eval = 0

    def tl(a: float) -> float:
        nonlocal n_eval
        n_eval += 1
        return float(energy_loss_versus_angle(W, v, e, mu, a).energy_loss)

    h = _TWO_PI / n_grid
    grid = np.arange(n_grid) * h
    curve = energy_loss_versus_angle(W, v, e, mu, grid)
    n_eval += n_grid
    T = curve.energy_loss
    excl = _excluded_sector(W, mu, ref)

    # every grid local maximum (cyclic) is refined; the best refined one wins
    prev, nxt = np.roll(T, 1), np.roll(T, -1)
    peaks = np.flatnonzero(np.isfinite(T) & (T >= prev) & (T >= nxt))
    if peaks.size == 0:
        peaks = np.array([int(np.argmax(T))])
    # T_L has at most two local maxima on the circle (its stationarity is a quartic in
    # tan(alpha/2)); on a plateau (T_L constant) every grid point is one: keep the best four
    peaks = peaks[np.argsort(-T[peaks], kind="stable")[:4]]
    best = None
    for k in peaks:
        lo, hi = grid[k] - h, grid[k] + h
        if not np.isfinite(prev[k]):
            lo = _trim(excl, grid[k], -h)
        if not np.isfinite(nxt[k]):
            hi = _trim(excl, grid[k], h)
        res = minimize_scalar(lambda a: -tl(a), bounds=(lo, hi), method="bounded",
                              options={"xatol": xtol, "maxiter": 500})
        a, val = float(res.x), -float(res.fun)
        if val < T[k]:
            a, val = float(grid[k]), float(T[k])
        if best is None or val > best[1]:
            best = (a % _TWO_PI, val)
    alpha_m, tl_max = best
    at = energy_loss_versus_angle(W, v, e, mu, alpha_m)
    t1, t2 = _tangent(ref, alpha_m)

    sectors = _gain_sectors(curve, excl, tl, xtol)
    if excl is None:
        w, nw = _coupling(W)
        a_max = _angle_against(w, ref) % _TWO_PI if mu * nw > 0.0 else 0.0
        pn_max = float(-(1.0 + e) * v[0] / (W[0, 0] - mu * nw))
    else:
        a_max, pn_max = None, math.inf
    return SweepResult(
        alpha_m=alpha_m, energy_loss_max=tl_max, normal_impulse=float(at.normal_impulse),
        direction=np.array([float(t1), float(t2)]), energy_gain_sectors=sectors,
        excluded_sector=excl, max_normal_impulse=pn_max, alpha_max_normal_impulse=a_max,
        n_evaluations=n_eval, xtol=float(xtol))


def _trim(excl, a: float, step: float) -> float:
    """Bracket end at grid angle a + step, pulled back to the excluded sector's edge."""
    if excl is None:
        return a + step
    edge = excl[0] if step > 0 else excl[1]
    d = (edge - a) % _TWO_PI if step > 0 else -((a - edge) % _TWO_PI)
    if abs(d) > abs(step):
        return a + step
    return a + d * (1.0 - 1e-9)


def _gain_sectors(curve: EnergyLossCurve, excl, tl, xtol: float) -> tuple:
    """Sectors where T_L < 0 or D <= 0, ends refined to xtol by Brent's root finder.

    T_L tends to -inf at both edges of an excluded sector (D -> 0+), so energy-gain
    directions always border it: a sector that meets the excluded directions contains them.
    """
    T, a = curve.energy_loss, curve.alpha
    n = a.size
    h = _TWO_PI / n
    gain = (~curve.admissible) | (T < 0.0)
    if np.all(gain):
        return ((0.0, _TWO_PI),)
    if not np.any(gain):
        return ()
    start = int(np.flatnonzero(~gain)[0])  # begin the walk at an energy-loss grid angle
    out = []
    i = 0
    while i < n:
        k = (start + i) % n
        if not gain[k]:
            i += 1
            continue
        j = i
        while j + 1 < n and gain[(start + j + 1) % n]:
            j += 1
        k_in, k_end = k, (start + j) % n
        a0 = _root(tl, a[k_in] - h, a[k_in], curve.admissible[k_in], excl, xtol, rising=False)
        a1 = _root(tl, a[k_end], a[k_end] + h, curve.admissible[k_end], excl, xtol, rising=True)
        out.append((a0 % _TWO_PI, a1 % _TWO_PI))
        i = j + 1
    return tuple(out)


def _root(tl, lo: float, hi: float, gain_end_admissible: bool, excl, xtol: float,
          rising: bool) -> float:
    """T_L = 0 between a loss angle and a gain (or excluded) angle; ``rising``: loss at hi."""
    if not gain_end_admissible and excl is not None:
        # move the excluded end onto the sector's edge, just inside the admissible side
        if rising:
            edge = excl[1]
            lo = lo + ((edge - lo) % _TWO_PI) + 1e-9 * (hi - lo)
        else:
            edge = excl[0]
            hi = hi - ((hi - edge) % _TWO_PI) - 1e-9 * (hi - lo)
    return brentq(tl, lo, hi, xtol=xtol)


# --------------------------------------------------------------------------------------------
# the sweep solver of the Pereira-Nikravesh law


def pereira_nikravesh_sweep(problem: ImpactProblem, xtol: float = DEFAULT_XTOL,
                             n_grid: int = DEFAULT_GRID, **options) -> ImpactResult:
    """Section 8 algorithm with the seed's search for the spatial sliding direction.

    Stick test first (eq. 42/52, closed form); otherwise slide on the cone boundary with
    pi_n from eq. (38)/(51): in space along the tangent maximizing T_L found by
    :func:`sweep_direction` (options ``xtol``, ``n_grid``); in the plane along eq. (55),
    t = -v_t-/|v_t-|, as the law prescribes. The plane's two tangents are both evaluated and
    ``extras['eq55_is_max_dissipation']`` says whether eq. (55)'s claim of maximal dissipation
    holds for this impact (it fails in a minority of slides; the opposite tangent's T_L is in
    ``extras['energy_loss_opposite']``).
    """
    check_single_contact(problem, options, "sweep", "options xtol, n_grid;",
                         "the angle sweep treats one contact; for several simultaneous "
                         "contacts use method='clarabel' or 'cvxpy'")
    xtol, n_grid = sweep_options(xtol, n_grid)
    W, v = problem.contact_block(0)
    e, mu = float(problem.restitution[0]), float(problem.friction[0])
    law = "pereira-nikravesh"
    if mu == 0.0:
        return assemble_result(problem, frictionless_impulse(W, v, e)[None], ["frictionless"],
                               law, "sweep", tol=1e-12)
    stick = sticking_impulse(W, v, e)
    if stick_admissible(stick, mu):
        return assemble_result(problem, stick[None], ["stick"], law, "sweep", tol=1e-12)
    c = -(1.0 + e) * float(v[0])
    if problem.planar:
        vt = float(v[1])
        eq55 = -math.copysign(1.0, vt) if vt != 0.0 else float(np.sign(stick[1]) or 1.0)
        scale = float(np.max(np.abs(W)))

        def slide(s: float):
            D = float(W[0, 0] + mu * s * W[0, 1])
            if not D > 1e-12 * scale:
                return None
            p = c / D
            g = np.array([1.0, mu * s])
            return -p * float(g @ v) - 0.5 * p * p * float(g @ W @ g), p, D

        chosen, other = slide(eq55), slide(-eq55)
        if chosen is None:
            raise NonPositiveEffectiveMassError(
                f"sliding denominator c_n^T M^-1 (c_n + mu c_t) <= 0 at mu = {mu:g} along "
                "eq. (55)'s tangent (Painleve-like jam); use law='coulomb', 'ccp' or "
                "'dissipative'")
        val, p, D = chosen
        extras = {"alpha_m": math.pi, "energy_loss_max": val, "normal_impulse": p,
                  "n_evaluations": 2,
                  "energy_loss_opposite": None if other is None else other[0],
                  "eq55_is_max_dissipation": other is None or val >= other[0]}
        return assemble_result(problem, (p * np.array([1.0, mu * eq55]))[None], ["slide"], law,
                               "sweep", effective_mass=D, tol=1e-12, extras=extras)
    sw = sweep_direction(W, v, e, mu, xtol=xtol, n_grid=n_grid)
    p = sw.normal_impulse
    D = c / p
    impulse = p * np.array([1.0, mu * sw.direction[0], mu * sw.direction[1]])
    # the paper's alpha_0, alpha_1 (Fig. 9) when there is a single gain sector
    one = sw.energy_gain_sectors[0] if len(sw.energy_gain_sectors) == 1 else (None, None)
    extras = {"alpha_m": sw.alpha_m, "energy_loss_max": sw.energy_loss_max,
              "normal_impulse": p, "direction": tuple(sw.direction.tolist()),
              "energy_gain_sectors": sw.energy_gain_sectors,
              "alpha_0": one[0], "alpha_1": one[1], "excluded_sector": sw.excluded_sector,
              "max_normal_impulse": sw.max_normal_impulse,
              "alpha_max_normal_impulse": sw.alpha_max_normal_impulse,
              "n_evaluations": sw.n_evaluations, "xtol": sw.xtol}
    # T_L is flat at alpha_m: the impulse is accurate to ~sqrt(eps), state that as the tolerance
    return assemble_result(problem, impulse[None], ["slide"], law, "sweep", effective_mass=D,
                           tol=1e-7, extras=extras)


__all__ = ["EnergyLossCurve", "SweepResult", "energy_loss_versus_angle", "sweep_direction",
           "max_dissipation_direction"]
