"""Bench section ``contact-scale``: the contact engine from 1 to 1,000 contacts against
Pinocchio's ADMM and PGS, on the corpus of :mod:`convimpact.bench.contact_corpus`.

For every problem ``(W, b, mu)`` of the corpus (the whole corpus in the full run,
:func:`~convimpact.bench.contact_corpus.quick_corpus` with the ``ccp`` law only in the quick
run) and every law (``ccp``, ``coulomb``), the solvers are

* ``ours``: :func:`convimpact.solve_contact_problem` at ``tol = 1e-8`` (an
  :class:`~convimpact.contacts.contact_problem.UncertifiedSolutionError` is a failure;
  the answer it carries is recorded with its residual);
* ``admm``: Pinocchio's ADMM at its tolerance 1e-8 (at most 100,000 iterations: stacks and walls
  need them). ADMM stops on its own primal/dual/complementarity test, not on the natural-map
  residual; when its answer misses 1e-8 by that residual it is run again at tolerance 1e-10
  (``admm-1e-10``), and ADMM counts as solved at equal certified accuracy when either run
  reaches 1e-8;
* ``pgs``: Pinocchio's PGS at 1e-8 (it may report convergence after 0 iterations with a wrong
  answer: only the residual decides).

Every answer is judged by one independent measure,
:func:`convimpact.bench.contact_peers.natural_map_residual`: *certified* means a residual of at
most 1e-8 (and, for ours, no exception). Times are medians of ``config.repeat`` rounds in which
every solver's batch runs in turn (a burst of load falls on all alike), after a first call per
problem that is not timed; past :data:`ONE_REPEAT_ABOVE` contacts, or when a call lasts more than
:data:`SLOW_CALL` seconds, that first call is the one measurement (ours past
:data:`ONE_REPEAT_ABOVE`: its second call, the first compiling what only large problems reach). The first solve of each law
(compilation, caches) is a warm-up and not recorded. The peers run in forked worker processes
(:mod:`.contact_scale_workers`; timed inside them, their stack limit lifted: Pinocchio's PGS
overflows 8 MB from about 400 contacts on), killed when a call exceeds
:data:`~.contact_scale_workers.TIME_LIMIT` seconds; a peer that timed out is
skipped on the larger problems of the same family, and a worker that crashes is recorded as
``crashed``.

Outputs: records (one per problem, law and solver), ``contact_scale_times.png`` and
``contact_scale_profile.png`` (:mod:`.contact_scale_charts`), and, unless records are dropped,
``contact_scale_impulses.npz`` holding every recorded answer at full precision (key: the
record's ``impulse_key``), so the residuals can be recomputed.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .contact_corpus import corpus, corpus_notes, quick_corpus
from .contact_scale_charts import (
    FIT_MIN_CONTACTS,
    FIT_MIN_POINTS,
    NAMES,
    SOLVERS,
    certified_times,
    power_law_fit,
)
from .contact_peers import natural_map_residual, pinocchio_contact_call
from .contact_scale_workers import TIME_LIMIT, PeerWorker
from .registry import BenchConfig, Progress, SectionResult, register_section
from .timing import MAX_INNER

LAWS = ("ccp", "coulomb")
QUICK_LAWS = ("ccp",)
TOL = 1e-8
TIGHT_TOL = 1e-10
ADMM_MAX_ITERATIONS = 100_000
PGS_MAX_ITERATIONS = 10_000
#: past this many contacts a solver is timed once
ONE_REPEAT_ABOVE = 300
#: a call lasting longer than this (seconds) is timed once
SLOW_CALL = 10.0
#: the worst ratio ours / ADMM is quoted over problems of more than this many contacts
WORST_RATIO_ABOVE = 40
NPZ = "contact_scale_impulses.npz"


# -- one problem -----------------------------------------------------------------------------

def _ours_call(case, law: str) -> Callable[[], tuple]:
    from ..contacts.contact_problem import (
        UncertifiedSolutionError,
        generalized_serves,
        solve_contact_problem,
    )

    # the user's path: M and J passed where the engine's fixed rule uses them
    extra = ({"mass_matrix": case.M, "jacobian": case.J} if generalized_serves(case.W)
             else {})

    def call():
        try:
            s = solve_contact_problem(case.W, case.b, case.mu, law=law, tol=TOL, dim=case.dim,
                                      **extra)
            return ("ok", s.impulse, {"iterations": s.iterations,
                                      "engine_residual": s.residual,
                                      "generalized": bool(extra)}, None)
        except UncertifiedSolutionError as exc:
            s = exc.solution
            return ("uncertified", s.impulse, {"iterations": s.iterations,
                                               "engine_residual": exc.residual,
                                               "generalized": bool(extra)}, str(exc))

    return call


def _peer_maker(case, law: str, kind: str, tol: float) -> Callable[[], Callable[[], Any]]:
    cap = ADMM_MAX_ITERATIONS if kind == "admm" else PGS_MAX_ITERATIONS
    return lambda: pinocchio_contact_call(case.W, case.b, case.mu, case.dim, law, tol,
                                          kind=kind, max_iterations=cap)


class _Timed:
    """One solver on one problem: its first call's outcome and its timed batches."""

    def __init__(self, solver: str, run: Callable[[int], tuple]):
        self.solver, self.run = solver, run
        self.times: list[float] = []
        self.first: tuple = ()
        self.n_inner = 1
        self.repeat = True

    def start(self) -> tuple:
        self.first = self.run(1)
        return self.first


