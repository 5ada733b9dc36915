"""Section ``batch``: impacts per second of the batch API against per-impact Python loops.

For every law, planar (d = 2, k = 2..6) and spatial (d = 3, k = 3..6; with k = 2 a spatial W is
singular and every frictional impact is rejected) contacts, on N random impacts (SPD M, random
Jc with the normal row turned so that the contact approaches, dq ~ N(0, 1), e ~ U(0, 1),
mu ~ U(0, 1.5): a mix of sticking and sliding; ``chatterjee-ruina`` also takes e_t ~ U(-1, 1)
per item, drawn apart so that its items are the other laws'), four paths are timed:

* ``resolve_impacts``: :func:`convimpact.impact.batch.impacts.resolve_impacts` on the whole batch, split
  over the process's cores (its default), and ``resolve_impacts 1 thread`` on one thread
  (validation, W and v-, the kernel, dq+, energies and flags), compiled;
* ``contact_impulses``: :func:`convimpact.impact.batch.impacts.contact_impulses` from the batch's
  (W, v-) (the kernel alone, plus v+ and the energy loss), compiled;
* ``loop solve_contact``: a plain Python loop over :func:`convimpact.impact.exact.dispatch.solve_contact`
  on the same (W, v-) (the fast kernel, impulses only);
* ``loop resolve_impact``: a plain Python loop over ``resolve_impact(..., method="fast")``
  (full validation and result), the per-impact public path.

Rates are impacts per second: items divided by the median wall time of one call over the batch
(:func:`convimpact.bench.timing.time_call`); ``cpu_impacts_per_second`` divides by the median
process CPU time instead (the machine may be shared: the two differ when other processes take
the cores). The loops run on the first :data:`LOOP_N` items (fewer when quick). The accuracy
column is the largest relative deviation of the batch's impulse and dq+ from ``resolve_impact``
on the looped items (failures must agree). The compiled kernels' build time is measured in a
subprocess with an empty numba cache (cold, full runs only) and with the cache it left (warm).
Without numba (an optional dependency, the ``batch`` extra) the section records no
measurement: ``meta["error"]`` and the summary say why.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..impact.exact.lane import HOT_CALLS
from .registry import BenchConfig, Progress, SectionResult, register_section

LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge", "chatterjee-ruina")
#: laws whose spatial items integrate a curved slip (tens of microseconds per item, compiled):
#: their spatial batches take the first 1/SLOW_SPATIAL_SHARE of the items, so that the
#: section's time stays that of the other laws
SLOW_SPATIAL = ("stronge",)
SLOW_SPATIAL_SHARE = 20
#: (d, k) shapes measured
SHAPES = tuple((2, k) for k in range(2, 7)) + tuple((3, k) for k in range(3, 7))
#: batch sizes (full, quick)
BATCH_N = (100_000, 5_000)
#: items of the per-impact Python loops (full, quick)
LOOP_N = (400, 40)
PATHS = ("resolve_impacts", "resolve_impacts 1 thread", "contact_impulses", "loop solve_contact",
         "loop resolve_impact")
#: the issue's targets: impacts/s of every law on spatial contacts with k <= 6, and of the
#: planar closed form given (W, v)
TARGET_SPATIAL = 1e6
TARGET_PLANAR_WV = 1e7


def random_batch(seed: int, n: int, d: int, k: int) -> dict[str, np.ndarray]:
    """N approaching single-contact impacts with a mix of sticking and sliding."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, k, k))
    M = A @ A.transpose(0, 2, 1) + 0.5 * np.eye(k)
    J = rng.normal(size=(n, d, k))
    dq = rng.normal(size=(n, k))
    s = np.einsum("nk,nk->n", J[:, 0], dq)
    J[:, 0] *= np.where(s > 0, -1.0, 1.0)[:, None]
    return {"M": M, "Jc": J, "dq": dq, "e": rng.uniform(0.0, 1.0, n),
            "mu": rng.uniform(0.0, 1.5, n)}


