"""The ``derivatives`` section's several-contact part: exact impact derivatives at 2, 4 and 8
simultaneous spatial contacts, against the solve and against central finite differences.

The problems (:func:`several_problem`) are random but well conditioned and built
deterministically from the config's seed: k = 3 n + 2 coordinates, M = I + 0.1 A A^T / k,
contact rows J = [I 0] + 0.25 N(0, 1) / sqrt(k) (full row rank, W = J M^-1 J^T near I), every
contact approaching (v_n ~ -U(0.5, 1.5), v_t ~ N(0, 0.5^2)), e = 0.5, mu_i ~ U(0.2, 0.8) per
contact. The modes reached (stick, slide, separate per contact) are recorded, not prescribed.

Three calls are timed, the median process CPU time per call (:func:`timed_within`):

* ``solve``: ``resolve_impact(M, Jc, dq, e, mu, law=law)``, the default method (``interior``
  for ccp, coulomb and dissipative, ``clarabel`` for pereira-nikravesh and stronge);
* ``solve + derivatives``: the same with ``derivatives=True`` (every jacobian: dq, M, Jc, e,
  mu of dq+ and of the impulse);
* ``central FD``: the jacobian of dq+ with respect to **dq, e and mu only**, central
  differences of the public call at the solver tolerance 1e-12 (that its step 1e-6 needs):
  2 (k + 1 + n) calls. The differences with respect to M (k (k + 1) / 2 symmetric pairs) and
  Jc (3 n k entries) would need 2 (k (k + 1) / 2 + 3 n k) calls more -- 1 950 at n = 8 --
  so their cost is *estimated* as that count times the measured time per call, not run.

Accuracy: per key (dq, e, mu), max |FD - analytic| / max |analytic|, the analytic jacobian
taken from the same tolerance-1e-12 answer as the differences.
"""

from __future__ import annotations

import math
import time
from typing import Any, Callable

import numpy as np

from .registry import BenchConfig

SEVERAL_LAWS = ("ccp", "coulomb", "dissipative", "pereira-nikravesh", "stronge")
N_CONTACTS = (2, 4, 8)
#: contact dimension (spatial) and coordinates beyond the contact rows
DIM = 3
EXTRA = 2
E = 0.5
STEP = 1e-6
#: solver of the differences (and of the analytic jacobian they are compared with): a tight
#: tolerance, so that the solver's error over the step stays below the differences' own
FD_OPTIONS = {
    "ccp": {"method": "interior", "tol": 1e-12},
    "coulomb": {"method": "interior", "tol": 1e-12},
    "dissipative": {"method": "interior", "tol": 1e-12},
    "pereira-nikravesh": {"method": "clarabel", "tol": 1e-12},
    "stronge": {"method": "clarabel", "tol": 1e-12},
}
#: CPU seconds a slow measurement may take before its batches stop (full, quick)
BUDGET = {False: 3.0, True: 0.5}


def several_problem(seed: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float,
                                                 np.ndarray]:
    """(M, Jc (n, 3, k), dq, e, mu (n,)) of a well-conditioned random impact of ``n``
    spatial contacts (module docstring)."""
    rng = np.random.default_rng([seed, n, DIM, 27])
    N = n * DIM
    k = N + EXTRA
    A = rng.standard_normal((k, k))
    M = np.eye(k) + 0.1 * A @ A.T / k
    J = np.zeros((N, k))
    J[:, :N] = np.eye(N)
    J += 0.25 * rng.standard_normal((N, k)) / np.sqrt(k)
    v = np.zeros(N)
    for i in range(n):
        v[i * DIM] = -rng.uniform(0.5, 1.5)
        v[i * DIM + 1:(i + 1) * DIM] = 0.5 * rng.standard_normal(DIM - 1)
    dq = np.linalg.lstsq(J, v, rcond=None)[0]
    mu = rng.uniform(0.2, 0.8, size=n)
    return 0.5 * (M + M.T), J.reshape(n, DIM, k), dq, E, mu


