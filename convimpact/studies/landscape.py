"""Dissipation landscapes: one impact state, a law evaluated over grids of e and mu.

:func:`closed_form_landscape` is the paper's Figs. 5-7: the Section 8 algorithm for one planar
contact over e in [0, 1] and a *signed* mu, vectorized in numpy (no Python loop per point).
Following the paper, mu > 0 puts the friction impulse along t = -v_t-/|v_t-| (eq. 55) and
mu < 0 along the slip itself; sticking is admitted where the sticking impulse lies in the cone
|pi_t| <= |mu| pi_n. Points where the sliding denominator of eq. (38) is not positive (a
Painleve-like jam) carry NaN *and* are marked in ``jammed``; no NaN appears anywhere else.

:func:`law_landscape` evaluates any law/method of :func:`convimpact.resolve_impact` (mu >= 0)
point by point on one validated problem, reusing the solver's compiled program, with a
progress bar on long runs. A law's parameter beyond e and mu (the tangential restitution
``e_t`` of ``"chatterjee-ruina"``) is one value for the whole landscape, given as ``e_t=``
to it and to :func:`contact_landscape` (refused with the other laws) and kept in ``meta``.

:func:`contact_landscape` evaluates any law with the exact single-contact kernels of
``method="fast"``: the contact-space data are reduced once, the grid is solved by the
compiled batch (:func:`convimpact.impact.batch.impacts.contact_impulses`, which compiles every law,
planar and spatial -- Stronge's curved spatial slip integrated by its compiled DOP853; one
Python kernel call per point only on small grids or without numba), and energy, velocities
and the diagnostics' flags are computed in numpy over the grid (identical flags to
:func:`law_landscape`).

:func:`angle_landscape` (:mod:`.angle_landscape`) evaluates the spatial sliding rule of
Section 9.3 over e x mu x alpha (the angle of the tangential impulse, Fig. 9), vectorized,
with the exact angle of maximal dissipation alpha_m per (e, mu).

:func:`stick_boundary` (and :func:`landscape_stick_boundary` for a planar landscape, whose
``meta`` keeps the sticking impulse) gives the exact boundary of the stick region over (mu, e)
as a :class:`StickBoundary`: |mu| = |pi_t(e)| / pi_n(e) with the sticking impulse of eq. (42),
affine in e -- a curve in closed form, not the grid's cells.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ..errors import ConvImpactError, NonFiniteError, ShapeError
from ..impact.problem.build import ImpactProblem, build_problem, check_restitution
from ..impact.results import _fields_as_json
from ..validation import grid
from .angle_landscape import AngleLandscape, angle_landscape  # noqa: F401  (this API)
from .stick_boundary import (  # noqa: F401  (this API)
    StickBoundary,
    _boundary_from_meta,
    _planar_problem,
    _sticking_meta,
    stick_boundary,
)

REGIMES = ("separating", "frictionless", "stick", "slide", "failed")
#: grids from this many points on go to the compiled batch (a Python loop over the kernel,
#: about 3e4 points/s, costs less below it than the batch's compilation, about 20 s once)
BATCH_MIN_POINTS = 20_000




@dataclass(frozen=True, eq=False)
class Landscape:
    """A law evaluated over a grid: arrays of shape (len(e), len(mu)).

    Attributes
    ----------
    e, mu : the grid axes.
    energy_loss : T_L (eq. 58); negative where energy is gained.
    energy_loss_fraction : T_L / T-.
    normal_impulse : pi_n.
    tangential_impulse : pi_t on the frame's tangent axes, shape (..., d - 1).
    v_plus : post-impact contact-frame velocity, shape (..., d).
    tangential_velocity : post-impact slip along the paper's t (planar) or its norm (spatial).
    regime : integer codes into :data:`REGIMES`.
    energy_gained, friction_pushes_slip, slip_reversal, jammed, failed : boolean masks.
    stick_possible : mask of (e, mu) where the sticking impulse is admissible.
    law, method : what was evaluated. ``meta`` records the impact state.
    """

    e: np.ndarray
    mu: np.ndarray
    energy_loss: np.ndarray
    energy_loss_fraction: np.ndarray
    normal_impulse: np.ndarray
    tangential_impulse: np.ndarray
    v_plus: np.ndarray
    tangential_velocity: np.ndarray
    regime: np.ndarray
    energy_gained: np.ndarray
    friction_pushes_slip: np.ndarray
    slip_reversal: np.ndarray
    jammed: np.ndarray
    failed: np.ndarray
    stick_possible: np.ndarray
    law: str
    method: str
    meta: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))

    def regime_names(self) -> np.ndarray:
        """The regime of every point as strings."""
        return np.asarray(REGIMES, dtype=object)[self.regime]

    def counts(self) -> dict[str, int]:
        """How many grid points fall in each regime and failure flag."""
        out = {name: int(np.sum(self.regime == i)) for i, name in enumerate(REGIMES)}
        for flag in ("energy_gained", "friction_pushes_slip", "slip_reversal", "jammed",
                     "failed"):
            out[flag] = int(np.sum(getattr(self, flag)))
        return out

    def as_dict(self) -> dict[str, Any]:
        """Plain-JSON view (NaN becomes None)."""
        out = _fields_as_json(self)
        out["regime_names"] = list(REGIMES)
        out["counts"] = self.counts()
        return out


def landscape_stick_boundary(L: Landscape) -> StickBoundary | None:
    """The exact stick boundary of a planar landscape, from the sticking impulse its
    ``meta`` keeps.

    Parameters
    ----------
    L : a landscape of this module.

    Returns
    -------
    StickBoundary or None
        None where it has none: a spatial contact, a singular W, or a law without one.
    """
    return _boundary_from_meta(L.meta, L.law)


def closed_form_landscape(M, Jc, dq, e, mu, C=None) -> Landscape:
    """Section 8 over a grid of e and signed mu, vectorized (the paper's Figs. 5-7).

    Parameters
    ----------
    M, Jc, dq, C : as for :func:`convimpact.resolve_impact`; one planar contact.
    e : (ne,) array_like of restitution coefficients in [0, 1].
    mu : (nmu,) array_like of signed friction coefficients (see module docstring).
    """
    P = _planar_problem(M, Jc, dq, C)
    e = grid("e", e)
    e = check_restitution(e, e.size)
    mu = grid("mu", mu)
    if not np.all(np.isfinite(mu)):
        raise ShapeError("mu must be finite")
    W, v = P.contact_block(0)
    vn, vt = float(v[0]), float(v[1])
    T_minus = P.kinetic_energy(P.dq_minus)
    E, MU = np.meshgrid(e, mu, indexing="ij")
    shape = E.shape
    if vn >= 0.0:
        z = np.zeros(shape)
        f = np.zeros(shape, bool)
        return Landscape(e, mu, z, z, z, z[..., None], np.broadcast_to(v, shape + (2,)).copy(),
                         np.full(shape, vt), np.zeros(shape, int), f, f, f, f, f, f,
                         "pereira-nikravesh", "closed-form", MappingProxyType({"v_minus": v}))

    # sticking impulse, eq. (42)/(52): affine in e
    from ..impact.laws.pereira_nikravesh import DELASSUS_COND_MAX

    if np.linalg.cond(W) < DELASSUS_COND_MAX:
        Winv = np.linalg.inv(W)
        st_n = -(Winv[0, 0] * (1 + E) * vn + Winv[0, 1] * vt)
        st_t = -(Winv[1, 0] * (1 + E) * vn + Winv[1, 1] * vt)
        stick = (st_n >= 0) & (np.abs(st_t) <= np.abs(MU) * st_n)
    elif np.all(mu == 0.0):
        # frictionless everywhere (e.g. a central impact whose tangent moves no mass):
        # the sticking solve is never needed
        st_n = st_t = np.zeros(shape)
        stick = np.zeros(shape, bool)
    else:
        from ..errors import SingularSystemError

        raise SingularSystemError(
            f"the Delassus matrix W = Jc M^-1 Jc^T is singular (cond = {np.linalg.cond(W):.3e}):"
            " the sticking solve of eq. (42)/(52) has no unique answer; evaluate this impact "
            "with mu = 0 only, or use contact_landscape with law='dissipative'")
    # sliding, eq. (38): t opposite to v_t- for mu > 0 (eq. 55), along it for mu < 0
    # sign of the slip; with no slip, friction saturates where the sticking impulse pointed
    s = np.full(shape, np.sign(vt)) if vt != 0.0 else -np.sign(st_t)
    s = np.where(s == 0, -1.0, s)
    g_t = -MU * s  # frame-tangent component of (n + mu t)
    denom = W[0, 0] + W[0, 1] * g_t
    jam = ~stick & ~(denom > 1e-12 * np.abs(W).max())
    with np.errstate(divide="ignore", invalid="ignore"):
        sl_n = np.where(jam, np.nan, -(1 + E) * vn / np.where(jam, 1.0, denom))
    pn = np.where(stick, st_n, sl_n)
    pt = np.where(stick, st_t, sl_n * g_t)
    frictionless = MU == 0
    pn = np.where(frictionless, -(1 + E) * vn / W[0, 0], pn)
    pt = np.where(frictionless, 0.0, pt)
    jam = jam & ~frictionless
    vpn = vn + W[0, 0] * pn + W[0, 1] * pt
    vpt = vt + W[1, 0] * pn + W[1, 1] * pt
    TL = -(pn * vn + pt * vt) - 0.5 * (W[0, 0] * pn**2 + 2 * W[0, 1] * pn * pt + W[1, 1] * pt**2)
    regime = np.where(frictionless, 1, np.where(stick, 2, 3))
    tol = 1e-12
    gained = TL < -tol * T_minus
    pushes = pt * vt > tol * np.abs(pt) * abs(vt)
    reversal = (regime == 3) & (pt * vpt > tol * np.abs(pt) * np.abs(vpt))
    return Landscape(
        e=e, mu=mu, energy_loss=TL, energy_loss_fraction=TL / T_minus, normal_impulse=pn,
        tangential_impulse=pt[..., None], v_plus=np.stack([vpn, vpt], axis=-1),
        tangential_velocity=-s * vpt, regime=regime, energy_gained=gained & ~jam,
        friction_pushes_slip=pushes & ~jam, slip_reversal=reversal & ~jam, jammed=jam,
        failed=np.zeros(shape, bool), stick_possible=stick & ~frictionless,
        law="pereira-nikravesh", method="closed-form",
        meta=MappingProxyType({"v_minus": v.tolist(), "energy_before": T_minus,
                               "t_sign": "mu > 0: friction along -v_t-/|v_t-| (eq. 55)",
                               **_sticking_meta(W, v)}),
    )


class _Progress:
    """A plain progress bar on stderr, shown only for runs longer than ``after`` seconds."""

    def __init__(self, total: int, label: str, after: float = 2.0, stream=None):
        self.total, self.label, self.after = total, label, after
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()
        self.shown = False

    def update(self, done: int) -> None:
        elapsed = time.perf_counter() - self.start
        if elapsed < self.after and done < self.total:
            return
        if not self.shown and done >= self.total and elapsed < self.after:
            return
        self.shown = True
        frac = done / self.total
        bar = "#" * int(30 * frac)
        eta = elapsed / max(frac, 1e-9) - elapsed
        self.stream.write(f"\r{self.label} [{bar:<30}] {done}/{self.total} "
                          f"{elapsed:5.1f}s eta {eta:5.1f}s")
        if done >= self.total:
            self.stream.write("\n")
        self.stream.flush()


def law_landscape(M, Jc, dq, e, mu, C=None, law: str = "coulomb", method: str = "auto",
                  progress: bool = True, *, e_t=None, **options) -> Landscape:
    """Evaluate ``resolve_impact`` over a grid of e and mu (mu >= 0) for one impact state.

    ``e_t`` is the tangential restitution of law ``"chatterjee-ruina"`` (in [-1, 1], default 0;
    one value for the whole grid, recorded in ``meta``), refused with the other laws.
    Points where the law raises a :class:`~convimpact.errors.ConvImpactError` are marked in
    ``failed`` (and ``jammed`` for a non-positive effective mass) with NaN values there.
    """
    from ..errors import NonPositiveEffectiveMassError
    from ..impact import check_law_method, choose_method, solve_problem

    check_law_method(law, method)  # names, before the grid (a list is no law)

    e_t = _law_parameters(law, e_t)
    e = grid("e", e)
    e = check_restitution(e, e.size)
    mu = grid("mu", mu)
    if not np.isfinite(mu).all():
        raise NonFiniteError("mu contains NaN or infinity; pass finite (signed) friction "
                             "coefficients")
    base = build_problem(M, Jc, dq, 0.0, 0.0, C, e_t)
    d = base.dim
    if method == "auto":
        method = choose_method(base, law)
    shape = (e.size, mu.size)
    nan = lambda *s: np.full(shape + s, np.nan)  # noqa: E731
    TL, pn, pt, vp = nan(), nan(), nan(d - 1), nan(d)
    regime = np.full(shape, REGIMES.index("failed"))
    flags = {k: np.zeros(shape, bool) for k in ("energy_gained", "friction_pushes_slip",
                                                "slip_reversal", "jammed", "failed")}
    stick_possible = np.zeros(shape, bool)
    bar = _Progress(e.size * mu.size, f"{law}/{method}") if progress else None
    n = 0
    for i, ei in enumerate(e):
        for j, mj in enumerate(mu):
            P = build_problem(base.mass_matrix, list(base.jacobians) if not base.single
                              else base.jacobians[0], base.dq_minus, ei, mj,
                              base.loop_jacobian if base.n_loops else None, e_t)
            try:
                r = solve_problem(P, law, method, **options)
            except NonPositiveEffectiveMassError:
                flags["jammed"][i, j] = flags["failed"][i, j] = True
            except ConvImpactError:
                flags["failed"][i, j] = True
            else:
                imp = np.atleast_2d(r.impulse)[0]
                TL[i, j], pn[i, j], pt[i, j] = r.energy_loss, imp[0], imp[1:]
                vp[i, j] = np.atleast_2d(r.v_plus)[0]
                reg = r.regime if isinstance(r.regime, str) else r.regime[0]
                regime[i, j] = REGIMES.index(reg)
                stick_possible[i, j] = reg == "stick"
                dg = r.diagnostics
                flags["energy_gained"][i, j] = dg.energy_gained
                flags["friction_pushes_slip"][i, j] = dg.friction_pushes_slip
                flags["slip_reversal"][i, j] = dg.slip_reversal
            n += 1
            if bar:
                bar.update(n)
    T_minus = base.kinetic_energy(base.dq_minus)
    vt = base.v_minus[0, 1:]
    if d == 2:
        s = np.sign(vt[0]) if vt[0] != 0 else 1.0
        tangential_velocity = -s * vp[..., 1]
    else:
        tangential_velocity = np.linalg.norm(vp[..., 1:], axis=-1)
    return Landscape(
        e=e, mu=mu, energy_loss=TL, energy_loss_fraction=TL / T_minus, normal_impulse=pn,
        tangential_impulse=pt, v_plus=vp, tangential_velocity=tangential_velocity,
        regime=regime, stick_possible=stick_possible, law=law, method=method,
        meta=MappingProxyType({"v_minus": base.v_minus[0].tolist(), "energy_before": T_minus,
                               **({} if e_t is None else {"e_t": e_t})}),
        **flags,
    )


def _law_parameters(law: str, e_t) -> float | None:
    """The landscape's tangential restitution: checked in [-1, 1] for a law that has one
    (default 0), None for the others; given to another law, UnknownOptionError."""
    from ..impact.problem.build import check_tangential_restitution
    from ..impact.resolve import check_law_parameters

    e_t = check_law_parameters(law, e_t)
    return None if e_t is None else float(check_tangential_restitution(e_t)[0])


def contact_landscape(M, Jc, dq, e, mu, C=None, law: str = "coulomb",
                      progress: bool = True, *, e_t=None) -> Landscape:
    """Any law over a grid of e and mu (mu >= 0) with the exact single-contact kernels.

    The contact-space data (Delassus block ``W`` with the loops folded in, ``v-``) are computed
    once; a grid of at least :data:`BATCH_MIN_POINTS` points is then solved in one call of the
    compiled batch
    :func:`convimpact.impact.batch.impacts.contact_impulses` (item for item the kernel of
    ``method="fast"``, :func:`convimpact.impact.exact.dispatch.solve_contact`, to round-off), and
    everything after the impulse -- energy loss (eq. 58 in contact space), post-impact velocity
    and the failure flags -- is evaluated in numpy over the whole grid, with the same
    definitions and tolerance as :func:`convimpact.impact.diagnostics.assemble_result` for
    ``method="fast"``. Planar or spatial, one contact, every law on the batch (``"stronge"``
    in space too: its curved slip integrated by the batch's compiled DOP853); a smaller grid,
    or any grid without numba, takes one
    :func:`~convimpact.impact.exact.dispatch.solve_contact` call per point (same answers to round-off;
    below that size the loop costs less than the batch's one-time compilation, so a first
    ``convimpact paper`` compiles nothing for its landscapes).

    Parameters
    ----------
    M, Jc, dq, C : as for :func:`convimpact.resolve_impact`; one contact.
    e : (ne,) array_like of restitution coefficients in [0, 1].
    mu : (nmu,) array_like of friction coefficients >= 0.
    law : one of :data:`convimpact.LAWS`.
    progress : show a progress bar on stderr when the per-point loop is long.
    e_t : float, optional
        Tangential restitution in [-1, 1] of law ``"chatterjee-ruina"`` (default 0), one value
        for the grid (kept in ``meta``); refused with the other laws.

    Returns
    -------
    Landscape
        ``method="fast"``. Points where the kernel raises are NaN and marked in ``failed``
        (and in ``jammed`` for a non-positive sliding denominator or a jammed collision).
        ``stick_possible`` marks the points where the law stuck.
    """
    from ..errors import UnknownOptionError
    from ..impact.exact.dispatch import FAST_LAWS, FAST_TOL
    from ..impact.problem.build import check_friction

    if type(law) is not str or law not in FAST_LAWS:
        raise UnknownOptionError(f"unknown law {law!r}; choose one of {', '.join(FAST_LAWS)}")
    e_t = _law_parameters(law, e_t)
    e = grid("e", e)
    e = check_restitution(e, e.size)
    mu = grid("mu", mu)
    mu = check_friction(mu, mu.size)
    P = build_problem(M, Jc, dq, 0.0, 0.0, C)
    if P.n_contacts != 1:
        raise ShapeError("contact_landscape takes one contact Jacobian (d x k)")
    W, v = P.contact_block(0)
    shape = (e.size, mu.size)
    solved = (_batch_grid(W, v, e, mu, law, e_t) if e.size * mu.size >= BATCH_MIN_POINTS
              else None)
    if solved is None:
        solved = _loop_grid(W, v, e, mu, law, progress, e_t)
    pi, regime, jam, failed = solved
    return _landscape_from_impulses(P, e, mu, pi.reshape(shape + (P.dim,)),
                                    regime.reshape(shape), jam.reshape(shape),
                                    failed.reshape(shape), law, "fast", FAST_TOL,
                                    {} if e_t is None else {"e_t": e_t})


def _batch_grid(W: np.ndarray, v: np.ndarray, e: np.ndarray, mu: np.ndarray, law: str,
                e_t: float | None = None):
    """(pi, regime, jam, failed) over the flattened grid from the compiled batch, or None when
    numba is missing (or a law registered later has no batch code)."""
    from ..errors import NotSupportedError

    try:
        from ..impact.batch import impacts as batch
    except ImportError:  # pragma: no cover - the module itself imports nothing optional
        return None
    if law not in batch.LAW_CODES:
        return None
    E, MU = np.meshgrid(e, mu, indexing="ij")
    try:
        b = batch.contact_impulses(W, v, E.ravel(), MU.ravel(), law, e_t=e_t)
    except NotSupportedError:  # no numba: the per-point loop gives the same answers
        return None
    failed = b.status != batch.OK
    regime = np.where(failed, REGIMES.index("failed"), b.regime).astype(int)
    pi = np.where(failed[:, None], np.nan, b.impulse)
    return pi, regime, b.status == batch.JAM, failed


def _loop_grid(W: np.ndarray, v: np.ndarray, e: np.ndarray, mu: np.ndarray, law: str,
               progress: bool, e_t: float | None = None):
    """(pi, regime, jam, failed) over the flattened grid, one kernel call per point."""
    from ..errors import NonPositiveEffectiveMassError
    from ..impact.exact.dispatch import solve_contact

    n = e.size * mu.size
    pi = np.full((n, v.size), np.nan)
    regime = np.full(n, REGIMES.index("failed"))
    jam = np.zeros(n, bool)
    failed = np.zeros(n, bool)
    bar = _Progress(n, f"{law}/fast") if progress else None
    k = 0
    for ei in e:
        for mj in mu:
            try:
                sol = solve_contact(W, v, float(ei), float(mj), law,
                                    0.0 if e_t is None else e_t)
            except NonPositiveEffectiveMassError:
                jam[k] = failed[k] = True
            except ConvImpactError:
                failed[k] = True
            else:
                pi[k] = sol.impulse
                regime[k] = REGIMES.index(sol.regime)
            k += 1
            if bar:
                bar.update(k)
    return pi, regime, jam, failed


def _landscape_from_impulses(P: ImpactProblem, e, mu, pi, regime, jam, failed, law, method,
                             tol, law_meta: Mapping[str, Any] | None = None) -> Landscape:
    """Energy, velocities and the diagnostics' flags of a grid of contact impulses
    (``law_meta``: the law's parameters beyond e and mu, kept in ``meta``)."""
    W, v = P.contact_block(0)
    tiny = 1e-300
    T_minus = P.kinetic_energy(P.dq_minus)
    ok = ~failed
    p = np.where(ok[..., None], pi, 0.0)
    v_plus = v + p @ W.T
    dT = p @ v + 0.5 * np.einsum("...i,ij,...j->...", p, W, p)
    TL = np.where(ok, -dT, np.nan)
    v_plus = np.where(ok[..., None], v_plus, np.nan)
    gained = ok & (dT > tol * max(T_minus, tiny) * 10.0)
    pt, vt = p[..., 1:], v[1:]
    npt = np.linalg.norm(pt, axis=-1)
    pscale = np.maximum(np.linalg.norm(p, axis=-1), tiny)
    vscale = max(float(np.max(np.abs(v))), tiny)
    pushes = ok & (npt > tol * pscale) & (pt @ vt > tol * npt * float(np.linalg.norm(vt)))
    vtp = np.where(ok[..., None], v_plus[..., 1:], 0.0)
    nvtp = np.linalg.norm(vtp, axis=-1)
    slipping = nvtp > tol * 10.0 * vscale
    reversal = (ok & (regime == REGIMES.index("slide")) & slipping & (npt > tol * pscale)
                & (np.sum(pt * vtp, axis=-1) > tol * npt * nvtp))
    if P.planar:
        s = np.sign(vt[0]) if vt[0] != 0 else 1.0
        tangential_velocity = -s * v_plus[..., 1]
    else:
        tangential_velocity = np.linalg.norm(v_plus[..., 1:], axis=-1)
    return Landscape(
        e=e, mu=mu, energy_loss=TL, energy_loss_fraction=TL / T_minus,
        normal_impulse=np.where(ok, pi[..., 0], np.nan), tangential_impulse=pi[..., 1:],
        v_plus=v_plus, tangential_velocity=tangential_velocity, regime=regime,
        energy_gained=gained, friction_pushes_slip=pushes, slip_reversal=reversal, jammed=jam,
        failed=failed, stick_possible=regime == REGIMES.index("stick"), law=law, method=method,
        meta=MappingProxyType({"v_minus": v.tolist(), "energy_before": T_minus,
                               **(_sticking_meta(W, v) if P.planar else {}),
                               **(law_meta or {})}),
    )

