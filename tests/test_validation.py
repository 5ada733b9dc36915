"""Issue 29: every edge case it lists answers with a typed error naming the argument the user
passed (or correctly, where the input is valid), one test each; and the checkers of
:mod:`convimpact.validation` themselves."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from .cli_run import run_cli

from convimpact import resolve_impact
from convimpact.cli import main
from convimpact.impact.batch import contact_impulses, resolve_impacts
from convimpact.errors import (
    ConvImpactError,
    DegenerateContactError,
    NonFiniteError,
    ParameterError,
    ShapeError,
    SingularSystemError,
    UnknownOptionError,
)
from convimpact.scenes import list_scenes, load_scene, scene_parameters
from convimpact import validation as V

# --------------------------------------------------------------------------------------------
# the checkers


@pytest.mark.parametrize("value", [True, "1.0", 1j, None, [1.0], np.array([1.0, 2.0])])
def test_real_refuses_what_is_not_a_real_number(value):
    with pytest.raises(ParameterError, match="x"):
        V.real("x", value)


@pytest.mark.parametrize("value,error", [(np.nan, NonFiniteError), (np.inf, NonFiniteError),
                                         (0.0, ParameterError), (-1, ParameterError)])
def test_positive(value, error):
    with pytest.raises(error, match="rtol"):
        V.positive("rtol", value)


def test_accepted_numbers_convert_exactly():
    assert V.positive("x", np.float32(0.5)) == 0.5
    assert V.positive("x", np.array(2)) == 2.0
    assert V.positive("x", np.inf, allow_inf=True) == np.inf
    assert V.integer("n", np.int64(7)) == 7
    assert V.integer("n", 1e4) == 10_000
    assert V.in_range("e", 1, 0.0, 1.0) == 1.0


@pytest.mark.parametrize("value", [2.5, "10", True, None, np.nan])
def test_integer_refuses(value):
    with pytest.raises(ParameterError, match="n_grid"):
        V.integer("n_grid", value, minimum=8)


def test_time_span_and_times():
    assert V.time_span("t_span", np.array([0, 1])) == (0.0, 1.0)
    for bad, error in [((1, 0), ParameterError), ((0, np.nan), NonFiniteError),
                       ("01", ShapeError), ((0, 1, 2), ShapeError), (3.0, ShapeError)]:
        with pytest.raises(error, match="t_span"):
            V.time_span("t_span", bad)
    np.testing.assert_array_equal(V.sorted_times("t_eval", [0.1, 0.2], 0, 1), [0.1, 0.2])
    with pytest.raises(ParameterError, match="t_eval"):
        V.sorted_times("t_eval", [0.2, 0.1], 0, 1)


def test_check_parameters_names_the_owner_the_parameter_and_the_range():
    specs = {"e": V.Unit(), "case": V.Choice(("a", "b")), "on": V.Flag(),
             "tilt": V.Vector(3), "axis": V.OrNone(V.Real())}
    assert V.check_parameters("scene 's'", specs, {"e": 1, "axis": None, "on": np.True_}) \
        == {"e": 1.0, "axis": None, "on": True}
    with pytest.raises(ParameterError, match=r"scene 's': e must be in \[0, 1\], got 2.0"):
        V.check_parameters("scene 's'", specs, {"e": 2})
    with pytest.raises(UnknownOptionError, match="'x'.*e, case, on, tilt, axis"):
        V.check_parameters("scene 's'", specs, {"x": 1})
    with pytest.raises(ShapeError, match="tilt must have 3 entries"):
        V.check_parameters("scene 's'", specs, {"tilt": (1, 2)})


# --------------------------------------------------------------------------------------------
# the impact API

M3 = np.diag([1.0, 2.0, 3.0])
J_SAME = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])  # normal row = tangent row: W singular
DQ3 = np.array([0.3, -1.0, 0.2])


@pytest.mark.parametrize("mu", [0.3, 2.0])
def test_auto_pereira_nikravesh_singular_w_falls_back(mu):
    """n = t = the second coordinate: W = [[1/2, 1/2], [1/2, 1/2]], v- = (-1, -1). Sticking
    would need v_n+ = 1/2 and v_t+ = 0 from one rank of W: impossible, so the contact slides
    along eq. (55)'s t = -sgn(v_t-) = +1: v_n+ = -1 + 1/2 (1 + mu) pi_n = e = 1/2 gives
    pi_n = 3 / (1 + mu), pi_t = mu pi_n."""
    r = resolve_impact(M3, J_SAME, DQ3, e=0.5, mu=mu)
    pn = 3.0 / (1.0 + mu)
    assert r.regime == "slide"
    np.testing.assert_allclose(r.impulse, [pn, mu * pn], rtol=1e-12)
    np.testing.assert_allclose(r.v_plus, [0.5, 0.5], atol=1e-12)
    assert any("clarabel instead" in n for n in r.diagnostics.notes)


def test_separating_contact_with_overflowing_energy_raises():
    with pytest.raises(NonFiniteError, match="kinetic energy"):
        resolve_impact(np.eye(2), np.eye(2), [1e200, 1e200], e=0.5, mu=0.3)


def test_batch_zero_jacobian_is_degenerate_like_resolve_impact():
    J0 = np.zeros((2, 3))
    with pytest.raises(DegenerateContactError):
        resolve_impact(M3, J0, DQ3, e=0.5, mu=0.3)
    with pytest.raises(DegenerateContactError, match="impact 1 of the batch of 2"):
        resolve_impacts(M3, np.stack([J_SAME * [[1], [0]] + [[0, 0, 0], [1, 0, 0]], J0]), DQ3,
                        e=0.5, mu=0.3)


def test_batch_grazing_contact_is_not_degenerate():
    """A zero normal row with moving tangents is a grazing contact: separating, no impulse."""
    J = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    b = resolve_impacts(M3, J, DQ3, e=0.5, mu=0.3)
    assert b.status[0] == 0 and b.regimes() == ("separating",)
    np.testing.assert_array_equal(b.impulse[0], [0.0, 0.0])


@pytest.mark.parametrize("law", ["stronge", "pereira-nikravesh", "coulomb", "ccp",
                                 "dissipative", "chatterjee-ruina"])
def test_contact_impulses_flags_an_indefinite_w_under_every_law(law):
    W = np.array([[1.0, 2.0], [2.0, 1.0]])  # eigenvalues 3 and -1
    b = contact_impulses(W, [-1.0, 0.5], e=0.5, mu=0.3, law=law)
    assert b.status[0] == 1  # SINGULAR
    assert np.isnan(b.impulse).all()
    with pytest.raises(SingularSystemError):
        contact_impulses(W, [-1.0, 0.5], e=0.5, mu=0.3, law=law, on_error="raise")


def test_contact_impulses_accepts_a_semidefinite_w():
    """W = [[1, 1], [1, 1]] (n and t dependent) is semidefinite: not flagged as indefinite by
    the check; the frictionless law answers Newton's pi_n = -(1 + e) v_n / W_nn."""
    b = contact_impulses([[1.0, 1.0], [1.0, 1.0]], [-1.0, 0.0], e=0.5, mu=0.0,
                         law="stronge")
    assert b.status[0] == 0
    np.testing.assert_allclose(b.impulse[0], [1.5, 0.0])


