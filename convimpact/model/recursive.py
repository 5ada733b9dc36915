"""Recursive rigid-body algorithms on a model's tree of joint coordinates, compiled (numba).

The tree walked here is the tree of *elementary motions*: node j is joint coordinate j (a
revolute turn about, or a prismatic slide along, one axis), its parent the coordinate that
moves it last (the previous motion of the same joint, or the last coordinate of the nearest
ancestor body that has coordinates; -1 for the ground). Bodies welded by fixed joints ride on
the node of their anchor and their masses are lumped into it once, when the tables are built,
so a multi-coordinate joint is a chain of nodes through massless frames (as in Pinocchio).

Everything is written in world (ground) coordinates, Featherstone's spatial vectors with the
linear part first and the reference point at the world origin:

* motion subspace of node j: ``S_j = (o_j x a_j, a_j)`` (revolute, axis a_j through o_j) or
  ``(u_j, 0)`` (prismatic), and its time derivative ``S_dot_j = V_pre x S_j`` where ``V_pre``
  is the spatial velocity of the frame carrying the axis;
* spatial velocity ``V_j = V_parent + S_j theta_dot_j``; the world inertia of node j about the
  origin ``Y_j = (m, h = m c, I_O)`` (ten numbers), composites are plain sums;
* **M** by the composite-rigid-body algorithm ``M_ij = S_i . (Yc_j S_j)`` (i an ancestor of j);
* **f** of eq. (4) by Newton-Euler: ``a_j = a_parent + S_dot_j theta_dot_j`` from
  ``a_ground = (-g, 0)``, ``F_j = Y_j a_j + V_j x* (Y_j V_j)`` summed over subtrees,
  ``f_j = -S_j . F_j`` (the applied joint forces are added by the caller);
* the momentum rate ``p_dot = f + M_dot theta_dot`` of eq. (11) directly, from Lagrange's
  equations ``p_dot_j = dT/dtheta_j - dV/dtheta_j = S_dot_j . H_j + S_j . G_j`` with ``H_j``
  and ``G_j`` the spatial momentum and the gravity wrench of the subtree of j;
* **M_dot** by differentiating the CRBA: ``Ydot = V x* Y - Y V x`` per node;
* contact gaps, frames ``(n, t1, t2)`` and Jacobians ``Jc[r, s] = S_s . w_r`` with the unit
  wrench ``w_r = (e_r, x x e_r)`` of frame axis e_r at the contact point x (body j's side
  subtracted), and ``Jc_dot[r, s] = S_dot_s . w_r + S_s . w_dot_r`` (the contact point and
  the frame move with the bodies: the exact total derivative along theta_dot).

Planar models are embedded in space (z = 0, revolute axes along z): the arithmetic is the
spatial one and the planar quantities are the x-y (and z-angular) components.

All arrays live in one flat buffer per :class:`~convimpact.model.data.Data` (its layout
built once per model, :class:`Layout`): first the integer table (sizes, the offsets of the
sections, parents and kinds, read through an int64 view), then the model's constants, the
state and every computed quantity, so a call from Python passes four arguments and the
kernel makes a dozen views.
Per node, body and contact the quantities are columns of one row (``NW_*``, ``BW_*``,
``CW_*``) and are reached by (row, column offset), never by views made in the loops (a view
costs an atomic reference count, as much as the arithmetic of a small model). Node rows
have one extra row, the ground (index -1): identity placement, zero velocity, acceleration
``-g``. The buffer also records the state it holds and which stages are current, so
:func:`evaluate` (one call from Python per request) compares the state, drops what changed
and runs only the missing stages with their prerequisites.

No input is validated here except the length and finiteness of theta and theta_dot (codes
``R_BAD_SHAPE_*``, ``R_NON_FINITE_*``); :func:`evaluate` is compiled for one signature
(:data:`EVALUATE_SIGNATURE`) and :class:`~convimpact.model.data.Data` closes it to others,
so any other argument type raises TypeError (and Data converts it) instead of compiling.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: the entry points (with a CPython wrapper)
_jit = njit(cache=True, nogil=True, error_model="numpy")
#: internal functions, called from compiled code only
_int = njit(cache=True, nogil=True, error_model="numpy", no_cpython_wrapper=True,
            no_cfunc_wrapper=True)

# ---- stage flags ---------------------------------------------------------------------------
POS = 1  # node and body placements, motion subspaces S
INERTIA = 2  # world inertias of the nodes
MASS = 4  # M by CRBA (composite inertias kept for MDOT)
CHOL = 8  # lower Cholesky factor of M
CONTACT = 16  # gaps, frames, contact Jacobians of every contact
VEL = 32  # velocities, S_dot, body velocities
BIAS = 64  # f (without applied forces) and p_dot = f + M_dot theta_dot
CDOT = 128  # contact Jacobians' time derivatives
MDOT = 256  # M_dot
CPOS = 512  # placements of the nodes that move a contact point only (implied by POS)
#: flags that depend on the configuration only
Q_FLAGS = POS | INERTIA | MASS | CHOL | CONTACT | CPOS
#: each flag with the stages it needs first
REQUIRES = {POS: 0, INERTIA: POS, MASS: POS | INERTIA, CHOL: POS | INERTIA | MASS,
            CONTACT: CPOS, VEL: POS, BIAS: POS | INERTIA | VEL,
            CDOT: POS | CONTACT | VEL, MDOT: POS | INERTIA | MASS | VEL, CPOS: 0}
#: number of flag combinations
N_FLAGS = 1024
#: the bit of :func:`evaluate`'s flags saying that theta_dot is given
HAS_V = N_FLAGS

# ---- status codes ---------------------------------------------------------------------------
OK = 0
NOT_DEFINITE = 2  # Cholesky of M failed (M singular or not positive definite)
# bits of the code :func:`evaluate` returns
R_NON_FINITE_Q = 1  # theta not finite (nothing is current afterwards)
R_NON_FINITE_V = 2  # theta_dot not finite (no velocity stage is current afterwards)
R_Q_CHANGED = 4  # a new configuration: every earlier stage was dropped
R_V_CHANGED = 8  # a new velocity: the velocity stages were dropped
R_NOT_DEFINITE = 16  # the Cholesky factorization of M failed
R_BAD_SHAPE_Q = 32  # theta is not of length k (nothing was read)
R_BAD_SHAPE_V = 64  # theta_dot is not of length k (nothing was read)
#: the signature :func:`evaluate` is compiled for (and the only one it accepts)
EVALUATE_SIGNATURE = "int64(int64, float64[::1], float64[::1], float64[::1])"

# ---- itab header ------------------------------------------------------------------------------
H_PLANAR, H_K, H_NB, H_NC, H_NCS = 0, 1, 2, 3, 4
H_OFF = 8  # offsets of the sections follow
# work sections
(W_VEC, W_NODE, W_BODY, W_CON, W_CJ, W_CJD, W_M, W_L, W_MD, W_YD, W_SCR, W_MW) = range(12)
N_WORK = 12
# itab sections
I_NI, I_BI, I_CI, I_CS, I_CL = range(5)
N_ITAB = 5
# rows of the VEC section
V_THETA, V_DTHETA, V_BIAS, V_PDOT = range(4)

# node columns: constants, then the state's quantities
NW_T0R, NW_T0P, NW_T0ANG, NW_AXIS, NW_MASS, NW_COM, NW_IC = 0, 9, 12, 13, 16, 17, 20
NW_R, NW_P, NW_ANG, NW_S, NW_Y, NW_YC = 29, 38, 41, 42, 48, 58
NW_V, NW_SD, NW_A, NW_F, NW_H, NW_G = 68, 74, 80, 86, 92, 98
NWC = 104
# columns of the M_dot work rows: S, S_dot, V and Y, Yc carried to the world origin
MW_S, MW_SD, MW_V, MW_Y, MW_YC = 0, 6, 12, 18, 28
MWC = 38
# body columns: placement of the body frame in its node's frame, then the state's
BW_XR, BW_XP, BW_XANG, BW_R, BW_P, BW_ANG, BW_VO, BW_W = 0, 9, 12, 13, 22, 25, 26, 29
BWC = 32
# contact columns: geometry in the anchor nodes' frames, then the state's
CW_PI, CW_RI, CW_PJ, CW_RJ, CW_NJ, CW_TJ = 0, 3, 4, 7, 8, 11
CW_GAP, CW_OK, CW_X, CW_C, CW_E, CW_XD, CW_ED = 14, 15, 16, 22, 28, 37, 43
CWC = 52
# scratch rows (36 columns each); the last holds the state of the buffer
SC_GRAV, SC_A, SC_B, SC_W, SC_WD, SC_META = 0, 1, 2, 3, 4, 7
N_SCR = 8
# columns of the SC_META row: stages current, theta held, theta_dot held, Cholesky succeeded
META_DONE, META_HAS_Q, META_HAS_V, META_CHOL = 0, 1, 2, 3

# node integer columns
NI_PARENT, NI_KIND, NI_FIRST = 0, 1, 2
NIC = 3
# contact integer columns
CI_AI, CI_AJ, CI_TARGET = 0, 1, 2
CIC = 3

REVOLUTE, PRISMATIC = 0, 1
PLANE, SPHERE = 0, 1


def work_shapes(k: int, nb: int, nc: int) -> list[tuple[int, ...]]:
    """Shapes of the work sections, in the order of the ``W_*`` indices (node rows have a
    ground row at index k)."""
    n = k + 1
    return [(4, k), (n, NWC), (nb, BWC), (nc, CWC), (nc, 3, k), (nc, 3, k), (k, k), (k, k),
            (k, k), (n, 36), (N_SCR, 36), (n, MWC)]


# ---- small algebra on (array, row, column offset) ---------------------------------------------
@_int
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@_int
def _dot6(A, i, a, B, j, b):
    return (A[i, a] * B[j, b] + A[i, a + 1] * B[j, b + 1] + A[i, a + 2] * B[j, b + 2]
            + A[i, a + 3] * B[j, b + 3] + A[i, a + 4] * B[j, b + 4] + A[i, a + 5] * B[j, b + 5])


@_int
def _mv(A, i, a, x0, x1, x2):
    """The 3 x 3 matrix stored row-major at A[i, a:a+9] times (x0, x1, x2)."""
    return (A[i, a] * x0 + A[i, a + 1] * x1 + A[i, a + 2] * x2,
            A[i, a + 3] * x0 + A[i, a + 4] * x1 + A[i, a + 5] * x2,
            A[i, a + 6] * x0 + A[i, a + 7] * x1 + A[i, a + 8] * x2)


@_int
def _mm(A, i, a, B, j, b, C, l, c):
    """C[l, c:c+9] = A[i, a:a+9] B[j, b:b+9] (3 x 3, row-major)."""
    for r in range(3):
        a0, a1, a2 = A[i, a + 3 * r], A[i, a + 3 * r + 1], A[i, a + 3 * r + 2]
        for q in range(3):
            C[l, c + 3 * r + q] = a0 * B[j, b + q] + a1 * B[j, b + 3 + q] + a2 * B[j, b + 6 + q]


@_int
def _ymul(Y, i, y, X, j, x, O, l, o):
    """O[l, o:o+6] = Y X for the 10-number inertia Y[i, y:y+10] = (m, h, Ixx, Iyy, Izz, Ixy,
    Ixz, Iyz) about the origin and the motion X[j, x:x+6] = (v, w)."""
    m = Y[i, y]
    h0, h1, h2 = Y[i, y + 1], Y[i, y + 2], Y[i, y + 3]
    v0, v1, v2 = X[j, x], X[j, x + 1], X[j, x + 2]
    w0, w1, w2 = X[j, x + 3], X[j, x + 4], X[j, x + 5]
    O[l, o] = m * v0 - (h1 * w2 - h2 * w1)
    O[l, o + 1] = m * v1 - (h2 * w0 - h0 * w2)
    O[l, o + 2] = m * v2 - (h0 * w1 - h1 * w0)
    O[l, o + 3] = (h1 * v2 - h2 * v1) + Y[i, y + 4] * w0 + Y[i, y + 7] * w1 + Y[i, y + 8] * w2
    O[l, o + 4] = (h2 * v0 - h0 * v2) + Y[i, y + 7] * w0 + Y[i, y + 5] * w1 + Y[i, y + 9] * w2
    O[l, o + 5] = (h0 * v1 - h1 * v0) + Y[i, y + 8] * w0 + Y[i, y + 9] * w1 + Y[i, y + 6] * w2


# ---- stages -----------------------------------------------------------------------------------
@_int
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


@_int
def _inertias(node, scr, k):
    """Y_j about the node's origin p_j: (m, h = m d, I_p) with d = R com (no p: exact for a
    body centred on its joint)."""
    for j in range(k):
        m = node[j, NW_MASS]
        if m == 0.0:
            for i in range(10):
                node[j, NW_Y + i] = 0.0
            continue
        d0, d1, d2 = _mv(node, j, NW_R, node[j, NW_COM], node[j, NW_COM + 1], node[j, NW_COM + 2])
        _mm(node, j, NW_R, node, j, NW_IC, scr, SC_A, 0)  # R Ic, then (R Ic) R^T
        R = NW_R
        I00 = (scr[SC_A, 0] * node[j, R] + scr[SC_A, 1] * node[j, R + 1]
               + scr[SC_A, 2] * node[j, R + 2])
        I11 = (scr[SC_A, 3] * node[j, R + 3] + scr[SC_A, 4] * node[j, R + 4]
               + scr[SC_A, 5] * node[j, R + 5])
        I22 = (scr[SC_A, 6] * node[j, R + 6] + scr[SC_A, 7] * node[j, R + 7]
               + scr[SC_A, 8] * node[j, R + 8])
        I01 = (scr[SC_A, 0] * node[j, R + 3] + scr[SC_A, 1] * node[j, R + 4]
               + scr[SC_A, 2] * node[j, R + 5])
        I02 = (scr[SC_A, 0] * node[j, R + 6] + scr[SC_A, 1] * node[j, R + 7]
               + scr[SC_A, 2] * node[j, R + 8])
        I12 = (scr[SC_A, 3] * node[j, R + 6] + scr[SC_A, 4] * node[j, R + 7]
               + scr[SC_A, 5] * node[j, R + 8])
        dd = d0 * d0 + d1 * d1 + d2 * d2
        y = NW_Y
        node[j, y] = m
        node[j, y + 1], node[j, y + 2], node[j, y + 3] = m * d0, m * d1, m * d2
        node[j, y + 4] = I00 + m * (dd - d0 * d0)
        node[j, y + 5] = I11 + m * (dd - d1 * d1)
        node[j, y + 6] = I22 + m * (dd - d2 * d2)
        node[j, y + 7] = I01 - m * d0 * d1
        node[j, y + 8] = I02 - m * d0 * d2
        node[j, y + 9] = I12 - m * d1 * d2


@_int
def _shift_add(Y, i, y, d0, d1, d2, O, l, o):
    """O[l, o:o+10] += the inertia Y[i, y:y+10] about a point A, expressed about B = A - d."""
    m = Y[i, y]
    h0, h1, h2 = Y[i, y + 1], Y[i, y + 2], Y[i, y + 3]
    hd = 2.0 * (h0 * d0 + h1 * d1 + h2 * d2) + m * (d0 * d0 + d1 * d1 + d2 * d2)
    O[l, o] += m
    O[l, o + 1] += h0 + m * d0
    O[l, o + 2] += h1 + m * d1
    O[l, o + 3] += h2 + m * d2
    O[l, o + 4] += Y[i, y + 4] + hd - 2.0 * h0 * d0 - m * d0 * d0
    O[l, o + 5] += Y[i, y + 5] + hd - 2.0 * h1 * d1 - m * d1 * d1
    O[l, o + 6] += Y[i, y + 6] + hd - 2.0 * h2 * d2 - m * d2 * d2
    O[l, o + 7] += Y[i, y + 7] - (h0 * d1 + d0 * h1) - m * d0 * d1
    O[l, o + 8] += Y[i, y + 8] - (h0 * d2 + d0 * h2) - m * d0 * d2
    O[l, o + 9] += Y[i, y + 9] - (h1 * d2 + d1 * h2) - m * d1 * d2


@_int
def _crba(ni, node, M, scr, k):
    """Composite inertias about each node's origin; M_ij = S_i . (Yc_j S_j) carried to p_i."""
    for j in range(k):
        for i in range(10):
            node[j, NW_YC + i] = node[j, NW_Y + i]
    for j in range(k - 1, -1, -1):
        _ymul(node, j, NW_YC, node, j, NW_S, scr, SC_A, 0)  # F = Yc_j S_j about p_j
        M[j, j] = _dot6(node, j, NW_S, scr, SC_A, 0)
        f0, f1, f2 = scr[SC_A, 0], scr[SC_A, 1], scr[SC_A, 2]
        c = j
        i = ni[j, NI_PARENT]
        while i >= 0:  # carry the moment to p_i: n += (p_c - p_i) x f
            t0, t1, t2 = _cross(node[c, NW_P] - node[i, NW_P],
                                node[c, NW_P + 1] - node[i, NW_P + 1],
                                node[c, NW_P + 2] - node[i, NW_P + 2], f0, f1, f2)
            scr[SC_A, 3] += t0
            scr[SC_A, 4] += t1
            scr[SC_A, 5] += t2
            v = _dot6(node, i, NW_S, scr, SC_A, 0)
            M[i, j] = v
            M[j, i] = v
            c = i
            i = ni[i, NI_PARENT]
        lam = ni[j, NI_PARENT]
        if lam >= 0:
            _shift_add(node, j, NW_YC, node[j, NW_P] - node[lam, NW_P],
                       node[j, NW_P + 1] - node[lam, NW_P + 1],
                       node[j, NW_P + 2] - node[lam, NW_P + 2], node, lam, NW_YC)
    # entries of two coordinates on different branches are never written: they stay zero


