"""The installed package is the source tree: every subpackage is listed in pyproject.toml, so
`pip install .` (not only an editable install) ships every room of the layout."""

from pathlib import Path

import pytest

tomllib = pytest.importorskip("tomllib")  # Python >= 3.11

ROOT = Path(__file__).resolve().parents[1]


def test_every_subpackage_is_installed():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    on_disk = {".".join(p.parent.relative_to(ROOT).parts)
               for p in (ROOT / "convimpact").rglob("__init__.py")}
    on_disk.add("convimpact.problems")  # installed from the top-level folder problems/
    assert config["package-dir"]["convimpact.problems"] == "problems"
    assert listed == on_disk
