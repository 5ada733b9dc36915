"""Kinematics of the tree, compiled: placements, velocities and point Jacobians.

Everything is in world (ground) coordinates, Featherstone's spatial vectors with the linear
part first:

* placements (stage ``POS``; ``CPOS`` for the nodes that move a contact point only):
  each node's rotation and origin from its parent's, its joint placement and its coordinate,
  its motion subspace ``S_j = (0, a_j)`` about its origin (revolute, axis a_j) or ``(u_j, 0)``
  (prismatic), and every body frame (:func:`_positions`);
* velocities (stage ``VEL``): ``V_j = V_parent + S_j theta_dot_j``, the time derivative
  ``S_dot_j = V_pre x S_j`` with ``V_pre`` the spatial velocity of the frame carrying the
  axis, and every body frame's velocity (:func:`_velocities`);
* the Jacobian of a material point of a node's frame, or its rate along the held velocity
  (:func:`point_columns`, called from Python by :mod:`convimpact.model.kinematics`).
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import jit, jit_internal
from .compiled_algebra import _cross, _mm, _mv
from .tree_layout import (BW_ANG, BW_P, BW_R, BW_VO, BW_W, BW_XANG, BW_XP, BW_XR, H_K, H_OFF, I_NI,
                          NIC, NI_FIRST, NI_KIND, NI_PARENT, NWC, NW_ANG, NW_AXIS, NW_P, NW_R, NW_S,
                          NW_SD, NW_T0ANG, NW_T0P, NW_T0R, NW_V, N_WORK, REVOLUTE, SC_A, SC_B,
                          V_DTHETA, V_THETA, W_NODE)


@jit_internal
def _positions(ni, bi, vec, node, body, scr, k, nb, nodes, n_nodes):
    """Placements and S of the nodes (all when ``nodes`` is empty: then the bodies' too)."""
    for jj in range(n_nodes if n_nodes >= 0 else k):
        j = nodes[jj] if n_nodes >= 0 else jj
        lam = ni[j, NI_PARENT]
        if ni[j, NI_FIRST]:  # joint placement T0 in the parent node's frame
            _mm(node, lam, NW_R, node, j, NW_T0R, scr, SC_A, 0)
            t0, t1, t2 = _mv(node, lam, NW_R, node[j, NW_T0P], node[j, NW_T0P + 1],
                             node[j, NW_T0P + 2])
            p0 = node[lam, NW_P] + t0
            p1 = node[lam, NW_P + 1] + t1
            p2 = node[lam, NW_P + 2] + t2
            ang = node[lam, NW_ANG] + node[j, NW_T0ANG]
        else:
            for i in range(9):
                scr[SC_A, i] = node[lam, NW_R + i]
            p0, p1, p2 = node[lam, NW_P], node[lam, NW_P + 1], node[lam, NW_P + 2]
            ang = node[lam, NW_ANG]
        x, y, z = node[j, NW_AXIS], node[j, NW_AXIS + 1], node[j, NW_AXIS + 2]
        a0, a1, a2 = _mv(scr, SC_A, 0, x, y, z)
        q = vec[V_THETA, j]
        if ni[j, NI_KIND] == REVOLUTE:  # S about p_j (on the axis): (0, a)
            node[j, NW_S], node[j, NW_S + 1], node[j, NW_S + 2] = 0.0, 0.0, 0.0
            node[j, NW_S + 3], node[j, NW_S + 4], node[j, NW_S + 5] = a0, a1, a2
            c = math.cos(q)
            s = math.sin(q)
            t = 1.0 - c
            scr[SC_B, 0] = t * x * x + c
            scr[SC_B, 1] = t * x * y - s * z
            scr[SC_B, 2] = t * x * z + s * y
            scr[SC_B, 3] = t * x * y + s * z
            scr[SC_B, 4] = t * y * y + c
            scr[SC_B, 5] = t * y * z - s * x
            scr[SC_B, 6] = t * x * z - s * y
            scr[SC_B, 7] = t * y * z + s * x
            scr[SC_B, 8] = t * z * z + c
            _mm(scr, SC_A, 0, scr, SC_B, 0, node, j, NW_R)
            node[j, NW_P], node[j, NW_P + 1], node[j, NW_P + 2] = p0, p1, p2
            node[j, NW_ANG] = ang + z * q
        else:
            node[j, NW_S], node[j, NW_S + 1], node[j, NW_S + 2] = a0, a1, a2
            node[j, NW_S + 3], node[j, NW_S + 4], node[j, NW_S + 5] = 0.0, 0.0, 0.0
            for i in range(9):
                node[j, NW_R + i] = scr[SC_A, i]
            node[j, NW_P] = p0 + a0 * q
            node[j, NW_P + 1] = p1 + a1 * q
            node[j, NW_P + 2] = p2 + a2 * q
            node[j, NW_ANG] = ang
    if n_nodes >= 0:
        return
    for b in range(1, nb):
        an = bi[b, 0]
        _mm(node, an, NW_R, body, b, BW_XR, body, b, BW_R)
        t0, t1, t2 = _mv(node, an, NW_R, body[b, BW_XP], body[b, BW_XP + 1], body[b, BW_XP + 2])
        body[b, BW_P] = node[an, NW_P] + t0
        body[b, BW_P + 1] = node[an, NW_P + 1] + t1
        body[b, BW_P + 2] = node[an, NW_P + 2] + t2
        body[b, BW_ANG] = node[an, NW_ANG] + body[b, BW_XANG]


@jit_internal
def _velocities(ni, bi, vec, node, body, k, nb):
    """Per node: (v_j, w_j), the velocity of its origin p_j and its angular velocity, and
    S_dot (about p_j) = crm(V of the frame carrying the axis) S."""
    for i in range(6):
        node[k, NW_V + i] = 0.0
    for j in range(k):
        lam = ni[j, NI_PARENT]
        w0, w1, w2 = node[lam, NW_V + 3], node[lam, NW_V + 4], node[lam, NW_V + 5]
        r0 = node[j, NW_P] - node[lam, NW_P]
        r1 = node[j, NW_P + 1] - node[lam, NW_P + 1]
        r2 = node[j, NW_P + 2] - node[lam, NW_P + 2]
        c0, c1, c2 = _cross(w0, w1, w2, r0, r1, r2)
        v0, v1, v2 = node[lam, NW_V] + c0, node[lam, NW_V + 1] + c1, node[lam, NW_V + 2] + c2
        s0, s1, s2 = node[j, NW_S], node[j, NW_S + 1], node[j, NW_S + 2]
        s3, s4, s5 = node[j, NW_S + 3], node[j, NW_S + 4], node[j, NW_S + 5]
        # (w x s_lin + v x s_ang, w x s_ang)
        a0, a1, a2 = _cross(w0, w1, w2, s0, s1, s2)
        b0, b1, b2 = _cross(v0, v1, v2, s3, s4, s5)
        c0, c1, c2 = _cross(w0, w1, w2, s3, s4, s5)
        node[j, NW_SD], node[j, NW_SD + 1], node[j, NW_SD + 2] = a0 + b0, a1 + b1, a2 + b2
        node[j, NW_SD + 3], node[j, NW_SD + 4], node[j, NW_SD + 5] = c0, c1, c2
        qd = vec[V_DTHETA, j]
        node[j, NW_V], node[j, NW_V + 1] = v0 + s0 * qd, v1 + s1 * qd
        node[j, NW_V + 2], node[j, NW_V + 3] = v2 + s2 * qd, w0 + s3 * qd
        node[j, NW_V + 4], node[j, NW_V + 5] = w1 + s4 * qd, w2 + s5 * qd
    for b in range(1, nb):
        an = bi[b, 0]
        w0, w1, w2 = node[an, NW_V + 3], node[an, NW_V + 4], node[an, NW_V + 5]
        c0, c1, c2 = _cross(w0, w1, w2, body[b, BW_P] - node[an, NW_P],
                            body[b, BW_P + 1] - node[an, NW_P + 1],
                            body[b, BW_P + 2] - node[an, NW_P + 2])
        body[b, BW_VO] = node[an, NW_V] + c0
        body[b, BW_VO + 1] = node[an, NW_V + 1] + c1
        body[b, BW_VO + 2] = node[an, NW_V + 2] + c2
        body[b, BW_W], body[b, BW_W + 1], body[b, BW_W + 2] = w0, w1, w2


@jit
def point_columns(work, node, x0, x1, x2, rate, J):
    """The Jacobian (rate = False) or its time derivative along the held velocity (rate =
    True) of the material point at world (x0, x1, x2) of the frame of ``node`` (-1: the
    ground), into J (6, k): rows 0-2 the point's velocity, rows 3-5 the angular velocity.
    Columns outside the node's support are left as they are (zero them first)."""
    itab = work.view(np.int64)
    k = itab[H_K]
    o = itab[H_OFF + W_NODE]
    node_ = work[o:o + (k + 1) * NWC].reshape((k + 1, NWC))
    o = itab[H_OFF + N_WORK + I_NI]
    ni = itab[o:o + k * NIC].reshape((k, NIC))
    # the material point's velocity (rate only)
    w0, w1, w2 = node_[node, NW_V + 3], node_[node, NW_V + 4], node_[node, NW_V + 5]
    c0, c1, c2 = _cross(w0, w1, w2, x0 - node_[node, NW_P], x1 - node_[node, NW_P + 1],
                        x2 - node_[node, NW_P + 2])
    v0, v1, v2 = node_[node, NW_V] + c0, node_[node, NW_V + 1] + c1, node_[node, NW_V + 2] + c2
    s = node
    base = NW_SD if rate else NW_S
    while s >= 0:
        d0, d1, d2 = x0 - node_[s, NW_P], x1 - node_[s, NW_P + 1], x2 - node_[s, NW_P + 2]
        a0, a1, a2 = node_[s, base + 3], node_[s, base + 4], node_[s, base + 5]
        t0, t1, t2 = _cross(a0, a1, a2, d0, d1, d2)
        J[0, s] = node_[s, base] + t0
        J[1, s] = node_[s, base + 1] + t1
        J[2, s] = node_[s, base + 2] + t2
        if rate:
            u0, u1, u2 = _cross(node_[s, NW_S + 3], node_[s, NW_S + 4], node_[s, NW_S + 5],
                                v0, v1, v2)
            J[0, s] += u0
            J[1, s] += u1
            J[2, s] += u2
        J[3, s], J[4, s], J[5, s] = a0, a1, a2
        s = ni[s, NI_PARENT]
