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
    return float(np.linalg.norm(x))


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
    pushes = False
    reversal = False
    cone = 0.0
    coulomb = 0.0
    restitution = 0.0
    for i in range(P.n_contacts):
        pn, pt = pi[i, 0], pi[i, 1:]
        vt_minus, vt_plus = v_minus[i, 1:], v_plus[i, 1:]
        mu, e = P.friction[i], P.restitution[i]
        npt = _norm(pt)
        if npt > tol * pi_scale and float(pt @ vt_minus) > tol * npt * _norm(vt_minus):
            pushes = True
        slipping = _norm(vt_plus) > tol * 10.0 * v_scale
        if (regimes[i] == "slide" and slipping and npt > tol * pi_scale
                and float(pt @ vt_plus) > tol * npt * _norm(vt_plus)):
            reversal = True
        cone = max(cone, max(0.0, npt - mu * pn, -pn) / pi_scale)
        if slipping and pn > tol * pi_scale:
            u_dir = vt_plus / _norm(vt_plus)
            coulomb = max(coulomb, _norm(pt + mu * pn * u_dir) / pi_scale)
        target = -e * min(v_minus[i, 0], 0.0)  # Newton's law (eq. 21) on approaching contacts
        if pn > tol * pi_scale:
            restitution = max(restitution, abs(v_plus[i, 0] - target) / v_scale)
        else:
            restitution = max(restitution, max(0.0, target - v_plus[i, 0]) / v_scale)

    C = P.loop_jacobian
    loop_res = 0.0
    loop_cond = None
    if P.n_loops:
        loop_res = _norm(C @ dq_plus) / max(np.linalg.norm(C, 2) * _norm(P.dq_minus), _TINY)
        loop_cond = float(np.linalg.cond(P.loop_matrix))
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
    diag = ImpactDiagnostics(
        energy_before=T_minus,
        energy_after=T_plus,
        energy_gained=bool(energy_gained),
        friction_pushes_slip=pushes,
        slip_reversal=reversal,
        effective_mass=effective_mass,
        delassus_condition=float(np.linalg.cond(P.delassus)),
        loop_condition=loop_cond,
        mass_condition=float(np.linalg.cond(P.mass_matrix)),
        restitution_residual=float(restitution),
        cone_violation=float(cone),
        coulomb_residual=float(coulomb),
        loop_residual=float(loop_res),
        momentum_residual=float(mom_res),
        warnings=tuple(notes),
        extras=MappingProxyType(dict(extras or {})),
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
