"""What an event-driven step watches (:class:`EventWatch`, a part of
:class:`~convimpact.simulation.event_driven.EventDrivenRun`): the free contacts closing in a
step (:class:`StepSamples` samples the step's interpolant for gaps and normal speeds), the held
contacts' margins (a force leaving its cone or turning tensile), the sliding contacts' slip
velocities along their anchored directions and Painleve's indicator, each located at its
instant; and the frozen friction directions' alignment with the slip (``turn:<c>``).

Frozen slip directions. In space a sliding contact's friction opposes the slip velocity,
``-mu lambda_n v_t / |v_t|``. Followed during a segment, that direction makes the equations
stiff where the slip is slow: a slip velocity across it relaxes at a rate ~ mu g / |v_t|, so
an explicit integrator's steps shrink to ~ |v_t| / (mu g) at a slip onset (|v_t| grows from
0) and near a stop. Measured on the box stack (problems/box_stack.py), whose top box starts
to slide at 0.633 s: 185 of the run's 211 steps (3,900 of 4,177 right-hand sides) fell in the
27 ms after the onset, the run 202x MuJoCo per simulated second; an implicit integrator
(Radau, finite-difference Jacobians) took 3,163 steps. Rather than a slip-speed floor (a
change of the physics) or an implicit step, the run freezes the direction of each spatial
slip that starts at an event (:class:`~.canonical.HeldMode`'s ``frozen``: the force
problem's onset direction; kept frozen over later segments while the slip keeps it; slips
under way since the run's start follow their velocity, as before) and watches here that
the slip keeps it: the event
``turn:<c>`` ends the segment where the slip velocity's component across the direction
exceeds :data:`SLIP_TURN_TOL` (|v_t| + |theta_dot|_inf + rest_velocity). Until then the
friction is Coulomb's to that angle; where the slip keeps its direction (the stack, the
sliding tables, a box pushed along its slip: by symmetry) the segment has no stiff mode and
the stack's run takes 24 steps and 556 right-hand sides. A slip that turns (a side force)
is refrozen once along its velocity, then followed (:data:`~.contact_events.FREEZES`), as
before; so is a slip whose velocity already leaves the direction where a segment starts.
Like the other event functions, this one is evaluated at the steps' ends: within a step the
angle can exceed its bound and come back unseen (after a refreeze along a slow slip, up to
~1e-7 rad on a box pushed from rest). An onset's direction, read off an acceleration that
vanishes at the instant, is exact where symmetry fixes it (the stack); elsewhere (a box
pushed obliquely) it is off by ~1e-7 rad, the slip soon turns away from it and the run
follows the slip as before. Runs with sensitivities follow the direction throughout (their
variational equations differentiate it).
"""

from __future__ import annotations

from functools import partial
from typing import Any, Mapping, Sequence

import numpy as np

from .canonical import _cho_solve
from .events import DIP_SAMPLES, gap_event, locate_crossing
from .sustained import MARGIN_SLACK, held_forces, held_margin_extension, painleve_indicator

#: how far a sliding contact's slip velocity v_t may leave its frozen friction direction s
#: before the event ``turn:<c>`` ends the segment: its component across s stays below
#: SLIP_TURN_TOL (|v_t| + |theta_dot|_inf + rest_velocity) (an angle of SLIP_TURN_TOL rad
#: once the slip is under way; at an onset, a speed within the integration's own tolerance
#: of the motion's velocities, where the direction of v_t is round-off). The friction force
#: differs from Coulomb's by that angle at most; it is 0 where the slip keeps its direction
#: (the box stack's top box, a box pushed from rest: by symmetry)
SLIP_TURN_TOL = 1e-8
#: half-width (s) of the first bracket tried around the predicted zero of a held group's
#: margin (:meth:`EventWatch.locate_margin`)
PREDICTED_BRACKET = 1e-9
#: an event found in a step: (time, "impact" / "touch" / "mode", contact name)
Event = tuple[float, str, str]
Held = tuple[str, ...]


