"""Section ``derivatives``: the cost of an impact's exact derivatives next to the solve it
differentiates, and against central finite differences (time and accuracy).

For every law with a single-contact derivative, planar and spatial (k = 6 joint coordinates, a
random SPD M and contact Jacobian, seed from the config), in its stick and slide modes (mu
chosen per mode, the regime reached recorded), three calls are timed
(:func:`convimpact.bench.timing.time_call`, medians over the config's batches):

* ``solve``: ``resolve_impact(...)``, the answer alone;
* ``solve + derivatives``: ``resolve_impact(..., derivatives=True)``, the answer and every
  jacobian (dq, M, Jc, e, mu; e_t for chatterjee-ruina) of dq+ and of the impulse;
* ``central FD``: the same jacobians of dq+ by central differences of the public call
  (2 calls per argument entry: k for dq, k (k + 1) / 2 symmetric pairs of M, d k for Jc, e, mu:
  2 (k + k (k + 1) / 2 + d k + 2) calls; the step 1e-6 of each argument's scale).

Accuracy: the largest deviation of the finite differences from the analytic jacobians,
relative to each key's largest entry (the differences' own error, truncation h^2 and round-off
eps / h, sets it: about 1e-9 to 1e-10 is what they can show).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .registry import BenchConfig, Progress, SectionResult, register_section
from .timing import time_call

LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge", "chatterjee-ruina")
#: joint coordinates of the measured impacts
K = 6
#: mu per mode (the regime reached is recorded: a random W may stick or slide elsewhere)
MODE_MU = {"slide": 0.1, "stick": 3.0}
E = 0.4
E_T = 0.3
REL_STEP = 1e-6
PATHS = ("solve", "solve + derivatives", "central FD")


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


def deviations(jac, fd) -> dict[str, float]:
    """Per key, max |FD - analytic| / max |analytic| (M compared on its symmetric pairs)."""
    out = {}
    for name, ref in fd.items():
        if name == "M_pairs":
            JM = np.asarray(jac["M"])
            k = JM.shape[-1]
            a = np.where(np.eye(k, dtype=bool), JM, JM + np.swapaxes(JM, -1, -2))
            iu = np.triu_indices(k)
            a, ref, name = a[:, iu[0], iu[1]], ref[:, iu[0], iu[1]], "M"
        else:
            a = np.asarray(jac[name])
        scale = max(float(np.abs(a).max()), 1e-300)
        out[name] = float(np.abs(a - ref).max()) / scale
    return out


def measure(law: str, d: int, mode: str, config: BenchConfig) -> dict[str, Any] | None:
    import convimpact as ci
    from convimpact.impact.laws import TANGENTIAL_LAWS, law_module

    if getattr(law_module(law), "impulse_derivative", None) is None:
        return None
    M, Jc, dq = problem(config.seed, d)
    e_t = E_T if law in TANGENTIAL_LAWS else None
    mu = MODE_MU[mode]

    def solve(**kw):
        return ci.resolve_impact(M, Jc, dq, e=E, mu=mu, law=law, e_t=e_t, **kw)

    def dq_plus(M_, Jc_, dq_, e_, mu_, et_):
        return ci.resolve_impact(M_, Jc_, dq_, e=e_, mu=mu_, law=law, e_t=et_).dq_plus

    t_solve, r = time_call(solve, config.repeat, config.min_batch_time)
    t_der, rd = time_call(lambda: solve(derivatives=True), config.repeat,
                          config.min_batch_time)
    t_fd, fd = time_call(lambda: fd_jacobian(dq_plus, M, Jc, dq, E, mu, e_t),
                         max(3, config.repeat // 2), config.min_batch_time)
    dev = deviations(rd.jacobian, fd)
    return {
        "law": law, "d": d, "k": K, "mode": mode, "mu": mu, "regime": rd.regime,
        "one_sided": bool(rd.derivatives.one_sided),
        "time_solve": t_solve.median, "time_solve_iqr": t_solve.iqr,
        "time_derivatives": t_der.median, "time_derivatives_iqr": t_der.iqr,
        "time_fd": t_fd.median, "time_fd_iqr": t_fd.iqr,
        "fd_calls": fd_calls(K, d, e_t is not None),
        "derivative_over_solve": t_der.median / t_solve.median,
        "fd_over_derivative": t_fd.median / t_der.median,
        "fd_deviation": max(dev.values()), "fd_deviation_by_key": dev,
        "answer_matches": bool(np.allclose(r.dq_plus, rd.dq_plus, rtol=1e-12, atol=1e-14)),
    }


def chart(records: list[dict[str, Any]], out: Path) -> str:
    """Two panels per run: the three calls' median times per law/d/mode (log), and the
    finite differences' deviation from the analytic jacobians."""
    from .charts import _plt, save_chart

    plt = _plt()
    labels = [f"{r['law']}\n{'planar' if r['d'] == 2 else 'spatial'} {r['regime']}"
              for r in records]
    x = np.arange(len(records))
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(max(8.0, 0.55 * len(records) + 2), 8.5),
                                 sharex=True)
    width = 0.27
    keys = ("time_solve", "time_derivatives", "time_fd")
    for j, (key, name) in enumerate(zip(keys, PATHS)):
        ax.bar(x + (j - 1) * width, [1e6 * r[key] for r in records], width, label=name)
    ax.set_yscale("log")
    ax.set_ylabel("median time per call (µs)")
    ax.set_title(f"impact derivatives, k = {K}: time per call")
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(axis="y", which="both", alpha=0.3)
    bx.bar(x, [max(r["fd_deviation"], 1e-17) for r in records], 0.5, color="tab:gray")
    bx.set_yscale("log")
    bx.set_ylabel("max |FD - analytic| / max |analytic|")
    bx.set_title("central differences (step 1e-6 of each argument) vs the analytic jacobians")
    bx.grid(axis="y", which="both", alpha=0.3)
    bx.set_xticks(x)
    bx.set_xticklabels(labels, rotation=60, ha="right", fontsize=7)
    fig.tight_layout()
    return save_chart(fig, out, "derivatives.png")


