"""The contact engine: a primal-dual interior point on the cone complementarity problem
``K ∋ r ⊥ u = W r + b ∈ K*`` (the convex relaxation of Coulomb's law, ``ccp``), finished by
Newton (:mod:`.finish`); Coulomb's law in De Saxce's form by Newton from the CCP's answer, or
where that misses, by an interior point on the law itself (:mod:`.coulomb_interior`, stopped
where it stalls) and an ADMM (:mod:`.admm_kernel` compiled, :mod:`.admm` on large sparse W,
its iterations compiled in :mod:`.admm_sparse_kernel`),
Newton again from what comes within 1e-5 (a long finish, :data:`LONG_NEWTON_STEPS`), and past
:data:`SPARING_NEWTON_MAX_ROWS` rows, where these miss (before them on weakly coupled contacts:
the sphere piles), the nonsmooth Gauss-Seidel with exact one-contact solves and Newton tries
(:mod:`.gauss_seidel`, :mod:`.local_coulomb`; Newton's tries lightly damped; the sticking
contacts' velocity solved to zero between sweeps, :mod:`.subspace`). :func:`solve` is the
entry; small problems go first to the compiled dense kernels of the same method, and up to
:data:`ADMM_FIRST_MAX_ROWS` rows the compiled ADMM from zero gets a bounded try first (before
the kernels above :data:`ADMM_FIRST_MIN_ROWS` rows): :mod:`.first_tries`.

The CCP's interior point (Mehrotra's predictor-corrector with Nesterov-Todd scaling, dense or
sparse) is :mod:`.ccp_interior`. Where W is singular the velocity is unique and the impulses are
not: the answer is the interior point's iterate where it stops, or, from 120 to 300 rows, the
ADMM's when its short try is certified first.

Where W has more rows than rank (every stack and pile) and the finish's sparse step is the
costlier one, the Newton steps and the sparse ADMM's solves go through ``W = G G^T``
(:mod:`.lowrank`, decided once per solve by a count of flops).

The answer is accepted on the natural-map residual in the original data
(:func:`.cones.natural_map_residual`) and never returned above ``tol``: the caller raises.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from . import cones
from .ccp_interior import EngineResult, solve_ccp, use_sparse  # noqa: F401 (public here)
from .admm import RELAX, AdmmRace, ccp_admm
from .admm_kernel import dense_admm
from .coulomb_interior import coulomb_interior
from .finish import newton_finish
from .fixed_point import shift_fixed_point
from .gauss_seidel import nsgs_light, weakly_coupled
from .generalized import engine_factors
from .light_direct import DAMPING as LIGHT_DAMPING, FIRST as LIGHT_FIRST, \
    STALL_STEPS as LIGHT_STALL, STEPS as LIGHT_STEPS, light_direct
from .first_tries import (  # noqa: F401 (the engine's constants and warm start, public here)
    ADMM_FIRST_MAX_ROWS, ADMM_FIRST_MIN_ROWS, COMPILED_MAX_ROWS, HANDOVER_TOL, admm_first,
    compiled_answer, kernels, warm_newton)
from .threads import one_blas_thread

#: Coulomb's law: the ADMM from the CCP answer is the compiled dense one
#: (:mod:`.admm_kernel`) for W dense or up to this many rows; above, :mod:`.admm` on W's
#: sparse factorization (per iteration the dense one was 1.5-1.8x faster than it at 380-400
#: rows on piles, 1.5x slower at 670 on a wall)
DENSE_ADMM_MAX_ROWS = 450
#: Newton steps on Coulomb's natural map straight from the CCP answer past
#: :data:`SPARING_NEWTON_MAX_ROWS` rows on sparse W, where the ADMM of :mod:`.admm` also
#: tries Newton more often (the sphere piles of 624-897 contacts), stopped where it crawls
#: (DIRECT_STALL, DIRECT_FIRST: the log pile of 920 certified in 10 steps, the robot crowd of
#: 480 at 2e-8 after 10, certified in 12: 78 -> 53 ms, where the interior point on the law had
#: followed the 10; the others stop before 10); up to those rows or on dense W the light
#: Newton of :mod:`.light_direct` (its weight, steps and stops), run there where light_direct
#: has not, the long Newton following (certified: planar-stack-400 in 1 light step, 160
#: TALOS feet in 9 and 1, box-stack-200 in 3 and 12; elsewhere the ADMM's way is the cheaper)
DIRECT_NEWTON_STEPS = 12
SPARING_NEWTON_MAX_ROWS = 900
#: the CCP: past its interior point and Newton finish (stopped by TRY_STALL, DIRECT_STALL past
#: SPARING_NEWTON_MAX_ROWS) the ADMM
#: (:func:`.admm.ccp_admm`), at most this many iterations, aiming at this fraction of tol (a
#: wall of 976 contacts: 9.1e-9 to 9.4e-9 at tol with b perturbed by 1e-14, 8e-10 at 0.1 tol)
CCP_ADMM_ITER = 10000
CCP_ADMM_MARGIN = 0.1
#: Newton steps of a try from an ADMM iterate (within 1e-5 it converges in 1-4 where it does)
POLISH_STEPS = 4
#: Coulomb's law: the interior point on the law itself (:mod:`.coulomb_interior`) runs at most
#: this many steps where Newton from the CCP answer missed (it converged in about 20 on
#: stacks, stalled early elsewhere), and Newton is tried from its answer within
#: :data:`POLISH_FROM`
COULOMB_IP_ITER = 60
POLISH_FROM = 1e-4
#: Coulomb's law: where the ADMM's way ends within :data:`LONG_NEWTON_FROM`, Newton runs up to
#: this many steps from its best answer before the fixed point (on a pile of 624 spheres the
#: regularized Newton went from 8e-7 to 7e-9 in 30 steps, slowly, where the short tries of 4
#: and 10 had stopped)
LONG_NEWTON_FROM = 1e-5
LONG_NEWTON_STEPS = 40
#: past :data:`SPARING_NEWTON_MAX_ROWS` rows (a Newton step: 0.05-0.15 s at 2,900 rows) a try
#: from an ADMM iterate, the direct one and the CCP's finish stop where their best has not
#: halved in this many steps, the long Newton in LONG_STALL (on the walls of 424 and 976
#: contacts 6e-6 to 4.3e-6 in 40 steps, 1.2 s; below, it reached tol in 26-39 at 480-600 rows)
TRY_STALL = 5
LONG_STALL = 10
#: ...the direct one (from the CCP answer) where its best has not halved in DIRECT_STALL
#: steps (walls of 424 and 976 contacts, log pile of 528: 2-3 steps instead of 5-7, 3.7e-3
#: to 1.1e-3 left, 20 ms a step at 976; those that served halved it every two steps: a log
#: pile of 920, 10 steps to 2.5e-9, a robot crowd of 480, 10 steps to 2e-8)
DIRECT_STALL = 2
#: ...and after DIRECT_FIRST[0] steps where its best is above DIRECT_FIRST[1] times the
#: start's (first steps from the CCP answer: 0.29 on the log pile of 920 and the box stack of
#: 400, 0.45 on the robot crowd of 480, 0.49 and 0.54 on the walls of 976 and 424; the log
#: pile of 528 none, 1.0: one step, 17 ms, instead of two, 0.154 -> 0.130 s)
DIRECT_FIRST = (1, 0.6)
#: ...and for Coulomb's law on strongly coupled contacts (not the NSGS's first) the CCP
#: answer is a start only: its finish is skipped from within CCP_START_FROM, else stopped
#: by DIRECT_STALL (the wall of 976 contacts: 5 steps, 0.15 s, from 1.9e-7 to 1.2e-7, the
#: ADMM's iterations after them 6,054 from there, 6,049 from the interior point's 1.9e-7)
CCP_START_FROM = 1e-6
#: (the CCP's own finish past SPARING_NEWTON_MAX_ROWS rows stops by DIRECT_STALL too: on the
#: wall of 976 contacts 2 steps instead of 5, its ADMM then 1,050 iterations instead of 920,
#: the CCP in 0.23 s instead of 0.29)
#: ...and a try from an ADMM iterate stops after TRY_FIRST[0] steps where it has not dropped
#: by TRY_FIRST[1] (the tries that served dropped 10-500x in 1-2 steps: walls of 424 and 976
#: contacts, log pile of 528, sphere piles; the failed ones 1.9-8x, 6-8 steps on; on the
#: walls of 424 and 976 and the log pile of 528 the one that served dropped 11x in its first
#: step, the failed ones by at most 1.2x: at 20-28 ms a step at 976) and after ADMM_TRY_STALL
#: steps where its best has not halved (the wall of 424: 9.3e-7 to 8.4e-8 in one step, then
#: 8.3e-8 for 5 more); up to SPARING_NEWTON_MAX_ROWS the try (POLISH_STEPS) is judged by
#: TRY_FIRST too, and the long Newton follows only where it was not cut (first steps that
#: served: 2.5e-4 to 0.012 on sphere piles of 145-288 contacts; cut: 0.99 on the wall of 224,
#: whose try and long Newton had taken 13 steps, 26 ms, where its sparse ADMM went on
#: for 240 iterations, 6 ms: 48 -> 34 ms; 0.70 on the log pile of 264, certified in 3, the
#: ADMM alone instead, 39 -> 38 ms)
TRY_FIRST = (1, 0.5)
ADMM_TRY_STALL = 3
#: ...and comes from within this residual, then on each drop by 100 (the ADMM alone certified
#: the walls of 424 and 976 contacts, from zero, and the log pile of 528 in 4,600, 5,740 and
#: 1,780 iterations, where tries from 1e-4 and in 1e-5 to 1e-2 had cost 1-4 s, failing; from
#: 9.3e-7 to 9.7e-7 the tries failed on all three, from 2.7e-7 and 2.2e-7 they certified the
#: wall of 424 and the log pile of 528 in one step, 100x: 2,616 -> 2,493 and 1,140 -> 1,080
#: iterations; on the wall of 976 from 2.7e-7 it failed)
ADMM_TRY_FROM = 3e-7
#: Coulomb's law on large sparse W: the ADMM of :mod:`.admm` stops where its best (Newton's
#: tries included) is above ADMM_STALL_ABOVE every ADMM_STALL_ITER iterations (sphere piles
#: of 624-897 contacts: 1e-2 at 2,000, the NSGS's; walls, log piles: 1e-4 by 640); it is
#: over-relaxed (RELAX) past SPARING_NEWTON_MAX_ROWS (below, a robot's crawl was lost)
ADMM_STALL_ITER = 2000
ADMM_STALL_ABOVE = 1e-4
#: ...and where its own best crawls below ADMM_STALL_ABOVE, a run from zero joins it
#: (:class:`.admm.AdmmRace`: the brick wall of 976 contacts)
#: Coulomb's law on large sparse W: where the ADMM of :mod:`.admm` ends its ``admm_iter``
#: iterations within this residual, it runs on alone up to :data:`ADMM_EXTEND_ITER` more (the
#: brick wall of 976 contacts from the CCP answer: 5.9e-7 at 20,000 iterations, 1e-8 at 43,520)
ADMM_EXTEND_FROM = 1e-6
ADMM_EXTEND_ITER = 40000


def solve(W, b: np.ndarray, mu: np.ndarray, d: int, *, coulomb: bool, tol: float = 1e-8,
          max_iter: int = 100, newton_iter: int = 30, admm_iter: int = 20000,
          sparse: bool | None = None, compiled: bool = True,
          start: np.ndarray | None = None, generalized=None) -> EngineResult:
    """The engine.

    With ``compiled``: from :data:`ADMM_FIRST_MIN_ROWS` to :data:`ADMM_FIRST_MAX_ROWS` rows the
    compiled ADMM from zero (:func:`.admm_kernel.dense_admm`, at most
    :data:`ADMM_FIRST_ITER` iterations for Coulomb's law, :data:`ADMM_FIRST_ITER_CCP` for the
    CCP, Newton tried from its iterate within 1e-5); then up to :data:`COMPILED_MAX_ROWS` rows
    the compiled dense kernels (interior point and Newton), and below
    :data:`ADMM_FIRST_MIN_ROWS` rows the ADMM's try after them. Each answer is kept when its
    natural-map residual is at most ``tol``. Then the CCP: the interior point, and the Newton
    finish where it stops short of ``tol`` (skipped when the compiled CCP kernel's answer is
    certified), then the ADMM (:data:`CCP_ADMM_ITER`). Coulomb's law: past
    :data:`SPARING_NEWTON_MAX_ROWS` rows on weakly coupled contacts
    (:func:`.gauss_seidel.weakly_coupled`: the sphere piles) the nonsmooth Gauss-Seidel first
    (:func:`.gauss_seidel.nsgs_light`, from the CCP's answer, Newton tried on its way); then
    Newton from the CCP's answer (lightly damped, :mod:`.light_direct`, up to
    :data:`SPARING_NEWTON_MAX_ROWS` rows or on dense W, the long Newton following within
    :data:`LONG_NEWTON_FROM`; past them :data:`DIRECT_NEWTON_STEPS`); where that does not reach
    ``tol``, the interior point on the law (:mod:`.coulomb_interior`, :data:`COULOMB_IP_ITER`
    steps at most; past :data:`SPARING_NEWTON_MAX_ROWS` rows before the ADMM where Newton came
    near, below after) and the ADMM (compiled on dense W and up to
    :data:`DENSE_ADMM_MAX_ROWS` rows, else :mod:`.admm` on the sparse factorization, joined by
    a run from zero where it crawls: :class:`.admm.AdmmRace`), Newton tried within 1e-5
    (:data:`ADMM_TRY_FROM` in .admm) and run long (:data:`LONG_NEWTON_STEPS`) from any answer
    within :data:`LONG_NEWTON_FROM`; past :data:`SPARING_NEWTON_MAX_ROWS` rows the NSGS
    where it did not run first; then the fixed point on De Saxce's shift (:mod:`.fixed_point`).

    ``start`` (n, d), optional, is a warm start (a time-stepping scheme's impulses of the
    previous step): the law's Newton finish (:func:`warm_newton`) runs from it first, and its
    answer is returned when its natural-map residual is at most ``tol``; otherwise the cold
    path above runs as without it (the warm attempt's steps are counted in ``iterations``).
    The interior point itself is not warm-started: its iterates must stay central, and a
    start on the cones' boundary (where impulses of sliding or open contacts lie) slows it.
    """
    warm_steps = 0
    if start is not None:
        R = warm_newton(W, b, mu, d, start, coulomb=coulomb, tol=tol, newton_iter=newton_iter,
                        sparse=sparse, compiled=compiled)
        if R.converged:
            return R
        warm_steps = R.iterations
    R = _cold(W, b, mu, d, coulomb, tol, max_iter, newton_iter, admm_iter, sparse, compiled,
              generalized)
    if warm_steps:
        R = EngineResult(R.impulse, R.velocity, R.residual, R.iterations + warm_steps,
                         R.converged, R.message)
    return R


def _cold(W, b, mu, d, coulomb, tol, max_iter, newton_iter, admm_iter, sparse, compiled,
          generalized=None):
    n = mu.shape[0]
    ccp = None
    spent = 0  # the iterations of the tries that did not certify (counted in the answer's)
    try_admm = compiled and n * d <= ADMM_FIRST_MAX_ROWS
    # the CCP's compiled kernels are fast and sure on their rows: its ADMM try comes above
    if try_admm and n * d > (ADMM_FIRST_MIN_ROWS if coulomb else COMPILED_MAX_ROWS):
        # the compiled interior point's dense Newton grows as rows^3: the ADMM first
        R = admm_first(W, b, mu, d, coulomb, tol, newton_iter, compiled)
        if R.converged:
            return R
        spent += R.iterations
        try_admm = False
    if compiled and n * d <= COMPILED_MAX_ROWS:
        R = compiled_answer(W, b, mu, d, coulomb, tol, max_iter, newton_iter)
        if R.converged:
            return _counted(R, spent)
        spent += R.iterations
    if try_admm and coulomb:
        R = admm_first(W, b, mu, d, coulomb, tol, newton_iter, compiled)
        if R.converged:
            return _counted(R, spent)
        spent += R.iterations
    if compiled and n * d <= COMPILED_MAX_ROWS and coulomb:  # the CCP answer, a start below
        ccp = compiled_answer(W, b, mu, d, False, tol, max_iter, newton_iter)
        ccp = ccp if ccp.converged else None
    with one_blas_thread(), np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if coulomb and compiled and ccp is None and n * d <= DENSE_ADMM_MAX_ROWS:
            R, ccp = light_direct(W, b, mu, d, tol=tol, max_iter=max_iter, sparse=sparse)
            if R.converged:  # (:mod:`.light_direct`: the stacks)
                return _counted(R, spent)
            spent += R.iterations - ccp.iterations  # (the CCP's are counted below)
            light_tried = True
        else:
            light_tried = False
        return _counted(_solve(W, b, mu, d, coulomb, tol, max_iter, newton_iter, admm_iter,
                               sparse, ccp, generalized, light_tried), spent)


def _counted(R: EngineResult, spent: int) -> EngineResult:
    """``R`` with ``spent`` more iterations (those of the tries before it)."""
    return R if not spent else EngineResult(R.impulse, R.velocity, R.residual,
                                            R.iterations + spent, R.converged, R.message)


def _solve(W, b, mu, d, coulomb, tol, max_iter, newton_iter, admm_iter, sparse, ccp=None,
           generalized=None, light_tried=False):
    n = mu.shape[0]
    if sparse is None:
        sparse = use_sparse(W, n * d)
    W = sp.csr_matrix(W) if sparse else (W.toarray() if sp.issparse(W) else W)
    b = np.asarray(b, dtype=float).reshape(n, d)
    # W = G G^T found where the finish first needs it, kept when of low rank
    factor, admm_factor = engine_factors(W, generalized, sparse)
    Gs = factor.G if sp.issparse(factor.G) else None  # (M, J)'s G where m <= 0.4 N
    R = ccp if ccp is not None else solve_ccp(W, b, mu, d, tol=tol, max_iter=max_iter,
                                              sparse=sparse, G=Gs)
    iterations = R.iterations
    dense_admm_here = not sparse or n * d <= DENSE_ADMM_MAX_ROWS
    sparing = dense_admm_here or n * d <= SPARING_NEWTON_MAX_ROWS
    ip_first = not sparing
    nsgs_first = bool(coulomb and ip_first and weakly_coupled(W, d))
    start_only = coulomb and ip_first and not nsgs_first  # (CCP_START_FROM)
    if R.residual > (CCP_START_FROM if start_only else tol):
        r, res, k = newton_finish(W, b, mu, R.impulse, coulomb=False, tol=tol,
                                  max_iter=newton_iter, sparse=sparse, factor=factor,
                                  stall_steps=DIRECT_STALL if start_only or ip_first
                                  and not coulomb else TRY_STALL)
        iterations += k
        if res < R.residual:
            res, u = cones.natural_map_residual(W, b, mu, r, coulomb=False)
            R = EngineResult(r, u, res, iterations, res <= tol,
                             "converged" if res <= tol else R.message)
    if not coulomb:
        if R.residual > tol and newton_iter > 0:  # the ADMM (CCP_ADMM_ITER), a finish too
            r, _, k = ccp_admm(W, b, mu, R.impulse, sparse, tol=CCP_ADMM_MARGIN * tol,
                               max_iter=min(admm_iter, CCP_ADMM_ITER), factor=admm_factor,
                               dense=not sparse or n * d <= DENSE_ADMM_MAX_ROWS)
            res, u = cones.natural_map_residual(W, b, mu, r, coulomb=False)
            if res < R.residual:
                R = EngineResult(r, u, res, iterations + k, res <= tol,
                                 "converged" if res <= tol else R.message)
        return R
    best = [np.inf, R.impulse, "converged"]
    long_tried = [np.inf]

    def long_newton(r, res):
        """Newton up to LONG_NEWTON_STEPS from an answer within LONG_NEWTON_FROM (once per
        drop of the residual by 100), its answer kept in ``best`` when better."""
        nonlocal iterations
        if not tol < res <= min(LONG_NEWTON_FROM, 1e-2 * long_tried[0]):
            return
        long_tried[0] = res
        rn, resn, k = newton_finish(W, b, mu, r, coulomb=True, tol=tol,
                                    max_iter=LONG_NEWTON_STEPS, sparse=sparse, factor=factor,
                                    stall_steps=None if sparing else LONG_STALL)
        iterations += k
        if resn < best[0]:
            best[:2] = resn, rn

    def interior():
        """The interior point on Coulomb's law itself, stopped where it stalls, and Newton
        from its answer within POLISH_FROM."""
        nonlocal iterations
        rc, resc, kc = coulomb_interior(W, b, mu, d, tol=tol, max_iter=COULOMB_IP_ITER,
                                        sparse=sparse)
        iterations += kc
        if tol < resc < POLISH_FROM:
            rn, resn, kn = newton_finish(W, b, mu, rc, coulomb=True, tol=tol,
                                         max_iter=min(newton_iter, POLISH_STEPS),
                                         sparse=sparse, factor=factor)
            iterations += kn
            if resn < resc:
                rc, resc = rn, resn
        if resc < best[0]:
            best[:2] = resc, rc
        long_newton(rc, resc)

    def nsgs():  # past SPARING_NEWTON_MAX_ROWS: the NSGS from the CCP answer
        nonlocal iterations
        rg, resg, kg = nsgs_light(W, b, mu, d, R.impulse, tol=tol, newton_iter=newton_iter)
        iterations += kg
        if resg < best[0]:
            best[:2] = resg, rg
            best[2] = "converged" if resg <= tol else "the NSGS's limits"

    # a separate branch: past SPARING_NEWTON_MAX_ROWS on weakly coupled contacts (the sphere
    # piles, :func:`.gauss_seidel.weakly_coupled`) the NSGS first: 0.9-1.9 s to certify piles
    # of 624-897 spheres, where the interior point and the ADMM spent 1.2-2.5 s and stalled
    # at 7e-5-6e-2 (after them elsewhere: it left brick walls at 2e-5-2e-6); before the direct
    # Newton too (on the piles it stalled, 0.2-0.4 s; not needed by planar-stack-1000)
    if nsgs_first:
        nsgs()
    res = best[0]
    # sparing, the direct Newton is light (:mod:`.light_direct`'s weight, steps and stops),
    # the long one following within LONG_NEWTON_FROM, and none where light_direct ran (160
    # TALOS feet: 9 light steps to 1.4e-8, where the full weight's 4 had left 1.3e-4 and the
    # ADMM's way took 40 more; box-stack-200: 3 to 2.9e-7, then 12; the log pile of 264: cut
    # after 1, 0.44, where the full weight's 4 had served nothing; after light_direct the
    # full weight's first step crawled too, 0.68-0.83, on the log pile of 135 and the sphere
    # piles of 126 and 145 contacts)
    if res > tol and not (sparing and light_tried):
        if sparing:
            r, res, k = newton_finish(W, b, mu, R.impulse, coulomb=True, tol=tol,
                                      max_iter=min(newton_iter, LIGHT_STEPS), sparse=sparse,
                                      factor=factor, stall_steps=LIGHT_STALL,
                                      first=LIGHT_FIRST, damping=LIGHT_DAMPING)
        else:
            r, res, k = newton_finish(W, b, mu, R.impulse, coulomb=True, tol=tol,
                                      max_iter=min(newton_iter, DIRECT_NEWTON_STEPS),
                                      sparse=sparse, factor=factor,
                                      stall_steps=TRY_STALL if nsgs_first else DIRECT_STALL,
                                      first=None if nsgs_first else DIRECT_FIRST)
        iterations += k
        if res < best[0]:
            best[:2] = res, r
        if sparing:
            long_newton(r, res)
    # past SPARING_NEWTON_MAX_ROWS before the ADMM where Newton came within POLISH_FROM (the
    # sparse ADMM took 10 s on a 400-box stack, Newton 3e-5, the interior point certified it),
    # else not (walls of 424 and 976 contacts, log pile of 528, sphere piles: Newton 6.5e-4 to
    # 2e-2, the interior point stalled at 8e-4 to 6e-2 in 0.15-0.55 s); below, after the ADMM
    ip_before = ip_first and res <= POLISH_FROM
    if best[0] > tol and ip_before:
        interior()
    if best[0] > tol:
        tried = [np.inf]

        last = [np.inf]  # the residual of the last iterate checked

        def check(r, given=None):
            # given: the compiled sparse ADMM's own residual of r (W's product through G),
            # taken above 2 tol; near tol and elsewhere the certificate's, on W as given
            nonlocal iterations
            res = given if given is not None and given > 2.0 * tol else \
                cones.natural_map_residual(W, b, mu, r, coulomb=True)[0]
            last[0] = res
            if res < best[0]:
                best[:2] = res, r
            if best[0] <= tol:
                return True
            # sparing: Newton tried from within 1e-5, then after each drop by 1000 (as the
            # compiled ADMM's polish); else from within ADMM_TRY_FROM, on each drop by 100
            if res < (min(1e-5, 1e-3 * tried[0]) if sparing
                      else min(ADMM_TRY_FROM, 1e-2 * tried[0])):
                tried[0] = res
                rn, resn, k = newton_finish(W, b, mu, r, coulomb=True, tol=tol,
                                            max_iter=min(newton_iter, POLISH_STEPS if sparing
                                                         else 10), sparse=sparse, factor=factor,
                                            stall_steps=None if sparing else ADMM_TRY_STALL,
                                            first=TRY_FIRST)
                iterations += k
                if resn < best[0]:
                    best[:2] = resn, rn
                if sparing and resn <= TRY_FIRST[1] * res:  # (else it was cut: TRY_FIRST)
                    long_newton(rn, resn)
            tried.append(res)
            return best[0] <= tol

        # the ADMM from the CCP answer (from zero, 1.2-3.5x slower on most of the corpus, is
        # the sparse ADMM's second start, joining where the first crawls: admm.AdmmRace)
        done = 0
        if dense_admm_here:  # compiled, dense

            def polish(r):
                nonlocal iterations
                rn, resn, k = newton_finish(W, b, mu, r, coulomb=True, tol=tol,
                                            max_iter=min(newton_iter, POLISH_STEPS),
                                            sparse=sparse, factor=factor)
                iterations += k
                return rn, resn, k

            Wd = W.toarray() if sp.issparse(W) else W
            r, _, done = dense_admm(Wd, b, mu, d, R.impulse, tol=tol, max_iter=admm_iter,
                                    polish=polish, relax=RELAX)
            res, _ = cones.natural_map_residual(W, b, mu, r, coulomb=True)
            if res < best[0]:
                best[:2] = res, r
            if best[0] > tol and not ip_first:
                interior()
        else:
            runs = AdmmRace(W, b, mu, R.impulse, sparse, factor=admm_factor,
                            below=ADMM_STALL_ABOVE, relax=RELAX if not sparing else 1.0,
                            tol=tol)
            while done < admm_iter:
                done += 10
                r = runs.next()
                if check(r, runs.residual):
                    break
                runs.judge(last[0])
                if done % ADMM_STALL_ITER == 0 and best[0] > ADMM_STALL_ABOVE:
                    break  # stalled far from a solution: the NSGS's way below
            # within ADMM_EXTEND_FROM at its limit the ADMM goes on alone (no Newton tries)
            extra = 0
            while tol < best[0] <= ADMM_EXTEND_FROM and extra < ADMM_EXTEND_ITER:
                extra += 10
                done += 10
                r = runs.next()
                res = runs.residual
                if res is None or res <= 2.0 * tol:
                    res, _ = cones.natural_map_residual(W, b, mu, r, coulomb=True)
                if res < best[0]:
                    best[:2] = res, r
            if best[0] > tol and not ip_first:
                interior()
        iterations += done  # (the direct Newton's steps were counted once, above)
        best[2] = "the ADMM's iteration limit" if best[0] > tol else "converged"
        long_newton(best[1], best[0])  # from the ADMM's best answer
        if best[0] > tol and ip_first and not nsgs_first:
            nsgs()
        if best[0] > tol:  # the fixed point on the De Saxce shift, CCP by CCP
            for r in shift_fixed_point(W, b, mu, d, best[1], tol, max_iter, sparse, solve_ccp):
                iterations += 1
                if check(r):
                    best[2] = "converged"
                    break
            else:
                best[2] = "the ADMM's and the fixed point's iteration limits"
    res, u = cones.natural_map_residual(W, b, mu, best[1], coulomb=True)
    return EngineResult(best[1], u, res, iterations, res <= tol,
                        "converged" if res <= tol else f"Coulomb's law not solved ({best[2]})")

