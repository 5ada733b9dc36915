"""Hand one impact of any Mechanism to :func:`convimpact.resolve_impact`.

:func:`impact_arguments` evaluates M, the contact Jacobians and the loop Jacobian at the
impact state and returns exactly the keyword arguments of ``resolve_impact``;
:func:`resolve_mechanism_impact` does both steps. Both use only the
:class:`~convimpact.mechanism.Mechanism` protocol, so they work on the joint-coordinate
models of this package, on Pinocchio wrappers and on hand-written mechanisms alike.
"""

from __future__ import annotations

from typing import Sequence, Union

import numpy as np

from ..errors import ModelError, NonFiniteError, ShapeError

#: default tolerance on |gap| for a contact to count as touching
GAP_TOL = 1e-9

Contacts = Union[None, str, Sequence[str]]


def _state(mechanism, value, name: str) -> np.ndarray:
    k = mechanism.n_coordinates
    a = np.asarray(value, dtype=float)
    if a.shape != (k,):
        raise ShapeError(f"{name} must have shape ({k},) for this mechanism, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name} contains NaN or infinity; pass finite values")
    return a


def active_contacts(mechanism, theta, gap_tol: float = GAP_TOL) -> list[str]:
    """Names of the contacts whose gap is at most ``gap_tol`` (touching or penetrating)."""
    theta = _state(mechanism, theta, "theta")
    return [c for c in mechanism.contact_names if mechanism.contact_gap(c, theta) <= gap_tol]


def impact_arguments(mechanism, theta, dtheta, contacts: Contacts = None,
                     gap_tol: float = GAP_TOL, e=None, mu=None) -> dict:
    """The keyword arguments of :func:`convimpact.resolve_impact` for an impact at a state.

    Parameters
    ----------
    mechanism : any :class:`~convimpact.mechanism.Mechanism`.
    theta, dtheta : (k,) joint coordinates and velocities just before the impact.
    contacts : a contact name (then ``Jc`` is one (d, k) array and e, mu scalars), a sequence
        of names (``Jc`` a list), or None for every contact with ``gap <= gap_tol``.
    gap_tol : touching tolerance used when ``contacts`` is None.
    e, mu : override the contacts' own coefficients (scalar or one per contact).

    Returns
    -------
    dict
        ``M``, ``Jc``, ``dq``, ``C`` (None for open trees), ``e`` and ``mu``, ready for
        ``resolve_impact(**args)``.

    Raises
    ------
    ModelError
        For an unknown contact name or when ``contacts`` is None and none is touching.

    Examples
    --------
    The paper's planar double pendulum, case (a), at its impact state:

    >>> import numpy as np, convimpact as ci
    >>> scene = ci.load_scene("pendulum_planar", case="a")
    >>> args = ci.impact_arguments(scene.mechanism, *scene.impact_state, "tip")
    >>> sorted(args), np.round(args["Jc"] @ args["dq"], 3).tolist()
    (['C', 'Jc', 'M', 'dq', 'e', 'mu'], [-1.309, -2.683])
    >>> ci.resolve_impact(**args, law="coulomb").regime
    'stick'
    """
    theta = _state(mechanism, theta, "theta")
    dtheta = _state(mechanism, dtheta, "dtheta")
    single = isinstance(contacts, str)
    if contacts is None:
        names = active_contacts(mechanism, theta, gap_tol)
        if not names:
            gaps = {c: mechanism.contact_gap(c, theta) for c in mechanism.contact_names}
            raise ModelError(f"no contact is touching at this state (gaps {gaps}); name the "
                             "contact(s) explicitly or pass the impact configuration")
    else:
        names = [contacts] if single else list(contacts)
        if not names:
            raise ModelError("contacts is empty; name at least one contact")
        known = set(mechanism.contact_names)
        for c in names:
            if c not in known:
                raise ModelError(f"unknown contact {c!r}; contacts are "
                                 f"{', '.join(mechanism.contact_names) or 'none'}")
    M = np.asarray(mechanism.mass_matrix(theta), dtype=float)
    Jc = [np.asarray(mechanism.contact_jacobian(c, theta), dtype=float) for c in names]
    params = [mechanism.contact_parameters(c) for c in names]
    e_list = [p[0] for p in params] if e is None else np.broadcast_to(e, (len(names),)).tolist()
    mu_list = [p[1] for p in params] if mu is None else np.broadcast_to(mu, (len(names),)).tolist()
    C = None
    if mechanism.n_loop_constraints:
        C = np.asarray(mechanism.loop_jacobian(theta), dtype=float)
    if single:
        return dict(M=M, Jc=Jc[0], dq=dtheta.copy(), C=C, e=float(e_list[0]), mu=float(mu_list[0]))
    return dict(M=M, Jc=Jc, dq=dtheta.copy(), C=C, e=e_list, mu=mu_list)


def resolve_mechanism_impact(mechanism, theta, dtheta, contacts: Contacts = None,
                             law: str = "pereira-nikravesh", method: str = "auto",
                             e=None, mu=None, gap_tol: float = GAP_TOL, **options):
    """Resolve the impact of ``mechanism`` at (theta, theta_dot) with ``resolve_impact``.

    Parameters are those of :func:`impact_arguments` plus ``law``, ``method`` and the
    ``options`` of :func:`convimpact.resolve_impact`: solver options, and the law's parameters
    beyond the contacts' e and mu (``e_t=``, the tangential restitution of law
    ``"chatterjee-ruina"``, refused with the other laws).

    Returns
    -------
    ImpactResult
        As returned by :func:`convimpact.resolve_impact` (``dq_plus`` is theta_dot after).
    """
    from ..impact import resolve_impact

    args = impact_arguments(mechanism, theta, dtheta, contacts, gap_tol, e, mu)
    return resolve_impact(**args, law=law, method=method, **options)
