"""Pinocchio as an outside peer on the benchmark's problems (optional: PyPI package ``pin``).

* ``impulseDynamics`` (frictionless): the overload ``impulseDynamics(model, data, v_before, J,
  r, damping)`` solves ``[M J^T; J 0]`` with ``J v+ = -r J v-`` after ``crba``; it reads the mass
  matrix from ``data.M``, so a chain of ``k`` revolute joints carries any SPD ``M`` of the
  benchmark. ``J`` stacks the contact normals and, for closed loops, the rows of C
  (``C v- = 0``, so those rows stay closed). It treats every contact as bilateral: with
  several contacts it disagrees with the unilateral reference wherever one would separate.
* ``ADMMConstraintSolver`` and ``PGSConstraintSolver`` on the Delassus matrix ``W`` of our
  reduction (``DelassusOperatorDense``), one ``PointContactConstraintModel`` per contact with
  its friction coefficient, velocities reordered to Pinocchio's ``(t1, t2, n)`` and the drift
  ``g = v- + e v_n- n`` (Newton's restitution shift). Measured on this version: ADMM with
  ``solve_ncp=False`` returns the CCP impulse and with ``solve_ncp=True`` the Coulomb (NCP)
  one; PGS returns the Coulomb impulse whatever ``solve_ncp`` says, so it is compared with the
  ``coulomb`` law. Planar problems are embedded in space with a decoupled unit ``t2`` row and
  zero ``t2`` drift (the solution then has ``pi_t2 = 0``).

Every failure to build or run a peer is returned as a reason string, never faked.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..impact.problem.build import ImpactProblem

#: (label, law, solver kind, solve_ncp)
CONTACT_PEERS = (
    ("pinocchio ADMM ccp", "ccp", "admm", False),
    ("pinocchio ADMM ncp", "coulomb", "admm", True),
    ("pinocchio PGS", "coulomb", "pgs", True),
)


def pinocchio_version() -> str | None:
    try:
        import pinocchio as pin
    except ImportError:
        return None
    return str(pin.__version__)


def _chain_model(pin, k: int):
    model = pin.Model()
    parent = 0
    for i in range(k):
        parent = model.addJoint(parent, pin.JointModelRX(), pin.SE3.Identity(), f"j{i}")
        model.appendBodyToJoint(parent, pin.Inertia.Identity(), pin.SE3.Identity())
    return model


def impulse_dynamics_call(problem: ImpactProblem) -> Callable[[], tuple[np.ndarray, np.ndarray]]:
    """A no-argument call of ``pinocchio.impulseDynamics`` on the frictionless ``problem``.

    Returns a function giving ``(impulse (n_contacts, d), dq_plus)``.
    """
    import pinocchio as pin

    k, n, d = problem.n_coordinates, problem.n_contacts, problem.dim
    model = _chain_model(pin, k)
    data = model.createData()
    M = np.asfortranarray(problem.mass_matrix)
    rows = [problem.jacobians[i, 0] for i in range(n)]
    J = np.vstack(rows + ([problem.loop_jacobian] if problem.n_loops else []))
    J = np.asfortranarray(J)
    dq = problem.dq_minus.copy()
    e = float(problem.restitution[0])
    if np.any(problem.restitution != e):
        raise ValueError("impulseDynamics takes one restitution coefficient for all rows")

    def call():
        data.M = M  # impulseDynamics' second overload reads M from data (crba "already called")
        dq_plus = np.array(pin.impulseDynamics(model, data, dq, J, e, 0.0))
        pi = np.zeros((n, d))
        pi[:, 0] = np.asarray(data.impulse_c)[:n]
        return pi, dq_plus

    return call


def embed_contact_problem(W: np.ndarray, b: np.ndarray, dim: int
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(W3, g, idx)``: the dense ``W`` (n d x n d, contacts normal first) and the drift
    ``b`` (n d,) in Pinocchio's (t1, t2, n) order, 3 rows per contact; a planar problem
    (d = 2) gets a decoupled ``t2`` row with the mean diagonal of ``W`` and zero drift.
    ``idx[j]`` is Pinocchio's index of our row ``j``."""
    W = np.asarray(W, dtype=float)
    n, d = W.shape[0] // dim, dim
    W3 = np.zeros((3 * n, 3 * n))
    g = np.zeros(3 * n)
    # our index of (contact i, component c) -> Pinocchio's index
    ours = [(i, c) for i in range(n) for c in range(d)]
    pin_index = {}
    for i in range(n):
        pin_index[(i, 0)] = 3 * i + 2  # normal last
        pin_index[(i, 1)] = 3 * i
        if d == 3:
            pin_index[(i, 2)] = 3 * i + 1
        else:
            W3[3 * i + 1, 3 * i + 1] = float(np.trace(W)) / W.shape[0]  # decoupled t2
    idx = np.array([pin_index[oc] for oc in ours])
    W3[np.ix_(idx, idx)] = W
    g[idx] = np.asarray(b, dtype=float).ravel()
    return W3, g, idx


