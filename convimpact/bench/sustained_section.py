"""Section ``sustained``: event-driven and Moreau–Jean on the sustained-contact scenes, h -> 0.

The two schemes should converge to each other on every scene with sustained frictional
contact. Scenes (each over a span that holds its transition):

* ``spinning_ball`` planar and ``spatial=True``: slides, rolls from ~0.291 s, over [0, 0.5]
  (spatial [0, 0.4]);
* ``sliding_box``: slides on two corners, stops at ~1.019 s, over [0, 1.2];
* ``incline_box`` with mu = 0.5 (slides from rest) and the default mu = 0.7 (holds), [0, 0.5];
* ``rocking_block``: pivots on a corner, lands at ~0.351 s, over [0, 0.6];
* ``rimless_wheel``: foot strikes at ~0.483 s and ~1.345 s, over [0, 1.6] ([0, 0.8] quick);
* ``painleve_rod`` with mu = 0.5 (below the paradox: the foot slides), over [0, 0.4].

Runs (the impact law "coulomb" throughout; held contacts carry Coulomb friction in both):

* reference: event-driven :func:`convimpact.simulation.simulate` (DOP853) with
  ``rtol = 1e-11, atol = 1e-13``;
* event-driven at ``rtol`` in (1e-6, 1e-8, 1e-10) (quick: 1e-6, 1e-8), ``atol = 1e-2 rtol``;
* Moreau–Jean :func:`convimpact.simulation.moreau.simulate_moreau` (theta = 1/2) at h in
  (1e-2, 4e-3, 2e-3, 1e-3, 5e-4) (quick: 4e-3, 1e-3).

Measured per run:

* ``final_state_error``: ``|y(t1) - y_ref(t1)| / |y_ref(t1)|``, ``y = (theta, theta_dot)``
  (as in the ``simulation`` section), against the reference;
* ``closed_form``: each observable of the scene that has a closed form, its value, the exact
  value and the error (relative, or absolute in m where the exact value is 0, flagged
  ``relative: False``); ``observable_error`` is the first one's, the scene's transition where
  it has one. Observables: the ball's roll time (``parameters["roll_time"]``) and final speed
  (planar x_dot(t1), spatial |v(t1)|; ``final_speed``); the box's stop time and stop distance
  x(t1) - x0 (``stop_time``, ``stop_distance``); the incline box's distance down the slope at
  t1 (1/2 a t1^2, a = ``acceleration_from_rest``; 0 when it holds: absolute error); the
  block's first landing time (Housner, exact, by quadrature, see
  :func:`~convimpact.bench.sustained_references.housner_first_landing_time`); the wheel's
  first strike time (quadrature,
  :func:`~convimpact.bench.sustained_references.wheel_first_strike_time`) and its angular
  velocity just before that strike (``omega_minus_first``). The rod has none. Event-driven
  times are its located events (start of the contact's first ``stick`` interval; the first
  impact of the striking contact, the block's lifted corner or the wheel's next foot).
  Moreau–Jean's are on its grid: the first sample whose slip speed is at most
  :data:`STICK_TOL` times the initial one (and, as ``*_extrapolated``, the zero of its slip
  speed extrapolated linearly from the last two slipping samples: the event-driven value is
  its event again); the midpoint of the first impact step of the striking contact (impulses
  on the pivot or stance foot, which Moreau–Jean also gives, are skipped), whose pre-impact
  velocity is v_k at the start of that step. Grid times are O(h) by construction, and their
  observed "order" is quantized by where the grid falls (two steps can give the same first
  grid point after the event);
* ``energy_error``: ``|E(t1) - E_ref(t1)|`` divided by the reference's largest kinetic energy
  (by its largest |E| when it never moves: the box holding on the incline);
* ``wall_time``: ``result.wall_time`` (best of up to 3 runs, 2 quick; runs over
  0.5 s are not repeated).

The reference's own closed-form errors are in ``meta["references"]``. Per scene,
``meta["aggregates"]`` holds Moreau–Jean's error at the smallest h; its observed order, the
least-squares slope of log error against log h over the last 3 steps (2 quick; None when the
errors are at round-off, below :data:`ROUNDOFF`), and the slope between the two smallest steps
(below :data:`STALL_ORDER` the summary says the error hardly falls, or rises); and the
wall-time ratio Moreau–Jean / event-driven at equal final-state error: Moreau–Jean's most
accurate run against the event-driven time interpolated (log-log) at that error between the
event-driven runs that bracket it, or, when every event-driven run is at least as accurate,
against the cheapest one (errors below ROUNDOFF count as equal).

Painleve's paradox, ``painleve_rod`` at its default mu = 1.5, is not compared: the
event-driven run stops at t = 0 with status 2 (the contact force problem is inconsistent);
``meta["painleve_paradox"]`` records that stop and, for every h, whether Moreau–Jean completes
the span, its energy at the start and the end (and the largest), its impact steps and its
penetration.

Charts (:mod:`~convimpact.bench.sustained_charts`): ``sustained_work_precision.png`` (one
log-log panel per scene: final-state error, solid, and closed-form error, dashed hollow,
against wall time; event-driven and Moreau–Jean in their own markers, labels rtol and h) and
``sustained_convergence.png`` (Moreau–Jean's final-state and closed-form errors against h for
all scenes, with slope-1 and slope-2 guides). The closed forms are in
:mod:`~convimpact.bench.sustained_references`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import ConvImpactError
from ..scenes import load_scene
from ..simulation import simulate
from ..simulation.moreau import simulate_moreau
from .registry import BenchConfig, Progress, SectionResult, register_section
from .simulation_section import best_of
from .sustained_charts import convergence_chart, work_precision_chart
from .sustained_references import ROUNDOFF, STICK_TOL, closed_form_errors, observables

LAW = "coulomb"
REF_RTOL, REF_ATOL = 1e-11, 1e-13
#: a final-state order below this between the two smallest steps is reported as a stall
STALL_ORDER = 0.5


def rtols(quick: bool) -> tuple[float, ...]:
    return (1e-6, 1e-8) if quick else (1e-6, 1e-8, 1e-10)


def steps(quick: bool) -> tuple[float, ...]:
    return (4e-3, 1e-3) if quick else (1e-2, 4e-3, 2e-3, 1e-3, 5e-4)


# -- scenes -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Case:
    key: str
    label: str
    name: str
    params: Mapping[str, Any]
    span: tuple[float, float]
    quick_span: tuple[float, float] | None = None

    def span_for(self, quick: bool) -> tuple[float, float]:
        return self.quick_span if (quick and self.quick_span) else self.span


CASES = (
    Case("ball", "ball (planar)", "spinning_ball", {}, (0.0, 0.5)),
    Case("ball-3d", "ball (spatial)", "spinning_ball", {"spatial": True}, (0.0, 0.4)),
    Case("sliding-box", "sliding box", "sliding_box", {}, (0.0, 1.2)),
    Case("incline-slides", "incline box mu=0.5 (slides)", "incline_box", {"mu": 0.5},
         (0.0, 0.5)),
    Case("incline-holds", "incline box mu=0.7 (holds)", "incline_box", {}, (0.0, 0.5)),
    Case("rocking-block", "rocking block", "rocking_block", {}, (0.0, 0.6)),
    Case("rimless-wheel", "rimless wheel", "rimless_wheel", {}, (0.0, 1.6), (0.0, 0.8)),
    Case("painleve-rod", "Painleve rod mu=0.5", "painleve_rod", {"mu": 0.5}, (0.0, 0.4)),
)
#: the extra, uncompared case: Painleve's rod at its default mu = 1.5
PARADOX = "painleve-paradox"
PARADOX_SPAN = (0.0, 0.3)


def scene_keys() -> list[str]:
    """Keys accepted by :func:`run_sustained`'s ``scenes``."""
    return [c.key for c in CASES] + [PARADOX]


