"""The ``pereira-nikravesh`` law's search at several contacts in one compiled call: the tiers
and the pick of :mod:`~convimpact.impact.laws.pn_complementarity` on its compiled path, with
the Python orchestration between its kernels moved into :func:`search`.

What the law does on its compiled path (``_search`` and ``_pick`` there) and :func:`search`
does alike, step for step:

1. the stick tier (:func:`~.pn_complementarity_kernels.stick_tier`, the same call) over the
   candidate active sets (those holding an approaching contact, largest first); every
   admissible one is a candidate, in that order;
2. if none: the slide tier. Every set's relaxed bound (:func:`~.pn_complementarity_kernels.
   relaxed_bounds`) and every several-contact program (:func:`~.pn_complementarity_slide.
   slide_many`, the same call); the sets visited by increasing bound (ties by the sets'
   tuples, as Python's ``sorted`` of ``(bound, A)``), +inf skipped, stopping at the first
   bound above the best admissible energy so far plus ``1e-9`` of the energy scale; a
   certified or trivial program is a candidate when admissible; a one-contact set slides by
   the single-contact law (:func:`~convimpact.impact.laws.pereira_nikravesh_kernel._pn_planar` or
   ``_pn_spatial``, the compiled kernel ``solve_contact`` dispatches to, with the same
   inputs), only when that contact approaches, and is a candidate when admissible at the
   tolerance 1e-10;
3. the pick: candidates sorted by energy (stable), the velocities ``W pi`` of each compared
   with the first's (``1e-8 max |v-|``), the ties (the first's velocities and energy within
   ``1e-9`` of the energy scale) ranked by the largest set, then the least impulse norm, then
   the order; the candidates with other velocities are reported (the law's warning).

**Warm starts** (:class:`SlideWarmStart`, a time stepper's island): each slide program is
first tried from the active set of its cones and the impulse of the previous call
(:func:`~.pn_complementarity_slide.slide_set_warm`); an accepted Newton answer is a KKT point
of the convex program, hence a minimizer, with the velocities and energy of the cold one
(where redundant contacts leave a family of minimizers, possibly another member).

**The pruned search** (``prune``, for a time stepper whose island slid on every contact on
the step before): :func:`~.pn_complementarity_prune.pruned_search`, without the stick sets
and slide programs that provably cannot be the law's answer (the argument there).

**Sets without a candidate.** The whole search too skips the sets certified to have no
admissible impulse and the stick sets certified to have no admissible sticking impulse
(:mod:`~.pn_complementarity_exclusion`): they could never be candidates, so the answer, the
candidates and the law's warning are those of the search over every set.

Where the law's Python path would do anything else -- an interior-point program (a slide
program no guess certifies), a one-contact kernel outside its safe scale or without
friction, a kernel error, a NaN bound, no admissible set -- :func:`search` returns
:data:`FALLBACK` and the caller runs the law's own search, which solves, reports or raises.
The answers are the law's (the same kernels on the same data; the one difference, products
such as ``W pi`` formed in compiled loops rather than by numpy, is round-off);
``tests/impact/test_pn_complementarity_search.py`` compares them with the law's own search.
"""

from __future__ import annotations

import functools

import numpy as np

from ...compiled import jit as _jit
from .pn_complementarity_exclusion import excluded_sets
from .pn_complementarity_kernels import relaxed_bounds, stick_tier
from .pn_complementarity_prune import SINGLE_ACCURACY, pruned_search, single_candidate
from .pn_complementarity_slide import slide_many_warm

TINY = 1e-300
#: statuses of :func:`search`
DONE, FALLBACK, NEEDS = 0, 1, 2
#: tiers of :func:`search`
STICK_TIER, SLIDE_TIER = 0, 1
#: the law's tolerances of its tie tests (pn_complementarity._pick and _slide_tier)
ENERGY_TIE = 1e-9
VELOCITY_TIE = 1e-8


@functools.lru_cache(maxsize=512)
def tuple_ranks(subsets: tuple[tuple[int, ...], ...]) -> np.ndarray:
    """Each set's position among ``subsets`` sorted as Python sorts tuples."""
    order = sorted(range(len(subsets)), key=lambda s: subsets[s])
    rank = np.empty(len(subsets), dtype=np.int64)
    rank[order] = np.arange(len(subsets))
    rank.flags.writeable = False
    return rank