class StepSamples:
    """The free contacts' gaps and normal speeds on one step's interpolant.

    The event functions of :func:`~.events.gap_event` sample every free contact at the same
    instants (the interior points of :func:`~.events.first_dip`); here each instant's state
    is interpolated once (the interior points in one vectorized call) and its gaps and normal
    speeds evaluated once for all contacts, the values those of separate evaluations.
    ``run`` is the :class:`~convimpact.simulation.event_driven.EventDrivenRun` (not imported
    here: it imports this module).
    """

    def __init__(self, run: Any, free: Sequence[str], interp, t_old: float,
                 t_new: float, n: int = DIP_SAMPLES):
        self.run, self.free, self.interp, self.k = run, tuple(free), interp, run.k
        times = [t_old + (t_new - t_old) * j / n for j in range(1, n)]
        self.y: dict[float, np.ndarray] = {}
        if self.free and times:
            Y = np.asarray(interp(np.array(times)), float)
            self.y = {t: np.ascontiguousarray(Y[:, i]) for i, t in enumerate(times)}
        self._gaps: dict[float, dict[str, float]] = {}
        self._speeds: dict[float, dict[str, float]] = {}

    def state(self, s: float) -> np.ndarray:
        y = self.y.get(s)
        if y is None:
            y = self.y[s] = np.asarray(self.interp(s), float)
        return y

    def gap(self, c: str, s: float) -> float:
        g = self._gaps.get(s)
        if g is None:
            g = self._gaps[s] = self.run.gaps(self.free, self.state(s)[:self.k])
        return g[c]

    def speed(self, c: str, s: float) -> float:
        v = self._speeds.get(s)
        if v is None:
            v = self._speeds[s] = self.run.normal_speeds(self.free, self.state(s))
        return v[c]


