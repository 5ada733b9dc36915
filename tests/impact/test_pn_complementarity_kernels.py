"""The compiled stick tier and the certified slide solves of law pereira-nikravesh at several
contacts (:mod:`convimpact.impact.laws.pn_complementarity_kernels`, ``_slide``, ``_newton``):
closed forms of a box landing flat (sticking, sliding) and on an edge, and the
interior-point path (Clarabel and its polish, the law's Python path) as the second method
on random impacts."""

import itertools

import numpy as np
import pytest

import convimpact as ci
from convimpact.bench.several_problems import four_corner_box, random_several
from convimpact.impact.conic.clarabel_backend import ClarabelBackend
from convimpact.impact.conic.program import ConeQP
from convimpact.impact.conic.qp import solve_cone_qp
from convimpact.impact.laws import pn_complementarity as pc
from convimpact.impact.laws import pn_complementarity_impulse as pimp
from convimpact.impact.laws.pn_complementarity_slide import slide_set
from convimpact.impact.problem.build import build_problem

LAW = "pereira-nikravesh"


def _resolve(monkeypatch, compiled, **args):
    monkeypatch.setattr(pc, "compiled_kernels", lambda: compiled)
    return ci.resolve_impact(**args, law=LAW)


def _box_inertia(half, m):
    a, b, c = half
    return m / 3.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


