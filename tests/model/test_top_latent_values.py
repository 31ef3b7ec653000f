"""The ``ml-top10`` (``ml-topK``) forecast: the most likely forecast of only the 10 (K) most
probable latent values, decoding only those."""

from __future__ import annotations

import dataclasses

import pytest
import torch

from grouptron.constants import is_point_forecast, top_forecast_size
from grouptron.errors import GrouptronError
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.predict import (
    POINT_FORECASTS,
    decode_every_latent,
    forecast_name,
    most_likely_positions,
    point_forecast,
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


def test_ml_top_k_names_the_most_likely_of_the_k_most_probable() -> None:
    """``ml-topK`` for any K: ``point_forecast`` decodes the K most probable latent values
    (all of them in a model with fewer); other names are refused with the choices."""
    model, batch = _model(25), random_batch(size=6)
    with torch.no_grad():
        encoding, velocity = decode_every_latent(model, batch, 12)
        for k in (2, 3, 25, 40):
            got = point_forecast(f"ml-top{k}")(model, batch, 12, 0.4, ())
            picked = most_likely_positions(
                *top_latent_values(encoding, velocity, min(k, 25)), 12, 0.4, 4 if k >= 25 else 1
            )
            torch.testing.assert_close(got, picked, atol=1e-5, rtol=0)
    for bad in ("ml-top1", "ml-top02", "ml-topx", "ml-top", "best"):
        with pytest.raises(GrouptronError, match="ml-topK"):
            point_forecast(bad)


def test_names_of_point_forecasts() -> None:
    assert [
        top_forecast_size(n) for n in ("ml-top2", "ml-top10", "ml-top1", "ml", "ml-top007")
    ] == [
        2,
        10,
        None,
        None,
        None,
    ]
    assert (
        top_forecast_size("ml-top\u00b2") is None
        and top_forecast_size("ml-top\u0661\u0660") is None
    )
    assert all(is_point_forecast(n) for n in ("ml", "ml-argmax", "mean", "ml-top10", "ml-top3"))
    assert [forecast_name("ml", k, 25) for k in (1, 2, 10, 25)] == [
        "ml-argmax",
        "ml-top2",
        "ml-top10",
        "ml",
    ]
    assert not any(is_point_forecast(n) for n in ("samples", "best-of-20", "ml-top-3", ""))
