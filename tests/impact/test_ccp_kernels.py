"""The compiled single-contact kernels of laws "ccp" and "dissipative" (laws/ccp.py,
laws/dissipative.py) against independent derivations.

Oracles: the planar boundary ray written out by hand (pi = r (1, mu s), r = -(b_n + mu s b_t) /
(W_nn + 2 mu s W_nt + mu^2 W_tt), the sign s chosen by the KKT conditions of the program, not
by the kernel's objective comparison), the KKT residual of the SOC program
(tests/impact/convex_systems.py), Clarabel's conic path as a second method, and the extras
written out from u = W pi + b. The kernels' rare branches (the companion-matrix roots, no KKT
point) are reached by sabotaging the closed-form algebra in plain Python
(``NUMBA_DISABLE_JIT=1``, where the kernels look their helpers up by name), which also checks
that the uncompiled code gives the compiled run's impulses.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import convimpact as ci
from convimpact.impact.exact.dispatch import solve_contact
from convimpact.impact.laws.ccp import NO_KKT_POINT

from .convex_systems import ccp_residual, delassus, newton_b, random_system


def _spd(rng, d):
    A = rng.normal(size=(d, d)) * rng.choice([1e-3, 1.0, 1e3])
    return A @ A.T + rng.choice([1e-4, 0.1, 1.0]) * np.abs(A).max() ** 2 * np.eye(d)


def _approaching(rng, d):
    v = rng.normal(size=d)
    v[0] = -abs(v[0]) - 1e-3
    return v


def _hand_ray(W, b, mu):
    """The planar boundary answer by hand: the ray pi = r (1, mu s) whose optimal point
    r = -(b_n + mu s b_t) / (W_nn + 2 mu s W_nt + mu^2 W_tt) satisfies KKT, i.e. u = W pi + b
    lies on the dual cone's boundary opposite to the ray: u = sigma (mu, -s), sigma >= 0."""
    found = []
    for s in (1.0, -1.0):
        den = W[0, 0] + 2.0 * mu * s * W[0, 1] + mu * mu * W[1, 1]
        r = -(b[0] + mu * s * b[1]) / den
        if not r > 0.0:
            continue
        pi = r * np.array([1.0, mu * s])
        u = W @ pi + b
        tol = 1e-9 * (np.abs(b).max() + np.abs(W).max() * r)
        if u[0] >= -tol and s * u[1] <= tol and abs(u[0] + mu * s * u[1]) <= tol:
            found.append(pi)
    assert len(found) == 1  # the program is strictly convex: one KKT point
    return found[0]


def test_planar_slides_are_the_hand_derived_boundary_ray():
    rng = np.random.default_rng(11)
    n = {"ccp": 0, "dissipative": 0}
    while min(n.values()) < 60:
        W, v = _spd(rng, 2), _approaching(rng, 2)
        e, mu = float(rng.choice([0.0, 1.0, rng.uniform()])), float(rng.uniform(0.05, 3.0))
        for law in n:
            sol = solve_contact(W, v, e, mu, law)
            if sol.regime != "slide":
                continue
            n[law] += 1
            ee = e if law == "ccp" else 0.0
            b = np.array([(1.0 + ee) * v[0], v[1]])
            ray = _hand_ray(W, b, mu)
            scale = np.abs(ray).max()
            if law == "ccp":
                np.testing.assert_allclose(sol.impulse, ray, rtol=0, atol=1e-13 * scale)
                u = W @ sol.impulse + b
                x = sol.extras
                assert set(x) == {"normal_velocity_lift", "post_slip"}
                vs = np.abs(v).max()
                assert x["normal_velocity_lift"] == pytest.approx(u[0], abs=1e-13 * vs)
                assert x["post_slip"][0] == pytest.approx(u[1], abs=1e-13 * vs)
                assert sol.effective_mass is None and sol.warnings == ()
            else:
                np.testing.assert_allclose(sol.impulse, (1.0 + e) * ray, rtol=0,
                                           atol=2e-13 * scale)
                plastic = np.array(sol.extras["plastic_impulse"])
                np.testing.assert_allclose(plastic, ray, rtol=0, atol=1e-13 * scale)
                assert list(sol.impulse) == [(1.0 + e) * p for p in plastic]  # exactly


def test_stick_and_frictionless_answers_and_their_extras():
    W, v = np.array([[2.0, 0.3], [0.3, 1.0]]), np.array([-1.0, 0.2])
    stick = np.linalg.solve(W, -np.array([-1.5, 0.2]))  # b = (1.5 v_n, v_t), e = 0.5
    sol = solve_contact(W, v, 0.5, 2.0, "ccp")
    assert sol.regime == "stick" and dict(sol.extras) == {"normal_velocity_lift": 0.0}
    np.testing.assert_allclose(sol.impulse, stick, rtol=1e-15)
    # dissipative at mu = 0: the frictionless plastic impulse -v_n / W_nn, times 1 + e
    d = solve_contact(W, v, 0.5, 0.0, "dissipative")
    assert d.regime == "frictionless"
    assert d.extras["plastic_impulse"] == (0.5, 0.0)
    assert list(d.impulse) == [0.75, 0.0]
    W3, v3 = np.diag([2.0, 1.0, 1.0]), np.array([-1.0, 0.2, 0.1])
    d = solve_contact(W3, v3, 1.0, 0.0, "dissipative")
    assert d.extras["plastic_impulse"] == (0.5, 0.0, 0.0) and list(d.impulse) == [1.0, 0.0, 0.0]
    assert solve_contact(W, v, 0.5, 0.0, "ccp").regime == "frictionless"


