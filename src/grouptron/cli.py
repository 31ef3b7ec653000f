"""The ``grouptron`` command: data, evaluation and (later) training subcommands.

Errors caused by input are printed on one line and end the program with exit code 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from grouptron import __version__
from grouptron.baselines.constant_velocity import constant_velocity
from grouptron.config import (
    DataConfig,
    ExperimentConfig,
    GroupConfig,
    experiment_preset,
    load_config,
)
from grouptron.constants import SPLITS, UNIV_N_PAPER
from grouptron.data.dataset import load_part
from grouptron.data.download import fetch_dataset
from grouptron.data.locate import resolve_data_dir
from grouptron.data.reader import read_tracks
from grouptron.data.scene import Scene, build_scene
from grouptron.data.subsets import UNIV_N_DEFINITIONS, UnivN, parse_univ_n, univ_n_mask
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import MODES, evaluate_model
from grouptron.evaluation.report import PROTOCOLS, ReportSettings, find_checkpoints, run_report
from grouptron.evaluation.report_tables import report_markdown
from grouptron.evaluation.results import (
    EvaluationResult,
    mean_over_splits,
    results_json,
    results_table,
    score,
)
from grouptron.evaluation.test_sets import load_test_set
from grouptron.geometry import DERIVATIVE_SCHEMES
from grouptron.groups.cache import load_groups
from grouptron.groups.clustering import LINKAGES
from grouptron.groups.distances import DISTANCE_KINDS
from grouptron.groups.labels import read_group_labels, read_id_map
from grouptron.groups.scene import groups_per_step, position_grid, score_against_labels
from grouptron.inference.predictor import Predictor, resolve_checkpoint
from grouptron.inference.tracks import FORECAST_MODES, forecast_scene
from grouptron.io import (
    refuse_folder,
    write_array_csv_atomically,
    write_csv_atomically,
    write_text_atomically,
)
from grouptron.model.checkpoint import load_checkpoint, load_trained_model
from grouptron.model.factory import MODEL_NAMES, uses_groups
from grouptron.training import distributed
from grouptron.training.metrics_log import MetricsWriter
from grouptron.training.precision import PRECISIONS, precision_name, resolve_precision
from grouptron.training.trainer import LAST, train
from grouptron.viz.forecasts import Panel, animate_forecasts, plot_forecasts, tracks_around
from grouptron.viz.groups import plot_step_groups
from grouptron.viz.training import plot_training_curves

log = logging.getLogger("grouptron")
EXIT_USAGE = 2
REPORT_CHECKPOINTS = "checkpoints"
CURVES = "curves.png"


class _Formatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """Keep the examples' line breaks and show defaults."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        raise GrouptronError(message)


def _add_gap_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--on-gap",
        choices=("split", "error"),
        default="split",
        help="a track that misses steps in the middle: split it into two tracks (with a "
        "warning) or stop with an error",
    )


def _add_data_options(parser: argparse.ArgumentParser, derivatives: bool = True) -> None:
    parser.add_argument(
        "--data-dir",
        help="ETH/UCY folder (default: $GROUPTRON_DATA, else ~/.cache/grouptron/eth_ucy)",
    )
    if derivatives:
        parser.add_argument(
            "--derivatives",
            choices=DERIVATIVE_SCHEMES,
            help="velocity/acceleration scheme: 'central' (the papers' protocol, looks one step "
            "ahead; the default) or 'backward' (causal); a checkpoint brings its own",
        )
    _add_gap_option(parser)
    parser.add_argument(
        "--no-cache", action="store_true", help="rebuild samples instead of using the cache"
    )


def _int_at_least(value: str, lowest: int) -> int:
    try:
        number = int(value)
    except ValueError:
        number = lowest - 1
    if number < lowest:
        wanted = "a positive integer" if lowest == 1 else f"an integer >= {lowest}"
        raise argparse.ArgumentTypeError(f"expected {wanted}, got {value!r}")
    return number


def _positive_int(value: str) -> int:
    return _int_at_least(value, 1)


def _non_negative_int(value: str) -> int:
    return _int_at_least(value, 0)


def _device(value: str) -> torch.device:
    try:
        return torch.device(value)
    except RuntimeError:
        raise argparse.ArgumentTypeError(f"not a torch device: {value!r}") from None


def _splits(value: str) -> list[str]:
    if value == "all":
        return list(SPLITS)
    if value not in SPLITS:
        raise GrouptronError(f"unknown split {value!r}; choose from {', '.join(SPLITS)} or all")
    return [value]


def _int_list(value: str) -> list[int]:
    try:
        numbers = [int(v) for v in value.split(",") if v.strip()]
    except ValueError:
        raise GrouptronError(f"expected comma-separated integers, got {value!r}") from None
    if any(n < 1 for n in numbers):
        raise GrouptronError(f"expected positive integers, got {value!r}")
    return numbers


# --- data -------------------------------------------------------------------------------------


