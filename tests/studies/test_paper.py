"""``convimpact paper``: figure data against independent numbers, the JSON contract, the PNGs."""

import io
import json
import os
from contextlib import redirect_stdout

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
import scipy.linalg as sla

import convimpact as ci
from convimpact import cli
from convimpact.studies.landscape import REGIMES, angle_landscape, closed_form_landscape, contact_landscape
from convimpact.studies.paper import fig3_data, paper_examples, table1
from convimpact.studies.paper_figures import FIGURES


@pytest.fixture(scope="module")
def examples():
    return paper_examples()


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    buf = io.StringIO()
    with redirect_stdout(buf):
        code = cli.main(["paper", "--quick", "--json", "--out", str(out)])
    assert code == 0
    return out, buf.getvalue()


def _constrained_inverse(M, C):
    """G = N (N^T M N)^-1 N^T with N a basis of null(C): the loop-constrained M^-1."""
    if C is None:
        return np.linalg.inv(M)
    N = sla.null_space(C)
    return N @ np.linalg.solve(N.T @ M @ N, N.T)


# ------------------------------------------------------------------------------------------
# the paper's approach velocities


@pytest.mark.parametrize("key, printed", [("pendulum_a", (-1.309, -2.683)),
                                          ("pendulum_b", (-0.416, -2.956)),
                                          ("pendulum_3d", (-1.309, -2.683, 0.809))])
def test_approach_velocities_to_printed_digits(examples, key, printed):
    ex = examples[key]
    v = ex.Jc @ ex.dq  # eq. (17)
    np.testing.assert_array_equal(np.round(v, 3), printed)


# ------------------------------------------------------------------------------------------
# Fig. 3 and Table 1


def test_fig3_against_eq59_and_two_particles(examples):
    e = np.linspace(0.0, 1.0, 11)
    data = fig3_data(examples, e)
    for ratio, key in ((1.0, "slider_crank"), (5.0, "slider_crank_ratio5"),
                       (10.0, "slider_crank_ratio10")):
        ex = examples[key]
        case = data["cases"][f"m4/m_eff = {ratio:g}"]
        G = _constrained_inverse(ex.M, ex.C)
        c_n = ex.Jc[0]
        v_n = float(c_n @ ex.dq)
        T = 0.5 * ex.dq @ ex.M @ ex.dq
        eq59 = (1 - e ** 2) * v_n ** 2 / (2 * float(c_n @ G @ c_n)) / T  # eq. (59) / T-
        # two particles: the crank-slider is 1-DOF, so with theta_dot = N w its generalized
        # mass along the slide is m_eff = N^T M N / N_3^2 (N from null(C) of the mechanism)
        Nm = sla.null_space(ex.C[:, :3])
        assert Nm.shape[1] == 1
        Nm = Nm[:, 0]
        m_eff = float(Nm @ ex.M[:3, :3] @ Nm) / Nm[2] ** 2
        m4 = ex.M[3, 3]
        assert m4 / m_eff == pytest.approx(ratio, rel=1e-9)
        v3, v4 = ex.dq[2], ex.dq[3]
        assert v4 == pytest.approx(-v3)  # equal and opposite approach
        # T_L = (1 - e^2) m_r v_rel^2 / 2, T- = (m_eff + m4) v^2 / 2 with v4 = -v3, v_rel = 2 v3
        two = (1 - e ** 2) * 4 * m_eff * m4 / (m_eff + m4) ** 2
        np.testing.assert_allclose(case["law"], eq59, rtol=1e-10, atol=1e-13)
        np.testing.assert_allclose(case["law"], two, rtol=1e-9, atol=1e-13)
        np.testing.assert_allclose(case["eq59"], eq59, rtol=1e-10, atol=1e-13)
        np.testing.assert_allclose(case["two_mass"], two, rtol=1e-9, atol=1e-13)
        # the paper: case 1 comes to a halt at e = 0; cases 2 and 3 lose 4 r / (1 + r)^2
        assert case["fraction_at_e0"] == pytest.approx(4 * ratio / (1 + ratio) ** 2, rel=1e-9)


