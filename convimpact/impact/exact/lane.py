"""The public call's fast lane: one open-loop contact, validated, reduced and solved in compiled
code.

``resolve_impact(M, Jc, dq, e, mu, law=...)`` with one contact (``Jc`` a 2-D array), no loop
constraints, ``method="auto"`` or ``"fast"`` and no options spent most of its time around the
law rather than in it: checking M, factoring it, forming the contact space, mapping the
impulse back, building the diagnostics. This lane does all of it in one compiled call (numba,
:func:`convimpact.impact.exact.lane_kernel.lane_solve`):

1. M is checked (exactly symmetric, finite) and factored, ``M = L L^T``; then
   ``X = L^-1 Jc^T``, ``W = X^T X`` (eq. 29's Delassus block) and ``v- = Jc dq``, all finite;
2. the law's exact kernel gives the contact impulse ``pi`` from ``(W, v-, e, mu)`` -- the
   law's one compiled kernel, which ``method="fast"`` and
   :func:`~convimpact.impact.batch.resolve_impacts` run too;
3. ``dq+ = dq + L^-T X pi`` (eq. 29), ``v+ = v- + W pi`` and ``T+ - T- = pi.v- + 1/2 pi.W.pi``
   (eq. 58).

The lane takes only the plain case of :func:`~convimpact.impact.problem.build.build_problem`: real
float data of the right shapes, M exactly symmetric and safely positive definite (every
Cholesky pivot above ``PIVOT_RTOL`` times its diagonal entry), a normal that moves mass and
approaches, e in [0, 1] and mu >= 0 given as numbers, every figure finite and within
1e-100 .. 1e100. Anything else -- bad input, a separating or degenerate contact, an M the
full path symmetrizes, a kernel that refuses (a singular W that ``method="auto"`` hands to the
conic paths, a jam) -- returns None, and :func:`~convimpact.impact.resolve.resolve_impact`
takes its full path, which raises the same typed errors and writes the same notes as before.

The answer is ``method="fast"``'s to round-off (the factorization is not LAPACK's, so the
last bits of W may differ). Everything but the impulse, the velocities, the regime, the
energy loss and the effective mass is measured on first access: the diagnostics (residuals,
flags, condition numbers) from a problem built then on private copies of the data, as on the
full path; the law's ``notes`` and ``extras`` (e.g. the CCP normal-velocity lift, Stronge's
phases) from the law's kernel, run again then on the lane's W and v- (its entry on plain
floats, ``contact_kernel``).

Compilation, in two tiers so that a short session never waits for it:

* **tier 1** (first call): the reduction and the map back compiled
  (:func:`~.lane_kernel.reduce_one`, :func:`~.lane_kernel.finish_one`) around the law's
  kernel called from Python (only that law's kernel compiles);
* **tier 2**: the whole call compiled (:func:`~.lane_kernel.lane_solve`, with the law's
  kernel of the call's dimension only), taken at once when the cache on disk holds it, else
  after ``HOT_CALLS`` lane calls in the process -- a loop, not a handful of impacts -- or
  when :func:`compile_lane` is called.

Both tiers run the same kernels: their answers agree to round-off (the bench's ``coldstart``
section measures what each costs on a cold and a warm cache).
"""

from __future__ import annotations

import math
import time
from functools import cached_property
from types import MappingProxyType

import numpy as np

from ..diagnostics import assemble_result
from ...errors import ConvImpactError, as_real_array
from ..laws import LAW_CODES as _LAW_CODES
from .dispatch import _REGIME_NAMES as _REGIMES
from ..problem.build import _new, build_problem
from ..results import ImpactDiagnostics, ImpactResult

#: relative accuracy recorded for the answers (that of ``method="fast"``)
LANE_TOL = 1e-10
#: lane calls in a process after which the whole call is compiled (tier 2), when numba's disk
#: cache does not hold it already
HOT_CALLS = 200
_EMPTY = np.zeros(0)
_EMPTY.flags.writeable = False
_NO_EXTRAS = MappingProxyType({})
_F64 = np.dtype(np.float64)
#: tier 1: (reduce_one, finish_one) (None: not built yet; False: numba missing, lane off)
_COMPILED = None
#: tier 2: lane_solve (None: not built yet)
_SOLVE = None
_CALLS = 0
#: the tier-2 entries, per law (built once per process)
_ENTRIES: dict = {}
#: the law kernels' extras scratch of tier 2 (read lazily through the law's kernel instead)
_OUT = np.empty(32)
#: the compiled module (exact.lane_kernel), imported by _build
_S = None
COMPILE_SECONDS: dict[str, float] = {}


