"""Exact derivatives of the cone complementarity laws ``ccp``, ``coulomb`` and
``dissipative``, at one contact (:data:`ccp_one`, ...) and at several (:data:`ccp_several`,
...): the implicit differentiation of their modes' equations
(:mod:`convimpact.impact.derivatives.modes`).

Each law's answer solves a cone complementarity problem with ``u = W pi + b``,

* ``ccp``: ``K_mu ∋ pi ⊥ u ∈ K_mu*`` (the KKT system of the cone program
  min 1/2 pi.W.pi + pi.b over K_mu), ``b = v + e min(v_n, 0) n``, contacts that do not
  approach (by more than round-off) without friction of their own;
* ``coulomb``: ``K_mu ∋ pi ⊥ u + mu |u_t| n ∈ K_mu*`` (De Saxce), the same b, every contact
  with its friction;
* ``dissipative``: the CCP with e = 0 (the plastic impulse ``pi_p``), then Poisson's scaling
  ``pi_i = (1 + e_i) pi_p,i`` contact by contact.

Per contact the answer is in one of four states: **separating** (pi = 0, u strictly inside
the dual cone: ``u_n > mu |u_t|`` for the CCP, ``u_n > 0`` for Coulomb), **frictionless**
(mu = 0 pressing: u_n = 0, pi_t = 0), **stick** (pi inside the cone, u = 0), **slide** (pi on
the cone's boundary ``|pi_t| = mu pi_n > 0``, ``u_t = -sigma t`` with ``t = pi_t / |pi_t|`` and
``sigma > 0``, ``u_n = mu sigma`` for the CCP -- its normal-velocity lift -- and ``u_n = 0`` for
Coulomb). Inside a mode these are smooth equations in ``(pi, sigma)``; their implicit
differentiation is the derivative. For the CCP it is exactly the differentiation of the KKT
system of its cone program with the active cone faces fixed.

Mode boundaries (one-sided derivatives, stated in ``one_sided``; ``other_side=True`` gives
the neighbouring mode's, all boundary contacts flipped at once):

* about to separate: ``pi_i = 0`` and u on the dual cone's boundary (for the CCP
  ``u_n = mu |u_t|``; Coulomb ``u_n = 0``): separating on one side, stick (u = 0) or slide
  (parametrized by the slip,
  :meth:`~convimpact.impact.derivatives.modes.ModeSystem.slide_on_slip`) on the other;
* the stick limit: pi on the cone's boundary with no slip (``u = 0``): stick | slide;
* a contact touching at ``v_n- = 0`` with e > 0: the kink of ``b_n = v_n + e min(v_n, 0)``
  (the derivative given is ``v_n- >= 0``'s); for the CCP and the dissipative law, a pressed
  contact approaching within round-off, which they give no friction of its own.

At one contact (the laws' ``impulse_derivative``, driven by
:mod:`convimpact.impact.derivatives.single`) the same modes with ``b = ((1 + e) v_n, v_t)``
(:func:`~convimpact.impact.derivatives.modes.cone_slide`), t moving with the data in space;
at mu = 0 the right derivative with respect to mu is along the frictionless answer's
post-impact slip. The impulse is continuous at the stick limit (sigma = 0 there); where
Coulomb's law has several sliding solutions the derivative is that of the one returned (the
most dissipative).

Redundant contacts (a singular mode system: the impulse non-unique, the velocity unique):
the engine's choice (where its interior point stops on its way to the analytic centre of the
solution set) has no derivative written here; NotSupportedError, or with
``redundant="velocity"`` the minimum-norm derivative exact for the velocity
(:meth:`~convimpact.impact.derivatives.modes.ModeSystem.solve`).
"""

from __future__ import annotations

import numpy as np

from ..conic.paths import APPROACH_RTOL, approaching, impulse_scale
from ...errors import ParameterError
from ..problem.build import ImpactProblem
from ..derivatives.modes import VELOCITY_ONLY, ModeSystem, check_redundant, cone_slide
from ..derivatives.single import law_entry, mu_zero_column, newton_mode, newton_stick

#: relative distance to a mode boundary below which the answer counts as on it
BOUNDARY_RTOL = 1e-7

