"""Section ``busy``: the latency of one public call on a quiet and on a busy machine.

``resolve_impact`` with one contact is timed call by call (the median of single calls, not
of batches: a call that waits for a descheduled BLAS thread is one slow call), on its two
paths -- the compiled lane (one open-loop contact) and the full path (``method="closed-form"``,
closed loops with ``C=``, a k = 30 robot) -- planar and spatial, in four phases:

* ``quiet``: nothing else started by the section;
* ``busy``: with :data:`N_HOGS` CPU-bound processes (``while True: pass``) started by the
  section, bounded in time (each exits by itself after a deadline) and killed when the phase
  ends, in a ``finally`` block;
* ``clarabel quiet`` and ``clarabel busy``: the same after one ``method="clarabel"`` solve in
  the process (a Clarabel build may leave threads of its own: one-contact calls of 24-46 ms
  were reported after one; the process's thread counts before and after are recorded).

Each pair of phases (quiet and busy, then the same after Clarabel) is measured in
:data:`ROUNDS` alternating windows -- quiet, busy, quiet, busy, ... -- each with its share of
the calls and of the time budget, and a phase's median is over the calls of all its windows
(each window's median is kept too). On a shared machine the other users' load drifts; timed
in one window per phase, a passing disturbance decided a whole phase (the wave-3 run's
spatial closed form: 2.06x busy in one window, 1.01x in the next busy window of the same run,
no BLAS thread woken in either).

The phases run in a fresh Python process (:func:`measure`), so that "before Clarabel" is true
whichever sections ran before, and BLAS has the threads a user gets: the environment's
``OPENBLAS_NUM_THREADS`` if set, else OpenBLAS's default (one per core) -- not the one thread
:func:`~convimpact.bench.registry.run_bench` pins in this process. Besides the latencies each
row records the CPU time taken meanwhile by the process's other threads (the BLAS worker
threads, where /proc tells): a tiny LAPACK call that hands work to a BLAS thread shows there.
The target: the busy median within :data:`TARGET_RATIO` of the quiet median, before and after
Clarabel.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from .registry import BenchConfig, Progress, SectionResult, register_section

#: CPU-bound processes of the busy phases
N_HOGS = 2
#: the issue's target: busy median / quiet median at most this
TARGET_RATIO = 2.0
PHASES = ("quiet", "busy", "clarabel quiet", "clarabel busy")
#: (name, d, k, loop rows m, method, mu): the cases timed ("auto" with m = 0: the lane)
CASES = (
    ("planar lane", 2, 3, 0, "auto", 0.3),
    ("spatial lane", 3, 6, 0, "auto", 0.3),
    ("planar closed form", 2, 3, 0, "closed-form", 0.3),
    ("spatial closed form", 3, 6, 0, "closed-form", 20.0),  # sticking: closed form in space
    ("planar closed loop", 2, 4, 1, "auto", 0.3),
    ("spatial closed loop", 3, 6, 2, "auto", 0.3),
    ("spatial closed form k=30", 3, 30, 0, "closed-form", 20.0),
)
#: per (case, phase): the most calls timed and the time budget in seconds (full, quick)
CALLS = (3000, 150)
BUDGET = (1.5, 0.08)
#: random problems per case, called in turn
N_PROBLEMS = 8
#: seconds the hogs run before a busy window is timed
WARMUP = (0.3, 0.1)
#: alternating windows per pair of phases (full, quick)
ROUNDS = (3, 1)


def _problems(case: tuple, seed: int) -> list[dict[str, Any]]:
    """Random approaching impacts of one case (SPD M, Jc with the normal approaching, dq in
    the null space of C for loops) that its method solves."""
    import convimpact as ci

    name, d, k, m, method, mu = case
    rng = np.random.default_rng(seed)
    out: list[dict[str, Any]] = []
    for _ in range(20 * N_PROBLEMS):
        A = rng.normal(size=(k, k))
        M = A @ A.T + 0.5 * np.eye(k)
        J = rng.normal(size=(d, k))
        dq = rng.normal(size=k)
        kw: dict[str, Any] = {"M": M, "Jc": J, "e": 0.5, "mu": mu, "method": method}
        if m:
            C = rng.normal(size=(m, k))
            Q, _ = np.linalg.qr(C.T)
            dq = dq - Q @ (Q.T @ dq)
            kw["C"] = C
        if J[0] @ dq > 0:
            J[0] = -J[0]
        kw["dq"] = dq
        try:  # the spatial closed form solves sticking impacts only
            ci.resolve_impact(**kw)
        except ci.ConvImpactError:
            continue
        out.append(kw)
        if len(out) == N_PROBLEMS:
            return out
    raise RuntimeError(f"busy: no {N_PROBLEMS} solvable problems for case {name!r}")


def _thread_ticks() -> dict[int, int] | None:
    """CPU clock ticks (user + system) of each thread of this process (None without /proc)."""
    out = {}
    try:
        for tid in os.listdir("/proc/self/task"):
            with open(f"/proc/self/task/{tid}/stat") as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
            out[int(tid)] = int(fields[11]) + int(fields[12])
    except (OSError, IndexError, ValueError):
        return None
    return out


def _time_case(problems: list[dict[str, Any]], calls: int, budget: float) -> dict[str, Any]:
    """Per-call latencies of resolve_impact over ``problems`` in turn (one window), and the CPU
    seconds the process's other threads took meanwhile."""
    from convimpact import resolve_impact

    for kw in problems:  # warm-up
        resolve_impact(**kw)
    me = threading.get_native_id()
    before = _thread_ticks()
    n = len(problems)
    times = []
    clock = time.perf_counter
    start = clock()
    while len(times) < calls and (clock() - start < budget or len(times) < n):
        kw = problems[len(times) % n]
        t = clock()
        resolve_impact(**kw)
        times.append(clock() - t)
    wall = clock() - start
    after = _thread_ticks()
    others = None
    if before is not None and after is not None:
        hz = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
        others = sum(v - before.get(t, 0) for t, v in after.items() if t != me) / hz
    return {"times": times, "wall": wall, "others_cpu": others}


