"""The batch API's results: :class:`ContactBatch` (from (W, v)) and :class:`ImpactBatch`
(from (M, Jc, dq)), frozen dataclasses whose fields carry
:class:`~convimpact.impact.results.ImpactResult`'s names as arrays over the batch."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping

import numpy as np

from .checks import OK, REGIMES, STATUS_NAMES, _kernel_error
from ...errors import ConvImpactError


class _BatchStatus:
    """What both batch results answer from their ``impulse``, ``status`` and ``regime``."""

    def __len__(self) -> int:
        return self.impulse.shape[0]

    @property
    def ok(self) -> np.ndarray:
        """(N,) bool: the kernel solved the item."""
        return self.status == OK

    @property
    def failed(self) -> np.ndarray:
        """Indices of the items the kernel rejected."""
        return np.flatnonzero(self.status != OK)

    def regimes(self) -> tuple[str, ...]:
        """Regime names per item ("failed" where the kernel rejected it)."""
        names = REGIMES + ("failed",)
        return tuple(names[int(r)] for r in self.regime)


@dataclass(frozen=True, eq=False)
class ContactBatch(_BatchStatus):
    """Impulses of N contacts from (W, v) (:func:`contact_impulses`).

    Attributes
    ----------
    impulse : (N, d) contact-frame impulses, normal first (NaN where the kernel failed).
    regime : (N,) int8 indices into :data:`REGIMES` (-1 = failed).
    status : (N,) int8 :data:`OK`, :data:`SINGULAR`, :data:`JAM` or :data:`NO_SOLUTION`.
    effective_mass : (N,) the sliding denominator c_n^T G (c_n + mu c_t) where a Newton law
        slid (ContactSolution.effective_mass), NaN elsewhere.
    v_plus : (N, d) post-impact contact velocity v + W pi.
    energy_loss : (N,) T_L = -(pi.v + 1/2 pi.W.pi).
    law : the impact law.
    """

    impulse: np.ndarray
    regime: np.ndarray
    status: np.ndarray
    effective_mass: np.ndarray
    v_plus: np.ndarray
    energy_loss: np.ndarray
    law: str
    _errors: Mapping[int, ConvImpactError] = field(default=None, repr=False)

    regime_names: ClassVar[tuple[str, ...]] = REGIMES



@dataclass(frozen=True, eq=False)
class ImpactBatch(_BatchStatus):
    """N single-contact impacts resolved at once (:func:`resolve_impacts`).

    The fields carry :class:`~convimpact.impact.results.ImpactResult`'s names (and its
    diagnostics' flags) as arrays over the batch; item i equals ``resolve_impact(M[i], Jc[i],
    dq[i], e[i], mu[i], law=law, method="fast")`` to round-off.

    Attributes
    ----------
    dq_plus : (N, k) joint velocities after impact.
    impulse : (N, d) contact-frame impulses, normal first.
    regime : (N,) int8 indices into :data:`REGIMES` ("separating", "frictionless", "stick",
        "slide"); -1 where the kernel rejected the impact.
    energy_loss : (N,) T- - T+ (eq. 58).
    v_minus, v_plus : (N, d) contact velocities before and after impact.
    law, method : the impact law, and "fast" (the exact single-contact kernels).
    energy_before, energy_after : (N,) T- and T+.
    energy_gained, friction_pushes_slip, slip_reversal, penetration : (N,) bool, the flags of
        ImpactDiagnostics (False where the kernel rejected the impact).
    effective_mass : (N,) the sliding denominator c_n^T M^-1 (c_n + mu c_t) where a Newton
        law slid (ImpactDiagnostics.effective_mass), NaN elsewhere.
    delassus : (N, d, d) W = Jc M^-1 Jc^T of each impact.
    status : (N,) int8 :data:`OK` or the reason the kernel rejected the impact
        (:data:`SINGULAR`, :data:`JAM`, :data:`NO_SOLUTION`); those items hold NaN.
    jacobian, impulse_jacobian : read-only mappings or None
        With ``derivatives=True``: ImpactResult's jacobians stacked over the batch, shape
        ``(N,) + `` one item's (``"dq"`` (N, k, k), ``"M"`` (N, k, k, k), ``"Jc"``
        (N, k, d, k), ``"e"``, ``"mu"`` (N, k) for dq_plus; (N, d, ...) for the impulse);
        NaN for a rejected item. None when not asked.
    one_sided : (N,) bool or None
        With ``derivatives=True``: whether item i's derivative is one-sided (a mode boundary;
        ``resolve_impact(..., derivatives="both")`` on that item gives the statement and the
        other side).
    """

    dq_plus: np.ndarray
    impulse: np.ndarray
    regime: np.ndarray
    energy_loss: np.ndarray
    v_minus: np.ndarray
    v_plus: np.ndarray
    law: str
    method: str
    energy_before: np.ndarray
    energy_after: np.ndarray
    energy_gained: np.ndarray
    friction_pushes_slip: np.ndarray
    slip_reversal: np.ndarray
    penetration: np.ndarray
    effective_mass: np.ndarray
    delassus: np.ndarray
    status: np.ndarray
    jacobian: Mapping[str, np.ndarray] | None = field(default=None, repr=False)
    impulse_jacobian: Mapping[str, np.ndarray] | None = field(default=None, repr=False)
    one_sided: np.ndarray | None = field(default=None, repr=False)
    _errors: Mapping[int, ConvImpactError] = field(default=None, repr=False)
    _friction: Any = field(default=None, repr=False)  # effective mu per item (error())
    _restitution: Any = field(default=None, repr=False)
    _tangential: Any = field(default=None, repr=False)  # e_t per item (error())

    regime_names: ClassVar[tuple[str, ...]] = REGIMES
    status_names: ClassVar[Mapping[int, str]] = STATUS_NAMES

    @property
    def normal_impulse(self) -> np.ndarray:
        return self.impulse[:, 0]

    @property
    def tangential_impulse(self) -> np.ndarray:
        return self.impulse[:, 1:]


    def error(self, i: int) -> ConvImpactError | None:
        """The typed error ``resolve_impact(..., method="fast")`` raises for impact i (None
        if it was solved)."""
        i = int(i)
        if self.status[i] == OK:
            return None
        if self._errors and i in self._errors:
            return self._errors[i]
        et = 0.0 if self._tangential is None or not len(self._tangential) \
            else float(self._tangential[i])
        return _kernel_error(self.delassus[i], self.v_minus[i], float(self._restitution[i]),
                             float(self._friction[i]), self.law, int(self.status[i]), i,
                             len(self), et)

    def as_dict(self) -> dict[str, Any]:
        """Plain-JSON view (lists; NaN stays NaN)."""
        out: dict[str, Any] = {}
        for name in ("dq_plus", "impulse", "regime", "energy_loss", "v_minus", "v_plus",
                     "energy_before", "energy_after", "energy_gained", "friction_pushes_slip",
                     "slip_reversal", "penetration", "effective_mass", "status"):
            out[name] = getattr(self, name).tolist()
        out.update(law=self.law, method=self.method, regime_names=list(REGIMES),
                   status_names={str(k): v for k, v in STATUS_NAMES.items()})
        return out
