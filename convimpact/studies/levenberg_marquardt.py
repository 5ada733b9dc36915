"""Bounded Levenberg–Marquardt for :func:`convimpact.studies.fitting.fit_coefficients`.

Marquardt's diagonal scaling, Nielsen's damping update, bounds by projection: a parameter at
a bound whose gradient points out of the box is held there, as is one whose Jacobian column
is a zero sensitivity. It stops on the gradient's largest cosine with the residual (``gtol``),
a vanishing step (``xtol``) or a vanishing decrease (``ftol``); a simulation that fails at a
trial point counts as an infinitely bad step.
"""

from __future__ import annotations

import numpy as np

#: a Jacobian column below this fraction of the largest is a zero sensitivity
ZERO_SENSITIVITY = 1e-9


class LevenbergMarquardt:
    """Bounded Levenberg–Marquardt on the weighted residuals (state kept for the summary).

    ``model`` gives ``trajectory_and_derivatives(x)`` (predictions and their derivatives in
    x), ``predict(x)`` and ``last_result`` (:class:`~.fitting_model.TrajectoryModel`);
    :meth:`solve` leaves the last iterate, its predictions, residuals, Jacobian and cost on
    the object, with ``converged``, ``status`` and ``iterations``.
    """

    def __init__(self, model, observed, weights, lo, hi, max_iterations, xtol, gtol, ftol):
        self.model, self.observed, self.weights = model, observed, weights
        self.lo, self.hi = lo, hi
        self.max_iterations, self.xtol, self.gtol, self.ftol = max_iterations, xtol, gtol, ftol
        self.iterations = 0
        self.converged = False
        self.status = "not started"

    def residual(self, predicted):
        return ((self.observed - predicted) * self.weights).ravel()

    def linearise(self, x):
        predicted, jac = self.model.trajectory_and_derivatives(x)
        # r = (y - h) w, so dr/dx = -dh/dx w
        J = -(jac * self.weights[None, :, None]).reshape(-1, len(x))
        return predicted, self.residual(predicted), J

    def trial(self, x):
        from ..errors import SimulationError

        kept = self.model.last_result  # the linearisation's run stays the reference
        try:
            return self.residual(self.model.predict(x))
        except SimulationError:  # a failed run counts as an infinitely bad step
            return None
        finally:
            self.model.last_result = kept

    def solve(self, x):
        x = np.clip(np.asarray(x, float), self.lo, self.hi)
        predicted, r, J = self.linearise(x)
        cost = 0.5 * float(r @ r)
        lam, nu = 1e-3, 2.0
        while True:
            g = J.T @ r
            norms = np.linalg.norm(J, axis=0)
            live = norms > ZERO_SENSITIVITY * max(norms.max(), np.finfo(float).tiny)
            at_lo = (x <= self.lo) & (g > 0)
            at_hi = (x >= self.hi) & (g < 0)
            free = live & ~at_lo & ~at_hi
            rnorm = np.sqrt(2 * cost)
            cosines = np.abs(g[free]) / (norms[free] * rnorm) if rnorm > 0 else np.zeros(0)
            if not free.any() or rnorm == 0 or cosines.max() <= self.gtol:
                self.converged, self.status = True, "gradient"
                break
            if self.iterations >= self.max_iterations:
                self.status = f"iteration limit ({self.max_iterations}) reached"
                break
            self.iterations += 1
            A = J[:, free].T @ J[:, free]
            D = np.diag(np.maximum(np.diag(A), 1e-12 * np.diag(A).max()))
            accepted = False
            while lam < 1e16:
                step = np.zeros_like(x)
                step[free] = np.linalg.solve(A + lam * D, -g[free])
                x_new = np.clip(x + step, self.lo, self.hi)
                step = x_new - x
                r_new = self.trial(x_new)
                cost_new = np.inf if r_new is None else 0.5 * float(r_new @ r_new)
                Js = J @ step
                predicted_drop = -(g @ step) - 0.5 * float(Js @ Js)
                if cost_new < cost and predicted_drop > 0:
                    rho = (cost - cost_new) / predicted_drop
                    lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                    nu = 2.0
                    accepted = True
                    break
                lam *= nu
                nu *= 2.0
                if np.all(np.abs(step) <= self.xtol * (np.abs(x) + self.xtol)):
                    break  # the steps vanish without a decrease: at the minimum
            if not accepted:
                # no decrease along ever shorter steps: a minimum to the step tolerance
                if np.all(np.abs(step) <= self.xtol * (np.abs(x) + self.xtol)):
                    self.converged, self.status = True, "step"
                else:
                    self.status = "no step lowers the cost (damping exhausted)"
                break
            small_step = np.all(np.abs(step) <= self.xtol * (np.abs(x) + self.xtol))
            small_drop = (cost - cost_new <= self.ftol * cost
                          and predicted_drop <= self.ftol * cost)
            x = x_new
            predicted, r, J = self.linearise(x)
            cost = 0.5 * float(r @ r)
            if small_step or small_drop:
                self.converged, self.status = True, "step" if small_step else "cost"
                break
        self.x, self.predicted, self.r, self.J, self.cost = x, predicted, r, J, cost
