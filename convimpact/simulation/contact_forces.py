"""The contact force problem of sustained contact: Coulomb friction at the acceleration level.

The closed contacts' accelerations are affine in their forces (loops folded in)::

    a = W lambda + a_free,     W = J G J^T,     a_free = J theta_ddot_free + J_dot theta_dot,

with ``G`` the (loop-constrained) inverse mass matrix, ``J`` the stacked contact Jacobians
(rows n, t or n, t1, t2 per contact) and ``theta_ddot_free`` the acceleration without contact
forces. Per contact, with its slip velocity ``v_t``, Coulomb's conditions are

* normal: ``a_n >= 0``, ``lambda_n >= 0``, ``a_n lambda_n = 0`` (the contact opens or presses);
* sliding (``v_t != 0``): ``lambda_t = -mu lambda_n v_t / |v_t|``;
* not sliding (``v_t = 0``): either stick, ``a_t = 0`` with ``|lambda_t| <= mu lambda_n``, or
  start to slip, ``lambda_t = -mu lambda_n s`` with ``a_t = kappa s``, ``kappa >= 0``, ``|s| = 1``.

This is the impact law ``coulomb`` of :mod:`convimpact.impact.laws.coulomb` with ``e = 0``
written for accelerations and forces instead of velocities and impulses (where v_t = 0).

Two exact solvers use this module's data: :func:`force_solutions` enumerates the
contacts' modes (open, stick, slip; planar onsets in both directions) for every solution, at
most :data:`MAX_CONTACTS` contacts; each combination is a linear system in ``lambda`` (for a
spatial slip onset, a one-parameter family in the slip angle, whose roots are bracketed on a
scan and refined by Brent's method), and a combination is a solution when its inequalities
hold. It is the reference; the simulator uses
:func:`~convimpact.simulation.force_solver.solve_contact_forces`, which finds the modes with
the contact engine instead (no cap on the number of contacts) and solves each combination
found with this module's :func:`_candidate`. Redundant contacts (several rows of ``J``
dependent: a box on two corners sticking) leave the forces indeterminate; where the
least-norm solution violates an inequality,
:func:`~convimpact.simulation.force_distribution.max_margin_distribution` picks the
distribution over the null space: the largest smallest margin t*, then, among the
distributions whose margins all reach t* - 1e-12 (of the force scale), the least norm
(unique, and continuous in the data). The modes' names (``OPEN``, ``STICK``,
``SLIP``), ``RTOL`` and ``max_margin_distribution`` are importable from here too.

For one planar contact :func:`planar_contact_force` gives every solution in closed form.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.optimize import brentq

from ..errors import NotSupportedError, ShapeError
from .force_distribution import OPEN, RTOL, SLIP, STICK, max_margin_distribution

#: largest number of closed contacts enumerated (4^n combinations in the plane)
MAX_CONTACTS = 7
#: slip angles scanned to bracket a spatial slip onset
SCAN = 144


@dataclass(frozen=True, eq=False)
class ContactForceProblem:
    """The data of the force problem on ``n`` closed contacts of dimension ``d`` (2 or 3).

    Attributes
    ----------
    delassus : (n d, n d) W = J G J^T.
    free_acceleration : (n d,) contact accelerations without contact forces.
    mu : (n,) friction coefficients.
    slip : (n, d - 1) slip velocities v_t (rows of zeros where the contact does not slide).
    """

    delassus: np.ndarray
    free_acceleration: np.ndarray
    mu: np.ndarray
    slip: np.ndarray

    def __post_init__(self):
        W = np.asarray(self.delassus, float)
        b = np.asarray(self.free_acceleration, float).ravel()
        mu = np.asarray(self.mu, float).ravel()
        slip = np.asarray(self.slip, float)
        n = mu.size
        if n == 0 or b.size % n or b.size // n not in (2, 3):
            raise ShapeError(f"free_acceleration of size {b.size} does not match {n} contacts "
                             "of dimension 2 or 3")
        d = b.size // n
        if W.shape != (b.size, b.size) or slip.shape != (n, d - 1):
            raise ShapeError(f"delassus must be {(b.size, b.size)} and slip {(n, d - 1)}, got "
                             f"{W.shape} and {slip.shape}")
        if not (np.all(np.isfinite(W)) and np.all(np.isfinite(b)) and np.all(np.isfinite(slip))
                and np.all(mu >= 0.0)):
            raise ShapeError("the force problem's data must be finite and mu >= 0")
        for name, value in (("delassus", W), ("free_acceleration", b), ("mu", mu),
                            ("slip", slip)):
            object.__setattr__(self, name, value)

    @property
    def n(self) -> int:
        return int(self.mu.size)

    @property
    def d(self) -> int:
        return int(self.free_acceleration.size // self.mu.size)

    @cached_property
    def sliding_mask(self) -> np.ndarray:
        """(n,) whether each contact slides (a nonzero slip velocity)."""
        return np.any(self.slip != 0.0, axis=1)

    def sliding(self, i: int) -> bool:
        return bool(self.sliding_mask[i])

    @cached_property
    def scales(self) -> tuple[float, float]:
        """(acceleration scale, force scale) of the problem: the tolerances are relative
        to them."""
        diag = np.abs(np.diag(self.delassus))
        w = float(np.max(diag)) if diag.size and np.max(diag) > 0 else 1.0
        a = float(np.max(np.abs(self.free_acceleration)))
        a = a if a > 0.0 else w * 1e-300
        return a, a / w

    def effective_normal_mass(self) -> np.ndarray:
        """Per contact ``W_nn - mu W_nt s`` in its slip direction s (W_nn where not sliding):
        the normal acceleration per unit normal force of a sliding contact; <= 0 is
        Painleve's case."""
        d, W = self.d, self.delassus
        out = np.empty(self.n)
        for i in range(self.n):
            r = i * d
            s = _unit(self.slip[i])
            out[i] = W[r, r] - self.mu[i] * float(W[r, r + 1:r + d] @ s)
        return out


