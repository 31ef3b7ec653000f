"""Pictures of forecasts at one frame: histories, ground truth, most likely and sampled
futures, pedestrians coloured by detected group; one panel per model."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; works without a display
import matplotlib.pyplot as plt
import numpy as np

from grouptron.inference.predictor import Forecast


@dataclass(frozen=True)
class Panel:
    """One model's forecast and what to draw around it.

    Attributes:
        title: e.g. the model and checkpoint name.
        forecast: the model's forecast at the frame.
        history: (N, T, 2) observed positions up to the frame (NaN where unobserved), aligned
            with ``forecast.ids``.
        truth: (N, H, 2) the recorded future (NaN where the file has none).
    """

    title: str
    forecast: Forecast
    history: np.ndarray
    truth: np.ndarray


def tracks_around(
    tracks: np.ndarray, ids: np.ndarray, frame: int, frames_per_step: int, before: int, after: int
) -> tuple[np.ndarray, np.ndarray]:
    """(N, before + 1, 2) positions up to ``frame`` and (N, after, 2) after it, NaN where the
    (R, 4) ``frame, id, x, y`` rows have none."""
    offsets = np.arange(-before, after + 1) * frames_per_step + frame  # (W,)
    grid = np.full((len(ids), len(offsets), 2), np.nan)
    order = np.argsort(ids)
    near = np.isin(tracks[:, 0], offsets) & np.isin(tracks[:, 1], ids)
    rows = tracks[near]
    agent = order[np.searchsorted(ids[order], rows[:, 1])]
    grid[agent, (rows[:, 0].astype(np.int64) - offsets[0]) // frames_per_step] = rows[:, 2:]
    return grid[:, : before + 1], grid[:, before + 1 :]


def plot_forecasts(panels: Sequence[Panel], frame: int, out: Path) -> None:
    """Save a PNG with one panel per model (metres, equal aspect, shared axes)."""
    colours = plt.get_cmap("tab10")
    fig, axes = plt.subplots(
        1, len(panels), figsize=(7 * len(panels), 6.5), dpi=120, sharex=True, sharey=True
    )
    axes = np.atleast_1d(axes)
    try:
        for ax, panel in zip(axes, panels, strict=True):
            forecast = panel.forecast
            for k in range(len(forecast)):
                colour = colours(int(forecast.group[k]) % 10)
                origin = panel.history[k, -1]
                if forecast.samples is not None:
                    for drawn in forecast.samples[k]:
                        path = np.vstack([origin, drawn])
                        ax.plot(path[:, 0], path[:, 1], "-", color=colour, lw=0.5, alpha=0.25)
                hist = panel.history[k]
                ax.plot(hist[:, 0], hist[:, 1], "-", color=colour, lw=2.2)
                truth = np.vstack([origin, panel.truth[k]])
                ax.plot(truth[:, 0], truth[:, 1], ":", color="black", lw=1.2)
                ml = np.vstack([origin, forecast.most_likely[k]])
                ax.plot(ml[:, 0], ml[:, 1], "--", color=colour, lw=1.8)
                ax.plot(*origin, "o", color=colour, ms=6, mec="black", mew=0.6)
            ax.set_aspect("equal", adjustable="box")
            ax.set(xlabel="x (m)", ylabel="y (m)", title=f"{panel.title}\nframe {frame}")
            ax.grid(alpha=0.3)
        legend = [
            plt.Line2D([0], [0], color="grey", lw=2.2, label="observed (3.2 s)"),
            plt.Line2D([0], [0], color="black", ls=":", lw=1.2, label="ground truth"),
            plt.Line2D([0], [0], color="grey", ls="--", lw=1.8, label="most likely (4.8 s)"),
            plt.Line2D([0], [0], color="grey", lw=0.5, alpha=0.6, label="samples"),
        ]
        axes[-1].legend(handles=legend, loc="best", fontsize=8, title="colour: detected group")
        fig.tight_layout()
        out.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out)
    finally:
        plt.close(fig)
