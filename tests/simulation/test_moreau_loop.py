"""The one Moreau–Jean step loop (:mod:`convimpact.simulation.moreau_loop`): closed forms on
the bench's boxes, the recorded series against the mechanism's own functions, and the two
predictors against each other.

Closed forms used (derived by hand, independent of the code):

* a box sliding on its four bottom corners on a level floor with Coulomb friction mu
  decelerates at mu g: with theta = 1/2 the scheme's friction impulse per step is mu m g h
  while it slides, so ``v_k = v0 - mu g t_k`` and ``x_k = x0 + v0 t_k - mu g t_k^2 / 2``
  exactly (the midpoint rule integrates a linear velocity exactly) until the step where it
  stops, ``t_stop = v0 / (mu g)``; then it stays (static friction), having moved
  ``v0^2 / (2 mu g)`` within one step's travel ``v0 h``; it neither tips (``mu c < a``:
  the friction's moment about the far corners is smaller than the weight's) nor lifts;
* a box at rest on its four corners: per step the normal impulses sum to m g h, and the
  corners' moment balance about the centre of mass (corners at (+-a, +-b)) makes opposite
  corners carry equal loads, so the symmetric split is m g h / 4 per corner;
* with e = 0 and theta = 1 a step changes E = T + V by
  ``r . u_{k+1} - (v_{k+1} - v_k)^T M (v_{k+1} - v_k) / 2 <= 0`` (see
  ``test_moreau_engine.py``): E never rises.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.bench.moreau_scenes import BOX_MASS, MU, SLIDE_SPEED, box_row
from convimpact.scenes import load_scene
from convimpact.simulation import moreau_engine as me
from convimpact.simulation.moreau import simulate_moreau

G = 9.81
H = 2e-3


def test_box_slides_to_rest_at_coulombs_rate():
    mech, q, v = box_row(1, True)
    r = simulate_moreau(mech, (0.0, 1.0), (q, v), h=H, law="coulomb")
    t = r.t
    t_stop = SLIDE_SPEED / (MU * G)                         # 0.680 s
    sliding = t <= t_stop - H
    v_exact = SLIDE_SPEED - MU * G * t[sliding]
    x_exact = q[0] + SLIDE_SPEED * t[sliding] - 0.5 * MU * G * t[sliding] ** 2
    assert np.max(np.abs(r.dtheta[sliding, 0] - v_exact)) < 1e-9
    assert np.max(np.abs(r.theta[sliding, 0] - x_exact)) < 1e-9
    stopped = t >= t_stop + H
    assert np.max(np.abs(r.dtheta[stopped, 0])) < 1e-9
    assert abs(r.theta[-1, 0] - q[0] - SLIDE_SPEED ** 2 / (2 * MU * G)) <= SLIDE_SPEED * H
    # no tipping, no lift, no turn: every other coordinate stays put
    assert np.max(np.abs(r.theta[:, 1:] - q[1:])) < 1e-9
    assert r.max_penetration < 1e-12


@pytest.mark.parametrize("law", ["ccp", "coulomb"])
def test_box_at_rest_carries_a_quarter_of_its_weight_per_corner(law):
    mech, q, v = box_row(1, False)
    # the first step's contact problem, through the engine solver's own entry
    ev = me.Evaluator(mech, mech.contact_names)
    M, _, J = ev.positions(q)
    inv = me.inverse_mass(M, np.zeros((0, q.size)), me.GroupCache())
    v_free = H * (inv.G @ np.asarray(mech.generalized_forces(0.0, q, v), float))
    b = np.einsum("cdk,k->cd", J, v_free)
    r, _ = me.solve_step(np.arange(4), J, b, np.full(4, MU), inv, coulomb=law == "coulomb",
                         tol=1e-10, last=None, split=True, counters=me.EngineCounters())
    np.testing.assert_allclose(r[:, 0], BOX_MASS * G * H / 4, rtol=1e-8)
    assert np.max(np.abs(r[:, 1:])) < 1e-8 * BOX_MASS * G * H
    # and over a run it stays exactly where it is
    res = simulate_moreau(mech, (0.0, 0.5), (q, v), h=H, law=law)
    assert np.max(np.abs(res.theta - q)) < 1e-12 and np.max(np.abs(res.dtheta)) < 1e-12
    assert res.max_penetration < 1e-12 and res.max_active_contacts == 4


@pytest.mark.parametrize("law", ["ccp", "coulomb"])
def test_energy_never_rises_with_plastic_contacts(law):
    mech, q, v = box_row(2, True)
    r = simulate_moreau(mech, (0.0, 0.3), (q, v), h=H, law=law, theta=1.0)
    E = r.total_energy
    scale = 0.5 * 2 * BOX_MASS * SLIDE_SPEED ** 2
    assert np.max(np.diff(E)) <= 1e-12 * scale
    assert E[-1] < E[0] - 0.1 * scale                     # friction did work


def test_recorded_series_are_the_mechanisms_own():
    """Momenta, energies and penetration, computed once from the stored states at the end
    of the run, against the mechanism's protocol functions sample by sample."""
    mech, q, v = box_row(2, True)
    r = simulate_moreau(mech, (0.0, 0.5), (q, v), h=H, law="ccp")   # ccp: the boxes hop
    T, V, pen = [], [], 0.0
    for th, dth, p in zip(r.theta, r.dtheta, r.p):
        M = mech.mass_matrix(th)
        np.testing.assert_allclose(p, M @ dth, rtol=1e-12, atol=1e-14)
        T.append(mech.kinetic_energy(th, dth))
        V.append(mech.potential_energy(th))
        pen = max(pen, -min(mech.contact_gap(c, th) for c in mech.contact_names))
    np.testing.assert_allclose(r.kinetic_energy, T, rtol=1e-12)
    np.testing.assert_allclose(r.potential_energy, V, rtol=1e-12, atol=1e-14)
    assert r.max_penetration == pytest.approx(pen, rel=1e-12)
    assert r.max_penetration > 0.0 and np.ptp(V) > 0.0     # something to compare


