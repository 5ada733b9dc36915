"""The batch API's input checks and typed errors (:mod:`convimpact.impact.batch.impacts`).

Its constants (law codes, regime names, per-impact status codes and the typed error of each),
the validation of the arguments of :func:`~convimpact.impact.batch.impacts.resolve_impacts` and
:func:`~convimpact.impact.batch.impacts.contact_impulses` (real arrays of consistent batched or shared
shapes, e and mu in range, the options), and the errors: bad input found by the compiled
drivers (:func:`_input_error`, naming the impact) and the error of an item the law's kernel
rejected, with the law's own message (:func:`_kernel_error`).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping

import numpy as np

from ..laws import LAW_CODES as _LAW_CODES
from ...errors import (ConvImpactError, DegenerateContactError, InputError, MassMatrixError,
                       NonFiniteError, NonPositiveEffectiveMassError, ParameterError,
                       ShapeError, SingularSystemError, SolverError, UnknownOptionError,
                       as_real_array)

#: laws of the batch (every law has an exact single-contact kernel), with their codes
LAW_CODES: Mapping[str, int] = MappingProxyType(_LAW_CODES)
#: regime names; ``ImpactBatch.regime`` holds indices into this tuple (FAILED = -1 for
#: impacts the kernel rejected)
REGIMES: tuple[str, ...] = ("separating", "frictionless", "stick", "slide")
FAILED = -1
#: per-impact status codes
OK, SINGULAR, JAM, NO_SOLUTION = 0, 1, 2, 3
#: status code -> name
STATUS_NAMES: Mapping[int, str] = MappingProxyType(
    {OK: "ok", SINGULAR: "singular", JAM: "jam", NO_SOLUTION: "no-solution"})
#: status code -> the typed error resolve_impact raises for such an impact
STATUS_ERRORS: Mapping[int, type] = MappingProxyType(
    {SINGULAR: SingularSystemError, JAM: NonPositiveEffectiveMassError,
     NO_SOLUTION: SolverError})
ON_ERROR = ("flag", "raise")

def _real_array(name: str, value) -> np.ndarray:
    """A float64 C-contiguous array of real numbers (no strings, booleans, complex, objects)."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise ShapeError(f"{name} must be real numbers, got {type(value).__name__} {value!r}")
    if isinstance(value, np.ndarray) and value.dtype.kind != "O":
        a = value
    elif isinstance(value, (list, tuple, np.ndarray)):
        # the core's typed conversion: a boolean, string, complex or None entry of a sequence
        # is refused by name (numpy would read [0.3, True] as [0.3, 1.0])
        a = as_real_array(name, value)
    else:
        try:
            a = np.asarray(value)
        except (TypeError, ValueError) as exc:
            raise ShapeError(f"{name} must be a numeric array, got {type(value).__name__}"
                             ) from exc
    if a.dtype.kind not in "iuf":
        what = {"b": "booleans", "U": "strings", "S": "strings", "O": "objects or ragged "
                "nested sequences", "c": "complex numbers"}.get(a.dtype.kind, str(a.dtype))
        raise ShapeError(f"{name} must be real numbers, got an array of {what}")
    return np.asarray(a, dtype=np.float64, order="C")


def _batched(name: str, a: np.ndarray, item_ndim: int, item_shape: str) -> np.ndarray:
    if a.ndim == item_ndim:
        return a[None]
    if a.ndim == item_ndim + 1:
        return a
    if item_ndim == 0:
        raise ShapeError(f"{name} must be a scalar or one value per impact (N,); got shape "
                         f"{a.shape}")
    raise ShapeError(f"{name} must have shape {item_shape} (shared by every impact) or "
                     f"(N, {item_shape[1:-1]}) (one per impact); got {a.shape}")


def _batch_size(arrays: dict[str, np.ndarray], shared_ndim: dict[str, bool]) -> int:
    sizes = {name: a.shape[0] for name, a in arrays.items() if not shared_ndim[name]}
    if not sizes:
        return 1
    n = max(sizes.values())
    bad = {name: s for name, s in sizes.items() if s != n}
    if bad:
        raise ShapeError("the batch dimensions disagree: " + ", ".join(
            f"{name} has {s}" for name, s in sizes.items()) + "; every per-impact argument "
            "needs the same N (or drop the batch dimension to share one value)")
    return n


def _check_finite(name: str, a: np.ndarray, per_item: bool) -> None:
    if a.size and not np.isfinite(a).all():
        bad = ~np.isfinite(a.reshape(a.shape[0], -1)).all(axis=1)
        i = int(np.flatnonzero(bad)[0])
        where = f"{name}[{i}]" if per_item else name
        raise NonFiniteError(f"{where} contains NaN or infinity (impact {i}); pass finite values"
                             if per_item else f"{name} contains NaN or infinity; pass finite "
                             "values")


