"""The linearized equations of an impact law's mode at several contacts (implicit function theorem).

Inside a mode -- which contacts separate, stick or slide, and which equality constraints and
cone faces are active -- the impulse ``pi`` of a law (with the auxiliary unknowns of its
mode: cone multipliers ``sigma``, equality multipliers ``lambda``) solves a smooth square
system ``F(x; W, v, e, mu) = 0``. Its derivative is

    dx = -F_x^-1 (F_W dW + F_v dv + F_e de + F_mu dmu),

:meth:`ModeSystem.solve`. The laws' derivative modules (:mod:`.cone_derivative`,
:mod:`.pn_complementarity_derivative`) write their modes' equations with the rows of this
module, each a :class:`Row`: a linear form in ``(dx, dW, dv, de, dmu)`` -- the differential of
one equation at the answer, written by hand:

* :meth:`ModeSystem.unknown` ``x_c`` (an impulse component held at zero, ...);
* :meth:`ModeSystem.velocity` ``u_r = (W pi + b)_r`` with the law's ``b = v + e min(v_n, 0) n``
  (or ``b = v``): ``d u_r = W_r. dpi + pi_j dW_rj + (db_r/dv_r) dv_r + min(v_n, 0) de_i``;
* :meth:`ModeSystem.stationarity` ``y_r = (W (pi - N lambda) + v)_r``, the gradient of the
  program P_N's Lagrangian (``N lambda``: the multipliers of its equalities ``u_n = 0`` on the
  normal rows);
* :meth:`ModeSystem.friction` ``mu_i``.

``W`` derivatives are the partials with respect to the entries ``W_rj`` as they appear in the
equations; contracted with a symmetric ``dW`` they give the derivative the contract of
:class:`~convimpact.impact.derivatives.contact.ContactDerivative` asks for.
"""

from __future__ import annotations

import numpy as np

from ..errors import NotSupportedError, ParameterError

#: condition number of the mode's Jacobian above which the impulse is taken as not unique
JACOBIAN_COND_MAX = 1e11


def check_redundant(redundant) -> None:
    """``redundant`` must be "raise" or "velocity" (a ParameterError otherwise)."""
    if not (type(redundant) is str and redundant in ("raise", "velocity")):
        raise ParameterError(f"redundant must be 'raise' or 'velocity', got {redundant!r}")


class Row:
    """The differential of one equation: coefficients of dx (m), dW (N, N), dv (N), de (n),
    dmu (n)."""

    __slots__ = ("x", "W", "v", "e", "mu")

    def __init__(self, m: int, N: int, n: int):
        self.x = np.zeros(m)
        self.W = np.zeros((N, N))
        self.v = np.zeros(N)
        self.e = np.zeros(n)
        self.mu = np.zeros(n)

    def _new(self) -> "Row":
        r = Row.__new__(Row)
        return r

    def __add__(self, other: "Row") -> "Row":
        r = self._new()
        for name in Row.__slots__:
            setattr(r, name, getattr(self, name) + getattr(other, name))
        return r

    def __sub__(self, other: "Row") -> "Row":
        return self + (-1.0) * other

    def __rmul__(self, c: float) -> "Row":
        r = self._new()
        for name in Row.__slots__:
            setattr(r, name, c * getattr(self, name))
        return r


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
        vn = v[::d]
        self.b = v.copy()
        self.b[::d] += e * np.minimum(vn, 0.0)
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
        self.add(rows[0] - lift * (mu * self.unknown(sigma_col) + sigma * self.friction(i)))
        for k in range(d - 1):
            row = rows[k + 1] + t[k] * self.unknown(sigma_col)
            for l in range(d - 1):
                if Pm[k, l] != 0.0:
                    row = row + (sigma * Pm[k, l]) * self.unknown(base + 1 + l)
            self.add(row)
        cone = (-mu) * self.unknown(base) - self.pi[base] * self.friction(i)
        for l in range(d - 1):
            cone = cone + t[l] * self.unknown(base + 1 + l)
        self.add(cone)

    def slide_on_slip(self, i: int, mu: float, lift: float) -> None:
        """A slide parametrized by the post-impact slip (|u_t| > 0, ``tau = u_t / |u_t|``):
        ``u_n = lift mu |u_t|`` and ``pi_t = -mu pi_n tau`` (valid down to pi_i = 0)."""
        d = self.d
        base = i * d
        ut = self.u[base + 1:base + d]
        s = float(np.linalg.norm(ut))
        tau = ut / s
        Pm = (np.eye(d - 1) - np.outer(tau, tau)) / s
        vel = [self.velocity(base + k) for k in range(1, d)]
        row = self.velocity(base) - lift * s * self.friction(i)
        for l in range(d - 1):
            row = row - (lift * mu * tau[l]) * vel[l]
        self.add(row)
        pn = self.pi[base]
        for k in range(d - 1):
            row = self.unknown(base + 1 + k) + (mu * tau[k]) * self.unknown(base) \
                + (pn * tau[k]) * self.friction(i)
            for l in range(d - 1):
                if Pm[k, l] != 0.0:
                    row = row + (mu * pn * Pm[k, l]) * vel[l]
            self.add(row)

    # -- the solve ----------------------------------------------------------------------

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
        if len(self.rows) != self.m:
            raise AssertionError(f"{len(self.rows)} equations for {self.m} unknowns")
        J = np.array([r.x for r in self.rows])
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
        rhs = np.concatenate([
            np.array([r.W.ravel() for r in self.rows]), np.array([r.v for r in self.rows]),
            np.array([r.e for r in self.rows]), np.array([r.mu for r in self.rows])], axis=1)
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
