"""The plastic maximal-dissipation impact scaled by Poisson's hypothesis.

The plastic impulse ``pi_p`` minimizes T+ over the friction cones (the CCP program with e = 0),
and the impulse is ``pi = (1 + e_i) pi_p`` per contact (Poisson). With one common e the energy
loss is exactly ``1/2 (1 - e^2) pi_p^T W pi_p >= 0`` (complementarity gives
``pi_p^T v+_p = 0``). With *different* e per contact the loss is
``1/2 |pi_p|_W^2 - 1/2 |E pi_p|_W^2`` (E = diag(e)), which can be negative when contacts couple;
the diagnostics then flag the energy gain. The result's ``regime`` describes the plastic
phase; the plastic impulse is reported in ``extras["plastic_impulse"]``.

Both the exact kernel (``method="fast"``) and the conic path reuse the CCP law's solvers
(:mod:`convimpact.impact.laws.ccp`) with e = 0: :func:`_dissipative_planar` and
:func:`_dissipative_spatial` (compiled; the batch and the compiled lane run them too) call the
CCP kernels, or take the frictionless plastic impulse ``-v_n / W_nn`` when mu = 0, and scale by
1 + e. Their scratch ``out`` holds the plastic impulse (``out[0:d]``, exactly the one scaled:
``impulse / (1 + e)`` may differ from it in the last bit), reported as
``extras["plastic_impulse"]``.
"""

from __future__ import annotations

import numpy as np

from .codes import FRICTIONLESS, OK, _NAN, _jit
from ..conic.paths import ProgramOptions, regimes_from_slip, solver_report
from ..conic.qp import Backend
from ..diagnostics import assemble_result
from ..exact.dispatch import compiled_kernel
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from .ccp import NO_SOLUTION_MESSAGES, _ccp_planar, _ccp_spatial, solve_ccp
from .cone_derivative import dissipative_one as impulse_derivative  # noqa: F401
from .cone_derivative import dissipative_several as several_impulse_derivative  # noqa: F401

LAW = "dissipative"
#: ``out`` of the kernels: the plastic impulse (pi_n, pi_t1[, pi_t2]) at [0, 1, 2]
_OUT_PLASTIC = 0


@_jit
def _dissipative_planar(w00, w01, w11, v0, v1, e, mu, out):
    """One planar contact: the plastic impulse (frictionless if mu = 0, else CCP's with e = 0)
    times 1 + e; the plastic impulse into ``out``."""
    if mu == 0.0:
        st, rg, p0, p1, p2, em = OK, FRICTIONLESS, -(1.0 + 0.0) * v0 / w00, 0.0, 0.0, _NAN
    else:
        st, rg, p0, p1, p2, em = _ccp_planar(w00, w01, w11, v0, v1, 0.0, mu, out)
    if st != OK:
        return st, rg, p0, p1, p2, em
    out[_OUT_PLASTIC] = p0
    out[_OUT_PLASTIC + 1] = p1
    k = 1.0 + e  # Poisson's hypothesis on the plastic impulse
    return OK, rg, k * p0, k * p1, k * p2, _NAN


@_jit
def _dissipative_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out):
    """One spatial contact (as :func:`_dissipative_planar`)."""
    if mu == 0.0:
        st, rg, p0, p1, p2, em = OK, FRICTIONLESS, -(1.0 + 0.0) * v0 / w00, 0.0, 0.0, _NAN
    else:
        st, rg, p0, p1, p2, em = _ccp_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2,
                                              0.0, mu, out)
    if st != OK:
        return st, rg, p0, p1, p2, em
    out[_OUT_PLASTIC] = p0
    out[_OUT_PLASTIC + 1] = p1
    out[_OUT_PLASTIC + 2] = p2
    k = 1.0 + e
    return OK, rg, k * p0, k * p1, k * p2, _NAN


def _extras(out, regime, impulse, w, v, d, e, mu) -> tuple:
    """The plastic impulse the answer scaled (one contact has one e: Poisson's scaling gains no
    energy, so no warnings)."""
    return {"plastic_impulse": tuple(float(x) for x in out[_OUT_PLASTIC:_OUT_PLASTIC + d])}, ()


# mu = 0 inside: the frictionless plastic impulse times 1 + e, as the other paths compute it
contact_kernel = compiled_kernel(LAW, _dissipative_planar, _dissipative_spatial, _extras,
                                 frictionless_inside=True, no_solution=NO_SOLUTION_MESSAGES)


def program_result(P: ImpactProblem, backend: Backend, method: str,
                   opts: ProgramOptions) -> ImpactResult:
    plastic, sol = solve_ccp(P, backend, opts, restitution=np.zeros(P.n_contacts))
    pi, plastic_loss, predicted = poisson_scaled(P, plastic)
    vplus_plastic = P.v_minus + (P.delassus @ plastic.ravel()).reshape(P.n_contacts, P.dim)
    extras = {
        "plastic_impulse": plastic.tolist(),
        "plastic_energy_loss": plastic_loss,
        "predicted_energy_loss": predicted,  # 1/2 (1 - e^2) pi_p^T W pi_p for a common e
        "plastic_normal_velocity_lift": vplus_plastic[:, 0].tolist(),
        **solver_report(sol, opts),
    }
    acc = opts.accuracy(sol.polished)
    regimes = regimes_from_slip(P, plastic, vplus_plastic, acc)
    return assemble_result(P, pi, regimes, LAW, method, tol=acc,
                           extras=extras, warnings=poisson_warnings(P, predicted))


def poisson_scaled(P: ImpactProblem, plastic: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Poisson's hypothesis on the plastic impulse ``pi_p`` (n_contacts, d): the impulse
    ``(1 + e_i) pi_p`` per contact, the plastic phase's energy loss ``1/2 |pi_p|_W^2`` and the
    loss predicted after the scaling, ``1/2 |pi_p|_W^2 - 1/2 |E pi_p|_W^2``."""
    flat = plastic.ravel()
    W = P.delassus
    Ep = (plastic * P.restitution[:, None]).ravel()
    plastic_loss = 0.5 * float(flat @ W @ flat)
    return (plastic * (1.0 + P.restitution)[:, None], plastic_loss,
            plastic_loss - 0.5 * float(Ep @ W @ Ep))


def poisson_warnings(P: ImpactProblem, predicted: float) -> tuple[str, ...]:
    """The statements of Poisson's scaling with different e per coupled contact: an energy gain
    (``predicted`` energy loss < 0), and a plastic impulse that is not unique (singular W)."""
    if not np.ptp(P.restitution) > 0:
        return ()
    warnings = []
    if predicted < 0:
        warnings.append("different e per contact: Poisson scaling of coupled contacts gains "
                        "energy here (1/2 |pi_p|_W^2 < 1/2 |E pi_p|_W^2)")
    lam = np.linalg.eigvalsh(P.delassus)
    if not lam[0] > 1e-10 * lam[-1]:
        warnings.append(
            "different e per contact on a singular Delassus matrix: the plastic impulse is "
            "not unique, so the Poisson-scaled answer (theta_dot+) depends on which plastic "
            "impulse the solver found; use one e for coupled contacts")
    return tuple(warnings)
