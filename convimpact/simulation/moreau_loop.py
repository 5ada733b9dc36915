"""The Moreau–Jean step loop of :func:`convimpact.simulation.moreau.simulate_moreau`: one loop
for every law, over a per-step contact solver.

Per step (the scheme of :mod:`.moreau`): a *predictor* gives the intermediate configuration
``q_m``, M and the inverse mass G there, the smooth forces and the free velocity ``v_free``
(with the loop impulse of the smooth part), and the active contacts by gap prediction with
their rows ``J`` and ``b = J v_free`` plus Newton's restitution (a :class:`Step`); the
*solver* turns the step's contact problem into ``v_{k+1}`` and the loop impulse:

* :class:`.moreau_engine.EngineSolver` (laws ``ccp``, ``coulomb`` and ``dissipative`` under
  method "auto" or
  "interior"): the contact engine island by island, warm-started, every answer certified;
* :class:`.moreau_impact.ImpactSolver` (every other law and method): one call of
  :func:`convimpact.resolve_impact` per island of the step's active contacts.

Then the predictor moves the positions, ``q_{k+1} = q_m + h theta v_{k+1}`` (loops projected
back), and the :class:`Recorder` keeps the raw state; momenta, energies, loop drifts and the
largest penetration are computed from the stored states once, at the end of the run.

On a :class:`ModelPredictor` with an :class:`.moreau_engine.EngineSolver` (no loops), the
steps that keep the previous step's island layout take the fast path of
:mod:`.moreau_fast` (two compiled calls per step, the same answers bit for bit).

Two predictors compute the same quantities: :class:`ModelPredictor`, one compiled call per
step (:func:`.moreau_step_kernels.predict_model`) for the models of :mod:`convimpact.model`
without loops or applied forces, and :class:`ProtocolPredictor` for any mechanism (the
Mechanism protocol, loops, applied forces).
"""

from __future__ import annotations

import time as _time
from typing import Any

import numpy as np

from ..contacts.threads import one_blas_thread
from ..errors import SimulationError
from .moreau_engine import Evaluator, GroupCache, InverseMass, inverse_mass, regroup
from .moreau_fast import FINISHED, PREDICTED, REDO, FastStep
from .moreau_step_kernels import (
    EVAL_SHIFT,
    GAP_ROUNDOFF,
    NOT_DEFINITE,
    NOT_FINITE,
    REGROUP,
    advance,
    contact_rows_into,
    dense_support,
    model_series,
    model_support,
    predict_model,
)
from .projection import project_positions, project_velocities


def end_of_step(mech, qm, v_new, h_theta: float, M, loop_rows, projection_tol: float,
                t_end: float):
    """``(q_{k+1}, v_{k+1}, projected)``: ``q_{k+1} = q_m + h theta v_{k+1}``, for closed
    loops projected back onto Psi = 0 (M-weighted, when the drift exceeds
    ``projection_tol``) and v onto C(q_{k+1}) v = 0; SimulationError for a non-finite state."""
    q_new = qm + h_theta * v_new
    projected = False
    if int(mech.n_loop_constraints):
        drift = float(np.max(np.abs(mech.loop_residual(q_new))))
        if drift > projection_tol:
            q_new, _, _ = project_positions(mech.loop_residual, loop_rows, M, q_new,
                                            0.1 * projection_tol)
            projected = True
        v_new = project_velocities(np.asarray(mech.mass_matrix(q_new), float),
                                   loop_rows(q_new), v_new)
    if not (np.all(np.isfinite(q_new)) and np.all(np.isfinite(v_new))):
        raise SimulationError(f"the state became non-finite at t = {t_end:.9g}; reduce h")
    return q_new, v_new, projected


class Step:
    """One step's prediction (arrays may be views of buffers reused by the next step: copy
    what you keep). ``index``, ``tm`` (t_m), ``hk`` (the step), ``qm``, ``v`` (v_k), ``M``
    and ``inv`` (:class:`.moreau_engine.InverseMass`) at q_m, ``blocks`` (the
    :class:`.moreau_engine.GroupCache` G is block diagonal over), ``C`` (loop rows at q_m),
    ``v_free``, ``sigma`` (the loop impulse after the smooth part), and the active contacts:
    ``active`` (indices), ``Ja`` (na, d, k), ``b`` (na, d), ``vn_k`` (na,); ``support``:
    ``(jcol, joff)``, contact c's row of J is zero outside the columns
    ``jcol[joff[c]:joff[c + 1]]`` (:mod:`.moreau_step_kernels`)."""

    __slots__ = ("index", "tm", "hk", "qm", "v", "M", "inv", "blocks", "C", "v_free",
                 "sigma", "active", "Ja", "b", "vn_k", "support")


