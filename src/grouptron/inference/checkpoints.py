"""Checkpoints by path or shipped name, and the model used where none is named."""

from __future__ import annotations

import difflib
import logging
import os
from pathlib import Path

from grouptron import constants
from grouptron.errors import GrouptronError
from grouptron.model.checkpoint import BEST_WEIGHTS_FILE

log = logging.getLogger("grouptron")

CHECKPOINTS_ENV = "GROUPTRON_CHECKPOINTS"
PACKAGE_CHECKPOINTS = Path(__file__).resolve().parents[1] / "checkpoints"
"""The shipped checkpoints installed with the package (weights and configs only; in a source
checkout a link to the repository's checkpoints/)."""

DEFAULT_CHECKPOINT = constants.DEFAULT_CHECKPOINT
"""The model used where none is named (``Predictor.from_checkpoint()``, ``grouptron predict``,
``plot``, ``adapt``): the group-aware residual variant fine-tuned on every ETH/UCY recording and
real crowds from three other places, strictly causal, with its own point forecast
(``ml-top2``, stored with it). Chosen over the same recipe on plain Trajectron++ (residual)
by the worst of three seeds on the out-of-domain development set; each of its seeds is at
most 0.90x constant velocity's FDE pooled and with 25+ neighbours, and below it on every
recording
(benchmarks/RESULTS.md, "A deployment model"). A model for use: it saw the ETH/UCY test
recordings, so it never appears in benchmark tables."""

INSTALLED_CHECKPOINTS = (
    DEFAULT_CHECKPOINT,
    "trajectron++-residual-univ-backward",
    "grouptron-robust-residual-univ-backward",
    "grouptron-robust-univ-backward",
    "trajectron++-univ-backward",
    "grouptron-univ-backward",
    "trajectron++-residual-all-locations-backward",
    "grouptron-robust-all-locations-backward",
)
"""The causal models whose weights an install carries (pyproject's package-data names the same
ones): what a user picks by name to forecast live tracks. Every other shipped checkpoint (the
paper's tables, seed replicates, the papers' protocol) installs its card and config only and
is loaded from the repository's checkpoints/ folder."""


def resolve_checkpoint(name_or_path: str | Path, checkpoints_dir: str | Path | None = None) -> Path:
    """A checkpoint file from a path or a shipped name such as ``"grouptron-univ-backward"``.

    Names are looked up in ``checkpoints_dir``, ``$GROUPTRON_CHECKPOINTS``, ``./checkpoints`` and
    the shipped checkpoints installed with the package, so shipped names resolve from any
    working directory.
    """
    if not isinstance(name_or_path, str | os.PathLike) or not str(name_or_path):
        raise GrouptronError(
            f"a checkpoint is a shipped name or a path to a .safetensors file, not {name_or_path!r}"
        )
    path = Path(name_or_path)
    if path.is_file():
        return path
    if path.is_dir() and (path / BEST_WEIGHTS_FILE).is_file():
        return path / BEST_WEIGHTS_FILE
    if path.suffix == ".safetensors" or len(path.parts) > 1:  # a path, not a shipped name
        raise GrouptronError(
            f"{path}: a folder without {BEST_WEIGHTS_FILE}; name the checkpoint file"
            if path.is_dir()
            else f"{path}: checkpoint not found"
        )
    folders = [Path(d) for d in (checkpoints_dir, os.environ.get(CHECKPOINTS_ENV)) if d]
    folders += [Path("checkpoints"), PACKAGE_CHECKPOINTS]
    for folder in folders:
        candidate = folder / str(name_or_path) / BEST_WEIGHTS_FILE
        if candidate.is_file():
            return candidate
    if (PACKAGE_CHECKPOINTS / str(name_or_path) / "config.json").is_file():
        raise GrouptronError(
            f"checkpoint {name_or_path!s} is shipped in the repository's checkpoints/ folder but "
            f"not with this install: clone the repository and run from it, or set "
            f"${CHECKPOINTS_ENV} to that folder"
        )
    known = sorted(
        {p.parent.name for f in folders if f.is_dir() for p in f.glob(f"*/{BEST_WEIGHTS_FILE}")}
    )
    if path.is_dir():  # a folder here, named like a checkpoint, but not one
        raise GrouptronError(
            f"{path}: a folder without {BEST_WEIGHTS_FILE}, and no shipped checkpoint has that name"
        )
    close = difflib.get_close_matches(str(name_or_path), known, n=3)
    if close:
        raise GrouptronError(f"no checkpoint {name_or_path!s}; did you mean {' or '.join(close)}?")
    hint = f"; known names: {', '.join(known)}" if known else ""
    raise GrouptronError(
        f"no checkpoint {name_or_path!s}: not a file, and no {BEST_WEIGHTS_FILE} under "
        f"{', '.join(str(f) for f in dict.fromkeys(folders))}{hint} (set ${CHECKPOINTS_ENV} to "
        f"a folder of <name>/{BEST_WEIGHTS_FILE})"
    )


def warn_look_ahead(name: str | Path, derivatives: str) -> None:
    """Warn that a checkpoint trained with central derivatives reads, for each forecast, the
    position one step after the forecast time (docs/recordings.md, "Look-ahead")."""
    if derivatives == "central":
        log.warning(
            "%s was trained with central derivatives: each forecast reads the position one "
            "step after the forecast time, which live data does not have; use a backward "
            "checkpoint for causal forecasts",
            name,
        )
