"""The contact force problem of sustained contact solved without enumerating modes.

:mod:`~convimpact.simulation.contact_forces` states the problem (``a = W lambda + a_free``
with Coulomb's conditions per contact) and solves it by enumerating the modes of every
contact: exact, but 3^n to 4^n linear systems. Here the modes are *found*, not enumerated:

1. **Islands.** Contacts that do not share a body (no coupling entry in ``W``) are
   independent problems, solved apart.
2. **The contact engine.** A sliding contact's friction is fixed by its slip velocity,
   ``lambda_t = -mu lambda_n s``: its only unknown is ``lambda_n``, complementary to
   ``a_n`` (a frictionless contact in a problem whose matrix ``W T`` has the column
   ``W (e_n - mu s e_t)``). A contact at rest in its tangent plane obeys Coulomb's law at
   the acceleration level in De Saxce's form, ``K_mu ∋ lambda ⊥ a + mu |a_t| e_n ∈ K_mu*``
   (stick, or slip onset along ``a_t``). Without sliding contacts this is the contact
   problem of :func:`convimpact.solve_contact_problem` with the symmetric ``W``, solved
   by the engine (:func:`convimpact.contacts.engine.solve`); with them, a semismooth
   Newton method on the natural map of the (non-symmetric) mixed problem
   (:func:`~convimpact.contacts.finish.newton_finish`) from the engine's answer with
   the sliding contacts' friction left out.
3. **The modes, and the exact forces.** Each contact's mode is read off the answer (open
   where ``a_n > 0``; stick where ``a_t = 0``; slip onset along ``a_t`` otherwise) and the
   forces of these modes are solved exactly as the enumerator solves one combination
   (a linear system; among redundant contacts the distribution of
   :func:`~convimpact.simulation.force_distribution.max_margin_distribution`), every
   inequality checked. A contact on the edge between two modes (``lambda_n`` and ``a_n``
   both ~0, or ``a_t`` ~0 on the cone's boundary) is tried both ways; a contact that may
   close or open is kept closed (a grazing contact with no force stays closed). Every
   combination is decided, none skipped on a guess: one whose slip onsets are held at zero
   tangential acceleration by its own sticking rows is refused with the same combination
   sticking there (an implication, :func:`_refused_as_stuck`), and the margin programs of
   the combinations start from a nearby program's active set (the located event's, then
   the first combination's), the solver running only where Newton's method does not
   certify the optimum there.

**Uniqueness and Painleve's paradox.** Redundant contacts (a table on four or more legs, a
box on its face) leave the forces statically indeterminate; with friction the distribution
also moves the accelerations, and the rigid model then has a family of solutions. That is
not Painleve's paradox: the distribution is *chosen* (the largest smallest margin, then the
least norm: :func:`~convimpact.simulation.force_distribution.max_margin_distribution`) and
the solution says so in ``notes``. Painleve's paradox is the loss of existence or
uniqueness that a contact in slip with a non-positive effective normal mass
``A = W_nn - mu W_nt s`` causes (Painleve's rod). Where a slipping contact has ``A <= 0``, or
no solution is found, the problem is decided by the exact enumerator when it has at most
:data:`ENUMERATE_MAX` contacts; beyond, :class:`~convimpact.errors.PainleveError` is
raised naming the contacts with ``A <= 0`` (or, with every ``A > 0``,
:class:`~convimpact.errors.SolverError`: the solver failed, no paradox is claimed).
"""

from __future__ import annotations

import itertools

import numpy as np

from ..contacts.engine import solve as engine_solve
from ..contacts.finish import newton_finish
from ..errors import PainleveError, SolverError
from .contact_forces import (ContactForceProblem, ContactForceSolution, _candidate,
                             _label_frictionless, _onset_roots, _scales, _unit,
                             force_solutions, planar_contact_force)
from .force_distribution import OPEN, RTOL, SLIP, STICK
from .force_distribution_polish import _lstsq

