"""The Moreau–Jean loop on the contact engine (laws ``ccp`` and ``coulomb``).

The scheme is :mod:`.moreau`'s, step for step (intermediate configuration, explicit smooth
forces, free velocity, active set by gap prediction, Newton's restitution at the velocity
level, position update and loop projection); only the contact problem is posed and solved
differently: by :mod:`.moreau_engine`, in the generalized coordinates' block structure,
island by island, warm-started from the previous step's impulses, every answer certified.

Differences from the path through :func:`convimpact.resolve_impact` (other laws, methods
and options):

* every active contact carries its friction (the per-impact law ``ccp`` of
  ``resolve_impact`` keeps only the normal of a contact that does not approach);
* the impact events carry no :class:`~convimpact.impact.results.ImpactResult`
  (``result=None``): the step's certificate is the engine's natural-map residual, at most
  ``tol`` on every island; ``regime`` is read off the answer (``"separating"`` for a zero
  normal impulse, ``"stick"`` where the contact's slip after the step is at most 1e-9 of the
  step's velocity scale, else ``"slide"``; ``"frictionless"`` for mu = 0).
"""

from __future__ import annotations

import time as _time
from typing import Any

import numpy as np

from ..impact.contacts.threads import one_blas_thread
from ..impact.errors import ConvImpactError, SimulationError
from .moreau_engine import (
    EngineCounters,
    Evaluator,
    GroupCache,
    StepProblem,
    inverse_mass,
    solve_step,
)
from .moreau_kernels import contact_rows
from .projection import project_positions, project_velocities
from .result import SERIES, ImpactEvent


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


class Recorder:
    """The sampled series of a Moreau–Jean run (:data:`~.result.SERIES`) and the largest
    penetration (-gap) of any contact at a stored state."""

    def __init__(self, mech, evaluator: Evaluator):
        self.mech, self.ev = mech, evaluator
        self.k = int(mech.n_coordinates)
        self.m = int(mech.n_loop_constraints)
        self.rows: dict[str, list] = {key: [] for key in SERIES}
        self.max_penetration = 0.0

    def __call__(self, t: float, th: np.ndarray, dth: np.ndarray, sigma: np.ndarray) -> None:
        mech, m, rows = self.mech, self.m, self.rows
        M_, g_ = self.ev.mass_and_gaps(th)
        C_ = (np.asarray(mech.loop_jacobian(th), float).reshape(m, self.k) if m
              else np.zeros((0, self.k)))
        rows["t"].append(t)
        rows["theta"].append(th.copy())
        rows["dtheta"].append(dth.copy())
        rows["p"].append(M_ @ dth - C_.T @ sigma)
        rows["sigma"].append(sigma.copy())
        rows["T"].append(0.5 * float(dth @ M_ @ dth))
        rows["V"].append(float(mech.potential_energy(th)))
        if m:
            rows["psi"].append(float(np.max(np.abs(mech.loop_residual(th)))))
            rows["cdq"].append(float(np.max(np.abs(C_ @ dth))))
        else:
            rows["psi"].append(0.0)
            rows["cdq"].append(0.0)
        if g_.size:
            self.max_penetration = max(self.max_penetration, -float(np.min(g_)))


#: a contact whose predicted end-of-step gap is at most gap_tol + this (times max(1, max|q|))
#: takes part: round-off of the configuration, not an opening
GAP_ROUNDOFF = 1e-12


def run_engine_steps(mech, q, v, **kwargs) -> dict[str, Any]:
    """Run the loop (:func:`_run`, keyword arguments as there) with BLAS on one thread: the
    step's matrices are small, and a threaded BLAS spends more on waking its threads (on a
    shared machine, far more) than on the products."""
    with one_blas_thread():
        return _run(mech, q, v, **kwargs)


