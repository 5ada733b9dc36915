"""The public call's fast lane: one open-loop contact, validated and reduced in compiled code.

``resolve_impact(M, Jc, dq, e, mu, law=...)`` with one contact (``Jc`` a 2-D array), no loop
constraints, ``method="auto"`` or ``"fast"`` and no options spent most of its time around the
law rather than in it: checking M, factoring it, forming the contact space, mapping the
impulse back, building the diagnostics. This lane does that work in two small compiled calls
(numba) around the law's exact kernel -- the very kernel of ``method="fast"``
(:func:`convimpact.impact.fast.dispatch` on plain floats):

1. :func:`reduce_one` checks M (exactly symmetric, finite) and factors it, ``M = L L^T``; then
   ``X = L^-1 Jc^T``, ``W = X^T X`` (eq. 29's Delassus block) and ``v- = Jc dq``, all finite.
2. The law's kernel gives the contact impulse ``pi`` from ``(W, v-, e, mu)``.
3. :func:`finish_one` maps it back: ``dq+ = dq + L^-T X pi`` (eq. 29), ``v+ = v- + W pi`` and
   ``T+ - T- = pi.v- + 1/2 pi.W.pi`` (eq. 58).

The lane takes only the plain case of :func:`~convimpact.impact.problem.build_problem`: real
float data of the right shapes, M exactly symmetric and safely positive definite (every
Cholesky pivot above ``PIVOT_RTOL`` times its diagonal entry), a normal that moves mass and
approaches, e in [0, 1] and mu >= 0 given as numbers, every figure finite and within
1e-100 .. 1e100. Anything else -- bad input, a separating or degenerate contact, an M the
full path symmetrizes, a kernel that raises (a singular W that ``method="auto"`` hands to the
conic paths, a jam) -- returns None, and :func:`~convimpact.impact.resolve.resolve_impact`
takes its full path, which raises the same typed errors and writes the same notes as before.

The answer is ``method="fast"``'s to round-off (the factorization is not LAPACK's, so the
last bits of W may differ). The diagnostics -- residuals, flags, condition numbers -- are
measured on first access, as on the full path, from a problem built then on private copies
of the data.

The compiled functions are built on the first call (about 1-3 s, then cached on disk by
numba: later processes load them in milliseconds); :func:`compile_lane` builds them ahead
of time and returns the seconds it took. Without numba the lane is off and every call takes
the full path.
"""

from __future__ import annotations

import math
import time
from types import MappingProxyType

import numpy as np

from .diagnostics import assemble_result
from .errors import ConvImpactError, as_real_array
from .problem import IMMOBILE_RTOL, SAFE_SCALE, TINY_NORMAL, _new, build_problem
from .results import ImpactDiagnostics, ImpactResult

#: a Cholesky pivot at or below this fraction of its diagonal entry sends M to the full
#: path (whose LAPACK factorization decides positive definiteness at the edge)
PIVOT_RTOL = 1e-12
#: figures the lane computes in plain arithmetic (outside, the full path normalizes them)
PLAIN = (1e-100, 1e100)
#: relative accuracy recorded for the answers (that of ``method="fast"``)
LANE_TOL = 1e-10

_EMPTY = np.zeros(0)
_EMPTY.flags.writeable = False
_NO_EXTRAS = MappingProxyType({})
_F64 = np.dtype(np.float64)
#: the compiled functions (None: not built yet; False: numba missing, the lane is off)
_COMPILED = None
COMPILE_SECONDS: dict[str, float] = {}


def _build():
    """Compile (or load from numba's disk cache) :func:`reduce_one` and :func:`finish_one`."""
    global _COMPILED
    t = time.perf_counter()
    try:
        import numba
    except ImportError:
        _COMPILED = False
        return _COMPILED
    jit = numba.njit(cache=True, nogil=True)
    _COMPILED = (jit(reduce_one), jit(finish_one))
    # compile for the one signature the lane uses (C-contiguous float64 arrays)
    M, J, dq = np.eye(2), np.array([[1.0, 0.0], [0.0, 1.0]]), np.array([0.0, -1.0])
    ws = np.empty(layout(2, 2)[-1])
    _COMPILED[0](M, J, dq, ws)
    _COMPILED[1](ws, 2, 2, np.zeros(2), dq)
    COMPILE_SECONDS["lane"] = time.perf_counter() - t
    return _COMPILED


def compile_lane() -> float:
    """Build the lane's compiled functions now; the seconds it took (0.0 without numba)."""
    if _COMPILED is None:
        _build()
    return COMPILE_SECONDS.get("lane", 0.0)


