"""The compiled recursive algorithms against the old definitions, Pinocchio and differences.

* against the old per-body implementation (:mod:`tests.model.reference_model`, a frozen copy
  of eqs. 3, 4, 11 and 16-19 as they were computed column by column): M, f, M_dot, the
  momentum rate f + M_dot theta_dot, B, T, V, gaps, frames and contact Jacobians on random
  planar and spatial trees and chains with every joint kind, to 1e-12;
* against Pinocchio (``to_pinocchio``): ``crba``, ``rnea(q, v, 0)``, the Coriolis matrix
  (M_dot = C + C^T), frame Jacobians and their time variation at the contact points, to 1e-12;
* the contact Jacobians' time derivatives against Richardson-extrapolated central differences
  of the old contact Jacobian along theta_dot (plane and sphere contacts, both sides moving);
* the unchecked entry points agree with the checked protocol methods, the state cache is
  exact when states alternate, and bad input is refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.errors import NonFiniteError, ShapeError, SingularSystemError
from convimpact.model import (Joint, ModelBuilder, forward_kinematics, point_jacobian,
                              point_jacobian_dot)
from convimpact.model import recursive as rc
from convimpact.model.random import random_model

from .reference_model import ReferenceModel

TOL = 1e-12
KINDS_PLANAR = ("revolute", "prismatic", "free", "translation", "fixed")
KINDS_SPATIAL = ("revolute", "prismatic", "free", "universal", "translation", "fixed")
CASES = [(planar, chain, seed) for planar in (True, False) for chain in (False, True)
         for seed in range(6)]


def _case(planar, chain, seed, n_bodies=None, n_contacts=4):
    rng = np.random.default_rng(500 + seed + 50 * chain + 100 * planar)
    kinds = KINDS_PLANAR if planar else KINDS_SPATIAL
    n = n_bodies or int(rng.integers(1, 8))
    model, theta = random_model(rng, planar, n_bodies=n, joint_kinds=kinds,
                                n_contacts=n_contacts, chain=chain)
    dtheta = rng.normal(size=model.n_coordinates)
    return model, theta, dtheta


def _close(a, b, tol=TOL):
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(1.0, float(np.max(np.abs(b))) if b.size else 1.0)
    assert a.shape == b.shape
    assert np.max(np.abs(a - b), initial=0.0) <= tol * scale, np.max(np.abs(a - b))


@pytest.mark.parametrize("planar,chain,seed", CASES)
def test_dynamics_equal_the_old_definitions(planar, chain, seed):
    model, th, dth = _case(planar, chain, seed)
    mech, ref = model.mechanism(), ReferenceModel(model)
    t = 0.3
    _close(mech.mass_matrix(th), ref.mass_matrix(th))
    f_ref = ref.generalized_forces(t, th, dth)
    _close(mech.generalized_forces(t, th, dth), f_ref)
    Md_ref = ref.mass_matrix_dot(th, dth)
    _close(mech.mass_matrix_dot(th, dth), Md_ref, 1e-11)
    _close(mech.momentum_rate(t, th, dth), f_ref + Md_ref @ dth, 1e-11)
    _close(mech.velocity_transformation(th), ref.velocity_transformation(th))
    assert mech.kinetic_energy(th, dth) == pytest.approx(ref.kinetic_energy(th, dth), rel=TOL,
                                                         abs=TOL)
    assert mech.potential_energy(th) == pytest.approx(ref.potential_energy(th), rel=TOL, abs=TOL)


@pytest.mark.parametrize("planar,chain,seed", CASES)
def test_contacts_equal_the_old_definitions(planar, chain, seed):
    model, th, _ = _case(planar, chain, seed)
    mech, ref = model.mechanism(), ReferenceModel(model)
    for name in model.contact_names:
        new, old = mech.contact_frame(name, th), ref.contact_frame(name, th)
        assert new.gap == pytest.approx(old.gap, abs=TOL)
        _close(new.point, old.point)
        _close(new.normal, old.normal)
        _close(new.tangents, old.tangents)
        _close(new.jacobian, old.jacobian)
        _close(mech.contact_jacobian(name, th), old.jacobian)
        assert mech.contact_gap(name, th) == pytest.approx(old.gap, abs=TOL)


def _richardson(fun, h=1e-3):
    """Central difference along h extrapolated with h/2: O(h^4)."""
    d1 = (fun(h) - fun(-h)) / (2 * h)
    d2 = (fun(h / 2) - fun(-h / 2)) / h
    return (4 * d2 - d1) / 3


@pytest.mark.parametrize("planar,chain,seed", CASES)
def test_contact_jacobian_rates_are_the_time_derivatives(planar, chain, seed):
    model, th, dth = _case(planar, chain, seed)
    mech = model.mechanism()
    for name in model.contact_names:
        fd = _richardson(lambda h: ReferenceModel(model).contact_jacobian(name, th + h * dth))
        _close(mech.contact_jacobian_dot(name, th, dth), fd, 1e-8)
        # and it is the rate of the exact gap's rate: d/dt (Jc[0] dtheta) at fixed dtheta
        g = _richardson(lambda h: ReferenceModel(model).contact_jacobian(name, th + h * dth)[0]
                        @ dth)
        assert mech.contact_jacobian_dot(name, th, dth)[0] @ dth == pytest.approx(
            g, abs=1e-8 * max(1.0, abs(g)))


def test_sphere_contacts_between_two_moving_bodies_in_space_and_plane():
    for planar in (True, False):
        d = 2 if planar else 3
        b = ModelBuilder(planar=planar, gravity=np.eye(d)[1] * -9.81)
        rev = Joint.revolute() if planar else Joint.revolute((0.3, 0.2, 1.0))
        b.add_body("a", "ground", rev, 1.0, np.eye(d)[0] * 0.5, 0.1 if planar else [0.1] * 3)
        b.add_body("b", "a", Joint.free(), 2.0, np.zeros(d), 0.2 if planar else [0.2, 0.3, 0.4],
                   joint_origin=np.eye(d)[0])
        b.add_contact("ab", "b", np.eye(d)[1] * 0.1, radius=0.05, against="a",
                      sphere_center=np.eye(d)[0] * 0.8, sphere_radius=0.1)
        model = b.build()
        mech = model.mechanism()
        rng = np.random.default_rng(3)
        for _ in range(5):
            th = rng.normal(size=model.n_coordinates)
            dth = rng.normal(size=model.n_coordinates)
            ref = ReferenceModel(model).contact_frame("ab", th)
            _close(mech.contact_jacobian("ab", th), ref.jacobian)
            fd = _richardson(lambda h: ReferenceModel(model).contact_jacobian("ab", th + h * dth))
            _close(mech.contact_jacobian_dot("ab", th, dth), fd, 1e-8)


# -- Pinocchio ------------------------------------------------------------------------------------
def _skew(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


@pytest.mark.parametrize("planar,chain,seed", CASES)
def test_against_pinocchio(planar, chain, seed):
    pin = pytest.importorskip("pinocchio")
    from convimpact.model import pinocchio_adapter as pa
    model, th, dth = _case(planar, chain, seed)
    mech = model.mechanism()
    pm, perm = pa.to_pinocchio(model)
    inv = np.argsort(perm)
    back = np.ix_(inv, inv)
    # the contact points of body i as frames (point contacts: material points)
    lift = (lambda v: np.array([v[0], v[1], 0.0])) if planar else (lambda v: np.asarray(v))
    frames = {}
    for spec in model.contacts:
        fr = mech.contact_frame(spec.name, th)
        body = model.bodies[spec.body].name
        R, p = mech.body_placement(body, th)
        f0 = pm.frames[pm.getFrameId(body)]
        local = pin.SE3(np.eye(3), lift(R.T @ (fr.point - p)))
        frames[spec.name] = pm.addFrame(pin.Frame("x:" + spec.name, f0.parentJoint,
                                                  f0.placement * local, pin.FrameType.OP_FRAME))
    pd = pm.createData()
    q, v = th[perm], dth[perm]
    M = np.array(pin.crba(pm, pd, q)).reshape(pm.nv, pm.nv)
    M = np.triu(M) + np.triu(M, 1).T
    _close(mech.mass_matrix(th), M[back])
    f = -np.array(pin.rnea(pm, pd, q, v, np.zeros_like(v)))[inv]
    _close(mech.generalized_forces(0.0, th, dth), f)
    Cor = np.array(pin.computeCoriolisMatrix(pm, pd, q, v)).reshape(pm.nv, pm.nv)
    _close(mech.mass_matrix_dot(th, dth), (Cor + Cor.T)[back], 1e-11)
    _close(mech.momentum_rate(0.0, th, dth), f + ((Cor + Cor.T) @ v)[inv], 1e-11)
    pin.computeJointJacobiansTimeVariation(pm, pd, q, v)
    pin.updateFramePlacements(pm, pd)
    rows = slice(0, 2) if planar else slice(0, 3)
    for spec in model.contacts:
        fid = frames[spec.name]
        nv = pm.nv
        Jw = np.array(pin.getFrameJacobian(pm, pd, fid, pin.WORLD)).reshape(6, nv)
        dJw = np.array(pin.getFrameJacobianTimeVariation(pm, pd, fid, pin.WORLD)).reshape(6, nv)
        x = pd.oMf[fid].translation
        J = (Jw[:3] - _skew(x) @ Jw[3:])[:, inv]  # the point's linear Jacobian
        xdot = (Jw[:3] - _skew(x) @ Jw[3:]) @ v
        dJ = (dJw[:3] - _skew(xdot) @ Jw[3:] - _skew(x) @ dJw[3:])[:, inv]
        fr = mech.contact_frame(spec.name, th)
        E = np.array([lift(fr.normal)] + [lift(t) for t in fr.tangents])
        own = model.bodies[spec.body]
        # body i's material point at x: our point Jacobian and its rate
        forward_kinematics(model, mech.data, th, dth)
        Jv, _ = point_jacobian(model, mech.data, own.index, fr.point)
        dJv, _ = point_jacobian_dot(model, mech.data, own.index, fr.point)
        _close(Jv, J[rows])
        _close(dJv, dJ[rows])
        if spec.other == 0 and spec.target == "plane":
            # x = c - r n moves with the centre c: d/dt J(x) = J_dot(x) - [u]x J_w,
            # u = x_dot - v(x) = r w x n
            u = spec.radius * np.cross(Jw[3:] @ v, lift(fr.normal))
            dJx = dJ - (_skew(u) @ Jw[3:])[:, inv]
            _close(mech.contact_jacobian(spec.name, th), (E @ J)[rows])
            _close(mech.contact_jacobian_dot(spec.name, th, dth), (E @ dJx)[rows])


# -- entry points, caching, validation ------------------------------------------------------------
@pytest.mark.parametrize("planar", [True, False])
def test_unchecked_entry_points_agree_and_the_cache_is_exact(planar):
    model, th, dth = _case(planar, False, 1, n_bodies=6)
    mech = model.mechanism()
    ref = ReferenceModel(model)
    th2 = th + 0.1
    for _ in range(3):  # alternate two states: every quantity follows the state asked for
        for state in (th, th2):
            d = mech.rhs_positions(state)
            assert d.chol_ok
            _close(d.M, ref.mass_matrix(state))
            _close(d.L @ d.L.T, d.M)
            for i, name in enumerate(model.contact_names):
                _close(d.contact_jacobian[i, :model.dim], ref.contact_jacobian(name, state))
                assert d.gap[i] == pytest.approx(ref.contact_gap(name, state), abs=TOL)
            f, pdot, d = mech.rhs_velocities(0.2, state, dth, True)
            _close(f, ref.generalized_forces(0.2, state, dth))
            _close(pdot, f + ref.mass_matrix_dot(state, dth) @ dth, 1e-11)
            _close(mech.mass_matrix(state), ref.mass_matrix(state))
            _close(mech.contact_jacobian_dot(model.contact_names[0], state, dth),
                   d.contact_jacobian_dot[0, :model.dim])


def test_bad_input_is_refused_and_leaves_no_stale_state():
    model, th, dth = _case(False, False, 2, n_bodies=3)
    mech = model.mechanism()
    M0 = mech.mass_matrix(th)
    bad = th.copy()
    bad[1] = np.nan
    with pytest.raises(NonFiniteError, match="theta"):
        mech.mass_matrix(bad)
    assert mech.data.theta is None  # nothing half-computed is kept
    f0 = mech.generalized_forces(0.0, th, dth)
    with pytest.raises(NonFiniteError, match="dtheta"):
        mech.generalized_forces(0.0, th, np.full_like(dth, np.inf))
    assert mech.data.dtheta is None and mech.data.theta is not None
    with pytest.raises(ShapeError, match="shape"):
        mech.mass_matrix(th[:-1])
    _close(mech.mass_matrix(th), M0)
    _close(mech.mass_matrix(list(th)), M0)  # any sequence of numbers
    _close(mech.generalized_forces(0.0, th, dth), f0)


def test_coincident_sphere_centres_are_refused():
    b = ModelBuilder(planar=True)
    b.add_body("a", "ground", Joint.translation(), 1.0, (0, 0), 0.1)
    b.add_contact("s", "a", (0.0, 0.0), radius=0.1, sphere_center=(0.0, 0.0), sphere_radius=0.1)
    mech = b.build().mechanism()
    with pytest.raises(SingularSystemError, match="coincide"):
        mech.contact_jacobian("s", np.zeros(2))
    assert mech.contact_gap("s", np.array([1.0, 0.0])) == pytest.approx(0.8)


def test_bodies_welded_to_the_ground_and_models_without_contacts():
    b = ModelBuilder(planar=False)
    b.add_body("base", "ground", Joint.fixed(), 3.0, (0, 0.1, 0), [0.1, 0.2, 0.25],
               joint_origin=(0.5, 0, 0))
    b.add_body("arm", "base", Joint.revolute((0, 0, 1)), 1.0, (0.3, 0, 0), [0.01, 0.05, 0.05],
               joint_origin=(0, 0.2, 0))
    b.add_body("tool", "arm", Joint.fixed(), 0.5, (0.1, 0, 0), [0.01, 0.01, 0.01],
               joint_origin=(0.6, 0, 0))
    model = b.build()
    mech, ref = model.mechanism(), ReferenceModel(model)
    th, dth = np.array([0.7]), np.array([-1.3])
    _close(mech.mass_matrix(th), ref.mass_matrix(th))
    _close(mech.generalized_forces(0.0, th, dth), ref.generalized_forces(0.0, th, dth))
    _close(mech.mass_matrix_dot(th, dth), ref.mass_matrix_dot(th, dth))
    assert mech.potential_energy(th) == pytest.approx(ref.potential_energy(th), abs=TOL)


def test_flags_and_their_prerequisites():
    closure = rc.closures()
    assert closure[rc.CONTACT] == rc.CONTACT | rc.CPOS
    assert closure[rc.BIAS] == rc.BIAS | rc.VEL | rc.INERTIA | rc.POS
    assert closure[rc.CDOT] & (rc.POS | rc.CONTACT | rc.VEL) == rc.POS | rc.CONTACT | rc.VEL
    assert all(closure[f] & f == f for f in range(rc.N_FLAGS))


def test_pickled_and_copied_mechanisms_keep_their_views():
    import copy
    import pickle
    model, th, dth = _case(False, True, 4, n_bodies=4)
    mech = model.mechanism()
    M0 = mech.mass_matrix(th)
    for twin in (pickle.loads(pickle.dumps(mech)), copy.deepcopy(mech)):
        _close(twin.mass_matrix(th), M0)
        _close(twin.mass_matrix(th + 0.3), mech.mass_matrix(th + 0.3))
        _close(twin.generalized_forces(0.0, th, dth), mech.generalized_forces(0.0, th, dth))
