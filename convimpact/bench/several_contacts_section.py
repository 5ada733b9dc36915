"""Bench section ``several``: the exact several-contact solver against Pinocchio and Clarabel.

Problems (:mod:`convimpact.bench.several_problems`): a free box landing on its four bottom
corners (k = 6, W of size 12 and rank 6; sliding at mu = 0.3, sticking at mu = 1) and random
impacts of 2-8 contacts, planar and spatial. Two laws, each against the peers that solve it:

* ``ccp`` (Anitescu's program; Pinocchio's ADMM with ``solve_ncp=False``): ``interior`` --
  :func:`convimpact.impact.several.interior.solve_cone_complementarity` on (W, b, mu), the
  compiled interior point, its Newton finish and the KKT certificate (the solver against the
  peers' solvers, which also start from W); ``resolve_impact`` -- the public call from the raw
  data (M, the list of Jc, dq, e, mu; ``method="interior"``): validation, the reduction to W,
  the solve and the ImpactResult (for ``ccp`` its compiled lane,
  :mod:`convimpact.impact.several.lane`; ``coulomb`` takes the full path); ``clarabel`` at tol 1e-8 and
  1e-10 (the conic path, equilibrated and KKT-polished); Pinocchio ADMM at 1e-6, 1e-8, 1e-10.
* ``coulomb`` (Coulomb's law; Pinocchio's ADMM with ``solve_ncp=True`` and PGS): the same
  paths (the conic path is its safeguarded fixed point over CCP programs).

Timings are medians of ``config.repeat`` batches per path, the paths' batches interleaved
round by round (:func:`interleaved_times`: a burst of load on the shared machine falls on all
paths alike); the fastest batch is recorded too.
Accuracy: for ``ccp`` the error ``max |v+ - v+_ref| / max |v-|`` of the contact velocities
(unique even where the impulses are not, as on the box) against Clarabel at tol 1e-12; for
``coulomb``, whose answer need not be unique at several contacts (the box has a family of
them), the residual of Coulomb's conditions of each answer
(:func:`convimpact.contacts.newton.coulomb_certificate`, relative), with the velocity
error against the conic path recorded too. The first call's cost is measured: in this
process (compiling, or loading numba's cached machine code) and, in the full run, in fresh
processes with an empty and then a filled numba cache.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .charts import _plt, save_chart
from .registry import BenchConfig, Progress, SectionResult, register_section
from .timing import MAX_INNER, time_call

LAWS = ("ccp", "coulomb")
REFERENCE_TOL = 1e-12
ADMM_TOLS = (1e-6, 1e-8, 1e-10)
#: (n_contacts, dim) of the random problems, full and quick runs
RANDOM_FULL = tuple((n, d) for d in (2, 3) for n in (2, 3, 4, 6, 8))
RANDOM_QUICK = ((3, 3),)
COMPILE_SNIPPET = ("import time; t = time.perf_counter(); "
                   "from convimpact.impact.several.interior import compile_kernels; "
                   "s = compile_kernels(); print(time.perf_counter() - t)")


def _problems(quick: bool, seed: int) -> list[tuple[str, str, dict]]:
    from .several_problems import four_corner_box, random_several

    out = [("box, 4 corners, mu 0.3 (slide)", "box", four_corner_box(mu=0.3))]
    if not quick:
        out.append(("box, 4 corners, mu 1 (stick)", "box", four_corner_box(mu=1.0)))
    for n, d in (RANDOM_QUICK if quick else RANDOM_FULL):
        out.append((f"random {'planar' if d == 2 else 'spatial'}, {n} contacts", "random",
                    random_several(seed, n, d)))
    return out


def _vplus(P, impulse: np.ndarray) -> np.ndarray:
    return P.v_minus + (P.delassus @ np.asarray(impulse).ravel()).reshape(P.n_contacts, P.dim)


def _error(P, impulse, ref_vplus) -> float:
    scale = max(float(np.max(np.abs(P.v_minus))), 1e-300)
    return float(np.max(np.abs(_vplus(P, impulse) - ref_vplus))) / scale


def _compile_times(full: bool) -> dict[str, Any]:
    """Seconds of the first call: here, and (full run) in fresh processes, cold and cached."""
    from convimpact.impact.several.interior import compile_kernels

    out: dict[str, Any] = {}
    t = time.perf_counter()
    compile_kernels()
    out["this_process"] = time.perf_counter() - t
    if full:
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            for key in ("fresh_process_cold_cache", "fresh_process_warm_cache"):
                try:
                    run = subprocess.run([sys.executable, "-c", COMPILE_SNIPPET], env=env,
                                         capture_output=True, text=True, timeout=900,
                                         check=True)
                    out[key] = float(run.stdout.strip().splitlines()[-1])
                except (subprocess.SubprocessError, ValueError, IndexError) as exc:
                    out[key] = None
                    out[f"{key}_error"] = f"{type(exc).__name__}: {exc}"
    return out


def _paths(P, law: str, quick: bool, peers: bool,
           raw: tuple) -> list[tuple[str, Callable[[], Any]]]:
    """(label, call returning the impulse) per timed path of ``law`` on ``P`` (built from the
    ``raw`` arguments of resolve_impact: M, Jc, dq, e, mu, C)."""
    from convimpact.impact import resolve_impact, solve_problem
    from convimpact.impact.conic.paths import approaching, newton_shift
    from convimpact.impact.several.interior import solve_cone_complementarity

    W = P.delassus
    b = P.v_minus.ravel() + newton_shift(P)
    coulomb = law == "coulomb"
    mu = P.friction if coulomb else np.where(approaching(P), P.friction, 0.0)
    d = P.dim
    out = [
        ("interior", lambda: solve_cone_complementarity(W, b, mu, d, coulomb=coulomb).impulse),
        ("resolve_impact", lambda: resolve_impact(*raw, law=law, method="interior").impulse),
    ]
    for tol in ((1e-10,) if quick else (1e-8, 1e-10)):
        out.append((f"clarabel tol {tol:.0e}",
                    lambda tol=tol: solve_problem(P, law, "clarabel", tol=tol).impulse))
    if peers:
        from .pinocchio_peers import contact_solver_call

        for tol in ((1e-10,) if quick else ADMM_TOLS):
            out.append((f"pinocchio ADMM tol {tol:.0e}",
                        contact_solver_call(P, "admm", coulomb, tol)))
        if coulomb:
            out.append(("pinocchio PGS tol 1e-10", contact_solver_call(P, "pgs", True, 1e-10)))
    return out


def interleaved_times(paths: list[tuple[str, Callable[[], Any]]], repeat: int,
                      min_batch_time: float) -> tuple[dict[str, tuple[list, Any]],
                                                      dict[str, str]]:
    """Per-call seconds of every path over ``repeat`` rounds, the paths' batches interleaved.

    Each path is warmed up and its batch size chosen as in
    :func:`convimpact.bench.timing.time_call` (a batch lasts about ``min_batch_time``); then
    every round times one batch of each path in turn, so that a burst of load on the shared
    machine falls on all paths alike and their ratios stay meaningful. Returns
    ``({label: (per-call times, last value)}, {label: error text of a path that failed})``.
    """
    ok: dict[str, tuple[Callable[[], Any], int, list, Any]] = {}
    failed: dict[str, str] = {}
    for label, call in paths:
        try:
            _, value = time_call(call, 1, min_batch_time)  # warm-up and a first estimate
            t = time.perf_counter()
            value = call()
            dt = time.perf_counter() - t
        except Exception as exc:  # a peer that does not converge, a solver that refuses
            failed[label] = f"{type(exc).__name__}: {exc}"
            continue
        n_inner = int(min(MAX_INNER, max(1, math.ceil(min_batch_time / max(dt, 1e-9)))))
        ok[label] = (call, n_inner, [], value)
    for _ in range(max(1, repeat)):
        for label, (call, n_inner, times, _) in ok.items():
            t = time.perf_counter()
            for _ in range(n_inner):
                value = call()
            times.append((time.perf_counter() - t) / n_inner)
    return {label: (v[2], v[3]) for label, v in ok.items()}, failed


def _law_residual(P, law: str, impulse) -> float:
    """The law's own certificate of an answer (relative KKT / Coulomb residual)."""
    from convimpact.impact.conic.paths import approaching, newton_shift
    from convimpact.impact.several.interior import kernels

    K = kernels()
    b = P.v_minus.ravel() + newton_shift(P)
    pi = np.ascontiguousarray(np.asarray(impulse, dtype=float).ravel())
    if law == "coulomb":
        return float(K.coulomb_certificate(P.delassus, b, P.friction, P.dim, pi)[0])
    mu = np.where(approaching(P), P.friction, 0.0)
    return float(K.ccp_certificate(P.delassus, b, mu, P.dim, pi)[0])


