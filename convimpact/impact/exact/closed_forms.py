"""The paper's closed forms for one contact (Sections 5-8), on its Delassus block.

They act on one contact's Delassus block ``W`` (d x d, d = 2 planar or 3 spatial; for closed
loops it is the Schur complement of the bordered matrices of eqs. (51)/(52), so the same
formulas serve open and closed loops) and its pre-impact contact velocity
``v = (v_n, v_t...)`` in the contact frame. Impulses come back in the contact frame, normal
first; ``v_n < 0`` means approaching.

* :func:`frictionless_impulse`: eq. (38) with mu = 0;
* :func:`sticking_impulse`: eq. (42) / (52), the impulse that stops the slip;
* :func:`sliding_impulse`: eq. (38) / (51) along a given tangent;
* :func:`stick_admissible`: the contact law's test (53);
* :func:`pereira_nikravesh`: the Section 8 algorithm (stick test, else slide; in space the
  sliding direction must be supplied: the paper has no closed form for it).

Plain numpy: these are the cross-check of the exact compiled kernels
(:mod:`convimpact.impact.laws.pereira_nikravesh`), and the public closed forms of
:mod:`convimpact.impact`.
"""

from __future__ import annotations

import numpy as np

from ...errors import (NonPositiveEffectiveMassError, NotSupportedError, SingularSystemError,
                       as_real_array, contact_inputs, real_number)

#: condition number above which W is treated as singular by the sticking solve
DELASSUS_COND_MAX = 1e12
#: relative tolerance of the stick admissibility test |pi_t| <= mu pi_n
STICK_RTOL = 1e-12


