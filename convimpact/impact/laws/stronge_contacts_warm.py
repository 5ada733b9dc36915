"""The warm-started plastic compression of law ``stronge`` at several contacts, compiled in one
call: :func:`warm_compression` (see "Warm start" in
:mod:`convimpact.impact.laws.stronge_contacts`, which calls it).

From the previous compression ``prev`` of as many contacts, on the problem ``u = W pi + b``:

1. the program is equilibrated as :func:`convimpact.impact.conic.qp.equilibrated` does (each
   contact's impulse by ``1 / sqrt(max diag W_ii)``, then the whole to unit data);
2. ``prev`` is classified as the polish's primary kind per contact
   (:func:`convimpact.impact.conic.polish.classify_contacts`: zero, frictionless-active,
   inside the cone, on its boundary with the tangent of ``prev``);
3. Coulomb's conditions on that active set are solved by the polish's compiled Newton
   (:func:`~convimpact.impact.conic.polish_newton.active_set_newton`, its closeness test
   included);
4. the answer's Coulomb residual is measured as
   :func:`convimpact.impact.laws.coulomb_program.coulomb_residual` measures it;
5. the null space of the active set's Jacobian at the answer (singular values below 1e-9
   of the largest) is the tangent of its family of solutions; its image under W says
   whether that family moves any velocity (relative 1e-8).

Returns ``(status, pi, residual)``: status :data:`UNIQUE` (locally unique), :data:`REDUNDANT`
(a family of impulses with the same velocities) or :data:`MOVING` (a family of motions),
or :data:`FAILED` (not certified: pi is zero, the caller takes the fixed point).

With ``fast`` (for a caller that accepts UNIQUE and REDUNDANT alike: every e = 0, Moreau--Jean's
steps without an impact, :mod:`convimpact.simulation.moreau_stronge`) the linear algebra
takes the complete orthogonal decomposition of :mod:`convimpact.impact.conic.polish_cod`
instead of the singular value decomposition (the Newton's minimum-norm steps, cut 1e-13, and
the null space of step 5, cut :data:`NULL_RTOL`: the same steps and spaces wherever the rank
is clear); step 5 takes the Jacobian the Newton evaluated at its answer (not again at the
start's tangent) without the boundary contacts' kappa (:func:`_without_kappa`), and is
skipped where no contact is on its cone's boundary: then the
unknowns are impulse components ``x_S = u`` (``dx/du`` the selection S), the equations the
rows S of ``W x + b`` (no ``z`` term), so ``J = S^T W S`` (scaled) and a null vector v has
``v.J.v = |W^1/2 S v|^2 = 0``, i.e. ``W S v = 0``: every family moves no velocity, and the
status is :data:`STILL` (UNIQUE or REDUNDANT, not told apart).
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit as _jit
from ...compiled import jit_internal as _jit_internal
from ..conic.polish_cod import cod_null_space
from ..conic.polish_newton import (ACT, BND, INT, POLISH_MAX_NEWTON, TINY, _layout, _unpack,
                                   active_set_jacobian, newton_core, primary_kinds)
from ..conic.polish_steps import _matmat, _matvec

UNIQUE, REDUNDANT, MOVING, FAILED, STILL = 0, 1, 2, -1, 3
#: singular values of the active set's Jacobian below this fraction of the largest: its null
#: space (the family of solutions)
NULL_RTOL = 1e-9
#: a family whose velocities move by less than this (relative to W dx/du) moves none
STILL_RTOL = 1e-8


@_jit
def _coulomb_residual(W, b, mu, d, pi):
    """The relative residual of ``K ∋ pi ⊥ u + mu |u_t| n ∈ K*`` (u = W pi + b), as
    :func:`~convimpact.impact.laws.coulomb_program.coulomb_residual` defines it."""
    n = mu.size
    u = _matvec(W, pi) + b
    ps = max(np.sqrt(np.sum(pi * pi)), TINY)
    wmax = np.max(np.abs(W))
    vs = max(np.sqrt(np.sum(b * b)), wmax * ps, TINY)
    r = 0.0
    for i in range(n):
        o = i * d
        xt = 0.0
        ut = 0.0
        for a in range(1, d):
            xt += pi[o + a] ** 2
            ut += u[o + a] ** 2
        xt, ut = np.sqrt(xt), np.sqrt(ut)
        yn = u[o] + mu[i] * ut
        r = max(r, max(0.0, xt - mu[i] * pi[o], -pi[o]) / ps)
        if mu[i] == 0.0:
            r = max(r, max(0.0, -yn) / vs, xt / ps, abs(pi[o] * yn) / (ps * vs))
        else:
            vsi = vs * max(1.0, mu[i])
            r = max(r, max(0.0, mu[i] * ut - yn) / vsi)
            dot = pi[o] * yn
            for a in range(1, d):
                dot += pi[o + a] * u[o + a]
            r = max(r, abs(dot) / (ps * vsi))
    return r


@_jit_internal
def _times_sparse(A, B):
    """A B for a B mostly zero (``dx/du``: at most three entries per column), the sums in
    :func:`~convimpact.impact.conic.polish_steps._matmat`'s order."""
    out = np.zeros((A.shape[0], B.shape[1]))
    for k in range(B.shape[0]):
        for c in range(B.shape[1]):
            b = B[k, c]
            if b != 0.0:
                for r in range(A.shape[0]):
                    out[r, c] += A[r, k] * b
    return out