def test_table1_solves_eq51_and_keeps_central_invariants(examples):
    ex = examples["slider_crank"]
    r = ci.resolve_impact(**ex.arguments)
    t = table1(ex, r)
    # eq. (51) with mu = 0, assembled by hand: unknowns (d_dq, d_sigma, pi_n)
    k, m = ex.M.shape[0], ex.C.shape[0]
    c_n = ex.Jc[0]
    A = np.zeros((k + m + 1, k + m + 1))
    A[:k, :k] = ex.M
    A[:k, k:k + m] = -ex.C.T
    A[:k, -1] = -c_n
    A[k:k + m, :k] = ex.C
    A[-1, :k] = c_n
    b = np.zeros(k + m + 1)
    b[-1] = -(1 + ex.e) * float(c_n @ ex.dq)
    x = np.linalg.solve(A, b)
    np.testing.assert_allclose(t["delta_theta_dot"], x[:k], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(t["loop_impulse"], x[k:k + m], rtol=1e-9, atol=1e-10)
    assert t["normal_impulse"] == pytest.approx(x[-1], rel=1e-10)
    ck = t["checks"]
    assert ck["equal_and_opposite"] and ck["free_slider_momentum_matches_impulse"]
    g = ck["generalized_impulse_on_sliders"]
    assert g[0] == pytest.approx(-x[-1]) and g[1] == pytest.approx(x[-1])
    assert ck["restitution_ratio"] == pytest.approx(0.83, rel=1e-12)
    assert ck["loop_velocity_residual"] < 1e-10 * np.linalg.norm(ex.dq)
    # momentum of the free slider: m4 Delta v4 = pi_n (n = -x acts on slider 3, +x on slider 4)
    assert ex.M[3, 3] * x[3] == pytest.approx(x[-1], rel=1e-10)


# ------------------------------------------------------------------------------------------
# landscapes against single resolve_impact calls


@pytest.mark.parametrize("key", ["pendulum_a", "pendulum_b", "pendulum_3d", "slider_crank"])
@pytest.mark.parametrize("law", ci.LAWS)
def test_contact_landscape_matches_resolve_impact(examples, key, law):
    ex = examples[key]
    e = np.array([0.0, 0.35, 0.83, 1.0])
    mu = np.array([0.0, 0.1, 0.45, 0.9]) if key != "slider_crank" else np.array([0.0])
    L = contact_landscape(ex.M, ex.Jc, ex.dq, e, mu, ex.C, law=law, progress=False)
    T = 0.5 * ex.dq @ ex.M @ ex.dq
    for i, ei in enumerate(e):
        for j, mj in enumerate(mu):
            # a second solver path (the conic program through Clarabel) where it exists
            spatial = ex.Jc.shape[0] == 3
            method = "clarabel" if (law != "pereira-nikravesh" or spatial) else "closed-form"
            r = ci.resolve_impact(ex.M, ex.Jc, ex.dq, e=ei, mu=mj, C=ex.C, law=law, method=method)
            assert REGIMES[L.regime[i, j]] == r.regime
            np.testing.assert_allclose(L.normal_impulse[i, j], r.impulse[0], rtol=1e-6,
                                       atol=1e-8)
            np.testing.assert_allclose(L.tangential_impulse[i, j], r.impulse[1:], rtol=1e-6,
                                       atol=1e-7)
            np.testing.assert_allclose(L.v_plus[i, j], r.v_plus, rtol=1e-6, atol=1e-7)
            # T_L against eq. (58) on the joint rates of the single call
            TL = T - 0.5 * r.dq_plus @ ex.M @ r.dq_plus
            assert L.energy_loss[i, j] == pytest.approx(TL, rel=1e-6, abs=1e-8)
            if abs(TL) > 1e-6 * T:
                assert L.energy_gained[i, j] == (TL < 0)


def test_paper_landscapes_match_pointwise_closed_form(examples):
    rng = np.random.default_rng(6)
    for key, lo, hi in (("pendulum_a", -0.5, 0.5), ("pendulum_b", -0.4, 0.6)):
        ex = examples[key]
        e, mu = np.linspace(0, 1, 21), np.linspace(lo, hi, 21)
        L = closed_form_landscape(ex.M, ex.Jc, ex.dq, e, mu)
        iv = ci.stiction_interval(ex.M, ex.Jc, ex.dq)
        # eq. (62) by Cramer's rule (D_1/D > 0, D_2/D > 0 of eq. 42, t opposite to the slip)
        W = ex.Jc @ np.linalg.solve(ex.M, ex.Jc.T)
        vn, vt = ex.Jc @ ex.dq
        s = -np.sign(vt)  # paper's t = -v_t-/|v_t-| on the frame axis
        m_nn, m_nt, m_tt = W[0, 0], s * W[0, 1], W[1, 1]
        vt_p = s * vt
        for ee in np.linspace(0, 1, 101):
            D1 = -(1 + ee) * vn * m_tt + vt_p * m_nt
            D2 = -m_nn * vt_p + (1 + ee) * vn * m_nt
            D = m_nn * m_tt - m_nt ** 2
            inside = iv.lower <= ee <= iv.upper
            if min(abs(D1), abs(D2)) > 1e-9:
                assert inside == (D1 / D > 0 and D2 / D > 0)
        for _ in range(25):
            i, j = rng.integers(0, 21, 2)
            if mu[j] < 0:
                continue
            r = ci.resolve_impact(ex.M, ex.Jc, ex.dq, e=e[i], mu=mu[j], method="closed-form")
            assert L.energy_loss[i, j] == pytest.approx(r.energy_loss, rel=1e-9, abs=1e-12)
            assert L.tangential_velocity[i, j] == pytest.approx(-np.sign(vt) * r.v_plus[1],
                                                                rel=1e-9, abs=1e-12)


def test_angle_landscape_against_joint_space_energy(examples):
    ex = examples["pendulum_3d"]
    alpha = np.linspace(0, 2 * np.pi, 73)
    A = angle_landscape(ex.M, ex.Jc, ex.dq, [0.3, 0.7], [0.2, 0.4], alpha)
    v = ex.Jc @ ex.dq
    ref = v[1:] / np.linalg.norm(v[1:])
    T = 0.5 * ex.dq @ ex.M @ ex.dq
    Minv = np.linalg.inv(ex.M)
    for i, e in enumerate((0.3, 0.7)):
        for j, mu in enumerate((0.2, 0.4)):
            for k in range(0, 73, 6):
                a = alpha[k]
                t = np.array([np.cos(a) * ref[0] - np.sin(a) * ref[1],
                              np.cos(a) * ref[1] + np.sin(a) * ref[0]])
                g = ex.Jc.T @ np.array([1.0, mu * t[0], mu * t[1]])  # c_n + mu c_t
                pn = -(1 + e) * v[0] / float(ex.Jc[0] @ Minv @ g)  # eq. (38)
                dq_plus = ex.dq + Minv @ g * pn  # eqs. (29), (35)
                TL = T - 0.5 * dq_plus @ ex.M @ dq_plus  # eq. (58)
                assert A.normal_impulse[i, j, k] == pytest.approx(pn, rel=1e-10)
                assert A.energy_loss[i, j, k] == pytest.approx(TL, rel=1e-9, abs=1e-12)
            # alpha_m is the maximum over a fine brute-force grid, and the sweep's answer
            fine = np.linspace(0, 2 * np.pi, 20001)
            B = angle_landscape(ex.M, ex.Jc, ex.dq, [e], [mu], fine)
            assert A.energy_loss_max[i, j] >= np.nanmax(B.energy_loss) - 1e-12
            assert A.energy_loss_max[i, j] == pytest.approx(np.nanmax(B.energy_loss), rel=1e-7)
            r = ci.resolve_impact(ex.M, ex.Jc, ex.dq, e=e, mu=mu, method="sweep")
            da = (A.alpha_m[i, j] - r.diagnostics.extras["alpha_m"] + np.pi) % (2 * np.pi) - np.pi
            assert abs(da) < 1e-6


def test_pendulum_3d_normal_rebound_is_the_papers(examples):
    ex = examples["pendulum_3d"]
    r = ci.resolve_impact(**ex.arguments, law="pereira-nikravesh")
    assert round(float(r.v_plus[0]), 3) == 0.916  # printed 0.916 n (e = 0.7 inferred from it)
    assert np.linalg.norm(r.impulse[1:]) == pytest.approx(0.4 * r.impulse[0], rel=1e-9)


# ------------------------------------------------------------------------------------------
# the command: JSON contract and figures

CONTRACT = ("theta", "dq", "M", "Jc", "v_minus", "e", "mu", "laws")
RESULT_FIELDS = ("dq_plus", "impulse", "loop_impulse", "regime", "energy_loss", "diagnostics")


def test_json_is_complete(paper_run):
    out, stdout = paper_run
    data = json.loads(stdout)
    with open(os.path.join(out, "paper.json")) as fh:
        on_disk = json.load(fh)
    assert on_disk == data
    for key in ("pendulum_a", "pendulum_b", "pendulum_3d", "slider_crank"):
        ex = data[key]
        for field in CONTRACT:
            assert field in ex, (key, field)
        assert set(ex["laws"]) == set(ci.LAWS)
        for law, res in ex["laws"].items():
            for field in RESULT_FIELDS:
                assert field in res, (key, law, field)
            assert len(res["dq_plus"]) == len(ex["dq"])
            assert "held" in res["diagnostics"]
    assert "C" in data["slider_crank"] and len(data["slider_crank"]["C"]) == 2
    assert len(data["slider_crank"]["laws"]["coulomb"]["loop_impulse"]) == 2
    for key in ("table1", "fig3", "fig5_6", "fig7", "fig9", "fig10", "law_landscapes",
                "assumptions", "figures"):
        assert key in data
    assert sorted(data["figures"]) == sorted(FIGURES)
    # the numbers in the JSON are the ones a direct call gives
    ex = paper_examples()["pendulum_b"]
    r = ci.resolve_impact(**ex.arguments, law="coulomb")
    np.testing.assert_allclose(data["pendulum_b"]["laws"]["coulomb"]["dq_plus"], r.dq_plus,
                               rtol=1e-12)
    assert data["fig3"]["cases"]["m4/m_eff = 1"]["fraction_at_e0"] == pytest.approx(1.0)


def test_pngs_exist_and_are_not_trivial(paper_run):
    import matplotlib.image as mpimg

    out, _ = paper_run
    for name in FIGURES:
        path = os.path.join(out, name)
        assert os.path.getsize(path) > 15_000, name
        img = mpimg.imread(path)
        assert img.shape[0] > 300 and img.shape[1] > 300, name
        rgb = img[::4, ::4, :3].reshape(-1, 3)
        assert np.unique(np.round(rgb, 2), axis=0).shape[0] > 20, name  # not a single colour
        assert rgb.std() > 0.05, name


def test_table_printed():
    from convimpact.studies.paper import build_report
    from convimpact.studies.paper_cli import format_summary

    text = format_summary(build_report(quick=True))
    assert "Assumptions" in text and "Table 1 analogue" in text and "alpha_m" in text
    assert "[-1.309, -2.683, 0.809]  vs  [-1.309, -2.683, 0.809]" in text
    for law in ci.LAWS:
        assert law in text


def test_bad_options_give_typed_errors(examples):
    ex = examples["pendulum_a"]
    with pytest.raises(ci.UnknownOptionError):
        contact_landscape(ex.M, ex.Jc, ex.dq, [0.5], [0.3], law="newton")
    with pytest.raises(ci.ParameterError):
        contact_landscape(ex.M, ex.Jc, ex.dq, [0.5], [-0.3])
    with pytest.raises(ci.ShapeError):
        angle_landscape(ex.M, ex.Jc, ex.dq, [0.5], [0.3], [0.0])  # planar contact
    sc = examples["slider_crank"]
    with pytest.raises(ci.SingularSystemError):
        closed_form_landscape(sc.M, sc.Jc, sc.dq, [0.5], [0.3], sc.C)


# ------------------------------------------------------------------------------------------
# property: the vectorized post-processing of contact_landscape reproduces assemble_result

from hypothesis import given, settings, strategies as st  # noqa: E402


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 31 - 1), d=st.sampled_from([2, 3]),
       law=st.sampled_from(ci.LAWS))
