"""Newton polish of a conic answer on its active set, and the KKT residual that certifies it.

An interior-point answer on the cone boundary is accurate to about sqrt(tol) only; the polish
classifies each contact (zero, interior, on the boundary, frictionless-active) and solves the
KKT equations of that active set by Newton's method, keeping the answer only when the active
set is consistent (then it is an exact KKT point: the optimum of the convex program).

* A contact close to a classification threshold (an impulse barely inside the cone at the
  stick threshold mu ~ mu*, or barely nonzero) is ambiguous: its kinds across the threshold
  are tried too, nearest classification first, so the polish is exact on both sides of it.
* With an ill-conditioned Delassus matrix (a light hub on long spokes: cond(W) up to 1e10
  and more) the program's objective, the kinetic energy, hardly sees the light directions,
  and the interior-point method may stop far from the answer (``AlmostSolved``, or
  penetrating velocities). When no classification near its answer is consistent, every
  active set of up to :data:`POLISH_EXHAUSTIVE_MAX` combinations is tried (zero, interior,
  boundary with the tangent of the answer or opposite the slip): the velocities of a
  consistent active set are exact whatever the interior-point method reached.

The Newton solves run compiled (:mod:`~convimpact.impact.conic.polish_newton`: the active
sets of one phase in one call); the classification and the order of the active sets stay
here.

Every threshold is relative: impulses to ``X = max |x|``, velocities (``W x + q``) to
``V = max(|q|, |W x|)``, and the Newton residual to the round-off of forming ``W x + q``
(``|W| X``; with an ill-conditioned W the impulse is ``|q| / lambda_min(W)`` and cond(W) eps
is the accuracy any contact-space method reaches, :func:`roundoff_floor`).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

# the Newton's constants are the kernel's; POLISH_ACCEPT and VELOCITY_RESIDUAL_MAX are the
# conic paths' acceptance rule, imported from here by the laws and the lanes
from .polish_newton import (ACT, BND, EPS, INT, POLISH_ACCEPT, POLISH_BOUNDARY_RTOL,  # noqa: F401
                            POLISH_MAX_NEWTON, POLISH_ZERO_RTOL, TINY, VELOCITY_RESIDUAL_MAX,
                            ZERO, active_set_newton)
from ...compiled import announce, cached, plain
from .program import ConeQP

#: a classification within this factor of its threshold is ambiguous: the other kind is tried
POLISH_AMBIGUITY = 1e2
#: at most this many active sets are tried near the interior-point answer
POLISH_MAX_TRIES = 16
#: at most this many active sets are tried when none near the answer is consistent
POLISH_EXHAUSTIVE_MAX = 256

#: one contact's kind in an active set: ("zero" | "act" | "int", None) or ("bnd", tangent)
Kind = tuple


def _unit(t: np.ndarray) -> tuple | None:
    n = float(np.linalg.norm(t))
    return tuple(float(c) / n for c in t) if n > 0.0 and math.isfinite(n) else None


def _contact_kinds(qp: ConeQP, x: np.ndarray) -> list[list[Kind]]:
    """Per contact, the kinds to try near ``x``: the primary classification first.

    ``zero``: ``|x_i| <= 1e-4 X`` or ``x_n <= 0``; ``act``: a frictionless contact's normal
    pressing; ``bnd``: ``mu x_n - |x_t| <= 1e-4 |x_i|``; ``int``: strictly inside. A value
    within a factor :data:`POLISH_AMBIGUITY` of a threshold adds the kind across it.
    """
    d = qp.dim
    X = max(float(np.max(np.abs(x))), TINY)
    out = []
    for i, mu in enumerate(qp.mu):
        xi = x[i * d:(i + 1) * d]
        nx = float(np.linalg.norm(xi))
        if mu == 0.0:
            lives = [("act", None)]
        else:
            bnd = ("bnd", _unit(xi[1:]) or (1.0,) + (0.0,) * (d - 2))
            gap = (mu * xi[0] - np.linalg.norm(xi[1:])) / max(nx, TINY)
            if gap <= POLISH_BOUNDARY_RTOL:
                lives = [bnd, ("int", None)]
            elif gap <= POLISH_BOUNDARY_RTOL * POLISH_AMBIGUITY:
                lives = [("int", None), bnd]
            else:
                lives = [("int", None)]
        if nx <= POLISH_ZERO_RTOL * X or xi[0] <= 0.0:
            kinds = [("zero", None)] + (lives if nx > 0.0 else [])
        else:
            kinds = list(lives)
            if nx <= POLISH_ZERO_RTOL * POLISH_AMBIGUITY * X:
                kinds.append(("zero", None))
        out.append(kinds)
    return out


def _all_kinds(qp: ConeQP, x: np.ndarray, near: list[list[Kind]]) -> list[list[Kind]]:
    """Per contact, every kind (primary first): zero, interior, and the boundary with the
    tangent of ``x`` or opposite the slip of ``W x + q`` (both signs in the plane)."""
    d = qp.dim
    u = qp.W @ x + qp.q
    out = []
    for i, mu in enumerate(qp.mu):
        if mu == 0.0:
            kinds = [("zero", None), ("act", None)]
        else:
            kinds = [("zero", None), ("int", None)]
            for t in (_unit(x[i * d + 1:(i + 1) * d]), _unit(-u[i * d + 1:(i + 1) * d])):
                if t is not None and ("bnd", t) not in kinds:
                    kinds.append(("bnd", t))
            if d == 2:
                kinds += [k for k in (("bnd", (1.0,)), ("bnd", (-1.0,))) if k not in kinds]
        first = near[i][0]
        if first[0] == "bnd":  # the primary boundary kind replaces the one with its tangent
            kinds = [k for k in kinds if k[0] != "bnd" or k[1] != first[1]]
        out.append([first] + [k for k in kinds if k != first])
    return out


def classify_contacts(qp: ConeQP, x: np.ndarray) -> list[str]:
    """The primary kind of every contact (``zero``, ``act``, ``bnd`` or ``int``)."""
    return [k[0][0] for k in _contact_kinds(qp, x)]


def _active_sets(options: list[list[Kind]], limit: int):
    """Active sets in order of the number of contacts moved off their primary kind."""
    n = len(options)
    ambiguous = [i for i in range(n) if len(options[i]) > 1]
    tries = 0
    for flips in range(len(ambiguous) + 1):
        for chosen in itertools.combinations(ambiguous, flips):
            for alts in itertools.product(*(range(1, len(options[i])) for i in chosen)):
                kinds = [o[0] for o in options]
                for i, a in zip(chosen, alts):
                    kinds[i] = options[i][a]
                yield kinds
                tries += 1
                if tries >= limit:
                    return


def _kind_arrays(qp: ConeQP, sets: list[list[Kind]]) -> tuple[np.ndarray, np.ndarray]:
    """Active sets as the compiled Newton's arrays: kinds (n_sets, n) and tangents
    (n_sets, n, 2)."""
    code = {"zero": ZERO, "act": ACT, "int": INT, "bnd": BND}
    n = qp.n_contacts
    kinds = np.zeros((len(sets), n), dtype=np.int64)
    tangs = np.zeros((len(sets), n, 2))
    for j, kset in enumerate(sets):
        for i, (k, t) in enumerate(kset):
            kinds[j, i] = code[k]
            if t is not None:
                tangs[j, i, :len(t)] = t
    return kinds, tangs


#: the polish's Newton runs as plain Python (:func:`convimpact.compiled.plain`, the same
#: source) on programs of at most this many rows while its machine code is not cached, for
#: the first :data:`PLAIN_CALLS` polishes of a process: a first call does not wait ~7 s for
#: the compilation (a 4-contact program takes ~10 ms in Python)
PLAIN_MAX_ROWS = 24
PLAIN_CALLS = 200
_POLISHES = [0, None]  # polishes so far; whether the kernel is cached (None: not asked yet)


def _newton(rows: int):
    """The Newton to run on a program of ``rows`` rows: compiled, or its plain twin."""
    _POLISHES[0] += 1
    if rows <= PLAIN_MAX_ROWS and _POLISHES[0] <= PLAIN_CALLS:
        if _POLISHES[1] is None:
            _POLISHES[1] = cached(active_set_newton)
        if not _POLISHES[1]:
            return plain(active_set_newton)
    announce("polish's active-set Newton", 7, active_set_newton)
    return active_set_newton


def _first_certified(qp: ConeQP, x0: np.ndarray, sets: list[list[Kind]], coulomb: bool,
                     near: bool) -> tuple[np.ndarray, bool]:
    """The first of ``sets`` whose Newton solve is accepted (compiled,
    :func:`~convimpact.impact.conic.polish_newton.active_set_newton`): (x, True), else (x0,
    False)."""
    if not sets:
        return x0, False

    kinds, tangs = _kind_arrays(qp, sets)
    f = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    args = (f(qp.W), f(qp.q), f(qp.E), f(qp.f), f(qp.mu), int(qp.dim))
    start = f(x0)
    newton = _newton(start.size)
    for j in range(len(sets)):
        x, ok = newton(*args, kinds[j], tangs[j], start, bool(coulomb), bool(near),
                       POLISH_MAX_NEWTON, False, False)
        if ok:
            return x, True
    return x0, False


def polish_cone_qp(qp: ConeQP, x0: np.ndarray, coulomb: bool = False,
                   exhaustive: bool | None = None) -> tuple[np.ndarray, bool]:
    """Newton refinement of an interior-point answer on its active set (KKT equations).

    Each contact is classified from ``x0`` as zero, interior, on the cone boundary, or (when
    frictionless) active; the KKT system ``W x + q - E^T lambda - z = 0``, ``E x = f`` is then
    solved by Newton's method with ``x_i = r (1, mu c)``, ``z_i = kappa (mu, -c)`` on boundary
    contacts (c a unit tangent: the complementary pair of K_mu and its dual), ``z_i = 0`` on
    interior ones and ``x_i = 0`` on zero ones (minimum-norm steps: the Jacobian is singular
    when contacts are redundant). The answer is kept only when its residual is at round-off
    and it is consistent (r > 0, kappa >= 0, interior points inside, zero contacts' z in K*)
    and close to ``x0`` (within 1e-2 max |x0|). Contacts near a classification threshold are
    tried with their alternative kinds (at most :data:`POLISH_MAX_TRIES` active sets); if none
    is consistent and ``exhaustive`` (default: for the cone QP, not for Coulomb's law, whose
    fixed point calls the polish on every iterate), every active set (at most
    :data:`POLISH_EXHAUSTIVE_MAX`) is tried without the closeness test; when none is
    consistent ``x0`` is returned unchanged. The Newton solves are compiled
    (:mod:`~convimpact.impact.conic.polish_newton`).

    With ``coulomb=True`` the same active-set Newton solves Coulomb's law instead of the cone
    QP's KKT system (E must be empty): ``u = W x + q`` with ``u_i = 0`` (stick),
    ``u_i = kappa (0, -c)`` on sliding contacts (no normal lift) and ``u_n >= 0`` on zero ones.

    Returns
    -------
    x, polished (True when the refinement was accepted)
    """
    if qp.dim * qp.n_contacts + qp.E.shape[0] == 0:
        return np.zeros(0), True
    near = _contact_kinds(qp, x0)
    first = list(_active_sets(near, POLISH_MAX_TRIES))
    x, ok = _first_certified(qp, x0, first, coulomb, near=True)
    if ok:
        return x, True
    if not (not coulomb if exhaustive is None else exhaustive):
        return x0, False
    tried = {tuple(k) for k in first}
    rest = [k for k in _active_sets(_all_kinds(qp, x0, near), POLISH_EXHAUSTIVE_MAX)
            if tuple(k) not in tried]
    return _first_certified(qp, x0, rest, coulomb, near=False)


def kkt_residual(qp: ConeQP, x: np.ndarray) -> float:
    """Relative KKT residual of a cone-QP answer.

    The multipliers of ``E x = f`` are fitted by least squares on the rows where the cone
    leaves the stationarity free of a dual (interior and frictionless-normal rows, or all
    rows when there are none); then ``z = W x + q - E^T lambda``. The residual is the max of
    |E x - f| (relative to max(|f|, |E| X)), the cone violation of x (relative to
    X = max |x|), the dual-cone violation of z (relative to V = max(|q|, |W x|)) and
    |x_i . z_i| (relative to X V). Its floor is the round-off of forming W x + q,
    :func:`roundoff_floor`.
    """
    d, n, m = qp.dim, qp.n_contacts, qp.E.shape[0]
    g = qp.W @ x + qp.q
    lam = np.zeros(m)
    if m:
        rows = np.zeros(n * d, dtype=bool)
        for i, k in enumerate(classify_contacts(qp, x)):
            if k == "int":
                rows[i * d:(i + 1) * d] = True
            elif k == "act":
                rows[i * d] = True
        if rows.sum() < m:
            rows[:] = True
        lam, *_ = np.linalg.lstsq(qp.E.T[rows], g[rows], rcond=None)
    z = g - qp.E.T @ lam
    X = max(float(np.max(np.abs(x), initial=0.0)), TINY)
    V = max(float(np.max(np.abs(qp.q), initial=0.0)), float(np.max(np.abs(qp.W @ x))), TINY)
    r = 0.0
    if m:
        r = float(np.max(np.abs(qp.E @ x - qp.f))) / max(
            float(np.max(np.abs(qp.f))), float(np.max(np.abs(qp.E))) * X, TINY)
    for i, mu in enumerate(qp.mu):
        xi, zi = x[i * d:(i + 1) * d], z[i * d:(i + 1) * d]
        if mu == 0.0:
            r = max(r, max(0.0, -xi[0]) / X, float(np.max(np.abs(xi[1:]))) / X,
                    max(0.0, -zi[0]) / V, abs(xi[0] * zi[0]) / (X * V))
        else:
            r = max(r, max(0.0, np.linalg.norm(xi[1:]) - mu * xi[0]) / X,
                    max(0.0, mu * np.linalg.norm(zi[1:]) - zi[0]) / V,
                    abs(float(xi @ zi)) / (X * V))
    return r


def roundoff_floor(qp: ConeQP, x: np.ndarray) -> float:
    """The relative residual that round-off alone leaves in W x + q: eps |W| X / V.

    With an ill-conditioned W the impulse X is of order |q| / lambda_min(W), and forming
    the velocities ``W x + q`` cancels digits: cond(W) eps is the accuracy any contact-space
    method (closed forms included) reaches there.
    """
    X = max(float(np.max(np.abs(x), initial=0.0)), TINY)
    V = max(float(np.max(np.abs(qp.q), initial=0.0)), float(np.max(np.abs(qp.W @ x))), TINY)
    return EPS * float(np.max(np.abs(qp.W), initial=0.0)) * X / V
