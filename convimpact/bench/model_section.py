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

And the cost of one simulated second (0.3 s in quick mode), per kind, size and backend, all
at the same integrator tolerances (DOP853, rtol 1e-8, atol 1e-10; wall time best of 2, 1 in
quick):

* ``simulation``: the event-driven :func:`convimpact.simulation.simulate` with contacts, on
  chains of n links dropped on the floor
  (:func:`~convimpact.bench.model_problems.dropped_chain`: the tip strikes it) and on random
  revolute trees released from rest above a plane
  (:func:`~convimpact.bench.model_problems.swinging_tree`), planar and spatial; ``ours`` on
  our model, ``pinocchio`` the same run on the same model evaluated by Pinocchio
  (:class:`~convimpact.model.pinocchio_mechanism.PinocchioMechanism` through the protocol:
  M by crba, f by nonLinearEffects, M_dot from the Coriolis matrix, the contact Jacobians'
  exact rates), with the two runs' final-state difference (the chains are chaotic: from about
  20 links the runs part at round-off and their event counts differ, so
  ``wall_per_evaluation`` is the fair ratio there);
* ``free motion``: the same bodies without contacts, ``ours`` by the simulator (canonical
  equations, y = [theta, p]) against ``pinocchio aba``: Pinocchio's articulated-body forward
  dynamics integrated by scipy's DOP853 on y = [q, v] (:func:`aba_free_motion`), the
  recursive O(n) floor of the smooth dynamics.

Chart ``model_scaling.png``: one log-log panel per quantity, time against n, and the cost of
one right-hand-side evaluation of the simulations. The summary states the ratios
ours/Pinocchio (median over the mechanisms of each n), how each cost grows from the smallest
to the largest n, and its growth exponent (:func:`exponent`: the log-log slope, median over
the kinds).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..errors import ConvImpactError
from ..model import contact_jacobian, generalized_forces, mass_matrix
from ..model import recursive as rc
from .model_charts import scaling_chart
from .model_problems import (dropped_chain, pinocchio_twin, random_mechanism, swinging_tree,
                             without_contacts)
from .registry import BenchConfig, Progress, SectionResult, register_section
from .timing import time_call

QUANTITIES = ("M", "f", "Jc")
SIM_QUANTITIES = ("simulation", "free motion")
KINDS = ("planar chain", "planar tree", "spatial chain", "spatial tree")
PINOCCHIO = {"M": "crba", "f": "rnea", "Jc": "computeFrameJacobian"}
#: the peer of "ours" per quantity (default "pinocchio")
PEERS = {"free motion": "pinocchio aba"}


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


SIM_KINDS = ("planar chain", "spatial chain", "planar tree", "spatial tree")
#: integrator tolerances of every simulated second (ours, the Pinocchio backend, ABA)
RTOL, ATOL = 1e-8, 1e-10


def tree_sizes(quick: bool) -> tuple[int, ...]:
    """Numbers of bodies of the swinging trees (simulated)."""
    return (2, 5) if quick else (2, 5, 10, 20, 50)


def _sim_problem(kind: str, n: int, seed: int):
    planar, chain = kind.startswith("planar"), kind.endswith("chain")
    return dropped_chain(n, planar) if chain else swinging_tree(n, planar, seed)


def _best_run(mech, span, y0, n_best):
    from ..simulation import simulate

    best = None
    for _ in range(n_best):
        res = simulate(mech, span, y0, rtol=RTOL, atol=ATOL)
        if best is None or res.wall_time < best.wall_time:
            best = res
    return best


def aba_free_motion(twin: dict, q0, v0, span, n_best: int = 1):
    """Pinocchio's own forward dynamics (``pinocchio.aba``) integrated by scipy's DOP853 at
    the simulator's tolerances, y = [q, v], no contacts: ``(wall time, nfev, final q)``."""
    import time

    from scipy.integrate import solve_ivp

    pin = _pinocchio()
    pm, pd = twin["model"], twin["data"]
    k = pm.nv
    tau = np.zeros(k)

    def rhs(t, y):
        return np.concatenate([y[k:], pin.aba(pm, pd, y[:k], y[k:], tau)])

    best = None
    for _ in range(n_best):
        t0 = time.perf_counter()
        sol = solve_ivp(rhs, span, np.concatenate([q0, v0]), method="DOP853", rtol=RTOL,
                        atol=ATOL)
        wall = time.perf_counter() - t0
        if best is None or wall < best[0]:
            best = (wall, int(sol.nfev), sol.y[:k, -1].copy())
    return best


def _sim_record(kind, n, k, qty, impl, span) -> dict[str, Any]:
    return {"kind": kind, "n_bodies": n, "k": k, "quantity": qty, "implementation": impl,
            "span": list(span)}


