"""``convimpact simulate SCENE``: run a scene of ``problems/`` through its impacts.

Writes ``result.json`` (the scene's parameters, the settings, every impact event and contact
switch, the contact mode timeline, the energy, drift and contact series) and PNG plots
``trajectory.png``, ``energy.png`` and ``contacts.png`` (per contact: mode timeline and
forces) into ``--out`` (default ``./simulate-SCENE``); ``--json`` prints the JSON to
standard output instead (and writes files only when ``--out`` is given too). ``--animate``
also writes ``animation.gif``, the mechanism moving with its contacts coloured by mode (models
built with ModelBuilder only).
``convimpact simulate --list`` names the scenes; ``convimpact simulate --bench [SCENE]``
times them (RHS evaluations per second, wall time per simulated second, impact share).
``--e-t`` sets the tangential restitution of ``--law chatterjee-ruina`` (every contact; the
scene's contacts give e and mu); with another law it is refused.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..files import write_whole
from ..cli import command
from ..errors import NotSupportedError, ParameterError, UnknownOptionError
from ..impact import LAWS, METHODS, available_methods
from ..impact.results import _jsonable
from ..scenes import list_scenes, load_scene
from .animation import animate, check_animatable, check_outlines, plot_contacts
from .result import SimulationResult
from ..validation import arg_finite, arg_nonnegative_int, arg_positive, arg_positive_int
from .simulate import INTEGRATORS, simulate


def _parse_params(items: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in items or []:
        if "=" not in item:
            raise ParameterError(f"--param expects KEY=VALUE, got {item!r}")
        key, val = item.split("=", 1)
        try:
            out[key] = json.loads(val)
        except json.JSONDecodeError:
            out[key] = val
    return out


def _strict(v):
    """Strict JSON: non-finite floats become the strings "inf", "-inf", "nan"."""
    if isinstance(v, float) and not np.isfinite(v):
        return "nan" if np.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return {k: _strict(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_strict(x) for x in v]
    return v


def scene_report(scene, res: SimulationResult, series: bool = True) -> dict[str, Any]:
    """JSON-ready report of a scene's simulation: parameters, events, energy and drift."""
    report = {
        "scene": scene.name,
        "description": scene.description,
        "parameters": _jsonable(dict(scene.parameters)),
        "contacts": list(scene.mechanism.contact_names),
        "theta0": _jsonable(np.asarray(scene.theta0)),
        "dtheta0": _jsonable(np.asarray(scene.dtheta0)),
        **res.as_dict(series=False),
    }
    report["n_impacts"] = len(res.impacts)
    report["impact_share"] = res.impact_share
    if series:
        report["series"] = {
            "t": res.t.tolist(),
            "theta": res.theta.tolist(),
            "dtheta": res.dtheta.tolist(),
            "kinetic_energy": res.kinetic_energy.tolist(),
            "potential_energy": res.potential_energy.tolist(),
            "total_energy": res.total_energy.tolist(),
            "loop_residual": res.loop_residual.tolist(),
            "loop_velocity_residual": res.loop_velocity_residual.tolist(),
            "held": res.held.tolist(),
            "contact_mode": res.contact_mode.tolist(),
            "contact_force": res.contact_force.tolist(),
        }
    return _strict(report)


def _coordinate_units(mechanism, k: int) -> list[str]:
    """'rad' for revolute coordinates, 'm' for prismatic ones ('-' when unknown)."""
    model = getattr(mechanism, "model", None)
    motion = getattr(model, "coordinate_motion", None)
    out = []
    for j in range(k):
        try:
            kind = motion(j).kind if callable(motion) else motion[j].kind
        except Exception:  # noqa: BLE001 - a user mechanism without joint kinds
            kind = ""
        out.append({"revolute": "rad", "prismatic": "m"}.get(kind, "-"))
    return out


#: coordinates drawn in trajectory.png, impacts marked by lines, contacts in contacts.png
#: (a scene of many bodies is shown in part: its animation shows the whole)
MAX_PANELS = 12
MAX_IMPACT_LINES = 60
MAX_CONTACT_PLOTS = 24


