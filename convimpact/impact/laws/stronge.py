"""Stronge's energetic restitution by impulse-space integration (Darboux--Keller).

The collision is followed through the normal impulse ``p = p_n`` as a time-like variable
(Keller 1986; Stronge 1990, 2000). With the contact-frame impulse ``pi(p) = (p, pi_t(p))`` the
contact velocity is ``v(p) = v- + W pi(p)`` (W = Jc G Jc^T, normal first, approaching
``v_n- < 0``), and Coulomb friction acts against the *current* slip throughout::

    dpi_t / dp = lambda,   |lambda| <= mu,
    slipping (v_t != 0):   lambda = -mu s,  s = v_t / |v_t|,   so  dv/dp = W (n - mu s),
    sticking (v_t == 0):   lambda = -W_tt^-1 W_tn  (keeps v_t = 0), admissible iff |lambda| <= mu.

Writing ``W = [[A, b^T], [b, C]]`` (A = W_nn, b = W_tn, C = W_tt): while sticking,
``dv_t = b dp + C dpi_t = 0`` gives the *sticking ratio* ``lambda_s = -C^-1 b`` (in the plane
``-W_tn / W_tt``), and ``dv_n / dp = A - b^T C^-1 b = det W / det C > 0``. When the slip
reaches zero and ``|C^-1 b| > mu`` the contact cannot stick; it slips on in the direction
``s`` the dynamics select, the one whose tangential acceleration ``b - mu C s = kappa s`` is
along ``s`` with ``kappa > 0``: ``s = (kappa I + mu C)^-1 b`` with ``kappa > 0`` the unique
root of ``|(kappa I + mu C)^-1 b| = 1`` (``|.|`` decreases from ``|C^-1 b| / mu > 1`` to 0;
solved by safeguarded Newton in C's eigenbasis). That ray is invariant (the acceleration is
constant along it), so the slip then grows linearly in p. In the plane this is the slip
reversal ``s = sgn(W_tn)``, ``kappa = |W_tn| - mu W_tt``.

Compression ends at ``p_c`` where ``v_n(p_c) = 0``; restitution ends at ``p_f`` where the work
of the normal impulse in restitution is ``e^2`` times minus its work in compression::

    W_n(p) = int_0^p v_n dp',     W_n(p_f) - W_n(p_c) = -e^2 W_n(p_c).

The impulse is ``pi = (p_f, pi_t(p_f))``. Energy is never created:
``T+ - T- = W_n(p_f) - mu int |v_t| dp = (1 - e^2) W_n(p_c) - mu int |v_t| dp <= 0``. With
``mu = 0`` or ``W_tn = 0`` the normal impulse is Newton's, ``(1 + e) p_c`` with
``p_c = -v_n- / W_nn``.

One contact, planar -- exact. Every phase is linear in p: slip (``lambda = -mu s``), stick
(``lambda = -W_tn / W_tt`` when ``|W_tn| <= mu W_tt``), reversal (``s = sgn W_tn`` otherwise).
A slip stops at ``p_s = |v_t| / (mu W_tt - s W_tn)`` when that is positive; at most two
phases occur. Compression ends at a root of a linear function, restitution at the smaller
positive root of the quadratic ``W_n(p) = (1 - e^2) W_n(p_c)`` (written cancellation-free):
closed forms, accurate to round-off.

One contact, spatial -- exact in its linear phases (stick, and slip along an invariant ray:
an onset from rest, or a pre-impact slip already on such a ray), integrated in its curved
one. A pre-impact slip off the invariant rays turns as it slows; ``dv_t/dp = b - mu C s`` is
discontinuous at ``v_t = 0``, where the slip stops at a finite ``p`` with a non-analytic
(fractional-power) approach. The slip is therefore integrated in the variable ``sigma``,
``dsigma = dp / |v_t|``, in which ``dv_t/dsigma = |v_t| b - mu C v_t`` is smooth (Lipschitz,
analytic away from 0) and the stop is an exponential decay (reached as ``sigma -> inf``):
the state ``(p, pi_t, W_n)`` obeys ``dp/dsigma = |v_t|``, ``dpi_t/dsigma = -mu v_t``,
``dW_n/dsigma = |v_t| v_n`` with ``v = v- + W pi``. It is integrated by an embedded
Runge--Kutta pair of order 8(5,3) (Dormand--Prince DOP853: the coefficients of
scipy.integrate's DOP853, our own compiled step loop, :mod:`.stronge_slip`).

**Error control.** Each step's local error estimate is kept below ``ODE_RTOL = 1e-13`` times
``|y| + (p_0, p_0, p_0, |v_n-| p_0)``, ``p_0 = |v_n-| / W_nn`` the frictionless compression
impulse (absolute on impulses and work at that scale, relative beyond it). The events
``v_n = 0`` (end of compression) and ``W_n = (1 - e^2) W_n(p_c)`` (end of restitution) are
located inside the accepted step by bracketed Newton iterations on the step length, each
re-taking the step (so to the method's own accuracy; |dsigma| <= 1e-13 h). A decelerating
slip is handed to the exact straight finish of a linear phase (its last ``|v_t| / |h|`` of
impulse, h = s.(b - mu C s) < 0, with the stop and the events in it exact) once its direction
has settled on the one it stops along: the straight finish misses
``|v_t| |dh/dphi| dphi / (|h| (|h| + |dg/dphi|))`` of normal impulse (first order of the
tail in the angle dphi ~ |g / g'| left, g = s_perp.(b - mu C s)), and the hand-over waits
until that is below ``1e-13 p_0`` with dphi <= 1e-3, or until ``|v_t| <= 1e-10 |v-|`` (the
integration's round-off floor). The stick / onset decision is then taken at ``v_t = 0``.
Measured (400 random systems, 360 of them with a curved slip, and the 150 of
tests/impact/test_stronge.py): against the same code at ``ODE_RTOL = 1e-15`` (run as plain
Python) the impulses agree to 7e-12 relative (median 3e-15), against an independent
solve_ivp integration in p to 2e-11 (the latter's own error; median 1e-13); the energetic
condition holds to 3e-12 by quadrature of the independent path (median 2e-14). The compiled
code and the same code as plain Python (``NUMBA_DISABLE_JIT=1``) agree to 3e-13 (math.hypot
differs in its last bit, which the step-size control turns into other steps). We state 1e-10
(:data:`~convimpact.impact.exact.dispatch.FAST_TOL`). Cost (compiled, measured through
:func:`contact_kernel` on 100 random systems, one core): a spatial impact takes 10-30 steps
(median 13-18; up to a few hundred for stiff slips, ``mu |W_tt| >> |h|``), about 16 us
(median; 60 us at worst of 100) against 10-15 us for the other laws' kernels through
:func:`~convimpact.impact.exact.dispatch.solve_contact`; a planar one about 6 us.

A collision that cannot end raises :class:`NonPositiveEffectiveMassError` (a Painleve-like
jam): a phase in which ``dv_n/dp = W_nn - mu W_tn . s <= 0`` before compression ends, or in
which the contact re-approaches (``v_n < 0``) during restitution before the energy condition
is met; the message names the phase and its ``dv_n/dp``. A singular W where the stick /
onset decision needs ``C^-1 b`` or ``det W / det C`` raises :class:`SingularSystemError`; a
curved slip whose step size underflows (below 1e-300) :class:`SolverError`.

Implementation. :func:`_stronge_planar` (here) and
:func:`~convimpact.impact.laws.stronge_slip._stronge_spatial` are the kernel, compiled, and
its only implementation: :func:`contact_kernel` (their entry on plain floats,
``method="fast"``), the batch and the compiled lane all run them. They return a status and
the impulse and write the path's record into a float64 scratch (its layout:
:mod:`.stronge_slip`), from which :func:`_extras` builds the ``extras`` below and
:func:`_errors` the errors' messages.

Several contacts. Impacts whose contacts are dynamically independent (the off-diagonal
blocks of W vanish, |W_ij| <= 1e-12 times the diagonal scale) are resolved exactly, contact by
contact, through the same exact kernel (no cone program is solved; ``extras["formulation"]``
says so). Coupled contacts go to the two-phase formulation of
:mod:`convimpact.impact.laws.stronge_contacts` (compression by a cone program, expansion by
Poisson's normal impulses with maximal-dissipation friction; never creates energy).

Derivative. :func:`impulse_derivative` (and :func:`several_impulse_derivative`, which also
differentiates the coupled contacts' two-phase formulation,
:mod:`convimpact.impact.laws.stronge_contacts_derivative`) gives ``d pi / d(W, v-, e, mu)``:
the path re-traced with the kernel's decisions and differentiated phase by phase and event by
event (:mod:`convimpact.impact.laws.stronge_derivative` states the method, its one-sided mode
boundaries and its accuracy: ~1e-11 relative against central differences, median).

``extras`` of the result: ``phases`` (their kinds in order: ``"slip"``, ``"stick"``,
``"reversal"`` (planar slip after a stop), ``"onset"`` (slip from rest, in the selected
direction)), ``phase_impulses`` (the normal impulse at their boundaries, ``0, ..., p_f``),
``compression_impulse`` p_c, ``normal_work_compression``
W_n(p_c), ``normal_work_restitution`` W_n(p_f) - W_n(p_c), ``energetic_restitution``
``sqrt(-(W_n(p_f) - W_n(p_c)) / W_n(p_c))`` (= e), ``friction_work`` ``T+ - T- - W_n(p_f)``
(<= 0), ``slip_direction`` (the onset direction, when one was selected) and
``integration_steps`` (accepted DOP853 steps, spatial curved slip).

Example (a planar contact whose slip stops and sticks):

>>> sol = contact_kernel([[2.0, 0.5], [0.5, 1.0]], [-1.0, 0.2], 2, 0.5, 0.8)
>>> sol.regime, sol.extras["phases"]
('stick', ('slip', 'stick'))
>>> round(sol.extras["energetic_restitution"], 12)
0.5
"""