class _Embedded:
    """W and the restitution-shifted drift in Pinocchio's (t1, t2, n) order, 3 per contact."""

    def __init__(self, problem: ImpactProblem):
        n, d = problem.n_contacts, problem.dim
        v = problem.v_minus
        b = v.copy()
        b[:, 0] += problem.restitution * np.minimum(v[:, 0], 0.0)
        self.W, self.g, self.idx = embed_contact_problem(problem.delassus, b, d)
        self.n, self.d = n, d

    def back(self, lam: np.ndarray) -> np.ndarray:
        return np.asarray(lam)[self.idx].reshape(self.n, self.d)


def contact_solver_call(problem: ImpactProblem, kind: str, solve_ncp: bool, tol: float,
                        max_iterations: int = 10000) -> Callable[[], np.ndarray]:
    """A no-argument call of Pinocchio's ADMM or PGS contact solver on ``problem``'s W.

    Returns a function giving the contact impulse (n_contacts, d); raises RuntimeError when
    the solver reports no convergence.
    """
    emb = _Embedded(problem)
    return embedded_solver_call(emb.W, emb.g, problem.friction, emb.back, kind, solve_ncp, tol,
                                max_iterations)


def embedded_solver_call(W3: np.ndarray, g: np.ndarray, mu: np.ndarray,
                         back: Callable[[np.ndarray], np.ndarray], kind: str, solve_ncp: bool,
                         tol: float, max_iterations: int = 10000,
                         delassus: Any = None) -> Callable[[], np.ndarray]:
    """A no-argument call of Pinocchio's ADMM or PGS solver on the embedded problem
    (``W3``, ``g`` in (t1, t2, n) order, friction ``mu`` per contact); ``back`` maps
    Pinocchio's impulses to ours; ``delassus`` (optional) replaces
    ``DelassusOperatorDense(W3)``. Raises RuntimeError when the solver does not converge."""
    import pinocchio as pin

    n = len(g) // 3
    model = pin.Model()
    jid = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
    model.appendBodyToJoint(jid, pin.Inertia.Identity(), pin.SE3.Identity())
    models = pin.StdVec_ConstraintModel()
    for i in range(n):
        cm = pin.PointContactConstraintModel(model, jid)
        cm.setFriction(float(mu[i]))
        models.append(pin.ConstraintModel(cm))
    datas = pin.StdVec_ConstraintData()
    for cm in models:
        datas.append(cm.createData())
    if delassus is None:
        delassus = pin.DelassusOperatorDense(np.asfortranarray(W3))
    if kind == "admm":
        solver, settings, Result = (pin.ADMMConstraintSolver(3 * n), pin.ADMMSolverSettings(),
                                    pin.ADMMSolverResult)
    elif kind == "pgs":
        solver, settings, Result = (pin.PGSConstraintSolver(3 * n), pin.PGSSolverSettings(),
                                    pin.PGSSolverResult)
    else:
        raise ValueError(f"unknown Pinocchio contact solver {kind!r}")
    settings.solve_ncp = bool(solve_ncp)
    settings.max_iterations = int(max_iterations)
    for name in ("absolute_feasibility_tol", "relative_feasibility_tol",
                 "absolute_complementarity_tol", "relative_complementarity_tol"):
        setattr(settings, name, float(tol))
    g = g.copy()

    def call():
        result = Result()
        ok = solver.solve(delassus, g, models, datas, settings, result)
        if not ok:
            raise RuntimeError(f"Pinocchio {kind.upper()} did not converge in "
                               f"{max_iterations} iterations at tolerance {tol:g}")
        return back(np.array(result.retrieveConstraintImpulses()))

    return call


def peer_facts() -> dict[str, Any]:
    """What the peers are, for bench.json."""
    return {
        "pinocchio": pinocchio_version(),
        "impulseDynamics": "frictionless, bilateral normals (+ loop rows), M via data.M",
        "contact_solvers": {label: {"law": law, "solver": kind, "solve_ncp": ncp}
                            for label, law, kind, ncp in CONTACT_PEERS},
        "note": ("PGS returned the Coulomb (NCP) impulse with solve_ncp False or True in our "
                 "checks, so it is compared with law 'coulomb'"),
    }
