"""Give a finished run trained with a named model's switches that model's name, in place.

Usage:
    python campaign/name_variant.py FOLDER [FOLDER ...] [--as MODEL]

The screening runs (``screen.py --only robust``, ``--only trajectron++-residual``) and the
default-model runs were trained as ``--model grouptron`` or ``--model trajectron++`` with the
switches that now make the named models ``grouptron-robust`` and ``trajectron++-residual``
(``grouptron.presets.MODEL_PRESETS``): the same network, the same settings, the same random
draws. This script checks that a run is of the named model's base model with exactly its
preset on its split (everything else, such as the seed or the derivatives, stays as trained)
and rewrites the model name in the run's checkpoints (``best.safetensors``,
``last.safetensors``), ``config.json`` and card. ``--as`` picks the named model (default
``grouptron-robust``). Run it on a copy meant for shipping, never on a folder that a screening
run still resumes.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from grouptron.config import ExperimentConfig, config_from_dict, config_to_dict, save_config
from grouptron.errors import GrouptronError
from grouptron.model.checkpoint import load_checkpoint, save_checkpoint
from grouptron.presets import MODEL_PRESETS, NAMED_MODEL_BASES, VARIANT_MODEL, preset_values
from grouptron.training.model_card import write_model_card
from grouptron.training.selection import SELECTION

SWITCHES = sorted(
    (section, key)
    for preset in MODEL_PRESETS.values()
    for section, values in preset.items()
    for key in values
)
"""Every setting some named model's preset sets: a run given a name must have each at that
model's value (its preset's, else the default), so that a run with another model's switches
too (robust Grouptron with the velocity residual, say, is `grouptron-robust-residual`) is not
named after either of the others."""


def named(config: ExperimentConfig, where: Path, name: str = VARIANT_MODEL) -> ExperimentConfig:
    """``config`` as the named model ``name``, or an error when a switch differs from its."""
    if config.model_name == name:
        return config
    if config.model_name != NAMED_MODEL_BASES[name]:
        raise GrouptronError(f"{where}: a {config.model_name} run, not {NAMED_MODEL_BASES[name]}")
    stored = config_to_dict(config)
    expected = config_to_dict(
        config_from_dict(ExperimentConfig, preset_values(config.split, name, config.dataset))
    )
    differing = [
        f"{section}.{key} = {stored[section][key]!r} (the preset: {expected[section][key]!r})"
        for section, key in SWITCHES
        if stored[section][key] != expected[section][key]
    ]
    if differing:
        raise GrouptronError(f"{where}: not {name}'s settings: {'; '.join(differing)}")
    return dataclasses.replace(config, model_name=name)


def rename_run(folder: Path, name: str = VARIANT_MODEL) -> None:
    """Rewrite every file of ``folder`` that names the model, as the named model ``name``."""
    for file in ("best.safetensors", "last.safetensors"):
        path = folder / file
        if path.exists():
            checkpoint = load_checkpoint(path)
            checkpoint.config = named(checkpoint.config, path, name)
            save_checkpoint(path, checkpoint)
    config = named(load_checkpoint(folder / "best.safetensors").config, folder, name)
    save_config(config, folder / "config.json")
    metrics = folder / "metrics.jsonl"
    records = [json.loads(line) for line in metrics.read_text().splitlines() if line.strip()]
    selection_file = folder / SELECTION
    selection = json.loads(selection_file.read_text()) if selection_file.exists() else None
    write_model_card(folder, config, records, selection)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("folders", nargs="+", type=Path, help="finished run folders")
    parser.add_argument(
        "--as",
        dest="name",
        choices=tuple(NAMED_MODEL_BASES),
        default=VARIANT_MODEL,
        help="the named model (default: %(default)s)",
    )
    args = parser.parse_args(argv)
    try:
        for folder in args.folders:
            rename_run(folder, args.name)
            print(f"{folder}: {args.name}")
    except (GrouptronError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