@pytest.mark.filterwarnings("ignore:Solution may be inaccurate")
def test_spatial_slides_satisfy_kkt_agree_with_clarabel_and_report_u():
    n = 0
    for seed in range(40):
        M, Jc, dq, C = random_system(seed, 3, 1, seed % 2)
        W = delassus(M, Jc, C)
        W = 0.5 * (W + W.T)
        v = Jc @ dq
        e, mu = 0.1 + 0.02 * seed, 0.2 + 0.05 * seed
        for law in ("ccp", "dissipative"):
            fast = ci.resolve_impact(M, Jc, dq, e, mu, C, law=law, method="fast")
            if fast.regime != "slide":
                continue
            n += 1
            conic = ci.resolve_impact(M, Jc, dq, e, mu, C, law=law, method="clarabel")
            assert np.linalg.norm(fast.impulse - conic.impulse) <= 1e-6 * np.linalg.norm(
                conic.impulse)
            pi = fast.impulse if law == "ccp" else fast.impulse / (1.0 + e)
            b = newton_b(v, [e if law == "ccp" else 0.0])
            assert ccp_residual(W, b, [mu], 3, pi) < 1e-11
            if law == "ccp":
                x = fast.diagnostics.extras
                u = W @ pi + b
                vs = np.abs(v).max()
                assert set(x) == {"normal_velocity_lift", "post_slip_speed", "direction"}
                assert x["normal_velocity_lift"] == pytest.approx(u[0], abs=1e-12 * vs)
                assert x["post_slip_speed"] == pytest.approx(np.linalg.norm(u[1:]),
                                                             abs=1e-12 * vs)
                np.testing.assert_allclose(np.array(x["direction"]) * mu * pi[0], pi[1:],
                                           rtol=0, atol=1e-13 * np.abs(pi).max())
    assert n >= 20


# run with NUMBA_DISABLE_JIT=1: the plain-Python kernels, then with the closed-form algebra
# sabotaged (laws.ccp's names: both laws' spatial kernels look them up there)
_SCRIPT = r"""
import json, sys
import numpy as np
import convimpact as ci
import convimpact.impact.laws.ccp as ccp
from convimpact.impact.exact.dispatch import solve_contact

cases = json.loads(sys.argv[1])
laws = ("ccp", "dissipative")
out = {"plain": [[solve_contact(W, v, e, mu, law).impulse.tolist() for law in laws]
                 for W, v, e, mu in cases]}
cand = ccp._candidates
z5 = (0.0,) * 5
none = (False, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0, z5, z5, z5, z5)
ccp._newton_root = lambda *E: (1.0, 0.0, False)  # Newton never converges
ccp._candidates = lambda *a: cand(*a) if a[-1] else none  # Ferrari finds no root
out["companion"] = [[solve_contact(W, v, e, mu, law).impulse.tolist() for law in laws]
                    for W, v, e, mu in cases if len(v) == 3]
ccp._candidates = lambda *a: none  # nor does the companion matrix
out["errors"] = []
for law in laws:
    W, v, e, mu = cases[-1]
    try:
        solve_contact(W, v, e, mu, law)
        out["errors"].append(None)
    except ci.SolverError as exc:
        out["errors"].append(str(exc))
print(json.dumps(out))
"""


def test_plain_python_kernels_the_companion_fallback_and_no_kkt_point():
    rng = np.random.default_rng(3)
    cases = []
    for d in (2, 3):
        while sum(len(c[1]) == d for c in cases) < 4:
            W, v = _spd(rng, d), _approaching(rng, d)
            e, mu = float(rng.uniform()), float(rng.uniform(0.1, 1.5))
            if all(solve_contact(W, v, e, mu, law).regime == "slide"
                   for law in ("ccp", "dissipative")):
                cases.append((W.tolist(), v.tolist(), e, mu))
    compiled = [[solve_contact(W, v, e, mu, law).impulse for law in ("ccp", "dissipative")]
                for W, v, e, mu in cases]
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", OPENBLAS_NUM_THREADS="1")
    run = subprocess.run([sys.executable, "-c", _SCRIPT, json.dumps(cases)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    got = json.loads(run.stdout.splitlines()[-1])
    # uncompiled: the compiled run's impulses (libm's hypot and Python's may differ in the
    # last bit, which only moves the boundary answer by round-off)
    for plain, ref in zip(got["plain"], compiled):
        for p, r in zip(plain, ref):
            np.testing.assert_allclose(p, r, rtol=0, atol=4e-16 * np.abs(r).max())
    # Ferrari and Newton sabotaged: the companion matrix's roots give the KKT point
    spatial = [(c, r) for c, r in zip(cases, compiled) if len(c[1]) == 3]
    assert len(got["companion"]) == len(spatial) == 4
    for pair, ((W, v, e, mu), ref) in zip(got["companion"], spatial):
        W, v = np.array(W), np.array(v)
        for law, p, r in zip(("ccp", "dissipative"), pair, ref):
            p = np.array(p) if law == "ccp" else np.array(p) / (1.0 + e)
            b = newton_b(v, [e if law == "ccp" else 0.0])
            assert ccp_residual(W, b, [mu], 3, p) < 1e-10
            scale = np.abs(r).max()
            np.testing.assert_allclose(np.array(pair[0 if law == "ccp" else 1]), r, rtol=0,
                                       atol=1e-10 * scale)
    # every root lost: no certified answer, the typed error (never a wrong root)
    assert got["errors"] == [NO_KKT_POINT, NO_KKT_POINT]