def test_contact_landscape_flags_match_diagnostics_on_random_systems(seed, d, law):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(d, 6))
    A = rng.normal(size=(k, k))
    M = A @ A.T + 0.5 * np.eye(k)
    Jc = rng.normal(size=(d, k))
    dq = rng.normal(size=k)
    if Jc[0] @ dq > 0:
        dq = -dq
    e = np.array([0.0, 0.6, 1.0])
    mu = np.array([0.0, 0.3, 1.2])
    L = contact_landscape(M, Jc, dq, e, mu, law=law, progress=False)
    T = 0.5 * dq @ M @ dq
    for i, ei in enumerate(e):
        for j, mj in enumerate(mu):
            try:
                r = ci.resolve_impact(M, Jc, dq, e=ei, mu=mj, law=law, method="fast")
            except ci.ConvImpactError as exc:
                assert L.failed[i, j]
                assert L.jammed[i, j] == isinstance(exc, ci.NonPositiveEffectiveMassError)
                continue
            assert not L.failed[i, j]
            assert REGIMES[L.regime[i, j]] == r.regime
            TL = T - 0.5 * r.dq_plus @ M @ r.dq_plus  # eq. (58) in joint space
            assert L.energy_loss[i, j] == pytest.approx(TL, rel=1e-8, abs=1e-10 * max(T, 1))
            np.testing.assert_allclose(L.v_plus[i, j], Jc @ r.dq_plus, rtol=1e-8,
                                       atol=1e-10 * np.abs(Jc @ dq).max())
            dg = r.diagnostics
            assert L.energy_gained[i, j] == dg.energy_gained
            assert L.friction_pushes_slip[i, j] == dg.friction_pushes_slip
            assert L.slip_reversal[i, j] == dg.slip_reversal