class _Buffers:
    """The active rows' buffers of a mechanism with nc contacts of dimension d."""

    def __init__(self, mech, nc: int, d: int, k: int):
        self.e = np.array([float(mech.contact_parameters(c)[0])
                           for c in mech.contact_names])
        self.active = np.zeros(nc, dtype=np.int64)
        self.Ja = np.zeros((nc, d, k))
        self.b = np.zeros((nc, d))
        self.vn_k = np.zeros(nc)
        #: per row of Ja, the contact whose columns it holds (-1: none)
        self.held = np.full(nc, -1, dtype=np.int64)
        self._views: dict = {}

    def fill(self, st: Step, na: int) -> None:
        views = self._views.get(na)
        if views is None:
            views = self._views[na] = (self.active[:na], self.Ja[:na], self.b[:na],
                                       self.vn_k[:na])
        st.active, st.Ja, st.b, st.vn_k = views


class ModelPredictor:
    """The predictor on a model without loops or applied forces: one compiled call per step
    (:func:`.moreau_step_kernels.predict_model`) on the model's work buffer, on the supports
    of M and of the contacts' Jacobians (:func:`.moreau_step_kernels.model_support`),
    certified on the model's evaluation at every regroup (:meth:`certify`)."""

    #: its steps may be taken by :class:`.moreau_fast.FastStep` (with an EngineSolver's)
    FAST = True

    @staticmethod
    def applies(mech) -> bool:
        from ..model.mechanism import ModelMechanism

        return (type(mech) is ModelMechanism and not int(mech.n_loop_constraints)
                and mech.model.applied_forces is None)

    def __init__(self, mech, theta: float, gap_tol: float, rest_velocity: float):
        self.mech, self.data = mech, mech.data
        k, nc, d = int(mech.n_coordinates), len(mech.contact_names), int(mech.model.dim)
        self.theta, self.gap_tol, self.rest_velocity = theta, gap_tol, rest_velocity
        self.nfev_per_step = 2 if theta < 1.0 else 1
        data = self.data
        self.views = (data.work, data.M, data.gap, data.contact_jacobian[:, :d], data.bias)
        self.cache = GroupCache()
        self.cache.mask = np.zeros(k * k, dtype=np.bool_)
        self.cache.gflat = self.cache.gsize = np.zeros(0, np.int64)
        self.cache.goff = np.zeros(1, np.int64)
        self.cache.Minv = np.zeros((k, k))
        self.inv: InverseMass | None = None
        self.qm, self.vtmp, self.vfree = np.zeros(k), np.zeros(k), np.zeros(k)
        self.buf = _Buffers(mech, nc, d, k)
        self.C = np.zeros((0, k))
        self.st = Step()
        self.msup, jcol, joff = model_support(data.work)
        self.support = (jcol, joff)
        #: the supports held on every regroup so far (False: the dense ones, for good)
        self.structural = True
        self._off = None

    def certify(self) -> bool:
        """Whether M and the contacts' Jacobians, as the model evaluated them last, are
        zero outside the supports; if not, the dense supports from now on (False)."""
        _, Mv, _, Jv, _ = self.views
        k, nc = Mv.shape[0], Jv.shape[0]
        if self._off is None:  # the entries outside the supports, once
            jcol, joff = self.support
            moff = np.ones(k * k, dtype=np.bool_)
            moff[self.msup] = False
            joff_mask = np.ones((nc, k), dtype=np.bool_)
            joff_mask[np.repeat(np.arange(nc), np.diff(joff)), jcol] = False
            self._off = (moff, joff_mask)
        moff, joff_mask = self._off
        ok = not (np.any(Mv.reshape(-1)[moff]) or np.any(np.any(Jv != 0.0, axis=1)[joff_mask]))
        if not ok:
            self.structural = False
            self.msup, jcol, joff = dense_support(nc, k)
            self.support = (jcol, joff)
            self.buf.held[:] = -1
            self.buf.Ja[...] = 0.0
        return ok

    def predict_into(self, q, v, hk: float) -> tuple[int, int]:
        """:func:`.moreau_step_kernels.predict_model` on this predictor's buffers:
        ``(status, n_active)``."""
        c, buf = self.cache, self.buf
        work, Mv, gapv, Jv, biasv = self.views
        jcol, joff = self.support
        return predict_model(work, Mv, gapv, Jv, biasv, q, v, hk, self.theta, c.gflat,
                             c.gsize, c.goff, c.mask, c.Minv, self.qm, self.vtmp, self.vfree,
                             buf.e, self.gap_tol, self.rest_velocity, buf.active, buf.Ja,
                             buf.b, buf.vn_k, self.msup, jcol, joff, buf.held)

    def predict(self, index: int, t: float, q, v, hk: float, sigma) -> Step:
        c, buf = self.cache, self.buf
        work, Mv, gapv, Jv, biasv = self.views
        jcol, joff = self.support
        # (predict_into's call, inline: this is the step's hot path)
        status, na = predict_model(work, Mv, gapv, Jv, biasv, q, v, hk, self.theta, c.gflat,
                                   c.gsize, c.goff, c.mask, c.Minv, self.qm, self.vtmp,
                                   self.vfree, buf.e, self.gap_tol, self.rest_velocity,
                                   buf.active, buf.Ja, buf.b, buf.vn_k, self.msup, jcol, joff,
                                   buf.held)
        for i in range(2):  # another call only after a regroup, at the same state
            if i:
                status, na = self.predict_into(q, v, hk)
            if status != REGROUP:
                break
            if self.structural and not self.certify():
                status, na = self.predict_into(q, v, hk)  # on the dense supports
                if status != REGROUP:
                    break
            regroup(Mv, self.C, c)
            self.inv = InverseMass(c.Minv, c.groups)
        if status:
            self._fail(status)
        return self.step_view(index, t, v, hk, na, sigma)

    def step_view(self, index: int, t: float, v, hk: float, na: int, sigma) -> Step:
        """The :class:`Step` of the prediction in the buffers (``na`` active contacts)."""
        st = self.st
        st.index, st.tm, st.hk, st.qm, st.v = index, t + (1.0 - self.theta) * hk, hk, self.qm, v
        st.M, st.inv, st.C, st.v_free = self.views[1], self.inv, self.C, self.vfree
        st.sigma = sigma
        st.blocks = self.cache
        st.support = self.support
        self.buf.fill(st, na)
        return st

    def _fail(self, status: int):
        if status == NOT_DEFINITE:
            raise SimulationError("the mass matrix is not positive definite (or not finite) "
                                  "on this step")
        if status == NOT_FINITE:
            raise SimulationError("the mass matrix is not finite")
        if status == REGROUP:
            raise SimulationError("the mass matrix's coupling changed twice at one state")
        from ..model import recursive as rc

        # the model's own error (non-finite or wrongly shaped state): its typed exception
        self.data.cache.clear()
        self.data.compute(rc.MASS | rc.CONTACT, np.array(self.qm))
        raise SimulationError(f"the model's evaluation failed (code {status >> EVAL_SHIFT})")

    def finish(self, st: Step, v_new, t_end: float, q_out, v_out) -> bool:
        if not advance(st.qm, v_new, st.hk * self.theta, q_out, v_out):
            raise SimulationError(f"the state became non-finite at t = {t_end:.9g}; reduce h")
        return False

    def close(self) -> None:
        # the compiled pass moved the model's state behind its Data's back: drop what the
        # Data derived from the state it last saw
        self.data.cache.clear()

    def series(self, theta, dtheta, sigma):
        data, lay = self.data, self.data.layout
        n, k = theta.shape
        p, T, V = np.empty((n, k)), np.empty(n), np.empty(n)
        try:
            gmin = model_series(data.work, data.M, data.gap, data.position3, data.rotation3,
                                lay.body_mass, lay.body_com, lay.gravity, theta, dtheta, p,
                                T, V, self.msup)
        finally:
            data.cache.clear()
        zeros = np.zeros(n)
        return p, T, V, zeros, zeros.copy(), (-gmin if np.isfinite(gmin) else 0.0)