def _ours_runner(call: Callable[[], tuple]) -> Callable[[int], tuple]:
    def run(n_inner: int) -> tuple:
        t = time.perf_counter()
        for _ in range(n_inner):
            status, r, facts, err = call()
        dt = (time.perf_counter() - t) / n_inner
        return (status, dt, r, facts, err)

    return run


def _peer_runner(worker: PeerWorker) -> Callable[[int], tuple]:
    def run(n_inner: int) -> tuple:
        if worker.ready[0] != "ready":
            return worker.ready
        return worker.run(n_inner, TIME_LIMIT)

    return run


def measure_problem(case, law: str, repeat: int, min_batch_time: float, peers: bool,
                    skip: dict[str, str]) -> list[dict[str, Any]]:
    """Records of every solver of ``law`` on ``case`` (``skip``: solver -> reason not run);
    each record also carries the answer under ``"_impulse"`` (removed before writing)."""
    base = {"problem": case.name, "family": case.family, "n": case.n_contacts,
            "dim": case.dim, "law": law}
    entries = [_Timed("ours", _ours_runner(_ours_call(case, law)))]
    workers: list[PeerWorker] = []

    def add_peer(solver: str, kind: str, tol: float) -> _Timed:
        w = PeerWorker(_peer_maker(case, law, kind, tol))
        workers.append(w)
        e = _Timed(solver, _peer_runner(w))
        entries.append(e)
        return e

    records = []
    try:
        if peers:
            for solver, kind in (("admm", "admm"), ("pgs", "pgs")):
                if solver not in skip:
                    add_peer(solver, kind, TOL)
        for e in entries:
            e.start()
        admm = next((e for e in entries if e.solver == "admm"), None)
        rerun = admm is not None and admm.first[0] == "ok" and \
            natural_map_residual(case.W, case.b, case.mu, admm.first[2], law) > TOL
        if rerun and "admm-1e-10" not in skip:
            add_peer("admm-1e-10", "admm", TIGHT_TOL).start()
        timed = [e for e in entries if e.first[0] in ("ok", "uncertified")]
        for e in timed:
            dt = e.first[1]
            e.repeat = case.n_contacts <= ONE_REPEAT_ABOVE and dt <= SLOW_CALL
            e.n_inner = int(min(MAX_INNER, max(1, math.ceil(min_batch_time / max(dt, 1e-9)))))
            if not e.repeat:
                if e.solver == "ours" and dt <= SLOW_CALL:
                    # its first call may have compiled kernels that only large problems reach
                    # (the supernodal factorization, the NSGS: 4.1 s for 0.2 s on the
                    # 624-sphere pile's CCP with a cold cache): the second one is measured
                    again = e.run(1)
                    dt = again[1] if again[0] == e.first[0] else dt
                e.times.append(dt)
        for _ in range(max(1, repeat)):  # interleaved rounds
            for e in timed:
                if not e.repeat:
                    continue
                out = e.run(e.n_inner)
                if out[0] in ("ok", "uncertified"):
                    e.times.append(out[1])
                else:  # a repeat that failed or timed out: keep what was measured
                    e.repeat = False
        for e in entries:
            records.append(_record(base, case, law, e))
        for solver, reason in skip.items():
            if solver in SOLVERS or rerun:
                records.append({**base, "solver": solver, "status": "skipped",
                                "error": reason, "time_median": None, "residual": None,
                                "certified": False, "claimed": False, "iterations": None,
                                "n_timed": 0})
    finally:
        for w in workers:
            w.close()
    return records


