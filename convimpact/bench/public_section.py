"""Section ``public``: one public ``resolve_impact`` call against its kernels and Pinocchio.

For every law, planar (d = 2, k = 2 and 4) and spatial (d = 3, k = 3 and 6) contacts, on
:data:`N_PROBLEMS` random approaching single-contact impacts (SPD M, random Jc with the normal
row turned so that the contact approaches, e ~ U(0, 1), mu ~ U(0, 1.5): sticking and sliding
mixed), each path is timed as the median over timed batches of one loop over the problems,
divided by their number (µs per impact):

* ``resolve_impact``: the public call, ``method="auto"`` (full validation, the law, dq+, the
  result; diagnostics measured on first access and not read here);
* ``kernel from Python``: :func:`convimpact.impact.exact.dispatch.solve_contact` on the
  problem's (W, v-) -- the law's one compiled kernel called from Python, impulse only;
* ``compiled kernel``: :func:`convimpact.impact.batch.impacts.contact_impulses` on all the problems'
  (W, v-) at once, per impact -- the compiled kernel without per-call overhead;
* ``pinocchio ADMM`` (``ccp``: ``solve_ncp=False``; ``coulomb``: ``True``) and ``pinocchio PGS``
  (``coulomb``) on the same W at tolerance 1e-10 (:mod:`convimpact.bench.pinocchio_peers`;
  planar problems embedded in space), where the law is theirs.

Accuracy: the largest impulse error relative to |pi| against an independent reference -- the
law's convex program through Clarabel at tolerance 1e-12 for ``ccp`` and ``dissipative``
(``method="clarabel"``; unique answers) and for ``pereira-nikravesh`` (its conic path: the
paper's closed form in the plane, the program P_N KKT-polished in space), the kernel itself for
``stronge`` (no second method here: its kernel is checked against an independent ``solve_ivp``
integration in impulse space by ``tests/impact/test_stronge.py``), the law's definition
evaluated in numpy for
``chatterjee-ruina`` (J_I = -(v_n / W_nn) n, J_II = -W^-1 v, (1 + e) J_I + (1 + e_t)(J_II - J_I)
brought back into the cone along J_II - J_I; its e_t ~ U(-1, 1) per problem, drawn apart so
that the other laws' problems are unchanged). Coulomb's law may have several solutions at one
spatial contact (its kernel lists them in ``extras["n_slide_solutions"]``; Clarabel's fixed
point and Pinocchio may land on another): its accuracy is Coulomb's own residual
(:func:`convimpact.impact.laws.coulomb.coulomb_residual`: cone, dual cone and
complementarity, relative), which every solution zeroes. The issue's targets are checked and
stated: the public call at most 15 µs planar and 25 µs spatial, and within 2x of its kernel.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from .registry import BenchConfig, Progress, SectionResult, register_section

LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge", "chatterjee-ruina")
SHAPES = ((2, 2), (2, 4), (3, 3), (3, 6))
#: problems per (law, shape) (full, quick)
N_PROBLEMS = (60, 12)
#: the issue's targets for one public call (seconds)
TARGET = {2: 15e-6, 3: 25e-6}
#: laws whose spatial kernel integrates the slip in impulse space (no closed form)
INTEGRATED_IN_SPACE = ("stronge",)
#: laws measured against their conic path through Clarabel (a second method)
CONIC_REFERENCE = ("ccp", "dissipative", "pereira-nikravesh")
#: Pinocchio's solvers per law: (label, kind, solve_ncp)
PEERS = {"ccp": (("pinocchio ADMM", "admm", False),),
         "coulomb": (("pinocchio ADMM", "admm", True), ("pinocchio PGS", "pgs", True))}
PATHS = ("resolve_impact", "kernel from Python", "compiled kernel", "pinocchio ADMM", "pinocchio PGS")


def _problems(seed: int, n: int, d: int, k: int, law: str = "") -> list[dict[str, Any]]:
    from convimpact.impact.laws import TANGENTIAL_LAWS

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        A = rng.normal(size=(k, k))
        M = A @ A.T + 0.5 * np.eye(k)
        J = rng.normal(size=(d, k))
        dq = rng.normal(size=k)
        if J[0] @ dq > 0:
            J[0] = -J[0]
        out.append({"M": M, "Jc": J, "dq": dq, "e": float(rng.uniform()),
                    "mu": float(rng.uniform(0.0, 1.5))})
    if law in TANGENTIAL_LAWS:  # its e_t from a stream of its own: the problems are the same
        et = np.random.default_rng([seed, 1]).uniform(-1.0, 1.0, n)
        for p, x in zip(out, et):
            p["e_t"] = float(x)
    return out


def chatterjee_ruina_reference(W: np.ndarray, v: np.ndarray, e: float, mu: float,
                               e_t: float) -> np.ndarray:
    """Law ``chatterjee-ruina``'s impulse from its definition, in numpy (the reference its
    kernels are measured against): the plastic frictionless and sticking impulses J_I and J_II,
    J^ = (1 + e) J_I + (1 + e_t)(J_II - J_I), kept when in the cone, else
    (1 + e) J_I + kappa (J_II - J_I) on its boundary."""
    j1 = np.zeros_like(v)
    j1[0] = -v[0] / W[0, 0]
    b = -np.linalg.solve(W, v) - j1
    J = (1.0 + e) * j1 + (1.0 + e_t) * b
    if np.linalg.norm(J[1:]) <= mu * J[0]:
        return J
    kappa = mu * (1.0 + e) * j1[0] / (np.linalg.norm(b[1:]) - mu * b[0])
    return (1.0 + e) * j1 + kappa * b


#: shortest timed batch (seconds): the loops take about a millisecond, and a burst of load on
#: the shared machine would otherwise dominate a batch of two or three of them
MIN_BATCH_TIME = 0.02


def _per_impact(fn, n: int, config: BenchConfig) -> float:
    """Median seconds per impact of ``fn()`` (a loop over n impacts)."""
    from .timing import time_call

    batch = config.min_batch_time if config.quick else max(config.min_batch_time,
                                                           MIN_BATCH_TIME)
    timing, _ = time_call(fn, repeat=config.repeat, min_batch_time=batch)
    return timing.median / n


class _CoulombCertificate:
    """Coulomb's residual of an impulse at one contact (a law with several solutions)."""

    def __init__(self, W, v, e, mu):
        self.W, self.b, self.mu = W, v.copy(), np.array([mu])
        self.b[0] += e * min(v[0], 0.0)  # Newton's restitution shift

    def error(self, pi) -> float:
        from convimpact.impact.laws.coulomb import coulomb_residual

        pi = np.asarray(pi, float)
        return coulomb_residual(self.W, self.b, self.mu, self.W.shape[0], pi)


