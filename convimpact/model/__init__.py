"""Joint-coordinate models of mechanisms (Sections 2-3 of the paper).

A mechanism is described once as a :class:`Model` (built with :class:`ModelBuilder`) and
evaluated at a state (theta, theta_dot) by plain functions that cache per-state quantities in
a :class:`Data` workspace, in the style of Pinocchio's Model/Data split. The evaluations are
the compiled recursive algorithms of :mod:`convimpact.model.recursive` (composite rigid
bodies for M, Newton-Euler for f, one pass for every contact's gap, Jacobian and its rate).
``model.mechanism()``
returns a :class:`ModelMechanism`, which satisfies :class:`convimpact.mechanism.Mechanism`
and is what scenes and simulators use.

>>> import numpy as np
>>> from convimpact.model import ModelBuilder, Joint
>>> b = ModelBuilder(planar=True)
>>> _ = b.add_body("rod", "ground", Joint.revolute(), mass=1.0, com=(0.5, 0.0), inertia=1 / 12)
>>> b.add_contact("tip", body="rod", point=(1.0, 0.0), normal=(0.0, 1.0), plane_point=(0.0, -1.0))
>>> mech = b.build().mechanism()
>>> float(mech.mass_matrix(np.array([-np.pi / 2]))[0, 0])   # m L^2 / 3
0.3333333333333333
>>> float(mech.contact_gap("tip", np.array([-np.pi / 2])))
0.0
"""

from .builder import GROUND, BodyInfo, ContactSpec, LoopSpec, Model, ModelBuilder
from .contacts import (ContactFrame, contact_frame, contact_gap, contact_jacobian,
                       contact_jacobian_dot)
from .data import Data
from .dynamics import (
    generalized_forces,
    kinetic_energy,
    mass_matrix,
    mass_matrix_dot,
    momentum_rate,
    potential_energy,
    velocity_transformation,
)
from .impact import GAP_TOL, active_contacts, impact_arguments, resolve_mechanism_impact
from .joints import Joint, Motion
from .kinematics import forward_kinematics, point_jacobian, point_jacobian_dot
from .loops import assemble, consistent_velocity, loop_jacobian, loop_jacobian_dot, loop_residual
from .mechanism import ModelMechanism
from .placement import place_resting, rest_velocity

__all__ = [
    "GROUND", "BodyInfo", "ContactSpec", "LoopSpec", "Model", "ModelBuilder", "Data", "Joint",
    "Motion", "ModelMechanism", "ContactFrame", "forward_kinematics", "point_jacobian",
    "point_jacobian_dot", "mass_matrix", "mass_matrix_dot", "generalized_forces",
    "kinetic_energy", "potential_energy", "velocity_transformation", "loop_residual",
    "loop_jacobian", "loop_jacobian_dot", "assemble", "consistent_velocity", "contact_frame",
    "contact_gap", "contact_jacobian", "contact_jacobian_dot", "momentum_rate", "GAP_TOL",
    "active_contacts", "impact_arguments",
    "resolve_mechanism_impact", "place_resting", "rest_velocity",
]