def _record(base: dict[str, Any], case, law: str, e: _Timed) -> dict[str, Any]:
    status, dt, r, facts, err = e.first
    rec = {**base, "solver": e.solver, "status": status, "claimed": status == "ok",
           "tol": TIGHT_TOL if e.solver == "admm-1e-10" else TOL, "iterations": None,
           **(facts or {})}
    if e.times:
        q1, med, q3 = (float(x) for x in np.percentile(e.times, [25, 50, 75]))
        rec.update(time_median=med, time_iqr=q3 - q1, n_timed=len(e.times), n_inner=e.n_inner)
    else:  # failed or timed out: the time to the failure
        rec.update(time_median=dt, time_iqr=None, n_timed=0)
    if r is not None:
        res = natural_map_residual(case.W, case.b, case.mu, r, law)
        rec["residual"] = res
        rec["certified"] = bool(status == "ok" and res <= TOL)
        rec["_impulse"] = np.asarray(r, dtype=float).reshape(case.n_contacts, case.dim)
    else:
        rec.update(residual=None, certified=False)
    if err:
        rec["error"] = err
    return rec


# -- the section -------------------------------------------------------------------------------

def _cases(config: BenchConfig):
    cases = quick_corpus() if config.quick else corpus()
    return sorted(cases, key=lambda c: (c.n_contacts, c.name))


def _warm_up(cases, law: str) -> None:
    """The first call of a law, untimed (compilation, caches), and of the engine's compiled
    ADMM (:mod:`convimpact.contacts.admm_kernel`), which the smallest problems do not
    reach."""
    from ..contacts.admm_kernel import dense_admm
    from ..contacts.engine import warm_newton

    _ours_call(cases[0], law)()
    W, b, mu = np.array([[2.0, 0.5], [0.5, 1.0]]), np.array([-1.0, 0.5]), np.array([0.3])
    dense_admm(W, b, mu, 2, np.zeros((1, 2)), tol=1e-8, max_iter=100, coulomb=law == "coulomb")
    warm_newton(W, b, mu, 2, np.zeros((1, 2)), coulomb=law == "coulomb")  # its Newton


def _short(t: float | None) -> str:
    if t is None:
        return "-"
    return f"{t * 1e6:.0f} us" if t < 1e-3 else (f"{t * 1e3:.1f} ms" if t < 1 else f"{t:.2f} s")


def _progress_line(i: int, total: int, case, law: str, recs: list[dict[str, Any]]) -> str:
    parts = []
    for r in recs:
        mark = ("certified" if r["certified"] else r["status"] if r["status"] != "ok" else
                "not certified")
        res = "" if r["residual"] is None else f" res {r['residual']:.0e}"
        parts.append(f"{r['solver']} {_short(r['time_median'])}{res} {mark}")
    return (f"contact-scale [{i}/{total}] {law} {case.name} ({case.n_contacts} contacts): "
            + "; ".join(parts))


@register_section("contact-scale", "contact engine at scale: solve_contact_problem against "
                                   "Pinocchio's ADMM and PGS on 2-1,000-contact problems "
                                   "(laws ccp and coulomb), certified by the natural-map "
                                   "residual at 1e-8")