#: largest island whose possible paradox (or failed solve) is decided by enumeration
ENUMERATE_MAX = 7
#: natural-map residual (relative) at which the engine's or Newton's answer is used
SOLVE_TOL = 1e-10
#: relative size below which lambda_n, a_n or |a_t| count as zero when reading the modes
MODE_RTOL = 1e-7
#: relative size below which a mode decision is on the edge (tried both ways)
EDGE_RTOL = 1e-4
#: edge contacts tried both ways at most (2^EDGE_MAX combinations)
EDGE_MAX = 6
#: relative residual below which an onset's tangential rows count as combinations of the
#: rows its combination holds at zero (:func:`_refused_as_stuck`)
STUCK_RTOL = 1e-10
_EPS = float(np.finfo(float).eps)  # (scipy.linalg.lstsq's default cond for dgelsy)


def islands(W: np.ndarray, n: int, d: int) -> list[np.ndarray]:
    """The contacts' independent groups: connected components of the coupling graph of
    ``W`` (contacts i, j coupled where a block ``W_ij`` is not zero, relative 1e-13)."""
    A = np.abs(np.asarray(W, float)).reshape(n, d, n, d).max(axis=(1, 3))
    A = A > 1e-13 * max(float(A.max(initial=0.0)), 1e-300)
    label = np.full(n, -1)
    groups = []
    for seed in range(n):  # breadth-first search
        if label[seed] >= 0:
            continue
        label[seed] = len(groups)
        members, frontier = [seed], [seed]
        while frontier:
            reach = np.flatnonzero(A[frontier].any(axis=0) & (label < 0))
            label[reach] = len(groups)
            members += reach.tolist()
            frontier = reach.tolist()
        groups.append(np.sort(np.array(members)))
    return groups


def _sub(P: ContactForceProblem, idx: np.ndarray) -> ContactForceProblem:
    rows = (idx[:, None] * P.d + np.arange(P.d)).ravel()
    return ContactForceProblem(P.delassus[np.ix_(rows, rows)], P.free_acceleration[rows],
                               P.mu[idx], P.slip[idx])


def solve_contact_forces(P: ContactForceProblem, rtol: float = RTOL,
                         warm: dict | None = None) -> ContactForceSolution:
    """The solution of the force problem, island by island (one planar contact: the closed
    form).

    ``warm`` (optional, one island): the active set of a nearby largest-smallest-margin
    program of the same contacts and modes (a run's held group at the event that ended its
    segment, :func:`~.force_distribution.max_margin_distribution`'s ``warm``), tried for the
    combinations' refusals before the solver; on return ``warm["chosen"]`` holds the
    chosen combination's program (its active set where one ran, for the next segment's
    margins) or None.

    Raises
    ------
    PainleveError
        Painleve's paradox: no solution (``kind="inconsistent"``) or several
        (``"indeterminate"``), with ``.contacts`` the indices of the contacts involved.
    SolverError
        No solution found where no contact's effective normal mass is non-positive.
    """
    n, d = P.n, P.d
    parts = islands(P.delassus, n, d)
    if len(parts) == 1:
        return _island(P, rtol, warm)
    force, acc = np.zeros((n, d)), np.zeros((n, d))
    modes, direction = [OPEN] * n, np.zeros((n, d - 1))
    margin, notes = np.inf, []
    for idx in parts:
        try:
            s = _island(_sub(P, idx), rtol)
        except PainleveError as exc:
            exc.contacts = tuple(int(idx[i]) for i in exc.contacts)
            raise
        force[idx], acc[idx], direction[idx] = s.force, s.acceleration, s.direction
        for i, m in zip(idx, s.modes):
            modes[i] = m
        margin = min(margin, s.margin)
        notes += [f"contacts {idx.tolist()}: {note}" for note in s.notes]
    return ContactForceSolution(force, acc, tuple(modes), direction, margin, tuple(notes))