from __future__ import annotations

import math
from operator import mul

from .codes import FAILED, JAM, OK, SINGULAR, SLIDE, STICK, _NAN, _jit
from ..conic.paths import ProgramOptions
from ..conic.qp import Backend
from ...errors import NonPositiveEffectiveMassError, SingularSystemError
from ..exact.dispatch import compiled_kernel, coupled, independent_contacts_result
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from .stronge_slip import (  # noqa: F401  (the path in impulse space; its tolerances re-exported)
    FLOOR_RTOL,
    JAM_RTOL,
    MAX_IMPULSE,
    MAX_STEPS,
    O_DIRECTION,
    O_ERR_COMPRESSING,
    O_ERR_KIND,
    O_ERR_VALUE,
    O_HAS_DIRECTION,
    O_KINDS,
    O_NPHASES,
    O_PC,
    O_STARTS,
    O_STEPS,
    O_WC,
    O_WN,
    ODE_RTOL,
    PH_ONSET,
    PH_REVERSAL,
    PH_SLIP,
    PH_STICK,
    PHASE_NAMES,
    RAY_RTOL,
    SINGULAR_RTOL,
    STICK_RTOL,
    STOP_RTOL,
    TAIL_RTOL,
    _failed,
    _run_linear,
    _scaled_back,
    _speed_exponent,
    _start,
    _stronge_spatial,
)

