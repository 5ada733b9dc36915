"""Scenes: a mechanism with its initial state and parameters, ready to simulate or to impact.

Every module of :mod:`convimpact.problems` (the top-level ``problems/`` folder) that defines
``make_scene(**params) -> Scene`` is a scene; :func:`list_scenes` names them and
:func:`load_scene` builds one.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from .impact.errors import ConvImpactError, ParameterError, UnknownOptionError
from .mechanism import Mechanism


@dataclass(frozen=True, eq=False)
class Scene:
    """A mechanism, where it starts, and what the scene assumes.

    Attributes
    ----------
    name : module name of the scene in ``problems/``.
    description : one paragraph, including every assumption the paper leaves open.
    mechanism : the model, satisfying :class:`convimpact.mechanism.Mechanism`.
    theta0, dtheta0 : initial joint coordinates and velocities for simulation.
    t_end : default simulated time span [0, t_end].
    parameters : JSON-ready scene parameters (masses, lengths, e, mu, assumptions).
    impact_state : (theta, dtheta) at the paper's impact instant, or None.
    impact_contact : name of the contact that strikes at ``impact_state``, or None.
    outlines : per body name, an (n, 2) (planar) or (n, 3) (spatial) array of body-frame
        points outlining the body, or None: drawing only, the dynamics never read it. The
        animation (:func:`convimpact.simulation.animation.animate`) draws a planar body as
        the polygon through its points in order, a spatial one as the convex hull of the
        projected points; a body without an outline is drawn as the hull of its joints and
        contact points.
    simulation : None, or how the scene is meant to be simulated when the caller does not
        say: ``{"scheme": "moreau-jean", "h": ..., "law": ...}`` (the scheme of
        :func:`convimpact.simulation.simulate_with` and its options); None is the event-driven
        default. ``convimpact simulate`` follows it.
    """

    name: str
    description: str
    mechanism: Mechanism
    theta0: np.ndarray
    dtheta0: np.ndarray
    t_end: float
    parameters: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    impact_state: tuple[np.ndarray, np.ndarray] | None = None
    impact_contact: str | None = None
    outlines: Mapping[str, np.ndarray] | None = None
    simulation: Mapping[str, Any] | None = None


def list_scenes() -> list[str]:
    """Names of the scenes in ``convimpact.problems``."""
    import convimpact.problems as pkg

    names = []
    for info in pkgutil.iter_modules(pkg.__path__):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"convimpact.problems.{info.name}")
        if callable(getattr(mod, "make_scene", None)):
            names.append(info.name)
    return sorted(names)


def load_scene(name: str, **params) -> Scene:
    """Build scene ``name`` with optional parameters."""
    if name not in list_scenes():
        raise UnknownOptionError(
            f"unknown scene {name!r}; available: {', '.join(list_scenes()) or 'none'}")
    mod = importlib.import_module(f"convimpact.problems.{name}")
    sig = inspect.signature(mod.make_scene)
    accepts_any = any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values())
    unknown = [k for k in params if k not in sig.parameters and not accepts_any]
    if unknown:
        raise UnknownOptionError(
            f"scene {name!r} has no parameter {', '.join(map(repr, unknown))}; its parameters: "
            f"{', '.join(sig.parameters) or 'none'}")
    try:
        return mod.make_scene(**params)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ConvImpactError):
            raise
        raise ParameterError(f"bad parameter for scene {name!r}: {exc}") from None
