"""Checks shared by every simulation scheme: time span, integrator, a consistent start.

The event-driven, Moreau-Jean and compliant schemes all start the same way: a time span that
increases, a named scipy integrator, and an initial state on Psi = 0 with C theta_dot = 0
(eqs. 6-7) that does not penetrate any contact. The two schemes that call an impact law also
check its parameters beyond e and mu (:func:`law_options`: the tangential restitution of
law ``"chatterjee-ruina"``) before the first step.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK23, RK45, OdeSolver, Radau

from ..errors import (
    LoopConstraintError,
    NonFiniteError,
    PenetrationError,
    ShapeError,
    UnknownOptionError,
)
from .projection import project_positions, project_velocities

INTEGRATORS: dict[str, type[OdeSolver]] = {
    "RK45": RK45, "RK23": RK23, "DOP853": DOP853, "Radau": Radau, "BDF": BDF, "LSODA": LSODA,
}
#: relative tolerance on C theta_dot = 0 for the initial velocities
INITIAL_VELOCITY_RTOL = 1e-8


def integrator_class(integrator) -> type[OdeSolver]:
    """A scipy ``OdeSolver`` class from its name (or the class itself)."""
    if isinstance(integrator, str):
        if integrator not in INTEGRATORS:
            raise UnknownOptionError(
                f"unknown integrator {integrator!r}; choose one of {', '.join(INTEGRATORS)}")
        return INTEGRATORS[integrator]
    if isinstance(integrator, type) and issubclass(integrator, OdeSolver):
        return integrator
    raise UnknownOptionError("integrator must be a name or a scipy OdeSolver subclass")


def law_options(law: str, impact_options: Mapping[str, Any] | None,
                contacts: Sequence[str]) -> tuple[dict[str, Any], dict[str, float] | None]:
    """Split ``impact_options`` into the solver options and the law's tangential restitution
    per contact, checked before any step.

    ``impact_options["e_t"]`` is the tangential restitution of law ``"chatterjee-ruina"``
    (:mod:`convimpact.impact.laws.chatterjee_ruina`): one value in [-1, 1] for every contact,
    or a mapping from contact names to values (contacts left out take the law's default, 0).
    Given with another law it raises :class:`UnknownOptionError` naming the law that has one;
    a value outside [-1, 1] (where the law creates energy) raises ``ParameterError``.

    Returns
    -------
    (options, e_t)
        The other options (forwarded to ``resolve_impact`` as they are) and ``{contact:
        e_t}``, or None when ``e_t`` is not given (the law's default applies).
    """
    from ..impact.laws import TANGENTIAL_LAWS
    from ..impact.problem.build import check_tangential_restitution

    from ..validation import mapping

    options = mapping("impact_options", impact_options)
    if "e_t" not in options:
        return options, None
    e_t = options.pop("e_t")
    if law not in TANGENTIAL_LAWS:
        raise UnknownOptionError(
            f"impact_options e_t is the tangential restitution of law "
            f"{', '.join(map(repr, TANGENTIAL_LAWS))}; law {law!r} has none: drop e_t or "
            f"pass law={TANGENTIAL_LAWS[0]!r}")
    if isinstance(e_t, Mapping):
        unknown = [c for c in e_t if c not in contacts]
        if unknown:
            raise UnknownOptionError(
                f"impact_options e_t names unknown contact(s) {', '.join(map(repr, unknown))}; "
                f"the contacts: {', '.join(contacts)}")
        values = {c: float(check_tangential_restitution(e_t[c])[0]) for c in e_t}
        return options, {c: values.get(c, 0.0) for c in contacts}
    value = float(check_tangential_restitution(e_t)[0])
    return options, {c: value for c in contacts}


def positive(**values: float) -> None:
    """Raise ParameterError (NonFiniteError) unless every named value is a positive finite
    real number (strings, booleans and complex numbers are refused, not converted)."""
    from ..validation import positive as _positive

    for name, val in values.items():
        _positive(name, val)


def time_span(t_span, scene) -> tuple[float, float]:
    """(t0, t1) from ``t_span``, or (0, scene.t_end) when it is None."""
    from ..validation import time_span as _time_span

    if t_span is None:
        if scene is None:
            raise ShapeError("t_span is required when simulating a bare mechanism")
        return _time_span("t_span (0, scene.t_end)", (0.0, scene.t_end))
    return _time_span("t_span", t_span)


def initial_state(y0, scene, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(theta0, dtheta0) from ``y0`` given as a tuple, or from the scene when ``y0`` is None."""
    if y0 is None:
        if scene is None:
            raise ShapeError("y0 is required when simulating a bare mechanism")
        y0 = (scene.theta0, scene.dtheta0)
    if not (isinstance(y0, tuple) and len(y0) == 2):
        raise ShapeError("y0 must be a tuple (theta0, dtheta0)")
    return state_vector("theta0", y0[0], k), state_vector("dtheta0", y0[1], k)


def state_vector(name: str, v, k: int) -> np.ndarray:
    """A finite vector of k joint values, or ShapeError / NonFiniteError."""
    from ..errors import as_real_array

    a = as_real_array(name, v).ravel()  # a string, boolean or complex entry: ShapeError
    if a.shape != (k,):
        raise ShapeError(f"{name} must have {k} entries (one per joint coordinate), got {a.size}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name} contains NaN or infinity: {a.tolist()}; pass finite values")
    return a


def consistent_start(mech, theta: np.ndarray, dtheta: np.ndarray | None, *, assemble: bool,
                     projection_tol: float, contact_tol: float):
    """Check (or, with ``assemble``, restore) Psi = 0 and C theta_dot = 0, and no penetration.

    ``dtheta`` may be None (a start given as momenta); then only the positions are checked.
    Returns ``(theta, dtheta)``.
    """
    k, m = int(mech.n_coordinates), int(mech.n_loop_constraints)
    if m:
        def loop_rows(th):
            return np.asarray(mech.loop_jacobian(th), float).reshape(m, k)

        err = float(np.max(np.abs(np.asarray(mech.loop_residual(theta), float))))
        if err > projection_tol:
            if not assemble:
                raise LoopConstraintError(
                    f"the initial theta violates the loop constraints: max |Psi| = {err:.3e} "
                    f"(> {projection_tol:.1e}); assemble it first or pass assemble=True")
            theta, _, _ = project_positions(mech.loop_residual, loop_rows,
                                            mech.mass_matrix(theta), theta, projection_tol)
        if dtheta is not None:
            C = loop_rows(theta)
            cdq = float(np.linalg.norm(C @ dtheta))
            scale = float(np.linalg.norm(C)) * max(float(np.linalg.norm(dtheta)), 1e-300)
            if cdq > INITIAL_VELOCITY_RTOL * scale:
                if not assemble:
                    raise LoopConstraintError(
                        f"the initial theta_dot violates C theta_dot = 0 (eq. 7): |C theta_dot| "
                        f"= {cdq:.3e}; give consistent velocities or pass assemble=True")
                dtheta = project_velocities(np.asarray(mech.mass_matrix(theta), float), C, dtheta)
    for c in mech.contact_names:
        g = float(mech.contact_gap(c, theta))
        if not np.isfinite(g):
            raise NonFiniteError(f"the gap of contact {c!r} is not finite at the initial state")
        if g < -contact_tol:
            raise PenetrationError(
                f"the initial state penetrates contact {c!r} (gap {g:.3e} < -contact_tol = "
                f"{-contact_tol:.1e}); start with the contact open or touching")
    return theta, dtheta
