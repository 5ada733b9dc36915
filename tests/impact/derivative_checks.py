"""The independent second method of the derivative tests: central finite differences of the
PUBLIC call ``resolve_impact`` (and one-sided ones at a boundary), and the scenes they use.

Steps are chosen from the scale of each argument (h = 1e-6 of its largest entry, the central
difference's truncation h^2 and round-off eps/h both near 1e-10 of the answer's scale)."""

from __future__ import annotations

import numpy as np

import convimpact as ci

REL_STEP = 1e-6


def scene(d: int, k: int = 5, seed: int = 0, v=None, loops: int = 0):
    """(M, Jc, dq, C): a random SPD M, a contact Jacobian with the contact velocity ``v``
    (normal first) and, with ``loops``, C of that many rows with C dq = 0."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(k, k))
    M = A @ A.T + k * np.eye(k)
    M = 0.5 * (M + M.T)
    Jc = rng.normal(size=(d, k))
    C = rng.normal(size=(loops, k)) if loops else None
    if v is None:
        v = np.concatenate(([-1.0], rng.normal(size=d - 1)))
    # dq with Jc dq = v (and C dq = 0): the least-norm solution of the stacked system
    rows = Jc if C is None else np.vstack([Jc, C])
    rhs = np.asarray(v, float) if C is None else np.concatenate([v, np.zeros(loops)])
    dq = np.linalg.lstsq(rows, rhs, rcond=None)[0]
    return M, Jc, dq, C


def call(M, Jc, dq, e, mu, C=None, law="pereira-nikravesh", e_t=None, **kw):
    return ci.resolve_impact(M, Jc, dq, e=e, mu=mu, C=C, law=law, e_t=e_t, **kw)


def _fd(f, x, h, side=0):
    """Central difference; at a domain edge (side = +1 / -1) the one-sided second-order one."""
    if side == 0:
        return (f(x + h) - f(x - h)) / (2.0 * h)
    h = side * h
    return (-3.0 * f(x) + 4.0 * f(x + h) - f(x + 2.0 * h)) / (2.0 * h)


#: the ranges of the coefficients: the one-sided differences at their edges
RANGES = {"e": (0.0, 1.0), "mu": (0.0, np.inf), "e_t": (-1.0, 1.0)}


def _side(name, x, h):
    lo, hi = RANGES[name]
    return 1 if x - h < lo else (-1 if x + h > hi else 0)


def finite_differences(M, Jc, dq, e, mu, C=None, law="pereira-nikravesh", e_t=None,
                       method="auto"):
    """Central differences of ``result.dq_plus`` and ``result.impulse`` with respect to dq
    (along ker C with loops: "dq" is then laid out against the basis "Z" of ker C), the
    symmetric pairs of M ("M_pairs": M_ij and M_ji moved together, upper triangle filled),
    Jc's entries, e, mu (and e_t; one-sided second-order differences at the edges of their
    ranges). Returns ``{"dq_plus": {...}, "impulse": {...}}`` laid out as the jacobians."""
    args = dict(M=np.array(M, float), Jc=np.array(Jc, float) if isinstance(Jc, np.ndarray)
                else [np.array(j, float) for j in Jc], dq=np.array(dq, float),
                e=e, mu=mu, C=C, law=law, e_t=e_t)
    r0 = ci.resolve_impact(args["M"], args["Jc"], args["dq"], e=e, mu=mu, C=C, law=law,
                           e_t=e_t, method=method)
    k = r0.dq_plus.size
    ishape = np.shape(r0.impulse)

    def out(**over):
        a = {**args, **over}
        r = ci.resolve_impact(a["M"], a["Jc"], a["dq"], e=a["e"], mu=a["mu"], C=a["C"],
                              law=a["law"], e_t=a["e_t"], method=method)
        return np.concatenate([r.dq_plus, np.ravel(r.impulse)])

    res = {}
    dq0 = args["dq"]
    hq = REL_STEP * max(np.abs(dq0).max(), 1e-300)
    Z = np.eye(k) if C is None else np.linalg.svd(C)[2][C.shape[0]:].T
    res["dq"] = np.stack([_fd(lambda s: out(dq=dq0 + s * z), 0.0, hq) for z in Z.T], axis=-1)
    M0 = args["M"]
    hm = REL_STEP * np.abs(M0).max()
    dm = np.zeros(out().shape + (k, k))
    for i in range(k):
        for j in range(i, k):
            E = np.zeros((k, k))
            E[i, j] = E[j, i] = 1.0
            dm[..., i, j] = _fd(lambda s: out(M=M0 + s * E), 0.0, hm)
    res["M_pairs"] = dm
    J0 = np.array(args["Jc"], float)
    as_list = not isinstance(args["Jc"], np.ndarray)
    hj = REL_STEP * np.abs(J0).max()
    dj = np.zeros(out().shape + J0.shape)
    for idx in np.ndindex(*J0.shape):
        E = np.zeros(J0.shape)
        E[idx] = 1.0
        dj[(...,) + idx] = _fd(lambda s: out(Jc=list(J0 + s * E) if as_list
                                             else J0 + s * E), 0.0, hj)
    res["Jc"] = dj
    for name in ("e", "mu") + (("e_t",) if e_t is not None else ()):
        x0 = np.asarray(args[name], float)
        h = REL_STEP * max(np.abs(x0).max(), 1.0)
        if x0.ndim == 0:
            res[name] = _fd(lambda s: out(**{name: float(x0 + s)}), 0.0, h,
                            _side(name, float(x0), h))
        else:
            res[name] = np.stack([_fd(lambda s: out(**{name: list(x0 + s * ei)}), 0.0, h,
                                      _side(name, float(x0 @ ei), h))
                                  for ei in np.eye(x0.size)], axis=-1)
    split = {"dq_plus": {"Z": Z}, "impulse": {"Z": Z}}
    for name, a in res.items():
        split["dq_plus"][name] = a[:k]
        split["impulse"][name] = a[k:].reshape(ishape + a.shape[1:])
    return split


def assert_matches(jac, fd, rtol=2e-6, floor=1e-3):
    """The analytic jacobian against the finite differences (scale: the largest entry, at
    least ``floor``: a derivative that is zero by the mechanics is compared absolutely)."""
    Z = fd["Z"]
    checks = {"dq": (jac["dq"] @ Z, fd["dq"])}
    JM = np.asarray(jac["M"])
    k = JM.shape[-1]
    pairs = JM + np.swapaxes(JM, -1, -2)
    sym = np.where(np.eye(k, dtype=bool), JM, pairs)
    iu = np.triu_indices(k)
    checks["M"] = (sym[..., iu[0], iu[1]], fd["M_pairs"][..., iu[0], iu[1]])
    for name in ("Jc", "e", "mu", "e_t"):
        if name in fd:
            checks[name] = (np.asarray(jac[name]), fd[name])
    for name, (a, b) in checks.items():
        assert a.shape == b.shape, (name, a.shape, b.shape)
        scale = max(np.abs(b).max(), np.abs(a).max(), floor)
        err = np.abs(a - b).max() / scale
        assert err <= rtol, f"{name}: relative error {err:.3e}\nanalytic\n{a}\nfd\n{b}"
