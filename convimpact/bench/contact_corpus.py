"""A corpus of contact problems ``u = W r + b`` built from physical scenes, for benchmarking
several-contact solvers (2 to 1,000 contacts, planar and spatial).

Each :class:`ContactCase` carries the problem (``W`` sparse, ``b``, ``mu``; per contact the
impulse is ``(r_n, r_t[, r_t2])``, normal first) and the mechanics it comes from: the mass
matrix ``M``, the contact Jacobian ``J`` (rows normal first, orthonormal frames), the
pre-impact velocity ``dq`` and the restitution ``e``, with ``W = J M^-1 J^T`` and
``b = J dq + e min(v_n, 0)`` on the normal rows (``v_n`` the normal rows of ``J dq``;
Newton's restitution shift, so ``u_n >= 0`` targets ``v_n+ >= -e v_n-``).

Families (scenes in :mod:`.contact_scenes`, robots in :mod:`.contact_robots`):

* ``box-stack``: towers of 1 to 250 boxes on the floor, 4 corner contacts per interface;
  ``J`` has full column rank, so ``W`` (12 N rows) has rank 6 N;
* ``box-wall``: running-bond brick walls, each brick on the floor or on one or two bricks;
* ``sphere-pile``: square (``sq``) and tetrahedral (``hex``) pyramids of spheres;
* ``capsule-pile``: log piles of capsules, and ``rod-on-rod-3`` (three collinear contacts);
* ``robot-feet``: TALOS humanoids (4 corners per flat sole) and Solo-12 quadrupeds (point feet)
  of ``example-robot-data`` side by side; omitted, with a note in :func:`corpus_notes`, when
  Pinocchio or the robot package is missing;
* ``planar-stack``: planar towers of rectangles (d = 2), 2 corner contacts per interface;
* ``small``: the several-contact benchmark's box on four corners and ``random_several``
  impacts (2-8 contacts, d = 2 and 3; their Jacobians are random, their frames not
  orthonormal).

Scenes alternate between "rest" (e = 0; every body falls at g h with h = 10 ms, small lateral
and spin velocities: a time step of sustained contact) and "impact" (e in [0.05, 0.6]; bodies
descending at 0.3-1 m/s with lateral velocities and rim speeds up to 0.5 m/s). Friction is
drawn per interface (the contacts between one pair of bodies): mu ~ U(0.1, 1), and mu = 0 with
probability 0.04. Every problem has its own generator seeded by its name: adding a problem
never changes the others, and two builds are identical.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping

import numpy as np
import scipy.sparse as sp

from . import contact_scenes as cs

FAMILIES = ("small", "box-stack", "box-wall", "sphere-pile", "capsule-pile", "robot-feet",
            "planar-stack")


@dataclass(frozen=True, eq=False)
class ContactCase:
    """One contact problem ``u = W r + b`` of the corpus.

    Attributes
    ----------
    name : unique label, e.g. ``"box-stack-100"``.
    family : one of :data:`FAMILIES`.
    n_contacts, dim : number of contacts and their dimension (2 planar, 3 spatial).
    W : (n d, n d) CSR, symmetric positive semidefinite, ``J M^-1 J^T``.
    b : (n d,) free velocity with the restitution shift on the normal rows.
    mu : (n,) friction coefficients (>= 0).
    M : (k, k) CSR, symmetric positive definite mass matrix.
    J : (n d, k) CSR contact Jacobian, each contact's rows normal first.
    dq : (k,) pre-impact generalized velocity.
    e : restitution coefficient used in ``b``.
    mode : ``"rest"``, ``"impact"`` or ``"random"`` (the random small problems).
    geometry : per-contact ``points``, ``normals``, ``pairs`` (lower body or -1 for the
        floor, upper body), ``groups`` and per-body ``centres`` where the scene has them.
    """

    name: str
    family: str
    n_contacts: int
    dim: int
    W: sp.csr_matrix
    b: np.ndarray
    mu: np.ndarray
    M: sp.csr_matrix
    J: sp.csr_matrix
    dq: np.ndarray
    e: float
    mode: str = "impact"
    geometry: Mapping[str, np.ndarray] = field(default_factory=dict)

    @property
    def k(self) -> int:
        """Number of generalized coordinates."""
        return int(self.M.shape[0])

    def problem(self) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
        """``(W, b, mu)``, the arguments of a contact solver."""
        return self.W, self.b, self.mu


def delassus(J: sp.spmatrix, Minv: sp.spmatrix) -> sp.csr_matrix:
    """``J M^-1 J^T`` in CSR, symmetrized (both triangles from the same products)."""
    J = sp.csr_matrix(J)
    W = sp.csr_matrix(J @ sp.csr_matrix(Minv) @ J.T)
    W = sp.csr_matrix(0.5 * (W + W.T))
    W.sort_indices()
    return W


def shifted_velocity(J: sp.spmatrix, dq: np.ndarray, e: float, dim: int) -> np.ndarray:
    """``b = J dq`` with ``e min(v_n, 0)`` added to every normal row."""
    b = np.asarray(J @ dq, dtype=float).copy()
    vn = b[::dim].copy()
    b[::dim] += e * np.minimum(vn, 0.0)
    return b


def _group_friction(rng: np.random.Generator, groups: np.ndarray) -> np.ndarray:
    n_groups = int(groups.max()) + 1
    mu = rng.uniform(0.1, 1.0, n_groups)
    mu[rng.uniform(size=n_groups) < 0.04] = 0.0
    return mu[groups]


def _restitution(rng: np.random.Generator, mode: str) -> float:
    return 0.0 if mode == "rest" else float(rng.uniform(0.05, 0.6))


def _case(name: str, family: str, dim: int, M, Minv, J, dq, e: float, mu, mode: str,
          geometry: Mapping[str, np.ndarray]) -> ContactCase:
    J = sp.csr_matrix(J)
    n = J.shape[0] // dim
    return ContactCase(name=name, family=family, n_contacts=n, dim=dim, W=delassus(J, Minv),
                       b=shifted_velocity(J, dq, e, dim), mu=np.asarray(mu, dtype=float),
                       M=sp.csr_matrix(M), J=J, dq=np.asarray(dq, dtype=float), e=float(e),
                       mode=mode, geometry=dict(geometry))


def _from_assembly(name: str, family: str, mode: str,
                   build: Callable[[np.random.Generator], cs.Assembly],
                   rng: np.random.Generator) -> ContactCase:
    A = build(rng)
    M, Minv, J = A.matrices()
    dq = A.velocities(rng, mode)
    groups = np.asarray(A.groups)
    geometry = dict(points=np.asarray(A.points), normals=np.asarray(A.normals),
                    pairs=np.asarray(A.pairs), groups=groups, centres=np.asarray(A.centres))
    return _case(name, family, A.dim, M, Minv, J, dq, _restitution(rng, mode),
                 _group_friction(rng, groups), mode, geometry)


def _from_robots(name: str, mode: str, robots: list[str],
                 rng: np.random.Generator) -> ContactCase:
    from .contact_robots import robot_scene

    s = robot_scene(rng, robots, mode)
    geometry = dict(points=s["points"], groups=s["groups"],
                    normals=np.tile([0.0, 0.0, 1.0], (len(s["points"]), 1)))
    return _case(name, "robot-feet", 3, s["M"], s["Minv"], s["J"], s["dq"],
                 _restitution(rng, mode), _group_friction(rng, s["groups"]), mode, geometry)


def _from_small(name: str, args: Mapping[str, Any], dim: int) -> ContactCase:
    """A ``resolve_impact`` argument set (M, list of d x k Jc blocks, dq, e, mu)."""
    M = np.asarray(args["M"], dtype=float)
    Jc = args["Jc"]
    Jc = [np.asarray(j, dtype=float) for j in (Jc if isinstance(Jc, list) else [Jc])]
    mu = np.broadcast_to(np.asarray(args["mu"], dtype=float), (len(Jc),)).copy()
    Minv = np.linalg.inv(M)
    return _case(name, "small", dim, M, 0.5 * (Minv + Minv.T), np.vstack(Jc),
                 np.asarray(args["dq"], dtype=float), float(args["e"]), mu,
                 "impact" if name == "four-corner-box" else "random", {})


# -- the corpus table: (family, name, hand count of contacts, mode, builder(name, rng)) -------

def _stack(n_boxes: int, mode: str):
    return ("box-stack", f"box-stack-{4 * n_boxes}", 4 * n_boxes, mode,
            lambda name, rng: _from_assembly(name, "box-stack", mode,
                                             lambda r: cs.box_stack(r, n_boxes), rng))


def _wall(width: int, rows: int, mode: str):
    n = 4 * width + 8 * (rows - 1) * (width - 1)
    return ("box-wall", f"box-wall-{width}x{rows}-{n}", n, mode,
            lambda name, rng: _from_assembly(name, "box-wall", mode,
                                             lambda r: cs.box_wall(r, width, rows), rng))


def _pile(side: int, packing: str, mode: str):
    if packing == "square":
        n = side ** 2 + 4 * sum(j * j for j in range(1, side))
    else:
        n = side * (side + 1) // 2 + 3 * sum(j * (j + 1) // 2 for j in range(1, side))
    label = "sq" if packing == "square" else "hex"
    return ("sphere-pile", f"sphere-pile-{label}-{n}", n, mode,
            lambda name, rng: _from_assembly(name, "sphere-pile", mode,
                                             lambda r: cs.sphere_pile(r, side, packing), rng))


def _logs(per_layer: int, layers: int, mode: str):
    n = 2 * per_layer + (layers - 1) * per_layer ** 2
    return ("capsule-pile", f"capsule-pile-{per_layer}x{layers}-{n}", n, mode,
            lambda name, rng: _from_assembly(name, "capsule-pile", mode,
                                             lambda r: cs.capsule_pile(r, per_layer, layers),
                                             rng))


def _planar(n_boxes: int, mode: str):
    return ("planar-stack", f"planar-stack-{2 * n_boxes}", 2 * n_boxes, mode,
            lambda name, rng: _from_assembly(name, "planar-stack", mode,
                                             lambda r: cs.planar_stack(r, n_boxes), rng))


def _robots(talos: int, solo: int, mode: str):
    n = 8 * talos + 4 * solo
    label = "-".join(f"{c}{r}" for c, r in ((talos, "talos"), (solo, "solo")) if c)
    robots = ["talos"] * talos + ["solo"] * solo
    return ("robot-feet", f"robot-feet-{label}-{n}", n, mode,
            lambda name, rng: _from_robots(name, mode, robots, rng))


def _small_box():
    from .several_problems import four_corner_box

    return ("small", "four-corner-box", 4, "impact",
            lambda name, rng: _from_small(name, four_corner_box(), 3))


def _small_random(n: int, dim: int):
    from .several_problems import random_several

    return ("small", f"random-several-n{n}-d{dim}", n, "random",
            lambda name, rng: _from_small(name, random_several(0, n, dim), dim))


def _table() -> list[tuple]:
    R, I = "rest", "impact"
    return [
        _small_box(), *(_small_random(n, d) for d in (2, 3) for n in (2, 5, 8)),
        *(_stack(n, m) for n, m in ((1, I), (2, R), (4, I), (7, R), (12, I), (25, R),
                                    (50, I), (100, R), (250, I))),
        *(_wall(w, r, m) for w, r, m in ((2, 2, I), (3, 3, R), (4, 4, I), (6, 6, R),
                                         (8, 8, I), (10, 14, R))),
        *(_pile(s, "square", m) for s, m in ((2, I), (3, R), (4, I), (5, R), (6, I), (8, R),
                                             (9, I))),
        *(_pile(s, "hex", m) for s, m in ((2, R), (3, I), (4, R), (6, I), (8, R), (11, I))),
        ("capsule-pile", "rod-on-rod-3", 3, I,
         lambda name, rng: _from_assembly(name, "capsule-pile", I, cs.rod_on_rod, rng)),
        *(_logs(p, l, m) for p, l, m in ((2, 2, R), (3, 3, I), (4, 4, R), (5, 6, I),
                                         (6, 8, R), (8, 9, I), (10, 10, R))),
        *(_robots(t, s, m) for t, s, m in ((0, 1, I), (1, 0, R), (2, 2, I), (4, 0, R),
                                           (0, 16, I), (8, 8, R), (20, 0, I), (40, 40, R))),
        *(_planar(n, m) for n, m in ((1, I), (2, R), (3, I), (5, R), (10, I), (20, R),
                                     (50, I), (100, R), (200, I), (500, R))),
    ]


#: names of :func:`quick_corpus`
QUICK = ("four-corner-box", "random-several-n5-d2", "random-several-n8-d3", "box-stack-16",
         "box-stack-100", "box-wall-3x3-44", "sphere-pile-sq-29", "sphere-pile-hex-40",
         "rod-on-rod-3", "capsule-pile-3x3-24", "robot-feet-1talos-8", "planar-stack-20")

_NOTES: list[str] = []


def _build(entry: tuple) -> ContactCase:
    family, name, n, mode, builder = entry
    rng = np.random.default_rng([zlib.crc32(name.encode()), 20240611])
    case = builder(name, rng)
    if case.n_contacts != n:
        raise AssertionError(f"{name}: built {case.n_contacts} contacts, hand count {n}")
    return case


def corpus(max_contacts: int | None = None, families: Iterable[str] | None = None,
           names: Iterable[str] | None = None) -> list[ContactCase]:
    """The corpus (about 60 problems, 2 to 1,000 contacts), optionally only the problems of
    at most ``max_contacts`` contacts, of ``families`` or with the given ``names``.

    Robots need Pinocchio and ``example-robot-data``; when either is missing their problems
    are left out and :func:`corpus_notes` says why.
    """
    fams = set(FAMILIES if families is None else families)
    unknown = fams - set(FAMILIES)
    if unknown:
        raise ValueError(f"unknown families {sorted(unknown)}; known: {FAMILIES}")
    wanted = None if names is None else set(names)
    _NOTES.clear()
    out = []
    for entry in _table():
        family, name, n = entry[:3]
        if family not in fams or (max_contacts is not None and n > max_contacts):
            continue
        if wanted is not None and name not in wanted:
            continue
        try:
            out.append(_build(entry))
        except ImportError as exc:  # Pinocchio or example-robot-data missing
            _NOTES.append(f"{name}: left out ({type(exc).__name__}: {exc})")
    return out


def corpus_notes() -> list[str]:
    """Why problems were left out of the last :func:`corpus` call (empty when none were)."""
    return list(_NOTES)


def quick_corpus() -> list[ContactCase]:
    """A dozen problems of every family, 3 to 100 contacts, for quick runs and tests."""
    return corpus(names=QUICK)


def describe(case: ContactCase, rank: bool = False) -> dict[str, Any]:
    """JSON-ready facts of ``case`` (rank of W by a dense SVD when ``rank``)."""
    facts = dict(name=case.name, family=case.family, n_contacts=case.n_contacts, dim=case.dim,
                 k=case.k, nnz_W=int(case.W.nnz), e=case.e, mode=case.mode,
                 mu_zero=int(np.sum(case.mu == 0.0)))
    if rank:
        facts["rank_W"] = int(np.linalg.matrix_rank(case.W.toarray(), hermitian=True))
    return facts
