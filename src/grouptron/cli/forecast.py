"""``grouptron predict`` and ``grouptron plot``: forecasts of a track file, as CSV or pictures."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from grouptron.cli.common import (
    read_bag_tracks,
    read_track_table,
    show_progress,
    warn_look_ahead,
)
from grouptron.data.ndjson import write_forecast_ndjson
from grouptron.data.reader import TrackTable
from grouptron.data.ros_bag import BagTracks
from grouptron.data.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.evaluation.calibration import calibration_for
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.inference.forecast import Forecast
from grouptron.inference.predictor import Predictor
from grouptron.inference.tracks import forecast_scene
from grouptron.io import (
    refuse_folder,
    write_array_csv_atomically,
)
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.predict import default_point_forecast
from grouptron.presets import describe_group_rule
from grouptron.viz.files import check_picture_path
from grouptron.viz.forecasts import Panel, animate_forecasts, plot_forecasts, tracks_around
from grouptron.viz.foxglove import TOPIC, write_forecast_mcap


def _write_trajnet(path: Path, forecast: Forecast, table: TrackTable, *, sampled: bool) -> None:
    """Forecasts as TrajNet++ predictions, each scene with the pedestrian's observed rows."""
    rows = zip(table.ped_id.tolist(), table.frame.tolist(), table.pos_m, strict=True)
    position = {(p, f): xy for p, f, xy in rows}
    step = table.frames_per_step
    history = []
    for p, f in zip(forecast.ids.tolist(), forecast.frames.tolist(), strict=True):
        keys = [(int(p), int(f) - k * step) for k in range(7, -1, -1)]
        history.append(np.asarray([position[key] for key in keys if key in position]))
    positions = forecast.samples if sampled else forecast.most_likely[:, None]
    assert positions is not None
    write_forecast_ndjson(
        path, forecast.frames, forecast.ids, positions, history, frames_per_step=step
    )


def cmd_predict(args: argparse.Namespace) -> int:
    """``grouptron predict``: forecast every pedestrian of a track file and write the
    positions as CSV (or ``.ndjson``) rows to a file or standard output."""
    to_stdout = args.out == "-"
    if not to_stdout:
        refuse_folder(Path(args.out), inputs=(args.tracks,))  # before the work, not after it
    path = resolve_checkpoint(args.checkpoint)
    model, experiment = load_trained_model(path)
    warn_look_ahead(args.checkpoint, experiment.data.derivatives)
    torch.set_num_threads(args.threads)
    bag = read_bag_tracks(args) if Path(args.tracks).suffix == ".mcap" else None
    table = (
        bag[0]
        if bag
        else read_track_table(args, args.frames_per_step or experiment.data.frames_per_step)
    )
    frames_per_step = table.frames_per_step
    data = dataclasses.replace(experiment.data, frames_per_step=frames_per_step)
    experiment = dataclasses.replace(experiment, data=data)
    scene = build_scene(table, data, name=str(args.tracks))
    mode = args.mode or default_point_forecast(experiment.model)
    if (args.regions or args.calibration) and (mode == "samples" or args.out.endswith(".ndjson")):
        raise GrouptronError(
            "--regions and --calibration go with a point forecast (--mode) written as CSV or MCAP"
        )
    calibrated = calibration_for(args.calibration, experiment, mode, str(path))  # before work
    forecast = forecast_scene(
        model,
        experiment,
        scene,
        mode,
        num_samples=args.samples,
        seed=args.seed,
        progress=show_progress(args),
        min_points=args.min_points,
        device=args.device,
        keep_distribution=bool(args.regions),
    )
    forecast = dataclasses.replace(forecast, calibration=calibrated)
    if Path(args.out).suffix == ".mcap":
        count = _write_mcap(args, forecast, table, None if bag is None else bag[1], data.dt_s)
        print(
            f"wrote {count} scene updates ({len(forecast)} forecasts) to {args.out}, topic {TOPIC}"
        )
        return 0
    count = _write_rows(args, forecast, table, mode, data.horizon_steps)
    # The summary goes to standard error when the forecasts go to standard output.
    print(
        f"wrote {count} rows for {len(forecast)} (pedestrian, frame) pairs "
        f"({experiment.model_name}, {data.derivatives} derivatives, {mode}) to "
        f"{'standard output' if to_stdout else args.out}",
        file=sys.stderr if to_stdout else sys.stdout,
    )
    return 0


