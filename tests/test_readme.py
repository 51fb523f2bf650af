"""README.md stands alone."""

from __future__ import annotations

import glob
import re
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _bash_lines(text: str) -> list[str]:
    """The command lines of the ```bash blocks (continuations joined, comments dropped)."""
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split("  #")[0].strip()
            if line:
                lines.append(line)
    return lines


def test_no_reference_outside_the_repository():
    assert "../" not in README
    for path in re.findall(r"`((?:scripts|intersection_cosim|scenarios|sumo_networks|tests)/[^`\s]*)`", README):
        pattern = re.sub(r"\{[^}]*\}|<[^>]*>", "*", path)
        assert glob.glob(str(ROOT / pattern)), path
