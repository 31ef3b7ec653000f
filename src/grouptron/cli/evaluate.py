"""``grouptron evaluate``: score a checkpoint or constant velocity on the test sets."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
import torch

from grouptron.cli.common import (
    data_settings,
    log,
    own_layout,
    recording_format,
    show_progress,
    warn_look_ahead,
)
from grouptron.cli.options import eval_modes, parse_splits
from grouptron.config import (
    DataConfig,
    ExperimentConfig,
)
from grouptron.constants import ALL_LOCATIONS, SPLITS
from grouptron.data.custom import load_dataset_part, read_dataset
from grouptron.data.locate import resolve_data_dir
from grouptron.data.subsets import density_masks, parse_univ_n
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import (
    ModeScores,
    SampleScores,
    constant_velocity_scores,
    score_samples,
)
from grouptron.evaluation.recordings import evaluate_recordings, training_files
from grouptron.evaluation.results import (
    EvaluationResult,
    mean_over_splits,
    results_json,
    results_table,
)
from grouptron.evaluation.test_sets import load_test_set
from grouptron.groups.assign import assign_groups
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import uses_groups
from grouptron.model.predict import ABLATIONS, default_point_forecast


def _row(template: EvaluationResult, scores: ModeScores) -> EvaluationResult:
    return dataclasses.replace(
        template,
        samples=scores.samples,
        ade=scores.ade,
        fde=scores.fde,
        mode=scores.mode,
        nll=scores.nll if scores.mode == "nll" else None,
    )


def cmd_evaluate_tracks(args: argparse.Namespace) -> int:
    """``evaluate --tracks``: recordings of one's own instead of the benchmark's test sets."""
    fmt = recording_format(args)
    files = [Path(f) for f in args.tracks]
    if args.split is not None or args.subset is not None:
        raise GrouptronError("--split and --subset choose benchmark test sets, not --tracks")
    model, experiment = None, None
    data = data_settings(args)
    if args.checkpoint:
        model, experiment = load_trained_model(resolve_checkpoint(args.checkpoint))
        torch.set_num_threads(args.threads)
        data = dataclasses.replace(experiment.data, on_gap=args.on_gap)
        if args.derivatives and args.derivatives != data.derivatives:
            raise GrouptronError(
                f"{args.checkpoint} was trained with {data.derivatives} derivatives, not "
                f"{args.derivatives}"
            )
        for path in training_files(files, experiment):
            log.warning(
                "%s is part of the data %s was trained or validated on (%s split): its scores "
                "are not held-out scores",
                path,
                args.checkpoint,
                experiment.split,
            )
        warn_look_ahead(args.checkpoint, data.derivatives)
    if "nll" in _modes(args, experiment) and args.mode != "all":
        raise GrouptronError("--mode nll is scored on benchmark test sets, not on --tracks")
    modes = tuple(m for m in _modes(args, experiment) if m != "nll")
    ablate = _ablations(args, experiment is not None and uses_groups(experiment))
    results = evaluate_recordings(
        files, fmt, model=model, experiment=experiment, data=data, modes=modes,
        seed=args.seed, progress=show_progress(args), device=args.device,
        by_density=args.by_density, ablate=ablate, baseline=model is not None,
    )  # fmt: skip
    print(results_json(results) if args.format == "json" else results_table(results))
    return 0


def cmd_evaluate_dataset(args: argparse.Namespace) -> int:
    """``evaluate --dataset``: the test part of a dataset of one's own."""
    if own_layout(args) or args.no_speed_check:
        raise GrouptronError(
            "--columns, --fps, --units, --max-gap and --no-speed-check describe --tracks files; "
            "a --dataset file gives its files' layout itself"
        )
    dataset = read_dataset(args.dataset)
    model, experiment = None, None
    data = data_settings(args)
    if args.checkpoint:
        model, experiment = load_trained_model(resolve_checkpoint(args.checkpoint))
        torch.set_num_threads(args.threads)
        data = experiment.data
    part = load_dataset_part(dataset, "test", data, use_cache=not args.no_cache)
    template = EvaluationResult(dataset.name, "constant-velocity", None, 0, 0.0, 0.0)
    template = dataclasses.replace(template, derivatives=data.derivatives)
    masks: dict[str | None, np.ndarray | None] = {None: None}
    masks.update(density_masks(part.samples) if args.by_density else {})
    ablate = _ablations(args, experiment is not None and uses_groups(experiment))
    baseline = [constant_velocity_scores(part.samples, data.horizon_steps)]
    cv_rows = [
        dataclasses.replace(_row(template, baseline[0].summary(keep)), subset=subset, mode=None)
        for subset, keep in masks.items()
    ]
    results = []
    if model is not None and experiment is not None:
        groups = None
        if uses_groups(experiment):
            groups = assign_groups(part.samples, experiment.groups, data.position_scale_m)
        per_sample = score_samples(
            model.to(args.device), experiment, part.samples, _modes(args, experiment),
            seed=args.seed, progress=show_progress(args), groups=groups, device=args.device,
            ablate=ablate,
        )  # fmt: skip
        suffix = f" without {' and '.join(ablate)}" if ablate else ""
        template = dataclasses.replace(
            template, model=experiment.model_name + suffix, checkpoint=str(args.checkpoint)
        )
        results = [
            dataclasses.replace(_row(template, scores.summary(keep)), subset=subset)
            for scores in per_sample
            for subset, keep in masks.items()
        ]
    results += cv_rows  # constant velocity beside the model, on the same samples
    print(results_json(results) if args.format == "json" else results_table(results))
    return 0


