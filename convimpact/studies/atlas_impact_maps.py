"""Impact maps of the failure atlas: the impact laws over the configurations of the double
pendulum (:func:`pendulum_angle_map`, :func:`pendulum_friction_map`) and of the slider-crank
(:func:`slider_crank_map`, its states by :func:`slider_crank_state`).

Each map first collects its samples (cell, M, Jc, dq, e, mu, C), then judges them all under
every path (:func:`~convimpact.studies.atlas_modes._classify_samples`: the ``"fast"`` paths of
the open-loop pendulum maps in one compiled batch per path, the others per sample), then
accumulates the judgments cell by cell in sample order.
"""

from __future__ import annotations

import math
import time
from typing import Callable, Iterable, Sequence

import numpy as np

from .atlas_modes import (DEFAULT_PATHS, IMPACT_MODES, PENDULUM_RATES, AtlasMap, _label,
                          _classify_samples, _MapBuilder, _Sample)


def _pendulum_mechanism(mass: float = 1.0, length: float = 1.0):
    """The paper's planar double pendulum (problems/_double_pendulum.py); the tip contact's
    Jacobian does not depend on the floor height, so one model serves every configuration
    (the floor is taken at the configuration's tip height)."""
    from convimpact.problems._double_pendulum import build

    return build(True, mass, length, -2.0 * length, 0.5, 0.3).mechanism()


def _judge_into(b: _MapBuilder, samples: list[_Sample], paths,
                marks: list[tuple[int, str]], progress: Callable[[str], None] | None) -> None:
    """Judge ``samples`` under ``paths`` and add them to ``b`` in order; ``marks`` are
    (samples judged, message) pairs passed to ``progress`` once that many are judged."""
    pending = list(marks) if progress else []

    def after(i: int) -> None:
        while pending and pending[0][0] <= i + 1:
            progress(pending.pop(0)[1])

    judged = _classify_samples(samples, paths, after=after if pending else None)
    for _, msg in pending:  # marks with no sample after them
        progress(msg)
    for s, j in zip(samples, judged):
        b.add(s.iy, s.ix, j)


def pendulum_angle_map(theta1: Sequence[float] | None = None,
                       theta2: Sequence[float] | None = None, e: Iterable[float] = (0.5,),
                       mu: Iterable[float] = (0.3, 0.8),
                       rates: Iterable[Sequence[float]] = PENDULUM_RATES,
                       paths=DEFAULT_PATHS, progress: Callable[[str], None] | None = None
                       ) -> AtlasMap:
    """Impact laws over the planar double pendulum's configurations theta1 x theta2.

    The tip strikes a floor at its own height; theta1 is rod 1's angle from +x, theta2 rod 2's
    angle relative to rod 1 (radians). Each cell tries every rate pair (theta_dot), e and mu.
    Also returns ``values["delassus_condition"]`` (2-norm condition of W).
    """
    th1 = np.linspace(-np.pi, 0.0, 13) if theta1 is None else np.asarray(theta1, float)
    th2 = np.linspace(-np.pi, np.pi, 13) if theta2 is None else np.asarray(theta2, float)
    mech = _pendulum_mechanism()
    labels = [_label(p) for p in paths]
    b = _MapBuilder(labels, IMPACT_MODES, (th2.size, th1.size))
    cond = np.full((th2.size, th1.size), np.nan)
    t0 = time.perf_counter()
    samples: list[_Sample] = []
    marks: list[tuple[int, str]] = []
    for iy, b2 in enumerate(th2):
        for ix, a1 in enumerate(th1):
            th = np.array([a1, b2])
            M = np.asarray(mech.mass_matrix(th), float)
            J = np.asarray(mech.contact_jacobian("tip", th), float)
            W = J @ np.linalg.solve(M, J.T)
            cond[iy, ix] = np.linalg.cond(W)
            for rate in rates:
                for ee in e:
                    for mm in mu:
                        samples.append(_Sample(iy, ix, M, J, np.asarray(rate, float), ee, mm))
        marks.append((len(samples), f"atlas pendulum theta1 x theta2: row {iy + 1}/{th2.size}"))
    _judge_into(b, samples, paths, marks, progress)
    return b.build("pendulum_angles", "planar double pendulum, tip on the floor: theta1 x "
                   "theta2", "theta1 (rod 1 from +x) [rad]", "theta2 (rod 2 relative) [rad]",
                   th1, th2, {"delassus_condition": cond},
                   {"e": list(e), "mu": list(mu), "rates": [list(r) for r in rates],
                    "paths": labels}, t0)


