"""Fuzz suite (issue 29): malformed input at every public entry point and CLI command.

Each property replaces one argument of a valid call by a malformed value (a boolean, text,
a complex number, None, NaN, an infinity, zero, a negative or huge number, an array of the
wrong shape, a mapping) and asserts that the call ends in a typed error -- a subclass of
:class:`convimpact.ConvImpactError` (for the command line: exit status 2 with a message,
never a traceback) -- or in a correct answer (finite numbers), never in another exception or
a NaN. Examples are drawn deterministically (the suite's Hypothesis profile derandomizes)
and every draw is used (no ``assume``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from .cli_run import run_cli
from hypothesis import given, settings
from hypothesis import strategies as st

from convimpact import resolve_impact
from convimpact.impact.batch import contact_impulses, resolve_impacts
from convimpact.errors import ConvImpactError

#: examples per property: the whole file runs in well under 30 s
FEW = settings(max_examples=40, deadline=None)
SOME = settings(max_examples=80, deadline=None)

JUNK_SCALARS = [True, False, None, "0.5", "x", "", "nan", 1j, 1 + 2j, math.nan, math.inf,
                -math.inf, 0, 0.0, -1, -1e-300, 1e-320, 1e308, 1e200, -1e308, 2.5, 10**400,
                np.float32(np.nan), np.int64(-3), np.bool_(True), np.complex128(1j)]
JUNK_CONTAINERS = [[], [1.0], [[1.0, 2.0]], [1.0, "a"], [1.0, None], [1.0, True],
                   [[1.0], [1.0, 2.0]], (math.nan, 1.0), {"a": 1}, {1: 2}, set(),
                   np.zeros(0), np.zeros((2, 2, 2, 2)), np.array(["a", "b"]),
                   np.array([1j, 2j]), np.array([True, False]), np.full(3, np.nan),
                   np.full(2, np.inf), object()]
junk = st.sampled_from(JUNK_SCALARS + JUNK_CONTAINERS)


def _finite(*arrays) -> bool:
    return all(np.isfinite(np.asarray(a, dtype=float)).all() for a in arrays)


def _typed(call):
    """Run ``call``: its value, or None when it raised a ConvImpactError (any other exception
    propagates and fails the property)."""
    try:
        return call()
    except ConvImpactError as exc:
        assert str(exc), "a typed error must say what to change"
        return None


# --------------------------------------------------------------------------------------------
# the impact API

M = np.array([[2.0, 0.3, 0.1], [0.3, 1.5, 0.2], [0.1, 0.2, 1.0]])
J = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
DQ = np.array([0.4, -1.0, 0.2])
IMPACT = {"M": M, "Jc": J, "dq": DQ, "e": 0.5, "mu": 0.3, "law": "pereira-nikravesh",
          "method": "auto"}
LAWS = ["pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge", "chatterjee-ruina"]


@SOME
@given(name=st.sampled_from(sorted(IMPACT)), value=junk, law=st.sampled_from(LAWS))
def test_resolve_impact_malformed_argument(name, value, law):
    kwargs = {**IMPACT, "law": law, name: value}
    r = _typed(lambda: resolve_impact(**kwargs))
    if r is not None:
        assert _finite(r.impulse, r.dq_plus, r.v_plus, [r.energy_loss])


@FEW
@given(name=st.sampled_from(["xtol", "n_grid", "e_t", "C", "tol", "bogus"]), value=junk)
def test_resolve_impact_malformed_option(name, value):
    method = "sweep" if name in ("xtol", "n_grid") else "auto"
    law = "chatterjee-ruina" if name == "e_t" else "pereira-nikravesh"
    r = _typed(lambda: resolve_impact(M, J, DQ, e=0.5, mu=0.3, law=law, method=method,
                                      **{name: value}))
    if r is not None:
        assert _finite(r.impulse, r.dq_plus)


@SOME
@given(scale_v=st.sampled_from([1e-300, 1e-200, 1e-100, 1e-20, 1.0, 1e20, 1e100]),
       scale_t=st.sampled_from([0.0, 1e-300, 1.0, 1e100]), law=st.sampled_from(LAWS),
       spatial=st.booleans(), sign=st.sampled_from([-1.0, 1.0]))
def test_resolve_impact_extreme_scales(scale_v, scale_t, law, spatial, sign):
    """Approach and slip speeds far apart (the issue's -1e-300 included): an answer with
    finite numbers, or a typed error -- never OverflowError or NaN."""
    Jc = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])[:3 if spatial else 2]
    dq = np.array([0.5 * scale_t, sign * scale_v, 0.3 * scale_t])
    r = _typed(lambda: resolve_impact(M, Jc, dq, e=0.5, mu=0.3, law=law))
    if r is not None:
        assert _finite(r.impulse, r.dq_plus, r.v_plus)
    b = _typed(lambda: resolve_impacts(M, Jc, dq, e=0.5, mu=0.3, law=law))
    if b is not None:
        ok = b.status == 0
        assert _finite(b.impulse[ok], b.dq_plus[ok])


BATCH = {"M": M, "Jc": J, "dq": np.stack([DQ, -DQ]), "e": 0.5, "mu": [0.0, 0.3],
         "law": "coulomb", "on_error": "flag", "threads": 1}


@SOME
@given(name=st.sampled_from(sorted(BATCH)), value=junk, law=st.sampled_from(LAWS))
def test_resolve_impacts_malformed_argument(name, value, law):
    kwargs = {**BATCH, "law": law, name: value}
    b = _typed(lambda: resolve_impacts(**kwargs))
    if b is not None:
        ok = b.status == 0
        assert _finite(b.impulse[ok], b.dq_plus[ok], b.v_plus[ok])


@SOME
@given(name=st.sampled_from(sorted(IMPACT) + ["derivatives"]), value=junk,
       law=st.sampled_from(LAWS))
def test_resolve_impact_with_derivatives_malformed_argument(name, value, law):
    kwargs = {**IMPACT, "law": law, "derivatives": True, name: value}
    r = _typed(lambda: resolve_impact(**kwargs))
    if r is not None and r.jacobian is not None:
        assert _finite(*r.jacobian.values(), *r.impulse_jacobian.values())


@FEW
@given(name=st.sampled_from(sorted(BATCH) + ["derivatives"]), value=junk,
       law=st.sampled_from(LAWS[:4]))
def test_resolve_impacts_with_derivatives_malformed_argument(name, value, law):
    kwargs = {**BATCH, "law": law, "derivatives": True, name: value}
    b = _typed(lambda: resolve_impacts(**kwargs))
    if b is not None and getattr(b, "jacobian", None) is not None:
        ok = b.status == 0
        assert _finite(*(np.asarray(v)[ok] for v in b.jacobian.values()))


CONTACTS = {"W": np.array([[0.7, 0.1], [0.1, 0.9]]), "v": [[-1.0, 0.5], [-0.5, 0.0]],
            "e": 0.5, "mu": 0.3, "law": "stronge", "on_error": "flag", "threads": None}


@SOME
@given(name=st.sampled_from(sorted(CONTACTS)), value=junk, law=st.sampled_from(LAWS),
       W=st.sampled_from([None, [[1.0, 2.0], [2.0, 1.0]], [[0.0, 0.0], [0.0, 0.0]],
                          [[1.0, 1.0], [1.0, 1.0]], [[-1.0, 0.0], [0.0, 1.0]]]))
def test_contact_impulses_malformed_argument(name, value, law, W):
    kwargs = {**CONTACTS, "law": law, name: value}
    if W is not None and name != "W":
        kwargs["W"] = W
    b = _typed(lambda: contact_impulses(**kwargs))
    if b is not None:
        ok = b.status == 0
        assert _finite(b.impulse[ok], b.v_plus[ok])
        assert np.isnan(b.impulse[~ok]).all()


# --------------------------------------------------------------------------------------------
# simulation


@pytest.fixture(scope="module")
def ball():
    from convimpact.scenes import load_scene

    return load_scene("bouncing_ball", t_end=0.05)


SIMULATE = ["t_span", "y0", "law", "method", "integrator", "rtol", "atol", "max_step",
            "first_step", "dense_output", "t_eval", "event_tol", "contact_tol",
            "projection_tol", "assemble", "zeno", "zeno_time_tol", "rest_velocity",
            "max_impacts", "painleve", "impacts", "impact_options", "sensitivities"]


@FEW
@given(name=st.sampled_from(SIMULATE), value=junk)
def test_simulate_malformed_argument(ball, name, value):
    from convimpact.simulation import simulate

    r = _typed(lambda: simulate(ball, **{"t_span": (0.0, 0.05), name: value}))
    if r is not None:
        assert _finite(r.t, r.theta, r.dtheta)


SCHEME_OPTIONS = {"moreau-jean": ["h", "theta", "gap_tol", "rest_velocity", "projection_tol",
                                  "contact_tol", "law", "impact_options", "assemble"],
                  "compliant": ["stiffness", "exponent", "e", "mu", "model", "rtol", "atol",
                                "max_step", "first_step", "regularization_velocity",
                                "min_impact_velocity", "integrator"]}
VALID_SCHEME = {"moreau-jean": {"h": 5e-3}, "compliant": {"stiffness": 1e4}}


PERIODIC = ["y0", "section", "reduce", "t_max", "strides", "tol", "max_iterations",
            "jacobian", "step", "simulate_options", "touch_tol", "rest_velocity", "progress"]


@settings(max_examples=20, deadline=None)
@given(name=st.sampled_from(PERIODIC), value=junk)
def test_find_periodic_orbit_malformed_argument(name, value):
    from convimpact.problems import rimless_wheel
    from convimpact.simulation import find_periodic_orbit

    scene = rimless_wheel.make_scene()
    n, leg = int(scene.parameters["n_spokes"]), float(scene.parameters["leg_length"])
    kwargs = {"reduce": lambda th, dth: rimless_wheel.reduce(th, dth, n, leg), "t_max": 3.0,
              name: value}
    orbit = _typed(lambda: find_periodic_orbit(scene, **kwargs))
    if orbit is not None:
        assert _finite(orbit.theta, orbit.dtheta, [orbit.period], np.abs(orbit.multipliers))


FIT = ["parameters", "per_contact", "noise", "initial", "y0", "t0", "jacobian",
       "confidence_level", "max_iterations", "xtol", "gtol", "ftol",
       "finite_difference_step", "simulate_options"]


@settings(max_examples=20, deadline=None)
@given(name=st.sampled_from(FIT), value=junk)
def test_fit_coefficients_malformed_argument(name, value):
    from convimpact.scenes import load_scene
    from convimpact.studies import Observations, fit_coefficients

    times = np.linspace(0.05, 0.4, 5)  # the ball dropped from 1 m: y = 1 - g t^2 / 2
    obs = Observations(times, 1.0 - 0.5 * 9.81 * times ** 2, ("y",))
    scene = load_scene("bouncing_ball", e=0.6, mu=0.2, speed=0.0)
    fit = _typed(lambda: fit_coefficients(scene, obs, **{name: value}))
    if fit is not None:
        assert _finite(fit.estimates, fit.standard_errors[np.isfinite(fit.standard_errors)])


@FEW
@given(scheme=st.sampled_from(sorted(SCHEME_OPTIONS)), data=st.data(), value=junk)
def test_simulate_with_malformed_option(ball, scheme, data, value):
    from convimpact.simulation.schemes import simulate_with

    name = data.draw(st.sampled_from(SCHEME_OPTIONS[scheme]))
    kwargs = {**VALID_SCHEME[scheme], name: value}
    r = _typed(lambda: simulate_with(ball, (0.0, 0.05), scheme=scheme, **kwargs))
    if r is not None:
        assert _finite(r.t, r.theta, r.dtheta)


@SOME
@given(data=st.data(), value=junk)
def test_load_scene_malformed_parameter(data, value):
    """Every declared parameter of every scene (robot_drop, whose robot model is an optional
    download-free extra, included when installed), junk in place of its value."""
    from convimpact.scenes import list_scenes, load_scene, scene_parameters

    scene = data.draw(st.sampled_from([s for s in list_scenes() if s != "robot_drop"]))
    names = sorted(scene_parameters(scene)) or ["bogus"]
    name = data.draw(st.sampled_from(names + ["bogus"]))
    s = _typed(lambda: load_scene(scene, **{name: value}))
    if s is not None:
        assert _finite(s.theta0, s.dtheta0, [s.t_end]) and s.t_end > 0


@FEW
@given(name=junk)
def test_load_scene_malformed_name(name):
    from convimpact.scenes import load_scene

    assert _typed(lambda: load_scene(name)) is None


# --------------------------------------------------------------------------------------------
# studies


@FEW
@given(workers=junk)
def test_study_executor_workers(workers, tmp_path_factory):
    from convimpact.studies.executors import make_executor

    ex = _typed(lambda: make_executor("processes", workers))
    if ex is not None:  # never started: closing is free
        assert isinstance(ex.n_workers, int) and ex.n_workers >= 1
        ex.close()


# --------------------------------------------------------------------------------------------
# the command line (in-process: convimpact.cli.main)

TEXT = ["nan", "inf", "-inf", "0", "-1", "2.5", "x", "", "1e400", "-0", "1e-320", "True",
        "[1]", "{}", "1j"]
COMMANDS = {
    "demo": ["--angle", "--e", "--mu", "--e-t"],
    "simulate": ["--t-end", "--rtol", "--atol", "--max-impacts", "--e-t", "--law",
                 "--method", "--integrator", "--zeno", "--param"],
    "simulate --bench": ["--repeats"],
    "study": ["--workers", "--executor"],
    "atlas": ["--workers"],
    "bench": ["--repeat", "--blas-threads", "--sections"],
}


_cli = run_cli


@SOME
@given(data=st.data(), text=st.sampled_from(TEXT))
def test_cli_malformed_option(data, text, tmp_path_factory):
    """A malformed value of a command's option: exit status 2 and a one-line error, no
    traceback, and nothing written -- or, where the value is valid (e.g. --angle 0), a run
    that succeeds (status 0)."""
    command = data.draw(st.sampled_from(sorted(COMMANDS)))
    option = data.draw(st.sampled_from(COMMANDS[command]))
    out = tmp_path_factory.mktemp("out")
    valid = _valid_cli_value(command, option, text)
    if option == "--param":
        text = f"height={text}"
    argv = {
        "demo": ["demo"],
        "simulate": ["simulate", "bouncing_ball", "--t-end", "0.05", "--json"],
        "simulate --bench": ["simulate", "--bench", "bouncing_ball"],
        "study": ["study", "studies/pendulum_monte_carlo.toml", "--out", str(out / "s.zarr"),
                  "--executor", "serial"],
        "atlas": ["atlas", "--out", str(out / "atlas")],
        "bench": ["bench", "--out", str(out / "bench")],
    }[command] + [option, text]
    if valid is False:
        code, err = _cli(argv)
        assert code == 2, (argv, err)
        assert "Traceback" not in err and "error" in err
        assert not list(out.iterdir()), "a refused command wrote files"
    elif valid:
        code, err = _cli(argv)
        assert code == 0, (argv, err)


def _valid_cli_value(command: str, option: str, text: str) -> bool | None:
    """Whether ``text`` is a valid value of ``option``; None: valid but too slow to run here
    (a study, the atlas, the benchmark, a simulation with changed tolerances)."""
    try:
        x = float(text)
    except ValueError:
        return False
    finite = math.isfinite(x)
    if option in ("--angle", "--e", "--mu", "--e-t"):
        ok = finite and {"--e": 0 <= x <= 1, "--mu": x >= 0,
                         "--e-t": -1 <= x <= 1}.get(option, True)
        if not ok:
            return False
        return True if command == "demo" and text == "0" else None
    if option in ("--repeats", "--workers", "--repeat"):
        return None if text.lstrip("-").isdigit() and int(text) >= 1 else False
    if option in ("--blas-threads", "--max-impacts"):
        return None if text.lstrip("-").isdigit() and int(text) >= 0 else False
    if option in ("--t-end", "--rtol", "--atol"):
        return None if finite and x > 0 else False
    if option == "--param":
        return None if finite and x > 0.1 else False
    return False


LANDSCAPE = {"e": [0.0, 0.5], "mu": [-0.3, 0.3], "law": "coulomb"}


@FEW
@given(name=st.sampled_from(["e", "mu", "law"]), value=junk,
       which=st.sampled_from(["closed_form", "law"]))
def test_study_landscape_malformed_grid(name, value, which):
    """The dissipation landscapes over grids of e and signed mu (one planar contact)."""
    from convimpact.studies.landscape import closed_form_landscape, law_landscape

    if which == "closed_form":
        if name == "law":
            return  # the closed form has no law argument
        kwargs = {k: v for k, v in {**LANDSCAPE, name: value}.items() if k != "law"}
        call = lambda: closed_form_landscape(M, J, DQ, **kwargs)  # noqa: E731
    else:
        kwargs = {**LANDSCAPE, name: value}
        call = lambda: law_landscape(M, J, DQ, **kwargs)  # noqa: E731
    L = _typed(call)
    if L is not None:
        assert np.isfinite(L.e).all() and np.isfinite(L.mu).all()


ENERGY = {"M": M, "c_n": J[0], "c_t": J[1], "dq": DQ, "e": 0.5, "mu": 0.3,
          "normal_impulse": 1.0, "dq_minus": DQ, "dq_plus": -0.5 * DQ}


@SOME
@given(which=st.sampled_from(["energy_loss", "central_energy_loss", "oblique_energy_loss",
                              "oblique_coefficients", "stiction_interval"]),
       data=st.data(), value=junk)
def test_energy_functions_malformed_argument(which, data, value):
    """The energy API (eqs. 58-62): a typed error or finite numbers."""
    import inspect

    import convimpact as ci

    fn = getattr(ci, which)
    names = [p for p in inspect.signature(fn).parameters if p in ENERGY or p == "Jc"]
    name = data.draw(st.sampled_from(names))
    kwargs = {p: (J if p == "Jc" else ENERGY[p]) for p in names}
    kwargs[name] = value
    r = _typed(lambda: fn(**kwargs))
    if r is None:
        return
    if which == "stiction_interval":
        assert r.empty or (0.0 <= r.lower <= r.upper <= 1.0)
    else:
        assert _finite(np.atleast_1d(r))
