"""The polish's compiled active-set Newton (:mod:`convimpact.impact.conic.polish_newton`),
checked against numbers derived here: closed forms of one contact, the KKT (natural-map)
residual and Coulomb's conditions written out in this file, and Clarabel's raw
interior-point answer (accurate to ~1e-6 on the cone boundary) on random programs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from convimpact.compiled import plain
from convimpact.impact.conic.paths import backend
from convimpact.impact.conic.polish import polish_cone_qp
from convimpact.impact.conic.polish_newton import (BND, DAMPED_MAX_NEWTON, INT,
                                                   POLISH_MAX_NEWTON, ZERO, active_set_jacobian,
                                                   active_set_newton)
from convimpact.impact.conic.program import ConeQP
from convimpact.impact.conic.qp import equilibrated

from .convex_systems import ccp_residual, coulomb_conditions


def natural_map(W, q, mu, d, x):
    """max_i |x_i - P_K(x_i - z_i)| / max(|x|, |q|) with z = W x + q (the cone QP's KKT)."""
    n = len(mu)
    X = np.ravel(x).reshape(n, d)
    Z = (W @ np.ravel(x) + q).reshape(n, d)
    worst = 0.0
    for i in range(n):
        y = X[i] - Z[i]
        yn, yt = y[0], y[1:]
        t = math.sqrt(float(yt @ yt))
        m = mu[i]
        if t <= m * yn:
            p = y
        elif m * t <= -yn:
            p = np.zeros(d)
        else:
            e = np.concatenate([[1.0], m * yt / t]) / math.sqrt(1.0 + m * m)
            p = (y @ e) * e
        worst = max(worst, float(np.max(np.abs(X[i] - p))))
    return worst / max(float(np.max(np.abs(x))), float(np.max(np.abs(q))), 1e-300)


#: the three ways the kernel is run: the polish's (SVD steps), the slide programs' of law
#: pereira-nikravesh (pivoted steps), and their damped Newton from far starts
MODES = {"polish": (POLISH_MAX_NEWTON, False, False), "pivoted": (POLISH_MAX_NEWTON, False, True),
         "damped": (DAMPED_MAX_NEWTON, True, True)}
MODE = MODES["polish"]


def _newton(*args, mode=None, python=False):
    fn = plain(active_set_newton) if python else active_set_newton
    return fn(*args, *(MODE if mode is None else mode))


def _args(W, q, mu, d):
    N = W.shape[0]
    return (np.asarray(W, float), np.asarray(q, float), np.zeros((0, N)), np.zeros(0),
            np.asarray(mu, float), d)


@pytest.mark.parametrize("python", [False, True], ids=["compiled", "plain"])
@pytest.mark.parametrize("mode", sorted(MODES))
def test_one_planar_contact_sliding_by_hand(mode, python):
    """W = diag(a, b), q = (qn, qt), qn < 0: the CCP's boundary minimizer
    x_n = (mu |qt| - qn) / (a + b mu^2), x_t = -mu s x_n (s = sign qt) when the unconstrained
    x_t = -qt / b leaves the cone; Coulomb's slide x_n = -qn / a (u_n = 0)."""
    def run(*args):
        return _newton(*args, mode=MODES[mode], python=python)

    a, b, mu = 2.0, 0.5, 0.3
    qn, qt = -1.0, 3.0
    W, q = np.diag([a, b]), np.array([qn, qt])
    xn = (mu * abs(qt) - qn) / (a + b * mu * mu)
    ccp = np.array([xn, -mu * xn])
    assert abs(-qt / b) > mu * xn  # the cone binds
    kind, tang = np.array([BND]), np.array([[-1.0, 0.0]])
    x, ok = run(*_args(W, q, [mu], 2), kind, tang, ccp * (1 + 1e-6), False, True)
    assert ok and np.allclose(x, ccp, rtol=1e-14, atol=0.0)
    xn_c = -qn / a
    coul = np.array([xn_c, -mu * xn_c])
    assert (qt - b * mu * xn_c) > 0.0  # the slip keeps its sign: friction opposes it
    x, ok = run(*_args(W, q, [mu], 2), kind, tang, coul * (1 - 1e-6), True, True)
    assert ok and np.allclose(x, coul, rtol=1e-14, atol=0.0)


@pytest.mark.parametrize("python", [False, True], ids=["compiled", "plain"])
@pytest.mark.parametrize("mode", sorted(MODES))
def test_one_spatial_contact_sticking_and_separating_by_hand(mode, python):
    """Inside the cone the answer is -W^-1 q; a contact whose q_n > 0 stays at zero with
    its dual q in K* (mu |q_t| <= q_n)."""
    def run(*args):
        return _newton(*args, mode=MODES[mode], python=python)

    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 3))
    W = A @ A.T + np.eye(3)
    stick = np.array([1.0, 0.1, -0.05])
    q = -W @ stick
    x, ok = run(*_args(W, q, [0.5], 3), np.array([INT]), np.zeros((1, 2)),
                stick + 1e-7, False, True)
    assert ok and np.allclose(x, stick, rtol=0, atol=1e-15)
    q = np.array([1.0, 0.2, -0.1])  # mu |q_t| = 0.11 < q_n: zero is optimal
    x, ok = run(*_args(W, q, [0.5], 3), np.array([ZERO]), np.zeros((1, 2)),
                np.zeros(3), False, False)
    assert ok and not x.any()
    # the same contact declared inside the cone: -W^-1 q leaves the cone, refused
    x, ok = run(*_args(W, q, [0.5], 3), np.array([INT]), np.zeros((1, 2)),
                np.zeros(3), False, False)
    assert not ok


