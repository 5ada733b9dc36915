"""Section ``derivatives``: the cost of an impact's exact derivatives next to the solve it
differentiates, and against central finite differences (time and accuracy).

For every law with a single-contact derivative, planar and spatial (k = 6 joint coordinates, a
random SPD M and contact Jacobian, seed from the config), in its stick and slide modes (mu
chosen per mode, the regime reached recorded), three calls are timed
(:func:`timed`: the median process CPU time per call over the config's batches of at least
20 ms; the machine is shared, and the wall time, recorded too, also counts the other
processes' turns):

* ``solve``: ``resolve_impact(...)``, the answer alone (its compiled lane);
* ``solve + derivatives``: ``resolve_impact(..., derivatives=True)``, the answer and every
  jacobian (dq, M, Jc, e, mu; e_t for chatterjee-ruina) of dq+ and of the impulse;
* ``central FD``: the same jacobians of dq+ by central differences of the public call
  (2 calls per argument entry: k for dq, k (k + 1) / 2 symmetric pairs of M, d k for Jc, e, mu:
  2 (k + k (k + 1) / 2 + d k + 2) calls; the step 1e-6 of each argument's scale).

Accuracy: the largest deviation of the finite differences from the analytic jacobians,
relative to each key's largest entry, or to max |dq+| / max(1, max |argument|) when that is
larger (a derivative that nearly vanishes, Stronge's in mu while the contact sticks, say, is
compared on the answer's scale); the differences' own error, truncation h^2 and round-off
eps / h, sets it: about 1e-9 to 1e-10 is what they can show.

Stronge's law is differentiated through its impulse-space integration: planar in closed form,
spatial by the variational equations integrated in pure Python (about 20-30 ms a call, against
the compiled solve's tens of microseconds).

Several contacts (2, 4, 8, spatial; ccp, coulomb, dissipative, pereira-nikravesh, stronge):
:mod:`convimpact.bench.derivatives_several`. Charts: :mod:`convimpact.bench.derivatives_charts`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .registry import BenchConfig, Progress, SectionResult, register_section
from .timing import timed

LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge", "chatterjee-ruina")
#: joint coordinates of the measured impacts
K = 6
#: larger systems, measured for a few laws and modes: the finite differences' call count
#: grows as k^2 / 2 (M's symmetric pairs), the analytic jacobian's cost slowly
LARGE_K = 24
LARGE = (("pereira-nikravesh", 3, "slide"), ("ccp", 3, "slide"), ("coulomb", 2, "stick"))
#: mu per mode (the regime reached is recorded: a random W may stick or slide elsewhere)
MODE_MU = {"slide": 0.1, "stick": 3.0}
E = 0.4
E_T = 0.3
REL_STEP = 1e-6
PATHS = ("solve", "solve + derivatives", "central FD")
#: shortest timed batch (full, quick), seconds
BATCH_TIME = {False: 0.02, True: 0.005}


def problem(seed: int, d: int, k: int = K) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M, Jc, dq): a random SPD M, a contact Jacobian and dq with contact velocity
    (-1, N(0, 1)...) (approaching and slipping)."""
    rng = np.random.default_rng([seed, d, k])
    A = rng.normal(size=(k, k))
    M = A @ A.T + k * np.eye(k)
    Jc = rng.normal(size=(d, k))
    v = np.concatenate(([-1.0], rng.normal(size=d - 1)))
    dq = np.linalg.lstsq(Jc, v, rcond=None)[0]
    return 0.5 * (M + M.T), Jc, dq


