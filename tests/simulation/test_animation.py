"""Animation (GIF of the mechanism, contacts coloured by mode) and the contact-mode figure."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from PIL import Image

from convimpact import cli
from convimpact.errors import NotSupportedError, ParameterError, ShapeError
from convimpact.model import Joint, ModelBuilder
from convimpact.scenes import Scene, load_scene
from convimpact.simulation import simulate
from convimpact.simulation.animation import (
    MODE_COLORS, MechanismAnimation, animate, convex_hull, frame_times, interpolate_samples,
    modes_at, plot_contacts, states_at)
from convimpact.simulation.result import MODE_NAMES, ModeInterval, SimulationResult
from convimpact.simulation.testing import PointMass


def hand_result(t, theta, **fields) -> SimulationResult:
    """A SimulationResult with the given samples and empty bookkeeping."""
    t = np.asarray(t, float)
    theta = np.asarray(theta, float)
    n = len(t)
    z = np.zeros(n)
    base = dict(t=t, theta=theta, dtheta=np.zeros_like(theta), p=np.zeros_like(theta),
                sigma=np.zeros((n, 0)), kinetic_energy=z, potential_energy=z, loop_residual=z,
                loop_velocity_residual=z, held=np.zeros(n, int), impacts=(), contact_events=(),
                sol=None, status=0, message="", nfev=0, nevents_fev=0, n_steps=n,
                n_projections=0, n_restarts=0, wall_time=0.0, impact_time=0.0)
    base.update(fields)
    return SimulationResult(**base)


def rgb(hex_color: str) -> np.ndarray:
    return np.array([int(hex_color[i:i + 2], 16) for i in (1, 3, 5)])


def gif_frames(path) -> list[np.ndarray]:
    im = Image.open(path)
    out = []
    for i in range(im.n_frames):
        im.seek(i)
        out.append(np.asarray(im.convert("RGB")).astype(int))
    return out


def inside_axes(anim: MechanismAnimation, frame: np.ndarray) -> np.ndarray:
    """The pixels of a frame inside the drawing axes (the legend is outside)."""
    height = frame.shape[0]
    x0, y0, x1, y1 = anim.ax.get_window_extent().extents
    return frame[int(height - y1) + 2:int(height - y0) - 2, int(x0) + 2:int(x1) - 2]


# modes of the hand-made ball run: open until 0.35 s, stick until 0.65 s, slip to 1 s
SWITCHES = (0.35, 0.65)


@pytest.fixture(scope="module")
def ball():
    """The bouncing-ball model with a hand-made fall to the floor and a known mode pattern."""
    scene = load_scene("bouncing_ball", mu=0.3)
    t = np.linspace(0.0, 1.0, 21)
    y = np.maximum(1.0 - 1.8 * t, 0.1)  # reaches the floor (centre at the radius) at 0.5 s
    theta = np.column_stack([0.3 * t, y])
    codes = np.searchsorted(SWITCHES, t, side="right")  # 0 open, 1 stick, 2 slip
    force = np.zeros((len(t), 1, 2))
    force[:, 0, 0] = np.where(codes > 0, 9.81, 0.0)
    force[:, 0, 1] = np.where(codes == 2, -2.0, 0.0)
    intervals = (ModeInterval("floor", "open", 0.0, SWITCHES[0]),
                 ModeInterval("floor", "stick", SWITCHES[0], SWITCHES[1]),
                 ModeInterval("floor", "slip", SWITCHES[1], 1.0))
    res = hand_result(t, theta, contact_names=("floor",), contact_mode=codes[:, None],
                      contact_force=force, mode_intervals=intervals)
    return scene, res


def test_frame_times_real_time_and_cap():
    times, fps = frame_times(0.0, 3.0, fps=25)
    assert len(times) == 76 and fps == pytest.approx(25.0)
    assert times[0] == 0.0 and times[-1] == 3.0
    times, fps = frame_times(0.0, 100.0, fps=25)  # 2501 frames wanted: capped
    assert len(times) == 300 and fps == pytest.approx(299 / 100.0)
    times, fps = frame_times(0.0, 1.0, fps=10, duration=2.0)  # slow motion
    assert len(times) == 21 and fps == pytest.approx(10.0)
    with pytest.raises(ParameterError):
        frame_times(0.0, 1.0, fps=0)


def test_interpolation_takes_the_post_impact_sample():
    t = np.array([0.0, 1.0, 1.0, 2.0])  # an impact at t = 1: pre and post samples
    v = np.array([[0.0], [1.0], [5.0], [6.0]])
    got = interpolate_samples(t, v, np.array([0.5, 1.0, 1.5, 3.0, -1.0]))[:, 0]
    np.testing.assert_allclose(got, [0.5, 5.0, 5.5, 6.0, 0.0])


def test_modes_from_intervals_or_samples(ball):
    _, res = ball
    times = np.array([0.0, 0.3, 0.4, 0.6, 0.7, 1.0])
    expected = [0, 0, 1, 1, 2, 2]
    assert modes_at(res, ["floor"], times)[:, 0].tolist() == expected
    sampled = dataclasses.replace(res, mode_intervals=())  # falls back on contact_mode
    assert modes_at(sampled, ["floor"], times)[:, 0].tolist() == expected
    bare = dataclasses.replace(res, mode_intervals=(), contact_names=())
    assert modes_at(bare, ["floor"], times)[:, 0].tolist() == [0] * 6  # nothing recorded


def test_gif_frames_size_and_mode_colours(ball, tmp_path):
    scene, res = ball
    anim = MechanismAnimation(res, scene.mechanism, fps=10)
    path = anim.save(tmp_path / "ball.gif")
    frames = gif_frames(path)
    assert len(frames) == len(anim.times) == 11
    assert Image.open(path).size == (480, 360) and frames[0].shape == (360, 480, 3)
    expected = [MODE_NAMES[int(np.searchsorted(SWITCHES, t, side="right"))] for t in anim.times]
    assert expected.count("stick") == 3 and expected.count("slip") == 4
    # the contact marker, at the ball's lowest point, is drawn in the mode's colour
    for i, frame in enumerate(frames):
        col, row = np.round(anim.pixel(anim.frames.contact_points[i, 0])[0]).astype(int)
        np.testing.assert_allclose(frame[row, col], rgb(MODE_COLORS[expected[i]]), atol=30,
                                   err_msg=f"frame {i} (t = {anim.times[i]:.2f} s)")
    # inside the axes, green shows exactly in the stick frames, red in the slip frames
    for i, frame in enumerate(frames):
        r, g, b = np.moveaxis(inside_axes(anim, frame), -1, 0)
        green = np.count_nonzero((g > 120) & (r < 90) & (b < 90))
        red = np.count_nonzero((r > 180) & (g < 70) & (b < 70))
        assert (green > 5) == (expected[i] == "stick"), (i, green)
        assert (red > 5) == (expected[i] == "slip"), (i, red)


def test_impact_flashes_after_the_impact(tmp_path):
    scene = load_scene("bouncing_ball", mu=0.3, speed=1.0)
    res = simulate(scene, (0.0, 0.6), dense_output=True)
    t_imp = res.impacts[0].time
    anim = MechanismAnimation(res, scene.mechanism, fps=20, size=(4, 3), dpi=60)
    frames = gif_frames(anim.save(tmp_path / "impact.gif"))
    assert len(frames) == len(anim.times) == 13

    def amber(frame):
        r, g, b = np.moveaxis(inside_axes(anim, frame), -1, 0)
        return np.count_nonzero((r > 230) & (g > 150) & (g < 200) & (b < 60))

    flashing = [i for i, t in enumerate(anim.times) if 0 <= t - t_imp < 2 * (1 / 20)]
    assert flashing and all(amber(frames[i]) > 20 for i in flashing)
    assert all(amber(frames[i]) == 0 for i, t in enumerate(anim.times) if t < t_imp)
    # frames come from the dense output; without it, from the samples
    np.testing.assert_allclose(anim.theta, states_at(res, anim.times))
    sampled = dataclasses.replace(res, sol=None)
    np.testing.assert_allclose(states_at(sampled, res.t[-1:]), res.theta[-1:])


def test_spatial_model_and_loop_joints(tmp_path):
    pend = load_scene("pendulum_3d")
    t = np.linspace(0.0, 0.3, 4)
    theta = pend.theta0 + np.outer(t, [1.0, 0.5, -0.5])
    p = animate(hand_result(t, theta), pend.mechanism, tmp_path / "p3d.gif", fps=10,
                size=(3, 2), dpi=50, view="top")
    im = Image.open(p)
    assert im.n_frames == 4 and im.size == (150, 100)
    crank = load_scene("slider_crank")
    res = hand_result(t, np.tile(crank.theta0, (4, 1)))
    anim = MechanismAnimation(res, crank.mechanism, fps=10)
    assert anim.frames.loop_pins.shape == (4, 2, 2)  # both frames of the cut pin
    np.testing.assert_allclose(anim.frames.loop_pins[:, 0], anim.frames.loop_pins[:, 1],
                               atol=1e-9)  # assembled
    with pytest.raises(ParameterError):
        MechanismAnimation(res, crank.mechanism, view="top")  # planar: its own plane


def test_animation_needs_a_built_model(tmp_path):
    res = hand_result([0.0, 1.0], [[0.0, 1.0], [0.0, 0.5]])
    with pytest.raises(NotSupportedError, match="ModelBuilder"):
        animate(res, PointMass(), tmp_path / "x.gif")
    assert not (tmp_path / "x.gif").exists()


def test_plot_contacts(ball, tmp_path):
    scene, res = ball
    path = plot_contacts(res, tmp_path / "contacts.png", mechanism=scene.mechanism)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    png = np.asarray(Image.open(path).convert("RGB")).astype(int)
    for mode in MODE_NAMES:  # every mode's band is drawn
        assert np.any(np.all(np.abs(png - rgb(MODE_COLORS[mode])) < 8, axis=-1)), mode
    bare = dataclasses.replace(res, contact_names=(), contact_mode=np.zeros((21, 0), int),
                               contact_force=np.zeros((21, 0, 2)), mode_intervals=())
    assert plot_contacts(bare, tmp_path / "none.png") is None
    assert not (tmp_path / "none.png").exists()


def test_cli_animate(tmp_path, capsys):
    out = tmp_path / "ball"
    assert cli.main(["simulate", "bouncing_ball", "--out", str(out), "--t-end", "0.3",
                     "--animate"]) == 0
    text = capsys.readouterr().out
    assert f"wrote {out / 'animation.gif'}" in text and f"wrote {out / 'contacts.png'}" in text
    im = Image.open(out / "animation.gif")
    assert im.n_frames == len(frame_times(0.0, 0.3)[0]) == 8 and im.size == (480, 360)
    assert (out / "contacts.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_animate_user_mechanism_is_a_clean_error(monkeypatch, tmp_path, capsys):
    import convimpact.simulation.cli as simcli

    def make(name, **params):
        return Scene(name="drop", description="particle", mechanism=PointMass(),
                     theta0=np.array([0.0, 1.0]), dtheta0=np.zeros(2), t_end=0.2)

    monkeypatch.setattr(simcli, "load_scene", make)
    assert cli.main(["simulate", "drop", "--out", str(tmp_path), "--animate"]) == 2
    assert "ModelBuilder" in capsys.readouterr().err
    assert not (tmp_path / "animation.gif").exists()


# a planar box (width W, height H) whose only contacts are its two bottom corners
W, H = 0.4, 0.2
BOX_CORNERS = np.array([[-W / 2, -H / 2], [W / 2, -H / 2], [W / 2, H / 2], [-W / 2, H / 2]])


def box_scene(outlines=True, y0=H / 2 + 0.02) -> Scene:
    b = ModelBuilder(planar=True)
    b.add_body("box", "ground", Joint.free(), 1.0, (0.0, 0.0), (W ** 2 + H ** 2) / 12,
               coordinate_names=["x", "y", "phi"])
    for name, corner in (("left", BOX_CORNERS[0]), ("right", BOX_CORNERS[1])):
        b.add_contact(name, body="box", point=corner, normal=(0.0, 1.0),
                      plane_point=(0.0, 0.0), e=0.0, mu=0.5)
    return Scene(name="box", description="a box on its bottom corners",
                 mechanism=b.build().mechanism(), theta0=np.array([0.0, y0, 0.0]),
                 dtheta0=np.zeros(3), t_end=0.1,
                 outlines={"box": BOX_CORNERS} if outlines else None)


def world(pose, local):
    x, y, phi = pose
    R = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
    return np.array([x, y]) + np.asarray(local) @ R.T


def test_box_outline_is_drawn_as_its_rectangle(tmp_path):
    scene = box_scene()
    poses = np.array([[0.0, 0.3, 0.2], [0.2, 0.4, -0.5]])
    res = hand_result([0.0, 1.0], poses)
    anim = MechanismAnimation(res, scene.mechanism, fps=1, outlines=scene.outlines)
    hulled = MechanismAnimation(res, scene.mechanism, fps=1)  # no outline: the hull
    assert len(anim.times) == 2 and anim.body_names == ("box",)
    inside = np.array([[-0.4 * W, 0.4 * H], [0.4 * W, 0.4 * H]])  # near the top corners
    for i, pose in enumerate(poses):
        anim.draw(i)
        xy = anim.body_polygons["box"].get_xy()
        assert len(xy) == 5  # the four corners, closed
        np.testing.assert_allclose(xy[:4], world(pose, BOX_CORNERS), atol=1e-12)
        hulled.draw(i)
        tri = hulled.body_polygons["box"].get_xy()  # origin and the two bottom corners
        assert len(tri) == 4
        np.testing.assert_allclose(np.sort(tri[:3], axis=0),
                                   np.sort(world(pose, [[0, 0], *BOX_CORNERS[:2]]), axis=0),
                                   atol=1e-12)
        # the top of the box is painted with its outline, background without
        for a, colour_expected in ((anim, True), (hulled, False)):
            a.fig.canvas.draw()
            img = np.asarray(a.fig.canvas.buffer_rgba())[..., :3].astype(int)
            for col, row in np.round(a.pixel(world(pose, inside))).astype(int):
                painted = np.any(np.abs(img[row, col] - 255) > 25)
                assert painted == colour_expected, (i, a is anim, img[row, col])
    frames = gif_frames(anim.save(tmp_path / "box.gif"))
    assert len(frames) == 2
    anim.close()
    hulled.close()


def test_outlines_are_checked():
    scene = box_scene()
    res = hand_result([0.0, 1.0], np.tile(scene.theta0, (2, 1)))
    with pytest.raises(ParameterError, match="unknown body 'lid'"):
        MechanismAnimation(res, scene.mechanism, outlines={"lid": BOX_CORNERS})
    with pytest.raises(ShapeError, match="outline of 'box'"):
        MechanismAnimation(res, scene.mechanism, outlines={"box": np.zeros((4, 3))})


def test_spatial_outline_is_the_hull_of_its_projection():
    pend = load_scene("pendulum_3d")
    body = pend.mechanism.model.bodies[1]
    cube = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1)])
    res = hand_result([0.0, 1.0], np.tile(pend.theta0, (2, 1)))
    anim = MechanismAnimation(res, pend.mechanism, fps=1, view="front",
                              outlines={body.name: cube})
    anim.draw(0)
    R, o = pend.mechanism.body_placement(body.name, pend.theta0)
    corners = anim.projection(o + cube @ R.T)
    xy = anim.body_polygons[body.name].get_xy()[:-1]
    hull = convex_hull(corners)
    assert len(xy) == len(hull) >= 4  # the outline of the projected cube, not the rod
    np.testing.assert_allclose(np.sort(xy, axis=0), np.sort(hull, axis=0), atol=1e-12)
    anim.close()


def test_cli_animate_passes_the_scene_outlines(monkeypatch, tmp_path, capsys):
    import convimpact.simulation.cli as simcli

    seen = {}
    real = simcli.animate

    def spy(*args, **kwargs):
        seen.update(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(simcli, "load_scene", lambda name, **params: box_scene())
    monkeypatch.setattr(simcli, "animate", spy)
    assert cli.main(["simulate", "box", "--out", str(tmp_path), "--t-end", "0.04",
                     "--animate"]) == 0
    assert seen["outlines"]["box"] is BOX_CORNERS
    assert Image.open(tmp_path / "animation.gif").n_frames == 2
    bad = dataclasses.replace(box_scene(), outlines={"lid": BOX_CORNERS})
    monkeypatch.setattr(simcli, "load_scene", lambda name, **params: bad)
    assert cli.main(["simulate", "box", "--out", str(tmp_path / "bad"), "--animate"]) == 2
    assert "unknown body 'lid'" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()  # refused before simulating
