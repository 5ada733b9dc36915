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

The solver is exact: it enumerates the contacts' modes (open, stick, slip; planar onsets in
both directions); each combination is a linear system in ``lambda`` (for a spatial slip onset,
a one-parameter family in the slip angle, whose roots are bracketed on a scan and refined by
Brent's method), and a combination is a solution when its inequalities hold. Redundant
contacts (several rows of ``J`` dependent: a box on two corners sticking) leave the forces
indeterminate but the accelerations unique; where the least-norm solution violates an
inequality, :func:`max_margin_distribution` picks the distribution over the null space: the
largest smallest margin, then, among the distributions reaching it, the least norm (unique).
Distinct solutions are counted in accelerations: none or several with a sliding contact is
Painleve's paradox (:class:`~convimpact.impact.errors.PainleveError`).

For one planar contact :func:`planar_contact_force` gives the same answer in closed form.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from ..impact.errors import NotSupportedError, PainleveError, ShapeError, SolverError

OPEN, STICK, SLIP = "open", "stick", "slip"
#: largest number of closed contacts enumerated (4^n combinations in the plane)
MAX_CONTACTS = 7
#: slip angles scanned to bracket a spatial slip onset
SCAN = 144
#: default relative tolerance of the inequalities
RTOL = 1e-9
#: shortfall (relative to the force scale) below the largest smallest margin allowed to the
#: margins in the least-norm choice among redundant contacts' distributions
#: (max_margin_distribution: it keeps the program on the optimal face strictly feasible)
MARGIN_RTOL = 1e-10
#: rank tolerance (relative to the largest singular value) of the face's equations
FACE_RTOL = 1e-8
#: a cone of the max-min program whose slack and multiplier are both below this is
#: degenerate (active or not: both are tried)
DEGENERATE = 1e-5
#: tolerance (relative) of the optimality conditions a cone program's solution must meet
CERTIFY_RTOL = 1e-8


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

    def sliding(self, i: int) -> bool:
        return bool(np.any(self.slip[i] != 0.0))

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
    """

    force: np.ndarray
    acceleration: np.ndarray
    modes: tuple[str, ...]
    direction: np.ndarray
    margin: float


def _unit(v: np.ndarray) -> np.ndarray:
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 0.0 else np.zeros_like(v)


def _scales(P: ContactForceProblem) -> tuple[float, float]:
    """(acceleration scale, force scale) of the problem: the tolerances are relative to them."""
    diag = np.abs(np.diag(P.delassus))
    w = float(np.max(diag)) if diag.size and np.max(diag) > 0 else 1.0
    a = float(np.max(np.abs(P.free_acceleration)))
    a = a if a > 0.0 else w * 1e-300
    return a, a / w


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
            out.append(mu[i] * lam[n0] - float(np.linalg.norm(lam[n0 + 1:n0 + d])))
            out.append(lam[n0])
        else:
            out.append(lam[n0])
            if onset[i]:
                out.append(float(a[n0 + 1:n0 + d] @ dirs[i]) * to_force)
    return np.array(out)


def max_margin_distribution(mu: np.ndarray, d: int, combo, lam0: np.ndarray, Z: np.ndarray,
                            fscale: float) -> tuple[np.ndarray, float]:
    """The force distribution chosen among the indeterminate ones ``lam0 + Z xi``: the
    largest smallest margin, then, among the distributions reaching it, the least Euclidean
    norm. Unique for any data.

    Redundant contacts leave the forces statically indeterminate while the motion is not: a
    table on four legs has three equilibrium equations (vertical force, two moments) for four
    normal forces. ``lam0`` (n d,) is one distribution, the columns of ``Z`` span the
    indeterminate part, ``combo`` gives the contacts' modes; the margins are
    ``mu lambda_n - |lambda_t|`` (stick) and ``lambda_n`` (slip), none for open contacts.

    1. ``t* = max_xi min(margins)`` (capped at ``fscale``): the largest smallest margin any
       distribution reaches. It decides whether a group holds: a sticking group slips only
       when no distribution keeps every force in its cone. But maximizing a minimum is not
       strictly convex: the maximizers form a convex set F (a whole face when a margin binds
       without depending on every redundant direction, e.g. a determinate contact's), and
       which point of F an interior-point method returns depends on its iterates, hence on
       its version.
    2. The distribution returned is the one of least ``|lambda|`` in F: the projection of
       ``-lam0`` onto a closed convex set, so unique whatever the solver. Least norm (least
       squares) is the classic choice for a statically indeterminate support: it is the limit
       of equally stiff elastic supports (least complementary energy ``sum lambda_i^2 / 2 k``,
       Menabrea's theorem); for a box resting on four corners with its centre of mass over
       the middle it gives ``m g / 4`` per corner, and whenever the least-squares
       distribution itself reaches ``t*`` it is the one returned. Where F is a single point
       (the minimum has a kink there, e.g. a planar table at rest on three legs with its
       centre of mass off the middle leg: the legs' margins balanced) that point is
       returned: the margin comes first.

    F is found from the optimality conditions rather than as ``margins >= t* - tol``: such a
    shell, of width ~tol around F (a single point where the minimum has a kink), is too
    thin for an interior-point method (with tol = 1e-10, Clarabel 0.11.1 stopped short,
    ``InsufficientProgress`` or ``AlmostSolved``, on 53 of 117 such programs from a box
    sliding on four corners, and returned margins below the shell on others). Stage 1's
    solution is refined by Newton's method on its optimality conditions, the active cones
    fixed (:func:`_polish_max_min`: an interior-point solution meets them to about the square
    root of its tolerance only). By complementarity every maximizer keeps each active cone's
    slack where the refined one has it: zero, or on the same ray of the cone's boundary;
    these are linear equations whose solutions (an SVD, rank relative ``FACE_RTOL``) form
    the affine hull of F. If that is a point, it is the answer; otherwise stage 2 is the
    least-norm program on the hull with every margin ``>= t* - MARGIN_RTOL fscale``, no
    longer thin. The answer depends on the span of ``Z``
    only (an orthonormal basis of it is used) and moves by round-off when the data do.

    Each program's solution is accepted only with Clarabel's status ``Solved`` or
    ``AlmostSolved`` and its optimality conditions (primal and dual cone membership,
    stationarity, complementarity) holding to ``CERTIFY_RTOL``, evaluated here; the returned
    margin must be within ``RTOL`` (relative to the force scale and the distribution's size;
    ``CERTIFY_RTOL |t*|`` if larger) of ``t*``. Otherwise
    :class:`~convimpact.impact.errors.SolverError` is raised, never an unconverged
    distribution returned.

    Returns (lambda, margin): the distribution (n d,) and its smallest margin (force units;
    ``inf`` without stick or slip contacts).
    """
    lam0 = np.asarray(lam0, float).ravel()
    Z = np.asarray(Z, float).reshape(lam0.size, -1)
    mu = np.asarray(mu, float).ravel()
    scale = float(fscale)
    if not (np.isfinite(scale) and scale > 0.0):
        scale = max(float(np.max(np.abs(lam0), initial=0.0)), 1e-300)
    Q = _range_basis(Z)
    r = Q.shape[1]
    l0 = lam0 / scale  # unknowns in units of the force scale: order one
    blocks = _margin_blocks(mu, d, combo, l0, Q)
    if r == 0 or not blocks:  # determinate, or no margin to keep: the least norm
        lam = lam0 - Q @ (Q.T @ lam0)
        return lam, _smallest_margin(mu, d, combo, lam)
    # tau <= 1 (the force scale) keeps the max-min bounded: a margin of its own
    blocks.append(("nn", np.zeros((1, r)), np.ones(1), np.ones(1)))
    A = np.vstack([blk[1] for blk in blocks])
    b = np.concatenate([blk[2] for blk in blocks])
    w = np.concatenate([blk[3] for blk in blocks])
    cones = [(blk[0], len(blk[2])) for blk in blocks]
    # stage 1: max tau s.t. b - A y - tau w in the cones; unknowns (y, tau)
    x1, z1 = _solve_certified(np.zeros((r + 1, r + 1)), np.r_[np.zeros(r), -1.0],
                              np.hstack([A, w[:, None]]), b, cones, "largest smallest margin")
    # its optimality conditions solved to round-off on the active cones (Newton)
    y_star, t_star, kinds = _polish_max_min(blocks, x1, z1)
    t_star = min(t_star, _smallest_margin(mu, d, combo, l0 + Q @ y_star))
    # the affine hull of the optimal face: every maximizer keeps each active cone's slack
    # s = b - t* w - A y where it is (zero, or on the ray)
    rows_E, rows_e = [], []
    for (kind, Ab, bb, wb), how in zip(blocks, kinds):
        if how is not None:
            L = np.eye(len(bb)) if isinstance(how, str) else _off_ray(how)
            rows_E.append(L @ Ab)
            rows_e.append(L @ (bb - t_star * wb))
    rank, N = 0, np.eye(r)
    if rows_E:
        _, sv, Vt = np.linalg.svd(np.vstack(rows_E))
        rank = int(np.sum(sv > FACE_RTOL * sv[0])) if sv[0] > 0.0 else 0
        N = Vt[rank:].T
    if rank == r:  # the face is one point: the maximizer is unique
        y = y_star
    else:
        # stage 2: min |l0 + Q (y_base + N u)|^2 / 2 over the hull, the margins kept
        # >= t* - MARGIN_RTOL: on the hull an active cone's slack is constant (left out,
        # checked below) or moves along its ray (kept on the ray's forward half, s0 >= 0)
        y_base = y_star - N @ (N.T @ y_star)  # the hull's point nearest y = 0
        AN = A @ N
        AN[np.abs(AN) <= 1e-12 * max(1.0, float(np.max(np.abs(AN))))] = 0.0
        b2 = b - (t_star - MARGIN_RTOL) * w - A @ y_base
        free, k = [], 0
        for (kind, size), how in zip(cones, kinds):
            if np.any(AN[k:k + size] != 0.0):
                free.append((k, kind, size) if how is None else (k, "nn", 1))
            k += size
        g = N.T @ (Q.T @ l0)
        if free:
            sel = np.concatenate([np.arange(k0, k0 + size) for k0, _, size in free])
            u, _ = _solve_certified(np.eye(N.shape[1]), g, AN[sel], b2[sel],
                                    [(kind, size) for _, kind, size in free],
                                    "least-norm distribution")
        else:
            u = -g
        y = y_base + N @ u
    lam = lam0 + Q @ (y * scale)
    margin = _smallest_margin(mu, d, combo, lam)
    # the margin given up (MARGIN_RTOL in stage 2, round-off): at most RTOL near t* = 0,
    # where its sign decides hold or slip, CERTIFY_RTOL relative to |t*| elsewhere
    slack = max(RTOL, CERTIFY_RTOL * abs(t_star)) * (1.0 + float(np.max(np.abs(y))))
    if not margin >= (t_star - slack) * scale:
        raise SolverError(f"the force distribution of redundant contacts: margin {margin:.6e} "
                          f"below the largest one {t_star * scale:.6e}")
    return lam, margin


def _polish_max_min(blocks, x1: np.ndarray, z1: np.ndarray):
    """(y, t*, kinds): the max-min program's solution refined by Newton's method on its
    optimality conditions, given which cones are active (from the solver's solution).

    Per cone (slack s = b - A y - tau w, multiplier z): inactive (z = 0, kind None);
    active scalar or apex (s = 0, kind "zero"); on the boundary (s = alpha (1, u),
    z = beta (1, -u), |u| = 1, kind u). The conditions -sum A'z = 0, 1 - sum w'z = 0 and
    the cones' equations are square in (y, tau, z or alpha, beta, angle); an interior-point
    solution meets them to ~sqrt of its tolerance only (a smooth maximum, a ray's
    direction), Newton's method to round-off. A cone whose s and z are both ~0 (degenerate)
    is tried both ways; if Newton's method does not converge in the cones the solver's
    solution is kept."""
    r = x1.size - 1
    slacks, ambiguous, k = [], [], 0
    for j, (kind, Ab, bb, wb) in enumerate(blocks):
        zb = z1[k:k + len(bb)]
        sb = bb - Ab @ x1[:r] - x1[r] * wb
        k += len(bb)
        slacks.append((sb, zb))
        sn, zn = float(np.linalg.norm(sb[1:])), float(np.linalg.norm(zb[1:]))
        if max(zb[0] + zn, sb[0] - sn) < DEGENERATE:
            ambiguous.append(j)
    first = _active_cones(blocks, slacks, ())
    tried = [first] + ([_active_cones(blocks, slacks, ambiguous)] if ambiguous else [])
    for kinds, unknowns in tried:
        v = _newton_max_min(blocks, kinds, unknowns, x1)
        if v is not None:
            break
    else:
        kinds, unknowns = first
        v = np.concatenate([x1] + unknowns)
    out_kinds, k = [], r + 1
    for how, p in zip(kinds, unknowns):
        if how is None or isinstance(how, str):
            out_kinds.append(how)
        else:
            out_kinds.append(np.array([math.cos(v[k + 2]), math.sin(v[k + 2])]))
        k += p.size
    return v[:r], float(v[r]), out_kinds


def _active_cones(blocks, slacks, flip):
    """Each cone's kind (None, "zero" or a ray) and its initial unknowns: of each of the
    cone's complementary pairs of eigenvalues (s0 -+ |s1|, z0 +- |z1|) one member is ~0 at
    the optimum, the larger member tells which (the cones in flip: the other way)."""
    kinds, unknowns = [], []
    for j, ((kind, Ab, bb, wb), (sb, zb)) in enumerate(zip(blocks, slacks)):
        sn, zn = float(np.linalg.norm(sb[1:])), float(np.linalg.norm(zb[1:]))
        inactive = (zb[0] + zn <= sb[0] - sn) != (j in flip)
        if inactive:  # z = 0
            kinds.append(None)
            unknowns.append(np.zeros(0))
        elif kind == "nn" or zb[0] - zn > sb[0] + sn:  # s = 0 (for a cone: its apex)
            kinds.append("zero")
            unknowns.append(np.maximum(zb, 0.0) if kind == "nn" else zb.copy())
        else:  # s and z on opposite rays of the boundary
            u = sb[1:] / sn if sn > zn else -zb[1:] / max(zn, 1e-300)
            kinds.append(("ray", len(zb)))
            unknowns.append(np.r_[0.5 * (sb[0] + sn), 0.5 * (zb[0] + zn),
                                  math.atan2(u[1], u[0])])
    return kinds, unknowns


def _newton_max_min(blocks, kinds, unknowns, x1: np.ndarray):
    """Newton's method (least-squares steps) on the max-min optimality conditions with the
    cones' kinds fixed; the solution vector (y, tau, unknowns), or None when it does not
    converge to 1e-12 or leaves a cone."""
    r = x1.size - 1
    sizes = [p.size for p in unknowns]

    def parts(v):
        out, k = [], r + 1
        for n in sizes:
            out.append(v[k:k + n])
            k += n
        return out

    def residual(v):
        y, tau = v[:r], v[r]
        stat = np.zeros(r + 1)
        stat[r] = 1.0
        J_stat = np.zeros((r + 1, v.size))
        eqs, J_eqs, k = [], [], r + 1
        for (kind, Ab, bb, wb), how, p in zip(blocks, kinds, parts(v)):
            n = p.size
            if how is None:
                continue
            s = bb - Ab @ y - tau * wb
            Js = np.zeros((len(bb), v.size))
            Js[:, :r] = -Ab
            Js[:, r] = -wb
            Aw = np.hstack([Ab, wb[:, None]])  # the stationarity's -d/dz
            if how == "zero":
                zb = p
                J_stat[:, k:k + n] = -Aw.T
                eqs.append(s)
            else:
                alpha, beta, phi = p
                c, sn = math.cos(phi), math.sin(phi)
                ray, dray = np.array([1.0, c, sn]), np.array([0.0, -sn, c])
                zdir, dzdir = np.array([1.0, -c, -sn]), np.array([0.0, sn, -c])
                zb = beta * zdir
                J_stat[:, k + 1] = -Aw.T @ zdir
                J_stat[:, k + 2] = -Aw.T @ (beta * dzdir)
                eqs.append(s - alpha * ray)
                Js[:, k] = -ray
                Js[:, k + 2] = -alpha * dray
            stat = stat - Aw.T @ zb
            J_eqs.append(Js)
            k += n
        return np.concatenate([stat] + eqs), np.vstack([J_stat] + J_eqs)

    v = np.concatenate([x1] + unknowns)
    best, best_norm = v, float(np.max(np.abs(residual(v)[0])))
    for _ in range(30):
        F, J = residual(v)
        # least-squares steps, small singular values cut: along a face of maximizers the
        # conditions are singular, and the step stays near the solver's point
        step = np.linalg.lstsq(J, F, rcond=1e-10)[0]
        v = v - step
        norm = float(np.max(np.abs(residual(v)[0])))
        if norm < best_norm:
            best, best_norm = v, norm
        if norm <= 1e-15 or float(np.max(np.abs(step))) <= 1e-16:
            break
    if not best_norm <= 1e-12:
        return None
    y, tau = best[:r], best[r]
    for (kind, Ab, bb, wb), how, p in zip(blocks, kinds, parts(best)):
        s = bb - Ab @ y - tau * wb
        if how is None:
            viol = _cone_violation(s, [(kind, len(bb))])
        elif how == "zero":
            viol = _cone_violation(p, [(kind, len(bb))])
        else:
            viol = max(-p[0], -p[1])
        if viol > 1e-12:
            return None
    return best


def _off_ray(u: np.ndarray) -> np.ndarray:
    """Rows L with L s = 0 exactly when s (in R^3) lies on the ray through (1, u): the
    component of s's tangential part across u, and s0 - u . s1."""
    return np.array([[0.0, -u[1], u[0]], [1.0, -u[0], -u[1]]])


def _range_basis(Z: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the span of Z's columns (rank relative 1e-10; entries below
    1e-13 set to zero)."""
    if Z.size == 0:
        return np.zeros((Z.shape[0], 0))
    U, sv, _ = np.linalg.svd(Z, full_matrices=False)
    rank = int(np.sum(sv > 1e-10 * sv[0])) if sv[0] > 0.0 else 0
    Q = U[:, :rank]
    # entries at round-off are zeros (a contact outside the redundancy): left in, they make
    # rows of size 1e-16 that the solver's equilibration blows up
    return np.where(np.abs(Q) > 1e-13, Q, 0.0)


def _margin_blocks(mu, d: int, combo, l0: np.ndarray, Q: np.ndarray) -> list:
    """Per margin the cone constraint ``b - A y - floor w in K`` stating it is ``>= floor``
    at ``l0 + Q y``: (kind, A, b, w), kind "nn" (one nonnegative row) or "soc".

    Slip: ``lambda_n``. Planar stick: ``mu lambda_n - lambda_t`` and ``mu lambda_n +
    lambda_t``, two half-planes (the two-dimensional cone, kept polyhedral for the solver).
    Spatial stick: ``(mu lambda_n, lambda_t)`` in the second-order cone."""
    out = []
    for i, mode in enumerate(combo):
        n0 = i * d
        if mode == SLIP:
            out.append(("nn", -Q[n0:n0 + 1], l0[n0:n0 + 1].copy(), np.ones(1)))
        elif mode == STICK and d == 2:
            for sign in (1.0, -1.0):
                out.append(("nn", -(mu[i] * Q[n0:n0 + 1] + sign * Q[n0 + 1:n0 + 2]),
                            np.array([mu[i] * l0[n0] + sign * l0[n0 + 1]]), np.ones(1)))
        elif mode == STICK:
            A = -Q[n0:n0 + d].copy()
            A[0] *= mu[i]
            out.append(("soc", A, np.r_[mu[i] * l0[n0], l0[n0 + 1:n0 + d]],
                        np.r_[1.0, np.zeros(d - 1)]))
    return out


def _smallest_margin(mu, d: int, combo, lam: np.ndarray) -> float:
    """The smallest of the stick (mu lambda_n - |lambda_t|) and slip (lambda_n) margins."""
    out = np.inf
    for i, mode in enumerate(combo):
        n0 = i * d
        if mode == SLIP:
            out = min(out, float(lam[n0]))
        elif mode == STICK:
            out = min(out, mu[i] * float(lam[n0]) - float(np.linalg.norm(lam[n0 + 1:n0 + d])))
    return out


def _cone_violation(v: np.ndarray, cones) -> float:
    """How far v lies outside the product of cones (0 inside)."""
    worst, k = 0.0, 0
    for kind, size in cones:
        part = v[k:k + size]
        k += size
        if kind == "nn":
            worst = max(worst, float(np.max(-part, initial=0.0)))
        else:
            worst = max(worst, float(np.linalg.norm(part[1:]) - part[0]))
    return worst


def _solve_certified(P: np.ndarray, q: np.ndarray, A: np.ndarray, b: np.ndarray, cones,
                     what: str) -> np.ndarray:
    """(x, z): argmin x'Px/2 + q'x s.t. b - A x in the cones, and the multipliers, by
    Clarabel. Returned only when the
    status is Solved or AlmostSolved and the optimality conditions hold to CERTIFY_RTOL
    (evaluated here, not taken from the solver): s = b - A x and the multipliers z in their
    (self-dual) cones, P x + q + A'z = 0 and s'z = 0."""
    import clarabel
    import scipy.sparse as sp

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-11
    kinds = {"nn": clarabel.NonnegativeConeT, "soc": clarabel.SecondOrderConeT}
    solver = clarabel.DefaultSolver(sp.triu(sp.csc_matrix(P), format="csc"), q,
                                    sp.csc_matrix(A), b, [kinds[k](n) for k, n in cones],
                                    settings)
    sol = solver.solve()
    status = str(sol.status)
    if status not in ("Solved", "AlmostSolved"):
        raise SolverError(f"the force distribution of redundant contacts ({what}): Clarabel "
                          f"{status}")
    x, z = np.asarray(sol.x, float), np.asarray(sol.z, float)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(z))):
        raise SolverError(f"the force distribution of redundant contacts ({what}): Clarabel "
                          f"{status} with a non-finite solution")
    s = b - A @ x
    Px, Az = P @ x, A.T @ z

    def big(*vs):
        return 1.0 + max(float(np.max(np.abs(v), initial=0.0)) for v in vs)

    # each residual relative to the size of its terms (as the solver's own criteria)
    residuals = {"primal cone": _cone_violation(s, cones) / big(b, A @ x),
                 "dual cone": _cone_violation(z, cones) / big(z),
                 "stationarity": float(np.max(np.abs(Px + q + Az))) / big(Px, q, Az),
                 "complementarity": abs(float(s @ z)) / big(0.5 * float(x @ Px) + float(q @ x),
                                                           float(b @ z))}
    bad = {k: v for k, v in residuals.items() if not v <= CERTIFY_RTOL}
    if bad:
        raise SolverError(f"the force distribution of redundant contacts ({what}): Clarabel "
                          f"{status}, but its optimality conditions fail: {bad}")
    return x, z


def _candidate(P: ContactForceProblem, combo, dirs, onset, rtol: float):
    """The solution of one combination with given directions, or None."""
    ascale, fscale = _scales(P)
    E, r = _system(P, combo, dirs)
    solved = _solve(E, r, 1e-9 * max(ascale, float(np.max(np.abs(E))) * fscale))
    if solved is None:
        return None
    lam, Z = solved
    slack = _slacks(P, combo, dirs, lam, onset)
    margin = float(np.min(slack, initial=np.inf))
    if margin < -rtol * fscale and Z.shape[1] and any(m != OPEN for m in combo):
        lam, margin = max_margin_distribution(P.mu, P.d, combo, lam, Z, fscale)
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
            f"at once, got {n}; use simulate_with(scheme='moreau-jean') for larger contact sets")
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


def _rank(s: ContactForceSolution) -> tuple[int, int, float]:
    return (sum(m == OPEN for m in s.modes), sum(m == SLIP for m in s.modes), -s.margin)


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


def solve_contact_forces(P: ContactForceProblem, rtol: float = RTOL) -> ContactForceSolution:
    """The unique solution of the force problem (one planar contact: the closed form).

    Raises
    ------
    PainleveError
        No solution (inconsistent) or several (indeterminate): Painleve's paradox.
    """
    if P.n == 1 and P.d == 2:
        sols = planar_contact_force(P.delassus, P.free_acceleration, float(P.mu[0]),
                                    float(P.slip[0, 0]), rtol)
    else:
        sols = force_solutions(P, rtol)
    if len(sols) == 1:
        return sols[0]
    kind = "inconsistent" if not sols else "indeterminate"
    exc = PainleveError(
        f"Painleve's paradox: the contact force problem is {kind} ({len(sols)} solutions); "
        "effective normal masses in the slip direction "
        f"{np.round(P.effective_normal_mass(), 6).tolist()} (<= 0 is the paradox)")
    exc.kind, exc.n_solutions = kind, len(sols)
    raise exc


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
