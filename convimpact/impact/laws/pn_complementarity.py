"""The ``pereira-nikravesh`` law at several simultaneous contacts, in complementarity form.

Newton's law (eq. 21) at several contacts is a complementarity condition, not an equality:
with the Newton velocity ``u_n = v_n+ + e min(v_n-, 0)`` of each contact,

    u_n >= 0,   pi_n >= 0,   u_n pi_n = 0,                                    (N)

so a contact either carries an impulse and leaves at Newton's velocity (``v_n+ = -e v_n-``,
or ``v_n+ = 0`` when it was not approaching), or carries none and does not penetrate
(``v_n+ >= -e v_n-``). Whether a contact approaches at -1e-12 (what an integrator leaves) or
touches exactly changes nothing: (N) is continuous in ``v_n-``, whereas imposing
``v_n+ = -e v_n-`` wherever ``v_n- < 0`` makes a rocking block stop dead when its pivot
approaches at round-off.

The paper's friction rule (Section 8) is kept on the contacts that carry impulse, the
*active set* A:

1. **Stick.** For every A holding an approaching contact (impulses among contacts that
   merely touch would be an impact without collision; approaching at round-off,
   ``v_n- >= -1e-9 max |v-|``, counts as touching): ``u_n = 0`` and ``v_t+ = 0`` on A
   (eqs. 42/52 jointly), ``pi = 0`` off A. Admissible when every impulse on A lies in its
   friction cone (eq. 53) and no contact off A penetrates (``u_n >= 0``). If any A is
   admissible the law sticks on the most dissipative one (smallest T+).
2. **Slide.** Otherwise, for every such A: one contact slides by the single-contact law
   (eq. 55 in the plane, the maximal-dissipation direction of eq. 60 in space); several by
   the program P_N(A): minimize T+ subject to ``u_n = 0`` on A and ``pi in K_mu`` (the seed's
   maximal dissipation). Admissible when no contact off A penetrates; the law returns the
   most dissipative admissible one.

An active set is a choice of which contacts keep touching; the law picks, as P-N does for
one contact, sticking first and maximal dissipation among the admissible choices. (Housner's
rocking block and McGeer's rimless wheel land sticking on the new corner, the old one
lifting: the stick tier's answer.) Several
admissible active sets with different velocities (Newton's law with friction is not unique
at several contacts) are reported in the warnings; equally dissipative sets with the same
velocities (redundant contacts) give the largest set's least-norm impulse. The stick tier
solves every active set (2^n - 1 linear systems, at most :data:`MAX_CONTACTS` contacts; a
NotSupportedError names the other laws); the slide tier visits them by increasing lower
bound of T+ (the same minimum without the cones,
:func:`~.pn_complementarity_kernels.relaxed_bounds`) and stops when no remaining set can be
more dissipative than the best admissible one. An active set whose program fails (not
converged, a jam) is listed in ``extras["failed_active_sets"]`` and, when it might have
been more dissipative than the answer, in a warning.

The stick tier, the relaxed bounds and the admissibility test are written once, in
:mod:`.pn_complementarity_kernels`, and run compiled or as plain Python
(:func:`compiled_kernels`); compiled, every slide program of several contacts is first solved
exactly and certified by its KKT conditions (:mod:`.pn_complementarity_slide`). The same
sets, tests, tie-break and warnings either way.
"""

from __future__ import annotations

import functools
import itertools
import math
from typing import Any

import numpy as np

from ..conic.paths import ProgramOptions, approaching, regimes_from_slip, solver_report
from ..conic.polish import kkt_residual
from ..conic.qp import TINY, Backend, ConeQP, equilibrated, solve_cone_qp
from ..diagnostics import assemble_result
from ...compiled import announce, cached, plain
from ...errors import ConvImpactError, NotSupportedError, SolverError
from ..exact.dispatch import solve_contact
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from . import pn_complementarity_kernels as kernels
from . import pn_complementarity_search as search
from . import pn_complementarity_slide as slide