def _island(P: ContactForceProblem, rtol: float,
            warm: dict | None = None) -> ContactForceSolution:
    if P.n == 1 and P.d == 2:
        sols = planar_contact_force(P.delassus, P.free_acceleration, float(P.mu[0]),
                                    float(P.slip[0, 0]), rtol)
        return _unique(P, sols, (0,))
    sol, answers = None, []
    for r, u in _answers(P):  # the modes read off the engine's answer, then Newton's
        answers.append((r, u))
        sol = _read_modes(P, r, u, rtol, warm=warm)
        if sol is not None:
            break
    for r, u in answers if sol is None else ():  # onsets of vanishing a_t: any direction
        sol = _read_modes(P, r, u, rtol, vanishing=True)
        if sol is not None:
            break
    A = P.effective_normal_mass()
    w = float(np.max(np.abs(np.diag(P.delassus))))
    if sol is not None:  # the slipping contacts, and the sliding ones that open
        bad = tuple(i for i, m in enumerate(sol.modes) if P.mu[i] > 0.0 and (
            (m == SLIP and _onset_mass(P, i, sol.direction[i]) <= 1e-12 * w)
            or (m == OPEN and P.sliding(i) and A[i] <= 1e-12 * w)))
    else:
        bad = tuple(i for i in range(P.n) if P.sliding(i) and A[i] <= 1e-12 * w)
    if sol is not None and not bad:
        return sol
    if P.n <= ENUMERATE_MAX:  # decided exactly
        return _unique(P, force_solutions(P, rtol), bad or tuple(range(P.n)))
    if bad:
        _raise(P, "inconsistent" if sol is None else "indeterminate",
               0 if sol is None else 2, bad)
    raise SolverError(f"the contact force problem of {P.n} contacts: no solution found "
                      "(every effective normal mass is positive: no paradox is claimed)")


def _onset_mass(P: ContactForceProblem, i: int, s: np.ndarray) -> float:
    """W_nn - mu W_nt s of contact i along s (the slip's or the onset's direction)."""
    r, d = i * P.d, P.d
    return float(P.delassus[r, r] - P.mu[i] * (P.delassus[r, r + 1:r + d] @ s))


def _unique(P, sols, contacts) -> ContactForceSolution:
    if len(sols) == 1:
        return sols[0]
    _raise(P, "inconsistent" if not sols else "indeterminate", len(sols), contacts)


def _raise(P: ContactForceProblem, kind: str, count: int, contacts) -> None:
    exc = PainleveError(
        f"Painleve's paradox: the contact force problem is {kind} "
        f"({'no' if count == 0 else count if P.n <= ENUMERATE_MAX else 'several'} "
        f"solution{'s' if count != 1 else ''}) at contacts {list(contacts)}; effective "
        f"normal masses in the slip direction {np.round(P.effective_normal_mass(), 6).tolist()}"
        " (<= 0 is the paradox)")
    exc.kind, exc.n_solutions, exc.contacts = kind, count, tuple(contacts)
    raise exc


def _reduced(P: ContactForceProblem) -> tuple[np.ndarray, np.ndarray]:
    """(W T, mu'): a sliding contact's force is lambda_n (1, -mu s): its column of ``W T``
    is ``W (e_n - mu s e_t)``, its tangential columns zero, its cone the normal half-line
    (mu' = 0)."""
    d, W = P.d, P.delassus
    WT, mu = W.copy(), P.mu.copy()
    for i in range(P.n):
        if P.sliding(i):
            n0 = i * d
            s = _unit(P.slip[i])
            WT[:, n0] = W[:, n0] - P.mu[i] * (W[:, n0 + 1:n0 + d] @ s)
            WT[:, n0 + 1:n0 + d] = 0.0
            mu[i] = 0.0
    return WT, mu


def _answers(P: ContactForceProblem):
    """Approximate solutions (lambda (n, d) in the reduced unknowns, a (n, d)) at
    :data:`SOLVE_TOL`, cheapest first: the engine's on the symmetric problem with the
    sliding contacts frictionless (exact without sliding contacts; with them, their modes
    are often right already), then Newton's method on the mixed problem from it and from
    zero."""
    n, d = P.n, P.d
    b = P.free_acceleration
    WT, mu_r = _reduced(P)
    R = engine_solve(P.delassus, b, mu_r, d, coulomb=True, tol=SOLVE_TOL)
    if R.converged:
        yield R.impulse, R.velocity
    if not any(P.sliding(i) for i in range(n)):
        return
    for r0 in (R.impulse, np.zeros((n, d))):
        r, res, _ = newton_finish(WT, b, mu_r, np.asarray(r0, float).reshape(n, d),
                                  coulomb=True, tol=SOLVE_TOL, max_iter=60)
        if res <= SOLVE_TOL:
            yield r, (WT @ r.ravel() + b).reshape(n, d)


