"""The compiled spatial Stronge kernel (convimpact.impact.laws.stronge_slip) against
the Python kernel it ports (convimpact.impact.laws.stronge.contact_kernel, a separate
implementation on plain floats), and against what can be checked by hand from W, v and the
returned impulse alone.

Hundreds of random spatial contacts (W = Jc M^-1 Jc^T from random M and Jc, approaching v,
e in [0, 1], mu in [0, 1.5]) with curved slips, sticks, slips that stop and restart in the
selected direction (onset), contacts at rest in the tangent plane, slips on invariant rays
(accelerating, and decelerating to a stop) and jams: ``contact_impulses(W, v, e, mu,
"stronge")`` gives the Python kernel's status, regime and impulse (to 1e-10 relative; the
port takes the same branches with the same expressions, so in practice bit for bit), and
its rejected items carry the batch's status of the Python kernel's error. By hand:

* energy never rises: T+ - T- = pi.v- + 1/2 pi.W.pi <= 0 (to round-off);
* the friction impulse is in the cone, |pi_t| <= mu pi_n;
* a contact at rest in the tangent plane, or slipping on an accelerating invariant ray, has
  one linear phase whose ratio pi_t / pi_n is constant, so the normal velocity is linear in
  the normal impulse and the energetic restitution is Newton's: v_n+ = -e v_n-; in a stick,
  v_t+ = 0 as well; in a slip from rest (onset) |pi_t| = mu pi_n and v_t+ is opposite pi_t.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")  # the compiled kernels (an optional dependency)

from convimpact.impact import batch  # noqa: E402
from convimpact.impact.batch import REGIMES, contact_impulses, resolve_impacts  # noqa: E402
from convimpact.impact.errors import (NonPositiveEffectiveMassError,  # noqa: E402
                                      SingularSystemError, SolverError)
from convimpact.impact.laws.stronge import contact_kernel  # noqa: E402

TOL = 1e-10


def _delassus(rng, k: int, scale: float = 1.0) -> np.ndarray:
    A = rng.normal(size=(k, k))
    M = A @ A.T + rng.uniform(0.05, 1.0) * np.eye(k)
    J = rng.normal(size=(3, k)) * np.exp(scale * rng.normal(size=(3, 1)))
    W = J @ np.linalg.solve(M, J.T)
    return 0.5 * (W + W.T)


def _ray_system(rng, accelerating: bool):
    """(W, v): v_t on an invariant ray s of the slip dynamics, b - mu C s = +-kappa s."""
    mu = float(rng.uniform(0.1, 1.5))
    B = rng.normal(size=(2, 2))
    C = B @ B.T + 0.2 * np.eye(2)
    phi = rng.uniform(0.0, 2.0 * np.pi)
    s = np.array([np.cos(phi), np.sin(phi)])
    kappa = float(rng.uniform(0.05, 1.0))
    b = (kappa if accelerating else -kappa) * s + mu * C @ s
    A = float(b @ np.linalg.solve(C, b)) + rng.uniform(0.2, 2.0)  # W positive definite
    W = np.block([[np.array([[A]]), b[None, :]], [b[:, None], C]])
    v = np.r_[-rng.uniform(0.2, 3.0), rng.uniform(0.1, 2.0) * s]
    return W, v, mu


def cases():
    """(W, v, e, mu, kind) for the random contacts; kind names how they were built."""
    rng = np.random.default_rng(20261123)
    out = []
    for i in range(360):
        W = _delassus(rng, int(rng.integers(3, 8)), 0.7 if i % 5 else 0.0)
        v = rng.normal(size=3)
        v[0] = -abs(v[0]) - 0.05
        kind = "random"
        if i % 6 == 1:  # at rest in the tangent plane: stick or onset
            v[1:] = 0.0
            kind = "rest"
        e = float(rng.choice([0.0, 1.0, rng.uniform()]))
        mu = float(rng.uniform(0.0, 1.5))
        if i % 17 == 3:
            mu = 0.0
        out.append((W, v, e, mu, kind))
    for i in range(40):
        accelerating = i % 2 == 0
        W, v, mu = _ray_system(rng, accelerating)
        out.append((W, v, float(rng.uniform()), mu, "ray+" if accelerating else "ray-"))
    return out


def _python(W, v, e, mu):
    """The Python kernel's (status, regime, impulse, extras) on the same W and v."""
    try:
        s = contact_kernel(W.tolist(), v.tolist(), 3, e, mu)
    except NonPositiveEffectiveMassError:
        return batch.JAM, None, None, None
    except SingularSystemError:
        return batch.SINGULAR, None, None, None
    except SolverError:
        return batch.NO_SOLUTION, None, None, None
    return batch.OK, s.regime, np.asarray(s.impulse, dtype=float), dict(s.extras)


@pytest.fixture(scope="module")
def solved():
    cs = cases()
    W = np.array([c[0] for c in cs])
    v = np.array([c[1] for c in cs])
    e = np.array([c[2] for c in cs])
    mu = np.array([c[3] for c in cs])
    return cs, W, v, e, mu, contact_impulses(W, v, e, mu, "stronge")