class EventWatch:
    """The event functions of a run (see the module docstring); they use its state, its
    equations and its options."""

    def closing_in_step(self, free: Sequence[str], interp, t_old: float, t_new: float,
                        y_new: np.ndarray,
                        g_prev: Mapping[str, float]) -> tuple[list[Event], dict[str, float]]:
        """Free contacts closing in the step (see :func:`~.events.gap_event`) and their gaps
        at its end (the step's samples shared by the contacts, :class:`StepSamples`)."""
        found: list[Event] = []
        g_new = self.gaps(free, y_new[:self.k])
        samples = StepSamples(self, free, interp, t_old, t_new)
        for c in free:
            event = gap_event(partial(samples.gap, c), partial(samples.speed, c), t_old, t_new,
                              g_prev[c], g_new[c], self.opts.event_tol)
            if event is not None:
                found.append((*event, c))
        return found, g_new

    def gaps(self, contacts: Sequence[str], th: np.ndarray) -> dict[str, float]:
        """The gaps of ``contacts`` at theta (one compiled pass for all of them on a model),
        counted as event-function evaluations."""
        self.nevents_fev += len(contacts)
        if self.eq._model and contacts:
            d = self.mech.rhs_positions(np.ascontiguousarray(th, dtype=float))
            idx = [self.contact_at[c] for c in contacts]
            if all(d.contact_ok[idx]):  # else contact_gap raises the typed error
                return {c: float(d.gap[i]) for c, i in zip(contacts, idx)}
        return {c: float(self.mech.contact_gap(c, th)) for c in contacts}

    def normal_speeds(self, contacts: Sequence[str], y: np.ndarray) -> dict[str, float]:
        """The normal velocities of ``contacts`` at the state ``y``: on a model with no
        constraint in force, theta_dot = M^-1 p and the Jacobians from one compiled pass."""
        if self.eq._model and contacts and not self.eq.n_constraints:
            d = self.mech.rhs_positions(np.ascontiguousarray(y[:self.k], dtype=float))
            if d.chol_ok:
                dth = _cho_solve(d.L, y[self.k:])
                J = d.contact_jacobian
                return {c: float(J[self.contact_at[c], 0] @ dth) for c in contacts}
        th, dth, _ = self.state(y)
        J = self._jacobians(th)
        return {c: float(J(c)[0] @ dth) for c in contacts}

    def watch(self, t: float, y: np.ndarray, anchors: Mapping[str, np.ndarray],
              keys: Sequence[str] | None = None) -> dict:
        """The held contacts' event functions at (t, y): the force margin, the slip
        velocities along their anchors, and the Painleve indicator (only ``keys`` when
        given: locating one of them evaluates that one alone).

        The margin and the indicator do not depend on the anchors at a state where every
        slip keeps its direction (they enter only past a reversal or below the slip floor,
        where the anchors are left as they were): watching the same state again after
        :meth:`slip_anchors` (the next step's start) takes them from this evaluation.
        """
        self.nevents_fev += 1
        if self.margin_hint.get("eq") is not self.eq:  # a new segment's modes
            self.margin_hint = {"eq": self.eq}
        want = (lambda key: True) if keys is None else (lambda key: key in keys)
        out = {}
        memo = self._watched
        key = y.tobytes()
        same = (keys is None and memo is not None and memo[0] is self.eq and memo[1] == t
                and memo[2] == key)
        recorded = self._recorded
        if same:
            out["margin"] = memo[4]
        elif (keys is None and recorded is not None and recorded.forces is not None
              and recorded.matches(self.eq, t, key)):  # the exact ones of the sample just
            forces = recorded.forces                 # recorded, already computed
            margin = recorded.margin
            self.margin_hint["exact"] = True
            if forces:
                d = max(len(v) for v in forces.values())
                lam = np.zeros(len(forces) * d)
                for i, c in enumerate(self.eq.held):
                    lam[i * d:i * d + len(forces[c])] = forces[c]
                self.margin_hint["lam"] = lam
            out["margin"] = margin + MARGIN_SLACK
        elif want("margin"):
            forces, margin = held_forces(self.eq, t, y, self.margin_hint, margin_only=True)
            out["margin"] = margin + MARGIN_SLACK
        if anchors:
            th, dth, _ = self.state(y)
            names = (list(anchors) if keys is None else list(dict.fromkeys(
                key[5:] for key in keys if key[:5] in ("slip:", "turn:")
                and key[5:] in anchors)))
            if names:
                V = self._slip_velocities(th, dth, names)  # (n, d - 1)
                S = np.array([anchors[c] for c in names], float).reshape(V.shape)
                along = np.einsum("ij,ij->i", V, S)
                modes = self.eq.modes
                turn = (self._turn_functions(V, S, along, dth)
                        if any(modes[c].frozen for c in names) else None)
                for i, c in enumerate(names):
                    if want("slip:" + c):
                        out["slip:" + c] = float(along[i])
                    if turn is not None and modes[c].frozen and want("turn:" + c):
                        out["turn:" + c] = float(turn[i])
            if same:
                out["painleve"] = memo[5]
            elif want("painleve"):
                out["painleve"] = painleve_indicator(self.eq, t, y)
        if keys is None and not same:
            exact = forces if self.margin_hint.get("exact", True) else None
            self._watched = (self.eq, t, key, exact, out["margin"], out.get("painleve"))
        return out

    def _slip_velocities(self, th: np.ndarray, dth: np.ndarray,
                         contacts: Sequence[str]) -> np.ndarray:
        """The slip velocities v_t (n, d - 1) of ``contacts`` at (theta, theta_dot): from
        one compiled pass on a model, else :meth:`contact_row`."""
        if self.eq._model:
            d = self.mech.rhs_positions(np.ascontiguousarray(th, dtype=float))
            if d.contact_ok.all():
                idx = [self.contact_at[c] for c in contacts]
                return d.contact_jacobian[idx, 1:self.d] @ dth
        return np.array([self.contact_row(c, th)[1:] @ dth for c in contacts])

    def _turn_functions(self, V: np.ndarray, S: np.ndarray, along: np.ndarray,
                        dth: np.ndarray) -> np.ndarray:
        """The event functions of frozen slip directions: per row of V (slip velocities
        v_t) and S (their frozen unit directions s; ``along`` = v_t . s),
        ``SLIP_TURN_TOL (|v_t| + |theta_dot|_inf + rest_velocity) - |v_t - (v_t . s) s|``,
        positive while v_t keeps along s (:data:`SLIP_TURN_TOL`; the rest velocity, the
        slip floor, keeps it positive at an onset from rest, where v_t and theta_dot are 0,
        so that a slip turning in the first step is caught)."""
        across = V - along[:, None] * S
        speed = float(np.max(np.abs(dth))) if dth.size else 0.0
        return (SLIP_TURN_TOL * (np.sqrt(np.einsum("ij,ij->i", V, V)) + speed
                                 + self.opts.rest_velocity)
                - np.sqrt(np.einsum("ij,ij->i", across, across)))

    def _jacobians(self, th: np.ndarray):
        """contact name -> its Jacobian at theta (rows n, t...): from one compiled pass on a
        model (the state's pass, already done), else :meth:`contact_row`."""
        if self.eq._model:
            d = self.mech.rhs_positions(np.ascontiguousarray(th, dtype=float))
            if all(d.contact_ok):
                J, at, dd = d.contact_jacobian, self.contact_at, self.d
                return lambda c: J[at[c], :dd]
        return lambda c: self.contact_row(c, th)

    def slip_anchors(self, y: np.ndarray) -> dict[str, np.ndarray]:
        """Per sliding contact with friction, its slip direction now (the event functions of
        slip reversal are the slip velocities along these); stored as the direction the
        friction keeps while the slip speed is below the floor."""
        th, dth, _ = self.state(y)
        out = {}
        if not self.eq.slipping:
            return out
        jac = self._jacobians(th)  # (one compiled pass)
        names = [c for c, _ in self.eq.slipping]
        S = self.eq.slip_directions(names, np.array([jac(c) for c in names]), dth)
        for i, c in enumerate(names):
            out[c] = S[i] if S is not None else self.eq.slip_direction(c, jac(c), dth)
            self.eq.set_slip_direction(c, out[c])
        return out

    def held_in_step(self, interp, t_old: float, t_new: float, w_prev: Mapping[str, float],
                     w_new: Mapping[str, float], anchors) -> list[Event]:
        """Held contacts whose mode stops being valid in the step (a margin, a slip velocity
        along its anchor or the Painleve indicator through zero; a slip turning away from its
        frozen direction)."""
        found: list[Event] = []
        crossing = [key for key, prev in w_prev.items() if prev > 0.0 >= w_new[key]]
        rest = [key for key in crossing if key != "margin"]
        together = (self.locate_together(interp, t_old, t_new, w_prev, w_new, anchors, rest)
                    if len(rest) > 1 and not self.opts.sensitivities else None)
        for key in crossing:
            if key != "margin" and together is not None:
                continue
            prev, new = w_prev[key], w_new[key]

            def fun(s, key=key):
                return self.watch(s, np.asarray(interp(s), float), anchors, (key,))[key]
            if key == "margin":
                te = self.locate_margin(fun, interp, t_old, t_new, prev, new)
            else:
                te = locate_crossing(fun, t_old, t_new, prev, new, self.opts.event_tol)
            found.append((te, "mode", key))
        return found + (together or [])

    def locate_together(self, interp, t_old: float, t_new: float, w_prev: Mapping[str, float],
                        w_new: Mapping[str, float], anchors, keys: Sequence[str]):
        """The events of several held contacts' functions (slip velocities, frozen
        directions, the Painleve indicator: ``keys``) crossing zero in one step, where
        only the earliest instant matters (the run stops there and the force problem
        decides every mode): the earliest by the values' linear interpolation located by
        Brent's method (:func:`~.events.locate_crossing`, to ``event_tol``), then every
        other key evaluated at once (one evaluation of the state for all) at that instant
        te, and at te - event_tol (those crossed by te) or te + event_tol (the others):
        crossed within event_tol of te, an event there (the instant's group); crossed
        later, none in this step (its own crossing, if any, ends a later segment). A table
        sliding on 48 legs stops on all of them at once: 3 evaluations of the state for
        the 47 others instead of ~3 each. None where some key crossed more than event_tol
        before te (then each is located by itself, as without this)."""
        tol = self.opts.event_tol

        def values(s: float, which) -> Mapping[str, float]:
            if s == t_new:
                return w_new
            return self.watch(s, np.asarray(interp(s), float), anchors, tuple(which))

        def estimate(key: str) -> float:
            return t_old + (t_new - t_old) * w_prev[key] / (w_prev[key] - w_new[key])
        first = min(keys, key=lambda key: (estimate(key), key))
        te = locate_crossing(lambda s: values(s, (first,))[first], t_old, t_new,
                             w_prev[first], w_new[first], tol)
        others = [key for key in keys if key != first]
        at = values(te, others)
        crossed = [key for key in others if at[key] <= 0.0]
        if crossed:
            lo = te - tol
            if not lo > t_old:
                return None
            at_lo = values(lo, crossed)
            if any(at_lo[key] <= 0.0 for key in crossed):
                return None  # an earlier crossing: located one by one
        pending = [key for key in others if at[key] > 0.0]
        hi = min(te + tol, t_new)
        at_hi = values(hi, pending) if pending else {}
        return ([(te, "mode", first)] + [(te, "mode", key) for key in crossed]
                + [(hi, "mode", key) for key in pending if at_hi[key] <= 0.0])

    def locate_margin(self, fun, interp, t_old: float, t_new: float, fa: float,
                      fb: float) -> float:
        """Where the held forces' margin ``fun`` (> 0 at t_old, ``fa``; <= 0 at t_new,
        ``fb``) crosses zero: Brent's method on it (:func:`~.events.locate_crossing`),
        within a bracket narrowed first by a predictor where one applies.

        Each value of the margin is a cone program (:func:`~.sustained.held_forces`), and
        the active set of the program changes along a long step: locating its zero by
        Brent's method over the whole step cost the box stack's tip 19 evaluations, five
        of them by the solver. The margin at t_new was just computed by an exact program;
        the smooth extension of that program's active set
        (:func:`~.sustained.held_margin_extension`: its optimality conditions solved with
        the cones' kinds fixed, no solver) is followed back by the Illinois method to its
        zero t_p, and where the margin's own values change sign across t_p within a small
        bracket (widened tenfold at a time from :data:`PREDICTED_BRACKET`), Brent's method
        runs on that bracket. The event is the margin's zero either way, to ``event_tol``:
        the extension only chooses where to look (where the margin changes sign more than
        once in the step, Brent's method over the step may find another of its zeros)."""
        tol = self.opts.event_tol
        known: dict[float, float] = {}
        warm = self.margin_hint.get("warm") or {}
        state = (warm.get("active"), warm.get("lam"), warm.get("tau"))
        if state[0] is not None and self.eq.dropped:
            eq = self.eq

            def extension(s: float) -> float | None:
                got = held_margin_extension(eq, s, np.asarray(interp(s), float), state)
                return None if got is None else got + MARGIN_SLACK

            tp = _illinois_root(extension, t_old, t_new, fa, fb, PREDICTED_BRACKET)
            if tp is not None:
                bracket = _bracket_near(fun, tp, t_old, t_new, fa, fb, known,
                                        max(PREDICTED_BRACKET, tol))
                if bracket is not None:
                    return locate_crossing(fun, *bracket, tol, known)
        return locate_crossing(fun, t_old, t_new, fa, fb, tol, known)


