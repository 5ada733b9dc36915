"""Compiled (numba) batch kernels behind :func:`convimpact.impact.batch.resolve_impacts`.

A line-by-line port of the exact single-contact kernels of :mod:`convimpact.impact.laws`
(``contact_kernel`` of each law, with :mod:`~convimpact.impact.small_linalg`,
:mod:`~convimpact.impact.boundary` and :mod:`~convimpact.impact.max_dissipation`) to numba, on
scalars and small scratch arrays, plus two fused driver loops: one from (W, v) and one from
(M, Jc, dq) that also validates M (symmetry, Cholesky), forms W = Jc M^-1 Jc^T and v- = Jc dq,
solves, maps the impulse back to dq+ and measures the result's flags exactly as
:func:`convimpact.impact.diagnostics.assemble_result` does for one contact.

Branches are taken in the same order and with the same floating-point expressions as the
Python kernels, so the answers agree to round-off. The rare branches of the Python kernels
that use numpy's companion-matrix roots (``robust=True``), the rescaling of W and v outside
[2^-166, 2^166] (:func:`convimpact.impact.fast.dispatch`), and the "no solution found" errors
(spatial ``stronge``: its step-size underflow) are not ported: the kernel returns
:data:`DEFER` and :mod:`convimpact.impact.batch` solves those items with the Python kernel
itself (:func:`convimpact.impact.fast.solve_contact`).

Layout
------
* :mod:`.common`: the ``njit`` options, status/regime/law codes, tolerances, scalar helpers;
* :mod:`.algebra`: 2 x 2 and 3 x 3 solves, polynomial roots, the cone-boundary directions;
* one module per law: :mod:`.pereira_nikravesh` (with max_dissipation), :mod:`.coulomb`,
  :mod:`.ccp`, :mod:`.dissipative`, :mod:`.stronge` (planar: its exact piecewise-linear path)
  and :mod:`.stronge_spatial` (spatial: the same path with its curved slip integrated by the
  Python kernel's own DOP853 step loop, event location and hand-over, ported);
* :mod:`.loop`: one contact's dispatch and the drivers :func:`contact_batch` and
  :func:`impact_batch` (the two entries :mod:`convimpact.impact.batch` calls).

Compilation and its cache
-------------------------
Importing this package imports numba (an optional dependency: ``pip install
"convimpact[batch]"``); :mod:`convimpact.impact.batch` imports it lazily and raises
:class:`~convimpact.impact.errors.NotSupportedError` without numba, so ``import convimpact``
pays nothing. Every kernel compiles on its first call with ``cache=True``: the machine code
is kept in ``__pycache__`` beside each module. numba checks a cached function against the
timestamp of *its own* source file only, while the machine code of a caller contains the
kernels it calls from the sibling modules: after editing ``common.py``, ``algebra.py`` or a
law's module in place, delete ``convimpact/impact/batch_kernels/__pycache__`` (an installed
copy is rewritten whole, so every cache entry is invalidated on upgrade).
"""

from __future__ import annotations
