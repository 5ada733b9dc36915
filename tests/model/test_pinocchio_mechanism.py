"""The Pinocchio-backed mechanism against our own backend, finite differences and closed forms.

Our models (ModelBuilder) are exported with ``to_pinocchio`` (an independent implementation:
Pinocchio's CRBA, RNEA, Coriolis matrix and Jacobians) and wrapped as PinocchioMechanism with the
same contacts; M, f, M_dot, gaps, contact Jacobians and their rates, energies agree to 1e-10,
and impacts and simulations agree with our backend's. J_dot and M_dot are checked by central
differences on the Solo-12 quadruped of example-robot-data (free base, 18 coordinates); a
one-link URDF written here gives closed forms.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

import convimpact as ci  # noqa: E402
from convimpact.bench.model_problems import dropped_chain, random_mechanism  # noqa: E402
from convimpact.errors import (ModelError, NotSupportedError, ParameterError,  # noqa: E402
                                      ShapeError)
from convimpact.mechanism import Mechanism  # noqa: E402
from convimpact.model import impact_arguments, resolve_mechanism_impact  # noqa: E402
from convimpact.model import pinocchio_adapter as pa  # noqa: E402
from convimpact.model import pinocchio_robots as robots  # noqa: E402
from convimpact.model.pinocchio_mechanism import PinocchioMechanism, root_joint  # noqa: E402
from convimpact.model.random import random_model  # noqa: E402

TOL = 1e-10


def solo12_or_skip():
    """Solo-12, or skip when the registry package example-robot-data is not installed."""
    try:
        return robots.solo12()
    except robots.RobotDataUnavailableError:
        pytest.skip("the robot models need example-robot-data (pip install -e \".[test-full]\")")


def twin(model):
    """(PinocchioMechanism of ``model``'s contacts, permutation q = theta[perm])."""
    pm, perm = pa.to_pinocchio(model)
    contacts = [pa.PinocchioContact(s.name, model.bodies[s.body].name, normal=s.normal,
                                    plane_point=s.other_point, tangent=s.tangent,
                                    e=s.restitution, mu=s.friction, local_point=s.point)
                for s in model.contacts]
    return PinocchioMechanism(pm, contacts, planar=model.planar), np.asarray(perm)


def with_prismatic(planar: bool, seed: int):
    """A random tree of revolute and prismatic joints with two plane contacts."""
    rng = np.random.default_rng(50 + seed)
    model, theta = random_model(rng, planar, n_bodies=5, joint_kinds=("revolute", "prismatic"),
                                n_contacts=0)
    from convimpact.bench.model_problems import _rebuild
    b = _rebuild(model)
    d = model.dim
    for i, body in enumerate((model.bodies[-1], model.bodies[2])):
        normal = rng.normal(size=d)
        normal /= np.linalg.norm(normal)
        b.add_contact(f"c{i}", body.name, rng.normal(size=d) * 0.3, normal=normal,
                      plane_point=-normal * 2.0, e=0.3, mu=0.4)
    return b.build(), theta


CASES = ([("random", planar, chain, seed) for planar in (True, False) for chain in (True, False)
          for seed in (1, 2)] + [("prismatic", planar, False, seed) for planar in (True, False)
                                 for seed in (0, 1)])


def _case(kind, planar, chain, seed):
    if kind == "random":
        model, theta, _ = random_mechanism(6, planar, chain, seed)
    else:
        model, theta = with_prismatic(planar, seed)
    dtheta = np.random.default_rng(seed).normal(size=model.n_coordinates)
    return model, theta, dtheta


@pytest.mark.parametrize("kind,planar,chain,seed", CASES)
def test_every_term_equals_our_backend(kind, planar, chain, seed):
    model, th, dth = _case(kind, planar, chain, seed)
    ours = model.mechanism()
    theirs, perm = twin(model)
    assert isinstance(theirs, Mechanism)
    q, v = th[perm], dth[perm]
    inv = np.argsort(perm)
    back = np.ix_(inv, inv)
    M = ours.mass_matrix(th)
    scale = max(1.0, np.abs(M).max())
    assert np.allclose(theirs.mass_matrix(q)[back], M, atol=TOL * scale, rtol=0)
    assert np.allclose(theirs.mass_matrix_dot(q, v)[back], ours.mass_matrix_dot(th, dth),
                       atol=TOL * 10 * scale, rtol=0)
    f = ours.generalized_forces(0.0, th, dth)
    assert np.allclose(theirs.generalized_forces(0.0, q, v)[inv], f,
                       atol=TOL * max(1.0, np.abs(f).max()), rtol=0)
    assert np.allclose(theirs.momentum_rate(0.0, q, v)[inv], ours.momentum_rate(0.0, th, dth),
                       atol=TOL * 10 * max(1.0, np.abs(f).max()), rtol=0)
    assert theirs.kinetic_energy(q, v) == pytest.approx(ours.kinetic_energy(th, dth), abs=TOL)
    assert theirs.potential_energy(q) == pytest.approx(ours.potential_energy(th), abs=TOL * 10)
    assert theirs.contact_names == ours.contact_names
    for c in ours.contact_names:
        assert theirs.contact_gap(c, q) == pytest.approx(ours.contact_gap(c, th), abs=TOL)
        J = ours.contact_jacobian(c, th)
        assert J.shape == (2 if planar else 3, model.n_coordinates)
        assert np.allclose(theirs.contact_jacobian(c, q)[:, inv], J, atol=TOL, rtol=0)
        assert np.allclose(theirs.contact_jacobian_dot(c, q, v)[:, inv],
                           ours.contact_jacobian_dot(c, th, dth), atol=TOL * 10, rtol=0)
        assert theirs.contact_parameters(c) == ours.contact_parameters(c)


@pytest.fixture(scope="module")
def solo():
    return solo12_or_skip()


def _solo_state(mech, seed=0):
    rng = np.random.default_rng(seed)
    th = robots.solo12_standing(mech, 0.05) + rng.normal(scale=0.2, size=mech.n_coordinates)
    return th, rng.normal(size=mech.n_coordinates)


def test_solo12_rates_match_central_differences(solo):
    th, dth = _solo_state(solo)
    h = 1e-6
    Mdot = (solo.mass_matrix(th + h * dth) - solo.mass_matrix(th - h * dth)) / (2 * h)
    assert np.allclose(solo.mass_matrix_dot(th, dth), Mdot, atol=1e-7)
    for c in solo.contact_names:
        Jd = (solo.contact_jacobian(c, th + h * dth) - solo.contact_jacobian(c, th - h * dth)) / (2 * h)
        assert np.allclose(solo.contact_jacobian_dot(c, th, dth), Jd, atol=1e-7)
        # d(gap)/dt = normal row . theta_dot
        dg = (solo.contact_gap(c, th + h * dth) - solo.contact_gap(c, th - h * dth)) / (2 * h)
        assert solo.contact_jacobian(c, th)[0] @ dth == pytest.approx(dg, abs=1e-8)
    # gravity: f at rest is -dV/dtheta
    grad = np.array([(solo.potential_energy(th + h * e) - solo.potential_energy(th - h * e)) / (2 * h)
                     for e in np.eye(solo.n_coordinates)])
    assert np.allclose(solo.generalized_forces(0.0, th, np.zeros_like(th)), -grad, atol=1e-7)


def test_solo12_free_base_carries_the_urdf_mass(solo):
    urdf = ET.parse(robots.robot_file("solo_description/robots/solo12.urdf"))
    mass = sum(float(m.get("value")) for m in urdf.iter("mass"))
    th, dth = _solo_state(solo, 1)
    M = solo.mass_matrix(th)
    assert solo.n_coordinates == 18
    assert solo.coordinate_names[:6] == ("base_x", "base_y", "base_z", "base_yaw", "base_pitch",
                                         "base_roll")
    assert list(solo.model.names)[1:7] == list(solo.coordinate_names[:6])
    assert np.allclose(M[:3, :3], mass * np.eye(3), atol=1e-12)  # translation block: total mass
    # a pure translation of the base moves every foot by the same amount, gaps by dz
    e = np.zeros(18)
    e[2] = 0.01
    for c in solo.contact_names:
        assert solo.contact_gap(c, th + e) - solo.contact_gap(c, th) == pytest.approx(0.01, abs=1e-14)
        assert np.allclose(solo.contact_jacobian(c, th)[:, :3], np.array([[0, 0, 1.0], [1.0, 0, 0],
                                                                          [0, 1.0, 0]]), atol=1e-14)
    # the potential energy is m g z_com
    V0 = solo.potential_energy(th)
    assert solo.potential_energy(th + e) - V0 == pytest.approx(mass * 9.81 * 0.01, rel=1e-12)


ONE_LINK = """<robot name="one_link">
  <link name="base"/>
  <link name="rod">
    <inertial><origin xyz="0 0 -{L}"/><mass value="{m}"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial>
  </link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="rod"/>
    <axis xyz="0 1 0"/><limit lower="-10" upper="10" effort="1" velocity="1"/></joint>
  <link name="tip"/>
  <joint name="tip_joint" type="fixed"><parent link="rod"/><child link="tip"/>
    <origin xyz="0 0 -{L}"/></joint>
</robot>"""


def test_a_urdf_string_gives_the_closed_forms():
    m, L = 2.0, 0.5
    c = pa.PinocchioContact("tip", "tip", normal=(0, 0, 1), plane_point=(0, 0, -0.6),
                            tangent=(1, 0, 0), e=0.5, mu=0.2)
    mech = PinocchioMechanism.from_urdf(ONE_LINK.format(m=m, L=L), contacts=[c])
    for a in (0.0, 0.4, -1.1):
        th, dth = np.array([a]), np.array([1.5])
        assert mech.mass_matrix(th)[0, 0] == pytest.approx(0.02 + m * L * L, rel=1e-12)
        # rotation about +y by a: the tip at L(-sin a, 0, -cos a)
        assert mech.contact_gap("tip", th) == pytest.approx(0.6 - L * np.cos(a), abs=1e-14)
        J = mech.contact_jacobian("tip", th)
        assert np.allclose(J[:, 0], [L * np.sin(a), -L * np.cos(a), 0.0], atol=1e-14)
        Jd = mech.contact_jacobian_dot("tip", th, dth)
        assert np.allclose(Jd[:, 0], 1.5 * np.array([L * np.cos(a), L * np.sin(a), 0.0]),
                           atol=1e-14)
        assert mech.potential_energy(th) == pytest.approx(-m * 9.81 * L * np.cos(a), abs=1e-12)
        assert mech.generalized_forces(0, th, dth)[0] == pytest.approx(-m * 9.81 * L * np.sin(a),
                                                                       abs=1e-12)
    assert mech.coordinate_names == ("hinge",)


def test_impacts_agree_with_our_backend():
    model, th, dth = _case("random", False, False, 1)
    theirs, perm = twin(model)
    ours = model.mechanism()
    args_ours = impact_arguments(ours, th, dth, contacts="tip")
    args_theirs = impact_arguments(theirs, th[perm], dth[perm], contacts="tip")
    inv = np.argsort(perm)
    dq = args_ours["dq"]
    if np.asarray(args_ours["Jc"]).reshape(-1, dq.size)[0] @ dq > 0:
        dq = -dq
    r1 = ci.resolve_impact(args_ours["M"], args_ours["Jc"], dq, e=0.4, mu=0.3)
    r2 = ci.resolve_impact(args_theirs["M"], args_theirs["Jc"], dq[perm], e=0.4, mu=0.3)
    assert r1.regime == r2.regime
    assert np.allclose(r2.impulse, r1.impulse, atol=1e-9)
    assert np.allclose(r2.dq_plus[inv], r1.dq_plus, atol=1e-9)
    # Solo-12 landing on four feet at once: the Pinocchio-backed mechanism straight in
    solo = solo12_or_skip()
    th = robots.solo12_standing(solo, 0.0)
    dth = np.zeros(18)
    dth[2] = -1.0  # falling at 1 m/s
    res = resolve_mechanism_impact(solo, th, dth, e=0.0)
    assert len(res.impulse) == 4
    for c in solo.contact_names:  # no foot still approaches
        assert solo.contact_jacobian(c, th)[0] @ res.dq_plus > -1e-8
    assert solo.kinetic_energy(th, res.dq_plus) < solo.kinetic_energy(th, dth)


@pytest.mark.parametrize("planar", [True, False])
def test_simulation_agrees_with_our_backend(planar):
    model, th0, dth0 = dropped_chain(3, planar)
    theirs, perm = twin(model)
    assert np.array_equal(perm, np.arange(model.n_coordinates))
    ours = ci.simulate(model.mechanism(), (0.0, 0.5), (th0, dth0))
    res = ci.simulate(theirs, (0.0, 0.5), (th0, dth0))
    assert res.status == ours.status == 0
    assert len(res.impacts) == len(ours.impacts) >= 1
    assert [i.time for i in res.impacts] == pytest.approx([i.time for i in ours.impacts], abs=1e-7)
    assert np.allclose(res.theta[-1], ours.theta[-1], atol=1e-6)
    assert np.allclose(res.dtheta[-1], ours.dtheta[-1], atol=1e-5)


def test_bad_input_raises_clear_errors(monkeypatch, tmp_path):
    model, _, _ = dropped_chain(2, False)
    pm, _ = pa.to_pinocchio(model)
    with pytest.raises(ModelError, match="no frame 'nope'"):
        PinocchioMechanism(pm, [pa.PinocchioContact("c", "nope", normal=(0, 1, 0))])
    with pytest.raises(ParameterError, match="e must be in"):
        PinocchioMechanism(pm, [pa.PinocchioContact("c", "link1", normal=(0, 1, 0), e=2.0)])
    with pytest.raises(ModelError, match="planar"):
        PinocchioMechanism(pm, [pa.PinocchioContact("c", "link1", normal=(0, 1, 0))], planar=True)
    mech = PinocchioMechanism(pm, [pa.PinocchioContact("c", "link1", normal=(0, 1, 0))])
    with pytest.raises(ModelError, match="unknown contact 'd'"):
        mech.contact_gap("d", np.zeros(3))
    with pytest.raises(ShapeError):
        mech.mass_matrix(np.zeros(2))
    with pytest.raises(ci.ConvImpactError, match="non-finite"):
        mech.mass_matrix(np.array([0.0, np.nan, 0.0]))
    solo12_or_skip()
    path = robots.robot_file("solo_description/robots/solo12.urdf")
    with pytest.raises(NotSupportedError, match="root_joint='free'"):
        PinocchioMechanism(pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer()))
    with pytest.raises(NotSupportedError, match="Coriolis"):  # inexact in Pinocchio: refused
        PinocchioMechanism(pin.buildModelFromUrdf(str(path), pin.JointModelSphericalZYX()))
    with pytest.raises(ParameterError, match="free-flyer"):
        root_joint("freeflyer")
    with pytest.raises(ModelError, match="no URDF file"):
        PinocchioMechanism.from_urdf(tmp_path / "missing.urdf")
    with pytest.raises(ModelError, match="no file"):
        robots.robot_file("no_description/robots/none.urdf")
    # example-robot-data missing: a typed error that says what to install
    from importlib import metadata

    def missing(name):
        raise metadata.PackageNotFoundError(name)
    monkeypatch.setattr(metadata, "distribution", missing)
    monkeypatch.setitem(__import__("sys").modules, "cmeel", None)
    robots.robot_data_dir.cache_clear()
    try:
        with pytest.raises(robots.RobotDataUnavailableError, match="pip install example-robot-data"):
            robots.solo12()
    finally:
        robots.robot_data_dir.cache_clear()


