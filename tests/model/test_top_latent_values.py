"""The ``ml-top10`` forecast: the most likely forecast of only the 10 most probable latent
values, decoding only those."""

from __future__ import annotations

import dataclasses

import torch

from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.predict import (
    POINT_FORECASTS,
    decode_every_latent,
    most_likely_positions,
    predict_most_likely,
    top_latent_values,
)
from tests.helpers.models import SMALL, random_batch


def _model(latent_modes: int) -> TrajectronCVAE:
    torch.manual_seed(0)
    return TrajectronCVAE(dataclasses.replace(SMALL, latent_modes=latent_modes)).eval()


def test_top10_decodes_only_the_ten_most_probable_latent_values() -> None:
    model, batch = _model(25), random_batch(size=8)
    with torch.no_grad():
        got = POINT_FORECASTS["ml-top10"](model, batch, 12, 0.4, ())
        encoding, velocity = decode_every_latent(model, batch, 12)
        picked = most_likely_positions(*top_latent_values(encoding, velocity, 10), 12, 0.4)
        everything = predict_most_likely(model, batch, 12, 0.4)
    assert got.shape == (8, 12, 2)
    torch.testing.assert_close(got, picked, atol=1e-5, rtol=0)
    assert not torch.allclose(got, everything, atol=1e-4)  # 15 values left out: another mode


def test_top10_of_a_model_with_fewer_latent_values_is_the_full_mixture() -> None:
    model, batch = _model(5), random_batch(size=4)
    with torch.no_grad():
        got = POINT_FORECASTS["ml-top10"](model, batch, 12, 0.4, ())
        everything = predict_most_likely(model, batch, 12, 0.4)
    torch.testing.assert_close(got, everything, atol=1e-5, rtol=0)
