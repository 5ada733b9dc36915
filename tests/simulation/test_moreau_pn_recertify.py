"""Law pereira-nikravesh's sliding islands re-certified in one pass
(:mod:`convimpact.simulation.moreau_pn_recertify`): a box sliding on its four corners, its
impulse derived by hand (the normal impulses balancing friction's pitch moment, Coulomb's
friction against the slip), proved to be the law's answer by the pruned search's
certificates; a wrong impulse refused with nothing written; Moreau's trajectory on the
one-call path against Coulomb's closed form, step by step."""

from types import SimpleNamespace

import numpy as np
import pytest

from convimpact.bench.moreau_scenes import GRAVITY, HALF, MU, box_row
from convimpact.impact.laws import pn_complementarity as pn
from convimpact.impact.laws import pn_complementarity_impulse as pimp
from convimpact.impact.laws.pn_complementarity_impulse import _sets
from convimpact.simulation import moreau_engine as me
from convimpact.simulation.moreau import simulate_moreau
from convimpact.simulation.moreau_pn_recertify import recertified_slide

H = 2e-3
LAW = "pereira-nikravesh"
#: the slide programs' accuracy on the law's direct path (clarabel's default options)
ACCURACY = 1e-9


@pytest.fixture(scope="module", autouse=True)
def compiled_path():
    pimp.compile_kernels()


def _island(v0):
    """One box sliding at v0 along x on its four corners: W = J G J^T, v- = J v_free, J
    (12, 6), G and the contact frames (rows n, t1, t2 of each corner)."""
    mech, q, v = box_row(1, True)
    v = v.copy()
    v[0] = v0
    ev = me.Evaluator(mech, mech.contact_names)
    M, _, J = ev.positions(q)
    G = np.linalg.inv(M)
    v_free = v + H * (G @ np.asarray(mech.generalized_forces(0.0, q, v), float))
    Jf = J.reshape(-1, q.size)
    return SimpleNamespace(J=J, Jf=Jf, G=G, v_free=v_free, W=Jf @ G @ Jf.T,
                           vm=Jf @ v_free, frames=J[:, :, :3])


def _hand_impulse(isl, pitch_balanced=True):
    """The impulse of Coulomb's sliding box (mass 1, h): the normal impulses sum to
    m g h, the front corners (x = +a) carry more by the friction's pitch moment about the
    centre, ``P_front - P_back = mu c P / a``; each corner's friction is mu p_n against the
    slip (-x), written in the corner's frame."""
    a, _, c = HALF
    P = 1.0 * GRAVITY * H
    pi = np.zeros(12)
    for k, (sx, _) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
        shift = sx * MU * c / a if pitch_balanced else 0.0
        pn_k = P / 4 * (1.0 + shift)
        force = np.array([-MU * pn_k, 0.0, pn_k])  # world x, y, z
        pi[3 * k:3 * k + 3] = isl.frames[k] @ force
    return pi


def _warm(pi):
    masks = np.ascontiguousarray(_sets(4, (True,) * 4)[1])
    wpi = np.zeros((masks.shape[0], 12))
    wpi[0] = pi
    wvalid = np.zeros(masks.shape[0], dtype=np.bool_)
    wvalid[:] = True
    return masks, wpi, wvalid


def _recertify(isl, masks, wpi, wvalid):
    return recertified_slide(isl.W, np.abs(isl.W), isl.vm, np.full(4, MU), 3, masks,
                             ACCURACY, pn.CONE_RTOL, pn.VELOCITY_SLACK_MAX, wpi, wvalid)


def test_the_hand_derived_sliding_impulse_is_certified_as_the_laws_answer():
    """At 2 m/s the hand impulse passes every certificate; its velocity jump is Coulomb's:
    the box leaves the step at v0 - mu g h along x, no vertical or angular velocity; the
    sets with no admissible impulse (the edges and the lone corners: 8 of the 14 others)
    have their warm starts dropped, the triples and diagonals (dominated) keep theirs."""
    isl = _island(2.0)
    masks, wpi, wvalid = _warm(_hand_impulse(isl))
    assert _recertify(isl, masks, wpi, wvalid)
    v_new = isl.v_free + isl.G @ isl.Jf.T @ wpi[0]
    np.testing.assert_allclose(v_new[0], 2.0 - MU * GRAVITY * H, rtol=0, atol=1e-12)
    np.testing.assert_allclose(v_new[1:], 0.0, rtol=0, atol=1e-12)
    sizes = masks.sum(axis=1)
    diagonal = np.array([sorted(np.flatnonzero(m).tolist()) in ([0, 2], [1, 3])
                         for m in masks])
    assert wvalid[0] and np.all(wvalid[sizes == 3]) and np.all(wvalid[diagonal])
    assert not np.any(wvalid[(sizes == 1) | ((sizes == 2) & ~diagonal)])


@pytest.mark.parametrize("case", ["unbalanced", "no warm start"])
def test_a_wrong_or_missing_impulse_is_refused_with_nothing_written(case):
    """Equal normal impulses leave the pitch moment unbalanced (the front corners sink:
    not a KKT point); without a valid warm start there is nothing to re-certify. Either
    way False, and the warm starts untouched (the caller runs the search)."""
    isl = _island(2.0)
    masks, wpi, wvalid = _warm(_hand_impulse(isl, pitch_balanced=case != "unbalanced"))
    if case == "no warm start":
        wvalid[0] = False
    before = wvalid.copy()
    assert not _recertify(isl, masks, wpi, wvalid)
    np.testing.assert_array_equal(wvalid, before)


def test_moreau_decelerates_at_mu_g_on_every_step_until_it_stops():
    """A box launched at 1 m/s on the one-call path: v_k = v0 - mu g t_k on every step
    (Coulomb), no lift or rotation, until it stops at v0 / (mu g) and rests; every sliding
    step after the mode's first is answered without the law's full search."""
    v0 = 1.0
    mech, q, v = box_row(1, True)
    v = v.copy()
    v[0] = v0
    res = simulate_moreau(mech, (0.0, 0.4), (q, v), h=H, law=LAW)
    t = np.asarray(res.t)
    vx = res.dtheta[:, 0]
    sliding = v0 - MU * GRAVITY * t > MU * GRAVITY * H
    np.testing.assert_allclose(vx[sliding], v0 - MU * GRAVITY * t[sliding], rtol=0, atol=1e-9)
    assert np.max(np.abs(res.dtheta[:, 1:])) < 1e-9
    stop = v0 / (MU * GRAVITY)
    assert np.all(np.abs(vx[t > stop + 2 * H]) < 1e-12)
    assert res.contact_solver["pruned"] >= np.count_nonzero(sliding) - 2
