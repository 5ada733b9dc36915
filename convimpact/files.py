"""Result files written whole: a run that fails, or is stopped, while writing leaves no file
that looks complete.

:func:`write_whole` writes to ``<name>.partial`` beside the target and renames it over the
target only once the text is written (a rename within one folder is atomic on POSIX
systems). The command line's result files (``convimpact simulate``'s ``result.json``, the
bench's ``bench.json`` and ``summary.txt``, the paper's ``paper.json``) go through it, each
written after the figures it lists.
"""

from __future__ import annotations

from pathlib import Path


def write_whole(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` under a temporary name, renamed when whole; returns the
    path. A failure removes the temporary file and leaves ``path`` as it was."""
    path = Path(path)
    partial = path.with_name(path.name + ".partial")
    try:
        partial.write_text(text)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    partial.replace(path)
    return path
