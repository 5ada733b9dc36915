"""The derivative of law ``"stronge"`` on several coupled contacts: the two-phase formulation
of :mod:`convimpact.impact.laws.stronge_contacts`, differentiated phase by phase.

``pi = pi_c + x``:

1. **Compression** ``pi_c``, Moreau's plastic impulse with Coulomb friction (law
   ``coulomb`` with e = 0): its derivative is that law's several-contact derivative
   (:func:`convimpact.impact.laws.cone_derivative.coulomb_several`, the implicit
   differentiation of its mode equations) on the plastic problem.
2. **Expansion** ``x``: normals ``x_n,i = e_i pi_c,n,i``, tangential impulses minimizing
   ``1/2 x.W.x + x.v_c`` (``v_c = v- + W pi_c``) over the discs ``|x_t,i| <= r_i = mu_i
   x_n,i``. Its KKT conditions per contact, with ``g = (W x + v_c)_t,i``: inside the disc
   ``g = 0``; on its boundary ``x_t,i + r_i g / |g| = 0``. Differentiated with the active
   set fixed::

       inside:    (W dx + dW x + dv_c)_t,i = 0
       boundary:  dx_t,i + dr_i g/|g| + (r_i / |g|) (I - g g^T / |g|^2) dg = 0,
       dv_c = dv- + dW pi_c + W dpi_c,   dx_n,i = de_i pi_c,n,i + e_i dpi_c,n,i.

   A contact on the disc's boundary with ``g = 0`` (sticking at the friction limit) is
   between the two sets: one-sided (``other_side`` swaps its set).

Not covered (NotSupportedError): an expansion scaled down to keep energy (``kappa < 1``,
different e per coupled contact) and a second plastic compression after the expansion.
"""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np

from ..derivatives.contact import ContactDerivative
from ...errors import NotSupportedError
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from .stronge_path import symmetric_tensor

#: |x_t| within this (relative) of the disc's radius counts as on its boundary, as the
#: expansion's own KKT certificate does
DISC_RTOL = 1e-9
#: |g| below this (relative to the velocity scale) on the boundary: between inside and boundary
LIMIT_RTOL = 1e-7


def _columns(D: ContactDerivative, N: int, n: int) -> np.ndarray:
    """A ContactDerivative as a matrix over theta = (W's upper triangle, v, e, mu)."""
    iu = list(zip(*np.triu_indices(N)))
    cols = [D.W[:, i, j] + D.W[:, j, i] if i != j else D.W[:, i, i] for i, j in iu]
    return np.column_stack(cols + [D.v, D.e, D.mu])


def _tensor(G: np.ndarray, N: int, n: int) -> dict:
    """The matrix over theta back to the contract's arrays (a symmetric pair split evenly)."""
    m = N * (N + 1) // 2
    return {"W": symmetric_tensor(G, N), "v": G[:, m:m + N], "e": G[:, m + N:m + N + n],
            "mu": G[:, m + N + n:m + N + 2 * n]}


def _dW_times(x: np.ndarray, N: int, P: int) -> np.ndarray:
    """d(W x) / dtheta at fixed x: (N, P), nonzero in W's columns only."""
    out = np.zeros((N, P))
    for k, (i, j) in enumerate(zip(*np.triu_indices(N))):
        out[i, k] += x[j]
        if i != j:
            out[j, k] += x[i]
    return out


def coupled_derivative(problem: ImpactProblem, result: ImpactResult,
                       other_side: bool = False) -> ContactDerivative:
    """``d pi / d(W, v-, e, mu)`` of the two-phase formulation (module docstring); with
    ``other_side``, at a boundary (of the compression's modes or the expansion's sets) the
    neighbouring modes' too, every boundary flipped at once.

    Raises
    ------
    NotSupportedError
        for an expansion scaled by kappa < 1 or a second plastic compression, or where the
        compression's derivative is not defined (redundant contacts).
    """
    D, sided = _coupled(problem, result, False)
    if other_side and sided:
        other, _ = _coupled(problem, result, True)
        D = dataclasses.replace(D, other_side=other)
    return D


