"""Coulomb's law on the conic path: the fixed point over shifted CCP programs and the residual
of Coulomb's conditions (:mod:`convimpact.impact.laws.coulomb` finishes one contact exactly
and checks the answer).

With ``u = W pi + b``, ``b = v- + e min(v_n-, 0) n`` per contact, Coulomb's law is
``K_mu ∋ pi ⊥ u + mu |u_t| n ∈ K_mu*``: a CCP program whose ``q_n`` is shifted by
``s = mu |u_t|``, the shift being the unknown of the fixed point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..conic.paths import ProgramOptions, cone_qp, newton_shift, normal_mask
from ..conic.polish import EPS, VELOCITY_RESIDUAL_MAX, polish_cone_qp
from ..conic.qp import TINY, Backend, ConeQP, equilibrated, solve_cone_qp
from ..problem.build import ImpactProblem


def coulomb_residual(W: np.ndarray, b: np.ndarray, mu: np.ndarray, d: int,
                     pi: np.ndarray) -> float:
    """Relative residual of ``K ∋ pi ⊥ y = u + mu |u_t| n ∈ K*`` with ``u = W pi + b``.

    Max of the cone violation of pi, the dual-cone violation of y and the per-contact
    complementarity |pi_i . y_i|, each relative to |pi| and |b|.
    """
    n = mu.shape[0]
    x = pi.reshape(n, d)
    u = (W @ pi + b).reshape(n, d)
    y = u.copy()
    y[:, 0] += mu * np.linalg.norm(u[:, 1:], axis=1)
    ps = max(float(np.linalg.norm(pi)), TINY)
    vs = max(float(np.linalg.norm(b)), float(np.max(np.abs(W))) * ps, TINY)
    r = 0.0
    for i in range(n):
        r = max(r, max(0.0, np.linalg.norm(x[i, 1:]) - mu[i] * x[i, 0], -x[i, 0]) / ps)
        if mu[i] == 0.0:
            r = max(r, max(0.0, -y[i, 0]) / vs, np.linalg.norm(x[i, 1:]) / ps)
            r = max(r, abs(x[i, 0] * y[i, 0]) / (ps * vs))
        else:
            # y_n carries mu |u_t|: measure against mu-scaled velocities, so round-off in u_t
            # is not magnified by a large mu into a false failure
            vsi = vs * max(1.0, float(mu[i]))
            r = max(r, max(0.0, mu[i] * np.linalg.norm(y[i, 1:]) - y[i, 0]) / vsi)
            r = max(r, abs(float(x[i] @ y[i])) / (ps * vsi))
    return float(r)


@dataclass
class FixedPoint:
    """Where :func:`coulomb_fixed_point` stopped."""

    pi: np.ndarray  # (n_contacts, d) impulse
    iterations: int  # CCP programs solved
    converged: bool
    residual: float  # the fixed-point residual max |mu |u_t| - s| / |v-| of the last program
    conic_iterations: int
    status: str  # the last program's solver status
    finished_by: str
    polished: bool  # the last program was KKT-polished
    newton: bool  # the active-set Newton on Coulomb's conditions certified the answer
    unit: ConeQP  # the equilibrated problem (pi = scale * y): Coulomb's conditions measured on it
    scale: np.ndarray


def coulomb_fixed_point(P: ImpactProblem, backend: Backend, opts: ProgramOptions) -> FixedPoint:
    """The fixed point ``s -> mu |u_t(pi(s))|`` over shifted CCP programs (see
    :func:`convimpact.impact.laws.coulomb.solve_coulomb`), with the active-set Newton of
    Coulomb's conditions from each iterate on several contacts. One contact with friction
    stops after the first pass: the exact single-contact solve finishes or rescues it."""
    n, d = P.n_contacts, P.dim
    W = P.delassus
    b = P.v_minus.ravel() + newton_shift(P)
    mu = P.friction
    fric = mu > 0.0
    nmask = normal_mask(n, d)
    vscale = max(float(np.max(np.abs(P.v_minus))), TINY)

    def solve_for(s: np.ndarray):
        q = b.copy()
        q[nmask] += s
        sol = solve_cone_qp(backend, cone_qp(P, q), opts.tol, opts.max_iter)
        u = (W @ sol.x + b).reshape(n, d)
        return sol, mu * np.linalg.norm(u[:, 1:], axis=1)

    sW = max(float(np.max(np.abs(W))), TINY)
    # Coulomb's conditions keep their form under a uniform scaling of each contact's rows, so
    # the active-set Newton works on the equilibrated program (pi = scale * y)
    unit, scale = equilibrated(ConeQP(W, b, mu, d, np.zeros((0, n * d)), np.zeros(0)))
    iters = conic_iters = 0
    converged = polished = newton = False
    last_x = None
    res_norm = math.inf
    status = ""
    # first Anderson-accelerated and safeguarded (restart with halved mixing when the residual
    # does not drop), then, if that fails, the plain iteration, which is slower but reaches
    # active sets that the accelerated one jumps over
    for memory in ([opts.anderson_memory, 0] if opts.anderson_memory else [0]):
        s = np.zeros(n)
        hist_s: list[np.ndarray] = []
        hist_r: list[np.ndarray] = []
        prev = math.inf
        beta = 1.0  # mixing; halved whenever a step fails to reduce the residual
        for _ in range(opts.max_fixed_point_iter):
            sol, gs = solve_for(s)
            iters += 1
            conic_iters += max(sol.iterations, 0)
            status, last_x, polished = sol.status, sol.x, sol.polished
            r = gs - s
            res_norm = float(np.max(np.abs(r))) / vscale
            # mu |u_t| carries the round-off of W pi + b: cond(W) eps where W is
            # ill-conditioned (the impulse |b| / lambda_min(W) cancels digits), capped
            roundoff = min(1e2 * EPS * sW * float(np.max(np.abs(sol.x), initial=0.0))
                           * max(1.0, float(np.max(mu))) / vscale, VELOCITY_RESIDUAL_MAX)
            if res_norm <= max(opts.fixed_point_tol, opts.accuracy(sol.polished), roundoff) \
                    or not np.any(fric):
                converged = True
                break
            # active-set Newton on Coulomb's conditions from this iterate
            if n > 1:
                y, ok = polish_cone_qp(unit, sol.x / scale, coulomb=True)
                if ok and coulomb_residual(unit.W, unit.q, mu, d, y) <= 1e-11:
                    last_x, converged, newton = y * scale, True, True
                    break
            if memory and res_norm > 0.9 * prev and hist_s:  # safeguard: restart, damp
                hist_s.clear()
                hist_r.clear()
                beta = max(beta * 0.5, 1.0 / 16.0)
            prev = res_norm
            hist_s.append(s.copy())
            hist_r.append(r.copy())
            if len(hist_s) > memory + 1:
                hist_s.pop(0)
                hist_r.pop(0)
            s_new = s + beta * r
            if len(hist_s) >= 2 and memory > 0:  # Anderson (type II) step
                dR = np.array([hist_r[k + 1] - hist_r[k] for k in range(len(hist_r) - 1)]).T
                dS = np.array([hist_s[k + 1] - hist_s[k] for k in range(len(hist_s) - 1)]).T
                gamma, *_ = np.linalg.lstsq(dR, r, rcond=None)
                s_new = s_new - (dS + beta * dR) @ gamma
            s = np.maximum(s_new, 0.0)
        if converged or (n == 1 and fric[0]):
            break  # one contact: the exact solve finishes or rescues
    pi = last_x.reshape(n, d)
    finished = "fixed point" + (" (polished programs)" if polished else "")
    if newton:
        finished = "active-set Newton on Coulomb's conditions"
    elif n > 1:
        y, ok = polish_cone_qp(unit, pi.ravel() / scale, coulomb=True)
        if ok and coulomb_residual(unit.W, unit.q, mu, d, y) <= \
                coulomb_residual(unit.W, unit.q, mu, d, pi.ravel() / scale):
            pi, newton = (y * scale).reshape(n, d), True
            finished += ", then active-set Newton"
    return FixedPoint(pi, iters, converged, res_norm, conic_iters, status, finished, polished,
                      newton, unit, scale)


__all__ = ["coulomb_residual", "coulomb_fixed_point", "FixedPoint"]