def with_law_parameters(data: dict[str, np.ndarray], law: str, seed: int) -> dict[str, np.ndarray]:
    """``data`` with the law's parameters beyond e and mu: e_t ~ U(-1, 1) per item for the
    laws with a tangential restitution (``chatterjee-ruina``), drawn from a stream of its own
    so that the items are those of the other laws."""
    from convimpact.impact.laws import TANGENTIAL_LAWS

    if law not in TANGENTIAL_LAWS:
        return data
    e_t = np.random.default_rng([seed, 1]).uniform(-1.0, 1.0, len(data["e"]))
    return {**data, "e_t": e_t}


def _timed(fn: Callable[[], Any], repeat: int) -> tuple[float, float, float, Any]:
    """(median wall s, iqr wall s, median CPU s, value) of ``fn()`` after one warm-up call."""
    value = fn()
    walls, cpus = [], []
    for _ in range(max(1, repeat)):
        t, c = time.perf_counter(), time.process_time()
        value = fn()
        walls.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
    q1, med, q3 = np.percentile(walls, [25, 50, 75])
    return float(med), float(q3 - q1), float(np.median(cpus)), value


def _deviation(b, data: dict[str, np.ndarray], law: str, n: int) -> tuple[float, int]:
    """Largest relative deviation of the batch from resolve_impact over the first n items,
    and the number of items on which the two disagreed about failing."""
    import convimpact as ci

    worst, mismatch = 0.0, 0
    for i in range(n):
        extra = {"e_t": data["e_t"][i]} if "e_t" in data else {}
        try:
            r = ci.resolve_impact(data["M"][i], data["Jc"][i], data["dq"][i], data["e"][i],
                                  data["mu"][i], law=law, method="fast", **extra)
        except ci.ConvImpactError:
            mismatch += int(b.status[i] == 0)
            continue
        if b.status[i] != 0:
            mismatch += 1
            continue
        sp = max(float(np.abs(r.impulse).max()), 1e-300)
        sq = max(float(np.abs(r.dq_plus).max()), float(np.abs(data["dq"][i]).max()))
        worst = max(worst, float(np.abs(b.impulse[i] - r.impulse).max()) / sp,
                    float(np.abs(b.dq_plus[i] - r.dq_plus).max()) / sq)
    return worst, mismatch


def compile_times(cold: bool) -> dict[str, Any]:
    """Seconds of :func:`convimpact.impact.exact.lane.compile_lane` (resolve_impact's compiled lane,
    both tiers, numba imported by it) and :func:`convimpact.impact.batch.impacts.compile_kernels` in fresh
    subprocesses: with an empty numba cache (``cold``, when asked) and then with the cache it
    wrote (warm); plus the import of convimpact."""
    code = ("import json, time; t = time.perf_counter(); import convimpact; "
            "t1 = time.perf_counter() - t; "
            "from convimpact.impact.exact import lane as L; L.compile_lane(); "
            "from convimpact.impact.batch.impacts import compile_kernels; "
            "print(json.dumps({'import_convimpact': t1, 'lane': L.COMPILE_SECONDS['lane'], "
            "'lane_solve': L.COMPILE_SECONDS.get('lane_solve', 0.0), **compile_kernels()}))")
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ)
        if cold:
            env["NUMBA_CACHE_DIR"] = tmp  # empty: numba compiles everything
        runs = (("cold", "warm") if cold else ("warm",))
        for name in runs:
            t = time.perf_counter()
            res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                 env=env, timeout=900)
            wall = time.perf_counter() - t
            if res.returncode != 0:
                out[name] = {"error": res.stderr[-500:]}
                continue
            out[name] = {**json.loads(res.stdout.strip().splitlines()[-1]),
                         "process_wall_time": wall}
    return out


@register_section("batch", "batch API: impacts per second of resolve_impacts and "
                           "contact_impulses per law, planar and spatial, k = 2..6, against "
                           "Python loops over the fast kernel and over resolve_impact")
