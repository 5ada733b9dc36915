"""Draw the gallery's figures: every scene simulated, and the paper's reproduced figures.

Run by the Sphinx build (``docs/conf.py``) when ``docs/gallery/_generated/`` lacks them, or by
hand: ``python docs/gallery/make_figures.py [--force]``. Each scene is simulated over its
default span as ``convimpact simulate SCENE`` does (the default law, or the scheme a scene
declares), and drawn by the same
plotting code (trajectory, energy, contact modes); ``robot_drop`` needs the optional Pinocchio
and example-robot-data packages and a long run, so the gallery shows its committed figure
instead. The paper's figures are those of ``convimpact paper``. Nothing here is committed: the
figures always come from the code as it is.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
OUT = HERE / "_generated"
STAMP = OUT / "figures.json"
PAGES = HERE / "scenes"
FIGURES = HERE.parent / "figures"
#: a scene whose docstring says this needs Pinocchio robots and runs long: not simulated here
OPTIONAL = "Needs the optional packages"


def use_checkout_scenes() -> None:
    """Make ``convimpact.problems`` this checkout's ``problems/`` folder.

    An editable install elsewhere maps ``convimpact.problems`` to its own folder; the site
    documents the scenes of the checkout it is built from.
    """
    import importlib.util

    import convimpact

    folder = ROOT / "problems"
    loaded = sys.modules.get("convimpact.problems")
    if not (folder / "__init__.py").exists() or (
            loaded is not None and Path(loaded.__file__).resolve().parent == folder):
        return
    spec = importlib.util.spec_from_file_location(
        "convimpact.problems", folder / "__init__.py", submodule_search_locations=[str(folder)])
    module = importlib.util.module_from_spec(spec)
    sys.modules["convimpact.problems"] = module
    spec.loader.exec_module(module)
    convimpact.problems = module


def _docstring(name: str) -> str:
    import importlib

    return importlib.import_module(f"convimpact.problems.{name}").__doc__ or ""


def needs_optional_packages(name: str) -> bool:
    """Scenes built on a registry robot (Pinocchio, example-robot-data): shown, not simulated."""
    return OPTIONAL in " ".join(_docstring(name).split())


def _scene_figures(out: Path) -> dict[str, dict]:
    from convimpact import list_scenes, load_scene, simulate
    from convimpact.simulation.cli import write_plots

    done = {}
    for name in list_scenes():
        if needs_optional_packages(name):
            continue
        t0 = time.perf_counter()
        scene = load_scene(name)
        declared = dict(scene.simulation or {})
        if declared.get("scheme") == "moreau-jean":  # as `convimpact simulate` runs it
            from convimpact.simulation.moreau import simulate_moreau

            res = simulate_moreau(scene, (0.0, float(scene.t_end)), h=float(declared["h"]),
                                  law=declared.get("law", "pereira-nikravesh"),
                                  impact_options=dict(declared.get("impact_options", {})))
        else:
            res = simulate(scene, (0.0, float(scene.t_end)), dense_output=True)
        folder = out / name
        folder.mkdir(parents=True, exist_ok=True)
        files = [p.name for p in write_plots(scene, res, folder)]
        files += _animation(scene, res, folder)
        done[name] = {"files": files, "impacts": len(res.impacts), "t_end": float(scene.t_end),
                      "status": int(res.status), "message": str(res.message), "seconds": round(time.perf_counter() - t0, 2)}
        print(f"gallery: {name}: {len(res.impacts)} impacts, {len(files)} figures "
              f"({done[name]['seconds']} s)", file=sys.stderr)
    return done


def _animation(scene, res, folder: Path) -> list[str]:
    """An animated GIF of the run (15 frames/s, at most 150 frames) where the scene can be drawn."""
    from convimpact.errors import NotSupportedError
    from convimpact.simulation.animation import animate

    try:
        animate(res, scene.mechanism, folder / "animation.gif", fps=15, max_frames=150,
                outlines=scene.outlines, title=scene.name)
    except NotSupportedError:  # not built with ModelBuilder: no geometry to draw
        return []
    return ["animation.gif"]


def _paper_figures(out: Path) -> list[str]:
    from convimpact.studies.paper import build_report
    from convimpact.studies.paper_figures import write_figures

    t0 = time.perf_counter()
    folder = out / "paper"
    folder.mkdir(parents=True, exist_ok=True)
    files = [Path(p).name for p in write_figures(build_report(), str(folder))]
    print(f"gallery: the paper's {len(files)} figures ({time.perf_counter() - t0:.1f} s)",
          file=sys.stderr)
    return files


def make_figures(force: bool = False) -> dict:
    """Draw the figures unless they are there already, and write the scenes' page.

    Returns the record of what was drawn (per scene its figures, impacts and status).
    """
    use_checkout_scenes()
    from convimpact import list_scenes

    record = json.loads(STAMP.read_text()) if STAMP.exists() and not force else None
    wanted = [n for n in list_scenes() if not needs_optional_packages(n)]
    if record is None or sorted(record["scenes"]) != sorted(wanted):
        import matplotlib

        matplotlib.use("Agg")
        OUT.mkdir(parents=True, exist_ok=True)
        record = {"scenes": _scene_figures(OUT), "paper": _paper_figures(OUT)}
        STAMP.write_text(json.dumps(record, indent=1))
    write_scene_pages(record)
    return record


def _description(name: str) -> str:
    """The scene module's docstring up to its first underlined heading, as MyST Markdown."""
    lines = _docstring(name).strip("\n").splitlines()
    keep: list[str] = []
    for i, line in enumerate(lines):
        if i + 1 < len(lines) and set(lines[i + 1].strip()) == {"-"}:
            break
        keep.append(line[4:] if line.startswith("    ") and i > 0 else line)
    text = "\n".join(keep).strip()
    text = re.sub(r":(?:func|class|mod|meth|data|attr):`~?([^`]+)`", r"`\1`", text)
    return text