LAW = "pereira-nikravesh"
#: largest number of simultaneous contacts whose active sets are enumerated
MAX_CONTACTS = 8
#: condition number above which a stick system is solved in the least-squares sense
STICK_COND_MAX = 1e12
#: relative tolerance of the cone test of a stick impulse
CONE_RTOL = 1e-9
#: largest relative round-off allowance on velocities (cond(W) eps, capped)
VELOCITY_SLACK_MAX = 1e-4
EPS = float(np.finfo(float).eps)
#: several-contact calls of a process after which the compiled kernels run (compiled_kernels)
HOT_CALLS = 200
_CALLS = 0
#: ``extras["solver_status"]`` of a slide program certified without the interior-point method
CERTIFIED = "certified active-set Newton"
# the stick tier, the relaxed bounds and the admissibility test are the compiled kernels'
# (pn_complementarity_kernels); before those are compiled the same functions run as plain
# Python (convimpact.compiled.plain): one source, two ways of running it
_STICK_SOLVE = plain(kernels.stick_solve)
_ADMISSIBLE = plain(kernels.admissible)
_STICK_TIER = {True: kernels.stick_tier, False: plain(kernels.stick_tier)}
_RELAXED_BOUNDS = {True: kernels.relaxed_bounds, False: plain(kernels.relaxed_bounds)}


def newton_velocity_shift(P: ImpactProblem) -> np.ndarray:
    """``b = v- + e min(v_n-, 0) n`` (n_contacts, d): the Newton velocity is ``u = W pi + b``."""
    b = P.v_minus.copy()
    b[:, 0] += P.restitution * np.minimum(P.v_minus[:, 0], 0.0)
    return b


def _mask(P: ImpactProblem, A: tuple[int, ...]) -> np.ndarray:
    """Active set A as the kernels take it: an (n,) bool membership mask."""
    member = np.zeros(P.n_contacts, dtype=np.bool_)
    member[list(A)] = True
    member.flags.writeable = False  # (as candidate_sets' rows: one compiled signature)
    return member


def stick_on(P: ImpactProblem, A: tuple[int, ...], b: np.ndarray) -> np.ndarray | None:
    """Impulse sticking every contact of A with ``u_n = 0`` (eq. 42/52 jointly), or None.

    A frictionless contact keeps only its normal row. A singular system (redundant
    contacts) is solved in the least-squares sense and accepted only when consistent. The
    stick tier's own solve (:func:`~.pn_complementarity_kernels.stick_solve`), run as plain
    Python.
    """
    W, bf, _, mu = _kernel_data(P, b)
    rows = np.empty(W.shape[0], dtype=np.int64)
    solved, m, x, _ = _STICK_SOLVE(W, bf, mu, P.dim, _mask(P, A), STICK_COND_MAX, rows)
    if not solved:
        return None
    pi = np.zeros(P.n_contacts * P.dim)
    pi[rows[:m]] = x
    return pi.reshape(P.n_contacts, P.dim)


