"""The package benchmark behind ``convimpact bench``.

Sections (registered in run order, see :mod:`convimpact.bench.registry`):

* ``per-impact`` (:mod:`~convimpact.bench.per_impact`): every law, method and tolerance on the
  same planar/spatial, single/several-contact, open/closed-loop problems, median wall time
  against error to a tight reference, with Pinocchio as an outside peer when installed;
* ``landscape`` (:mod:`~convimpact.bench.throughput`): points per second of the dissipation
  landscapes.

Every run records the machine (:mod:`~convimpact.bench.machine`) and writes ``bench.json``,
``summary.txt`` and PNG charts. Further sections plug in with :func:`register_section`: a
module of this package whose name ends in ``_section`` is imported with the package (after
the two above, in name order), so adding ``convimpact/bench/<name>_section.py`` is enough.

>>> from convimpact.bench import section_names
>>> section_names()[:2]
['per-impact', 'landscape']
"""

from __future__ import annotations

from .registry import (
    BenchConfig,
    SectionResult,
    register_section,
    run_bench,
    section_names,
    stderr_progress,
)
from . import per_impact as _per_impact  # noqa: E402,F401  (registers "per-impact")
from . import throughput as _throughput  # noqa: E402,F401  (registers "landscape")


def _load_section_modules() -> None:
    """Import every ``*_section`` module of this package (each registers its section)."""
    import importlib
    import pkgutil

    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        if info.name.endswith("_section"):
            importlib.import_module(f"{__name__}.{info.name}")


_load_section_modules()
from . import cli as _cli  # noqa: E402,F401  (registers the subcommand, after the sections)

__all__ = ["BenchConfig", "SectionResult", "register_section", "run_bench", "section_names",
           "stderr_progress"]
