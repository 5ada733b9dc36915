"""The batch loops of the compiled kernels: the two drivers.

Each item goes through :func:`convimpact.impact.laws.table.contact_item` (separating, W_nn > 0,
the safe range of W's trace and v -- else the item is deferred to solve_contact, which
rescales by powers of two -- mu = 0, then the law's kernel, chosen at compile time by the
law's code and the dimension);
* :func:`contact_batch`: every item from (W, v), with v+ and the energy loss;
* :func:`impact_batch`: every item from (M, Jc, dq): validates M (finite, symmetric,
  Cholesky), forms W = Jc M^-1 Jc^T and v- = Jc dq, solves, maps the impulse back to dq+ and
  measures :func:`convimpact.impact.diagnostics.assemble_result`'s flags.
"""

from __future__ import annotations

import math

import numpy as np

from ...compiled import literally
from ..laws.table import contact_item as _contact_item
from ..laws.codes import (BAD_DQ_FINITE, BAD_J_FINITE, BAD_M_DEFINITE, BAD_M_FINITE,
                          BAD_M_SYMMETRY, BAD_OVERFLOW, BAD_W_FINITE, DEFER, FAILED, OK,
                          OUT_SIZE, SLIDE, SYMMETRY_RTOL, _NAN, _jit, _pmax2)


# --------------------------------------------------------------------------------------------
# driver from (W, v)


@_jit
def contact_batch(law, dim, W, v, e, mu, et, impulse, regime, status, effm, vplus, eloss):
    """Every item of a batch of contacts from (W, v) under law code ``law`` in dimension
    ``dim`` (= ``impulse.shape[1]``; both compiled as constants: each law and dimension
    compiles its own driver, with that one kernel); arrays with a leading dimension 1 are
    shared by every item. Returns (first item with non-finite data or -1, deferred count)."""
    literally(law)
    literally(dim)
    n = impulse.shape[0]
    d = impulse.shape[1]
    bw = W.shape[0] > 1
    bv = v.shape[0] > 1
    be = e.shape[0] > 1
    bm = mu.shape[0] > 1
    bt = et.shape[0] > 1
    first_bad = -1
    ndefer = 0
    out = np.empty(OUT_SIZE)  # the kernels' extras (not read by the batch)
    for i in range(n):
        iw = i if bw else 0
        iv = i if bv else 0
        w00, w01, w11 = W[iw, 0, 0], W[iw, 0, 1], W[iw, 1, 1]
        v0, v1 = v[iv, 0], v[iv, 1]
        w02, w12, w22, v2 = 0.0, 0.0, 0.0, 0.0
        if d == 3:
            w02, w12, w22, v2 = W[iw, 0, 2], W[iw, 1, 2], W[iw, 2, 2], v[iv, 2]
        ei = e[i if be else 0]
        mi = mu[i if bm else 0]
        ti = et[i if bt else 0]
        fin = w00 + w01 + w11 + v0 + v1 + w02 + w12 + w22 + v2
        if d == 3:
            fin += W[iw, 1, 0] + W[iw, 2, 0] + W[iw, 2, 1]
        else:
            fin += W[iw, 1, 0]
        if not math.isfinite(fin):
            # round-off cannot overflow a sum of finite doubles below 1e307; recheck exactly
            bad = not (math.isfinite(w00) and math.isfinite(w01) and math.isfinite(w11)
                       and math.isfinite(v0) and math.isfinite(v1) and math.isfinite(w02)
                       and math.isfinite(w12) and math.isfinite(w22) and math.isfinite(v2))
            for a in range(d):
                for b in range(d):
                    if not math.isfinite(W[iw, a, b]):
                        bad = True
            if bad:
                status[i] = BAD_W_FINITE
                regime[i] = FAILED
                if first_bad < 0:
                    first_bad = i
                for a in range(d):
                    impulse[i, a] = _NAN
                    vplus[i, a] = _NAN
                effm[i] = _NAN
                eloss[i] = _NAN
                continue
        st, rg, p0, p1, p2, em = _contact_item(law, dim, w00, w01, w02, w11, w12, w22, v0, v1,
                                               v2, ei, mi, ti, out)
        status[i] = st
        regime[i] = rg
        effm[i] = em if st == OK else _NAN
        if st == DEFER:
            ndefer += 1
        impulse[i, 0] = p0
        impulse[i, 1] = p1
        if d == 3:
            impulse[i, 2] = p2
        if st != OK:
            for a in range(d):
                vplus[i, a] = _NAN
            eloss[i] = _NAN
            continue
        # v+ = v + W pi and T_L = -(pi.v + 1/2 pi.W.pi), W read from its upper triangle
        if d == 2:
            u0 = w00 * p0 + w01 * p1
            u1 = w01 * p0 + w11 * p1
            vplus[i, 0] = v0 + u0
            vplus[i, 1] = v1 + u1
            eloss[i] = -(p0 * v0 + p1 * v1 + 0.5 * (p0 * u0 + p1 * u1))
        else:
            u0 = w00 * p0 + w01 * p1 + w02 * p2
            u1 = w01 * p0 + w11 * p1 + w12 * p2
            u2 = w02 * p0 + w12 * p1 + w22 * p2
            vplus[i, 0] = v0 + u0
            vplus[i, 1] = v1 + u1
            vplus[i, 2] = v2 + u2
            eloss[i] = -(p0 * v0 + p1 * v1 + p2 * v2 + 0.5 * (p0 * u0 + p1 * u1 + p2 * u2))
    return first_bad, ndefer