def _error(a: np.ndarray, ref) -> float:
    if isinstance(ref, _CoulombCertificate):
        return ref.error(a)
    return float(np.abs(a - ref).max() / max(np.abs(ref).max(), 1e-300))


@register_section("public", "the public call: resolve_impact per law against the law's Python "
                            "and compiled kernels and Pinocchio's ADMM/PGS, planar and spatial")
def public_section(config: BenchConfig, progress: Progress) -> SectionResult:
    import convimpact as ci
    from convimpact.impact.exact import lane
    from convimpact.impact.batch.impacts import contact_impulses
    from convimpact.impact.exact.dispatch import solve_contact
    from convimpact.impact.problem.build import build_problem

    from .pinocchio_peers import contact_solver_call, pinocchio_version

    t = time.perf_counter()
    compile_s = lane.compile_lane()
    progress(f"public: compiled lane ready in {time.perf_counter() - t:.2f} s")
    have_pin = pinocchio_version() is not None
    n = N_PROBLEMS[1] if config.quick else N_PROBLEMS[0]
    records: list[dict[str, Any]] = []
    failures: list[str] = []
    for d, k in SHAPES:
        for law in LAWS:
            probs = _problems(config.seed + 100 * d + k, n, d, k, law)
            P = [build_problem(p["M"], p["Jc"], p["dq"], p["e"], p["mu"], None, p.get("e_t"))
                 for p in probs]
            W = np.array([q.delassus for q in P])
            v = np.array([q.v_minus[0] for q in P])
            e = np.array([p["e"] for p in probs])
            mu = np.array([q.friction[0] for q in P])
            # the law's parameters beyond e and mu (e_t), per problem, for the laws with them
            tangential = "e_t" in probs[0]
            et = np.array([p["e_t"] for p in probs]) if tangential else np.zeros(n)
            extra = [{"e_t": p["e_t"]} if tangential else {} for p in probs]
            batch_extra = {"e_t": et} if tangential else {}
            public = [ci.resolve_impact(**p, law=law) for p in probs]
            if law in CONIC_REFERENCE:
                ref = [ci.solve_problem(q, law, "clarabel", tol=1e-12).impulse for q in P]
                ref_name = "clarabel tol=1e-12"
            elif law == "coulomb":
                ref = [_CoulombCertificate(W[i], v[i], e[i], mu[i]) for i in range(n)]
                ref_name = "Coulomb residual"
            elif law == "chatterjee-ruina":
                ref = [chatterjee_ruina_reference(W[i], v[i], e[i], mu[i], et[i])
                       for i in range(n)]
                ref_name = "the law's definition in numpy"
            else:
                ref = [np.asarray(solve_contact(W[i], v[i], e[i], mu[i], law).impulse)
                       for i in range(n)]
                ref_name = "the kernel itself (solve_ivp in the tests)"
            rows: list[tuple[str, float, float]] = []

            def public_loop():
                for p, x in zip(probs, extra):
                    ci.resolve_impact(p["M"], p["Jc"], p["dq"], p["e"], p["mu"], law=law, **x)

            err = max(_error(r.impulse, ref[i]) for i, r in enumerate(public))
            rows.append(("resolve_impact", _per_impact(public_loop, n, config), err))
            Wl, vl, etl = list(W), list(v), et.tolist()

            def kernel_loop():
                for i in range(n):
                    solve_contact(Wl[i], vl[i], e[i], mu[i], law, etl[i])

            err = max(_error(np.asarray(solve_contact(W[i], v[i], e[i], mu[i], law,
                                                      etl[i]).impulse),
                             ref[i]) for i in range(n))
            rows.append(("kernel from Python", _per_impact(kernel_loop, n, config), err))
            b = contact_impulses(W, v, e, mu, law, threads=1, **batch_extra)
            err = max(_error(b.impulse[i], ref[i]) for i in range(n))
            rows.append(("compiled kernel", _per_impact(
                lambda: contact_impulses(W, v, e, mu, law, threads=1, **batch_extra), n,
                config), err))
            for label, kind, ncp in (PEERS.get(law, ()) if have_pin else ()):
                calls = [contact_solver_call(q, kind, ncp, 1e-10) for q in P]
                try:
                    err = max(_error(c()[0], ref[i]) for i, c in enumerate(calls))
                except RuntimeError as exc:  # a peer that does not converge: said, not timed
                    failures.append(f"{label} on {law} d={d} k={k}: {exc}")
                    progress(f"public: {failures[-1]}")
                    continue

                def peer_loop():
                    for c in calls:
                        c()

                rows.append((label, _per_impact(peer_loop, n, config), err))
            for path, sec, err in rows:
                records.append({"law": law, "d": d, "k": k, "path": path, "n": n,
                                "seconds_per_impact": sec, "max_error": err,
                                "reference": ref_name})
            progress(f"public {law} d={d} k={k}: " + ", ".join(
                f"{p} {s * 1e6:.1f} us (err {e_:.0e})" for p, s, e_ in rows))
    fig = _chart(records, Path(config.out))
    meta = {"definition": "seconds_per_impact = median wall time of a loop over the problems "
                          "/ their number; max_error = max |pi - pi_ref| / |pi_ref|",
            "n_problems": n, "shapes": [list(s) for s in SHAPES],
            "targets_us": {"planar": TARGET[2] * 1e6, "spatial": TARGET[3] * 1e6},
            "lane_compile_seconds_in_this_process": compile_s,
            "lane_compile": dict(lane.COMPILE_SECONDS), "peer_failures": failures}
    summary = _summary(records)
    if failures:
        summary.append(f"not timed (no convergence on at least one of the {n} problems): "
                       + "; ".join(failures))
    return SectionResult("public", records, [fig], summary, meta)


