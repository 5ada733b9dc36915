"""Section ``sensitivities``: the cost of ``simulate(..., sensitivities=True)`` next to the run it
differentiates, and against central finite differences of whole simulations (time and
accuracy).

Scenes (``convimpact.scenes.load_scene``; the settings keep every run's sequence of events
and modes under small perturbations, no event on a mode boundary):

* ``bouncing_ball`` (e 0.6, mu 0.2, launched at 3 m/s), 0-0.8 s: one sliding impact;
* ``pendulum_planar`` case a (e 0.5, mu 0.3), 0-0.8 s: two sliding impacts of the tip;
* ``bouncing_rod`` (e 0.5, mu 0.3), launched sideways and spinning (dtheta0 = (0.8, 0, 1):
  dropped from rest its first impact has zero slip, a mode boundary), 0-0.7 s: three
  sliding impacts;
* ``sliding_box`` (v0 3 m/s, mu 0.3), 0-1.5 s: held corners sliding, slip -> stick;
* ``rocking_block`` (e 0.3, mu 1, tilt 0.1 rad), 0-1.2 s: pivoting, landings, lift-offs.

Three runs are timed at the default tolerances (rtol 1e-8, atol 1e-10), the median process
CPU time over the config's repeats (at most :data:`BUDGET` CPU seconds each):

* ``simulate``: ``simulate(scene, span)``;
* ``simulate, sensitivities=True``: the same run with its state transition and its
  derivatives in e and mu;
* ``central FD``: the state transition by central differences of whole runs, 2 runs per
  direction of the initial state: 2 x 2k for the free scenes; for the scenes starting on held
  contacts (box, block) only the m < 2k directions that keep them touching (positions and
  velocities in the null space of the touching contacts' normal rows: the others change the
  sequence of contact modes, where no derivative exists).

Accuracy, at tight tolerances (rtol 1e-11, atol 1e-12, event_tol 1e-13; step 1e-6): the
largest deviation of the differences from the exact state transition (along the directions
above) and from the derivatives in e and mu (the scene's one coefficient, shared by its
contacts: the sum of the per-contact columns; a coefficient at its range's end, the box's
e = 0, is not differenced), relative to max(1, max |exact|). Every differenced run is checked
to have the nominal run's sequence of impacts and contact events.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .derivatives_several import timed_within
from .registry import BenchConfig, Progress, SectionResult, register_section

#: (scene, parameters, time span, initial velocities replacing the scene's or None, events)
SCENES = (
    ("bouncing_ball", {"e": 0.6, "mu": 0.2, "speed": 3.0}, (0.0, 0.8), None),
    ("pendulum_planar", {"case": "a", "e": 0.5, "mu": 0.3}, (0.0, 0.8), None),
    ("bouncing_rod", {"e": 0.5, "mu": 0.3}, (0.0, 0.7), (0.8, 0.0, 1.0)),
    ("sliding_box", {"v0": 3.0, "mu": 0.3}, (0.0, 1.5), None),
    ("rocking_block", {"e": 0.3, "mu": 1.0, "tilt": 0.1}, (0.0, 1.2), None),
)
QUICK_SCENES = ("bouncing_ball", "sliding_box")
TIGHT = {"rtol": 1e-11, "atol": 1e-12, "event_tol": 1e-13}
STEP = 1e-6
#: CPU seconds per timed measurement before its repeats stop (full, quick)
BUDGET = {False: 4.0, True: 0.3}
#: a contact touches at the start when its gap is within this (simulate's contact_tol)
TOUCH = 1e-8


def make_scene(name: str, parameters: dict[str, Any], dtheta0=None):
    from convimpact.scenes import load_scene

    scene = load_scene(name, **parameters)
    if dtheta0 is not None:
        scene = dataclasses.replace(scene, dtheta0=np.asarray(dtheta0, dtype=float))
    return scene


def final_state(res) -> np.ndarray:
    return np.concatenate([res.theta[-1], res.dtheta[-1]])


def signature(res) -> tuple:
    """The run's sequence of impacts (contacts) and contact events (kinds)."""
    return (tuple(tuple(ev.contacts) for ev in res.impacts),
            tuple(ev.kind for ev in res.contact_events))


