"""An exact solver for the laws at several contacts (``method="interior"``): ``ccp`` and
``dissipative`` (one convex cone program), and ``coulomb`` (a cone complementarity problem).

The laws ``ccp`` and ``dissipative`` reduce at several contacts to one convex program over the
product of the friction cones (:mod:`convimpact.impact.laws.ccp`,
:mod:`convimpact.impact.laws.dissipative`),

    minimize 1/2 pi^T W pi + b^T pi   over   pi_i in K_mu_i,

with ``b = v- + e min(v_n-, 0) n`` (ccp) or ``b = v-`` (the dissipative law's plastic phase,
then scaled by 1 + e per contact), and contacts that do not approach entering with their
normal only (``pi_t = 0``: pressed by the others, never kicked along their slip). The answer
of the law is the program's KKT point,

    K ∋ pi  ⊥  z = W pi + b ∈ K*,

which is what this path computes and certifies, by the contact engine
(:mod:`convimpact.contacts.engine`): up to
:data:`~convimpact.contacts.engine.COMPILED_MAX_ROWS` contact rows in one compiled call
(:mod:`convimpact.contacts.interior_point`, :mod:`convimpact.contacts.newton`);
above, or where that answer fails the certificate of step 3, by the engine's vectorized
backend (the same interior point on LAPACK or sparse factorizations, its own Newton finish),
judged by the same certificate:

1. a primal-dual interior point (Mehrotra's predictor-corrector with Nesterov-Todd scaling,
   one dense Cholesky factorization per iteration) on the program written over standard
   second-order cones, each contact equilibrated by its own effective mass, to a
   complementarity gap and residual of 1e-9 (10-20 iterations);
2. a semismooth Newton finish on the natural map ``pi - Proj_K(pi - z) = 0`` from there
   (quadratic convergence: two or three steps to round-off; a singular W -- a box on four
   corners -- is handled by basic solutions of the Newton systems);
3. the law's KKT certificate on the original data (:func:`~convimpact.contacts.certificates.ccp_certificate`:
   cone and dual-cone violations and per-contact complementarity, relative to the impulse
   and velocity scales, as the conic paths' :func:`~convimpact.impact.conic.polish.kkt_residual`
   measures them). The answer is returned only when the certificate is at most ``tol``
   (default 1e-10) or, for an ill-conditioned W, 1e3 times the round-off floor
   ``eps max|W| max|pi| / max|z|`` capped at
   :data:`~convimpact.impact.conic.polish.VELOCITY_RESIDUAL_MAX` (the conic paths' rule);
   otherwise :class:`CertificateError`, a :class:`~convimpact.errors.SolverError`
   (under ``method="auto"``, Clarabel takes over and the result's notes say so).

``coulomb`` (Coulomb's law with Newton's restitution, ``K ∋ pi ⊥ u + mu |u_t| n ∈ K*``,
``u = W pi + b``, every contact with its friction) is not a convex program: it is solved by the
same semismooth Newton on its own natural map, started from the CCP answer (the start of the
conic path's fixed point) -- the engine's backend adds Pinocchio's ADMM where that Newton
misses -- and accepted on Coulomb's conditions
(:func:`~convimpact.impact.laws.coulomb.coulomb_residual`, compiled as
:func:`~convimpact.contacts.certificates.coulomb_certificate`) to ``tol``. It is tried first under ``method="auto"``
(:data:`convimpact.impact.resolve.INTERIOR_FIRST`): at several contacts the law may have
several solutions (a box on four corners has a family of them), and the answer is the one the
engine reaches, possibly another than the conic path's fixed point.

Options (keyword arguments of ``resolve_impact``): ``tol`` (the certificate's acceptance
tolerance, default 1e-10), ``max_iter`` (interior-point iterations, default 100),
``newton_iter`` (Newton steps, default 20).

On the public path (``resolve_impact``, :func:`ccp_result` and its siblings) the law's data,
the kernel, the certificate and the answer's velocities and regimes come from one compiled
call (:func:`~.law_programs.solve_law`), the same kernels and certificate as
:func:`solve_cone_complementarity` with no dispatch between them.

The kernels compile on their first call (numba, ``cache=True``; :func:`compile_kernels`
builds them ahead of time and says how long it took): measured 27 s once per machine, then
1.2 s in a fresh process from numba's cache (``convimpact bench --sections several``);
``import convimpact`` compiles nothing, and one-contact impacts never load them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..conic.polish import VELOCITY_RESIDUAL_MAX
from ..diagnostics import assemble_result
from ...errors import SolverError
from ..laws.dissipative import poisson_scaled, poisson_warnings
from ..options import parse_method_options
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from ...contacts.engine import COMPILED_MAX_ROWS, HANDOVER_TOL
from ...contacts.engine import solve as engine_solve

METHOD = "interior"
#: laws this path solves
LAWS = ("ccp", "dissipative", "coulomb")
#: the natural-map residual the engine is asked for before the law's certificate judges
ENGINE_TOL = 1e-12
#: accuracy claimed for certified answers (the tol passed to assemble_result)
CERTIFIED_ACCURACY = 1e-9
_STATUS = {0: "converged", 1: "iteration limit", 2: "stalled", 3: "trivial"}


class CertificateError(SolverError):
    """The interior path's answer failed its certificate (a
    :class:`~convimpact.errors.SolverError`). Under ``method="auto"`` the impact is
    handed to the conic path, which the result's notes say: where the certificate fails the
    Delassus matrix is nearly singular or the program has no solution, which the conic path
    treats or reports itself."""


@dataclass(frozen=True)
class InteriorOptions:
    """Validated options of ``method="interior"`` (see the module docstring)."""

    tol: float = 1e-10
    max_iter: int = 100
    newton_iter: int = 20


@dataclass(frozen=True)
class CertifiedImpulse:
    """A certified answer of the cone complementarity problem.

    Attributes
    ----------
    impulse : (n_contacts, d) contact-frame impulse.
    kkt_residual : the certificate (relative KKT residual on the original data).
    accepted_residual : the largest certificate accepted for these data.
    interior_iterations, newton_steps : work done by the two phases.
    interior_status : how the interior point stopped ("converged", "iteration limit", ...).
    """

    impulse: np.ndarray
    kkt_residual: float
    accepted_residual: float
    interior_iterations: int
    newton_steps: int
    interior_status: str


DEFAULT_OPTIONS = InteriorOptions()


_KERNELS = None


def kernels():
    """The compiled law programs (:mod:`.law_programs`, with the engine's kernels and
    certificates they run), imported on first use (compiled then, or loaded from numba's
    on-disk cache, with a message when that takes long)."""
    global _KERNELS
    if _KERNELS is None:
        from . import law_programs
        from ...compiled import announce

        announce("several-contact interior kernels", 25, law_programs.solve_law,
                 law_programs.ccp_kernel, law_programs.coulomb_kernel)
        _KERNELS = law_programs
    return _KERNELS


def compile_kernels() -> dict[str, float]:
    """Build (or load from numba's on-disk cache) the kernels now; seconds per step.

    ``import`` (numba and the module) and ``first_call`` (compiling, or loading the cached
    machine code of, the interior point, the Newton finish and the certificate, alone and
    as the public path's single call).
    """
    t0 = time.perf_counter()
    K = kernels()
    out = {"import": time.perf_counter() - t0}
    t = time.perf_counter()
    W = np.eye(6)
    b = -np.ones(6)
    mu = np.array([0.5, 0.0])
    for kernel, certificate in ((K.ccp_kernel, K.ccp_certificate),
                                (K.coulomb_kernel, K.coulomb_certificate)):
        pi, *_ = kernel(W, b, mu, 3, HANDOVER_TOL, 100, 20)
        certificate(W, b, mu, 3, pi)
    for mode in range(3):  # the public path's single call (law_programs.solve_law)
        K.solve_law(W, b, mu, mu, 3, mode, HANDOVER_TOL, 100, 20, CERTIFIED_ACCURACY)
    out["first_call"] = time.perf_counter() - t
    return out


def parse_options(options: dict) -> InteriorOptions:
    """Validate the keyword options of ``method="interior"``."""
    if not options:
        return DEFAULT_OPTIONS
    return parse_method_options(METHOD, options, InteriorOptions,
                                {"max_iter": 1, "newton_iter": 0})


def solve_cone_complementarity(W: np.ndarray, b: np.ndarray, mu: np.ndarray, dim: int,
                               opts: InteriorOptions = DEFAULT_OPTIONS,
                               coulomb: bool = False) -> CertifiedImpulse:
    """The certified answer of a law's cone complementarity problem on contact data.

    ``coulomb=False``: the KKT point of ``min 1/2 pi^T W pi + b^T pi`` over ``pi_i in K_mu_i``
    (``K ∋ pi ⊥ W pi + b ∈ K*``); ``coulomb=True``: Coulomb's law
    ``K ∋ pi ⊥ u + mu |u_t| n ∈ K*``, ``u = W pi + b``, by Newton from the former.

    Parameters
    ----------
    W : (n d, n d) symmetric positive semidefinite Delassus matrix.
    b : (n d,) linear term (contact velocities with the law's shift).
    mu : (n,) friction coefficients; ``mu_i = 0`` keeps contact i's normal only.
    dim : d, 2 (planar) or 3 (spatial).
    opts : tolerances and iteration limits.
    coulomb : solve Coulomb's law instead of the convex program.

    Raises
    ------
    CertificateError (a SolverError)
        when the answer fails its certificate (the program has no solution -- a rigid pinch
        through a singular W -- or the iterations did not reach one).
    """
    K = kernels()
    W = np.ascontiguousarray(W, dtype=float)
    b = np.ascontiguousarray(b, dtype=float)
    mu = np.ascontiguousarray(mu, dtype=float)
    kernel = K.coulomb_kernel if coulomb else K.ccp_kernel
    certificate = K.coulomb_certificate if coulomb else K.ccp_certificate
    pi, status, iters, steps, _r1, _r2 = kernel(W, b, mu, int(dim), HANDOVER_TOL,
                                                int(opts.max_iter), int(opts.newton_iter))
    if status == K.TRIVIAL:
        return CertifiedImpulse(pi.reshape(mu.shape[0], dim), 0.0, opts.tol, 0, 0, "trivial")
    # a non-finite impulse gives a NaN or infinite certificate, which the test below rejects
    residual, floor = certificate(W, b, mu, int(dim), pi)
    accepted = _accepted(residual, floor, opts, status, iters, steps, coulomb)
    return CertifiedImpulse(pi.reshape(mu.shape[0], dim), float(residual), float(accepted),
                            int(iters), int(steps), _STATUS.get(status, str(status)))


def _accepted(residual: float, floor: float, opts: InteriorOptions, status: int, iters: int,
              steps: int, coulomb: bool) -> float:
    """The largest certificate accepted for these data (``tol``, or 1e3 times the round-off
    floor capped at :data:`~convimpact.impact.conic.polish.VELOCITY_RESIDUAL_MAX`).

    Raises
    ------
    CertificateError
        when ``residual`` exceeds it (a NaN or infinite residual always does).
    """
    accepted = _acceptance(floor, opts)
    if not residual <= accepted:
        what = ("Coulomb's conditions" if coulomb else "the law's KKT certificate")
        hint = ("Newton on Coulomb's law did not reach a solution from the CCP answer; use "
                "method='clarabel' (its safeguarded fixed point)" if coulomb else
                "the program probably has no solution (no impulse in the friction cones "
                "satisfies the law, e.g. a rigid pinch through a singular Delassus matrix) or "
                "is badly conditioned; raise max_iter, or use method='clarabel'")
        raise CertificateError(
            f"method {METHOD!r}: the answer fails {what} (certificate: relative residual "
            f"{residual:.2e} > {accepted:.1e}; interior point {_STATUS.get(status, status)} "
            f"after {iters} iterations, {steps} Newton steps): {hint}")
    return accepted


#: regime names of the kernels' codes (:func:`~.law_programs.result_data`)
REGIMES = ("separating", "frictionless", "stick", "slide")
#: the laws' modes of :func:`~.law_programs.solve_law`
_MODES = {"ccp": 0, "dissipative": 1, "coulomb": 2}
#: regime names of the codes as :func:`~.law_programs.solve_law` returns them (floats)
_REGIME_OF = {float(code): name for code, name in enumerate(REGIMES)}


def _solve(P: ImpactProblem, opts: InteriorOptions, law: str) -> tuple:
    """The law's program on P in one compiled call, posed as
    :func:`convimpact.impact.laws.ccp.solve_ccp` (and
    :func:`convimpact.impact.laws.coulomb.solve_coulomb`) pose it: ``b = v- + e min(v_n-, 0) n``
    (not for the dissipative law's plastic phase), contacts that do not approach without
    friction of their own (unless ``coulomb``); certified as
    :func:`solve_cone_complementarity` certifies it.

    Returns
    -------
    (the kernel's impulse (n, d), the solver's report for the extras, the regimes of that
    impulse by the conic paths' rule, and as lists per contact its normal velocity lift
    ``v_n+ + e min(v_n-, 0)``, ``mu |v_t+|`` and ``v_n+``)

    Raises
    ------
    CertificateError
    """
    n, d = P.jacobians.shape[:2]
    K = kernels()
    W = np.ascontiguousarray(P.delassus, dtype=float)
    v = P.v_minus.reshape(-1)
    answer = None
    if n * d <= COMPILED_MAX_ROWS:
        answer = K.solve_law(W, v, P.restitution, P.friction, d, _MODES[law], HANDOVER_TOL,
                             int(opts.max_iter), int(opts.newton_iter), CERTIFIED_ACCURACY)
    if answer is None or not (answer[0] == K.TRIVIAL
                              or answer[3] <= _acceptance(answer[4], opts)):
        answer = _engine_law(K, W, v, P, d, law, opts)
    status, iters, steps, residual, floor, out = answer
    accepted = _acceptance(floor, opts)
    if status == K.TRIVIAL:  # b = 0: pi = 0 is the answer
        kkt, name = 0.0, "trivial"
    else:
        if not residual <= accepted:
            _accepted(residual, floor, opts, status, iters, steps, law == "coulomb")  # raises
        kkt, name = float(residual), _STATUS.get(status, str(status))
    report = solver_report(name, iters, steps, kkt, opts.tol)
    N = n * d
    per = out[N:].tolist()
    return (out[:N].reshape(n, d), report, [_REGIME_OF[c] for c in per[:n]],
            per[n:2 * n], per[2 * n:3 * n], per[3 * n:])


def _acceptance(floor: float, opts: InteriorOptions) -> float:
    """The largest certificate accepted: ``tol``, or 1e3 times the round-off floor capped at
    :data:`~convimpact.impact.conic.polish.VELOCITY_RESIDUAL_MAX`."""
    return max(opts.tol, min(1e3 * floor, VELOCITY_RESIDUAL_MAX))


def _engine_law(K, W, v, P: ImpactProblem, d: int, law: str, opts: InteriorOptions) -> tuple:
    """:func:`~.law_programs.solve_law`'s answer by the contact engine's vectorized backend: the
    law's data (:func:`~.law_programs.law_data`), the engine, the law's certificate and the
    result's per-contact data, as the compiled call forms them."""
    mode = _MODES[law]
    e, friction = P.restitution, P.friction
    b, mu = K.law_data(v, e, friction, d, mode != 1, mode == 2)
    if not np.any(b):
        pi = np.zeros_like(b)
        return K._law_answer(W, v, e, friction, d, CERTIFIED_ACCURACY, pi, K.TRIVIAL, 0, 0,
                             0.0, 0.0)
    R = engine_solve(W, b.reshape(-1, d), mu, d, coulomb=mode == 2, tol=ENGINE_TOL,
                     compiled=False, max_iter=int(opts.max_iter), newton_iter=int(opts.newton_iter))
    pi = np.ascontiguousarray(R.impulse.reshape(-1))
    certificate = K.coulomb_certificate if mode == 2 else K.ccp_certificate
    residual, floor = certificate(W, b, mu, d, pi)
    return K._law_answer(W, v, e, friction, d, CERTIFIED_ACCURACY, pi,
                         0 if R.converged else 1, int(R.iterations), 0, residual, floor)


def solver_report(interior_status: str, iterations: int, newton_steps: int, kkt: float,
                  tol: float) -> dict:
    """The solver's part of a certified answer's extras."""
    return {"solver_status": "certified", "interior_status": interior_status,
            "iterations": iterations, "newton_steps": newton_steps, "tolerance": tol,
            "polished": True, "kkt_residual": kkt}


def law_extras(law: str, report: dict, lift=None, mu_slip=None, plastic=None,
               plastic_energy_loss=None, predicted=None, plastic_lift=None) -> dict:
    """A certified answer's extras for ``law`` (``report``: :func:`solver_report`): for
    ``ccp`` the normal-velocity lift and ``mu |v_t+|`` per contact; for ``coulomb`` how it was
    finished and its residual; for ``dissipative`` the plastic phase (impulse, energy loss,
    the predicted loss after Poisson's scaling, its normal-velocity lift)."""
    if law == "ccp":
        return {"normal_velocity_lift": lift, "mu_times_slip": mu_slip, **report}
    if law == "coulomb":
        return {"finished_by": "Newton on Coulomb's natural map from the CCP answer",
                "complementarity_residual": report["kkt_residual"],
                "accuracy": CERTIFIED_ACCURACY, **report}
    return {"plastic_impulse": plastic, "plastic_energy_loss": plastic_energy_loss,
            "predicted_energy_loss": predicted, "plastic_normal_velocity_lift": plastic_lift,
            **report}


def ccp_result(P: ImpactProblem, **options) -> ImpactResult:
    """Law ``ccp`` by the interior point with its KKT certificate (the same result as the
    conic path's :func:`convimpact.impact.laws.ccp.program_result`)."""
    return _result(P, "ccp", options)


def dissipative_result(P: ImpactProblem, **options) -> ImpactResult:
    """Law ``dissipative`` by the interior point with its KKT certificate (the same result as
    the conic path's :func:`convimpact.impact.laws.dissipative.program_result`)."""
    return _result(P, "dissipative", options)


def coulomb_result(P: ImpactProblem, **options) -> ImpactResult:
    """Law ``coulomb`` by Newton on its natural map from the CCP answer, accepted on Coulomb's
    conditions (:func:`~convimpact.impact.laws.coulomb.coulomb_residual`, compiled). Where the
    law has several solutions (several contacts, a singular W) the one Newton reaches from the
    CCP answer is returned -- possibly another than the conic path's fixed point's, which is
    why ``method="auto"`` keeps the conic path for this law."""
    return _result(P, "coulomb", options)


def _result(P: ImpactProblem, law: str, options: dict) -> ImpactResult:
    """The certified answer of ``law`` (the dissipative law's: Poisson-scaled) as a result."""
    pi, report, regimes, lift, mu_slip, vn_plus = _solve(P, parse_options(options), law)
    warnings = ()
    if law == "dissipative":
        plastic, (pi, plastic_loss, predicted) = pi, poisson_scaled(P, pi)
        extras = law_extras(law, report, plastic=plastic.tolist(),
                            plastic_energy_loss=plastic_loss, predicted=predicted,
                            plastic_lift=vn_plus)
        warnings = poisson_warnings(P, predicted)
    else:
        extras = law_extras(law, report, lift=lift, mu_slip=mu_slip)
    return assemble_result(P, pi, regimes, law, METHOD, tol=CERTIFIED_ACCURACY, extras=extras,
                           warnings=warnings)
