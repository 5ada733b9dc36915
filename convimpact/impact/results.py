"""Result types of an impact resolution (small frozen dataclasses, the paper's names spelled out)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from types import MappingProxyType
from typing import Any, Mapping, Union

import numpy as np

Regime = str  # "separating", "frictionless", "stick" or "slide"

#: default tolerances used by :meth:`ImpactDiagnostics.held` (relative residuals)
DEFAULT_HOLD_TOL = 1e-6


#: the diagnostics measured on first access (all at once), in the order of :meth:`as_dict`
MEASURED = ("energy_before", "energy_after", "energy_gained", "friction_pushes_slip",
            "slip_reversal", "penetration", "restitution_residual", "cone_violation",
            "coulomb_residual", "loop_residual", "momentum_residual")


def _measured(name: str, doc: str) -> property:
    def get(self):
        return self._values[name]

    get.__name__ = name
    return property(get, doc=doc)


def _condition(matrix) -> float:
    """2-norm condition number of ``matrix`` (or of ``matrix()``, a matrix built on first
    access); 1.0 for None."""
    if callable(matrix):
        matrix = matrix()
    return float(np.linalg.cond(matrix)) if matrix is not None else 1.0


@dataclass(frozen=True, eq=False, repr=False)
class ImpactDiagnostics:
    """What the impact law did, measured on its answer.

    Flags (booleans) say when the law misbehaved; residuals (relative, dimensionless, >= 0)
    say how well each physical property held. A residual of 0 means exactly held. Every
    threshold is relative to the data's own scales (impulses, velocities, energies), so
    changing the units of M and dq changes no flag.

    Everything below except ``effective_mass``, ``warnings``' solver part and ``extras`` is
    measured on first access -- all at once, then cached -- so an impact solve does not pay
    for diagnostics nobody reads; the condition numbers are computed on their own first access.

    Attributes
    ----------
    energy_before, energy_after : float
        Kinetic energies T- and T+ (eq. 58); ``inf`` where T itself exceeds double precision's
        range (the warnings say so).
    energy_gained : bool
        T+ > T- beyond round-off: the law created energy.
    friction_pushes_slip : bool
        Some contact's tangential impulse points along its pre-impact slip (pi_t . v_t- > 0).
    slip_reversal : bool
        Some sliding contact ends with a slip the friction impulse does not oppose
        (pi_t . v_t+ > 0): the slide assumption of the law reversed itself.
    penetration : bool
        Some contact still approaches after the impact (v_n+ < 0): the law drives it into
        penetration (e.g. Poisson scaling of coupled contacts in the dissipative law).
    effective_mass : float or None
        The sliding denominator c_n^T M^-1 (c_n + mu c_t) of eq. (38)/(51) when a slide branch
        of the closed form was taken (its inverse is an effective mass); None otherwise.
    delassus_condition : float
        2-norm condition number of the Delassus matrix W = Jc G Jc^T.
    loop_condition : float or None
        Condition number of C M^-1 C^T (closed loops), None for open loops.
    mass_condition : float
        Condition number of M.
    restitution_residual : float
        Max over contacts of |v_n+ + e v_n-| / |v_n-| where the contact carries an impulse, and
        of the negative part of (v_n+ + e v_n-) where it carries none (separation condition);
        for law "stronge" (energetic restitution) instead max |W_r + e^2 W_c| / |W_c| over the
        normal impulse's works in compression W_c and restitution W_r stated in ``extras``.
    cone_violation : float
        Max over contacts of max(0, |pi_t| - mu pi_n, -pi_n) / |pi|.
    coulomb_residual : float
        Max over contacts of |pi_t + mu pi_n u_t/|u_t|| / |pi| for contacts that slip after
        impact (u_t = v_t+): zero when friction opposes the post-impact slip at full strength.
    loop_residual : float
        |C theta_dot+| relative to |C|_F |theta_dot-| (eq. 43).
    momentum_residual : float
        |M Delta theta_dot - Jc^T pi - C^T Delta sigma| relative to |Jc^T pi| (eqs. 33, 44).
    warnings : tuple of str
        Human-readable statements: the solver's and the data's (``notes``), then one per flag
        raised.
    notes : tuple of str
        The statements made when the result was built (solver path, data).
    extras : mapping
        Law-specific figures (e.g. the CCP normal-velocity lift, sweep angle, iterations).
    """

    effective_mass: float | None = None
    notes: tuple[str, ...] = ()
    extras: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    # the measurement: a callable returning the MEASURED values and "flag_warnings" (or
    # such a mapping itself), evaluated on first access
    _source: Any = field(default=None, repr=False)
    # matrices behind the condition numbers (W, M, C M^-1 C^T), kept for lazy evaluation
    # (or callables returning them)
    _delassus: Any = field(default=None, repr=False)
    _mass: Any = field(default=None, repr=False)
    _loop: Any = field(default=None, repr=False)

    @cached_property
    def _values(self) -> Mapping[str, Any]:
        src = self._source
        if src is None:  # nothing to measure: every property held
            return MappingProxyType({**dict.fromkeys(MEASURED, 0.0), **dict.fromkeys(
                ("energy_gained", "friction_pushes_slip", "slip_reversal", "penetration"),
                False), "flag_warnings": ()})
        return MappingProxyType(dict(src() if callable(src) else src))

    energy_before = _measured("energy_before", "Kinetic energy T- (eq. 58).")
    energy_after = _measured("energy_after", "Kinetic energy T+ (eq. 58).")
    energy_gained = _measured("energy_gained", "T+ > T- beyond round-off.")
    friction_pushes_slip = _measured("friction_pushes_slip", "pi_t . v_t- > 0 somewhere.")
    slip_reversal = _measured("slip_reversal", "A slide ends with unopposed slip.")
    penetration = _measured("penetration", "v_n+ < 0 somewhere.")
    restitution_residual = _measured("restitution_residual", "Newton's law, relative.")
    cone_violation = _measured("cone_violation", "Friction cone violation, relative.")
    coulomb_residual = _measured("coulomb_residual", "Coulomb's post-slip law, relative.")
    loop_residual = _measured("loop_residual", "|C theta_dot+|, relative.")
    momentum_residual = _measured("momentum_residual", "Momentum balance, relative.")

    @property
    def warnings(self) -> tuple[str, ...]:
        """The notes, then a statement of each flag raised."""
        return self.notes + self._values["flag_warnings"]

    def with_notes(self, *notes: str) -> "ImpactDiagnostics":
        """A copy with ``notes`` put before the existing ones (measurements kept)."""
        new = replace(self, notes=(*notes, *self.notes))
        if "_values" in self.__dict__:
            new.__dict__["_values"] = self.__dict__["_values"]
        return new

    @cached_property
    def delassus_condition(self) -> float:
        return _condition(self._delassus)

    @cached_property
    def mass_condition(self) -> float:
        return _condition(self._mass)

    @cached_property
    def loop_condition(self) -> float | None:
        if self._loop is None or np.size(self._loop) == 0:
            return None
        return float(np.linalg.cond(self._loop))

    def held(self, tol: float = DEFAULT_HOLD_TOL) -> dict[str, bool]:
        """Which physical properties held to relative tolerance ``tol``."""
        return {
            "restitution": self.restitution_residual <= tol,
            "friction_cone": self.cone_violation <= tol,
            "friction_opposes_post_slip": self.coulomb_residual <= tol,
            "energy_not_gained": not self.energy_gained,
            "no_penetration": not self.penetration,
            "loop_closed": self.loop_residual <= tol,
            "momentum_balance": self.momentum_residual <= tol,
        }

    def as_dict(self) -> dict[str, Any]:
        """Plain-JSON view."""
        out = {k: getattr(self, k) for k in MEASURED[:6]}
        out["effective_mass"] = self.effective_mass
        out.update((k, getattr(self, k)) for k in MEASURED[6:])
        for k in ("delassus_condition", "loop_condition", "mass_condition"):
            out[k] = getattr(self, k)
        out["warnings"] = list(self.warnings)
        out["extras"] = {k: _jsonable(v) for k, v in self.extras.items()}
        out["held"] = self.held()
        return out

    def __repr__(self) -> str:
        shown = ", ".join(f"{k}={getattr(self, k)!r}" for k in MEASURED)
        return (f"ImpactDiagnostics({shown}, effective_mass={self.effective_mass!r}, "
                f"warnings={self.warnings!r})")


@dataclass(frozen=True, eq=False)
class ImpactResult:
    """Outcome of one impact (the momentum balance of Sections 5-8).

    For a single contact (``Jc`` passed as one matrix) ``impulse``, ``v_minus``, ``v_plus`` have
    shape (d,) and ``regime`` is a string; for several contacts they are stacked with shape
    (n_contacts, d) and ``regime`` is a tuple of strings, one per contact.

    Attributes
    ----------
    dq_plus : (k,) joint velocities after impact, theta_dot+ = theta_dot- + Delta theta_dot.
    impulse : contact-frame impulse, normal first: (pi_n, pi_t) or (pi_n, pi_t1, pi_t2).
    loop_impulse : (m,) internal loop impulses Delta sigma (eq. 44); empty for open loops.
    regime : "separating", "frictionless", "stick" or "slide" (per contact for several).
    energy_loss : T- - T+ (eq. 58); negative when the law gained energy.
    v_minus, v_plus : contact-frame relative velocities before and after impact (eq. 17).
    law, method : the impact law and the solver path that produced this result.
    diagnostics : :class:`ImpactDiagnostics`.
    jacobian : read-only mapping or None
        With ``resolve_impact(..., derivatives=True)``: argument name (``"dq"``, ``"M"``,
        ``"Jc"``, ``"e"``, ``"mu"``, and ``"e_t"`` for law chatterjee-ruina) -> the derivative
        of ``dq_plus`` with respect to it, of shape ``dq_plus.shape + shape of the argument``
        (read-only arrays; see :mod:`convimpact.impact.derivatives`). None when not asked.
    impulse_jacobian : read-only mapping or None
        The same for ``impulse`` (shape ``impulse.shape + shape of the argument``).
    derivatives : :class:`ImpactDerivatives` or None
        How the derivatives were obtained: the mode per contact, the one-sided statements at
        a mode boundary and (``derivatives="both"``) the other side's jacobians.
    """

    dq_plus: np.ndarray
    impulse: np.ndarray
    loop_impulse: np.ndarray
    regime: Union[Regime, tuple[Regime, ...]]
    energy_loss: float
    v_minus: np.ndarray
    v_plus: np.ndarray
    law: str
    method: str
    diagnostics: ImpactDiagnostics
    jacobian: Mapping[str, np.ndarray] | None = None
    impulse_jacobian: Mapping[str, np.ndarray] | None = None
    derivatives: "ImpactDerivatives | None" = None

    @property
    def normal_impulse(self):
        """pi_n (per contact for several contacts)."""
        return self.impulse[..., 0]

    @property
    def tangential_impulse(self):
        """pi_t in the contact frame (per contact for several contacts)."""
        return self.impulse[..., 1:]

    def as_dict(self) -> dict[str, Any]:
        """Plain-JSON view (lists and floats)."""
        return {
            "dq_plus": _jsonable(self.dq_plus),
            "impulse": _jsonable(self.impulse),
            "loop_impulse": _jsonable(self.loop_impulse),
            "regime": self.regime if isinstance(self.regime, str) else list(self.regime),
            "energy_loss": float(self.energy_loss),
            "v_minus": _jsonable(self.v_minus),
            "v_plus": _jsonable(self.v_plus),
            "law": self.law,
            "method": self.method,
            "diagnostics": self.diagnostics.as_dict(),
        }


@dataclass(frozen=True, eq=False)
class ImpactDerivatives:
    """The record of an impact's derivatives (``ImpactResult.derivatives``).

    Attributes
    ----------
    modes : tuple of str
        Per contact, the mode the derivative belongs to ("separating", "frictionless",
        "stick", "slide", or a law's finer name).
    one_sided : tuple of str
        Empty inside a mode. At a mode boundary (the stick limit |pi_t| = mu pi_n, zero
        pre-impact slip under eq. (55), a contact at v_n- = 0, mu = 0), one statement per
        boundary met: ``jacobian`` is then the one-sided derivative of the mode in ``modes``.
    other_modes : tuple of str or None
        At a boundary, with ``derivatives="both"``: the neighbouring mode per contact.
    other_jacobian, other_impulse_jacobian : read-only mappings or None
        At a boundary, with ``derivatives="both"``: the derivatives of ``dq_plus`` and
        ``impulse`` on the other side (same keys and shapes as ``jacobian``).
    """

    modes: tuple[str, ...]
    one_sided: tuple[str, ...] = ()
    other_modes: tuple[str, ...] | None = None
    other_jacobian: Mapping[str, np.ndarray] | None = None
    other_impulse_jacobian: Mapping[str, np.ndarray] | None = None

    @property
    def at_boundary(self) -> bool:
        """Whether the derivative is one-sided (a mode boundary was met)."""
        return bool(self.one_sided)


def _jsonable(v):
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (np.floating, np.integer, np.bool_)):
        return v.item()
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, Mapping):
        return {str(k): _jsonable(x) for k, x in v.items()}
    return v


def _fields_as_json(obj) -> dict[str, Any]:
    """A dataclass's fields as plain JSON, non-finite floats as None."""
    out = {}
    for k in obj.__dataclass_fields__:
        v = getattr(obj, k)
        if isinstance(v, np.ndarray) and v.dtype.kind == "f":
            v = np.where(np.isfinite(v), v, None)
        out[k] = _jsonable(v)
    return out
