"""Exact single-contact impact solvers (``method="fast"``): the dispatcher and its contract.

One contact's impact reduces to its Delassus block ``W`` (d x d, d = 2 planar or 3 spatial;
closed loops are already folded in by :mod:`convimpact.impact.problem`) and its pre-impact
velocity ``v = (v_n, v_t...)``. Every law is then a small problem over the friction cone
``K_mu = {|pi_t| <= mu pi_n}`` with an interior (stick / unconstrained) branch that is a linear
solve (:mod:`~convimpact.impact.small_linalg`) and a boundary (slide) branch
``pi = pi_n (1, mu t)`` whose defining condition is a quartic in tan(th/2)
(:mod:`~convimpact.impact.boundary`). Each law module of :mod:`convimpact.impact.laws` holds
its own kernel and registers it here with :func:`register_kernel`; :func:`solve_contact`
validates the data, brings W to a safe scale, and calls the law's kernel.

A kernel is ``kernel(w, v, d, e, mu) -> ContactSolution`` on plain Python lists and floats
(numpy's per-call overhead would dominate: a spatial solve takes some 10-20 microseconds, a
planar one a few). It is called only with an approaching contact (v_n < 0), W_nn > 0, tr(W)
within [1e-100, 1e100], e in [0, 1] and a finite mu >= 0 (mu = 0: :func:`frictionless`).

Degenerate cases are explicit: v_t- = 0 needs no special branch; a (numerically) singular W
raises SingularSystemError naming the conic paths; a law whose every sliding root has a
non-positive denominator raises NonPositiveEffectiveMassError (Newton laws); a boundary answer
that no certificate accepts raises SolverError -- never a NaN, never a silently wrong root.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .diagnostics import assemble_result
from .errors import (
    NonFiniteError,
    NonPositiveEffectiveMassError,
    NotSupportedError,
    ParameterError,
    SingularSystemError,
    UnknownOptionError,
)
from .problem import ImpactProblem
from .resolve import LAWS, load_solver_modules, register_solver
from .results import ImpactResult
from .small_linalg import as_lists

#: laws treated by :func:`solve_contact` (every law has an exact single-contact kernel)
FAST_LAWS = LAWS
#: relative tolerance of the cone / sign tests (round-off allowance)
CONE_RTOL = 1e-12
#: relative tolerance on a boundary root's residual for it to count as a solution
ROOT_RTOL = 1e-8
#: accuracy stated for the fast path (passed to assemble_result)
FAST_TOL = 1e-10


@dataclass(frozen=True, slots=True)
class ContactSolution:
    """Impulse of one contact under one law, as found by :func:`solve_contact`.

    Attributes
    ----------
    impulse : (d,) contact-frame impulse, normal first (pi_n, pi_t) or (pi_n, pi_t1, pi_t2).
    regime : "separating", "frictionless", "stick" or "slide".
    effective_mass : the sliding denominator c_n^T G (c_n + mu c_t) of eq. (38)/(51) when the
        law slid with Newton's restitution, else None.
    extras : law-specific figures (sliding angle, energy loss, CCP lift, solution counts).
    warnings : statements about the solve (e.g. P_N's interior optimum disagreeing).
    """

    impulse: np.ndarray
    regime: str
    effective_mass: float | None = None
    extras: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    warnings: tuple[str, ...] = ()


#: a law's single-contact kernel: (w, v, d, e, mu) on plain floats -> ContactSolution
Kernel = Callable[[list, list, int, float, float], ContactSolution]
_KERNELS: dict[str, Kernel] = {}


def solution(impulse: Sequence[float], regime: str, effective_mass: float | None = None,
             extras: dict | None = None, warnings: tuple[str, ...] = ()) -> ContactSolution:
    """A :class:`ContactSolution` from plain floats (read-only extras)."""
    return ContactSolution(np.array(impulse), regime, effective_mass,
                           MappingProxyType(extras or {}), warnings)


def in_cone(pn: float, ptn: float, mu: float) -> bool:
    """|pi_t| <= mu pi_n (eq. 53), with the closed form's round-off allowance."""
    return pn >= 0.0 and ptn <= mu * pn * (1.0 + CONE_RTOL)


def jam_error(mu: float, D: float, law: str) -> NonPositiveEffectiveMassError:
    """The Painleve-like jam of a Newton law: every sliding denominator D <= 0."""
    return NonPositiveEffectiveMassError(
        f"sliding denominator c_n^T M^-1 (c_n + mu c_t) = {D:.3e} <= 0 at mu = {mu:g} for every "
        f"sliding solution of law {law!r} (Painleve-like jam: eq. (38) would divide by it); use "
        "law='ccp' or 'dissipative', which stay well posed, or lower mu")


def frictionless(w: list, v: list, d: int, e: float) -> ContactSolution:
    """Eq. (38) with mu = 0: ``pi_n = -(1 + e) v_n / W_nn`` (every Newton law agrees)."""
    pi = [0.0] * d
    pi[0] = -(1.0 + e) * v[0] / w[0][0]
    return solution(pi, "frictionless")


#: extras of a ContactSolution that are impulses or energies (they scale like pi)
_IMPULSE_EXTRAS = ("plastic_impulse", "normal_impulse", "energy_loss_max")


def rescaled(sol: ContactSolution, g: float) -> ContactSolution:
    """A solution computed with W / tr(W), brought back to W (``g = 1 / tr``): impulses,
    impulse-like extras and energies times ``g``, the sliding denominator over ``g``."""
    extras = dict(sol.extras)
    for key in _IMPULSE_EXTRAS:
        if key in extras and extras[key] is not None:
            extras[key] = (tuple(g * x for x in extras[key]) if isinstance(extras[key], tuple)
                           else g * extras[key])
    mass = None if sol.effective_mass is None else sol.effective_mass / g
    return ContactSolution(sol.impulse * g, sol.regime, mass, MappingProxyType(extras),
                           sol.warnings)


def _kernel(law: str) -> Kernel:
    kernel = _KERNELS.get(law)
    if kernel is None:
        load_solver_modules()
        kernel = _KERNELS.get(law)
        if kernel is None:
            raise UnknownOptionError(
                f"unknown law {law!r}; choose one of {', '.join(FAST_LAWS)}")
    return kernel


def solve_contact(W, v, e: float, mu: float, law: str) -> ContactSolution:
    """Exact impulse of one contact under ``law`` (the kernel of ``method="fast"``).

    Parameters
    ----------
    W : (d, d) array_like
        The contact's Delassus block (loops already folded in), d = 2 (n, t) or 3 (n, t1, t2).
    v : (d,) array_like
        Pre-impact contact velocity; ``v[0] = v_n < 0`` when approaching.
    e : float
        Restitution in [0, 1].
    mu : float
        Friction coefficient >= 0.
    law : {"pereira-nikravesh", "coulomb", "ccp", "dissipative"}
        ``"pereira-nikravesh"``: stick test (eq. 42), else slide on the cone boundary along
        eq. (55) in the plane and along the maximal-dissipation direction in space (eq. 60).
        ``"coulomb"``: Newton restitution on u = v+ + e v_n- n and friction opposing the
        post-impact slip (stick if the stick impulse is in the cone, else u_n = 0 and
        pi_t = -mu pi_n u_t/|u_t|; the most dissipative solution if several).
        ``"ccp"``: min 1/2 pi.W.pi + pi.b over K_mu, b = v + e v_n n.
        ``"dissipative"``: ccp with e = 0, the impulse times (1 + e).

    Returns
    -------
    ContactSolution

    Raises
    ------
    ShapeError, UnknownOptionError, NonFiniteError, ParameterError
        bad shapes, law, non-finite data, e outside [0, 1] or mu < 0.
    SingularSystemError
        W_nn <= 0, or W singular where the law inverts it.
    NonPositiveEffectiveMassError
        Newton laws whose every slide has a non-positive denominator (Painleve-like).
    SolverError
        no solution of the law's conditions exists (Coulomb) or was found.
    """
    w, vv, d = as_lists(W, v)
    e = float(e)
    mu = float(mu)
    kernel = _kernel(law)
    if not math.isfinite(sum(map(sum, w)) + sum(vv) + e + mu):
        raise NonFiniteError("W, v, e and mu must be finite; got NaN or infinity")
    if not (0.0 <= e <= 1.0 and mu >= 0.0):
        raise ParameterError(f"need e in [0, 1] and mu >= 0, got e = {e:g}, mu = {mu:g}")
    if not vv[0] < 0.0:
        return solution([0.0] * d, "separating")
    A = w[0][0]
    if not A > 0.0:
        raise SingularSystemError(
            f"W_nn = c_n^T M^-1 c_n = {A:.3e}: the contact normal moves no mass in this "
            "configuration; no impulse can act there")
    tr = sum(w[i][i] for i in range(d))
    if not 1e-100 < tr < 1e100:
        # products of W's entries (quartic coefficients, determinants) would under- or
        # overflow: solve with W / tr(W); every law is homogeneous, pi scales by 1 / tr
        scaled = solve_contact([[x / tr for x in row] for row in w], vv, e, mu, law)
        return rescaled(scaled, 1.0 / tr)
    return kernel(w, vv, d, e, mu)


def register_kernel(law: str, kernel: Kernel) -> Kernel:
    """Register ``kernel`` as law ``law``'s exact single-contact solver (``method="fast"``)."""
    _KERNELS[law] = kernel

    def solver(problem: ImpactProblem, **options) -> ImpactResult:
        if options:
            raise UnknownOptionError(
                f"method 'fast' takes no options, got {', '.join(sorted(options))}")
        if problem.n_contacts != 1:
            raise NotSupportedError(
                f"method='fast' is exact for one contact only; for {problem.n_contacts} "
                "simultaneous contacts use method='clarabel' or method='cvxpy'")
        W, v = problem.contact_block(0)
        sol = solve_contact(W, v, float(problem.restitution[0]), float(problem.friction[0]), law)
        return assemble_result(problem, sol.impulse[None], [sol.regime], law, "fast",
                               effective_mass=sol.effective_mass, tol=FAST_TOL,
                               extras=sol.extras, warnings=sol.warnings)

    solver.__name__ = f"fast_{law.replace('-', '_')}"
    solver.__doc__ = f"Exact single-contact solver of law {law!r} (see solve_contact)."
    register_solver(law, "fast")(solver)
    return kernel


__all__ = ["ContactSolution", "solve_contact", "register_kernel", "frictionless", "FAST_LAWS",
           "FAST_TOL"]
