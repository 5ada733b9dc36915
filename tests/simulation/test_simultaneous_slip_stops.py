"""Several held contacts' event functions crossing zero in one step, located together
(EventWatch.locate_together): the earliest by Brent's method, the others evaluated at once
at that instant. Checked against the closed form (a table sliding on n legs stops at
t_s = v0 / (mu g), every leg at once) and against the one-by-one location it replaces (each
key by Brent's method): the same events, to event_tol, and the same motion.
"""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.scenes import load_scene
from convimpact.simulation import event_watch
from convimpact.simulation.canonical import CanonicalEquations, HeldMode

TOL = 1e-12  # the runs' event_tol (the default)
ATOL = 1e-10  # the runs' atol (the default)


def _stops(res, mech) -> list[float]:
    return [next(iv.t_start for iv in res.modes_of(c) if iv.mode == "stick")
            for c in mech.contact_names]


def _one_by_one(monkeypatch):
    monkeypatch.setattr(event_watch.EventWatch, "locate_together", lambda self, *a: None)


@pytest.mark.parametrize("legs", [6, 24])
def test_a_table_stops_on_every_leg_at_once_at_v0_over_mu_g(legs, monkeypatch):
    sc = load_scene("table", legs=legs, v0=0.6, t_end=0.5)
    p, mech = sc.parameters, sc.mechanism
    res = ci.simulate(mech, (0.0, sc.t_end), (sc.theta0, sc.dtheta0))
    assert res.status == 0, res.message
    t_s = p["v0"] / (p["mu"] * p["gravity"])
    stops = _stops(res, mech)
    assert max(stops) - min(stops) <= TOL
    assert stops[0] == pytest.approx(t_s, rel=1e-8)
    _one_by_one(monkeypatch)
    ref = ci.simulate(mech, (0.0, sc.t_end), (sc.theta0, sc.dtheta0))
    assert abs(_stops(ref, mech)[0] - stops[0]) <= 2 * TOL
    # the same motion to the runs' accuracy (simulate's atol, 1e-10): the table's angles,
    # zero by symmetry, carry round-off of 1e-12 that differs between the two runs (on 24
    # legs 2.3e-12 against 1.1e-12 on one machine), so 1e-12 was a bound on round-off
    np.testing.assert_allclose(res.theta[-1], ref.theta[-1], rtol=0, atol=ATOL)
    np.testing.assert_allclose(res.dtheta[-1], ref.dtheta[-1], rtol=0, atol=ATOL)
    # the other legs' crossings checked at the instant, not each located by Brent's method
    assert res.nevents_fev < ref.nevents_fev - legs


def test_a_spinning_table_stops_its_legs_as_located_one_by_one(monkeypatch):
    """Sliding at 1 m/s and spinning at 5 rad/s: the legs' slips stop at different
    instants (several crossings in a step, some more than event_tol apart)."""
    sc = load_scene("table", legs=6, v0=1.0, mu=0.5)
    mech = sc.mechanism
    th = np.asarray(sc.theta0, float)
    spin = next(j for j in range(3, mech.n_coordinates)
                if all(abs(float(np.asarray(mech.contact_jacobian(c, th), float)[0, j]))
                       < 1e-12 for c in mech.contact_names))
    dth = np.array(sc.dtheta0, float)
    dth[spin] = 5.0
    res = ci.simulate(mech, (0.0, sc.t_end), (th, dth))
    _one_by_one(monkeypatch)
    ref = ci.simulate(mech, (0.0, sc.t_end), (th, dth))
    assert res.status == ref.status == 0
    assert [(e.contact, e.kind) for e in res.contact_events] == \
        [(e.contact, e.kind) for e in ref.contact_events]
    np.testing.assert_allclose([e.time for e in res.contact_events],
                               [e.time for e in ref.contact_events], rtol=0, atol=2 * TOL)
    np.testing.assert_allclose(res.theta[-1], ref.theta[-1], rtol=0, atol=1e-10)


def test_slip_directions_at_once_are_the_one_by_one_directions():
    """CanonicalEquations.slip_directions against slip_direction contact by contact: slips
    followed, reversed against their stored direction, below the slip floor, frozen."""
    sc = load_scene("table", legs=8, v0=0.6)
    mech = sc.mechanism
    names = list(mech.contact_names)
    rng = np.random.default_rng(3)
    stored = rng.normal(size=(8, 2))
    stored /= np.linalg.norm(stored, axis=1)[:, None]
    modes = {c: HeldMode("slip", tuple(stored[i]), 0.4, frozen=(i == 5))
             for i, c in enumerate(names)}
    eq = CanonicalEquations(mech, names, modes, slip_floor=1e-6)
    th = np.asarray(sc.theta0, float) + 0.01 * rng.normal(size=mech.n_coordinates)
    for scale in (1.0, 1e-9):  # (1e-9: every slip below the floor)
        dth = scale * rng.normal(size=mech.n_coordinates)
        J = np.array([np.asarray(mech.contact_jacobian(c, th), float) for c in names])
        at_once = eq.slip_directions(names, J, dth)
        one_by_one = np.array([eq.slip_direction(c, J[i], dth) for i, c in enumerate(names)])
        np.testing.assert_allclose(at_once, one_by_one, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(at_once[5], stored[5])  # frozen: kept
        if scale < 1.0:  # below the floor: every stored direction kept
            np.testing.assert_array_equal(at_once, stored)
        else:  # followed, some against their stored directions (a reversal: -v_t / |v_t|)
            V = J[:, 1:, :] @ dth
            against = [i for i in range(8) if i != 5 and V[i] @ stored[i] < 0.0]
            assert against
            for i in against:
                np.testing.assert_allclose(at_once[i], -V[i] / np.linalg.norm(V[i]),
                                           rtol=0, atol=1e-15)
