"""The refinement of the largest-smallest-margin program's solution
(:func:`~.force_distribution.max_margin_distribution`, stage 1): Newton's method on its
optimality conditions with the active cones fixed, from the solver's point
(:func:`_polish_max_min`) or from the last program's active set at a nearby state
(:func:`_warm_max_min`, margin-only calls), and the cone helpers both modules use.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg.lapack import dgelsy as _dgelsy
from scipy.linalg.lapack import dgelsy_lwork as _dgelsy_lwork

#: a cone of the max-min program whose slack and multiplier are both below this is
#: degenerate (active or not: both are tried)
DEGENERATE = 1e-5
#: Newton steps without a smaller residual after which the polish stops (its best kept)
NEWTON_STALL = 3


#: LAPACK's optimal workspace of dgelsy per (rows, columns, right-hand sides) of the system
#: (queried once)
_GELSY_LWORK: dict = {}


def _lstsq(J: np.ndarray, F: np.ndarray, cond: float) -> np.ndarray:
    """The least-squares solution of ``J x = F`` (F a vector, or a matrix of right-hand
    sides) by LAPACK's dgelsy (a complete orthogonal factorization with column pivoting;
    singular values below ``cond`` of the largest cut), as ``scipy.linalg.lstsq(J, F, cond,
    lapack_driver="gelsy")`` computes it (the same routine, arguments and workspace),
    without its per-call checks and look-ups: the Newton steps here solve a hundred small
    systems per event."""
    m, n = J.shape
    nrhs = 1 if F.ndim == 1 else F.shape[1]
    lwork = _GELSY_LWORK.get((m, n, nrhs))
    if lwork is None:
        work, info = _dgelsy_lwork(m, n, nrhs, cond)
        if info != 0:
            raise ValueError(f"dgelsy's workspace query failed: {info}")
        lwork = _GELSY_LWORK[(m, n, nrhs)] = int(work.real)
    if m < n:  # (the solution overwrites the right-hand side: room for n entries)
        rhs = np.zeros((n,) + F.shape[1:])
        rhs[:m] = F
    else:
        rhs = F
    x, info = _dgelsy(J, rhs, np.zeros((n, 1), dtype=np.int32), cond, lwork,
                      False, False)[1::3]
    if info < 0:
        raise ValueError(f"illegal value in argument {-info} of dgelsy")
    return x[:n]


def _polish_max_min(blocks, x1: np.ndarray, z1: np.ndarray):
    """(y, t*, kinds, active): the max-min program's solution refined by Newton's method on
    its optimality conditions, given which cones are active (from the solver's solution);
    ``active`` the kinds and unknowns Newton's method converged with (None where it did
    not: the solver's point is kept), for :func:`_warm_max_min`.

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
        sn, zn = _norm(sb[1:]), _norm(zb[1:])
        if max(zb[0] + zn, sb[0] - sn) < DEGENERATE:
            ambiguous.append(j)
    first = _active_cones(blocks, slacks, ())
    tried = [first] + ([_active_cones(blocks, slacks, ambiguous)] if ambiguous else [])
    polished = False
    for kinds, unknowns in tried:
        v = _newton_max_min(blocks, kinds, unknowns, x1)
        if v is not None:
            polished = True
            break
    else:
        kinds, unknowns = first
        v = np.concatenate([x1] + unknowns)
    out_kinds, parts, k = [], [], r + 1
    for how, p in zip(kinds, unknowns):
        if how is None or isinstance(how, str):
            out_kinds.append(how)
        else:
            out_kinds.append(np.array([math.cos(v[k + 2]), math.sin(v[k + 2])]))
        parts.append(v[k:k + p.size].copy())
        k += p.size
    # (the active set and its unknowns: a later program near this one starts from them)
    return v[:r], float(v[r]), out_kinds, ((kinds, parts) if polished else None)


def _warm_max_min(blocks, warm: dict, lam0: np.ndarray, Q: np.ndarray, scale: float):
    """(y, t*) of the max-min program by Newton's method on its optimality conditions at
    the active set of the last program (``warm``: a nearby state's, the same contacts and
    modes), from its maximizer moved into the current distributions; None where that
    active set is not this program's (Newton's method fails, or a cone's slack or
    multiplier leaves its cone: :func:`_newton_max_min` checks them). Where it succeeds
    the point meets every optimality condition of the (convex) program: t* is its
    largest smallest margin, as the solver's would give after the polish."""
    active = warm.get("active")
    lam_prev = warm.get("lam")
    if active is None or lam_prev is None or lam_prev.shape != lam0.shape:
        return None
    kinds, parts = active
    if len(kinds) != len(blocks) or any(
            how is not None and not isinstance(how, str) and len(blk[2]) != how[1]
            or (isinstance(how, str) and p.size != len(blk[2]))
            for how, p, blk in zip(kinds, parts, blocks)):
        return None
    r = Q.shape[1]
    x0 = np.empty(r + 1)
    x0[:r] = Q.T @ ((lam_prev - lam0) / scale)
    x0[r] = warm["tau"]
    v = _newton_max_min(blocks, kinds, [p.copy() for p in parts], x0)
    if v is None:
        return None
    k, fresh = r + 1, []
    for p in parts:
        fresh.append(v[k:k + p.size].copy())
        k += p.size
    warm["active"] = (kinds, fresh)
    return v[:r], float(v[r])


def _active_cones(blocks, slacks, flip):
    """Each cone's kind (None, "zero" or a ray) and its initial unknowns: of each of the
    cone's complementary pairs of eigenvalues (s0 -+ |s1|, z0 +- |z1|) one member is ~0 at
    the optimum, the larger member tells which (the cones in flip: the other way)."""
    kinds, unknowns = [], []
    for j, ((kind, Ab, bb, wb), (sb, zb)) in enumerate(zip(blocks, slacks)):
        sn, zn = _norm(sb[1:]), _norm(zb[1:])
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
            unknowns.append(np.array([0.5 * (sb[0] + sn), 0.5 * (zb[0] + zn),
                                      math.atan2(u[1], u[0])]))
    return kinds, unknowns


def _kernels():
    """:mod:`.force_newton_kernels`, imported on first use (it imports numba)."""
    global _KERNELS
    if _KERNELS is None:
        from . import force_newton_kernels
        _KERNELS = force_newton_kernels
    return _KERNELS


_KERNELS = None


def _newton_max_min(blocks, kinds, unknowns, x1: np.ndarray, check: bool = True):
    """Newton's method (least-squares steps) on the max-min optimality conditions with the
    cones' kinds fixed; the solution vector (y, tau, unknowns), or None when it does not
    converge to 1e-12 or leaves a cone (``check`` False: the cones are not checked, the
    solution of the conditions is returned wherever they hold: the smooth extension of
    the active set's program). The conditions and their Jacobian are evaluated by
    :func:`~.force_newton_kernels.max_min_residual`."""
    ck = _kernels()
    r = x1.size - 1
    sizes = [p.size for p in unknowns]
    # the active cones' constant parts, once: their rows of the equations' Jacobian (the
    # slacks' -A and -w), the stationarity's -Aw^T columns, and where each sits
    act, k, row = [], r + 1, r + 1
    for (kind, Ab, bb, wb), how, n in zip(blocks, kinds, sizes):
        if how is not None:
            act.append((isinstance(how, str), Ab, bb, wb, k, row, len(bb)))
            row += len(bb)
        k += n
    size = r + 1 + sum(sizes)
    J0 = np.zeros((row, size))
    if act:
        A = np.vstack([a[1] for a in act])
        b = np.concatenate([a[2] for a in act])
        w = np.concatenate([a[3] for a in act])
        J0[r + 1:, :r] = -A
        J0[r + 1:, r] = -w
        for zero, Ab, bb, wb, k, row0, m in act:
            if zero:  # the stationarity's -d/dz: -(A_c, w_c)'
                J0[:r, k:k + m] = -Ab.T
                J0[r, k:k + m] = -wb
    else:
        A, b, w = np.zeros((0, r)), np.zeros(0), np.zeros(0)
    zero = np.array([a[0] for a in act], dtype=np.bool_)
    ks = np.array([a[4] for a in act], dtype=np.int64)
    rows0 = np.array([a[5] for a in act], dtype=np.int64)
    ms = np.array([a[6] for a in act], dtype=np.int64)

    def residual(v):
        F = np.empty(row)
        J = np.empty((row, size))
        ck.max_min_residual(v, r, zero, ks, rows0, ms, A, b, w, J0, F, J)
        return F, J

    v = np.concatenate([x1] + unknowns)
    F, J = residual(v)
    best, best_norm = v, float(np.abs(F).max())
    stalled = 0
    for _ in range(30):
        # least-squares steps, small singular values cut: along a face of maximizers the
        # conditions are singular, and the step stays near the solver's point
        step = _lstsq(J, F, 1e-10)
        v = v - step
        F, J = residual(v)  # (the next step's too)
        norm = float(np.abs(F).max())
        # (no gain over NEWTON_STALL steps running: Newton's method is at its round-off
        # floor or stuck where the cut singular directions hold the residual; the box
        # stack's onsets ran all 30 steps on an unchanged residual, 8 of its 55 polishes)
        stalled = 0 if norm < best_norm else stalled + 1
        if norm < best_norm:
            best, best_norm = v, norm
        if (norm <= (1e-15 if check else 1e-12) or float(np.abs(step).max()) <= 1e-16
                or stalled >= NEWTON_STALL):
            break  # (an unchecked extension, a predictor, needs no digits past 1e-12)
    if not best_norm <= 1e-12:
        return None
    if not check:
        return best
    return best if _in_cones(blocks, kinds, sizes, best, r) else None


def _in_cones(blocks, kinds, sizes, v: np.ndarray, r: int) -> bool:
    """Whether Newton's solution ``v`` of :func:`_newton_max_min` keeps every inactive
    cone's slack and every active cone's multiplier in its cone (to 1e-12): the inactive
    cones' slacks at once, the "zero" cones' multipliers and the rays' (alpha, beta) >= 0."""
    y, tau = v[:r], v[r]
    off = [blk for blk, how in zip(blocks, kinds) if how is None]
    if off:
        slack = (np.concatenate([blk[2] for blk in off]) - np.vstack([blk[1] for blk in off]) @ y
                 - tau * np.concatenate([blk[3] for blk in off]))
        m = np.array([len(blk[2]) for blk in off], dtype=np.int64)
        starts = np.zeros(len(off), dtype=np.int64)
        np.cumsum(m[:-1], out=starts[1:])
        soc = np.array([blk[0] == "soc" for blk in off], dtype=np.bool_)
        if _kernels().cone_violation(slack, soc, starts, m) > 1e-12:
            return False
    k = r + 1
    for (kind, _, bb, _), how, n in zip(blocks, kinds, sizes):
        if how is not None:
            p = v[k:k + n]
            viol = (_cone_violation(p, [(kind, len(bb))]) if isinstance(how, str)
                    else max(-p[0], -p[1]))
            if viol > 1e-12:
                return False
        k += n
    return True


def _off_ray(u: np.ndarray) -> np.ndarray:
    """Rows L with L s = 0 exactly when s (in R^3) lies on the ray through (1, u): the
    component of s's tangential part across u, and s0 - u . s1."""
    return np.array([[0.0, -u[1], u[0]], [1.0, -u[0], -u[1]]])


def _norm(v: np.ndarray) -> float:
    """The Euclidean norm of a short vector."""
    return math.sqrt(float(v @ v))


def _list_violation(kind: str, part: list) -> float:
    """How far one cone's entries (a list of floats) lie outside it (0 inside)."""
    if kind == "nn":
        return max(0.0, -min(part)) if part else 0.0
    return max(0.0, math.sqrt(sum(x * x for x in part[1:])) - part[0])


def _cone_violation(v: np.ndarray, cones) -> float:
    """How far v lies outside the product of cones (0 inside)."""
    worst, k = 0.0, 0
    for kind, size in cones:
        part = v[k:k + size]
        k += size
        if kind == "nn":
            if size:
                worst = max(worst, -float(part.min()))
        else:
            tail = part[1:]
            worst = max(worst, math.sqrt(float(tail @ tail)) - float(part[0]))
    return worst


def _polish_least_norm(blocks, g: np.ndarray, y1: np.ndarray, z1: np.ndarray,
                       max_sets: int = 8) -> np.ndarray | None:
    """The solution of ``min |y|^2 / 2 + g'y`` s.t. ``b - A y in K`` per block (kind, A, b,
    w) to round-off, by Newton's method on its optimality conditions with the active cones
    fixed, from an interior-point solution (y1, multipliers z1): a primal-dual active-set
    method. None where it does not certify.

    Per cone: inactive (z = 0); "zero" (s = 0, z free, then checked in K); on the boundary
    of a second-order cone (s on a ray of it, z on the opposite one, :func:`_newton_least_norm`).
    The objective is strictly convex, so the minimizer is unique and the active set only
    decides how it is computed. Cones whose equations depend on the others' are left out
    first (:func:`_independent`: in a thin shell more cones bind than can at once); where
    the conditions at a set fail (a multiplier of the wrong sign, an inactive cone violated,
    a slack on the backward ray) the set is corrected and Newton's method rerun from the
    solver's point (at most ``max_sets`` sets). Accepted when stationarity and the active
    equations hold to 1e-12 relative, every inactive slack lies in its cone (to 1e-13) and
    every multiplier in its (to 1e-12)."""
    A_all = np.vstack([blk[1] for blk in blocks])
    b_all = np.concatenate([blk[2] for blk in blocks])
    sizes = [len(blk[2]) for blk in blocks]
    starts = np.concatenate([[0], np.cumsum(sizes)])
    s1 = b_all - A_all @ y1
    kinds = []
    for j, (kind, Ab, bb, wb) in enumerate(blocks):
        sb, zb = s1[starts[j]:starts[j + 1]], z1[starts[j]:starts[j + 1]]
        sn, zn = _norm(sb[1:]), _norm(zb[1:])
        if zb[0] + zn <= sb[0] - sn:
            kinds.append(None)
        elif kind == "nn" or zb[0] - zn > sb[0] + sn:
            kinds.append("zero")
        else:
            kinds.append("bd")
    weight = [float(z1[starts[j]]) for j in range(len(blocks))]  # the solver's z0
    start = [z1[starts[j]:starts[j + 1]].copy() for j in range(len(blocks))]
    scale = 1.0 + float(np.max(np.abs(g), initial=0.0)) + float(np.max(np.abs(y1)))
    for _ in range(max_sets):
        kinds = _independent(blocks, kinds, y1, weight, start)
        # (each set from the solver's point and multipliers: near the solution)
        got = _newton_least_norm(blocks, g, kinds, y1, scale, start)
        if got is None:
            return None
        y, mult = got
        s = b_all - A_all @ y
        change = False
        for j, (kind, Ab, bb, wb) in enumerate(blocks):
            sb = s[starts[j]:starts[j + 1]]
            how = kinds[j]
            if how is None:
                if _list_violation(kind, sb.tolist()) > 1e-13 * scale:
                    kinds[j] = "zero" if kind == "nn" else "bd"
                    weight[j] = np.inf  # (kept: left out, it is violated)
                    change = True
            elif how == "zero":
                if _cone_violation(mult[j], [(kind, sizes[j])]) > 1e-12 * scale:
                    kinds[j] = None if kind == "nn" or mult[j][0] < 0.0 else "bd"
                    change = True
            elif mult[j][0] < -1e-12 * scale:  # (beta, alpha): a negative multiplier
                kinds[j] = None
                change = True
            elif mult[j][1] < -1e-12 * scale:  # the slack on the backward ray: outside
                kinds[j] = "zero"
                change = True
        if not change:
            return y
    return None


def _independent(blocks, kinds, y: np.ndarray, weight, start=None) -> list:
    """The active cones with those whose equations depend on the others' left out, the
    one of least ``weight`` (the solver's multiplier) of each dependent set first: in a
    thin shell more cones bind than can at once (a group whose margins' sum is fixed),
    and their equations are then inconsistent or redundant. The rows are the equations'
    gradients at the solver's point y (a boundary cone's along its ray, from its slack,
    or where that is ~0 from its multiplier ``start``); a dependency is a singular value
    below 1e-6 of the largest (the solver's point is accurate to ~1e-7 only)."""
    kinds = list(kinds)
    while True:
        rows, owner = [], []
        for j, how in enumerate(kinds):
            if how is None:
                continue
            kind, Ab, bb, wb = blocks[j]
            if how == "bd":
                s = bb - Ab @ y
                sn = _norm(s[1:])
                z = start[j] if start is not None else None
                zn = _norm(z[1:]) if z is not None and len(z) == len(bb) else 0.0
                if max(sn, zn) > 0.0:
                    u = s[1:] / sn if sn >= zn else -z[1:] / zn
                    rows.append(-(Ab[0] - u @ Ab[1:]))
                    owner.append(j)
            if how == "zero":
                rows += list(-Ab)
                owner += [j] * len(bb)
        if not rows:
            return kinds
        G = np.array(rows)
        U, sv, _ = np.linalg.svd(G)  # left singular vectors: dependencies of the rows
        tol = 1e-6 * max(float(sv[0]), 1e-300)
        dead = [i for i in range(G.shape[0]) if i >= sv.size or sv[i] <= tol]
        if not dead:
            return kinds
        w = np.abs(U[:, dead[-1]])
        involved = {owner[i] for i in range(len(owner)) if w[i] > 1e-6 * float(w.max())}
        kinds[min(involved, key=lambda j: (weight[j], j))] = None


def _newton_least_norm(blocks, g: np.ndarray, kinds, y0: np.ndarray, scale: float,
                       start=None):
    """Newton's method (least-squares steps) on the optimality conditions of
    :func:`_polish_least_norm`'s program with the cones' kinds fixed: ``y + g + sum A'z =
    0``; a "zero" cone's slack ``s = b - A y = 0`` (z free); a cone on its boundary with
    ``s = alpha (1, cos phi, sin phi)`` and ``z = beta (1, -cos phi, -sin phi)`` (as
    :func:`_newton_max_min`'s rays: no division by |s1|, which may be ~0). From y0 and the
    multipliers ``start`` (per block, the solver's z). Returns (y, per block: z for "zero",
    (beta, alpha) on the boundary, None inactive), or None where the conditions do not
    hold to 1e-12 relative."""
    r = y0.size
    act, size = [], r
    v0 = [y0.copy()]
    for j, how in enumerate(kinds):
        if how is None:
            continue
        kind, Ab, bb, wb = blocks[j]
        m = len(bb)
        z = None if start is None or start[j] is None else np.asarray(start[j], float)
        if how == "zero":
            v0.append(z.copy() if z is not None and z.size == m else np.zeros(m))
            act.append((j, how, size, m))
            size += m
        else:
            sb = bb - Ab @ y0
            sn = _norm(sb[1:])
            zn = 0.0 if z is None or z.size != m else _norm(z[1:])
            u = (sb[1:] / sn if sn >= zn or zn == 0.0 else -z[1:] / zn) if max(sn, zn) > 0.0 \
                else np.array([1.0, 0.0])
            beta = 0.5 * (z[0] + zn) if z is not None and z.size == m else 0.0
            v0.append(np.array([0.5 * (sb[0] + sn), max(beta, 0.0), math.atan2(u[1], u[0])]))
            act.append((j, how, size, 3))
            size += 3
    v = np.concatenate(v0)

    ck = _kernels()
    zero = np.array([how == "zero" for _, how, _, _ in act], dtype=np.bool_)
    ks = np.array([k0 for _, _, k0, _ in act], dtype=np.int64)
    ms = np.array([m for _, _, _, m in act], dtype=np.int64)
    if act:
        A = np.vstack([blocks[j][1] for j, _, _, _ in act])
        b = np.concatenate([blocks[j][2] for j, _, _, _ in act])
    else:
        A, b = np.zeros((0, r)), np.zeros(0)

    def residual(v):
        F = np.empty(size)
        J = np.empty((size, size))
        ck.least_norm_residual(v, r, g, zero, ks, ms, A, b, F, J)
        return F, J

    best, stalled = None, 0
    for _ in range(40):
        F, J = residual(v)
        res = float(np.abs(F).max()) if F.size else 0.0
        if best is None or res < best[0]:
            best, stalled = (res, v.copy()), 0
        else:
            stalled += 1
        if res <= 1e-14 * scale or stalled >= NEWTON_STALL:
            break
        v = v - _lstsq(J, F, 1e-12)
    res, v = best
    if not res <= 1e-12 * scale:
        return None
    out = [None] * len(blocks)
    for j, how, k, m in act:
        out[j] = v[k:k + m].copy() if how == "zero" else np.array([v[k + 1], v[k]])
    return v[:r].copy(), out
