"""Scale-free answers and typed errors (issue 15, items 5 and 6).

Scale: the answers of every law on the README particle and on a spinning ball are derived by
hand below; with M times ``a`` and dq times ``b`` the regime stays, the impulse scales as
``a b``, the joint and contact velocities as ``b`` -- for ``a``, ``b`` from 1e-150 to 1e150,
on method ``fast`` and ``auto`` -- and ``diagnostics.held()`` agrees with the friction cone
measured here by hand. Where the answer (impulse, energy change) leaves double precision's
range the call raises NonFiniteError, never NaN.

Types: strings, booleans, complex numbers and None are typed errors naming the entry; numpy
numbers of real type are accepted; a contact whose Jacobian is zero is a typed error.
"""

import math

import numpy as np
import pytest

import convimpact as ci
from convimpact.impact.exact.dispatch import solve_contact

E, MU = 0.5, 0.3
#: the laws whose answers are derived by hand below
HAND_LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative")

# --------------------------------------------------------------------------------------------
# the README particle: mass 2, floor normal +y, tangent +x; v- = (v_n, v_t) = (-1, 1), W = I/2
M_P = 2.0 * np.eye(2)
J_P = np.array([[0.0, 1.0], [1.0, 0.0]])
DQ_P = np.array([1.0, -1.0])


def _projection(x: float, y: float) -> float:
    """pi_n of the Euclidean projection of (x, y) onto the cone |y| <= MU x, when it lies on
    the boundary: (x + MU |y|) / (1 + MU^2) (the point is outside the cone and its polar)."""
    return (x + MU * abs(y)) / (1.0 + MU * MU)


# Newton's laws slide: pi_n = (1 + e) m |v_n| = 3, pi_t = -MU pi_n = -0.9 (the stick impulse
# (3, -2) leaves the cone). CCP: W = I/m makes the program a projection of -m b,
# b = ((1 + e) v_n, v_t) = (-1.5, 1), onto the cone; dissipative: the same with e = 0, times
# (1 + e).
_CCP_P = _projection(3.0, -2.0)
_DIS_P = 1.5 * _projection(2.0, -2.0)
PARTICLE = {
    "pereira-nikravesh": (3.0, -0.9),
    "coulomb": (3.0, -0.9),
    "ccp": (_CCP_P, -MU * _CCP_P),
    "dissipative": (_DIS_P, -MU * _DIS_P),
}

# --------------------------------------------------------------------------------------------
# a ball (m = 1, r = 0.1, I = 2/5 m r^2) spinning onto the floor: coordinates (v, omega);
# contact point velocity v + omega x (-r e_z): rows n = e_z, t1 = (e_x, -r e_y), t2 = (e_y, r e_x)
R_B, I_B = 0.1, 0.4 * 0.1 ** 2
M_B = np.diag([1.0, 1.0, 1.0, I_B, I_B, I_B])
J_B = np.array([[0, 0, 1, 0, 0, 0], [1, 0, 0, 0, -R_B, 0], [0, 1, 0, R_B, 0, 0]], float)
DQ_B = np.array([1.0, 0.3, -1.0, 2.0, -5.0, 1.0])
# v- = (-1, 1.5, 0.5); W = diag(1, c, c) with c = 1 + r^2 / I = 3.5: no normal-tangent coupling
# and an isotropic tangent, so every law's friction acts along -v_t-/|v_t-| (for P-N's maximal
# dissipation, Coulomb's post-slip and CCP's projection alike) and its size is a 1-D problem.
_VT = np.array([1.5, 0.5])
_C = 3.5
_T = -_VT / np.hypot(*_VT)


def _ball(law: str) -> np.ndarray:
    vt = float(np.hypot(*_VT))
    if law in ("pereira-nikravesh", "coulomb"):
        pn = 1.5  # (1 + e) |v_n| / W_nn; stick would need |pi_t| = vt / c = 0.4518 > MU pn = 0.45
        # (Coulomb: the post-impact slip vt - c MU pn = 0.0061 > 0 is opposed: a slide)
    else:
        # on the ray pi = r (1, MU t): 1/2 r^2 (1 + MU^2 c) + r (b_n - MU |b_t|) is least at
        # r = (MU |b_t| - b_n) / (1 + MU^2 c), b_n = (1 + e) v_n (CCP) or v_n (plastic phase);
        # the unconstrained optimum -W^-1 b leaves the cone in both cases
        bn = -1.5 if law == "ccp" else -1.0
        pn = (MU * vt - bn) / (1.0 + MU * MU * _C)
        if law == "dissipative":
            pn *= 1.5  # Poisson's (1 + e)
    return np.r_[pn, MU * pn * _T]


