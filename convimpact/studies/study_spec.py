"""The specification of a study: which evaluator (*kind*), over which grid or sample of parameters.

A study spec is a frozen :class:`StudySpec`, read from TOML (:func:`load_spec`) or a mapping
(:func:`spec_from_dict`) and validated in full against its kind
(:mod:`convimpact.studies.study_kinds`) before any work starts: an unknown kind, option or
parameter, an empty range, a value of the wrong type or outside its bounds raise
:class:`StudySpecError` naming the entry. The spec's types (:class:`StudySpec`,
:class:`GridAxis`, :class:`SampledParameter`, :class:`ParameterInfo`, :class:`StudySpecError`,
``SAMPLE_DIM``, ``DISTRIBUTIONS``) are defined in :mod:`convimpact.studies.study_types`, which
the kinds import too, and handed on from here.

TOML layout::

    [study]
    kind = "impacts"              # a registered kind (convimpact.studies.study_kinds)
    title = "double pendulum: impact laws over the configurations"
    seed = 7                      # seeds the sampled parameters (default 0)
    chunk_points = 50000          # points per unit of work (default: the kind's)

    [options]                     # the kind's fixed options
    scene = "pendulum_planar"

    [grid]                        # one dimension per entry, in this order
    theta1 = { start = -3.14159, stop = 0.0, num = 200, units = "rad" }   # linspace
    law = { values = ["coulomb", "ccp"] }                                  # explicit values

    [sample]                      # optional: one dimension "sample" of `size` random points
    size = 1000
    mu = { distribution = "uniform", low = 0.0, high = 1.0 }
    e = { distribution = "normal", mean = 0.5, std = 0.05 }

The dataset's dimensions are the grid's names in order, then ``sample`` when sampling.
Sampled values are drawn once from ``numpy.random.default_rng(seed)`` in declaration order
(they do not depend on the chunking or the executor) and become coordinates along ``sample``.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from .study_kinds import get_kind
from .study_types import (  # noqa: F401
    DISTRIBUTIONS, SAMPLE_DIM, GridAxis, ParameterInfo, SampledParameter, StudySpec,
    StudySpecError,
)

#: largest number of points of one study (the grid's product times the sample size)
MAX_POINTS = 10**10


def load_spec(path: str | Path) -> StudySpec:
    """Read and validate a TOML study spec (see the module docstring)."""
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise StudySpecError(f"no study spec at {str(p)!r}") from None
    except tomllib.TOMLDecodeError as exc:
        raise StudySpecError(f"{p}: not valid TOML: {exc}") from None
    return spec_from_dict(data, source=str(p))


def spec_from_dict(data: Mapping[str, Any], source: str = "spec") -> StudySpec:
    """Validate a spec given as a mapping (the TOML layout) and return it frozen."""
    if not isinstance(data, Mapping):
        raise StudySpecError(f"{source}: a study spec is a table, got {type(data).__name__}")
    _only(data, ("study", "options", "grid", "sample"), f"{source}: top-level table")
    study = _table(data, "study", source, required=True)
    _only(study, ("kind", "title", "seed", "chunk_points"), f"{source}: [study]")
    if "kind" not in study:
        raise StudySpecError(f"{source}: [study] needs kind = \"...\"")
    kind = get_kind(_string(study["kind"], f"{source}: [study] kind"))
    title = _string(study.get("title", ""), f"{source}: [study] title")
    seed = _integer(study.get("seed", 0), f"{source}: [study] seed", low=0)
    chunk = study.get("chunk_points")
    chunk = None if chunk is None else _integer(chunk, f"{source}: [study] chunk_points", low=1)
    options = kind.check_options(dict(_table(data, "options", source)), source)
    known = kind.parameters(options)
    grid = tuple(_axis(name, entry, known, kind.name, source)
                 for name, entry in _table(data, "grid", source).items())
    sample = dict(_table(data, "sample", source))
    size = _integer(sample.pop("size", 0), f"{source}: [sample] size", low=0)
    sampled = tuple(_sampled(name, entry, known, kind.name, source)
                    for name, entry in sample.items())
    if sampled and size == 0:
        raise StudySpecError(f"{source}: [sample] draws {', '.join(p.name for p in sampled)} "
                             "but size is 0; give size = N > 0")
    if size and not sampled:
        raise StudySpecError(f"{source}: [sample] size = {size} but no parameter is sampled")
    names = [a.name for a in grid] + [p.name for p in sampled]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise StudySpecError(f"{source}: parameter(s) {', '.join(dup)} both on the grid and "
                             "sampled; choose one")
    if SAMPLE_DIM in names:
        raise StudySpecError(f"{source}: {SAMPLE_DIM!r} is the sampling dimension's name")
    if not grid and not size:
        raise StudySpecError(f"{source}: nothing to sweep: give a [grid] or a [sample]")
    spec = StudySpec(kind.name, title, MappingProxyType(options), grid, size, sampled, seed,
                     chunk)
    if spec.n_points > MAX_POINTS:
        raise StudySpecError(f"{source}: {spec.n_points:.3g} points exceed {MAX_POINTS:.0e}; "
                             "split the study")
    drawn = spec.sample_values()
    for p in sampled:
        info, v = known[p.name], drawn[p.name]
        if (info.low is not None and v.min() < info.low
                or info.high is not None and v.max() > info.high):
            raise StudySpecError(f"{source}: [sample] {p.name} draws values in "
                                 f"[{v.min():.6g}, {v.max():.6g}], outside its bounds "
                                 f"[{info.low}, {info.high}]; narrow the distribution")
    kind.check_spec(spec, source)
    return spec


def _only(table: Mapping[str, Any], allowed: tuple[str, ...], where: str) -> None:
    unknown = [k for k in table if k not in allowed]
    if unknown:
        raise StudySpecError(f"{where} has unknown key(s) {', '.join(map(repr, unknown))}; "
                             f"allowed: {', '.join(allowed)}")


def _table(data: Mapping[str, Any], key: str, source: str,
           required: bool = False) -> Mapping[str, Any]:
    if key not in data:
        if required:
            raise StudySpecError(f"{source}: missing [{key}] table")
        return {}
    v = data[key]
    if not isinstance(v, Mapping):
        raise StudySpecError(f"{source}: [{key}] must be a table, got {type(v).__name__}")
    return v


def _string(v, where: str) -> str:
    if not isinstance(v, str):
        raise StudySpecError(f"{where} must be a string, got {type(v).__name__} {v!r}")
    return v


def _integer(v, where: str, low: int | None = None) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise StudySpecError(f"{where} must be an integer, got {type(v).__name__} {v!r}")
    if low is not None and v < low:
        raise StudySpecError(f"{where} must be >= {low}, got {v}")
    return int(v)


def _real(v, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise StudySpecError(f"{where} must be a number, got {type(v).__name__} {v!r}")
    f = float(v)
    if not math.isfinite(f):
        raise StudySpecError(f"{where} must be finite, got {v!r}")
    return f


def _known(name: str, known: Mapping[str, ParameterInfo], kind: str,
           source: str) -> ParameterInfo:
    if name not in known:
        raise StudySpecError(f"{source}: unknown parameter {name!r} for kind {kind!r}; its "
                             f"parameters: {', '.join(known) or 'none'}")
    return known[name]


def check_value(info: ParameterInfo, v, where: str):
    """One value of a parameter, type- and bound-checked (a float, an int or a string)."""
    if info.dtype == "str":
        s = _string(v, where)
        if info.choices is not None and s not in info.choices:
            raise StudySpecError(f"{where}: {s!r} is not one of {', '.join(info.choices)}")
        return s
    x = _integer(v, where) if info.dtype == "int" else _real(v, where)
    if info.low is not None and x < info.low or info.high is not None and x > info.high:
        raise StudySpecError(f"{where} = {x!r} is outside [{info.low}, {info.high}]")
    return x


def _axis(name: str, entry, known, kind: str, source: str) -> GridAxis:
    info = _known(name, known, kind, source)
    where = f"{source}: [grid] {name}"
    if not isinstance(entry, Mapping):
        raise StudySpecError(f"{where} must be a table {{values = [...]}} or {{start, stop, "
                             f"num}}, got {type(entry).__name__} {entry!r}")
    entry = dict(entry)
    units = _string(entry.pop("units", info.units), f"{where} units")
    if "values" in entry:
        _only(entry, ("values",), where)
        vals = entry["values"]
        if not isinstance(vals, (list, tuple)):
            raise StudySpecError(f"{where} values must be a list, got {type(vals).__name__}")
        values = tuple(check_value(info, v, f"{where} values[{i}]") for i, v in enumerate(vals))
    else:
        _only(entry, ("start", "stop", "num", "scale"), where)
        missing = [k for k in ("start", "stop", "num") if k not in entry]
        if missing:
            raise StudySpecError(f"{where} needs values = [...] or start, stop, num (missing "
                                 f"{', '.join(missing)})")
        if info.dtype != "float":
            raise StudySpecError(f"{where}: a {info.dtype} parameter takes values = [...]")
        a, b = _real(entry["start"], f"{where} start"), _real(entry["stop"], f"{where} stop")
        num = _integer(entry["num"], f"{where} num")
        scale = _string(entry.get("scale", "linear"), f"{where} scale")
        if scale not in ("linear", "log"):
            raise StudySpecError(f"{where} scale must be 'linear' or 'log', got {scale!r}")
        if num < 1:
            raise StudySpecError(f"{where} is an empty range (num = {num}); give num >= 1")
        if scale == "log" and (a <= 0 or b <= 0):
            raise StudySpecError(f"{where}: a log scale needs start, stop > 0")
        arr = np.geomspace(a, b, num) if scale == "log" else np.linspace(a, b, num)
        values = tuple(check_value(info, float(x), f"{where} point {i}")
                       for i, x in enumerate(arr))
    if not values:
        raise StudySpecError(f"{where} is empty; give at least one value")
    if len(set(values)) != len(values):
        raise StudySpecError(f"{where} repeats a value; the values of a dimension are distinct")
    return GridAxis(name, values, units)


def _sampled(name: str, entry, known, kind: str, source: str) -> SampledParameter:
    info = _known(name, known, kind, source)
    where = f"{source}: [sample] {name}"
    if info.dtype != "float":
        raise StudySpecError(f"{where}: only float parameters can be sampled ({name} is "
                             f"{info.dtype}); put it on the grid")
    if not isinstance(entry, Mapping):
        raise StudySpecError(f"{where} must be a table {{distribution = ..., ...}}")
    entry = dict(entry)
    units = _string(entry.pop("units", info.units), f"{where} units")
    dist = _string(entry.pop("distribution", ""), f"{where} distribution")
    if dist not in DISTRIBUTIONS:
        raise StudySpecError(f"{where} distribution must be one of "
                             f"{', '.join(DISTRIBUTIONS)}, got {dist!r}")
    _only(entry, DISTRIBUTIONS[dist], where)
    args = {}
    for k in DISTRIBUTIONS[dist]:
        if k not in entry:
            raise StudySpecError(f"{where}: {dist} needs {', '.join(DISTRIBUTIONS[dist])}")
        args[k] = _real(entry[k], f"{where} {k}")
    if dist in ("uniform", "loguniform"):
        if not args["low"] < args["high"]:
            raise StudySpecError(f"{where} is an empty range: low < high is needed")
        if dist == "loguniform" and args["low"] <= 0:
            raise StudySpecError(f"{where}: loguniform needs low > 0")
        check_value(info, args["low"], f"{where} low")
        check_value(info, args["high"], f"{where} high")
    elif args["std"] < 0:
        raise StudySpecError(f"{where}: std must be >= 0")
    return SampledParameter(name, dist, tuple(args.items()), units)
