"""A supernodal sparse LDL^T for the engine's refactored systems: :class:`SupernodalLDL`, in
place of QDLDL's numeric factorization where one pattern is factored many times.

QDLDL (the LDL^T of OSQP, an up-looking factorization one scalar at a time) spent a third of
the engine's time on the corpus's problems of 100 to 1,000 contacts, and 40-45 % on the sphere
piles, whose systems fill in: the CCP interior point's ``W + H`` on a pile of 897 spheres,
2,607 rows, factors in 13 ms, 53 Mflop of which 81 % lie in columns whose factor shares one
row pattern with 31 or more neighbours (supernodes; the last one, dense, 328 columns). This
module factors the same matrix in QDLDL's ordering (approximate minimum degree) column block
by column block: each supernode's columns are one dense panel, the updates from the
supernodes below it in the elimination tree are matrix products (BLAS), and a panel is
factored by blocks of :data:`PANEL_BLOCK` columns, with matrix products between them
(left-looking, as CHOLMOD's supernodal factorization). No pivoting, as QDLDL: the matrices
are quasi-definite (positive definite, or ``[[H, G], [G^T, -I]]`` with H positive definite),
where an LDL^T exists in every symmetric ordering.

The symbolic part (the ordering, the factor's pattern, the supernodes, where each entry of
the matrix lands in the panels) is made once per pattern, from one QDLDL factorization (its
permutation and the pattern of its factor); :meth:`SupernodalLDL.update` then refactors
numerically. At a zero or non-finite pivot QDLDL refactors that matrix (as it did before
this module).
"""

from __future__ import annotations

import numpy as np
import qdldl
import scipy.sparse as sp

from ..compiled import announce
from ..compiled import jit as _jit

#: supernodes of at least this many columns count as wide (:attr:`SupernodalLDL.wide_share`)
WIDE = 16

#: the supernodes serve a pattern whose factorization takes at least this many flops (QDLDL's
#: count) with at least this share in wide supernodes; else QDLDL factors it (on the corpus:
#: 14-53 Mflop and 0.84-0.89 on sphere piles of 624-897 contacts, 2.5-5x faster; at most
#: 6 Mflop elsewhere, where the supernodes' setup and small panels cost what they save)
MIN_FLOPS = 1e7
MIN_WIDE_SHARE = 0.6

#: first compilation of the numeric factorization and solve on 2 cores (s), announced
COMPILE_SECONDS = 6

#: columns of a panel factored one by one before a matrix product updates the panel's rest
PANEL_BLOCK = 32


@_jit
def _dense_ldl(P, D, f):
    """LDL^T in place of the panel P (m x w, its top w x w block the supernode's diagonal
    block, lower part read), the pivots into ``D[f:f + w]``; returns False at a zero or
    non-finite pivot. Blocks of PANEL_BLOCK columns, each followed by one product."""
    m, w = P.shape
    nb = PANEL_BLOCK
    for j0 in range(0, w, nb):
        j1 = min(j0 + nb, w)
        for j in range(j0, j1):
            dj = P[j, j]
            if dj == 0.0 or not np.isfinite(dj):
                return False
            D[f + j] = dj
            inv = 1.0 / dj
            for i in range(j + 1, m):
                P[i, j] *= inv
            for jj in range(j + 1, j1):
                c = P[jj, j] * dj
                if c != 0.0:
                    for i in range(jj, m):
                        P[i, jj] -= P[i, j] * c
        if j1 < w:
            Lb = np.ascontiguousarray(P[j1:, j0:j1])
            Wb = np.ascontiguousarray(P[j1:w, j0:j1]) * D[f + j0:f + j1]
            P[j1:, j1:w] -= np.dot(Lb, Wb.T)
    return True


