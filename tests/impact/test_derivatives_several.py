"""Exact impulse derivatives at several simultaneous contacts (``several_impulse_derivative`` of
laws pereira-nikravesh, ccp, coulomb, dissipative and chatterjee-ruina).

Oracles, each independent of the code under test:

* central finite differences of the impulse of the PUBLIC path (``build_problem`` +
  ``solve_problem`` at tol = 1e-12) along perturbations of dq, Jc, M, e, mu (and e_t), the
  contract's W-derivative contracted with the symmetric ``dW`` those induce
  (``dW = dJ G J^T + J G dJ^T``, ``-J G dM G J^T``). Step: the solvers answer to about 1e-12
  relative, the data are of order one and W's condition number below ~10, so the central
  difference's truncation (h^2 ~ 1e-10) and noise (1e-12 / h ~ 1e-7) both stay below the
  asserted 2e-6 with h = 1e-5;
* closed forms derived by hand: two independent frictionless contacts (W diagonal:
  ``pi_n,i = -(1 + e_i) v_i / W_ii``) and a frictionless coupled pair that both press
  (``pi_n = -(1 + e) W^-1 v_n``, so ``d pi / d v = -(1 + e) W^-1``, ``d pi = -W^-1 dW pi``);
* at a mode boundary the one-sided differences (forward and backward) match the derivative
  and its ``other_side`` (one each).

Problems with a prescribed mode (stick, slide, separate per contact) are constructed, not drawn
and filtered: an answer ``(pi, u)`` satisfying the law's complementarity conditions is chosen,
and ``v`` (then ``dq``, Jc having full row rank) is solved from ``u = W pi + b``.
"""

import numpy as np
import pytest

from convimpact.impact.errors import NotSupportedError, ParameterError
from convimpact.impact.laws import law_module
from convimpact.impact.problem.build import build_problem
from convimpact.impact.resolve import solve_problem

H = 1e-5
RTOL = 2e-6
CONE_LAWS = ("ccp", "coulomb", "dissipative")
METHOD = {"ccp": "interior", "coulomb": "interior", "dissipative": "interior",
          "pereira-nikravesh": "clarabel"}


def _solve(M, Jl, dq, e, mu, law, e_t=None):
    P = build_problem(M, Jl, dq, e, mu, e_t=e_t)
    if law == "chatterjee-ruina":
        return P, solve_problem(P, law)
    return P, solve_problem(P, law, method=METHOD[law], tol=1e-12)


def _system(rng, n, d, coupling=0.25, extra=2):
    """A well-conditioned k-DOF system with n contacts: M near I, Jc of full row rank."""
    N = n * d
    k = N + extra
    A = rng.standard_normal((k, k))
    M = np.eye(k) + 0.1 * A @ A.T / k
    J = np.zeros((N, k))
    J[:, :N] = np.eye(N)
    J += coupling * rng.standard_normal((N, k)) / np.sqrt(k)
    return M, J


def _split(J, n, d):
    return [J[i * d:(i + 1) * d] for i in range(n)]


def _unit(rng, m):
    t = rng.standard_normal(m)
    return t / np.linalg.norm(t)


def _construct(rng, law, modes, d, mu=0.4, e=0.5):
    """(M, Jc list, dq, e, mu) whose answer under ``law`` has the given modes per contact
    ("sep", "stick", "slide", "limit": stick at the cone's boundary, "touch": pi = 0 with u on
    the dual cone's boundary), and the expected impulse."""
    n = len(modes)
    M, J = _system(rng, n, d)
    for i, m in enumerate(modes):
        if m == "touch":  # its normal shares contact 0's, so that the others press it
            J[i * d] = 0.7 * J[i * d] + 0.7 * J[0]
    W = J @ np.linalg.solve(M, J.T)
    lift = 0.0 if law == "coulomb" else 1.0
    pi, u = np.zeros(n * d), np.zeros(n * d)
    mus = np.broadcast_to(np.asarray(mu, dtype=float), (n,))
    for i, m in enumerate(modes):
        s = slice(i * d, (i + 1) * d)
        t = _unit(rng, d - 1)
        mu = mus[i]
        pn, sig = rng.uniform(0.5, 1.5), rng.uniform(0.3, 1.0)
        if m in ("sep", "touch"):
            ut = rng.standard_normal(d - 1) * (0.2 if m == "touch" else 1.0)
            gap = rng.uniform(0.3, 1.0) if m == "sep" else 0.0
            u[s] = np.r_[lift * mu * np.linalg.norm(ut) + gap, ut]
        elif m == "stick":
            pi[s] = np.r_[pn, mu * pn * rng.uniform(0.1, 0.7) * t]
        elif m == "zero":  # no impulse and no velocity: at the apex
            pass
        elif m == "limit":
            pi[s] = np.r_[pn, mu * pn * t]
        else:  # slide
            pi[s] = np.r_[pn, mu * pn * t]
            u[s] = np.r_[lift * mu * sig, -sig * t]
    pressed = [i for i in range(n) if modes[i] not in ("sep", "touch", "zero")]
    for _ in range(20):  # a pressed contact must approach (b_n < 0): press it harder
        b = u - W @ pi
        low = [i for i in pressed if not b[i * d] < 0.0]
        if not low:
            break
        for i in low:
            pi[i * d:(i + 1) * d] *= 1.5
    assert all(b[i * d] < 0.0 for i in pressed)
    e_b = 0.0 if law == "dissipative" else e
    v = b.copy()
    for i in range(n):
        if v[i * d] < 0.0:
            v[i * d] /= 1.0 + e_b
    dq = np.linalg.lstsq(J, v, rcond=None)[0]
    if law == "dissipative":
        pi = pi * (1.0 + e)
    return M, _split(J, n, d), dq, e, mus if np.ndim(mus) and np.ptp(mus) else mus[0], pi


