"""Book-keeping of an event-driven run's contacts: the mode timeline, the per-sample contact
series, Painleve events, and the velocity projection onto possibly redundant constraints."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np
import scipy.linalg as sla

from .canonical import CanonicalEquations
from .result import MODE_NAMES, ModeInterval, PainleveEvent
from .sustained import held_forces


class ModeLog:
    """The per-contact mode timeline: every contact starts "open" at ``t0``."""

    def __init__(self, contacts: Sequence[str], t0: float):
        self.current = {c: ("open", t0) for c in contacts}
        self.closed: list[ModeInterval] = []

    def update(self, t: float, modes: Mapping[str, str]) -> None:
        """The modes from time t on (an unchanged mode continues its interval)."""
        for c, mode in modes.items():
            old, start = self.current[c]
            if mode == old:
                continue
            if t > start:
                self.closed.append(ModeInterval(c, old, start, t))
            self.current[c] = (mode, t)

    def intervals(self, t_end: float) -> tuple[ModeInterval, ...]:
        """Every interval up to ``t_end``, in time order."""
        last = [ModeInterval(c, mode, start, t_end) for c, (mode, start) in self.current.items()]
        return tuple(sorted(self.closed + last, key=lambda iv: (iv.t_start, iv.contact)))


class PendingForces:
    """A recorded sample's held forces, computed on first demand (:meth:`resolve`).

    Recording the exact forces of every sample costs a force-distribution program per
    sample wherever the contacts are redundant; the run needs them only at a segment's
    start (its first margin) and the result only when its ``contact_force`` series is read.
    The sample keeps what :func:`~.sustained.held_forces` reads of its equations (the held
    modes, whose stored slip directions the run updates at every step, and the segment's
    offset), so that the forces computed later are those computed at the sample's time.
    """

    __slots__ = ("eq", "modes", "offset", "t", "y", "key", "forces", "margin")

    def __init__(self, eq: CanonicalEquations, t: float, y: np.ndarray):
        self.eq, self.t = eq, float(t)
        self.modes, self.offset = dict(eq.modes), eq.offset
        self.y = np.array(y, float)
        self.key = self.y.tobytes()
        self.forces: dict[str, np.ndarray] | None = None
        self.margin = np.inf

    def matches(self, eq: CanonicalEquations, t: float, key: bytes) -> bool:
        """Whether this is the sample of ``eq`` at (t, y), y's bytes ``key``."""
        return self.eq is eq and self.t == t and self.key == key

    def resolve(self) -> dict[str, np.ndarray]:
        """The held contacts' forces at the sample (computed once), as
        :func:`~.sustained.held_forces` without a hint; its margin in :attr:`margin`."""
        if self.forces is None:
            eq = self.eq
            modes, offset = eq.modes, eq.offset
            eq.modes, eq.offset = self.modes, self.offset
            try:
                self.forces, self.margin = held_forces(eq, self.t, self.y)
            finally:
                eq.modes, eq.offset = modes, offset
        return self.forces


def contact_rows(rows: Mapping[str, list], contacts: Sequence[str], eq: CanonicalEquations,
                 forces: Mapping[str, np.ndarray] | PendingForces, d: int) -> None:
    """Append one sample's number of held contacts, mode codes and contact-frame forces
    (or, for forces still to compute, their :class:`PendingForces`: see
    :func:`force_series`)."""
    rows["held"].append(len(eq.held))
    codes = []
    for c in contacts:
        if c in eq.held:
            kind = eq.modes[c].kind
            codes.append(MODE_NAMES.index("stick" if kind == "stick" else "slip"))
        else:
            codes.append(0)
    rows["mode"].append(codes)
    rows["force"].append(forces if isinstance(forces, PendingForces)
                         else _force_values(contacts, eq.held, forces, d))


