"""Law ``chatterjee-ruina`` in the studies: landscapes (``e_t=``), the ``impacts`` and
``simulation`` study kinds (``e_t`` as an option or a parameter axis) and the atlas's paths,
checked against the closed form of a ball.

Closed form. A uniform ball (mass m, radius r, I = 2/5 m r^2) striking the floor with normal
velocity -V (V > 0) and slip s (the contact point's tangential velocity, a vector in space):
W is diagonal in the contact frame, W_nn = 1/m, W_tt = 1/m + r^2/I = 7/(2m). The law's
candidate J^ = (1 + e) J_I + (1 + e_t)(J_II - J_I) has J^_n = (1 + e) m V and
J^_t = -(1 + e_t)(2m/7) s; it is in the cone when (1 + e_t)(2/7)|s| <= mu (1 + e) V, and then

    v_n+ = e V,    s+ = -e_t s;

outside it J_t = -mu (1 + e) m V s/|s| and s+ = s - (7/2) mu (1 + e) V s/|s|. With W diagonal
the energy lost is T_L = 1/2 m (1 - e^2) V^2 + 1/2 (2m/7)(|s|^2 - |s+|^2). A point mass (the
bouncing ball scene) has W_tt = 1/m instead: in the cone x_dot+ = -e_t x_dot-.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.errors import ParameterError, UnknownOptionError
from convimpact.studies import landscape as landscape_module
from convimpact.studies.landscape import contact_landscape, law_landscape

M_BALL, R_BALL = 1.0, 0.1
I_BALL = 0.4 * M_BALL * R_BALL**2
G = 9.81


def planar_ball(u, V, w):
    """M, Jc, dq of a planar ball (x, y, phi); contact frame n = +y, t = +x, so the tangential
    row gives the slip s = x_dot + r phi_dot."""
    M = np.diag([M_BALL, M_BALL, I_BALL])
    Jc = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, R_BALL]])
    return M, Jc, np.array([u, -V, w])


def spatial_ball(v, omega):
    """M, Jc, dq of a ball (velocity v, angular velocity omega); frame n = +y, t1 = +x,
    t2 = +z: the contact point moves at v + omega x (-r y) = (vx + r wz, vy, vz - r wx)."""
    M = np.diag([M_BALL] * 3 + [I_BALL] * 3)
    Jc = np.array([[0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
                   [1.0, 0.0, 0.0, 0.0, 0.0, R_BALL],
                   [0.0, 0.0, 1.0, -R_BALL, 0.0, 0.0]])
    return M, Jc, np.concatenate([v, omega])


def closed_form(V, s, e, mu, e_t):
    """(v_n+, s+, stick, T_L) of the ball (s a vector of the tangential axes)."""
    s = np.atleast_1d(np.asarray(s, float))
    ns = np.linalg.norm(s)
    stick = (1 + e_t) * (2.0 / 7.0) * ns <= mu * (1 + e) * V
    s_plus = -e_t * s if stick else s - 3.5 * mu * (1 + e) * V * s / ns
    TL = 0.5 * M_BALL * (1 - e**2) * V**2 + 0.5 * (2 * M_BALL / 7) * (ns**2 - s_plus @ s_plus)
    return e * V, s_plus, stick, TL


E_GRID = np.array([0.0, 0.3, 0.8, 1.0])
MU_GRID = np.array([0.0, 0.05, 0.2, 0.5, 1.5])
E_T_GRID = np.array([-1.0, -0.4, 0.0, 0.35, 1.0])


def check_landscape(L, V, s, e_t):
    assert L.law == "chatterjee-ruina" and L.meta["e_t"] == e_t
    assert not L.failed.any() and not L.energy_gained.any()
    for i, e in enumerate(L.e):
        for j, mu in enumerate(L.mu):
            vn, s_plus, stick, TL = closed_form(V, s, e, mu, e_t)
            assert L.v_plus[i, j, 0] == pytest.approx(vn, abs=1e-12)
            np.testing.assert_allclose(L.v_plus[i, j, 1:], s_plus, rtol=0, atol=1e-12)
            assert L.energy_loss[i, j] == pytest.approx(TL, rel=1e-10, abs=1e-12)
            if mu > 0:
                assert L.regime_names()[i, j] == ("stick" if stick else "slide")


@pytest.mark.parametrize("e_t", E_T_GRID)
def test_contact_landscape_planar_ball_over_e_t(e_t):
    V, u, w = 2.0, 1.0, 5.0  # slip s = 1.5
    M, Jc, dq = planar_ball(u, V, w)
    L = contact_landscape(M, Jc, dq, E_GRID, MU_GRID, law="chatterjee-ruina", e_t=e_t,
                          progress=False)
    check_landscape(L, V, [u + R_BALL * w], e_t)
    # in the cone the slip is restituted by e_t whatever e
    stick = L.regime_names() == "stick"
    assert stick.any()
    np.testing.assert_allclose(L.v_plus[..., 1][stick], -e_t * 1.5, atol=1e-12)


@pytest.mark.parametrize("e_t", [-0.6, 0.5])
def test_contact_landscape_spatial_ball_and_the_compiled_batch(e_t, monkeypatch):
    """A slip along no axis (spatial kernel); the same grid through the compiled batch
    (BATCH_MIN_POINTS lowered) gives the same closed form."""
    V = 1.5
    M, Jc, dq = spatial_ball(np.array([0.4, -V, -0.3]), np.array([2.0, 0.7, 1.0]))
    s = (Jc @ dq)[1:]
    np.testing.assert_allclose(s, [0.4 + R_BALL * 1.0, -0.3 - R_BALL * 2.0])
    L = contact_landscape(M, Jc, dq, E_GRID, MU_GRID, law="chatterjee-ruina", e_t=e_t,
                          progress=False)
    check_landscape(L, V, s, e_t)
    monkeypatch.setattr(landscape_module, "BATCH_MIN_POINTS", 1)
    B = contact_landscape(M, Jc, dq, E_GRID, MU_GRID, law="chatterjee-ruina", e_t=e_t,
                          progress=False)
    check_landscape(B, V, s, e_t)


@pytest.mark.parametrize("method", ["fast", "clarabel"])
def test_law_landscape_over_e_t(method):
    V, u, w = 2.0, -0.5, 2.0  # slip s = -0.3
    M, Jc, dq = planar_ball(u, V, w)
    for e_t in (-0.5, 0.0, 0.9):
        L = law_landscape(M, Jc, dq, E_GRID, MU_GRID, law="chatterjee-ruina", method=method,
                          progress=False, e_t=e_t)
        assert L.method == method
        check_landscape(L, V, [u + R_BALL * w], e_t)


def test_landscapes_refuse_e_t_where_the_law_has_none_or_out_of_range():
    M, Jc, dq = planar_ball(1.0, 2.0, 0.0)
    for fn in (contact_landscape, law_landscape):
        with pytest.raises(UnknownOptionError, match="law 'coulomb' has none"):
            fn(M, Jc, dq, [0.5], [0.3], law="coulomb", e_t=0.5, progress=False)
        with pytest.raises(ParameterError, match=r"\[-1, 1\]"):
            fn(M, Jc, dq, [0.5], [0.3], law="chatterjee-ruina", e_t=-1.2, progress=False)
    # no e_t: the law's default 0 (the slip stops in the cone), recorded in meta
    L = contact_landscape(M, Jc, dq, [0.5], [1.0], law="chatterjee-ruina", progress=False)
    assert L.meta["e_t"] == 0.0
    assert L.v_plus[0, 0, 1] == pytest.approx(0.0, abs=1e-12)
    assert "e_t" not in contact_landscape(M, Jc, dq, [0.5], [1.0], law="coulomb",
                                          progress=False).meta


@pytest.mark.parametrize("e_t", [-0.5, 0.0, 0.7])
def test_stick_boundary_of_the_ball_in_closed_form(e_t):
    """mu_star(e) = (1 + e_t)(2/7)|s| / ((1 + e) V) for the ball, from the landscape's meta and
    from stick_boundary(..., e_t=); the landscape's stick cells lie on its side."""
    from convimpact.studies.landscape import landscape_stick_boundary, stick_boundary
    from convimpact.studies.plotting import plot_landscape

    V, u, w = 2.0, 1.0, 5.0
    s = u + R_BALL * w
    M, Jc, dq = planar_ball(u, V, w)
    e = np.linspace(0.0, 1.0, 11)
    mu = np.linspace(0.0, 1.0, 23)
    L = contact_landscape(M, Jc, dq, e, mu, law="chatterjee-ruina", e_t=e_t, progress=False)
    expect = (1 + e_t) * (2.0 / 7.0) * abs(s) / ((1 + e) * V)
    for sb in (landscape_stick_boundary(L),
               stick_boundary(M, Jc, dq, law="chatterjee-ruina", e_t=e_t)):
        assert sb.law == "chatterjee-ruina"
        np.testing.assert_allclose(sb.mu_star(e), expect, rtol=1e-12)
        clear = np.abs(mu[None, :] - expect[:, None]) > 1e-9
        assert np.array_equal((mu[None, :] >= expect[:, None])[clear & (mu[None, :] > 0)],
                              L.stick_possible[clear & (mu[None, :] > 0)])
        # e where the boundary crosses a column: mu (1 + e) V = (1 + e_t)(2/7)|s|
        m = 0.5
        e_cross = (1 + e_t) * (2.0 / 7.0) * abs(s) / (m * V) - 1.0
        got = sb.e_at(m)
        if 0.0 <= e_cross <= 1.0:
            np.testing.assert_allclose(got, [e_cross], rtol=1e-12)
        else:
            assert got.size == 0
    ax = plot_landscape(L, "energy_loss", legend="inside")  # draws the exact boundary
    ax.figure.canvas.draw()
    with pytest.raises(UnknownOptionError, match="law 'coulomb' has none"):
        stick_boundary(M, Jc, dq, law="coulomb", e_t=0.5)


