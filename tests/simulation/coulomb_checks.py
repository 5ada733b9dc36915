"""Checks of Coulomb's conditions in sustained contact on a simulation result, from the
stored series and the mechanism's contact Jacobians (independent of the scheme's code)."""

from __future__ import annotations

import numpy as np


def slip_velocity(mech, contact, theta, dtheta):
    """v_t of ``contact`` per sample (n, d - 1)."""
    return np.array([np.asarray(mech.contact_jacobian(contact, th), float)[1:] @ dth
                     for th, dth in zip(theta, dtheta)])


def assert_coulomb(res, mech, rtol=1e-7, rest_velocity=1e-6):
    """On every closed sample: lambda_n >= 0; sticking: v_t = 0 and |lambda_t| <= mu lambda_n;
    sliding: |lambda_t| = mu lambda_n with lambda_t opposing v_t, where the slip is faster
    than the run's ``rest_velocity`` (simulate's default; below it the scheme counts a slip
    as stopped and its friction keeps its last direction). Returns the number of stick and
    slip samples checked."""
    counts = {"stick": 0, "slip": 0}
    for i, c in enumerate(res.contact_names):
        mu = float(mech.contact_parameters(c)[1])
        codes = res.contact_mode[:, i]
        closed = codes > 0
        if not np.any(closed):
            continue
        lam = res.contact_force[closed, i]
        scale = max(float(np.max(np.abs(lam))), 1e-12)
        vt = slip_velocity(mech, c, res.theta[closed], res.dtheta[closed])
        # a body at rest moves at round-off: speeds are measured against 1 mm/s at least
        vscale = max(float(np.max(np.abs(res.dtheta))), 1e-3)
        assert np.all(lam[:, 0] >= -rtol * scale), f"{c}: tensile normal force"
        lt = np.linalg.norm(lam[:, 1:], axis=1)
        stick = codes[closed] == 1
        slip = codes[closed] == 2
        if np.any(stick):
            assert np.all(np.linalg.norm(vt[stick], axis=1) <= rtol * vscale), f"{c}: sticks but slides"
            assert np.all(lt[stick] <= mu * lam[stick, 0] + rtol * scale), f"{c}: outside the cone"
        moving = slip & (np.linalg.norm(vt, axis=1) > max(1e-6 * vscale, rest_velocity))
        if np.any(moving) and mu > 0:
            np.testing.assert_allclose(lt[moving], mu * lam[moving, 0], rtol=0,
                                       atol=rtol * scale)
            power = np.einsum("ij,ij->i", lam[moving, 1:], vt[moving])
            assert np.all(power <= rtol * scale * vscale), f"{c}: friction pushes the slip"
        counts["stick"] += int(np.sum(stick))
        counts["slip"] += int(np.sum(slip))
    return counts
