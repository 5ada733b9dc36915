"""An ADMM on Coulomb's law in De Saxce's form: the engine's way close to a solution of the
non-convex problem when Newton from the CCP answer does not get there; Newton then finishes.

Coulomb's law reads ``K ∋ r ⊥ y = W r + b + s ∈ K*`` with De Saxce's shift
``s = mu |u_t| e_n``. The iteration (Carpentier et al., "From compliant to rigid contact
simulation: a unified and efficient approach", RSS 2024: the ADMM of Pinocchio) splits ``r``
from its copy ``w`` in the friction cones:

    x+ = (W + (rho + eta) I)^-1 (eta x - b - s + rho w - lam)      (a proximal step)
    w+ = P_K(x+ + lam / rho)
    lam+ = lam + rho (x+ - w+),     s+ = mu |(-lam+)_t| e_n

(``-lam`` tends to the shifted velocity ``y``), with ``rho`` balanced between the primal and
dual residuals (each change one new factorization) and ``eta`` a small proximal term that
keeps a singular W factorizable.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np
import qdldl
import scipy.linalg as sla
import scipy.sparse as sp

from .admm_kernel import (BALANCE, ETA, RHO_POWER, RHO_STEP, TAU, admm_update,  # noqa: F401
                          dense_admm)
from .admm_sparse_kernel import SparseAdmmRun
from .cones import natural_map_residual, project
from .generalized import WoodburySolver



#: the over-relaxation of the proximal step (OSQP's alpha: ``x`` enters the cone step and the
#: multiplier as ``RELAX x + (1 - RELAX) w``); measured from the CCP answer and from zero, in
#: iterations to 1e-8 at 1, 1.3 and 1.6: brick wall of 976 contacts from zero 5,740, 2,650,
#: 1,740 (from the CCP answer > 30,000, > 30,000, 23,620); wall of 424 from the CCP answer
#: 4,600, 3,030, 2,590 (zero: 4,920, 3,300, 3,720); log pile of 528 from the CCP answer 1,780,
#: 1,370, 1,120 (zero: 6,350, 4,880, 4,000). The engine's compiled dense ADMM from the CCP
#: answer too (:func:`.admm_kernel.dense_admm`: 1.6-2x fewer on 12 stacks, piles, walls and
#: robots of 48-264 contacts; not from zero, its first try: a log pile of 264 contacts went
#: from 280 iterations to 6,810, a pile of 256 spheres from 18,160 to none in 20,000)
RELAX = 1.6


def _largest_eigenvalue(A, size: int) -> float:
    v = np.random.default_rng(0).standard_normal(size)
    lam = 0.0
    for _ in range(30):
        w = A @ v
        nw = np.linalg.norm(w)
        if nw == 0.0:
            return 0.0
        lam, v = float(v @ w) / float(v @ v), w / nw
    return max(lam, 0.0)


class _Solver:
    """Solves with ``A + shift I``: by a sparse LDL^T (QDLDL) or a dense Cholesky of it, or,
    given ``G`` with ``A = G G^T`` (N x r, r < N), by Woodbury's identity
    ``(G G^T + c I)^-1 = (I - G (c I + G^T G)^-1 G^T) / c`` (a Cholesky of r rows)."""

    def __init__(self, A, sparse: bool, G: np.ndarray | None = None):
        self.A, self.sparse, self.f = A, sparse, None
        self.G = G
        self.GtG = None if G is None else G.T @ G

    def factor(self, shift: float) -> None:
        A = self.A
        if self.G is not None:
            K = self.GtG.copy()
            K[np.diag_indices_from(K)] += shift
            self.f = ("woodbury", sla.cho_factor(K, check_finite=False), shift)
        elif self.sparse:
            K = sp.triu(A + shift * sp.identity(A.shape[0], format="csc"), format="csc")
            if self.f is None:
                self.f = qdldl.Solver(K)
            else:
                self.f.update(K)
        else:
            K = A.copy()
            K[np.diag_indices_from(K)] += shift
            self.f = sla.cho_factor(K, check_finite=False)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        if self.G is not None:
            _, f, shift = self.f
            return (rhs - self.G @ sla.cho_solve(f, self.G.T @ rhs, check_finite=False)) / shift
        return self.f.solve(rhs) if self.sparse else sla.cho_solve(self.f, rhs,
                                                                   check_finite=False)


def coulomb_admm(W, b: np.ndarray, mu: np.ndarray, r0: np.ndarray, sparse: bool, *,
                 check_every: int = 10, factor=None, coulomb: bool = True,
                 relax: float = RELAX, like=None, anderson: bool = False):
    """ADMM iterations from ``r0`` (n, d), yielding the cone copy (n, d) every
    ``check_every`` iterations (the caller judges it and stops when it likes).

    The iteration runs on the data as given (an equilibration of the contacts slowed it on
    stacks and walls in our measurements), with Pinocchio's parameters: the proximal weight
    ``eta = 1e-6``, ``rho = tau sqrt(L eta) (L / eta)^0.2`` with ``tau = 1/2``, L the largest
    eigenvalue of W, and rho doubled or halved whenever the primal and dual residuals differ
    by a factor of more than 10. ``factor``, optional: W's low-rank factor
    (:class:`~.lowrank.DelassusFactor`); where it has one, the proximal steps are solved
    through it (Woodbury's identity), the same iteration.

    On sparse W (G none or sparse) the iterations are compiled
    (:class:`.admm_sparse_kernel.SparseAdmmRun`, the same iteration to round-off; its
    ``residual`` is the natural-map residual of the last iterate given); elsewhere a
    Python generator. Either is an iterator: ``next(run)``. ``like``, optional: a compiled
    run on the same W and factor whose set-up the new one shares. With ``anderson``, the
    compiled run is accelerated (:class:`.admm_anderson.AndersonAdmmRun`; the Python
    generator is not).
    """
    G = None if factor is None else factor.G
    if sparse and sp.issparse(W) and check_every == 10 and (G is None or sp.issparse(G)):
        n, d = r0.shape
        like = like if isinstance(like, SparseAdmmRun) else None
        L = like.L if like is not None else _largest_eigenvalue(_Product(W, G), n * d) or 1.0
        rho = TAU * np.sqrt(L * ETA) * (L / ETA) ** RHO_POWER
        cls = SparseAdmmRun
        if anderson:
            from .admm_anderson import AndersonAdmmRun as cls
        return cls(W, b, mu, np.asarray(r0, dtype=float), G, L=L, rho=rho,
                   eta=ETA, relax=relax, balance=BALANCE, step=RHO_STEP,
                   coulomb=coulomb, like=like)
    return _python_admm(W, b, mu, r0, sparse, check_every=check_every, factor=factor,
                        coulomb=coulomb, relax=relax)


class _Product:
    """``v -> W v``, through ``G (G^T v)`` where G is given (sparse)."""

    def __init__(self, W, G):
        self.W, self.G = W, G
        self.Gt = None if G is None else sp.csr_matrix(G.T)

    def __matmul__(self, v):
        return self.W @ v if self.G is None else self.G @ (self.Gt @ v)


def _python_admm(W, b: np.ndarray, mu: np.ndarray, r0: np.ndarray, sparse: bool, *,
                 check_every: int = 10, factor=None, coulomb: bool = True,
                 relax: float = RELAX) -> Iterator[np.ndarray]:
    """:func:`coulomb_admm`'s iterations in Python (dense W, or a dense low-rank factor)."""

    n, d = r0.shape
    size = n * d
    q = np.asarray(b, dtype=float).ravel()
    L = _largest_eigenvalue(W, size) or 1.0
    eta = ETA
    rho = TAU * np.sqrt(L * eta) * (L / eta) ** RHO_POWER
    G = None if factor is None else factor.G
    solver = WoodburySolver(G) if sp.issparse(G) else _Solver(W, sparse, G)
    solver.factor(rho + eta)
    x = np.asarray(r0, dtype=float).ravel()
    w = project(x.reshape(n, d), mu).ravel()
    lam = -(W @ w + q)

    def shift(v):
        out = np.zeros((n, d))
        vv = v.reshape(n, d)
        if not coulomb:
            return out.ravel()
        out[:, 0] = mu * np.sqrt(np.einsum("ij,ij->i", vv[:, 1:], vv[:, 1:]))
        return out.ravel()

    s = shift(-lam)
    x, w, lam = x.copy(), np.ascontiguousarray(w), np.ascontiguousarray(lam)
    m = np.ascontiguousarray(mu, dtype=float)
    scratch = np.empty(x.size), np.empty(x.size)
    it = 0
    while True:
        it += 1
        x_new = solver.solve(eta * x - q - s + rho * w - lam)
        # over-relaxed (RELAX), then w, lam, s (-lam -> the shifted velocity u + s at the
        # solution): compiled; the proximal centre x is the solve's own answer
        relaxed = np.ascontiguousarray(relax * x_new + (1.0 - relax) * w)
        primal, dual = admm_update(relaxed, x, w, lam, s, m, d, rho, eta, coulomb, *scratch)
        x[:] = x_new
        if it % check_every == 0:
            yield w.reshape(n, d).copy()
        if primal > BALANCE * dual and rho < 1e8 * L:
            rho *= RHO_STEP
            solver.factor(rho + eta)
        elif dual > BALANCE * primal and rho > 1e-8 * L:
            rho /= RHO_STEP
            solver.factor(rho + eta)


def ccp_admm(W, b: np.ndarray, mu: np.ndarray, r0: np.ndarray, sparse: bool, *, tol: float,
             max_iter: int, factor=None, dense: bool = False
             ) -> tuple[np.ndarray, float, int]:
    """The CCP (no De Saxce shift) by the ADMM of :func:`coulomb_admm` from ``r0`` (n, d) until
    the CCP's natural-map residual (:func:`~.cones.natural_map_residual`, checked every ten
    iterations) is at most ``tol`` or ``max_iter`` iterations are done: the engine's way where
    the interior point stalls short of ``tol`` and the Newton finish crawls (a problem whose
    complementarity is not strict: on the brick wall of 976 contacts the interior point stopped
    at 1.9e-7, the finish's line search took steps of 1e-2 to 0.25 and reached 1.5e-8 in 30
    steps; this ADMM from the interior point's answer: 1.2e-9 in 1,000 iterations, 0.26 s).

    With ``dense``, the compiled ADMM of :func:`.admm_kernel.dense_admm` on W made dense.
    Returns the best ``(r, residual, iterations)``."""
    n, d = r0.shape
    if dense:
        Wd = W.toarray() if sp.issparse(W) else np.asarray(W, dtype=float)
        r, _, done = dense_admm(Wd, np.asarray(b, dtype=float).reshape(n, d), mu, d, r0,
                                tol=tol, max_iter=max_iter, coulomb=False)
        return r, natural_map_residual(Wd, b, mu, r, coulomb=False)[0], done
    run = coulomb_admm(W, b, mu, r0, sparse, factor=factor, coulomb=False)
    best_res, best = np.inf, np.asarray(r0, dtype=float)
    done = 0
    while done < max_iter and best_res > tol:
        r = next(run)
        done += 10
        res = _residual(run, W, b, mu, r, coulomb=False, tol=tol)
        if res < best_res:
            best_res, best = res, r
    return best, best_res, done


def _residual(run, W, b, mu, r, *, coulomb: bool, tol: float) -> float:
    """The natural-map residual of the iterate ``r`` of ``run``: the compiled run's own
    (W's product through G) where it is above twice ``tol``, else computed on W as given
    (the certificate's)."""
    res = getattr(run, "residual", None)
    if res is None or res <= 2.0 * tol:
        res, _ = natural_map_residual(W, b, mu, r, coulomb=coulomb)
    return float(res)


#: :class:`AdmmRace`: the first run's best is marked every CRAWL_ITER iterations; where it has
#: not dropped by CRAWL_DROP over CRAWL_WINDOW marks, the run from zero joins (on the brick
#: wall of 976 contacts, without over-relaxation, the ADMM from the CCP answer crawled from
#: 1e-6 at 3,000 iterations to 5e-7 at 27,000, from zero it certified at 5,740; on the wall of
#: 424 from the CCP answer it stayed at 4e-7 from 2,000 to 4,400 and certified at 4,600, 4,920
#: from zero; on the log pile of 528 from the CCP answer at 1,780, 6,350 from zero); over-
#: relaxed, the wall of 976 went from 3.2e-6 at 1,000 to 1.4e-6 at 2,000: with a window of one
#: mark the run from zero joins there, 5,040 iterations in all instead of 6,050 with two (the
#: wall of 424 and the log pile of 528 certify before any crawl either way)
CRAWL_ITER = 1000
CRAWL_WINDOW = 1
CRAWL_DROP = 0.1
#: ...and where the first run, at its rate over that window, would need more than
#: REPLACE_BEYOND iterations to reach tol, it is dropped as the run from zero joins (the
#: longest runs from zero measured, over-relaxed: log pile of 528 4,000, wall of 424 3,720;
#: on the wall of 976, 3.2e-6 to 1.4e-6 over 1,000 iterations, 5,800 more at that rate: the
#: run from zero alone from 2,000 certified at 3,770 iterations in all instead of 5,040)
REPLACE_BEYOND = 4000
#: ...and the run from zero is Anderson-accelerated (:mod:`.admm_anderson`): on the brick wall
#: of 976 contacts 3,766 -> 2,676 iterations in all (b perturbed by 1e-14, seeds 1-6: 2,677 to
#: 2,681), 385-417 -> 319-323 ms; the run from the CCP answer is not: accelerated, on that wall
#: from 6.3e-7 to 1.1e-7 at 6,000 iterations (memory 10) but the wall of 424 went from 2,492
#: to 12,905 iterations and the log pile of 528 from 1,080 to 1,940 (the sphere pile of 256
#: 1,155 -> 895); nothing else of the corpus runs from zero here
ANDERSON_FROM_ZERO = True


class AdmmRace:
    """The ADMM of :func:`coulomb_admm` from ``r0``, joined by a second run from zero
    (Pinocchio's start) where the first crawls; the runs then take turns of ten iterations,
    until the second's best residual is below the first's: the first is then dropped (at
    once where it is too slow for ``tol``).

    :meth:`next` gives the next iterate (ten iterations of one run), :meth:`judge` takes its
    natural-map residual. Every :data:`CRAWL_ITER` iterations the first run's best residual
    is marked; where it is at most ``below`` and above :data:`CRAWL_DROP` times the mark
    :data:`CRAWL_WINDOW` marks earlier, the run from zero joins (once); where the first would
    need more than :data:`REPLACE_BEYOND` iterations to reach ``tol`` at its rate over that
    window, the first is dropped there and then. On the brick wall of 976 contacts
    (over-relaxed) the run from zero replaces it at 2,000 iterations and certifies at 3,770
    (joining only: 5,040; with a window of two marks: joining at 3,000, 6,060); accelerated
    (:data:`ANDERSON_FROM_ZERO`), at 2,676.
    """

    def __init__(self, W, b, mu, r0, sparse: bool, *, factor=None, below: float = 1e-4,
                 relax: float = RELAX, tol: float = 1e-8):
        self.args = W, b, mu, sparse, factor, relax
        self.tol = tol
        self.runs = [coulomb_admm(W, b, mu, r0, sparse, factor=factor, relax=relax)]
        self.zeros = np.zeros_like(np.asarray(r0, dtype=float))
        self.crawl = CRAWL_ITER, CRAWL_WINDOW, CRAWL_DROP, below
        self.done = 0
        self.last = 0  # the run of the last iterate
        self.best = [np.inf, np.inf]  # each run's best residual
        self.joined = False
        self.marks = [np.inf]  # the first run's best every crawl_iter iterations
        self.residual = None

    def next(self) -> np.ndarray:
        self.last = (self.done // 10) % len(self.runs)
        self.done += 10
        run = self.runs[self.last]
        r = next(run)
        #: the natural-map residual of the iterate given, where its run computed it
        self.residual = getattr(run, "residual", None)
        return r

    def judge(self, res: float) -> None:
        which = self.last + (1 if self.joined and len(self.runs) == 1 else 0)
        self.best[which] = min(self.best[which], res)
        if len(self.runs) > 1:
            if self.best[1] < self.best[0]:
                del self.runs[0]
            return
        crawl_iter, window, drop, below = self.crawl
        self.marks[-1] = self.best[0]
        if not self.joined and self.done % crawl_iter == 0:
            m = self.marks
            if len(m) > window and m[-1] <= below and m[-1] > drop * m[-1 - window]:
                W, b, mu, sparse, factor, relax = self.args
                self.runs.append(coulomb_admm(W, b, mu, self.zeros, sparse, factor=factor,
                                              relax=relax, like=self.runs[0],
                                              anderson=ANDERSON_FROM_ZERO))
                self.joined = True
                # the first run's iterations to tol at its rate over the window: beyond
                # REPLACE_BEYOND it is dropped at once (the run from zero alone)
                rate = m[-1] / m[-1 - window]
                if rate < 1.0 and m[-1] > self.tol:
                    left = np.log(m[-1] / self.tol) / -np.log(rate) * window * crawl_iter
                else:
                    left = np.inf
                if left > REPLACE_BEYOND:
                    del self.runs[0]
            m.append(m[-1])
