"""Law pereira-nikravesh's search pruned of what provably cannot be its answer, for a time
stepper whose island slid on every contact on the step before (a *sliding mode*):
:func:`pruned_search`, called by :func:`~.pn_complementarity_search.search` with ``prune``.

The law (:mod:`~convimpact.impact.laws.pn_complementarity`) sticks on the most dissipative
admissible active set if any is admissible, else slides on the most dissipative admissible
one (ties with the same velocities going to the largest set). With ``f(pi) = T+ - T- =
pi.v- + 1/2 pi.W.pi``, ``u = W pi + b`` the Newton velocities and ``pi*`` the minimizer of
the full set's slide program P_N(full) (``u_n = 0`` on every contact, ``pi`` in the cones),
certified by its KKT conditions and admissible (else the law's own search decides):

**Dominated slide sets.** A set B is dominated when ``u_n = 0`` on B and ``u_n >= 0`` off B
force ``u_n = 0`` everywhere (:func:`dominated`: the normal rows of ``[W | b]`` off B in the
span of B's, or exactly two outside it with opposite parts, ``u_j + c u_k = 0``, c > 0; on a
box on its four corners: any three corners, a diagonal pair). Every admissible answer of B
(``pi`` in the cones on B, zero off B, ``u_n = 0`` on B, ``u_n >= 0`` off B) then has
``u_n = 0`` everywhere and is feasible for P_N(full): ``f(B) >= f(pi*)``, and one as
dissipative as ``pi*`` is a minimizer of P_N(full) too, with its velocities (the minimizers
of a convex quadratic over a convex set share ``W pi``). So B can neither be more
dissipative than the full set nor tie with it at other velocities, and a tie at the same
velocities goes to the full set. The sets not dominated (on a box: an edge's pair, tipping
about the edge; a lone corner) are solved as the law solves them, all of them (no bound, no
early stop: the visit order only decides which sets the law's warning lists), and the
law's pick is applied.

**Stick sets excluded.** Where no restitution acts (``b = v-``) and every contact is
frictional: a stick set A with ``rank W_AA = rank W`` (A's contacts fix every motion the
island's contacts see: ``null J_A = null J``; on a box: three corners or four) sticks with
``J_A v+ = 0``, hence ``u = J v+ = 0`` at every contact. Such a sticking impulse minimizes
``f`` over every impulse (``f(pi) - min f = 1/2 u.W^+.u``), and if admissible it is feasible
for P_N(full), so ``min f >= f(pi*) >= min f + 1/2 u*.W^+.u*``: impossible while the full
set's answer still slips, ``1/2 |u*|^2 / tr W > 1e-6`` of the law's energy scale (a margin
far above the programs' round-off). Before that, every stick set whose sticking impulse certainly leaves a cone is
excluded whatever the restitution (:func:`stick_clearly_inadmissible`: W_SS factored by
Cholesky where its condition is below 1e4, so that the law's LU solve and this one differ by
far less than the margin the test keeps, 1e-8 of the impulse; on a sliding box: the lone
corners, whose sticking needs a friction many times mu). The stick sets left (rank W_AA
judged by Gram-Schmidt with a clear gap, else not excluded) run the law's stick tier; any
admissible one hands the decision to the law's own search.

**Sets with no admissible impulse** (:mod:`.pn_complementarity_exclusion`): before any
other test, the sets whose far contacts would have to sink (on a sliding box the edges and
the lone corners: no impulse on them passes the law's admissibility test) are neither stuck
nor slid, and the stick sets whose sticking would need more friction than the cones give
(on a box sliding at 2 m/s: all of them) are not stuck; the screens and the rank argument
then run only on the stick sets left. Both are certificates on ``W``, ``b`` and the law's
tolerances, not heuristics: an excluded set has no candidate the law could rank.

**The full set's program re-certified.** Where the previous step's answer of the full set
is still a KKT point of this step's program (:func:`~.pn_complementarity_slide.
warm_kkt_point`; a box sliding straight: the same normal impulses and friction direction
every step) it is the minimizer, taken without the Newton.

**Cold smaller sets.** The sets not dominated are solved from the law's own guesses (not
from the previous step's answer): on a sliding box a side's pair rejects its warm start on
most steps, and a cold program costs about what a warm one does.

The answer is the law's, except where its ranking is decided by round-off (a dominated set
whose energy falls below the full set's by round-off with velocities more than ``1e-8``
apart), where either is as good. What the pruned search does not give is the law's warning
on several admissible active sets, which needs every visited set: the time stepper takes it
from the full search of the mode's first step (:mod:`convimpact.simulation.moreau_impact`).
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit as _jit
from .codes import OK as KERNEL_OK
from .pereira_nikravesh_kernel import _pn_planar, _pn_spatial
from ..problem.compiled_reduction import back_substitute
from .pn_complementarity_exclusion import excluded_sets
from .pn_complementarity_kernels import admissible, set_rows, stick_tier, sub_cholesky
from .pn_complementarity_slide import slide_set_warm, warm_kkt_point

TINY = 1e-300
EPS = float(np.finfo(float).eps)
#: the admissibility tolerance of the stick tier and of one-contact slides
SINGLE_ACCURACY = 1e-10
#: the out buffer of the single-contact kernels (laws.codes.OUT_SIZE)
OUT_SIZE = 32
#: the slip the full set's answer must keep for the stick sets' exclusion: 1/2 |u*|^2 / tr W
#: over the law's energy scale
STICK_EXCLUSION_MARGIN = 1e-6
#: Gram-Schmidt residuals (relative to the largest column) read as independent / dependent;
#: between them the rank is not judged
RANK_INDEPENDENT = 1e-6
RANK_DEPENDENT = 1e-12
#: the sticking screen (:func:`stick_clearly_inadmissible`): the bound on cond_2(W_SS) below
#: which its Cholesky solve stands for the law's LU one, and the allowance for the two
#: solves' difference, relative to the impulse's norm
SCREEN_COND_MAX = 1e4
SCREEN_ERROR = 1e-8


@_jit
def energy_change(W, vminus, pi):
    """``T+ - T- = pi.v- + 1/2 pi.W.pi``."""
    return pi @ vminus + 0.5 * (pi @ (W @ pi))


@_jit
def single(W, vminus, e, mu, d, i, lo, hi):
    """The single-contact law on contact i alone, as ``solve_contact`` dispatches it: (status,
    impulse (d,)); status 1 no impulse (not approaching), 2 the Python path must decide."""
    p = np.zeros(d)
    o = i * d
    v0 = vminus[o]
    if not v0 < 0.0:
        return 1, p
    w00 = W[o, o]
    if not (w00 > 0.0 and mu[i] > 0.0):
        return 2, p  # raises, or the frictionless impulse: the law's own path
    tr = w00 + W[o + 1, o + 1] + (W[o + 2, o + 2] if d == 3 else 0.0)
    vs = max(-v0, max(abs(vminus[o + 1]), abs(vminus[o + d - 1])))
    if not (lo <= tr <= hi and lo <= vs <= hi):
        return 2, p
    out = np.zeros(OUT_SIZE)
    if d == 2:
        st, rg, p0, p1, p2, D = _pn_planar(w00, W[o, o + 1], W[o + 1, o + 1], v0,
                                           vminus[o + 1], e[i], mu[i], out)
    else:
        st, rg, p0, p1, p2, D = _pn_spatial(w00, W[o, o + 1], W[o, o + 2], W[o + 1, o + 1],
                                            W[o + 1, o + 2], W[o + 2, o + 2], v0,
                                            vminus[o + 1], vminus[o + 2], e[i], mu[i], out)
    if st != KERNEL_OK:
        return 2, p
    p[0] = p0
    p[1] = p1
    if d == 3:
        p[2] = p2
    return 0, p


@_jit
def single_candidate(W, absW, vminus, b, e, mu, d, i, member, cone_rtol, slack_max, lo, hi):
    """Contact i sliding alone by the single-contact law, as the law's candidate: (got, pi
    (N,), admissible at :data:`SINGLE_ACCURACY`, T+ - T-), ``got`` as :func:`single`'s."""
    pi = np.zeros(W.shape[0])
    got, p = single(W, vminus, e, mu, d, i, lo, hi)
    if got != 0:
        return got, pi, False, 0.0
    for k in range(d):
        pi[i * d + k] = p[k]
    if admissible(W, absW, member, pi, b, mu, d, cone_rtol, slack_max, SINGLE_ACCURACY):
        return got, pi, True, energy_change(W, vminus, pi)
    return got, pi, False, 0.0


