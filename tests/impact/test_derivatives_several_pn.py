"""Exact impulse derivatives at several simultaneous contacts of laws pereira-nikravesh
(complementarity form: its stick tier, the slide program P_N over an active set, one-contact
slides, redundant contacts) and chatterjee-ruina (per contact), against central finite
differences of the public path and one-sided differences at mode boundaries (the problems and
checks: several_derivative_problems.py; the cone laws and the closed forms:
test_derivatives_several.py)."""

import numpy as np
import pytest

from convimpact.impact.laws import law_module

from .several_derivative_problems import (H, RTOL, check_fd, construct, construct_pn, flat_box,
                                          free_draw, one_sided_pair, predicted, solve, split,
                                          system, unit)


@pytest.mark.parametrize("d", [2, 3])
def test_pereira_nikravesh_stick_tier_matches_finite_differences(d):
    """The stick tier on a constructed active set (u = 0 with impulses inside the cones on it,
    u_n > 0 and no impulse off it), mixed with separating contacts."""
    rng = np.random.default_rng(7 + d)
    law = "pereira-nikravesh"
    for modes in (["stick", "sep"], ["stick", "stick", "sep"], ["sep", "stick", "stick", "stick"],
                  ["stick", "sep", "stick", "sep", "stick"]):
        M, Jl, dq, e, mu, pi = construct(rng, "ccp", modes, d)
        P, R = solve(M, Jl, dq, e, mu, law)
        extras = R.diagnostics.extras
        assert extras["tier"] == "stick"
        assert extras["active_set"] == [i for i, m in enumerate(modes) if m == "stick"]
        assert np.max(np.abs(R.impulse.ravel() - pi)) <= 1e-9
        D = law_module(law).several_impulse_derivative(P, R)
        assert D.one_sided == ()
        errors = check_fd(rng, law, M, Jl, dq, e, mu, D, 1e-3 * np.max(np.abs(pi)))
        assert max(errors.values()) <= RTOL, errors


@pytest.mark.parametrize("d", [2, 3])
def test_pereira_nikravesh_slide_tier_matches_finite_differences(d):
    """Large slip: no stick set is admissible, P_N over the most dissipative active set
    (contacts on their cone's boundary and inside it; one-contact slides)."""
    rng = np.random.default_rng(20 + d)
    law = "pereira-nikravesh"
    sizes = []
    for n in (2, 3, 4):
        M, Jl, dq = free_draw(rng, n, d, slip=3.0)
        P, R = solve(M, Jl, dq, 0.5, 0.4, law)
        assert R.diagnostics.extras["tier"] == "slide"
        sizes.append(len(R.diagnostics.extras["active_set"]))
        D = law_module(law).several_impulse_derivative(P, R)
        assert D.one_sided == ()
        errors = check_fd(rng, law, M, Jl, dq, 0.5, 0.4, D, 1e-3 * np.max(np.abs(R.impulse)))
        assert max(errors.values()) <= RTOL, errors
    assert max(sizes) > 1


@pytest.mark.parametrize("d", [2, 3])
def test_pereira_nikravesh_slide_program_mixed_kinds(d):
    """Constructed KKT points of P_N(A) with contacts on their cone's boundary, inside it, and
    off A: the law's answer (checked), and its derivative against central differences."""
    rng = np.random.default_rng(80 + d)
    law = "pereira-nikravesh"
    for kinds in (["boundary", "interior"], ["boundary", "interior", "sep"],
                  ["interior", "boundary", "boundary", "sep", "interior"]):
        M, Jl, dq, e, mu, pi = construct_pn(rng, kinds, d)
        P, R = solve(M, Jl, dq, e, mu, law)
        assert R.diagnostics.extras["tier"] == "slide"
        assert np.max(np.abs(R.impulse.ravel() - pi)) <= 1e-9
        D = law_module(law).several_impulse_derivative(P, R)
        assert D.one_sided == ()
        errors = check_fd(rng, law, M, Jl, dq, e, mu, D, 1e-3 * np.max(np.abs(pi)))
        assert max(errors.values()) <= RTOL, (kinds, errors)


