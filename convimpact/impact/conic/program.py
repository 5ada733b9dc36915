"""The cone QP that every impact law reduces to, as data: :class:`ConeQP`.

``minimize 1/2 x^T W x + q^T x  s.t.  E x = f,  x_i in K_mu_i`` in contact space. How the laws
reduce to it and how a backend solves it is :mod:`convimpact.impact.conic.qp` (which hands
the name on); the Newton polish of an answer is :mod:`convimpact.impact.conic.polish`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class ConeQP:
    """``minimize 1/2 x^T W x + q^T x  s.t.  E x = f,  x_i in K_mu_i`` in contact space.

    Attributes
    ----------
    W : (N, N) symmetric positive semidefinite, N = n_contacts d.
    q : (N,) linear term.
    mu : (n_contacts,) friction coefficients; mu_i = 0 poses pi_n >= 0, pi_t = 0.
    dim : d, 2 (planar) or 3 (spatial).
    E, f : (m, N), (m,) equality constraints (m may be 0).
    """

    W: np.ndarray
    q: np.ndarray
    mu: np.ndarray
    dim: int
    E: np.ndarray
    f: np.ndarray

    @property
    def n_contacts(self) -> int:
        """The number of contacts."""
        return self.mu.shape[0]

    @property
    def structure(self) -> tuple:
        """What fixes the compiled program: sizes, which contacts are frictionless, m."""
        return (self.n_contacts, self.dim, tuple(bool(m == 0.0) for m in self.mu),
                self.E.shape[0])