def _build():
    """Tier 1: compile (or load from numba's disk cache) reduce_one and finish_one; take tier 2
    at once when numba's disk cache already holds it."""
    global _COMPILED, _S
    t = time.perf_counter()
    try:
        from . import lane_kernel as single
    except ImportError:  # numba missing
        _COMPILED = False
        return _COMPILED
    _S = single
    from ...compiled import announce
    announce("single-contact lane (reduction and map back)", 3, single.reduce_one,
             single.finish_one)
    # compile for the one signature the lane uses (C-contiguous float64 arrays)
    M, J, dq = np.eye(2), np.array([[1.0, 0.0], [0.0, 1.0]]), np.array([0.0, -1.0])
    ws = np.empty(layout(2, 2)[-1])
    single.reduce_one(M, J, dq, ws)
    single.finish_one(ws, 2, 2, np.zeros(2), dq)
    _COMPILED = (single.reduce_one, single.finish_one)
    COMPILE_SECONDS["lane"] = time.perf_counter() - t
    if _cached(single.lane_solve):
        _build_solve()
    return _COMPILED


def _cached(dispatcher) -> bool:
    """Whether numba's disk cache holds machine code of ``dispatcher`` for this source."""
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except Exception:  # a numba without this layout: decide by the call count alone
        return False


def _build_solve():
    """Tier 2: compile (or load from numba's disk cache) lane_solve."""
    global _SOLVE
    t = time.perf_counter()
    from ...compiled import LawEntries, announce
    announce("single-contact lane's whole call", 4, _S.lane_solve)
    M, J, dq = np.eye(2), np.array([[1.0, 0.0], [0.0, 1.0]]), np.array([-1.0, 0.5])
    ws = np.empty(layout(2, 2)[-1])
    solve = _ENTRIES.get("lane_solve") or _ENTRIES.setdefault("lane_solve",
                                                               LawEntries(_S.lane_solve, 2))
    solve(0, 2, M, J, dq, 0.5, 0.3, 0.0, ws, _OUT)
    _SOLVE = solve
    COMPILE_SECONDS["lane_solve"] = time.perf_counter() - t
    return _SOLVE


def compile_lane() -> float:
    """Build both tiers of the lane now; the seconds it took (0.0 without numba)."""
    if _COMPILED is None:
        _build()
    if _COMPILED and _SOLVE is None:
        _build_solve()
    return COMPILE_SECONDS.get("lane", 0.0) + COMPILE_SECONDS.get("lane_solve", 0.0)


def layout(k: int, d: int) -> tuple[int, ...]:
    """Offsets into the lane's workspace (shared with its compiled side,
    :mod:`convimpact.impact.exact.lane_kernel`): L, X, W, v-, dq+, v+, [T+ - T-, max |pi|,
    max |v-|], copies of M, Jc, dq, pi and [status, regime code, effective mass, mu used]; the
    last entry is the size."""
    oX = k * k
    oW = oX + k * d
    ov = oW + d * d
    oo = ov + d
    oc = oo + k + d + 3
    op = oc + k * k + d * k + k
    return oX, oW, ov, oo, oc, op, op + 7


class _LaneAnswer:
    """What a lane answer measures on first access only: the law's kernel solution (notes,
    extras) when the compiled kernel gave the impulse, and the diagnostics -- the problem
    built from the private copies of the data in the workspace and the answer measured by
    :func:`~convimpact.impact.diagnostics.assemble_result`, as the full path measures it."""

    __slots__ = ("ws", "k", "d", "e", "mu", "mu_used", "pi", "regime", "law", "kernel", "sol",
                 "e_t")

    def __init__(self, ws, k, d, e, mu, mu_used, pi, regime, law, kernel, sol, e_t):
        self.ws, self.k, self.d, self.e, self.mu, self.mu_used = ws, k, d, e, mu, mu_used
        self.pi, self.regime, self.law, self.kernel, self.sol = pi, regime, law, kernel, sol
        self.e_t = e_t

    def mass(self) -> np.ndarray:
        k, oc = self.k, layout(self.k, self.d)[4]
        return self.ws[oc:oc + k * k].reshape(k, k)

    def delassus(self) -> np.ndarray:
        oW, d = layout(self.k, self.d)[1], self.d
        return self.ws[oW:oW + d * d].reshape(d, d)

    def solution(self):
        """The law's kernel on the lane's (W, v-), from Python: its notes and extras."""
        if self.sol is None:
            d = self.d
            oW = layout(self.k, d)[1]
            wv = self.ws[oW:oW + d * d + d].tolist()
            w = [wv[0:3], wv[3:6], wv[6:9]] if d == 3 else [wv[0:2], wv[2:4]]
            self.sol = self.kernel(w, wv[d * d:], d, self.e, self.mu_used, self.e_t or 0.0)
        return self.sol

    def __call__(self) -> dict:
        k, d = self.k, self.d
        oc = layout(k, d)[4]
        J = self.ws[oc + k * k:oc + k * k + d * k].reshape(d, k)
        dq = self.ws[oc + k * k + d * k:oc + k * k + d * k + k]
        P = build_problem(self.mass(), J, dq, self.e, self.mu, None, self.e_t)
        full = assemble_result(P, self.pi.reshape(1, d), [self.regime], self.law, "fast",
                               tol=LANE_TOL, extras=self.solution().extras)
        return full.diagnostics._values


