"""The compiled right-hand side of the canonical equations with held contacts
(convimpact.simulation.canonical_kernels) and the sliding mode continued through a slip
reversal, against closed forms.

* A table on n legs sliding (all legs held, the normal rows beyond three dropped as
  redundant): ``theta_dot`` is the launch velocity and ``p_dot`` (eq. 14: the applied and
  friction forces; the held rows' normal forces live in the multipliers) has the
  translational part ``(-mu m g cos psi, -m g, -mu m g sin psi)``: the friction of legs whose
  normal forces total m g, along -v; at rest (sticking) ``p_dot`` is gravity alone.
* A stack of boxes at rest: every box's ``p_dot`` is its weight, ``(0, -m g, 0, 0, 0, 0)``.
* Runs: tables on 16 and 48 legs stop at ``v0 / (mu g)`` after ``v0^2 / (2 mu g)``, their
  recorded normal forces never tensile and totalling m g.
* Past a slip reversal a spatial slip keeps its stored direction (the mode's equations
  continued smoothly; the event ends the segment at the reversal).
* Secondary: the compiled path and the numpy path give the same numbers to round-off.
"""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.scenes import load_scene
from convimpact.simulation.canonical import CanonicalEquations, HeldMode
from convimpact.simulation.sustained import contact_state, held_modes, redundant_rows
from convimpact.simulation.force_solver import solve_contact_forces

G = 9.81


def _held_equations(scene, theta, dtheta):
    """The equations the run builds at an event: modes from the force problem, redundant
    rows dropped."""
    mech = scene.mechanism
    names = mech.contact_names
    cs = contact_state(mech, 0.0, theta, dtheta, names, 1e-6)
    sol = solve_contact_forces(cs.problem)
    modes = held_modes(cs, sol.modes, sol.direction)
    held = tuple(c for c in names if c in modes)
    probe = CanonicalEquations(mech, held, modes, dims=cs.dims)
    M = np.asarray(mech.mass_matrix(theta), float)
    dropped = redundant_rows(M, None, probe.rows, cs.jacobians)
    return CanonicalEquations(mech, held, modes, dropped, cs.dims, slip_floor=1e-6)


def _state(eq, theta, dtheta):
    return np.concatenate([theta, eq.momentum(theta, dtheta)])


@pytest.mark.parametrize("legs", [4, 16, 48])
def test_sliding_table_decelerates_at_mu_g(legs):
    m, mu, psi = 2.0, 0.3, np.radians(23.0)
    scene = load_scene("table", legs=legs, v0=0.6, mu=mu, mass=m)
    eq = _held_equations(scene, scene.theta0, scene.dtheta0)
    # three independent normal rows; every leg's normal force is an unknown of the sliding
    # group (its least-norm distribution)
    assert eq._compiled and len(eq.rows) == 3 and len(eq.slipping) == legs
    assert len(eq.redundant_slipping) == legs - 3
    ydot = eq(0.0, _state(eq, scene.theta0, scene.dtheta0))
    np.testing.assert_allclose(ydot[:6], scene.dtheta0, atol=1e-14)
    expected = np.array([-mu * m * G * np.cos(psi), -m * G, -mu * m * G * np.sin(psi)])
    np.testing.assert_allclose(ydot[6:9], expected, atol=1e-11 * m * G)


@pytest.mark.parametrize("legs", [3, 48])
def test_table_at_rest_is_in_equilibrium(legs):
    scene = load_scene("table", legs=legs, v0=0.0)
    eq = _held_equations(scene, scene.theta0, scene.dtheta0)
    assert all(eq.modes[c].kind == "stick" for c in eq.held)
    ydot = eq(0.0, _state(eq, scene.theta0, scene.dtheta0))
    np.testing.assert_allclose(ydot, [0] * 7 + [-2.0 * G] + [0] * 4, atol=1e-11 * 2.0 * G)


def test_box_stack_at_rest_is_in_equilibrium():
    scene = load_scene("box_stack")
    eq = _held_equations(scene, scene.theta0, scene.dtheta0)
    assert eq._compiled and len(eq.held) == 12
    ydot = eq(0.0, _state(eq, scene.theta0, scene.dtheta0))
    weight = np.tile([0.0, -1.0 * G, 0.0, 0.0, 0.0, 0.0], 3)  # 1 kg boxes
    np.testing.assert_allclose(ydot, np.r_[np.zeros(18), weight], atol=1e-11 * 3 * G)


@pytest.mark.parametrize("legs", [16, 48])
def test_many_legged_tables_stop_at_the_closed_form_time_and_distance(legs):
    m, mu, v0, psi = 2.0, 0.3, 0.6, np.radians(23.0)
    scene = load_scene("table", legs=legs, v0=v0, mu=mu, mass=m, t_end=0.3)
    t_stop, d_stop = v0 / (mu * G), v0 ** 2 / (2 * mu * G)
    res = ci.simulate(scene.mechanism, (0.0, 0.3), (scene.theta0, scene.dtheta0))
    assert res.status == 0, res.message
    for name in scene.mechanism.contact_names:
        ivs = res.modes_of(name)
        assert [iv.mode for iv in ivs] == ["slip", "stick"]
        assert ivs[1].t_start == pytest.approx(t_stop, rel=1e-8)
    np.testing.assert_allclose(res.theta[-1, [0, 2]],
                               d_stop * np.array([np.cos(psi), np.sin(psi)]), rtol=1e-8)
    np.testing.assert_allclose(res.theta[-1, 3:], 0.0, atol=1e-9)
    # unilateral supports: no recorded leg pulls (before the sliding mode was continued
    # through the stop, the steps crawling onto it recorded legs at -124 N on 48 legs)
    assert res.contact_force[:, :, 0].min() >= -1e-9 * m * G
    np.testing.assert_allclose(res.contact_force[1:, :, 0].sum(axis=1), m * G, rtol=1e-8)