def write_plots(scene, res: SimulationResult, out: Path) -> list[Path]:
    """Trajectory, energy/drift and (when there are contacts, at most
    :data:`MAX_CONTACT_PLOTS`) contact plots (Agg backend)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    t_imp = [ev.time for ev in res.impacts]
    k = res.theta.shape[1]
    names = list(getattr(scene.mechanism, "coordinate_names", None)
                 or [f"theta{j + 1}" for j in range(k)])
    units = _coordinate_units(scene.mechanism, k)
    # sample the dense output on a fine grid (steps of a high-order integrator are long);
    # velocities by central differences of the interpolant (a jump smears over one cell)
    if res.sol is not None:
        tt = np.linspace(res.t[0], res.t[-1], 2000)
        th = np.array([res.sol(ti)[:k] for ti in tt])
        dt = 1e-7 * max(float(res.t[-1] - res.t[0]), 1e-300)
        lo = np.maximum(tt - dt, res.t[0])
        hi = np.minimum(tt + dt, res.t[-1])
        dth = np.array([(res.sol(b)[:k] - res.sol(a)[:k]) / (b - a) for a, b in zip(lo, hi)])
    else:
        tt, th, dth = res.t, res.theta, res.dtheta
    # panels in natural order of the coordinate names (theta1, theta2, ... theta10); a scene
    # of many bodies (the disc pile's 342 coordinates) shows its first MAX_PANELS
    order = sorted(range(k), key=lambda j: [int(p) if p.isdigit() else p
                                            for p in re.split(r"(\d+)", names[j])])
    shown = order[:MAX_PANELS]
    if len(t_imp) > MAX_IMPACT_LINES:  # hundreds of impact steps: lines would hide the plot
        t_imp = []
    fig, axes = plt.subplots(len(shown), 2, sharex=True, figsize=(10, 1.9 * len(shown) + 1.0),
                             squeeze=False)
    order = shown
    for row, j in enumerate(order):
        axes[row, 0].plot(tt, th[:, j], color=f"C{j}")
        axes[row, 0].set_ylabel(f"{names[j]} [{units[j]}]")
        axes[row, 1].plot(tt, dth[:, j], color=f"C{j}", lw=1.0)
        axes[row, 1].set_ylabel(f"d{names[j]}/dt [{units[j]}/s]")
        for ax in axes[row]:
            for ti in t_imp:
                ax.axvline(ti, color="0.8", lw=0.5, zorder=0)
    axes[-1, 0].set_xlabel("t [s]")
    axes[-1, 1].set_xlabel("t [s]")
    axes[0, 0].set_title("joint coordinates")
    axes[0, 1].set_title("joint velocities (jumps at impacts)")
    more = f"; first {len(shown)} of {k} coordinates" if len(shown) < k else ""
    fig.suptitle(f"{scene.name}: trajectory ({len(res.impacts)} impacts"
                 + (", grey lines" if t_imp else "") + f"{more})")
    fig.tight_layout()
    p = out / "trajectory.png"
    fig.savefig(p, dpi=100)
    plt.close(fig)
    paths.append(p)

    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    axes[0].plot(res.t, res.kinetic_energy, label="T")
    axes[0].plot(res.t, res.potential_energy, label="V")
    axes[0].plot(res.t, res.total_energy, label="T + V", color="k")
    axes[0].set_ylabel("energy [J]")
    axes[0].legend(loc="upper right", fontsize="small")
    axes[0].set_title(f"{scene.name}: energy and constraint drift")
    if scene.mechanism.n_loop_constraints:
        floor = 1e-18
        axes[1].semilogy(res.t, np.maximum(res.loop_residual, floor), label="max |Psi|")
        axes[1].semilogy(res.t, np.maximum(res.loop_velocity_residual, floor),
                         label="max |C theta_dot|")
        axes[1].set_ylabel("constraint drift")
        axes[1].legend(loc="upper right", fontsize="small")
    else:  # open loops: no drift to show; the energy audit instead
        # the law's losses so far (the post-impact sample shares the impact's time)
        lost = np.array([sum(ev.energy_loss for ev in res.impacts
                             if ev.time < tj or (ev.time == tj and j > 0 and res.t[j - 1] == tj))
                         for j, tj in enumerate(res.t)])
        fric = (res.friction_dissipation if res.friction_dissipation.size == res.t.size
                else np.zeros_like(res.t))
        axes[1].plot(res.t, res.total_energy[0] - res.total_energy, color="k",
                     label="E(0) - E(t)")
        axes[1].plot(res.t, lost, label="impact losses (law)")
        axes[1].plot(res.t, fric, label="sliding friction work")
        axes[1].plot(res.t, lost + fric, "--", color="0.5", label="sum")
        axes[1].set_ylabel("energy dissipated [J]")
        axes[1].legend(loc="upper left", fontsize="small")
        axes[0].set_title(f"{scene.name}: energy")
    axes[1].set_xlabel("t [s]")
    for ax in axes:
        for ti in t_imp:
            ax.axvline(ti, color="0.8", lw=0.5, zorder=0)
    fig.tight_layout()
    p = out / "energy.png"
    fig.savefig(p, dpi=100)
    plt.close(fig)
    paths.append(p)
    if 0 < len(getattr(scene.mechanism, "contact_names", None) or ()) <= MAX_CONTACT_PLOTS:
        p = plot_contacts(res, out / "contacts.png", mechanism=scene.mechanism,
                          title=f"{scene.name}: contact modes and forces")
        if p is not None:
            paths.append(p)
    return paths


def _impact_options(args: argparse.Namespace) -> dict[str, Any]:
    """``impact_options`` of the run: ``--e-t`` for the law that has a tangential restitution,
    refused (UnknownOptionError) with any other."""
    from ..impact.laws import TANGENTIAL_LAWS

    if args.e_t is None:
        return {}
    if args.law not in TANGENTIAL_LAWS:
        raise UnknownOptionError(
            f"--e-t is the tangential restitution of law "
            f"{', '.join(map(repr, TANGENTIAL_LAWS))}; --law {args.law} has none (drop --e-t "
            f"or pass --law {TANGENTIAL_LAWS[0]})")
    return {"e_t": args.e_t}


def run(args: argparse.Namespace) -> int:
    """Entry point of ``convimpact simulate``."""
    if args.list:
        for name in list_scenes():
            print(name)
        return 0
    if args.bench:
        args.law = args.law or "pereira-nikravesh"
        impact_options = _impact_options(args)
        from .benchmark import run_benchmark

        rows = run_benchmark([args.scene] if args.scene else None, repeats=args.repeats,
                             law=args.law, method=args.method, integrator=args.integrator,
                             rtol=args.rtol, atol=args.atol, impact_options=impact_options)
        text = json.dumps(_strict(rows), indent=1)
        if args.out is not None:
            Path(args.out).mkdir(parents=True, exist_ok=True)
            write_whole(Path(args.out) / "simulation_benchmark.json", text)
        if args.json:
            print(text)
        else:
            print(f"{'scene':<18} {'impacts':>7} {'steps':>6} {'RHS/s':>8} {'wall/sim s':>10} "
                  f"{'impact %':>8}")
            for r in rows["rows"]:
                print(f"{r['scene']:<18} {r['n_impacts']:>7} {r['n_steps']:>6} "
                      f"{r['rhs_per_second']:>8.0f} {r['wall_per_simulated_second']:>10.4f} "
                      f"{100 * r['impact_share']:>8.1f}")
        return 0
    if not args.scene:
        raise ParameterError("name a scene (see `convimpact simulate --list`)")
    scene = load_scene(args.scene, **_parse_params(args.param))
    if args.animate:
        check_outlines(check_animatable(scene.mechanism), scene.outlines)  # fail early
    t_end = float(args.t_end) if args.t_end is not None else float(scene.t_end)
    declared = dict(scene.simulation or {})
    scheme = args.scheme or declared.get("scheme", "event-driven")
    if args.law is None:
        args.law = declared.get("law", "pereira-nikravesh") if scheme == declared.get(
            "scheme") else "pereira-nikravesh"
    impact_options = _impact_options(args)
    if args.method != "auto" and args.method not in available_methods(args.law):
        raise NotSupportedError(
            f"law {args.law!r} has no method {args.method!r}; available: "
            f"{', '.join(available_methods(args.law))}")
    if scheme == "moreau-jean":
        from .moreau import simulate_moreau

        h = args.h if args.h is not None else declared.get("h")
        if h is None:
            raise ParameterError("Moreau–Jean needs a step: pass --h")
        options = {**dict(declared.get("impact_options", {})), **impact_options}
        res = simulate_moreau(scene, (0.0, t_end), h=float(h), law=args.law,
                              method=args.method, impact_options=options)
    else:
        # the scene's declared kinks of its applied forces, inside this run's span
        breakpoints = [b for b in declared.get("breakpoints", ()) if 0.0 < b < t_end]
        res = simulate(scene, (0.0, t_end), law=args.law, method=args.method,
                       integrator=args.integrator, rtol=args.rtol, atol=args.atol,
                       zeno=args.zeno, max_impacts=args.max_impacts, dense_output=True,
                       impact_options=impact_options, breakpoints=breakpoints)
    report = scene_report(scene, res)
    written: list[Path] = []
    out = Path(args.out) if args.out is not None else Path(f"simulate-{scene.name}")
    if args.out is not None or not args.json or args.animate:
        out.mkdir(parents=True, exist_ok=True)
        # result.json is written last, whole (a temporary name renamed): a run whose plots or
        # animation fail leaves no result that looks complete
        partial = out / "result.json.partial"
        try:
            if args.out is not None or not args.json:
                partial.write_text(json.dumps(report, indent=1))
                written = [*write_plots(scene, res, out)]
            if args.animate:
                written.append(animate(res, scene.mechanism, out / "animation.gif",
                                       title=f"{scene.name}: t = [0, {t_end:g}] s",
                                       outlines=scene.outlines))
        except BaseException:
            partial.unlink(missing_ok=True)
            raise
        if partial.exists():
            p = out / "result.json"
            partial.replace(p)
            written.insert(0, p)
    if args.json:
        json.dump(report, sys.stdout, indent=1)
        print()
        return 0 if res.success else 1
    e_t = f" (e_t = {args.e_t:g})" if args.e_t is not None else ""
    how = (f"integrator {res.settings['integrator']}" if scheme != "moreau-jean" else
           f"Moreau–Jean h = {res.settings['h']:g} s, {res.n_contact_steps} contact steps, "
           f"at most {getattr(res, 'max_active_contacts', 0)} contacts on a step, max "
           f"penetration {res.max_penetration:.2e} m")
    print(f"{scene.name}: t = [0, {t_end:g}] s, law {args.law}{e_t}, method {args.method}, "
          f"{how}")
    print(f"  status {res.status}: {res.message}")
    print(f"  {len(res.impacts)} impacts, {len(res.contact_events)} contact switches, "
          f"{res.n_steps} steps, {res.nfev} RHS evaluations "
          f"({res.rhs_per_second:.0f}/s), wall {res.wall_time:.3f} s "
          f"({100 * res.impact_share:.1f}% in impact resolution)")
    print(f"  energy T+V: {res.total_energy[0]:.6g} -> {res.total_energy[-1]:.6g} J; "
          f"max |Psi| = {res.max_loop_residual:.2e}, "
          f"max |C theta_dot| = {res.max_loop_velocity_residual:.2e}")
    for w in res.warnings:
        print(f"  WARNING: {w}")
    for c in res.contact_names:
        spent = {m: sum(iv.t_end - iv.t_start for iv in res.modes_of(c) if iv.mode == m)
                 for m in ("stick", "slip")}
        if any(spent.values()):
            print(f"  contact {c}: stick {spent['stick']:.4g} s, slip {spent['slip']:.4g} s")
    for ev in res.impacts[:10]:
        print(f"  t = {ev.time:.9g}  {'+'.join(ev.contacts):<12} {'/'.join(ev.regime):<14} "
              f"pi_n = {np.round(ev.impulse[:, 0], 6).tolist()}  "
              f"T_L = {ev.energy_loss + 0.0:.6g}")  # + 0.0: never print -0
    if len(res.impacts) > 10:
        print(f"  ... {len(res.impacts) - 10} more impacts in result.json")
    for p in written:
        print(f"  wrote {p}")
    return 0 if res.success else 1


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", nargs="?", help="scene name (module of problems/)")
    p.add_argument("--list", action="store_true", help="name the scenes and exit")
    p.add_argument("--law", default=None, choices=LAWS,
                   help="impact law (default: the scene's declared law, else pereira-nikravesh)")
    p.add_argument("--scheme", default=None, choices=("event-driven", "moreau-jean"),
                   help="simulation scheme (default: the scene's declared one, else "
                        "event-driven)")
    p.add_argument("--h", type=float, default=None,
                   help="Moreau–Jean step (default: the scene's declared one)")
    p.add_argument("--method", default="auto", choices=METHODS, help="impact solver path")
    p.add_argument("--e-t", type=arg_finite, default=None,
                   help="tangential restitution in [-1, 1] of --law chatterjee-ruina (default "
                        "0); refused with the other laws")
    p.add_argument("--t-end", type=arg_positive, default=None,
                   help="end time (default: the scene's)")
    p.add_argument("--out", default=None, help="output directory (default ./simulate-SCENE)")
    p.add_argument("--json", action="store_true", help="print the JSON report to stdout")
    p.add_argument("--animate", action="store_true",
                   help="also write animation.gif (the mechanism moving, contacts coloured by "
                        "mode; models built with ModelBuilder)")
    p.add_argument("--integrator", default="DOP853", choices=sorted(INTEGRATORS))
    p.add_argument("--rtol", type=arg_positive, default=1e-8)
    p.add_argument("--atol", type=arg_positive, default=1e-10)
    p.add_argument("--zeno", default="persist", choices=("persist", "stop"),
                   help="accumulating impacts: hold the contact closed, or stop")
    p.add_argument("--max-impacts", type=arg_nonnegative_int, default=10_000)
    p.add_argument("--bench", action="store_true",
                   help="benchmark the scene (or every scene): RHS/s, wall time per simulated "
                        "second, share of impact resolution")
    p.add_argument("--repeats", type=arg_positive_int, default=3,
                   help="benchmark repeats (best is kept)")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="scene parameter (JSON value), repeatable")


run.add_arguments = _add_arguments
command("simulate", "simulate a scene of problems/ through its impacts (canonical equations)")(run)
