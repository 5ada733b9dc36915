"""The paper's figures: the exact stick boundary, round colour-bar ticks, legends that name only
what is drawn, units on every axis, one colour bar per law figure, and what paper.json's nulls
mean. Numbers are checked against formulas written out here, independently of the package."""

import fnmatch
import io
import json
import os
from contextlib import redirect_stderr, redirect_stdout

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import convimpact as ci  # noqa: E402
from convimpact import cli  # noqa: E402
from convimpact.studies.landscape import (closed_form_landscape, contact_landscape,  # noqa: E402
                                          landscape_stick_boundary, stick_boundary)
from convimpact.studies.paper import NULL_VALUES, paper_examples  # noqa: E402
from convimpact.studies.paper_figures import FIGURES  # noqa: E402
from convimpact.studies.plotting import (nice_levels, plot_angle_sweep,  # noqa: E402
                                         plot_landscape, plot_tangent_vectors,
                                         plot_velocity_comparison)


@pytest.fixture(scope="module")
def examples():
    return paper_examples()


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _cramer(M, Jc, dq, e, C=None):
    """(D, D1, D2) of eq. (42) by Cramer's rule, as printed before eq. (62), in the frame's (n, t).

    W = Jc M^-1 Jc^T (open loops) or with the loop folded in through a null-space basis of C.
    pi_n = D1 / D, pi_t = D2 / D.
    """
    if C is None:
        W = Jc @ np.linalg.solve(M, Jc.T)
    else:
        import scipy.linalg as sla

        N = sla.null_space(C)
        W = Jc @ N @ np.linalg.solve(N.T @ M @ N, N.T @ Jc.T)
    vn, vt = Jc @ dq
    m_nn, m_nt, m_tn, m_tt = W[0, 0], W[0, 1], W[1, 0], W[1, 1]
    D = m_nn * m_tt - m_nt * m_tn
    D1 = (-(1 + e) * vn) * m_tt - m_nt * (-vt)
    D2 = m_nn * (-vt) - (-(1 + e) * vn) * m_tn
    return D, D1, D2


def _boundary_residual(M, Jc, dq, e, mu, C=None):
    """|pi_t| - |mu| pi_n of the sticking impulse, relative to |pi|: zero on the boundary."""
    D, D1, D2 = _cramer(M, Jc, dq, e, C)
    pn, pt = D1 / D, D2 / D
    return (abs(pt) - abs(mu) * pn) / np.hypot(pn, pt), pn


def _random_planar(seed):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(2, 6))
    A = rng.normal(size=(k, k))
    M = A @ A.T + 0.3 * np.eye(k)
    Jc = rng.normal(size=(2, k))
    dq = rng.normal(size=k)
    if Jc[0] @ dq > 0:
        dq = -dq
    return M, Jc, dq


# ------------------------------------------------------------------------------------------
# the stick boundary of Figs. 5-7


@pytest.mark.parametrize("key", ["pendulum_a", "pendulum_b"])
def test_stick_boundary_points_satisfy_the_cramer_condition(examples, key):
    ex = examples[key]
    sb = stick_boundary(ex.M, ex.Jc, ex.dq, ex.C)
    e, mu = sb.curve(5.0, n=401)
    assert e.size > 200
    for ei, mi in zip(e, mu):
        res, pn = _boundary_residual(ex.M, ex.Jc, ex.dq, ei, mi)
        assert pn > 0
        assert abs(res) < 1e-10, (ei, mi, res)
    # per column, the closed-form crossings lie on it too
    for m in np.linspace(0.01, 0.6, 25):
        for ei in sb.e_at(m):
            res, pn = _boundary_residual(ex.M, ex.Jc, ex.dq, ei, m)
            assert pn > 0 and abs(res) < 1e-10


def test_stick_boundary_of_pendulum_a_has_the_printed_bounds(examples):
    ex = examples["pendulum_a"]
    sb = stick_boundary(ex.M, ex.Jc, ex.dq)
    # its kink (mu* = 0, pi_t = 0) is the upper bound of eq. (62), and pi_n = 0 the lower one
    iv = ci.stiction_interval(ex.M, ex.Jc, ex.dq)
    e, mu = sb.curve(0.5)
    assert mu.min() == 0.0
    assert e[np.argmin(mu)] == pytest.approx(iv.upper, abs=1e-12)
    D, D1, _ = _cramer(ex.M, ex.Jc, ex.dq, iv.lower)
    assert D1 / D == pytest.approx(0.0, abs=1e-9)
    assert np.isinf(sb.mu_star(iv.lower - 1e-6))
    # at |mu| = 0.5 the curve's ends, by the closed form of each column
    ends = sb.e_at(0.5)
    assert ends.size == 2
    for ei in ends:
        assert abs(_boundary_residual(ex.M, ex.Jc, ex.dq, ei, 0.5)[0]) < 1e-12
    # case (b) never sticks for |mu| <= 0.6 (the paper: "this pendulum never sticks")
    b = examples["pendulum_b"]
    assert stick_boundary(b.M, b.Jc, b.dq).curve(0.6)[0].size == 0


