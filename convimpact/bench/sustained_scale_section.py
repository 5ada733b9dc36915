"""Section ``sustained-scale``: the event-driven scheme's many-contact scenes against MuJoCo,
and the cost of one stop's contact force problem against the enumerator it replaced.

1. **One stop** (the force problem of sustained contact at an event, solved by
   :func:`convimpact.simulation.force_solver.solve_contact_forces`): the ``table`` scene on
   3 to 48 legs, at rest and sliding, posed at its initial state
   (:func:`~convimpact.simulation.sustained.contact_state`); median time of ours and of the
   exact enumerator (:func:`~convimpact.simulation.contact_forces.force_solutions`, 3^n to
   4^n mode combinations: at rest up to 4 legs, sliding up to 7 (quick: 3 and 5)), and whether
   the two agree (modes, and forces to 1e-7 of the force scale).
2. **Simulation per simulated second**: ``table`` on 4 to 48 legs at rest and sliding
   (0.5 s; it stops at v0 / (mu g) = 0.204 s), and ``box_stack`` (12 contacts, 0.9 s; the
   push's onset ``t_push``, a kink of the applied force, passed as ``breakpoints``: the
   integrator restarts there instead of shrinking its steps onto it; also timed without), ours
   (event-driven, default tolerances) against MuJoCo (:mod:`.sustained_scale_peers`,
   default settings, 2 ms steps) on the same scenes: wall time per simulated second, the
   deepest penetration, the observables with closed forms (the table's stop time and
   distance v0 / (mu g), v0^2 / (2 mu g), the energy it loses, 1/2 m v0^2; at rest the
   energy drift over m g h; the stack's tipping time, 0.44 s) and their errors. Wall time
   and the process's CPU time (which a loaded machine inflates less: a run of ours is
   milliseconds to seconds, a MuJoCo rollout often less than one scheduler slice), each
   the median of ``repeat`` runs of the scene (ours: fewer once :data:`RUN_BUDGET` seconds
   are spent; after one untimed run of another scene, which warms the caches); MuJoCo's
   rollouts after a 10-step warm-up.
3. **A humanoid pushed** (full run, with the ``robots`` extra): ``humanoid_push`` (TALOS on
   its 8 sole corners) ours once (after an untimed run) against MuJoCo on the same 18 coordinates
   (:mod:`.humanoid_peer`: the MJCF written from our reduced Pinocchio model, PD as MuJoCo's
   joint springs and dampers): time per simulated second, the soles' penetration, and how far
   the push carries the base (sideways displacement, roll, sole slip), computed with our
   model on both runs' states.

The growth with the number of contacts is the least-squares slope of log time against log
contacts, per series.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from .registry import BenchConfig, Progress, SectionResult, register_section

LEGS = (3, 4, 5, 6, 8, 12, 16, 24, 32, 48)
QUICK_LEGS = (3, 4, 8, 16)
SIM_LEGS = (4, 8, 16, 24, 32, 48)
QUICK_SIM_LEGS = (4, 16)
#: largest table the enumerator is timed on, at rest and sliding (3^n, 2^n combinations)
ENUMERATE = {"rest": 4, "slide": 7}
QUICK_ENUMERATE = {"rest": 3, "slide": 5}
TABLE_SPAN = 0.5
#: seconds of repeated runs of one scene beyond which no further run is timed
RUN_BUDGET = 3.0


def _table(legs: int, kind: str):
    from ..scenes import load_scene

    return load_scene("table", legs=legs, v0=0.6 if kind == "slide" else 0.0,
                      t_end=TABLE_SPAN)


def _stop_problem(scene):
    from ..simulation.sustained import contact_state

    mech = scene.mechanism
    return contact_state(mech, 0.0, scene.theta0, scene.dtheta0, mech.contact_names,
                         1e-6).problem


def _time(fn, repeat: int) -> tuple[float, Any]:
    out = fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        if sum(times) > 5.0:
            break
    return float(np.median(times)), out


def measure_stops(config: BenchConfig, progress: Progress) -> list[dict[str, Any]]:
    """Part 1: one stop's force problem, ours and the enumerator's."""
    from ..simulation.contact_forces import force_solutions
    from ..simulation.force_solver import solve_contact_forces

    legs_list = QUICK_LEGS if config.quick else LEGS
    limits = QUICK_ENUMERATE if config.quick else ENUMERATE
    records = []
    for kind in ("rest", "slide"):
        for legs in legs_list:
            P = _stop_problem(_table(legs, kind))
            t_ours, ours = _time(lambda: solve_contact_forces(P), config.repeat)
            rec = {"part": "stop", "scene": f"table-{kind}", "contacts": legs,
                   "ours_time": t_ours, "ours_modes": list(ours.modes),
                   "enumerator_time": None, "agree": None}
            if legs <= limits[kind]:
                t_enum, sols = _time(lambda: force_solutions(P), 1)
                rec["enumerator_time"] = t_enum
                rec["enumerator_solutions"] = len(sols)
                if len(sols) == 1:
                    rec["agree"] = bool(sols[0].modes == ours.modes and np.allclose(
                        sols[0].force, ours.force, atol=1e-7 * P.scales[1]))
            records.append(rec)
            progress(f"sustained-scale stop: table {kind} {legs} legs: ours "
                     f"{t_ours * 1e3:.2f} ms" + (f", enumerator {rec['enumerator_time']:.2f} s"
                                                 if rec["enumerator_time"] else ""))
    return records


def _ours_run(scene, repeat: int, **options):
    """(median wall time, median CPU time, result) of ``repeat`` runs of the scene (fewer
    past :data:`RUN_BUDGET` seconds in all; at least one); ``options`` of
    :func:`~convimpact.simulation.simulate`."""
    from ..simulation import simulate

    walls, cpus, res = [], [], None
    for _ in range(max(1, repeat)):
        t0, c0 = time.perf_counter(), time.process_time()
        res = simulate(scene.mechanism, (0.0, scene.t_end), (scene.theta0, scene.dtheta0),
                       **options)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
        if sum(walls) > RUN_BUDGET:
            break
    return float(np.median(walls)), float(np.median(cpus)), res


def _ours_table(scene, repeat: int = 1) -> dict[str, Any]:
    p = scene.parameters
    wall, cpu, res = _ours_run(scene, repeat)
    mech = scene.mechanism
    gaps = np.array([[mech.contact_gap(c, th) for c in mech.contact_names] for th in res.theta])
    E = res.kinetic_energy + res.potential_energy
    m, g, h, v0 = p["mass"], p["gravity"], p["height"], p["v0"]
    out = {"wall_per_second": wall / scene.t_end, "cpu_per_second": cpu / scene.t_end,
           "status": res.status,
           "penetration": float(max(0.0, -gaps.min())),
           "distance": float(np.hypot(res.theta[-1, 0] - scene.theta0[0],
                                      res.theta[-1, 2] - scene.theta0[2]))}
    if v0 == 0:  # at rest: nothing to lose or gain
        out["energy_drift"] = float(np.max(np.abs(E - E[0]))) / (m * g * h)
    if v0 > 0:
        first = [iv.t_start for iv in res.modes_of(mech.contact_names[0]) if iv.mode == "stick"]
        out["stop_time"] = first[0] if first else math.nan
        out["energy_lost"] = float((E[0] - E[-1]) / (0.5 * m * v0 ** 2))
    return out


def _errors(rec: dict[str, Any], p) -> None:
    """Errors of the observables against the closed forms, in place."""
    if p["v0"] > 0:
        rec["stop_time_error"] = abs(rec["stop_time"] - p["stop_time"]) / p["stop_time"]
        rec["distance_error"] = abs(rec["distance"] - p["stop_distance"]) / p["stop_distance"]
        rec["energy_lost_error"] = abs(rec["energy_lost"] - 1.0)
    else:
        rec["distance_error"] = rec["distance"]  # absolute (m): it should not move


def measure_simulations(config: BenchConfig, progress: Progress,
                        mujoco: bool) -> list[dict[str, Any]]:
    """Part 2: event-driven against MuJoCo per simulated second."""
    from ..scenes import load_scene
    from . import sustained_scale_peers as peers

    records = []
    _ours_table(_table(4, "slide"))  # warm-up
    for kind in ("rest", "slide"):
        for legs in (QUICK_SIM_LEGS if config.quick else SIM_LEGS):
            scene = _table(legs, kind)
            p = scene.parameters
            rec = {"part": "simulation", "scene": f"table-{kind}", "contacts": legs,
                   "scheme": "event-driven", **_ours_table(scene, config.repeat)}
            _errors(rec, p)
            records.append(rec)
            line = f"sustained-scale simulate: table {kind} {legs} legs: ours " \
                   f"{rec['wall_per_second']:.3f} s/s"
            if mujoco:
                run = peers.run_table(p, scene.t_end, config.repeat)
                mj = {"part": "simulation", "scene": f"table-{kind}", "contacts": legs,
                      "scheme": "mujoco", "wall_per_second": run.wall_time / scene.t_end,
                      "cpu_per_second": run.cpu_time / scene.t_end,
                      **peers.table_observables(p, run)}
                if kind == "rest":
                    mj.pop("stop_time", None)
                _errors(mj, p)
                records.append(mj)
                line += f", MuJoCo {mj['wall_per_second']:.4f} s/s"
            progress(line)
    scene = load_scene("box_stack")
    p = scene.parameters
    # the push's onset, a kink of the applied force, declared (the headline), and not
    wall_plain, cpu_plain, _ = _ours_run(scene, config.repeat)
    wall, cpu, res = _ours_run(scene, config.repeat, breakpoints=(p["t_push"],))
    back = [iv.t_start for iv in res.modes_of("box0_c0") if iv.mode == "open"]
    rec = {"part": "simulation", "scene": "box_stack", "contacts": 4 * p["n_boxes"],
           "scheme": "event-driven", "wall_per_second": wall / scene.t_end,
           "cpu_per_second": cpu / scene.t_end, "breakpoints": [p["t_push"]],
           "wall_per_second_plain": wall_plain / scene.t_end,
           "cpu_per_second_plain": cpu_plain / scene.t_end,
           "status": res.status, "tip_time": back[0] if back else math.nan,
           "penetration": float(max(0.0, -min(scene.mechanism.contact_gap(c, th)
                                              for th in res.theta
                                              for c in scene.mechanism.contact_names)))}
    rec["tip_time_error"] = abs(rec["tip_time"] - p["tip_time"]) / p["tip_time"]
    records.append(rec)
    line = f"sustained-scale simulate: box_stack: ours {rec['wall_per_second']:.3f} s/s"
    if mujoco:
        run = peers.run_stack(p, scene.t_end, config.repeat)
        mj = {"part": "simulation", "scene": "box_stack", "contacts": 4 * p["n_boxes"],
              "scheme": "mujoco", "wall_per_second": run.wall_time / scene.t_end,
              "cpu_per_second": run.cpu_time / scene.t_end,
              **peers.stack_observables(p, run)}
        mj["tip_time_error"] = abs(mj["tip_time"] - p["tip_time"]) / p["tip_time"]
        records.append(mj)
        line += f", MuJoCo {mj['wall_per_second']:.4f} s/s"
    progress(line)
    if mujoco and not config.quick:
        records += _humanoid(config, progress)
    return records


#: what the humanoid's two runs are compared on (:func:`.humanoid_peer.observables`)
HUMANOID_OBSERVABLES = {"base_y_end": "base y at the end [m]", "max_roll": "largest roll [rad]",
                        "sole_slip": "sole slip [m]",
                        "energy_rise_before_push": "energy rise before the push [J]"}


def _humanoid(config: BenchConfig, progress: Progress) -> list[dict[str, Any]]:
    """TALOS pushed (:mod:`.humanoid_peer`), when Pinocchio and example-robot-data are
    installed (the ``robots`` extra); nothing otherwise."""
    from ..model.pinocchio_robots import RobotDataUnavailableError
    from . import humanoid_peer

    try:
        recs = humanoid_peer.humanoid_records(config.repeat)
    except (ImportError, RobotDataUnavailableError) as exc:
        progress(f"sustained-scale simulate: humanoid_push skipped ({exc})")
        return []
    ours, mj = recs
    progress(f"sustained-scale simulate: humanoid_push: ours {ours['wall_per_second']:.3f} "
             f"s/s, MuJoCo {mj['wall_per_second']:.4f} s/s")
    return recs


def growth(records: list[dict[str, Any]], key: str) -> float | None:
    """Exponent p of ``key = c contacts^p`` (least squares in log-log), None below two
    sizes."""
    from .contact_scale_charts import power_law_fit

    pts = [(r["contacts"], r[key]) for r in records if r.get(key)]
    p, _ = power_law_fit([q[0] for q in pts], [q[1] for q in pts])
    return None if math.isnan(p) else p


def aggregate(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Per series: ratios ours / MuJoCo, growth exponents, worst errors."""
    out: dict[str, Any] = {}
    stops = [r for r in records if r["part"] == "stop"]
    for kind in ("rest", "slide"):
        rs = [r for r in stops if r["scene"] == f"table-{kind}"]
        out[f"stop_{kind}"] = {
            "ours_ms": {r["contacts"]: r["ours_time"] * 1e3 for r in rs},
            "enumerator_s": {r["contacts"]: r["enumerator_time"] for r in rs
                             if r["enumerator_time"]},
            "agree": all(r["agree"] is not False for r in rs),
            "ours_growth": growth(rs, "ours_time")}
    sims = [r for r in records if r["part"] == "simulation"]
    for scene in sorted({r["scene"] for r in sims}):
        ours = {r["contacts"]: r for r in sims if r["scene"] == scene
                and r["scheme"] == "event-driven"}
        mj = {r["contacts"]: r for r in sims if r["scene"] == scene and r["scheme"] == "mujoco"}
        ratio = {n: ours[n]["wall_per_second"] / mj[n]["wall_per_second"] for n in ours
                 if n in mj}
        ratio_cpu = {n: ours[n]["cpu_per_second"] / mj[n]["cpu_per_second"] for n in ours
                     if n in mj and ours[n].get("cpu_per_second")
                     and mj[n].get("cpu_per_second")}
        out[scene] = {
            "ratio_ours_over_mujoco": ratio,
            "ratio_ours_over_mujoco_cpu": ratio_cpu,
            "ours_growth": growth(list(ours.values()), "wall_per_second"),
            "mujoco_growth": growth(list(mj.values()), "wall_per_second"),
            "worst_penetration": {"ours": max(r["penetration"] for r in ours.values()),
                                  "mujoco": max((r["penetration"] for r in mj.values()),
                                                default=None)}}
        plain = {n: ours[n]["wall_per_second_plain"] / mj[n]["wall_per_second"] for n in ours
                 if n in mj and ours[n].get("wall_per_second_plain")}
        if plain:  # the box stack without the push's breakpoint
            out[scene]["ratio_without_breakpoint"] = plain
            out[scene]["ratio_without_breakpoint_cpu"] = {
                n: ours[n]["cpu_per_second_plain"] / mj[n]["cpu_per_second"] for n in plain}
        if scene == "humanoid_push":
            out[scene]["observables"] = {
                s: {k: d[8][k] for k in HUMANOID_OBSERVABLES if k in d.get(8, {})}
                for s, d in (("ours", ours), ("mujoco", mj))}
        for key in ("stop_time_error", "distance_error", "energy_lost_error",
                    "tip_time_error", "energy_drift"):
            vals = {s: max((r[key] for r in d.values() if r.get(key) is not None),
                           default=None) for s, d in (("ours", ours), ("mujoco", mj))}
            if any(v is not None for v in vals.values()):
                out[scene][f"worst_{key}"] = vals
    return out