#: law -> (lift of u_n on a slide, b holds Newton's e, friction at non-approaching contacts)
_LAWS = {"ccp": (1.0, True, False), "coulomb": (0.0, True, True),
         "dissipative": (1.0, False, False)}


def _answer(problem: ImpactProblem, result, law: str) -> np.ndarray:
    """The result's impulse (for ``dissipative``: its plastic impulse), flat."""
    if getattr(result, "law", law) != law:
        raise ParameterError(f"the result is law {result.law!r}'s, not {law!r}'s")
    n, d = problem.n_contacts, problem.dim
    pi = np.asarray(result.impulse, dtype=float).reshape(n * d)
    if law == "dissipative":
        plastic = result.diagnostics.extras.get("plastic_impulse")
        if plastic is not None:
            return np.asarray(plastic, dtype=float).reshape(n * d)
        return (pi.reshape(n, d) / (1.0 + problem.restitution)[:, None]).ravel()
    return pi


def classify(problem: ImpactProblem, pi: np.ndarray, u: np.ndarray, mu: np.ndarray,
             lift: float, reported: list[str]) -> list[tuple[str, str | None, str]]:
    """Per contact: (its mode, the neighbouring mode at a boundary or None, the statement).

    Modes: "separating", "frictionless", "stick", "slide" (on the cone, by the impulse) and
    "slide-slip" (by the slip: the slide next to a separation). ``reported``: the result's
    regimes, which decide on which side of a boundary the answer is taken to be.
    """
    n, d = problem.n_contacts, problem.dim
    tol = BOUNDARY_RTOL
    vscale = max(float(np.max(np.abs(problem.v_minus))), 1e-300)
    pscale = impulse_scale(problem)
    out = []

    def side(i, a, b, what):
        first, second = (b, a) if reported[i] == b.split("-")[0] else (a, b)
        return first, second, (f"contact {i}: {what}; the derivative is the one-sided one of "
                               f"the {first.split('-')[0]} mode, the other side "
                               f"{second.split('-')[0]}")

    for i in range(n):
        p = pi[i * d:(i + 1) * d]
        w = u[i * d:(i + 1) * d]
        pn, pt = p[0], float(np.linalg.norm(p[1:]))
        un, ut = w[0], float(np.linalg.norm(w[1:]))
        zero = float(np.linalg.norm(p)) <= tol * pscale
        if mu[i] == 0.0:
            if not zero:
                out.append(("frictionless", None, ""))
            elif un > tol * vscale:
                out.append(("separating", None, ""))
            else:
                out.append(side(i, "separating", "frictionless",
                                "about to separate (pi = 0 and u_n = 0)"))
            continue
        if zero:
            if un - lift * mu[i] * ut > tol * vscale:
                out.append(("separating", None, ""))
            else:
                other = "stick" if ut <= tol * vscale else "slide-slip"
                out.append(side(i, "separating", other,
                                "about to separate (pi = 0 with u on the dual cone's boundary)"))
        elif mu[i] * pn - pt > tol * float(np.linalg.norm(p)):
            out.append(("stick", None, ""))
        elif ut > tol * vscale:
            out.append(("slide", None, ""))
        else:
            out.append(side(i, "stick", "slide",
                            "at the stick limit (|pi_t| = mu pi_n with no post-impact slip)"))
    return out