@pytest.mark.parametrize("seed", range(12))
def test_stick_boundary_separates_the_grid(seed):
    M, Jc, dq = _random_planar(seed)
    e = np.linspace(0, 1, 41)
    mu = np.linspace(-1.5, 1.5, 61)
    L = closed_form_landscape(M, Jc, dq, e, mu)
    sb = landscape_stick_boundary(L)
    assert sb is not None
    ms = sb.mu_star(e)[:, None]
    margin = np.abs(np.abs(mu)[None, :] - ms)
    clear = (margin > 1e-9) & (mu[None, :] != 0)
    predicted = np.abs(mu)[None, :] >= ms
    assert np.array_equal(predicted[clear], L.stick_possible[clear])
    for ei, mi in zip(*sb.curve(1.5, n=101)):
        assert abs(_boundary_residual(M, Jc, dq, ei, mi)[0]) < 1e-10


@pytest.mark.parametrize("law", ci.LAWS)
@pytest.mark.parametrize("seed", range(4))
def test_each_laws_stick_region_is_bounded_by_its_curve(law, seed):
    M, Jc, dq = _random_planar(100 + seed)
    e = np.linspace(0, 1, 21)
    mu = np.linspace(0, 2.0, 21)
    L = contact_landscape(M, Jc, dq, e, mu, law=law, progress=False)
    sb = landscape_stick_boundary(L)
    assert sb.law == law
    ms = sb.mu_star(e)[:, None]
    if law == "dissipative":  # the plastic impulse pi(0), whatever e
        D, D1, D2 = _cramer(M, Jc, dq, 0.0)
        expect = abs(D2 / D) / (D1 / D) if D1 / D > 0 else np.inf
        assert np.allclose(ms, expect, rtol=1e-10)
    clear = (np.abs(mu[None, :] - ms) > 1e-9) & (mu[None, :] > 0) & ~L.failed
    assert np.array_equal((mu[None, :] >= ms)[clear], L.stick_possible[clear])


def test_plot_draws_the_exact_boundary_not_the_grid(examples):
    ex = examples["pendulum_a"]
    L = closed_form_landscape(ex.M, ex.Jc, ex.dq, np.linspace(0, 1, 21),
                              np.linspace(-0.5, 0.5, 21))  # a coarse grid: stairs if from it
    ax = plot_landscape(L, "energy_loss", legend="inside")
    crimson = [ln for ln in ax.lines if ln.get_color() == "crimson" and ln.get_linestyle() == "-"]
    assert len(crimson) == 2  # mu > 0 and its mirror at mu < 0
    n = 0
    for ln in crimson:
        x, y = (np.asarray(a, float) for a in ln.get_data())
        ok = np.isfinite(x)
        assert ok.sum() > 100  # a curve, not 21 cells
        for xi, yi in zip(x[ok], y[ok]):
            assert abs(_boundary_residual(ex.M, ex.Jc, ex.dq, yi, xi)[0]) < 1e-10
            n += 1
    assert n > 200


# ------------------------------------------------------------------------------------------
# colour bars, legends, units


def _is_round(values):
    v = np.asarray(values, float)
    step = np.min(np.diff(v))
    mant = step / 10 ** np.floor(np.log10(step))
    return (any(np.isclose(mant, m) for m in (1, 2, 2.5, 5))
            and np.allclose(v / step, np.round(v / step), atol=1e-9))


def test_nice_levels_are_round_and_cover_the_range():
    for lo, hi in ((-1.039, 1.039), (-2.926, 0.99), (0.0, 11.3), (-1.0, 1.0), (3e-4, 7e-4)):
        lv = nice_levels(lo, hi)
        assert lv[0] <= lo and lv[-1] >= hi and _is_round(lv)