@dataclass(frozen=True, eq=False)
class ContactForceSolution:
    """One solution of the force problem.

    Attributes
    ----------
    force : (n, d) contact forces (normal first).
    acceleration : (n, d) contact accelerations.
    modes : per contact "open", "stick" or "slip".
    direction : (n, d - 1) the unit slip direction friction opposes (the slip's, or the
        onset's); zero rows for open and sticking contacts.
    margin : the smallest slack of the inequalities, relative to the problem's scale (>= 0
        up to the tolerance).
    notes : what the solver chose where the rigid model leaves a choice (the distribution
        among redundant contacts), empty otherwise.
    """

    force: np.ndarray
    acceleration: np.ndarray
    modes: tuple[str, ...]
    direction: np.ndarray
    margin: float
    notes: tuple[str, ...] = ()


def _unit(v: np.ndarray) -> np.ndarray:
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 0.0 else np.zeros_like(v)


def _scales(P: ContactForceProblem) -> tuple[float, float]:
    """(acceleration scale, force scale) of the problem: the tolerances are relative to them."""
    return P.scales


def _system(P: ContactForceProblem, combo, dirs) -> tuple[np.ndarray, np.ndarray]:
    """The linear equations E lambda = r of one combination of modes."""
    d, W, b = P.d, P.delassus, P.free_acceleration
    N = W.shape[0]
    E = np.zeros((N, N))
    r = np.zeros(N)
    for i, mode in enumerate(combo):
        rows = slice(i * d, (i + 1) * d)
        if mode == OPEN:
            E[rows, rows] = np.eye(d)
        elif mode == STICK:
            E[rows] = W[rows]
            r[rows] = -b[rows]
        else:  # slip along dirs[i]: a_n = 0, lambda_t = -mu lambda_n s
            n0 = i * d
            E[n0] = W[n0]
            r[n0] = -b[n0]
            for j in range(d - 1):
                E[n0 + 1 + j, n0 + 1 + j] = 1.0
                E[n0 + 1 + j, n0] = P.mu[i] * dirs[i][j]
    return E, r


def _solve(E: np.ndarray, r: np.ndarray, tol: float):
    """lambda0 and a null-space basis Z of E lambda = r, or None when inconsistent."""
    U, sv, Vt = np.linalg.svd(E)
    smax = float(sv[0]) if sv.size else 0.0
    rank = int(np.sum(sv > 1e-11 * smax)) if smax > 0 else 0
    coef = (U.T @ r)[:rank] / sv[:rank]
    lam = Vt[:rank].T @ coef
    if float(np.max(np.abs(E @ lam - r), initial=0.0)) > tol:
        return None
    return lam, Vt[rank:].T


