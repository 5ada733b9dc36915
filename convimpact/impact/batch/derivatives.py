"""The derivatives of a batch of single-contact impacts (``resolve_impacts(...,
derivatives=True)``): item by item, the law's ``impulse_derivative`` at the batch's answer
and the chain rule of :mod:`convimpact.impact.derivatives.chain`, stacked over the batch.

The answers come from the compiled loop; the derivatives are formed per item in Python
(a few hundred microseconds each: the cost is that of ``resolve_impact(...,
derivatives=True)`` without its solve).
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Mapping

import numpy as np

from ..derivatives.attach import check_derivatives
from ..derivatives.chain import _read_only, impact_jacobians
from ...errors import NotSupportedError, UnknownOptionError
from ..laws import TANGENTIAL_LAWS, law_module
from ..problem.build import build_problem
from .checks import OK, REGIMES

_SCALAR = {"e": True, "mu": True, "e_t": True}


def check_batch_derivatives(derivatives, law: str) -> bool:
    """``derivatives=`` of the batch: False or True (UnknownOptionError otherwise, "both"
    included: the other side is asked of resolve_impact per item); NotSupportedError when the
    law has no single-contact derivative."""
    try:  # the public call's check, then the batch's refusal of its other values
        derivatives = check_derivatives(derivatives)
    except UnknownOptionError:
        pass
    if type(derivatives) is not bool:
        extra = (" (the other side at a boundary is given per item by resolve_impact(..., "
                 "derivatives='both'))" if derivatives == "both" else "")
        raise UnknownOptionError(
            f"derivatives of resolve_impacts must be False or True, got {derivatives!r}{extra}")
    if derivatives and getattr(law_module(law), "impulse_derivative", None) is None:
        raise NotSupportedError(
            f"law {law!r} has no derivative of its single-contact impulse "
            "(impulse_derivative): resolve_impacts(..., derivatives=True) cannot treat it")
    return derivatives


def batch_jacobians(law: str, M, Jc, dq, e, mu, e_t, dq_plus: np.ndarray,
                    impulse: np.ndarray, regime: np.ndarray, status: np.ndarray
                    ) -> tuple[Mapping, Mapping, np.ndarray]:
    """(jacobian, impulse_jacobian, one_sided) stacked over the batch; the arguments are the
    batched (N, ...) views the batch solved (broadcast where shared), its answers per item."""
    n, k = dq_plus.shape
    d = impulse.shape[1]
    fn = law_module(law).impulse_derivative
    tangential = law in TANGENTIAL_LAWS
    names = ("dq", "M", "Jc", "e", "mu") + (("e_t",) if tangential else ())
    tails = {"dq": (k,), "M": (k, k), "Jc": (d, k), "e": (), "mu": (), "e_t": ()}
    jq = {name: np.full((n, k) + tails[name], np.nan) for name in names}
    jp = {name: np.full((n, d) + tails[name], np.nan) for name in names}
    one_sided = np.zeros(n, dtype=bool)
    for i in range(n):
        if status[i] != OK:
            continue
        P = build_problem(M[i], Jc[i], dq[i], float(e[i]), float(mu[i]), None,
                          float(e_t[i]) if tangential else None)
        answer = SimpleNamespace(impulse=impulse[i], regime=REGIMES[int(regime[i])])
        cd = fn(P, answer, other_side=False)
        a, b = impact_jacobians(P, impulse[i], cd, _SCALAR)
        for name in names:
            jq[name][i] = a[name]
            jp[name][i] = b[name]
        one_sided[i] = bool(cd.one_sided)
    one_sided.flags.writeable = False
    return _read_only(jq), _read_only(jp), one_sided
