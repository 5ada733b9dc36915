"""impact_arguments / resolve_mechanism_impact on any Mechanism-protocol object."""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.errors import ModelError, ShapeError
from convimpact.mechanism import Mechanism
from convimpact.model import (
    Joint,
    ModelBuilder,
    active_contacts,
    impact_arguments,
    resolve_mechanism_impact,
)


class Particle:
    """A hand-written planar particle of mass 2 above the floor y = 0 (no model code)."""

    n_coordinates = 2
    n_loop_constraints = 0
    contact_names = ("floor",)

    def mass_matrix(self, theta):
        return 2.0 * np.eye(2)

    def mass_matrix_dot(self, theta, dtheta):
        return np.zeros((2, 2))

    def generalized_forces(self, t, theta, dtheta):
        return np.array([0.0, -2.0 * 9.81])

    def loop_residual(self, theta):
        return np.zeros(0)

    def loop_jacobian(self, theta):
        return np.zeros((0, 2))

    def loop_jacobian_dot(self, theta, dtheta):
        return np.zeros((0, 2))

    def contact_gap(self, name, theta):
        return float(theta[1])

    def contact_jacobian(self, name, theta):
        return np.array([[0.0, 1.0], [-1.0, 0.0]])  # n = +y, t = -x

    def contact_parameters(self, name):
        return 0.5, 0.2

    def kinetic_energy(self, theta, dtheta):
        return float(dtheta @ dtheta)

    def potential_energy(self, theta):
        return 2.0 * 9.81 * float(theta[1])


def test_hand_written_mechanism():
    p = Particle()
    assert isinstance(p, Mechanism)
    args = impact_arguments(p, [0.3, 0.0], [1.0, -2.0])
    assert set(args) == {"M", "Jc", "dq", "C", "e", "mu"}
    assert args["C"] is None and args["e"] == [0.5] and args["mu"] == [0.2]
    r = resolve_mechanism_impact(p, [0.3, 0.0], [1.0, -2.0])
    # by hand: pi_n = m (1 + e) |v_n| = 2 * 1.5 * 2 = 6; sliding (mu pi_n = 1.2 < m |v_t| = 2)
    assert r.dq_plus[1] == pytest.approx(1.0)
    assert r.dq_plus[0] == pytest.approx(1.0 - 0.2 * 6.0 / 2.0)


def _two_ball_model():
    b = ModelBuilder(planar=True)
    b.add_body("a", "ground", Joint.translation(), 1.0, (0, 0), 0.01)
    b.add_body("b", "ground", Joint.translation(), 3.0, (0, 0), 0.01)
    b.add_contact("a_floor", "a", (0, 0), radius=0.1, normal=(0, 1), e=0.3, mu=0.1)
    b.add_contact("b_floor", "b", (0, 0), radius=0.1, normal=(0, 1), e=0.6, mu=0.4)
    b.add_contact("a_b", "a", (0, 0), radius=0.1, against="b", sphere_center=(0, 0),
                  sphere_radius=0.1, e=1.0, mu=0.0)
    return b.build().mechanism()


def test_contact_selection_and_overrides():
    mech = _two_ball_model()
    theta = np.array([0.0, 0.1, 0.5, 0.1])  # both on the floor, 0.3 m apart
    assert active_contacts(mech, theta) == ["a_floor", "b_floor"]
    args = impact_arguments(mech, theta, [0.0, -1.0, 0.0, -1.0])
    assert len(args["Jc"]) == 2 and args["e"] == [0.3, 0.6] and args["mu"] == [0.1, 0.4]
    one = impact_arguments(mech, theta, np.zeros(4), contacts="a_b", e=0.9, mu=0.0)
    assert one["Jc"].shape == (2, 4) and one["e"] == 0.9 and one["mu"] == 0.0
    # sphere-sphere normal from b's centre toward a's: -x; t = n turned +90 deg = -y
    assert np.allclose(one["Jc"], [[-1, 0, 1, 0], [0, -1, 0, 1]])
    assert mech.contact_gap("a_b", theta) == pytest.approx(0.3)
    with pytest.raises(ShapeError):
        impact_arguments(mech, theta[:3], np.zeros(4))


def test_head_on_elastic_collision_of_two_balls():
    """Newton's cradle by hand: m_a = 1 at +1 m/s hits m_b = 3 at rest, e = 1."""
    mech = _two_ball_model()
    theta = np.array([0.0, 1.0, 0.2, 1.0])  # touching, above the floor
    r = resolve_mechanism_impact(mech, theta, [1.0, 0.0, 0.0, 0.0], contacts="a_b")
    assert np.allclose(r.dq_plus, [-0.5, 0.0, 0.5, 0.0])


def test_no_touching_contact():
    mech = _two_ball_model()
    with pytest.raises(ModelError, match="no contact is touching"):
        impact_arguments(mech, np.array([0.0, 1.0, 3.0, 1.0]), np.zeros(4))
    with pytest.raises(ModelError, match="empty"):
        impact_arguments(mech, np.zeros(4), np.zeros(4), contacts=[])


def test_closed_loop_arguments_carry_C():
    from convimpact.problems import slider_crank
    args = slider_crank.impact_arguments(mass_ratio=1.0)
    C = args["C"]
    assert C.shape == (2, 4) and np.allclose(C @ args["dq"], 0.0, atol=1e-12)
    r = ci.resolve_impact(**args)
    assert np.allclose(C @ r.dq_plus, 0.0, atol=1e-10)
