"""The distribution of the forces among redundant contacts: unique by construction.

Redundant contacts (several rows of the contact Jacobian dependent: a box on two corners
sticking, a table on four legs) leave the forces of the sustained-contact problem statically
indeterminate, ``lam0 + Z xi``, while its accelerations are unique. Where the least-norm
distribution violates an inequality of the contacts' modes, :func:`max_margin_distribution`
picks one in two stages: the largest smallest margin t* (a cone program by Clarabel, its
solution refined by Newton's method on the optimality conditions, the active cones fixed),
then the least norm among the distributions whose margins all reach :func:`shell_floor`
(t*), just below t* (a strictly convex program, solved the same way, from the
unconstrained minimizer first, the solver's answer where that does not certify): unique, and
continuous in the data (a 1e-13 change of the state moves it by round-off). Every
program's solution is certified here (cone membership, stationarity, complementarity)
before it is accepted.

The contacts' modes and the default tolerance of the inequalities are defined here, in the
lower of the two modules that use them; :mod:`~convimpact.simulation.contact_forces` (the
force problem, which calls this one) hands them on.
"""

from __future__ import annotations

import numpy as np

from ..errors import SolverError
from .force_cold_start import cold_max_min, optimality_residuals
from .force_distribution_polish import (_off_ray, _polish_least_norm, _polish_max_min,
                                         _warm_max_min)
from .force_dual import refusal_bound

OPEN, STICK, SLIP = "open", "stick", "slip"
#: default relative tolerance of the inequalities
RTOL = 1e-9
#: shortfall (relative to the force scale) below the largest smallest margin allowed to the
#: margins in the least-norm choice among redundant contacts' distributions
#: (:func:`shell_floor`: it gives stage 2's program an interior; with 1e-10 the choice lay
#: 1.4e-9 of the force scale from the least-norm maximizer of a planar table whose
#: maximizer is one point, with 1e-12 1.4e-11)
MARGIN_RTOL = 1e-12
#: rank tolerance (relative to the largest singular value) of the face's equations
FACE_RTOL = 1e-8
#: tolerance (relative) of the optimality conditions a cone program's solution must meet
CERTIFY_RTOL = 1e-8
#: margin (relative to the force scale) by which stage 1's largest smallest margin must lie
#: below ``below`` for max_margin_distribution to skip stage 2 (polished, it is exact to
#: ~1e-12; unpolished, the solver's optimum is within its duality-gap tolerance, 1e-11)
BELOW_GUARD = 1e-9
#: the same for the solver's own largest smallest margin, unpolished, where its status is
#: "Solved" (its tolerances 1e-11)
SOLVED_GUARD = 1e-8
#: active sets a margin-only call's warm start tries (the last program's, then earlier ones)
WARM_SETS = 4


