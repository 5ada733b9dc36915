"""Book-keeping of an event-driven run's contacts: the mode timeline, the per-sample contact
series, Painleve events, and the velocity projection onto possibly redundant constraints."""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
import scipy.linalg as sla

from .canonical import CanonicalEquations
from .result import MODE_NAMES, ModeInterval, PainleveEvent


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


def contact_rows(rows: Mapping[str, list], contacts: Sequence[str], eq: CanonicalEquations,
                 forces: Mapping[str, np.ndarray], d: int) -> None:
    """Append one sample's number of held contacts, mode codes and contact-frame forces."""
    rows["held"].append(len(eq.held))
    codes, values = [], []
    for c in contacts:
        if c in eq.held:
            kind = eq.modes[c].kind
            codes.append(MODE_NAMES.index("stick" if kind == "stick" else "slip"))
            f = np.zeros(d)
            f[:len(forces[c])] = forces[c]
            values.append(f)
        else:
            codes.append(0)
            values.append(np.zeros(d))
    rows["mode"].append(codes)
    rows["force"].append(values)


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
    if C.shape[0] == 0:
        return dtheta.copy()
    cho = sla.cho_factor(M, lower=True)
    A = sla.cho_solve(cho, C.T)
    lam = np.linalg.lstsq(C @ A, C @ dtheta, rcond=1e-12)[0]
    return dtheta - A @ lam