def slide_on(P: ImpactProblem, A: tuple[int, ...], b: np.ndarray, backend: Backend,
             opts: ProgramOptions) -> tuple[np.ndarray, dict[str, Any]] | None:
    """The sliding impulse of active set A, or None where A cannot slide.

    One contact: the single-contact law (eq. 55 / eq. 60, the exact kernel), which needs it
    approaching. Several: P_N(A), minimize T+ = T- + pi.v- + 1/2 pi.W.pi subject to
    ``u_n = 0`` on A and pi in the cones (None when infeasible), by the interior-point
    method and its polish (the compiled path first tries
    :func:`~.pn_complementarity_slide.slide_set`, see :func:`_slide_tier`).
    """
    n, d = P.n_contacts, P.dim
    pi = np.zeros((n, d))
    if len(A) == 1:
        i = A[0]
        if not P.v_minus[i, 0] < 0.0:
            return None  # alone, a contact that does not approach takes no impulse
        W, v = P.contact_block(i)
        sol = solve_contact(W, v, float(P.restitution[i]), float(P.friction[i]), LAW)
        pi[i] = sol.impulse
        return pi, {"effective_mass": sol.effective_mass, "accuracy": 1e-10,
                    "warnings": tuple(sol.warnings), "slide_rule": "single-contact law"}
    try:
        sol = solve_cone_qp(backend, slide_program(P, A, -b[list(A), 0]), opts.tol,
                            opts.max_iter)
    except SolverError as exc:
        if "infeasible" in str(exc).lower():
            return None
        raise
    pi[list(A)] = sol.x.reshape(len(A), d)
    return pi, {"effective_mass": None, "accuracy": opts.accuracy(sol.polished),
                "warnings": (), "slide_rule": "P_N over the active set",
                **solver_report(sol, opts)}


def slide_program(P: ImpactProblem, A, f: np.ndarray) -> ConeQP:
    """P_N over the contacts ``A``: minimize 1/2 pi.W.pi + v-.pi subject to ``W_n pi = f`` on
    the normal rows of A and pi in A's friction cones (the law's one and several contacts)."""
    A, d = list(A), P.dim
    idx = np.concatenate([np.arange(i * d, (i + 1) * d) for i in A])
    W = P.delassus[np.ix_(idx, idx)]
    return ConeQP(W, P.v_minus[A].ravel(), P.friction[A], d, W[::d], f)


def _kkt_residual(P: ImpactProblem, A: tuple[int, ...], pi: np.ndarray, b: np.ndarray) -> float:
    """The relative KKT residual of P_N(A) at ``pi`` (on the equilibrated program, as the
    interior-point path reports it)."""
    eq = equilibrated(slide_program(P, A, -b[list(A), 0]))
    if eq is None:
        return 0.0
    scaled, s = eq
    return kkt_residual(scaled, pi[list(A)].ravel() / s)


def _admissible(P: ImpactProblem, A: tuple[int, ...], pi: np.ndarray, b: np.ndarray,
                tol: float, fast: bool = False) -> bool:
    """(N) and the cones: pi_n >= 0 and |pi_t| <= mu pi_n on A, u_n >= 0 off A, to round-off
    (:func:`~.pn_complementarity_kernels.admissible`, compiled with ``fast``, else run as
    plain Python).

    Contact by contact (their effective masses may lie far apart): a velocity row is allowed
    ``tol`` of its own size plus the round-off of forming it, ``1e2 eps sum_k |W_jk| |pi_k|``
    (cond(W) eps of the velocities where W is ill-conditioned), capped at
    :data:`VELOCITY_SLACK_MAX`; an impulse the same divided by the contact's W_nn.
    """
    W, bf, _, mu = _kernel_data(P, b)
    test = kernels.admissible if fast else _ADMISSIBLE
    return bool(test(W, np.abs(W), _mask(P, A), np.ascontiguousarray(pi.ravel(), float), bf,
                     mu, P.dim, CONE_RTOL, VELOCITY_SLACK_MAX, float(tol)))


def _energy_change(P: ImpactProblem, pi: np.ndarray) -> float:
    """T+ - T- = pi.v- + 1/2 pi.W.pi (eq. 58 in contact space)."""
    flat = pi.ravel()
    return float(flat @ P.v_minus.ravel() + 0.5 * flat @ P.delassus @ flat)


def _regimes(P: ImpactProblem, A: tuple[int, ...], pi: np.ndarray, tol: float) -> list[str]:
    vplus = P.v_minus + (P.delassus @ pi.ravel()).reshape(P.n_contacts, P.dim)
    return regimes_from_slip(P, pi, vplus, tol, [i not in A for i in range(P.n_contacts)])