def _run(mech, q, v, *, t0: float, t1: float, h: float, theta: float,
                     n_steps: int, law: str, tol: float, gap_tol: float,
                     rest_velocity: float, projection_tol: float, warm_start: bool,
                     islands: bool, max_iter: int = 100, newton_iter: int = 20
                     ) -> dict[str, Any]:
    """Run the loop; returns the recorded rows, impacts, counters and figures."""
    contacts = tuple(mech.contact_names)
    k = int(mech.n_coordinates)
    m = int(mech.n_loop_constraints)
    ev = Evaluator(mech, contacts)
    params = [mech.contact_parameters(c) for c in contacts]
    e_all = np.array([float(p[0]) for p in params])
    mu_all = np.array([float(p[1]) for p in params])
    coulomb = law == "coulomb"
    counters = EngineCounters()
    cache = GroupCache()
    layout_cache: dict = {}
    last = None  # previous step's impulses (nc, d)
    sigma = np.zeros(m)
    impacts: list[ImpactEvent] = []
    stats = {"nfev": 0, "contact_steps": 0, "proj": 0, "max_active": 0, "impact_time": 0.0}

    def loop_rows(th):
        return (np.asarray(mech.loop_jacobian(th), float).reshape(m, k) if m
                else np.zeros((0, k)))

    recorder = Recorder(mech, ev)

    def record(t, th, dth):
        recorder(t, th, dth, sigma)

    t = t0
    record(t, q, v)
    for step in range(n_steps):
        hk = min(h, t1 - t)
        if hk <= 0:
            break
        tm = t + (1.0 - theta) * hk
        qm = q + hk * (1.0 - theta) * v
        M, gaps, J = ev.positions(qm)
        d = J.shape[1] if J.ndim == 3 else 0
        C = loop_rows(qm)
        inv = inverse_mass(M, C, cache)
        f = np.asarray(mech.generalized_forces(tm, qm, v), float)
        stats["nfev"] += 1
        Minv = inv.Minv if inv.Minv is not None else inv.G
        if theta < 1.0:
            v_pred = v + (1.0 - theta) * hk * (Minv @ f)
            f = np.asarray(mech.generalized_forces(tm, qm, v_pred), float)
            stats["nfev"] += 1
        v_star = v + hk * (Minv @ f)
        if m:
            s = inv.S @ (C @ v_star)
            v_free = v_star - inv.A @ s
            sigma = sigma - s
        else:
            v_free = v_star
        v_new = v_free
        if contacts:
            # a resting contact's predicted gap is 0 up to the round-off of the positions:
            # that round-off must not switch it off (one corner of two would then carry
            # the load alone and turn the body)
            slack = GAP_ROUNDOFF * max(1.0, float(np.max(np.abs(qm), initial=0.0)))
            active, Ja, b, vn_k = contact_rows(gaps, J, v, v_free, e_all, hk * theta,
                                               gap_tol + slack, rest_velocity)
        else:
            active = np.zeros(0, dtype=np.int64)
        if active.size:
            stats["contact_steps"] += 1
            stats["max_active"] = max(stats["max_active"], int(active.size))
            start = None
            if warm_start and last is not None:
                start = last[active]
            t_start = _time.perf_counter()
            try:
                r = solve_step(StepProblem(active, Ja, b, mu_all[active]), inv,
                               coulomb=coulomb, tol=tol, start=start, split=islands,
                               counters=counters, names=contacts, max_iter=max_iter,
                               newton_iter=newton_iter, where=f"at t = {tm:.9g}, step {step}",
                               cache=layout_cache)
            except ConvImpactError as exc:
                exc.add_note(f"(while solving the step's contact problem at t = {tm:.9g}, "
                             f"step {step}, in simulate_moreau)")
                raise
            finally:
                stats["impact_time"] += _time.perf_counter() - t_start
            gen = np.einsum("cdk,cd->k", Ja, r)
            v_new = v_free + inv.G @ gen
            if m:
                sigma = sigma - inv.S @ (inv.A.T @ gen)
            if last is None:
                last = np.zeros((len(contacts), d))
            last[:] = 0.0
            last[active] = r
            hit = np.flatnonzero((vn_k < -rest_velocity) & (r[:, 0] > 0.0))
            if hit.size:
                u = np.einsum("cdk,k->cd", Ja, v_new)
                scale = max(float(np.abs(b).max()), 1e-300)
                slip = np.sqrt(np.einsum("cd,cd->c", u[:, 1:], u[:, 1:]))
                regime = tuple(
                    "frictionless" if mu_all[active[i]] <= 0.0 else
                    "separating" if r[i, 0] <= 0.0 else
                    "stick" if slip[i] <= 1e-9 * scale else "slide" for i in hit)
                T_minus = 0.5 * float(v_free @ M @ v_free)
                T_plus = 0.5 * float(v_new @ M @ v_new)
                impacts.append(ImpactEvent(
                    time=tm, contacts=tuple(contacts[active[i]] for i in hit),
                    held_contacts=(), regime=regime, impulse=r[hit].copy(),
                    loop_impulse=np.zeros(m), generalized_impulse=gen,
                    theta=qm.copy(), dtheta_minus=v.copy(), dtheta_plus=v_new.copy(),
                    energy_loss=T_minus - T_plus,
                    kinetic_energy_minus=0.5 * float(v @ M @ v), kinetic_energy_plus=T_plus,
                    persistent=(), released=(), resolve_time=0.0, result=None))
        elif last is not None:
            last[:] = 0.0
        q, v, projected = end_of_step(mech, qm, v_new, hk * theta, M, loop_rows,
                                      projection_tol, t + hk)
        stats["proj"] += projected
        t = t1 if step == n_steps - 1 else t + hk
        record(t, q, v)
    stats["max_pen"] = recorder.max_penetration
    return {"rows": recorder.rows, "impacts": impacts, "counters": counters, "stats": stats}