def cmd_data_fetch(args: argparse.Namespace) -> int:
    data_dir = resolve_data_dir(args.data_dir)
    report = fetch_dataset(data_dir, base_url=args.base_url, timeout_s=args.timeout)
    print(
        f"{data_dir}: {len(report.verified)} files verified, {len(report.downloaded)} "
        f"downloaded, {len(report.replaced)} corrupt files replaced"
    )
    return 0


def cmd_data_stats(args: argparse.Namespace) -> int:
    data_dir = resolve_data_dir(args.data_dir)
    config = DataConfig(derivatives=args.derivatives or "central", on_gap=args.on_gap)
    univ_n = _int_list(args.univ_n)
    stats: dict[str, dict[str, object]] = {}
    for split in _splits(args.split):
        parts = {
            part: load_part(data_dir, split, part, config, use_cache=not args.no_cache)
            for part in ("train", "val", "test")
        }
        scenes = [s for p in parts.values() for s in p.scenes]
        entry: dict[str, object] = {
            "scenes": len(scenes),
            "tracks": sum(s.num_tracks for s in scenes),
            "train_samples": len(parts["train"].samples),
            "val_samples": len(parts["val"].samples),
            "test_samples": len(parts["test"].samples),
            "test_max_pedestrians_per_step": max(s.max_present for s in parts["test"].scenes),
        }
        if split == "univ":
            test = parts["test"].samples
            entry["univ_n"] = {
                definition: {
                    str(n): int(univ_n_mask(test, UnivN(n, definition)).sum()) for n in univ_n
                }
                for definition in UNIV_N_DEFINITIONS
            }
        stats[split] = entry
    if args.format == "json":
        print(json.dumps(stats, indent=2))
        return 0
    header = (
        f"{'split':<6} {'scenes':>6} {'tracks':>7} {'train':>8} {'val':>7} {'test':>7} "
        f"{'max peds/step (test)':>21}"
    )
    print(f"ETH/UCY samples ({config.derivatives} derivatives) from {data_dir}")
    print(header)
    print("-" * len(header))
    for split, e in stats.items():
        print(
            f"{split:<6} {e['scenes']:>6} {e['tracks']:>7} {e['train_samples']:>8} "
            f"{e['val_samples']:>7} {e['test_samples']:>7} "
            f"{e['test_max_pedestrians_per_step']:>21}"
        )
    if "univ" in stats:
        counts = stats["univ"]["univ_n"]
        assert isinstance(counts, dict)
        for definition, label in (
            ("predicted", "at steps with >= N predicted agents (the paper's)"),
            ("present", "at steps with >= N pedestrians present"),
        ):
            per_n = ", ".join(f"N={n}: {c}" for n, c in counts[definition].items())
            print(f"UNIV-N test samples {label}: {per_n}")
    return 0


# --- evaluate ---------------------------------------------------------------------------------


def _eval_modes(value: str) -> tuple[str, ...]:
    if value == "all":
        return MODES
    modes = tuple(v.strip() for v in value.split(",") if v.strip())
    unknown = [m for m in modes if m not in MODES]
    if unknown or not modes:
        raise GrouptronError(
            f"unknown mode {', '.join(unknown) or value!r}; choose from {', '.join(MODES)} or all"
        )
    return modes


def cmd_evaluate(args: argparse.Namespace) -> int:
    if (args.model is None) == (args.checkpoint is None):
        raise GrouptronError("give either --checkpoint PATH or --model constant-velocity")
    data_dir = resolve_data_dir(args.data_dir)
    model = None
    if args.checkpoint:
        model, experiment = load_trained_model(args.checkpoint)
        torch.set_num_threads(experiment.train.threads)
        config = experiment.data
        if args.derivatives and args.derivatives != config.derivatives:
            raise GrouptronError(
                f"{args.checkpoint} was trained with {config.derivatives} derivatives; "
                f"evaluating it on {args.derivatives} ones would be meaningless"
            )
        split_arg = args.split or experiment.split
    else:
        config = DataConfig(derivatives=args.derivatives or "central", on_gap=args.on_gap)
        split_arg = args.split or "all"
    splits = _splits(split_arg)
    subset = parse_univ_n(args.subset) if args.subset else None
    if args.subset and splits != ["univ"]:
        raise GrouptronError("--subset univ-N needs --split univ")
    modes = _eval_modes(args.mode)
    results: list[EvaluationResult] = []
    group_config = experiment.groups if model is not None and uses_groups(experiment) else None
    for split in splits:
        samples, groups = load_test_set(
            data_dir, split, config, subset, group_config, use_cache=not args.no_cache
        )
        if model is None:
            pred = constant_velocity(samples.hist_rel_m.astype("float64"), config.horizon_steps)
            cv = score(split, "constant-velocity", args.subset, pred, samples)
            results.append(dataclasses.replace(cv, protocol=config.derivatives))
            continue
        scores = evaluate_model(
            model,
            experiment,
            samples,
            modes,
            seed=args.seed,
            progress=not args.quiet,
            groups=groups,
        )
        for s in scores:
            results.append(
                EvaluationResult(
                    split=split,
                    model=experiment.model_name,
                    subset=args.subset,
                    samples=s.samples,
                    ade=s.ade,
                    fde=s.fde,
                    mode=s.mode,
                    nll=s.nll if s.mode == "nll" else None,
                    checkpoint=str(args.checkpoint),
                    protocol=config.derivatives,
                )
            )
    if len(splits) == len(SPLITS):
        for mode in dict.fromkeys(r.mode for r in results):
            results.append(mean_over_splits([r for r in results if r.mode == mode]))
    print(results_json(results) if args.format == "json" else results_table(results))
    return 0


