"""Problems and finite-difference checks shared by the tests of the several-contact impulse
derivatives (test_derivatives_several.py, test_derivatives_several_pn.py).

Problems with a prescribed mode (stick, slide, separate per contact) are constructed, not drawn
and filtered: an answer ``(pi, u)`` satisfying the law's complementarity conditions (or a KKT
point of P-N's slide program) is chosen, and ``v`` (then ``dq``, Jc having full row rank) is
solved from ``u = W pi + b``. The finite differences are central, of the impulse of the PUBLIC
path (``build_problem`` + ``solve_problem`` at tol = 1e-12). Step: the solvers answer to about
1e-12 relative, the data are of order one and W's condition number below ~10, so the central
difference's truncation (h^2 ~ 1e-10) and noise (1e-12 / h ~ 1e-7) both stay below the asserted
RTOL = 2e-6 with H = 1e-5.
"""

import numpy as np

from convimpact.impact.problem.build import build_problem
from convimpact.impact.resolve import solve_problem

#: the central differences' step and the relative tolerance asserted (module docstring)
H = 1e-5
RTOL = 2e-6
CONE_LAWS = ("ccp", "coulomb", "dissipative")
#: the method each law is solved by, at tol = 1e-12
METHOD = {"ccp": "interior", "coulomb": "interior", "dissipative": "interior",
          "pereira-nikravesh": "clarabel"}


def solve(M, Jl, dq, e, mu, law, e_t=None):
    P = build_problem(M, Jl, dq, e, mu, e_t=e_t)
    if law == "chatterjee-ruina":
        return P, solve_problem(P, law)
    return P, solve_problem(P, law, method=METHOD[law], tol=1e-12)


def system(rng, n, d, coupling=0.25, extra=2):
    """A well-conditioned k-DOF system with n contacts: M near I, Jc of full row rank."""
    N = n * d
    k = N + extra
    A = rng.standard_normal((k, k))
    M = np.eye(k) + 0.1 * A @ A.T / k
    J = np.zeros((N, k))
    J[:, :N] = np.eye(N)
    J += coupling * rng.standard_normal((N, k)) / np.sqrt(k)
    return M, J


def split(J, n, d):
    return [J[i * d:(i + 1) * d] for i in range(n)]


def unit(rng, m):
    t = rng.standard_normal(m)
    return t / np.linalg.norm(t)


def construct(rng, law, modes, d, mu=0.4, e=0.5):
    """(M, Jc list, dq, e, mu) whose answer under ``law`` has the given modes per contact
    ("sep", "stick", "slide", "limit": stick at the cone's boundary, "touch": pi = 0 with u on
    the dual cone's boundary), and the expected impulse."""
    n = len(modes)
    M, J = system(rng, n, d)
    for i, m in enumerate(modes):
        if m == "touch":  # its normal shares contact 0's, so that the others press it
            J[i * d] = 0.7 * J[i * d] + 0.7 * J[0]
    W = J @ np.linalg.solve(M, J.T)
    lift = 0.0 if law == "coulomb" else 1.0
    pi, u = np.zeros(n * d), np.zeros(n * d)
    mus = np.broadcast_to(np.asarray(mu, dtype=float), (n,))
    for i, m in enumerate(modes):
        s = slice(i * d, (i + 1) * d)
        t = unit(rng, d - 1)
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
    return M, split(J, n, d), dq, e, mus if np.ndim(mus) and np.ptp(mus) else mus[0], pi


def predicted(D, dW, dv, de=None, dmu=None):
    out = np.einsum("aij,ij->a", D.W, dW) + D.v @ dv
    if de is not None:
        out = out + D.e @ de
    if dmu is not None:
        out = out + D.mu @ dmu
    return out


def directions(rng, M, Jl, dq, e, mu):
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
        ("Jc", lambda s: (M, split(J + s * dJ, n, d), dq, e0, mu0),
         dJ @ G @ J.T + J @ G @ dJ.T, dJ @ dq, zn, zn),
        ("M", lambda s: (M + s * dM, Jl, dq, e0, mu0), -J @ G @ dM @ G @ J.T, zv, zn, zn),
        ("e", lambda s: (M, Jl, dq, e0 + s * de, mu0), zW, zv, de, zn),
        ("mu", lambda s: (M, Jl, dq, e0, mu0 + s * dmu), zW, zv, zn, dmu),
    ]


