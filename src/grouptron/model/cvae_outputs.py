"""What the CVAE's parts return: the encoding, the decoded velocity Gaussians and a training
pass's output (apart from the network, so that the forecasting engine and the loss can read them
without importing it)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import torch

from grouptron.model import gaussians

Feedback = Literal["sample", "mean"]


@dataclass(frozen=True)
class Encoding:
    """The condition ``x`` and the latent logits of ``B`` samples.

    Attributes:
        x: (B, Dx) condition ``[edge encoding; history encoding]`` (+ ``E_scene``).
        p_logits: (B, Z) centred logits of p(z|x).
        q_logits: (B, Z) centred logits of q(z|x,y), or None without a future.
    """

    x: torch.Tensor
    p_logits: torch.Tensor
    q_logits: torch.Tensor | None


@dataclass(frozen=True)
class VelocityGaussians:
    """Per-step velocity Gaussians of ``M`` decoded branches per sample.

    Attributes:
        mean: (B, M, H, 2) m/s.
        log_sigma: (B, M, H, 2).
        corr: (B, M, H).
        fed_back: (B, M, H, 2) the actions fed back into the decoder (samples or means).
    """

    mean: torch.Tensor
    log_sigma: torch.Tensor
    corr: torch.Tensor
    fed_back: torch.Tensor

    @property
    def cov(self) -> torch.Tensor:
        """(B, M, H, 3) covariance entries."""
        return gaussians.covariance_entries(self.log_sigma, self.corr)


@dataclass(frozen=True)
class CVAEOutput:
    """What the loss needs: the encoding and all Z latent branches decoded."""

    encoding: Encoding
    velocity: VelocityGaussians
