"""The contact force problem of sustained contact (convimpact.simulation.contact_forces).

References derived here by hand (a particle on a floor and on an incline, a box on two
corners; the distribution among redundant contacts: a table on three legs, a box on four
corners), the closed form of one planar contact against the general enumeration, and the
``coulomb`` impact law's conic path (Clarabel) on the same data: with every contact at zero
slip the force problem is Coulomb's law with e = 0 for (a, lambda) instead of (v+, pi).
"""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.simulation import force_distribution
from convimpact.simulation.force_solver import solve_contact_forces
from convimpact.simulation.contact_forces import (ContactForceProblem, force_solutions,
                                                  max_margin_distribution,
                                                  planar_contact_force)

G = 9.81


def _problem(W, b, mu, slip):
    return ContactForceProblem(np.asarray(W, float), np.asarray(b, float),
                               np.atleast_1d(np.asarray(mu, float)),
                               np.asarray(slip, float).reshape(len(np.atleast_1d(mu)), -1))


def _incline(slope, m=2.0):
    """A particle of mass m on an incline; contact frame n (out of the plane), t (down-slope):
    W = I/m, a_free = (-g cos a, g sin a)."""
    return np.eye(2) / m, np.array([-G * np.cos(slope), G * np.sin(slope)])


@pytest.mark.parametrize("mu", [0.2, 0.5, np.tan(np.radians(30)) * (1 + 1e-6), 0.7])
def test_particle_on_incline_holds_iff_mu_at_least_tan(mu):
    m, a = 2.0, np.radians(30)
    W, b = _incline(a, m)
    sol = solve_contact_forces(_problem(W, b, mu, [0.0]))
    assert sol.force[0, 0] == pytest.approx(m * G * np.cos(a), rel=1e-12)
    if mu >= np.tan(a):
        assert sol.modes == ("stick",)
        np.testing.assert_allclose(sol.force[0], [m * G * np.cos(a), -m * G * np.sin(a)],
                                   rtol=1e-12)
        assert sol.acceleration[0, 1] == pytest.approx(0.0, abs=1e-12)
    else:  # slides down-slope (s = +1) at g (sin a - mu cos a)
        assert sol.modes == ("slip",) and sol.direction[0, 0] == 1.0
        assert sol.acceleration[0, 1] == pytest.approx(G * (np.sin(a) - mu * np.cos(a)),
                                                       rel=1e-12)
        assert sol.force[0, 1] == pytest.approx(-mu * m * G * np.cos(a), rel=1e-12)


@pytest.mark.parametrize("vt", [2.0, -0.5])
def test_sliding_particle_feels_mu_m_g_against_its_slip(vt):
    m, mu = 3.0, 0.4
    sol = solve_contact_forces(_problem(np.eye(2) / m, [-G, 0.0], mu, [vt]))
    assert sol.modes == ("slip",)
    np.testing.assert_allclose(sol.force[0], [m * G, -np.sign(vt) * mu * m * G], rtol=1e-12)
    assert sol.acceleration[0, 1] == pytest.approx(-np.sign(vt) * mu * G, rel=1e-12)


def test_free_flight_is_open_and_frictionless_contact_is_closed_without_friction():
    open_ = solve_contact_forces(_problem(np.eye(2), [1.0, 3.0], 0.5, [0.0]))
    assert open_.modes == ("open",) and np.all(open_.force == 0.0)
    frictionless = solve_contact_forces(_problem(np.eye(2), [-G, 3.0], 0.0, [0.0]))
    assert frictionless.modes == ("slip",)
    np.testing.assert_allclose(frictionless.force[0], [G, 0.0], rtol=1e-12)


def _random_planar(rng):
    k = int(rng.integers(2, 5))
    A = rng.normal(size=(k, k))
    M = A @ A.T + 0.5 * np.eye(k)
    J = rng.normal(size=(2, k))
    W = J @ np.linalg.solve(M, J.T)
    b = rng.normal(size=2)
    vt = [0.0, float(rng.normal())][int(rng.integers(0, 2))]
    return W, b, float(rng.uniform(0.0, 1.5)), vt


