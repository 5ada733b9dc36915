"""The friction cones of a contact problem, vectorized over contacts.

A contact problem ``u = W r + b`` has per contact ``r_i = (r_n, r_t)`` (normal first) in the
friction cone ``K_mu = {|r_t| <= mu r_n}`` and its velocity in the dual cone
``K_mu* = {mu |u_t| <= u_n}``. The engine works in the standard second-order cone
``Q = {x_0 >= |x_1|}`` through ``r = D x``, ``D = diag(1, mu, ..., mu)`` per contact
(``z = D u`` then lies in Q exactly when u lies in ``K_mu*``, and ``x^T z = r^T u``); a
frictionless contact keeps its normal only (the half-line, a cone of dimension one).

Second-order cone algebra after Vandenberghe, "The CVXOPT linear and quadratic cone program
solvers" (2010): the Jordan product ``x o y = (x^T y, x_0 y_1 + y_0 x_1)``, its inverse, and
the Nesterov-Todd scaling ``G`` with ``G z = G^-1 x = lambda``. Arrays of cones are ``(n, m)``
(one row per cone).
"""

from __future__ import annotations

import numpy as np


def project(r: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Projection of each row of ``r`` (n, d), normal first, onto ``K_mu``.

    Closed form: inside, itself; in the polar cone ``{mu |r_t| <= -r_n}``, zero; otherwise
    onto the cone's boundary ray through ``r_t``:
    ``r_n' = (r_n + mu |r_t|) / (1 + mu^2)``, ``r_t' = mu r_n' r_t / |r_t|``.
    ``mu = 0``: the normal half-line.
    """
    rn = r[:, 0]
    rt = r[:, 1:]
    t = np.sqrt(np.einsum("ij,ij->i", rt, rt))
    inside = t <= mu * rn
    polar = mu * t <= -rn
    pn = (rn + mu * t) / (1.0 + mu * mu)
    # on the boundary ray: r_t scaled by mu pn / |r_t| (|r_t| > 0 there)
    scale = np.divide(mu * pn, t, out=np.zeros_like(t), where=t > 0.0)
    scale = np.where(inside, 1.0, np.where(polar, 0.0, scale))
    out = np.empty_like(r)
    out[:, 0] = np.where(inside, rn, np.where(polar, 0.0, pn))
    out[:, 1:] = rt * scale[:, None]
    return out


def natural_map_residual(W, b: np.ndarray, mu: np.ndarray, r: np.ndarray,
                         coulomb: bool) -> tuple[float, np.ndarray]:
    """The relative natural-map error of ``r`` (n, d) and its velocity ``u = W r + b``.

    ``|r - P_K(r - y)| / max(|b|, |r|, |u|)`` with ``y = u + mu |u_t| e_n`` for Coulomb's law
    in De Saxce's form and ``y = u`` for the cone complementarity problem (CCP).
    """
    n, d = r.shape
    u = (W @ r.ravel()).reshape(n, d) + b.reshape(n, d)
    y = u.copy()
    if coulomb:
        y[:, 0] += mu * np.sqrt(np.einsum("ij,ij->i", u[:, 1:], u[:, 1:]))
    err = np.linalg.norm(r - project(r - y, mu))
    scale = max(np.linalg.norm(b), np.linalg.norm(r), np.linalg.norm(u), np.finfo(float).tiny)
    return float(err / scale), u


# --- the standard second-order cone, rows of an (n, m) array ------------------------------


def jdet(x: np.ndarray) -> np.ndarray:
    """``x_0^2 - |x_1|^2 = (x_0 - |x_1|)(x_0 + |x_1|)`` per row (the cone's determinant,
    factored so that it keeps its relative accuracy near the boundary)."""
    t = np.sqrt(np.einsum("ij,ij->i", x[:, 1:], x[:, 1:]))
    return (x[:, 0] - t) * (x[:, 0] + t)


def jprod(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The Jordan product ``x o y`` per row."""
    out = x[:, :1] * y + y[:, :1] * x
    out[:, 0] = np.einsum("ij,ij->i", x, y)
    return out


def jsolve(lam: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``t`` with ``lam o t = r`` per row (lam in the cone's interior)."""
    l0 = lam[:, 0]
    t0 = (r[:, 0] * l0 - np.einsum("ij,ij->i", lam[:, 1:], r[:, 1:])) / jdet(lam)
    out = np.empty_like(r)
    out[:, 0] = t0
    out[:, 1:] = (r[:, 1:] - t0[:, None] * lam[:, 1:]) / l0[:, None]
    return out


def nt_scaling(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nesterov-Todd scaling of interior points x, z of Q (rows).

    Returns ``(G, Ginv, lam)``: symmetric positive definite ``G`` (n, m, m) with
    ``G z = G^-1 x = lam``. One-dimensional cones: ``G = sqrt(x / z)``.
    """
    n, m = x.shape
    if m == 1:
        g = np.sqrt(x[:, 0] / z[:, 0])
        return g[:, None, None], (1.0 / g)[:, None, None], np.sqrt(x * z)
    sx = np.sqrt(jdet(x))
    sz = np.sqrt(jdet(z))
    xb = x / sx[:, None]
    zb = z / sz[:, None]
    gamma = np.sqrt(0.5 * (1.0 + np.einsum("ij,ij->i", xb, zb)))
    w = xb.copy()
    w[:, 0] += zb[:, 0]
    w[:, 1:] -= zb[:, 1:]
    w /= 2.0 * gamma[:, None]                       # w^T J w = 1, w_0 >= 1
    v = w.copy()
    v[:, 0] += 1.0
    v /= np.sqrt(2.0 * (w[:, 0] + 1.0))[:, None]
    beta = np.sqrt(sx / sz)
    J = np.ones(m)
    J[1:] = -1.0
    vvT = 2.0 * v[:, :, None] * v[:, None, :]
    G = beta[:, None, None] * (vvT - np.diag(J))
    Jv = v * J
    Ginv = (2.0 * Jv[:, :, None] * Jv[:, None, :] - np.diag(J)) / beta[:, None, None]
    lam = np.einsum("nij,nj->ni", G, z)
    return G, Ginv, lam


def max_step(x: np.ndarray, dx: np.ndarray) -> float:
    """The largest ``a >= 0`` (capped at 1e30) with ``x + a dx`` in Q for every row."""
    if x.shape[1] == 1:
        neg = dx[:, 0] < 0.0
        return float(np.min(-x[neg, 0] / dx[neg, 0], initial=1e30))
    # (x0 + a d0)^2 - |x1 + a d1|^2 >= 0 and x0 + a d0 >= 0
    a = jdet(dx)
    h = x[:, 0] * dx[:, 0] - np.einsum("ij,ij->i", x[:, 1:], dx[:, 1:])
    c = np.maximum(jdet(x), 0.0)
    step = np.full(x.shape[0], 1e30)
    disc = np.maximum(h * h - a * c, 0.0)
    root = np.sqrt(disc)
    with np.errstate(divide="ignore", invalid="ignore"):
        # smallest positive root of a s^2 + 2 h s + c = 0
        r1 = np.where(a != 0.0, (-h - root) / a, -c / (2.0 * h))
        r2 = np.where(a != 0.0, (-h + root) / a, np.inf)
    for r in (r1, r2):
        ok = np.isfinite(r) & (r > 0.0)
        step = np.where(ok & (r < step), r, step)
    lin = dx[:, 0] < 0.0
    step = np.where(lin, np.minimum(step, -x[:, 0] / np.where(lin, dx[:, 0], -1.0)), step)
    return float(step.min(initial=1e30))
