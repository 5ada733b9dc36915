"""The distribution chosen among redundant contacts' forces does not jump when the state
moves by round-off (the standard: a law's answer must not jump when its data move by
round-off).

The state: the box stack (problems/box_stack.py) at its tip instant, at rest in its initial
configuration, pushed at the top box's centre by F = ramp m g (t - t_push) = 0.48 m g at
t_tip = 0.44 s, every corner sticking (mu = 0.6): the 12 corners held (the instant before
the lowest box's back corners open) and the 10 left once they have. The distribution is
indeterminate (18 and 13 free directions); the motion is not. Checked independently of the
code under test: each box's corners carry the weight of the boxes above and the push (the
statics of the sub-stack above each level: the normal forces total (n - i) m g, the friction
forces total -F along x and 0 along z), every force lies in its friction cone, and a state
moved by 1e-13 (relative, random directions) moves the distribution by at most 1e-8 of the
force scale m g n / 2. (Before the choice was made in a shell around the largest smallest
margin, the same perturbations moved it by up to 4.9e-6 N with the 12 corners held and by
0.062 N with 10, of a force scale of 14.7 N: the least-norm point of the maximizers' face,
read off the active cones at a degenerate optimum, and Clarabel's accuracy.)
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.scenes import load_scene
from convimpact.simulation.canonical import CanonicalEquations, HeldMode
from convimpact.simulation.sustained import held_forces, redundant_rows

G = 9.81


@pytest.fixture(scope="module")
def stack():
    return load_scene("box_stack")


def _forces(scene, held, theta, dtheta, t):
    """(n_held, 3) held forces (normal, then x and z friction) at (theta, dtheta, t)."""
    mech = scene.mechanism
    mu = scene.parameters["mu"]
    modes = {c: HeldMode("stick", mu=mu) for c in held}
    jac = {c: np.asarray(mech.contact_jacobian(c, theta), float) for c in held}
    M = np.asarray(mech.mass_matrix(theta), float)
    probe = CanonicalEquations(mech, held, modes, dims={c: 3 for c in held})
    dropped = redundant_rows(M, None, probe.rows, jac)
    eq = CanonicalEquations(mech, held, modes, dropped, {c: 3 for c in held})
    y = np.concatenate([theta, eq.momentum(theta, dtheta, np.zeros(eq.n_constraints))])
    forces, _ = held_forces(eq, t, y)
    return np.array([forces[c] for c in held])


@pytest.mark.parametrize("opened", [False, True], ids=["12 held", "10 held"])
def test_the_distribution_at_the_box_stacks_tip_moves_by_round_off_only(stack, opened):
    """1e-9 s before the closed-form tip instant with the 12 corners held (the back corners
    of the lowest box nearly unloaded), 1e-9 s after with those two open (the run locates
    the tip 4.8e-10 s past it, to its event tolerance): there the stack starts to turn
    about the front edge, its accelerations ~1e-8 of g, so the statics hold to 1e-7."""
    p = stack.parameters
    n, m, mu = p["n_boxes"], p["mass"], p["mu"]
    t_tip = p["tip_time"] + (1e-9 if opened else -1e-9)
    rtol = 1e-7 if opened else 1e-9
    names = stack.mechanism.contact_names
    held = [c for c in names if not (opened and c in ("box0_c0", "box0_c3"))]
    theta, dtheta = np.array(stack.theta0, float), np.zeros_like(stack.theta0)
    F0 = _forces(stack, held, theta, dtheta, t_tip)
    push = p["ramp"] * m * G * (t_tip - p["t_push"])
    assert push == pytest.approx(n * m * G * p["width"] / ((2 * n - 1) * p["height"]),
                                 rel=1e-8)
    # statics of the sub-stack above each level (independent of the code)
    for i in range(n):
        rows = [k for k, c in enumerate(held) if c.startswith(f"box{i}_")]
        np.testing.assert_allclose(F0[rows, 0].sum(), (n - i) * m * G, rtol=rtol)
        np.testing.assert_allclose(F0[rows, 1].sum(), -push, rtol=rtol)
        np.testing.assert_allclose(F0[rows, 2].sum(), 0.0, atol=rtol * m * G)
    # friction cones (to the solver's tolerance, 1e-9 of the force scale)
    scale = n * m * G / 2
    cone = mu * F0[:, 0] - np.hypot(F0[:, 1], F0[:, 2])
    assert np.all(cone >= -1e-9 * scale)
    # round-off in the state moves the distribution by round-off
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(6):
        dth = 1e-13 * rng.standard_normal(theta.size) * np.maximum(np.abs(theta), 1.0)
        ddth = 1e-13 * rng.standard_normal(theta.size)
        F1 = _forces(stack, held, theta + dth, dtheta + ddth, t_tip)
        worst = max(worst, float(np.max(np.abs(F1 - F0))))
    assert worst <= 1e-8 * scale, f"moved by {worst:.3g} N"


def test_a_tie_between_a_redundant_group_and_a_determinate_contact_is_continuous():
    """A body on four sticking corners (+-a, 0, +-c), loaded by m g, a push T along x and a
    moment Mz about z (so N_i = m g / 4 -+ Mz / (4 a)), and a fifth, determinate contact
    whose margin is fixed at c5. The corners' margins mu N_i - |T_i| sum to at most
    mu m g - T, so the group's largest smallest margin is (mu m g - T) / 4, reached only
    with T_i = (mu N_i - t*, 0). With c5 equal to it both bind t*: the maximizers' face is
    the single point whichever gives way under round-off, and the distribution chosen is
    that point, moved by round-off only when the data move by 1e-13."""
    from convimpact.simulation.force_distribution import STICK, max_margin_distribution

    m, mu, a, c = 1.0, 0.5, 0.3, 0.2
    T, Mz = 2.0, 0.3
    t_star = (mu * m * G - T) / 4

    def problem(T, Mz, c5):
        B = np.zeros((6, 12))  # rows: force x, y, z, moment x, y, z
        for i, (x, z) in enumerate([(-a, -c), (a, -c), (a, c), (-a, c)]):
            n, t1, t2 = 3 * i, 3 * i + 1, 3 * i + 2
            B[1, n] = B[0, t1] = B[2, t2] = 1.0
            B[3, n], B[4, t1], B[4, t2], B[5, n] = -z, z, -x, x
        rhs = np.array([T, m * G, 0.0, 0.0, 0.0, Mz])
        _, sv, Vt = np.linalg.svd(B)
        Z = Vt[int(np.sum(sv > 1e-12 * sv[0])):].T
        lam0 = np.concatenate([np.linalg.lstsq(B, rhs, rcond=None)[0], [2.0, mu * 2.0 - c5, 0.0]])
        return B, rhs, lam0, np.vstack([Z, np.zeros((3, Z.shape[1]))])

    B, rhs, lam0, Z = problem(T, Mz, t_star)
    lam, margin = max_margin_distribution(np.full(5, mu), 3, [STICK] * 5, lam0, Z, m * G)
    N = m * G / 4 + np.array([-1, 1, 1, -1]) * Mz / (4 * a)
    expected = np.column_stack([N, mu * N - t_star, np.zeros(4)])
    np.testing.assert_allclose(lam[:12].reshape(4, 3), expected, atol=1e-10 * m * G)
    np.testing.assert_allclose(B @ lam[:12], rhs, atol=1e-12 * m * G)
    assert margin == pytest.approx(t_star, abs=1e-10 * m * G)
    rng = np.random.default_rng(3)
    for _ in range(6):
        d = 1.0 + 1e-13 * rng.standard_normal(3)
        _, _, lam0_p, Z_p = problem(T * d[0], Mz * d[1], t_star * d[2])
        lam_p, _ = max_margin_distribution(np.full(5, mu), 3, [STICK] * 5, lam0_p, Z_p, m * G)
        assert np.max(np.abs(lam_p - lam)) <= 1e-8 * m * G