#: the coefficients' ranges: name -> (out of range, the message's statement of the range)
_RANGES = {
    "e_t": (lambda a: (a < -1.0) | (a > 1.0),
            "tangential restitution must lie in [-1, 1] (outside it the law creates energy)"),
    "e": (lambda a: (a < 0.0) | (a > 1.0), "coefficient of restitution must lie in [0, 1]"),
    "mu": (lambda a: a < 0.0, "coefficient of friction must be >= 0"),
}


def _check_parameters(e: np.ndarray, mu: np.ndarray, et: np.ndarray,
                      shared: dict[str, bool]) -> None:
    """e, mu and e_t finite, then in range (the message names the first offending impact)."""
    arrays = {"e": e, "mu": mu, "e_t": et}
    for name, a in arrays.items():
        _check_finite(name, a, not shared[name])
    for name, (outside, what) in _RANGES.items():
        a = arrays[name]
        bad = np.flatnonzero(outside(a))
        if bad.size:
            i = int(bad[0])
            where = f"{name} = {a[0]:g}" if shared[name] else f"{name}[{i}] = {a[i]:g} (impact {i})"
            raise ParameterError(f"{what}, got {where}"
                                 + (f"; {bad.size} impacts out of range" if bad.size > 1 else ""))


def _check_options(law, on_error) -> int:
    if not isinstance(law, str) or law not in LAW_CODES:
        raise UnknownOptionError(f"unknown impact law {law!r}; choose one of "
                                 f"{', '.join(LAW_CODES)}")
    if not isinstance(on_error, str) or on_error not in ON_ERROR:
        raise UnknownOptionError(f"on_error must be 'flag' (per-impact status codes) or "
                                 f"'raise' (the first rejected impact's error), got {on_error!r}")
    return LAW_CODES[law]


def _check_degenerate(W: np.ndarray, Jb: np.ndarray, n: int) -> None:
    """Raise DegenerateContactError for the first impact whose contact normal moves no mass
    (c_n^T M^-1 c_n below the smallest normal number: the whole Jacobian is zero, or the normal
    row is numerically zero relative to M's scale) -- as ``resolve_impact`` does; a zero normal
    row whose tangent rows move mass is a grazing contact: separating, not an error."""
    from ..problem.build import TINY_NORMAL

    wn = W[:, 0, 0]
    low = np.flatnonzero(~(wn >= TINY_NORMAL))
    if not low.size:
        return
    d = W.shape[1]
    wt = W[low, 1, 1] if d == 2 else np.maximum(W[low, 1, 1], W[low, 2, 2])
    rows = Jb[low if Jb.shape[0] > 1 else np.zeros(low.size, dtype=np.intp), 0]
    zero_row = ~rows.any(axis=1)
    bad = ~(zero_row & (wt >= TINY_NORMAL))
    if not bad.any():
        return
    j = int(np.argmax(bad))
    i = int(low[j])
    where = f"impact {i} of the batch of {n}" if n > 1 else "the impact"
    what = ("is zero, and so are its tangent rows" if zero_row[j] else
            f"is numerically zero relative to M's scale (c_n^T M^-1 c_n = {wn[i]:.3e} "
            "underflows double precision)")
    raise DegenerateContactError(
        f"{where}: the contact Jacobian's normal row {what}: the contact cannot approach or "
        "take an impulse; check the contact normal and the Jacobian (or rescale units), or "
        "leave the contact out")


#: tolerance of the semidefiniteness test of a user's Delassus block (the principal minors of
#: W / max |W| are accepted down to -INDEFINITE_RTOL)
INDEFINITE_RTOL = 1e-10


def _indefinite(Wb: np.ndarray) -> np.ndarray:
    """Per item (N,) of the (N or 1, d, d) blocks read from their upper triangle: whether W is
    not positive semidefinite (a principal minor of order j below -INDEFINITE_RTOL s^j, s the
    sum of |W|'s upper entries). A Delassus matrix J M^-1 J^T is semidefinite; an indefinite
    one has no impulse law. Items far from unit scale are divided by s first (no overflow)."""
    d = Wb.shape[1]
    rows = [Wb[:, 0, 0], Wb[:, 0, 1], Wb[:, 1, 1]]
    if d == 3:
        rows += [Wb[:, 0, 2], Wb[:, 1, 2], Wb[:, 2, 2]]
    s = np.abs(rows[0])
    for r in rows[1:]:
        s = s + np.abs(r)
    far = ~((s >= 1e-100) & (s <= 1e100))
    if far.any():
        scale = np.where(far & (s > 0.0) & np.isfinite(s), s, 1.0)
        rows = [r / scale for r in rows]
        s = np.where(far & (s > 0.0), 1.0, s)
    tol = INDEFINITE_RTOL
    if d == 2:
        a, b, c = rows
        return (np.minimum(a, c) < -tol * s) | (a * c - b * b < -tol * s * s)
    a, b, c, g, h, f = rows  # [[a, b, g], [b, c, h], [g, h, f]]
    s2 = tol * s * s
    bad = np.minimum(np.minimum(a, c), f) < -tol * s
    bad |= (a * c - b * b < -s2) | (a * f - g * g < -s2) | (c * f - h * h < -s2)
    det = a * (c * f - h * h) - b * (b * f - g * h) + g * (b * h - c * g)
    return bad | (det < -s2 * s)


