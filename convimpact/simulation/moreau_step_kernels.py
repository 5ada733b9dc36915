"""Compiled stages of a Moreau–Jean step's predictor and positions (:mod:`.moreau_loop`),
allocation-free.

* :func:`predict_model`: the predictor of a step on a model of :mod:`convimpact.model`
  without loops or applied forces, in one call: the intermediate configuration, M, the
  contacts' gaps and Jacobians (the model's compiled pass,
  :func:`convimpact.model.recursive.evaluate`, on its work buffer), the inverse mass block by
  block (:func:`block_inverses`), the smooth forces at t_m (twice for theta < 1), the free
  velocity and the active contacts' rows (:func:`contact_rows_into`);
* :func:`block_inverses`: the inverse of M's diagonal blocks (the coordinate groups) by
  Cholesky;
* :func:`contact_rows_into`: the active set by gap prediction and the contact problem's
  ``b`` with Newton's restitution, into preallocated buffers;
* :func:`advance`: ``q_{k+1} = q_m + h theta v_{k+1}`` into the recorded rows;
* :func:`model_series`: the recorded run's momenta, energies and smallest gap, sample by
  sample, on the model's compiled pass;
* :func:`model_support`, :func:`dense_support`: where M and the contact Jacobians can be
  nonzero (below).

**Supports.** The model's compiled pass writes M_ij only where coordinate i is an ancestor
of j or j of i in its tree of coordinates (the composite-rigid-body algorithm; entries of
two coordinates on different branches are never written and stay zero), and contact c's
Jacobian only in the columns of the ancestors of its two bodies' nodes (its rows are zeroed,
then those columns written). :func:`model_support` reads these supports from the model's
tables; the predictor scans M only on its support (``msup``, the flat indices of the
ancestor pairs) and reads and copies each contact's Jacobian only on its columns
(``jcol[joff[c]:joff[c + 1]]``), with the same sums in the same order without their exact
zero terms (hence the same numbers bit for bit: a sum that starts at +0 and skips terms
``0 * x`` with x finite is unchanged). The active rows' buffer ``Ja`` keeps, per row, the
contact whose columns it holds (``held``): a row that takes another contact is first
zeroed on the columns of the one it held, so ``Ja`` is always the dense copy.
:class:`.moreau_loop.ModelPredictor` certifies the supports on the model's own evaluation
whenever it regroups (every entry outside them exactly zero), else it falls back to
:func:`dense_support`.

Status codes of :func:`predict_model`: :data:`OK`, :data:`REGROUP` (M has a nonzero outside
the cached coordinate groups: regroup and call again), :data:`NOT_DEFINITE` (a block of M is
not positive definite), :data:`NOT_FINITE` (M is not finite) and the model's own error bits
shifted by :data:`EVAL_SHIFT` (the caller re-runs the evaluation through the model's Python
entry, which raises its typed error).
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import jit as _jit
from ..model.recursive import (BIAS, CI_AI, CI_AJ, CIC, CONTACT, H_K, H_NC, H_OFF, HAS_V,
                               I_CI, I_NI, MASS, N_WORK, NI_PARENT, NIC, evaluate)

OK, REGROUP, NOT_DEFINITE, NOT_FINITE = 0, 1, 2, 3
EVAL_SHIFT = 8
#: the model's error bits (non-finite or wrongly shaped state)
_EVAL_ERRORS = 1 | 2 | 32 | 64
#: a contact whose predicted end-of-step gap is at most gap_tol + this (times max(1, max|q|))
#: takes part: round-off of the configuration, not an opening
GAP_ROUNDOFF = 1e-12
_POSITIONS = MASS | CONTACT
_FORCES = BIAS | HAS_V


def _chain(parent: np.ndarray, node: int) -> list:
    """The node and its ancestors (-1: the ground, none)."""
    out = []
    while node >= 0:
        out.append(int(node))
        node = int(parent[node])
    return out


def model_support(work: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(msup, jcol, joff)`` of the model whose work buffer is ``work`` (module docstring):
    the sorted flat indices (i k + j) of the ancestor pairs of its coordinates (each
    coordinate with itself included) and, per contact c, the sorted columns
    ``jcol[joff[c]:joff[c + 1]]`` of the ancestors of its two bodies' nodes."""
    itab = work.view(np.int64)
    k, nc = int(itab[H_K]), int(itab[H_NC])
    io = H_OFF + N_WORK
    o = int(itab[io + I_NI])
    parent = itab[o:o + k * NIC].reshape((k, NIC))[:, NI_PARENT]
    o = int(itab[io + I_CI])
    ci = itab[o:o + nc * CIC].reshape((nc, CIC))
    flat = set()
    for j in range(k):
        for i in _chain(parent, j):
            flat.add(i * k + j)
            flat.add(j * k + i)
    cols = [sorted(set(_chain(parent, int(ci[c, CI_AI])) + _chain(parent, int(ci[c, CI_AJ]))))
            for c in range(nc)]
    off = np.concatenate([[0], np.cumsum([len(x) for x in cols])]).astype(np.int64)
    jcol = np.array([a for x in cols for a in x], dtype=np.int64)
    return np.array(sorted(flat), dtype=np.int64), jcol, off


