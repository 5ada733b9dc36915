"""Law "stronge"'s compiled kernels -- the one implementation
(convimpact.impact.laws.stronge and .stronge_slip), run alike by solve_contact, the batch and
the lanes -- against derivations independent of them.

Hundreds of random spatial contacts (W = Jc M^-1 Jc^T from random M and Jc, approaching v,
e in [0, 1], mu in [0, 1.5]) with curved slips, sticks, slips that stop and restart in the
selected direction (onset), contacts at rest in the tangent plane, slips on invariant rays
(accelerating, and decelerating to a stop) and a jam, through ``contact_impulses(W, v, e, mu,
"stronge")``:

* against an independent integration of the impulse-space ODE dv/dp = W (n - mu s) by
  scipy's solve_ivp (DOP853 at rtol 1e-12; the stop, v_n = 0 and the energetic stop
  condition W_n(p_f) - W_n(p_c) = -e^2 W_n(p_c) found by brentq on the work integral; the
  slip direction at rest by a grid and brentq on the circle: ``brute_force`` of
  tests/impact/test_stronge.py): the same phases and impulses to 1e-9 relative;
* the jam, independently: the same ODE integrated by solve_ivp re-approaches (v_n back to 0
  from above) before restitution has restored e^2 of the compression's work, at the dv_n/dp
  the error names;
* by hand: energy never rises, the impulse is in the cone, one linear phase (from rest, or on
  an accelerating invariant ray) obeys Newton's v_n+ = -e v_n-, a stick v_t+ = 0, an onset
  slides on the cone's boundary against the post-impact slip; every solved item reports
  energetic restitution e, friction work <= 0 and works that add up to T+ - T-.

Planar cases worked by hand (a slip that stops and sticks, a slip reversal) through the
batch and solve_contact; the law's own error messages; and the same code run as plain Python
(NUMBA_DISABLE_JIT=1, in a subprocess) gives the compiled impulses, and there reaches the
step-size underflow (SolverError) with an unmeetable tolerance.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

pytest.importorskip("numba")  # the compiled kernels (an optional dependency)

from convimpact.impact.batch import impacts as batch  # noqa: E402
from convimpact.impact.batch.impacts import REGIMES, contact_impulses, resolve_impacts  # noqa: E402
from convimpact.errors import (NonPositiveEffectiveMassError,  # noqa: E402
                                      SingularSystemError)
from convimpact.impact.exact.dispatch import solve_contact  # noqa: E402

from .test_stronge import brute_force  # noqa: E402  (the independent solve_ivp integration)

TOL = 1e-10
#: against the independent integration (its own error is ~1e-11: test_stronge.py)
REF_TOL = 1e-9


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


@pytest.fixture(scope="module")
def solved():
    cs = cases()
    W = np.array([c[0] for c in cs])
    v = np.array([c[1] for c in cs])
    e = np.array([c[2] for c in cs])
    mu = np.array([c[3] for c in cs])
    return cs, W, v, e, mu, contact_impulses(W, v, e, mu, "stronge")


def test_spatial_batch_against_an_independent_integration(solved):
    """Every solved item: solve_contact's answer (the same kernel: equal bit for bit) and, on
    the rays, the contacts at rest and every eighth random contact, solve_ivp's integration in
    p: the same phases, compression impulse and impulse; frictionless items are Newton's."""
    cs, W, v, e, mu, b = solved
    seen = set()
    checked = 0
    for i, (Wi, vi, ei, mi, kind) in enumerate(cs):
        if b.status[i] != batch.OK:
            seen.add(batch.STATUS_NAMES[int(b.status[i])])
            continue
        regime = REGIMES[b.regime[i]]
        seen.add(regime)
        if mi == 0.0:
            assert regime == "frictionless"
            np.testing.assert_allclose(b.impulse[i], [-(1.0 + ei) * vi[0] / Wi[0, 0], 0.0, 0.0],
                                       rtol=1e-15)
            continue
        sol = solve_contact(Wi, vi, ei, mi, "stronge")
        np.testing.assert_array_equal(b.impulse[i], sol.impulse)
        assert sol.regime == regime
        phases = sol.extras["phases"]
        seen.update(phases)
        if sol.extras.get("integration_steps"):
            seen.add("curved")
        elif kind.startswith("ray") and phases[0] == "slip":
            seen.add("ray")
        if kind == "random" and i % 8:
            continue
        pi, pc, _, kinds, _ = brute_force(Wi, vi, ei, mi)
        np.testing.assert_allclose(b.impulse[i], pi, rtol=REF_TOL, atol=REF_TOL * pi[0])
        assert list(phases) == kinds, (i, kind)
        assert sol.extras["compression_impulse"] == pytest.approx(pc, rel=REF_TOL)
        checked += 1
    # every path of the kernel was taken, and checked against the integration
    assert {"stick", "slide", "frictionless", "slip", "onset", "curved", "ray", "jam"} <= seen
    assert checked >= 120