LAW = "stronge"

_INF = math.inf


# --------------------------------------------------------------------------------------------
# one planar contact: exact (compiled; every path runs it)


@_jit
def _stronge_planar(A, B, C, v0, v1, e, mu, out):
    """One planar contact (:func:`_stronge_planar_scaled`) in velocity units where the
    approach speed -v0 is of order one: the works W_n ~ v0^2 / A would underflow to zero for
    -v0 ~ 1e-300 beside an O(1) slip, and with them the restitution's target (the contact
    would leave at v_n+ = 0 whatever e). v- is scaled by a power of two, exactly, and the
    answer scaled back (as :func:`~convimpact.impact.laws.stronge_slip._stronge_spatial`)."""
    k = _speed_exponent(v0, v1, 0.0)
    st, regime, p0, p1, p2, mass = _stronge_planar_scaled(
        A, B, C, math.ldexp(v0, k), math.ldexp(v1, k), e, mu, out)
    return _scaled_back(out, k, st, regime, p0, p1, p2, mass)


@_jit
def _stronge_planar_scaled(A, B, C, v0, v1, e, mu, out):
    """One planar contact (W = [[A, B], [B, C]]), mu > 0, approaching, W in the safe range:
    linear phases of slip against v_t, stick (ratio -B / C when |B| <= mu C) or slip along
    sgn B (reversal after a slip, onset from rest) until the collision ends; the phases, works
    and jams into ``out`` (layout: :mod:`.stronge_slip`)."""
    tr = A + C
    _start(out)
    p, pt, pt2, Wn, target, vt2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    vn, vt = v0, v1
    compressing = v0 < 0.0  # True, typed as a plain bool (see _stronge_spatial)
    done = not compressing
    s0 = 0.0 if v1 == 0.0 else math.copysign(1.0, v1)
    kind = PH_SLIP
    while not done:
        if vt != 0.0:  # slip (or, against the pre-impact slip, its reversal)
            s = math.copysign(1.0, vt)
            kind = PH_SLIP if s == s0 else PH_REVERSAL
            lam = -mu * s
            at = B + C * lam
            stop = -vt / at if vt * at < 0.0 else _INF
        elif abs(B) <= mu * C * (1.0 + STICK_RTOL):  # at rest, and it can stay so
            det = A * C - B * B
            if not det > SINGULAR_RTOL * tr * tr:
                return _failed(out, SINGULAR, 0, det, compressing), FAILED, _NAN, _NAN, _NAN, _NAN
            kind = PH_STICK
            lam = -B / C
            at = 0.0
            stop = _INF
        else:  # at rest, and it cannot stay so: slip along sgn W_tn
            s = math.copysign(1.0, B)
            kind = PH_REVERSAL if s0 != 0.0 else PH_ONSET
            lam = -mu * s
            at = B + C * lam
            stop = _INF
        st, _, p, pt, pt2, vn, vt, vt2, Wn, compressing, target, done = _run_linear(
            out, kind, p, pt, pt2, vn, vt, vt2, Wn, compressing, target, done, e, tr,
            A + B * lam, lam, 0.0, at, 0.0, stop)
        if st != OK:
            return st, FAILED, _NAN, _NAN, _NAN, _NAN
    out[O_WN] = Wn
    return OK, STICK if kind == PH_STICK else SLIDE, p, pt, 0.0, _NAN


