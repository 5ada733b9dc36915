"""Section ``atlas``: the failure atlas (:mod:`convimpact.studies.atlas`) as counts, regions and maps.

Every map of :func:`convimpact.studies.atlas.failure_atlas` becomes one record (its JSON form: axes,
counts per path and mode, the regions as 0/1 grids, measured values) and one PNG drawn by
:func:`convimpact.studies.atlas.plot_atlas`. The summary quotes, per map, the modes met by each path.
"""

from __future__ import annotations

from pathlib import Path

from ..studies.atlas import atlas_counts, failure_atlas, plot_atlas
from .registry import BenchConfig, Progress, SectionResult, register_section


@register_section("atlas", "failure atlas: where each law, method and simulation scheme "
                           "gains energy, reverses slip, meets a singular matrix or fails")
def atlas_section(config: BenchConfig, progress: Progress) -> SectionResult:
    """Build the atlas (coarse grids when quick) and draw its maps."""
    import matplotlib.pyplot as plt

    maps = failure_atlas(quick=config.quick, progress=progress)
    records, figures, summary = [], [], []
    for m in maps:
        name = f"atlas_{m.name}.png"
        fig = plot_atlas(m, Path(config.out) / name)
        plt.close(fig)
        figures.append(name)
        records.append(m.as_dict())
        parts = []
        for path, counts in m.counts.items():
            met = {k: v for k, v in counts.items() if v}
            parts.append(f"{path}: " + (", ".join(f"{k} {v}" for k, v in met.items())
                                        if met else "none"))
        summary.append(f"atlas {m.name} ({m.n_samples} samples per path, "
                       f"{m.wall_time:.1f} s): " + "; ".join(parts))
    meta = {"totals": atlas_counts(maps),
            "definitions": "see convimpact.studies.atlas (modes, thresholds); regions are any-over-"
                           "samples per cell, counts are over samples"}
    return SectionResult("atlas", records, figures, summary, meta)