def frictionless_impulse(W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """Frictionless (or central) impulse: eq. (38) with mu = 0, pi_n = -(1+e) v_n / m_nn."""
    W, v, e = contact_inputs(W, v, e)
    w_nn = float(W[0, 0])
    if not w_nn > 0.0:
        raise SingularSystemError(
            f"c_n^T M^-1 c_n = {w_nn:.3e}: the contact normal moves no mass in this "
            "configuration (the contact point cannot move along n); no impulse can act there"
        )
    pi = np.zeros(W.shape[0])
    pi[0] = -(1.0 + e) * float(v[0]) / w_nn  # eq. (38), mu = 0
    return pi


def sticking_impulse(W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """Impulse that stops the slip and restitutes the normal velocity: eq. (42) / (52).

    Solves ``W pi = -((1+e) v_n, v_t)``; in space the 3 x 3 analogue with t1, t2.

    Raises
    ------
    SingularSystemError
        when W is singular (contact directions dependent through the mechanism).
    """
    W, v, e = contact_inputs(W, v, e)
    lam = np.linalg.eigvalsh(W)  # W is symmetric positive semi-definite
    cond = lam[-1] / lam[0] if lam[0] > 0 else np.inf
    if not cond < DELASSUS_COND_MAX:
        raise SingularSystemError(
            f"the Delassus matrix W = Jc M^-1 Jc^T is singular (cond = {cond:.3e}): the "
            "contact's tangential and normal motions are dependent here, so the sticking "
            "solve of eq. (42)/(52) has no unique answer; use law='dissipative' or "
            "law='coulomb' with method='cvxpy', which accept a singular W"
        )
    rhs = -np.asarray(v, dtype=float).copy()
    rhs[0] *= 1.0 + e  # eq. (42): right-hand side -(1+e) v_n, -v_t
    return np.linalg.solve(W, rhs)


def sliding_impulse(W: np.ndarray, v: np.ndarray, e: float, mu: float,
                    direction: np.ndarray) -> tuple[np.ndarray, float]:
    """Sliding impulse pi = pi_n (n + mu t) with pi_n from eq. (38) / (51).

    Parameters
    ----------
    direction : (d-1,) unit vector of the friction impulse in the tangent plane (the paper's t).
        ``mu`` may be negative here (the paper's landscapes use it to flip t); the public API
        validates mu >= 0 before calling.

    Returns
    -------
    impulse, effective_mass_denominator
        ``c_n^T G (c_n + mu c_t)``, the denominator of eq. (38).

    Raises
    ------
    NonPositiveEffectiveMassError
        when that denominator is not positive (Painleve-like jam): no finite compressive
        normal impulse slides the contact along t.
    """
    W, v, e, mu = contact_inputs(W, v, e, mu)
    g = np.empty(W.shape[0])
    g[0] = 1.0
    g[1:] = mu * np.asarray(direction, dtype=float)
    denom = float(W[0] @ g)  # c_n^T M^-1 (c_n + mu c_t), eq. (38)
    if not denom > 1e-12 * float(np.max(np.abs(W))):
        coupling = float(W[0, 1:] @ np.asarray(direction, dtype=float))
        crit = (f"; sliding along t is well posed for mu < {W[0, 0] / -coupling:.6g}"
                if coupling < 0 else "")
        raise NonPositiveEffectiveMassError(
            f"sliding denominator c_n^T M^-1 (c_n + mu c_t) = {denom:.3e} <= 0 at mu = {mu:g} "
            f"(Painleve-like jam: eq. (38) would divide by it){crit}; use law='coulomb', "
            "'ccp' or 'dissipative', which stay well posed"
        )
    return (-(1.0 + e) * float(v[0]) / denom) * g, denom


def stick_admissible(impulse: np.ndarray, mu: float, rtol: float = STICK_RTOL) -> bool:
    """Contact law (53): the stick impulse lies in the friction cone, |pi_t| <= mu pi_n."""
    impulse = as_real_array("impulse", impulse)
    mu = real_number("mu", mu)
    pn = float(impulse[0])
    return pn >= 0.0 and float(np.linalg.norm(impulse[1:])) <= mu * pn * (1.0 + rtol)


def planar_slide_direction(v: np.ndarray, stick_impulse: np.ndarray | None) -> np.ndarray:
    """Tangent of the friction impulse in the plane: opposite to v_t- (eq. 55).

    With no pre-impact slip (v_t- = 0) eq. (55) is undefined; the friction then saturates in
    the direction the sticking impulse needed (sign of its pi_t).
    """
    vt = float(v[1])
    if vt != 0.0:
        return np.array([-np.sign(vt)])
    s = float(np.sign(stick_impulse[1])) if stick_impulse is not None else 0.0
    return np.array([s if s != 0.0 else 1.0])


def pereira_nikravesh(W: np.ndarray, v: np.ndarray, e: float, mu: float,
                      slide_direction=None) -> tuple[np.ndarray, str, float | None]:
    """The Section 8 algorithm for one approaching contact.

    1. Solve the sticking problem (eq. 42/52). 2. If |pi_t| <= mu pi_n, stick (eq. 53).
    3. Otherwise slide on the cone boundary with pi_n from eq. (38)/(51): in the plane along
    t = -v_t-/|v_t-| (eq. 55); in space along ``slide_direction(W, v, e, mu)`` (the
    maximal-dissipation direction; the closed form alone has none and raises).

    Returns
    -------
    impulse, regime, sliding denominator (None unless sliding)
    """
    W, v, e, mu = contact_inputs(W, v, e, mu)
    if mu == 0.0:
        return frictionless_impulse(W, v, e), "frictionless", None
    stick = sticking_impulse(W, v, e)
    if stick_admissible(stick, mu):
        return stick, "stick", None
    if W.shape[0] == 2:
        direction = planar_slide_direction(v, stick)
    elif slide_direction is None:
        raise NotSupportedError(
            "spatial sliding needs the maximal-dissipation direction of the tangential "
            "impulse (Section 9.3), which has no closed form in the paper: use "
            "method='fast' (exact), 'cvxpy', 'clarabel' or 'sweep' (the paper's search)"
        )
    else:
        direction = slide_direction(W, v, e, mu)
    impulse, denom = sliding_impulse(W, v, e, mu, direction)
    return impulse, "slide", denom