BALL = {law: _ball(law) for law in HAND_LAWS}
CASES = {"particle": (M_P, J_P, DQ_P, {k: np.array(v) for k, v in PARTICLE.items()}),
         "ball": (M_B, J_B, DQ_B, BALL)}


def _hand_dq_plus(M, J, dq, pi):
    return dq + np.linalg.solve(M, J.T @ pi)  # eq. (29), by hand from the hand impulse


def _representable(sa: int, sb: int, case: str) -> bool:
    """Whether the answer fits in double precision: |pi| ~ 10^(sa+sb), T ~ 10^(sa+2sb)."""
    return abs(sa + sb) <= 300 and sa + 2 * sb <= 300


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("law", HAND_LAWS)
def test_hand_answers_at_unit_scale(case, law):
    M, J, dq, ref = CASES[case]
    for method in ("fast", "auto"):
        r = ci.resolve_impact(M, J, dq, e=E, mu=MU, law=law, method=method)
        assert r.regime == "slide"
        np.testing.assert_allclose(r.impulse, ref[law], rtol=1e-12)
        np.testing.assert_allclose(r.dq_plus, _hand_dq_plus(M, J, dq, ref[law]), rtol=1e-12)


def _check_scaled(case, law, method, sa, sb):
    M, J, dq, ref = CASES[case]
    a, b = 10.0 ** sa, 10.0 ** sb
    args = (M * a, J, dq * b)
    if not _representable(sa, sb, case):
        with pytest.raises(ci.NonFiniteError, match="rescale"):
            ci.resolve_impact(*args, e=E, mu=MU, law=law, method=method)
        return
    r = ci.resolve_impact(*args, e=E, mu=MU, law=law, method=method)
    assert r.regime == "slide", (sa, sb)
    pi0 = ref[law]
    np.testing.assert_allclose(r.impulse / a / b, pi0, rtol=1e-12)
    np.testing.assert_allclose(r.dq_plus / b, _hand_dq_plus(M, J, dq, pi0), rtol=1e-12)
    np.testing.assert_allclose(r.v_plus / b, J @ _hand_dq_plus(M, J, dq, pi0), rtol=1e-12,
                               atol=1e-13)
    assert np.all(np.isfinite(r.impulse)) and math.isfinite(r.energy_loss)
    # the cone measured by hand on the returned impulse (hypot: no square under/overflows)
    ratio = math.hypot(*r.impulse[1:]) / r.impulse[0]
    assert ratio == pytest.approx(MU, rel=1e-12)  # a slide sits on the cone's boundary
    held = r.diagnostics.held()
    assert held["friction_cone"] == (ratio <= MU * (1 + 1e-6))
    assert held["friction_cone"] and held["momentum_balance"]
    assert r.diagnostics.cone_violation <= 1e-12
    # every flag and property as at unit scale
    unit = ci.resolve_impact(M, J, dq, e=E, mu=MU, law=law, method=method).diagnostics
    assert held == unit.held()
    for flag in ("energy_gained", "friction_pushes_slip", "slip_reversal", "penetration"):
        assert getattr(r.diagnostics, flag) == getattr(unit, flag)


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("law", HAND_LAWS)
@pytest.mark.parametrize("method", ["fast", "auto"])
def test_same_answer_when_m_and_dq_scale_together(case, law, method):
    for s in range(-150, 151, 10):
        _check_scaled(case, law, method, s, s)


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("law", HAND_LAWS)
@pytest.mark.parametrize("method", ["fast", "auto"])
def test_same_answer_when_m_and_dq_scale_independently(case, law, method):
    for sa in range(-150, 151, 50):
        for sb in range(-150, 151, 50):
            _check_scaled(case, law, method, sa, sb)


