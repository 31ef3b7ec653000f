"""Latency of live forecasting: one ``stream().update`` (groups + most likely) per frame.

Usage:
    python benchmarks/streaming.py [--checkpoint NAME_OR_PATH] [--people 10,50,100,200]
                                   [--frames 60] [--threads N] [--stress torch|N]
                                   [--forecast ml|ml-argmax|mean|ml-top10|ml-topK]
                                   [--mixture] [--min-points 2] [--max-missed-steps 2]
                                   [--regions Q] [--calibration FILE|none] [--profile]
                                   [--replay FILE] [--learn] [--learn-frames 1500]

A synthetic scene of N pedestrians walking in pairs and alone through a square sized for about
one person per 4 m^2 is streamed frame by frame; the first 9 frames (before anyone has 8 steps)
are not timed. By default the default model with its own point forecast (what
``Predictor.from_checkpoint()`` gives), and beside it, fed the same frames in turn, the same
checkpoint's argmax latent: the ratio of the two medians is the figure that holds across
machines. ``--replay FILE`` also times the real crowd around the most crowded frame of an
ETH/UCY-layout file (the densest Grand Central file has 279 people). With ``--regions Q``,
the same default predictor also runs with its Q-regions drawn at every update (from its
shipped or ``--calibration`` radii) and with online calibration (``stream(
online_calibration=True)``: each update also scores the forecasts whose truths arrived and
moves the radii), each beside the forecast alone in the same run. Prints the
median and 90th percentile of the update time per N
(``--most-likely``, the older name of ``--forecast``, and ``--latent-values K``, of
``--forecast ml-topK``, still work). ``--learn`` then times,
at each N, the default predictor's session without learning and then with it
(``stream(learn=True)``, rounds every 10 s of stream time in the session's learning process,
so that several run while it is timed): ``--learn-frames`` updates each, back to back (the
worst case: a tracker at 2.5 Hz leaves the round 390 ms of every 400 ms), the medians and the
ratio, and the median of the updates made while a round was running. ``--stress torch``
(another PyTorch process multiplying matrices beside it) or ``--stress N`` (N busy processes)
times every N twice in the same run, quiet and then beside those processes
(``benchmarks/stress.py``), and prints the ratio of the default predictor's medians: what a
shared CPU does to it. ``--profile``
then prints, per N, where the default predictor's time goes: ``cProfile`` around its updates
(frames 10 on), the cumulative time per update of the parts in :data:`PROFILED`.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import time
from pathlib import Path

import numpy as np
from stress import stress_kind, stressed  # benchmarks/ is on sys.path

from grouptron import Predictor
from grouptron.cli.options import calibration_option, point_forecast_option
from grouptron.constants import DEFAULT_CHECKPOINT
from grouptron.inference.learning import LearningOptions
from grouptron.point_forecast import PointForecast


def synthetic_frames(
    people: int, frames: int, seed: int = 0
) -> list[tuple[np.ndarray, np.ndarray]]:
    """(ids, (N, 2) positions) per frame; pairs share a heading and walk side by side."""
    rng = np.random.default_rng(seed)
    side = 2.0 * np.sqrt(people)
    start = rng.uniform(0, side, (people, 2))
    heading = rng.uniform(0, 2 * np.pi, people)
    heading[1::2] = heading[::2][: people // 2]  # partners walk alike
    start[1::2] = start[::2][: people // 2] + 0.6
    velocity = 1.2 * np.stack([np.cos(heading), np.sin(heading)], 1)
    out = []
    for k in range(frames):
        wobble = rng.normal(0, 0.02, (people, 2))
        out.append((np.arange(people), start + velocity * 0.4 * k + wobble))
    return out


def add_predictor_options(parser: argparse.ArgumentParser, forecast: str | None) -> None:
    """The options that pick and configure the predictor (shared with ``soak.py``)."""
    parser.add_argument("--checkpoint", default=DEFAULT_CHECKPOINT)
    parser.add_argument(
        "--threads",
        type=int,
        help="Predictor(threads=...): PyTorch threads of its forecasts (default: the "
        "Predictor's own, LIVE_THREADS)",
    )
    parser.add_argument(
        "--forecast",
        "--most-likely",
        dest="forecast",
        type=point_forecast_option,
        default=None if forecast is None else PointForecast.parse(forecast),
        help="the Predictor's point forecast (default: the model's own; ml-argmax skips the "
        "mixture; mean decodes all Z latent values, ml-top10 (ml-topK) the 10 (K) most "
        "probable; --most-likely: its older name)",
    )
    parser.add_argument(
        "--latent-values",
        type=int,
        help="K: the older way to ask for --forecast ml-topK (with --forecast ml or none)",
    )
    parser.add_argument("--mixture", action="store_true", help="also return the mixture")
    parser.add_argument("--min-points", type=int, default=2, help="Predictor(min_points=...)")
    parser.add_argument(
        "--max-missed-steps", type=int, default=2, help="Predictor(max_missed_steps=...)"
    )
    parser.add_argument(
        "--calibration",
        type=calibration_option,
        help="Predictor(calibration=...): a grouptron calibrate file, or none (default: the "
        "checkpoint's shipped one)",
    )


def chosen_forecast(args: argparse.Namespace) -> PointForecast | None:
    """The point forecast the options name (None: the model's own)."""
    if not args.latent_values:
        return args.forecast
    if args.forecast not in (None, PointForecast("ml")):
        raise SystemExit(f"--latent-values goes with --forecast ml, not {args.forecast}")
    return PointForecast("ml", args.latent_values)  # ml of the K most probable: ml-topK


def load_predictor(args: argparse.Namespace, forecast: str | None = None) -> Predictor:
    """The predictor the options describe, or (``forecast``) a yardstick of the same
    checkpoint with that point forecast and no calibration."""
    threads = {} if args.threads is None else {"threads": args.threads}
    return Predictor.from_checkpoint(
        args.checkpoint,
        **threads,
        forecast=forecast or chosen_forecast(args),
        mixture=args.mixture,
        min_points=args.min_points,
        max_missed_steps=args.max_missed_steps,
        calibration=False if forecast else args.calibration,  # the yardstick has none
    )


Variant = tuple[Predictor, bool, float | None]
"""A timed session: its predictor, whether its radii adapt online, the q of the regions drawn
with every update (None: none)."""


def recorded_frames(path: Path, frames: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(ids, (N, 2) positions) of the ``frames`` consecutive frames of an ETH/UCY-layout file
    (``frame id x y``, 10 frames per 0.4 s step) around its most crowded one, renumbered
    10 apart from 0."""
    rows = np.loadtxt(path)
    steps, counts = np.unique(rows[:, 0], return_counts=True)
    busiest = int(np.argmax(counts))
    first = max(0, min(busiest - frames // 2, len(steps) - frames))
    chosen = steps[first : first + frames]
    return [(rows[rows[:, 0] == f, 1], rows[rows[:, 0] == f, 2:4]) for f in chosen]


def timed_updates(
    variants: list[Variant],
    people: int,
    frames: int,
    recorded: list[tuple[np.ndarray, np.ndarray]] | None = None,
) -> tuple[list[list[float]], list[int]]:
    """Per variant, the update times (ms, its regions included) after the first 9 frames and
    its last forecast count; the variants take each frame in turn, so a drift of the machine
    hits all alike."""
    sessions = [p.stream(online_calibration=online) for p, online, _ in variants]
    times: list[list[float]] = [[] for _ in variants]
    counts = [0] * len(variants)
    for k, (ids, xy) in enumerate(recorded or synthetic_frames(people, frames)):
        for i, session in enumerate(sessions):
            started = time.perf_counter()
            forecast = session.update(10 * k, ids, xy)
            region_q = variants[i][2]
            if region_q is not None:  # drawn with the update, as a planner would ask
                forecast.regions(region_q)
            if k >= 9:
                times[i].append(1000 * (time.perf_counter() - started))
                counts[i] = len(forecast)
    return times, counts


def timing_line(label: str, times: list[list[float]], forecasts: int, yardstick: bool) -> str:
    """A row of the table: median / p90 ms of every variant, and the ratio of the first's
    median to the yardstick's (the last variant) where there is one."""
    medians = [statistics.median(t) for t in times]
    p90s = [float(np.percentile(t, 90)) for t in times]
    line = f"{label:>7} {forecasts:>10}"
    line += "".join(f" {f'{m:.1f} / {p:.1f}':>22}" for m, p in zip(medians, p90s, strict=True))
    return line + (f" {medians[0] / medians[-1]:>6.2f}" if yardstick else "")


PROFILED = (
    ("encoders", "model/predict.py", "encode_prior"),
    ("of which the scene encoder", "model/grouptron.py", "encode_scene"),
    ("decoder", "model/cvae.py", "decode"),
    ("of which its steps", "model/cvae.py", "_decode_means"),
    ("mixture mode", "model/mixture_mode.py", "mixture_mode"),
    ("groups at the step", "groups/scene.py", "groups_at_step"),
    ("samples and edges", "prepare/samples.py", "scene_samples"),
    ("whole update", "inference/stream.py", "update"),
)
"""The parts of an update the profile reports: (label, the end of its file's path, function
name). Parts may hold others, as their labels say."""


def profile_update(predictor: Predictor, people: int, frames: int) -> dict[str, float]:
    """ms per update spent in each of :data:`PROFILED` (cumulative, cProfile's own overhead
    included, so the parts are comparable with each other rather than with the timings)."""
    session = predictor.stream()
    profiler = cProfile.Profile()
    timed = 0
    for k, (ids, xy) in enumerate(synthetic_frames(people, frames)):
        if k >= 9:
            profiler.enable()
            timed += 1
        session.update(10 * k, ids, xy)
        profiler.disable()
    stats = pstats.Stats(profiler).stats  # type: ignore[attr-defined]
    spent: dict[str, float] = {}
    for label, module, function in PROFILED:
        seconds = sum(
            v[3]
            for (path, _, name), v in stats.items()
            if name == function and path.endswith(module) and "grouptron" in path
        )
        spent[label] = 1000 * seconds / max(timed, 1)
    return spent


def learning_line(predictor: Predictor, people: int, frames: int) -> str:
    """Median ms per update without learning, then with it (rounds every 10 s of stream
    time in the background), their ratio, and the median while a round was running."""
    frames_seen = synthetic_frames(people, frames)
    times: dict[str, list[float]] = {"off": [], "on": [], "during a round": []}
    rounds = LearningOptions(round_s=10.0)
    for learn in (False, True):
        session = predictor.stream(learn=rounds if learn else False)
        for k, (ids, xy) in enumerate(frames_seen):
            busy = session.learner is not None and session.learner.busy
            started = time.perf_counter()
            session.update(10 * k, ids, xy)
            if k >= 9:
                ms = 1000 * (time.perf_counter() - started)
                times["on" if learn else "off"].append(ms)
                if busy:
                    times["during a round"].append(ms)
        if session.learner is not None:
            session.learner.wait()
            status = session.learning
    median = {k: statistics.median(v) if v else float("nan") for k, v in times.items()}
    return (
        f"learning, {people} people: median ms per update off {median['off']:.1f}, on "
        f"{median['on']:.1f} (ratio {median['on'] / median['off']:.2f}), while a round ran "
        f"{median['during a round']:.1f} ({len(times['during a round'])} updates); {status.line()}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_predictor_options(parser, forecast=None)
    parser.add_argument("--people", default="10,50,100,200")
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument(
        "--regions", type=float, help="also draw each update's Q-regions (first predictor only)"
    )
    parser.add_argument("--profile", action="store_true", help="then profile the default's parts")
    parser.add_argument(
        "--stress",
        type=stress_kind,
        help="also time each N beside busy processes: 'torch' (another PyTorch process) or a "
        "number of busy processes",
    )
    parser.add_argument(
        "--learn", action="store_true", help="then time updates with online learning on and off"
    )
    parser.add_argument("--learn-frames", type=int, default=1500, help="updates timed each way")
    parser.add_argument(
        "--replay",
        metavar="FILE",
        help="also time the frames around the most crowded one of this frame,id,x,y file "
        "(e.g. the densest Grand Central file, gc_043.txt: up to 279 people)",
    )
    args = parser.parse_args()
    predictor = load_predictor(args)
    variants: list[Variant] = [(predictor, False, None)]
    names = ["forecast"]
    if args.regions is not None:  # the cost of regions, static and online, in the same run
        variants += [(predictor, False, args.regions), (predictor, True, args.regions)]
        names += [
            f"+ {(predictor.calibration and 'calibrated') or 'own'} regions",
            "+ online regions",
        ]
    if predictor.point_forecast_name != "ml-argmax":
        variants.append((load_predictor(args, "ml-argmax"), False, None))  # the yardstick
        names.append("argmax")
    named = chosen_forecast(args)
    print(
        f"{predictor.source}: {predictor.config.model_name}, {predictor.threads} threads, "
        f"point forecast {named or 'by default'} ({predictor.point_forecast_name}, "
        f"{predictor.decoded_latent_values} latent values decoded), mixture = {predictor.mixture}"
    )
    print("median / p90 ms per update: " + "; ".join(names))
    header = f"{'people':>7} {'forecasts':>10}" + "".join(f" {n:>22}" for n in names)
    if names[-1] == "argmax":
        header += f" {'ratio':>6}"
    print(header)
    yardstick = names[-1] == "argmax"
    for people in (int(n) for n in args.people.split(",")):
        times, counts = timed_updates(variants, people, args.frames)
        print(timing_line(str(people), times, counts[0], yardstick))
        if args.stress:
            with stressed(args.stress) as beside:
                busy, _ = timed_updates(variants, people, args.frames)
            print(timing_line(str(people), busy, counts[0], yardstick) + f" ({beside})")
            ratio = statistics.median(busy[0]) / statistics.median(times[0])
            print(f"{'':>7} stressed / quiet median, {names[0]}: {ratio:.2f}")
    if args.replay:
        recorded = recorded_frames(Path(args.replay), args.frames)
        times, counts = timed_updates(variants, 0, args.frames, recorded)
        print(timing_line(Path(args.replay).name, times, counts[0], yardstick))
    if args.learn:
        for people in (int(n) for n in args.people.split(",")):
            print(learning_line(predictor, people, args.learn_frames))
    if args.profile:
        for people in (int(n) for n in args.people.split(",")):
            spent = profile_update(predictor, people, args.frames)
            parts = ", ".join(f"{label} {ms:.2f}" for label, ms in spent.items())
            print(f"profile, {people} people, ms per update: {parts}")


if __name__ == "__main__":
    main()
