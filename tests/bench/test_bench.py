"""``convimpact bench``: the quick run end to end, its JSON and charts, and the bench's parts.

No timing is asserted (the machine is shared); what is asserted: the documented keys, PNG
files of real size, errors of the exact paths against independent references, and the parts
(problem generator, timer, peers, BLAS pinning) against numbers derived by hand.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest

import convimpact as ci
from convimpact import cli
from convimpact.bench import BenchConfig, SectionResult, register_section, run_bench
from convimpact.bench import registry
from convimpact.bench.problems import CLASSES, random_impact, random_spd
from convimpact.bench.timing import time_call
from convimpact.errors import ParameterError, UnknownOptionError
from convimpact.impact.problem.build import build_problem


def _png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    return struct.unpack(">II", head[16:24])


def _strict_load(path: Path) -> dict:
    def bad(token):
        raise ValueError(f"non-strict JSON constant {token}")

    return json.loads(path.read_text(), parse_constant=bad)


#: slow: the quick run of the per-impact and landscape sections times every path of every law
#: (on a cold cache it compiles them all: a minute and a half). The fast suite keeps what these
#: tests check: the bench's JSON and charts (test_sections_plug_in below, and each other
#: section's tests), the exact paths against independent references
#: (tests/impact/test_crosscheck_matrix.py, test_fast.py, test_clarabel_backend.py) and
#: Pinocchio's impulse against the closed form (test_pinocchio_peers_against_hand_results).
slow_bench_run = pytest.mark.slow


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    # the sections of this file; later sections (simulation, atlas) test themselves
    code = cli.main(["bench", "--quick", "--out", str(out), "--sections", "per-impact",
                     "landscape"])
    assert code == 0
    return out, _strict_load(out / "bench.json")


@slow_bench_run
def test_json_documented_keys(quick_run):
    out, report = quick_run
    for key in ("schema", "command", "config", "machine", "sections", "summary", "wall_time"):
        assert key in report
    assert report["config"]["quick"] is True and report["config"]["repeat"] == 3
    m = report["machine"]
    for key in ("timestamp", "cpu_model", "cpu_count", "load_average", "versions",
                "blas_threads"):
        assert key in m
    for lib in ("python", "numpy", "scipy", "cvxpy", "clarabel", "pin"):
        assert lib in m["versions"]
    import numpy
    assert m["versions"]["numpy"] == numpy.__version__
    assert set(report["sections"]) == {"per-impact", "landscape"}
    per = report["sections"]["per-impact"]
    rec = per["records"][0]
    for key in ("problem", "class", "law", "method", "setting", "status", "time_full",
                "time_kernel", "impulse_error", "velocity_error", "reference"):
        assert key in rec
    ok = [r for r in per["records"] if r["status"] == "ok"]
    assert ok and all(r["time_full"]["median"] > 0 for r in ok)
    assert all(r["time_full"]["q1"] <= r["time_full"]["median"] <= r["time_full"]["q3"]
               for r in ok)
    # every class of the suite was measured, and every law (plus the frictionless variant)
    assert {r["class"] for r in ok} == set(CLASSES)
    assert {r["law"] for r in ok} == set(ci.LAWS) | {"frictionless"}
    assert per["meta"]["aggregates"] and per["meta"]["problems"]
    # failures are typed library errors with a message, never silent
    for r in per["records"]:
        if r["status"] != "ok":
            assert r["error_type"] and r["message"]
            assert r["peer"] or not r["unexpected"], r
    land = report["sections"]["landscape"]["records"]
    assert land[0]["function"] == "closed_form_landscape"
    assert all(r["points_per_second"] > 0 for r in land), [r for r in land if r.get("error")]
    assert report["summary"] and (out / "summary.txt").read_text().count("fast is") >= 1


@slow_bench_run
def test_charts_are_real_pngs(quick_run):
    out, report = quick_run
    figures = [f for s in report["sections"].values() for f in s["figures"]]
    assert "landscape_throughput.png" in figures
    assert {f"per_impact_{law}.png" for law in ("ccp", "coulomb", "frictionless")} <= set(figures)
    import matplotlib.image as mpimg

    for name in figures:
        path = out / name
        assert path.stat().st_size > 15_000, name
        w, h = _png_size(path)
        assert w >= 600 and h >= 300, (name, w, h)
        img = mpimg.imread(path)
        assert img.std() > 0.05, f"{name} looks blank"


@slow_bench_run
def test_exact_paths_agree_with_independent_references(quick_run):
    _, report = quick_run
    recs = report["sections"]["per-impact"]["records"]

    def errs(law, label, single=True):
        return [r["impulse_error"] for r in recs if r["law"] == law and r["label"] == label
                and r["status"] == "ok" and (r["n_contacts"] == 1) == single]

    # the paper's closed form against the fast quartic kernel (separate implementations)
    cf = errs("pereira-nikravesh", "closed-form")
    assert cf and max(cf) < 1e-12
    # Clarabel at its default tolerance against the exact single-contact kernel, every law
    for law in ("ccp", "coulomb", "dissipative", "frictionless"):
        e = errs(law, "clarabel tol=1e-10")
        assert e and max(e) < 1e-7, (law, e)
    # several contacts: the reference (Clarabel at 1e-12) cross-checked by cvxpy at 1e-12
    refs = report["sections"]["per-impact"]["meta"]["references"]
    several = [x for x in refs if x["reference"] == "clarabel tol=1e-12"
               and x["crosscheck_impulse_error"] is not None]
    assert several and max(x["crosscheck_impulse_error"] for x in several) < 1e-6
    # Pinocchio's impulseDynamics on one frictionless contact: the same closed form
    pin = errs("frictionless", "pinocchio impulseDynamics")
    if report["machine"]["versions"]["pin"]:
        assert pin and max(pin) < 1e-10


def test_random_problem_properties():
    rng = np.random.default_rng(3)
    M = random_spd(rng, 12, 1e4)
    assert np.allclose(M, M.T)
    assert np.linalg.cond(M) == pytest.approx(1e4, rel=1e-8)
    args = random_impact(rng, 10, 3, 3, n_loops=1, cond=1e2, e=0.4, mu=[0.1, 0.2, 0.3])
    C, dq = args["C"], args["dq"]
    assert np.linalg.norm(C @ dq) < 1e-12 * np.linalg.norm(dq)
    for J in args["Jc"]:
        vn = J[0] @ dq
        assert vn < 0 and abs(vn) >= 0.1 * np.linalg.norm(J[0]) * np.linalg.norm(dq) - 1e-12
    P = build_problem(**args)
    # 9 contact rows on k - m = 9 free directions: the Delassus matrix is nonsingular
    assert np.linalg.matrix_rank(P.delassus) == 9


def test_time_call_counts_calls_and_orders_quartiles():
    calls = []
    t, value = time_call(lambda: calls.append(1) or len(calls), repeat=5, min_batch_time=0.0,
                         warmup=2)
    # min_batch_time 0: one call per batch, after two warm-up calls
    assert t.n_inner == 1 and t.n_batches == 5 and len(calls) == 7 and value == 7
    assert 0 < t.best <= t.q1 <= t.median <= t.q3 and t.iqr == pytest.approx(t.q3 - t.q1)


def test_blas_threads_restored():
    from convimpact.bench.threads import blas_threads

    with blas_threads(1) as info:
        during = [lib["during"] for lib in info["libraries"]]
        assert all(d == 1 for d in during)
    with blas_threads(None) as info2:
        assert info2["libraries"] == []
    # the previous counts are back: setting again reports them as "before"
    with blas_threads(1) as info3:
        assert [lib["before"] for lib in info3["libraries"]] == \
            [lib["before"] for lib in info["libraries"]]


def test_pinocchio_peers_against_hand_results():
    pytest.importorskip("pinocchio")
    from convimpact.bench.pinocchio_peers import contact_solver_call, impulse_dynamics_call

    rng = np.random.default_rng(5)
    args = random_impact(rng, 5, 1, 3, cond=10.0, e=0.6, mu=0.0)
    P = build_problem(**args)
    pi, dq_plus = impulse_dynamics_call(P)()
    # frictionless single contact by hand: pi_n = -(1 + e) v_n / (c_n M^-1 c_n) (eq. 38, mu = 0)
    cn = args["Jc"][0]
    vn = cn @ args["dq"]
    pn = -(1 + 0.6) * vn / (cn @ np.linalg.solve(args["M"], cn))
    assert pi[0, 0] == pytest.approx(pn, rel=1e-12) and np.all(pi[0, 1:] == 0)
    assert dq_plus == pytest.approx(args["dq"] + np.linalg.solve(args["M"], cn * pn), rel=1e-10)
    # planar contact embedded in space: ADMM (CCP) inside the cone it solves the stick equation
    args = random_impact(rng, 4, 1, 2, cond=10.0, e=0.5, mu=50.0)
    P = build_problem(**args)
    W, v = P.contact_block(0)
    b = v + np.array([0.5 * v[0], 0.0])
    stick = np.linalg.solve(W, -b)  # W pi + b = 0 (sticking, interior of a wide cone)
    assert stick[0] > 0 and abs(stick[1]) < 50.0 * stick[0]
    lam = contact_solver_call(P, "admm", False, 1e-12)()
    assert lam[0] == pytest.approx(stick, rel=1e-8, abs=1e-10)


def test_sections_plug_in(tmp_path):
    seen = {}

    @register_section("dummy-test", "a section registered by the test")
    def dummy(config, progress):
        progress("dummy running")
        seen["config"] = config
        meta = {"unit": "none"}
        if seen.get("aggregates"):
            meta["aggregates"] = [{"n": 1}]
        return SectionResult("dummy-test", [{"x": 1.0, "y": float("nan")}], [], ["dummy ran"],
                             meta)

    try:
        config = BenchConfig.make(tmp_path, quick=True, repeat=2)
        lines = []
        report = run_bench(config, ["dummy-test"], lines.append)
        assert seen["config"].repeat == 2 and any("dummy running" in x for x in lines)
        data = _strict_load(tmp_path / "bench.json")
        assert data["sections"]["dummy-test"]["records"] == [{"x": 1.0, "y": None}]
        assert data == report
        # the documented keys of every bench.json (the slow quick run checks them on the
        # per-impact and landscape sections too)
        for key in ("schema", "command", "config", "machine", "sections", "summary",
                    "wall_time"):
            assert key in data, key
        for key in ("timestamp", "cpu_model", "cpu_count", "load_average", "versions",
                    "blas_threads"):
            assert key in data["machine"], key
        assert "dummy ran" in (tmp_path / "summary.txt").read_text()
        with pytest.raises(UnknownOptionError, match="dummy-test"):
            run_bench(config, ["no-such-section"], lines.append)
        # records are dropped only where a section keeps aggregates of them
        slim = BenchConfig.make(tmp_path / "slim", quick=True, keep_records=False)
        assert run_bench(slim, ["dummy-test"], lines.append)["sections"]["dummy-test"][
            "records"] == [{"x": 1.0, "y": None}]
        seen["aggregates"] = True
        out = run_bench(slim, ["dummy-test"], lines.append)["sections"]["dummy-test"]
        assert out["records"] == [] and out["records_dropped"] == 1
    finally:
        registry._SECTIONS.pop("dummy-test", None)
    with pytest.raises(ParameterError):
        BenchConfig.make(tmp_path, repeat=0)
