"""Property tests are deterministic wherever the README's test command runs.

Hypothesis draws the same examples on every run (``derandomize=True``), in CI (where its own
``ci`` profile does the same) and on a user's machine alike, so the suite cannot pass or fail
by chance. To explore new examples, run with ``HYPOTHESIS_PROFILE=explore``.
"""

import os

from hypothesis import settings

settings.register_profile("deterministic", derandomize=True, deadline=None)
settings.register_profile("explore", derandomize=False, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "deterministic"))
