"""Section ``per-impact``: wall time and error of every solver path on the same impacts.

For each problem of :func:`~convimpact.bench.problems.problem_suite`, each law (plus
``"frictionless"``: the same impact with mu = 0, the common ground with Pinocchio's
``impulseDynamics``) and each :class:`~convimpact.bench.paths.SolverPath` that serves it:

* ``time_full``: ``solve_problem(problem, law, method, **options)`` on the prebuilt problem
  (median and interquartile range of the per-call time over timed batches after a warm-up);
* ``time_kernel``: the bare kernel on the contact block where one exists (``fast``:
  :func:`convimpact.impact.exact.dispatch.solve_contact`; closed form:
  :func:`convimpact.impact.laws.pereira_nikravesh.pereira_nikravesh`; Pinocchio's ADMM/PGS: the solver call);
* ``impulse_error = |pi - pi_ref| / |pi_ref|`` and
  ``velocity_error = |dq+ - dq+_ref| / |dq-|`` against a tight reference: ``fast`` for one
  contact (exact), else Clarabel at tol 1e-12 (then cvxpy at 1e-12, then Clarabel at its
  default). A second tight path cross-checks each reference (``reference_crosscheck``).

The time to validate and reduce the problem (``build_problem``) is measured once per problem
and reported with it; it is not in ``time_full``.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any, Callable

import numpy as np

from ..errors import ConvImpactError
from ..impact import LAWS, available_methods, solve_problem
from ..impact.problem.build import ImpactProblem, build_problem
from . import pinocchio_peers as peers
from .paths import SolverPath, reference_paths, solver_paths
from .per_impact_laws import law_speed_chart, law_speed_summary
from .problems import CLASSES, BenchProblem, problem_suite
from .registry import BenchConfig, Progress, SectionResult, register_section
from .timing import time_call

FRICTIONLESS = "frictionless"
BENCH_LAWS = LAWS + (FRICTIONLESS,)
#: methods of ours run on the frictionless impacts (law "coulomb" at mu = 0)
FRICTIONLESS_METHODS = ("closed-form", "fast", "clarabel", "cvxpy")
#: Pinocchio contact-solver tolerances
PEER_TOLS_FULL = (1e-4, 1e-6, 1e-8, 1e-10, 1e-12)
PEER_TOLS_QUICK = (1e-8,)


def _law_problem(bp: BenchProblem, law: str) -> tuple[ImpactProblem, str]:
    """The problem a bench law runs on and the library law that resolves it."""
    if law == FRICTIONLESS:
        return bp.frictionless(), "coulomb"
    return bp.problem, law


def _solve_call(P: ImpactProblem, law: str, path: SolverPath) -> Callable[[], Any]:
    real = "pereira-nikravesh" if path.method == "closed-form" and law == "coulomb" else law
    opts = path.options_for(real)
    return lambda: solve_problem(P, real, path.method, **opts)


def _serves(path: SolverPath, bp: BenchProblem, law: str) -> bool:
    if path.single_only and bp.problem.n_contacts != 1:
        return False
    if law == FRICTIONLESS:
        if path.method not in FRICTIONLESS_METHODS:
            return False
        real = "pereira-nikravesh" if path.method == "closed-form" else "coulomb"
        return path.method in available_methods(real)
    return law in path.laws and path.method in available_methods(law)


def _errors(pi, dq_plus, ref, P: ImpactProblem) -> tuple[float, float]:
    pi = np.ravel(pi)
    rpi, rdq = ref
    scale = float(np.linalg.norm(rpi))
    d = float(np.linalg.norm(pi - rpi))
    e_pi = d / scale if scale > 0 else d
    e_v = float(np.linalg.norm(dq_plus - rdq)) / max(float(np.linalg.norm(P.dq_minus)), 1e-300)
    return e_pi, e_v


def _reference(bp: BenchProblem, law: str) -> tuple[tuple | None, str | None, float | None, list]:
    """(pi_ref, dq_plus_ref), its label, the cross-check error and notes of failed tries.

    The reference is the first candidate of :func:`reference_paths` that succeeds; the
    cross-check is the first later candidate of another method that succeeds.
    """
    P, real = _law_problem(bp, law)
    notes = []
    ref = ref_label = None
    cross = None
    for path in reference_paths(P.n_contacts == 1):
        if ref is not None and path.method == ref_label.split()[0]:
            continue
        try:
            r = solve_problem(P, real, path.method, **path.options_for(real))
        except Exception as exc:  # typed library errors and bugs alike are recorded
            notes.append(f"{path.label}: {type(exc).__name__}: {exc}"[:300])
            continue
        val = (np.ravel(r.impulse), np.asarray(r.dq_plus))
        if ref is None:
            ref, ref_label = val, path.label
        else:
            cross = _errors(val[0], val[1], ref, P)[0]
            break
    return ref, ref_label, cross, notes


def _record(bp: BenchProblem, law: str, method: str, setting: str, options: dict,
            peer: bool) -> dict[str, Any]:
    # problem facts (k, dim, loops, source) are in meta["problems"], options in meta["paths"]
    return {"problem": bp.name, "class": bp.problem_class, "n_contacts": bp.info["n_contacts"],
            "law": law, "method": method, "setting": setting,
            "label": method if setting == "default" else f"{method} {setting}",
            "peer": peer, "status": "ok", "error_type": None,
            "message": None, "time_full": None, "time_kernel": None, "impulse_error": None,
            "velocity_error": None, "regime": None, "energy_gained": None,
            "reference": None, "is_reference": False, "unexpected": False}


def _fail(rec: dict, exc: BaseException) -> dict:
    """Mark a record failed; ``unexpected`` when the exception is not a library error."""
    rec["status"] = "failed"
    rec["error_type"] = type(exc).__name__
    rec["message"] = str(exc)[:300]
    rec["unexpected"] = not isinstance(exc, ConvImpactError)
    return rec


def _measure_ours(bp, law, path, ref, ref_label, config) -> dict[str, Any]:
    P, real = _law_problem(bp, law)
    rec = _record(bp, law, path.method, path.setting, path.options_for(real), False)
    rec["reference"] = ref_label
    rec["is_reference"] = ref_label == path.label
    try:
        t, res = time_call(_solve_call(P, real, path), config.repeat, config.min_batch_time)
    except Exception as exc:  # a bug in a solver is reported (unexpected=True), not fatal
        return _fail(rec, exc)
    rec["time_full"] = t.as_dict()
    rec["regime"] = res.regime if isinstance(res.regime, str) else list(res.regime)
    rec["energy_gained"] = bool(res.diagnostics.energy_gained)
    if ref is not None:
        rec["impulse_error"], rec["velocity_error"] = _errors(res.impulse, res.dq_plus, ref, P)
    if path.kernel is not None:
        klaw = "pereira-nikravesh" if path.method == "closed-form" else real
        try:
            tk, _ = time_call(path.kernel(P, klaw), config.repeat, config.min_batch_time)
            rec["time_kernel"] = tk.as_dict()
        except Exception as exc:
            rec["message"] = f"kernel: {type(exc).__name__}: {exc}"[:300]
    return rec


def _measure_peers(bp, law, ref, ref_label, config) -> list[dict[str, Any]]:
    out = []
    P, _ = _law_problem(bp, law)
    if law == FRICTIONLESS:
        rec = _record(bp, law, "pinocchio impulseDynamics", "default", {}, True)
        rec["reference"] = ref_label
        try:
            call = peers.impulse_dynamics_call(P)
            t, (pi, dqp) = time_call(call, config.repeat, config.min_batch_time)
        except Exception as exc:  # a peer's failure is data, not a crash
            out.append(_fail(rec, exc))
        else:
            rec["time_full"] = t.as_dict()
            if ref is not None:
                rec["impulse_error"], rec["velocity_error"] = _errors(pi, dqp, ref, P)
            out.append(rec)
        return out
    tols = PEER_TOLS_QUICK if config.quick else PEER_TOLS_FULL
    for label, plaw, kind, ncp in peers.CONTACT_PEERS:
        if plaw != law:
            continue
        for tol in tols:
            rec = _record(bp, law, label, f"tol={tol:.0e}", {"tol": tol, "solve_ncp": ncp}, True)
            rec["reference"] = ref_label
            try:
                kern = peers.contact_solver_call(P, kind, ncp, tol)

                def full(kern=kern):
                    pi = kern()
                    return pi, P.dq_minus + P.velocity_jump(pi)[0]

                tk, _ = time_call(kern, config.repeat, config.min_batch_time)
                t, (pi, dqp) = time_call(full, config.repeat, config.min_batch_time)
            except Exception as exc:  # recorded with its reason, never faked
                out.append(_fail(rec, exc))
                continue
            rec["time_full"], rec["time_kernel"] = t.as_dict(), tk.as_dict()
            if ref is not None:
                rec["impulse_error"], rec["velocity_error"] = _errors(pi, dqp, ref, P)
            out.append(rec)
    return out


def aggregate(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per (class, law, label): medians over the problems of the class."""
    groups: dict[tuple, list] = defaultdict(list)
    for r in records:
        groups[(r["class"], r["law"], r["label"])].append(r)
    out = []
    for (cls, law, label), rows in groups.items():
        ok = [r for r in rows if r["status"] == "ok"]

        def med(key, sub=None, rows=ok):
            vals = [r[key]["median"] if sub else r[key] for r in rows
                    if r[key] is not None]
            return float(np.median(vals)) if vals else None

        errs = [r["impulse_error"] for r in ok if r["impulse_error"] is not None]
        verrs = [r["velocity_error"] for r in ok if r["velocity_error"] is not None]
        out.append({
            "class": cls, "law": law, "label": label, "method": rows[0]["method"],
            "setting": rows[0]["setting"], "peer": rows[0]["peer"],
            "n_problems": len(rows), "n_ok": len(ok), "n_failed": len(rows) - len(ok),
            "failures": sorted({r["error_type"] for r in rows if r["status"] != "ok"}),
            "time_full_median": med("time_full", True),
            "time_kernel_median": med("time_kernel", True),
            "impulse_error_median": float(np.median(errs)) if errs else None,
            "impulse_error_max": float(np.max(errs)) if errs else None,
            "velocity_error_max": float(np.max(verrs)) if verrs else None,
            "is_reference": any(r["is_reference"] for r in rows),
        })
    return out


