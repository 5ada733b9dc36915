"""Detection of accumulating (Zeno) impacts of a bouncing contact with e < 1.

A contact bouncing on a fixed surface under a constant normal acceleration a and restitution e
has impact times whose intervals shrink geometrically, Delta_{j+1} = e Delta_j, so infinitely
many impacts accumulate before the finite time

    t_inf = t_j + Delta_j r / (1 - r),      r = Delta_j / Delta_{j-1}  (= e),

(for a particle dropped with impact speed v_1 at t_1: t_inf = t_1 + 2 e v_1 / (a (1 - e))).

Why several ratios: a single ratio proves nothing. A rotating body often taps the floor twice
in quick succession (rebound, the rotation brings the same point back down a fraction of a
millisecond later): two intervals with ratio 1e-4 then 6e-4, which a two-interval test reads
as a sequence converging within microseconds, although the body then flies off. For the
bounce model above the ratio is *exactly* e at every impact (Delta_j = 2 v_j / a and
v_{j+1} = e v_j), and for a body whose normal acceleration varies slowly over the shrinking
intervals it tends to e. So a contact is declared accumulating only when its last
``MIN_RATIOS`` (three) consecutive interval ratios all lie in ``RATIO_BAND`` (0.05, 0.98) and
agree: (max - min) / mean < ``RATIO_SPREAD`` (0.2). Then t_inf is extrapolated from the last
ratio and the contact is held when t_inf - t_j <= ``time_tol``. Restitutions below 0.05 are
not recognised as geometric (their sequence reaches ``rest_velocity`` after a few impacts);
above 0.98 the sequence is too slow to extrapolate and ``max_impacts`` bounds the run.

The default ``time_tol`` (see :func:`convimpact.simulation.simulate`) is absolute,
``1e6 * event_tol`` (1e-6 s by default): it does not depend on the length of the time span,
so the same bounce sequence is held after the same impact whatever ``t_end`` is.

Policy (documented in :func:`convimpact.simulation.simulate`): a contact is declared
accumulating as above -- or when its post-impact separation speed is at most
``rest_velocity`` (at rest). A contact at rest is always switched to *persistent*: the impact
is redone with e = 0 and the gap is held closed as a bilateral constraint until its normal
force would turn tensile. For an accumulation the simulator does the same
(``zeno="persist"``, default) or stops with a report (``zeno="stop"``). Either way the run
cannot stall: the number of impacts is also bounded by ``max_impacts``.

Limitation -- a held contact carries no friction: it is bilateral in the normal direction and
frictionless in the tangent plane (sustained Coulomb sliding is not modelled). A held contact
with mu > 0 that slides therefore keeps its tangential speed without dissipation; the
simulator reports this in ``SimulationResult.warnings`` (duration and max slip speed).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

#: consecutive interval ratios that must agree before an accumulation is declared
MIN_RATIOS = 3
#: open band each of those ratios must lie in (a bounce sequence has ratio e)
RATIO_BAND = (0.05, 0.98)
#: max relative spread (max - min) / mean of those ratios
RATIO_SPREAD = 0.2


@dataclass(frozen=True)
class Accumulation:
    """Verdict for one contact at one impact.

    Attributes
    ----------
    accumulating : True when the contact should stop bouncing.
    reason : why (empty when not accumulating).
    kind : "rest" (separation speed below ``rest_velocity``: the contact is held whatever the
        policy) or "accumulation" (geometric sequence: held or stop, per the policy).
    ratio : last interval ratio r (None with fewer than MIN_RATIOS + 2 impacts).
    limit_time : extrapolated accumulation time t_inf (None unless the last MIN_RATIOS ratios
        are consistent, see the module docstring).
    """

    accumulating: bool
    reason: str = ""
    kind: str = ""
    ratio: float | None = None
    limit_time: float | None = None


@dataclass
class AccumulationDetector:
    """Keeps the impact times of each contact and judges accumulation.

    Parameters
    ----------
    time_tol : remaining-time threshold on the geometric extrapolation (s).
    rest_velocity : separation speed below which a contact is considered at rest.
    """

    time_tol: float
    rest_velocity: float
    times: dict[str, list[float]] = field(default_factory=dict)

    def record(self, contact: str, t: float) -> None:
        self.times.setdefault(contact, []).append(float(t))

    def forget(self, contact: str) -> None:
        """Start a fresh sequence (after the contact was released)."""
        self.times.pop(contact, None)

    def check(self, contact: str, separation_speed: float) -> Accumulation:
        """Judge ``contact`` right after an impact recorded with :meth:`record`."""
        ts = self.times.get(contact, [])
        ratio = limit = None
        consistent = False
        if len(ts) >= MIN_RATIOS + 2:
            d = np.diff(np.asarray(ts[-(MIN_RATIOS + 2):], float))
            if np.all(d[:-1] > 0.0) and d[-1] >= 0.0:
                rs = d[1:] / d[:-1]
                ratio = float(rs[-1])
                lo, hi = RATIO_BAND
                if np.all((rs > lo) & (rs < hi)):
                    spread = float((rs.max() - rs.min()) / rs.mean())
                    consistent = spread < RATIO_SPREAD
                if consistent:
                    limit = ts[-1] + d[-1] * ratio / (1.0 - ratio)
        if separation_speed <= self.rest_velocity:
            return Accumulation(True, f"separation speed {separation_speed:.3e} <= rest_velocity "
                                f"{self.rest_velocity:.1e}", "rest", ratio, limit)
        if limit is not None and limit - ts[-1] <= self.time_tol:
            return Accumulation(
                True, f"impacts accumulate geometrically (last {MIN_RATIOS} interval ratios "
                f"consistent, last {ratio:.4f}); extrapolated accumulation time "
                f"t_inf = {limit:.9g}, {limit - ts[-1]:.3e} s ahead "
                f"(<= zeno_time_tol {self.time_tol:.1e})",
                "accumulation", ratio, limit)
        return Accumulation(False, "", "", ratio, limit)

    def judge_impact(self, t: float, separation_speeds: Mapping[str, float],
                     ) -> tuple[list[str], dict[str, float | None], list[str], bool]:
        """Record an impact at ``t`` of the contacts in ``separation_speeds`` (name -> normal
        speed after it) and judge each with :meth:`check`.

        Returns the contacts to hold, their extrapolated accumulation times, the reasons, and
        whether one of them accumulates geometrically (rather than being at rest).
        """
        persist: list[str] = []
        limits: dict[str, float | None] = {}
        reasons = []
        geometric = False
        for c, speed in separation_speeds.items():
            self.record(c, t)
            verdict = self.check(c, speed)
            if verdict.accumulating:
                persist.append(c)
                limits[c] = verdict.limit_time
                reasons.append(f"{c}: {verdict.reason}")
                if verdict.kind == "accumulation":
                    geometric = True
        return persist, limits, reasons, geometric