def _predicted(D, dW, dv, de=None, dmu=None):
    out = np.einsum("aij,ij->a", D.W, dW) + D.v @ dv
    if de is not None:
        out = out + D.e @ de
    if dmu is not None:
        out = out + D.mu @ dmu
    return out


def _directions(rng, M, Jl, dq, e, mu):
    """Perturbation directions of the public arguments with the contact-space perturbations
    (dW, dv, de, dmu) they induce: a list of (name, step function, dW, dv, de, dmu)."""
    n, d = len(Jl), Jl[0].shape[0]
    J = np.vstack(Jl)
    G = np.linalg.inv(M)
    k = M.shape[0]
    e0 = np.broadcast_to(np.asarray(e, dtype=float), (n,)).copy()
    mu0 = np.broadcast_to(np.asarray(mu, dtype=float), (n,)).copy()
    ddq = rng.standard_normal(k)
    dJ = rng.standard_normal(J.shape)
    A = rng.standard_normal((k, k))
    dM = A + A.T
    de, dmu = rng.uniform(0.5, 1.0, n), rng.uniform(0.5, 1.0, n)
    zW, zv, zn = np.zeros((n * d, n * d)), np.zeros(n * d), np.zeros(n)
    return [
        ("dq", lambda s: (M, Jl, dq + s * ddq, e0, mu0), zW, J @ ddq, zn, zn),
        ("Jc", lambda s: (M, _split(J + s * dJ, n, d), dq, e0, mu0),
         dJ @ G @ J.T + J @ G @ dJ.T, dJ @ dq, zn, zn),
        ("M", lambda s: (M + s * dM, Jl, dq, e0, mu0), -J @ G @ dM @ G @ J.T, zv, zn, zn),
        ("e", lambda s: (M, Jl, dq, e0 + s * de, mu0), zW, zv, de, zn),
        ("mu", lambda s: (M, Jl, dq, e0, mu0 + s * dmu), zW, zv, zn, dmu),
    ]


def _check_fd(rng, law, M, Jl, dq, e, mu, D, pi_scale):
    """Max relative error of the derivative against central differences, per direction."""
    errors = {}
    for name, at, dW, dv, de, dmu in _directions(rng, M, Jl, dq, e, mu):
        fd = (_solve(*at(H), law)[1].impulse.ravel()
              - _solve(*at(-H), law)[1].impulse.ravel()) / (2 * H)
        pred = _predicted(D, dW, dv, de, dmu)
        errors[name] = float(np.max(np.abs(fd - pred)) / max(np.max(np.abs(fd)), pi_scale))
    return errors


def _mode_lists(d):
    return [["stick", "slide", "sep"], ["slide", "sep", "stick", "slide"],
            ["sep", "slide", "stick", "stick", "slide"],
            ["stick", "slide", "slide", "sep", "stick", "sep"], ["slide", "slide"]]


@pytest.mark.parametrize("law", CONE_LAWS)
@pytest.mark.parametrize("d", [2, 3])
def test_cone_laws_mixed_modes_match_finite_differences(law, d):
    rng = np.random.default_rng(100 + 10 * d + CONE_LAWS.index(law))
    for modes in _mode_lists(d):
        M, Jl, dq, e, mu, pi = _construct(rng, law, modes, d)
        P, R = _solve(M, Jl, dq, e, mu, law)
        assert np.max(np.abs(R.impulse.ravel() - pi)) <= 1e-9  # the constructed answer
        D = law_module(law).several_impulse_derivative(P, R)
        names = {"sep": "separating", "stick": "stick", "slide": "slide"}
        assert D.regimes == tuple(names[m] for m in modes)
        assert D.one_sided == () and D.other_side is None
        assert law_module(law).several_impulse_derivative(P, R, other_side=True).other_side \
            is None  # no boundary: no other side
        errors = _check_fd(rng, law, M, Jl, dq, e, mu, D, 1e-3 * np.max(np.abs(pi)))
        assert max(errors.values()) <= RTOL, (modes, errors)


