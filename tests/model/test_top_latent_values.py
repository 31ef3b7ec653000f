"""The ``ml-top10`` (``ml-topK``) forecast: the most likely forecast of only the 10 (K) most
probable latent values, decoding only those."""

from __future__ import annotations

import dataclasses

import pytest
import torch

from grouptron.errors import GrouptronError
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.predict import (
    decode_every_latent,
    most_likely_positions,
    predict_point,
    top_latent_values,
)
from grouptron.point_forecast import NAMED, PointForecast, is_point_forecast
from tests.helpers.models import SMALL, random_batch

ML = PointForecast.parse("ml")
TOP10 = PointForecast.parse("ml-top10")


def _model(latent_values: int) -> TrajectronCVAE:
    torch.manual_seed(0)
    return TrajectronCVAE(dataclasses.replace(SMALL, latent_values=latent_values)).eval()


def test_top10_decodes_only_the_ten_most_probable_latent_values() -> None:
    model, batch = _model(25), random_batch(size=8)
    with torch.no_grad():
        got = predict_point(model, batch, TOP10, 12, 0.4)
        encoding, velocity = decode_every_latent(model, batch, 12)
        picked = most_likely_positions(*top_latent_values(encoding, velocity, 10), 12, 0.4)
        everything = predict_point(model, batch, ML, 12, 0.4)
    assert got.shape == (8, 12, 2)
    torch.testing.assert_close(got, picked, atol=1e-5, rtol=0)
    assert not torch.allclose(got, everything, atol=1e-4)  # 15 values left out: another mode


def test_top10_of_a_model_with_fewer_latent_values_is_the_full_mixture() -> None:
    model, batch = _model(5), random_batch(size=4)
    with torch.no_grad():
        got = predict_point(model, batch, TOP10, 12, 0.4)
        everything = predict_point(model, batch, ML, 12, 0.4)
    torch.testing.assert_close(got, everything, atol=1e-5, rtol=0)


def test_ml_top_k_names_the_most_likely_of_the_k_most_probable() -> None:
    """``ml-topK`` for any K: ``predict_point`` decodes the K most probable latent values
    (all of them in a model with fewer); other names are refused with the choices."""
    model, batch = _model(25), random_batch(size=6)
    with torch.no_grad():
        encoding, velocity = decode_every_latent(model, batch, 12)
        for k in (2, 3, 25, 40):
            got = predict_point(model, batch, PointForecast.parse(f"ml-top{k}"), 12, 0.4)
            picked = most_likely_positions(
                *top_latent_values(encoding, velocity, min(k, 25)), 12, 0.4, 4 if k >= 25 else 1
            )
            torch.testing.assert_close(got, picked, atol=1e-5, rtol=0)
    for bad in ("ml-top02", "ml-top0", "ml-topx", "ml-top", "best"):
        with pytest.raises(GrouptronError, match="ml-topK"):
            PointForecast.parse(bad)


def test_names_of_point_forecasts() -> None:
    assert [PointForecast.parse(n).top for n in ("ml-top2", "ml-top10", "ml-top1", "ml")] == [
        2,
        10,
        1,
        None,
    ]
    assert PointForecast.parse("ml-top1") == PointForecast.parse("ml-argmax")  # one latent value
    for bad in ("ml-top007", "ml-top\u00b2", "ml-top\u0661\u0660"):
        assert not is_point_forecast(bad)
        with pytest.raises(GrouptronError, match="ml-topK"):
            PointForecast.parse(bad)
    assert all(is_point_forecast(n) for n in ("ml", "ml-argmax", "mean", "ml-top10", "ml-top3"))
    assert NAMED == ("ml", "ml-argmax", "mean", "ml-top10")
    assert [PointForecast("ml", k).for_model(25).name for k in (1, 2, 10, 25)] == [
        "ml-argmax",
        "ml-top2",
        "ml-top10",
        "ml",
    ]
    assert not any(is_point_forecast(n) for n in ("samples", "best-of-20", "ml-top-3", ""))
