"""Derivatives of the one-contact modes the laws share, by implicit differentiation.

Every function returns ``dp``, a (d, P) array: the derivative of the contact's impulse
(normal first) with respect to the flat parameter vector
``theta = (W_00, W_01, ..., W_dd, v_0, ..., v_d-1, e, mu, e_t)`` (P = d^2 + d + 3; W's entries
as independent, which is exact for the contraction with symmetric perturbations, the only one
the contract defines). :func:`contact_derivative` splits it into a
:class:`~convimpact.impact.derivatives.contact.ContactDerivative`.

The modes (c = -(1 + e) v_n, b = ((1 + e) v_n, v_t) the Newton-shifted velocity):

* :func:`frictionless`: ``pi = (c / W_nn) n``;
* :func:`stick`: ``W pi = -((1 + e) v_n, v_t)`` (eq. 42/52);
* :func:`eq55_slide`: ``pi = (c / D) g``, ``g = (1, mu s)``, ``D = W_n . g`` with the tangent s
  fixed (eq. 38/55, the plane);
* :func:`cone_slide`: a slide on the cone boundary ``|pi_t| = mu pi_n`` whose tangent
  t = pi_t/|pi_t| is set by the law's optimality conditions, differentiated as a whole
  (the unknowns pi, the multipliers sigma, lambda):

  - ``"ccp"``: ``W pi + b = sigma (mu, -t)`` (the cone program's KKT conditions);
  - ``"coulomb"``: ``W pi + b = sigma (0, -t)`` (u_n = 0, post-impact slip against t);
  - ``"max-dissipation"``: ``W pi + v - lambda W_n - sigma (mu, -t) = 0`` and
    ``W_n . pi = c`` (stationarity of T_L on the boundary, eq. 60: the program P_N's
    Lagrange conditions, sigma of either sign);
* :func:`mu_zero_column`: at mu = 0 the right derivative with respect to mu of the mode a
  friction law enters for mu > 0 (mu < 0 is outside every law's domain).
"""

from __future__ import annotations

import numpy as np

from .contact import ContactDerivative

#: relative distance of the stick impulse from the cone boundary below which a contact is at
#: the stick limit (its derivative one-sided)
STICK_LIMIT_RTOL = 1e-9


def n_params(d: int) -> int:
    return d * d + d + 3


def seeds(d: int):
    """The derivatives of (W, v, e, mu, e_t) with respect to theta: (d, d, P), (d, P), then
    three (P,) rows."""
    eye = np.eye(n_params(d))
    return (eye[:d * d].reshape(d, d, -1), eye[d * d:d * d + d], eye[-3], eye[-2], eye[-1])


def contact_derivative(dp: np.ndarray, regime: str, tangential: bool = False,
                       one_sided: tuple[str, ...] = (),
                       other: ContactDerivative | None = None,
                       impulse: np.ndarray | None = None) -> ContactDerivative:
    """Split a (d, P) derivative into the contract's fields (one contact); ``impulse``: the
    answer it is taken at when not the result's (an other side)."""
    d = dp.shape[0]
    return ContactDerivative(
        W=np.ascontiguousarray(dp[:, :d * d].reshape(d, d, d)),
        v=np.ascontiguousarray(dp[:, d * d:d * d + d]),
        e=dp[:, -3:-2].copy(), mu=dp[:, -2:-1].copy(),
        e_t=dp[:, -1:].copy() if tangential else None,
        regimes=(regime,), one_sided=tuple(one_sided), other_side=other,
        impulse=None if impulse is None else np.asarray(impulse, dtype=float)[None].copy())


def zero(d: int) -> np.ndarray:
    return np.zeros((d, n_params(d)))


