"""Law ``stronge`` at several contacts: the plastic compression warm-started from the previous
compression (:func:`convimpact.impact.laws.stronge_contacts._warm_plastic`), checked against
closed forms (a box sliding on four corners), Coulomb's conditions written out in the test,
and the fixed point over Clarabel programs on the same problems; and refused where that
would change an answer (a family of motions, redundant impulses an expansion releases)."""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
import convimpact.impact.laws.stronge_contacts as sc
from convimpact.errors import ConvImpactError

from .convex_systems import coulomb_conditions, delassus, random_system

A, B, C = 0.2, 0.15, 0.1  # half sizes of the box (m)
MASS, G, H, MU = 1.0, 9.81, 2e-3, 0.3


def box_on_four_corners():
    """(M, Jcs) of a free box (translation, then rotation rates) with its four bottom
    corners on the floor z = 0 (contact frames: normal z, tangents x, y)."""
    inertia = MASS * np.array([B * B + C * C, A * A + C * C, A * A + B * B]) / 3
    M = np.diag(np.concatenate([np.full(3, MASS), inertia]))
    Jcs = []
    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        p = np.array([sx * A, sy * B, -C])
        rows = [np.concatenate([ax, np.cross(p, ax)]) for ax in np.eye(3)[[2, 0, 1]]]
        Jcs.append(np.array(rows))
    return M, Jcs


@pytest.fixture(autouse=True)
def cold():
    sc._WARM.clear()
    yield
    sc._WARM.clear()


@pytest.fixture
def programs(monkeypatch):
    """Counts the fixed points over cone programs (the path the warm start replaces)."""
    calls = []
    solve = sc.solve_coulomb

    def counted(*args, **kwargs):
        calls.append(1)
        return solve(*args, **kwargs)

    monkeypatch.setattr(sc, "solve_coulomb", counted)
    return calls


def _resolve(M, Jcs, v, e):
    return ci.resolve_impact(M, Jcs, v, [e] * len(Jcs), [MU] * len(Jcs), law="stronge",
                             method="clarabel")


def test_sliding_box_steps_by_closed_form_without_cone_programs(programs):
    """A box sliding at V along x that meets the floor at v_z = -g h on four corners (a
    Moreau-Jean step): u_n = 0 at every corner leaves v_x+ = V - mu g h and no rotation;
    the friction's pitching moment c mu P_n (P_n = m g h) is balanced by a (N_front -
    N_rear) = c mu P_n: each front corner (P_n + c mu P_n / a) / 4, each rear one
    (P_n - c mu P_n / a) / 4, the split symmetric in y (the twist of the four normals moves
    nothing; both paths take the symmetric one). After the first step, no cone program."""
    M, Jcs = box_on_four_corners()
    Pn = MASS * G * H
    front, rear = (Pn + C * MU * Pn / A) / 4, (Pn - C * MU * Pn / A) / 4
    for k, V in enumerate((2.0, 2.0 - MU * G * H, 1.5, 1.49)):
        r = _resolve(M, Jcs, np.array([V, 0, -G * H, 0, 0, 0]), 0.0)
        assert np.allclose(r.dq_plus, [V - MU * G * H, 0, 0, 0, 0, 0], rtol=0, atol=1e-13)
        pi = np.asarray(r.impulse)
        assert np.allclose(pi[:, 0], [rear, front, front, rear], rtol=1e-6, atol=0)
        assert np.allclose(pi[:, 1], -MU * pi[:, 0], rtol=1e-12, atol=0)
        assert np.allclose(pi[:, 2], 0.0, atol=1e-12 * Pn)
        assert len(programs) == 1  # only the first step solved cone programs


def test_box_at_rest_keeps_its_weight_without_cone_programs(programs):
    """At rest each corner carries a quarter of m g h (the symmetric split), v+ = 0."""
    M, Jcs = box_on_four_corners()
    for _ in range(3):
        r = _resolve(M, Jcs, np.array([0, 0, -G * H, 0, 0, 0.0]), 0.0)
        assert np.allclose(r.dq_plus, 0.0, atol=1e-15)
        assert np.allclose(np.asarray(r.impulse)[:, 0], MASS * G * H / 4, rtol=1e-6)
    assert len(programs) == 1


def test_spinning_box_is_a_family_of_motions_and_keeps_the_cone_programs(programs):
    """Sliding and spinning on four corners, the split of the normal impulses changes the
    friction moments, hence the velocities: Coulomb's law has a family of solutions, the
    warm start is refused and the answer is the fixed point's, as without a previous call."""
    M, Jcs = box_on_four_corners()
    v1 = np.array([2.0, 1.3, -G * H, 0, 0, 2.0])
    v2 = v1 + np.array([-MU * G * H, 0, 0, 0, 0, -0.01])
    _resolve(M, Jcs, v1, 0.0)
    r = _resolve(M, Jcs, v2, 0.0)
    assert len(programs) == 2
    sc._WARM.clear()
    cold = _resolve(M, Jcs, v2, 0.0)
    assert np.array_equal(r.impulse, cold.impulse)


