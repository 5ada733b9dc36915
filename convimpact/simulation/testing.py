"""Small hand-derived mechanisms with closed-form dynamics, for tests and examples.

Each satisfies :class:`convimpact.mechanism.Mechanism` and is written from its Lagrangian
``L = 1/2 theta_dot^T M(theta) theta_dot - V(theta)`` by hand, independently of
:mod:`convimpact.model`. With ``p = M theta_dot`` the canonical equations give
``p_dot = 1/2 theta_dot^T (dM/dtheta) theta_dot - dV/dtheta + Q`` and eq. (2)
``M theta_ddot = f`` gives ``f = p_dot - M_dot theta_dot``.

* :class:`PointMass` -- a particle in a vertical plane above a floor (the drop test).
* :class:`DoublePendulum` -- two point masses on massless links hanging from a support
  above a floor; the lower mass strikes the floor.
* :class:`FallingRod` -- a slender rod whose two ends can strike the floor (simultaneous
  contacts, bouncing to rest).
* :class:`SliderCrank` -- crank, coupler (uniform rods), slider on the line y = 0 (loop cut at
  the coupler-slider pin: Psi = 0 has two rows) and a free slider ahead of it on the same line,
  struck centrally; an optional restoring torque ``-c (theta1_dot - omega)`` on the crank.
"""

from __future__ import annotations

import numpy as np


class PointMass:
    """Particle (x, y) of mass m under gravity g above the floor y = floor.

    Contact "floor": gap y - floor, frame n = +y, t = +x.
    """

    n_coordinates = 2
    n_loop_constraints = 0
    contact_names = ("floor",)

    def __init__(self, mass: float = 1.0, g: float = 9.81, e: float = 0.5, mu: float = 0.0,
                 floor: float = 0.0):
        self.m, self.g, self.e, self.mu, self.floor = mass, g, e, mu, floor

    def mass_matrix(self, theta):
        return self.m * np.eye(2)

    def mass_matrix_dot(self, theta, dtheta):
        return np.zeros((2, 2))

    def generalized_forces(self, t, theta, dtheta):
        return np.array([0.0, -self.m * self.g])

    def loop_residual(self, theta):
        return np.zeros(0)

    def loop_jacobian(self, theta):
        return np.zeros((0, 2))

    def loop_jacobian_dot(self, theta, dtheta):
        return np.zeros((0, 2))

    def contact_gap(self, name, theta):
        return float(theta[1] - self.floor)

    def contact_jacobian(self, name, theta):
        return np.array([[0.0, 1.0], [1.0, 0.0]])

    def contact_parameters(self, name):
        return self.e, self.mu

    def kinetic_energy(self, theta, dtheta):
        return 0.5 * self.m * float(dtheta @ dtheta)

    def potential_energy(self, theta):
        return self.m * self.g * float(theta[1])