def _parameters(name: str) -> str:
    import importlib
    import inspect

    sig = inspect.signature(importlib.import_module(f"convimpact.problems.{name}").make_scene)
    items = [f"`{p.name}={p.default!r}`" for p in sig.parameters.values()
             if p.default is not inspect.Parameter.empty]
    return ", ".join(items)


def _write(path: Path, lines: list[str]) -> None:
    text = "\n".join(lines).rstrip() + "\n"
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


def _first_sentence(name: str) -> str:
    return _description(name).split("\n\n")[0].replace("\n", " ")


def write_scene_pages(record: dict) -> None:
    """``docs/gallery/scenes/``: a page per scene of ``list_scenes()`` and an index of them."""
    from convimpact import list_scenes

    PAGES.mkdir(parents=True, exist_ok=True)
    names = list_scenes()
    for stale in PAGES.glob("*.md"):
        if stale.stem != "index" and stale.stem not in names:
            stale.unlink()
    header = "<!-- written by docs/gallery/make_figures.py at build time: edit that script -->"
    index = [header, "", "# The scenes", "",
             "Every scene of `convimpact.list_scenes()`, simulated over its default span as "
             "`convimpact simulate SCENE` does: event-driven with the default law "
             "(`pereira-nikravesh`) at the default tolerances, unless the scene declares its "
             "own scheme (`disc_pile`: Moreau–Jean, law `coulomb`); the animations and figures "
             "are drawn by the build from the code as it is.", "", "| | | |", "|---|---|---|"]
    cells = []
    for name in names:
        info = record["scenes"].get(name)
        page = [header, "", f"# `{name}`", "", _description(name), ""]
        params = _parameters(name)
        if params and "Parameters of" not in _docstring(name):
            page += [f"Parameters of `load_scene(\"{name}\", ...)`: {params}.", ""]
        code = ["```python", "import convimpact as ci", "",
                f"scene = ci.load_scene(\"{name}\")",
                "res = ci.simulate(scene, (0.0, scene.t_end))", "```", ""]
        if info is None:
            picture = f"../../figures/{name}.png" if (FIGURES / f"{name}.png").exists() else None
            page += ["Needs the optional packages `pin` and `example-robot-data` (extra "
                     "`robots`); not simulated by the documentation build.", ""]
            page += [f"![{name}]({picture})", ""] if picture else []
            page += code
        else:
            if (FIGURES / f"{name}.gif").exists():
                picture = f"../../figures/{name}.gif"
            elif "animation.gif" in info["files"]:
                picture = f"../_generated/{name}/animation.gif"
            else:
                picture = None
            page += [f"Over {info['t_end']:g} s: {info['impacts']} impacts; status "
                     f"{info['status']} ({info.get('message', '')}).", ""]
            page += code
            page += [f"From the command line: `convimpact simulate {name} --out DIR` (add "
                     "`--animate` for a GIF).", ""]
            page += [f"![{name} animated]({picture})", ""] if picture else []
            page += ["Grey lines mark the impacts.", ""]
            for f in ("trajectory.png", "energy.png", "contacts.png"):
                if f in info["files"]:
                    page += [f"![{name}: {f[:-4]}](../_generated/{name}/{f})", ""]
        _write(PAGES / f"{name}.md", page)
        thumb = f"[![{name}]({picture})]({name}.md)<br>" if picture else ""
        cells.append(f"{thumb}[`{name}`]({name}.md): {_first_sentence(name)}")
    for i in range(0, len(cells), 3):
        row = cells[i:i + 3] + [""] * (3 - len(cells[i:i + 3]))
        index.append("| " + " | ".join(c.replace("|", "\\|") for c in row) + " |")
    index += ["", "```{toctree}", ":hidden:", "", *names, "```", ""]
    _write(PAGES / "index.md", index)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--force", action="store_true", help="draw again even if present")
    make_figures(force=p.parse_args(argv).force)
    return 0


if __name__ == "__main__":
    sys.exit(main())