def test_planar_root_and_mjcf(tmp_path):
    mjcf = tmp_path / "box.xml"
    mjcf.write_text("""<mujoco><worldbody><body name="box" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 0 1"/>
      <inertial pos="0.5 0 0" mass="3" diaginertia="0.1 0.1 0.2"/>
      </body></worldbody></mujoco>""")
    mech = PinocchioMechanism.from_mjcf(mjcf)
    assert mech.n_coordinates == 1
    assert mech.mass_matrix(np.zeros(1))[0, 0] == pytest.approx(0.2 + 3 * 0.25, rel=1e-12)
    planar = PinocchioMechanism.from_urdf(ONE_LINK.format(m=1.0, L=0.5), root_joint="planar",
                                          planar=False)
    assert planar.coordinate_names == ("base_x", "base_y", "base_angle", "hinge")
    M = planar.mass_matrix(np.zeros(4))
    assert np.allclose(M[:2, :2], np.eye(2), atol=1e-14)  # one body of 1 kg, free in x and y


def test_landscapes_accept_the_pinocchio_mechanism():
    from convimpact.studies.landscape import law_landscape
    model, th, dth = dropped_chain(3, True)
    theirs, perm = twin(model)
    th = th + np.array([0.0, -0.4, 0.3])
    dth = np.array([-1.0, 0.5, 0.2])
    grids = dict(e=[0.0, 0.5], mu=[0.1, 0.6], law="coulomb", progress=False)
    a = impact_arguments(model.mechanism(), th, dth, contacts="tip")
    b = impact_arguments(theirs, th, dth, contacts="tip")
    La = law_landscape(a["M"], a["Jc"], a["dq"], C=a["C"], **grids)
    Lb = law_landscape(b["M"], b["Jc"], b["dq"], C=b["C"], **grids)
    assert np.array_equal(La.regime, Lb.regime)
    assert np.allclose(La.energy_loss, Lb.energy_loss, atol=1e-10)
    assert np.allclose(La.v_plus, Lb.v_plus, atol=1e-10)
    assert np.all(La.normal_impulse > 0)  # the state strikes: the grid is not trivially zero
