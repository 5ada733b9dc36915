"""Open pages of the built site in headless Chromium, screenshot them, fail on a broken page.

Usage (after building the site into docs/_build/html)::

    python docs/screenshots.py [--html docs/_build/html] [--out docs/screenshots]

For each page it checks, independently of the browser, that the HTML file exists, holds the
text the page must show, and that every image it references exists in the build; then it takes
a screenshot with Chromium (Debian's ``chromium`` package, or ``$CHROMIUM``) and fails when the
picture is blank (almost one colour) or the browser wrote nothing. Screenshots are shrunk to at
most 1000 px wide and saved as palette PNGs so that they stay small. Exit status 0 when every
page passed, 1 otherwise (each failure is printed).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import unquote, urlparse

DOCS = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Page:
    """A page to open: its path in the build, the texts it must hold, its screenshot's name."""

    path: str
    must_contain: tuple[str, ...]
    name: str
    height: int = 1400


PAGES = (
    Page("index.html", ("convimpact", "Impact dynamics of multibody systems", "Getting started"),
         "home.png"),
    Page("api/generated/convimpact.resolve_impact.html",
         ("resolve_impact", "Parameters", "Returns", "Raises"), "resolve_impact.png", 1600),
    Page("gallery/scenes/index.html", ("The scenes", "bouncing_ball", "rocking_block",
                                        "slider_crank"), "gallery_scenes.png", 1600),
)


def find_chromium() -> str:
    for name in (os.environ.get("CHROMIUM"), "chromium", "chromium-browser", "google-chrome"):
        if name and shutil.which(name):
            return shutil.which(name)
    raise SystemExit("no Chromium found: apt-get install chromium (or set $CHROMIUM)")


def check_html(html_root: Path, page: Page) -> list[str]:
    """Problems found in the page's HTML: missing file, missing text, missing images."""
    f = html_root / page.path
    if not f.exists():
        return [f"{page.path}: not built"]
    text = f.read_text(encoding="utf-8")
    problems = [f"{page.path}: does not contain {t!r}" for t in page.must_contain if t not in text]
    for src in re.findall(r'<img[^>]+src="([^"]+)"', text):
        if urlparse(src).scheme in ("http", "https", "data"):
            continue
        target = (f.parent / unquote(src.split("#")[0])).resolve()
        if not target.exists():
            problems.append(f"{page.path}: image {src} is missing")
    return problems


def screenshot(chromium: str, html_root: Path, page: Page, out: Path) -> list[str]:
    """Take the screenshot; problems if the browser failed or the picture is blank."""
    from PIL import Image

    url = (html_root / page.path).resolve().as_uri()
    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / "raw.png"
        cmd = [chromium, "--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
               "--no-first-run", "--disable-extensions", f"--user-data-dir={tmp}/profile",
               f"--window-size=1280,{page.height}", "--virtual-time-budget=5000",
               f"--screenshot={raw}", url]
        try:
            run = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
        except subprocess.TimeoutExpired:
            return [f"{page.path}: Chromium did not finish in 180 s"]
        if not raw.exists():
            return [f"{page.path}: Chromium wrote no screenshot (exit {run.returncode}): "
                    f"{run.stderr.strip()[-500:]}"]
        img = Image.open(raw).convert("RGB")
    problems = []
    colours = img.getcolors(maxcolors=1 << 16)
    if colours is not None:
        dominant = max(count for count, _ in colours) / (img.width * img.height)
        if dominant > 0.97 or len(colours) < 16:
            problems.append(f"{page.path}: the screenshot is blank ({len(colours)} colours, "
                            f"{dominant:.1%} one colour)")
    if img.width > 1000:
        img = img.resize((1000, round(img.height * 1000 / img.width)), Image.LANCZOS)
    out.parent.mkdir(parents=True, exist_ok=True)
    img.quantize(colors=128, method=Image.MEDIANCUT).save(out, optimize=True)
    return problems


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--html", type=Path, default=DOCS / "_build" / "html")
    p.add_argument("--out", type=Path, default=DOCS / "screenshots")
    args = p.parse_args(argv)
    chromium = find_chromium()
    failures = []
    for page in PAGES:
        problems = check_html(args.html, page)
        if not any("not built" in q for q in problems):
            problems += screenshot(chromium, args.html, page, args.out / page.name)
        status = "FAILED" if problems else "ok"
        size = (args.out / page.name).stat().st_size // 1024 if (args.out / page.name).exists() else 0
        print(f"{status:6s} {page.path} -> {args.out / page.name} ({size} kB)")
        failures += problems
    for q in failures:
        print("  " + q, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
