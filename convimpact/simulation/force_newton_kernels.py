"""Compiled pieces of the Newton polish of the largest-smallest-margin program
(:func:`~.force_distribution_polish._newton_max_min`): its optimality conditions' residual and
Jacobian at a point, and how far a stacked vector of cone entries lies outside its cones.

The event-driven run evaluates these a few hundred times per event of a many-contact scene
(the box stack: 41 polishes per run, each a few residuals), on systems of 10 to 40 unknowns
where numpy's per-call overhead, not the arithmetic, was the cost. The numbers are those of
the numpy expressions they replace (the same sums; their order may differ by round-off).
"""

from __future__ import annotations

import math

from ..compiled import jit, jit_internal


@jit_internal
def _ray(phi, ray, dray, zdir, dzdir):
    """A cone's boundary ray ``(1, cos phi, sin phi)`` and its dual direction
    ``(1, -cos phi, -sin phi)``, with their derivatives in phi, into the four 3-vectors."""
    co, sn = math.cos(phi), math.sin(phi)
    ray[0], ray[1], ray[2] = 1.0, co, sn
    dray[0], dray[1], dray[2] = 0.0, -sn, co
    zdir[0], zdir[1], zdir[2] = 1.0, -co, -sn
    dzdir[0], dzdir[1], dzdir[2] = 0.0, sn, -co


@jit
def max_min_residual(v, r, zero, ks, rows0, ms, A, b, w, J0, F, J):
    """The conditions F (into ``F``) and their Jacobian (into ``J``, from its constant part
    ``J0``) of the max-min program at ``v = (y, tau, unknowns)`` with the active cones
    fixed: stationarity ``e_tau - sum_c (A_c, w_c)' z_c = 0`` (rows 0..r), then per active
    cone its slack ``s_c = b_c - A_c y - tau w_c`` equal to 0 (``zero[c]``: z_c = its
    unknowns) or to ``alpha (1, cos phi, sin phi)`` (a ray: unknowns alpha, beta, phi;
    ``z_c = beta (1, -cos phi, -sin phi)``). Cone c's rows of A, b, w start at
    ``rows0[c] - (r + 1)`` (its rows of F at ``rows0[c]``), its unknowns at ``ks[c]`` in v,
    ``ms[c]`` rows."""
    n, size = J0.shape
    for i in range(n):
        for j in range(size):
            J[i, j] = J0[i, j]
    for j in range(r):
        F[j] = 0.0
    F[r] = 1.0
    tau = v[r]
    zdir = [0.0, 0.0, 0.0]
    dzdir = [0.0, 0.0, 0.0]
    ray = [0.0, 0.0, 0.0]
    dray = [0.0, 0.0, 0.0]
    for c in range(zero.shape[0]):
        k, row0, m = ks[c], rows0[c], ms[c]
        a0 = row0 - (r + 1)
        if zero[c]:
            for i in range(m):
                s = b[a0 + i]
                for j in range(r):
                    s -= A[a0 + i, j] * v[j]
                F[row0 + i] = s - tau * w[a0 + i]
                z = v[k + i]
                for j in range(r):
                    F[j] -= A[a0 + i, j] * z
                F[r] -= w[a0 + i] * z
        else:
            alpha, beta, phi = v[k], v[k + 1], v[k + 2]
            _ray(phi, ray, dray, zdir, dzdir)
            for j in range(r + 1):
                g = 0.0
                dg = 0.0
                for i in range(3):
                    a = A[a0 + i, j] if j < r else w[a0 + i]
                    g += a * zdir[i]
                    dg += a * dzdir[i]
                J[j, k + 1] = -g
                J[j, k + 2] = -beta * dg
                F[j] -= beta * g
            for i in range(3):
                s = b[a0 + i]
                for j in range(r):
                    s -= A[a0 + i, j] * v[j]
                F[row0 + i] = s - tau * w[a0 + i] - alpha * ray[i]
                J[row0 + i, k] = -ray[i]
                J[row0 + i, k + 2] = -alpha * dray[i]


@jit
def cone_violation(x, soc, starts, sizes):
    """How far the stacked cone entries ``x`` lie outside their cones (0 inside): per cone
    (``soc[c]``: a second-order cone, else nonnegative entries) at ``starts[c]`` with
    ``sizes[c]`` entries, ``|x_1..| - x_0`` or ``-min x``; the largest."""
    worst = 0.0
    for c in range(soc.shape[0]):
        k, m = starts[c], sizes[c]
        if soc[c]:
            t = 0.0
            for i in range(1, m):
                t += x[k + i] * x[k + i]
            worst = max(worst, math.sqrt(t) - x[k])
        else:
            for i in range(m):
                worst = max(worst, -x[k + i])
    return worst


@jit
def least_norm_residual(v, r, g, zero, ks, ms, A, b, F, J):
    """The conditions F (into ``F``) and their Jacobian (into ``J``) of the least-norm
    program ``min |y|^2 / 2 + g'y`` s.t. ``b - A y`` in the cones, at ``v = (y, unknowns)``
    with the active cones fixed (:func:`~.force_distribution_polish._newton_least_norm`):
    stationarity ``y + g + sum_c A_c' z_c = 0`` (rows 0..r-1), then per active cone its
    slack ``s_c = b_c - A_c y`` equal to 0 (``zero[c]``: z_c = its unknowns) or to
    ``alpha (1, cos phi, sin phi)`` (a ray: unknowns alpha, beta, phi; z_c = beta (1, -cos
    phi, -sin phi)). Cone c's unknowns and rows of F start at ``ks[c]`` (``ms[c]`` of each),
    its rows of A and b at ``ks[c] - r``."""
    size = J.shape[0]
    for i in range(size):
        for j in range(size):
            J[i, j] = 0.0
    for j in range(r):
        F[j] = v[j] + g[j]
        J[j, j] = 1.0
    zdir = [0.0, 0.0, 0.0]
    dzdir = [0.0, 0.0, 0.0]
    ray = [0.0, 0.0, 0.0]
    dray = [0.0, 0.0, 0.0]
    for c in range(zero.shape[0]):
        k, m = ks[c], ms[c]
        a0 = k - r
        for i in range(m):
            for j in range(r):
                J[k + i, j] = -A[a0 + i, j]
        if zero[c]:
            for i in range(m):
                s = b[a0 + i]
                for j in range(r):
                    s -= A[a0 + i, j] * v[j]
                F[k + i] = s
                z = v[k + i]
                for j in range(r):
                    F[j] += A[a0 + i, j] * z
                    J[j, k + i] = A[a0 + i, j]
        else:
            alpha, beta, phi = v[k], v[k + 1], v[k + 2]
            _ray(phi, ray, dray, zdir, dzdir)
            for j in range(r):
                gz = 0.0
                dgz = 0.0
                for i in range(3):
                    gz += A[a0 + i, j] * zdir[i]
                    dgz += A[a0 + i, j] * dzdir[i]
                F[j] += beta * gz
                J[j, k + 1] = gz
                J[j, k + 2] = beta * dgz
            for i in range(3):
                s = b[a0 + i]
                for j in range(r):
                    s -= A[a0 + i, j] * v[j]
                F[k + i] = s - alpha * ray[i]
                J[k + i, k] = -ray[i]
                J[k + i, k + 2] = -alpha * dray[i]
