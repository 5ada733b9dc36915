"""Detection of accumulating (Zeno) impacts of a bouncing contact with e < 1.

A contact bouncing on a fixed surface under a constant normal acceleration a and restitution e
has impact times whose intervals shrink geometrically, Delta_{j+1} = e Delta_j, so infinitely
many impacts accumulate before the finite time

    t_inf = t_j + Delta_j r / (1 - r),      r = Delta_j / Delta_{j-1}  (= e),

(for a particle dropped with impact speed v_1 at t_1: t_inf = t_1 + 2 e v_1 / (a (1 - e))).

Policy (documented in :func:`convimpact.simulation.simulate`): a contact is declared
accumulating when, over its last three impacts, the interval ratio r is in (0, 1) and the
remaining time Delta_j r / (1 - r) is at most ``time_tol`` -- or when its post-impact
separation speed is at most ``rest_velocity`` (at rest). A contact at rest is always switched
to *persistent*: the impact is redone with e = 0 and the gap is held closed as a bilateral
constraint (frictionless in the tangent plane) until its normal force would turn tensile.
For an accumulation the simulator does the same (``zeno="persist"``, default) or stops with
a report (``zeno="stop"``). Either way the run cannot stall: the number of impacts is also
bounded by ``max_impacts``.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Accumulation:
    """Verdict for one contact at one impact.

    Attributes
    ----------
    accumulating : True when the contact should stop bouncing.
    reason : why (empty when not accumulating).
    kind : "rest" (separation speed below ``rest_velocity``: the contact is held whatever the
        policy) or "accumulation" (geometric sequence: held or stop, per the policy).
    ratio : last interval ratio r (None with fewer than three impacts).
    limit_time : extrapolated accumulation time t_inf (None without a geometric sequence).
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
        if len(ts) >= 3:
            d1, d2 = ts[-2] - ts[-3], ts[-1] - ts[-2]
            if d1 > 0.0 and 0.0 <= d2 < d1:
                ratio = d2 / d1
                limit = ts[-1] + d2 * ratio / (1.0 - ratio)
        if separation_speed <= self.rest_velocity:
            return Accumulation(True, f"separation speed {separation_speed:.3e} <= rest_velocity "
                                f"{self.rest_velocity:.1e}", "rest", ratio, limit)
        if limit is not None and limit - ts[-1] <= self.time_tol:
            return Accumulation(
                True, f"impacts accumulate geometrically (interval ratio {ratio:.4f}); "
                f"extrapolated accumulation time t_inf = {limit:.9g}, "
                f"{limit - ts[-1]:.3e} s ahead (<= zeno_time_tol {self.time_tol:.1e})",
                "accumulation", ratio, limit)
        return Accumulation(False, "", "", ratio, limit)