def _energy_scale(P: ImpactProblem) -> float:
    """The law's energy scale ``1/2 max|v-|^2 / max W_ii`` of its ties and early stop."""
    return max(0.5 * float(np.max(np.abs(P.v_minus))) ** 2 /
               float(np.max(np.abs(np.diag(P.delassus)))), TINY)


def several_sets_note(sets: list) -> str:
    """The law's warning on several admissible active sets ``sets`` (the answer's first)."""
    listed = ", ".join(str(list(A)) for A in sets)
    return (f"Newton's law in complementarity form has {len(sets)} admissible active sets "
            f"here ({listed}) with different velocities; the most dissipative is returned")


def _pick(P: ImpactProblem, found: list[tuple]) -> tuple[tuple, list[str]]:
    """The most dissipative candidate, and a warning when others with other velocities exist.

    Candidates as dissipative as the best to round-off and with its velocities (redundant
    contacts: a box at rest on four corners sticks on all four, on a diagonal pair or on
    three, with the same zero velocity) differ only in how the impulse is shared; the largest
    active set is taken, then the impulse of least norm, so that the answer does not jump
    with the data's round-off (on the box: m g h / 4 on each corner)."""
    found.sort(key=lambda c: c[0])
    vs = max(float(np.max(np.abs(P.v_minus))), TINY)
    energy_scale = _energy_scale(P)
    # every candidate's velocity change W pi and impulse norm at once
    stacked = np.stack([c[2].ravel() for c in found])
    jumps = stacked @ P.delassus
    same = (np.max(np.abs(jumps - jumps[0]), axis=1) <= 1e-8 * vs).tolist()
    norms = np.sqrt(np.sum(stacked * stacked, axis=1)).tolist()
    ties = [(-len(c[1]), norm, k) for k, (c, sv, norm) in enumerate(zip(found, same, norms))
            if sv and c[0] <= found[0][0] + 1e-9 * energy_scale]
    best = found[min(ties)[2]]
    others = [c for c, sv in zip(found, same) if not sv]
    return best, [several_sets_note([c[1] for c in [best, *others]])] if others else []


def compiled_kernels() -> bool:
    """Whether this call runs the compiled stick tier and certified slide solves
    (:mod:`.pn_complementarity_kernels`, :mod:`.pn_complementarity_slide`): at once when
    numba's disk cache holds them, else from the :data:`HOT_CALLS`-th several-contact call of
    the process on (a time-stepping loop, not a handful of impacts; their first compilation
    takes about a minute on 2 cores, announced on stderr), or after
    :func:`~.pn_complementarity_impulse.compile_kernels`. Before, the same kernel functions
    run as plain Python (:func:`convimpact.compiled.plain`: no compilation to wait for) and
    every slide program by the interior-point method and its polish (a second method: their
    minimizers agree to round-off; where redundant contacts leave a family of minimizers,
    the two paths may return different members, with the same velocities and energy)."""
    global _CALLS
    _CALLS += 1
    if _CALLS > HOT_CALLS:
        return True
    entries = (kernels.stick_tier, kernels.relaxed_bounds, slide.slide_many, search.search)
    if _CALLS == 1 and all(cached(k) for k in entries):
        _CALLS = HOT_CALLS + 1
        return True
    if _CALLS == HOT_CALLS:
        announce("pereira-nikravesh several-contact kernels", 60, *entries)
        return True
    return False


@functools.lru_cache(maxsize=512)
def candidate_sets(n: int, closing: tuple[bool, ...]) -> tuple[list[tuple[int, ...]], np.ndarray]:
    """The active sets the law visits, largest first (each holding an approaching contact),
    and their (n_sets, n) membership masks."""
    subsets = [A for k in range(n, 0, -1) for A in itertools.combinations(range(n), k)
               if any(closing[i] for i in A)]
    masks = np.zeros((len(subsets), n), dtype=bool)
    for s, A in enumerate(subsets):
        masks[s, list(A)] = True
    masks.flags.writeable = False
    return subsets, masks


