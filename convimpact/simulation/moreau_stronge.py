"""Law ``"stronge"`` on Moreau–Jean's islands without :func:`convimpact.resolve_impact`: the
law's warm-started plastic compression on every island of a step in one compiled call
(:func:`stronge_islands`), for :class:`.moreau_impact.ImpactSolver` (:class:`StrongeIslands`).

**When.** On a step where no active contact approaches at the step's start
(``v_n,k >= -rest_velocity`` everywhere: no impact to record, every per-contact restitution
``e_eff`` is 0), for laws ``stronge`` under methods ``auto``, ``clarabel`` and ``cvxpy``, on
a mechanism without loop constraints. Steps with an impact, and every island this module
does not answer, take :func:`convimpact.resolve_impact` as before.

**What the law does there.** With every ``e_eff = 0``, law ``stronge`` on an island of
several coupled contacts (:mod:`convimpact.impact.laws.stronge_contacts`) is its phase 1,
the plastic compression ``pi_c`` by Coulomb's conditions: phase 2 releases ``e pi_c,n = 0``
(no Gauss--Seidel sweep, ``kappa = 1``) and phase 3 acts only where ``pi_c`` leaves a
contact approaching. Its phase 1 is first tried by the compiled active-set Newton from a
previous compression (:func:`~convimpact.impact.laws.stronge_contacts_warm.
warm_compression`), kept when it certifies (Coulomb residual :data:`~convimpact.impact.
laws.stronge_contacts.WARM_RESIDUAL`; a locally unique solution, or redundant impulses that
move no velocity: with every e = 0 both are the fixed point's velocities).

**The direct call** does exactly that per island, from the island's own last impulses (each
contact's impulse on the last step it was active, whoever computed it), with the checks the
law's full call makes on the way:

* the island's ``W = J G J^T`` (G the step's block inverse of M) and ``v- = J v_free``,
  symmetrized and checked as :func:`~convimpact.impact.problem.build.build_problem` does
  (:func:`~convimpact.contacts.interior_point.contact_checks`: finite, every normal and
  tangent moving mass); not plain -> the full call;
* no contact with ``v_n- < 0``: no impulse (``resolve_impact``'s separating answer);
* ``W`` not coupling the contacts (:func:`~convimpact.impact.exact.dispatch.coupled`, its
  threshold :data:`~convimpact.impact.exact.dispatch.DECOUPLED_RTOL`), or exactly one contact
  approaching by more than round-off (:data:`~convimpact.impact.conic.paths.APPROACH_RTOL`:
  the law may then take the exact single-contact integration) -> the full call;
* the warm Newton not certified, a start of zeros, or the compression leaving a contact
  approaching by more than :data:`~convimpact.impact.laws.stronge_contacts.KKT_RTOL`
  ``max |v-|`` (phase 3 would act), or a non-finite answer -> the full call;
* an island of one contact that may take an impulse -> the full call (the law's exact
  single-contact integration).

The warm start is the law's own, in its ``fast`` mode (:func:`~convimpact.impact.laws.
stronge_contacts_warm.warm_compression`: a complete orthogonal decomposition instead of the
SVD, the family test on the Newton's own Jacobian without the boundary contacts' kappa, none
where no contact is on its cone's boundary): the same accept decisions wherever the ranks are
clear (checked against the SVD mode in the tests), at a fraction of numba's SVD's cost.

The islands are :meth:`.moreau_impact.ImpactSolver._islands`'; the compiled call checks that
the step's active contacts and the coordinates each moves are the ones they were laid out
for (else they are laid out again), and a new island none of whose contacts has an impulse
of its own yet starts from the law's memory of the same kind of problem (the start its full
call would try first).

Answered islands take ``pi = pi_c`` (normals clipped at 0, as the law does) and
``v_{k+1} = v_free + G J^T pi`` on their coordinates: the law's answer, with the velocities
of its fixed point to round-off; where redundant contacts (a box on four corners) leave the
split of ``pi`` free, the split is the Newton's from the island's own start instead of from
the law's memory of the last problem of the same kind (another island's, on a row of boxes),
a difference of the size the law's docstring states, which moves no velocity.
Not made: the law's result record (regimes, diagnostics, per-phase extras), which nobody
reads on such a step.
"""

from __future__ import annotations

import numpy as np

