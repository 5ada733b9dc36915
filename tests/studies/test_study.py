"""The study runner: specs checked before work, the same bytes from every executor, a killed
worker and an interrupted study both ending with the serial dataset, the atlas as studies.

The Dask tests run a scheduler and two worker processes on this machine (LocalCluster)."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import numpy as np
import pytest

import convimpact as ci
from convimpact.studies.study import run_study
from convimpact.studies.study_spec import StudySpecError, load_spec, spec_from_dict
from convimpact.studies.study_store import StudyStore, StudyStoreError, chunk_regions, chunk_shape

distributed = pytest.importorskip("distributed", reason="studies need dask, xarray and zarr (pip install -e \".[test-full]\")")
pytest.importorskip("xarray", reason="studies need dask, xarray and zarr (pip install -e \".[test-full]\")")
pytest.importorskip("zarr", reason="studies need dask, xarray and zarr (pip install -e \".[test-full]\")")

IMPACTS = {
    "study": {"kind": "impacts", "title": "pendulum impacts", "chunk_points": 150, "seed": 3},
    "options": {"scene": "pendulum_planar"},
    "grid": {"theta1": {"start": -3.0, "stop": -0.2, "num": 12, "units": "rad"},
             "law": {"values": ["coulomb", "pereira-nikravesh"]}},
    "sample": {"size": 50, "mu": {"distribution": "uniform", "low": 0.0, "high": 1.2},
               "theta2": {"distribution": "uniform", "low": -3.0, "high": 3.0}},
}
ENSEMBLE = {
    "study": {"kind": "simulation", "title": "bouncing rods", "chunk_points": 2},
    "options": {"scene": "bouncing_rod", "t_end": 0.6},
    "grid": {"e": {"values": [0.6, 0.9]}, "tilt": {"start": 10.0, "stop": 60.0, "num": 6}},
}


def _same_bytes(a, b) -> bool:
    if not a.identical(b):
        return False
    return all(np.array_equal(a[v].values.view(np.uint8), b[v].values.view(np.uint8))
               for v in a.data_vars)


#: Dask's wall-clock limits (connecting, a worker coming back): generous, so that only a
#: cluster that cannot start or recover reaches them on a loaded machine (Dask's default
#: connect timeout is 30 s)
DASK_LIMIT = 600


@pytest.fixture(scope="module")
def client():
    import dask

    limits = {"distributed.comm.timeouts.connect": f"{DASK_LIMIT}s",
              "distributed.comm.timeouts.tcp": f"{DASK_LIMIT}s"}
    with dask.config.set(limits):
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           dashboard_address=None)
        c = distributed.Client(cluster, timeout=DASK_LIMIT)
        yield c
        c.close()
        cluster.close()


def _wait_for_workers(client, n: int) -> None:
    try:
        client.wait_for_workers(n, timeout=DASK_LIMIT)
    except TimeoutError as exc:  # pragma: no cover - a broken cluster, not a slow one
        pytest.fail(f"wall-clock limit hit: the Dask cluster did not have {n} workers within "
                    f"{DASK_LIMIT} s ({exc})")


@pytest.fixture(scope="module")
def serial_impacts(tmp_path_factory):
    return run_study(spec_from_dict(IMPACTS), tmp_path_factory.mktemp("s") / "i.zarr",
                     "serial", progress=False).dataset


@pytest.fixture(scope="module")
def serial_ensemble(tmp_path_factory):
    return run_study(spec_from_dict(ENSEMBLE), tmp_path_factory.mktemp("s") / "e.zarr",
                     "serial", progress=False).dataset


def test_chunk_shape_by_hand():
    # 8 points of (4, 5, 3): the last axis whole (3), then 8 // 3 = 2 of the middle one
    assert chunk_shape((4, 5, 3), 8) == (1, 2, 3)
    assert chunk_shape((4, 5, 3), 60) == (4, 5, 3)
    assert chunk_shape((4, 5, 3), 1) == (1, 1, 1)
    regions = chunk_regions((5,), (2,))
    assert [(r[0].start, r[0].stop) for r in regions] == [(0, 2), (2, 4), (4, 5)]


def test_impacts_match_resolve_impact_point_by_point(serial_impacts):
    """The batch study against the per-impact Python path (method "fast"), at points read
    back from the store; the sample equals numpy's draws from the spec's seed."""
    ds = serial_impacts
    rng = np.random.default_rng(3)
    np.testing.assert_array_equal(ds["mu"].values, rng.uniform(0.0, 1.2, 50))
    np.testing.assert_array_equal(ds["theta2"].values, rng.uniform(-3.0, 3.0, 50))
    assert ds["theta1"].attrs["units"] == "rad" and ds["energy_loss"].attrs["units"] == "J"
    scene = ci.load_scene("pendulum_planar")
    mech, dq = scene.mechanism, scene.impact_state[1]
    for i, law, s in [(0, "coulomb", 0), (5, "pereira-nikravesh", 17), (11, "coulomb", 49)]:
        pt = ds.isel(theta1=i, sample=s).sel(law=law)
        th = np.array([float(pt.theta1), float(pt.theta2)])
        r = ci.resolve_impact(mech.mass_matrix(th), mech.contact_jacobian("tip", th), dq,
                              0.5, float(pt.mu), law=law, method="fast")
        np.testing.assert_allclose(pt["impulse"].values, r.impulse, atol=1e-10)
        assert pt["energy_loss"].values == pytest.approx(r.energy_loss, abs=1e-10)
        assert ds.attrs["regime_names"][int(pt["regime"])] == r.regime


def test_store_opens_in_xarray_without_a_warning(serial_impacts, tmp_path):
    """A study store carries consolidated metadata: xarray opens it directly, in one read and
    without a warning (no "failed to open with consolidated metadata", nothing about the
    bookkeeping folder), and reads the study's dataset; a store made without it (an older
    version) is consolidated when the study is resumed."""
    import warnings

    import xarray as xr

    path = tmp_path / "c.zarr"
    run_study(spec_from_dict(IMPACTS), path, "serial", progress=False)
    for open_store in (lambda: xr.open_zarr(path),
                       lambda: xr.open_dataset(path, engine="zarr", chunks=None)):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            ds = open_store().load()
        assert _same_bytes(ds[list(serial_impacts.data_vars)], serial_impacts)
    # an older store: its root metadata without the consolidated block
    root = path / "zarr.json"
    meta = json.loads(root.read_text())
    meta.pop("consolidated_metadata")
    root.write_text(json.dumps(meta))
    assert not StudyStore(path).consolidated()
    again = run_study(spec_from_dict(IMPACTS), path, "serial", progress=False)
    assert again.chunks_computed == 0 and StudyStore(path).consolidated()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _same_bytes(xr.open_zarr(path).load()[list(serial_impacts.data_vars)],
                           serial_impacts)


def test_progress_goes_to_a_log_as_lines(tmp_path, capsys):
    """stderr not a terminal (a log, a batch job): the default progress is plain lines -- the
    chunks to compute, then each tenth and the end -- not a bar's carriage returns."""
    run = run_study(spec_from_dict(IMPACTS), tmp_path / "l.zarr", "serial")
    lines = capsys.readouterr().err.splitlines()
    mine = [ln for ln in lines if "] pendulum impacts: " in ln]
    assert mine[0].endswith(f"pendulum impacts: {run.n_chunks} of {run.n_chunks} chunks to "
                            "compute")
    assert mine[-1].endswith(f"{run.n_chunks}/{run.n_chunks} chunks (100 %)")
    # a line each tenth of the chunks (12 chunks: every 2nd)
    n = run.n_chunks
    step = -(-n // 10)
    counts = [int(ln.split(": ")[1].split("/")[0]) for ln in mine[1:]]
    assert counts == sorted(set(list(range(step, n + 1, step)) + [n]))
    assert not any("\r" in ln for ln in lines)


@pytest.mark.slow
def test_dask_and_processes_give_the_serial_bytes(client, serial_impacts, tmp_path):
    # slow (on a cold cache each worker compiles the batch kernels); the fast suite checks
    # every executor's bytes against serial in tests/studies/test_study_bench.py and Dask's
    # under a killed worker below
    run = run_study(spec_from_dict(IMPACTS), tmp_path / "d.zarr", client=client,
                    progress=False)
    assert run.executor == "dask" and run.n_workers == 2 and run.chunks_computed == run.n_chunks
    assert _same_bytes(run.dataset, serial_impacts)
    run = run_study(spec_from_dict(IMPACTS), tmp_path / "p.zarr", "processes", workers=2,
                    progress=False)
    assert _same_bytes(run.dataset, serial_impacts)


def test_worker_killed_mid_study_loses_and_duplicates_nothing(client, serial_ensemble,
                                                              tmp_path):
    """After the first chunk completes, the worker busiest with the others is killed
    (SIGKILL); Dask reruns its task elsewhere; the store ends with one record per chunk and
    the serial dataset."""
    killed = []

    def kill_busy_worker(record):
        if killed:
            return
        busy = [w for w, tasks in client.processing().items() if tasks]
        pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    path = tmp_path / "k.zarr"
    run = run_study(spec_from_dict(ENSEMBLE), path, client=client, progress=False,
                    on_chunk=kill_busy_worker)
    assert killed
    records = StudyStore(path).records()
    assert [r["chunk"] for r in records] == list(range(run.n_chunks)) == list(range(6))
    assert _same_bytes(run.dataset, serial_ensemble)
    _wait_for_workers(client, 2)  # the nanny restarted the killed one


def test_interrupted_study_resumes_and_recomputes_only_the_rest(serial_ensemble, tmp_path):
    seen = []

    def stop_after_two(record):
        seen.append(record["chunk"])
        if len(seen) == 2:
            raise KeyboardInterrupt

    path = tmp_path / "r.zarr"
    with pytest.raises(KeyboardInterrupt):
        run_study(spec_from_dict(ENSEMBLE), path, "serial", progress=False,
                  on_chunk=stop_after_two)
    assert StudyStore(path).done() == {0, 1}
    run = run_study(spec_from_dict(ENSEMBLE), path, "serial", progress=False)
    assert (run.chunks_skipped, run.chunks_computed) == (2, 4)
    assert _same_bytes(run.dataset, serial_ensemble)
    again = run_study(spec_from_dict(ENSEMBLE), path, "serial", progress=False)
    assert again.chunks_computed == 0


def _with(**changes):
    spec = json.loads(json.dumps(IMPACTS))
    for dotted, value in changes.items():
        *head, last = dotted.split("__")
        table = spec
        for k in head:
            table = table.setdefault(k, {})
        table[last] = value
    return spec


@pytest.mark.parametrize("spec, message", [
    (_with(grid__omega={"values": [1.0]}), "unknown parameter 'omega'"),
    (_with(grid__theta1={"start": 0.0, "stop": 1.0, "num": 0}), "empty range"),
    (_with(grid__theta1={"values": []}), "is empty"),
    (_with(grid__theta1={"start": 0.0, "stop": 1.0, "num": "10"}), "must be an integer"),
    (_with(grid__theta1={"values": [0.0, "1"]}), "must be a number"),
    (_with(grid__law={"values": ["coulomb", "newton"]}), "is not one of"),
    (_with(grid__e={"values": [0.5, 1.5]}), "outside [0.0, 1.0]"),
    (_with(sample__mu={"distribution": "uniform", "low": 1.0, "high": 1.0}), "empty range"),
    (_with(sample__mu={"distribution": "normal", "mean": 0.1, "std": 0.5}), "outside its"),
    (_with(study__kind="impact"), "unknown study kind 'impact'"),
    (_with(options__scene="no_such_scene"), "unknown scene"),
    (_with(options__speed=3.0), "unknown option(s) speed"),
    (_with(study__chunk_points=True), "must be an integer"),
])
def test_bad_spec_is_refused_before_any_work(spec, message, tmp_path):
    toml = tmp_path / "bad.toml"
    toml.write_text(_toml(spec))
    with pytest.raises(StudySpecError) as info:
        run_study(toml, tmp_path / "never.zarr", "serial", progress=False)
    assert message in str(info.value)
    assert not (tmp_path / "never.zarr").exists()


def _toml(spec) -> str:
    """A TOML text of the spec (inline tables; enough for these specs)."""
    def value(v):
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, bool):
            return "true" if v else "false"
        return json.dumps(v)
    return "\n".join(f"[{table}]\n" + "\n".join(f"{k} = {value(v)}" for k, v in body.items())
                     for table, body in spec.items()) + "\n"


