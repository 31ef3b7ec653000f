"""Site adaptation: fine-tune a checkpoint on the first minutes of a site's own recordings and
score it, before and after, on a later part that it never saw.

    from grouptron.workflows.adapt import AdaptRequest, adapt
    result = adapt(AdaptRequest(files=(Path("site.txt"),), minutes=5, holdout_minutes=5))
    print(result.table())

Recordings given together are played one after the other (a site's recordings in time
order); the adaptation part is their first ``minutes``, the held-out part their last
``holdout_minutes``, and the two may not overlap. The adapted folder keeps a record of the
files and seconds it adapted on (``adaptation.json``), which ``evaluate`` checks.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.constants import CONSTANT_VELOCITY
from grouptron.data.datasets.download import file_sha256
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.data.formats.reader import TrackTable
from grouptron.data.formats.track_files import TrackSource, read_track_file
from grouptron.data.prepare.samples import SampleSet, concatenate_samples, scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.data.prepare.windows import cut_windows, step_window
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import SampleScores, constant_velocity_scores, score_samples
from grouptron.evaluation.results import EvaluationResult, results_table, score_rows
from grouptron.evaluation.uncertainty import Interval, mean_interval
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.io import write_text_atomically
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model
from grouptron.model.forecaster import Forecaster
from grouptron.model.predict import default_point_forecast
from grouptron.training.trainer import BEST, train

ADAPTATION = "adaptation.json"
"""The record, in an adapted run's folder, of the files and seconds it adapted on."""
SPLIT = "site-adaptation"


@dataclass(frozen=True)
class AdaptRequest:
    """A site adaptation.

    Attributes:
        files: the site's recordings (ROS 2 bags too), in time order.
        layout: how each is read, its ``path`` aside (default: ETH/UCY's ``frame id x y``).
        minutes: the adaptation part: the first minutes of the recordings.
        holdout_minutes: the held-out part: the last minutes, scored before and after (0:
            none, nothing is scored).
        checkpoint: the checkpoint adapted (a shipped name or a file).
        out: the adapted run's folder.
        steps: optimiser steps of the fine-tune (a fixed budget, whatever ``minutes``).
        batch_size, lr, seed, threads: of the fine-tune (fp32, a fresh optimiser).
        on_gap: what a track that misses steps does (``split`` or ``error``).
    """

    files: tuple[Path, ...]
    layout: TrackSource = field(default_factory=lambda: TrackSource(""))
    minutes: float = 5.0
    holdout_minutes: float = 0.0
    checkpoint: str = DEFAULT_CHECKPOINT
    out: str = "runs/adapted"
    steps: int = 300
    batch_size: int = 64
    lr: float = 3e-4
    seed: int = 0
    threads: int = 2
    on_gap: Literal["split", "error"] = "split"


@dataclass(frozen=True)
class AdaptResult:
    """An adapted run and, with a held-out part, its scores there.

    Attributes:
        out: the adapted run's folder (``best.safetensors``: the adapted weights).
        adapted_s: seconds of recording adapted on; samples: training samples they gave.
        rows: on the held-out part (with 95% intervals): the checkpoint before, after,
            constant velocity.
        gain: FDE after minus before on the same held-out samples (paired; metres).
    """

    out: Path
    adapted_s: float
    samples: int
    rows: list[EvaluationResult]
    gain: Interval | None

    @property
    def best(self) -> Path:
        """The adapted weights, ``<out>/best.safetensors``."""
        return self.out / BEST

    def table(self) -> str:
        """The held-out rows as a table and the paired gain, or a line without a held-out part."""
        line = f"adapted on {self.adapted_s / 60:.1f} min ({self.samples} samples) -> {self.best}"
        if self.gain is None:
            return line
        gain = f"FDE after minus before: {self.gain.mean:+.3f} m [{self.gain.low:+.3f}, "
        return f"{line}\n{results_table(self.rows)}\n{gain}{self.gain.high:+.3f}] (95%)"


def adapt(request: AdaptRequest, *, progress: bool = False) -> AdaptResult:
    """Fine-tune ``request.checkpoint`` on the adaptation part and score the held-out part."""
    source = resolve_checkpoint(request.checkpoint)
    model, experiment = load_trained_model(source)
    data = experiment.data
    layout = dataclasses.replace(request.layout, on_gap=request.on_gap)
    tables = [
        read_track_file(track, data.frames_per_step, data.dt_s)[0]
        for track in layout.files(request.files)
    ]
    steps = [int(t.step.max()) + 1 for t in tables]
    total_s = sum(steps) * data.dt_s
    if request.minutes <= 0 or request.holdout_minutes < 0:
        raise GrouptronError("the adaptation part needs minutes > 0 (and a held-out part >= 0)")
    if (request.minutes + request.holdout_minutes) * 60 > total_s + 1e-9:
        parts, verb = f"the adaptation part ({request.minutes:g} min)", "needs"
        if request.holdout_minutes:
            later = f"the held-out part ({request.holdout_minutes:g} min)"
            parts, verb = f"{parts} and {later}, which may not overlap,", "need"
        raise GrouptronError(
            f"{parts} {verb} more than the recordings hold ({total_s / 60:.2f} min)"
        )
    windows = cut_windows(steps, request.minutes * 60, request.holdout_minutes * 60, data.dt_s)
    first = [step_window(t, 0, end) for t, end in zip(tables, windows.first, strict=True)]
    last = [
        step_window(t, start, n) for t, start, n in zip(tables, windows.last, steps, strict=True)
    ]
    train_samples = _samples(
        [t for t in first if t is not None], experiment, data.min_history_train
    )
    out = Path(request.out)
    _fine_tune(experiment, source, train_samples, out, request, progress)
    _write_record(out, request, source, tables, windows.first, data.dt_s)
    adapted_s = sum(windows.first) * data.dt_s
    held = [t for t in last if t is not None]
    if request.holdout_minutes == 0 or not held:
        return AdaptResult(out, adapted_s, len(train_samples), [], None)
    adapted, _ = load_trained_model(out / BEST)
    rows, gain = _held_out(model, adapted, experiment, held, str(source), str(out / BEST))
    return AdaptResult(out, adapted_s, len(train_samples), rows, gain)