def _write_rows(
    args: argparse.Namespace, forecast: Forecast, table: TrackTable, mode: str, horizon: int
) -> int:
    """Write the forecasts as TrajNet++ ``.ndjson`` or CSV rows (``-``: standard output);
    returns how many rows."""
    sampled = mode == "samples"
    if Path(args.out).suffix == ".ndjson":
        _write_trajnet(Path(args.out), forecast, table, sampled=sampled)
        return len(forecast) * horizon * (args.samples if sampled else 1)
    header, rows, formats = forecast.table(sampled, args.regions, table.times)
    if args.out == "-":
        sys.stdout.write(",".join(header) + "\n")
        np.savetxt(sys.stdout, rows, fmt=list(formats), delimiter=",")
    else:
        write_array_csv_atomically(Path(args.out), header, rows, formats)
    return len(rows)


def _write_mcap(
    args: argparse.Namespace,
    forecast: Forecast,
    table: TrackTable,
    bag: BagTracks | None,
    dt_s: float,
) -> int:
    """Foxglove scene updates of ``forecast`` on the input's clock (a bag's stamps) and in its
    frame (``map`` for a file)."""
    # A person's pieces never overlap in time: (frame, id) names one row of the table.
    _, person = np.unique(np.concatenate([table.ped_id, forecast.ids]), return_inverse=True)
    people = int(person.max()) + 1
    row_key = table.frame.astype(np.int64) * people + person[: len(table.ped_id)]
    wanted = forecast.frames.astype(np.int64) * people + person[len(table.ped_id) :]
    order = np.argsort(row_key)
    origins = table.pos_m[order[np.searchsorted(row_key[order], wanted)]]

    def time_of_frame(frame: int) -> float:
        return float(table.times.seconds(np.array([frame]))[0])

    names = (lambda i: f"{i:g}") if bag is None else bag.name
    return write_forecast_mcap(
        Path(args.out),
        forecast,
        origins,
        time_of_frame,
        bag.frame_id if bag is not None and bag.frame_id else "map",
        dt_s,
        names,
        args.regions[0] if args.regions else None,
    )


# --- plot -------------------------------------------------------------------------------------


