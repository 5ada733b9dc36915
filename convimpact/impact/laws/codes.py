"""What every compiled batch kernel shares: the ``njit`` options, the status, regime and law
codes, the tolerances, and small scalar and tuple helpers.

Codes and tolerances are module constants, frozen into the machine code where a kernel reads
them; :mod:`convimpact.impact.batch.impacts` reads the status codes through the package.
"""

from __future__ import annotations

import math

from ...compiled import jit as _jit  # every kernel's njit options, and its cache

# status codes of one item (see convimpact.impact.batch.impacts for the public names)
OK = 0
SINGULAR = 1  # SingularSystemError: W_nn <= 0, or W singular where the law inverts it
JAM = 2  # NonPositiveEffectiveMassError: every sliding denominator <= 0 (Newton laws)
NO_SOLUTION = 3  # SolverError: no answer of the law's conditions found (certificates failed)
DEFER = 9  # W or v outside [SAFE_LO, SAFE_HI]: rescaled by the Python dispatcher, solved again

#: length of the float64 scratch ``out`` every law kernel takes as its last argument and
#: writes its extras into (law-specific layout, documented in the law's module; the batch
#: drivers pass one and do not read it)
OUT_SIZE = 32
# input errors found by the (M, Jc, dq) driver (raised by batch.py, naming the item)
BAD_M_FINITE = -1
BAD_M_SYMMETRY = -2
BAD_M_DEFINITE = -3
BAD_J_FINITE = -4
BAD_DQ_FINITE = -5
BAD_OVERFLOW = -6
BAD_W_FINITE = -7  # (W, v) driver: W or v not finite

# regime codes (the order of batch.REGIMES)
SEPARATING = 0
FRICTIONLESS = 1
STICK = 2
SLIDE = 3
FAILED = -1

CONE_RTOL = 1e-12
ROOT_RTOL = 1e-8
SINGULAR_RTOL = 1e-12
SYMMETRY_RTOL = 1e-10
#: W's trace and v's largest entry inside this range are solved here; outside it the Python
#: dispatcher (exact.dispatch.dispatch) rescales, so those items are deferred to it
SAFE_LO, SAFE_HI = 2.0 ** -166, 2.0 ** 166

_NAN = math.nan


# --------------------------------------------------------------------------------------------
# small helpers (Python's max/min semantics: the first argument wins unless beaten)


@_jit
def _pmax2(a, b):
    return b if b > a else a


@_jit
def _in_cone(pn, ptn, mu):
    return pn >= 0.0 and ptn <= mu * pn * (1.0 + CONE_RTOL)


@_jit
def _unit_or(x1, x2, f1, f2):
    n = math.hypot(x1, x2)
    if n > 0.0:
        return x1 / n, x2 / n
    return f1, f2


@_jit
def _tset4(t, j, x):
    """The 4-tuple t with element j replaced by x."""
    return (x if j == 0 else t[0], x if j == 1 else t[1], x if j == 2 else t[2],
            x if j == 3 else t[3])


@_jit
def _tset5(t, j, x):
    """The 5-tuple t with element j replaced by x."""
    return (x if j == 0 else t[0], x if j == 1 else t[1], x if j == 2 else t[2],
            x if j == 3 else t[3], x if j == 4 else t[4])