def summary_lines(agg: dict[str, Any]) -> list[str]:
    lines = []
    for kind in ("rest", "slide"):
        a = agg[f"stop_{kind}"]
        ours = a["ours_ms"]
        enum = a["enumerator_s"]
        lines.append(
            f"one stop, table {kind}: ours {min(ours.values()):.2f}-{max(ours.values()):.2f} ms "
            f"over {min(ours)}-{max(ours)} legs (growth n^{a['ours_growth']:.2f}); enumerator "
            + ", ".join(f"{n} legs {t:.2f} s" for n, t in enum.items())
            + ("; answers agree" if a["agree"] else "; ANSWERS DIFFER"))
    for scene in ("table-rest", "table-slide", "box_stack", "humanoid_push"):
        if scene not in agg:
            continue
        a = agg[scene]
        ratio = a["ratio_ours_over_mujoco"]
        if ratio:
            lines.append(f"{scene}: ours / MuJoCo per simulated second "
                         + ", ".join(f"{n}: {r:.1f}x" for n, r in sorted(ratio.items()))
                         + (f"; growth ours n^{a['ours_growth']:.2f}, MuJoCo "
                            f"n^{a['mujoco_growth']:.2f}" if a["ours_growth"] is not None
                            and a["mujoco_growth"] is not None else ""))
            cpu = a.get("ratio_ours_over_mujoco_cpu")
            if cpu:
                lines.append("  in CPU time (the process's, robust to a loaded machine): "
                             + ", ".join(f"{n}: {r:.1f}x" for n, r in sorted(cpu.items())))
        plain = a.get("ratio_without_breakpoint")
        if plain:
            cpu = a["ratio_without_breakpoint_cpu"]
            lines.append("  (the push's onset t_push declared as a breakpoint; without it: "
                         + ", ".join(f"{n}: {r:.1f}x, CPU {cpu[n]:.1f}x"
                                     for n, r in sorted(plain.items())) + ")")
        obs = a.get("observables")
        if obs and obs.get("ours") and obs.get("mujoco"):
            lines.append("  " + "; ".join(
                f"{label}: ours {obs['ours'][k]:.2g}, MuJoCo {obs['mujoco'][k]:.2g}"
                for k, label in HUMANOID_OBSERVABLES.items()))
        for key, label in (("worst_stop_time_error", "stop time error"),
                           ("worst_distance_error", "distance error"),
                           ("worst_tip_time_error", "tip time error"),
                           ("worst_penetration", "penetration [m]")):
            v = a.get(key) if key != "worst_penetration" else a["worst_penetration"]
            if v:
                lines.append(f"  {label}: ours {v['ours']:.2g}, MuJoCo "
                             + ("-" if v.get("mujoco") is None else f"{v['mujoco']:.2g}"))
    return lines