class DoublePendulum:
    """Point masses m1, m2 on massless links l1, l2 from a support at height ``height``.

    theta = (phi1, phi2), absolute link angles from the downward vertical. Positions:
    x1 = l1 sin phi1, y1 = h - l1 cos phi1, x2 = x1 + l2 sin phi2, y2 = y1 - l2 cos phi2.
    Contact "tip": mass 2 against the floor y = 0, n = +y, t = +x.
    """

    n_coordinates = 2
    n_loop_constraints = 0
    contact_names = ("tip",)

    def __init__(self, m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81, height=1.8, e=0.8, mu=0.0):
        self.m1, self.m2, self.l1, self.l2, self.g, self.h = m1, m2, l1, l2, g, height
        self.e, self.mu = e, mu

    def mass_matrix(self, theta):
        a, b = theta
        c = self.m2 * self.l1 * self.l2 * np.cos(a - b)
        return np.array([[(self.m1 + self.m2) * self.l1**2, c], [c, self.m2 * self.l2**2]])

    def mass_matrix_dot(self, theta, dtheta):
        a, b = theta
        s = -self.m2 * self.l1 * self.l2 * np.sin(a - b) * (dtheta[0] - dtheta[1])
        return np.array([[0.0, s], [s, 0.0]])

    def generalized_forces(self, t, theta, dtheta):
        a, b = theta
        w1, w2 = dtheta
        k = self.m2 * self.l1 * self.l2 * np.sin(a - b)
        half = np.array([-k * w1 * w2, k * w1 * w2])  # 1/2 dq^T dM/dtheta_i dq
        gradV = np.array([(self.m1 + self.m2) * self.g * self.l1 * np.sin(a),
                          self.m2 * self.g * self.l2 * np.sin(b)])
        return half - gradV - self.mass_matrix_dot(theta, dtheta) @ dtheta

    def loop_residual(self, theta):
        return np.zeros(0)

    def loop_jacobian(self, theta):
        return np.zeros((0, 2))

    def loop_jacobian_dot(self, theta, dtheta):
        return np.zeros((0, 2))

    def tip(self, theta):
        a, b = theta
        return np.array([self.l1 * np.sin(a) + self.l2 * np.sin(b),
                         self.h - self.l1 * np.cos(a) - self.l2 * np.cos(b)])

    def contact_gap(self, name, theta):
        return float(self.tip(theta)[1])

    def contact_jacobian(self, name, theta):
        a, b = theta
        return np.array([[self.l1 * np.sin(a), self.l2 * np.sin(b)],     # d y2
                         [self.l1 * np.cos(a), self.l2 * np.cos(b)]])    # d x2

    def contact_parameters(self, name):
        return self.e, self.mu

    def kinetic_energy(self, theta, dtheta):
        return 0.5 * float(dtheta @ self.mass_matrix(theta) @ dtheta)

    def potential_energy(self, theta):
        a, b = theta
        y1 = self.h - self.l1 * np.cos(a)
        y2 = y1 - self.l2 * np.cos(b)
        return self.g * (self.m1 * y1 + self.m2 * y2)


class SliderCrank:
    """Slider-crank (closed loop) striking a free slider; horizontal plane (no gravity) by default.

    theta = (phi1 crank angle, phi2 coupler angle, x3 slider, x4 free slider), absolute angles
    from +x. Crank: uniform rod r, m1 about the origin; coupler: uniform rod l, m2 pinned at the
    crank tip; slider m3 at (x3, 0) pinned to the coupler's end (the cut joint):
    Psi = (r cos phi1 + l cos phi2 - x3, r sin phi1 + l sin phi2) = 0. Free slider m4 at x4.
    Contact "slider": gap x4 - x3 - clearance, n toward slider 4 (+x), t = +y (central impact:
    the tangent row is zero). Crank torque -c (phi1_dot - omega) keeps the speed near omega.
    """

    n_coordinates = 4
    n_loop_constraints = 2
    contact_names = ("slider",)

    def __init__(self, r=0.1, l=0.3, m1=0.1, m2=0.2, m3=0.3, m4=0.3, clearance=0.05,
                 e=0.83, mu=0.0, damping=0.0, omega=0.0, g=0.0):
        self.r, self.l, self.m = r, l, (m1, m2, m3, m4)
        self.clearance, self.e, self.mu = clearance, e, mu
        self.damping, self.omega, self.g = damping, omega, g

    def mass_matrix(self, theta):
        m1, m2, m3, m4 = self.m
        r, l = self.r, self.l
        c = 0.5 * m2 * r * l * np.cos(theta[0] - theta[1])
        return np.array([[m1 * r**2 / 3 + m2 * r**2, c, 0, 0],
                         [c, m2 * l**2 / 3, 0, 0],
                         [0, 0, m3, 0],
                         [0, 0, 0, m4]], dtype=float)

    def mass_matrix_dot(self, theta, dtheta):
        s = -0.5 * self.m[1] * self.r * self.l * np.sin(theta[0] - theta[1]) * (
            dtheta[0] - dtheta[1])
        out = np.zeros((4, 4))
        out[0, 1] = out[1, 0] = s
        return out

    def generalized_forces(self, t, theta, dtheta):
        m1, m2, _, _ = self.m
        r, l, g = self.r, self.l, self.g
        a, b = theta[0], theta[1]
        k = 0.5 * m2 * r * l * np.sin(a - b) * dtheta[0] * dtheta[1]
        half = np.array([-k, k, 0.0, 0.0])
        gradV = np.array([(0.5 * m1 + m2) * g * r * np.cos(a), 0.5 * m2 * g * l * np.cos(b), 0, 0])
        Q = np.array([-self.damping * (dtheta[0] - self.omega), 0.0, 0.0, 0.0])
        return half - gradV + Q - self.mass_matrix_dot(theta, dtheta) @ dtheta

    def loop_residual(self, theta):
        a, b, x3 = theta[0], theta[1], theta[2]
        return np.array([self.r * np.cos(a) + self.l * np.cos(b) - x3,
                         self.r * np.sin(a) + self.l * np.sin(b)])

    def loop_jacobian(self, theta):
        a, b = theta[0], theta[1]
        r, l = self.r, self.l
        return np.array([[-r * np.sin(a), -l * np.sin(b), -1.0, 0.0],
                         [r * np.cos(a), l * np.cos(b), 0.0, 0.0]])

    def loop_jacobian_dot(self, theta, dtheta):
        a, b = theta[0], theta[1]
        r, l = self.r, self.l
        return np.array([[-r * np.cos(a) * dtheta[0], -l * np.cos(b) * dtheta[1], 0.0, 0.0],
                         [-r * np.sin(a) * dtheta[0], -l * np.sin(b) * dtheta[1], 0.0, 0.0]])

    def assembled(self, phi1: float, dphi1: float, x4: float, dx4: float):
        """(theta, theta_dot) on Psi = 0, C theta_dot = 0 with the coupler's elbow up."""
        r, l = self.r, self.l
        s = -r * np.sin(phi1) / l
        phi2 = np.arcsin(s)
        x3 = r * np.cos(phi1) + l * np.cos(phi2)
        dphi2 = -r * np.cos(phi1) * dphi1 / (l * np.cos(phi2))
        dx3 = -r * np.sin(phi1) * dphi1 - l * np.sin(phi2) * dphi2
        return np.array([phi1, phi2, x3, x4]), np.array([dphi1, dphi2, dx3, dx4])

    def contact_gap(self, name, theta):
        return float(theta[3] - theta[2] - self.clearance)

    def contact_jacobian(self, name, theta):
        return np.array([[0.0, 0.0, -1.0, 1.0], [0.0, 0.0, 0.0, 0.0]])

    def contact_parameters(self, name):
        return self.e, self.mu

    def kinetic_energy(self, theta, dtheta):
        return 0.5 * float(dtheta @ self.mass_matrix(theta) @ dtheta)

    def potential_energy(self, theta):
        m1, m2, _, _ = self.m
        a, b = theta[0], theta[1]
        return self.g * (0.5 * m1 * self.r * np.sin(a)
                         + m2 * (self.r * np.sin(a) + 0.5 * self.l * np.sin(b)))


