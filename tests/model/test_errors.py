"""Bad model input gets a typed error from convimpact.errors with an actionable message."""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.errors import ConvImpactError, ModelError, NonFiniteError, ShapeError
from convimpact.model import Joint, ModelBuilder, assemble, impact_arguments


def _pendulum(planar=True):
    b = ModelBuilder(planar=planar)
    if planar:
        b.add_body("rod", "ground", Joint.revolute(), 1.0, (0.5, 0.0), 1 / 12)
        b.add_contact("tip", "rod", (1.0, 0.0), normal=(0.0, 1.0), plane_point=(0.0, -1.0))
    else:
        b.add_body("rod", "ground", Joint.revolute((0, 0, 1)), 1.0, (0.5, 0, 0), (0.01, 0.1, 0.1))
    return b


def test_errors_are_value_errors_of_the_library():
    assert issubclass(ModelError, ConvImpactError) and issubclass(ModelError, ValueError)


@pytest.mark.parametrize("mass", [0.0, -1.0, np.nan, np.inf])
def test_zero_negative_or_nonfinite_mass(mass):
    with pytest.raises(ModelError, match="mass"):
        ModelBuilder(planar=True).add_body("a", "ground", Joint.revolute(), mass, (0, 0), 1.0)


@pytest.mark.parametrize("inertia,match", [
    (np.diag([1.0, 1.0, -0.1]), "not positive definite"),
    (np.diag([1.0, 1.0, 0.0]), "allow_singular_inertia"),
    (np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "not symmetric"),
    (np.diag([1.0, 1.0, 3.0]), "triangle"),
    (np.eye(2), "3 x 3"),
])
def test_bad_spatial_inertia(inertia, match):
    with pytest.raises(ModelError, match=match):
        ModelBuilder(planar=False).add_body("a", "ground", Joint.revolute((0, 0, 1)), 1.0,
                                            (0, 0, 0), inertia)


@pytest.mark.parametrize("inertia", [0.0, -1.0, [1.0, 2.0]])
def test_bad_planar_inertia(inertia):
    with pytest.raises(ModelError, match="inertia|I_zz"):
        ModelBuilder(planar=True).add_body("a", "ground", Joint.revolute(), 1.0, (0, 0), inertia)


def test_slender_rod_inertia_is_accepted_when_declared():
    b = ModelBuilder(planar=False)
    b.add_body("rod", "ground", Joint.revolute((0, 0, 1)), 1.0, (0.5, 0, 0), (0.0, 1 / 12, 1 / 12),
               allow_singular_inertia=True)
    M = b.build().mechanism().mass_matrix(np.zeros(1))
    assert M[0, 0] == pytest.approx(1 / 3)


def test_unknown_names():
    b = _pendulum()
    with pytest.raises(ModelError, match="unknown parent body 'nope'"):
        b.add_body("x", "nope", Joint.revolute(), 1.0, (0, 0), 1.0)
    with pytest.raises(ModelError, match="already exists"):
        b.add_body("rod", "ground", Joint.revolute(), 1.0, (0, 0), 1.0)
    with pytest.raises(ModelError, match="unknown contact body 'ghost'"):
        b.add_contact("c", "ghost", (0, 0), normal=(0, 1))
    with pytest.raises(ModelError, match="unknown loop body"):
        b.add_loop("l", "revolute", "rod", "ghost")
    mech = b.build().mechanism()
    with pytest.raises(ModelError, match="unknown contact 'foot'"):
        mech.contact_gap("foot", np.zeros(1))
    with pytest.raises(ModelError, match="unknown contact"):
        mech.contact_parameters("foot")
    with pytest.raises(ModelError, match="unknown body 'ghost'"):
        mech.point_position("ghost", (0, 0), np.zeros(1))
    with pytest.raises(ModelError, match="unknown joint 'knee'"):
        mech.model.joint_coordinates("knee")
    with pytest.raises(ModelError, match="unknown joint 'knee'"):
        mech.coordinate_index("knee")
    with pytest.raises(ModelError, match="unknown contact"):
        impact_arguments(mech, np.zeros(1), np.zeros(1), contacts=["foot"])


def test_unknown_joint_name_in_assembly():
    b = ModelBuilder(planar=True)
    b.add_body("a", "ground", Joint.revolute(), 1.0, (0.5, 0), 0.1)
    b.add_body("c", "a", Joint.revolute(), 1.0, (0.5, 0), 0.1, joint_origin=(1, 0))
    b.add_loop("pin", "revolute", "c", "ground", origin_a=(1, 0), origin_b=(1.5, 0))
    mech = b.build().mechanism()
    with pytest.raises(ModelError, match="unknown joint 'elbow'"):
        assemble(mech, [0.1, 0.2], fixed=["elbow"])


def test_bad_joints_and_geometry():
    with pytest.raises(ModelError, match="zero"):
        Joint.prismatic((0.0, 0.0)).motions(planar=True)
    with pytest.raises(ModelError, match="planar"):
        Joint.universal((0, 1, 0), (0, 0, 1)).motions(planar=True)
    with pytest.raises(ModelError, match="turns about z"):
        Joint.revolute((1.0, 0.0, 0.0)).motions(planar=True)
    with pytest.raises(ModelError, match="needs an axis"):
        Joint.revolute().motions(planar=False)
    with pytest.raises(ModelError, match="unknown joint kind"):
        Joint("helical").motions(planar=False)
    b = _pendulum()
    with pytest.raises(ModelError, match="either a plane"):
        b.add_contact("c", "rod", (0, 0))
    with pytest.raises(ModelError, match="restitution"):
        b.add_contact("c", "rod", (0, 0), normal=(0, 1), e=1.5)
    with pytest.raises(ModelError, match="friction"):
        b.add_contact("c", "rod", (0, 0), normal=(0, 1), mu=-0.1)
    with pytest.raises(ModelError, match="rotation"):
        ModelBuilder(planar=False).add_body("a", "ground", Joint.revolute((0, 0, 1)), 1.0,
                                            (0, 0, 0), np.eye(3), joint_rotation=2 * np.eye(3))
    with pytest.raises(ModelError, match="no joint coordinates"):
        ModelBuilder(planar=True).build()
    with pytest.raises(ModelError, match="unknown cut joint kind"):
        _pendulum().add_loop("l", "spherical", "rod", "ground")


def test_bad_states():
    mech = _pendulum().build().mechanism()
    with pytest.raises(ShapeError, match=r"shape \(1,\)"):
        mech.mass_matrix(np.zeros(2))
    with pytest.raises(NonFiniteError):
        mech.mass_matrix(np.array([np.nan]))
    with pytest.raises(NonFiniteError):
        mech.generalized_forces(0.0, np.zeros(1), np.array([np.inf]))
    with pytest.raises(ModelError, match="no contact is touching"):
        impact_arguments(mech, np.zeros(1), np.ones(1))


def test_applied_forces_of_wrong_shape():
    b = _pendulum()
    b.set_applied_forces(lambda t, th, dth: np.zeros(3))
    with pytest.raises(ShapeError, match="applied forces"):
        b.build().mechanism().generalized_forces(0.0, np.zeros(1), np.zeros(1))
    with pytest.raises(ModelError):
        _pendulum().set_applied_forces(42)