def _flag_indefinite(bad: np.ndarray, status, regime, outs, errors, n: int) -> None:
    """Items with an indefinite W that the law's kernel answered: flagged SINGULAR (NaN
    numbers, SingularSystemError), as the kernels that invert W flag them."""
    idx = np.flatnonzero(bad & (status == OK))
    for i in idx.tolist():
        status[i] = SINGULAR
        regime[i] = FAILED
        for o in outs:
            o[i] = np.nan
        errors[i] = SingularSystemError(
            f"impact {i} of the batch of {n}: W is not positive semidefinite (a principal "
            "minor is negative), so it is no Delassus matrix J M^-1 J^T and no impulse law "
            "applies; check W's assembly")


# --------------------------------------------------------------------------------------------
# errors of single items


def _status_of(exc: BaseException) -> int:
    if isinstance(exc, NonPositiveEffectiveMassError):
        return JAM
    if isinstance(exc, SingularSystemError):
        return SINGULAR
    return NO_SOLUTION


def _item_error(exc: ConvImpactError, i: int, n: int) -> ConvImpactError:
    """The same error type with the impact's index in front of its message."""
    out = type(exc)(f"impact {i} of the batch of {n}: {exc}")
    out.__cause__ = exc
    return out


def _kernel_error(W, v, e: float, mu: float, law: str, status: int, i: int,
                  n: int, e_t: float = 0.0) -> ConvImpactError:
    """The typed error of item i, with the message of the law's kernel (re-run on its W, v
    through :func:`~convimpact.impact.exact.dispatch.solve_contact`, which raises it)."""
    from ..exact.dispatch import solve_contact

    try:
        solve_contact(W, v, e, mu, law, e_t)
    except ConvImpactError as exc:
        return _item_error(exc, i, n)
    # unreachable unless the batch's reduction and solve_contact's disagree: say so
    return STATUS_ERRORS.get(status, SolverError)(
        f"impact {i} of the batch of {n}: the batch rejected it "
        f"({STATUS_NAMES.get(status, status)}) but solve_contact solves it; please report")


def _raise_first(status: np.ndarray, errors: Mapping[int, ConvImpactError], W, v, e, mu,
                 law: str, et=None) -> None:
    bad = np.flatnonzero(status != OK)
    if not bad.size:
        return
    i = int(bad[0])
    exc = errors.get(i) or _kernel_error(W[i], v[i], float(e[i]), float(mu[i]), law,
                                         int(status[i]), i, status.shape[0],
                                         0.0 if et is None else float(et[i]))
    if bad.size > 1:
        exc.args = (f"{exc.args[0]} ({bad.size} impacts of the batch were rejected; "
                    "on_error='flag' returns per-impact status codes instead)",)
    raise exc


def _input_error(code: int, i: int, n: int, M: np.ndarray, J: np.ndarray | None = None,
                 dq: np.ndarray | None = None) -> InputError:
    from ..laws import codes as K  # numba is loaded: the drivers ran

    im = i if M.shape[0] > 1 else 0
    where = f"impact {i} of the batch of {n}" if n > 1 else "the impact"
    mname = f"M[{i}]" if M.shape[0] > 1 else "M"
    jname = f"Jc[{i}]" if J is not None and J.shape[0] > 1 else "Jc"
    qname = f"dq[{i}]" if dq is not None and dq.shape[0] > 1 else "dq"
    if code == K.BAD_M_FINITE:
        return NonFiniteError(f"{mname} contains NaN or infinity ({where}); pass finite values")
    if code == K.BAD_M_SYMMETRY:
        A = M[im]
        return MassMatrixError(
            f"{mname} is not symmetric ({where}: max |M - M^T| = "
            f"{float(np.max(np.abs(A - A.T))):.3e} for max |M| = {float(np.max(np.abs(A))):.3e}"
            "); a generalized mass matrix B^T M B (eq. 3) is symmetric: check its assembly")
    if code == K.BAD_M_DEFINITE:
        A = M[im]
        lam = float(np.linalg.eigvalsh(0.5 * (A + A.T))[0])
        return MassMatrixError(
            f"{mname} is not positive definite ({where}: smallest eigenvalue {lam:.3e}); every "
            "body needs positive mass and the joint coordinates must be independent")
    if code == K.BAD_J_FINITE:
        return NonFiniteError(f"{jname} contains NaN or infinity ({where}); pass finite values")
    if code == K.BAD_DQ_FINITE:
        return NonFiniteError(f"{qname} contains NaN or infinity ({where}); pass finite values")
    if code == K.BAD_W_FINITE:
        return NonFiniteError(f"W or v contains NaN or infinity ({where}); pass finite values")
    return NonFiniteError(
        f"{where} overflows double precision (Delassus matrix, contact velocities or kinetic "
        "energy not finite); rescale the units of M, Jc and dq")