@pytest.mark.parametrize("law", ci.LAWS)
def test_every_registered_law_scales(law):
    # any law (also one added later, without a hand answer here) is homogeneous: its scaled
    # answer is its unit answer scaled
    for case, (M, J, dq, _) in sorted(CASES.items()):
        unit = ci.resolve_impact(M, J, dq, e=E, mu=MU, law=law)
        for sa, sb in ((-150, -150), (-150, 100), (120, -60), (100, 100)):
            a, b = 10.0 ** sa, 10.0 ** sb
            r = ci.resolve_impact(M * a, J, dq * b, e=E, mu=MU, law=law)
            assert r.regime == unit.regime
            np.testing.assert_allclose(r.impulse / a / b, unit.impulse, rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(r.dq_plus / b, unit.dq_plus, rtol=1e-9, atol=1e-12)
            assert r.diagnostics.held() == unit.diagnostics.held()


def test_issue_example_is_a_slide_on_the_cone():
    # issue 15 item 5: M x 1e-140 with dq x 1e-140 returned a "stick" with |pi_t|/pi_n = 0.67
    r = ci.resolve_impact(M_P * 1e-140, J_P, DQ_P * 1e-140, e=E, mu=MU)
    assert r.regime == "slide"
    assert abs(r.impulse[1]) / r.impulse[0] == pytest.approx(MU, rel=1e-12)
    assert r.diagnostics.held()["friction_cone"]
    # the energies (~1e-420) underflow: flags stay scale-free, and the warnings say so
    assert not r.diagnostics.energy_gained
    assert any("below double precision" in w for w in r.diagnostics.warnings)


def test_a_violated_cone_is_reported_at_any_scale():
    # a forced stick impulse outside the cone (|pi_t| / pi_n = 2/3 > MU): the diagnostics see
    # it at every scale, as the hand ratio does
    from convimpact.impact.diagnostics import assemble_result

    for s in (-150, -140, 0, 100):
        a = b = 10.0 ** s
        P = ci.build_problem(M_P * a, J_P, DQ_P * b, E, MU)
        r = assemble_result(P, np.array([3.0, -2.0]) * a * b, ["stick"], "pereira-nikravesh",
                            "test")
        assert abs(r.impulse[1]) / r.impulse[0] == pytest.approx(2 / 3)
        assert not r.diagnostics.held()["friction_cone"]
        # max(0, |pi_t| - MU pi_n) / |pi| = (2 - 0.9) / sqrt(13)
        assert r.diagnostics.cone_violation == pytest.approx(1.1 / math.sqrt(13), rel=1e-12)


@pytest.mark.parametrize("law", HAND_LAWS)
def test_kernel_rescales_w_and_v_independently(law):
    # pi(a W, b v) = (b / a) pi(W, v): hand answers of the particle (W = I/2, v = (-1, 1))
    W, v = 0.5 * np.eye(2), np.array([-1.0, 1.0])
    for sa, sb in ((200, 150), (-200, -150), (-250, -100), (120, 160), (0, -290)):
        a, b = 10.0 ** sa, 10.0 ** sb
        sol = solve_contact(W * a, v * b, E, MU, law)
        np.testing.assert_allclose(sol.impulse * a / b, PARTICLE[law], rtol=1e-12)
        assert sol.regime == "slide"
        if sol.effective_mass is not None:  # W_nn + MU s W_nt = 1/2, in W's units
            assert sol.effective_mass / a == pytest.approx(0.5, rel=1e-12)


def test_beyond_double_precision_is_a_typed_error():
    for law in HAND_LAWS:
        with pytest.raises(ci.NonFiniteError, match="overflows"):  # |pi| ~ 1e400
            solve_contact(0.5e-200 * np.eye(2), [-1e200, 1e200], E, MU, law)
        with pytest.raises(ci.NonFiniteError, match="underflows"):  # |pi| ~ 1e-400
            solve_contact(0.5e200 * np.eye(2), [-1e-200, 1e-200], E, MU, law)
        with pytest.raises(ci.NonFiniteError, match="rescale"):  # T ~ 1e450
            ci.resolve_impact(M_P * 1e150, J_P, DQ_P * 1e150, e=E, mu=MU, law=law)


# --------------------------------------------------------------------------------------------
# types


@pytest.mark.parametrize("kwargs, err, msg", [
    (dict(e="0.5"), ci.ParameterError, r"e must be a real number, got str '0.5'"),
    (dict(e=True), ci.ParameterError, r"e must be a real number, got bool True"),
    (dict(mu=np.bool_(False)), ci.ParameterError, "mu must be a real number, got bool"),
    (dict(mu=0.3 + 0j), ci.ParameterError, "mu must be a real number, got complex"),
    (dict(e=None), ci.ParameterError, "e must be a real number, got None"),
    (dict(e=[True]), ci.ParameterError, "e has a boolean entry"),
    (dict(e=np.array(["0.5"])), ci.ParameterError, "e has a string entry"),
    (dict(dq=["1", "-1"]), ci.ShapeError, r"dq has a string entry \('1'\)"),
    (dict(dq=[1.0, True]), ci.ShapeError, "dq has a boolean entry"),
    (dict(dq=np.array([True, False])), ci.ShapeError, "dq has a boolean entry"),
    (dict(dq=[1.0 + 1j, -1.0]), ci.ShapeError, "dq has a complex entry .*pass real velocities"),
    (dict(dq=np.array([1.0, -1.0], dtype=complex)), ci.ShapeError,
     "dq has a complex entry .*pass real velocities"),
    (dict(dq=np.array([1.0, None], dtype=object)), ci.ShapeError, "dq has an entry None"),
    (dict(dq=np.array([1.0, "x"], dtype=object)), ci.ShapeError, "dq has a string entry"),
    (dict(M=np.eye(2, dtype=bool)), ci.ShapeError, "M has a boolean entry"),
    (dict(M=[["2", "0"], ["0", "2"]]), ci.ShapeError, "M has a string entry"),
    (dict(M="mass"), ci.ShapeError, "numeric"),
    (dict(Jc=np.array([[0, 1], [1, 0]], dtype=bool)), ci.ShapeError, "Jc has a boolean entry"),
    (dict(Jc=[[0.0, 1.0], [1.0, "0"]]), ci.ShapeError, "Jc has a string entry"),
    (dict(C=[["1", "0"]]), ci.ShapeError, "C has a string entry"),
    (dict(Jc=np.zeros((2, 2))), ci.DegenerateContactError, "normal row is zero"),
    (dict(Jc=[[0.0, 1e-170], [1e-170, 0.0]]), ci.DegenerateContactError,
     "numerically zero relative to M's scale"),
    (dict(M=1e300 * np.eye(2), Jc=[[0.0, 1e-5], [1.0, 0.0]]), ci.DegenerateContactError,
     "numerically zero relative to M's scale"),
])
def test_bad_types_are_typed_errors(kwargs, err, msg):
    args = dict(M=M_P, Jc=J_P, dq=DQ_P, e=E, mu=MU)
    args.update(kwargs)
    with pytest.raises(err, match=msg):
        ci.resolve_impact(**args)
    assert issubclass(err, ci.InputError)


def test_zero_contact_among_several_names_it():
    with pytest.raises(ci.DegenerateContactError, match="of contact 1"):
        ci.resolve_impact(M_P, [J_P, np.zeros((2, 2))], DQ_P, e=E, mu=MU)


def test_zero_normal_row_with_moving_tangent_cannot_approach_and_says_so():
    # the tip of a pendulum at the bottom of its swing against a floor: c_n = 0, c_t != 0
    r = ci.resolve_impact(np.eye(1), [[0.0], [1.0]], [2.0], e=E, mu=MU)
    assert r.regime == "separating" and r.impulse.tolist() == [0.0, 0.0]
    assert any("normal row is zero" in w for w in r.diagnostics.warnings)


@pytest.mark.parametrize("convert", [
    lambda x: x.astype(np.float32), lambda x: x.astype(np.int64),
    lambda x: x.tolist(), lambda x: x.astype(object)])
def test_real_numpy_types_are_accepted(convert):
    # the README particle with every argument in another real type: the hand answer
    r = ci.resolve_impact(convert(M_P), convert(J_P), convert(DQ_P), e=np.float64(E),
                          mu=np.float32(MU), law="coulomb")
    np.testing.assert_allclose(r.impulse, [3.0, -0.9], rtol=1e-7)
    r = ci.resolve_impact(M_P, J_P, DQ_P, e=np.int64(0), mu=np.array(MU))
    assert r.impulse[0] == pytest.approx(2.0)  # (1 + 0) m |v_n|


@pytest.mark.parametrize("call, err, msg", [
    (lambda: solve_contact([["1", 0], [0, 1]], [-1.0, 0.0], E, MU, "ccp"), ci.ShapeError,
     "W has a string entry"),
    (lambda: solve_contact(np.eye(2), [True, False], E, MU, "ccp"), ci.ShapeError,
     "v has a boolean entry"),
    (lambda: solve_contact(np.eye(2), [-1.0, 0.0], "0.5", MU, "ccp"), ci.ParameterError,
     "e must be a real number, got str"),
    (lambda: solve_contact(np.eye(2), [-1.0, 0.0], E, True, "ccp"), ci.ParameterError,
     "mu must be a real number, got bool"),
    (lambda: ci.resolve_impact(M_P, J_P, DQ_P, e="0.5", mu=MU, method="sweep"),
     ci.ParameterError, "got str"),
    (lambda: ci.resolve_impact(M_P, [J_P, J_P], DQ_P, e=[0.5, "0.5"], mu=MU),
     ci.ParameterError, "string entry"),
    (lambda: ci.central_energy_loss(M_P, [0.0, 1.0], DQ_P, "0.5"), ci.ParameterError,
     "got str"),
    (lambda: ci.oblique_energy_loss(M_P, [0, 1], [1, 0], DQ_P, 1.0, True), ci.ParameterError,
     "got bool"),
    (lambda: ci.energy_loss(M_P, ["1", "-1"], DQ_P), ci.ShapeError, "dq_minus has a string"),
    (lambda: ci.stiction_interval(M_P, J_P, [1.0, 1j]), ci.ShapeError, "complex"),
])
def test_every_public_entry_types_its_input(call, err, msg):
    with pytest.raises(err, match=msg):
        call()


# ---- the public closed-form helpers take the same typed inputs as resolve_impact ----------
def test_closed_form_helpers_reject_strings_booleans_and_complex():
    import convimpact.impact as imp
    from convimpact.impact.laws.max_dissipation import max_dissipation_direction
    from convimpact.impact.exact.sweep import energy_loss_versus_angle, sweep_direction

    W2, v2 = np.array([[2.0, 0.3], [0.3, 1.0]]), np.array([-1.0, 0.5])
    W3, v3 = np.diag([2.0, 1.0, 1.5]), np.array([-1.0, 0.5, 0.2])
    # the particle W = I/2 (mass 2) hitting at v = (-1, 0): pi_n = (1 + e) * 2 (hand value)
    assert imp.frictionless_impulse(np.eye(2) / 2, [-1.0, 0.0], 0.5)[0] == pytest.approx(3.0)
    bad_e = ("0.5", True, np.bool_(False), 0.5 + 1j)
    for e in bad_e:
        with pytest.raises(ci.ParameterError):
            imp.frictionless_impulse(W2, v2, e)
        with pytest.raises(ci.ParameterError):
            imp.sticking_impulse(W2, v2, e)
        with pytest.raises(ci.ParameterError):
            imp.pereira_nikravesh(W2, v2, e, 0.3)
        with pytest.raises(ci.ParameterError):
            imp.pereira_nikravesh(W2, v2, 0.5, e)
        with pytest.raises(ci.ParameterError):
            max_dissipation_direction(W3, v3, e, 0.3)
        with pytest.raises(ci.ParameterError):
            sweep_direction(W3, v3, 0.5, e)
        with pytest.raises(ci.ParameterError):
            energy_loss_versus_angle(W3, v3, e, 0.3, [0.0])
        with pytest.raises(ci.ParameterError):
            imp.stick_admissible(np.array([1.0, 0.1]), e)
    for v in (["-1", "0.5"], [True, False], [-1.0 + 1j, 0.5]):
        with pytest.raises(ci.ShapeError):
            imp.sticking_impulse(W2, v, 0.5)
        with pytest.raises(ci.ShapeError):
            imp.sliding_impulse(W2, v, 0.5, 0.3, np.array([1.0]))
