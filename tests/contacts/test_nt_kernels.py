"""The interior points' compiled cone algebra (convimpact.contacts.nt_kernels) against the
definitions, computed here: the Nesterov-Todd scaling's H = T^-2 maps x to z and lam = T z
satisfies lam o lam = (T z) o (T^-1 x); the Jordan solve inverts the Jordan product; the
step to the boundary lands on it."""

import numpy as np
import pytest

from convimpact.contacts.nt_kernels import (affine_target, corrector_target, max_step,
                                            nt_blocks, scaled_rhs)


def _jprod(x, y):
    """x o y per row: (x . y, x_0 y_1 + y_0 x_1)."""
    out = x[:, :1] * y + y[:, :1] * x
    out[:, 0] = np.einsum("ij,ij->i", x, y)
    return out


def _interior(rng, k, m):
    x = rng.standard_normal((k, m))
    if m > 1:
        x[:, 0] = np.linalg.norm(x[:, 1:], axis=1) + rng.uniform(1e-3, 2.0, k)
    else:
        x[:, 0] = rng.uniform(1e-3, 2.0, k)
    return x


@pytest.mark.parametrize("m", [1, 2, 3])
def test_scaling_maps_x_to_z_and_lam_is_symmetric(m):
    rng = np.random.default_rng(m)
    k = 50
    x, z = _interior(rng, k, m), _interior(rng, k, m)
    v, beta, lam, H = nt_blocks(x.ravel(), z.ravel(), m)
    # H = T^-2 with T z = T^-1 x: H x = z, H symmetric positive definite
    np.testing.assert_allclose(np.einsum("kij,kj->ki", H, x), z, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(H, np.transpose(H, (0, 2, 1)), rtol=1e-12, atol=1e-14)
    assert np.all(np.linalg.eigvalsh(H) > 0.0)
    # lam lies in the cone's interior with lam o lam = x o z in the cone's determinant:
    # det(lam)^2 = det(x) det(z), and lam^T lam = x^T z (the scaling's invariants)
    lam = lam.reshape(k, m)
    det = (lambda a: a[:, 0] ** 2 - np.sum(a[:, 1:] ** 2, axis=1))
    np.testing.assert_allclose(det(lam) ** 2, det(x) * det(z), rtol=1e-9)
    np.testing.assert_allclose(np.sum(lam * lam, axis=1), np.sum(x * z, axis=1), rtol=1e-9)


@pytest.mark.parametrize("m", [1, 3])
def test_rhs_and_targets_by_the_jordan_product(m):
    rng = np.random.default_rng(10 + m)
    k = 30
    x, z = _interior(rng, k, m), _interior(rng, k, m)
    v, beta, lam, H = nt_blocks(x.ravel(), z.ravel(), m)
    L = lam.reshape(k, m)
    t = rng.standard_normal(k * m)
    # T^-1 (lam \ t): T out solves lam o (T out) = t; T = (H)^(-1/2) on each cone
    out = scaled_rhs(v, beta, lam, t, m).reshape(k, m)
    T = np.stack([np.linalg.inv(_sqrtm(Hc)) for Hc in H])
    np.testing.assert_allclose(_jprod(L, np.einsum("kij,kj->ki", T, out)), t.reshape(k, m),
                               rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(affine_target(lam, m).reshape(k, m), -_jprod(L, L), rtol=1e-12)
    dx, dz = rng.standard_normal(k * m), rng.standard_normal(k * m)
    Ti = np.linalg.inv(T)
    sx = np.einsum("kij,kj->ki", Ti, dx.reshape(k, m))
    sz = np.einsum("kij,kj->ki", T, dz.reshape(k, m))
    e = np.zeros((k, m))
    e[:, 0] = 1.0
    want = 0.7 * e - _jprod(L, L) - _jprod(sx, sz)
    np.testing.assert_allclose(corrector_target(v, beta, lam, dx, dz, 0.7, m).reshape(k, m),
                               want, rtol=1e-8, atol=1e-10)


def _sqrtm(H):
    w, Q = np.linalg.eigh(H)
    return (Q * np.sqrt(w)) @ Q.T


def test_step_to_the_boundary_lands_on_it():
    rng = np.random.default_rng(20)
    k, m = 40, 3
    x, z = _interior(rng, k, m), _interior(rng, k, m)
    dx, dz = rng.standard_normal((k, m)), rng.standard_normal((k, m))
    a = max_step(x.ravel(), dx.ravel(), z.ravel(), dz.ravel(), m)

    def margin(s):  # the smallest of x0 - |x1| over both arrays' rows at step s
        return min(np.min(v[:, 0] - np.linalg.norm(v[:, 1:], axis=1))
                   for v in (x + s * dx, z + s * dz))

    assert 0.0 < a < 1e30
    assert margin(a * (1 - 1e-9)) > 0.0
    assert abs(margin(a)) <= 1e-9 * (1.0 + np.abs(x).max() + a * np.abs(dx).max())
    assert margin(a * (1 + 1e-6)) < 0.0