def max_margin_distribution(mu: np.ndarray, d: int, combo, lam0: np.ndarray, Z: np.ndarray,
                            fscale: float, below: float | None = None,
                            warm: dict | None = None,
                            orthonormal: bool = False) -> tuple[np.ndarray, float]:
    """The force distribution chosen among the indeterminate ones ``lam0 + Z xi``: the
    largest smallest margin ``t*``, then, among the distributions whose every margin is at
    least :func:`shell_floor` (t*) ``= t* - MARGIN_RTOL`` (1e-12 of the force scale below
    ``t*``), the least Euclidean norm. Unique for any data, and continuous in them.

    Redundant contacts leave the forces statically indeterminate while the motion is not: a
    table on four legs has three equilibrium equations (vertical force, two moments) for four
    normal forces. ``lam0`` (n d,) is one distribution, the columns of ``Z`` span the
    indeterminate part, ``combo`` gives the contacts' modes; the margins are
    ``mu lambda_n - |lambda_t|`` (stick) and ``lambda_n`` (slip), none for open contacts.

    1. ``t* = max_xi min(margins)`` (capped at ``fscale``): the largest smallest margin any
       distribution reaches. It decides whether a group holds: a sticking group slips only
       when no distribution keeps every force in its cone. Maximizing a minimum is not
       strictly convex: the maximizers form a convex set F, which point of it an
       interior-point method returns depends on its iterates, and F itself changes its
       dimension under round-off where margins of different groups tie at ``t*`` (the box
       stack past its tip instant: the middle box's back corners and the top box's four
       corners all at 0.02 of the force scale; by the scene's numbers), so the least-norm
       point of F can jump (by 0.06-0.23 N of 14.7 N there, from a 1e-13 change of the
       state).
    2. The distribution returned is the least-norm one in the shell S = {every margin >=
       t* - MARGIN_RTOL}: the projection of ``-lam0`` onto a closed convex set with
       interior (a maximizer keeps MARGIN_RTOL of slack), unique whatever the solver, and
       moving by O(round-off) when the data do (the floor is continuous in ``t*``, which is
       continuous in the data; where the margins are linear in the forces, as for planar
       contacts, Hoffman's bound makes the move Lipschitz whatever the shell's width).
       Least norm (least squares) is the classic choice for a statically
       indeterminate support: the limit of equally stiff elastic supports (least
       complementary energy ``sum lambda_i^2 / 2 k``, Menabrea's theorem); for a box resting
       on four corners with its centre of mass over the middle it gives ``m g / 4`` per
       corner, and whenever the least-squares distribution itself lies in S it is the one
       returned. Its distance from the least-norm point of F is of the order of the shell's
       width (1.4e-11 of the force scale for a planar table on three legs whose F is one
       point, ``m g (5/18, 5/18, 4/9)``); the margin comes first.

    Stage 1 is solved by a compiled primal-dual interior-point method from a cold start
    and refined by Newton's method on its optimality conditions, the active cones fixed,
    which certifies it (:func:`~.force_cold_start.cold_max_min`; where that polish does
    not converge, the interior point is taken on the optimality residuals a solver's
    answer is held to); where neither certifies, by Clarabel, its solution refined the
    same way (:func:`_polish_max_min`: an
    interior-point solution meets the conditions to about the square root of its
    tolerance only). Stage 2 is solved by Newton's method on
    its optimality conditions (:func:`_polish_least_norm`: a primal-dual active set, cones
    whose equations depend on the others' left out, a multiplier of the wrong sign or a
    violated cone correcting the set), certified there to round-off, from the unconstrained
    minimizer (the cones it violates active), else from Clarabel's solution on S
    (:func:`_least_norm_in_shell`). Where that polish does not certify, the former
    stage 2 is used (:func:`_least_norm_on_face`: the least-norm program on the affine hull
    of F read off stage 1's active cones), exact where that active set is, but not
    continuous where it is degenerate. The answer depends on the span of ``Z`` only (an
    orthonormal basis of it is used).

    Each program's solution is accepted only with its optimality conditions (primal and
    dual cone membership, stationarity, complementarity) holding, evaluated here: to
    ``CERTIFY_RTOL`` for Clarabel's (with its status ``Solved`` or ``AlmostSolved``) and an
    unpolished interior point's, to
    1e-12 for stage 2's polished one; the returned
    margin must be within ``RTOL`` (relative to the force scale and the distribution's size;
    ``CERTIFY_RTOL |t*|`` if larger) of the floor. Otherwise
    :class:`~convimpact.errors.SolverError` is raised, never an unconverged
    distribution returned.

    ``below`` (force units, optional): where the largest smallest margin is below it (by
    :data:`BELOW_GUARD` of the force scale when finite; ``inf``: always) the caller needs
    the margin only: stage 2 is skipped and the maximizer of stage 1 returned with its
    margin (one of the maximizers: not the unique choice). The mode selection rejects a
    combination so (its margin clearly negative), the event functions locate the margin's
    zero so (a margin is all they ask for).

    ``warm`` (a dict the caller keeps between programs of one set of contacts and modes,
    e.g. over a segment): the last program's active set and maximizer are kept there, and
    a margin-only call (``below=inf``) first tries Newton's method on the optimality
    conditions at that active set (:func:`_warm_max_min`), the solver only where it fails;
    with a finite ``below`` (a refusal), a largest margin certified so below ``below`` (by
    :data:`BELOW_GUARD`) is returned without the solver (the mode selection at the event a
    held group's margin crossing located, from the located margin's active set); where
    Newton's method fails there, a dual point from those active sets may still bound the
    largest margin below ``below`` (weak duality, :func:`~.force_dual.refusal_bound`): then
    ``lam0`` is returned with its own margin (below the bound), without the solver.

    ``orthonormal``: the columns of ``Z`` are orthonormal already (a basis from an SVD or
    a QR of full rank), used as they are (their round-off entries zeroed, as
    :func:`_range_basis` does) instead of an SVD of them.

    Returns (lambda, margin): the distribution (n d,) and its smallest margin (force units;
    ``inf`` without stick or slip contacts).
    """
    lam0 = np.asarray(lam0, float).ravel()
    Z = np.asarray(Z, float).reshape(lam0.size, -1)
    mu = np.asarray(mu, float).ravel()
    scale = float(fscale)
    if not (np.isfinite(scale) and scale > 0.0):
        scale = max(float(np.max(np.abs(lam0), initial=0.0)), 1e-300)
    Q = _zero_round_off(Z) if orthonormal else _range_basis(Z)
    r = Q.shape[1]
    l0 = lam0 / scale  # unknowns in units of the force scale: order one
    blocks = _margin_blocks(mu, d, combo, l0, Q)
    if r == 0 or not blocks:  # determinate, or no margin to keep: the least norm
        lam = lam0 - Q @ (Q.T @ lam0)
        return lam, _smallest_margin(mu, d, combo, lam)
    # tau <= 1 (the force scale) keeps the max-min bounded: a margin of its own
    blocks.append(("nn", np.zeros((1, r)), np.ones(1), np.ones(1)))
    if warm is not None and below is not None and not np.isfinite(below) and below > 0.0:
        got = _warm_tries(blocks, warm, lam0, Q, scale)
        if got is not None:  # the margin alone, at a recent program's active set
            y_star, t_star = got
            lam = lam0 + Q @ (y_star * scale)
            warm["lam"], warm["tau"] = lam, t_star
            return lam, _smallest_margin(mu, d, combo, lam)
    elif warm is not None and below is not None and np.isfinite(below):
        got = _warm_tries(blocks, warm, lam0, Q, scale)
        if got is not None and got[1] * scale < below - BELOW_GUARD * scale:
            # certified below (the optimality conditions at a nearby program's active
            # set: the polished solver's t*, without the solver)
            lam = lam0 + Q @ (got[0] * scale)
            return lam, _smallest_margin(mu, d, combo, lam)
        bound = (refusal_bound(blocks, warm, below / scale - BELOW_GUARD) if got is None
                 else None)
        if bound is not None and bound * scale < below - BELOW_GUARD * scale:
            # certified below by weak duality (a dual point from those active sets): no
            # distribution reaches ``below``; lam0's own margin is below it too
            return lam0, _smallest_margin(mu, d, combo, lam0)
    A = np.vstack([blk[1] for blk in blocks])
    b = np.concatenate([blk[2] for blk in blocks])
    w = np.concatenate([blk[3] for blk in blocks])
    cones = [(blk[0], len(blk[2])) for blk in blocks]
    # stage 1: max tau s.t. b - A y - tau w in the cones; unknowns (y, tau)
    q1 = np.zeros(r + 1)
    q1[r] = -1.0
    # a compiled interior-point solve polished and certified on the optimality conditions
    # (:func:`~.force_cold_start.cold_max_min`); Clarabel only where that does not certify
    stage1 = cold_max_min(blocks, CERTIFY_RTOL)
    if stage1 is None:
        x1, z1, status = _solve_certified(np.zeros((r + 1, r + 1)), q1,
                                          np.hstack([A, w[:, None]]), b, cones,
                                          "largest smallest margin")
        if (below is not None and np.isfinite(below) and status == "Solved"
                and x1[r] * scale < below - SOLVED_GUARD * scale):
            # clearly below: the margin is all the caller needs (Clarabel's "Solved" holds
            # its duality gap and residuals to 1e-11, far inside the guard), no polish
            lam = lam0 + Q @ (x1[:r] * scale)
            return lam, min(x1[r] * scale, _smallest_margin(mu, d, combo, lam))
        # its optimality conditions solved to round-off on the active cones (Newton)
        stage1 = _polish_max_min(blocks, x1, z1)
    y_star, t_star, kinds, active = stage1
    if warm is not None:
        _keep_earlier(warm)
        warm["active"] = active
        warm["lam"], warm["tau"] = lam0 + Q @ (y_star * scale), t_star
    t_star = min(t_star, _smallest_margin(mu, d, combo, l0 + Q @ y_star))
    if below is not None and (t_star * scale < below - BELOW_GUARD * scale
                              if np.isfinite(below) else below > 0.0):
        lam = lam0 + Q @ (y_star * scale)
        return lam, _smallest_margin(mu, d, combo, lam)
    # stage 2: min |l0 + Q y|^2 / 2 (= |y|^2 / 2 + g'y + const, Q orthonormal) over the
    # whole space with every margin >= shell_floor(t*): a strictly convex program on a set
    # with interior (the maximizer keeps t* - floor of slack), its solution polished to
    # round-off on its optimality conditions
    floor = shell_floor(t_star)
    shell = [(kind, Ab, bb - floor * wb, wb) for kind, Ab, bb, wb in blocks[:-1]]
    g = Q.T @ l0
    y = _least_norm_in_shell(shell, g)
    if y is None:  # (not certified: the program on the optimal face's hull)
        y = _least_norm_on_face(blocks, kinds, t_star, y_star, A, b, w, cones, g, r)
    lam = lam0 + Q @ (y * scale)
    margin = _smallest_margin(mu, d, combo, lam)
    # the margin given up (MARGIN_RTOL in stage 2, round-off): at most RTOL near t* = 0,
    # where its sign decides hold or slip, CERTIFY_RTOL relative to |t*| elsewhere
    slack = max(RTOL, CERTIFY_RTOL * abs(t_star)) * (1.0 + float(np.max(np.abs(y))))
    # (a negative largest margin: no distribution fits the modes, which the callers reject
    # on the margin returned; its last digits do not matter)
    if not margin >= (floor - slack) * scale and t_star >= -RTOL:
        raise SolverError(f"the force distribution of redundant contacts: margin {margin:.6e} "
                          f"below the largest one {t_star * scale:.6e}")
    return lam, margin


