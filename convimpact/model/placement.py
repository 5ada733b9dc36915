"""Placing a mechanism at rest on chosen contacts: closed gaps and zero normal velocities.

:func:`place_resting` moves a guessed configuration the least distance, in the metric of the
mass matrix at the guess, onto the configurations where the named contacts touch (gap exactly
zero) and every loop closes (Psi = 0). :func:`rest_velocity` removes the normal velocity of
those contacts (and keeps ``C theta_dot = 0``) by the M-metric projection, so a scene can
start resting on them. Both work with any :class:`~convimpact.mechanism.Mechanism`: they use
the gap and the normal row of the contact Jacobian, which is the gap's gradient
(``d(gap)/dt = Jc[0] @ theta_dot``).

>>> import numpy as np
>>> from convimpact.model import Joint, ModelBuilder, place_resting
>>> b = ModelBuilder(planar=True)
>>> _ = b.add_body("box", "ground", Joint.free(), 1.0, (0, 0), 1 / 12,
...                coordinate_names=["x", "y", "phi"])
>>> for name, sx in (("left", -0.5), ("right", 0.5)):
...     b.add_contact(name, body="box", point=(sx, -0.25), normal=(0, 1))
>>> mech = b.build().mechanism()
>>> theta = place_resting(mech, [0.3, 1.0, 0.2], ["left", "right"])
>>> np.round(theta, 12).tolist()    # lying flat on the floor, centre 0.25 above it
[0.3, 0.25, 0.0]
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import (
    AssemblyError,
    MassMatrixError,
    ModelError,
    ParameterError,
    ShapeError,
    SingularSystemError,
)
from .loops import _fixed_indices

#: relative singular-value threshold below which constraint rows count as dependent
RANK_RTOL = 1e-10
#: residual (max |gap|, |Psi|) below which a step that raises it is still taken; a
#: Gauss-Newton step from there brings it back to round-off
ACCEPT_BAND = 1e-6


def _names(mechanism, contacts) -> list[str]:
    if isinstance(contacts, str):
        contacts = [contacts]
    names = list(contacts)
    known = list(getattr(mechanism, "contact_names", ()))
    for c in names:
        if not isinstance(c, str) or c not in known:
            raise ModelError(f"unknown contact {c!r}; contacts are {', '.join(known) or 'none'}")
    dup = sorted({c for c in names if names.count(c) > 1})
    if dup:
        raise ParameterError(f"contact(s) {', '.join(map(repr, dup))} named more than once")
    return names


def _vector(value, k: int, what: str) -> np.ndarray:
    try:
        a = np.array(value, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ShapeError(f"{what} must be a numeric {k}-vector, got {value!r}") from None
    if a.shape != (k,):
        raise ShapeError(f"{what} must have {k} entries (one per coordinate), got {a.size}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{what} must be finite, got {a.tolist()}")
    return a


def _constraints(mechanism, names: list[str],
                 theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Values (gaps, then Psi), their Jacobian (normal rows, then C) and the full contact
    Jacobians (n_contacts, d, k) at theta."""
    k = mechanism.n_coordinates
    gaps = np.array([mechanism.contact_gap(c, theta) for c in names], dtype=float)
    Jc = [np.atleast_2d(np.asarray(mechanism.contact_jacobian(c, theta), dtype=float))
          for c in names]
    J_all = np.array(Jc).reshape(len(names), -1, k) if names else np.zeros((0, 1, k))
    G = J_all[:, 0, :]
    if mechanism.n_loop_constraints:
        psi = np.asarray(mechanism.loop_residual(theta), dtype=float)
        C = np.asarray(mechanism.loop_jacobian(theta), dtype=float).reshape(-1, k)
    else:
        psi, C = np.zeros(0), np.zeros((0, k))
    return np.concatenate([gaps, psi]), np.vstack([G, C]), J_all


def _metric_factor(W: np.ndarray) -> np.ndarray:
    """Cholesky factor L (W = L L^T) of the metric on the free coordinates."""
    try:
        return np.linalg.cholesky(0.5 * (W + W.T))
    except np.linalg.LinAlgError:
        raise MassMatrixError(
            "the mass matrix restricted to the free coordinates is not positive definite, so "
            "'nearest in the M metric' is undefined; fix the coordinates that carry no "
            "inertia") from None


def _rank(rows: np.ndarray) -> int:
    if rows.shape[0] == 0:
        return 0
    return int(np.sum(np.linalg.svd(rows, compute_uv=False) > RANK_RTOL))