@_int
def _cholesky(M, L, k):
    for j in range(k):
        s = M[j, j]
        for p in range(j):
            s -= L[j, p] * L[j, p]
        if not s > 0.0 or not math.isfinite(s):
            return NOT_DEFINITE
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, k):
            s = M[i, j]
            for p in range(j):
                s -= L[i, p] * L[j, p]
            L[i, j] = s / d
    return OK


@_int
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


@_int
def _bias(ni, vec, node, scr, k):
    """Newton-Euler about each node's origin: (A_j, w_dot_j) the acceleration of p_j and the
    angular acceleration at theta_ddot = 0 from A_ground = -g; force and moment
    (f, n about p_j) = (m A + w_dot x h + w x (w x h), I w_dot + w x I w + h x A); the
    subtree momenta (L, K about p_j) and gravity wrenches for p_dot = S_dot . H + S . G."""
    g0, g1, g2 = scr[SC_GRAV, 0], scr[SC_GRAV, 1], scr[SC_GRAV, 2]
    node[k, NW_A], node[k, NW_A + 1], node[k, NW_A + 2] = -g0, -g1, -g2
    node[k, NW_A + 3], node[k, NW_A + 4], node[k, NW_A + 5] = 0.0, 0.0, 0.0
    for j in range(k):
        lam = ni[j, NI_PARENT]
        qd = vec[V_DTHETA, j]
        w0, w1, w2 = node[lam, NW_V + 3], node[lam, NW_V + 4], node[lam, NW_V + 5]
        e0, e1, e2 = node[lam, NW_A + 3], node[lam, NW_A + 4], node[lam, NW_A + 5]
        r0 = node[j, NW_P] - node[lam, NW_P]
        r1 = node[j, NW_P + 1] - node[lam, NW_P + 1]
        r2 = node[j, NW_P + 2] - node[lam, NW_P + 2]
        a0, a1, a2 = _cross(e0, e1, e2, r0, r1, r2)
        c0, c1, c2 = _cross(w0, w1, w2, r0, r1, r2)
        b0, b1, b2 = _cross(w0, w1, w2, c0, c1, c2)
        A0 = node[lam, NW_A] + a0 + b0
        A1 = node[lam, NW_A + 1] + a1 + b1
        A2 = node[lam, NW_A + 2] + a2 + b2
        s0, s1, s2 = node[j, NW_S], node[j, NW_S + 1], node[j, NW_S + 2]
        s3, s4, s5 = node[j, NW_S + 3], node[j, NW_S + 4], node[j, NW_S + 5]
        # revolute: w_dot += (w x a) qd; prismatic: A += 2 w x u qd (Coriolis)
        t0, t1, t2 = _cross(w0, w1, w2, s3, s4, s5)
        u0, u1, u2 = _cross(w0, w1, w2, s0, s1, s2)
        A0 += 2.0 * u0 * qd
        A1 += 2.0 * u1 * qd
        A2 += 2.0 * u2 * qd
        e0 += t0 * qd
        e1 += t1 * qd
        e2 += t2 * qd
        node[j, NW_A], node[j, NW_A + 1], node[j, NW_A + 2] = A0, A1, A2
        node[j, NW_A + 3], node[j, NW_A + 4], node[j, NW_A + 5] = e0, e1, e2
        m = node[j, NW_Y]
        if m == 0.0:
            for i in range(6):
                node[j, NW_F + i] = 0.0
                node[j, NW_H + i] = 0.0
                node[j, NW_G + i] = 0.0
            continue
        h0, h1, h2 = node[j, NW_Y + 1], node[j, NW_Y + 2], node[j, NW_Y + 3]
        w0, w1, w2 = node[j, NW_V + 3], node[j, NW_V + 4], node[j, NW_V + 5]
        v0, v1, v2 = node[j, NW_V], node[j, NW_V + 1], node[j, NW_V + 2]
        # force m a_c = m A + w_dot x h + w x (w x h)
        a0, a1, a2 = _cross(e0, e1, e2, h0, h1, h2)
        c0, c1, c2 = _cross(w0, w1, w2, h0, h1, h2)
        b0, b1, b2 = _cross(w0, w1, w2, c0, c1, c2)
        node[j, NW_F] = m * A0 + a0 + b0
        node[j, NW_F + 1] = m * A1 + a1 + b1
        node[j, NW_F + 2] = m * A2 + a2 + b2
        # moment about p_j: I w_dot + w x (I w) + h x A
        Ixx, Iyy, Izz = node[j, NW_Y + 4], node[j, NW_Y + 5], node[j, NW_Y + 6]
        Ixy, Ixz, Iyz = node[j, NW_Y + 7], node[j, NW_Y + 8], node[j, NW_Y + 9]
        k0 = Ixx * w0 + Ixy * w1 + Ixz * w2
        k1 = Ixy * w0 + Iyy * w1 + Iyz * w2
        k2 = Ixz * w0 + Iyz * w1 + Izz * w2
        d0, d1, d2 = _cross(w0, w1, w2, k0, k1, k2)
        a0, a1, a2 = _cross(h0, h1, h2, A0, A1, A2)
        node[j, NW_F + 3] = Ixx * e0 + Ixy * e1 + Ixz * e2 + d0 + a0
        node[j, NW_F + 4] = Ixy * e0 + Iyy * e1 + Iyz * e2 + d1 + a1
        node[j, NW_F + 5] = Ixz * e0 + Iyz * e1 + Izz * e2 + d2 + a2
        # momentum (L, K about p_j) = (m v + w x h, I w + h x v); gravity (m g, h x g)
        node[j, NW_H], node[j, NW_H + 1], node[j, NW_H + 2] = m * v0 + c0, m * v1 + c1, m * v2 + c2
        a0, a1, a2 = _cross(h0, h1, h2, v0, v1, v2)
        node[j, NW_H + 3], node[j, NW_H + 4], node[j, NW_H + 5] = k0 + a0, k1 + a1, k2 + a2
        node[j, NW_G], node[j, NW_G + 1], node[j, NW_G + 2] = m * g0, m * g1, m * g2
        node[j, NW_G + 3], node[j, NW_G + 4], node[j, NW_G + 5] = _cross(h0, h1, h2, g0, g1, g2)
    for j in range(k - 1, -1, -1):
        vec[V_BIAS, j] = -_dot6(node, j, NW_S, node, j, NW_F)
        vec[V_PDOT, j] = _dot6(node, j, NW_SD, node, j, NW_H) + _dot6(node, j, NW_S, node, j, NW_G)
        lam = ni[j, NI_PARENT]
        if lam >= 0:
            r0 = node[j, NW_P] - node[lam, NW_P]
            r1 = node[j, NW_P + 1] - node[lam, NW_P + 1]
            r2 = node[j, NW_P + 2] - node[lam, NW_P + 2]
            for col in (NW_F, NW_H, NW_G):
                f0, f1, f2 = node[j, col], node[j, col + 1], node[j, col + 2]
                t0, t1, t2 = _cross(r0, r1, r2, f0, f1, f2)
                node[lam, col] += f0
                node[lam, col + 1] += f1
                node[lam, col + 2] += f2
                node[lam, col + 3] += node[j, col + 3] + t0
                node[lam, col + 4] += node[j, col + 4] + t1
                node[lam, col + 5] += node[j, col + 5] + t2


