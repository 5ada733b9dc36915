"""Law ``pereira-nikravesh`` at several contacts for a time stepper: the impulse alone
(:func:`several_contacts_impulse`), by one compiled call of the law's search where the law's
compiled path is taken (:func:`compiled_impulse`, on
:func:`~.pn_complementarity_search.search`) and by the law's own search
(:mod:`.pn_complementarity`) where that call leaves the decision to it; and
:func:`compile_kernels`, which takes the compiled path now.

This module sits above the law's modules: it calls the law's search, tests and pick
(:mod:`.pn_complementarity`) and the compiled search; neither imports it.
"""

from __future__ import annotations

import functools
import time

import numpy as np

from ...errors import ConvImpactError
from ..conic.paths import ProgramOptions
from ..conic.qp import Backend
from ..problem.build import SAFE_SCALE, ImpactProblem, build_problem
from . import pn_complementarity as law
from .pn_complementarity_search import (DONE, NEEDS, SLIDE_TIER, SlideWarmStart, search,
                                        tuple_ranks)


#: the law's :func:`~.pn_complementarity.candidate_sets` (read only, kept per pattern of
#: approaching contacts: a time stepper asks for the same ones step after step)
_sets = law.candidate_sets


@functools.lru_cache(maxsize=512)
def _ranks(n: int, closing: tuple[bool, ...]) -> np.ndarray:
    return tuple_ranks(tuple(_sets(n, closing)[0]))


def compiled_impulse(P, backend, opts, notes: list[str] | None = None,
                     warm: SlideWarmStart | None = None, prune: bool = False
                     ) -> np.ndarray | None:
    """The law's impulse (n_contacts, d) on its compiled path by one call of
    :func:`~.pn_complementarity_search.search` (the same kernels, tests and warning), with its
    warning on several admissible active sets appended to ``notes``; None where the law's own
    search must decide (:data:`~.pn_complementarity_search.FALLBACK`). ``backend``, ``opts``:
    the law's interior-point backend and options; ``warm``: the slide programs' warm starts of
    these contacts (:class:`~.pn_complementarity_search.SlideWarmStart`, updated; the same
    minimizers, :func:`~.pn_complementarity_slide.slide_set_warm`); None: every program from
    the law's own guesses. ``prune``: the search without the sets that cannot beat the full
    set's slide (:mod:`.pn_complementarity_prune`; its warning is then not the whole
    search's: ``notes`` is left alone, ``warm.full_slide`` tells whether the answer slid on
    every contact); the programs it leaves to the interior-point method are solved here as
    the law solves them (``slide_on``, its admissibility test) and the law's own pick
    (``_pick``) is applied."""
    n, d = P.n_contacts, P.dim
    b = law.newton_velocity_shift(P)
    key = law.closing_key(P)
    subsets, masks = _sets(n, key)
    if not subsets:
        return None
    W, bf, vf, mu = law._kernel_data(P, b)
    warm = warm if warm is not None else SlideWarmStart()
    starts = warm.get((n, d, key), len(subsets), n, d)
    warm.full_slide = warm.pruned = False
    status, tier, pi, sets, same, best, cand_pi, needs = search(
        W, bf, vf, mu, np.ascontiguousarray(P.restitution, dtype=float), d, masks,
        _ranks(n, key), float(opts.accuracy(True)), law.STICK_COND_MAX, law.CONE_RTOL,
        law.VELOCITY_SLACK_MAX, SAFE_SCALE[0], SAFE_SCALE[1], *starts, bool(prune))
    if status == NEEDS:  # (pruned only) the programs the law solves by the interior point
        found = [(law._energy_change(P, x.reshape(n, d)), subsets[s], x.reshape(n, d), {})
                 for s, x in zip(sets.tolist(), cand_pi)]
        for s in needs.tolist():
            A = subsets[s]
            try:
                got = law.slide_on(P, A, b, backend, opts)
            except ConvImpactError:
                return None
            if got is not None and law._admissible(P, A, got[0], b, got[1]["accuracy"]):
                found.append((law._energy_change(P, got[0]), A, got[0], got[1]))
        (_, A, x, _), _ = law._pick(P, found)
        warm.full_slide = len(A) == n
        warm.pruned = True
        return x
    if status != DONE:
        return None
    warm.full_slide = bool(tier == SLIDE_TIER and sets[best] == 0 and len(subsets[0]) == n)
    warm.pruned = bool(prune)
    if notes is not None and not prune and not same.all():
        others = [int(s) for s, sv in zip(sets, same) if not sv]
        notes.append(law.several_sets_note([subsets[s] for s in [int(sets[best]), *others]]))
    return pi.reshape(n, d)


def compile_kernels() -> float:
    """Compile (or load from the cache) the law's compiled path now and take it from the
    next several-contact call on; the seconds it took."""
    from ..conic.paths import backend, parse_options

    t = time.perf_counter()
    saved, law._CALLS = law._CALLS, law.HOT_CALLS - 1  # this call compiles (announced)
    try:
        # a block on two corners sliding (the slide tier), then landing flat (the stick tier)
        M = np.diag([1.0, 1.0, 0.02])
        J = [np.array([[0.0, 1.0, x], [1.0, 0.0, 0.1]]) for x in (-0.2, 0.2)]
        # twice: the second round takes the one-call search (pn_complementarity_search)
        for dq in ([2.0, -1.0, 0.0], [0.0, -1.0, 0.0]) * 2:
            several_contacts_impulse(build_problem(M, J, np.array(dq), 0.0, 0.3),
                                     backend("clarabel"), parse_options("clarabel", {}))
    finally:
        law._CALLS = max(saved, law.HOT_CALLS) + 1
    return time.perf_counter() - t


def several_contacts_impulse(P: ImpactProblem, backend: Backend, opts: ProgramOptions,
                             notes: list[str] | None = None, warm=None, prune: bool = False
                             ) -> np.ndarray | None:
    """The impulse (n_contacts, d) of :func:`~.pn_complementarity.several_contacts_result`,
    without its result (regimes, diagnostics), for a time stepper that needs only the
    impulse; None where that call would raise or report active sets it could not solve (the
    caller then makes the full call, which raises or reports). ``notes``, optional: a list
    the result's warning on several admissible active sets with different velocities is
    appended to (the time stepper aggregates them, :mod:`convimpact.simulation.moreau_impact`).
    On the compiled path first :func:`compiled_impulse` (``warm`` and ``prune`` as there; with
    ``prune`` the pruned search first), the law's own search where it leaves the decision."""
    if P.n_contacts <= law.MAX_CONTACTS and law.compiled_path_active():
        for pruned in ((True, False) if prune else (False,)):
            pi = compiled_impulse(P, backend, opts, notes, warm, pruned)
            if pi is not None:
                return pi
    try:
        tier, found, failures, _ = law._search(P, backend, opts)
    except ConvImpactError:
        return None
    if failures:
        return None
    best, picked_notes = law._pick(P, found)
    if warm is not None:  # the law's own search: its answer slid on every contact?
        warm.full_slide = tier == "slide" and len(best[1]) == P.n_contacts
    if notes is not None:
        notes.extend(picked_notes)
    return best[2]
