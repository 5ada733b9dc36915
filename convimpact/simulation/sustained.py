"""Sustained contact in the event-driven scheme: the force problem at a state, the modes it
selects, the redundant rows, and the held contacts' forces and margins during a segment.

At every event the simulator poses the contact force problem
(:mod:`~convimpact.simulation.contact_forces`) on the contacts that are closed or closing at
rest, and its solution selects each contact's mode: open (released), stick or slip. During a
segment the modes are fixed (:class:`~.canonical.CanonicalEquations`) and the run watches
their validity: a normal force turning tensile, a sticking force reaching the friction
cone's boundary (:func:`held_forces` gives the margin), a slip velocity reaching zero, and
the sliding contacts' force system turning singular (:func:`painleve_indicator`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import scipy.linalg as sla

from .canonical import CanonicalEquations, HeldMode, Row, _cho_solve, _cholesky
from .contact_forces import (OPEN, SLIP, STICK, ContactForceProblem, max_margin_distribution)
from .force_margin_extension import margin_extension


#: relative slack below which a margin counts as violated (a mode on the cone's boundary, e.g.
#: a box on an incline with mu = tan(slope) exactly, keeps sticking)
MARGIN_SLACK = 1e-9
#: margin (relative to the force scale) above which a hinted distribution stands in for the
#: exact largest-margin one in the event functions (:func:`held_forces`): its margin, a lower
#: bound of the largest, proves that positive (no event), and a step's end value of the
#: margin enters the location of a crossing only as a bracket's positive end (Brent's method
#: keeps the sign change, whatever the value). Was 1e-3: the box stack's sliding top box
#: (margins 7e-4 to 7e-3) ran a cone program at each step's end for no decision
HINT_MARGIN = 1e-6
#: rank tolerance of the held rows (relative to the largest singular value of C M^-1 C^T)
RANK_RTOL = 1e-10


@dataclass(frozen=True, eq=False)
class ContactState:
    """The closed-contact data at one state: the force problem and what it was built from."""

    contacts: tuple[str, ...]
    problem: ContactForceProblem
    jacobians: Mapping[str, np.ndarray]
    dims: Mapping[str, int]


def contact_state(mech, t: float, theta: np.ndarray, dtheta: np.ndarray,
                  contacts: Sequence[str], slip_tol: float) -> ContactState:
    """The force problem of ``contacts`` at (t, theta, theta_dot).

    ``W = J G J^T`` with G the loop-constrained inverse mass matrix; ``a_free`` from the loops'
    constrained dynamics without contact forces plus ``J_dot theta_dot``; a contact slides
    when its slip speed exceeds ``slip_tol``.
    """
    contacts = tuple(contacts)
    probe = CanonicalEquations(mech, contacts)  # frictionless: for J and J_dot only
    F = probe.factors(theta, constraints=False)  # M's factor, the contact Jacobians
    jac = F.jac
    jdot = probe.contact_jacobians_dot(theta, dtheta)
    f = probe.generalized_forces(t, theta, dtheta)
    J = np.vstack([jac[c] for c in contacts])
    Jdot = np.vstack([jdot[c] if jdot[c].shape == jac[c].shape else np.zeros_like(jac[c])
                      for c in contacts])
    MiJ = F.solve(J.T)
    acc = F.solve(f)
    if mech.n_loop_constraints:
        C = np.asarray(mech.loop_jacobian(theta), float).reshape(-1, F.M.shape[0])
        Cdot = np.asarray(mech.loop_jacobian_dot(theta, dtheta), float).reshape(C.shape)
        MiC = F.solve(C.T)
        S = C @ MiC
        acc = acc - MiC @ np.linalg.solve(S, C @ acc + Cdot @ dtheta)
        MiJ = MiJ - MiC @ np.linalg.solve(S, C @ MiJ)
    W = J @ MiJ
    W = 0.5 * (W + W.T)
    b = J @ acc + Jdot @ dtheta
    dims = {c: len(jac[c]) for c in contacts}
    slip = np.zeros((len(contacts), max(dims.values()) - 1))
    for i, c in enumerate(contacts):
        vt = jac[c][1:] @ dtheta
        if float(np.linalg.norm(vt)) > slip_tol:
            slip[i] = vt
    mus = np.array([float(mech.contact_parameters(c)[1]) for c in contacts])
    return ContactState(contacts, ContactForceProblem(W, b, mus, slip), jac, dims)


def held_modes(state: ContactState, modes: Sequence[str],
               directions: np.ndarray) -> dict[str, HeldMode]:
    """The :class:`HeldMode` of each closed contact of a force-problem solution."""
    out = {}
    for i, c in enumerate(state.contacts):
        if modes[i] == OPEN:
            continue
        mu = float(state.problem.mu[i])
        if modes[i] == STICK:
            out[c] = HeldMode("stick", (), mu)
        else:
            out[c] = HeldMode("slip", tuple(float(x) for x in directions[i]), mu)
    return out


def redundant_rows(M: np.ndarray, loop_rows: np.ndarray | None, rows: Sequence[Row],
                   jac: Mapping[str, np.ndarray]) -> frozenset:
    """Rows to leave out so that the constraints are independent: loops first, then normal
    rows, then tangential rows, each kept when it raises the rank of C M^-1 C^T."""
    M = np.asarray(M, float)
    L = _cholesky(M)
    if L is None:
        sla.cho_factor(M, lower=True)  # raises scipy's error, as before
        raise np.linalg.LinAlgError("the mass matrix is not positive definite")
    loops = [] if loop_rows is None else [r for r in np.atleast_2d(loop_rows)]
    position: dict = {}
    for i, r in enumerate(rows):
        position.setdefault(r, i)
    order = sorted(rows, key=lambda r: (r[1] > 0, position[r]))
    dropped = []
    scale = max(float(np.max(np.abs(_cho_solve(L, np.eye(len(M)))))), 1e-300)
    # every candidate row's products X M^-1 X^T once; a trial's C M^-1 C^T is a submatrix
    X = np.array(loops + [jac[c][j] for c, j in order], float).reshape(-1, len(M))
    G = X @ _cho_solve(L, X.T)
    kept = list(range(len(loops)))
    for u, (c, j) in enumerate(order, start=len(loops)):
        if len(kept) >= len(M):  # as many independent rows as coordinates: the rest depend
            dropped.append((c, j))
            continue
        trial = kept + [u]
        S = G[trial][:, trial]
        norm = float(X[u] @ X[u]) * scale
        # its smallest eigenvalue above RANK_RTOL * norm: S - RANK_RTOL norm I positive
        # definite, its Cholesky factor exists (a compiled factorization, not eigvalsh)
        S = 0.5 * (S + S.T)
        S.flat[::len(trial) + 1] -= RANK_RTOL * max(norm, 1e-300)
        if _cholesky(S) is not None:
            kept.append(u)
        else:
            dropped.append((c, j))
    return frozenset(dropped)


def held_forces(eq: CanonicalEquations, t: float, y: np.ndarray, hint: dict | None = None,
                margin_only: bool = False) -> tuple[dict[str, np.ndarray], float]:
    """The held contacts' forces and their smallest margin, relative to the force scale.

    The margin is ``mu lambda_n - |lambda_t|`` for sticking contacts and ``lambda_n`` for
    sliding (and frictionless) ones. Where rows were dropped as redundant the distribution
    among the contacts is indeterminate; as in the force problem
    (:func:`~.contact_forces._candidate`), the least-norm distribution is taken where it keeps
    every margin positive, and otherwise the one with the largest smallest margin t* (then
    the least norm among those whose margins all reach t* - 1e-12 of the force scale, unique
    and continuous in the data: :func:`~.contact_forces.max_margin_distribution`), so a
    sticking group slips
    only when no distribution keeps every force in its cone. (The margin is then continuous
    where it crosses zero: there the least-norm distribution's margin is not positive.)

    ``hint`` (a dict kept by the caller over a segment; the event functions pass one): the
    last exact distribution, moved into the current set of distributions, stands in for the
    exact program while its margin exceeds :data:`HINT_MARGIN`: it proves the largest margin
    positive, which is all an event function needs of it away from zero; near zero the exact
    program runs (and refreshes the hint). The forces returned are then that stand-in's.

    ``margin_only`` (the event functions locating a margin's zero): the exact program stops
    at the largest smallest margin (:func:`~.contact_forces.max_margin_distribution`'s
    ``below``), its maximizer standing in for the distribution chosen among them; with a
    ``hint``, from the last program's active set (its ``warm``).
    """
    forces = eq.contact_forces(t, y)
    if hint is not None:  # whether the forces returned are the exact ones (no stand-in)
        hint["exact"] = True
    if not eq.held:
        return forces, np.inf
    d, mu, combo, lam0, fscale = _held_data(eq, forces)
    smallest = _margins(mu, d, combo)
    if eq.dropped:
        # P: the projection onto the forces' determinate part (the complement of the
        # indeterminate directions Z): without forming Z where that is cheap
        # (_determinate_part), else P = I - Q Q^T with Q an orthonormal basis of Z.
        # lam0 - (I - P) lam0 = P lam0 is the least-norm distribution.
        cheap = _determinate_part(eq, y, d)
        Z, basis = None, None
        if cheap is not None:
            project, null, basis = cheap
        else:
            Z = _indeterminate(eq, y, d)
            null = Z.shape[1] > 0
            if null:
                Q = np.linalg.qr(Z)[0]
                if not eq.n_loops:  # Z of full rank: Q is an orthonormal basis of it
                    basis = (lambda: Q)

                def project(v):
                    return v - Q @ (Q.T @ v)
        if null:
            lam = project(lam0)  # the least-norm distribution
            if smallest(lam) <= MARGIN_SLACK * fscale:
                prev = None if hint is None else hint.get("lam")
                if prev is not None and prev.shape == lam0.shape:
                    lam = prev - project(prev - lam0)
                if prev is None or prev.shape != lam0.shape or (
                        smallest(lam) <= HINT_MARGIN * fscale):
                    # (margin only: an orthonormal basis of Z's span where one is at hand;
                    # the distribution chosen keeps the basis of _indeterminate: among
                    # many maximizers its last digits can depend on the basis)
                    orthonormal = margin_only and basis is not None
                    if orthonormal:
                        Z = basis()
                    elif Z is None:
                        Z = _indeterminate(eq, y, d)
                    lam, _ = max_margin_distribution(
                        mu, d, combo, lam0, Z, fscale, below=np.inf if margin_only else None,
                        warm=None if hint is None else hint.setdefault("warm", {}),
                        orthonormal=orthonormal)
                    if hint is not None:
                        hint["lam"] = lam
                        if margin_only:
                            hint["exact"] = False
                elif hint is not None:
                    hint["exact"] = False
            forces = {c: lam[i * d:i * d + len(forces[c])] for i, c in enumerate(eq.held)}
            lam0 = lam
    return forces, smallest(lam0) / fscale


def _held_data(eq: CanonicalEquations, forces: Mapping[str, np.ndarray]):
    """(d, mu, modes, lam0 (n d,), force scale) of the held contacts' forces ``forces``
    (mu and the modes kept on ``eq`` while its modes are the same dict: the run replaces
    only the slip directions in it)."""
    d = max(len(v) for v in forces.values())
    kept = getattr(eq, "_held_kinds", None)
    if kept is None or kept[0] is not eq.modes:
        kept = eq._held_kinds = (eq.modes, np.array([eq.modes[c].mu for c in eq.held]),
                                 [STICK if eq.modes[c].kind == "stick" else SLIP
                                  for c in eq.held])
    mu, combo = kept[1], kept[2]
    lam0 = np.zeros(len(eq.held) * d)
    for i, c in enumerate(eq.held):
        lam0[i * d:i * d + len(forces[c])] = forces[c]
    return d, mu, combo, lam0, max(float(np.max(np.abs(lam0))), 1e-300)


def held_margin_extension(eq: CanonicalEquations, t: float, y: np.ndarray,
                          state: tuple) -> float | None:
    """The smooth extension of the held contacts' largest smallest margin (relative to the
    force scale, as :func:`held_forces`') from the active set of a nearby exact program
    (``state``: its active set, maximizer and margin), by
    :func:`~.force_margin_extension.margin_extension`; None where it does not apply (no
    redundancy, no convergence). Not a margin: a predictor of where the margin crosses
    zero while the active set stays the program's."""
    if not eq.held or not eq.dropped:
        return None
    d, mu, combo, lam0, fscale = _held_data(eq, eq.contact_forces(t, y))
    cheap = _determinate_part(eq, y, d)
    if cheap is not None and cheap[2] is not None:
        Z, orthonormal = cheap[2](), True
    else:
        Z, orthonormal = _indeterminate(eq, y, d), False
    if Z.shape[1] == 0:
        return None
    got = margin_extension(mu, d, combo, lam0, Z, fscale, state, orthonormal)
    return got


def _margins(mu: np.ndarray, d: int, combo):
    """lam (n d,) -> its smallest margin: lambda_n of every contact, mu lambda_n - |lambda_t|
    of the sticking ones with friction (:func:`~.force_distribution._smallest_margin`,
    vectorized)."""
    cone = np.array([kind == STICK for kind in combo]) & (mu > 0.0)
    any_cone = bool(cone.any())
    every = bool(cone.all())
    mu_c = mu[cone]

    def smallest(lam: np.ndarray) -> float:
        F = lam.reshape(-1, d)
        margin = F[:, 0].min()
        if every and d == 3:  # (every contact a cone: no selection)
            cones = mu_c * F[:, 0] - np.hypot(F[:, 1], F[:, 2])
            return float(min(margin, cones.min()))
        margin = float(margin)
        if any_cone:
            T = F[cone, 1:]
            tangential = np.sqrt(np.einsum("ij,ij->i", T, T))
            margin = min(margin, float(np.min(mu_c * F[cone, 0] - tangential)))
        return margin
    return smallest


def _determinate_part(eq: CanonicalEquations, y: np.ndarray, d: int):
    """The projection onto the held forces' determinate part (the orthogonal complement of
    :func:`_indeterminate`'s directions, same rank rule) without forming them, where that is
    cheap: no loops, every contact of d rows, and either all sticking (the unknowns are the
    forces: the complement is spanned by the thin SVD's rows R of B, P = R^T R) or all
    sliding with one mu (each unknown, a normal force, enters its contact's block along
    (1, -mu s), of one norm for all: with T those unit columns, P = I - T (I - R^T R) T^T).
    Returns (v -> P v, whether there are indeterminate directions, a function returning an
    orthonormal basis of them or None), or None (then :func:`_indeterminate` and a QR).
    All sticking, the basis is the SVD's other right singular vectors (the null space of
    B, :func:`_indeterminate`'s Z up to a rotation)."""
    if eq.n_loops:
        return None
    kinds = {eq.modes[c].kind for c in eq.held}
    if kinds != {"stick"} and kinds != {"slip"}:
        return None
    theta = y[:eq.k]
    # held rows fixing every velocity (a resting stack): theta_dot = 0, theta stays the
    # segment's own to round-off, and B's factors are reused while it does (to 1e-13)
    locked = kinds == {"stick"} and eq.n_constraints >= eq.k
    memo = getattr(eq, "_locked_determinate", None) if locked else None
    if (memo is not None and memo[0] == d and float(np.abs(theta - memo[1]).max())
            <= 1e-13 * (1.0 + float(np.abs(memo[1]).max()))):
        return memo[2]
    jac = eq.contact_jacobians(theta)
    if any(len(jac[c]) != d for c in eq.held):
        return None
    n = len(eq.held)
    if kinds == {"stick"}:
        B = np.vstack([jac[c] for c in eq.held]).T  # (k, n d): the unknowns in order
        T = None
    else:
        mus = {eq.modes[c].mu for c in eq.held}
        if len(mus) != 1:
            return None
        mu = mus.pop()
        dtheta, _ = eq.theta_dot(theta, y[eq.k:])
        Jh = np.array([jac[c] for c in eq.held])  # (n, d, k)
        S = (None if mu <= 0 else eq.slip_directions(eq.held, Jh, dtheta))  # (at once)
        if S is None:
            S = np.array([eq.slip_direction(c, jac[c], dtheta) if mu > 0 else np.zeros(d - 1)
                          for c in eq.held]).reshape(n, d - 1)
        Jn = Jh[:, 0]  # (n, k)
        Jt = Jh[:, 1:]  # (n, d - 1, k)
        B = (Jn - mu * np.einsum("ijk,ij->ik", Jt, S)).T
        cols = np.hstack([np.ones((n, 1)), -mu * S])  # (n, d): each unknown's block
        norms = np.sqrt(np.einsum("ij,ij->i", cols, cols))
        if np.max(norms) - np.min(norms) > 1e-12 * np.max(norms):
            return None  # unit slip directions of unequal length: the general path
        T = cols / norms[:, None]
    # (all sticking: the full SVD, at the thin one's cost here, gives the basis too)
    _, sv, Vt = np.linalg.svd(B, full_matrices=T is None)
    rank = int(np.sum(sv > 1e-8 * sv[0])) if sv.size else 0
    R = Vt[:rank]
    null = rank < B.shape[1]  # indeterminate directions exist
    if T is None:
        out = (lambda v: R.T @ (R @ v)), null, (lambda: Vt[rank:].T)
        if locked:
            eq._locked_determinate = (d, np.array(theta, float), out)
        return out

    def project(v):
        u = np.einsum("ij,ij->i", T, v.reshape(n, d))  # T^T v
        w = u - R.T @ (R @ u)  # its indeterminate part
        return v - (T * w[:, None]).ravel()
    return project, null, None


def _indeterminate(eq: CanonicalEquations, y: np.ndarray, d: int) -> np.ndarray:
    """A basis of the held forces (n d,) that produce no generalized force (redundancy)."""
    k = eq.k
    theta = y[:k]
    dtheta, _ = eq.theta_dot(theta, y[k:])
    jac = eq.contact_jacobians(theta)
    cols, index = [], []
    for i, c in enumerate(eq.held):
        mode = eq.modes[c]
        if mode.kind == "stick":
            for j in range(len(jac[c])):
                cols.append(jac[c][j])
                index.append([(i * d + j, 1.0)])
        else:  # the tangential force follows the normal one
            s = eq.slip_direction(c, jac[c], dtheta) if mode.mu > 0 else np.zeros(len(jac[c]) - 1)
            cols.append(jac[c][0] - mode.mu * (jac[c][1:].T @ s))
            index.append([(i * d, 1.0)] + [(i * d + 1 + j, -mode.mu * s[j])
                                           for j in range(len(s))])
    B = np.array(cols).T  # (k, n_unknowns)
    if eq.n_loops:  # loop multipliers are free too
        B = np.hstack([B, np.asarray(eq.mechanism.loop_jacobian(theta), float).reshape(-1, k).T])
    _, sv, Vt = np.linalg.svd(B)
    # (relative 1e-8, not round-off's 1e-10: the friction of a self-equilibrated normal
    # distribution among many sliding legs makes a singular value of ~1e-10 that comes and
    # goes with the slip's round-off, and the distribution with it)
    rank = int(np.sum(sv > 1e-8 * sv[0])) if sv.size else 0
    N = Vt[rank:].T[:len(cols)]  # null directions restricted to the contact unknowns
    Z = np.zeros((len(eq.held) * d, N.shape[1]))
    rows = [row for entries in index for row, _ in entries]  # each force row once
    units = [u for u, entries in enumerate(index) for _ in entries]
    coefs = np.array([coef for entries in index for _, coef in entries])
    Z[rows] = coefs[:, None] * N[units]
    return Z


def painleve_indicator(eq: CanonicalEquations, t: float, y: np.ndarray) -> float:
    """det(C M^-1 (C^T + D)) / det(C M^-1 C^T) of the sliding set: 1 without friction,
    through zero where the sliding contacts' force system turns singular (Painleve)."""
    if not eq.slipping:
        return 1.0
    got = eq._compiled_terms(t, y)
    if got is not None:
        return got[2]
    k = eq.k
    theta = y[:k]
    dtheta, _, F = eq.velocities(theta, y[k:])
    D = eq.friction_columns(theta, dtheta, F.jac)[:, :eq.n_constraints]
    S = F.C @ F.A
    K = S + F.C @ F.solve(D)
    return float(np.linalg.det(np.linalg.solve(S, K)))
