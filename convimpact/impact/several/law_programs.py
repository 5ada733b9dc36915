"""The several-contact programs of an impact's laws, compiled, on the contact engine's kernels.

An impact's contact data (pre-impact contact velocities v-, restitution e, friction mu) become
the engine's program ``u = W r + b``: :func:`law_data` forms b and the friction vector,
:func:`solve_law` runs the law's kernel (:func:`convimpact.contacts.newton.ccp_kernel`, or
:func:`~convimpact.contacts.newton.coulomb_kernel`) and its certificate on the original data, and
:func:`result_data` reads the post-impact velocities, slip speeds and regimes off the impulse.
:func:`solve_law` and the engine's kernels are taken into their compiled callers' bodies
(:data:`convimpact.compiled.jit_inline`): the lane compiles them as one function, not as a
chain of functions each of which would optimize and emit everything below it again.
"""

from __future__ import annotations

import math

import numpy as np

from ...contacts.certificates import ccp_certificate, coulomb_certificate
from ...contacts.interior_point import TINY, TRIVIAL, _jit
from ...contacts.newton import ccp_kernel, cone_kernel, coulomb_kernel  # noqa: F401 (kernels() hands on all three)
from ...compiled import jit_inline


#: a contact approaching slower than this fraction of max |v-| counts as touching
#: (:data:`convimpact.impact.conic.paths.APPROACH_RTOL`)
APPROACH_RTOL = 1e-9


@_jit
def law_data(v, e, friction, d, newton, all_friction):
    """The linear term b and the friction vector of a law's program from the contact data.

    ``b = v- + e min(v_n-, 0) n`` (``newton``; else b = v-, the dissipative law's plastic
    phase) and ``mu = friction`` (``all_friction``: Coulomb's law) or, for the
    maximal-dissipation programs, zero at contacts that do not approach by more than
    round-off (:func:`convimpact.impact.conic.paths.approaching`).
    """
    n = friction.shape[0]
    b = v.copy()
    mu = friction.copy()
    vscale = 0.0
    for i in range(v.shape[0]):
        if abs(v[i]) > vscale:
            vscale = abs(v[i])
    for i in range(n):
        vn = v[i * d]
        if newton and vn < 0.0:
            b[i * d] = vn + e[i] * vn
        if not all_friction and not vn < -APPROACH_RTOL * vscale:
            mu[i] = 0.0
    return b, mu


@_jit
def result_data(W, v, pi, friction, d, tol):
    """Post-impact velocities, slip speeds and regime codes of an impulse.

    ``v+ = v- + W pi``; per contact |v_t+| and the regime (0 separating, 1 frictionless,
    2 stick, 3 slide) by the rule of :func:`convimpact.impact.conic.paths.regimes_from_slip`:
    separating when ``pi_n <= tol |v-| / |W|``, frictionless when mu = 0, stick when
    ``|v_t+| <= 10 tol |v-|`` (max norms).
    """
    n = friction.shape[0]
    N = n * d
    vplus = np.empty(N)
    vscale = TINY
    wscale = TINY
    for i in range(N):
        s = v[i]
        for j in range(N):
            s += W[i, j] * pi[j]
            if abs(W[i, j]) > wscale:
                wscale = abs(W[i, j])
        vplus[i] = s
        if abs(v[i]) > vscale:
            vscale = abs(v[i])
    slip = np.empty(n)
    codes = np.empty(n, dtype=np.int64)
    pscale = vscale / wscale
    for i in range(n):
        o = i * d
        t = 0.0
        for j in range(o + 1, o + d):
            t += vplus[j] * vplus[j]
        slip[i] = math.sqrt(t)
        if pi[o] <= tol * pscale:
            codes[i] = 0
        elif friction[i] == 0.0:
            codes[i] = 1
        elif slip[i] <= 10.0 * tol * vscale:
            codes[i] = 2
        else:
            codes[i] = 3
    return vplus, slip, codes


@_jit
def _law_answer(W, v, e, friction, d, accuracy, pi, status, it, steps, residual, floor):
    """:func:`solve_law`'s return: the kernel's figures and one array (a single one to box)
    holding the impulse and, per contact, the regime code, the lift, ``mu |v_t+|`` and
    ``v_n+``."""
    vplus, slip, codes = result_data(W, v, pi, friction, d, accuracy)
    n = friction.shape[0]
    N = n * d
    out = np.empty(N + 4 * n)
    for c in range(N):  # (a slice assignment would compile numba's shape-error message)
        out[c] = pi[c]
    for i in range(n):
        vn = v[i * d]
        out[N + i] = codes[i]
        out[N + n + i] = vplus[i * d] - (-e[i]) * (vn if vn < 0.0 else 0.0)
        out[N + 2 * n + i] = friction[i] * slip[i]
        out[N + 3 * n + i] = vplus[i * d]
    return status, it, steps, residual, floor, out


@jit_inline
def solve_law(W, v, e, friction, d, mode, tol, max_iter, newton_iter, accuracy):
    """One law on contact data in one compiled call (the public path's: no dispatch between
    the steps): :func:`law_data`, the law's kernel, its certificate and :func:`result_data`.

    ``mode`` 0 is ``ccp`` (Newton's shift), 1 the dissipative law's plastic phase (b = v-),
    2 ``coulomb``. Returns the kernel's status, iterations and Newton steps, the certificate
    and its round-off floor (both 0 for a trivial program), and one array (a single one to
    box) holding the kernel's impulse (N) and, per contact (n each), the regime code of that
    impulse at ``accuracy``, the lift ``v_n+ - (-e min(v_n-, 0))``, ``mu |v_t+|`` and
    ``v_n+`` (elementwise, as numpy forms them).
    """
    coulomb = mode == 2
    b, mu = law_data(v, e, friction, d, mode != 1, coulomb)
    pi, status, it, steps, r1, r2 = cone_kernel(W, b, mu, d, tol, max_iter, newton_iter,
                                                 coulomb)
    residual = 0.0
    floor = 0.0
    if status != TRIVIAL:
        if coulomb:
            residual, floor = coulomb_certificate(W, b, mu, d, pi)
        else:
            residual, floor = ccp_certificate(W, b, mu, d, pi)
    return _law_answer(W, v, e, friction, d, accuracy, pi, status, it, steps, residual, floor)