def _slacks(P: ContactForceProblem, combo, dirs, lam: np.ndarray, onset) -> np.ndarray:
    """The inequalities' slacks (>= 0 when satisfied), in force units."""
    d, mu = P.d, P.mu
    a = P.delassus @ lam + P.free_acceleration
    ascale, fscale = _scales(P)
    to_force = fscale / ascale  # accelerations measured in force units
    out = []
    for i, mode in enumerate(combo):
        n0 = i * d
        if mode == OPEN:
            out.append(a[n0] * to_force)
        elif mode == STICK:
            t = lam[n0 + 1:n0 + d]  # (|t| as np.linalg.norm computes it: sqrt(t . t))
            out.append(mu[i] * lam[n0] - math.sqrt(float(t @ t)))
            out.append(lam[n0])
        else:
            out.append(lam[n0])
            if onset[i]:
                out.append(float(a[n0 + 1:n0 + d] @ dirs[i]) * to_force)
    return np.array(out)


def _candidate(P: ContactForceProblem, combo, dirs, onset, rtol: float,
               warm: dict | None = None):
    """The solution of one combination with given directions, or None. ``warm``: an
    active set of a nearby margin program to try for the refusal first
    (:func:`~.force_distribution.max_margin_distribution`)."""
    ascale, fscale = _scales(P)
    E, r = _system(P, combo, dirs)
    solved = _solve(E, r, 1e-9 * max(ascale, float(np.max(np.abs(E))) * fscale))
    if solved is None:
        return None
    lam, Z = solved
    slack = _slacks(P, combo, dirs, lam, onset)
    margin = float(np.min(slack, initial=np.inf))
    if margin < -rtol * fscale and Z.shape[1] and any(m != OPEN for m in combo):
        # (a combination whose largest margin is clearly negative is rejected after the
        # program's first stage: no distribution of it holds)
        lam, margin = max_margin_distribution(P.mu, P.d, combo, lam, Z, fscale,
                                              below=-rtol * fscale, orthonormal=True,
                                              warm=warm)
        slack = _slacks(P, combo, dirs, lam, onset)
        margin = min(margin, float(np.min(slack, initial=np.inf)))
    if margin < -rtol * fscale:
        return None
    d = P.d
    direction = np.zeros((P.n, d - 1))
    for i, mode in enumerate(combo):
        if mode == SLIP:
            direction[i] = dirs[i]
    a = P.delassus @ lam + P.free_acceleration
    return ContactForceSolution(force=lam.reshape(P.n, d), acceleration=a.reshape(P.n, d),
                                modes=tuple(combo), direction=direction,
                                margin=margin / fscale if fscale > 0 else margin)