# -- measurements -------------------------------------------------------------------------------
def _final_state(res) -> np.ndarray:
    return np.concatenate([res.theta[-1], res.dtheta[-1]])


def _run(scheme: str, scene, span, opts: dict[str, Any]):
    if scheme == "event-driven":
        return simulate(scene, span, **opts)
    return simulate_moreau(scene, span, **opts)


def _reference_events(ref) -> dict[str, Any]:
    return {"impact_times": [float(i.time) for i in ref.impacts],
            "mode_switches": [{"contact": iv.contact, "mode": iv.mode, "t": float(iv.t_start)}
                              for iv in ref.mode_intervals if iv.t_start > 0]}


def _order(rows: list[dict[str, Any]], key: str, n_last: int) -> float | None:
    """Slope of log(error) against log(h) over the n_last smallest steps (errors above
    ROUNDOFF only); None with fewer than 2 such points."""
    pts = [(r["options"]["h"], r[key]) for r in rows
           if r.get(key) is not None and r[key] > ROUNDOFF]
    pts = sorted(pts)[:n_last]
    if len(pts) < 2:
        return None
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def equal_error_ratio(mj: list[dict[str, Any]], ed: list[dict[str, Any]],
                      key: str = "final_state_error") -> dict[str, Any] | None:
    """Moreau–Jean's most accurate run against the event-driven cost at its error.

    Errors below :data:`ROUNDOFF` count as equal (round-off), so among Moreau–Jean runs all at
    round-off the cheapest is taken. Returns {mj_setting, mj_error, mj_wall_time, ed_setting,
    ed_error, ed_wall_time, ratio, how}: ``how`` is "interpolated" (the event-driven wall time
    interpolated log-log at Moreau–Jean's error between the two event-driven runs that bracket
    it), "cheapest" (every event-driven run is at least as accurate: its cheapest one) or None
    when no event-driven run reaches the error (ratio None).
    """
    def err(r):
        return max(r[key], ROUNDOFF)

    mj = [r for r in mj if r.get(key) is not None and r.get("wall_time")]
    ed = sorted((r for r in ed if r.get(key) is not None and r.get("wall_time")),
                key=lambda r: r["wall_time"])
    if not mj or not ed:
        return None
    best = min(mj, key=lambda r: (err(r), r["wall_time"]))
    target = err(best)
    out = {"mj_setting": best["setting"], "mj_error": best[key],
           "mj_wall_time": best["wall_time"], "ed_setting": None, "ed_error": None,
           "ed_wall_time": None, "ratio": None, "how": None,
           "roundoff": bool(target <= ROUNDOFF)}
    ok = [r for r in ed if err(r) <= target]
    if not ok:
        return out
    if ok[0] is ed[0]:
        out.update(ed_setting=ed[0]["setting"], ed_error=ed[0][key],
                   ed_wall_time=ed[0]["wall_time"], how="cheapest")
    else:
        hi = ok[0]
        lo = max((r for r in ed if r["wall_time"] <= hi["wall_time"] and err(r) > target),
                 key=lambda r: r["wall_time"])
        le = np.log([err(lo), err(hi)])
        f = (math.log(target) - le[0]) / (le[1] - le[0])
        lx = np.log([lo["wall_time"], hi["wall_time"]])
        out.update(ed_setting=f"{lo['setting']}..{hi['setting']}", ed_error=best[key],
                   ed_wall_time=float(np.exp(lx[0] + min(max(f, 0.0), 1.0) * (lx[1] - lx[0]))),
                   how="interpolated")
    out["ratio"] = best["wall_time"] / out["ed_wall_time"]
    return out