class ProtocolPredictor:
    """The predictor through the Mechanism protocol (any mechanism; loops, applied forces):
    :class:`.moreau_engine.Evaluator`, :func:`.moreau_engine.inverse_mass`, the mechanism's
    forces, :func:`.moreau_step_kernels.contact_rows_into`."""

    def __init__(self, mech, theta: float, gap_tol: float, rest_velocity: float,
                 projection_tol: float):
        self.mech = mech
        self.contacts = tuple(mech.contact_names)
        self.k, self.m = int(mech.n_coordinates), int(mech.n_loop_constraints)
        self.theta, self.gap_tol, self.rest_velocity = theta, gap_tol, rest_velocity
        self.projection_tol = projection_tol
        self.nfev_per_step = 2 if theta < 1.0 else 1
        self.ev = Evaluator(mech, self.contacts)
        self.cache = GroupCache()
        self.buf = None
        self.st = Step()
        self.support = dense_support(len(self.contacts), self.k)[1:]

    def loop_rows(self, q):
        m, k = self.m, self.k
        return (np.asarray(self.mech.loop_jacobian(q), float).reshape(m, k) if m
                else np.zeros((0, k)))

    def predict(self, index: int, t: float, q, v, hk: float, sigma) -> Step:
        mech, th = self.mech, self.theta
        tm = t + (1.0 - th) * hk
        qm = q + hk * (1.0 - th) * v
        M, gaps, J = self.ev.positions(qm)
        C = self.loop_rows(qm)
        inv = inverse_mass(M, C, self.cache)
        f = np.asarray(mech.generalized_forces(tm, qm, v), float)
        Minv = inv.Minv if inv.Minv is not None else inv.G
        if th < 1.0:
            v_pred = v + (1.0 - th) * hk * (Minv @ f)
            f = np.asarray(mech.generalized_forces(tm, qm, v_pred), float)
        v_star = v + hk * (Minv @ f)
        if self.m:
            s = inv.S @ (C @ v_star)
            v_free = v_star - inv.A @ s
            sigma = sigma - s  # loop impulse of the smooth part (M dv = h f + C^T dsigma)
        else:
            v_free = v_star
        st = self.st
        st.index, st.tm, st.hk, st.qm, st.v, st.M, st.inv, st.C = index, tm, hk, qm, v, M, inv, C
        st.v_free, st.sigma, st.blocks = v_free, sigma, self.cache
        st.support = self.support
        na = 0
        if self.contacts:
            if self.buf is None:
                self.buf = _Buffers(mech, len(self.contacts), J.shape[1], self.k)
            buf = self.buf
            # a resting contact's predicted gap is 0 up to the round-off of the positions:
            # that round-off must not switch it off (one corner of two would then carry
            # the load alone and turn the body)
            slack = GAP_ROUNDOFF * max(1.0, float(np.max(np.abs(qm), initial=0.0)))
            na = contact_rows_into(gaps, np.ascontiguousarray(J), v, v_free, buf.e, hk * th,
                                   self.gap_tol + slack, self.rest_velocity, buf.active,
                                   buf.Ja, buf.b, buf.vn_k, *self.support, buf.held)
            buf.fill(st, na)
        else:
            st.active = np.zeros(0, dtype=np.int64)
        return st

    def finish(self, st: Step, v_new, t_end: float, q_out, v_out) -> bool:
        q_new, v_new, projected = end_of_step(self.mech, st.qm, v_new, st.hk * self.theta,
                                              st.M, self.loop_rows, self.projection_tol,
                                              t_end)
        q_out[:] = q_new
        v_out[:] = v_new
        return projected

    def close(self) -> None:
        pass

    def series(self, theta, dtheta, sigma):
        mech, m, n = self.mech, self.m, theta.shape[0]
        p, T, V = np.empty_like(theta), np.empty(n), np.empty(n)
        psi, cdq = np.zeros(n), np.zeros(n)
        pen = 0.0
        for s in range(n):
            th, dth = theta[s], dtheta[s]
            M_, g_ = self.ev.mass_and_gaps(th)
            C_ = self.loop_rows(th)
            p[s] = M_ @ dth - C_.T @ sigma[s]
            T[s] = 0.5 * float(dth @ M_ @ dth)
            V[s] = float(mech.potential_energy(th))
            if m:
                psi[s] = float(np.max(np.abs(mech.loop_residual(th))))
                cdq[s] = float(np.max(np.abs(C_ @ dth)))
            if g_.size:
                pen = max(pen, -float(np.min(g_)))
        return p, T, V, psi, cdq, pen


