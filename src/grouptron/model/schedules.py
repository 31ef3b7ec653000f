"""Annealing schedules of the reference, as pure functions of the iteration."""

from __future__ import annotations

import math

from grouptron.config import LossConfig


def sigmoid_anneal(
    start: float, final: float, centre_iter: float, divisor: float, *, it: int
) -> float:
    """``start + (final - start) * sigmoid((it - centre) / divisor)``."""
    return start + (final - start) / (1.0 + math.exp(-(it - centre_iter) / divisor))


def kl_weight(config: LossConfig, it: int) -> float:
    """Weight of the KL term: 0 -> 100, half-way at iteration 400."""
    return sigmoid_anneal(
        0.0, config.kl_weight_final, config.kl_weight_centre_iter, config.kl_weight_divisor, it=it
    )


def logit_clip(config: LossConfig, it: int) -> float:
    """Clip of the latent logits in training: 0.05 -> 5.0, half-way at iteration 300."""
    return sigmoid_anneal(
        config.logit_clip_start,
        config.logit_clip_final,
        config.logit_clip_centre_iter,
        config.logit_clip_divisor,
        it=it,
    )
