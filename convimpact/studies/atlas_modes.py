"""The failure modes of the atlas, the classification of one impact into them, and the map type.

:func:`classify_impact` judges one impact under one (law, method); :func:`classify_error` names the
mode of a typed error; :class:`AtlasMap` holds one map of the atlas. A map judges all its samples
at once (:func:`_classify_samples`): the ``"fast"`` paths on open-loop single-contact samples go
through one compiled batch per path (:func:`convimpact.impact.batch.impacts.resolve_impacts`, same
answers as one ``resolve_impact(..., method="fast")`` per sample), the other paths per sample.
The modes and thresholds are defined in :mod:`convimpact.studies.atlas`; the maps are built in
:mod:`convimpact.studies.atlas_impact_maps` and :mod:`convimpact.studies.atlas_simulation_maps`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..errors import (
    ConvImpactError,
    LoopConstraintError,
    NonPositiveEffectiveMassError,
    NotSupportedError,
    SingularSystemError,
    SolverError,
)
from ..impact import solve_problem
from ..impact.problem.build import build_problem

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
                 ("stronge", "clarabel"), ("chatterjee-ruina", "fast"),
                 ("chatterjee-ruina", "clarabel"))
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


def _error_judgment(exc: BaseException) -> tuple[tuple[str, ...], str]:
    """(modes, message) of an exception met while posing or solving an impact."""
    mode = classify_error(exc) if isinstance(exc, ConvImpactError) else "unexpected_error"
    return (mode,), f"{type(exc).__name__}: {exc}"


def _prepare(make_problem: Callable[[], Any], paths):
    """(problem, None) for an approaching impact, else (None, the judgment of every path):
    its error when the problem itself is ill-posed, ``separating`` when no contact approaches."""
    try:
        problem = make_problem()
    except Exception as exc:  # the problem itself is ill-posed: every path meets it
        judged = _error_judgment(exc)
        return None, {_label(p): judged for p in paths}
    if not np.any(problem.v_minus[:, 0] < 0.0):
        return None, {_label(p): (("separating",), "") for p in paths}
    return problem, None


def _solve_one(problem, law: str, method: str, options) -> tuple[tuple[str, ...], str]:
    """(modes, message) of one approaching problem under one (law, method)."""
    try:
        r = solve_problem(problem, law, method, **options)
    except Exception as exc:
        return _error_judgment(exc)
    d = r.diagnostics
    return tuple(m for m, flag in (("energy_gain", d.energy_gained),
                                   ("slip_reversal", d.slip_reversal),
                                   ("friction_pushes_slip", d.friction_pushes_slip))
                 if flag), ""


def _classify(make_problem: Callable[[], Any], paths, options=None):
    """{path label: (modes, message)} for one problem under every path."""
    options = options or {}
    problem, judged = _prepare(make_problem, paths)
    if judged is not None:
        return judged
    return {_label((law, method)): _solve_one(problem, law, method, options)
            for law, method in paths}


@dataclass(frozen=True, eq=False)
class _Sample:
    """One impact of a map: its cell (iy, ix) and its data (as :func:`build_problem` takes)."""

    iy: int
    ix: int
    M: np.ndarray
    Jc: np.ndarray
    dq: np.ndarray
    e: float
    mu: float
    C: np.ndarray | None = None


#: det W / tr(W)^d at or below which a batch answer is left to the per-sample path: the batch
#: forms W = Jc M^-1 Jc^T in another operation order than :func:`build_problem` (the two differ
#: in the last bit), and on a (near) rank-one W -- a stretched or folded pendulum -- whether a
#: law's exact kernel inverts W, and which branch it takes, is decided by that round-off. Four
#: orders of magnitude above the kernels' own singularity test (det W / tr(W)^d <= 1e-12).
FRAGILE_RTOL = 1e-8


def _relative_det(W: np.ndarray) -> np.ndarray:
    """det W / tr(W)^d per block of an (N, d, d) stack (NaN where it is not finite)."""
    d = W.shape[-1]
    with np.errstate(all="ignore"):
        return np.linalg.det(W) / np.trace(W, axis1=-2, axis2=-1) ** d


def _batch_fast(law: str, samples: Sequence[_Sample], todo: Sequence[int]
                ) -> tuple[dict[int, tuple[tuple[str, ...], str]], set[int]]:
    """Judgments of the samples ``todo`` (approaching, open-loop, one contact) under
    (law, "fast") through :func:`convimpact.impact.batch.impacts.resolve_impacts`, one batch per shape
    of (M, Jc), on this thread only (``threads=1``: the atlas's studies already run maps in
    parallel processes); item i equals ``resolve_impact(..., method="fast")`` to round-off.

    A rejected item (status SINGULAR, JAM, NO_SOLUTION) is named by :func:`classify_error` of
    the typed error ``resolve_impact`` raises for it (``ImpactBatch.error``; its message is the
    kernel's own, without the batch index). An item whose W (or, spatial, whose tangent block)
    is within :data:`FRAGILE_RTOL` of singular is *fragile*: its answer may hinge on W's last
    bit, so the caller judges it per sample. Samples whose batch cannot run (numba missing:
    NotSupportedError; input the batch refuses) get no judgment either.

    Returns
    -------
    judged : dict
        ``{sample index: (modes, message)}``.
    fragile : set of int
        The sample indices (among ``judged``) to judge per sample instead.
    """
    from ..impact.batch import impacts as B

    groups: dict[tuple, list[int]] = {}
    for i in todo:
        s = samples[i]
        groups.setdefault((np.shape(s.M), np.shape(s.Jc)), []).append(i)
    out: dict[int, tuple[tuple[str, ...], str]] = {}
    fragile: set[int] = set()
    for idx in groups.values():
        try:
            b = B.resolve_impacts(np.array([samples[i].M for i in idx], float),
                                  np.array([samples[i].Jc for i in idx], float),
                                  np.array([samples[i].dq for i in idx], float),
                                  np.array([samples[i].e for i in idx], float),
                                  np.array([samples[i].mu for i in idx], float),
                                  law=law, on_error="flag", threads=1)
        except NotSupportedError:  # no numba: no group can run
            return out, fragile
        except ConvImpactError:  # input the batch refuses: this group goes per sample
            continue
        W = b.delassus
        sure = _relative_det(W) > FRAGILE_RTOL
        if W.shape[-1] == 3:
            sure &= _relative_det(W[:, 1:, 1:]) > FRAGILE_RTOL
        fragile.update(i for i, ok in zip(idx, sure.tolist()) if not ok)
        status = b.status.tolist()
        flags = list(zip(b.energy_gained.tolist(), b.slip_reversal.tolist(),
                         b.friction_pushes_slip.tolist()))
        for j, i in enumerate(idx):
            if status[j] != B.OK:
                err = b.error(j)
                cause = err.__cause__
                out[i] = _error_judgment(cause if type(cause) is type(err) else err)
            else:
                out[i] = tuple(m for m, flag in zip(("energy_gain", "slip_reversal",
                                                     "friction_pushes_slip"), flags[j])
                               if flag), ""
    return out, fragile


def _classify_samples(samples: Sequence[_Sample], paths, options=None,
                      after: Callable[[int], None] | None = None
                      ) -> list[dict[str, tuple[tuple[str, ...], str]]]:
    """Judge every sample under every path: ``[_classify(sample, paths)]`` in sample order.

    Each sample's problem is posed once (an ill-posed or separating one is judged so on every
    path). The paths with method ``"fast"`` judge the approaching open-loop single-contact
    samples in one compiled batch per path (:func:`_batch_fast`); every other path, and every
    sample the batch cannot take (a loop Jacobian C, several contacts, solver ``options``,
    no numba) or answers on a W within :data:`FRAGILE_RTOL` of singular, calls
    :func:`convimpact.solve_problem` per sample, as :func:`_classify` does. The judgments are
    those of :func:`_classify` sample by sample.

    Parameters
    ----------
    samples : the impacts, in the order their judgments are wanted.
    paths : (law, method) pairs.
    options : solver options (passed to every per-sample solve; none: batches allowed).
    after : called with the sample's index once it is judged (progress).

    Returns
    -------
    list of dict
        Per sample, ``{path label: (modes, message)}`` with the labels in ``paths`` order.
    """
    options = options or {}
    paths = [tuple(p) for p in paths]
    prepared = [_prepare(lambda s=s: build_problem(s.M, s.Jc, s.dq, s.e, s.mu, s.C), paths)
                for s in samples]
    batched: dict[str, dict[int, tuple[tuple[str, ...], str]]] = {}
    if not options:
        todo = [i for i, (problem, _) in enumerate(prepared) if problem is not None
                and samples[i].C is None and np.ndim(samples[i].Jc) == 2]
        for law, method in paths:
            if method == "fast" and todo:
                judged, fragile = _batch_fast(law, samples, todo)
                batched[_label((law, method))] = {i: j for i, j in judged.items()
                                                  if i not in fragile}
    out = []
    for i, (problem, judged) in enumerate(prepared):
        if judged is None:
            judged = {}
            for law, method in paths:
                label = _label((law, method))
                got = batched.get(label, {}).get(i)
                judged[label] = (got if got is not None
                                 else _solve_one(problem, law, method, options))
        out.append(judged)
        if after is not None:
            after(i)
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
