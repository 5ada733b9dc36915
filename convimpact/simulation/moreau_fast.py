"""The fast path of a Moreau–Jean step on the contact engine: two compiled calls per step.

A step of :func:`convimpact.simulation.moreau.simulate_moreau` through
:class:`.moreau_loop.ModelPredictor` and :class:`.moreau_engine.EngineSolver` runs, on its
general path, about twenty lines of Python around five compiled kernels (the predictor, the
layout check, the small islands' solve, the impulses' application, the positions' update);
at a few contacts that Python costs more than the kernels. :class:`FastStep` runs the same
step as two compiled calls, :func:`.moreau_step_kernels.predict_model` and
:func:`solve_apply_advance` (the layout check, :func:`.moreau_kernels.solve_small_islands`,
the dissipative law's scaling, :func:`.moreau_kernels.apply_impulses` and
:func:`.moreau_step_kernels.advance` fused), with the same kernels in the same order on the
same buffers: the answers are those of the general path, bit for bit (the dissipative law's
``J_n v_free`` is summed in a loop rather than by BLAS: equal to round-off).

It applies while the step keeps the previous step's island layout (same active contacts,
same moved columns, same coordinate groups, only small islands) and every island is
certified by the compiled solve; any other step (the first, a change of the active set, a
regroup of M, an island the compiled solve leaves above ``tol``, a non-finite state, a loop
mechanism) is handed back to the general path, which takes it from the prediction in the buffers
(from scratch after a regroup of M or a failed evaluation: the compiled predictor is a pure
function of the state into its buffers) and reaches the same answer or raises its typed
error. Steps without active contacts
(free flight) are finished here too. The solver's counters count the fast steps as the
general path does; ``solve_time`` and the loop's ``impact_time`` include the application of
the impulses and the update of the positions (about a tenth of a microsecond) on these steps.
"""

from __future__ import annotations

import time as _time

from ..compiled import jit as _jit
from .moreau_kernels import apply_impulses, same_pattern_on, solve_small_islands
from .moreau_step_kernels import advance

#: :func:`solve_apply_advance`'s outcomes
DONE, LAYOUT, NOT_CERTIFIED, NON_FINITE = 0, 1, 2, 3
#: :meth:`FastStep.step`'s outcomes
REDO, PREDICTED, FINISHED = 0, 1, 2


@_jit
def solve_apply_advance(Ja_all, b_all, vn_all, active_all, na, mu_all, G, gflat, gsize, goff,
                        key_active, key_moves, icon, icoff, icol, icoloff, d, coulomb,
                        poisson, tol, max_iter, newton_iter, last, use_start, r_all, res,
                        used, b2_all, factor_all, v_free, v_new, gen, rest_velocity, qm,
                        h_theta, q_out, v_out, jcol, joff):
    """A step's contact problem on its cached layout, ``v_{k+1}`` and ``q_{k+1}``.

    ``Ja_all``, ``b_all``, ``vn_all``, ``active_all``, ``r_all`` are the active rows' buffers
    (the first ``na`` used); ``key_active``, ``key_moves`` and ``icon`` .. ``icoloff`` the
    cached :class:`.moreau_engine.Layout`. Returns ``(outcome, iterations, warm starts kept,
    contacts hit)``: :data:`LAYOUT` when the step's pattern is not the layout's (nothing
    written), :data:`NOT_CERTIFIED` when an island's residual is above ``tol`` (``last``
    untouched), :data:`NON_FINITE` for a non-finite state, else :data:`DONE` with ``r``,
    ``v_new``, ``gen``, ``last`` and ``q_out``, ``v_out`` written. ``poisson``: the
    dissipative law (the plastic problem, ``b_n = J_n v_free``, each impulse times
    ``1 + e_eff = b_n / J_n v_free`` where ``J_n v_free < 0``; ``b2_all``, ``factor_all``
    scratch). ``jcol``, ``joff``: the supports of the contacts' rows
    (:attr:`.moreau_loop.Step.support`).
    """
    Ja = Ja_all[:na]
    active = active_all[:na]
    if not same_pattern_on(Ja, active, key_active, key_moves, jcol, joff):
        return LAYOUT, 0, 0, 0
    r = r_all[:na]
    b = b_all[:na]
    k = v_free.shape[0]
    if poisson:
        b = b2_all[:na]
        for c in range(na):
            vnf = 0.0
            for a in range(k):
                vnf += Ja[c, 0, a] * v_free[a]
            factor_all[c] = b_all[c, 0] / vnf if vnf < 0.0 else 1.0
            for rr in range(d):
                b[c, rr] = b_all[c, rr]
            b[c, 0] = vnf
    its, kept, bad = solve_small_islands(Ja, b, mu_all, active, G, icon, icoff, icol, icoloff,
                                         d, coulomb, tol, max_iter, newton_iter, last,
                                         use_start, r, res, used)
    if bad:
        return NOT_CERTIFIED, its, kept, 0
    if poisson:
        for c in range(na):
            for rr in range(d):
                r[c, rr] *= factor_all[c]
    hits = apply_impulses(Ja, r, G, gflat, gsize, goff, v_free, v_new, gen, last, active,
                          vn_all[:na], rest_velocity)
    if not advance(qm, v_new, h_theta, q_out, v_out):
        return NON_FINITE, its, kept, hits
    return DONE, its, kept, hits


