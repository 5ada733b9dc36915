"""Compiled (numba) certificates of the several-contact solver's answers, on the original data.

An impulse of the ``interior`` path is accepted on these measures, never on the iteration's
own: :func:`ccp_certificate` is the relative KKT residual of the cone complementarity
problem ``K ∋ pi ⊥ W pi + b ∈ K*`` (the ``ccp`` law and the dissipative law's plastic
phase), :func:`coulomb_certificate` the relative residual of Coulomb's law
``K ∋ pi ⊥ u + mu |u_t| n ∈ K*``, ``u = W pi + b``. Each also returns the round-off floor
below which its residual cannot be asked to fall. They are called by the drivers of
:mod:`convimpact.contacts.newton` (which hands them on) and by
:mod:`convimpact.impact.several.interior`.
"""

from __future__ import annotations

import math

import numpy as np

from .interior_point import EPS, TINY, _jit


@_jit
def _finite(x):
    for i in range(x.shape[0]):
        if not math.isfinite(x[i]):
            return False
    return True


@_jit
def ccp_certificate(W, b, mu, d, pi):
    """Relative KKT residual of ``K ∋ pi ⊥ W pi + b ∈ K*`` (frictionless: pi_t = 0).

    The max over contacts of the cone violation of pi (relative to X = max |pi|), the
    dual-cone violation of ``z = W pi + b`` (relative to V = max(|b|, |W pi|)) and
    ``|pi_i . z_i|`` (relative to X V), as :func:`convimpact.impact.conic.polish.kkt_residual`
    measures a conic answer; also returns the round-off floor ``eps max|W| X / V``. An
    impulse that is not finite has an infinite residual.
    """
    n = mu.shape[0]
    N = n * d
    if not _finite(pi):
        return np.inf, 0.0
    z = np.empty(N)
    X = TINY
    V = TINY
    wmax = 0.0
    for i in range(N):
        s = b[i]
        t = 0.0
        for j in range(N):
            s += W[i, j] * pi[j]
            t += W[i, j] * pi[j]
            if abs(W[i, j]) > wmax:
                wmax = abs(W[i, j])
        z[i] = s
        V = max(V, abs(b[i]), abs(t))
        X = max(X, abs(pi[i]))
    r = 0.0
    for i in range(n):
        o = i * d
        pt = 0.0
        zt = 0.0
        dot = pi[o] * z[o]
        for j in range(o + 1, o + d):
            pt += pi[j] * pi[j]
            zt += z[j] * z[j]
            dot += pi[j] * z[j]
        pt = math.sqrt(pt)
        zt = math.sqrt(zt)
        if mu[i] == 0.0:
            r = max(r, max(0.0, -pi[o]) / X, pt / X, max(0.0, -z[o]) / V,
                    abs(pi[o] * z[o]) / (X * V))
        else:
            r = max(r, max(0.0, pt - mu[i] * pi[o]) / X, max(0.0, mu[i] * zt - z[o]) / V,
                    abs(dot) / (X * V))
    return r, EPS * wmax * X / V


@_jit
def coulomb_certificate(W, b, mu, d, pi):
    """Relative residual of Coulomb's law ``K ∋ pi ⊥ y = u + mu |u_t| n ∈ K*``, u = W pi + b:
    :func:`convimpact.impact.laws.coulomb.coulomb_residual` compiled (the same terms and
    scales), and the round-off floor ``eps max|W| max|pi| max(1, mu) / |b|``."""
    n = mu.shape[0]
    N = n * d
    if not _finite(pi):
        return np.inf, 0.0
    u = np.empty(N)
    ps = 0.0
    bn = 0.0
    wmax = 0.0
    for i in range(N):
        s = b[i]
        for j in range(N):
            s += W[i, j] * pi[j]
            if abs(W[i, j]) > wmax:
                wmax = abs(W[i, j])
        u[i] = s
        ps += pi[i] * pi[i]
        bn += b[i] * b[i]
    ps = max(math.sqrt(ps), TINY)
    vs = max(math.sqrt(bn), wmax * ps, TINY)
    r = 0.0
    mumax = 1.0
    for i in range(n):
        o = i * d
        ut = 0.0
        pt = 0.0
        for j in range(o + 1, o + d):
            ut += u[j] * u[j]
            pt += pi[j] * pi[j]
        ut = math.sqrt(ut)
        pt = math.sqrt(pt)
        yn = u[o] + mu[i] * ut
        r = max(r, max(0.0, pt - mu[i] * pi[o], -pi[o]) / ps)
        if mu[i] == 0.0:
            r = max(r, max(0.0, -yn) / vs, pt / ps, abs(pi[o] * yn) / (ps * vs))
        else:
            mumax = max(mumax, mu[i])
            vsi = vs * max(1.0, mu[i])
            r = max(r, max(0.0, mu[i] * ut - yn) / vsi)
            dot = pi[o] * yn
            for j in range(o + 1, o + d):
                dot += pi[j] * u[j]
            r = max(r, abs(dot) / (ps * vsi))
    return r, EPS * wmax * ps * mumax / max(math.sqrt(bn), TINY)
