"""How many climbs the mixture mode of the 10 most probable latent values needs.

Usage:
    python benchmarks/mode_starts.py [--checkpoint NAME] [--starts 1,2] [--threads 1]

For the checkpoint's ``ml-top10`` forecast on every validation file of the five splits and on
the out-of-domain development set (``$GROUPTRON_OOD``): the largest distance (mm, over all 12
steps) between the forecast climbed from ``--starts`` starts and from the benchmark's four, and
how many forecasts move by more than 1 mm; the p(z|x) weight of the most probable latent value
(10th / 50th / 90th percentile) and the smallest renormalised weight among the top 10 (whether
any latent value could be dropped). Then the mode search of one streaming update of 50 people
(benchmarks/streaming.py's scene), median ms per start count.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import torch

from grouptron import Predictor
from grouptron.data.datasets.custom import read_dataset
from grouptron.data.datasets.locate import resolve_data_dir, split_files
from grouptron.data.formats.layout import RecordingFormat
from grouptron.data.formats.track_files import TrackSource
from grouptron.evaluation.recordings import recording_samples
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.model import predict
from grouptron.model.batch import batches
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model
from grouptron.model.mixture_mode import mixture_mode
from grouptron.model.predict import decode_every_latent, most_likely_positions, top_latent_values

sys.path.insert(0, str(Path(__file__).resolve().parent))
from out_of_domain import DEVELOPMENT_SET
from streaming import synthetic_frames


def deviations(
    model, config, samples, starts: list[int]
) -> tuple[dict[int, np.ndarray], np.ndarray]:  # type: ignore[no-untyped-def]
    """Per start count, (S,) largest distance in mm from the four-start forecast; (S, 10)
    renormalised weights of the 10 most probable latent values."""
    H, dt = config.data.horizon_steps, config.data.dt_s
    out: dict[int, list[np.ndarray]] = {s: [] for s in starts}
    weights = []
    with torch.inference_mode():
        for _, batch in batches(samples, config, 512, groups_for_model(samples, config)):
            top = top_latent_values(*decode_every_latent(model.eval(), batch, H), 10)
            weights.append(torch.softmax(top[0].p_logits, -1).numpy())
            reference = most_likely_positions(*top, H, dt, predict.MODE_STARTS)
            for s in starts:
                moved = (most_likely_positions(*top, H, dt, s) - reference).norm(dim=-1)
                out[s].append(1000 * moved.amax(-1).numpy())
    return {s: np.concatenate(v) for s, v in out.items()}, np.concatenate(weights)


def search_ms(name: str, starts: list[int], people: int = 50) -> dict[int, float]:
    """Median ms of the mode search of one update (the mixtures of the last frame's forecast)."""
    captured = []

    def capture(*args, **kwargs):  # type: ignore[no-untyped-def]
        captured.append(args[:3])
        return mixture_mode(*args, **kwargs)

    predict.mixture_mode = capture  # what most_likely_positions calls
    session = Predictor.from_checkpoint(name, forecast="ml-top10").stream()
    for k, (ids, xy) in enumerate(synthetic_frames(people, 20)):
        session.update(10 * k, ids, xy)
    predict.mixture_mode = mixture_mode
    mixtures = captured[-1]
    times = {}
    for s in [*starts, predict.MODE_STARTS]:
        runs = []
        for _ in range(20):
            began = time.perf_counter()
            mixture_mode(*mixtures, num_starts=s)
            runs.append(1000 * (time.perf_counter() - began))
        times[s] = statistics.median(runs)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoint", default=DEFAULT_CHECKPOINT)
    parser.add_argument("--starts", default="1,2")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    starts = [int(s) for s in args.starts.split(",")]
    model, config = load_trained_model(resolve_checkpoint(args.checkpoint))
    parts = [(f"{split} val", split_files(resolve_data_dir(), split, "val"), RecordingFormat())
             for split in ("eth", "hotel", "univ", "zara1", "zara2")]  # fmt: skip
    for description in DEVELOPMENT_SET.split(","):
        dataset = read_dataset(description)
        parts.append((dataset.name, dataset.files("test"), dataset.recording))
    print(f"{args.checkpoint}, ml-top10: starts against four")
    print("| files | forecasts | starts | largest move mm | moved > 1 mm | top weight p10/p50/p90 "
          "| smallest top-10 weight |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for name, files, fmt in parts:
        sources = [TrackSource.from_format(f, fmt) for f in files]
        samples = recording_samples(sources, config.data)
        moved, weights = deviations(model, config, samples, starts)
        top = np.percentile(weights[:, 0], [10, 50, 90])
        for s in starts:
            largest, count = moved[s].max(), (moved[s] > 1).sum()
            spread = f"{top[0]:.2f}/{top[1]:.2f}/{top[2]:.2f}"
            print(f"| {name} | {len(samples)} | {s} | {largest:.3f} | {count} | {spread} "
                  f"| {weights.min():.3f} |", flush=True)  # fmt: skip
    times = search_ms(args.checkpoint, starts)
    print("\nmode search of one 50-person update, median ms: "
          + ", ".join(f"{s} start(s) {ms:.1f}" for s, ms in times.items()))  # fmt: skip


if __name__ == "__main__":
    main()