def _samples(tables: list[TrackTable], experiment: ExperimentConfig, min_history: int) -> SampleSet:
    """Samples of the windows' scenes (a full future each; ``min_history`` observed points)."""
    data = experiment.data
    scenes = [build_scene(t, data, name=f"{t.path.stem}-{i}") for i, t in enumerate(tables)]
    samples = concatenate_samples([scene_samples(s, data, min_history) for s in scenes])
    if not len(samples):
        raise GrouptronError(
            "no person in that part of the recordings has a full future of "
            f"{data.horizon_steps} steps: give more minutes"
        )
    return samples


def _fine_tune(
    experiment: ExperimentConfig,
    source: Path,
    samples: SampleSet,
    out: Path,
    request: AdaptRequest,
    progress: bool,
) -> None:
    """A fixed budget of optimiser steps from the checkpoint's weights (no validation: the
    last weights are kept)."""
    per_epoch = math.ceil(len(samples) / request.batch_size)
    epochs = max(1, math.ceil(request.steps / per_epoch))
    settings = dataclasses.replace(
        experiment.train,
        epochs=epochs,
        batch_size=request.batch_size,
        learning_rate=request.lr,
        seed=request.seed,
        threads=request.threads,
        init_from=str(source),
        bf16=False,
        epoch_samples=0,
    )
    adapted = dataclasses.replace(experiment, split=SPLIT, dataset="", train=settings)
    groups = groups_for_model(samples, adapted)
    empty = np.zeros(len(samples), dtype=bool)
    torch.set_num_threads(request.threads)
    train(
        adapted,
        samples,
        samples.subset(empty),
        out,
        progress=progress,
        train_groups=groups,
        val_groups=None if groups is None else groups.subset(empty, samples),
    )


def _write_record(
    out: Path,
    request: AdaptRequest,
    source: Path,
    tables: list[TrackTable],
    first: tuple[int, ...],
    dt_s: float,
) -> None:
    files = [
        {"file": str(t.path), "sha256": file_sha256(t.path), "adapted_until_s": end * dt_s}
        for t, end in zip(tables, first, strict=True)
        if end > 0
    ]
    record = {"checkpoint": str(source), "minutes": request.minutes, "files": files}
    write_text_atomically(out / ADAPTATION, json.dumps(record, indent=2) + "\n")


def _held_out(
    before: Forecaster,
    after: Forecaster,
    experiment: ExperimentConfig,
    tables: list[TrackTable],
    before_name: str,
    after_name: str,
) -> tuple[list[EvaluationResult], Interval]:
    """Rows before, after and of constant velocity on the held-out part, and the paired gain."""
    data = experiment.data
    samples = _samples(tables, experiment, data.history_steps)
    groups = groups_for_model(samples, experiment)
    mode = default_point_forecast(experiment).name
    scored: list[tuple[str, SampleScores]] = []
    for name, model in ((before_name, before), (after_name, after)):
        (scores,) = score_samples(model, experiment, samples, (mode,), groups=groups)
        scored.append((name, scores))
    scored.append((CONSTANT_VELOCITY, constant_velocity_scores(samples, data.horizon_steps)))
    steps = time_step_ids(samples)
    rows = []
    labels = (f"{experiment.model_name}, before", f"{experiment.model_name}, adapted", None)
    for (name, scores), label in zip(scored, labels, strict=True):
        template = EvaluationResult("held-out part", label or name, None, 0, 0.0, 0.0)
        template = dataclasses.replace(
            template, checkpoint=name if label else None, derivatives=data.derivatives
        )
        rows += score_rows(template, scores, {None: None}, steps=steps, named_mode=bool(label))
    gain = mean_interval(scored[1][1].fde - scored[0][1].fde, steps)
    return rows, gain


def adapted_parts(checkpoint: Path, files: tuple[Path, ...]) -> list[tuple[Path, float]]:
    """The given files that ``checkpoint``'s run adapted on (byte for byte), each with the
    seconds from its start that it adapted on; none for a run that was not adapted."""
    record_path = Path(checkpoint).parent / ADAPTATION
    if not record_path.is_file():
        return []
    try:
        record = json.loads(record_path.read_text())
        seen = {entry["sha256"]: float(entry["adapted_until_s"]) for entry in record["files"]}
    except (OSError, ValueError, KeyError, TypeError):
        raise GrouptronError(f"{record_path}: cannot read the adaptation record") from None
    found = [(Path(f), seen.get(file_sha256(Path(f)))) for f in files]
    return [(path, seconds) for path, seconds in found if seconds is not None]
