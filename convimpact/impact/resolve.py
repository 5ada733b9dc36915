"""``resolve_impact``: validate an impact, pick a law and a solver path, return the jump.

Laws (what physics is imposed) and methods (how it is computed) are separate axes. Every
``(law, method)`` pair is a solver named in an explicit table (:data:`GENERIC_SOLVERS`: the
methods every law has, built from the law's module; :data:`SPECIFIC_SOLVERS`: the rest);
its module is imported on first use, so that ``import convimpact`` stays light and the closed
form never pays for cvxpy. :func:`register_solver` adds a solver of one's own.
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import Callable

import numpy as np

from .diagnostics import assemble_result
from ..errors import (NonPositiveEffectiveMassError, NotSupportedError, SingularSystemError,
                      SolverError, UnknownOptionError)
from .exact.lane import resolve_one
from .options import METHOD_OPTIONS, options_help  # noqa: F401 (public here)
from .laws import LAW_MODULES, TANGENTIAL_LAWS, law_module
from .problem.build import ImpactProblem, build_problem
from .results import ImpactResult

LAWS = tuple(LAW_MODULES)
METHODS = ("auto", "closed-form", "sweep", "fast", "interior", "clarabel", "cvxpy")

Solver = Callable[..., ImpactResult]

#: every solver path, as an explicit table (nothing registers itself on import): the methods
#: every law has -> the factory ``make(law, method) -> solver`` that builds it from the law's
#: module (its compiled kernel ``contact_kernel``, its cone program ``program_result``)
GENERIC_SOLVERS: dict[str, str] = {
    "fast": "convimpact.impact.exact.dispatch:kernel_solver",
    "clarabel": "convimpact.impact.conic.paths:conic_solver",
    "cvxpy": "convimpact.impact.conic.paths:conic_solver",
}
#: the paths of some laws only: (law, method) -> the solver ``solver(problem, **options)``
SPECIFIC_SOLVERS: dict[tuple[str, str], str] = {
    ("pereira-nikravesh", "closed-form"): "convimpact.impact.laws.pereira_nikravesh:closed_form",
    ("pereira-nikravesh", "sweep"): "convimpact.impact.exact.sweep:pereira_nikravesh_sweep",
    ("ccp", "interior"): "convimpact.impact.several.interior:ccp_result",
    ("coulomb", "interior"): "convimpact.impact.several.interior:coulomb_result",
    ("dissipative", "interior"): "convimpact.impact.several.interior:dissipative_result",
}
#: the solvers built from the tables (on first use) and those given to register_solver
_SOLVERS: dict[tuple[str, str], Solver] = {}


def _load(spec: str):
    module, name = spec.split(":")
    return getattr(importlib.import_module(module), name)


def _registered(law: str, method: str) -> bool:
    return method in GENERIC_SOLVERS or (law, method) in SPECIFIC_SOLVERS \
        or (law, method) in _SOLVERS


def solver(law: str, method: str) -> Solver:
    """The solver of ``(law, method)``, built from the tables on first use."""
    fn = _SOLVERS.get((law, method))
    if fn is None:
        spec = SPECIFIC_SOLVERS.get((law, method))
        if spec is not None:
            fn = _load(spec)
        elif method in GENERIC_SOLVERS:
            fn = _load(GENERIC_SOLVERS[method])(law, method)
        else:
            raise NotSupportedError(
                f"law {law!r} has no method {method!r}; available: "
                f"{', '.join(available_methods(law)) or 'none'}")
        _SOLVERS[(law, method)] = fn
    return fn


def register_solver(law: str, method: str) -> Callable[[Solver], Solver]:
    """Decorator registering ``solver(problem, **options) -> ImpactResult`` for a law/method
    (a solver of one's own; it takes precedence over the tables)."""
    if law not in LAWS or method not in METHODS or method == "auto":
        raise UnknownOptionError(f"cannot register unknown law/method {law!r}/{method!r}")

    def deco(fn: Solver) -> Solver:
        _SOLVERS[(law, method)] = fn
        _CANDIDATES.clear()
        return fn

    return deco


def available_methods(law: str) -> list[str]:
    """Solver paths of ``law``."""
    return [m for m in METHODS if m != "auto" and _registered(law, m)]


def check_law_method(law: str, method: str) -> None:
    """Raise UnknownOptionError unless ``law`` and ``method`` are known names."""
    # a name is a str (an array or a list would make `in` raise or compare elementwise)
    if type(law) is not str or law not in LAWS:
        raise UnknownOptionError(f"unknown impact law {law!r}; choose one of {', '.join(LAWS)}")
    if type(method) is not str or method not in METHODS:
        raise UnknownOptionError(
            f"unknown method {method!r}; choose one of {', '.join(METHODS)}")


#: methods that treat one contact only
SINGLE_CONTACT_METHODS = ("closed-form", "fast", "sweep")
_CANDIDATES: dict[tuple, list[str]] = {}
#: laws whose several contacts go to the contact engine (method "interior") first under
#: method="auto": the convex programs (unique velocities) and Coulomb's law, whose answer at
#: several contacts is the one the engine reaches (Newton from the CCP answer, else its ADMM)
#: -- where the law has several solutions, possibly another than the conic path's fixed point
INTERIOR_FIRST = ("ccp", "dissipative", "coulomb")
#: laws whose several open-loop contacts the compiled lane of method "interior" takes
INTERIOR_LANE = ("ccp", "dissipative", "coulomb")


def _candidates(problem: ImpactProblem, law: str) -> list[str]:
    """Registered methods exact for this problem, cheapest first.

    One contact goes to its law's exact kernel (``fast``, which rescales data far from unit
    scale before it solves), then to the law's closed form or conic programs.
    """
    single = problem.n_contacts == 1
    key = (law, single)
    order = _CANDIDATES.get(key)
    if order is None:
        if single:
            names = ("fast", "closed-form", "clarabel", "cvxpy")
        elif law in INTERIOR_FIRST:
            names = ("interior", "clarabel", "cvxpy")
        else:
            names = ("clarabel", "cvxpy")
        order = _CANDIDATES[key] = [m for m in names if _registered(law, m)]
    return order


def choose_method(problem: ImpactProblem, law: str) -> str:
    """The cheapest registered method that is exact for this problem (``method="auto"``)."""
    candidates = _candidates(problem, law)
    if not candidates:
        raise NotSupportedError(
            f"no solver is registered for law {law!r} on {problem.n_contacts} contact(s)")
    return candidates[0]


def _separating(problem: ImpactProblem, law: str, method: str) -> ImpactResult:
    n = problem.n_contacts
    return assemble_result(
        problem, np.zeros((n, problem.dim)), ["separating"] * n, law, method,
        warnings=("no contact is approaching (v_n- >= 0): no impulse acts",),
    )


def solve_problem(problem: ImpactProblem, law: str = "pereira-nikravesh",
                  method: str = "auto", derivatives=False, **options) -> ImpactResult:
    """Resolve an already validated :class:`~convimpact.impact.problem.build.ImpactProblem`.

    With ``method="auto"`` the cheapest exact method is tried first; where it cannot treat the
    problem because the Delassus matrix is singular (the closed forms and ``fast`` invert it),
    the conic paths, which do not, are tried next and the result says so in its warnings.

    ``derivatives`` (False, True, "both" or "velocity") as in :func:`resolve_impact`; the keys ``"e"``,
    ``"mu"`` (``"e_t"``) have the shape of a scalar argument, ``(k,)``, when the problem was
    built from one Jacobian, and of per-contact ones, ``(k, n)``, otherwise.
    """
    check_law_method(law, method)
    derivatives = _check_derivatives(derivatives)
    result = _solve(problem, law, method, options)
    if derivatives:
        from .derivatives.attach import with_derivatives

        result = with_derivatives(problem, result, law, derivatives)
    return result


def _check_derivatives(derivatives):
    if derivatives is False:
        return False
    from .derivatives.attach import check_derivatives

    return check_derivatives(derivatives)


def _solve(problem: ImpactProblem, law: str, method: str, options: dict) -> ImpactResult:
    """:func:`solve_problem` without the derivatives (law and method already checked)."""
    if method == "auto":
        candidates = _candidates(problem, law)
        if not candidates:
            raise NotSupportedError(
                f"no solver is registered for law {law!r} on {problem.n_contacts} contact(s)")
    else:
        if not _registered(law, method):
            raise NotSupportedError(
                f"law {law!r} has no method {method!r}; available: "
                f"{', '.join(available_methods(law)) or 'none'}")
        if problem.n_contacts > 1 and method in SINGLE_CONTACT_METHODS:
            raise NotSupportedError(
                f"method {method!r} treats one contact; for several simultaneous contacts use "
                "method='interior', 'clarabel' or 'cvxpy'")
        candidates = [method]
    if not any(problem.approaching):
        return _separating(problem, law, candidates[0])
    for i, name in enumerate(candidates):
        try:
            result = solver(law, name)(problem, **options)
        except (SingularSystemError, SolverError) as exc:
            # a singular W the exact kernels cannot invert, or an interior-point answer that
            # failed its certificate: the conic paths treat the impact or report it themselves.
            # The exact paths between (the closed forms) invert the same W, so a singular W
            # goes to the first conic path left (law "pereira-nikravesh": fast, closed-form,
            # clarabel)
            conic = [m for m in candidates[i + 1:] if m in ("clarabel", "cvxpy")]
            if (isinstance(exc, NonPositiveEffectiveMassError) or not conic
                    or (not isinstance(exc, SingularSystemError)
                        and (name != "interior" or candidates[i + 1] != conic[0]))):
                raise
            fallback = f"method 'auto': {name} cannot treat this impact ({exc}); used " \
                       f"{conic[0]} instead"
            result = solver(law, conic[0])(problem, **options)
            return dataclasses.replace(result,
                                       diagnostics=result.diagnostics.with_notes(fallback))
        return result
    raise AssertionError("unreachable")  # pragma: no cover


def resolve_impact(M, Jc, dq, e=0.0, mu=0.0, C=None, law: str = "pereira-nikravesh",
                   method: str = "auto", e_t=None, derivatives=False,
                   **options) -> ImpactResult:
    """Resolve one impact of a multibody system in joint coordinates.

    Parameters
    ----------
    M : (k, k) array_like
        Generalized mass matrix in joint coordinates (eq. 3); symmetric positive definite.
    Jc : (d, k) array_like, or a list of them for several simultaneous contacts
        Contact Jacobian in the contact frame, rows ``n, t`` (planar, d = 2) or ``n, t1, t2``
        (spatial, d = 3); row i is (frame axis i)^T R with R = D B (eqs. 16-19). The normal
        points toward body i, so an approaching contact has ``Jc[0] @ dq < 0``.
    dq : (k,) array_like
        Joint velocities theta_dot before impact.
    e : float or per-contact sequence
        Newton's coefficient of restitution, in [0, 1] (eq. 21).
    mu : float or per-contact sequence
        Coulomb's coefficient of friction, >= 0.
    C : (m, k) array_like, optional
        Jacobian of the loop constraints (eq. 7) for closed loops; full row rank, C dq = 0.
    law : {"pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge", "chatterjee-ruina"}
        The impact law (see the package documentation for exact definitions).
    method : {"auto", "closed-form", "sweep", "fast", "interior", "clarabel", "cvxpy"}
        The solver path; ``"auto"`` picks the cheapest one exact for the problem. One
        open-loop contact (``fast``) and several under ``interior`` run in compiled lanes
        (:mod:`convimpact.impact.exact.lane`, :mod:`convimpact.impact.several.lane`) when the data
        are plain; any other case takes the full path, with the same answers to round-off.
    e_t : float or per-contact sequence, optional
        Tangential restitution in [-1, 1] of law ``"chatterjee-ruina"`` (default 0); the
        other laws have none.
    derivatives : {False, True, "both", "velocity"}
        With True the result carries ``jacobian`` and ``impulse_jacobian``: argument name
        (``"dq"``, ``"M"``, ``"Jc"``, ``"e"``, ``"mu"``; ``"e_t"`` for chatterjee-ruina) ->
        the derivative of ``dq_plus`` (of ``impulse``) with respect to it, of shape
        ``dq_plus.shape + shape of the argument`` (``"M"``: with respect to symmetric
        perturbations, as a symmetric gradient), analytic inside the answer's mode; and
        ``derivatives``, the record of the mode per contact and of the one-sided statements
        at a mode boundary (also in the diagnostics' warnings). With "both" the record also
        holds the other side's jacobians at a boundary. With "velocity", where redundant
        contacts (more contact rows than the bodies' freedoms) leave a cone law's impulse
        non-unique, the minimum-norm derivative of the mode's equations is given instead of
        NotSupportedError: exact for ``dq_plus`` and ``v_plus``, a choice for the impulse
        (said in the record). See the user guide's "Impact derivatives".
    **options
        Solver options (tolerances, iteration limits) of the method: see the table in the
        Notes (:data:`METHOD_OPTIONS`). A name the method does not take raises
        UnknownOptionError listing the ones it takes. Under ``method="auto"`` the options go
        to the method it picks for the impact, so pass the method whose options you set.

    Returns
    -------
    ImpactResult
        ``dq_plus``, contact-frame ``impulse`` (normal first), ``loop_impulse`` (Delta sigma),
        ``regime``, ``energy_loss`` (eq. 58), ``v_minus``, ``v_plus``, and ``diagnostics``
        (measured on first access). Every decision and flag is scale-free: M times ``a`` and
        dq times ``b`` give the same regime, the impulse times ``a b`` and the velocities
        times ``b``.

    Raises
    ------
    InputError (ShapeError, NonFiniteError, MassMatrixError, ParameterError,
    DegenerateContactError, UnknownOptionError, LoopConstraintError)
        for bad input: wrong shapes, entries that are not real numbers (a string, a boolean,
        a complex number: ShapeError, or ParameterError for e and mu), NaN or infinity, a
        contact Jacobian that is zero, and units so far apart that the impulse or the energy
        change leaves double precision's range (NonFiniteError);
    SingularSystemError, NonPositiveEffectiveMassError
        when the chosen branch must invert a singular matrix or jams (Painleve-like);
    SolverError
        when an iterative or conic solver does not converge;
    NotSupportedError
        when the method cannot treat the case (the message names one that can).

    Notes
    -----
    The methods and their options (keyword arguments, defaults in brackets):

    ============  ==========================================================================
    method        options
    ============  ==========================================================================
    auto          those of the method it picks: ``fast`` for one contact; ``interior`` for
                  several under laws ccp, dissipative and coulomb, else ``clarabel``
    closed-form   none (law pereira-nikravesh, one contact)
    fast          none (every law, one contact)
    sweep         ``xtol`` [1e-10] tolerance of the slip angle (rad); ``n_grid`` [360] grid
                  angles bracketing the energy-loss maxima (law pereira-nikravesh, one
                  contact)
    interior      ``tol`` [1e-10] acceptance of the KKT certificate (relative residual);
                  ``max_iter`` [100] interior-point iterations; ``newton_iter`` [20] Newton
                  steps (laws ccp, dissipative, coulomb; any number of contacts)
    clarabel      ``tol`` [1e-10] gap and feasibility of the scaled cone program;
                  ``max_iter`` [200] interior-point iterations; for law coulomb's fixed
                  point of programs also ``fixed_point_tol`` [1e-9, relative],
                  ``max_fixed_point_iter`` [100] and ``anderson_memory`` [5] (every law,
                  any number of contacts)
    cvxpy         as clarabel (the same programs through cvxpy)
    ============  ==========================================================================

    Examples
    --------
    A particle of mass 2 hitting the floor at 45 degrees, rows (n, t) of the contact frame:

    >>> import numpy as np, convimpact as ci
    >>> r = ci.resolve_impact(2 * np.eye(2), np.array([[0., 1.], [1., 0.]]), [1., -1.],
    ...                       e=0.5, mu=0.3)
    >>> r.regime, np.round(r.v_plus, 3).tolist()
    ('slide', [0.5, 0.55])
    """
    check_law_method(law, method)
    e_t = check_law_parameters(law, e_t)
    if derivatives is not False:
        derivatives = _check_derivatives(derivatives)
    if derivatives:
        # the derivatives need the validated problem (W, G, the law's answer): the compiled
        # lanes below, which return a finished result only, are bypassed; the full path
        # gives the same answer to round-off
        from .derivatives.attach import with_derivatives

        problem = build_problem(M, Jc, dq, e, mu, C, e_t)
        result = _solve(problem, law, method, options)
        scalar = {"e": np.ndim(e) == 0, "mu": np.ndim(mu) == 0,
                  "e_t": e_t is None or np.ndim(e_t) == 0}
        return with_derivatives(problem, result, law, derivatives, scalar)
    if C is None and not options and type(Jc) is np.ndarray and Jc.ndim == 2 \
            and (method == "auto" or method == "fast"):
        # one open-loop contact: the compiled lane (convimpact.impact.exact.lane), which hands
        # every case but the plain one back to the full path below
        kernel = _fast_kernel(law)
        if kernel is not None:
            result = resolve_one(M, Jc, dq, e, mu, law, kernel, e_t)
            if result is not None:
                return result
    elif C is None and not options and type(Jc) is list and (
            (method == "auto" and law in INTERIOR_FIRST)
            or (method == "interior" and law in INTERIOR_LANE)):
        # several open-loop contacts on the interior path: the compiled lane
        # (convimpact.impact.several.lane), which hands every case but the plain one back
        from .several.lane import resolve_several  # (imported on first use)

        result = resolve_several(M, Jc, dq, e, mu, law)
        if result is not None:
            return result
    problem = build_problem(M, Jc, dq, e, mu, C, e_t)
    return _solve(problem, law, method, options)


def check_law_parameters(law: str, e_t):
    """The tangential restitution of a law that has one (default 0), else None; e_t given to
    another law raises UnknownOptionError."""
    if law in TANGENTIAL_LAWS:
        return 0.0 if e_t is None else e_t
    if e_t is not None:
        raise UnknownOptionError(
            f"e_t is the tangential restitution of law {', '.join(map(repr, TANGENTIAL_LAWS))}; "
            f"law {law!r} has none")
    return None


def _fast_kernel(law: str):
    """The law's exact single-contact kernel on plain floats (its module's
    ``contact_kernel``), imported on first use."""
    kernel = _FAST_KERNELS.get(law)
    if kernel is None:
        kernel = _FAST_KERNELS[law] = law_module(law).contact_kernel
    return kernel


#: the laws' single-contact kernels, filled on first use
_FAST_KERNELS: dict = {}
