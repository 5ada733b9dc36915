"""The contract between an impact law and the derivative chain: a law's impulse derivative in
contact space."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class ContactDerivative:
    """Derivative of a law's contact-frame impulse with respect to its contact-space data.

    Shapes use the flat contact space: ``n`` contacts of dimension ``d`` (2 planar, 3 spatial),
    ``N = n d``, the impulse flattened contact by contact, normal first (``pi.ravel()``).

    Attributes
    ----------
    W : (N, N, N) array
        ``d pi_a = sum_ij W[a, i, j] dW_ij`` for every *symmetric* perturbation ``dW`` of the
        Delassus matrix (only the contraction with symmetric ``dW`` is defined: a law may put
        a symmetric pair's whole weight on either entry or split it).
    v : (N, N) array
        ``d pi / d v_minus`` (the pre-impact contact-frame velocities, flattened).
    e, mu : (N, n) arrays
        ``d pi / d e_i`` and ``d pi / d mu_i`` (per contact).
    e_t : (N, n) array or None
        ``d pi / d e_t_i`` for a law with a tangential restitution, else None.
    regimes : tuple of str
        The mode the derivative belongs to, per contact ("separating", "frictionless",
        "stick", "slide", or a law's finer name such as "slide-stick" for Stronge).
    one_sided : tuple of str
        Empty inside a mode. At a mode boundary (the stick limit, a contact about to separate,
        a slip reversal, ...) one statement per boundary met: the derivative above is the
        one-sided derivative of the mode named in ``regimes``.
    other_side : ContactDerivative or None
        At a boundary, the derivative of the neighbouring mode (when asked for), else None.
    impulse : (n, d) array or None
        The impulse this derivative is taken at when it is not the result's (an other side
        across a boundary where the impulse jumps, e.g. the spatial stick limit of law
        pereira-nikravesh); None: the result's impulse.
    """

    W: np.ndarray
    v: np.ndarray
    e: np.ndarray
    mu: np.ndarray
    e_t: np.ndarray | None
    regimes: tuple[str, ...]
    one_sided: tuple[str, ...] = ()
    other_side: "ContactDerivative | None" = None
    impulse: np.ndarray | None = None
