"""Pictures of a simulation: an animated GIF of the mechanism and a contact-mode figure.

:func:`animate` draws a mechanism built with :class:`~convimpact.model.ModelBuilder` at
uniformly spaced times of a :class:`~convimpact.simulation.result.SimulationResult` and
writes the frames as an animated GIF (matplotlib's ``PillowWriter``: no ffmpeg needed, works
headless). Every body is drawn from the model alone, as the convex hull of its joint origin,
centre of mass, child joint origins, loop-joint frames and contact points; contact spheres
(radius > 0) as discs; plane contacts against the ground as the ground; each contact point
is coloured by its mode (open grey, stick green, slip red) with an arrow for its force while
closed, and impacts flash.

:func:`plot_contacts` draws, per contact, the mode timeline and the contact force series
(normal force, tangential force magnitude, and the friction bound mu lambda_n).

Both are used by ``convimpact simulate`` (``contacts.png`` always, ``animation.gif`` with
``--animate``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence, Union

import numpy as np

from ..impact.errors import NotSupportedError, ParameterError, ShapeError
from .result import MODE_NAMES, SimulationResult

#: colour of each contact mode (open grey, stick green, slip red)
MODE_COLORS = {"open": "#8c8c8c", "stick": "#2ca02c", "slip": "#d62728"}
#: colour of the flash marking an impact
IMPACT_COLOR = "#ffb000"
#: colour of the contact force arrows
FORCE_COLOR = "#17306b"
#: body colours (no green or red, which mark the contact modes)
BODY_COLORS = ("#1f77b4", "#9467bd", "#8c564b", "#17becf", "#e7ba52", "#393b79", "#7f7f7f")
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


def _contact_columns(result: SimulationResult, names: Sequence[str]) -> list[int | None]:
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
    cols = _contact_columns(result, names)
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
    for c, col in enumerate(_contact_columns(result, names)):
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
# geometry of the model
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


def check_animatable(mechanism: Any):
    """The :class:`~convimpact.model.builder.Model` behind ``mechanism``.

    Raises
    ------
    NotSupportedError
        When ``mechanism`` was not built with ModelBuilder (a user-defined Mechanism has no
        geometry to draw).
    """
    from ..model.builder import Model

    model = getattr(mechanism, "model", None)
    if not isinstance(model, Model):
        raise NotSupportedError(
            f"animation needs a mechanism built with convimpact.model.ModelBuilder "
            f"(model.mechanism()); {type(mechanism).__name__} is a user-defined Mechanism "
            "whose bodies and contact geometry are unknown")
    return model


def _canvas_pillow_writer(fps: float):
    """A ``PillowWriter`` that takes each frame from the Agg canvas as it stands.

    matplotlib's writer redraws the whole figure (``savefig``) per frame; this one copies
    the canvas that :meth:`MechanismAnimation.save` has already updated (background cached,
    moving artists redrawn) and quantizes it to a 256-colour palette (fast octree, no
    dithering, so flat colours stay exact). Writing the GIF is still PillowWriter's.
    """
    from matplotlib.animation import PillowWriter
    from PIL import Image

    class CanvasPillowWriter(PillowWriter):
        def grab_frame(self, **savefig_kwargs):
            rgba = np.asarray(self.fig.canvas.buffer_rgba())
            frame = Image.fromarray(np.ascontiguousarray(rgba[..., :3]))
            self._frames.append(frame.quantize(colors=256, method=Image.Quantize.FASTOCTREE,
                                               dither=Image.Dither.NONE))

    return CanvasPillowWriter(fps=fps)


@dataclass
class _Frames:
    """World geometry of every frame (filled by :meth:`MechanismAnimation._collect`).

    ``n`` frames, ``d`` the dimension, ``nc`` the number of contacts.
    """

    bodies: list = field(default_factory=list)  # per body: (n, points of the body, d)
    pins: Any = None  # (n, revolute joints, d)
    loop_pins: Any = None  # (n, 2 per loop, d): the frames on body a and body b
    rails: list = field(default_factory=list)  # per prismatic joint: (n, 2, d) ends
    disc_centres: list = field(default_factory=list)  # per disc: (n, d)
    disc_marks: list = field(default_factory=list)  # per disc: (n, d), a point on the rim
    contact_points: Any = None  # (n, nc, d)
    contact_normals: Any = None  # (n, nc, d)
    contact_tangents: Any = None  # (n, nc, d - 1, d)
    moving_planes: list = field(default_factory=list)  # per plane: point, normal, tangents
    moving_spheres: list = field(default_factory=list)  # per sphere: (n, d) centre


class MechanismAnimation:
    """The figure and artists of an animation of a simulated mechanism.

    :func:`animate` is the usual entry point; this class is for drawing single frames
    (``draw(i)`` then ``fig.savefig``), writing the GIF (``save``) and locating things in
    the picture (``pixel``).

    Parameters
    ----------
    result : the simulation.
    mechanism : the simulated mechanism, built with ModelBuilder (``model.mechanism()``).
    fps, duration, max_frames : see :func:`frame_times`.
    size : figure size in inches (width, height).
    dpi : dots per inch; a frame is ``size * dpi`` pixels.
    view : spatial models only, see :class:`ViewProjection`.
    title : text above the picture (default none).

    Attributes
    ----------
    times : (n,) frame times; fps : playback frame rate; theta : (n, k) frame states;
    modes : (n, n_contacts) mode codes; forces : (n, n_contacts, d) contact-frame forces;
    fig, ax : the matplotlib figure and axes; projection : the :class:`ViewProjection`.
    """

    def __init__(self, result: SimulationResult, mechanism: Any, fps: float = 25.0,
                 duration: float | None = None, size: tuple[float, float] = (6.0, 4.5),
                 dpi: float = 80, view: View = None, title: str | None = None,
                 max_frames: int = MAX_FRAMES):
        self.model = check_animatable(mechanism)
        self.mechanism = mechanism
        self.result = result
        if result.theta.ndim != 2 or result.theta.shape[1] != self.model.n_coordinates:
            raise ShapeError(f"the result has {result.theta.shape[-1]} coordinates, the model "
                             f"{self.model.n_coordinates}; animate a result of this mechanism")
        if len(result.t) == 0:
            raise ShapeError("the result has no samples to animate")
        self.dim = self.model.dim
        self.projection = ViewProjection(self.dim, view, self.model.gravity)
        self.times, self.fps = frame_times(result.t[0], result.t[-1], fps, duration, max_frames)
        self.size = (float(size[0]), float(size[1]))
        self.dpi = float(dpi)
        self.title = title
        self.contact_names = tuple(self.model.contact_names)
        self.theta = states_at(result, self.times)
        self.modes = modes_at(result, self.contact_names, self.times)
        self.forces = forces_at(result, self.contact_names, self.times, self.dim)
        self._impact_points: dict = {}
        self._collect()
        self._build_figure()

    # -- geometry ------------------------------------------------------------------------
    def _body_local_points(self, b: int) -> np.ndarray:
        """Body-frame points outlining body b (origin, COM, child joints, loops, contacts)."""
        model = self.model
        d = self.dim
        pts = [np.zeros(d), model.bodies[b].com]
        pts += [c.placement_origin for c in model.bodies if c.parent == b]
        for lp in model.loops:
            if lp.body_a == b:
                pts.append(lp.origin_a)
            if lp.body_b == b:
                pts.append(lp.origin_b)
        for spec in model.contacts:
            if spec.body == b:
                pts.append(spec.point)
            if spec.other == b:
                pts.append(spec.other_point)
        return np.array(pts, dtype=float)

    def _collect(self) -> None:
        """World geometry at every frame."""
        model, mech = self.model, self.mechanism
        n, d = len(self.times), self.dim
        bodies = model.bodies[1:]
        local = {b.index: self._body_local_points(b.index) for b in bodies}
        self._pin_bodies = [b.index for b in bodies
                            if b.motions and all(m.kind == "revolute" for m in b.motions)]
        self._rail_bodies = [b.index for b in bodies
                             if len(b.motions) == 1 and b.motions[0].kind == "prismatic"]
        self._discs = [i for i, s in enumerate(model.contacts) if s.radius > 0]
        self._moving_planes = [i for i, s in enumerate(model.contacts)
                               if s.target == "plane" and s.other != 0]
        self._moving_spheres = [i for i, s in enumerate(model.contacts)
                                if s.target == "sphere" and s.other != 0]
        f = _Frames()
        f.bodies = [np.zeros((n, len(local[b.index]), d)) for b in bodies]
        f.pins = np.zeros((n, len(self._pin_bodies), d))
        f.loop_pins = np.zeros((n, 2 * len(model.loops), d))
        f.rails = [np.zeros((n, 2, d)) for _ in self._rail_bodies]
        f.disc_centres = [np.zeros((n, d)) for _ in self._discs]
        f.disc_marks = [np.zeros((n, d)) for _ in self._discs]
        nc = len(self.contact_names)
        f.contact_points = np.zeros((n, nc, d))
        f.contact_normals = np.zeros((n, nc, d))
        f.contact_tangents = np.zeros((n, nc, d - 1, d))
        f.moving_planes = [(np.zeros((n, d)), np.zeros((n, d)), np.zeros((n, d - 1, d)))
                           for _ in self._moving_planes]
        f.moving_spheres = [np.zeros((n, d)) for _ in self._moving_spheres]
        # prismatic coordinate ranges over the run, for the rails
        th_all = np.vstack([self.theta, self.result.theta])
        rail_range = []
        for b in self._rail_bodies:
            j = model.bodies[b].coordinates[0]
            rail_range.append((float(np.min(th_all[:, j])), float(np.max(th_all[:, j]))))
        for i, theta in enumerate(self.theta):
            place = {b.index: mech.body_placement(b.name, theta) for b in bodies}
            place[0] = (np.eye(d), np.zeros(d))
            for bi, b in enumerate(bodies):
                R, o = place[b.index]
                f.bodies[bi][i] = o + local[b.index] @ R.T
            for pi, b in enumerate(self._pin_bodies):
                f.pins[i, pi] = place[b][1]
            for li, lp in enumerate(model.loops):
                Ra, oa = place[lp.body_a]
                Rb, ob = place[lp.body_b]
                f.loop_pins[i, 2 * li] = oa + Ra @ lp.origin_a
                f.loop_pins[i, 2 * li + 1] = ob + Rb @ lp.origin_b
            for ri, b in enumerate(self._rail_bodies):
                info = model.bodies[b]
                Rp, op = place[info.parent]
                origin = op + Rp @ info.placement_origin
                axis = Rp @ info.placement_rotation @ info.motions[0].axis
                smin, smax = rail_range[ri]
                f.rails[ri][i] = [origin + smin * axis, origin + smax * axis]
            for ci, name in enumerate(self.contact_names):
                cf = mech.contact_frame(name, theta)
                f.contact_points[i, ci] = cf.point
                f.contact_normals[i, ci] = cf.normal
                f.contact_tangents[i, ci] = cf.tangents
            for di, c in enumerate(self._discs):
                spec = model.contacts[c]
                R, o = place[spec.body]
                f.disc_centres[di][i] = o + R @ spec.point
                f.disc_marks[di][i] = f.disc_centres[di][i] + spec.radius * R[:, 0]
            for pi, c in enumerate(self._moving_planes):
                spec = model.contacts[c]
                R, o = place[spec.other]
                f.moving_planes[pi][0][i] = o + R @ spec.other_point
                f.moving_planes[pi][1][i] = f.contact_normals[i, c]
                f.moving_planes[pi][2][i] = f.contact_tangents[i, c]
            for si, c in enumerate(self._moving_spheres):
                spec = model.contacts[c]
                R, o = place[spec.other]
                f.moving_spheres[si][i] = o + R @ spec.other_point
        self.frames = f

    def _ground_planes(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]]:
        """Distinct plane contacts against the ground: (point, normal, tangents, contacts)."""
        planes: list = []
        for ci, spec in enumerate(self.model.contacts):
            if spec.target != "plane" or spec.other != 0:
                continue
            n = spec.normal / np.linalg.norm(spec.normal)
            for pl in planes:
                if np.allclose(pl[1], n, atol=1e-9) and abs(n @ (spec.other_point - pl[0])) < 1e-9:
                    pl[3].append(ci)
                    break
            else:
                planes.append((spec.other_point.astype(float), n,
                               self.frames.contact_tangents[0, ci], [ci]))
        return planes

    # -- figure --------------------------------------------------------------------------
    def _build_figure(self) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import LineCollection, PolyCollection
        from matplotlib.figure import Figure
        from matplotlib.lines import Line2D
        from matplotlib.patches import Circle, FancyArrowPatch, Polygon

        P = self.projection
        f = self.frames
        fig = Figure(figsize=self.size, dpi=self.dpi, facecolor="white")
        FigureCanvasAgg(fig)
        ax_box = [0.11, 0.09, 0.86, 0.76]
        ax = fig.add_axes(ax_box)
        self.fig, self.ax = fig, ax
        # -- extent of the motion (mechanism only), then of the ground under it
        parts = [b.reshape(-1, self.dim) for b in f.bodies]
        parts += [r.reshape(-1, self.dim) for r in f.rails]
        parts.append(f.contact_points.reshape(-1, self.dim))
        moving = P(np.vstack(parts))
        lo, hi = moving.min(axis=0), moving.max(axis=0)
        for di, c in enumerate(self._discs):
            r = self.model.contacts[c].radius
            cen = P(f.disc_centres[di])
            lo, hi = np.minimum(lo, cen.min(axis=0) - r), np.maximum(hi, cen.max(axis=0) + r)
        scale = float(max(np.max(hi - lo), 1e-3))
        self.scene_size = scale
        # force arrows: the largest force of the run is drawn 0.2 scene sizes long
        world_forces = (self.forces[..., :1] * f.contact_normals
                        + np.einsum("nck,nckd->ncd", self.forces[..., 1:], f.contact_tangents))
        closed = self.modes != 0
        fmax = float(np.max(np.linalg.norm(world_forces[closed], axis=-1))) if closed.any() else 0.0
        self.force_scale = 0.2 * scale / fmax if fmax > 0 else 0.0
        self._world_forces = world_forces
        if closed.any():
            tips = P(f.contact_points[closed] + self.force_scale * world_forces[closed])
            lo, hi = np.minimum(lo, tips.min(axis=0)), np.maximum(hi, tips.max(axis=0))
        planes = self._ground_planes()
        ground_pts = []
        all_world = np.vstack(parts)
        for o, n, tang, cs in planes:
            feet = f.contact_points[:, cs].reshape(-1, self.dim)
            feet = feet - ((feet - o) @ n)[:, None] * n
            ground_pts.append(P(feet))
        if ground_pts:
            gp = np.vstack(ground_pts)
            lo, hi = np.minimum(lo, gp.min(axis=0)), np.maximum(hi, gp.max(axis=0))
        # the spatial floor patch: the shadow of the mechanism on it, padded
        patches3d = []
        if self.dim == 3:
            for o, n, tang, cs in planes:
                uv = (all_world - o) @ tang.T
                umin, vmin = uv.min(axis=0) - 0.25 * scale
                umax, vmax = uv.max(axis=0) + 0.25 * scale
                corners = [o + u * tang[0] + v * tang[1]
                           for u, v in ((umin, vmin), (umax, vmin), (umax, vmax), (umin, vmax))]
                grid = []
                for s in np.linspace(0.0, 1.0, 6):
                    u = umin + s * (umax - umin)
                    v = vmin + s * (vmax - vmin)
                    grid.append([o + u * tang[0] + vmin * tang[1],
                                 o + u * tang[0] + vmax * tang[1]])
                    grid.append([o + umin * tang[0] + v * tang[1],
                                 o + umax * tang[0] + v * tang[1]])
                pc = P(np.array(corners))
                patches3d.append((pc, P(np.array(grid))))
                lo, hi = np.minimum(lo, pc.min(axis=0)), np.maximum(hi, pc.max(axis=0))
        # -- fixed limits with equal scale filling the axes box
        pad = 0.06 * float(max(np.max(hi - lo), 1e-3))
        lo, hi = lo - pad, hi + pad
        w_px = ax_box[2] * self.size[0]
        h_px = ax_box[3] * self.size[1]
        span = hi - lo
        per_unit = min(w_px / span[0], h_px / span[1])
        half = 0.5 * np.array([w_px, h_px]) / per_unit
        mid = 0.5 * (lo + hi)
        ax.set_xlim(mid[0] - half[0], mid[0] + half[0])
        ax.set_ylim(mid[1] - half[1], mid[1] + half[1])
        ax.set_aspect("equal", adjustable="box")
        ax.tick_params(labelsize="x-small")
        if self.dim == 2:
            ax.set_xlabel("x [m]", fontsize="small")
            ax.set_ylabel("y [m]", fontsize="small")
        else:
            ax.set_xlabel(f"[m] ({P.description})", fontsize="small")
        # -- static ground
        if self.dim == 2:
            far = 20.0 * max(half)
            for o, n, tang, cs in planes:
                t = tang[0]
                foot = mid - ((mid - o) @ n) * n
                a, b = foot - far * t, foot + far * t
                band = 0.03 * scale
                ax.add_patch(Polygon([a, b, b - band * n, a - band * n], closed=True,
                                     facecolor="0.85", edgecolor="none", zorder=0))
                ax.plot([a[0], b[0]], [a[1], b[1]], color="0.35", lw=1.5, zorder=1)
        else:
            for pc, grid in patches3d:
                ax.add_patch(Polygon(pc, closed=True, facecolor="0.93", edgecolor="0.5",
                                     lw=0.8, zorder=0))
                ax.add_collection(LineCollection(grid, colors="0.8", lw=0.5, zorder=0.5))
        for c, spec in enumerate(self.model.contacts):
            if spec.target == "sphere" and spec.other == 0:
                ax.add_patch(Circle(P(spec.other_point), spec.other_radius, facecolor="0.85",
                                    edgecolor="0.35", zorder=0.5))
        # -- moving artists
        self._rail_art = LineCollection([], colors="0.55", lw=1.0, linestyles="--", zorder=1)
        ax.add_collection(self._rail_art)
        self._body_art = []
        for bi, b in enumerate(self.model.bodies[1:]):
            color = BODY_COLORS[bi % len(BODY_COLORS)]
            poly = Polygon(np.zeros((1, 2)), closed=True, facecolor=(color, 0.35),
                           edgecolor=(color, 0.9), lw=3.5, joinstyle="round", capstyle="round",
                           zorder=2)
            ax.add_patch(poly)
            self._body_art.append(poly)
        self._disc_art = []
        for c in self._discs:
            spec = self.model.contacts[c]
            color = BODY_COLORS[(spec.body - 1) % len(BODY_COLORS)]
            circ = Circle((0.0, 0.0), spec.radius, facecolor=(color, 0.35),
                          edgecolor=(color, 0.9), lw=1.5, zorder=2.5)
            ax.add_patch(circ)
            self._disc_art.append(circ)
        self._spin_art = LineCollection([], colors="0.15", lw=1.0, zorder=3)
        ax.add_collection(self._spin_art)
        self._plane_art = PolyCollection([], facecolors="0.75", edgecolors="0.3", lw=1.5,
                                         zorder=2.2)
        ax.add_collection(self._plane_art)
        self._sphere_art = []
        for c in self._moving_spheres:
            spec = self.model.contacts[c]
            circ = Circle((0.0, 0.0), spec.other_radius, facecolor="0.8", edgecolor="0.3",
                          zorder=2.2)
            ax.add_patch(circ)
            self._sphere_art.append(circ)
        (self._pin_art,) = ax.plot([], [], "o", ms=5, mfc="white", mec="0.1", mew=1.2,
                                   ls="none", zorder=4)
        (self._loop_art,) = ax.plot([], [], "s", ms=5, mfc="white", mec="0.1", mew=1.2,
                                    ls="none", zorder=4)
        (self._flash_art,) = ax.plot([], [], "*", ms=22, mfc=IMPACT_COLOR, mec="#b36b00",
                                     mew=0.8, ls="none", zorder=5.5)
        self._arrow_art = []
        for _ in self.contact_names:
            arrow = FancyArrowPatch((0.0, 0.0), (0.0, 0.0), arrowstyle="-|>", mutation_scale=10,
                                    color=FORCE_COLOR, lw=1.6, zorder=5, visible=False)
            ax.add_patch(arrow)
            self._arrow_art.append(arrow)
        nc = len(self.contact_names)
        self._contact_art = ax.scatter(np.zeros(nc), np.zeros(nc), s=42, c=["w"] * nc,
                                       edgecolors="0.1", linewidths=0.7, zorder=6)
        self._time_art = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", ha="left",
                                 family="monospace", fontsize="small", zorder=7,
                                 bbox=dict(facecolor="white", edgecolor="none", alpha=0.8))
        self._status_art = ax.text(0.98, 0.97, "", transform=ax.transAxes, va="top", ha="right",
                                   fontsize="small", fontweight="bold", color="#b36b00", zorder=7)
        # flash: the first two frames at or after each impact
        dt = float(self.times[1] - self.times[0]) if len(self.times) > 1 else 0.0
        self._flash_window = 2.0 * dt
        self._time_decimals = max(2, int(np.ceil(-np.log10(dt))) + 1) if dt > 0 else 3
        handles = []
        if self.contact_names:
            handles += [Line2D([], [], marker="o", ls="none", mfc=MODE_COLORS[m], mec="0.1",
                               label=m) for m in MODE_NAMES]
            handles.append(Line2D([], [], marker="*", ms=11, ls="none", mfc=IMPACT_COLOR,
                                  mec="#b36b00", label="impact"))
            handles.append(Line2D([], [], color=FORCE_COLOR, lw=1.6, marker=">", ms=5,
                                  label="contact force"))
        if self.model.loops:
            handles.append(Line2D([], [], marker="s", ls="none", mfc="white", mec="0.1",
                                  label="loop joint"))
        if handles:
            fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 0.94),
                       ncol=len(handles), frameon=False, fontsize="x-small", handletextpad=0.3,
                       columnspacing=1.0)
        if self.title:
            fig.text(0.5, 0.985, self.title, ha="center", va="top", fontsize="small")

    # -- drawing -------------------------------------------------------------------------
    def draw(self, i: int) -> None:
        """Update the artists to frame ``i``."""
        P, f = self.projection, self.frames
        t = float(self.times[i])
        for bi, poly in enumerate(self._body_art):
            hull = convex_hull(P(f.bodies[bi][i]))
            poly.set_xy(hull if len(hull) > 1 else np.vstack([hull, hull]))
        self._rail_art.set_segments([P(r[i]) for r in f.rails])
        for di, circ in enumerate(self._disc_art):
            circ.center = tuple(P(f.disc_centres[di][i]))
        self._spin_art.set_segments([P(np.array([f.disc_centres[di][i], f.disc_marks[di][i]]))
                                     for di in range(len(self._disc_art))])
        verts = []
        half = 0.06 * self.scene_size
        for (o, n, tang) in f.moving_planes:
            if self.dim == 2:
                verts.append(P(np.array([o[i] - half * tang[i][0], o[i] + half * tang[i][0]])))
            else:
                t1, t2 = tang[i]
                verts.append(P(np.array([o[i] + half * (a * t1 + b * t2)
                                         for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))])))
        self._plane_art.set_verts(verts)
        for si, circ in enumerate(self._sphere_art):
            circ.center = tuple(P(f.moving_spheres[si][i]))
        pins = P(f.pins[i]) if len(self._pin_bodies) else np.zeros((0, 2))
        self._pin_art.set_data(pins[:, 0], pins[:, 1])
        lp = P(f.loop_pins[i]) if len(f.loop_pins[i]) else np.zeros((0, 2))
        self._loop_art.set_data(lp[:, 0], lp[:, 1])
        points = P(f.contact_points[i]) if len(self.contact_names) else np.zeros((0, 2))
        self._contact_art.set_offsets(points)
        self._contact_art.set_facecolors([MODE_COLORS[MODE_NAMES[m]] for m in self.modes[i]])
        for ci, arrow in enumerate(self._arrow_art):
            closed = self.modes[i, ci] != 0
            vec = P(self._world_forces[i, ci]) * self.force_scale
            show = closed and np.linalg.norm(vec) > 1e-3 * self.scene_size
            arrow.set_visible(bool(show))
            if show:
                arrow.set_positions(tuple(points[ci]), tuple(points[ci] + vec))
        flash = [self._impact_point(e, ci) for e, ev in enumerate(self.result.impacts)
                 if 0.0 <= t - ev.time < self._flash_window
                 for ci, name in enumerate(self.contact_names) if name in ev.contacts]
        fl = P(np.array(flash)) if flash else np.zeros((0, 2))
        self._flash_art.set_data(fl[:, 0], fl[:, 1])
        if self.dim == 3 and self._body_art:
            depth = [float(np.mean(pts[i] @ P.camera)) for pts in f.bodies]
            for rank, bi in enumerate(np.argsort(depth)):
                self._body_art[bi].set_zorder(2.0 + 0.4 * rank / len(self._body_art))
        self._time_art.set_text(f"t = {t:.{self._time_decimals}f} s")
        status = "impact" if flash else ""
        for ev in self.result.painleve:
            if t >= ev.time:
                status = f"Painleve ({ev.kind}) at t = {ev.time:.4g} s"
        self._status_art.set_text(status)

    def _impact_point(self, event: int, contact: int) -> np.ndarray:
        """World contact point of ``contact`` at impact ``event`` (where the flash is drawn)."""
        key = (event, contact)
        if key not in self._impact_points:
            theta = self.result.impacts[event].theta
            self._impact_points[key] = self.mechanism.contact_frame(
                self.contact_names[contact], theta).point
        return self._impact_points[key]

    def pixel(self, points: np.ndarray) -> np.ndarray:
        """Pixel (column, row) in a frame image of world points (..., d); row 0 at the top."""
        xy = self.ax.transData.transform(self.projection(np.atleast_2d(points)))
        height = self.fig.get_size_inches()[1] * self.fig.dpi
        return np.column_stack([xy[:, 0], height - xy[:, 1]])

    def _moving_artists(self) -> list:
        """The artists :meth:`draw` updates (redrawn on a cached background by :meth:`save`)."""
        arts = [self._rail_art, self._plane_art, *self._sphere_art, *self._body_art,
                *self._disc_art, self._spin_art, self._pin_art, self._loop_art,
                self._flash_art, *self._arrow_art, self._contact_art, self._time_art,
                self._status_art]
        return sorted(arts, key=lambda a: a.get_zorder())

    def save(self, path: Union[str, Path]) -> Path:
        """Write every frame to the animated GIF ``path``.

        The static part of the picture (axes, ticks, ground, legend) is rendered once; each
        frame redraws only the moving artists over it.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        canvas = self.fig.canvas
        moving = self._moving_artists()
        writer = _canvas_pillow_writer(self.fps)
        try:
            for art in moving:
                art.set_animated(True)
            canvas.draw()
            background = canvas.copy_from_bbox(self.fig.bbox)
            with writer.saving(self.fig, str(path), self.dpi):
                for i in range(len(self.times)):
                    self.draw(i)
                    canvas.restore_region(background)
                    if self.dim == 3:
                        moving.sort(key=lambda a: a.get_zorder())
                    for art in moving:
                        if art.get_visible():
                            self.ax.draw_artist(art)
                    writer.grab_frame()
        finally:
            for art in moving:
                art.set_animated(False)
        return path

    def close(self) -> None:
        """Release the figure."""
        self.fig.clear()