def test_planar_closed_form_equals_the_enumeration_on_random_contacts():
    rng = np.random.default_rng(7)
    n_cases = 0
    for _ in range(300):
        W, b, mu, vt = _random_planar(rng)
        closed = planar_contact_force(W, b, mu, vt)
        general = force_solutions(_problem(W, b, mu, [vt]))
        assert len(closed) == len(general)
        for s in closed:
            match = [g for g in general if np.allclose(g.acceleration, s.acceleration,
                                                       atol=1e-9 * np.max(np.abs(b)))]
            assert len(match) == 1 and match[0].modes == s.modes
            np.testing.assert_allclose(match[0].force, s.force, atol=1e-9 * np.max(np.abs(b)))
        n_cases += len(closed) == 1
    assert n_cases > 250  # most random contacts are well posed (W positive definite, mu < ...)


def _random_zero_slip(rng, n, d):
    k = n * d + int(rng.integers(0, 3))
    A = rng.normal(size=(k, k))
    M = A @ A.T + 0.5 * np.eye(k)
    J = rng.normal(size=(n * d, k))
    acc = rng.normal(size=k)  # a "free acceleration": b = J acc
    mu = rng.uniform(0.1, 1.0, size=n)
    return M, J, acc, mu


@pytest.mark.parametrize("n,d", [(1, 3), (2, 2), (2, 3), (3, 2)])
def test_zero_slip_force_problem_is_coulombs_law_with_e0_on_the_conic_path(n, d):
    """Where no contact slides the force problem is the impact law 'coulomb' with e = 0 for
    (a, lambda): its conic path (Clarabel) on the same W and b must agree."""
    if "clarabel" not in ci.available_methods("coulomb"):
        pytest.skip("clarabel not installed")
    rng = np.random.default_rng(11 + 10 * n + d)
    checked = 0
    for _ in range(12):
        M, J, acc, mu = _random_zero_slip(rng, n, d)
        W = J @ np.linalg.solve(M, J.T)
        b = J @ acc
        sols = force_solutions(_problem(W, b, mu, np.zeros((n, d - 1))))
        if len(sols) != 1:
            continue  # several Coulomb solutions: nothing unique to compare
        Jc = [J[i * d:(i + 1) * d] for i in range(n)]
        r = ci.resolve_impact(M, Jc if n > 1 else Jc[0], acc, [0.0] * n if n > 1 else 0.0,
                              list(mu) if n > 1 else float(mu[0]), law="coulomb",
                              method="clarabel")
        scale = max(1.0, float(np.max(np.abs(sols[0].force))))
        np.testing.assert_allclose(np.asarray(r.impulse).reshape(n, d), sols[0].force,
                                   atol=1e-6 * scale)
        checked += 1
    assert checked >= 6


def _box_on_incline(mu, slope, width=0.4, height=0.2, m=1.0):
    """A planar box (x, y, phi) resting on two bottom corners on an incline; the frame is the
    incline's (t down-slope, n out of it), gravity g (sin a, -cos a) in that frame."""
    I = m * (width ** 2 + height ** 2) / 12.0
    rows = []
    for x in (-width / 2, width / 2):
        r = np.array([x, -height / 2])
        rows += [[0.0, 1.0, r[0]], [1.0, 0.0, -r[1]]]  # n = y, t = x: v + omega x r
    J = np.array(rows)
    Gm = np.diag([1 / m, 1 / m, 1 / I])
    grav = np.array([G * np.sin(slope), -G * np.cos(slope), 0.0])
    return _problem(J @ Gm @ J.T, J @ grav, [mu, mu], np.zeros((2, 1)))


@pytest.mark.parametrize("mu", [0.5, 0.57, 0.58, 0.8])
def test_box_on_two_corners_holds_iff_mu_at_least_tan_despite_redundancy(mu):
    """The two tangential rows are one (redundant): the forces are indeterminate, the motion
    is not; the box holds exactly when mu >= tan(30 deg) = 0.5774."""
    a, m = np.radians(30), 1.0
    sol = solve_contact_forces(_box_on_incline(mu, a))
    total = sol.force.sum(axis=0)
    if mu >= np.tan(a):
        assert sol.modes == ("stick", "stick")
        np.testing.assert_allclose(total, [m * G * np.cos(a), -m * G * np.sin(a)], rtol=1e-9)
        assert np.all(np.abs(sol.force[:, 1]) <= mu * sol.force[:, 0] * (1 + 1e-9))
    else:
        assert sol.modes == ("slip", "slip")
        np.testing.assert_allclose(sol.acceleration[:, 1], G * (np.sin(a) - mu * np.cos(a)),
                                   rtol=1e-9)
        np.testing.assert_allclose(total[0], m * G * np.cos(a), rtol=1e-9)


