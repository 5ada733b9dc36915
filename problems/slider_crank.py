"""Slider-crank striking a free slider along the slide line: Section 9.1 (Fig. 2).

The paper's geometry comes from its reference [7], which is not available; we chose a
plausible in-line slider-crank (all values are parameters):

* crank (body 1): uniform bar, length 0.15 m, mass 0.5 kg, hinged at the origin (theta1);
* coupler (body 2): uniform bar, length 0.40 m, mass 0.4 kg, hinged to the crank end
  (theta2, relative to the crank);
* slider (body 3): block 0.10 m x 0.05 m, mass 0.3 kg, sliding on the x axis (theta3 = the
  x position of its pin);
* the loop is cut at the coupler-slider pin (a planar revolute cut joint, 2 constraints);
* free slider (body 4): block 0.10 m wide on the same line (theta4 = its centre's x), struck
  by slider 3's right face: a central impact, n = -x (toward body 3), t = -y.

Joint coordinates theta = (theta1, theta2, theta3, theta4); gravity acts along -y, normal to
the slide, so it does not drive the sliders.

Driving torque: a speed regulator on the crank, ``tau1 = K (omega_ref - theta1_dot)`` with
``K = J / tau_c``, where J is the crank-axis inertia of the constrained mechanism at
theta1 = 0 and ``tau_c = 0.02 s`` (the paper's "restoring torque"). It holds the crank near
omega_ref but not tightly: measured over 1-3 s of simulation, theta1_dot stays within
14.8-25.7 rad/s (about +-27 % of 20 rad/s), because the crank-axis inertia varies along the
turn. A stiffer regulator (smaller tau_c) would hold it closer at the price of a stiff
integration.

Impact state: crank at theta1 = -60 degrees turning at omega_ref = 20 rad/s (slider 3 moving
right, toward body 4), assembled by Newton's method; slider 4 touches slider 3 and approaches
it (moving left, "driven inertially to the left") with the same speed as slider 3. Its mass is
``mass_ratio`` (1, 5 or 10: the paper's cases 1-3 of Fig. 3) times the crank-slider's
generalized mass along the slide at that configuration, ``1 / (u^T J3 G J3^T u)`` with G the
loop-constrained inverse mass matrix. The simulation starts with the same crank state and
slider 4 0.05 m further right, so they collide shortly after — at theta1 of about -50.6
degrees, not at the -60 degree impact state where the free slider's mass is defined (the
impact examples use the -60 degree state).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import Joint, ModelBuilder
from convimpact.model import impact_arguments as _impact_arguments
from convimpact.scenes import Scene
from convimpact.validation import NonNegative, Positive, Real, Unit

CRANK_LENGTH, CRANK_MASS = 0.15, 0.5
COUPLER_LENGTH, COUPLER_MASS = 0.40, 0.4
SLIDER_MASS, SLIDER_HALF_WIDTH, SLIDER_HALF_HEIGHT = 0.3, 0.05, 0.025

#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"mass_ratio": Positive(), "e": Unit(), "mu": NonNegative(),
              "omega_ref": Real(0.0, low_open=True)}


FREE_SLIDER_HALF_WIDTH = 0.05
OMEGA_REF = 20.0
CRANK_ANGLE_IMPACT = np.radians(-60.0)
TIME_CONSTANT = 0.02


def _bar(b: ModelBuilder, name, parent, mass, length, origin, coord):
    b.add_body(name, parent, Joint.revolute(), mass, (length / 2, 0.0), mass * length ** 2 / 12,
               joint_origin=origin, coordinate_names=[coord])


def _build(m4: float, e: float, mu: float, gain: float, omega_ref: float):
    b = ModelBuilder(planar=True)
    _bar(b, "crank", "ground", CRANK_MASS, CRANK_LENGTH, (0.0, 0.0), "theta1")
    _bar(b, "coupler", "crank", COUPLER_MASS, COUPLER_LENGTH, (CRANK_LENGTH, 0.0), "theta2")
    block = lambda m, hw, hh: m * ((2 * hw) ** 2 + (2 * hh) ** 2) / 12  # noqa: E731
    b.add_body("slider", "ground", Joint.prismatic((1.0, 0.0)), SLIDER_MASS, (0.0, 0.0),
               block(SLIDER_MASS, SLIDER_HALF_WIDTH, SLIDER_HALF_HEIGHT),
               coordinate_names=["theta3"])
    b.add_body("free_slider", "ground", Joint.prismatic((1.0, 0.0)), m4, (0.0, 0.0),
               block(m4, FREE_SLIDER_HALF_WIDTH, SLIDER_HALF_HEIGHT), coordinate_names=["theta4"])
    b.add_loop("pin", "revolute", "coupler", "slider", origin_a=(COUPLER_LENGTH, 0.0))
    b.add_contact("blocks", body="slider", point=(SLIDER_HALF_WIDTH, 0.0), against="free_slider",
                  plane_point=(-FREE_SLIDER_HALF_WIDTH, 0.0), normal=(-1.0, 0.0), e=e, mu=mu)

    def driving_torque(t, theta, dtheta):
        tau = np.zeros(4)
        tau[0] = gain * (omega_ref - dtheta[0])
        return tau

    b.set_applied_forces(driving_torque)
    return b.build()


def _crank_state(mech, theta1: float, omega: float):
    """Assembled (theta, theta_dot) of the crank-slider for a crank angle and speed."""
    r, l = CRANK_LENGTH, COUPLER_LENGTH
    # rough guess, then Newton with theta1 fixed
    phi2 = np.arcsin(np.clip(-r * np.sin(theta1) / l, -1, 1))
    guess = np.array([theta1, phi2 - theta1 + 0.05, r * np.cos(theta1) + l * np.cos(phi2) + 0.01, 1.0])
    theta = mech.assemble(guess, fixed=["theta1", "theta4"])
    dtheta = mech.consistent_velocity(theta, np.array([omega, 0.0, 0.0, 0.0]),
                                      fixed=["theta1", "theta4"])
    return theta, dtheta


def generalized_slide_mass(mech, theta) -> float:
    """Crank-slider's generalized mass along the slide: 1 / (u^T J3 G J3^T u), eq. (59) style."""
    M = mech.mass_matrix(theta)[:3, :3]
    C = mech.loop_jacobian(theta)[:, :3]
    Minv = np.linalg.inv(M)
    G = Minv - Minv @ C.T @ np.linalg.solve(C @ Minv @ C.T, C @ Minv)
    u = np.array([0.0, 0.0, 1.0])  # slider 3's velocity along +x is theta3_dot
    return 1.0 / float(u @ G @ u)