@register_section("sustained-scale", "event-driven many-contact scenes (tables on 3-48 legs, "
                                     "a box stack, a humanoid pushed) against MuJoCo, and one "
                                     "stop's force problem "
                                     "against the mode enumerator")
def sustained_scale_section(config: BenchConfig, progress: Progress) -> SectionResult:
    from .mujoco_peers import mujoco_version
    from .sustained_scale_charts import simulation_chart, stop_chart

    version = mujoco_version()
    records = measure_stops(config, progress)
    records += measure_simulations(config, progress, version is not None)
    agg = aggregate(records)
    figures = [stop_chart(records, config.out), simulation_chart(records, config.out)]
    notes = [] if version else ["mujoco is not installed: only ours is measured"]
    meta = {"aggregates": agg, "mujoco": version, "table_span": TABLE_SPAN,
            "mujoco_settings": "defaults: timestep 2 ms, Euler, pyramidal cone, solref 0.02 1; "
                               "condim 3 with the scene's mu; table feet spheres of 5 mm",
            "time": f"ours: median of up to {config.repeat} runs per scene (at most "
                    f"{RUN_BUDGET} s of runs) after a warm-up run of another scene; MuJoCo: "
                    f"median of {config.repeat} rollouts; stops: median of up to "
                    f"{config.repeat} calls after one untimed call"}
    return SectionResult("sustained-scale", records, figures, summary_lines(agg) + notes, meta)