def predictor(mech, theta: float, gap_tol: float, rest_velocity: float,
              projection_tol: float):
    """The predictor for ``mech`` (:class:`ModelPredictor` where it applies)."""
    if ModelPredictor.applies(mech):
        return ModelPredictor(mech, theta, gap_tol, rest_velocity)
    return ProtocolPredictor(mech, theta, gap_tol, rest_velocity, projection_tol)


def run_steps(mech, q, v, solver, **kwargs) -> dict[str, Any]:
    """Run the loop (:func:`_run`, keyword arguments as there) with BLAS on one thread: the
    step's matrices are small, and a threaded BLAS spends more on waking its threads (on a
    shared machine, far more) than on the products."""
    with one_blas_thread():
        return _run(mech, q, v, solver, **kwargs)


def _run(mech, q, v, solver, *, t0: float, t1: float, h: float, theta: float, n_steps: int,
         gap_tol: float, rest_velocity: float, projection_tol: float) -> dict[str, Any]:
    """The loop; returns the series (:data:`~.result.SERIES` keys as arrays) and the
    figures (``stats``). ``solver`` has ``solve(step) -> (v_{k+1}, sigma)`` and
    ``idle()`` (a step without active contacts)."""
    k, m = int(mech.n_coordinates), int(mech.n_loop_constraints)
    pred = predictor(mech, theta, gap_tol, rest_velocity, projection_tol)
    T = np.empty(n_steps + 1)
    Q, Vel, S = np.empty((n_steps + 1, k)), np.empty((n_steps + 1, k)), np.zeros(
        (n_steps + 1, m))
    sigma = np.zeros(m)
    T[0], Q[0], Vel[0] = t0, q, v
    q, v = Q[0], Vel[0]
    stats = {"nfev": 0, "contact_steps": 0, "proj": 0, "max_active": 0, "impact_time": 0.0}
    t, count = t0, 1
    clock = _time.perf_counter
    fast = FastStep(pred, solver) if FastStep.applies(pred, solver) else None
    try:
        for step in range(n_steps):
            hk = min(h, t1 - t)
            if hk <= 0:
                break
            done = REDO if fast is None else fast.step(step, t, q, v, hk, sigma, Q[count],
                                                         Vel[count], stats)
            if done == FINISHED:
                t = t1 if step == n_steps - 1 else t + hk
                q, v = Q[count], Vel[count]
                T[count] = t
                count += 1
                continue
            if done == PREDICTED:
                st = pred.step_view(step, t, v, hk, fast.na, sigma)
            else:
                st = pred.predict(step, t, q, v, hk, sigma)
            na = st.active.shape[0]
            if na:
                stats["contact_steps"] += 1
                if na > stats["max_active"]:
                    stats["max_active"] = na
                t_start = clock()
                try:
                    v_new, sigma = solver.solve(st)
                finally:
                    stats["impact_time"] += clock() - t_start
            else:
                solver.idle()
                v_new, sigma = st.v_free, st.sigma
            stats["proj"] += pred.finish(st, v_new, t + hk, Q[count], Vel[count])
            t = t1 if step == n_steps - 1 else t + hk
            q, v = Q[count], Vel[count]
            T[count] = t
            if m:
                S[count] = sigma
            count += 1
    finally:
        pred.close()
    stats["nfev"] = pred.nfev_per_step * (count - 1)
    Q, Vel, S = Q[:count], Vel[:count], S[:count]
    p, E_kin, E_pot, psi, cdq, pen = pred.series(Q, Vel, S)
    stats["max_pen"] = pen
    series = {"t": T[:count], "theta": Q, "dtheta": Vel, "p": p, "sigma": S,
              "kinetic_energy": E_kin, "potential_energy": E_pot, "loop_residual": psi,
              "loop_velocity_residual": cdq}
    return {"series": series, "stats": stats}
