"""Contacts of the tree, compiled: gaps, contact frames, Jacobians and their time derivatives.

Per contact (a point or sphere of body i against a plane or sphere of body j): the gap, the
frame ``(n, t1, t2)`` (``(n, t)`` planar; ``t1`` of a sphere-sphere normal by
:func:`_complement`, as :func:`convimpact.model.geometry.orthonormal_complement`) and the
Jacobian ``Jc[r, s] = S_s . w_r`` with the unit wrench ``w_r = (e_r, x x e_r)`` of frame axis
e_r at the contact point x, body j's side subtracted (stage ``CONTACT``, :func:`_contacts`);
and ``Jc_dot[r, s] = S_dot_s . w_r + S_s . w_dot_r`` (stage ``CDOT``, :func:`_contacts_dot`):
the contact point and the frame move with the bodies, so this is the exact total derivative
along theta_dot.
"""

from __future__ import annotations

import math

from ..compiled import jit_internal
from .compiled_algebra import _cross, _mv
from .tree_layout import (CI_AI, CI_AJ, CI_TARGET, CW_C, CW_E, CW_ED, CW_GAP, CW_NJ, CW_OK, CW_PI,
                          CW_PJ, CW_RI, CW_RJ, CW_TJ, CW_X, CW_XD, NI_PARENT, NW_P, NW_R, NW_S,
                          NW_SD, NW_V, PLANE, SC_W)


@jit_internal
def _complement(n0, n1, n2):
    """(t1, t2) of :func:`convimpact.model.geometry.orthonormal_complement`."""
    a0, a1, a2 = abs(n0), abs(n1), abs(n2)
    if a0 <= a1 and a0 <= a2:
        e0, e1, e2 = 1.0, 0.0, 0.0
    elif a1 <= a2:
        e0, e1, e2 = 0.0, 1.0, 0.0
    else:
        e0, e1, e2 = 0.0, 0.0, 1.0
    en = e0 * n0 + e1 * n1 + e2 * n2
    t0, t1, t2 = e0 - en * n0, e1 - en * n1, e2 - en * n2
    tn = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    t0, t1, t2 = t0 / tn, t1 / tn, t2 / tn
    u0, u1, u2 = _cross(n0, n1, n2, t0, t1, t2)
    return t0, t1, t2, u0, u1, u2


@jit_internal
def _complement_dot(n0, n1, n2, m0, m1, m2):
    """Time derivative of :func:`_complement` along n_dot = (m0, m1, m2): (t1_dot, t2_dot)."""
    a0, a1, a2 = abs(n0), abs(n1), abs(n2)
    if a0 <= a1 and a0 <= a2:
        e0, e1, e2 = 1.0, 0.0, 0.0
    elif a1 <= a2:
        e0, e1, e2 = 0.0, 1.0, 0.0
    else:
        e0, e1, e2 = 0.0, 0.0, 1.0
    en = e0 * n0 + e1 * n1 + e2 * n2
    em = e0 * m0 + e1 * m1 + e2 * m2
    u0, u1, u2 = e0 - en * n0, e1 - en * n1, e2 - en * n2
    un = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    t0, t1, t2 = u0 / un, u1 / un, u2 / un
    ud0, ud1, ud2 = -em * n0 - en * m0, -em * n1 - en * m1, -em * n2 - en * m2
    tu = t0 * ud0 + t1 * ud1 + t2 * ud2
    td0, td1, td2 = (ud0 - t0 * tu) / un, (ud1 - t1 * tu) / un, (ud2 - t2 * tu) / un
    a0, a1, a2 = _cross(m0, m1, m2, t0, t1, t2)
    b0, b1, b2 = _cross(n0, n1, n2, td0, td1, td2)
    return td0, td1, td2, a0 + b0, a1 + b1, a2 + b2


@jit_internal
def _columns(node, s, con, c, side, rows, sign, out, rate):
    """Contact c's Jacobian entries (or, with ``rate``, their rates) of node s for the rows,
    side 0 (body i, +) or 1 (body j, -): e_r . (S_lin + S_ang x (x - p_s)) and its time
    derivative e_dot_r . col + e_r . (S_dot_lin + S_dot_ang x (x - p_s) + S_ang x x_dot)."""
    x = CW_X + 3 * side
    d0 = con[c, x] - node[s, NW_P]
    d1 = con[c, x + 1] - node[s, NW_P + 1]
    d2 = con[c, x + 2] - node[s, NW_P + 2]
    t0, t1, t2 = _cross(node[s, NW_S + 3], node[s, NW_S + 4], node[s, NW_S + 5], d0, d1, d2)
    c0, c1, c2 = node[s, NW_S] + t0, node[s, NW_S + 1] + t1, node[s, NW_S + 2] + t2
    if not rate:
        for r in range(rows):
            e = CW_E + 3 * r
            out[r] = sign * (con[c, e] * c0 + con[c, e + 1] * c1 + con[c, e + 2] * c2)
        return
    y = CW_XD + 3 * side
    t0, t1, t2 = _cross(node[s, NW_SD + 3], node[s, NW_SD + 4], node[s, NW_SD + 5], d0, d1, d2)
    u0, u1, u2 = _cross(node[s, NW_S + 3], node[s, NW_S + 4], node[s, NW_S + 5],
                        con[c, y], con[c, y + 1], con[c, y + 2])
    g0 = node[s, NW_SD] + t0 + u0
    g1 = node[s, NW_SD + 1] + t1 + u1
    g2 = node[s, NW_SD + 2] + t2 + u2
    for r in range(rows):
        e = CW_E + 3 * r
        f = CW_ED + 3 * r
        out[r] = sign * (con[c, f] * c0 + con[c, f + 1] * c1 + con[c, f + 2] * c2
                         + con[c, e] * g0 + con[c, e + 1] * g1 + con[c, e + 2] * g2)