def _find(aggs, cls, law, label):
    for a in aggs:
        if a["class"] == cls and a["law"] == law and a["label"] == label:
            return a
    return None


def _us(t: float) -> str:
    return f"{t * 1e6:.3g} us" if t < 1e-3 else f"{t * 1e3:.3g} ms"


def _err(x) -> str:
    return "n/a" if x is None else f"{x:.1e}"


def summarize(aggs: list[dict[str, Any]], records: list[dict[str, Any]]) -> list[str]:
    """Sentences quoting medians and ratios of this run."""
    lines = []
    single = "spatial, 1 contact, open"
    several = "spatial, several contacts, open"
    for law in ("ccp", "coulomb", "dissipative", "pereira-nikravesh"):
        f = _find(aggs, single, law, "fast")
        c = _find(aggs, single, law, "clarabel tol=1e-10")
        if f and c and f["time_full_median"] and c["time_full_median"]:
            lines.append(
                f"{law}, {single}: fast {_us(f['time_full_median'])} vs clarabel tol=1e-10 "
                f"{_us(c['time_full_median'])} per solve (median): fast is "
                f"{c['time_full_median'] / f['time_full_median']:.3g}x faster; clarabel's "
                f"median impulse error against fast {_err(c['impulse_error_median'])} "
                f"(max {_err(c['impulse_error_max'])})")
    f = _find(aggs, single, "ccp", "fast")
    if f and f["time_kernel_median"] and f["time_full_median"]:
        lines.append(f"fast kernel alone (solve_contact, ccp, {single}): "
                     f"{_us(f['time_kernel_median'])}, i.e. "
                     f"{f['time_kernel_median'] / f['time_full_median']:.0%} of the "
                     f"{_us(f['time_full_median'])} of a full solve_problem call")
    s = _find(aggs, single, "pereira-nikravesh", "sweep xtol=1e-10 grid=360")
    f = _find(aggs, single, "pereira-nikravesh", "fast")
    if s and f and s["time_full_median"] and f["time_full_median"]:
        lines.append(f"pereira-nikravesh, {single}: the seed's sweep (xtol 1e-10) takes "
                     f"{_us(s['time_full_median'])}, {s['time_full_median'] / f['time_full_median']:.3g}x "
                     f"the exact fast path, with median impulse error "
                     f"{_err(s['impulse_error_median'])}")
    for law in ("ccp", "coulomb"):
        c = _find(aggs, several, law, "clarabel tol=1e-10")
        x = _find(aggs, several, law, "cvxpy tol=1e-10")
        if c and x and c["time_full_median"] and x["time_full_median"]:
            lines.append(f"{law}, {several}: clarabel tol=1e-10 {_us(c['time_full_median'])} vs "
                         f"cvxpy tol=1e-10 {_us(x['time_full_median'])}: clarabel direct is "
                         f"{x['time_full_median'] / c['time_full_median']:.3g}x faster "
                         f"(median errors {_err(c['impulse_error_median'])} and "
                         f"{_err(x['impulse_error_median'])})")
    for law, label in (("ccp", "pinocchio ADMM ccp tol=1e-10"),
                       ("coulomb", "pinocchio ADMM ncp tol=1e-10"),
                       ("coulomb", "pinocchio PGS tol=1e-10"),
                       ("ccp", "pinocchio ADMM ccp tol=1e-08")):
        for cls in (single, several):
            p = _find(aggs, cls, law, label)
            ours = _find(aggs, cls, law, "fast" if cls == single else "clarabel tol=1e-10")
            if p and ours and p["time_full_median"] and ours["time_full_median"]:
                lines.append(f"{law}, {cls}: {label} {_us(p['time_full_median'])} "
                             f"(kernel {_us(p['time_kernel_median'] or float('nan'))}, median "
                             f"error {_err(p['impulse_error_median'])}) vs {ours['label']} "
                             f"{_us(ours['time_full_median'])} (error "
                             f"{_err(ours['impulse_error_median'])})")
    p = _find(aggs, single, FRICTIONLESS, "pinocchio impulseDynamics")
    f = _find(aggs, single, FRICTIONLESS, "fast")
    if p and f and p["time_full_median"] and f["time_full_median"]:
        lines.append(f"frictionless, {single}: pinocchio impulseDynamics "
                     f"{_us(p['time_full_median'])} (from M and J, median error "
                     f"{_err(p['impulse_error_median'])}) vs fast {_us(f['time_full_median'])}")
    p = _find(aggs, several, FRICTIONLESS, "pinocchio impulseDynamics")
    if p:
        lines.append(f"frictionless, {several}: impulseDynamics (bilateral normals) max impulse "
                     f"error {_err(p['impulse_error_max'])} against the unilateral reference")
    for cls, law, method in ((several, "ccp", "clarabel"), (several, "coulomb", "clarabel"),
                             (single, "ccp", "pinocchio ADMM ccp"),
                             (single, "coulomb", "pinocchio PGS")):
        rows = [a for a in aggs if a["class"] == cls and a["law"] == law
                and a["method"] == method and a["time_full_median"]
                and a["impulse_error_median"] is not None and a["setting"].startswith("tol=")]
        if len(rows) >= 2:
            rows.sort(key=lambda a: -float(a["setting"].split("=")[1]))
            lo, hi = rows[0], rows[-1]
            lines.append(f"{law}, {cls}, {method}: loosest {lo['setting']} "
                         f"{_us(lo['time_full_median'])} (median error "
                         f"{_err(lo['impulse_error_median'])}) vs tightest {hi['setting']} "
                         f"{_us(hi['time_full_median'])} (error "
                         f"{_err(hi['impulse_error_median'])})")
    multi = {r["problem"] for r in records if r["n_contacts"] > 1}
    pn_inf = {r["problem"] for r in records if r["n_contacts"] > 1
              and r["law"] == "pereira-nikravesh" and r["error_type"] == "SolverError"}
    cr_coupled = {r["problem"] for r in records if r["n_contacts"] > 1
                  and r["law"] == "chatterjee-ruina" and r["error_type"] == "NotSupportedError"}
    if multi:
        lines.append(f"pereira-nikravesh with several contacts: P_N raised SolverError "
                     f"(Newton's restitution infeasible at every approaching contact) on "
                     f"{len(pn_inf)} of {len(multi)} several-contact problems; the other laws "
                     "let contacts separate")
        lines.append(f"chatterjee-ruina with several contacts: NotSupportedError (the law is "
                     f"defined per contact; coupled contacts, W not block-diagonal) on "
                     f"{len(cr_coupled)} of {len(multi)} several-contact problems, solved "
                     "contact by contact on the others")
    n_fail = [r for r in records if r["status"] != "ok"]
    kinds = defaultdict(int)
    for r in n_fail:
        kinds[f"{r['law']}/{r['label']}: {r['error_type']}"] += 1
    top = ", ".join(f"{k} x{v}" for k, v in sorted(kinds.items(), key=lambda kv: -kv[1])[:4])
    lines.append(f"{len(records) - len(n_fail)} of {len(records)} measured solves succeeded"
                 + (f"; failures (recorded in bench.json): {top}" if n_fail else ""))
    odd = [r for r in n_fail if r.get("unexpected") and not r["peer"]]
    if odd:
        lines.append(f"WARNING: {len(odd)} solves raised exceptions outside convimpact.errors "
                     f"(e.g. {odd[0]['law']}/{odd[0]['label']} on {odd[0]['problem']}: "
                     f"{odd[0]['error_type']}: {odd[0]['message'][:120]})")
    return lines


