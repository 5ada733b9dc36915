"""The batch API (convimpact.impact.batch.impacts) against the one-impact path it batches.

Every item of ``resolve_impacts`` must equal ``resolve_impact(..., method="fast")`` to 1e-10
(impulse, dq+, v+, energy loss, effective mass; regime and the four flags exactly; the
tolerance grows with cond(W) beyond 1e4, where the problem itself amplifies the round-off in
which the two paths form W), and every
item of ``contact_impulses`` must equal ``solve_contact``: thousands of random problems per law
and dimension, with frictionless, separating, sticking and sliding contacts, mu up to 1e6, the
stick/slide boundary (mu set to the stick impulse's ratio), no pre-impact slip, singular W, W
scaled to 1e+-120 (the Python kernel's rescaling), shared and per-impact arguments. No timings
are asserted.

numba is optional (the ``batch`` extra; the ``test`` extra installs it): without it this module
is skipped, and :func:`test_without_numba_the_batch_api_raises_not_supported` simulates its
absence where it is installed.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

pytest.importorskip("numba")  # the compiled kernels (an optional dependency)

import convimpact as ci  # noqa: E402
from convimpact.impact.batch import impacts as batch  # noqa: E402
from convimpact.impact.batch.impacts import (REGIMES, STATUS_ERRORS, contact_impulses,  # noqa: E402
                                     resolve_impacts)
from convimpact.impact.exact.dispatch import solve_contact  # noqa: E402

LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative")
TOL = 1e-10
MUS = np.array([0.0, 0.01, 0.1, 0.3, 1.0, 3.0, 1e3, 1e6])


def random_impacts(seed: int, n: int, d: int, k: int | None = None):
    """(M, Jc, dq, e, mu) for n impacts: k in d-1 .. 6 unless given (k < d: singular W),
    a third of them separating, some with no pre-impact slip or mu at the stick boundary."""
    rng = np.random.default_rng(seed)
    ks = rng.integers(d - 1, 7, n) if k is None else np.full(n, k)
    out = []
    for i in range(n):
        ki = int(max(ks[i], 1))
        A = rng.normal(size=(ki, ki))
        Mi = A @ A.T + rng.uniform(0.05, 1.0) * np.eye(ki)
        Ji = rng.normal(size=(d, ki))
        qi = rng.normal(size=ki)
        if i % 3:  # approaching
            if Ji[0] @ qi > 0:
                Ji[0] *= -1.0
        if i % 11 == 5:  # no pre-impact slip, exactly: v_t = Jc[1:] dq = 0
            qi[1:] = 0.0
            Ji[1:, 0] = 0.0
        e = float(rng.choice([0.0, 0.3, 0.5, 1.0]))
        mu = float(rng.choice(MUS))
        boundary = i % 7 == 3
        if boundary:  # the stick/slide boundary: mu = |pi_t| / pi_n of the stick impulse
            W = Ji @ np.linalg.solve(Mi, Ji.T)
            v = Ji @ qi
            try:
                pi = np.linalg.solve(W, -np.r_[(1 + e) * v[0], v[1:]])
                if pi[0] > 0:
                    mu = float(np.linalg.norm(pi[1:]) / pi[0])
            except np.linalg.LinAlgError:
                pass
        out.append((Mi, Ji, qi, e, mu, boundary))
    return out


def words(exc) -> str:
    return re.sub(r"[-+]?\d[\d.e+-]*", "#", str(exc))


def compare_item(b, i, ref, law, dq, boundary=False):
    """Item i of an ImpactBatch against resolve_impact's ImpactResult (or its error).

    On the stick/slide boundary (``boundary``) round-off in W decides the regime (and the
    flags that depend on it) either way; the numbers must agree all the same."""
    if isinstance(ref, Exception):
        assert b.status[i] != batch.OK, (i, ref)
        assert isinstance(ref, STATUS_ERRORS[int(b.status[i])]), (i, ref, b.status[i])
        assert b.regime[i] == batch.FAILED and np.all(np.isnan(b.impulse[i]))
        err = b.error(i)
        assert type(err) is type(ref) and f"impact {i}" in str(err)
        assert words(ref) in words(err)  # the same message, up to the round-off of figures
        return
    assert b.status[i] == batch.OK, (i, ref.regime, b.status[i])
    # both paths solve with W formed in a different order of operations (LAPACK against the
    # compiled loop): beyond cond(W) = 1e4 the problem itself amplifies that round-off
    tol = TOL * max(1.0, 1e-4 * ref.diagnostics.delassus_condition
                    * ref.diagnostics.mass_condition ** 0.5)
    scale_p = max(np.abs(ref.impulse).max(), 1e-300)
    assert np.abs(b.impulse[i] - ref.impulse).max() <= tol * scale_p, (i, law)
    scale_q = max(np.abs(ref.dq_plus).max(), np.abs(dq).max())
    assert np.abs(b.dq_plus[i] - ref.dq_plus).max() <= tol * scale_q, (i, law)
    vs = max(np.abs(ref.v_minus).max(), np.abs(ref.v_plus).max())
    assert np.abs(b.v_plus[i] - ref.v_plus).max() <= tol * vs, (i, law)
    assert np.abs(b.v_minus[i] - ref.v_minus).max() <= tol * vs
    D = ref.diagnostics
    es = max(D.energy_before, abs(D.energy_after), 1e-300)
    assert abs(b.energy_loss[i] - ref.energy_loss) <= tol * es
    assert abs(b.energy_before[i] - D.energy_before) <= tol * D.energy_before
    if boundary and {REGIMES[b.regime[i]], ref.regime} <= {"stick", "slide"}:
        return
    assert REGIMES[b.regime[i]] == ref.regime, (i, law)
    assert (bool(b.energy_gained[i]), bool(b.friction_pushes_slip[i]),
            bool(b.slip_reversal[i]), bool(b.penetration[i])) == (
        D.energy_gained, D.friction_pushes_slip, D.slip_reversal, D.penetration), (i, law)
    if D.effective_mass is None:
        assert math.isnan(b.effective_mass[i])
    else:
        assert b.effective_mass[i] == pytest.approx(D.effective_mass, rel=tol)
    assert b.error(i) is None


def reference(M, J, q, e, mu, law):
    try:
        return ci.resolve_impact(M, J, q, e, mu, law=law, method="fast")
    except ci.ConvImpactError as exc:
        return exc


@pytest.fixture(scope="module")
def problems():
    return {d: random_impacts(100 + d, 1500, d) for d in (2, 3)}


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("law", LAWS)
def test_resolve_impacts_equals_resolve_impact(problems, law, d):
    """Random impacts of every size k = d-1 .. 6 (grouped by k, since a batch has one k)."""
    items = problems[d]
    regimes = set()
    for k in sorted({it[0].shape[0] for it in items}):
        idx = [i for i, it in enumerate(items) if it[0].shape[0] == k]
        M = np.array([items[i][0] for i in idx])
        J = np.array([items[i][1] for i in idx])
        q = np.array([items[i][2] for i in idx])
        e = np.array([items[i][3] for i in idx])
        mu = np.array([items[i][4] for i in idx])
        b = resolve_impacts(M, J, q, e, mu, law)
        assert len(b) == len(idx) and b.dq_plus.shape == (len(idx), k)
        for j, i in enumerate(idx):
            ref = reference(*items[i][:5], law)
            compare_item(b, j, ref, law, q[j], boundary=items[i][5])
            regimes.add(ref.regime if not isinstance(ref, Exception) else type(ref).__name__)
    assert {"separating", "frictionless", "stick", "slide", "SingularSystemError"} <= regimes


def wv_cases(seed: int, n: int, d: int):
    """(W, v, e, mu) including singular W, W scaled by 1e+-120 and 1e+-50, v_t = 0."""
    rng = np.random.default_rng(seed)
    W = np.empty((n, d, d))
    v = np.empty((n, d))
    for i in range(n):
        r = int(rng.integers(1, d + 1)) if i % 9 == 0 else d
        A = rng.normal(size=(d, r))
        W[i] = A @ A.T + (0.0 if i % 9 == 0 else rng.uniform(0, 0.3)) * np.eye(d)
        v[i] = rng.normal(size=d)
        if i % 4:
            v[i, 0] = -abs(v[i, 0])
        if i % 13 == 1:
            v[i, 1:] = 0.0
        if i % 17 == 2:
            W[i] *= 10.0 ** rng.choice([-120, 120, -50, 50])
    e = rng.choice([0.0, 0.5, 1.0], n)
    mu = rng.choice(MUS, n)
    return W, v, e, mu


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("law", LAWS)
def test_contact_impulses_equals_solve_contact(law, d):
    W, v, e, mu = wv_cases(7 + d, 3000, d)
    b = contact_impulses(W, v, e, mu, law)
    seen = set()
    for i in range(len(b)):
        try:
            s = solve_contact(W[i], v[i], e[i], mu[i], law)
        except ci.ConvImpactError as exc:
            assert b.status[i] != batch.OK and isinstance(exc, STATUS_ERRORS[int(b.status[i])])
            assert np.all(np.isnan(b.impulse[i])) and b.regime[i] == batch.FAILED
            seen.add(type(exc).__name__)
            continue
        seen.add(s.regime)
        assert b.status[i] == batch.OK
        scale = max(np.abs(s.impulse).max(), 1e-300)
        assert np.abs(b.impulse[i] - s.impulse).max() <= TOL * scale, i
        assert REGIMES[b.regime[i]] == s.regime
        if s.effective_mass is None:
            assert math.isnan(b.effective_mass[i])
        else:
            assert b.effective_mass[i] == pytest.approx(s.effective_mass, rel=TOL)
        Wi = np.triu(W[i]) + np.triu(W[i], 1).T
        u = Wi @ s.impulse
        vs = max(np.abs(v[i]).max(), np.abs(u).max())
        assert np.abs(b.v_plus[i] - (v[i] + u)).max() <= TOL * vs
        tl = -(s.impulse @ v[i] + 0.5 * s.impulse @ u)
        assert abs(b.energy_loss[i] - tl) <= TOL * max(abs(s.impulse @ v[i]), 1e-300)
    assert {"separating", "stick", "slide", "frictionless", "SingularSystemError"} <= seen


def test_shared_arguments_broadcast():
    rng = np.random.default_rng(3)
    M = np.diag([2.0, 1.0, 0.5])
    Jc = np.array([[0.0, 0.2, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    dq = rng.normal(size=(50, 3))
    dq[:, 2] = -np.abs(dq[:, 2]) - 0.1
    mu = np.linspace(0.0, 2.0, 50)
    for law in LAWS:
        b = resolve_impacts(M, Jc, dq, 0.5, mu, law)
        for i in range(50):
            compare_item(b, i, reference(M, Jc, dq[i], 0.5, mu[i], law), law, dq[i])
        one = resolve_impacts(M, Jc, dq[7], 0.5, mu[7], law)  # nothing batched: N = 1
        assert len(one) == 1 and np.allclose(one.impulse[0], b.impulse[7], rtol=0, atol=0)


def test_immobile_tangent_is_frictionless_and_scales_are_handled():
    # tangent rows that move no mass (build_problem makes such a contact frictionless), and
    # mass matrices so small / large that W's trace leaves fast.dispatch's safe range (the
    # Python kernel rescales them)
    Jc = np.array([[[0.0, -1.0], [0.0, 0.0]], [[1.0, 1.0], [1.0, -1.0]],
                   [[1.0, 1.0], [1.0, -1.0]], [[0.3, 1.0], [1.0, 0.2]]])
    M = np.array([np.eye(2), 1e-110 * np.eye(2), 1e110 * np.eye(2), np.eye(2)])
    dq = np.array([[0.3, 1.0], [0.5, -2.0], [0.5, -2.0], [0.4, -1.0]])
    for law in LAWS:
        b = resolve_impacts(M, Jc, dq, 0.5, 0.4, law)
        for i in range(4):
            compare_item(b, i, reference(M[i], Jc[i], dq[i], 0.5, 0.4, law), law, dq[i])
        assert b.regime[0] == REGIMES.index("frictionless")


def test_readme_particle_and_result_fields():
    M, Jc = 2.0 * np.eye(2), np.array([[0.0, 1.0], [1.0, 0.0]])
    b = resolve_impacts(M, Jc, [1.0, -1.0], e=0.5, mu=[0.0, 0.3, 1.0])
    assert b.regimes() == ("frictionless", "slide", "stick")
    assert b.law == "pereira-nikravesh" and b.method == "fast"
    np.testing.assert_allclose(b.impulse[1], [3.0, -0.9])
    np.testing.assert_allclose(b.v_plus[1], [0.5, 0.55])
    assert b.energy_loss[1] == pytest.approx(1.4475)
    assert b.normal_impulse.shape == (3,) and b.tangential_impulse.shape == (3, 1)
    assert b.ok.all() and b.failed.size == 0
    for name in ("dq_plus", "impulse", "regime", "status", "energy_gained"):
        with pytest.raises(ValueError):
            getattr(b, name)[0] = 0  # read-only
    d = b.as_dict()
    assert d["regime_names"] == list(REGIMES) and len(d["impulse"]) == 3
    empty = resolve_impacts(np.zeros((0, 2, 2)), Jc, [1.0, -1.0])
    assert len(empty) == 0 and empty.dq_plus.shape == (0, 2)


def test_rejected_impacts_are_flagged_or_raised():
    # k = 2 < d = 3: W is singular; the exact kernels (which invert it) reject the impact
    # with friction; the frictionless one (mu = 0) only divides by W_nn
    M = np.eye(2)
    Jc = np.array([[0.0, -1.0], [1.0, 0.0], [1.0, 1.0]])
    dq = np.array([0.5, 1.0])
    mu = np.array([0.5, 0.0])
    for law in LAWS:
        b = resolve_impacts(M, Jc, dq, 0.5, mu, law)
        assert b.status.tolist()[0] == batch.SINGULAR and b.failed.tolist() == [0]
        assert b.regimes()[0] == "failed" and np.isnan(b.dq_plus[0]).all()
        assert not b.energy_gained[0] and b.status[1] == batch.OK
        with pytest.raises(ci.SingularSystemError) as exc:
            ci.resolve_impact(M, Jc, dq, 0.5, 0.5, law=law, method="fast")
        assert words(exc.value) in words(b.error(0))
        with pytest.raises(ci.SingularSystemError, match=r"impact 0 of the batch of 2"):
            resolve_impacts(M, Jc, dq, 0.5, mu, law, on_error="raise")
        c = contact_impulses(b.delassus, b.v_minus, 0.5, mu, law)
        assert c.status[0] == batch.SINGULAR and c.failed.tolist() == [0]
        with pytest.raises(ci.SingularSystemError, match="impact 0"):
            contact_impulses(b.delassus, b.v_minus, 0.5, mu, law, on_error="raise")
    # the status of an error raised by the Python kernel (jams cannot occur for one
    # regular contact: tests/studies/test_atlas.py proves it for the planar seed law)
    assert batch._status_of(ci.NonPositiveEffectiveMassError("x")) == batch.JAM
    assert batch._status_of(ci.SingularSystemError("x")) == batch.SINGULAR
    assert batch._status_of(ci.SolverError("x")) == batch.NO_SOLUTION


@pytest.mark.parametrize("args, error, match", [
    (dict(M=np.eye(2)[None].repeat(3, 0) * [[[1]], [[1]], [[-1]]]), ci.MassMatrixError,
     r"M\[2\] is not positive definite \(impact 2"),
    (dict(M=np.array([np.eye(2), [[1.0, 0.5], [0.0, 1.0]], np.eye(2)])), ci.MassMatrixError,
     r"M\[1\] is not symmetric"),
    (dict(M=np.array([np.eye(2), np.eye(2), [[1.0, np.nan], [np.nan, 1.0]]])),
     ci.NonFiniteError, r"M\[2\]"),
    (dict(dq=np.array([[1.0, -1.0], [np.inf, 0.0], [1.0, -1.0]])), ci.NonFiniteError,
     r"dq\[1\]"),
    (dict(Jc=np.array([[[0.0, 1.0], [1.0, 0.0]]] * 2 + [[[0.0, np.nan], [1.0, 0.0]]])),
     ci.NonFiniteError, r"Jc\[2\]"),
    (dict(e=[0.5, 1.5, 0.5]), ci.ParameterError, r"e\[1\] = 1\.5 \(impact 1\)"),
    (dict(mu=[0.5, 0.2, -0.1]), ci.ParameterError, r"mu\[2\] = -0\.1 \(impact 2\)"),
    (dict(mu=[0.5, np.nan, 0.1]), ci.NonFiniteError, r"mu\[1\]"),
    (dict(mu=[0.5, 0.1]), ci.ShapeError, "batch dimensions disagree"),
    (dict(e=True), ci.ShapeError, "real numbers"),
    (dict(mu=np.array([True, False, True])), ci.ShapeError, "booleans"),
    (dict(dq="fast"), ci.ShapeError, "real numbers"),
    (dict(M=np.eye(2) + 0j), ci.ShapeError, "complex"),
    (dict(Jc=np.ones((3, 4, 2))), ci.ShapeError, "2 x 2"),
    (dict(dq=np.ones((3, 3))), ci.ShapeError, "length 2"),
    (dict(M=np.ones((3, 2, 3))), ci.ShapeError, "square"),
    (dict(law="newton"), ci.UnknownOptionError, "unknown impact law"),
    (dict(on_error="ignore"), ci.UnknownOptionError, "on_error"),
    (dict(C=np.ones((1, 2))), ci.NotSupportedError, "closed loops"),
])
def test_bad_input_raises_typed_errors_naming_the_impact(args, error, match):
    base = dict(M=np.eye(2), Jc=np.array([[0.0, 1.0], [1.0, 0.0]]),
                dq=np.array([[1.0, -1.0]] * 3), e=0.5, mu=0.3, on_error="flag")
    base.update(args)
    with pytest.raises(error, match=match):
        resolve_impacts(**base)


def test_contact_impulses_bad_input():
    W = np.array([[1.0, 0.2], [0.2, 1.0]])
    with pytest.raises(ci.NonFiniteError, match="impact 1"):
        contact_impulses(np.array([W, W * np.nan]), [-1.0, 0.5])
    with pytest.raises(ci.ShapeError, match="d = 2"):
        contact_impulses(np.eye(4), np.ones(4))
    with pytest.raises(ci.ParameterError, match="e = 2"):
        contact_impulses(W, [-1.0, 0.5], e=2.0)
    b = contact_impulses(W, [-1.0, 0.5], 0.5, 0.3)
    assert len(b) == 1 and b.regimes() == (REGIMES[int(b.regime[0])],)


def test_import_compiles_nothing():
    """``import convimpact`` neither imports numba nor the compiled module."""
    import subprocess
    import sys

    code = ("import sys, convimpact, convimpact.impact.batch.impacts; "
            "print('numba' in sys.modules, 'convimpact.impact.batch_kernels' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["False", "False"]


def test_without_numba_the_same_kernels_run_as_plain_python():
    """numba missing (simulated in a fresh process: ``sys.modules["numba"] = None``): one
    RuntimeWarning says so, and the public call and the batch run the same kernels as plain
    Python -- the README's particle by hand: W = I/2, pi_n = (1 + e) / W_nn = 3, a slide with
    pi_t = -mu pi_n, v+ = (0.5, 0.55); at mu = 1 it sticks, v+ = (0.5, 0)."""
    import json
    import subprocess
    import sys

    script = (
        "import sys, warnings, json\n"
        "sys.modules['numba'] = None\n"
        "import numpy as np, convimpact as ci\n"
        "from convimpact.impact.batch import resolve_impacts\n"
        "with warnings.catch_warnings(record=True) as w:\n"
        "    warnings.simplefilter('always')\n"
        "    M, J = 2.0 * np.eye(2), np.array([[0.0, 1.0], [1.0, 0.0]])\n"
        "    r = ci.resolve_impact(M, J, [1.0, -1.0], e=0.5, mu=0.3)\n"
        "    b = resolve_impacts(M, J, [1.0, -1.0], e=0.5, mu=[0.3, 1.0], law='coulomb')\n"
        "print(json.dumps({'v': r.v_plus.tolist(), 'b': b.v_plus.tolist(), 'compiled': "
        "type(ci.impact.laws.pereira_nikravesh._pn_planar).__name__, 'warnings': "
        "[str(x.message) for x in w if issubclass(x.category, RuntimeWarning)]}))\n")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    assert got["compiled"] == "function"  # plain Python, not a numba dispatcher
    np.testing.assert_allclose(got["v"], [0.5, 0.55], rtol=1e-14)
    np.testing.assert_allclose(got["b"], [[0.5, 0.55], [0.5, 0.0]], rtol=1e-14, atol=1e-15)
    assert len(got["warnings"]) == 1 and "plain Python" in got["warnings"][0]


def test_bench_section_batch_runs(tmp_path):
    """``convimpact bench --sections batch`` (quick): records, chart, summary; no timings
    asserted, only that every path was measured and the batch agreed with resolve_impact."""
    from convimpact.bench import BenchConfig, run_bench

    report = run_bench(BenchConfig.make(out=tmp_path, quick=True, repeat=1), ["batch"],
                       lambda message: None)
    sec = report["sections"]["batch"]
    paths = {r["path"] for r in sec["records"]}
    assert paths == {"resolve_impacts", "resolve_impacts 1 thread", "contact_impulses",
                     "loop solve_contact", "loop resolve_impact"}
    assert all(r["impacts_per_second"] > 0 for r in sec["records"])
    for agg in sec["meta"]["aggregates"]:
        assert agg["max_deviation_vs_resolve_impact"] < 1e-10
        assert agg["failure_mismatches"] == 0
    assert (tmp_path / sec["figures"][0]).stat().st_size > 0
    assert any("impacts/s" in s for s in sec["summary"])


@pytest.mark.parametrize("d", [2, 3])
def test_stronge_batch_equals_resolve_impact(d):
    """law 'stronge': planar items by the compiled port of the exact piecewise-linear kernel,
    spatial ones deferred to the Python kernel -- item i equals resolve_impact(...,
    method="fast") (to the round-off of W formed by a different Cholesky), rejected items
    flagged with their typed error."""
    items = random_impacts(700 + d, 60, d, k=4)
    M, Jc, dq = (np.array([it[j] for it in items]) for j in range(3))
    e, mu = (np.array([it[j] for it in items]) for j in (3, 4))
    b = resolve_impacts(M, Jc, dq, e, mu, "stronge")
    assert b.law == "stronge"
    for i in range(len(b)):
        ref = reference(M[i], Jc[i], dq[i], e[i], mu[i], "stronge")
        if isinstance(ref, Exception):
            compare_item(b, i, ref, "stronge", dq[i])
            continue
        assert b.status[i] == batch.OK and b.regimes()[i] == ref.regime
        # W formed by two Cholesky orders: cond(W) amplifies their round-off (as compare_item)
        D = ref.diagnostics
        tol = 1e-9 * max(1.0, 1e-4 * D.delassus_condition * D.mass_condition ** 0.5)
        scale = max(float(np.max(np.abs(ref.dq_plus))), float(np.max(np.abs(dq[i]))))
        assert np.max(np.abs(b.dq_plus[i] - ref.dq_plus)) <= tol * scale, i
        assert b.energy_gained[i] == ref.diagnostics.energy_gained
        assert b.slip_reversal[i] == ref.diagnostics.slip_reversal
    c = contact_impulses(b.delassus, b.v_minus, e, mu, "stronge")
    ok = b.status == batch.OK
    np.testing.assert_array_equal(c.status, b.status)
    np.testing.assert_allclose(c.impulse[ok], b.impulse[ok], rtol=0, atol=0)
    assert not b.energy_gained.any()


def test_threads_split_the_batch_without_changing_a_bit():
    """A batch above PARALLEL_MIN split over threads equals the one-thread batch bit for bit,
    and a bad item in the second slice is still the one the error names."""
    rng = np.random.default_rng(77)
    n, k = batch.PARALLEL_MIN + 1001, 4
    A = rng.normal(size=(n, k, k))
    M = A @ A.transpose(0, 2, 1) + 0.5 * np.eye(k)
    J = rng.normal(size=(n, 3, k))
    dq = rng.normal(size=(n, k))
    e, mu = rng.uniform(size=n), rng.uniform(0, 1.5, size=n)
    one = batch.resolve_impacts(M, J, dq, e, mu, law="coulomb", threads=1)
    two = batch.resolve_impacts(M, J, dq, e, mu, law="coulomb", threads=2)
    for name in ("dq_plus", "impulse", "v_plus", "regime", "status", "energy_loss"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))
    c1 = batch.contact_impulses(one.delassus, one.v_minus, e, mu, "ccp", threads=1)
    c2 = batch.contact_impulses(one.delassus, one.v_minus, e, mu, "ccp", threads=3)
    np.testing.assert_array_equal(c1.impulse, c2.impulse)
    bad = M.copy()
    bad[n - 5, 0, 0] = np.nan
    with pytest.raises(ci.NonFiniteError, match=f"impact {n - 5}"):
        batch.resolve_impacts(bad, J, dq, e, mu, threads=2)
    for wrong in (0, True, 1.5, "2"):
        with pytest.raises(ci.ParameterError):
            batch.resolve_impacts(M[:3], J[:3], dq[:3], e[:3], mu[:3], threads=wrong)
