"""Scenes of free rigid bodies in contact, for the contact-problem corpus
(:mod:`convimpact.bench.contact_corpus`).

Every body is free: in space its generalized velocity is ``(v, omega)`` (the centre's velocity
and the angular velocity, both in world axes) with the mass matrix ``diag(m, m, m, I_world)``,
``I_world = R I_body R^T``; in the plane (x horizontal, y up) it is ``(v_x, v_y, omega)`` with
``diag(m, m, I)``. A contact at the world point ``p`` between a lower body ``a`` (or the fixed
floor) and an upper body ``b`` has the unit normal ``n`` pointing from ``a`` into ``b`` and the
orthonormal frame ``(n, t1[, t2])``; its rows measure the velocity of ``b``'s material point at
``p`` minus ``a``'s, so the row of axis ``x`` is ``(x, (p - c_b) x x)`` on ``b``'s columns and
minus ``(x, (p - c_a) x x)`` on ``a``'s (in the plane ``r x x = r_x x_y - r_y x_x``). Rows
are normal first; a positive normal velocity separates.

Scenes: towers of boxes (four contacts per interface at the corners of the overlap of the two
faces), a staggered brick wall (four contacts at the corners of each overlap rectangle),
pyramids of spheres in square or triangular (hexagonal) packing, log piles of capsules
crossing layer by layer, two parallel rods touching at three collinear points, and planar
towers of rectangles (two corner contacts per interface). Geometry is exact: spheres of one
radius are spaced 1 % apart within a layer so that each touches exactly the 4 (square) or 3
(triangular) spheres below it and no neighbour. A capsule's inertia is that of a solid
cylinder of its total length (the hemispherical caps' inertia is approximated).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.sparse as sp

#: time step of the "rest" velocities: each body falls at g h (m/s), as in one implicit step
REST_STEP = 0.01
GRAVITY = 9.81


def _frame(normal: np.ndarray) -> np.ndarray:
    """Orthonormal rows (n, t1[, t2]); for n = z (space) this is (z, x, y), for n = y (plane)
    it is (y, x)."""
    n = normal / np.linalg.norm(normal)
    if n.size == 2:
        return np.array([n, [n[1], -n[0]]])
    e = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = e - (e @ n) * n
    t1 /= np.linalg.norm(t1)
    return np.array([n, t1, np.cross(n, t1)])


def rot_z(theta: float) -> np.ndarray:
    """Rotation by ``theta`` about the world z axis."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class Assembly:
    """Free rigid bodies and their contacts, assembled into sparse M, M^-1 and J.

    Parameters
    ----------
    dim : 3 (space, 6 coordinates per body) or 2 (plane, 3 per body).
    """

    def __init__(self, dim: int) -> None:
        self.dim = dim
        self.dof = 6 if dim == 3 else 3
        self.masses: list[float] = []
        self.inertias: list[np.ndarray] = []
        self.centres: list[np.ndarray] = []
        self.sizes: list[float] = []
        self._rows: list[tuple[int, int, np.ndarray]] = []  # (contact, body, d x dof block)
        self.points: list[np.ndarray] = []
        self.normals: list[np.ndarray] = []
        self.pairs: list[tuple[int, int]] = []
        self.groups: list[int] = []

    @property
    def n_bodies(self) -> int:
        return len(self.masses)

    @property
    def n_contacts(self) -> int:
        return len(self.points)

    def body(self, centre: Sequence[float], mass: float, inertia: np.ndarray | float,
             size: float) -> int:
        """Add a body (centre, mass, world inertia 3x3 or scalar in the plane, a
        characteristic half size for spin velocities); returns its index."""
        self.centres.append(np.asarray(centre, dtype=float))
        self.masses.append(float(mass))
        self.inertias.append(np.atleast_2d(np.asarray(inertia, dtype=float)))
        self.sizes.append(float(size))
        return self.n_bodies - 1

    def _block(self, body: int, point: np.ndarray, frame: np.ndarray) -> np.ndarray:
        r = point - self.centres[body]
        if self.dim == 3:
            return np.hstack([frame, np.cross(r, frame)])
        return np.hstack([frame, (r[0] * frame[:, 1] - r[1] * frame[:, 0])[:, None]])

    def contact(self, point: Sequence[float], normal: Sequence[float], upper: int,
                lower: int | None, group: int) -> None:
        """A contact at ``point`` whose ``normal`` points from ``lower`` (None: the floor)
        into ``upper``; contacts of one ``group`` (interface) share a friction coefficient."""
        p = np.asarray(point, dtype=float)
        frame = _frame(np.asarray(normal, dtype=float))
        i = self.n_contacts
        self._rows.append((i, upper, self._block(upper, p, frame)))
        if lower is not None:
            self._rows.append((i, lower, -self._block(lower, p, frame)))
        self.points.append(p)
        self.normals.append(frame[0])
        self.pairs.append((-1 if lower is None else lower, upper))
        self.groups.append(group)

    def matrices(self) -> tuple[sp.csr_matrix, sp.csr_matrix, sp.csr_matrix]:
        """(M, M^-1, J), sparse CSR; M and M^-1 block diagonal, exactly symmetric."""
        nb, f, d = self.n_bodies, self.dof, self.dim
        lin = f - (3 if d == 3 else 1)
        rows, cols, vals, ivals = [], [], [], []
        for i, (m, inertia) in enumerate(zip(self.masses, self.inertias)):
            block = np.zeros((f, f))
            block[:lin, :lin] = m * np.eye(lin)
            block[lin:, lin:] = 0.5 * (inertia + inertia.T)
            inv = np.zeros((f, f))
            inv[:lin, :lin] = np.eye(lin) / m
            ii = np.linalg.inv(block[lin:, lin:])
            inv[lin:, lin:] = 0.5 * (ii + ii.T)
            r, c = np.meshgrid(np.arange(f) + f * i, np.arange(f) + f * i, indexing="ij")
            rows.append(r.ravel())
            cols.append(c.ravel())
            vals.append(block.ravel())
            ivals.append(inv.ravel())
        k = nb * f
        rows_a, cols_a = np.concatenate(rows), np.concatenate(cols)
        M = sp.csr_matrix((np.concatenate(vals), (rows_a, cols_a)), shape=(k, k))
        Minv = sp.csr_matrix((np.concatenate(ivals), (rows_a, cols_a)), shape=(k, k))
        jr, jc, jv = [], [], []
        for i, body, block in self._rows:
            r, c = np.meshgrid(np.arange(d) + d * i, np.arange(f) + f * body, indexing="ij")
            jr.append(r.ravel())
            jc.append(c.ravel())
            jv.append(block.ravel())
        J = sp.csr_matrix((np.concatenate(jv), (np.concatenate(jr), np.concatenate(jc))),
                          shape=(d * self.n_contacts, k))
        for A in (M, Minv, J):
            A.eliminate_zeros()
            A.sort_indices()
        return M, Minv, J

    def velocities(self, rng: np.random.Generator, mode: str) -> np.ndarray:
        """Pre-impact velocities: "impact" - every body descends at a common speed in
        [0.3, 1] m/s (each +-30 %) with lateral velocities up to 0.5 m/s and spins whose rim
        speed is up to 0.5 m/s; "rest" - every body falls at g h (h = 10 ms) with lateral
        velocities up to 0.2 m/s and rim speeds up to 0.05 m/s."""
        nb, d = self.n_bodies, self.dim
        lin = d
        ang = 3 if d == 3 else 1
        dq = np.zeros((nb, self.dof))
        if mode == "impact":
            v0 = rng.uniform(0.3, 1.0)
            down = -v0 * (1.0 + rng.uniform(-0.3, 0.3, nb))
            lateral = rng.uniform(-0.3, 0.3, d - 1) + rng.uniform(-0.5, 0.5, (nb, d - 1))
            spin = 0.5
        elif mode == "rest":
            down = np.full(nb, -GRAVITY * REST_STEP)
            lateral = rng.uniform(-0.1, 0.1, d - 1) + rng.uniform(-0.1, 0.1, (nb, d - 1))
            spin = 0.05
        else:
            raise ValueError(f"unknown mode {mode!r}")
        dq[:, :lin - 1] = lateral
        dq[:, lin - 1] = down
        sizes = np.asarray(self.sizes)[:, None]
        dq[:, lin:] = rng.uniform(-spin, spin, (nb, ang)) / sizes
        return dq.ravel()


