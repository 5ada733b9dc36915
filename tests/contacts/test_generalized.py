"""The contact problem in generalized coordinates (convimpact.contacts.generalized and the
``mass_matrix=``/``jacobian=`` entry of solve_contact_problem).

Oracles, none of them the code under test: the closed form of one sliding planar contact
(derived by hand below), ``J M^-1 J^T`` and the linear solves formed densely here with numpy,
the Levenberg-Marquardt step from its dense normal equations, the natural-map residual
recomputed with this file's own projection, and the answer of the same problem on W alone
(the engine's other path: a second method, ADMM and Newton on W's own factorizations).
"""

import numpy as np
import pytest
import scipy.sparse as sp

import convimpact as ci
from convimpact.bench.contact_corpus import corpus
from convimpact.contacts import engine
from convimpact.contacts.generalized import GeneralizedFactor, WoodburySolver
from convimpact.contacts import lowrank_sparse
from convimpact.contacts.lowrank_sparse import SparseLowRankStep, sparse_lowrank_step
from convimpact.errors import MassMatrixError, NonFiniteError, ParameterError, ShapeError

from .cone_checks import project_cone
from .cone_checks import coulomb_residual


def _random_generalized(rng, bodies=4, contacts=7, d=3):
    """Block-diagonal M (one 6x6 SPD block per body) and a sparse J touching two bodies per
    contact."""
    blocks = []
    for _ in range(bodies):
        A = rng.standard_normal((6, 6))
        blocks.append(A @ A.T + 6.0 * np.eye(6))
    M = sp.block_diag(blocks, format="csr")
    J = np.zeros((contacts * d, 6 * bodies))
    for c in range(contacts):
        i, j = rng.choice(bodies, 2, replace=False)
        J[c * d:(c + 1) * d, 6 * i:6 * i + 6] = rng.standard_normal((d, 6))
        J[c * d:(c + 1) * d, 6 * j:6 * j + 6] = rng.standard_normal((d, 6))
    return M, sp.csr_matrix(J)


def test_factor_gives_the_delassus_matrix():
    rng = np.random.default_rng(1)
    M, J = _random_generalized(rng)
    W = J.toarray() @ np.linalg.solve(M.toarray(), J.toarray().T)
    f = GeneralizedFactor(M, J)
    assert sp.issparse(f.G)
    assert np.abs(f.G @ f.G.T - W).max() <= 1e-12 * np.abs(W).max()
    assert np.abs(f.delassus().toarray() - W).max() <= 1e-12 * np.abs(W).max()
    x = rng.standard_normal(W.shape[0])
    assert np.allclose(f.times(x), W @ x, rtol=0, atol=1e-12 * np.abs(W).max() * 10)


def test_factor_of_mixed_blocks_in_shuffled_coordinates():
    # blocks of 1, 3, 3 and 5 coordinates, the coordinates shuffled: G G^T = J M^-1 J^T
    rng = np.random.default_rng(4)
    blocks = []
    for k in (1, 3, 3, 5):
        A = rng.standard_normal((k, k))
        blocks.append(A @ A.T + k * np.eye(k))
    Md = sp.block_diag(blocks).toarray()
    p = rng.permutation(Md.shape[0])
    Md = Md[p][:, p]
    J = rng.standard_normal((9, Md.shape[0]))
    W = J @ np.linalg.solve(Md, J.T)
    G = GeneralizedFactor(sp.csr_matrix(Md), J).G
    assert np.abs((G @ G.T) - W).max() <= 1e-12 * np.abs(W).max()


def test_woodbury_solver_solves_the_shifted_system_for_each_shift():
    rng = np.random.default_rng(2)
    M, J = _random_generalized(rng, bodies=3, contacts=9)  # 27 rows, rank <= 18
    f = GeneralizedFactor(M, J)
    W = (f.G @ f.G.T).toarray()
    s = WoodburySolver(f.G)
    rhs = rng.standard_normal(W.shape[0])
    for c in (1.0, 1e-2, 3.0):  # refactored numerically on the same pattern
        s.factor(c)
        x = s.solve(rhs)
        assert np.abs((W + c * np.eye(W.shape[0])) @ x - rhs).max() <= 1e-9 * np.abs(rhs).max()