@_int
def _mass_matrix_dot(ni, node, YD, MD, mw, scr, k):
    """dM/dt by differentiating the CRBA in world coordinates about the origin (the node
    quantities are carried there first): M_dot_ij = S_dot_i . F1 + S_i . F2 with
    F1 = Yc_j S_j, F2 = Yc_j S_dot_j + Ydot_c_j S_j, Ydot = crf(V) Y - Y crm(V)."""
    for j in range(k):
        p0, p1, p2 = node[j, NW_P], node[j, NW_P + 1], node[j, NW_P + 2]
        for base, src in ((MW_S, NW_S), (MW_SD, NW_SD), (MW_V, NW_V)):
            # a motion vector about p carried to the origin: lin += p x ang
            t0, t1, t2 = _cross(p0, p1, p2, node[j, src + 3], node[j, src + 4], node[j, src + 5])
            mw[j, base] = node[j, src] + t0
            mw[j, base + 1] = node[j, src + 1] + t1
            mw[j, base + 2] = node[j, src + 2] + t2
            mw[j, base + 3] = node[j, src + 3]
            mw[j, base + 4] = node[j, src + 4]
            mw[j, base + 5] = node[j, src + 5]
        for i in range(10):
            mw[j, MW_Y + i] = 0.0
            mw[j, MW_YC + i] = 0.0
        _shift_add(node, j, NW_Y, p0, p1, p2, mw, j, MW_Y)
    for j in range(k - 1, -1, -1):
        for i in range(10):
            mw[j, MW_YC + i] += mw[j, MW_Y + i]
        lam = ni[j, NI_PARENT]
        if lam >= 0:
            for i in range(10):
                mw[lam, MW_YC + i] += mw[j, MW_YC + i]
    for j in range(k):
        v0, v1, v2 = mw[j, MW_V], mw[j, MW_V + 1], mw[j, MW_V + 2]
        w0, w1, w2 = mw[j, MW_V + 3], mw[j, MW_V + 4], mw[j, MW_V + 5]
        m = mw[j, MW_Y]
        h0, h1, h2 = mw[j, MW_Y + 1], mw[j, MW_Y + 2], mw[j, MW_Y + 3]
        # Y (row-major into scratch row A): [[m 1, -[h]x], [[h]x, I]]
        Y6 = scr[SC_A]
        for i in range(36):
            Y6[i] = 0.0
        Y6[0] = Y6[7] = Y6[14] = m
        Y6[4], Y6[5], Y6[9], Y6[11], Y6[15], Y6[16] = h2, -h1, -h2, h0, h1, -h0
        Y6[19], Y6[20], Y6[24], Y6[26], Y6[30], Y6[31] = -h2, h1, h2, -h0, -h1, h0
        Y6[21], Y6[28], Y6[35] = mw[j, MW_Y + 4], mw[j, MW_Y + 5], mw[j, MW_Y + 6]
        Y6[22] = Y6[27] = mw[j, MW_Y + 7]
        Y6[23] = Y6[33] = mw[j, MW_Y + 8]
        Y6[29] = Y6[34] = mw[j, MW_Y + 9]
        # X = crm(V) = [[ [w]x, [v]x ], [0, [w]x]] (row-major into scratch row B)
        X = scr[SC_B]
        for i in range(36):
            X[i] = 0.0
        X[1], X[2], X[6], X[8], X[12], X[13] = -w2, w1, w2, -w0, -w1, w0
        X[22], X[23], X[27], X[29], X[33], X[34] = -w2, w1, w2, -w0, -w1, w0
        X[4], X[5], X[9], X[11], X[15], X[16] = -v2, v1, v2, -v0, -v1, v0
        for r in range(6):
            for c in range(6):
                s = 0.0
                for p in range(6):
                    s -= X[6 * p + r] * Y6[6 * p + c] + Y6[6 * r + p] * X[6 * p + c]
                YD[j, 6 * r + c] = s
    for j in range(k - 1, -1, -1):
        _ymul(mw, j, MW_YC, mw, j, MW_S, scr, SC_W, 0)  # F1 = Yc S
        _ymul(mw, j, MW_YC, mw, j, MW_SD, scr, SC_WD, 0)  # F2 = Yc S_dot + Ydot_c S
        for r in range(6):
            s = 0.0
            for c in range(6):
                s += YD[j, 6 * r + c] * mw[j, MW_S + c]
            scr[SC_WD, r] += s
        MD[j, j] = _dot6(mw, j, MW_SD, scr, SC_W, 0) + _dot6(mw, j, MW_S, scr, SC_WD, 0)
        i = ni[j, NI_PARENT]
        while i >= 0:
            val = _dot6(mw, i, MW_SD, scr, SC_W, 0) + _dot6(mw, i, MW_S, scr, SC_WD, 0)
            MD[i, j] = val
            MD[j, i] = val
            i = ni[i, NI_PARENT]
        lam = ni[j, NI_PARENT]
        if lam >= 0:
            for r in range(36):
                YD[lam, r] += YD[j, r]


