"""Section ``simulation``: work-precision of the three simulation schemes on the paper's scenes.

Scenes: the planar double pendulum released from horizontal onto the floor (``pendulum_planar``
case "drop"), the slider-crank striking the free slider (``slider_crank``, mass ratio 1) and
the bouncing rod (``bouncing_rod``), each over a short span that holds its first impact(s).
Schemes (all with the "coulomb" impact law where a law applies):

* event-driven :func:`convimpact.simulation.simulate` (DOP853) at several ``rtol``
  (``atol = 1e-2 rtol``);
* Moreau–Jean :func:`convimpact.simulation.moreau.simulate_moreau` at several steps h
  (theta = 1/2);
* compliant :func:`convimpact.simulation.compliant.simulate_compliant` (Hunt–Crossley, its e
  chosen by :func:`~convimpact.simulation.compliant.restitution_for` so that a free contact
  restitutes the scene's e; n = 1.5; Radau) at several stiffnesses k and tolerances.

Errors against a tight event-driven reference (``rtol = 1e-12``):

* ``impact_velocity_error``: max over the reference's first impacts (at most
  :data:`N_IMPACTS`) of ``|theta_dot+ - theta_dot+_ref| / |theta_dot+_ref|``; post-impact
  velocities are the event-driven ``dtheta_plus``, Moreau–Jean's velocity after the impact
  step, the compliant model's velocity at separation. A missed impact counts as error 1;
* ``final_state_error``: ``|y(t1) - y_ref(t1)| / |y_ref(t1)|`` with ``y = (theta, theta_dot)``;
* ``energy_error``: ``|E(t1) - E_ref(t1)|`` divided by the reference's largest kinetic energy.

Each run is timed as a whole (best of ``repeat`` runs in the full bench, one in quick).
The section also quotes :func:`convimpact.simulation.benchmark.benchmark_scene` per scene:
right-hand-side evaluations per second, wall time per simulated second and the share of the
time spent in impact resolution.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import ConvImpactError
from ..scenes import load_scene
from ..simulation import simulate
from ..simulation.benchmark import benchmark_scene
from ..simulation.compliant import restitution_for, simulate_compliant
from ..simulation.moreau import simulate_moreau
from .registry import BenchConfig, Progress, SectionResult, register_section

#: impacts of the reference compared
N_IMPACTS = 2
#: floor of the chart's error axis
ERROR_FLOOR = 1e-12
LAW = "coulomb"
SCHEME_STYLE = {"event-driven": ("o", "tab:blue"), "moreau-jean": ("s", "tab:red"),
                "compliant": ("^", "tab:green")}


def scenes(quick: bool) -> list[dict[str, Any]]:
    """The scenes and spans measured."""
    return [
        {"label": "pendulum drop", "name": "pendulum_planar", "params": {"case": "drop"},
         "span": (0.0, 0.7 if quick else 1.2)},
        {"label": "slider-crank", "name": "slider_crank", "params": {"mass_ratio": 1.0},
         "span": (0.0, 0.02 if quick else 0.05)},
        {"label": "bouncing rod", "name": "bouncing_rod", "params": {},
         "span": (0.0, 0.48 if quick else 0.6)},
    ]


def settings(quick: bool) -> list[tuple[str, str, dict[str, Any]]]:
    """(scheme, setting label, options) of every measured run."""
    out: list[tuple[str, str, dict[str, Any]]] = []
    for rtol in ((1e-4, 1e-7) if quick else (1e-4, 1e-6, 1e-8, 1e-10)):
        out.append(("event-driven", f"rtol={rtol:.0e}",
                    {"rtol": rtol, "atol": 1e-2 * rtol, "law": LAW}))
    for h in ((3e-3, 1e-3) if quick else (1e-2, 3e-3, 1e-3, 3e-4)):
        out.append(("moreau-jean", f"h={h:.0e}", {"h": h, "law": LAW}))
    ks = (1e5, 1e7) if quick else (1e5, 1e6, 1e7, 1e8)
    tols = (1e-6,) if quick else (1e-4, 1e-7)
    for k in ks:
        for rtol in tols:
            out.append(("compliant", f"k={k:.0e} rtol={rtol:.0e}",
                        {"stiffness": k, "rtol": rtol, "atol": 1e-3 * rtol}))
    return out


def _run(scheme: str, scene, span, options: dict[str, Any]):
    if scheme == "event-driven":
        return simulate(scene, span, **options)
    if scheme == "moreau-jean":
        return simulate_moreau(scene, span, **options)
    mech = scene.mechanism
    e = {c: restitution_for("hunt-crossley", mech.contact_parameters(c)[0])
         for c in mech.contact_names}
    return simulate_compliant(scene, span, model="hunt-crossley", e=e, **options)


def post_impact_velocities(res) -> list[np.ndarray]:
    """Post-impact joint velocities, in time order, of any scheme's result."""
    episodes = getattr(res, "episodes", None)
    if episodes is not None:
        return [ep.dtheta_end for ep in episodes if ep.dtheta_end is not None]
    return [np.asarray(i.dtheta_plus, float) for i in res.impacts]


