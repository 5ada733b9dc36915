"""Measure what an impact law's answer did: the one place every solver path builds its result.

Given a contact impulse, :func:`assemble_result` maps it back to joint velocities and loop
impulses (eqs. 29, 44, 45) and the energy change (eq. 58), and attaches the diagnostics: the
invariants the brief asks for -- restitution on the normal velocity, the friction cone,
friction opposing post-impact slip, C Delta theta_dot = 0, momentum balance, energy (eq. 58),
and the failure flags of Newton's law with friction -- measured by :func:`measure` on first
access, not on every call.

Every quantity is measured relative to the data's own scales: impulses relative to the largest
impulse, velocities to the largest pre-impact velocity, energies to T-; data outside
1e-100 .. 1e100 are normalized first, so no square under- or overflows and multiplying M by
``a`` and dq by ``b`` changes no flag and no residual.
"""

from __future__ import annotations

import math
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import NonFiniteError
from .problem.build import ImpactProblem, _new
from .results import ImpactDiagnostics, ImpactResult

_TINY = 1e-300
_NO_EXTRAS: Mapping[str, Any] = MappingProxyType({})
#: scales within which the diagnostics use the data unnormalized (bit-for-bit the formulas)
_PLAIN = (1e-100, 1e100)


def _norm(x) -> float:
    x = np.ravel(x)
    return float(np.sqrt(x @ x))


def _plain(s: float) -> bool:
    return _PLAIN[0] <= s <= _PLAIN[1]


def energy_change(p: np.ndarray, v: np.ndarray, W: np.ndarray, pl: list, vl: list) -> float:
    """T+ - T- = pi.v- + 1/2 pi.W.pi (eq. 58 in contact space; Delta sigma does no work
    because C theta_dot- = 0), for the flat impulse ``p`` and velocity ``v`` (also as the
    lists ``pl``, ``vl``) and the Delassus matrix ``W``.

    Outside 1e-100 .. 1e100 the impulse and velocity are normalized first, so the answer is
    finite, or +-inf (never NaN) where the energy itself exceeds double precision.
    """
    ps = max(map(abs, pl)) if pl else 0.0
    if ps == 0.0:
        return 0.0
    vs = max(map(abs, vl)) or 1.0
    if 1e-100 <= ps <= 1e100 and 1e-100 <= vs <= 1e100:  # _plain(ps) and _plain(vs)
        return float(p @ v + 0.5 * p @ W @ p)
    ph = p / ps
    q = float(ph @ (v / vs) + 0.5 * ph @ ((W @ ph) * (ps / vs)))
    return 0.0 if q == 0.0 else q * ps * vs


class _Answer:
    """What :func:`measure` needs of one result (kept by the diagnostics until first read):
    the problem (which owns its arrays) and a private copy of the impulse, from which the
    velocities are recomputed exactly as :func:`assemble_result` computed them."""

    __slots__ = ("problem", "pi", "regimes", "tol", "dT", "works")

    def __init__(self, problem: ImpactProblem, pi: np.ndarray, regimes: tuple, tol: float,
                 dT: float, works: np.ndarray | None = None):
        self.problem, self.pi, self.regimes, self.tol, self.dT = problem, pi, regimes, tol, dT
        self.works = works  # energetic restitution's normal works, see restitution_works

    def __call__(self) -> dict[str, Any]:
        return measure(self)