@register_section("several", "several contacts: the exact solver (method 'interior') against "
                             "Pinocchio's ADMM/PGS and Clarabel, laws ccp and coulomb, on a box "
                             "landing on four corners and random 2-8-contact impacts")
def several_contacts_section(config: BenchConfig, progress: Progress) -> SectionResult:
    from convimpact.impact import solve_problem
    from convimpact.impact.problem.build import build_problem

    from .pinocchio_peers import pinocchio_version

    compile_times = _compile_times(full=not config.quick)
    progress(f"several: kernels ready, first call {compile_times['this_process']:.2f} s here")
    peers = pinocchio_version() is not None
    notes = [] if peers else ["pinocchio is not installed: the peers are not measured"]
    records: list[dict[str, Any]] = []
    for name, kind, args in _problems(config.quick, config.seed):
        P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"], args["C"])
        for law in LAWS:
            ref = _vplus(P, solve_problem(P, law, "clarabel", tol=REFERENCE_TOL).impulse)
            raw = (args["M"], args["Jc"], args["dq"], args["e"], args["mu"], args["C"])
            paths = _paths(P, law, config.quick, peers, raw)
            timed, failed = interleaved_times(paths, config.repeat, config.min_batch_time)
            for label, _ in paths:
                base = {"problem": name, "kind": kind, "law": law, "path": label,
                        "n_contacts": P.n_contacts, "dim": P.dim}
                if label in failed:  # a path that fails is recorded, not fatal
                    records.append({**base, "failed": failed[label]})
                    progress(f"several {name} {law}: {label} failed ({failed[label]})")
                    continue
                times, impulse = timed[label]
                q1, med, q3 = (float(x) for x in np.percentile(times, [25, 50, 75]))
                records.append({**base, "wall_time": med, "wall_time_iqr": q3 - q1,
                                "best_wall_time": float(np.min(times)),
                                "error": _error(P, impulse, ref),
                                "law_residual": _law_residual(P, law, impulse)})
            row = _row(records, name, law)
            progress(f"several {name} {law}: interior {row['interior']['wall_time'] * 1e6:.0f} us"
                     + (f", ADMM 1e-10 {row[ADMM]['wall_time'] * 1e6:.0f} us"
                        if ADMM in row else ""))
    table = _table(records)
    figures = [_chart(records, config.out, law) for law in LAWS]
    summary = _summary(table, compile_times) + notes
    return SectionResult("several", records, figures, summary,
                         meta={"laws": list(LAWS),
                               "reference": f"clarabel tol {REFERENCE_TOL:g}",
                               "error": "max |v+ - v+_ref| / max |v-| (contact velocities)",
                               "law_residual": "relative KKT residual (ccp) or residual of "
                                               "Coulomb's conditions (coulomb)",
                               "compile_seconds": compile_times, "table": table})


