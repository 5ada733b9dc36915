"""Law ``"stronge"`` on several coupled contacts: a compression phase, then an expansion phase.

Formulation (after the phase structure of Uchida, Sherman & Delp, *Making a meaningful impact:
modelling simultaneous frictional collisions in spatial multibody systems*, Proc. R. Soc. A
471:20140859, 2015 -- the impact resolved into a compression and an expansion phase, with one
constrained (here convex) optimization per phase; we take *one interval per phase* and do not
subdivide a phase into sliding and rolling intervals):

1. **Compression** -- the plastic impulse ``pi_c``: Moreau's impact law with e = 0 and
   Coulomb friction opposing the slip at the phase's end,
   ``K_mu ∋ pi_c ⊥ v^c + mu |v_t^c| n ∈ K_mu*`` (the ``coulomb`` law's program,
   :func:`convimpact.impact.laws.coulomb.solve_coulomb`, on the chosen conic path
   ``method="clarabel"`` or ``"cvxpy"``). Every pressed contact ends the phase at
   ``v_n^c = 0`` (rolling, or sliding with ``pi_t = -mu pi_n s``); its energy change
   ``pi_c.v^c - 1/2 pi_c.W.pi_c = -sum mu pi_n |v_t^c| - 1/2 pi_c.W.pi_c <= 0``.
2. **Expansion** -- each contact releases Poisson's share of its compression impulse,
   ``x_n,i = e_i pi_c,n,i``, and its friction ``x_t,i`` (``|x_t,i| <= mu_i x_n,i``) opposes the
   slip: the tangential impulses minimize the kinetic energy after the phase,
   ``min 1/2 x.W.x + x.v^c`` over the discs with the normal impulses fixed (maximal
   dissipation on the expansion increment, a convex program). It is solved by block
   Gauss--Seidel over the contacts, each block exactly (an interval clamp in the plane, the
   trust-region secular equation in space), to a stated tolerance (:data:`PGS_RTOL`), with a
   KKT certificate; a solve that does not converge raises :class:`SolverError`.
3. **Re-compression** -- Poisson's expansion of coupled contacts can drive a contact into
   approach (``v_n < 0`` after it); that contact is then stopped by a second plastic
   compression, the program of phase 1 from the post-expansion velocity (a warning says so;
   it only dissipates, and leaves no contact approaching).

Assumptions and consequences, stated:

* **Never creates energy.** The Poisson candidate ``x = E pi_c`` is feasible, so the expansion
  releases at most ``e pi_c.v^c + 1/2 e^2 |pi_c|_W^2``; with one common e the whole impact
  therefore loses at least ``1/2 (1 - e^2) |pi_c|_W^2 + (1 + e) sum mu pi_n |v_t^c| >= 0``.
  With *different* e per contact on coupled contacts that bound can be negative; the
  expansion impulse is then scaled by the largest ``kappa in [0, 1]`` that keeps
  ``T+ <= T-`` (a warning says so and gives kappa).
* Restitution is Poisson's per contact (``x_n = e pi_c,n``); the works of each contact's
  normal impulse along the two phases' straight impulse paths are reported
  (``normal_work_compression`` / ``normal_work_restitution`` per contact under
  ``extras["contacts"]``) and the diagnostics measure the energetic restitution from them:
  it holds exactly for frictionless contacts that are dynamically independent, and is
  reported, not imposed, otherwise.
* One contact, several dynamically independent ones, or several of which only one approaches
  while the others lift under its exact impulse (a block landing on one corner while its
  pivot rises), are resolved by the exact impulse-space integration of
  :mod:`convimpact.impact.laws.stronge` instead; this model does
  not reduce to that integration when the coupling vanishes (it takes one interval per
  phase), so answers change continuously with the coupling only within each model.
* Frictionless contacts: the compression is the plastic linear complementarity problem and
  the answer is Poisson's multi-contact law (= Newton's for orthogonal contacts).

**Warm start** (a time-stepping scheme calls the law on nearly the same impact step after
step). The plastic compression of phase 1 is first tried by the compiled active-set Newton
on Coulomb's conditions (:mod:`convimpact.impact.conic.polish_newton`) from the last
compressions of as many contacts with the same friction (on the polish's primary
classification of each, with its closeness test: the same solution branch, moved by less
than 1e-2 of its size), with no cone program, in one compiled call per start
(:mod:`convimpact.impact.laws.stronge_contacts_warm`). Its answer is kept only when it meets
Coulomb's conditions at round-off (:data:`WARM_RESIDUAL`, the fixed point's own test) and
is the answer of the fixed point too: a locally unique solution, or, on redundant contacts
(a box on four corners), one whose family of solutions moves no velocity (the null space of
the Newton's Jacobian mapped by W) with every e = 0, so that the split of the compression
impulse feeds no expansion. Then the velocities are the fixed point's to round-off and only
that split may differ, by about what the interior point itself fixes it to (measured on the
bench's boxes: 4e-8 to 6e-8 of the impulse; the interior point's own answers differ by 7e-9
to 4e-8 between its tolerances 1e-8 and 1e-11). A family of motions (a box sliding and
spinning on four corners, where the split changes the friction moments), a contact changing
its kind, or any failure to certify takes the fixed point over Clarabel programs. The
memory holds, per process, the last :data:`WARM_STARTS` compressions of each of the last
:data:`WARM_KEEP` (contacts, dimension, friction) kinds of problem, tried latest first:
islands of one kind in different states (boxes at rest next to sliding ones) each find
their own start.

Its derivative (phase by phase: Coulomb's plastic compression, then the expansion's KKT
conditions) is :mod:`convimpact.impact.laws.stronge_contacts_derivative`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..conic.paths import ProgramOptions, regimes_from_slip
from ..conic.qp import Backend
from ..diagnostics import assemble_result
from ...errors import SolverError
from ..exact.dispatch import independent_contacts_result
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from .coulomb import solve_coulomb

LAW = "stronge"
#: relative step (to the impulse scale) at which the expansion's Gauss--Seidel sweeps stop
PGS_RTOL = 1e-14
#: most Gauss--Seidel sweeps of the expansion program
PGS_MAX_SWEEPS = 5000
#: relative KKT residual the expansion's answer must meet (else SolverError)
KKT_RTOL = 1e-9

FORMULATION = ("compression then expansion (after Uchida, Sherman & Delp 2015, one interval "
               "per phase): plastic compression by Moreau's law (e = 0, Coulomb friction); "
               "expansion with Poisson's normal impulse e_i pi_c,n,i per contact and friction "
               "at maximal dissipation against the slip")


def _disc_block(A: np.ndarray, c: np.ndarray, r: float) -> np.ndarray:
    """argmin 1/2 x.A.x + c.x over |x| <= r (A symmetric PSD, 1x1 or 2x2), exactly."""
    m = c.size
    if r <= 0.0:
        return np.zeros(m)
    if m == 1:
        a = float(A[0, 0])
        if a > 0.0:
            return np.array([min(max(-float(c[0]) / a, -r), r)])
        return np.array([-r * math.copysign(1.0, float(c[0])) if c[0] != 0.0 else 0.0])
    lam, Q = np.linalg.eigh(A)
    g = Q.T @ c
    top = max(float(lam[-1]), 0.0)
    if lam[0] > 1e-14 * max(top, 1e-300):
        x = -g / lam
        if math.hypot(*x) <= r:
            return Q @ x
    # boundary: x(k) = -g / (lam + k), |x(k)| = r with k > -lam_min (k >= 0); bisection-Newton
    nrm = float(np.linalg.norm(g))
    if nrm == 0.0:
        return np.zeros(m)
    lo, hi = max(-float(lam[0]), 0.0), nrm / r + top
    k = hi
    for _ in range(200):
        x = -g / (lam + k)
        f = 1.0 / float(np.linalg.norm(x)) - 1.0 / r  # increasing in k
        if f > 0.0:
            hi = k
        else:
            lo = k
        dx = float(np.sum(g * g / (lam + k) ** 3))
        n3 = float(np.linalg.norm(x)) ** 3
        new = k - f * n3 / dx if dx > 0.0 else 0.5 * (lo + hi)
        if not lo < new < hi:
            new = 0.5 * (lo + hi)
        if abs(new - k) <= 1e-16 * max(k, 1e-300) or hi - lo <= 1e-16 * hi:
            k = new
            break
        k = new
    x = -g / (lam + k)
    x *= r / float(np.linalg.norm(x))
    return Q @ x


def expansion_friction(W: np.ndarray, vc: np.ndarray, xn: np.ndarray, mu: np.ndarray,
                       scale: float) -> tuple[np.ndarray, int]:
    """The expansion impulse: normals ``xn`` fixed, tangential impulses minimizing
    ``1/2 x.W.x + x.vc`` over ``|x_t,i| <= mu_i xn_i`` (block Gauss--Seidel, each block
    exact). Returns the impulse (n, d) and the sweeps taken.

    Raises
    ------
    SolverError
        when the sweeps do not converge or the answer misses its KKT certificate.
    """
    n, d = vc.shape
    x = np.zeros((n, d))
    x[:, 0] = xn
    radius = mu * xn
    free = [i for i in range(n) if radius[i] > 0.0]
    if not free:  # no friction to distribute (every e = 0, or frictionless): no sweep
        return x, 0
    tdx = [np.arange(i * d + 1, (i + 1) * d) for i in range(n)]
    flat = x.ravel()
    grad = W @ flat + vc.ravel()
    sweeps = 0
    for sweeps in range(1, PGS_MAX_SWEEPS + 1):
        step = 0.0
        for i in free:
            t = tdx[i]
            A = W[np.ix_(t, t)]
            xt = flat[t]
            c = grad[t] - A @ xt  # the block's linear term with the others fixed
            new = _disc_block(A, c, float(radius[i]))
            delta = new - xt
            if delta.any():
                flat[t] = new
                grad += W[:, t] @ delta
                step = max(step, float(np.max(np.abs(delta))))
        if step <= PGS_RTOL * scale:
            break
    else:
        raise SolverError(
            f"law 'stronge' (several contacts): the expansion's friction program did not "
            f"converge in {PGS_MAX_SWEEPS} Gauss-Seidel sweeps; use law='dissipative' or 'ccp'")
    # KKT certificate: per contact, the tangential gradient g_t vanishes inside the disc, and
    # on its boundary x_t = -r g_t / |g_t| (friction opposite the slip it acts on)
    worst = 0.0
    gscale = max(float(np.max(np.abs(vc))), float(np.max(np.abs(W))) * scale, 1e-300)
    for i in free:
        t = tdx[i]
        g, xt, r = grad[t], flat[t], float(radius[i])
        ng = float(np.linalg.norm(g))
        if float(np.linalg.norm(xt)) < r * (1.0 - 1e-9):
            worst = max(worst, ng / gscale)
        else:
            worst = max(worst, float(np.linalg.norm(g + ng * xt / r)) / gscale)
    if worst > KKT_RTOL:
        raise SolverError(
            f"law 'stronge' (several contacts): the expansion's friction program ended with a "
            f"relative KKT residual {worst:.2e} > {KKT_RTOL:g}; use law='dissipative' or 'ccp'")
    return flat.reshape(n, d), sweeps


def _energy(p: np.ndarray, v: np.ndarray, W: np.ndarray) -> float:
    """T+ - T- of the impulse p from velocity v: p.v + 1/2 p.W.p (flattened)."""
    return float(p @ v + 0.5 * p @ W @ p)


def _kappa(dT_c: float, a: float, b: float) -> float:
    """Largest kappa in [0, 1] with dT_c + kappa a + 1/2 kappa^2 b <= 0 (dT_c <= 0)."""
    if dT_c + a + 0.5 * b <= 0.0:
        return 1.0
    if b <= 0.0:
        return max(min(-dT_c / a, 1.0), 0.0) if a > 0.0 else 1.0
    disc = a * a - 2.0 * b * dT_c
    return max(min((-a + math.sqrt(max(disc, 0.0))) / b, 1.0), 0.0)


#: Coulomb residual (on the equilibrated program) a warm-started compression must reach, the
#: fixed point's own test of its active-set Newton
WARM_RESIDUAL = 1e-11
#: kinds of problem (contacts, dimension, friction) whose compressions are remembered
WARM_KEEP = 64
#: compressions remembered per kind, the latest first (islands of one kind in different
#: states -- boxes at rest and sliding -- each find their own)
WARM_STARTS = 8
#: per (contacts, dimension, friction): the last compressions, the latest first
_WARM: dict[tuple, list[np.ndarray]] = {}


def _warm_key(P: ImpactProblem) -> tuple:
    return P.n_contacts, P.dim, np.ascontiguousarray(P.friction, dtype=float).tobytes()


def _warm_plastic(P: ImpactProblem, opts: ProgramOptions):
    """The plastic compression warm-started from a remembered compression of as many contacts
    (the latest first), or None when none certifies ("Warm start" in the module docstring).
    ``P`` carries its own restitution (the gate); the compression itself has e = 0.
    Returns (impulse (n, d), info, index of the start used)."""
    n, d = P.n_contacts, P.dim
    starts = _WARM.get(_warm_key(P))
    if not starts or n < 2:
        return None
    from .stronge_contacts_warm import REDUNDANT, UNIQUE, warm_compression

    mu = np.ascontiguousarray(P.friction, dtype=float)
    W = np.ascontiguousarray(P.delassus, dtype=float)
    b = np.ascontiguousarray(P.v_minus, dtype=float).ravel()
    plastic_only = not np.any(P.restitution != 0.0)
    for j, prev in enumerate(starts):
        status, pi, resid = warm_compression(W, b, mu, d, prev, False)
        if not resid <= WARM_RESIDUAL:
            continue
        if not (status == UNIQUE or (status == REDUNDANT and plastic_only)):
            return None  # a family of motions, or redundant impulses an expansion releases
        info = {"fixed_point_iterations": 0, "fixed_point_converged": True,
                "fixed_point_residual": 0.0, "conic_iterations": 0,
                "solver_status": "no cone program",
                "finished_by": "active-set Newton on Coulomb's conditions from a previous "
                               "compression",
                "complementarity_residual": float(resid), "tolerance": opts.tol,
                "accuracy": opts.accuracy(True)}
        return pi.reshape(n, d), info, j
    return None


def _remember(P: ImpactProblem, pi: np.ndarray, replaces: int | None) -> None:
    """Keep the compression ``pi`` first among its kind's starts (in place of the start it
    came from, if any), at most :data:`WARM_STARTS` per kind and :data:`WARM_KEEP` kinds."""
    key = _warm_key(P)
    starts = _WARM.pop(key, [])
    if replaces is not None:
        del starts[replaces]
    _WARM[key] = [pi.ravel().copy()] + starts[:WARM_STARTS - 1]
    while len(_WARM) > WARM_KEEP:  # the oldest kind first (dicts keep insertion order)
        del _WARM[next(iter(_WARM))]


def _plastic(P: ImpactProblem, backend: Backend, opts: ProgramOptions, warm: bool = True):
    """Moreau's plastic impact (e = 0) with Coulomb friction: (impulse (n, d), solver info).

    ``warm`` (the compression of phase 1): warm-started from a previous compression
    (:func:`_warm_plastic`) when that certifies, and remembered for the next calls; else, and
    for the re-compression of phase 3, by the fixed point over cone programs
    (:func:`~.coulomb.solve_coulomb`)."""
    got = _warm_plastic(P, opts) if warm else None
    used = None
    if got is None:
        pi, info = solve_coulomb(dataclasses.replace(P, restitution=np.zeros(P.n_contacts)),
                                 backend, opts)
    else:
        pi, info, used = got
    pi[:, 0] = np.maximum(pi[:, 0], 0.0)
    if warm:
        _remember(P, pi, used)
    return pi, info


def coupled_result(P: ImpactProblem, backend: Backend, method: str,
                   opts: ProgramOptions) -> ImpactResult:
    """Stronge's law on several coupled contacts (the module's two-phase formulation, or the
    exact single-contact integration when one contact approaches and the others lift)."""
    n, d = P.n_contacts, P.dim
    W = P.delassus
    vm = P.v_minus
    e, mu = P.restitution, P.friction
    alone = independent_contacts_result(P, LAW, method, one_approaching=True, lifted={
        "normal_work_compression": 0.0, "normal_work_restitution": 0.0})
    if alone is not None:
        return alone
    pc, info = _plastic(P, backend, opts)
    vc = vm + (W @ pc.ravel()).reshape(n, d)
    dT_c = _energy(pc.ravel(), vm.ravel(), W)
    scale = max(float(np.max(np.abs(pc))), 1e-300)
    x, sweeps = expansion_friction(W, vc, e * pc[:, 0], mu, scale)
    flat = x.ravel()
    a = float(flat @ vc.ravel())
    b = float(flat @ W @ flat)
    kappa = _kappa(dT_c, a, b)
    warnings = []
    if kappa < 1.0:
        warnings.append(
            f"law 'stronge' (several contacts): different e per coupled contact would make the "
            f"expansion gain energy; its impulse was scaled by kappa = {kappa:.6g} so that "
            "T+ <= T-")
        x = kappa * x
    pi = pc + x
    vp = vc + (W @ x.ravel()).reshape(n, d)
    xr = np.zeros((n, d))
    if np.any(vp[:, 0] < -KKT_RTOL * max(float(np.max(np.abs(vm))), 1e-300)):
        # 3. a contact the expansion drives into approach: a second plastic compression
        d_dq, _ = P.velocity_jump(pi.ravel())
        again = dataclasses.replace(P, dq_minus=P.dq_minus + d_dq, v_minus=vp)
        xr, _ = _plastic(again, backend, opts, warm=False)
        pi = pi + xr
        vp = vp + (W @ xr.ravel()).reshape(n, d)
        warnings.append("law 'stronge' (several contacts): the expansion drove a contact into "
                        "approach; a second plastic compression stopped it")
    contacts = []
    for i in range(n):
        wc = 0.5 * pc[i, 0] * (vm[i, 0] + vc[i, 0])
        wr = 0.5 * x[i, 0] * (vc[i, 0] + vp[i, 0])
        contacts.append({"compression_impulse": pc[i].tolist(),
                         "expansion_impulse": x[i].tolist(),
                         "recompression_impulse": xr[i].tolist(),
                         "normal_work_compression": wc, "normal_work_restitution": wr})
    extras = {"formulation": FORMULATION, "contacts": contacts, "expansion_scale": kappa,
              "expansion_sweeps": sweeps, "compression_solve": info}
    acc = info["accuracy"]
    regimes = regimes_from_slip(P, pi, vp, acc)
    return assemble_result(P, pi, regimes, LAW, method, tol=acc, extras=extras,
                           warnings=tuple(warnings))
