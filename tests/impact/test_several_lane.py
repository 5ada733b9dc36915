"""The several-contact lane of ``resolve_impact`` (convimpact.impact.several.lane): laws ccp and
dissipative at 2-8 open-loop contacts, method "auto"/"interior", no options.

The lane's answers are checked against the full path (``solve_problem(build_problem(...))``,
whose reduction is LAPACK's), against Clarabel (an independent conic solver), and against
momentum and energy computed here by hand; every non-plain case must reach the full path and
its typed errors and notes.
"""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.impact.several.interior import CertificateError
from convimpact.bench.several_problems import four_corner_box, random_several
from convimpact.impact import resolve as resolve_module
from convimpact.impact.several import lane as several_lane
from convimpact.impact.problem.build import build_problem
from convimpact.impact.resolve import solve_problem

pytest.importorskip("numba")


def _cases():
    """Random planar and spatial impacts of 2-8 contacts (e and mu per contact or shared)."""
    out = []
    rng = np.random.default_rng(2024)
    for seed in range(6):
        for n in range(2, 9):
            for dim in (2, 3):
                args = random_several(seed, n, dim)
                if seed % 2:
                    args["e"] = rng.uniform(0.0, 1.0, n).tolist()
                if seed % 3 == 0:
                    args["mu"] = float(rng.uniform(0.0, 1.5))
                out.append(args)
    return out


CASES = _cases()
LAWS = ("ccp", "dissipative")


def _lane(args, law):
    return several_lane.resolve_several(args["M"], args["Jc"], args["dq"], args["e"],
                                        args["mu"], law)


def _full(args, law, method="interior"):
    P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"])
    return solve_problem(P, law, method)


def _close(a, b, rtol, scale=None):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    s = scale if scale is not None else max(float(np.max(np.abs(b))), 1e-300)
    assert float(np.max(np.abs(a - b))) <= rtol * s, (a, b)


def _same_extras(r, f, rtol):
    assert set(r.diagnostics.extras) == set(f.diagnostics.extras)
    for key, value in f.diagnostics.extras.items():
        mine = r.diagnostics.extras[key]
        if isinstance(value, str) or isinstance(value, bool):
            assert mine == value, key
        elif key in ("iterations", "newton_steps"):  # round-off may stop them elsewhere
            assert type(mine) is int and mine >= 0, key
        elif key == "kkt_residual":
            assert mine <= 1e-10 and value <= 1e-10
        else:
            scale = max(float(np.max(np.abs(np.asarray(value, dtype=float)))),
                        float(np.max(np.abs(f.v_minus))))
            _close(mine, value, rtol, scale)


