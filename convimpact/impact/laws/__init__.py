"""The impact laws, one module each: the law's definition, its exact single-contact kernel
(``method="fast"``), its cone program(s) (``method="clarabel"``/``"cvxpy"``), and any closed
form of its own. A law module registers its solvers when imported
(:func:`convimpact.impact.fast.register_kernel`,
:func:`convimpact.impact.conic.paths.register_programs`,
:func:`convimpact.impact.resolve.register_solver`); :mod:`convimpact.impact.resolve` imports
it on first use.

Adding a law means adding its module here and one line to :data:`LAW_MODULES`.
"""

#: law name (the ``law=`` of ``resolve_impact``) -> its module in this package
LAW_MODULES = {
    "pereira-nikravesh": "pereira_nikravesh",  # the paper's law (Section 8)
    "coulomb": "coulomb",                      # Coulomb friction on the post-impact slip
    "ccp": "ccp",                              # Anitescu's cone complementarity relaxation
    "dissipative": "dissipative",              # plastic maximal dissipation x Poisson
    "stronge": "stronge",                      # Stronge's energetic law (impulse space)
}
