"""The public call's lane for several open-loop contacts: laws ``ccp``, ``dissipative`` and
``coulomb`` by the exact interior solver, validated, reduced, solved and mapped back in one
compiled call.

``resolve_impact(M, [J1, ..., Jn], dq, e, mu, law=...)`` with ``law`` "ccp" or "dissipative"
and ``method="auto"`` or ``"interior"`` (or ``law="coulomb"`` and ``method="interior"``:
under auto Coulomb's law keeps the conic path), no loop constraints and no options goes to
``method="interior"`` (:mod:`convimpact.impact.several.interior`), whose kernel is one
compiled call; around it the full path spent as long again building the problem (LAPACK
Cholesky, the contact space, the checks) and the result. This lane does all of it in one
compiled call (:func:`convimpact.impact.several.lane_kernel.lane_solve`): M checked and
factored, ``X = L^-1 Jc^T``, ``W = X^T X``, ``v- = Jc dq``, the plain-case contact checks, the
law's program by :func:`~convimpact.impact.several.law_programs.solve_law` (the interior path's own
call) accepted on its certificate by the interior path's rule, Poisson's scaling for the
dissipative law, and ``dq+``, ``v+`` and ``T+ - T-``.

It takes only the plain case: e and mu given as numbers, or one float per contact (a list, or
a float64 array) in range, Jc a list of n >= 2 float64 (d, k) arrays of one shape, M a float64
(k, k) array exactly symmetric and safely positive definite (every Cholesky pivot above
1e-12 times its diagonal entry), dq a float64 (k,) array (M and dq copied to C order when
they are strided or read-only: the compiled call has one signature), every
contact's normal and tangents moving mass, some contact approaching, the figures within
1e-100 .. 1e100, and an answer that passes its certificate. Anything else returns None and
:func:`~convimpact.impact.resolve.resolve_impact` takes its full path, which raises the same
typed errors, writes the same notes and (``method="auto"``) hands an uncertified answer to
Clarabel as before.

The answer is the full path's to round-off (the factorization is not LAPACK's). The result
has the same fields and extras (regimes, ``normal_velocity_lift``, ``mu_times_slip``, the
solver's report; for Coulomb's law ``finished_by`` and ``complementarity_residual``; for the
dissipative law ``plastic_impulse``, ``plastic_energy_loss``,
``predicted_energy_loss``, ``plastic_normal_velocity_lift``); its diagnostics -- and the
dissipative law's notes, which need the problem -- are measured on first access, by
:func:`~convimpact.impact.diagnostics.assemble_result` on a problem built then from private
copies of the data, as on the full path.

The compiled call is built on the first lane call (numba, ``cache=True``; see
:data:`COMPILE_SECONDS`). Without numba the lane is off.
"""

from __future__ import annotations

import math
import time
from functools import cached_property
from types import MappingProxyType

import numpy as np

from ..diagnostics import assemble_result
from ..laws.dissipative import poisson_warnings
from ..problem.build import _new, build_problem
from ..results import ImpactDiagnostics, ImpactResult
from .interior import (COMPILED_MAX_ROWS, _MODES, _REGIME_OF, _STATUS, CERTIFIED_ACCURACY,
                       DEFAULT_OPTIONS, HANDOVER_TOL, law_extras, solver_report)

_F64 = np.dtype(np.float64)
_EMPTY = np.zeros(0)
_EMPTY.flags.writeable = False
#: the compiled lane_solve (None: not built yet; False: numba missing, lane off) and the
#: offsets of its workspace (several_lane_kernels.layout)
_SOLVE = None
_LAYOUT = None
COMPILE_SECONDS: dict[str, float] = {}
DEFAULT_TOL = DEFAULT_OPTIONS.tol