# --------------------------------------------------------------------------------------------
# the kernels' record as the solution's extras, and their errors


def _extras(out, regime, impulse, w, v, d, e, mu) -> tuple:
    """The path's phases, the works of the normal impulse and of friction, the onset direction
    and the integration's steps (the ``extras`` of the module docstring) from ``out``."""
    if regime not in ("stick", "slide"):
        return None, ()
    n = int(out[O_NPHASES])
    impulse = [float(x) for x in impulse]
    dT = 0.0  # T+ - T- = pi.v- + 1/2 pi.W.pi
    for i in range(d):
        dT += impulse[i] * (v[i] + 0.5 * sum(map(mul, w[i], impulse)))
    Wc, Wn = float(out[O_WC]), float(out[O_WN])
    Wr = Wn - Wc
    extras = {
        "phases": tuple(PHASE_NAMES[int(k)] for k in out[O_KINDS:O_KINDS + n]),
        # each phase ends where the next starts; the last at p_f
        "phase_impulses": (0.0, *(float(x) for x in out[O_STARTS + 1:O_STARTS + n]),
                           impulse[0]),
        "compression_impulse": float(out[O_PC]),
        "normal_work_compression": Wc,
        "normal_work_restitution": Wr,
        "energetic_restitution": math.sqrt(max(-Wr / Wc, 0.0)) if Wc < 0.0 else 0.0,
        "friction_work": dT - Wn,
    }
    if out[O_HAS_DIRECTION]:
        extras["slip_direction"] = (float(out[O_DIRECTION]), float(out[O_DIRECTION + 1]))
    if out[O_STEPS]:
        extras["integration_steps"] = int(out[O_STEPS])
    return extras, ()


def _errors(out, status, w, v, d, e, mu) -> Exception | None:
    """The law's own messages: the jammed phase and its dv_n/dp, the singular matrix."""
    if status == JAM:
        kind = PHASE_NAMES[int(out[O_ERR_KIND])]
        stage = "compression" if out[O_ERR_COMPRESSING] else "restitution"
        return NonPositiveEffectiveMassError(
            f"law 'stronge': the {stage} of this contact cannot end -- in its {kind} phase the "
            f"normal velocity changes by dv_n/dp_n = {float(out[O_ERR_VALUE]):.3e} per unit "
            "normal impulse (W_nn - mu W_tn.s <= 0, a Painleve-like jam), so the contact would "
            "absorb an unbounded impulse or re-approach before restitution ends; lower mu, or "
            "use law='ccp' or 'dissipative', which stay well posed")
    if status == SINGULAR:
        what = "W_tt" if out[O_ERR_KIND] == 1.0 else "W"
        return SingularSystemError(
            f"law 'stronge': the contact's slip reached zero and {what} is singular "
            f"(det = {float(out[O_ERR_VALUE]):.3e}), so the sticking ratio -W_tt^-1 W_tn (or "
            "the normal compliance det W / det W_tt while sticking) is not defined; the "
            "impulse-space integration cannot go on. Use law='ccp' or 'dissipative', which "
            "accept a singular W")
    return None


# mu = 0: Newton's impulse (p_f = (1 + e) p_c), taken by the wrapper
contact_kernel = compiled_kernel(
    LAW, _stronge_planar, _stronge_spatial, _extras, errors=_errors,
    no_solution="law 'stronge': the spatial slip integration could not meet its error "
                "tolerance (step size underflow)")


# --------------------------------------------------------------------------------------------
# the law's entry points


def program_result(P: ImpactProblem, backend: Backend, method: str,
                   opts: ProgramOptions) -> ImpactResult:
    """Several contacts: exact, contact by contact, when they are dynamically independent;
    coupled contacts by the two-phase formulation of
    :mod:`convimpact.impact.laws.stronge_contacts` (on the conic path ``method``).

    ``backend`` and ``opts`` serve the coupled formulation's compression program only.
    """
    if coupled(P):
        from .stronge_contacts import coupled_result
        return coupled_result(P, backend, method, opts)
    return independent_contacts_result(P, LAW, method)



from .stronge_derivative import impulse_derivative, several_impulse_derivative  # noqa: E402,F401
