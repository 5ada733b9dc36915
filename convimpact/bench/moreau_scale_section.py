"""Bench section ``moreau-scale``: Moreau–Jean from 4 to 128 contacts, every law, and on a
pile of discs, against MuJoCo in the same run at the same step h.

Scenes (:mod:`.moreau_scenes`): rows of 1 to 32 boxes on the floor (4 to 128 corner contacts;
the boxes never touch: 1 to 32 islands), sliding at 2 m/s and at rest, and the scene
``disc_pile`` (114 discs settling in a box). Ours: :func:`convimpact.simulation.moreau.
simulate_moreau` (theta = 1/2, laws ``ccp``, ``coulomb`` and ``dissipative`` (ccp's plastic
problem, scaled by 1 + e) on the engine, every step's
islands certified at the natural-map residual 1e-8, warm starts and islands on; the laws of
:data:`OTHER_LAWS` island by island through ``resolve_impact``, one call per island and step
(pereira-nikravesh: the law's impulse directly on steps without an impact, resting islands
answered by the certificate of the law's answer after the first step of their resting mode,
sliding islands by the law's search in one compiled call, warm-started, without the
dominated active sets and the sets certified to have no admissible impulse
(:mod:`convimpact.impact.laws.pn_complementarity_exclusion`), the previous step's impulse
re-certified by its KKT conditions, after the first step of their sliding mode, every island
of such a mode in one compiled call per step, :mod:`convimpact.simulation.moreau_pn_islands`;
stronge: on steps without
an impact every island's warm-started compression in one compiled call,
:mod:`convimpact.simulation.moreau_stronge`),
:mod:`convimpact.simulation.moreau_impact`); MuJoCo: its default solver and soft contact,
elliptic cones, Euler, the same h (2 ms, MuJoCo's default). ``chatterjee-ruina`` is tried on
the smallest row and its refusal reported (the law is defined per contact and refuses a box's
four dynamically coupled corners).

Measured per run (ours: the median wall time of :data:`REPEATS` runs over :data:`SPAN`; the
other laws, which cost milliseconds per island and step, over :data:`OTHER_SPAN`, of
:data:`OTHER_REPEATS` runs, or their entries in :data:`OTHER_SPANS` and
:data:`OTHER_REPEATS_BY_LAW`; MuJoCo: of 5):

* ``wall_per_simulated_second``: wall time / simulated span (ours: ``result.wall_time``,
  which includes recording the series; MuJoCo: ``mj_step`` alone);
* ``max_penetration`` (m): ours the largest -gap at a stored state, MuJoCo the largest
  -dist of its contacts at any step (its soft contacts sit at a penetration by design);
* ``energy_rise``: the largest rise of E(t) above its lowest value so far, divided by the
  energy scale (the initial kinetic energy when sliding, else the potential m g (half
  height) of a box per box; the pile: its energy drop E(0) - min E); e = 0, so any rise is
  an error (MuJoCo's E leaves out the energy stored in its soft contacts, which it gives
  back: a rise after an impact);
* sliding boxes: ``speed_error``, the final speed against Coulomb's closed form
  max(v0 - mu g t, 0) (relative to v0);
* ``max_lift`` (m): the highest any box's centre rose above its resting height (a sliding
  box lifts off under the cone complementarity laws ccp and dissipative: ``u_n = mu |u_t|``);
* ours: ``contact_solver`` (islands solved, warm starts certified, engine calls; for
  pereira-nikravesh the island steps answered by the certificate, searched, searched
  without the dominated active sets (pruned), and found with several admissible active
  sets) and the run's ``warnings``.

Fitted exponents: least squares of log(wall per simulated second) against log(contacts) over
4..128 contacts, per law and motion, ours and MuJoCo's. ``ablation``: the 32-box rows over
:data:`ABLATION_SPAN` with everything on (``"none"``), warm starts off and islands off: what
each buys.

Charts (:mod:`.moreau_scale_charts`): ``moreau_scale_growth.png`` and ``moreau_pile.png``.
"""

