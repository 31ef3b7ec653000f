"""Constant velocity from the last one to four observed steps, causal inputs, every split.

Usage:
    python benchmarks/velocity_window.py [--splits eth,hotel,univ,zara1,zara2] [--windows 1,2,3,4]
                                         [--data-dir DIR]

The project's constant-velocity baseline repeats the last observed displacement (a window of
one step). Averaging the velocity over a longer window smooths annotation noise but reacts
later to turns. This prints, for each split's validation part (the other four locations,
which is all a model or a choice may look at) and test part (the held-out location), the
FDE/ADE in metres of every window and, on test, each window's paired FDE difference to the
one-step baseline with its 95% interval over resampled time steps. The window that validation
prefers is marked with ``<``; test is only reported, never used to choose. How each part's last
two displacements look (speed, how often the annotation repeats a position, how much they
turn) says how much the last one tells. Validation samples need 2 observed points and test
samples all 8 (the project's protocol), so short histories shrink the window on validation.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig
from grouptron.constants import DT_S, HISTORY_STEPS
from grouptron.data.datasets.dataset import load_part
from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.evaluation.metrics import ade, fde
from grouptron.evaluation.uncertainty import mean_interval

ZERO_M = 1e-6
"""A displacement shorter than this is none: the annotation repeated the position."""
MOVING_M = 0.05
"""Turns are measured only between displacements longer than this (a walker moves 0.5 m)."""


def windowed_velocity_forecast(
    hist_rel_m: np.ndarray, hist_mask: np.ndarray, horizon_steps: int, window_steps: int
) -> np.ndarray:
    """Constant velocity with the velocity averaged over the last ``window_steps`` steps.

    Where the ego was not observed that far back, the window shrinks to its earliest observed
    step inside it; with no earlier step the ego is taken to stand still (as the one-step
    baseline does).

    Args:
        hist_rel_m: (S, T, 2) observed positions relative to the current one (last row).
        hist_mask: (S, T) True where observed.
        horizon_steps: H.
        window_steps: n >= 1.

    Returns:
        (S, H, 2) predicted positions relative to the current one.
    """
    num_steps = hist_rel_m.shape[1]
    back = np.arange(1, window_steps + 1)  # (n,) steps back from t
    observed = hist_mask[:, num_steps - 1 - back]  # (S, n)
    reach = (observed * back).max(axis=1)  # (S,) furthest observed step back; 0: none
    earliest = np.take_along_axis(hist_rel_m, (num_steps - 1 - reach)[:, None, None], axis=1)
    velocity = -earliest[:, 0] / np.maximum(reach, 1)[:, None]  # (S, 2): current row is 0
    k = np.arange(1, horizon_steps + 1, dtype=hist_rel_m.dtype)
    return k[None, :, None] * velocity[:, None, :]


@dataclass(frozen=True)
class Motion:
    """How the last two observed displacements of a part's samples look."""

    speed_m_s: float  # median speed over the last 0.4 s step
    still: float  # share of samples whose last two displacements are both zero
    stop_go: float  # share with exactly one of them zero
    turn_deg: float  # median turn between them, samples moving > MOVING_M in both


def motion(hist_rel_m: np.ndarray, hist_mask: np.ndarray) -> Motion:
    """The :class:`Motion` of (S, T, 2) samples (those observed at t-2, t-1 and t)."""
    both = hist_mask[:, -3]
    before = hist_rel_m[both, -2] - hist_rel_m[both, -3]  # (S', 2) displacement t-2 -> t-1
    last = -hist_rel_m[both, -2]  # (S', 2) displacement t-1 -> t
    before_m, last_m = np.linalg.norm(before, axis=-1), np.linalg.norm(last, axis=-1)
    zero_before, zero_last = before_m < ZERO_M, last_m < ZERO_M
    moving = (before_m > MOVING_M) & (last_m > MOVING_M)
    cosine = (before[moving] * last[moving]).sum(-1) / (before_m[moving] * last_m[moving])
    turn = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    return Motion(
        speed_m_s=float(np.median(last_m)) / DT_S,
        still=float(np.mean(zero_before & zero_last)),
        stop_go=float(np.mean(zero_before ^ zero_last)),
        turn_deg=float(np.median(turn)) if turn.size else float("nan"),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--splits", default="eth,hotel,univ,zara1,zara2")
    parser.add_argument("--windows", default="1,2,3,4", help="velocity windows in steps")
    parser.add_argument("--data-dir", type=Path, default=None)
    args = parser.parse_args()
    data_dir = resolve_data_dir(args.data_dir)
    windows = [int(w) for w in args.windows.split(",")]
    if windows[0] != 1:
        parser.error("--windows: the first window must be 1 (the baseline)")
    if any(not 1 <= w < HISTORY_STEPS for w in windows):
        parser.error(f"--windows: each from 1 to {HISTORY_STEPS - 1} (the observed steps before t)")
    config = DataConfig(derivatives="backward")
    print("FDE/ADE in m of constant velocity averaged over the last n steps (causal inputs);")
    print("the last two displacements: speed, median m/s; still, share both zero; stop-go,")
    print(f"share one zero; turn, median degrees between them where both exceed {MOVING_M} m")
    print(
        f"{'split':<6} {'part':<5} {'samples':>7} {'speed':>6} {'still':>6} {'stop-go':>7} "
        f"{'turn':>6} " + " ".join(f"{f'n={w}':>13}" for w in windows)
    )
    for split in args.splits.split(","):
        preferred = None
        for part in ("val", "test"):
            samples = load_part(data_dir, split, part, config).samples
            horizon = samples.fut_rel_m.shape[1]
            forecasts = [
                windowed_velocity_forecast(samples.hist_rel_m, samples.hist_mask, horizon, w)
                for w in windows
            ]  # each (S, H, 2)
            fde_m = [fde(f, samples.fut_rel_m) for f in forecasts]  # each (S,)
            ade_m = [ade(f, samples.fut_rel_m) for f in forecasts]
            if part == "val":
                preferred = int(np.argmin([f.mean() for f in fde_m]))
            cells = [
                f"{f.mean():.3f}/{a.mean():.3f}" + ("<" if i == preferred else " ")
                for i, (f, a) in enumerate(zip(fde_m, ade_m, strict=True))
            ]
            seen = motion(samples.hist_rel_m, samples.hist_mask)
            print(
                f"{split:<6} {part:<5} {len(samples):>7} {seen.speed_m_s:>6.2f} "
                f"{seen.still:>6.3f} {seen.stop_go:>7.3f} {seen.turn_deg:>6.1f} "
                + " ".join(f"{c:>13}" for c in cells)
            )
            if part == "test":
                steps = time_step_ids(samples)
                paired = [mean_interval(fde_m[i] - fde_m[0], steps) for i in range(1, len(windows))]
                print(
                    f"{'':<6} {'':<5} {'':>7} {'':>6} {'':>6} {'':>7} {'':>6} {'':>13} "
                    + " ".join(f"{p.signed_text():>13}" for p in paired)
                    + "  (FDE - n=1's, m)"
                )


if __name__ == "__main__":
    main()
