"""law="stronge" on several coupled contacts (convimpact.impact.laws.stronge_contacts).

Oracles written here, independent of the module:

* a particle on two coincident floor contacts (W singular): the total impulse is a particle's
  frictional impact by hand, v_n+ = -e v_n-, the slip reduced by mu (1 + e) |v_n-| until it
  stops (|v_t+| = max(|v_t-| - mu (1 + e) |v_n-|, 0)) -- one contact of the particle's mass;
* frictionless contacts: Poisson's multi-contact law from the plastic linear complementarity
  problem solved here by enumerating its active sets (numpy only), times (1 + e);
* energy: T+ <= T- over random coupled systems (planar and spatial, per-contact e), the
  impulse in the friction cones, no contact left approaching;
* restitution as the formulation defines it: expansion normal impulse = e_i times the
  compression normal impulse at every contact (Poisson's per contact);
* a rod landing flat on two corners, frictionless, by hand (translation and rotation).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import convimpact as ci
from convimpact.errors import SolverError

METHODS = ("clarabel", "cvxpy")


def particle_by_hand(v, e, mu):
    """A unit particle's frictional impact on a floor (n = first axis), Coulomb friction
    against the slip until it stops: v+ = (-e v_n, slip shortened by mu (1 + e) |v_n|)."""
    v = np.asarray(v, float)
    vt = v[1:]
    s = float(np.linalg.norm(vt))
    pn = -(1.0 + e) * v[0]
    keep = max(s - mu * pn, 0.0)
    out = np.empty_like(v)
    out[0] = -e * v[0]
    out[1:] = vt * (keep / s) if s > 0 else 0.0
    return out


@pytest.mark.parametrize("d", [2, 3])
def test_particle_on_two_coincident_contacts_is_one_contact_by_hand(d):
    rng = np.random.default_rng(5 + d)
    frame = np.eye(d)
    for _ in range(12):
        m = rng.uniform(0.5, 3.0)
        v = rng.normal(size=d)
        v[0] = -abs(v[0])
        e, mu = rng.uniform(0, 1), rng.uniform(0, 1.2)
        for method in METHODS:
            r = ci.resolve_impact(m * np.eye(d), [frame, frame], v, e=e, mu=mu,
                                  law="stronge", method=method)
            np.testing.assert_allclose(r.dq_plus, particle_by_hand(v, e, mu), atol=1e-7)
            total = r.impulse.sum(axis=0)
            np.testing.assert_allclose(total, m * (particle_by_hand(v, e, mu) - v), atol=1e-7)
            assert not r.diagnostics.energy_gained


def poisson_lcp(W, vn, e):
    """Frictionless Poisson: the plastic LCP w = W p + vn >= 0 _|_ p >= 0 by enumeration of
    its active sets (the smallest-energy solution), then p (1 + e)."""
    n = len(vn)
    best = None
    for k in range(n + 1):
        for act in itertools.combinations(range(n), k):
            p = np.zeros(n)
            if act:
                idx = list(act)
                p[idx] = np.linalg.lstsq(W[np.ix_(idx, idx)], -vn[idx], rcond=None)[0]
            w = W @ p + vn
            if np.all(p >= -1e-12) and np.all(w >= -1e-10):
                T = 0.5 * p @ W @ p + p @ vn
                if best is None or T < best[0] - 1e-14:
                    best = (T, p)
    return (1.0 + e) * best[1]


def test_frictionless_coupled_contacts_equal_poisson_by_enumeration():
    rng = np.random.default_rng(21)
    for trial in range(25):
        k, n = int(rng.integers(3, 6)), int(rng.integers(2, 4))
        A = rng.normal(size=(k, k))
        M = A @ A.T + 0.5 * np.eye(k)
        Jc = [rng.normal(size=(2, k)) for _ in range(n)]
        dq = rng.normal(size=k)
        for J in Jc:
            if J[0] @ dq > 0:
                J[0] *= -1.0
        e = float(rng.uniform(0, 1))
        N = np.array([J[0] for J in Jc])
        Wn = N @ np.linalg.solve(M, N.T)
        expected = poisson_lcp(Wn, N @ dq, e)
        r = ci.resolve_impact(M, Jc, dq, e=e, mu=0.0, law="stronge", method=METHODS[trial % 2])
        np.testing.assert_allclose(r.impulse[:, 0], expected, atol=1e-7 * np.max(expected))
        # frictionless, common e: T_L = 1/2 (1 - e^2) p_c.W.p_c
        pc = expected / (1.0 + e)
        assert r.energy_loss == pytest.approx(0.5 * (1 - e * e) * pc @ Wn @ pc, rel=1e-7,
                                              abs=1e-10)


def test_corner_and_rod_by_hand():
    # a unit particle in a frictionless corner (floor and wall): Newton = Poisson, v+ = e v
    Jc = [np.array([[0.0, 1.0], [1.0, 0.0]]), np.array([[1.0, 0.0], [0.0, 1.0]])]
    r = ci.resolve_impact(np.eye(2), Jc, [-1.0, -1.0], e=0.6, mu=0.0, law="stronge")
    np.testing.assert_allclose(r.dq_plus, [0.6, 0.6], atol=1e-9)
    # a rod (mass 1, inertia 0.2, corners at +-0.5) landing flat at v = -1 on two frictionless
    # corners: symmetric, no rotation, each corner takes (1 + e) / 2
    Mr = np.diag([1.0, 1.0, 0.2])
    Ja = np.array([[0.0, 1.0, 0.5], [1.0, 0.0, 0.0]])
    Jb = np.array([[0.0, 1.0, -0.5], [1.0, 0.0, 0.0]])
    rod = ci.resolve_impact(Mr, [Ja, Jb], [0.0, -1.0, 0.0], e=0.5, mu=0.0, law="stronge")
    np.testing.assert_allclose(rod.dq_plus, [0.0, 0.5, 0.0], atol=1e-9)
    np.testing.assert_allclose(rod.impulse[:, 0], [0.75, 0.75], atol=1e-9)


def random_coupled(rng, d):
    k, n = int(rng.integers(2, 6)), int(rng.integers(2, 4))
    A = rng.normal(size=(k, k))
    M = A @ A.T + 0.3 * np.eye(k)
    Jc = [rng.normal(size=(d, k)) for _ in range(n)]
    dq = rng.normal(size=k)
    for J in Jc:
        if J[0] @ dq > 0:
            J[0] *= -1.0
    return M, Jc, dq, n


@pytest.mark.parametrize("d", [2, 3])
def test_random_coupled_never_gain_energy_and_keep_the_cone(d):
    rng = np.random.default_rng(40 + d)
    failures = 0
    for trial in range(30 if d == 2 else 14):
        M, Jc, dq, n = random_coupled(rng, d)
        e = rng.uniform(0, 1, size=n) if trial % 2 else float(rng.uniform(0, 1))
        mu = float(rng.uniform(0, 1.5))
        try:
            r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, law="stronge", method="clarabel")
        except SolverError:  # Coulomb's plastic compression did not converge: raised, said
            failures += 1
            continue
        dg = r.diagnostics
        T = 0.5 * dq @ M @ dq
        Tp = 0.5 * r.dq_plus @ M @ r.dq_plus
        assert Tp <= T * (1 + 1e-9), (trial, Tp - T)
        assert not dg.energy_gained and not dg.penetration
        pi = r.impulse
        assert np.all(pi[:, 0] >= -1e-9 * np.max(np.abs(pi)))
        assert np.all(np.linalg.norm(pi[:, 1:], axis=1) <= mu * pi[:, 0] + 1e-8 * np.max(
            np.abs(pi)))
        ex = dg.extras
        if ex.get("expansion_scale") == 1.0:
            ee = np.broadcast_to(e, (n,))
            for i, c in enumerate(ex["contacts"]):
                assert c["expansion_impulse"][0] == pytest.approx(
                    ee[i] * c["compression_impulse"][0], rel=1e-12, abs=1e-14)
    assert failures <= 2, failures


def test_one_approaching_contact_whose_partner_lifts_is_the_exact_single_contact():
    # a bar (mass 1, inertia 0.5, corners at +-0.5) landing on its left corner while its right
    # one touches: an upward impulse p at the left raises the right corner by
    # p - 0.5 (0.5 p / 0.5) = p / 2 > 0, so it lifts and the answer is the left corner's exact
    # single-contact impulse
    Mr = np.diag([1.0, 1.0, 0.5])
    Ja = np.array([[0.0, 1.0, -0.5], [1.0, 0.0, 0.0]])
    Jb = np.array([[0.0, 1.0, 0.5], [1.0, 0.0, 0.0]])
    dq = np.array([0.4, -0.5, 1.0])  # v_n: left -1.0, right 0.0
    alone = ci.resolve_impact(Mr, Ja, dq, e=0.5, mu=0.3, law="stronge")
    both = ci.resolve_impact(Mr, [Ja, Jb], dq, e=0.5, mu=0.3, law="stronge")
    np.testing.assert_allclose(both.dq_plus, alone.dq_plus, rtol=1e-13, atol=1e-14)
    assert both.regime[1] == "separating" and both.v_plus[1, 0] > 0.0
    assert both.diagnostics.restitution_residual <= 1e-9
