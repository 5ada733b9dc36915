"""The entry point of the compiled recursive algorithms: :func:`evaluate`.

One call from Python per request: it compares the state (theta, theta_dot) with the one the
work buffer holds, drops the stages that changed, and runs the stages asked for that are
missing, with their prerequisites (:func:`~convimpact.model.tree_layout.closures`), in
order: placements and velocities (:mod:`~convimpact.model.tree_kinematics`), inertias, M,
its Cholesky factor, f and p_dot, M_dot (:mod:`~convimpact.model.tree_dynamics`), the contacts
and their rates (:mod:`~convimpact.model.tree_contacts`).

No input is validated here except the length and finiteness of theta and theta_dot (codes
``R_BAD_SHAPE_*``, ``R_NON_FINITE_*``); :func:`evaluate` is compiled for one signature
(:data:`~convimpact.model.tree_layout.EVALUATE_SIGNATURE`) and
:class:`~convimpact.model.data.Data` closes it to others, so any other argument type raises
TypeError (and Data converts it) instead of compiling.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import jit
from .compiled_algebra import _cholesky
from .tree_contacts import _contacts, _contacts_dot
from .tree_dynamics import _bias, _crba, _inertias, _mass_matrix_dot
from .tree_kinematics import _positions, _velocities
from .tree_layout import (BIAS, BWC, CDOT, CHOL, CIC, CONTACT, CPOS, CWC, HAS_V, H_K, H_NB, H_NC,
                          H_NCS, H_OFF, H_PLANAR, INERTIA, I_BI, I_CI, I_CL, I_CS, I_NI, MASS, MDOT,
                          META_CHOL, META_DONE, META_HAS_Q, META_HAS_V, MWC, NIC, NWC, N_FLAGS,
                          N_SCR, N_WORK, OK, POS, Q_FLAGS, R_BAD_SHAPE_Q, R_BAD_SHAPE_V,
                          R_NON_FINITE_Q, R_NON_FINITE_V, R_NOT_DEFINITE, R_Q_CHANGED, R_V_CHANGED,
                          SC_META, VEL, V_DTHETA, V_THETA, W_BODY, W_CJ, W_CJD, W_CON, W_L, W_M,
                          W_MD, W_MW, W_NODE, W_SCR, W_VEC, W_YD)


@jit
def evaluate(flags, theta, dtheta, work):
    """Bring the stages in ``flags`` (and the stages they need) up to date at (theta,
    theta_dot); return a code of ``R_*`` bits (0: nothing new, nothing wrong).

    The buffer remembers the state it holds and the stages that are current, so a call at
    the same state runs only what is missing. Without the :data:`HAS_V` bit in ``flags`` the
    velocity held is kept (zero when none is; ``dtheta`` is then ignored). After a failed
    Cholesky (``R_NOT_DEFINITE``) the other stages still run. The buffer's first words are
    the integer table (read through an int64 view).
    """
    itab = work.view(np.int64)
    has_dtheta = flags & HAS_V != 0
    flags &= N_FLAGS - 1
    k = itab[H_K]
    if theta.shape[0] != k:
        return R_BAD_SHAPE_Q
    if has_dtheta and dtheta.shape[0] != k:
        return R_BAD_SHAPE_V
    nb = itab[H_NB]
    nc = itab[H_NC]
    n = k + 1
    planar = itab[H_PLANAR] != 0
    io = H_OFF + N_WORK
    o = itab[H_OFF + W_VEC]
    vec = work[o:o + 4 * k].reshape((4, k))
    o = itab[H_OFF + W_SCR]
    scr = work[o:o + N_SCR * 36].reshape((N_SCR, 36))
    done = int(scr[SC_META, META_DONE])
    has_q = scr[SC_META, META_HAS_Q] != 0.0
    has_v = scr[SC_META, META_HAS_V] != 0.0
    code = 0
    same = has_q
    if same:
        for j in range(k):
            if theta[j] != vec[V_THETA, j]:
                same = False
                break
    if not same:
        done = 0
        has_v = False
        code |= R_Q_CHANGED
    if has_dtheta and flags & ~Q_FLAGS:
        same = has_v
        if same:
            for j in range(k):
                if dtheta[j] != vec[V_DTHETA, j]:
                    same = False
                    break
        if not same:
            done &= Q_FLAGS
            has_v = False
            code |= R_V_CHANGED
    o = itab[io + I_CL]
    need = itab[o + (flags & ~done)] & ~done
    if need == 0:
        scr[SC_META, META_DONE] = done
        scr[SC_META, META_HAS_V] = 1.0 if has_v else 0.0
        return code
    o = itab[io + I_NI]
    ni = itab[o:o + k * NIC].reshape((k, NIC))
    o = itab[io + I_BI]
    bi = itab[o:o + nb].reshape((nb, 1))
    o = itab[io + I_CS]
    ncs = itab[H_NCS]
    csup = itab[o:o + ncs]
    o = itab[H_OFF + W_NODE]
    node = work[o:o + n * NWC].reshape((n, NWC))
    o = itab[H_OFF + W_BODY]
    body = work[o:o + nb * BWC].reshape((nb, BWC))
    if need & (POS | CPOS):
        for j in range(k):
            q = theta[j]
            if not math.isfinite(q):
                scr[SC_META, META_DONE] = 0.0
                scr[SC_META, META_HAS_Q] = 0.0
                scr[SC_META, META_HAS_V] = 0.0
                return R_NON_FINITE_Q
            vec[V_THETA, j] = q
        scr[SC_META, META_HAS_Q] = 1.0
        if need & POS:
            _positions(ni, bi, vec, node, body, scr, k, nb, csup, -1)
        else:
            _positions(ni, bi, vec, node, body, scr, k, nb, csup, ncs)
    if need & VEL:
        for j in range(k):
            q = dtheta[j] if has_dtheta else 0.0
            if not math.isfinite(q):
                scr[SC_META, META_DONE] = done & Q_FLAGS
                scr[SC_META, META_HAS_V] = 0.0
                return R_NON_FINITE_V
            vec[V_DTHETA, j] = q
        has_v = True
    flags = need
    if flags & INERTIA:
        _inertias(node, scr, k)
    if flags & (MASS | CHOL):
        o = itab[H_OFF + W_M]
        M = work[o:o + k * k].reshape((k, k))
        if flags & MASS:
            _crba(ni, node, M, scr, k)
        if flags & CHOL:
            o = itab[H_OFF + W_L]
            L = work[o:o + k * k].reshape((k, k))
            ok = _cholesky(M, L, k) == OK
            scr[SC_META, META_CHOL] = 1.0 if ok else 0.0
            if not ok:
                code |= R_NOT_DEFINITE
    if flags & VEL:
        _velocities(ni, bi, vec, node, body, k, nb)
    if flags & BIAS:
        _bias(ni, vec, node, scr, k)
    if flags & (CONTACT | CDOT) and nc > 0:
        o = itab[io + I_CI]
        ci = itab[o:o + nc * CIC].reshape((nc, CIC))
        o = itab[H_OFF + W_CON]
        con = work[o:o + nc * CWC].reshape((nc, CWC))
        if flags & CONTACT:
            o = itab[H_OFF + W_CJ]
            cj = work[o:o + nc * 3 * k].reshape((nc, 3, k))
            _contacts(ni, ci, node, con, cj, scr, k, nc, planar)
        if flags & CDOT:
            o = itab[H_OFF + W_CJD]
            cjd = work[o:o + nc * 3 * k].reshape((nc, 3, k))
            _contacts_dot(ni, ci, node, con, cjd, scr, k, nc, planar)
    if flags & MDOT:
        o = itab[H_OFF + W_MD]
        MD = work[o:o + k * k].reshape((k, k))
        o = itab[H_OFF + W_YD]
        YD = work[o:o + n * 36].reshape((n, 36))
        o = itab[H_OFF + W_MW]
        mw = work[o:o + n * MWC].reshape((n, MWC))
        _mass_matrix_dot(ni, node, YD, MD, mw, scr, k)
    done |= need
    if need & POS:
        done |= CPOS
    scr[SC_META, META_DONE] = done
    scr[SC_META, META_HAS_V] = 1.0 if has_v else 0.0
    return code
