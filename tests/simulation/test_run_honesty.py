"""Runs say what happened: simultaneous or sequential impacts (Newton's cradle), the impact
cap, and the impact laws' flags gathered into run-level counts and warnings."""

from __future__ import annotations

import json

import numpy as np
import pytest

import convimpact as ci
from convimpact.cli import main
from convimpact.model import Joint, ModelBuilder


def _cradle(e, n=3, r=0.1, m=1.0):
    """n balls on a frictionless line (prismatic joints along x, no gravity), ball i+1's left
    point against a plane on ball i's right side."""
    b = ModelBuilder(planar=True, gravity=(0.0, 0.0))
    for i in range(n):
        b.add_body(f"ball{i}", "ground", Joint.prismatic((1.0, 0.0)), m, (0.0, 0.0),
                   0.4 * m * r * r)
    for i in range(n - 1):
        b.add_contact(f"c{i}", body=f"ball{i + 1}", point=(0.0, 0.0), radius=r,
                      against=f"ball{i}", plane_point=(r, 0.0), normal=(1.0, 0.0), e=e, mu=0.0)
    return b.build().mechanism()


def _sequential_chain(v, e):
    """Pairwise Newton impacts of equal masses, repeated until no pair approaches."""
    v = list(v)
    while True:
        pairs = [i for i in range(len(v) - 1) if v[i] > v[i + 1] + 1e-15]
        if not pairs:
            return np.array(v)
        i = pairs[0]
        mean, rel = 0.5 * (v[i] + v[i + 1]), 0.5 * (v[i] - v[i + 1])
        v[i], v[i + 1] = mean - e * rel, mean + e * rel


@pytest.mark.parametrize("e", [1.0, 0.5, 0.0])
def test_newtons_cradle_simultaneous_and_sequential(e):
    """A ball at speed v strikes two touching balls (equal masses). Simultaneous: the struck
    pair moves as one body, momentum and Newton's law at the first contact give
    ((1 - 2e)/3, (1 + e)/3, (1 + e)/3) v; sequential: pairwise impacts in turn, (0, 0, v) for
    e = 1."""
    mech = _cradle(e)
    y0 = (np.array([-0.05, 0.2, 0.4]), np.array([1.0, 0.0, 0.0]))
    sim = ci.simulate(mech, (0.0, 0.2), y0, impacts="simultaneous", law="coulomb",
                      method="clarabel")
    np.testing.assert_allclose(sim.dtheta[-1], np.array([1 - 2 * e, 1 + e, 1 + e]) / 3,
                               atol=1e-9)
    seq = ci.simulate(mech, (0.0, 0.2), y0, impacts="sequential", law="coulomb",
                      method="clarabel")
    np.testing.assert_allclose(seq.dtheta[-1], _sequential_chain([1.0, 0.0, 0.0], e), atol=1e-9)
    if e == 1.0:
        np.testing.assert_allclose(seq.dtheta[-1], [0.0, 0.0, 1.0], atol=1e-12)
    # momentum is conserved either way
    assert sim.dtheta[-1].sum() == pytest.approx(1.0, abs=1e-12)
    assert seq.dtheta[-1].sum() == pytest.approx(1.0, abs=1e-12)
    with pytest.raises(ci.UnknownOptionError):
        ci.simulate(mech, (0.0, 0.2), y0, impacts="both")


def test_max_impacts_zero_resolves_no_impact():
    res = ci.simulate(ci.load_scene("bouncing_ball"), max_impacts=0)
    assert res.status == 1 and "max_impacts = 0" in res.message and res.impacts == ()
    # the ball stopped at the floor, falling: the first contact instant (free fall from 1 m,
    # radius 0.1: t = sqrt(2 * 0.9 / g))
    assert res.t[-1] == pytest.approx(np.sqrt(2 * 0.9 / 9.81), rel=1e-9)


def test_energy_gain_of_the_law_is_counted_and_warned():
    """The 3D pendulum with the paper's law: an impact creates energy; the run says so."""
    res = ci.simulate(ci.load_scene("pendulum_3d"))
    gained = [ev for ev in res.impacts if ev.kinetic_energy_plus > ev.kinetic_energy_minus
              * (1 + 1e-9)]
    assert gained  # measured independently of the flags: T+ > T-
    assert res.law_flags["energy_gained"] == len(gained)
    (warn,) = [w for w in res.warnings if "created kinetic energy" in w]
    worst = max(gained, key=lambda ev: ev.kinetic_energy_plus - ev.kinetic_energy_minus)
    assert f"t = {worst.time:.9g}" in warn
    assert res.as_dict(series=False)["law_flags"]["energy_gained"] == len(gained)
    clean = ci.simulate(ci.load_scene("pendulum_3d"), law="dissipative")
    assert clean.law_flags["energy_gained"] == 0
    assert not any("created kinetic energy" in w for w in clean.warnings)


def test_cli_prints_the_run_warnings_and_never_minus_zero(tmp_path, capsys):
    code = main(["simulate", "pendulum_3d", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    assert "WARNING:" in out and "created kinetic energy" in out
    assert "T_L = -0 " not in out and "T_L = -0\n" not in out
    report = json.loads((tmp_path / "result.json").read_text())
    assert report["law_flags"]["energy_gained"] >= 1 and report["warnings"]