def _build():
    """Compile (or load from numba's disk cache) lane_solve."""
    global _SOLVE, _LAYOUT
    t = time.perf_counter()
    try:
        from . import lane_kernel as K
    except ImportError:  # numba missing
        _SOLVE = False
        return _SOLVE
    o = DEFAULT_OPTIONS
    if (K.CERTIFIED_ACCURACY, K.HANDOVER_TOL, K.DEFAULT_TOL, K.MAX_ITER, K.NEWTON_ITER) != (
            CERTIFIED_ACCURACY, HANDOVER_TOL, o.tol, o.max_iter, o.newton_iter):
        # the compiled call's frozen copies of the interior path's constants (numba's cache
        # keeps them with the machine code) are stale: the lane would not be that path's
        # answer, so it stays off
        _SOLVE = False
        return _SOLVE
    from ...compiled import announce
    announce("several-contact lane (interior point, Newton finish, certificates)", 12,
             K.lane_solve)
    J = np.zeros((2, 2, 3))
    J[0, 0, 2] = J[1, 0, 2] = 1.0
    J[0, 1, 0] = J[1, 1, 1] = 1.0
    M, dq = np.eye(3), np.array([0.1, 0.2, -1.0])
    # the three laws share one specialization (the law's mode read at run time)
    from ...compiled import LawEntries
    solve = LawEntries(K.lane_solve, 0)
    for mode in (0, 1, 2):
        ws = np.empty(K.layout(2, 2, 3)[-1])
        solve(mode, M, J, dq, np.full(2, 0.5), np.full(2, 0.3), ws)
    _SOLVE = solve
    _LAYOUT = K.layout
    COMPILE_SECONDS["several_lane"] = time.perf_counter() - t
    return _SOLVE


def compile_lane() -> float:
    """Build the lane now; the seconds it took (0.0 without numba)."""
    if _SOLVE is None:
        _build()
    return COMPILE_SECONDS.get("several_lane", 0.0)


def _coefficients(x, n: int, upper: float) -> np.ndarray | None:
    """e or mu: a number, or n floats (a list, or a float64 array of shape (n,)), in
    [0, upper] and finite (a private copy), else None."""
    t = type(x)
    if t is float or t is int or t is np.float64:
        x = float(x)
        if 0.0 <= x <= upper and x != math.inf:
            return np.array([x] * n)
        return None
    if t is np.ndarray and x.dtype is _F64 and x.shape == (n,):
        x = x.tolist()
        t = list
    if t is list and len(x) == n:
        for a in x:
            if type(a) is not float or not (0.0 <= a <= upper) or a == math.inf:
                return None
        return np.array(x)
    return None


class _Answer:
    """What a lane answer measures on first access: the problem built from the private copies
    of the data and the answer assembled by :func:`assemble_result`, as the full path does."""

    __slots__ = ("ws", "n", "d", "k", "e", "mu", "pi", "regimes", "law", "extras",
                 "predicted", "_full")

    def __init__(self, ws, n, d, k, e, mu, pi, regimes, law, extras, predicted):
        self.ws, self.n, self.d, self.k, self.e, self.mu = ws, n, d, k, e, mu
        self.pi, self.regimes, self.law, self.extras = pi, regimes, law, extras
        self.predicted, self._full = predicted, None

    def _offsets(self):
        return _LAYOUT(self.n, self.d, self.k)

    def mass(self) -> np.ndarray:
        k = self.k
        ocM = self._offsets()[8]
        return self.ws[ocM:ocM + k * k].reshape(k, k)

    def delassus(self) -> np.ndarray:
        N = self.n * self.d
        return self.ws[:N * N].reshape(N, N)

    def full(self) -> ImpactResult:
        """The result :func:`assemble_result` builds on the problem (cached)."""
        if self._full is None:
            n, d, k = self.n, self.d, self.k
            off = self._offsets()
            ocJ, ocq = off[9], off[10]
            J = self.ws[ocJ:ocJ + n * d * k].reshape(n, d, k)
            dq = self.ws[ocq:ocq + k]
            P = build_problem(self.mass(), J, dq, self.e.tolist(), self.mu.tolist())
            warnings = ()
            if self.law == "dissipative":
                warnings = poisson_warnings(P, self.predicted)
            self._full = assemble_result(P, self.pi, self.regimes, self.law, "interior",
                                         tol=CERTIFIED_ACCURACY, extras=self.extras,
                                         warnings=warnings)
        return self._full

    def __call__(self) -> dict:
        return self.full().diagnostics._values


