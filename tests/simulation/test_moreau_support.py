"""The Moreau–Jean predictor on the supports of M and of the contact Jacobians
(:func:`convimpact.simulation.moreau_step_kernels.model_support`): the supports of a row of
free boxes and of a hinged pair in closed form, the predictor's M, gaps, rows and free
velocity against the model's own evaluation (a second mechanism, dense) over steps whose
active set changes, the regroup when a box's coordinates couple, the certificate's fallback
to the dense supports, and the sparse layout test against the dense one."""

from __future__ import annotations

import numpy as np

from convimpact.bench.moreau_scenes import BOX_MASS, HALF, box_row
from convimpact.model import Joint, ModelBuilder
from convimpact.simulation.moreau_kernels import same_pattern, same_pattern_on
from convimpact.simulation.moreau_loop import ModelPredictor
from convimpact.simulation.moreau_step_kernels import dense_support, model_support

H = 2e-3
THETA = 0.5


def _predictor(mech):
    return ModelPredictor(mech, THETA, 0.0, 1e-6)


def test_the_supports_of_a_row_of_free_boxes_are_their_own_blocks():
    """Three free boxes (6 coordinates each, a chain of 6 nodes from the ground): M's support
    is the three 6 x 6 diagonal blocks (108 entries) and each corner's Jacobian lives on its
    box's 6 columns."""
    mech, _, _ = box_row(3, False)
    msup, jcol, joff = model_support(mech.data.work)
    k = 18
    want = sorted(i * k + j for b in range(3) for i in range(6 * b, 6 * b + 6)
                  for j in range(6 * b, 6 * b + 6))
    assert msup.tolist() == want
    assert joff.tolist() == [6 * c for c in range(13)]
    for c in range(12):
        b = c // 4
        assert jcol[joff[c]:joff[c + 1]].tolist() == list(range(6 * b, 6 * b + 6))


def _hinged_pair():
    """A free box and a second box hinged to it about y at (0.3, 0, 0), one floor contact on
    each: 7 coordinates in one chain."""
    a, b, c = HALF
    inertia = np.diag([0.1, 0.2, 0.3])
    bld = ModelBuilder(planar=False, gravity=(0.0, 0.0, -9.81))
    bld.add_body("base", "ground", Joint.free(), BOX_MASS, (0.0, 0.0, 0.0), inertia)
    bld.add_body("flap", "base", Joint.revolute((0.0, 1.0, 0.0)), 0.5, (0.2, 0.0, 0.0),
                 inertia, joint_origin=(0.3, 0.0, 0.0))
    bld.add_contact("base_c", body="base", point=(-a, -b, -c), normal=(0.0, 0.0, 1.0), e=0.0,
                    mu=0.3)
    bld.add_contact("flap_c", body="flap", point=(0.4, 0.0, -c), normal=(0.0, 0.0, 1.0),
                    e=0.0, mu=0.3)
    return bld.build().mechanism()


def test_a_hinged_pair_couples_the_two_bodies_in_the_supports():
    """The hinge's node has the base's six nodes as ancestors: M's support is the full
    7 x 7 block and the flap's contact moves all 7 columns, the base's only its 6."""
    mech = _hinged_pair()
    msup, jcol, joff = model_support(mech.data.work)
    assert msup.tolist() == list(range(49))
    assert jcol[joff[0]:joff[1]].tolist() == list(range(6))
    assert jcol[joff[1]:joff[2]].tolist() == list(range(7))


def _reference(mech, q, v, hk):
    """The predictor's quantities by the mechanism's dense Python entries."""
    qm = q + (1.0 - THETA) * hk * v
    M = np.asarray(mech.mass_matrix(qm), float)
    Minv = np.linalg.inv(M)
    f = np.asarray(mech.generalized_forces(0.0, qm, v), float)
    vp = v + (1.0 - THETA) * hk * (Minv @ f)
    f = np.asarray(mech.generalized_forces(0.0, qm, vp), float)
    v_free = v + hk * (Minv @ f)
    gaps = np.array([mech.contact_gap(c, qm) for c in mech.contact_names])
    J = np.array([np.asarray(mech.contact_jacobian(c, qm), float)
                  for c in mech.contact_names])
    return qm, M, v_free, gaps, J