def _energy_flags(a: _Answer, dq_plus, sp: float, sv: float, p, vm, vp) -> tuple:
    """(T-, T+, energy_gained): in the data's units where they are plain, else normalized."""
    P, dT, tol = a.problem, a.dT, a.tol
    T_minus = P.kinetic_energy(P.dq_minus)
    if sp == 1.0 and sv == 1.0 and math.isfinite(dT) and _PLAIN[0] <= T_minus <= _PLAIN[1]:
        return T_minus, T_minus + dT, dT > tol * max(T_minus, _TINY) * 10.0
    T_plus = T_minus + dT
    if not (math.isfinite(T_minus) and math.isfinite(T_plus)):
        T_plus = P.kinetic_energy(dq_plus)
    # scale-free: (T+ - T-) / (sp sv) = 1/2 pi^.(v-^ + v+^) against 10 tol T- / (sp sv)
    dTh = 0.5 * float(np.sum(p * (vm + vp)))
    dq = P.dq_minus
    ds = float(np.max(np.abs(dq)))
    if dTh <= 0.0 or ds == 0.0:
        return T_minus, T_plus, False
    ms = P._mass_scale
    u = dq / ds
    That = 0.5 * float(u @ (P.mass_matrix / ms) @ u) * math.exp(
        math.log(ms) + 2.0 * math.log(ds) - math.log(sp) - math.log(sv))
    return T_minus, T_plus, dTh > tol * 10.0 * That


# --- energetic restitution (law "stronge", issue 16) -------------------------------------
def restitution_works(extras: Mapping[str, Any] | None, n: int) -> np.ndarray | None:
    """(n, 2) normal works (W_c, W_r) per contact -- the work of the normal impulse in
    compression and in restitution -- when the answer's ``extras`` state them (a law with
    energetic restitution: ``normal_work_compression`` / ``normal_work_restitution``, per
    contact under ``extras["contacts"]`` for several), else None (Newton's restitution)."""
    if not extras:
        return None
    rows = [extras] if "normal_work_compression" in extras else extras.get("contacts")
    if not rows or len(rows) != n:
        return None
    works = np.zeros((n, 2))
    for i, row in enumerate(rows):
        if "normal_work_compression" not in row:
            return None
        works[i] = row["normal_work_compression"], row["normal_work_restitution"]
    return works


def energetic_residual(works: np.ndarray, e: np.ndarray) -> float:
    """Max over contacts of |W_r + e^2 W_c| / |W_c| (Stronge's energetic restitution:
    the normal impulse's work in restitution is -e^2 times its work in compression); 0 for a
    contact that did no work in compression (no impulse)."""
    wc, wr = works[:, 0], works[:, 1]
    scale = np.abs(wc)
    res = np.where(scale > 0.0, np.abs(wr + e * e * wc) / np.where(scale > 0.0, scale, 1.0),
                   0.0)
    return float(np.max(res)) if res.size else 0.0
# --- end energetic restitution ----------------------------------------------------------