def test_atlas_maps_the_new_law():
    from convimpact.studies.atlas import DEFAULT_PATHS

    assert ("chatterjee-ruina", "fast") in DEFAULT_PATHS
    assert ("chatterjee-ruina", "clarabel") in DEFAULT_PATHS


# ---- study kinds -------------------------------------------------------------------------

def _run(spec_dict, tmp_path):
    pytest.importorskip("xarray", reason="studies need dask, xarray and zarr (pip install -e \".[test-full]\")")
    pytest.importorskip("zarr", reason="studies need dask, xarray and zarr (pip install -e \".[test-full]\")")
    from convimpact.studies.study import run_study
    from convimpact.studies.study_spec import spec_from_dict

    return run_study(spec_from_dict(spec_dict), tmp_path / "s.zarr", "serial",
                     progress=False).dataset


def test_impacts_study_sweeps_e_t_on_the_grid(tmp_path):
    """The spinning ball scene (a planar ball, I = 2/5 m r^2) at one impact state, over e_t x
    law x mu: chatterjee-ruina's points follow the closed form, coulomb's do not depend on
    e_t."""
    V, u, w = 2.0, 1.0, 5.0
    spec = {
        "study": {"kind": "impacts", "title": "ball: e_t", "chunk_points": 7},
        "options": {"scene": "spinning_ball", "theta": [0.0, R_BALL, 0.0],
                    "dtheta": [u, -V, w], "e": 0.5},
        "grid": {"e_t": {"values": E_T_GRID.tolist()},
                 "law": {"values": ["chatterjee-ruina", "coulomb"]},
                 "mu": {"values": [0.1, 0.4, 1.0]}},
    }
    ds = _run(spec, tmp_path)
    assert ds["status"].values.max() == 0
    cr = ds.sel(law="chatterjee-ruina")
    for e_t in E_T_GRID:
        for mu in (0.1, 0.4, 1.0):
            pt = cr.sel(e_t=e_t, mu=mu)
            vm, vp = pt["v_minus"].values, pt["v_plus"].values
            s = -vm[1]  # the scene's tangent is t = -x: Jc[1] theta_dot = -s
            assert s == pytest.approx(u + R_BALL * w)
            vn, s_plus, stick, TL = closed_form(V, [s], 0.5, mu, e_t)
            assert vp[0] == pytest.approx(vn, abs=1e-12)
            assert -vp[1] == pytest.approx(s_plus[0], abs=1e-12)
            assert float(pt["energy_loss"]) == pytest.approx(TL, rel=1e-10)
            assert not bool(pt["energy_gained"])
    co = ds.sel(law="coulomb")["v_plus"].values
    np.testing.assert_array_equal(co, np.broadcast_to(co[:1], co.shape))