@_jit_internal
def _without_kappa(J, Jx, kind, d):
    """J and dx/du without the boundary contacts' kappa (``fast``'s step 5): a boundary
    contact's kappa enters only its tangential rows, along ``(c, s)`` (the column
    ``(cos a, sin a) / sG``; in the plane the one tangential row), so the rows there are
    turned by that unit vector (an orthogonal map) and the one along it, the only row with
    kappa, is dropped with kappa's column. ``J v = 0`` then holds exactly when the reduced
    rows vanish on v without kappa and kappa's component is the one that row fixes: the
    null spaces have one dimension, and a family's velocities ``W dx/du v`` (kappa moves no
    x) are the same. A kappa column without entries (not a boundary ray) keeps J whole."""
    n = kind.size
    m, U = J.shape
    keep_r = np.ones(m, dtype=np.bool_)
    keep_c = np.ones(U, dtype=np.bool_)
    R = J.copy()
    row = 0
    col = 0
    for i in range(n):
        k = kind[i]
        if k == BND:
            kc = col + (2 if d == 3 else 1)
            if d == 3:
                a1, a2 = R[row + 1, kc], R[row + 2, kc]
                h = np.sqrt(a1 * a1 + a2 * a2)
                if h == 0.0:
                    return J, Jx
                c, s = a1 / h, a2 / h
                for j in range(U):
                    t1, t2 = R[row + 1, j], R[row + 2, j]
                    R[row + 1, j] = -s * t1 + c * t2
                    R[row + 2, j] = c * t1 + s * t2
                keep_r[row + 2] = False
            else:
                if R[row + 1, kc] == 0.0:
                    return J, Jx
                keep_r[row + 1] = False
            keep_c[kc] = False
            row += d
            col += 3 if d == 3 else 2
        elif k == INT:
            row += d
            col += d
        elif k == ACT:
            row += 1
            col += 1
    rows = np.nonzero(keep_r)[0]
    cols = np.nonzero(keep_c)[0]
    return R[rows][:, cols], Jx[:, cols]


@_jit
def warm_compression(W, b, mu, d, prev, fast=False):
    """The warm-started plastic compression (see the module docstring; ``fast`` there):
    (status, pi, Coulomb residual on the equilibrated program)."""
    n = mu.size
    N = n * d
    fail = (FAILED, np.zeros(N), np.inf)
    # 1. equilibration (qp.equilibrated without equality rows)
    D = np.ones(N)
    for i in range(n):
        top = 0.0
        for a in range(d):
            top = max(top, W[i * d + a, i * d + a])
        if top > 0.0:
            D[i * d:(i + 1) * d] = 1.0 / np.sqrt(top)
    Wd = D[:, None] * W * D[None, :]
    qd = D * b
    sW = np.max(np.abs(Wd))
    sq = np.max(np.abs(qd))
    if not sW > 0.0 or sq == 0.0:
        return fail
    Wu = Wd / sW
    qu = qd / sq
    scale = D * (sq / sW)
    y0 = prev / scale
    # 2. the polish's primary classification of the start
    kind, tang = primary_kinds(y0, mu, d)
    # 3. Coulomb's conditions on that active set
    E = np.zeros((0, N))
    f = np.zeros(0)
    y, ok, Jn, un = newton_core(Wu, qu, E, f, mu, d, kind, tang, y0, bool(True), bool(True),
                                POLISH_MAX_NEWTON, False, False, fast)
    if not ok:
        return fail
    # 4. the certificate
    resid = _coulomb_residual(Wu, qu, mu, d, y)
    # 5. the family of solutions through y
    if fast:
        if not np.any(kind == BND):
            return STILL, y * scale, resid
        J = Jn  # the Jacobian at the answer's unknowns, as the Newton evaluated it
        Jx = _unpack(un, kind, tang, mu, d, _layout(kind, d), bool(True), un.size)[2]
    else:
        J, Jx = active_set_jacobian(Wu, qu, E, f, mu, d, kind, tang, y, bool(True))
    status = UNIQUE
    if fast and J.shape[1] > 0:
        Jr, Jxr = _without_kappa(J, Jx, kind, d)
        V = cod_null_space(Jr, NULL_RTOL)
        if V.shape[1] > 0:
            dv = _times_sparse(Wu, Jxr)
            moved = np.max(np.abs(_matmat(Wu, _matmat(Jxr, V))))
            status = REDUNDANT if moved <= STILL_RTOL * max(np.max(np.abs(dv)), TINY) \
                else MOVING
    elif J.shape[1] > 0:
        _, sv, Vt = np.linalg.svd(J)
        top = sv[0] if sv.size else 0.0
        rank = 0
        for s in sv:
            if s > NULL_RTOL * top:
                rank += 1
        if rank < J.shape[1]:
            dv = _matmat(Wu, Jx)
            moved = np.max(np.abs(_matmat(dv, np.ascontiguousarray(Vt[rank:].T))))
            status = REDUNDANT if moved <= STILL_RTOL * max(np.max(np.abs(dv)), TINY) \
                else MOVING
    return status, y * scale, resid


__all__ = ["warm_compression", "UNIQUE", "REDUNDANT", "MOVING", "FAILED", "STILL"]
