"""Golden outputs of four frozen checkpoints on a fixed synthetic scene.

The checkpoints in this folder are copies of shipped ones frozen for the tests (retraining the
shipped models does not move them). ``compute`` runs them through the public prediction paths
(``Predictor`` with every point forecast, with samples and the mixture), one evaluator call
and one training loss on a fixed batch. Regenerate ``forecasts.npz`` only for an intended
change of behaviour:

    python -m tests.golden.compute
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.evaluation.evaluate import score_samples
from grouptron.inference.predictor import Predictor
from grouptron.model import schedules
from grouptron.model.batch import make_batch
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.elbo import elbo_loss
from grouptron.model.factory import groups_for_model
from grouptron.model.noise import draw_training_noise

HERE = Path(__file__).parent
CHECKPOINTS = (
    "grouptron-univ-backward",
    "trajectron++-eth-central",
    "trajectron++-residual-univ-backward",  # the default model
    "grouptron-robust-residual-univ-backward",  # every robust switch and the residual decoder
)
POINT_FORECASTS = ("ml", "ml-argmax", "mean", "ml-top10")
"""The named point forecasts, in the order of the stored scores."""
GOLDEN = HERE / "forecasts.npz"
FORECAST_FRAME = 100
LOSS_ITERATION = 500  # past the annealing centres, so every loss term is active


def synthetic_tracks() -> np.ndarray:
    """(R, 4) ``frame, id, x, y`` of 9 people over 21 steps (0.4 s, 10 frames each): two
    walking groups (one curving), a standing pair, a crossing walker, two late arrivals."""
    rows = []
    for step in range(21):
        t = step * 0.4
        people = {
            1: (0.0 + 1.2 * t, 0.0),
            2: (0.1 + 1.2 * t, 0.7),
            3: (-0.5 + 1.1 * t, 0.3 + 0.02 * t * t),
            4: (12.0 - 1.0 * t, 1.5 + 0.2 * np.sin(t)),
            5: (12.3 - 1.0 * t, 2.1 + 0.2 * np.sin(t)),
            6: (5.0, -1.5),
            7: (5.6, -1.4 + 0.01 * step),
            8: (4.0 + 0.3 * t, -6.0 + 1.3 * t),
        }
        if step >= 6:
            people[9] = (2.0 + 0.9 * (t - 2.4), 3.0 - 0.4 * (t - 2.4))
        if step >= 9:
            people[10] = (8.0 - 1.1 * (t - 3.6), -0.5)
        rows += [(step * 10, ped, x, y) for ped, (x, y) in people.items()]
    return np.asarray(rows, dtype=np.float64)


def forecasts(name: str) -> dict[str, np.ndarray]:
    """Forecasts at ``FORECAST_FRAME``: every point forecast, a seeded sample set and the
    mixture parameters, under the names they were first stored with (``<forecast>/most_likely``
    is the point forecast, ``mixture_means`` ``Forecast.mixture.means`` and so on)."""
    path = HERE / f"{name}.safetensors"
    tracks = synthetic_tracks()
    live = name.endswith("backward")  # a central model reads the recording's next two steps
    out = {}
    for point in POINT_FORECASTS:
        # Full histories only: the forecasts the golden values were first taken of.
        predictor = Predictor.from_checkpoint(path, forecast=point, mixture=True, min_points=8)
        forecast = predictor.predict(tracks, FORECAST_FRAME, num_samples=6, seed=3, live=live)
        out[f"{point}/most_likely"] = forecast.point
        if point == "ml":
            mixture, group = forecast.mixture, forecast.group
            assert forecast.samples is not None and mixture is not None and group is not None
            out["ids"] = forecast.ids.astype(np.float64)
            out["samples"] = forecast.samples
            out["mixture_log_weights"] = np.asarray(mixture.log_weights)
            out["mixture_means"] = np.asarray(mixture.means)
            out["mixture_covariances"] = np.asarray(mixture.covariances)
            out["group"] = group.astype(np.float64)
    return out


def training_loss(name: str) -> np.ndarray:
    """(5,) loss, log-likelihood, KL, mutual information and KL weight of one training step's
    forward pass on every sample of the scene, with fixed rotations and noise."""
    model, config = load_trained_model(HERE / f"{name}.safetensors")
    table = table_from_values(Path("golden"), synthetic_tracks(), np.arange(21 * 10), 10)
    scene = build_scene(table, config.data, name="golden")
    samples = scene_samples(scene, config.data, config.data.min_history_train)
    groups = groups_for_model(samples, config)
    index = np.arange(len(samples))
    angles = np.deg2rad(15.0 * (index % 24))
    batch = make_batch(samples, index, config.data, angles, groups=groups)
    generator_state = torch.get_rng_state()
    torch.manual_seed(11)
    noise = draw_training_noise(len(index), config.model, config.data.horizon_steps)
    model.train()
    # Seeded through the pass too: E_scene's dropout (a robust switch) draws as it runs.
    output = model(
        batch,
        noise,
        logit_clip=schedules.logit_clip(config.loss, LOSS_ITERATION),
    )
    torch.set_rng_state(generator_state)
    kl_weight = schedules.kl_weight(config.loss, LOSS_ITERATION)
    terms = elbo_loss(output, batch, config.loss, kl_weight, dt_s=config.data.dt_s)
    values = (terms.loss, terms.log_likelihood, terms.kl, terms.mutual_info)
    return np.asarray([float(v.detach()) for v in values] + [kl_weight])


def scores(name: str) -> np.ndarray:
    """(4, 2) ADE and FDE (m) of every point forecast on the scene's samples with a full
    history and future: one call of the evaluator."""
    model, config = load_trained_model(HERE / f"{name}.safetensors")
    table = table_from_values(Path("golden"), synthetic_tracks(), np.arange(21 * 10), 10)
    scene = build_scene(table, config.data, name="golden")
    samples = scene_samples(scene, config.data, config.data.history_steps)
    scored = score_samples(
        model, config, samples, POINT_FORECASTS, groups=groups_for_model(samples, config)
    )
    return np.asarray([[float(s.ade.mean()), float(s.fde.mean())] for s in scored])


def compute() -> dict[str, np.ndarray]:
    """Every golden array, keyed ``<checkpoint>/<output>``."""
    golden: dict[str, np.ndarray] = {}
    with torch.inference_mode():
        for name in CHECKPOINTS:
            golden.update({f"{name}/{k}": v for k, v in forecasts(name).items()})
    for name in CHECKPOINTS:
        golden[f"{name}/training_loss"] = training_loss(name)
        golden[f"{name}/scores"] = scores(name)
    return golden


if __name__ == "__main__":
    torch.set_num_threads(1)
    np.savez_compressed(GOLDEN, **compute())
    print(f"wrote {GOLDEN}")