@_jit
def _dot(a, b):
    """a.b in a loop (BLAS's call costs more than these short vectors)."""
    acc = 0.0
    for x in range(a.size):
        acc += a[x] * b[x]
    return acc


@_jit
def _project_out(r, Q, k):
    """r minus its projection on the orthonormal rows ``Q[:k]``, twice (for round-off), in
    place."""
    L = r.size
    for _ in range(2):
        for t in range(k):
            c = 0.0
            for x in range(L):
                c += Q[t, x] * r[x]
            for x in range(L):
                r[x] -= c * Q[t, x]


@_jit
def dominance_rows(W, absW, b, d):
    """The rows ``[W_n | b_n]`` the dominance tests compare (:func:`dominated_into`): each
    contact's normal row of W and its b, b rescaled to W's largest entry (``absW = |W|``)."""
    n = b.shape[0] // d
    N = W.shape[0]
    wscale = max(np.max(absW), TINY)
    bscale = 0.0
    for i in range(n):
        bscale = max(bscale, abs(b[i * d]))
    R = np.empty((n, N + 1))
    for i in range(n):
        R[i, :N] = W[i * d]
        R[i, N] = b[i * d] * (wscale / bscale) if bscale > 0.0 else 0.0
    return R


@_jit
def dominated(R, member):
    """:func:`dominated_into` with its own work arrays."""
    n, L = R.shape
    return dominated_into(R, member, np.empty((n, L)), np.empty(L), np.empty((2, L)))