def _dW_times(dW: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(dW p) as (d, P)."""
    return np.einsum("ijP,j->iP", dW, p)


def newton_shift(v: np.ndarray, e: float):
    """b = ((1 + e) v_n, v_t) and its derivative (d, P)."""
    d = v.size
    _, dv, de, _, _ = seeds(d)
    b = np.array(v, dtype=float)
    b[0] *= 1.0 + e
    db = dv.copy()
    db[0] = (1.0 + e) * dv[0] + v[0] * de
    return b, db


def frictionless(W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """pi = (c / W_nn) n, c = -(1 + e) v_n."""
    d = v.size
    dW, dv, de, _, _ = seeds(d)
    p0 = -(1.0 + e) * v[0] / W[0, 0]
    dp = zero(d)
    dp[0] = (-(1.0 + e) * dv[0] - v[0] * de - p0 * dW[0, 0]) / W[0, 0]
    return dp


def stick(W: np.ndarray, v: np.ndarray, e: float, p: np.ndarray) -> np.ndarray:
    """W pi = -b (the stick impulse of the Newton laws: normal restitution, no slip)."""
    d = v.size
    dW = seeds(d)[0]
    _, db = newton_shift(v, e)
    return np.linalg.solve(W, -db - _dW_times(dW, p))


def eq55_slide(W: np.ndarray, v: np.ndarray, e: float, mu: float, s: float) -> np.ndarray:
    """pi = (c / D) (1, mu s), D = W_nn + mu s W_nt, the tangent s = +-1 held fixed."""
    dW, dv, de, dmu, _ = seeds(2)
    g = np.array([1.0, mu * s])
    dg = np.zeros((2, dW.shape[-1]))
    dg[1] = s * dmu
    D = float(W[0] @ g)
    c = -(1.0 + e) * v[0]
    dc = -(1.0 + e) * dv[0] - v[0] * de
    dD = np.einsum("jP,j->P", dW[0], g) + W[0] @ dg
    return np.outer(g, dc / D - c * dD / D ** 2) + (c / D) * dg


def cone_slide(kind: str, W: np.ndarray, v: np.ndarray, e: float, mu: float,
               p: np.ndarray) -> np.ndarray:
    """A boundary slide ``|pi_t| = mu pi_n`` at the answer ``p``, its tangent set by the law's
    conditions (``kind``: "ccp", "coulomb" or "max-dissipation", see the module's docstring),
    differentiated implicitly with its multipliers."""
    d = v.size
    dW, dv, de, dmu, _ = seeds(d)
    P = dW.shape[-1]
    pt = p[1:]
    r = float(np.linalg.norm(pt))
    t = pt / r
    proj = (np.eye(d - 1) - np.outer(t, t)) / r  # d t / d pi_t (zero in the plane)
    cone_row = np.concatenate(([mu], -t))  # d (mu pi_n - |pi_t|) / d pi
    if kind == "max-dissipation":
        w0 = W[:, 0]
        a = np.concatenate(([mu], -t))
        A = np.column_stack([w0, a])
        lam, sigma = np.linalg.lstsq(A, W @ p + v, rcond=None)[0]
        m = d + 2
        Jx = np.zeros((m, m))
        Jx[:d, :d] = W
        Jx[1:d, 1:d] += sigma * proj
        Jx[:d, d] = -a          # sigma
        Jx[:d, d + 1] = -w0     # lambda
        Jx[d, :d] = cone_row
        Jx[d + 1, :d] = W[0]
        dc = -(1.0 + e) * dv[0] - v[0] * de
        F = np.zeros((m, P))
        F[:d] = _dW_times(dW, p) + dv - lam * dW[:, 0]
        F[0] -= sigma * dmu
        F[d] = p[0] * dmu
        F[d + 1] = np.einsum("jP,j->P", dW[0], p) - dc
    else:
        b, db = newton_shift(v, e)
        kappa = mu if kind == "ccp" else 0.0
        a = np.concatenate(([kappa], -t))
        u = W @ p + b
        sigma = float(a @ u) / float(a @ a)
        m = d + 1
        Jx = np.zeros((m, m))
        Jx[:d, :d] = W
        Jx[1:d, 1:d] += sigma * proj
        Jx[:d, d] = -a
        Jx[d, :d] = cone_row
        F = np.zeros((m, P))
        F[:d] = _dW_times(dW, p) + db
        if kind == "ccp":
            F[0] -= sigma * dmu
        F[d] = p[0] * dmu
    return -np.linalg.solve(Jx, F)[:d]


def stick_impulse(W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """The Newton laws' stick impulse, ``W^-1 (-(1 + e) v_n, -v_t)``."""
    b, _ = newton_shift(v, e)
    return np.linalg.solve(W, -b)


def at_stick_limit(ps: np.ndarray, mu: float) -> bool:
    """Whether the stick impulse ``ps`` lies on the cone boundary |pi_t| = mu pi_n (to
    :data:`STICK_LIMIT_RTOL` of |pi|)."""
    scale = float(np.linalg.norm(ps))
    return scale > 0.0 and abs(float(np.linalg.norm(ps[1:])) - mu * ps[0]) <= \
        STICK_LIMIT_RTOL * scale * (1.0 + mu)


def mu_zero_column(kind: str, W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """At mu = 0: the right derivative d pi / d mu of the mode entered for mu > 0.

    The friction impulse appears along the tangent t its law picks as mu -> 0+: eq. (55)'s
    ``-sgn v_t`` in the plane ("eq55", the sign of the stick impulse's pi_t where v_t = 0);
    against the post-impact slip of the frictionless answer, ``u_t = b_t + W_tn pi_n`` (laws
    "ccp", "coulomb"); the maximal-dissipation direction's limit ("max-dissipation", from
    dT_L/dmu at mu = 0: against the plastic frictionless answer's slip,
    ``v_t - W_tn v_n / W_nn``). A contact whose limiting slip is zero sticks: zero. A contact
    whose tangents move no mass has mu forced to 0: zero. Then, with pi = pi_n (1, mu t):
    ``d pi_t / d mu = pi_n t`` and ``d pi_n / d mu = -c W_nt.t / W_nn^2`` (Newton laws:
    W_n . pi = c) or ``-(b_t.t) / W_nn + 2 b_n W_nt.t / W_nn^2`` (ccp: the ray's optimum).
    """
    d = v.size
    A = W[0, 0]
    col = np.zeros(d)
    if not np.diag(W)[1:].max() > 1e-12 * A:  # immobile tangents: mu is not used
        return col
    b, _ = newton_shift(v, e)
    if kind == "eq55":
        if v[1] != 0.0:
            t = np.array([-np.sign(v[1])])
        else:
            ps = stick_impulse(W, v, e)
            if ps[1] == 0.0:
                return col
            t = np.array([np.sign(ps[1])])
    else:
        if kind == "max-dissipation":
            slip = v[1:] - W[1:, 0] * v[0] / A
        else:
            slip = b[1:] - W[1:, 0] * b[0] / A
        size = float(np.linalg.norm(slip))
        if not size > 1e-14 * float(np.linalg.norm(v)):
            return col
        t = -slip / size
    wt = float(W[0, 1:] @ t)
    pn = -b[0] / A
    if kind == "ccp":
        col[0] = -float(b[1:] @ t) / A + 2.0 * b[0] * wt / A ** 2
    else:
        col[0] = -pn * wt / A
    col[1:] = pn * t
    return col