def _reapproach(W, v, e, mu):
    """Independent of the kernel: the slip dv/dp = W (n - mu s), dW_n/dp = v_n integrated in p
    by solve_ivp while it slips (it must not stop before), to twice the re-approach impulse p_r
    where v_n falls back to 0: (W_n(p_c), W_n(p_r) - W_n(p_c), dv_n/dp on [p_r, 2 p_r]), p_c where
    v_n reaches 0 (the end of compression)."""
    vscale = float(np.max(np.abs(v)))

    def rhs(p, y):
        s = y[1:3] / np.linalg.norm(y[1:3])
        return np.r_[W @ np.r_[1.0, -mu * s], y[0]]

    def rising(p, y):
        return y[0]

    def falling(p, y):
        return y[0]

    def stop(p, y):
        return np.linalg.norm(y[1:3]) - 1e-10 * vscale

    rising.direction, falling.direction = 1, -1
    stop.direction, stop.terminal = -1, True
    first = solve_ivp(rhs, (0.0, 1e3 * abs(v[0]) / W[0, 0]), np.r_[v, 0.0], method="DOP853",
                      rtol=1e-12, atol=1e-14 * vscale, events=(rising, falling, stop),
                      dense_output=True)
    pc, pr = first.t_events[0][0], first.t_events[1][0]
    assert not len(first.t_events[2]) or first.t_events[2][0] > 2.0 * pr
    sol = solve_ivp(rhs, (0.0, 2.0 * pr), np.r_[v, 0.0], method="DOP853", rtol=1e-12,
                    atol=1e-14 * vscale, events=stop, dense_output=True)
    assert sol.status == 0  # slipping throughout
    Wc = sol.sol(pc)[3]
    Y = sol.sol(np.linspace(pr, 2.0 * pr, 4001))
    an = W[0, 0] - mu * (W[0, 1:] @ Y[1:3]) / np.linalg.norm(Y[1:3], axis=0)
    return Wc, sol.sol(pr)[3] - Wc, an


def test_the_jam_reapproaches_before_restitution_ends(solved):
    """A jammed item re-approaches in restitution with the energy condition unmet (by an
    independent integration), and the error says so, at the dv_n/dp of its slip there."""
    cs, W, v, e, mu, b = solved
    jams = np.flatnonzero(b.status == batch.JAM)
    assert jams.size
    for i in jams:
        Wi, vi, ei, mi, kind = cs[i]
        Wc, Wr, an = _reapproach(Wi, vi, ei, mi)
        assert Wc < 0.0 and Wr < ei * ei * -Wc  # v_n < 0 again, e^2 |W_c| not restored
        assert an[0] < 0.0
        with pytest.raises(NonPositiveEffectiveMassError) as info:
            solve_contact(Wi, vi, ei, mi, "stronge")
        msg = str(info.value)
        assert "the restitution of this contact cannot end" in msg and "slip phase" in msg
        # the kernel names dv_n/dp at its first accepted step past the re-approach: a value
        # of the slip's dv_n/dp just after p_r (printed to 4 digits)
        reported = float(re.search(r"dv_n/dp_n = (\S+) per", msg).group(1))
        assert np.min(np.abs(an - reported)) <= 1e-3 * abs(reported)


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


