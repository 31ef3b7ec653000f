"""``grouptron calibrate``: conformal radii of prediction regions on a site's own recording."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import torch

from grouptron.cli.common import read_track_table, warn_look_ahead
from grouptron.data.samples import scene_samples
from grouptron.data.scene import build_scene
from grouptron.evaluation.calibration import calibrate, save_calibration, weights_digest
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.io import refuse_folder
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.predict import default_point_forecast


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Score every person of ``--tracks`` with a full history and future and write the
    conformal radii of the regions for ``--checkpoint``'s point forecast."""
    out = Path(args.out)
    refuse_folder(out, inputs=(args.tracks,))  # before the work, not after it
    path = resolve_checkpoint(args.checkpoint)
    model, experiment = load_trained_model(path)
    warn_look_ahead(args.checkpoint, experiment.data.derivatives)
    torch.set_num_threads(args.threads)
    table = read_track_table(args, experiment.data.frames_per_step)
    data = dataclasses.replace(experiment.data, frames_per_step=table.frames_per_step)
    experiment = dataclasses.replace(experiment, data=data)
    scene = build_scene(table, data, name=str(args.tracks))
    samples = scene_samples(scene, data, data.history_steps, require_future=True)
    mode = args.mode or default_point_forecast(experiment.model)
    digest = weights_digest(path)
    calibration = calibrate(model, experiment, samples, mode, str(args.tracks), digest)
    save_calibration(calibration, out)
    held = calibration.uncalibrated_coverage_q90
    print(
        f"wrote {out}: conformal radii of {experiment.model_name}'s {mode} regions from "
        f"{calibration.samples} forecasts of {args.tracks}. Uncalibrated, its 90% regions "
        f"held {held[0]:.0%} of these truths 0.4 s ahead and {held[-1]:.0%} at "
        f"{0.4 * len(held):.1f} s. Use the file with --calibration {out} (predict, plot) or "
        "Predictor(calibration=...)"
    )
    return 0