def errors_against(res, ref) -> dict[str, float]:
    """The three error measures of the module docstring."""
    ref_v = post_impact_velocities(ref)[:N_IMPACTS]
    got = post_impact_velocities(res)
    errs = []
    for j, vr in enumerate(ref_v):
        if j >= len(got):
            errs.append(1.0)
        else:
            errs.append(float(np.linalg.norm(got[j] - vr) / max(np.linalg.norm(vr), 1e-300)))
    y = np.concatenate([res.theta[-1], res.dtheta[-1]])
    yr = np.concatenate([ref.theta[-1], ref.dtheta[-1]])
    scale_e = max(float(np.max(ref.kinetic_energy)), 1e-300)
    return {
        "impact_velocity_error": max(errs) if errs else None,
        "final_state_error": float(np.linalg.norm(y - yr) / max(np.linalg.norm(yr), 1e-300)),
        "energy_error": float(abs(res.total_energy[-1] - ref.total_energy[-1]) / scale_e),
    }


#: runs longer than this (s) are not repeated
REPEAT_BELOW = 0.5


def best_of(fn: Callable[[], Any], n: int):
    """The fastest of up to n runs (runs slower than REPEAT_BELOW are not repeated)."""
    best = None
    for _ in range(max(1, n)):
        r = fn()
        if best is None or r.wall_time < best.wall_time:
            best = r
        if r.wall_time > REPEAT_BELOW:
            break
    return best


