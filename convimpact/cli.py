"""Command line: ``convimpact SUBCOMMAND`` (also ``python -m convimpact``)."""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Callable, Sequence

import numpy as np

#: subcommand name -> (help, add_arguments(parser), run(args) -> exit code)
_COMMANDS: dict[str, tuple[str, Callable, Callable]] = {}


def command(name: str, help: str):
    """Register a subcommand: decorate ``run(args)``; ``run.add_arguments`` adds options."""

    def deco(run):
        _COMMANDS[name] = (help, getattr(run, "add_arguments", lambda p: None), run)
        return run

    return deco


def progress_printer(label: str, stream=None, start: float | None = None) -> Callable[[str], None]:
    """A progress callback for long commands: each message goes at once to stderr (``stream``)
    as ``[  12.3s] label: message``, the time since ``start`` (default: now)."""
    import time

    t0 = time.perf_counter() if start is None else start

    def progress(message: str) -> None:
        out = stream or sys.stderr
        out.write(f"[{time.perf_counter() - t0:7.1f}s] {label}: {message}\n")
        out.flush()

    return progress


def rod_on_floor(angle_deg: float = 30.0, vx: float = 1.0, vy: float = -1.0,
                 omega: float = 0.0, mass: float = 1.0, length: float = 1.0):
    """Raw matrices of a slender rod whose lower end strikes a horizontal floor.

    Coordinates (x, y, phi) of the centre of mass and the rod angle from +x; the lower end is
    at (x - L/2 cos phi, y - L/2 sin phi). Contact frame: n = +y (toward the rod), t = +x.
    Returns ``M, Jc, dq``.
    """
    phi = np.radians(angle_deg)
    h = 0.5 * length
    M = np.diag([mass, mass, mass * length**2 / 12.0])
    Jc = np.array([[0.0, 1.0, -h * np.cos(phi)],   # n: d/dt of the end's height
                   [1.0, 0.0, h * np.sin(phi)]])   # t: d/dt of the end's x
    return M, Jc, np.array([vx, vy, omega])


def _demo(args) -> int:
    from . import LAWS, available_methods, resolve_impact
    from .errors import ConvImpactError
    from .impact.laws import TANGENTIAL_LAWS

    from .impact.problem.build import (check_friction, check_restitution,
                                       check_tangential_restitution)

    check_restitution(args.e)
    check_friction(args.mu)
    # e_t: the tangential restitution of the laws that have one (0 by default), not passed to
    # the others
    e_t = 0.0 if args.e_t is None else float(check_tangential_restitution(args.e_t)[0])
    M, Jc, dq = rod_on_floor(args.angle)
    rows = []
    for law in LAWS:
        law_params = {"e_t": e_t} if law in TANGENTIAL_LAWS else {}
        for method in available_methods(law):
            if method == "interior":  # the several-contact solver: its own compile, not for one
                continue
            try:
                r = resolve_impact(M, Jc, dq, e=args.e, mu=args.mu, law=law, method=method,
                                   **law_params)
                rows.append({"law": law, "method": method, **r.as_dict()})
            except ConvImpactError as exc:
                rows.append({"law": law, "method": method, "error": str(exc)})
    if args.json:
        json.dump({"scene": "rod_on_floor", "angle_deg": args.angle, "e": args.e,
                   "mu": args.mu, "e_t": e_t, "results": rows}, sys.stdout, indent=2)
        print()
        return 0
    print(f"slender rod (m = 1 kg, L = 1 m) at {args.angle:g} deg striking a floor, "
          f"e = {args.e:g}, mu = {args.mu:g}, e_t = {e_t:g} "
          f"({', '.join(TANGENTIAL_LAWS)}); v- = {np.round(Jc @ dq, 4).tolist()} (n, t)")
    print(f"{'law':<18} {'method':<12} {'regime':<12} {'pi_n':>9} {'pi_t':>9} "
          f"{'v_n+':>8} {'v_t+':>8} {'T_L':>9}")
    for row in rows:
        if "error" in row:
            print(f"{row['law']:<18} {row['method']:<12} error: {row['error']}")
            continue
        pi, vp = row["impulse"], row["v_plus"]
        print(f"{row['law']:<18} {row['method']:<12} {row['regime']:<12} {pi[0]:9.4f} "
              f"{pi[1]:9.4f} {vp[0]:8.4f} {vp[1]:8.4f} {row['energy_loss']:9.5f}")
    return 0


def _demo_args(p: argparse.ArgumentParser) -> None:
    from .validation import arg_finite

    p.add_argument("--angle", type=arg_finite, default=30.0,
                   help="rod angle from the floor, degrees")
    p.add_argument("--e", type=arg_finite, default=0.5, help="coefficient of restitution")
    p.add_argument("--mu", type=arg_finite, default=0.3, help="coefficient of friction")
    p.add_argument("--e-t", type=arg_finite, default=None,
                   help="tangential restitution in [-1, 1] of law chatterjee-ruina (default 0; "
                        "the other laws have none)")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")


_demo.add_arguments = _demo_args
command("demo", "resolve one rod-on-floor impact under every law and method")(_demo)


def _load_command_modules() -> None:
    import importlib

    for name in ("convimpact.studies.paper_cli", "convimpact.simulation.cli", "convimpact.bench",
                 "convimpact.studies.study_cli"):
        try:
            importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name != name and not name.startswith(str(exc.name)):
                raise


def build_parser() -> argparse.ArgumentParser:
    _load_command_modules()
    parser = argparse.ArgumentParser(
        prog="convimpact",
        description="Impact dynamics of multibody systems with frictional contact "
                    "(Pereira & Nikravesh 1996, with maximal-dissipation convex laws).")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (help_, add_args, run) in _COMMANDS.items():
        p = sub.add_parser(name, help=help_, description=help_)
        add_args(p)
        p.set_defaults(_run=run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    from .errors import ConvImpactError

    args = build_parser().parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except ConvImpactError as exc:
        print(f"convimpact: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader went away (e.g. `convimpact paper --json | head`): stop quietly
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:  # pragma: no cover
            pass
        return 0
    except OSError as exc:
        print(f"convimpact: error: cannot write output: {exc} (choose another --out)",
              file=sys.stderr)
        return 2