def _read_modes(P: ContactForceProblem, r: np.ndarray, u: np.ndarray, rtol: float,
                vanishing: bool = False, warm: dict | None = None):
    """The exact solution in the modes the engine's answer shows (edges tried both ways),
    or None."""
    n, d = P.n, P.d
    ascale, fscale = _scales(P)
    first, edges = [], []
    for i in range(n):
        rn, an = r[i, 0] / fscale, u[i, 0] / ascale
        at = float(np.linalg.norm(u[i, 1:])) / ascale
        closed = rn > MODE_RTOL or an <= MODE_RTOL
        if P.sliding(i):
            s, onset, kinds = _unit(P.slip[i]), False, (SLIP, OPEN)
        elif P.mu[i] == 0.0:
            s, onset, kinds = np.zeros(d - 1), False, (SLIP, OPEN)
        elif at <= MODE_RTOL:
            s, onset, kinds = _unit(u[i, 1:]), True, (STICK, OPEN)
        else:
            s, onset, kinds = _unit(u[i, 1:]), True, (SLIP, OPEN)
        mode = kinds[0] if closed else OPEN
        options = [(mode, s, onset)]
        if max(rn, an) <= EDGE_RTOL:  # closed or open: both
            options.append((kinds[1] if closed else kinds[0], s, onset))
        on_cone = P.mu[i] * r[i, 0] - float(np.linalg.norm(r[i, 1:])) <= EDGE_RTOL * fscale
        if (not P.sliding(i) and P.mu[i] > 0.0 and mode != OPEN and at <= EDGE_RTOL
                and on_cone):  # stick, or an onset (a_t ~ 0: its direction is not known)
            along = [s] if at > MODE_RTOL else []
            if d == 2:
                alts = [(STICK, s, True), (SLIP, np.array([1.0]), True),
                        (SLIP, np.array([-1.0]), True)]
            else:  # along a_t, or against the friction force
                alts = [(STICK, s, True)] + [(SLIP, v, True) for v in along
                                             + [-_unit(r[i, 1:])] if np.any(v)]
            options += [o for o in alts if o[0] != mode or not np.array_equal(o[1], s)]
        first.append(options[0])
        if len(options) > 1:
            edges.append((i, options))
    edges = sorted(edges, key=lambda e: -len(e[1]))[:EDGE_MAX]
    failures: list[SolverError] = []
    best = _attempt(P, first, rtol, failures, vanishing, warm)
    if warm is not None:
        warm["chosen"] = None if best is None else dict(warm)
    if (best is not None and best.margin >= 0.0) or not edges:
        return _kept(best, failures)
    # the option indices of the combinations refused outright (no solver failure)
    refused = set() if best is not None or failures else {(0,) * len(edges)}
    for k, picks in enumerate(itertools.product(*[range(len(opts)) for _, opts in edges])):
        if k == 0:
            continue  # the first combination, tried above
        choice = list(first)
        for (i, opts), j in zip(edges, picks):
            choice[i] = opts[j]
        if _refused_as_stuck(P, choice, edges, picks, refused):
            refused.add(picks)
            continue
        n_failed = len(failures)
        mapped = _mapped_warm(P.d, first, choice, warm)
        cand = _attempt(P, choice, rtol, failures, vanishing, mapped)
        if cand is None and len(failures) == n_failed:
            refused.add(picks)
        if cand is not None and (best is None or _rank(cand) < _rank(best)):
            best = cand
            if warm is not None:  # the chosen combination's program, for the caller
                warm["chosen"] = mapped
    return _kept(best, failures)


def _mapped_warm(d: int, source, choice, warm: dict | None) -> dict | None:
    """A warm start for the margin program of the combination ``choice`` from that of
    ``source`` (``warm``: its active set, maximizer and margin, as
    :func:`~.force_distribution.max_margin_distribution` keeps them): each contact's cones
    keep their kinds where its mode is the same, are guessed inactive where it changed, and
    left out where it opened. A guess only: the program's refusal is taken from it where
    Newton's method certifies the optimality conditions there, and from the solver
    otherwise (two edge contacts of the box stack's tip, each combination with one of them
    open, were refused by the solver near a zero margin: a cone program and its polish)."""
    if warm is None or warm.get("active") is None or warm.get("lam") is None:
        return None
    kinds, parts = warm["active"]

    def layout(modes):
        return [(i, m) for i, m in enumerate(modes) if m != OPEN
                for _ in range(2 if m == STICK and d == 2 else 1)]
    src = layout([c[0] for c in source])
    if len(kinds) != len(src) + 1:  # (the last cone: the margin's bound)
        return None
    where: dict = {}
    for j, key in enumerate(src):
        where.setdefault(key, []).append(j)
    new_kinds, new_parts, taken = [], [], {}
    for key in layout([c[0] for c in choice]):
        js = where.get(key, ())
        n = taken.get(key, 0)
        taken[key] = n + 1
        if n < len(js):
            new_kinds.append(kinds[js[n]])
            new_parts.append(parts[js[n]])
        else:
            new_kinds.append(None)
            new_parts.append(np.zeros(0))
    new_kinds.append(kinds[-1])
    new_parts.append(parts[-1])
    return {"active": (new_kinds, new_parts), "lam": warm["lam"], "tau": warm["tau"]}