ADMM = "pinocchio ADMM tol 1e-10"


def _row(records: list[dict[str, Any]], name: str, law: str) -> dict[str, dict[str, Any]]:
    return {r["path"]: r for r in records
            if r["problem"] == name and r["law"] == law and "wall_time" in r}


def _table(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per problem and law: interior, ADMM 1e-10, PGS 1e-10, Clarabel 1e-10 medians and
    accuracies (velocity error for ccp, the law's residual for coulomb)."""
    out = []
    for name in dict.fromkeys(r["problem"] for r in records):
        for law in LAWS:
            row = _row(records, name, law)
            if "interior" not in row:
                continue
            item: dict[str, Any] = {"problem": name, "law": law}
            measure = "law_residual" if law == "coulomb" else "error"
            for key, path in (("interior", "interior"), ("result", "resolve_impact"),
                              ("admm", ADMM), ("pgs", "pinocchio PGS tol 1e-10"),
                              ("clarabel", "clarabel tol 1e-10")):
                if path in row:
                    item[f"{key}_time"] = row[path]["wall_time"]
                    item[f"{key}_accuracy"] = row[path][measure]
            if "admm_time" in item:
                item["interior_over_admm"] = item["interior_time"] / item["admm_time"]
                item["result_over_admm"] = item["result_time"] / item["admm_time"]
            if "clarabel_time" in item:
                item["clarabel_over_interior"] = item["clarabel_time"] / item["interior_time"]
            out.append(item)
    return out


def _us(t: float) -> str:
    return f"{t * 1e6:.0f} us" if t < 1e-2 else f"{t * 1e3:.1f} ms"


def _summary(table: list[dict[str, Any]], compile_times: dict[str, Any]) -> list[str]:
    lines = []
    for t in table:
        what = "residual" if t["law"] == "coulomb" else "error"
        s = (f"{t['problem']}, {t['law']}: interior {_us(t['interior_time'])} ({what} "
             f"{t['interior_accuracy']:.0e}; {_us(t['result_time'])} through resolve_impact)")
        if "admm_time" in t:
            s += (f", Pinocchio ADMM 1e-10 {_us(t['admm_time'])} ({what} "
                  f"{t['admm_accuracy']:.0e}): ratio {t['interior_over_admm']:.2f}")
        if "pgs_time" in t:
            s += f", PGS {_us(t['pgs_time'])} ({what} {t['pgs_accuracy']:.0e})"
        if "clarabel_time" in t:
            s += (f", Clarabel 1e-10 {_us(t['clarabel_time'])} "
                  f"({t['clarabel_over_interior']:.0f}x interior)")
        lines.append(s)
    for law in LAWS:
        rows = [t for t in table if t["law"] == law and "interior_over_admm" in t]
        if rows:
            r = [t["interior_over_admm"] for t in rows]
            f = [t["result_over_admm"] for t in rows]
            lines.append(
                f"{law}: interior / Pinocchio ADMM at 1e-10 {min(r):.2f}-{max(r):.2f} (median "
                f"{float(np.median(r)):.2f}; through resolve_impact {min(f):.2f}-{max(f):.2f}, "
                f"median {float(np.median(f)):.2f}) "
                f"over {len(r)} problems; largest interior "
                f"{'residual' if law == 'coulomb' else 'error'} "
                f"{max(t['interior_accuracy'] for t in rows):.1e}")
    c = compile_times
    line = f"first call of the interior kernels: {c['this_process']:.2f} s in this process"
    cold, warm = c.get("fresh_process_cold_cache"), c.get("fresh_process_warm_cache")
    if cold is not None and warm is not None:
        line += (f"; in a fresh process {cold:.1f} s with an empty numba cache (compiling), "
                 f"{warm:.2f} s with it filled")
    elif "fresh_process_cold_cache_error" in c or "fresh_process_warm_cache_error" in c:
        line += "; the fresh-process measurement failed (see meta.compile_seconds)"
    lines.append(line)
    return lines


STYLES = {"interior": ("C0", "o"), "resolve_impact": ("C0", "s"),
          "clarabel": ("C2", "^"), "pinocchio ADMM": ("C3", "D"), "pinocchio PGS": ("C1", "v")}


def _family(path: str) -> str:
    if path.startswith("interior"):
        return path
    return next(f for f in STYLES if path.startswith(f))


def _chart(records: list[dict[str, Any]], out: Path, law: str) -> str:
    """Speed against accuracy of one law: one panel for the box, one for the random problems."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11.5, 4.6), sharey=True)
    measure = "law_residual" if law == "coulomb" else "error"
    floor = 1e-17
    for ax, kind, title in ((axes[0], "box", "free box landing on 4 corners (k = 6)"),
                            (axes[1], "random", "random impacts, 2-8 contacts")):
        seen = set()
        for r in records:
            if r["kind"] != kind or r["law"] != law or "wall_time" not in r:
                continue
            family = _family(r["path"])
            color, marker = STYLES[family]
            ax.scatter(r["wall_time"] * 1e6, max(r[measure], floor), color=color,
                       marker=marker, s=30, alpha=0.8,
                       label=family if family not in seen else None)
            seen.add(family)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("median wall time per solve (µs)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
        ax.axhline(1e-10, color="0.6", lw=0.8, ls="--")
        if seen:
            ax.legend(fontsize=8, loc="best")
    axes[0].set_ylabel("residual of Coulomb's conditions (relative)" if law == "coulomb"
                       else "velocity error vs Clarabel at 1e-12 (relative)")
    fig.suptitle(f"law {law} at several contacts: speed against accuracy "
                 f"(values below {floor:g} drawn at {floor:g}; dashed: 1e-10)", fontsize=10)
    fig.tight_layout()
    return save_chart(fig, out, f"several_contacts_{law}.png")
