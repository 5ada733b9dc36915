"""Model quantities against finite differences of exact positions and energies.

Every reference here is computed from body placements only (positions and orientations of
the forward kinematics) by central differences, or from the Lagrangian:
* M: polarization of the kinetic energy built from finite-difference body velocities;
* B, Jc, C: finite differences of positions, gaps and Psi;
* M_dot, C_dot: finite differences in time along theta_dot;
* f: Lagrange's equations (FD of T and V) and energy conservation over an integration.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from convimpact.model.random import random_model

H = 1e-6
TOL = 2e-7

CASES = [(planar, seed) for planar in (True, False) for seed in range(6)]
KINDS_PLANAR = ("revolute", "prismatic", "free", "translation", "fixed")
KINDS_SPATIAL = ("revolute", "prismatic", "free", "universal", "translation", "fixed")


def _model(planar, seed, loop=None, chain=False):
    rng = np.random.default_rng(seed)
    kinds = KINDS_PLANAR if planar else KINDS_SPATIAL
    model, theta = random_model(rng, planar, n_bodies=4, joint_kinds=kinds, n_contacts=3,
                                loop=loop, chain=chain)
    dtheta = rng.normal(size=model.n_coordinates)
    return model, model.mechanism(), theta, dtheta


def _placements(mech, theta):
    """(R_b, c_b) of every moving body: orientation and centre of mass."""
    out = []
    for body in mech.model.bodies[1:]:
        R, p = mech.body_placement(body.name, theta)
        out.append((R, p + R @ body.com))
    return out


def _omega(planar, R, Rdot):
    W = Rdot @ R.T
    return np.array([W[1, 0]]) if planar else np.array([W[2, 1], W[0, 2], W[1, 0]])


def _fd_body_velocities(mech, theta, dtheta):
    plus, minus = _placements(mech, theta + H * dtheta), _placements(mech, theta - H * dtheta)
    now = _placements(mech, theta)
    out = []
    for (R, _), (Rp, cp), (Rm, cm) in zip(now, plus, minus):
        out.append(((cp - cm) / (2 * H), _omega(mech.planar, R, (Rp - Rm) / (2 * H))))
    return out


def _fd_kinetic_energy(mech, theta, dtheta):
    T = 0.0
    for body, (R, _), (v, w) in zip(mech.model.bodies[1:], _placements(mech, theta),
                                    _fd_body_velocities(mech, theta, dtheta)):
        I = body.inertia if mech.planar else R @ body.inertia @ R.T
        T += 0.5 * body.mass * v @ v + 0.5 * w @ I @ w
    return T


@pytest.mark.parametrize("planar,seed", CASES)
def test_mass_matrix_is_hessian_of_kinetic_energy(planar, seed):
    model, mech, theta, _ = _model(planar, seed)
    k = model.n_coordinates
    E = np.eye(k)
    T = [_fd_kinetic_energy(mech, theta, E[i]) for i in range(k)]
    M_ref = np.empty((k, k))
    for i in range(k):
        for j in range(k):
            M_ref[i, j] = _fd_kinetic_energy(mech, theta, E[i] + E[j]) - T[i] - T[j]
    M = mech.mass_matrix(theta)
    assert np.allclose(M, M_ref, atol=TOL * max(1.0, np.abs(M).max()))
    assert np.allclose(M, M.T)


@pytest.mark.parametrize("planar,seed", CASES)
def test_velocity_transformation_B(planar, seed):
    model, mech, theta, _ = _model(planar, seed)
    B = mech.velocity_transformation(theta)
    k = model.n_coordinates
    for j in range(k):
        col = np.concatenate([np.concatenate(vw) for vw in
                              _fd_body_velocities(mech, theta, np.eye(k)[j])])
        assert np.allclose(B[:, j], col, atol=TOL)


@pytest.mark.parametrize("planar,seed", CASES)
def test_contact_jacobians(planar, seed):
    model, mech, theta, dtheta = _model(planar, seed)
    for spec in model.contacts:
        fr = mech.contact_frame(spec.name, theta)
        Jc = mech.contact_jacobian(spec.name, theta)
        d = model.dim
        basis = np.vstack([fr.normal[None], fr.tangents])
        assert np.allclose(basis @ basis.T, np.eye(d), atol=1e-12)
        if not planar:  # right-handed (n, t1, t2)
            assert np.allclose(np.cross(basis[0], basis[1]), basis[2], atol=1e-12)
        # normal row: derivative of the exact gap
        dgap = (mech.contact_gap(spec.name, theta + H * dtheta)
                - mech.contact_gap(spec.name, theta - H * dtheta)) / (2 * H)
        assert Jc[0] @ dtheta == pytest.approx(dgap, abs=TOL)
        # all rows: relative velocity of the two material contact points
        xi = fr.point
        xj = xi if spec.target == "plane" else xi - fr.gap * fr.normal
        bi, bj = model.bodies[spec.body].name, model.bodies[spec.other].name
        Ri, pi_ = mech.body_placement(bi, theta)
        Rj, pj = mech.body_placement(bj, theta)
        li, lj = Ri.T @ (xi - pi_), Rj.T @ (xj - pj)

        def rel(th):
            return mech.point_position(bi, li, th) - mech.point_position(bj, lj, th)

        vrel = (rel(theta + H * dtheta) - rel(theta - H * dtheta)) / (2 * H)
        assert np.allclose(Jc @ dtheta, basis @ vrel, atol=TOL)


@pytest.mark.parametrize("planar,seed", CASES)
def test_mass_matrix_dot_in_time(planar, seed):
    model, mech, theta, dtheta = _model(planar, seed)
    Md_ref = (mech.mass_matrix(theta + H * dtheta) - mech.mass_matrix(theta - H * dtheta)) / (2 * H)
    assert np.allclose(mech.mass_matrix_dot(theta, dtheta), Md_ref, atol=TOL * 10)


@pytest.mark.parametrize("planar,seed", CASES)
def test_forces_satisfy_lagrange_equations(planar, seed):
    """f = -M_dot theta_dot + dT/dtheta - dV/dtheta (no applied forces)."""
    model, mech, theta, dtheta = _model(planar, seed)
    k = model.n_coordinates
    g = model.gravity

    def V(th):  # gravity potential from exact positions
        return -sum(b.mass * g @ c for b, (_, c) in zip(model.bodies[1:], _placements(mech, th)))

    E = np.eye(k)
    dT = np.array([(mech.kinetic_energy(theta + H * E[j], dtheta)
                    - mech.kinetic_energy(theta - H * E[j], dtheta)) / (2 * H) for j in range(k)])
    dV = np.array([(V(theta + H * E[j]) - V(theta - H * E[j])) / (2 * H) for j in range(k)])
    Md = (mech.mass_matrix(theta + H * dtheta) - mech.mass_matrix(theta - H * dtheta)) / (2 * H)
    f_ref = -Md @ dtheta + dT - dV
    f = mech.generalized_forces(0.0, theta, dtheta)
    assert np.allclose(f, f_ref, atol=1e-6 * max(1.0, np.abs(f_ref).max()))
    assert mech.potential_energy(theta) == pytest.approx(V(theta), abs=1e-12)


@pytest.mark.parametrize("planar,seed", [(True, 0), (False, 1), (False, 2)])
def test_energy_is_conserved_over_an_integration(planar, seed):
    model, mech, theta, dtheta = _model(planar, seed)
    k = model.n_coordinates

    def rhs(t, y):
        th, dth = y[:k], y[k:]
        return np.concatenate([dth, np.linalg.solve(mech.mass_matrix(th),
                                                    mech.generalized_forces(t, th, dth))])

    def energy(y):
        return mech.kinetic_energy(y[:k], y[k:]) + mech.potential_energy(y[:k])

    y0 = np.concatenate([theta, dtheta])
    sol = solve_ivp(rhs, (0.0, 0.3), y0, rtol=1e-11, atol=1e-12, method="DOP853")
    assert sol.success
    E0 = energy(y0)
    drift = max(abs(energy(sol.y[:, i]) - E0) for i in range(sol.y.shape[1]))
    assert drift < 1e-7 * max(1.0, abs(E0), mech.kinetic_energy(theta, dtheta))


LOOPS = [(True, "revolute"), (True, "prismatic"), (False, "revolute"), (False, "prismatic"),
         (False, "spherical")]


@pytest.mark.parametrize("planar,kind", LOOPS)
@pytest.mark.parametrize("seed", range(3))
def test_loop_jacobian_and_its_time_derivative(planar, kind, seed):
    model, mech, theta, dtheta = _model(planar, 10 + seed, loop=kind)
    theta = theta + 0.1 * np.random.default_rng(seed).normal(size=theta.size)  # off the loop
    k = model.n_coordinates
    C = mech.loop_jacobian(theta)
    assert C.shape == (model.n_loop_constraints, k)
    C_ref = np.column_stack([(mech.loop_residual(theta + H * e) - mech.loop_residual(theta - H * e))
                             / (2 * H) for e in np.eye(k)])
    assert np.allclose(C, C_ref, atol=TOL)
    Cd_ref = (mech.loop_jacobian(theta + H * dtheta) - mech.loop_jacobian(theta - H * dtheta)) / (2 * H)
    assert np.allclose(mech.loop_jacobian_dot(theta, dtheta), Cd_ref, atol=TOL * 10)


def test_applied_forces_enter_f():
    from convimpact.model import Joint, ModelBuilder
    b = ModelBuilder(planar=True, gravity=(0.0, 0.0))
    b.add_body("wheel", "ground", Joint.revolute(), 2.0, (0.0, 0.0), 0.5)
    b.set_applied_forces(lambda t, th, dth: np.array([3.0 * t - dth[0]]))
    mech = b.build().mechanism()
    assert mech.generalized_forces(2.0, np.zeros(1), np.array([1.0]))[0] == pytest.approx(5.0)


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 31 - 1), planar=st.booleans(), n_bodies=st.integers(1, 5))
def test_property_kinetic_energy_and_gap_rates(seed, planar, n_bodies):
    """On random trees: T from M equals T from finite-difference body velocities, and
    Jc[0] theta_dot is the rate of the exact gap."""
    rng = np.random.default_rng(seed)
    kinds = KINDS_PLANAR if planar else KINDS_SPATIAL
    model, theta = random_model(rng, planar, n_bodies=n_bodies, joint_kinds=kinds, n_contacts=2)
    mech = model.mechanism()
    dtheta = rng.normal(size=model.n_coordinates)
    T = mech.kinetic_energy(theta, dtheta)
    assert T >= 0.0
    assert T == pytest.approx(_fd_kinetic_energy(mech, theta, dtheta), abs=1e-7 * max(1.0, T))
    for name in model.contact_names:
        dgap = (mech.contact_gap(name, theta + H * dtheta)
                - mech.contact_gap(name, theta - H * dtheta)) / (2 * H)
        assert mech.contact_jacobian(name, theta)[0] @ dtheta == pytest.approx(dgap, abs=TOL)
