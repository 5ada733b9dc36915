"""The spatial sliding rule of Section 9.3 over e x mu x alpha (the paper's Fig. 9, generalized):
:func:`angle_landscape`, vectorized, with the exact angle of maximal dissipation alpha_m per
(e, mu). Part of the landscapes' API (:mod:`convimpact.studies.landscape` re-exports it)."""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ..errors import ShapeError
from ..impact.problem.build import build_problem, check_restitution
from ..impact.results import _fields_as_json
from ..validation import grid


@dataclass(frozen=True, eq=False)
class AngleLandscape:
    """The sliding rule of Section 9.3 over e x mu x alpha (the paper's Fig. 9, generalized).

    The tangential impulse slides along ``t(alpha)``, rotated by ``alpha`` counter-clockwise
    from the pre-impact slip ``v_t-`` in the (t1, t2) plane, with ``pi_n`` from eq. (38)/(51).

    Attributes
    ----------
    e, mu, alpha : the grid axes (alpha in radians).
    energy_loss : T_L(e, mu, alpha) (eq. 60), shape (ne, nmu, nalpha); NaN where excluded.
    normal_impulse : pi_n(e, mu, alpha) (eq. 38/51); NaN where excluded.
    admissible : the sliding denominator D(alpha) = c_n^T G (c_n + mu c_t) is positive.
    energy_gained : admissible directions with T_L < 0 (the paper's sector alpha_0..alpha_1).
    alpha_m : (ne, nmu) exact angle of maximal dissipation
        (:func:`~convimpact.impact.laws.max_dissipation.max_dissipation_direction`),
        in [0, 2 pi); NaN for mu = 0.
    energy_loss_max, normal_impulse_max_dissipation : T_L and pi_n at ``alpha_m``.
    meta : the impact state (v_minus, energy_before).
    """

    e: np.ndarray
    mu: np.ndarray
    alpha: np.ndarray
    energy_loss: np.ndarray
    normal_impulse: np.ndarray
    admissible: np.ndarray
    energy_gained: np.ndarray
    alpha_m: np.ndarray
    energy_loss_max: np.ndarray
    normal_impulse_max_dissipation: np.ndarray
    meta: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))

    def as_dict(self) -> dict[str, Any]:
        """Plain-JSON view (NaN becomes None)."""
        return _fields_as_json(self)


def angle_landscape(M, Jc, dq, e, mu, alpha, C=None) -> AngleLandscape:
    """T_L and pi_n of the Section 9.3 sliding rule over grids of e, mu and alpha, vectorized.

    Parameters
    ----------
    M, Jc, dq, C : as for :func:`convimpact.resolve_impact`; one spatial contact (Jc 3 x k)
        approaching (v_n- < 0).
    e : (ne,) restitution coefficients in [0, 1].
    mu : (nmu,) friction coefficients >= 0.
    alpha : (nalpha,) angles (radians) counter-clockwise from v_t- (from t1 if v_t- = 0).

    Returns
    -------
    AngleLandscape
    """
    from ..errors import ParameterError
    from ..impact.laws.max_dissipation import max_dissipation_direction
    from ..impact.problem.build import check_friction

    e = grid("e", e)
    e = check_restitution(e, e.size)
    mu = grid("mu", mu)
    mu = check_friction(mu, mu.size)
    alpha = grid("alpha", alpha)
    if not np.all(np.isfinite(alpha)):
        raise ShapeError("alpha must be finite angles in radians")
    P = build_problem(M, Jc, dq, 0.0, 0.0, C)
    if P.n_contacts != 1 or P.planar:
        raise ShapeError("angle_landscape takes one spatial contact (Jc of shape 3 x k); a "
                         "planar contact has only the two tangents alpha = 0 and pi")
    W, v = P.contact_block(0)
    if not v[0] < 0.0:
        raise ParameterError(f"the contact is not approaching (v_n- = {v[0]:g} >= 0): no "
                             "impulse acts, choose an impact state with v_n- < 0")
    vt = v[1:]
    nv = float(np.hypot(*vt))
    ref = vt / nv if nv > 0.0 else np.array([1.0, 0.0])
    t1 = np.cos(alpha) * ref[0] - np.sin(alpha) * ref[1]
    t2 = np.cos(alpha) * ref[1] + np.sin(alpha) * ref[0]
    E = e[:, None, None]
    MU = mu[None, :, None]
    wt = W[0, 1] * t1 + W[0, 2] * t2
    tWt = W[1, 1] * t1 * t1 + 2.0 * W[1, 2] * t1 * t2 + W[2, 2] * t2 * t2
    D = W[0, 0] + MU * wt  # eq. (38)/(51) denominator
    ok = np.broadcast_to(D > 1e-12 * float(np.max(np.abs(W))), (e.size, mu.size, alpha.size))
    pn = -(1.0 + E) * v[0] / np.where(ok, D, 1.0)
    TL = -pn * (v[0] + MU * (vt[0] * t1 + vt[1] * t2)) - 0.5 * pn * pn * (
        W[0, 0] + 2.0 * MU * wt + MU * MU * tWt)  # eq. (60)
    TL = np.where(ok, TL, np.nan)
    pn = np.where(ok, pn, np.nan)
    am = np.full((e.size, mu.size), np.nan)
    tlm = np.full_like(am, np.nan)
    pnm = np.full_like(am, np.nan)
    for i, ei in enumerate(e):  # one exact solve per (e, mu), none per angle
        for j, mj in enumerate(mu):
            if mj == 0.0:
                pnm[i, j] = -(1.0 + ei) * v[0] / W[0, 0]
                tlm[i, j] = 0.5 * (1.0 - ei * ei) * v[0] ** 2 / W[0, 0]  # eq. (59)
                continue
            t = max_dissipation_direction(W, v, float(ei), float(mj))
            am[i, j] = np.arctan2(ref[0] * t[1] - ref[1] * t[0], ref @ t) % (2.0 * np.pi)
            g = np.array([1.0, mj * t[0], mj * t[1]])
            p = -(1.0 + ei) * v[0] / float(W[0] @ g)
            pnm[i, j] = p
            tlm[i, j] = -p * float(g @ v) - 0.5 * p * p * float(g @ W @ g)
    return AngleLandscape(
        e=e, mu=mu, alpha=alpha, energy_loss=TL, normal_impulse=pn, admissible=ok.copy(),
        energy_gained=ok & (TL < 0.0), alpha_m=am, energy_loss_max=tlm,
        normal_impulse_max_dissipation=pnm,
        meta=MappingProxyType({"v_minus": v.tolist(),
                               "energy_before": P.kinetic_energy(P.dq_minus)}))