def _random_program(rng, d, n, redundant):
    N = n * d
    rank = max(1, N - 2) if redundant else N
    A = rng.normal(size=(N, rank))
    W = A @ A.T / rank
    q = rng.normal(size=N)
    q[::d] -= 0.5  # mostly pressing contacts
    mu = rng.uniform(0.1, 1.0, n)
    mu[rng.random(n) < 0.2] = 0.0
    return W, q, mu


@pytest.mark.parametrize("d", [2, 3])
def test_polish_of_clarabel_answers_meets_kkt_at_round_off(d):
    """Random cone QPs (some with redundant contacts): Clarabel's raw answer, polished, has a
    natural-map residual at round-off, and stays within Clarabel's accuracy of it."""
    rng = np.random.default_rng(11 + d)
    clarabel = backend("clarabel")
    polished = 0
    for trial in range(30):
        n = int(rng.integers(2, 6))
        W, q, mu = _random_program(rng, d, n, redundant=trial % 3 == 0)
        unit, _ = equilibrated(ConeQP(W, q, mu, d, np.zeros((0, n * d)), np.zeros(0)))
        raw = clarabel.solve(unit, 1e-10, 200).x
        x, ok = polish_cone_qp(unit, raw)
        assert natural_map(unit.W, unit.q, mu, d, raw) < 1e-4  # the raw answer is rough
        if not ok:
            continue
        polished += 1
        assert natural_map(unit.W, unit.q, mu, d, x) < 1e-12
        assert ccp_residual(unit.W, unit.q, mu, d, x) < 1e-12
        assert np.max(np.abs(x - raw)) < 1e-4 * max(np.max(np.abs(raw)), 1.0)
        # the velocities of a convex QP's minimizers are unique: Clarabel's to its accuracy
        assert np.max(np.abs(unit.W @ (x - raw))) < 1e-5
    assert polished >= 25


@pytest.mark.parametrize("d", [2, 3])
def test_coulomb_newton_from_a_perturbed_solution_meets_coulombs_conditions(d):
    """Coulomb's conditions (written out in the test) at round-off after the Newton from a
    solution perturbed by 1e-6, on random problems with sliding contacts."""
    rng = np.random.default_rng(7 + d)
    clarabel = backend("clarabel")
    checked = 0
    for _ in range(30):
        n = int(rng.integers(2, 5))
        W, q, mu = _random_program(rng, d, n, redundant=False)
        mu[mu == 0.0] = 0.4
        unit, _ = equilibrated(ConeQP(W, q, mu, d, np.zeros((0, n * d)), np.zeros(0)))
        # the Coulomb solution by the polish from Clarabel's CCP answer, shifted iteratively
        s = np.zeros(n)
        x = None
        for _ in range(60):
            qs = unit.q.copy()
            qs[::d] += s
            y = clarabel.solve(ConeQP(unit.W, qs, mu, d, unit.E, unit.f), 1e-10, 200).x
            u = (unit.W @ y + unit.q).reshape(n, d)
            s_new = mu * np.linalg.norm(u[:, 1:], axis=1)
            if np.max(np.abs(s_new - s)) < 1e-12:
                break
            s = s_new
        x, ok = polish_cone_qp(unit, y, coulomb=True)
        if not ok:
            continue
        checked += 1
        assert coulomb_conditions(unit.W, unit.q, mu, d, x) < 1e-12
        x2, ok2 = polish_cone_qp(unit, x * (1.0 + 1e-6), coulomb=True)
        assert ok2 and coulomb_conditions(unit.W, unit.q, mu, d, x2) < 1e-12
    assert checked >= 15


def test_jacobian_null_space_is_the_redundant_impulse_of_a_box_on_four_corners():
    """Four corners of a rigid box on the floor (6 dof, 12 contact rows), sticking: the
    Jacobian of the active set's equations has the 6-dimensional null space of W (impulses
    that move nothing), checked against W's rank computed here."""
    a, b, c = 0.2, 0.15, 0.1
    J = []
    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        p = np.array([sx * a, sy * b, -c])
        for axis in (np.array([0.0, 0, 1]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])):
            J.append(np.concatenate([axis, np.cross(p, axis)]))
    J = np.array(J)
    M = np.diag([1.0, 1.0, 1.0, 0.0108, 0.0167, 0.0208])
    W = J @ np.linalg.solve(M, J.T)
    assert np.linalg.matrix_rank(W) == 6
    mu = np.full(4, 0.3)
    x = np.tile([1.0, 0.0, 0.0], 4) / 4
    q = -W @ x
    Jac, Jx = active_set_jacobian(*_args(W, q, mu, 3), np.full(4, INT), np.zeros((4, 2)), x,
                                  True)
    sv = np.linalg.svd(Jac, compute_uv=False)
    assert int(np.sum(sv > 1e-9 * sv[0])) == 6
    assert np.allclose(Jx, np.eye(12))