def test_pereira_nikravesh_slide_program_zero_multiplier_is_one_sided():
    """Contact 0 of P_N(A) on its cone's boundary with a zero multiplier: on one side it
    stays on the boundary, on the other it moves inside; the derivative is one-sided, its
    other side the interior kind's, and the one-sided differences match one each."""
    rng = np.random.default_rng(90)
    law = "pereira-nikravesh"
    M, Jl, dq, e, mu, pi = construct_pn(rng, ["boundary", "boundary", "interior"], 3,
                                         sigma=0.0)
    P, R = solve(M, Jl, dq, e, mu, law)
    assert R.diagnostics.extras["active_set"] == [0, 1, 2]
    D = law_module(law).several_impulse_derivative(P, R, other_side=True)
    assert len(D.one_sided) == 1 and "contact 0" in D.one_sided[0]
    matched = 0
    for _ in range(3):
        direction = rng.standard_normal(dq.size)
        fwd, bwd, one, two = one_sided_pair(law, M, Jl, dq, e, mu, D, direction)
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
    M, J = system(rng, n, d, coupling=0.2)
    v = np.zeros(n * d)
    v[0], v[d], v[2 * d] = -0.6, 1.0, 0.8
    v[1:d] = 3.0 * unit(rng, d - 1)
    dq = np.linalg.lstsq(J, v, rcond=None)[0]
    Jl = split(J, n, d)
    P, R = solve(M, Jl, dq, 0.5, 0.4, law)
    assert R.diagnostics.extras["active_set"] == [0] and R.regime[0] == "slide"
    D = law_module(law).several_impulse_derivative(P, R)
    assert D.one_sided == ()
    errors = check_fd(rng, law, M, Jl, dq, 0.5, 0.4, D, 1e-3 * np.max(np.abs(R.impulse)))
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
            return solve(M, split(JJ, n, d), q, ee, mm, law, e_t=tt)

        P, R = impulse()
        D = law_module(law).several_impulse_derivative(P, R)
        regimes.update(D.regimes)
        assert len(D.one_sided) == 1  # the domain statement only (W block-diagonal)
        G = np.linalg.inv(M)
        dJ = stack([rng.standard_normal((d, kb)) for _ in range(n)])
        ddq = rng.standard_normal(n * kb)
        fd = (impulse(J + H * dJ, dq + H * ddq)[1].impulse.ravel()
              - impulse(J - H * dJ, dq - H * ddq)[1].impulse.ravel()) / (2 * H)
        pred = predicted(D, dJ @ G @ J.T + J @ G @ dJ.T, dJ @ dq + J @ ddq)
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
    M, J = system(rng, n, d, coupling=0.3)
    v = np.array([-0.8, 0.5, -0.2, 1.0, 0.3, 0.1, 0.9, -0.4, 0.2])
    dq = np.linalg.lstsq(J, v, rcond=None)[0]
    Jl = split(J, n, d)
    P, R = solve(M, Jl, dq, 0.4, 0.3, law, e_t=0.2)
    assert R.regime[1:] == ("separating", "separating") and R.regime[0] in ("stick", "slide")
    D = law_module(law).several_impulse_derivative(P, R)
    assert D.one_sided == ()
    assert np.all(D.W[d:] == 0.0) and np.all(D.v[:, d:] == 0.0)
    G = np.linalg.inv(M)
    dJ = rng.standard_normal(J.shape)
    ddq = rng.standard_normal(dq.size)
    fd = (solve(M, split(J + H * dJ, n, d), dq + H * ddq, 0.4, 0.3, law,
                 e_t=0.2)[1].impulse.ravel()
          - solve(M, split(J - H * dJ, n, d), dq - H * ddq, 0.4, 0.3, law,
                   e_t=0.2)[1].impulse.ravel()) / (2 * H)
    pred = predicted(D, dJ @ G @ J.T + J @ G @ dJ.T, dJ @ dq + J @ ddq)
    assert np.max(np.abs(fd - pred)) <= RTOL * np.max(np.abs(fd))


def test_pereira_nikravesh_contact_about_to_press_is_one_sided():
    """Stick tier, frictionless contact 2 with no impulse and u_n = 0: the active sets with and
    without it give the same answer (the law picks one), and each continues it on one side.
    The derivative is one-sided, its other side the other active set's; the forward and
    backward differences match one each."""
    rng = np.random.default_rng(70)
    law = "pereira-nikravesh"
    M, Jl, dq, e, mu, pi = construct(rng, "ccp", ["stick", "stick", "zero"], 3,
                                      mu=np.array([0.4, 0.4, 0.0]))
    P, R = solve(M, Jl, dq, e, mu, law)
    assert R.diagnostics.extras["active_set"] in ([0, 1], [0, 1, 2])  # a tie at the boundary
    D = law_module(law).several_impulse_derivative(P, R, other_side=True)
    assert len(D.one_sided) == 1 and "contact 2" in D.one_sided[0]
    assert {D.regimes[2], D.other_side.regimes[2]} == {"separating", "frictionless"}
    matched = 0
    for _ in range(3):
        direction = rng.standard_normal(dq.size)
        fwd, bwd, one, two = one_sided_pair(law, M, Jl, dq, e, mu, D, direction)
        tol = 1e-4 * max(np.max(np.abs(one)), np.max(np.abs(two)))
        straight = max(np.max(np.abs(fwd - one)), np.max(np.abs(bwd - two)))
        crossed = max(np.max(np.abs(fwd - two)), np.max(np.abs(bwd - one)))
        assert min(straight, crossed) <= tol
        matched += np.max(np.abs(one - two)) > 1e2 * tol
    assert matched >= 1  # the sides differ


def test_redundant_contacts_stick_pereira_nikravesh_minimum_norm():
    """Both corners stick (W singular): the law's stick impulse is the minimum-norm solution;
    its derivative holds along the perturbations that keep the stick equations consistent
    (dq, e, M, and the box's geometry: its half-width and height move the rows
    n_i = (0, 1, -+a), t_i = (1, 0, h) together), and is stated."""
    rng = np.random.default_rng(60)
    law = "pereira-nikravesh"
    M, Jl, dq, e, mu = flat_box(0.1, 0.8)
    P, R = solve(M, Jl, dq, e, mu, law)
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
            (lambda s: (M, split(J + s * dJ, 2, 2), dq), dJ @ G @ J.T + J @ G @ dJ.T, dJ @ dq),
            (lambda s: (M + s * dM, Jl, dq), -J @ G @ dM @ G @ J.T, np.zeros(4)),
            (lambda s: (M, Jl, dq + s * ddq), np.zeros((4, 4)), J @ ddq)):
        fd = (solve(*at(H), e, mu, law)[1].impulse.ravel()
              - solve(*at(-H), e, mu, law)[1].impulse.ravel()) / (2 * H)
        assert np.max(np.abs(fd - predicted(D, dW, dv))) <= RTOL * max(np.max(np.abs(fd)),
                                                                         scale)
    fd = (solve(M, Jl, dq, e + H, mu, law)[1].impulse.ravel()
          - solve(M, Jl, dq, e - H, mu, law)[1].impulse.ravel()) / (2 * H)
    assert np.max(np.abs(fd - D.e.sum(axis=1))) <= RTOL * scale
