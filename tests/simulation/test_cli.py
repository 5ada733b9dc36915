"""``convimpact simulate``: JSON report, files and plots, scene listing."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from convimpact import cli
from convimpact.scenes import Scene
from convimpact.simulation.testing import PointMass

G = 9.81


@pytest.fixture
def drop_scene(monkeypatch):
    import convimpact.simulation.cli as simcli

    def make(name, **params):
        e = float(params.get("e", 0.5))
        return Scene(name="drop", description="particle dropped from 1 m",
                     mechanism=PointMass(e=e), theta0=np.array([0.0, 1.0]),
                     dtheta0=np.zeros(2), t_end=0.6, parameters={"h0": 1.0, "e": e})

    monkeypatch.setattr(simcli, "load_scene", make)
    monkeypatch.setattr(simcli, "list_scenes", lambda: ["drop"])
    return make


def test_simulate_json(drop_scene, capsys):
    assert cli.main(["simulate", "drop", "--json", "--param", "e=0.25"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scene"] == "drop" and out["parameters"] == {"h0": 1.0, "e": 0.25}
    assert out["n_impacts"] == 1
    ev = out["impacts"][0]
    assert ev["time"] == pytest.approx(np.sqrt(2 / G), abs=1e-10)
    v1 = np.sqrt(2 * G)
    assert ev["energy_loss"] == pytest.approx(0.5 * (1 - 0.25**2) * v1**2, rel=1e-9)
    s = out["series"]
    assert len(s["t"]) == len(s["total_energy"]) == len(s["loop_residual"])
    assert s["total_energy"][0] == pytest.approx(G, rel=1e-12)  # m g h, m = 1, h = 1


def test_simulate_writes_files(drop_scene, tmp_path, capsys):
    assert cli.main(["simulate", "drop", "--out", str(tmp_path), "--t-end", "1.0"]) == 0
    text = capsys.readouterr().out
    assert "impacts" in text and "wrote" in text
    for name in ("result.json", "trajectory.png", "energy.png"):
        assert (tmp_path / name).exists()
    for name in ("trajectory.png", "energy.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = json.loads((tmp_path / "result.json").read_text())
    assert report["settings"]["t_span"] == [0.0, 1.0] and report["n_impacts"] == 2


def test_simulate_list(drop_scene, capsys):
    assert cli.main(["simulate", "--list"]) == 0
    assert capsys.readouterr().out.split() == ["drop"]


def test_simulate_unknown_scene_is_a_clean_error(capsys):
    assert cli.main(["simulate", "no_such_scene_xyz"]) == 2
    assert "unknown scene" in capsys.readouterr().err
