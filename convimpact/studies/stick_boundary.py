"""The exact boundary of the stick region of one planar impact over (mu, e):
:class:`StickBoundary` and :func:`stick_boundary` (part of the landscapes' API;
:mod:`convimpact.studies.landscape` re-exports them), with the sticking impulse of
eq. (42)/(52) that the landscapes keep in their ``meta`` (:func:`_sticking_meta` writes it,
:func:`_boundary_from_meta` reads it back; a landscape's own boundary is
:func:`convimpact.studies.landscape.landscape_stick_boundary`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..errors import ShapeError
from ..impact.problem.build import ImpactProblem, build_problem


def _planar_problem(M, Jc, dq, C) -> ImpactProblem:
    P = build_problem(M, Jc, dq, 0.0, 0.0, C)
    if P.n_contacts != 1 or not P.planar:
        raise ShapeError("the closed-form landscape takes one planar contact (Jc of shape 2 x k)")
    return P


def _sticking_meta(W: np.ndarray, v: np.ndarray) -> dict[str, Any]:
    """``meta`` entries of a planar landscape: the sticking impulse of eq. (42)/(52) at e = 0
    and its derivative in e (see :class:`StickBoundary`); none where W is singular."""
    lam = np.linalg.eigvalsh(W)
    if not lam[0] > 1e-12 * lam[-1]:
        return {}
    Winv = np.linalg.inv(W)
    return {"sticking_impulse_e0": (-Winv @ v).tolist(),
            "sticking_impulse_de": (-Winv[:, 0] * v[0]).tolist(),
            # law "stronge": the stick ratio |W_tn| / W_tt and the pre-impact slip's sign
            "stick_ratio": abs(float(W[0, 1])) / float(W[1, 1]),
            "slip_sign": float(np.sign(v[1])),
            # law "chatterjee-ruina": the frictionless plastic impulse's normal component
            "frictionless_impulse_e0": -float(v[0]) / float(W[0, 0])}


#: laws whose single-contact stick test is the sticking impulse of eq. (42)/(52) in the cone
_STICK_AT_E = ("pereira-nikravesh", "coulomb", "ccp")
#: laws with an exact stick boundary (:class:`StickBoundary`)
_STICK_LAWS = _STICK_AT_E + ("dissipative", "stronge", "chatterjee-ruina")


@dataclass(frozen=True, eq=False)
class StickBoundary:
    """The exact boundary of the stick region of one planar impact over (mu, e).

    The sticking impulse of eq. (42)/(52), pi(e) = -W^-1 ((1 + e) v_n-, v_t-), is affine in e:
    pi(e) = ``pi0`` + e ``pi1`` (Cramer's rule gives pi_n = D_1/D, pi_t = D_2/D, the
    determinants of eq. 62). The law sticks where it lies in the cone, |pi_t(e)| <= |mu| pi_n(e),
    that is where |mu| >= ``mu_star(e)`` = |pi_t(e)| / pi_n(e) (``inf`` where pi_n(e) <= 0: no
    friction sticks). The boundary is the curve |mu| = mu_star(e): a V through mu = 0 at the
    e where pi_t(e) = 0, not a staircase of grid cells.

    This holds for the ``pereira-nikravesh``, ``coulomb`` and ``ccp`` laws (each sticks exactly
    when the sticking impulse is admissible). The ``dissipative`` law's plastic phase sticks
    when pi(0) is admissible whatever e: its boundary is the vertical line mu = mu_star(0).

    ``stronge`` (mu >= 0) ends in stick when its first slip (friction -mu s, s = sgn v_t-,
    a single linear phase whose normal impulse would end at (1 + e) p_c) stops before the
    collision ends, and sticking is then admissible, mu >= ``stick_ratio`` = |W_tn| / W_tt.
    The stop comes first iff |v_t| (W_nn - mu s W_tn) <= (1 + e) |v_n| (mu W_tt - s W_tn),
    i.e. mu pi_n(e) >= -s pi_t(e) with the same sticking impulse: so
    mu_star(e) = max(``stick_ratio``, -s pi_t(e) / pi_n(e)) (where pi_n(e) > 0; ``inf``
    elsewhere), and ``stick_ratio`` alone with no pre-impact slip (s = 0).

    ``chatterjee-ruina`` sticks where its candidate J^(e) = (1 + e) J_I + k (J_II - J_I) lies
    in the cone (k = 1 + e_t; J_I = (-v_n/W_nn, 0) the frictionless plastic impulse, J_II the
    sticking impulse at e = 0). J^ is affine in e too: ``pi0`` = k J_II + (1 - k) J_I and
    ``pi1`` = J_I take the place of the sticking impulse's, and mu_star(e) = |J^_t| / J^_n
    as above (its tangential part k (J_II - J_I)_t does not depend on e, so the curve has no
    kink and never reaches mu = 0 unless J_II stops the slip with no tangential impulse).
    """

    pi0: np.ndarray
    pi1: np.ndarray
    law: str = "pereira-nikravesh"
    stick_ratio: float = 0.0
    slip_sign: float = 1.0

    def sticking_impulse(self, e) -> np.ndarray:
        """(pi_n, pi_t) of eq. (42)/(52) at e, shape (..., 2); at e = 0 for ``dissipative``;
        the candidate J^(e) for ``chatterjee-ruina``."""
        e = np.asarray(e, float)
        if self.law == "dissipative":
            e = np.zeros_like(e)
        return self.pi0 + e[..., None] * self.pi1

    def mu_star(self, e) -> np.ndarray:
        """The least |mu| at which the law sticks at e (``inf`` where it never sticks)."""
        p = self.sticking_impulse(e)
        if self.law == "stronge":
            if self.slip_sign == 0.0:
                return np.full(p.shape[:-1], self.stick_ratio)
            with np.errstate(divide="ignore", invalid="ignore"):
                q = np.where(p[..., 0] > 0.0, -self.slip_sign * p[..., 1] / p[..., 0], np.inf)
            return np.maximum(q, self.stick_ratio)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(p[..., 0] > 0.0, np.abs(p[..., 1]) / p[..., 0], np.inf)

    def e_at(self, mu: float) -> np.ndarray:
        """The e in [0, 1] where the boundary crosses the column ``mu`` (closed form, sorted).

        Solves |pi_t0 + e pi_t1| = |mu| (pi_n0 + e pi_n1) with pi_n > 0: two linear equations.
        """
        c = abs(float(mu))
        if self.law == "dissipative":
            return np.array([])  # a vertical line: no crossing of a column unless on it
        (an, at), (bn, bt) = self.pi0, self.pi1
        roots = []
        signs = (1.0, -1.0)
        if self.law == "stronge":  # -s pi_t(e) = mu pi_n(e), on or right of the stick ratio
            if self.slip_sign == 0.0 or c < self.stick_ratio:
                return np.array([])
            signs = (-self.slip_sign,)
        for sign in signs:
            den = bt - sign * c * bn
            if den != 0.0:
                e = (sign * c * an - at) / den
                if 0.0 <= e <= 1.0 and an + bn * e > 0.0:
                    roots.append(e)
        return np.unique(np.array(roots, float))

    def curve(self, mu_max: float, n: int = 801) -> tuple[np.ndarray, np.ndarray]:
        """Points (e, mu_star(e)) of the boundary with 0 <= mu_star <= ``mu_max``, e in [0, 1].

        The set {e : mu_star(e) <= mu_max} is one interval (a second-order-cone condition in
        e); it is sampled at ``n`` values of e and at the crossings of ``n`` columns of mu
        (:meth:`e_at`), its exact ends and the kink pi_t(e) = 0 included.
        Returns empty arrays when the law does not stick for |mu| <= mu_max.
        """
        mu_max = abs(float(mu_max))
        if self.law == "dissipative":
            m = float(self.mu_star(0.0))
            if m <= mu_max:
                return np.array([0.0, 1.0]), np.array([m, m])
            return np.array([]), np.array([])
        ends = self.e_at(mu_max)
        grid = np.linspace(0.0, 1.0, n)
        at, bt = float(self.pi0[1]), float(self.pi1[1])
        extra = [-at / bt] if bt != 0.0 and 0.0 <= -at / bt <= 1.0 else []  # the kink
        if self.law == "stronge":  # its kink: where the curve meets the stick ratio
            extra = list(self.e_at(self.stick_ratio))
        # and the crossings of n columns: dense where the curve runs flat in e
        cols = [self.e_at(m) for m in np.linspace(0.0, mu_max, n)[1:]]
        e = np.unique(np.concatenate([grid, ends, extra, *cols]))
        m = self.mu_star(e)
        keep = m <= mu_max * (1.0 + 1e-12)
        keep |= np.isin(e, ends)
        return e[keep], np.minimum(m[keep], mu_max)


def stick_boundary(M, Jc, dq, C=None, law: str = "pereira-nikravesh", *,
                   e_t=None) -> StickBoundary:
    """The exact stick boundary of one planar contact (see :class:`StickBoundary`).

    ``e_t`` is the tangential restitution of law ``"chatterjee-ruina"`` (in [-1, 1], default
    0), refused with the other laws. Raises :class:`~convimpact.errors.SingularSystemError`
    where W is singular (the sticking impulse is not unique) and ``UnknownOptionError`` for an
    unknown law.
    """
    from ..errors import SingularSystemError, UnknownOptionError
    from ..impact.problem.build import check_tangential_restitution
    from ..impact.resolve import check_law_parameters

    if law not in _STICK_LAWS:
        raise UnknownOptionError(f"unknown law {law!r}; choose one of "
                                 f"{', '.join(_STICK_LAWS)}")
    e_t = check_law_parameters(law, e_t)
    P = _planar_problem(M, Jc, dq, C)
    W, v = P.contact_block(0)
    meta = _sticking_meta(W, v)
    if not meta:
        raise SingularSystemError("the Delassus matrix W is singular: the sticking impulse of "
                                  "eq. (42)/(52) is not unique, so there is no stick boundary")
    if e_t is not None:
        meta["e_t"] = float(check_tangential_restitution(e_t)[0])
    return _boundary_from_meta(meta, law)


def _boundary_from_meta(meta: Mapping[str, Any], law: str) -> StickBoundary | None:
    """The :class:`StickBoundary` of law ``law`` from the entries :func:`_sticking_meta`
    wrote (None without them, or for a law without an exact boundary); for
    ``chatterjee-ruina`` with the landscape's ``e_t`` (0 when absent)."""
    if "sticking_impulse_e0" not in meta or law not in _STICK_LAWS:
        return None
    pi0 = np.asarray(meta["sticking_impulse_e0"], float)
    pi1 = np.asarray(meta["sticking_impulse_de"], float)
    if law == "chatterjee-ruina":
        if "frictionless_impulse_e0" not in meta:
            return None
        j1 = np.array([float(meta["frictionless_impulse_e0"]), 0.0])
        k = 1.0 + float(meta.get("e_t", 0.0))
        pi0, pi1 = k * pi0 + (1.0 - k) * j1, j1
    return StickBoundary(pi0=pi0, pi1=pi1, law=law,
                         stick_ratio=float(meta.get("stick_ratio", 0.0)),
                         slip_sign=float(meta.get("slip_sign", 1.0)))
