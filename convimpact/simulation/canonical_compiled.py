"""The compiled path of the canonical equations with held contacts
(:class:`~convimpact.simulation.canonical.CanonicalEquations` on a
:class:`~convimpact.model.ModelMechanism` without loops).

Between the model's own compiled passes (positions: M's factor and the contact Jacobians;
velocities: f, p_dot and the Jacobians' rates) the kernels of
:mod:`~convimpact.simulation.canonical_kernels` evaluate theta_dot and sigma (eqs. 7, 10,
13), p_dot (eq. 14) with the sliding contacts' Coulomb friction (eqs. 8, 9), and at the same
cost the multipliers, the friction power, the Painleve indicator and the slip directions the
run's event functions and samples ask for. The numbers are the general (numpy) path's to
round-off; wherever a kernel reports a failure (C M^-1 C^T or the sliding system singular,
a non-finite value) the methods return None and the general path decides, raising the
documented error. The last state's results are remembered (a step's end asks for them
several times).
"""

from __future__ import annotations

import numpy as np

from ..errors import NonFiniteError

_KERNELS = None
_EMPTY = np.zeros(0)  # (read only by the kernels)


def _kernels():
    """:mod:`.canonical_kernels`, imported on first use (it imports numba)."""
    global _KERNELS
    if _KERNELS is None:
        from . import canonical_kernels
        _KERNELS = canonical_kernels
    return _KERNELS


class CompiledHeldPath:
    """Mixin of :class:`~convimpact.simulation.canonical.CanonicalEquations`: its compiled
    evaluations (used where its ``_compiled`` flag is set)."""

    def theta_dot(self, theta: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(theta_dot, sigma) of :meth:`velocities`, by the compiled pass where the
        right-hand side has one (the same numbers to round-off, no factor cache)."""
        if self._compiled:
            theta = np.ascontiguousarray(theta, dtype=float)
            p = np.ascontiguousarray(p, dtype=float)
            key = theta.tobytes() + p.tobytes()
            memo = self._velocity_memo
            if memo is not None and memo[0] == key:
                return memo[1].copy(), memo[2].copy()
            got = self._held_velocities(theta, p)
            if got is not None:
                self._velocity_memo = (key, got[6], got[7])
                return got[6].copy(), got[7].copy()
        dtheta, sigma, _ = self.velocities(theta, p)
        return dtheta, sigma

    def _held_velocities(self, theta: np.ndarray, p: np.ndarray):
        """(data, L, C, A, S, SL, theta_dot, sigma) by
        :func:`~.canonical_kernels.held_velocities`, or None where the general path must
        decide."""
        ck = _kernels()
        k, m = self.k, len(self.rows)
        try:
            d = self.mechanism.rhs_positions(theta)
        except NonFiniteError:
            return None
        if not d.chol_ok:
            return None
        # (the factors' work arrays, written whole by the kernel on every call, or on its
        # lower triangle: SL's upper one stays zero; the results are new arrays)
        work = getattr(self, "_held_work", None)
        if work is None:
            work = self._held_work = (np.empty((k, k)), np.empty((m, k)), np.empty((k, m)),
                                      np.empty((m, m)), np.zeros((m, m)))
        L, C, A, S, SL = work
        dtheta, sigma = np.empty(k), np.empty(m)
        if ck.held_velocities(d.L, d.contact_jacobian, self._row_contact, self._row_row, p,
                              L, C, A, S, SL, dtheta, sigma) != ck.OK:
            return None
        return d, L, C, A, S, SL, dtheta, sigma

    def _held_rate(self, t: float, theta: np.ndarray, p: np.ndarray,
                   aux: np.ndarray | None = None) -> np.ndarray | None:
        """y_dot with held contacts and no loops: the model's two compiled passes around
        :func:`~.canonical_kernels.held_velocities` and :func:`~.canonical_kernels.held_rates`
        (the general path's numbers to round-off, without its factor cache); None where
        that path must decide (M or C M^-1 C^T not positive definite, the sliding
        contacts' system singular, a non-finite state or rate: it raises)."""
        ck = _kernels()
        theta = np.ascontiguousarray(theta, dtype=float)
        p = np.ascontiguousarray(p, dtype=float)
        k = self.k
        got = self._held_velocities(theta, p)
        if got is None:
            return None
        _, L, C, A, S, SL, dtheta, sigma = got
        try:
            f, pdot, dv = self.mechanism.rhs_velocities(t, theta, dtheta, True)
        except NonFiniteError:
            return None
        if self.slipping:
            # the stored directions and mu as arrays, kept while the modes are the same
            # (the run replaces the directions at each step: set_slip_direction)
            kept = self._slip_arrays
            if kept is None or kept[0] is not self.modes or kept[1] != self._modes_version:
                modes = [self.modes[c] for c, _ in self.slipping]
                if any(len(md.direction) != self._d - 1 for md in modes):
                    return None  # no stored direction (a hand-built mode): the general path
                kept = self._slip_arrays = (self.modes, self._modes_version,
                                            np.array([md.direction for md in modes], float),
                                            np.array([md.mu for md in modes]))
            stored, mu = kept[2], kept[3]
            # below its floor a contact keeps its stored direction: a frozen one always
            # (the flags are the segment's: the run replaces only the directions)
            floors = getattr(self, "_floors", None)
            if floors is None:
                floors = self._floors = np.array([
                    np.inf if self.modes[c].frozen else self.slip_floor
                    for c, _ in self.slipping])
        else:
            stored, mu, floors = np.zeros((0, 1)), _EMPTY, _EMPTY
        w = getattr(self, "_held_weights", None)  # (the segment's: its mu are fixed)
        if w is None:
            w = self._held_weights = (self.unknown_weights() if self.redundant
                                      else np.zeros(0))
        x0 = (self.offset if self.offset is not None and self.redundant
              else np.zeros(len(w)))
        out = np.empty(2 * k)
        want_nu = aux is not None
        if aux is None:
            aux = np.empty(self._aux_size)
        # the positions' Jacobians of this theta (the velocity pass recomputed them there)
        if ck.held_rates(L, C, A, S, SL, dv.contact_jacobian, dv.contact_jacobian_dot,
                         self._row_contact, self._row_row, self._slip_index, self._slip_cols,
                         stored, mu, self._extra_contact, self._extra_row, w, x0,
                         floors, f, pdot, dtheta, sigma, out,
                         aux, want_nu) != ck.OK:
            return None
        return out

    def _compiled_terms(self, t: float, y: np.ndarray):
        """(nu, friction power, Painleve indicator, slip directions (n_s, d - 1),
        theta_dot) by the compiled pass, or None where the general path must decide."""
        if not self._compiled:
            return None
        k, m = self.k, self.n_unknowns  # (no loops: the rows, the redundant sliding ones)
        y = np.ascontiguousarray(y, dtype=float)
        # (the stored slip directions enter below the slip floor: part of the key)
        key = (t, y.tobytes(), tuple(self.modes[c] for c, _ in self.slipping),
               None if self.offset is None else self.offset.tobytes())
        memo = self._terms_memo
        if memo is not None and memo[0] == key:
            aux, out = memo[1], memo[2]
        else:
            aux = np.empty(self._aux_size)
            out = self._held_rate(t, y[:k], y[k:], aux)
            if out is None:
                return None
            self._terms_memo = (key, aux, out)
        return (aux[:m].copy(), float(aux[m]), float(aux[m + 1]),
                aux[m + 2:].reshape(len(self.slipping), max(self._d - 1, 1)).copy(),
                out[:k].copy())
