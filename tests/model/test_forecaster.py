"""The forecaster interface's own parts: the kernel density of samples, the default point
forecast, refusals in one line, and what the shipped CVAEs declare."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.model.factory import build_model
from grouptron.model.forecaster import (
    KDE_FLOOR_M,
    Forecaster,
    Loss,
    kernel_density,
    latent_values_of,
)
from grouptron.point_forecast import PointForecast
from tests.helpers.models import SMALL, random_batch


class Straight(Forecaster):
    """Walks on at 1 m/s along x with noise of 0.1 m per step (samples only)."""

    def __init__(self, config: ExperimentConfig) -> None:
        super().__init__()
        self.weight = torch.nn.Parameter(torch.zeros(()))

    def sample(self, batch, horizon, dt_s, num_samples, generator=None):  # type: ignore[no-untyped-def]
        B = len(batch.hist_st)
        steps = torch.arange(1, horizon + 1, dtype=torch.float64) * dt_s
        mean = torch.stack([steps, torch.zeros_like(steps)], -1)  # (H, 2)
        noise = 0.1 * torch.randn(B, num_samples, horizon, 2, generator=generator)
        return mean + noise.double()


def test_kernel_density_is_scotts_rule_with_a_floor() -> None:
    rng = np.random.default_rng(0)
    samples = torch.from_numpy(rng.normal(size=(2, 50, 3, 2)))
    density = kernel_density(samples)
    assert density.means.shape == (2, 50, 3, 2) and density.covariances.shape == (2, 50, 3, 3)
    x = samples[0, :, 1].numpy()  # (K, 2) one step's samples
    expected = np.cov(x.T) * 50 ** (-1 / 3) + np.eye(2) * KDE_FLOOR_M**2
    var_x, cov_xy, var_y = density.covariances[0, 0, 1].numpy()
    assert np.allclose([[var_x, cov_xy], [cov_xy, var_y]], expected)
    assert np.allclose(density.log_weights.exp().sum(-1).numpy(), 1.0)
    same = kernel_density(torch.zeros(1, 4, 2, 2))  # a deterministic model's samples
    assert np.allclose(same.covariances[..., 0].numpy(), KDE_FLOOR_M**2)


def test_a_model_of_samples_makes_their_mean_and_refuses_the_rest() -> None:
    model = Straight(ExperimentConfig())
    batch = random_batch(4)
    made = model.forecast_point(batch, PointForecast("mean"), 12, 0.4)
    assert torch.allclose(
        made.point[:, -1], torch.tensor([4.8, 0.0], dtype=torch.float64), atol=0.1
    )
    assert made.distribution().means.shape == (4, 20, 12, 2)
    with pytest.raises(GrouptronError, match=r"makes no ml forecast .*--forecast mean"):
        model.forecast_point(batch, PointForecast("ml"), 12, 0.4)
    with pytest.raises(GrouptronError, match=r"cannot be evaluated without edges"):
        model.forecast_futures(batch, 12, 0.4, num_samples=2, ablate=("edges",))
    assert model.latent_values == 1


def test_loss_terms_are_logged_by_name() -> None:
    loss = Loss(torch.tensor(2.5), {"nll": torch.tensor(1.0)})
    assert loss.as_floats() == {"loss": 2.5, "nll": 1.0}


def test_the_shipped_cvaes_declare_what_they_make() -> None:
    trajectron = build_model(ExperimentConfig(model=SMALL))
    grouptron = build_model(ExperimentConfig(model_name="grouptron", model=SMALL))
    assert trajectron.point_forecasts == ("ml", "mean") and not trajectron.reads_groups
    assert grouptron.reads_groups and set(grouptron.ablations) == {"edges", "scene"}
    assert trajectron.latent_values == SMALL.latent_values
    assert latent_values_of(ExperimentConfig(model=SMALL)) == SMALL.latent_values
    assert latent_values_of(ExperimentConfig(model_name="pkg:Model")) == 1


def test_a_forecast_of_the_wrong_shape_is_refused_in_one_line() -> None:
    class Short(Straight):
        def sample(self, batch, horizon, dt_s, num_samples, generator=None):  # type: ignore[no-untyped-def]
            return super().sample(batch, horizon - 1, dt_s, num_samples, generator)

    with pytest.raises(GrouptronError, match=r"Short.sample returned shape \(4, 2, 11, 2\)"):
        Short(ExperimentConfig()).forecast_futures(random_batch(4), 12, 0.4, num_samples=2)