def _solve_mode(problem: ImpactProblem, pi: np.ndarray, u: np.ndarray, modes: list[str],
                mu: np.ndarray, lift: float, newton: bool, law: str, redundant: str):
    """``d pi / d (W, v, e, mu)`` of the given modes (the law's own b and friction) at the
    answer ``pi`` with ``u = W pi + b``."""
    n, d = problem.n_contacts, problem.dim
    N = n * d
    sliding = [i for i in range(n) if modes[i] == "slide"]
    aux = np.zeros(len(sliding))
    for j, i in enumerate(sliding):  # u_t = -sigma t with t the tangential impulse's direction
        pt = pi[i * d + 1:(i + 1) * d]
        aux[j] = max(-float(u[i * d + 1:(i + 1) * d] @ pt) / float(np.linalg.norm(pt)), 0.0)
    S = ModeSystem(problem.delassus, problem.v_minus.ravel(),
                   problem.restitution if newton else None, d, pi, len(sliding), aux)
    col = {i: N + j for j, i in enumerate(sliding)}
    for i in range(n):
        mode = modes[i]
        if mode == "separating":
            S.separating(i)
        elif mode == "frictionless":
            S.frictionless(i, S.velocity(i * d))
        elif mode == "stick":
            S.stick(i)
        elif mode == "slide":
            S.slide_on_cone(i, float(mu[i]), lift, col[i],
                            [S.velocity(i * d + k) for k in range(d)])
        else:  # "slide-slip"
            S.slide_on_slip(i, float(mu[i]), lift)
    dW, dv, de, dmu, singular = S.solve(f"law {law!r} at {n} contacts ({', '.join(modes)})",
                                        redundant)
    if not newton:
        de = np.zeros_like(de)
    return dW, dv, de, dmu, singular


def _derivative(problem: ImpactProblem, result, law: str, other_side: bool, redundant: str):
    from ..derivatives.contact import ContactDerivative

    lift, newton, all_friction = _LAWS[law]
    n, d = problem.n_contacts, problem.dim
    pi = _answer(problem, result, law)
    mu = problem.friction if all_friction else np.where(approaching(problem), problem.friction,
                                                        0.0)
    S = ModeSystem(problem.delassus, problem.v_minus.ravel(),
                   problem.restitution if newton else None, d, pi)
    reported = [result.regime] * n if isinstance(result.regime, str) else list(result.regime)
    found = classify(problem, pi, S.u, mu, lift, reported)
    notes = [s for _, _, s in found if s]
    vn = problem.v_minus[:, 0]
    if not all_friction:  # a contact touching within round-off takes no friction of its own
        notes += [f"contact {i}: touching within round-off (|v_n-| <= {APPROACH_RTOL:g} "
                  "max |v-|) and pressed: the law gives it no friction of its own, as it "
                  "would by approaching faster (then its friction acts: the answer jumps); "
                  "one-sided" for i in range(n) if problem.friction[i] > 0.0 and mu[i] == 0.0
                  and vn[i] <= 0.0 and found[i][0] != "separating"]
    if newton:
        notes += [f"contact {i}: touching (v_n- = 0) with e > 0, the kink of Newton's "
                  "b_n = v_n + e min(v_n, 0): the derivative is that of a contact not "
                  "approaching (d b_n / d v_n = 1; approaching, 1 + e)"
                  for i in range(n) if vn[i] == 0.0 and problem.restitution[i] > 0.0
                  and found[i][0] != "separating"]

    def build(modes, statements, other):
        dW, dv, de, dmu, singular = _solve_mode(problem, pi, S.u, modes, mu, lift, newton,
                                                law, redundant)
        if singular:
            statements = [*statements, VELOCITY_ONLY]
        if law == "dissipative":  # pi = (1 + e_i) pi_p,i
            scale = np.repeat(1.0 + problem.restitution, d)
            dW, dv = dW * scale[:, None, None], dv * scale[:, None]
            dmu = dmu * scale[:, None]
            de = np.zeros((n * d, n))
            for i in range(n):
                de[i * d:(i + 1) * d, i] = pi[i * d:(i + 1) * d]
        return ContactDerivative(W=dW, v=dv, e=de, mu=dmu, e_t=None,
                                 regimes=tuple(m.split("-")[0] for m in modes),
                                 one_sided=tuple(statements), other_side=other)

    other = None
    if other_side and any(o is not None for _, o, _ in found):  # every boundary flipped
        flipped = [o if o is not None else m for m, o, _ in found]
        other = build(flipped, [s + " (this is the other side)" for s in notes if s], None)
    return build([m for m, _, _ in found], notes, other)