def test_energetic_restitution_and_friction_work(solved):
    """Every solved spatial item with friction: the energetic restitution is e, friction only
    dissipates, and the works add up to T+ - T- = pi.v- + 1/2 pi.W.pi (eq. 58); the phases'
    boundaries rise from 0 to p_f, compression ending inside."""
    cs, W, v, e, mu, b = solved
    n = 0
    for i, (Wi, vi, ei, mi, kind) in enumerate(cs):
        if b.status[i] != batch.OK or mi == 0.0:
            continue
        ex = solve_contact(Wi, vi, ei, mi, "stronge").extras
        pi = b.impulse[i]
        dT = float(pi @ vi + 0.5 * pi @ Wi @ pi)
        T_scale = abs(vi[0]) * pi[0]
        dT_roundoff = 1e-12 * float(np.abs(pi) @ (np.abs(vi) + np.abs(Wi) @ np.abs(pi)))
        assert ex["energetic_restitution"] == pytest.approx(ei, abs=1e-9), i
        assert ex["friction_work"] <= 1e-12 * T_scale, i
        assert ex["normal_work_compression"] + ex["normal_work_restitution"] \
            + ex["friction_work"] == pytest.approx(dT, abs=dT_roundoff), i
        bounds = ex["phase_impulses"]
        assert bounds[0] == 0.0 and bounds[-1] == pi[0] and len(bounds) == len(ex["phases"]) + 1
        assert all(x < y for x, y in zip(bounds, bounds[1:]))
        assert 0.0 < ex["compression_impulse"] <= pi[0]
        n += 1
    assert n > 300


def test_planar_cases_by_hand_through_the_batch():
    """Worked by hand (phases linear in p, numbers in the comments): a slip that stops and
    sticks, and a slip that stops and reverses; the batch and solve_contact agree with them,
    e is the energetic restitution and friction's work is the hand integral of pi_t' v_t."""
    # slip then stick: W = [[2, .5], [.5, 1]], v- = (-1, .2), mu = .8, e = .5. Slip:
    # lambda = -.8, dv_n/dp = 1.6, dv_t/dp = -.3, stops at p_s = 2/3 after compression ended
    # at 1/1.6 (W_c = -1/3.2); restitution has gained 1/720 by p_s; stick, dv_n/dp = 1.75 from
    # v_n = 1/15: x/15 + .875 x^2 = e^2 / 3.2 - 1/720. Friction work: -.8 int_0^(2/3)
    # (.2 - .3 p) dp = -4/75, none while sticking.
    x = (-1 / 15 + math.sqrt(1 / 225 + 3.5 * (0.078125 - 1 / 720))) / 1.75
    stick = ([2 / 3 + x, -0.8 * 2 / 3 - 0.5 * x], "stick", ("slip", "stick"), -4 / 75)
    # slip then reversal: W = [[1, -.6], [-.6, 1]], v- = (-1, .2), mu = .3, e = 1. Slip:
    # dv_n/dp = 1.18, dv_t/dp = -.9, stops at p_s = 2/9; |W_tn| > mu W_tt: reversal, lambda =
    # +.3, dv_n/dp = .82, dv_t/dp = -.3; e = 1: restitution until W_n = 0. Friction work:
    # -.3 int_0^(2/9) (.2 - .9 p) dp + .3 int (-.3 (p - p_s)) dp = -1/150 - .045 (p_f - p_s)^2.
    ps, an1, an2 = 2 / 9, 1.18, 0.82
    vs = -1 + an1 * ps
    pc = ps - vs / an2
    Wc = -ps + 0.5 * an1 * ps ** 2 + vs * (pc - ps) + 0.5 * an2 * (pc - ps) ** 2
    pf = pc + math.sqrt(-2 * Wc / an2)
    reversal = ([pf, -0.3 * ps + 0.3 * (pf - ps)], "slide", ("slip", "reversal"),
                -1 / 150 - 0.045 * (pf - ps) ** 2)
    W = np.array([[[2.0, 0.5], [0.5, 1.0]], [[1.0, -0.6], [-0.6, 1.0]]])
    v = np.array([[-1.0, 0.2], [-1.0, 0.2]])
    e, mu = np.array([0.5, 1.0]), np.array([0.8, 0.3])
    b = contact_impulses(W, v, e, mu, "stronge")
    for i, (impulse, regime, phases, friction) in enumerate((stick, reversal)):
        assert b.status[i] == batch.OK and REGIMES[b.regime[i]] == regime
        np.testing.assert_allclose(b.impulse[i], impulse, rtol=1e-13)
        sol = solve_contact(W[i], v[i], e[i], mu[i], "stronge")
        np.testing.assert_array_equal(sol.impulse, b.impulse[i])
        assert sol.extras["phases"] == phases
        assert sol.extras["energetic_restitution"] == pytest.approx(e[i], rel=1e-12)
        assert sol.extras["friction_work"] == pytest.approx(friction, rel=1e-12)
        assert sol.extras["phase_impulses"][1] == pytest.approx(2 / 3 if i == 0 else ps,
                                                                rel=1e-14)
    vt_plus = 0.2 - 0.6 * b.impulse[1, 0] + b.impulse[1, 1]
    assert vt_plus < 0.0  # reversed; its last friction opposes it


