"""A picture of one step's groups: each pedestrian's recent path, coloured by group."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

from grouptron.io import save_atomically

matplotlib.use("Agg")  # files only; works without a display
import matplotlib.pyplot as plt
import numpy as np


def plot_step_groups(
    paths_m: np.ndarray,
    masks: np.ndarray,
    labels: np.ndarray,
    ped_ids: np.ndarray,
    *,
    title: str,
    out: Path,
) -> None:
    """Save a PNG of N pedestrians' histories (metres, equal aspect), one colour per group.

    Args:
        paths_m: (N, T, 2) positions, the last one the current.
        masks: (N, T) observed steps.
        labels: (N,) group of every pedestrian.
        ped_ids: (N,) ids written next to the current positions.
    """
    colours = plt.get_cmap("tab20")
    markers = "osD^v"  # colour and marker together tell up to 100 groups apart

    def style(group: int) -> tuple[Any, str]:
        return colours(group % 20), markers[(group // 20) % len(markers)]

    fig, ax = plt.subplots(figsize=(9, 6), dpi=120)
    for path, mask, label, pid in zip(paths_m, masks, labels, ped_ids, strict=True):
        colour, marker = style(int(label))
        seen = path[mask]
        ax.plot(seen[:, 0], seen[:, 1], "-", color=colour, lw=1.8, alpha=0.9)
        ax.plot(*seen[-1], marker, color=colour, ms=6, mec="black", mew=0.6)
        ax.annotate(str(pid), seen[-1], textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    handles = [
        plt.Line2D([0], [0], color=c, marker=m, lw=2, mec="black", mew=0.6, label=f"group {g}")
        for g in np.unique(labels)
        for c, m in [style(int(g))]
    ]
    ax.legend(
        handles=handles,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=7,
        ncol=1 if len(handles) <= 24 else 2,
        title="marker: now\nline: last 3.2 s",
        title_fontsize=7,
    )
    try:
        fig.tight_layout()
        out.parent.mkdir(parents=True, exist_ok=True)
        save_atomically(out, fig.savefig)
    finally:
        plt.close(fig)
