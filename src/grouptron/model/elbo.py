"""The training objective: the negative ELBO with all latent values enumerated exactly."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch
import torch.nn.functional as F

from grouptron.config import LossConfig
from grouptron.model import gaussians
from grouptron.model.batch import Batch
from grouptron.model.cvae_outputs import CVAEOutput


@dataclass(frozen=True)
class LossTerms:
    """Scalar terms of one batch; ``loss`` is what is minimised."""

    loss: torch.Tensor
    log_likelihood: torch.Tensor
    kl: torch.Tensor
    mutual_info: torch.Tensor

    def as_floats(self) -> dict[str, float]:
        """The terms as detached Python floats, by name."""
        return {
            "loss": float(self.loss.detach()),
            "log_likelihood": float(self.log_likelihood.detach()),
            "kl": float(self.kl.detach()),
            "mutual_info": float(self.mutual_info.detach()),
        }


def position_log_likelihood(
    output: CVAEOutput, batch: Batch, dt_s: float, step_max: float
) -> torch.Tensor:
    """(B,) sum over steps of ``min(step_max, log sum_z q(z|x,y) N(y_k; position branch z))``."""
    assert output.encoding.q_logits is not None
    velocity = output.velocity
    pos_mean, pos_cov = gaussians.integrate_single_integrator(
        velocity.mean, velocity.cov, dt_s
    )  # (B, Z, H, 2), (B, Z, H, 3)
    log_q = F.log_softmax(output.encoding.q_logits, dim=-1)  # (B, Z)
    truth = batch.fut_rel_m[:, None]  # (B, 1, H, 2)
    per_mode = gaussians.log_prob(truth, pos_mean, pos_cov)  # (B, Z, H)
    per_step = torch.logsumexp(log_q[:, :, None] + per_mode, dim=1)  # (B, H)
    return per_step.clamp(max=step_max).sum(dim=-1)


def kl_categorical(q_logits: torch.Tensor, p_logits: torch.Tensor) -> torch.Tensor:
    """(B,) KL(q || p) of categorical distributions given by logits."""
    log_q = F.log_softmax(q_logits, dim=-1)
    log_p = F.log_softmax(p_logits, dim=-1)
    return (log_q.exp() * (log_q - log_p)).sum(dim=-1)


BatchMean = Callable[[torch.Tensor], torch.Tensor]
"""(B, ...) per-sample values -> (...) their mean over the batch (global when distributed)."""


def _mean_over_batch(values: torch.Tensor) -> torch.Tensor:
    return values.mean(dim=0)


def mutual_information(
    p_logits: torch.Tensor, batch_mean: BatchMean = _mean_over_batch
) -> torch.Tensor:
    """I(x; z) under p(z|x) over the batch: entropy of the mean minus the mean entropy."""
    log_p = F.log_softmax(p_logits, dim=-1)
    probs = log_p.exp()
    mean_probs = batch_mean(probs)
    entropy_of_mean = -(mean_probs * torch.log(mean_probs.clamp_min(1e-30))).sum()
    mean_entropy = batch_mean(-(probs * log_p).sum(dim=-1))
    return entropy_of_mean - mean_entropy


def elbo_loss(
    output: CVAEOutput,
    batch: Batch,
    config: LossConfig,
    kl_weight: float,
    *,
    dt_s: float,
    batch_mean: BatchMean = _mean_over_batch,
) -> LossTerms:
    """``-(E[log p(y|x,z)] - w_kl * max(KL, free bits) + w_mi * I)`` averaged over the batch
    (``batch_mean`` averages over the global batch when it is split across processes)."""
    encoding = output.encoding
    assert encoding.q_logits is not None
    log_likelihood = batch_mean(
        position_log_likelihood(output, batch, dt_s, config.log_likelihood_max)
    )
    kl = batch_mean(kl_categorical(encoding.q_logits, encoding.p_logits))
    kl = kl.clamp(min=config.kl_free_bits)
    mutual_info = mutual_information(encoding.p_logits, batch_mean)
    elbo = log_likelihood - kl_weight * kl + config.mutual_info_weight * mutual_info
    return LossTerms(loss=-elbo, log_likelihood=log_likelihood, kl=kl, mutual_info=mutual_info)