def _check_rank(S: np.ndarray, mobility: np.ndarray, names: list[str], n_free: int) -> None:
    """Raise when the contact rows of S = A L^-T are dependent on each other or on the loops.

    Each contact row is measured against its contact point's whole mobility (the norm of its
    full Jacobian in the same metric), each loop row against its own norm, so the test does
    not depend on units: a gap whose gradient is negligible next to how its point can move
    (a gap at a minimum, a point sliding along its plane) counts as dependent.
    """
    n = len(names)
    if S.shape[0] == 0:
        return
    scale = np.concatenate([mobility, np.linalg.norm(S[n:], axis=1)])
    keep = scale > 0
    rows = np.where(keep[:, None], S / np.where(keep, scale, 1.0)[:, None], 0.0)
    loops = rows[n:][keep[n:]]
    rank_loops = _rank(loops)
    rank_all = _rank(np.vstack([rows[:n], loops]))
    if rank_all < rank_loops + n:
        raise SingularSystemError(
            f"the gaps of contacts {', '.join(names)} are not independent here (rank "
            f"{rank_all - rank_loops} of {n} after the loop constraints, {n_free} free "
            "coordinates): they cannot be closed as separate conditions. Name fewer contacts, "
            "fix fewer coordinates, or start from a guess where each contact can still move "
            "(a gap at its minimum has a zero gradient)")


