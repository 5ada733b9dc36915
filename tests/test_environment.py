"""The environment the suite sets itself (tests/conftest.py) takes effect: figures go to Agg,
and numpy's and scipy's BLAS run one thread -- measured on the loaded libraries, not read back
from the variables."""

import os
import pytest


def test_variables_are_set_for_the_tests_and_their_subprocesses():
    assert os.environ["MPLBACKEND"] == "Agg"
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        assert os.environ[name] == "1", name


def test_matplotlib_draws_off_screen():
    import matplotlib

    assert matplotlib.get_backend().lower() == "agg"


def test_blas_runs_one_thread():
    threadpoolctl = pytest.importorskip(
        "threadpoolctl", reason="threadpoolctl (in the test extra) reads the BLAS thread count")
    import numpy as np
    import scipy.linalg

    np.linalg.solve(np.eye(3) * 2.0, np.ones(3))  # numpy's and scipy's BLAS both loaded
    scipy.linalg.cho_factor(np.eye(3) * 2.0)
    blas = [p for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas"]
    assert blas, "no BLAS library found loaded"
    assert {p["num_threads"] for p in blas} == {1}, blas


def test_hypothesis_is_derandomized_without_deadline():
    # every property test draws the same examples on every run, and no example can fail for
    # taking long on a loaded machine (the tests' own @settings inherit this profile)
    from hypothesis import settings

    if os.environ.get("HYPOTHESIS_PROFILE", "deterministic") != "deterministic":
        pytest.skip("exploring: HYPOTHESIS_PROFILE chose another profile")
    assert settings.default.derandomize is True and settings.default.deadline is None
    assert settings().derandomize is True and settings(max_examples=5).deadline is None
