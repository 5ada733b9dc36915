"""Any model Pinocchio loads (URDF, MJCF, its own API) as a full simulatable mechanism.

:class:`PinocchioMechanism` evaluates a ``pinocchio.Model`` through the
:class:`~convimpact.mechanism.Mechanism` protocol, so :func:`convimpact.resolve_impact` (through
:func:`convimpact.model.impact_arguments`), :func:`convimpact.simulate` and the landscapes
accept it:

* M(theta) by CRBA, f = -nonLinearEffects (+ applied forces), M_dot = C + C^T from Pinocchio's
  Coriolis matrix;
* contacts declared on frames (:class:`~convimpact.model.pinocchio_terms.PinocchioContact`):
  a point of a frame against a plane fixed in the world, gap = signed distance, Jacobian rows
  (n, t1, t2) in space or (n, t) for a planar model (embedded in the x-y plane), and their
  exact time derivative along theta_dot;
* point loop closures between two frames;
* kinetic energy 1/2 theta_dot^T M theta_dot, potential energy of gravity
  (``computePotentialEnergy``) plus that of conservative applied forces when given.

Loaders: :meth:`PinocchioMechanism.from_urdf` (a file, or a URDF string),
:meth:`PinocchioMechanism.from_mjcf`, and the constructor for a ``pinocchio.Model``.

The protocol needs theta_dot = d theta/dt, so quaternion joints (Pinocchio's free-flyer,
spherical and unbounded revolute joints; nq != nv) are refused. A floating base is offered as
:func:`root_joint` ``"free"``: prismatic joints along x, y, z (world axes) followed by revolute
joints about z, y, x (Z-Y-X Euler angles: yaw, pitch, roll), chained through massless bodies,
so theta_dot is the Euler angles' rate. (Pinocchio's ``SphericalZYX`` and composite joints
would do the same in one joint, but its Coriolis matrix is inexact for them: M_dot differs
from finite differences of M by 7 % on Solo-12; such joints are refused.)
Euler angles are singular at pitch = +-90 degrees: there M loses rank (the simulator stops with
a :class:`~convimpact.errors.SimulationError`); keep the base away from that attitude or
re-seat the angles between runs. ``"planar"`` is x, y and a rotation about z.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Callable, Optional, Sequence, Union

import numpy as np

from ..errors import (ModelError, NonFiniteError, NotSupportedError, ParameterError,
                             ShapeError)
from .pinocchio_terms import (FrameRef, PinocchioContact, _frame_id, _pin, _skew, contact_basis,
                              mass_matrix, point_loop_jacobian, point_loop_jacobian_dot)

ROOT_JOINTS = ("fixed", "free", "planar")

#: the root joints as chains of elementary joints: (coordinate name, Pinocchio joint class)
ROOT_CHAINS = {"free": (("base_x", "JointModelPX"), ("base_y", "JointModelPY"),
                        ("base_z", "JointModelPZ"), ("base_yaw", "JointModelRZ"),
                        ("base_pitch", "JointModelRY"), ("base_roll", "JointModelRX")),
               "planar": (("base_x", "JointModelPX"), ("base_y", "JointModelPY"),
                          ("base_angle", "JointModelRZ"))}
#: coordinate names given to the root joints' coordinates
ROOT_COORDINATES = {k: tuple(n for n, _ in v) for k, v in ROOT_CHAINS.items()}
#: joints whose Coriolis matrix Pinocchio computes exactly (constant motion subspace);
#: SphericalZYX, composite, planar and mimic joints give M_dot != C + C^T (checked against
#: finite differences of M) and are refused
EXACT_JOINTS = frozenset({"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelPX",
                          "JointModelPY", "JointModelPZ", "JointModelRevoluteUnaligned",
                          "JointModelPrismaticUnaligned", "JointModelTranslation"})


def root_joint(kind: str = "free") -> tuple:
    """The root joints offered by the loaders, as a chain of elementary Pinocchio joints
    (massless between them) whose velocity is its coordinates' time derivative (nq == nv).

    Parameters
    ----------
    kind : "free" (x, y, z translation in world axes, then Z-Y-X Euler angles: yaw about z,
        pitch about the turned y, roll about the twice-turned x; singular at pitch = +-90
        degrees), "planar" (x, y, then a rotation about z) or "fixed" (the model's root is
        welded: an empty chain).

    Returns
    -------
    tuple of (coordinate name, pinocchio.JointModel)
    """
    if kind not in ROOT_JOINTS:
        raise ParameterError(f"root_joint must be one of {', '.join(ROOT_JOINTS)}, got {kind!r} "
                             "(Pinocchio's quaternion free-flyer has nq != nv and is refused)")
    if kind == "fixed":
        return ()
    pin = _pin()
    return tuple((name, getattr(pin, cls)()) for name, cls in ROOT_CHAINS[kind])


def _build(pin, load, root):
    """``load(root_joint_or_None)`` -> pinocchio.Model, with the root chain prepended."""
    if root is None or isinstance(root, str):
        kind = root or "fixed"
        chain = root_joint(kind)
    else:
        kind, chain = "custom", (("root_joint", root),)
    if not chain:
        return load(None), kind
    robot = load(chain[-1][1])
    if len(chain) == 1:
        return robot, kind
    head = pin.Model()
    head.gravity = robot.gravity
    jid = 0
    for name, jm in chain[:-1]:
        jid = head.addJoint(jid, jm, pin.SE3.Identity(), name)
    fid = head.addFrame(pin.Frame("root_chain", jid, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    model = pin.appendModel(head, robot, fid, pin.SE3.Identity())
    model.names[len(chain)] = chain[-1][0]
    model.name = robot.name
    return model, kind


def _lift(v, planar: bool, name: str) -> np.ndarray:
    a = np.asarray(v, dtype=float).ravel()
    if planar and a.shape == (2,):
        a = np.array([a[0], a[1], 0.0])
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ShapeError(f"{name} must be a finite 3-vector{' (or 2-vector, planar)' if planar else ''}"
                         f", got {v!r}")
    return a


class PinocchioMechanism:
    """A Pinocchio model through the :class:`~convimpact.mechanism.Mechanism` protocol.

    Parameters
    ----------
    model : pinocchio.Model with ``nq == nv`` (joint velocities are the time derivatives of
        the coordinates, as eqs. (1)-(14) assume; quaternion joints are refused).
    contacts : plane contacts on frames (:class:`PinocchioContact`).
    loops : pairs of frames whose origins coincide (point loop closures).
    applied_forces : optional ``(t, theta, theta_dot) -> (nv,)`` joint forces.
    applied_potential : optional ``theta -> float``, the potential energy of the conservative
        part of ``applied_forces`` (added to :meth:`potential_energy`, so energy checks see it).
    planar : the model moves in the x-y plane (revolute joints about z, prismatic joints and
        gravity in the plane): contact Jacobians have the two rows (n, t), normals lie in the
        plane. Checked at a few configurations.
    coordinate_names : names of the coordinates (default: Pinocchio's joint names, a
        multi-coordinate joint's as ``name:i``, the root joints' as in :data:`ROOT_COORDINATES`).

    Raises
    ------
    NotSupportedError : nq != nv.
    ModelError : an unknown frame, or a ``planar`` model that leaves the plane.
    """

    def __init__(self, model, contacts: Sequence[PinocchioContact] = (),
                 loops: Sequence[tuple[FrameRef, FrameRef]] = (),
                 applied_forces: Optional[Callable] = None,
                 applied_potential: Optional[Callable] = None, planar: bool = False,
                 coordinate_names: Optional[Sequence[str]] = None):
        pin = _pin()
        if not isinstance(model, pin.Model):
            raise ModelError(f"model must be a pinocchio.Model, got {type(model).__name__}")
        if model.nq != model.nv:
            raise NotSupportedError(
                f"this Pinocchio model has nq = {model.nq} != nv = {model.nv} (quaternion or "
                "unbounded joints, e.g. the free-flyer); the Mechanism protocol needs theta_dot = "
                "d theta/dt. Load it with root_joint='free' (translation + Z-Y-X Euler angles), "
                "or use convimpact.model.pinocchio_adapter.impact_arguments for single impacts")
        if model.nv == 0:
            raise ModelError("the Pinocchio model has no degree of freedom")
        inexact = sorted({j.shortname() for j in list(model.joints)[1:]} - EXACT_JOINTS)
        if inexact:
            raise NotSupportedError(
                f"the Pinocchio model has {', '.join(inexact)} joints, whose Coriolis matrix "
                "Pinocchio does not compute exactly (M_dot != C + C^T); use elementary joints "
                "(revolute, prismatic, translation), e.g. root_joint='free' for a floating base")
        self._pin = pin
        self.model = model
        self.planar = bool(planar)
        self._data = model.createData()  # dynamics: crba, nle, Coriolis, potential
        self._kin = model.createData()  # kinematics and Jacobians at one configuration
        self._kin_key: Optional[bytes] = None
        self._vel = model.createData()  # Jacobians' time variation at one state
        self._vel_key: Optional[bytes] = None
        names = [c.name for c in contacts]
        if len(set(names)) != len(names):
            raise ModelError(f"contact names must be unique, got {names}")
        self.contacts = {}
        for c in contacts:
            if not isinstance(c, PinocchioContact):
                raise ModelError(f"contacts must be PinocchioContact, got {type(c).__name__}")
            if not (0.0 <= float(c.e) <= 1.0) or not float(c.mu) >= 0.0:
                raise ParameterError(f"contact {c.name!r}: e must be in [0, 1] and mu >= 0, "
                                     f"got e = {c.e}, mu = {c.mu}")
            fid = _frame_id(model, c.frame)
            n = _lift(c.normal, self.planar, f"contact {c.name!r} normal")
            basis = contact_basis(n, None if c.tangent is None else
                                  _lift(c.tangent, self.planar, f"contact {c.name!r} tangent"),
                                  planar=self.planar)
            point = _lift(c.plane_point, self.planar, f"contact {c.name!r} plane_point")
            local = (np.zeros(3) if c.local_point is None
                     else _lift(c.local_point, self.planar, f"contact {c.name!r} local_point"))
            frame = model.frames[fid]
            placement = frame.placement * pin.SE3(np.eye(3), local)
            self.contacts[c.name] = (c, int(frame.parentJoint), placement, basis, point)
        self.loops = tuple(loops)
        for a, b in self.loops:
            _frame_id(model, a), _frame_id(model, b)
        self._loop_ids = [(_frame_id(model, a), _frame_id(model, b)) for a, b in self.loops]
        self.applied_forces = applied_forces
        self.applied_potential = applied_potential
        self.n_coordinates: int = int(model.nv)
        self.n_loop_constraints: int = 3 * len(self.loops)
        self.contact_names: Sequence[str] = tuple(self.contacts)
        self.coordinate_names: Sequence[str] = self._names(coordinate_names)
        if self.planar:
            self._check_planar()

    # -- construction ---------------------------------------------------------------------
    @classmethod
    def from_urdf(cls, urdf: Union[str, Path], root_joint: Union[str, object, None] = "fixed",
                  contacts: Sequence[PinocchioContact] = (), **options) -> "PinocchioMechanism":
        """Load a URDF file (or a URDF document given as a string starting with ``<``).

        Parameters
        ----------
        urdf : path of the ``.urdf`` file, or its XML text.
        root_joint : "fixed" (the root link is welded to the world), "free", "planar" (see
            :func:`root_joint`) or an elementary Pinocchio ``JointModel``.
        contacts : plane contacts on the model's frames (link and joint names are frames).
        **options : the other arguments of :class:`PinocchioMechanism`.
        """
        pin = _pin()
        text = str(urdf)
        if text.lstrip().startswith("<"):
            def load(jm):
                return pin.buildModelFromXML(text) if jm is None else pin.buildModelFromXML(text, jm)
        else:
            path = Path(urdf)
            if not path.is_file():
                raise ModelError(f"no URDF file at {str(path)!r}")

            def load(jm):
                return (pin.buildModelFromUrdf(str(path)) if jm is None
                        else pin.buildModelFromUrdf(str(path), jm))
        model, kind = _build(pin, load, root_joint)
        return cls(model, contacts, **cls._root_options(model, kind, options))

    @classmethod
    def from_mjcf(cls, path: Union[str, Path], root_joint: Union[str, object, None] = "fixed",
                  contacts: Sequence[PinocchioContact] = (), **options) -> "PinocchioMechanism":
        """Load a MuJoCo MJCF file (``pinocchio.buildModelFromMJCF``); arguments as
        :meth:`from_urdf`. MJCF ``freejoint``/``ball`` joints are quaternion joints: refused.
        Pinocchio's MJCF parser puts the root joint in place of the top body's own joint, so a
        floating robot (a ``freejoint`` on its torso) loads with ``root_joint="free"``."""
        pin = _pin()
        path = Path(path)
        if not path.is_file():
            raise ModelError(f"no MJCF file at {str(path)!r}")

        def load(jm):
            with warnings.catch_warnings():  # the root-joint overload is deprecated in pin 3.x
                warnings.simplefilter("ignore", DeprecationWarning)
                model = (pin.buildModelFromMJCF(str(path)) if jm is None
                         else pin.buildModelFromMJCF(str(path), jm, "root_joint"))
            # (model, constraint models) in recent Pinocchio
            return model[0] if isinstance(model, tuple) else model
        model, kind = _build(pin, load, root_joint)
        return cls(model, contacts, **cls._root_options(model, kind, options))

    @staticmethod
    def _root_options(model, kind: str, options: dict) -> dict:
        if kind in ROOT_COORDINATES and "coordinate_names" not in options:
            names = list(ROOT_COORDINATES[kind])
            for j in range(len(names) + 1, model.njoints):
                nv = model.joints[j].nv
                names += [model.names[j]] if nv == 1 else [f"{model.names[j]}:{i}"
                                                           for i in range(nv)]
            if len(names) == model.nv:
                options = dict(options, coordinate_names=names)
        if kind == "planar":
            options.setdefault("planar", True)
        return options

    def _names(self, names) -> tuple[str, ...]:
        if names is None:
            out = []
            for j in range(1, self.model.njoints):
                nv = self.model.joints[j].nv
                out += [self.model.names[j]] if nv == 1 else [f"{self.model.names[j]}:{i}"
                                                              for i in range(nv)]
            return tuple(out)
        names = tuple(str(n) for n in names)
        if len(names) != self.n_coordinates:
            raise ShapeError(f"coordinate_names needs {self.n_coordinates} names, got {len(names)}")
        return names

    def _check_planar(self) -> None:
        g = np.asarray(self.model.gravity.linear, dtype=float)
        if abs(g[2]) > 1e-12:
            raise ModelError(f"planar=True needs gravity in the x-y plane, got {g.tolist()}")
        rng = np.random.default_rng(0)
        for theta in (np.zeros(self.n_coordinates), rng.uniform(-1, 1, self.n_coordinates)):
            for name in self.contact_names:
                J = self._point_jacobian(name, theta)
                if np.abs(J[2]).max() > 1e-9 * max(1.0, np.abs(J).max()):
                    raise ModelError(f"planar=True but contact {name!r} moves out of the x-y "
                                     "plane (a joint axis is not z, or a prismatic axis not in "
                                     "the plane)")

    def __repr__(self) -> str:
        kind = "planar" if self.planar else "spatial"
        return (f"PinocchioMechanism({self.model.name or 'model'}, {kind}, "
                f"k={self.n_coordinates}, m={self.n_loop_constraints}, "
                f"contacts={list(self.contact_names)})")

    # -- input ------------------------------------------------------------------------------
    def _q(self, theta, name: str = "theta") -> np.ndarray:
        q = np.asarray(theta, dtype=float)
        if q.shape != (self.n_coordinates,):
            raise ShapeError(f"{name} must have shape ({self.n_coordinates},), got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise NonFiniteError(f"{name} has a non-finite entry: {q.tolist()}")
        return q

    def _contact(self, name: str):
        try:
            return self.contacts[name]
        except (KeyError, TypeError):
            raise ModelError(f"unknown contact {name!r}; contacts are "
                             f"{', '.join(self.contact_names) or 'none'}") from None

    def _kinematics(self, q: np.ndarray):
        key = q.tobytes()
        if key != self._kin_key:
            self._pin.computeJointJacobians(self.model, self._kin, q)
            self._kin_key = key
        return self._kin

    def _velocity_kinematics(self, q: np.ndarray, v: np.ndarray):
        key = q.tobytes() + v.tobytes()
        if key != self._vel_key:
            self._pin.computeJointJacobiansTimeVariation(self.model, self._vel, q, v)
            self._vel_key = key
        return self._vel

    def _point(self, data, name: str) -> np.ndarray:
        _, joint, placement, _, _ = self.contacts[name]
        return np.array((data.oMi[joint] * placement).translation)

    def _point_jacobian(self, name: str, theta) -> np.ndarray:
        q = self._q(theta)
        c, joint, placement, _, _ = self._contact(name)
        data = self._kinematics(q)
        Jw = np.asarray(self._pin.getJointJacobian(self.model, data, joint, self._pin.WORLD)
                        ).reshape(6, self.n_coordinates)
        p = self._point(data, name)
        return Jw[:3] - _skew(p) @ Jw[3:]

    # -- Mechanism protocol -----------------------------------------------------------------
    def mass_matrix(self, theta) -> np.ndarray:
        """M(theta) by CRBA (symmetrized), (k, k)."""
        return mass_matrix(self.model, self._data, self._q(theta))

    def mass_matrix_dot(self, theta, dtheta) -> np.ndarray:
        """dM/dt = C + C^T with Pinocchio's Coriolis matrix C(theta, theta_dot), (k, k)."""
        k = self.n_coordinates
        Cor = np.array(self._pin.computeCoriolisMatrix(
            self.model, self._data, self._q(theta), self._q(dtheta, "dtheta"))).reshape(k, k)
        return Cor + Cor.T

    def generalized_forces(self, t, theta, dtheta) -> np.ndarray:
        """f = -(C theta_dot + g) (``nonLinearEffects``) plus the applied forces, (k,)."""
        q, v = self._q(theta), self._q(dtheta, "dtheta")
        f = -np.array(self._pin.nonLinearEffects(self.model, self._data, q, v)).reshape(-1)
        if self.applied_forces is not None:
            f = f + np.asarray(self.applied_forces(t, q, v), dtype=float).reshape(-1)
        return f

    def momentum_rate(self, t, theta, dtheta) -> np.ndarray:
        """p_dot = f + M_dot theta_dot (eq. 11) = C^T theta_dot - g + applied forces, (k,)
        (with f = -(C theta_dot + g) and M_dot = C + C^T)."""
        q, v = self._q(theta), self._q(dtheta, "dtheta")
        k = self.n_coordinates
        Cor = np.array(self._pin.computeCoriolisMatrix(self.model, self._data, q, v)).reshape(k, k)
        g = np.array(self._pin.computeGeneralizedGravity(self.model, self._data, q)).reshape(-1)
        pdot = Cor.T @ v - g
        if self.applied_forces is not None:
            pdot = pdot + np.asarray(self.applied_forces(t, q, v), dtype=float).reshape(-1)
        return pdot

    def loop_residual(self, theta) -> np.ndarray:
        """Psi = p_a - p_b of each loop's frame origins, (m,)."""
        if not self.loops:
            return np.zeros(0)
        q = self._q(theta)
        d = self._data
        self._pin.framesForwardKinematics(self.model, d, q)
        return np.concatenate([d.oMf[a].translation - d.oMf[b].translation
                               for a, b in self._loop_ids])

    def loop_jacobian(self, theta) -> np.ndarray:
        """C(theta), (m, k)."""
        if not self.loops:
            return np.zeros((0, self.n_coordinates))
        q = self._q(theta)
        return np.vstack([point_loop_jacobian(self.model, self._data, q, a, b)
                          for a, b in self.loops])

    def loop_jacobian_dot(self, theta, dtheta) -> np.ndarray:
        """C_dot(theta, theta_dot), (m, k)."""
        if not self.loops:
            return np.zeros((0, self.n_coordinates))
        q, v = self._q(theta), self._q(dtheta, "dtheta")
        return np.vstack([point_loop_jacobian_dot(self.model, self._data, q, v, a, b)
                          for a, b in self.loops])

    def contact_gap(self, name: str, theta) -> float:
        """Signed distance n . (p - plane_point) of the contact point from its plane."""
        _, _, _, basis, plane = self._contact(name)
        p = self._point(self._kinematics(self._q(theta)), name)
        return float(basis[0] @ (p - plane))

    def contact_point(self, name: str, theta) -> np.ndarray:
        """World position (3,) of the contact point."""
        self._contact(name)
        return self._point(self._kinematics(self._q(theta)), name)

    def contact_jacobian(self, name: str, theta) -> np.ndarray:
        """Rows (n, t1, t2) - (n, t) planar - of the contact point's velocity, (d, k)."""
        _, _, _, basis, _ = self._contact(name)
        return basis @ self._point_jacobian(name, theta)

    def contact_jacobian_dot(self, name: str, theta, dtheta) -> np.ndarray:
        """Exact d Jc/dt along theta_dot, (d, k) (the plane and its frame are fixed)."""
        _, joint, _, basis, _ = self._contact(name)
        q, v = self._q(theta), self._q(dtheta, "dtheta")
        pin = self._pin
        d = self._velocity_kinematics(q, v)
        k = self.n_coordinates
        Jw = np.asarray(pin.getJointJacobian(self.model, d, joint, pin.WORLD)).reshape(6, k)
        dJw = np.asarray(pin.getJointJacobianTimeVariation(self.model, d, joint, pin.WORLD)
                         ).reshape(6, k)
        p = self._point(d, name)
        pdot = (Jw[:3] - _skew(p) @ Jw[3:]) @ v
        return basis @ (dJw[:3] - _skew(pdot) @ Jw[3:] - _skew(p) @ dJw[3:])

    def contact_parameters(self, name: str) -> tuple[float, float]:
        """(e, mu) of the contact."""
        c = self._contact(name)[0]
        return float(c.e), float(c.mu)

    def kinetic_energy(self, theta, dtheta) -> float:
        """T = 1/2 theta_dot^T M theta_dot."""
        v = self._q(dtheta, "dtheta")
        return 0.5 * float(v @ self.mass_matrix(theta) @ v)

    def potential_energy(self, theta) -> float:
        """Gravity's potential (``computePotentialEnergy``, bodies on moving joints) plus
        ``applied_potential``."""
        q = self._q(theta)
        V = float(self._pin.computePotentialEnergy(self.model, self._data, q))
        if self.applied_potential is not None:
            V += float(self.applied_potential(q))
        return V

    # -- extras ------------------------------------------------------------------------------
    def frame_placement(self, frame: FrameRef, theta) -> tuple[np.ndarray, np.ndarray]:
        """World (rotation (3, 3), origin (3,)) of a frame."""
        fid = _frame_id(self.model, frame)
        q = self._q(theta)
        self._pin.framesForwardKinematics(self.model, self._data, q)
        oMf = self._data.oMf[fid]
        return np.array(oMf.rotation), np.array(oMf.translation)

    def coordinate_index(self, name: str) -> int:
        """Index in theta of coordinate ``name``."""
        try:
            return self.coordinate_names.index(name)
        except ValueError:
            raise ModelError(f"unknown coordinate {name!r}; coordinates are "
                             f"{', '.join(self.coordinate_names)}") from None


__all__ = ["PinocchioMechanism", "PinocchioContact", "root_joint", "ROOT_JOINTS",
           "ROOT_CHAINS", "ROOT_COORDINATES", "EXACT_JOINTS"]
