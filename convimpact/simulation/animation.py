"""Pictures of a simulation: an animated GIF of the mechanism (and the contact-mode figure).

:func:`animate` draws a mechanism built with :class:`~convimpact.model.ModelBuilder` at
uniformly spaced times of a :class:`~convimpact.simulation.result.SimulationResult` and
writes the frames as an animated GIF (matplotlib's ``PillowWriter``: no ffmpeg needed, works
headless); its docstring lists what is drawn: bodies from the model (or given outlines),
contacts coloured by their mode with their forces, impacts flashing.

The pieces live in :mod:`~convimpact.simulation.animation_frames` (frame times, sampling the
result, projection), :mod:`~convimpact.simulation.animation_geometry` (world geometry of the
frames) and :mod:`~convimpact.simulation.contact_plots` (:func:`plot_contacts`, the mode
timeline and forces per contact); their public names are importable from here too.

Both pictures are used by ``convimpact simulate`` (``contacts.png`` always,
``animation.gif`` with ``--animate``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Union

import numpy as np

from ..errors import ShapeError
from .animation_frames import (
    DEFAULT_SPATIAL_VIEW, MAX_FRAMES, MODE_COLORS, NAMED_VIEWS, View, ViewProjection,
    convex_hull, forces_at, frame_times, interpolate_samples, modes_at, states_at)
from .animation_geometry import (
    FrameGeometry, check_animatable, check_outlines, collect_geometry, ground_planes)
from .contact_plots import plot_contacts
from .result import MODE_NAMES, SimulationResult

__all__ = [
    "BODY_COLORS", "DEFAULT_SPATIAL_VIEW", "FORCE_COLOR", "IMPACT_COLOR", "MAX_FRAMES",
    "MODE_COLORS", "NAMED_VIEWS", "FrameGeometry", "MechanismAnimation", "View",
    "ViewProjection", "animate", "check_animatable", "check_outlines", "collect_geometry",
    "convex_hull", "forces_at", "frame_times", "ground_planes", "interpolate_samples",
    "modes_at", "plot_contacts", "states_at"]

#: colour of the flash marking an impact
IMPACT_COLOR = "#ffb000"
#: colour of the contact force arrows
FORCE_COLOR = "#17306b"
#: body colours (no green or red, which mark the contact modes)
BODY_COLORS = ("#1f77b4", "#9467bd", "#8c564b", "#17becf", "#e7ba52", "#393b79", "#7f7f7f")


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


class MechanismAnimation:
    """The figure and artists of an animation of a simulated mechanism.

    :func:`animate` is the usual entry point; this class is for drawing single frames
    (``draw(i)`` then ``fig.savefig``), writing the GIF (``save``) and locating things in
    the picture (``pixel``).

    Parameters
    ----------
    Those of :func:`animate` but ``path``.

    Attributes
    ----------
    times : (n,) frame times; fps : playback frame rate; theta : (n, k) frame states;
    modes : (n, n_contacts) mode codes; forces : (n, n_contacts, d) contact-frame forces;
    fig, ax : the matplotlib figure and axes; projection : the :class:`ViewProjection`;
    frames : the :class:`FrameGeometry`; body_names : the moving bodies, in model order;
    body_polygons : per body name, the matplotlib ``Polygon`` drawing it.
    """

    def __init__(self, result: SimulationResult, mechanism: Any, fps: float = 25.0,
                 duration: float | None = None, size: tuple[float, float] = (6.0, 4.5),
                 dpi: float = 80, view: View = None, title: str | None = None,
                 max_frames: int = MAX_FRAMES,
                 outlines: Mapping[str, np.ndarray] | None = None):
        self.model = check_animatable(mechanism)
        self._outlines = check_outlines(self.model, outlines)
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
        self.body_names = tuple(b.name for b in self.model.bodies[1:])
        self.theta = states_at(result, self.times)
        self.modes = modes_at(result, self.contact_names, self.times)
        self.forces = forces_at(result, self.contact_names, self.times, self.dim)
        self._impact_points: dict = {}
        # world geometry at every frame
        self.frames = collect_geometry(self.model, self.mechanism, self.theta, self.result.theta,
                                       self._outlines)
        self._build_figure()

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
        parts += [f.pins.reshape(-1, self.dim), f.loop_pins.reshape(-1, self.dim)]
        parts.append(f.contact_points.reshape(-1, self.dim))
        moving = P(np.vstack(parts))
        lo, hi = moving.min(axis=0), moving.max(axis=0)
        for di, c in enumerate(f.disc_contacts):
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
        planes = ground_planes(self.model, f)
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
            # a hull is often a segment or a sliver: a thick edge keeps it visible; an
            # outline with an area is drawn with a thin edge so that its corners stay sharp
            thin = f.outlined[bi] and len(self._outlines[b.index]) > 2
            poly = Polygon(np.zeros((1, 2)), closed=True, facecolor=(color, 0.35),
                           edgecolor=(color, 0.9), lw=1.5 if thin else 3.5,
                           joinstyle="miter" if thin else "round", capstyle="round", zorder=2)
            ax.add_patch(poly)
            self._body_art.append(poly)
        self.body_polygons = dict(zip(self.body_names, self._body_art))
        self._disc_art = []
        for c in f.disc_contacts:
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
        for c in f.sphere_contacts:
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
            pts = P(f.bodies[bi][i])
            if not (f.outlined[bi] and self.dim == 2):  # planar outlines: the polygon in order
                pts = convex_hull(pts)
            poly.set_xy(pts if len(pts) > 1 else np.vstack([pts, pts]))
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
        pins = P(f.pins[i]) if len(f.pin_bodies) else np.zeros((0, 2))
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
            max_frames: int = MAX_FRAMES,
            outlines: Mapping[str, np.ndarray] | None = None) -> Path:
    """Write an animated GIF of a simulated mechanism, contacts coloured by their mode.

    Frames are taken at uniform times over ``[t[0], t[-1]]`` of the result; by default the
    GIF plays in real time (``duration`` = the simulated span) at ``fps`` frames per second,
    but never with more than ``max_frames`` frames (default 300): a longer run is shown at a
    lower frame rate over the same playback time. The state of each frame comes from the
    dense output ``result.sol`` when available, otherwise from the samples interpolated
    linearly (the post-impact sample at an impact instant).

    What is drawn, from the model (:attr:`ModelMechanism.model`) and the optional outlines:

    * each body as the convex hull of its joint origin, centre of mass, child joint origins,
      loop-joint frames and contact points (a thick segment when they are collinear), or,
      when ``outlines`` has the body, from its outline: planar models the polygon through
      the outline points in their order, spatial models the convex hull of the projected
      outline points; with pins at revolute joints, dashed rails along prismatic joints and
      squares at loop joints;
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
    outlines : optional, per body name an (n, d) array (n >= 2, d = 2 planar, 3 spatial) of
        body-frame points outlining the body, e.g. :attr:`convimpact.scenes.Scene.outlines`;
        bodies not in it are drawn as their hull. Drawing only.

    Returns
    -------
    Path of the written GIF.

    Raises
    ------
    NotSupportedError
        When the mechanism was not built with ModelBuilder (a user-defined Mechanism object
        has no geometry to draw).
    ParameterError
        Bad ``fps``, ``duration``, ``max_frames`` or ``view``; an outline of a body the
        model does not have.
    ShapeError
        An outline that is not an (n, d) array, or a result of another mechanism.
    """
    anim = MechanismAnimation(result, mechanism, fps=fps, duration=duration, size=size, dpi=dpi,
                              view=view, title=title, max_frames=max_frames, outlines=outlines)
    try:
        return anim.save(path)
    finally:
        anim.close()
