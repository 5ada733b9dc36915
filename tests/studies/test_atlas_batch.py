"""The atlas's "fast" paths through the compiled batch (``resolve_impacts``) on the open-loop
pendulum maps, checked against an independent per-sample classification.

The reference is one :func:`~convimpact.studies.atlas.classify_impact` call per sample and
path (one ``resolve_impact`` each), accumulated here cell by cell; the map must show exactly
the same flags, counts, separating samples and sample counts. Double pendulum (rods L = 1,
relative angles): the tip's Jacobian columns are ``L (p(a1) + p(a1 + a2), p(a1 + a2))`` with
``p(a) = (-sin a, cos a)``, so at a2 = 0 (stretched) the first column is twice the second,
Jc has rank one and so has W = Jc M^-1 Jc^T: a law that inverts W meets a singular system.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import convimpact.impact.batch.impacts as batch
from convimpact.errors import NotSupportedError
from convimpact.problems._double_pendulum import build
from convimpact.studies.atlas import (IMPACT_MODES, PENDULUM_RATES, classify_error,
                                      classify_impact, pendulum_angle_map,
                                      pendulum_friction_map, slider_crank_map)
from convimpact.studies.atlas_modes import _batch_fast, _Sample

pytest.importorskip("numba")  # the compiled batch (an optional dependency)

PEND = build(True, 1.0, 1.0, -2.0, 0.5, 0.3).mechanism()
FAST_PATHS = (("pereira-nikravesh", "fast"), ("coulomb", "fast"), ("ccp", "fast"),
              ("dissipative", "fast"), ("stronge", "fast"))
# one path that never batches, mixed in: the map must keep it per sample
PATHS = FAST_PATHS + (("pereira-nikravesh", "closed-form"),)


def _cell(a1: float, a2: float) -> tuple[np.ndarray, np.ndarray]:
    th = np.array([a1, a2])
    return (np.asarray(PEND.mass_matrix(th), float),
            np.asarray(PEND.contact_jacobian("tip", th), float))


def _reference(cells, shape, samples_of):
    """Flags, counts, separating and samples from one classify_impact per sample and path.

    ``cells`` yields (iy, ix, M, J); ``samples_of`` gives the cell's (dq, e, mu) list."""
    labels = [f"{law}/{method}" for law, method in PATHS]
    flags = {p: {m: np.zeros(shape, bool) for m in IMPACT_MODES} for p in labels}
    counts = {p: {m: 0 for m in IMPACT_MODES} for p in labels}
    separating = np.zeros(shape, int)
    samples = np.zeros(shape, int)
    for iy, ix, M, J in cells:
        for dq, e, mu in samples_of(iy, ix):
            samples[iy, ix] += 1
            seen = set()
            for (law, method), p in zip(PATHS, labels):
                modes = classify_impact(M, J, dq, e, mu, law=law, method=method)
                seen.add(modes == ("separating",))
                for m in modes:
                    if m != "separating":
                        flags[p][m][iy, ix] = True
                        counts[p][m] += 1
            assert len(seen) == 1  # every path agrees on whether the contact approaches
            separating[iy, ix] += seen.pop()
    return flags, counts, separating, samples


def _assert_same(amap, ref):
    flags, counts, separating, samples = ref
    assert np.array_equal(amap.samples, samples)
    assert np.array_equal(amap.separating, separating)
    for p in flags:
        assert dict(amap.counts[p]) == counts[p], p
        for m in IMPACT_MODES:
            assert np.array_equal(amap.flags[p][m], flags[p][m]), (p, m)


@pytest.fixture
def spy(monkeypatch):
    """Records the law of every resolve_impacts call (and its batch size)."""
    calls = []
    real = batch.resolve_impacts

    def wrapped(M, *args, **kw):
        calls.append((kw["law"], len(M)))
        return real(M, *args, **kw)

    monkeypatch.setattr(batch, "resolve_impacts", wrapped)
    return calls


def test_batched_angle_map_equals_per_sample_classification(spy):
    th1 = np.linspace(-math.pi, 0.0, 5)
    th2 = np.linspace(-math.pi, math.pi, 5)  # -pi, 0, pi: folded / stretched rows
    mus = (0.3, 0.8)
    amap = pendulum_angle_map(th1, th2, mu=mus, paths=PATHS)
    cells = [(iy, ix, *_cell(a1, a2)) for iy, a2 in enumerate(th2)
             for ix, a1 in enumerate(th1)]
    ref = _reference(cells, (5, 5), lambda iy, ix: [(np.array(r, float), 0.5, mu)
                                                    for r in PENDULUM_RATES for mu in mus])
    _assert_same(amap, ref)
    # one batch per fast path, over every approaching sample (never the closed form)
    approaching = 5 * 5 * len(PENDULUM_RATES) * len(mus) - int(ref[2].sum())
    assert spy == [(law, approaching) for law, _ in FAST_PATHS]
    # the map exercises the singular rows: 3 rates x 2 mu at each stretched/folded cell
    assert ref[1]["pereira-nikravesh/fast"]["singular_delassus"] > 0
    assert amap.examples["pereira-nikravesh/fast"]["singular_delassus"].startswith(
        "SingularSystemError: ")