@pytest.mark.parametrize("law", CONE_LAWS)
def test_cone_laws_derivative_is_the_same_from_every_method(law):
    """The derivative depends on the law's answer and mode, not on the method: from the
    answers of the conic paths (KKT-polished) it equals the interior point's."""
    rng = np.random.default_rng(110 + CONE_LAWS.index(law))
    M, Jl, dq, e, mu, _ = _construct(rng, law, ["stick", "slide", "sep", "slide"], 3)
    P = build_problem(M, Jl, dq, e, mu)
    ref = law_module(law).several_impulse_derivative(P, solve_problem(P, law,
                                                                      method="interior"))
    for method in ("clarabel", "cvxpy"):
        D = law_module(law).several_impulse_derivative(P, solve_problem(P, law, method=method))
        assert D.regimes == ref.regimes
        for name in ("W", "v", "e", "mu"):
            a, b = getattr(D, name), getattr(ref, name)
            assert np.max(np.abs(a - b)) <= 1e-7 * max(np.max(np.abs(b)), 1.0), (method, name)


def _free_draw(rng, n, d, slip, approach=0.8):
    """A problem drawn freely (no prescribed mode): normal approach, slip of size ``slip``."""
    M, J = _system(rng, n, d, coupling=0.3)
    v = np.zeros(n * d)
    for i in range(n):
        v[i * d] = -rng.uniform(0.2, 1.0) if rng.uniform() < approach else rng.uniform(0.1, 0.5)
        v[i * d + 1:(i + 1) * d] = slip * rng.standard_normal(d - 1)
    return M, _split(J, n, d), np.linalg.lstsq(J, v, rcond=None)[0]


@pytest.mark.parametrize("d", [2, 3])
def test_pereira_nikravesh_stick_tier_matches_finite_differences(d):
    """The stick tier on a constructed active set (u = 0 with impulses inside the cones on it,
    u_n > 0 and no impulse off it), mixed with separating contacts."""
    rng = np.random.default_rng(7 + d)
    law = "pereira-nikravesh"
    for modes in (["stick", "sep"], ["stick", "stick", "sep"], ["sep", "stick", "stick", "stick"],
                  ["stick", "sep", "stick", "sep", "stick"]):
        M, Jl, dq, e, mu, pi = _construct(rng, "ccp", modes, d)
        P, R = _solve(M, Jl, dq, e, mu, law)
        extras = R.diagnostics.extras
        assert extras["tier"] == "stick"
        assert extras["active_set"] == [i for i, m in enumerate(modes) if m == "stick"]
        assert np.max(np.abs(R.impulse.ravel() - pi)) <= 1e-9
        D = law_module(law).several_impulse_derivative(P, R)
        assert D.one_sided == ()
        errors = _check_fd(rng, law, M, Jl, dq, e, mu, D, 1e-3 * np.max(np.abs(pi)))
        assert max(errors.values()) <= RTOL, errors


@pytest.mark.parametrize("d", [2, 3])
def test_pereira_nikravesh_slide_tier_matches_finite_differences(d):
    """Large slip: no stick set is admissible, P_N over the most dissipative active set
    (contacts on their cone's boundary and inside it; one-contact slides)."""
    rng = np.random.default_rng(20 + d)
    law = "pereira-nikravesh"
    sizes = []
    for n in (2, 3, 4):
        M, Jl, dq = _free_draw(rng, n, d, slip=3.0)
        P, R = _solve(M, Jl, dq, 0.5, 0.4, law)
        assert R.diagnostics.extras["tier"] == "slide"
        sizes.append(len(R.diagnostics.extras["active_set"]))
        D = law_module(law).several_impulse_derivative(P, R)
        assert D.one_sided == ()
        errors = _check_fd(rng, law, M, Jl, dq, 0.5, 0.4, D, 1e-3 * np.max(np.abs(R.impulse)))
        assert max(errors.values()) <= RTOL, errors
    assert max(sizes) > 1


def _construct_pn(rng, kinds, d, mu=0.4, e=0.5, sigma=None):
    """A KKT point of P-N's slide program P_N(A) with the given kinds per contact
    ("boundary": on the cone with multiplier sigma (mu, -t), "interior", "sep": off A):
    pi and the cone multipliers s are chosen, the multipliers lambda of ``u_n = 0`` on A
    solve ``(W (pi - N lambda))_n + v_n = s_n`` with ``v_n = -(W pi)_n / (1 + e)`` (so that
    ``u_n = 0``), and ``v = s - W (pi - N lambda)`` on A."""
    n = len(kinds)
    M, J = _system(rng, n, d)
    W = J @ np.linalg.solve(M, J.T)
    A = [i for i, k in enumerate(kinds) if k != "sep"]
    pi, s = np.zeros(n * d), np.zeros(n * d)
    for i, k in enumerate(kinds):
        t, pn = _unit(rng, d - 1), rng.uniform(0.5, 1.5)
        if k == "boundary":
            pi[i * d:(i + 1) * d] = np.r_[pn, mu * pn * t]
            sig = rng.uniform(0.3, 1.0) if sigma is None or i else sigma
            s[i * d:(i + 1) * d] = sig * np.r_[mu, -t]
        elif k == "interior":
            pi[i * d:(i + 1) * d] = np.r_[pn, mu * pn * rng.uniform(0.1, 0.7) * t]
    nA = [i * d for i in A]
    Wpi = W @ pi
    vn = -Wpi[nA] / (1 + e)
    lam = np.linalg.solve(W[np.ix_(nA, nA)], Wpi[nA] + vn - s[nA])
    z = pi.copy()
    z[nA] -= lam
    v = s - W @ z
    for i, k in enumerate(kinds):
        if k == "sep":
            v[i * d] = rng.uniform(0.5, 1.0)
    return M, _split(J, n, d), np.linalg.lstsq(J, v, rcond=None)[0], e, mu, pi


