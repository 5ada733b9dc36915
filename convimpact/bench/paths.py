"""The solver paths the per-impact benchmark times: (law, method, setting) and their kernels.

A :class:`SolverPath` is one method at one setting of its options (tolerances, grids), with
the laws it serves, whether it treats one contact only, and, where one exists, the bare kernel
that works on the contact block ``(W, v)`` without the ``solve_problem`` wrapping (validation
of options, result assembly and diagnostics).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

from ..impact import LAWS, available_methods
from ..impact.conic.qp import DEFAULT_TOL  # the conic paths' default tolerance
from ..impact.problem.build import ImpactProblem

#: tolerance of the tight reference for several contacts
REFERENCE_TOL = 1e-12


@dataclass(frozen=True)
class SolverPath:
    """One method at one setting.

    Attributes
    ----------
    method : the ``method=`` of ``solve_problem``.
    setting : short label of the options, e.g. ``"tol=1e-06"`` or ``"default"``.
    options : keyword options passed to ``solve_problem``.
    laws : laws the path serves.
    single_only : True when the method treats one contact only.
    kernel : ``kernel(problem, law) -> call`` returning a no-argument call of the bare kernel,
        or None.
    """

    method: str
    setting: str
    options: Mapping[str, Any] = field(default_factory=dict)
    laws: tuple[str, ...] = LAWS
    single_only: bool = False
    kernel: Callable[[ImpactProblem, str], Callable[[], Any]] | None = None

    @property
    def label(self) -> str:
        return self.method if self.setting == "default" else f"{self.method} {self.setting}"

    def options_for(self, law: str) -> dict[str, Any]:
        """Options for ``law``: the Coulomb fixed point follows ``tol`` (10 tol, the default
        ratio 1e-9 / 1e-10)."""
        opts = dict(self.options)
        if law == "coulomb" and "tol" in opts and self.method in ("clarabel", "cvxpy"):
            opts["fixed_point_tol"] = min(10.0 * opts["tol"], 1e-2)
        return opts


def _fast_kernel(problem: ImpactProblem, law: str):
    from ..impact.exact.dispatch import solve_contact

    W, v = problem.contact_block(0)
    e, mu = float(problem.restitution[0]), float(problem.friction[0])
    return lambda: solve_contact(W, v, e, mu, law)


def _closed_form_kernel(problem: ImpactProblem, law: str):
    from ..impact.laws.pereira_nikravesh import pereira_nikravesh

    W, v = problem.contact_block(0)
    e, mu = float(problem.restitution[0]), float(problem.friction[0])
    return lambda: pereira_nikravesh(W, v, e, mu)


def _tol(t: float) -> str:
    return f"tol={t:.0e}"


def solver_paths(quick: bool) -> list[SolverPath]:
    """The paths of a full or quick run (only methods registered in this install)."""
    pn = ("pereira-nikravesh",)
    paths = [
        SolverPath("closed-form", "default", laws=pn, single_only=True,
                   kernel=_closed_form_kernel),
        SolverPath("fast", "default", single_only=True, kernel=_fast_kernel),
    ]
    sweeps = ([(1e-3, 36), (1e-10, 360)] if quick
              else [(1e-2, 36), (1e-5, 90), (1e-10, 360)])
    for xtol, grid in sweeps:
        paths.append(SolverPath("sweep", f"xtol={xtol:.0e} grid={grid}",
                                {"xtol": xtol, "n_grid": grid}, laws=pn, single_only=True))
    clar = [1e-6, 1e-10] if quick else [1e-4, 1e-6, 1e-8, 1e-10, 1e-12]
    for t in clar:
        paths.append(SolverPath("clarabel", _tol(t), {"tol": t}))
    for t in ([1e-10] if quick else [1e-6, 1e-8, 1e-10]):
        paths.append(SolverPath("cvxpy", _tol(t), {"tol": t}))
    registered = {law: set(available_methods(law)) for law in LAWS}
    return [p for p in paths if any(p.method in registered[law] for law in p.laws)]


def reference_paths(single: bool) -> list[SolverPath]:
    """Reference candidates in order: fast for one contact, then Clarabel and cvxpy at 1e-12."""
    out = [SolverPath("fast", "default", single_only=True)] if single else []
    out += [SolverPath("clarabel", _tol(REFERENCE_TOL), {"tol": REFERENCE_TOL}),
            SolverPath("cvxpy", _tol(REFERENCE_TOL), {"tol": REFERENCE_TOL}),
            SolverPath("clarabel", _tol(DEFAULT_TOL), {"tol": DEFAULT_TOL})]
    return out
