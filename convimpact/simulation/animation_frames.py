"""Sampling a simulation at the frames of an animation, and projecting it to the picture.

:func:`frame_times` chooses uniform frame times and the playback rate; :func:`states_at`,
:func:`modes_at` and :func:`forces_at` give the joint coordinates, contact modes and contact
forces of a :class:`~convimpact.simulation.result.SimulationResult` at those times (right-
continuous at impacts); :class:`ViewProjection` maps world points to the drawing plane and
:func:`convex_hull` outlines a set of projected points. Used by
:mod:`convimpact.simulation.animation` and :mod:`convimpact.simulation.contact_plots`.
"""

from __future__ import annotations

from typing import Sequence, Union

import numpy as np

from ..errors import ParameterError, ShapeError
from .result import MODE_NAMES, SimulationResult

#: colour of each contact mode (open grey, stick green, slip red)
MODE_COLORS = {"open": "#8c8c8c", "stick": "#2ca02c", "slip": "#d62728"}
#: at most this many frames in a GIF by default (longer runs play at a lower frame rate)
MAX_FRAMES = 300
#: default oblique view of spatial models: (azimuth, elevation) in degrees
DEFAULT_SPATIAL_VIEW = (30.0, 20.0)
#: named views of spatial models: (azimuth, elevation) in degrees, the vertical pointing up
NAMED_VIEWS = {"oblique": DEFAULT_SPATIAL_VIEW, "front": (0.0, 0.0), "side": (90.0, 0.0),
               "top": (0.0, 90.0)}

View = Union[None, str, Sequence[float]]


# ----------------------------------------------------------------------------------------
# sampling the result at frame times
# ----------------------------------------------------------------------------------------
def frame_times(t_start: float, t_end: float, fps: float = 25.0, duration: float | None = None,
                max_frames: int = MAX_FRAMES) -> tuple[np.ndarray, float]:
    """Uniform frame times over [t_start, t_end] and the playback frame rate.

    Parameters
    ----------
    t_start, t_end : the simulated span.
    fps : requested playback frame rate (frames per second).
    duration : playback duration in seconds; default the simulated span (real time).
    max_frames : cap on the number of frames; when ``duration * fps`` exceeds it, the frame
        rate is lowered so that the playback still lasts ``duration``.

    Returns
    -------
    times : (n,) frame times, ``n = floor(duration * fps) + 1`` but at least 2 and at most
        ``max_frames`` (``t_start`` and ``t_end`` included).
    fps : the playback frame rate actually used, ``(n - 1) / duration``: one frame interval
        of playback is one frame interval of simulated time scaled by duration / span.
    """
    if not (np.isfinite(fps) and fps > 0):
        raise ParameterError(f"fps must be positive, got {fps}")
    if max_frames < 2:
        raise ParameterError(f"max_frames must be at least 2, got {max_frames}")
    span = float(t_end) - float(t_start)
    duration = span if duration is None else float(duration)
    if not np.isfinite(duration) or duration < 0:
        raise ParameterError(f"duration must be a non-negative number of seconds, got {duration}")
    n = int(np.floor(duration * fps + 1e-9)) + 1
    n = min(max(n, 2), int(max_frames))
    play_fps = (n - 1) / duration if duration > 0 else float(fps)
    return np.linspace(float(t_start), float(t_end), n), float(play_fps)


