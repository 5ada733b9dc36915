"""The event-driven result's contact forces computed on first read (lazy recording).

The forces are checked against statics derived by hand, not against the code: a stack of
boxes at rest carries on each level's corners the weight of the boxes above (vertical
equilibrium) and, once pushed horizontally at the top, a friction total equal to the push
(horizontal equilibrium of the boxes above the level; problems/box_stack.py: the push
``ramp m g (t - t_push)`` at the top box's centre, the stack tipping at 0.44 s)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from convimpact.scenes import load_scene
from convimpact.simulation import simulate
from convimpact.simulation.result import SimulationResult


def _bare(**kw) -> SimulationResult:
    required = {f.name: None for f in dataclasses.fields(SimulationResult)
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING}
    return SimulationResult(**required, **kw)


def test_a_callable_series_is_computed_once_on_first_read():
    calls = []

    def compute():
        calls.append(1)
        return np.full((2, 1, 3), 7.0)

    res = _bare(contact_force=compute)
    assert calls == []  # not at construction
    assert res.contact_force.shape == (2, 1, 3)
    assert np.all(res.contact_force == 7.0)
    assert calls == [1]  # kept after the first read
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.contact_force = np.zeros((0, 0, 0))  # type: ignore[misc]


def test_default_is_the_empty_series():
    assert _bare().contact_force.shape == (0, 0, 0)


def test_box_stack_forces_read_after_the_run_satisfy_statics():
    scene = load_scene("box_stack")
    p = scene.parameters
    t_end = 0.4  # pushed from t_push = 0.2, tipping at 0.44: at rest throughout
    res = simulate(scene.mechanism, (0.0, t_end), (scene.theta0, scene.dtheta0))
    assert res.status == 0
    assert callable(res.__dict__["_lazy_contact_force"])  # left to compute by the run
    F = res.contact_force
    n, g, m = p["n_boxes"], p["gravity"], p["mass"]
    closed = res.held == 4 * n
    assert closed.sum() >= 3
    for level in range(n):
        corners = F[closed][:, 4 * level:4 * level + 4]  # box `level`'s bottom corners
        # vertical: the weight of this box and those above it
        np.testing.assert_allclose(corners[:, :, 0].sum(axis=1), (n - level) * m * g,
                                   rtol=1e-8)
        # horizontal: the push at the top, ramp m g (t - t_push) after t_push
        push = p["ramp"] * m * g * np.maximum(res.t[closed] - p["t_push"], 0.0)
        friction = np.linalg.norm(corners[:, :, 1:].sum(axis=1), axis=1)
        np.testing.assert_allclose(friction, push, atol=1e-8 * m * g)
        # Coulomb: every corner inside its cone
        tangential = np.linalg.norm(corners[:, :, 1:], axis=2)
        assert np.all(tangential <= p["mu"] * corners[:, :, 0] + 1e-9)


def test_a_result_pickles_with_its_lazy_forces_and_read_only_mappings():
    """A run's result crosses a process boundary (pickle): the pending forces are computed on
    the way, equal to the ones read in place, and the mappings stay read-only."""
    import pickle
    from types import MappingProxyType

    scene = load_scene("table")
    y0 = np.r_[scene.theta0, scene.dtheta0]
    res = simulate(scene.mechanism, (0.0, 0.05), y0)
    twin = simulate(scene.mechanism, (0.0, 0.05), y0)
    back = pickle.loads(pickle.dumps(res))
    assert np.array_equal(back.contact_force, twin.contact_force)  # forces read in place
    assert back.contact_force.shape[0] == back.t.size > 0
    assert np.array_equal(back.y, twin.y)
    assert type(back.settings) is type(res.settings) and back.settings == res.settings
    assert isinstance(res.parameter_sensitivity, MappingProxyType)  # the default: read-only
    assert isinstance(back.parameter_sensitivity, MappingProxyType)
    with pytest.raises(TypeError):
        back.parameter_sensitivity["e"] = 1  # type: ignore[index]
    with pytest.raises(dataclasses.FrozenInstanceError):
        back.t = np.zeros(1)  # type: ignore[misc]