def animate(result: SimulationResult, mechanism: Any, path: Union[str, Path], fps: float = 25,
            duration: float | None = None, size: tuple[float, float] = (6, 4.5),
            dpi: float = 80, view: View = None, *, title: str | None = None,
            max_frames: int = MAX_FRAMES) -> Path:
    """Write an animated GIF of a simulated mechanism, contacts coloured by their mode.

    Frames are taken at uniform times over ``[t[0], t[-1]]`` of the result; by default the
    GIF plays in real time (``duration`` = the simulated span) at ``fps`` frames per second,
    but never with more than ``max_frames`` frames (default 300): a longer run is shown at a
    lower frame rate over the same playback time. The state of each frame comes from the
    dense output ``result.sol`` when available, otherwise from the samples interpolated
    linearly (the post-impact sample at an impact instant).

    What is drawn, from the model alone (:attr:`ModelMechanism.model`):

    * each body as the convex hull of its joint origin, centre of mass, child joint origins,
      loop-joint frames and contact points (a thick segment when they are collinear), with
      pins at revolute joints, dashed rails along prismatic joints and squares at loop joints;
    * contact spheres (radius > 0) as discs with a radius line showing the body's rotation;
    * planes against the ground: planar models a ground line through the plane point,
      normal to the plane's normal, shaded on the solid side; spatial models a gridded floor
      patch under the motion; planes and spheres on moving bodies move with them;
    * each contact point (the point of body i nearest the other surface) as a dot coloured
      by its mode at the frame time (open grey, stick green, slip red), and while closed an
      arrow of its force on body i (normal + tangential, the largest force of the run drawn
      0.2 scene sizes long); impact contacts flash with an amber star on the two frames at or
      after the impact; a Painleve stop is announced at the top right.

    Planar models are drawn in their x-y plane; spatial models in an orthographic view with
    the vertical up the picture, by default oblique (azimuth 30, elevation 20 degrees), see
    :class:`ViewProjection`. Axis limits are fixed over the whole motion, with equal scales.

    Parameters
    ----------
    result : the simulation (``dense_output=True`` gives smooth frames).
    mechanism : the simulated mechanism, built with ModelBuilder (``model.mechanism()``).
    path : the GIF file to write (parent directories are created).
    fps : playback frames per second.
    duration : playback duration in seconds (default: the simulated span, real time).
    size : figure size in inches; each frame is ``size * dpi`` pixels.
    dpi : dots per inch.
    view : spatial models: (azimuth, elevation) in degrees or "oblique", "front", "side",
        "top"; planar models: None.
    title : a line of text above the picture.
    max_frames : cap on the number of frames.

    Returns
    -------
    Path of the written GIF.

    Raises
    ------
    NotSupportedError
        When the mechanism was not built with ModelBuilder (a user-defined Mechanism object
        has no geometry to draw).
    ParameterError
        Bad ``fps``, ``duration``, ``max_frames`` or ``view``.
    """
    anim = MechanismAnimation(result, mechanism, fps=fps, duration=duration, size=size, dpi=dpi,
                              view=view, title=title, max_frames=max_frames)
    try:
        return anim.save(path)
    finally:
        anim.close()