def check_fd(rng, law, M, Jl, dq, e, mu, D, pi_scale):
    """Max relative error of the derivative against central differences, per direction."""
    errors = {}
    for name, at, dW, dv, de, dmu in directions(rng, M, Jl, dq, e, mu):
        fd = (solve(*at(H), law)[1].impulse.ravel()
              - solve(*at(-H), law)[1].impulse.ravel()) / (2 * H)
        pred = predicted(D, dW, dv, de, dmu)
        errors[name] = float(np.max(np.abs(fd - pred)) / max(np.max(np.abs(fd)), pi_scale))
    return errors


def mode_lists(d):
    return [["stick", "slide", "sep"], ["slide", "sep", "stick", "slide"],
            ["sep", "slide", "stick", "stick", "slide"],
            ["stick", "slide", "slide", "sep", "stick", "sep"], ["slide", "slide"]]


def free_draw(rng, n, d, slip, approach=0.8):
    """A problem drawn freely (no prescribed mode): normal approach, slip of size ``slip``."""
    M, J = system(rng, n, d, coupling=0.3)
    v = np.zeros(n * d)
    for i in range(n):
        v[i * d] = -rng.uniform(0.2, 1.0) if rng.uniform() < approach else rng.uniform(0.1, 0.5)
        v[i * d + 1:(i + 1) * d] = slip * rng.standard_normal(d - 1)
    return M, split(J, n, d), np.linalg.lstsq(J, v, rcond=None)[0]


def construct_pn(rng, kinds, d, mu=0.4, e=0.5, sigma=None):
    """A KKT point of P-N's slide program P_N(A) with the given kinds per contact
    ("boundary": on the cone with multiplier sigma (mu, -t), "interior", "sep": off A):
    pi and the cone multipliers s are chosen, the multipliers lambda of ``u_n = 0`` on A
    solve ``(W (pi - N lambda))_n + v_n = s_n`` with ``v_n = -(W pi)_n / (1 + e)`` (so that
    ``u_n = 0``), and ``v = s - W (pi - N lambda)`` on A."""
    n = len(kinds)
    M, J = system(rng, n, d)
    W = J @ np.linalg.solve(M, J.T)
    A = [i for i, k in enumerate(kinds) if k != "sep"]
    pi, s = np.zeros(n * d), np.zeros(n * d)
    for i, k in enumerate(kinds):
        t, pn = unit(rng, d - 1), rng.uniform(0.5, 1.5)
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
    return M, split(J, n, d), np.linalg.lstsq(J, v, rcond=None)[0], e, mu, pi


def one_sided_pair(law, M, Jl, dq, e, mu, D, direction):
    """Forward and backward differences along ``direction`` (a dq perturbation) and the two
    derivatives' predictions."""
    J = np.vstack(Jl)
    h = 1e-7
    f0 = solve(M, Jl, dq, e, mu, law)[1].impulse.ravel()
    fwd = (solve(M, Jl, dq + h * direction, e, mu, law)[1].impulse.ravel() - f0) / h
    bwd = (f0 - solve(M, Jl, dq - h * direction, e, mu, law)[1].impulse.ravel()) / h
    dv = J @ direction
    return fwd, bwd, D.v @ dv, D.other_side.v @ dv


def flat_box(slip, mu):
    """A planar box (mass 1, half-width 1) landing flat on its two corners: 4 contact rows,
    3 degrees of freedom (W singular)."""
    M = np.diag([1.0, 1.0, 1.0 / 3.0 * 1.0 * (1.0 + 0.25)])
    Jl = [np.array([[0.0, 1, -1.0], [1, 0, 0.5]]), np.array([[0.0, 1, 1.0], [1, 0, 0.5]])]
    dq = np.array([slip, -1.0, 0.05])
    return M, Jl, dq, 0.5, mu
