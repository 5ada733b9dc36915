"""The chain rule from a law's contact-space derivative to the arguments of ``resolve_impact``.

A law's :class:`~convimpact.impact.derivatives.contact.ContactDerivative` gives ``d pi`` for
perturbations of its contact-space data ``(W, v_minus, e, mu[, e_t])``. With

    W = Jc G Jc^T,    v_minus = Jc dq,    dq_plus = dq + G Jc^T pi,

(``G = M^-1`` for open loops; for closed loops with C the loop-projected inverse
``G = Z (Z^T M Z)^-1 Z^T = M^-1 - M^-1 C^T (C M^-1 C^T)^-1 C M^-1``, Z a basis of ker C, so that
``dG = -G dM G`` in both cases) and ``H = Jc G`` (the flat, stacked Jacobian rows):

* ``dv = dJc dq + Jc ddq``,  ``dW = dJc H^T + H dJc^T - H dM H^T``;
* ``d dq_plus = ddq - G dM G Jc^T pi + G dJc^T pi + G Jc^T dpi``.

Conventions (stated in the user guide, ``docs/user_guide/derivatives.md``):

* ``"M"`` is the derivative with respect to *symmetric* perturbations, given as the symmetric
  gradient: ``d dq_plus = sum_ij jacobian["M"][..., i, j] dM_ij`` for every symmetric ``dM``;
  changing the pair ``M_ij = M_ji`` together by h (i != j) changes dq_plus by
  ``(jacobian["M"][..., i, j] + jacobian["M"][..., j, i]) h = 2 jacobian["M"][..., i, j] h``.
* ``"dq"`` is the derivative along every direction; with closed loops only the directions
  with ``C ddq = 0`` are admissible data.
* ``"e"``, ``"mu"`` (``"e_t"``) follow the argument's shape: a scalar applies to every
  contact, so its derivative is the sum over the contacts' columns.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping

import numpy as np

from ..problem.build import ImpactProblem
from .contact import ContactDerivative


def projected_inverse(problem: ImpactProblem) -> np.ndarray:
    """``G``: ``M^-1`` for open loops, the loop-projected inverse for closed ones (k x k)."""
    M = problem.mass_matrix
    L = problem.cholesky
    k = M.shape[0]
    Linv = np.linalg.solve(L, np.eye(k))
    G = Linv.T @ Linv
    if problem.n_loops:
        GC = G @ problem.loop_jacobian.T
        G = G - GC @ np.linalg.solve(problem.loop_matrix, GC.T)
    return 0.5 * (G + G.T)


def _read_only(arrays: dict) -> Mapping[str, np.ndarray]:
    for a in arrays.values():
        a.flags.writeable = False
    return MappingProxyType(arrays)


def impact_jacobians(problem: ImpactProblem, impulse: np.ndarray, cd: ContactDerivative,
                     scalar: Mapping[str, bool]) -> tuple[Mapping, Mapping]:
    """The derivatives of ``dq_plus`` and of the impulse with respect to ``dq``, ``M``, ``Jc``,
    ``e``, ``mu`` (and ``e_t`` when the law has it), by the chain rule of this module.

    Parameters
    ----------
    problem : the validated impact.
    impulse : the contact-frame impulse of the answer (any shape holding n x d values).
    cd : the law's derivative of its flat impulse in contact space.
    scalar : per argument name ("e", "mu", "e_t"), whether the caller gave one value for every
        contact (the derivative is then summed over the contacts).

    Returns
    -------
    (jacobian, impulse_jacobian) : read-only mappings of read-only arrays; shapes
        ``dq_plus.shape + argument shape`` and ``impulse.shape + argument shape``.
    """
    n, d, k = problem.jacobians.shape
    N = n * d
    J = problem.jacobian_rows
    dq = problem.dq_minus
    p = np.asarray(impulse, dtype=float).reshape(N)
    G = projected_inverse(problem)
    H = J @ G  # (N, k); G Jc^T = H^T
    Pw = np.asarray(cd.W, dtype=float).reshape(N, N, N)
    Pv = np.asarray(cd.v, dtype=float).reshape(N, N)
    # the impulse
    dp = {"dq": Pv @ J}
    m = -np.einsum("abc,bi,cj->aij", Pw, H, H)
    dp["M"] = 0.5 * (m + m.transpose(0, 2, 1))
    dp["Jc"] = (np.einsum("acd,dm->acm", Pw + Pw.transpose(0, 2, 1), H)
                + np.einsum("ac,m->acm", Pv, dq))
    params = {"e": cd.e, "mu": cd.mu}
    if cd.e_t is not None:
        params["e_t"] = cd.e_t
    for name, value in params.items():
        value = np.asarray(value, dtype=float).reshape(N, n)
        dp[name] = value.sum(axis=1) if scalar.get(name, False) else value
    # dq_plus = dq + G Jc^T pi
    y = H.T @ p
    dv = {"dq": np.eye(k) + H.T @ dp["dq"]}
    gm = np.einsum("ai,j->aij", G, y)
    dv["M"] = -0.5 * (gm + gm.transpose(0, 2, 1)) + np.einsum("ab,bij->aij", H.T, dp["M"])
    dv["Jc"] = np.einsum("am,c->acm", G, p) + np.einsum("ab,bcm->acm", H.T, dp["Jc"])
    for name in params:
        dv[name] = H.T @ dp[name]
    # shapes: the impulse as the result gives it, Jc as it was passed
    ishape = (d,) if problem.single else (n, d)
    jshape = (d, k) if problem.single else (n, d, k)
    out_q, out_p = {}, {}
    for name in dv:
        tail = dp[name].shape[1:]
        if name == "Jc":
            tail = jshape
        out_q[name] = np.ascontiguousarray(dv[name].reshape((k,) + tail))
        out_p[name] = np.ascontiguousarray(dp[name].reshape(ishape + tail))
    return _read_only(out_q), _read_only(out_p)


def zero_derivative(problem: ImpactProblem, regimes: tuple[str, ...],
                    tangential: bool) -> ContactDerivative:
    """The derivative of a zero impulse that stays zero (every contact separating)."""
    n, d = problem.n_contacts, problem.dim
    N = n * d
    return ContactDerivative(W=np.zeros((N, N, N)), v=np.zeros((N, N)), e=np.zeros((N, n)),
                             mu=np.zeros((N, n)),
                             e_t=np.zeros((N, n)) if tangential else None, regimes=regimes)