class FastStep:
    """The fast path (module docstring) of a run on a :class:`.moreau_loop.ModelPredictor`
    and an :class:`.moreau_engine.EngineSolver` without loops."""

    @staticmethod
    def applies(pred, solver) -> bool:
        # (the predictor and the solver say so themselves, :attr:`.moreau_loop.ModelPredictor.
        # FAST` and :attr:`.moreau_engine.EngineSolver.FAST`: this module imports neither)
        return (bool(getattr(type(pred), "FAST", False))
                and bool(getattr(type(solver), "FAST", False)) and solver.m == 0)

    def __init__(self, pred, solver):
        self.pred, self.solver = pred, solver
        self._layout = None   # the solver's layout the fast arguments below were built for
        self._groups = None
        self._args = None
        self._b2 = self._factor = None  # the dissipative law's scratch
        self.steps = 0        # steps finished here (for the tests and the bench)
        self.na = 0           # active contacts of the last prediction

    def _prepare(self):
        """The solve's arguments for the solver's current layout, or None when the layout
        does not admit the fast path (none yet, other groups, a large island)."""
        s, p, lay = self.solver, self.pred, self.solver.layout
        c = p.cache
        self._layout, self._groups = lay, c.groups
        if (lay is None or lay.groups is not c.groups or lay.large or lay.icoff.size <= 1
                or s.last is None):
            self._args = None
            return
        if self._b2 is None:
            self._b2, self._factor = p.buf.b.copy(), p.buf.vn_k.copy()
        self._args = (lay, lay.icoff.size - 1)

    def step(self, index: int, t: float, q, v, hk: float, sigma, q_out, v_out,
             stats: dict) -> int:
        """Run step ``index`` from ``(q, v)`` at t into ``q_out``, ``v_out``: :data:`FINISHED`;
        else the general path takes the step, from the prediction in the predictor's
        buffers (:data:`PREDICTED`, ``self.na`` active contacts; the solver's state
        untouched) or from scratch (:data:`REDO`)."""
        s, p = self.solver, self.pred
        c = p.cache
        buf = p.buf
        th = p.theta
        status, na = p.predict_into(q, v, hk)
        if status:
            return REDO
        self.na = na
        if na == 0:
            if not advance(p.qm, p.vfree, hk * th, q_out, v_out):
                return PREDICTED
            s.idle()
            self.steps += 1
            return FINISHED
        if s.layout is not self._layout or c.groups is not self._groups:
            self._prepare()
        if self._args is None:
            return PREDICTED
        lay, n_small = self._args
        t0 = _time.perf_counter()
        outcome, its, kept, hits = solve_apply_advance(
            buf.Ja, buf.b, buf.vn_k, buf.active, na, s.mu, c.Minv, c.gflat, c.gsize, c.goff,
            lay.active, lay.moves, lay.icon, lay.icoff, lay.icol, lay.icoloff,
            buf.Ja.shape[1], s.coulomb, s.poisson, s.tol, s.max_iter, s.newton_iter, s.last,
            s.warm_start, s.r, lay.res, lay.used, self._b2, self._factor, p.vfree, s.v_new,
            s.gen, s.rest_velocity, p.qm, hk * th, q_out, v_out, *p.support)
        spent = _time.perf_counter() - t0
        if outcome:
            return PREDICTED
        cnt = s.counters
        cnt.iterations += its
        cnt.warm_started += kept
        cnt.problems += n_small
        cnt.solve_time += spent
        stats["impact_time"] += spent
        stats["contact_steps"] += 1
        if na > stats["max_active"]:
            stats["max_active"] = na
        if hits:
            s._event(p.step_view(index, t, v, hk, na, sigma), s.r[:na])
        self.steps += 1
        return FINISHED