def test_sparse_step_is_the_levenberg_marquardt_step():
    rng = np.random.default_rng(3)
    n, d = 8, 3
    M, J = _random_generalized(rng, bodies=3, contacts=n, d=d)
    G = GeneralizedFactor(M, J).G
    A = rng.standard_normal((n, d, d))
    E = rng.standard_normal((n, d, d))
    F = rng.standard_normal(n * d)
    lam = 0.3
    Jn = sp.block_diag(list(A)).toarray() + sp.block_diag(list(E)).toarray() @ (G @ G.T)
    want = -np.linalg.solve(Jn.T @ Jn + lam * np.eye(n * d), Jn.T @ F)
    got = sparse_lowrank_step(A, E, G, lam, F)
    assert np.abs(got - want).max() <= 1e-8 * np.abs(want).max()


def _lm_step(A, E, G, lam, F):
    """The Levenberg-Marquardt step from the dense normal equations (an independent check)."""
    Jn = sp.block_diag(list(A)).toarray() + sp.block_diag(list(E)).toarray() @ (G @ G.T)
    return -np.linalg.solve(Jn.T @ Jn + lam * np.eye(Jn.shape[0]), Jn.T @ F)


def test_kept_sparse_step_is_the_levenberg_marquardt_step_at_every_step(monkeypatch):
    # one layout, several steps with other blocks and weights (contacts opening: E's block
    # zero; a weight down to 1e-8), each against the dense normal equations; then the same
    # with the LDL^T's refinement refused, so that SuperLU takes every step
    rng = np.random.default_rng(11)
    n, d = 10, 3
    M, J = _random_generalized(rng, bodies=4, contacts=n, d=d)
    G = GeneralizedFactor(M, J).G
    for refuse in (False, True):
        if refuse:
            monkeypatch.setattr(lowrank_sparse, "MAX_REFINEMENTS", -1)
        stepper = SparseLowRankStep(G, d)
        for k, lam in enumerate((0.3, 1e-3, 1e-8)):
            A = rng.standard_normal((n, d, d))
            E = rng.standard_normal((n, d, d))
            E[rng.permutation(n)[:k + 2]] = 0.0
            F = rng.standard_normal(n * d)
            want = _lm_step(A, E, G, lam, F)
            got = stepper.solve(A, E, lam, F)
            assert np.abs(got - want).max() <= 1e-7 * np.abs(want).max()
        assert (stepper.fallbacks == 3) if refuse else (stepper.fallbacks == 0)


def test_one_sliding_contact_closed_form_from_generalized_coordinates():
    # W = J M^-1 J^T = [[2, 1/2], [1/2, 1]] with M = diag(1, 4) and J = C diag(1, 2), C C^T =
    # W; b = (-1, 1/2), mu = 0.3: the contact slides (test_contact_admm's closed form),
    # r = (1, -0.3) / 1.85
    C = np.linalg.cholesky(np.array([[2.0, 0.5], [0.5, 1.0]]))
    M = np.diag([1.0, 4.0])
    J = C @ np.diag([1.0, 2.0])
    for W in (None, [[2.0, 0.5], [0.5, 1.0]]):
        s = ci.solve_contact_problem(W, [-1.0, 0.5], 0.3, mass_matrix=M, jacobian=J)
        assert np.abs(s.impulse - np.array([[1.0, -0.3]]) / 1.85).max() <= 1e-9
        assert np.abs(s.velocity[0, 0]) <= 1e-9


