"""The largest-smallest-margin program (:func:`~.force_distribution.max_margin_distribution`,
stage 1) solved from a nearby program's active set by a primal-dual active-set method, where
Newton's method at that set alone fails: the set corrected by what its solution violates.

Newton's method on the optimality conditions with the cones' kinds fixed
(:func:`~.force_distribution_polish._newton_max_min`) solves the program exactly when the
kinds are the optimum's. A state moved along a step changes which cones bind: the box
stack's margin at a located event, its step's end and the combinations of modes at an event
each had an active set none of the nearby programs' had, and went to the solver (7 of the
run's margin programs). Here the kinds are corrected from the solution of the conditions
(not checked in the cones) at the current set: an inactive cone whose slack leaves it
binds (a half-line at zero, a second-order cone on its boundary ray along the slack), a
binding cone whose multiplier leaves the dual cone is released (a negative half-line's, a
ray's negative beta) or moved to the apex (a ray's negative alpha), and Newton's method
runs again from the last solution, at most :data:`ACTIVE_SET_ROUNDS` times. A set whose
solution meets every condition (primal and dual cones to 1e-12, the equations to 1e-12:
:func:`~.force_distribution_polish._newton_max_min`'s check) is the program's optimum, the
convex program's KKT point, whichever way it was found; else None (then the solver).
"""

from __future__ import annotations

import math

import numpy as np

from .force_distribution_polish import _cone_violation, _newton_max_min

#: corrections of the active set tried before the solver is asked
ACTIVE_SET_ROUNDS = 4
#: violation (of a slack or a multiplier, in units of the force scale) that changes a cone's
#: kind
VIOLATION = 1e-12


def corrected_max_min(blocks, kinds, parts, x0: np.ndarray):
    """(v, kinds, parts): the max-min program's optimum ``v = (y, tau, unknowns)`` with the
    active set it holds at, from the set (``kinds``, ``parts``: a nearby program's, as
    :func:`~.force_distribution_polish._warm_max_min` takes them) and the start ``x0 =
    (y, tau)``, corrected at most :data:`ACTIVE_SET_ROUNDS` times; None where no set so
    reached meets the optimality conditions."""
    kinds, parts = list(kinds), [np.asarray(p, float).copy() for p in parts]
    r = x0.size - 1
    x = x0.copy()
    for _ in range(ACTIVE_SET_ROUNDS + 1):
        v = _newton_max_min(blocks, kinds, [p.copy() for p in parts], x)
        if v is not None:
            return v, kinds, _parts(v, parts, r)
        # (the best iterate, where the conditions at this set have no solution: too few
        # cones bind; its violated slacks bind the missing ones)
        v = _newton_max_min(blocks, kinds, [p.copy() for p in parts], x, loose=True)
        x, parts = v[:r + 1].copy(), _parts(v, parts, r)
        if not _correct(blocks, kinds, parts, x):
            return None  # (every cone in its cone, yet not certified: leave it)
    return None


def _parts(v: np.ndarray, parts, r: int) -> list:
    """The unknowns of each cone in the solution vector v."""
    out, k = [], r + 1
    for p in parts:
        out.append(v[k:k + p.size].copy())
        k += p.size
    return out


def _correct(blocks, kinds, parts, x: np.ndarray) -> bool:
    """Change the kinds (and unknowns) of the cones that the solution ``x = (y, tau)`` with
    ``parts`` violates, in place; whether any changed."""
    r = x.size - 1
    y, tau = x[:r], x[r]
    changed = False
    for j, ((kind, Ab, bb, wb), how) in enumerate(zip(blocks, kinds)):
        p = parts[j]
        if how is None:
            s = bb - Ab @ y - tau * wb
            if _cone_violation(s, [(kind, len(bb))]) <= VIOLATION:
                continue
            if kind == "nn":
                kinds[j], parts[j] = "zero", np.zeros(len(bb))
            else:  # onto the boundary ray along the slack's tangential part
                st = s[1:]
                n = math.sqrt(float(st @ st))
                phi = math.atan2(float(st[1]), float(st[0])) if n > 0.0 else 0.0
                kinds[j] = ("ray", len(bb))
                parts[j] = np.array([max(0.5 * (float(s[0]) + n), 0.0), 0.0, phi])
            changed = True
        elif isinstance(how, str):  # s = 0: its multiplier must lie in the (dual) cone
            if _cone_violation(p, [(kind, len(bb))]) <= VIOLATION:
                continue
            if kind == "nn" or p[0] < 0.0:
                kinds[j], parts[j] = None, np.zeros(0)
            else:  # on the dual cone's boundary: the slack leaves the apex along a ray
                zt = p[1:]
                n = math.sqrt(float(zt @ zt))
                kinds[j] = ("ray", len(bb))
                parts[j] = np.array([0.0, float(p[0]),
                                     math.atan2(-float(zt[1]), -float(zt[0]))])
            changed = True
        else:  # a ray (alpha, beta, phi): both nonnegative
            alpha, beta, phi = float(p[0]), float(p[1]), float(p[2])
            if beta < -VIOLATION:
                kinds[j], parts[j] = None, np.zeros(0)
                changed = True
            elif alpha < -VIOLATION:
                kinds[j] = "zero"
                parts[j] = beta * np.array([1.0, -math.cos(phi), -math.sin(phi)])
                changed = True
    return changed


def warm_corrected(blocks, warm: dict, lam0: np.ndarray, Q: np.ndarray, scale: float):
    """(y, t*) of the max-min program by :func:`corrected_max_min` from the last program's
    active set and maximizer (``warm``, as :func:`~.force_distribution_polish._warm_max_min`
    keeps them; the set it ends with becomes the last), or None (no active cone to start
    from, another program's size, or no set certified)."""
    active, lam_prev = warm.get("active"), warm.get("lam")
    if active is None or lam_prev is None or lam_prev.shape != lam0.shape:
        return None
    kinds, parts = active
    if len(kinds) != len(blocks) or all(how is None for how in kinds):
        return None
    r = Q.shape[1]
    x0 = np.empty(r + 1)
    x0[:r] = Q.T @ ((lam_prev - lam0) / scale)
    x0[r] = warm["tau"]
    try:
        got = corrected_max_min(blocks, kinds, parts, x0)
    except (ValueError, np.linalg.LinAlgError):  # a cone's size differs: not this program
        return None
    if got is None:
        return None
    v, kinds, parts = got
    warm["active"] = (kinds, parts)
    return v[:r], float(v[r])