@jit_internal
def _jacobian_rows(ni, node, con, c, ai, aj, rows, k, cj, out, dot):
    """Contact c's rows of the contact Jacobian (``dot``: of its time derivative) into
    ``cj[c, :, :k]``: the columns of body i's joints and their ancestors, less body j's."""
    for r in range(3):
        for s in range(k):
            cj[c, r, s] = 0.0
    for side in range(2):
        s = ai if side == 0 else aj
        sign = 1.0 if side == 0 else -1.0
        while s >= 0:
            _columns(node, s, con, c, side, rows, sign, out, dot)
            for r in range(rows):
                cj[c, r, s] += out[r]
            s = ni[s, NI_PARENT]


@jit_internal
def _contacts(ni, ci, node, con, cj, scr, k, nc, planar):
    rows = 2 if planar else 3
    for c in range(nc):
        ai, aj = ci[c, CI_AI], ci[c, CI_AJ]
        ri, rj = con[c, CW_RI], con[c, CW_RJ]
        d0, d1, d2 = _mv(node, ai, NW_R, con[c, CW_PI], con[c, CW_PI + 1], con[c, CW_PI + 2])
        pi0, pi1, pi2 = node[ai, NW_P] + d0, node[ai, NW_P + 1] + d1, node[ai, NW_P + 2] + d2
        d0, d1, d2 = _mv(node, aj, NW_R, con[c, CW_PJ], con[c, CW_PJ + 1], con[c, CW_PJ + 2])
        pj0, pj1, pj2 = node[aj, NW_P] + d0, node[aj, NW_P + 1] + d1, node[aj, NW_P + 2] + d2
        con[c, CW_C], con[c, CW_C + 1], con[c, CW_C + 2] = pi0, pi1, pi2
        con[c, CW_C + 3], con[c, CW_C + 4], con[c, CW_C + 5] = pj0, pj1, pj2
        con[c, CW_OK] = 1.0
        if ci[c, CI_TARGET] == PLANE:
            n0, n1, n2 = _mv(node, aj, NW_R, con[c, CW_NJ], con[c, CW_NJ + 1], con[c, CW_NJ + 2])
            con[c, CW_GAP] = n0 * (pi0 - pj0) + n1 * (pi1 - pj1) + n2 * (pi2 - pj2) - ri
            xi0, xi1, xi2 = pi0 - ri * n0, pi1 - ri * n1, pi2 - ri * n2
            xj0, xj1, xj2 = xi0, xi1, xi2
            if planar:
                t0, t1, t2 = -n1, n0, 0.0
                u0, u1, u2 = 0.0, 0.0, 0.0
            else:
                t0, t1, t2 = _mv(node, aj, NW_R, con[c, CW_TJ], con[c, CW_TJ + 1],
                                 con[c, CW_TJ + 2])
                u0, u1, u2 = _cross(n0, n1, n2, t0, t1, t2)
        else:
            e0, e1, e2 = pi0 - pj0, pi1 - pj1, pi2 - pj2
            dist = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            if dist < 1e-12:  # coincident centres: the normal is undefined
                con[c, CW_OK] = 0.0
                dist = 1.0
            n0, n1, n2 = e0 / dist, e1 / dist, e2 / dist
            con[c, CW_GAP] = dist - ri - rj
            xi0, xi1, xi2 = pi0 - ri * n0, pi1 - ri * n1, pi2 - ri * n2
            xj0, xj1, xj2 = pj0 + rj * n0, pj1 + rj * n1, pj2 + rj * n2
            if planar:
                t0, t1, t2 = -n1, n0, 0.0
                u0, u1, u2 = 0.0, 0.0, 0.0
            elif con[c, CW_OK] == 0.0:
                t0, t1, t2, u0, u1, u2 = 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
            else:
                t0, t1, t2, u0, u1, u2 = _complement(n0, n1, n2)
        e = CW_E
        con[c, e], con[c, e + 1], con[c, e + 2] = n0, n1, n2
        con[c, e + 3], con[c, e + 4], con[c, e + 5] = t0, t1, t2
        con[c, e + 6], con[c, e + 7], con[c, e + 8] = u0, u1, u2
        con[c, CW_X], con[c, CW_X + 1], con[c, CW_X + 2] = xi0, xi1, xi2
        con[c, CW_X + 3], con[c, CW_X + 4], con[c, CW_X + 5] = xj0, xj1, xj2
        _jacobian_rows(ni, node, con, c, ai, aj, rows, k, cj, scr[SC_W], False)


