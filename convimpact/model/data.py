"""Per-state workspace of a model (Pinocchio's ``Data``).

A :class:`Data` belongs to one :class:`~convimpact.model.builder.Model`. It owns one flat
work buffer that the compiled recursive algorithms (:mod:`convimpact.model.recursive`) fill
for a state (theta, theta_dot), and remembers which quantities are current, so computing M,
f and the contact Jacobians at one state walks the tree once per stage and asking again at
the same state costs nothing. Every array attribute below is a view into that buffer,
overwritten by the next evaluation at another state: copy what you keep.
"""

from __future__ import annotations

import weakref
from typing import Any, Optional

import numpy as np

from ..errors import NonFiniteError, ShapeError
from . import recursive as rc

_F64 = np.dtype(np.float64)
_LAYOUTS: "weakref.WeakKeyDictionary[Any, rc.Layout]" = weakref.WeakKeyDictionary()


def layout_of(model) -> rc.Layout:
    """The :class:`~convimpact.model.recursive.Layout` of ``model`` (built once per model)."""
    lay = _LAYOUTS.get(model)
    if lay is None:
        lay = _LAYOUTS[model] = rc.Layout(model)
    return lay


_HAS_V = rc.HAS_V
_Q_CHANGED = rc.R_Q_CHANGED
_V_CHANGED = rc.R_V_CHANGED
_ERRORS = rc.R_NON_FINITE_Q | rc.R_NON_FINITE_V | rc.R_BAD_SHAPE_Q | rc.R_BAD_SHAPE_V
_READY = False


def _evaluate():
    """:func:`~convimpact.model.recursive.evaluate`, compiled (or loaded from the cache) for
    its one signature and closed to any other, so that other argument types raise TypeError
    instead of compiling a variant."""
    global _READY
    if not _READY:
        if hasattr(rc.evaluate, "compile"):  # a plain function under NUMBA_DISABLE_JIT=1
            rc.evaluate.compile(rc.EVALUATE_SIGNATURE)
            rc.evaluate.disable_compile()
        _READY = True
    return rc.evaluate


