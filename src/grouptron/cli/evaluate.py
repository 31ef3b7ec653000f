"""``grouptron evaluate``: score a checkpoint or constant velocity on the test sets, track
files or a dataset (the work: :func:`grouptron.workflows.evaluate.evaluate`)."""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from grouptron.cli.common import own_layout, show_progress, track_file
from grouptron.cli.learning import learning_options
from grouptron.cli.options import eval_modes, parse_splits
from grouptron.data.datasets.custom import read_dataset
from grouptron.errors import GrouptronError
from grouptron.evaluation.metrics import scoring
from grouptron.evaluation.results import results_json, results_table
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT
from grouptron.point_forecast import is_sampled_mode
from grouptron.workflows.evaluate import (
    Benchmark,
    EvaluationOptions,
    Source,
    Tracks,
    evaluate,
)
from grouptron.workflows.evaluate_files import ForecastFiles
from grouptron.workflows.evaluate_learning import (
    LearningEvaluation,
    evaluate_learning,
    learning_json,
    learning_table,
)


def _check_options(args: argparse.Namespace) -> None:
    """Refuse option combinations that the Python API's types rule out (the workflow checks
    the rest), before anything is read."""
    _check_forecast_options(args)
    if args.tracks and args.dataset:
        raise GrouptronError("give either --tracks or --dataset, not both")
    if (args.tracks or args.dataset) and (args.split is not None or args.subset is not None):
        raise GrouptronError("--split and --subset choose benchmark test sets, not --tracks")
    if args.learn and (not args.tracks or args.model is not None):
        raise GrouptronError("--learn scores a checkpoint learning the sites of --tracks files")
    if args.dataset and (own_layout(args) or args.no_speed_check):
        raise GrouptronError(
            "--columns, --fps, --units, --max-gap and --no-speed-check describe --tracks files; "
            "a --dataset file gives its files' layout itself"
        )


def _scored(args: argparse.Namespace) -> str | ForecastFiles | None:
    """What is scored: forecast files, constant velocity alone (None) or a checkpoint."""
    if args.forecasts:
        files = tuple(Path(f) for f in args.forecasts)
        return ForecastFiles(files, args.name or "", allow_missing=args.allow_missing)
    return None if args.model is not None else (args.checkpoint or DEFAULT_CHECKPOINT)


def _check_forecast_options(args: argparse.Namespace) -> None:
    """One of a checkpoint, forecast files or constant velocity; what files cannot take."""
    given = [args.checkpoint, args.model, args.forecasts]
    if sum(g is not None for g in given) > 1:
        raise GrouptronError(
            "give one of --checkpoint PATH, --forecasts FILE or --model constant-velocity"
        )
    if (args.name or args.allow_missing) and not args.forecasts:
        raise GrouptronError("--name and --allow-missing describe --forecasts files")
    if args.forecasts and (args.learn or args.calibration is not None or args.dataset):
        raise GrouptronError(
            "--forecasts files are scored as they are: --learn, --calibration and --dataset "
            "need a --checkpoint"
        )


def _source(args: argparse.Namespace) -> Source:
    if args.tracks:
        return Tracks(tuple(Path(f) for f in args.tracks), track_file(args, path=""))
    if args.dataset:
        return read_dataset(args.dataset)
    splits = tuple(parse_splits(args.split)) if args.split is not None else None
    return Benchmark(splits, args.subset, Path(args.data_dir) if args.data_dir else None)


def _modes(args: argparse.Namespace) -> tuple[str, ...] | None:
    """The modes asked for (None: the checkpoint's own point forecast); ``all`` leaves out
    what has no meaning here: the NLL of track files, the sampled modes of constant
    velocity (the workflow refuses them when named)."""
    if args.mode is None:
        return None
    modes = eval_modes(args.mode)
    if args.mode != "all":
        return modes
    if args.model is not None:
        return tuple(m for m in modes if not is_sampled_mode(m))
    return tuple(m for m in modes if m != "nll") if args.tracks else modes


def cmd_evaluate(args: argparse.Namespace) -> int:
    """``grouptron evaluate``: score a checkpoint beside constant velocity (or that alone) on
    the benchmark's test sets, track files or a dataset, as a table or JSON."""
    _check_options(args)
    checkpoint = _scored(args)
    torch.set_num_threads(args.threads)
    if args.learn:
        return _evaluate_learning(args, args.checkpoint or DEFAULT_CHECKPOINT)
    ablate = tuple(a.strip() for a in (args.ablate or "").split(",") if a.strip())
    options = EvaluationOptions(
        seed=args.seed,
        by_density=args.by_density,
        ablate=ablate,
        derivatives=args.derivatives,
        on_gap=args.on_gap,
        device=args.device,
        use_cache=not getattr(args, "no_cache", False),
        progress=show_progress(args),
        regions=args.regions,
        calibration=args.calibration,
        include_seen=args.include_seen,
        metrics=args.metrics,
    )
    with scoring(args.metrics):  # registered while the table prints too: their labels
        rows = evaluate(_source(args), checkpoint, _modes(args), options)
        print(results_json(rows) if args.format == "json" else results_table(rows))
    return 0


def _evaluate_learning(args: argparse.Namespace, checkpoint: str) -> int:
    """``evaluate --tracks ... --learn``: every file replayed learning its site, its later
    part scored beside the fixed model."""
    sources = _source(args)
    assert isinstance(sources, Tracks)
    options = learning_options(args)
    assert options is not None
    request = LearningEvaluation(
        sources.sources, checkpoint, options, args.scored_from, show_progress(args)
    )
    rows = evaluate_learning(request)
    print(learning_json(rows) if args.format == "json" else learning_table(rows))
    return 0