@_jit
def _factor(vals, vptr, rows, rptr, start, col_of, D, dest, data):
    """The numeric factorization (module docstring) into ``vals`` (the panels, row-major,
    panel s at ``vals[vptr[s]:vptr[s + 1]]``) and ``D``; ``data`` the matrix's entries,
    ``dest`` where each lands. Returns False at a zero or non-finite pivot.

    Right-looking by supernodes: once a panel is factored, its whole update ``L_b D L_b^T``
    (L_b its rows below the diagonal block) is one matrix product, scattered into the panels
    of the supernodes its rows belong to (a row of L_b lies in every such panel: the rows of
    a supernode's factor below another's columns are among that one's rows)."""
    nsn = start.shape[0] - 1
    vals[:] = 0.0
    for k in range(data.shape[0]):
        if dest[k] >= 0:
            vals[dest[k]] += data[k]
    for s in range(nsn):
        f, l = start[s], start[s + 1]
        w = l - f
        r0, r1 = rptr[s], rptr[s + 1]
        m = r1 - r0
        P = vals[vptr[s]:vptr[s + 1]].reshape(m, w)
        if not _dense_ldl(P, D, f):
            return False
        if w == m:
            continue
        # (rows w.. of the row-major panel: a contiguous slice of vals)
        Lb = vals[vptr[s] + w * w:vptr[s + 1]].reshape(m - w, w)
        C = np.dot(Lb, (Lb * D[f:l]).T)
        nb = m - w
        a = 0
        while a < nb:
            s2 = col_of[rows[r0 + w + a]]
            f2, l2 = start[s2], start[s2 + 1]
            w2 = l2 - f2
            a2 = a
            while a2 < nb and rows[r0 + w + a2] < l2:
                a2 += 1
            q0 = rptr[s2]
            P2 = vals[vptr[s2]:vptr[s2 + 1]].reshape(rptr[s2 + 1] - q0, w2)
            p = 0
            for i in range(a, nb):
                row = rows[r0 + w + i]
                while rows[q0 + p] != row:
                    p += 1
                for b in range(a, min(i + 1, a2)):
                    P2[p, rows[r0 + w + b] - f2] -= C[i, b]
            a = a2
    return True


@_jit
def _solve(vals, vptr, rows, rptr, start, D, perm, b):
    """``x`` with ``A x = b`` from the factors (``perm``: the ordering, new -> old); the
    panels read by rows (row-major)."""
    n = D.shape[0]
    x = np.empty(n)
    for k in range(n):
        x[k] = b[perm[k]]
    nsn = start.shape[0] - 1
    for s in range(nsn):  # L y = x
        f, l = start[s], start[s + 1]
        w = l - f
        r0, r1 = rptr[s], rptr[s + 1]
        m = r1 - r0
        P = vals[vptr[s]:vptr[s + 1]].reshape(m, w)
        for i in range(1, w):
            acc = x[f + i]
            for j in range(i):
                acc -= P[i, j] * x[f + j]
            x[f + i] = acc
        for i in range(w, m):
            acc = 0.0
            for j in range(w):
                acc += P[i, j] * x[f + j]
            x[rows[r0 + i]] -= acc
    for k in range(n):
        x[k] /= D[k]
    y = np.empty(n)
    for s in range(nsn - 1, -1, -1):  # L^T x = y
        f, l = start[s], start[s + 1]
        w = l - f
        r0, r1 = rptr[s], rptr[s + 1]
        m = r1 - r0
        P = vals[vptr[s]:vptr[s + 1]].reshape(m, w)
        for j in range(w):
            y[j] = x[f + j]
        for i in range(w, m):
            xi = x[rows[r0 + i]]
            for j in range(w):
                y[j] -= P[i, j] * xi
        for i in range(w - 1, -1, -1):
            yi = y[i]
            x[f + i] = yi
            for j in range(i):
                y[j] -= P[i, j] * yi
    out = np.empty(n)
    for k in range(n):
        out[perm[k]] = x[k]
    return out


def _upper(A, upper: bool) -> sp.csc_matrix:
    A = sp.csc_matrix(A) if upper else sp.triu(A, format="csc")
    A.sort_indices()
    return A


