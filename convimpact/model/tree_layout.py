"""The layout of a model's work buffer, and the stage flags of the compiled recursive algorithms.

The tree walked by :mod:`convimpact.model.recursive` is the tree of *elementary motions*:
node j is joint coordinate j (a revolute turn about, or a prismatic slide along, one axis),
its parent the coordinate that moves it last (the previous motion of the same joint, or the
last coordinate of the nearest ancestor body that has coordinates; -1 for the ground). Bodies
welded by fixed joints ride on the node of their anchor and their masses are lumped into it
once, when the tables are built (:class:`Layout`), so a multi-coordinate joint is a chain of
nodes through massless frames (as in Pinocchio). Planar models are embedded in space (z = 0,
revolute axes along z).

All arrays live in one flat buffer per :class:`~convimpact.model.data.Data` (its layout
built once per model, :class:`Layout`): first the integer table (sizes, the offsets of the
sections, parents and kinds, read through an int64 view), then the model's constants, the
state and every computed quantity, so a call from Python passes four arguments and the
kernel makes a dozen views.
Per node, body and contact the quantities are columns of one row (``NW_*``, ``BW_*``,
``CW_*``) and are reached by (row, column offset), never by views made in the loops (a view
costs an atomic reference count, as much as the arithmetic of a small model). Node rows
have one extra row, the ground (index -1): identity placement, zero velocity, acceleration
``-g``. The buffer also records the state it holds and which stages are current (the
``SC_META`` row), so :func:`~convimpact.model.tree_evaluate.evaluate` runs only the stages
missing.

This module defines the stage flags (``POS`` ... ``CPOS``, each with the stages it
:data:`REQUIRES`), the status codes (``R_*`` bits), the section and column indices, the
shapes of the sections (:func:`work_shapes`), the closure of every flag combination under
its prerequisites (:func:`closures`) and the tables themselves (:class:`Layout`). The compiled
stages read the constants as globals, frozen into their machine code.
"""

from __future__ import annotations

import numpy as np

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