def test_colour_bar_ticks_are_round_and_clipping_is_explained(examples):
    ex = examples["pendulum_a"]
    L = closed_form_landscape(ex.M, ex.Jc, ex.dq, np.linspace(0, 1, 41),
                              np.linspace(-0.5, 0.5, 41))
    speed = float(np.linalg.norm(ex.v_minus))
    fig, ax = plt.subplots()
    plot_landscape(L, values=-L.tangential_velocity, ax=ax, limits=(-0.4 * speed, 0.4 * speed),
                   label="slip [m/s]")
    cb = fig.axes[-1]
    ticks = [t for t in cb.get_yticks() if cb.get_ylim()[0] - 1e-9 <= t <= cb.get_ylim()[1] + 1e-9]
    assert len(ticks) >= 3 and _is_round(ticks)
    assert cb.get_title() == ""  # no unexplained "clipped"
    assert "pointed ends: values beyond the scale" in cb.get_ylabel()
    assert ax.convimpact_mappable.extend == "both"


def test_legend_names_only_drawn_lines(examples):
    """Fig. 5: the outgoing slip vanishes on the whole stick region; no zero contour is named
    that is not drawn."""
    ex = examples["pendulum_a"]
    L = closed_form_landscape(ex.M, ex.Jc, ex.dq, np.linspace(0, 1, 101),
                              np.linspace(-0.5, 0.5, 101))
    ax = plot_landscape(L, values=-L.tangential_velocity, zero_contour=True, label="slip [m/s]",
                        legend="inside")
    drawn = {matplotlib.colors.to_hex(ln.get_color()) for ln in ax.lines}
    for coll in ax.collections:
        for c in np.atleast_2d(coll.get_edgecolor()):
            if len(c):
                drawn.add(matplotlib.colors.to_hex(c))
    for h in ax.get_legend().legend_handles:
        if isinstance(h, matplotlib.lines.Line2D):
            assert matplotlib.colors.to_hex(h.get_color()) in drawn, h.get_label()
    assert not any("= 0" in t.get_text() for t in ax.get_legend().get_texts())


def test_fig9_legend_does_not_cover_the_curves(examples):
    from convimpact.studies.paper import fig9_data

    f9 = fig9_data(examples["pendulum_3d"], 181)
    fig, ax = plt.subplots()
    nan = np.array([np.nan if x is None else x for x in f9["energy_loss"]])
    pn = np.array([np.nan if x is None else x for x in f9["normal_impulse"]])
    plot_angle_sweep(np.array(f9["alpha"]), nan, pn, alpha_m=f9["alpha_m"], ax=ax,
                     gain_sectors=f9["energy_gain_sectors"],
                     alpha_max_normal_impulse=f9["alpha_max_normal_impulse"])
    fig.canvas.draw()
    leg = ax.get_legend().get_window_extent()
    frame = ax.get_window_extent()
    assert leg.y1 <= frame.y0  # below the axes
    assert len(ax.get_legend().get_texts()) >= 5  # both axes' curves are named


def test_fig10_axes_carry_units():
    fig, (a1, a2) = plt.subplots(1, 2)
    plot_tangent_vectors({"v": [1.0, 2.0]}, ax=a1, unit="m/s")
    plot_tangent_vectors({"p": [0.5, -0.2]}, ax=a2, unit="N s", dashed=("p",))
    assert "[m/s]" in a1.get_xlabel() and "[m/s]" in a1.get_ylabel()
    assert "[N s]" in a2.get_xlabel() and "[N s]" in a2.get_ylabel()


def test_reference_values_are_labelled_as_the_papers(examples):
    r = ci.resolve_impact(**examples["pendulum_3d"].arguments, law="pereira-nikravesh")
    ref = np.array([0.916, 0.675, 0.41])
    fig, ax = plt.subplots()
    plot_velocity_comparison({"pereira-nikravesh": r.v_plus, "other": r.v_plus * 0.5},
                             reference=ref, reference_label="paper: ...", ax=ax)
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert any("paper: 0.675" in t for t in labels) and any("paper: 0.41" in t for t in labels)
    # no bar's value is written on (within 4 % of the range of) a reference line
    span = max(ref.max(), r.v_plus.max())
    for t in ax.texts:
        x, y = t.get_position()
        group = int(round(x))
        assert abs(y - ref[group]) > 0.04 * span, t.get_text()


# ------------------------------------------------------------------------------------------
# the command's figures and JSON


#: what ``convimpact paper`` printed on stderr as it went (filled by the paper_out fixture)
PAPER_PROGRESS: list[str] = []


@pytest.fixture(scope="module")
def paper_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper_figs")
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        assert cli.main(["paper", "--quick", "--out", str(out)]) == 0
    PAPER_PROGRESS[:] = err.getvalue().splitlines()
    with open(os.path.join(out, "paper.json")) as fh:
        return out, json.load(fh)