def _summary(records: list[dict[str, Any]]) -> list[str]:
    by = {(r["law"], r["d"], r["k"], r["path"]): r for r in records}
    out = []
    for d in (2, 3):
        pub = [r for r in records if r["d"] == d and r["path"] == "resolve_impact"]
        if not pub:
            continue
        us = [r["seconds_per_impact"] * 1e6 for r in pub]
        ratios = [r["seconds_per_impact"] / by[(r["law"], d, r["k"], "kernel from Python")]
                  ["seconds_per_impact"] for r in pub]
        cratios = [r["seconds_per_impact"] / by[(r["law"], d, r["k"], "compiled kernel")]
                   ["seconds_per_impact"] for r in pub]
        worst = max(pub, key=lambda r: r["seconds_per_impact"])
        kind = "planar" if d == 2 else "spatial"
        closed = [r["seconds_per_impact"] * 1e6 for r in pub
                  if not (d == 3 and r["law"] in INTEGRATED_IN_SPACE)]
        met = ("met" if max(closed) <= TARGET[d] * 1e6 else "not met") + (
            f" for every law with a closed form or a finite search (slowest {max(closed):.1f} "
            "us)" if d == 3 else "")
        out.append(
            f"resolve_impact, one {kind} contact, every law (k = "
            f"{'/'.join(str(k) for k in sorted({r['k'] for r in pub}))}): median "
            f"{np.median(us):.1f} us per call (range {min(us):.1f}..{max(us):.1f}; slowest "
            f"{worst['law']} k={worst['k']}); target {TARGET[d] * 1e6:.0f} us {met}; "
            f"public / kernel from Python {np.median(ratios):.2f} (range {min(ratios):.2f}.."
            f"{max(ratios):.2f}); public / compiled kernel {np.median(cratios):.1f} (the "
            f"call's fixed cost); largest impulse error {max(r['max_error'] for r in pub):.1e}")
    for law, label in (("ccp", "pinocchio ADMM"), ("coulomb", "pinocchio ADMM"),
                       ("coulomb", "pinocchio PGS")):
        for d, k in SHAPES:
            peer = by.get((law, d, k, label))
            pub = by.get((law, d, k, "resolve_impact"))
            if peer is None or pub is None:
                continue
            out.append(
                f"{law} d={d} k={k}: resolve_impact {pub['seconds_per_impact'] * 1e6:.1f} us "
                f"(error {pub['max_error']:.0e}) vs {label} tol=1e-10 "
                f"{peer['seconds_per_impact'] * 1e6:.1f} us on W alone (error "
                f"{peer['max_error']:.0e}): ratio ours/peer "
                f"{pub['seconds_per_impact'] / peer['seconds_per_impact']:.2f}")
    return out