@_int
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


@_int
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


@_int
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


@_int
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
        for r in range(3):
            for s in range(k):
                cj[c, r, s] = 0.0
        for side in range(2):
            nd = ai if side == 0 else aj
            if nd < 0:
                continue
            sign = 1.0 if side == 0 else -1.0
            out = scr[SC_W]
            s = nd
            while s >= 0:
                _columns(node, s, con, c, side, rows, sign, out, False)
                for r in range(rows):
                    cj[c, r, s] += out[r]
                s = ni[s, NI_PARENT]


@_int
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
        for r in range(3):
            for s in range(k):
                cjd[c, r, s] = 0.0
        for side in range(2):
            nd_ = ai if side == 0 else aj
            if nd_ < 0:
                continue
            sign = 1.0 if side == 0 else -1.0
            out = scr[SC_W]
            s = nd_
            while s >= 0:
                _columns(node, s, con, c, side, rows, sign, out, True)
                for r in range(rows):
                    cjd[c, r, s] += out[r]
                s = ni[s, NI_PARENT]


# ---- the entry point --------------------------------------------------------------------------
@_jit
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


@_jit
def cho_solve_vec(L, b, out):
    """``out = (L L^T)^-1 b`` for a lower Cholesky factor L (out may be b)."""
    n = L.shape[0]
    for i in range(n):
        s = b[i]
        for p in range(i):
            s -= L[i, p] * out[p]
        out[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for p in range(i + 1, n):
            s -= L[p, i] * out[p]
        out[i] = s / L[i, i]


@_jit
def cho_solve_mat(L, B, out):
    """``out = (L L^T)^-1 B`` column by column, B of shape (n, m) (out may be B)."""
    n = L.shape[0]
    m = B.shape[1]
    for c in range(m):
        for i in range(n):
            s = B[i, c]
            for p in range(i):
                s -= L[i, p] * out[p, c]
            out[i, c] = s / L[i, i]
        for i in range(n - 1, -1, -1):
            s = out[i, c]
            for p in range(i + 1, n):
                s -= L[p, i] * out[p, c]
            out[i, c] = s / L[i, i]


@_jit
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


@_jit
def all_finite(a):
    """True when every entry of the 1-D array ``a`` is finite."""
    for i in range(a.shape[0]):
        if not math.isfinite(a[i]):
            return False
    return True


@_jit
def cholesky(M, L):
    """Lower Cholesky factor of M into L (upper triangle untouched); False when M is not
    positive definite."""
    return _cholesky(M, L, M.shape[0]) == OK


# ---- tables (Python) -------------------------------------------------------------------------
def closures() -> list[int]:
    """For every combination of stage flags, the flags with all their prerequisites."""
    out = []
    for flags in range(N_FLAGS):
        need = flags
        while True:
            more = need
            for f, req in REQUIRES.items():
                if need & f:
                    more |= req
            if more == need:
                break
            need = more
        out.append(need)
    return out


class Layout:
    """The model's tables and the work layout (built once per model).

    Attributes
    ----------
    itab : the integer table (the first ``n_int`` words of every work buffer).
    work_size : length of a work buffer; ``offsets`` and ``shapes`` of its float sections.
    node_of_body : (n_bodies,) the node each body rides on (-1: the ground).
    """

    def __init__(self, model):
        k, nb, nc = model.n_coordinates, model.n_bodies, len(model.contacts)
        planar = model.planar
        self.k, self.nb, self.nc, self.planar = k, nb, nc, planar

        def lift(v):
            v = np.asarray(v, dtype=float)
            return np.array([v[0], v[1], 0.0]) if planar else v.astype(float)

        def lift_rot(R):
            if not planar:
                return np.asarray(R, dtype=float)
            R3 = np.eye(3)
            R3[:2, :2] = R
            return R3

        ni = np.zeros((k, NIC), dtype=np.int64)
        node = np.zeros((k + 1, NWC))
        body = np.zeros((nb, BWC))
        bi = np.full((nb, 1), -1, dtype=np.int64)
        # per body: anchor node and the placement (R, p, angle) of its frame in the node's
        Xr = [np.eye(3)] * nb
        Xp = [np.zeros(3)] * nb
        Xa = [0.0] * nb
        anchor = [-1] * nb
        lumped: dict[int, list] = {}
        for b in model.bodies[1:]:
            a = b.parent
            R0, p0 = lift_rot(b.placement_rotation), lift(b.placement_origin)
            # placement of the joint frame in the parent's anchor node frame
            Rj = Xr[a] @ R0
            pj = Xp[a] + Xr[a] @ p0
            aj = Xa[a] + b.placement_angle
            if b.coordinates:
                for i, (j, mo) in enumerate(zip(b.coordinates, b.motions)):
                    ni[j, NI_PARENT] = anchor[a] if i == 0 else b.coordinates[i - 1]
                    ni[j, NI_KIND] = REVOLUTE if mo.kind == "revolute" else PRISMATIC
                    ni[j, NI_FIRST] = 1 if i == 0 else 0
                    node[j, NW_T0R:NW_T0R + 9] = (Rj if i == 0 else np.eye(3)).ravel()
                    if i == 0:
                        node[j, NW_T0P:NW_T0P + 3] = pj
                        node[j, NW_T0ANG] = aj
                    axis = (np.array([0.0, 0.0, mo.axis[0]]) if planar and mo.kind == "revolute"
                            else lift(mo.axis))
                    node[j, NW_AXIS:NW_AXIS + 3] = axis
                anchor[b.index] = b.coordinates[-1]
                Xr[b.index], Xp[b.index], Xa[b.index] = np.eye(3), np.zeros(3), 0.0
            else:
                anchor[b.index] = anchor[a]
                Xr[b.index], Xp[b.index], Xa[b.index] = Rj, pj, aj
            bi[b.index, 0] = anchor[b.index]
            body[b.index, BW_XR:BW_XR + 9] = Xr[b.index].ravel()
            body[b.index, BW_XP:BW_XP + 3] = Xp[b.index]
            body[b.index, BW_XANG] = Xa[b.index]
            if anchor[b.index] >= 0:
                I = b.inertia
                I3 = np.diag([0.0, 0.0, float(I[0, 0])]) if planar else np.asarray(I, float)
                R = Xr[b.index]
                lumped.setdefault(anchor[b.index], []).append(
                    (b.mass, Xp[b.index] + R @ lift(b.com), R @ I3 @ R.T))
        body[0, BW_XR:BW_XR + 9] = np.eye(3).ravel()
        body[0, BW_R:BW_R + 9] = np.eye(3).ravel()
        node[k, NW_R:NW_R + 9] = np.eye(3).ravel()  # the ground row
        for j, parts in lumped.items():
            m = sum(p[0] for p in parts)
            c = sum(p[0] * p[1] for p in parts) / m
            Ic = np.zeros((3, 3))
            for mb, cb, Ib in parts:
                d = cb - c
                Ic += Ib + mb * ((d @ d) * np.eye(3) - np.outer(d, d))
            node[j, NW_MASS] = m
            node[j, NW_COM:NW_COM + 3] = c
            node[j, NW_IC:NW_IC + 9] = Ic.ravel()
        ci = np.zeros((nc, CIC), dtype=np.int64)
        con = np.zeros((nc, CWC))
        for c, spec in enumerate(model.contacts):
            i, jb = spec.body, spec.other
            ci[c, CI_AI], ci[c, CI_AJ] = anchor[i], anchor[jb]
            ci[c, CI_TARGET] = PLANE if spec.target == "plane" else SPHERE
            con[c, CW_PI:CW_PI + 3] = Xp[i] + Xr[i] @ lift(spec.point)
            con[c, CW_RI] = spec.radius
            con[c, CW_PJ:CW_PJ + 3] = Xp[jb] + Xr[jb] @ lift(spec.other_point)
            con[c, CW_RJ] = spec.other_radius
            if spec.target == "plane":
                con[c, CW_NJ:CW_NJ + 3] = Xr[jb] @ lift(spec.normal)
                if not planar:
                    con[c, CW_TJ:CW_TJ + 3] = Xr[jb] @ spec.tangent
        self.node_of_body = np.array(anchor, dtype=np.int64)
        self.body_mass = np.array([0.0] + [b.mass for b in model.bodies[1:]])
        self.body_com = np.array([np.zeros(3)] + [lift(b.com) for b in model.bodies[1:]])
        self.gravity = lift(model.gravity)
        support = set()
        for c in range(nc):
            for a in ci[c, CI_AI], ci[c, CI_AJ]:
                while a >= 0:
                    support.add(int(a))
                    a = ni[a, NI_PARENT]
        csup = np.array(sorted(support), dtype=np.int64)

        self.shapes = work_shapes(k, nb, nc)
        sizes = [int(np.prod(s)) for s in self.shapes]
        header = H_OFF + N_WORK + N_ITAB
        iparts = [ni.ravel(), bi.ravel(), ci.ravel(), csup,
                  np.array(closures(), dtype=np.int64)]
        isizes = [p.size for p in iparts]
        n_int = header + sum(isizes)
        self.n_int = n_int
        self.offsets = n_int + np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        self.work_size = n_int + int(sum(sizes))
        ioff = header + np.concatenate([[0], np.cumsum(isizes)[:-1]]).astype(np.int64)
        itab = np.zeros(n_int, dtype=np.int64)
        itab[H_PLANAR], itab[H_K], itab[H_NB], itab[H_NC] = int(planar), k, nb, nc
        itab[H_NCS] = csup.size
        itab[H_OFF:H_OFF + N_WORK] = self.offsets
        itab[H_OFF + N_WORK:header] = ioff
        for o, p in zip(ioff, iparts):
            itab[o:o + p.size] = p
        self.itab = itab
        template = np.zeros(self.work_size)
        template.view(np.int64)[:n_int] = itab
        self.view(template, W_NODE)[:] = node
        self.view(template, W_BODY)[:] = body
        self.view(template, W_CON)[:] = con
        self.view(template, W_SCR)[SC_GRAV, :3] = lift(model.gravity)
        self._template = template

    def new_work(self) -> np.ndarray:
        """A fresh work buffer holding the model's constants (and the ground row)."""
        return self._template.copy()

    def view(self, work: np.ndarray, section: int) -> np.ndarray:
        """The section ``section`` (a ``W_*`` index) of ``work`` as an array view."""
        o = int(self.offsets[section])
        shape = self.shapes[section]
        return work[o:o + int(np.prod(shape))].reshape(shape)