def pendulum_friction_map(theta2: Sequence[float] | None = None,
                          mu: Sequence[float] | None = None, theta1: float = -0.6 * np.pi,
                          e: Iterable[float] = (0.0, 0.5, 1.0),
                          rates: Iterable[Sequence[float]] = PENDULUM_RATES,
                          paths=DEFAULT_PATHS, progress=None) -> AtlasMap:
    """Impact laws over theta2 x mu of the double pendulum at a fixed theta1 (default -108
    degrees, case (a)'s rod 1), every rate pair and e in each cell."""
    th2 = np.linspace(-np.pi, np.pi, 13) if theta2 is None else np.asarray(theta2, float)
    mus = np.linspace(0.0, 1.5, 7) if mu is None else np.asarray(mu, float)
    mech = _pendulum_mechanism()
    labels = [_label(p) for p in paths]
    b = _MapBuilder(labels, IMPACT_MODES, (mus.size, th2.size))
    t0 = time.perf_counter()
    samples: list[_Sample] = []
    marks: list[tuple[int, str]] = []
    for ix, b2 in enumerate(th2):
        th = np.array([theta1, b2])
        M = np.asarray(mech.mass_matrix(th), float)
        J = np.asarray(mech.contact_jacobian("tip", th), float)
        for iy, mm in enumerate(mus):
            for rate in rates:
                for ee in e:
                    samples.append(_Sample(iy, ix, M, J, np.asarray(rate, float), ee, mm))
        if ix % 4 == 0:
            marks.append((len(samples), f"atlas pendulum theta2 x mu: column {ix + 1}/"
                          f"{th2.size}"))
    _judge_into(b, samples, paths, marks, progress)
    return b.build("pendulum_friction", f"planar double pendulum at theta1 = "
                   f"{math.degrees(theta1):.0f} deg: theta2 x mu", "theta2 (rod 2 relative) "
                   "[rad]", "mu", th2, mus, {},
                   {"theta1": theta1, "e": list(e), "rates": [list(r) for r in rates],
                    "paths": labels}, t0)


def slider_crank_state(mech, crank_angle: float, crank_rate: float = 20.0,
                       slider_speed: float = -1.0, geometry: str = "scene"):
    """(theta, theta_dot) of a slider-crank with the free slider touching slider 3.

    ``geometry="scene"``: :mod:`convimpact.problems.slider_crank` (relative coupler angle,
    crank 0.15 m, coupler 0.40 m). ``geometry="isosceles"``: the hand model
    :class:`convimpact.simulation.testing.SliderCrank` with r = l (absolute angles; at the
    change points phi1 = +-90 deg the pin sits on the crank axis and C loses rank). Velocities
    solve C theta_dot = 0 for the crank rate by least squares (exact where C has full rank,
    the minimum-norm consistent choice at a change point).
    """
    a = float(crank_angle)
    if geometry == "scene":
        from convimpact.problems.slider_crank import (COUPLER_LENGTH, CRANK_LENGTH,
                                                      FREE_SLIDER_HALF_WIDTH,
                                                      SLIDER_HALF_WIDTH)
        r, l = CRANK_LENGTH, COUPLER_LENGTH
        phi2 = math.asin(max(-1.0, min(1.0, -r * math.sin(a) / l)))
        th = np.array([a, phi2 - a, r * math.cos(a) + l * math.cos(phi2), 0.0])
        th[3] = th[2] + SLIDER_HALF_WIDTH + FREE_SLIDER_HALF_WIDTH
    else:
        r, l = mech.r, mech.l
        phi2 = math.asin(max(-1.0, min(1.0, -r * math.sin(a) / l)))
        th = np.array([a, phi2, r * math.cos(a) + l * math.cos(phi2), 0.0])
        th[3] = th[2] + mech.clearance
    C = np.asarray(mech.loop_jacobian(th), float)
    rest = np.linalg.lstsq(C[:, 1:3], -C[:, 0] * crank_rate, rcond=None)[0]
    dq = np.array([crank_rate, rest[0], rest[1], slider_speed])
    return th, dq


