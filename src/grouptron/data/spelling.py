"""How error messages name the options of a recording's layout: as the command line's flags
(``--max-gap 2``) or as the keywords of Python calls and dataset files (``max_gap_s=2``)."""

from __future__ import annotations

from dataclasses import dataclass

_FLAG_NAMES = {"max_gap_s": "--max-gap"}


@dataclass(frozen=True)
class OptionSpelling:
    """``flags``: write options as command-line flags; else as keywords."""

    flags: bool

    def name(self, option: str) -> str:
        """``"max_gap_s"`` -> ``"--max-gap"`` or ``"max_gap_s"``."""
        if not self.flags:
            return option
        return _FLAG_NAMES.get(option, "--" + option.replace("_", "-"))

    def setting(self, option: str, value: object) -> str:
        """``("units", "cm")`` -> ``"--units cm"`` or ``"units='cm'"``; switching the speed
        check off is ``--no-speed-check`` on the command line."""
        if not self.flags:
            return f"{option}={value!r}"
        if option == "check_speed" and value is False:
            return "--no-speed-check"
        return f"{self.name(option)} {value}"


FLAGS = OptionSpelling(flags=True)
KEYWORDS = OptionSpelling(flags=False)