def closing_key(P: ImpactProblem) -> tuple[bool, ...]:
    """The contacts an active set must hold one of (:func:`candidate_sets`): the approaching
    ones; impulses among contacts that merely touch would be an impact without collision (one
    contact alone takes no impulse then either). Where every approach is round-off (touching
    contacts, no impact): those with ``v_n- < 0``."""
    closing = approaching(P)
    if not closing.any():
        closing = P.v_minus[:, 0] < 0.0
    return tuple(bool(c) for c in closing)


def _kernel_data(P: ImpactProblem, b: np.ndarray) -> tuple[np.ndarray, ...]:
    """W, b, v- (flattened) and mu as the kernels take them (C-contiguous float64)."""
    return (np.ascontiguousarray(P.delassus, dtype=float),
            np.ascontiguousarray(b.ravel(), dtype=float),
            np.ascontiguousarray(P.v_minus.ravel(), dtype=float),
            np.ascontiguousarray(P.friction, dtype=float))


def stick_candidates(P: ImpactProblem, b: np.ndarray, subsets: list[tuple[int, ...]],
                     masks: np.ndarray, fast: bool = True) -> list[tuple]:
    """The stick tier: every active set whose sticking impulse (:func:`stick_on`) is
    admissible, as (T+ - T-, A, pi, info), in the order of ``subsets``; one call of
    :func:`~.pn_complementarity_kernels.stick_tier`, compiled with ``fast``, else run as
    plain Python."""
    n, d = P.n_contacts, P.dim
    ok, energy, pis = _STICK_TIER[bool(fast)](*_kernel_data(P, b), d, masks, STICK_COND_MAX,
                                              CONE_RTOL, VELOCITY_SLACK_MAX, 1e-10)
    return [(float(energy[s]), A, pis[s].reshape(n, d), {"accuracy": 1e-10})
            for s, A in enumerate(subsets) if ok[s]]


def _certified_info(status: int, opts: ProgramOptions) -> dict[str, Any]:
    """The info of a slide program solved by :func:`~.pn_complementarity_slide.slide_set`
    (status 1: certified by the KKT conditions, -1: trivial, pi = 0)."""
    return {"effective_mass": None, "accuracy": opts.accuracy(True), "warnings": (),
            "slide_rule": "P_N over the active set",
            "solver_status": CERTIFIED if status == 1 else "trivial", "iterations": 0,
            "tolerance": opts.tol, "polished": True,
            "kkt_residual": None if status == 1 else 0.0}


def _slide_tier(P: ImpactProblem, b: np.ndarray, subsets: list[tuple[int, ...]],
                masks: np.ndarray, backend: Backend, opts: ProgramOptions, fast: bool
                ) -> tuple[list[tuple], list[str]]:
    """The slide tier: (admissible candidates, failed active sets).

    Most dissipative first: an active set whose relaxed bound (no cones) cannot beat the
    best admissible slide found so far is not solved. With ``fast``, every several-contact
    program is first solved in one compiled call
    (:func:`~.pn_complementarity_slide.slide_many`: certified by its KKT conditions, with
    the admissibility test and T+ - T-), the programs it leaves to the interior-point path
    and the one-contact slides then as on the Python path.
    """
    n, d = P.n_contacts, P.dim
    found: list[tuple] = []
    failures: list[str] = []
    energy_scale = _energy_scale(P)
    data = _kernel_data(P, b)
    bounds = _RELAXED_BOUNDS[bool(fast)](*data, d, masks).tolist()
    index = {A: i for i, A in enumerate(subsets)}
    if fast:
        status, pis, ok_many, energy = slide.slide_many(*data, d, masks, CONE_RTOL,
                                                  VELOCITY_SLACK_MAX, opts.accuracy(True))
    for bound, A in sorted(zip(bounds, subsets)):
        if math.isinf(bound):
            continue
        if found and bound > min(c[0] for c in found) + 1e-9 * energy_scale:
            break
        if fast and status[index[A]] in (1, -1):
            i = index[A]
            if ok_many[i]:
                found.append((float(energy[i]), A, pis[i].reshape(n, d),
                              _certified_info(int(status[i]), opts)))
            continue
        try:
            got = slide_on(P, A, b, backend, opts)
        except ConvImpactError as exc:  # a jam or an unconverged program of this A
            failures.append(f"{list(A)}: {exc}")
            continue
        if got is not None and _admissible(P, A, got[0], b, got[1]["accuracy"], fast):
            found.append((_energy_change(P, got[0]), A, got[0], got[1]))
    return found, failures