def test_redundant_contacts_with_restitution_keep_the_cone_programs(programs):
    """e > 0 releases Poisson's share of each corner's compression impulse: the split among
    redundant corners would then change the velocities, so the warm start is refused."""
    M, Jcs = box_on_four_corners()
    for _ in range(2):
        _resolve(M, Jcs, np.array([1.0, 0, -0.5, 0, 0, 0]), 0.5)
    assert len(programs) == 2


@pytest.mark.parametrize("d", [2, 3])
def test_unique_solutions_warm_equal_the_fixed_point(d, programs):
    """Coupled contacts with a nonsingular W (random systems): the second of two nearby
    impacts is warm-started; its impulse meets Coulomb's conditions in the compression
    (written out here) and equals the fixed point's answer on the same problem."""
    taken = 0
    for seed in range(12):
        M, Jc, dq, _ = random_system(seed, d, 3, 0)
        W = delassus(M, Jc)
        e = 0.4
        dq2 = dq * (1.0 + 1e-4)
        try:
            _resolve(M, Jc, dq, e)
            before = len(programs)
            r = _resolve(M, Jc, dq2, e)
        except ConvImpactError:
            continue
        if len(programs) > before:
            continue  # refused (its active set moved): nothing to compare
        taken += 1
        sc._WARM.clear()
        cold = _resolve(M, Jc, dq2, e)
        scale = np.max(np.abs(cold.impulse))
        assert np.max(np.abs(np.asarray(r.impulse) - cold.impulse)) < 1e-9 * scale
        assert np.max(np.abs(np.asarray(r.dq_plus) - cold.dq_plus)) < 1e-9 * np.max(
            np.abs(cold.dq_plus))
        # the compression phase itself: Coulomb's conditions with e = 0 at round-off
        J = np.concatenate(Jc).reshape(-1, M.shape[0])
        pc = _compression(M, Jc, dq2, e)
        assert coulomb_conditions(W, J @ dq2, [MU] * 3, d, pc.ravel()) < 1e-10
    assert taken >= 3


def _compression(M, Jc, dq, e):
    """The compression phase's impulse (n, d) of the law on that impact."""
    from convimpact.impact.conic.paths import ProgramOptions, backend
    from convimpact.impact.problem.build import build_problem

    P = build_problem(M, Jc, dq, np.full(len(Jc), e), np.full(len(Jc), MU))
    return sc._plastic(P, backend("clarabel"), ProgramOptions())[0]


def test_warm_kernel_residual_and_statuses_by_hand():
    """The kernel's Coulomb residual of pi = 0 on an approaching contact pair is
    max_i(-b_n,i / max(1, mu_i)) / |b| (the dual-cone violation, by hand); from a start on the
    exact sticking answer -W^-1 b (inside the cones, W nonsingular) it returns that answer,
    locally unique; from a start far from every solution it certifies nothing."""
    from convimpact.impact.laws.stronge_contacts_warm import (FAILED, UNIQUE, _coulomb_residual,
                                                              warm_compression)

    rng = np.random.default_rng(2)
    A = rng.normal(size=(6, 6))
    W = A @ A.T + np.eye(6)
    mu = np.array([0.9, 1.2])
    stick = np.array([1.0, 0.1, -0.2, 0.5, 0.05, 0.1])
    b = -W @ stick
    r0 = _coulomb_residual(W, b, mu, 3, np.zeros(6))
    assert r0 == pytest.approx(max(-b[0], -b[3] / 1.2, 0.0) / np.linalg.norm(b), rel=1e-14)
    status, pi, resid = warm_compression(W, b, mu, 3, stick * (1 + 1e-7))
    assert status == UNIQUE and resid < 1e-14
    assert np.allclose(pi, stick, rtol=0, atol=1e-14)
    status, _, resid = warm_compression(W, b, mu, 3, -stick)
    assert status == FAILED and resid == np.inf


def test_islands_of_one_kind_in_different_states_each_find_their_start(programs):
    """A box at rest and a box sliding (the same four corners, mu): called in turn, as the
    islands of one Moreau-Jean step, each is warm-started from its own last compression
    once both have been solved, and keeps its closed form (v+ = 0; v_x+ = V - mu g h)."""
    M, Jcs = box_on_four_corners()
    for k in range(4):
        rest = _resolve(M, Jcs, np.array([0, 0, -G * H, 0, 0, 0.0]), 0.0)
        V = 2.0 - k * MU * G * H
        slide = _resolve(M, Jcs, np.array([V, 0, -G * H, 0, 0, 0]), 0.0)
        assert np.allclose(rest.dq_plus, 0.0, atol=1e-15)
        assert np.allclose(slide.dq_plus, [V - MU * G * H, 0, 0, 0, 0, 0], atol=1e-13)
    assert len(programs) == 2