@pytest.mark.parametrize("d", [2, 3])
def test_pereira_nikravesh_slide_program_mixed_kinds(d):
    """Constructed KKT points of P_N(A) with contacts on their cone's boundary, inside it, and
    off A: the law's answer (checked), and its derivative against central differences."""
    rng = np.random.default_rng(80 + d)
    law = "pereira-nikravesh"
    for kinds in (["boundary", "interior"], ["boundary", "interior", "sep"],
                  ["interior", "boundary", "boundary", "sep", "interior"]):
        M, Jl, dq, e, mu, pi = _construct_pn(rng, kinds, d)
        P, R = _solve(M, Jl, dq, e, mu, law)
        assert R.diagnostics.extras["tier"] == "slide"
        assert np.max(np.abs(R.impulse.ravel() - pi)) <= 1e-9
        D = law_module(law).several_impulse_derivative(P, R)
        assert D.one_sided == ()
        errors = _check_fd(rng, law, M, Jl, dq, e, mu, D, 1e-3 * np.max(np.abs(pi)))
        assert max(errors.values()) <= RTOL, (kinds, errors)


def test_pereira_nikravesh_slide_program_zero_multiplier_is_one_sided():
    """Contact 0 of P_N(A) on its cone's boundary with a zero multiplier: on one side it
    stays on the boundary, on the other it moves inside; the derivative is one-sided, its
    other side the interior kind's, and the one-sided differences match one each."""
    rng = np.random.default_rng(90)
    law = "pereira-nikravesh"
    M, Jl, dq, e, mu, pi = _construct_pn(rng, ["boundary", "boundary", "interior"], 3,
                                         sigma=0.0)
    P, R = _solve(M, Jl, dq, e, mu, law)
    assert R.diagnostics.extras["active_set"] == [0, 1, 2]
    D = law_module(law).several_impulse_derivative(P, R, other_side=True)
    assert len(D.one_sided) == 1 and "contact 0" in D.one_sided[0]
    matched = 0
    for _ in range(3):
        direction = rng.standard_normal(dq.size)
        fwd, bwd, one, two = _one_sided_pair(law, M, Jl, dq, e, mu, D, direction)
        tol = 1e-4 * max(np.max(np.abs(one)), np.max(np.abs(two)))
        straight = max(np.max(np.abs(fwd - one)), np.max(np.abs(bwd - two)))
        crossed = max(np.max(np.abs(fwd - two)), np.max(np.abs(bwd - one)))
        assert min(straight, crossed) <= tol
        matched += np.max(np.abs(one - two)) > 1e2 * tol
    assert matched >= 1


@pytest.mark.parametrize("d", [2, 3])
def test_pereira_nikravesh_one_contact_slide_among_lifting_contacts(d):
    """One approaching contact slides (eq. 55 in the plane, maximal dissipation in space), the
    others leave: the slide tier with a one-contact active set."""
    rng = np.random.default_rng(30 + d)
    law = "pereira-nikravesh"
    n = 3
    M, J = _system(rng, n, d, coupling=0.2)
    v = np.zeros(n * d)
    v[0], v[d], v[2 * d] = -0.6, 1.0, 0.8
    v[1:d] = 3.0 * _unit(rng, d - 1)
    dq = np.linalg.lstsq(J, v, rcond=None)[0]
    Jl = _split(J, n, d)
    P, R = _solve(M, Jl, dq, 0.5, 0.4, law)
    assert R.diagnostics.extras["active_set"] == [0] and R.regime[0] == "slide"
    D = law_module(law).several_impulse_derivative(P, R)
    assert D.one_sided == ()
    errors = _check_fd(rng, law, M, Jl, dq, 0.5, 0.4, D, 1e-3 * np.max(np.abs(R.impulse)))
    assert max(errors.values()) <= RTOL, errors