from ..compiled import jit as _jit
from ..contacts.interior_point import contact_checks
from ..errors import ConvImpactError
from ..impact.conic.paths import APPROACH_RTOL, parse_options
from ..impact.exact.dispatch import DECOUPLED_RTOL
from ..impact.laws.stronge_contacts import _WARM, KKT_RTOL, WARM_RESIDUAL
from ..impact.laws.stronge_contacts_warm import REDUNDANT, STILL, UNIQUE, warm_compression
from ..impact.problem.build import IMMOBILE_RTOL, TINY_NORMAL
from .moreau_kernels import (apply_island_impulse, island_delassus, island_velocity,
                             same_pattern_on)
from .moreau_step_kernels import dense_support

LAW = "stronge"
#: the methods whose several-contact path is the law's conic one (the warm start included)
METHODS = ("auto", "clarabel", "cvxpy")
#: island statuses of :func:`stronge_islands`
FULL, ANSWERED, SEPARATING = 0, 1, 2
#: the checks' thresholds, as the law's full call takes them (see the module docstring)
TOLERANCES = (IMMOBILE_RTOL, TINY_NORMAL, DECOUPLED_RTOL, APPROACH_RTOL, WARM_RESIDUAL,
              KKT_RTOL)


@_jit
def stronge_islands(Ja, vn_k, v_free, G, active, ref_active, ref_moves, icon, icoff, icol,
                    icoloff, mu_all, last, tols, r, v_new, status, jcol, joff):
    """For every island i (contacts ``icon[icoff[i]:icoff[i + 1]]``, rows of ``Ja`` (na, d,
    k), among the ``active`` contacts; coordinates ``icol[icoloff[i]:icoloff[i + 1]]``): the
    law's answer with every e = 0 where the module docstring's checks hold, from the start
    impulses ``last[active]`` (``last`` (n_contacts, d), ``mu_all`` (n_contacts,)); ``tols``:
    rest_velocity and the thresholds of :data:`TOLERANCES`, in that order.

    Returns ``(-1, 0, 0)``, doing nothing, on a step with an impact (some
    ``vn_k < -rest_velocity``, ``vn_k`` (na,) the normal velocities at the step's start), and
    ``(-2, 0, 0)`` when the islands were laid out for other contacts: ``active`` is not
    ``ref_active`` or the coordinates each contact moves (``Ja``'s nonzero columns) are not
    ``ref_moves`` (na, k). Else writes ``status[i]``:
    ANSWERED (the impulse into ``r`` (na, d), ``v_free + G J^T pi`` into ``v_new`` on the
    island's coordinates), SEPARATING (no contact with v_n- < 0: no impulse, ``v_new`` left)
    or FULL (the law's full call decides; an island of one contact that may take an
    impulse), and returns (islands FULL, islands ANSWERED, the most contacts of one of
    those). ``v_new`` holds ``v_free`` on entry."""
    rest_velocity, immobile_rtol, tiny_normal = tols[0], tols[1], tols[2]
    decoupled_rtol, approach_rtol, warm_residual, kkt_rtol = tols[3], tols[4], tols[5], tols[6]
    d = Ja.shape[1]
    full, done, largest = 0, 0, 0
    for c in range(vn_k.shape[0]):
        if vn_k[c] < -rest_velocity:
            return -1, 0, 0
    if not same_pattern_on(Ja, active, ref_active, ref_moves, jcol, joff):
        return -2, 0, 0
    n_isl = icoff.shape[0] - 1
    for i in range(n_isl):
        c0, c1 = icoff[i], icoff[i + 1]
        k0, k1 = icoloff[i], icoloff[i + 1]
        nc = c1 - c0
        N = nc * d
        cons = icon[c0:c1]
        cols = icol[k0:k1]
        status[i] = FULL
        vm = np.zeros(N)
        island_velocity(Ja, v_free, cons, cols, d, vm)
        vscale = 0.0
        touching = False
        for c in range(nc):
            for a in range(d):
                vscale = max(vscale, abs(vm[c * d + a]))
            if vm[c * d] < 0.0:
                touching = True
        if not touching:
            status[i] = SEPARATING
            continue
        if nc == 1:
            continue
        W = np.empty((N, N))
        island_delassus(Ja, G, cons, cols, d, W)
        if contact_checks(W, vm, d, immobile_rtol, tiny_normal) != 0:
            continue
        # coupled (dispatch.coupled): some off-diagonal block above its scale
        coupled = False
        for p in range(nc):
            sp = 0.0
            for a in range(d):
                sp = max(sp, np.sqrt(max(W[p * d + a, p * d + a], 0.0)))
            for q in range(p + 1, nc):
                sq = 0.0
                for a in range(d):
                    sq = max(sq, np.sqrt(max(W[q * d + a, q * d + a], 0.0)))
                bound = decoupled_rtol * max(sp, 1e-300) * max(sq, 1e-300)
                for a in range(d):
                    for b in range(d):
                        if abs(W[p * d + a, q * d + b]) > bound:
                            coupled = True
        if not coupled:
            continue
        approaching = 0
        for c in range(nc):
            if vm[c * d] < -approach_rtol * vscale:
                approaching += 1
        if approaching == 1:
            continue
        mu = np.empty(nc)
        prev = np.empty(N)
        any_start = False
        for c in range(nc):
            g = active[cons[c]]
            mu[c] = mu_all[g]
            for a in range(d):
                prev[c * d + a] = last[g, a]
                if last[g, a] != 0.0:
                    any_start = True
        if not any_start:
            continue
        kind, pi, resid = warm_compression(W, vm, mu, d, prev, bool(True))
        if not (resid <= warm_residual and (kind == UNIQUE or kind == REDUNDANT
                                            or kind == STILL)):
            continue
        finite = True
        for c in range(nc):
            pi[c * d] = max(pi[c * d], 0.0)
        for a in range(N):
            if not np.isfinite(pi[a]):
                finite = False
        if not finite:
            continue
        # phase 3 would act where the compression leaves a contact approaching
        floor = -kkt_rtol * max(vscale, 1e-300)
        pressed = True
        for c in range(nc):
            un = vm[c * d]
            for b in range(N):
                un += W[c * d, b] * pi[b]
            if un < floor:
                pressed = False
        if not pressed:
            continue
        status[i] = ANSWERED
        done += 1
        largest = max(largest, nc)
        apply_island_impulse(Ja, G, cons, cols, d, pi, r, v_new)
    for i in range(n_isl):
        if status[i] == FULL:
            full += 1
    return full, done, largest


