"""Dissipation landscapes: one impact state, a law evaluated over grids of e and mu.

:func:`closed_form_landscape` is the paper's Figs. 5-7: the Section 8 algorithm for one planar
contact over e in [0, 1] and a *signed* mu, vectorized in numpy (no Python loop per point).
Following the paper, mu > 0 puts the friction impulse along t = -v_t-/|v_t-| (eq. 55) and
mu < 0 along the slip itself; sticking is admitted where the sticking impulse lies in the cone
|pi_t| <= |mu| pi_n. Points where the sliding denominator of eq. (38) is not positive (a
Painleve-like jam) carry NaN *and* are marked in ``jammed``; no NaN appears anywhere else.

:func:`law_landscape` evaluates any law/method of :func:`convimpact.resolve_impact` (mu >= 0)
point by point on one validated problem, reusing the solver's compiled program, with a
progress bar on long runs.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from .errors import ConvImpactError, ShapeError
from .problem import ImpactProblem, build_problem, check_restitution
from .results import _jsonable

REGIMES = ("separating", "frictionless", "stick", "slide", "failed")


@dataclass(frozen=True, eq=False)
class Landscape:
    """A law evaluated over a grid: arrays of shape (len(e), len(mu)).

    Attributes
    ----------
    e, mu : the grid axes.
    energy_loss : T_L (eq. 58); negative where energy is gained.
    energy_loss_fraction : T_L / T-.
    normal_impulse : pi_n.
    tangential_impulse : pi_t on the frame's tangent axes, shape (..., d - 1).
    v_plus : post-impact contact-frame velocity, shape (..., d).
    tangential_velocity : post-impact slip along the paper's t (planar) or its norm (spatial).
    regime : integer codes into :data:`REGIMES`.
    energy_gained, friction_pushes_slip, slip_reversal, jammed, failed : boolean masks.
    stick_possible : mask of (e, mu) where the sticking impulse is admissible.
    law, method : what was evaluated. ``meta`` records the impact state.
    """

    e: np.ndarray
    mu: np.ndarray
    energy_loss: np.ndarray
    energy_loss_fraction: np.ndarray
    normal_impulse: np.ndarray
    tangential_impulse: np.ndarray
    v_plus: np.ndarray
    tangential_velocity: np.ndarray
    regime: np.ndarray
    energy_gained: np.ndarray
    friction_pushes_slip: np.ndarray
    slip_reversal: np.ndarray
    jammed: np.ndarray
    failed: np.ndarray
    stick_possible: np.ndarray
    law: str
    method: str
    meta: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))

    def regime_names(self) -> np.ndarray:
        """The regime of every point as strings."""
        return np.asarray(REGIMES, dtype=object)[self.regime]

    def counts(self) -> dict[str, int]:
        """How many grid points fall in each regime and failure flag."""
        out = {name: int(np.sum(self.regime == i)) for i, name in enumerate(REGIMES)}
        for flag in ("energy_gained", "friction_pushes_slip", "slip_reversal", "jammed",
                     "failed"):
            out[flag] = int(np.sum(getattr(self, flag)))
        return out

    def as_dict(self) -> dict[str, Any]:
        """Plain-JSON view (NaN becomes None)."""
        out = {}
        for k in self.__dataclass_fields__:
            v = getattr(self, k)
            if isinstance(v, np.ndarray) and v.dtype.kind == "f":
                v = np.where(np.isfinite(v), v, None)
            out[k] = _jsonable(v)
        out["regime_names"] = list(REGIMES)
        out["counts"] = self.counts()
        return out


def _planar_problem(M, Jc, dq, C) -> ImpactProblem:
    P = build_problem(M, Jc, dq, 0.0, 0.0, C)
    if P.n_contacts != 1 or not P.planar:
        raise ShapeError("the closed-form landscape takes one planar contact (Jc of shape 2 x k)")
    return P


def closed_form_landscape(M, Jc, dq, e, mu, C=None) -> Landscape:
    """Section 8 over a grid of e and signed mu, vectorized (the paper's Figs. 5-7).

    Parameters
    ----------
    M, Jc, dq, C : as for :func:`convimpact.resolve_impact`; one planar contact.
    e : (ne,) array_like of restitution coefficients in [0, 1].
    mu : (nmu,) array_like of signed friction coefficients (see module docstring).
    """
    P = _planar_problem(M, Jc, dq, C)
    e = check_restitution(np.atleast_1d(np.asarray(e, float)), np.size(e))
    mu = np.atleast_1d(np.asarray(mu, float))
    if not np.all(np.isfinite(mu)):
        raise ShapeError("mu must be finite")
    W, v = P.contact_block(0)
    vn, vt = float(v[0]), float(v[1])
    T_minus = P.kinetic_energy(P.dq_minus)
    E, MU = np.meshgrid(e, mu, indexing="ij")
    shape = E.shape
    if vn >= 0.0:
        z = np.zeros(shape)
        f = np.zeros(shape, bool)
        return Landscape(e, mu, z, z, z, z[..., None], np.broadcast_to(v, shape + (2,)).copy(),
                         np.full(shape, vt), np.zeros(shape, int), f, f, f, f, f, f,
                         "pereira-nikravesh", "closed-form", MappingProxyType({"v_minus": v}))

    # sticking impulse, eq. (42)/(52): affine in e
    Winv = np.linalg.inv(W)
    st_n = -(Winv[0, 0] * (1 + E) * vn + Winv[0, 1] * vt)
    st_t = -(Winv[1, 0] * (1 + E) * vn + Winv[1, 1] * vt)
    stick = (st_n >= 0) & (np.abs(st_t) <= np.abs(MU) * st_n)
    # sliding, eq. (38): t opposite to v_t- for mu > 0 (eq. 55), along it for mu < 0
    # sign of the slip; with no slip, friction saturates where the sticking impulse pointed
    s = np.full(shape, np.sign(vt)) if vt != 0.0 else -np.sign(st_t)
    s = np.where(s == 0, -1.0, s)
    g_t = -MU * s  # frame-tangent component of (n + mu t)
    denom = W[0, 0] + W[0, 1] * g_t
    jam = ~stick & ~(denom > 1e-12 * np.abs(W).max())
    with np.errstate(divide="ignore", invalid="ignore"):
        sl_n = np.where(jam, np.nan, -(1 + E) * vn / np.where(jam, 1.0, denom))
    pn = np.where(stick, st_n, sl_n)
    pt = np.where(stick, st_t, sl_n * g_t)
    frictionless = MU == 0
    pn = np.where(frictionless, -(1 + E) * vn / W[0, 0], pn)
    pt = np.where(frictionless, 0.0, pt)
    jam = jam & ~frictionless
    vpn = vn + W[0, 0] * pn + W[0, 1] * pt
    vpt = vt + W[1, 0] * pn + W[1, 1] * pt
    TL = -(pn * vn + pt * vt) - 0.5 * (W[0, 0] * pn**2 + 2 * W[0, 1] * pn * pt + W[1, 1] * pt**2)
    regime = np.where(frictionless, 1, np.where(stick, 2, 3))
    tol = 1e-12
    gained = TL < -tol * T_minus
    pushes = pt * vt > tol * np.abs(pt) * abs(vt)
    reversal = (regime == 3) & (pt * vpt > tol * np.abs(pt) * np.abs(vpt))
    return Landscape(
        e=e, mu=mu, energy_loss=TL, energy_loss_fraction=TL / T_minus, normal_impulse=pn,
        tangential_impulse=pt[..., None], v_plus=np.stack([vpn, vpt], axis=-1),
        tangential_velocity=-s * vpt, regime=regime, energy_gained=gained & ~jam,
        friction_pushes_slip=pushes & ~jam, slip_reversal=reversal & ~jam, jammed=jam,
        failed=np.zeros(shape, bool), stick_possible=stick & ~frictionless,
        law="pereira-nikravesh", method="closed-form",
        meta=MappingProxyType({"v_minus": v.tolist(), "energy_before": T_minus,
                               "t_sign": "mu > 0: friction along -v_t-/|v_t-| (eq. 55)"}),
    )


class _Progress:
    """A plain progress bar on stderr, shown only for runs longer than ``after`` seconds."""

    def __init__(self, total: int, label: str, after: float = 2.0, stream=None):
        self.total, self.label, self.after = total, label, after
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()
        self.shown = False

    def update(self, done: int) -> None:
        elapsed = time.perf_counter() - self.start
        if elapsed < self.after and done < self.total:
            return
        if not self.shown and done >= self.total and elapsed < self.after:
            return
        self.shown = True
        frac = done / self.total
        bar = "#" * int(30 * frac)
        eta = elapsed / max(frac, 1e-9) - elapsed
        self.stream.write(f"\r{self.label} [{bar:<30}] {done}/{self.total} "
                          f"{elapsed:5.1f}s eta {eta:5.1f}s")
        if done >= self.total:
            self.stream.write("\n")
        self.stream.flush()


def law_landscape(M, Jc, dq, e, mu, C=None, law: str = "coulomb", method: str = "auto",
                  progress: bool = True, **options) -> Landscape:
    """Evaluate ``resolve_impact`` over a grid of e and mu (mu >= 0) for one impact state.

    Points where the law raises a :class:`~convimpact.errors.ConvImpactError` are marked in
    ``failed`` (and ``jammed`` for a non-positive effective mass) with NaN values there.
    """
    from .errors import NonPositiveEffectiveMassError
    from .impact import choose_method, solve_problem

    e = check_restitution(np.atleast_1d(np.asarray(e, float)), np.size(e))
    mu = np.atleast_1d(np.asarray(mu, float))
    base = build_problem(M, Jc, dq, 0.0, 0.0, C)
    d = base.dim
    if method == "auto":
        method = choose_method(base, law)
    shape = (e.size, mu.size)
    nan = lambda *s: np.full(shape + s, np.nan)  # noqa: E731
    TL, pn, pt, vp = nan(), nan(), nan(d - 1), nan(d)
    regime = np.full(shape, REGIMES.index("failed"))
    flags = {k: np.zeros(shape, bool) for k in ("energy_gained", "friction_pushes_slip",
                                                "slip_reversal", "jammed", "failed")}
    stick_possible = np.zeros(shape, bool)
    bar = _Progress(e.size * mu.size, f"{law}/{method}") if progress else None
    n = 0
    for i, ei in enumerate(e):
        for j, mj in enumerate(mu):
            P = build_problem(base.mass_matrix, list(base.jacobians) if not base.single
                              else base.jacobians[0], base.dq_minus, ei, mj,
                              base.loop_jacobian if base.n_loops else None)
            try:
                r = solve_problem(P, law, method, **options)
            except NonPositiveEffectiveMassError:
                flags["jammed"][i, j] = flags["failed"][i, j] = True
            except ConvImpactError:
                flags["failed"][i, j] = True
            else:
                imp = np.atleast_2d(r.impulse)[0]
                TL[i, j], pn[i, j], pt[i, j] = r.energy_loss, imp[0], imp[1:]
                vp[i, j] = np.atleast_2d(r.v_plus)[0]
                reg = r.regime if isinstance(r.regime, str) else r.regime[0]
                regime[i, j] = REGIMES.index(reg)
                stick_possible[i, j] = reg == "stick"
                dg = r.diagnostics
                flags["energy_gained"][i, j] = dg.energy_gained
                flags["friction_pushes_slip"][i, j] = dg.friction_pushes_slip
                flags["slip_reversal"][i, j] = dg.slip_reversal
            n += 1
            if bar:
                bar.update(n)
    T_minus = base.kinetic_energy(base.dq_minus)
    vt = base.v_minus[0, 1:]
    if d == 2:
        s = np.sign(vt[0]) if vt[0] != 0 else 1.0
        tangential_velocity = -s * vp[..., 1]
    else:
        tangential_velocity = np.linalg.norm(vp[..., 1:], axis=-1)
    return Landscape(
        e=e, mu=mu, energy_loss=TL, energy_loss_fraction=TL / T_minus, normal_impulse=pn,
        tangential_impulse=pt, v_plus=vp, tangential_velocity=tangential_velocity,
        regime=regime, stick_possible=stick_possible, law=law, method=method,
        meta=MappingProxyType({"v_minus": base.v_minus[0].tolist(), "energy_before": T_minus}),
        **flags,
    )
