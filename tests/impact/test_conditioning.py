"""Every path answers where the impact is well posed, however ill-conditioned M is (issue 15,
item 2).

A rimless wheel whose hub inertia is tiny (radius of gyration rho l) has cond(M) = 1/rho^2:
its spin is nearly free, so the kinetic energy -- the objective of the conic programs --
hardly sees it, and the interior-point method stops short (the conic paths raised
SolverError from cond(M) ~ 1e6, where the ``fast`` path answers to 1e-11). The conic paths
now polish their answers on the exact active set with scale-free tolerances and fall back
to every active set when the interior-point answer is too rough to classify.

Independent numbers: McGeer's strike ratio omega+ = eta omega-,
eta = (cos(2 pi / n) + rho^2) / (1 + rho^2) (angular momentum about the new foot, derived in
``test_roundoff_contacts``); a plastic sticking impact leaves the contact at rest
(v+ = 0); and the ``fast`` path's closed forms. The matrices are written out by hand here
(a free planar or spatial rigid body and a point of it), not built by convimpact.

Accuracy: every contact-space method forms ``W pi + v`` with an impulse of size
|v| / lambda_min(W), which cancels cond(W) eps of the velocities; the fast path's error
against McGeer's ratio grows as 3e-15, 4e-13, 3e-11, 8e-9, 6e-7 over cond(M) = 1e2 .. 1e10,
so the tolerance here is 1e-11 + 2e-15 cond(M), for every path alike. Measured (conic
against fast, worst over laws, e, mu and both conic paths; dq+ relative to max |dq+|):
wheel 4e-14, 1e-12, 1e-10, 4e-8, 3e-6; spatial body 2e-14, 2e-11, 5e-10, 6e-8, 8e-6; every
path against McGeer's ratio 1e-14, 7e-13, 1e-10, 2e-8, 9e-7.
"""

import math

import numpy as np
import pytest

import convimpact as ci

CONDS = (1e2, 1e4, 1e6, 1e8, 1e10)
PATHS = ("clarabel", "cvxpy")


def tol(cond: float) -> float:
    """Relative accuracy every path reaches at cond(M) (module docstring)."""
    return 1e-11 + 2e-15 * cond


def point_jacobian_2d(r, n):
    """Rows n, t (t = n turned by +90 degrees) of the velocity of the body point at r from
    the centre of a free planar body (x, y, phi): v = (x' - phi' r_y, y' + phi' r_x)."""
    n = np.asarray(n, dtype=float)
    t = np.array([-n[1], n[0]])
    V = np.array([[1.0, 0.0, -r[1]], [0.0, 1.0, r[0]]])
    return np.array([n @ V, t @ V])


def wheel(rho, omega=1.0, n=8, slope_deg=5.0):
    """McGeer's wheel (m = 1, l = 1) at the strike: foot7 landing while the wheel turns at
    omega about foot0, both feet on the slope. Returns M, [J7, J0], dq, eta."""
    g = math.radians(slope_deg)
    phi = math.pi / n + g  # the chord foot7 -> foot0 lies along the slope
    feet = [np.array([math.cos(phi + a), math.sin(phi + a)])
            for a in (-math.pi / 2 + 2 * math.pi * 7 / n, -math.pi / 2)]
    normal = (-math.sin(g), math.cos(g))
    J = [point_jacobian_2d(r, normal) for r in feet]
    M = np.diag([1.0, 1.0, rho ** 2])
    r0 = -feet[1]  # hub - foot0
    dq = omega * np.array([-r0[1], r0[0], 1.0])
    eta = (math.cos(2 * math.pi / n) + rho ** 2) / (1 + rho ** 2)
    return M, J, dq, eta


def rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - b)) / np.max(np.abs(b)))


@pytest.mark.parametrize("cond", CONDS)
def test_one_foot_every_law_and_path_answers_like_the_fast_path(cond):
    M, J, dq, eta = wheel(cond ** -0.5)
    assert np.linalg.cond(M) == pytest.approx(cond, rel=1e-9)
    for law in ci.LAWS:
        for e, mu in ((0.0, 1.0), (0.5, 1.0), (0.0, 0.05), (0.5, 0.05)):
            fast = ci.resolve_impact(M, J[0], dq, e=e, mu=mu, law=law, method="fast")
            if (e, mu) == (0.0, 1.0):  # a plastic stick: McGeer's ratio
                assert fast.regime == "stick"
                assert fast.dq_plus[2] == pytest.approx(eta, rel=tol(cond))
            for method in PATHS:
                r = ci.resolve_impact(M, J[0], dq, e=e, mu=mu, law=law, method=method)
                assert rel(r.dq_plus, fast.dq_plus) <= tol(cond), (law, method, e, mu)


@pytest.mark.parametrize("cond", CONDS)
def test_two_feet_every_law_and_path_strikes_by_mcgeers_ratio(cond):
    """Both feet as contacts (the old one touching to round-off): W is singular (4 rows, 3
    degrees of freedom) as well as ill-conditioned."""
    M, J, dq, eta = wheel(cond ** -0.5)
    for law in ci.LAWS:
        for method in PATHS:
            r = ci.resolve_impact(M, J, dq, e=0.0, mu=1.0, law=law, method=method)
            assert r.dq_plus[2] == pytest.approx(eta, rel=tol(cond)), (law, method)
            assert r.regime[1] == "separating"


def spatial_body(cond, seed=3):
    """A free rigid body in space (v, omega), m = 1, principal inertias k^2 (1, 1.5, 0.7) with
    k^2 = 1 / (0.7 cond) (so cond(M) = cond), struck at the body point r = (0.3, -1, 0.2)
    against the floor n = +y (t1 = +x, t2 = -z): rows of v + omega x r."""
    k2 = 1.0 / (0.7 * cond)
    M = np.diag([1.0, 1.0, 1.0, k2, 1.5 * k2, 0.7 * k2])
    r = np.array([0.3, -1.0, 0.2])
    skew = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    V = np.hstack([np.eye(3), -skew])  # v + omega x r = v - [r]x omega
    frame = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    Jc = frame @ V
    rng = np.random.default_rng(seed)
    dq = rng.normal(size=6)
    dq[1] = -abs(dq[1]) - 1.0
    dq[3:] *= 0.3
    return M, Jc, dq


@pytest.mark.parametrize("cond", CONDS)
def test_spatial_body_every_law_and_path_answers_like_the_fast_path(cond):
    M, Jc, dq = spatial_body(cond)
    assert np.linalg.cond(M) == pytest.approx(cond, rel=1e-9)
    for law in ci.LAWS:
        for e, mu in ((0.0, 2.0), (0.4, 0.1)):
            fast = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, law=law, method="fast")
            vs = float(np.max(np.abs(Jc @ dq)))
            if (e, mu) == (0.0, 2.0):  # plastic stick: the contact point stops
                assert fast.regime == "stick"
                assert np.max(np.abs(Jc @ fast.dq_plus)) <= tol(cond) * vs
            for method in PATHS:
                r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, law=law, method=method)
                if (e, mu) == (0.0, 2.0):
                    assert np.max(np.abs(Jc @ r.dq_plus)) <= tol(cond) * vs, (law, method)
                # compare the contact velocities (what the law decides) and dq+ itself
                assert np.max(np.abs(r.v_plus - fast.v_plus)) <= tol(cond) * vs, (law, method)
                assert rel(r.dq_plus, fast.dq_plus) <= tol(cond), (law, method, e, mu)