def _search(P: ImpactProblem, backend: Backend, opts: ProgramOptions
            ) -> tuple[str, list[tuple], list[str], np.ndarray]:
    """The tiers (module docstring): (tier, admissible candidates, failed active sets, b)."""
    n = P.n_contacts
    if n > MAX_CONTACTS:
        raise NotSupportedError(
            f"law 'pereira-nikravesh' enumerates the 2^n - 1 active sets of its contacts and "
            f"treats at most {MAX_CONTACTS} simultaneous contacts, got {n}; use law='coulomb', "
            "'ccp' or 'dissipative'")
    b = newton_velocity_shift(P)
    subsets, masks = candidate_sets(n, closing_key(P))
    fast = compiled_kernels()
    stick = stick_candidates(P, b, subsets, masks, fast)
    tier = "stick"
    found = stick
    failures: list[str] = []
    if not found:
        tier = "slide"
        found, failures = _slide_tier(P, b, subsets, masks, backend, opts, fast)
    if not found:
        detail = ("; ".join(failures[:3]) + ("; ..." if len(failures) > 3 else "")
                  if failures else "every active set is infeasible or lets a contact penetrate")
        raise SolverError(
            "P_N has no admissible active set: no choice of touching contacts satisfies "
            "Newton's law (v_n+ + e v_n- >= 0, pi_n >= 0, complementary) with impulses in the "
            f"friction cones ({detail}); use law='coulomb', 'ccp' or 'dissipative'")
    return tier, found, failures, b


def compiled_path_active() -> bool:
    """Whether the compiled path (:func:`compiled_kernels`) is already taken in this process,
    without counting a call."""
    return _CALLS > HOT_CALLS


def several_contacts_result(P: ImpactProblem, backend: Backend, method: str,
                            opts: ProgramOptions) -> ImpactResult:
    """The law at several contacts (module docstring): stick on the most dissipative
    admissible active set, else slide on the most dissipative admissible one."""
    tier, found, failures, b = _search(P, backend, opts)
    (dT, A, pi, info), notes = _pick(P, found)
    if info.get("kkt_residual", 0.0) is None:  # certified: its residual, as the polish's
        info = {**info, "kkt_residual": _kkt_residual(P, A, pi, b)}
    acc = float(info["accuracy"])
    extras: dict[str, Any] = {
        "active_set": list(A), "stick_test": tier == "stick", "tier": tier,
        "admissible_active_sets": [list(c[1]) for c in found],
        **{k: v for k, v in info.items() if k not in ("accuracy", "warnings",
                                                      "effective_mass")}}
    if failures:
        extras["failed_active_sets"] = failures
    warnings = [*info.get("warnings", ()), *notes]
    if failures:
        warnings.append(f"{len(failures)} active set(s) could not be solved and might have "
                        "dissipated more (extras['failed_active_sets']); the answer is the "
                        "most dissipative of the others")
    return assemble_result(P, pi, _regimes(P, A, pi, acc), LAW, method,
                           effective_mass=info.get("effective_mass"), tol=acc, extras=extras,
                           warnings=tuple(warnings))
