"""Law ``chatterjee-ruina`` in the simulators (event-driven ``simulate`` and Moreau-Jean), its
tangential restitution ``e_t`` passed as ``impact_options={"e_t": ...}``.

Hand derivation for a uniform ball (mass m, radius r, I = 2/5 m r^2; planar free joint
(x, y, phi)) striking the level floor y = 0 with normal velocity v_n = y_dot < 0 and slip
s = x_dot + r phi_dot (the bottom point's velocity along +x). In the contact frame (n = +y,
t along x) the Delassus matrix is diagonal: W_nn = 1/m, W_tt = 1/m + r^2/I = 7/(2m). The
frictionless plastic impulse is J_I = -m v_n n, the sticking one J_II = -W^-1 v =
(-m v_n, -(2m/7) s), so b = J_II - J_I = (0, -(2m/7) s), and the law's candidate is
J^ = (1 + e) J_I + (1 + e_t) b. It is in the cone when (1 + e_t)(2/7)|s| <= mu (1 + e)|v_n|;
then

    y_dot+ = -e v_n,   s+ = s + W_tt J_t = -e_t s,
    x_dot+ = x_dot - (1 + e_t)(2/7) s,   phi_dot+ = phi_dot - (1 + e_t)(5/7) s / r

(the impulse J_t at the bottom point turns the ball by r J_t / I). Outside the cone J is
brought back along b to the cone's boundary: J_t = -mu (1 + e) m |v_n| sgn(s), whence
s+ = s - (7/2) mu (1 + e) |v_n| sgn(s). Free fall from rest at centre height h0 gives
v_n = -sqrt(2 g (h0 - r)) at t = sqrt(2 (h0 - r) / g).
"""

from __future__ import annotations

import numpy as np
import pytest

import convimpact
from convimpact.errors import (
    ConvImpactError,
    NotSupportedError,
    ParameterError,
    UnknownOptionError,
)
from convimpact.model import Joint, ModelBuilder
from convimpact.simulation.moreau import simulate_moreau
from convimpact.simulation.testing import FallingRod

G = 9.81
M_BALL, R_BALL = 1.0, 0.1
H0 = 0.5  # centre height at release: one bounce before t = 0.5 s (the next is at 0.63 s)


def ball(e=0.6, mu=0.5, names=("ball",), spacing=1.0):
    """Planar balls (I = 2/5 m r^2) on free joints over the floor y = 0, one contact each."""
    b = ModelBuilder(planar=True)
    for i, name in enumerate(names):
        b.add_body(name, "ground", Joint.free(), M_BALL, (0.0, 0.0), 0.4 * M_BALL * R_BALL**2,
                   joint_name=f"{name}_joint",
                   coordinate_names=[f"x_{name}", f"y_{name}", f"phi_{name}"])
        b.add_contact(f"floor_{name}", body=name, point=(0.0, 0.0), radius=R_BALL,
                      normal=(0.0, 1.0), e=e, mu=mu)
    return b.build().mechanism()


def slip(dq):
    """The bottom point's velocity along +x of a ball (x_dot, y_dot, phi_dot)."""
    return dq[0] + R_BALL * dq[2]


def hand_impact(dq, e, mu, e_t):
    """(dq+, regime) of one ball striking the floor, from the derivation above."""
    xd, vn, wd = dq
    s = xd + R_BALL * wd
    jt = -(1.0 + e_t) * (2.0 / 7.0) * M_BALL * s  # the candidate's tangential impulse
    regime = "stick"
    if abs(jt) > mu * (1.0 + e) * M_BALL * abs(vn):
        jt = -mu * (1.0 + e) * M_BALL * abs(vn) * np.sign(s)
        regime = "slide"
    inertia = 0.4 * M_BALL * R_BALL**2
    return np.array([xd + jt / M_BALL, -e * vn, wd + R_BALL * jt / inertia]), regime


def energy(dq, y):
    inertia = 0.4 * M_BALL * R_BALL**2
    return 0.5 * M_BALL * (dq[0]**2 + dq[1]**2) + 0.5 * inertia * dq[2]**2 + M_BALL * G * y


