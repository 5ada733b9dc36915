"""Mode boundaries (issue 27): at the stick limit, at v_n- = 0 and at eq. (55)'s zero
pre-impact slip the derivative is one-sided -- stated in the record and the diagnostics --
and with ``derivatives="both"`` the other side's is given. Each side's is checked against a
one-sided finite difference taken from that side only (points at s h, 2 s h, 3 s h, never at
the boundary itself, so a jump of the impulse there does not enter)."""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci

from .derivative_checks import scene

H = 1e-6


def one_sided(f, side, h=H):
    """d f / ds at s = 0 from the quadratic through s = side * (h, 2h, 3h)."""
    s = side * h * np.array([1.0, 2.0, 3.0])
    ys = [np.asarray(f(x), dtype=float) for x in s]
    w = []  # the Lagrange weights of the derivative at 0
    for i in range(3):
        others = [s[j] for j in range(3) if j != i]
        den = np.prod([s[i] - sj for sj in others])
        # L_i(x) = prod (x - s_j) / den, L_i'(0) = -(sum of s_j) / den
        w.append(-(others[0] + others[1]) / den)
    return sum(wi * yi for wi, yi in zip(w, ys))


def _sides(r, f):
    """(jacobian of the side a step along ``direction`` lands on, regime there) for both
    signs, from the record: the result's own jacobian or the other side's."""
    out = []
    for side in (1.0, -1.0):
        regime = f(side * H, "regime")
        own = r.derivatives.modes[0] == regime
        jac = r.jacobian if own else r.derivatives.other_jacobian
        out.append((side, regime, own, jac))
    return out


def rigid_body_on_a_plane(dq, r=(0.3, -0.2)):
    """A planar rigid body (x, y, theta; m = 2, I = 0.05) touching a floor at the point r
    from its centre: rows n = (0, 1, r_x), t = (1, 0, -r_y)."""
    M = np.diag([2.0, 2.0, 0.05])
    Jc = np.array([[0.0, 1.0, r[0]], [1.0, 0.0, -r[1]]])
    return M, Jc, np.array(dq, dtype=float)


@pytest.mark.parametrize("law", ["pereira-nikravesh", "coulomb", "ccp", "dissipative",
                                 "chatterjee-ruina"])
@pytest.mark.parametrize("d", [2, 3])
def test_stick_limit(law, d):
    M, Jc, dq, _ = scene(d, seed=0)
    e = 0.4
    e_t = 0.3 if law == "chatterjee-ruina" else None
    kw = dict(e=e, law=law, e_t=e_t)
    stuck = ci.resolve_impact(M, Jc, dq, mu=3.0, **kw)
    assert stuck.regime == "stick"
    p = stuck.impulse
    mu_star = float(np.linalg.norm(p[1:]) / p[0])  # the stick limit |pi_t| = mu pi_n
    r = ci.resolve_impact(M, Jc, dq, mu=mu_star, derivatives="both", **kw)
    rec = r.derivatives
    assert rec.one_sided and "stick limit" in rec.one_sided[0]
    assert any("one-sided derivative" in w for w in r.diagnostics.warnings)
    assert {rec.modes[0], rec.other_modes[0]} == {"stick", "slide"}
    # with derivatives=True: the statement, no other side
    plain = ci.resolve_impact(M, Jc, dq, mu=mu_star, derivatives=True, **kw)
    assert plain.derivatives.one_sided == rec.one_sided
    assert plain.derivatives.other_jacobian is None
    # (law pereira-nikravesh in space: P_N's boundary optimum is not the stick impulse when
    # e > 0, so the impulse jumps here and the slide side's derivative is taken at the
    # slide's own answer; the differences below never use the boundary point itself)

    def f_mu(s, what="dq_plus"):
        res = ci.resolve_impact(M, Jc, dq, mu=mu_star + s, **kw)
        return res.regime if what == "regime" else res.dq_plus

    seen = set()
    for side, regime, own, jac in _sides(r, f_mu):
        seen.add(regime)
        np.testing.assert_allclose(jac["mu"], one_sided(f_mu, side), atol=2e-5)
    assert seen == {"stick", "slide"}
    # a direction of dq: its two signs land on the two sides
    rng = np.random.default_rng(3)
    delta = rng.normal(size=dq.size)

    def f_dq(s, what="dq_plus"):
        res = ci.resolve_impact(M, Jc, dq + s * delta, mu=mu_star, **kw)
        return res.regime if what == "regime" else res.dq_plus

    seen = set()
    for side, regime, own, jac in _sides(r, f_dq):
        seen.add(regime)
        np.testing.assert_allclose(jac["dq"] @ delta, one_sided(f_dq, side), atol=2e-5)
    assert seen == {"stick", "slide"}