class SeveralLaneDiagnostics(ImpactDiagnostics):
    """:class:`~convimpact.impact.results.ImpactDiagnostics` of a lane answer whose ``notes``
    (the dissipative law's Poisson statements, which need the problem) are measured on first
    access too."""

    @cached_property
    def notes(self) -> tuple[str, ...]:
        return self._source.full().diagnostics.notes


def resolve_several(M, Jc, dq, e, mu, law: str) -> ImpactResult | None:
    """Several contacts through the lane, or None when the full path must take them.

    ``Jc`` is a list (checked by the caller); ``law`` is "ccp", "dissipative" or (for
    ``method="interior"``) "coulomb".
    """
    solve = _SOLVE
    if not solve:
        if solve is False:
            return None
        solve = _build()
        if not solve:
            return None
    mode = _MODES.get(law)
    n = len(Jc)
    if mode is None or n * 3 > COMPILED_MAX_ROWS:  # large problems: the engine's own backend
        return None
    if n < 2 or type(M) is not np.ndarray or M.dtype is not _F64 or type(dq) is not np.ndarray \
            or dq.dtype is not _F64 or dq.ndim != 1:
        return None
    k = dq.shape[0]
    if M.shape != (k, k) or k == 0:
        return None
    J0 = Jc[0]
    if type(J0) is not np.ndarray:
        return None
    shape = J0.shape
    if len(shape) != 2 or shape[1] != k or not (shape[0] == 2 or shape[0] == 3):
        return None
    for j in Jc:
        if type(j) is not np.ndarray or j.dtype is not _F64 or j.shape != shape:
            return None
    ev = _coefficients(e, n, 1.0)
    if ev is None:
        return None
    mv = _coefficients(mu, n, 1.7976931348623157e308)
    if mv is None:
        return None
    # the compiled call's one signature: C-contiguous writeable arrays (others would compile
    # another specialization on first sight): copy the others
    if not (M.flags.c_contiguous and M.flags.writeable):
        M = np.array(M, order="C")
    if not (dq.flags.c_contiguous and dq.flags.writeable):
        dq = np.array(dq, order="C")
    d = shape[0]
    J = np.array(Jc)
    ov, odq, ovp, _, _, opl, oout, osc, _, _, _, size = _LAYOUT(n, d, k)
    ws = np.empty(size)
    if solve(mode, M, J, dq, ev, mv, ws) != 0:
        return None
    per = ws[oout:osc + 8].tolist()
    sc = per[4 * n:]
    status = int(sc[0])
    report = solver_report(_STATUS.get(status, str(status)), int(sc[1]), int(sc[2]), sc[3],
                           DEFAULT_TOL)
    regimes = tuple([_REGIME_OF[c] for c in per[:n]])
    predicted = sc[7] if law == "dissipative" else None
    extras = law_extras(law, report, lift=per[n:2 * n], mu_slip=per[2 * n:3 * n],
                        plastic=ws[opl:oout].reshape(n, d).tolist() if predicted is not None
                        else None, plastic_energy_loss=sc[6], predicted=predicted,
                        plastic_lift=per[3 * n:4 * n])
    vpc = ws[ovp:opl].reshape(3, n, d)  # v+, pi and the private copy of pi
    answer = _Answer(ws, n, d, k, ev, mv, vpc[2], regimes, law, extras, predicted)
    values = dict(effective_mass=None, extras=MappingProxyType(extras), _source=answer,
                  _delassus=answer.delassus, _mass=answer.mass, _loop=None)
    if law != "dissipative":  # no notes: the plain case has none, and the law states none
        values["notes"] = ()
        diag = _new(ImpactDiagnostics, values)
    else:
        diag = _new(SeveralLaneDiagnostics, values)
    return _new(ImpactResult, dict(
        dq_plus=ws[odq:ovp], impulse=vpc[1], loop_impulse=_EMPTY, regime=regimes,
        energy_loss=-sc[5], v_minus=ws[ov:odq].reshape(n, d), v_plus=vpc[0], law=law,
        method="interior", diagnostics=diag))
