"""The benchmark's impact problems: the same ones for every solver path.

Random problems (fixed seeds) span planar and spatial contacts, one and several contacts, open
and closed loops, k = 2 ... 30 joint coordinates and mass matrices of controlled conditioning:
``M = Q diag(s) Q^T`` with Q a random rotation and ``s`` log-spaced from 1 to ``cond``. The
contact Jacobians are random with each normal row oriented so the contact approaches
(``v_n- < 0``, ``|v_n-|`` at least a tenth of ``|c_n| |dq|``); the loop Jacobian C is random of
full row rank and ``dq`` lies in its null space (eq. 7). Several contacts use
``n_contacts d <= k - m`` rows so the Delassus matrix is nonsingular. The paper's impact
states (planar and spatial double pendulum, slider-crank) join when ``convimpact.problems``
imports.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..impact.problem.build import ImpactProblem, build_problem

#: problem classes (one chart panel each), in panel order
CLASSES = tuple(f"{geo}, {num}, {loop}" for geo in ("planar", "spatial")
                for num in ("1 contact", "several contacts") for loop in ("open", "closed"))


def class_name(planar: bool, n_contacts: int, closed: bool) -> str:
    return (f"{'planar' if planar else 'spatial'}, "
            f"{'1 contact' if n_contacts == 1 else 'several contacts'}, "
            f"{'closed' if closed else 'open'}")


@dataclass(frozen=True, eq=False)
class BenchProblem:
    """One impact of the benchmark.

    Attributes
    ----------
    name : unique label, e.g. ``"rand-spatial-n3-k12-m0-c1e+03-s4"`` or ``"pendulum_3d"``.
    problem_class : one of :data:`CLASSES`.
    source : ``"random"`` or ``"scene"``.
    args : the raw ``resolve_impact`` arguments M, Jc, dq, C, e, mu.
    problem : the validated :class:`~convimpact.impact.problem.build.ImpactProblem`.
    info : JSON-ready facts (k, n_contacts, dim, n_loops, mass condition, e, mu, ...).
    """

    name: str
    problem_class: str
    source: str
    args: Mapping[str, Any]
    problem: ImpactProblem
    info: Mapping[str, Any] = field(default_factory=dict)

    def frictionless(self) -> ImpactProblem:
        """The same impact with mu = 0 at every contact."""
        a = self.args
        return build_problem(a["M"], a["Jc"], a["dq"], a["e"], 0.0, a["C"])


def random_spd(rng: np.random.Generator, k: int, cond: float) -> np.ndarray:
    """Random symmetric positive definite k x k matrix with 2-norm condition number ``cond``."""
    Q, R = np.linalg.qr(rng.normal(size=(k, k)))
    Q = Q * np.sign(np.diag(R))
    s = np.logspace(0.0, np.log10(cond), k) if k > 1 else np.ones(1)
    M = (Q * s) @ Q.T
    return 0.5 * (M + M.T)


def random_impact(rng: np.random.Generator, k: int, n_contacts: int, dim: int, n_loops: int = 0,
                  cond: float = 1e2, e: float = 0.5, mu=0.3) -> dict[str, Any]:
    """Raw ``resolve_impact`` arguments of a random impact (see the module docstring)."""
    M = random_spd(rng, k, cond)
    C = None
    dq = rng.normal(size=k)
    if n_loops:
        C = rng.normal(size=(n_loops, k))
        Q, _ = np.linalg.qr(C.T, mode="complete")
        dq = Q[:, n_loops:] @ rng.normal(size=k - n_loops)  # in the null space of C
    Jc = []
    for _ in range(n_contacts):
        J = rng.normal(size=(dim, k))
        while True:
            vn = float(J[0] @ dq)
            if abs(vn) >= 0.1 * np.linalg.norm(J[0]) * np.linalg.norm(dq):
                break
            J[0] = rng.normal(size=k)
        if vn > 0:
            J[0] = -J[0]
        Jc.append(J)
    mu = np.broadcast_to(np.asarray(mu, float), (n_contacts,)).copy()
    return dict(M=M, Jc=Jc[0] if n_contacts == 1 else Jc, dq=dq, C=C, e=float(e),
                mu=float(mu[0]) if n_contacts == 1 else mu.tolist())


def _bench_problem(name: str, source: str, args: dict, extra: dict | None = None) -> BenchProblem:
    P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"], args["C"])
    info = {
        "k": P.n_coordinates, "n_contacts": P.n_contacts, "dim": P.dim, "n_loops": P.n_loops,
        "mass_condition": float(np.linalg.cond(P.mass_matrix)),
        "delassus_condition": float(np.linalg.cond(P.delassus)),
        "e": P.restitution.tolist(), "mu": P.friction.tolist(),
        "v_minus": P.v_minus.tolist(), **(extra or {}),
    }
    return BenchProblem(name, class_name(P.planar, P.n_contacts, P.n_loops > 0), source,
                        args, P, info)


#: random problems (dim, n_contacts, k, n_loops, cond) of the full run, per class
_FULL = {
    (2, False, False): [(1, 2, 0, 1e1), (1, 6, 0, 1e3), (1, 15, 0, 1e2), (1, 30, 0, 1e5)],
    (2, False, True): [(1, 3, 1, 1e1), (1, 8, 2, 1e3), (1, 30, 6, 1e5)],
    (2, True, False): [(2, 4, 0, 1e1), (3, 8, 0, 1e3), (5, 12, 0, 1e2), (10, 30, 0, 1e4)],
    (2, True, True): [(2, 6, 1, 1e2), (3, 10, 2, 1e3), (8, 30, 4, 1e4)],
    (3, False, False): [(1, 3, 0, 1e1), (1, 6, 0, 1e3), (1, 15, 0, 1e2), (1, 30, 0, 1e5)],
    (3, False, True): [(1, 4, 1, 1e1), (1, 9, 2, 1e3), (1, 30, 6, 1e5)],
    (3, True, False): [(2, 6, 0, 1e1), (3, 9, 0, 1e3), (4, 14, 0, 1e2), (8, 30, 0, 1e4)],
    (3, True, True): [(2, 8, 1, 1e2), (3, 12, 2, 1e3), (7, 30, 6, 1e4)],
}
#: the quick run: one small problem per class, one k = 30
_QUICK = {
    (2, False, False): [(1, 6, 0, 1e2)],
    (2, False, True): [(1, 5, 1, 1e2)],
    (2, True, False): [(3, 8, 0, 1e2)],
    (2, True, True): [(2, 6, 1, 1e2)],
    (3, False, False): [(1, 30, 0, 1e3)],
    (3, False, True): [(1, 6, 2, 1e2)],
    (3, True, False): [(2, 8, 0, 1e2)],
    (3, True, True): [(2, 9, 1, 1e2)],
}


def random_problems(quick: bool, seed: int) -> list[BenchProblem]:
    """The random part of the suite (e in [0.2, 0.9], mu in [0.1, 1] per contact)."""
    table = _QUICK if quick else _FULL
    out = []
    for (dim, several, closed), rows in table.items():
        for (n, k, m, cond) in rows:
            # one generator per problem: adding a problem never changes the others
            rng = np.random.default_rng([seed, dim, n, k, m, int(np.log10(cond))])
            e = float(rng.uniform(0.2, 0.9))
            mu = rng.uniform(0.1, 1.0, size=n)
            args = random_impact(rng, k, n, dim, m, cond, e, mu)
            name = f"rand-{'planar' if dim == 2 else 'spatial'}-n{n}-k{k}-m{m}-c{cond:.0e}"
            out.append(_bench_problem(name, "random", args, {"seed": [seed, dim, n, k, m]}))
    return out


def scene_problems() -> tuple[list[BenchProblem], list[str]]:
    """The paper's impact states, with a note for every scene that could not be built."""
    out, notes = [], []
    specs = [
        ("pendulum_planar case a", "pendulum_planar", dict(case="a")),
        ("pendulum_planar case b", "pendulum_planar", dict(case="b")),
        ("pendulum_3d", "pendulum_3d", {}),
        ("slider_crank ratio 1, mu 0.2", "slider_crank", dict(mass_ratio=1.0, mu=0.2)),
        ("slider_crank ratio 10, mu 0.2", "slider_crank", dict(mass_ratio=10.0, mu=0.2)),
    ]
    import importlib

    for label, module, params in specs:
        try:
            mod = importlib.import_module(f"convimpact.problems.{module}")
            args = mod.impact_arguments(**params)
            out.append(_bench_problem(label, "scene", dict(args), {"scene": module,
                                                                 "parameters": params}))
        except Exception as exc:  # a scene that is missing or broken is recorded, not fatal
            notes.append(f"{label}: not included ({type(exc).__name__}: {exc})")
    return out, notes


def problem_suite(quick: bool, seed: int) -> tuple[list[BenchProblem], list[str]]:
    """Random problems of every class plus the paper's impact states; notes on omissions."""
    scenes, notes = scene_problems()
    if quick:
        scenes = [p for p in scenes if p.name in ("pendulum_planar case a", "pendulum_3d")]
    return random_problems(quick, seed) + scenes, notes
