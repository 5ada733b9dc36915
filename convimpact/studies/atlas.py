"""The failure atlas: where each impact law, solver path and simulation scheme misbehaves.

Maps over configurations of the paper's mechanisms mark, per (law, method) or per scheme,
every *failure mode* met in a cell (any over the velocities, e and mu swept in that cell),
and count the modes over all the individual problems:

Impact laws (one :func:`convimpact.solve_problem` per problem; :data:`IMPACT_MODES`):

* ``energy_gain``, ``slip_reversal``, ``friction_pushes_slip`` -- the diagnostics' flags;
* ``non_positive_effective_mass`` -- :class:`~convimpact.impact.errors.NonPositiveEffectiveMassError`
  (Painleve-like jam of a Newton law);
* ``singular_delassus`` -- :class:`~convimpact.impact.errors.SingularSystemError` (W not invertible:
  a folded or stretched pendulum, a central impact with friction);
* ``singular_loop`` -- :class:`~convimpact.impact.errors.LoopConstraintError` (C loses rank: a
  slider-crank's change point);
* ``no_convergence`` -- :class:`~convimpact.impact.errors.SolverError`;
* ``not_supported`` -- :class:`~convimpact.impact.errors.NotSupportedError`;
* ``unexpected_error`` -- anything else (a bug; its message is kept in ``examples``).

Problems whose contact does not approach are counted as ``separating`` (not a failure).

Simulation (:data:`SIMULATION_MODES`), against an event-driven run of the same start:

* ``missed_impact`` -- an event-driven impact with no Moreau–Jean impact step within 2 h
  (missed outright, e.g. the late impacts of an accumulation, which Moreau–Jean settles
  plastically, or displaced by more than 2 h as the trajectories drift apart after earlier
  impacts);
* ``smeared_impact`` -- one event-driven impact answered by several Moreau–Jean impact steps,
  or by one whose post-impact velocity is off by more than ``smear_tol`` (relative);
* ``compliant_stiff`` -- the compliant run's steps per second of contact exceed
  ``stiff_ratio`` times its steps per second of free flight;
* ``compliant_deep`` -- the compliant run penetrates deeper than ``depth_tol``;
* ``zeno`` -- the event-driven run detected accumulating impacts (module
  :mod:`convimpact.simulation.zeno`).

Map builders: :func:`pendulum_angle_map` (theta1 x theta2), :func:`pendulum_friction_map`
(theta2 x mu), :func:`slider_crank_map` (crank angle x mu, the paper's geometry or an
isosceles one whose loop matrix is singular at the change points), :func:`pendulum_drop_map`
(simulation, initial angles) and :func:`rod_zeno_map` (simulation, tilt x e).
:func:`failure_atlas` builds them all; :func:`plot_atlas` draws one map.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

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
                 ("dissipative", "fast"), ("dissipative", "clarabel"))
#: joint rates of the double pendulum tried in each cell (rad/s)
PENDULUM_RATES = ((1.0, 1.0), (1.0, -1.0), (-1.0, 2.0))
#: drawing priority of the modes (most severe first) and their colours
_PRIORITY = ("unexpected_error", "singular_loop", "singular_delassus",
             "non_positive_effective_mass", "no_convergence", "not_supported", "energy_gain",
             "slip_reversal", "friction_pushes_slip", "missed_impact", "smeared_impact",
             "compliant_deep", "compliant_stiff", "zeno")
_COLORS = {"ok": "#f2f2f2", "separating": "#d0d0d0", "not_judged": "white", "unexpected_error": "black",
           "singular_loop": "#6a3d9a", "singular_delassus": "#1f78b4",
           "non_positive_effective_mass": "#e31a1c", "no_convergence": "#ff7f00",
           "not_supported": "#b15928", "energy_gain": "#fb9a99", "slip_reversal": "#33a02c",
           "friction_pushes_slip": "#b2df8a", "missed_impact": "#e31a1c",
           "smeared_impact": "#fdbf6f", "compliant_deep": "#1f78b4",
           "compliant_stiff": "#a6cee3", "zeno": "#6a3d9a"}


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


# ---------------------------------------------------------------------------------------------
# impact laws
# ---------------------------------------------------------------------------------------------

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


def _pendulum_mechanism(mass: float = 1.0, length: float = 1.0):
    """The paper's planar double pendulum (problems/_double_pendulum.py); the tip contact's
    Jacobian does not depend on the floor height, so one model serves every configuration
    (the floor is taken at the configuration's tip height)."""
    from convimpact.problems._double_pendulum import build

    return build(True, mass, length, -2.0 * length, 0.5, 0.3).mechanism()


def pendulum_angle_map(theta1: Sequence[float] | None = None,
                       theta2: Sequence[float] | None = None, e: Iterable[float] = (0.5,),
                       mu: Iterable[float] = (0.3, 0.8),
                       rates: Iterable[Sequence[float]] = PENDULUM_RATES,
                       paths=DEFAULT_PATHS, progress: Callable[[str], None] | None = None
                       ) -> AtlasMap:
    """Impact laws over the planar double pendulum's configurations theta1 x theta2.

    The tip strikes a floor at its own height; theta1 is rod 1's angle from +x, theta2 rod 2's
    angle relative to rod 1 (radians). Each cell tries every rate pair (theta_dot), e and mu.
    Also returns ``values["delassus_condition"]`` (2-norm condition of W).
    """
    th1 = np.linspace(-np.pi, 0.0, 13) if theta1 is None else np.asarray(theta1, float)
    th2 = np.linspace(-np.pi, np.pi, 13) if theta2 is None else np.asarray(theta2, float)
    mech = _pendulum_mechanism()
    labels = [_label(p) for p in paths]
    b = _MapBuilder(labels, IMPACT_MODES, (th2.size, th1.size))
    cond = np.full((th2.size, th1.size), np.nan)
    t0 = time.perf_counter()
    for iy, b2 in enumerate(th2):
        for ix, a1 in enumerate(th1):
            th = np.array([a1, b2])
            M = np.asarray(mech.mass_matrix(th), float)
            J = np.asarray(mech.contact_jacobian("tip", th), float)
            W = J @ np.linalg.solve(M, J.T)
            cond[iy, ix] = np.linalg.cond(W)
            for rate in rates:
                for ee in e:
                    for mm in mu:
                        b.add(iy, ix, _classify(
                            lambda: build_problem(M, J, np.asarray(rate, float), ee, mm),
                            paths))
        if progress:
            progress(f"atlas pendulum theta1 x theta2: row {iy + 1}/{th2.size}")
    return b.build("pendulum_angles", "planar double pendulum, tip on the floor: theta1 x "
                   "theta2", "theta1 (rod 1 from +x) [rad]", "theta2 (rod 2 relative) [rad]",
                   th1, th2, {"delassus_condition": cond},
                   {"e": list(e), "mu": list(mu), "rates": [list(r) for r in rates],
                    "paths": labels}, t0)


def pendulum_friction_map(theta2: Sequence[float] | None = None,
                          mu: Sequence[float] | None = None, theta1: float = -0.6 * np.pi,
                          e: Iterable[float] = (0.0, 0.5, 1.0),
                          rates: Iterable[Sequence[float]] = PENDULUM_RATES,
                          paths=DEFAULT_PATHS, progress=None) -> AtlasMap:
    """Impact laws over theta2 x mu of the double pendulum at a fixed theta1 (default -108
    degrees, case (a)'s rod 1), every rate pair and e in each cell."""
    th2 = np.linspace(-np.pi, np.pi, 13) if theta2 is None else np.asarray(theta2, float)
    mus = np.linspace(0.0, 1.5, 7) if mu is None else np.asarray(mu, float)
    mech = _pendulum_mechanism()
    labels = [_label(p) for p in paths]
    b = _MapBuilder(labels, IMPACT_MODES, (mus.size, th2.size))
    t0 = time.perf_counter()
    for ix, b2 in enumerate(th2):
        th = np.array([theta1, b2])
        M = np.asarray(mech.mass_matrix(th), float)
        J = np.asarray(mech.contact_jacobian("tip", th), float)
        for iy, mm in enumerate(mus):
            for rate in rates:
                for ee in e:
                    b.add(iy, ix, _classify(
                        lambda: build_problem(M, J, np.asarray(rate, float), ee, mm), paths))
        if progress and ix % 4 == 0:
            progress(f"atlas pendulum theta2 x mu: column {ix + 1}/{th2.size}")
    return b.build("pendulum_friction", f"planar double pendulum at theta1 = "
                   f"{math.degrees(theta1):.0f} deg: theta2 x mu", "theta2 (rod 2 relative) "
                   "[rad]", "mu", th2, mus, {},
                   {"theta1": theta1, "e": list(e), "rates": [list(r) for r in rates],
                    "paths": labels}, t0)


def slider_crank_state(mech, crank_angle: float, crank_rate: float = 20.0,
                       slider_speed: float = -1.0, geometry: str = "scene"):
    """(theta, theta_dot) of a slider-crank with the free slider touching slider 3.

    ``geometry="scene"``: :mod:`convimpact.problems.slider_crank` (relative coupler angle,
    crank 0.15 m, coupler 0.40 m). ``geometry="isosceles"``: the hand model
    :class:`convimpact.simulation.testing.SliderCrank` with r = l (absolute angles; at the
    change points phi1 = +-90 deg the pin sits on the crank axis and C loses rank). Velocities
    solve C theta_dot = 0 for the crank rate by least squares (exact where C has full rank,
    the minimum-norm consistent choice at a change point).
    """
    a = float(crank_angle)
    if geometry == "scene":
        from convimpact.problems.slider_crank import (COUPLER_LENGTH, CRANK_LENGTH,
                                                      FREE_SLIDER_HALF_WIDTH,
                                                      SLIDER_HALF_WIDTH)
        r, l = CRANK_LENGTH, COUPLER_LENGTH
        phi2 = math.asin(max(-1.0, min(1.0, -r * math.sin(a) / l)))
        th = np.array([a, phi2 - a, r * math.cos(a) + l * math.cos(phi2), 0.0])
        th[3] = th[2] + SLIDER_HALF_WIDTH + FREE_SLIDER_HALF_WIDTH
    else:
        r, l = mech.r, mech.l
        phi2 = math.asin(max(-1.0, min(1.0, -r * math.sin(a) / l)))
        th = np.array([a, phi2, r * math.cos(a) + l * math.cos(phi2), 0.0])
        th[3] = th[2] + mech.clearance
    C = np.asarray(mech.loop_jacobian(th), float)
    rest = np.linalg.lstsq(C[:, 1:3], -C[:, 0] * crank_rate, rcond=None)[0]
    dq = np.array([crank_rate, rest[0], rest[1], slider_speed])
    return th, dq


def slider_crank_map(crank_angle: Sequence[float] | None = None,
                     mu: Sequence[float] | None = None, e: Iterable[float] = (0.83,),
                     geometry: str = "scene", slider_speeds: Iterable[float] = (-1.0,),
                     paths=DEFAULT_PATHS, progress=None) -> AtlasMap:
    """Impact laws over crank angle x mu of the slider-crank striking the free slider.

    The crank angle covers its full turn, dead centres (0, +-pi) included; the crank turns at
    20 rad/s and the free slider moves at each of ``slider_speeds``. Also returns
    ``values["loop_condition"]`` (condition of C M^-1 C^T; inf where C loses rank).
    """
    from convimpact.simulation.testing import SliderCrank

    ang = (np.linspace(-np.pi, np.pi, 25) if crank_angle is None
           else np.asarray(crank_angle, float))
    mus = np.linspace(0.0, 1.0, 5) if mu is None else np.asarray(mu, float)
    if geometry == "scene":
        from convimpact.scenes import load_scene

        mech = load_scene("slider_crank").mechanism
    elif geometry == "isosceles":
        mech = SliderCrank(r=0.2, l=0.2)
    else:
        from ..impact.errors import UnknownOptionError
        raise UnknownOptionError(f"unknown geometry {geometry!r}; choose 'scene' or "
                                 "'isosceles'")
    labels = [_label(p) for p in paths]
    b = _MapBuilder(labels, IMPACT_MODES, (mus.size, ang.size))
    loop_cond = np.full((mus.size, ang.size), np.nan)
    t0 = time.perf_counter()
    for ix, a in enumerate(ang):
        for v4 in slider_speeds:
            th, dq = slider_crank_state(mech, a, slider_speed=v4, geometry=geometry)
            M = np.asarray(mech.mass_matrix(th), float)
            C = np.asarray(mech.loop_jacobian(th), float)
            name = mech.contact_names[0]
            J = np.asarray(mech.contact_jacobian(name, th), float)
            S = C @ np.linalg.solve(M, C.T)
            sv = np.linalg.svd(S, compute_uv=False)
            loop_cond[:, ix] = sv[0] / sv[-1] if sv[-1] > 0 else np.inf
            for iy, mm in enumerate(mus):
                for ee in e:
                    b.add(iy, ix, _classify(lambda: build_problem(M, J, dq, ee, mm, C), paths))
        if progress and ix % 6 == 0:
            progress(f"atlas slider-crank ({geometry}) angle x mu: column {ix + 1}/{ang.size}")
    title = ("slider-crank striking the free slider" if geometry == "scene" else
             "isosceles slider-crank (r = l, change points at +-90 deg)")
    return b.build(f"slider_crank_{geometry}", f"{title}: crank angle x mu",
                   "crank angle [rad]", "mu", ang, mus, {"loop_condition": loop_cond},
                   {"geometry": geometry, "e": list(e), "slider_speeds": list(slider_speeds),
                    "crank_rate": 20.0, "paths": labels}, t0)


# ---------------------------------------------------------------------------------------------
# simulation
# ---------------------------------------------------------------------------------------------

def judge_time_stepping(ref, mj, h: float, smear_tol: float = 1e-2,
                        t_end: float | None = None) -> dict[str, Any]:
    """Compare Moreau–Jean's impact steps with the event-driven impacts of the same start.

    Returns
    -------
    dict with ``missed`` and ``smeared`` (numbers of event-driven impacts), and
    ``velocity_error`` (max relative post-impact velocity error over the matched impacts).
    Event-driven impacts later than ``t_end - 2 h`` are not judged (the step may not have
    reached them).
    """
    t_end = float(ref.t[-1]) if t_end is None else float(t_end)
    mj_times = np.array([i.time for i in mj.impacts])
    missed = smeared = 0
    err = 0.0
    for imp in ref.impacts:
        if imp.time > t_end - 2 * h:
            continue
        near = np.nonzero(np.abs(mj_times - imp.time) <= 2 * h)[0] if mj_times.size else []
        if len(near) == 0:
            missed += 1
            continue
        last = mj.impacts[int(near[-1])]
        e = float(np.linalg.norm(last.dtheta_plus - imp.dtheta_plus)
                  / max(np.linalg.norm(imp.dtheta_plus), 1e-300))
        err = max(err, e)
        if len(near) > 1 or e > smear_tol:
            smeared += 1
    return {"missed": missed, "smeared": smeared, "velocity_error": err}


def judge_compliant(res, stiff_ratio: float = 10.0, depth_tol: float = 1e-3) -> dict[str, Any]:
    """Stiffness and penetration of a compliant run (see the module docstring)."""
    span = float(res.t[-1] - res.t[0])
    t_contact = sum(ep.duration if ep.duration is not None else float(res.t[-1]) - ep.t_start
                    for ep in res.episodes)
    free_steps = res.n_steps - res.n_contact_steps
    t_free = max(span - t_contact, 1e-300)
    if res.n_contact_steps and t_contact > 0 and free_steps > 0:
        ratio = (res.n_contact_steps / t_contact) / (free_steps / t_free)
    else:
        ratio = float("nan")
    return {"step_ratio": ratio, "stiff": bool(ratio > stiff_ratio),
            "max_penetration": res.max_penetration,
            "deep": bool(res.max_penetration > depth_tol)}


def _zeno(ref) -> bool:
    return any(ev.kind == "persist" and ev.accumulation_time is not None
               for ev in ref.contact_events)


def pendulum_drop_map(theta1: Sequence[float] | None = None,
                      theta2: Sequence[float] | None = None, t_end: float = 0.8,
                      h: float = 2e-3, stiffness: float = 1e6, smear_tol: float = 1e-2,
                      stiff_ratio: float = 10.0, depth_tol: float = 1e-3,
                      progress=None) -> AtlasMap:
    """Simulation failures of the double pendulum dropped from rest at (theta1, theta2).

    Per cell: the event-driven run (law "coulomb", rtol 1e-9) is the reference; Moreau–Jean
    at step ``h`` is judged by :func:`judge_time_stepping`, the compliant model (Hunt–Crossley
    with the scene's restitution, ``stiffness``) by :func:`judge_compliant`. Starts whose tip
    is below the floor (y = -1.5 m) are left blank (``values["feasible"] = 0``).
    """
    from ..scenes import load_scene
    from ..simulation import simulate
    from ..simulation.compliant import restitution_for, simulate_compliant
    from ..simulation.moreau import simulate_moreau

    th1 = np.radians([-60.0, 0.0, 60.0]) if theta1 is None else np.asarray(theta1, float)
    th2 = np.radians([-60.0, 0.0, 60.0]) if theta2 is None else np.asarray(theta2, float)
    scene = load_scene("pendulum_planar", case="drop")
    mech = scene.mechanism
    e_c = restitution_for("hunt-crossley", mech.contact_parameters("tip")[0])
    paths = ("event-driven", "moreau-jean", "compliant")
    b = _MapBuilder(paths, SIMULATION_MODES, (th2.size, th1.size))
    shape = (th2.size, th1.size)
    vals = {k: np.full(shape, np.nan) for k in (
        "feasible", "event_driven_impacts", "moreau_velocity_error", "compliant_step_ratio",
        "compliant_penetration")}
    t0 = time.perf_counter()
    for iy, b2 in enumerate(th2):
        for ix, a1 in enumerate(th1):
            q0 = np.array([a1, b2])
            if mech.contact_gap("tip", q0) <= 1e-3:
                vals["feasible"][iy, ix] = 0
                continue
            vals["feasible"][iy, ix] = 1
            y0 = (q0, np.zeros(2))
            judged: dict[str, tuple[tuple[str, ...], str]] = {}
            try:
                ref = simulate(scene, (0.0, t_end), y0, law="coulomb", rtol=1e-9, atol=1e-11)
            except ConvImpactError as exc:
                judged["event-driven"] = ((), f"{type(exc).__name__}: {exc}")
                b.add(iy, ix, judged)
                continue
            vals["event_driven_impacts"][iy, ix] = len(ref.impacts)
            judged["event-driven"] = (("zeno",) if _zeno(ref) else (), "")
            try:
                mj = simulate_moreau(scene, (0.0, t_end), y0, h=h)
                jt = judge_time_stepping(ref, mj, h, smear_tol, t_end)
                vals["moreau_velocity_error"][iy, ix] = jt["velocity_error"]
                judged["moreau-jean"] = (tuple(m for m, n in (("missed_impact", jt["missed"]),
                                                               ("smeared_impact",
                                                                jt["smeared"])) if n), "")
            except ConvImpactError as exc:
                judged["moreau-jean"] = (("missed_impact",), f"{type(exc).__name__}: {exc}")
            try:
                co = simulate_compliant(scene, (0.0, t_end), y0, stiffness=stiffness,
                                        e=e_c, model="hunt-crossley")
                jc = judge_compliant(co, stiff_ratio, depth_tol)
                vals["compliant_step_ratio"][iy, ix] = jc["step_ratio"]
                vals["compliant_penetration"][iy, ix] = jc["max_penetration"]
                judged["compliant"] = (tuple(m for m, f in (("compliant_stiff", jc["stiff"]),
                                                             ("compliant_deep", jc["deep"]))
                                             if f), "")
            except ConvImpactError as exc:
                judged["compliant"] = (("compliant_stiff",), f"{type(exc).__name__}: {exc}")
            b.add(iy, ix, judged)
        if progress:
            progress(f"atlas pendulum drops: row {iy + 1}/{th2.size}")
    return b.build("pendulum_drop", "double pendulum dropped from rest: simulation schemes "
                   "over the initial angles", "theta1(0) [rad]", "theta2(0) [rad]", th1, th2,
                   vals, {"t_end": t_end, "h": h, "stiffness": stiffness,
                          "smear_tol": smear_tol, "stiff_ratio": stiff_ratio,
                          "depth_tol": depth_tol, "law": "coulomb",
                          "compliant_model": "hunt-crossley", "compliant_e": e_c}, t0)


def rod_zeno_map(tilt_deg: Sequence[float] | None = None, e: Sequence[float] | None = None,
                 t_end: float = 1.2, height: float = 0.5, progress=None) -> AtlasMap:
    """Where the bouncing rod's impacts accumulate (event-driven, law "coulomb"): tilt x e.

    ``values["accumulation_time"]``: the first extrapolated accumulation instant (NaN: none
    within the span); ``values["impacts"]``: impacts resolved before it.
    """
    from ..scenes import load_scene
    from ..simulation import simulate

    tilts = np.array([0.0, 30.0, 60.0]) if tilt_deg is None else np.asarray(tilt_deg, float)
    es = np.array([0.2, 0.5, 0.8]) if e is None else np.asarray(e, float)
    b = _MapBuilder(("event-driven",), ("zeno",), (es.size, tilts.size))
    acc = np.full((es.size, tilts.size), np.nan)
    nimp = np.full((es.size, tilts.size), np.nan)
    t0 = time.perf_counter()
    for iy, ee in enumerate(es):
        for ix, tilt in enumerate(tilts):
            scene = load_scene("bouncing_rod", e=float(ee), tilt=float(tilt), height=height)
            ref = simulate(scene, (0.0, t_end), law="coulomb", rtol=1e-8, atol=1e-10)
            times = [ev.accumulation_time for ev in ref.contact_events
                     if ev.accumulation_time is not None]
            acc[iy, ix] = min(times) if times else np.nan
            nimp[iy, ix] = len(ref.impacts)
            b.add(iy, ix, {"event-driven": (("zeno",) if _zeno(ref) else (), "")})
        if progress:
            progress(f"atlas rod Zeno: row {iy + 1}/{es.size}")
    return b.build("rod_zeno", "bouncing rod: accumulating impacts (tilt x e)", "tilt [deg]",
                   "e", tilts, es, {"accumulation_time": acc, "impacts": nimp},
                   {"t_end": t_end, "height": height, "law": "coulomb"}, t0)


# ---------------------------------------------------------------------------------------------
# the whole atlas and its maps
# ---------------------------------------------------------------------------------------------

def failure_atlas(quick: bool = False, progress: Callable[[str], None] | None = None,
                  paths=DEFAULT_PATHS) -> list[AtlasMap]:
    """Every map of the atlas (quick: coarse grids; full: fine grids)."""
    n = 9 if quick else 37
    maps = [
        pendulum_angle_map(np.linspace(-np.pi, 0.0, n), np.linspace(-np.pi, np.pi, n),
                           mu=(0.3, 0.8) if quick else (0.2, 0.5, 0.8, 1.2),
                           paths=paths, progress=progress),
        pendulum_friction_map(np.linspace(-np.pi, np.pi, n),
                              np.linspace(0.0, 1.5, 7 if quick else 16),
                              e=(0.5,) if quick else (0.0, 0.5, 1.0), paths=paths,
                              progress=progress),
        slider_crank_map(np.linspace(-np.pi, np.pi, 13 if quick else 73),
                         np.linspace(0.0, 1.0, 3 if quick else 6),
                         e=(0.83,) if quick else (0.0, 0.5, 0.83, 1.0), paths=paths,
                         progress=progress),
        slider_crank_map(np.linspace(-np.pi, np.pi, 13 if quick else 73),
                         np.linspace(0.0, 1.0, 3 if quick else 6),
                         e=(0.83,) if quick else (0.0, 0.5, 0.83, 1.0), geometry="isosceles",
                         paths=paths, progress=progress),
    ]
    k = 2 if quick else 6
    maps.append(pendulum_drop_map(np.radians(np.linspace(-45.0, 45.0, k)),
                                  np.radians(np.linspace(-45.0, 45.0, k)),
                                  t_end=0.7 if quick else 1.2, h=2e-3 if quick else 1e-3,
                                  progress=progress))
    maps.append(rod_zeno_map(np.linspace(0.0, 60.0, 2 if quick else 5),
                             np.array([0.2, 0.8]) if quick else np.linspace(0.1, 0.9, 5),
                             t_end=1.0 if quick else 1.5, progress=progress))
    return maps


def atlas_counts(maps: Sequence[AtlasMap]) -> dict[str, dict[str, int]]:
    """Counts per path summed over maps (impact maps and simulation maps separately keyed)."""
    out: dict[str, dict[str, int]] = {}
    for m in maps:
        for p, c in m.counts.items():
            acc = out.setdefault(p, {})
            for mode, n in c.items():
                acc[mode] = acc.get(mode, 0) + int(n)
    return out


def plot_atlas(atlas_map: AtlasMap, out: str | Path | None = None,
               paths: Sequence[str] | None = None, ncols: int = 3):
    """Draw one map: a panel per path, each cell coloured by its most severe mode.

    Parameters
    ----------
    atlas_map : the map.
    out : file (PNG) to write, or None.
    paths : the panels (default every path of the map).
    ncols : panels per row.

    Returns
    -------
    matplotlib Figure
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    m = atlas_map
    paths = list(paths or m.paths)
    present = [mode for mode in _PRIORITY if mode in m.modes
               and any(np.any(m.flags[p][mode]) for p in paths)]
    empty = (np.asarray(m.samples) == 0) if m.samples is not None else None
    has_empty = empty is not None and bool(np.any(empty))
    cats = ["ok", "separating"] + present + (["not_judged"] if has_empty else [])
    cmap = ListedColormap([_COLORS[c] for c in cats])
    ncols = min(ncols, len(paths))
    nrows = int(math.ceil(len(paths) / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.3 * ncols, 3.6 * nrows + 1.0),
                             squeeze=False, sharex=True, sharey=True)
    x, y = np.asarray(m.x), np.asarray(m.y)

    def edges(v):
        if v.size == 1:
            return np.array([v[0] - 0.5, v[0] + 0.5])
        mid = 0.5 * (v[1:] + v[:-1])
        return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])

    for ax, p in zip(axes.ravel(), paths):
        img = np.zeros((y.size, x.size))
        img[m.all_separating] = 1
        for code, mode in reversed(list(enumerate(present, start=2))):
            img[m.flags[p][mode]] = code
        if has_empty:  # e.g. a start that penetrates the floor: nothing was run there
            img[empty] = len(cats) - 1
        ax.pcolormesh(edges(x), edges(y), img, cmap=cmap, vmin=-0.5,
                      vmax=len(cats) - 0.5, shading="flat")
        items = [f"{k.replace('_', ' ')}: {v}" for k, v in m.counts[p].items() if v]
        lines = [", ".join(items[i:i + 2]) for i in range(0, len(items), 2)]
        ax.set_title("\n".join([p] + (lines or ["no failure"])), fontsize=7)
    for ax in axes.ravel()[len(paths):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel(m.x_name, fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel(m.y_name, fontsize=8)
    handles = [Patch(facecolor=_COLORS[c], edgecolor="0.6", label=c.replace("_", " "))
               for c in cats]
    fig.legend(handles=handles, loc="lower center", ncol=min(6, len(handles)), fontsize=8,
               frameon=False)
    fig.suptitle(f"failure atlas: {m.title}\n(cell colour: most severe mode met over "
                 f"{_cell_note(m)}; counts over {m.n_samples} samples)", fontsize=9)
    fig.tight_layout(rect=(0, 0.07, 1, 0.93))
    if out is not None:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out, dpi=90)
    return fig


def _cell_note(m: AtlasMap) -> str:
    keys = [k for k in ("rates", "e", "mu", "slider_speeds") if k in m.fixed]
    return "the " + ", ".join(keys) + " of each cell" if keys else "each cell"