@pytest.mark.parametrize("option,value,error", [
    ("xtol", -1, ParameterError), ("xtol", 0, ParameterError), ("xtol", np.nan, NonFiniteError),
    ("xtol", np.inf, NonFiniteError), ("n_grid", 0, ParameterError),
    ("n_grid", -3, ParameterError), ("n_grid", 2.5, ParameterError),
    ("n_grid", "10", ParameterError)])
@pytest.mark.parametrize("rows", [2, 3])
def test_sweep_options(option, value, error, rows):
    J = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])[:rows]
    with pytest.raises(error, match=option):
        resolve_impact(M3, J, DQ3, e=0.5, mu=0.3, method="sweep", **{option: value})


# --------------------------------------------------------------------------------------------
# simulate, simulate_with


@pytest.fixture(scope="module")
def ball():
    return load_scene("bouncing_ball", t_end=0.3)


@pytest.mark.parametrize("kwargs,error,name", [
    ({"t_span": (0, 1j)}, ShapeError, "t_span"),
    ({"t_span": ("0", "0.6")}, ShapeError, "t_span"),
    ({"y0": (np.array([0.0, 1 + 1j]), np.zeros(2))}, ShapeError, "theta0"),
    ({"y0": np.array([0.0, 1.0, 0.0, 1j])}, ShapeError, "y0"),
    ({"rtol": "1e-8"}, ParameterError, "rtol"),
    ({"atol": np.array([1e-9, 1e-9])}, ParameterError, "atol"),
    ({"max_step": 0}, ParameterError, "max_step"),
    ({"max_step": -1}, ParameterError, "max_step"),
    ({"max_step": np.nan}, NonFiniteError, "max_step"),
    ({"max_step": "1"}, ParameterError, "max_step"),
    ({"first_step": 0}, ParameterError, "first_step"),
    ({"first_step": -1}, ParameterError, "first_step"),
    ({"first_step": np.nan}, NonFiniteError, "first_step"),
    ({"max_impacts": "x"}, ParameterError, "max_impacts"),
    ({"max_impacts": 2.5}, ParameterError, "max_impacts"),
    ({"max_impacts": -1}, ParameterError, "max_impacts"),
    ({"t_eval": ["a"]}, ShapeError, "t_eval"),
    ({"t_eval": [0.1, np.nan]}, NonFiniteError, "t_eval"),
    ({"zeno_time_tol": -1}, ParameterError, "zeno_time_tol"),
    ({"zeno_time_tol": np.nan}, NonFiniteError, "zeno_time_tol"),
    ({"impact_options": [1, 2]}, ParameterError, "impact_options"),
    ({"zeno": 1}, UnknownOptionError, "zeno"),
    ({"dense_output": "yes"}, ParameterError, "dense_output"),
])
def test_simulate_refuses(ball, kwargs, error, name):
    from convimpact.simulation import simulate

    with pytest.raises(error, match=name):
        simulate(ball, **kwargs)


