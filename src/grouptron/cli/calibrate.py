"""``grouptron calibrate``: conformal radii of prediction regions on a site's own recording
(the work: :func:`grouptron.workflows.calibrate.calibrate_tracks`)."""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from grouptron.cli.common import track_file
from grouptron.workflows.calibrate import calibrate_tracks


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Score every person of ``--tracks`` with a full history and future and write the
    conformal radii of the regions for ``--checkpoint``'s point forecast."""
    out = Path(args.out)
    torch.set_num_threads(args.threads)
    calibration = calibrate_tracks(track_file(args), out, args.checkpoint, args.forecast)
    held = calibration.uncalibrated_coverage_q90
    print(
        f"wrote {out}: conformal radii of {calibration.checkpoint}'s "
        f"{calibration.point_forecast} regions from {calibration.samples} forecasts of "
        f"{args.tracks}. Uncalibrated, its 90% regions held {held[0]:.0%} of these truths "
        f"{calibration.step_s:g} s ahead and {held[-1]:.0%} at "
        f"{calibration.step_s * len(held):.1f} s. Use the file with "
        f"--calibration {out} (predict, plot) or Predictor(calibration=...)"
    )
    return 0
