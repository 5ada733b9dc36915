"""The world geometry an animation draws, from a model built with ModelBuilder.

:func:`collect_geometry` places, at every frame state, what :class:`~convimpact.simulation.
animation.MechanismAnimation` draws: the points of each body (its outline when one is given,
else its joint origin, centre of mass, child joint origins, loop-joint frames and contact
points), revolute pins, loop-joint frames, prismatic rails, contact discs, contact frames and
the planes and spheres carried by moving bodies. :func:`ground_planes` groups the plane
contacts against the ground into the ground lines or floors to draw.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..errors import NotSupportedError, ParameterError, ShapeError


def check_animatable(mechanism: Any):
    """The :class:`~convimpact.model.builder.Model` behind ``mechanism``.

    Raises
    ------
    NotSupportedError
        When ``mechanism`` was not built with ModelBuilder (a user-defined Mechanism has no
        geometry to draw).
    """
    from ..model.builder import Model

    model = getattr(mechanism, "model", None)
    if not isinstance(model, Model):
        raise NotSupportedError(
            f"animation needs a mechanism built with convimpact.model.ModelBuilder "
            f"(model.mechanism()); {type(mechanism).__name__} is a user-defined Mechanism "
            "whose bodies and contact geometry are unknown")
    return model


def check_outlines(model, outlines: Mapping[str, Any] | None) -> dict[int, np.ndarray]:
    """Body-frame outlines keyed by body index, checked against ``model``.

    Parameters
    ----------
    model : the :class:`~convimpact.model.builder.Model`.
    outlines : None or, per body name, an (n, d) array of body-frame points (n >= 2,
        d the model's dimension).

    Raises
    ------
    ParameterError
        An outline of a body the model does not have (or of the ground), or with non-finite
        points.
    ShapeError
        An outline that is not an (n, d) array with n >= 2.
    """
    if outlines is None:
        return {}
    names = [b.name for b in model.bodies[1:]]
    checked = {}
    for name, points in dict(outlines).items():
        if name not in names:
            raise ParameterError(f"outline of unknown body {name!r}; the model's moving bodies: "
                                 f"{', '.join(names) or 'none'}")
        try:
            arr = np.array(points, dtype=float)
        except (TypeError, ValueError):
            raise ShapeError(f"the outline of {name!r} must be an (n, {model.dim}) array of "
                             "body-frame points") from None
        if arr.ndim != 2 or arr.shape[1] != model.dim or len(arr) < 2:
            raise ShapeError(f"the outline of {name!r} must be an (n, {model.dim}) array of "
                             f"body-frame points with n >= 2, got shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ParameterError(f"the outline of {name!r} has non-finite points")
        checked[model.body_index(name)] = arr
    return checked


def body_hull_points(model, b: int) -> np.ndarray:
    """Body-frame points whose hull draws body b (origin, COM, child joints, loops, contacts)."""
    pts = [np.zeros(model.dim), model.bodies[b].com]
    pts += [c.placement_origin for c in model.bodies if c.parent == b]
    for lp in model.loops:
        if lp.body_a == b:
            pts.append(lp.origin_a)
        if lp.body_b == b:
            pts.append(lp.origin_b)
    for spec in model.contacts:
        if spec.body == b:
            pts.append(spec.point)
        if spec.other == b:
            pts.append(spec.other_point)
    return np.array(pts, dtype=float)


@dataclass
class FrameGeometry:
    """World geometry of every frame (from :func:`collect_geometry`).

    ``n`` frames, ``d`` the dimension, ``nc`` the number of contacts; "moving bodies" are
    ``model.bodies[1:]``.
    """

    bodies: list = field(default_factory=list)  # per moving body: (n, points of the body, d)
    outlined: list = field(default_factory=list)  # per moving body: drawn from an outline?
    pins: Any = None  # (n, revolute joints, d)
    loop_pins: Any = None  # (n, 2 per loop, d): the frames on body a and body b
    rails: list = field(default_factory=list)  # per prismatic joint: (n, 2, d) ends
    disc_centres: list = field(default_factory=list)  # per disc: (n, d)
    disc_marks: list = field(default_factory=list)  # per disc: (n, d), a point on the rim
    contact_points: Any = None  # (n, nc, d)
    contact_normals: Any = None  # (n, nc, d)
    contact_tangents: Any = None  # (n, nc, d - 1, d)
    moving_planes: list = field(default_factory=list)  # per plane: point, normal, tangents
    moving_spheres: list = field(default_factory=list)  # per sphere: (n, d) centre
    pin_bodies: list = field(default_factory=list)  # bodies on revolute joints (pins)
    rail_bodies: list = field(default_factory=list)  # bodies on one prismatic joint (rails)
    disc_contacts: list = field(default_factory=list)  # contacts with a sphere (radius > 0)
    plane_contacts: list = field(default_factory=list)  # contacts against a moving plane
    sphere_contacts: list = field(default_factory=list)  # contacts against a moving sphere


def collect_geometry(model, mechanism: Any, theta: np.ndarray, run_theta: np.ndarray,
                     outlines: Mapping[int, np.ndarray] | None = None) -> FrameGeometry:
    """World geometry at every frame state.

    Parameters
    ----------
    model : the :class:`~convimpact.model.builder.Model` of ``mechanism``.
    mechanism : its mechanism (``body_placement``, ``contact_frame``).
    theta : (n, k) frame states.
    run_theta : (m, k) all states of the run (the prismatic rails span their range).
    outlines : body-frame outlines keyed by body index (see :func:`check_outlines`); a body
        with one is placed from its outline points, the others from :func:`body_hull_points`.
    """
    outlines = outlines or {}
    n, d = len(theta), model.dim
    bodies = model.bodies[1:]
    local = {b.index: outlines.get(b.index, None) for b in bodies}
    local = {b: pts if pts is not None else body_hull_points(model, b) for b, pts in local.items()}
    f = FrameGeometry()
    f.outlined = [b.index in outlines for b in bodies]
    f.pin_bodies = [b.index for b in bodies
                    if b.motions and all(m.kind == "revolute" for m in b.motions)]
    f.rail_bodies = [b.index for b in bodies
                     if len(b.motions) == 1 and b.motions[0].kind == "prismatic"]
    f.disc_contacts = [i for i, s in enumerate(model.contacts) if s.radius > 0]
    f.plane_contacts = [i for i, s in enumerate(model.contacts)
                        if s.target == "plane" and s.other != 0]
    f.sphere_contacts = [i for i, s in enumerate(model.contacts)
                         if s.target == "sphere" and s.other != 0]
    f.bodies = [np.zeros((n, len(local[b.index]), d)) for b in bodies]
    f.pins = np.zeros((n, len(f.pin_bodies), d))
    f.loop_pins = np.zeros((n, 2 * len(model.loops), d))
    f.rails = [np.zeros((n, 2, d)) for _ in f.rail_bodies]
    f.disc_centres = [np.zeros((n, d)) for _ in f.disc_contacts]
    f.disc_marks = [np.zeros((n, d)) for _ in f.disc_contacts]
    names = model.contact_names
    nc = len(names)
    f.contact_points = np.zeros((n, nc, d))
    f.contact_normals = np.zeros((n, nc, d))
    f.contact_tangents = np.zeros((n, nc, d - 1, d))
    f.moving_planes = [(np.zeros((n, d)), np.zeros((n, d)), np.zeros((n, d - 1, d)))
                       for _ in f.plane_contacts]
    f.moving_spheres = [np.zeros((n, d)) for _ in f.sphere_contacts]
    # prismatic coordinate ranges over the run, for the rails
    th_all = np.vstack([theta, run_theta])
    rail_range = []
    for b in f.rail_bodies:
        j = model.bodies[b].coordinates[0]
        rail_range.append((float(np.min(th_all[:, j])), float(np.max(th_all[:, j]))))
    for i, th in enumerate(theta):
        place = {b.index: mechanism.body_placement(b.name, th) for b in bodies}
        place[0] = (np.eye(d), np.zeros(d))
        for bi, b in enumerate(bodies):
            R, o = place[b.index]
            f.bodies[bi][i] = o + local[b.index] @ R.T
        for pi, b in enumerate(f.pin_bodies):
            f.pins[i, pi] = place[b][1]
        for li, lp in enumerate(model.loops):
            Ra, oa = place[lp.body_a]
            Rb, ob = place[lp.body_b]
            f.loop_pins[i, 2 * li] = oa + Ra @ lp.origin_a
            f.loop_pins[i, 2 * li + 1] = ob + Rb @ lp.origin_b
        for ri, b in enumerate(f.rail_bodies):
            info = model.bodies[b]
            Rp, op = place[info.parent]
            origin = op + Rp @ info.placement_origin
            axis = Rp @ info.placement_rotation @ info.motions[0].axis
            smin, smax = rail_range[ri]
            f.rails[ri][i] = [origin + smin * axis, origin + smax * axis]
        for ci, name in enumerate(names):
            cf = mechanism.contact_frame(name, th)
            f.contact_points[i, ci] = cf.point
            f.contact_normals[i, ci] = cf.normal
            f.contact_tangents[i, ci] = cf.tangents
        for di, c in enumerate(f.disc_contacts):
            spec = model.contacts[c]
            R, o = place[spec.body]
            f.disc_centres[di][i] = o + R @ spec.point
            f.disc_marks[di][i] = f.disc_centres[di][i] + spec.radius * R[:, 0]
        for pi, c in enumerate(f.plane_contacts):
            spec = model.contacts[c]
            R, o = place[spec.other]
            f.moving_planes[pi][0][i] = o + R @ spec.other_point
            f.moving_planes[pi][1][i] = f.contact_normals[i, c]
            f.moving_planes[pi][2][i] = f.contact_tangents[i, c]
        for si, c in enumerate(f.sphere_contacts):
            spec = model.contacts[c]
            R, o = place[spec.other]
            f.moving_spheres[si][i] = o + R @ spec.other_point
    return f


def ground_planes(model, frames: FrameGeometry
                  ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]]:
    """Distinct plane contacts against the ground: (point, normal, tangents, contacts)."""
    planes: list = []
    for ci, spec in enumerate(model.contacts):
        if spec.target != "plane" or spec.other != 0:
            continue
        n = spec.normal / np.linalg.norm(spec.normal)
        for pl in planes:
            if np.allclose(pl[1], n, atol=1e-9) and abs(n @ (spec.other_point - pl[0])) < 1e-9:
                pl[3].append(ci)
                break
        else:
            planes.append((spec.other_point.astype(float), n,
                           frames.contact_tangents[0, ci], [ci]))
    return planes