def test_paper_shows_its_progress(paper_out):
    """``convimpact paper`` says what it does as it goes, on stderr: each step with the time
    since the start, the six examples one by one, every figure as it is written."""
    import re

    lines = [ln for ln in PAPER_PROGRESS if "] paper: " in ln]
    stamps = [float(re.match(r"\[\s*([\d.]+)s\] paper: ", ln).group(1)) for ln in lines]
    assert stamps == sorted(stamps) and stamps[0] >= 0.0
    text = "\n".join(lines)
    for i, key in enumerate(("pendulum_a", "pendulum_b", "pendulum_3d", "slider_crank",
                             "slider_crank_ratio5", "slider_crank_ratio10")):
        assert f"example {i + 1}/6: {key} under the 6 laws" in text
    written = [ln.split("written: ")[1] for ln in lines if " written: " in ln]
    assert written == list(FIGURES)
    assert [ln.split("paper: ")[1][:22] for ln in lines if "law landscapes" in ln] == \
        ["law landscapes 1/2: pe", "law landscapes 2/2: pe"] * 2  # the JSON's, the figures'
    # --quiet turns them off
    assert cli.build_parser().parse_args(["paper", "--quiet"]).quiet is True


def _nulls(x, path=""):
    if x is None:
        yield path
    elif isinstance(x, dict):
        for k, v in x.items():
            yield from _nulls(v, f"{path}.{k}" if path else k)
    elif isinstance(x, list):
        for v in x:
            yield from _nulls(v, path)


def test_every_null_in_paper_json_is_documented(paper_out):
    _, data = paper_out
    assert data["null_values"] == NULL_VALUES
    paths = list(_nulls(data))
    assert paths  # Fig. 7's jam and the slider-crank's singular W
    for p in paths:
        assert any(fnmatch.fnmatchcase(p, pat) for pat in NULL_VALUES), p
    # landscape nulls are exactly the jammed points
    for key in ("fig5_6", "fig7"):
        f = data[key]
        jam = np.array(f["jammed"], bool)
        for q in ("energy_loss", "energy_loss_fraction", "normal_impulse",
                  "tangential_velocity"):
            isnull = np.array([[v is None for v in row] for row in f[q]])
            assert np.array_equal(isnull, jam), (key, q)
    assert np.array(data["fig7"]["jammed"]).any()
    # not-applicable diagnostics are omitted, not null
    for key in ("pendulum_a", "slider_crank"):
        for law, res in data[key]["laws"].items():
            d = res["diagnostics"]
            assert d.get("effective_mass", 0.0) is not None
            assert d.get("loop_condition", 0.0) is not None
    assert "loop_condition" in data["slider_crank"]["laws"]["coulomb"]["diagnostics"]
    assert data["slider_crank"]["laws"]["coulomb"]["diagnostics"]["delassus_condition"] is None
    assert isinstance(data["fig9"]["excluded_sector"], list)


def test_paper_json_stick_boundary_is_exact(paper_out, examples):
    _, data = paper_out
    sb = data["fig5_6"]["stick_boundary"]
    ex = examples["pendulum_a"]
    assert len(sb["e"]) > 5
    for e, m in zip(sb["e"], sb["mu_star"]):
        res, pn = _boundary_residual(ex.M, ex.Jc, ex.dq, e, m)
        assert pn > 0 and abs(res) < 1e-10


def test_law_figures_share_one_colour_bar(paper_out):
    import matplotlib.image as mpimg

    out, data = paper_out
    # the PNG itself: read back, and the figure rebuilt to count its axes
    from convimpact.studies.paper import build_report
    from convimpact.studies.paper_figures import write_figures

    rep = build_report(quick=True)
    created = []
    orig = plt.Figure.savefig

    def spy(self, *a, **k):
        created.append(len(self.axes))
        return orig(self, *a, **k)

    plt.Figure.savefig = spy
    try:
        names = [os.path.basename(p) for p in write_figures(rep, str(out))]
    finally:
        plt.Figure.savefig = orig
    per_name = dict(zip(names, created))
    assert per_name["laws_pendulum_a.png"] == len(ci.LAWS) + 1  # six laws, one colour bar
    assert per_name["laws_pendulum_b.png"] == len(ci.LAWS) + 1
    assert per_name["fig10_tangent_plane.png"] == 2  # velocities and impulses apart
    for name in names:
        assert mpimg.imread(os.path.join(out, name)).shape[0] > 300