# --------------------------------------------------------------------------------------------
# driver from (M, Jc, dq)
#
# One function with the linear algebra written out: small helpers taking arrays would make
# numba count references on every call (atomic operations that cost more than the algebra).



@_jit
def impact_batch(law, dim, M, J, dq, e, mu, et, tol, idx, given, dq_plus, impulse, v_minus, v_plus, W,
                 regime, status, effm, mu_eff, energy_before, energy_after, flags):
    """Every impact of a batch from (M, Jc, dq) (leading dimension 1 = shared): validate M
    (finite, symmetric, Cholesky), reduce to W = X^T X with X = L^-1 Jc^T and v- = Jc dq, solve,
    map back (dq+ = dq + L^-T X pi, v+ = v- + W pi) and measure assemble_result's flags.

    With a non-empty ``idx`` only those items are (re)done, with the impulses ``given`` (one
    row per item; ``regime`` already set): the completion of items solve_contact solved
    (those outside the compiled range of scale).

    Returns (first item with bad input or -1, deferred count). ``flags`` columns:
    energy_gained, friction_pushes_slip, slip_reversal, penetration; ``mu_eff`` receives the
    friction actually used (0 where the tangent directions move no mass, as build_problem).
    ``law`` and ``dim`` (= ``impulse.shape[1]``) are compiled as constants, as in
    :func:`contact_batch`.
    """
    literally(law)
    literally(dim)
    n = dq_plus.shape[0]
    k = dq_plus.shape[1]
    d = impulse.shape[1]
    L = np.zeros((k, k))
    rd = np.zeros(k)
    X = np.empty((k, d))
    z = np.empty(k)
    w = np.zeros((3, 3))
    vm = np.zeros(3)
    p = np.zeros(3)
    out = np.empty(OUT_SIZE)  # the kernels' extras (not read by the batch)
    bM = M.shape[0] > 1
    bJ = J.shape[0] > 1
    bq = dq.shape[0] > 1
    be = e.shape[0] > 1
    bm = mu.shape[0] > 1
    bt = et.shape[0] > 1
    redo = idx.shape[0] > 0
    count = idx.shape[0] if redo else n
    first_bad = -1
    ndefer = 0
    mstat = 0
    jok = True
    last_im = -1
    last_ij = -1
    tiny = 1e-300
    for t in range(count):
        i = idx[t] if redo else t
        im = i if bM else 0
        ij = i if bJ else 0
        iq = i if bq else 0
        new_m = im != last_im
        if new_m:
            last_im = im
            # M: finite, symmetric, L = chol((M + M^T) / 2), rd = 1 / diag(L)
            mstat = 0
            fin = 0.0
            scale = 0.0
            asym = 0.0
            for a in range(k):
                x = M[im, a, a]
                fin += x
                scale = _pmax2(scale, abs(x))
                L[a, a] = x
                for b in range(a + 1, k):
                    x = M[im, b, a]
                    y = M[im, a, b]
                    fin += x + y
                    scale = _pmax2(_pmax2(scale, abs(x)), abs(y))
                    asym = _pmax2(asym, abs(x - y))
                    L[b, a] = 0.5 * (x + y)
            if not math.isfinite(fin):
                for a in range(k):
                    for b in range(k):
                        if not math.isfinite(M[im, a, b]):
                            mstat = BAD_M_FINITE
            if mstat == 0 and asym > SYMMETRY_RTOL * _pmax2(scale, tiny):
                mstat = BAD_M_SYMMETRY
            if mstat == 0:
                for j in range(k):
                    s = L[j, j]
                    for m in range(j):
                        s -= L[j, m] * L[j, m]
                    if not s > 0.0:
                        mstat = BAD_M_DEFINITE
                        break
                    ljj = math.sqrt(s)
                    L[j, j] = ljj
                    r = 1.0 / ljj
                    rd[j] = r
                    for a in range(j + 1, k):
                        x = L[a, j]
                        for m in range(j):
                            x -= L[a, m] * L[j, m]
                        L[a, j] = x * r
        if mstat == 0 and (new_m or ij != last_ij):
            last_ij = ij
            # X = L^-1 Jc^T and W = X^T X
            fin = 0.0
            for c in range(d):
                for a in range(k):
                    x = J[ij, c, a]
                    fin += x
                    for m in range(a):
                        x -= L[a, m] * X[m, c]
                    X[a, c] = x * rd[a]
            jok = True
            if not math.isfinite(fin):
                for c in range(d):
                    for a in range(k):
                        if not math.isfinite(J[ij, c, a]):
                            jok = False
            for a in range(d):
                for b in range(a, d):
                    s = 0.0
                    for m in range(k):
                        s += X[m, a] * X[m, b]
                    w[a, b] = s
                    w[b, a] = s
        elif mstat != 0:
            last_ij = -1
        T = 0.0
        bad = 0
        if mstat != 0:
            bad = mstat
        elif not jok:
            bad = BAD_J_FINITE
        else:
            # v- = Jc dq, T- = 1/2 |L^T dq|^2
            fin = 0.0
            for c in range(d):
                s = 0.0
                for a in range(k):
                    s += J[ij, c, a] * dq[iq, a]
                vm[c] = s
                fin += s
            for a in range(k):
                s = 0.0
                for m in range(a, k):
                    s += L[m, a] * dq[iq, m]
                T += s * s
            T *= 0.5
            for a in range(d):
                for b in range(d):
                    fin += w[a, b]
            if not math.isfinite(fin + T):
                bad = BAD_OVERFLOW
                for a in range(k):
                    if not math.isfinite(dq[iq, a]):
                        bad = BAD_DQ_FINITE
        if bad != 0:
            status[i] = bad
            regime[i] = FAILED
            if first_bad < 0:
                first_bad = i
            continue
        if redo:
            for a in range(d):
                p[a] = given[t, a]
            rg = regime[i]
        else:
            for a in range(d):
                v_minus[i, a] = vm[a]
                for b in range(d):
                    W[i, a, b] = w[a, b]
            energy_before[i] = T
            ei = e[i if be else 0]
            mi = mu[i if bm else 0]
            ti = et[i if bt else 0]
            # build_problem: tangent directions that move no mass take no friction
            tmax = w[1, 1]
            if d == 3 and w[2, 2] > tmax:
                tmax = w[2, 2]
            dmax = abs(w[0, 0])
            for a in range(1, d):
                if abs(w[a, a]) > dmax:
                    dmax = abs(w[a, a])
            if tmax <= 1e-14 * _pmax2(dmax, tiny) and mi > 0.0:
                mi = 0.0
            mu_eff[i] = mi
            st, rg, p0, p1, p2, em = _contact_item(law, dim, w[0, 0], w[0, 1], w[0, 2],
                                                   w[1, 1], w[1, 2], w[2, 2], vm[0], vm[1],
                                                   vm[2], ei, mi, ti, out)
            status[i] = st
            regime[i] = rg
            effm[i] = em if st == OK else _NAN
            if st != OK:
                if st == DEFER:
                    ndefer += 1
                for a in range(d):
                    impulse[i, a] = _NAN
                    v_plus[i, a] = _NAN
                for a in range(k):
                    dq_plus[i, a] = _NAN
                energy_after[i] = _NAN
                continue
            p[0] = p0
            p[1] = p1
            p[2] = p2
        # dq+ = dq + L^-T (X pi)
        for a in range(k):
            s = 0.0
            for c in range(d):
                s += X[a, c] * p[c]
            z[a] = s
        for a in range(k - 1, -1, -1):
            s = z[a]
            for m in range(a + 1, k):
                s -= L[m, a] * z[m]
            z[a] = s * rd[a]
            dq_plus[i, a] = dq[iq, a] + z[a]
        # v+ = v- + W pi, T+ - T- = pi.v- + 1/2 pi.W.pi, and the flags (assemble_result)
        pv = 0.0
        pwp = 0.0
        pn2 = 0.0
        npt2 = 0.0
        nvm2 = 0.0
        nvp2 = 0.0
        ptvm = 0.0
        ptvp = 0.0
        vs = 0.0
        for a in range(d):
            s = 0.0
            for b in range(d):
                s += w[a, b] * p[b]
            vp = vm[a] + s
            v_plus[i, a] = vp
            impulse[i, a] = p[a]
            pa = p[a]
            pv += pa * vm[a]
            pwp += pa * s
            pn2 += pa * pa
            vs = _pmax2(vs, abs(vm[a]))
            if a > 0:
                npt2 += pa * pa
                nvm2 += vm[a] * vm[a]
                nvp2 += vp * vp
                ptvm += pa * vm[a]
                ptvp += pa * vp
        dT = pv + 0.5 * pwp
        energy_after[i] = T + dT
        pi_scale = _pmax2(math.sqrt(pn2), tiny)
        v_scale = _pmax2(vs, tiny)
        npt = math.sqrt(npt2)
        nvm = math.sqrt(nvm2)
        nvp = math.sqrt(nvp2)
        acting = npt > tol * pi_scale
        flags[i, 0] = dT > tol * _pmax2(T, tiny) * 10.0
        flags[i, 1] = acting and ptvm > tol * npt * nvm
        slipping = nvp > tol * 10.0 * v_scale
        flags[i, 2] = rg == SLIDE and slipping and acting and ptvp > tol * npt * nvp
        flags[i, 3] = v_plus[i, 0] < -tol * 10.0 * v_scale
    return first_bad, ndefer
