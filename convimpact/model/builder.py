"""The model: a validated, immutable description of a mechanism (Pinocchio's ``Model``).

:class:`ModelBuilder` collects bodies (each attached to its parent by a joint), loop-closing
cut joints, contacts and applied forces, validates every entry as it is added, and
:meth:`ModelBuilder.build` freezes them into a :class:`Model`. Evaluations at a state live
elsewhere (:mod:`.kinematics`, :mod:`.dynamics`, :mod:`.loops`, :mod:`.contacts`) and cache
per-state quantities in a :class:`~convimpact.model.data.Data`.

Conventions
-----------
* The ground is body 0, named ``"ground"``; it has no coordinates.
* A body's frame is its joint frame after the joint's motion. The joint frame is placed in
  the parent's frame by ``joint_origin`` and ``joint_rotation`` (planar: an angle in radians;
  spatial: a 3 x 3 rotation matrix). ``com`` and ``inertia`` (about the centre of mass) are
  expressed in the body frame, as in Pinocchio.
* Joint coordinates are numbered in the order the bodies are added (tree order).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from ..errors import ModelError
from .data import Data
from .geometry import orthonormal_complement, rot2
from .joints import Joint, Motion
from .mechanism import ModelMechanism
from .specs import BodyInfo, ContactSpec, LoopSpec

GROUND = "ground"
#: tolerance on inertia symmetry / eigenvalues relative to the largest entry
INERTIA_RTOL = 1e-9

AppliedForces = Callable[[float, np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class Model:
    """An immutable mechanism description; create it with :class:`ModelBuilder`.

    Attributes
    ----------
    planar : bool
        True for x-y plane kinematics (positions 2-vectors, angular quantities 1-vectors).
    gravity : (d,) gravitational acceleration.
    bodies : tuple of BodyInfo, ``bodies[0]`` is the ground.
    coordinate_names : names of the k joint coordinates.
    support : (n_bodies, k) bool, ``support[b, j]`` when coordinate j moves body b.
    contacts : tuple of ContactSpec in declaration order.
    loops : tuple of LoopSpec (cut joints).
    applied_forces : callable ``(t, theta, dtheta) -> (k,)`` joint forces/torques, or None.
    """

    planar: bool
    gravity: np.ndarray
    bodies: tuple[BodyInfo, ...]
    coordinate_names: tuple[str, ...]
    coordinate_body: np.ndarray  # (k,) owning body of each coordinate
    coordinate_motion: tuple[Motion, ...]
    support: np.ndarray
    contacts: tuple[ContactSpec, ...]
    loops: tuple[LoopSpec, ...]
    applied_forces: Optional[AppliedForces] = None
    _contact_index: dict = field(default_factory=dict)

    @property
    def dim(self) -> int:
        """Dimension of positions: 2 (planar) or 3 (spatial)."""
        return 2 if self.planar else 3

    @property
    def rot_dim(self) -> int:
        """Dimension of angular velocities: 1 (planar) or 3 (spatial)."""
        return 1 if self.planar else 3

    @property
    def n_coordinates(self) -> int:
        return len(self.coordinate_names)

    @property
    def n_bodies(self) -> int:
        """Number of bodies including the ground."""
        return len(self.bodies)

    @property
    def n_loop_constraints(self) -> int:
        return sum(lp.n_rows for lp in self.loops)

    @property
    def contact_names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.contacts)

    def body_index(self, name: str) -> int:
        """Index of body ``name`` (0 is the ground). Raises ModelError for unknown names."""
        for b in self.bodies:
            if b.name == name:
                return b.index
        raise ModelError(f"unknown body {name!r}; bodies are {', '.join(b.name for b in self.bodies)}")

    def joint_coordinates(self, joint_name: str) -> tuple[int, ...]:
        """Indices in theta of joint ``joint_name``'s coordinates. ModelError if unknown."""
        for b in self.bodies[1:]:
            if b.joint_name == joint_name:
                return b.coordinates
        raise ModelError(f"unknown joint {joint_name!r}; joints are "
                         f"{', '.join(b.joint_name for b in self.bodies[1:])}")

    def coordinate_index(self, name: str) -> int:
        """Index in theta of the coordinate (or one-coordinate joint) called ``name``."""
        if name in self.coordinate_names:
            return self.coordinate_names.index(name)
        idx = self.joint_coordinates(name)
        if len(idx) != 1:
            raise ModelError(f"joint {name!r} has {len(idx)} coordinates; name one of "
                             f"{', '.join(self.coordinate_names[i] for i in idx)}")
        return idx[0]

    def contact(self, name: str) -> ContactSpec:
        """The contact called ``name``. Raises ModelError for unknown names."""
        try:
            return self.contacts[self._contact_index[name]]
        except KeyError:
            raise ModelError(f"unknown contact {name!r}; contacts are "
                             f"{', '.join(self.contact_names) or 'none'}") from None

    def create_data(self) -> Data:
        """A fresh :class:`~convimpact.model.data.Data` workspace for this model."""
        return Data(self)

    def mechanism(self) -> ModelMechanism:
        """This model as a :class:`convimpact.mechanism.Mechanism` (a :class:`ModelMechanism`)."""
        return ModelMechanism(self)


