"""Section ``landscape``: points per second of the dissipation landscapes on one planar state.

The state is the paper's planar double pendulum, case (a) of Section 9.2 (the rod-on-floor
demo of :mod:`convimpact.cli` when the scenes do not import). Measured:

* :func:`convimpact.studies.landscape.closed_form_landscape`, vectorized over a grid of e and signed
  mu (the paper's Figs. 5-7);
* :func:`convimpact.studies.landscape.contact_landscape` for every law on a grid large enough
  for the compiled batch (:data:`~convimpact.studies.landscape.BATCH_MIN_POINTS` points or more:
  one :func:`~convimpact.impact.batch.impacts.contact_impulses` call, then numpy over the grid);
* :func:`convimpact.studies.landscape.law_landscape`, one ``solve_problem`` per point, for every law
  and every method registered for it (mu >= 0).

Each figure is grid points divided by the median wall time of the whole landscape call (a
one-point call first, untimed, compiles what needs compiling).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..impact import LAWS, available_methods
from ..studies.landscape import (BATCH_MIN_POINTS, closed_form_landscape, contact_landscape,
                                 law_landscape)
from .registry import BenchConfig, Progress, SectionResult, register_section
from .timing import time_call

#: landscapes slower than this (seconds, first timed run) are not repeated
REPEAT_BELOW = 1.0


def planar_state() -> tuple[dict[str, Any], str]:
    """Raw arguments of the fixed planar impact state and its name."""
    try:
        from convimpact.problems.pendulum_planar import impact_arguments

        args = impact_arguments("a")
        return {k: args[k] for k in ("M", "Jc", "dq", "C")}, "pendulum_planar case a"
    except Exception:  # scenes unavailable: the demo's rod, always present
        from ..cli import rod_on_floor

        M, Jc, dq = rod_on_floor(30.0)
        return {"M": M, "Jc": Jc, "dq": dq, "C": None}, "rod_on_floor 30 deg"


def _time_landscape(fn, config: BenchConfig) -> tuple[float, float, Any]:
    """(median seconds, iqr, result) of a landscape call, repeated only when it is cheap."""
    t, res = time_call(fn, 1, 0.0, warmup=1)
    if t.median < REPEAT_BELOW and config.repeat > 1:
        t, res = time_call(fn, config.repeat, 0.0, warmup=0)
    return t.median, t.iqr, res


@register_section("landscape", "landscape throughput: points per second, vectorized closed "
                               "form against per-point law solves")
def landscape_section(config: BenchConfig, progress: Progress) -> SectionResult:
    """Run item 2 of the benchmark (see the module docstring)."""
    from .charts import throughput_chart

    state, state_name = planar_state()
    ne_cf, nmu_cf = (41, 81) if config.quick else (201, 401)
    ne, nmu = (4, 5) if config.quick else (12, 12)
    records = []

    e_cf = np.linspace(0.0, 1.0, ne_cf)
    mu_cf = np.linspace(-1.0, 1.0, nmu_cf)
    wall, iqr, L = _time_landscape(lambda: closed_form_landscape(**state, e=e_cf, mu=mu_cf),
                                   config)
    records.append({"label": "closed-form (vectorized)", "law": "pereira-nikravesh",
                    "method": "closed-form", "function": "closed_form_landscape",
                    "grid": [ne_cf, nmu_cf], "points": ne_cf * nmu_cf, "wall_time": wall,
                    "wall_time_iqr": iqr, "points_per_second": ne_cf * nmu_cf / wall,
                    "failed_points": int(np.sum(L.failed)), "jammed_points": int(np.sum(L.jammed))})
    progress(f"landscape closed-form vectorized: {ne_cf * nmu_cf / wall:.3g} points/s")

    nb = 150 if config.quick else 201  # at least BATCH_MIN_POINTS points: the batch
    e_b, mu_b = np.linspace(0.0, 1.0, nb), np.linspace(0.0, 1.0, nb)
    assert nb * nb >= BATCH_MIN_POINTS
    for law in LAWS:
        def batch_call(law=law):
            return contact_landscape(**state, e=e_b, mu=mu_b, law=law, progress=False)

        wall, iqr, L = _time_landscape(batch_call, config)
        records.append({"label": f"{law} / batch", "law": law, "method": "batch",
                        "function": "contact_landscape", "grid": [nb, nb], "points": nb * nb,
                        "wall_time": wall, "wall_time_iqr": iqr,
                        "points_per_second": nb * nb / wall,
                        "failed_points": int(np.sum(L.failed)),
                        "jammed_points": int(np.sum(L.jammed)), "error": None})
        progress(f"landscape {law}/batch (contact_landscape): {nb * nb / wall:.3g} points/s")

    e = np.linspace(0.0, 1.0, ne)
    mu = np.linspace(0.0, 1.0, nmu)
    for law in LAWS:
        for method in available_methods(law):
            def call(law=law, method=method, e=e, mu=mu):
                return law_landscape(**state, e=e, mu=mu, law=law, method=method,
                                     progress=False)

            n = ne * nmu
            try:
                law_landscape(**state, e=e[:1], mu=mu[-1:], law=law, method=method,
                              progress=False)
                wall, iqr, L = _time_landscape(call, config)
            except Exception as exc:  # a whole landscape failing is recorded, not fatal
                records.append({"label": f"{law} / {method}", "law": law, "method": method,
                                "function": "law_landscape", "grid": [ne, nmu], "points": n,
                                "wall_time": None, "points_per_second": None,
                                "error": f"{type(exc).__name__}: {exc}"[:300]})
                progress(f"landscape {law}/{method}: failed ({type(exc).__name__})")
                continue
            records.append({"label": f"{law} / {method}", "law": law, "method": method,
                            "function": "law_landscape", "grid": [ne, nmu], "points": n,
                            "wall_time": wall, "wall_time_iqr": iqr,
                            "points_per_second": n / wall,
                            "failed_points": int(np.sum(L.failed)),
                            "jammed_points": int(np.sum(L.jammed)), "error": None})
            progress(f"landscape {law}/{method}: {n / wall:.3g} points/s")
    fig = throughput_chart(records, config.out,
                           f"landscape throughput on {state_name} (law / method)")
    cf = records[0]
    per_point = [r for r in records[1:] if r["points_per_second"]]
    summary = []
    pn_cf = next((r for r in per_point if r["law"] == "pereira-nikravesh"
                  and r["method"] == "closed-form"), None)
    if pn_cf:
        summary.append(
            f"closed_form_landscape (vectorized) evaluates {cf['points_per_second']:.3g} "
            f"points/s, {cf['points_per_second'] / pn_cf['points_per_second']:.3g}x the "
            f"per-point closed form through law_landscape ({pn_cf['points_per_second']:.3g} "
            "points/s)")
    batch = {r["law"]: r for r in per_point if r["method"] == "batch"}
    fast = {r["law"]: r for r in per_point if r["method"] == "fast"}
    if batch:
        rates = [r["points_per_second"] for r in batch.values()]
        gains = [batch[law]["points_per_second"] / fast[law]["points_per_second"]
                 for law in batch if law in fast]
        summary.append(
            f"contact_landscape on the compiled batch ({batch[next(iter(batch))]['points']} "
            f"points, every law): {min(rates):.3g}..{max(rates):.3g} points/s ("
            + ", ".join(f"{law} {r['points_per_second']:.3g}" for law, r in batch.items())
            + f"), {min(gains):.3g}..{max(gains):.3g}x the per-point fast landscape")
    for law in ("ccp", "coulomb", "dissipative"):
        rows = {r["method"]: r for r in per_point if r["law"] == law}
        if "fast" in rows and "clarabel" in rows:
            summary.append(
                f"{law} landscape: fast {rows['fast']['points_per_second']:.3g} points/s, "
                f"clarabel {rows['clarabel']['points_per_second']:.3g}"
                + (f", cvxpy {rows['cvxpy']['points_per_second']:.3g}" if "cvxpy" in rows
                   else "") + " points/s")
    meta = {"state": state_name, "closed_form_grid": {"e": [0.0, 1.0, ne_cf],
                                                      "mu": [-1.0, 1.0, nmu_cf]},
            "law_grid": {"e": [0.0, 1.0, ne], "mu": [0.0, 1.0, nmu]},
            "definition": "points_per_second = grid points / median wall time of the call"}
    return SectionResult("landscape", records, [fig], summary, meta)