@_jit
def _slide_tier(W, b, vminus, mu, d, masks, cone_rtol, slack_max, tol, wkind, wtang, wpi,
                wvalid, skip):
    """The relaxed bounds and :func:`~.pn_complementarity_slide.slide_many_warm` on the sets
    not in ``skip`` (those: bound +inf, not solved, their warm starts dropped)."""
    ns = masks.shape[0]
    N = W.shape[0]
    kept = np.flatnonzero(~skip)
    bounds = np.full(ns, np.inf)
    status = np.full(ns, -3, dtype=np.int64)
    spis = np.zeros((ns, N))
    sok = np.zeros(ns, dtype=np.bool_)
    senergy = np.zeros(ns)
    sub = masks[kept]
    kb = relaxed_bounds(W, b, vminus, mu, d, sub)
    kk, kt, kp, kv = wkind[kept], wtang[kept], wpi[kept], wvalid[kept]
    st, pis, ok, energy = slide_many_warm(W, b, vminus, mu, d, sub, cone_rtol, slack_max, tol,
                                          kk, kt, kp, kv)
    for t in range(kept.size):
        s = kept[t]
        bounds[s] = kb[t]
        status[s] = st[t]
        spis[s] = pis[t]
        sok[s] = ok[t]
        senergy[s] = energy[t]
        wkind[s] = kk[t]
        wtang[s] = kt[t]
        wpi[s] = kp[t]
        wvalid[s] = kv[t]
    for s in range(ns):
        if skip[s]:
            wvalid[s] = False
    return bounds, status, spis, sok, senergy


