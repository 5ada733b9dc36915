"""The friction cones of a contact problem, vectorized over contacts.

A contact problem ``u = W r + b`` has per contact ``r_i = (r_n, r_t)`` (normal first) in the
friction cone ``K_mu = {|r_t| <= mu r_n}`` and its velocity in the dual cone
``K_mu* = {mu |u_t| <= u_n}``. The engine works in the standard second-order cone
``Q = {x_0 >= |x_1|}`` through ``r = D x``, ``D = diag(1, mu, ..., mu)`` per contact
(``z = D u`` then lies in Q exactly when u lies in ``K_mu*``, and ``x^T z = r^T u``); a
frictionless contact keeps its normal only (the half-line, a cone of dimension one).

Here: the projection onto the friction cones and the natural-map residual, the engine's
certificate. The interior points' second-order cone algebra (the Jordan product, the
Nesterov-Todd scaling) is compiled: :mod:`.interior_point`, applied group by group by
:mod:`.nt_kernels`.
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