def dense_support(nc: int, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The supports of :func:`model_support` holding every entry (any M and Jacobians)."""
    return (np.arange(k * k, dtype=np.int64), np.tile(np.arange(k, dtype=np.int64), nc),
            (k * np.arange(nc + 1)).astype(np.int64))


@_jit
def block_inverses(Mflat, flat, s, out):
    """Invert the SPD blocks ``Mflat[flat]`` (n_blocks of s x s, row-major) into
    ``out[flat]`` by Cholesky; returns False (out undefined) when a block is not positive
    definite or not finite."""
    nb = flat.shape[0] // (s * s)
    L = np.empty((s, s))
    Li = np.empty((s, s))
    for b in range(nb):
        o = b * s * s
        for i in range(s):
            for j in range(i + 1):
                v = Mflat[flat[o + i * s + j]]
                for p in range(j):
                    v -= L[i, p] * L[j, p]
                if i == j:
                    if not (v > 0.0) or not math.isfinite(v):
                        return False
                    L[i, i] = math.sqrt(v)
                else:
                    L[i, j] = v / L[j, j]
        # Li = L^-1 (lower)
        for j in range(s):
            for i in range(s):
                Li[i, j] = 0.0
            Li[j, j] = 1.0 / L[j, j]
            for i in range(j + 1, s):
                v = 0.0
                for p in range(j, i):
                    v -= L[i, p] * Li[p, j]
                Li[i, j] = v / L[i, i]
        # M^-1 = Li^T Li
        for i in range(s):
            for j in range(s):
                v = 0.0
                for p in range(max(i, j), s):
                    v += Li[p, i] * Li[p, j]
                out[flat[o + i * s + j]] = v
    return True


@_jit
def contact_rows_into(gaps, J, v, v_free, e, h_theta, limit, rest_velocity, active, Ja, b,
                      vn_k, jcol, joff, held):
    """The step's active contacts and their data, into the buffers; returns their number.

    A contact is active when ``gaps[c] + h_theta J_n v_free <= limit``. Fills ``active``
    (indices), ``Ja`` (their Jacobian rows), ``b = J v_free`` with Newton's restitution
    ``e_eff min(v_n,free, 0)`` added to the normal (``e_eff = min(e v_n,k / v_n,free, 1)``
    on contacts approaching at the step's start, ``v_n,k < -rest_velocity`` and
    ``v_n,free < 0``; 0 otherwise) and ``vn_k``, the normal velocities at the start.
    Contact c's row is read on its columns ``jcol[joff[c]:joff[c + 1]]`` only (zero
    elsewhere); ``held[i]``: the contact whose columns row i of ``Ja`` holds (-1: none),
    updated (module docstring).
    """
    nc, d, k = J.shape
    i = 0
    for c in range(nc):
        c0, c1 = joff[c], joff[c + 1]
        vnf = 0.0
        for t in range(c0, c1):
            a = jcol[t]
            vnf += J[c, 0, a] * v_free[a]
        if not (gaps[c] + h_theta * vnf <= limit):
            continue
        active[i] = c
        old = held[i]
        if old != c:
            if old >= 0:
                for t in range(joff[old], joff[old + 1]):
                    a = jcol[t]
                    for r in range(d):
                        Ja[i, r, a] = 0.0
            held[i] = c
        for r in range(d):
            s = 0.0
            for t in range(c0, c1):
                a = jcol[t]
                Ja[i, r, a] = J[c, r, a]
                s += J[c, r, a] * v_free[a]
            b[i, r] = s
        s = 0.0
        for t in range(c0, c1):
            a = jcol[t]
            s += J[c, 0, a] * v[a]
        vn_k[i] = s
        if s < -rest_velocity and vnf < 0.0:
            b[i, 0] += min(e[c] * s / vnf, 1.0) * vnf
        i += 1
    return i


@_jit
def block_times(A, gflat, gsize, goff, x, out):
    """``out = A x`` for A (k, k) zero outside the coordinate groups' blocks (flat indices
    ``gflat``, per size ``gsize[s]`` those at ``goff[s]:goff[s + 1]``, each block row-major
    over its sorted coordinates): the dense product's sums, in its order, without the
    zeros."""
    k = x.shape[0]
    Af = A.reshape(-1)
    for i in range(k):
        out[i] = 0.0
    for s in range(gsize.shape[0]):
        for f0 in range(goff[s], goff[s + 1]):
            f = gflat[f0]
            i = f // k
            out[i] += Af[f] * x[f - i * k]


@_jit
def predict_model(work, Mv, gapv, Jv, biasv, q, v, hk, theta, gflat, gsize, goff, inside,
                  Minv, qm, vtmp, vfree, e, gap_tol, rest_velocity, active, Ja, b, vn_k, msup,
                  jcol, joff, held):
    """The predictor of a step (module docstring) from ``(q, v)`` with step ``hk``.

    ``Mv, gapv, Jv, biasv``: the model's views of M, the gaps, the contact Jacobians
    (n_contacts, d, k) and f in ``work``. The coordinate groups: blocks of size
    ``gsize[s]`` with flat indices ``gflat[goff[s]:goff[s + 1]]`` into M; ``inside`` (k k)
    marks their entries. ``msup``, ``jcol``, ``joff``, ``held``: the supports of M and of
    the contacts' Jacobians and the rows' contacts (module docstring): M is scanned (finite,
    nonzeros inside the groups) on ``msup`` only. Writes ``Minv``, ``qm``, ``vfree`` and the
    active rows; returns ``(status, n_active)``.
    """
    k = q.shape[0]
    c1 = hk * (1.0 - theta)
    for i in range(k):
        qm[i] = q[i] + c1 * v[i]
    code = evaluate(_POSITIONS, qm, qm, work)
    if code & _EVAL_ERRORS:
        return code << EVAL_SHIFT, 0
    Mflat = Mv.reshape(-1)
    outside = False
    for t in range(msup.shape[0]):
        f = msup[t]
        x = Mflat[f]
        if not math.isfinite(x):
            return NOT_FINITE, 0
        if x != 0.0 and not inside[f]:
            outside = True
    if outside:
        return REGROUP, 0
    Iflat = Minv.reshape(-1)
    for s in range(gsize.shape[0]):
        if not block_inverses(Mflat, gflat[goff[s]:goff[s + 1]], gsize[s], Iflat):
            return NOT_DEFINITE, 0
    code = evaluate(_FORCES, qm, v, work)
    if code & _EVAL_ERRORS:
        return code << EVAL_SHIFT, 0
    if theta < 1.0:
        block_times(Minv, gflat, gsize, goff, biasv, vfree)
        for i in range(k):
            vtmp[i] = v[i] + c1 * vfree[i]
        code = evaluate(_FORCES, qm, vtmp, work)
        if code & _EVAL_ERRORS:
            return code << EVAL_SHIFT, 0
    block_times(Minv, gflat, gsize, goff, biasv, vfree)
    for i in range(k):
        vfree[i] = v[i] + hk * vfree[i]
    qmax = 1.0
    for i in range(k):
        qmax = max(qmax, abs(qm[i]))
    na = contact_rows_into(gapv, Jv, v, vfree, e, hk * theta,
                           gap_tol + GAP_ROUNDOFF * qmax, rest_velocity, active, Ja, b, vn_k,
                           jcol, joff, held)
    return OK, na


@_jit
def advance(qm, v_new, h_theta, q_out, v_out):
    """``q_out = qm + h_theta v_new``, ``v_out = v_new``; False when either is not finite."""
    ok = True
    for i in range(qm.shape[0]):
        x = qm[i] + h_theta * v_new[i]
        q_out[i] = x
        v_out[i] = v_new[i]
        if not (math.isfinite(x) and math.isfinite(v_new[i])):
            ok = False
    return ok


@_jit
def model_series(work, Mv, gapv, pos3, rot3, body_mass, body_com, gravity, thetas, dthetas,
                 p, T, V, msup):
    """Per recorded sample: ``p = M v``, ``T = v M v / 2``, the gravitational potential
    ``V = -sum_b m_b g . c_b`` and the smallest gap (returned, +inf without contacts).
    M v is summed on M's support ``msup`` (sorted flat indices, module docstring): the dense
    product's sums in its order without their zero terms."""
    n, k = thetas.shape
    nb = body_mass.shape[0]
    gmin = np.inf
    q = np.empty(k)
    for s in range(n):
        for i in range(k):
            q[i] = thetas[s, i]
        evaluate(_POSITIONS, q, q, work)
        Mflat = Mv.reshape(-1)
        for i in range(k):
            p[s, i] = 0.0
        for u in range(msup.shape[0]):
            f = msup[u]
            i = f // k
            p[s, i] += Mflat[f] * dthetas[s, f - i * k]
        t = 0.0
        for i in range(k):
            t += dthetas[s, i] * p[s, i]
        T[s] = 0.5 * t
        e = 0.0
        for bb in range(nb):
            for a in range(3):
                c = pos3[bb, a]
                for j in range(3):
                    c += rot3[bb, a, j] * body_com[bb, j]
                e -= body_mass[bb] * gravity[a] * c
        V[s] = e
        for c in range(gapv.shape[0]):
            gmin = min(gmin, gapv[c])
    return gmin