def timed_within(fn: Callable[[], Any], repeat: int, budget: float
                 ) -> tuple[dict[str, float], Any]:
    """Median process CPU (and wall) time of ``fn`` over up to ``repeat`` calls after a
    warm-up call, stopping once ``budget`` CPU seconds are spent (at least one timed call):
    for calls of 10 ms to seconds, where batches of several calls would cost too much."""
    value = fn()
    cpu, wall = [], []
    spent = 0.0
    for _ in range(max(1, repeat)):
        c, w = time.process_time(), time.perf_counter()
        value = fn()
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
        spent += cpu[-1]
        if spent >= budget:
            break
    return {"cpu": float(np.median(cpu)), "wall": float(np.median(wall)),
            "n_timed": len(cpu)}, value


def fd_dq_e_mu(call, dq: np.ndarray, e: float, mu: np.ndarray) -> dict[str, np.ndarray]:
    """Central differences of ``call(dq, e, mu) -> dq_plus`` with respect to dq (k x k), the
    scalar e (k,) and the per-contact mu (k x n), step :data:`STEP` (dq: times max |dq|)."""
    h = STEP * float(np.abs(dq).max())
    out = {"dq": np.stack([(call(dq + h * z, e, mu) - call(dq - h * z, e, mu)) / (2 * h)
                           for z in np.eye(dq.size)], axis=-1),
           "e": (call(dq, e + STEP, mu) - call(dq, e - STEP, mu)) / (2 * STEP),
           "mu": np.stack([(call(dq, e, mu + STEP * z) - call(dq, e, mu - STEP * z))
                           / (2 * STEP) for z in np.eye(mu.size)], axis=-1)}
    return out


def fd_calls_several(k: int, n: int) -> int:
    """Calls of :func:`fd_dq_e_mu`: two per entry of dq, e and mu."""
    return 2 * (k + 1 + n)