@pytest.mark.parametrize("law", LAWS + ("coulomb",))
def test_the_lane_is_the_full_path_to_round_off(law):
    """ccp, dissipative and coulomb under auto (the two spellings, auto and interior, take
    the same path)."""
    taken = 0
    for args in CASES:
        try:
            r = ci.resolve_impact(**args, law=law,
                                  method="auto")
        except CertificateError:  # Newton missed Coulomb's law: the full path's error too
            assert law == "coulomb"
            with pytest.raises(CertificateError):
                _full(args, law)
            continue
        try:
            f = _full(args, law)
        except CertificateError:
            f = None
        assert r.method == "interior" and r.law == law
        if f is None or type(r.diagnostics._source).__module__ != several_lane.__name__:
            # Newton on Coulomb's law from the CCP answer missed on W's last bits (the full
            # path failed), or the lane's compiled kernel missed its certificate and the full
            # path's contact engine answered: the answer must hold Coulomb's conditions itself
            # (measured on the problem built by LAPACK, by the diagnostics)
            assert law == "coulomb"
            assert r.diagnostics.coulomb_residual <= 1e-9
            assert r.diagnostics.cone_violation <= 1e-9
            assert r.diagnostics.momentum_residual <= 1e-9
            taken += 1
            continue
        # the lane answered (not the full path): its diagnostics are the lane's
        assert type(r.diagnostics._source).__name__ == "_Answer"
        taken += 1
        vs = float(np.max(np.abs(args["dq"])))
        _close(r.impulse, f.impulse, 1e-10)
        _close(r.dq_plus, f.dq_plus, 1e-10, max(vs, float(np.max(np.abs(f.dq_plus)))))
        _close(r.v_plus, f.v_plus, 1e-10, float(np.max(np.abs(f.v_minus))))
        _close(r.v_minus, f.v_minus, 1e-12)
        assert r.regime == f.regime
        assert r.impulse.shape == f.impulse.shape and r.v_plus.shape == f.v_plus.shape
        assert r.loop_impulse.shape == (0,)
        assert abs(r.energy_loss - f.energy_loss) <= 1e-10 * f.diagnostics.energy_before
        _same_extras(r, f, 1e-9)
        assert r.diagnostics.notes == f.diagnostics.notes
        assert r.diagnostics.warnings == f.diagnostics.warnings
        assert r.diagnostics.effective_mass is None
        for name in ("cone_violation", "momentum_residual"):
            assert getattr(r.diagnostics, name) <= 1e-8
        for name in ("restitution_residual", "coulomb_residual"):
            assert getattr(r.diagnostics, name) == pytest.approx(
                getattr(f.diagnostics, name), rel=1e-6, abs=1e-9)
        assert r.diagnostics.energy_gained == f.diagnostics.energy_gained
        assert r.diagnostics.penetration == f.diagnostics.penetration
        np.testing.assert_allclose(r.diagnostics.delassus_condition,
                                   f.diagnostics.delassus_condition, rtol=1e-6)
        np.testing.assert_allclose(r.diagnostics.mass_condition,
                                   f.diagnostics.mass_condition, rtol=1e-10)
    assert taken >= len(CASES) - (2 if law == "coulomb" else 0)


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("mu", [0.0, 0.3, 1.0])
def test_the_box_on_four_corners(law, mu):
    """W is singular (rank 6 of 12): the impulses are not unique, the velocities are."""
    for e in (0.0, 0.5, 1.0):
        args = four_corner_box(mu=mu, e=e)
        r = ci.resolve_impact(**args, law=law)
        f = _full(args, law)
        assert r.method == "interior" and r.regime == f.regime
        _close(r.dq_plus, f.dq_plus, 1e-10, float(np.max(np.abs(args["dq"]))))
        _close(r.v_plus, f.v_plus, 1e-10, float(np.max(np.abs(f.v_minus))))
        # the impulses agree where they are determined: their generalized impulse J^T pi
        J = np.array(args["Jc"])
        _close(np.einsum("idk,id->k", J, r.impulse), np.einsum("idk,id->k", J, f.impulse),
               1e-9)
        assert abs(r.energy_loss - f.energy_loss) <= 1e-10 * f.diagnostics.energy_before
        assert r.diagnostics.warnings == f.diagnostics.warnings


def test_against_clarabel_on_ccp():
    """An independent conic solver: the same velocities and impulses (W nonsingular)."""
    for args in CASES[::3]:
        r = ci.resolve_impact(**args, law="ccp")
        c = ci.resolve_impact(**args, law="ccp", method="clarabel")
        assert r.method == "interior" and c.method == "clarabel"
        _close(r.impulse, c.impulse, 1e-8)
        _close(r.dq_plus, c.dq_plus, 1e-8, float(np.max(np.abs(args["dq"]))))


@pytest.mark.parametrize("law", LAWS)
def test_momentum_and_energy_by_hand(law):
    for args in CASES[::2] + [four_corner_box(mu=0.3), four_corner_box(mu=1.0)]:
        r = ci.resolve_impact(**args, law=law)
        M, dq = args["M"], args["dq"]
        gen = sum(J.T @ p for J, p in zip(args["Jc"], r.impulse))
        _close(M @ (r.dq_plus - dq), gen, 1e-11)
        T0, T1 = 0.5 * dq @ M @ dq, 0.5 * r.dq_plus @ M @ r.dq_plus
        assert abs(r.energy_loss - (T0 - T1)) <= 1e-11 * T0
        np.testing.assert_allclose(r.v_minus, np.array([J @ dq for J in args["Jc"]]),
                                   rtol=0, atol=1e-13 * np.abs(r.v_minus).max())
        np.testing.assert_allclose(r.v_plus, np.array([J @ r.dq_plus for J in args["Jc"]]),
                                   rtol=0, atol=1e-12 * np.abs(r.v_minus).max())


def test_the_dissipative_extras_are_the_laws():
    args = random_several(3, 4, 3)
    args["e"] = [0.2, 0.5, 0.7, 0.9]
    r = ci.resolve_impact(**args, law="dissipative")
    x = r.diagnostics.extras
    plastic = np.array(x["plastic_impulse"])
    e = np.array(args["e"])
    _close(r.impulse, plastic * (1.0 + e)[:, None], 1e-14)
    P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"])
    W, p, Ep = P.delassus, plastic.ravel(), (plastic * e[:, None]).ravel()
    assert abs(x["plastic_energy_loss"] - 0.5 * p @ W @ p) <= 1e-12 * abs(0.5 * p @ W @ p)
    pred = 0.5 * p @ W @ p - 0.5 * Ep @ W @ Ep
    assert abs(x["predicted_energy_loss"] - pred) <= 1e-12 * abs(0.5 * p @ W @ p)