def _measure_case(case: Case, config: BenchConfig, progress: Progress, n_rep: int):
    scene = load_scene(case.name, **case.params)
    span = case.span_for(config.quick)
    obs = observables(case.key, scene, span)
    ref = simulate(scene, span, law=LAW, rtol=REF_RTOL, atol=REF_ATOL)
    y_ref = _final_state(ref)
    t_max, e_max = float(np.max(ref.kinetic_energy)), float(np.max(np.abs(ref.total_energy)))
    scale_e = t_max if t_max > 1e-12 * e_max else max(e_max, 1e-300)  # at rest: |E|
    ref_cf = closed_form_errors(ref, "event-driven", obs)
    ref_meta = {"scene": case.name, "params": dict(case.params), "span": list(span),
                "rtol": REF_RTOL, "atol": REF_ATOL, "law": LAW, "status": ref.status,
                "wall_time": ref.wall_time, "closed_form": ref_cf, **_reference_events(ref)}
    progress(f"sustained {case.label}: reference status {ref.status}, {ref.wall_time:.2f}s, "
             + (", ".join(f"{k} error {v['error']:.1e}" for k, v in ref_cf.items())
                or "no closed form"))
    records = []
    runs = [("event-driven", f"rtol={r:.0e}", {"rtol": r, "atol": 1e-2 * r, "law": LAW})
            for r in rtols(config.quick)]
    runs += [("moreau-jean", f"h={h:g}", {"h": h, "law": LAW}) for h in steps(config.quick)]
    for scheme, setting, opts in runs:
        rec: dict[str, Any] = {"scene": case.key, "label": case.label, "scheme": scheme,
                               "setting": setting, "options": dict(opts), "span": list(span)}
        try:
            res = best_of(lambda: _run(scheme, scene, span, opts), n_rep)
        except ConvImpactError as exc:
            rec.update(wall_time=None, status=None, final_state_error=None,
                       observable_error=None, error=f"{type(exc).__name__}: {exc}"[:300])
            records.append(rec)
            progress(f"sustained {case.label} {scheme} {setting}: {type(exc).__name__}")
            continue
        done = res.status == 0
        cf = closed_form_errors(res, scheme, obs)
        y = _final_state(res)
        rec.update(
            status=res.status, wall_time=res.wall_time, n_steps=res.n_steps, nfev=res.nfev,
            n_impacts=len(res.impacts), error=None if done else res.message[:300],
            final_state_error=(float(np.linalg.norm(y - y_ref) / max(np.linalg.norm(y_ref),
                                                                     1e-300)) if done else None),
            energy_error=(float(abs(res.total_energy[-1] - ref.total_energy[-1]) / scale_e)
                          if done else None),
            closed_form=cf, observable_error=cf[obs[0].name]["error"] if obs else None,
            max_penetration=getattr(res, "max_penetration", 0.0))
        records.append(rec)
        obs_text = f", {obs[0].name} error {rec['observable_error']:.1e}" if obs else ""
        progress(f"sustained {case.label} {scheme} {setting}: {res.wall_time:.3f}s, final state "
                 f"error {rec['final_state_error'] if done else float('nan'):.1e}{obs_text}")
    return records, ref_meta