def slider_crank_map(crank_angle: Sequence[float] | None = None,
                     mu: Sequence[float] | None = None, e: Iterable[float] = (0.83,),
                     geometry: str = "scene", slider_speeds: Iterable[float] = (-1.0,),
                     paths=DEFAULT_PATHS, progress=None) -> AtlasMap:
    """Impact laws over crank angle x mu of the slider-crank striking the free slider.

    The crank angle covers its full turn, dead centres (0, +-pi) included; the crank turns at
    20 rad/s and the free slider moves at each of ``slider_speeds``. Also returns
    ``values["loop_condition"]`` (condition of C M^-1 C^T; inf where C loses rank).
    """
    from convimpact.simulation.testing import SliderCrank

    ang = (np.linspace(-np.pi, np.pi, 25) if crank_angle is None
           else np.asarray(crank_angle, float))
    mus = np.linspace(0.0, 1.0, 5) if mu is None else np.asarray(mu, float)
    if geometry == "scene":
        from convimpact.scenes import load_scene

        mech = load_scene("slider_crank").mechanism
    elif geometry == "isosceles":
        mech = SliderCrank(r=0.2, l=0.2)
    else:
        from ..errors import UnknownOptionError
        raise UnknownOptionError(f"unknown geometry {geometry!r}; choose 'scene' or "
                                 "'isosceles'")
    labels = [_label(p) for p in paths]
    b = _MapBuilder(labels, IMPACT_MODES, (mus.size, ang.size))
    loop_cond = np.full((mus.size, ang.size), np.nan)
    t0 = time.perf_counter()
    samples: list[_Sample] = []
    marks: list[tuple[int, str]] = []
    for ix, a in enumerate(ang):
        for v4 in slider_speeds:
            th, dq = slider_crank_state(mech, a, slider_speed=v4, geometry=geometry)
            M = np.asarray(mech.mass_matrix(th), float)
            C = np.asarray(mech.loop_jacobian(th), float)
            name = mech.contact_names[0]
            J = np.asarray(mech.contact_jacobian(name, th), float)
            S = C @ np.linalg.solve(M, C.T)
            sv = np.linalg.svd(S, compute_uv=False)
            loop_cond[:, ix] = sv[0] / sv[-1] if sv[-1] > 0 else np.inf
            for iy, mm in enumerate(mus):
                for ee in e:
                    samples.append(_Sample(iy, ix, M, J, dq, ee, mm, C))
        if ix % 6 == 0:
            marks.append((len(samples), f"atlas slider-crank ({geometry}) angle x mu: column "
                          f"{ix + 1}/{ang.size}"))
    _judge_into(b, samples, paths, marks, progress)
    title = ("slider-crank striking the free slider" if geometry == "scene" else
             "isosceles slider-crank (r = l, change points at +-90 deg)")
    return b.build(f"slider_crank_{geometry}", f"{title}: crank angle x mu",
                   "crank angle [rad]", "mu", ang, mus, {"loop_condition": loop_cond},
                   {"geometry": geometry, "e": list(e), "slider_speeds": list(slider_speeds),
                    "crank_rate": 20.0, "paths": labels}, t0)
