"""ModelConfig.velocity_residual: the decoder predicts changes of the current velocity, so a
decoder that has learnt nothing forecasts constant velocity."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import torch

from grouptron.baselines.constant_velocity import constant_velocity
from grouptron.config import DataConfig, ExperimentConfig
from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.model.batch import make_batch
from grouptron.model.factory import build_model
from grouptron.model.predict import predict_point
from grouptron.point_forecast import PointForecast
from tests.golden.compute import synthetic_tracks
from tests.helpers.models import SMALL


def _silent_decoder(residual: bool) -> tuple[torch.nn.Module, ExperimentConfig]:
    config = ExperimentConfig(
        model_name="trajectron++",
        model=dataclasses.replace(SMALL, velocity_residual=residual),
        data=DataConfig(derivatives="backward"),
    )
    torch.manual_seed(0)
    model = build_model(config).eval()
    with torch.no_grad():  # every output of the head 0: mean change 0, unit spread
        model.gaussian_head.weight.zero_()
        model.gaussian_head.bias.zero_()
    return model, config


def test_a_residual_decoder_that_learnt_nothing_forecasts_constant_velocity() -> None:
    rows = synthetic_tracks()
    data = DataConfig(derivatives="backward")
    scene = build_scene(table_from_values(Path("s"), rows, np.arange(len(rows))), data)
    samples = scene_samples(scene, data, data.history_steps, only_step=8)
    batch = make_batch(samples, np.arange(len(samples)), data)
    expected = constant_velocity(samples.hist_rel_m.astype(np.float64), data.horizon_steps)
    for residual in (True, False):
        model, _ = _silent_decoder(residual)
        with torch.no_grad():
            ml = PointForecast("ml")
            got = predict_point(model, batch, ml, data.horizon_steps, data.dt_s).numpy()
        moving = np.abs(expected).max() > 0.5
        assert moving  # the scene's walkers move, so the two switches differ
        assert np.allclose(got, expected, atol=1e-4) == residual
