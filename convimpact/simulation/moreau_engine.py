"""The contact problem of a Moreau–Jean step on the contact engine, island by island.

The step solver (:class:`EngineSolver`) of :func:`convimpact.simulation.moreau.simulate_moreau`
for the laws ``"ccp"``, ``"coulomb"`` and ``"dissipative"`` (under ``method`` "auto" or
"interior"), and what
the step loop's predictors share (:mod:`.moreau_loop`): :class:`Evaluator` (M, gaps and
contact Jacobians at a configuration) and the inverse mass of a step.

* **Inverse mass**: the coordinate groups of M and the loops
  (:func:`.islands.coordinate_groups`, kept while M, or with loops the coupling of M and C,
  has no nonzero outside their blocks) and G block by block (compiled Cholesky of each
  block, :func:`.moreau_step_kernels.block_inverses`; a mass matrix that is not positive
  definite or not finite raises :class:`~convimpact.errors.SimulationError`); with
  loops G is the loop-constrained inverse ``M^-1 - A (C A)^-1 A^T``, ``A = M^-1 C^T``, so
  ``C v_{k+1} = 0`` (:func:`inverse_mass`).
* **Islands**: the active contacts' islands (:func:`.islands.contact_islands`; the layout
  kept while the active set and the columns their rows move stay, :func:`layout`) and per
  island the problem ``u = W r + b`` with ``W = J G J^T`` and
  ``b = J v_free + e_eff min(J_n v_free, 0) e_n`` (Newton's restitution at the velocity
  level, ``e_eff`` as in :mod:`.moreau`); every active contact carries its friction.
  ``"dissipative"`` (CCP's plastic impulse scaled by Poisson's hypothesis,
  :mod:`convimpact.impact.laws.dissipative`) solves the ccp problem with ``e = 0``
  (``b = J v_free``) and multiplies each contact's impulse by ``1 + e_eff``: the law's
  definition, exact; the certificate is the plastic problem's.
* **Solves** (:func:`solve_step`): islands of at most
  :data:`~convimpact.contacts.engine.COMPILED_MAX_ROWS` rows are assembled and solved
  together in one compiled call (:func:`.moreau_kernels.solve_small_islands`); one it leaves
  uncertified is finished by the engine backend's regularized Newton from its answer
  (:func:`convimpact.contacts.engine.warm_newton`), then by the full engine; larger
  islands go to :func:`convimpact.contacts.engine.solve` (W sparse from
  :data:`SPARSE_MIN_ROWS` rows). With ``warm_start`` each island starts from the previous
  step's impulses of its contacts (Newton on the law's natural map; the cold path when that
  is not certified).

Every island's answer is certified: its relative natural-map residual (the engine's
measure) is at most ``tol``, else
:class:`~convimpact.contacts.contact_problem.UncertifiedSolutionError` naming the step
and the contacts; no answer above ``tol`` is ever applied.

Differences from the step solver through :func:`convimpact.resolve_impact`
(:mod:`.moreau_impact`, other laws and methods): every active contact carries its friction
(the per-impact law ``ccp`` of ``resolve_impact`` keeps only the normal of a contact that
does not approach); the impact events carry no
:class:`~convimpact.impact.results.ImpactResult` (``result=None``): the step's certificate is
the engine's natural-map residual; ``regime`` is read off the answer (``"separating"`` for a
zero normal impulse, ``"stick"`` where the contact's slip after the step is at most 1e-9 of
the step's velocity scale, else ``"slide"``; ``"frictionless"`` for mu = 0).
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..contacts import ccp_interior, engine
from ..contacts.contact_problem import ContactSolution, UncertifiedSolutionError
from ..errors import ConvImpactError, LoopConstraintError, SimulationError
from .islands import Groups, contact_islands, coordinate_groups
from .moreau_kernels import apply_impulses, assemble_islands, same_pattern, solve_small_islands
from .moreau_step_kernels import block_inverses
from .result import ImpactEvent

#: the laws whose step problem the engine solves
ENGINE_LAWS = ("ccp", "coulomb", "dissipative")
#: islands with at least this many contact rows get a sparse W
SPARSE_MIN_ROWS = ccp_interior.SPARSE_MIN_ROWS


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
    solve_time: float = 0.0    # s in the contact solves (the small islands' assembly
    #                            included: one compiled call assembles and solves them)
    assembly_time: float = 0.0  # s assembling the large islands' W

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
    # the same, flat, for the compiled predictor: the blocks' flat indices (gflat), per
    # size s = gsize[i] those at gflat[goff[i]:goff[i + 1]], and the mask of their entries
    gflat: np.ndarray | None = None
    gsize: np.ndarray | None = None
    goff: np.ndarray | None = None
    mask: np.ndarray | None = None


def regroup(M: np.ndarray, C: np.ndarray, cache: GroupCache) -> None:
    """Recompute the cached groups from M's (and the loops') coupling pattern, joined with
    the patterns met before; SimulationError for a non-finite M."""
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
    cache.gflat = cache.inside.astype(np.int64)
    cache.gsize = np.array(list(cache.flat), dtype=np.int64)
    cache.goff = np.concatenate([[0], np.cumsum([f.size for f in cache.flat.values()])]
                                ).astype(np.int64)
    cache.mask = np.zeros(k * k, dtype=np.bool_)
    cache.mask[cache.inside] = True


def inverse_mass(M: np.ndarray, C: np.ndarray, cache: GroupCache) -> InverseMass:
    """The step's G (see the module docstring); raises SimulationError for an M that is not
    positive definite or not finite and LoopConstraintError for a singular ``C M^-1 C^T``.

    The groups are recomputed only when M (or, with loops, the coupling of M and C) has a
    nonzero (or non-finite) entry outside the cached groups' blocks (one count of M's
    nonzeros per step; with loops, one comparison of the coupling patterns).
    """
    flatM = M.reshape(-1)
    if C.shape[0]:
        rows = C != 0.0
        pattern = (M != 0.0) | ((rows.T.astype(float) @ rows.astype(float)) > 0.0)
        if cache.pattern is None or np.any(pattern & ~cache.pattern):
            regroup(M, C, cache)
    elif (cache.groups is None
          or np.count_nonzero(flatM) != np.count_nonzero(flatM[cache.inside])):
        regroup(M, C, cache)
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


@dataclass
class Layout:
    """How a step's active contacts split into islands (reused while the active set, the
    columns their rows move and the groups stay: a resting or sliding scene keeps it for
    many steps). The small islands (at most
    :data:`~convimpact.contacts.engine.COMPILED_MAX_ROWS` rows) flat, for
    :func:`.moreau_step_kernels.solve_small_islands`: island i has the active contacts
    ``icon[icoff[i]:icoff[i + 1]]`` and the coordinates ``icol[icoloff[i]:icoloff[i + 1]]``;
    the large ones as (contacts, coordinates)."""

    active: np.ndarray
    moves: np.ndarray
    groups: Groups
    split: bool
    icon: np.ndarray
    icoff: np.ndarray
    icol: np.ndarray
    icoloff: np.ndarray
    large: list
    largest: int           # contacts of the largest island
    res: np.ndarray        # per small island: residual, warm start kept (outputs)
    used: np.ndarray


def layout(active: np.ndarray, J: np.ndarray, groups: Groups, split: bool,
           cached: Layout | None) -> Layout:
    """The step's :class:`Layout`: ``cached`` when it is that of the same active contacts,
    moved columns and groups."""
    if (cached is not None and cached.groups is groups and cached.split == split
            and same_pattern(J, active, cached.active, cached.moves)):
        return cached
    na, d, k = J.shape
    moves = np.any(J != 0.0, axis=1)
    small, large = [], []
    for cs, cols in contact_islands(moves, groups, split):
        (small if cs.size * d <= engine.COMPILED_MAX_ROWS else large).append((cs, cols))

    def flat(parts):
        off = np.concatenate([[0], np.cumsum([x.size for x in parts])]).astype(np.int64)
        return (np.concatenate(parts).astype(np.int64) if parts else np.zeros(0, np.int64)), off

    icon, icoff = flat([cs for cs, _ in small])
    icol, icoloff = flat([cols for _, cols in small])
    largest = max([cs.size for cs, _ in small + large], default=0)
    return Layout(active.copy(), moves, groups, split, icon, icoff, icol, icoloff, large,
                  largest, np.zeros(len(small)), np.zeros(len(small), dtype=np.bool_))


def solve_step(active: np.ndarray, J: np.ndarray, b: np.ndarray, mu_all: np.ndarray,
               inv: InverseMass, *, coulomb: bool, tol: float, last: np.ndarray | None,
               split: bool, counters: EngineCounters, names: tuple = (),
               max_iter: int = 100, newton_iter: int = 20, where: str | tuple = "",
               cached: Layout | None = None, out: np.ndarray | None = None
               ) -> tuple[np.ndarray, Layout]:
    """The certified impulses (na, d) of the step's contact problem, island by island, and
    the layout used (pass it back as ``cached``).

    ``active`` (na,) indexes the mechanism's contacts (``mu_all``, ``last``, ``names``);
    ``J`` (na, d, k) and ``b`` (na, d) are the active contacts' rows. ``last`` (n_contacts,
    d), optional: the previous step's impulses, each island's warm start where nonzero.
    ``where`` (for the error message): a string, or ``(t_m, step)``.
    """
    t0 = _time.perf_counter()
    assembly = counters.assembly_time
    na, d, k = J.shape
    lay = layout(active, J, inv.groups, split, cached)
    r = np.zeros((na, d)) if out is None else out
    G = inv.G
    warm = last is not None
    prev = last if warm else _NO_LAST
    if lay.icoff.size > 1:
        its, kept, bad = solve_small_islands(
            J, b, mu_all, active, G, lay.icon, lay.icoff, lay.icol, lay.icoloff, d, coulomb,
            tol, max_iter, newton_iter, prev, warm, r, lay.res, lay.used)
        n_small = lay.icoff.size - 1
        counters.iterations += its
        counters.warm_started += kept
        counters.problems += n_small
        if bad:
            for i in np.flatnonzero(~(lay.res <= tol)):  # NaN included
                cs = lay.icon[lay.icoff[i]:lay.icoff[i + 1]]
                cols = lay.icol[lay.icoloff[i]:lay.icoloff[i + 1]]
                nd = cs.size * d
                Wi = np.empty(nd * nd)
                assemble_islands(J, G, cs[None, :], cols[None, :], d, Wi)
                Wi = Wi.reshape(nd, nd)
                bi, mi = b[cs].ravel(), mu_all[active[cs]]
                # the regularized (Levenberg-Marquardt) Newton of the engine's backend from
                # the compiled answer first: it finishes where the compiled Newton stalls
                # (Coulomb's law on redundant contacts, a box's first step on four corners)
                R = engine.warm_newton(Wi, bi, mi, d, r[cs], coulomb=coulomb, tol=tol,
                                       newton_iter=newton_iter, compiled=False)
                counters.iterations += int(R.iterations)
                if R.converged:
                    r[cs] = R.impulse
                    counters.newton_finished += 1
                    continue
                r[cs] = _engine(Wi, bi, mi, d, coulomb, tol, None, counters, max_iter, where,
                                [names[c] for c in active[cs]])
    counters.largest_island = max(counters.largest_island, lay.largest)
    for cs, cols in lay.large:
        t2 = _time.perf_counter()
        nd = cs.size * d
        JI = J[cs][:, :, cols].reshape(nd, cols.size)
        GI = G[np.ix_(cols, cols)]
        if nd >= SPARSE_MIN_ROWS:
            Js = sp.csr_matrix(JI)
            W = (Js @ sp.csr_matrix(GI) @ Js.T).tocsr()
            W = 0.5 * (W + W.T)
        else:
            W = JI @ GI @ JI.T
            W = 0.5 * (W + W.T)
        counters.assembly_time += _time.perf_counter() - t2
        counters.problems += 1
        s = prev[active[cs]] if warm else None
        s = None if s is None or not np.any(s != 0.0) else s
        r[cs] = _engine(W, b[cs].ravel(), mu_all[active[cs]], d, coulomb, tol, s, counters,
                        max_iter, where, [names[c] for c in active[cs]])
    counters.solve_time += _time.perf_counter() - t0 - (counters.assembly_time - assembly)
    return r, lay


_NO_LAST = np.zeros((0, 0))


def _engine(W, b, mu, d, coulomb, tol, start, counters, max_iter, where, names):
    R = engine.solve(W, b.reshape(-1, d), mu, d, coulomb=coulomb, tol=tol,
                     max_iter=max_iter, start=start)
    counters.engine_calls += 1
    counters.iterations += int(R.iterations)
    if start is not None and R.message.endswith("(warm start)"):
        counters.warm_started += 1
    if not R.converged:
        law = "coulomb" if coulomb else "ccp"
        if not isinstance(where, str):
            where = f"at t = {where[0]:.9g}, step {where[1]}"
        sol = ContactSolution(R.impulse, R.velocity, float(R.residual), "not certified",
                              int(R.iterations), law, tol)
        raise UncertifiedSolutionError(
            f"Moreau–Jean: the contact engine did not certify the step's {law} problem "
            f"({len(names)} contacts: {', '.join(map(str, names))}) at tol {tol:g}: best "
            f"natural-map residual {R.residual:.3g} ({R.message}) {where}",
            float(R.residual), sol)
    return R.impulse


class EngineSolver:
    """The contact problem of a step on the contact engine (laws ``ccp``, ``coulomb`` and
    ``dissipative``),
    for :func:`.moreau_loop.run_steps`: :func:`solve_step` on the step's active rows, then
    ``v_{k+1} = v_free + G J^T r`` (:func:`.moreau_step_kernels.apply_impulses`) and an
    :class:`~.result.ImpactEvent` on the steps where an approaching contact is hit."""

    #: without loops (``m == 0``), its steps may be taken by :class:`.moreau_fast.FastStep`
    FAST = True

    def __init__(self, mech, *, law: str, tol: float, max_iter: int = 100, newton_iter: int = 20,
                 warm_start: bool, islands: bool, rest_velocity: float):
        self.contacts = tuple(mech.contact_names)
        nc, k = len(self.contacts), int(mech.n_coordinates)
        self.m = int(mech.n_loop_constraints)
        self.mu = np.array([float(mech.contact_parameters(c)[1]) for c in self.contacts])
        self.coulomb = law == "coulomb"
        self.poisson = law == "dissipative"  # the plastic ccp impulse times 1 + e_eff
        self.tol, self.max_iter, self.newton_iter = tol, max_iter, newton_iter
        self.warm_start, self.split = warm_start, islands
        self.rest_velocity = rest_velocity
        self.counters = EngineCounters()
        self.layout: Layout | None = None
        self.last: np.ndarray | None = None  # (nc, d): the previous step's impulses
        self.r = None
        self.v_new, self.gen = np.empty(k), np.empty(k)
        self.impacts: list[ImpactEvent] = []
        self.nc = nc

    def idle(self) -> None:
        """A step without active contacts: nothing to warm-start the next from."""
        if self.last is not None:
            self.last[:] = 0.0

    def solve(self, st) -> tuple[np.ndarray, np.ndarray]:
        """``(v_{k+1}, sigma)`` of the step ``st`` (:class:`.moreau_loop.Step`)."""
        na, d = st.Ja.shape[0], st.Ja.shape[1]
        if self.last is None:
            self.last = np.zeros((self.nc, d))
            self.r = np.zeros((self.nc, d))
        r = self.r[:na]
        b = st.b
        if self.poisson:
            # b_n = v_n,free (1 + e_eff) where v_n,free < 0: the plastic problem has b_n =
            # v_n,free, and the impulse is the plastic one times 1 + e_eff (= b_n / v_n,free)
            vnf = st.Ja[:, 0, :] @ st.v_free
            closing = vnf < 0.0
            poisson = np.ones(na)
            poisson[closing] = b[closing, 0] / vnf[closing]
            b = b.copy()
            b[:, 0] = vnf
        try:
            _, self.layout = solve_step(
                st.active, st.Ja, b, self.mu, st.inv, coulomb=self.coulomb, tol=self.tol,
                last=self.last if self.warm_start else None, split=self.split,
                counters=self.counters, names=self.contacts, max_iter=self.max_iter,
                newton_iter=self.newton_iter, where=(st.tm, st.index), cached=self.layout,
                out=r)
        except ConvImpactError as exc:
            exc.add_note(f"(while solving the step's contact problem at t = {st.tm:.9g}, "
                         f"step {st.index}, in simulate_moreau)")
            raise
        if self.poisson:
            r *= poisson[:, None]
        inv = st.inv
        c = st.blocks
        hits = apply_impulses(st.Ja, r, inv.G, c.gflat, c.gsize, c.goff, st.v_free,
                              self.v_new, self.gen, self.last, st.active, st.vn_k,
                              self.rest_velocity)
        sigma = st.sigma
        if self.m:
            sigma = sigma - inv.S @ (inv.A.T @ self.gen)
        if hits:
            self._event(st, r)
        return self.v_new, sigma

    def _event(self, st, r) -> None:
        active, rv = st.active, self.rest_velocity
        hit = np.flatnonzero((st.vn_k < -rv) & (r[:, 0] > 0.0))
        v_new, M = self.v_new, st.M
        u = np.einsum("cdk,k->cd", st.Ja, v_new)
        scale = max(float(np.abs(st.b).max()), 1e-300)
        slip = np.sqrt(np.einsum("cd,cd->c", u[:, 1:], u[:, 1:]))
        regime = tuple(
            "frictionless" if self.mu[active[i]] <= 0.0 else
            "separating" if r[i, 0] <= 0.0 else
            "stick" if slip[i] <= 1e-9 * scale else "slide" for i in hit)
        T_minus = 0.5 * float(st.v_free @ M @ st.v_free)
        T_plus = 0.5 * float(v_new @ M @ v_new)
        self.impacts.append(ImpactEvent(
            time=st.tm, contacts=tuple(self.contacts[active[i]] for i in hit),
            held_contacts=(), regime=regime, impulse=r[hit].copy(),
            loop_impulse=np.zeros(self.m), generalized_impulse=self.gen.copy(),
            theta=st.qm.copy(), dtheta_minus=st.v.copy(), dtheta_plus=v_new.copy(),
            energy_loss=T_minus - T_plus,
            kinetic_energy_minus=0.5 * float(st.v @ M @ st.v), kinetic_energy_plus=T_plus,
            persistent=(), released=(), resolve_time=0.0, result=None))
