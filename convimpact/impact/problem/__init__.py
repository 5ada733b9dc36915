"""Step 1 of an impact: validate the raw data and reduce them to contact space.

* :mod:`.build`: :func:`build_problem` checks ``M, Jc, dq, e, mu, C`` (typed errors naming
  what to change) and forms the :class:`ImpactProblem` every law works on: the Delassus matrix
  ``W = Jc G Jc^T`` (closed loops folded in, eqs. 43-52), the pre-impact contact velocities
  ``v- = Jc dq`` (eq. 17) and the map back from contact impulses to the jump in ``dq`` and the
  loop impulses (eqs. 29, 44, 45);
* :mod:`.reduction`: that reduction on validated arrays (Cholesky of M, ``X = L^-1 Jc^T``,
  the Schur complement of the loops);
* :mod:`.dense`: the small dense algebra it needs, with no LAPACK call that hands a tiny matrix
  to BLAS threads;
* :mod:`.compiled_reduction`: the same reduction and map back in numba, for the compiled lanes
  (:mod:`convimpact.impact.exact.lane`, :mod:`convimpact.impact.several.lane`).
"""

from .build import ImpactProblem, build_problem

__all__ = ["ImpactProblem", "build_problem"]
