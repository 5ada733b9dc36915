"""The evaluators a study can run (*kinds*), each declaring its parameters and output variables.

A kind is a :class:`StudyKind`: it normalizes its fixed options (:meth:`StudyKind.check_options`),
names the parameters a grid or a sample may sweep (:meth:`StudyKind.parameters`), declares the
output variables of the dataset with their extra dimensions, dtypes and units
(:meth:`StudyKind.outputs`), and evaluates one chunk of points (:meth:`StudyKind.evaluate`).
Built-in kinds:

* ``impacts`` (:mod:`convimpact.studies.study_impacts`): single-contact impacts of a scene's
  mechanism through the compiled batch (:func:`convimpact.impact.batch.impacts.resolve_impacts`);
* ``simulation`` (:mod:`convimpact.studies.study_simulations`): an ensemble of event-driven runs
  of a scene over its parameters, summarized per run;
* ``atlas-map`` (:mod:`convimpact.studies.atlas_study`): one map of the failure atlas.

:func:`register_kind` adds one; :func:`get_kind` looks one up by name (importing the built-in
modules on first use, in worker processes too).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from .study_types import ParameterInfo, StudySpec, StudySpecError

#: modules defining the built-in kinds (imported by :func:`get_kind`)
BUILTIN_KIND_MODULES = ("convimpact.studies.study_impacts",
                        "convimpact.studies.study_simulations",
                        "convimpact.studies.atlas_study")

_KINDS: dict[str, "StudyKind"] = {}


@dataclass(frozen=True)
class OutputVariable:
    """One output variable of a kind.

    Attributes
    ----------
    name : the dataset variable's name.
    dtype : numpy dtype name ("float64", "int8", "int32", "bool").
    units : the ``units`` attr ("" when dimensionless or a code).
    description : the ``long_name`` attr.
    extra_dims : (dimension, coordinate values) after the study's dimensions, e.g.
        ``(("contact_axis", ("n", "t")),)``.
    """

    name: str
    dtype: str = "float64"
    units: str = ""
    description: str = ""
    extra_dims: tuple[tuple[str, tuple], ...] = ()

    @property
    def extra_shape(self) -> tuple[int, ...]:
        return tuple(len(v) for _, v in self.extra_dims)

    @property
    def fill_value(self):
        """The value of points not computed yet: NaN for floats, 0 or False otherwise."""
        dt = np.dtype(self.dtype)
        return np.nan if dt.kind == "f" else dt.type(0)


@dataclass(frozen=True)
class ChunkOutput:
    """What :meth:`StudyKind.evaluate` returns: the output arrays of the chunk (shape: the
    chunk's shape, then each variable's extra dimensions) and JSON-ready ``meta`` kept in the
    chunk's completion record (e.g. the first error message met)."""

    arrays: Mapping[str, np.ndarray]
    meta: Mapping[str, Any]


class StudyKind:
    """Base of the study kinds (see the module docstring). Subclasses set ``name``,
    ``description``, ``default_chunk_points`` and override the methods below."""

    name: str = ""
    description: str = ""
    #: points per chunk when the spec gives none (chosen so a chunk takes about a second or
    #: more: the runner's scheduling overhead stays under 5 %, see ``convimpact bench``)
    default_chunk_points: int = 1000

    def check_options(self, options: dict[str, Any], source: str) -> dict[str, Any]:
        """Validate and normalize the fixed options (JSON-ready values); raise
        :class:`StudySpecError` naming a bad one."""
        if options:
            raise StudySpecError(f"{source}: kind {self.name!r} takes no options, got "
                                 f"{', '.join(options)}")
        return options

    def parameters(self, options: Mapping[str, Any]) -> dict[str, ParameterInfo]:
        """The parameters a grid or a sample may sweep, by name."""
        raise NotImplementedError

    def check_spec(self, spec: StudySpec, source: str) -> None:
        """Checks across the whole spec (after every entry passed its own)."""

    def outputs(self, spec: StudySpec) -> tuple[OutputVariable, ...]:
        """The output variables (their names, dtypes, units and extra dimensions)."""
        raise NotImplementedError

    def evaluate(self, spec: StudySpec, points: Mapping[str, np.ndarray]) -> ChunkOutput:
        """Evaluate one chunk: ``points[name]`` holds each swept parameter over the chunk
        (every array has the chunk's shape)."""
        raise NotImplementedError

    def dataset_attrs(self, spec: StudySpec) -> dict[str, Any]:
        """Extra global attrs of the dataset (JSON-ready)."""
        return {}


def register_kind(kind: StudyKind) -> StudyKind:
    """Register a kind under ``kind.name`` (replacing one of the same name)."""
    if not kind.name:
        raise ValueError("a study kind needs a name")
    _KINDS[kind.name] = kind
    return kind


def _load_builtin() -> None:
    for module in BUILTIN_KIND_MODULES:
        importlib.import_module(module)


def kind_names() -> list[str]:
    """The registered kinds."""
    _load_builtin()
    return sorted(_KINDS)


def get_kind(name: str) -> StudyKind:
    """The kind registered as ``name``; :class:`StudySpecError` naming the known ones."""
    _load_builtin()
    if name not in _KINDS:
        raise StudySpecError(f"unknown study kind {name!r}; choose from "
                             f"{', '.join(sorted(_KINDS))}")
    return _KINDS[name]


def scene_options(options: dict[str, Any], source: str, kind: str) -> tuple[str, dict]:
    """Pop and check ``scene`` (a name in ``convimpact.problems``) and ``scene_parameters``
    (a table of its ``make_scene`` arguments); the scene is built once to check them."""
    from ..errors import ConvImpactError

    name = options.pop("scene", None)
    if not isinstance(name, str):
        raise StudySpecError(f"{source}: kind {kind!r} needs options.scene = \"<scene name>\" "
                             f"(a string), got {name!r}")
    params = options.pop("scene_parameters", {})
    if not isinstance(params, Mapping):
        raise StudySpecError(f"{source}: options.scene_parameters must be a table")
    params = dict(params)
    try:
        cached_scene(name, freeze_parameters(params))
    except ConvImpactError as exc:
        raise StudySpecError(f"{source}: options.scene: {exc}") from None
    return name, params


def freeze_parameters(params: Mapping[str, Any]) -> tuple:
    """Hashable form of scene parameters: sorted (name, value) pairs, lists as tuples."""
    return tuple(sorted((k, tuple(v) if isinstance(v, list) else v)
                        for k, v in params.items()))


_SCENES: dict[tuple, Any] = {}


def cached_scene(name: str, frozen_params: tuple):
    """``load_scene(name, **params)`` built once per process (``frozen_params`` from sorted
    (name, value) pairs)."""
    key = (name, frozen_params)
    if key not in _SCENES:
        from ..scenes import load_scene

        _SCENES[key] = load_scene(name, **{k: list(v) if isinstance(v, tuple) else v
                                           for k, v in frozen_params})
    return _SCENES[key]


def scene_of(options: Mapping[str, Any]):
    """The scene named by normalized options (``scene``, ``scene_parameters``)."""
    return cached_scene(options["scene"], freeze_parameters(options.get("scene_parameters", {})))
