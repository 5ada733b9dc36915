"""Random multibody impact data for the conic-law tests, and independent reference formulas.

Nothing here calls convimpact: the Delassus matrix is formed with the null-space formula
``G = N (N^T M N)^-1 N^T`` (N a basis of ker C), not with problem.py's Schur complement, and
the complementarity residuals are written out from the law definitions.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from hypothesis import strategies as st


def random_system(seed: int, d: int, n_contacts: int, loops: int, extra: int = 1):
    """(M, Jc, dq, C): SPD M, Jc rows (n, t...) per contact, dq in ker C, contact 0 approaching.

    k = n_contacts d + loops + extra joint coordinates, so W is generically nonsingular when
    extra >= 0; a negative extra gives redundant contacts (singular W).
    """
    rng = np.random.default_rng(seed)
    k = max(n_contacts * d + loops + extra, loops + 1)
    A = rng.normal(size=(k, k))
    M = A @ A.T + 0.5 * np.eye(k)
    J = rng.normal(size=(n_contacts, d, k))
    C = None
    if loops:
        C = rng.normal(size=(loops, k))
        N = sla.null_space(C)
        dq = N @ rng.normal(size=N.shape[1])
    else:
        dq = rng.normal(size=k)
    if J[0, 0] @ dq > 0:
        J[0, 0] *= -1.0
    if J[0, 0] @ dq > -1e-3:  # make the impact clearly approaching
        J[0, 0] -= 0.5 * dq / (dq @ dq) * (1.0 + J[0, 0] @ dq)
    Jc = J[0] if n_contacts == 1 else [J[i] for i in range(n_contacts)]
    return M, Jc, dq, C


def delassus(M, Jc, C=None):
    """W = Jc G Jc^T with G = N (N^T M N)^-1 N^T (independent of convimpact.impact.problem.build)."""
    J = np.asarray(Jc if not isinstance(Jc, list) else np.concatenate(Jc), dtype=float)
    J = J.reshape(-1, M.shape[0])
    if C is None:
        G = np.linalg.inv(M)
    else:
        N = sla.null_space(np.atleast_2d(C))
        G = N @ np.linalg.solve(N.T @ M @ N, N.T)
    return J @ G @ J.T


def ccp_residual(W, b, mu, d, pi):
    """max of cone violation, dual-cone violation and |pi_i . y_i| for y = W pi + b."""
    n = len(mu)
    x = np.ravel(pi).reshape(n, d)
    y = (W @ np.ravel(pi) + b).reshape(n, d)
    ps = max(np.linalg.norm(x), 1e-300)
    vs = max(np.linalg.norm(b), 1e-300)
    r = 0.0
    for i in range(n):
        r = max(r, max(0.0, np.linalg.norm(x[i, 1:]) - mu[i] * x[i, 0]) / ps)
        r = max(r, max(0.0, mu[i] * np.linalg.norm(y[i, 1:]) - y[i, 0]) / vs)
        r = max(r, abs(x[i] @ y[i]) / (ps * vs))
    return r


def coulomb_conditions(W, b, mu, d, pi):
    """Residual of K ∋ pi ⊥ u + mu |u_t| n ∈ K* with u = W pi + b (Moreau's Coulomb law)."""
    n = len(mu)
    u = (W @ np.ravel(pi) + b).reshape(n, d)
    shift = np.zeros((n, d))
    shift[:, 0] = np.asarray(mu) * np.linalg.norm(u[:, 1:], axis=1)
    return ccp_residual(W, b + shift.ravel(), mu, d, pi)


def newton_b(v_minus, e):
    """b = v- + e min(v_n-, 0) n, flattened."""
    v = np.array(v_minus, dtype=float).reshape(len(e), -1)
    v[:, 0] += np.asarray(e) * np.minimum(v[:, 0], 0.0)
    return v.ravel()


systems = st.fixed_dictionaries({
    "seed": st.integers(0, 2**32 - 1),
    "d": st.sampled_from([2, 3]),
    "n_contacts": st.integers(1, 3),
    "loops": st.integers(0, 1),
    "e": st.floats(0.0, 1.0),
    "mu": st.floats(0.05, 1.5),
})