from __future__ import annotations

import math
import statistics
from typing import Any

import numpy as np

from ..impact.laws.pn_complementarity_impulse import compile_kernels as compile_pn_kernels
from ..scenes import load_scene
from ..simulation.moreau import simulate_moreau
from .contact_scale_charts import power_law_fit
from .moreau_scale_charts import growth_chart, pile_chart
from .moreau_scenes import (
    BOX_MASS,
    GRAVITY,
    HALF,
    MU,
    SLIDE_SPEED,
    box_row,
    box_row_mjcf,
    box_row_qvel,
    disc_pile_mjcf,
    run_mujoco,
)
from .mujoco_peers import mujoco_version
from .registry import BenchConfig, Progress, SectionResult, register_section

#: the step of both simulators (s): MuJoCo's default timestep
STEP = 2e-3
BOXES = (1, 2, 4, 8, 16, 32)
QUICK_BOXES = (1, 4)
SPAN = 0.5
QUICK_SPAN = 0.1
PILE_SPAN = 1.0
QUICK_PILE_SPAN = 0.1
QUICK_PILE = {"columns": 4, "rows": 3}
REPEATS = 5
#: span of the runs without warm starts or islands (and of their reference run)
ABLATION_SPAN = 0.2
MUJOCO_REPEATS = 5
LAWS = ("ccp", "coulomb", "dissipative")
#: the laws solved through resolve_impact island by island (not on the contact engine)
OTHER_LAWS = ("pereira-nikravesh", "stronge")
#: their span and repeats (s; they cost milliseconds per island and step)
OTHER_SPAN = 0.04
QUICK_OTHER_SPAN = 0.02
OTHER_REPEATS = 1
#: ... except where a law is cheap enough for a longer span and a median (quick runs: 1 run):
#: pereira-nikravesh sliding over the engine laws' and MuJoCo's span (its sliding islands
#: pruned by certificates, :mod:`convimpact.impact.laws.pn_complementarity_exclusion`)
OTHER_SPANS = {"pereira-nikravesh": SPAN, "stronge": 0.2}
#: ... and at rest, where pereira-nikravesh's resting islands take the certificate and
#: stronge's the warm-started compression in one compiled call (the engine laws' span: the
#: first step's search of each island counted over as many steps)
OTHER_REST_SPANS = {"pereira-nikravesh": SPAN, "stronge": SPAN}
OTHER_REPEATS_BY_LAW = {"pereira-nikravesh": 3, "stronge": 3}
#: steps of the untimed warm-up run of each of those laws
WARM_STEPS = 25
#: the pile's law and certificate tolerance (see the summary)
PILE_LAW = "coulomb"


def _energy_rise(E: np.ndarray, scale: float) -> float:
    """The largest rise of E above its lowest value so far, over ``scale``."""
    return float(max(0.0, np.max(E - np.minimum.accumulate(E))) / scale)


def _box_record(n: int, sliding: bool, law: str, span: float, progress: Progress,
                repeats: int | None = None, **options) -> dict[str, Any]:
    mech, q, v = box_row(n, sliding)
    walls, res = [], None
    for _ in range(REPEATS if repeats is None else repeats):
        res = simulate_moreau(mech, (0.0, span), (q, v), h=STEP, law=law, **options)
        walls.append(res.wall_time)
    E = res.total_energy
    scale = (0.5 * BOX_MASS * SLIDE_SPEED ** 2 if sliding else BOX_MASS * GRAVITY * HALF[2]) * n
    rec = {"simulator": "moreau-jean", "law": law, "boxes": n, "contacts": 4 * n,
           "motion": "sliding" if sliding else "rest", "span": span,
           "wall_per_simulated_second": statistics.median(walls) / span,
           "walls": walls, "max_penetration": res.max_penetration,
           "energy_rise": _energy_rise(E, scale), "contact_solver": res.contact_solver,
           "max_lift": float(np.max(np.asarray(res.theta)[:, 2::6]) - HALF[2]),
           "max_active_contacts": res.max_active_contacts, "warnings": list(res.warnings),
           **options}
    if sliding:
        exact = max(SLIDE_SPEED - MU * GRAVITY * span, 0.0)
        rec["speed_error"] = float(np.max(np.abs(res.dtheta[-1][0::6] - exact)) / SLIDE_SPEED)
    progress(f"moreau-scale {law} {rec['motion']} {4 * n} contacts {options or ''}: "
             f"{rec['wall_per_simulated_second']:.3g} s per simulated s")
    return rec