def test_a_spatial_slip_past_its_reversal_keeps_its_stored_direction():
    scene = load_scene("table", legs=4, v0=0.6)
    s0 = (0.6, 0.8)
    modes = {c: HeldMode("slip", s0, 0.3) for c in scene.mechanism.contact_names}
    eq = CanonicalEquations(scene.mechanism, tuple(modes), modes, slip_floor=1e-6)
    jac = np.zeros((3, 6))
    jac[1, 0] = jac[2, 2] = 1.0  # tangents t1 = x, t2 = z
    forward = np.array([0.3, 0.0, 0.4, 0, 0, 0])  # slip velocity 0.5 (0.6, 0.8)
    np.testing.assert_allclose(eq.slip_direction("leg0", jac, forward), s0, atol=1e-15)
    np.testing.assert_allclose(eq.slip_direction("leg0", jac, -forward), s0, atol=1e-15)
    turned = np.array([0.8, 0.0, -0.5, 0, 0, 0])  # within 90 deg of s0: its own direction
    unit = np.array([0.8, -0.5]) / np.hypot(0.8, 0.5)
    np.testing.assert_allclose(eq.slip_direction("leg0", jac, turned), unit, atol=1e-15)
    # beyond 90 deg (a reversal): continued as the mirror image, whose friction still
    # opposes the stored direction's side
    np.testing.assert_allclose(eq.slip_direction("leg0", jac, -turned), unit, atol=1e-15)
    slow = np.array([3e-7, 0.0, -4e-7, 0, 0, 0])  # below the floor: the stored one
    np.testing.assert_allclose(eq.slip_direction("leg0", jac, slow), s0, atol=1e-15)


@pytest.mark.parametrize("scene_args", [("table", {"legs": 5, "v0": 0.6}),
                                        ("table", {"legs": 24, "v0": 0.0}),
                                        ("box_stack", {})])
def test_compiled_path_agrees_with_the_numpy_path(scene_args):
    name, kw = scene_args
    scene = load_scene(name, **kw)
    eq = _held_equations(scene, scene.theta0, scene.dtheta0)
    rng = np.random.default_rng(7)
    k = eq.k
    for _ in range(3):
        theta = scene.theta0 + 1e-3 * rng.normal(size=k)
        y = np.concatenate([theta, eq.momentum(theta, scene.dtheta0 + 0.05 * rng.normal(
            size=k))])
        fast = eq._held_rate(0.0, y[:k], y[k:])
        eq._compiled = False
        try:
            slow = eq(0.0, y)
        finally:
            eq._compiled = True
        scale = np.max(np.abs(slow))
        np.testing.assert_allclose(fast, slow, atol=1e-11 * scale)


def test_sliding_redundant_group_carries_the_force_problems_distribution():
    """A four-legged table sliding at 1 m/s and spinning at 5 rad/s about the vertical: its
    legs slide in different directions, so the legs' normal forces (three independent rows
    for four legs) move the table. The equations carry every leg's normal force: at the
    start they are the contact force problem's (force_solver, a second method: its
    least-norm distribution, all compressive), on the compiled and the numpy path. With an
    offset along the indeterminate directions (a start distribution other than the least
    norm) both paths agree and the legs still carry m g (no vertical acceleration)."""
    m = 2.0
    scene = load_scene("table", legs=4, v0=1.0, mu=0.5, mass=m)
    mech = scene.mechanism
    th = np.asarray(scene.theta0, float)
    dth = np.array(scene.dtheta0, float)
    dth[4] = 5.0  # the Cardan angle about the vertical (y)
    names = mech.contact_names
    sol = solve_contact_forces(contact_state(mech, 0.0, th, dth, names, 1e-6).problem)
    assert list(sol.modes) == ["slip"] * 4 and np.all(sol.force[:, 0] > 0.5)
    eq = _held_equations(scene, th, dth)
    assert eq.redundant_slipping and len(eq.rows) == 3
    y = _state(eq, th, dth)
    for compiled in (True, False):
        eq._compiled, eq._terms_memo = compiled, None
        forces = eq.contact_forces(0.0, y)
        np.testing.assert_allclose([forces[c] for c in names], sol.force, atol=1e-9 * m * G)
    eq._compiled = True
    eq.start_from(0.0, y, {c: sol.force[i] for i, c in enumerate(names)})
    assert eq.offset is None  # the force problem's distribution is the least-norm one
    eq.offset = np.array([0.3, -0.2, 0.1, 0.4])
    eq._terms_memo = None
    fast, fast_forces = eq(0.0, y), eq.contact_forces(0.0, y)
    eq._compiled, eq._terms_memo = False, None
    slow, slow_forces = eq(0.0, y), eq.contact_forces(0.0, y)
    np.testing.assert_allclose(fast, slow, atol=1e-11 * np.max(np.abs(slow)))
    for c in names:
        np.testing.assert_allclose(fast_forces[c], slow_forces[c], atol=1e-11 * m * G)
    assert sum(slow_forces[c][0] for c in names) == pytest.approx(m * G, rel=1e-11)
    assert max(abs(slow_forces[c][0] - sol.force[i, 0]) for i, c in enumerate(names)) > 0.01
