"""Law "stronge", spatial, at approach speeds far below the slip speed (issue 29): the curved
slip's integration is scaled, so -1e-300 gives the straight-slip closed form, not an error."""

import numpy as np
import pytest

from convimpact import resolve_impact
from convimpact.impact.batch import resolve_impacts

M = np.array([[2.0, 0.3, 0.1], [0.3, 1.5, 0.2], [0.1, 0.2, 1.0]])
J = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # v = (dq1, dq0, dq2)
E, MU = 0.5, 0.3
VT = np.array([0.5, 0.3])


def straight_slip(vn: float, d: int) -> np.ndarray:
    """|v_n-| << |v_t-|: the tangential velocity changes by O(|v_n-|) over the collision, so
    the slip keeps its direction s = v_t / |v_t|; along it v_n grows at A - mu b.s per unit
    normal impulse, compression ends at p_c = -v_n / (A - mu b.s), and with a constant slip
    direction Stronge's energetic restitution gives p_f = (1 + e) p_c (W_n linear in p)."""
    W = J[:d] @ np.linalg.solve(M, J[:d].T)
    vt = VT[:d - 1]
    s = vt / np.linalg.norm(vt)
    rate = W[0, 0] - MU * W[0, 1:] @ s
    pf = (1 + E) * (-vn / rate)
    return pf * np.concatenate([[1.0], -MU * s])


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("vn", [-1e-300, -1e-200, -1e-160])
def test_tiny_approach_is_the_straight_slip(vn, d):
    """Planar and spatial: the answer of the closed form, restitution included (v_n+ =
    e |v_n-| for a constant slip), in resolve_impact and the batch alike."""
    dq = np.array([VT[0], vn, VT[1]])
    want = straight_slip(vn, d)
    r = resolve_impact(M, J[:d], dq, e=E, mu=MU, law="stronge")
    assert r.regime == "slide"
    np.testing.assert_allclose(r.impulse, want, rtol=1e-9)
    assert r.v_plus[0] == pytest.approx(E * -vn, rel=1e-9)
    b = resolve_impacts(M, J[:d], dq, e=E, mu=MU, law="stronge")
    assert b.status[0] == 0
    np.testing.assert_allclose(b.impulse[0], want, rtol=1e-9)


def test_order_one_approach_unchanged_by_the_scaling():
    """A curved slip at |v_n-| ~ |v_t-|: the momentum balance M (dq+ - dq-) = J^T pi holds and
    the contact separates."""
    dq = np.array([VT[0], -1.0, VT[1]])
    r = resolve_impact(M, J, dq, e=E, mu=MU, law="stronge")
    assert r.regime == "slide"
    np.testing.assert_allclose(M @ (r.dq_plus - dq), J.T @ r.impulse, atol=1e-12)
    assert r.v_plus[0] > 0