def reduce_one(M, J, dq, ws):  # compiled by _build
    """Check and reduce one contact into ``ws`` (layout: :func:`layout`). Returns 0 when the
    data are the plain case, else a code > 0: the full path must take them."""
    k = M.shape[0]
    d = J.shape[0]
    oX = k * k
    oW = oX + k * d
    ov = oW + d * d
    oc = ov + d + k + d + 3
    # private copies of the data (the diagnostics measure them on first access)
    for i in range(k):
        for j in range(k):
            ws[oc + i * k + j] = M[i, j]
        ws[oc + k * k + d * k + i] = dq[i]
    for c in range(d):
        for i in range(k):
            ws[oc + k * k + c * k + i] = J[c, i]
    # M exactly symmetric and finite (the full path symmetrizes or rejects the others)
    for i in range(k):
        if not math.isfinite(M[i, i]):
            return 1
        for j in range(i):
            if M[i, j] != M[j, i] or not math.isfinite(M[i, j]):
                return 1
    # Cholesky M = L L^T, every pivot safely positive
    for i in range(k * k):
        ws[i] = 0.0
    for j in range(k):
        s = M[j, j]
        for p in range(j):
            s -= ws[j * k + p] * ws[j * k + p]
        if not s > PIVOT_RTOL * M[j, j]:
            return 2
        r = math.sqrt(s)
        ws[j * k + j] = r
        for i in range(j + 1, k):
            s = M[i, j]
            for p in range(j):
                s -= ws[i * k + p] * ws[j * k + p]
            ws[i * k + j] = s / r
    # X = L^-1 J^T (forward substitution, column by column), W = X^T X, v = J dq
    for c in range(d):
        for i in range(k):
            s = J[c, i]
            for p in range(i):
                s -= ws[i * k + p] * ws[oX + p * d + c]
            ws[oX + i * d + c] = s / ws[i * k + i]
    total = 0.0
    for a in range(d):
        for b in range(a + 1):
            s = 0.0
            for i in range(k):
                s += ws[oX + i * d + a] * ws[oX + i * d + b]
            ws[oW + a * d + b] = s
            ws[oW + b * d + a] = s
            total += s
        s = 0.0
        for i in range(k):
            if not math.isfinite(J[a, i]):
                return 3
            s += J[a, i] * dq[i]
        ws[ov + a] = s
        total += s
    if not math.isfinite(total):
        return 3
    vs = 0.0
    tr = 0.0
    for a in range(d):
        vs = max(vs, abs(ws[ov + a]))
        tr += ws[oW + a * d + a]
    if not (ws[oW] >= TINY_NORMAL and ws[ov] < 0.0):
        return 4  # a degenerate normal, or a contact that does not approach
    if not (SAFE_SCALE[0] <= tr <= SAFE_SCALE[1] and SAFE_SCALE[0] <= vs <= SAFE_SCALE[1]):
        return 5  # far from unit scale: the full path rescales
    wt = ws[oW + d + 1]
    if d == 3 and ws[oW + 8] > wt:
        wt = ws[oW + 8]
    if wt <= IMMOBILE_RTOL * ws[oW]:
        return -1  # tangents that move no mass: plain, but frictionless (as build_problem)
    return 0


def finish_one(ws, k, d, pi, dq):  # compiled by _build
    """Map the impulse back into ``ws``: dq+ (k), v+ (d), T+ - T-, max |pi|, max |v-|.
    Returns T+ - T-, or NaN when a figure is not finite or |pi| is outside 1e-100 .. 1e100
    (the full path normalizes or raises)."""
    oX = k * k
    oW = oX + k * d
    ov = oW + d * d
    oo = ov + d
    # y = X pi, then dq+ = dq + L^-T y (back substitution)
    for i in range(k):
        s = 0.0
        for c in range(d):
            s += ws[oX + i * d + c] * pi[c]
        ws[oo + i] = s
    for i in range(k - 1, -1, -1):
        s = ws[oo + i]
        for p in range(i + 1, k):
            s -= ws[p * k + i] * ws[oo + p]
        ws[oo + i] = s / ws[i * k + i]
    for i in range(k):
        ws[oo + i] += dq[i]
    dT = 0.0
    ps = 0.0
    vs = 0.0
    for a in range(d):
        s = ws[ov + a]
        q = 0.0
        for b in range(d):
            q += ws[oW + a * d + b] * pi[b]
        ws[oo + k + a] = s + q
        dT += pi[a] * s + 0.5 * pi[a] * q
        ps = max(ps, abs(pi[a]))
        vs = max(vs, abs(s))
    ws[oo + k + d] = dT
    ws[oo + k + d + 1] = ps
    ws[oo + k + d + 2] = vs
    total = dT
    for i in range(k + d):
        total += ws[oo + i]
    if not math.isfinite(total) or not (ps == 0.0 or PLAIN[0] <= ps <= PLAIN[1]):
        return math.nan
    return dT


