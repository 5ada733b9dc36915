"""Placing mechanisms at rest on contacts: closed gaps, nearest configuration, rest velocities,
and the typed errors of impossible requests."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

import convimpact as ci
from convimpact.errors import (
    AssemblyError,
    ConvImpactError,
    ModelError,
    ParameterError,
    ShapeError,
    SingularSystemError,
)
from convimpact.model import Joint, ModelBuilder, place_resting, rest_velocity

W, H = 0.4, 1.0  # box width, height


def _box(normal=(0.0, 1.0), with_top=False):
    b = ModelBuilder(planar=True)
    b.add_body("box", "ground", Joint.free(), 2.0, (0.0, 0.0), 2.0 * (W * W + H * H) / 12,
               coordinate_names=["x", "y", "phi"])
    corners = [("left", (-W / 2, -H / 2)), ("right", (W / 2, -H / 2))]
    if with_top:
        corners.append(("top_left", (-W / 2, H / 2)))
    for name, p in corners:
        b.add_contact(name, body="box", point=p, normal=normal, mu=0.5)
    return b.build().mechanism()


def _corner_y(theta, p):
    x, y, phi = theta
    return y + np.sin(phi) * p[0] + np.cos(phi) * p[1]


def test_box_tilted_about_a_corner_lands_flat_on_both_corners():
    mech = _box()
    guess = np.array([0.3, 1.4, 0.35])  # tilted, above the floor
    theta = place_resting(mech, guess, ["left", "right"])
    for c in ("left", "right"):
        assert abs(mech.contact_gap(c, theta)) <= 1e-12
    assert theta[1] == pytest.approx(H / 2, abs=1e-12) and theta[2] == pytest.approx(0.0, abs=1e-12)
    # the nearest such configuration in the M metric, by an independent constrained solve
    M = mech.mass_matrix(guess)
    cons = [{"type": "eq", "fun": lambda th, p=p: _corner_y(th, p)}
            for p in ((-W / 2, -H / 2), (W / 2, -H / 2))]
    ref = minimize(lambda th: (th - guess) @ M @ (th - guess), guess, constraints=cons,
                   method="SLSQP", options={"ftol": 1e-14, "maxiter": 200})
    assert np.allclose(theta, ref.x, atol=1e-6)


def test_box_on_one_corner_with_its_tilt_fixed():
    mech = _box()
    guess = np.array([0.25, 2.0, -0.1])
    theta = place_resting(mech, guess, "right", fixed=["phi"])
    assert theta[2] == guess[2]  # fixed: bit-identical
    assert theta[0] == guess[0]  # the gap does not depend on x: the least change keeps it
    assert abs(mech.contact_gap("right", theta)) <= 1e-12
    assert mech.contact_gap("left", theta) == pytest.approx(W * np.sin(0.1), rel=1e-12)
    # fixing by index is the same
    assert np.array_equal(place_resting(mech, guess, ["right"], fixed=[2]), theta)


def test_box_on_an_incline_lies_along_it():
    a = np.radians(30.0)
    mech = _box(normal=(-np.sin(a), np.cos(a)))
    theta = place_resting(mech, [0.0, 1.0, 0.0], ["left", "right"])
    assert theta[2] == pytest.approx(a, abs=1e-12)
    for c in ("left", "right"):
        assert abs(mech.contact_gap(c, theta)) <= 1e-12
    # the centre is H/2 above the incline
    assert -np.sin(a) * theta[0] + np.cos(a) * theta[1] == pytest.approx(H / 2, abs=1e-12)


def _wheel(n=8, slope_deg=5.0):
    g = np.radians(slope_deg)
    b = ModelBuilder(planar=True)
    b.add_body("hub", "ground", Joint.free(), 1.0, (0, 0), 0.01,
               coordinate_names=["x", "y", "phi"])
    for i in range(n):
        ang = -np.pi / 2 + 2 * np.pi * i / n
        b.add_contact(f"foot{i}", body="hub", point=(np.cos(ang), np.sin(ang)),
                      normal=(-np.sin(g), np.cos(g)))
    return b.build().mechanism(), g


def test_rimless_wheel_placed_on_two_feet():
    n = 8
    mech, g = _wheel(n)
    theta = place_resting(mech, [0.1, 1.3, 0.2], ["foot0", "foot1"])
    gaps = np.array([mech.contact_gap(f"foot{i}", theta) for i in range(n)])
    assert np.max(np.abs(gaps[:2])) <= 1e-12 and np.all(gaps[2:] > 0.1)
    # the chord between the feet lies along the slope: spoke angles -90 + phi, -45 + phi
    assert theta[2] == pytest.approx(g - np.pi / n, abs=1e-12)
    # the hub is l cos(pi/n) above the slope
    height = -np.sin(g) * theta[0] + np.cos(g) * theta[1]
    assert height == pytest.approx(np.cos(np.pi / n), abs=1e-12)


def test_placement_keeps_loops_closed():
    r, cl = 0.15, 0.4
    b = ModelBuilder(planar=True)
    b.add_body("crank", "ground", Joint.revolute(), 0.5, (r / 2, 0), 0.5 * r * r / 12)
    b.add_body("coupler", "crank", Joint.revolute(), 0.4, (cl / 2, 0), 0.4 * cl * cl / 12,
               joint_origin=(r, 0))
    b.add_body("slider", "ground", Joint.prismatic((1, 0)), 0.3, (0, 0), 1e-3)
    b.add_loop("pin", "revolute", "coupler", "slider", origin_a=(cl, 0))
    # the coupler's midpoint rests on a floor 0.05 below the slider's line
    b.add_contact("knee", body="coupler", point=(cl / 2, 0), normal=(0, 1),
                  plane_point=(0, -0.05))
    mech = b.build().mechanism()
    phi = -0.5
    psi = np.arcsin(-r * np.sin(phi) / cl)
    guess = mech.assemble(np.array([phi, psi - phi, r * np.cos(phi) + cl * np.cos(psi)]))
    theta = place_resting(mech, guess, ["knee"])
    assert abs(mech.contact_gap("knee", theta)) <= 1e-12
    assert np.max(np.abs(mech.loop_residual(theta))) <= 1e-12
    # closed form: the knee's height is (r/2) sin(phi) = -0.05
    assert np.sin(theta[0]) == pytest.approx(-0.1 / r, abs=1e-12)
    v = rest_velocity(mech, theta, np.array([1.0, 0.0, 0.0]), ["knee"])
    assert abs(mech.contact_jacobian("knee", theta)[0] @ v) <= 1e-12
    assert np.max(np.abs(mech.loop_jacobian(theta) @ v)) <= 1e-12


def test_spatial_ball_resting_on_the_floor():
    b = ModelBuilder(planar=False)
    b.add_body("ball", "ground", Joint.free(), 1.0, (0, 0, 0), [0.004] * 3,
               coordinate_names=["x", "y", "z", "rx", "ry", "rz"])
    b.add_contact("floor", body="ball", point=(0, 0, 0), radius=0.1, normal=(0, 1, 0))
    mech = b.build().mechanism()
    guess = np.array([0.2, 0.7, -0.3, 0.1, 0.2, 0.3])
    theta = place_resting(mech, guess, ["floor"])
    assert theta[1] == pytest.approx(0.1, abs=1e-13)
    assert np.array_equal(np.delete(theta, 1), np.delete(guess, 1))


def test_rest_velocity_is_the_m_metric_projection():
    mech = _box()
    theta = place_resting(mech, [0.0, 1.0, 0.0], ["left", "right"])
    v = np.array([1.0, -2.0, 0.7])
    out = rest_velocity(mech, theta, v, ["left", "right"])
    for c in ("left", "right"):
        Jc = mech.contact_jacobian(c, theta)
        assert abs(Jc[0] @ out) <= 1e-14
    assert out[0] == pytest.approx(1.0)  # sliding kept
    # the correction is M-orthogonal to every velocity that keeps the contacts closed
    M = mech.mass_matrix(theta)
    assert (np.array([1.0, 0.0, 0.0]) @ M @ (out - v)) == pytest.approx(0.0, abs=1e-14)
    # fixed rates are kept; one contact only: the box may turn about the other corner
    one = rest_velocity(mech, theta, v, "right", fixed=["phi"])
    assert one[2] == v[2] and abs(mech.contact_jacobian("right", theta)[0] @ one) <= 1e-14


def test_exports():
    assert ci.place_resting is place_resting and ci.rest_velocity is rest_velocity
    assert "place_resting" in ci.__all__ and "rest_velocity" in ci.__all__


def test_errors_name_the_problem():
    mech = _box(with_top=True)
    guess = np.array([0.0, 2.0, 0.3])
    with pytest.raises(ModelError, match="unknown contact 'nope'"):
        place_resting(mech, guess, ["left", "nope"])
    with pytest.raises(ModelError):
        place_resting(mech, guess, ["left"], fixed=["psi"])
    with pytest.raises(ModelError):
        rest_velocity(mech, guess, np.zeros(3), ["nope"])
    with pytest.raises(ParameterError, match="more than once"):
        place_resting(mech, guess, ["left", "left"])
    with pytest.raises(ShapeError):
        place_resting(mech, guess[:2], ["left"])
    # both corners with the tilt fixed: the gaps differ by W sin(tilt), not independent
    with pytest.raises(SingularSystemError, match="not independent"):
        place_resting(mech, guess, ["left", "right"], fixed=["phi"])
    # three corners of a rigid box cannot all touch the floor
    with pytest.raises(SingularSystemError):
        place_resting(mech, np.array([0.0, 2.0, 0.0]), ["left", "right", "top_left"])
    with pytest.raises(SingularSystemError, match="every coordinate is fixed"):
        place_resting(mech, guess, ["left"], fixed=[0, 1, 2])
    # three gaps of a body whose x does not enter them: never independent
    with pytest.raises(SingularSystemError):
        place_resting(mech, np.array([0.0, 2.0, 0.3]), ["left", "right", "top_left"])


def test_geometrically_impossible_request_fails_with_assembly_error():
    """Two corners 0.4 m apart cannot touch planes 1 m apart: independent gaps, no solution."""
    b = ModelBuilder(planar=True)
    b.add_body("box", "ground", Joint.free(), 2.0, (0.0, 0.0), 2.0 * (W * W + H * H) / 12,
               coordinate_names=["x", "y", "phi"])
    b.add_contact("left", body="box", point=(-W / 2, -H / 2), normal=(0, 1))
    b.add_contact("high", body="box", point=(W / 2, -H / 2), normal=(0, 1), plane_point=(0, 1))
    mech = b.build().mechanism()
    for tilt in (0.3, -0.3, 0.0):
        with pytest.raises(AssemblyError, match="cannot place") as info:
            place_resting(mech, [0.0, 2.0, tilt], ["left", "high"])
        assert isinstance(info.value, ConvImpactError) and "max |gap|" in str(info.value)


def test_unreachable_contact_fails_with_assembly_error():
    """A pendulum whose tip cannot reach the floor: no silent answer."""
    b = ModelBuilder(planar=True)
    b.add_body("rod", "ground", Joint.revolute(), 1.0, (0.5, 0.0), 1 / 12)
    b.add_contact("tip", body="rod", point=(1.0, 0.0), normal=(0, 1), plane_point=(0, -2.0))
    mech = b.build().mechanism()
    with pytest.raises(AssemblyError, match="cannot place"):
        place_resting(mech, [-1.0], ["tip"])
    # started exactly at the bottom, the gap's gradient is zero
    with pytest.raises(SingularSystemError):
        place_resting(mech, [-np.pi / 2], ["tip"])
