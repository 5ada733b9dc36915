"""Section ``coldstart``: how long a first use waits for compilation, with an empty cache and
with a warm one.

Three scenarios, each in fresh Python processes (``OPENBLAS_NUM_THREADS=1``) with its own
empty compiled-code cache (a new temporary ``CONVIMPACT_CACHE_DIR``; see
:mod:`convimpact.compiled`), run once cold and once more warm on the cache the first run
left:

* ``single``: ``import convimpact`` and the first single-contact ``resolve_impact`` (planar,
  k = 3, the default law) -- the compiled lane's first tier;
* ``several``: ``import convimpact`` and the first call of every law at three spatial contacts
  (a box on three corners, k = 6, ``method="auto"``), law after law (a law that refuses these
  coupled contacts is timed to its refusal, which is recorded);
* ``batch``: ``import convimpact`` and the first ``resolve_impacts`` call (64 planar items,
  the default law).

Each figure is wall time (the machine is shared: CPU time of the process is recorded too).
numba's import is counted apart (the worker imports it before the first call to record
numba's compile events); a first call's wait is numba's import plus the call. The cold runs
also record, from numba's ``numba:compile`` events, the seconds each compiled function took
(exclusive of the functions it compiled in turn, which happen inside its type inference) and
the type specializations each dispatcher holds at the end (``len(dispatcher.signatures)``).
Targets (the issue's): import + first single-contact call <= 10 s; the first several-contact
call of every law + the first batch call <= 30 s in all.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from .registry import BenchConfig, Progress, SectionResult, register_section

SCENARIOS = ("single", "several", "batch")
TARGETS = {"single": 10.0, "several+batch": 30.0}
#: the compiled functions listed per scenario in meta (by exclusive compile seconds)
TOP = 12

#: the measuring process: argv[1] is the scenario; prints one JSON line
WORKER = r'''
import json, sys, time
scenario = sys.argv[1]
c0, t0 = time.process_time(), time.perf_counter()
import convimpact as ci
out = {"scenario": scenario, "import_convimpact": time.perf_counter() - t0,
       "import_convimpact_cpu": time.process_time() - c0, "calls": {}, "calls_cpu": {}}
import numpy as np
c0, t0 = time.process_time(), time.perf_counter()
from numba.core import event
out["import_numba"] = time.perf_counter() - t0
out["import_numba_cpu"] = time.process_time() - c0


class Recorder(event.Listener):
    def __init__(self):
        self.buffer = []

    def on_start(self, ev):
        self.buffer.append((True, time.perf_counter(), time.process_time(), ev.data))

    def on_end(self, ev):
        self.buffer.append((False, time.perf_counter(), time.process_time(), ev.data))


rec = Recorder()
event.register("numba:compile", rec)


def timed(name, fn):
    c, t = time.process_time(), time.perf_counter()
    try:
        fn()
    except ci.ConvImpactError as exc:  # a law that does not take these data (timed anyway)
        out.setdefault("refused", {})[name] = f"{type(exc).__name__}: {exc}"[:300]
    out["calls"][name] = time.perf_counter() - t
    out["calls_cpu"][name] = time.process_time() - c


if scenario == "single":
    M = np.array([[2.0, 0.3, 0.1], [0.3, 1.0, 0.2], [0.1, 0.2, 0.5]])
    Jc = np.array([[0.0, 1.0, 0.4], [1.0, 0.0, -0.3]])
    dq = np.array([0.2, -1.0, 0.1])
    timed("pereira-nikravesh", lambda: ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.3))
elif scenario == "several":
    def skew(r):
        return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    M = np.diag([2.0, 2.0, 2.0, 0.05, 0.08, 0.1])
    frame = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    corners = ([0.2, 0.1, -0.1], [-0.2, 0.1, -0.1], [0.0, -0.15, -0.1])
    Jcs = [frame @ np.hstack([np.eye(3), -skew(np.array(r))]) for r in corners]
    dq = np.array([0.3, -0.1, -1.0, 0.2, -0.1, 0.5])
    for law in ci.LAWS:
        timed(law, lambda: ci.resolve_impact(M, Jcs, dq, e=0.5, mu=0.3, law=law))
else:
    rng = np.random.default_rng(7)
    n = 64
    A = rng.normal(size=(n, 3, 3))
    M = A @ A.transpose(0, 2, 1) + np.eye(3)
    Jc = rng.normal(size=(n, 2, 3))
    dq = rng.normal(size=(n, 3))
    Jc[:, 0] *= -np.sign(np.einsum("nk,nk->n", Jc[:, 0], dq))[:, None]
    timed("resolve_impacts", lambda: ci.resolve_impacts(M, Jc, dq, 0.5, 0.3))

# compile seconds per function, exclusive of the functions compiled inside it
stack, per = [], {}
for start, t, c, data in rec.buffer:
    if start:
        stack.append([t, c, 0.0, 0.0])
        continue
    t1, c1, child_t, child_c = stack.pop()
    wall, cpu = t - t1, c - c1
    if stack:
        stack[-1][2] += wall
        stack[-1][3] += cpu
    f = data["dispatcher"].py_func
    name = f"{f.__module__}.{f.__qualname__}".replace("convimpact.impact.", "")
    row = per.setdefault(name, {"function": name, "compiles": 0, "wall": 0.0, "cpu": 0.0,
                                "inclusive_wall": 0.0})
    row["compiles"] += 1
    row["wall"] += wall - child_t
    row["cpu"] += cpu - child_c
    row["inclusive_wall"] = max(row["inclusive_wall"], wall)
from numba.core.registry import CPUDispatcher
for mname, m in list(sys.modules.items()):
    if mname.startswith("convimpact") and m is not None:
        for v in list(vars(m).values()):
            if isinstance(v, CPUDispatcher) and v.py_func.__module__ == mname:
                name = f"{mname}.{v.py_func.__qualname__}".replace("convimpact.impact.", "")
                if v.signatures:
                    per.setdefault(name, {"function": name, "compiles": 0, "wall": 0.0,
                                          "cpu": 0.0, "inclusive_wall": 0.0})
                    per[name]["signatures"] = len(v.signatures)
                    per[name]["signature_list"] = [str(s) for s in v.signatures]
out["functions"] = sorted(per.values(), key=lambda r: -r["cpu"])
out["compile_wall"] = sum(r["wall"] for r in per.values())
out["compile_cpu"] = sum(r["cpu"] for r in per.values())
from convimpact import compiled
out["cache_dir"] = compiled._DIR or None
out["key_seconds"] = compiled.KEY_SECONDS
print(json.dumps(out))
'''


def run_worker(scenario: str, cache: str, timeout: float = 1800.0) -> dict[str, Any]:
    """One fresh process measuring ``scenario`` with the compiled cache in ``cache``."""
    env = dict(os.environ, CONVIMPACT_CACHE_DIR=cache, OPENBLAS_NUM_THREADS="1")
    env.pop("NUMBA_DISABLE_JIT", None)
    t = time.perf_counter()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    res = subprocess.run([sys.executable, "-c", WORKER, scenario], capture_output=True,
                         text=True, env=env, timeout=timeout)
    wall = time.perf_counter() - t
    if res.returncode != 0:
        return {"scenario": scenario, "error": res.stderr[-800:]}
    out = json.loads(res.stdout.strip().splitlines()[-1])
    out["process_wall"] = wall
    out["load_average"] = load  # 1-minute load of the machine as the process started
    out["messages"] = [ln for ln in res.stderr.splitlines() if ln.startswith("convimpact:")]
    out["first_use"] = out["import_numba"] + sum(out["calls"].values())
    out["first_use_cpu"] = out["import_numba_cpu"] + sum(out["calls_cpu"].values())
    out["total"] = out["import_convimpact"] + out["first_use"]
    out["total_cpu"] = out["import_convimpact_cpu"] + out["first_use_cpu"]
    return out


def measure(progress: Progress, scenarios=SCENARIOS) -> dict[str, dict[str, Any]]:
    """Cold then warm runs of each scenario, each scenario on its own empty cache."""
    runs: dict[str, dict[str, Any]] = {}
    for scenario in scenarios:
        with tempfile.TemporaryDirectory(prefix="convimpact-coldstart-") as cache:
            for state in ("cold", "warm"):
                r = run_worker(scenario, cache)
                runs[f"{scenario} {state}"] = r
                if "error" in r:
                    progress(f"coldstart {scenario} {state}: failed: {r['error'][-200:]}")
                else:
                    progress(f"coldstart {scenario} {state}: import {r['import_convimpact']:.2f}"
                             f" s + first use {r['first_use']:.2f} s (CPU {r['total_cpu']:.2f}"
                             f" s in all)")
    return runs


def records_of(runs: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    rows = []
    for key, r in runs.items():
        scenario, state = key.split()
        if "error" in r:
            rows.append({"scenario": scenario, "cache": state, "error": r["error"]})
            continue
        rows.append({"scenario": scenario, "cache": state,
                     "import_convimpact": r["import_convimpact"],
                     "import_numba": r["import_numba"], "calls": r["calls"],
                     "first_use": r["first_use"], "total": r["total"],
                     "total_cpu": r["total_cpu"], "process_wall": r["process_wall"],
                     "first_use_cpu": r["first_use_cpu"], "compile_cpu": r["compile_cpu"],
                     "messages": r["messages"], "load_average": r.get("load_average"),
                     "refused": r.get("refused", {}),
                     "key_seconds": r["key_seconds"]})
    return rows


def breakdown(runs: dict[str, dict[str, Any]], top: int = TOP) -> dict[str, Any]:
    """Per cold scenario: the ``top`` compiled functions by exclusive compile CPU seconds,
    the number of functions compiled, and every convimpact function compiled for more than
    one type signature (literal constants passed by compiled callers specialize a callee)."""
    keys = ("function", "compiles", "cpu", "wall", "inclusive_wall", "signatures",
            "signature_list")
    out = {}
    for key, r in runs.items():
        if key.endswith("cold") and "functions" in r:
            fns = r["functions"]
            ours = [f for f in fns if not f["function"].startswith("numba.")]
            out[key.split()[0]] = {
                "top": [{k: f[k] for k in keys if k in f} for f in fns[:top]],
                "functions_compiled": len(ours),
                "compiles": sum(f["compiles"] for f in ours),
                "numba_internal_cpu": sum(f["cpu"] for f in fns
                                          if f["function"].startswith("numba.")),
                "several_signatures": [{k: f[k] for k in keys if k in f} for f in ours
                                       if f.get("signatures", 0) > 1]}
    return out


def summary_sentences(rows: list[dict[str, Any]]) -> list[str]:
    by = {(r["scenario"], r["cache"]): r for r in rows if "error" not in r}
    out = []
    labels = {"single": "import + first single-contact resolve_impact",
              "several": "import + first several-contact call of every law",
              "batch": "import + first resolve_impacts"}
    for s in SCENARIOS:
        c, w = by.get((s, "cold")), by.get((s, "warm"))
        if c and w:
            out.append(f"cold start, {labels[s]}: {c['total']:.1f} s with an empty cache "
                       f"(CPU {c['total_cpu']:.1f} s; numba compiling {c['compile_cpu']:.1f} s "
                       f"of it), {w['total']:.2f} s warm")
    c1, c2, c3 = (by.get((s, "cold")) for s in SCENARIOS)

    def verdict(wall, cpu, target):
        met = "met" if wall <= target else "met in CPU time only" if cpu <= target else "not met"
        return f"{wall:.1f} s wall, {cpu:.1f} s CPU: {met}"

    if c1:
        out.append(f"target: import + first single-contact call <= {TARGETS['single']:.0f} s: "
                   + verdict(c1["total"], c1["total_cpu"], TARGETS["single"]))
    if c2 and c3:
        out.append(f"target: first several-contact call of every law + first batch <= "
                   f"{TARGETS['several+batch']:.0f} s in all: "
                   + verdict(c2["first_use"] + c3["first_use"],
                             c2["first_use_cpu"] + c3["first_use_cpu"], TARGETS["several+batch"]))
    keys = [k for r in rows if "error" not in r for k in r.get("key_seconds", [])]
    if keys:
        out.append(f"cache key (hash of the compiled sources) at the first kernel import: "
                   f"{1e3 * min(keys):.1f}-{1e3 * max(keys):.1f} ms")
    return out


def chart(rows: list[dict[str, Any]], out: Path) -> str:
    """Stacked horizontal bars per scenario, cold and warm: import convimpact, import numba,
    first call(s); the targets drawn as dashed lines."""
    from .charts import _plt, save_chart

    plt = _plt()
    by = {(r["scenario"], r["cache"]): r for r in rows if "error" not in r}
    titles = {"single": "(i) import + first single-contact\nresolve_impact (planar)",
              "several": "(ii) import + first call of every law,\n3 spatial contacts",
              "batch": "(iii) import + first resolve_impacts\n(64 planar items)"}
    fig, axes = plt.subplots(len(SCENARIOS), 1, figsize=(10, 7.2), sharex=True)
    parts = (("import convimpact", "import_convimpact", "0.6"),
             ("import numba", "import_numba", "tab:blue"))
    xmax = max([r["total"] for r in by.values()] + [TARGETS["single"]]) * 1.22
    for ax, s in zip(axes, SCENARIOS):
        ax.set_title(titles[s], fontsize=10, loc="left")
        ylabels = []
        for y, state in enumerate(("warm", "cold")):
            r = by.get((s, state))
            ylabels.append(f"{state} cache")
            if r is None:
                continue
            left = 0.0
            for label, key, color in parts:
                ax.barh(y, r[key], left=left, color=color, height=0.6,
                        label=label if (s, state) == ("single", "warm") else None)
                left += r[key]
            colors = {"pereira-nikravesh": "tab:red", "coulomb": "tab:orange",
                      "ccp": "tab:green", "dissipative": "tab:purple", "stronge": "tab:brown",
                      "chatterjee-ruina": "tab:cyan", "resolve_impacts": "tab:olive"}
            for name, sec in r["calls"].items():
                ax.barh(y, sec, left=left, color=colors.get(name, "tab:gray"), height=0.6,
                        label=f"first call: {name}" if state == "cold" else None)
                left += sec
            ax.text(left + xmax * 0.01, y, f"{r['total']:.1f} s (CPU {r['total_cpu']:.1f} s)",
                    va="center", fontsize=9)
        ax.set_yticks([0, 1])
        ax.set_yticklabels(ylabels)
        ax.set_xlim(0, xmax)
        ax.grid(True, axis="x", alpha=0.3)
        if s == "single":
            ax.axvline(TARGETS["single"], color="0.4", ls="--", lw=1)
            ax.text(TARGETS["single"], 0.5, f" target {TARGETS['single']:.0f} s",
                    fontsize=8, color="0.3", va="center")
    axes[-1].set_xlabel("seconds (wall, fresh process, empty or warm compiled-code cache)")
    handles, labels = [], []
    for ax in axes:
        for h, l in zip(*ax.get_legend_handles_labels()):
            if l not in labels:
                handles.append(h)
                labels.append(l)
    fig.legend(handles, labels, loc="lower center", ncol=4, frameon=False, fontsize=8.5)
    c2, c3 = by.get(("several", "cold")), by.get(("batch", "cold"))
    both = (f"; (ii)+(iii) first use, cold: {c2['first_use'] + c3['first_use']:.1f} s, CPU "
            f"{c2['first_use_cpu'] + c3['first_use_cpu']:.1f} s (target "
            f"{TARGETS['several+batch']:.0f} s)") if c2 and c3 else ""
    loads = [r["load_average"] for r in by.values() if r.get("load_average") is not None]
    load = (f"; load average {min(loads):.1f}-{max(loads):.1f} on the shared machine"
            if loads else "")
    fig.suptitle("cold start: the wait for numba's compilation on first use" + both + "\n"
                 "wall seconds in fresh processes (CPU seconds in brackets)" + load,
                 fontsize=10)
    fig.tight_layout(rect=(0, 0.1, 1, 0.95))
    return save_chart(fig, out, "coldstart.png")


@register_section("coldstart", "cold start: import + the first single-contact, several-contact "
                               "(every law) and batch calls, with an empty and a warm "
                               "compiled-code cache, in fresh processes")
def coldstart_section(config: BenchConfig, progress: Progress) -> SectionResult:
    try:
        import numba  # noqa: F401
    except ImportError as exc:
        return SectionResult("coldstart", [], [], [f"coldstart skipped: {exc}"],
                             {"skipped": True, "error": str(exc)})
    scenarios = ("single",) if config.quick else SCENARIOS
    runs = measure(progress, scenarios)
    rows = records_of(runs)
    fig = chart(rows, Path(config.out))
    meta = {"definition": "seconds of wall time in fresh processes, OPENBLAS_NUM_THREADS=1, "
                          "each scenario on its own empty CONVIMPACT_CACHE_DIR (cold) and then "
                          "on the cache it left (warm); first_use = numba's import + the "
                          "call(s)",
            "targets": TARGETS, "breakdown": breakdown(runs)}
    return SectionResult("coldstart", rows, [fig], summary_sentences(rows), meta)