def test_impacts_study_e_t_as_option_and_refused_without_the_law(tmp_path):
    from convimpact.studies.study_spec import StudySpecError, spec_from_dict

    V, u, w = 2.0, -0.5, 2.0
    spec = {
        "study": {"kind": "impacts", "title": "ball: one e_t"},
        "options": {"scene": "spinning_ball", "theta": [0.0, R_BALL, 0.0],
                    "dtheta": [u, -V, w], "e": 0.8, "law": "chatterjee-ruina", "e_t": 0.6},
        "grid": {"mu": {"values": [0.05, 1.0]}},
    }
    ds = _run(spec, tmp_path)
    for mu in (0.05, 1.0):
        vp = ds.sel(mu=mu)["v_plus"].values
        vn, s_plus, _, _ = closed_form(V, [u + R_BALL * w], 0.8, mu, 0.6)
        np.testing.assert_allclose(vp, [vn, -s_plus[0]], rtol=0, atol=1e-12)
    bad = {**spec, "options": {**spec["options"], "law": "coulomb"}}
    with pytest.raises(StudySpecError, match="law 'coulomb'|'coulomb' have none"):
        spec_from_dict(bad)
    bad = {**spec, "options": {**spec["options"], "e_t": 1.5}}
    with pytest.raises(StudySpecError, match="outside"):
        spec_from_dict(bad)
    no_law = {**spec, "options": {k: v for k, v in spec["options"].items() if k != "e_t"},
              "grid": {"e_t": {"values": [0.0, 0.5]}}}
    no_law["options"]["law"] = "stronge"
    with pytest.raises(StudySpecError, match="have none"):
        spec_from_dict(no_law)


