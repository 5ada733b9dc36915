"""Anderson acceleration of the sparse ADMM of :mod:`.admm_sparse_kernel`, safeguarded (type
II, as SCS 3: Zhang, O'Donoghue and Boyd, "Globally convergent type-I Anderson acceleration
for nonsmooth fixed-point iterations", SIAM J. Optim. 2020; Fu, Zhang and Boyd, "Anderson
accelerated Douglas-Rachford splitting", 2020).

The fixed-point map F is :data:`INTERVAL` ADMM iterations on the state ``z = (w, lam / rho)``
(the proximal centre x enters it with the weight ``eta / (rho + eta)``, 1e-6 or less: it is
carried, not accelerated). With the last ``memory`` differences of the iterates (S) and of their
residuals ``g = z - F(z)`` (Y), the next iterate is ``F(z) - (S - Y) gamma``, gamma the
(slightly regularized) least-squares solution of ``Y gamma = g``. It is kept only when the
map's residual there is at most :data:`SAFEGUARD` times the one it was extrapolated from;
else the run goes back to the plain ``F(z)`` and the memory is cleared (also when rho
changes: the map changes with W's factorization).

The engine accelerates the run from zero of :class:`.admm.AdmmRace` only (see
:data:`.admm.ANDERSON_FROM_ZERO` for what the others did). Tried on the engine's first try, the
compiled dense ADMM from zero, by this run on the brick wall of 88 contacts: 3,000 iterations
left it at 1e-4 (memories 5-10, every iteration), 9e-7 (memory 5, every ten): no gain.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import announce
from ..compiled import jit as _jit
from .admm_kernel import _desaxce
from .admm_sparse_kernel import SparseAdmmRun, sparse_admm_steps
from .interior_point import _cho_solve, _cholesky

#: the differences kept; on the brick wall of 976 contacts (the engine's run from zero, joining
#: at 2,000 iterations), in iterations in all: 5 2,786, 6 2,686, 8 2,676, 10 2,797, 12 2,766
#: (without: 3,766)
MEMORY = 8
#: the map accelerated is this many ADMM iterations (SCS 3's acceleration interval): on that
#: wall from zero, alone, with a memory of 10, certified at 740 iterations with 1 (each
#: iteration 2x dearer: the least squares on 2N rows) and 940 with 10; in the engine, memory
#: 8: with 1 2,816 iterations, 401 ms; with 5 6,166; with 10 2,676, 320 ms (without: 3,766,
#: 385-417 ms)
INTERVAL = 10
#: an accelerated iterate is kept where its fixed-point residual is at most this times the
#: residual of the iterate it was extrapolated from (on that wall 0.95: 2,756 iterations in
#: all, 1.05 and 1.5: 2,676)
SAFEGUARD = 1.0
#: the least-squares problem's Tikhonov weight, relative to the trace of Y^T Y
REGULARIZE = 1e-10
#: an extrapolation whose weights exceed this (max norm) is not taken
MAX_WEIGHT = 1e4
#: first compilation of :func:`anderson_admm_steps` on 2 cores (s), announced (1.5 s measured
#: with an empty cache, after the sparse ADMM's own kernels)
COMPILE_SECONDS = 2

# info's entries: columns filled, next column, previous iterate held, candidate pending;
# then the extrapolations kept and rejected (counts)
_FILLED, _POS, _HAVE, _CAND, _KEPT, _REJECTED = 0, 1, 2, 3, 4, 5


@_jit
def _reset(info):
    for k in range(4):
        info[k] = 0


@_jit
def anderson_admm_steps(woodbury, Gp, Gi, Gx, Tp, Ti, Tx, Wp, Wi, Wx, Lp, Li, Lx, D, P,
                        b, mu, d, x, w, lam, s, rho, eta, Lmax, relax, coulomb, count,
                        balance, step, S, Y, gram, info, base, zprev, gprev, wout, safeguard,
                        interval):
    """Up to ``count`` ADMM iterations from the state ``(x, w, lam, s)`` (updated in place;
    as :func:`.admm_sparse_kernel.sparse_admm_steps`), extrapolated after each ``interval``
    of them (the map F) unless rho changed; an extrapolation is dropped where F's residual
    there exceeds ``safeguard`` times the one it came from. ``S`` and ``Y``
    (memory, 2N), ``gram`` (memory, memory), ``info`` (6 ints), ``base`` (1 + 3N: the
    residual norm and the plain iterate ``(w, lam / rho, x)`` of a pending extrapolation),
    ``zprev`` and ``gprev`` (2N) carry the acceleration between calls. ``wout`` receives
    the cone copy w of the last ADMM iterate (in the cones, as the plain run's). Returns
    ``(iterations, new rho)`` (the caller refactors where rho changed; the memory is then
    cleared)."""
    N = b.shape[0]
    n2 = 2 * N
    mem = S.shape[0]
    z = np.empty(n2)
    f = np.empty(n2)
    g = np.empty(n2)
    rhs = np.empty(mem)
    weights = np.empty(mem)
    spd = np.empty((mem, mem))
    chol = np.empty((mem, mem))
    it = 0
    while it < count:
        it += 1
        for i in range(N):
            z[i] = w[i]
            z[N + i] = lam[i] / rho
        done, new_rho = sparse_admm_steps(woodbury, Gp, Gi, Gx, Tp, Ti, Tx, Wp, Wi, Wx, Lp,
                                          Li, Lx, D, P, b, mu, d, x, w, lam, s, rho, eta,
                                          Lmax, relax, coulomb, min(interval, count - it + 1),
                                          balance, step)
        it += done - 1
        ng = 0.0
        for i in range(N):
            wout[i] = w[i]
            f[i] = w[i]
            f[N + i] = lam[i] / rho
        for i in range(n2):
            g[i] = z[i] - f[i]
            ng += g[i] * g[i]
        ng = math.sqrt(ng)
        if new_rho != rho:
            _reset(info)
            return it, new_rho
        if done < interval:  # a part of the map (the count's end): no difference of F's
            _reset(info)
            continue
        if info[_CAND] == 1 and ng > safeguard * base[0]:
            # rejected: back to the plain iterate it was extrapolated from, memory cleared
            for i in range(N):
                w[i] = base[1 + i]
                lam[i] = rho * base[1 + N + i]
                x[i] = base[1 + n2 + i]
                wout[i] = w[i]
            if coulomb:
                _desaxce(lam, mu, d, s, False)
            _reset(info)
            info[_REJECTED] += 1
            continue
        if info[_CAND] == 1:
            info[_KEPT] += 1
        info[_CAND] = 0
        if info[_HAVE] == 1:  # the newest differences into the memory (a ring)
            col = info[_POS]
            for i in range(n2):
                S[col, i] = z[i] - zprev[i]
                Y[col, i] = g[i] - gprev[i]
            if info[_FILLED] < mem:
                info[_FILLED] += 1
            info[_POS] = (col + 1) % mem
            for j in range(info[_FILLED]):
                t = 0.0
                for i in range(n2):
                    t += Y[col, i] * Y[j, i]
                gram[col, j] = t
                gram[j, col] = t
        for i in range(n2):
            zprev[i] = z[i]
            gprev[i] = g[i]
        info[_HAVE] = 1
        k = info[_FILLED]
        if k == 0:
            continue
        trace = 0.0
        for j in range(k):
            trace += gram[j, j]
            t = 0.0
            for i in range(n2):
                t += Y[j, i] * g[i]
            rhs[j] = t
        reg = REGULARIZE * trace + 1e-300
        A = spd[:k, :k]
        for a in range(k):
            for c in range(k):
                A[a, c] = gram[a, c]
            A[a, a] += reg
        if not _cholesky(A, chol[:k, :k]):
            continue
        gamma = weights[:k]
        _cho_solve(chol[:k, :k], rhs[:k], gamma)
        big = 0.0
        for a in range(k):
            big = max(big, abs(gamma[a]))
        if not big <= MAX_WEIGHT:
            continue
        base[0] = ng
        for i in range(n2):
            base[1 + i] = f[i]
        for i in range(N):
            base[1 + n2 + i] = x[i]
        for j in range(k):
            gj = gamma[j]
            for i in range(n2):
                f[i] -= gj * (S[j, i] - Y[j, i])
        for i in range(N):
            w[i] = f[i]
            lam[i] = rho * f[N + i]
        if coulomb:
            _desaxce(lam, mu, d, s, False)
        info[_CAND] = 1
    return it, rho


class AndersonAdmmRun(SparseAdmmRun):
    """:class:`.admm_sparse_kernel.SparseAdmmRun` accelerated (:func:`anderson_admm_steps`,
    ``memory`` differences): :meth:`next` runs ten iterations and returns the cone copy
    w of the last ADMM iterate (not the extrapolation), :attr:`residual` its natural-map
    residual. ``memory``, ``interval``, ``safeguard``: :data:`MEMORY`, :data:`INTERVAL`,
    :data:`SAFEGUARD`."""

    def __init__(self, *args, memory: int = MEMORY, interval: int = INTERVAL,
                 safeguard: float = SAFEGUARD, **kwargs):
        announce("Anderson-accelerated ADMM's kernel", COMPILE_SECONDS, anderson_admm_steps)
        super().__init__(*args, **kwargs)
        self.interval, self.safeguard = interval, safeguard
        N = self.q.size
        self.S = np.zeros((memory, 2 * N))
        self.Y = np.zeros((memory, 2 * N))
        self.gram = np.zeros((memory, memory))
        self.info = np.zeros(6, dtype=np.int64)
        self.base = np.zeros(1 + 3 * N)
        self.zprev = np.zeros(2 * N)
        self.gprev = np.zeros(2 * N)
        self.wout = self.w.copy()

    def _steps(self, left: int) -> tuple[int, float]:
        return anderson_admm_steps(
            self.woodbury, *self.G, *self.T, *self.W, *self.F, self.q, self.mu, self.d,
            self.x, self.w, self.lam, self.s, self.rho, self.eta, self.L, self.relax,
            self.coulomb, left, self.balance, self.step, self.S, self.Y, self.gram,
            self.info, self.base, self.zprev, self.gprev, self.wout, self.safeguard,
            self.interval)

    def _given(self) -> np.ndarray:
        return self.wout  # the last plain ADMM iterate's cone copy, not the extrapolation