def contact_scale_section(config: BenchConfig, progress: Progress) -> SectionResult:
    from .contact_scale_charts import profile_chart, times_chart
    from .pinocchio_peers import pinocchio_version

    laws = QUICK_LAWS if config.quick else LAWS
    cases = _cases(config)
    notes = list(corpus_notes())
    peers = pinocchio_version() is not None
    if not peers:
        notes.append("pinocchio is not installed: only ours is measured")
    records: list[dict[str, Any]] = []
    total = len(cases) * len(laws)
    i = 0
    for law in laws:
        _warm_up(cases, law)
        timed_out: dict[tuple[str, str], int] = {}  # (family, solver) -> contacts
        for case in cases:
            i += 1
            skip = {s: f"skipped: timed out past {TIME_LIMIT:g} s on {n} contacts of this "
                       "family" for (fam, s), n in timed_out.items()
                    if fam == case.family and n < case.n_contacts}
            recs = measure_problem(case, law, config.repeat, config.min_batch_time, peers,
                                   skip)
            for r in recs:
                if r["status"] == "timeout":
                    timed_out.setdefault((case.family, r["solver"]), case.n_contacts)
            records += recs
            progress(_progress_line(i, total, case, law, recs))
    figures = [times_chart(records, laws, config.out, TIME_LIMIT),
               profile_chart(records, laws, config.out)]
    impulses = {}
    for j, r in enumerate(records):
        imp = r.pop("_impulse", None)
        if imp is not None:
            r["impulse_key"] = f"r{j}"
            impulses[r["impulse_key"]] = imp
    if config.keep_records:
        Path(config.out).mkdir(parents=True, exist_ok=True)
        np.savez_compressed(Path(config.out) / NPZ, **impulses)
    else:
        for r in records:
            r.pop("impulse_key", None)
    aggregates = aggregate(records, laws)
    summary = summary_lines(aggregates) + notes
    meta = {"laws": list(laws), "tol": TOL, "tight_tol": TIGHT_TOL,
            "problems": [c.name for c in cases], "names": NAMES,
            "residual": "natural_map_residual (contact_peers): |r - P_K(r - y)| / "
                        "max(|b|, |r|, |u|), y = u (ccp) or u + mu |u_t| e_n (coulomb)",
            "certified": f"residual <= {TOL:g} (and, for ours, no UncertifiedSolutionError)",
            "admm_solved": "certified at 1e-8, or its rerun at tolerance 1e-10 certified (the "
                           "time is then the 1e-10 run's)",
            "time": f"median of up to {config.repeat} interleaved rounds after an untimed "
                    f"first call; one call past {ONE_REPEAT_ABOVE} contacts or "
                    f"{SLOW_CALL:g} s (ours past {ONE_REPEAT_ABOVE}: its second); peers "
                    "timed in worker processes",
            "limits": {"time_limit_seconds": TIME_LIMIT,
                       "admm_max_iterations": ADMM_MAX_ITERATIONS,
                       "pgs_max_iterations": PGS_MAX_ITERATIONS},
            "peer_workers": "forked processes, soft stack limit raised to the hard limit "
                            "(Pinocchio 4.1's PGS overflowed the 8 MB default from about 400 "
                            "contacts on)",
            "pgs_ccp": "PGS is asked for the CCP with solve_ncp False, but returned Coulomb's "
                       "answer in earlier checks (pinocchio_peers.peer_facts): its ccp answers "
                       "are judged against a law it may not solve",
            "iterations": "ours only (interior-point iterations and Newton steps); the peer "
                          "call does not return its count",
            "generalized": "ours called with mass_matrix and jacobian (the corpus's M and J) "
                           "where contact_problem.generalized_serves(W) holds (the engine's "
                           "sparse path: a fixed rule on W, no timing), with W alone elsewhere",
            "impulses": NPZ if config.keep_records else None,
            "fit_min_contacts": FIT_MIN_CONTACTS, "aggregates": aggregates}
    return SectionResult("contact-scale", records, figures, summary, meta)


def aggregate(records: list[dict[str, Any]], laws) -> dict[str, Any]:
    """Per law: certified counts, fitted exponents, ratios ours / ADMM, ours' failures."""
    out: dict[str, Any] = {}
    for law in laws:
        problems, table = certified_times(records, law)
        rows = {(r["problem"], r["solver"]): r for r in records if r["law"] == law}
        n_of = {r["problem"]: r["n"] for r in records if r["law"] == law}
        a: dict[str, Any] = {"problems": len(problems)}
        a["certified"] = {s: sum(t is not None for t in table[s]) for s in SOLVERS}
        a["admm_certified_at_1e-8"] = sum(bool(rows.get((p, "admm"), {}).get("certified"))
                                          for p in problems)
        a["admm_reruns_at_1e-10"] = sum((p, "admm-1e-10") in rows and
                                        rows[(p, "admm-1e-10")]["status"] != "skipped"
                                        for p in problems)
        a["timeouts"] = sorted(f"{r['solver']} {r['problem']}" for r in rows.values()
                               if r["status"] in ("timeout", "skipped"))
        a["crashes"] = sorted(f"{r['solver']} {r['problem']} ({r.get('error', '')})"
                              for r in rows.values() if r["status"] == "crashed")
        a["exponents"] = {s: _fit(problems, table[s], n_of) for s in SOLVERS}
        family_of = {r["problem"]: r.get("family", "") for r in records if r["law"] == law}
        a["family_exponents"] = {
            fam: {s: _fit(problems, table[s], n_of, lambda p: family_of[p] == fam)
                  for s in ("ours", "admm")}
            for fam in sorted(set(family_of.values()) - {""})}
        ratios = [(p, o / m) for p, o, m in zip(problems, table["ours"], table["admm"])
                  if o is not None and m is not None]
        a["ratio_ours_admm_median"] = (float(np.median([x for _, x in ratios]))
                                       if ratios else None)
        a["ratio_ours_admm_count"] = len(ratios)
        big = [(p, x) for p, x in ratios if n_of[p] > WORST_RATIO_ABOVE]
        worst = max(big, key=lambda px: px[1]) if big else None
        a["ratio_ours_admm_worst_past_40"] = (None if worst is None else
                                              {"problem": worst[0], "n": n_of[worst[0]],
                                               "ratio": worst[1]})
        a["ours_failures"] = [{"problem": r["problem"], "n": r["n"], "status": r["status"],
                               "residual": r["residual"],
                               "engine_residual": r.get("engine_residual")}
                              for r in rows.values() if r["solver"] == "ours"
                              and not r["certified"]]
        out[law] = a
    return out


