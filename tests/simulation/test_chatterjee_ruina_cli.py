"""``--e-t`` on the command line: ``convimpact simulate --law chatterjee-ruina --e-t`` and
``convimpact demo`` (every law, the new one with its e_t).

Hand derivations. The bouncing ball scene is a point mass m with a translation joint: W is
diagonal with W_nn = W_tt = 1/m, so law ``chatterjee-ruina`` gives, in the cone
((1 + e_t)|u| <= mu (1 + e)|v_n|), x_dot+ = -e_t u and y_dot+ = -e v_n, with v_n =
-sqrt(2 g (h - r)) after the drop from centre height h. The demo's rod (m = 1, L = 1, at
angle phi from the floor, its lower end striking with dq = (1, -1, 0)) has, in the contact
frame (n = +y, t = +x) with c = L/2 cos phi, s = L/2 sin phi and I = m L^2 / 12,
W = [[1/m + c^2/I, -c s/I], [-c s/I, 1/m + s^2/I]] and v- = (-1, 1).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from convimpact import cli

G = 9.81


def test_simulate_e_t_restitutes_the_ball_slip(capsys):
    e, mu, e_t, u, h, r = 0.5, 0.5, 0.5, 1.0, 1.0, 0.1
    argv = ["simulate", "bouncing_ball", "--json", "--t-end", "0.6", "--param", f"speed={u}",
            "--param", f"mu={mu}", "--param", f"e={e}", "--law", "chatterjee-ruina",
            "--e-t", str(e_t)]
    assert cli.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["settings"]["law"] == "chatterjee-ruina"
    assert out["settings"]["e_t"] == {"floor": e_t}
    ev = out["impacts"][0]
    vn = -np.sqrt(2.0 * G * (h - r))
    np.testing.assert_allclose(ev["dtheta_minus"], [u, vn], atol=1e-8)
    assert (1 + e_t) * u <= mu * (1 + e) * abs(vn)  # the hand case is in the cone
    np.testing.assert_allclose(ev["dtheta_plus"], [-e_t * u, -e * ev["dtheta_minus"][1]],
                               rtol=0, atol=1e-12)


def test_simulate_e_t_with_another_law_is_a_clean_error(capsys):
    assert cli.main(["simulate", "bouncing_ball", "--law", "coulomb", "--e-t", "0.5"]) == 2
    err = capsys.readouterr().err
    assert "--e-t is the tangential restitution of law 'chatterjee-ruina'" in err
    assert "--law coulomb has none" in err
    assert cli.main(["simulate", "bouncing_ball", "--law", "chatterjee-ruina",
                     "--e-t", "1.5", "--json"]) == 2
    assert "[-1, 1]" in capsys.readouterr().err


def _rod_by_hand(angle_deg, e, mu, e_t):
    """The demo rod under chatterjee-ruina, from the law's definition with W by hand: J_I =
    -(v_n / W_nn) n, J_II = -W^-1 v, J^ = (1 + e) J_I + (1 + e_t)(J_II - J_I); outside the
    cone, J = (1 + e) J_I + kappa (J_II - J_I) on its boundary."""
    m, L = 1.0, 1.0
    inertia = m * L**2 / 12
    c, s = 0.5 * L * np.cos(np.radians(angle_deg)), 0.5 * L * np.sin(np.radians(angle_deg))
    W = np.array([[1 / m + c * c / inertia, -c * s / inertia],
                  [-c * s / inertia, 1 / m + s * s / inertia]])
    v = np.array([-1.0, 1.0])
    j1 = np.array([-v[0] / W[0, 0], 0.0])
    j2 = -np.linalg.solve(W, v)
    b = j2 - j1
    J = (1 + e) * j1 + (1 + e_t) * b
    if abs(J[1]) > mu * J[0]:
        kappa = mu * (1 + e) * j1[0] / (abs(b[1]) - mu * b[0])
        J = (1 + e) * j1 + kappa * b
    return J, v + W @ J


@pytest.mark.parametrize("e_t, mu, regime", [(None, 5.0, "stick"), (0.4, 5.0, "stick"),
                                              (-0.3, 5.0, "stick"), (0.4, 0.3, "slide")])
def test_demo_lists_the_new_law_with_its_e_t(e_t, mu, regime, capsys):
    e = 0.5
    argv = ["demo", "--json", "--e", str(e), "--mu", str(mu)]
    if e_t is not None:
        argv += ["--e-t", str(e_t)]
    assert cli.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["e_t"] == (0.0 if e_t is None else e_t)
    rows = [r for r in out["results"] if r["law"] == "chatterjee-ruina"]
    assert {r["method"] for r in rows} >= {"fast"}
    J, v_plus = _rod_by_hand(30.0, e, mu, 0.0 if e_t is None else e_t)
    for r in rows:
        assert "error" not in r
        assert r["regime"] == regime
        np.testing.assert_allclose(r["impulse"], J, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(r["v_plus"], v_plus, rtol=1e-9, atol=1e-12)
        assert r["v_plus"][0] == pytest.approx(e, rel=1e-12)  # v_n+ = -e v_n-
    # the other laws run without e_t, as before
    others = {r["law"] for r in out["results"]} - {"chatterjee-ruina"}
    assert {"pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge"} <= others


def test_demo_table_shows_the_new_law(capsys):
    assert cli.main(["demo", "--e-t", "0.4"]) == 0
    text = capsys.readouterr().out
    assert "e_t = 0.4" in text
    assert any(line.startswith("chatterjee-ruina") for line in text.splitlines())


def test_demo_e_t_outside_its_range_is_a_clean_error(capsys):
    assert cli.main(["demo", "--e-t", "1.5"]) == 2
    assert "[-1, 1]" in capsys.readouterr().err
