"""The failure atlas: where each impact law, solver path and simulation scheme misbehaves.

Maps over configurations of the paper's mechanisms mark, per (law, method) or per scheme,
every *failure mode* met in a cell (any over the velocities, e and mu swept in that cell),
and count the modes over all the individual problems:

Impact laws (:data:`IMPACT_MODES`): one :func:`convimpact.solve_problem` per problem and path,
except on the open-loop pendulum maps, whose ``"fast"`` paths judge all the map's problems in
one compiled batch per path (:func:`convimpact.impact.batch.impacts.resolve_impacts`; a rejected item's
status is named by the typed error ``resolve_impact(..., method="fast")`` raises for it). The
answers, and so the maps, are the same: the problems whose W is within
:data:`~convimpact.studies.atlas_modes.FRAGILE_RTOL` of singular (their answer hinges on W's
last bit, which the batch forms in another order), loops, and runs without numba go per problem.

* ``energy_gain``, ``slip_reversal``, ``friction_pushes_slip`` -- the diagnostics' flags;
* ``non_positive_effective_mass`` --
  :class:`~convimpact.errors.NonPositiveEffectiveMassError`
  (Painleve-like jam of a Newton law);
* ``singular_delassus`` -- :class:`~convimpact.errors.SingularSystemError` (W not invertible:
  a folded or stretched pendulum, a central impact with friction);
* ``singular_loop`` -- :class:`~convimpact.errors.LoopConstraintError` (C loses rank: a
  slider-crank's change point);
* ``no_convergence`` -- :class:`~convimpact.errors.SolverError`;
* ``not_supported`` -- :class:`~convimpact.errors.NotSupportedError`;
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

The modes, their classification and the map type are in :mod:`convimpact.studies.atlas_modes`,
the impact maps in :mod:`convimpact.studies.atlas_impact_maps`, the simulation maps in
:mod:`convimpact.studies.atlas_simulation_maps` and the drawing in
:mod:`convimpact.studies.atlas_plot`; every public name is importable from here.
:func:`failure_atlas` builds the maps in this process; the same maps run as studies (chunks
on local processes or a Dask cluster, a resumable Zarr store per map) through
:func:`convimpact.studies.atlas_study.run_atlas` and ``convimpact atlas --out DIR``, and come out
equal but for their wall times.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from .atlas_impact_maps import (pendulum_angle_map, pendulum_friction_map, slider_crank_map,
                                slider_crank_state)
from .atlas_modes import (DEFAULT_PATHS, IMPACT_MODES, PENDULUM_RATES, SIMULATION_MODES,
                          AtlasMap, classify_error, classify_impact)
from .atlas_plot import plot_atlas
from .atlas_simulation_maps import (judge_compliant, judge_time_stepping, pendulum_drop_map,
                                    rod_zeno_map)


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


__all__ = ["IMPACT_MODES", "SIMULATION_MODES", "DEFAULT_PATHS", "PENDULUM_RATES", "AtlasMap",
           "classify_error", "classify_impact", "pendulum_angle_map", "pendulum_friction_map",
           "slider_crank_state", "slider_crank_map", "judge_time_stepping", "judge_compliant",
           "pendulum_drop_map", "rod_zeno_map", "failure_atlas", "atlas_counts", "plot_atlas"]