@pytest.mark.parametrize("scheme,kwargs,name", [
    ("compliant", {"stiffness": 1e5, "max_step": 0}, "max_step"),
    ("event-driven", {"max_step": 0}, "max_step"),
    ("moreau-jean", {"h": "1e-3"}, "h"),
    ("moreau-jean", {"h": 0.0}, "h"),
    ("moreau-jean", {"h": 1e-3, "theta": 2}, "theta"),
])
def test_simulate_with_refuses(ball, scheme, kwargs, name):
    from convimpact.simulation.schemes import simulate_with

    with pytest.raises(ParameterError, match=name):
        simulate_with(ball, scheme=scheme, **kwargs)


def test_valid_integral_max_impacts_and_float_span_run(ball):
    """Valid input of other types is answered: max_impacts=2.0, t_span of numpy ints. The
    ball released from h = 1 m (centre; radius 0.1) first lands at sqrt(2 * 0.9 / 9.81)."""
    from convimpact.simulation import simulate

    r = simulate(ball, t_span=np.array([0, 1]), max_impacts=2.0)
    assert len(r.impacts) == 2
    assert r.impacts[0].time == pytest.approx(np.sqrt(2 * 0.9 / 9.81), rel=1e-7)


# --------------------------------------------------------------------------------------------
# load_scene


ABSURD = [
    ("bouncing_ball", {"height": -1}, "height"), ("bouncing_ball", {"height": np.nan}, "height"),
    ("bouncing_ball", {"height": np.inf}, "height"), ("bouncing_ball", {"t_end": 0}, "t_end"),
    ("bouncing_ball", {"t_end": -1}, "t_end"), ("bouncing_ball", {"radius": 0}, "radius"),
    ("bouncing_ball", {"e": "0.5"}, "e"), ("bouncing_ball", {"mass": True}, "mass"),
    ("bouncing_rod", {"length": -1}, "length"), ("bouncing_rod", {"mass": 0}, "mass"),
    ("slider_crank", {"omega_ref": np.nan}, "omega_ref"),
    ("slider_crank", {"mass_ratio": -1}, "mass_ratio"),
    ("spinning_ball", {"spatial": "yes"}, "spatial"),
    ("spinning_ball", {"spatial": True, "direction_deg": np.nan}, "direction_deg"),
    ("spinning_ball", {"radius": 0}, "radius"),
    ("rimless_wheel", {"n_spokes": 2.5}, "n_spokes"), ("rimless_wheel", {"rho": 0}, "rho"),
    ("pendulum_3d", {"length": 0}, "length"), ("pendulum_planar", {"mu": -1}, "mu"),
    ("rocking_block", {"tilt": 2.0}, "tilt"), ("sliding_box", {"mu": 0}, "mu"),
    ("incline_box", {"slope_deg": 90}, "slope_deg"),
    ("painleve_rod", {"angle_deg": 0}, "angle_deg"),
    ("robot_drop", {"tilt": (0, 1)}, "tilt"),
]


@pytest.mark.parametrize("scene,params,name", ABSURD)
def test_load_scene_refuses_absurd_parameters_naming_them(scene, params, name):
    if scene not in list_scenes():
        pytest.skip(f"scene {scene} not installed")
    with pytest.raises(ConvImpactError, match=rf"scene '{scene}': {name}\b"):
        load_scene(scene, **params)


def test_every_scene_declares_every_parameter_and_its_defaults_fit():
    import inspect
    import importlib

    for name in list_scenes():
        specs = scene_parameters(name)
        if not specs:  # a scene added without declarations keeps the signature's check
            continue
        sig = inspect.signature(importlib.import_module(f"convimpact.problems.{name}")
                                .make_scene)
        assert set(specs) == set(sig.parameters), name
        for p in sig.parameters.values():
            specs[p.name].check(p.name, p.default)


# --------------------------------------------------------------------------------------------
# the command line


_run = run_cli


