"""The force distribution's programs answered without the cone solver, each against a second
method:

* stage 2 of max_margin_distribution (the least-norm distribution in the shell of margins
  >= t* - 1e-12) by the primal-dual active-set polish from the unconstrained minimizer:
  on the box stack's two shell programs (its tip and its top box's slip onset) it
  certifies, and equals Clarabel's solution of the same program posed here (elsewhere,
  where it does not certify, the solver's start is taken as before).
"""

from __future__ import annotations

import clarabel
import numpy as np
import scipy.sparse as sp

from convimpact.scenes import load_scene
from convimpact.simulation import force_distribution, simulate
from convimpact.simulation.force_distribution_polish import _polish_least_norm


def _clarabel(P, q, A, b, cones):
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-10
    kinds = {"nn": clarabel.NonnegativeConeT, "soc": clarabel.SecondOrderConeT}
    out = clarabel.DefaultSolver(sp.csc_matrix(np.triu(P)), q, sp.csc_matrix(A), b,
                                 [kinds[k](m) for k, m in cones], settings).solve()
    assert str(out.status) in ("Solved", "AlmostSolved")  # (a thin shell: often Almost)
    return np.asarray(out.x)


def _shell_by_the_solver(shell, g):
    A = np.vstack([blk[1] for blk in shell])
    b = np.concatenate([blk[2] for blk in shell])
    return _clarabel(np.eye(g.size), g, A, b, [(blk[0], len(blk[2])) for blk in shell])


def test_the_stacks_shell_programs_are_solved_without_the_solver(monkeypatch):
    stack = load_scene("box_stack", t_end=0.7)
    shells, solver_runs = [], []
    least_norm = force_distribution._least_norm_in_shell
    raw = force_distribution._solve_raw

    def kept(shell, g):
        shells.append((shell, g))
        return least_norm(shell, g)

    def counted(*args):
        solver_runs.append(args[0].shape)
        return raw(*args)
    monkeypatch.setattr(force_distribution, "_least_norm_in_shell", kept)
    monkeypatch.setattr(force_distribution, "_solve_raw", counted)
    simulate(stack.mechanism, (0.0, stack.t_end), (stack.theta0, stack.dtheta0),
             breakpoints=[stack.parameters["t_push"]])
    assert len(shells) == 2  # the tip's and the slip onset's chosen combinations
    assert solver_runs == []  # neither needed the solver
    for shell, g in shells:
        y = _polish_least_norm(shell, g, -g, np.zeros(sum(len(blk[2]) for blk in shell)))
        assert y is not None
        np.testing.assert_allclose(y, _shell_by_the_solver(shell, g), rtol=0, atol=1e-5)
