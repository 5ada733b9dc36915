"""The conic solver paths (``method="clarabel"`` and ``"cvxpy"``): options, registration, and
the contact-space helpers the laws' programs share.

A law module of :mod:`convimpact.impact.laws` writes its program(s) as a function
``program_result(problem, backend, method, options) -> ImpactResult`` on the cone QP of
:mod:`~convimpact.impact.conic.qp`; :func:`conic_solver` makes the solver of each conic path
from it (each backend built lazily on first use, so the closed forms never pay for cvxpy).

Options of both conic paths (keyword arguments of ``resolve_impact``): ``tol`` (the conic
solver's gap and feasibility tolerance on the scaled problem, default 1e-10), ``max_iter``
(interior-point iterations, default 200) and, for ``"coulomb"``, ``fixed_point_tol`` (default
1e-9 relative), ``max_fixed_point_iter`` (default 100), ``anderson_memory`` (default 5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..options import parse_method_options
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from .qp import DEFAULT_MAX_ITER, DEFAULT_TOL, TINY, Backend, ConeQP, QPSolution

#: default relative tolerance of the Coulomb fixed point and of its complementarity check
DEFAULT_FIXED_POINT_TOL = 1e-9
DEFAULT_MAX_FIXED_POINT_ITER = 100
DEFAULT_ANDERSON_MEMORY = 5


@dataclass(frozen=True)
class ProgramOptions:
    """Validated options of the conic solver paths (see the module docstring)."""

    tol: float = DEFAULT_TOL
    max_iter: int = DEFAULT_MAX_ITER
    fixed_point_tol: float = DEFAULT_FIXED_POINT_TOL
    max_fixed_point_iter: int = DEFAULT_MAX_FIXED_POINT_ITER
    anderson_memory: int = DEFAULT_ANDERSON_MEMORY

    def accuracy(self, polished: bool) -> float:
        """Relative accuracy claimed for impulses (the ``tol`` passed to assemble_result).

        Polished answers (Newton on the KKT equations) are accurate to round-off, claimed 1e-9;
        raw interior-point answers on the cone boundary to about sqrt(tol) (measured:
        1e-6 at tol = 1e-10), claimed 10 sqrt(tol).
        """
        return 1e-9 if polished else 10.0 * math.sqrt(self.tol)


def parse_options(method: str, options: dict) -> ProgramOptions:
    """Validate the keyword options of a conic path; unknown names raise UnknownOptionError."""
    return parse_method_options(method, options, ProgramOptions, _MINIMUM)


#: the least value of each count option
_MINIMUM = {"max_iter": 1, "max_fixed_point_iter": 1, "anderson_memory": 0}


#: a law's conic result: (problem, backend, method, options) -> ImpactResult
ProgramResult = Callable[[ImpactProblem, Backend, str, ProgramOptions], ImpactResult]
_BACKENDS: dict[str, Backend] = {}


def backend(method: str) -> Backend:
    """The shared backend of a conic path, built on first use (``"clarabel"`` or ``"cvxpy"``)."""
    built = _BACKENDS.get(method)
    if built is None:
        if method == "clarabel":
            from .clarabel_backend import ClarabelBackend as make
        else:
            from .cvxpy_backend import CvxpyBackend as make
        built = _BACKENDS[method] = make()
    return built


def conic_solver(law: str, method: str):
    """The solver of a conic path (``method`` "clarabel" or "cvxpy") for ``law``: its cone
    program (the law module's ``program_result``) on the shared backend (the factory named in
    :data:`convimpact.impact.resolve.GENERIC_SOLVERS`)."""
    from ..laws import law_module

    result = law_module(law).program_result

    def solver(problem: ImpactProblem, **options) -> ImpactResult:
        return result(problem, backend(method), method, parse_options(method, options))

    solver.__name__ = f"{law.replace('-', '_')}_{method}"
    solver.__doc__ = f"Law {law!r} by the {method} conic path (see {result.__module__})."
    return solver


# --------------------------------------------------------------------------------------------
# contact-space helpers shared by the laws' programs


def solver_report(sol: QPSolution, opts: ProgramOptions) -> dict:
    """The conic solve's report for a result's extras (status, iterations, polish, KKT)."""
    return {"solver_status": sol.status, "iterations": sol.iterations, "tolerance": opts.tol,
            "polished": sol.polished, "kkt_residual": sol.kkt_residual}


def normal_mask(n: int, d: int) -> np.ndarray:
    m = np.zeros(n * d, dtype=bool)
    m[::d] = True
    return m


#: an approach speed below this fraction of max |v-| is round-off (see approaching)
APPROACH_RTOL = 1e-9


def approaching(P: ImpactProblem) -> np.ndarray:
    """Per contact: approaching by more than round-off, ``v_n- < -APPROACH_RTOL max |v-|``.

    Where a law treats approaching and touching contacts differently (the maximal-dissipation
    programs give a contact that does not approach no friction of its own; P-N's active sets
    need an approaching contact), a contact approaching at round-off -- -1e-16 from cos/sin,
    -1e-12 as an integrator leaves it -- must count as touching, or the answer would jump with
    the sign of the round-off (a sliding pivot would be kicked at -1e-12 and not at +1e-12).
    """
    vscale = float(np.max(np.abs(P.v_minus)))
    return P.v_minus[:, 0] < -APPROACH_RTOL * vscale


def newton_shift(P: ImpactProblem, restitution: np.ndarray | None = None) -> np.ndarray:
    """``b - v- = e min(v_n-, 0) n`` per contact, flattened (e: the problem's, or
    ``restitution``)."""
    e = P.restitution if restitution is None else restitution
    s = np.zeros((P.n_contacts, P.dim))
    s[:, 0] = e * np.minimum(P.v_minus[:, 0], 0.0)
    return s.ravel()


def impulse_scale(P: ImpactProblem) -> float:
    """Impulse scale |v-| / max|W| for relative thresholds."""
    return max(float(np.max(np.abs(P.v_minus))), TINY) / max(float(np.max(np.abs(P.delassus))),
                                                             TINY)


def regimes_from_slip(P: ImpactProblem, pi: np.ndarray, vplus: np.ndarray,
                      tol: float, separated=None) -> list[str]:
    """Regime per contact from the impulse (or the flags ``separated``, one per contact) and
    the (law's own) post-impact slip."""
    if separated is None:
        pscale = impulse_scale(P)
        separated = [pi[i, 0] <= tol * pscale for i in range(P.n_contacts)]
    vscale = max(float(np.max(np.abs(P.v_minus))), TINY)
    out = []
    for i in range(P.n_contacts):
        if separated[i]:
            out.append("separating")
        elif P.friction[i] == 0.0:
            out.append("frictionless")
        elif np.linalg.norm(vplus[i, 1:]) <= 10 * tol * vscale:
            out.append("stick")
        else:
            out.append("slide")
    return out


def cone_qp(P: ImpactProblem, q: np.ndarray, E=None, f=None, mu=None) -> ConeQP:
    N = P.n_contacts * P.dim
    E = np.zeros((0, N)) if E is None else E
    f = np.zeros(0) if f is None else f
    return ConeQP(P.delassus, q, P.friction if mu is None else mu, P.dim, E, f)
