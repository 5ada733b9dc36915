"""The lean public path of several contacts (``resolve_impact`` -> ``build_problem`` ->
``method="interior"`` -> ``assemble_result``): the compiled contact checks, the single
compiled solver call and the lazily formed lists change no answer, note or diagnostic.

Oracles: Clarabel's conic path (to 1e-8); the Delassus matrix, the contact classification and
the energy recomputed here from the raw data in plain numpy (``Jc M^-1 Jc^T`` by a solve,
the degenerate and immobile rules of the module's docstring, ``T = 1/2 dq^T M dq``); and the
same problem built field by field (``dataclasses.replace``, whose derived caches take the
Python route).
"""

import dataclasses

import numpy as np
import pytest

import convimpact as ci
from convimpact.bench.several_problems import four_corner_box, random_several
from convimpact.impact.problem.build import IMMOBILE_RTOL, build_problem
from convimpact.impact.resolve import solve_problem


def _relative(a, b):
    return np.abs(np.asarray(a) - np.asarray(b)).max() / max(np.abs(b).max(), 1e-300)


def _cases():
    yield "box", four_corner_box()
    for dim in (2, 3):
        for n in (2, 4, 8):
            yield f"d{dim}n{n}", random_several(3, n, dim)


CASES = dict(_cases())


@pytest.mark.parametrize("name", sorted(CASES))
def test_public_ccp_matches_clarabel_and_its_own_energy(name):
    args = CASES[name]
    r = ci.resolve_impact(**args, law="ccp")
    assert r.method == "interior"
    ref = ci.resolve_impact(**args, law="ccp", method="clarabel")
    assert _relative(r.dq_plus, ref.dq_plus) <= 1e-8
    assert _relative(r.v_plus, ref.v_plus) <= 1e-8
    assert r.regime == ref.regime
    # the energy loss is T- - T+ of the velocities themselves (eq. 58)
    M, dq = args["M"], args["dq"]
    T = 0.5 * dq @ M @ dq
    loss = T - 0.5 * r.dq_plus @ M @ r.dq_plus
    assert abs(r.energy_loss - loss) <= 1e-10 * T
    # the extras: the normal-velocity lift and mu |v_t+| per contact, from the answer
    e = np.broadcast_to(args["e"], r.v_minus.shape[:1])
    mu = np.broadcast_to(args["mu"], r.v_minus.shape[:1])
    lift = r.v_plus[:, 0] + e * np.minimum(r.v_minus[:, 0], 0.0)
    slip = mu * np.linalg.norm(r.v_plus[:, 1:], axis=1)
    scale = np.abs(r.v_minus).max()
    ex = r.diagnostics.extras
    assert np.abs(np.array(ex["normal_velocity_lift"]) - lift).max() <= 1e-12 * scale
    assert np.abs(np.array(ex["mu_times_slip"]) - slip).max() <= 1e-12 * scale * mu.max()


@pytest.mark.parametrize("name", sorted(CASES))
def test_problem_equals_plain_numpy_and_its_field_by_field_twin(name):
    args = CASES[name]
    P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"])
    J = np.asarray(args["Jc"], dtype=float).reshape(-1, args["M"].shape[0])
    W = J @ np.linalg.solve(args["M"], J.T)
    assert _relative(P.delassus, W) <= 1e-12
    assert np.array_equal(P.delassus, P.delassus.T)  # symmetrized exactly
    assert np.array_equal(P.v_minus.ravel(), J @ args["dq"])
    assert P.notes == ()
    assert P.approaching == tuple(bool(x) for x in P.v_minus[:, 0] < 0.0)
    assert P._lists == (P.delassus.tolist(), P.v_minus.ravel().tolist())
    twin = dataclasses.replace(P)  # its caches formed by __post_init__ (the Python route)
    assert twin._lists == P._lists and twin.approaching == P.approaching
    for law in ("ccp", "dissipative", "coulomb"):
        a = solve_problem(P, law, "interior")
        b = solve_problem(twin, law, "interior")
        assert np.array_equal(a.dq_plus, b.dq_plus) and a.regime == b.regime
        assert a.energy_loss == b.energy_loss
        assert a.diagnostics.as_dict() == b.diagnostics.as_dict()
    # the public call takes the compiled lane (its own Cholesky, not LAPACK's): the same
    # velocities to round-off (dq+ is unique even where W is singular and pi is not)
    r = ci.resolve_impact(**args, law="ccp")
    full = solve_problem(P, "ccp")
    assert _relative(r.dq_plus, full.dq_plus) <= 1e-12 and r.regime == full.regime


def test_immobile_tangents_and_a_zero_normal_row_keep_their_rules():
    """The compiled checks hand these to the Python rules: a contact whose tangents move no
    mass is frictionless; a zero normal row is noted."""
    args = random_several(5, 4, 3)
    Jc = [j.copy() for j in args["Jc"]]
    Jc[1][1:] = 0.0
    P = build_problem(args["M"], Jc, args["dq"], args["e"], args["mu"])
    W = P.delassus
    d = np.diag(W)
    immobile = [max(d[3 * i + 1:3 * i + 3]) <= IMMOBILE_RTOL * d.max() for i in range(4)]
    assert immobile == [False, True, False, False]
    assert P.friction[1] == 0.0
    assert np.array_equal(np.delete(P.friction, 1), np.delete(np.asarray(args["mu"]), 1))
    Jc = [j.copy() for j in args["Jc"]]
    Jc[2][0] = 0.0
    r = ci.resolve_impact(args["M"], Jc, args["dq"], args["e"], args["mu"], law="ccp")
    assert any("contact 2: the contact Jacobian's normal row is zero" in w
               for w in r.diagnostics.warnings)
    ref = ci.resolve_impact(args["M"], Jc, args["dq"], args["e"], args["mu"], law="ccp",
                            method="clarabel")
    assert _relative(r.dq_plus, ref.dq_plus) <= 1e-8


@pytest.mark.parametrize("bad, error", [
    (dict(mu=[0.1, float("nan")]), ci.NonFiniteError),
    (dict(mu=[0.1, -0.2]), ci.ParameterError),
    (dict(mu=[0.1, 0.2, 0.3]), ci.ShapeError),
    (dict(dq=[np.nan, 0, 0, 0, 0, 0]), ci.NonFiniteError),
])
def test_bad_input_on_the_lean_path_raises_the_same_typed_errors(bad, error):
    args = {**random_several(1, 2, 2), **bad}
    with pytest.raises(error):
        ci.resolve_impact(**args, law="ccp")


def test_a_non_finite_delassus_entry_is_still_caught():
    args = random_several(2, 3, 3)
    M = args["M"].copy()
    M[4, 4] = np.inf
    with pytest.raises((ci.NonFiniteError, ci.MassMatrixError)):
        ci.resolve_impact(M, args["Jc"], args["dq"], args["e"], args["mu"], law="ccp")
    Jc = [j.copy() for j in args["Jc"]]
    Jc[0][1, 0] = 1e200
    with pytest.raises(ci.NonFiniteError), np.errstate(over="ignore"):
        ci.resolve_impact(args["M"], Jc, args["dq"] * 1e200, args["e"], args["mu"], law="ccp")