def shell_floor(t_star: float) -> float:
    """The smallest margin (relative to the force scale) the distribution chosen among
    redundant contacts' may have (:func:`max_margin_distribution`, stage 2), given the
    largest smallest margin ``t*``: ``t* - MARGIN_RTOL`` (continuous in ``t*``, so the set
    of admissible distributions moves continuously with the data)."""
    return t_star - MARGIN_RTOL


def _least_norm_on_face(blocks, kinds, t_star: float, y_star: np.ndarray, A, b, w, cones,
                        g: np.ndarray, r: int) -> np.ndarray:
    """The former stage 2 (the fallback of :func:`_least_norm_in_shell`): the least-norm
    program on the affine hull of the optimal face read off stage 1's active cones (every
    maximizer keeps each active cone's slack where the polished one has it), the margins
    kept >= t* - MARGIN_RTOL. Exact where the active set is; where it is degenerate the
    hull can change with round-off in the data."""
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
        gN = N.T @ g
        if free:
            sel = np.concatenate([np.arange(k0, k0 + size) for k0, _, size in free])
            u, _, _ = _solve_certified(np.eye(N.shape[1]), gN, AN[sel], b2[sel],
                                    [(kind, size) for _, kind, size in free],
                                    "least-norm distribution")
        else:
            u = -gN
        y = y_base + N @ u
    return y


