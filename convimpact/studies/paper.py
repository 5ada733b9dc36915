"""The reproduction of Pereira & Nikravesh (1996): the examples of Section 9 and their data.

One call of :func:`build_report` computes every number (the impact examples of Section 9 under
the six laws of ``convimpact.LAWS``, the Table 1 analogue, the data of Figs. 3, 5-7, 9 and 10
and the law landscapes) as plain JSON; :func:`convimpact.studies.paper_figures.write_figures` draws the PNG
figures from it; :mod:`convimpact.studies.paper_cli` prints its summary and is the subcommand
``convimpact paper [--out DIR] [--json] [--quick]``.

The paper leaves open some data; the choices are stated in :data:`ASSUMPTIONS` and printed:
rod masses, the slider-crank geometry (its ref. [7] is unavailable), the sign of the printed
joint rates, and e, mu of the single-impact examples.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

from ..errors import ConvImpactError
from ..impact.results import _jsonable

#: e, mu of the planar pendulum examples (the paper sweeps them; the scenes' defaults)
PENDULUM_E, PENDULUM_MU = 0.5, 0.3
#: e, mu of the 3D pendulum, inferred from the printed answer of Section 9.3:
#: e = 0.916 / 1.309 = 0.70 and |pi_t| / pi_n = |(1.26, -0.99)| / 4.026 = 0.398
PENDULUM_3D_E, PENDULUM_3D_MU = 0.7, 0.4
#: free-slider mass over the crank-slider's generalized mass along the slide (Fig. 3 cases 1-3)
MASS_RATIOS = (1.0, 5.0, 10.0)
#: restitution of the slider-crank impact (Section 9.1)
SLIDER_CRANK_E = 0.83

#: numbers printed in the paper, for comparison
PAPER = {
    "table1": {"delta_theta_dot_4": 41.58, "delta_theta_dot_3": -68.285,
               "reference_7": {"delta_theta_dot_4": 41.8, "delta_theta_dot_3": -68.3}},
    "fig3_energy_loss_fraction_at_e0": {"case 1 (m4 = 0.19)": 1.0, "case 2 (m4 = 0.95)": 0.54,
                                        "case 3 (m4 = 1.9)": 0.32},
    "approach_velocity": {"pendulum_a": [-1.309, -2.683], "pendulum_b": [-0.416, -2.956],
                          "pendulum_3d": [-1.309, -2.683, 0.809]},
    "pendulum_3d": {"v_plus": [0.916, 0.675, 0.41], "impulse": [4.026, 1.26, -0.99],
                    "normal_impulse_share_of_max": 0.78,
                    "alpha_max_normal_impulse_deg": 196.25},
}

ASSUMPTIONS = (
    "Double pendulum rods: uniform slender rods, L = 1 m, m = 1 kg each (the paper gives no "
    "mass); in 3D their inertia about the rod axis is zero and the base is massless. Velocities "
    "and angles do not depend on the mass scale, impulses and energies scale with it.",
    "The paper prints joint rates -1 rad/s with clockwise-positive angles; we use +1 rad/s "
    "counter-clockwise, which reproduces its approach velocities.",
    f"Planar pendulum examples (cases a and b) use e = {PENDULUM_E}, mu = {PENDULUM_MU} (the "
    "paper only sweeps e and mu for them).",
    f"3D pendulum: e = {PENDULUM_3D_E}, mu = {PENDULUM_3D_MU}, inferred from the paper's "
    "printed answer (v_n+ / v_n- = 0.916 / 1.309; |pi_t| / pi_n = 0.398).",
    "Slider-crank geometry and masses are ours (the paper's ref. [7] is unavailable): crank "
    "0.15 m / 0.5 kg, coupler 0.40 m / 0.4 kg, slider 0.3 kg, crank at -60 deg turning at "
    "20 rad/s; the free slider approaches at the slider's speed. Its mass is 1, 5 and 10 times "
    "the crank-slider's generalized mass along the slide, the ratios of the paper's cases "
    "m4 = 0.19, 0.95, 1.9 (case 1 'equivalent' masses). Table 1's numbers therefore differ; we "
    f"check the central-impact invariants instead. e = {SLIDER_CRANK_E}, mu = 0.",
    "Negative mu in Figs. 5-7 follows the paper: the friction impulse acts along the slip. Each "
    "law is run with method='auto' (the exact single-contact kernels, or the closed form).",
)


_UNDEFINED = ("undefined: the sliding denominator of eq. (38) is <= 0 there -- a Painleve-like "
              "jam in Figs. 5-7 (only at mu < 0, friction along the slip; `jammed` is true at "
              "exactly these points), an excluded direction in Fig. 9")

#: where ``paper.json`` holds null, and what it means there. Keys are patterns over dotted
#: paths (``*`` any key; list positions omitted). Values that do not apply (the effective mass
#: of a law that did not slide, the loop condition number of an open loop) are omitted instead.
NULL_VALUES = {
    "fig*.energy_loss": _UNDEFINED,
    "fig*.energy_loss_fraction": _UNDEFINED,
    "fig*.normal_impulse": _UNDEFINED,
    "fig*.tangential_velocity": _UNDEFINED,
    "fig*.eq62_stiction_interval": "empty: no e in [0, 1] satisfies eq. (62)",
    "law_landscapes.*.*.energy_loss_fraction": "the law raised at that grid point "
                                               "(counted in `counts.failed`)",
    "*.laws.*.diagnostics.delassus_condition": "infinite: W = Jc M^-1 Jc^T is singular (the "
                                               "slider-crank's contact tangent moves no mass: "
                                               "its impact is frictionless whatever mu)",
}

#: diagnostics that are None where they do not apply; omitted from the JSON then
_NOT_APPLICABLE = ("effective_mass", "loop_condition")


@dataclass(frozen=True, eq=False)
class PaperExample:
    """One impact of Section 9 ready for :func:`convimpact.resolve_impact`.

    Attributes
    ----------
    name : JSON key (``pendulum_a`` ...).
    description : the scene's description with its assumptions.
    theta, dq : joint coordinates and rates theta_dot- at impact.
    M, Jc, C : mass matrix, contact Jacobian (rows n, t...) and loop Jacobian (or None).
    e, mu : restitution and friction.
    parameters : the scene's parameters.
    """

    name: str
    description: str
    theta: np.ndarray
    dq: np.ndarray
    M: np.ndarray
    Jc: np.ndarray
    C: np.ndarray | None
    e: float
    mu: float
    parameters: Mapping[str, Any]

    @property
    def arguments(self) -> dict:
        """Keyword arguments of :func:`convimpact.resolve_impact`."""
        return dict(M=self.M, Jc=self.Jc, dq=self.dq, C=self.C, e=self.e, mu=self.mu)

    @property
    def v_minus(self) -> np.ndarray:
        """Approach velocity in the contact frame, Jc theta_dot- (eq. 17)."""
        return self.Jc @ self.dq


def _example(name: str, scene, e: float, mu: float) -> PaperExample:
    from ..model import impact_arguments

    theta, dq = scene.impact_state
    a = impact_arguments(scene.mechanism, theta, dq, contacts=scene.impact_contact, e=e, mu=mu)
    return PaperExample(name=name, description=scene.description, theta=np.asarray(theta, float),
                        dq=np.asarray(a["dq"], float), M=np.asarray(a["M"], float),
                        Jc=np.asarray(a["Jc"], float),
                        C=None if a["C"] is None else np.asarray(a["C"], float),
                        e=float(e), mu=float(mu), parameters=dict(scene.parameters))


def paper_examples() -> dict[str, PaperExample]:
    """The impacts of Section 9: both planar pendulums, the 3D pendulum, the slider-crank.

    ``slider_crank`` is the mass ratio 1 (the paper's case 1); ``slider_crank_ratio5`` and
    ``slider_crank_ratio10`` are its cases 2 and 3.
    """
    from ..problems import pendulum_3d, pendulum_planar, slider_crank

    out = {
        "pendulum_a": _example("pendulum_a", pendulum_planar.make_scene("a", PENDULUM_E,
                                                                        PENDULUM_MU),
                               PENDULUM_E, PENDULUM_MU),
        "pendulum_b": _example("pendulum_b", pendulum_planar.make_scene("b", PENDULUM_E,
                                                                        PENDULUM_MU),
                               PENDULUM_E, PENDULUM_MU),
        "pendulum_3d": _example("pendulum_3d", pendulum_3d.make_scene(PENDULUM_3D_E,
                                                                      PENDULUM_3D_MU),
                                PENDULUM_3D_E, PENDULUM_3D_MU),
    }
    for ratio in MASS_RATIOS:
        key = "slider_crank" if ratio == 1.0 else f"slider_crank_ratio{ratio:g}"
        out[key] = _example(key, slider_crank.make_scene(ratio, SLIDER_CRANK_E, 0.0),
                            SLIDER_CRANK_E, 0.0)
    return out


def resolve_under_laws(example: PaperExample) -> dict[str, Any]:
    """:func:`convimpact.resolve_impact` under every law (``method="auto"``).

    Returns law -> :class:`~convimpact.impact.results.ImpactResult`, or the error message (str) when
    the law raised a :class:`~convimpact.errors.ConvImpactError`.
    """
    from ..impact import LAWS, resolve_impact

    out: dict[str, Any] = {}
    for law in LAWS:
        try:
            out[law] = resolve_impact(**example.arguments, law=law)
        except ConvImpactError as exc:
            out[law] = f"{type(exc).__name__}: {exc}"
    return out


def table1(example: PaperExample, result) -> dict[str, Any]:
    """Table 1 analogue: jumps of every joint rate, impulses, and the central-impact checks.

    Checks (independent of the law's bookkeeping): the contact's generalized impulse acts
    with equal and opposite components on the two sliders (theta3, theta4); the free slider's
    momentum changes by the contact impulse (m4 Delta theta_dot_4 = pi_n); the closing speed
    is restituted by e (v_n+ = -e v_n-); the loop stays closed (C theta_dot+ = 0, eq. 43).
    """
    jump = result.dq_plus - example.dq
    pi_n = float(result.impulse[0])
    gen = example.Jc.T @ result.impulse  # eq. (27)/(28): generalized contact impulse
    m4 = float(example.M[3, 3])
    v_n_minus, v_n_plus = float(result.v_minus[0]), float(result.v_plus[0])
    loop = example.C @ result.dq_plus
    return {
        "coordinates": ["theta_dot_1 (crank) [rad/s]", "theta_dot_2 (coupler) [rad/s]",
                        "theta_dot_3 (slider x) [m/s]", "theta_dot_4 (free slider x) [m/s]"],
        "dq_minus": example.dq.tolist(),
        "delta_theta_dot": jump.tolist(),
        "dq_plus": result.dq_plus.tolist(),
        "normal_impulse": pi_n,
        "loop_impulse": result.loop_impulse.tolist(),
        "energy_loss": float(result.energy_loss),
        "checks": {
            "generalized_impulse_on_sliders": [float(gen[2]), float(gen[3])],
            "equal_and_opposite": bool(np.isclose(gen[2], -gen[3], rtol=1e-12, atol=0.0)),
            "free_slider_momentum_change": m4 * float(jump[3]),
            "free_slider_momentum_matches_impulse": bool(
                np.isclose(m4 * jump[3], pi_n, rtol=1e-9)),
            "v_n_minus": v_n_minus, "v_n_plus": v_n_plus,
            "restitution_ratio": -v_n_plus / v_n_minus,
            "loop_velocity_residual": float(np.linalg.norm(loop)),
        },
        "paper": PAPER["table1"],
        "note": "our geometry is not the paper's (ref. [7] unavailable): compare the checks, "
                "not the digits",
    }


def fig3_data(examples: Mapping[str, PaperExample], e: np.ndarray) -> dict[str, Any]:
    """Energy loss fraction versus e for the three free-slider masses (Fig. 3).

    ``law``: the Section 8 law over e (vectorized, :func:`closed_form_landscape` at mu = 0);
    ``eq59``: :func:`convimpact.impact.energy.central_energy_loss` (eq. 59) over T-;
    ``two_mass``: two particles of masses m_eff (the crank-slider's generalized mass along the
    slide) and m4 with the sliders' velocities, T_L = (1 - e^2) m_r v_rel^2 / 2 over their
    kinetic energy.
    """
    from ..impact.energy import central_energy_loss
    from .landscape import closed_form_landscape

    out: dict[str, Any] = {"e": e.tolist(), "cases": {}}
    for ratio in MASS_RATIOS:
        key = "slider_crank" if ratio == 1.0 else f"slider_crank_ratio{ratio:g}"
        ex = examples[key]
        T_minus = 0.5 * float(ex.dq @ ex.M @ ex.dq)
        L = closed_form_landscape(ex.M, ex.Jc, ex.dq, e, [0.0], ex.C)
        eq59 = np.array([central_energy_loss(ex.M, ex.Jc[0], ex.dq, float(ei), ex.C)
                         for ei in e]) / T_minus
        m_eff = float(ex.parameters["generalized_slide_mass"])
        m4 = float(ex.parameters["free_slider_mass"])
        v3, v4 = float(ex.dq[2]), float(ex.dq[3])
        m_r = m_eff * m4 / (m_eff + m4)
        T2 = 0.5 * m_eff * v3 ** 2 + 0.5 * m4 * v4 ** 2
        two = (1.0 - e ** 2) * 0.5 * m_r * (v3 - v4) ** 2 / T2
        out["cases"][f"m4/m_eff = {ratio:g}"] = {
            "mass_ratio": ratio, "free_slider_mass": m4, "generalized_slide_mass": m_eff,
            "energy_before": T_minus, "law": L.energy_loss_fraction[:, 0].tolist(),
            "eq59": eq59.tolist(), "two_mass": two.tolist(),
            "fraction_at_e0": float(L.energy_loss_fraction[0, 0]),
            "fraction_at_e0_two_mass": float(two[0]),
        }
    return out


def _landscape_json(L, stiction) -> dict[str, Any]:
    from .landscape import landscape_stick_boundary

    keep = ("e", "mu", "tangential_velocity", "energy_loss", "energy_loss_fraction",
            "normal_impulse", "regime", "stick_possible", "energy_gained", "slip_reversal",
            "friction_pushes_slip", "jammed", "failed")
    d = L.as_dict()
    out = {k: d[k] for k in keep}
    out.update(law=L.law, method=L.method, counts=d["counts"], regime_names=d["regime_names"],
               v_minus=list(L.meta["v_minus"]), energy_before=L.meta["energy_before"],
               eq62_stiction_interval=[stiction.lower, stiction.upper])
    sb = landscape_stick_boundary(L)
    if sb is not None:
        m = sb.mu_star(L.e)
        ok = np.isfinite(m)
        out["stick_boundary"] = {
            "definition": "the law sticks where |mu| >= mu_star(e) = |pi_t(e)| / pi_n(e), "
                          "pi(e) = sticking_impulse_e0 + e sticking_impulse_de (eq. 42); "
                          "listed at the grid's e where pi_n(e) > 0 (elsewhere it never sticks)",
            "sticking_impulse_e0": sb.pi0.tolist(), "sticking_impulse_de": sb.pi1.tolist(),
            "e": L.e[ok].tolist(), "mu_star": m[ok].tolist()}
    return out


def _pendulum_landscapes(examples, n: int) -> dict[str, Any]:
    from ..impact.energy import stiction_interval
    from .landscape import closed_form_landscape

    out = {}
    for key, lo, hi in (("pendulum_a", -0.5, 0.5), ("pendulum_b", -0.4, 0.6)):
        ex = examples[key]
        e = np.linspace(0.0, 1.0, n)
        mu = np.linspace(lo, hi, n)
        L = closed_form_landscape(ex.M, ex.Jc, ex.dq, e, mu, ex.C)
        iv = stiction_interval(ex.M, ex.Jc, ex.dq, C=ex.C)  # eq. (62), independent of mu
        out[key] = (L, iv)
    return out


def _law_landscapes(examples, n: int,
                    progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    from ..impact import LAWS
    from .landscape import contact_landscape

    out: dict[str, Any] = {}
    keys = ("pendulum_a", "pendulum_b")
    for k, key in enumerate(keys):
        ex = examples[key]
        e = np.linspace(0.0, 1.0, n)
        mu = np.linspace(0.0, 0.6, n)
        if progress:
            progress(f"law landscapes {k + 1}/{len(keys)}: {key}, {len(LAWS)} laws on "
                     f"{n} x {n} (e, mu)")
        out[key] = {law: contact_landscape(ex.M, ex.Jc, ex.dq, e, mu, ex.C, law=law,
                                           progress=False) for law in LAWS}
    return out


def fig9_data(example: PaperExample, n_alpha: int) -> dict[str, Any]:
    """Energy loss and normal impulse versus the tangent angle alpha (Fig. 9), with alpha_m."""
    from .landscape import angle_landscape
    from ..impact.problem.build import build_problem
    from ..impact.exact.sweep import sweep_direction

    alpha = np.linspace(0.0, 2.0 * np.pi, n_alpha)
    A = angle_landscape(example.M, example.Jc, example.dq, [example.e], [example.mu], alpha,
                        example.C)
    P = build_problem(example.M, example.Jc, example.dq, example.e, example.mu, example.C)
    W, v = P.contact_block(0)
    sw = sweep_direction(W, v, example.e, example.mu)
    pn_m = float(A.normal_impulse_max_dissipation[0, 0])
    fin = lambda x: None if x is None or not math.isfinite(x) else float(x)  # noqa: E731
    return {
        "e": example.e, "mu": example.mu, "alpha": alpha.tolist(),
        "energy_loss": np.where(np.isfinite(A.energy_loss[0, 0]), A.energy_loss[0, 0],
                                None).tolist(),
        "normal_impulse": np.where(np.isfinite(A.normal_impulse[0, 0]), A.normal_impulse[0, 0],
                                   None).tolist(),
        "alpha_m": float(A.alpha_m[0, 0]), "alpha_m_deg": math.degrees(A.alpha_m[0, 0]),
        "alpha_m_sweep": sw.alpha_m, "energy_loss_max": float(A.energy_loss_max[0, 0]),
        "normal_impulse_at_alpha_m": pn_m,
        "max_normal_impulse": fin(sw.max_normal_impulse),
        "alpha_max_normal_impulse": fin(sw.alpha_max_normal_impulse),
        "alpha_max_normal_impulse_deg": (None if sw.alpha_max_normal_impulse is None
                                         else math.degrees(sw.alpha_max_normal_impulse)),
        "normal_impulse_share_of_max": (pn_m / sw.max_normal_impulse
                                        if math.isfinite(sw.max_normal_impulse) else None),
        "energy_gain_sectors": [list(s) for s in sw.energy_gain_sectors],
        "energy_gain_sectors_deg": [[math.degrees(a) for a in s]
                                    for s in sw.energy_gain_sectors],
        # [alpha_0, alpha_1] of the directions where eq. (38)'s denominator is <= 0; [] if none
        "excluded_sector": [] if sw.excluded_sector is None else list(sw.excluded_sector),
        "paper": PAPER["pendulum_3d"],
    }


def fig10_data(result) -> dict[str, Any]:
    """Tangent-plane vectors of the maximal-dissipation answer (Fig. 10).

    ``t_average`` is the tangent of the averaging rule the paper compares with (its ref. [17],
    "an averaging process of the tangential components of the approach and separation
    velocities"; the reference list is not in our copy of the paper): opposite to the mean of
    v_t- and v_t+, as a unit vector (dimensionless).
    """
    vtm = np.asarray(result.v_minus[1:], float)
    vtp = np.asarray(result.v_plus[1:], float)
    mean = 0.5 * (vtm + vtp)
    t_avg = -mean / np.linalg.norm(mean) if np.linalg.norm(mean) > 0 else np.zeros(2)
    pit = np.asarray(result.impulse[1:], float)
    return {"v_t_minus": vtm.tolist(), "delta_v_t": (vtp - vtm).tolist(),
            "v_t_plus": vtp.tolist(), "pi_t": pit.tolist(), "t_average": t_avg.tolist(),
            "angle_pi_t_to_t_average_deg": math.degrees(math.atan2(
                pit[0] * t_avg[1] - pit[1] * t_avg[0], pit @ t_avg)),
            "law": result.law, "method": result.method}


def _example_json(ex: PaperExample, results: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {
        "description": ex.description, "parameters": _jsonable(dict(ex.parameters)),
        "theta": ex.theta.tolist(), "dq": ex.dq.tolist(), "M": ex.M.tolist(),
        "Jc": ex.Jc.tolist(),
    }
    if ex.C is not None:
        out["C"] = ex.C.tolist()
    out.update(v_minus=ex.v_minus.tolist(), e=ex.e, mu=ex.mu,
               energy_before=0.5 * float(ex.dq @ ex.M @ ex.dq))
    paper_v = PAPER["approach_velocity"].get(ex.name)
    if paper_v is not None:
        out["paper_v_minus"] = paper_v
    laws = {}
    for law, r in results.items():
        if isinstance(r, str):
            laws[law] = {"error": r}
            continue
        laws[law] = r.as_dict()
        diag = laws[law]["diagnostics"]
        for k in _NOT_APPLICABLE:
            if diag.get(k) is None:
                diag.pop(k, None)
    out["laws"] = laws
    return out


def _finite_json(x):
    """Replace NaN and infinities by None so the JSON is strict."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _finite_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite_json(v) for v in x]
    return x


@dataclass(frozen=True, eq=False)
class PaperReport:
    """Everything ``convimpact paper`` computes.

    Attributes
    ----------
    data : the JSON document (strict JSON: a null is an undefined or infinite value, where
        :data:`NULL_VALUES` says; values that do not apply are omitted).
    examples : the :class:`PaperExample` of each key.
    results : law -> ImpactResult (or error message) per example.
    landscapes : (Landscape, StictionInterval) of pendulums a and b (Figs. 5-7).
    law_landscapes : per pendulum case, law -> Landscape over e x mu >= 0.
    """

    data: dict
    examples: Mapping[str, PaperExample]
    results: Mapping[str, Mapping[str, Any]]
    landscapes: Mapping[str, Any]
    law_landscapes: Mapping[str, Any]


def build_report(quick: bool = False,
                 progress: Callable[[str], None] | None = None) -> PaperReport:
    """Compute every number of the reproduction (``quick``: coarser grids).

    ``progress``, when given, is told each step as it starts (``convimpact paper`` prints
    them on stderr): the examples, each example under each law (a law's first use compiles
    its kernels: most of a first run's time), the figures' data, each law landscape.
    """
    from ..impact import LAWS

    say = progress or (lambda message: None)
    t0 = time.perf_counter()
    n_land, n_law, n_e, n_alpha = (41, 21, 21, 361) if quick else (101, 51, 101, 1441)
    # the figures of Figs. 5-7 and of the law landscapes are drawn on finer grids
    n_fig, n_fig_law = (121, 41) if quick else (301, 101)
    say("building the examples: pendulums a, b and 3D, the slider-crank at "
        f"{len(MASS_RATIOS)} mass ratios (a first run on this machine spends most of its "
        "time compiling the kernels, once)")
    examples = paper_examples()
    results = {}
    for i, (k, ex) in enumerate(examples.items()):
        say(f"example {i + 1}/{len(examples)}: {k} under the {len(LAWS)} laws")
        results[k] = resolve_under_laws(ex)
    data: dict[str, Any] = {k: _example_json(ex, results[k]) for k, ex in examples.items()}
    sc = results["slider_crank"]["pereira-nikravesh"]
    say(f"Table 1 and Fig. 3 ({n_e} restitutions)")
    data["table1"] = table1(examples["slider_crank"], sc)
    data["fig3"] = fig3_data(examples, np.linspace(0.0, 1.0, n_e))
    say(f"Figs. 5-7: the pendulums' landscapes, {n_land} x {n_land} (e, mu)")
    lands = _pendulum_landscapes(examples, n_land)
    data["fig5_6"] = _landscape_json(*lands["pendulum_a"])
    data["fig7"] = _landscape_json(*lands["pendulum_b"])
    say(f"Figs. 9-10: the 3D pendulum over {n_alpha} tangent angles")
    data["fig9"] = fig9_data(examples["pendulum_3d"], n_alpha)
    p3 = results["pendulum_3d"]["pereira-nikravesh"]
    data["fig10"] = fig10_data(p3)
    law_lands = _law_landscapes(examples, n_law, progress)
    data["law_landscapes"] = {
        key: {law: {"e": L.e.tolist(), "mu": L.mu.tolist(), "counts": L.counts(),
                    "energy_loss_fraction": np.where(np.isfinite(L.energy_loss_fraction),
                                                     L.energy_loss_fraction, None).tolist()}
              for law, L in per.items()}
        for key, per in law_lands.items()}
    data["pendulum_3d_comparison"] = {
        law: (r if isinstance(r, str) else {"v_plus": r.v_plus.tolist(),
                                            "impulse": r.impulse.tolist()})
        for law, r in results["pendulum_3d"].items()}
    data["pendulum_3d_comparison"]["paper"] = {"v_plus": PAPER["pendulum_3d"]["v_plus"],
                                               "impulse": PAPER["pendulum_3d"]["impulse"]}
    data["assumptions"] = list(ASSUMPTIONS)
    data["paper"] = PAPER
    data["settings"] = {"quick": quick, "landscape_grid": n_land, "law_landscape_grid": n_law,
                        "fig3_points": n_e, "fig9_angles": n_alpha,
                        "figure_landscape_grid": n_fig, "figure_law_landscape_grid": n_fig_law}
    data["null_values"] = dict(NULL_VALUES)
    data["elapsed_compute_s"] = time.perf_counter() - t0
    return PaperReport(_finite_json(_jsonable(data)), examples, results,
                       {k: v for k, v in lands.items()}, law_lands)


__all__ = ["PaperExample", "PaperReport", "paper_examples", "resolve_under_laws", "table1",
           "fig3_data", "fig9_data", "fig10_data", "build_report", "ASSUMPTIONS", "PAPER",
           "NULL_VALUES"]
