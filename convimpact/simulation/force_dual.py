"""Dual (weak-duality) certificates of the largest-smallest-margin program
(:func:`~.force_distribution.max_margin_distribution`, stage 1): a bound on its optimum from
a multiplier vector, without the solver.

The program, in the unknowns (y, tau) with blocks (kind, A, b, w) of
:func:`~.force_distribution._margin_blocks` (its last block the bound tau <= 1), is

    t* = max tau  s.t.  s = b - A y - tau w  in K  (K: a product of nonnegative half-lines
                                                   and second-order cones, self-dual).

For any z in K with ``A'z = 0`` and ``w'z > 0`` and any feasible (y, tau), ``s'z >= 0``
gives ``tau w'z <= b'z - y'A'z = b'z``: **t* <= b'z / w'z** (weak duality). A multiplier
vector so bounding t* below the level a combination of modes must reach proves the
combination's refusal; the solver is not asked. :func:`refusal_bound` takes its candidate
multipliers from the active sets a nearby program's Newton polish left
(:func:`~.force_distribution_polish._warm_max_min`'s ``warm``): their support and values,
moved onto ``A'z = 0, w'z = 1`` (the least change, on the same support) and into K. Where
the nearby active set is this program's optimal one, the bound is the optimum itself; where
the optimum is degenerate (the box stack's top box at its slip onset, one corner sticking
and three slipping: a cone whose slack is 0.01 and multiplier 6e-9, on which Newton's method
stalls at a residual of 1e-9) the dual point still bounds it. A point that does not meet
``A'z = 0`` to :data:`DUAL_RTOL`, or leaves K, proves nothing: None.

The stationarity residual ``e = A'z`` (at most :data:`DUAL_RTOL` relative) moves the bound by
``|y'e| / w'z`` for a distribution y (in units of the force scale): the callers compare the
bound with a guard of 1e-9 of the force scale, which covers distributions up to 1e3 force
scales; every program's solution here is accepted on its optimality conditions to such
tolerances (the solver's to 1e-8, Newton's to 1e-12).
"""

from __future__ import annotations

import math

import numpy as np

from .force_distribution_polish import _kernels, _lstsq

#: largest stationarity residual |A'z|_inf (relative to 1 + |A|_inf |z|_inf) of a dual point
#: that certifies a bound
DUAL_RTOL = 1e-12
#: rounds of (move onto A'z = 0, w'z = 1; move into K) from the candidate multipliers, and
#: of the boundary point's active sets
DUAL_ROUNDS = 5
#: rounds of step 1 of :func:`dual_point` (the least change, then into K): on the box
#: stack, the sliding-direction tests and the dual certificates' tests, 83 of its 83
#: successes came in the first round and its 46 failures ran all five; past two rounds the
#: boundary point (step 2) is taken
PROJECTION_ROUNDS = 2


def _stacked(blocks):
    """(A, b, w, second-order flags, starts, sizes, |A|_inf) of the blocks, stacked."""
    sizes = np.array([len(blk[2]) for blk in blocks], dtype=np.int64)
    starts = np.zeros(len(blocks), dtype=np.int64)
    np.cumsum(sizes[:-1], out=starts[1:])
    A = np.vstack([blk[1] for blk in blocks])
    return (A, np.concatenate([blk[2] for blk in blocks]),
            np.concatenate([blk[3] for blk in blocks]),
            np.array([blk[0] == "soc" for blk in blocks], dtype=np.bool_), starts, sizes,
            float(np.abs(A).max()) if A.size else 0.0)


def dual_bound(blocks, z: np.ndarray, stacked=None) -> float | None:
    """The bound ``b'z / w'z`` on the largest smallest margin t* certified by the
    multipliers ``z`` (all blocks' entries stacked, in the blocks' order), or None where
    ``z`` is not dual feasible: outside K (no tolerance), ``w'z <= 0``, or ``|A'z|_inf`` above
    :data:`DUAL_RTOL` (1 + |A|_inf |z|_inf). ``stacked``: the blocks' :func:`_stacked`
    arrays, where the caller has them."""
    A, b, w, soc, starts, sizes, amax = _stacked(blocks) if stacked is None else stacked
    z = np.asarray(z, float)
    if z.size != b.size:
        raise ValueError(f"the multipliers have {z.size} entries, the blocks {b.size}")
    if _kernels().cone_violation(z, soc, starts, sizes) > 0.0:
        return None
    wz = float(w @ z)
    if not wz > 0.0:
        return None
    zmax = float(np.abs(z).max())
    if float(np.abs(A.T @ z).max()) > DUAL_RTOL * (1.0 + amax * zmax):
        return None
    return float(b @ z) / wz