def measure(a: _Answer) -> dict[str, Any]:
    """The diagnostics of one answer (see :class:`~convimpact.impact.results.ImpactDiagnostics`),
    with the statement of each flag raised under ``"flag_warnings"``."""
    P, tol, pi = a.problem, a.tol, a.pi
    n, d = pi.shape
    d_dq, dsigma = P.velocity_jump(pi.ravel())  # as assemble_result did, bit for bit
    dq_plus = P.dq_minus + d_dq
    v_minus, v_plus = P.v_minus, (P._rows @ dq_plus).reshape(n, d)
    ps = float(np.max(np.abs(pi))) if pi.size else 0.0
    vs = float(np.max(np.abs(v_minus)))
    sp = ps if ps > 0.0 and not _plain(ps) else 1.0  # normalize only outside 1e+-100
    sv = vs if vs > 0.0 and not _plain(vs) else 1.0
    p = pi / sp if sp != 1.0 else pi
    vm = v_minus / sv if sv != 1.0 else v_minus
    vp = v_plus / sv if sv != 1.0 else v_plus
    T_minus, T_plus, energy_gained = _energy_flags(a, dq_plus, sp, sv, p, vm, vp)

    pi_scale = max(_norm(p), _TINY)
    v_scale = max(float(np.max(np.abs(vm))), _TINY)
    # per-contact checks, vectorized over contacts
    pn, pt = p[:, 0], p[:, 1:]
    vt_minus, vt_plus = vm[:, 1:], vp[:, 1:]
    mu, e = P.friction, P.restitution
    npt = np.sqrt(np.einsum("ij,ij->i", pt, pt))
    nvt_minus = np.sqrt(np.einsum("ij,ij->i", vt_minus, vt_minus))
    nvt_plus = np.sqrt(np.einsum("ij,ij->i", vt_plus, vt_plus))
    acting = npt > tol * pi_scale
    pushes = bool(np.any(acting & (np.einsum("ij,ij->i", pt, vt_minus)
                                   > tol * npt * nvt_minus)))
    slipping = nvt_plus > tol * 10.0 * v_scale
    sliding = np.array([r == "slide" for r in a.regimes])
    reversal = bool(np.any(sliding & slipping & acting
                           & (np.einsum("ij,ij->i", pt, vt_plus) > tol * npt * nvt_plus)))
    cone = float(np.max(np.maximum.reduce([np.zeros_like(pn), npt - mu * pn, -pn]))) / pi_scale
    pressed = pn > tol * pi_scale
    coulomb = 0.0
    opposing = slipping & pressed
    if opposing.any():
        u_dir = vt_plus[opposing] / nvt_plus[opposing, None]
        miss = pt[opposing] + (mu * pn)[opposing, None] * u_dir
        coulomb = float(np.max(np.sqrt(np.einsum("ij,ij->i", miss, miss)))) / pi_scale
    penetration = bool(np.any(vp[:, 0] < -tol * 10.0 * v_scale))
    target = -e * np.minimum(vm[:, 0], 0.0)  # Newton's law (eq. 21) on approaching contacts
    restitution = float(np.max(np.where(pressed, np.abs(vp[:, 0] - target),
                                        np.maximum(0.0, target - vp[:, 0])))) / v_scale
    # --- energetic restitution (law "stronge", issue 16) ---------------------------------
    if a.works is not None:
        restitution = energetic_residual(a.works, e)
    # --- end energetic restitution ----------------------------------------------------------

    C = P.loop_jacobian
    loop_res = 0.0
    if P.n_loops:
        ds = float(np.max(np.abs(P.dq_minus)))
        sd = ds if ds > 0.0 and not _plain(ds) else 1.0
        loop_res = _norm(C @ (dq_plus / sd)) / max(
            np.linalg.norm(C) * _norm(P.dq_minus / sd), _TINY)
    gen_impulse = P.jacobian_rows.T @ p.ravel()
    mom_res = _norm(P.mass_matrix @ (d_dq / sp) - gen_impulse - C.T @ (dsigma / sp)) / max(
        _norm(gen_impulse), _TINY)

    flags = []
    if not (math.isfinite(T_minus) and math.isfinite(T_plus)):
        flags.append("the kinetic energies exceed double precision's range: T- and T+ are "
                     "reported as inf (impulses, velocities and the energy loss are exact)")
    elif T_minus < _PLAIN[0] * 1e-200 and P.dq_minus.any():
        flags.append("the kinetic energies are below double precision's range: T-, T+ and the "
                     "energy loss are rounded to (nearly) 0; the flags are measured scale-free")
    if energy_gained:
        flags.append(f"energy gained: T+ - T- = {a.dT:.6g} (the law created energy)")
    if pushes:
        flags.append("friction impulse pushes along the pre-impact slip (pi_t . v_t- > 0)")
    if reversal:
        flags.append("slip reversal: post-impact slip is not opposed by the friction impulse")
    if penetration:
        flags.append("penetration: a contact still approaches after the impact (v_n+ < 0)")
    return {
        "energy_before": T_minus, "energy_after": T_plus, "energy_gained": bool(energy_gained),
        "friction_pushes_slip": pushes, "slip_reversal": reversal, "penetration": penetration,
        "restitution_residual": float(restitution), "cone_violation": float(cone),
        "coulomb_residual": float(coulomb), "loop_residual": float(loop_res),
        "momentum_residual": float(mom_res), "flag_warnings": tuple(flags),
    }


