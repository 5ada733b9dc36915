"""Bench sections ``derivatives`` and ``sensitivities``: a quick run's records, charts and
summaries. No timing is asserted (the machine is shared); what is asserted is the independent
check the sections make: central finite differences (of the public ``resolve_impact``, of
whole ``simulate`` runs) agree with the exact derivatives to the differences' own accuracy;
every law with a single-contact derivative (Stronge's included) is measured planar and
spatial, the several-contact rows are there, the finite-difference call counts are the ones
the modules state, and the charts are real PNGs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from convimpact.bench import BenchConfig, section_names
from convimpact.bench.derivatives_section import derivatives_section, fd_calls
from convimpact.bench.derivatives_several import (fd_calls_m_jc, fd_calls_several,
                                                  several_problem)
from convimpact.bench.registry import strict_json
from convimpact.bench.sensitivities_section import directions, make_scene, sensitivities_section
from convimpact.bench.threads import blas_threads

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_derivatives")
    messages: list[str] = []
    with blas_threads(1):
        res = derivatives_section(BenchConfig.make(out, quick=True, repeat=1),
                                  messages.append)
    return out, res, messages


@pytest.fixture(scope="module")
def sens(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_sensitivities")
    messages: list[str] = []
    with blas_threads(1):
        res = sensitivities_section(BenchConfig.make(out, quick=True, repeat=1),
                                    messages.append)
    return out, res, messages


def test_registered():
    assert {"derivatives", "sensitivities"} <= set(section_names())


def test_single_contact_records(run):
    out, res, messages = run
    single = [r for r in res.records if r["part"] == "one contact"]
    assert {(r["law"], r["d"]) for r in single} >= {(law, d) for d in (2, 3) for law in
                                                    ("pereira-nikravesh", "stronge")}
    for r in single:
        assert r["answer_matches"]
        assert r["fd_deviation"] < 1e-7
        assert r["regime"] in ("stick", "slide")
        # k = 6: 6 for dq, 21 symmetric pairs of M, d k for Jc, e and mu, twice
        assert r["fd_calls"] == 2 * (6 + 21 + 6 * r["d"] + 2 + (r["law"] == "chatterjee-ruina"))
        assert r["time_solve"] > 0 and r["time_derivatives"] > 0 and r["time_fd"] > 0
    assert fd_calls(24, 3, False) == 796
    assert "skipped" not in " ".join(res.summary)  # every law has its derivative now
    assert any("stronge spatial" in s and "pure Python" in s for s in res.summary)
    json.dumps(strict_json(res.records))
    assert messages and res.summary


def test_several_contact_records(run):
    out, res, _ = run
    several = [r for r in res.records if r["part"] == "several contacts"]
    assert {r["law"] for r in several} >= {"ccp", "stronge"}
    for r in several:
        n, k = r["n_contacts"], r["k"]
        assert k == 3 * n + 2 and len(r["regime"]) == n
        assert r["answer_matches"]
        assert r["fd_deviation"] < 1e-6  # the independent check
        assert set(r["fd_deviation_by_key"]) == {"dq", "e", "mu"}
        # two calls per entry of dq (k), e (1), mu (n); M's symmetric pairs and Jc's 3 n k
        # entries would need 2 (k (k + 1) / 2 + 3 n k) more
        assert r["fd_calls"] == 2 * (k + 1 + n)
        assert r["fd_calls_m_jc"] == k * (k + 1) + 6 * n * k
        assert r["fd_estimate_all"] == pytest.approx(
            r["time_fd"] / r["fd_calls"] * (r["fd_calls"] + r["fd_calls_m_jc"]))
    assert fd_calls_several(26, 8) == 70 and fd_calls_m_jc(26, 8) == 1950
    assert any("spatial contacts" in s for s in res.summary)


def test_several_problem_is_deterministic_and_approaching():
    M, Jc, dq, e, mu = several_problem(7, 4)
    M2, Jc2, dq2, _, mu2 = several_problem(7, 4)
    np.testing.assert_array_equal(M, M2)
    np.testing.assert_array_equal(dq, dq2)
    assert Jc.shape == (4, 3, 14) and mu.shape == (4,)
    assert np.all(np.linalg.eigvalsh(M) > 0.5)
    assert np.all(np.einsum("ijk,k->ij", Jc, dq)[:, 0] < 0.0)  # every contact approaches


def test_derivative_charts(run):
    out, res, _ = run
    assert res.figures == ["derivatives.png", "derivatives_several.png"]
    for name in res.figures:
        assert (out / name).read_bytes()[:8] == PNG


def test_sensitivities_records(sens):
    out, res, messages = sens
    assert {r["scene"] for r in res.records} == {"bouncing_ball", "sliding_box"}
    for r in res.records:
        assert r["fd_runs_same_events"] and r["default_matches_plain"]
        assert r["fd_runs"] == 2 * r["n_directions"]
        assert r["deviation_state"] < 1e-4  # the independent check: whole runs differenced
        assert r["deviation_mu"] < 1e-4
        assert r["time_plain"] > 0 and r["time_sensitivities"] > 0 and r["time_fd"] > 0
    ball = next(r for r in res.records if r["scene"] == "bouncing_ball")
    assert ball["n_directions"] == 4 and ball["deviation_e"] < 1e-4
    assert ball["events"] == ["impact"]
    box = next(r for r in res.records if r["scene"] == "sliding_box")
    assert box["n_directions"] == 2 and "deviation_e" not in box  # e = 0: range's end
    assert (out / "sensitivities.png").read_bytes()[:8] == PNG
    json.dumps(strict_json(res.records))
    assert messages and len(res.summary) == 3


def test_held_scene_directions_keep_the_corners_on_the_floor():
    """The box rests on both corners: the admissible directions are x and vx alone."""
    scene = make_scene("sliding_box", {"v0": 3.0, "mu": 0.3})
    D, _ = directions(scene)
    assert D.shape == (6, 2)
    np.testing.assert_allclose(np.abs(D[:, 0]), [1, 0, 0, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(np.abs(D[:, 1]), [0, 0, 0, 1, 0, 0], atol=1e-12)
