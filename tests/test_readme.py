"""The README's Python examples run as written, and its two commands are the ones CI uses."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_readme_python_blocks_run():
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert blocks
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {"__name__": "__readme__"})


def test_readme_commands_and_ci_agree():
    main = re.search(r"<!-- main-command -->\n```bash\n(.*?)\n```", README).group(1)
    test = re.search(r"<!-- test-command -->\n```bash\n(.*?)\n```", README).group(1)
    assert "pip install" in main and "convimpact" in main.split("&&")[-1]
    assert "pytest" in test
    ci = (ROOT / ".ci" / "run").read_text()
    assert "test-command" in ci  # .ci/run reads the test command from the README


def test_main_command_subcommand_exists():
    main = re.search(r"<!-- main-command -->\n```bash\n(.*?)\n```", README).group(1)
    sub = main.split("&&")[-1].split()[1]
    out = subprocess.run([sys.executable, "-m", "convimpact", sub, "--help"],
                         capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
