"""The random draws of one training step, made outside the model.

Drawing them for the whole (global) batch and handing each process its rows makes a batch split
across processes see exactly the dropout masks and decoder samples the undivided batch would,
so distributed training equals single-process training for the same global batch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F

from grouptron.config import ModelConfig


def dropout_sizes(config: ModelConfig) -> dict[str, int]:
    """Features per dropout site of the CVAE (in the order they are drawn)."""
    return {
        "history": config.history_hidden,
        "edge": config.edge_hidden,
        "edge_combined": config.edge_hidden,
        "future": 4 * config.future_hidden,  # final h and c of both directions
        "p_z": config.p_z_hidden,
    }


@dataclass(frozen=True)
class TrainingNoise:
    """Per-sample random draws of one training step.

    Attributes:
        dropout: site -> (B, D) uniforms in [0, 1); a feature is kept where its uniform is below
            the keep probability.
        decoder: (B, Z, H, 2) standard normal draws behind the fed-back velocity samples.
    """

    dropout: dict[str, torch.Tensor]
    decoder: torch.Tensor

    def rows(self, index: np.ndarray) -> TrainingNoise:
        """The draws of samples ``index`` (e.g. one process's share of the batch)."""
        rows = torch.as_tensor(index, dtype=torch.long)
        return TrainingNoise({k: v[rows] for k, v in self.dropout.items()}, self.decoder[rows])

    def to(self, device: torch.device | str) -> TrainingNoise:
        """A copy with every draw on ``device``."""
        return TrainingNoise(
            {k: v.to(device) for k, v in self.dropout.items()}, self.decoder.to(device)
        )


def draw_training_noise(
    batch_size: int, config: ModelConfig, horizon: int, extra: dict[str, int] | None = None
) -> TrainingNoise:
    """Draw a step's noise from the global torch RNG (seeded and saved with the run); ``extra``
    dropout sites (a variant's) are drawn last, so runs without them draw what they always did."""
    dropout = {site: torch.rand(batch_size, size) for site, size in dropout_sizes(config).items()}
    decoder = torch.randn(batch_size, config.latent_values, horizon, 2)
    for site, size in (extra or {}).items():
        dropout[site] = torch.rand(batch_size, size)
    return TrainingNoise(dropout, decoder)


def dropout(
    h: torch.Tensor, keep: float, training: bool, uniforms: torch.Tensor | None
) -> torch.Tensor:
    """Inverted dropout of (B, D) features with keep probability ``keep``; the mask comes from
    ``uniforms`` when given (training steps), else from the global RNG."""
    if not training or keep >= 1.0:
        return h
    if uniforms is None:
        return F.dropout(h, p=1.0 - keep, training=True)
    return h * (uniforms < keep).to(h.dtype) / keep
