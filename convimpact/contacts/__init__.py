"""The contact engine: contact problems ``u = W r + b`` with friction cones, any number of
contacts, certified on the original data.

The cone complementarity problem ``K ∋ r ⊥ W r + b ∈ K*`` (the laws ``ccp`` and
``dissipative``) and Coulomb's law in De Saxce's form. Its users: an impact's several contacts
(:mod:`convimpact.impact.several`), Moreau–Jean's steps and the event-driven simulator's
sustained-contact forces (:mod:`convimpact.simulation`), and the public
:func:`~.contact_problem.solve_contact_problem`. It depends on nothing of the package but
:mod:`convimpact.errors` and :mod:`convimpact.compiled`.

* :mod:`.engine`: the entry (:func:`~.engine.solve`); the compiled dense kernels first on
  small problems, the compiled ADMM's bounded try on mid-size ones, else
  :mod:`.ccp_interior`, the interior point on dense (LAPACK) or sparse (QDLDL)
  factorizations, and Coulomb's law from its answer;
* :mod:`.cones`: the friction cones' algebra and the natural-map residual; :mod:`.finish`: the
  regularized semismooth Newton finish; :mod:`.admm_kernel` (compiled, dense) and
  :mod:`.admm` (sparse; its iterations compiled in :mod:`.admm_sparse_kernel`): the ADMM on
  Coulomb's law in De Saxce's form; :mod:`.fixed_point`:
  the fixed point on De Saxce's shift, the last resort; :mod:`.subspace`: the firmly sticking
  contacts' velocity solved to zero between the Gauss-Seidel's sweeps; :mod:`.threads`: the
  factorizations on one BLAS thread;
* :mod:`.lowrank`: W's low-rank factor (pivoted Cholesky) and the finish's step through it;
* :mod:`.generalized`: the problem in generalized coordinates, ``W = G G^T`` with
  ``G = J L^-T`` sparse from the mass matrix and the contact Jacobian, and the engine's
  linear algebra through it (the ADMM's solves by Woodbury's identity, the interior point's
  quasi-definite system); :mod:`.lowrank_sparse`: the finish's step through a sparse G, laid
  out once per solve; :mod:`.sparse_step`: the finish's sparse step system on W's block
  pattern, set up once per problem; :mod:`.supernodal`: a supernodal LDL^T, in place of
  QDLDL's numeric factorization where a fixed pattern fills in;
* :mod:`.contact_problem`: :func:`~.contact_problem.solve_contact_problem`, the public API on
  ``(W, b, mu)``, or ``(M, J, b, mu)`` (``mass_matrix=``, ``jacobian=``);
* the compiled dense kernels: :mod:`.interior_point` (Mehrotra, Nesterov-Todd),
  :mod:`.newton` (the scaled programs and their drivers), :mod:`.natural_map` (their Newton
  finish), :mod:`.certificates`.
"""
