"""Joint types of a kinematic tree, each a sequence of elementary one-coordinate motions.

A joint connects a body to its parent. Its motion is a chain of elementary revolute or
prismatic motions about/along axes expressed in the joint frame as it has moved so far
(so a ``universal`` joint turns about its first axis, then about the second axis carried by
the first rotation). Every joint coordinate theta_j therefore satisfies theta_dot_j = d
theta_j / dt, which is what the paper's equations (1)-(14) assume.

================  ==========================  ==============================================
kind              planar coordinates          spatial coordinates
================  ==========================  ==============================================
``revolute``      angle about +z              angle about ``axis``
``prismatic``     displacement along ``axis`` displacement along ``axis``
``fixed``         none                        none
``translation``   x, y                        x, y, z
``free``          x, y, angle                 x, y, z, then body-fixed X-Y-Z (Cardan) angles
``universal``     (not planar)                angle about ``axis1``, then about ``axis2``
================  ==========================  ==============================================

The spatial ``free`` joint uses Cardan angles rather than a quaternion so that theta_dot is
the time derivative of theta; like every three-angle set it is singular where the middle
angle is +-90 degrees (the mass matrix is then singular), which the model reports through
:class:`~convimpact.errors.MassMatrixError` when an impact is resolved there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

JOINT_KINDS = ("revolute", "prismatic", "fixed", "translation", "free", "universal")


@dataclass(frozen=True, eq=False)
class Motion:
    """One elementary motion: ``kind`` "revolute" or "prismatic" with a unit ``axis``.

    ``axis`` is expressed in the joint frame after the preceding motions of the same joint:
    shape (1,) (+1 or -1, the z direction) for a planar revolute, (2,) for a planar
    prismatic, (3,) for spatial motions.
    """

    kind: str
    axis: np.ndarray


@dataclass(frozen=True, eq=False)
class Joint:
    """A joint type with its axes; build it with the class methods.

    Examples
    --------
    >>> Joint.revolute().n_coordinates(planar=True)
    1
    >>> Joint.free().n_coordinates(planar=False)
    6
    """

    kind: str
    axes: tuple = ()

    # -- constructors ------------------------------------------------------------------
    @classmethod
    def revolute(cls, axis=None) -> "Joint":
        """A hinge. Planar: about +z (``axis`` None, +1 or -1). Spatial: about ``axis``."""
        return cls("revolute", (axis,))

    @classmethod
    def prismatic(cls, axis) -> "Joint":
        """A slider along ``axis`` (2-vector planar, 3-vector spatial, in the joint frame)."""
        return cls("prismatic", (axis,))

    @classmethod
    def fixed(cls) -> "Joint":
        """A weld: the body moves rigidly with its parent."""
        return cls("fixed", ())

    @classmethod
    def translation(cls) -> "Joint":
        """Free translation without rotation (a point mass): x, y (, z)."""
        return cls("translation", ())

    @classmethod
    def free(cls) -> "Joint":
        """A floating base: translations, then rotation (planar angle / spatial Cardan X-Y-Z)."""
        return cls("free", ())

    @classmethod
    def universal(cls, axis1, axis2) -> "Joint":
        """Spatial: a turn about ``axis1``, then about ``axis2`` as carried by the first turn."""
        return cls("universal", (axis1, axis2))

    # -- expansion into elementary motions ------------------------------------------------
    def n_coordinates(self, planar: bool) -> int:
        """Number of joint coordinates this joint adds."""
        return len(self.motions(planar))

    def motions(self, planar: bool) -> tuple[Motion, ...]:
        """The elementary motions, validated for the planar or spatial case.

        Raises
        ------
        ModelError
            Unknown kind, missing or zero axis, wrong axis size, or a joint that does not
            exist in the plane.
        """
        d = 2 if planar else 3
        if self.kind not in JOINT_KINDS:
            raise ModelError(f"unknown joint kind {self.kind!r}; use one of {', '.join(JOINT_KINDS)}")
        if self.kind == "fixed":
            return ()
        if self.kind == "revolute":
            return (self._revolute(self.axes[0], planar),)
        if self.kind == "prismatic":
            return (Motion("prismatic", _unit(self.axes[0], d, "prismatic axis")),)
        if self.kind == "translation":
            return tuple(Motion("prismatic", np.eye(d)[i]) for i in range(d))
        if self.kind == "free":
            trans = tuple(Motion("prismatic", np.eye(d)[i]) for i in range(d))
            if planar:
                return trans + (Motion("revolute", np.ones(1)),)
            return trans + tuple(Motion("revolute", np.eye(3)[i]) for i in range(3))
        # universal
        if planar:
            raise ModelError("a universal joint does not exist in a planar model; use two "
                             "revolute joints or build the model with planar=False")
        return (self._revolute(self.axes[0], False), self._revolute(self.axes[1], False))

    @staticmethod
    def _revolute(axis, planar: bool) -> Motion:
        if planar:
            if axis is None:
                return Motion("revolute", np.ones(1))
            a = np.atleast_1d(np.asarray(axis, dtype=float)).ravel()
            if a.size == 3 and abs(a[0]) < 1e-12 and abs(a[1]) < 1e-12:
                a = a[2:]
            if a.size != 1 or abs(abs(a[0]) - 1.0) > 1e-12:
                raise ModelError(f"a planar revolute joint turns about z: pass axis None, +1, -1 "
                                 f"or (0, 0, +-1), got {axis!r}")
            return Motion("revolute", np.sign(a))
        if axis is None:
            raise ModelError("a spatial revolute joint needs an axis, e.g. Joint.revolute((0, 0, 1))")
        return Motion("revolute", _unit(axis, 3, "revolute axis"))


def _unit(axis, d: int, what: str) -> np.ndarray:
    if axis is None:
        raise ModelError(f"the {what} is missing; pass a {d}-vector")
    a = np.asarray(axis, dtype=float).ravel()
    if a.shape != (d,) or not np.all(np.isfinite(a)):
        raise ModelError(f"the {what} must be a finite {d}-vector, got {axis!r}")
    n = float(np.linalg.norm(a))
    if n < 1e-12:
        raise ModelError(f"the {what} is zero; pass a non-zero {d}-vector")
    return a / n
