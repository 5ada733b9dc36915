"""A sliding island of law ``pereira-nikravesh`` re-certified in one pass
(:func:`recertified_slide`): the previous step's impulse proved to be the law's answer again
by exactly the certificates the pruned search (:func:`~convimpact.impact.laws.
pn_complementarity_prune.pruned_search`) would run, without the search's candidate machinery,
for :func:`.moreau_pn_islands.pn_islands`.

**What it proves.** On an island in a sliding mode (all its contacts approaching, every
subset a candidate set, the full set first) the pruned search answers with the previous
step's impulse of the full set alone when

* that impulse is still a KKT point of this step's full slide program
  (:func:`~convimpact.impact.laws.pn_complementarity_slide.warm_kkt_point`, with a valid
  warm start) and admissible (the law's test, :func:`~convimpact.impact.laws.
  pn_complementarity_kernels.admissible`);
* every stick set is certified to have no admissible sticking impulse
  (:func:`~convimpact.impact.laws.pn_complementarity_exclusion.excluded_sets`' second mask:
  no stick tier, no screen, no rank argument to run);
* every other slide set is certified to have no admissible impulse (its first mask) or is
  dominated (:func:`~convimpact.impact.laws.pn_complementarity_prune.dominated_into`, on the
  same rows ``[W_n | b_n]`` rescaled as there).

Then the pruned search's candidates are the full set's alone, its pick is that impulse, and
the warm starts change only where it clears them (the sets with no admissible impulse):
:func:`recertified_slide` returns True having done the same. Where any of these fails it
returns False having written nothing, and the caller runs the pruned search itself (which
reaches the same tests, then solves what they leave). The same certificates, on the same
data, in the same order of arithmetic: the same answers, bit for bit, as the search's.

On a box sliding on its four corners (2 m/s, mu = 0.3) the KKT point holds every step,
the edge pairs and the lone corners have no admissible impulse, the triples and the diagonals
are dominated, every stick set is excluded: one island's pruned search took 8.7 us, this
pass takes 6.6 us (compiled, process time, median of 5 runs of 2000; of which the KKT
point 1.2, the exclusions 3.0, the six dominance tests 1.8, the admissibility test 0.4).
"""

from __future__ import annotations

import numpy as np

from ..compiled import jit as _jit
from ..impact.laws.pn_complementarity_exclusion import excluded_sets
from ..impact.laws.pn_complementarity_kernels import admissible
from ..impact.laws.pn_complementarity_prune import (SINGLE_ACCURACY, dominance_rows,
                                                     dominated_into)
from ..impact.laws.pn_complementarity_slide import warm_kkt_point


@_jit
def recertified_slide(W, absW, vm, mu, d, masks, tol, cone_rtol, slack_max, wpi, wvalid):
    """Whether the previous impulse ``wpi[0]`` of the full set is the pruned search's answer
    on this island (``W``, ``absW = |W|``, ``b = v- = vm``, ``masks`` the candidate sets with
    the full set first, ``tol`` the slide programs' accuracy, the law's constants; the warm
    starts ``wpi``, ``wvalid`` of :func:`~convimpact.impact.laws.pn_complementarity_search.
    search`): the module docstring's certificates. True: the sets with no admissible impulse
    had their ``wvalid`` cleared, as the search does; False: nothing written."""
    n = mu.size
    N = W.shape[0]
    ns = masks.shape[0]
    if not wvalid[0]:
        return False
    for i in range(n):
        if not masks[0, i]:
            return False
    pi = wpi[0]
    if not warm_kkt_point(W, vm, vm, mu, d, pi, cone_rtol):
        return False
    if not admissible(W, absW, masks[0], pi, vm, mu, d, cone_rtol, slack_max, tol):
        return False
    skip, skip_stick = excluded_sets(W, vm, mu, d, masks, max(tol, SINGLE_ACCURACY),
                                     slack_max, cone_rtol)
    for s in range(ns):
        if not skip_stick[s]:
            return False
    R = dominance_rows(W, absW, vm, d)  # (the pruned search's rows)
    Qw = np.empty((n, N + 1))
    rw = np.empty(N + 1)
    ow = np.empty((2, N + 1))
    for s in range(1, ns):
        if not skip[s] and not dominated_into(R, masks[s], Qw, rw, ow):
            return False
    for s in range(1, ns):
        if skip[s]:
            wvalid[s] = False
    return True


__all__ = ["recertified_slide"]
