"""Result files are written whole (convimpact.files.write_whole)."""

from __future__ import annotations

import pytest

from convimpact.files import write_whole


def test_a_whole_write_replaces_the_file_and_leaves_no_partial(tmp_path):
    target = tmp_path / "bench.json"
    target.write_text("old")
    assert write_whole(target, '{"new": 1}\n') == target
    assert target.read_text() == '{"new": 1}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bench.json"]


def test_a_failed_write_leaves_the_old_file_and_no_partial(tmp_path, monkeypatch):
    target = tmp_path / "paper.json"
    target.write_text("old and complete")
    from pathlib import Path

    real = Path.write_text

    def failing(self, text, *args, **kwargs):
        real(self, text[: len(text) // 2], *args, **kwargs)  # half written, then the failure
        raise OSError("disk full")

    monkeypatch.setattr(Path, "write_text", failing)
    with pytest.raises(OSError, match="disk full"):
        write_whole(target, "x" * 100)
    monkeypatch.setattr(Path, "write_text", real)
    assert target.read_text() == "old and complete"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["paper.json"]