def fd_jacobian(call, M, Jc, dq, e, mu, e_t) -> dict[str, np.ndarray]:
    """Central differences of dq+ (``call(M, Jc, dq, e, mu, e_t) -> dq_plus``), laid out as
    ``jacobian`` (M's symmetric pairs: jacobian[..., i, j] + [..., j, i] for i != j)."""
    k = dq.size
    out: dict[str, np.ndarray] = {}

    def cd(f, h):
        return (f(h) - f(-h)) / (2.0 * h)

    h = REL_STEP * np.abs(dq).max()
    out["dq"] = np.stack([cd(lambda s: call(M, Jc, dq + s * z, e, mu, e_t), h)
                          for z in np.eye(k)], axis=-1)
    h = REL_STEP * np.abs(M).max()
    pairs = np.zeros((k, k, k))
    for i in range(k):
        for j in range(i, k):
            D = np.zeros((k, k))
            D[i, j] = D[j, i] = 1.0
            pairs[:, i, j] = cd(lambda s: call(M + s * D, Jc, dq, e, mu, e_t), h)
    out["M_pairs"] = pairs
    h = REL_STEP * np.abs(Jc).max()
    dj = np.zeros((k,) + Jc.shape)
    for idx in np.ndindex(*Jc.shape):
        D = np.zeros(Jc.shape)
        D[idx] = 1.0
        dj[(slice(None),) + idx] = cd(lambda s: call(M, Jc + s * D, dq, e, mu, e_t), h)
    out["Jc"] = dj
    out["e"] = cd(lambda s: call(M, Jc, dq, e + s, mu, e_t), REL_STEP)
    out["mu"] = cd(lambda s: call(M, Jc, dq, e, mu + s, e_t), REL_STEP)
    if e_t is not None:
        out["e_t"] = cd(lambda s: call(M, Jc, dq, e, mu, e_t + s), REL_STEP)
    return out