def _modes(args: argparse.Namespace, experiment: ExperimentConfig | None) -> tuple[str, ...]:
    """The modes asked for; by default the checkpoint's own point forecast (what predict
    writes), or ``ml`` for constant velocity (one forecast)."""
    if args.mode is not None:
        return eval_modes(args.mode)
    return (default_point_forecast(experiment.model),) if experiment is not None else ("ml",)


def _ablations(args: argparse.Namespace, has_scene: bool) -> tuple[str, ...]:
    ablate = tuple(a.strip() for a in (args.ablate or "").split(",") if a.strip())
    unknown = sorted(set(ablate) - set(ABLATIONS))
    if unknown:
        raise GrouptronError(
            f"unknown --ablate {', '.join(unknown)}; choose from {', '.join(ABLATIONS)}"
        )
    if ablate and not args.checkpoint:
        raise GrouptronError("--ablate takes inputs away from a checkpoint's model")
    if "scene" in ablate and not has_scene:
        raise GrouptronError("--ablate scene needs a Grouptron checkpoint (a scene encoding)")
    return ablate


def _model_and_data(
    args: argparse.Namespace,
) -> tuple[TrajectronCVAE | None, ExperimentConfig | None, DataConfig]:
    """The checkpoint's model, experiment and data settings, or only data settings for the
    baseline."""
    if not args.checkpoint:
        return None, None, data_settings(args)
    model, experiment = load_trained_model(resolve_checkpoint(args.checkpoint))
    torch.set_num_threads(args.threads)
    config = experiment.data
    if args.derivatives and args.derivatives != config.derivatives:
        raise GrouptronError(
            f"{args.checkpoint} was trained with {config.derivatives} derivatives; "
            f"evaluating it on {args.derivatives} ones would be meaningless"
        )
    return model, experiment, config


def _check_options(args: argparse.Namespace) -> None:
    """Refuse option combinations that have no meaning, before anything is read."""
    if args.model is not None and args.checkpoint is not None:
        raise GrouptronError("give either --checkpoint PATH or --model constant-velocity")
    if args.model is None and args.checkpoint is None:
        args.checkpoint = DEFAULT_CHECKPOINT
    if args.tracks and args.dataset:
        raise GrouptronError("give either --tracks or --dataset, not both")
    sampled = [m for m in eval_modes(args.mode or "ml") if m in ("best-of-20", "nll")]
    if args.model is not None and sampled and args.mode != "all":
        raise GrouptronError(
            f"constant velocity makes one forecast: --mode {','.join(sampled)} needs a --checkpoint"
        )


def cmd_evaluate(args: argparse.Namespace) -> int:
    """``grouptron evaluate``: score a checkpoint beside constant velocity (or that alone) on
    the benchmark's test sets, as a table or JSON (``--tracks``, ``--dataset``: own handlers)."""
    _check_options(args)
    if args.tracks:
        return cmd_evaluate_tracks(args)
    if args.dataset:
        return cmd_evaluate_dataset(args)
    data_dir = resolve_data_dir(args.data_dir)
    model, experiment, config = _model_and_data(args)
    if experiment is not None and experiment.split == ALL_LOCATIONS:
        raise GrouptronError(
            f"{args.checkpoint} was trained on every ETH/UCY location ({ALL_LOCATIONS}), so "
            "no benchmark test set is held out from it; score it on recordings of your own "
            "(--tracks, --dataset)"
        )
    splits = parse_splits(
        args.split if args.split is not None else (experiment.split if experiment else "all")
    )
    subset = parse_univ_n(args.subset) if args.subset is not None else None
    if subset is not None and splits != ["univ"]:
        raise GrouptronError("--subset univ-N needs --split univ")
    modes = _modes(args, experiment)
    grouped = experiment is not None and uses_groups(experiment)
    ablate = _ablations(args, grouped)
    results: list[EvaluationResult] = []
    group_config = experiment.groups if experiment is not None and grouped else None
    for split in splits:
        samples, groups = load_test_set(
            data_dir, split, config, subset, group_config=group_config, use_cache=not args.no_cache
        )
        masks = {args.subset: None, **(density_masks(samples) if args.by_density else {})}
        scored: list[tuple[str, str | None, SampleScores]] = []
        if model is not None and experiment is not None:
            suffix = f" without {' and '.join(ablate)}" if ablate else ""
            scored += [
                (experiment.model_name + suffix, str(args.checkpoint), scores)
                for scores in score_samples(
                    model.to(args.device), experiment, samples, modes, seed=args.seed,
                    progress=show_progress(args), groups=groups, ablate=ablate,
                    device=args.device,
                )
            ]  # fmt: skip
        # Constant velocity beside the model, on the same samples.
        baseline = constant_velocity_scores(samples, config.horizon_steps)
        scored.append(("constant-velocity", None, baseline))
        for name, checkpoint, scores in scored:
            template = EvaluationResult(split, name, None, 0, 0.0, 0.0)
            template = dataclasses.replace(
                template, checkpoint=checkpoint, derivatives=config.derivatives
            )
            for subset_name, keep in masks.items():
                row = dataclasses.replace(_row(template, scores.summary(keep)), subset=subset_name)
                results.append(row if checkpoint else dataclasses.replace(row, mode=None))
    results = [r for r in results if r.samples or r.subset is None]
    if len(splits) == len(SPLITS) and not args.by_density:
        for mode in dict.fromkeys(r.mode for r in results):
            results.append(mean_over_splits([r for r in results if r.mode == mode]))
    print(results_json(results) if args.format == "json" else results_table(results))
    return 0