def _kkt_step(W_L: np.ndarray, A: np.ndarray, J_all: np.ndarray, c: np.ndarray,
              r: np.ndarray, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Steps of the linearised problem min |r + d|_W s.t. c + A d = 0 (free columns).

    Returns (d_feasible, d_tangent): the least-W-norm correction of c, and the move toward
    the guess that keeps the linearised constraints; their sum solves the problem.
    """
    # change of variables z = L^T d: W-norms become Euclidean, A d = S z with S = A L^-T
    S = np.linalg.solve(W_L, A.T).T
    mobility = np.array([np.linalg.norm(np.linalg.solve(W_L, J.T)) for J in J_all])
    _check_rank(S, mobility, names, A.shape[1])
    Sp = np.linalg.pinv(S, rcond=RANK_RTOL)
    z_r = W_L.T @ r
    z_f = -Sp @ c
    z_t = -(z_r - Sp @ (S @ z_r))
    return np.linalg.solve(W_L.T, z_f), np.linalg.solve(W_L.T, z_t)


def place_resting(mechanism, theta, contacts: Sequence[str] | str, fixed: Sequence = (),
                  tol: float = 1e-13, max_iter: int = 50) -> np.ndarray:
    """The configuration nearest ``theta`` where the named contacts touch and loops close.

    Solves ``min (theta' - theta)^T M(theta) (theta' - theta)`` subject to
    ``gap_c(theta') = 0`` for every named contact and ``Psi(theta') = 0``, with the ``fixed``
    coordinates kept, by Gauss-Newton: each step solves the problem with the constraints
    linearised (normal rows of the contact Jacobians and C) and the metric frozen at the
    guess, halving the step while it would raise the constraint residual. The fixed point is
    a stationary point of the nonlinear problem (its Lagrange conditions hold).

    Parameters
    ----------
    mechanism : a :class:`~convimpact.mechanism.Mechanism`.
    theta : (k,) the guess, e.g. the body held above the floor at the wanted attitude.
    contacts : names of the contacts to close (a single name is accepted).
    fixed : coordinates kept at their guessed values, by index or by name when the
        mechanism has ``coordinate_index`` (e.g. the tilt angle of a block).
    tol : tolerance on ``max |gap|`` and ``max |Psi|`` (absolute, in their units).
    max_iter : Gauss-Newton iterations allowed.

    Returns
    -------
    theta : (k,) the placed configuration: every named gap and Psi within ``tol``.

    Raises
    ------
    ModelError
        Unknown contact or coordinate names, or fixed indices out of range.
    ParameterError, ShapeError
        A contact named twice, a guess of the wrong size or not finite, bad tol/max_iter.
    MassMatrixError
        M restricted to the free coordinates is not positive definite.
    SingularSystemError
        The named gaps are not independent (redundant contacts, too many fixed
        coordinates, or a contact whose gap is at a minimum it cannot leave).
    AssemblyError
        The iteration does not reach ``tol`` (e.g. a contact that cannot reach its surface)
        or does not settle within ``max_iter``; the message reports the residual.

    Examples
    --------
    See the module docstring.
    """
    k = mechanism.n_coordinates
    guess = _vector(theta, k, "theta")
    names = _names(mechanism, contacts)
    if not (np.isfinite(tol) and tol > 0):
        raise ParameterError(f"tol must be positive, got {tol}")
    if int(max_iter) < 1:
        raise ParameterError(f"max_iter must be at least 1, got {max_iter}")
    fix = _fixed_indices(mechanism, fixed)
    free = np.setdiff1d(np.arange(k), fix)
    n_rows = len(names) + mechanism.n_loop_constraints
    if n_rows == 0:
        return guess
    if free.size == 0:
        raise SingularSystemError("every coordinate is fixed: nothing can move to close "
                                  f"the contacts {', '.join(names)}")
    W_L = _metric_factor(np.asarray(mechanism.mass_matrix(guess), dtype=float)[np.ix_(free, free)])
    step_tol = 1e-10 * (1.0 + float(np.max(np.abs(guess))))

    th = guess.copy()
    c, A, J = _constraints(mechanism, names, th)
    res = float(np.max(np.abs(c)))
    for _ in range(int(max_iter)):
        d_f, d_t = _kkt_step(W_L, A[:, free], J[:, :, free], c, (th - guess)[free], names)
        if res <= tol and np.max(np.abs(d_t)) <= step_tol:
            return th
        step = d_f + d_t
        lam, moved = 1.0, False
        for _ in range(40):
            trial = th.copy()
            trial[free] += lam * step
            c_t, A_t, J_t = _constraints(mechanism, names, trial)
            res_t = float(np.max(np.abs(c_t)))
            if np.isfinite(res_t) and (res_t < res or res_t <= max(tol, ACCEPT_BAND)):
                moved = True
                break
            lam *= 0.5
            if lam < 1e-3 and step is not d_f:
                step, lam = d_f, 1.0  # the pull toward the guess hinders: correct gaps only
        if not moved:
            break
        th, c, A, J, res = trial, c_t, A_t, J_t, res_t
    else:
        d_f, d_t = _kkt_step(W_L, A[:, free], J[:, :, free], c, (th - guess)[free], names)
        if res <= tol and np.max(np.abs(d_t)) <= step_tol:
            return th
        if res <= tol:
            raise AssemblyError(
                f"the contacts {', '.join(names)} are closed (max residual {res:.2e}) but the "
                f"minimum-norm iteration did not settle in {max_iter} iterations; start from "
                "a guess nearer the resting configuration or raise max_iter")
    raise AssemblyError(
        f"cannot place the mechanism resting on {', '.join(names)}: max |gap|, |Psi| = "
        f"{res:.3e} after Gauss-Newton (tolerance {tol:.1e}). The contacts may not be able "
        "to reach their surfaces together (check the geometry and the fixed coordinates), "
        "or the guess is too far")


def rest_velocity(mechanism, theta, dtheta, contacts: Sequence[str] | str,
                  fixed: Sequence = ()) -> np.ndarray:
    """Remove the normal velocity of the named contacts by the M-metric projection.

    Returns the velocity nearest ``dtheta`` in the kinetic-energy metric,
    ``min (v - dtheta)^T M (v - dtheta)``, with ``Jc_n v = 0`` for every named contact,
    ``C v = 0`` (loops) and the ``fixed`` coordinates' rates unchanged. Tangential (slip)
    velocities are kept as far as the constraints allow.

    Parameters
    ----------
    mechanism : a :class:`~convimpact.mechanism.Mechanism`.
    theta : (k,) configuration (normally placed with :func:`place_resting`).
    dtheta : (k,) wanted velocities.
    contacts : names of the contacts that rest (a single name is accepted).
    fixed : coordinates whose rates are kept (indices or names).

    Returns
    -------
    dtheta : (k,) corrected velocities.

    Raises
    ------
    ModelError, ParameterError, ShapeError, MassMatrixError
        As in :func:`place_resting`.
    SingularSystemError
        The normal rows are dependent (together with the loops and fixed rates).
    """
    k = mechanism.n_coordinates
    th = _vector(theta, k, "theta")
    v = _vector(dtheta, k, "dtheta")
    names = _names(mechanism, contacts)
    fix = _fixed_indices(mechanism, fixed)
    free = np.setdiff1d(np.arange(k), fix)
    _, A, J = _constraints(mechanism, names, th)
    if A.shape[0] == 0:
        return v
    if free.size == 0:
        raise SingularSystemError("every coordinate rate is fixed: nothing can change to stop "
                                  f"the contacts {', '.join(names)}")
    W_L = _metric_factor(np.asarray(mechanism.mass_matrix(th), dtype=float)[np.ix_(free, free)])
    d_f, _ = _kkt_step(W_L, A[:, free], J[:, :, free], A @ v, np.zeros(free.size), names)
    out = v.copy()
    out[free] += d_f
    return out


__all__ = ["place_resting", "rest_velocity"]