@_jit
def dominated_into(R, member, Q, r, outside):
    """Whether the normal velocities ``u_n = R [pi; 1]`` (R: the normal rows of ``[W | b]``,
    its last column rescaled to W's size) vanishing on the contacts of ``member`` and
    non-negative elsewhere vanish everywhere: every other row in the span of the member rows
    (to round-off, ``1e-11`` of R's largest row), or exactly two outside it whose parts
    outside are opposite (``u_j + c u_k = 0``, c > 0; to ``1e-9`` in direction)."""
    n, L = R.shape
    scale = 0.0
    for i in range(n):
        scale = max(scale, np.sqrt(_dot(R[i], R[i])))
    cut = 1e-11 * max(scale, TINY)
    k = 0
    for i in range(n):
        if member[i]:
            r[:] = R[i]
            _project_out(r, Q, k)
            nr = np.sqrt(_dot(r, r))
            if nr > cut:
                for x in range(L):  # (loops, not array expressions: no temporaries)
                    Q[k, x] = r[x] / nr
                k += 1
    count = 0
    for j in range(n):
        if not member[j]:
            r[:] = R[j]
            _project_out(r, Q, k)
            nr = np.sqrt(_dot(r, r))
            if nr > cut:
                if count == 2:
                    return False
                for x in range(L):
                    outside[count, x] = r[x] / nr
                count += 1
    if count == 0:
        return True
    if count == 1:
        return False
    gap = 0.0
    for x in range(L):
        gap += (outside[0, x] + outside[1, x]) ** 2
    return np.sqrt(gap) <= 1e-9


@_jit
def rank_clear(A):
    """Rank of the symmetric matrix A by Gram-Schmidt on its rows (its columns), and whether
    every row's residual lay clearly on one side (above :data:`RANK_INDEPENDENT` or below
    :data:`RANK_DEPENDENT` of the largest row)."""
    m = A.shape[0]
    scale = 0.0
    for c in range(m):
        scale = max(scale, np.sqrt(_dot(A[c], A[c])))
    if not scale > 0.0:
        return 0, True
    Q = np.empty((m, m))
    k = 0
    for c in range(m):
        r = A[c].copy()
        _project_out(r, Q, k)
        nr = np.sqrt(_dot(r, r))
        if nr > RANK_INDEPENDENT * scale:
            Q[k] = r / nr
            k += 1
        elif nr > RANK_DEPENDENT * scale:
            return k, False
    return k, True