def test_spatial_particle_on_incline_slips_straight_down():
    """In space the slip direction of an onset is found, not given: down the steepest line."""
    a, m, mu, psi = np.radians(30), 1.5, 0.3, 0.7  # the down-slope line at angle psi in (t1, t2)
    down = np.array([np.cos(psi), np.sin(psi)])
    b = np.r_[-G * np.cos(a), G * np.sin(a) * down]
    sol = solve_contact_forces(_problem(np.eye(3) / m, b, mu, [[0.0, 0.0]]))
    assert sol.modes == ("slip",)
    np.testing.assert_allclose(sol.direction[0], down, atol=1e-12)
    np.testing.assert_allclose(sol.acceleration[0, 1:], G * (np.sin(a) - mu * np.cos(a)) * down,
                               atol=1e-12)


def _painleve_rod(theta, mu, s, m=1.0, l=0.5):
    """Painleve's rod: uniform, length 2l, end on the floor, angle theta; (x, y, phi) of the
    centre; end at centre - l (cos phi, sin phi). Returns W and the rod-at-rest a_free."""
    I = m * l ** 2 / 3.0
    # end velocity = v_c + omega x r, r = -l (cos, sin): rows (n = y, t = x)
    J = np.array([[0.0, 1.0, -l * np.cos(theta)], [1.0, 0.0, l * np.sin(theta)]])
    W = J @ np.diag([1 / m, 1 / m, 1 / I]) @ J.T
    return W


def test_painleve_rod_effective_mass_and_paradox():
    """W_nt = -l^2 sin cos / I = -3 sin cos / m, so A = W_nn - mu s W_nt
    = (1 + 3 cos^2 + 3 mu s sin cos)/m for the uniform rod (I = m l^2/3 about the centre); at
    60 degrees with mu = 1.5 and s = -1, A = (1.75 - 1.95)/m < 0: the problem has no solution
    (pressed, b_n < 0) or two (b_n > 0: open, or closed with lambda_n = -b_n/A > 0)."""
    theta, mu, s, m = np.radians(60), 1.5, -1.0, 1.0
    W = _painleve_rod(theta, mu, s, m)
    A = (1 + 3 * np.cos(theta) ** 2 + 3 * mu * s * np.sin(theta) * np.cos(theta)) / m
    P = _problem(W, [-G, 0.0], mu, [s])
    assert P.effective_normal_mass()[0] == pytest.approx(A, rel=1e-12) and A < 0
    with pytest.raises(ci.PainleveError) as err:
        solve_contact_forces(P)
    assert err.value.kind == "inconsistent" and err.value.n_solutions == 0
    with pytest.raises(ci.PainleveError) as err:
        solve_contact_forces(_problem(W, [G, 0.0], mu, [s]))
    assert err.value.kind == "indeterminate" and err.value.n_solutions == 2
    # sliding the other way the same rod is well posed
    ok = solve_contact_forces(_problem(W, [-G, 0.0], mu, [-s]))
    assert ok.modes == ("slip",) and ok.force[0, 0] > 0


def test_bad_data_are_typed_errors():
    with pytest.raises(ci.ShapeError):
        ContactForceProblem(np.eye(2), np.zeros(3), np.array([0.3]), np.zeros((1, 1)))
    with pytest.raises(ci.ShapeError):
        ContactForceProblem(np.eye(2), np.array([np.nan, 0.0]), np.array([0.3]), np.zeros((1, 1)))


# The distribution among redundant contacts (max_margin_distribution): the largest smallest
# margin, then the least norm among the distributions reaching it. References by hand.

def _null(E):
    """An orthonormal basis of the null space of E."""
    _, sv, Vt = np.linalg.svd(E)
    return Vt[int(np.sum(sv > 1e-12 * sv[0])):].T


