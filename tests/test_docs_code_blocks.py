"""Every Python code block of the README and of the documentation pages runs as written, and
prints what the page says it prints.

A page's blocks run in order in one namespace (a later block may use an earlier one's names),
each block's standard output compared with the ``text`` block that follows it, if any (lines
stripped of trailing spaces). A block preceded by ``<!-- requires: pkg ... -->`` is skipped when
one of those optional packages is absent; ``<!-- skip-test -->`` skips a block (none today).
Pages written by the build (the gallery's scenes, the generated API stubs, the copied
notebooks) and the committed bench outputs are not checked here.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
GENERATED = ("_build", "api/generated", "tutorials/notebooks", "bench", "gallery/_generated",
             "gallery/scenes")
BLOCK = re.compile(
    r"(?P<marker><!--\s*(?P<directive>requires:[^>]*|skip-test)\s*-->\s*\n)?"
    r"```python\n(?P<code>.*?)```\n"
    r"(?:\s*```text\n(?P<output>.*?)```\n)?", re.S)


def pages() -> list[Path]:
    out = [ROOT / "README.md"]
    for p in sorted(DOCS.rglob("*.md")):
        rel = p.relative_to(DOCS).as_posix()
        if rel.startswith(GENERATED):
            continue
        out.append(p)
    return out


def blocks(text: str) -> list[dict]:
    return [m.groupdict() for m in BLOCK.finditer(text)]


def _normalized(text: str) -> str:
    return "\n".join(line.rstrip() for line in text.strip().splitlines())


def test_the_pages_have_checked_examples():
    found = {p.relative_to(ROOT).as_posix(): blocks(p.read_text()) for p in pages()}
    assert found["README.md"], "the README has no Python block"
    assert found["docs/getting_started.md"][0]["output"], "the first impact shows its output"
    assert sum(1 for bs in found.values() for b in bs if b["output"]) >= 15


@pytest.mark.parametrize("page", [p for p in pages() if blocks(p.read_text())],
                         ids=lambda p: p.relative_to(ROOT).as_posix())
def test_page_code_blocks_run_and_print_what_the_page_says(page, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    found = blocks(page.read_text())
    namespace = {"__name__": "__docs__"}
    rel = page.relative_to(ROOT).as_posix()
    for i, b in enumerate(found):
        directive = b["directive"] or ""
        if directive == "skip-test":
            continue
        if directive.startswith("requires:"):
            missing = [m for m in directive.split(":", 1)[1].split()
                       if importlib.util.find_spec(m) is None]
            if missing:
                continue
        stdout = io.StringIO()
        with contextlib.redirect_stdout(stdout):
            exec(compile(b["code"], f"{rel} block {i + 1}", "exec"), namespace)
        if b["output"] is not None:
            assert _normalized(stdout.getvalue()) == _normalized(b["output"]), (
                f"{rel}, block {i + 1} printed\n{stdout.getvalue()}\nthe page says\n{b['output']}")