def directions(scene) -> tuple[np.ndarray, str]:
    """Columns: directions of the initial state (theta, dtheta) the differences take, and
    their description (module docstring)."""
    from scipy.linalg import null_space

    mech = scene.mechanism
    k = len(scene.theta0)
    touching = [c for c in mech.contact_names
                if abs(mech.contact_gap(c, scene.theta0)) <= TOUCH]
    if not touching:
        return np.eye(2 * k), "every direction (2k)"
    Jn = np.array([np.atleast_2d(mech.contact_jacobian(c, scene.theta0))[0]
                   for c in touching])
    N = null_space(Jn)
    D = np.zeros((2 * k, 2 * N.shape[1]))
    D[:k, :N.shape[1]] = N
    D[k:, N.shape[1]:] = N
    return D, (f"{D.shape[1]} of {2 * k}: positions and velocities keeping "
               f"{', '.join(touching)} touching")


def fd_state(scene, span, D: np.ndarray, **options) -> tuple[np.ndarray, list]:
    """Central differences of the final state along the columns of ``D`` (2 runs each) and
    the runs' signatures."""
    from convimpact.simulation import simulate

    x0 = np.concatenate([scene.theta0, scene.dtheta0])
    k = len(scene.theta0)
    cols, sigs = [], []
    for d in D.T:
        runs = [simulate(scene, span, (x[:k], x[k:]), **options)
                for x in (x0 + STEP * d, x0 - STEP * d)]
        cols.append((final_state(runs[0]) - final_state(runs[1])) / (2 * STEP))
        sigs += [signature(r) for r in runs]
    return np.array(cols).T, sigs


def differenced_parameters(parameters: dict[str, Any]) -> list[str]:
    """The coefficients e and mu of the scene strictly inside their ranges."""
    out = []
    if 0.0 < parameters.get("e", 0.0) < 1.0:
        out.append("e")
    if parameters.get("mu", 0.0) > 0.0:
        out.append("mu")
    return out


def deviation(fd: np.ndarray, exact: np.ndarray) -> float:
    return float(np.abs(fd - exact).max()) / max(1.0, float(np.abs(exact).max()))


def measure_scene(name: str, parameters: dict[str, Any], span, dtheta0,
                  config: BenchConfig) -> dict[str, Any]:
    """Times (default tolerances) and accuracy (tight tolerances) of one scene."""
    import time

    from convimpact.simulation import simulate

    scene = make_scene(name, parameters, dtheta0)
    D, described = directions(scene)
    budget = BUDGET[config.quick]
    t_plain, plain = timed_within(lambda: simulate(scene, span), config.repeat, budget)
    t_sens, sens = timed_within(lambda: simulate(scene, span, sensitivities=True),
                                config.repeat, budget)
    t_fd, _ = timed_within(lambda: fd_state(scene, span, D), config.repeat, budget)
    c = time.process_time()
    exact = simulate(scene, span, sensitivities=True, **TIGHT)
    t_tight = time.process_time() - c
    fd, sigs = fd_state(scene, span, D, **TIGHT)
    nominal = signature(exact)
    row: dict[str, Any] = {
        "scene": name, "parameters": parameters, "span": list(span),
        "dtheta0": None if dtheta0 is None else list(dtheta0), "k": len(scene.theta0),
        "events": [ev.kind for ev in exact.event_sensitivities],
        "n_impacts": len(exact.impacts), "directions": described, "n_directions": D.shape[1],
        "one_sided_events": sum(bool(ev.one_sided) for ev in exact.event_sensitivities),
        "time_plain": t_plain["cpu"], "time_sensitivities": t_sens["cpu"],
        "time_fd": t_fd["cpu"], "wall_plain": t_plain["wall"],
        "wall_sensitivities": t_sens["wall"], "wall_fd": t_fd["wall"],
        "runs_timed": [t_plain["n_timed"], t_sens["n_timed"], t_fd["n_timed"]],
        "fd_runs": 2 * D.shape[1],
        "sensitivities_over_plain": t_sens["cpu"] / t_plain["cpu"],
        "fd_over_sensitivities": t_fd["cpu"] / t_sens["cpu"],
        "time_sensitivities_tight": t_tight,
        "deviation_state": deviation(fd, exact.state_transition @ D),
        "default_matches_plain": bool(np.allclose(final_state(plain), final_state(sens),
                                                  rtol=1e-12, atol=1e-14)),
    }
    same = all(s == nominal for s in sigs)
    for p in differenced_parameters(parameters):
        runs = [simulate(make_scene(name, {**parameters, p: parameters[p] + s * STEP},
                                    dtheta0), span, **TIGHT) for s in (1.0, -1.0)]
        same &= all(signature(r) == nominal for r in runs)
        row[f"deviation_{p}"] = deviation(
            (final_state(runs[0]) - final_state(runs[1])) / (2 * STEP),
            exact.parameter_sensitivity[p].sum(axis=1))
    row["fd_runs_same_events"] = bool(same)
    row["events_label"] = _events_label(row)
    return row


