"""Exact single-contact impact solvers (``method="fast"``): the dispatcher and its contract.

One contact's impact reduces to its Delassus block ``W`` (d x d, d = 2 planar or 3 spatial;
closed loops are already folded in by :mod:`convimpact.impact.problem.build`) and its pre-impact
velocity ``v = (v_n, v_t...)``. Every law is then a small problem over the friction cone
``K_mu = {|pi_t| <= mu pi_n}`` with an interior (stick / unconstrained) branch that is a linear
solve and a boundary (slide) branch ``pi = pi_n (1, mu t)`` whose defining condition is a
quartic in tan(th/2) (both in :mod:`~convimpact.impact.laws.algebra`). Each law module of
:mod:`convimpact.impact.laws` holds its own compiled kernel and its entry ``contact_kernel``
(:func:`compiled_kernel`); :func:`solve_contact` validates the data, brings W to a safe scale,
and calls the law's kernel.

A kernel entry is ``kernel(w, v, d, e, mu, e_t=0) -> ContactSolution`` on plain Python lists
and floats (it calls the compiled kernel on scalars: a call costs about a microsecond), which
it must not modify. It is called only with an approaching contact
(v_n < 0), W_nn > 0, tr(W) and max |v| within :data:`~convimpact.impact.problem.build.SAFE_SCALE`
(about 1e-50 .. 1e50), e in [0, 1] and a finite mu >= 0 (mu = 0: :func:`frictionless`).

Scale: the dispatcher brings W and v into that range by exact powers of two (independently:
the laws are homogeneous, pi(a W, b v) = (b / a) pi(W, v)), so the kernels' relative
tolerances see the same numbers whatever the units, and scales the answer back
(:func:`rescaled`: impulses, velocities and energies among the extras too, by
:data:`EXTRAS_UNITS`). An impulse that leaves double precision's range raises
NonFiniteError -- never an inf, a NaN or a silent zero.

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

from ..diagnostics import assemble_result
from ...errors import (NonFiniteError, SolverError, NonPositiveEffectiveMassError,
                       ParameterError, SingularSystemError, UnknownOptionError)
from ..options import check_single_contact
from ..problem.build import SAFE_SCALE, TINY_NORMAL, ImpactProblem, real_number
from ..laws import LAW_MODULES, law_module
from ..results import ImpactResult
from ..problem.dense import as_lists, singular_error

#: laws treated by :func:`solve_contact` (every law has an exact single-contact kernel)
FAST_LAWS = tuple(LAW_MODULES)
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


_NO_EXTRAS: Mapping[str, Any] = MappingProxyType({})

#: a law's single-contact kernel: (w, v, d, e, mu) on plain floats -> ContactSolution
Kernel = Callable[[list, list, int, float, float], ContactSolution]


def solution(impulse: Sequence[float], regime: str, effective_mass: float | None = None,
             extras: dict | None = None, warnings: tuple[str, ...] = ()) -> ContactSolution:
    """A :class:`ContactSolution` from plain floats (read-only extras)."""
    return ContactSolution(np.array(impulse), regime, effective_mass,
                           MappingProxyType(extras) if extras else _NO_EXTRAS, warnings)


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


#: units of the kernels' extras that carry them (the others -- angles, directions, counts,
#: flags -- are dimensionless); :func:`rescaled` scales these back. A kernel adding an
#: extra with units must list it here.
EXTRAS_UNITS = MappingProxyType({
    "plastic_impulse": "impulse", "normal_impulse": "impulse",
    "energy_loss_max": "energy",
    "normal_velocity_lift": "velocity", "post_slip": "velocity", "post_slip_speed": "velocity",
    # law "stronge": the impulse-space path and the works of the normal impulse and friction
    "compression_impulse": "impulse", "phase_impulses": "impulse",
    "normal_work_compression": "energy", "normal_work_restitution": "energy",
    "friction_work": "energy",
})


def _ldexp(x: float, n: int) -> float:
    """x 2^n, inf (signed) on overflow instead of OverflowError, 0 on underflow."""
    try:
        return math.ldexp(x, n)
    except OverflowError:
        return math.copysign(math.inf, x)


def _scale_value(x, n: int):
    if x is None or isinstance(x, bool):
        return x
    if isinstance(x, (tuple, list)):
        return type(x)(_ldexp(y, n) for y in x)
    return _ldexp(x, n)


def rescaled(sol: ContactSolution, pw: int, pv: int) -> ContactSolution:
    """A solution computed with ``W 2^pw`` and ``v 2^pv``, brought back to W and v: impulses
    times ``2^(pw - pv)``, velocities times ``2^-pv``, energies times ``2^(pw - 2 pv)``, the
    sliding denominator times ``2^-pw`` (exact: powers of two).

    Raises
    ------
    NonFiniteError
        when the impulse leaves double precision's range (overflows, or underflows below the
        smallest normal number while the scaled answer is not zero).
    """
    n_pi = pw - pv
    shifts = {"impulse": n_pi, "velocity": -pv, "energy": pw - 2 * pv}
    scaled = sol.impulse.tolist()
    impulse = [_ldexp(x, n_pi) for x in scaled]
    big = max(map(abs, scaled))
    top = max(map(abs, impulse))
    if not math.isfinite(top) or (big > 0.0 and top < TINY_NORMAL):
        raise NonFiniteError(
            f"the impulse {'overflows' if n_pi > 0 else 'underflows'} double precision (|pi| "
            f"~ 1e{math.log10(big) + n_pi * math.log10(2.0):.0f}): the units of M, Jc and dq "
            "are too far apart; rescale them")
    extras = dict(sol.extras)
    for key, unit in EXTRAS_UNITS.items():
        if key in extras:
            extras[key] = _scale_value(extras[key], shifts[unit])
    mass = None if sol.effective_mass is None else _ldexp(sol.effective_mass, -pw)
    return solution(impulse, sol.regime, mass, extras, sol.warnings)


def _kernel(law: str) -> Kernel:
    """The law's compiled single-contact kernel (its module's ``contact_kernel``)."""
    if law not in LAW_MODULES:
        raise UnknownOptionError(f"unknown law {law!r}; choose one of {', '.join(FAST_LAWS)}")
    return law_module(law).contact_kernel


def dispatch(kernel: Kernel, w: list, v: list, d: int, e: float, mu: float,
             e_t: float = 0.0) -> ContactSolution:
    """Run ``kernel`` on validated data (finite, e in [0, 1], mu >= 0, e_t in [-1, 1]): a
    separating contact takes no impulse, W_nn <= 0 raises, data outside :data:`SAFE_SCALE`
    are rescaled."""
    if not v[0] < 0.0:
        return solution([0.0] * d, "separating")
    A = w[0][0]
    if not A > 0.0:
        raise SingularSystemError(
            f"W_nn = c_n^T M^-1 c_n = {A:.3e}: the contact normal moves no mass in this "
            "configuration; no impulse can act there")
    tr = w[0][0] + w[1][1] + (w[2][2] if d == 3 else 0.0)
    vs = max(-v[0], abs(v[1]), abs(v[-1]))
    lo, hi = SAFE_SCALE
    if lo <= tr <= hi and lo <= vs <= hi:
        return kernel(w, v, d, e, mu, e_t)
    # homogeneous laws: solve with W 2^pw and v 2^pv, both of order one, and scale back
    big = max(tr, max(abs(x) for row in w for x in row))  # = tr for a PSD W
    pw, pv = -math.frexp(big)[1], -math.frexp(vs)[1]
    ws = [[math.ldexp(x, pw) for x in row] for row in w]
    return rescaled(kernel(ws, [math.ldexp(x, pv) for x in v], d, e, mu, e_t), pw, pv)


def solve_contact(W, v, e: float, mu: float, law: str, e_t: float = 0.0) -> ContactSolution:
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
    law : {"pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge", "chatterjee-ruina"}
        ``"pereira-nikravesh"``: stick test (eq. 42), else slide on the cone boundary along
        eq. (55) in the plane and along the maximal-dissipation direction in space (eq. 60).
        ``"coulomb"``: Newton restitution on u = v+ + e v_n- n and friction opposing the
        post-impact slip (stick if the stick impulse is in the cone, else u_n = 0 and
        pi_t = -mu pi_n u_t/|u_t|; the most dissipative solution if several).
        ``"ccp"``: min 1/2 pi.W.pi + pi.b over K_mu, b = v + e v_n n.
        ``"dissipative"``: ccp with e = 0, the impulse times (1 + e).
        ``"stronge"``: Stronge's energetic law, integrated in impulse space.
        ``"chatterjee-ruina"``: the plastic impulses scaled by 1 + e and 1 + e_t, brought back
        into the friction cone.
    e_t : float
        Tangential restitution in [-1, 1] (law ``"chatterjee-ruina"`` only).

    Returns
    -------
    ContactSolution

    Raises
    ------
    ShapeError, UnknownOptionError, NonFiniteError, ParameterError
        bad shapes or entries (strings, booleans, complex numbers), law, non-finite data, e
        outside [0, 1] or mu < 0 (or e, mu not real numbers); an impulse beyond double
        precision's range (NonFiniteError).
    SingularSystemError
        W_nn <= 0, or W singular where the law inverts it.
    NonPositiveEffectiveMassError
        Newton laws whose every slide has a non-positive denominator (Painleve-like).
    SolverError
        no solution of the law's conditions exists (Coulomb) or was found.
    """
    w, vv, d = as_lists(W, v)
    e = real_number("e", e)
    mu = real_number("mu", mu)
    e_t = real_number("e_t", e_t)
    kernel = _kernel(law)
    if not (all(map(math.isfinite, vv)) and all(math.isfinite(x) for row in w for x in row)
            and math.isfinite(e) and math.isfinite(mu) and math.isfinite(e_t)):
        raise NonFiniteError("W, v, e, mu and e_t must be finite; got NaN or infinity")
    if not (0.0 <= e <= 1.0 and mu >= 0.0 and -1.0 <= e_t <= 1.0):
        raise ParameterError(f"need e in [0, 1], mu >= 0 and e_t in [-1, 1], got e = {e:g}, "
                             f"mu = {mu:g}, e_t = {e_t:g}")
    return dispatch(kernel, w, vv, d, e, mu, e_t)


