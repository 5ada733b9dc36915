"""Sphinx configuration of the convimpact documentation.

Build it with ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (the ``docs``
extra installs what it needs). Warnings are errors: a broken reference, a public name without a
docstring or a notebook that does not render fails the build.
"""

from __future__ import annotations

import re
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))

import convimpact  # noqa: E402

project = "convimpact"
author = "the convimpact developers"
copyright = "2026, the convimpact developers"
release = convimpact.__version__
version = release

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_copybutton",
]

# --- sources -------------------------------------------------------------------------------
# docs/bench/ holds the committed outputs of `convimpact bench` (figures, JSON, summaries):
# the pages show and link them, they are not pages of their own.
exclude_patterns = ["_build", "bench/**", "**.ipynb_checkpoints", "gallery/_generated/**"]
templates_path = ["_templates"]  # the class page: its documented members, no empty tables
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"

# the tutorials are the notebooks of the top-level notebooks/ folder, committed with their
# outputs: copied in at build time and rendered from those stored outputs (not re-executed:
# the suite executes them, and a build must not depend on a kernel's wall clock)
_TUTORIALS = DOCS / "tutorials" / "notebooks"
_TUTORIALS.mkdir(parents=True, exist_ok=True)
for _nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
    _target = _TUTORIALS / _nb.name
    if not _target.exists() or _target.read_bytes() != _nb.read_bytes():
        shutil.copyfile(_nb, _target)
nb_execution_mode = "off"
nb_merge_streams = True

# the gallery: every scene simulated and the paper's figures, drawn from the code as it is
# (docs/gallery/make_figures.py; drawn when docs/gallery/_generated/ lacks them or the scenes
# changed; `python docs/gallery/make_figures.py --force` redraws them after a code change)
sys.path.insert(0, str(DOCS / "gallery"))
import make_figures  # noqa: E402

make_figures.make_figures()

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist", "attrs_inline"]
myst_heading_anchors = 3
myst_dmath_double_inline = True

# --- API reference -------------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"  # numpydoc writes the parameters; the signature keeps the hints
autodoc_member_order = "bysource"
autodoc_default_options = {"inherited-members": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
# numpydoc's validation is not run on every private detail; a public name without a docstring
# is caught below instead
numpydoc_validation_checks: set[str] = set()

# --- HTML ----------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"convimpact {release}"
html_static_path = ["_static"]
html_css_files = ["custom.css"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_sidebars = {"index": [], "changelog": [], "getting_started": [], "layout": []}  # no section to navigate
html_show_sourcelink = False


_LITERAL = re.compile(r"(``.+?``|`[^`]+`)")


def _plain_text(segment: str) -> str:
    # the docstrings write |v_t| for norms and FR_... for name patterns, plain text to a reader
    # and substitutions or references to reStructuredText: escape them outside literals
    segment = re.sub(r"\|", r"\\|", segment)
    return re.sub(r"(\w)_(?=[\s.,;:)]|$)", r"\1\\_", segment)


def _escape_docstring(app, what, name, obj, options, lines):
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        table_row = stripped.startswith("|") and stripped.rstrip().endswith("|") and " | " in stripped
        if table_row or stripped.startswith(("+", "..", ">>>", "...")) or (
                "|" not in line and "_" not in line):
            continue
        parts = _LITERAL.split(line)
        lines[i] = "".join(p if j % 2 else _plain_text(p) for j, p in enumerate(parts))


_SECTION = re.compile(r"^(Parameters|Attributes|Other Parameters|Returns|Yields|Raises)$")
_ENTRY = re.compile(r"^(?P<indent>\s*)(?P<names>[\w*][\w*, ]*?) : (?P<rest>.+)$")


def _is_prose(rest: str, line: str, following: str) -> bool:
    """Is the "type" after ``name :`` a description (a real type precedes an indented,
    capitalised description, or is a set of values)?"""
    rest = rest.rstrip()
    if rest.endswith("."):
        return True
    if len(rest.split()) <= 5 or rest.startswith("{"):
        return False
    deeper = following.strip() and (len(following) - len(following.lstrip())
                                     > len(line) - len(line.lstrip()))
    return not deeper or not following.strip()[0].isupper()


def _split_prose_types(app, what, name, obj, options, lines):
    """Many docstrings write ``name : what it is`` on one line, the description where numpydoc
    expects a type; a "type" of more than five words, or ending with a period, is moved to the
    description's line, so it renders as prose rather than as a long italic type (runs before
    numpydoc parses)."""
    section = None
    out = []
    for i, line in enumerate(lines):
        stripped = line.strip()
        if _SECTION.match(stripped) and i + 1 < len(lines) and set(lines[i + 1].strip()) == {"-"}:
            section = stripped
        elif stripped and not line.startswith((" ", "\t")) and i + 1 < len(lines) and \
                set(lines[i + 1].strip()) == {"-"}:
            section = None
        m = _ENTRY.match(line) if section in ("Parameters", "Attributes", "Other Parameters") \
            else None
        if m and _is_prose(m.group("rest"), line, lines[i + 1] if i + 1 < len(lines) else ""):
            out += [f"{m.group('indent')}{m.group('names')}", f"{m.group('indent')}    {m.group('rest')}"]
        else:
            out.append(line)
    lines[:] = out


def _warn_missing_docstring(app, what, name, obj, options, lines):
    """A public name documented without a docstring is a warning (an error under -W)."""
    if what in ("function", "class", "method", "exception") and not any(l.strip() for l in lines):
        from sphinx.util import logging

        logging.getLogger("convimpact.docs").warning(
            f"public name {name} has no docstring", type="convimpact", subtype="docstring")


def setup(app):
    app.connect("autodoc-process-docstring", _split_prose_types, priority=100)
    app.connect("autodoc-process-docstring", _escape_docstring)
    app.connect("autodoc-process-docstring", _warn_missing_docstring)