def fd_calls(k: int, d: int, tangential: bool) -> int:
    return 2 * (k + k * (k + 1) // 2 + d * k + 2 + int(tangential))


def deviations(jac, fd, floors: dict[str, float] | None = None) -> dict[str, float]:
    """Per key, max |FD - analytic| / max(max |analytic|, floors[key]) (M compared on its
    symmetric pairs)."""
    out = {}
    floors = floors or {}
    for name, ref in fd.items():
        if name == "M_pairs":
            JM = np.asarray(jac["M"])
            k = JM.shape[-1]
            a = np.where(np.eye(k, dtype=bool), JM, JM + np.swapaxes(JM, -1, -2))
            iu = np.triu_indices(k)
            a, ref, name = a[:, iu[0], iu[1]], ref[:, iu[0], iu[1]], "M"
        else:
            a = np.asarray(jac[name])
        scale = max(float(np.abs(a).max()), floors.get(name, 0.0), 1e-300)
        out[name] = float(np.abs(a - ref).max()) / scale
    return out


def measure(law: str, d: int, mode: str, config: BenchConfig,
            k: int = K) -> dict[str, Any] | None:
    import convimpact as ci
    from convimpact.impact.laws import TANGENTIAL_LAWS, law_module

    if getattr(law_module(law), "impulse_derivative", None) is None:
        return None
    M, Jc, dq = problem(config.seed, d, k)
    e_t = E_T if law in TANGENTIAL_LAWS else None
    mu = MODE_MU[mode]

    def solve(**kw):
        return ci.resolve_impact(M, Jc, dq, e=E, mu=mu, law=law, e_t=e_t, **kw)

    def dq_plus(M_, Jc_, dq_, e_, mu_, et_):
        return ci.resolve_impact(M_, Jc_, dq_, e=e_, mu=mu_, law=law, e_t=et_).dq_plus

    # batches of at least BATCH_TIME: the FD jacobian takes about a millisecond, so shorter
    # batches would hold one or two calls, too few against bursts of load on a shared machine
    batch = max(config.min_batch_time, BATCH_TIME[config.quick])
    t_solve, r = timed(solve, config.repeat, batch)
    t_der, rd = timed(lambda: solve(derivatives=True), config.repeat, batch)
    t_fd, fd = timed(lambda: fd_jacobian(dq_plus, M, Jc, dq, E, mu, e_t), config.repeat,
                     batch)
    size = float(np.abs(rd.dq_plus).max())
    floors = {name: size / max(1.0, float(np.abs(value).max())) for name, value in
              (("dq", dq), ("M", M), ("Jc", Jc), ("e", E), ("mu", mu), ("e_t", e_t or 0.0))}
    dev = deviations(rd.jacobian, fd, floors)
    return {
        "law": law, "d": d, "k": k, "mode": mode, "mu": mu, "regime": rd.regime,
        "one_sided": bool(rd.derivatives.one_sided),
        "time_solve": t_solve["cpu"], "time_derivatives": t_der["cpu"], "time_fd": t_fd["cpu"],
        "wall_solve": t_solve["wall"], "wall_derivatives": t_der["wall"],
        "wall_fd": t_fd["wall"], "calls_per_batch": [t["n_inner"] for t in
                                                      (t_solve, t_der, t_fd)],
        "fd_calls": fd_calls(k, d, e_t is not None),
        "derivative_over_solve": t_der["cpu"] / t_solve["cpu"],
        "fd_over_derivative": t_fd["cpu"] / t_der["cpu"],
        "fd_deviation": max(dev.values()), "fd_deviation_by_key": dev,
        "answer_matches": bool(np.allclose(r.dq_plus, rd.dq_plus, rtol=1e-12, atol=1e-14)),
        "derivative_modes": list(rd.derivatives.modes),
    }


#: laws of the quick run (one of each derivative's kind: closed form, fixed point, Stronge's
#: integration, the tangential law)
QUICK_LAWS = ("pereira-nikravesh", "coulomb", "stronge", "chatterjee-ruina")
#: several-contact runs of the quick run: (law, n contacts)
QUICK_SEVERAL = (("ccp", 2), ("stronge", 2))


def _single_contact(config: BenchConfig, progress: Progress) -> tuple[list, list]:
    records, skipped = [], []
    for law in (QUICK_LAWS if config.quick else LAWS):
        for d in (2, 3):
            for mode in MODE_MU:
                rec = measure(law, d, mode, config)
                if rec is None:
                    skipped.append(law)
                    break
                progress(f"derivatives {law} d={d} {rec['regime']}: solve "
                         f"{1e6 * rec['time_solve']:.1f} µs, with derivatives "
                         f"{1e6 * rec['time_derivatives']:.1f} µs, central FD "
                         f"{1e6 * rec['time_fd']:.0f} µs; FD deviation "
                         f"{rec['fd_deviation']:.1e}")
                records.append({"part": "one contact", **rec})
            if law in skipped:
                break
    if not config.quick:
        for law, d, mode in LARGE:
            rec = measure(law, d, mode, config, LARGE_K)
            if rec is not None:
                progress(f"derivatives {law} d={d} k={LARGE_K} {rec['regime']}: with "
                         f"derivatives {1e6 * rec['time_derivatives']:.1f} µs, central FD "
                         f"{1e6 * rec['time_fd']:.0f} µs")
                records.append({"part": "one contact", **rec})
    return records, skipped


def _several_contacts(config: BenchConfig, progress: Progress) -> list:
    from .derivatives_several import N_CONTACTS, SEVERAL_LAWS, measure_several

    runs = QUICK_SEVERAL if config.quick else [(law, n) for law in SEVERAL_LAWS
                                                for n in N_CONTACTS]
    batch = max(config.min_batch_time, BATCH_TIME[config.quick])
    rows = []
    for law, n in runs:
        row = measure_several(law, n, config, batch)
        if "skipped" in row:
            progress(f"derivatives {law} {n} contacts: skipped ({row['skipped']})")
        else:
            progress(f"derivatives {law} {n} contacts (k = {row['k']}, "
                     f"{'/'.join(sorted(set(row['regime'])))}): solve "
                     f"{1e3 * row['time_solve']:.2f} ms, with derivatives "
                     f"{1e3 * row['time_derivatives']:.2f} ms, central FD (dq, e, mu) "
                     f"{1e3 * row['time_fd']:.0f} ms; FD deviation {row['fd_deviation']:.1e}")
        rows.append({"part": "several contacts", **row})
    return rows


def _single_summary(records: list, skipped: list) -> list[str]:
    summary = []
    small = [r for r in records if r["k"] == K]
    large = [r for r in records if r["k"] != K]
    fast = [r for r in small if not (r["law"] == "stronge" and r["d"] == 3)]
    stronge3 = [r for r in small if r["law"] == "stronge" and r["d"] == 3]
    if fast:
        ratio = [r["derivative_over_solve"] for r in fast]
        fd = [r["fd_over_derivative"] for r in fast]
        tder = [1e6 * r["time_derivatives"] for r in fast]
        summary.append(
            f"one contact, k = {K}: resolve_impact with derivatives=True takes "
            f"{min(tder):.0f}-{max(tder):.0f} µs CPU, {min(ratio):.0f}-{max(ratio):.0f}x the "
            f"solve alone (median {np.median(ratio):.0f}x; every law planar, every law but "
            f"stronge spatial); a central-difference jacobian of dq+ in every argument "
            f"({min(r['fd_calls'] for r in fast)}-{max(r['fd_calls'] for r in fast)} calls) "
            f"takes {min(fd):.1f}-{max(fd):.1f}x the analytic one")
    if stronge3:
        summary.append(
            "stronge spatial, one contact: the derivative integrates the variational "
            "equations of the impulse-space integration in pure Python, "
            + " and ".join(f"{1e3 * r['time_derivatives']:.0f} ms ({r['regime']})"
                           for r in stronge3)
            + f" against the compiled solve's "
            f"{min(1e6 * r['time_solve'] for r in stronge3):.0f}-"
            f"{max(1e6 * r['time_solve'] for r in stronge3):.0f} µs; central differences "
            f"({stronge3[0]['fd_calls']} calls of the compiled solve) take "
            + " and ".join(f"{1e3 * r['time_fd']:.1f} ms" for r in stronge3))
    if small:
        dev = [r["fd_deviation"] for r in records]
        summary.append(
            f"one contact: central differences agree with the analytic jacobians to "
            f"{min(dev):.1e}-{max(dev):.1e} (relative, every law, planar and spatial, stick "
            f"and slide)")
    if large:
        summary.append(
            f"one contact, k = {LARGE_K}: the analytic jacobians take "
            f"{min(1e6 * r['time_derivatives'] for r in large):.0f}-"
            f"{max(1e6 * r['time_derivatives'] for r in large):.0f} µs CPU, a central-"
            f"difference jacobian ({min(r['fd_calls'] for r in large)}-"
            f"{max(r['fd_calls'] for r in large)} calls) "
            f"{min(r['fd_over_derivative'] for r in large):.0f}-"
            f"{max(r['fd_over_derivative'] for r in large):.0f}x that")
    if skipped:
        summary.append(f"no single-contact derivative (skipped): {', '.join(skipped)}")
    return summary


@register_section("derivatives", "impact derivatives: resolve_impact with and without "
                  "derivatives=True, and central-difference jacobians (time and accuracy), "
                  "per law, at one contact and at 2, 4 and 8 contacts")
def derivatives_section(config: BenchConfig, progress: Progress) -> SectionResult:
    from .derivatives_charts import several_contacts_chart, single_contact_chart
    from .derivatives_several import (BUDGET, DIM, E as SEVERAL_E, FD_OPTIONS, N_CONTACTS,
                                      STEP, several_summary)

    records, skipped = _single_contact(config, progress)
    several = _several_contacts(config, progress)
    figures = [single_contact_chart(records, config.out)] if records else []
    if any("skipped" not in r for r in several):
        figures.append(several_contacts_chart(several, config.out))
    summary = _single_summary(records, skipped) + several_summary(several)
    return SectionResult(
        name="derivatives", records=records + several, figures=figures, summary=summary,
        meta={"k": K, "large_k": LARGE_K, "e": E, "e_t": E_T, "mode_mu": MODE_MU,
              "rel_step": REL_STEP, "paths": list(PATHS), "skipped": skipped,
              "several": {"n_contacts": list(N_CONTACTS), "d": DIM, "e": SEVERAL_E,
                          "step": STEP, "fd_options": FD_OPTIONS, "fd_budget": BUDGET,
                          "fd_arguments": ["dq", "e", "mu"],
                          "fd_m_jc": "estimated: calls x measured time per call"}})
