"""The firmly sticking contacts' linear system solved between Gauss-Seidel sweeps: the
subspace minimization of Silcowitz, Niebe & Erleben's projected Gauss-Seidel with subspace
minimization (PGS-SM, 2010), on Coulomb's law.

On the large sphere piles the nonsmooth Gauss-Seidel of :mod:`.gauss_seidel` plateaus with
its residual on sticking contacts whose velocity has not converged: the impulses drift along
an ill-conditioned linear mode (the spheres' spin) that Gauss-Seidel converges on slowly.
Here the contacts that stick with a margin (``|r_t| < ratio mu r_n``, ``r_n`` not negligible)
are the unknowns of ``u_S = 0`` (d equations each), every other contact held at its impulse:
``W_SS dr_S = -u_S``; the answer is projected onto the friction cones (a contact driven out
of its cone lands on its boundary, sliding) and the sweeps go on from there. On piles W has
more rows than rank and ``W_SS`` may be singular (a sphere on four sticking contacts: 12
unknowns for 6 velocities): it is solved shifted, ``(W_SS + eps I)``, with iterative
refinement (the proximal point's iteration: components in W_SS's null space stay where
they were).

Measured on the 624-sphere pile from the NSGS's iterate after 1,000 sweeps, one step every 50
sweeps: its residual 6.3e-6 after 4,800 sweeps, 1.1e-4 without the steps (the distance to
the certified answer 0.0017 against 0.039 of |r|). Left out of the unknowns, measured:

* the sliding contacts (``r = r_n (1, -mu t)`` with t held, ``u_n = 0``): the system of the
  624-sphere pile then had singular values down to 1.6e-4 (of 100), its answer moved the
  impulses by 20 % away from the solution (t from the impulse or from the velocity alike);
* the sticking contacts near their cone's boundary (``|r_t| >= 0.9 mu r_n``): pinned to
  ``u = 0`` they kept sticking where they slide at the solution (with every sticking
  contact an unknown the residual rose to 1e-2-3e-1);
* the contacts of ``r_n`` at round-off (1e-12, open ones the sweeps left there): as
  unknowns they were pinned to ``u = 0`` while separating.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .cones import project

#: :func:`stick_step`: a contact is an unknown where ``|r_t| < STICK_RATIO mu r_n`` (on the
#: 624-sphere pile from the NSGS's iterate after 1,000 sweeps, a step every 50 sweeps: the
#: distance to the certified answer after 2,400 more 0.0096 of |r| at 0.9, 0.059 without
#: steps; at 0.7 the engine's sweeps on the large piles 5,400-7,900 where 0.9 took
#: 3,100-5,000)
STICK_RATIO = 0.9
#: ...and ``r_n > OPEN_REL max |r|``
OPEN_REL = 1e-8
#: the shift of ``W_SS``, relative to its mean diagonal, and the refinement steps (1e-6 and
#: 1e-4 alike where b is exactly J v; with b moved by 1e-6, b_S leaves W_SS's range and the
#: shifted solve's null-space part grows as 1 / eps: at 1e-6 the 897-sphere pile's steps
#: held it at 9e-5 for 30,000 sweeps)
SHIFT = 1e-4
REFINE = 2
#: a step that moves the impulses by more than this fraction of |r| is not taken (a
#: near-singular W_SS)
MAX_CHANGE = 0.05


def stick_step(W: sp.csr_matrix, b: np.ndarray, mu: np.ndarray, r: np.ndarray, *,
               ratio: float = STICK_RATIO, open_rel: float = OPEN_REL, shift: float = SHIFT,
               refine: int = REFINE, max_change: float = MAX_CHANGE) -> np.ndarray | None:
    """The impulses with the firmly sticking contacts' velocity solved to zero.

    Parameters
    ----------
    W : (n d, n d) sparse matrix
        The Delassus matrix (symmetric positive semidefinite).
    b : (n, d) array
        The free velocity.
    mu : (n,) array
        Friction coefficients (a frictionless contact is never an unknown).
    r : (n, d) array
        The current impulses.
    ratio, open_rel : float
        The unknowns: the contacts with ``|r_t| < ratio mu r_n`` and
        ``r_n > open_rel max |r|``.
    shift : float
        ``W_SS`` is factored as ``W_SS + shift mean(diag W_SS) I``...
    refine : int
        ...and the step refined this many times on ``W_SS dr = -u_S``.
    max_change : float
        No step where it would move the impulses by more than this fraction of ``|r|``.

    Returns
    -------
    (n, d) array or None
        ``r`` with the unknowns' impulses moved by the step, projected onto the friction
        cones; None where there is no unknown, the system is singular to round-off or the
        step is too long.
    """
    n, d = r.shape
    rn = r[:, 0]
    rt = np.sqrt(np.einsum("ij,ij->i", r[:, 1:], r[:, 1:]))
    scale = float(np.max(np.abs(r), initial=0.0))
    firm = (rn > open_rel * scale) & (rt < ratio * mu * rn)  # (frictionless: never)
    S = np.flatnonzero(firm)
    if S.size == 0:
        return None
    rows = (S[:, None] * d + np.arange(d)).ravel()
    rhs = -(W @ r.ravel() + np.asarray(b, dtype=float).ravel())[rows]
    A = sp.csc_matrix(W[rows][:, rows])
    eps = shift * float(np.mean(A.diagonal()))
    try:
        # symmetric positive definite: SuperLU in its symmetric mode (diagonal pivots, minimum
        # degree on A + A^T) factors it in 0.9 ms, 2.1 ms in its default (1,065 unknowns)
        lu = spla.splu(sp.csc_matrix(A + eps * sp.identity(rows.size, format="csc")),
                       permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
        dx = lu.solve(rhs)
        for _ in range(refine):
            dx += lu.solve(rhs - A @ dx)
    except RuntimeError:  # exactly singular
        return None
    if not np.all(np.isfinite(dx)) or \
            np.linalg.norm(dx) > max_change * np.linalg.norm(r):
        return None
    out = np.asarray(r, dtype=float).ravel().copy()
    out[rows] += dx
    return project(out.reshape(n, d), mu)