def _table_on_three_legs(mass=1.0, legs=(-0.3, 0.0, 0.3), com=0.05, height=0.1):
    """A planar table at rest on three legs (x_i in the table's frame, its centre of mass at
    x = com, the feet at height below it); forces (n_i, t_i) up and along +x. Equilibrium:
    sum n = M g, sum t = 0, moments about the centre of mass sum (X_i n_i + h t_i) = 0 with
    X_i = x_i - com. Returns (X, E, f): E lambda = f, lambda = (n1, t1, n2, t2, n3, t3)."""
    X = np.asarray(legs, float) - com
    E = np.zeros((3, 6))
    E[0, 0::2] = 1.0
    E[1, 1::2] = 1.0
    E[2, 0::2], E[2, 1::2] = X, height
    return X, E, np.array([mass * G, 0.0, 0.0])


def _least_squares_legs(X, weight):
    """min sum n_i^2 s.t. sum n = W, sum X n = 0, by Lagrange: n_i = a + b X_i, so
    n_i = W (S2 - S1 X_i) / (3 S2 - S1^2), S1 = sum X, S2 = sum X^2 (and t = 0: the
    tangential forces only have to sum to zero)."""
    S1, S2 = X.sum(), (X ** 2).sum()
    return weight * (S2 - S1 * X) / (3 * S2 - S1 ** 2)


def _perturbed(lam0, Z, rng):
    """The same data up to round-off: lam0 and Z to 1e-15 (relative), Z's columns mixed."""
    R = np.linalg.qr(rng.normal(size=(Z.shape[1], Z.shape[1])))[0]
    return (lam0 * (1 + 1e-15 * rng.normal(size=lam0.shape)),
            (Z @ R) * (1 + 1e-15 * rng.normal(size=Z.shape)))


def _block_and_table(mass_block=0.05, mu=0.5):
    """A block sliding (its normal force m g, determinate) and a table at rest on three
    legs in one problem: the block's margin lambda_n = m g binds whatever the legs carry, so
    every distribution of the table with leg margins >= m g is a maximizer (a face)."""
    X, E, f = _table_on_three_legs()
    N = _null(E)
    particular = np.linalg.lstsq(E, f, rcond=None)[0] + N @ np.array([0.4, -0.3, 0.2])
    lam0 = np.r_[mass_block * G, -mu * mass_block * G, particular]  # not the least norm
    Z = np.vstack([np.zeros((2, N.shape[1])), N])
    return X, lam0, Z, [mu] * 4, ["slip", "stick", "stick", "stick"]


def test_on_a_face_of_maximizers_the_table_carries_its_least_squares_loads():
    X, lam0, Z, mu, combo = _block_and_table()
    # by hand: X = (-0.35, -0.05, 0.25), S1 = -0.15, S2 = 0.1875: n = M g (1/4, 1/3, 5/12)
    n = _least_squares_legs(X, G)
    np.testing.assert_allclose(n, G * np.array([1 / 4, 1 / 3, 5 / 12]), rtol=1e-14)
    assert 0.5 * n.min() > 0.05 * G  # the legs' least-squares margins exceed the block's
    lam, margin = max_margin_distribution(np.array(mu), 2, combo, lam0, Z, float(G))
    f = lam.reshape(4, 2)
    np.testing.assert_allclose(f[0], [0.05 * G, -0.5 * 0.05 * G], rtol=1e-13)
    np.testing.assert_allclose(f[1:, 0], n, rtol=1e-10)
    np.testing.assert_allclose(f[1:, 1], 0.0, atol=1e-10 * G)
    assert margin == pytest.approx(0.05 * G, rel=1e-10)  # the block's, the largest possible