def _refused_as_stuck(P: ContactForceProblem, choice, edges, picks, refused) -> bool:
    """Whether a combination is refused because the same combination with its slip onsets
    sticking instead was: where every onset's tangential acceleration is held at zero by
    the combination's own equations.

    A combination C fixes ``a_n = 0`` at its closed contacts and ``a_t = 0`` at its
    sticking ones (rows K of ``a = W lambda + b``). Where an onset's tangential rows T are
    combinations of them, ``W_T = G W_K`` and ``b_T = G b_K`` (to round-off, tested here),
    ``a_T = G a_K = 0`` for every lambda of C: a slip that cannot start (a box with two of
    its corners sticking: its other corners are held too, the relative motion being
    rigid). A solution of C is then one of C' (the onsets sticking, no other change): its
    equations hold, and its margins are C's (the onsets' forces lie on their cones'
    boundaries, margin 0, their lambda_n kept >= the margin). So where C' was refused
    (its largest margin below the tolerance, by the guards of
    :func:`~.force_distribution.max_margin_distribution`), C is too, and is not solved
    (the box stack's top box at its slip onset: 10 of 16 combinations). ``picks``: C's
    option index per edge contact; ``refused``: the picks refused so far."""
    d = P.d
    onsets = [i for i, c in enumerate(choice)
              if c[0] == SLIP and c[2] and P.mu[i] > 0.0 and not P.sliding(i)]
    if not onsets:
        return False
    edge_of = {i: e for e, (i, _) in enumerate(edges)}
    stuck = list(picks)
    for i in onsets:
        e = edge_of.get(i)
        j = None if e is None else next(
            (j for j, o in enumerate(edges[e][1]) if o[0] == STICK), None)
        if j is None:
            return False
        stuck[e] = j
    if tuple(stuck) not in refused:
        return False
    K = [i * d + j for i, c in enumerate(choice) if c[0] != OPEN
         for j in (range(d) if c[0] == STICK else (0,))]
    T = [i * d + j for i in onsets for j in range(1, d)]
    W, b = P.delassus, P.free_acceleration
    # W_T ~ G W_K (least squares by a pivoted QR, dgelsy: W_K's rows may be dependent)
    G = _lstsq(W[K].T, W[T].T, _EPS).T
    ascale = _scales(P)[0]
    wscale = max(float(np.max(np.abs(W))), 1e-300)
    return bool(np.max(np.abs(W[T] - G @ W[K])) <= STUCK_RTOL * wscale
                and np.max(np.abs(b[T] - G @ b[K])) <= STUCK_RTOL * ascale)


def _attempt(P, choice, rtol: float, failures: list, vanishing: bool = False,
             warm: dict | None = None):
    """:func:`_exact`, a solver failure of its distribution kept aside (another combination
    may be the solution)."""
    try:
        return _exact(P, choice, rtol, vanishing, warm)
    except SolverError as exc:
        failures.append(exc)
        return None


def _kept(best, failures: list):
    """The solution found; where none was and a distribution's solver failed, that failure
    (no paradox is claimed on a failed solve)."""
    if best is None and failures:
        raise failures[0]
    return best


def _rank(s: ContactForceSolution) -> tuple[bool, int, int]:
    """Preference among the edge combinations: a solution valid only within the tolerance
    (a negative margin: a held force crossing zero, a sticking force crossing the cone) after
    one valid outright, then fewer open contacts, then fewer slipping ones."""
    return (s.margin < 0.0, sum(m == OPEN for m in s.modes), sum(m == SLIP for m in s.modes))


