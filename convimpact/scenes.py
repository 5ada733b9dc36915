"""Scenes: a mechanism with its initial state and parameters, ready to simulate or to impact.

Every module of :mod:`convimpact.problems` (the top-level ``problems/`` folder) that defines
``make_scene(**params) -> Scene`` is a scene; :func:`list_scenes` names them and
:func:`load_scene` builds one. A scene declares its parameters' types and ranges once, in its
module's ``PARAMETERS`` (name -> :class:`convimpact.validation.Spec`, e.g. ``{"e": Unit(),
"radius": Positive()}``), which ``load_scene`` checks before the scene is built.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from .errors import ConvImpactError, NonFiniteError, ParameterError, UnknownOptionError
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
        default. ``convimpact simulate`` follows it. ``"breakpoints"``: times where the
        applied forces have a kink (event-driven runs end a segment there, see
        :func:`convimpact.simulation.simulate`).
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


def scene_parameters(name: str) -> Mapping[str, Any]:
    """The parameter specs scene ``name`` declares (its module's ``PARAMETERS``: parameter
    name -> :class:`convimpact.validation.Spec`), or an empty mapping for a scene that
    declares none."""
    mod = _scene_module(name)
    return MappingProxyType(dict(getattr(mod, "PARAMETERS", {})))


def _scene_module(name):
    if not isinstance(name, str) or name not in list_scenes():
        raise UnknownOptionError(
            f"unknown scene {name!r}; available: {', '.join(list_scenes()) or 'none'}")
    return importlib.import_module(f"convimpact.problems.{name}")


def load_scene(name: str, **params) -> Scene:
    """Build scene ``name`` with optional parameters.

    Each parameter is checked against the range the scene declares for it (its module's
    ``PARAMETERS``, see :func:`scene_parameters`) before the scene is built: an unknown name
    raises :class:`UnknownOptionError` listing the scene's parameters, a value of the wrong
    type or out of range a :class:`ParameterError` (:class:`NonFiniteError` for NaN or
    infinity) naming the parameter and its range.
    """
    from .validation import check_parameters

    mod = _scene_module(name)
    sig = inspect.signature(mod.make_scene)
    specs = getattr(mod, "PARAMETERS", None)
    if specs is not None:
        params = check_parameters(f"scene {name!r}", specs, params)
    else:
        accepts_any = any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values())
        unknown = [k for k in params if k not in sig.parameters and not accepts_any]
        if unknown:
            raise UnknownOptionError(
                f"scene {name!r} has no parameter {', '.join(map(repr, unknown))}; its "
                f"parameters: {', '.join(sig.parameters) or 'none'}")
    try:
        return mod.make_scene(**params)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ConvImpactError):
            raise
        raise ParameterError(f"bad parameter for scene {name!r}: {exc}") from None
    except (OverflowError, ZeroDivisionError) as exc:
        given = ", ".join(f"{k}={v!r}" for k, v in params.items()) or "its defaults"
        raise NonFiniteError(
            f"scene {name!r} with {given}: a figure of the scene leaves double precision's "
            f"range ({exc}); choose values of ordinary magnitude") from None