# --- report -----------------------------------------------------------------------------------


def _report_command(args: argparse.Namespace, modes: tuple[str, ...]) -> str:
    """The canonical command line that regenerates this report (written into it)."""
    parts = ["grouptron report", f"--protocol {args.protocol}", f"--mode {','.join(modes)}"]
    if args.nll_max_samples:
        parts.append(f"--nll-max-samples {args.nll_max_samples}")
    if args.checkpoints != REPORT_CHECKPOINTS:
        parts.append(f"--checkpoints {args.checkpoints}")
    if args.seed:
        parts.append(f"--seed {args.seed}")
    if args.out:
        parts.append(f"--out {args.out}")
    return " ".join(parts)


def cmd_report(args: argparse.Namespace) -> int:
    if args.out:
        refuse_folder(Path(args.out))  # before the work, not after it
    protocols = PROTOCOLS if args.protocol == "both" else (args.protocol,)
    modes = _eval_modes(args.mode)
    settings = ReportSettings(
        modes=modes,
        seed=args.seed,
        nll_max_samples=args.nll_max_samples,
        use_cache=not args.no_cache,
    )
    data_dir = resolve_data_dir(args.data_dir)
    checkpoints = find_checkpoints(Path(args.checkpoints), protocols)
    torch.set_num_threads(args.threads)
    report = run_report(data_dir, checkpoints, protocols, settings, progress=not args.quiet)
    if args.format == "json":
        text = report.to_json() + "\n"
    else:
        text = report_markdown(report, protocols, _report_command(args, modes))
    if args.out:
        write_text_atomically(Path(args.out), text)
        print(f"wrote {args.out}")
    else:
        print(text, end="")
    return 0


# --- predict ----------------------------------------------------------------------------------


def cmd_predict(args: argparse.Namespace) -> int:
    refuse_folder(Path(args.out))  # before the work, not after it
    model, experiment = load_trained_model(resolve_checkpoint(args.checkpoint))
    torch.set_num_threads(args.threads)
    frames_per_step = args.frames_per_step or experiment.data.frames_per_step
    data = dataclasses.replace(experiment.data, frames_per_step=frames_per_step)
    experiment = dataclasses.replace(experiment, data=data)
    scene = build_scene(
        read_tracks(args.tracks, frames_per_step, args.on_gap), data, name=str(args.tracks)
    )
    forecast = forecast_scene(
        model, experiment, scene, args.mode, args.samples, args.seed, progress=not args.quiet
    )
    header, rows, formats = forecast.table(sampled=args.mode == "samples")
    write_array_csv_atomically(Path(args.out), header, rows, formats)
    print(
        f"wrote {len(rows)} rows for {len(forecast)} (pedestrian, frame) pairs "
        f"({experiment.model_name}, {data.derivatives} derivatives, {args.mode}) to {args.out}"
    )
    return 0


# --- plot -------------------------------------------------------------------------------------


def cmd_plot(args: argparse.Namespace) -> int:
    out = Path(args.out)
    refuse_folder(out)  # before the work, not after it
    predictors = [Predictor.from_checkpoint(c) for c in (args.checkpoint, args.compare) if c]
    data = predictors[0].config.data
    table = read_tracks(args.tracks, data.frames_per_step, args.on_gap)
    rows = np.column_stack([table.frame, table.ped_id, table.pos_m]).astype(np.float64)
    if args.until is None:
        plot_forecasts(_plot_panels(args, predictors, rows, args.frame), args.frame, out)
        print(f"wrote {out}: forecasts at frame {args.frame}")
        return 0
    if args.until <= args.frame:
        raise GrouptronError(f"--until {args.until} must come after --frame {args.frame}")
    if out.suffix.lower() not in (".gif", ".mp4"):
        raise GrouptronError(f"{out}: an animation (--until) is written as .gif or .mp4")
    step = data.frames_per_step
    wanted = range(args.frame, args.until + 1, step)
    present = set(rows[:, 0].astype(np.int64).tolist())
    drawn = [
        (frame, _plot_panels(args, predictors, rows, frame, required=False))
        for frame in tqdm(wanted, desc="forecasting", unit="frame", disable=args.quiet)
        if frame in present
    ]
    drawn = [(frame, panels) for frame, panels in drawn if panels]
    if not drawn:
        raise GrouptronError(
            f"{args.tracks}: nobody between frames {args.frame} and {args.until} has "
            f"{data.history_steps} observed steps"
        )
    animate_forecasts(drawn, out)
    print(f"wrote {out}: {len(drawn)} frames from {drawn[0][0]} to {drawn[-1][0]}")
    return 0