def _paradox(config: BenchConfig, progress: Progress) -> dict[str, Any]:
    """Painleve's rod at mu = 1.5: the event-driven stop, and what Moreau–Jean does there."""
    scene = load_scene("painleve_rod")
    p = scene.parameters
    ed = simulate(scene, PARADOX_SPAN, law=LAW, rtol=1e-8, atol=1e-10)
    out: dict[str, Any] = {
        "scene": "painleve_rod", "params": {"mu": p["mu"]}, "span": list(PARADOX_SPAN),
        "painleve_A": p["painleve_A"], "regime": p["regime"],
        "mu_critical_at_angle": p["mu_critical_at_angle"],
        "event_driven": {"status": ed.status, "message": ed.message, "t_stop": float(ed.t[-1]),
                         "painleve": [ev.as_dict() for ev in ed.painleve],
                         "warnings": list(ed.warnings)},
        "moreau_jean": []}
    progress(f"sustained Painleve rod mu={p['mu']}: event-driven status {ed.status} at "
             f"t = {ed.t[-1]:g}")
    for h in steps(config.quick):
        row: dict[str, Any] = {"h": h}
        try:
            m = simulate_moreau(scene, PARADOX_SPAN, h=h, law=LAW)
        except ConvImpactError as exc:
            row.update(completed=False, error=f"{type(exc).__name__}: {exc}"[:300])
        else:
            E = m.total_energy
            row.update(status=m.status, message=m.message,
                       completed=bool(m.status == 0 and m.t[-1] >= PARADOX_SPAN[1] - 1e-12),
                       t_end=float(m.t[-1]), energy_start=float(E[0]), energy_end=float(E[-1]),
                       energy_max=float(np.max(E)),
                       energy_rise=float(np.max(E) - E[0]),
                       n_impact_steps=len(m.impacts), n_contact_steps=m.n_contact_steps,
                       first_impact_time=float(m.impacts[0].time) if m.impacts else None,
                       max_penetration=m.max_penetration, wall_time=m.wall_time,
                       final_state=_final_state(m).tolist())
        out["moreau_jean"].append(row)
        progress(f"sustained Painleve rod mu={p['mu']} moreau-jean h={h:g}: "
                 + (f"completed {row['completed']}, energy {row['energy_start']:.4f} -> "
                    f"{row['energy_end']:.4f} J" if "energy_end" in row else row["error"]))
    return out


