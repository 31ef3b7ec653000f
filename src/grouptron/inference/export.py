"""The network alone, from standardised inputs to the forecast distribution, for running
outside Python (ONNX). The contract (inputs, outputs, what the caller computes before and
after) is docs/export.md.
"""

from __future__ import annotations

import contextlib
import json
import logging
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import torch
from torch import nn

from grouptron import constants
from grouptron.config import ExperimentConfig
from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.inference.calibration import RegionCalibration, calibration_document
from grouptron.io import refuse_folder, save_atomically
from grouptron.model.batch import Batch, GroupBatch, make_batch
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import cvae_only, groups_for_model, uses_groups
from grouptron.model.forecaster import Forecaster
from grouptron.model.gaussians import (
    covariance_matrices,
    position_covariances,
    positions_from_velocities,
)
from grouptron.model.predict import decode_every_latent, default_point_forecast

EXPORT_FORMATS = constants.EXPORT_FORMATS
BASE_INPUTS = ("hist_st", "hist_mask", "nbr_sum_st", "edge_scale")
COUNT_INPUTS = ("nbr_count",)
GROUP_INPUTS = ("node_st", "node_mask", "node_group", "group_sample", "ego_group")
OUTPUTS = ("log_weights", "position_mean_m", "position_cov_m2")
ONNX_OPSET = 18