def _entry(law: str):
    def several_impulse_derivative(problem: ImpactProblem, result, other_side: bool = False,
                                   *, redundant: str = "raise"):
        """Derivative of the contact-frame impulse of law ``{law}`` at several contacts with
        respect to ``(W, v_minus, e, mu)`` inside the answer's mode (module docstring).

        Parameters
        ----------
        problem : ImpactProblem
            The problem the result answers (:func:`~convimpact.impact.problem.build.build_problem`).
        result : ImpactResult
            An answer of law ``{law}`` (any method).
        other_side : bool
            At a mode boundary, also the neighbouring mode's derivative (``.other_side``).
        redundant : {"raise", "velocity"}
            Where redundant contacts leave the impulse non-unique: raise NotSupportedError,
            or give the minimum-norm derivative of the mode's equations, exact for the
            velocity (``W dpi``, ``G Jc^T dpi``), stated in ``one_sided``.

        Returns
        -------
        ContactDerivative

        Raises
        ------
        NotSupportedError
            Redundant contacts with ``redundant="raise"``: the impulse is not unique (the
            velocity is).
        ParameterError
            The result is another law's, or ``redundant`` is not one of its values.
        """
        check_redundant(redundant)
        return _derivative(problem, result, law, other_side, redundant)

    several_impulse_derivative.__doc__ = several_impulse_derivative.__doc__.replace("{law}", law)
    several_impulse_derivative.__qualname__ = f"{law}.several_impulse_derivative"
    return several_impulse_derivative


#: each law's ``several_impulse_derivative`` (re-exported under that name by its module)
ccp_several = _entry("ccp")
coulomb_several = _entry("coulomb")
dissipative_several = _entry("dissipative")



# --------------------------------------------------------------------------------------------
# one contact


def _plastic(mode):
    """pi = (1 + e) pi_p, pi_p the CCP impulse with e = 0 (its derivative with e held at 0)."""
    def scaled(W, v, e, mu, et, regime, p):
        pp = p / (1.0 + e)
        dpp = mode(W, v, 0.0, mu, et, regime, pp)
        dpp[:, -3] = 0.0  # the plastic impulse does not depend on e
        dp = (1.0 + e) * dpp
        dp[:, -3] += pp
        return dp
    return scaled


def _cone_mode(law):
    return newton_mode(lambda W, v, e, mu, p: cone_slide(law, W, v, e, mu, p))


#: each law's ``impulse_derivative`` (re-exported under that name by its module)
ccp_one = law_entry(
    "ccp", """Derivative of the CCP impulse of one contact with respect to (W, v_minus, e, mu):
    implicit differentiation of the program's KKT conditions in the answer's mode (interior:
    ``W pi + b = 0``; boundary: ``W pi + b = sigma (mu, -t)``, ``|pi_t| = mu pi_n``, with its
    multiplier sigma); one-sided at the stick limit and, for mu, at mu = 0 (module docstring).""",
    _cone_mode("ccp"), stick_of=newton_stick,
    mu_zero=lambda W, v, e, et: mu_zero_column("ccp", W, v, e))
coulomb_one = law_entry(
    "coulomb", """Derivative of the Coulomb impulse of one contact with respect to
    (W, v_minus, e, mu): stick ``W pi = -b``, slide ``u_n = 0``, ``u_t = -sigma t`` with
    ``|pi_t| = mu pi_n``, differentiated implicitly with the slip speed sigma; one-sided at
    the stick limit and, for mu, at mu = 0 (module docstring).""",
    _cone_mode("coulomb"), stick_of=newton_stick,
    mu_zero=lambda W, v, e, et: mu_zero_column("coulomb", W, v, e))
dissipative_one = law_entry(
    "dissipative", """Derivative of the dissipative impulse of one contact with respect to
    (W, v_minus, e, mu): ``d pi = (1 + e) d pi_p + pi_p de``, with ``d pi_p`` the CCP law's at
    e = 0; one-sided at the plastic stick limit and, for mu, at mu = 0.""",
    _plastic(_cone_mode("ccp")),
    stick_of=lambda W, v, e, mu, et: (1.0 + e) * newton_stick(W, v, 0.0, mu, et),
    mu_zero=lambda W, v, e, et: (1.0 + e) * mu_zero_column("ccp", W, v, 0.0))

__all__ = ["ccp_several", "coulomb_several", "dissipative_several", "ccp_one", "coulomb_one",
           "dissipative_one", "classify"]