def measure_simulations(config: BenchConfig, progress: Progress) -> list[dict[str, Any]]:
    """Records of one simulated second (0.3 s quick) per kind, size and backend: with
    contacts (``simulation``: ours, our simulator on PinocchioMechanism) and without
    (``free motion``: ours, Pinocchio's ABA integrated at the same tolerances)."""
    from ..simulation import simulate

    span = (0.0, 0.3 if config.quick else 1.0)
    sim = span[1] - span[0]
    n_best = 1 if config.quick else 2
    has_pin = _pinocchio() is not None
    records: list[dict[str, Any]] = []
    model, th0, dth0 = dropped_chain(2, True)  # warm-up: the simulator's and impact laws' imports
    simulate(model.mechanism(), (0.0, 0.5), (th0, dth0))
    if has_pin:
        aba_free_motion(pinocchio_twin(model), th0, dth0, (0.0, 0.1))
    for kind in SIM_KINDS:
        ns = chain_sizes(config.quick) if kind.endswith("chain") else tree_sizes(config.quick)
        for n in ns:
            model, th0, dth0 = _sim_problem(kind, n, config.seed)
            twin = pinocchio_twin(model) if has_pin else None
            perm = twin["permutation"] if twin else np.arange(model.n_coordinates)
            inv = np.argsort(perm)
            runs = [("simulation", "ours", model.mechanism(), (th0, dth0)),
                    ("free motion", "ours", without_contacts(model).mechanism(), (th0, dth0))]
            if twin is not None:
                runs.insert(1, ("simulation", "pinocchio", twin["mechanism"],
                                (th0[perm], dth0[perm])))
            finals: dict[tuple[str, str], np.ndarray] = {}
            for qty, impl, mech, y0 in runs:
                rec = _sim_record(kind, n, model.n_coordinates, qty, impl, span)
                try:
                    best = _best_run(mech, span, y0, n_best)
                except ConvImpactError as exc:
                    rec.update(median=None, error=f"{type(exc).__name__}: {exc}"[:300])
                    records.append(rec)
                    continue
                rec.update(median=best.wall_time / sim, wall_time=best.wall_time,
                           nfev=int(best.nfev), n_impacts=len(best.impacts),
                           status=best.status, wall_per_evaluation=best.wall_time / best.nfev,
                           error=None)
                back = inv if impl == "pinocchio" else slice(None)
                finals[(qty, impl)] = np.concatenate([best.theta[-1][back],
                                                      best.dtheta[-1][back]])
                records.append(rec)
            if twin is not None:
                wall, nfev, q_end = aba_free_motion(twin, th0[perm], dth0[perm], span, n_best)
                rec = _sim_record(kind, n, model.n_coordinates, "free motion", "pinocchio aba",
                                  span)
                rec.update(median=wall / sim, wall_time=wall, nfev=nfev, n_impacts=0, status=0,
                           wall_per_evaluation=wall / nfev, error=None)
                if ("free motion", "ours") in finals:
                    rec["final_state_difference"] = float(np.max(np.abs(
                        q_end[inv] - finals[("free motion", "ours")][:model.n_coordinates])))
                records.append(rec)
            if ("simulation", "ours") in finals and ("simulation", "pinocchio") in finals:
                diff = float(np.max(np.abs(finals[("simulation", "ours")]
                                           - finals[("simulation", "pinocchio")])))
                for r in records:
                    if (r["kind"], r["n_bodies"], r["quantity"]) == (kind, n, "simulation"):
                        r["final_state_difference"] = diff
            progress(f"model simulated {kind} n={n}: " + ", ".join(
                f"{r['quantity']} {r['implementation']} {r['median']:.3g} s/s ({r['nfev']} RHS)"
                for r in records if r["kind"] == kind and r["n_bodies"] == n
                and r["quantity"] in SIM_QUANTITIES and r.get("median")))
    return records


def _median(values):
    values = [v for v in values if v is not None]
    return float(np.median(values)) if values else None


def ratio_table(records: list[dict[str, Any]], impl: str = "ours") -> dict[str, dict[int, float]]:
    """Per quantity and n, the median over the kinds of ``impl`` / Pinocchio."""
    out: dict[str, dict[int, float]] = {}
    for qty in QUANTITIES + SIM_QUANTITIES:
        per_n: dict[int, list[float]] = {}
        peer_impl = PEERS.get(qty, "pinocchio")
        for r in records:
            if r["quantity"] != qty or r["implementation"] != impl or r.get("median") is None:
                continue
            peer = [p for p in records if p["quantity"] == qty and p["kind"] == r["kind"]
                    and p["n_bodies"] == r["n_bodies"] and p["implementation"] == peer_impl
                    and p.get("median")]
            if peer:
                key = "wall_per_evaluation" if qty in SIM_QUANTITIES else "median"
                per_n.setdefault(r["n_bodies"], []).append(r[key] / peer[0][key])
        if per_n:
            out[qty] = {n: float(np.median(v)) for n, v in sorted(per_n.items())}
    return out


