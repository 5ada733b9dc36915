"""What a study spec is made of: the frozen :class:`StudySpec` and its parts, and the error of
a spec that cannot run.

These are the words that both the kinds (:mod:`convimpact.studies.study_kinds`: a kind names
its :class:`ParameterInfo`, evaluates a :class:`StudySpec`, raises :class:`StudySpecError`) and
the reading of a spec (:mod:`convimpact.studies.study_spec`: TOML or a mapping, validated
against its kind) speak; this module imports neither. Every name here is also importable from
:mod:`convimpact.studies.study_spec`.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ..errors import InputError

#: name of the sampling dimension
SAMPLE_DIM = "sample"
#: distributions of sampled parameters and their required arguments
DISTRIBUTIONS: Mapping[str, tuple[str, ...]] = MappingProxyType(
    {"uniform": ("low", "high"), "normal": ("mean", "std"), "loguniform": ("low", "high")})


class StudySpecError(InputError):
    """A study specification that cannot run (raised before any work starts)."""


@dataclass(frozen=True)
class ParameterInfo:
    """A parameter a kind accepts on a grid or in a sample.

    Attributes
    ----------
    name : the parameter's name (the dataset's dimension or sample coordinate).
    dtype : ``"float"``, ``"int"`` or ``"str"``.
    units : units written to the coordinate's attrs ("" when dimensionless).
    description : one line.
    low, high : inclusive bounds of numeric values (None: unbounded).
    choices : the allowed values of a ``"str"`` parameter.
    """

    name: str
    dtype: str = "float"
    units: str = ""
    description: str = ""
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] | None = None


@dataclass(frozen=True)
class GridAxis:
    """One grid dimension: its name, values (floats, ints or strings) and units."""

    name: str
    values: tuple
    units: str = ""

    @property
    def size(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class SampledParameter:
    """A parameter drawn per sample point: ``distribution`` with ``arguments`` (name, value)."""

    name: str
    distribution: str
    arguments: tuple[tuple[str, float], ...]
    units: str = ""


@dataclass(frozen=True)
class StudySpec:
    """A validated study: a kind, its options, a grid and/or a sample of parameters.

    Attributes
    ----------
    kind : the registered evaluator (:func:`convimpact.studies.study_kinds.get_kind`).
    title : what the study is (the dataset's ``title`` attr).
    options : the kind's fixed options, normalized by the kind.
    grid : the grid dimensions, in order.
    sample_size : number of sample points (0: no sample dimension).
    sampled : the parameters drawn per sample point.
    seed : seed of the sampled parameters.
    chunk_points : points per unit of work (None: the kind's default).
    """

    kind: str
    title: str = ""
    options: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    grid: tuple[GridAxis, ...] = ()
    sample_size: int = 0
    sampled: tuple[SampledParameter, ...] = ()
    seed: int = 0
    chunk_points: int | None = None

    @property
    def dims(self) -> tuple[str, ...]:
        """The study's dimensions: the grid's names, then ``sample`` when sampling."""
        return tuple(a.name for a in self.grid) + ((SAMPLE_DIM,) if self.sample_size else ())

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(a.size for a in self.grid) + ((self.sample_size,) if self.sample_size
                                                    else ())

    @property
    def n_points(self) -> int:
        return int(math.prod(self.shape))

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.grid) + tuple(p.name for p in self.sampled)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form; :func:`spec_from_dict` of it gives an equal spec."""
        study = {"kind": self.kind, "title": self.title, "seed": self.seed}
        if self.chunk_points is not None:
            study["chunk_points"] = self.chunk_points
        out: dict[str, Any] = {"study": study, "options": _plain(dict(self.options)),
                               "grid": {a.name: {"values": list(a.values), "units": a.units}
                                        for a in self.grid}}
        if self.sample_size:
            sample: dict[str, Any] = {"size": self.sample_size}
            for p in self.sampled:
                sample[p.name] = {"distribution": p.distribution, **dict(p.arguments),
                                  "units": p.units}
            out["sample"] = sample
        return out

    def digest(self) -> str:
        """SHA-256 of the canonical JSON form (identifies the study in a store)."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def sample_values(self) -> dict[str, np.ndarray]:
        """The sampled parameters' values (drawn in declaration order from ``seed``)."""
        rng = np.random.default_rng(self.seed)
        out = {}
        for p in self.sampled:
            a = dict(p.arguments)
            if p.distribution == "uniform":
                out[p.name] = rng.uniform(a["low"], a["high"], self.sample_size)
            elif p.distribution == "loguniform":
                out[p.name] = np.exp(rng.uniform(math.log(a["low"]), math.log(a["high"]),
                                                 self.sample_size))
            else:
                out[p.name] = rng.normal(a["mean"], a["std"], self.sample_size)
        return out


def _plain(v):
    if isinstance(v, Mapping):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v
