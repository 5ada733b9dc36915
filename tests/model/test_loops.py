"""Loop closures: assembled states, Newton assembly, consistent velocities, failure reports."""

from __future__ import annotations

import re

import numpy as np
import pytest

from convimpact.errors import AssemblyError
from convimpact.model import Joint, ModelBuilder, assemble, consistent_velocity
from convimpact.model.random import random_model

LOOPS = [(True, "revolute"), (True, "prismatic"), (False, "revolute"), (False, "prismatic"),
         (False, "spherical")]


def _chain(planar, kind, seed):
    rng = np.random.default_rng(100 + seed)
    # enough revolute joints for the loop to keep mobility: 4 planar (2 removed), 7 spatial (5)
    n = 4 if planar else 7
    model, theta_star = random_model(rng, planar, n_bodies=n, joint_kinds=("revolute",),
                                     n_contacts=0, loop=kind, chain=True)
    return model.mechanism(), theta_star, rng


@pytest.mark.parametrize("planar,kind", LOOPS)
@pytest.mark.parametrize("seed", range(3))
def test_newton_assembly_reaches_the_constraint_manifold(planar, kind, seed):
    mech, theta_star, rng = _chain(planar, kind, seed)
    assert np.max(np.abs(mech.loop_residual(theta_star))) < 1e-12  # assembled by construction
    guess = theta_star + 0.05 * rng.normal(size=theta_star.size)
    assert np.max(np.abs(mech.loop_residual(guess))) > 1e-4
    theta = assemble(mech, guess, fixed=[0])
    assert np.max(np.abs(mech.loop_residual(theta))) <= 1e-12
    assert theta[0] == guess[0]  # the fixed coordinate is kept
    # C theta_dot = 0 after the velocity correction, keeping coordinate 0's rate
    dtheta = consistent_velocity(mech, theta, rng.normal(size=theta.size), fixed=[0])
    C = mech.loop_jacobian(theta)
    assert np.max(np.abs(C @ dtheta)) < 1e-12 * max(1.0, np.abs(dtheta).max())
    # and the corrected velocity moves along the manifold: Psi stays O(h^2)
    h = 1e-4
    assert np.max(np.abs(mech.loop_residual(theta + h * dtheta))) < 50 * h * h * (1 + dtheta @ dtheta)


def _slider_crank(r=0.15, l=0.4, offset=0.0):
    b = ModelBuilder(planar=True)
    b.add_body("crank", "ground", Joint.revolute(), 0.5, (r / 2, 0), 0.5 * r * r / 12)
    b.add_body("coupler", "crank", Joint.revolute(), 0.4, (l / 2, 0), 0.4 * l * l / 12,
               joint_origin=(r, 0))
    b.add_body("slider", "ground", Joint.prismatic((1, 0)), 0.3, (0, 0), 1e-3,
               joint_origin=(0, offset))
    b.add_loop("pin", "revolute", "coupler", "slider", origin_a=(l, 0))
    return b.build().mechanism()


def test_slider_crank_assembly_matches_closed_form():
    r, l = 0.15, 0.4
    mech = _slider_crank(r, l)
    for phi in np.radians([-150.0, -60.0, 10.0, 95.0]):
        theta = assemble(mech, [phi, -phi, r + l], fixed=["crank"])
        x = r * np.cos(phi) + np.sqrt(l * l - (r * np.sin(phi)) ** 2)
        assert theta[2] == pytest.approx(x, abs=1e-12)
        assert theta[0] + theta[1] == pytest.approx(np.arcsin(-r * np.sin(phi) / l), abs=1e-12)
        w = 7.0
        dtheta = consistent_velocity(mech, theta, [w, 0.0, 0.0], fixed=["crank"])
        xdot = -r * w * np.sin(phi) - (r * r * w * np.sin(phi) * np.cos(phi)
                                       / np.sqrt(l * l - (r * np.sin(phi)) ** 2))
        assert dtheta[2] == pytest.approx(xdot, rel=1e-10)
        assert np.allclose(mech.loop_jacobian(theta) @ dtheta, 0.0, atol=1e-12)


def test_unassemblable_loop_reports_the_residual():
    # slide line 0.8 m above the crank pivot, out of reach of r + l = 0.55 m
    mech = _slider_crank(offset=0.8)
    with pytest.raises(AssemblyError) as exc:
        assemble(mech, [0.3, 0.5, 0.2], fixed=["crank"])
    msg = str(exc.value)
    m = re.search(r"max \|Psi\| = ([0-9.e+-]+)", msg)
    assert m is not None and "link lengths" in msg
    # the best the free coordinates can do leaves at least 0.8 - (l + r sin(0.3)) in y
    assert float(m.group(1)) >= 0.8 - 0.4 - 0.15 * np.sin(0.3) - 1e-6


def test_velocity_that_cannot_be_made_consistent_raises():
    mech = _slider_crank()
    theta = assemble(mech, [0.4, -0.4, 0.5], fixed=["crank"])
    with pytest.raises(AssemblyError):
        consistent_velocity(mech, theta, [1.0, 0.0, 0.0], fixed=[0, 1, 2])


def test_open_tree_assembly_is_identity():
    model, theta = random_model(np.random.default_rng(0), True, n_contacts=0)
    mech = model.mechanism()
    assert mech.n_loop_constraints == 0
    assert np.array_equal(assemble(mech, theta), theta)
    assert mech.loop_residual(theta).shape == (0,)
    assert mech.loop_jacobian(theta).shape == (0, model.n_coordinates)