def layout(k: int, d: int) -> tuple[int, ...]:
    """Offsets into the lane's workspace: L (k*k, row-major lower), X (k*d), W (d*d), v- (d),
    dq+ (k), v+ (d), [T+ - T-, max |pi|, max |v-|], then copies of M (k*k), Jc (d*k), dq (k);
    the last entry is the size."""
    oX = k * k
    oW = oX + k * d
    ov = oW + d * d
    oo = ov + d
    oc = oo + k + d + 3
    return oX, oW, ov, oo, oc, oc + k * k + d * k + k


class _LaneAnswer:
    """The diagnostics' measurement of a lane answer: on first access only, the problem is
    built from the private copies of the data in the workspace and the answer measured by
    :func:`~convimpact.impact.diagnostics.assemble_result`, as the full path measures it."""

    __slots__ = ("ws", "k", "d", "e", "mu", "pi", "regime", "law", "extras")

    def __init__(self, ws, k, d, e, mu, pi, regime, law, extras):
        self.ws, self.k, self.d, self.e, self.mu = ws, k, d, e, mu
        self.pi, self.regime, self.law, self.extras = pi, regime, law, extras

    def mass(self) -> np.ndarray:
        k, oc = self.k, layout(self.k, self.d)[4]
        return self.ws[oc:oc + k * k].reshape(k, k)

    def delassus(self) -> np.ndarray:
        oW, d = layout(self.k, self.d)[1], self.d
        return self.ws[oW:oW + d * d].reshape(d, d)

    def __call__(self) -> dict:
        k, d = self.k, self.d
        oc = layout(k, d)[4]
        J = self.ws[oc + k * k:oc + k * k + d * k].reshape(d, k)
        dq = self.ws[oc + k * k + d * k:oc + k * k + d * k + k]
        P = build_problem(self.mass(), J, dq, self.e, self.mu)
        full = assemble_result(P, self.pi.reshape(1, d), [self.regime], self.law, "fast",
                               tol=LANE_TOL, extras=self.extras)
        return full.diagnostics._values


def _number(x) -> float | None:
    """A plain real number as float, else None (the full path validates the rest)."""
    t = type(x)
    if t is float or t is np.float64:
        return float(x)
    if t is int:
        return float(x)
    return None


def resolve_one(M, Jc, dq, e, mu, law: str, kernel) -> ImpactResult | None:
    """One contact through the lane, or None when the full path must take it.

    ``kernel`` is the law's single-contact kernel (``fast._KERNELS[law]``); ``Jc`` is a
    2-D numpy array (checked by the caller).
    """
    lane = _COMPILED
    if not lane:
        if lane is False:
            return None
        lane = _build()
        if not lane:
            return None
    e_ = _number(e)
    mu_ = _number(mu)
    if e_ is None or mu_ is None or not (0.0 <= e_ <= 1.0 and 0.0 <= mu_ < math.inf):
        return None
    try:
        Mf = M if type(M) is np.ndarray and M.dtype is _F64 else as_real_array("M", M)
        Jf = Jc if Jc.dtype is _F64 else as_real_array("Jc", Jc)
        qf = dq if type(dq) is np.ndarray and dq.dtype is _F64 else as_real_array("dq", dq)
    except ConvImpactError:
        return None
    if Mf.ndim != 2 or qf.ndim != 1:
        return None
    k = qf.shape[0]
    d = Jf.shape[0]
    if Mf.shape != (k, k) or Jf.shape[1] != k or not (d == 2 or d == 3) or k == 0:
        return None
    oW = k * k + k * d
    ov = oW + d * d
    oo = ov + d
    ws = np.empty(oo + k + d + 3 + k * k + d * k + k)  # layout(k, d)
    code = lane[0](Mf, Jf, qf, ws)
    if code > 0:
        return None
    wv = ws[oW:oo].tolist()  # W (row-major), then v-
    w = [wv[0:3], wv[3:6], wv[6:9]] if d == 3 else [wv[0:2], wv[2:4]]
    try:
        sol = kernel(w, wv[d * d:], d, e_, 0.0 if code else mu_)
    except ConvImpactError:
        return None  # the full path raises it, or (method="auto") tries the conic paths
    pi = sol.impulse
    dT = lane[1](ws, k, d, pi, qf)
    if dT != dT:
        return None  # beyond plain arithmetic: the full path normalizes or raises
    extras = sol.extras
    answer = _LaneAnswer(ws, k, d, e_, mu_, pi, sol.regime, law, extras)
    diag = _new(ImpactDiagnostics, dict(
        effective_mass=sol.effective_mass, notes=sol.warnings,
        extras=extras if extras else _NO_EXTRAS, _source=answer, _delassus=answer.delassus,
        _mass=answer.mass, _loop=None))
    return _new(ImpactResult, dict(
        dq_plus=ws[oo:oo + k], impulse=pi, loop_impulse=_EMPTY, regime=sol.regime,
        energy_loss=-dT, v_minus=ws[ov:oo], v_plus=ws[oo + k:oo + k + d], law=law,
        method="fast",
        diagnostics=diag))
