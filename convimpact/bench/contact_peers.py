"""Outside peers and an accuracy measure for contact problems ``u = W r + b`` given as
``(W, b, mu)`` (the corpus of :mod:`convimpact.bench.contact_corpus`).

* :func:`pinocchio_contact_call`: Pinocchio's ADMM or PGS constraint solver on ``W``, through
  the embedding of :func:`convimpact.bench.pinocchio_peers.embed_contact_problem` (rows
  permuted to Pinocchio's per-contact order (t1, t2, n), normal last; planar problems get a
  decoupled second tangent with zero drift). Law ``"ccp"`` runs with ``solve_ncp=False``
  (the cone complementarity problem), ``"coulomb"`` with ``solve_ncp=True`` (the De Saxce
  correction, Coulomb's law).
* :func:`natural_map_residual`: the relative error of the natural map
  ``r - P_K(r - y)``, ``y = u + mu |u_t| e_n`` (Coulomb) or ``y = u`` (CCP), ``P_K`` the
  projection on the product of friction cones ``K_mu = {|r_t| <= mu r_n}``
  (:func:`project_friction_cones`, in closed form).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp

LAWS = ("coulomb", "ccp")


def _check_law(law: str) -> None:
    if law not in LAWS:
        raise ValueError(f"law must be one of {LAWS}, got {law!r}")


def pinocchio_contact_call(W, b: np.ndarray, mu: np.ndarray, dim: int, law: str = "ccp",
                           tol: float = 1e-8, kind: str = "admm",
                           max_iterations: int = 10000,
                           sparse_delassus: bool = False,
                           check: float | None = None) -> Callable[[], np.ndarray]:
    """A no-argument call of Pinocchio's contact solver on ``u = W r + b``.

    Parameters
    ----------
    W : (n d, n d) dense array or scipy.sparse matrix, contacts normal first.
    b : (n d,) free velocity (restitution shift included).
    mu : (n,) friction coefficients.
    dim : contact dimension d, 2 or 3.
    law : ``"ccp"`` (``solve_ncp=False``) or ``"coulomb"`` (``solve_ncp=True``).
    tol : Pinocchio's absolute and relative feasibility and complementarity tolerances.
    kind : ``"admm"`` or ``"pgs"``.
    max_iterations : the solver's iteration cap.
    sparse_delassus : use ``DelassusOperatorSparse`` on the embedded W instead of the dense
        operator.
    check : when given, the call also raises RuntimeError if the returned impulse's
        :func:`natural_map_residual` exceeds it (Pinocchio 4.1's PGS reported convergence
        after 0 iterations with a residual of 0.18 on a sphere pile; ADMM has not done so).

    Returns
    -------
    A function returning the impulse ``r`` as an (n, d) array (normal first); it raises
    RuntimeError when the solver reports no convergence. The embedding and the solver's
    construction happen here, outside the call.
    """
    from .pinocchio_peers import embed_contact_problem, embedded_solver_call

    _check_law(law)
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    Wd = W.toarray() if sp.issparse(W) else np.asarray(W, dtype=float)
    n = Wd.shape[0] // dim
    mu = np.broadcast_to(np.asarray(mu, dtype=float), (n,))
    W3, g, idx = embed_contact_problem(Wd, np.asarray(b, dtype=float), dim)

    def back(lam: np.ndarray) -> np.ndarray:
        return np.asarray(lam)[idx].reshape(n, dim)

    delassus = None
    if sparse_delassus:
        import pinocchio as pin

        delassus = pin.DelassusOperatorSparse(sp.csc_matrix(W3))
    call = embedded_solver_call(W3, g, mu, back, kind, law == "coulomb", tol, max_iterations,
                                delassus=delassus)
    if check is None:
        return call
    b_vec = np.asarray(b, dtype=float)

    def checked() -> np.ndarray:
        r = call()
        res = natural_map_residual(W, b_vec, mu, r, law)
        if not res <= check:
            raise RuntimeError(f"Pinocchio {kind.upper()} reported convergence with a "
                               f"natural-map residual {res:.1e} > {check:g}")
        return r

    return checked


def project_friction_cones(x: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Projection of ``x`` (n, d), rows ``(x_n, x_t)``, on the product of the cones
    ``K_mu = {|x_t| <= mu x_n}`` (mu = 0: the half-line ``x_n >= 0, x_t = 0``).

    Closed form per contact, with ``s = |x_t|``: ``x`` itself when ``s <= mu x_n``; zero when
    ``mu s <= -x_n`` (``x`` in the polar cone); otherwise the point of the boundary ray
    ``(1, mu x_t / s)`` at abscissa ``(x_n + mu s) / (1 + mu^2)``.
    """
    x = np.asarray(x, dtype=float)
    mu = np.broadcast_to(np.asarray(mu, dtype=float), (x.shape[0],))
    xn, xt = x[:, 0], x[:, 1:]
    s = np.linalg.norm(xt, axis=1)
    out = np.zeros_like(x)
    inside = s <= mu * xn
    polar = mu * s <= -xn
    edge = ~inside & ~polar
    out[inside] = x[inside]
    a = (xn[edge] + mu[edge] * s[edge]) / (1.0 + mu[edge] ** 2)
    out[edge, 0] = a
    out[edge, 1:] = (a * mu[edge] / s[edge])[:, None] * xt[edge]
    return out


def natural_map_residual(W, b: np.ndarray, mu: np.ndarray, r: np.ndarray,
                         law: str = "coulomb") -> float:
    """Relative natural-map error of the impulse ``r`` for ``u = W r + b``:
    ``||r - P_K(r - y)|| / max(||b||, ||r||, ||u||)`` with ``y = u + mu |u_t| e_n``
    (``"coulomb"``) or ``y = u`` (``"ccp"``); 0 when ``b``, ``r`` and ``u`` all vanish.

    ``r`` may be (n d,) or (n, d); ``d`` is read from ``r`` when 2-D, else from
    ``len(b) / len(mu)``.
    """
    _check_law(law)
    b = np.asarray(b, dtype=float).ravel()
    mu = np.asarray(mu, dtype=float).ravel()
    r = np.asarray(r, dtype=float)
    d = r.shape[1] if r.ndim == 2 else b.size // mu.size
    r = r.reshape(-1, d)
    u = (np.asarray(W @ r.ravel()).ravel() + b).reshape(-1, d)
    y = u.copy()
    if law == "coulomb":
        y[:, 0] += mu * np.linalg.norm(u[:, 1:], axis=1)
    err = np.linalg.norm(r - project_friction_cones(r - y, mu))
    scale = max(np.linalg.norm(b), np.linalg.norm(r), np.linalg.norm(u))
    return float(err / scale) if scale > 0.0 else 0.0
