"""The first-stage program of max_margin_distribution (the largest smallest margin t*) solved
by the compiled interior-point cold start and certified by the Newton polish
(simulation/force_cold_start.py, force_interior_kernels.py), against second methods:

* a closed form: four sticking corners of a body on a plane under m g and a tangential load T
  through their centroid, t* = (mu m g - T) / 4 (test_sustained_margin_programs.py);
* Clarabel's optimum of the same program, on random programs (spatial stick and slip modes,
  random distributions and redundancies) and on every first-stage program of the box stack;
* the program of the box stack where the polish's certificate must not fire (degenerate:
  Newton's polish does not converge in the cones from the interior point, nor from
  Clarabel's): the interior point is accepted there on the residuals Clarabel's answer is
  held to (1e-8), and refused where they are asked to 1e-14.
"""

from __future__ import annotations

import clarabel
import numpy as np
import pytest
import scipy.sparse as sp

from convimpact.scenes import load_scene
from convimpact.simulation import force_distribution, simulate
from convimpact.simulation.force_cold_start import cold_max_min
from convimpact.simulation.force_distribution import SLIP, STICK, _margin_blocks

from .test_force_dual import SCALE, _blocks
from .test_sustained_margin_programs import _largest


def _by_clarabel(blocks):
    """t* of the program by Clarabel (its own settings here: tolerances 1e-10)."""
    A = np.vstack([blk[1] for blk in blocks])
    b = np.concatenate([blk[2] for blk in blocks])
    w = np.concatenate([blk[3] for blk in blocks])
    r = A.shape[1]
    q = np.zeros(r + 1)
    q[r] = -1.0
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-10
    kinds = {"nn": clarabel.NonnegativeConeT, "soc": clarabel.SecondOrderConeT}
    sol = clarabel.DefaultSolver(sp.csc_matrix((r + 1, r + 1)), q,
                                 sp.csc_matrix(np.hstack([A, w[:, None]])), b,
                                 [kinds[blk[0]](len(blk[2])) for blk in blocks],
                                 settings).solve()
    return str(sol.status), float(sol.x[r])


def _margins(blocks, y):
    """Each block's margin at y (tau = 0): s0 - |s1| of a cone, s of a half-line."""
    out = []
    for kind, A, b, w in blocks[:-1]:
        s = b - A @ y
        out.append(s[0] - np.linalg.norm(s[1:]) if kind == "soc" else float(s.min()))
    return np.array(out)


@pytest.mark.parametrize("T", [1.0, 4.9, 6.0, 8.0])
def test_the_closed_form_margin_of_four_sticking_corners(T):
    _, _, blocks = _blocks(T)
    got = cold_max_min(blocks, 1e-8)
    assert got is not None and got[3] is not None  # certified
    assert got[1] == pytest.approx(_largest(T) / SCALE, abs=1e-12)
    # its maximizer reaches t*: every margin at least t* (a primal certificate, here)
    assert _margins(blocks, got[0]).min() >= got[1] - 1e-12


@pytest.mark.parametrize("d", [2, 3])
def test_random_programs_agree_with_clarabel(d):
    """Planar (stick: two half-planes) and spatial (stick: a second-order cone) modes."""
    rng = np.random.default_rng(7 + d)
    certified = 0
    for _ in range(60):
        n = int(rng.integers(2 if d == 2 else 3, 7))
        combo = [STICK if rng.uniform() < 0.7 else SLIP for _ in range(n)]
        mu = rng.uniform(0.2, 1.0, n)
        lam0 = rng.normal(size=(n, d))
        lam0[:, 0] = rng.uniform(0.0, 2.0, n)
        r = int(rng.integers(1, min(7, d * n)))
        Q, _ = np.linalg.qr(rng.normal(size=(d * n, r)))
        blocks = _margin_blocks(mu, d, combo, lam0.ravel(), Q)
        blocks.append(("nn", np.zeros((1, r)), np.ones(1), np.ones(1)))
        status, t_ref = _by_clarabel(blocks)
        got = cold_max_min(blocks, 1e-8)
        if got is None:
            continue
        certified += 1
        assert status in ("Solved", "AlmostSolved")
        assert got[1] == pytest.approx(t_ref, abs=1e-8)
        assert min(_margins(blocks, got[0]).min(), 1.0) >= got[1] - 1e-11
    assert certified >= 55  # (where it does not certify, the solver answers)


def test_the_box_stacks_programs_without_the_solver(monkeypatch):
    stack = load_scene("box_stack")
    seen, solver_runs = [], []
    clarabel_call = force_distribution._clarabel

    def kept(blocks, rtol):
        got = cold_max_min(blocks, rtol)
        seen.append((blocks, got))
        return got

    def counted(*args):
        solver_runs.append(1)
        return clarabel_call(*args)
    monkeypatch.setattr(force_distribution, "cold_max_min", kept)
    monkeypatch.setattr(force_distribution, "_clarabel", counted)
    res = simulate(stack.mechanism, (0.0, stack.t_end), (stack.theta0, stack.dtheta0),
                   breakpoints=[stack.parameters["t_push"]])
    back = [iv.t_start for iv in res.modes_of("box0_c0") if iv.mode == "open"]
    p = stack.parameters
    assert abs(back[0] - p["tip_time"]) / p["tip_time"] < 1e-8  # (the answer: 1.1e-9)
    assert len(seen) == 5 and not solver_runs  # every first-stage program without it
    for blocks, got in seen:
        status, t_ref = _by_clarabel(blocks)
        assert got[1] == pytest.approx(t_ref, abs=1e-8)
    unpolished = [blocks for blocks, got in seen if got[3] is None]
    assert len(unpolished) == 1
    # that program is degenerate: Clarabel's own point does not polish either ...
    blocks = unpolished[0]
    A = np.vstack([blk[1] for blk in blocks])
    w = np.concatenate([blk[3] for blk in blocks])
    b = np.concatenate([blk[2] for blk in blocks])
    q = np.zeros(A.shape[1] + 1)
    q[-1] = -1.0
    sol = clarabel_call(np.zeros((q.size, q.size)), q, np.hstack([A, w[:, None]]), b,
                        [(blk[0], len(blk[2])) for blk in blocks])
    polished = force_distribution._polish_max_min(blocks, np.asarray(sol.x), np.asarray(sol.z))
    assert polished[3] is None
    # ... and its interior point is refused where the residuals are asked to 1e-14
    assert cold_max_min(blocks, 1e-14) is None


def test_blocks_outside_its_form_are_left_to_the_solver():
    _, _, blocks = _blocks(4.0)
    kind, A, b, w = blocks[0]
    tilted = [(kind, A, b, np.array([1.0, 0.1, 0.0]))] + blocks[1:]
    assert cold_max_min(tilted, 1e-8) is None
