"""The failure atlas as studies: each map of :func:`convimpact.studies.atlas.failure_atlas` run
through the study runner (local processes or a Dask cluster) and read back as an
:class:`~convimpact.studies.atlas_modes.AtlasMap`.

Study kind ``atlas-map``: options ``map`` (a name of :data:`ATLAS_MAPS`) and ``fixed`` (the
map builder's other arguments, JSON-ready); the grid has the map's two axes, the builder's
outer loop first, so a chunk is a block of the builder's rows and the first error message of
each mode is the one a serial build meets first. Outputs: ``flags`` (bool; dimensions
``path``, ``mode`` after the axes), ``separating`` and ``samples`` (per cell), one
``value_<name>`` per measured map; the counts of each mode and the examples are kept in each
chunk's record and summed in chunk order by :func:`atlas_map_from_store`.

:func:`atlas_specs` gives the specs of the whole atlas (quick or full grids, as
:func:`~convimpact.studies.atlas.failure_atlas`); :func:`run_atlas` runs them and returns the
maps, equal (but for ``wall_time``) to a serial build.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from .atlas_impact_maps import pendulum_angle_map, pendulum_friction_map, slider_crank_map
from .atlas_modes import DEFAULT_PATHS, IMPACT_MODES, SIMULATION_MODES, AtlasMap, _label
from .atlas_simulation_maps import pendulum_drop_map, rod_zeno_map
from .study_kinds import ChunkOutput, OutputVariable, StudyKind, register_kind
from .study_spec import ParameterInfo, StudySpec, StudySpecError, spec_from_dict

_SIM_PATHS = ("event-driven", "moreau-jean", "compliant")


@dataclass(frozen=True)
class AtlasMapDefinition:
    """How one atlas map runs as a study: its builder, its x and y arguments, which of them
    the builder loops over outside (``outer``), its paths and modes (None: from the
    ``paths`` argument, the impact modes) and the names of its measured value maps."""

    builder: Callable[..., AtlasMap]
    x: str
    y: str
    outer: str
    paths: tuple[str, ...] | None
    modes: tuple[str, ...]
    values: tuple[str, ...]


#: the atlas maps by name
ATLAS_MAPS: Mapping[str, AtlasMapDefinition] = {
    "pendulum_angles": AtlasMapDefinition(pendulum_angle_map, "theta1", "theta2", "y", None,
                                          IMPACT_MODES, ("delassus_condition",)),
    "pendulum_friction": AtlasMapDefinition(pendulum_friction_map, "theta2", "mu", "x", None,
                                            IMPACT_MODES, ()),
    "slider_crank_scene": AtlasMapDefinition(slider_crank_map, "crank_angle", "mu", "x",
                                             None, IMPACT_MODES, ("loop_condition",)),
    "slider_crank_isosceles": AtlasMapDefinition(slider_crank_map, "crank_angle", "mu", "x",
                                                 None, IMPACT_MODES, ("loop_condition",)),
    "pendulum_drop": AtlasMapDefinition(
        pendulum_drop_map, "theta1", "theta2", "y", _SIM_PATHS, SIMULATION_MODES,
        ("feasible", "event_driven_impacts", "moreau_velocity_error", "compliant_step_ratio",
         "compliant_penetration")),
    "rod_zeno": AtlasMapDefinition(rod_zeno_map, "tilt_deg", "e", "y", ("event-driven",),
                                   ("zeno",), ("accumulation_time", "impacts")),
}


def _axes_order(d: AtlasMapDefinition) -> tuple[str, str]:
    return (d.y, d.x) if d.outer == "y" else (d.x, d.y)


def _paths(d: AtlasMapDefinition, fixed: Mapping[str, Any]) -> tuple[str, ...]:
    if d.paths is not None:
        return d.paths
    return tuple(_label(tuple(p)) for p in fixed.get("paths", DEFAULT_PATHS))


def _builder_kwargs(fixed: Mapping[str, Any]) -> dict[str, Any]:
    kw = dict(fixed)
    if "paths" in kw:
        kw["paths"] = tuple(tuple(p) for p in kw["paths"])
    if "rates" in kw:
        kw["rates"] = tuple(tuple(r) for r in kw["rates"])
    return kw


class AtlasMapKind(StudyKind):
    """One map of the failure atlas (see the module docstring)."""

    name = "atlas-map"
    description = "one map of the failure atlas (laws, methods, simulation schemes)"
    default_chunk_points = 1

    def check_options(self, options: dict[str, Any], source: str) -> dict[str, Any]:
        options = dict(options)
        name = options.pop("map", None)
        if name not in ATLAS_MAPS:
            raise StudySpecError(f"{source}: options.map must be one of "
                                 f"{', '.join(ATLAS_MAPS)}, got {name!r}")
        fixed = options.pop("fixed", {})
        if not isinstance(fixed, Mapping):
            raise StudySpecError(f"{source}: options.fixed must be a table")
        if options:
            raise StudySpecError(f"{source}: unknown option(s) {', '.join(options)} for kind "
                                 "'atlas-map'; its options: map, fixed")
        return {"map": name, "fixed": dict(fixed)}

    def parameters(self, options: Mapping[str, Any]) -> dict[str, ParameterInfo]:
        d = ATLAS_MAPS[options["map"]]
        return {d.x: ParameterInfo(d.x), d.y: ParameterInfo(d.y)}

    def check_spec(self, spec: StudySpec, source: str) -> None:
        d = ATLAS_MAPS[spec.options["map"]]
        if spec.dims != _axes_order(d):
            raise StudySpecError(f"{source}: map {spec.options['map']!r} needs the grid "
                                 f"{' x '.join(_axes_order(d))} in this order")

    def outputs(self, spec: StudySpec) -> tuple[OutputVariable, ...]:
        d = ATLAS_MAPS[spec.options["map"]]
        extra = (("path", _paths(d, spec.options["fixed"])), ("mode", d.modes))
        return ((OutputVariable("flags", "bool", "", "failure mode met in the cell", extra),
                 OutputVariable("separating", "int32", "", "samples whose contact separates"),
                 OutputVariable("samples", "int32", "", "samples judged in the cell"))
                + tuple(OutputVariable(f"value_{v}", "float64", "", v.replace("_", " "))
                        for v in d.values))

    def evaluate(self, spec: StudySpec, points: Mapping[str, np.ndarray]) -> ChunkOutput:
        d = ATLAS_MAPS[spec.options["map"]]
        first, second = _axes_order(d)
        kw = _builder_kwargs(spec.options["fixed"])
        kw[first] = np.asarray(points[first][:, 0], float)
        kw[second] = np.asarray(points[second][0, :], float)
        m = d.builder(**kw)

        def lay(a):  # (ny, nx) -> (outer, inner)
            a = np.asarray(a)
            return a if d.outer == "y" else a.T

        paths = _paths(d, spec.options["fixed"])
        flags = np.stack([np.stack([lay(m.flags[p][mode]) for mode in d.modes], -1)
                          for p in paths], -2)
        arrays = {"flags": flags, "separating": lay(m.separating),
                  "samples": lay(m.samples)}
        for v in d.values:
            arrays[f"value_{v}"] = lay(np.asarray(m.values[v], float))
        meta = {"counts": {p: dict(c) for p, c in m.counts.items()}, "n_samples": m.n_samples,
                "examples": {p: dict(e) for p, e in m.examples.items()},
                "name": m.name, "title": m.title, "x_name": m.x_name, "y_name": m.y_name,
                "fixed": _json_ready(m.fixed)}
        return ChunkOutput(arrays, meta)


def _json_ready(v):
    if isinstance(v, dict):
        return {k: _json_ready(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_ready(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


register_kind(AtlasMapKind())


def atlas_specs(quick: bool = False) -> list[StudySpec]:
    """The studies of the whole atlas, with the grids of
    :func:`~convimpact.studies.atlas.failure_atlas` (``quick``: coarse)."""
    n = 9 if quick else 37
    pi = float(np.pi)
    paths = [list(p) for p in DEFAULT_PATHS]

    def lin(a, b, k):
        return {"values": [float(x) for x in np.linspace(a, b, k)]}

    crank = 13 if quick else 73
    maps = [
        ("pendulum_angles", {"theta2": lin(-pi, pi, n), "theta1": lin(-pi, 0.0, n)},
         {"mu": [0.3, 0.8] if quick else [0.2, 0.5, 0.8, 1.2], "paths": paths}),
        ("pendulum_friction", {"theta2": lin(-pi, pi, n),
                               "mu": lin(0.0, 1.5, 7 if quick else 16)},
         {"e": [0.5] if quick else [0.0, 0.5, 1.0], "paths": paths}),
    ]
    for geometry in ("scene", "isosceles"):
        maps.append((f"slider_crank_{geometry}",
                     {"crank_angle": lin(-pi, pi, crank), "mu": lin(0.0, 1.0, 3 if quick else 6)},
                     {"e": [0.83] if quick else [0.0, 0.5, 0.83, 1.0], "geometry": geometry,
                      "paths": paths}))
    k = 2 if quick else 6
    drop = [float(x) for x in np.radians(np.linspace(-45.0, 45.0, k))]
    maps.append(("pendulum_drop", {"theta2": {"values": drop}, "theta1": {"values": drop}},
                 {"t_end": 0.7 if quick else 1.2, "h": 2e-3 if quick else 1e-3}))
    maps.append(("rod_zeno", {"e": {"values": [0.2, 0.8] if quick else
                                    [float(x) for x in np.linspace(0.1, 0.9, 5)]},
                              "tilt_deg": lin(0.0, 60.0, 2 if quick else 5)},
                 {"t_end": 1.0 if quick else 1.5}))
    specs = []
    for name, grid, fixed in maps:
        inner = list(grid.values())[1]["values"]
        specs.append(spec_from_dict({
            "study": {"kind": "atlas-map", "title": f"failure atlas: {name}",
                      "chunk_points": len(inner)},
            "options": {"map": name, "fixed": fixed}, "grid": grid}, source=f"atlas {name}"))
    return specs


def atlas_map_from_store(store) -> AtlasMap:
    """The :class:`AtlasMap` held by a complete ``atlas-map`` study store."""
    spec = store.spec
    d = ATLAS_MAPS[spec.options["map"]]
    ds = store.open_dataset()
    records = store.records()
    paths = _paths(d, spec.options["fixed"])

    def lay(a):  # (outer, inner) -> (ny, nx)
        a = np.asarray(a)
        return a if d.outer == "y" else a.T

    flags = {p: {mode: lay(ds["flags"].values[:, :, i, j]) for j, mode in enumerate(d.modes)}
             for i, p in enumerate(paths)}
    counts = {p: {mode: 0 for mode in d.modes} for p in paths}
    examples: dict[str, dict[str, str]] = {p: {} for p in paths}
    for r in records:
        for p, c in r["meta"]["counts"].items():
            for mode, k in c.items():
                counts[p][mode] += int(k)
        for p, ex in r["meta"]["examples"].items():
            for mode, msg in ex.items():
                examples[p].setdefault(mode, msg)
    first = records[0]["meta"]
    values = {v: lay(ds[f"value_{v}"].values) for v in d.values}
    return AtlasMap(first["name"], first["title"], first["x_name"], first["y_name"],
                    np.asarray(ds[d.x].values, float), np.asarray(ds[d.y].values, float),
                    paths, d.modes, flags, lay(ds["separating"].values.astype(int)), counts,
                    sum(int(r["meta"]["n_samples"]) for r in records), values, first["fixed"],
                    examples, sum(r["compute_seconds"] for r in records),
                    lay(ds["samples"].values.astype(int)))


def run_atlas(out: str | Path, quick: bool = False, executor=None, *, workers: int | None = None,
              scheduler: str | None = None, client=None,
              progress: bool | None = None) -> list[AtlasMap]:
    """Run every map of the atlas as a study into ``out/stores/<map>.zarr`` (resuming any
    finished chunks) and return the maps in the order of
    :func:`~convimpact.studies.atlas.failure_atlas`."""
    from .executors import Executor, make_executor
    from .study import run_study
    from .study_store import StudyStore

    own = not isinstance(executor, Executor)
    ex = (make_executor(executor if isinstance(executor, str) else None, workers, scheduler,
                        client) if own else executor)
    maps = []
    try:
        for spec in atlas_specs(quick):
            path = Path(out) / "stores" / f"{spec.options['map']}.zarr"
            run_study(spec, path, ex, progress=progress, load=False)
            maps.append(atlas_map_from_store(StudyStore(path)))
    finally:
        if own:
            ex.close()
    return maps
