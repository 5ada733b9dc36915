"""The compiled law table: a law's code -> its kernels, for the compiled drivers (the batch's
loops and the public call's lane), built from :data:`~convimpact.impact.laws.LAW_MODULES`:
adding a law adds nothing here.

A law's code is its index in ``LAW_MODULES``. :func:`planar_item` and :func:`spatial_item`
validate one contact the way :func:`convimpact.impact.exact.dispatch.dispatch` does
(separating, W_nn > 0, the compiled range of scale, else DEFER: the dispatcher rescales) and
call the law's kernels as its entry ``contact_kernel`` declares them (``compiled_kernel``'s
``planar``, ``spatial``, ``frictionless_inside``, ``tangential``). In compiled code the law is
a compile-time constant (the drivers make it one with ``numba.literally``), so a driver
compiles the one law it is called with -- the first call of a law does not wait for the
others. As plain Python (``NUMBA_DISABLE_JIT=1``, or no numba) the same functions look the
law up at run time.
"""

from __future__ import annotations

from . import LAW_MODULES, law_module
from .codes import DEFER, FAILED, FRICTIONLESS, OK, SAFE_HI, SAFE_LO, SEPARATING, SINGULAR, \
    _NAN, _jit, _pmax2

#: per law code: the law's ``contact_kernel`` (its compiled kernels and their conventions)
KERNELS = tuple(law_module(name).contact_kernel for name in LAW_MODULES)


@_jit
def _frictionless(w00, v0, e):
    return OK, FRICTIONLESS, -(1.0 + e) * v0 / w00, 0.0, 0.0, _NAN


@_jit
def _checks(w00, w11, w22, v0, v1, v2):
    """0 to solve, else the answer's status: separating (OK), W_nn <= 0, outside the range
    (a planar contact: w22 = v2 = 0)."""
    if not v0 < 0.0:
        return OK
    if not w00 > 0.0:
        return SINGULAR
    vs = _pmax2(_pmax2(-v0, abs(v1)), abs(v2))
    tr = w00 + w11 + w22
    if not (SAFE_LO <= tr <= SAFE_HI and SAFE_LO <= vs <= SAFE_HI):
        return DEFER
    return -1


@_jit
def _refused(st):
    if st == OK:
        return OK, SEPARATING, 0.0, 0.0, 0.0, _NAN
    return st, FAILED, _NAN, _NAN, _NAN, _NAN


def planar_item(law, w00, w01, w11, v0, v1, e, mu, et, out):
    """One planar contact of law code ``law``: (status, regime, p0, p1, p2, effective mass)."""
    st = _checks(w00, w11, 0.0, v0, v1, 0.0)
    if st >= 0:
        return _refused(st)
    k = KERNELS[law]
    if mu == 0.0 and not k.frictionless_inside:
        return _frictionless(w00, v0, e)
    if k.tangential:
        return k.planar(w00, w01, w11, v0, v1, e, mu, et, out)
    return k.planar(w00, w01, w11, v0, v1, e, mu, out)


def spatial_item(law, w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out):
    """One spatial contact of law code ``law`` (as :func:`planar_item`)."""
    st = _checks(w00, w11, w22, v0, v1, v2)
    if st >= 0:
        return _refused(st)
    k = KERNELS[law]
    if mu == 0.0 and not k.frictionless_inside:
        return _frictionless(w00, v0, e)
    if k.tangential:
        return k.spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out)
    return k.spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out)


def contact_item(law, dim, w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out):
    """One contact of law code ``law`` in dimension ``dim`` (2: planar, read from w00, w01,
    w11, v0, v1; 3: spatial): :func:`planar_item` or :func:`spatial_item`. In compiled code
    both ``law`` and ``dim`` are compile-time constants (the drivers make them so with
    ``numba.literally``), so a driver compiles the one kernel of the one dimension it is
    called with: a planar first call does not compile the law's spatial kernel."""
    if dim == 2:
        return planar_item(law, w00, w01, w11, v0, v1, e, mu, et, out)
    return spatial_item(law, w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out)


def _register_compiled() -> None:
    """The compiled forms of the two items: the law's kernel chosen when the driver is typed
    (``law`` a literal), so only that law compiles."""
    try:
        from numba import types
        from numba.extending import overload
    except ImportError:  # no numba: the plain functions above are the items
        return

    def _law(law):
        """The law's kernel entry once ``law`` is typed as a literal (numba first asks with
        the plain int: None, then with the literal the driver's ``literally`` forces)."""
        return KERNELS[law.literal_value] if isinstance(law, types.IntegerLiteral) else None

    @overload(planar_item, jit_options={"nogil": True, "error_model": "numpy"})
    def _planar(law, w00, w01, w11, v0, v1, e, mu, et, out):
        k = _law(law)
        if k is None:
            return None
        # the closure's constants: numba prunes the branch of the other arity at compile time
        kernel, inside, tangential = k.planar, k.frictionless_inside, k.tangential

        def impl(law, w00, w01, w11, v0, v1, e, mu, et, out):
            st = _checks(w00, w11, 0.0, v0, v1, 0.0)
            if st >= 0:
                return _refused(st)
            if mu == 0.0 and not inside:
                return _frictionless(w00, v0, e)
            if tangential:
                return kernel(w00, w01, w11, v0, v1, e, mu, et, out)
            return kernel(w00, w01, w11, v0, v1, e, mu, out)
        return impl

    @overload(spatial_item, jit_options={"nogil": True, "error_model": "numpy"})
    def _spatial(law, w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out):
        k = _law(law)
        if k is None:
            return None
        kernel, inside, tangential = k.spatial, k.frictionless_inside, k.tangential

        def impl(law, w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out):
            st = _checks(w00, w11, w22, v0, v1, v2)
            if st >= 0:
                return _refused(st)
            if mu == 0.0 and not inside:
                return _frictionless(w00, v0, e)
            if tangential:
                return kernel(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out)
            return kernel(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out)
        return impl

    @overload(contact_item, jit_options={"nogil": True, "error_model": "numpy"})
    def _contact(law, dim, w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out):
        # numba does not prune ``if dim == 2`` on a literal argument: the dimension's item is
        # chosen here, once ``dim`` (and ``law``) are typed as literals
        if not (isinstance(law, types.IntegerLiteral) and isinstance(dim, types.IntegerLiteral)):
            return None
        if dim.literal_value == 2:
            def impl(law, dim, w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out):
                return planar_item(law, w00, w01, w11, v0, v1, e, mu, et, out)
        elif dim.literal_value == 3:
            def impl(law, dim, w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out):
                return spatial_item(law, w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et,
                                    out)
        else:
            return None
        return impl


_register_compiled()