class Data:
    """Kinematic and dynamic quantities of a model at the last evaluated state.

    The array attributes are views into the work buffer, current after the evaluation that
    fills them.

    Attributes
    ----------
    theta, dtheta : the configuration and velocity the arrays belong to (None until set).
    rotation : (n_bodies, d, d) body orientations; ``angle`` (n_bodies,) planar absolute angles.
    position : (n_bodies, d) body-frame origins; ``velocity`` their velocities.
    omega : (n_bodies, r) body angular velocities.
    node_position : (k + 1, 3) the origin p_j of each joint coordinate's moving frame (on its
        axis for a revolute coordinate; the last row: the ground).
    S, S_dot : (k, 6) world motion subspace of every joint coordinate about its origin p_j
        (linear part first: (0, a) revolute, (u, 0) prismatic) and its time derivative.
    node_velocity : (k + 1, 6) velocity of p_j and angular velocity of each moving frame.
    M, L, M_dot : mass matrix, its lower Cholesky factor (``chol_ok`` False when M is not
        positive definite), dM/dt.
    bias : (k,) f of eq. (4) without applied forces; ``momentum_rate`` (k,) f + M_dot theta_dot
        (without applied forces).
    gap, contact_ok : (n_contacts,) gaps, and 0 where a sphere pair's centres coincide.
    contact_point : (n_contacts, 2, 3) the contact points on bodies i and j (3-vectors).
    contact_basis, contact_basis_dot : (n_contacts, 3, 3) rows n, t1, t2 and their rates
        (planar: n, t, 0 in the x-y plane).
    contact_jacobian, contact_jacobian_dot : (n_contacts, 3, k) rows n, t1, t2 (planar: the
        first two rows).
    cache : derived quantities at this state (cleared when it changes; keys starting with
        ``"q:"`` depend on the configuration only and survive a change of velocity).
    """

    def __init__(self, model):
        self.model = model
        lay = self.layout = layout_of(model)
        self.work = lay.new_work()
        self.itab = self.work.view(np.int64)[:lay.n_int]
        self._evaluate = _evaluate()
        self._meta = lay.view(self.work, rc.W_SCR)[rc.SC_META]
        k, nb, nc = model.n_coordinates, model.n_bodies, len(model.contacts)
        self.k, self.d = k, model.dim
        self._shape, self._strides = (k,), (8,)
        vec = lay.view(self.work, rc.W_VEC)
        node = lay.view(self.work, rc.W_NODE)
        body = lay.view(self.work, rc.W_BODY)
        con = lay.view(self.work, rc.W_CON)
        self._theta, self._dtheta = vec[rc.V_THETA], vec[rc.V_DTHETA]
        self.bias, self.momentum_rate = vec[rc.V_BIAS], vec[rc.V_PDOT]
        br = body[:, rc.BW_R:rc.BW_R + 9].reshape(nb, 3, 3)
        bp = body[:, rc.BW_P:rc.BW_P + 3]
        bv = body[:, rc.BW_VO:rc.BW_VO + 3]
        bw = body[:, rc.BW_W:rc.BW_W + 3]
        if model.planar:
            self.rotation, self.position, self.velocity = br[:, :2, :2], bp[:, :2], bv[:, :2]
            self.omega = bw[:, 2:3]
        else:
            self.rotation, self.position, self.velocity, self.omega = br, bp, bv, bw
        self.rotation3, self.position3 = br, bp
        self.angle = body[:, rc.BW_ANG]
        self.S = node[:k, rc.NW_S:rc.NW_S + 6]
        self.S_dot = node[:k, rc.NW_SD:rc.NW_SD + 6]
        self.node_position = node[:, rc.NW_P:rc.NW_P + 3]
        self.node_velocity = node[:, rc.NW_V:rc.NW_V + 6]
        self.M = lay.view(self.work, rc.W_M)
        self.L = lay.view(self.work, rc.W_L)
        self.M_dot = lay.view(self.work, rc.W_MD)
        self.gap = con[:, rc.CW_GAP]
        self.contact_ok = con[:, rc.CW_OK]
        self.contact_point = con[:, rc.CW_X:rc.CW_X + 6].reshape(nc, 2, 3)
        self.contact_basis = con[:, rc.CW_E:rc.CW_E + 9].reshape(nc, 3, 3)
        self.contact_basis_dot = con[:, rc.CW_ED:rc.CW_ED + 9].reshape(nc, 3, 3)
        self.contact_jacobian = lay.view(self.work, rc.W_CJ)
        self.contact_jacobian_dot = lay.view(self.work, rc.W_CJD)
        #: per contact: its Jacobian's d rows and their rates (views)
        self.jacobian_rows = [self.contact_jacobian[c, :self.d] for c in range(nc)]
        self.jacobian_rate_rows = [self.contact_jacobian_dot[c, :self.d] for c in range(nc)]
        self.cache: dict[str, Any] = {}

    def __reduce__(self):
        # the attributes are views of the work buffer: rebuild them around a copy of it
        return (_restore, (self.model, self.work.copy()))

    def state(self, value, name: str = "theta") -> np.ndarray:
        """``value`` as a float64 C-contiguous (k,) array (ShapeError otherwise; finiteness
        is checked by the compiled pass that reads it: NonFiniteError)."""
        if (type(value) is np.ndarray and value.dtype is _F64 and value.shape == self._shape
                and value.strides == self._strides):
            return value
        try:
            a = np.ascontiguousarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ShapeError(f"{name} must be a numeric vector of length {self.k}") from None
        if a.shape != self._shape:
            raise ShapeError(f"{name} must have shape ({self.k},) for this model (coordinates "
                             f"{', '.join(self.model.coordinate_names)}), got {a.shape}")
        return a

    @property
    def theta(self) -> Optional[np.ndarray]:
        return self._theta if self._meta[rc.META_HAS_Q] else None

    @property
    def dtheta(self) -> Optional[np.ndarray]:
        return self._dtheta if self._meta[rc.META_HAS_V] else None

    @property
    def chol_ok(self) -> bool:
        """True when the last Cholesky factorization of M succeeded."""
        return bool(self._meta[rc.META_CHOL])

    def done(self, flags: int) -> bool:
        """True when every stage in ``flags`` is current."""
        return int(self._meta[rc.META_DONE]) & flags == flags

    def compute(self, flags: int, theta, dtheta=None) -> None:
        """Bring the stages in ``flags`` (:mod:`~convimpact.model.recursive` flags) up to
        date at (theta, theta_dot), with the stages they need.

        ``dtheta`` None keeps the velocity held (zero when none is). Float64 C-contiguous
        arrays of length k go straight to the compiled pass; anything else is converted or
        refused (ShapeError) first. Raises NonFiniteError for NaN or infinite input.
        """
        try:
            if dtheta is None:
                code = self._evaluate(flags, theta, theta, self.work)
            else:
                code = self._evaluate(flags | _HAS_V, theta, dtheta, self.work)
        except TypeError:  # not a writable float64 C-contiguous vector: convert or refuse it
            theta = np.array(self.state(theta, "theta"))
            if dtheta is None:
                code = self._evaluate(flags, theta, theta, self.work)
            else:
                dtheta = np.array(self.state(dtheta, "dtheta"))
                code = self._evaluate(flags | _HAS_V, theta, dtheta, self.work)
        if code:
            self._changed(code, theta, dtheta)

    def _changed(self, code: int, theta, dtheta) -> None:
        if code & _ERRORS:
            for bit, name, value in ((rc.R_BAD_SHAPE_Q, "theta", theta),
                                     (rc.R_BAD_SHAPE_V, "dtheta", dtheta)):
                if code & bit:
                    raise ShapeError(
                        f"{name} must have shape ({self.k},) for this model (coordinates "
                        f"{', '.join(self.model.coordinate_names)}), got {np.shape(value)}")
            self.cache.clear()
            what = "theta" if code & rc.R_NON_FINITE_Q else "dtheta"
            raise NonFiniteError(f"{what} contains NaN or infinity; pass finite values")
        if self.cache:
            if code & _Q_CHANGED:
                self.cache.clear()
            elif code & _V_CHANGED:
                self.cache = {k: v for k, v in self.cache.items() if k.startswith("q:")}


def _restore(model, work: np.ndarray) -> Data:
    """A Data of ``model`` holding a copy of ``work`` (unpickling, copy.deepcopy)."""
    data = Data(model)
    data.work[:] = work
    return data