def _illinois_root(f, ta: float, tb: float, fa: float, fb: float, xtol: float,
                   max_iter: int = 30) -> float | None:
    """A zero of ``f`` in (ta, tb) by the Illinois method (regula falsi, the retained end's
    value halved) from the ends' values ``fa > 0 >= fb`` (the margin's own at ta: ``f``
    there is not computed; a predictor needs no more), to ``xtol`` in time or a value below
    1e-10; None where ``f`` gives None or the ends do not change sign."""
    if not (fa > 0.0 >= fb):
        return None
    a, b = ta, tb
    side = 0
    for _ in range(max_iter):
        x = b - fb * (b - a) / (fb - fa)
        if not a < x < b:
            x = 0.5 * (a + b)
        fx = f(x)
        if fx is None:
            return None
        if abs(fx) <= 1e-10 or b - a <= xtol:
            return x
        if fx > 0.0:
            a, fa = x, fx
            if side == 1:
                fb *= 0.5
            side = 1
        else:
            b, fb = x, fx
            if side == -1:
                fa *= 0.5
            side = -1
    return None


def _bracket_near(fun, tp: float, ta: float, tb: float, fa: float, fb: float,
                  known: dict, width: float, tries: int = 8):
    """(a, b, fun(a), fun(b)) with fun(a) > 0 >= fun(b), a and b within ``width`` (widened
    tenfold up to ``tries`` times) of tp, inside [ta, tb]; None where none is found so.
    Values computed are added to ``known``."""
    def value(x: float) -> float:
        if x == ta:
            return fa
        if x == tb:
            return fb
        v = known.get(x)
        if v is None:
            v = known[x] = fun(x)
        return v
    x = min(max(tp, ta), tb)
    fx = value(x)
    step = width
    for _ in range(tries):
        if fx > 0.0:
            y = min(x + step, tb)
            fy = value(y)
            if fy <= 0.0:
                return x, y, fx, fy
            x, fx = y, fy
        else:
            y = max(x - step, ta)
            fy = value(y)
            if fy > 0.0:
                return y, x, fy, fx
            x, fx = y, fy
        if x in (ta, tb):
            return None
        step *= 10.0
    return None
