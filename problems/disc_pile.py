"""A pile of 114 discs settling in a box: a scene of many contacts for Moreau–Jean.

Planar. Uniform discs (radii drawn uniformly in [0.046, 0.0499] m by ``seed``, mass
1 kg x (r / 0.05)^2, I = m r^2 / 2; chosen), each on a free planar joint, theta = (x_i, y_i,
phi_i) per disc, start at rest on the sites of a loose hexagonal lattice: ``rows`` rows
(default 12) alternately of ``columns`` (default 10) and ``columns - 1`` sites 0.1 m apart,
the rows 1.15 sqrt(3) 0.05 = 0.0996 m apart (15 % more than in a close packing), the lowest
0.06 m above the floor, inside a box of inner width 0.1 m x ``columns`` (the floor y = 0 and
the walls x = 0 and x = width). No two discs touch at the start; they fall by up to some
centimetres, each row into the hollows of the one below, and settle into a pile of some 230
to 260 closed contacts (redundant: a disc resting on two others and pressed by two more).

Contacts (e = 0, mu = 0.3 everywhere; chosen): every disc against the floor and each wall
(planes), and every pair of discs whose centres start closer than :data:`NEIGHBOUR_FACTOR`
times the sum of their radii (disc against disc: the normal along the line of centres; the
lattice's neighbours, in the row and in the rows above and below). The candidate pairs are
fixed when the scene is built: a disc that left its neighbours would pass through others
unseen; :func:`unlisted_overlap` measures that on a run (the bench section ``moreau-scale``
reports it; it is 0 when the pile settles in place, as it does here).

The scene declares Moreau–Jean as its scheme (``simulation``: law ``coulomb``, h = 2 ms,
certificate tolerance 1e-6, see below): event-driven simulation of a settling pile (hundreds
of impacts and stick-slip transitions, redundant contacts) is not what that scheme is for.
The tolerance: on this pile's impact steps (some 100 contacts in one island) the engine's
Coulomb solve stalls between 1e-8 and 1e-7 in natural-map residual (its ADMM's iteration
limit), so the scene asks for 1e-6; law ``ccp`` is certified at 1e-8.

Expected: the pile comes to rest (kinetic energy -> 0) with no penetration beyond the
scheme's O(h |v|); e = 0, so the energy only falls (by theta = 1/2's O(h) impact-step error
at most, see :mod:`convimpact.simulation.moreau`).

Parameters of :func:`make_scene`: columns (10), rows (12), mu (0.3), e (0), seed (0),
t_end (1 s).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import Joint, ModelBuilder
from convimpact.scenes import Scene
from convimpact.validation import Integer, NonNegative, Positive, Unit

PARAMETERS = {"columns": Integer(2, 1000), "rows": Integer(1, 1000), "mu": NonNegative(),
              "e": Unit(), "seed": Integer(0), "t_end": Positive()}

G = 9.81
#: disc pairs closer than this factor times the sum of their radii at the start are contacts
NEIGHBOUR_FACTOR = 2.3
#: default step of the scene's Moreau–Jean run (s)
STEP = 2e-3
#: lattice half spacing (m), radii range, first row height, row spacing (a hexagonal
#: lattice of discs of radius R opened by 15 %: rows sqrt(3) R apart in contact)
R = 0.05
R_MIN, R_MAX = 0.046, 0.0499
BOTTOM = 0.06
ROW_SPACING = 1.15 * np.sqrt(3.0) * R
#: the certificate tolerance of the scene's Coulomb run (see the module docstring)
COULOMB_TOL = 1e-6


def layout(columns: int, rows: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Initial centres (n, 2) and radii (n,) (see the module docstring): rows alternately of
    ``columns`` and ``columns - 1`` sites, ``2 R`` apart, rows ``ROW_SPACING`` apart."""
    rng = np.random.default_rng(seed)
    sites = []
    for j in range(rows):
        odd = j % 2
        for i in range(columns - odd):
            sites.append((R * (1 + odd) + 2 * R * i, BOTTOM + ROW_SPACING * j))
    centres = np.array(sites, dtype=float)
    radii = rng.uniform(R_MIN, R_MAX, len(sites))
    return centres, radii


def neighbour_pairs(centres: np.ndarray, radii: np.ndarray) -> list[tuple[int, int]]:
    """Pairs (i < j) whose centres are closer than NEIGHBOUR_FACTOR (r_i + r_j)."""
    d = np.linalg.norm(centres[:, None, :] - centres[None, :, :], axis=2)
    lim = NEIGHBOUR_FACTOR * (radii[:, None] + radii[None, :])
    i, j = np.nonzero(np.triu(d < lim, 1))
    return list(zip(i.tolist(), j.tolist()))


