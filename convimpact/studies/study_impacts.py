"""Study kind ``impacts``: single-contact impacts of a scene's mechanism, in compiled batches.

Each point is one impact of the contact ``options.contact`` of the scene ``options.scene`` at
the configuration theta, the velocities theta_dot, restitution e, friction mu under ``law``;
the points of a chunk are resolved by :func:`convimpact.impact.batch.impacts.resolve_impacts` (one
call per law; M and Jc are evaluated once per distinct configuration of the chunk). The floor
is taken at the contact's own height (the contact Jacobian does not depend on the gap).

Options: ``scene`` (required), ``scene_parameters`` (table), ``contact`` (default the scene's
impact contact, or its first), ``theta`` and ``dtheta`` (lists of k values, default the
scene's impact state, or its initial state), ``e`` and ``mu`` (default the contact's), ``law``
(default "pereira-nikravesh"), ``e_t`` (the tangential restitution of law
"chatterjee-ruina", default 0). Parameters a grid or sample may sweep: ``theta1`` ...
``thetak``, ``dtheta1`` ... ``dthetak`` (one-based), ``e`` (in [0, 1]), ``mu`` (>= 0),
``e_t`` (in [-1, 1]) and ``law`` (a string). ``e_t`` reaches the laws that have one only (on
a grid that also sweeps ``law``, the other laws' points do not depend on it); a spec giving
``e_t`` with none of them is refused. Open trees only (the batch does not take loop
constraints).

Outputs: ``regime`` (int8 code into ``regime_names``, -1 where the kernel rejected the
impact), ``status`` (int8 code into ``status_names``: 0 ok, 1 singular W, 2 jam, 3 no
solution), ``impulse``, ``v_minus``, ``v_plus`` (contact frame, dimension ``contact_axis``),
``energy_before`` and ``energy_loss`` (J) and the flags ``energy_gained``, ``slip_reversal``,
``friction_pushes_slip``, ``penetration``.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from .study_kinds import (ChunkOutput, OutputVariable, StudyKind, register_kind,
                          scene_of, scene_options)
from .study_spec import ParameterInfo, StudySpec, StudySpecError, check_value

_FLAGS = ("energy_gained", "slip_reversal", "friction_pushes_slip", "penetration")


class ImpactsKind(StudyKind):
    """Single-contact impacts through the compiled batch (see the module docstring)."""

    name = "impacts"
    description = "single-contact impacts of a scene's mechanism (compiled batch)"
    default_chunk_points = 200_000

    def check_options(self, options: dict[str, Any], source: str) -> dict[str, Any]:
        from ..impact.batch.impacts import LAW_CODES

        options = dict(options)
        scene_name, scene_params = scene_options(options, source, self.name)
        out: dict[str, Any] = {"scene": scene_name, "scene_parameters": scene_params}
        scene = scene_of(out)
        mech = scene.mechanism
        if mech.n_loop_constraints:
            raise StudySpecError(f"{source}: scene {scene_name!r} has loop constraints; the "
                                 "impacts kind batches open trees only")
        contact = options.pop("contact", scene.impact_contact or mech.contact_names[0])
        if contact not in mech.contact_names:
            raise StudySpecError(f"{source}: options.contact {contact!r} is not a contact of "
                                 f"{scene_name!r}: {', '.join(mech.contact_names)}")
        state = scene.impact_state or (scene.theta0, scene.dtheta0)
        k = mech.n_coordinates
        for key, default in (("theta", state[0]), ("dtheta", state[1])):
            v = options.pop(key, None)
            v = [float(x) for x in np.asarray(default, float)] if v is None else v
            if not isinstance(v, list) or len(v) != k:
                raise StudySpecError(f"{source}: options.{key} must be a list of {k} numbers")
            out[key] = [check_value(ParameterInfo(key), x, f"{source}: options.{key}[{i}]")
                        for i, x in enumerate(v)]
        e0, mu0 = mech.contact_parameters(contact)
        params = self._parameters(k, tuple(LAW_CODES))
        out["contact"] = contact
        for key, default in (("e", e0), ("mu", mu0), ("law", "pereira-nikravesh")):
            out[key] = check_value(params[key], options.pop(key, default),
                                   f"{source}: options.{key}")
        if "e_t" in options:  # kept only when given (the specs without it are unchanged)
            out["e_t"] = check_value(params["e_t"], options.pop("e_t"), f"{source}: options.e_t")
        if options:
            raise StudySpecError(f"{source}: unknown option(s) {', '.join(options)} for kind "
                                 f"'impacts'; its options: scene, scene_parameters, contact, "
                                 f"theta, dtheta, e, mu, law, e_t")
        return out

    def check_spec(self, spec: StudySpec, source: str) -> None:
        """``e_t`` (an option, on the grid or sampled) needs a law that has one."""
        from ..impact.laws import TANGENTIAL_LAWS

        swept = set(spec.parameter_names)
        if "e_t" not in spec.options and "e_t" not in swept:
            return
        law_axis = next((a for a in spec.grid if a.name == "law"), None)
        laws = law_axis.values if law_axis is not None else (spec.options["law"],)
        if not any(law in TANGENTIAL_LAWS for law in laws):
            raise StudySpecError(
                f"{source}: e_t is the tangential restitution of law "
                f"{', '.join(map(repr, TANGENTIAL_LAWS))}; the study's law(s) "
                f"{', '.join(map(repr, laws))} have none: drop e_t or add that law")

    @staticmethod
    def _parameters(k: int, laws: tuple[str, ...]) -> dict[str, ParameterInfo]:
        out = {}
        for i in range(1, k + 1):
            out[f"theta{i}"] = ParameterInfo(f"theta{i}", units="rad or m",
                                             description=f"joint coordinate {i}")
            out[f"dtheta{i}"] = ParameterInfo(f"dtheta{i}", units="rad/s or m/s",
                                              description=f"joint velocity {i} before impact")
        out["e"] = ParameterInfo("e", low=0.0, high=1.0, description="restitution")
        out["mu"] = ParameterInfo("mu", low=0.0, description="friction coefficient")
        out["e_t"] = ParameterInfo("e_t", low=-1.0, high=1.0,
                                   description="tangential restitution (law chatterjee-ruina)")
        out["law"] = ParameterInfo("law", dtype="str", choices=laws, description="impact law")
        return out

    def parameters(self, options: Mapping[str, Any]) -> dict[str, ParameterInfo]:
        from ..impact.batch.impacts import LAW_CODES

        return self._parameters(len(options["theta"]), tuple(LAW_CODES))

    def _axes(self, options: Mapping[str, Any]) -> tuple[str, ...]:
        mech = scene_of(options).mechanism
        d = np.asarray(mech.contact_jacobian(options["contact"],
                                             np.asarray(options["theta"], float))).shape[0]
        return ("n", "t") if d == 2 else ("n", "t1", "t2")

    def outputs(self, spec: StudySpec) -> tuple[OutputVariable, ...]:
        from ..impact.batch.impacts import REGIMES, STATUS_NAMES

        ax = (("contact_axis", self._axes(spec.options)),)
        regimes = " ".join(f"{i}={r}" for i, r in enumerate(REGIMES))
        status = " ".join(f"{i}={s}" for i, s in STATUS_NAMES.items())
        return (
            OutputVariable("regime", "int8", "", f"regime code: -1=failed {regimes}"),
            OutputVariable("status", "int8", "", f"kernel status: {status}"),
            OutputVariable("impulse", "float64", "N s", "contact impulse", ax),
            OutputVariable("v_minus", "float64", "m/s", "contact velocity before", ax),
            OutputVariable("v_plus", "float64", "m/s", "contact velocity after", ax),
            OutputVariable("energy_before", "float64", "J", "kinetic energy before impact"),
            OutputVariable("energy_loss", "float64", "J", "kinetic energy lost (T- - T+)"),
        ) + tuple(OutputVariable(f, "bool", "", f.replace("_", " ")) for f in _FLAGS)

    def dataset_attrs(self, spec: StudySpec) -> dict[str, Any]:
        from ..impact.batch.impacts import REGIMES, STATUS_NAMES

        return {"regime_names": list(REGIMES),
                "status_names": [STATUS_NAMES[i] for i in sorted(STATUS_NAMES)]}

    def evaluate(self, spec: StudySpec, points: Mapping[str, np.ndarray]) -> ChunkOutput:
        from ..impact.batch.impacts import resolve_impacts
        from ..impact.laws import TANGENTIAL_LAWS

        o = spec.options
        shape = next(iter(points.values())).shape
        n = int(np.prod(shape))
        k = len(o["theta"])
        theta = np.tile(np.asarray(o["theta"], float), (n, 1))
        dtheta = np.tile(np.asarray(o["dtheta"], float), (n, 1))
        for i in range(k):
            if f"theta{i + 1}" in points:
                theta[:, i] = points[f"theta{i + 1}"].ravel()
            if f"dtheta{i + 1}" in points:
                dtheta[:, i] = points[f"dtheta{i + 1}"].ravel()
        e = points["e"].ravel().astype(float) if "e" in points else np.full(n, o["e"])
        mu = points["mu"].ravel().astype(float) if "mu" in points else np.full(n, o["mu"])
        e_t = (points["e_t"].ravel().astype(float) if "e_t" in points
               else np.full(n, float(o.get("e_t", 0.0))))
        law = points["law"].ravel() if "law" in points else np.full(n, o["law"], object)
        mech = scene_of(o).mechanism
        configs, index = np.unique(theta, axis=0, return_inverse=True)
        index = index.ravel()
        Ms = np.array([np.asarray(mech.mass_matrix(q), float) for q in configs])
        Js = np.array([np.asarray(mech.contact_jacobian(o["contact"], q), float)
                       for q in configs])
        d = Js.shape[1]
        out = {"regime": np.full(n, -1, np.int8), "status": np.zeros(n, np.int8),
               "energy_before": np.full(n, np.nan), "energy_loss": np.full(n, np.nan)}
        for key in ("impulse", "v_minus", "v_plus"):
            out[key] = np.full((n, d), np.nan)
        for f in _FLAGS:
            out[f] = np.zeros(n, bool)
        for name in sorted(set(law.tolist())):
            sel = np.nonzero(law == name)[0]
            # one thread: the study runs its chunks in parallel processes already
            law_params = {"e_t": e_t[sel]} if name in TANGENTIAL_LAWS else {}
            b = resolve_impacts(Ms[index[sel]], Js[index[sel]], dtheta[sel], e[sel], mu[sel],
                                law=str(name), threads=1, **law_params)
            out["regime"][sel] = b.regime
            out["status"][sel] = b.status
            out["energy_before"][sel] = b.energy_before
            out["energy_loss"][sel] = b.energy_loss
            for key in ("impulse", "v_minus", "v_plus"):
                out[key][sel] = getattr(b, key)
            for f in _FLAGS:
                out[f][sel] = getattr(b, f)
        arrays = {k_: v.reshape(shape + v.shape[1:]) for k_, v in out.items()}
        return ChunkOutput(arrays, {"configurations": int(configs.shape[0])})


register_kind(ImpactsKind())