@pytest.mark.parametrize("argv,option", [
    (["demo", "--angle", "nan"], "--angle"), (["demo", "--angle", "inf"], "--angle"),
    (["demo", "--mu", "-inf"], "--mu"),
    (["simulate", "--bench", "bouncing_ball", "--repeats", "0"], "--repeats"),
    (["simulate", "--bench", "--repeats", "-1"], "--repeats"),
    (["simulate", "bouncing_ball", "--t-end", "nan"], "--t-end"),
    (["simulate", "bouncing_ball", "--max-impacts", "2.5"], "--max-impacts"),
    (["study", "studies/pendulum_monte_carlo.toml", "--out", "X", "--workers", "0"],
     "--workers"),
    (["study", "studies/pendulum_monte_carlo.toml", "--out", "X", "--workers", "-1"],
     "--workers"),
    (["atlas", "--out", "X", "--workers", "0"], "--workers"),
])
def test_cli_refuses_naming_the_option(argv, option, tmp_path):
    argv = [str(tmp_path / "store") if a == "X" else a for a in argv]
    code, err = _run(argv)
    assert code == 2
    assert f"argument {option}" in err and "Traceback" not in err
    assert not (tmp_path / "store").exists()


def test_cli_scene_parameter_named(tmp_path):
    code, err = _run(["simulate", "bouncing_ball", "--param", "height=-1", "--out",
                      str(tmp_path)])
    assert code == 2 and "height must be > 0" in err
    assert not (tmp_path / "result.json").exists()


def test_cli_failed_plot_leaves_no_result_json(tmp_path):
    (tmp_path / "trajectory.png").mkdir()  # the plot cannot be written
    code, err = _run(["simulate", "bouncing_ball", "--t-end", "0.2", "--out", str(tmp_path)])
    assert code == 2 and "cannot write" in err
    assert not (tmp_path / "result.json").exists()
    assert not (tmp_path / "result.json.partial").exists()


def test_cli_successful_run_writes_result_json(tmp_path):
    code, _ = _run(["simulate", "bouncing_ball", "--t-end", "0.2", "--out", str(tmp_path)])
    assert code == 0
    report = json.loads((tmp_path / "result.json").read_text())
    assert report["scene"] == "bouncing_ball"
    assert not list(Path(tmp_path).glob("*.partial"))


def test_study_workers_refused_before_the_store(tmp_path):
    for package in ("xarray", "zarr", "dask"):
        pytest.importorskip(package, reason="studies need dask, xarray and zarr "
                                            "(pip install -e \".[test-full]\")")
    from convimpact.studies.study import run_study

    for workers in (0, -1, 2.5, "2"):
        with pytest.raises(ParameterError, match="workers"):
            run_study("studies/pendulum_monte_carlo.toml", tmp_path / "s.zarr",
                      "processes", workers=workers)
        assert not (tmp_path / "s.zarr").exists()


@pytest.mark.parametrize("kwargs,name", [({"mu": [0.3, True]}, "mu"), ({"e": [0.5, "1"]}, "e"),
                                         ({"dq": [[1.0, -1.0], [1.0, 1j]]}, "dq")])
def test_batch_refuses_boolean_string_complex_entries(kwargs, name):
    """numpy alone reads [0.3, True] as [0.3, 1.0]: the batch refuses such entries by name."""
    args = {"M": np.eye(2), "Jc": np.eye(2), "dq": [[1.0, -1.0], [1.0, -2.0]], "e": 0.5,
            "mu": 0.3, **kwargs}
    with pytest.raises(ShapeError, match=f"{name} has a"):
        resolve_impacts(**args)


def test_energy_functions_raise_instead_of_returning_inf():
    import convimpact as ci

    with pytest.raises(NonFiniteError, match="T-"):
        ci.energy_loss(np.eye(2), [1e200, 0.0], [0.0, 0.0])
    with pytest.raises(NonFiniteError, match="energy loss"):
        ci.central_energy_loss(np.eye(2), [1.0, 0.0], [-1e200, 0.0], 0.5)
    # in range: eq. (58) by hand, 1/2 (1 + 4) - 1/2 (1/4 + 1) = 1.875
    assert ci.energy_loss(np.eye(2), [1.0, 2.0], [0.5, 1.0]) == pytest.approx(1.875)


@pytest.mark.parametrize("h", ["1e-3", True, 1j, 0.0, -1e-3, float("nan")])
def test_simulate_moreau_called_directly_refuses_a_step_that_is_not_a_positive_real(h):
    """The scheme's own entry point (the user guide calls it) checks h as simulate_with does:
    a string, a boolean or a complex number is refused, not converted."""
    from convimpact.errors import NonFiniteError, ParameterError
    from convimpact.simulation.moreau import simulate_moreau

    with pytest.raises((ParameterError, NonFiniteError), match="h must"):
        simulate_moreau(load_scene("bouncing_ball"), (0.0, 0.1), h=h)