def _pooled(windows: list[dict[str, Any]]) -> dict[str, Any]:
    """One phase's figures from its windows: statistics of every call, each window's median,
    and the other threads' CPU seconds per wall second over all of them."""
    a = np.sort(np.concatenate([np.asarray(w["times"]) for w in windows]))
    wall = sum(w["wall"] for w in windows)
    others = [w["others_cpu"] for w in windows]
    share = None if None in others or wall <= 0 else sum(others) / wall
    return {"median_s": float(np.median(a)), "mean_s": float(a.mean()),
            "p90_s": float(a[int(0.9 * (len(a) - 1))]), "max_s": float(a[-1]),
            "n_calls": len(a), "window_medians_s": [float(np.median(w["times"]))
                                                     for w in windows],
            "other_threads_cpu_share": share}


def _start_hogs(n: int, deadline: float) -> list[subprocess.Popen]:
    """``n`` CPU-bound Python processes, each ending by itself after ``deadline`` seconds."""
    code = (f"import time\nend = time.monotonic() + {deadline:.1f}\n"
            "while time.monotonic() < end: pass")
    return [subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.DEVNULL,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            for _ in range(n)]


def _stop_hogs(hogs: list[subprocess.Popen]) -> None:
    for p in hogs:
        if p.poll() is None:
            p.kill()
    for p in hogs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:  # pragma: no cover - a process that ignores SIGKILL
            pass


def _blas_threads() -> list[dict[str, Any]]:
    """The OpenBLAS libraries loaded in this process and their thread counts."""
    import ctypes

    from .threads import _functions, _loaded_openblas

    out = []
    for path in _loaded_openblas():
        try:
            get, _ = _functions(ctypes.CDLL(path))
        except OSError:
            continue
        out.append({"library": os.path.basename(path), "threads": int(get()) if get else None})
    return out


def _n_threads() -> int | None:
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return None


