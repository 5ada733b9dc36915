"""The contact-problem corpus (convimpact.bench.contact_corpus) and its peers' measures
(convimpact.bench.contact_peers), against numbers derived by hand or by dense algebra."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from convimpact.bench import contact_scenes as cs
from convimpact.bench.contact_corpus import FAMILIES, corpus, quick_corpus
from convimpact.bench.contact_peers import (natural_map_residual, pinocchio_contact_call,
                                            project_friction_cones)

HAS_PIN = importlib.util.find_spec("pinocchio") is not None


def _has_robot_data() -> bool:
    if not HAS_PIN:
        return False
    from convimpact.model.pinocchio_robots import RobotDataUnavailableError, robot_data_dir

    try:
        robot_data_dir()
    except RobotDataUnavailableError:
        return False
    return True


#: the robot-feet family needs Pinocchio and example-robot-data (the test-full extra)
HAS_ROBOTS = _has_robot_data()


@pytest.fixture(scope="module")
def quick():
    return {c.name: c for c in quick_corpus()}


@pytest.fixture(scope="module")
def full():
    return corpus()


def test_full_corpus_shape(full):
    names = [c.name for c in full]
    sizes = np.array([c.n_contacts for c in full])
    assert len(set(names)) == len(names)
    assert 50 <= len(full) <= 70
    assert sizes.min() == 2 and sizes.max() == 1000
    # roughly log-uniform: every decade 2-10, 10-100, 100-1000 holds at least a sixth
    for lo, hi in ((2, 10), (10, 100), (100, 1001)):
        assert np.sum((sizes >= lo) & (sizes < hi)) >= len(full) / 6
    assert {c.family for c in full} == set(FAMILIES) - ({"robot-feet"} if not HAS_ROBOTS else set())
    assert {c.dim for c in full} == {2, 3}
    assert any(np.any(c.mu == 0.0) for c in full)
    assert all(np.all((c.mu == 0.0) | ((c.mu >= 0.1) & (c.mu <= 1.0))) for c in full)
    assert all(c.e == 0.0 for c in full if c.mode == "rest")
    assert all(0.0 < c.e < 0.6 for c in full if c.mode == "impact" and c.family != "small")
    assert [c.name for c in corpus(max_contacts=10)] == [c.name for c in full
                                                         if c.n_contacts <= 10]


def test_quick_corpus(quick):
    # one robot case (robot-feet-1talos-8) among the twelve, when the robot data are there
    assert len(quick) == (12 if HAS_ROBOTS else 11)
    assert max(c.n_contacts for c in quick.values()) <= 100
    assert {c.family for c in quick.values()} == set(FAMILIES) - (
        {"robot-feet"} if not HAS_ROBOTS else set())


def test_delassus_is_J_Minv_JT_by_dense_inverse(quick):
    for c in quick.values():
        if c.k > 200:
            continue
        J, M = c.J.toarray(), c.M.toarray()
        W = J @ np.linalg.inv(M) @ J.T
        assert np.allclose(c.W.toarray(), W, rtol=1e-10, atol=1e-10 * np.abs(W).max()), c.name
        assert np.allclose(M, M.T) and np.linalg.eigvalsh(M).min() > 0.0, c.name
        assert c.W.shape == (c.n_contacts * c.dim,) * 2 and c.b.shape == (c.n_contacts * c.dim,)
        assert c.mu.shape == (c.n_contacts,) and c.dq.shape == (c.k,)


def test_W_symmetric_psd(quick):
    for c in quick.values():
        W = c.W.toarray()
        assert np.array_equal(W, W.T), c.name
        lam = np.linalg.eigvalsh(W)
        assert lam.min() >= -1e-12 * lam.max(), c.name


def test_restitution_shift_on_normal_rows_only(quick):
    for c in quick.values():
        v = (c.J.toarray() @ c.dq).reshape(c.n_contacts, c.dim)
        expected = v.copy()
        expected[:, 0] = np.where(v[:, 0] < 0.0, (1.0 + c.e) * v[:, 0], v[:, 0])
        assert np.allclose(c.b.reshape(-1, c.dim), expected, rtol=1e-12, atol=1e-14), c.name


def test_box_ranks():
    # one box on 4 corners: 12 rows on 6 coordinates, the 4 corners span every twist
    c = corpus(names=["box-stack-4", "box-stack-16", "four-corner-box"])
    ranks = {x.name: np.linalg.matrix_rank(x.W.toarray(), hermitian=True) for x in c}
    assert ranks["box-stack-4"] == 6 and ranks["four-corner-box"] == 6
    # 4 boxes: 16 contacts, 48 rows; rank 6 N = 24 < 12 N = 48
    assert ranks["box-stack-16"] == 24


def test_contact_frames_orthonormal_and_normal_first(quick):
    for name in ("box-stack-16", "box-wall-3x3-44", "sphere-pile-sq-29", "capsule-pile-3x3-24",
                 "planar-stack-20", "rod-on-rod-3"):
        c = quick[name]
        d, f = c.dim, (6 if c.dim == 3 else 3)
        J = c.J.toarray()
        for i, (lower, upper) in enumerate(c.geometry["pairs"]):
            frame = J[d * i:d * i + d, f * upper:f * upper + d]  # linear part on the upper body
            assert np.allclose(frame @ frame.T, np.eye(d), atol=1e-14), name
            assert np.allclose(frame[0], c.geometry["normals"][i]), name
            if lower >= 0:  # the lower body sees the opposite rows
                assert np.allclose(J[d * i:d * i + d, f * lower:f * lower + d], -frame)


def test_sphere_pile_normals_along_centres(quick):
    c = quick["sphere-pile-sq-29"]
    g = c.geometry
    n, centres = g["normals"], g["centres"]
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-15)
    J = c.J.toarray()
    for i, (lower, upper) in enumerate(g["pairs"]):
        if lower < 0:
            assert np.allclose(n[i], [0, 0, 1])
            assert np.isclose(centres[upper][2], 0.05)
            continue
        axis = centres[upper] - centres[lower]
        assert np.isclose(np.linalg.norm(axis), 0.1, rtol=1e-12)  # touching: 2 R
        assert np.allclose(n[i], axis / 0.1, atol=1e-14)
        assert np.allclose(g["points"][i], (centres[upper] + centres[lower]) / 2)
        # a normal along the centres has no moment about either centre
        assert np.allclose(J[3 * i, 6 * upper + 3:6 * upper + 6], 0.0, atol=1e-15)
        assert np.allclose(J[3 * i, 6 * lower + 3:6 * lower + 6], 0.0, atol=1e-15)


def test_hand_contact_counts():
    rng = np.random.default_rng(0)
    assert cs.box_stack(rng, 3).n_contacts == 12          # 3 interfaces x 4 corners
    assert cs.box_wall(rng, 3, 2).n_contacts == 12 + 16   # 3 bricks on the floor, 2 on 2 each
    assert cs.box_wall(rng, 3, 3).n_contacts == 12 + 16 + 16  # third row: 2 ends on 1, 1 on 2
    assert cs.sphere_pile(rng, 3, "square").n_contacts == 9 + 4 * 4 + 4
    assert cs.sphere_pile(rng, 3, "hex").n_contacts == 6 + 3 * 3 + 3
    assert cs.capsule_pile(rng, 3, 2).n_contacts == 2 * 3 + 3 * 3
    assert cs.rod_on_rod(rng).n_contacts == 3
    assert cs.planar_stack(rng, 3).n_contacts == 6
    sq = cs.sphere_pile(rng, 2, "square")  # 4 on the floor, the top one on all 4
    assert sum(1 for a, b in sq.pairs if b == 4) == 4


@pytest.mark.skipif(not HAS_PIN, reason="Pinocchio (pin) not installed")
def test_robot_contact_counts_and_ranks():
    from convimpact.bench.contact_corpus import corpus_notes

    c = {x.name: x for x in corpus(families=["robot-feet"], max_contacts=8)}
    if corpus_notes():
        pytest.skip("; ".join(corpus_notes()))
    talos, solo = c["robot-feet-1talos-8"], c["robot-feet-1solo-4"]
    assert (talos.n_contacts, talos.k, solo.n_contacts, solo.k) == (8, 38, 4, 18)
    # two rigid soles: rank 6 each; four point feet on 18 coordinates: rank 12
    assert np.linalg.matrix_rank(talos.W.toarray(), hermitian=True) == 12
    assert np.linalg.matrix_rank(solo.W.toarray(), hermitian=True) == 12


def test_deterministic():
    a, b = quick_corpus(), quick_corpus()
    for x, y in zip(a, b):
        assert x.name == y.name
        for f in ("W", "J", "M"):
            assert (getattr(x, f) != getattr(y, f)).nnz == 0
        for f in ("b", "mu", "dq"):
            assert np.array_equal(getattr(x, f), getattr(y, f))
        assert x.e == y.e


def test_projection_hand_cases():
    P = project_friction_cones
    assert np.allclose(P(np.array([[1.0, 0.3, -0.4]]), 0.6), [[1.0, 0.3, -0.4]])  # inside
    assert np.allclose(P(np.array([[-2.0, 0.3, 0.4]]), 1.0), 0.0)  # polar: |t| = .5 <= 2 / 1
    assert np.allclose(P(np.array([[0.0, 2.0, 0.0]]), 1.0), [[1.0, 1.0, 0.0]])
    # mu = 1/2, x = (1, 3, 4): s = 5, abscissa (1 + 2.5) / 1.25 = 2.8, |t| = 1.4 along (3, 4)/5
    p = P(np.array([[1.0, 3.0, 4.0]]), 0.5)
    assert np.allclose(p, [[2.8, 0.84, 1.12]])
    assert np.isclose((np.array([1.0, 3.0, 4.0]) - p[0]) @ p[0], 0.0)
    assert np.allclose(P(np.array([[0.0, -2.0]]), 1.0), [[1.0, -1.0]])  # planar
    assert np.allclose(P(np.array([[2.0, 1.0], [-1.0, 3.0]]), [0.0, 0.0]),
                       [[2.0, 0.0], [0.0, 0.0]])  # mu = 0: the normal half-line
    x = np.array([[1.0, 3.0, 4.0], [-2.0, 0.3, 0.4], [0.5, 0.1, 0.0]])
    assert np.allclose(P(x, [0.5, 1.0, 0.3]), [[2.8, 0.84, 1.12], [0, 0, 0], [0.5, 0.1, 0.0]])


def test_natural_map_residual_hand_cases():
    W = np.diag([2.0, 1.0, 1.0, 2.0, 1.0, 1.0])
    mu = np.array([0.5, 0.0])
    b_dual = np.array([1.0, 0.2, 0.1, 0.5, -3.0, 2.0])  # |b_t| <= b_n / mu, and mu = 0: b_n >= 0
    for law in ("coulomb", "ccp"):
        assert natural_map_residual(W, b_dual, mu, np.zeros(6), law) == 0.0
    # r = 0 with an approaching normal: r - P_K(-b) = -(1, 0, 0) and ||b|| = 1
    b = np.array([-1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert np.isclose(natural_map_residual(W, b, mu, np.zeros(6), "ccp"), 1.0)
    # the frictionless solution r_n = 1/2 of 2 r_n - 1 = 0 (u = 0)
    r = np.array([[0.5, 0.0, 0.0], [0.0, 0.0, 0.0]])
    assert natural_map_residual(W, b, mu, r, "coulomb") == 0.0
    assert natural_map_residual(W, b, mu, r * 1.1, "coulomb") > 0.01


@pytest.mark.skipif(not HAS_PIN, reason="Pinocchio (pin) not installed")
def test_pinocchio_admm_reaches_the_natural_map(quick):
    for name in ("four-corner-box", "planar-stack-20"):
        c = quick[name]
        r = pinocchio_contact_call(c.W, c.b, c.mu, c.dim, "ccp", 1e-8, kind="admm")()
        assert r.shape == (c.n_contacts, c.dim)
        assert natural_map_residual(c.W, c.b, c.mu, r, "ccp") < 1e-6, name
    c = quick["four-corner-box"]
    r = pinocchio_contact_call(c.W, c.b, c.mu, 3, "coulomb", 1e-8, check=1e-6)()
    assert natural_map_residual(c.W, c.b, c.mu, r, "coulomb") < 1e-6
