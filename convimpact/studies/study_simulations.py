"""Study kind ``simulation``: an ensemble of event-driven runs of a scene, summarized per run.

Each point builds the scene ``options.scene`` with the swept parameters of its ``make_scene``
(plus the fixed ``options.scene_parameters``) and runs :func:`convimpact.simulate` from the
scene's initial state over [0, t_end]. Options: ``scene`` (required), ``scene_parameters``,
``t_end`` (default the scene's), ``law`` (default "coulomb"), ``rtol`` (1e-8), ``atol``
(1e-10), ``summary_start`` (0.5: the mean velocities are taken over the last half), ``e_t``
(the tangential restitution in [-1, 1] of law "chatterjee-ruina", every contact; refused
with another law). Parameters: the numeric arguments of the scene's ``make_scene`` (e.g. the
rimless wheel's ``slope_deg``, ``mu``, ``e``, ``omega0``; the contacts' e and mu come from
there), and ``e_t`` when the law has one (passed as ``impact_options={"e_t": ...}``).

Outputs per run: ``status`` (the result's status; -1 where the run raised, its first message
in the chunk's record), ``n_impacts``, ``final_time`` (s), ``energy_change`` (J, total
mechanical energy at the end minus at the start), ``theta_final`` and ``mean_velocity``
((theta(t_end) - theta(t_s)) / (t_end - t_s) with t_s = summary_start x t_end; dimension
``coordinate``) -- e.g. the rimless wheel's walking speed is ``-mean_velocity`` of x.
"""

from __future__ import annotations

import inspect
from typing import Any, Mapping

import numpy as np

from ..errors import ConvImpactError
from .study_kinds import (ChunkOutput, OutputVariable, StudyKind, freeze_parameters, cached_scene,
                          register_kind, scene_of, scene_options)
from .study_spec import ParameterInfo, StudySpec, StudySpecError, check_value


#: the tangential restitution of the laws that have one (law chatterjee-ruina)
_E_T = ParameterInfo("e_t", low=-1.0, high=1.0,
                     description="tangential restitution (law chatterjee-ruina)")


