"""The scripts of examples/ run, and their answers meet numbers derived by hand."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_example_is_tested_and_is_a_script():
    scripts = sorted(p.stem for p in EXAMPLES.glob("*.py"))
    assert scripts == ["contact_problem", "first_impact", "simulate_rocking_block"]
    for name in scripts:
        text = (EXAMPLES / f"{name}.py").read_text()
        assert text.startswith('"""') and 'if __name__ == "__main__":' in text


def test_first_impact_runs_as_a_script():
    out = subprocess.run([sys.executable, str(EXAMPLES / "first_impact.py")], cwd=ROOT,
                         capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"})
    assert out.returncode == 0, out.stderr
    assert "pereira-nikravesh" in out.stdout and "1.4475" in out.stdout


def test_first_impact_meets_the_hand_derivation(capsys):
    results = load("first_impact").main()
    assert set(results) == {"pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge",
                            "chatterjee-ruina"}
    # the sticking impulse solves W pi = -((1 + e) v_n, v_t) with W = I / 2, v = (-1, 1):
    # (3, -2), outside the cone |pi_t| <= 0.3 pi_n, so the paper's law slides on its boundary
    r = results["pereira-nikravesh"]
    assert r.regime == "slide"
    np.testing.assert_allclose(r.impulse, [3.0, -0.9], atol=1e-12)
    np.testing.assert_allclose(r.v_plus, [0.5, 1.0 - 0.9 / 2.0], atol=1e-12)
    assert r.energy_loss == pytest.approx(2.0 - 0.5 * 2.0 * (0.5**2 + 0.55**2), abs=1e-12)
    for law in ("stronge", "dissipative", "ccp"):
        assert results[law].energy_loss >= 0.0          # these never gain energy here
    assert "1.4475" in capsys.readouterr().out


def test_rocking_block_lands_with_housners_ratio(capsys):
    res, r = load("simulate_rocking_block").main()
    assert r == pytest.approx(1.0 - 1.5 * (0.2**2 / (0.2**2 + 1.0**2)), abs=1e-15)
    assert len(res.impacts) >= 2
    for ev in res.impacts:
        ratio = abs(ev.dtheta_plus[2]) / abs(ev.dtheta_minus[2])
        assert ratio == pytest.approx(r, rel=1e-6)
    assert np.all(np.diff(res.total_energy) <= 1e-9)
    assert "Housner" in capsys.readouterr().out


def test_contact_problem_balances_the_momentum(capsys):
    example = load("contact_problem")
    W, b = example.box_contact_problem()
    assert np.linalg.matrix_rank(W) == 6
    sol = example.main()
    r_n = sol.impulse[:, 0]
    # momentum: the normal impulses stop the fall of the unit mass at 1 m/s
    assert r_n.sum() == pytest.approx(1.0, abs=1e-9)
    # angular momentum: their moments cancel, so opposite corners carry equal impulses
    assert r_n[0] == pytest.approx(r_n[2], abs=1e-9) and r_n[1] == pytest.approx(r_n[3], abs=1e-9)
    assert np.abs(sol.impulse[:, 1:]).max() < 1e-9      # nothing slides: no friction
    assert np.abs(sol.velocity).max() < 1e-9            # a plastic landing
    assert "solved" in capsys.readouterr().out