@pytest.mark.parametrize("e_t", [-0.7, 0.0, 0.5, 1.0])
def test_one_bounce_restitutes_the_slip_by_e_t(e_t):
    e, mu = 0.6, 0.5
    mech = ball(e, mu)
    dq0 = np.array([1.0, 0.0, 5.0])  # backspin: slip 1.5 m/s; in the cone for mu = 0.5
    res = convimpact.simulate(mech, (0.0, 0.5), (np.array([0.0, H0, 0.0]), dq0),
                              law="chatterjee-ruina", impact_options={"e_t": e_t})
    assert res.status == 0
    assert res.settings["e_t"] == {"floor_ball": e_t}
    assert len(res.impacts) == 1
    ev = res.impacts[0]
    # free fall to the floor, by hand
    assert ev.time == pytest.approx(np.sqrt(2.0 * (H0 - R_BALL) / G), abs=1e-9)
    vn = -np.sqrt(2.0 * G * (H0 - R_BALL))
    np.testing.assert_allclose(ev.dtheta_minus, [1.0, vn, 5.0], rtol=0, atol=1e-8)
    expected, regime = hand_impact(ev.dtheta_minus, e, mu, e_t)
    assert regime == "stick" and ev.regime == ("stick",)
    np.testing.assert_allclose(ev.dtheta_plus, expected, rtol=0, atol=1e-12)
    # the contact point: slip restituted by e_t, normal velocity by e
    assert slip(ev.dtheta_plus) == pytest.approx(-e_t * slip(ev.dtheta_minus), abs=1e-12)
    assert ev.dtheta_plus[1] == pytest.approx(-e * ev.dtheta_minus[1], abs=1e-12)
    # the impact's energy by hand; the total energy never rises over the run
    y = ev.theta[1]
    assert ev.kinetic_energy_minus - ev.kinetic_energy_plus == pytest.approx(
        energy(ev.dtheta_minus, y) - energy(expected, y), rel=1e-10)
    total = np.asarray(res.total_energy)
    assert total[0] == pytest.approx(energy(dq0, H0), rel=1e-12)
    assert np.all(np.diff(total) <= 1e-9 * total[0])
    # free flight keeps it: the run loses exactly the impact's loss (integration error aside)
    assert total[0] - total[-1] == pytest.approx(
        energy(ev.dtheta_minus, y) - energy(expected, y), rel=1e-6, abs=1e-9)


def test_one_bounce_slides_where_the_candidate_leaves_the_cone():
    e, mu, e_t = 0.6, 0.1, 0.5  # (1 + e_t)(2/7)|s| = 0.64 > mu (1 + e)|v_n| = 0.45
    mech = ball(e, mu)
    res = convimpact.simulate(mech, (0.0, 0.5), (np.array([0.0, H0, 0.0]),
                                                  np.array([1.0, 0.0, 5.0])),
                              law="chatterjee-ruina", impact_options={"e_t": e_t})
    ev, = res.impacts
    expected, regime = hand_impact(ev.dtheta_minus, e, mu, e_t)
    assert regime == "slide" and ev.regime == ("slide",)
    np.testing.assert_allclose(ev.dtheta_plus, expected, rtol=0, atol=1e-12)
    s, vn = slip(ev.dtheta_minus), ev.dtheta_minus[1]
    assert slip(ev.dtheta_plus) == pytest.approx(s - 3.5 * mu * (1 + e) * abs(vn), abs=1e-12)
    assert ev.dtheta_plus[1] == pytest.approx(-e * vn, abs=1e-12)
    total = np.asarray(res.total_energy)
    assert np.all(np.diff(total) <= 1e-9 * total[0])


def test_independent_balls_each_take_their_own_e_t():
    """Two balls landing together: W is block-diagonal, the law applies contact by contact
    with e_t given per contact name."""
    e, mu = 0.6, 0.5
    mech = ball(e, mu, names=("a", "b"))
    dq0 = np.array([1.0, 0.0, 5.0, -0.5, 0.0, 2.0])
    e_t = {"floor_a": 0.3, "floor_b": -0.5}
    res = convimpact.simulate(mech, (0.0, 0.5), (np.array([0.0, H0, 0.0, 1.0, H0, 0.0]), dq0),
                              law="chatterjee-ruina", impact_options={"e_t": e_t})
    ev, = res.impacts
    assert set(ev.contacts) == {"floor_a", "floor_b"}
    for i, c in enumerate(("a", "b")):
        before, after = ev.dtheta_minus[3 * i:3 * i + 3], ev.dtheta_plus[3 * i:3 * i + 3]
        expected, _ = hand_impact(before, e, mu, e_t[f"floor_{c}"])
        np.testing.assert_allclose(after, expected, rtol=0, atol=1e-12)
        assert slip(after) == pytest.approx(-e_t[f"floor_{c}"] * slip(before), abs=1e-12)
    total = np.asarray(res.total_energy)
    assert np.all(np.diff(total) <= 1e-9 * total[0])


def test_moreau_jean_restitutes_the_slip_of_the_impact_step():
    """Moreau-Jean: the impact step's impulse leaves v_n+ = -e v_n,k and, gravity having no
    component along the floor, s+ = -e_t s_k, exactly as the hand derivation."""
    e, mu, e_t = 0.6, 0.5, 0.4
    mech = ball(e, mu)
    res = simulate_moreau(mech, (0.0, 0.5), (np.array([0.0, H0, 0.0]),
                                             np.array([1.0, 0.0, 5.0])),
                          h=1e-3, law="chatterjee-ruina", impact_options={"e_t": e_t})
    assert res.settings["e_t"] == {"floor_ball": e_t}
    ev, = res.impacts
    expected, regime = hand_impact(ev.dtheta_minus, e, mu, e_t)
    assert regime == "stick"
    np.testing.assert_allclose(ev.dtheta_plus, expected, rtol=0, atol=1e-12)
    assert slip(ev.dtheta_plus) == pytest.approx(-e_t * slip(ev.dtheta_minus), abs=1e-12)
    total = np.asarray(res.total_energy)
    assert np.all(np.diff(total) <= 1e-12 * total[0])


