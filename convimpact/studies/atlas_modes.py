"""The failure modes of the atlas, the classification of one impact into them, and the map type.

:func:`classify_impact` judges one impact under one (law, method); :func:`classify_error` names the
mode of a typed error; :class:`AtlasMap` holds one map of the atlas. The modes and thresholds are
defined in :mod:`convimpact.studies.atlas`; the maps are built in
:mod:`convimpact.studies.atlas_impact_maps` and :mod:`convimpact.studies.atlas_simulation_maps`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..impact.errors import (
    ConvImpactError,
    LoopConstraintError,
    NonPositiveEffectiveMassError,
    NotSupportedError,
    SingularSystemError,
    SolverError,
)
from ..impact import solve_problem
from ..impact.problem import build_problem

IMPACT_MODES = ("energy_gain", "slip_reversal", "friction_pushes_slip",
                "non_positive_effective_mass", "singular_delassus", "singular_loop",
                "no_convergence", "not_supported", "unexpected_error")
SIMULATION_MODES = ("missed_impact", "smeared_impact", "compliant_stiff", "compliant_deep",
                    "zeno")
#: (law, method) pairs mapped by default
DEFAULT_PATHS = (("pereira-nikravesh", "closed-form"), ("pereira-nikravesh", "fast"),
                 ("pereira-nikravesh", "clarabel"), ("coulomb", "fast"),
                 ("coulomb", "clarabel"), ("ccp", "fast"), ("ccp", "clarabel"),
                 ("dissipative", "fast"), ("dissipative", "clarabel"), ("stronge", "fast"),
                 ("stronge", "clarabel"))
#: joint rates of the double pendulum tried in each cell (rad/s)
PENDULUM_RATES = ((1.0, 1.0), (1.0, -1.0), (-1.0, 2.0))


def _label(path: tuple[str, str] | str) -> str:
    return path if isinstance(path, str) else f"{path[0]}/{path[1]}"


@dataclass(frozen=True, eq=False)
class AtlasMap:
    """One map of the atlas.

    Attributes
    ----------
    name : short identifier (file names, JSON keys).
    title : what is mapped.
    x_name, y_name : axis names; x, y : axis values (the map has shape (len(y), len(x))).
    paths : labels of what is judged ("law/method" or a simulation scheme).
    modes : the failure modes this map can show.
    flags : ``flags[path][mode]`` boolean (ny, nx): the mode occurred in that cell.
    separating : (ny, nx) number of samples per cell whose contact does not approach.
    counts : ``counts[path][mode]`` number of individual samples with that mode.
    n_samples : samples judged per path (problems, or runs).
    values : named (ny, nx) float maps measured on the way (conditions, penetrations ...).
    fixed : the parameters held fixed or swept inside the cells.
    examples : ``examples[path][mode]`` the first error message met (for typed errors).
    wall_time : seconds spent building the map.
    samples : (ny, nx) number of samples judged per cell.
    """

    name: str
    title: str
    x_name: str
    y_name: str
    x: np.ndarray
    y: np.ndarray
    paths: tuple[str, ...]
    modes: tuple[str, ...]
    flags: Mapping[str, Mapping[str, np.ndarray]]
    separating: np.ndarray
    counts: Mapping[str, Mapping[str, int]]
    n_samples: int
    values: Mapping[str, np.ndarray] = field(default_factory=dict)
    fixed: Mapping[str, Any] = field(default_factory=dict)
    examples: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    wall_time: float = 0.0
    samples: np.ndarray | None = None

    @property
    def all_separating(self) -> np.ndarray:
        """(ny, nx) True where every sample of the cell separates (no impact to judge)."""
        n = self.samples if self.samples is not None else np.ones_like(self.separating)
        return (self.separating > 0) & (self.separating >= n)

    def region(self, path: str, mode: str) -> np.ndarray:
        """Boolean (ny, nx) map of one mode for one path."""
        return np.asarray(self.flags[path][mode], bool)

    def cells(self, path: str, mode: str) -> list[tuple[float, float]]:
        """(x, y) of the cells where ``mode`` occurred for ``path``."""
        iy, ix = np.nonzero(self.region(path, mode))
        return [(float(self.x[i]), float(self.y[j])) for j, i in zip(iy, ix)]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: axes, counts, regions as 0/1 lists (only modes that occurred)."""
        regions = {p: {m: np.asarray(a, int).tolist() for m, a in fl.items() if np.any(a)}
                   for p, fl in self.flags.items()}
        return {
            "name": self.name, "title": self.title, "x_name": self.x_name,
            "y_name": self.y_name, "x": np.asarray(self.x).tolist(),
            "y": np.asarray(self.y).tolist(), "paths": list(self.paths),
            "modes": list(self.modes), "n_samples": self.n_samples,
            "counts": {p: dict(c) for p, c in self.counts.items()},
            "separating_cells": int(np.sum(self.all_separating)),
            "regions": regions,
            "values": {k: [[float(x) if math.isfinite(x) else None for x in row]
                           for row in np.asarray(v, float)] for k, v in self.values.items()},
            "fixed": dict(self.fixed), "examples": {p: dict(e) for p, e in
                                                    self.examples.items()},
            "wall_time": self.wall_time,
        }