def _exact(P: ContactForceProblem, choice, rtol: float, vanishing: bool = False,
           warm: dict | None = None):
    """The enumerator's solution of one combination; a spatial onset's direction refined to
    the one along its own tangential acceleration (a fixed point), or None."""
    n, d = P.n, P.d
    combo = [c[0] for c in choice]
    dirs = [np.asarray(c[1], float) if c[0] == SLIP else np.zeros(d - 1) for c in choice]
    onset = [c[2] and c[0] == SLIP and P.mu[i] > 0.0 and not P.sliding(i)
             for i, c in enumerate(choice)]
    ascale = _scales(P)[0]
    cand = _candidate(P, combo, dirs, onset, rtol, warm)
    if d == 3 and any(onset):
        for _ in range(8):  # the directions as a fixed point, from the engine's
            if cand is None or _along(P, cand, onset, ascale, vanishing):
                break
            dirs = [_unit(cand.acceleration[i, 1:]) if onset[i] else dirs[i] for i in range(n)]
            if not all(np.any(dirs[i]) for i in range(n) if onset[i]):
                return None
            cand = _candidate(P, combo, dirs, onset, rtol)
        if cand is not None and not _along(P, cand, onset, ascale, vanishing):
            # the enumerator's root finding on the onsets' angles, for this combination
            unknown = [i for i in range(n) if onset[i]]
            cands = []
            for phis in _onset_roots(P, combo, dirs, unknown):
                dd = list(dirs)
                for i, ph in zip(unknown, phis):
                    dd[i] = np.array([np.cos(ph), np.sin(ph)])
                c = _candidate(P, combo, dd, onset, rtol)
                if c is not None and _along(P, c, onset, ascale, vanishing):
                    cands.append(c)
            cand = cands[0] if len(cands) == 1 else None
    if cand is None:
        return None
    sliding = [P.sliding(i) for i in range(n)]
    cand = _label_frictionless(P.mu, sliding, cand)
    if _indeterminate(P, cand):
        note = ("redundant contacts: the forces are statically indeterminate; the "
                "distribution with the largest smallest margin, then the least norm, is taken")
        cand = ContactForceSolution(cand.force, cand.acceleration, cand.modes, cand.direction,
                                    cand.margin, (note,))
    return cand


def _along(P: ContactForceProblem, cand: ContactForceSolution, onset, ascale: float,
           vanishing: bool = False) -> bool:
    """Whether each onset's tangential acceleration lies along its direction. With
    ``vanishing`` (the second reading of the modes, where the first found no solution) an
    onset whose tangential acceleration counts as zero (below MODE_RTOL, as when the modes
    are read) passes in the direction tried: it has none of its own, as a group of
    redundant contacts at the instant its largest margin reaches zero (a box on four
    corners pushed obliquely: |a_t| ~ 1e-8 of the scale, its direction round-off; every
    combination was refused and the enumerator's several solutions reported as Painleve's
    paradox for a third of the push's directions). The run freezes that direction and
    refreezes it along the slip velocity if the slip turns away
    (:meth:`~.contact_events.ContactEvents.freeze_directions`)."""
    for i in range(P.n):
        if onset[i]:
            at, s = cand.acceleration[i, 1:], cand.direction[i]
            if vanishing and float(np.linalg.norm(at)) <= MODE_RTOL * ascale:
                continue
            if float(np.linalg.norm(at - (at @ s) * s)) > 1e-9 * ascale:
                return False
    return True


def _indeterminate(P: ContactForceProblem, s: ContactForceSolution) -> bool:
    """Whether the closed contacts' force system of the modes is rank deficient."""
    closed = [i for i, m in enumerate(s.modes) if m != OPEN]
    if len(closed) < 2:
        return False
    d = P.d
    cols = []
    for i in closed:
        rows = slice(i * d, (i + 1) * d)
        if s.modes[i] == STICK:
            cols += [P.delassus[:, i * d + j] for j in range(d)]
        else:
            cols.append(P.delassus[:, i * d] - P.mu[i] * (P.delassus[:, rows][:, 1:]
                                                          @ s.direction[i]))
    C = np.array(cols).T
    sv = np.linalg.svd(C, compute_uv=False)
    return bool(sv[-1] <= 1e-10 * sv[0]) if sv[0] > 0 else True