def _least_norm_in_shell(shell, g: np.ndarray) -> np.ndarray | None:
    """argmin |y|^2 / 2 + g'y s.t. ``b - A y`` in each block's cone
    (:func:`max_margin_distribution`'s stage 2), by :func:`_polish_least_norm` (a
    primal-dual active-set method, certified to round-off on the program's optimality
    conditions) first from the unconstrained minimizer ``-g`` (no multiplier: the cones it
    violates start active), then from Clarabel's solution (from which status soever: a
    shell as thin as 1e-10 often ends "AlmostSolved"); None where neither certifies. The
    program is strictly convex: a certified answer is its unique minimizer, whichever the
    start (the box stack's tip and slip onset: both starts certify, 3e-16 apart; the
    solver is not run)."""
    y = _polish_least_norm(shell, g, -g, np.zeros(sum(len(blk[2]) for blk in shell)))
    if y is not None:
        return y
    A = np.vstack([blk[1] for blk in shell])
    b = np.concatenate([blk[2] for blk in shell])
    cones = [(blk[0], len(blk[2])) for blk in shell]
    r = g.size
    x, z, _ = _solve_raw(np.eye(r), g, A, b, cones)
    if x is None:
        return None
    return _polish_least_norm(shell, g, x, z)


def _warm_tries(blocks, warm: dict, lam0: np.ndarray, Q: np.ndarray, scale: float):
    """:func:`_warm_max_min` at the last program's active set, then at the earlier ones
    kept (:data:`WARM_SETS` in all, the latest first; the one that holds becomes the
    last): locating a margin's zero, the evaluations alternate between the two sides of
    the root and between regions of the step where different cones bind, so the active set
    of the evaluation before is often not this one's while an earlier one is. (Each is a
    certified optimum, whichever active set it came from: :func:`_warm_max_min`.)"""
    got = _warm_max_min(blocks, warm, lam0, Q, scale)
    if got is not None:
        return got
    earlier = warm.get("earlier", [])
    for j, (active, lam, tau) in enumerate(earlier):
        trial = {"active": active, "lam": lam, "tau": tau}
        got = _warm_max_min(blocks, trial, lam0, Q, scale)
        if got is not None:
            del earlier[j]
            _keep_earlier(warm)
            warm["active"] = trial["active"]
            return got
    return None


