"""``grouptron compare``: two models' paired differences on the same test samples (the work:
:func:`grouptron.workflows.compare.compare`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from grouptron.cli.options import parse_splits
from grouptron.evaluation.metrics import scoring
from grouptron.workflows.compare import Side, compare, compared_table
from grouptron.workflows.evaluate_files import ForecastFiles

FORECAST_SUFFIXES = (".csv", ".ndjson")


def side(text: str) -> Side:
    """Forecast files by their suffix (comma-separated: one per test recording), else a
    checkpoint (a name, file or run folder)."""
    files = [Path(part) for part in text.split(",")]
    if all(f.suffix in FORECAST_SUFFIXES for f in files):
        return ForecastFiles(tuple(files))
    return text


def cmd_compare(args: argparse.Namespace) -> int:
    """``grouptron compare A B``: both scored on each split's test samples, B - A printed."""
    torch.set_num_threads(args.threads)
    names = args.split.split(",") if args.split else []
    splits = tuple(s for name in names for s in parse_splits(name.strip())) or None
    with scoring(args.metrics):  # registered for this comparison only (and its labels)
        rows = compare(
            side(args.a), side(args.b), splits, args.mode, data_dir=args.data_dir, seed=args.seed
        )
        if args.format == "json":
            print(json.dumps({"a": args.a, "b": args.b, "rows": [r.to_dict() for r in rows]}))
        else:
            print(compared_table(rows, (args.a, args.b)))
    return 0
