"""The plastic maximal-dissipation impact scaled by Poisson's hypothesis.

The plastic impulse ``pi_p`` minimizes T+ over the friction cones (the CCP program with e = 0),
and the impulse is ``pi = (1 + e_i) pi_p`` per contact (Poisson). With one common e the energy
loss is exactly ``1/2 (1 - e^2) pi_p^T W pi_p >= 0`` (complementarity gives
``pi_p^T v+_p = 0``). With *different* e per contact the loss is
``1/2 |pi_p|_W^2 - 1/2 |E pi_p|_W^2`` (E = diag(e)), which can be negative when contacts couple;
the diagnostics then flag the energy gain. The result's ``regime`` describes the plastic
phase; the plastic impulse is reported in ``extras["plastic_impulse"]``.

Both the exact kernel (``method="fast"``) and the conic path reuse the CCP law's solvers
(:mod:`convimpact.impact.laws.ccp`) with e = 0.
"""

from __future__ import annotations

import numpy as np

from ..conic.paths import ProgramOptions, register_programs, regimes_from_slip, solver_report
from ..conic.qp import Backend
from ..diagnostics import assemble_result
from ..fast import ContactSolution, frictionless, register_kernel, solution
from ..problem import ImpactProblem
from ..results import ImpactResult
from .ccp import ccp_impulse, solve_ccp

LAW = "dissipative"


def contact_kernel(w: list, v: list, d: int, e: float, mu: float) -> ContactSolution:
    """The dissipative law for one contact on plain floats (the ``fast`` kernel)."""
    plastic = frictionless(w, v, d, 0.0) if mu == 0.0 else ccp_impulse(w, v, d, 0.0, mu, LAW)
    impulse = tuple(float(x) for x in plastic.impulse)
    k = 1.0 + e  # Poisson's hypothesis on the plastic impulse
    return solution([k * x for x in impulse], plastic.regime,
                    extras={"plastic_impulse": impulse})


def program_result(P: ImpactProblem, backend: Backend, method: str,
                   opts: ProgramOptions) -> ImpactResult:
    plastic, sol = solve_ccp(P, backend, opts, restitution=np.zeros(P.n_contacts))
    pi = plastic * (1.0 + P.restitution)[:, None]  # Poisson's hypothesis
    flat = plastic.ravel()
    W = P.delassus
    Ep = (plastic * P.restitution[:, None]).ravel()
    predicted = 0.5 * float(flat @ W @ flat) - 0.5 * float(Ep @ W @ Ep)
    vplus_plastic = P.v_minus + (W @ flat).reshape(P.n_contacts, P.dim)
    extras = {
        "plastic_impulse": plastic.tolist(),
        "plastic_energy_loss": 0.5 * float(flat @ W @ flat),
        "predicted_energy_loss": predicted,  # 1/2 (1 - e^2) pi_p^T W pi_p for a common e
        "plastic_normal_velocity_lift": vplus_plastic[:, 0].tolist(),
        **solver_report(sol, opts),
    }
    acc = opts.accuracy(sol.polished)
    warnings = poisson_warnings(P, W, predicted)
    regimes = regimes_from_slip(P, plastic, vplus_plastic, acc)
    return assemble_result(P, pi, regimes, LAW, method, tol=acc,
                           extras=extras, warnings=tuple(warnings))


register_kernel(LAW, contact_kernel)
register_programs(LAW, program_result)


def poisson_warnings(P, W: np.ndarray, predicted: float) -> list[str]:
    """The statements of Poisson's scaling with different e per coupled contact: an energy gain
    (``predicted`` energy loss < 0), and a plastic impulse that is not unique (singular W)."""
    warnings = []
    if np.ptp(P.restitution) > 0 and predicted < 0:
        warnings.append("different e per contact: Poisson scaling of coupled contacts gains "
                        "energy here (1/2 |pi_p|_W^2 < 1/2 |E pi_p|_W^2)")
    if np.ptp(P.restitution) > 0:
        lam = np.linalg.eigvalsh(W)
        if not lam[0] > 1e-10 * lam[-1]:
            warnings.append(
                "different e per contact on a singular Delassus matrix: the plastic impulse is "
                "not unique, so the Poisson-scaled answer (theta_dot+) depends on which plastic "
                "impulse the solver found; use one e for coupled contacts")
    return warnings
