"""How error messages name the options of a recording's layout: as the command line's flags
(``--units cm``), as Python keywords (``units='cm'``) or as the keys of a dataset file
(``units = "cm"``)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Literal

_FLAG_NAMES = {"max_gap_s": "--max-gap"}


@dataclass(frozen=True)
class OptionSpelling:
    """``style``: ``flags`` (command line), ``keywords`` (Python) or ``keys`` (TOML/JSON)."""

    style: Literal["flags", "keywords", "keys"]

    def name(self, option: str) -> str:
        """``"max_gap_s"`` -> ``"--max-gap"``, or ``"max_gap_s"`` as a keyword or key."""
        if self.style != "flags":
            return option
        return _FLAG_NAMES.get(option, "--" + option.replace("_", "-"))

    def setting(self, option: str, value: object) -> str:
        """``("units", "cm")`` -> ``--units cm``, ``units='cm'`` or ``units = "cm"``; the
        speed check is switched off with ``--no-speed-check`` on the command line."""
        if self.style == "keywords":
            return f"{option}={value!r}"
        if self.style == "keys":
            return f"{option} = {json.dumps(value)}"
        if option == "check_speed" and value is False:
            return "--no-speed-check"
        return f"{self.name(option)} {value}"


FLAGS = OptionSpelling("flags")
KEYWORDS = OptionSpelling("keywords")
FILE_KEYS = OptionSpelling("keys")