def exponent(records: list[dict[str, Any]], qty: str, impl: str,
             key: str = "median") -> float | None:
    """Median over the kinds of the least-squares slope of log(time) against log(n): the
    cost grows as n^exponent (None with fewer than three sizes)."""
    slopes = []
    for kind in {r["kind"] for r in records if r["quantity"] == qty}:
        rows = [r for r in records if r["quantity"] == qty and r["kind"] == kind
                and r["implementation"] == impl and r.get(key)]
        if len({r["n_bodies"] for r in rows}) >= 3:
            x = np.log([r["n_bodies"] for r in rows])
            y = np.log([r[key] for r in rows])
            slopes.append(float(np.polyfit(x, y, 1)[0]))
    return _median(slopes)


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
            x_ours, x_pin = exponent(records, qty, "ours"), exponent(records, qty, "pinocchio")
            if x_ours is not None and x_pin is not None:
                text += (f"; growth exponent (log-log slope, median over the kinds): ours "
                         f"{x_ours:.2f}, Pinocchio {x_pin:.2f}")
        out.append(text)
    for qty in SIM_QUANTITIES:
        sims = [r for r in records if r["quantity"] == qty and r.get("median")]
        if not sims:
            continue
        impls = sorted({r["implementation"] for r in sims})
        parts = []
        for impl in impls:
            rows = sorted((r for r in sims if r["implementation"] == impl),
                          key=lambda r: (r["kind"], r["n_bodies"]))
            x = exponent(records, qty, impl)
            xe = exponent(records, qty, impl, "wall_per_evaluation")
            parts.append(f"{impl} {min(r['median'] for r in rows):.3g}-"
                         f"{max(r['median'] for r in rows):.3g} s"
                         + (f" (growth exponent {x:.2f}; per RHS evaluation {xe:.2f})"
                            if x is not None and xe is not None else ""))
        what = ("with contacts (event-driven; chains dropped on the floor, random trees "
                "swinging above a plane)" if qty == "simulation" else
                "of the free motion (no contacts; ours: the canonical equations, Pinocchio: "
                "ABA, both DOP853 at rtol 1e-8)")
        text = (f"one simulated second {what}, wall time per simulated second over n = "
                f"{min(r['n_bodies'] for r in sims)}-{max(r['n_bodies'] for r in sims)}: "
                + "; ".join(parts))
        if qty in ratios:
            text += (f"; ours/{PEERS.get(qty, 'pinocchio')} per right-hand-side evaluation "
                     "(median over the kinds): " + ", ".join(
                         f"n={n}: {v:.2g}" for n, v in ratios[qty].items()))
        diffs = [r["final_state_difference"] for r in sims if "final_state_difference" in r
                 and r["n_bodies"] <= 5]
        if diffs:
            text += f"; final states of the two runs differ by at most {max(diffs):.1e} (n <= 5)"
        out.append(text)
    return out


def run_model(config: BenchConfig, progress: Progress) -> SectionResult:
    """Measure and chart (see the module docstring)."""
    progress("model: compiling the recursive algorithms (cached after the first run)")
    model, theta, dtheta = random_mechanism(2, True, True, config.seed)
    model.mechanism().generalized_forces(0.0, theta, dtheta)
    records = measure_evaluations(config, progress)
    records += measure_simulations(config, progress)
    exponents = {q: {impl: x for impl in
                     ("ours", "ours (unchecked)", "pinocchio", "pinocchio aba")
                     if (x := exponent(records, q, impl)) is not None}
                 for q in QUANTITIES + SIM_QUANTITIES}
    figures = [scaling_chart(records, config.out, exponents)]
    pin = _pinocchio()
    meta = {
        "pinocchio": None if pin is None else str(pin.__version__),
        "sizes": list(sizes(config.quick)), "chain_sizes": list(chain_sizes(config.quick)),
        "tree_sizes": list(tree_sizes(config.quick)),
        "exponents": exponents,
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
            "simulation": "convimpact.simulate (DOP853, rtol 1e-8, atol 1e-10) of the dropped "
                          "chain / swinging tree; 'pinocchio': the same run on "
                          "PinocchioMechanism (Pinocchio's coordinates)",
            "free motion": "the same bodies without contacts: 'ours' convimpact.simulate, "
                           "'pinocchio aba' scipy DOP853 on y = [q, v] with pinocchio.aba, "
                           "same tolerances",
            "exponents": "least-squares slope of log(time) against log(n), median over kinds",
        },
    }
    return SectionResult("model", records, figures, summary_sentences(records), meta)


@register_section("model", "model evaluation against the number of bodies: M, f, Jc and one "
                           "simulated second, ours and Pinocchio's")
def model_section(config: BenchConfig, progress: Progress) -> SectionResult:
    """Run the section (see the module docstring)."""
    return run_model(config, progress)