@register_section("derivatives", "impact derivatives: resolve_impact with and without "
                  "derivatives=True, and a central-difference jacobian (time and accuracy), "
                  "per law")
def derivatives_section(config: BenchConfig, progress: Progress) -> SectionResult:
    records = []
    skipped = []
    laws = LAWS[:2] + LAWS[-1:] if config.quick else LAWS
    for law in laws:
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
                records.append(rec)
            if law in skipped:
                break
    figures = [chart(records, config.out)] if records else []
    summary = []
    if records:
        ratio = [r["derivative_over_solve"] for r in records]
        fd = [r["fd_over_derivative"] for r in records]
        dev = [r["fd_deviation"] for r in records]
        tder = [1e6 * r["time_derivatives"] for r in records]
        summary.append(
            f"resolve_impact with derivatives=True takes {min(tder):.0f}-{max(tder):.0f} µs "
            f"(k = {K}), {min(ratio):.1f}-{max(ratio):.1f}x the solve alone (median "
            f"{np.median(ratio):.1f}x); a central-difference jacobian of dq+ "
            f"({records[0]['fd_calls']}-{max(r['fd_calls'] for r in records)} calls) takes "
            f"{min(fd):.0f}-{max(fd):.0f}x the analytic one")
        summary.append(
            f"central differences agree with the analytic jacobians to {min(dev):.1e}-"
            f"{max(dev):.1e} (relative, every law, planar and spatial, stick and slide)")
    if skipped:
        summary.append(f"no single-contact derivative (skipped): {', '.join(skipped)}")
    return SectionResult(name="derivatives", records=records, figures=figures,
                         summary=summary,
                         meta={"k": K, "e": E, "e_t": E_T, "mode_mu": MODE_MU,
                               "rel_step": REL_STEP, "paths": list(PATHS),
                               "skipped": skipped})
