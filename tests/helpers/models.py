"""Small model and experiment settings, and a random batch, for fast model tests."""

from __future__ import annotations

import torch

from grouptron.config import DataConfig, ExperimentConfig, ModelConfig, TrainConfig
from grouptron.model.batch import Batch

SMALL = ModelConfig(
    history_hidden=8,
    edge_hidden=8,
    future_hidden=8,
    latent_values=5,
    p_z_hidden=8,
    decoder_hidden=16,
)
"""A small model: a fraction of the paper's widths, so tests run in moments."""

TINY = ExperimentConfig(model=SMALL, train=TrainConfig(epochs=2, batch_size=32, threads=1))
"""The small model trained for two epochs on one thread."""

TINY_MODEL = {"history_hidden": 8, "edge_hidden": 8, "future_hidden": 8, "latent_values": 5,
              "p_z_hidden": 8, "decoder_hidden": 16}  # fmt: skip
"""The small model's widths as the ``model`` table of a JSON config file."""


def random_batch(size: int = 6, seed: int = 0, history: int = 8, horizon: int = 12) -> Batch:
    """A seeded batch of random histories and futures; sample 0 has a short history."""
    g = torch.Generator().manual_seed(seed)
    mask = torch.ones(size, history, dtype=torch.bool)
    mask[0, :5] = False  # a short history (left padding)
    hist = torch.randn(size, history, 6, generator=g) * mask[..., None]
    fut = torch.randn(size, horizon, 2, generator=g).cumsum(1)
    return Batch(
        hist_st=hist,
        hist_mask=mask,
        nbr_sum_st=torch.randn(size, history, 6, generator=g) * mask[..., None],
        edge_scale=torch.rand(size, generator=g),
        fut_rel_m=fut,
        fut_st=fut / DataConfig().position_scale_m,
    )