class SupernodalLDL:
    """``A = P L D L^T P^T`` of a quasi-definite sparse A (module docstring), with
    qdldl.Solver's calls: ``SupernodalLDL(A, upper=False)``, :meth:`update`, :meth:`solve`.

    Parameters
    ----------
    A : scipy.sparse (n, n), symmetric (its upper triangle read; ``upper``: A is that
        triangle, in CSC). Its pattern (explicit zeros included) is the one every
        :meth:`update` must keep.
    """

    def __init__(self, A, upper: bool = False):
        K = _upper(A, upper)
        n = K.shape[0]
        self.n, self.nnz = n, K.nnz
        self._indptr, self._indices = K.indptr.copy(), K.indices.copy()
        # the ordering and the factor's pattern, from QDLDL's factorization of A
        first = qdldl.Solver(K, upper=True)
        Lq, _, perm = first.factors()
        Lq = sp.csc_matrix(Lq)
        Lq.sort_indices()
        Lp, Li = Lq.indptr.astype(np.int64), Lq.indices.astype(np.int64)
        perm = np.asarray(perm, dtype=np.int64)
        counts = np.diff(Lp)
        parent = np.full(n, -1, dtype=np.int64)
        has = counts > 0
        parent[has] = Li[Lp[:-1][has]]
        # fundamental supernodes: j joins j - 1 where j is its only child in the etree's
        # chain with the pattern of j - 1 less row j
        joins = np.zeros(n, dtype=bool)
        joins[1:] = (parent[:-1] == np.arange(1, n)) & (counts[1:] == counts[:-1] - 1)
        start = np.flatnonzero(~joins).astype(np.int64)
        start = np.append(start, n)
        nsn = start.size - 1
        width = np.diff(start)
        # the factorization's flops (QDLDL's count), and the share in wide supernodes
        col_flops = (counts + 1.0) ** 2
        self.flops = float(col_flops.sum())
        self.wide_share = float(col_flops[np.repeat(width >= WIDE, width)].sum()) / max(
            self.flops, 1.0)
        # QDLDL's factorization answers until the first update (and where a pivot fails);
        # where the supernodes would not pay, always
        self._qdldl = self._first = first
        self.fallbacks = 0  # (the updates QDLDL took)
        self.supernodal = self.flops >= MIN_FLOPS and self.wide_share >= MIN_WIDE_SHARE
        if not self.supernodal:
            return
        announce("supernodal sparse factorization", COMPILE_SECONDS, _factor, _solve)
        col_of = np.repeat(np.arange(nsn, dtype=np.int64), width)
        first_col = start[:-1]
        # each supernode's rows: its own columns, then its first column's rows below them
        rlen = counts[first_col] + 1
        rptr = np.concatenate([[0], np.cumsum(rlen)]).astype(np.int64)
        rows = np.empty(rptr[-1], dtype=np.int64)
        rows[rptr[col_of] + np.arange(n) - first_col[col_of]] = np.arange(n)
        nbel = rlen - width
        k = np.arange(nbel.sum()) - np.repeat(np.cumsum(nbel) - nbel, nbel)
        rows[np.repeat(rptr[:-1] + width, nbel) + k] = Li[
            np.repeat(Lp[first_col] + width - 1, nbel) + k]
        self._rptr, self._rows = rptr, rows
        self._vptr = np.concatenate([[0], np.cumsum(rlen * width)]).astype(np.int64)
        self._start, self._col_of, self._perm = start, col_of, perm
        # where each entry of A's upper triangle lands in the panels (row-major m x w)
        pinv = np.empty(n, dtype=np.int64)
        pinv[perm] = np.arange(n)
        col = np.repeat(np.arange(n), np.diff(K.indptr))
        a, b = pinv[K.indices], pinv[col]
        lo, hi = np.minimum(a, b), np.maximum(a, b)  # (row hi, column lo) of the lower part
        # (each panel's rows keyed by (supernode, row): one sorted array, searched at once)
        owner = np.repeat(np.arange(nsn, dtype=np.int64), rlen)
        pos = np.searchsorted(owner * n + self._rows, col_of[lo] * n + hi)
        sk = col_of[lo]
        dest = self._vptr[sk] + (pos - self._rptr[sk]) * width[sk] + (lo - first_col[sk])
        self._dest = dest
        self._vals = np.zeros(int(self._vptr[-1]))
        self._D = np.empty(n)

    def update(self, A, upper: bool = False) -> None:
        """Refactor numerically with A's new values (same pattern). At a zero or non-finite
        pivot, QDLDL refactors instead, and answers until the next update: what QDLDL did
        before this module (near the cones' boundary the CCP interior point's last systems
        can be singular to round-off; QDLDL's update goes on there without a word)."""
        K = _upper(A, upper)
        if not self.supernodal:
            self._qdldl.update(K, upper=True)
            return
        if K.nnz != self.nnz or not (np.array_equal(K.indptr, self._indptr)
                                     and np.array_equal(K.indices, self._indices)):
            raise ValueError("the matrix's pattern is not the one factored first")
        if _factor(self._vals, self._vptr, self._rows, self._rptr, self._start,
                   self._col_of, self._D, self._dest, np.asarray(K.data, dtype=float)):
            self._first = None
            return
        self.fallbacks += 1
        self._qdldl.update(K, upper=True)
        self._first = self._qdldl

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``A^-1 b``."""
        if self._first is not None:
            return self._first.solve(np.ascontiguousarray(b, dtype=float))
        return _solve(self._vals, self._vptr, self._rows, self._rptr, self._start, self._D,
                      self._perm, np.ascontiguousarray(b, dtype=float))
