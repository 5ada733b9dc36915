"""A certificate that shortens law ``pereira-nikravesh`` on Moreau–Jean's resting islands, in
one compiled call per step (:func:`stick_all_certified`, used by :mod:`.moreau_impact`).

The law (:mod:`convimpact.impact.laws.pn_complementarity`) returns, in its stick tier, the
most dissipative admissible active set: ``T+ - T- = f(pi) = pi.v- + 1/2 pi.W.pi`` smallest,
then, among the candidates as dissipative as that one (to ``1e-9`` of the energy scale) and
with its velocities (``W pi`` to ``1e-8 max |v-|``), the largest set, then the impulse of
least norm. It is not "the first admissible set in a preference order": the answer needs the
least ``f`` over every admissible set, so the law solves all of them (2^n - 1).

Where the island's contacts are all frictional and no restitution acts (``b = v-``: a contact
at rest, ``e_eff = 0``), sticking on *every* contact gives ``u = W pi + v- = 0`` on every row,
and ``u = grad f``: the sticking impulse is then a minimizer of ``f`` over every impulse, not
only over the admissible ones. Every other candidate B has ``f(B) >= min f``, and (W positive
semi-definite) ``f(B) - min f = 1/2 u_B.W^+.u_B``: with ``u_G = W pi_G + v-`` the full set's
computed velocities, any B at most as dissipative as it has velocities within
``|u_G| (1 + sqrt(cond+ W))`` of its (cond+: the ratio of W's extreme nonzero eigenvalues).
When that is below ``1e-9 max |v-|`` (ten times inside the law's "same velocities" test) and
``1/2 |u_G|^2 / lambda_min+`` below ``1e-10`` of the energy scale (ten times inside its tie
test), every candidate the law could rank first has the full set's velocities and ties with
it, and the full set, the unique largest candidate, is the law's answer: the same impulse as
the law's (the same compiled solve, :func:`~convimpact.impact.laws.pn_complementarity_kernels.
stick_tier` on the one set) without solving the other sets. The law's own answer differs only
where its ranking is decided by the round-off of the energies (candidates within ~1e-15 of the
energy scale of each other with velocities 1e-8 apart), where either answer is as good.

The island's W is formed as on the engine path (``J G J^T``, :func:`.moreau_kernels.
island_delassus`, G the step's block inverse of M) and symmetrized and checked as
:func:`convimpact.impact.problem.build.build_problem` does (:func:`~convimpact.contacts.
interior_point.contact_checks`), not through ``build_problem``'s Cholesky factor: the same
numbers to round-off.
"""

from __future__ import annotations

import numpy as np

from ..compiled import jit as _jit
from ..contacts.interior_point import contact_checks
from ..impact.laws.pn_complementarity_kernels import admissible, stick_solve, sub_cholesky
from .moreau_kernels import apply_island_impulse, island_delassus, island_velocity

EPS = float(np.finfo(float).eps)
TINY = 1e-300
#: island statuses of :func:`certify_islands`
STICK, SEARCH, SEPARATING, NOT_PLAIN = 1, 0, 2, -1
#: the certificate's margins: velocities (relative to max |v-|) and energies (relative to the
#: law's energy scale), ten times inside the law's tie tests (1e-8 and 1e-9)
VELOCITY_MARGIN = 1e-9
ENERGY_MARGIN = 1e-10


@_jit
def _certified(W, vm, mu, d, x, lam, cone_rtol, slack_max):
    """Whether the impulse ``x`` sticking every contact (``W x = -v-``, ``lam`` the
    eigenvalues of W) is the law's answer: the certificate of the module docstring."""
    N = W.shape[0]
    member = np.ones(mu.size, dtype=np.bool_)
    if not admissible(W, np.abs(W), member, x, vm, mu, d, cone_rtol, slack_max, 1e-10):
        return False
    u = W @ x + vm
    unorm = np.sqrt(u @ u)
    vs = max(np.max(np.abs(vm)), TINY)
    big = 0.0
    for a in range(N):
        big = max(big, abs(W[a, a]))
    escale = max(0.5 * vs * vs / big, TINY)
    lmax = np.max(np.abs(lam))
    lmin = np.inf
    for a in range(lam.size):
        if lam[a] > EPS * N * lmax:
            lmin = min(lmin, lam[a])
    if not (lmin < np.inf and lmax > 0.0):
        return False
    return (unorm * (1.0 + np.sqrt(lmax / lmin)) <= VELOCITY_MARGIN * vs
            and 0.5 * unorm * unorm / lmin <= ENERGY_MARGIN * escale)


@_jit
def stick_certificate(W, vm, mu, d, cond_max, cone_rtol, slack_max, rows):
    """The impulse sticking every contact and whether it is the law's answer (the
    certificate of the module docstring; needs every contact frictional and b = v-)."""
    member = np.ones(mu.size, dtype=np.bool_)
    solved, m, x, lam = stick_solve(W, vm, mu, d, member, cond_max, rows)
    # every contact frictional: S is every row in order, W_SS = W, x the impulse
    if not solved:
        return x, False
    return x, _certified(W, vm, mu, d, x, lam, cone_rtol, slack_max)


