"""A picture of a training run: loss and validation error per epoch."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only; works without a display
import matplotlib.pyplot as plt

from grouptron.io import save_atomically


def plot_training_curves(records: list[dict[str, Any]], title: str, out: Path) -> None:
    """Save a PNG with the training loss (left) and validation ML ADE/FDE next to constant
    velocity (right), one point per epoch."""
    epochs = [r["epoch"] for r in records]
    fig, (loss_ax, val_ax) = plt.subplots(1, 2, figsize=(11, 4), dpi=110)
    try:
        loss_ax.plot(epochs, [r.get("train_loss", math.nan) for r in records], "o-", label="loss")
        loss_ax.set(xlabel="epoch", ylabel="training loss (negative ELBO)", title="training")
        loss_ax.grid(alpha=0.3)
        for key, label, style in (
            ("val_ml_fde", "ML FDE", "o-"),
            ("val_ml_ade", "ML ADE", "s-"),
            ("val_cv_fde", "constant velocity FDE", "--"),
            ("val_cv_ade", "constant velocity ADE", ":"),
        ):
            values = [r.get(key, math.nan) for r in records]
            if not all(math.isnan(v) for v in values):
                val_ax.plot(epochs, values, style, label=label)
        val_ax.set(xlabel="epoch", ylabel="metres", title="validation")
        val_ax.grid(alpha=0.3)
        if val_ax.get_lines():
            val_ax.legend()
        fig.suptitle(title)
        fig.tight_layout()
        save_atomically(out, fig.savefig)
    finally:
        plt.close(fig)
