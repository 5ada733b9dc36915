"""The Poincaré section just after an impact: which contacts hold it, its tangent space, the
flow there, and the projection of a state onto it (used by :mod:`.periodic`).

Just after an impact every contact that touches and stays (|v_n| <= rest_velocity) holds
gap = 0 and J_n theta_dot = 0, and J_t theta_dot = 0 when it sticks; every contact that
touches and leaves (v_n > 0) holds gap = 0 (the section proper); the loops hold Psi = 0,
C theta_dot = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import AssemblyError, SolverError
from .initial import state_vector
from .projection import project_positions, project_velocities

__all__ = ["project_to_section"]


class PeriodicOrbitError(SolverError):
    """Newton shooting did not converge, or a stride could not be completed (no impact within
    ``t_max``, a failed simulation). Never comes with an answer."""


@dataclass(frozen=True)
class _Section:
    held: tuple[str, ...]
    sticking: tuple[str, ...]
    leaving: tuple[str, ...]


def _classify(mech, z, k, touch_tol, rest_velocity) -> _Section:
    th, dth = z[:k], z[k:]
    held, sticking, leaving = [], [], []
    for c in mech.contact_names:
        gap = float(mech.contact_gap(c, th))
        if abs(gap) > touch_tol:
            continue
        J = np.asarray(mech.contact_jacobian(c, th), float)
        v = J @ dth
        if v[0] > rest_velocity:
            leaving.append(c)
        else:
            held.append(c)
            if np.all(np.abs(v[1:]) <= rest_velocity):
                sticking.append(c)
    return _Section(tuple(held), tuple(sticking), tuple(leaving))


def _constraints(mech, sec: _Section, k: int):
    """c(z) = [Psi; gaps of held and leaving; C theta_dot; held rows . theta_dot]."""
    def c(z):
        th, dth = z[:k], z[k:]
        parts = [np.asarray(mech.loop_residual(th), float).ravel()]
        parts.append(np.array([mech.contact_gap(n, th) for n in sec.held + sec.leaving], float))
        if mech.n_loop_constraints:
            parts.append(np.asarray(mech.loop_jacobian(th), float) @ dth)
        for n in sec.held:
            J = np.asarray(mech.contact_jacobian(n, th), float)
            parts.append(J @ dth if n in sec.sticking else J[:1] @ dth)
        return np.concatenate(parts)
    return c


def _velocity_rows(mech, sec: _Section, th):
    rows = [np.asarray(mech.loop_jacobian(th), float).reshape(-1, th.size)]
    for n in sec.held:
        J = np.asarray(mech.contact_jacobian(n, th), float)
        rows.append(J if n in sec.sticking else J[:1])
    return np.vstack(rows)


def _jac(fun, x, h):
    f0 = np.asarray(fun(x), float)
    out = np.empty((f0.size, x.size))
    for i in range(x.size):
        e = np.zeros(x.size)
        e[i] = h
        out[:, i] = (np.asarray(fun(x + e), float) - np.asarray(fun(x - e), float)) / (2 * h)
    return out


def _null_space(A, n, rtol=1e-8):
    if A.shape[0] == 0:
        return np.eye(n)
    _, s, vt = np.linalg.svd(A)
    rank = int(np.sum(s > rtol * max(1.0, s[0])))
    return vt[rank:].T


def _flow(mech, sec: _Section, z, k):
    """d(theta, theta_dot)/dt at z with the held contacts (stick: all rows) closed."""
    th, dth = z[:k], z[k:]
    M = np.asarray(mech.mass_matrix(th), float)
    f = np.asarray(mech.generalized_forces(0.0, th, dth), float)
    A = _velocity_rows(mech, sec, th)
    if A.shape[0] == 0:
        return np.concatenate([dth, np.linalg.solve(M, f)])
    h = 1e-7 / max(1.0, float(np.linalg.norm(dth)))
    Adot_dth = (_velocity_rows(mech, sec, th + h * dth) - _velocity_rows(mech, sec, th - h * dth)
                ) @ dth / (2 * h)
    kkt = np.block([[M, -A.T], [A, np.zeros((A.shape[0], A.shape[0]))]])
    sol = np.linalg.solve(kkt, np.concatenate([f, -Adot_dth]))
    return np.concatenate([dth, sol[:k]])


def _project(mech, sec: _Section, z, k, tol=1e-12):
    """z moved onto the section's manifold (M-weighted minimal corrections); a failed
    projection is a :class:`PeriodicOrbitError`."""
    try:
        return _project_unchecked(mech, sec, z, k, tol)
    except AssemblyError as exc:
        raise PeriodicOrbitError(f"the state cannot be moved onto the section: {exc}") from exc


def _project_unchecked(mech, sec: _Section, z, k, tol):
    names = sec.held + sec.leaving
    th, dth = z[:k].copy(), z[k:].copy()
    M = np.asarray(mech.mass_matrix(th), float)

    def residual(t):
        return np.concatenate([np.asarray(mech.loop_residual(t), float).ravel(),
                               [mech.contact_gap(n, t) for n in names]])

    def jacobian(t):
        rows = [np.asarray(mech.loop_jacobian(t), float).reshape(-1, k)]
        rows += [np.asarray(mech.contact_jacobian(n, t), float)[:1] for n in names]
        return np.vstack(rows)

    if residual(th).size:
        th, _, _ = project_positions(residual, jacobian, M, th, tol)
    A = _velocity_rows(mech, sec, th)
    if A.shape[0]:
        dth = project_velocities(np.asarray(mech.mass_matrix(th), float), A, dth)
    return np.concatenate([th, dth])



def project_to_section(system, state, like) -> np.ndarray:
    """Move ``state`` [theta, theta_dot] onto the section of the orbit ``like`` (a
    :class:`~convimpact.simulation.PeriodicOrbit`): its held
    contacts' gaps and velocities and its section contacts' gaps zeroed (loops closed) by
    M-weighted minimal corrections (:func:`~convimpact.simulation.project_positions`,
    :func:`~convimpact.simulation.project_velocities`). For starting guesses made by
    displacing a fixed point (a branch switch at a period doubling): a displacement along
    the section's tangent space leaves its constraints violated at second order, enough for a
    held foot to strike at t = 0.
    """
    from .simulate import _as_mechanism

    mech, _ = _as_mechanism(system)
    k = int(mech.n_coordinates)
    z = state_vector("state", state, 2 * k)
    sec = _Section(tuple(like.held_contacts), tuple(like.sticking_contacts),
                   tuple(like.section_contacts))
    return _project(mech, sec, z, k)