def test_toml_spec_round_trip_and_store_refuses_another_study(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text(_toml(IMPACTS))
    spec = load_spec(toml)
    assert spec.dims == ("theta1", "law", "sample") and spec.shape == (12, 2, 50)
    assert spec_from_dict(spec.to_dict()).digest() == spec.digest()
    StudyStore.open_or_create(tmp_path / "x.zarr", spec)
    other = spec_from_dict(_with(study__seed=4))
    with pytest.raises(StudyStoreError, match="holds another study"):
        StudyStore.open_or_create(tmp_path / "x.zarr", other)


def test_cli_study_runs_then_finds_everything_done(tmp_path, capsys):
    from convimpact.cli import main

    toml = tmp_path / "s.toml"
    toml.write_text(_toml(ENSEMBLE))
    out = tmp_path / "cli.zarr"
    assert main(["study", str(toml), "--out", str(out), "--executor", "serial", "--quiet"]) == 0
    assert "computed 6 of 6 chunks" in capsys.readouterr().out
    assert main(["study", str(toml), "--out", str(out), "--quiet"]) == 0
    assert "already in the store" in capsys.readouterr().out
    bad = tmp_path / "bad.toml"
    bad.write_text(_toml({**ENSEMBLE, "grid": {"tilt": {"values": []}}}))
    assert main(["study", str(bad), "--out", str(tmp_path / "b.zarr")]) == 2
    assert "is empty" in capsys.readouterr().err


def _atlas_maps_equal_the_builders(tmp_path, **executor) -> None:
    """Two quick atlas maps run as studies equal the map builders called directly (JSON form,
    wall time aside), the first error messages included."""
    from convimpact.studies.atlas_study import (ATLAS_MAPS, _builder_kwargs,
                                                atlas_map_from_store, atlas_specs)

    specs = {s.options["map"]: s for s in atlas_specs(quick=True)}
    for name in ("slider_crank_isosceles", "rod_zeno"):
        spec = specs[name]
        path = tmp_path / f"{name}.zarr"
        run_study(spec, path, progress=False, **executor)
        got = atlas_map_from_store(StudyStore(path)).as_dict()
        kw = _builder_kwargs(spec.options["fixed"])
        kw.update({a.name: np.array(a.values) for a in spec.grid})
        want = ATLAS_MAPS[name].builder(**kw).as_dict()
        got.pop("wall_time"), want.pop("wall_time")
        assert json.dumps(got, sort_keys=True) == json.dumps(want, sort_keys=True)
        if name == "slider_crank_isosceles":
            assert got["counts"]["pereira-nikravesh/fast"]["singular_loop"] > 0


def test_atlas_maps_as_studies_equal_the_serial_builders(tmp_path):
    _atlas_maps_equal_the_builders(tmp_path, executor="serial")


@pytest.mark.slow
def test_atlas_maps_on_the_cluster_equal_the_serial_builders(client, tmp_path):
    """The same on the Dask cluster (slow: its workers build the maps' models and kernels
    again); the fast suite checks the atlas as serial studies (above) and the Dask executor
    on the impacts and ensemble studies (the serial bytes, a killed worker)."""
    _atlas_maps_equal_the_builders(tmp_path, client=client)


def test_a_missing_studies_extra_is_a_clear_error(monkeypatch, tmp_path):
    """Without xarray/zarr the study refuses before any work, naming the extra."""
    import sys

    from convimpact.errors import NotSupportedError
    from convimpact.studies.study import run_study

    monkeypatch.setitem(sys.modules, "zarr", None)
    with pytest.raises(NotSupportedError, match=r"convimpact\[studies\]"):
        run_study(Path(__file__).parents[2] / "studies" / "pendulum_monte_carlo.toml",
                  tmp_path / "store")
    assert not (tmp_path / "store").exists()