@register_section("per-impact", "per-impact solver paths: median wall time and error "
                                "against a tight reference, every law, method and tolerance")
def per_impact_section(config: BenchConfig, progress: Progress) -> SectionResult:
    """Run item 1 of the benchmark (see the module docstring)."""
    from .charts import per_impact_charts

    problems, notes = problem_suite(config.quick, config.seed)
    paths = solver_paths(config.quick)
    have_pin = peers.pinocchio_version() is not None
    if not have_pin:
        notes.append("Pinocchio (pip package 'pin') is not installed: no outside peers")
    records: list[dict[str, Any]] = []
    references: list[dict[str, Any]] = []
    problem_rows = []
    for i, bp in enumerate(problems):
        a = bp.args
        tb, _ = time_call(lambda: build_problem(a["M"], a["Jc"], a["dq"], a["e"], a["mu"],
                                                a["C"]), config.repeat, config.min_batch_time)
        problem_rows.append({"name": bp.name, "class": bp.problem_class, "source": bp.source,
                             **bp.info, "time_build_problem": tb.as_dict()})
        progress(f"per-impact {i + 1}/{len(problems)}: {bp.name} ({bp.problem_class})")
        for law in BENCH_LAWS:
            ref, ref_label, cross, ref_notes = _reference(bp, law)
            references.append({"problem": bp.name, "law": law, "reference": ref_label,
                               "crosscheck_impulse_error": cross, "notes": ref_notes})
            for path in paths:
                if _serves(path, bp, law):
                    records.append(_measure_ours(bp, law, path, ref, ref_label, config))
            if have_pin:
                records += _measure_peers(bp, law, ref, ref_label, config)
    aggs = aggregate(records)
    progress(f"per-impact: {len(records)} measurements done; drawing the charts")
    figures = per_impact_charts(aggs, config.out, BENCH_LAWS, CLASSES)
    figures = [*figures, *law_speed_chart(aggs, config.out, BENCH_LAWS)]
    meta = {
        "definitions": {
            "time_full": "seconds per solve_problem call on the prebuilt ImpactProblem "
                         "(median, quartiles over timed batches after one warm-up call)",
            "time_kernel": "seconds per bare kernel call on the contact block (fast: "
                           "solve_contact; closed-form: laws.pereira_nikravesh.pereira_nikravesh; "
                           "Pinocchio ADMM/PGS: the solver's solve on W)",
            "impulse_error": "|pi - pi_ref| / |pi_ref| (2-norm over all contacts)",
            "velocity_error": "|dq+ - dq+_ref| / |dq-|",
            "reference": "fast for one contact (exact), else clarabel tol=1e-12, then cvxpy "
                         "tol=1e-12, then clarabel tol=1e-10",
            "frictionless": "the same impact with mu = 0, law 'coulomb' (closed-form: "
                            "'pereira-nikravesh'); the common ground with impulseDynamics",
            "aggregates": "per (class, law, label): medians over the class's problems",
            "coulomb_options": "the conic paths' law 'coulomb' also sets fixed_point_tol = "
                               "10 tol (the library's default ratio 1e-9 / 1e-10)",
        },
        "classes": list(CLASSES),
        "problems": problem_rows,
        "references": references,
        "paths": [{"label": p.label, "method": p.method, "options": dict(p.options),
                   "laws": list(p.laws), "single_only": p.single_only,
                   "kernel": p.kernel is not None} for p in paths],
        "peers": peers.peer_facts(),
        "notes": notes,
        "aggregates": aggs,
    }
    summary = summarize(aggs, records) + law_speed_summary(aggs, BENCH_LAWS)
    return SectionResult("per-impact", records, figures, summary, meta)