class FallingRod:
    """Uniform slender rod (x, y, phi) of mass m and length L under gravity above the floor y = 0.

    theta = (x, y, phi): centre of mass and angle from +x. Contacts "left" and "right": the ends
    (x -+ L/2 cos phi, y -+ L/2 sin phi) against the floor, frame n = +y, t = +x.
    """

    n_coordinates = 3
    n_loop_constraints = 0
    contact_names = ("left", "right")

    def __init__(self, mass=1.0, length=1.0, g=9.81, e=0.5, mu=0.0):
        self.m, self.L, self.g, self.e, self.mu = mass, length, g, e, mu

    def mass_matrix(self, theta):
        return np.diag([self.m, self.m, self.m * self.L**2 / 12.0])

    def mass_matrix_dot(self, theta, dtheta):
        return np.zeros((3, 3))

    def generalized_forces(self, t, theta, dtheta):
        return np.array([0.0, -self.m * self.g, 0.0])

    def loop_residual(self, theta):
        return np.zeros(0)

    def loop_jacobian(self, theta):
        return np.zeros((0, 3))

    def loop_jacobian_dot(self, theta, dtheta):
        return np.zeros((0, 3))

    def _sign(self, name):
        return -1.0 if name == "left" else 1.0

    def contact_gap(self, name, theta):
        return float(theta[1] + self._sign(name) * 0.5 * self.L * np.sin(theta[2]))

    def contact_jacobian(self, name, theta):
        s, h, phi = self._sign(name), 0.5 * self.L, theta[2]
        return np.array([[0.0, 1.0, s * h * np.cos(phi)],
                         [1.0, 0.0, -s * h * np.sin(phi)]])

    def contact_parameters(self, name):
        return self.e, self.mu

    def kinetic_energy(self, theta, dtheta):
        return 0.5 * float(dtheta @ self.mass_matrix(theta) @ dtheta)

    def potential_energy(self, theta):
        return self.m * self.g * float(theta[1])