def batch_section(config: BenchConfig, progress: Progress) -> SectionResult:
    from convimpact.impact.batch.impacts import compile_kernels, contact_impulses, resolve_impacts
    from convimpact.impact.exact.dispatch import solve_contact
    import convimpact as ci

    t = time.perf_counter()
    first = compile_kernels()
    first["total"] = time.perf_counter() - t
    progress(f"batch: kernels ready in {first['total']:.2f} s (first call in this process)")
    n_batch = BATCH_N[1] if config.quick else BATCH_N[0]
    n_loop = LOOP_N[1] if config.quick else LOOP_N[0]
    shapes = ((2, 2), (2, 6), (3, 3), (3, 6)) if config.quick else SHAPES
    records: list[dict[str, Any]] = []
    for d, k in shapes:
        full = random_batch(config.seed + 10 * d + k, n_batch, d, k)
        for law in LAWS:
            if d == 3 and law in SLOW_SPATIAL:
                data = {key: val[:n_batch // SLOW_SPATIAL_SHARE] for key, val in full.items()}
            else:
                data = full
            data = with_law_parameters(data, law, config.seed + 10 * d + k)
            n_items = len(data["e"])
            wall, iqr, cpu, b = _timed(lambda: resolve_impacts(**data, law=law), config.repeat)
            W, v = b.delassus, b.v_minus
            e, mu = data["e"], data["mu"]
            # e_t per item for the laws that have one, 0 (unused) for the others
            et = data.get("e_t", np.zeros(n_items))
            law_kw = {"e_t": et} if "e_t" in data else {}
            # the kernel sees the friction resolve_impacts used (build_problem's rule)
            rows = [("resolve_impacts", n_items, wall, iqr, cpu)]
            w1, i1, c1, _ = _timed(lambda: resolve_impacts(**data, law=law, threads=1),
                                   config.repeat)
            rows.append(("resolve_impacts 1 thread", n_items, w1, i1, c1))
            w2, i2, c2, _ = _timed(lambda: contact_impulses(W, v, e, mu, law, **law_kw),
                                   config.repeat)
            rows.append(("contact_impulses", n_items, w2, i2, c2))
            Wl, vl, etl = list(W[:n_loop]), list(v[:n_loop]), et[:n_loop].tolist()
            public_kw = [{"e_t": x} for x in etl] if law_kw else [{}] * n_loop

            def loop_kernel():
                for i in range(n_loop):
                    try:
                        solve_contact(Wl[i], vl[i], e[i], mu[i], law, etl[i])
                    except ci.ConvImpactError:
                        pass

            def loop_public():
                for i in range(n_loop):
                    try:
                        ci.resolve_impact(data["M"][i], data["Jc"][i], data["dq"][i], e[i],
                                          mu[i], law=law, method="fast", **public_kw[i])
                    except ci.ConvImpactError:
                        pass

            reps = max(1, min(config.repeat, 3 if config.quick else config.repeat))
            rows.append(("loop solve_contact", n_loop, *_timed(loop_kernel, reps)[:3]))
            rows.append(("loop resolve_impact", n_loop, *_timed(loop_public, reps)[:3]))
            dev, mismatch = _deviation(b, data, law, n_loop)
            counts = np.bincount(b.regime.astype(int) + 1, minlength=5)
            mix = {"failed": int(counts[0]), "separating": int(counts[1]),
                   "frictionless": int(counts[2]), "stick": int(counts[3]),
                   "slide": int(counts[4])}
            for path, n, w_, q_, c_ in rows:
                records.append({
                    "law": law, "d": d, "k": k, "path": path, "n": n, "wall_time": w_,
                    "wall_time_iqr": q_, "cpu_time": c_,
                    "impacts_per_second": n / w_ if w_ > 0 else None,
                    "cpu_impacts_per_second": n / c_ if c_ > 0 else None,
                    "max_deviation_vs_resolve_impact": dev if path == "resolve_impacts" else None,
                    "failure_mismatches": mismatch if path == "resolve_impacts" else None,
                    "regimes": mix})
            progress(f"batch {law} d={d} k={k}: {n_items / wall:.3g}/s batch, "
                     f"{n_items / w2:.3g}/s (W, v), loops {rows[3][1] / rows[3][2]:.3g}/s "
                     f"kernel, {rows[4][1] / rows[4][2]:.3g}/s resolve_impact; max deviation "
                     f"{dev:.1e}")
    compile_info: dict[str, Any] = {"first_call_in_process": first}
    if not config.quick:
        progress("batch: measuring the kernels' build time in subprocesses (cold cache)")
        compile_info.update(compile_times(cold=True))
    aggs = aggregates(records)
    fig = batch_chart(records, Path(config.out))
    meta = {"definition": "impacts_per_second = items / median wall time of one call over "
                          "them; cpu_* uses process CPU time",
            "batch_n": n_batch, "loop_n": n_loop, "shapes": [list(s) for s in shapes],
            "targets": {"spatial_k_le_6": TARGET_SPATIAL, "planar_from_W_v": TARGET_PLANAR_WV},
            "compile": compile_info, "aggregates": aggs}
    return SectionResult("batch", records, [fig], summary_sentences(aggs, compile_info), meta)


def aggregates(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per law and d: median and minimum over k of each path's rate, and the ratios of the
    batch's median rate to the loops'."""
    out = []
    for law in LAWS:
        for d in (2, 3):
            rows = [r for r in records if r["law"] == law and r["d"] == d]
            if not rows:
                continue
            agg: dict[str, Any] = {"law": law, "d": d, "ks": sorted({r["k"] for r in rows})}
            for path in PATHS:
                rates = [r["impacts_per_second"] for r in rows if r["path"] == path
                         and r["impacts_per_second"]]
                cpu = [r["cpu_impacts_per_second"] for r in rows if r["path"] == path
                       and r["cpu_impacts_per_second"]]
                agg[path] = {"median": float(np.median(rates)) if rates else None,
                             "min": float(np.min(rates)) if rates else None,
                             "cpu_median": float(np.median(cpu)) if cpu else None,
                             "cpu_min": float(np.min(cpu)) if cpu else None}
            b = agg["resolve_impacts"]["median"]
            for path in ("loop solve_contact", "loop resolve_impact"):
                m = agg[path]["median"]
                agg[f"ratio_vs_{path.replace(' ', '_')}"] = b / m if b and m else None
            # the public per-impact path against its kernel (issue 13: within 2x)
            pub, ker = agg["loop resolve_impact"]["median"], agg["loop solve_contact"]["median"]
            agg["public_over_kernel"] = ker / pub if pub and ker else None
            devs = [r["max_deviation_vs_resolve_impact"] for r in rows
                    if r["max_deviation_vs_resolve_impact"] is not None]
            agg["max_deviation_vs_resolve_impact"] = max(devs) if devs else None
            agg["failure_mismatches"] = sum(r["failure_mismatches"] or 0 for r in rows
                                            if r["path"] == "resolve_impacts")
            out.append(agg)
    return out


#: threads of resolve_impacts' default (the cores this process may use)
_THREADS = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


def _ratio(x) -> str:
    return "n/a x" if x is None else f"{x:.2f}x"


def summary_sentences(aggs: list[dict[str, Any]], compile_info: dict[str, Any]) -> list[str]:
    out = []
    for a in aggs:
        name = "planar" if a["d"] == 2 else "spatial"
        ks = f"k = {a['ks'][0]}..{a['ks'][-1]}"
        r, w = a["resolve_impacts"], a["contact_impulses"]
        r1 = a["resolve_impacts 1 thread"]
        out.append(
            f"{a['law']} {name} ({ks}): resolve_impacts {r['median']:.3g} impacts/s on "
            f"{_THREADS} threads (median over k; slowest k {r['min']:.3g}), on one thread "
            f"{r1['median']:.3g}/s (slowest k {r1['min']:.3g}), "
            f"contact_impulses from (W, v) {w['median']:.3g}/s; "
            f"{a['ratio_vs_loop_solve_contact']:.3g}x a Python loop over solve_contact "
            f"({a['loop solve_contact']['median']:.3g}/s) and "
            f"{a['ratio_vs_loop_resolve_impact']:.3g}x a loop over resolve_impact "
            f"({a['loop resolve_impact']['median']:.3g}/s; one resolve_impact costs "
            f"{_ratio(a.get('public_over_kernel'))} its kernel solve_contact); largest "
            f"deviation from "
            f"resolve_impact {a['max_deviation_vs_resolve_impact']:.1e}, "
            f"{a['failure_mismatches']} failure mismatches")
    spatial = [a for a in aggs if a["d"] == 3 and a["law"] not in SLOW_SPATIAL]
    if spatial:
        low = min(a["resolve_impacts"]["min"] for a in spatial)
        low1 = min(a["resolve_impacts 1 thread"]["min"] for a in spatial)
        out.append(f"spatial target {TARGET_SPATIAL:.0e}/s for every law and k <= 6: slowest "
                   f"measured {low:.3g}/s on {_THREADS} threads over the laws with a closed "
                   f"form or a finite search -> "
                   f"{'met' if low >= TARGET_SPATIAL else 'not met'} on this run ({low1:.3g}/s "
                   f"on one thread: {'met' if low1 >= TARGET_SPATIAL else 'not met'})")
    for a in (a for a in aggs if a["d"] == 3 and a["law"] in SLOW_SPATIAL):
        out.append(f"{a['law']} spatial (its slip integrated in impulse space, compiled): "
                   f"{a['resolve_impacts']['median']:.3g} impacts/s on {_THREADS} threads "
                   f"(slowest k {a['resolve_impacts']['min']:.3g}) -> the target is not met "
                   f"for this law; {a['ratio_vs_loop_solve_contact']:.3g}x the kernel "
                   "called from Python per item")
    planar = [a for a in aggs if a["d"] == 2 and a["law"] == "pereira-nikravesh"]
    if planar:
        p = planar[0]["contact_impulses"]
        out.append(f"planar closed form from (W, v): {p['median']:.3g}/s (slowest k "
                   f"{p['min']:.3g}/s; target {TARGET_PLANAR_WV:.0e}/s "
                   f"{'met' if p['min'] >= TARGET_PLANAR_WV else 'not met'})")
    f = compile_info.get("first_call_in_process", {})
    parts = [f"first call in this process {f.get('total', float('nan')):.2f} s"]
    for name in ("cold", "warm"):
        c = compile_info.get(name)
        if c and "error" not in c:
            parts.append(f"{name} numba cache: build {c['planar'] + c['spatial']:.1f} s "
                         f"(+ {c['import']:.2f} s importing numba), resolve_impact's "
                         f"compiled lane {c.get('lane', float('nan')):.2f} s (tier 1: the "
                         f"reduction) + {c.get('lane_solve', float('nan')):.2f} s (tier 2: "
                         f"the whole call, taken after {HOT_CALLS} calls or from the disk "
                         f"cache), import convimpact {c['import_convimpact']:.2f} s")
    out.append("compiled kernels: " + "; ".join(parts))
    return out


def batch_chart(records: list[dict[str, Any]], out: Path) -> str:
    """Impacts per second against k, one panel per law and dimension, one line per path."""
    from .charts import _plt

    plt = _plt()
    styles = {"resolve_impacts": ("tab:red", "o", "-"),
              "resolve_impacts 1 thread": ("tab:orange", "o", "--"),
              "contact_impulses": ("tab:purple", "D", "-"),
              "loop solve_contact": ("tab:blue", "s", "--"),
              "loop resolve_impact": ("0.3", "v", ":")}
    fig, axes = plt.subplots(2, len(LAWS), figsize=(4.2 * len(LAWS), 8), sharey=True)
    for row, d in enumerate((2, 3)):
        for col, law in enumerate(LAWS):
            ax = axes[row, col]
            ax.set_title(f"{law}, {'planar' if d == 2 else 'spatial'}", fontsize=10)
            ax.set_yscale("log")
            ax.grid(True, which="major", alpha=0.3)
            for path, (color, marker, ls) in styles.items():
                rows = sorted((r for r in records if r["law"] == law and r["d"] == d
                               and r["path"] == path and r["impacts_per_second"]),
                              key=lambda r: r["k"])
                if rows:
                    ax.plot([r["k"] for r in rows], [r["impacts_per_second"] for r in rows],
                            color=color, marker=marker, ls=ls, label=path)
            target = TARGET_SPATIAL if d == 3 else TARGET_PLANAR_WV
            ax.axhline(target, color="0.6", ls="--", lw=0.8)
            if row == 1:
                ax.set_xlabel("k (joint coordinates)")
            if col == 0:
                ax.set_ylabel("impacts per second (median wall time)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), frameon=False, fontsize=9)
    fig.suptitle("batch API against per-impact Python loops (dashed grey: the targets, 1e7/s "
                 "planar from (W, v), 1e6/s spatial)", fontsize=12)
    fig.tight_layout(rect=(0, 0.05, 1, 0.96))
    name = "batch_throughput.png"
    fig.savefig(Path(out) / name, dpi=90)
    plt.close(fig)
    return name
