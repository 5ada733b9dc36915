"""The contact problem of a Moreau–Jean step on the contact engine, island by island.

Used by :func:`convimpact.simulation.moreau.simulate_moreau` for the laws ``"ccp"`` and
``"coulomb"`` (under ``method`` "auto" or "interior"). Per step, at the intermediate
configuration ``q_m``:

1. one evaluation of M, every contact's gap and Jacobian (one compiled pass for the models of
   :mod:`convimpact.model`; name by name for any other mechanism);
2. the coordinate groups of M and the loops (:func:`.islands.coordinate_groups`, kept while
   M has no nonzero outside their blocks) and the inverse mass G block by block (compiled
   Cholesky of each block, :func:`.moreau_kernels.block_inverses`; a mass matrix that is
   not positive definite or not finite raises
   :class:`~convimpact.impact.errors.SimulationError`); with loops G is the
   loop-constrained inverse ``M^-1 - A (C A)^-1 A^T``, ``A = M^-1 C^T``, so
   ``C v_{k+1} = 0``;
3. the candidate contacts (:mod:`.moreau_loop`): those whose gap predicted at the end of the
   step with the free velocity closes, ``g + h theta J_n v_free <= gap_tol`` (up to the
   positions' round-off); no other contact enters;
4. their islands (:func:`.islands.contact_islands`; the layout kept while the active set
   stays, :func:`layout`) and per island the problem ``u = W r + b`` with ``W = J G J^T``
   (compiled for the small islands, :func:`.moreau_kernels.assemble_islands`; sparse for an
   island of :data:`SPARSE_MIN_ROWS` rows or more) and
   ``b = J v_free + e_eff min(J_n v_free, 0) e_n`` (Newton's restitution at the velocity
   level, ``e_eff`` as in :mod:`.moreau`); every active contact carries its friction;
5. islands of at most :data:`~convimpact.impact.contacts.engine.COMPILED_MAX_ROWS` rows are
   solved together in one compiled call (:func:`.moreau_kernels.solve_islands`); one it
   leaves uncertified is finished by the engine backend's regularized Newton from its
   answer (:func:`convimpact.impact.contacts.engine.warm_newton`), then by the full engine;
   larger islands go to :func:`convimpact.impact.contacts.engine.solve` (sparse LDL^T, its
   symbolic analysis reused within the solve, not across steps). With ``warm_start`` each
   island starts from the previous step's impulses of its contacts (Newton on the law's
   natural map; the cold path when that is not certified).

Every island's answer is certified: its relative natural-map residual (the engine's
measure) is at most ``tol``, else
:class:`~convimpact.impact.contacts.contact_problem.UncertifiedSolutionError` naming the step
and the contacts; no answer above ``tol`` is ever applied.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..impact.contacts import engine
from ..impact.contacts.contact_problem import ContactSolution, UncertifiedSolutionError
from ..impact.errors import LoopConstraintError, SimulationError
from .islands import Groups, contact_islands, coordinate_groups
from .moreau_kernels import assemble_islands, block_inverses, solve_islands

#: the laws whose step problem the engine solves
ENGINE_LAWS = ("ccp", "coulomb")
#: islands with at least this many contact rows get a sparse W
SPARSE_MIN_ROWS = engine.SPARSE_MIN_ROWS


@dataclass
class EngineCounters:
    """What the engine path did over a run (``MoreauResult.contact_solver``)."""

    problems: int = 0          # islands solved
    warm_started: int = 0      # islands whose warm start was certified
    engine_calls: int = 0      # islands solved by engine.solve (large or not certified)
    newton_finished: int = 0   # small islands certified by the backend's Newton from the
    #                            compiled answer (where the compiled call stopped short)
    iterations: int = 0
    largest_island: int = 0    # contacts
    solve_time: float = 0.0    # s in the contact solves (assembly excluded)
    assembly_time: float = 0.0

    def as_dict(self) -> dict:
        return dict(self.__dict__)


class Evaluator:
    """M, gaps and contact Jacobians at a configuration: the model's compiled pass when the
    mechanism is a :class:`convimpact.model.mechanism.ModelMechanism`, else the Mechanism
    protocol contact by contact."""

    def __init__(self, mech, contacts):
        self.mech = mech
        self.contacts = tuple(contacts)
        data = getattr(mech, "data", None)
        model = getattr(mech, "model", None)
        self.fast = (data is not None and model is not None and hasattr(data, "contact_ok")
                     and tuple(mech.contact_names) == self.contacts)
        if self.fast:
            from ..model import recursive as rc

            self._flags = rc.MASS | rc.CONTACT
            self.d = int(model.dim)
        else:
            self.d = None  # from the first Jacobian evaluated

    def positions(self, q: np.ndarray):
        """``(M, gaps (nc,), J (nc, d, k))`` at q (new arrays)."""
        mech = self.mech
        if self.fast:
            data = mech.data
            data.compute(self._flags, np.ascontiguousarray(q, dtype=float))
            if not np.all(data.contact_ok):
                bad = self.contacts[int(np.flatnonzero(~np.asarray(data.contact_ok,
                                                                   bool))[0])]
                mech.contact_gap(bad, q)  # raises the model's typed error
            return np.array(data.M, dtype=float), np.array(data.gap, dtype=float), np.array(
                data.contact_jacobian[:, :self.d], dtype=float)
        M = np.asarray(mech.mass_matrix(q), float)
        gaps = np.array([float(mech.contact_gap(c, q)) for c in self.contacts])
        J = np.array([np.asarray(mech.contact_jacobian(c, q), float) for c in self.contacts])
        if self.d is None:
            self.d = J.shape[1]
        return M, gaps, J

    def mass_and_gaps(self, q: np.ndarray):
        """``(M, gaps)`` at q (one pass for the model's mechanisms)."""
        if self.fast:
            data = self.mech.data
            data.compute(self._flags, np.ascontiguousarray(q, dtype=float))
            return np.array(data.M, dtype=float), np.array(data.gap, dtype=float)
        return np.asarray(self.mech.mass_matrix(q), float), self.gaps(q)

    def gaps(self, q: np.ndarray) -> np.ndarray:
        if self.fast:
            from ..model import recursive as rc

            data = self.mech.data
            data.compute(rc.CONTACT, np.ascontiguousarray(q, dtype=float))
            return np.array(data.gap, dtype=float)
        return np.array([float(self.mech.contact_gap(c, q)) for c in self.contacts])


@dataclass
class InverseMass:
    """G (k, k) of a step, block diagonal over ``groups``; with loops also what the loop
    impulse needs (``A = M^-1 C^T`` and ``S = C A``)."""

    G: np.ndarray
    groups: Groups
    Minv: np.ndarray | None = None
    A: np.ndarray | None = None
    S: np.ndarray | None = None


@dataclass
class GroupCache:
    """The coordinate groups kept across steps: the union of the coupling patterns met,
    the groups, per group size the flat indices of their blocks in M, all of them
    (``inside``), and the inverse mass array the blocks are written into."""

    pattern: np.ndarray | None = None
    groups: Groups | None = None
    flat: dict = field(default_factory=dict)
    inside: np.ndarray | None = None
    Minv: np.ndarray | None = None


def _regroup(M: np.ndarray, C: np.ndarray, cache: GroupCache) -> None:
    k = M.shape[0]
    if not np.all(np.isfinite(M)):
        raise SimulationError("the mass matrix is not finite")
    pattern = M != 0.0
    if C.shape[0]:
        rows = C != 0.0
        pattern = pattern | ((rows.T.astype(float) @ rows.astype(float)) > 0.0)
    # the union of the patterns met so far: an entry of M that vanishes at some angle
    # (a free body's coupling at zero rotation) keeps its group (coarser groups stay exact)
    cache.pattern = pattern if cache.pattern is None else (pattern | cache.pattern)
    cache.groups = coordinate_groups(cache.pattern)
    cache.flat = {s: (idx[:, :, None] * k + idx[:, None, :]).ravel()
                  for s, (_, idx) in cache.groups.by_size.items()}
    cache.inside = np.concatenate(list(cache.flat.values()))
    cache.Minv = np.zeros((k, k))


def inverse_mass(M: np.ndarray, C: np.ndarray, cache: GroupCache) -> InverseMass:
    """The step's G (see the module docstring); raises SimulationError for an M that is not
    positive definite or not finite and LoopConstraintError for a singular ``C M^-1 C^T``.

    The groups are recomputed only when M has a nonzero (or non-finite) entry outside the
    cached groups' blocks (one count of M's nonzeros per step) or the mechanism has loops.
    """
    flatM = M.reshape(-1)
    if (cache.groups is None or C.shape[0]
            or np.count_nonzero(flatM) != np.count_nonzero(flatM[cache.inside])):
        _regroup(M, C, cache)
    groups = cache.groups
    Minv = cache.Minv
    flatI = Minv.reshape(-1)
    for s in groups.by_size:
        if not block_inverses(flatM, cache.flat[s], s, flatI):
            raise SimulationError("the mass matrix is not positive definite (or not finite) "
                                  "on this step")
    if C.shape[0] == 0:
        return InverseMass(Minv, groups)
    A = Minv @ C.T
    S = C @ A
    try:
        Sinv = np.linalg.inv(np.linalg.cholesky(S))
    except np.linalg.LinAlgError:
        raise LoopConstraintError(
            "the loop matrix C M^-1 C^T is singular on this step (a dead-centre configuration "
            "or redundant loops); Moreau–Jean cannot keep C v = 0 here") from None
    Sinv = Sinv.T @ Sinv
    return InverseMass(Minv - A @ Sinv @ A.T, groups, Minv, A, Sinv)


@dataclass(frozen=True)
class StepProblem:
    """The active contacts of a step (indices into the mechanism's contacts), their
    Jacobian rows (na, d, k), b (na, d) and friction coefficients."""

    active: np.ndarray
    J: np.ndarray
    b: np.ndarray
    mu: np.ndarray


@dataclass
class Layout:
    """How a step's active contacts split into islands and batches (reused while the active
    set and the groups stay the same: a resting or sliding scene keeps it for many steps)."""

    key: tuple
    batches: list          # (C (B, nc), K (B, nk)) per shape of the small islands
    where: list            # the small islands' contacts, in solve order
    offsets: tuple         # (moff, boff, woff) of the compiled call
    large: list            # (contacts, coordinates) of the large islands


def layout(active: np.ndarray, J: np.ndarray, groups: Groups, split: bool,
           cache: dict | None) -> Layout:
    """The step's :class:`Layout`, from ``cache["layout"]`` when the active contacts, the
    coordinates their rows move and the groups are those of the cached one."""
    na, d, k = J.shape
    moves = np.any(J != 0.0, axis=1)
    key = (active.tobytes(), np.packbits(moves).tobytes(), id(groups), split)
    if cache is not None:
        hit = cache.get("layout")
        if hit is not None and hit.key == key:
            return hit
    islands = contact_islands(moves, groups, split)
    by_shape: dict = {}
    large = []
    for cs, cols in islands:
        if cs.size * d <= engine.COMPILED_MAX_ROWS:
            by_shape.setdefault((cs.size, cols.size), []).append((cs, cols))
        else:
            large.append((cs, cols))
    batches, where, sizes = [], [], []
    for (nc, _), items in by_shape.items():
        batches.append((np.array([c for c, _ in items]), np.array([c for _, c in items])))
        where.extend(c for c, _ in items)
        sizes.append(np.full(len(items), nc))
    if where:
        nc_of = np.concatenate(sizes)
        moff = np.concatenate([[0], np.cumsum(nc_of)])
        offsets = (moff, moff * d, np.concatenate([[0], np.cumsum((nc_of * d) ** 2)]))
    else:
        offsets = (None, None, None)
    out = Layout(key, batches, where, offsets, large)
    if cache is not None:
        cache["layout"] = out
    return out


def solve_step(problem: StepProblem, inv: InverseMass, *, coulomb: bool, tol: float,
               start: np.ndarray | None, split: bool, counters: EngineCounters,
               names: tuple = (), max_iter: int = 100, newton_iter: int = 20,
               where: str = "", cache: dict | None = None) -> np.ndarray:
    """The certified impulses (na, d) of the step's contact problem, island by island
    (``cache``: a dict kept across steps for the island layout)."""
    t0 = _time.perf_counter()
    J, b, mu = problem.J, problem.b, problem.mu
    na, d, k = J.shape
    lay = layout(problem.active, J, inv.groups, split, cache)
    out = np.zeros((na, d))
    # the small islands, batched by shape: W = J_I G_II J_I^T
    Ws, bs, mus, starts, warm = [], [], [], [], []
    for C, K in lay.batches:
        B, nc = C.shape
        WI = np.empty(B * (nc * d) ** 2)
        assemble_islands(J, inv.G, C, K, d, WI)
        Ws.append(WI)
        bs.append(b[C].ravel())
        mus.append(mu[C].ravel())
        if start is None:
            starts.append(np.zeros(B * nc * d))
            warm.append(np.zeros(B, dtype=bool))
        else:
            sc = start[C].reshape(B, -1)
            starts.append(sc.ravel())
            warm.append(np.any(sc != 0.0, axis=1))
    counters.assembly_time += _time.perf_counter() - t0
    if Ws:
        t1 = _time.perf_counter()
        moff, boff, woff = lay.offsets
        bcat = np.concatenate(bs)
        Wcat = np.concatenate(Ws)
        mucat = np.concatenate(mus)
        r, res, used, its = solve_islands(Wcat, woff, bcat, boff, mucat, moff, d, coulomb,
                                          tol, max_iter, newton_iter, np.concatenate(starts),
                                          np.concatenate(warm))
        counters.solve_time += _time.perf_counter() - t1
        counters.iterations += int(its.sum())
        counters.warm_started += int(used.sum())
        counters.problems += len(lay.where)
        counters.largest_island = max(counters.largest_island,
                                      int(np.max(np.diff(moff))))
        out[np.concatenate(lay.where)] = r.reshape(-1, d)
        for i in np.flatnonzero(res > tol):
            cs = lay.where[i]
            nd = cs.size * d
            Wi = Wcat[woff[i]:woff[i + 1]].reshape(nd, nd)
            bi, mi = bcat[boff[i]:boff[i + 1]], mucat[moff[i]:moff[i + 1]]
            # the regularized (Levenberg-Marquardt) Newton of the engine's backend from the
            # compiled answer first: it finishes where the compiled Newton stalls (Coulomb's
            # law on redundant contacts, a box's first step on four corners)
            t3 = _time.perf_counter()
            R = engine.warm_newton(Wi, bi, mi, d, r[boff[i]:boff[i + 1]], coulomb=coulomb,
                                   tol=tol, newton_iter=newton_iter, compiled=False)
            counters.solve_time += _time.perf_counter() - t3
            counters.iterations += int(R.iterations)
            if R.converged:
                out[cs] = R.impulse
                counters.newton_finished += 1
                continue
            out[cs] = _engine(Wi, bi, mi, d, coulomb, tol, None, counters, max_iter, where,
                              [names[c] for c in problem.active[cs]])
    for cs, cols in lay.large:
        t2 = _time.perf_counter()
        nd = cs.size * d
        JI = J[cs][:, :, cols].reshape(nd, cols.size)
        GI = inv.G[np.ix_(cols, cols)]
        if nd >= SPARSE_MIN_ROWS:
            Js = sp.csr_matrix(JI)
            W = (Js @ sp.csr_matrix(GI) @ Js.T).tocsr()
            W = 0.5 * (W + W.T)
        else:
            W = JI @ GI @ JI.T
            W = 0.5 * (W + W.T)
        counters.assembly_time += _time.perf_counter() - t2
        counters.problems += 1
        counters.largest_island = max(counters.largest_island, cs.size)
        s = None if start is None or not np.any(start[cs] != 0.0) else start[cs]
        out[cs] = _engine(W, b[cs].ravel(), mu[cs], d, coulomb, tol, s, counters, max_iter,
                          where, [names[c] for c in problem.active[cs]])
    return out


def _engine(W, b, mu, d, coulomb, tol, start, counters, max_iter, where, names):
    t = _time.perf_counter()
    R = engine.solve(W, b.reshape(-1, d), mu, d, coulomb=coulomb, tol=tol,
                     max_iter=max_iter, start=start)
    counters.solve_time += _time.perf_counter() - t
    counters.engine_calls += 1
    counters.iterations += int(R.iterations)
    if start is not None and R.message.endswith("(warm start)"):
        counters.warm_started += 1
    if not R.converged:
        law = "coulomb" if coulomb else "ccp"
        sol = ContactSolution(R.impulse, R.velocity, float(R.residual), "not certified",
                              int(R.iterations), law, tol)
        raise UncertifiedSolutionError(
            f"Moreau–Jean: the contact engine did not certify the step's {law} problem "
            f"({len(names)} contacts: {', '.join(map(str, names))}) at tol {tol:g}: best "
            f"natural-map residual {R.residual:.3g} ({R.message}) {where}",
            float(R.residual), sol)
    return R.impulse
