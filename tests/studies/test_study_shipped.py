"""The shipped study (double pendulum impact atlas) and its spec files, at a small size.

Hand derivation: the tip of the double pendulum (L = 1, relative angles) is at height
sin a1 + sin(a1 + a2), so at joint rates (1, 1) its normal velocity is
v_n = cos a1 + 2 cos(a1 + a2); the impact separates exactly where v_n >= 0 (beyond the
1e-9 relative threshold of a touching contact). The dissipative law never gains energy
(T_L = 1/2 (1 - e^2) pi^T W pi >= 0)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from convimpact.studies.pendulum_impact_atlas import (categories, plot_pendulum_impact_atlas,
                                                      study_dict, study_spec)
from convimpact.studies.study import run_study
from convimpact.studies.study_spec import load_spec, spec_from_dict

pytest.importorskip("xarray", reason="studies need dask, xarray and zarr (pip install -e \".[test-full]\")")
pytest.importorskip("zarr", reason="studies need dask, xarray and zarr (pip install -e \".[test-full]\")")

ROOT = Path(__file__).resolve().parents[2]


def test_spec_files_load_and_the_shipped_toml_is_the_module_spec():
    assert load_spec(ROOT / "studies" / "pendulum_impact_atlas.toml").digest() == \
        study_spec().digest()
    assert study_spec().n_points == 8_000_000
    mc = load_spec(ROOT / "studies" / "pendulum_monte_carlo.toml")
    assert mc.dims == ("law", "sample") and mc.shape == (4, 100_000)


def test_small_pendulum_atlas_against_the_hand_normal_velocity(tmp_path):
    run = run_study(spec_from_dict(study_dict(points=24)), tmp_path / "a.zarr", "serial",
                    progress=False)
    ds = run.dataset
    a1 = ds["theta1"].values[:, None]
    a2 = ds["theta2"].values[None, :]
    vn = np.cos(a1) + 2.0 * np.cos(a1 + a2)
    clear = np.abs(vn) > 1e-6
    separating = ds["regime"].values == 0  # (theta1, theta2, mu, law)
    for i in range(2):
        for j in range(4):
            np.testing.assert_array_equal(separating[:, :, i, j][clear], (vn >= 0)[clear])
    np.testing.assert_allclose(ds["v_minus"].sel(contact_axis="n").values[:, :, 0, 0], vn,
                               atol=1e-12)
    assert not ds["energy_gained"].sel(law="dissipative").values.any()
    assert ds["energy_gained"].sel(law="pereira-nikravesh").values.any()
    cat = categories(ds)
    assert set(np.unique(cat)) <= set(range(7))
    fig = plot_pendulum_impact_atlas(ds, tmp_path / "atlas.png")
    assert (tmp_path / "atlas.png").stat().st_size > 10_000
    import matplotlib.pyplot as plt
    plt.close(fig)