def measure(params: dict[str, Any]) -> dict[str, Any]:
    """Every case in every phase, in this process (run in a fresh one by the section).

    ``params``: ``quick`` (bool), ``seed`` (int), ``cases`` (names, default all).
    """
    import convimpact as ci
    from convimpact.impact.exact import lane

    quick = bool(params.get("quick"))
    calls, budget, warmup = CALLS[quick], BUDGET[quick], WARMUP[quick]
    wanted = params.get("cases") or [c[0] for c in CASES]
    cases = [c for c in CASES if c[0] in wanted]
    t = time.perf_counter()
    lane.compile_lane()  # the compiled lane from numba's disk cache (compiled once if not)
    compile_s = time.perf_counter() - t
    problems = {c[0]: _problems(c, int(params.get("seed", 0)) + 17 * i)
                for i, c in enumerate(cases)}
    facts: dict[str, Any] = {"lane_ready_seconds": compile_s, "blas": _blas_threads(),
                             "threads_before_clarabel": _n_threads(),
                             "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
                             "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS")}
    rounds = ROUNDS[quick]
    calls, budget = max(calls // rounds, N_PROBLEMS), budget / rounds
    # a hog outlives no window by much even if this process dies: its deadline covers one
    deadline = warmup + len(cases) * (budget * 3 + 1.0) + 30.0
    windows: dict[tuple[str, str], list[dict[str, Any]]] = {}
    loads: dict[str, list] = {}
    for pair in (PHASES[:2], PHASES[2:]):
        if pair[0] == "clarabel quiet":
            first = problems[cases[0][0]][0]
            t = time.perf_counter()
            ci.resolve_impact(**{**first, "method": "clarabel"})
            facts["clarabel_solve_seconds"] = time.perf_counter() - t
            facts["threads_after_clarabel"] = _n_threads()
        for _ in range(rounds):
            for phase in pair:
                hogs: list[subprocess.Popen] = []
                try:
                    if phase.endswith("busy"):
                        hogs = _start_hogs(N_HOGS, deadline)
                        time.sleep(warmup)
                    loads.setdefault(phase, []).append(_loadavg())
                    for case in cases:
                        windows.setdefault((case[0], phase), []).append(
                            _time_case(problems[case[0]], calls, budget))
                finally:
                    _stop_hogs(hogs)
    rows: list[dict[str, Any]] = []
    for phase in PHASES:
        for name, d, k, m, method, mu in cases:
            rows.append({"case": name, "d": d, "k": k, "loop_rows": m, "method": method,
                         "path": "lane" if method == "auto" and not m else "full",
                         "phase": phase, "hogs": N_HOGS if phase.endswith("busy") else 0,
                         "load_average": loads[phase][0], "load_averages": loads[phase],
                         "windows": rounds, **_pooled(windows[(name, phase)])})
    facts["blas_after"] = _blas_threads()
    return {"records": rows, "facts": facts}


def _loadavg() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        return None


_CHILD = ("import json, sys\n"
          "from convimpact.bench.busy_section import measure\n"
          "print(json.dumps(measure(json.loads(sys.argv[1]))))\n")


def run_child(params: dict[str, Any], timeout: float) -> dict[str, Any]:
    """:func:`measure` in a fresh Python process (the environment's BLAS threads, no Clarabel
    solve before the first phases); killed after ``timeout`` seconds."""
    env = dict(os.environ)
    env.setdefault("MPLBACKEND", "Agg")
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, json.dumps(params)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        out, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"busy: the measuring process failed ({proc.returncode}): "
                           f"{err.strip()[-2000:]}")
    return json.loads(out.strip().splitlines()[-1])