def test_compiled_spatial_kernel_equals_the_python_kernel(solved):
    cs, W, v, e, mu, b = solved
    assert batch.PYTHON_SPATIAL_LAWS == ()
    seen = set()
    worst = 0.0
    for i, (Wi, vi, ei, mi, kind) in enumerate(cs):
        status, regime, pi, extras = _python(Wi, vi, ei, mi)
        assert b.status[i] == status, (i, kind)
        if status != batch.OK:
            assert b.regime[i] == batch.FAILED and np.isnan(b.impulse[i]).all()
            seen.add(batch.STATUS_NAMES[status])
            continue
        assert REGIMES[b.regime[i]] == regime, (i, kind)
        dev = float(np.max(np.abs(b.impulse[i] - pi)) / np.max(np.abs(pi)))
        assert dev <= TOL, (i, kind, dev)
        worst = max(worst, dev)
        phases = extras.get("phases", ())
        seen.add(regime)
        seen.update(phases)
        if extras.get("integration_steps"):
            seen.add("curved")
        elif mi > 0.0 and kind.startswith("ray") and phases[0] == "slip":
            seen.add("ray")
    # every path of the kernel was taken
    assert {"stick", "slide", "frictionless", "slip", "onset", "curved", "ray", "jam"} <= seen
    assert worst <= TOL


def test_compiled_answers_by_hand(solved):
    """Energy never rises; the impulse is in the cone; one linear phase (from rest, or an
    accelerating invariant ray) obeys v_n+ = -e v_n-, a stick v_t+ = 0, an onset slides on
    the cone's boundary against the post-impact slip."""
    cs, W, v, e, mu, b = solved
    checked = {"rest-stick": 0, "rest-onset": 0, "ray+": 0}
    for i, (Wi, vi, ei, mi, kind) in enumerate(cs):
        if b.status[i] != batch.OK:
            continue
        pi = b.impulse[i]
        vplus = vi + Wi @ pi
        # the round-off of v + W pi
        scale = max(float(np.max(np.abs(vi))), float(np.max(np.abs(Wi)) * np.max(np.abs(pi))))
        T_scale = float(pi @ Wi @ pi) + 1e-300
        dT = float(pi @ vi + 0.5 * pi @ Wi @ pi)  # T+ - T-
        assert dT <= 1e-10 * T_scale, (i, kind, dT)
        assert np.hypot(pi[1], pi[2]) <= mi * pi[0] * (1.0 + 1e-10) + 1e-300, (i, kind)
        np.testing.assert_allclose(b.v_plus[i], vplus, rtol=0, atol=1e-12 * scale)
        one_phase = kind == "rest" or (kind == "ray+" and mi > 0.0)
        if not one_phase:
            continue
        assert abs(vplus[0] + ei * vi[0]) <= TOL * scale, (i, kind)  # Newton = energetic
        if kind == "rest" and REGIMES[b.regime[i]] == "stick":
            assert np.max(np.abs(vplus[1:])) <= TOL * scale, i
            checked["rest-stick"] += 1
        elif kind == "rest" and mi > 0.0:
            assert abs(np.hypot(pi[1], pi[2]) - mi * pi[0]) <= TOL * pi[0], i
            cross = pi[1] * vplus[2] - pi[2] * vplus[1]
            assert abs(cross) <= TOL * np.hypot(*pi[1:]) * np.hypot(*vplus[1:]) + 1e-300, i
            assert pi[1:] @ vplus[1:] < 0.0, i
            checked["rest-onset"] += 1
        elif kind == "ray+":
            checked["ray+"] += 1
    assert min(checked.values()) >= 5, checked


def test_resolve_impacts_spatial_stronge_is_compiled(monkeypatch):
    """resolve_impacts from (M, Jc, dq) takes the compiled kernel (no item is left to the
    Python kernel) and equals contact_impulses on its own W and v- bit for bit."""
    def deferred(*args, **kwargs):
        raise AssertionError("a spatial stronge item was deferred to the Python kernel")

    monkeypatch.setattr(batch, "_solve_deferred", deferred)
    rng = np.random.default_rng(5)
    n, k = 200, 4
    A = rng.normal(size=(n, k, k))
    M = A @ A.transpose(0, 2, 1) + 0.3 * np.eye(k)
    J = rng.normal(size=(n, 3, k))
    dq = rng.normal(size=(n, k))
    dq[np.einsum("nk,nk->n", J[:, 0], dq) > 0] *= -1.0
    e = rng.uniform(0.0, 1.0, n)
    mu = rng.uniform(0.0, 1.5, n)
    b = resolve_impacts(M, J, dq, e, mu, "stronge")
    c = contact_impulses(b.delassus, b.v_minus, e, mu, "stronge")
    np.testing.assert_array_equal(c.status, b.status)
    ok = b.status == batch.OK
    assert ok.sum() > 0.9 * n
    np.testing.assert_array_equal(c.impulse[ok], b.impulse[ok])
    assert not b.energy_gained.any()


def test_the_port_mirrors_the_python_kernels_constants():
    """The tolerances and DOP853's coefficients are the Python kernel's (no drift)."""
    from convimpact.impact.laws import stronge_slip as S
    from convimpact.impact.laws import stronge as P

    for name in ("STICK_RTOL", "JAM_RTOL", "SINGULAR_RTOL", "RAY_RTOL", "ODE_RTOL", "STOP_RTOL",
                 "TAIL_RTOL", "FLOOR_RTOL", "MAX_STEPS", "MAX_IMPULSE"):
        assert getattr(S, name) == getattr(P, name), name
    TA, TB, TE3, TE5, ns = P._tableau()
    assert S._NS == ns and S._NE == len(TE5)
    for i in range(1, ns):
        assert tuple(S._A[i, :i]) == TA[i]
    assert tuple(S._B) == TB and tuple(S._E3) == TE3 and tuple(S._E5) == TE5
