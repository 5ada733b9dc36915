"""The batch API's derivatives (issue 27): ``resolve_impacts(..., derivatives=True)`` stacks
the items' jacobians; each item against central finite differences of the public call."""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.errors import NotSupportedError, UnknownOptionError
from convimpact.impact.laws import law_module

from .derivative_checks import assert_matches, finite_differences, scene


# the batch adds no law-specific code to the derivatives (each item runs the law's
# impulse_derivative, tested for every law in test_derivatives_laws): two laws, the second
# with a tangential restitution, keep the compiled batch kernels loaded few
@pytest.mark.parametrize("law, d", [("pereira-nikravesh", 2), ("pereira-nikravesh", 3),
                                    ("chatterjee-ruina", 3)])
def test_stacked_jacobians_match_finite_differences(law, d):
    M, Jc, dq, _ = scene(d, seed=0)
    mus = np.array([0.0, 0.1, 3.0])  # frictionless, slide, stick
    e_t = 0.3 if law == "chatterjee-ruina" else None
    b = ci.resolve_impacts(M, Jc, dq, e=0.4, mu=mus, law=law, e_t=e_t, derivatives=True)
    k = dq.size
    assert b.jacobian["dq"].shape == (3, k, k)
    assert b.jacobian["M"].shape == (3, k, k, k)
    assert b.jacobian["Jc"].shape == (3, k, d, k)
    assert b.jacobian["mu"].shape == (3, k) and b.impulse_jacobian["mu"].shape == (3, d)
    assert b.one_sided.tolist() == [True, False, False]  # mu's derivative at mu = 0
    for i, mu in enumerate(mus):
        fd = finite_differences(M, Jc, dq, 0.4, float(mu), law=law, e_t=e_t)
        item = {name: a[i] for name, a in b.jacobian.items()}
        assert_matches(item, fd["dq_plus"])
        item = {name: a[i] for name, a in b.impulse_jacobian.items()}
        assert_matches(item, fd["impulse"])


def test_without_derivatives_nothing_is_attached_and_a_failed_item_is_nan():
    M, Jc, dq, _ = scene(2, seed=0)
    assert ci.resolve_impacts(M, Jc, dq, e=0.4, mu=0.1).jacobian is None
    # item 1 rejected: W = [[1, 2], [2, 4]] is singular and its stick solve inverts it;
    # item 0 is frictionless with e = 0: d dq+/d dq = I - M^-1 Jn^T Jn / (Jn M^-1 Jn^T)
    b = ci.resolve_impacts(np.eye(2), np.array([[1.0, 0.0], [2.0, 0.0]]), [-1.0, 0.0],
                           e=0.0, mu=[0.0, 0.5], derivatives=True)
    assert b.regimes() == ("frictionless", "failed")
    np.testing.assert_allclose(b.jacobian["dq"][0], [[0.0, 0.0], [0.0, 1.0]], atol=1e-15)
    assert np.isnan(b.jacobian["dq"][1]).all() and np.isnan(b.impulse_jacobian["M"][1]).all()


@pytest.mark.parametrize("bad", ["both", "yes", 1, None])
def test_bad_values(bad):
    M, Jc, dq, _ = scene(2, seed=0)
    with pytest.raises(UnknownOptionError, match="derivatives"):
        ci.resolve_impacts(M, Jc, dq, e=0.4, mu=0.1, derivatives=bad)


def test_a_law_without_a_derivative_is_named(monkeypatch):
    M, Jc, dq, _ = scene(2, seed=0)
    monkeypatch.delattr(law_module("dissipative"), "impulse_derivative")
    with pytest.raises(NotSupportedError, match="'dissipative'"):
        ci.resolve_impacts(M, Jc, dq, e=0.4, mu=0.1, law="dissipative", derivatives=True)