def _force_values(contacts: Sequence[str], held: Sequence[str],
                  forces: Mapping[str, np.ndarray], d: int) -> list[np.ndarray]:
    """One sample's (n_contacts,) forces padded to d entries, zero for the open contacts."""
    values = []
    for c in contacts:
        f = np.zeros(d)
        if c in held:
            f[:len(forces[c])] = forces[c]
        values.append(f)
    return values


def force_series(samples: Sequence, contacts: Sequence[str], d: int) -> np.ndarray:
    """The (n, n_contacts, d) contact forces of recorded samples (:func:`contact_rows`'
    rows), the pending ones computed now."""
    rows = [_force_values(contacts, s.eq.held, s.resolve(), d)
            if isinstance(s, PendingForces) else s for s in samples]
    return np.array(rows, float).reshape(len(rows), len(contacts), d)


def painleve_event(t: float, contacts: Sequence[str], effective_mass: np.ndarray,
                   kind: str, n_solutions: int) -> PainleveEvent:
    """The record of a Painleve paradox met at time t."""
    return PainleveEvent(time=float(t), contacts=tuple(contacts), kind=kind,
                         n_solutions=int(n_solutions),
                         effective_mass=tuple(float(x) for x in effective_mass))


def project_onto(M: np.ndarray, C: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
    """M-orthogonal projection of theta_dot onto ``C theta_dot = 0``, C possibly rank
    deficient (redundant contacts): the frictionless plastic correction of least energy."""
    dtheta = np.asarray(dtheta, float)
    if C.shape[0] == 0 or not np.any(C @ dtheta):  # (already on it: at rest, exactly)
        return dtheta.copy()
    cho = sla.cho_factor(M, lower=True)
    A = sla.cho_solve(cho, C.T)
    lam = np.linalg.lstsq(C @ A, C @ dtheta, rcond=1e-12)[0]
    return dtheta - A @ lam


#: the impact laws' flags gathered over a run, with what each means
LAW_FLAGS = {
    "energy_gained": "the impact law created kinetic energy (T+ > T-)",
    "penetration": "a contact still approached after the impact (v_n+ < 0)",
    "slip_reversal": "a sliding contact's slip ended along its friction impulse",
    "friction_pushes_slip": "a sliding impulse's friction pointed along the pre-impact slip",
}


def law_flags(impacts: Sequence, law: str) -> tuple[dict[str, int], tuple[str, ...]]:
    """Counts of the law's flags over the impacts of a run, and one warning per flag raised.

    ``friction_pushes_slip`` is counted only for impacts with a sliding contact (a sticking
    impulse may point along a small pre-impact slip: it stops it). The energy warning names
    the worst impact (largest T+ - T-).
    """
    counts = {k: 0 for k in LAW_FLAGS}
    worst: dict[str, Any] = {}
    for ev in impacts:
        if ev.result is None:  # a Moreau–Jean step on the contact engine: no law report
            continue
        diag = ev.result.diagnostics
        for k in LAW_FLAGS:
            if not getattr(diag, k):
                continue
            if k == "friction_pushes_slip" and "slide" not in ev.regime:
                continue
            counts[k] += 1
            gain = ev.kinetic_energy_plus - ev.kinetic_energy_minus
            if k not in worst or (k == "energy_gained" and gain > worst[k][1]):
                worst[k] = (ev, gain)
    warnings = []
    for k, n in counts.items():
        if not n:
            continue
        ev, gain = worst[k]
        text = (f"{n} of {len(impacts)} impacts: {LAW_FLAGS[k]} (law {law!r}); ")
        if k == "energy_gained":
            text += (f"the largest at t = {ev.time:.9g} ({', '.join(ev.contacts)}): T from "
                     f"{ev.kinetic_energy_minus:.6g} to {ev.kinetic_energy_plus:.6g} "
                     f"(+{gain:.4g}); law='dissipative' or 'ccp' never create energy")
        else:
            text += f"first at t = {ev.time:.9g} ({', '.join(ev.contacts)})"
        warnings.append(text)
    return counts, tuple(warnings)
