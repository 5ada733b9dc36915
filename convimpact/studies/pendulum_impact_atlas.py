"""A shipped study: four impact laws over a million configurations of the double pendulum.

The paper's planar double pendulum (rods 1 m, 1 kg; ``pendulum_planar``) strikes the floor
with its tip at every configuration theta1 x theta2 of a 1000 x 1000 grid (theta1 in
[-pi, 0], rod 1 from +x; theta2 in [-pi, pi], rod 2 relative to rod 1), at the paper's joint
rates (1, 1) rad/s, restitution e = 0.5, under the laws pereira-nikravesh, coulomb, ccp and
dissipative (Stronge's and Chatterjee-Ruina's are not in this shipped spec) and mu in
{0.3, 0.8}: 8e6 impacts through the compiled batch (study kind ``impacts``). The spec is
``studies/pendulum_impact_atlas.toml`` (the same as :func:`study_spec`); the figure
(:func:`plot_pendulum_impact_atlas`, ``docs/figures/pendulum_impact_atlas.png``) colours each
configuration by its regime and marks where the law gains energy.

``python -m convimpact.studies.pendulum_impact_atlas --out DIR [--quick] [--scheduler ADDRESS]``
runs it (``--quick``: a 100 x 100 grid) into ``DIR/pendulum_impact_atlas.zarr`` and draws the
figure into ``DIR``; ``convimpact study studies/pendulum_impact_atlas.toml --out STORE`` runs
the same study.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .study_spec import StudySpec, spec_from_dict

#: grid points per axis of the full study and of the quick one
FULL_POINTS, QUICK_POINTS = 1000, 100


def study_dict(points: int = FULL_POINTS) -> dict[str, Any]:
    """The spec as a mapping (the TOML layout) with ``points`` per angle."""
    return {
        "study": {"kind": "impacts", "title": "double pendulum: impact laws over "
                  f"{points} x {points} configurations", "chunk_points": 200_000},
        "options": {"scene": "pendulum_planar", "contact": "tip", "dtheta": [1.0, 1.0],
                    "e": 0.5},
        # the configurations first: a chunk evaluates M and Jc once for its 8 (mu, law)
        "grid": {"theta1": {"start": -math.pi, "stop": 0.0, "num": points, "units": "rad"},
                 "theta2": {"start": -math.pi, "stop": math.pi, "num": points,
                            "units": "rad"},
                 "mu": {"values": [0.3, 0.8]},
                 "law": {"values": ["pereira-nikravesh", "coulomb", "ccp", "dissipative"]}},
    }


def study_spec(quick: bool = False) -> StudySpec:
    """The validated spec (full: 1000 x 1000 configurations; quick: 100 x 100)."""
    return spec_from_dict(study_dict(QUICK_POINTS if quick else FULL_POINTS),
                          source="pendulum_impact_atlas")


#: categories of the figure, in colour order
CATEGORIES = ("separating", "frictionless", "stick", "slide", "stick, gains energy",
              "slide, gains energy", "kernel rejects (singular W)")
_COLORS = ("#d9d9d9", "#fdfdfd", "#a6cee3", "#b2df8a", "#1f78b4", "#33a02c", "#000000")


def categories(ds) -> np.ndarray:
    """Category index (into :data:`CATEGORIES`) of every impact of the dataset."""
    regime = ds["regime"].values.astype(int)
    gained = ds["energy_gained"].values
    cat = np.where(regime < 0, 6, regime)
    cat = np.where(gained & (regime == 2), 4, cat)
    return np.where(gained & (regime == 3), 5, cat)


def plot_pendulum_impact_atlas(ds, out: str | Path | None = None):
    """One panel per (mu, law): each configuration coloured by its regime, energy gain dark.

    Returns the matplotlib Figure (written to ``out`` as PNG when given)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    cat = categories(ds)
    mus, laws = ds["mu"].values, [str(v) for v in ds["law"].values]
    th1, th2 = ds["theta1"].values, ds["theta2"].values
    fig, axes = plt.subplots(len(mus), len(laws), figsize=(3.2 * len(laws),
                                                            3.0 * len(mus) + 0.9),
                             sharex=True, sharey=True, squeeze=False)
    cmap = ListedColormap(_COLORS)
    for i, mu in enumerate(mus):
        for j, law in enumerate(laws):
            ax = axes[i, j]
            c = cat[:, :, i, j]  # (theta1, theta2)
            ax.imshow(c.T, origin="lower", cmap=cmap, vmin=-0.5, vmax=len(_COLORS) - 0.5,
                      extent=(th1[0], th1[-1], th2[0], th2[-1]), aspect="auto",
                      interpolation="nearest")
            approaching = c != 0
            gain = 100.0 * np.mean(np.isin(c[approaching], (4, 5))) if approaching.any() \
                else 0.0
            ax.set_title(f"{law}, mu = {mu:g}\nenergy gained at {gain:.1f} % of impacts",
                         fontsize=8)
            if i == len(mus) - 1:
                ax.set_xlabel("theta1 (rod 1 from +x) [rad]", fontsize=8)
            if j == 0:
                ax.set_ylabel("theta2 (rod 2 relative) [rad]", fontsize=8)
            ax.tick_params(labelsize=7)
    present = set(np.unique(cat).tolist())
    handles = [Patch(facecolor=col, edgecolor="0.5", label=name)
               for k, (name, col) in enumerate(zip(CATEGORIES, _COLORS)) if k in present]
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=7,
               frameon=False)
    n = th1.size * th2.size
    fig.suptitle(f"double pendulum striking the floor with its tip: {n:,} configurations x "
                 f"{len(laws)} laws x {len(mus)} friction coefficients (e = 0.5, joint rates "
                 "(1, 1) rad/s)", fontsize=9)
    fig.tight_layout(rect=(0, 0.05, 1, 0.95))
    if out is not None:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out, dpi=110)
    return fig


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m convimpact.studies.pendulum_impact_atlas --out DIR [--quick]``."""
    import matplotlib.pyplot as plt

    from .study import run_study

    p = argparse.ArgumentParser(prog="python -m convimpact.studies.pendulum_impact_atlas",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="output directory (store and figure)")
    p.add_argument("--quick", action="store_true", help="100 x 100 configurations")
    p.add_argument("--scheduler", default=None, help="a Dask scheduler address")
    p.add_argument("--executor", choices=("processes", "serial"), default="processes")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    out = Path(args.out)
    run = run_study(study_spec(args.quick), out / "pendulum_impact_atlas.zarr", args.executor,
                    scheduler=args.scheduler, progress=False if args.quiet else None)
    fig = plot_pendulum_impact_atlas(run.dataset, out / "pendulum_impact_atlas.png")
    plt.close(fig)
    print(f"{run.points_computed} impacts computed in {run.wall_time:.1f} s on "
          f"{run.executor} ({run.n_workers} workers; {run.chunks_skipped} chunks were "
          f"already in the store); figure {out / 'pendulum_impact_atlas.png'}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
