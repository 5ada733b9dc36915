"""Measure what an impact law's answer did: the one place every solver path builds its result.

Given a contact impulse, :func:`assemble_result` maps it back to joint velocities and loop
impulses (eqs. 29, 44, 45) and measures every invariant the brief asks for: restitution on the
normal velocity, the friction cone, friction opposing post-impact slip, C Delta theta_dot = 0,
momentum balance, energy (eq. 58), and the failure flags of Newton's law with friction.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from .problem import ImpactProblem
from .results import ImpactDiagnostics, ImpactResult

_TINY = 1e-300


def _norm(x) -> float:
    x = np.ravel(x)
    return float(np.sqrt(x @ x))


def assemble_result(
    problem: ImpactProblem,
    impulse: np.ndarray,
    regimes: Sequence[str],
    law: str,
    method: str,
    *,
    effective_mass: float | None = None,
    tol: float = 1e-9,
    extras: Mapping[str, Any] | None = None,
    warnings: Sequence[str] = (),
) -> ImpactResult:
    """Turn a contact impulse into an :class:`ImpactResult` with measured diagnostics.

    Parameters
    ----------
    problem : the validated impact.
    impulse : (n_contacts, d) contact-frame impulses.
    regimes : one regime name per contact.
    law, method : names recorded in the result.
    effective_mass : sliding denominator of eq. (38)/(51), when the law used one.
    tol : relative accuracy of the solution (the solver's tolerance); flags are raised only
        beyond it, so that a solver's round-off is not reported as physics.
    extras, warnings : law-specific figures and statements to carry along.
    """
    P = problem
    pi = np.asarray(impulse, dtype=float).reshape(P.n_contacts, P.dim)
    d_dq, dsigma = P.velocity_jump(pi)
    dq_plus = P.dq_minus + d_dq
    v_minus = P.v_minus
    v_plus = (P.jacobians.reshape(-1, P.n_coordinates) @ dq_plus).reshape(P.n_contacts, P.dim)
    flat = pi.ravel()

    # energy, eq. (58) in contact space: T+ - T- = pi.v- + 1/2 pi.W.pi (Delta sigma does no
    # work because C theta_dot- = 0)
    T_minus = P.kinetic_energy(P.dq_minus)
    dT = float(flat @ v_minus.ravel() + 0.5 * flat @ P.delassus @ flat)
    T_plus = T_minus + dT
    energy_gained = dT > tol * max(T_minus, _TINY) * 10.0

    pi_scale = max(_norm(flat), _TINY)
    v_scale = max(float(np.max(np.abs(v_minus))), _TINY)
    # per-contact checks, vectorized over contacts
    pn, pt = pi[:, 0], pi[:, 1:]
    vt_minus, vt_plus = v_minus[:, 1:], v_plus[:, 1:]
    mu, e = P.friction, P.restitution
    npt = np.sqrt(np.einsum("ij,ij->i", pt, pt))
    nvt_minus = np.sqrt(np.einsum("ij,ij->i", vt_minus, vt_minus))
    nvt_plus = np.sqrt(np.einsum("ij,ij->i", vt_plus, vt_plus))
    acting = npt > tol * pi_scale
    pushes = bool(np.any(acting & (np.einsum("ij,ij->i", pt, vt_minus)
                                   > tol * npt * nvt_minus)))
    slipping = nvt_plus > tol * 10.0 * v_scale
    sliding = np.array([r == "slide" for r in regimes])
    reversal = bool(np.any(sliding & slipping & acting
                           & (np.einsum("ij,ij->i", pt, vt_plus) > tol * npt * nvt_plus)))
    cone = float(np.max(np.maximum.reduce([np.zeros_like(pn), npt - mu * pn, -pn]))) / pi_scale
    pressed = pn > tol * pi_scale
    coulomb = 0.0
    opposing = slipping & pressed
    if opposing.any():
        u_dir = vt_plus[opposing] / nvt_plus[opposing, None]
        miss = pt[opposing] + (mu * pn)[opposing, None] * u_dir
        coulomb = float(np.max(np.sqrt(np.einsum("ij,ij->i", miss, miss)))) / pi_scale
    penetration = bool(np.any(v_plus[:, 0] < -tol * 10.0 * v_scale))
    target = -e * np.minimum(v_minus[:, 0], 0.0)  # Newton's law (eq. 21) on approaching contacts
    restitution = float(np.max(np.where(pressed, np.abs(v_plus[:, 0] - target),
                                        np.maximum(0.0, target - v_plus[:, 0])))) / v_scale

    C = P.loop_jacobian
    loop_res = 0.0
    if P.n_loops:
        loop_res = _norm(C @ dq_plus) / max(np.linalg.norm(C) * _norm(P.dq_minus), _TINY)
    gen_impulse = P.jacobians.reshape(-1, P.n_coordinates).T @ flat
    mom_res = _norm(P.mass_matrix @ d_dq - gen_impulse - C.T @ dsigma) / max(
        _norm(gen_impulse), _TINY)

    notes = list(warnings)
    if energy_gained:
        notes.append(f"energy gained: T+ - T- = {dT:.6g} (the law created energy)")
    if pushes:
        notes.append("friction impulse pushes along the pre-impact slip (pi_t . v_t- > 0)")
    if reversal:
        notes.append("slip reversal: post-impact slip is not opposed by the friction impulse")
    if penetration:
        notes.append("penetration: a contact still approaches after the impact (v_n+ < 0)")
    diag = ImpactDiagnostics(
        energy_before=T_minus,
        energy_after=T_plus,
        energy_gained=bool(energy_gained),
        friction_pushes_slip=pushes,
        slip_reversal=reversal,
        penetration=penetration,
        effective_mass=effective_mass,
        restitution_residual=float(restitution),
        cone_violation=float(cone),
        coulomb_residual=float(coulomb),
        loop_residual=float(loop_res),
        momentum_residual=float(mom_res),
        warnings=tuple(notes),
        extras=MappingProxyType(dict(extras or {})),
        _delassus=P.delassus,
        _mass=P.mass_matrix,
        _loop=P.loop_matrix if P.n_loops else None,
    )
    if P.single:
        return ImpactResult(
            dq_plus=dq_plus, impulse=pi[0], loop_impulse=dsigma, regime=regimes[0],
            energy_loss=-dT, v_minus=v_minus[0].copy(), v_plus=v_plus[0], law=law,
            method=method, diagnostics=diag,
        )
    return ImpactResult(
        dq_plus=dq_plus, impulse=pi, loop_impulse=dsigma, regime=tuple(regimes),
        energy_loss=-dT, v_minus=v_minus.copy(), v_plus=v_plus, law=law, method=method,
        diagnostics=diag,
    )