def unlisted_overlap(theta: np.ndarray, radii: np.ndarray, pairs) -> float:
    """Largest overlap (m, >= 0) of two discs that are not a candidate pair, over the
    configurations ``theta`` (m, 3 n) or (3 n,)."""
    th = np.atleast_2d(theta)
    n = radii.size
    listed = np.zeros((n, n), dtype=bool)
    for i, j in pairs:
        listed[i, j] = listed[j, i] = True
    np.fill_diagonal(listed, True)
    worst = 0.0
    for row in th:
        c = row.reshape(n, 3)[:, :2]
        d = np.linalg.norm(c[:, None, :] - c[None, :, :], axis=2)
        overlap = np.where(listed, -np.inf, radii[:, None] + radii[None, :] - d)
        worst = max(worst, float(overlap.max()))
    return max(worst, 0.0)


def make_scene(columns: int = 10, rows: int = 12, mu: float = 0.3, e: float = 0.0,
               seed: int = 0, t_end: float = 1.0) -> Scene:
    """The disc pile (see the module docstring)."""
    width = 2 * R * columns
    centres, radii = layout(columns, rows, seed)
    n = radii.size
    b = ModelBuilder(planar=True)
    mass = (radii / 0.05) ** 2
    for i in range(n):
        b.add_body(f"disc{i}", "ground", Joint.free(), float(mass[i]), (0.0, 0.0),
                   0.5 * float(mass[i]) * radii[i] ** 2, joint_name=f"float{i}",
                   coordinate_names=[f"x{i}", f"y{i}", f"phi{i}"])
    for i in range(n):
        r = float(radii[i])
        b.add_contact(f"floor{i}", body=f"disc{i}", point=(0.0, 0.0), radius=r,
                      normal=(0.0, 1.0), e=e, mu=mu)
        b.add_contact(f"left{i}", body=f"disc{i}", point=(0.0, 0.0), radius=r,
                      normal=(1.0, 0.0), plane_point=(0.0, 0.0), e=e, mu=mu)
        b.add_contact(f"right{i}", body=f"disc{i}", point=(0.0, 0.0), radius=r,
                      normal=(-1.0, 0.0), plane_point=(width, 0.0), e=e, mu=mu)
    pairs = neighbour_pairs(centres, radii)
    for i, j in pairs:
        b.add_contact(f"disc{i}-disc{j}", body=f"disc{j}", point=(0.0, 0.0),
                      radius=float(radii[j]), against=f"disc{i}", sphere_center=(0.0, 0.0),
                      sphere_radius=float(radii[i]), e=e, mu=mu)
    mech = b.build().mechanism()
    theta0 = np.zeros(3 * n)
    theta0[0::3], theta0[1::3] = centres[:, 0], centres[:, 1]
    angle = np.linspace(0.0, 2.0 * np.pi, 13)[:-1]
    outlines = {f"disc{i}": np.column_stack([radii[i] * np.cos(angle),
                                             radii[i] * np.sin(angle)]) for i in range(n)}
    params = dict(
        n_discs=n, columns=columns, rows=rows, radii=radii.tolist(), masses=mass.tolist(),
        mu=mu, e=e, gravity=G,
        box_width=width, n_candidate_contacts=len(mech.contact_names),
        n_neighbour_pairs=len(pairs), neighbour_factor=NEIGHBOUR_FACTOR, seed=seed,
        neighbour_check=("disc pairs are candidate contacts only when their centres start "
                         f"closer than {NEIGHBOUR_FACTOR} (r_i + r_j); check a run with "
                         "unlisted_overlap"),
        assumptions=["radii, masses and lattice chosen", "e = 0, mu = 0.3",
                     "candidate disc pairs fixed at the start (neighbours)"])
    description = (
        f"{n} discs (radii 0.046-0.0499 m, m = (r/0.05)^2 kg, I = m r^2/2; chosen) fall from "
        f"a loose hexagonal lattice in a box {width:g} m wide (floor y = 0, walls x = 0 and "
        f"x = {width:g}) and settle into a pile; e = {e}, mu = {mu} at every contact; disc "
        f"pairs starting "
        f"closer than {NEIGHBOUR_FACTOR} (r_i + r_j) are candidate contacts "
        f"({len(pairs)} pairs, {len(mech.contact_names)} candidates in all). Moreau–Jean "
        "(law coulomb, h = 2 ms, certificate 1e-6) is the scene's scheme.")
    return Scene(name="disc_pile", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=np.zeros(3 * n), t_end=t_end, parameters=MappingProxyType(params),
                 outlines=outlines,
                 simulation=MappingProxyType({"scheme": "moreau-jean", "h": STEP,
                                              "law": "coulomb",
                                              "impact_options": {"tol": COULOMB_TOL}}))