def _tumbling_row():
    """Two boxes tilted, turning and lifted by different heights: corners touch the floor
    at different steps (the active set grows and shrinks)."""
    mech, q, v = box_row(2, True)
    q, v = q.copy(), v.copy()
    q[2::6] += [1e-3, 4e-3]
    q[3::6] = [0.3, -0.1]
    q[4::6] = [-0.2, 0.25]
    v[3::6] = [12.0, -9.0]
    v[5::6] = [6.0, 4.0]
    v[2::6] = [-0.8, 0.5]
    return mech, q, v


def test_the_predictor_on_the_supports_is_the_models_dense_evaluation():
    """Thirty steps of a tumbling pair of boxes (the states from a dense reference march: q' =
    q_m + h/2 v_free): q_m, M, M^-1 on the groups, v_free, the active set by gap prediction
    and its rows J (every entry, zeros included), b = J v_free and v_n,k = J_n v, against a
    second mechanism's dense evaluation; the active set changes on the way."""
    mech, q, v = _tumbling_row()
    ref, _, _ = box_row(2, True)
    pred = _predictor(mech)
    sets = set()
    for step in range(30):
        st = pred.predict(step, step * H, q, v, H, np.zeros(0))
        qm, M, v_free, gaps, J = _reference(ref, q, v, H)
        assert np.array_equal(st.qm, qm)
        assert np.allclose(st.M, M, rtol=1e-13, atol=1e-15)
        assert np.allclose(st.inv.G, np.linalg.inv(M), rtol=1e-10, atol=1e-13)
        assert np.allclose(st.v_free, v_free, rtol=1e-11, atol=1e-13)
        vnf = J[:, 0, :] @ v_free
        active = np.flatnonzero(gaps + THETA * H * vnf <= 1e-12 * max(1.0, np.abs(qm).max()))
        assert st.active.tolist() == active.tolist()
        assert np.allclose(st.Ja, J[active], rtol=1e-13, atol=1e-15)
        assert np.array_equal(st.Ja == 0.0, J[active] == 0.0)
        assert np.allclose(st.b, np.einsum("crk,k->cr", J[active], v_free), atol=1e-12)
        assert np.allclose(st.vn_k, J[active, 0, :] @ v, atol=1e-12)
        sets.add(tuple(active.tolist()))
        q, v = qm + THETA * H * v_free, v_free  # no impulse: the states are the reference's
    # rows that take another box's contacts (their old columns zeroed): box 0 on the floor
    # and box 1 lifted, then the other way round, then both down
    rest, q0, v0 = box_row(2, False)
    for lifted in ((0.0, 0.05), (0.05, 0.0), (0.0, 0.0)):
        q1 = q0.copy()
        q1[2::6] += lifted
        st = pred.predict(30, 0.0, q1, v0, H, np.zeros(0))
        _, _, _, _, J = _reference(ref, q1, v0, H)
        sets.add(tuple(st.active.tolist()))
        assert np.array_equal(st.Ja, J[st.active])
    pred.close()
    assert {(0, 1, 2, 3), (4, 5, 6, 7)} <= sets and len(sets) >= 4 and pred.structural


def test_a_free_box_at_zero_angles_has_its_mass_on_the_diagonal():
    """Closed form at zero Cardan angles, centre of mass at the origin: M = diag(m, m, m,
    Ixx, Iyy, Izz) (the box's principal moments), so the groups are single coordinates and
    M^-1 is 1 / diag; v_free = v - h g e_z."""
    mech, q, v = box_row(1, True)
    pred = _predictor(mech)
    st = pred.predict(0, 0.0, q, v, H, np.zeros(0))
    a, b, c = HALF
    m = BOX_MASS
    diag = np.array([m, m, m, m * (b * b + c * c) / 3, m * (a * a + c * c) / 3,
                     m * (a * a + b * b) / 3])
    assert np.allclose(st.M, np.diag(diag), rtol=1e-14, atol=1e-15)
    assert np.allclose(st.inv.G, np.diag(1.0 / diag), rtol=1e-14)
    assert sorted(g.size for g in st.inv.groups.members) == [1] * 6
    assert np.allclose(st.v_free, v + H * np.array([0, 0, -9.81, 0, 0, 0]), atol=1e-14)
    pred.close()


