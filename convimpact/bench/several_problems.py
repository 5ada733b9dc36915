"""The several-contact benchmark's problems: a free box landing on its four bottom corners and
random impacts of 2-8 contacts (the same ones for every solver of the several-contact section).

The box (k = 6: the centre's velocity and the angular velocity in world axes, at the
instant its faces are aligned with the world axes) has half sizes (a, b, c), mass m and
I = m/3 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2) about its centre; its corners p = (+-a, +-b, -c)
touch the floor z = 0 with the contact frame (n, t1, t2) = (z, x, y), so each contact's rows
are ``(axis, p x axis)``. Four contacts on six coordinates: the 12 x 12 Delassus matrix has
rank 6, the impulses are not unique, the velocities are.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .problems import random_impact


def four_corner_box(mu: float = 0.3, e: float = 0.5,
                    velocity: Sequence[float] = (0.8, 0.3, -1.0),
                    angular_velocity: Sequence[float] = (0.3, -0.2, 0.5),
                    half_sizes: Sequence[float] = (0.2, 0.15, 0.1),
                    mass: float = 1.0) -> dict[str, Any]:
    """``resolve_impact`` arguments (M, Jc, dq, e, mu, C) of the box landing on four corners."""
    a, b, c = (float(h) for h in half_sizes)
    inertia = mass / 3.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    M = np.diag([mass, mass, mass, *inertia])
    axes = (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    Jc = []
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            p = np.array([sx * a, sy * b, -c])
            Jc.append(np.array([np.concatenate([ax, np.cross(p, ax)]) for ax in axes]))
    dq = np.array([*velocity, *angular_velocity], dtype=float)
    return dict(M=M, Jc=Jc, dq=dq, e=float(e), mu=float(mu), C=None)


def random_several(seed: int, n_contacts: int, dim: int, k: int | None = None,
                   cond: float = 1e2) -> dict[str, Any]:
    """``resolve_impact`` arguments of a random impact of ``n_contacts`` contacts: k = n d + 2
    coordinates (W nonsingular), e ~ U(0.2, 0.9), mu ~ U(0.1, 1) per contact."""
    rng = np.random.default_rng([seed, n_contacts, dim])
    e = float(rng.uniform(0.2, 0.9))
    mu = rng.uniform(0.1, 1.0, size=n_contacts)
    return random_impact(rng, k or n_contacts * dim + 2, n_contacts, dim, 0, cond, e, mu)