def _keep_earlier(warm: dict) -> None:
    """Move the warm start's last active set (with its maximizer) to the front of its
    earlier ones (:data:`WARM_SETS` - 1 kept)."""
    if warm.get("active") is None or warm.get("lam") is None:
        return
    earlier = warm.setdefault("earlier", [])
    earlier.insert(0, (warm["active"], warm["lam"], warm["tau"]))
    del earlier[WARM_SETS - 1:]


def _range_basis(Z: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the span of Z's columns (rank relative 1e-10; entries below
    1e-13 set to zero)."""
    if Z.size == 0:
        return np.zeros((Z.shape[0], 0))
    U, sv, _ = np.linalg.svd(Z, full_matrices=False)
    rank = int(np.sum(sv > 1e-10 * sv[0])) if sv[0] > 0.0 else 0
    return _zero_round_off(U[:, :rank])


def _zero_round_off(Q: np.ndarray) -> np.ndarray:
    """An orthonormal basis with its entries at round-off (below 1e-13) set to zero: they
    are zeros (a contact outside the redundancy); left in, they make rows of size 1e-16
    that the solver's equilibration blows up."""
    return np.where(np.abs(Q) > 1e-13, Q, 0.0)


def _margin_blocks(mu, d: int, combo, l0: np.ndarray, Q: np.ndarray) -> list:
    """Per margin the cone constraint ``b - A y - floor w in K`` stating it is ``>= floor``
    at ``l0 + Q y``: (kind, A, b, w), kind "nn" (one nonnegative row) or "soc".

    Slip: ``lambda_n``. Planar stick: ``mu lambda_n - lambda_t`` and ``mu lambda_n +
    lambda_t``, two half-planes (the two-dimensional cone, kept polyhedral for the solver).
    Spatial stick: ``(mu lambda_n, lambda_t)`` in the second-order cone."""
    n = len(combo)
    if d == 3 and n and all(mode in (STICK, SLIP) for mode in combo):
        # (spatial, no open contact: every block a slice of the scaled forces, at once)
        mu_n = np.where(np.array([mode == STICK for mode in combo]), mu[:n], 1.0)
        A_all = -Q[:n * d].reshape(n, d, -1)
        A_all[:, 0] *= mu_n[:, None]
        b_all = l0[:n * d].reshape(n, d).copy()
        b_all[:, 0] *= mu_n
        soc_w = np.array([1.0, 0.0, 0.0])
        one = np.ones(1)
        return [("nn", A_all[i, :1], b_all[i, :1], one) if mode == SLIP
                else ("soc", A_all[i], b_all[i], soc_w) for i, mode in enumerate(combo)]
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
            b = l0[n0:n0 + d].copy()
            b[0] *= mu[i]
            w = np.zeros(d)
            w[0] = 1.0
            out.append(("soc", A, b, w))
    return out


