"""The equations of an impact law's contact modes, at one contact or several, and their
derivatives by implicit differentiation.

Inside a mode -- which contacts separate, stick or slide, and which equality constraints and
cone faces are active -- the impulse ``pi`` of a law (with the auxiliary unknowns of its
mode: cone multipliers ``sigma``, equality multipliers ``lambda``) solves a smooth square
system ``F(x; W, v, e, mu) = 0``. Its derivative is

    dx = -F_x^-1 (F_W dW + F_v dv + F_e de + F_mu dmu).

A :class:`ModeSystem` holds the system's rows at the answer, each a :class:`Row`: a linear
form in ``(dx, dW, dv, de, dmu)`` -- the differential of one equation, written by hand:

* :meth:`ModeSystem.unknown` ``x_c`` (an impulse component held at zero, ...);
* :meth:`ModeSystem.velocity` ``u_r = (W pi + b)_r`` with the law's ``b = v + e min(v_n, 0) n``
  (or ``b = v``): ``d u_r = W_r. dpi + pi_j dW_rj + (db_r/dv_r) dv_r + min(v_n, 0) de_i``;
* :meth:`ModeSystem.stationarity` ``y_r = (W (pi - N lambda) + v)_r``, the gradient of the
  program P_N's Lagrangian (``N lambda``: the multipliers of its equalities ``u_n = 0`` on the
  normal rows);
* :meth:`ModeSystem.friction` ``mu_i``;

and the equations the laws share per contact (its methods from ``separating`` to
``planar_slide``). :meth:`ModeSystem.solve` gives the several-contact derivative (the laws'
``several_impulse_derivative``), :meth:`ModeSystem.one_contact` the one-contact one in the
flat layout below.

``W`` derivatives are the partials with respect to the entries ``W_rj`` as they appear in the
equations; contracted with a symmetric ``dW`` they give the derivative the contract of
:class:`~convimpact.impact.derivatives.contact.ContactDerivative` asks for.

**One contact** (the laws' ``impulse_derivative``, driven by :mod:`.single`): the mode
functions below return ``dp``, a (d, P) array: the derivative of the impulse (normal first)
with respect to ``theta = (W_00, W_01, ..., W_dd, v_0, ..., v_d-1, e, mu, e_t)``
(P = d^2 + d + 3); :func:`contact_derivative` splits it into a ``ContactDerivative``. With
``b = ((1 + e) v_n, v_t)`` and ``c = -(1 + e) v_n``: :func:`frictionless`, :func:`stick`
(eq. 42/52), :func:`eq55_slide` (eq. 38/55) and :func:`cone_slide`, the slide on the cone's
boundary of ``"ccp"`` (``W pi + b = sigma (mu, -t)``), ``"coulomb"`` (``W pi + b = sigma (0,
-t)``) or ``"max-dissipation"`` (``W pi + v - lambda W_n - sigma (mu, -t) = 0`` and
``W_n . pi = c``: P_N's Lagrange conditions, eq. 60).
"""

from __future__ import annotations

import numpy as np

from ...errors import NotSupportedError, ParameterError
from .contact import ContactDerivative

#: condition number of the mode's Jacobian above which the impulse is taken as not unique
JACOBIAN_COND_MAX = 1e11


def check_redundant(redundant) -> None:
    """``redundant`` must be "raise" or "velocity" (a ParameterError otherwise)."""
    if not (type(redundant) is str and redundant in ("raise", "velocity")):
        raise ParameterError(f"redundant must be 'raise' or 'velocity', got {redundant!r}")


class Row:
    """The differential of one equation: coefficients of dx (m), dW (N, N), dv (N), de (n),
    dmu (n), stored side by side in one flat array ``a`` (the attributes are views of it)."""

    __slots__ = ("a", "shape")

    def __init__(self, m: int, N: int, n: int, a: np.ndarray | None = None):
        self.shape = (m, N, n)
        self.a = np.zeros(m + N * N + N + 2 * n) if a is None else a

    def _part(self, k: int) -> np.ndarray:
        """The k-th of (dx, dW flat, dv, de, dmu): a view of ``a``."""
        m, N, n = self.shape
        ends = (0, m, m + N * N, m + N * N + N, m + N * N + N + n, self.a.size)
        return self.a[ends[k]:ends[k + 1]]

    x = property(lambda self: self._part(0))
    W = property(lambda self: self._part(1).reshape(self.shape[1], self.shape[1]))
    v = property(lambda self: self._part(2))
    e = property(lambda self: self._part(3))
    mu = property(lambda self: self._part(4))

    def __sub__(self, other: "Row") -> "Row":
        return Row(*self.shape, self.a - other.a)

    def __rmul__(self, c: float) -> "Row":
        return Row(*self.shape, c * self.a)


