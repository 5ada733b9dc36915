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
3. **The modes, and the exact forces.** Each contact's mode is read off the answer and
   the forces of these modes are solved exactly, edge contacts tried both ways
   (:func:`~convimpact.simulation.force_combinations.read_modes`). At an event of a run
   the engine starts from the held contacts' forces there (``start``: its Newton finish
   from them, :func:`~convimpact.contacts.engine.solve`'s warm start; the cold path where
   that does not converge).

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

import numpy as np

from ..contacts.engine import solve as engine_solve
from ..contacts.finish import newton_finish
from ..errors import PainleveError, SolverError
from .contact_forces import (ContactForceProblem, ContactForceSolution, _unit,
                             force_solutions, planar_contact_force)
from .force_combinations import read_modes
from .force_distribution import OPEN, RTOL, SLIP

#: largest island whose possible paradox (or failed solve) is decided by enumeration
ENUMERATE_MAX = 7
#: natural-map residual (relative) at which the engine's or Newton's answer is used
SOLVE_TOL = 1e-10


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
                         warm: dict | None = None,
                         start: np.ndarray | None = None) -> ContactForceSolution:
    """The solution of the force problem, island by island (one planar contact: the closed
    form).

    ``warm`` (optional, one island): the active set of a nearby largest-smallest-margin
    program of the same contacts and modes (a run's held group at the event that ended its
    segment, :func:`~.force_distribution.max_margin_distribution`'s ``warm``), tried for the
    combinations' refusals before the solver; on return ``warm["chosen"]`` holds the
    chosen combination's program (its active set where one ran, for the next segment's
    margins) or None.

    ``start`` (optional, (n, d)): forces near a solution (a run's held contacts' forces at
    the event, zero for the others), the engine's warm start (its Newton finish from them,
    kept where its natural-map residual reaches the tolerance; the cold path otherwise).
    Only where the engine's answer is read: the modes are read off it and every
    combination solved exactly as from a cold answer.

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
    start = None if start is None else np.asarray(start, float).reshape(n, d)
    if len(parts) == 1:
        return _island(P, rtol, warm, start)
    force, acc = np.zeros((n, d)), np.zeros((n, d))
    modes, direction = [OPEN] * n, np.zeros((n, d - 1))
    margin, notes = np.inf, []
    for idx in parts:
        try:
            s = _island(_sub(P, idx), rtol, start=None if start is None else start[idx])
        except PainleveError as exc:
            exc.contacts = tuple(int(idx[i]) for i in exc.contacts)
            raise
        force[idx], acc[idx], direction[idx] = s.force, s.acceleration, s.direction
        for i, m in zip(idx, s.modes):
            modes[i] = m
        margin = min(margin, s.margin)
        notes += [f"contacts {idx.tolist()}: {note}" for note in s.notes]
    return ContactForceSolution(force, acc, tuple(modes), direction, margin, tuple(notes))


def _island(P: ContactForceProblem, rtol: float, warm: dict | None = None,
            start: np.ndarray | None = None) -> ContactForceSolution:
    if P.n == 1 and P.d == 2:
        sols = planar_contact_force(P.delassus, P.free_acceleration, float(P.mu[0]),
                                    float(P.slip[0, 0]), rtol)
        return _unique(P, sols, (0,))
    sol, answers = None, []
    for r, u in _answers(P, start):  # the modes read off the engine's answer, then Newton's
        answers.append((r, u))
        sol = read_modes(P, r, u, rtol, warm=warm)
        if sol is not None:
            break
    for r, u in answers if sol is None else ():  # onsets of vanishing a_t: any direction
        sol = read_modes(P, r, u, rtol, vanishing=True)
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


def _answers(P: ContactForceProblem, start: np.ndarray | None = None):
    """Approximate solutions (lambda (n, d) in the reduced unknowns, a (n, d)) at
    :data:`SOLVE_TOL`, cheapest first: the engine's on the symmetric problem with the
    sliding contacts frictionless (exact without sliding contacts; with them, their modes
    are often right already), then Newton's method on the mixed problem from it and from
    zero. ``start``: the engine's warm start (the sliding contacts' tangential parts left
    out, as their friction is)."""
    n, d = P.n, P.d
    b = P.free_acceleration
    WT, mu_r = _reduced(P)
    if start is not None:
        start = np.where(P.sliding_mask[:, None] & (np.arange(d) > 0), 0.0, start)
    R = engine_solve(P.delassus, b, mu_r, d, coulomb=True, tol=SOLVE_TOL, start=start)
    if R.converged:
        yield R.impulse, R.velocity
    if not any(P.sliding(i) for i in range(n)):
        return
    for r0 in (R.impulse, np.zeros((n, d))):
        r, res, _ = newton_finish(WT, b, mu_r, np.asarray(r0, float).reshape(n, d),
                                  coulomb=True, tol=SOLVE_TOL, max_iter=60)
        if res <= SOLVE_TOL:
            yield r, (WT @ r.ravel() + b).reshape(n, d)
