"""Simulation maps of the failure atlas: the event-driven, Moreau–Jean and compliant schemes
judged against each other (:func:`judge_time_stepping`, :func:`judge_compliant`) over the double
pendulum's drops (:func:`pendulum_drop_map`) and the bouncing rod's Zeno region
(:func:`rod_zeno_map`)."""

from __future__ import annotations

import time
from typing import Any, Sequence

import numpy as np

from ..errors import ConvImpactError
from .atlas_modes import SIMULATION_MODES, AtlasMap, _MapBuilder


def judge_time_stepping(ref, mj, h: float, smear_tol: float = 1e-2,
                        t_end: float | None = None) -> dict[str, Any]:
    """Compare Moreau–Jean's impact steps with the event-driven impacts of the same start.

    Returns
    -------
    dict with ``missed`` and ``smeared`` (numbers of event-driven impacts), and
    ``velocity_error`` (max relative post-impact velocity error over the matched impacts).
    Event-driven impacts later than ``t_end - 2 h`` are not judged (the step may not have
    reached them).
    """
    t_end = float(ref.t[-1]) if t_end is None else float(t_end)
    mj_times = np.array([i.time for i in mj.impacts])
    missed = smeared = 0
    err = 0.0
    for imp in ref.impacts:
        if imp.time > t_end - 2 * h:
            continue
        near = np.nonzero(np.abs(mj_times - imp.time) <= 2 * h)[0] if mj_times.size else []
        if len(near) == 0:
            missed += 1
            continue
        last = mj.impacts[int(near[-1])]
        e = float(np.linalg.norm(last.dtheta_plus - imp.dtheta_plus)
                  / max(np.linalg.norm(imp.dtheta_plus), 1e-300))
        err = max(err, e)
        if len(near) > 1 or e > smear_tol:
            smeared += 1
    return {"missed": missed, "smeared": smeared, "velocity_error": err}


def judge_compliant(res, stiff_ratio: float = 10.0, depth_tol: float = 1e-3) -> dict[str, Any]:
    """Stiffness and penetration of a compliant run (see the module docstring)."""
    span = float(res.t[-1] - res.t[0])
    t_contact = sum(ep.duration if ep.duration is not None else float(res.t[-1]) - ep.t_start
                    for ep in res.episodes)
    free_steps = res.n_steps - res.n_contact_steps
    t_free = max(span - t_contact, 1e-300)
    if res.n_contact_steps and t_contact > 0 and free_steps > 0:
        ratio = (res.n_contact_steps / t_contact) / (free_steps / t_free)
    else:
        ratio = float("nan")
    return {"step_ratio": ratio, "stiff": bool(ratio > stiff_ratio),
            "max_penetration": res.max_penetration,
            "deep": bool(res.max_penetration > depth_tol)}


def _zeno(ref) -> bool:
    return any(ev.kind == "persist" and ev.accumulation_time is not None
               for ev in ref.contact_events)