def test_where_the_maximizer_is_one_point_the_margins_come_first():
    """The table alone: margins mu n_i - |t_i| (t = 0 is best); along the redundant
    direction n = n_LS + s (1, -2, 1) the smallest margin is largest where the two lighter
    legs balance, n1 + s = n2 - 2 s, s = (n2 - n1) / 3 = M g / 36: n = M g (5/18, 5/18, 4/9),
    not the least-squares M g (1/4, 1/3, 5/12)."""
    X, E, f = _table_on_three_legs()
    N = _null(E)
    lam0 = np.linalg.lstsq(E, f, rcond=None)[0]  # the least-squares distribution
    lam, margin = max_margin_distribution(np.array([0.5] * 3), 2, ["stick"] * 3, lam0, N,
                                          float(G))
    np.testing.assert_allclose(lam.reshape(3, 2)[:, 0], G * np.array([5 / 18, 5 / 18, 4 / 9]),
                               rtol=1e-10)
    np.testing.assert_allclose(lam.reshape(3, 2)[:, 1], 0.0, atol=1e-10 * G)
    assert margin == pytest.approx(0.5 * G * 5 / 18, rel=1e-10)


def _box_on_four_corners(m=1.0, a=0.4, c=0.3, h=0.2):
    """A box at rest on four corners (r_i = (+-a/2, -h/2, +-c/2) from its centre of mass),
    forces (n, t1, t2) along (y, x, z). Equilibrium: sum f = (0, m g, 0) and
    sum r_i x f_i = 0; returns (E, rhs) for lambda = (n1, t1x, t1z, ..., n4, t4x, t4z)."""
    E = np.zeros((6, 12))
    for i, (sx, sz) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        r = np.array([sx * a / 2, -h / 2, sz * c / 2])
        for j, axis in enumerate((1, 0, 2)):  # n along y, t1 along x, t2 along z
            e = np.zeros(3)
            e[axis] = 1.0
            E[:3, 3 * i + j] = e
            E[3:, 3 * i + j] = np.cross(r, e)
    return E, np.r_[0.0, m * G, 0.0, 0.0, 0.0, 0.0]


@pytest.mark.parametrize("seed", range(5))
def test_the_distribution_is_the_same_when_the_data_move_by_round_off(seed):
    """1e-15 (relative) on lam0 and Z, and Z's columns mixed: the same numbers, by hand."""
    rng = np.random.default_rng(seed)
    # the box at rest: m g / 4 per corner, no tangential force
    E, rhs = _box_on_four_corners()
    N = _null(E)
    lam0 = np.linalg.lstsq(E, rhs, rcond=None)[0] + N @ rng.normal(size=N.shape[1])
    lam0, Z = _perturbed(lam0, N, rng)
    lam, margin = max_margin_distribution(np.array([0.3] * 4), 3, ["stick"] * 4, lam0, Z,
                                          float(G))
    np.testing.assert_allclose(lam.reshape(4, 3)[:, 0], G / 4, rtol=1e-12)
    np.testing.assert_allclose(lam.reshape(4, 3)[:, 1:], 0.0, atol=1e-12 * G)
    assert margin == pytest.approx(0.3 * G / 4, rel=1e-12)
    # the block and the table: the table's least-squares loads, M g (1/4, 1/3, 5/12)
    _, lam0, Z, mu, combo = _block_and_table()
    lam0, Z = _perturbed(lam0, Z, rng)
    lam, _ = max_margin_distribution(np.array(mu), 2, combo, lam0, Z, float(G))
    np.testing.assert_allclose(lam.reshape(4, 2)[1:, 0], G * np.array([1 / 4, 1 / 3, 5 / 12]),
                               rtol=1e-10)
    np.testing.assert_allclose(lam.reshape(4, 2)[1:, 1], 0.0, atol=1e-10 * G)


def test_an_unconverged_cone_program_raises_instead_of_answering(monkeypatch):
    import clarabel

    original = clarabel.DefaultSettings

    def two_iterations():
        settings = original()
        settings.max_iter = 2
        return settings

    monkeypatch.setattr(clarabel, "DefaultSettings", two_iterations)
    # the compiled cold start answers this program itself when it certifies its point; its
    # fallback, Clarabel, is what must not answer unconverged: the cold start declined here
    monkeypatch.setattr(force_distribution, "cold_max_min", lambda blocks, rtol: None)
    _, lam0, Z, mu, combo = _block_and_table()
    with pytest.raises(ci.SolverError, match="Clarabel MaxIterations"):
        max_margin_distribution(np.array(mu), 2, combo, lam0, Z, float(G))
