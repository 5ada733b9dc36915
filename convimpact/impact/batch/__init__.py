"""Many single-contact impacts at once: a driver over the laws' compiled kernels, not a
second pipeline (the same kernels as ``resolve_impact``).

* :mod:`.impacts`: :func:`resolve_impacts` (from ``M, Jc, dq``) and :func:`contact_impulses`
  (from ``W, v-``), threads, and the items outside the compiled range of scale;
* :mod:`.drivers`: the compiled loops (validation of M, the reduction, the law's kernel, the
  map back and the flags of the diagnostics per item);
* :mod:`.checks`: the input checks and the typed errors, naming the offending item;
* :mod:`.results`: :class:`ImpactBatch` and :class:`ContactBatch`.
"""

from .impacts import (  # noqa: F401  (the batch API)
    FAILED,
    JAM,
    LAW_CODES,
    NO_SOLUTION,
    OK,
    REGIMES,
    SINGULAR,
    STATUS_NAMES,
    ContactBatch,
    ImpactBatch,
    compile_kernels,
    contact_impulses,
    resolve_impacts,
)

__all__ = ["resolve_impacts", "contact_impulses", "ImpactBatch", "ContactBatch", "REGIMES",
           "LAW_CODES", "STATUS_NAMES", "OK", "SINGULAR", "JAM", "NO_SOLUTION", "FAILED",
           "compile_kernels"]
