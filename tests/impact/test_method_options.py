"""Each method's options are documented (a table in resolve_impact's docstring, the table
:data:`convimpact.impact.resolve.METHOD_OPTIONS`) and are exactly what the method takes: every
documented option is accepted, its documented default is the method's own, and a name the
method does not take raises UnknownOptionError listing the valid ones."""

import re

import numpy as np
import pytest

import convimpact as ci
from convimpact.impact import resolve

#: a particle of mass 2 hitting the floor at 45 degrees, and a box corner pair (two contacts)
M = 2.0 * np.eye(2)
JC = np.array([[0.0, 1.0], [1.0, 0.0]])
DQ = np.array([1.0, -1.0])
#: a valid value of each option (the defaults' order of magnitude)
VALUES = {"xtol": 1e-9, "n_grid": 180, "tol": 1e-9, "max_iter": 150, "newton_iter": 10,
          "fixed_point_tol": 1e-8, "max_fixed_point_iter": 50, "anderson_memory": 3}


def _table() -> str:
    """The Notes section of resolve_impact's docstring."""
    return ci.resolve_impact.__doc__.split("Notes\n    -----")[1].split("Examples\n")[0]


#: a law each method treats
LAW = {"closed-form": "pereira-nikravesh", "sweep": "pereira-nikravesh", "interior": "ccp"}


def test_every_method_has_its_row():
    assert set(resolve.METHOD_OPTIONS) == set(ci.METHODS) - {"auto"}
    table = _table()
    for method, names in resolve.METHOD_OPTIONS.items():
        assert f"\n    {method} " in table, method
        for name in names:
            assert f"``{name}``" in table, (method, name)


def test_documented_defaults_are_the_methods_own():
    from convimpact.impact.conic.paths import ProgramOptions
    from convimpact.impact.several.interior import InteriorOptions
    from convimpact.impact.exact import sweep

    table = " ".join(_table().split())
    # each ``name`` [default] of the table, in order (max_iter twice: interior's, the conic's)
    documented = [(n, float(v)) for n, v in re.findall(r"``(\w+)`` \[([-+.e\d]+)", table)]
    assert documented == [
        ("xtol", sweep.DEFAULT_XTOL), ("n_grid", sweep.DEFAULT_GRID),
        *((n, float(getattr(InteriorOptions(), n))) for n in ("tol", "max_iter", "newton_iter")),
        *((n, float(getattr(ProgramOptions(), n))) for n in (
            "tol", "max_iter", "fixed_point_tol", "max_fixed_point_iter", "anderson_memory"))]


@pytest.mark.parametrize("method", list(resolve.METHOD_OPTIONS))
def test_documented_options_are_taken_and_others_refused(method):
    law = LAW.get(method, "coulomb")
    names = resolve.METHOD_OPTIONS[method]
    reference = ci.resolve_impact(M, JC, DQ, e=0.5, mu=0.3, law=law, method=method)
    r = ci.resolve_impact(M, JC, DQ, e=0.5, mu=0.3, law=law, method=method,
                          **{n: VALUES[n] for n in names})
    # the options move no answer beyond the tolerances they set
    np.testing.assert_allclose(r.impulse, reference.impulse, rtol=1e-6, atol=1e-9)
    with pytest.raises(ci.UnknownOptionError) as info:
        ci.resolve_impact(M, JC, DQ, e=0.5, mu=0.3, law=law, method=method, xtoll=1e-9)
    message = str(info.value)
    assert "xtoll" in message
    for name in names:  # the valid ones, named
        assert name in message, (method, name, message)


def test_auto_with_options_names_the_methods_that_take_them():
    # one contact: auto picks fast, which takes none; the message says which methods do
    with pytest.raises(ci.UnknownOptionError) as info:
        ci.resolve_impact(M, JC, DQ, e=0.5, mu=0.3, law="coulomb", tol=1e-9)
    message = str(info.value)
    assert "method 'fast' takes no options" in message and "method='auto'" in message
    for method, names in resolve.METHOD_OPTIONS.items():
        assert f"{method}: {', '.join(names) if names else 'none'}" in message
