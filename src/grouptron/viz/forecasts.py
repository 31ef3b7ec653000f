"""Pictures of forecasts: histories, ground truth, the point forecast with its prediction
regions (or sampled futures), pedestrians coloured by detected group; one panel per model; one
frame (PNG) or a range (GIF/MP4)."""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only; works without a display
import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation
from matplotlib.colors import hsv_to_rgb
from matplotlib.patches import Ellipse

from grouptron.errors import GrouptronError
from grouptron.inference.forecast import Forecast
from grouptron.io import save_atomically


@dataclass(frozen=True)
class Panel:
    """One model's forecast and what to draw around it.

    Attributes:
        title: e.g. the model and checkpoint name.
        forecast: the model's forecast at the frame.
        history: (N, T, 2) observed positions up to the frame (NaN where unobserved), aligned
            with ``forecast.ids``.
        truth: (N, H, 2) the recorded future (NaN where the file has none).
        point_forecast: what the dashed line is (``most likely``, ``argmax latent``, ``mean``).
        group_rule: how the colours' groups were found (``config.describe_group_rule``).
        region_q: draw each forecast step's region holding this probability (None: none).
        ids: write each person's id beside them.
    """

    title: str
    forecast: Forecast
    history: np.ndarray
    truth: np.ndarray
    point_forecast: str = "most likely"
    group_rule: str = ""
    region_q: float | None = None
    ids: bool = False


REGION_STEPS = (3, 6, 9, 12)
"""Forecast steps whose regions are drawn (1.2 s apart: all twelve overlap into a smear)."""


def group_colour(group: int) -> tuple[float, float, float]:
    """A colour per group that stays distinct from its neighbours' in a crowd of many groups:
    hues a golden-ratio turn apart, so that consecutive groups never look alike."""
    hue = (group * 0.6180339887) % 1.0
    value = 0.85 if group % 2 else 0.65  # alternate brightness too
    rgb = hsv_to_rgb((hue, 0.8, value))
    return float(rgb[0]), float(rgb[1]), float(rgb[2])


