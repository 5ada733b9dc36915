"""A contact problem given as a Delassus matrix: a box landing flat on its four corners.

Run: ``python examples/contact_problem.py``. ``solve_contact_problem(W, b, mu, law=...)``
solves ``u = W r + b`` with Coulomb's law (or its convex relaxation, the CCP) at every
contact and certifies the answer by its natural-map residual. Here W = J M^-1 J^T of a cube
of mass 1 and side 0.2 landing flat (its 4 x 3 contact rows, a singular W: 12 rows, 6
velocities) and b = J v with v the landing velocity, straight down at 1 m/s. The impulses stop
the fall (a plastic landing, u = 0) and carry no friction; their sum is m * 1 and their moments
cancel, which leaves a family of answers (r1 = r3, r2 = r4, r1 + r2 = 0.5, corners counted
around the box): W is singular. The engine's interior point returns the central one, 0.25 each.
"""

import numpy as np

import convimpact as ci


def box_contact_problem(mass=1.0, side=0.2, speed=1.0):
    """W and b of a cube landing flat on a floor: rows (n, t1, t2) = (z, x, y) per corner."""
    inertia = mass * side**2 / 6.0                     # a uniform cube about its centre
    Minv = np.diag([1 / mass] * 3 + [1 / inertia] * 3)
    h = side / 2
    rows = []
    for cx, cy in ((h, h), (-h, h), (-h, -h), (h, -h)):
        p = np.array([cx, cy, -h])                     # the corner from the centre
        for axis in (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]),
                     np.array([0.0, 1.0, 0.0])):
            rows.append(np.concatenate([axis, np.cross(p, axis)]))   # v + w x p along axis
    J = np.array(rows)
    v = np.array([0.0, 0.0, -speed, 0.0, 0.0, 0.0])
    return J @ Minv @ J.T, J @ v


def main():
    W, b = box_contact_problem()
    print(f"W: {W.shape}, rank {np.linalg.matrix_rank(W)}")
    for law in ("coulomb", "ccp"):
        sol = ci.solve_contact_problem(W, b.reshape(4, 3), mu=0.5, law=law)   # (n, d)
        print(f"{law:8s} {sol.status}: normal impulses {np.round(sol.impulse[:, 0], 6)}, "
              f"largest friction {np.abs(sol.impulse[:, 1:]).max():.1e}, "
              f"largest |u| {np.abs(sol.velocity).max():.1e}, residual {sol.residual:.1e}")
    return sol


if __name__ == "__main__":
    main()