def ccp_residual(W, b, mu, r):
    """The CCP's natural-map residual (y = u), recomputed here."""
    n, d = r.shape
    u = (np.asarray(W) @ r.ravel() + np.ravel(b)).reshape(n, d)
    err = np.linalg.norm(r - project_cone(r - u, mu))
    return err / max(np.linalg.norm(b), np.linalg.norm(r), np.linalg.norm(u))


@pytest.fixture(scope="module")
def small_corpus():
    return {c.name: c for c in corpus(max_contacts=130)}


@pytest.mark.parametrize("coulomb", [True, False])
@pytest.mark.parametrize("name", ["box-wall-4x4-88", "sphere-pile-hex-126"])
def test_generalized_path_agrees_with_the_delassus_path(small_corpus, name, coulomb):
    case = small_corpus[name]
    n, d = case.n_contacts, case.dim
    b = case.b.reshape(n, d)
    answers = []
    residual = coulomb_residual if coulomb else ccp_residual
    for g in (None, GeneralizedFactor(case.M, case.J)):
        # the engine's sparse path (forced: sparse, no compiled dense kernels) on each: the
        # interior point, the ADMM and the Newton steps through G with g
        R = engine.solve(case.W, b, case.mu, d, coulomb=coulomb, sparse=True, compiled=False,
                         generalized=g)
        assert R.converged
        assert residual(case.W.toarray(), case.b, case.mu, R.impulse) <= 1e-8
        answers.append(R)
    # the velocities agree (the impulses need not: W is singular on walls and piles)
    scale = max(np.abs(case.b).max(), 1e-300)
    assert np.abs(answers[0].velocity - answers[1].velocity).max() <= 1e-6 * scale
    # the public entry on the generalized path, certified on W
    s = ci.solve_contact_problem(case.W, case.b, case.mu, dim=d, mass_matrix=case.M,
                                 jacobian=case.J, law="coulomb" if coulomb else "ccp")
    assert residual(case.W.toarray(), case.b, case.mu, s.impulse) <= 1e-8
    u = case.W @ s.impulse.ravel() + case.b
    assert np.abs(s.velocity.ravel() - u).max() <= 1e-10 * max(np.abs(u).max(), 1.0)
    assert project_cone(s.impulse, case.mu) == pytest.approx(s.impulse, abs=1e-9)


def test_bad_generalized_inputs_get_typed_errors():
    M = np.diag([1.0, 4.0])
    J = np.eye(2)
    W = J @ np.linalg.inv(M) @ J.T
    b, mu = [-1.0, 0.5], 0.3
    with pytest.raises(ParameterError):
        ci.solve_contact_problem(W, b, mu, mass_matrix=M)
    with pytest.raises(ParameterError):
        ci.solve_contact_problem(W, b, mu, jacobian=J)
    with pytest.raises(ShapeError):
        ci.solve_contact_problem(None, b, mu)
    with pytest.raises(MassMatrixError):
        ci.solve_contact_problem(None, b, mu, mass_matrix=np.diag([1.0, -1.0]), jacobian=J)
    with pytest.raises(MassMatrixError):
        ci.solve_contact_problem(None, b, mu, mass_matrix=[[1.0, 0.5], [0.0, 1.0]],
                                 jacobian=J)
    with pytest.raises(ShapeError):
        ci.solve_contact_problem(None, b, mu, mass_matrix=M, jacobian=np.eye(3))
    with pytest.raises(ShapeError):
        ci.solve_contact_problem(None, b, mu, mass_matrix=np.ones((2, 3)), jacobian=J)
    with pytest.raises(NonFiniteError):
        ci.solve_contact_problem(None, b, mu, mass_matrix=M, jacobian=[[np.nan, 0], [0, 1]])
    with pytest.raises(ShapeError):
        ci.solve_contact_problem(None, b, mu, mass_matrix=M, jacobian=[["1", 0], [0, 1]])
    with pytest.raises(ShapeError):  # W is not J M^-1 J^T
        ci.solve_contact_problem(2.0 * W, b, mu, mass_matrix=M, jacobian=J)