def tracks_around(
    tracks: np.ndarray,
    ids: np.ndarray,
    frame: int,
    frames_per_step: int,
    *,
    before: int,
    after: int,
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


def _draw_panel(ax: plt.Axes, panel: Panel, frame: int) -> None:
    """Histories, truth, the point forecast with its regions (or samples) of one model,
    coloured by group."""
    forecast = panel.forecast
    regions = None if panel.region_q is None else forecast.regions(panel.region_q)
    for k in range(len(forecast)):
        group = k if forecast.group is None else int(forecast.group[k])
        colour = group_colour(group)
        origin = panel.history[k, -1]
        if regions is not None:
            for step in (s for s in REGION_STEPS if s <= regions.major_m.shape[1]):
                h = step - 1
                ellipse = Ellipse(
                    tuple(regions.centre[k, h]),
                    2 * regions.major_m[k, h],
                    2 * regions.minor_m[k, h],
                    angle=float(np.degrees(regions.angle_rad[k, h])),
                    facecolor=colour,
                    edgecolor=colour,
                    alpha=0.12,
                    lw=0.6,
                )
                ax.add_patch(ellipse)
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
        if panel.ids:
            ax.annotate(
                f"{forecast.ids[k]:g}",
                origin,
                xytext=(3, 3),
                textcoords="offset points",
                fontsize=7,
            )
    ax.set_aspect("equal", adjustable="box")
    rule = f", groups: {panel.group_rule}" if panel.group_rule else ""
    ax.set(xlabel="x (m)", ylabel="y (m)", title=f"{panel.title}\nframe {frame}{rule}")
    ax.grid(alpha=0.3)


def _add_legend(ax: plt.Axes, panel: Panel) -> None:
    legend: list[Any] = [
        plt.Line2D([0], [0], color="grey", lw=2.2, label="observed (3.2 s)"),
        plt.Line2D([0], [0], color="black", ls=":", lw=1.2, label="ground truth"),
        plt.Line2D(
            [0], [0], color="grey", ls="--", lw=1.8, label=f"{panel.point_forecast} (4.8 s)"
        ),
    ]
    if panel.region_q is not None:
        seconds = ", ".join(f"{0.4 * s:g}" for s in REGION_STEPS)
        label = f"{100 * panel.region_q:g}% region at {seconds} s"
        label += "\n(calibrated)" if panel.forecast.calibration is not None else "\n(uncalibrated)"
        legend.append(Ellipse((0, 0), 1, 1, facecolor="grey", alpha=0.25, label=label))
    if panel.forecast.samples is not None and panel.forecast.samples.shape[1]:
        legend.append(plt.Line2D([0], [0], color="grey", lw=0.5, alpha=0.6, label="samples"))
    # Outside the axes: inside, it hides pedestrians in crowded frames.
    ax.legend(
        handles=legend,
        loc="upper left",
        bbox_to_anchor=(1.02, 1.0),
        fontsize=8,
        title="colour: detected group",
    )


def _figure(columns: int) -> tuple[plt.Figure, np.ndarray]:
    fig, axes = plt.subplots(
        1, columns, figsize=(7 * columns + 2, 6.5), dpi=120, sharex=True, sharey=True
    )
    return fig, np.atleast_1d(axes)


def plot_forecasts(panels: Sequence[Panel], frame: int, out: Path) -> None:
    """Save a PNG with one panel per model (metres, equal aspect, shared axes)."""
    fig, axes = _figure(len(panels))
    try:
        for ax, panel in zip(axes, panels, strict=True):
            _draw_panel(ax, panel, frame)
        _add_legend(axes[-1], panels[0])
        fig.tight_layout()
        # "tight": the legend outside the axes is part of the picture, not cut at its edge.
        save_atomically(out, functools.partial(fig.savefig, bbox_inches="tight"))
    finally:
        plt.close(fig)


def _bounds(frames: Sequence[tuple[int, Sequence[Panel]]], margin_m: float = 1.0) -> np.ndarray:
    """(2, 2) [[x_min, x_max], [y_min, y_max]] over every drawn point of every frame."""
    points = [
        array.reshape(-1, 2)
        for _, panels in frames
        for panel in panels
        for array in (panel.history, panel.truth, panel.forecast.most_likely)
    ]
    stacked = np.concatenate(points)
    stacked = stacked[np.isfinite(stacked).all(axis=1)]
    low, high = stacked.min(axis=0) - margin_m, stacked.max(axis=0) + margin_m
    return np.stack([low, high], axis=1)


def animate_forecasts(
    frames: Sequence[tuple[int, Sequence[Panel]]], out: Path, steps_per_second: float = 2.5
) -> None:
    """Save an animated GIF (Pillow) or MP4 (needs ffmpeg) of forecasts frame after frame.

    Args:
        frames: (frame, panels) per picture, all with the same number of panels.
        out: ``.gif`` or ``.mp4`` file.
        steps_per_second: playback rate (2.5 = real time for 0.4 s steps).
    """
    suffix = out.suffix.lower()
    # The stubs say int, but both writers use fps as a number (GIF: 1000 / fps ms a picture),
    # and real time for 0.4 s steps is 2.5.
    fps: Any = steps_per_second
    if suffix == ".gif":
        writer: animation.AbstractMovieWriter = animation.PillowWriter(fps=fps)
    elif suffix == ".mp4":
        if not animation.writers.is_available("ffmpeg"):
            raise GrouptronError(f"{out}: writing MP4 needs ffmpeg on PATH; write a .gif instead")
        writer = animation.FFMpegWriter(fps=fps)
    else:
        raise GrouptronError(f"{out}: an animation is written as .gif or .mp4, not {suffix!r}")
    (x_lim, y_lim) = _bounds(frames)
    fig, axes = _figure(len(frames[0][1]))

    def draw(index: int) -> None:
        frame, panels = frames[index]
        for ax, panel in zip(axes, panels, strict=True):
            ax.clear()
            _draw_panel(ax, panel, frame)
            ax.set(xlim=x_lim, ylim=y_lim)
        _add_legend(axes[-1], panels[0])

    try:
        draw(0)
        fig.tight_layout()
        movie = animation.FuncAnimation(fig, draw, frames=len(frames), repeat=False)
        save_atomically(out, lambda path: movie.save(path, writer=writer))
    finally:
        plt.close(fig)