def active_multipliers(blocks, active) -> np.ndarray | None:
    """The multipliers (stacked per block) of a Newton polish's active set ``active``
    (kinds, unknowns: :func:`~.force_distribution_polish._polish_max_min`): zero on the
    inactive cones, the unknowns on the "zero" ones, ``beta (1, -cos phi, -sin phi)`` on a
    ray; None where the active set does not fit the blocks."""
    kinds, parts = active
    if len(kinds) != len(blocks):
        return None
    out = []
    for (kind, _, bb, _), how, p in zip(blocks, kinds, parts):
        m = len(bb)
        if how is None:
            out.append(np.zeros(m))
        elif isinstance(how, str):
            if p.size != m:
                return None
            out.append(np.asarray(p, float))
        else:
            if m != 3 or p.size != 3:
                return None
            beta, phi = float(p[1]), float(p[2])
            out.append(beta * np.array([1.0, -math.cos(phi), -math.sin(phi)]))
    return np.concatenate(out) if out else np.zeros(0)


def _into_cones(blocks, z: np.ndarray) -> np.ndarray:
    """The projection of z onto K (blockwise: the half-lines' negative parts cut, each
    second-order cone's Euclidean projection)."""
    out = z.copy()
    k = 0
    for kind, _, bb, _ in blocks:
        m = len(bb)
        part = out[k:k + m]
        if kind == "nn":
            np.maximum(part, 0.0, out=part)
        else:
            t, norm = float(part[0]), math.sqrt(float(part[1:] @ part[1:]))
            if norm <= -t:
                part[:] = 0.0
            elif norm > t:
                scale = 0.5 * (t + norm)
                part[0] = scale
                part[1:] *= scale / norm
        k += m
    return out


def dual_point(blocks, z0: np.ndarray, stacked=None) -> np.ndarray | None:
    """A dual point near the candidate ``z0`` on its support S (the blocks where it is not
    zero), or None where none is found:

    1. alternately the least change onto ``A'z = 0, w'z = 1`` (a minimum-norm least-squares
       step on S's columns) and the projection into K, until the point is dual feasible
       (:func:`dual_bound`), at most :data:`PROJECTION_ROUNDS` times;
    2. else (the stationary points on S leave K: at a degenerate optimum the dual point
       lies on a second-order cone's boundary and needs half-lines outside S with tiny
       multipliers) :func:`_boundary_point` from step 1's first least-squares point."""
    stacked = _stacked(blocks) if stacked is None else stacked
    sizes = [len(blk[2]) for blk in blocks]
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
    support = [j for j in range(len(blocks))
               if np.any(z0[starts[j]:starts[j + 1]] != 0.0)]
    if not support:
        return None
    cols = np.concatenate([np.arange(starts[j], starts[j + 1]) for j in support])
    # stationarity's rows on the support: A_S' (r rows), then w_S' (one)
    M = np.vstack([np.vstack([blocks[j][1] for j in support]).T,
                   np.concatenate([blocks[j][3] for j in support])[None, :]])
    target = np.zeros(M.shape[0])
    target[-1] = 1.0
    z = z0.copy()
    sub = [blocks[j] for j in support]
    first = None
    for _ in range(PROJECTION_ROUNDS):
        zs = z[cols]
        zs = zs - _lstsq(M, M @ zs - target, 1e-12)
        if first is None:
            first = zs
        z[cols] = _into_cones(sub, zs)
        if dual_bound(blocks, z, stacked) is not None:
            return z
    z = np.zeros_like(z0)
    z[cols] = first
    return _boundary_point(blocks, z, support, starts, stacked)


