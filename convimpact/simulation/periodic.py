"""Periodic orbits of impacting systems: Newton shooting on the Poincaré section of an impact.

The stride map P takes a state z = (theta, theta_dot) just after an impact, simulates it with
:func:`~convimpact.simulation.simulate` to just after the next impact, and maps the end state
back to the reference with ``reduce`` (a walker's translation down the slope, the relabelling
of its legs, a wheel's angle modulo a spoke). A periodic orbit is a fixed point z* = P(z*).

The section and its tangent space
---------------------------------
Just after an impact the state lies on a manifold: every contact that touches and stays
(|v_n| below ``rest_velocity``, e = 0) holds gap = 0 and J_n theta_dot = 0, and J_t
theta_dot = 0 when it sticks; every contact that touches and leaves (v_n > 0: the foot that
lifts off, a ball that bounces) holds gap = 0 (the section proper: the orbit crosses it
transversally, d gap/dt = v_n > 0); the loops hold Psi = 0, C theta_dot = 0. Its tangent
space T at z* is the null space of these constraints' Jacobian, and the stride map's
Jacobian is taken on T (perturbations off T are not states of the system).

Trivial multipliers
-------------------
Two kinds of directions of T are mapped to zero by construction, and are removed (and
reported by name in ``trivial_multipliers``):

* the flow direction f(z*) (a shift of the start along the orbit), when no contact leaves at
  the section (f then lies in T): P(Flow_s(z*)) = P(z*), so DP f = 0;
* the directions ``reduce`` removes, e.g. a translation along the slope: the kernel of
  D reduce (taken at the stride's end, intersected with T); DP maps them to zero.

With N the span of these directions, N is invariant (DP N = 0) and the multipliers are the
eigenvalues of the map induced on the quotient T / N: with Q = [W, N] (W an orthonormal
complement of N in T), Q^-1 DP Q is block triangular, its W-block the reduced stride map's
Jacobian (``result.jacobian``) and its N-block the trivial multipliers (0 up to the
differencing error, reported as computed).

For an exact state transition matrix Phi (at fixed time) of a stride ending on a section
g(x) = 0 at the variable time t_f(z0): g_x (Phi dz0 + f dt_f) = 0 gives
dt_f = -g_x Phi dz0 / (g_x f), and the end state moves by dx = Phi dz0 + f dt_f, so
DP = (I - f g_x / (g_x f)) Phi: the flow direction at the section is projected out. Across
the impact x+ = Delta(x-) that ends the stride (g the striking gap, f- the flow before it),
DP = D Delta (I - f- g_x / (g_x f-)) Phi- = (S - f+ g_x / (g_x f-)) Phi-, S = D Delta +
(f+ - D Delta f-) g_x / (g_x f-) the saltation matrix; then D reduce in front.

The Jacobian
------------
``jacobian="state-transition"``: the section state transitions of ``simulate(...,
sensitivities=True)`` (each impact record's d x(tau+)/d x(t_0) with the impact time moving,
i.e. (I - f g_z / (g_z f)) Phi across the saltation), chained over the strides with
reduce's Jacobian: one simulation per Jacobian instead of 2 d; on the rimless wheel it gives
eta^2 to 2e-8, on the compass gait the differenced multipliers to 6e-7; on the simplest
walker 0.4 s against 1.1 s by differences (Garcia's multipliers to 1e-4 either way: the
feet's mass ratio 1e-5 conditions M). ``"auto"`` takes the state transitions, and central
differences where the scene's run cannot be differentiated (``simulate`` raises
NotSupportedError for ``sensitivities=True``).

``jacobian="finite-differences"``: central differences of the stride map along an
orthonormal basis of T, with step ``step`` (each a full simulation with the tight default
tolerances rtol = atol = 1e-12, so that the differenced error ~ tol / step stays near 1e-7).
``reduce``'s own Jacobian (to find its kernel) is differenced too (it is algebra, not a
simulation).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np
import scipy.linalg as sla

from ..errors import NonFiniteError, NotSupportedError, ParameterError, ShapeError
from ..validation import choice, integer, mapping, positive
from .initial import state_vector
from .periodic_section import (PeriodicOrbitError, _classify, _constraints, _flow, _jac,
                               _null_space, _project, project_to_section)

__all__ = ["find_periodic_orbit", "PeriodicOrbit", "TrivialMultiplier", "PeriodicOrbitError",
           "stride_map", "project_to_section"]

SECTIONS = ("impact",)
JACOBIANS = ("auto", "state-transition", "finite-differences")
#: simulate's tolerances on the stride map unless the caller sets them
STRIDE_DEFAULTS = {"rtol": 1e-12, "atol": 1e-12}


@dataclass(frozen=True)
class TrivialMultiplier:
    """A multiplier removed because it is zero by construction.

    Attributes
    ----------
    name : what the direction is ("time shift along the orbit", "symmetry removed by
        reduce").
    value : |DP n| for the unit direction n, as computed: 0 by construction, so its size
        is the differencing error of the Jacobian.
    direction : the direction n in the state space (theta, theta_dot), unit norm.
    """

    name: str
    value: float
    direction: np.ndarray


@dataclass(frozen=True)
class PeriodicOrbit:
    """A fixed point of the stride map and its stability.

    Attributes
    ----------
    theta, dtheta : the fixed point just after the impact, reduced to the reference.
    period : the time of one stride (from the impact to the next one).
    multipliers : Floquet multipliers of the reduced stride map, complex, by decreasing
        modulus (the trivial ones removed).
    trivial_multipliers : the removed ones, named.
    stable : all |multipliers| < 1.
    iterations : Newton iterations taken.
    residual : max |P(z*) - z*| at the returned point.
    jacobian : the reduced stride map's Jacobian (on T / N, in the basis ``basis``).
    basis : (2k, d) orthonormal basis of the quotient's complement W in the state space.
    jacobian_method : how the stride map was differentiated.
    held_contacts : contacts held closed at the section.
    sticking_contacts : those of them that stick (all their rows held).
    section_contacts : contacts leaving the ground at the section (the section's gaps).
    impact_contacts : the contacts that strike at the end of the stride.
    strides : impacts per period (the map whose fixed point this is: P applied that often).
    points : the orbit's states on the section, one per stride, the fixed point first
        ((strides, 2k)).
    """

    theta: np.ndarray
    dtheta: np.ndarray
    period: float
    multipliers: np.ndarray
    trivial_multipliers: tuple[TrivialMultiplier, ...]
    stable: bool
    iterations: int
    residual: float
    jacobian: np.ndarray
    basis: np.ndarray
    jacobian_method: str
    held_contacts: tuple[str, ...]
    sticking_contacts: tuple[str, ...]
    section_contacts: tuple[str, ...]
    impact_contacts: tuple[str, ...] = field(default=())
    strides: int = 1
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def state(self) -> np.ndarray:
        """The fixed point as one vector [theta, theta_dot]."""
        return np.concatenate([self.theta, self.dtheta])

    @property
    def spectral_radius(self) -> float:
        """max |multiplier| (< 1: stable)."""
        return float(np.max(np.abs(self.multipliers))) if self.multipliers.size else 0.0


@dataclass(frozen=True)
class _Stride:
    state: np.ndarray  # reduced end state
    raw: np.ndarray  # end state before reduce
    time: float
    contacts: tuple[str, ...]
    points: tuple[np.ndarray, ...]
    transition: np.ndarray | None = None  # d(raw end state)/d(start), the time moving


class _Problem:
    """The stride map of one system with fixed options."""

    def __init__(self, mech, reduce, t_max, sim_options, strides=1):
        self.strides = int(strides)
        self.jacobian = "finite-differences"
        self.mech = mech
        self.k = int(mech.n_coordinates)
        self.reduce = reduce
        self.t_max = t_max
        self.sim_options = sim_options
        self.n_strides = 0

    def apply_reduce(self, z: np.ndarray) -> np.ndarray:
        if self.reduce is None:
            return z
        k = self.k
        out = self.reduce(z[:k].copy(), z[k:].copy())
        if not (isinstance(out, tuple) and len(out) == 2):
            raise ShapeError("reduce must return a tuple (theta, dtheta)")
        th = state_vector("reduce(...)[0]", out[0], k)
        dth = state_vector("reduce(...)[1]", out[1], k)
        return np.concatenate([th, dth])

    def stride(self, z: np.ndarray) -> _Stride:
        """``self.strides`` strides from z (each to just after the next impact, reduced)."""
        total, points, contacts = 0.0, [], ()
        for _ in range(self.strides):
            s = self.one_stride(z)
            total += s.time
            points.append(s.state)
            contacts = contacts or s.contacts
            z = s.state
        return _Stride(s.state, s.raw, total, contacts, tuple(points))

    def one_stride(self, z: np.ndarray, sensitivities: bool = False) -> _Stride:
        from .simulate import simulate

        k = self.k
        self.n_strides += 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = simulate(self.mech, (0.0, self.t_max), (z[:k].copy(), z[k:].copy()),
                               max_impacts=1, sensitivities=sensitivities,
                               **self.sim_options)
        except (ParameterError, ShapeError, NotSupportedError):
            raise
        except Exception as exc:  # a penetrating start, Painleve, a singular system...
            raise PeriodicOrbitError(
                f"a stride from {np.array2string(z, precision=6)} failed: "
                f"{type(exc).__name__}: {exc}") from exc
        if not res.impacts:
            raise PeriodicOrbitError(
                f"no impact within t_max = {self.t_max:g} from the state "
                f"{np.array2string(z, precision=6)} (the system fell, stopped, or strides "
                "more slowly: raise t_max)")
        if res.status != 1:
            raise PeriodicOrbitError(f"the stride's simulation stopped early: {res.message}")
        ev = res.impacts[-1]
        if ev.time <= 1e-9 * self.t_max:
            raise PeriodicOrbitError(
                f"the stride from {np.array2string(z, precision=6)} strikes at its start "
                f"(contacts {', '.join(ev.contacts)} approach there): the state is not on the "
                "section; move it there with project_to_section")
        raw = np.concatenate([res.theta[-1], res.dtheta[-1]])
        transition = None
        if sensitivities:
            last = [e for e in res.event_sensitivities if e.time == res.t[-1]]
            if not last or last[-1].state_transition is None:
                raise PeriodicOrbitError("the stride's simulation gave no section state "
                                         "transition at its impact")
            transition = np.asarray(last[-1].state_transition, float)
        return _Stride(self.apply_reduce(raw), raw, float(ev.time), tuple(ev.contacts), (),
                       transition)


# ---- Jacobian of the stride map ------------------------------------------------------------


def _stride_jacobian(prob: _Problem, z, U, step):
    """DP U (2k x d): by central differences, or from the section state transitions of
    ``simulate(..., sensitivities=True)`` chained with reduce's Jacobian."""
    if prob.jacobian == "auto":  # exact where the scene's run can be differentiated
        try:
            prob.jacobian = "state-transition"
            return _stride_jacobian(prob, z, U, step)
        except NotSupportedError:
            prob.jacobian = "finite-differences"
    if prob.jacobian == "state-transition":
        D = np.eye(2 * prob.k)
        for _ in range(prob.strides):
            s = prob.one_stride(z, sensitivities=True)
            R = (_jac(prob.apply_reduce, s.raw, 1e-7) if prob.reduce is not None
                 else np.eye(2 * prob.k))
            D = R @ s.transition @ D
            z = s.state
        return D @ U
    cols = []
    for i in range(U.shape[1]):
        zp = prob.stride(z + step * U[:, i]).state
        zm = prob.stride(z - step * U[:, i]).state
        cols.append((zp - zm) / (2 * step))
    return np.column_stack(cols)


def _trivial_directions(prob: _Problem, sec, z, U, end_raw, k, in_plane_tol=1e-6):
    """Orthonormal basis of N within T (in T's coordinates) and the names of its columns."""
    dirs, names = [], []
    f = _flow(prob.mech, sec, z, k)
    fn = np.linalg.norm(f)
    if fn > 0:
        ft = U.T @ f
        if np.linalg.norm(f - U @ ft) <= in_plane_tol * fn:
            dirs.append(ft / np.linalg.norm(ft))
            names.append("time shift along the orbit (the section is the impact)")
    if prob.reduce is not None:
        R = _jac(prob.apply_reduce, end_raw, 1e-7)
        _, s, vt = np.linalg.svd(R)
        K = vt[int(np.sum(s > 1e-6 * max(1.0, s[0]))):].T
        if K.shape[1]:
            u, s2, _ = np.linalg.svd(U.T @ K, full_matrices=False)
            for j in np.where(s2 > 1 - in_plane_tol)[0]:
                dirs.append(u[:, j])
                names.append("symmetry removed by reduce")
    if not dirs:
        return np.zeros((U.shape[1], 0)), names
    D = np.column_stack(dirs)
    q, r = np.linalg.qr(D)
    keep = np.abs(np.diag(r)) > 1e-6
    return q[:, keep], [n for n, kp in zip(names, keep) if kp]


def _multipliers(DPT, Nt):
    d = DPT.shape[0]
    n = Nt.shape[1]
    if n == 0:
        return DPT, np.eye(d), np.linalg.eigvals(DPT)
    W = sla.null_space(Nt.T)
    Q = np.column_stack([W, Nt])
    B = np.linalg.solve(Q, DPT @ Q)
    A = B[: d - n, : d - n]
    return A, W, np.linalg.eigvals(A)


# ---- the public call -----------------------------------------------------------------------


def stride_map(system, y0=None, *, reduce: Callable | None = None, t_max: float | None = None,
               strides: int = 1, simulate_options: Mapping[str, Any] | None = None
               ) -> tuple[np.ndarray, float]:
    """The stride map P (``strides`` times): the state just after the next impact, reduced,
    and the time it took.

    Parameters are those of :func:`find_periodic_orbit`. Returns ``(z, time)`` with
    ``z = [theta, theta_dot]``.
    """
    prob, z0 = _setup(system, y0, reduce, t_max, simulate_options, strides)
    s = prob.stride(z0)
    return s.state, s.time


def _setup(system, y0, reduce, t_max, simulate_options, strides=1):
    from .simulate import _as_mechanism

    mech, scene = _as_mechanism(system)
    k = int(mech.n_coordinates)
    if reduce is not None and not callable(reduce):
        raise ParameterError(f"reduce must be a callable (theta, dtheta) -> (theta, dtheta) "
                             f"or None, got {type(reduce).__name__}")
    if y0 is None:
        if scene is None:
            raise ShapeError("y0 is required for a bare mechanism")
        y0 = (scene.theta0, scene.dtheta0)
    if isinstance(y0, tuple):
        if len(y0) != 2:
            raise ShapeError("y0 as a tuple must be (theta0, dtheta0)")
        z0 = np.concatenate([state_vector("theta0", y0[0], k), state_vector("dtheta0", y0[1], k)])
    else:
        z0 = state_vector("y0", y0, 2 * k)
    if t_max is None:
        if scene is None:
            raise ShapeError("t_max (the longest stride) is required for a bare mechanism")
        t_max = scene.t_end
    t_max = positive("t_max", t_max)
    opts = dict(STRIDE_DEFAULTS)
    opts.update(mapping("simulate_options", simulate_options))
    for bad in ("max_impacts", "t_span", "y0", "dense_output", "t_eval"):
        if bad in opts:
            raise ParameterError(f"simulate_options may not set {bad!r}: the stride map sets it")
    strides = integer("strides", strides, minimum=1)
    return _Problem(mech, reduce, t_max, opts, strides), z0


def find_periodic_orbit(system, y0=None, *, section: str = "impact",
                        reduce: Callable | None = None, t_max: float | None = None,
                        strides: int = 1, tol: float = 1e-9, max_iterations: int = 25,
                        jacobian: str = "auto", step: float = 1e-5,
                        simulate_options: Mapping[str, Any] | None = None,
                        touch_tol: float = 1e-7, rest_velocity: float = 1e-6,
                        progress: bool = False) -> PeriodicOrbit:
    """Find a periodic orbit by Newton shooting on the Poincaré section of an impact.

    Parameters
    ----------
    system : Mechanism or Scene
        As for :func:`~convimpact.simulation.simulate`.
    y0 : (theta, dtheta) or ndarray [theta, theta_dot], optional
        A state near the orbit (default: the scene's). One stride from it gives the first
        point on the section.
    section : {"impact"}
        The Poincaré section: just after an impact.
    reduce : callable (theta, dtheta) -> (theta, dtheta), optional
        Maps the state just after the impact back to the reference (translation down the
        slope, relabelling of legs, an angle modulo a spoke). Smooth near the orbit.
    t_max : float, optional
        The longest stride (default: the scene's ``t_end``); no impact by then is an error.
    strides : int
        Impacts per period: 1 for a period-one orbit, 2 for a period-two orbit (a fixed point
        of the doubled map P o P, after a period doubling), ...
    tol : float
        Convergence: max |P(z) - z| <= tol (state units).
    max_iterations : int
        Newton iterations before :class:`PeriodicOrbitError`.
    jacobian : {"auto", "finite-differences", "state-transition"}
        How the stride map is differentiated: the section state transition matrices of
        ``simulate(..., sensitivities=True)`` ("state-transition"; "auto" takes them, and
        central differences where the run cannot be differentiated), or central finite
        differences ("finite-differences").
    step : float
        The differencing step along each unit direction of the section's tangent space.
    simulate_options : mapping, optional
        Options of :func:`~convimpact.simulation.simulate` for each stride (law, method,
        integrator, rtol, atol...; default rtol = atol = 1e-12).
    touch_tol, rest_velocity : float
        A contact with |gap| <= touch_tol at the section touches; it is held if its normal
        velocity is <= rest_velocity (sticking if its tangential one is too), else it leaves.
    progress : bool
        Print each Newton iteration's residual.

    Returns
    -------
    PeriodicOrbit

    Raises
    ------
    ShapeError, NonFiniteError, ParameterError, UnknownOptionError
        for malformed input (wrong sizes, NaN, strings or booleans for numbers, an unknown
        section or jacobian, a reduce that is not callable or returns the wrong shapes);
    PeriodicOrbitError
        when Newton does not converge within ``max_iterations`` or a stride cannot be
        completed (no impact within ``t_max``, a failed simulation).
    """
    section = choice("section", section, SECTIONS)
    jacobian = choice("jacobian", jacobian, JACOBIANS)
    tol = positive("tol", tol)
    step = positive("step", step)
    touch_tol = positive("touch_tol", touch_tol)
    rest_velocity = positive("rest_velocity", rest_velocity)
    max_iterations = integer("max_iterations", max_iterations, minimum=1)
    if not isinstance(progress, (bool, np.bool_)):
        raise ParameterError(f"progress must be True or False, got {progress!r}")
    prob, z0 = _setup(system, y0, reduce, t_max, simulate_options, strides)
    prob.jacobian = jacobian
    mech, k = prob.mech, prob.k

    s = prob.one_stride(z0)
    z = s.state
    sec = _classify(mech, z, k, touch_tol, rest_velocity)
    if not sec.held and not sec.leaving:
        raise PeriodicOrbitError(
            "no contact touches at the section (after the impact and reduce): reduce must "
            "map the state back to the reference, with the contacts where they were")
    s = prob.stride(z)
    residual = float(np.max(np.abs(s.state - z)))
    iterations = 0
    while True:
        if progress:
            print(f"  Newton {iterations}: max |P(z) - z| = {residual:.3e}", flush=True)
        if not np.isfinite(residual):
            raise NonFiniteError("the stride map returned a non-finite state")
        if residual <= tol:
            break
        if iterations >= max_iterations:
            raise PeriodicOrbitError(
                f"Newton shooting did not converge in {max_iterations} iterations: "
                f"max |P(z) - z| = {residual:.3e} > tol = {tol:g}")
        iterations += 1
        U = _null_space(_jac(_constraints(mech, sec, k), z, 1e-7), 2 * k)
        DPT = U.T @ _stride_jacobian(prob, z, U, step)
        r = U.T @ (s.state - z)
        try:
            delta = np.linalg.solve(DPT - np.eye(U.shape[1]), -r)
        except np.linalg.LinAlgError:
            raise PeriodicOrbitError("the stride map has a multiplier 1 at the iterate "
                                     "(singular Newton system)") from None
        lam = 1.0
        for _ in range(8):  # backtracking on max |P(z) - z|
            try:
                z_new = _project(mech, sec, z + lam * (U @ delta), k)
                s_new = prob.stride(z_new)
                res_new = float(np.max(np.abs(s_new.state - z_new)))
            except PeriodicOrbitError:
                res_new = np.inf
            if res_new < residual or lam < 0.01:
                break
            lam *= 0.5
        if not np.isfinite(res_new):
            raise PeriodicOrbitError(
                f"Newton shooting left the orbit's basin after {iterations} iterations "
                f"(every damped step failed a stride); last max |P(z) - z| = {residual:.3e}")
        z, s, residual = z_new, s_new, res_new

    # multipliers at the converged point
    U = _null_space(_jac(_constraints(mech, sec, k), z, 1e-7), 2 * k)
    DPT = U.T @ _stride_jacobian(prob, z, U, step)
    Nt, names = _trivial_directions(prob, sec, z, U, s.raw, k)
    A, W, mult = _multipliers(DPT, Nt)
    order = np.argsort(-np.abs(mult), kind="stable")
    mult = mult[order]
    # each trivial unit direction n with |DP n| (0 by construction)
    trivial = tuple(TrivialMultiplier(name, float(np.linalg.norm(DPT @ Nt[:, j])), U @ Nt[:, j])
                    for j, name in enumerate(names))
    return PeriodicOrbit(
        theta=z[:k].copy(), dtheta=z[k:].copy(), period=s.time, multipliers=mult,
        trivial_multipliers=trivial, stable=bool(np.all(np.abs(mult) < 1.0)),
        iterations=iterations, residual=residual, jacobian=A, basis=U @ W,
        jacobian_method=prob.jacobian, held_contacts=sec.held,
        sticking_contacts=sec.sticking,
        section_contacts=sec.leaving, impact_contacts=s.contacts, strides=prob.strides,
        points=np.vstack([z] + list(s.points[:-1])))