@pytest.mark.parametrize("d", [2, 3])
def test_chatterjee_ruina_independent_contacts_match_finite_differences(d):
    """Three bodies, one contact each (W block-diagonal): the law contact by contact; Jc
    perturbed within each body's block (a coupling perturbation leaves the law's domain)."""
    from scipy.linalg import block_diag

    rng = np.random.default_rng(40 + d)
    law = "chatterjee-ruina"
    n, kb = 3, d + 1
    M = block_diag(*[np.eye(kb) + 0.2 * (lambda A: A @ A.T)(rng.standard_normal((kb, kb)))
                     for _ in range(n)])

    def stack(blocks):
        J = np.zeros((n * d, n * kb))
        for i in range(n):
            J[i * d:(i + 1) * d, i * kb:(i + 1) * kb] = blocks[i]
        return J

    J = stack([np.eye(d, kb) + 0.3 * rng.standard_normal((d, kb)) for _ in range(n)])
    regimes = set()
    for slip in (0.05, 3.0):
        v = np.concatenate([np.r_[-rng.uniform(0.3, 1.0), slip * rng.standard_normal(d - 1)]
                            for _ in range(n)])
        dq = np.linalg.lstsq(J, v, rcond=None)[0]
        e, mu, et = rng.uniform(0.2, 0.8, n), rng.uniform(0.2, 0.6, n), \
            rng.uniform(-0.5, 0.5, n)

        def impulse(JJ=J, q=dq, ee=e, mm=mu, tt=et):
            return _solve(M, _split(JJ, n, d), q, ee, mm, law, e_t=tt)

        P, R = impulse()
        D = law_module(law).several_impulse_derivative(P, R)
        regimes.update(D.regimes)
        assert len(D.one_sided) == 1  # the domain statement only (W block-diagonal)
        G = np.linalg.inv(M)
        dJ = stack([rng.standard_normal((d, kb)) for _ in range(n)])
        ddq = rng.standard_normal(n * kb)
        fd = (impulse(J + H * dJ, dq + H * ddq)[1].impulse.ravel()
              - impulse(J - H * dJ, dq - H * ddq)[1].impulse.ravel()) / (2 * H)
        pred = _predicted(D, dJ @ G @ J.T + J @ G @ dJ.T, dJ @ dq + J @ ddq)
        scale = np.max(np.abs(fd))
        assert np.max(np.abs(fd - pred)) <= RTOL * scale
        for name, base, jac in (("ee", e, D.e), ("mm", mu, D.mu), ("tt", et, D.e_t)):
            dx = rng.uniform(0.5, 1.0, n)
            fd = (impulse(**{name: base + H * dx})[1].impulse.ravel()
                  - impulse(**{name: base - H * dx})[1].impulse.ravel()) / (2 * H)
            assert np.max(np.abs(fd - jac @ dx)) <= RTOL * max(np.max(np.abs(fd)), 1e-3), name
    assert regimes == {"stick", "slide"}


def test_chatterjee_ruina_one_approaching_coupled_contact():
    """Coupled contacts, only contact 0 approaching, the others lifting: the law's impulse is
    contact 0's single-contact answer, so its derivative lives in contact 0's block (no
    domain statement: a generic perturbation keeps the others lifting)."""
    rng = np.random.default_rng(45)
    law = "chatterjee-ruina"
    n, d = 3, 3
    M, J = _system(rng, n, d, coupling=0.3)
    v = np.array([-0.8, 0.5, -0.2, 1.0, 0.3, 0.1, 0.9, -0.4, 0.2])
    dq = np.linalg.lstsq(J, v, rcond=None)[0]
    Jl = _split(J, n, d)
    P, R = _solve(M, Jl, dq, 0.4, 0.3, law, e_t=0.2)
    assert R.regime[1:] == ("separating", "separating") and R.regime[0] in ("stick", "slide")
    D = law_module(law).several_impulse_derivative(P, R)
    assert D.one_sided == ()
    assert np.all(D.W[d:] == 0.0) and np.all(D.v[:, d:] == 0.0)
    G = np.linalg.inv(M)
    dJ = rng.standard_normal(J.shape)
    ddq = rng.standard_normal(dq.size)
    fd = (_solve(M, _split(J + H * dJ, n, d), dq + H * ddq, 0.4, 0.3, law,
                 e_t=0.2)[1].impulse.ravel()
          - _solve(M, _split(J - H * dJ, n, d), dq - H * ddq, 0.4, 0.3, law,
                   e_t=0.2)[1].impulse.ravel()) / (2 * H)
    pred = _predicted(D, dJ @ G @ J.T + J @ G @ dJ.T, dJ @ dq + J @ ddq)
    assert np.max(np.abs(fd - pred)) <= RTOL * np.max(np.abs(fd))


ALL_LAWS = ("pereira-nikravesh", "ccp", "coulomb", "dissipative")


@pytest.mark.parametrize("law", ALL_LAWS + ("chatterjee-ruina",))
def test_two_independent_frictionless_contacts_closed_form(law):
    """Two particles (masses 2 and 5) falling on the ground, mu = 0: W = diag(1/m), and
    pi_n,i = -(1 + e_i) v_i / W_ii, so d pi_n,i / d v_n,i = -(1 + e_i) / W_ii,
    d / d e_i = -v_i / W_ii, d / d W_ii = (1 + e_i) v_i / W_ii^2 (dissipative: the same, its
    plastic impulse being -v_i / W_ii)."""
    m = np.array([2.0, 5.0])
    M = np.diag([m[0], m[0], m[1], m[1]])
    Jl = [np.array([[0.0, 1, 0, 0], [1, 0, 0, 0]]), np.array([[0.0, 0, 0, 1], [0, 0, 1, 0]])]
    dq = np.array([0.0, -1.5, 0.0, -0.7])
    e = np.array([0.3, 0.8])
    P, R = _solve(M, Jl, dq, e, 0.0, law, e_t=0.0 if law == "chatterjee-ruina" else None)
    D = law_module(law).several_impulse_derivative(P, R)
    w, vn = 1.0 / m, dq[[1, 3]]
    for i in range(2):
        r = 2 * i
        assert D.v[r, r] == pytest.approx(-(1 + e[i]) / w[i], rel=1e-12)
        assert D.e[r, i] == pytest.approx(-vn[i] / w[i], rel=1e-12)
        assert D.W[r, r, r] == pytest.approx((1 + e[i]) * vn[i] / w[i] ** 2, rel=1e-12)
        assert D.v[r, 2 - r] == 0.0 and D.e[r, 1 - i] == 0.0
    assert np.all(D.v[1::2] == 0.0) and np.all(D.W[1::2] == 0.0)  # no tangential impulse