def _boundary_point(blocks, z: np.ndarray, support, starts, stacked) -> np.ndarray | None:
    """A dual point from ``z`` (stationary on the ``support``): each second-order cone of
    the support put on its boundary ray ``beta (1, -cos phi, -sin phi)`` through z's
    (beta = its first entry), its half-lines kept as entries, and the program's other
    half-lines (but the bound tau <= 1) added from zero; Gauss-Newton on stationarity
    (``A'z = 0, w'z = 1``, minimum-norm steps: the added multipliers stay small) in those
    unknowns, the added half-lines whose multiplier comes out negative left out and the
    rest solved again (at most :data:`DUAL_ROUNDS` sets); the point where
    :func:`dual_bound` accepts one, else None. (The box stack's slip onset: one corner
    sticking, three slipping, the optimum's multipliers 1 on the sticking corner's cone
    boundary and 6e-9 on a slipping corner's normal force.)"""
    r = blocks[0][1].shape[1]
    rays = [j for j in support if blocks[j][0] == "soc"]
    kept = [j for j in support if blocks[j][0] != "soc"]
    extra = [j for j in range(len(blocks) - 1)
             if blocks[j][0] == "nn" and j not in support]
    target = np.zeros(r + 1)
    target[r] = 1.0
    u0 = []
    for j in rays:
        zb = z[starts[j]:starts[j + 1]]
        u0 += [float(zb[0]), math.atan2(-float(zb[2]), -float(zb[1]))]
    AwT = {j: np.vstack([blocks[j][1].T, blocks[j][3][None, :]])
           for j in rays + kept + extra}
    for _ in range(DUAL_ROUNDS):
        full = kept + extra
        u = np.concatenate([u0, np.concatenate([z[starts[j]:starts[j + 1]] for j in full])
                            if full else np.zeros(0)])
        last = np.inf
        for _ in range(12):
            F, cols, k = -target, [], 0
            for j in rays:
                beta, phi = u[k], u[k + 1]
                c, sn = math.cos(phi), math.sin(phi)
                g = AwT[j] @ np.array([1.0, -c, -sn])
                F = F + beta * g
                cols.append(np.column_stack([g, beta * (AwT[j] @ np.array([0.0, sn, -c]))]))
                k += 2
            for j in full:
                m = len(blocks[j][2])
                F = F + AwT[j] @ u[k:k + m]
                cols.append(AwT[j])
                k += m
            norm = float(np.abs(F).max())
            # (converged, or at its round-off floor: the box stack's onset reached 1.4e-15
            # in one step and spent ten more on it)
            if norm <= 1e-15 or norm > 0.99 * last:
                break
            last = norm
            u = u - _lstsq(np.hstack(cols), F, 1e-12)
        out = np.zeros_like(z)
        k = 0
        for j in rays:
            out[starts[j]:starts[j + 1]] = u[k] * np.array([1.0, -math.cos(u[k + 1]),
                                                            -math.sin(u[k + 1])])
            k += 2
        negative = []
        for j in full:
            m = len(blocks[j][2])
            out[starts[j]:starts[j + 1]] = u[k:k + m]
            if j in extra and float(u[k:k + m].min()) < 0.0:
                negative.append(j)
            k += m
        if dual_bound(blocks, out, stacked) is not None:
            return out
        if not negative:
            return None
        extra = [j for j in extra if j not in negative]
    return None


def refusal_bound(blocks, warm: dict, level: float | None = None) -> float | None:
    """The least bound on the program's largest smallest margin that the active sets of a
    nearby program certify (``warm``: the last one, then the earlier ones kept, as
    :func:`~.force_distribution._warm_tries` tries them), each moved to a dual point of this
    program (:func:`dual_point`); None where none of them gives a dual-feasible point.
    ``level`` (optional): the first bound below it is returned, the later sets not tried
    (the caller asks whether the optimum lies below ``level``: any bound below it proves
    so)."""
    sets = []
    if warm.get("active") is not None:
        sets.append(warm["active"])
    sets += [entry[0] for entry in warm.get("earlier", ()) if entry[0] is not None]
    best, stacked = None, _stacked(blocks)
    for active in sets:
        z0 = active_multipliers(blocks, active)
        z = None if z0 is None else dual_point(blocks, z0, stacked)
        if z is None:
            continue
        bound = dual_bound(blocks, z, stacked)
        if bound is not None and (best is None or bound < best):
            best = bound
            if level is not None and best < level:
                break
    return best
