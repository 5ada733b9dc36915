"""Section ``mujoco``: our event-driven simulation against MuJoCo at equal accuracy.

Scenes (:data:`convimpact.bench.mujoco_peers.SCENES`, built as MJCF with our masses, inertias,
lengths, gravity and initial state): the bouncing ball (e = 0.5, frictionless), the bouncing
rod (e = 0.5, mu = 0.3) and the double pendulum's drop (e = 0.5, mu = 0.3), over the spans of
:data:`SPANS`, each holding the first two or three impacts.

* Ours: :func:`convimpact.simulation.simulate` (DOP853, law ``coulomb``) at several ``rtol``
  (``atol = 1e-2 rtol``), the whole call timed (best of ``repeat``).
* MuJoCo: ``mujoco.rollout.rollout`` (the stepping loop in C, its fastest honest loop for one
  trajectory) over a grid of contact time constants ``timeconst`` (MuJoCo's default 0.02 and
  stiffer), integrators (Euler, RK4) and timesteps ``timeconst / ratio``; for each
  ``timeconst`` the ``dampratio`` calibrated so that MuJoCo's converged rebound restitutes
  e (:func:`~convimpact.bench.mujoco_peers.calibrate`).

Errors (:mod:`convimpact.bench.mujoco_accuracy`): the first rebound's energy error and the final
state error against the closed form (ball) or our event-driven run at rtol 1e-12.
**Equal-accuracy point**: ours, the cheapest ``rtol`` whose rebound and final-state errors are
both at most :data:`OURS_TARGET`; MuJoCo, per (integrator, timeconst) the largest timestep
whose rebound error, and that of every smaller timestep of the grid, is at most
:data:`MUJOCO_TARGET`, then the cheapest of these. Where MuJoCo's *converged* soft contact
(timestep ``timeconst / converged_ratio``) is itself further than the target from the rigid
reference (its friction during a compliant impact is not a rigid Coulomb impact: the rod and
the double pendulum), no step can reach it, and the step is chosen on the error against that
converged run instead (MuJoCo's discretization error alone: the reading most favourable to
it); the converged run's own error (the model floor) is stated. The ratios are MuJoCo's wall
time, and CPU time, per simulated second over ours (above 1: ours is faster); CPU time is the
steadier measure on a shared machine.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..scenes import load_scene
from .mujoco_accuracy import LAW, Reference, ball_reference, errors, simulated_reference
from .mujoco_accuracy import state_from_dense
from .registry import BenchConfig, Progress, SectionResult, register_section

OURS_TARGET = 1e-6
MUJOCO_TARGET = 1e-3
#: scene label -> simulated span end (s)
SPANS = {"bouncing ball": 1.0, "bouncing rod": 0.6, "pendulum drop": 1.2}
ERROR_FLOOR = 1e-13


def grids(quick: bool) -> dict[str, Any]:
    """The settings measured (quick: MuJoCo's default time constant, Euler, two steps)."""
    if quick:
        return {"rtols": (1e-6, 1e-8), "timeconsts": (0.02,), "integrators": ("Euler",),
                "ratios": {"Euler": (20, 100)}, "converged_ratio": 400,
                "calibration_tol": 1e-5}
    return {"rtols": (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-10),
            "timeconsts": (0.02, 0.005, 0.002), "integrators": ("Euler", "RK4"),
            "ratios": {"Euler": (5, 10, 20, 50, 100, 200, 500, 1000),
                       "RK4": (2, 5, 10, 20, 50, 100, 200)},
            "converged_ratio": 2000, "calibration_tol": 1e-7}


def reference_for(label: str, scene, t_end: float) -> Reference:
    if label == "bouncing ball":
        return ball_reference(scene.parameters, t_end)
    return simulated_reference(scene, t_end)


def ours_record(label: str, scene, ref: Reference, rtol: float, repeat: int) -> dict[str, Any]:
    """One event-driven run: best wall time of ``repeat`` plain runs, errors from the same
    run with dense output (identical steps)."""
    import time

    from ..simulation import simulate

    span = (0.0, ref.t_end)
    opts = {"law": LAW, "rtol": rtol, "atol": 1e-2 * rtol}
    best = cpu = np.inf
    for _ in range(max(1, repeat)):
        t0, c0 = time.perf_counter(), time.process_time()
        res = simulate(scene, span, **opts)
        best = min(best, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    dense = simulate(scene, span, dense_output=True, **opts)
    mech = scene.mechanism
    th_m, dth_m = state_from_dense(mech, dense, ref.t_mid)
    rec = {"scene": label, "simulator": "ours", "setting": f"rtol={rtol:.0e}", "rtol": rtol,
           "atol": 1e-2 * rtol, "wall_time": best, "wall_per_simulated_second": best / ref.t_end,
           "cpu_per_simulated_second": cpu / ref.t_end,
           "n_impacts": len(res.impacts), "nfev": res.nfev, "n_steps": res.n_steps}
    rec.update(errors(mech, ref, th_m, dth_m, res.theta[-1], res.dtheta[-1]))
    return rec


def mujoco_record(label: str, scene, ref: Reference, cal, integrator: str, timestep: float,
                  ratio: int, repeat: int, converged=None) -> dict[str, Any]:
    """One MuJoCo rollout and its errors (against the reference, and against ``converged``,
    MuJoCo's own run at the same contact parameters and a tiny timestep, when given)."""
    from .mujoco_peers import ContactSetting, simulate_mujoco

    c = ContactSetting(cal.timeconst, cal.dampratio, timestep, integrator)
    run = simulate_mujoco(label, scene, ref.t_end, c, repeat=repeat)
    th_m, dth_m = run.state_at(ref.t_mid)
    rec = {"scene": label, "simulator": "mujoco",
           "setting": f"{integrator} tc={cal.timeconst:g} h=tc/{ratio}",
           "integrator": integrator, "timeconst": cal.timeconst, "dampratio": cal.dampratio,
           "timestep": timestep, "ratio": ratio, "n_steps": int(run.time.size),
           "wall_time": run.wall_time, "wall_per_simulated_second": run.wall_time / ref.t_end,
           "cpu_per_simulated_second": run.cpu_time / ref.t_end}
    mech = scene.mechanism
    rec.update(errors(mech, ref, th_m, dth_m, run.qpos[-1], run.qvel[-1]))
    if converged is not None:
        own = converged_reference(mech, ref, converged)
        rec.update({f"self_{k}": v for k, v in
                    errors(mech, own, th_m, dth_m, run.qpos[-1], run.qvel[-1]).items()})
    return rec


def converged_reference(mech, ref: Reference, run) -> Reference:
    """A MuJoCo run at a tiny timestep as the reference of MuJoCo's discretization error
    (the energy scale stays the rigid reference's)."""
    th_m, dth_m = run.state_at(ref.t_mid)
    return Reference(t_end=ref.t_end, t_mid=ref.t_mid,
                     energy_mid=mech.kinetic_energy(th_m, dth_m) + mech.potential_energy(th_m),
                     kinetic_before=ref.kinetic_before,
                     state_end=np.concatenate([run.qpos[-1], run.qvel[-1]]),
                     impact_times=ref.impact_times, source="MuJoCo, tiny timestep")


def ours_choice(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """Our cheapest run with both errors at most :data:`OURS_TARGET`."""
    ok = [r for r in rows if r["simulator"] == "ours" and r["rebound_error"] <= OURS_TARGET
          and r["final_state_error"] <= OURS_TARGET]
    return min(ok, key=lambda r: r["wall_time"]) if ok else None


def mujoco_choice(rows: list[dict[str, Any]],
                  key: str = "rebound_error") -> dict[str, Any] | None:
    """MuJoCo's cheapest run with ``key`` at :data:`MUJOCO_TARGET` (see the module docstring)."""
    picks = []
    chains: dict[tuple, list[dict[str, Any]]] = {}
    for r in rows:
        if r["simulator"] == "mujoco" and r.get(key) is not None:
            chains.setdefault((r["integrator"], r["timeconst"]), []).append(r)
    for chain in chains.values():
        chain = sorted(chain, key=lambda r: r["timestep"])  # smallest step first
        chosen = None
        for r in chain:
            if r[key] > MUJOCO_TARGET:
                break
            chosen = r
        if chosen is not None:
            picks.append(chosen)
    return min(picks, key=lambda r: r["wall_time"]) if picks else None


def work_precision_chart(records: list[dict[str, Any]], labels: list[str], out) -> str:
    """Wall time per simulated second against error, one column per scene, one row per error
    measure; MuJoCo's lines join the timesteps of one (integrator, timeconst)."""
    from .charts import _plt, save_chart

    plt = _plt()
    fig, axes = plt.subplots(3, len(labels), figsize=(5.2 * len(labels), 12.6), squeeze=False)
    colors = {("Euler", 0): "tab:red", ("Euler", 1): "tab:orange", ("Euler", 2): "tab:brown",
              ("RK4", 0): "tab:green", ("RK4", 1): "tab:olive", ("RK4", 2): "tab:cyan"}
    for j, label in enumerate(labels):
        rows = [r for r in records if r["scene"] == label]
        tcs = sorted({r["timeconst"] for r in rows if r["simulator"] == "mujoco"}, reverse=True)
        mj = mujoco_choice(rows) or mujoco_choice(rows, "self_rebound_error")
        picks = [p for p in (ours_choice(rows), mj) if p]
        for i, (key, title) in enumerate((
                ("rebound_error", "first rebound energy error"),
                ("final_state_error", "final state error"),
                ("self_rebound_error", "rebound error, MuJoCo against its converged run"))):
            ax = axes[i, j]
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.grid(True, which="major", alpha=0.3)
            ax.set_title(f"{label}: {title}", fontsize=10)
            ax.set_xlabel("relative error")
            ours = sorted((r for r in rows if r["simulator"] == "ours"), key=lambda r: r["rtol"])
            okey = "rebound_error" if key == "self_rebound_error" else key
            ax.plot([max(r[okey], ERROR_FLOOR) for r in ours],
                    [r["wall_per_simulated_second"] for r in ours], "o-", color="tab:blue",
                    label="ours (event-driven, rtol)")
            for r in ours:
                ax.annotate(f"{r['rtol']:.0e}", (max(r[okey], ERROR_FLOOR),
                                                 r["wall_per_simulated_second"]),
                            fontsize=6, color="tab:blue", xytext=(3, 3), textcoords="offset points")
            for integ in ("Euler", "RK4"):
                for k, tc in enumerate(tcs):
                    sub = sorted((r for r in rows if r["simulator"] == "mujoco"
                                  and r["integrator"] == integ and r["timeconst"] == tc),
                                 key=lambda r: r["timestep"])
                    if sub:
                        ax.plot([max(r[key], ERROR_FLOOR) for r in sub],
                                [r["wall_per_simulated_second"] for r in sub],
                                "s--" if integ == "Euler" else "^--",
                                color=colors.get((integ, k), "gray"), alpha=0.8, ms=4,
                                label=f"MuJoCo {integ}, timeconst {tc:g}")
            for p in picks:
                pkey = okey if p["simulator"] == "ours" else key
                if p.get(pkey) is not None:
                    ax.plot([max(p[pkey], ERROR_FLOOR)], [p["wall_per_simulated_second"]], "o",
                            ms=13, mfc="none", mec="black")
            if key != "final_state_error":
                ax.axvline(OURS_TARGET, color="tab:blue", lw=0.8, ls=":")
                ax.axvline(MUJOCO_TARGET, color="tab:red", lw=0.8, ls=":")
        for i in range(3):
            axes[i, j].set_ylabel("wall time per simulated second [s]")
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.suptitle("simulation against MuJoCo: wall time per simulated second against error "
                 f"(circled: ours at {OURS_TARGET:g}, MuJoCo at {MUJOCO_TARGET:g}; dotted: "
                 "the two targets)", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    return save_chart(fig, out, "mujoco_work_precision.png")


def comparison(label: str, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The equal-accuracy point of one scene.

    MuJoCo's step is chosen on its rebound error against the reference; where no setting
    reaches :data:`MUJOCO_TARGET` so (its converged soft contact differs from the rigid law by
    more: the ``model_floor``), on its error against its own converged run instead.
    """
    ours = ours_choice(rows)
    floor = {r["timeconst"]: r["rebound_error"] for r in rows
             if r["simulator"] == "mujoco-converged"}
    mj, criterion = mujoco_choice(rows), "against the reference"
    if mj is None:
        mj, criterion = mujoco_choice(rows, "self_rebound_error"), "against its converged run"
    out: dict[str, Any] = {"scene": label, "ours": ours and ours["setting"],
                           "mujoco": mj and mj["setting"], "mujoco_criterion": criterion,
                           "model_floor": floor}
    if ours and mj:
        out.update(ours_wall_per_s=ours["wall_per_simulated_second"],
                   mujoco_wall_per_s=mj["wall_per_simulated_second"],
                   ours_rebound_error=ours["rebound_error"],
                   mujoco_rebound_error=mj["rebound_error"],
                   mujoco_self_rebound_error=mj.get("self_rebound_error"),
                   ours_final_state_error=ours["final_state_error"],
                   mujoco_final_state_error=mj["final_state_error"],
                   mujoco_over_ours=mj["wall_per_simulated_second"]
                   / ours["wall_per_simulated_second"],
                   mujoco_over_ours_cpu=mj["cpu_per_simulated_second"]
                   / ours["cpu_per_simulated_second"])
        key = "rebound_error" if criterion == "against the reference" else "self_rebound_error"
        lucky = [r for r in rows if r["simulator"] == "mujoco" and r.get(key) is not None
                 and r[key] <= MUJOCO_TARGET]
        if lucky:  # any single run at the target, smaller steps or not (a lenient reading)
            low = min(lucky, key=lambda r: r["wall_time"])
            out.update(mujoco_lenient=low["setting"],
                       mujoco_lenient_over_ours=low["wall_per_simulated_second"]
                       / ours["wall_per_simulated_second"])
    return out


def sentence(c: dict[str, Any]) -> str:
    """The summary line of one scene."""
    floor = ", ".join(f"{v:.1e} at timeconst {k:g}" for k, v in sorted(c["model_floor"].items()))
    if "mujoco_over_ours" in c:
        own = (f", {c['mujoco_self_rebound_error']:.1e} against its converged run"
               if c.get("mujoco_self_rebound_error") is not None else "")
        return (f"{c['scene']}: ours {c['ours_wall_per_s']:.3g} s per simulated s at "
                f"{c['ours']} (rebound error {c['ours_rebound_error']:.1e}, final state "
                f"{c['ours_final_state_error']:.1e}); MuJoCo {c['mujoco_wall_per_s']:.3g} s at "
                f"{c['mujoco']}, step chosen {c['mujoco_criterion']} (rebound error "
                f"{c['mujoco_rebound_error']:.1e}{own}, final state "
                f"{c['mujoco_final_state_error']:.1e}; converged MuJoCo's rebound error: "
                f"{floor}); MuJoCo/ours {c['mujoco_over_ours']:.3g} in wall time, "
                f"{c['mujoco_over_ours_cpu']:.3g} in CPU time")
    if c.get("mujoco") is None:
        return (f"{c['scene']}: no MuJoCo setting reached {MUJOCO_TARGET:g} even against its "
                f"own converged run (converged rebound error {floor}); ours at {c['ours']}")
    return f"{c['scene']}: none of our tolerances reached {OURS_TARGET:g}"


@register_section("mujoco", "simulation against MuJoCo (optional peer): wall time per "
                            "simulated second at equal accuracy, MuJoCo's contact calibrated "
                            "to the scene's restitution")
def mujoco_section(config: BenchConfig, progress: Progress) -> SectionResult:
    """Run the comparison of the module docstring (skipped with a note without MuJoCo)."""
    from .mujoco_peers import (SCENES, SOLIMP, ContactSetting, calibrate, mujoco_version,
                               simulate_mujoco, timestep_grid)

    version = mujoco_version()
    if version is None:
        note = "mujoco is not installed (pip install mujoco): section skipped"
        progress(note)
        return SectionResult("mujoco", [], [], [note], {"skipped": note})
    g = grids(config.quick)
    repeat = 1 if config.quick else 5
    cals = []
    for tc in g["timeconsts"]:
        cal = calibrate(tc, 0.5, tol=g["calibration_tol"])
        cals.append(cal)
        progress(f"mujoco: timeconst {tc:g} -> dampratio {cal.dampratio:.6f} "
                 f"(rebound {cal.restitution_reached:.8f}, +-{cal.convergence:.1e})")
    records: list[dict[str, Any]] = []
    refs: dict[str, Any] = {}
    comparisons = []
    for label, (name, params, _) in SCENES.items():
        scene = load_scene(name, **params)
        ref = reference_for(label, scene, SPANS[label])
        refs[label] = {"source": ref.source, "t_end": ref.t_end, "t_mid": ref.t_mid,
                       "impact_times": list(ref.impact_times), "self_error": ref.self_error}
        ours_record(label, scene, ref, g["rtols"][0], 1)  # warm-up (compiled kernels, caches)
        for rtol in g["rtols"]:
            records.append(ours_record(label, scene, ref, rtol, repeat))
            r = records[-1]
            progress(f"mujoco {label} ours rtol {rtol:.0e}: {r['wall_per_simulated_second']:.3g}"
                     f" s/s, rebound {r['rebound_error']:.1e}, final {r['final_state_error']:.1e}")
        for cal in cals:
            h_conv = timestep_grid(ref.t_end, cal.timeconst, [g["converged_ratio"]])[0]
            conv = simulate_mujoco(label, scene, ref.t_end,
                                   ContactSetting(cal.timeconst, cal.dampratio, h_conv))
            th_m, dth_m = conv.state_at(ref.t_mid)
            records.append({"scene": label, "simulator": "mujoco-converged",
                            "setting": f"Euler tc={cal.timeconst:g} h=tc/{g['converged_ratio']}",
                            "integrator": "Euler", "timeconst": cal.timeconst,
                            "dampratio": cal.dampratio, "timestep": h_conv,
                            "wall_time": conv.wall_time,
                            "wall_per_simulated_second": conv.wall_time / ref.t_end,
                            **errors(scene.mechanism, ref, th_m, dth_m, conv.qpos[-1],
                                     conv.qvel[-1])})
            progress(f"mujoco {label} converged tc={cal.timeconst:g}: rebound error "
                     f"{records[-1]['rebound_error']:.1e}")
            for integ in g["integrators"]:
                ratios = g["ratios"][integ]
                steps = timestep_grid(ref.t_end, cal.timeconst, ratios)
                for ratio, h in zip(ratios, steps):
                    records.append(mujoco_record(label, scene, ref, cal, integ, h, ratio, repeat,
                                                 converged=conv))
                    r = records[-1]
                    progress(f"mujoco {label} {r['setting']}: {r['wall_per_simulated_second']:.3g}"
                             f" s/s, rebound {r['rebound_error']:.1e} (own "
                             f"{r['self_rebound_error']:.1e}), final {r['final_state_error']:.1e}")
        comparisons.append(comparison(label, [r for r in records if r["scene"] == label]))
        progress(sentence(comparisons[-1]))
    figures = [work_precision_chart(records, list(SCENES), config.out)]
    summary = [
        f"MuJoCo {version} contact calibration (solimp {' '.join(f'{x:g}' for x in SOLIMP)}, "
        "constant impedance): "
        + "; ".join(f"timeconst {c.timeconst:g} s -> dampratio {c.dampratio:.5f} (converged "
                    f"rebound e = {c.restitution_reached:.7f})" for c in cals)]
    summary += [sentence(c) for c in comparisons]
    meta = {
        "mujoco_version": version, "law": LAW, "ours_target": OURS_TARGET,
        "mujoco_target": MUJOCO_TARGET, "spans": SPANS, "references": refs,
        "calibrations": [c.__dict__ for c in cals], "comparisons": comparisons,
        "grids": g,
        "definitions": {
            "rebound_error": "|E(t_mid) - E_ref(t_mid)| / T_ref before the first impact, "
                             "t_mid between the reference's first two impacts",
            "final_state_error": "|(theta, theta_dot)(t_end) - ref| / |ref|",
            "self_rebound_error": "MuJoCo's rebound error against its own run at the same "
                                  "contact parameters and timestep timeconst/converged_ratio",
            "wall_per_simulated_second": "ours: the whole simulate() call; MuJoCo: "
                                         "mujoco.rollout.rollout over the span (model built "
                                         "beforehand); best of the repeats",
            "mujoco_choice": "per (integrator, timeconst) the largest timestep whose rebound "
                             "error and every smaller one's is at most the target; the "
                             "cheapest; against its converged run where no setting reaches "
                             "the target against the reference",
            "ours_choice": "the cheapest rtol with both errors at most the target"},
    }
    return SectionResult("mujoco", records, figures, summary, meta)