@pytest.mark.parametrize("law", ALL_LAWS)
def test_frictionless_coupled_pair_closed_form(law):
    """A uniform bar (mass 3, length 2, I = m L^2 / 12) falls nearly flat on both ends, mu = 0:
    W_nn = [[1/m + 3/m, 1/m - 3/m], ...] couples the ends and both press, so
    pi_n = -(1 + e) W_nn^-1 v_n: d pi_n / d v_n = -(1 + e) W_nn^-1 and d pi_n = -W_nn^-1 dW pi_n;
    d pi_n / d e_i = -W_nn^-1[:, i] v_n,i (dissipative: pi_i = (1 + e) pi_p,i, so
    d pi_n,i / d e_i = pi_p,i = -(W_nn^-1 v_n)_i and zero across contacts)."""
    m, L = 3.0, 2.0
    M = np.diag([m, m, m * L * L / 12])
    Jl = [np.array([[0.0, 1, -L / 2], [1, 0, 0]]), np.array([[0.0, 1, L / 2], [1, 0, 0]])]
    dq = np.array([0.2, -1.0, 0.1])
    e = 0.6
    P, R = _solve(M, Jl, dq, e, 0.0, law)
    D = law_module(law).several_impulse_derivative(P, R)
    Wn = np.array([[4.0, -2.0], [-2.0, 4.0]]) / m
    vn = np.array([dq[1] - L / 2 * dq[2], dq[1] + L / 2 * dq[2]])
    Winv = np.linalg.inv(Wn)
    pn = -(1 + e) * Winv @ vn
    assert np.all(pn > 0) and np.allclose(R.impulse[:, 0], pn, rtol=1e-9)
    nr = [0, 2]
    assert np.allclose(D.v[np.ix_(nr, nr)], -(1 + e) * Winv, rtol=1e-10, atol=1e-12)
    dW = np.array([[0.3, -0.1], [-0.1, 0.7]])
    full = np.zeros((4, 4))
    full[np.ix_(nr, nr)] = dW
    assert np.allclose(np.einsum("aij,ij->a", D.W, full)[nr], -Winv @ dW @ pn, rtol=1e-10)
    if law == "dissipative":
        expected = np.diag(-Winv @ vn)
    else:
        expected = -Winv * vn[None, :]
    assert np.allclose(D.e[nr], expected, rtol=1e-10, atol=1e-12)


def _one_sided_pair(law, M, Jl, dq, e, mu, D, direction):
    """Forward and backward differences along ``direction`` (a dq perturbation) and the two
    derivatives' predictions."""
    J = np.vstack(Jl)
    h = 1e-7
    f0 = _solve(M, Jl, dq, e, mu, law)[1].impulse.ravel()
    fwd = (_solve(M, Jl, dq + h * direction, e, mu, law)[1].impulse.ravel() - f0) / h
    bwd = (f0 - _solve(M, Jl, dq - h * direction, e, mu, law)[1].impulse.ravel()) / h
    dv = J @ direction
    return fwd, bwd, D.v @ dv, D.other_side.v @ dv


@pytest.mark.parametrize("law", CONE_LAWS)
@pytest.mark.parametrize("boundary", ["touch", "limit"])
def test_cone_laws_at_a_mode_boundary_are_one_sided(law, boundary):
    """A contact about to separate (pi = 0 with u on the dual cone's boundary), or at the stick
    limit (pi on the cone's boundary, no slip): the derivative is one-sided, stated, and the
    other side is the neighbouring mode's; each matches one of the one-sided differences."""
    rng = np.random.default_rng(50 + (boundary == "limit") + 2 * CONE_LAWS.index(law))
    modes = ["stick", "slide", boundary]
    M, Jl, dq, e, mu, _ = _construct(rng, law, modes, 3)
    P, R = _solve(M, Jl, dq, e, mu, law)
    D = law_module(law).several_impulse_derivative(P, R, other_side=True)
    assert len(D.one_sided) == 1 and "contact 2" in D.one_sided[0]
    assert D.other_side is not None and D.other_side.regimes[:2] == D.regimes[:2]
    assert {D.regimes[2], D.other_side.regimes[2]} == (
        {"separating", "slide"} if boundary == "touch" else {"stick", "slide"})
    assert law_module(law).several_impulse_derivative(P, R).other_side is None
    for _ in range(3):
        direction = rng.standard_normal(dq.size)
        fwd, bwd, one, two = _one_sided_pair(law, M, Jl, dq, e, mu, D, direction)
        scale = max(np.max(np.abs(one)), np.max(np.abs(two)))
        tol = 1e-4 * scale
        straight = max(np.max(np.abs(fwd - one)), np.max(np.abs(bwd - two)))
        crossed = max(np.max(np.abs(fwd - two)), np.max(np.abs(bwd - one)))
        assert min(straight, crossed) <= tol
        assert np.max(np.abs(one - two)) > 1e2 * tol  # the two sides differ


