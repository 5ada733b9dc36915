"""derivatives="velocity": redundant contacts (more contact rows than the bodies' freedoms)
leave a cone law's impulse non-unique but its velocities unique; the derivative of dq_plus
is then exact, checked against central differences of the public call (the impulse's
jacobian, a minimum-norm choice, is not compared: the impulse itself is not a function of
the data). The mode's derivative holds along the perturbations that keep its equations
consistent, as the statement in ``one_sided`` says."""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.errors import NotSupportedError, UnknownOptionError

from .derivative_checks import assert_matches, finite_differences


def flat_rod(tilt: float = 0.0):
    """A planar rod (mass 1, length 1, theta = (x, y, phi)) landing with both ends on the
    floor: two contacts, 4 contact rows on 3 freedoms (W 4 x 4 of rank 3)."""
    M = np.diag([1.0, 1.0, 1.0 / 12.0])
    c, s = np.cos(tilt), np.sin(tilt)
    Jc = []
    for side in (-0.5, 0.5):
        rx, ry = side * c, side * s  # the end relative to the centre
        Jc.append(np.array([[0.0, 1.0, rx],     # n = +y: v_y + phi_dot r_x
                            [1.0, 0.0, -ry]]))  # t = +x: v_x - phi_dot r_y
    dq = np.array([0.4, -1.0, 0.1])
    return M, Jc, dq


@pytest.mark.parametrize("law", ["ccp", "coulomb", "dissipative"])
def test_redundant_contacts_velocity_derivative_matches_finite_differences(law):
    M, Jc, dq = flat_rod()
    with pytest.raises(NotSupportedError, match="redundant"):
        ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.8, law=law, derivatives=True)
    r = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.8, law=law, derivatives="velocity")
    assert r.regime == ("stick", "stick")
    assert any("velocity" in s or "minimum-norm" in s for s in r.derivatives.one_sided)
    fd = finite_differences(M, Jc, dq, [0.5, 0.5], [0.8, 0.8], law=law)
    r = ci.resolve_impact(M, Jc, dq, e=[0.5, 0.5], mu=[0.8, 0.8], law=law,
                          derivatives="velocity")
    ref = dict(fd["dq_plus"])
    # the tangent rows of the two ends are equal ((1, 0, 0): v_x); moving one of them alone
    # makes the four sticking equations on three freedoms inconsistent, and the law leaves
    # this mode (an end slips): the derivative of the mode holds along the perturbations
    # that keep its equations consistent -- every other argument, and the normal rows
    fd_jc = ref.pop("Jc")
    assert_matches(r.jacobian, ref, rtol=2e-6)
    normal_rows = np.asarray(r.jacobian["Jc"])[:, :, 0, :]
    scale = max(np.abs(fd_jc[:, :, 0, :]).max(), 1e-3)  # a zero derivative: absolutely
    assert np.abs(normal_rows - fd_jc[:, :, 0, :]).max() <= 2e-6 * scale
    tangent_rows = np.asarray(r.jacobian["Jc"])[:, :, 1, :]
    both = tangent_rows[:, 0] + tangent_rows[:, 1]  # the two rows moved together
    fd_both = fd_jc[:, 0, 1, :] + fd_jc[:, 1, 1, :]
    assert np.abs(both - fd_both).max() <= 2e-6 * max(scale, np.abs(fd_both).max())


def test_velocity_mode_equals_true_where_the_impulse_is_unique():
    M, Jc, dq = flat_rod(tilt=0.3)  # one end strikes first: one contact, W regular
    a = ci.resolve_impact(M, Jc[0], dq, e=0.5, mu=0.8, law="ccp", derivatives=True)
    b = ci.resolve_impact(M, Jc[0], dq, e=0.5, mu=0.8, law="ccp", derivatives="velocity")
    for key in a.jacobian:
        np.testing.assert_array_equal(a.jacobian[key], b.jacobian[key])


@pytest.mark.parametrize("value", ["Velocity", "yes", 1, 0.0, None])
def test_derivatives_takes_only_its_values(value):
    M, Jc, dq = flat_rod()
    with pytest.raises(UnknownOptionError, match="velocity"):
        ci.resolve_impact(M, Jc[0], dq, e=0.5, mu=0.8, law="ccp", derivatives=value)
