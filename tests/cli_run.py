"""Run the command line in-process for the tests: ``(exit code, standard error)``."""

from __future__ import annotations

import contextlib
import io


def run_cli(argv) -> tuple[int, str]:
    """``convimpact.cli.main(argv)`` with stdout discarded and stderr captured; an argparse
    exit (SystemExit) gives its code."""
    from convimpact.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
    return code, err.getvalue()