def test_pereira_nikravesh_contact_about_to_press_is_one_sided():
    """Stick tier, frictionless contact 2 with no impulse and u_n = 0: the active sets with and
    without it give the same answer (the law picks one), and each continues it on one side.
    The derivative is one-sided, its other side the other active set's; the forward and
    backward differences match one each."""
    rng = np.random.default_rng(70)
    law = "pereira-nikravesh"
    M, Jl, dq, e, mu, pi = _construct(rng, "ccp", ["stick", "stick", "zero"], 3,
                                      mu=np.array([0.4, 0.4, 0.0]))
    P, R = _solve(M, Jl, dq, e, mu, law)
    assert R.diagnostics.extras["active_set"] in ([0, 1], [0, 1, 2])  # a tie at the boundary
    D = law_module(law).several_impulse_derivative(P, R, other_side=True)
    assert len(D.one_sided) == 1 and "contact 2" in D.one_sided[0]
    assert {D.regimes[2], D.other_side.regimes[2]} == {"separating", "frictionless"}
    matched = 0
    for _ in range(3):
        direction = rng.standard_normal(dq.size)
        fwd, bwd, one, two = _one_sided_pair(law, M, Jl, dq, e, mu, D, direction)
        tol = 1e-4 * max(np.max(np.abs(one)), np.max(np.abs(two)))
        straight = max(np.max(np.abs(fwd - one)), np.max(np.abs(bwd - two)))
        crossed = max(np.max(np.abs(fwd - two)), np.max(np.abs(bwd - one)))
        assert min(straight, crossed) <= tol
        matched += np.max(np.abs(one - two)) > 1e2 * tol
    assert matched >= 1  # the sides differ


def _flat_box(slip, mu):
    """A planar box (mass 1, half-width 1) landing flat on its two corners: 4 contact rows,
    3 degrees of freedom (W singular)."""
    M = np.diag([1.0, 1.0, 1.0 / 3.0 * 1.0 * (1.0 + 0.25)])
    Jl = [np.array([[0.0, 1, -1.0], [1, 0, 0.5]]), np.array([[0.0, 1, 1.0], [1, 0, 0.5]])]
    dq = np.array([slip, -1.0, 0.05])
    return M, Jl, dq, 0.5, mu


def test_redundant_contacts_stick_pereira_nikravesh_minimum_norm():
    """Both corners stick (W singular): the law's stick impulse is the minimum-norm solution;
    its derivative holds along the perturbations that keep the stick equations consistent
    (dq, e, M, and the box's geometry: its half-width and height move the rows
    n_i = (0, 1, -+a), t_i = (1, 0, h) together), and is stated."""
    rng = np.random.default_rng(60)
    law = "pereira-nikravesh"
    M, Jl, dq, e, mu = _flat_box(0.1, 0.8)
    P, R = _solve(M, Jl, dq, e, mu, law)
    assert R.diagnostics.extras["tier"] == "stick" and R.regime == ("stick", "stick")
    D = law_module(law).several_impulse_derivative(P, R)
    assert any("minimum-norm" in s for s in D.one_sided)
    J = np.vstack(Jl)
    G = np.linalg.inv(M)
    scale = np.max(np.abs(R.impulse))
    dJ = np.zeros_like(J)
    dJ[0, 2], dJ[2, 2], dJ[1, 2], dJ[3, 2] = -0.7, 0.7, 0.4, 0.4  # da = 0.7, dh = 0.4
    A = rng.standard_normal((3, 3))
    dM = A + A.T
    ddq = rng.standard_normal(3)
    for at, dW, dv in (
            (lambda s: (M, _split(J + s * dJ, 2, 2), dq), dJ @ G @ J.T + J @ G @ dJ.T, dJ @ dq),
            (lambda s: (M + s * dM, Jl, dq), -J @ G @ dM @ G @ J.T, np.zeros(4)),
            (lambda s: (M, Jl, dq + s * ddq), np.zeros((4, 4)), J @ ddq)):
        fd = (_solve(*at(H), e, mu, law)[1].impulse.ravel()
              - _solve(*at(-H), e, mu, law)[1].impulse.ravel()) / (2 * H)
        assert np.max(np.abs(fd - _predicted(D, dW, dv))) <= RTOL * max(np.max(np.abs(fd)),
                                                                         scale)
    fd = (_solve(M, Jl, dq, e + H, mu, law)[1].impulse.ravel()
          - _solve(M, Jl, dq, e - H, mu, law)[1].impulse.ravel()) / (2 * H)
    assert np.max(np.abs(fd - D.e.sum(axis=1))) <= RTOL * scale


