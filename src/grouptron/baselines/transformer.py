"""A small trajectory Transformer on the forecaster interface: a learned baseline of the
attention family, after Giuliari et al. (ICPR 2020), "Transformer Networks for Trajectory
Forecasting".

As theirs, it reads one person's own history only (no neighbours, no scene): an encoder of
self-attention over the observed steps (each step's standardised position, velocity and
acceleration, with a learned embedding of its place in the window; steps before the person
was seen are masked), and a decoder whose queries are the future steps. It is smaller and
not autoregressive, and it forecasts a distribution:

- 64 model dimensions, 2 encoder and 2 decoder layers of 4 heads (theirs: 512, 6 and 6, 8
  heads), trainable in minutes on a laptop's CPU;
- the 12 future steps are 12 learned queries decoded at once, each attending to the others
  and to the history, rather than one step at a time from the previous prediction;
- each step's output is a bivariate Gaussian of its displacement (``StepGaussians``, trained
  by its negative log-likelihood), so it samples futures for best-of-K and has exact regions;
  theirs regresses one future (TF) or samples quantised displacements (TF_q).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from grouptron.baselines.step_gaussians import RAW_VALUES, StepGaussianForecaster, StepGaussians
from grouptron.config import ExperimentConfig
from grouptron.model.batch import Batch
from grouptron.model.forecaster import model_settings


@dataclass(frozen=True)
class TransformerSettings:
    """``--set model_settings.NAME=VALUE``, stored with the weights.

    Attributes:
        width: model dimensions.
        heads: attention heads.
        encoder_layers, decoder_layers: layers of each.
        feedforward: hidden units of each layer's feed-forward part.
        dropout: dropout while training.
        min_sigma_m: the least spread of a step's displacement, metres.
    """

    width: int = 64
    heads: int = 4
    encoder_layers: int = 2
    decoder_layers: int = 2
    feedforward: int = 128
    dropout: float = 0.1
    min_sigma_m: float = 0.01


class TrajectoryTransformer(StepGaussianForecaster):
    """One person's history -> attention -> a Gaussian of each future displacement."""

    def __init__(self, config: ExperimentConfig) -> None:
        super().__init__()
        s = self.settings = model_settings(TransformerSettings, config)
        history, horizon = config.data.history_steps, config.data.horizon_steps
        self.embed = nn.Linear(6, s.width)
        self.history_place = nn.Parameter(0.02 * torch.randn(history, s.width))
        self.queries = nn.Parameter(0.02 * torch.randn(horizon, s.width))
        self.encoder = nn.TransformerEncoder(
            nn.TransformerEncoderLayer(
                s.width, s.heads, s.feedforward, s.dropout, batch_first=True
            ),
            s.encoder_layers,
            norm=nn.LayerNorm(s.width),
            enable_nested_tensor=False,  # padded steps stay dense: one code path always
        )
        self.decoder = nn.TransformerDecoder(
            nn.TransformerDecoderLayer(
                s.width, s.heads, s.feedforward, s.dropout, batch_first=True
            ),
            s.decoder_layers,
            norm=nn.LayerNorm(s.width),
        )
        self.head = nn.Linear(s.width, RAW_VALUES)

    def step_gaussians(self, batch: Batch) -> StepGaussians:
        """The (B, H) step Gaussians of ``batch``'s people."""
        tokens = self.embed(batch.hist_st.float()) + self.history_place  # (B, T, width)
        unseen = ~batch.hist_mask  # (B, T); the present step is always seen
        queries = self.queries.expand(len(batch), -1, -1)  # (B, H, width)
        memory = self.encoder(tokens, src_key_padding_mask=unseen)
        decoded = self.decoder(queries, memory, memory_key_padding_mask=unseen)
        return StepGaussians.from_raw(self.head(decoded), self.settings.min_sigma_m)