def _lam_of(E: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Solutions of stacked systems E[j] lam = r (least squares where E[j] is singular)."""
    try:
        return np.linalg.solve(E, r[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.einsum("...ij,...j->...i", np.linalg.pinv(E, rcond=1e-11), r)


def _onset_residuals(P: ContactForceProblem, combo, dirs, unknown: list[int],
                     phis: np.ndarray, along: bool = False) -> np.ndarray:
    """cross(a_t, s) of the onsets ``unknown`` at the angles ``phis`` (m, len(unknown)); with
    ``along`` also a_t . s (the onset needs it >= 0) as a second array."""
    d = P.d
    E0, r = _system(P, combo, dirs)
    E = np.broadcast_to(E0, (len(phis),) + E0.shape).copy()
    for u, i in enumerate(unknown):
        n0 = i * d
        E[:, n0 + 1, n0] = P.mu[i] * np.cos(phis[:, u])
        E[:, n0 + 2, n0] = P.mu[i] * np.sin(phis[:, u])
    lam = _lam_of(E, np.broadcast_to(r, (len(phis), len(r))))
    a = lam @ P.delassus.T + P.free_acceleration
    out = np.empty((len(phis), len(unknown)))
    dot = np.empty((len(phis), len(unknown)))
    for u, i in enumerate(unknown):
        n0 = i * d
        c, s = np.cos(phis[:, u]), np.sin(phis[:, u])
        out[:, u] = a[:, n0 + 1] * s - a[:, n0 + 2] * c
        dot[:, u] = a[:, n0 + 1] * c + a[:, n0 + 2] * s
    return (out, dot) if along else out


def _onset_roots(P: ContactForceProblem, combo, dirs, unknown: list[int]) -> list:
    """Slip angles of the spatial onsets in ``unknown`` where a_t is parallel to s."""
    def residual(phis):
        return _onset_residuals(P, combo, dirs, unknown, np.atleast_2d(phis))[0]

    if len(unknown) == 1:
        grid = np.linspace(0.0, 2 * math.pi, SCAN + 1)
        vals, dots = _onset_residuals(P, combo, dirs, unknown, grid[:, None], along=True)
        vals, dots = vals[:, 0], dots[:, 0]
        roots = []
        for j in range(SCAN):
            v0, v1 = vals[j], vals[j + 1]
            if dots[j] < 0.0 and dots[j + 1] < 0.0:
                continue  # a_t opposes s here: no onset (its root is the antiparallel one)
            if v0 == 0.0:
                roots.append([grid[j]])
            elif v0 * v1 < 0.0:
                f = lambda x: float(residual([x])[0])  # noqa: E731
                if f(grid[j]) * f(grid[j + 1]) < 0.0:  # (a singular stack solves by pinv)
                    roots.append([brentq(f, grid[j], grid[j + 1], xtol=1e-14)])
        return roots
    # several spatial onsets together: Newton's method from 16 common directions at once
    # (a batched finite-difference Jacobian), the converged starts kept
    m = len(unknown)
    phis = np.repeat(np.linspace(0.0, 2 * math.pi, 16, endpoint=False)[:, None], m, axis=1)
    tol = 1e-10 * max(_scales(P)[0], 1e-300)
    step_h = 1e-7
    for _ in range(40):
        R = _onset_residuals(P, combo, dirs, unknown, phis)
        jac = np.empty((len(phis), m, m))
        for u in range(m):
            shifted = phis.copy()
            shifted[:, u] += step_h
            jac[:, :, u] = (_onset_residuals(P, combo, dirs, unknown, shifted) - R) / step_h
        try:
            step = np.linalg.solve(jac, R[..., None])[..., 0]
        except np.linalg.LinAlgError:
            step = np.einsum("sij,sj->si", np.linalg.pinv(jac), R)
        phis = phis - np.clip(step, -0.5, 0.5)
        if float(np.max(np.abs(step))) < 1e-13:
            break
    R = _onset_residuals(P, combo, dirs, unknown, phis)
    good = np.max(np.abs(R), axis=1) < tol
    return [list(p) for p in phis[good]]


def force_solutions(P: ContactForceProblem, rtol: float = RTOL) -> list[ContactForceSolution]:
    """Every solution of the force problem, distinct in accelerations.

    Where several combinations give the same accelerations (a stick whose force lies on the
    cone's boundary is also a slip onset with kappa = 0; an open contact with a_n = 0 is also
    closed with lambda_n = 0) the one with the most closed, then sticking, contacts is kept.
    """
    n, d = P.n, P.d
    if n > MAX_CONTACTS:
        raise NotSupportedError(
            f"the force problem enumerates the modes of at most {MAX_CONTACTS} closed contacts "
            f"at once, got {n}; solve_contact_forces (convimpact.simulation.force_solver) has no cap")
    options = []
    for i in range(n):
        if P.sliding(i):
            opts = [(OPEN, None, False), (SLIP, _unit(P.slip[i]), False)]
        elif P.mu[i] == 0.0:  # frictionless: closed means a_n = 0 and lambda_t = 0
            opts = [(OPEN, None, False), (SLIP, np.zeros(d - 1), False)]
        elif d == 2:
            opts = [(OPEN, None, False), (STICK, None, False), (SLIP, np.array([1.0]), True),
                    (SLIP, np.array([-1.0]), True)]
        else:
            opts = [(OPEN, None, False), (STICK, None, False), (SLIP, None, True)]
        options.append(opts)
    found: list[ContactForceSolution] = []
    for choice in itertools.product(*options):
        combo = [c[0] for c in choice]
        dirs = [c[1] if c[1] is not None else np.zeros(d - 1) for c in choice]
        onset = [c[2] for c in choice]
        unknown = [i for i, c in enumerate(choice) if c[0] == SLIP and c[1] is None]
        if unknown:
            for phis in _onset_roots(P, combo, dirs, unknown):
                dd = list(dirs)
                for i, ph in zip(unknown, phis):
                    dd[i] = np.array([math.cos(ph), math.sin(ph)])
                cand = _candidate(P, combo, dd, onset, rtol)
                if cand is not None:
                    found.append(cand)
        else:
            cand = _candidate(P, combo, dirs, onset, rtol)
            if cand is not None:
                found.append(cand)
    sliding = [P.sliding(i) for i in range(n)]
    found = [_label_frictionless(P.mu, sliding, s) for s in found]
    return _distinct(found, _scales(P)[0])


def _label_frictionless(mu, sliding, s: ContactForceSolution) -> ContactForceSolution:
    """A frictionless closed contact is "slip" (free along t), its direction that of a_t."""
    modes = list(s.modes)
    direction = s.direction.copy()
    for i, m in enumerate(modes):
        if mu[i] == 0.0 and m != OPEN:
            modes[i] = SLIP
            if not sliding[i]:
                direction[i] = _unit(s.acceleration[i, 1:])
    return ContactForceSolution(s.force, s.acceleration, tuple(modes), direction, s.margin)


def _rank(s: ContactForceSolution) -> tuple[bool, int, int, float]:
    """Order of preference among solutions of the same acceleration: one valid only within
    the tolerance (a negative margin) last -- at the instant a held contact's force crosses
    zero (or a sticking force reaches the cone) the closed (sticking) solution and the open
    (slipping) one coincide, and the event says which way the force goes: a held contact that
    stayed held with a tensile force would pull ever harder --; then fewer open contacts,
    fewer slipping ones, the larger margin."""
    return (s.margin < 0.0, sum(m == OPEN for m in s.modes), sum(m == SLIP for m in s.modes),
            -s.margin)


def _distinct(found: list[ContactForceSolution], ascale: float) -> list:
    """One solution per distinct acceleration (relative 1e-7), the best ranked kept."""
    groups: list[list[ContactForceSolution]] = []
    for s in found:
        for g in groups:
            if np.max(np.abs(g[0].acceleration - s.acceleration)) <= 1e-7 * ascale:
                g.append(s)
                break
        else:
            groups.append([s])
    return [min(g, key=_rank) for g in groups]


def planar_contact_force(W, b, mu: float, v_t: float,
                         rtol: float = RTOL) -> list[ContactForceSolution]:
    """Every solution for one planar contact, in closed form.

    With ``W = [[w_nn, w_nt], [w_nt, w_tt]]`` and ``b = (b_n, b_t)``:

    * open: ``lambda = 0``, valid when ``b_n >= 0``;
    * sliding (``v_t != 0``, ``s = sign v_t``): ``lambda_n = -b_n / A`` with the effective mass
      ``A = w_nn - mu s w_nt``, valid when ``lambda_n >= 0``;
    * at rest in t (``v_t = 0``): stick, ``lambda = -W^-1 b`` with ``|lambda_t| <= mu lambda_n``;
      or slip onset in direction ``s = +-1``: ``lambda_n = -b_n / A_s``, valid when
      ``lambda_n >= 0`` and ``a_t s = (w_tn - mu s w_tt) lambda_n s + b_t s >= 0``.
    """
    W = np.asarray(W, float)
    b = np.asarray(b, float)
    wnn, wnt, wtt = float(W[0, 0]), float(W[0, 1]), float(W[1, 1])
    bn, bt = float(b[0]), float(b[1])
    ascale = max(abs(bn), abs(bt), 1e-300 * max(wnn, 1.0))
    fscale = ascale / max(wnn, wtt, 1e-300)
    tol_a, tol_f = rtol * ascale, rtol * fscale
    found = []

    def add(ln, lt, mode, s, margin):
        a = (wnn * ln + wnt * lt + bn, wnt * ln + wtt * lt + bt)
        found.append(ContactForceSolution(
            force=np.array([[ln, lt]]), acceleration=np.array([a]), modes=(mode,),
            direction=np.array([[s]]), margin=margin / fscale))

    if bn >= -tol_a:
        add(0.0, 0.0, OPEN, 0.0, bn * fscale / ascale)
    signs = [1.0 if v_t > 0 else -1.0] if v_t != 0.0 else [1.0, -1.0]
    if mu == 0.0:
        signs = [0.0]  # frictionless: closed means a_n = 0, lambda_t = 0
    if v_t == 0.0 and mu > 0.0:
        det = wnn * wtt - wnt * wnt
        if det > 1e-13 * max(wnn * wtt, 1e-300):
            ln = (-bn * wtt + bt * wnt) / det
            lt = (-bt * wnn + bn * wnt) / det
            margin = min(mu * ln - abs(lt), ln)
            if margin >= -tol_f:
                add(ln, lt, STICK, 0.0, margin)
    for s in signs:
        A = wnn - mu * s * wnt
        if A == 0.0:
            continue
        ln = -bn / A
        if ln < -tol_f:
            continue
        lt = -mu * s * ln
        onset = v_t == 0.0 and mu > 0.0
        kappa = ((wnt * ln + wtt * lt + bt) * s) if onset else 0.0
        if onset and kappa < -tol_a:
            continue
        add(ln, lt, SLIP, s, min(ln, kappa * fscale / ascale) if onset else ln)
    found = [_label_frictionless([mu], [v_t != 0.0], f) for f in found]
    return _distinct(found, ascale)