def _fit(problems, times, n_of, keep=lambda p: True) -> dict[str, Any]:
    """The power law ``t = c n^p`` fitted over the certified problems of at least
    :data:`FIT_MIN_CONTACTS` contacts that ``keep`` accepts (nan below
    :data:`FIT_MIN_POINTS` of them)."""
    pts = [(n_of[p], t) for p, t in zip(problems, times)
           if t is not None and n_of[p] >= FIT_MIN_CONTACTS and keep(p)]
    p_, c_ = (power_law_fit(*zip(*pts)) if len(pts) >= FIT_MIN_POINTS
              else (math.nan, math.nan))
    return {"exponent": p_, "coefficient": c_, "points": len(pts)}


def summary_lines(aggregates: dict[str, Any]) -> list[str]:
    lines = []
    for law, a in aggregates.items():
        n = a["problems"]
        c = a["certified"]
        lines.append(
            f"{law}: certified at 1e-8 by the natural-map residual on {n} problems: ours "
            f"{c['ours']}/{n}, Pinocchio ADMM {a['admm_certified_at_1e-8']}/{n} at its tol "
            f"1e-8 ({c['admm']}/{n} with its rerun at 1e-10 on {a['admm_reruns_at_1e-10']}), "
            f"PGS {c['pgs']}/{n}")
        if a["ratio_ours_admm_median"] is not None:
            s = (f"{law}: time ours / ADMM at equal certified accuracy: median "
                 f"{a['ratio_ours_admm_median']:.3g} over {a['ratio_ours_admm_count']} problems "
                 "both solved")
            w = a["ratio_ours_admm_worst_past_40"]
            s += (f"; worst past {WORST_RATIO_ABOVE} contacts {w['ratio']:.3g} "
                  f"({w['problem']})" if w else f"; none solved by both past "
                                                f"{WORST_RATIO_ABOVE} contacts")
            lines.append(s)
        ex = a["exponents"]
        lines.append(f"{law}: fitted time ~ n^p over certified problems of >= "
                     f"{FIT_MIN_CONTACTS} contacts: " + ", ".join(
                         f"{NAMES[s].split(' (')[0]} p = {ex[s]['exponent']:.2f} "
                         f"({ex[s]['points']} problems)" if ex[s]["points"] >= FIT_MIN_POINTS else
                         f"{NAMES[s].split(' (')[0]} (too few)" for s in SOLVERS))
        fams = [(f, e) for f, e in a.get("family_exponents", {}).items()
                if e["ours"]["points"] >= FIT_MIN_POINTS]
        if fams:
            lines.append(f"{law}: the same fit per family, ours (ADMM): " + ", ".join(
                f"{f} n^{e['ours']['exponent']:.2f} (" + (
                    f"n^{e['admm']['exponent']:.2f}" if e["admm"]["points"] >= FIT_MIN_POINTS
                    else "too few") + ")" for f, e in fams))
        if a["ours_failures"]:
            lines.append(f"{law}: ours not certified on " + ", ".join(
                f"{f['problem']} (residual {f['residual']:.1e})" if f["residual"] is not None
                else f["problem"] for f in a["ours_failures"]))
        if a["crashes"]:
            lines.append(f"{law}: the peer's process crashed on {len(a['crashes'])} problems: "
                         + ", ".join(c.split(" (")[0] for c in a["crashes"])
                         + f" ({a['crashes'][0].split(' (', 1)[1].rstrip(')')})")
        if a["timeouts"]:
            lines.append(f"{law}: timed out (> {TIME_LIMIT:g} s) or skipped after a timeout: "
                         + ", ".join(a["timeouts"]))
    return lines
