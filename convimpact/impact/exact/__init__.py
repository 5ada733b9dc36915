"""Step 3a: the exact single-contact paths, which run each law's compiled kernel.

* :mod:`.dispatch`: ``method="fast"`` -- :func:`~.dispatch.solve_contact` validates one
  contact's ``(W, v-)``, brings it to a safe scale by powers of two and calls the law's
  kernel (:mod:`convimpact.impact.laws`); the Python entry of a compiled kernel
  (:func:`~.dispatch.compiled_kernel`: status codes to typed errors, extras), and several
  dynamically independent contacts solved one by one;
* :mod:`.lane` and :mod:`.lane_kernel`: the public call's compiled lane for one open-loop
  contact (reduction, the law's kernel and the map back in one numba call);
* :mod:`.closed_forms`: the paper's closed forms (Sections 5-8), the cross-check of the
  kernels and ``method="closed-form"``;
* :mod:`.sweep`: the paper's own 1-D search of the sliding angle (``method="sweep"``).
"""
