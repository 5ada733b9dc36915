"""The laws' compiled kernels run as plain Python (``NUMBA_DISABLE_JIT=1``): the same code,
debuggable and patchable. Run in subprocesses, with the answers checked in this process against
independent oracles (brute-force maximal dissipation, Coulomb's conditions, the KKT residual of
the CCP program) -- never against the compiled run alone.

The fallbacks of the boundary algebra are exercised by sabotage, which only plain Python
allows: Ferrari's quartic finds no root and Newton does not move, so every law's certificate
must send the solve to the companion-matrix roots (:func:`_eigen_quartic`); with those
sabotaged too, the certificates must turn a wrong root into SolverError.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from .convex_systems import ccp_residual, coulomb_conditions
from .test_fast import brute_max_dissipation, energy_loss_eq60, newton_b

LAWS4 = ("pereira-nikravesh", "coulomb", "ccp", "dissipative")


def _cases(n: int = 6) -> list:
    """Random spatial contacts on which Coulomb's law slides at e = 0.5, mu = 0.8."""
    from convimpact.impact.exact.dispatch import solve_contact

    rng = np.random.default_rng(5)
    cases = []
    while len(cases) < n:
        A = rng.normal(size=(3, 3))
        W = A @ A.T + 0.1 * np.eye(3)
        v = rng.normal(size=3)
        v[0] = -abs(v[0])
        if solve_contact(W, v, 0.5, 0.8, "coulomb").regime == "slide":
            cases.append((W.tolist(), v.tolist()))
    return cases


_SCRIPT = textwrap.dedent('''
    import json, sys
    import numpy as np
    import convimpact.impact.laws.algebra as algebra
    from convimpact.impact.exact.dispatch import solve_contact
    import convimpact.errors as errors

    cases, laws, sabotage, e, mu = json.loads(sys.stdin.read())

    def patch(name, fn):
        # the kernels call the algebra through module globals: patch every module holding it
        for mod in list(sys.modules.values()):
            if getattr(mod, "__name__", "").startswith("convimpact.") and \\
                    getattr(mod, name, None) is getattr(algebra, name):
                setattr(mod, name, fn)

    for law in laws:  # import the law modules before patching their globals
        try:
            solve_contact(np.eye(3), [-1.0, 0.0, 0.0], e, mu, law)
        except errors.ConvImpactError:
            pass
    if sabotage >= 1:  # Ferrari finds nothing, Newton does not move
        patch("_quartic", lambda c4, c3, c2, c1, c0: (0, 0.0, 0.0, 0.0, 0.0))
        patch("_polish", lambda c4, c3, c2, c1, c0, t: t)
    if sabotage >= 2:  # and the companion matrix finds nothing either
        patch("_eigen_quartic", lambda c4, c3, c2, c1, c0: (0, 0.0, 0.0, 0.0, 0.0))
    out = []
    for W, v in cases:
        row = {}
        for law in laws:
            try:
                sol = solve_contact(np.array(W), np.array(v), e, mu, law)
                row[law] = {"impulse": sol.impulse.tolist(), "regime": sol.regime,
                            "extras": {k: x for k, x in sol.extras.items()
                                       if k in ("direction", "n_slide_solutions")}}
            except errors.ConvImpactError as exc:
                row[law] = {"error": type(exc).__name__}
        out.append(row)
    print(json.dumps(out))
''')


def _run(cases, laws, sabotage: int, e: float, mu: float, jit: bool = False) -> list:
    env = dict(os.environ)
    if jit:
        env.pop("NUMBA_DISABLE_JIT", None)
    else:
        env["NUMBA_DISABLE_JIT"] = "1"
    proc = subprocess.run([sys.executable, "-c", _SCRIPT], input=json.dumps(
        [cases, list(laws), sabotage, e, mu]), capture_output=True, text=True, env=env,
        timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _oracle(W, v, e, mu, law, impulse, extras) -> bool:
    """Whether one law's answer passes its independent oracle."""
    W, v, pi = np.array(W), np.array(v), np.array(impulse)
    if law == "pereira-nikravesh":
        if "direction" not in extras:
            return True  # the stick test (a linear solve) decided
        t = np.array(extras["direction"])
        tl_ref, _ = brute_max_dissipation(W, v, e, mu)
        return abs(float(energy_loss_eq60(W, v, e, mu, t)[0]) - tl_ref) <= 1e-10 * abs(tl_ref)
    if law == "coulomb":
        return coulomb_conditions(W, newton_b(v, e), [mu], 3, pi) < 1e-10
    if law == "ccp":
        return ccp_residual(W, newton_b(v, e), [mu], 3, pi) < 1e-10
    return ccp_residual(W, v, [mu], 3, pi / (1 + e)) < 1e-10  # dissipative


def _check_oracles(W, v, e, mu, row) -> None:
    for law in LAWS4:
        assert _oracle(W, v, e, mu, law, row[law]["impulse"], row[law]["extras"]), law


@pytest.mark.slow
def test_plain_python_kernels_agree_with_the_oracles_and_the_compiled_run():
    # slow (a cold cache compiles every law's spatial kernels in its compiled subprocess); the
    # fast suite runs the same plain-Python kernels against the same oracles under sabotage
    # (below), Stronge's in tests/impact/test_batch_stronge_spatial.py and the CCP's in
    # tests/impact/test_ccp_kernels.py
    cases, e, mu = _cases(), 0.5, 0.8
    plain = _run(cases, LAWS4 + ("stronge",), 0, e, mu)
    compiled = _run(cases, LAWS4 + ("stronge",), 0, e, mu, jit=True)
    for (W, v), row, crow in zip(cases, plain, compiled):
        _check_oracles(W, v, e, mu, row)
        for law in LAWS4 + ("stronge",):
            # the same code: plain Python and machine code agree to round-off
            np.testing.assert_allclose(row[law]["impulse"], crow[law]["impulse"],
                                       rtol=1e-12, atol=1e-14)
            assert row[law]["regime"] == crow[law]["regime"]


def test_certificates_fall_back_to_companion_roots_then_raise():
    cases, e, mu = _cases(), 0.5, 0.8
    sabotaged = _run(cases, LAWS4, 1, e, mu)
    for (W, v), row in zip(cases, sabotaged):
        _check_oracles(W, v, e, mu, row)
    # with the companion matrix sabotaged as well, the certificates turn a wrong root into
    # SolverError -- never a silently wrong answer (an answer still given must pass its oracle)
    broken = _run(cases, LAWS4, 2, e, mu)
    raised = set()
    for (W, v), row in zip(cases, broken):
        for law in LAWS4:
            if "error" in row[law]:
                assert row[law]["error"] == "SolverError", (law, row[law])
                raised.add(law)
            else:
                assert _oracle(W, v, e, mu, law, row[law]["impulse"], row[law]["extras"]), law
    assert {"pereira-nikravesh", "ccp", "dissipative"} <= raised
