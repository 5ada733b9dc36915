"""The public names survive the layout: every name the flat package exported still resolves
from the same place (the list below is the flat layout's, written out, not read from the code)."""

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import convimpact as ci

#: convimpact.__all__ of the flat layout (before convimpact/impact and convimpact/studies)
FLAT_TOP_LEVEL = (
    "resolve_impact", "solve_problem", "simulate", "Mechanism", "Scene", "list_scenes",
    "load_scene", "impact_arguments", "resolve_mechanism_impact", "ModelBuilder", "Joint",
    "build_problem", "available_methods", "ImpactProblem", "ImpactResult", "ImpactDiagnostics",
    "LAWS", "METHODS", "energy_loss", "central_energy_loss", "oblique_energy_loss",
    "oblique_coefficients", "stiction_interval", "StictionInterval", "frictionless_impulse",
    "sticking_impulse", "sliding_impulse", "stick_admissible", "pereira_nikravesh", "errors",
)
#: the exception hierarchy, importable from convimpact and convimpact.errors
ERRORS = (
    "ConvImpactError", "InputError", "ShapeError", "NonFiniteError", "MassMatrixError",
    "ParameterError", "UnknownOptionError", "LoopConstraintError", "SingularSystemError",
    "NonPositiveEffectiveMassError", "SolverError", "NotSupportedError", "ModelError",
    "AssemblyError", "SimulationError", "PenetrationError",
)


@pytest.mark.parametrize("name", FLAT_TOP_LEVEL + ERRORS)
def test_top_level_names_resolve(name):
    assert getattr(ci, name) is not None
    assert name in ci.__all__


def test_errors_module_keeps_its_name():
    from convimpact.errors import SolverError  # the flat layout's import line

    errors = importlib.import_module("convimpact.errors")
    assert SolverError is ci.SolverError is errors.SolverError
    for name in ERRORS:
        assert issubclass(getattr(errors, name), ci.ConvImpactError)


def test_model_names_resolve():
    from convimpact.model import Joint, ModelBuilder, impact_arguments

    assert ModelBuilder is ci.ModelBuilder and Joint is ci.Joint
    assert impact_arguments is ci.impact_arguments


def test_every_law_is_registered_with_its_paths():
    # the six laws, each on the exact kernel and both conic paths; the paper's law also on
    # its closed form and its own angle sweep
    assert ci.LAWS == ("pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge",
                       "chatterjee-ruina")
    assert ci.available_methods("pereira-nikravesh") == [
        "closed-form", "sweep", "fast", "clarabel", "cvxpy"]
    for law in ("stronge", "chatterjee-ruina"):
        assert ci.available_methods(law) == ["fast", "clarabel", "cvxpy"]
    # the other laws also on the exact several-contact solver
    for law in ("coulomb", "ccp", "dissipative"):
        assert ci.available_methods(law) == ["fast", "interior", "clarabel", "cvxpy"]


def test_placement_names_resolve():
    from convimpact.model import place_resting, rest_velocity

    for name, obj in (("place_resting", place_resting), ("rest_velocity", rest_velocity)):
        assert getattr(ci, name) is obj and name in ci.__all__


def test_dir_lists_every_public_name_before_first_use():
    """dir() (and so tab completion) shows the names that load on first use -- simulate,
    ModelBuilder, impact_arguments, place_resting... -- in a fresh interpreter, without loading
    their modules; each then resolves."""
    code = ("import json, sys, convimpact as ci\n"
            "names = dir(ci)\n"
            "print(json.dumps({'dir': names, 'all': ci.__all__, 'loaded': sorted(m for m in "
            "sys.modules if m in ('convimpact.simulation', 'convimpact.model'))}))\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(Path(ci.__file__).resolve().parent.parent), os.environ.get("PYTHONPATH", "")]))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         check=True)
    got = json.loads(out.stdout)
    assert got["loaded"] == []  # dir() imported nothing heavy
    for name in ("simulate", "ModelBuilder", "impact_arguments", "place_resting",
                 "solve_contact_problem", *FLAT_TOP_LEVEL, *ERRORS):
        assert name in got["dir"], name
    assert set(got["all"]) <= set(got["dir"])
    for name in got["dir"]:
        assert hasattr(ci, name), name
    with pytest.raises(AttributeError, match="no attribute 'simulate_later'"):
        ci.simulate_later  # noqa: B018


def test_compiled_module_lists_its_decorators():
    from convimpact import compiled

    assert {"jit", "jit_internal", "literally"} <= set(dir(compiled))