def _events_label(row: dict[str, Any]) -> str:
    kinds = [k for k in row["events"] if k != "start"]
    counts = {k: kinds.count(k) for k in dict.fromkeys(kinds)}
    return ", ".join(f"{n} {k}{'s' if n > 1 else ''}" for k, n in counts.items()) or "no event"


@register_section("sensitivities", "trajectory sensitivities: simulate with and without "
                  "sensitivities=True, and central differences of whole runs (time and "
                  "accuracy), per scene")
def sensitivities_section(config: BenchConfig, progress: Progress) -> SectionResult:
    from .derivatives_charts import sensitivities_chart

    rows = []
    for name, parameters, span, dtheta0 in SCENES:
        if config.quick and name not in QUICK_SCENES:
            continue
        row = measure_scene(name, parameters, span, dtheta0, config)
        devs = ", ".join(f"{key[10:]} {row[key]:.1e}" for key in
                         ("deviation_state", "deviation_e", "deviation_mu") if key in row)
        progress(f"sensitivities {name} ({row['events_label']}): simulate "
                 f"{1e3 * row['time_plain']:.1f} ms, with sensitivities "
                 f"{1e3 * row['time_sensitivities']:.1f} ms, central FD ({row['fd_runs']} runs) "
                 f"{1e3 * row['time_fd']:.0f} ms; FD deviation {devs}")
        rows.append(row)
    figures = [sensitivities_chart(rows, config.out)] if rows else []
    summary = []
    if rows:
        ratio = [r["sensitivities_over_plain"] for r in rows]
        summary.append(
            "simulate with sensitivities=True (default tolerances) takes "
            + ", ".join(f"{r['scene']} {1e3 * r['time_sensitivities']:.0f} ms "
                        f"({r['sensitivities_over_plain']:.1f}x)" for r in rows)
            + f" CPU: {min(ratio):.1f}-{max(ratio):.1f}x the run alone")
        summary.append(
            "central differences of the state transition (same tolerances) take "
            + ", ".join(f"{r['scene']} {r['fd_over_sensitivities']:.1f}x ({r['fd_runs']} "
                        f"runs)" for r in rows)
            + " the exact sensitivities")
        keys = ("deviation_state", "deviation_e", "deviation_mu")
        summary.append(
            "at rtol 1e-11 (step 1e-6) central differences of whole runs agree with the "
            "exact state transition and derivatives in e and mu to (largest relative "
            "deviation, to max(1, max |exact|)) "
            + ", ".join(f"{r['scene']} {max(r[k] for k in keys if k in r):.1e}" for r in rows)
            + f"; {sum(r['fd_runs_same_events'] for r in rows)} of {len(rows)} scenes kept "
            f"their sequence of events in every differenced run")
        flagged = [r for r in rows if r["one_sided_events"]]
        if flagged:
            summary.append(
                "events the run itself flags as one-sided or ill-conditioned (grazing "
                "landings at the end of a bouncing sequence): "
                + ", ".join(f"{r['scene']} {r['one_sided_events']} of {r['n_impacts']} impacts"
                            for r in flagged)
                + " -- where its largest deviation comes from")
    return SectionResult(
        name="sensitivities", records=rows, figures=figures, summary=summary,
        meta={"tight": TIGHT, "step": STEP, "budget": BUDGET,
              "scenes": [{"scene": n, "parameters": p, "span": list(s),
                          "dtheta0": None if d is None else list(d)}
                         for n, p, s, d in SCENES],
              "deviation": "max |FD - exact| / max(1, max |exact|)"})