def _plot_panels(
    args: argparse.Namespace,
    predictors: list[Predictor],
    rows: np.ndarray,
    frame: int,
    required: bool = True,
) -> list[Panel]:
    """One panel per model at ``frame`` (empty when nobody can be forecast and not required)."""
    data = predictors[0].config.data
    panels = []
    for predictor in predictors:
        forecast = predictor.predict(rows, frame, args.samples, args.seed, live=False)
        if not len(forecast):
            if not required:
                return []
            raise GrouptronError(
                f"{args.tracks}: nobody at frame {frame} has {data.history_steps} observed "
                "steps; pick another --frame"
            )
        history, truth = tracks_around(
            rows,
            forecast.ids,
            frame,
            data.frames_per_step,
            data.history_steps - 1,
            data.horizon_steps,
        )
        name = f"{predictor.config.model_name} ({predictor.config.data.derivatives})"
        panels.append(Panel(name, forecast, history, truth))
    return panels


# --- train ------------------------------------------------------------------------------------


def cmd_train(args: argparse.Namespace) -> int:
    experiment = (
        load_config(ExperimentConfig, args.config)
        if args.config
        else experiment_preset(args.split, args.model)
    )
    data = dataclasses.replace(
        experiment.data,
        **({"derivatives": args.derivatives} if args.derivatives else {}),
        on_gap=args.on_gap,
    )
    train_overrides = {
        key: value
        for key, value in {
            "epochs": args.epochs,
            "seed": args.seed,
            "batch_size": args.batch_size,
            "learning_rate": args.lr,
            "threads": args.threads,
            "init_from": args.init_from,
        }.items()
        if value is not None
    }
    if args.precision is not None or not args.config:
        precision = args.precision or "auto"
        train_overrides["bf16"] = resolve_precision(precision, torch.device(args.device))
    experiment = dataclasses.replace(
        experiment,
        split=args.split,
        model_name=args.model,
        data=data,
        train=dataclasses.replace(experiment.train, **train_overrides),
    )
    out = Path(args.out or f"runs/{args.model}-{args.split}-{data.derivatives}")
    if args.resume and (out / LAST).exists():
        # A resumed run keeps its own configuration; only its length and threads may change.
        stored = load_checkpoint(out / LAST).config
        if (stored.split, stored.model_name) != (args.split, args.model):
            raise GrouptronError(
                f"{out} holds a {stored.model_name} run on {stored.split}, not "
                f"{args.model} on {args.split}"
            )
        length = {k: v for k, v in train_overrides.items() if k in ("epochs", "threads")}
        if args.precision is not None:  # an explicit choice may change it
            length["bf16"] = resolve_precision(args.precision, torch.device(args.device))
            if length["bf16"] != stored.train.bf16:
                print(
                    f"note: {out} ran in {precision_name(stored.train.bf16)} so far; the "
                    f"remaining epochs run in {args.precision} (each epoch's precision is in "
                    "metrics.csv and on the model card)"
                )
        experiment = dataclasses.replace(stored, train=dataclasses.replace(stored.train, **length))
        data = experiment.data
    data_dir = resolve_data_dir(args.data_dir)
    train_part = load_part(data_dir, args.split, "train", data, use_cache=not args.no_cache)
    val_part = load_part(data_dir, args.split, "val", data, use_cache=not args.no_cache)
    train_groups = val_groups = None
    if uses_groups(experiment):
        print("clustering every sample's neighbours into groups (cached after the first run)")
        train_groups, val_groups = (
            load_groups(
                data_dir,
                args.split,
                name,
                data,
                experiment.groups,
                part.samples,
                use_cache=not args.no_cache,
            )
            for name, part in (("train", train_part), ("val", val_part))
        )
    cluster = distributed.start(torch.device(args.device))
    if cluster.is_main:
        processes = f", {cluster.world_size} processes" if cluster.distributed else ""
        print(
            f"training {args.model} on {args.split} ({data.derivatives} derivatives): "
            f"{len(train_part.samples)} training / {len(val_part.samples)} validation samples, "
            f"{experiment.train.epochs} epochs{processes} -> {out}"
        )
    try:
        state = train(
            experiment,
            train_part.samples,
            val_part.samples,
            out,
            resume=args.resume,
            progress=not args.quiet,
            train_groups=train_groups,
            val_groups=val_groups,
            device=args.device,
            cluster=cluster,
        )
    finally:
        distributed.stop(cluster)
    if cluster.is_main:
        records = MetricsWriter(out).records()
        if records:
            plot_training_curves(records, out.name, out / CURVES)
        print(
            f"done: {state.epoch} epochs, {state.iteration} steps; best validation ML FDE "
            f"{state.best_val_fde:.3f} m; checkpoints in {out}"
        )
    return 0


# --- groups ---------------------------------------------------------------------------------


def _group_configs(args: argparse.Namespace) -> list[GroupConfig]:
    linkages = LINKAGES if args.linkage == "all" else (args.linkage,)
    distances = DISTANCE_KINDS if args.distance == "all" else (args.distance,)
    return [GroupConfig(linkage=link, distance=dist) for link in linkages for dist in distances]