def test_singular_w_messages():
    """The stick decision on a singular W: the planar det W (sticking admissible), the spatial
    det W_tt (from rest) -- SingularSystemError naming it, status SINGULAR in the batch."""
    planar = np.array([[1.0, 1.0], [1.0, 1.0]])
    with pytest.raises(SingularSystemError, match=r"slip reached zero and W is singular "
                                                  r"\(det = 0\.000e\+00\)"):
        solve_contact(planar, [-1.0, 0.0], 0.5, 2.0, "stronge")
    spatial = np.array([[2.0, 0.1, 0.1], [0.1, 1.0, 1.0], [0.1, 1.0, 1.0]])
    with pytest.raises(SingularSystemError, match="W_tt is singular"):
        solve_contact(spatial, [-1.0, 0.0, 0.0], 0.5, 0.3, "stronge")
    assert contact_impulses(planar, [-1.0, 0.0], 0.5, 2.0, "stronge").status[0] == \
        batch.SINGULAR
    assert contact_impulses(spatial, [-1.0, 0.0, 0.0], 0.5, 0.3, "stronge").status[0] == \
        batch.SINGULAR


#: a planar slip that stops and sticks, and a spatial curved slip (DOP853 steps)
_PLAIN = {"planar": ([[2.0, 0.5], [0.5, 1.0]], [-1.0, 0.2], 0.5, 0.8),
          "spatial": ([[1.3, 0.4, -0.3], [0.4, 1.1, 0.2], [-0.3, 0.2, 0.9]], [-1.0, 0.5, 0.3],
                      0.5, 0.4)}

_PLAIN_RUN = """
import json, sys
from convimpact.errors import SolverError
from convimpact.impact.exact.dispatch import solve_contact
from convimpact.impact.laws import stronge_dop853, stronge_slip
cases = json.loads(sys.argv[1])
out = {"compiled": type(stronge_slip._stronge_spatial).__name__ != "function"}
for name, (W, v, e, mu) in cases.items():
    sol = solve_contact(W, v, e, mu, "stronge")
    out[name] = [sol.impulse.tolist(), list(sol.extras["phases"]),
                 sol.extras.get("integration_steps", 0)]
stronge_dop853.ODE_RTOL = 1e-300  # (plain Python reads it at run time) no step can meet it
try:
    W, v, e, mu = cases["spatial"]
    solve_contact(W, v, e, mu, "stronge")
    out["underflow"] = None
except SolverError as exc:
    out["underflow"] = str(exc)
print(json.dumps(out))
"""


def test_plain_python_gives_the_compiled_impulses():
    """NUMBA_DISABLE_JIT=1 (a subprocess): the kernels run as plain Python -- the planar path
    gives the compiled impulse exactly, the spatial integration to round-off (its step-size
    control turns last-bit differences of math.hypot into a few more or fewer steps) -- and an
    unmeetable tolerance ends in the step size's underflow, SolverError."""
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", OPENBLAS_NUM_THREADS="1")
    run = subprocess.run([sys.executable, "-c", _PLAIN_RUN, json.dumps(_PLAIN)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    plain = json.loads(run.stdout.strip().splitlines()[-1])
    assert plain["compiled"] is False
    for name, (W, v, e, mu) in _PLAIN.items():
        sol = solve_contact(W, v, e, mu, "stronge")
        impulse, phases, steps = plain[name]
        assert phases == list(sol.extras["phases"])
        if name == "planar":
            np.testing.assert_array_equal(impulse, sol.impulse)
        else:
            assert steps > 0 and sol.extras["integration_steps"] > 0
            np.testing.assert_allclose(impulse, sol.impulse, rtol=1e-12)
    assert "step size underflow" in plain["underflow"]
