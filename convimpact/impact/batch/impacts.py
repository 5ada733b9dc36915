"""Many single-contact impacts at once: :func:`resolve_impacts` and :func:`contact_impulses`.

``resolve_impacts(M, Jc, dq, e, mu, law=...)`` resolves N independent impacts of one contact
each -- the same answers as ``resolve_impact(M[i], Jc[i], dq[i], e[i], mu[i], law=law,
method="fast")`` to round-off -- in one compiled loop (:mod:`.drivers`): per item it
validates M (finite, symmetric, Cholesky), forms W = Jc M^-1 Jc^T and v- = Jc dq, applies the
law's exact single-contact kernel (the same compiled kernel every path runs), maps the impulse
back to dq+ and measures the flags of
:func:`~convimpact.impact.diagnostics.assemble_result`. ``contact_impulses(W, v, e, mu, law)``
is the lower-level entry on the Delassus blocks and contact velocities directly (the batch
analogue of :func:`convimpact.impact.exact.dispatch.solve_contact`).

Shapes: an argument with a leading batch dimension N is per impact, one without it is shared
by every impact (M (k, k) or (N, k, k); Jc (d, k) or (N, d, k) with d = 2 planar, 3 spatial;
dq (k,) or (N, k); e, mu scalars or (N,)). Arrays must be real numbers (no strings, no
booleans, no complex).

Error policy
------------
* **Bad input raises**, whatever ``on_error`` says, with the typed error of
  :func:`~convimpact.resolve_impact` (ShapeError, NonFiniteError, MassMatrixError,
  ParameterError, UnknownOptionError) and a message naming the first offending impact.
* **An impact the exact kernel rejects** -- a singular W where the law inverts it (or
  W_nn <= 0), a Painleve-like jam of a Newton law, no certified solution -- is *flagged* by
  default (``on_error="flag"``): its ``status`` is :data:`SINGULAR`, :data:`JAM` or
  :data:`NO_SOLUTION`, its regime :data:`FAILED` (-1), its numbers NaN, its flags False; the
  others are unaffected. ``on_error="raise"`` raises instead the error ``resolve_impact(...,
  method="fast")`` raises on the first such impact (SingularSystemError,
  NonPositiveEffectiveMassError, SolverError), naming its index. ``batch.error(i)`` gives that
  exception for any flagged item after the fact.

The compiled kernels are built on the first call and cached per user
(:mod:`convimpact.compiled`), so later processes load them in a fraction of a second;
:func:`compile_kernels` builds them ahead of time and says how long it took. ``import
convimpact`` compiles nothing and does not import numba; without numba the same code runs as
plain Python (with a warning).
"""

from __future__ import annotations

import math
import os
import time
from types import MappingProxyType, SimpleNamespace

import numpy as np

from ...errors import ConvImpactError, InputError, NotSupportedError, ParameterError, ShapeError
from ..resolve import check_law_parameters
from .checks import (  # noqa: F401  (the batch API's names)
    FAILED,
    JAM,
    LAW_CODES,
    NO_SOLUTION,
    OK,
    ON_ERROR,
    REGIMES,
    SINGULAR,
    STATUS_ERRORS,
    STATUS_NAMES,
    _batch_size,
    _batched,
    _check_degenerate,
    _check_options,
    _check_parameters,
    _flag_indefinite,
    _indefinite,
    _input_error,
    _item_error,
    _raise_first,
    _real_array,
    _status_of,
)
from .results import ContactBatch, ImpactBatch  # noqa: F401

#: relative accuracy of the answers (that of method="fast"; passed to the flags' thresholds)
BATCH_TOL = 1e-10

_DEFER = 9  # laws.codes.DEFER: outside the compiled range of scale, solved by solve_contact
_NO_ITEMS = np.zeros(0, dtype=np.int64)
_NO_IMPULSES = {2: np.zeros((0, 2)), 3: np.zeros((0, 3))}
_K = None  # the compiled module, imported on first use


def _kernels():
    """The compiled drivers (:mod:`.drivers`), imported on first use."""
    global _K
    if _K is None:
        from . import drivers as loop
        from ...compiled import LawEntries, announce

        announce("batch kernels (the law's, in the batch's dimension)", 5, loop.impact_batch,
                 loop.contact_batch)
        _K = SimpleNamespace(impact_batch=LawEntries(loop.impact_batch, 2),
                             contact_batch=LawEntries(loop.contact_batch, 2),
                             BAD_W_FINITE=loop.BAD_W_FINITE)
    return _K


# --------------------------------------------------------------------------------------------
# results


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


# --------------------------------------------------------------------------------------------
# threads: the compiled drivers release the GIL (nogil), so slices of a batch run in parallel