def work_precision_chart(records: list[dict[str, Any]], scene: str, out: Path) -> str:
    """Three log-log panels (impact velocity, final state, energy): error against wall time."""
    from .charts import _plt, save_chart

    plt = _plt()
    rows = [r for r in records if r["scene"] == scene and r.get("wall_time")]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), sharex=True)
    keys = (("impact_velocity_error", "post-impact velocity error (first impacts)"),
            ("final_state_error", "final state error"),
            ("energy_error", "energy error at t_end / max T"))
    for ax, (key, title) in zip(axes, keys):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="major", alpha=0.3)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("wall time of the run [s]")
        for scheme, (marker, color) in SCHEME_STYLE.items():
            sub = sorted((r for r in rows if r["scheme"] == scheme and r.get(key) is not None),
                         key=lambda r: r["wall_time"])
            if not sub:
                continue
            xs = [r["wall_time"] for r in sub]
            ys = [max(r[key], ERROR_FLOOR) for r in sub]
            ax.plot(xs, ys, marker=marker, color=color, ls="-" if scheme != "compliant"
                    else "none", label=scheme, alpha=0.85)
            for r, x, y in zip(sub, xs, ys):
                ax.annotate(r["setting"].replace(" rtol=", "/"), (x, y), fontsize=6,
                            color=color, xytext=(3, 3), textcoords="offset points")
    axes[0].set_ylabel("relative error against the tight event-driven reference")
    axes[0].legend(fontsize=8, loc="best")
    fig.suptitle(f"simulation work-precision: {scene} (law '{LAW}'; labels: tolerance, step "
                 "h, stiffness k)", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    name = f"simulation_{scene.replace(' ', '_').replace('-', '_')}.png"
    return save_chart(fig, out, name)


def _cheapest_below(rows, key: str, level: float):
    ok = [r for r in rows if r.get(key) is not None and r[key] <= level and r.get("wall_time")]
    return min(ok, key=lambda r: r["wall_time"]) if ok else None


def headline(rows: list[dict[str, Any]], label: str) -> str:
    """Each time-stepping scheme's most accurate run against the cheapest event-driven run
    that is at least as accurate (post-impact velocity error)."""
    key = "impact_velocity_error"
    parts = []
    for scheme in ("moreau-jean", "compliant"):
        sub = [r for r in rows if r["scheme"] == scheme and r.get(key) is not None]
        if not sub:
            continue
        best = min(sub, key=lambda r: (r[key], r["wall_time"]))
        ed = _cheapest_below([r for r in rows if r["scheme"] == "event-driven"], key,
                             best[key])
        text = (f"{scheme} at best {best[key]:.2g} in {best['wall_time']:.3g} s "
                f"({best['setting']})")
        if ed:
            text += (f", event-driven {ed[key]:.2g} in {ed['wall_time']:.3g} s "
                     f"({ed['setting']}); wall-time ratio {scheme}/event-driven "
                     f"{best['wall_time'] / ed['wall_time']:.3g}")
        parts.append(text)
    return f"{label}, post-impact velocity error: " + "; ".join(parts)


@register_section("simulation", "simulation work-precision: event-driven, Moreau-Jean and "
                                "compliant contact against a tight event-driven reference")
def simulation_section(config: BenchConfig, progress: Progress) -> SectionResult:
    """Run item 3 of the benchmark (see the module docstring)."""
    records: list[dict[str, Any]] = []
    figures: list[str] = []
    summary: list[str] = []
    refs: dict[str, Any] = {}
    n_rep = 2 if config.quick else 3
    for sc in scenes(config.quick):
        scene = load_scene(sc["name"], **sc["params"])
        span = sc["span"]
        ref = simulate(scene, span, law=LAW, rtol=1e-12, atol=1e-14)
        refs[sc["label"]] = {
            "span": list(span), "rtol": 1e-12, "atol": 1e-14, "law": LAW,
            "impact_times": [i.time for i in ref.impacts[:N_IMPACTS]],
            "n_impacts": len(ref.impacts), "wall_time": ref.wall_time}
        progress(f"simulation {sc['label']}: reference {len(ref.impacts)} impacts, "
                 f"{ref.wall_time:.2f}s")
        for scheme, label, opts in settings(config.quick):
            rec: dict[str, Any] = {"scene": sc["label"], "scheme": scheme, "setting": label,
                                   "options": dict(opts), "span": list(span)}
            try:
                res = best_of(lambda: _run(scheme, scene, span, opts), n_rep)
            except ConvImpactError as exc:
                rec.update(wall_time=None, error=f"{type(exc).__name__}: {exc}"[:300])
                records.append(rec)
                progress(f"simulation {sc['label']} {scheme} {label}: {type(exc).__name__}")
                continue
            sim_t = float(span[1] - span[0])
            rec.update(errors_against(res, ref))
            rec.update(
                wall_time=res.wall_time, status=res.status, nfev=res.nfev,
                n_steps=res.n_steps, rhs_per_second=res.rhs_per_second,
                wall_per_simulated_second=res.wall_time / sim_t,
                impact_time=res.impact_time, impact_share=res.impact_share,
                n_impacts=len(post_impact_velocities(res)),
                max_penetration=getattr(res, "max_penetration", 0.0),
                n_contact_steps=getattr(res, "n_contact_steps", None),
                max_loop_residual=res.max_loop_residual, error=None)
            if scheme == "compliant":
                rec["contact_durations"] = res.contact_durations
                rec["njev"] = res.njev
            records.append(rec)
            progress(f"simulation {sc['label']} {scheme} {label}: {res.wall_time:.3f}s, "
                     f"impact velocity error {rec['impact_velocity_error']:.2e}")
        figures.append(work_precision_chart(records, sc["label"], config.out))
        rows = [r for r in records if r["scene"] == sc["label"]]
        summary.append(headline(rows, sc["label"]))
        comp = [r for r in rows if r["scheme"] == "compliant" and r.get("wall_time")]
        if comp:
            stiff = max(comp, key=lambda r: r["options"]["stiffness"])
            summary.append(
                f"{sc['label']}: compliant k = {stiff['options']['stiffness']:.0e} penetrates "
                f"{stiff['max_penetration']:.2e} m and spends {stiff['n_contact_steps']} of "
                f"{stiff['n_steps']} steps in contact")

    # per-scene throughput of the event-driven simulator (simulation/benchmark.py)
    throughput = []
    names = (("pendulum_planar", "slider_crank", "bouncing_rod") if config.quick else
             ("pendulum_planar", "pendulum_3d", "slider_crank", "bouncing_rod", "bouncing_ball"))
    for name in names:
        try:
            row = benchmark_scene(name, repeats=1 if config.quick else 3)
        except ConvImpactError as exc:
            row = {"scene": name, "error": f"{type(exc).__name__}: {exc}"[:300]}
        throughput.append(row)
        if "error" not in row:
            progress(f"simulation throughput {name}: {row['rhs_per_second']:.3g} RHS/s")
    ok = [r for r in throughput if "error" not in r]
    if ok:
        summary.append(
            "event-driven throughput over each scene's default span: " + "; ".join(
                f"{r['scene']} {r['rhs_per_second']:.3g} RHS/s, "
                f"{r['wall_per_simulated_second']:.3g} s per simulated s, "
                f"{100 * r['impact_share']:.1f}% in impact resolution" for r in ok))
    meta = {
        "law": LAW, "references": refs, "n_impacts_compared": N_IMPACTS,
        "throughput": throughput,
        "definitions": {
            "impact_velocity_error": "max over the reference's first impacts of |dq+ - "
                                     "dq+_ref| / |dq+_ref| (missed impact: 1)",
            "final_state_error": "|(theta, theta_dot)(t1) - ref| / |ref|",
            "energy_error": "|E(t1) - E_ref(t1)| / max T_ref",
            "compliant": "Hunt-Crossley, n = 1.5, e set by restitution_for so a free contact "
                         "restitutes the scene's e, Radau, atol = 1e-3 rtol",
            "moreau-jean": "theta = 1/2, law coulomb",
            "event-driven": "DOP853, atol = 1e-2 rtol, law coulomb"},
    }
    return SectionResult("simulation", records, figures, summary, meta)