def make_scene(mass_ratio: float = 1.0, e: float = 0.83, mu: float = 0.0,
               omega_ref: float = OMEGA_REF) -> Scene:
    """The slider-crank of Section 9.1 (see the module docstring for every assumption)."""
    mass_ratio = float(mass_ratio)
    probe = _build(1.0, e, mu, 0.0, omega_ref).mechanism()
    th0, _ = _crank_state(probe, 0.0, omega_ref)
    # crank-axis inertia of the constrained mechanism at theta1 = 0: theta_dot = N w, N from C
    C = probe.loop_jacobian(th0)[:, :3]
    n = np.linalg.solve(C[:, 1:], -C[:, :1]).ravel()
    N = np.concatenate([[1.0], n])
    J = float(N @ probe.mass_matrix(th0)[:3, :3] @ N)
    gain = J / TIME_CONSTANT
    th_imp, dth_mech = _crank_state(probe, CRANK_ANGLE_IMPACT, omega_ref)
    m_slide = generalized_slide_mass(probe, th_imp)
    m4 = mass_ratio * m_slide
    mech = _build(m4, e, mu, gain, omega_ref).mechanism()
    v3 = dth_mech[2]
    x4 = th_imp[2] + SLIDER_HALF_WIDTH + FREE_SLIDER_HALF_WIDTH
    theta_imp = th_imp.copy()
    theta_imp[3] = x4
    dtheta_imp = dth_mech.copy()
    dtheta_imp[3] = -abs(v3)
    theta0 = theta_imp.copy()
    theta0[3] += 0.05
    description = (
        "Slider-crank of Pereira & Nikravesh (1996) Section 9.1 with a free slider on the slide "
        "line. The paper's geometry (its ref. [7]) is unavailable: we chose crank 0.15 m / 0.5 kg, "
        "coupler 0.40 m / 0.4 kg (uniform bars), slider 3 0.3 kg (0.10 x 0.05 m block), the loop "
        "cut at the coupler-slider pin. Crank speed held near omega_ref = "
        f"{omega_ref} rad/s by tau1 = K (omega_ref - theta1_dot), K = {gain:.4g} N m s "
        f"(crank inertia / 0.02 s). Impact at theta1 = -60 deg: slider 3 moving right at "
        f"{v3:.4g} m/s, slider 4 ({m4:.4g} kg = {mass_ratio:g} x the crank-slider's generalized "
        f"mass {m_slide:.4g} kg along the slide) touching and moving left at the same speed. "
        "Central impact, n = -x toward slider 3, t = -y; default e = 0.83 as in the paper."
    )
    params = dict(mass_ratio=mass_ratio, e=e, mu=mu, omega_ref=omega_ref, speed_gain=gain,
                  crank_length=CRANK_LENGTH, crank_mass=CRANK_MASS,
                  coupler_length=COUPLER_LENGTH, coupler_mass=COUPLER_MASS,
                  slider_mass=SLIDER_MASS, free_slider_mass=m4, generalized_slide_mass=m_slide,
                  crank_angle_at_impact=float(CRANK_ANGLE_IMPACT), slider_speed=float(v3),
                  assumptions=["geometry and masses chosen (paper's ref. [7] unavailable)",
                               "crank speed regulator tau1 = K (omega_ref - theta1_dot)",
                               "slider 4 approaches with slider 3's speed"])
    return Scene(name="slider_crank", description=description, mechanism=mech,
                 theta0=theta0, dtheta0=dtheta_imp.copy(), t_end=1.0,
                 parameters=MappingProxyType(params),
                 impact_state=(theta_imp, dtheta_imp), impact_contact="blocks")


def impact_arguments(mass_ratio: float = 1.0, e: float = 0.83, mu: float = 0.0) -> dict:
    """Raw ``resolve_impact`` arguments (M, Jc, dq, C, e, mu) at the scene's impact state."""
    scene = make_scene(mass_ratio=mass_ratio, e=e, mu=mu)
    theta, dtheta = scene.impact_state
    return _impact_arguments(scene.mechanism, theta, dtheta, contacts="blocks")
