"""Section ``model``: the cost of the model's evaluations against the number of bodies, ours
and Pinocchio's, in the same run.

Mechanisms (:mod:`~convimpact.bench.model_problems`): planar and spatial revolute chains and
random trees of n bodies (n in :func:`sizes`), one point contact on the last body, exported
to Pinocchio by :func:`~convimpact.model.pinocchio_adapter.to_pinocchio` (M agrees to
round-off; a frame is added at the contact point). Per mechanism, the median time per call
(:func:`~convimpact.bench.timing.time_call`, calls alternating between two configurations so
that no cache answers) of:

* ``M``: ours :func:`convimpact.model.mass_matrix` (composite rigid bodies; validates its
  input, returns a new array) against ``pinocchio.crba``;
* ``f``: ours :func:`convimpact.model.generalized_forces` (Newton-Euler, eq. 4) against
  ``pinocchio.rnea(q, v, 0)`` (= -f);
* ``Jc``: ours :func:`convimpact.model.contact_jacobian` (forward kinematics of the contact's
  support, the contact frame and the rows n, t(1, t2)) against
  ``pinocchio.computeFrameJacobian`` at the contact point (``LOCAL_WORLD_ALIGNED``);
* ``(unchecked)`` rows: ours through :meth:`convimpact.model.Data.compute` without validation
  or copy (the simulator's entry), for M, f and Jc.

And the cost of one simulated second of a chain of n links dropped on the floor
(:func:`~convimpact.bench.model_problems.dropped_chain`: its tip strikes the floor) with the
event-driven :func:`convimpact.simulation.simulate` (defaults: DOP853, rtol 1e-6) on our model
and, for the spatial chain, on the same model evaluated by Pinocchio
(:class:`~convimpact.model.pinocchio_adapter.PinocchioMechanism`: M by crba, f by
nonLinearEffects, M_dot from the Coriolis matrix, the contact Jacobian's rate by central
differences): wall time (best of 2, 1 in quick), right-hand-side evaluations, impacts, and the
two runs' final-state difference (the chains are chaotic: from about 20 links the two runs
part at round-off and their event counts differ, so ``wall_per_evaluation`` is the fair
ratio there).

Chart ``model_scaling.png``: one log-log panel per quantity, time against n. The summary
states the ratios ours/Pinocchio (median over the mechanisms of each n) and how each cost
grows from the smallest to the largest n.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..impact.errors import ConvImpactError
from ..model import contact_jacobian, generalized_forces, mass_matrix
from ..model import recursive as rc
from .model_problems import dropped_chain, pinocchio_twin, random_mechanism
from .registry import BenchConfig, Progress, SectionResult, register_section
from .timing import time_call

QUANTITIES = ("M", "f", "Jc")
KINDS = ("planar chain", "planar tree", "spatial chain", "spatial tree")
PINOCCHIO = {"M": "crba", "f": "rnea", "Jc": "computeFrameJacobian"}


def sizes(quick: bool) -> tuple[int, ...]:
    """Numbers of bodies measured."""
    return (2, 5, 10, 20) if quick else (2, 3, 5, 10, 20, 30, 50)


def chain_sizes(quick: bool) -> tuple[int, ...]:
    """Numbers of links of the dropped chain."""
    return (2, 5, 10) if quick else (2, 5, 10, 20, 50)


def _pinocchio():
    try:
        import pinocchio
    except ImportError:
        return None
    return pinocchio


def evaluation_calls(model, theta, dtheta, pin_twin=None) -> dict[tuple[str, str], Callable]:
    """No-argument calls of every measured evaluation: ``{(quantity, implementation): fn}``.

    Each call alternates between theta + 0.1 (its first call) and theta, so that a cached
    answer never serves; the values of every implementation's n-th call belong to the same
    configuration."""
    data = model.create_data()
    th = (np.array(theta, dtype=float), np.array(theta, dtype=float) + 0.1)
    dth = np.array(dtheta, dtype=float)
    name = model.contact_names[0]

    def alternate(states):
        phase = [0]

        def nxt():
            phase[0] ^= 1
            return states[phase[0]]
        return nxt

    def ours(kind):
        nxt = alternate(th)
        if kind == "M":
            return lambda: mass_matrix(model, data, nxt())
        if kind == "f":
            return lambda: generalized_forces(model, data, 0.0, nxt(), dth)
        return lambda: contact_jacobian(model, data, name, nxt())

    def unchecked(kind):
        nxt = alternate(th)
        if kind == "M":
            def call():
                data.compute(rc.MASS, nxt())
                return data.M
        elif kind == "f":
            def call():
                data.compute(rc.BIAS, nxt(), dth)
                return data.bias
        else:
            def call():
                data.compute(rc.CONTACT, nxt())
                return data.contact_jacobian[0]
        return call

    calls: dict[tuple[str, str], Callable] = {}
    for qty in QUANTITIES:
        calls[(qty, "ours")] = ours(qty)
        calls[(qty, "ours (unchecked)")] = unchecked(qty)
    if pin_twin is not None:
        pin = _pinocchio()
        pm, pd, perm = pin_twin["model"], pin_twin["data"], pin_twin["permutation"]
        q = (th[0][perm].copy(), th[1][perm].copy())
        v = dth[perm].copy()
        a0 = np.zeros_like(v)
        fid = pin_twin["frames"][name]
        lwa = pin.LOCAL_WORLD_ALIGNED
        nm, nf, nj = alternate(q), alternate(q), alternate(q)
        calls[("M", "pinocchio")] = lambda: pin.crba(pm, pd, nm())
        calls[("f", "pinocchio")] = lambda: pin.rnea(pm, pd, nf(), v, a0)
        calls[("Jc", "pinocchio")] = lambda: pin.computeFrameJacobian(pm, pd, nj(), fid, lwa)
    return calls


def measure_evaluations(config: BenchConfig, progress: Progress) -> list[dict[str, Any]]:
    """Records of the per-call times of every (kind, n, quantity, implementation)."""
    has_pin = _pinocchio() is not None
    records = []
    for kind in KINDS:
        planar, chain = kind.startswith("planar"), kind.endswith("chain")
        for n in sizes(config.quick):
            model, theta, dtheta = random_mechanism(n, planar, chain, config.seed)
            twin = pinocchio_twin(model) if has_pin else None
            calls = evaluation_calls(model, theta, dtheta, twin)
            times = {}
            for (qty, impl), fn in calls.items():
                t, _ = time_call(fn, repeat=config.repeat, min_batch_time=config.min_batch_time,
                                 warmup=3)
                times[(qty, impl)] = t.median
                records.append({"kind": kind, "n_bodies": n, "k": model.n_coordinates,
                                "quantity": qty, "implementation": impl,
                                "reference": PINOCCHIO[qty] if impl == "pinocchio" else None,
                                **t.as_dict()})
            progress(f"model {kind} n={n}: " + ", ".join(
                f"{qty} {1e6 * times[(qty, 'ours')]:.1f} us"
                + (f" / {PINOCCHIO[qty]} {1e6 * times[(qty, 'pinocchio')]:.1f} us"
                   if (qty, "pinocchio") in times else "") for qty in QUANTITIES))
    return records


def measure_simulations(config: BenchConfig, progress: Progress) -> list[dict[str, Any]]:
    """Records of one simulated second (0.3 s quick) of the dropped chain per backend."""
    from ..simulation import simulate

    span = (0.0, 0.3 if config.quick else 1.0)
    n_best = 1 if config.quick else 2
    has_pin = _pinocchio() is not None
    records = []
    model, th0, dth0 = dropped_chain(2, True)  # warm-up: the simulator's and impact laws' imports
    simulate(model.mechanism(), (0.0, 0.5), (th0, dth0))
    for planar in (True, False):
        for n in chain_sizes(config.quick):
            model, th0, dth0 = dropped_chain(n, planar)
            backends = [("ours", model.mechanism())]
            if has_pin and not planar:
                backends.append(("pinocchio", pinocchio_twin(model)["mechanism"]))
            finals = {}
            for impl, mech in backends:
                rec: dict[str, Any] = {"kind": ("planar" if planar else "spatial") + " chain",
                                       "n_bodies": n, "k": model.n_coordinates,
                                       "quantity": "simulation", "implementation": impl,
                                       "span": list(span)}
                try:
                    best = None
                    for _ in range(n_best):
                        res = simulate(mech, span, (th0, dth0))
                        if best is None or res.wall_time < best.wall_time:
                            best = res
                except ConvImpactError as exc:
                    rec.update(median=None, error=f"{type(exc).__name__}: {exc}"[:300])
                    records.append(rec)
                    continue
                sim = span[1] - span[0]
                rec.update(median=best.wall_time / sim, wall_time=best.wall_time,
                           nfev=int(best.nfev), n_impacts=len(best.impacts),
                           status=best.status, wall_per_evaluation=best.wall_time / best.nfev,
                           error=None)
                finals[impl] = np.concatenate([best.theta[-1], best.dtheta[-1]])
                records.append(rec)
            if len(finals) == 2:
                diff = float(np.max(np.abs(finals["ours"] - finals["pinocchio"])))
                for r in records[-2:]:
                    r["final_state_difference"] = diff
            progress(f"model dropped chain {'planar' if planar else 'spatial'} n={n}: " + ", ".join(
                f"{r['implementation']} {r['median']:.3g} s per simulated s ({r['nfev']} RHS)"
                for r in records if r["n_bodies"] == n and r["kind"].startswith(
                    "planar" if planar else "spatial") and r["quantity"] == "simulation"
                and r.get("median")))
    return records


def _median(values):
    values = [v for v in values if v is not None]
    return float(np.median(values)) if values else None


def ratio_table(records: list[dict[str, Any]], impl: str = "ours") -> dict[str, dict[int, float]]:
    """Per quantity and n, the median over the kinds of ``impl`` / Pinocchio."""
    out: dict[str, dict[int, float]] = {}
    for qty in QUANTITIES + ("simulation",):
        per_n: dict[int, list[float]] = {}
        for r in records:
            if r["quantity"] != qty or r["implementation"] != impl or r.get("median") is None:
                continue
            peer = [p for p in records if p["quantity"] == qty and p["kind"] == r["kind"]
                    and p["n_bodies"] == r["n_bodies"] and p["implementation"] == "pinocchio"
                    and p.get("median")]
            if peer:
                key = "wall_per_evaluation" if qty == "simulation" else "median"
                per_n.setdefault(r["n_bodies"], []).append(r[key] / peer[0][key])
        if per_n:
            out[qty] = {n: float(np.median(v)) for n, v in sorted(per_n.items())}
    return out


def growth(records: list[dict[str, Any]], qty: str, impl: str) -> float | None:
    """Median over the kinds of time(largest n) / time(smallest n)."""
    ratios = []
    for kind in {r["kind"] for r in records if r["quantity"] == qty}:
        rows = sorted((r for r in records if r["quantity"] == qty and r["kind"] == kind
                       and r["implementation"] == impl and r.get("median")),
                      key=lambda r: r["n_bodies"])
        if len(rows) >= 2:
            ratios.append(rows[-1]["median"] / rows[0]["median"])
    return _median(ratios)


def summary_sentences(records: list[dict[str, Any]]) -> list[str]:
    """Ratios ours/Pinocchio and the growth of each cost, quoting this run's medians."""
    out = []
    ratios = ratio_table(records)
    raw = ratio_table(records, "ours (unchecked)")
    ns = sorted({r["n_bodies"] for r in records if r["quantity"] in QUANTITIES})
    for qty in QUANTITIES:
        ours = [r for r in records if r["quantity"] == qty and r["implementation"] == "ours"]
        if not ours:
            continue
        lo, hi = min(r["median"] for r in ours), max(r["median"] for r in ours)
        text = (f"{qty}: ours {1e6 * lo:.3g}-{1e6 * hi:.3g} us per call over n = {ns[0]}-{ns[-1]} "
                "bodies (planar and spatial chains and trees)")
        if qty in ratios:
            r = ratios[qty]
            peer = [p for p in records
                    if p["quantity"] == qty and p["implementation"] == "pinocchio"]
            plo, phi = min(p["median"] for p in peer), max(p["median"] for p in peer)
            text += (f", pinocchio.{PINOCCHIO[qty]} {1e6 * plo:.3g}-{1e6 * phi:.3g} us; ratio "
                     f"ours/Pinocchio {min(r.values()):.2g}-{max(r.values()):.2g} "
                     f"(median over the four kinds per n: "
                     + ", ".join(f"n={n}: {v:.2g}" for n, v in r.items()) + ")")
            if qty in raw:
                text += (f"; unchecked entry {min(raw[qty].values()):.2g}-"
                         f"{max(raw[qty].values()):.2g}")
            g_ours, g_pin = growth(records, qty, "ours"), growth(records, qty, "pinocchio")
            text += (f"; cost from n = {ns[0]} to {ns[-1]}: ours x{g_ours:.3g}, Pinocchio "
                     f"x{g_pin:.3g}")
        out.append(text)
    sims = [r for r in records if r["quantity"] == "simulation" and r.get("median")]
    if sims:
        parts = []
        for r in sorted(sims, key=lambda r: (r["kind"], r["n_bodies"], r["implementation"])):
            parts.append(f"{r['kind']} n={r['n_bodies']} {r['implementation']} "
                         f"{r['median']:.3g} s ({r['nfev']} RHS, {r['n_impacts']} impacts)")
        text = ("one simulated second of the dropped chain (event-driven, wall time per "
                "simulated second): " + "; ".join(parts))
        if "simulation" in ratios:
            text += ("; ours/Pinocchio backend per right-hand-side evaluation: " + ", ".join(
                f"n={n}: {v:.2g}" for n, v in ratios["simulation"].items()))
        out.append(text)
    return out