def ratios(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per case: each phase's median over the quiet median (before Clarabel)."""
    by = {(r["case"], r["phase"]): r for r in records}
    out = []
    for name in dict.fromkeys(r["case"] for r in records):
        quiet = by.get((name, "quiet"))
        if quiet is None:
            continue
        row = {"case": name, "path": quiet["path"], "quiet_median_s": quiet["median_s"]}
        for phase in PHASES[1:]:
            r = by.get((name, phase))
            row[phase] = r["median_s"] / quiet["median_s"] if r else None
        # after Clarabel, busy against quiet after Clarabel as well
        cq, cb = by.get((name, "clarabel quiet")), by.get((name, "clarabel busy"))
        row["clarabel busy / clarabel quiet"] = (cb["median_s"] / cq["median_s"]
                                                 if cq and cb else None)
        out.append(row)
    return out


@register_section("busy", "the latency of one public call, lane and full path, planar and "
                          "spatial: quiet, beside two CPU-bound processes, after a Clarabel solve")
def busy_section(config: BenchConfig, progress: Progress) -> SectionResult:
    params = {"quick": config.quick, "seed": config.seed}
    progress(f"busy: timing {len(CASES)} cases in {len(PHASES)} phases in a fresh process "
             f"({N_HOGS} CPU-bound processes in the busy phases)")
    t = time.perf_counter()
    res = run_child(params, timeout=900.0)
    records = res["records"]
    progress(f"busy: measured in {time.perf_counter() - t:.1f} s")
    rat = ratios(records)
    for r in rat:
        progress(f"busy {r['case']}: quiet {r['quiet_median_s'] * 1e6:.1f} us; busy x"
                 f"{r['busy']:.2f}, after Clarabel x{r['clarabel quiet']:.2f}, after Clarabel "
                 f"busy x{r['clarabel busy']:.2f}")
    fig = _chart(records, rat, Path(config.out))
    meta = {"definition": "median_s: median wall time of single resolve_impact calls (each "
                          "timed alone), over the case's random problems in turn, pooled over "
                          "the phase's windows (quiet and busy alternate, ROUNDS windows each; "
                          "window_medians_s: each window's median); "
                          "other_threads_cpu_share: CPU seconds of the process's other threads "
                          "(BLAS workers) per wall second while timing",
            "rounds": ROUNDS[bool(config.quick)], "phases": list(PHASES), "cases": [list(c) for c in CASES], "hogs": N_HOGS,
            "target_ratio": TARGET_RATIO, "ratios": rat, "process": res["facts"]}
    return SectionResult("busy", records, [fig], _summary(records, rat), meta)


def _summary(records: list[dict[str, Any]], rat: list[dict[str, Any]]) -> list[str]:
    out = []
    for r in rat:
        worst = max(x for x in (r["busy"], r["clarabel busy / clarabel quiet"]) if x is not None)
        out.append(
            f"{r['case']} ({r['path']}): quiet median {r['quiet_median_s'] * 1e6:.1f} us; "
            f"busy / quiet {r['busy']:.2f}, after Clarabel {r['clarabel quiet']:.2f} (busy "
            f"{r['clarabel busy']:.2f}); target busy / quiet <= {TARGET_RATIO:g} "
            f"{'met' if worst <= TARGET_RATIO else 'not met'}")
    shares = [r["other_threads_cpu_share"] for r in records
              if r["other_threads_cpu_share"] is not None]
    if shares:
        out.append(f"CPU taken by the process's other threads (BLAS workers) while timing: at "
                   f"most {max(shares):.3f} s per s (0: no BLAS thread woken)")
    return out


def _chart(records: list[dict[str, Any]], rat: list[dict[str, Any]], out: Path) -> str:
    """Left: median latency per case and phase (µs, log); right: each phase's median over the
    quiet one, against the target."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    from .charts import _plt, save_chart

    plt = _plt()
    names = [r["case"] for r in rat]
    by = {(r["case"], r["phase"]): r for r in records}
    colors = {"quiet": "tab:blue", "busy": "tab:red", "clarabel quiet": "tab:cyan",
              "clarabel busy": "tab:orange"}
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 5.2))
    x = np.arange(len(names))
    w = 0.8 / len(PHASES)
    for i, phase in enumerate(PHASES):
        med = [by[(n, phase)]["median_s"] * 1e6 if (n, phase) in by else np.nan for n in names]
        p90 = [by[(n, phase)]["p90_s"] * 1e6 if (n, phase) in by else np.nan for n in names]
        ax.bar(x + (i - 1.5) * w, med, w, color=colors[phase], label=f"{phase} (median)")
        ax.scatter(x + (i - 1.5) * w, p90, marker="_", s=60, color="k", zorder=3,
                   label="90th percentile" if i == 0 else None)
    ax.set_yscale("log")
    ax.set_ylabel("µs per call")
    ax.set_xticks(x)
    ax.set_xticklabels(names, rotation=25, ha="right", fontsize=8)
    ax.set_title("one resolve_impact call: median (bars) and 90th percentile", fontsize=10)
    ax.grid(True, axis="y", which="major", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    keys = ("busy", "clarabel quiet", "clarabel busy")
    for i, key in enumerate(keys):
        vals = [r[key] if r[key] is not None else np.nan for r in rat]
        bx.bar(x + (i - 1) * 0.27, vals, 0.27, color=colors[key], label=f"{key} / quiet")
    bx.axhline(TARGET_RATIO, color="k", ls="--", lw=0.9)
    bx.text(len(names) - 0.5, TARGET_RATIO, f"target {TARGET_RATIO:g}x", ha="right",
            va="bottom", fontsize=8)
    bx.axhline(1.0, color="gray", lw=0.6)
    bx.set_yscale("log")
    seen = [v for r in rat for v in (r[k] for k in keys) if v is not None and v > 0]
    lo, hi = min(seen + [1.0]) / 1.5, max(seen + [TARGET_RATIO]) * 1.5
    bx.set_ylim(lo, hi)
    bx.set_yticks([t for t in (1e-3, 1e-2, 0.1, 0.25, 0.5, 1, 2, 5, 10, 100, 1e3, 1e4)
                   if lo <= t <= hi])
    bx.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}x"))
    bx.yaxis.set_minor_formatter(NullFormatter())
    bx.set_ylabel("median / quiet median")
    bx.set_xticks(x)
    bx.set_xticklabels(names, rotation=25, ha="right", fontsize=8)
    bx.set_title(f"ratio to the quiet median ({N_HOGS} CPU-bound processes when busy)",
                 fontsize=10)
    bx.grid(True, axis="y", which="both", alpha=0.3)
    bx.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    return save_chart(fig, out, "busy_latency.png")