def fd_calls_m_jc(k: int, n: int, d: int = DIM) -> int:
    """Further calls a central-difference jacobian with respect to M (symmetric pairs) and Jc
    would need."""
    return 2 * (k * (k + 1) // 2 + n * d * k)


def measure_several(law: str, n: int, config: BenchConfig,
                    batch_time: float) -> dict[str, Any]:
    """Time and accuracy of ``law``'s derivative at ``n`` contacts (module docstring); a law
    whose several-contact derivative does not apply to the problem gives a row with
    ``skipped`` (the error's message) and no timings."""
    import convimpact as ci
    from convimpact.errors import NotSupportedError

    from .timing import timed

    M, Jc, dq, e, mu = several_problem(config.seed, n)
    k = dq.size
    tight = FD_OPTIONS[law]
    row: dict[str, Any] = {"law": law, "n_contacts": n, "d": DIM, "k": k,
                           "delassus_condition": float(np.linalg.cond(
                               Jc.reshape(-1, k) @ np.linalg.solve(M, Jc.reshape(-1, k).T))),
                           "fd_options": tight}
    try:
        exact = ci.resolve_impact(M, Jc, dq, e, mu, law=law, derivatives=True, **tight)
    except NotSupportedError as exc:
        row["skipped"] = str(exc)
        return row

    def plain():
        return ci.resolve_impact(M, Jc, dq, e, mu, law=law)

    def with_derivatives():
        return ci.resolve_impact(M, Jc, dq, e, mu, law=law, derivatives=True)

    def dq_plus(dq_, e_, mu_):
        return ci.resolve_impact(M, Jc, dq_, e_, mu_, law=law, **tight).dq_plus

    budget = BUDGET[config.quick]
    t_solve, r = timed(plain, config.repeat, batch_time)
    t_der, rd = timed(with_derivatives, config.repeat, batch_time)
    t_fd, fd = timed_within(lambda: fd_dq_e_mu(dq_plus, dq, e, mu), config.repeat, budget)
    dev = {name: float(np.abs(fd[name] - exact.jacobian[name]).max())
           / max(float(np.abs(exact.jacobian[name]).max()), 1e-300) for name in fd}
    calls = fd_calls_several(k, n)
    per_call = t_fd["cpu"] / calls
    more = fd_calls_m_jc(k, n)
    row.update({
        "regime": list(rd.regime), "one_sided": list(rd.derivatives.one_sided),
        "time_solve": t_solve["cpu"], "time_derivatives": t_der["cpu"], "time_fd": t_fd["cpu"],
        "wall_solve": t_solve["wall"], "wall_derivatives": t_der["wall"],
        "wall_fd": t_fd["wall"],
        "calls_per_batch": [t_solve["n_inner"], t_der["n_inner"]], "fd_timed": t_fd["n_timed"],
        "fd_calls": calls, "fd_time_per_call": per_call,
        "fd_calls_m_jc": more, "fd_estimate_all": per_call * (calls + more),
        "derivative_over_solve": t_der["cpu"] / t_solve["cpu"],
        "fd_over_derivative": t_fd["cpu"] / t_der["cpu"],
        "fd_deviation": max(dev.values()), "fd_deviation_by_key": dev,
        "answer_matches": bool(np.allclose(r.dq_plus, rd.dq_plus, rtol=1e-12, atol=1e-14)),
        "regime_at_fd_tolerance": list(exact.regime),
    })
    if not math.isfinite(row["fd_deviation"]):
        row["fd_deviation"] = None
    return row


#: laws solved on the compiled interior-point lane (the others by conic programs)
LANE_LAWS = ("ccp", "coulomb", "dissipative")


def _span(values, fmt) -> str:
    lo, hi = min(values), max(values)
    return f"{lo:{fmt}}-{hi:{fmt}}" if f"{lo:{fmt}}" != f"{hi:{fmt}}" else f"{lo:{fmt}}"


def several_summary(rows: list[dict[str, Any]]) -> list[str]:
    """Summary sentences of the several-contact rows (ranges of this run's medians)."""
    done = [r for r in rows if "skipped" not in r]
    if not done:
        return []
    out = []
    ns = sorted({r["n_contacts"] for r in done})
    ks = sorted({r["k"] for r in done})
    groups = (([r for r in done if r["law"] in LANE_LAWS], "compiled interior-point lane"),
              ([r for r in done if r["law"] not in LANE_LAWS], "cone programs"))
    parts = []
    for at, how in groups:
        if at:
            laws = ", ".join(dict.fromkeys(r["law"] for r in at))
            parts.append(
                f"{laws} ({how}, solve {_span([1e3 * r['time_solve'] for r in at], '.2g')} "
                f"ms): with derivatives=True "
                f"{_span([1e3 * r['time_derivatives'] for r in at], '.2g')} ms, "
                f"{_span([r['derivative_over_solve'] for r in at], '.1f')}x the solve")
    out.append(f"{', '.join(map(str, ns))} spatial contacts (k = {', '.join(map(str, ks))}): "
               + "; ".join(parts)
               + (" (ratios near 1: the derivative's algebra is within the cone program's "
                  "run-to-run spread)" if groups[1][0] else ""))
    fd = []
    for n in ns:
        at = [r for r in done if r["n_contacts"] == n]
        fd.append(f"{_span([r['fd_over_derivative'] for r in at], '.0f')}x at {n} "
                  f"({at[0]['fd_calls']} calls)")
    est = []
    for n in ns:
        at = [r for r in done if r["n_contacts"] == n]
        est.append(f"{_span([r['fd_estimate_all'] / r['time_derivatives'] for r in at], '.0f')}"
                   f"x at {n} ({at[0]['fd_calls'] + at[0]['fd_calls_m_jc']} calls)")
    slowest = max(done, key=lambda r: r["fd_estimate_all"])
    out.append(
        "several contacts: central differences of dq+ in dq, e and mu only (tol 1e-12) take "
        + ", ".join(fd) + " the analytic jacobians (which hold every argument); with M and Jc "
        "too, estimated from the measured time per call (not run), " + ", ".join(est)
        + f" -- {slowest['fd_estimate_all']:.0f} s for {slowest['law']} at "
        f"{slowest['n_contacts']} contacts")
    dev = [r["fd_deviation"] for r in done if r["fd_deviation"] is not None]
    out.append(f"several contacts: central differences (dq, e, mu) agree with the analytic "
               f"jacobians to {min(dev):.1e}-{max(dev):.1e} (relative; every law and size)")
    skipped = [f"{r['law']} n = {r['n_contacts']}" for r in rows if "skipped" in r]
    if skipped:
        out.append(f"several-contact derivative not applicable (skipped): {', '.join(skipped)}")
    return out
