"""Cross-check of our models against Pinocchio (an independent implementation), and the adapter.

Random planar and spatial trees are exported with ``to_pinocchio``; Pinocchio's CRBA, RNEA,
Coriolis matrix, frame Jacobians and potential energy must agree with our M, f, M_dot, B, Jc
and V to 1e-10. A double pendulum written directly in Pinocchio reproduces our scene.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

import convimpact as ci  # noqa: E402
from convimpact.errors import ModelError, NotSupportedError  # noqa: E402
from convimpact.mechanism import Mechanism  # noqa: E402
from convimpact.model import resolve_mechanism_impact  # noqa: E402
from convimpact.model import impact_arguments as model_impact_arguments  # noqa: E402
from convimpact.model import pinocchio_adapter as pa  # noqa: E402
from convimpact.model.random import random_model  # noqa: E402
from convimpact.scenes import load_scene  # noqa: E402

TOL = 1e-10
CASES = [(planar, seed) for planar in (True, False) for seed in range(8)]


def _pair(planar, seed):
    rng = np.random.default_rng(1000 + seed)
    kinds = ("revolute", "prismatic", "free", "fixed", "translation")
    if not planar:
        kinds += ("universal",)
    model, theta = random_model(rng, planar, n_bodies=5, joint_kinds=kinds, n_contacts=4)
    pm, perm = pa.to_pinocchio(model)
    return model, model.mechanism(), theta, rng.normal(size=theta.size), pm, pm.createData(), perm


def _lift(model, v):
    return np.array([v[0], v[1], 0.0]) if model.planar else v


@pytest.mark.parametrize("planar,seed", CASES)
def test_dynamics_agree_with_pinocchio(planar, seed):
    model, mech, th, dth, pm, pd, perm = _pair(planar, seed)
    inv = np.argsort(perm)
    q, v = th[perm], dth[perm]
    back = np.ix_(inv, inv)
    M = mech.mass_matrix(th)
    assert np.allclose(pa.mass_matrix(pm, pd, q)[back], M, atol=TOL, rtol=0)
    f = -np.array(pin.nonLinearEffects(pm, pd, q, v))[inv]
    assert np.allclose(mech.generalized_forces(0.0, th, dth), f, atol=TOL * max(1, np.abs(f).max()))
    Cor = np.array(pin.computeCoriolisMatrix(pm, pd, q, v))
    assert np.allclose(mech.mass_matrix_dot(th, dth), (Cor + Cor.T)[back], atol=TOL * 10)
    # Pinocchio leaves bodies welded to the ground out of its potential (a constant for us)
    welded = sum(-b.mass * model.gravity @ mech.body_placement(b.name, th)[1]
                 - b.mass * model.gravity @ (mech.body_placement(b.name, th)[0] @ b.com)
                 for b in model.bodies[1:] if not model.support[b.index].any())
    assert mech.potential_energy(th) - welded == pytest.approx(
        pin.computePotentialEnergy(pm, pd, q), abs=TOL)


@pytest.mark.parametrize("planar,seed", CASES)
def test_jacobians_agree_with_pinocchio(planar, seed):
    model, mech, th, dth, pm, pd, perm = _pair(planar, seed)
    inv = np.argsort(perm)
    q = th[perm]
    pin.computeJointJacobians(pm, pd, q)
    pin.updateFramePlacements(pm, pd)
    rows = slice(0, 2) if planar else slice(0, 3)
    for body in model.bodies[1:]:
        fid = pm.getFrameId(body.name)
        R, p = mech.body_placement(body.name, th)
        assert np.allclose(pd.oMf[fid].translation[rows], p, atol=TOL)
        J = np.array(pin.getFrameJacobian(pm, pd, fid, pin.LOCAL_WORLD_ALIGNED))[:, inv]
        Jv = mech.point_jacobian(body.name, np.zeros(model.dim), th)
        assert np.allclose(J[rows], Jv, atol=TOL)
        # angular rows of B at the body's centre of mass (z row for planar models)
        B = mech.velocity_transformation(th)
        d, r = model.dim, model.rot_dim
        blk = (body.index - 1) * (d + r)
        ang = J[5:6] if planar else J[3:6]
        assert np.allclose(B[blk + d:blk + d + r], ang, atol=TOL)
    for spec in model.contacts:
        fr = mech.contact_frame(spec.name, th)
        bi = model.bodies[spec.body].name
        Ri, pi_ = mech.body_placement(bi, th)
        local = _lift(model, Ri.T @ (fr.point - pi_))
        other = None if spec.other == 0 else model.bodies[spec.other].name
        tangent = None if planar else fr.tangents[0]
        Jc = pa.contact_jacobian(pm, pd, q, bi, _lift(model, fr.normal), tangent,
                                 other_frame=other, local_point=local, planar=planar)[:, inv]
        if spec.target == "sphere":  # our Jc uses body j's own contact point, r_j n beyond
            xj = fr.point - fr.gap * fr.normal
            Rj, pj = mech.body_placement(other, th)
            Jj_ours = mech.point_jacobian(other, Rj.T @ (xj - pj), th)
            Jj_same = mech.point_jacobian(other, Rj.T @ (fr.point - pj), th)
            basis = np.vstack([fr.normal[None], fr.tangents])
            Jc = Jc - basis @ (Jj_ours - Jj_same)  # shift body j's point to ours
        assert np.allclose(mech.contact_jacobian(spec.name, th), Jc, atol=TOL)


def _pinocchio_double_pendulum(spatial: bool):
    """The Section 9.2/9.3 pendulum written directly in Pinocchio (no conversion code)."""
    m, L = 1.0, 1.0
    pm = pin.Model()
    pm.gravity = pin.Motion(np.array([0.0, -9.81, 0.0, 0, 0, 0]))
    parent = 0
    if spatial:  # massless base turning about y
        parent = pm.addJoint(0, pin.JointModelRY(), pin.SE3.Identity(), "base")
    inertia = pin.Inertia(m, np.array([L / 2, 0, 0]), np.diag([0.0, m * L * L / 12, m * L * L / 12]))
    j1 = pm.addJoint(parent, pin.JointModelRZ(), pin.SE3.Identity(), "j1")
    pm.appendBodyToJoint(j1, inertia, pin.SE3.Identity())
    j2 = pm.addJoint(j1, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([L, 0, 0])), "j2")
    pm.appendBodyToJoint(j2, inertia, pin.SE3.Identity())
    pm.addFrame(pin.Frame("tip", j2, pin.SE3(np.eye(3), np.array([L, 0, 0])), pin.FrameType.OP_FRAME))
    return pm


def test_pinocchio_pendulum_reproduces_the_scene_and_the_paper():
    scene = load_scene("pendulum_3d", e=0.5, mu=0.3)
    th, dth = scene.impact_state
    pm = _pinocchio_double_pendulum(spatial=True)
    floor_y = scene.parameters["floor_y"]
    contact = pa.PinocchioContact("tip", "tip", normal=(0, 1, 0), plane_point=(0, floor_y, 0),
                                  tangent=(-1, 0, 0), e=0.5, mu=0.3)
    pmech = pa.PinocchioMechanism(pm, contacts=[contact])
    assert isinstance(pmech, Mechanism)
    assert pmech.contact_gap("tip", th) == pytest.approx(0.0, abs=1e-12)
    ours = model_impact_arguments(scene.mechanism, th, dth, contacts=["tip"])
    theirs = model_impact_arguments(pmech, th, dth, contacts=["tip"])
    assert np.allclose(ours["M"], theirs["M"], atol=TOL)
    assert np.allclose(ours["Jc"][0], theirs["Jc"][0], atol=TOL)
    assert np.round(theirs["Jc"][0] @ dth, 3).tolist() == [-1.309, -2.683, 0.809]
    direct = pa.impact_arguments(pm, pm.createData(), th, dth, [contact])
    assert np.allclose(direct["Jc"][0], ours["Jc"][0], atol=TOL)
    r = resolve_mechanism_impact(pmech, th, dth, contacts="tip")
    assert (ours["Jc"][0] @ r.dq_plus)[0] == pytest.approx(0.5 * 1.309017, rel=1e-5)
    # the Mechanism protocol's dynamics agree too
    assert np.allclose(pmech.generalized_forces(0.0, th, dth),
                       scene.mechanism.generalized_forces(0.0, th, dth), atol=TOL)
    assert np.allclose(pmech.mass_matrix_dot(th, dth), scene.mechanism.mass_matrix_dot(th, dth),
                       atol=TOL)
    assert pmech.potential_energy(th) == pytest.approx(scene.mechanism.potential_energy(th))
    with pytest.raises(ModelError, match="unknown contact"):
        pmech.contact_jacobian("heel", th)


def test_point_loop_closure_against_finite_differences_and_our_loop():
    rng = np.random.default_rng(7)
    model, th = random_model(rng, False, n_bodies=7, joint_kinds=("revolute",), n_contacts=0,
                             loop="spherical", chain=True)
    mech = model.mechanism()
    pm, perm = pa.to_pinocchio(model)
    inv = np.argsort(perm)
    lp = model.loops[0]
    # frames at the two cut-joint origins
    b_a = model.bodies[lp.body_a].name
    jid = pm.frames[pm.getFrameId(b_a)].parentJoint
    off = pm.frames[pm.getFrameId(b_a)].placement
    pm.addFrame(pin.Frame("cut_a", jid, off * pin.SE3(np.eye(3), lp.origin_a), pin.FrameType.OP_FRAME))
    pm.addFrame(pin.Frame("cut_b", 0, pin.SE3(np.eye(3), lp.origin_b), pin.FrameType.OP_FRAME))
    pmech = pa.PinocchioMechanism(pm, loops=[("cut_a", "cut_b")])
    th = th + 0.05 * rng.normal(size=th.size)
    dth = rng.normal(size=th.size)
    q, v = th[perm], dth[perm]
    assert np.allclose(pmech.loop_residual(q), mech.loop_residual(th), atol=TOL)
    C = pmech.loop_jacobian(q)[:, inv]
    assert np.allclose(C, mech.loop_jacobian(th), atol=TOL)
    h = 1e-6
    Cd_fd = (pmech.loop_jacobian(q + h * v) - pmech.loop_jacobian(q - h * v)) / (2 * h)
    assert np.allclose(pmech.loop_jacobian_dot(q, v), Cd_fd, atol=1e-7)
    assert np.allclose(pmech.loop_jacobian_dot(q, v)[:, inv], mech.loop_jacobian_dot(th, dth), atol=TOL)


def test_quaternion_models_are_refused_by_the_mechanism_but_not_for_impacts():
    pm = pin.Model()
    j = pm.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
    pm.appendBodyToJoint(j, pin.Inertia.FromBox(2.0, 0.2, 0.3, 0.4), pin.SE3.Identity())
    pm.addFrame(pin.Frame("corner", j, pin.SE3(np.eye(3), np.array([0.1, -0.15, 0.2])),
                          pin.FrameType.OP_FRAME))
    with pytest.raises(NotSupportedError, match="nq = 7"):
        pa.PinocchioMechanism(pm)
    q = pin.neutral(pm)
    v = np.array([0.0, -1.0, 0.0, 0.5, 0.0, 0.0])
    c = pa.PinocchioContact("corner", "corner", normal=(0, 1, 0), e=0.0, mu=0.0)
    args = pa.impact_arguments(pm, pm.createData(), q, v, [c])
    r = ci.resolve_impact(**args)
    assert (args["Jc"][0] @ r.dq_plus)[0] == pytest.approx(0.0, abs=1e-12)  # plastic
    # by hand: v_y + (w x r)_y = v_y + w_z r_x - w_x r_z, w = (0.5, 0, 0), r = (0.1, -0.15, 0.2)
    assert (args["Jc"][0] @ v)[0] == pytest.approx(-1.0 - 0.5 * 0.2)
    with pytest.raises(ModelError, match="no frame"):
        pa.contact_jacobian(pm, pm.createData(), q, "nose", (0, 1, 0))


def test_missing_pinocchio_gives_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "pinocchio", None)
    with pytest.raises(pa.PinocchioUnavailableError, match="pip install convimpact\\[pinocchio\\]"):
        pa.mass_matrix(None, None, np.zeros(1))
    assert issubclass(pa.PinocchioUnavailableError, ImportError)
    assert issubclass(pa.PinocchioUnavailableError, NotSupportedError)