class SimulationKind(StudyKind):
    """An ensemble of event-driven simulations (see the module docstring)."""

    name = "simulation"
    description = "an ensemble of event-driven simulations of a scene, summarized per run"
    default_chunk_points = 8

    def check_options(self, options: dict[str, Any], source: str) -> dict[str, Any]:
        from ..impact import LAWS
        from ..impact.laws import TANGENTIAL_LAWS

        options = dict(options)
        scene_name, scene_params = scene_options(options, source, self.name)
        out: dict[str, Any] = {"scene": scene_name, "scene_parameters": scene_params}
        scene = scene_of(out)
        specs = {"t_end": (ParameterInfo("t_end", low=1e-12), float(scene.t_end)),
                 "law": (ParameterInfo("law", "str", choices=tuple(LAWS)), "coulomb"),
                 "rtol": (ParameterInfo("rtol", low=1e-14, high=1e-2), 1e-8),
                 "atol": (ParameterInfo("atol", low=1e-16, high=1.0), 1e-10),
                 "summary_start": (ParameterInfo("summary_start", low=0.0, high=0.99), 0.5)}
        for key, (info, default) in specs.items():
            out[key] = check_value(info, options.pop(key, default), f"{source}: options.{key}")
        if "e_t" in options:  # kept only when given (the specs without it are unchanged)
            if out["law"] not in TANGENTIAL_LAWS:
                raise StudySpecError(
                    f"{source}: options.e_t is the tangential restitution of law "
                    f"{', '.join(map(repr, TANGENTIAL_LAWS))}; law {out['law']!r} has none")
            out["e_t"] = check_value(_E_T, options.pop("e_t"), f"{source}: options.e_t")
        if options:
            raise StudySpecError(f"{source}: unknown option(s) {', '.join(options)} for kind "
                                 f"'simulation'; its options: scene, scene_parameters, "
                                 f"{', '.join(specs)}, e_t")
        return out

    def parameters(self, options: Mapping[str, Any]) -> dict[str, ParameterInfo]:
        import importlib

        from ..impact.laws import TANGENTIAL_LAWS

        mod = importlib.import_module(f"convimpact.problems.{options['scene']}")
        out = {}
        for p in inspect.signature(mod.make_scene).parameters.values():
            if p.name in options["scene_parameters"] or isinstance(p.default, bool):
                continue
            if isinstance(p.default, int):
                out[p.name] = ParameterInfo(p.name, "int")
            elif isinstance(p.default, float):
                out[p.name] = ParameterInfo(p.name, "float")
        if options["law"] in TANGENTIAL_LAWS:
            out["e_t"] = _E_T  # the law's parameter (no scene takes one)
        return out

    def check_spec(self, spec: StudySpec, source: str) -> None:
        """Build the scene at the grid's corners (first and last values) to catch values its
        ``make_scene`` rejects before any run."""
        base = dict(spec.options["scene_parameters"])
        for pick in (0, -1):
            params = {**base, **{a.name: a.values[pick] for a in spec.grid if a.name != "e_t"}}
            try:
                cached_scene(spec.options["scene"], freeze_parameters(params))
            except ConvImpactError as exc:
                raise StudySpecError(f"{source}: scene {spec.options['scene']!r} rejects "
                                     f"{params}: {exc}") from None

    def outputs(self, spec: StudySpec) -> tuple[OutputVariable, ...]:
        k = scene_of(spec.options).mechanism.n_coordinates
        coord = (("coordinate", tuple(f"theta{i + 1}" for i in range(k))),)
        return (
            OutputVariable("status", "int8", "", "simulation status (-1: raised)"),
            OutputVariable("n_impacts", "int32", "", "impacts resolved"),
            OutputVariable("final_time", "float64", "s", "time reached"),
            OutputVariable("energy_change", "float64", "J", "mechanical energy end - start"),
            OutputVariable("theta_final", "float64", "", "joint coordinates at the end", coord),
            OutputVariable("mean_velocity", "float64", "", "mean joint velocity over the "
                           "summary window", coord),
        )

    def evaluate(self, spec: StudySpec, points: Mapping[str, np.ndarray]) -> ChunkOutput:
        from ..scenes import load_scene
        from ..simulation import simulate

        o = spec.options
        shape = next(iter(points.values())).shape
        n = int(np.prod(shape))
        k = scene_of(o).mechanism.n_coordinates
        status = np.full(n, -1, np.int8)
        n_imp = np.zeros(n, np.int32)
        t_fin, d_en = np.full(n, np.nan), np.full(n, np.nan)
        th_fin, mean_v = np.full((n, k), np.nan), np.full((n, k), np.nan)
        flat = {name: np.asarray(v).ravel() for name, v in points.items()}
        first_error = ""
        for i in range(n):
            params = {**o["scene_parameters"], **{name: v[i].item() for name, v in flat.items()}}
            e_t = params.pop("e_t", o.get("e_t"))  # the law's, not the scene's
            impact_options = {} if e_t is None else {"e_t": e_t}
            try:
                scene = load_scene(o["scene"], **params)
                r = simulate(scene, (0.0, o["t_end"]), law=o["law"], rtol=o["rtol"],
                             atol=o["atol"], impact_options=impact_options)
            except ConvImpactError as exc:
                first_error = first_error or f"{params}: {type(exc).__name__}: {exc}"
                continue
            status[i], n_imp[i], t_fin[i] = r.status, len(r.impacts), r.t[-1]
            energy = np.asarray(r.kinetic_energy) + np.asarray(r.potential_energy)
            d_en[i] = energy[-1] - energy[0]
            th_fin[i] = r.theta[-1]
            j = int(np.searchsorted(r.t, o["summary_start"] * r.t[-1]))
            j = min(j, len(r.t) - 2)
            mean_v[i] = (r.theta[-1] - r.theta[j]) / (r.t[-1] - r.t[j])
        arrays = {"status": status, "n_impacts": n_imp, "final_time": t_fin,
                  "energy_change": d_en, "theta_final": th_fin, "mean_velocity": mean_v}
        return ChunkOutput({k_: v.reshape(shape + v.shape[1:]) for k_, v in arrays.items()},
                           {"first_error": first_error} if first_error else {})


register_kind(SimulationKind())
