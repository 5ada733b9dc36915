"""The Zarr store of a study: its layout, one region written per chunk, completion markers, resume.

A study store is a Zarr (format 3) group on a file system every worker can reach, created
once by :meth:`StudyStore.create` from a template (xarray, dimensions, coordinates, units in
attrs, every variable filled with its fill value) whose Zarr chunks are exactly the study's
chunks of work, so each unit of work writes its own Zarr chunks and no other. Bookkeeping
lives beside the arrays in ``STORE/.study/``:

* ``spec.json`` -- the spec (and its digest): a store answers only the study it was made for;
* ``done/<chunk>.json`` -- one completion record per chunk, written atomically (a temporary
  file renamed) **after** the chunk's data: a chunk whose record exists is complete; a chunk
  interrupted mid-write has no record and is recomputed on resume, rewriting the same region
  with the same bytes. So a killed worker loses no finished chunk and the store holds each
  chunk once, whatever was retried.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..errors import ConvImpactError
from .study_kinds import OutputVariable, get_kind
from .study_spec import SAMPLE_DIM, StudySpec, spec_from_dict

#: format version of the store's bookkeeping
STORE_SCHEMA = 1
#: a study without ``chunk_points`` is cut into at least this many chunks (when it has as
#: many points)
MIN_CHUNKS = 16


class StudyStoreError(ConvImpactError, RuntimeError):
    """A store that cannot hold this study (another study's store, or not a study store)."""


def chunk_shape(shape: tuple[int, ...], points: int) -> tuple[int, ...]:
    """The chunk of work over a study of ``shape``: whole trailing dimensions while they fit in
    ``points``, then a block of the next one, then single indices (C order)."""
    out = [1] * len(shape)
    budget = max(1, int(points))
    for i in range(len(shape) - 1, -1, -1):
        if shape[i] <= budget:
            out[i] = shape[i]
            budget //= max(shape[i], 1)
        else:
            out[i] = max(1, budget)
            break
    return tuple(out)


def default_chunk_points(spec: StudySpec, kind) -> int:
    """Points per chunk: the spec's ``chunk_points``, else the kind's default, but at most
    1/:data:`MIN_CHUNKS` of the study (so that the workers of a small cluster share the tail;
    the layout depends on the spec only, never on the executor)."""
    if spec.chunk_points:
        return int(spec.chunk_points)
    return max(1, min(int(kind.default_chunk_points), math.ceil(spec.n_points / MIN_CHUNKS)))


def chunk_regions(shape: tuple[int, ...], chunks: tuple[int, ...]) -> list[tuple[slice, ...]]:
    """The regions of the chunks (C order of the chunk grid); index i is chunk i."""
    counts = [math.ceil(n / c) for n, c in zip(shape, chunks)]
    regions = []
    for idx in np.ndindex(*counts):
        regions.append(tuple(slice(i * c, min((i + 1) * c, n))
                             for i, c, n in zip(idx, chunks, shape)))
    return regions


class StudyStore:
    """A study's Zarr store at ``path`` (see the module docstring)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._group = None
        self._spec: StudySpec | None = None
        self._outputs: dict[str, OutputVariable] | None = None

    @property
    def meta_dir(self) -> Path:
        return self.path / ".study"

    @property
    def done_dir(self) -> Path:
        return self.meta_dir / "done"

    def exists(self) -> bool:
        return (self.meta_dir / "spec.json").is_file()

    # -- creation and opening -------------------------------------------------------------

    @classmethod
    def open_or_create(cls, path: str | Path, spec: StudySpec) -> "StudyStore":
        """The store of ``spec`` at ``path``: created when absent, checked when present
        (:class:`StudyStoreError` if it holds another study)."""
        store = cls(path)
        if store.exists():
            held = store.stored()
            if held["digest"] != spec.digest():
                raise StudyStoreError(
                    f"{store.path} holds another study ({held['spec']['study'].get('title')!r}"
                    f", kind {held['spec']['study']['kind']!r}); choose another store or "
                    "remove it")
            if not store.consolidated():  # a store made before consolidated metadata
                store._consolidate()
            return store
        if store.path.exists() and any(store.path.iterdir()):
            raise StudyStoreError(f"{store.path} exists and is not a study store; choose "
                                  "another store or remove it")
        store._create(spec)
        return store

    def stored(self) -> dict[str, Any]:
        """The store's ``spec.json``: ``spec`` (dict), ``digest``, ``chunks``, ``n_chunks``."""
        try:
            return json.loads((self.meta_dir / "spec.json").read_text())
        except FileNotFoundError:
            raise StudyStoreError(f"{self.path} is not a study store (no .study/spec.json)") \
                from None

    @property
    def spec(self) -> StudySpec:
        if self._spec is None:
            self._spec = spec_from_dict(self.stored()["spec"], source=str(self.path))
        return self._spec

    @property
    def chunks(self) -> tuple[int, ...]:
        return tuple(self.stored()["chunks"])

    def regions(self) -> list[tuple[slice, ...]]:
        return chunk_regions(self.spec.shape, self.chunks)

    def _create(self, spec: StudySpec) -> None:
        import dask.array as da
        import xarray as xr

        kind = get_kind(spec.kind)
        chunks = chunk_shape(spec.shape, default_chunk_points(spec, kind))
        coords: dict[str, Any] = {}
        for axis in spec.grid:
            vals = (np.array(axis.values, dtype=object) if isinstance(axis.values[0], str)
                    else np.asarray(axis.values))
            coords[axis.name] = xr.Variable((axis.name,), vals, {"units": axis.units})
        if spec.sample_size:
            coords[SAMPLE_DIM] = xr.Variable((SAMPLE_DIM,), np.arange(spec.sample_size))
            for p in spec.sampled:
                coords[p.name] = xr.Variable((SAMPLE_DIM,), spec.sample_values()[p.name],
                                             {"units": p.units,
                                              "distribution": p.distribution,
                                              **dict(p.arguments)})
        data_vars = {}
        for var in kind.outputs(spec):
            for dim, vals in var.extra_dims:
                coords.setdefault(dim, xr.Variable((dim,), np.array(vals, dtype=object)))
            shape = spec.shape + var.extra_shape
            data = da.full(shape, var.fill_value, dtype=var.dtype,
                           chunks=chunks + var.extra_shape)
            data_vars[var.name] = xr.Variable(
                spec.dims + tuple(d for d, _ in var.extra_dims), data,
                {"units": var.units, "long_name": var.description})
        attrs = {"title": spec.title, "study_kind": spec.kind, "study_digest": spec.digest(),
                 "study_spec": json.dumps(spec.to_dict(), sort_keys=True),
                 **kind.dataset_attrs(spec)}
        ds = xr.Dataset(data_vars, coords, attrs)
        encoding = {name: {"fill_value": var.fill_value}
                    for name, var in ((v.name, v) for v in kind.outputs(spec))}
        self.path.parent.mkdir(parents=True, exist_ok=True)
        ds.to_zarr(str(self.path), mode="w", compute=False, consolidated=False,
                   zarr_format=3, encoding=encoding)
        self.done_dir.mkdir(parents=True, exist_ok=True)
        self._consolidate()
        n = len(chunk_regions(spec.shape, chunks))
        _atomic_write(self.meta_dir / "spec.json", json.dumps(
            {"schema": STORE_SCHEMA, "spec": spec.to_dict(), "digest": spec.digest(),
             "chunks": list(chunks), "n_chunks": n}, indent=1))

    def consolidated(self) -> bool:
        """Whether the store carries consolidated metadata (one read opens it)."""
        try:
            root = json.loads((self.path / "zarr.json").read_text())
        except (FileNotFoundError, ValueError):
            return False
        return bool(root.get("consolidated_metadata"))

    def _consolidate(self) -> None:
        """Write the store's metadata consolidated into its root ``zarr.json``, so that
        ``xarray.open_zarr(path)`` opens it in one read and without a warning. The arrays'
        metadata never change after creation (the chunks only fill them), so once is enough."""
        import warnings

        import zarr

        with warnings.catch_warnings():
            # the bookkeeping folder .study is not a Zarr node; and Zarr 3 notes that
            # consolidated metadata is its own extension of format 3 (which xarray reads)
            warnings.filterwarnings("ignore", message=r"Object at \.study is not recognized")
            warnings.filterwarnings("ignore", message="Consolidated metadata is currently not")
            zarr.consolidate_metadata(str(self.path))

    # -- chunks ---------------------------------------------------------------------------

    def done(self) -> set[int]:
        """Indices of the completed chunks."""
        if not self.done_dir.is_dir():
            return set()
        return {int(p.stem) for p in self.done_dir.glob("*.json")}

    def write_chunk(self, index: int, arrays: Mapping[str, np.ndarray]) -> None:
        """Write chunk ``index``'s output arrays into its region (idempotent)."""
        import zarr

        if self._group is None:
            self._group = zarr.open_group(str(self.path), mode="r+")
        if self._outputs is None:
            self._outputs = {v.name: v for v in get_kind(self.spec.kind).outputs(self.spec)}
        region = self.regions()[index]
        for name, var in self._outputs.items():
            a = np.asarray(arrays[name], dtype=var.dtype)
            expect = tuple(s.stop - s.start for s in region) + var.extra_shape
            if a.shape != expect:
                raise StudyStoreError(f"chunk {index}: {name} has shape {a.shape}, its region "
                                      f"needs {expect}")
            self._group[name][region] = a

    def mark_done(self, index: int, record: Mapping[str, Any]) -> None:
        """Record chunk ``index`` as complete (atomic; after its data)."""
        _atomic_write(self.done_dir / f"{index}.json", json.dumps(dict(record)))

    def records(self) -> list[dict[str, Any]]:
        """The completion records, in chunk order."""
        return [json.loads((self.done_dir / f"{i}.json").read_text())
                for i in sorted(self.done())]

    def open_dataset(self, load: bool = True):
        """The study's ``xarray.Dataset`` (loaded into memory unless ``load=False``)."""
        import warnings

        import xarray as xr

        if self.consolidated():
            ds = xr.open_zarr(str(self.path), consolidated=True)
        else:  # a store made before consolidated metadata, opened read-only
            with warnings.catch_warnings():  # the bookkeeping folder .study is not a Zarr node
                warnings.filterwarnings("ignore", message=r"Object at \.study is not recognized")
                ds = xr.open_zarr(str(self.path), consolidated=False)
        order = [v.name for v in get_kind(self.spec.kind).outputs(self.spec)]
        ds = ds[order]
        return ds.load() if load else ds


def _atomic_write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix="tmp-", suffix=".part")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