class ModeSystem:
    """The rows of one mode's equations at an answer ``pi`` of a law.

    Parameters
    ----------
    W : (N, N) Delassus matrix; v : (N,) pre-impact contact velocities (flat).
    e : (n,) restitution as it enters the law's ``b``, or None for a law whose ``b = v``.
    d : contact dimension. pi : (N,) the answer. n_aux : auxiliary unknowns after ``pi``.
    aux : (n_aux,) their values (multipliers), used by :meth:`stationarity`.
    """

    def __init__(self, W: np.ndarray, v: np.ndarray, e: np.ndarray | None, d: int,
                 pi: np.ndarray, n_aux: int = 0, aux: np.ndarray | None = None):
        self.N = W.shape[0]
        self.n = self.N // d
        self.newton = e is not None
        e = np.zeros(self.n) if e is None else e
        self.Wm, self.vv, self.ee, self.d = W, v, e, d
        self.m = self.N + n_aux
        self.pi = pi
        self.aux = np.zeros(n_aux) if aux is None else aux
        self.b = v.copy()
        self.b[::d] += e * np.minimum(v[::d], 0.0)
        self.u = W @ pi + self.b
        self.rows: list[Row] = []

    def zero(self) -> Row:
        return Row(self.m, self.N, self.n)

    def unknown(self, c: int) -> Row:
        r = self.zero()
        r.x[c] = 1.0
        return r

    def friction(self, i: int) -> Row:
        r = self.zero()
        r.mu[i] = 1.0
        return r

    def velocity(self, k: int) -> Row:
        """``u_k = (W pi + b)_k``."""
        r = self.zero()
        r.x[:self.N] = self.Wm[k]
        r.W[k] = self.pi
        i, comp = divmod(k, self.d)
        if comp == 0 and self.newton and self.vv[k] < 0.0:
            r.v[k] = 1.0 + self.ee[i]
            r.e[i] = self.vv[k]
        else:
            r.v[k] = 1.0
        return r

    def stationarity(self, k: int, lam: dict[int, int]) -> Row:
        """``y_k = (W (pi - N lambda) + v)_k``; ``lam`` maps a contact to its multiplier's
        column."""
        d = self.d
        z = self.pi.copy()
        r = self.zero()
        r.x[:self.N] = self.Wm[k]
        for i, c in lam.items():
            z[i * d] -= self.aux[c - self.N]
            r.x[c] = -self.Wm[k, i * d]
        r.W[k] = z
        r.v[k] = 1.0
        return r

    def add(self, *rows: Row) -> None:
        self.rows.extend(rows)

    # -- the equations every law shares ---------------------------------------------------

    def separating(self, i: int) -> None:
        """pi_i = 0."""
        self.add(*(self.unknown(i * self.d + k) for k in range(self.d)))

    def frictionless(self, i: int, normal: Row) -> None:
        """``normal`` = 0 (u_n or y_n) and pi_t = 0."""
        self.add(normal, *(self.unknown(i * self.d + k) for k in range(1, self.d)))

    def stick(self, i: int) -> None:
        """u_i = 0."""
        self.add(*(self.velocity(i * self.d + k) for k in range(self.d)))

    def slide_on_cone(self, i: int, mu: float, lift: float, sigma_col: int,
                      rows: list[Row]) -> None:
        """A slide parametrized by the impulse on the cone boundary (|pi_t| = mu pi_n > 0,
        ``t = pi_t / |pi_t|``) and the slip multiplier ``sigma``: ``V_n = lift mu sigma``,
        ``V_t = -sigma t`` and ``|pi_t| = mu pi_n``, with ``V`` the rows ``rows`` (u: the CCP
        with lift 1, Coulomb with lift 0; y: P_N's stationarity with lift 1)."""
        d, N = self.d, self.N
        base = i * d
        pt = self.pi[base + 1:base + d]
        a = float(np.linalg.norm(pt))
        t = pt / a
        Pm = (np.eye(d - 1) - np.outer(t, t)) / a
        sigma = self.aux[sigma_col - N]
        first = Row(*rows[0].shape, rows[0].a.copy())  # V_n - lift (mu sigma + sigma dmu)
        first.x[sigma_col] -= lift * mu
        first.mu[i] -= lift * sigma
        self.add(first)
        for k in range(d - 1):  # V_t + sigma t, t moving with pi_t
            row = Row(*rows[k + 1].shape, rows[k + 1].a.copy())
            row.x[sigma_col] += t[k]
            row.x[base + 1:base + d] += sigma * Pm[k]
            self.add(row)
        cone = self.zero()  # |pi_t| - mu pi_n
        cone.x[base] = -mu
        cone.x[base + 1:base + d] = t
        cone.mu[i] = -self.pi[base]
        self.add(cone)

    def slide_on_slip(self, i: int, mu: float, lift: float) -> None:
        """A slide parametrized by the post-impact slip (|u_t| > 0, ``tau = u_t / |u_t|``):
        ``u_n = lift mu |u_t|`` and ``pi_t = -mu pi_n tau`` (valid down to pi_i = 0)."""
        d = self.d
        base = i * d
        ut = self.u[base + 1:base + d]
        r = float(np.linalg.norm(ut))
        tau = ut / r
        Pm = (np.eye(d - 1) - np.outer(tau, tau)) / r
        V = np.array([self.velocity(base + k).a for k in range(1, d)])  # the u_t rows
        row = self.velocity(base)
        row.a -= (lift * mu) * (tau @ V)
        row.mu[i] -= lift * r
        self.add(row)
        pn = self.pi[base]
        for k in range(d - 1):
            row = Row(self.m, self.N, self.n, (mu * pn) * (Pm[k] @ V))
            row.x[base + 1 + k] += 1.0
            row.x[base] += mu * tau[k]
            row.mu[i] += pn * tau[k]
            self.add(row)

    def planar_slide(self, i: int, mu: float, s: float) -> None:
        """Eq. (55)'s slide in the plane: ``u_n = 0`` and ``pi_t = mu s pi_n``, s held."""
        base = i * self.d
        self.add(self.velocity(base), self.unknown(base + 1) - (mu * s) * self.unknown(base)
                 - (s * self.pi[base]) * self.friction(i))

    # -- the solve ----------------------------------------------------------------------

    def _system(self) -> tuple[np.ndarray, np.ndarray]:
        """F_x (m, m) and (F_W, F_v, F_e, F_mu) side by side (m, N^2 + N + 2n)."""
        if len(self.rows) != self.m:
            raise AssertionError(f"{len(self.rows)} equations for {self.m} unknowns")
        F = np.array([r.a for r in self.rows])
        return F[:, :self.m], F[:, self.m:]

    def one_contact(self) -> np.ndarray:
        """One contact's ``dp`` (d, P) in the flat layout (the e_t column zero);
        ``np.linalg.LinAlgError`` where the mode's equations are singular."""
        J, rhs = self._system()
        d = self.d
        dp = np.zeros((d, n_params(d)))
        dp[:, :-1] = -np.linalg.solve(J, rhs)[:d]
        return dp

    def solve(self, what: str, redundant: str = "raise"
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
        """``d pi`` with respect to W (N, N, N), v (N, N), e (N, n), mu (N, n), and whether
        the mode's Jacobian was singular.

        A singular Jacobian (redundant contacts: the impulse is not unique, the velocity is)
        raises NotSupportedError (``what`` names the law's situation in the message), or with
        ``redundant="velocity"`` gives the minimum-norm solution of the linearized equations:
        along a perturbation that keeps them consistent it is one derivative of the solution
        set, and every other differs from it by an impulse the bodies do not feel (``W dpi``
        and ``G Jc^T dpi`` are the same).
        """
        J, rhs = self._system()
        cond = np.linalg.cond(J)
        singular = not cond < JACOBIAN_COND_MAX
        if singular and redundant != "velocity":
            raise NotSupportedError(
                f"{what}: the equations of this mode do not determine the impulse (their "
                f"Jacobian has condition number {cond:.1e}): redundant contacts (more "
                "contact rows than the bodies' degrees of freedom, W singular) leave the "
                "impulse non-unique while the post-impact velocity is unique, and the law "
                "has no selection rule of its own whose derivative is defined here; "
                "redundant='velocity' gives a derivative exact for the velocity (W dpi, "
                "G Jc^T dpi)")
        N, n = self.N, self.n
        if singular:
            dx = -(np.linalg.pinv(J, rcond=1.0 / JACOBIAN_COND_MAX) @ rhs)[:N]
        else:
            dx = -np.linalg.solve(J, rhs)[:N]
        dW = dx[:, :N * N].reshape(N, N, N)
        dv = dx[:, N * N:N * N + N]
        de = dx[:, N * N + N:N * N + N + n]
        dmu = dx[:, N * N + N + n:]
        return dW, dv, de, dmu, singular


#: the statement of a derivative taken with ``redundant="velocity"`` on a singular mode
VELOCITY_ONLY = (
    "redundant contacts: the impulse is not unique (the post-impact velocity is), and this "
    "derivative is the minimum-norm solution of the mode's linearized equations: exact for "
    "the velocity (W d pi, and d theta_dot+ through G Jc^T d pi) along perturbations that keep "
    "those equations consistent (the contacts staying redundant, e.g. a rigid body's geometry "
    "and inertia), while d pi itself is one of the impulse derivatives compatible with the law, "
    "not necessarily its solver's")


# --------------------------------------------------------------------------------------------
# one contact: the flat layout and the modes the laws share


def n_params(d: int) -> int:
    return d * d + d + 3


def seeds(d: int):
    """The derivatives of (W, v, e, mu, e_t) with respect to theta: (d, d, P), (d, P), then
    three (P,) rows (read-only, shared)."""
    found = _SEEDS.get(d)
    if found is None:
        eye = np.eye(n_params(d))
        eye.flags.writeable = False
        found = _SEEDS[d] = (eye[:d * d].reshape(d, d, -1), eye[d * d:d * d + d], eye[-3],
                             eye[-2], eye[-1])
    return found


_SEEDS: dict = {}


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


def newton_shift(v: np.ndarray, e: float) -> np.ndarray:
    """One contact's ``b = ((1 + e) v_n, v_t)`` (an approaching contact)."""
    b = np.array(v, dtype=float)
    b[0] *= 1.0 + e
    return b


def _one(W, v, e, p, aux=()) -> ModeSystem:
    return ModeSystem(W, v, np.array([e]), v.size, np.asarray(p, dtype=float), len(aux),
                      np.array(aux, dtype=float))


def frictionless(W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """pi = (c / W_nn) n, c = -(1 + e) v_n."""
    p = np.zeros(v.size)
    p[0] = -(1.0 + e) * v[0] / W[0, 0]
    S = _one(W, v, e, p)
    S.frictionless(0, S.velocity(0))
    return S.one_contact()


def stick(W: np.ndarray, v: np.ndarray, e: float, p: np.ndarray) -> np.ndarray:
    """W pi = -b (the stick impulse of the Newton laws: normal restitution, no slip)."""
    S = _one(W, v, e, p)
    S.stick(0)
    return S.one_contact()


def eq55_slide(W: np.ndarray, v: np.ndarray, e: float, mu: float, s: float) -> np.ndarray:
    """pi = (c / D) (1, mu s), D = W_nn + mu s W_nt, the tangent s = +-1 held fixed."""
    g = np.array([1.0, mu * s])
    S = _one(W, v, e, (-(1.0 + e) * v[0] / float(W[0] @ g)) * g)
    S.planar_slide(0, mu, s)
    return S.one_contact()


def cone_slide(kind: str, W: np.ndarray, v: np.ndarray, e: float, mu: float,
               p: np.ndarray) -> np.ndarray:
    """A boundary slide ``|pi_t| = mu pi_n`` at the answer ``p``, its tangent set by the law's
    conditions (``kind``: "ccp", "coulomb" or "max-dissipation", see the module's docstring),
    differentiated implicitly with its multipliers."""
    d = v.size
    t = p[1:] / float(np.linalg.norm(p[1:]))
    if kind == "max-dissipation":  # the multipliers (lambda, sigma) by least squares
        a = np.concatenate(([mu], -t))
        lam, sigma = np.linalg.lstsq(np.column_stack([W[:, 0], a]), W @ p + v, rcond=None)[0]
        S = _one(W, v, e, p, (lam, sigma))
        S.slide_on_cone(0, mu, 1.0, d + 1, [S.stationarity(k, {0: d}) for k in range(d)])
        S.add(S.velocity(0))
        return S.one_contact()
    lift = 1.0 if kind == "ccp" else 0.0
    a = np.concatenate(([lift * mu], -t))
    sigma = float(a @ (W @ p + newton_shift(v, e))) / float(a @ a)
    S = _one(W, v, e, p, (sigma,))
    S.slide_on_cone(0, mu, lift, d, [S.velocity(k) for k in range(d)])
    return S.one_contact()