def classify_error(exc: BaseException) -> str:
    """The failure mode of an exception raised by an impact solve."""
    if isinstance(exc, NonPositiveEffectiveMassError):
        return "non_positive_effective_mass"
    if isinstance(exc, SingularSystemError):
        return "singular_delassus"
    if isinstance(exc, LoopConstraintError):
        return "singular_loop"
    if isinstance(exc, SolverError):
        return "no_convergence"
    if isinstance(exc, NotSupportedError):
        return "not_supported"
    return "unexpected_error"


def classify_impact(M, Jc, dq, e, mu, C=None, law: str = "pereira-nikravesh",
                    method: str = "auto", **options) -> tuple[str, ...]:
    """Failure modes of one impact under one law and method.

    Returns
    -------
    tuple of str
        ``("separating",)`` when no contact approaches, otherwise the modes of
        :data:`IMPACT_MODES` met (empty: the law answered cleanly).
    """
    return _classify(lambda: build_problem(M, Jc, dq, e, mu, C), [(law, method)],
                     options)[_label((law, method))][0]


def _classify(make_problem: Callable[[], Any], paths, options=None):
    """{path label: (modes, message)} for one problem under every path."""
    options = options or {}
    out = {}
    try:
        problem = make_problem()
    except Exception as exc:  # the problem itself is ill-posed: every path meets it
        mode = classify_error(exc) if isinstance(exc, ConvImpactError) else "unexpected_error"
        return {_label(p): ((mode,), f"{type(exc).__name__}: {exc}") for p in paths}
    if not np.any(problem.v_minus[:, 0] < 0.0):
        return {_label(p): (("separating",), "") for p in paths}
    for law, method in paths:
        try:
            r = solve_problem(problem, law, method, **options)
        except Exception as exc:
            mode = (classify_error(exc) if isinstance(exc, ConvImpactError)
                    else "unexpected_error")
            out[_label((law, method))] = ((mode,), f"{type(exc).__name__}: {exc}")
            continue
        d = r.diagnostics
        modes = tuple(m for m, flag in (("energy_gain", d.energy_gained),
                                        ("slip_reversal", d.slip_reversal),
                                        ("friction_pushes_slip", d.friction_pushes_slip))
                      if flag)
        out[_label((law, method))] = (modes, "")
    return out


class _MapBuilder:
    """Accumulates flags, counts and examples cell by cell."""

    def __init__(self, paths: Sequence[str], modes: Sequence[str], shape: tuple[int, int]):
        self.paths, self.modes, self.shape = tuple(paths), tuple(modes), shape
        self.flags = {p: {m: np.zeros(shape, bool) for m in modes} for p in self.paths}
        self.counts = {p: {m: 0 for m in modes} for p in self.paths}
        self.examples: dict[str, dict[str, str]] = {p: {} for p in self.paths}
        self.separating = np.zeros(shape, int)
        self.samples = np.zeros(shape, int)
        self.n = 0

    def add(self, iy: int, ix: int, judged: Mapping[str, tuple[tuple[str, ...], str]]):
        self.n += 1
        self.samples[iy, ix] += 1
        sep = False
        for p, (modes, msg) in judged.items():
            for m in modes:
                if m == "separating":
                    sep = True
                    continue
                self.flags[p][m][iy, ix] = True
                self.counts[p][m] += 1
                if msg and m not in self.examples[p]:
                    self.examples[p][m] = msg[:300]
        if sep:
            self.separating[iy, ix] += 1

    def build(self, name, title, x_name, y_name, x, y, values, fixed, t0) -> AtlasMap:
        return AtlasMap(name, title, x_name, y_name, np.asarray(x, float), np.asarray(y, float),
                        self.paths, self.modes, self.flags, self.separating, self.counts,
                        self.n, values, fixed, self.examples, time.perf_counter() - t0,
                        self.samples)
