"""Simulation benchmark: right-hand-side throughput, wall time per simulated second, impact share.

``run_benchmark()`` simulates each scene of ``problems/`` over its default span (best of
``repeats`` runs by wall time) and returns one JSON-ready row per scene; the package
benchmark and ``convimpact simulate --bench`` read these rows.
"""

from __future__ import annotations

import platform
from typing import Any, Sequence

import numpy as np

from ..scenes import list_scenes, load_scene
from .simulate import simulate


def benchmark_scene(name: str, repeats: int = 3, **options) -> dict[str, Any]:
    """Simulate scene ``name`` ``repeats`` times; figures of the fastest run.

    Returns
    -------
    dict with scene, t_end, n_impacts, n_steps, nfev, rhs_per_second, wall_time,
    wall_per_simulated_second, impact_time, impact_share, max_loop_residual, status.
    """
    scene = load_scene(name)
    best = None
    for _ in range(max(1, int(repeats))):
        res = simulate(scene, **options)
        if best is None or res.wall_time < best.wall_time:
            best = res
    span = float(best.t[-1] - best.t[0])
    return {
        "scene": name,
        "t_end": span,
        "status": best.status,
        "n_impacts": len(best.impacts),
        "n_contact_switches": len(best.contact_events),
        "n_steps": best.n_steps,
        "n_restarts": best.n_restarts,
        "n_projections": best.n_projections,
        "nfev": best.nfev,
        "rhs_per_second": best.rhs_per_second,
        "wall_time": best.wall_time,
        "wall_per_simulated_second": best.wall_time / span if span > 0 else float("nan"),
        "impact_time": best.impact_time,
        "impact_share": best.impact_share,
        "max_loop_residual": best.max_loop_residual,
        "settings": dict(best.settings),
    }


def run_benchmark(scenes: Sequence[str] | None = None, repeats: int = 3,
                  **options) -> dict[str, Any]:
    """Benchmark every event-driven scene (or the named ones); JSON-ready. A scene that
    declares another scheme (``Scene.simulation``: the disc pile's Moreau–Jean) is left out
    of the default list: the bench section ``moreau-scale`` measures it."""
    names = list(scenes) if scenes else [
        n for n in list_scenes()
        if dict(load_scene(n).simulation or {}).get("scheme", "event-driven") == "event-driven"]
    rows = [benchmark_scene(n, repeats, **options) for n in names]
    return {
        "benchmark": "simulation",
        "machine": {"python": platform.python_version(), "numpy": np.__version__,
                    "processor": platform.processor() or platform.machine()},
        "repeats": int(repeats),
        "rows": rows,
    }