def _track_scene(args: argparse.Namespace) -> Scene:
    table = read_tracks(args.tracks, args.frames_per_step, args.on_gap)
    return build_scene(table, DataConfig(frames_per_step=args.frames_per_step), str(args.tracks))


def cmd_groups_evaluate(args: argparse.Namespace) -> int:
    scene = _track_scene(args)
    labels = read_group_labels(args.labels)
    if args.id_map:
        mapping = read_id_map(args.id_map)
        labels = {track: labels[label] for track, label in mapping.items() if label in labels}
    rows = []
    for config in _group_configs(args):
        scores = score_against_labels(scene, labels, config, every=args.every)
        for protocol, values in scores.items():
            rows.append(
                {
                    "protocol": protocol,
                    "linkage": config.linkage,
                    "distance": config.distance,
                    **values,
                }
            )
    if args.format == "json":
        # NaN (no decision of a kind) is not JSON: write null.
        clean = [{k: None if v != v else v for k, v in row.items()} for row in rows]
        document = {"tracks": str(args.tracks), "labels": str(args.labels), "results": clean}
        print(json.dumps(document, indent=2))
        return 0
    header = (
        f"{'protocol':<9} {'linkage':<9} {'distance':<10} {'precision':>9} {'recall':>7} "
        f"{'F1':>6} {'Dice':>6} {'decisions':>9}"
    )
    print(header)
    print("-" * len(header))
    for r in rows:
        print(
            f"{r['protocol']:<9} {r['linkage']:<9} {r['distance']:<10} "
            f"{r['pair_precision']:>9.3f} {r['pair_recall']:>7.3f} {r['pair_f1']:>6.3f} "
            f"{r['dice']:>6.3f} {r['decisions']:>9}"
        )
    return 0


def cmd_groups_detect(args: argparse.Namespace) -> int:
    scene = _track_scene(args)
    config = GroupConfig(linkage=args.linkage, distance=args.distance)
    found = list(groups_per_step(scene, config))
    if not found:
        raise GrouptronError(
            f"{args.tracks}: no pedestrian is tracked over 2 or more steps, so there is "
            "nobody to group"
        )
    rows = [
        (scene.first_frame + f.step * scene.frames_per_step, int(scene.ped_id[track]), int(label))
        for f in found
        for track, label in zip(f.tracks, f.labels, strict=True)
    ]
    if args.out:
        write_csv_atomically(Path(args.out), ("frame", "id", "group"), rows)
        print(f"{len(rows)} rows ({len(found)} steps) written to {args.out}")
    else:
        print("frame,id,group")
        for row in rows:
            print(",".join(str(v) for v in row))
    if args.plot:
        if not found:
            raise GrouptronError(f"{args.tracks}: no step to plot")
        if args.frame is None:
            chosen = max(found, key=lambda f: len(f.tracks))
        else:
            step, rest = divmod(args.frame - scene.first_frame, scene.frames_per_step)
            matches = [f for f in found if f.step == step]
            if rest or not matches:
                raise GrouptronError(f"frame {args.frame} is not a frame of {args.tracks}")
            chosen = matches[0]
        pad = DataConfig().history_steps - 1
        pos, present = position_grid(scene, pad)
        window = slice(chosen.step, chosen.step + pad + 1)
        frame = scene.first_frame + chosen.step * scene.frames_per_step
        plot_step_groups(
            pos[chosen.tracks, window] + scene.centre_world_m,
            present[chosen.tracks, window],
            chosen.labels,
            scene.ped_id[chosen.tracks],
            f"{Path(args.tracks).name}, frame {frame}: {len(chosen.tracks)} pedestrians, "
            f"{len(np.unique(chosen.labels))} groups ({config.linkage} linkage)",
            Path(args.plot),
        )
        print(f"plot of frame {frame} written to {args.plot}")
    return 0


