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

The algorithms live in modules by what they compute; this module hands their public names on
(the flags, codes and column indices, :func:`evaluate`, :class:`Layout` and the Cholesky
helpers), and none of them imports it:

* :mod:`~convimpact.model.tree_layout`: the stage flags and status codes, the layout of the
  work buffer (:class:`Layout`, :func:`work_shapes`, :func:`closures`);
* :mod:`~convimpact.model.compiled_algebra`: small spatial algebra and dense Cholesky
  (:func:`cholesky`, :func:`cho_solve_vec`, :func:`cho_solve_mat`, :func:`all_finite`);
* :mod:`~convimpact.model.tree_kinematics`: placements, motion subspaces, velocities and
  :func:`point_columns`;
* :mod:`~convimpact.model.tree_dynamics`: inertias, M (CRBA), f and p_dot (Newton-Euler),
  M_dot;
* :mod:`~convimpact.model.tree_contacts`: contact gaps, frames, Jacobians and their rates;
* :mod:`~convimpact.model.tree_evaluate`: :func:`evaluate`, the one entry point that runs the
  stages a request needs.
"""

from __future__ import annotations

from .compiled_algebra import all_finite, cho_solve_mat, cho_solve_vec, cholesky  # noqa: F401
from .tree_evaluate import evaluate  # noqa: F401
from .tree_kinematics import point_columns  # noqa: F401
from .tree_layout import (  # noqa: F401
    BIAS, BWC, BW_ANG, BW_P, BW_R, BW_VO, BW_W, BW_XANG, BW_XP, BW_XR, CDOT, CHOL, CIC, CI_AI,
    CI_AJ, CI_TARGET, CONTACT, CPOS, CWC, CW_C, CW_E, CW_ED, CW_GAP, CW_NJ, CW_OK, CW_PI, CW_PJ,
    CW_RI, CW_RJ, CW_TJ, CW_X, CW_XD, EVALUATE_SIGNATURE, HAS_V, H_K, H_NB, H_NC, H_NCS, H_OFF,
    H_PLANAR, INERTIA, I_BI, I_CI, I_CL, I_CS, I_NI, MASS, MDOT, META_CHOL, META_DONE, META_HAS_Q,
    META_HAS_V, MWC, MW_S, MW_SD, MW_V, MW_Y, MW_YC, NIC, NI_FIRST, NI_KIND, NI_PARENT,
    NOT_DEFINITE, NWC, NW_A, NW_ANG, NW_AXIS, NW_COM, NW_F, NW_G, NW_H, NW_IC, NW_MASS, NW_P, NW_R,
    NW_S, NW_SD, NW_T0ANG, NW_T0P, NW_T0R, NW_V, NW_Y, NW_YC, N_FLAGS, N_ITAB, N_SCR, N_WORK, OK,
    PLANE, POS, PRISMATIC, Q_FLAGS, REQUIRES, REVOLUTE, R_BAD_SHAPE_Q, R_BAD_SHAPE_V,
    R_NON_FINITE_Q, R_NON_FINITE_V, R_NOT_DEFINITE, R_Q_CHANGED, R_V_CHANGED, SC_A, SC_B, SC_GRAV,
    SC_META, SC_W, SC_WD, SPHERE, VEL, V_BIAS, V_DTHETA, V_PDOT, V_THETA, W_BODY, W_CJ, W_CJD,
    W_CON, W_L, W_M, W_MD, W_MW, W_NODE, W_SCR, W_VEC, W_YD, Layout, closures, work_shapes,
)