def _smallest_margin(mu, d: int, combo, lam: np.ndarray) -> float:
    """The smallest of the stick (mu lambda_n - |lambda_t|) and slip (lambda_n) margins."""
    F = np.asarray(lam, float).reshape(-1, d)
    slip = np.fromiter((mode == SLIP for mode in combo), bool, len(combo))
    stick = np.fromiter((mode == STICK for mode in combo), bool, len(combo))
    out = float(np.min(F[slip, 0])) if slip.any() else np.inf
    if stick.any():
        T = F[stick, 1:]
        out = min(out, float(np.min(np.asarray(mu, float)[stick] * F[stick, 0]
                                    - np.sqrt(np.einsum("ij,ij->i", T, T)))))
    return out


def _csc(M: np.ndarray):
    """The CSC matrix of the dense M's nonzero entries (as ``scipy.sparse.csc_matrix(M)``,
    the same entries and pattern, built directly: the generic conversion cost more than
    the small programs' solves)."""
    import scipy.sparse as sp

    M = np.asarray(M, dtype=float)
    cols, rows = np.nonzero(M.T)  # column by column, rows ascending
    indptr = np.zeros(M.shape[1] + 1, dtype=np.int32)
    np.cumsum(np.bincount(cols, minlength=M.shape[1]), out=indptr[1:])
    return sp.csc_matrix((M[rows, cols], rows.astype(np.int32), indptr), shape=M.shape)


def _clarabel(P, q, A, b, cones):
    """Clarabel's solution of argmin x'Px/2 + q'x s.t. b - A x in the cones (tolerances
    1e-11), whatever its status."""
    import clarabel

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-11
    kinds = {"nn": clarabel.NonnegativeConeT, "soc": clarabel.SecondOrderConeT}
    solver = clarabel.DefaultSolver(_csc(np.triu(P)), q, _csc(A), b,
                                    [kinds[k](n) for k, n in cones], settings)
    return solver.solve()


def _solve_raw(P, q, A, b, cones):
    """(x, z, status) of Clarabel on argmin x'Px/2 + q'x s.t. b - A x in the cones, whatever
    its status (None's where not finite): a starting point for a polish that certifies."""
    sol = _clarabel(P, q, A, b, cones)
    x, z = np.asarray(sol.x, float), np.asarray(sol.z, float)
    if x.size != q.size or not (np.all(np.isfinite(x)) and np.all(np.isfinite(z))):
        return None, None, str(sol.status)
    return x, z, str(sol.status)


def _solve_certified(P: np.ndarray, q: np.ndarray, A: np.ndarray, b: np.ndarray, cones,
                     what: str) -> tuple[np.ndarray, np.ndarray, str]:
    """(x, z, status): argmin x'Px/2 + q'x s.t. b - A x in the cones, and the multipliers, by
    Clarabel. Returned only when the
    status is Solved or AlmostSolved and the optimality conditions hold to CERTIFY_RTOL
    (evaluated here, not taken from the solver): s = b - A x and the multipliers z in their
    (self-dual) cones, P x + q + A'z = 0 and s'z = 0."""
    sol = _clarabel(P, q, A, b, cones)
    status = str(sol.status)
    if status not in ("Solved", "AlmostSolved"):
        raise SolverError(f"the force distribution of redundant contacts ({what}): Clarabel "
                          f"{status}")
    x, z = np.asarray(sol.x, float), np.asarray(sol.z, float)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(z))):
        raise SolverError(f"the force distribution of redundant contacts ({what}): Clarabel "
                          f"{status} with a non-finite solution")
    residuals = optimality_residuals(P, q, A, b, cones, x, z)
    bad = {k: v for k, v in residuals.items() if not v <= CERTIFY_RTOL}
    if bad:
        raise SolverError(f"the force distribution of redundant contacts ({what}): Clarabel "
                          f"{status}, but its optimality conditions fail: {bad}")
    return x, z, status