# -- summary ------------------------------------------------------------------------------------
def _aggregate(key: str, records: list[dict[str, Any]], quick: bool) -> dict[str, Any]:
    rows = [r for r in records if r["scene"] == key]
    mj = sorted((r for r in rows if r["scheme"] == "moreau-jean"),
                key=lambda r: -r["options"]["h"])
    ed = [r for r in rows if r["scheme"] == "event-driven"]
    n_last = 2 if quick else 3
    small = mj[-1] if mj else None
    return {
        "mj_h": [r["options"]["h"] for r in mj],
        "mj_final_state_error": [r.get("final_state_error") for r in mj],
        "mj_observable_error": [r.get("observable_error") for r in mj],
        "mj_wall_time": [r.get("wall_time") for r in mj],
        "ed_rtol": [r["options"]["rtol"] for r in ed],
        "ed_final_state_error": [r.get("final_state_error") for r in ed],
        "ed_observable_error": [r.get("observable_error") for r in ed],
        "ed_wall_time": [r.get("wall_time") for r in ed],
        "smallest_h": small["options"]["h"] if small else None,
        "mj_error_at_smallest_h": small.get("final_state_error") if small else None,
        "mj_observable_error_at_smallest_h": small.get("observable_error") if small else None,
        "mj_closed_form_at_smallest_h": ({k: v["error"] for k, v in
                                          (small.get("closed_form") or {}).items()}
                                         if small else {}),
        "order_final_state": _order(mj, "final_state_error", n_last),
        "order_observable": _order(mj, "observable_error", n_last),
        "order_points": n_last,
        "order_last_pair": _order(mj, "final_state_error", 2),
        "equal_error": equal_error_ratio(mj, ed),
    }


def _fmt_order(p: float | None) -> str:
    return "at round-off" if p is None else f"{p:.2f}"