def test_batched_friction_map_equals_per_sample_classification(spy):
    th2 = np.linspace(-math.pi, math.pi, 5)
    mus = np.array([0.0, 0.6, 1.2])
    theta1 = -0.6 * math.pi
    es = (0.0, 1.0)
    amap = pendulum_friction_map(th2, mus, theta1=theta1, e=es, paths=PATHS)
    cells = [(iy, ix, *_cell(theta1, a2)) for ix, a2 in enumerate(th2)
             for iy in range(mus.size)]
    ref = _reference(cells, (3, 5), lambda iy, ix: [(np.array(r, float), e, mus[iy])
                                                    for r in PENDULUM_RATES for e in es])
    _assert_same(amap, ref)
    assert [law for law, _ in spy] == [law for law, _ in FAST_PATHS]


def test_without_numba_the_map_falls_back_to_per_sample(monkeypatch):
    def missing(*args, **kw):
        raise NotSupportedError("resolve_impacts needs numba")

    th1, th2, mus = np.linspace(-math.pi, 0.0, 3), np.linspace(-math.pi, math.pi, 3), (0.5,)
    monkeypatch.setattr(batch, "resolve_impacts", missing)
    amap = pendulum_angle_map(th1, th2, mu=mus, paths=PATHS)
    cells = [(iy, ix, *_cell(a1, a2)) for iy, a2 in enumerate(th2)
             for ix, a1 in enumerate(th1)]
    _assert_same(amap, _reference(cells, (3, 3), lambda iy, ix: [
        (np.array(r, float), 0.5, mu) for r in PENDULUM_RATES for mu in mus]))


def test_stretched_pendulum_is_singular_delassus_with_a_message():
    a1, a2 = math.radians(-112.5), 0.0
    M, J = _cell(a1, a2)
    # by hand: the tip's Jacobian columns are p(a1) + p(a1 + a2) = 2 p(a1) and p(a1), with
    # p(a1) = (-sin a1, cos a1) in (x, y), i.e. (cos a1, sin a1) in the frame (n = +y, t = -x)
    np.testing.assert_allclose(J[:, 1], [math.cos(a1), math.sin(a1)], atol=1e-12)
    np.testing.assert_allclose(J[:, 0], 2.0 * J[:, 1], atol=1e-12)
    W = J @ np.linalg.solve(M, J.T)
    assert abs(np.linalg.det(W)) <= 1e-12 * np.trace(W) ** 2  # rank one
    dq = np.array([1.0, -1.0])
    assert (J @ dq)[0] < 0.0  # approaching
    # the batch itself names the kernel's rejection through classify_error, with the
    # kernel's message (not the batch index), and leaves the round-off-decided item to the
    # per-sample path
    judged, fragile = _batch_fast("pereira-nikravesh", [_Sample(0, 0, M, J, dq, 0.5, 0.3)],
                                  [0])
    modes, msg = judged[0]
    assert modes == ("singular_delassus",) and fragile == {0}
    assert msg.startswith("SingularSystemError: ") and "singular" in msg
    assert "of the batch" not in msg
    # and the map classifies it so, with an example message
    amap = pendulum_angle_map([a1], [a2], mu=(0.3,), rates=[(1.0, -1.0)], paths=FAST_PATHS)
    for law in ("pereira-nikravesh", "coulomb", "ccp", "dissipative"):
        path = f"{law}/fast"
        assert amap.counts[path]["singular_delassus"] == 1
        assert amap.flags[path]["singular_delassus"][0, 0]
        assert "singular" in amap.examples[path]["singular_delassus"]
        assert sum(amap.counts[path].values()) == 1


def test_status_codes_map_to_the_modes_of_their_errors():
    expected = {batch.SINGULAR: "singular_delassus", batch.JAM: "non_positive_effective_mass",
                batch.NO_SOLUTION: "no_convergence"}
    assert {s: classify_error(err("x")) for s, err in batch.STATUS_ERRORS.items()} == expected


def test_loop_maps_never_batch(spy):
    slider_crank_map(np.linspace(-math.pi, math.pi, 3), np.array([0.0, 0.5]),
                     paths=FAST_PATHS[:2])
    assert spy == []