class _Protocol:
    """A mechanism through the Mechanism protocol only (not a model: the loop's protocol
    predictor)."""

    def __init__(self, mech):
        self._m = mech
        self.n_coordinates = mech.n_coordinates
        self.n_loop_constraints = mech.n_loop_constraints
        self.contact_names = tuple(mech.contact_names)
        self.coordinate_names = tuple(mech.coordinate_names)

    def __getattr__(self, name):
        if name in ("mass_matrix", "generalized_forces", "contact_gap", "contact_jacobian",
                    "contact_parameters", "kinetic_energy", "potential_energy",
                    "loop_residual", "loop_jacobian", "contact_jacobian_dot",
                    "mass_matrix_dot", "momentum_rate", "loop_jacobian_dot"):
            return getattr(self._m, name)
        raise AttributeError(name)


@pytest.mark.parametrize("case", ["box-coulomb", "box-ccp", "rocking-pereira-nikravesh"])
def test_the_two_predictors_agree(case):
    if case.startswith("box"):
        mech, q, v = box_row(2, True)
        span, law = (0.0, 0.1), case.split("-", 1)[1]
    else:
        scene = load_scene("rocking_block")
        mech, q, v = scene.mechanism, scene.theta0, scene.dtheta0
        span, law = (0.0, 0.4), "pereira-nikravesh"
    a = simulate_moreau(mech, span, (q, v), h=H, law=law)
    b = simulate_moreau(_Protocol(mech), span, (q, v), h=H, law=law)
    for x, y in ((a.theta, b.theta), (a.dtheta, b.dtheta), (a.p, b.p),
                 (a.total_energy, b.total_energy)):
        np.testing.assert_allclose(x, y, rtol=1e-10, atol=1e-12)
    assert a.max_penetration == pytest.approx(b.max_penetration, rel=1e-9, abs=1e-15)
    assert len(a.impacts) == len(b.impacts) and a.n_contact_steps == b.n_contact_steps
    assert a.n_contact_steps > 0


@pytest.mark.parametrize("protocol", [False, True])
def test_an_overflowing_state_raises_a_typed_error(protocol):
    from convimpact.errors import SimulationError

    mech, q, v = box_row(1, False)
    v = v.copy()
    v[2] = 1e308                         # the configuration, then M, overflow within a step
    with pytest.raises(SimulationError, match="not finite|non-finite"):
        simulate_moreau(_Protocol(mech) if protocol else mech, (0.0, 0.01), (q, v), h=H,
                        law="coulomb")