def _sentence(label: str, agg: dict[str, Any], ref: dict[str, Any]) -> str:
    cf = ref["closed_form"]
    ref_text = ("reference vs closed form " + ", ".join(
        f"{k} {v['error']:.1e}" for k, v in cf.items())) if cf else "no closed form"
    hs = agg["mj_h"]
    n = agg["order_points"]
    obs_name = next(iter(cf), None)
    text = (f"{label} (t1 = {ref['span'][1]:g} s; {ref_text}): Moreau–Jean at h = "
            f"{agg['smallest_h']:g} final-state error {agg['mj_error_at_smallest_h']:.2g}")
    if obs_name:
        text += ", closed-form errors " + ", ".join(
            f"{k} {v:.2g}" for k, v in agg["mj_closed_form_at_smallest_h"].items())
    n = min(n, len(hs))
    text += (f"; observed order over h = {hs[-n]:g}..{hs[-1]:g}: "
             f"{_fmt_order(agg['order_final_state'])} (final state")
    last = agg["order_last_pair"]
    if n > 2 and last is not None:
        text += f"; {last:.2f} between the last two h"
    if last is not None and last < 0:
        text += ": the error rises"
    elif last is not None and last < STALL_ORDER:
        text += ": the error hardly falls"
    text += ")"
    if obs_name:
        text += f", {_fmt_order(agg['order_observable'])} ({obs_name})"
    eq = agg["equal_error"]
    if eq and eq["ratio"] is not None and eq["roundoff"]:
        text += (f"; both schemes exact to round-off (constant forces between switches): "
                 f"Moreau–Jean's cheapest ({eq['mj_setting']}, {eq['mj_error']:.2g}) "
                 f"{eq['mj_wall_time']:.3g} s, event-driven's cheapest ({eq['ed_setting']}, "
                 f"{eq['ed_error']:.2g}) {eq['ed_wall_time']:.3g} s: ratio MJ/ED "
                 f"{eq['ratio']:.3g}")
    elif eq and eq["ratio"] is not None:
        if eq["how"] == "cheapest":
            text += (f"; even the cheapest event-driven run ({eq['ed_setting']}, error "
                     f"{eq['ed_error']:.2g}, {eq['ed_wall_time']:.3g} s) is at least as "
                     f"accurate as Moreau–Jean's best ({eq['mj_setting']}, {eq['mj_error']:.2g}, "
                     f"{eq['mj_wall_time']:.3g} s): wall-time ratio MJ/ED {eq['ratio']:.3g}")
        else:
            text += (f"; at equal final-state error {eq['mj_error']:.2g} Moreau–Jean "
                     f"({eq['mj_setting']}) takes {eq['mj_wall_time']:.3g} s, event-driven "
                     f"(interpolated {eq['ed_setting']}) {eq['ed_wall_time']:.3g} s: ratio "
                     f"MJ/ED {eq['ratio']:.3g}")
    elif eq:
        text += f"; no event-driven run reaches Moreau–Jean's best error {eq['mj_error']:.2g}"
    return text


def _paradox_sentence(px: dict[str, Any]) -> str:
    ed = px["event_driven"]
    parts = []
    for r in px["moreau_jean"]:
        if "energy_end" in r:
            parts.append(f"h = {r['h']:g} {'completes' if r['completed'] else 'stops'} "
                         f"({r['n_impact_steps']} impact steps), energy {r['energy_start']:.4g} "
                         f"-> {r['energy_end']:.4g} J (max {r['energy_max']:.4g})")
        else:
            parts.append(f"h = {r['h']:g} fails: {r['error'][:80]}")
    kind = ed["painleve"][0]["kind"] if ed["painleve"] else "none"
    return (f"Painleve rod mu = {px['params']['mu']} (A = {px['painleve_A']:.3g} < 0, "
            f"{px['regime']}; not compared): event-driven stops with status {ed['status']} at "
            f"t = {ed['t_stop']:g} (Painleve event: {kind}); Moreau–Jean over "
            f"[0, {px['span'][1]:g}]: " + "; ".join(parts))


