"""Robot models shipped by the registry package ``example-robot-data``, located without
downloading anything.

The PyPI package ``example-robot-data`` (a cmeel wheel) installs its URDF/SRDF files under
``<site-packages>/cmeel.prefix/share/example-robot-data/robots/``; it has no importable Python
module here, so :func:`robot_data_dir` finds that folder through the distribution's installed
file list (``importlib.metadata``), with cmeel's prefix as a fallback. When the package is
missing every function raises :class:`RobotDataUnavailableError` (both a
:class:`~convimpact.errors.NotSupportedError` and an ``ImportError``).

:func:`solo12` loads the Solo-12 quadruped as a :class:`PinocchioMechanism` with a free base
(translation + Z-Y-X Euler angles) and point contacts at its four feet against the floor z = 0.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from ..errors import ModelError, NotSupportedError
from .pinocchio_adapter import PinocchioContact
from .pinocchio_mechanism import PinocchioMechanism
from .placement import place_resting

DISTRIBUTION = "example-robot-data"
#: the robots folder inside the installed prefix
ROBOTS = Path("share") / "example-robot-data" / "robots"
#: Solo-12's feet (frames of its URDF)
SOLO12_FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
#: Solo-12's "standing" posture of its SRDF: (HAA, HFE, KFE) per leg
SOLO12_STANDING = {"FL": (0.1, 0.8, -1.6), "FR": (-0.1, 0.8, -1.6),
                   "HL": (0.1, -0.8, 1.6), "HR": (-0.1, -0.8, 1.6)}
#: TALOS's soles (frames of its URDF) and their half sizes (the URDF's 0.21 x 0.13 m foot box)
TALOS_SOLES = ("left_sole_link", "right_sole_link")
TALOS_SOLE = (0.105, 0.065)


class RobotDataUnavailableError(NotSupportedError, ImportError):
    """The package ``example-robot-data`` is not installed."""


@lru_cache(maxsize=1)
def robot_data_dir() -> Path:
    """The ``robots`` folder of the installed ``example-robot-data`` package."""
    from importlib import metadata

    candidates = []
    try:
        dist = metadata.distribution(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        dist = None
    if dist is not None:
        for f in dist.files or ():
            parts = Path(str(f)).parts
            if "robots" in parts and "example-robot-data" in parts:
                i = parts.index("robots")
                candidates.append(Path(str(dist.locate_file(Path(*parts[:i + 1])))))
                break
        candidates.append(Path(str(dist.locate_file("cmeel.prefix"))) / ROBOTS)
    try:
        from cmeel import __file__ as cmeel_file  # cmeel wheels install next to it
        candidates.append(Path(cmeel_file).resolve().parent.parent / "cmeel.prefix" / ROBOTS)
    except ImportError:
        pass
    for c in candidates:
        if c.is_dir():
            return c
    raise RobotDataUnavailableError(
        "the robot models need the PyPI package 'example-robot-data' (its URDF files): "
        "install it with `pip install example-robot-data`"
        + (f"; looked in {', '.join(map(str, candidates))}" if candidates else ""))


def robot_file(relative: str) -> Path:
    """Path of a file of ``example-robot-data``, e.g. ``"solo_description/robots/solo12.urdf"``."""
    path = robot_data_dir() / relative
    if not path.is_file():
        raise ModelError(f"example-robot-data has no file {relative!r} (in {robot_data_dir()})")
    return path


def solo12(mu: float = 0.8, e: float = 0.0, floor: float = 0.0,
           applied_forces: Optional[Callable] = None,
           applied_potential: Optional[Callable] = None) -> PinocchioMechanism:
    """Solo-12 (12 actuated joints, 2.5 kg) with a free base and its four feet on a floor.

    Coordinates (18): base x, y, z, yaw, pitch, roll, then the joints FL_HAA, FL_HFE, FL_KFE,
    FR_..., HL_..., HR_... (hip abduction, hip flexion, knee). Contacts "FL_FOOT" ... are
    point feet at the foot frames' origins (the URDF's foot collision is a mesh; we take its
    frame origin as the contact point) against the plane z = ``floor``, with restitution ``e``
    and friction ``mu``; the contact frames are (n, t1, t2) = (z, x, y).
    """
    contacts = [PinocchioContact(f, f, normal=(0.0, 0.0, 1.0), plane_point=(0.0, 0.0, floor),
                                 tangent=(1.0, 0.0, 0.0), e=e, mu=mu)
                for f in SOLO12_FEET]
    return PinocchioMechanism.from_urdf(robot_file("solo_description/robots/solo12.urdf"),
                                        root_joint="free", contacts=contacts,
                                        applied_forces=applied_forces,
                                        applied_potential=applied_potential)


def solo12_standing(mech: PinocchioMechanism, height: float = 0.0) -> np.ndarray:
    """The SRDF's "standing" posture of :func:`solo12` (:data:`SOLO12_STANDING`), base level,
    its lowest foot ``height`` above the floor."""
    theta = np.zeros(mech.n_coordinates)
    for leg, angles in SOLO12_STANDING.items():
        for joint, angle in zip(("HAA", "HFE", "KFE"), angles):
            theta[mech.coordinate_index(f"{leg}_{joint}")] = angle
    lowest = min(mech.contact_gap(f, theta) for f in SOLO12_FEET)
    theta[mech.coordinate_index("base_z")] = height - lowest
    return theta


def talos_legs(mu: float = 0.8, e: float = 0.0, applied_forces: Optional[Callable] = None,
               applied_potential: Optional[Callable] = None
               ) -> tuple[PinocchioMechanism, np.ndarray]:
    """TALOS with its arms, torso and head locked in the SRDF's "half_sitting" posture:
    a free base and the twelve leg joints (18 coordinates), flat soles on the floor z = 0.

    Model no more than the scene needs: the locked joints' links stay rigidly attached
    (Pinocchio's ``buildReducedModel``), their masses and inertias merged into the torso.
    Each sole (the URDF's 0.21 x 0.13 m foot box) touches the floor at its four corners,
    contacts ``left_sole_<i>`` and ``right_sole_<i>`` (i = 0..3: (-x, -y), (-x, +y),
    (+x, -y), (+x, +y) in the sole frame), e and mu given, frames (n, t1, t2) = (z, x, y).

    Returns (mechanism, theta_half_sitting): the posture with the soles exactly on the floor.
    """
    from .pinocchio_terms import _pin

    pin = _pin()
    full = PinocchioMechanism.from_urdf(robot_file("talos_data/robots/talos_reduced.urdf"),
                                        root_joint="free")
    model = full.model
    pin.loadReferenceConfigurations(model, str(robot_file("talos_data/srdf/talos.srdf")), False)
    q_ref = np.array(model.referenceConfigurations["half_sitting"])
    locked = [j for j in range(1, model.njoints)
              if model.names[j] not in full.coordinate_names[:6]
              and not model.names[j].startswith("leg_")]
    reduced = pin.buildReducedModel(model, locked, q_ref)
    contacts = [PinocchioContact(f"{side}_sole_{i}", f"{side}_sole_link",
                                 normal=(0.0, 0.0, 1.0), plane_point=(0.0, 0.0, 0.0),
                                 tangent=(1.0, 0.0, 0.0), e=e, mu=mu,
                                 local_point=(sx * TALOS_SOLE[0], sy * TALOS_SOLE[1], 0.0))
                for side in ("left", "right")
                for i, (sx, sy) in enumerate([(-1, -1), (-1, 1), (1, -1), (1, 1)])]
    names = [n for n in full.coordinate_names
             if n in full.coordinate_names[:6] or n.startswith("leg_")]
    mech = PinocchioMechanism(reduced, contacts, applied_forces=applied_forces,
                              applied_potential=applied_potential, coordinate_names=names)
    theta = np.array([q_ref[full.coordinate_index(n)] for n in names])
    lowest = min(mech.contact_gap(c.name, theta) for c in contacts)
    theta[mech.coordinate_index(names[2])] -= lowest
    # the SRDF's posture leaves the soles 0.2 mm off flat: three corners of each sole on the
    # floor (the fourth follows) by the smallest mass-weighted change of the posture
    flat = [f"{side}_sole_{i}" for side in ("left", "right") for i in range(3)]
    return mech, place_resting(mech, theta, flat, fixed=names[:2] + names[3:4])


__all__ = ["RobotDataUnavailableError", "robot_data_dir", "robot_file", "solo12",
           "solo12_standing", "talos_legs", "SOLO12_FEET", "SOLO12_STANDING", "TALOS_SOLES",
           "TALOS_SOLE"]