@pytest.mark.parametrize("law", ["pereira-nikravesh", "coulomb", "ccp", "dissipative",
                                 "chatterjee-ruina"])
@pytest.mark.parametrize("mu", [0.1, 2.0])
def test_contact_at_zero_normal_velocity(law, mu):
    """v_n- = 0 exactly (the body slides along the floor): separating, one-sided; the
    approaching side's derivative matches the difference taken while approaching."""
    M, Jc, dq = rigid_body_on_a_plane([0.7, 0.0, 0.0])
    e_t = 0.3 if law == "chatterjee-ruina" else None
    kw = dict(e=0.4, mu=mu, law=law, e_t=e_t)
    r = ci.resolve_impact(M, Jc, dq, derivatives="both", **kw)
    assert r.regime == "separating"
    assert r.derivatives.one_sided and "v_n- = 0" in r.derivatives.one_sided[0]
    assert r.derivatives.other_modes[0] in ("stick", "slide")
    delta = np.array([0.0, -1.0, 0.0])  # approaching: v_n = dy + r_x dtheta < 0

    def f(s):
        return ci.resolve_impact(M, Jc, dq + s * delta, **kw).dq_plus

    np.testing.assert_allclose(r.derivatives.other_jacobian["dq"] @ delta, one_sided(f, 1.0),
                               atol=1e-5)
    np.testing.assert_allclose(r.jacobian["dq"] @ delta, one_sided(f, -1.0), atol=1e-12)


def test_zero_pre_impact_slip_of_eq_55():
    """Eq. (55)'s tangent -sgn(v_t-) flips at v_t- = 0: the impulse jumps; each side's
    derivative is its slide's (tangent held)."""
    M, Jc, dq = rigid_body_on_a_plane([0.0, -1.0, 0.0])  # v = (-1, 0) exactly
    kw = dict(e=0.5, mu=0.1)
    r = ci.resolve_impact(M, Jc, dq, derivatives="both", **kw)
    assert r.regime == "slide" and r.v_minus[1] == 0.0
    rec = r.derivatives
    assert rec.one_sided and "zero pre-impact slip" in rec.one_sided[0]
    assert rec.other_modes == ("slide",)
    delta = np.array([1.0, 0.0, 0.0])  # v_t = dx: the slip's sign
    s = np.sign(r.impulse[1])  # the side v_t- s < 0 is the result's own

    def f(x):
        return ci.resolve_impact(M, Jc, dq + x * delta, **kw).dq_plus

    np.testing.assert_allclose(r.jacobian["dq"] @ delta, one_sided(f, -s), atol=1e-5)
    np.testing.assert_allclose(rec.other_jacobian["dq"] @ delta, one_sided(f, s), atol=1e-5)
    for name in ("e", "mu"):  # and the other side's impulse is its own
        def g(x, name=name):
            return ci.resolve_impact(M, Jc, dq + s * 1e-3 * delta,
                                     **{**kw, name: kw[name] + x}).dq_plus
        np.testing.assert_allclose(rec.other_jacobian[name], one_sided(g, 1.0), atol=1e-5)