#: regime codes of the compiled kernels (laws.codes) -> names
_REGIME_NAMES = ("separating", "frictionless", "stick", "slide")
#: the extras of a law's compiled kernel: (out, regime, impulse, w, v, d, e, mu) -> (extras,
#: warnings), ``out`` the float64 scratch the kernel wrote (its layout is the law's)
Extras = Callable[..., tuple]


def _no_extras(out, regime, impulse, w, v, d, e, mu) -> tuple:
    return None, ()


def compiled_kernel(law: str, planar: Callable, spatial: Callable, extras: Extras = _no_extras,
                    no_solution: str | tuple[str, str] = "", frictionless_inside: bool = False,
                    errors: Callable | None = None, tangential: bool = False) -> Kernel:
    """The Python entry ``(w, v, d, e, mu, e_t) -> ContactSolution`` of a law's compiled
    kernels.

    ``planar(w00, w01, w11, v0, v1, e, mu, out)`` and ``spatial(w00, w01, w02, w11, w12, w22,
    v0, v1, v2, e, mu, out)`` return ``(status, regime, p0, p1, p2, effective_mass)`` (codes of
    :mod:`convimpact.impact.laws.codes`) and write the law's extras into ``out``;
    this turns a status into the typed error (SINGULAR: SingularSystemError, JAM:
    NonPositiveEffectiveMassError, NO_SOLUTION: SolverError with the law's ``no_solution``
    message, or its (planar, spatial) pair) and ``out`` into the solution's extras and warnings by ``extras``. mu = 0 is
    Newton's frictionless impulse unless the law's kernels treat it (``frictionless_inside``).
    A law with messages of its own passes ``errors(out, status, w, v, d, e, mu) -> Exception
    or None`` (None: the generic error of that status). A law with a tangential restitution
    (``tangential``) takes it as its kernels' argument after mu, and as its ``extras``' last.
    """
    from ..laws.codes import JAM, NO_SOLUTION, OK, OUT_SIZE, SINGULAR

    def kernel(w: list, v: list, d: int, e: float, mu: float,
               e_t: float = 0.0) -> ContactSolution:
        if mu == 0.0 and not frictionless_inside:
            return frictionless(w, v, d, e)
        out = np.zeros(OUT_SIZE)
        law_args = (e, mu, e_t, out) if tangential else (e, mu, out)
        if d == 2:
            st, rg, p0, p1, p2, D = planar(w[0][0], w[0][1], w[1][1], v[0], v[1], *law_args)
        else:
            st, rg, p0, p1, p2, D = spatial(w[0][0], w[0][1], w[0][2], w[1][1], w[1][2],
                                            w[2][2], v[0], v[1], v[2], *law_args)
        if st != OK:
            exc = errors(out, st, w, v, d, e, mu) if errors is not None else None
            if exc is not None:
                raise exc
            if st == SINGULAR:
                raise singular_error(law, float(np.linalg.det(np.array(w))))
            if st == JAM:
                raise jam_error(mu, D, law)
            if st == NO_SOLUTION:
                raise SolverError((no_solution if type(no_solution) is str
                                   else no_solution[d - 2])
                                  or f"law {law!r} found no solution for this contact; use "
                                  "method='clarabel'")
            raise SolverError(f"law {law!r}: the compiled kernel returned status {st}")
        impulse = (p0, p1) if d == 2 else (p0, p1, p2)
        regime = _REGIME_NAMES[rg]
        ex, warns = (extras(out, regime, impulse, w, v, d, e, mu, e_t) if tangential
                     else extras(out, regime, impulse, w, v, d, e, mu))
        return solution(impulse, regime, D if D == D else None, ex, warns)

    kernel.__name__ = f"{law.replace('-', '_')}_kernel"
    kernel.__doc__ = f"The compiled single-contact kernel of law {law!r} on plain floats."
    # what the compiled law table (convimpact.impact.laws.table) reads
    kernel.planar, kernel.spatial = planar, spatial
    kernel.frictionless_inside, kernel.tangential = frictionless_inside, tangential
    return kernel


