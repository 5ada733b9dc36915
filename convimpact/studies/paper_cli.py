"""``convimpact paper``: the text summary of the reproduction (:func:`format_summary`), its JSON
(:func:`dumps`) and the subcommand (:func:`run`), which writes the figures and ``paper.json``."""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from typing import Any, Mapping

import numpy as np

from ..files import write_whole
from .. import cli
from .paper import ASSUMPTIONS, PENDULUM_3D_E, PENDULUM_3D_MU, PaperReport, build_report
from .paper_figures import write_figures


def format_summary(report: PaperReport) -> str:
    """The short table printed by ``convimpact paper``."""
    d = report.data
    lines = ["Pereira & Nikravesh (1996), Section 9, reproduced by convimpact", "",
             "Assumptions (the paper leaves these open):"]
    lines += [f"  - {a}" for a in ASSUMPTIONS]
    lines += ["", "Approach velocities v_r- (n, t...) [m/s]: ours vs paper"]
    for key in ("pendulum_a", "pendulum_b", "pendulum_3d"):
        lines.append(f"  {key:<12} {np.round(d[key]['v_minus'], 3).tolist()}  vs  "
                     f"{d[key]['paper_v_minus']}")
    t1 = d["table1"]
    lines += ["", "Table 1 analogue: slider-crank strikes the free slider (e = 0.83, m4 = m_eff)"]
    for name, dj in zip(t1["coordinates"], t1["delta_theta_dot"]):
        lines.append(f"  Delta {name:<34} {dj:12.5f}")
    ck = t1["checks"]
    lines.append(f"  impulse pi_n = {t1['normal_impulse']:.5f} N s, loop impulses Delta sigma = "
                 f"{np.round(t1['loop_impulse'], 5).tolist()}")
    gen = np.round(ck["generalized_impulse_on_sliders"], 6).tolist()
    lines.append(f"  checks: generalized impulse on sliders {gen}"
                 f" (equal and opposite: {ck['equal_and_opposite']}), m4 Delta theta_dot_4 = "
                 f"{ck['free_slider_momentum_change']:.5f}, v_n+/v_n- = "
                 f"{-ck['restitution_ratio']:.4f}, |C theta_dot+| = "
                 f"{ck['loop_velocity_residual']:.1e}")
    lines.append("  (paper: Delta theta_dot_4 = 41.58, Delta theta_dot_3 = -68.285 for its "
                 "geometry, not ours)")
    lines += ["", "Fig. 3: energy loss fraction at e = 0 (law | two-particle closed form | paper)"]
    for (label, c), paper in zip(d["fig3"]["cases"].items(), (1.0, 0.54, 0.32)):
        lines.append(f"  {label:<14} {c['fraction_at_e0']:.4f} | {c['fraction_at_e0_two_mass']:.4f}"
                     f" | {paper:.2f}")
    f9 = d["fig9"]
    lines += ["", f"3D pendulum (e = {PENDULUM_3D_E}, mu = {PENDULUM_3D_MU}): alpha_m = "
              f"{f9['alpha_m_deg']:.2f} deg, pi_n(alpha_m) = {f9['normal_impulse_at_alpha_m']:.4f}"
              f" N s, energy-gain sectors (deg) "
              f"{[[round(a, 2) for a in s] for s in f9['energy_gain_sectors_deg']]}"]
    lines.append("  v_r+ per law vs paper 0.916 n + 0.675 t1 + 0.41 t2:")
    for law, r in report.results["pendulum_3d"].items():
        txt = r if isinstance(r, str) else np.round(r.v_plus, 4).tolist()
        lines.append(f"    {law:<18} {txt}")
    lines += ["", f"{'example':<21} {'law':<18} {'regime':<12} {'pi_n':>9} {'T_L/T-':>8}  broken"]
    for key, per in report.results.items():
        ex = report.examples[key]
        T = 0.5 * float(ex.dq @ ex.M @ ex.dq)
        for law, r in per.items():
            if isinstance(r, str):
                lines.append(f"{key:<21} {law:<18} error: {r[:60]}")
                continue
            broken = [k for k, ok in r.diagnostics.held().items() if not ok]
            lines.append(f"{key:<21} {law:<18} {r.regime:<12} {float(r.impulse[0]):9.4f} "
                         f"{r.energy_loss / T:8.4f}  {', '.join(broken) or '-'}")
    return "\n".join(lines)


_INNER_LIST = re.compile(r"\[\s+([^\[\]{}]*?)\s+\]")


def dumps(data: Mapping[str, Any]) -> str:
    """Strict JSON, indented, with every innermost list of numbers or strings on one line."""
    text = json.dumps(data, indent=1, allow_nan=False)
    compact = _INNER_LIST.sub(lambda m: "[" + re.sub(r"\s*\n\s*", " ", m.group(1)) + "]", text)
    # the reformatting only touches whitespace between tokens; keep it only if it round-trips
    return compact if json.loads(compact) == json.loads(text) else text


def run(args) -> int:
    """``convimpact paper``: compute, write the figures and JSON, print the summary."""
    t0 = time.perf_counter()
    progress = None if args.quiet else cli.progress_printer("paper", start=t0)
    report = build_report(quick=args.quick, progress=progress)
    out = args.out
    paths = write_figures(report, out, progress)
    data = dict(report.data)
    data["figures"] = [os.path.basename(p) for p in paths]
    data["elapsed_total_s"] = time.perf_counter() - t0
    text = dumps(data)
    json_path = os.path.join(out, "paper.json")
    write_whole(json_path, text + "\n")  # after the figures it lists
    if args.json:
        sys.stdout.write(text + "\n")
        return 0
    print(format_summary(report))
    print(f"\nwrote {len(paths)} figures and {json_path} into {os.path.abspath(out)} "
          f"in {time.perf_counter() - t0:.1f} s")
    return 0


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="convimpact-paper",
                   help="folder for the PNG figures and paper.json (default ./convimpact-paper/)")
    p.add_argument("--json", action="store_true",
                   help="print the JSON document to standard output instead of the table")
    p.add_argument("--quick", action="store_true", help="coarser grids (for tests and CI)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress lines on stderr (each step, example, law and figure)")


run.add_arguments = _add_arguments
cli.command("paper", "reproduce the paper's examples and figures (PNG + JSON)")(run)

__all__ = ["format_summary", "dumps", "run"]