class ForecastNetwork(nn.Module):
    """A trained model as a function of plain tensors (B samples, T history steps, Z latent
    values, H future steps; Nn nodes and G groups for Grouptron).

    Inputs: ``hist_st`` (B, T, 6) float32, ``hist_mask`` (B, T) bool, ``nbr_sum_st`` (B, T, 6)
    float32, ``edge_scale`` (B,) float32; Grouptron also ``node_st`` (Nn, T, 6) float32,
    ``node_mask`` (Nn, T) bool, ``node_group`` (Nn,) int64, ``group_sample`` (G,) int64,
    ``ego_group`` (B,) int64; a model with the ``mean`` edge aggregation or the count
    feature also ``nbr_count`` (B, T) float32, last (the fields of
    :class:`~grouptron.model.batch.Batch`).

    Outputs: ``log_weights`` (B, Z) log p(z|x); ``position_mean_m`` (B, Z, H, 2) each latent
    value's mean positions relative to the position at ``t``, metres; ``position_cov_m2``
    (B, Z, H, 2, 2) their covariances.
    """

    def __init__(self, model: TrajectronCVAE, config: ExperimentConfig) -> None:
        super().__init__()
        self.model = model.eval()
        self.config = config
        self.horizon = config.data.horizon_steps
        self.dt_s = config.data.dt_s
        self.uses_groups = uses_groups(config)
        self.uses_count = uses_neighbour_count(config)

    @property
    def input_names(self) -> tuple[str, ...]:
        """The network's input names, in the order :meth:`forward` takes them."""
        return self.names_for(self.config)

    @staticmethod
    def names_for(config: ExperimentConfig) -> tuple[str, ...]:
        """The input names of a network of ``config``: the base ones, then the group ones
        (Grouptron) and ``nbr_count`` where it reads them."""
        names = BASE_INPUTS + (GROUP_INPUTS if uses_groups(config) else ())
        return names + (COUNT_INPUTS if uses_neighbour_count(config) else ())

    def forward(self, *inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(B, Z) log p(z|x), (B, Z, H, 2) mean positions in metres and (B, Z, H, 2, 2) their
        covariances in m^2, from the inputs in the order of :attr:`input_names`."""
        hist_st, hist_mask, nbr_sum_st, edge_scale = inputs[:4]
        groups = GroupBatch(*inputs[4:9]) if self.uses_groups else None
        count = inputs[-1] if self.uses_count else None
        batch = Batch(hist_st, hist_mask, nbr_sum_st, edge_scale, hist_st, hist_st, groups, count)
        encoding, velocity = decode_every_latent(self.model, batch, self.horizon)
        cov = position_covariances(velocity.cov, self.dt_s)  # (B, Z, H, 3)
        return (
            torch.log_softmax(encoding.p_logits, dim=-1),
            positions_from_velocities(velocity.mean, self.dt_s),
            covariance_matrices(cov),
        )


def uses_neighbour_count(config: ExperimentConfig) -> bool:
    """Whether the network reads ``nbr_count`` (the mean edge aggregation or count feature)."""
    return config.model.edge_aggregation != "sum" or config.model.edge_count_feature


def batch_inputs(batch: Batch, config: ExperimentConfig) -> tuple[torch.Tensor, ...]:
    """The network's inputs from a batch, in the order of ``ForecastNetwork.input_names``."""
    inputs: tuple[torch.Tensor, ...] = (
        batch.hist_st,
        batch.hist_mask,
        batch.nbr_sum_st,
        batch.edge_scale,
    )
    if uses_groups(config):
        if batch.groups is None:
            raise GrouptronError("a Grouptron network needs a batch with groups")
        g = batch.groups
        inputs += (g.node_st, g.node_mask, g.node_group, g.group_sample, g.ego_group)
    if uses_neighbour_count(config):
        if batch.nbr_count is None:
            raise GrouptronError("this network needs a batch with nbr_count")
        inputs += (batch.nbr_count,)
    return inputs


def example_batch(config: ExperimentConfig) -> Batch:
    """A small batch to trace the network with: four pairs walking side by side for ten steps
    (several samples, groups and nodes, so that no size is mistaken for a constant)."""
    steps, pairs = 10, 4
    frame = np.repeat(np.arange(steps), 2 * pairs) * config.data.frames_per_step
    person = np.tile(np.arange(2 * pairs), steps)
    heading = person // 2 * (np.pi / 2)  # (R,) pairs walk in four directions
    along = 1.2 * config.data.dt_s * np.repeat(np.arange(steps), 2 * pairs)
    x = 3.0 * (person // 2) + along * np.cos(heading) + 0.6 * (person % 2)
    y = along * np.sin(heading)
    rows = np.column_stack([frame, person, x, y]).astype(np.float64)
    table = table_from_values(Path("example"), rows, np.arange(len(rows)))
    scene = build_scene(table, config.data, name="example")
    samples = scene_samples(scene, config.data, 2, require_future=False, only_step=steps - 1)
    index = np.arange(len(samples))
    return make_batch(samples, index, config.data, groups=groups_for_model(samples, config))


def export_onnx(
    model: Forecaster,
    config: ExperimentConfig,
    out: str | Path,
    calibration: RegionCalibration | None = None,
) -> list[str]:
    """Write the network as ONNX to ``out`` (sample, node and group counts dynamic), with the
    constants a caller needs in its metadata (and a site's region calibration, when given);
    returns the input names."""
    out = Path(out)
    refuse_folder(out)  # before the export, not after it
    try:
        import onnx
        import onnxscript  # noqa: F401  (the exporter needs it; fail here with the hint)
    except ImportError:
        raise GrouptronError(
            "export needs onnx and onnxscript: pip install 'grouptron[export]'"
        ) from None
    network = ForecastNetwork(cvae_only(model, "ONNX export"), config)
    inputs = batch_inputs(example_batch(config), config)
    samples = torch.export.Dim("samples")
    dims: dict[str, dict[int, torch.export.Dim]] = {
        n: {0: samples} for n in BASE_INPUTS + COUNT_INPUTS
    }
    if network.uses_groups:
        nodes, groups = torch.export.Dim("nodes"), torch.export.Dim("groups")
        dims |= {"node_st": {0: nodes}, "node_mask": {0: nodes}, "node_group": {0: nodes}}
        dims |= {"group_sample": {0: groups}, "ego_group": {0: samples}}
    with warnings.catch_warnings(), _quiet_exporter():
        warnings.simplefilter("ignore")
        program = torch.onnx.export(
            network,
            inputs,
            input_names=list(network.input_names),
            output_names=list(OUTPUTS),
            dynamic_shapes=(tuple(dims[n] for n in network.input_names),),  # one *inputs
            opset_version=ONNX_OPSET,
            dynamo=True,
            verbose=False,
        )
    assert program is not None

    def save(path: Path) -> None:
        program.save(str(path))
        exported = onnx.load(str(path))
        metadata = contract_metadata(config)
        if calibration is not None:
            metadata["grouptron.region_calibration"] = json.dumps(calibration_document(calibration))
        for key, value in metadata.items():
            exported.metadata_props.add(key=key, value=value)
        onnx.save(exported, str(path))

    save_atomically(out, save, fsync=True, suffix=".onnx")
    return list(network.input_names)


def contract_metadata(config: ExperimentConfig) -> dict[str, str]:
    """The constants of the input/output contract (docs/export.md), stored in the file."""
    data = config.data
    return {
        "grouptron.model": config.model_name,
        "grouptron.derivatives": data.derivatives,
        "grouptron.backward_start": data.backward_start,
        "grouptron.dt_s": repr(data.dt_s),
        "grouptron.history_steps": str(data.history_steps),
        "grouptron.horizon_steps": str(data.horizon_steps),
        "grouptron.state_scale": json.dumps(list(data.state_scale)),
        "grouptron.perception_radius_m": repr(data.perception_radius_m),
        "grouptron.edge_ramp_weights": json.dumps(list(data.edge_ramp_weights)),
        "grouptron.inputs": json.dumps(list(ForecastNetwork.names_for(config))),
        "grouptron.outputs": json.dumps(list(OUTPUTS)),
        "grouptron.point_forecast": default_point_forecast(config).name,
    }


@contextlib.contextmanager
def _quiet_exporter() -> Iterator[None]:
    """Silence the exporter's progress logging (it prints to the root logger)."""
    loggers = [logging.getLogger(n) for n in ("torch.onnx", "onnxscript")]
    levels = [log.level for log in loggers]
    for log in loggers:
        log.setLevel(logging.ERROR)
    try:
        yield
    finally:
        for log, level in zip(loggers, levels, strict=True):
            log.setLevel(level)


def run_onnx(path: Path, inputs: dict[str, np.ndarray]) -> list[np.ndarray]:
    """Run an exported network with onnxruntime: the outputs in the order of ``OUTPUTS``."""
    try:
        import onnxruntime
    except ImportError:
        raise GrouptronError(
            "running ONNX needs onnxruntime: pip install 'grouptron[export]'"
        ) from None
    session = onnxruntime.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    outputs: list[np.ndarray] = session.run(list(OUTPUTS), inputs)
    return outputs