@_jit
def coordinate_certificate(Ja, G, cons, cols, d, W, vm, mu, cond_max, cone_rtol, slack_max):
    """:func:`stick_certificate` of the island with the contacts ``cons`` (rows of ``Ja``
    (na, d, k)) and the coordinates ``cols`` (``W = J G J^T`` its Delassus matrix, ``G``
    the step's block inverse of M), solved in the island's coordinates where it has more
    contact rows than coordinates (W singular: a box on four corners, 12 rows and 6
    coordinates): with ``G_II = L L^T`` and ``B = J_I L``, ``W = B B^T`` has the nonzero
    eigenvalues of the small ``A = B^T B`` and ``W^+ = B (A^+)^2 B^T``, so the law's
    minimum-norm sticking impulse ``x = -W^+ v-`` (:func:`~convimpact.impact.laws.
    pn_complementarity_kernels.stick_solve`: W's eigenvalues above ``eps N max|lambda|``,
    the others dropped; its consistency test ``|W x + v-| <= 1e-9 |v-|``) comes from A's
    eigen-decomposition instead of W's: the same impulse and eigenvalues to round-off at a
    fraction of the cost. Elsewhere (and where G_II is not positive definite) it is
    :func:`stick_certificate` itself."""
    nc, nk = cons.shape[0], cols.shape[0]
    N = nc * d
    rows = np.empty(N, dtype=np.int64)
    if N <= nk:
        return stick_certificate(W, vm, mu, d, cond_max, cone_rtol, slack_max, rows)
    L = np.zeros((nk, nk))
    if not sub_cholesky(G, cols, nk, L):
        return stick_certificate(W, vm, mu, d, cond_max, cone_rtol, slack_max, rows)
    B = np.zeros((N, nk))
    for c in range(nc):
        for r in range(d):
            for a in range(nk):
                acc = 0.0
                for e in range(a, nk):
                    acc += Ja[cons[c], r, cols[e]] * L[e, a]
                B[c * d + r, a] = acc
    lam, Q = np.linalg.eigh(B.T @ B)
    smax = np.max(np.abs(lam))
    y = Q.T @ (B.T @ vm)
    for a in range(nk):
        y[a] = y[a] / (lam[a] * lam[a]) if abs(lam[a]) > EPS * N * smax else 0.0
    x = -(B @ (Q @ y))
    res = W @ x + vm
    if not np.sqrt(res @ res) <= 1e-9 * max(np.sqrt(vm @ vm), TINY):
        return x, False
    return x, _certified(W, vm, mu, d, x, lam, cone_rtol, slack_max)


@_jit
def certify_islands(Ja, v_free, es, mu_act, G, icon, icoff, icol, icoloff, d, cond_max,
                    cone_rtol, slack_max, immobile_rtol, tiny_normal, r, v_new, status):
    """For every island i (contacts ``icon[icoff[i]:icoff[i + 1]]``, rows of ``Ja`` (na, d,
    k), coordinates ``icol[icoloff[i]:icoloff[i + 1]]``): the law's answer where a
    certificate of the module docstring holds.

    Writes ``status[i]``: STICK (certified: the impulse into ``r`` (na, d) and
    ``v_free + G J^T pi`` into ``v_new`` on the island's coordinates), SEPARATING (no contact
    approaches, ``v_n- >= 0`` everywhere: no impulse, ``v_new`` left), SEARCH (the law must
    search) or NOT_PLAIN (degenerate contacts: the law's full call decides). ``v_new`` holds
    ``v_free`` on entry."""
    n_isl = icoff.shape[0] - 1
    for i in range(n_isl):
        c0, c1 = icoff[i], icoff[i + 1]
        k0, k1 = icoloff[i], icoloff[i + 1]
        nc = c1 - c0
        N = nc * d
        cons = icon[c0:c1]
        cols = icol[k0:k1]
        W = np.empty((N, N))
        rows = np.empty(N, dtype=np.int64)
        island_delassus(Ja, G, cons, cols, d, W)
        vm = np.zeros(N)
        island_velocity(Ja, v_free, cons, cols, d, vm)
        approaching = False
        for c in range(nc):
            if vm[c * d] < 0.0:
                approaching = True
        if not approaching:
            status[i] = SEPARATING
            continue
        if contact_checks(W, vm, d, immobile_rtol, tiny_normal) != 0:
            status[i] = NOT_PLAIN
            continue
        status[i] = SEARCH
        mu = np.empty(nc)
        plain = True
        for c in range(nc):
            mu[c] = mu_act[cons[c]]
            # every contact frictional (every row sticks), no restitution (b = v-)
            if not (mu[c] > 0.0) or es[cons[c]] * min(vm[c * d], 0.0) != 0.0:
                plain = False
        if not plain:
            continue
        pi, certified = stick_certificate(W, vm, mu, d, cond_max, cone_rtol, slack_max, rows)
        if not certified:
            continue
        status[i] = STICK
        # v_new = v_free + G_II J_I^T pi on the island's coordinates
        apply_island_impulse(Ja, G, cons, cols, d, pi, r, v_new)