def test_moreau_jean_resting_contact_is_not_restituted_tangentially():
    """A ball rolling on the floor stays active every step; e_t acts only on approaching
    contacts, so a rolling ball keeps rolling (slip 0) and its energy does not rise."""
    mech = ball(0.0, 0.5)
    th0 = np.array([0.0, R_BALL, 0.0])
    dq0 = np.array([1.0, 0.0, -1.0 / R_BALL])  # rolling: s = 0
    res = simulate_moreau(mech, (0.0, 0.05), (th0, dq0), h=1e-3, law="chatterjee-ruina",
                          impact_options={"e_t": 0.9})
    dq = np.asarray(res.dtheta)
    np.testing.assert_allclose(dq[:, 0] + R_BALL * dq[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(dq[:, 0], 1.0, atol=1e-12)
    total = np.asarray(res.total_energy)
    assert np.all(np.diff(total) <= 1e-12 * total[0])


def test_e_t_with_another_law_is_refused_before_the_run():
    mech = ball()
    y0 = (np.array([0.0, H0, 0.0]), np.array([1.0, 0.0, 5.0]))
    for run in (lambda **kw: convimpact.simulate(mech, (0.0, 0.01), y0, **kw),
                lambda **kw: simulate_moreau(mech, (0.0, 0.01), y0, h=1e-3, **kw)):
        # a span with no impact: the refusal comes from the options, not from an impact
        with pytest.raises(UnknownOptionError, match="tangential restitution of law "
                                                     "'chatterjee-ruina'; law 'coulomb'"):
            run(law="coulomb", impact_options={"e_t": 0.5})
        with pytest.raises(ParameterError, match=r"\[-1, 1\]"):
            run(law="chatterjee-ruina", impact_options={"e_t": 1.5})
        with pytest.raises(UnknownOptionError, match="unknown contact"):
            run(law="chatterjee-ruina", impact_options={"e_t": {"wall": 0.5}})
    # without e_t the law's default (0) applies: the slip stops at the bounce
    res = convimpact.simulate(mech, (0.0, 0.5), y0, law="chatterjee-ruina")
    ev, = res.impacts
    assert "e_t" not in res.settings
    assert slip(ev.dtheta_plus) == pytest.approx(0.0, abs=1e-12)


def test_resolve_mechanism_impact_takes_e_t():
    """One impact of a model: e and mu from its contact, e_t given to the law."""
    from convimpact.model.impact import resolve_mechanism_impact

    mech = ball(0.6, 0.5)
    th, dq = np.array([0.0, R_BALL, 0.0]), np.array([1.0, -2.0, 5.0])
    r = resolve_mechanism_impact(mech, th, dq, law="chatterjee-ruina", e_t=0.4)
    expected, regime = hand_impact(dq, 0.6, 0.5, 0.4)
    assert regime == "stick"
    assert ((r.regime,) if isinstance(r.regime, str) else tuple(r.regime)) == ("stick",)
    np.testing.assert_allclose(r.dq_plus, expected, rtol=0, atol=1e-12)
    with pytest.raises(UnknownOptionError, match="law 'coulomb' has none"):
        resolve_mechanism_impact(mech, th, dq, law="coulomb", e_t=0.4)


def test_coupled_contacts_raise_a_clear_error_naming_the_laws_that_can():
    """A rod landing flat closes both ends at once: the two contacts are coupled through the
    rod (W is not block-diagonal), where the law is not defined."""
    rod = FallingRod(e=0.5, mu=0.3)
    y0 = (np.array([0.0, 0.3, 0.0]), np.array([0.5, 0.0, 0.0]))
    runs = {"simulate": lambda: convimpact.simulate(rod, (0.0, 0.5), y0,
                                                    law="chatterjee-ruina",
                                                    impact_options={"e_t": 0.5}),
            "simulate_moreau": lambda: simulate_moreau(rod, (0.0, 0.5), y0, h=1e-3,
                                                       law="chatterjee-ruina",
                                                       impact_options={"e_t": 0.5})}
    for where, run in runs.items():
        with pytest.raises(NotSupportedError) as info:
            run()
        exc = info.value
        assert isinstance(exc, ConvImpactError)
        text = str(exc)
        assert "defined per contact" in text and "coupled" in text
        for law in ("'ccp'", "'dissipative'", "'coulomb'", "'stronge'"):
            assert law in text
        notes = " ".join(getattr(exc, "__notes__", []))
        assert "left, right" in notes and where in notes
    # the same rod under a law defined at coupled contacts runs
    res = convimpact.simulate(rod, (0.0, 0.5), y0, law="stronge")
    assert res.status == 0 and res.impacts
