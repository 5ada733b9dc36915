"""Impact derivatives of every one-contact law (issue 27, point 1), planar and spatial, in
each mode (stick, slide, frictionless), open and closed loops: the analytic jacobians of
``resolve_impact(..., derivatives=True)`` against central finite differences of the public
call (away from the mode boundaries; step from the scale of each argument)."""

from __future__ import annotations

import numpy as np
import pytest

from .derivative_checks import assert_matches, call, finite_differences, scene

LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative", "chatterjee-ruina")
#: mu putting the scene of seed 0 into each mode (the regime is asserted)
MODES = {"frictionless": 0.0, "slide": 0.1, "stick": 3.0}


@pytest.mark.parametrize("loops", [0, 1], ids=["open", "closed"])
@pytest.mark.parametrize("mode", list(MODES))
@pytest.mark.parametrize("d", [2, 3], ids=["planar", "spatial"])
@pytest.mark.parametrize("law", LAWS)
def test_jacobians_match_finite_differences(law, d, mode, loops):
    M, Jc, dq, C = scene(d, seed=0, loops=loops)
    e, mu = 0.4, MODES[mode]
    e_t = 0.3 if law == "chatterjee-ruina" else None
    r = call(M, Jc, dq, e, mu, C, law=law, e_t=e_t, derivatives=True)
    assert r.regime == mode
    assert r.derivatives.modes == (mode,)
    fd = finite_differences(M, Jc, dq, e, mu, C, law=law, e_t=e_t)
    assert_matches(r.jacobian, fd["dq_plus"])
    assert_matches(r.impulse_jacobian, fd["impulse"])
    # inside a mode nothing is one-sided, except mu's derivative at mu = 0 (right-sided)
    assert bool(r.derivatives.one_sided) == (mode == "frictionless")
    keys = {"dq", "M", "Jc", "e", "mu"} | ({"e_t"} if e_t is not None else set())
    assert set(r.jacobian) == keys == set(r.impulse_jacobian)


@pytest.mark.parametrize("law", ["ccp", "coulomb", "pereira-nikravesh"])
def test_per_contact_coefficients_and_the_jacobian_of_a_list(law):
    """e and mu given per contact ([e], [mu]) and Jc as a list of one matrix: the keys follow
    the arguments' shapes, and agree with the finite differences taken that way."""
    M, Jc, dq, C = scene(3, seed=0)
    r = call(M, [Jc], dq, [0.4], [0.1], law=law, derivatives=True)
    k = dq.size
    assert r.jacobian["e"].shape == (k, 1) and r.jacobian["mu"].shape == (k, 1)
    assert r.jacobian["Jc"].shape == (k, 1, 3, k)
    assert r.impulse_jacobian["Jc"].shape == (1, 3, 1, 3, k)
    fd = finite_differences(M, [Jc], dq, [0.4], [0.1], law=law)
    assert_matches(r.jacobian, fd["dq_plus"])
    assert_matches(r.impulse_jacobian, fd["impulse"])


def test_the_method_does_not_change_the_derivative():
    """The derivative depends on the law's answer, not on the method: ccp by its compiled
    kernel and by Clarabel's cone program (to the program's accuracy)."""
    M, Jc, dq, C = scene(3, seed=0)
    a = call(M, Jc, dq, 0.4, 0.1, law="ccp", method="fast", derivatives=True)
    b = call(M, Jc, dq, 0.4, 0.1, law="ccp", method="clarabel", derivatives=True)
    for name in a.jacobian:
        np.testing.assert_allclose(b.jacobian[name], a.jacobian[name], atol=1e-6)