def test_results_are_independent_of_later_changes_to_the_inputs():
    args = random_several(1, 3, 3)
    M, Jc, dq = args["M"].copy(), [J.copy() for J in args["Jc"]], args["dq"].copy()
    r = ci.resolve_impact(M, Jc, dq, args["e"], args["mu"], law="ccp")
    f = _full(args, "ccp")
    M *= 2.0
    Jc[0][:] = 0.0
    dq[:] = np.nan
    r.impulse[:] = 1e9  # even the result's own arrays: the diagnostics kept a copy
    assert r.diagnostics.momentum_residual <= 1e-12
    assert r.diagnostics.energy_before == pytest.approx(f.diagnostics.energy_before, rel=1e-14)
    assert r.diagnostics.mass_condition == pytest.approx(f.diagnostics.mass_condition,
                                                          rel=1e-12)


# -- the cases the lane hands to the full path -----------------------------------------------


def test_an_asymmetric_mass_matrix_goes_to_the_full_path():
    args = random_several(2, 3, 3)
    M = args["M"].copy()
    M[0, 1] *= 1.0 + 1e-13  # symmetric to round-off: the full path symmetrizes it
    assert _lane({**args, "M": M}, "ccp") is None
    r = ci.resolve_impact(**{**args, "M": M}, law="ccp")
    assert type(r.diagnostics._source).__module__ != several_lane.__name__
    M[0, 1] *= 1.1  # truly asymmetric: MassMatrixError
    with pytest.raises(ci.MassMatrixError):
        ci.resolve_impact(**{**args, "M": M}, law="ccp")


def test_a_zero_normal_row_is_noted_by_the_full_path():
    args = random_several(4, 3, 2)
    Jc = [J.copy() for J in args["Jc"]]
    Jc[1][0] = 0.0
    assert _lane({**args, "Jc": Jc}, "ccp") is None
    r = ci.resolve_impact(**{**args, "Jc": Jc}, law="ccp")
    f = _full({**args, "Jc": Jc}, "ccp")
    assert r.regime == f.regime
    np.testing.assert_array_equal(r.dq_plus, f.dq_plus)
    assert any("contact 1: the contact Jacobian's normal row is zero" in n
               for n in r.diagnostics.notes)


@pytest.mark.parametrize("where", ["M", "Jc", "dq"])
def test_nan_raises_non_finite_error(where):
    args = random_several(5, 2, 3)
    if where == "M":
        M = args["M"].copy()
        M[1, 1] = np.nan
        args["M"] = M
    elif where == "Jc":
        args["Jc"] = [J.copy() for J in args["Jc"]]
        args["Jc"][0][1, 2] = np.nan
    else:
        args["dq"] = args["dq"].copy()
        args["dq"][0] = np.nan
    assert _lane(args, "ccp") is None
    with pytest.raises(ci.NonFiniteError):
        ci.resolve_impact(**args, law="ccp")


@pytest.mark.parametrize("e, mu, error", [
    (1.5, 0.3, ci.ParameterError),
    (-0.1, 0.3, ci.ParameterError),
    (0.5, -1.0, ci.ParameterError),
    ("0.5", 0.3, ci.ParameterError),
    (True, 0.3, ci.ParameterError),
    (float("nan"), 0.3, ci.NonFiniteError),
    (0.5, float("inf"), ci.NonFiniteError),
    ([0.5, 0.5, 0.5], 0.3, ci.ShapeError),
])
def test_bad_coefficients_raise_the_full_paths_errors(e, mu, error):
    args = random_several(6, 2, 2)
    args["e"], args["mu"] = e, mu
    assert _lane(args, "ccp") is None
    with pytest.raises(error):
        ci.resolve_impact(**args, law="ccp")


def test_other_inputs_go_to_the_full_path_with_the_same_answer():
    args = random_several(7, 3, 3)
    ref = _full(args, "ccp")
    variants = [
        {"M": args["M"].tolist()},  # lists
        {"dq": args["dq"].tolist()},
        {"Jc": [J.tolist() for J in args["Jc"]]},
        {"Jc": tuple(args["Jc"])},  # a tuple of matrices: not the lane's list
        {"Jc": np.array(args["Jc"])},  # one (n, d, k) array
    ]
    for change in variants:
        r = ci.resolve_impact(**{**args, **change}, law="ccp")
        np.testing.assert_allclose(r.dq_plus, ref.dq_plus, rtol=1e-10, atol=1e-12)
    assert _lane({**args, "M": args["M"].tolist()}, "ccp") is None
    assert _lane({**args, "dq": args["dq"].astype(np.float32)}, "ccp") is None
    # options, loops and other laws or methods are not the lane's
    r = ci.resolve_impact(**args, law="ccp", tol=1e-10)
    assert type(r.diagnostics._source).__module__ != several_lane.__name__
    r = ci.resolve_impact(**args, law="ccp", method="clarabel")
    assert r.method == "clarabel"
    r = ci.resolve_impact(**args, law="coulomb", method="clarabel")
    assert r.method == "clarabel"