def _contact(kernel: Kernel, problem: ImpactProblem, i: int) -> ContactSolution:
    """Contact i of ``problem`` by ``kernel``, through :func:`dispatch` (e_t 0 where the
    problem has none)."""
    w, v = problem.contact_lists(i)
    et = problem.tangential_restitution
    return dispatch(kernel, w, v, problem.dim, float(problem.restitution[i]),
                    float(problem.friction[i]), 0.0 if et is None else float(et[i]))


#: off-diagonal blocks of W below this times the product of the two contacts' scales count
#: as zero (the contacts are dynamically independent)
DECOUPLED_RTOL = 1e-12


def coupled(problem: ImpactProblem) -> bool:
    """Whether some off-diagonal block of W couples two contacts (relative to their scales)."""
    n, d, W = problem.n_contacts, problem.dim, problem.delassus
    scale = np.maximum(np.sqrt(np.maximum(np.diag(W), 0.0)).reshape(n, d).max(axis=1), 1e-300)
    for i in range(n):
        for j in range(i + 1, n):
            block = W[i * d:(i + 1) * d, j * d:(j + 1) * d]
            if np.max(np.abs(block)) > DECOUPLED_RTOL * scale[i] * scale[j]:
                return True
    return False


def independent_contacts_result(problem: ImpactProblem, law: str, method: str,
                                one_approaching: bool = False,
                                lifted: Mapping[str, Any] = _NO_EXTRAS) -> ImpactResult | None:
    """Several contacts by the law's exact single-contact kernel, contact by contact: when they
    are dynamically independent (W block-diagonal), or -- with ``one_approaching`` -- when one
    contact approaches and its impulse leaves every other contact not approaching (they lift
    with no impulse; ``lifted``: their extras). None when neither holds."""
    from ..conic.paths import approaching

    n, d = problem.n_contacts, problem.dim
    if coupled(problem):
        act = np.flatnonzero(approaching(problem))
        if not one_approaching or act.size != 1:
            return None
        contacts = (int(act[0]),)
        formulation = (f"one approaching contact ({contacts[0]}): the exact single-contact "
                       "kernel; the others lift with no impulse")
    else:
        contacts = tuple(range(n))
        formulation = ("independent contacts (block-diagonal W): the exact single-contact "
                       "kernel per contact; no cone program is solved")
    pi = np.zeros((n, d))
    regimes, per_contact, warnings = ["separating"] * n, [dict(lifted) for _ in range(n)], []
    for i in contacts:
        sol = _contact(_kernel(law), problem, i)
        pi[i] = sol.impulse
        regimes[i] = sol.regime
        per_contact[i] = dict(sol.extras)
        warnings.extend(sol.warnings)
    if len(contacts) < n:
        vp = problem.v_minus + (problem.delassus @ pi.ravel()).reshape(n, d)
        vscale = max(float(np.max(np.abs(problem.v_minus))), 1e-300)
        if np.any(np.delete(vp[:, 0], contacts[0]) < -1e-9 * vscale):
            return None  # the lone impulse would drive another contact into the ground
    extras = {"formulation": formulation, "contacts": per_contact}
    return assemble_result(problem, pi, regimes, law, method, tol=FAST_TOL, extras=extras,
                           warnings=tuple(warnings))


def kernel_solver(law: str, method: str = "fast"):
    """The solver of ``method="fast"`` for ``law``: its exact single-contact kernel, through
    :func:`dispatch` (the factory named in :data:`convimpact.impact.resolve.GENERIC_SOLVERS`)."""
    kernel = _kernel(law)

    def solver(problem: ImpactProblem, **options) -> ImpactResult:
        check_single_contact(problem, options, "fast", "no options,",
                             "method='fast' is exact for one contact only; for {n} "
                             "simultaneous contacts use method='clarabel' or method='cvxpy'")
        sol = _contact(kernel, problem, 0)
        return assemble_result(problem, sol.impulse, [sol.regime], law, "fast",
                               effective_mass=sol.effective_mass, tol=FAST_TOL,
                               extras=sol.extras, warnings=sol.warnings)

    solver.__name__ = f"fast_{law.replace('-', '_')}"
    solver.__doc__ = f"Exact single-contact solver of law {law!r} (see solve_contact)."
    return solver


__all__ = ["ContactSolution", "solve_contact", "kernel_solver", "compiled_kernel",
           "frictionless", "FAST_LAWS",
           "FAST_TOL", "EXTRAS_UNITS", "dispatch", "rescaled"]