def test_simulation_study_sweeps_e_t(tmp_path):
    """The bouncing ball (point mass: x_dot+ = -e_t u in the cone) over e_t, stopped before
    its second impact: after the first the ball drifts at -e_t u."""
    from convimpact.studies.study_spec import StudySpecError, spec_from_dict

    u, e, mu, h, r = 1.0, 0.5, 0.5, 1.0, 0.1
    t1 = np.sqrt(2 * (h - r) / G)
    t_end = 1.8 * t1  # the second impact is at 3 t1 (e = 1/2)
    spec = {
        "study": {"kind": "simulation", "title": "ball: e_t", "chunk_points": 3},
        "options": {"scene": "bouncing_ball", "law": "chatterjee-ruina", "t_end": t_end,
                    "summary_start": 0.6,
                    "scene_parameters": {"speed": u, "e": e, "mu": mu, "height": h}},
        "grid": {"e_t": {"values": [-0.5, 0.0, 0.25, 1.0]}},
    }
    ds = _run(spec, tmp_path)
    assert (ds["status"].values == 0).all() and (ds["n_impacts"].values == 1).all()
    for e_t in (-0.5, 0.0, 0.25, 1.0):
        pt = ds.sel(e_t=e_t)
        assert (1 + e_t) * u <= mu * (1 + e) * np.sqrt(2 * G * (h - r))  # in the cone
        x_end = u * t1 - e_t * u * (t_end - t1)
        assert float(pt["theta_final"].sel(coordinate="theta1")) == pytest.approx(
            x_end, abs=1e-7)
        assert float(pt["mean_velocity"].sel(coordinate="theta1")) == pytest.approx(
            -e_t * u, abs=1e-7)
        assert float(pt["energy_change"]) < 0
    bad = {**spec, "options": {**spec["options"], "law": "coulomb"}}
    with pytest.raises(StudySpecError, match="unknown parameter 'e_t'"):
        spec_from_dict(bad)
    bad["grid"] = {"e": {"values": [0.5]}}
    bad["options"] = {**bad["options"], "e_t": 0.5}
    with pytest.raises(StudySpecError, match="law 'coulomb' has none"):
        spec_from_dict(bad)