def test_separating_contacts_go_to_the_full_path():
    args = random_several(8, 3, 2)
    args["dq"] = np.zeros_like(args["dq"])
    assert _lane(args, "ccp") is None
    r = ci.resolve_impact(**args, law="ccp")
    assert r.regime == ("separating",) * 3
    assert any("no contact is approaching" in n for n in r.diagnostics.notes)


def test_one_contact_in_a_list_is_not_the_lanes():
    args = random_several(9, 1, 3)
    assert _lane(args, "ccp") is None
    r = ci.resolve_impact(**args, law="ccp")
    assert r.method == "fast"


def test_a_certificate_failure_falls_back_as_before():
    """A rigid pinch (W singular, different e on opposing contacts): the interior path's
    certificate fails; "interior" raises CertificateError, "auto" hands the impact to
    Clarabel, which reports the unbounded program itself."""
    Jc = [np.array([[0.0, 1.0], [1.0, 0.0]]), np.array([[0.0, -1.0], [1.0, 0.0]])]
    args = dict(M=np.eye(2), Jc=Jc, dq=np.array([0.3, -1.0]), e=[0.5, 0.0], mu=0.3)
    assert _lane(args, "ccp") is None
    from convimpact.impact.several.interior import CertificateError

    with pytest.raises(CertificateError, match="certificate"):
        ci.resolve_impact(**args, law="ccp", method="interior")
    with pytest.raises(ci.SolverError, match="DualInfeasible"):
        ci.resolve_impact(**args, law="ccp")


#: an open-loop impact (two planar contacts on two coordinates: W singular) whose compiled
#: interior answer fails its certificate (relative residual about 4e-6); the contact engine's
#: vectorized backend and Clarabel solve it
UNCERTIFIED = dict(
    M=np.array([[0.3359787986469245, -0.41709879108954134],
                [-0.41709879108954134, 1.2842036598616486]]),
    Jc=[np.array([[0.7592967566972029, 0.1783784609068236],
                  [-0.5013711116132099, -1.451067021755964]]),
        np.array([[-1.294311297507505, 2.5319526356500632],
                  [-0.30757339855104626, -0.07258034020268184]])],
    dq=np.array([0.6927807931447961, -0.45827458113234576]),
    e=[0.5165933364244722, 0.3108749908022216], mu=[0.3022012466180334, 0.10777348300737677])


def test_an_uncertified_compiled_answer_goes_to_the_engine_and_agrees_with_clarabel():
    """The compiled kernel's answer fails its certificate, the lane hands the impact back, and
    the engine's vectorized backend certifies one; W is singular, so the impulses are not
    unique but the velocities are: Clarabel's (a second method) agree."""
    assert _lane(UNCERTIFIED, "ccp") is None
    r = ci.resolve_impact(**UNCERTIFIED, law="ccp", method="interior")
    auto = ci.resolve_impact(**UNCERTIFIED, law="ccp")
    ref = ci.resolve_impact(**UNCERTIFIED, law="ccp", method="clarabel")
    assert r.method == auto.method == "interior"
    assert r.diagnostics.extras["kkt_residual"] <= 1e-10
    scale = float(np.max(np.abs(ref.v_minus)))
    _close(r.v_plus, ref.v_plus, 1e-8, scale)
    _close(r.dq_plus, ref.dq_plus, 1e-8, float(np.max(np.abs(ref.dq_plus))))


def test_strided_and_read_only_arrays_take_the_lane_without_a_new_compilation():
    """A Fortran-ordered M, a strided dq and read-only arrays are copied into the compiled
    call's one signature (C-contiguous, writeable) rather than compiling another."""
    from convimpact.impact.several import lane_kernel as several_lane_kernels

    args = random_several(11, 3, 3)
    ref = ci.resolve_impact(**args, law="ccp")
    signatures = len(several_lane_kernels.lane_solve.signatures)
    M = np.asfortranarray(args["M"])
    dq = np.repeat(args["dq"], 2)[::2]
    Jc = [J.copy() for J in args["Jc"]]
    for a in (M, dq, *Jc):
        a.flags.writeable = False
    r = ci.resolve_impact(M, Jc, dq, args["e"], args["mu"], law="ccp")
    assert type(r.diagnostics._source).__module__ == several_lane.__name__
    np.testing.assert_array_equal(r.dq_plus, ref.dq_plus)
    assert len(several_lane_kernels.lane_solve.signatures) == signatures