class LaneDiagnostics(ImpactDiagnostics):
    """:class:`~convimpact.impact.results.ImpactDiagnostics` of a compiled lane answer: the
    law's ``notes`` and ``extras`` too are measured on first access (by the law's Python
    kernel on the same W and v-; see the module's docstring)."""

    @cached_property
    def notes(self) -> tuple[str, ...]:
        return tuple(self._source.solution().warnings)

    @cached_property
    def extras(self):
        extras = self._source.solution().extras
        return extras if extras else _NO_EXTRAS


def _number(x) -> float | None:
    """A plain real number as float, else None (the full path validates the rest)."""
    t = type(x)
    if t is float or t is np.float64:
        return float(x)
    if t is int:  # (an int beyond double precision: the full path refuses it)
        return float(x) if -(1 << 1000) < x < 1 << 1000 else None
    return None


def resolve_one(M, Jc, dq, e, mu, law: str, kernel, e_t=None) -> ImpactResult | None:
    """One contact through the lane, or None when the full path must take it.

    ``kernel`` is the law's single-contact kernel (its module's ``contact_kernel``); ``Jc`` is a
    2-D numpy array (checked by the caller).
    """
    global _CALLS
    lane = _COMPILED
    if not lane:
        if lane is False:
            return None
        lane = _build()
        if not lane:
            return None
    e_ = _number(e)
    mu_ = _number(mu)
    et_ = 0.0 if e_t is None else _number(e_t)
    if e_ is None or mu_ is None or et_ is None or not (
            0.0 <= e_ <= 1.0 and 0.0 <= mu_ < math.inf and -1.0 <= et_ <= 1.0):
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
    op = oo + k + d + 3 + k * k + d * k + k
    ws = np.empty(op + 7)  # layout(k, d)
    solve = _SOLVE
    if solve is None:
        _CALLS += 1
        if _CALLS >= HOT_CALLS:
            solve = _build_solve()
    if solve is not None:
        if not (Mf.flags.c_contiguous and Jf.flags.c_contiguous and qf.flags.c_contiguous):
            Mf, Jf, qf = (np.ascontiguousarray(a) for a in (Mf, Jf, qf))  # the entry's types
        code = solve(_LAW_CODES[law], d, Mf, Jf, qf, e_, mu_, et_, ws, _OUT)
        if code == 0:
            tail = ws[op + 3:op + 7].tolist()  # status, regime, effective mass, mu used
            regime = _REGIMES[int(tail[1])]
            effm = tail[2]
            answer = _LaneAnswer(ws, k, d, e_, mu_, tail[3], ws[op:op + d], regime, law,
                                 kernel, None, e_t)
            diag = _new(LaneDiagnostics, dict(
                effective_mass=None if effm != effm else effm, _source=answer,
                _delassus=answer.delassus, _mass=answer.mass, _loop=None))
            return _new(ImpactResult, dict(
                dq_plus=ws[oo:oo + k], impulse=answer.pi, loop_impulse=_EMPTY, regime=regime,
                energy_loss=-ws[oo + k + d], v_minus=ws[ov:oo], v_plus=ws[oo + k:oo + k + d],
                law=law, method="fast", diagnostics=diag))
        if code != _S.DEFERRED:
            return None
        mu_used = ws[op + 6]
    else:
        code = lane[0](Mf, Jf, qf, ws)
        if code > 0:
            return None
        mu_used = 0.0 if code else mu_
    # tier 1, or tier 2's items outside its range of scale: the law's kernel from Python on
    # the lane's W and v- (solve_contact's dispatch rescales)
    answer = _LaneAnswer(ws, k, d, e_, mu_, mu_used, None, None, law, kernel, None, e_t)
    try:
        sol = answer.solution()
    except ConvImpactError:
        return None  # the full path raises it, or (method="auto") tries the conic paths
    pi = answer.pi = sol.impulse
    answer.regime = sol.regime
    dT = lane[1](ws, k, d, pi, qf)
    if dT != dT:
        return None  # beyond plain arithmetic: the full path normalizes or raises
    extras = sol.extras
    diag = _new(ImpactDiagnostics, dict(
        effective_mass=sol.effective_mass, notes=sol.warnings,
        extras=extras if extras else _NO_EXTRAS, _source=answer, _delassus=answer.delassus,
        _mass=answer.mass, _loop=None))
    return _new(ImpactResult, dict(
        dq_plus=ws[oo:oo + k], impulse=pi, loop_impulse=_EMPTY, regime=sol.regime,
        energy_loss=-dT, v_minus=ws[ov:oo], v_plus=ws[oo + k:oo + k + d], law=law,
        method="fast",
        diagnostics=diag))
