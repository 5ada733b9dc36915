"""The documentation site's sources say true things about the code: every public name has a
reference page and a docstring, every name the pages use exists where they say, the options
table is the one the code enforces, the notebooks carry the outputs the site shows, and the
citation file is valid. (The site itself is built with warnings as errors by .ci/run.)"""

from __future__ import annotations

import importlib
import inspect
import json
import re
from pathlib import Path

import numpy as np
import pytest

import convimpact
import convimpact.impact.batch
import convimpact.model
import convimpact.simulation

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
API = DOCS / "api"
SOURCES = [ROOT / "README.md", ROOT / "CHANGELOG.md", *[
    p for p in DOCS.rglob("*.md")
    if not p.relative_to(DOCS).as_posix().startswith(("_build", "api/generated", "bench"))]]


def documented() -> set[str]:
    """Fully qualified names listed in the API pages' autosummary tables."""
    names = set()
    for page in API.glob("*.md"):
        module = None
        for line in page.read_text().splitlines():
            m = re.match(r"\.\. currentmodule:: (\S+)", line)
            if m:
                module = m.group(1)
            m = re.match(r"   (~?)([\w.]+)$", line)
            if m and module:
                names.add(f"{module}.{m.group(2)}")
    return names


MODULES = {"convimpact": convimpact, "convimpact.model": convimpact.model,
           "convimpact.simulation": convimpact.simulation,
           "convimpact.impact.batch": convimpact.impact.batch}


@pytest.mark.parametrize("module", sorted(MODULES))
def test_every_public_name_has_a_reference_page(module):
    listed = documented()
    mod = MODULES[module]
    for name in mod.__all__:
        obj = getattr(mod, name)
        same = f"convimpact.{name}" in listed and getattr(convimpact, name, None) is obj
        assert f"{module}.{name}" in listed or same, (
            f"{module}.{name} has no reference page: list it in an autosummary table of "
            f"docs/api/*.md (under `.. currentmodule:: {module}`)")


def test_every_documented_name_exists_and_has_a_docstring():
    for full in sorted(documented()):
        module, _, name = full.rpartition(".")
        obj = getattr(importlib.import_module(module), name)
        if inspect.isfunction(obj) or inspect.isclass(obj) or inspect.ismodule(obj):
            assert (inspect.getdoc(obj) or "").strip(), f"{full} has no docstring"


def test_the_names_the_pages_use_exist():
    """`ci.NAME`, `convimpact.NAME` and `from convimpact.X import Y` in the pages resolve."""
    for page in SOURCES:
        text = page.read_text()
        for name in set(re.findall(r"\bci\.([A-Za-z_]\w*)", text)):
            assert hasattr(convimpact, name), f"{page.name}: ci.{name} does not exist"
        for dotted in set(re.findall(r"\bconvimpact(?:\.[A-Za-z_]\w*)+", text)):
            parts = dotted.split(".")
            obj = convimpact
            for i, part in enumerate(parts[1:], start=1):
                if hasattr(obj, part):
                    obj = getattr(obj, part)
                    continue
                try:
                    obj = importlib.import_module(".".join(parts[:i + 1]))
                except ImportError:
                    pytest.fail(f"{page.name}: {dotted} does not exist")
        for module, names in re.findall(r"from (convimpact[\w.]*) import ([\w, ]+)", text):
            mod = importlib.import_module(module)
            for name in names.split(","):
                assert hasattr(mod, name.strip()), f"{page.name}: {module}.{name} does not exist"


def test_simulate_with_lives_in_the_simulation_package():
    assert not hasattr(convimpact, "simulate_with")
    assert callable(convimpact.simulation.simulate_with)


def _options_table() -> dict[str, set[str]]:
    text = (DOCS / "user_guide" / "choosing.md").read_text()
    start = text.index("| method | option |", text.index("### Each method's options"))
    table = text[start:text.index("\n\n", start)]
    out: dict[str, set[str]] = {}
    methods: list[str] = []
    for row in table.splitlines()[2:]:
        cells = [c.strip() for c in row.strip("|").split("|")]
        if cells[0]:
            methods = re.findall(r"`([\w-]+)`", cells[0])
        for m in methods:
            out.setdefault(m, set())
            option = re.findall(r"`(\w+)`", cells[1])
            if option:
                out[m].add(option[0])
    return out


@pytest.mark.parametrize("method,law,several", [
    ("closed-form", "pereira-nikravesh", False), ("fast", "coulomb", False),
    ("sweep", "pereira-nikravesh", False), ("interior", "ccp", True),
    ("clarabel", "coulomb", False), ("cvxpy", "coulomb", False)])
def test_the_options_table_is_what_the_methods_accept(method, law, several):
    table = _options_table()
    M, Jc = 2.0 * np.eye(2), np.array([[0.0, 1.0], [1.0, 0.0]])
    with pytest.raises(convimpact.UnknownOptionError) as err:
        convimpact.resolve_impact(M, [Jc, Jc] if several else Jc, [1.0, -1.0], e=0.5, mu=0.3,
                                  law=law, method=method, not_an_option=1)
    message = str(err.value)
    if "takes no options" in message:
        listed = ""
    elif "it accepts" in message:
        listed = message.split("it accepts", 1)[1]
    else:
        listed = message.split("takes options", 1)[1].split(";")[0]
    accepted = {name.strip() for name in listed.split(",") if name.strip()}
    assert accepted == table[method], (method, message)


def test_the_notebooks_carry_their_outputs():
    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        cells = json.loads(nb.read_text())["cells"]
        code = [c for c in cells if c["cell_type"] == "code" and "".join(c["source"]).strip()]
        assert code, nb.name
        assert any(c.get("outputs") for c in code), f"{nb.name} was committed without outputs"
        assert not any(o.get("output_type") == "error" for c in code for o in c.get("outputs", [])), \
            f"{nb.name} shows an error"


def test_citation_and_changelog():
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0"
    assert {"message", "title", "authors", "version"} <= set(cff)
    assert cff["version"] == convimpact.__version__
    assert any(ref["year"] == 1996 for ref in cff["references"])
    assert (ROOT / "CHANGELOG.md").read_text().startswith("# Changelog")
    assert "CHANGELOG.md" in (DOCS / "changelog.md").read_text()


def test_the_docs_extra_installs_the_build():
    text = (ROOT / "pyproject.toml").read_text()
    docs = re.search(r"^docs = \[(.*?)\]", text, flags=re.S | re.M)
    assert docs, "pyproject.toml has no docs extra"
    for package in ("sphinx", "pydata-sphinx-theme", "myst-nb", "numpydoc"):
        assert f'"{package}' in docs.group(1)
    assert "sphinx" in (ROOT / ".ci" / "run").read_text()


def test_the_readmes_links_and_pictures_exist():
    text = (ROOT / "README.md").read_text()
    targets = re.findall(r"\]\(([^)#\s]+)\)", text)
    assert targets
    for target in targets:
        if not target.startswith(("http://", "https://")):
            assert (ROOT / target).exists(), f"README links to {target}, which does not exist"