@jit_internal
def _contacts_dot(ni, ci, node, con, cjd, scr, k, nc, planar):
    rows = 2 if planar else 3
    for c in range(nc):
        ai, aj = ci[c, CI_AI], ci[c, CI_AJ]
        n0, n1, n2 = con[c, CW_E], con[c, CW_E + 1], con[c, CW_E + 2]
        ri, rj = con[c, CW_RI], con[c, CW_RJ]
        # material velocity of the centre (point) on body i, and body j's angular velocity
        p0, p1, p2 = con[c, CW_C], con[c, CW_C + 1], con[c, CW_C + 2]
        a0, a1, a2 = _cross(node[ai, NW_V + 3], node[ai, NW_V + 4], node[ai, NW_V + 5],
                            p0 - node[ai, NW_P], p1 - node[ai, NW_P + 1], p2 - node[ai, NW_P + 2])
        vci0, vci1, vci2 = node[ai, NW_V] + a0, node[ai, NW_V + 1] + a1, node[ai, NW_V + 2] + a2
        wj0, wj1, wj2 = node[aj, NW_V + 3], node[aj, NW_V + 4], node[aj, NW_V + 5]
        vcj0, vcj1, vcj2 = 0.0, 0.0, 0.0
        if ci[c, CI_TARGET] == PLANE:
            m0, m1, m2 = _cross(wj0, wj1, wj2, n0, n1, n2)
        else:
            q0, q1, q2 = con[c, CW_C + 3], con[c, CW_C + 4], con[c, CW_C + 5]
            b0, b1, b2 = _cross(wj0, wj1, wj2, q0 - node[aj, NW_P], q1 - node[aj, NW_P + 1],
                                q2 - node[aj, NW_P + 2])
            vcj0, vcj1, vcj2 = node[aj, NW_V] + b0, node[aj, NW_V + 1] + b1, node[aj, NW_V + 2] + b2
            e0, e1, e2 = p0 - q0, p1 - q1, p2 - q2
            dist = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            if con[c, CW_OK] == 0.0:
                dist = 1.0
            d0, d1, d2 = vci0 - vcj0, vci1 - vcj1, vci2 - vcj2
            nd = n0 * d0 + n1 * d1 + n2 * d2
            m0, m1, m2 = (d0 - n0 * nd) / dist, (d1 - n1 * nd) / dist, (d2 - n2 * nd) / dist
        xd = CW_XD
        con[c, xd], con[c, xd + 1], con[c, xd + 2] = vci0 - ri * m0, vci1 - ri * m1, vci2 - ri * m2
        if ci[c, CI_TARGET] == PLANE:
            for i in range(3):
                con[c, xd + 3 + i] = con[c, xd + i]
        else:
            con[c, xd + 3] = vcj0 + rj * m0
            con[c, xd + 4] = vcj1 + rj * m1
            con[c, xd + 5] = vcj2 + rj * m2
        ed = CW_ED
        con[c, ed], con[c, ed + 1], con[c, ed + 2] = m0, m1, m2
        if planar:
            con[c, ed + 3], con[c, ed + 4], con[c, ed + 5] = -m1, m0, 0.0
            con[c, ed + 6], con[c, ed + 7], con[c, ed + 8] = 0.0, 0.0, 0.0
        elif ci[c, CI_TARGET] == PLANE:
            con[c, ed + 3], con[c, ed + 4], con[c, ed + 5] = _cross(
                wj0, wj1, wj2, con[c, CW_E + 3], con[c, CW_E + 4], con[c, CW_E + 5])
            con[c, ed + 6], con[c, ed + 7], con[c, ed + 8] = _cross(
                wj0, wj1, wj2, con[c, CW_E + 6], con[c, CW_E + 7], con[c, CW_E + 8])
        elif con[c, CW_OK] == 0.0:
            for i in range(3, 9):
                con[c, ed + i] = 0.0
        else:
            t0, t1, t2, u0, u1, u2 = _complement_dot(n0, n1, n2, m0, m1, m2)
            con[c, ed + 3], con[c, ed + 4], con[c, ed + 5] = t0, t1, t2
            con[c, ed + 6], con[c, ed + 7], con[c, ed + 8] = u0, u1, u2
        _jacobian_rows(ni, node, con, c, ai, aj, rows, k, cjd, scr[SC_W], True)