def interpolate_samples(t: np.ndarray, values: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Piece-wise linear interpolation of samples that may repeat a time at a jump.

    At a repeated time (an impact stores the pre- and post-impact samples at the same
    instant) the later sample wins: the interpolation is right-continuous, so a query at the
    impact instant or after it uses the post-impact sample, one before it interpolates toward
    the pre-impact sample. Queries outside [t[0], t[-1]] take the end samples.

    Parameters
    ----------
    t : (n,) non-decreasing sample times.
    values : (n, ...) samples.
    times : (m,) query times.

    Returns
    -------
    (m, ...) interpolated values.
    """
    t = np.asarray(t, dtype=float)
    values = np.asarray(values, dtype=float)
    times = np.asarray(times, dtype=float)
    if len(t) == 0:
        raise ShapeError("cannot interpolate an empty series")
    idx = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 1)
    nxt = np.minimum(idx + 1, len(t) - 1)
    t0, t1 = t[idx], t[nxt]
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(t1 > t0, (times - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)
    w = np.clip(w, 0.0, 1.0).reshape((-1,) + (1,) * (values.ndim - 1))
    return values[idx] + w * (values[nxt] - values[idx])


def states_at(result: SimulationResult, times: np.ndarray) -> np.ndarray:
    """Joint coordinates theta at ``times``, (m, k).

    From the dense output ``result.sol`` when there is one (right-continuous at impacts),
    else by :func:`interpolate_samples` of ``result.theta`` (post-impact sample at an impact).
    """
    times = np.asarray(times, dtype=float)
    k = result.theta.shape[1]
    sol = result.sol
    if sol is not None:
        lo = getattr(sol, "t_min", -np.inf)
        hi = getattr(sol, "t_max", np.inf)
        tq = np.clip(times, lo, hi)
        y = np.asarray(sol(tq), dtype=float)
        if y.ndim == 2 and y.shape[1] == len(tq) and y.shape[0] >= k:
            return y[:k].T.copy()
        return np.array([np.asarray(sol(ti), dtype=float).ravel()[:k] for ti in tq])
    return interpolate_samples(result.t, result.theta, times)


def contact_columns(result: SimulationResult, names: Sequence[str]) -> list[int | None]:
    """Column of each contact in the result's contact series (None when not recorded)."""
    recorded = list(result.contact_names)
    return [recorded.index(c) if c in recorded else None for c in names]


def _intervals_mode(result: SimulationResult, contact: str, t: float) -> str | None:
    """Mode of ``contact`` at t from the mode timeline (None when it has no interval)."""
    found = None
    for iv in result.mode_intervals:
        if iv.contact == contact and iv.t_start <= t <= iv.t_end:
            found = iv.mode
    return found


def modes_at(result: SimulationResult, names: Sequence[str], times: np.ndarray) -> np.ndarray:
    """Mode codes (indices into :data:`MODE_NAMES`) of the contacts ``names`` at ``times``.

    The mode timeline ``result.mode_intervals`` is used for a contact that has intervals;
    otherwise the sampled ``result.contact_mode`` (the latest sample at or before each time);
    a contact with neither is open.

    Returns
    -------
    (m, len(names)) int array.
    """
    times = np.asarray(times, dtype=float)
    out = np.zeros((len(times), len(names)), dtype=int)
    cols = contact_columns(result, names)
    sampled = (result.contact_mode.ndim == 2 and result.contact_mode.shape[0] == len(result.t)
               and result.contact_mode.shape[0] > 0)
    idx = np.clip(np.searchsorted(result.t, times, side="right") - 1, 0, max(len(result.t) - 1, 0))
    with_intervals = {iv.contact for iv in result.mode_intervals}
    for c, (name, col) in enumerate(zip(names, cols)):
        if name in with_intervals:
            out[:, c] = [MODE_NAMES.index(_intervals_mode(result, name, ti) or "open")
                         for ti in times]
        elif sampled and col is not None and col < result.contact_mode.shape[1]:
            out[:, c] = result.contact_mode[idx, col]
    return out


def forces_at(result: SimulationResult, names: Sequence[str], times: np.ndarray,
              dim: int) -> np.ndarray:
    """Contact-frame forces (normal first) of the contacts ``names`` at ``times``.

    Linear interpolation of ``result.contact_force`` (right-continuous at repeated times);
    zeros for a contact whose forces were not recorded.

    Returns
    -------
    (m, len(names), dim) array.
    """
    times = np.asarray(times, dtype=float)
    out = np.zeros((len(times), len(names), dim))
    f = result.contact_force
    if f.ndim != 3 or f.shape[0] != len(result.t) or f.shape[0] == 0:
        return out
    d = min(dim, f.shape[2])
    for c, col in enumerate(contact_columns(result, names)):
        if col is not None and col < f.shape[1]:
            out[:, c, :d] = interpolate_samples(result.t, f[:, col, :d], times)
    return out


# ----------------------------------------------------------------------------------------
# projection
# ----------------------------------------------------------------------------------------
class ViewProjection:
    """Orthographic map from world coordinates to the drawing plane.

    Planar models are drawn in their own x-y plane. Spatial models are drawn in an
    orthographic view with the vertical (opposite to gravity; +y when there is no gravity)
    pointing up the picture: ``view = (azimuth, elevation)`` in degrees, the camera turned
    by ``azimuth`` about the vertical from the front (+z toward the viewer, +x to the
    right) and raised by ``elevation``; default the oblique view (30, 20). Named views:
    "oblique", "front" (x right, y up), "side" (-z right, y up) and "top" (x right, looking
    down the vertical).

    Parameters
    ----------
    dim : 2 (planar) or 3 (spatial).
    view : None, a name of :data:`NAMED_VIEWS` or (azimuth, elevation) in degrees; planar
        models accept only None (or "front").
    gravity : (dim,) gravitational acceleration (sets the vertical of spatial views).
    """

    def __init__(self, dim: int, view: View = None, gravity: np.ndarray | None = None):
        self.dim = int(dim)
        if self.dim == 2:
            if view not in (None, "front"):
                raise ParameterError(f"a planar model is drawn in its x-y plane; view must be "
                                     f"None, got {view!r}")
            self.matrix = np.eye(2)
            self.camera = None
            self.description = "x-y plane"
            return
        if view is None:
            view = DEFAULT_SPATIAL_VIEW
        if isinstance(view, str):
            if view not in NAMED_VIEWS:
                raise ParameterError(f"unknown view {view!r}; use (azimuth, elevation) in degrees "
                                     f"or one of {', '.join(NAMED_VIEWS)}")
            view = NAMED_VIEWS[view]
        try:
            az, el = (float(v) for v in view)
        except (TypeError, ValueError):
            raise ParameterError(
                f"view must be (azimuth, elevation) in degrees, got {view!r}") from None
        g = np.zeros(3) if gravity is None else np.asarray(gravity, dtype=float)
        up = -g / np.linalg.norm(g) if np.linalg.norm(g) > 0 else np.array([0.0, 1.0, 0.0])
        e1 = np.array([1.0, 0.0, 0.0]) - up[0] * up
        if np.linalg.norm(e1) < 1e-6:
            e1 = np.array([0.0, 0.0, 1.0]) - up[2] * up
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(e1, up)
        a, b = np.radians(az), np.radians(el)
        camera = np.cos(b) * (np.sin(a) * e1 + np.cos(a) * e2) + np.sin(b) * up
        right = np.cos(a) * e1 - np.sin(a) * e2
        self.matrix = np.vstack([right, np.cross(camera, right)])
        self.camera = camera  # unit vector toward the viewer (for depth ordering)
        self.description = f"orthographic view, azimuth {az:g} deg, elevation {el:g} deg"

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Project points or vectors, (..., dim) -> (..., 2)."""
        return np.asarray(points, dtype=float) @ self.matrix.T


# ----------------------------------------------------------------------------------------
# outlines
# ----------------------------------------------------------------------------------------
def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull of 2-D points (Andrew's monotone chain).

    Collinear points give the two extreme points, a single point itself.
    """
    pts = np.unique(np.round(np.asarray(points, dtype=float), 12), axis=0)
    if len(pts) <= 2:
        return pts
    order = np.lexsort((pts[:, 1], pts[:, 0]))
    pts = pts[order]

    def turn(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for p in pts:
        while len(lower) >= 2 and turn(lower[-2], lower[-1], p) <= 1e-15:
            lower.pop()
        lower.append(p)
    upper: list = []
    for p in pts[::-1]:
        while len(upper) >= 2 and turn(upper[-2], upper[-1], p) <= 1e-15:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])