class StrongeIslands:
    """The direct path of :class:`.moreau_impact.ImpactSolver` for law ``stronge`` (see the
    module docstring): :meth:`solve` before the solver's own work (the whole step when it
    answers every island), :meth:`pending` (the islands it answered, for the solver's calls
    of ``resolve_impact`` on the others), :meth:`remember` after. Holds each contact's
    impulse on the last step it was active."""

    def __init__(self, mech):
        self.n_contacts = len(mech.contact_names)
        self.mu = np.array([float(mech.contact_parameters(c)[1]) for c in mech.contact_names])
        self.last: np.ndarray | None = None  # (n_contacts, d), allocated on first use
        self.answered = 0  # island steps answered here (SEPARATING ones not counted)
        #: the islands' flat layout (see _relayout) and the coordinate groups it holds for
        self._flat: tuple | None = None
        self._groups = None
        self._pending = None  # (step index, answer) of a step answered in part
        self._every = False  # the layout's active contacts are all of them, in order
        self.tols = np.array([0.0, *TOLERANCES])

    @classmethod
    def applies(cls, mech, law: str, method: str, options) -> "StrongeIslands | None":
        """The direct path for this run, or None: law ``stronge`` under a method of
        :data:`METHODS`, no loop constraints, and ``options`` the conic path accepts (else
        ``resolve_impact`` reports them, as without this path)."""
        if law != LAW or method not in METHODS or int(mech.n_loop_constraints):
            return None
        try:
            parse_options("cvxpy" if method == "cvxpy" else "clarabel", dict(options))
        except ConvImpactError:
            return None
        return cls(mech)

    def _relayout(self, solver, st) -> None:
        """The step's islands (:meth:`.moreau_impact.ImpactSolver._islands`) laid out flat
        for :func:`stronge_islands`, with the contacts and the coordinates they move that
        the layout holds for. On a new layout, an island of several contacts none of which
        has an impulse of its own yet takes the law's memory as its start
        (:data:`~convimpact.impact.laws.stronge_contacts._WARM`: the last compression of a
        problem of the same kind, the start its full call would try first)."""
        active, Ja = st.active, st.Ja
        d = Ja.shape[1]
        moves = (Ja != 0.0).any(axis=1)
        islands, _ = solver._islands(moves, st.inv.groups, None, active)
        for cs, _ in islands:
            g = active[cs]
            if cs.size > 1 and not self.last[g].any():
                starts = _WARM.get((cs.size, d, self.mu[g].tobytes()))
                if starts:
                    self.last[g] = starts[0].reshape(cs.size, d)

        def cat(parts):
            off = np.concatenate([[0], np.cumsum([x.size for x in parts])]).astype(np.int64)
            return (np.concatenate(parts).astype(np.int64) if parts
                    else np.zeros(0, np.int64)), off

        icon, icoff = cat([cs for cs, _ in islands])
        icol, icoloff = cat([cols for _, cols in islands])
        self._flat = (np.array(active, dtype=np.int64), moves, icon, icoff, icol, icoloff,
                      np.zeros(len(islands), dtype=np.int64))
        # (every contact active, in order: the impulses are ``last`` whole)
        self._every = bool(np.array_equal(self._flat[0], np.arange(self.n_contacts)))
        # the island of each coordinate (-1: none), for _same_islands
        self._island_of = np.full(Ja.shape[2], -1, dtype=np.int64)
        for i in range(len(islands)):
            self._island_of[icol[icoloff[i]:icoloff[i + 1]]] = i

    def _same_islands(self, groups) -> bool:
        """Whether new coordinate groups leave the layout's islands as they are: each group
        lies within one island's coordinates or outside every island (a group joining two
        islands, or an island and a free coordinate, changes them). Then the layout holds
        (the islands are the components of the contacts and the groups they move; the
        compiled call checks the contacts and the coordinates they move each step)."""
        if groups.label.shape != self._island_of.shape:
            return False
        order = np.argsort(groups.label, kind="stable")
        where = self._island_of[order]
        starts = np.flatnonzero(np.r_[True, np.diff(groups.label[order]) != 0])
        return bool(np.array_equal(np.minimum.reduceat(where, starts),
                                   np.maximum.reduceat(where, starts)))

    def solve(self, solver, st):
        """``(v_{k+1}, sigma)`` of a step without an impact whose islands are all answered
        here (the solver's counters, impulses and this path's memory updated), else None:
        on a step with an impact, or with islands left to ``resolve_impact`` (the answered
        ones then wait in :meth:`pending`)."""
        self._pending = None
        active, Ja = st.active, st.Ja
        na, d = Ja.shape[0], Ja.shape[1]
        if self.last is None or self.last.shape[1] != d:
            self.last = np.zeros((self.n_contacts, d))
        r = np.zeros((na, d))
        v_new = st.v_free.copy()
        self.tols[0] = solver.rest_velocity
        G = np.ascontiguousarray(st.inv.G)
        vn_k = getattr(st, "vn_k", None)  # the predictor's J_n v_k (a hand-made step: none)
        if vn_k is None:
            vn_k = np.ascontiguousarray(Ja[:, 0, :] @ st.v)
        support = getattr(st, "support", None)  # (a hand-made step: none, the dense one)
        if support is None:
            support = dense_support(self.mu.size, Ja.shape[2])[1:]
        for _ in range(2):  # the second call after a new layout of the islands
            if st.inv.groups is not self._groups:
                if self._flat is not None and self._same_islands(st.inv.groups):
                    self._groups = st.inv.groups
                else:
                    self._relayout(solver, st)
            ref_active, ref_moves, icon, icoff, icol, icoloff, status = self._flat
            full, done, largest = stronge_islands(
                Ja, vn_k, st.v_free, G, active, ref_active, ref_moves, icon, icoff, icol,
                icoloff, self.mu, self.last, self.tols, r, v_new, status, *support)
            if full != -2:
                break
            self._relayout(solver, st)
        if full < 0:
            return None
        if done:
            self.answered += done
            solver.calls += done
            solver.certified += done
            if largest > solver.largest_island:
                solver.largest_island = largest
        if full:
            answered = set(np.flatnonzero(status != FULL).tolist())
            self._pending = (st.index, (answered, r, v_new, set()))
            return None
        solver.impulse = r
        if self._every:  # the layout's active contacts (the kernel checked: these) are all
            self.last[...] = r
        else:
            self.last[active] = r
        return v_new, st.sigma

    def pending(self, st):
        """The islands :meth:`solve` answered on this step when it left others
        (``(their indices, impulses (na, d), v_{k+1}, set())``, the shape of
        :meth:`.moreau_impact.ImpactSolver._certify`'s answer), else None."""
        got, self._pending = self._pending, None
        return got[1] if got is not None and got[0] == st.index else None

    def remember(self, active: np.ndarray, impulse: np.ndarray) -> None:
        """Keep the step's impulses of the active contacts as their next starts."""
        if impulse.size and self.last is not None and self.last.shape[1] == impulse.shape[1]:
            self.last[active] = impulse


__all__ = ["StrongeIslands", "stronge_islands", "METHODS", "FULL", "ANSWERED", "SEPARATING"]
