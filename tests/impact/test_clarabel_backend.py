"""Clarabel's own API path: hand-built CSC data, updates, tolerances, status errors, and
agreement with the cvxpy path on random systems (two independent compilations of one program).
"""

import numpy as np
import pytest
from hypothesis import given, settings

import convimpact as ci
from convimpact.impact.conic import clarabel_backend as cd
from convimpact.impact.conic.qp import ConeQP, solve_cone_qp

from .convex_systems import ccp_residual, coulomb_conditions, delassus, newton_b, random_system, \
    systems

LAWS = ("ccp", "dissipative", "coulomb", "pereira-nikravesh")


def _solve_both(M, Jc, dq, e, mu, C, law):
    out = {}
    for method in ("clarabel", "cvxpy"):
        try:
            out[method] = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, C=C, law=law, method=method)
        except ci.ConvImpactError as exc:
            out[method] = exc
    return out


@settings(max_examples=20, deadline=None)
@given(systems)
def test_clarabel_and_cvxpy_agree(s):
    """Post-impact velocities agree (unique even when W is singular and impulses are not)."""
    M, Jc, dq, C = random_system(s["seed"], s["d"], s["n_contacts"], s["loops"])
    for law in LAWS:
        if law == "coulomb" and s["n_contacts"] > 1:
            continue  # several contacts: Coulomb solutions need not be unique (see below)
        out = _solve_both(M, Jc, dq, s["e"], s["mu"], C, law)
        a, b = out["clarabel"], out["cvxpy"]
        if isinstance(a, Exception) or isinstance(b, Exception):
            assert type(a) is type(b), (law, a, b)
            continue
        scale = np.abs(dq).max() + np.abs(a.dq_plus).max()
        assert np.allclose(a.dq_plus, b.dq_plus, rtol=0, atol=1e-7 * scale), law
        assert a.regime == b.regime or law == "pereira-nikravesh", law


@settings(max_examples=20, deadline=None)
@given(systems)
def test_several_contacts_coulomb_both_paths_solve_the_law(s):
    """With several contacts both paths return an impulse meeting Coulomb's conditions (to the
    stated accuracy), checked with the residual written out in the test helper."""
    M, Jc, dq, C = random_system(s["seed"], s["d"], max(s["n_contacts"], 2), s["loops"])
    n = len(Jc)
    e, mu = np.full(n, s["e"]), np.full(n, s["mu"])
    W = delassus(M, Jc, C)
    b = newton_b(np.concatenate([j @ dq for j in Jc]), e)
    for method in ("clarabel", "cvxpy"):
        try:
            r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, C=C, law="coulomb", method=method)
        except ci.SolverError as exc:  # allowed: a typed failure, never a wrong answer
            assert "did not converge" in str(exc) or "status" in str(exc)
            continue
        acc = r.diagnostics.extras["accuracy"]
        assert coulomb_conditions(W, b, mu, s["d"], r.impulse) < 10 * max(acc, 1e-9)


def test_csc_arrays_match_dense_standard_form():
    """The hand-written CSC of A and P equals the dense standard form written from its
    definition: rows E, then frictionless tangents (x_t + s = 0), frictionless normals
    (-x_n + s = 0), then per frictional contact (-mu x_n, -x_t)."""
    import scipy.sparse as sp

    n, d, m = 3, 3, 2
    frictionless = (False, True, False)
    built = cd._Built((n, d, frictionless, m), 1e-9, 100)
    rng = np.random.default_rng(1)
    E = rng.normal(size=(m, n * d))
    mu = np.array([0.3, 0.0, 0.7])
    A = sp.csc_matrix((built.A_data(E, mu), built.A_indices, built.A_indptr),
                      shape=(built.n_rows, n * d)).toarray()
    dense = np.zeros((m + 2 + 1 + 6, 9))
    dense[:m] = E
    dense[m + 0, 4] = dense[m + 1, 5] = 1.0      # contact 1 tangents (zero cone)
    dense[m + 2, 3] = -1.0                       # contact 1 normal (nonnegative cone)
    dense[m + 3, 0], dense[m + 4, 1], dense[m + 5, 2] = -0.3, -1.0, -1.0  # SOC of contact 0
    dense[m + 6, 6], dense[m + 7, 7], dense[m + 8, 8] = -0.7, -1.0, -1.0  # SOC of contact 2
    assert np.array_equal(A, dense)
    W = rng.normal(size=(9, 9))
    W = W + W.T
    P = sp.csc_matrix((built.P_data(W), built.P_rows, built.P_indptr), shape=(9, 9)).toarray()
    assert np.array_equal(P, np.triu(W))