def test_a_box_that_turns_regroups_its_coordinates():
    """At zero angles the box's M is diagonal (six groups of one); turned about x and y its
    rotational and translational coordinates couple (entries of the support outside the
    groups): the predictor regroups, and M^-1 on the new groups is the inverse of M."""
    mech, q, v = box_row(1, True)
    pred = _predictor(mech)
    pred.predict(0, 0.0, q, v, H, np.zeros(0))
    groups0 = pred.cache.groups
    q2 = q.copy()
    q2[3], q2[4] = 0.4, -0.3
    st = pred.predict(1, H, q2, v, H, np.zeros(0))
    assert pred.cache.groups is not groups0
    assert max(g.size for g in st.inv.groups.members) > 1
    M = np.asarray(box_row(1, True)[0].mass_matrix(st.qm), float)
    assert np.allclose(st.inv.G, np.linalg.inv(M), rtol=1e-10, atol=1e-13)
    pred.close()


def test_a_hinged_pair_regroups_into_one_group_of_both_bodies():
    """The flap's hinge couples it to the base's coordinates: one group of all 7, M^-1 the
    inverse of the model's M."""
    mech = _hinged_pair()
    q = np.array([0.0, 0.0, HALF[2] + 1e-3, 0.1, 0.2, 0.0, 0.3])
    v = np.zeros(7)
    pred = _predictor(mech)
    st = pred.predict(0, 0.0, q, v, H, np.zeros(0))
    assert sorted(g.size for g in st.inv.groups.members) == [7]
    M = np.asarray(_hinged_pair().mass_matrix(st.qm), float)
    assert np.allclose(st.inv.G, np.linalg.inv(M), rtol=1e-10, atol=1e-12)
    pred.close()


def test_a_support_the_model_contradicts_falls_back_to_the_dense_one():
    """A predictor told a too small support (M's diagonal only, each corner on one column)
    finds nonzeros outside it when it regroups: it takes the dense supports from then on,
    and its prediction is the model's (the rows' every entry)."""
    mech, q, v = _tumbling_row()
    ref, _, _ = box_row(2, True)
    pred = _predictor(mech)
    k, nc = q.size, len(mech.contact_names)
    pred.msup = np.arange(k, dtype=np.int64) * (k + 1)
    pred.support = (np.zeros(nc, dtype=np.int64), np.arange(nc + 1, dtype=np.int64))
    st = pred.predict(0, 0.0, q, v, H, np.zeros(0))
    assert not pred.structural
    assert pred.msup.tolist() == dense_support(nc, k)[0].tolist()
    qm, M, v_free, gaps, J = _reference(ref, q, v, H)
    assert np.allclose(st.inv.G, np.linalg.inv(M), rtol=1e-10, atol=1e-13)
    assert st.active.size and np.allclose(st.Ja, J[st.active], rtol=1e-13, atol=1e-15)
    pred.close()


def test_the_layout_test_on_the_supports_is_the_dense_one():
    """same_pattern_on against same_pattern on rows with their support's zeros: the same
    answer on the key itself, on a column that stops moving, on one that starts moving
    inside the support and on other active contacts."""
    rng = np.random.default_rng(3)
    nc, d, k = 5, 3, 12
    jcol = np.concatenate([np.arange(3 * (c % 4), 3 * (c % 4) + 3) for c in range(nc)])
    joff = np.arange(0, 3 * nc + 1, 3, dtype=np.int64)
    active = np.array([0, 2, 3, 4], dtype=np.int64)
    Ja = np.zeros((active.size, d, k))
    for i, c in enumerate(active):
        cols = jcol[joff[c]:joff[c + 1]]
        Ja[i][:, cols] = rng.normal(size=(d, cols.size))
    Ja[1, :, jcol[joff[2]]] = 0.0  # a column of the support that does not move
    moves = np.any(Ja != 0.0, axis=1)
    cases = [(Ja, active)]
    stopped = Ja.copy()
    stopped[0, :, 1] = 0.0
    started = Ja.copy()
    started[1, 0, jcol[joff[2]]] = 0.5
    others = active.copy()
    others[2] = 1
    cases += [(stopped, active), (started, active), (Ja, others), (Ja[:3], active[:3])]
    for J_, act in cases:
        want = same_pattern(J_, act, active, moves)
        assert same_pattern_on(J_, act, active, moves, jcol, joff) == want
    assert [same_pattern(J_, a, active, moves) for J_, a in cases] == [True] + [False] * 4