@_jit
def stick_clearly_inadmissible(W, b, mu, d, member, cone_rtol, slack_max, tol):
    """Whether the law's sticking impulse of the active set ``member`` (``W_SS pi_S = -b_S``,
    :func:`~.pn_complementarity_kernels.stick_solve`) certainly leaves a cone of the set:
    W_SS factored by Cholesky; with ``cond_2(W_SS) <= ||W_SS||_F ||L^-1||_F^2 <=``
    :data:`SCREEN_COND_MAX` (far below the law's STICK_COND_MAX, so the law solves by LU) the
    two backward-stable solves differ by less than ``cond m eps |pi|`` (about 1e-11 |pi|),
    well inside :data:`SCREEN_ERROR` ``|pi| = E``. The set is excluded only when a contact's
    friction exceeds its cone by more than what E can move in the law's test (``pt`` by
    2E, ``pn`` by E, the tolerance ``ptol`` by ``(2 tol + max_row |W| / W_ii) E``, with
    ``tol, slack_max <= 1``); otherwise
    (False) the caller runs the law's stick tier on it."""
    N = W.shape[0]
    rows = np.empty(N, dtype=np.int64)
    m, _ = set_rows(member, mu, d, rows, rows[:0])
    L = np.zeros((m, m))
    fro = 0.0
    for a in range(m):
        for c in range(m):
            fro += W[rows[a], rows[c]] ** 2
    if not sub_cholesky(W, rows, m, L):
        return False
    inv2 = 0.0  # ||L^-1||_F^2, column by column of L^-1 (forward substitution)
    col = np.empty(m)
    for c in range(m):
        for i in range(m):
            acc = 1.0 if i == c else 0.0
            for k in range(c, i):
                acc -= L[i, k] * col[k]
            col[i] = acc / L[i, i] if i >= c else 0.0
            inv2 += col[i] * col[i]
    if not np.sqrt(fro) * inv2 <= SCREEN_COND_MAX:
        return False
    y = np.empty(m)
    for i in range(m):
        acc = -b[rows[i]]
        for k in range(i):
            acc -= L[i, k] * y[k]
        y[i] = acc / L[i, i]
    x = y
    back_substitute(L, x)  # x = L^-T y
    pi = np.zeros(N)
    for a in range(m):
        pi[rows[a]] = x[a]
    err = SCREEN_ERROR * np.sqrt(_dot(x, x))
    Wpi = W @ pi
    rowmax = 0.0
    for a in range(N):
        acc = 0.0
        for c in range(N):
            acc += abs(W[a, c])
        rowmax = max(rowmax, acc)
    for i in range(mu.size):
        if not (member[i] and mu[i] > 0.0):
            continue
        size = 0.0
        roundoff = 0.0
        for k in range(d):
            j = i * d + k
            size = max(size, max(abs(b[j]), abs(Wpi[j])))
            ro = 0.0
            for c in range(N):
                ro += abs(W[j, c]) * abs(pi[c])
            roundoff = max(roundoff, 1e2 * EPS * ro)
        slack = max(tol * size, min(roundoff, slack_max * size))
        pn = pi[i * d]
        pt2 = 0.0
        for k in range(1, d):
            pt2 += pi[i * d + k] ** 2
        pt = np.sqrt(pt2)
        wii = W[i * d, i * d]
        ptol = max(tol * np.sqrt(pn * pn + pt2), slack / wii)
        if pt - 2.0 * err > (mu[i] * (pn + err) * (1.0 + cone_rtol) + ptol
                             + (2.0 * tol + rowmax / wii) * err):
            return True
    return False


@_jit
def _rank_exclusion(W, b, vminus, mu, d, masks, pi_full, escale, keep):
    """The rank argument (module docstring) on the stick sets still kept in ``keep``,
    clearing those it excludes (in place)."""
    n = mu.size
    N = W.shape[0]
    for i in range(n):
        if not mu[i] > 0.0:
            return
    for a in range(N):
        if b[a] != vminus[a]:
            return
    u = W @ pi_full + b
    tr = 0.0
    for a in range(N):
        tr += W[a, a]
    if not (tr > 0.0 and 0.5 * (u @ u) / tr > STICK_EXCLUSION_MARGIN * escale):
        return
    full_rank, clear = rank_clear(W)
    if not clear:
        return
    for s in range(masks.shape[0]):
        if not keep[s]:
            continue
        members = np.flatnonzero(masks[s])
        m = members.size * d
        rows = np.empty(m, dtype=np.int64)
        for c in range(members.size):
            for k in range(d):
                rows[c * d + k] = members[c] * d + k
        Wss = np.empty((m, m))
        for x in range(m):
            for y in range(m):
                Wss[x, y] = W[rows[x], rows[y]]
        r, clear = rank_clear(Wss)
        keep[s] = not (clear and r == full_rank)


@_jit
def _kept_stick_sets(W, b, vminus, mu, d, masks, pi_full, escale):
    """The stick sets the rank argument (module docstring) leaves, as a mask over
    ``masks``."""
    keep = np.ones(masks.shape[0], dtype=np.bool_)
    _rank_exclusion(W, b, vminus, mu, d, masks, pi_full, escale, keep)
    return keep


