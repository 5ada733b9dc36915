"""Coulomb's law by nonsmooth block Gauss-Seidel (Jean & Moreau's NSGS): contact after
contact, the one-contact problem ``u_i = W_ii r_i + q_i`` (``q_i`` the velocity the other
contacts' impulses give) is solved exactly (:func:`.local_coulomb.solve_local`), on W stored
by block rows (BSR), compiled.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp

from ..compiled import jit as _jit
from .cones import natural_map_residual
from .finish import newton_finish
from .local_coulomb import solve_local
from .sparse_step import SparseStepSystem
from .subspace import stick_step


@_jit
def _sweeps(bptr, bcol, bdata, b, mu, d, r, hints, blocks, count, omega, order, first=0,
            omega_other=-1.0):
    """``count`` sweeps over the contacts, sweep k in ``order[(first + k) % len(order)]``, in
    place on ``r`` (n d,); returns the number of contacts without a local answer in the last
    sweep. ``omega`` over-relaxes the sticking answers, ``omega_other`` the others (take-off
    and slide; negative: ``omega``). W by block rows (BSR: ``bptr``, ``bcol``, ``bdata``
    (nb, d, d)): each neighbour's impulse read once for its d x d block (on the 897-sphere
    pile 1,000 sweeps in 0.15 s against 0.21 s by scalar rows, CSR; the same sums in the same
    order, bit for bit)."""
    q = np.empty(d)
    ri = np.empty(d)
    old = np.empty(d)
    misses = 0
    other = omega if omega_other < 0.0 else omega_other
    for sweep in range(count):
        misses = 0
        for k0 in range(order.shape[1]):
            c = order[(first + sweep) % order.shape[0], k0]
            o = c * d
            if d == 3:
                s0 = b[o]
                s1 = b[o + 1]
                s2 = b[o + 2]
                for p in range(bptr[c], bptr[c + 1]):
                    j = bcol[p] * 3
                    x0 = r[j]
                    x1 = r[j + 1]
                    x2 = r[j + 2]
                    # (one term at a time: the CSR row's order of additions)
                    s0 += bdata[p, 0, 0] * x0
                    s0 += bdata[p, 0, 1] * x1
                    s0 += bdata[p, 0, 2] * x2
                    s1 += bdata[p, 1, 0] * x0
                    s1 += bdata[p, 1, 1] * x1
                    s1 += bdata[p, 1, 2] * x2
                    s2 += bdata[p, 2, 0] * x0
                    s2 += bdata[p, 2, 1] * x1
                    s2 += bdata[p, 2, 2] * x2
                q[0] = s0
                q[1] = s1
                q[2] = s2
            else:
                for k in range(d):
                    s = b[o + k]
                    for p in range(bptr[c], bptr[c + 1]):
                        j = bcol[p] * d
                        for jj in range(d):
                            s += bdata[p, k, jj] * r[j + jj]
                    q[k] = s
            A = blocks[c]
            for k in range(d):
                old[k] = r[o + k]
            for k in range(d):  # q without this contact's own impulse
                s = 0.0
                for j in range(d):
                    s += A[k, j] * old[j]
                q[k] -= s
                ri[k] = old[k]
            kind = solve_local(A, q, mu[c], ri, hints[c:c + 1])
            if kind < 0:
                misses += 1
                continue
            w = omega if kind == 1 else other
            for k in range(d):
                r[o + k] = w * ri[k] + (1.0 - w) * old[k]
    return misses


def diagonal_blocks(W: sp.csr_matrix, d: int) -> np.ndarray:
    """The (n, d, d) diagonal blocks of W."""
    n = W.shape[0] // d
    out = np.empty((n, d, d))
    for k in range(d):
        for j in range(d):
            out[:, k, j] = W[np.arange(k, n * d, d), :][:, np.arange(j, n * d, d)].diagonal()
    return out


def gauss_seidel(W, b: np.ndarray, mu: np.ndarray, d: int, r0: np.ndarray, *,
                 sweeps: int = 10, omega: float = 1.0, order=None, first: int = 0,
                 omega_other: float | None = None):
    """A generator of NSGS iterates: each ``next()`` runs ``sweeps`` sweeps from the last
    iterate (``r0`` (n, d) first) and yields the impulses (n, d) (a copy); ``send(r)`` runs
    them from ``r`` (n, d) instead. Each contact's exact answer is over-relaxed by ``omega``
    where it sticks, by ``omega_other`` (None: ``omega``) where it takes off or slides
    (``r <- w r_exact + (1 - w) r``). ``order`` (k, n):
    the contact orders, sweep j in ``order[(first + j) % k]``."""
    W = sp.csr_matrix(W)
    W.sort_indices()
    n = mu.shape[0]
    blocks = np.ascontiguousarray(diagonal_blocks(W, d))
    r = np.ascontiguousarray(np.asarray(r0, dtype=float).reshape(-1)).copy()
    bb = np.ascontiguousarray(np.asarray(b, dtype=float).reshape(-1))
    m = np.ascontiguousarray(mu, dtype=float)
    hints = np.full(n, np.nan)
    Wb = sp.bsr_matrix(W, blocksize=(d, d))
    Wb.sort_indices()
    bptr = Wb.indptr.astype(np.int64)
    bcol = Wb.indices.astype(np.int64)
    bdata = np.ascontiguousarray(Wb.data, dtype=float)
    if order is None:
        order = np.arange(n)[None, :]
    order = np.ascontiguousarray(order, dtype=np.int64)
    done = first
    while True:
        # the orders run on across calls (each call restarted at the first before: with 10
        # sweeps a call, 10 of the 64 orders served)
        _sweeps(bptr, bcol, bdata, bb, m, d, r, hints, blocks, sweeps, omega, order,
                done % order.shape[0], -1.0 if omega_other is None else omega_other)
        done += sweeps
        restart = yield r.reshape(n, d).copy()
        if restart is not None:  # send(r): the sweeps go on from r
            r[:] = np.asarray(restart, dtype=float).reshape(-1)


#: :func:`weakly_coupled`: the median over contacts of the largest normal coupling at most
#: this (point contacts, one a pair of bodies, couple at about 1/2: 0.51-0.58 on the
#: corpus's sphere piles and planar stacks; several contacts on one interface more strongly:
#: 0.62 on box stacks, 0.62-0.66 on log piles, 0.72 on brick walls, 0.74 on robots' soles)
WEAK_COUPLING = 0.6


def weakly_coupled(W, d: int) -> bool:
    """Whether W's contacts are weakly coupled, the NSGS's good case: the median over
    contacts i of ``max_j |W_nn,ij| / sqrt(W_nn,ii W_nn,jj)`` (j != i, normal rows) is at
    most :data:`WEAK_COUPLING`. A property of W alone (deterministic, no solve)."""
    W = sp.csr_matrix(W)
    n = W.shape[0] // d
    Wn = W[::d, ::d].tocoo()
    diag = np.asarray(W.diagonal())[::d]
    off = (Wn.row != Wn.col) & (Wn.data != 0.0)
    rows, cols = Wn.row[off], Wn.col[off]
    denom = np.sqrt(diag[rows] * diag[cols])
    rel = np.divide(np.abs(Wn.data[off]), denom, out=np.zeros(rows.shape[0]),
                    where=denom > 0.0)
    largest = np.zeros(n)
    np.maximum.at(largest, rows, rel)
    return bool(n > 0 and np.median(largest) <= WEAK_COUPLING)


#: :func:`nsgs_newton`: sweeps at most...
NSGS_MAX_SWEEPS = 30000
#: ...stopped where the NSGS's own best residual (Newton's answers apart) has not dropped
#: tenfold in this many sweeps (at 6,000 the 624-sphere pile stopped at 9e-5, 300 sweeps
#: before its drop to 1e-5; on the large sphere piles the NSGS plateaus at 1e-4-5e-4 for up
#: to 10,000 sweeps, the Newton tries certifying them on the way)
NSGS_STALL_SWEEPS = 12000
#: sweeps between two natural-map checks
NSGS_CHECK = 10
#: over-relaxation of each contact's exact answer (``r <- omega r_exact + (1 - omega) r``):
#: sweeps to a residual of 3e-5 at 1.0 / 1.5: 10,000 / 7,000 on the 624-sphere pile, 8,000 /
#: 4,000 on the 897-sphere pile, 4,000 / 2,500 on the 726-sphere pile; but at 1.5, with b
#: moved by 1e-4, the 624-sphere pile's sweeps wandered at 4e-4-3e-3 for 12,000 sweeps (2 of 7
#: perturbed problems left uncertified), at 1.0 and 1.25 none. That was every kind at 1.25; now
#: the sticking answers only, the take-offs and slides exact (NSGS_OMEGA_OTHER: over-relaxed,
#: the slides left their cones, 70 kinds changed per 10 sweeps at 1.25, the take-offs' normal
#: impulse went negative). Work (sweeps plus Newton steps) on the 624 / 726 / 897-sphere piles
#: from the CCP answer, b moved by 1e-6, seeds 3-9, every kind at 1.25 -> sticks at 1.7:
#: 2,900-4,200 / 1,370 / 4,800-5,000 (and 20,800-21,300 in 2 of 7) -> 2,200-3,900 / 910 /
#: 3,200-3,700 (and 19,000 in 2 of 7), seeds 0-2 29,000 -> 21,500 in all; sticks at 1.5:
#: 24,400, at 1.85: seeds 3-9 624 / 726 pile as at 1.7, 897 pile 3,100-4,700 in 4 of 7 and
#: 8,900-20,300 in 3; take-offs and slides at 1.1 (sticks 1.25 / 1.5): 897 pile 24,500-25,200
#: / 4,300-20,800 with b moved by 1e-6, seeds 0-2; with b moved by 1e-3 (seeds 0-3, from the
#: unperturbed CCP answer) every kind at 1.25 / sticks at 1.7: 137,000 / 148,000 (one
#: 897-sphere pile left at 3e-6 / 9e-6 each, the tails 25,000-47,000 / 19,000-59,000). The
#: engine's iterations on the corpus's 624 / 726 / 897-sphere piles 3,436 / 1,396 / 4,837 ->
#: 2,408 / 936 / 4,234, with b moved by 1e-14 (seeds 1-8) 77,400 -> 60,600 in all. Without
#: the subspace steps in this run (b moved by 1e-6, seeds 0-7): work 72,400 -> 121,000 (624 /
#: 726 pile 2,200-2,700 / 910 -> 5,000-5,600 / 1,860; 897 pile 1.2-1.6 s -> 1.0 s a run, but
#: 20,000-21,000 in 2 of 8 runs instead of 1)
NSGS_OMEGA = 1.7
NSGS_OMEGA_OTHER = 1.0
#: ...and where that run stops uncertified, the restarts (:data:`NSGS_RESTARTS`, in the next
#: seeds' orders, without the subspace steps) over-relax every kind by this, as before (with
#: the sticks at 1.7 in the restarts too, the 897-sphere pile with b moved by 1e-3, seed 14, M
#: and J given, was refused at 3.1e-4; with the first run of before as a second run, four in
#: all, certified, but its sibling of seed 12 took 37 s under load 2, 10-14 s now)
NSGS_OMEGA_EVERY = 1.25
#: Newton is tried from an iterate within NSGS_NEWTON_FROM, then after each drop by
#: NSGS_NEWTON_DROP below the residual of the last try, and NSGS_NEWTON_AGAIN sweeps after
#: it while the NSGS plateaus: the light Newton (:data:`NSGS_NEWTON_DAMPING`) certified the
#: large sphere piles from 5e-4-5e-6 in 2-9 steps, its failed tries stopped in 3-6, and which
#: plateau iterate it certifies from is a matter of chance (from 2e-4 and every 1,000 sweeps:
#: 13 of 16 perturbed 624- and 897-sphere piles certified; from 5e-4 and every 500: 16 of 16,
#: and 8 of 8 of the 726-sphere pile; b moved by 1e-14-1e-3)
NSGS_NEWTON_FROM = 5e-4
NSGS_NEWTON_DROP = 0.5
NSGS_NEWTON_AGAIN = 500
#: the contact orders: this many random permutations, used in turn (the fixed order cycled:
#: on a 726-sphere pile it stalled at 1.6e-6-2e-4, random orders reached 1e-8), drawn from a
#: generator of fixed seed so that the engine stays deterministic
NSGS_ORDERS = 64
NSGS_SEED = 20261126
#: a Newton try that ends below this fraction of the residual of the iterate it started
#: from hands its answer to the sweeps, which go on from there (the tries on the plateau end
#: at 3e-5-3e-4, often 2-10x below the sweeps' iterate). Work (sweeps plus Newton steps) on
#: 36 perturbed large sphere piles (b moved by 0-1e-3, 12 seeds each): 624 pile 6,800 ->
#: 5,900 (1e-3: 7,800/9,100 -> 3,800/7,300), 897 pile unchanged at 1e-14-1e-10, 15,400 ->
#: 11,600 at 1e-6 seed 7, and certified at 1e-3 seed 14 (uncertified before, 1.2e-6 on
#: 678e8f2, 4.9e-5 with the NSGS first), 726 pile 3,060 -> 2,930; none uncertified. At 1
#: (any better answer handed on) one of 24 was left uncertified.
NSGS_RESTART_BELOW = 0.5
#: every this many sweeps the firmly sticking contacts' velocity is solved to zero
#: (:func:`.subspace.stick_step`, 1-5 ms on the large sphere piles, 4-20 sweeps) and the
#: sweeps go on from its answer; the steps pause NSGS_SUBSPACE_PAUSE sweeps where the
#: residual has not halved in NSGS_SUBSPACE_STALL (the steps and the sweeps can hold each
#: other at a point that is no solution: the 897-sphere pile with b moved by 1e-6, seed 2,
#: at 9e-5 for 30,000 sweeps, its residual on the sliding contacts and the sticking ones near
#: their cone's boundary, which the steps hold; turned off for good instead, on the same
#: pile with b moved by 1e-3 the sweeps then wandered at 1e-3-5e-3 for 10,000). Sweeps on
#: the sphere piles, b moved by 0 / 1e-14 (seeds 1-3) / 1e-6 (seeds 1-3) / 1e-3 (seeds 0-2),
#: without -> with the steps: 624 pile 5,900 / 5,900 / 5,900-6,400 / 6,000-61,000 (seed 0
#: refused at 2.5e-5) -> 3,400 / 3,400 / 3,200-4,200 / 4,400-5,000; 726 pile 2,900 / 2,900 /
#: 2,900 / 2,500-6,600 -> 1,400 / 1,400 / 1,400 / 1,600-2,900; 897 pile 5,400 / 5,400 /
#: 4,600-21,800 / 6,700-54,000 -> 4,800 / 4,800 / 4,600-5,000 / 7,000-18,000. Every 100
#: sweeps: 897 pile 21,400 unperturbed; never paused: 897 pile 36,000 at 1e-6, seeds 2 and 3.
#: Only the first run has the steps (:data:`NSGS_RESTARTS`): with b moved by 1e-3, seeds
#: 3-7, the 897 pile's sweeps 39,500 / 5,500 / 5,100 / 4,100 / refused (4.5e-7) without them,
#: with them in every run 81,500 and refused (2.2e-6) / 3,100 / 19,600 / 4,300 / refused, in
#: the first only seed 3 certified in 35,400 (seed 5 20,200, seed 7 refused at 4.5e-7).
#: Process time unperturbed (medians of 3, load 2): 624 pile 1.64 -> 1.15 s, 726 pile 1.02 ->
#: 0.74 s, 897 pile 1.85 -> 2.05 s (75 steps, 0.19 s; its Newton tries 0.55 -> 0.77 s)
NSGS_SUBSPACE_EVERY = 50
NSGS_SUBSPACE_STALL = 1000
NSGS_SUBSPACE_PAUSE = 500

# What the plateau is (measured on the 624-sphere pile from the CCP answer, 3,000 sweeps:
# residual 1.9e-4; the 726-sphere pile alike), for whoever tries to shorten it:
# * 95 % of the residual's square sits on sticking contacts whose velocity is not zero
#   (|u| ~ 1e-4): the linear part has not converged, the kinds are mostly right;
# * at omega 1 the kinds do not change for hundreds of sweeps (0 of 624 per 10 sweeps; at
#   1.25, 70 per 10 sweeps: the over-relaxed slides leave their cones) while the residual
#   stays at 0.9-1.7e-4 and the impulses drift along a fixed direction (cosine 0.99 between
#   50-sweep differences, 4 % of |r| in 2,000 sweeps): 77 % normal impulses of sticking
#   contacts, and the velocity it brings is the spheres' spin only;
# * the light Newton step from there predicts 9.5e-5 -> 8.7e-6 on its linear model, but the
#   full step changes the kind of ~5 contacts (sticks with |u_t| ~ 1e-5 turning to slides, a
#   slide opening) that then carry 99 % of the new residual; the line search cuts it to
#   1/64-1/256 (full steps without it cycle between 1e-4 and 1e-5);
# * where the tries stall (3.3e-5 on the 726-sphere pile, 5 tries in a row), 90 % of the
#   residual is on the 4 contacts around one sphere, all "sticking" (r inside the cone)
#   while separating (u_n > 0): no solution with these kinds, a least-squares point.
# Tried without gain (no change made): extrapolating along the drift (t = 10 windows: 1e-3),
# Anderson mixing of 10-sweep maps at omega 1 (m = 5, 20: 8e-5 as without), a Newton weight
# 100x heavier on sticking contacts (steps accepted whole, stalled at 1.7e-5-4.5e-5), rho
# times 10-1000, opening the separating sticks of a stalled try (certified 1 of 9 plateau
# iterates, 8 steps each), contact orders by the CCP's normal impulse, jittered (jitter
# 0.1-1: 624/897/726 piles 1.4-1.5 / 1.7-2.1 / 0.76-0.88 s, but at 0.3 the 897-sphere pile
# was left at 2.3e-5 after 23 s), omega 1 and 1.1 (20-50 % more work), tries every 250
# sweeps (897-sphere pile, b moved by 1e-6, seeds 0-11: seed 10 left at 3.9e-7 where now
# seed 1 is left at 2.2e-5; by 1e-3, seed 12 left at 1.2e-5 either way) or 1,000 (624-sphere
# pile 5,900 -> 8,900), the sweeps on G (W = G G^T, 9 entries a row for 32: 7 % faster, the
# slides' local solves, 250 ns each, dominate), the step in (dr, G^T dr) (its LDL^T 318k
# entries for W's 283k).
# Tried without gain, a second time (an active-set Newton with a ratio test, from the 624-sphere
# pile's plateau iterates after 100-3,000 sweeps): pivoting on the natural map's kinds cycles at
# the first kink (steps of 1e-14 on one contact, 1.9e-4 after 40 pivots); a Lemke orientation
# (|F| 9.5e-5 -> 4e-3 in 60 pivots); kink contacts held with the mixed Jacobian or a
# least-squares row (stalled at 1.3e-5 / 1.3e-4); full fixed-kind steps then local sweeps over
# the contacts that crossed (1.9e-4 -> 1e-2); the cone constraints as an active set (50-150
# active, residual 0.1); a watchdog over 12 full steps (9.8e-6-7.6e-4, none certified); a full
# step every 100 sweeps (2.9e-4 after 2,000 sweeps, 1.2e-4 without). Why: at 3,000 sweeps the
# plateau iterate is 6.5 % of |r| and 13 % of |u| from the certified answer, 18 kinds wrong,
# the residual 1e-3 on the segment between them (a curved valley the sweeps drift along). On
# the 726-sphere pile every stalled try had one kind wrong (a stick separating at 2.5e-5-1e-4
# m/s); opened, it certified in 5-7 steps, but the rule that picked it fired on the 624-sphere
# pile's stalls too (1.00 -> 1.08 s and 1.62 -> 1.73 s unperturbed).
# Tried without gain, a third time (every kind over-relaxed at 1.25 then; from the engine's CCP
# start; work = sweeps + Newton steps, the three large piles with b moved by 1e-6, seeds 0-2,
# unless said): where the sweeps spend their time on the 897-sphere pile, sweeps 700-3,400 at
# 1e-3-5e-3 (omega 1 alike, without the subspace steps alike), the distance to the certified
# answer falls steadily (0.22 of |r| at 500 sweeps, 0.12 at 2,000, 0.06 at 3,000, 0.017 at
# 4,750) with 45-77 kinds wrong (13-35 of them sticks that slide at the answer), the residual on
# firm sticks with |u_t| ~ 1e-2, a different handful of spheres each time; a subspace step there
# lowers it 1.0-1.7x (in 2 of 11 it raised it 8x) and the next 10 sweeps raise it back.
# Body-blocked sweeps (the contacts under one sphere in a row, 4 on the square piles, repeated m
# times; orders of the spheres random): m = 1 624 / 897 pile 2,400 / 22,100 sweeps (3,400 /
# 4,800 without the blocks), m = 2 5,700 / 16,700 and m = 4 10,800 / 21,600 contact solves per
# contact. A proximal term (W + rho I, b - rho r_k, r_k renewed every 10 sweeps; rho 0.01 and
# 0.1 of W's mean diagonal): the 897 pile still at 1e-3-2e-3 after 4,800 sweeps. A smoothing
# Newton (CHKS on the second-order cone, |u_t| smoothed alike, eps = 0.1-10 residuals): from the
# CCP answer 2.6e-2 -> 1.4e-2 in 40 steps, from 500 sweeps 1.8e-3 -> 1.7e-3 in 25 (line search
# at 1/8-1/128; every row live, 100 ms a step). Newton tried from the mean of the last 10
# checked iterates (its residual half the iterate's): work 29,000 -> 37,300. Orders alternating
# a permutation and its reverse (the unperturbed piles): 9,600 -> 12,300. The sweeps from zero
# instead of the CCP answer (seeds 0-7): 624 / 726 pile 0.61-1.01 / 0.34-0.38 s (0.81-1.15 /
# 0.57-0.59 s), 897 pile 1.6-2.4 s in 7 of 8 runs, 8.4 s in one (1.5-1.7 s, 8.5 and 8.8 s in
# two); with b moved by 1e-3 the 726 pile uncertified (seed 1, 8e-6). The light Newton's tries
# judged on their first step: the certifying ones' first steps 0.14-1.3 of the start (a rule at
# 0.5 would have cut 3 of 7). The slide's local Newton with its derivative in closed form (one
# evaluation a step instead of two): the sweeps as fast (1,000 sweeps 0.146 s against 0.147 s).
# The Newton tries' step system factored by the supernodal LDL^T (.supernodal) on the union of
# the live patterns met so far (refactored numerically while it holds): the 897 / 624-sphere
# piles' 18 / 26 steps 0.72 / 0.48 s -> 0.78 / 0.60 s (1.3e8 flops, 30 ms a numeric
# factorization against QDLDL's 33-40 ms for a new pattern's whole one; on every contact's
# pattern 4.2e8 flops, 70 ms).


def nsgs_newton(W, b: np.ndarray, mu: np.ndarray, d: int, r0: np.ndarray, *, tol: float,
                residual: Callable, newton: Callable | None = None,
                subspace: Callable | None = None,
                max_sweeps: int = NSGS_MAX_SWEEPS, omega: float = NSGS_OMEGA,
                omega_other: float = NSGS_OMEGA_OTHER,
                seed: int = NSGS_SEED) -> tuple[np.ndarray, float, int]:
    """Over-relaxed NSGS in random contact orders from ``r0`` (n, d), Newton tried on its way.

    ``residual(r)`` is the certificate (the natural-map residual of Coulomb's law);
    ``newton(r)`` returns ``(r, residual, steps)`` (a Newton finish), tried from iterates
    within :data:`NSGS_NEWTON_FROM`, after each drop by :data:`NSGS_NEWTON_DROP` below the
    residual of the last try and :data:`NSGS_NEWTON_AGAIN` sweeps after it; the sweeps go on
    from a try's answer below :data:`NSGS_RESTART_BELOW` times its start's residual (the
    generator :func:`gauss_seidel` takes it by ``send``); ``subspace(r)``, optional, returns
    impulses the sweeps go on from every :data:`NSGS_SUBSPACE_EVERY` sweeps (or None), paused
    as that constant says (:func:`.subspace.stick_step`). Stops at ``tol``,
    at ``max_sweeps`` or when the NSGS's own best residual (Newton's answers apart) has not
    dropped tenfold in :data:`NSGS_STALL_SWEEPS` sweeps. Returns the best
    ``(r, residual, work)`` (work: sweeps plus Newton steps).
    """
    n = mu.shape[0]
    rng = np.random.default_rng(seed)
    order = np.stack([rng.permutation(n) for _ in range(NSGS_ORDERS)])
    run = gauss_seidel(W, b, mu, d, r0, sweeps=NSGS_CHECK, omega=omega, order=order,
                       omega_other=omega_other)
    best_r = np.asarray(r0, dtype=float).reshape(n, d)
    best = residual(best_r)
    work = 0
    sweeps = 0
    own = best  # the NSGS's own best residual
    drop_at, drop_level = 0, best
    tried, tried_at = NSGS_NEWTON_FROM / NSGS_NEWTON_DROP, 0
    restart = None
    # the subspace steps: paused until paused_until; the residual last halved at sub_at
    paused_until, sub_at, sub_level = 0, 0, best
    while best > tol and sweeps < max_sweeps and sweeps - drop_at < NSGS_STALL_SWEEPS:
        if restart is None and subspace is not None and sweeps >= paused_until and \
                sweeps and sweeps % NSGS_SUBSPACE_EVERY == 0:
            restart = subspace(r)
        r = next(run) if restart is None else run.send(restart)
        restart = None
        sweeps += NSGS_CHECK
        res = residual(r)
        if res < 0.5 * sub_level:
            sub_at, sub_level = sweeps, res
        if sweeps - sub_at >= NSGS_SUBSPACE_STALL:
            paused_until = sweeps + NSGS_SUBSPACE_PAUSE
            sub_at, sub_level = paused_until, np.inf
        if res < best:
            best, best_r = res, r
        own = min(own, res)
        if own < 0.1 * drop_level:
            drop_at, drop_level = sweeps, own
        if newton is not None and tol < res < NSGS_NEWTON_FROM and (
                res < NSGS_NEWTON_DROP * tried or sweeps - tried_at >= NSGS_NEWTON_AGAIN):
            tried, tried_at = res, sweeps
            rn, resn, k = newton(r)
            work += k
            if resn < best:
                best, best_r = resn, rn
            if resn < NSGS_RESTART_BELOW * res:
                restart = rn
    return best_r, float(best), work + sweeps


#: :func:`nsgs_light`: Newton steps of a try (from 2e-4-5e-5 on the sphere piles of 624-897
#: contacts the light Newton certified in 2-9 steps, where the finish's took 26 from 1e-5),
#: a try stopped where its best residual has not halved in NSGS_NEWTON_STALL steps (the
#: failed tries stopped in 3-4)
NSGS_NEWTON_STEPS = 20
NSGS_NEWTON_STALL = 3
#: ...and after 2 steps where it has not halved (:func:`.finish.newton_finish`'s ``first``):
#: the tries that certified the large sphere piles (b perturbed by 0-1e-6) dropped 2.4-100x
#: in 2 steps, most failed ones 1.1-2x; Newton steps on the 624/897/726-sphere piles 41/20/20
#: -> 33/15/18, the same tries certifying (at 4x, (2, 0.25), a certifying try on the
#: 624-sphere pile with b moved by 1e-6 was cut: 6,800 -> 8,900 sweeps)
NSGS_NEWTON_FIRST = (2, 0.5)
#: ...with a light Levenberg-Marquardt weight (:func:`.finish.newton_finish`'s ``damping``):
#: on the sphere piles of 624-897 contacts the Newton matrix is ill-conditioned (a step of
#: 1.4e-4 for a map of 5e-7: singular values near 1e-3); the finish's weight damped exactly
#: those directions and its steps shrank the map by 0.6 each (9 steps from a residual of
#: 1e-6, 26 from 1e-5); 1000 times lighter, the same starts certified in 2-3 steps (the
#: Newton step itself unchanged, its linear model matched to 10 %)
NSGS_NEWTON_DAMPING = 1e-3


#: :func:`nsgs_light`: where the NSGS stops uncertified (its stall rule), it runs again from
#: the same start in other contact orders (the next seed; every kind over-relaxed alike,
#: :data:`NSGS_OMEGA_EVERY`), at most this many times: which
#: plateau iterate Newton certifies from is a matter of the orders (the 897-sphere pile with
#: b moved by 1e-6, seed 1, and by 1e-3, seed 12: stalled at 2.2e-5 and 1.2e-5 after 16,300
#: and 17,300 sweeps, 7.8 and 8.5 s, then certified in 5,400 and 7,700 sweeps with the next
#: seed's orders, 2.1 and 4.4 s, and with the one after, 5,200 and 6,800)
NSGS_RESTARTS = 2


def nsgs_light(W, b: np.ndarray, mu: np.ndarray, d: int, r0: np.ndarray, *, tol: float,
               newton_iter: int = NSGS_NEWTON_STEPS) -> tuple[np.ndarray, float, int]:
    """Coulomb's law on sparse W by :func:`nsgs_newton` from ``r0`` (n, d), its Newton tries
    by :func:`.finish.newton_finish` with :data:`NSGS_NEWTON_DAMPING` (at most ``newton_iter``
    and :data:`NSGS_NEWTON_STEPS` steps) on one step system of W, certified on the natural-map
    residual, the firmly sticking contacts solved every :data:`NSGS_SUBSPACE_EVERY` sweeps
    (:func:`.subspace.stick_step`), the sticking answers over-relaxed by :data:`NSGS_OMEGA`;
    where it stops uncertified, run again in other contact orders without those steps, every
    kind over-relaxed by :data:`NSGS_OMEGA_EVERY` (:data:`NSGS_RESTARTS`). Returns the best
    ``(r, residual, work)`` (the runs' work summed).
    """
    W = sp.csr_matrix(W)
    b = np.asarray(b, dtype=float).reshape(mu.shape[0], d)
    system = SparseStepSystem(W, d)

    def newton(r):
        return newton_finish(W, b, mu, r, coulomb=True, tol=tol, sparse=True,
                             step_system=system, damping=NSGS_NEWTON_DAMPING,
                             max_iter=min(newton_iter, NSGS_NEWTON_STEPS),
                             stall_steps=NSGS_NEWTON_STALL, first=NSGS_NEWTON_FIRST)

    best_r, best, work = r0, np.inf, 0
    # (omega, omega_other, seed, subspace steps): the sticks over-relaxed first, then the
    # restarts with every kind at NSGS_OMEGA_EVERY (NSGS_RESTARTS)
    runs = [(NSGS_OMEGA, NSGS_OMEGA_OTHER, NSGS_SEED, True)] + [
        (NSGS_OMEGA_EVERY, NSGS_OMEGA_EVERY, NSGS_SEED + k, False)
        for k in range(1, NSGS_RESTARTS + 1)]
    for omega, other, seed, steps in runs:
        r, res, w = nsgs_newton(W, b, mu, d, r0, tol=tol, newton=newton, seed=seed,
                                omega=omega, omega_other=other,
                                subspace=(lambda r: stick_step(W, b, mu, r)) if steps else None,
                                residual=lambda r: natural_map_residual(W, b, mu, r, True)[0])
        work += w
        if res < best:
            best_r, best = r, res
        if best <= tol:
            break
    return best_r, best, work