def pendulum_drop_map(theta1: Sequence[float] | None = None,
                      theta2: Sequence[float] | None = None, t_end: float = 0.8,
                      h: float = 2e-3, stiffness: float = 1e6, smear_tol: float = 1e-2,
                      stiff_ratio: float = 10.0, depth_tol: float = 1e-3,
                      progress=None) -> AtlasMap:
    """Simulation failures of the double pendulum dropped from rest at (theta1, theta2).

    Per cell: the event-driven run (law "coulomb", rtol 1e-9) is the reference; Moreau–Jean
    at step ``h`` is judged by :func:`judge_time_stepping`, the compliant model (Hunt–Crossley
    with the scene's restitution, ``stiffness``) by :func:`judge_compliant`. Starts whose tip
    is below the floor (y = -1.5 m) are left blank (``values["feasible"] = 0``).
    """
    from ..scenes import load_scene
    from ..simulation import simulate
    from ..simulation.compliant import restitution_for, simulate_compliant
    from ..simulation.moreau import simulate_moreau

    th1 = np.radians([-60.0, 0.0, 60.0]) if theta1 is None else np.asarray(theta1, float)
    th2 = np.radians([-60.0, 0.0, 60.0]) if theta2 is None else np.asarray(theta2, float)
    scene = load_scene("pendulum_planar", case="drop")
    mech = scene.mechanism
    e_c = restitution_for("hunt-crossley", mech.contact_parameters("tip")[0])
    paths = ("event-driven", "moreau-jean", "compliant")
    b = _MapBuilder(paths, SIMULATION_MODES, (th2.size, th1.size))
    shape = (th2.size, th1.size)
    vals = {k: np.full(shape, np.nan) for k in (
        "feasible", "event_driven_impacts", "moreau_velocity_error", "compliant_step_ratio",
        "compliant_penetration")}
    t0 = time.perf_counter()
    for iy, b2 in enumerate(th2):
        for ix, a1 in enumerate(th1):
            q0 = np.array([a1, b2])
            if mech.contact_gap("tip", q0) <= 1e-3:
                vals["feasible"][iy, ix] = 0
                continue
            vals["feasible"][iy, ix] = 1
            y0 = (q0, np.zeros(2))
            judged: dict[str, tuple[tuple[str, ...], str]] = {}
            try:
                ref = simulate(scene, (0.0, t_end), y0, law="coulomb", rtol=1e-9, atol=1e-11)
            except ConvImpactError as exc:
                judged["event-driven"] = ((), f"{type(exc).__name__}: {exc}")
                b.add(iy, ix, judged)
                continue
            vals["event_driven_impacts"][iy, ix] = len(ref.impacts)
            judged["event-driven"] = (("zeno",) if _zeno(ref) else (), "")
            try:
                mj = simulate_moreau(scene, (0.0, t_end), y0, h=h)
                jt = judge_time_stepping(ref, mj, h, smear_tol, t_end)
                vals["moreau_velocity_error"][iy, ix] = jt["velocity_error"]
                judged["moreau-jean"] = (tuple(m for m, n in (("missed_impact", jt["missed"]),
                                                               ("smeared_impact",
                                                                jt["smeared"])) if n), "")
            except ConvImpactError as exc:
                judged["moreau-jean"] = (("missed_impact",), f"{type(exc).__name__}: {exc}")
            try:
                co = simulate_compliant(scene, (0.0, t_end), y0, stiffness=stiffness,
                                        e=e_c, model="hunt-crossley")
                jc = judge_compliant(co, stiff_ratio, depth_tol)
                vals["compliant_step_ratio"][iy, ix] = jc["step_ratio"]
                vals["compliant_penetration"][iy, ix] = jc["max_penetration"]
                judged["compliant"] = (tuple(m for m, f in (("compliant_stiff", jc["stiff"]),
                                                             ("compliant_deep", jc["deep"]))
                                             if f), "")
            except ConvImpactError as exc:
                judged["compliant"] = (("compliant_stiff",), f"{type(exc).__name__}: {exc}")
            b.add(iy, ix, judged)
        if progress:
            progress(f"atlas pendulum drops: row {iy + 1}/{th2.size}")
    return b.build("pendulum_drop", "double pendulum dropped from rest: simulation schemes "
                   "over the initial angles", "theta1(0) [rad]", "theta2(0) [rad]", th1, th2,
                   vals, {"t_end": t_end, "h": h, "stiffness": stiffness,
                          "smear_tol": smear_tol, "stiff_ratio": stiff_ratio,
                          "depth_tol": depth_tol, "law": "coulomb",
                          "compliant_model": "hunt-crossley", "compliant_e": e_c}, t0)


def rod_zeno_map(tilt_deg: Sequence[float] | None = None, e: Sequence[float] | None = None,
                 t_end: float = 1.2, height: float = 0.5, progress=None) -> AtlasMap:
    """Where the bouncing rod's impacts accumulate (event-driven, law "coulomb"): tilt x e.

    ``values["accumulation_time"]``: the first extrapolated accumulation instant (NaN: none
    within the span); ``values["impacts"]``: impacts resolved before it.
    """
    from ..scenes import load_scene
    from ..simulation import simulate

    tilts = np.array([0.0, 30.0, 60.0]) if tilt_deg is None else np.asarray(tilt_deg, float)
    es = np.array([0.2, 0.5, 0.8]) if e is None else np.asarray(e, float)
    b = _MapBuilder(("event-driven",), ("zeno",), (es.size, tilts.size))
    acc = np.full((es.size, tilts.size), np.nan)
    nimp = np.full((es.size, tilts.size), np.nan)
    t0 = time.perf_counter()
    for iy, ee in enumerate(es):
        for ix, tilt in enumerate(tilts):
            scene = load_scene("bouncing_rod", e=float(ee), tilt=float(tilt), height=height)
            ref = simulate(scene, (0.0, t_end), law="coulomb", rtol=1e-8, atol=1e-10)
            times = [ev.accumulation_time for ev in ref.contact_events
                     if ev.accumulation_time is not None]
            acc[iy, ix] = min(times) if times else np.nan
            nimp[iy, ix] = len(ref.impacts)
            b.add(iy, ix, {"event-driven": (("zeno",) if _zeno(ref) else (), "")})
        if progress:
            progress(f"atlas rod Zeno: row {iy + 1}/{es.size}")
    return b.build("rod_zeno", "bouncing rod: accumulating impacts (tilt x e)", "tilt [deg]",
                   "e", tilts, es, {"accumulation_time": acc, "impacts": nimp},
                   {"t_end": t_end, "height": height, "law": "coulomb"}, t0)