def test_solver_built_once_and_updated():
    backend = cd.ClarabelBackend()
    rng = np.random.default_rng(2)
    answers = []
    for _ in range(4):
        A = rng.normal(size=(3, 3))
        W = A @ A.T + np.eye(3)
        v = rng.normal(size=3)
        v[0] = -1.0
        qp = ConeQP(W, v, np.array([0.4]), 3, np.zeros((0, 3)), np.zeros(0))
        x = solve_cone_qp(backend, qp).x
        answers.append(x)
        assert ccp_residual(W, v, [0.4], 3, x) < 1e-10  # each update solved its own data
    assert len(backend._built) == 1
    assert not np.allclose(answers[0], answers[1])


def test_default_and_tightened_tolerances_unpolished():
    """Stated accuracy of the raw interior-point answer on a sliding contact: about 1e-5
    relative at Clarabel's default tolerance 1e-8 and about 1e-6 at 1e-10 (impulse error
    ~ sqrt(tol) on the cone boundary); the KKT polish then brings it to round-off."""
    rng = np.random.default_rng(7)
    A = rng.normal(size=(3, 3))
    W = A @ A.T + 0.3 * np.eye(3)
    v = np.array([-1.0, 2.0, -0.7])
    qp = ConeQP(W, v, np.array([0.3]), 3, np.zeros((0, 3)), np.zeros(0))
    exact = solve_cone_qp(cd.ClarabelBackend(), qp, tol=1e-10).x
    assert ccp_residual(W, v, [0.3], 3, exact) < 1e-13
    err = {}
    for tol in (1e-8, 1e-10):
        raw = solve_cone_qp(cd.ClarabelBackend(), qp, tol=tol, polish=False).x
        err[tol] = np.abs(raw - exact).max() / np.abs(exact).max()
    assert err[1e-8] < 1e-4
    assert err[1e-10] < 1e-5


def test_iteration_limit_raises_with_status():
    M, Jc, dq, C = random_system(4, 3, 2, 0)
    with pytest.raises(ci.SolverError, match="MaxIterations"):
        ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.4, law="ccp", method="clarabel", max_iter=1)


def test_unbounded_program_raises():
    """A rigid pinch: one particle (mass 1, on a line) between two opposite frictionless
    contacts, the first approaching (v_n = -1), the second separating (v_n = +1). The direction
    pi = (1, 1) moves nothing (W (1,1) = 0) and lowers 1/2 pi.W.pi + pi.b by
    b_1 + b_2 = -(1+e) + 1 = -e < 0: the CCP program is unbounded for e > 0."""
    M = np.eye(1)
    Jc = [np.array([[1.0], [0.0]]), np.array([[-1.0], [0.0]])]
    dq = np.array([-1.0])
    for method in ("clarabel", "cvxpy"):
        with pytest.raises(ci.SolverError, match="unbounded|[Ii]nfeasible"):
            ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.0, law="ccp", method=method)
    # with e = 0 the program is bounded: plastic, the particle stops
    r = ci.resolve_impact(M, Jc, dq, e=0.0, mu=0.0, law="ccp", method="clarabel")
    assert r.dq_plus[0] == pytest.approx(0.0, abs=1e-10)