@pytest.mark.parametrize("compiled", [True, False])
def test_box_landing_flat_sticks_on_four_corners_by_hand(monkeypatch, compiled):
    """mu = 1, e = 0.5, vertical landing at 1 m/s: every corner sticks with m (1 + e) v / 4
    (the least-norm share of the redundant corners), the box rebounds at e v."""
    m, e, v = 1.0, 0.5, 1.0
    r = _resolve(monkeypatch, compiled, **four_corner_box(mu=1.0, e=e, velocity=(0, 0, -v),
                                                          angular_velocity=(0, 0, 0), mass=m))
    x = r.diagnostics.extras
    assert x["tier"] == "stick" and x["active_set"] == [0, 1, 2, 3]
    assert np.allclose(r.impulse, [[m * (1 + e) * v / 4, 0, 0]] * 4, rtol=0, atol=1e-12)
    assert np.allclose(r.dq_plus, [0, 0, e * v, 0, 0, 0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("compiled", [True, False])
def test_box_landing_on_an_edge_pivots_about_it_by_hand(monkeypatch, compiled):
    """Two corners (a, +-b, -c), e = 0, mu = 1: both stick and the box turns about the edge;
    angular momentum about the edge is conserved: (I_yy + m (a^2 + c^2)) omega_y = -m a v,
    v+ = (omega c, 0, omega a); each corner takes half of m (v+ - v-)."""
    half, m, v = (0.2, 0.15, 0.1), 1.0, 1.0
    a, _, c = half
    args = four_corner_box(mu=1.0, e=0.0, velocity=(0, 0, -v), angular_velocity=(0, 0, 0),
                           half_sizes=half, mass=m)
    args["Jc"] = args["Jc"][2:]  # the corners with x = +a
    r = _resolve(monkeypatch, compiled, **args)
    omega = -m * a * v / (_box_inertia(half, m)[1] + m * (a * a + c * c))
    vplus = np.array([omega * c, 0.0, omega * a])
    assert r.diagnostics.extras["tier"] == "stick"
    assert r.diagnostics.extras["active_set"] == [0, 1]
    assert np.allclose(r.dq_plus, [*vplus, 0, omega, 0], rtol=0, atol=1e-12)
    share = m * (vplus - [0, 0, -v]) / 2  # world (x, y, z) -> frame (n, t1, t2) = (z, x, y)
    assert np.allclose(r.impulse, [[share[2], share[0], share[1]]] * 2, rtol=0, atol=1e-12)


@pytest.mark.parametrize("compiled", [True, False])
def test_box_landing_flat_while_sliding_by_hand(monkeypatch, compiled):
    """vx = 2 > mu vz: no corner can stick; on all four corners (u_n = 0: no pitch, no roll,
    no vertical speed) the most dissipative slide brakes the box by mu m vz along -x:
    v+ = (vx - mu vz, 0, 0), omega+ = 0 (the normals' share is indeterminate, the box's
    velocities are not)."""
    mu, vx, vz = 0.3, 2.0, 1.0
    r = _resolve(monkeypatch, compiled, **four_corner_box(mu=mu, e=0.0, velocity=(vx, 0, -vz),
                                                          angular_velocity=(0, 0, 0)))
    x = r.diagnostics.extras
    assert x["tier"] == "slide" and x["active_set"] == [0, 1, 2, 3]
    assert np.allclose(r.dq_plus, [vx - mu * vz, 0, 0, 0, 0, 0], rtol=0, atol=1e-9)
    assert np.isclose(r.impulse[:, 0].sum(), vz, rtol=1e-9)
    assert np.allclose(r.impulse[:, 1], -mu * r.impulse[:, 0], rtol=0, atol=1e-9)
    assert x["solver_status"] == (pc.CERTIFIED if compiled else x["solver_status"])


def _answer(r):
    x = r.diagnostics.extras
    return (x["tier"], x["active_set"], sorted(x["admissible_active_sets"]), r.regime,
            sorted(r.diagnostics.warnings))


CASES = [(seed, n, d) for seed in range(6) for n in (2, 3, 4) for d in (2, 3)]


@pytest.mark.parametrize("seed,n,d", CASES)
def test_random_impacts_match_the_interior_point_path(monkeypatch, seed, n, d):
    """Random impacts (most sliding): the compiled path's tier, active set, admissible sets,
    regimes and warnings are the interior-point path's, its velocities equal to 1e-8. (Both
    paths run the same stick tier, compiled or as Python; its answers are checked against
    numpy below. The slide programs are two methods: certified Newton, interior point.)"""
    args = random_several(seed, n, d)
    dq = np.asarray(args["dq"], float)
    args["dq"] = dq * (1.0 + 4.0 * (seed % 2))  # odd seeds: larger slip
    slow = _resolve(monkeypatch, False, **args)
    fast = _resolve(monkeypatch, True, **args)
    assert _answer(fast)[:4] == _answer(slow)[:4]
    assert len(fast.diagnostics.warnings) == len(slow.diagnostics.warnings)
    scale = np.max(np.abs(slow.v_plus)) + np.max(np.abs(slow.v_minus))
    assert np.max(np.abs(fast.v_plus - slow.v_plus)) <= 1e-8 * scale


def _numpy_stick_sets(P, margin):
    """Every active set (holding an approaching contact) whose sticking impulse, solved here
    by numpy's least squares, satisfies the law's conditions with ``margin`` (relative to
    the impulses' and velocities' scales; negative: looser, positive: strictly inside):
    cones on A, no penetration off A. {A: T+ - T-}."""
    n, d, W = P.n_contacts, P.dim, P.delassus
    b = P.v_minus.copy()
    b[:, 0] += P.restitution * np.minimum(P.v_minus[:, 0], 0.0)
    vs = np.max(np.abs(P.v_minus))
    closing = P.v_minus[:, 0] < -1e-9 * vs
    out = {}
    for A in itertools.chain(*(itertools.combinations(range(n), k) for k in range(1, n + 1))):
        if not closing[list(A)].any():
            continue
        S = [i * d + a for i in A for a in (range(d) if P.friction[i] > 0 else (0,))]
        x = np.linalg.lstsq(W[np.ix_(S, S)], -b.ravel()[S], rcond=None)[0]
        if np.linalg.norm(W[np.ix_(S, S)] @ x + b.ravel()[S]) > 1e-9 * np.linalg.norm(b):
            continue
        pi = np.zeros(n * d)
        pi[S] = x
        u = (W @ pi + b.ravel()).reshape(n, d)
        p = pi.reshape(n, d)
        ps = max(np.max(np.abs(pi)), 1e-300)
        cones = all(np.linalg.norm(p[i, 1:]) <= P.friction[i] * p[i, 0] - margin * ps
                    and p[i, 0] >= margin * ps for i in A)
        apart = all(u[i, 0] >= margin * vs for i in range(n) if i not in A)
        if cones and apart:
            out[A] = pi @ P.v_minus.ravel() + 0.5 * pi @ W @ pi
    return out


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("seed,n,d", CASES)
def test_random_impacts_stick_by_numpys_least_squares(monkeypatch, compiled, seed, n, d):
    """The stick tier against its definition, solved by numpy: where some active set's
    sticking impulse lies strictly inside the cones with every other contact leaving
    (margin 1e-7), the law sticks; where no set is admissible even loosely (margin -1e-7),
    it slides. A stick answer is a loosely admissible set's sticking impulse (its T+ - T-)
    and dissipates at least as much as every strictly admissible set. The law's kernels
    (compiled or run as Python) decide by the symmetric eigendecomposition, LU and their
    own round-off allowances; numpy here by lstsq and fixed margins. (36 impacts, 15 of
    them stick.)"""
    args = random_several(seed, n, d)
    if seed % 2 == 0:  # even seeds: rough contacts (mu 1.7 to 2.6), most stick
        args["mu"] = np.asarray(args["mu"], float) * 10.0
    P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"])
    strict, loose = _numpy_stick_sets(P, 1e-7), _numpy_stick_sets(P, -1e-7)
    r = _resolve(monkeypatch, compiled, **args)
    x = r.diagnostics.extras
    if strict:
        assert x["tier"] == "stick"
    if not loose:
        assert x["tier"] == "slide"
    if x["tier"] != "stick":
        return
    A = tuple(x["active_set"])
    assert A in loose
    pi = r.impulse.ravel()
    dT = pi @ P.v_minus.ravel() + 0.5 * pi @ P.delassus @ pi
    scale = np.max(np.abs(P.v_minus)) ** 2 / np.max(np.diag(P.delassus))
    assert abs(dT - loose[A]) <= 1e-9 * scale
    assert dT <= min(strict.values(), default=np.inf) + 1e-9 * scale


def _slide_program(P, A):
    d = P.dim
    b = pc.newton_velocity_shift(P)
    idx = np.concatenate([np.arange(i * d, (i + 1) * d) for i in A])
    W = P.delassus[np.ix_(idx, idx)]
    return b, ConeQP(W, P.v_minus[list(A)].ravel(), P.friction[list(A)], d, W[::d],
                     -b[list(A), 0])


@pytest.mark.parametrize("d", [2, 3])
def test_certified_slides_are_clarabels_minimizers(d):
    """Every P_N(A) of random sliding impacts that slide_set certifies has Clarabel's
    minimum (objective to 1e-12 of its scale) and, W being nonsingular, its minimizer."""
    backend = ClarabelBackend()
    certified = 0
    for seed in range(4):
        args = random_several(seed, 4, d)
        args["dq"] = np.asarray(args["dq"], float) * 5.0
        P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"])
        for A in itertools.chain(*(itertools.combinations(range(4), k) for k in (2, 3, 4))):
            b, qp = _slide_program(P, A)
            status, pi = slide_set(np.ascontiguousarray(P.delassus), P.v_minus.ravel().copy(),
                                   b.ravel().copy(), P.friction.astype(float), d,
                                   np.array(A, dtype=np.int64))
            if status != 1:
                continue
            try:
                ref = solve_cone_qp(backend, qp, 1e-10, 200).x
            except ci.ConvImpactError:
                raise AssertionError(f"certified an infeasible program {A}") from None
            x = pi.reshape(4, d)[list(A)].ravel()
            obj = lambda y: 0.5 * y @ qp.W @ y + qp.q @ y  # noqa: E731
            assert abs(obj(x) - obj(ref)) <= 1e-12 * max(abs(obj(ref)), qp.q @ qp.q)
            assert np.max(np.abs(x - ref)) <= 1e-7 * np.max(np.abs(ref))
            certified += 1
    assert certified >= 12  # the others fall back to the interior-point path


def test_compile_kernels_switches_to_the_compiled_path(monkeypatch):
    """Before HOT_CALLS calls (cold cache) the Python path runs; compile_kernels() makes the
    next call compiled (its answer checked against the closed form of the flat landing)."""
    monkeypatch.setattr(pc, "_CALLS", 2)
    monkeypatch.setattr(pc, "HOT_CALLS", 10**6)
    assert pc.compiled_kernels() is False
    assert pimp.compile_kernels() >= 0.0
    assert pc.compiled_kernels() is True
    r = ci.resolve_impact(**four_corner_box(mu=1.0, e=0.0, velocity=(0, 0, -2.0),
                                            angular_velocity=(0, 0, 0)), law=LAW)
    assert np.allclose(r.impulse, [[0.5, 0, 0]] * 4, rtol=0, atol=1e-12)
