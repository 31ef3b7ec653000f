"""The edge encoder's density-robust switches (ModelConfig.edge_aggregation and
edge_count_feature): a mean over the neighbours does not grow with the crowd, the count
feature carries the density, and the reference's sum stays as it was."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch

from grouptron.config import ExperimentConfig, ModelConfig
from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.model.batch import Batch, make_batch
from grouptron.model.factory import build_model
from grouptron.model.predict import encode_prior
from tests.golden.compute import synthetic_tracks
from tests.helpers.models import SMALL


def _config(**switches: object) -> ExperimentConfig:
    model = dataclasses.replace(SMALL, **switches)  # type: ignore[arg-type]
    return ExperimentConfig(model_name="trajectron++", split="eth", model=model)


@pytest.fixture(scope="module")
def scene_batch() -> tuple[Batch, np.ndarray]:
    """The golden scene at step 8 and, per sample and history step, the neighbours observed
    there (counted by hand from the sample set's per-edge masks)."""
    rows = synthetic_tracks()
    config = _config()
    scene = build_scene(table_from_values(Path("s"), rows, np.arange(len(rows))), config.data)
    samples = scene_samples(scene, config.data, 2, only_step=8)
    index = np.arange(len(samples))
    counted = np.zeros(samples.hist_mask.shape)
    for s in index:  # the slow, obvious count
        for e in range(samples.nbr_offsets[s], samples.nbr_offsets[s + 1]):
            counted[s] += samples.nbr_hist_mask[e] & samples.hist_mask[s]
    return make_batch(samples, index, config.data), counted


def _condition(config: ExperimentConfig, batch: Batch) -> torch.Tensor:
    torch.manual_seed(0)
    model = build_model(config).eval()
    with torch.no_grad():
        return model.encode_condition(batch)


def _crowd_doubled(batch: Batch) -> Batch:
    """Every neighbour twice, in the same place: the sum doubles, the mean stays."""
    assert batch.nbr_count is not None
    return dataclasses.replace(
        batch, nbr_sum_st=2 * batch.nbr_sum_st, nbr_count=2 * batch.nbr_count
    )


def test_make_batch_counts_the_neighbours_observed_at_each_step(
    scene_batch: tuple[Batch, np.ndarray],
) -> None:
    batch, counted = scene_batch
    assert batch.nbr_count is not None and batch.nbr_count.shape == batch.hist_mask.shape
    np.testing.assert_array_equal(batch.nbr_count.numpy(), counted)
    assert counted.max() >= 2  # the scene has samples with several neighbours


def test_the_mean_ignores_a_doubled_crowd_and_the_sum_does_not(
    scene_batch: tuple[Batch, np.ndarray],
) -> None:
    batch, _ = scene_batch
    doubled = _crowd_doubled(batch)
    mean = _config(edge_aggregation="mean")
    torch.testing.assert_close(_condition(mean, batch), _condition(mean, doubled))
    for changed in (_config(), _config(edge_aggregation="mean", edge_count_feature=True)):
        assert not torch.allclose(_condition(changed, batch), _condition(changed, doubled))


def test_the_count_feature_widens_the_edge_input_and_needs_counts(
    scene_batch: tuple[Batch, np.ndarray],
) -> None:
    batch, _ = scene_batch
    config = _config(edge_aggregation="mean", edge_count_feature=True)
    model = build_model(config)
    assert model.edge_encoder is not None and model.edge_encoder.input_size == 13
    assert build_model(_config()).edge_encoder.input_size == 12  # type: ignore[union-attr]
    with pytest.raises(GrouptronError, match="nbr_count"):
        model.encode_condition(dataclasses.replace(batch, nbr_count=None))
    # The reference model never reads the counts.
    torch.testing.assert_close(
        _condition(_config(), batch),
        _condition(_config(), dataclasses.replace(batch, nbr_count=None)),
    )


def test_the_edges_ablation_takes_the_counts_away_too(
    scene_batch: tuple[Batch, np.ndarray],
) -> None:
    batch, _ = scene_batch
    config = _config(edge_aggregation="mean", edge_count_feature=True)
    torch.manual_seed(0)
    model = build_model(config).eval()
    alone = dataclasses.replace(
        batch,
        nbr_sum_st=torch.zeros_like(batch.nbr_sum_st),
        nbr_count=torch.zeros_like(batch.nbr_count),  # type: ignore[arg-type]
    )
    with torch.no_grad():
        ablated = encode_prior(model, batch, ("edges",)).p_logits
        expected = encode_prior(model, alone).p_logits
    torch.testing.assert_close(ablated, expected)


def test_edge_aggregation_is_checked() -> None:
    from grouptron.config import config_from_dict

    with pytest.raises(GrouptronError, match="edge_aggregation"):
        config_from_dict(ModelConfig, {"edge_aggregation": "max"})