def _coupled(problem: ImpactProblem, result: ImpactResult, flip: bool):
    """(the derivative, whether some boundary met has another side)."""
    from .cone_derivative import coulomb_several
    from ..conic.paths import regimes_from_slip

    n, d = problem.n_contacts, problem.dim
    N = n * d
    extras = result.diagnostics.extras
    contacts = extras["contacts"]
    if float(extras.get("expansion_scale", 1.0)) < 1.0:
        raise NotSupportedError(
            "law 'stronge' (several coupled contacts): the expansion was scaled down "
            f"(kappa = {extras['expansion_scale']:.6g}) to keep energy; this case has no "
            "derivative here (use one e for the coupled contacts, or law 'ccp')")
    if any(np.any(np.asarray(c["recompression_impulse"]) != 0.0) for c in contacts):
        raise NotSupportedError(
            "law 'stronge' (several coupled contacts): the expansion drove a contact into "
            "approach and a second plastic compression followed; this case has no derivative "
            "here (use law 'ccp' or 'dissipative')")
    pc = np.array([c["compression_impulse"] for c in contacts], dtype=float)
    x = np.array([c["expansion_impulse"] for c in contacts], dtype=float)
    W = problem.delassus
    vm = problem.v_minus
    e, mu = problem.restitution, problem.friction
    # 1. the plastic compression: Coulomb's derivative on the problem with e = 0
    plastic = dataclasses.replace(problem, restitution=np.zeros(n))
    vc = vm + (W @ pc.ravel()).reshape(n, d)
    regimes = regimes_from_slip(plastic, pc, vc, 1e-9)
    answer = SimpleNamespace(impulse=pc, law="coulomb", regime=tuple(regimes))
    Dc = coulomb_several(plastic, answer, other_side=True)
    sided = Dc.other_side is not None
    statements = [f"compression: {t}" for t in Dc.one_sided]
    if flip and Dc.other_side is not None:
        Dc = Dc.other_side
    m = N * (N + 1) // 2
    P = m + N + 2 * n
    Gc = _columns(Dc, N, n)
    Gc[:, m + N:m + N + n] = 0.0  # the plastic impulse does not depend on e
    # dv_c / dtheta
    Gvc = W @ Gc + _dW_times(pc.ravel(), N, P)
    Gvc[:, m:m + N] += np.eye(N)
    # 2. the expansion
    Gx = np.zeros((N, P))
    for i in range(n):
        Gx[i * d] = e[i] * Gc[i * d]
        Gx[i * d, m + N + i] += pc[i, 0]
    xf = x.ravel()
    g_all = W @ xf + vc.ravel()
    vscale = max(float(np.max(np.abs(vm))), 1e-300)
    tangential = [i * d + k for i in range(n) for k in range(1, d)]
    T = len(tangential)
    pos = {c: j for j, c in enumerate(tangential)}
    K = np.zeros((T, T))
    R = np.zeros((T, P))
    base = W @ Gx + _dW_times(xf, N, P) + Gvc  # dg from every known part (dx_t = 0)
    for i in range(n):
        rows = [pos[i * d + k] for k in range(1, d)]
        t = slice(i * d + 1, (i + 1) * d)
        r = float(mu[i] * x[i, 0])
        xt, g = x[i, 1:], g_all[t]
        ng = float(np.linalg.norm(g))
        gr = mu[i] * Gx[i * d]  # dr
        gr[m + N + n + i] += x[i, 0]
        if r <= 0.0:  # no friction to give: x_t stays 0 (a vanishing disc)
            K[rows, rows] = 1.0
            if ng > 0.0:
                R[rows] = -np.outer(g / ng, gr)
            continue
        on_boundary = float(np.linalg.norm(xt)) >= r * (1.0 - DISC_RTOL)
        at_limit = on_boundary and ng <= LIMIT_RTOL * vscale
        if at_limit:
            statements.append(f"contact {i}: sticks at the friction limit in the expansion "
                              "(|x_t| = mu x_n with no tangential gradient): one-sided")
            sided = True
            if flip:
                on_boundary = False
        Wt = W[t][:, tangential]
        if not on_boundary:  # g = 0
            K[np.ix_(rows, range(T))] = Wt
            R[rows] = -base[t]
        else:  # dx_t + dr ghat + (r / |g|) P_perp dg = 0
            ghat = g / ng
            Pp = (np.eye(d - 1) - np.outer(ghat, ghat)) * (r / ng)
            K[np.ix_(rows, range(T))] = Pp @ Wt
            K[np.ix_(rows, rows)] += np.eye(d - 1)
            R[rows] = -np.outer(ghat, gr) - Pp @ base[t]
    dxt = np.linalg.solve(K, R)
    Gx[tangential] = dxt
    G = Gc + Gx
    out = _tensor(G, N, n)
    names = tuple(result.regime) if not isinstance(result.regime, str) else (result.regime,)
    if not math.isfinite(float(np.max(np.abs(G)))):
        raise NotSupportedError("law 'stronge' (several coupled contacts): the expansion's "
                                "derivative is singular here")
    return ContactDerivative(e_t=None, regimes=names, one_sided=tuple(statements), **out), sided