def _clip(subject: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """Intersection of two convex counter-clockwise polygons (Sutherland-Hodgman)."""
    out = subject
    for j in range(len(clip)):
        a, b = clip[j], clip[(j + 1) % len(clip)]
        edge = b - a

        def inside(p):
            return edge[0] * (p[1] - a[1]) - edge[1] * (p[0] - a[0]) >= -1e-12

        src, out = out, []
        for i in range(len(src)):
            p, q = src[i], src[(i + 1) % len(src)]
            if inside(q):
                if not inside(p):
                    out.append(_cut(p, q, a, edge))
                out.append(q)
            elif inside(p):
                out.append(_cut(p, q, a, edge))
        if not out:
            return np.zeros((0, 2))
        out = np.array(out)
    return np.asarray(out)


def _cut(p: np.ndarray, q: np.ndarray, a: np.ndarray, edge: np.ndarray) -> np.ndarray:
    """Where the segment pq crosses the line through ``a`` along ``edge``."""
    dp = edge[0] * (p[1] - a[1]) - edge[1] * (p[0] - a[0])
    dq = edge[0] * (q[1] - a[1]) - edge[1] * (q[0] - a[0])
    return p + (q - p) * dp / (dp - dq)


def _rectangle(centre: np.ndarray, half: Sequence[float], theta: float) -> np.ndarray:
    """Counter-clockwise corners of a rectangle in the xy plane."""
    c, s = np.cos(theta), np.sin(theta)
    local = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * np.asarray(half[:2])
    return centre[:2] + local @ np.array([[c, s], [-s, c]])


def overlap_corners(upper: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """Four contact points of two stacked faces (ccw corner arrays): the vertices of their
    overlap polygon nearest to ``upper``'s corners (the overlap's own corners when it is a
    rectangle)."""
    poly = _clip(upper, lower)
    picked = [int(np.argmin(np.linalg.norm(poly - c, axis=1))) for c in upper]
    if len(set(picked)) != 4:
        raise ValueError("overlap polygon too small for four distinct corner contacts")
    return poly[picked]


def box_inertia(mass: float, half: Sequence[float]) -> np.ndarray:
    """Inertia about the centre of a solid box of half sizes (a, b, c), in its own axes."""
    a, b, c = half
    return mass / 3.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


def box_stack(rng: np.random.Generator, n_boxes: int) -> Assembly:
    """A tower of ``n_boxes`` boxes (half sizes 0.2 x 0.15 x 0.1 m, 0.5-2 kg), each shifted by
    up to 1 cm and turned by up to 0.05 rad about z; four contacts per interface (floor
    included) at the corners of the overlap of the two faces: 4 n_boxes contacts."""
    A = Assembly(3)
    half = np.array([0.2, 0.15, 0.1])
    prev = None
    for i in range(n_boxes):
        theta = rng.uniform(-0.05, 0.05)
        centre = np.array([*rng.uniform(-0.01, 0.01, 2), half[2] * (2 * i + 1)])
        R = rot_z(theta)
        m = rng.uniform(0.5, 2.0)
        b = A.body(centre, m, R @ box_inertia(m, half) @ R.T, float(np.linalg.norm(half)))
        face = _rectangle(centre, half, theta)
        pts = face if prev is None else overlap_corners(face, prev)
        for p in pts:
            A.contact([p[0], p[1], 2 * half[2] * i], [0, 0, 1], b, None if i == 0 else b - 1, i)
        prev = face
    return A


def box_wall(rng: np.random.Generator, width: int, rows: int) -> Assembly:
    """A running-bond brick wall: ``rows`` rows of bricks (half sizes 0.2 x 0.1 x 0.05 m,
    0.5-2 kg, 1 cm joints), even rows of ``width`` bricks, odd rows of ``width - 1`` bricks
    shifted by half a brick; the bottom row stands on the floor (4 corners each), every other
    brick on the one or two bricks below it, 4 contacts at the corners of each overlap
    rectangle: 4 width + 8 (rows - 1)(width - 1) contacts."""
    A = Assembly(3)
    half = np.array([0.2, 0.1, 0.05])
    gap = 0.01
    below: list[tuple[int, np.ndarray]] = []
    group = 0
    for r in range(rows):
        count = width if r % 2 == 0 else width - 1
        shift = 0.0 if r % 2 == 0 else half[0] + gap / 2
        row = []
        for j in range(count):
            centre = np.array([j * (2 * half[0] + gap) + shift + rng.uniform(-1e-3, 1e-3),
                               rng.uniform(-1e-3, 1e-3), half[2] * (2 * r + 1)])
            m = rng.uniform(0.5, 2.0)
            b = A.body(centre, m, box_inertia(m, half), float(np.linalg.norm(half)))
            face = _rectangle(centre, half, 0.0)
            z = 2 * half[2] * r
            if r == 0:
                for p in face:
                    A.contact([p[0], p[1], z], [0, 0, 1], b, None, group)
                group += 1
            for lb, lface in below:
                lo = max(face[0, 0], lface[0, 0])
                hi = min(face[1, 0], lface[1, 0])
                if hi - lo > 1e-9:
                    for p in overlap_corners(face, lface):
                        A.contact([p[0], p[1], z], [0, 0, 1], b, lb, group)
                    group += 1
            row.append((b, face))
        below = row
    return A


def sphere_pile(rng: np.random.Generator, side: int, packing: str = "square") -> Assembly:
    """A pyramid of spheres (radius 5 cm, 0.26-1 kg) of ``side`` spheres along the base's
    edge: ``"square"`` layers of side^2, (side-1)^2, ... spheres, each resting on 4 below;
    ``"hex"`` triangular layers (a tetrahedral pile), each sphere on 3 below. The bottom
    layer stands on the floor; contact normals run along the centres."""
    A = Assembly(3)
    R = 0.05
    s = 2 * R * 1.01
    if packing == "square":
        e1, e2 = np.array([1.0, 0.0]), np.array([0.0, 1.0])
        shift, h = (e1 + e2) / 2, np.sqrt(4 * R * R - s * s / 2)
        below = [(0, 0), (1, 0), (0, 1), (1, 1)]

        def cells(m):
            return [(i, j) for i in range(m) for j in range(m)]
    elif packing == "hex":
        e1, e2 = np.array([1.0, 0.0]), np.array([0.5, np.sqrt(3) / 2])
        shift, h = (e1 + e2) / 3, np.sqrt(4 * R * R - s * s / 3)
        below = [(0, 0), (1, 0), (0, 1)]

        def cells(m):
            return [(i, j) for i in range(m) for j in range(m - i)]
    else:
        raise ValueError(f"unknown packing {packing!r}")
    index: dict[tuple[int, int, int], int] = {}
    group = 0
    for layer in range(side):
        for i, j in cells(side - layer):
            xy = s * (i * e1 + j * e2 + layer * shift)
            c = np.array([xy[0], xy[1], R + layer * h])
            m = rng.uniform(250.0, 1000.0) * 4.0 / 3.0 * np.pi * R ** 3
            b = A.body(c, m, 0.4 * m * R * R * np.eye(3), R)
            index[(layer, i, j)] = b
            if layer == 0:
                A.contact([c[0], c[1], 0.0], [0, 0, 1], b, None, group)
                group += 1
            for di, dj in below:
                lb = index[(layer - 1, i + di, j + dj)] if layer else None
                if lb is None:
                    continue
                n = (c - A.centres[lb]) / (2 * R)
                A.contact(A.centres[lb] + R * n, n, b, lb, group)
                group += 1
    return A


def _rod_inertia(mass: float, radius: float, half_length: float, axis: int) -> np.ndarray:
    """Inertia of a capsule along world ``axis`` (0 or 1) as a solid cylinder of its length."""
    length = 2 * (half_length + radius)
    perp = mass * (3 * radius ** 2 + length ** 2) / 12.0
    I = np.full(3, perp)
    I[axis] = 0.5 * mass * radius ** 2
    return np.diag(I)


def capsule_pile(rng: np.random.Generator, per_layer: int, layers: int) -> Assembly:
    """A log pile: ``layers`` layers of ``per_layer`` capsules (radius 3 cm, 15 cm apart),
    along x in even layers and y in odd ones, each touching every capsule of the layer below
    at one crossing point; the bottom capsules lie on the floor with a contact below each end
    of their segment: 2 per_layer + (layers - 1) per_layer^2 contacts."""
    A = Assembly(3)
    rho, s = 0.03, 0.15
    L = (per_layer - 1) * s / 2 + 0.1
    offsets = (np.arange(per_layer) - (per_layer - 1) / 2) * s
    prev: list[tuple[int, float]] = []
    group = 0
    for layer in range(layers):
        axis = layer % 2
        row = []
        for j, off in enumerate(offsets):
            slide = rng.uniform(-0.02, 0.02)
            c = np.zeros(3)
            c[axis], c[1 - axis], c[2] = slide, off, rho * (2 * layer + 1)
            m = rng.uniform(500.0, 1500.0) * np.pi * rho ** 2 * (2 * L + 4 * rho / 3)
            b = A.body(c, m, _rod_inertia(m, rho, L, axis), L)
            if layer == 0:
                for end in (-L, L):
                    p = c.copy()
                    p[axis] += end
                    p[2] = 0.0
                    A.contact(p, [0, 0, 1], b, None, group)
                group += 1
            for lb, loff in prev:
                p = np.zeros(3)
                p[1 - axis], p[axis], p[2] = off, loff, 2 * rho * layer
                A.contact(p, [0, 0, 1], b, lb, group)
                group += 1
            row.append((b, off))
        prev = row
    return A


def rod_on_rod(rng: np.random.Generator) -> Assembly:
    """Two parallel capsules (radius 3 cm, segment 0.6 m) along x, one on the other, touching
    at three collinear points (the segment's ends and middle): a degenerate line contact."""
    A = Assembly(3)
    rho, L = 0.03, 0.3
    bodies = []
    for level in (0, 1):
        c = np.array([rng.uniform(-0.01, 0.01), 0.0, rho * (2 * level + 1)])
        m = rng.uniform(500.0, 1500.0) * np.pi * rho ** 2 * (2 * L + 4 * rho / 3)
        bodies.append(A.body(c, m, _rod_inertia(m, rho, L, 0), L))
    for x in (-0.9 * L, 0.0, 0.9 * L):
        A.contact([x, 0.0, 2 * rho], [0, 0, 1], bodies[1], bodies[0], 0)
    return A


def planar_stack(rng: np.random.Generator, n_boxes: int) -> Assembly:
    """A planar tower of ``n_boxes`` rectangles (half sizes 0.2 x 0.1 m, 0.5-2 kg) shifted by
    up to 3 cm; two contacts per interface (floor included) at the ends of the overlap."""
    A = Assembly(2)
    a, c = 0.2, 0.1
    prev = None
    for i in range(n_boxes):
        x = rng.uniform(-0.03, 0.03)
        m = rng.uniform(0.5, 2.0)
        b = A.body([x, c * (2 * i + 1)], m, m * (a * a + c * c) / 3.0, float(np.hypot(a, c)))
        lo, hi = (x - a, x + a) if prev is None else (max(x, prev) - a, min(x, prev) + a)
        for px in (lo, hi):
            A.contact([px, 2 * c * i], [0, 1], b, None if i == 0 else b - 1, i)
        prev = x
    return A
