"""A stack of boxes on the floor, at rest, then pushed sideways at the top until it topples.

``n_boxes`` identical uniform boxes (width w along x, height h along y, depth c along z,
mass m; chosen) are stacked on the floor y = 0, each on a free spatial joint (translations,
then Cardan X-Y-Z angles). Each box rests on its four bottom corners: the lowest box's
against the floor, every other box's against the top face of the box below (a plane of that
box, n = +y of its frame). That is 4 n_boxes closed contacts (12 for three boxes), each
box's four redundant (a table on four legs: three equations of vertical force and tilting
moments for four normal forces). e = 0 and one mu for every contact.

From ``t_push`` on a horizontal force along +x grows at the top box's centre,
F(t) = ramp m g (t - t_push). Closed forms for the rigid stack (while it does not move):

* each box carries the weight of those above: the normal forces of box i's corners total
  (n_boxes - i) m g (i = 0 the lowest), equal shares m g (n_boxes - i) / 4 before the push;
* the push tips the whole stack about the lowest box's front edge when its moment
  F (n_boxes - 1/2) h exceeds the restoring n_boxes m g w / 2, at
  F_tip = n_boxes m g w / ((2 n_boxes - 1) h), i.e. t_tip = t_push + F_tip / (ramp m g),
  provided nothing else gives first: the upper sub-stacks tip later (box j and those above
  at F = (n - j) m g w / ((2 (n - j) - 1) h), larger), and nothing slides while
  F < mu m g (the top box on the one below; the lower interfaces carry more weight).
  The defaults (w = 0.2, h = 0.25, mu = 0.6) give F_tip = 0.48 m g < mu m g: the stack tips
  as a whole at t_tip = 0.2 + 0.48 / 2 = 0.44 s: the lowest box's back corners open there;
* past its balance angle atan(w / (n h)) the stack falls over. The run ends at
  ``t_end`` (0.9 s), the stack well past it.

The event-driven scheme resolves the force problem of all the closed contacts at every event
(no enumeration of modes), with the redundant distribution chosen and noted.

Parameters of :func:`make_scene`: n_boxes (3), width (0.2 m), height (0.25 m), depth
(0.2 m), mass (1 kg), mu (0.6), ramp (2 /s: F grows by 2 m g per second), t_push (0.2 s),
t_end (0.9 s). ``parameters`` holds tip_force, tip_time, balance_angle and the normal
force totals per box at rest.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import Joint, ModelBuilder
from convimpact.scenes import Scene
from convimpact.validation import Integer, NonNegative, Positive

PARAMETERS = {"n_boxes": Integer(1, 50), "width": Positive(), "height": Positive(),
              "depth": Positive(), "mass": Positive(), "mu": NonNegative(),
              "ramp": NonNegative(), "t_push": NonNegative(), "t_end": Positive()}

G = 9.81
CORNERS = ((-1, -1), (1, -1), (1, 1), (-1, 1))  # (x, z) signs of a box's bottom corners


def _box_name(i: int) -> str:
    return f"box{i}"


def build_stack(n_boxes: int, width: float, height: float, depth: float, mass: float,
                mu: float, ramp: float, t_push: float):
    """The stack's mechanism (see the module docstring)."""
    b = ModelBuilder(planar=False)
    inertia = mass * np.diag([height ** 2 + depth ** 2, width ** 2 + depth ** 2,
                              width ** 2 + height ** 2]) / 12.0
    for i in range(n_boxes):
        b.add_body(_box_name(i), "ground", Joint.free(), mass, (0.0, 0.0, 0.0), inertia,
                   joint_name=f"float{i}")
        below = "ground" if i == 0 else _box_name(i - 1)
        plane = (0.0, 0.0, 0.0) if i == 0 else (0.0, 0.5 * height, 0.0)
        for j, (sx, sz) in enumerate(CORNERS):
            b.add_contact(f"{_box_name(i)}_c{j}", body=_box_name(i),
                          point=(0.5 * sx * width, -0.5 * height, 0.5 * sz * depth),
                          against=below, plane_point=plane, normal=(0.0, 1.0, 0.0),
                          e=0.0, mu=mu)
    k = 6 * n_boxes
    top = 6 * (n_boxes - 1)

    def push(t, theta, dtheta):
        f = np.zeros(k)
        f[top] = ramp * mass * G * max(0.0, t - t_push)  # along +x at the top box's centre
        return f

    b.set_applied_forces(push)
    return b.build().mechanism()


def box_outline(width: float, height: float, depth: float) -> np.ndarray:
    """The box's eight corners in its frame, for drawing."""
    w, h, c = 0.5 * width, 0.5 * height, 0.5 * depth
    return np.array([[sx * w, sy * h, sz * c] for sx in (-1, 1) for sy in (-1, 1)
                     for sz in (-1, 1)])


def make_scene(n_boxes: int = 3, width: float = 0.2, height: float = 0.25, depth: float = 0.2,
               mass: float = 1.0, mu: float = 0.6, ramp: float = 2.0, t_push: float = 0.2,
               t_end: float = 0.9) -> Scene:
    """The box stack (see the module docstring)."""
    n = int(n_boxes)
    mech = build_stack(n, width, height, depth, mass, mu, ramp, t_push)
    theta0 = np.zeros(6 * n)  # level boxes, each centre (i + 1/2) h up: every gap is 0
    for i in range(n):
        theta0[6 * i + 1] = (i + 0.5) * height
    tip_force = n * mass * G * width / ((2 * n - 1) * height)
    description = (
        f"{n} uniform boxes ({width} x {height} x {depth} m, {mass} kg each; chosen) stacked "
        "on the floor, each on a free spatial joint and on its four bottom corners (against "
        f"the floor or the top face of the box below; e = 0, mu = {mu}): {4 * n} closed, "
        f"redundant contacts. From t = {t_push} s a horizontal force F = {ramp} m g (t - "
        f"{t_push}) pushes the top box's centre along +x; the rigid stack tips about its "
        f"front edge at F = n m g w / ((2n - 1) h) = {tip_force / (mass * G):.6g} m g, "
        f"t = {t_push + tip_force / (ramp * mass * G):.6g} s, and falls over.")
    params = dict(
        n_boxes=n, width=width, height=height, depth=depth, mass=mass, mu=mu, ramp=ramp,
        t_push=t_push, gravity=G, tip_force=tip_force,
        tip_time=t_push + tip_force / (ramp * mass * G),
        balance_angle=float(np.arctan(width / (n * height))),
        normal_totals_at_rest=[(n - i) * mass * G for i in range(n)],
        assumptions=["box dimensions, masses and the push chosen",
                     "the push acts at the top box's centre, horizontally, growing linearly",
                     "contacts are the boxes' bottom corners against the plane below "
                     "(the top face of the box below, extended)"])
    outline = box_outline(width, height, depth)
    return Scene(name="box_stack", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=np.zeros(6 * n), t_end=t_end, parameters=MappingProxyType(params),
                 outlines={_box_name(i): outline for i in range(n)},
                 # the push's onset is a kink of the applied force: a segment ends there
                 simulation=MappingProxyType({"scheme": "event-driven",
                                              "breakpoints": (t_push,)}))