def test_redundant_contacts_cone_laws():
    """The same box: sticking, the engine's impulse is one of many (its velocity is unique):
    NotSupportedError says so; sliding, the slide equations fix the impulse (two normal
    impulses for the vertical and rotational motion) and the derivative matches."""
    rng = np.random.default_rng(61)
    M, Jl, dq, e, mu = _flat_box(0.1, 0.8)
    P, R = _solve(M, Jl, dq, e, mu, "ccp")
    assert R.regime == ("stick", "stick")
    with pytest.raises(NotSupportedError, match="non-unique"):
        law_module("ccp").several_impulse_derivative(P, R)
    M, Jl, dq, e, mu = _flat_box(3.0, 0.3)
    P, R = _solve(M, Jl, dq, e, mu, "ccp")
    assert R.regime == ("slide", "slide")
    D = law_module("ccp").several_impulse_derivative(P, R)
    errors = _check_fd(rng, "ccp", M, Jl, dq, e, mu, D, 1e-3 * np.max(np.abs(R.impulse)))
    assert max(errors.values()) <= RTOL, errors


@pytest.mark.parametrize("law", CONE_LAWS)
def test_redundant_contacts_velocity_derivative(law):
    """The sticking box under the cone laws with ``redundant="velocity"``: the impulse
    derivative given is one of many, but the velocities' derivatives it implies,
    ``d v+ = dv + dW pi + W dpi`` and ``d theta_dot+ = d dq + d(G Jc^T) pi + G Jc^T dpi``, match
    central differences of the public result's v_plus and dq_plus (unique although the impulse
    is not) along perturbations that keep the contacts redundant: dq, e, M, and the box's
    geometry (its half-width and height)."""
    rng = np.random.default_rng(62)
    M, Jl, dq, e, mu = _flat_box(0.1, 0.8)
    P, R = _solve(M, Jl, dq, e, mu, law)
    assert R.regime == ("stick", "stick")
    D = law_module(law).several_impulse_derivative(P, R, redundant="velocity")
    assert any("minimum-norm" in s for s in D.one_sided)
    J = np.vstack(Jl)
    G = np.linalg.inv(M)
    pi = R.impulse.ravel()
    dJ = np.zeros_like(J)
    dJ[0, 2], dJ[2, 2], dJ[1, 2], dJ[3, 2] = -0.7, 0.7, 0.4, 0.4  # da = 0.7, dh = 0.4
    A = rng.standard_normal((3, 3))
    dM = A + A.T
    ddq = rng.standard_normal(3)
    zero = np.zeros(2)
    cases = (  # (arguments at step s, dJ, dM, ddq, de)
        (lambda s: (M, _split(J + s * dJ, 2, 2), dq, e, mu), dJ, 0 * dM, 0 * ddq, zero),
        (lambda s: (M + s * dM, Jl, dq, e, mu), 0 * dJ, dM, 0 * ddq, zero),
        (lambda s: (M, Jl, dq + s * ddq, e, mu), 0 * dJ, 0 * dM, ddq, zero),
        (lambda s: (M, Jl, dq, e + s, mu), 0 * dJ, 0 * dM, 0 * ddq, np.ones(2)))
    for at, dJc, dMc, dqc, dec in cases:
        hi, lo = _solve(*at(H), law)[1], _solve(*at(-H), law)[1]
        dG = -G @ dMc @ G
        dW = dJc @ G @ J.T + J @ G @ dJc.T + J @ dG @ J.T
        dv = dJc @ dq + J @ dqc
        dpi = _predicted(D, dW, dv, dec)
        fd_vplus = (hi.v_plus.ravel() - lo.v_plus.ravel()) / (2 * H)
        assert np.max(np.abs(fd_vplus - (dv + dW @ pi + P.delassus @ dpi))) <= \
            RTOL * max(np.max(np.abs(fd_vplus)), 1.0)
        fd_dq = (hi.dq_plus - lo.dq_plus) / (2 * H)
        pred = dqc + (dG @ J.T + G @ dJc.T) @ pi + G @ J.T @ dpi
        assert np.max(np.abs(fd_dq - pred)) <= RTOL * max(np.max(np.abs(fd_dq)), 1.0)


def test_bad_input_is_refused():
    M, Jl, dq, e, mu = _flat_box(3.0, 0.3)
    P, R = _solve(M, Jl, dq, e, mu, "ccp")
    with pytest.raises(ParameterError, match="law 'ccp'"):
        law_module("coulomb").several_impulse_derivative(P, R)
    for law in ("ccp", "pereira-nikravesh"):
        with pytest.raises(ParameterError, match="redundant"):
            law_module(law).several_impulse_derivative(P, R, redundant="min-norm")
    P1 = build_problem(M, Jl[0], dq, e, mu)
    R1 = solve_problem(P1, "pereira-nikravesh")
    with pytest.raises(NotSupportedError, match="one contact"):
        law_module("pereira-nikravesh").several_impulse_derivative(P1, R1)