# -- the section --------------------------------------------------------------------------------
def run_sustained(config: BenchConfig, progress: Progress,
                  scenes: Sequence[str] | None = None) -> SectionResult:
    """Measure the selected scenes (keys of :func:`scene_keys`; default all)."""
    wanted = list(scenes) if scenes is not None else scene_keys()
    unknown = [k for k in wanted if k not in scene_keys()]
    if unknown:
        from ..errors import UnknownOptionError
        raise UnknownOptionError(f"unknown sustained scene(s) {', '.join(unknown)}; choose from "
                                 f"{', '.join(scene_keys())}")
    n_rep = 2 if config.quick else 3
    records: list[dict[str, Any]] = []
    refs: dict[str, Any] = {}
    labels: dict[str, str] = {}
    for case in CASES:
        if case.key not in wanted:
            continue
        recs, refs[case.key] = _measure_case(case, config, progress, n_rep)
        records += recs
        labels[case.key] = case.label
    figures: list[str] = []
    summary: list[str] = []
    aggregates: dict[str, Any] = {}
    if labels:
        figures.append(work_precision_chart(records, labels, config.out))
        figures.append(convergence_chart(records, labels, config.out))
        for key, label in labels.items():
            aggregates[key] = _aggregate(key, records, config.quick)
            summary.append(_sentence(label, aggregates[key], refs[key]))
        eqs = [a["equal_error"] for a in aggregates.values() if a["equal_error"]
               and a["equal_error"]["ratio"] is not None]
        ratios = [q["ratio"] for q in eqs if not q["roundoff"]]
        if ratios:
            summary.append(
                f"over the {len(ratios)} scenes where Moreau–Jean is not exact to round-off, "
                f"the wall-time ratio Moreau–Jean (most accurate h) / event-driven (at equal "
                f"final-state error, or its cheapest run when every run is more accurate) has "
                f"median {float(np.median(ratios)):.3g} (range {min(ratios):.3g}.."
                f"{max(ratios):.3g})")
    meta: dict[str, Any] = {
        "law": LAW, "references": refs, "aggregates": aggregates,
        "rtols": list(rtols(config.quick)), "steps": list(steps(config.quick)),
        "definitions": {
            "final_state_error": "|(theta, theta_dot)(t1) - ref| / |ref|, ref: event-driven "
                                 f"rtol={REF_RTOL:g}, atol={REF_ATOL:g}",
            "observable_error": "error of the scene's first closed-form observable (relative; "
                                "absolute in m where the exact value is 0)",
            "energy_error": "|E(t1) - E_ref(t1)| / max T_ref (max |E_ref| when T_ref ~ 0)",
            "stick_time": "event-driven: start of the first stick interval; Moreau–Jean: first "
                          f"sample with slip speed <= {STICK_TOL:g} x the initial one",
            "impact_time": "event-driven: located impact; Moreau–Jean: midpoint of the first "
                           "impact step (omega_minus: the velocity at the start of that step)",
            "order": "least-squares slope of log error vs log h over the smallest steps, "
                     f"errors above {ROUNDOFF:g}",
            "equal_error": "MJ's most accurate run against the event-driven wall time "
                           "interpolated log-log at its error, or the cheapest event-driven run "
                           "when all are at least as accurate",
            "moreau-jean": "theta = 1/2, law coulomb",
            "event-driven": "DOP853, atol = 1e-2 rtol, law coulomb",
            "wall_time": "result.wall_time, best of up to 3 runs (2 quick), runs over 0.5 s "
                         "once"},
    }
    if PARADOX in wanted:
        meta["painleve_paradox"] = _paradox(config, progress)
        summary.append(_paradox_sentence(meta["painleve_paradox"]))
    return SectionResult("sustained", records, figures, summary, meta)


@register_section("sustained", "sustained frictional contact: event-driven against Moreau-Jean "
                               "as h -> 0 on the ball, box, incline, block, wheel and rod scenes")
def sustained_section(config: BenchConfig, progress: Progress) -> SectionResult:
    """Run every scene (see the module docstring)."""
    return run_sustained(config, progress)
