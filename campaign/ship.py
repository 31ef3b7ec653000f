"""Copy a finished run into the shipped checkpoints, under the name the package loads it by.

Usage:
    python campaign/ship.py RUN_FOLDER NAME [--replicate] [--variant | --as MODEL]

Copies the card, ``best.safetensors``, ``config.json``, ``curves.png``, the metrics files and
``selection.json`` of ``RUN_FOLDER`` into ``checkpoints/NAME/``. A dataset description's
absolute path (where the run was trained on a dataset of its own) becomes portable in the
copy's config, card and weights' metadata (``portable_description``). Training state
(``last.safetensors``, ``candidates/``) is never shipped, and the run's paused state
(``campaign/paused/<run>``, README "Training state") is deleted, so the commit that ships a
run also removes its state. ``--replicate`` marks the card of a seed replicate of a shipped
run. ``--as MODEL`` gives a
run trained with a named model's switches that model's name in the copy (``name_variant.py``;
``--variant`` is ``--as grouptron-robust``). A run that has not made its final choice (no
``selection.json``) is refused, and so is a NAME that exists already.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import sys
from pathlib import Path

# name_variant.py is a script beside this one, not part of the package.
sys.path.insert(0, str(Path(__file__).resolve().parent))
from name_variant import named as named_config
from name_variant import rename_run

from grouptron.errors import GrouptronError
from grouptron.model.checkpoint import load_checkpoint
from grouptron.presets import NAMED_MODEL_BASES, VARIANT_MODEL
from grouptron.training.selection import SELECTION

REPO = Path(__file__).resolve().parents[1]
PAUSED = REPO / "campaign" / "paused"
"""Unfinished runs' resumable state, committed once when their training pauses."""
SHIPPED = REPO / "checkpoints"
"""What the package ships (``src/grouptron/checkpoints`` links here)."""
FILES = (
    "README.md",
    "best.safetensors",
    "config.json",
    "curves.png",
    "metrics.csv",
    "metrics.jsonl",
    SELECTION,
)


RESUME_LINE = "`last.safetensors` holds the full training state"
SHIPPED_LINE = (
    "Shipped without its training state (`last.safetensors` stays with the training "
    "campaign), so it cannot be resumed from here; `--init-from` fine-tunes from its weights."
)
REPLICATE_LINE = (
    "A seed replicate of the shipped run of the same name without the seed. " + SHIPPED_LINE
)


def mark_shipped(card: Path, replicate: bool) -> None:
    """Replace the card's resume instructions (written at training time) by a shipped note, or
    add the note where the card has none."""
    note = REPLICATE_LINE if replicate else SHIPPED_LINE
    lines = card.read_text().splitlines()
    kept = [note if line.startswith(RESUME_LINE) else line for line in lines]
    card.write_text("\n".join(kept if note in kept else [*kept, "", note]) + "\n")


def portable_description(stored: str, repo: Path = REPO) -> str:
    """A run's dataset description (``ExperimentConfig.dataset``) as shipped files name it:
    an absolute path names a file of the machine it was trained on, so it becomes the path
    relative to the repository where the file is inside it, else the file's name and the
    SHA-256 of its content (``corridor.toml#sha256=...``). Anything else is kept as it is."""
    path = Path(stored)
    if not path.is_absolute():
        return stored
    if path.resolve().is_relative_to(repo.resolve()):
        return path.resolve().relative_to(repo.resolve()).as_posix()
    try:
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError as exc:
        raise GrouptronError(f"{path}: cannot read the dataset description ({exc})") from None
    return f"{path.name}#sha256={digest}"


def make_portable(folder: Path, repo: Path = REPO) -> None:
    """Name the dataset description of the run in ``folder`` portably
    (:func:`portable_description`) in its config, card and ``best.safetensors``. Only the
    weights' header changes: their tensors keep every byte (the header is padded to 8)."""
    weights = folder / "best.safetensors"
    data = weights.read_bytes()
    end = 8 + int.from_bytes(data[:8], "little")
    header = json.loads(data[8:end])
    config = json.loads(header["__metadata__"]["config"])
    old = config.get("dataset", "")
    new = portable_description(old, repo)
    if new == old:
        return
    config["dataset"] = new
    header["__metadata__"]["config"] = json.dumps(config)
    text = json.dumps(header, separators=(",", ":"), ensure_ascii=False).encode()
    text += b" " * (-len(text) % 8)  # the tensors start 8-aligned, as safetensors writes
    weights.write_bytes(len(text).to_bytes(8, "little") + text + data[end:])
    for name in ("config.json", "README.md"):
        path = folder / name
        path.write_text(path.read_text().replace(old, new))


def ship(
    run: Path,
    name: str,
    *,
    replicate: bool,
    named: str | None,
    shipped: Path = SHIPPED,
    paused: Path = PAUSED,
) -> Path:
    """The shipped folder made from ``run`` (``shipped/name``), its model renamed to the named
    model ``named`` when given; the run's paused training state is deleted."""
    if not (run / SELECTION).exists():
        raise GrouptronError(f"{run}: not finished (no {SELECTION}); nothing shipped")
    target = shipped / name
    if target.exists():
        raise GrouptronError(f"{target} exists; remove it first to replace it")
    files = [*FILES]
    missing = [f for f in files if not (run / f).exists()]
    if missing:
        raise GrouptronError(f"{run}: missing {', '.join(missing)}")
    if named:  # refused before anything is copied
        named_config(load_checkpoint(run / "best.safetensors").config, run, named)
    target.mkdir(parents=True)
    for file in files:
        shutil.copy2(run / file, target / file)
    if named:
        rename_run(target, named)  # rewrites the card, so the replicate note comes after it
    mark_shipped(target / "README.md", replicate)
    make_portable(target)
    shutil.rmtree(paused / run.name, ignore_errors=True)
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("run", type=Path, help="a finished run folder")
    parser.add_argument("name", help="the shipped name, e.g. grouptron-robust-univ-backward")
    parser.add_argument(
        "--replicate", action="store_true", help="a seed replicate: say so on its card"
    )
    names = parser.add_mutually_exclusive_group()
    names.add_argument(
        "--as",
        dest="named",
        choices=tuple(NAMED_MODEL_BASES),
        help="give the copy this named model's name (a run trained with its switches)",
    )
    names.add_argument(
        "--variant",
        dest="named",
        action="store_const",
        const=VARIANT_MODEL,
        help=f"the same as --as {VARIANT_MODEL}",
    )
    args = parser.parse_args(argv)
    try:
        target = ship(args.run, args.name, replicate=args.replicate, named=args.named)
    except (GrouptronError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{args.run} -> {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