#: batches of at least this many items are split over threads (below, one call is cheaper)
PARALLEL_MIN = 8192
_POOL = None


def _thread_count(threads) -> int:
    """``threads`` validated: None -> the cores this process may use; else a positive int."""
    if threads is None:
        try:
            return max(1, len(os.sched_getaffinity(0)))
        except AttributeError:  # pragma: no cover - not on Linux
            return max(1, os.cpu_count() or 1)
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer)) \
            or threads < 1:
        raise ParameterError(f"threads must be a positive integer or None, got {threads!r}")
    return int(threads)


def _in_slices(run, n: int, threads: int) -> tuple[int, int]:
    """Run ``run(lo, hi) -> (first bad item in the slice or -1, deferred count)`` over the
    batch: in one call, or in ``threads`` contiguous slices on a thread pool. Every item is
    computed alone (a shared M is factored once per slice), so the answers do not depend on
    the split. Returns (first bad item or -1, deferred count) over the whole batch."""
    global _POOL
    if threads <= 1 or n < PARALLEL_MIN:
        return run(0, n)
    from concurrent.futures import ThreadPoolExecutor

    if _POOL is None or _POOL._max_workers < threads:
        _POOL = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="convimpact-batch")
    bounds = [(c * n // threads, (c + 1) * n // threads) for c in range(threads)]
    results = list(_POOL.map(lambda b: run(*b), bounds))
    bad = [lo + fb for (lo, _), (fb, _) in zip(bounds, results) if fb >= 0]
    return (min(bad) if bad else -1), sum(nd for _, nd in results)


def _part(a: np.ndarray, n: int, lo: int, hi: int) -> np.ndarray:
    """Items lo..hi of a batched argument (one shared by every item stays whole)."""
    return a[lo:hi] if a.shape[0] == n and n > 1 else a


# --------------------------------------------------------------------------------------------
# the public entries


def _coefficients(law: str, e, mu, e_t) -> tuple[tuple, dict]:
    """e, mu and e_t (0 for a law without one; refused with it) as batched float arrays, and
    which of them are shared by every impact."""
    et = check_law_parameters(law, e_t)
    arrays = (_real_array("e", e), _real_array("mu", mu),
              _real_array("e_t", 0.0 if et is None else et))
    return (tuple(_batched(name, a, 0, "") for name, a in zip(("e", "mu", "e_t"), arrays)),
            {name: a.ndim == 0 for name, a in zip(("e", "mu", "e_t"), arrays)})


def resolve_impacts(M, Jc, dq, e=0.0, mu=0.0, law: str = "pereira-nikravesh", *, e_t=None,
                    C=None, on_error: str = "flag", threads: int | None = None,
                    derivatives: bool = False) -> ImpactBatch:
    """Resolve N single-contact impacts at once (the batch form of ``resolve_impact``).

    Parameters
    ----------
    M : (k, k) or (N, k, k) array_like
        Generalized mass matrices (symmetric positive definite), shared or one per impact.
    Jc : (d, k) or (N, d, k) array_like
        Contact Jacobians in the contact frame, rows n, t (d = 2) or n, t1, t2 (d = 3).
    dq : (k,) or (N, k) array_like
        Joint velocities before impact.
    e, mu : float or (N,) array_like
        Restitution in [0, 1] and friction >= 0, shared or per impact.
    law : {"pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge", "chatterjee-ruina"}
        The impact law (as in ``resolve_impact``): its compiled kernel, the one every path
        runs.
    e_t : float or (N,) array_like, optional
        Tangential restitution in [-1, 1] of law ``"chatterjee-ruina"`` (default 0).
    C : None
        Closed loops are not batched: pass ``C`` to ``resolve_impact`` per impact.
    on_error : {"flag", "raise"}
        What to do with an impact the exact kernel rejects (singular W, Painleve-like jam, no
        certified solution): ``"flag"`` (default) records it in ``status`` and fills its
        numbers with NaN; ``"raise"`` raises the first one's typed error, naming its index.
        Bad input raises in either case.
    threads : int or None
        Threads a batch of at least :data:`PARALLEL_MIN` items is split over (the compiled
        loop releases the GIL); None: every core this process may use, 1: this thread only
        (e.g. inside a process pool). The answers do not depend on it.
    derivatives : bool
        True: also the items' derivatives, ``jacobian`` and ``impulse_jacobian`` stacked over
        the batch (as ``resolve_impact(..., derivatives=True)`` per item, e, mu and e_t taken
        per item as scalars), and ``one_sided`` (N,) (:mod:`.derivatives`).

    Returns
    -------
    ImpactBatch
        Arrays over the batch with ImpactResult's names: ``dq_plus`` (N, k), ``impulse``,
        ``v_minus``, ``v_plus`` (N, d), ``regime`` (codes into ``REGIMES``), ``energy_loss``,
        the diagnostic flags as bool arrays, ``effective_mass``, ``delassus``, ``status``.

    Raises
    ------
    ShapeError, NonFiniteError, MassMatrixError, ParameterError, UnknownOptionError
        for bad input (the message names the first offending impact);
    NotSupportedError
        when ``C`` is given;
    SingularSystemError, NonPositiveEffectiveMassError, SolverError
        with ``on_error="raise"`` only, for the first impact the kernel rejects.

    Examples
    --------
    The README's particle at 45 degrees, and the same particle at three friction values:

    >>> import numpy as np, convimpact as ci
    >>> from convimpact.impact.batch.impacts import resolve_impacts
    >>> M, Jc = 2.0 * np.eye(2), np.array([[0.0, 1.0], [1.0, 0.0]])
    >>> b = resolve_impacts(M, Jc, [1.0, -1.0], e=0.5, mu=[0.0, 0.3, 1.0])
    >>> b.regimes()
    ('frictionless', 'slide', 'stick')
    >>> np.round(b.v_plus[1], 3).tolist()
    [0.5, 0.55]
    """
    code = _check_options(law, on_error)
    nthreads = _thread_count(threads)
    if derivatives is not False:
        from .derivatives import check_batch_derivatives

        derivatives = check_batch_derivatives(derivatives, law)
    if C is not None:
        raise NotSupportedError(
            "resolve_impacts batches open-loop impacts only; for closed loops (C given) call "
            "resolve_impact per impact")
    M = _real_array("M", M)
    J = _real_array("Jc", Jc)
    q = _real_array("dq", dq)
    Mb = _batched("M", M, 2, "(k, k)")
    Jb = _batched("Jc", J, 2, "(d, k)")
    qb = _batched("dq", q, 1, "(k,)")
    (eb, mb, tb), coefficients_shared = _coefficients(law, e, mu, e_t)
    shared = {"M": M.ndim == 2, "Jc": J.ndim == 2, "dq": q.ndim == 1, **coefficients_shared}
    n = _batch_size({"M": Mb, "Jc": Jb, "dq": qb, "e": eb, "mu": mb, "e_t": tb}, shared)
    k = Mb.shape[1]
    if Mb.shape[2] != k or k == 0:
        raise ShapeError(f"M must be square k x k with k >= 1, got {M.shape[-2:]}")
    d = Jb.shape[1]
    if d not in (2, 3) or Jb.shape[2] != k:
        raise ShapeError(
            f"each contact Jacobian must be 2 x {k} (planar rows n, t) or 3 x {k} (spatial rows "
            f"n, t1, t2) to match M ({k} x {k}); got {J.shape[-2:]}")
    if qb.shape[1] != k:
        raise ShapeError(f"dq must be a vector of length {k} to match M, got {q.shape[-1:]}")
    _check_parameters(eb, mb, tb, shared)

    dq_plus = np.empty((n, k))
    impulse = np.empty((n, d))
    v_minus = np.empty((n, d))
    v_plus = np.empty((n, d))
    W = np.empty((n, d, d))
    regime = np.empty(n, np.int8)
    status = np.empty(n, np.int8)
    effm = np.empty(n)
    T0 = np.empty(n)
    T1 = np.empty(n)
    flags = np.zeros((n, 4), np.bool_)
    mu_all = np.empty(n)
    errors: dict[int, ConvImpactError] = {}
    if n:
        K = _kernels()
        outs = (dq_plus, impulse, v_minus, v_plus, W, regime, status, effm, mu_all, T0, T1,
                flags)

        def run(lo, hi):
            return K.impact_batch(code, d, *(_part(a, n, lo, hi)
                                             for a in (Mb, Jb, qb, eb, mb, tb)),
                                  BATCH_TOL, _NO_ITEMS, _NO_IMPULSES[d],
                                  *(o[lo:hi] for o in outs))

        first_bad, ndefer = _in_slices(run, n, nthreads)
        if first_bad >= 0:
            raise _input_error(int(status[first_bad]), int(first_bad), n, Mb, Jb, qb)
        _check_degenerate(W, Jb, n)
        e_all = np.broadcast_to(eb, (n,))
        et_all = np.broadcast_to(tb, (n,))
        if ndefer:
            _solve_deferred(law, code, status, regime, effm, W, v_minus, e_all, mu_all, et_all,
                            errors, lambda idx, pis: K.impact_batch(code, d, Mb, Jb, qb, eb, mb,
                                                                    tb, BATCH_TOL, idx, pis,
                                                                    *outs))
        if on_error == "raise":
            _raise_first(status, errors, W, v_minus, e_all, mu_all, law, et_all)
    else:
        e_all = et_all = np.zeros(0)
    jac = {}
    if derivatives:
        from .derivatives import batch_jacobians

        jac = dict(zip(("jacobian", "impulse_jacobian", "one_sided"), batch_jacobians(
            law, *(np.broadcast_to(a, (n,) + a.shape[1:]) for a in (Mb, Jb, qb, eb, mb, tb)),
            dq_plus, impulse, regime, status)))
    return ImpactBatch(
        dq_plus=_frozen(dq_plus), impulse=_frozen(impulse), regime=_frozen(regime),
        energy_loss=_frozen(T0 - T1), v_minus=_frozen(v_minus), v_plus=_frozen(v_plus),
        law=law, method="fast", energy_before=_frozen(T0), energy_after=_frozen(T1),
        energy_gained=_frozen(flags[:, 0].copy()),
        friction_pushes_slip=_frozen(flags[:, 1].copy()),
        slip_reversal=_frozen(flags[:, 2].copy()), penetration=_frozen(flags[:, 3].copy()),
        effective_mass=_frozen(effm), delassus=_frozen(W), status=_frozen(status),
        _errors=MappingProxyType(errors), _friction=mu_all, _restitution=e_all,
        _tangential=et_all, **jac)


def _solve_deferred(law: str, code: int, status, regime, effm, W, v, e, mu, et, errors,
                    finish) -> None:
    """Items outside the compiled loop's safe range of scale: solve_contact rescales them
    (exactly, by powers of two) and runs the same kernel."""
    from ..exact.dispatch import solve_contact

    idx = np.flatnonzero(status == _DEFER)
    done, pis = [], []
    d = W.shape[1]
    for i in idx:
        i = int(i)
        try:
            sol = solve_contact(W[i], v[i], float(e[i]), float(mu[i]), law, float(et[i]))
        except InputError:
            raise
        except ConvImpactError as exc:
            status[i] = _status_of(exc)
            regime[i] = FAILED
            errors[i] = _item_error(exc, i, status.shape[0])
            continue
        status[i] = OK
        regime[i] = REGIMES.index(sol.regime)
        effm[i] = math.nan if sol.effective_mass is None else float(sol.effective_mass)
        done.append(i)
        pis.append(np.asarray(sol.impulse, dtype=float).reshape(d))
    if done:
        finish(np.array(done, dtype=np.int64), np.array(pis))


def contact_impulses(W, v, e=0.0, mu=0.0, law: str = "pereira-nikravesh", *, e_t=None,
                     on_error: str = "flag", threads: int | None = None) -> ContactBatch:
    """Impulses of N single contacts from their Delassus blocks and velocities.

    The batch form of :func:`convimpact.impact.exact.dispatch.solve_contact`: item i equals
    ``solve_contact(W[i], v[i], e[i], mu[i], law)``. W is read from its upper triangle (as the
    kernels do); it is not checked for symmetry, and an item whose W is not positive
    semidefinite is flagged SINGULAR (every law: no impulse law applies to it).

    Parameters
    ----------
    W : (d, d) or (N, d, d) array_like
        Delassus blocks, d = 2 (n, t) or 3 (n, t1, t2).
    v : (d,) or (N, d) array_like
        Pre-impact contact velocities; v[..., 0] < 0 approaching.
    e, mu : float or (N,) array_like
    law : {"pereira-nikravesh", "coulomb", "ccp", "dissipative", "stronge", "chatterjee-ruina"}
        As in :func:`resolve_impacts`.
    e_t : float or (N,) array_like, optional
        As in :func:`resolve_impacts`.
    on_error : {"flag", "raise"}
        As in :func:`resolve_impacts`.
    threads : int or None
        As in :func:`resolve_impacts`.

    Returns
    -------
    ContactBatch
        ``impulse`` (N, d), ``regime``, ``status``, ``effective_mass``, ``v_plus = v + W pi``,
        ``energy_loss``.

    Examples
    --------
    >>> from convimpact.impact.batch.impacts import contact_impulses
    >>> b = contact_impulses([[0.5, 0.0], [0.0, 0.5]], [[-1.0, 1.0], [-1.0, 0.1]], e=0.5, mu=0.3)
    >>> b.regimes(), b.impulse.round(3).tolist()
    (('slide', 'stick'), [[3.0, -0.9], [3.0, -0.2]])
    """
    code = _check_options(law, on_error)
    nthreads = _thread_count(threads)
    Wa = _real_array("W", W)
    va = _real_array("v", v)
    Wb = _batched("W", Wa, 2, "(d, d)")
    vb = _batched("v", va, 1, "(d,)")
    (eb, mb, tb), coefficients_shared = _coefficients(law, e, mu, e_t)
    shared = {"W": Wa.ndim == 2, "v": va.ndim == 1, **coefficients_shared}
    n = _batch_size({"W": Wb, "v": vb, "e": eb, "mu": mb, "e_t": tb}, shared)
    d = vb.shape[1]
    if d not in (2, 3) or Wb.shape[1:] != (d, d):
        raise ShapeError(
            f"a contact needs W of shape (d, d) and v of length d with d = 2 (n, t) or 3 "
            f"(n, t1, t2); got W {Wa.shape[-2:]} and v {va.shape[-1:]}")
    _check_parameters(eb, mb, tb, shared)
    impulse = np.empty((n, d))
    regime = np.empty(n, np.int8)
    status = np.empty(n, np.int8)
    effm = np.empty(n)
    vplus = np.empty((n, d))
    eloss = np.empty(n)
    errors: dict[int, ConvImpactError] = {}
    if n:
        K = _kernels()
        outs = (impulse, regime, status, effm, vplus, eloss)

        def run(lo, hi):
            return K.contact_batch(code, d, *(_part(a, n, lo, hi)
                                              for a in (Wb, vb, eb, mb, tb)),
                                   *(o[lo:hi] for o in outs))

        first_bad, ndefer = _in_slices(run, n, nthreads)
        if first_bad >= 0:
            raise _input_error(K.BAD_W_FINITE, int(first_bad), n, Wb)
        W_all = np.broadcast_to(Wb, (n, d, d))
        v_all = np.broadcast_to(vb, (n, d))
        e_all = np.broadcast_to(eb, (n,))
        mu_all = np.broadcast_to(mb, (n,))
        et_all = np.broadcast_to(tb, (n,))
        if ndefer:
            def finish(idx, pis):
                impulse[idx] = pis
                Wi = np.triu(W_all[idx]) + np.triu(W_all[idx], 1).transpose(0, 2, 1)
                u = np.einsum("nij,nj->ni", Wi, pis)
                vplus[idx] = v_all[idx] + u
                eloss[idx] = -(np.einsum("ni,ni->n", pis, v_all[idx])
                               + 0.5 * np.einsum("ni,ni->n", pis, u))

            _solve_deferred(law, code, status, regime, effm, W_all, v_all, e_all, mu_all,
                            et_all, errors, finish)
            failed = status != OK
            impulse[failed] = np.nan
            vplus[failed] = np.nan
            eloss[failed] = np.nan
        indefinite = _indefinite(Wb)
        if indefinite.any():
            _flag_indefinite(np.broadcast_to(indefinite, (n,)), status, regime,
                             (impulse, effm, vplus, eloss), errors, n)
        if on_error == "raise":
            _raise_first(status, errors, W_all, v_all, e_all, mu_all, law, et_all)
    return ContactBatch(impulse=_frozen(impulse), regime=_frozen(regime),
                        status=_frozen(status), effective_mass=_frozen(effm),
                        v_plus=_frozen(vplus), energy_loss=_frozen(eloss), law=law,
                        _errors=MappingProxyType(errors))


def compile_kernels() -> dict[str, float]:
    """Build (or load from numba's on-disk cache) every compiled kernel now.

    Returns seconds per step: ``import`` (numba and the module), ``planar`` and ``spatial``
    (the first call of each driver on one impact per law). Later calls in this process pay
    nothing; later processes load the cached machine code.
    """
    t0 = time.perf_counter()
    _kernels()
    out = {"import": time.perf_counter() - t0}
    cases = {"planar": (np.eye(2), [[0.0, 1.0], [1.0, 0.0]], [1.0, -1.0]),
             "spatial": (np.eye(3), [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                         [1.0, 0.5, -1.0])}
    for name, (M, Jc, dq) in cases.items():
        t = time.perf_counter()
        for law in LAW_CODES:
            b = resolve_impacts(M, Jc, dq, 0.5, 0.3, law)
            contact_impulses(b.delassus, b.v_minus, 0.5, 0.3, law)
        out[name] = time.perf_counter() - t
    return out


__all__ = ["resolve_impacts", "contact_impulses", "ImpactBatch", "ContactBatch", "REGIMES",
           "LAW_CODES", "STATUS_NAMES", "OK", "SINGULAR", "JAM", "NO_SOLUTION", "FAILED",
           "compile_kernels"]
