"""Loss terms against direct computations; schedules at known points."""

from __future__ import annotations

import math

import pytest
import torch
from torch.distributions import Categorical, MultivariateNormal, kl_divergence

from grouptron.config import LossConfig
from grouptron.model import schedules
from grouptron.model.cvae import CVAEOutput, Encoding, TrajectronCVAE
from grouptron.model.elbo import (
    elbo_loss,
    kl_categorical,
    mutual_information,
    position_log_likelihood,
)
from tests.helpers.models import SMALL, random_batch


def test_kl_matches_torch() -> None:
    q, p = torch.randn(4, 25), torch.randn(4, 25)
    expected = kl_divergence(Categorical(logits=q), Categorical(logits=p))
    torch.testing.assert_close(kl_categorical(q, p), expected)


def test_mutual_information_of_identical_rows_is_zero_and_of_one_hots_is_log_n() -> None:
    assert mutual_information(torch.zeros(8, 25)).abs() < 1e-6
    one_hots = torch.eye(4) * 50.0
    assert mutual_information(one_hots) == pytest.approx(math.log(4), abs=1e-4)


def test_log_likelihood_is_the_clamped_sum_of_per_step_mixtures() -> None:
    torch.manual_seed(0)
    model = TrajectronCVAE(SMALL)
    batch = random_batch(size=3)
    out = model(batch, logit_clip=None)
    got = position_log_likelihood(out, batch, dt_s=0.4, step_max=1e9)
    velocity = out.velocity
    q = torch.softmax(out.encoding.q_logits, -1)
    expected = torch.zeros(3)
    for b in range(3):
        for k in range(12):
            density = 0.0
            for z in range(5):
                mean = velocity.mean[b, z, : k + 1].sum(0) * 0.4
                cov = velocity.cov[b, z, : k + 1].sum(0) * 0.16
                matrix = torch.stack([cov[[0, 1]], cov[[1, 2]]])
                density += (
                    q[b, z] * MultivariateNormal(mean, matrix).log_prob(batch.fut_rel_m[b, k]).exp()
                )
            expected[b] += torch.log(density)
    torch.testing.assert_close(got, expected, rtol=1e-4, atol=1e-4)
    clamped = position_log_likelihood(out, batch, dt_s=0.4, step_max=-1.0)
    assert (clamped <= -12.0 + 1e-5).all()


def test_elbo_combines_the_terms_with_free_bits() -> None:
    torch.manual_seed(0)
    model = TrajectronCVAE(SMALL)
    batch = random_batch(size=4)
    out = model(batch, logit_clip=None)
    same = CVAEOutput(
        Encoding(out.encoding.x, out.encoding.p_logits, out.encoding.p_logits), out.velocity
    )
    terms = elbo_loss(same, batch, LossConfig(), kl_weight=10.0, dt_s=0.4)
    assert float(terms.kl.detach()) == pytest.approx(
        0.07
    )  # KL(p || p) = 0, floored at the free bits
    expected = -(terms.log_likelihood - 10.0 * 0.07 + terms.mutual_info)
    torch.testing.assert_close(terms.loss, expected)


def test_schedules() -> None:
    config = LossConfig()
    assert schedules.kl_weight(config, 400) == pytest.approx(50.0)
    assert schedules.kl_weight(config, 0) == pytest.approx(100 / (1 + math.exp(4)))
    assert schedules.kl_weight(config, 5000) == pytest.approx(100.0)
    assert schedules.logit_clip(config, 300) == pytest.approx((0.05 + 5.0) / 2)
    assert schedules.logit_clip(config, 0) == pytest.approx(0.05 + 4.95 / (1 + math.exp(5)))
    assert schedules.logit_clip(config, 10_000) == pytest.approx(5.0)