# ----------------------------------------------------------------------------------------
# contact timeline figure
# ----------------------------------------------------------------------------------------
def _mode_runs(result: SimulationResult, contact: str,
               column: int | None) -> list[tuple[str, float, float]]:
    """(mode, t_start, t_end) runs of one contact over the run."""
    t0, t1 = float(result.t[0]), float(result.t[-1])
    ivs = result.modes_of(contact)
    if ivs:
        return [(iv.mode, float(iv.t_start), float(iv.t_end)) for iv in ivs]
    cm = result.contact_mode
    if column is None or cm.ndim != 2 or cm.shape[0] != len(result.t) or cm.shape[0] == 0:
        return [("open", t0, t1)]
    codes = cm[:, column]
    runs = []
    start = 0
    for j in range(1, len(codes) + 1):
        if j == len(codes) or codes[j] != codes[start]:
            end_t = float(result.t[j]) if j < len(codes) else t1
            runs.append((MODE_NAMES[int(codes[start])], float(result.t[start]), end_t))
            start = j
    return runs


def plot_contacts(result: SimulationResult, path: Union[str, Path], mechanism: Any = None,
                  title: str | None = None) -> Path | None:
    """Per contact: the mode timeline and, under it, the contact force series.

    For each contact a band shows its modes over time (open grey, stick green, slip red)
    and a plot under it the normal force lambda_n, the tangential force magnitude
    |lambda_t| and the friction bound mu lambda_n (dashed; needs ``mechanism`` for mu).
    Impacts are vertical lines (dark for the contact's own impacts, light for the others),
    a Painleve stop a magenta dotted line.

    Parameters
    ----------
    result : the simulation.
    path : the PNG file to write.
    mechanism : optional, the simulated mechanism: supplies mu (``contact_parameters``) and
        the contact names when the result did not record them.
    title : figure title.

    Returns
    -------
    Path of the written PNG, or None when there are no contacts (nothing is written).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    names = list(result.contact_names) or list(getattr(mechanism, "contact_names", None) or [])
    if not names or len(result.t) == 0:
        return None
    cols = _contact_columns(result, names)
    n = len(names)
    per = 2.4 if n <= 4 else 1.9
    fig = Figure(figsize=(9.0, 1.0 + per * n), dpi=100)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2 * n, 1, sharex=True,
                        gridspec_kw={"height_ratios": [0.45, 2.0] * n, "hspace": 0.12})
    t = result.t
    f = result.contact_force
    have_forces = f.ndim == 3 and f.shape[0] == len(t) and f.shape[0] > 0
    t_pl = [ev.time for ev in result.painleve]
    for c, (name, col) in enumerate(zip(names, cols)):
        ax_mode, ax_force = axes[2 * c], axes[2 * c + 1]
        for mode in MODE_NAMES:
            bars = [(a, b - a) for m, a, b in _mode_runs(result, name, col) if m == mode]
            if bars:
                ax_mode.broken_barh(bars, (0.0, 1.0), facecolors=MODE_COLORS[mode],
                                    edgecolor="none")
        ax_mode.set_ylim(0, 1)
        ax_mode.set_yticks([])
        mu = None
        if mechanism is not None and hasattr(mechanism, "contact_parameters"):
            try:
                mu = float(mechanism.contact_parameters(name)[1])
            except Exception:  # noqa: BLE001 - a user mechanism without parameters
                mu = None
        label = name if mu is None else f"{name}\n(mu = {mu:g})"
        ax_mode.set_ylabel(label, rotation=0, ha="right", va="center", fontsize="small")
        if have_forces and col is not None and col < f.shape[1]:
            lam_n = f[:, col, 0]
            lam_t = np.linalg.norm(f[:, col, 1:], axis=1)
            ax_force.plot(t, lam_n, color="C0", lw=1.2)
            ax_force.plot(t, lam_t, color="C4", lw=1.2)
            if mu is not None and mu > 0:
                ax_force.plot(t, mu * lam_n, color="C4", lw=1.0, ls="--", alpha=0.7)
        else:
            ax_force.text(0.5, 0.5, "no contact forces recorded", transform=ax_force.transAxes,
                          ha="center", va="center", color="0.4", fontsize="small")
        ax_force.set_ylabel("force [N]", fontsize="small")
        ax_force.tick_params(labelsize="x-small")
        for ax in (ax_mode, ax_force):
            for ev in result.impacts:
                own = name in ev.contacts
                ax.axvline(ev.time, color="0.25" if own else "0.8", lw=0.9 if own else 0.5,
                           ls="-" if own else ":", zorder=3 if ax is ax_mode else 0)
            for tp in t_pl:
                ax.axvline(tp, color="m", lw=1.2, ls=":", zorder=4)
    axes[-1].set_xlabel("t [s]")
    axes[-1].set_xlim(float(t[0]), float(t[-1]) if t[-1] > t[0] else float(t[0]) + 1.0)
    handles = [Patch(facecolor=MODE_COLORS[m], label=m) for m in MODE_NAMES]
    handles += [Line2D([], [], color="C0", lw=1.2, label=r"$\lambda_n$"),
                Line2D([], [], color="C4", lw=1.2, label=r"$|\lambda_t|$"),
                Line2D([], [], color="C4", lw=1.0, ls="--", alpha=0.7, label=r"$\mu\lambda_n$"),
                Line2D([], [], color="0.25", lw=0.9, label="impact")]
    if t_pl:
        handles.append(Line2D([], [], color="m", lw=1.2, ls=":", label="Painleve"))
    fig.legend(handles=handles, loc="upper right", ncol=len(handles), frameon=False,
               fontsize="small", bbox_to_anchor=(0.98, 1.0))
    fig.suptitle(title or "contact modes and forces", x=0.02, ha="left", fontsize="medium")
    fig.subplots_adjust(left=0.12, right=0.98, top=1.0 - 0.55 / fig.get_size_inches()[1],
                        bottom=0.45 / fig.get_size_inches()[1] + 0.02)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    fig.clear()
    return path