def _chart(records: list[dict[str, Any]], out: Path) -> str:
    """Speed against accuracy: µs per impact (x, log) against the largest impulse error (y,
    log; round-off floored at 1e-17), one panel per planar/spatial, one marker per path."""
    from matplotlib.ticker import NullFormatter

    from .charts import _plt, save_chart

    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), sharey=True)
    markers = {"resolve_impact": "o", "kernel from Python": "s", "compiled kernel": "^",
               "pinocchio ADMM": "D", "pinocchio PGS": "v"}
    colors = dict(zip(LAWS, ("C0", "C1", "C2", "C3", "C4", "C5")))
    for ax, d in zip(axes, (2, 3)):
        for r in records:
            if r["d"] != d:
                continue
            ax.scatter(r["seconds_per_impact"] * 1e6, max(r["max_error"], 1e-17),
                       marker=markers[r["path"]], color=colors[r["law"]], s=28, alpha=0.8)
        ax.axvline(TARGET[d] * 1e6, color="k", ls="--", lw=0.8)
        ax.text(TARGET[d] * 1e6, 1e-17, f" target {TARGET[d] * 1e6:.0f} us", fontsize=7,
                va="bottom")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("µs per impact (median)")
        ax.set_title(f"{'planar' if d == 2 else 'spatial'} contact, k = "
                     f"{', '.join(str(k) for dd, k in SHAPES if dd == d)}", fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
    axes[0].set_ylabel("largest impulse error (relative)")
    handles = [plt.Line2D([], [], ls="", marker=m, color="gray", label=p)
               for p, m in markers.items()]
    handles += [plt.Line2D([], [], ls="", marker="o", color=c, label=law)
                for law, c in colors.items()]
    fig.legend(handles=handles, fontsize=7, loc="lower center", ncol=6, frameon=False)
    fig.suptitle("one public call against its kernels and Pinocchio (error vs Clarabel 1e-12, "
                 "the conic path, the law's definition, or Coulomb's residual)", fontsize=10)
    fig.tight_layout(rect=(0, 0.09, 1, 1))
    return save_chart(fig, out, "public_call.png")