def cmd_plot(args: argparse.Namespace) -> int:
    """``grouptron plot``: draw forecasts at a frame, or with ``--until`` an animation."""
    out = Path(args.out)
    if args.until is not None and args.frame is not None and args.until <= args.frame:
        raise GrouptronError(f"--until {args.until} must come after --frame {args.frame}")
    check_picture_path(
        out, animation=args.until is not None, inputs=(args.tracks,)
    )  # before the work, not after it
    torch.set_num_threads(args.threads)
    predictors = _plot_predictors(args)
    for predictor in predictors:
        warn_look_ahead(predictor.source, predictor.config.data.derivatives)
    table = read_track_table(args, predictors[0].config.data.frames_per_step)
    _to_table_frames(args, table)
    if args.frame is None:  # the busiest frame (the middle one of equals): a telling picture
        frames, people = np.unique(table.frame, return_counts=True)
        busiest = frames[people == people.max()]
        args.frame = int(busiest[len(busiest) // 2])
        if args.until is not None and args.until <= args.frame:
            raise GrouptronError(f"--until {args.until} must come after --frame {args.frame}")
    _check_plot_frame(args, table)
    for predictor in predictors:  # forecast on the file's own frame grid
        data = dataclasses.replace(predictor.config.data, frames_per_step=table.frames_per_step)
        predictor.config = dataclasses.replace(predictor.config, data=data)
    data = predictors[0].config.data
    rows = table_rows(table)
    if args.until is None:
        plot_forecasts(_plot_panels(args, predictors, rows, args.frame), args.frame, out)
        print(f"wrote {out}: forecasts at {_file_time(table, args.frame)}")
        return 0
    step = data.frames_per_step
    wanted = range(args.frame, args.until + 1, step)
    # Every frame reads only its own window: cut a long file to the frames drawn once, not
    # once per frame (central derivatives read two steps past the horizon's start).
    first = args.frame - max(p.window_frames for p in predictors)
    last = args.until + (data.horizon_steps + 2) * step
    rows = rows[(rows[:, 0] >= first) & (rows[:, 0] <= last)]
    present = set(rows[:, 0].astype(np.int64).tolist())
    drawn = [
        (frame, _plot_panels(args, predictors, rows, frame, required=False))
        for frame in tqdm(wanted, desc="forecasting", unit="frame", disable=not show_progress(args))
        if frame in present
    ]
    drawn = [(frame, panels) for frame, panels in drawn if panels]
    if not drawn:
        raise GrouptronError(
            f"{args.tracks}: nobody between frames {args.frame} and {args.until} has "
            f"{predictors[0].min_points} observed steps"
        )
    animate_forecasts(drawn, out)
    print(f"wrote {out}: {len(drawn)} frames from {drawn[0][0]} to {drawn[-1][0]}")
    return 0


def _plot_predictors(args: argparse.Namespace) -> list[Predictor]:
    """The predictor of ``--checkpoint`` (with ``--calibration``) and of ``--compare``."""
    return [
        Predictor.from_checkpoint(
            c,
            most_likely=args.forecast,
            device=args.device,
            check_speed=not args.no_speed_check,  # the file was checked as it was read
            calibration=args.calibration if c == args.checkpoint else None,
        )
        for c in (args.checkpoint, args.compare)
        if c
    ]


def table_rows(table: TrackTable) -> np.ndarray:
    """(R, 4) ``frame, id, x, y`` of a table, each person's earlier tracks (split at a gap or
    a jump) under fresh ids, so that a predictor does not join them up again."""
    last_track = np.zeros(table.num_tracks, dtype=bool)
    ends = np.flatnonzero(np.append(table.ped_id[1:] != table.ped_id[:-1], True))
    last_track[table.track[ends]] = True  # rows are sorted by id, then step
    ids = table.ped_id.astype(np.float64)
    fresh = float(ids.max()) + 1 + table.track
    ids = np.where(last_track[table.track], ids, fresh)
    return np.column_stack([table.frame, ids, table.pos_m]).astype(np.float64)


def _to_table_frames(args: argparse.Namespace, table: TrackTable) -> None:
    """``--time`` (the file's seconds) and ``--frame``/``--until`` (the file's own frame
    numbers, as ``predict`` writes them) as the table's frames (in place)."""
    times = table.times
    if args.time is not None:
        if args.frame is not None or args.until is not None:
            raise GrouptronError("--time picks the frame: give --time or --frame (and --until)")
        args.frame = times.table_frame(args.time)
    elif times.file_fps is not None:  # a file in seconds has no frames: its --frame are steps
        for name in ("frame", "until"):
            if getattr(args, name) is not None:
                setattr(args, name, times.table_frame(getattr(args, name) / times.file_fps))


def _file_time(table: TrackTable, frame: int) -> str:
    """``frame F (t = T s)`` in the file's own terms, for messages."""
    own = table.times.file_frames(np.array([frame]))
    seconds = float(table.times.seconds(np.array([frame]))[0])
    return f"frame {frame if own is None else int(own[0])} (t = {seconds:.2f} s)"


def _check_plot_frame(args: argparse.Namespace, table: TrackTable) -> None:
    """Refuse a ``--frame`` off the file's frame grid or outside its frames."""
    if (args.frame - table.first_frame) % table.frames_per_step:
        raise GrouptronError(
            f"--frame {args.frame} is not on the {table.frames_per_step}-frame grid of "
            f"{args.tracks} (first frame {table.first_frame})"
        )
    last_frame = int(table.frame.max())
    if not table.first_frame <= args.frame <= last_frame:
        raise GrouptronError(
            f"--frame {args.frame} is outside the frames of {args.tracks} "
            f"({table.first_frame}-{last_frame})"
        )


def _plot_panels(
    args: argparse.Namespace,
    predictors: list[Predictor],
    rows: np.ndarray,
    frame: int,
    *,
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
                f"{args.tracks}: nobody at frame {frame} has {predictor.min_points} observed "
                "steps in a row; pick another --frame"
            )
        history, truth = tracks_around(
            rows,
            forecast.ids,
            frame,
            data.frames_per_step,
            before=data.history_steps - 1,
            after=data.horizon_steps,
        )
        name = f"{predictor.config.model_name} ({predictor.config.data.derivatives})"
        label = {
            "ml": "most likely",
            "ml-argmax": "argmax latent",
            "ml-top10": "most likely of top 10",
        }.get(args.forecast or default_point_forecast(predictor.config.model), "mean")
        rule = describe_group_rule(predictor.group_rule)
        panels.append(Panel(name, forecast, history, truth, label, rule, args.region, args.ids))
    return panels


# One flat list of options so that `--help` reads in the order a user needs them.