def _vec(value, d: int, what: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be a numeric {d}-vector, got {value!r}") from None
    if a.shape != (d,) or not np.all(np.isfinite(a)):
        raise ModelError(f"{what} must be a finite {d}-vector, got {value!r}")
    return a


def _rotation(value, planar: bool, what: str) -> tuple[np.ndarray, float]:
    if planar:
        angle = 0.0 if value is None else value
        try:
            angle = float(angle)
        except (TypeError, ValueError):
            raise ModelError(f"{what} of a planar model is an angle in radians, got {value!r}") from None
        if not np.isfinite(angle):
            raise ModelError(f"{what} must be finite, got {value!r}")
        return rot2(angle), angle
    if value is None:
        return np.eye(3), 0.0
    R = np.asarray(value, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ModelError(f"{what} of a spatial model is a 3 x 3 rotation matrix, got shape {R.shape}")
    if np.max(np.abs(R.T @ R - np.eye(3))) > 1e-9 or np.linalg.det(R) < 0:
        raise ModelError(f"{what} is not a proper rotation (R^T R != I or det R < 0)")
    return R, 0.0


def _inertia(value, planar: bool, allow_singular: bool, body: str) -> np.ndarray:
    hint = ("; pass allow_singular_inertia=True for an idealised slender rod or point mass "
            "whose joints never turn it about a zero-inertia axis")
    if planar:
        try:
            izz = float(np.asarray(value, dtype=float).ravel()[0]) if np.size(value) == 1 else None
        except (TypeError, ValueError):
            izz = None
        if izz is None or not np.isfinite(izz):
            raise ModelError(f"body {body!r}: planar inertia is the scalar I_zz about the centre "
                             f"of mass, got {value!r}")
        if izz < 0 or (izz == 0 and not allow_singular):
            raise ModelError(f"body {body!r}: inertia I_zz = {izz} must be positive"
                             + (hint if izz == 0 else ""))
        return np.array([[izz]])
    try:
        Ival = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"body {body!r}: inertia must be a 3 x 3 matrix, got {value!r}") from None
    if Ival.shape == (3,):
        Ival = np.diag(Ival)
    if Ival.shape != (3, 3) or not np.all(np.isfinite(Ival)):
        raise ModelError(f"body {body!r}: inertia must be a finite 3 x 3 matrix (or 3 principal "
                         f"moments), got shape {Ival.shape}")
    scale = max(float(np.max(np.abs(Ival))), 1e-300)
    if np.max(np.abs(Ival - Ival.T)) > INERTIA_RTOL * scale:
        raise ModelError(f"body {body!r}: inertia tensor is not symmetric")
    lam = np.linalg.eigvalsh(0.5 * (Ival + Ival.T))
    negative = lam[0] < -INERTIA_RTOL * scale
    if negative or (lam[0] <= INERTIA_RTOL * scale and not allow_singular):
        raise ModelError(f"body {body!r}: inertia tensor is not positive definite (principal "
                         f"moments {np.round(lam, 12).tolist()})" + ("" if negative else hint))
    if lam[2] > lam[0] + lam[1] + INERTIA_RTOL * scale:
        raise ModelError(f"body {body!r}: principal moments {lam.tolist()} violate the triangle "
                         "inequality I3 <= I1 + I2 that every rigid body satisfies")
    return 0.5 * (Ival + Ival.T)


class ModelBuilder:
    """Collects a mechanism's description, validating each entry; :meth:`build` freezes it.

    Parameters
    ----------
    planar : bool
        True for planar (x-y) kinematics, False for spatial.
    gravity : array_like, optional
        Gravitational acceleration, default ``(0, -9.81)`` planar / ``(0, -9.81, 0)`` spatial
        (y is vertical, as in the paper's figures).

    Examples
    --------
    A planar pendulum of one slender rod:

    >>> b = ModelBuilder(planar=True)
    >>> _ = b.add_body("rod", parent="ground", joint=Joint.revolute(), mass=1.0,
    ...                com=(0.5, 0.0), inertia=1 / 12)
    >>> model = b.build()
    >>> model.n_coordinates, model.coordinate_names
    (1, ('rod',))
    """

    def __init__(self, planar: bool, gravity=None):
        self.planar = bool(planar)
        d = 2 if self.planar else 3
        if gravity is None:
            gravity = np.eye(d)[1] * -9.81
        self.gravity = _vec(gravity, d, "gravity")
        self._bodies: list[BodyInfo] = [BodyInfo(
            name=GROUND, index=0, parent=-1, joint=Joint.fixed(), joint_name=GROUND, motions=(),
            coordinates=(), placement_rotation=np.eye(d), placement_origin=np.zeros(d),
            placement_angle=0.0, mass=0.0, com=np.zeros(d), inertia=np.zeros((1 if planar else 3,) * 2))]
        self._coord_names: list[str] = []
        self._coord_body: list[int] = []
        self._coord_motion: list[Motion] = []
        self._contacts: list[ContactSpec] = []
        self._loops: list[LoopSpec] = []
        self._applied: Optional[AppliedForces] = None

    @property
    def _d(self) -> int:
        return 2 if self.planar else 3

    def _index(self, name: str, what: str = "body") -> int:
        for b in self._bodies:
            if b.name == name:
                return b.index
        raise ModelError(f"unknown {what} {name!r}; bodies so far are "
                         f"{', '.join(b.name for b in self._bodies)}")

    def add_body(self, name: str, parent: str, joint: Joint, mass: float, com, inertia,
                 joint_origin=None, joint_rotation=None, joint_name: Optional[str] = None,
                 coordinate_names=None, allow_singular_inertia: bool = False) -> int:
        """Add a rigid body attached to ``parent`` by ``joint``; return its index.

        Parameters
        ----------
        name : unique body name (not "ground").
        parent : name of an existing body or "ground".
        joint : a :class:`Joint`.
        mass : positive mass.
        com : centre of mass in the body frame, (d,).
        inertia : planar I_zz (scalar) or spatial 3 x 3 tensor (or 3 principal moments), about
            the centre of mass in the body frame; symmetric positive definite.
        joint_origin, joint_rotation : placement of the joint frame in the parent frame.
        joint_name : defaults to the body name.
        coordinate_names : names of the joint's coordinates (default ``joint_name`` for one
            coordinate, ``joint_name[i]`` for several).
        allow_singular_inertia : accept zero principal moments (slender rods, point masses).

        Raises
        ------
        ModelError
            Duplicate or unknown names, non-positive mass, bad inertia, bad axes or placement.
        """
        d = self._d
        if not isinstance(name, str) or not name:
            raise ModelError(f"a body name must be a non-empty string, got {name!r}")
        if any(b.name == name for b in self._bodies):
            raise ModelError(f"body {name!r} already exists; body names must be unique")
        pidx = self._index(parent, "parent body")
        if not isinstance(joint, Joint):
            raise ModelError(f"joint must be a convimpact.model.Joint, got {type(joint).__name__}")
        motions = joint.motions(self.planar)
        try:
            mass = float(mass)
        except (TypeError, ValueError):
            raise ModelError(f"body {name!r}: mass must be a number, got {mass!r}") from None
        if not np.isfinite(mass) or mass <= 0.0:
            raise ModelError(f"body {name!r}: mass must be positive and finite, got {mass}")
        com = _vec(com, d, f"body {name!r}: com")
        I = _inertia(inertia, self.planar, allow_singular_inertia, name)
        origin = (np.zeros(d) if joint_origin is None
                  else _vec(joint_origin, d, f"body {name!r}: joint_origin"))
        R0, angle0 = _rotation(joint_rotation, self.planar, f"body {name!r}: joint_rotation")
        jname = name if joint_name is None else str(joint_name)
        if any(b.joint_name == jname for b in self._bodies):
            raise ModelError(f"joint {jname!r} already exists; joint names must be unique")
        n = len(motions)
        if coordinate_names is None:
            cnames = [jname] if n == 1 else [f"{jname}[{i}]" for i in range(n)]
        else:
            cnames = [str(c) for c in coordinate_names]
            if len(cnames) != n:
                raise ModelError(f"joint {jname!r} has {n} coordinates, got {len(cnames)} names")
        for c in cnames:
            if c in self._coord_names:
                raise ModelError(f"coordinate name {c!r} already exists")
        start = len(self._coord_names)
        coords = tuple(range(start, start + n))
        idx = len(self._bodies)
        self._coord_names += cnames
        self._coord_body += [idx] * n
        self._coord_motion += list(motions)
        self._bodies.append(BodyInfo(
            name=name, index=idx, parent=pidx, joint=joint, joint_name=jname, motions=motions,
            coordinates=coords, placement_rotation=R0, placement_origin=origin,
            placement_angle=angle0, mass=mass, com=com, inertia=I))
        return idx

    def add_contact(self, name: str, body: str, point, against: str = GROUND, plane_point=None,
                    normal=None, tangent=None, radius: float = 0.0, sphere_center=None,
                    sphere_radius: float = 0.0, e: float = 0.0, mu: float = 0.0) -> None:
        """Add a candidate contact between a point/sphere on ``body`` (body i) and ``against``.

        Parameters
        ----------
        name : unique contact name.
        body : body i carrying the point (sphere centre) ``point`` (body-frame coordinates).
        against : body j (default the ground).
        plane_point, normal : a plane on body j (its frame) with the normal toward body i.
        tangent : spatial only: t1 in body j's frame (projected onto the plane); default a
            deterministic completion. Planar contacts use ``t = n`` turned by +90 degrees.
        radius : radius of a sphere (disc) centred at ``point`` (0: a point).
        sphere_center, sphere_radius : instead of a plane, a sphere on body j (centre in its
            frame); the normal is then the unit vector from that centre toward body i's.
        e, mu : coefficients of restitution (in [0, 1]) and friction (>= 0).

        Raises
        ------
        ModelError
            Unknown bodies, duplicate name, bad geometry or parameters.
        """
        d = self._d
        if any(c.name == name for c in self._contacts):
            raise ModelError(f"contact {name!r} already exists; contact names must be unique")
        bi = self._index(body, "contact body")
        bj = self._index(against, "contact body")
        if bi == 0:
            raise ModelError(f"contact {name!r}: body i must be a moving body, not the ground")
        if bi == bj:
            raise ModelError(f"contact {name!r}: a body cannot contact itself")
        point = _vec(point, d, f"contact {name!r}: point")
        radius = float(radius)
        if not np.isfinite(radius) or radius < 0:
            raise ModelError(f"contact {name!r}: radius must be >= 0, got {radius}")
        e, mu = float(e), float(mu)
        if not (0.0 <= e <= 1.0):
            raise ModelError(f"contact {name!r}: coefficient of restitution must lie in [0, 1], got {e}")
        if not (np.isfinite(mu) and mu >= 0.0):
            raise ModelError(f"contact {name!r}: coefficient of friction must be >= 0, got {mu}")
        if (sphere_center is None) == (normal is None):
            raise ModelError(f"contact {name!r}: give either a plane (plane_point, normal) or a "
                             "sphere (sphere_center, sphere_radius) on the other body")
        t = None
        if normal is not None:
            n = _vec(normal, d, f"contact {name!r}: normal")
            if np.linalg.norm(n) < 1e-12:
                raise ModelError(f"contact {name!r}: the normal is zero")
            n = n / np.linalg.norm(n)
            o = np.zeros(d) if plane_point is None else _vec(plane_point, d, f"contact {name!r}: plane_point")
            if not self.planar:
                if tangent is None:
                    t, _ = orthonormal_complement(n)
                else:
                    t = _vec(tangent, 3, f"contact {name!r}: tangent")
                    t = t - (t @ n) * n
                    if np.linalg.norm(t) < 1e-9:
                        raise ModelError(f"contact {name!r}: tangent is parallel to the normal")
                    t = t / np.linalg.norm(t)
            elif tangent is not None:
                raise ModelError(f"contact {name!r}: a planar contact has t = n turned by +90 "
                                 "degrees; do not pass tangent (flip the normal instead)")
            spec = ContactSpec(name, bi, point, radius, "plane", bj, o, n, t, 0.0, e, mu)
        else:
            c = _vec(sphere_center, d, f"contact {name!r}: sphere_center")
            rj = float(sphere_radius)
            if not np.isfinite(rj) or rj < 0:
                raise ModelError(f"contact {name!r}: sphere_radius must be >= 0, got {rj}")
            spec = ContactSpec(name, bi, point, radius, "sphere", bj, c, None, None, rj, e, mu)
        self._contacts.append(spec)

    def add_loop(self, name: str, kind: str, body_a: str, body_b: str, origin_a=None,
                 origin_b=None, rotation_a=None, rotation_b=None) -> None:
        """Close a loop with a cut joint between a frame on ``body_a`` and one on ``body_b``.

        Parameters
        ----------
        kind : planar "revolute" or "prismatic" (slide along frame a's x axis); spatial
            "revolute" (about the z axes), "prismatic" (along the z axes) or "spherical".
        origin_a, origin_b : frame origins in the bodies' frames.
        rotation_a, rotation_b : frame orientations (planar angles / spatial 3 x 3 matrices).
            The joint is assembled when the two frames coincide up to its free motion.
        """
        d = self._d
        kinds = ("revolute", "prismatic") if self.planar else ("revolute", "prismatic", "spherical")
        if kind not in kinds:
            raise ModelError(f"loop {name!r}: unknown cut joint kind {kind!r}; use one of {', '.join(kinds)}")
        if any(lp.name == name for lp in self._loops):
            raise ModelError(f"loop {name!r} already exists")
        a = self._index(body_a, "loop body")
        b = self._index(body_b, "loop body")
        if a == b:
            raise ModelError(f"loop {name!r}: a cut joint connects two different bodies")
        oa = np.zeros(d) if origin_a is None else _vec(origin_a, d, f"loop {name!r}: origin_a")
        ob = np.zeros(d) if origin_b is None else _vec(origin_b, d, f"loop {name!r}: origin_b")
        Ra, aa = _rotation(rotation_a, self.planar, f"loop {name!r}: rotation_a")
        Rb, ab = _rotation(rotation_b, self.planar, f"loop {name!r}: rotation_b")
        self._loops.append(LoopSpec(name, kind, a, oa, Ra, aa, b, ob, Rb, ab))

    def set_applied_forces(self, forces: Optional[AppliedForces]) -> None:
        """Joint forces/torques ``forces(t, theta, dtheta) -> (k,)`` added to f (eq. 4)."""
        if forces is not None and not callable(forces):
            raise ModelError("applied forces must be a callable (t, theta, dtheta) -> (k,) or None")
        self._applied = forces

    def build(self) -> Model:
        """Freeze the description into an immutable :class:`Model`.

        Raises
        ------
        ModelError
            When the tree has no coordinates.
        """
        k = len(self._coord_names)
        if k == 0:
            raise ModelError("the model has no joint coordinates; add a body with a moving joint")
        nb = len(self._bodies)
        support = np.zeros((nb, k), dtype=bool)
        for b in self._bodies[1:]:
            support[b.index] = support[b.parent]
            support[b.index, list(b.coordinates)] = True
        contacts = tuple(self._contacts)
        return Model(
            planar=self.planar, gravity=self.gravity.copy(), bodies=tuple(self._bodies),
            coordinate_names=tuple(self._coord_names),
            coordinate_body=np.array(self._coord_body, dtype=int),
            coordinate_motion=tuple(self._coord_motion), support=support,
            contacts=contacts, loops=tuple(self._loops), applied_forces=self._applied,
            _contact_index={c.name: i for i, c in enumerate(contacts)},
        )


__all__ = ["GROUND", "BodyInfo", "ContactSpec", "LoopSpec", "Model", "ModelBuilder"]
