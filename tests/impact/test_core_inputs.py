"""Bad input is answered with a typed error whose message says what to change; never NaN."""

import numpy as np
import pytest

import convimpact as ci

M = np.diag([1.0, 1.0, 1.0 / 12.0])
JC = np.array([[0.0, 1.0, -0.4], [1.0, 0.0, 0.3]])
DQ = np.array([1.0, -1.0, 0.0])


@pytest.mark.parametrize("kwargs, err, msg", [
    (dict(M=np.ones((3, 2))), ci.ShapeError, "square"),
    (dict(Jc=np.ones((4, 3))), ci.ShapeError, "2 x 3"),
    (dict(Jc=np.ones((2, 4))), ci.ShapeError, "2 x 3"),
    (dict(dq=np.ones(4)), ci.ShapeError, "length 3"),
    (dict(Jc=[]), ci.ShapeError, "non-empty"),
    (dict(Jc=[JC, np.ones((3, 3))]), ci.ShapeError, "one shape"),
    (dict(e=[0.5, 0.5]), ci.ShapeError, "one value per contact"),
    (dict(M="mass"), ci.ShapeError, "numeric"),
    (dict(dq=np.array([np.nan, 0, 0])), ci.NonFiniteError, "NaN"),
    (dict(M=np.diag([1.0, np.inf, 1.0])), ci.NonFiniteError, "NaN"),
    (dict(Jc=JC * np.array([[1, 1, np.nan], [1, 1, 1]])), ci.NonFiniteError, "Jc"),
    (dict(M=np.array([[1.0, 0.5, 0], [0.4, 1, 0], [0, 0, 1]])), ci.MassMatrixError, "symmetric"),
    (dict(M=np.diag([1.0, -1.0, 1.0])), ci.MassMatrixError, "positive definite"),
    (dict(M=np.diag([1.0, 0.0, 1.0])), ci.MassMatrixError, "positive definite"),
    (dict(e=-0.1), ci.ParameterError, r"\[0, 1\]"),
    (dict(e=1.5), ci.ParameterError, r"\[0, 1\]"),
    (dict(e=np.nan), ci.NonFiniteError, "e"),
    (dict(mu=-0.2), ci.ParameterError, ">= 0"),
    (dict(mu=np.inf), ci.NonFiniteError, "mu"),
    (dict(law="newton"), ci.UnknownOptionError, "pereira-nikravesh"),
    (dict(method="magic"), ci.UnknownOptionError, "closed-form"),
    (dict(C=np.array([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])), ci.LoopConstraintError,
     "rank deficient"),
    (dict(C=np.array([[0.0, 1.0, 0.0]])), ci.LoopConstraintError, "project dq"),
    (dict(C=np.eye(3)), ci.LoopConstraintError, "fewer"),
    (dict(C=np.ones((1, 2))), ci.ShapeError, "m x 3"),
])
def test_bad_input_raises_typed_error(kwargs, err, msg):
    args = dict(M=M, Jc=JC, dq=DQ, e=0.5, mu=0.3)
    args.update(kwargs)
    with pytest.raises(err, match=msg):
        ci.resolve_impact(**args)


def test_every_error_is_a_convimpact_error_and_a_builtin():
    with pytest.raises(ci.ConvImpactError):
        ci.resolve_impact(M, JC, DQ, e=2.0)
    with pytest.raises(ValueError):
        ci.resolve_impact(M, JC, DQ, e=2.0)
    with pytest.raises(NotImplementedError):
        ci.resolve_impact(M, [JC, JC], DQ, method="closed-form")
    assert issubclass(ci.NonPositiveEffectiveMassError, ci.SingularSystemError)
    assert issubclass(ci.SingularSystemError, ArithmeticError)
    assert issubclass(ci.SolverError, RuntimeError)


def test_singular_delassus_in_sticking_branch():
    # the tangent row is parallel to the normal (t = 0.5 n through the mechanism): W is
    # singular, so the sticking solve of eq. (42) has no unique answer: the exact paths
    # raise, and method="auto" falls back to the conic path (issue 29), where sticking is
    # impossible (v_t = v_n / 2 for every impulse, so v_t+ = 0 would need v_n+ = 0) and the
    # contact slides along eq. (55)'s t = +1: with a = W_nn = 4/3, v_n+ = -2 + a (1 + mu / 2)
    # pi_n = e 2 gives pi_n = 3 / (a (1 + mu / 2)); v_t+ = v_n+ / 2 = 0.5 reverses the slip
    Mp = np.diag([1.0, 3.0])
    Jp = np.array([[-1.0, 1.0], [-0.5, 0.5]])
    with pytest.raises(ci.SingularSystemError, match="singular"):
        ci.resolve_impact(Mp, Jp, [2.0, 0.0], e=0.5, mu=0.3, method="fast")
    r = ci.resolve_impact(Mp, Jp, [2.0, 0.0], e=0.5, mu=0.3)
    pn = 3.0 / (4.0 / 3.0 * 1.15)
    np.testing.assert_allclose(r.impulse, [pn, 0.3 * pn], rtol=1e-12)
    np.testing.assert_allclose(r.v_plus, [1.0, 0.5], rtol=1e-12)
    assert r.diagnostics.slip_reversal
    # frictionless needs only m_nn: fine
    r = ci.resolve_impact(Mp, Jp, [2.0, 0.0], e=0.5, mu=0.0)
    assert np.all(np.isfinite(r.dq_plus))


def test_tangent_that_moves_no_mass_is_frictionless():
    # 1-D particles: the tangential row is zero, a friction impulse could do no work; the
    # impact is the central one whatever mu (hand: common velocity 0.5, e = 0.5)
    Mp = np.diag([1.0, 3.0])
    Jp = np.array([[-1.0, 1.0], [0.0, 0.0]])
    r = ci.resolve_impact(Mp, Jp, [2.0, 0.0], e=0.5, mu=0.3)
    assert r.regime == "frictionless"
    np.testing.assert_allclose(r.dq_plus, [-0.25, 0.75], rtol=1e-12)


def test_normal_that_moves_no_mass():
    Jp = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    with pytest.raises(ci.SingularSystemError):
        ci.frictionless_impulse(np.zeros((2, 2)), np.array([-1.0, 0.0]), 0.5)
    r = ci.resolve_impact(M, Jp, DQ, e=0.5, mu=0.0)  # v_n = 0: separating, not an error
    assert r.regime == "separating"


def test_closed_form_takes_no_options():
    with pytest.raises(ci.UnknownOptionError, match="no options"):
        ci.resolve_impact(M, JC, DQ, e=0.5, mu=0.3, method="closed-form", tol=1e-3)


def test_painleve_jam_raises_instead_of_dividing():
    # a forced slide (the paper's eq. 38 at a given mu) whose denominator is negative:
    # W_nn - mu W_nt' <= 0 for the friction direction t'
    W = np.array([[1.0, 0.9], [0.9, 1.0]])
    v = np.array([-1.0, -0.5])
    with pytest.raises(ci.NonPositiveEffectiveMassError, match=r"mu < 1\.1111"):
        ci.sliding_impulse(W, v, 0.5, 2.0, np.array([-1.0]))
    pi, denom = ci.sliding_impulse(W, v, 0.5, 1.0, np.array([-1.0]))
    assert denom == pytest.approx(0.1) and pi[0] == pytest.approx(15.0)
