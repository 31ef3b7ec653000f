"""The ``grouptron`` commands that the documentation shows."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

SHELL_OPERATORS = {">", ">>", "2>", "|", "&&", ";", "&"}


def shell_commands(path: Path) -> list[str]:
    """The ``grouptron`` commands of a file's bash blocks, continuation lines joined and
    trailing comments cut."""
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", path.read_text(), re.S):
        for line in block.replace("\\\n", " ").splitlines():
            if line.startswith("grouptron "):
                words = shlex.split(line, comments=True)
                cut = [i for i, w in enumerate(words) if w in SHELL_OPERATORS]
                words = words[: cut[0]] if cut else words  # redirections, pipes, chains
                commands.append(" ".join(shlex.quote(w) for w in words))
    return commands
