"""The impact laws, one module each: the law's definition (its docstring, with the
equations), its exact single-contact kernel compiled (``contact_kernel``: ``method="fast"``,
the batch, the lanes), its cone program(s) (``program_result``: ``method="clarabel"`` and
``"cvxpy"``), and any closed form of its own. :mod:`convimpact.impact.resolve` builds the
solver paths from these attributes (its explicit tables) and imports a law's module on first
use.

Adding a law means adding its module here and one line to :data:`LAW_MODULES` (the compiled
drivers find its kernels through :mod:`.table`).
"""

from __future__ import annotations

import importlib
from types import ModuleType

#: law name (the ``law=`` of ``resolve_impact``) -> its module in this package
LAW_MODULES = {
    "pereira-nikravesh": "pereira_nikravesh",  # the paper's law (Section 8)
    "coulomb": "coulomb",                      # Coulomb friction on the post-impact slip
    "ccp": "ccp",                              # Anitescu's cone complementarity relaxation
    "dissipative": "dissipative",              # plastic maximal dissipation x Poisson
    "stronge": "stronge",                      # Stronge's energetic law (impulse space)
    "chatterjee-ruina": "chatterjee_ruina",    # Chatterjee & Ruina's algebraic law (e, e_t)
}
#: law name -> its code in the compiled drivers (its index in LAW_MODULES)
LAW_CODES = {name: code for code, name in enumerate(LAW_MODULES)}
#: laws with a tangential restitution e_t (the ``e_t=`` of ``resolve_impact``)
TANGENTIAL_LAWS = ("chatterjee-ruina",)
#: laws defined per contact: at several contacts they apply contact by contact (independent
#: contacts, or one approaching while the others lift) and refuse coupled simultaneous impacts
PER_CONTACT_LAWS = ("chatterjee-ruina",)


def law_module(law: str) -> ModuleType:
    """The module of ``law`` (imported on first use)."""
    return importlib.import_module(f"{__name__}.{LAW_MODULES[law]}")