def _mujoco_box_record(n: int, sliding: bool, span: float) -> dict[str, Any]:
    xml = box_row_mjcf(n, STEP)
    runs = [run_mujoco(xml, span, box_row_qvel(n, sliding)) for _ in range(MUJOCO_REPEATS)]
    r = runs[0]
    scale = (0.5 * BOX_MASS * SLIDE_SPEED ** 2 if sliding else BOX_MASS * GRAVITY * HALF[2]) * n
    rec = {"simulator": "mujoco", "law": "mujoco", "boxes": n, "contacts": 4 * n,
           "motion": "sliding" if sliding else "rest", "span": span,
           "wall_per_simulated_second": statistics.median(x.wall for x in runs) / span,
           "walls": [x.wall for x in runs], "max_penetration": r.max_penetration,
           "energy_rise": _energy_rise(r.energy, scale), "max_contacts": r.max_contacts}
    if sliding:
        exact = max(SLIDE_SPEED - MU * GRAVITY * span, 0.0)
        rec["speed_error"] = float(np.max(np.abs(r.final_qvel[0::6] - exact)) / SLIDE_SPEED)
    return rec


def _pile(span: float, progress: Progress, quick: bool = False
          ) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The disc pile (quick: a 4 x 3 one), ours (law ``ccp`` at 1e-8 and the scene's
    declared law and tolerance) and MuJoCo's; returns the records and the chart's series."""
    import importlib

    scene = load_scene("disc_pile", **(QUICK_PILE if quick else {}))
    pile = importlib.import_module("convimpact.problems.disc_pile")
    sim = dict(scene.simulation)
    p = scene.parameters
    radii = np.asarray(p["radii"])
    centres, _ = pile.layout(p["columns"], p["rows"], p["seed"])
    pairs = pile.neighbour_pairs(centres, radii)
    records, series = [], {"ours": {}}
    for law, opts in (("ccp", {"tol": 1e-8}),
                      (sim["law"], dict(sim.get("impact_options", {})))):
        res = simulate_moreau(scene, (0.0, span), h=sim["h"], law=law, impact_options=opts)
        E = res.total_energy
        drop = max(float(E[0] - E.min()), 1e-300)
        rec = {"simulator": "moreau-jean", "law": law, "scene": "disc_pile",
               "contacts": res.max_active_contacts, "span": span,
               "wall_per_simulated_second": res.wall_time / span,
               "max_penetration": res.max_penetration, "energy_rise": _energy_rise(E, drop),
               "energy_drop": drop, "final_kinetic_energy": float(res.kinetic_energy[-1]),
               "unlisted_overlap": pile.unlisted_overlap(res.theta[::25], radii, pairs),
               "contact_solver": res.contact_solver, "tol": opts.get("tol", 1e-8)}
        records.append(rec)
        series["ours"][law] = (np.asarray(res.t), E - E[0],
                               np.asarray(res.theta[-1]).reshape(-1, 3)[:, :2])
        progress(f"moreau-scale pile ours ({law}): {rec['wall_per_simulated_second']:.3g} s "
                 f"per simulated s, {rec['contacts']} contacts")
    runs = [run_mujoco(disc_pile_mjcf(scene, sim["h"]), span) for _ in range(3)]
    r = runs[0]
    Em = r.energy
    dropm = max(float(Em[0] - Em.min()), 1e-300)
    masses = np.asarray(p["masses"])
    ke_m = float(0.5 * np.sum(masses * (r.final_qvel[0::3] ** 2 + r.final_qvel[1::3] ** 2))
                 + 0.5 * np.sum(0.5 * masses * radii ** 2 * r.final_qvel[2::3] ** 2))
    records.append({"simulator": "mujoco", "law": "mujoco", "scene": "disc_pile",
                    "contacts": r.max_contacts, "span": span,
                    "wall_per_simulated_second": statistics.median(x.wall for x in runs) / span,
                    "max_penetration": r.max_penetration,
                    "energy_rise": _energy_rise(Em, dropm), "energy_drop": dropm,
                    "final_kinetic_energy": ke_m})
    progress(f"moreau-scale pile MuJoCo: {records[-1]['wall_per_simulated_second']:.3g} s per "
             f"simulated s, {records[-1]['contacts']} contacts")
    series.update(mujoco=(np.arange(Em.size) * sim["h"], Em - Em[0],
                          np.column_stack([centres[:, 0] + r.final_qpos[0::3],
                                           centres[:, 1] + r.final_qpos[1::3]])),
                  radii=radii, width=float(p["box_width"]), h=sim["h"])
    return records, series


def _chatterjee_ruina(n: int, span: float) -> str | None:
    """None if law chatterjee-ruina runs on the row of n boxes at rest, else why it refuses."""
    from ..errors import ConvImpactError

    mech, q, v = box_row(n, False)
    try:
        simulate_moreau(mech, (0.0, span), (q, v), h=STEP, law="chatterjee-ruina")
    except ConvImpactError as exc:
        return f"{type(exc).__name__}: {str(exc).split(';')[0]}"
    return None


def _exponents(records: list[dict[str, Any]]) -> dict[str, Any]:
    out = {}
    for sim_law in sorted({(r["simulator"], r["law"]) for r in records}):
        for motion in ("sliding", "rest"):
            pts = sorted((r["contacts"], r["wall_per_simulated_second"]) for r in records
                         if (r["simulator"], r["law"]) == sim_law and r.get("motion") == motion
                         and not r.get("ablation"))
            if len(pts) >= 2:
                p, c = power_law_fit(*zip(*pts))
                out[f"{sim_law[1]}/{motion}"] = {"exponent": p, "coefficient": c}
    return out


def _ratio_table(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per contacts, motion and law: ours, MuJoCo's, and ours / MuJoCo."""
    mj = {(r["contacts"], r["motion"]): r["wall_per_simulated_second"] for r in records
          if r["simulator"] == "mujoco" and "motion" in r}
    rows = []
    for r in records:
        if r["simulator"] != "moreau-jean" or "motion" not in r or r.get("ablation"):
            continue
        theirs = mj.get((r["contacts"], r["motion"]))
        rows.append({"contacts": r["contacts"], "motion": r["motion"], "law": r["law"],
                     "ours": r["wall_per_simulated_second"], "mujoco": theirs,
                     "ratio": (r["wall_per_simulated_second"] / theirs) if theirs else None})
    return sorted(rows, key=lambda x: (x["law"], x["motion"], x["contacts"]))