@_jit
def search(W, b, vminus, mu, e, d, masks, rank, tol, cond_max, cone_rtol, slack_max, lo, hi,
           wkind, wtang, wpi, wvalid, prune):
    """The law's search and pick (module docstring) on one problem.

    Parameters
    ----------
    W : (N, N) Delassus matrix; b, vminus : (N,) Newton velocity shift and v-; mu, e : (n,);
    d : 2 or 3; masks : (n_sets, n) the candidate sets (``candidate_sets``), rank : (n_sets,)
    their :func:`tuple_ranks`; tol : the slide programs' accuracy; cond_max, cone_rtol,
    slack_max : the law's constants; lo, hi : the single-contact kernels' safe scale;
    wkind, wtang, wpi, wvalid : the slide programs' warm starts
    (:func:`~.pn_complementarity_slide.slide_many_warm`, updated in place); prune:
    :func:`~.pn_complementarity_prune.pruned_search` instead of the tiers.

    Returns
    -------
    status : DONE or FALLBACK.
    tier : STICK_TIER or SLIDE_TIER.
    pi : (N,) the answer.
    sets : (n_found,) the candidates' set indices, by energy (stable).
    same : (n_found,) bool, candidate with the first's velocities.
    best : position of the answer in ``sets``.
    """
    N = W.shape[0]
    ns = masks.shape[0]
    fe = np.empty(ns)
    fs = np.empty(ns, dtype=np.int64)
    fpi = np.empty((ns, N))
    nf = 0
    tier = STICK_TIER
    none_i = np.zeros(0, dtype=np.int64)
    none_b = np.zeros(0, dtype=np.bool_)
    none_pi = np.zeros((0, N))
    skip = np.zeros(ns, dtype=np.bool_)
    if not prune:  # (the pruned search runs the stick sets it cannot exclude)
        # the sets with no admissible impulse, stick or slide, and those with no admissible
        # sticking impulse (:mod:`.pn_complementarity_exclusion`): never candidates
        skip, skip_stick = excluded_sets(W, b, mu, d, masks, max(tol, SINGLE_ACCURACY),
                                         slack_max, cone_rtol)
        kept = np.flatnonzero(~skip_stick)
        ok, energy, pis = stick_tier(W, b, vminus, mu, d, masks[kept], cond_max, cone_rtol,
                                     slack_max, SINGLE_ACCURACY)
        for t in range(kept.size):
            if ok[t]:
                fe[nf] = energy[t]
                fs[nf] = kept[t]
                fpi[nf] = pis[t]
                nf += 1
    vs = 0.0
    for a in range(N):
        vs = max(vs, abs(vminus[a]))
    big = 0.0
    for a in range(N):
        big = max(big, abs(W[a, a]))
    escale = max(0.5 * vs * vs / big, TINY)
    if prune:
        tier = SLIDE_TIER
        needs = np.empty(ns, dtype=np.int64)
        nf, nn = pruned_search(W, b, vminus, mu, e, d, masks, tol, cond_max, cone_rtol,
                               slack_max, lo, hi, escale, wkind, wtang, wpi, wvalid, fe, fs,
                               fpi, needs)
        if nf < 0:
            return FALLBACK, tier, fpi[0] * 0.0, none_i, none_b, 0, none_pi, none_i
        if nn > 0:
            return NEEDS, tier, fpi[0] * 0.0, fs[:nf].copy(), none_b, 0, fpi[:nf].copy(), \
                needs[:nn].copy()
    elif nf == 0:
        tier = SLIDE_TIER
        bounds, status, spis, sok, senergy = _slide_tier(W, b, vminus, mu, d, masks, cone_rtol,
                                                         slack_max, tol, wkind, wtang, wpi,
                                                         wvalid, skip)
        absW = np.abs(W)
        for s in range(ns):
            if np.isnan(bounds[s]):
                return FALLBACK, tier, fpi[0] * 0.0, none_i, none_b, 0, none_pi, none_i
        by_rank = np.argsort(rank)
        order = by_rank[np.argsort(bounds[by_rank], kind="mergesort")]
        best_e = np.inf
        for s in order:
            bound = bounds[s]
            if np.isinf(bound):
                continue
            if nf > 0 and bound > best_e + ENERGY_TIE * escale:
                break
            st = status[s]
            if st == 1 or st == -1:
                if sok[s]:
                    fe[nf] = senergy[s]
                    fs[nf] = s
                    fpi[nf] = spis[s]
                    best_e = min(best_e, senergy[s])
                    nf += 1
                continue
            members = np.flatnonzero(masks[s])
            if members.size != 1:
                return FALLBACK, tier, fpi[0] * 0.0, none_i, none_b, 0, none_pi, none_i
            got, pi, ok_one, energy_one = single_candidate(
                W, absW, vminus, b, e, mu, d, members[0], masks[s], cone_rtol, slack_max, lo,
                hi)
            if got == 2:
                return FALLBACK, tier, fpi[0] * 0.0, none_i, none_b, 0, none_pi, none_i
            if ok_one:
                fe[nf] = energy_one
                fs[nf] = s
                fpi[nf] = pi
                best_e = min(best_e, fe[nf])
                nf += 1
    if nf == 0:
        return FALLBACK, tier, np.zeros(N), none_i, none_b, 0, none_pi, none_i
    # the pick
    srt = np.argsort(fe[:nf], kind="mergesort")
    vs = max(vs, TINY)
    jump0 = W @ fpi[srt[0]]
    same = np.zeros(nf, dtype=np.bool_)
    best = -1
    best_len = 0
    best_norm = 0.0
    for k in range(nf):
        c = srt[k]
        jump = W @ fpi[c]
        dev = 0.0
        for a in range(N):
            dev = max(dev, abs(jump[a] - jump0[a]))
        same[k] = dev <= VELOCITY_TIE * vs
        if same[k] and fe[c] <= fe[srt[0]] + ENERGY_TIE * escale:
            size = 0
            for m in masks[fs[c]]:
                if m:
                    size += 1
            norm = np.sqrt(fpi[c] @ fpi[c])
            if best < 0 or size > best_len or (size == best_len and norm < best_norm):
                best, best_len, best_norm = k, size, norm
    return (DONE, tier, fpi[srt[best]].copy(), fs[srt[:nf]].copy(), same, best, none_pi,
            none_i)


class SlideWarmStart:
    """The slide programs' answers of one group of contacts (an island of a time stepper)
    kept from one call to the next, as warm starts of
    :func:`~.pn_complementarity_slide.slide_many_warm`; reset when the candidate sets change
    (another number of contacts, dimension or set of approaching contacts)."""

    def __init__(self):
        self.key = None
        self.arrays = None
        #: the last call slid on every contact (the slide tier picked the full set)
        self.full_slide = False
        #: the last call's answer came from the pruned search
        self.pruned = False

    def get(self, key, n_sets: int, n: int, d: int) -> tuple:
        if key != self.key:
            self.key = key
            self.arrays = (np.zeros((n_sets, n), dtype=np.int64), np.zeros((n_sets, n, 2)),
                           np.zeros((n_sets, n * d)), np.zeros(n_sets, dtype=np.bool_))
        return self.arrays