@_jit
def _screened_stick_sets(W, b, vminus, mu, d, masks, pi_full, escale, cone_rtol, slack_max,
                         skip):
    """The stick sets no exclusion (module docstring) removes, as a mask over ``masks``:
    those of ``skip`` (no admissible impulse at all, :mod:`.pn_complementarity_exclusion`)
    out, :func:`stick_clearly_inadmissible` on every other set, then the rank argument on
    those left."""
    ns = masks.shape[0]
    keep = np.ones(ns, dtype=np.bool_)
    left = 0
    for s in range(ns):
        keep[s] = not (skip[s] or stick_clearly_inadmissible(W, b, mu, d, masks[s], cone_rtol,
                                                             slack_max, SINGLE_ACCURACY))
        left += keep[s]
    if left:
        _rank_exclusion(W, b, vminus, mu, d, masks, pi_full, escale, keep)
    return keep


@_jit
def pruned_search(W, b, vminus, mu, e, d, masks, tol, cond_max, cone_rtol, slack_max, lo, hi,
                  escale, wkind, wtang, wpi, wvalid, fe, fs, fpi, needs):
    """The law's search without what cannot be its answer (module docstring): the slide
    candidates into ``fe``, ``fs``, ``fpi`` (the full set's first) and the sets the Python
    path must solve (an interior-point program, a one-contact kernel outside the compiled
    one's reach) into ``needs``; returns (their numbers), or (-1, 0) where the law's own
    search must decide (the full set not certified or not admissible, a stick set
    admissible). ``escale``: the law's energy scale; the warm starts as
    :func:`~.pn_complementarity_slide.slide_many_warm`'s."""
    n = mu.size
    N = W.shape[0]
    if not np.all(masks[0]):
        return -1, 0
    absW = np.abs(W)
    full = np.flatnonzero(masks[0])
    if wvalid[0] and warm_kkt_point(W, vminus, b, mu, d, wpi[0], cone_rtol):
        pi_full = wpi[0].copy()  # the previous answer, a minimizer again (kind, tang kept)
    else:
        st, pi_full, kind, tang = slide_set_warm(W, vminus, b, mu, d, full, wkind[0],
                                                 wtang[0], wpi[0], wvalid[0])
        wvalid[0] = st == 1
        if st != 1:
            return -1, 0
        wkind[0, :n] = kind
        wtang[0, :n] = tang
        wpi[0] = pi_full
    if not admissible(W, absW, masks[0], pi_full, b, mu, d, cone_rtol, slack_max, tol):
        return -1, 0
    # the sets with no admissible impulse at all (their far contacts would sink)
    skip, skip_stick = excluded_sets(W, b, mu, d, masks, max(tol, SINGLE_ACCURACY),
                                     slack_max, cone_rtol)
    keep = _screened_stick_sets(W, b, vminus, mu, d, masks, pi_full, escale, cone_rtol,
                                slack_max, skip_stick)
    sticks = np.flatnonzero(keep)
    if sticks.size:
        ok = stick_tier(W, b, vminus, mu, d, masks[sticks], cond_max, cone_rtol, slack_max,
                        SINGLE_ACCURACY)[0]
        if np.any(ok):
            return -1, 0
    R = dominance_rows(W, absW, b, d)
    fe[0] = energy_change(W, vminus, pi_full)
    fs[0] = 0
    fpi[0] = pi_full
    nf = 1
    nn = 0
    Qw = np.empty((n, N + 1))
    rw = np.empty(N + 1)
    ow = np.empty((2, N + 1))
    for s in range(1, masks.shape[0]):
        if skip[s]:
            wvalid[s] = False
            continue
        if dominated_into(R, masks[s], Qw, rw, ow):
            continue
        members = np.flatnonzero(masks[s])
        if members.size >= 2:
            # cold: the smaller sets' warm starts fail as often as not on a sliding box
            # (a side's pair), and a cold program costs about what a warm one does
            st, pi, kind, tang = slide_set_warm(W, vminus, b, mu, d, members, wkind[s],
                                                wtang[s], wpi[s], False)
            wvalid[s] = st == 1
            if st == 1:
                wkind[s, :members.size] = kind
                wtang[s, :members.size] = tang
                wpi[s] = pi
            if not (st == 1 or st == -1):
                needs[nn] = s
                nn += 1
            elif admissible(W, absW, masks[s], pi, b, mu, d, cone_rtol, slack_max, tol):
                fe[nf] = energy_change(W, vminus, pi)
                fs[nf] = s
                fpi[nf] = pi
                nf += 1
            continue
        got, pi, ok, energy = single_candidate(W, absW, vminus, b, e, mu, d, members[0],
                                               masks[s], cone_rtol, slack_max, lo, hi)
        if got == 2:
            needs[nn] = s
            nn += 1
        elif ok:
            fe[nf] = energy
            fs[nf] = s
            fpi[nf] = pi
            nf += 1
    return nf, nn