def run_model(config: BenchConfig, progress: Progress) -> SectionResult:
    """Measure and chart (see the module docstring)."""
    from .model_charts import scaling_chart

    progress("model: compiling the recursive algorithms (cached after the first run)")
    model, theta, dtheta = random_mechanism(2, True, True, config.seed)
    model.mechanism().generalized_forces(0.0, theta, dtheta)
    records = measure_evaluations(config, progress)
    records += measure_simulations(config, progress)
    figures = [scaling_chart(records, config.out)]
    pin = _pinocchio()
    meta = {
        "pinocchio": None if pin is None else str(pin.__version__),
        "sizes": list(sizes(config.quick)), "chain_sizes": list(chain_sizes(config.quick)),
        "ratios": {q: {str(n): v for n, v in r.items()} for q, r in ratio_table(records).items()},
        "ratios_unchecked": {q: {str(n): v for n, v in r.items()}
                             for q, r in ratio_table(records, "ours (unchecked)").items()},
        "definitions": {
            "median": "seconds per call (per simulated second for 'simulation')",
            "M": "ours convimpact.model.mass_matrix / pinocchio.crba",
            "f": "ours convimpact.model.generalized_forces / pinocchio.rnea(q, v, 0)",
            "Jc": "ours convimpact.model.contact_jacobian / pinocchio.computeFrameJacobian "
                  "(LOCAL_WORLD_ALIGNED) at the contact point",
            "ours (unchecked)": "Data.compute(flags, theta[, dtheta]) without validation or copy",
            "simulation": "convimpact.simulate (DOP853, rtol 1e-6) of the dropped chain; "
                          "'pinocchio': the same run on PinocchioMechanism",
        },
    }
    return SectionResult("model", records, figures, summary_sentences(records), meta)


@register_section("model", "model evaluation against the number of bodies: M, f, Jc and one "
                           "simulated second, ours and Pinocchio's")
def model_section(config: BenchConfig, progress: Progress) -> SectionResult:
    """Run the section (see the module docstring)."""
    return run_model(config, progress)