@register_section("moreau-scale", "Moreau–Jean from 4 to 128 contacts (laws ccp, coulomb, "
                                  "dissipative on the contact engine; pereira-nikravesh, "
                                  "stronge island by island) and on a pile of 114 discs, "
                                  "against MuJoCo at the same step")
def moreau_scale_section(config: BenchConfig, progress: Progress) -> SectionResult:
    if mujoco_version() is None:
        return SectionResult("moreau-scale", [], summary=[
            "moreau-scale: MuJoCo is not installed (pip install mujoco); section skipped"])
    import os

    load_start = os.getloadavg()
    quick = config.quick
    boxes = QUICK_BOXES if quick else BOXES
    span = QUICK_SPAN if quick else SPAN
    other_span = QUICK_OTHER_SPAN if quick else OTHER_SPAN
    spans = {(law, sliding): other_span if quick else (
        OTHER_SPANS.get(law, other_span) if sliding else
        OTHER_REST_SPANS.get(law, OTHER_SPANS.get(law, other_span)))
        for law in OTHER_LAWS for sliding in (True, False)}
    repeats = {law: 1 if quick else OTHER_REPEATS_BY_LAW.get(law, OTHER_REPEATS)
               for law in OTHER_LAWS}
    records: list[dict[str, Any]] = []
    # the other laws are timed in few runs: load their compiled kernels first (untimed)
    compile_pn_kernels()
    for law in OTHER_LAWS:
        for sliding in (True, False):
            mech, q, v = box_row(1, sliding)
            simulate_moreau(mech, (0.0, WARM_STEPS * STEP), (q, v), h=STEP, law=law)
    for sliding in (True, False):
        for n in boxes:
            records.append(_mujoco_box_record(n, sliding, span))
            for law in LAWS:
                records.append(_box_record(n, sliding, law, span, progress))
            for law in OTHER_LAWS:
                records.append(_box_record(n, sliding, law, spans[law, sliding], progress,
                                           repeats=repeats[law]))
    refused = _chatterjee_ruina(boxes[0], other_span)
    # what warm starts and islands buy: the largest row without each
    n_big = boxes[-1]
    for sliding in (True, False):
        for law in LAWS:
            for opts in ({}, {"warm_start": False}, {"islands": False}):
                rec = _box_record(n_big, sliding, law, min(span, ABLATION_SPAN), progress,
                                  **opts)
                rec["ablation"] = next(iter(opts), "none")
                records.append(rec)
    pile_records, series = _pile(QUICK_PILE_SPAN if quick else PILE_SPAN, progress, quick)
    records += pile_records
    exps = _exponents(records)
    table = _ratio_table(records)
    figures = [growth_chart(records, exps, config.out, STEP),
               pile_chart(series, pile_records, config.out)]
    summary = []
    for laws, what in ((LAWS, "on the engine (islands, warm starts)"),
                       (OTHER_LAWS, "island by island through resolve_impact (pereira-nikravesh: "
                                    "the law's impulse directly on steps without an impact, "
                                    "resting islands by the certificate of its answer, "
                                    "sliding islands by its compiled search, pruned of the "
                                    "dominated active sets and of those certified to have no "
                                    "admissible impulse, the previous impulse re-certified, "
                                    "every island of such a mode in "
                                    "one compiled call per step; stronge: every island's "
                                    "warm-started compression in one compiled call on steps "
                                    "without an impact)")):
        ratios = [t["ratio"] for t in table if t["ratio"] and t["law"] in laws]
        summary.append(
            f"moreau-scale: Moreau–Jean {what}, laws {', '.join(laws)}, against MuJoCo at "
            f"h = {STEP:g} s from {4 * boxes[0]} to {4 * boxes[-1]} contacts: ours / MuJoCo "
            f"per simulated second {min(ratios, default=math.nan):.3g}x to "
            f"{max(ratios, default=math.nan):.3g}x (target <= 10x); exponents " + ", ".join(
                f"{k} {v['exponent']:.2f}" for k, v in exps.items()
                if k.split("/")[0] in laws) + " (target <= 1.3)")
    summary.append("  MuJoCo's exponents " + ", ".join(
        f"{k.split('/')[1]} {v['exponent']:.2f}" for k, v in exps.items()
        if k.startswith("mujoco/")) + "; " + ", ".join(
            f"{law} timed over {spans[law, True]:g} s sliding, {spans[law, False]:g} s at "
            f"rest (median of {repeats[law]})" for law in OTHER_LAWS)
        + f", {', '.join(LAWS)} over {span:g} s (median "
        f"of {REPEATS})")
    if refused:
        summary.append(f"  chatterjee-ruina on {4 * boxes[0]} contacts at rest refuses: {refused}")
    lifted = sorted({(r["law"], r["motion"]) for r in records
                     if r["simulator"] == "moreau-jean" and r.get("max_lift", 0.0) > 1e-3})
    if lifted:
        summary.append("  boxes that lift off the floor (max lift > 1 mm; a cone "
                       "complementarity's u_n = mu |u_t|): " + ", ".join(
                           f"{law} {motion} ({max(r['max_lift'] for r in records if r.get('law') == law and r.get('motion') == motion and 'max_lift' in r):.2g} m)"
                           for law, motion in lifted))
    for t in table:
        if t["contacts"] == 4 * boxes[-1] or t["contacts"] == 4 * boxes[0]:
            summary.append(f"  {t['law']} {t['motion']} {t['contacts']} contacts: "
                           f"{t['ours']:.3g} s vs MuJoCo {t['mujoco']:.3g} s per simulated s "
                           f"({t['ratio']:.3g}x)")
    for r in records:
        if r.get("ablation") not in (None, "none"):
            base = next(x for x in records if x.get("ablation") == "none"
                        and x["motion"] == r["motion"] and x["law"] == r["law"])
            ratio = r["wall_per_simulated_second"] / base["wall_per_simulated_second"]
            summary.append(f"  {r['law']} {r['motion']} {r['contacts']} contacts without "
                           f"{r['ablation'].replace('_', ' ')}: {ratio:.3g}x the time with "
                           f"it ({r['wall_per_simulated_second']:.3g} vs "
                           f"{base['wall_per_simulated_second']:.3g} s per simulated s)")
    pm = pile_records[-1]
    for po in pile_records[:-1]:
        summary.append(
            f"  disc pile, law {po['law']} (certified at {po['tol']:g}; {po['contacts']} "
            f"contacts at most, MuJoCo {pm['contacts']}): ours "
            f"{po['wall_per_simulated_second']:.3g} s vs MuJoCo "
            f"{pm['wall_per_simulated_second']:.3g} s per simulated s "
            f"({po['wall_per_simulated_second'] / pm['wall_per_simulated_second']:.3g}x); "
            f"penetration {po['max_penetration']:.2e} vs {pm['max_penetration']:.2e} m; "
            f"energy rise {po['energy_rise']:.2e} vs {pm['energy_rise']:.2e} of the settling "
            f"drop; final kinetic energy {po['final_kinetic_energy']:.2e} vs "
            f"{pm['final_kinetic_energy']:.2e} J; unlisted overlap {po['unlisted_overlap']:.1e} m")
    load = {"start": list(load_start), "end": list(os.getloadavg())}
    summary.append(f"  machine load (1, 5, 15 min) at the start {load_start[0]:.1f}, "
                   f"{load_start[1]:.1f}, {load_start[2]:.1f}; at the end "
                   f"{load['end'][0]:.1f}, {load['end'][1]:.1f}, {load['end'][2]:.1f} "
                   "(2 cores, shared: medians)")
    meta = {"step": STEP, "span": span, "other_span": other_span, "load_average": load,
            "boxes": list(boxes), "laws": list(LAWS), "other_laws": list(OTHER_LAWS),
            "other_repeats": OTHER_REPEATS, "other_spans": {
                f"{law}/{'sliding' if sl else 'rest'}": v for (law, sl), v in spans.items()},
            "other_repeats_by_law": repeats,
            "chatterjee_ruina_refused": refused,
            "repeats": REPEATS, "mujoco_repeats": MUJOCO_REPEATS, "mujoco": mujoco_version(),
            "exponents": exps, "table": table}
    return SectionResult("moreau-scale", records, figures, summary, meta)
