"""Bench section ``study`` (quick): every executor's dataset is the serial one bit for bit, and
the measured fractions and rates are well-formed; the chart is a real PNG."""

from __future__ import annotations

import pytest

pytest.importorskip("distributed", reason="studies need dask, xarray and zarr (pip install -e \".[test-full]\")")


def test_quick_study_section(tmp_path):
    from convimpact.bench import BenchConfig, section_names
    from convimpact.bench.study_section import study_section

    import dask

    assert "study" in section_names()
    # Dask's connect timeouts (30 s by default) made generous: a loaded machine starts the
    # section's workers slowly, and only a broken cluster should fail here
    with dask.config.set({"distributed.comm.timeouts.connect": "600s",
                          "distributed.comm.timeouts.tcp": "600s"}):
        res = study_section(BenchConfig.make(tmp_path, quick=True, repeat=1), lambda m: None)
    by = {(r["executor"], r["chunk_points"]): r for r in res.records}
    assert {e for e, _ in by} == {"serial", "processes", "dask"}
    for r in res.records:
        assert r["identical_to_serial"] is True
        assert r["points"] == 60 * 60 * 2 and r["impacts_per_second"] > 0
        assert 0.0 <= r["overhead_fraction"] < 1.0
        assert r["compute_seconds"] > 0 and r["startup_seconds"] > 0
    # the default chunking: at most 7200 / 16 = 450 points per chunk, i.e. whole law (2) and
    # theta2 (60) axes and 450 // 120 = 3 rows of theta1: 60 / 3 = 20 chunks
    assert {c for _, c in by} == {450}
    assert by[("serial", 450)]["speedup"] == 1.0 and by[("dask", 450)]["chunks"] == 20
    png = (tmp_path / res.figures[0]).read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    assert "bit-identical to serial: True" in res.summary[0]
