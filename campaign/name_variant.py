"""Give a finished run of Grouptron with the ``robust`` switches its model name, in place.

Usage:
    python campaign/name_variant.py FOLDER [FOLDER ...]

The screening runs (``screen.py --only robust``) and the default-model run were trained as
``--model grouptron`` with the switches that now make the named model ``grouptron-robust``
(``grouptron.presets.MODEL_PRESETS``): the same network, the same settings, the same random
draws. This script checks that a run's settings are exactly the named model's preset on its
split (everything else, such as the seed or the derivatives, stays as trained) and rewrites
the model name in the run's checkpoints (``best.safetensors``, ``last.safetensors``),
``config.json`` and card. Run it on a copy meant for shipping, never on a folder that a
screening run still resumes.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from grouptron.config import ExperimentConfig, config_to_dict, save_config
from grouptron.errors import GrouptronError
from grouptron.model.checkpoint import load_checkpoint, save_checkpoint
from grouptron.presets import VARIANT_MODEL as VARIANT
from grouptron.presets import preset_values
from grouptron.training.model_card import write_model_card
from grouptron.training.selection import SELECTION

SOURCE_MODEL = "grouptron"


def named(config: ExperimentConfig, where: Path) -> ExperimentConfig:
    """``config`` as the named variant, or an error when a setting of the preset differs."""
    if config.model_name == VARIANT:
        return config
    if config.model_name != SOURCE_MODEL:
        raise GrouptronError(f"{where}: a {config.model_name} run, not Grouptron")
    stored = config_to_dict(config)
    preset = preset_values(config.split, VARIANT, config.dataset)
    differing = [
        f"{section}.{key} = {stored[section][key]!r} (the preset: {value!r})"
        for section, values in preset.items()
        if isinstance(values, dict)  # the preset's sections; the rest is the run's own
        for key, value in values.items()
        if stored[section][key] != value
    ]
    if differing:
        raise GrouptronError(f"{where}: not {VARIANT}'s settings: {'; '.join(differing)}")
    return dataclasses.replace(config, model_name=VARIANT)


def rename_run(folder: Path) -> None:
    """Rewrite every file of ``folder`` that names the model."""
    for name in ("best.safetensors", "last.safetensors"):
        path = folder / name
        if path.exists():
            checkpoint = load_checkpoint(path)
            checkpoint.config = named(checkpoint.config, path)
            save_checkpoint(path, checkpoint)
    config = named(load_checkpoint(folder / "best.safetensors").config, folder)
    save_config(config, folder / "config.json")
    metrics = folder / "metrics.jsonl"
    records = [json.loads(line) for line in metrics.read_text().splitlines() if line.strip()]
    selection_file = folder / SELECTION
    selection = json.loads(selection_file.read_text()) if selection_file.exists() else None
    write_model_card(folder, config, records, selection)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("folders", nargs="+", type=Path, help="finished run folders")
    args = parser.parse_args(argv)
    try:
        for folder in args.folders:
            rename_run(folder)
            print(f"{folder}: {VARIANT}")
    except (GrouptronError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