# --- parser -----------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="grouptron",
        description="Group-aware pedestrian trajectory forecasting on ETH/UCY "
        "(Grouptron and Trajectron++).",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron data fetch\n"
        "  grouptron data stats --split all\n"
        "  grouptron evaluate --model constant-velocity --split all\n"
        "  grouptron train --split eth --epochs 10\n"
        "  grouptron evaluate --checkpoint runs/trajectron++-eth-central/best.safetensors\n\n"
        "Run 'grouptron COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"grouptron {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log more detail")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    data = commands.add_parser(
        "data",
        help="get and inspect the ETH/UCY benchmark",
        description="Get and inspect the ETH/UCY benchmark files.",
        formatter_class=_Formatter,
        epilog="examples:\n  grouptron data fetch\n  grouptron data stats --split univ",
    )
    data_commands = data.add_subparsers(dest="data_command", metavar="ACTION", parser_class=_Parser)

    fetch = data_commands.add_parser(
        "fetch",
        help="download the benchmark files and verify their checksums",
        description="Download the ETH/UCY files (Trajectron++ repository, fixed commit) into the "
        "data folder and verify every file against the SHA256 list shipped with grouptron. "
        "Files that already verify are kept; nothing half-written is ever left behind.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron data fetch\n"
        "  grouptron data fetch --data-dir ~/datasets/eth_ucy",
    )
    fetch.add_argument("--data-dir", help="target folder (default: $GROUPTRON_DATA or the cache)")
    fetch.add_argument(
        "--base-url", help="download from this URL prefix instead (or $GROUPTRON_DATA_URL)"
    )
    fetch.add_argument("--timeout", type=float, default=60.0, help="seconds per request")
    fetch.set_defaults(handler=cmd_data_fetch)

    stats = data_commands.add_parser(
        "stats",
        help="scenes, tracks and sample counts per split",
        description="Per split: scenes, tracks, training/validation/test samples, the most "
        "pedestrians in one step of the test recording(s), and for univ the UNIV-N subsets in "
        "both definitions: test samples at time steps with at least N predicted agents (test "
        "samples; the paper's Table II) and with at least N pedestrians present.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron data stats --split all\n"
        "  grouptron data stats --split univ --univ-n 30,40,50 --format json",
    )
    stats.add_argument("--split", default="all", help=f"one of {', '.join(SPLITS)} or all")
    stats.add_argument(
        "--univ-n",
        default=",".join(str(n) for n in UNIV_N_PAPER),
        help="comma-separated N for the UNIV-N counts",
    )
    stats.add_argument("--format", choices=("table", "json"), default="table")
    _add_data_options(stats)
    stats.set_defaults(handler=cmd_data_stats)

    evaluate = commands.add_parser(
        "evaluate",
        help="score a model on the test sets (ADE/FDE in metres)",
        description="Score a trained checkpoint or the constant-velocity baseline on the test "
        "samples of one or all splits (exactly 8 observed and 12 future steps). Modes: 'ml' "
        "(the mode of the latent mixture at every step, the papers' 'most likely'), "
        "'ml-argmax' (the most probable latent value's mean), 'best-of-20' (min ADE and min "
        "FDE over 20 samples, taken independently) and 'nll' (KDE NLL of 2000 samples). "
        "With --split all the unweighted mean over the five splits is added.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron evaluate --model constant-velocity --split all\n"
        "  grouptron evaluate --checkpoint runs/trajectron++-eth-central/best.safetensors\n"
        "  grouptron evaluate --checkpoint CKPT --split univ --subset univ-45 --mode all "
        "--format json",
    )
    evaluate.add_argument("--checkpoint", help="a .safetensors checkpoint written by training")
    evaluate.add_argument(
        "--model", choices=("constant-velocity",), help="score a baseline instead of a checkpoint"
    )
    evaluate.add_argument(
        "--split",
        help=f"one of {', '.join(SPLITS)} or all (default: the checkpoint's split, or all)",
    )
    evaluate.add_argument(
        "--subset",
        help="univ-N: only univ test samples at time steps with >= N predicted agents (the "
        "paper's Table II); univ-N-present: at time steps with >= N pedestrians present",
    )
    evaluate.add_argument(
        "--mode", default="ml", help=f"comma-separated of {', '.join(MODES)}, or all"
    )
    evaluate.add_argument("--seed", type=int, default=0, help="seed of the sampling modes")
    evaluate.add_argument("--format", choices=("table", "json"), default="table")
    evaluate.add_argument("--quiet", action="store_true", help="no progress bars")
    _add_data_options(evaluate)
    evaluate.set_defaults(handler=cmd_evaluate)

    report = commands.add_parser(
        "report",
        help="regenerate the paper's tables from a folder of checkpoints",
        description="Evaluate every <model>-<split>-<protocol>/best.safetensors in --checkpoints "
        "on its test set (and univ ones on UNIV-40/45/50), with constant velocity alongside, "
        "and write the Grouptron paper's Tables I and II with our numbers beside the published "
        "ones, the difference in percent, best-of-20, KDE NLL and the reproduction targets.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron report --mode ml                      # Tables I and II only (minutes)\n"
        "  grouptron report --out RESULTS.md --nll-max-samples 500\n"
        "  grouptron report --protocol central --format json --out results.json",
    )
    report.add_argument(
        "--checkpoints", default=REPORT_CHECKPOINTS, help="folder of checkpoint folders"
    )
    report.add_argument("--protocol", choices=(*PROTOCOLS, "both"), default="both")
    report.add_argument(
        "--mode",
        default="ml,best-of-20,nll",
        help=f"comma-separated of {', '.join(MODES)}, or all",
    )
    report.add_argument(
        "--nll-max-samples",
        type=_non_negative_int,
        default=0,
        help="KDE NLL on at most this many seeded random test samples per split (0: all; "
        "the NLL decodes 2000 futures per sample and dominates the run time)",
    )
    report.add_argument("--out", help="write the report here (default: standard output)")
    report.add_argument("--format", choices=("markdown", "json"), default="markdown")
    report.add_argument("--seed", type=int, default=0, help="seed of the sampling modes")
    report.add_argument("--threads", type=_positive_int, default=2, help="CPU threads")
    report.add_argument("--quiet", action="store_true", help="no progress output")
    _add_data_options(report, derivatives=False)
    report.set_defaults(handler=cmd_report)

    predict = commands.add_parser(
        "predict",
        help="forecast every pedestrian of a track file with a trained checkpoint",
        description="For every pedestrian and frame with 8 observed steps (the last at that "
        "frame), write the 12 predicted positions as CSV rows 'frame,id,step,x,y': frame is "
        "the last observed frame, step k (1..12) the position k steps (k * frames-per-step "
        "frames) later, x/y in the file's coordinates. --mode samples adds a 'sample' column "
        "and writes --samples futures per pedestrian and frame. The most likely (ml) output "
        "equals what `grouptron evaluate --mode ml` scores.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron predict --checkpoint checkpoints/grouptron-eth-central/best.safetensors \\\n"
        "      --tracks biwi_eth.txt --out forecast.csv\n"
        "  grouptron predict --checkpoint CKPT --tracks tracks.txt --out s.csv --mode samples",
    )
    predict.add_argument(
        "--checkpoint",
        required=True,
        help="a .safetensors checkpoint or a shipped name (grouptron-univ-backward)",
    )
    predict.add_argument("--tracks", required=True, help="a 'frame id x y' track file")
    predict.add_argument("--out", required=True, help="CSV file to write")
    predict.add_argument("--mode", choices=FORECAST_MODES, default="ml")
    predict.add_argument(
        "--samples", type=_positive_int, default=20, help="futures per pedestrian (samples)"
    )
    predict.add_argument("--seed", type=int, default=0, help="seed of --mode samples")
    predict.add_argument(
        "--frames-per-step",
        type=_positive_int,
        help="frames between steps 0.4 s apart (default: the checkpoint's, 10 for ETH/UCY)",
    )
    _add_gap_option(predict)
    predict.add_argument("--threads", type=_positive_int, default=2, help="CPU threads")
    predict.add_argument("--quiet", action="store_true", help="no progress bar")
    predict.set_defaults(handler=cmd_predict)

    plot = commands.add_parser(
        "plot",
        help="draw a checkpoint's forecasts at one frame of a track file",
        description="Draw, at one frame, every pedestrian with 8 observed steps: the observed "
        "path, the recorded future (dotted), the most likely forecast (dashed) and sampled "
        "futures (thin), coloured by detected group; axes in metres. --compare adds a second "
        "model's panel beside the first.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron plot --checkpoint checkpoints/grouptron-univ-central/best.safetensors \\\n"
        "      --tracks students003.txt --frame 3000 --out forecast.png\n"
        "  grouptron plot --checkpoint A --compare B --tracks FILE --frame F --out ab.png\n"
        "  grouptron plot --checkpoint A --tracks FILE --frame 3000 --until 3400 --out a.gif",
    )
    plot.add_argument(
        "--checkpoint",
        required=True,
        help="a .safetensors checkpoint or a shipped name (grouptron-univ-backward)",
    )
    plot.add_argument("--compare", help="a second checkpoint drawn beside the first")
    plot.add_argument("--tracks", required=True, help="a 'frame id x y' track file")
    plot.add_argument("--frame", type=int, required=True, help="the frame to forecast from")
    plot.add_argument(
        "--until",
        type=int,
        help="animate every step from --frame to this frame (the --out file is then a .gif, "
        "or a .mp4 when ffmpeg is installed; 2.5 pictures per second = real time)",
    )
    plot.add_argument("--out", required=True, help="PNG file to write (.gif/.mp4 with --until)")
    plot.add_argument("--samples", type=_non_negative_int, default=20, help="sampled futures")
    plot.add_argument("--seed", type=int, default=0, help="seed of the samples")
    plot.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_gap_option(plot)
    plot.set_defaults(handler=cmd_plot)

    train_cmd = commands.add_parser(
        "train",
        help="train a model on one split",
        description="Train a model on the training part of a split, validating on its "
        "validation part after every epoch. The output folder gets last.safetensors (full "
        "state; --resume continues from it exactly), best.safetensors (weights with the best "
        "validation ML FDE) and metrics.jsonl/metrics.csv.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron train --split eth --model trajectron++ --epochs 10\n"
        "  grouptron train --split univ --derivatives backward --out runs/univ-causal\n"
        "  grouptron train --split eth --resume\n"
        "  grouptron train --split eth --derivatives backward --epochs 3 \\\n"
        "      --init-from runs/trajectron++-eth-central/last.safetensors",
    )
    train_cmd.add_argument("--split", required=True, choices=SPLITS)
    train_cmd.add_argument("--model", default="trajectron++", choices=MODEL_NAMES)
    train_cmd.add_argument("--epochs", type=int, help="epochs (default 100, as the reference)")
    train_cmd.add_argument("--out", help="output folder (default runs/MODEL-SPLIT-DERIVATIVES)")
    train_cmd.add_argument(
        "--resume",
        action="store_true",
        help="continue the run in --out with its stored configuration (--epochs may extend it)",
    )
    train_cmd.add_argument(
        "--init-from",
        help="warm start from another run's last.safetensors (same model): its weights, "
        "optimiser state and step count, e.g. to move a central run to backward derivatives",
    )
    train_cmd.add_argument("--config", help="JSON file with an ExperimentConfig")
    train_cmd.add_argument("--seed", type=int)
    train_cmd.add_argument("--batch-size", type=int)
    train_cmd.add_argument("--lr", type=float, help="initial learning rate")
    train_cmd.add_argument("--threads", type=int, help="CPU threads (default 2)")
    train_cmd.add_argument(
        "--precision",
        choices=PRECISIONS,
        help="arithmetic of the decoder: bf16 autocast or fp32; auto (the default) picks bf16 "
        "where the hardware has it natively (CUDA, or a CPU with AVX-512 BF16 or AMX) and fp32 "
        "elsewhere, where bf16 is emulated and slow. Without this option a --config file's "
        "train.bf16 holds, and --resume keeps the run's precision",
    )
    train_cmd.add_argument("--quiet", action="store_true", help="no progress bars")
    train_cmd.add_argument(
        "--device", type=_device, default="cpu", help="torch device, e.g. cpu or cuda"
    )
    _add_data_options(train_cmd)
    train_cmd.set_defaults(handler=cmd_train)
    groups = commands.add_parser(
        "groups",
        help="detect pedestrian groups and score them against human labels",
        description="Group detection as the Grouptron paper does it: agglomerative clustering "
        "of trajectories (last 8 steps) on Hausdorff distances into C(N) = (N + 1) // 2 "
        "groups for N pedestrians.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron groups detect --tracks biwi_eth.txt --out groups.csv --plot groups.png\n"
        "  grouptron groups evaluate --tracks biwi_eth.txt --labels eth/groups.txt",
    )
    group_commands = groups.add_subparsers(
        dest="groups_command", metavar="ACTION", parser_class=_Parser
    )

    def track_options(parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--tracks", required=True, help="a 'frame id x y' track file")
        parser.add_argument(
            "--frames-per-step",
            type=_positive_int,
            default=10,
            help="frames between annotated steps",
        )
        _add_gap_option(parser)

    detect = group_commands.add_parser(
        "detect",
        help="group ids of every pedestrian at every step",
        description="Cluster the pedestrians present at every step of a track file into "
        "groups and write 'frame,id,group' rows (CSV); optionally plot one step.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron groups detect --tracks students003.txt --out groups.csv\n"
        "  grouptron groups detect --tracks biwi_eth.txt --plot eth.png --frame 5000",
    )
    track_options(detect)
    detect.add_argument("--out", help="CSV file (default: print to standard output)")
    detect.add_argument("--plot", help="PNG of one step's groups")
    detect.add_argument("--frame", type=int, help="frame to plot (default: the most crowded)")
    detect.add_argument("--linkage", choices=LINKAGES, default=GroupConfig().linkage)
    detect.add_argument("--distance", choices=DISTANCE_KINDS, default=GroupConfig().distance)
    detect.set_defaults(handler=cmd_groups_detect)

    score = group_commands.add_parser(
        "evaluate",
        help="score detected groups against whole-track human labels",
        description="At every step with two or more pedestrians, compare the detected groups "
        "with human labels (one group per line of ids; overlapping lines merged; anyone "
        "unlisted walks alone): precision, recall and F1 of the pairwise 'same group' "
        "decisions, and the paper's Dice score of identical groups. Protocol 'scene' "
        "clusters everyone present; 'per_ego' clusters each pedestrian with those within "
        "3 m, as the model does, and scores the ego's pairs.",
        formatter_class=_Formatter,
        epilog="examples:\n"
        "  grouptron groups evaluate --tracks biwi_eth.txt --labels eth/groups.txt\n"
        "  grouptron groups evaluate --tracks crowds_zara01.txt --labels zara1/groups.txt "
        "--linkage all --distance all --format json",
    )
    track_options(score)
    score.add_argument("--labels", required=True, help="group label file")
    score.add_argument("--id-map", help="CSV 'track_id,label_id' when the ids differ")
    score.add_argument("--linkage", choices=(*LINKAGES, "all"), default=GroupConfig().linkage)
    score.add_argument(
        "--distance", choices=(*DISTANCE_KINDS, "all"), default=GroupConfig().distance
    )
    score.add_argument("--every", type=_positive_int, default=1, help="score every k-th step")
    score.add_argument("--format", choices=("table", "json"), default="table")
    score.set_defaults(handler=cmd_groups_evaluate)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``grouptron`` console script; returns the exit code."""
    logging.basicConfig(format="grouptron: %(levelname)s: %(message)s", level=logging.WARNING)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.verbose:
            logging.getLogger().setLevel(logging.INFO)
        handler: Callable[[argparse.Namespace], int] | None = getattr(args, "handler", None)
        if handler is None:
            # A command group without an action: show its help.
            target = {"data": "data", "groups": "groups"}.get(args.command or "")
            if target:
                parser.parse_args([target, "--help"])
            parser.print_help()
            return EXIT_USAGE
        return handler(args)
    except GrouptronError as exc:
        print(f"grouptron: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:  # unwritable output, full disk, a folder given as a file, ...
        print(f"grouptron: error: {exc.strerror or exc}: {exc.filename or ''}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("grouptron: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
