"""The suite sets the environment it needs itself, so the README's test command runs the same
wherever it runs (CI runs exactly that command, with nothing exported around it).

* ``MPLBACKEND=Agg``: figures are drawn off-screen, with or without a display (the notebook
  test gives its kernels the inline backend itself).
* One BLAS/OpenMP thread (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``):
  the suite's dense solves are tiny, and threaded BLAS only adds contention on a shared
  machine. A BLAS library reads these when it loads, and pytest imports this file before any
  test module -- but after its plugins, some of which (zarr's) import numpy. So the variables
  reach every library loaded later (scipy's BLAS, the subprocesses the tests start), and
  threadpoolctl (in the test extra) sets the libraries already loaded to one thread.
  tests/test_environment.py measures the result on the loaded libraries.

Hypothesis draws the same examples on every run (``derandomize=True``) and has no deadline,
in CI (where its own ``ci`` profile does the same) and on a user's machine alike, so the suite
cannot pass or fail by chance or by the machine's load. To explore new examples, run with
``HYPOTHESIS_PROFILE=explore``.

Markers (registered in pyproject.toml): ``slow`` marks the tests the README's test command
leaves out (``-m "not slow"``); each repeats, at a larger size or through a subprocess or a
cluster, a property a fast test checks, and the second documented command runs them.
"""

import os
import sys

#: the environment every test runs in, set before numpy or matplotlib is imported
TEST_ENVIRONMENT = {
    "MPLBACKEND": "Agg",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}
os.environ.update(TEST_ENVIRONMENT)
#: whether numpy was loaded before this file (by a plugin), its BLAS too early for the variables
NUMPY_LOADED_EARLY = "numpy" in sys.modules
try:
    from threadpoolctl import threadpool_limits
except ImportError:  # pragma: no cover - in the test extra; without it the variables alone
    pass
else:
    threadpool_limits(1)

from hypothesis import settings  # noqa: E402

settings.register_profile("deterministic", derandomize=True, deadline=None)
settings.register_profile("explore", derandomize=False, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "deterministic"))
