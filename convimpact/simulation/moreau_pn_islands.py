"""Law ``"pereira-nikravesh"`` on Moreau–Jean's islands in one compiled call per step: the
islands of a resting or a sliding mode answered without :func:`convimpact.resolve_impact`
and without Python per island (:func:`pn_islands`), for :class:`.moreau_impact.ImpactSolver`
(:class:`PnIslands`).

**When.** On a step where no active contact approaches at the step's start
(``v_n,k >= -rest_velocity`` everywhere: no impact to record, every ``e_eff`` is 0), for
law ``pereira-nikravesh`` under the methods whose several-contact path is the law's
compiled one (:data:`.moreau_impact.DIRECT_METHODS`), once the law's compiled path is taken
(:func:`~convimpact.impact.laws.pn_complementarity.compiled_path_active`), on a mechanism
without loop constraints. Every other step, and every island this call does not answer,
takes :class:`.moreau_impact.ImpactSolver`'s own path, as before.

**What it answers.** Exactly the islands that solver answers without the law's full search
(its module docstring gives the arguments):

* an island in a *resting mode* (certified sticking on every contact on the step before,
  with the same contacts): the certificate of :mod:`.moreau_pn_kernels` again
  (:func:`~.moreau_pn_kernels.coordinate_certificate`: the same solve and tests, in the
  island's coordinates where W is singular); where it holds, its
  impulse; where it does not, the solver's path;
* an island in a *sliding mode* (the law's answer slid on every contact on the step
  before, with the same contacts): the law's search without the dominated active sets and
  those certified to have no admissible impulse, the previous impulse re-certified where it
  still solves the full set's program
  (first the previous impulse with the search's own certificates in one pass,
  :func:`.moreau_pn_recertify.recertified_slide`, then, where one fails,
  :func:`~convimpact.impact.laws.pn_complementarity_search.search` with ``prune``, the
  call :func:`~convimpact.impact.laws.pn_complementarity_impulse.compiled_impulse` makes,
  with the island's warm starts), when every contact of the island approaches by more
  than round-off (the candidate sets of the law are then every non-empty subset, the
  precomputed ones); where that search answers (``DONE``), its impulse, else the solver's
  path (which runs the same pruned search, then the law's own search);
* an island whose contacts all separate under ``v_free``: no impulse.

The checks are the direct path's: the island's ``W = J G J^T`` (G the step's block inverse
of M, :func:`.moreau_kernels.island_delassus`) and ``v- = J v_free`` symmetrized and checked
as :func:`~convimpact.impact.problem.build.build_problem` does
(:func:`~convimpact.contacts.interior_point.contact_checks`: not plain -> the solver's path);
the certificate's and the search's own certificates (KKT conditions, admissibility, the
pruning's exclusions) unchanged; anything else -> the solver's path. The answered islands
take ``v_{k+1} = v_free + G J^T pi`` on their coordinates (the law's velocities to
round-off: ``build_problem`` forms ``W`` and the jump through M's Cholesky factor instead).

**The modes and warm starts** are the solver's (``_modes_last``, ``_warm``): after a step
the solver's Python path took part in, they are read from it; after a step answered here
alone, the modes are this class's (``mode``) and the warm starts' arrays, views of this
class's buffers (one size of island per layout: the most common one), are shared with the
solver's :class:`~convimpact.impact.laws.pn_complementarity_search.SlideWarmStart` objects,
which are handed back to the solver whenever its path runs. The first step of a mode is
always the solver's (the law's full search and its ambiguity warning), as before.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..compiled import announce
from ..compiled import jit as _jit
from ..contacts.interior_point import contact_checks
from ..errors import ConvImpactError
from ..impact.conic.paths import APPROACH_RTOL, parse_options
from ..impact.laws import pn_complementarity as pn
from ..impact.laws.pn_complementarity import MAX_CONTACTS
from ..impact.laws.pn_complementarity_impulse import _ranks, _sets
from ..impact.laws.pn_complementarity_search import DONE, SLIDE_TIER, SlideWarmStart, search
from ..impact.problem.build import IMMOBILE_RTOL, SAFE_SCALE, TINY_NORMAL
from .moreau_kernels import (apply_island_impulse, island_delassus, island_velocity,
                             same_pattern_on)
from .moreau_pn_kernels import coordinate_certificate
from .moreau_pn_recertify import recertified_slide
from .moreau_step_kernels import dense_support

#: island modes (:class:`PnIslands`)
NONE, REST, SLIDE = 0, 1, 2
#: first compilation of :func:`pn_islands` on 2 cores (s), announced on stderr
COMPILE_SECONDS = 30
#: island statuses of :func:`pn_islands`
FULL, STUCK, SEPARATING, CERTIFIED_NEW, SLID = 0, 1, 2, 3, 4


@_jit
def _end_mode(i, slot, mode, wvalid):
    """Island i leaves its mode and its warm starts (as the solver's path drops the warm
    start of an island it does not search)."""
    mode[i] = NONE
    if slot[i] >= 0:
        for s in range(wvalid.shape[1]):
            wvalid[slot[i], s] = False


@_jit
def pn_islands(Ja, vn_k, v_free, G, active, ref_active, ref_moves, icon, icoff, icol,
               icoloff, eligible, slot, mode, mu_all, masks, rank, wkind, wtang, wpi, wvalid,
               tols, r, v_new, status, full_slide, jcol, joff):
    """For every island i (contacts ``icon[icoff[i]:icoff[i + 1]]``, rows of ``Ja`` (na, d,
    k), among the ``active`` contacts; coordinates ``icol[icoloff[i]:icoloff[i + 1]]``) the
    answer of the module docstring where it applies.

    ``eligible[i]``: an island the law's direct path takes (2 to MAX_CONTACTS contacts);
    ``mode[i]``: NONE, REST or SLIDE; ``slot[i]``: its warm starts' index in ``wkind``
    (n_slots, n_sets, n), ``wtang``, ``wpi``, ``wvalid`` (updated where answered), -1 for
    none; ``masks`` (n_sets, n), ``rank``: the law's candidate sets of n contacts all
    approaching and their tuple ranks; ``tols``: rest_velocity, immobile_rtol, tiny_normal,
    APPROACH_RTOL, STICK_COND_MAX, CONE_RTOL, VELOCITY_SLACK_MAX, the slide programs'
    accuracy and the single-contact kernels' safe scale (lo, hi).

    Returns ``(-1, 0, 0, 0)`` (nothing done) on a step with an impact (some
    ``vn_k < -rest_velocity``) and ``(-2, 0, 0, 0)`` when the islands were laid out for other
    contacts (``active`` is not ``ref_active`` or ``Ja``'s nonzero columns are not
    ``ref_moves``); else (islands FULL, STUCK, SLID, the most contacts of one answered),
    having written ``status[i]``: STUCK (resting mode, certified), SLID
    (sliding mode, the pruned search's answer; ``full_slide[i]``: on every contact),
    SEPARATING, CERTIFIED_NEW (certified, not in a resting mode: the solver searches it)
    or FULL; impulses into ``r`` (na, d) and ``v_free + G J^T pi`` into ``v_new`` (which
    holds ``v_free`` on entry) for STUCK and SLID islands. ``jcol``, ``joff``: the
    supports of the contacts' rows (:attr:`.moreau_loop.Step.support`)."""
    rest_velocity, immobile_rtol, tiny_normal = tols[0], tols[1], tols[2]
    approach_rtol, cond_max, cone_rtol, slack_max = tols[3], tols[4], tols[5], tols[6]
    slide_tol, lo, hi = tols[7], tols[8], tols[9]
    d = Ja.shape[1]
    for c in range(vn_k.shape[0]):
        if vn_k[c] < -rest_velocity:
            return -1, 0, 0, 0
    if not same_pattern_on(Ja, active, ref_active, ref_moves, jcol, joff):
        return -2, 0, 0, 0
    full, stuck, slid, largest = 0, 0, 0, 0
    for i in range(icoff.shape[0] - 1):
        c0, c1 = icoff[i], icoff[i + 1]
        nc = c1 - c0
        N = nc * d
        cons = icon[c0:c1]
        cols = icol[icoloff[i]:icoloff[i + 1]]
        status[i] = FULL
        full_slide[i] = False
        vm = np.zeros(N)
        island_velocity(Ja, v_free, cons, cols, d, vm)
        touching = False
        vscale = 0.0
        for c in range(nc):
            if vm[c * d] < 0.0:
                touching = True
            for a in range(d):
                vscale = max(vscale, abs(vm[c * d + a]))
        if not touching:
            status[i] = SEPARATING
            _end_mode(i, slot, mode, wvalid)
            continue
        if not eligible[i]:
            full += 1
            continue
        W = np.empty((N, N))
        island_delassus(Ja, G, cons, cols, d, W)
        if contact_checks(W, vm, d, immobile_rtol, tiny_normal) != 0:
            full += 1
            continue
        mu = np.empty(nc)
        frictional = True
        for c in range(nc):
            mu[c] = mu_all[active[cons[c]]]
            if not mu[c] > 0.0:
                frictional = False
        if mode[i] == SLIDE and slot[i] >= 0:
            closing = True
            for c in range(nc):
                if not vm[c * d] < -approach_rtol * vscale:
                    closing = False
            if closing:
                s = slot[i]
                absW = np.abs(W)
                if recertified_slide(W, absW, vm, mu, d, masks, slide_tol, cone_rtol,
                                     slack_max, wpi[s], wvalid[s]):
                    # the pruned search's answer, by its own certificates (.moreau_pn_recertify)
                    status[i] = SLID
                    full_slide[i] = True
                    apply_island_impulse(Ja, G, cons, cols, d, wpi[s, 0], r, v_new)
                    slid += 1
                    largest = max(largest, nc)
                    continue
                # on copies: the arrays change only where the search answers
                k_ = wkind[s].copy()
                t_ = wtang[s].copy()
                p_ = wpi[s].copy()
                v_ = wvalid[s].copy()
                got, tier, pi, sets, _, best, _, _ = search(
                    W, vm, vm, mu, np.zeros(nc), d, masks, rank, slide_tol, cond_max,
                    cone_rtol, slack_max, lo, hi, k_, t_, p_, v_, True)
                finite = True
                for a in range(N):
                    if not np.isfinite(pi[a]):
                        finite = False
                if got == DONE and finite:
                    wkind[s] = k_
                    wtang[s] = t_
                    wpi[s] = p_
                    wvalid[s] = v_
                    status[i] = SLID
                    full_slide[i] = tier == SLIDE_TIER and sets[best] == 0
                    if not full_slide[i]:
                        mode[i] = NONE
                    apply_island_impulse(Ja, G, cons, cols, d, pi, r, v_new)
                    slid += 1
                    largest = max(largest, nc)
                    continue
        if frictional:
            pi, certified = coordinate_certificate(Ja, G, cons, cols, d, W, vm, mu, cond_max,
                                                   cone_rtol, slack_max)
            if certified:
                if mode[i] == REST:
                    status[i] = STUCK
                    _end_mode(i, slot, mode, wvalid)
                    mode[i] = REST
                    apply_island_impulse(Ja, G, cons, cols, d, pi, r, v_new)
                    stuck += 1
                    largest = max(largest, nc)
                    continue
                status[i] = CERTIFIED_NEW
        full += 1
    return full, stuck, slid, largest


def flat_layout(parts: list) -> tuple[np.ndarray, np.ndarray]:
    """Integer arrays ``parts`` laid end to end and their offsets (the kernels' layout of
    islands: part i is ``flat[off[i]:off[i + 1]]``)."""
    off = np.concatenate([[0], np.cumsum([x.size for x in parts])]).astype(np.int64)
    return (np.concatenate(parts).astype(np.int64) if parts
            else np.zeros(0, np.int64)), off


class PnIslands:
    """The one-call path of :class:`.moreau_impact.ImpactSolver` for law
    ``pereira-nikravesh`` (module docstring): :meth:`solve` first on every step (the whole
    step when it answers every island), :meth:`pending` (what it answered, for the solver's
    own path on the others) and :meth:`keep` (its warm starts, back into the solver's after
    that path)."""

    def __init__(self, mech):
        self.n_contacts = len(mech.contact_names)
        self.mu = np.array([float(mech.contact_parameters(c)[1]) for c in mech.contact_names])
        self.tols = np.array([0.0, IMMOBILE_RTOL, TINY_NORMAL, APPROACH_RTOL,
                              pn.STICK_COND_MAX, pn.CONE_RTOL, pn.VELOCITY_SLACK_MAX, 0.0,
                              SAFE_SCALE[0], SAFE_SCALE[1]])
        self._flat = None      # the kernel's layout arrays
        self._groups = None    # the coordinate groups it was laid out for
        self._keys: list = []  # per island: its contacts' bytes
        self._objs: list = []  # per island: its SlideWarmStart (None: not slotted)
        self._synced = False   # the modes are this class's (no solver step since)
        self._pending = None
        self._keep: dict = {}
        self.answered = 0      # island steps answered here

    @classmethod
    def applies(cls, mech, direct: bool, options) -> "PnIslands | None":
        """The path for this run, or None: the solver's direct law path, no loops, and
        ``options`` its interior point accepts (else the solver's path reports them)."""
        if not direct or int(mech.n_loop_constraints):
            return None
        try:
            parse_options("clarabel", dict(options))
        except ConvImpactError:
            return None
        return cls(mech)

    def reset(self) -> None:
        """A step without contacts: every mode ends and every warm start is dropped."""
        self._flat = None
        self._groups = None
        self._synced = False

    def _relayout(self, solver, st) -> None:
        """The step's islands laid out flat for :func:`pn_islands`, with warm-start buffers
        for the islands of the most common eligible size, shared with the solver's
        :class:`SlideWarmStart` objects (their arrays copied in where they are of the key
        of every contact approaching)."""
        active, Ja = st.active, st.Ja
        d = Ja.shape[1]
        moves = (Ja != 0.0).any(axis=1)
        islands, _ = solver._islands(moves, st.inv.groups, None, active)
        sizes = [cs.size for cs, _ in islands]
        eligible = np.array([1 < s <= MAX_CONTACTS for s in sizes], dtype=np.bool_)
        common = Counter(s for s, e in zip(sizes, eligible) if e).most_common(1)
        n = common[0][0] if common else 2
        key3 = (n, d, (True,) * n)
        subsets, masks = _sets(n, key3[2])
        ns = len(subsets)
        members = [j for j, s in enumerate(sizes) if eligible[j] and s == n]
        slot = np.full(len(islands), -1, dtype=np.int64)
        slot[members] = np.arange(len(members))
        nsl = len(members)
        bufs = (np.zeros((nsl, ns, n), dtype=np.int64), np.zeros((nsl, ns, n, 2)),
                np.zeros((nsl, ns, n * d)), np.zeros((nsl, ns), dtype=np.bool_))
        self._keys = [active[cs].tobytes() for cs, _ in islands]
        self._objs = [None] * len(islands)
        for j in members:
            k = self._keys[j]
            w = solver._warm.get(k) or SlideWarmStart()
            views = tuple(b[slot[j]] for b in bufs)
            if w.key == key3 and w.arrays is not None:
                for dst, src in zip(views, w.arrays):
                    dst[...] = src
            w.key, w.arrays = key3, views
            self._objs[j] = w

        icon, icoff = flat_layout([cs for cs, _ in islands])
        icol, icoloff = flat_layout([cols for _, cols in islands])
        self._flat = (np.array(active, dtype=np.int64), moves, icon, icoff, icol, icoloff,
                      eligible, slot, np.zeros(len(islands), dtype=np.int64),
                      np.ascontiguousarray(masks), _ranks(n, key3[2]), *bufs,
                      np.zeros(len(islands), dtype=np.int64),
                      np.zeros(len(islands), dtype=np.bool_))
        self._groups = st.inv.groups
        self._synced = False
        flat = self._flat  # (the kernel's arguments after the step's own, built once)
        self._mid = (*flat[:7], flat[7], flat[8], self.mu, *flat[9:15], self.tols)
        self._tail = (flat[15], flat[16])

    def _read_modes(self, solver) -> None:
        """The modes after a step of the solver's own path, from its memory: resting where
        the island was certified, sliding where its warm start says it slid on every
        contact (adopting a warm start the solver made anew)."""
        mode = self._flat[8]
        for j, k in enumerate(self._keys):
            mode[j] = REST if k in solver._modes_last else NONE
            w = self._objs[j]
            if w is None:
                continue
            got = solver._warm.get(k)
            if got is None:  # not searched by the solver: a fresh start, as its own path
                w.full_slide = w.pruned = False
                w.arrays[3][...] = False
                continue
            if got is not w:  # the solver's own, new one: adopt it
                if got.key == w.key and got.arrays is not None:
                    for dst, src in zip(w.arrays, got.arrays):
                        dst[...] = src
                w.full_slide, w.pruned = got.full_slide, got.pruned
            if w.full_slide and mode[j] == NONE:
                mode[j] = SLIDE
        self._synced = True

    def solve(self, solver, st):
        """``(v_{k+1}, sigma)`` of a step answered here on every island (the solver's
        counters and impulses updated), else None (a step with an impact, or islands left
        to the solver's path; those answered wait in :meth:`pending`)."""
        self._pending = None
        self._keep = {}
        if not pn.compiled_path_active() or st.Ja.shape[0] == 0:
            self._synced = False
            return None
        Ja = st.Ja
        na, d = Ja.shape[0], Ja.shape[1]
        if self._flat is None or st.inv.groups is not self._groups:
            self._publish(solver)
            self._relayout(solver, st)
        if not self._synced:
            self._read_modes(solver)
        if self.tols[7] == 0.0:  # the first call: compiles (or loads) the kernel
            self.tols[7] = float(solver._direct_opts().accuracy(True))
            announce("Moreau–Jean islands of pereira-nikravesh in one call", COMPILE_SECONDS,
                     pn_islands)
        self.tols[0] = solver.rest_velocity
        r = np.zeros((na, d))
        v_new = st.v_free.copy()
        G = np.ascontiguousarray(st.inv.G)
        vn_k = getattr(st, "vn_k", None)  # the predictor's J_n v_k (a hand-made step: none)
        if vn_k is None:
            vn_k = np.ascontiguousarray(Ja[:, 0, :] @ st.v)
        support = getattr(st, "support", None)  # (a hand-made step: none, the dense one)
        if support is None:
            support = dense_support(self.n_contacts, Ja.shape[2])[1:]
        for _ in range(2):  # the second call after a new layout
            full, stuck, slid, largest = pn_islands(Ja, vn_k, st.v_free, G, st.active,
                                                    *self._mid, r, v_new, *self._tail,
                                                    *support)
            if full != -2:
                break
            self._publish(solver)
            self._relayout(solver, st)
            self._read_modes(solver)
        if full < 0:
            self._hand_over(solver, None)
            return None
        if stuck or slid:
            solver.largest_island = max(solver.largest_island, largest)
            solver.calls += stuck + slid
            solver.certified += stuck
            solver.pruned += slid
            self.answered += stuck + slid
        if full:
            status = self._flat[15]
            answered = set(np.flatnonzero((status == STUCK) | (status == SLID)
                                          | (status == SEPARATING)).tolist())
            certified = {self._keys[j] for j in
                         np.flatnonzero((status == STUCK) | (status == CERTIFIED_NEW)).tolist()}
            self._pending = (st.index, (answered, r, v_new, certified))
            self._hand_over(solver, status == SLID)
            return None
        # every island answered here (the kernel updated the modes)
        solver.impulse = r
        return v_new, st.sigma

    def _publish(self, solver) -> None:
        """Before a new layout: where the modes are this class's (steps answered here
        alone since the solver's path last ran), they go into the solver's memory (resting
        islands, sliding ones with their warm starts), which the new layout reads."""
        if not self._synced or self._flat is None:
            return
        mode = self._flat[8]
        solver._modes_last = {k for k, m in zip(self._keys, mode.tolist()) if m == REST}
        self._hand_over(solver, None)

    def _hand_over(self, solver, moved) -> None:
        """The warm starts into the solver's memory before its path runs (it reads them),
        the sliding islands answered here kept for after it (:meth:`keep`)."""
        mode = self._flat[8]
        for j, w in enumerate(self._objs):
            if w is not None:
                w.full_slide = bool(mode[j] == SLIDE)
                solver._warm[self._keys[j]] = w
        if moved is not None:
            self._keep = {self._keys[j]: self._objs[j] for j in np.flatnonzero(moved).tolist()}
        self._synced = False

    def pending(self, st):
        """What :meth:`solve` answered on this step when it left islands to the solver
        (``(their indices, impulses (na, d), v_{k+1}, the islands certified)``, the shape of
        :meth:`.moreau_impact.ImpactSolver._certify`'s answer), else None."""
        got, self._pending = self._pending, None
        return got[1] if got is not None and got[0] == st.index else None

    def keep(self) -> dict:
        """The warm starts of the sliding islands answered here on a step the solver's path
        took part in (for its memory of the next step)."""
        got, self._keep = self._keep, {}
        return got


__all__ = ["PnIslands", "pn_islands", "flat_layout", "NONE", "REST", "SLIDE"]