def assemble_result(
    problem: ImpactProblem,
    impulse: np.ndarray,
    regimes: Sequence[str],
    law: str,
    method: str,
    *,
    effective_mass: float | None = None,
    tol: float = 1e-9,
    extras: Mapping[str, Any] | None = None,
    warnings: Sequence[str] = (),
) -> ImpactResult:
    """Turn a contact impulse into an :class:`ImpactResult`; its diagnostics are measured on
    first access.

    Parameters
    ----------
    problem : the validated impact.
    impulse : (n_contacts, d) contact-frame impulses (or (d,) for one contact).
    regimes : one regime name per contact.
    law, method : names recorded in the result.
    effective_mass : sliding denominator of eq. (38)/(51), when the law used one.
    tol : relative accuracy of the solution (the solver's tolerance); flags are raised only
        beyond it, so that a solver's round-off is not reported as physics.
    extras, warnings : law-specific figures and statements to carry along.

    Raises
    ------
    NonFiniteError
        when the impulse or the velocity jump is not finite (beyond double precision's range).
    """
    P = problem
    n, d, _ = P.jacobians.shape
    if type(impulse) is not np.ndarray or impulse.dtype != np.float64:
        impulse = np.asarray(impulse, dtype=float)
    pi = impulse.reshape(n, d)
    flat = pi.ravel()
    pl = flat.tolist()
    if P._loop_cho is None:  # P.velocity_jump(flat) of an open loop, without the call
        d_dq, dsigma = P._minv_jt @ flat, np.zeros(0)
    else:
        d_dq, dsigma = P.velocity_jump(flat)
    dq_plus = P.dq_minus + d_dq
    v_flat = P._rows @ dq_plus
    v_plus = v_flat.reshape(n, d)
    # one sum of every figure: finite only if each is (else the exact test below decides)
    if not math.isfinite(sum(pl) + sum(dq_plus.tolist()) + sum(v_flat.tolist())):
        if not (all(map(math.isfinite, pl)) and np.isfinite(dq_plus).all()
                and np.isfinite(v_plus).all()):
            raise NonFiniteError(
                "the impulse or the velocity jump is not finite: it exceeds double precision's "
                "range for these units of M, Jc and dq; rescale them")
    dT = energy_change(flat, P.v_minus.ravel(), P.delassus, pl, P._vl)
    if not math.isfinite(dT):
        raise NonFiniteError(
            f"the energy change of the impact overflows double precision (T+ - T- = {dT}): "
            "the units of M and dq make kinetic energies exceed 1e308; rescale them")
    T_minus = P.kinetic_energy(P.dq_minus)
    if not (math.isfinite(T_minus) and math.isfinite(T_minus + dT)):
        # the answer's own figures are finite, but its energies are not (a separating
        # contact moving at 1e200 m/s): no inf is returned, as for the energy change
        raise NonFiniteError(
            f"the kinetic energy T- = 1/2 dq^T M dq = {T_minus} overflows double precision: "
            "the units of M and dq make kinetic energies exceed 1e308; rescale them")
    diag = _new(ImpactDiagnostics, dict(
        effective_mass=effective_mass,
        notes=(*P.notes, *warnings),
        extras=MappingProxyType(dict(extras)) if extras else _NO_EXTRAS,
        _source=_Answer(P, pi.copy(), tuple(regimes), tol, dT,
                        restitution_works(extras, n)),  # energetic restitution (issue 16)
        _delassus=P.delassus,
        _mass=P.mass_matrix,
        _loop=None if P._loop_cho is None else P.loop_matrix,
    ))
    if P.single:
        return _new(ImpactResult, dict(
            dq_plus=dq_plus, impulse=pi[0], loop_impulse=dsigma, regime=regimes[0],
            energy_loss=-dT, v_minus=P.v_minus[0].copy(), v_plus=v_plus[0], law=law,
            method=method, diagnostics=diag))
    return _new(ImpactResult, dict(
        dq_plus=dq_plus, impulse=pi, loop_impulse=dsigma, regime=tuple(regimes),
        energy_loss=-dT, v_minus=P.v_minus.copy(), v_plus=v_plus, law=law, method=method,
        diagnostics=diag))
